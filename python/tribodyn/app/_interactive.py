"""The interactive COF views of the report: Bokeh, embedded with its JavaScript inline (offline).

Why Bokeh: a well-kept (NumFOCUS) BSD library whose core bundle, inlined,
adds about 1.4 MB to ``report.html`` once, whatever the number of views
(plotly's offline bundle adds about 4.6 MB); pan, box zoom, wheel zoom and
hover work without a server or a network. The static PNGs stay for print.

The views are built by BokehJS in the browser, from the windows' numbers
embedded in the page (float64 arrays in base64) and BokehJS's own plotting
API (``bokeh-api.min.js``): Python never imports ``bokeh`` (its import and
its document model cost about 2 s of CPU per command line on a 2-core
machine, issue 38 point 3); the package's JavaScript files are read as they
are installed.
"""

from __future__ import annotations

import base64
import itertools
import json
from dataclasses import dataclass
from importlib.util import find_spec
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

__all__ = ["bokeh_resources", "cof_views"]

#: Most points drawn per series (evenly thinned above; the PNG figures show every window's band).
MAX_POINTS = 20_000

#: The BokehJS bundles the views need, in load order: the core and its plotting API.
_BUNDLES = ("bokeh.min.js", "bokeh-api.min.js")

#: Builds one report's views in the browser: ``tribodynCofViews(element id, data)`` (the data as
#: :func:`_view_data` writes it). Bokeh's plotting API, as ``bokeh.plotting`` would have been used in Python.
_BUILDER = r"""
window.tribodynCofViews = function (id, d) {
  var B = window.Bokeh, P = B.Plotting, tools = "pan,box_zoom,wheel_zoom,reset,save";
  function col(s, n) {
    if (s === null) { var a = new Float64Array(n); a.fill(NaN); return a; }
    var b = atob(s), u = new Uint8Array(b.length);
    for (var k = 0; k < b.length; k++) { u[k] = b.charCodeAt(k); }
    return new Float64Array(u.buffer);
  }
  var n = d.good, g = {};
  ["t", "mu", "lo", "hi", "T", "J", "inst"].forEach(function (k) { g[k] = col(d.cols[k], n); });
  var yr = d.y_range ? new B.Range1d({start: d.y_range[0], end: d.y_range[1]}) : new B.DataRange1d();
  var p = P.figure({height: 360, sizing_mode: "stretch_width", tools: tools, title: d.title, y_range: yr,
                    x_axis_label: "time t (s)", y_axis_label: d.y_label, output_backend: "canvas"});
  p.add_tools(new B.HoverTool({tooltips: [["t (s)", "@t{0.0}"], ["COF", "@mu{0.0000}"],
    ["95 % interval", "@lo{0.0000} to @hi{0.0000}"], ["T (\u00b0C)", "@T{0.0}"], ["J (A/mm\u00b2)", "@J{0.000}"]]}));
  var src = new B.ColumnDataSource({data: g});
  p.scatter({field: "t"}, {field: "mu"}, {source: src, size: 3, alpha: 0.6, color: "#222222", legend_label: d.legend});
  if (d.cols.inst !== null) {
    p.line({field: "t"}, {field: "inst"}, {source: src, color: "#ff7f0e", line_width: 1,
                                           legend_label: "instrument COF per window"});
  }
  var h = d.headline;
  if (h) {
    if (h.low !== null && h.high !== null) {
      p.varea({x: [h.t0, h.t1], y1: [h.low, h.low], y2: [h.high, h.high], fill_color: "#bbbbbb", fill_alpha: 0.5,
               legend_label: "95 % interval of the headline"});
    }
    p.line([h.t0, h.t1], [h.value, h.value], {color: "black", line_width: 2, legend_label: h.label});
  }
  var lg = p.legend;  // above the plot, as the PNG figures have it, so that it hides no point; a click hides a series
  p.center = p.center.filter(function (r) { return r !== lg; });
  lg.orientation = "horizontal";
  lg.location = "top_left";
  lg.click_policy = "hide";
  p.add_layout(lg, "above");
  var plots = [p];
  if (d.failed) {
    var ft = col(d.failed.t, d.failed.why.length);
    var f = P.figure({height: 90, sizing_mode: "stretch_width", x_range: p.x_range, tools: tools,
                      toolbar_location: null, title: d.failed.title});
    f.scatter({field: "t"}, {field: "y"}, {source: new B.ColumnDataSource({data: {t: ft,
      y: new Float64Array(ft.length), why: d.failed.why}}), marker: "dash", angle: Math.PI / 2, size: 10,
      color: "#888888"});
    f.add_tools(new B.HoverTool({tooltips: [["t (s)", "@t{0.0}"], ["reason", "@why"]]}));
    f.yaxis.visible = false;
    plots.push(f);
  }
  var side = [];
  d.side.forEach(function (s) {
    var c = P.figure({height: 300, sizing_mode: "stretch_width", tools: tools, title: s.title,
                      x_axis_label: s.label, y_axis_label: d.y_label, y_range: p.y_range});
    c.scatter({field: s.key}, {field: "mu"}, {source: src, size: 3, alpha: 0.5, color: "#1f77b4"});
    side.push(c);
  });
  if (side.length) { plots.push(new B.Row({children: side, sizing_mode: "stretch_width"})); }
  P.show(new B.Column({children: plots, sizing_mode: "stretch_width"}), "#" + id);
};
"""

#: Element ids of the views written by this process (unique within a report).
_IDS = itertools.count(1)


def _bokeh_js_dir() -> Optional[Path]:
    """The installed bokeh package's JavaScript folder (found without importing bokeh), or None."""
    spec = find_spec("bokeh")
    if spec is None or not spec.submodule_search_locations:
        return None
    js = Path(next(iter(spec.submodule_search_locations))) / "server" / "static" / "js"
    return js if all((js / b).is_file() for b in _BUNDLES) else None


def bokeh_resources() -> str:
    """The ``<script>`` tags of the report's head: BokehJS and its plotting API inline (about 1.4 MB, read from the
    installed bokeh package) and the views' builder; empty when bokeh's JavaScript is not installed (the views
    then say so)."""
    js = _bokeh_js_dir()
    if js is None:
        return ""
    parts = []
    for name in _BUNDLES:
        text = (js / name).read_text(encoding="utf-8").replace("</script", "<\\/script")
        parts.append(f"<script>\n/* BEGIN {name} */\n{text}\n/* END {name} */\n</script>")
    parts.append('<script>\nBokeh.set_log_level("info");\n' + _BUILDER + "</script>")
    return "\n".join(parts)


def _thin(n: int) -> np.ndarray:
    if n <= MAX_POINTS:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, MAX_POINTS).round().astype(np.int64))


@dataclass(frozen=True)
class _Series:
    """What the views plot, per window: time, whether it is shown as a point (``ok``), the COF with its interval,
    T and J; with the points' name in the legend and the COF axis's label. ``gated``: ``ok`` is the quality gate's
    verdict (a dynamic headline); else it says only which windows have the COF shown (the gate plays no part)."""

    t: np.ndarray
    ok: np.ndarray
    mu: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    temp: np.ndarray
    cur: np.ndarray
    what: str
    y_label: str
    instrument: np.ndarray  # the instrument's COF per window beside a classical one (NaN where none)
    gated: bool = True


def _series(results: Any) -> _Series:
    """The headline's COF per window: the dynamic ``mu_r`` of the gated windows, or the classical COF of each
    window (with the instrument's beside it; the instrument's alone in a COF-only export) when the headline is
    the classical, per-stroke or instrument COF."""
    table = results.table
    t = np.asarray(table["time"], dtype=float)
    head = getattr(results, "headline", None)
    dynamic = head is None or head.method == "dynamic"
    inst = np.asarray(table.get("mu_instrument", np.full(t.size, np.nan)), dtype=float)
    if dynamic:
        ok = np.asarray(table["ok"], dtype=bool)
        mu = np.asarray(table["mu_r"], dtype=float)
        lo = np.asarray(table.get("mu_r_low", np.full(t.size, np.nan)), dtype=float)
        hi = np.asarray(table.get("mu_r_high", np.full(t.size, np.nan)), dtype=float)
        what, y_label = "gated windows", "COF mu_r"
    else:  # the headline is the classical, per-stroke or instrument COF (docs/method.md 6e): no gate
        mu = np.asarray(table.get("mu_classical", np.full(t.size, np.nan)), dtype=float)
        what, y_label = "classical COF per window", "COF"
        if not np.isfinite(mu).any() and np.isfinite(inst).any():  # a COF-only export: the instrument's own
            mu, inst, what = inst, np.full(t.size, np.nan), "instrument COF per window"
        ok = np.isfinite(mu)
        lo = hi = np.full(t.size, np.nan)
    temp = np.asarray(table.get("T", np.full(t.size, np.nan)), dtype=float)
    cur = np.asarray(table.get("J", np.full(t.size, np.nan)), dtype=float)
    return _Series(t, ok, mu, lo, hi, temp, cur, what, y_label, inst if not dynamic else np.full(t.size, np.nan),
                   gated=dynamic)  # fmt: skip


def _b64(values: np.ndarray) -> Optional[str]:
    """Little-endian float64 values in base64 (a ``Float64Array`` in the page), None when none is finite."""
    a = np.ascontiguousarray(values, dtype="<f8")
    return base64.b64encode(a.tobytes()).decode("ascii") if np.isfinite(a).any() else None


def _headline_band(results: Any, t: np.ndarray) -> Optional[Dict[str, Any]]:
    """A classical, per-stroke or instrument headline as the view draws it (a line over the windows' times, its
    95 % interval as a band), as the COF-against-time figure does; None for a dynamic headline or none."""
    head = getattr(results, "headline", None)
    if head is None or head.method == "dynamic" or not t.size or not np.isfinite(head.value):
        return None
    low, high = (float(v) if v is not None and np.isfinite(v) else None for v in (head.low, head.high))
    return {"t0": float(t.min()), "t1": float(t.max()), "value": float(head.value), "low": low, "high": high,
            "label": f"headline: {head.method} COF {head.value:.4g} ({head.statistic})"}  # fmt: skip


def _y_range(mu: np.ndarray) -> Optional[List[float]]:
    """The COF axis fitted to the points shown (0.5-99.5 % with a margin), None without points."""
    mu = mu[np.isfinite(mu)]
    if not mu.size:
        return None
    q0, q1 = np.percentile(mu, [0.5, 99.5])
    pad = 0.1 * max(q1 - q0, 1e-3)
    return [float(min(0.0, q0 - pad) if q0 < 0 else max(0.0, q0 - 3 * pad)), float(q1 + pad)]


def _view_data(results: Any, name: str) -> Dict[str, Any]:
    """What the page's builder draws: the shown windows' columns, the failed windows, the side views."""
    s = _series(results)
    good = np.flatnonzero(s.ok & np.isfinite(s.mu) & np.isfinite(s.t))
    good = good[_thin(good.size)]
    bad = np.flatnonzero(~s.ok & np.isfinite(s.t))
    bad = bad[_thin(bad.size)]
    cols = {"t": s.t, "mu": s.mu, "lo": s.lo, "hi": s.hi, "T": s.temp, "J": s.cur, "inst": s.instrument}
    head = _headline_band(results, s.t[good])
    shown = [s.mu[good], s.instrument[good]] + ([np.array([head["low"], head["high"]], dtype=float)] if head else [])
    data: Dict[str, Any] = {
        "title": f"{name}: COF against time (zoom, pan, hover)",
        "y_label": s.y_label,
        "legend": f"{s.what} ({int(s.ok.sum())}{'' if s.gated or s.ok.all() else f' of {s.ok.size} windows'})",
        "good": int(good.size),
        "cols": {k: _b64(v[good]) for k, v in cols.items()},
        "y_range": _y_range(np.concatenate(shown)),
        "headline": head,
        "failed": None,
        "side": [
            {"key": key, "label": label, "title": f"COF against {label.split(' (')[0]}"}
            for key, values, label in (("T", s.temp, "temperature T (°C)"), ("J", s.cur, "current density J (A/mm²)"))
            if np.isfinite(values[good]).any()
        ],
    }
    # the row of failed windows is the quality gate's: a classical, per-stroke or instrument headline has none (the
    # windows without that COF are gaps, counted in the legend, as in the PNG figure)
    if bad.size and s.gated:
        data["failed"] = {
            "t": _b64(s.t[bad]),
            "why": [str(r) for r in np.asarray(results.table["reasons"])[bad]],
            "title": f"windows that failed the quality gate ({int((~s.ok).sum())}); hover for the reason",
        }
    return data


def cof_views(results: Any, name: str) -> Tuple[str, str]:
    """(script, div) of the zoomable COF-against-time view (and against T and J when they have data).

    Gated windows as points with hover (time, COF, interval, T, J), failed
    windows as grey ticks in their own row below with their reason; for a
    classical, per-stroke or instrument headline the windows with that COF,
    the headline and its interval, and no row of failed windows (the dynamic
    gate plays no part in that COF). The page's
    head must hold :func:`bokeh_resources`; without bokeh's JavaScript the
    div says so.
    """
    view_id = f"tribodyn-view-{next(_IDS)}"
    # "<" escaped: a file name or reason can never end the script element
    payload = json.dumps(_view_data(results, name), allow_nan=False).replace("<", "\\u003c")
    script = (f"<script>(function () {{ var d = {payload}, id = {json.dumps(view_id)}; if (!window.tribodynCofViews) "
              "return; try { window.tribodynCofViews(id, d); } catch (e) { console.error(e); "
              "document.getElementById(id).textContent = 'The interactive view could not be drawn: ' + e; } "
              "})();</script>")  # fmt: skip
    div = (f'<div id="{view_id}" class="tribodyn-view"><noscript>The interactive view needs JavaScript.</noscript>'
           "</div>")  # fmt: skip
    if _bokeh_js_dir() is None:
        div = f'<div id="{view_id}"><p class="note">Not drawn: bokeh\'s JavaScript is not installed.</p></div>'
    return script, div
