"""The interactive COF views of the report: Bokeh, embedded with its JavaScript inline (offline).

Why Bokeh: a well-kept (NumFOCUS) BSD library whose core bundle, inlined,
adds about 1.3 MB to ``report.html`` once, whatever the number of views
(plotly's offline bundle adds about 4.6 MB); pan, box zoom, wheel zoom and
hover work without a server or a network. The static PNGs stay for print.
"""

from __future__ import annotations

from typing import Any, List, Sequence, Tuple

import numpy as np

__all__ = ["bokeh_resources", "cof_views"]

#: Most points drawn per series (evenly thinned above; the PNG figures show every window's band).
MAX_POINTS = 20_000


def bokeh_resources() -> str:
    """The ``<script>`` holding Bokeh's core JavaScript, inline (about 1.3 MB)."""
    from bokeh.resources import Resources

    return str(Resources(mode="inline", components=["bokeh"]).render_js())


def _thin(n: int) -> np.ndarray:
    if n <= MAX_POINTS:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, MAX_POINTS).round().astype(np.int64))


def cof_views(results: Any, name: str) -> Tuple[str, str]:
    """(script, div) of the zoomable COF-against-time view (and against T and J when they have data).

    Gated windows as points with hover (time, COF, interval, T, J), failed
    windows as grey ticks in their own row below with their reason.
    """
    from bokeh.embed import components
    from bokeh.layouts import column, row
    from bokeh.models import ColumnDataSource, HoverTool, Range1d
    from bokeh.plotting import figure

    table = results.table
    t = np.asarray(table["time"], dtype=float)
    head = getattr(results, "headline", None)
    dynamic = head is None or head.method == "dynamic"
    if dynamic:
        ok = np.asarray(table["ok"], dtype=bool)
        mu = np.asarray(table["mu_r"], dtype=float)
        lo = np.asarray(table.get("mu_r_low", np.full(t.size, np.nan)), dtype=float)
        hi = np.asarray(table.get("mu_r_high", np.full(t.size, np.nan)), dtype=float)
        what, y_label = "gated windows", "COF mu_r"
    else:  # the headline is the classical or per-stroke COF (docs/method.md 6e): the dynamic gate plays no part
        mu = np.asarray(table.get("mu_classical", np.full(t.size, np.nan)), dtype=float)
        ok = np.isfinite(mu)
        lo = hi = np.full(t.size, np.nan)
        what, y_label = "classical COF per window", "classical COF"
    temp = np.asarray(table.get("T", np.full(t.size, np.nan)), dtype=float)
    cur = np.asarray(table.get("J", np.full(t.size, np.nan)), dtype=float)
    good = np.flatnonzero(ok & np.isfinite(mu) & np.isfinite(t))
    good = good[_thin(good.size)]
    bad = np.flatnonzero(~ok & np.isfinite(t))
    bad = bad[_thin(bad.size)]

    def clean(a: np.ndarray) -> List[Any]:
        return [None if not np.isfinite(x) else float(x) for x in a]

    src = ColumnDataSource(
        dict(t=t[good], mu=mu[good], lo=clean(lo[good]), hi=clean(hi[good]), T=clean(temp[good]), J=clean(cur[good]))
    )
    tools = "pan,box_zoom,wheel_zoom,reset,save"
    hover = HoverTool(
        tooltips=[
            ("t (s)", "@t{0.0}"),
            ("COF", "@mu{0.0000}"),
            ("95 % interval", "@lo{0.0000} to @hi{0.0000}"),
            ("T (°C)", "@T{0.0}"),
            ("J (A/mm²)", "@J{0.000}"),
        ]
    )
    p = figure(
        height=320,
        sizing_mode="stretch_width",
        tools=tools,
        title=f"{name}: COF against time (zoom, pan, hover)",
        x_axis_label="time t (s)",
        y_axis_label=y_label,
        output_backend="canvas",
    )
    p.add_tools(hover)
    p.scatter("t", "mu", source=src, size=3, alpha=0.6, color="#222222", legend_label=f"{what} ({int(ok.sum())})")
    if good.size:
        v = mu[good]
        q0, q1 = np.percentile(v, [0.5, 99.5])
        pad = 0.1 * max(q1 - q0, 1e-3)
        p.y_range = Range1d(min(0.0, q0 - pad) if q0 < 0 else max(0.0, q0 - 3 * pad), q1 + pad)
    p.legend.location = "top_left"
    plots: List[Any] = [p]
    if bad.size:
        reasons = [str(r) for r in np.asarray(table["reasons"])[bad]]
        fsrc = ColumnDataSource(dict(t=t[bad], y=np.zeros(bad.size), why=reasons))
        f = figure(
            height=90,
            sizing_mode="stretch_width",
            x_range=p.x_range,
            tools=tools,
            toolbar_location=None,
            title=f"windows that failed the quality gate ({int((~ok).sum())}); hover for the reason",
        )
        f.scatter("t", "y", source=fsrc, marker="dash", angle=np.pi / 2, size=10, color="#888888")
        f.add_tools(HoverTool(tooltips=[("t (s)", "@t{0.0}"), ("reason", "@why")]))
        f.yaxis.visible = False
        plots.append(f)
    side = []
    for values, label in ((temp, "temperature T (°C)"), (cur, "current density J (A/mm²)")):
        if np.isfinite(values[good]).any():
            c = figure(
                height=300,
                sizing_mode="stretch_width",
                tools=tools,
                title=f"COF against {label.split(' (')[0]}",
                x_axis_label=label,
                y_axis_label=y_label,
                y_range=p.y_range,
            )
            c.scatter(values[good], mu[good], size=3, alpha=0.5, color="#1f77b4")
            side.append(c)
    if side:
        plots.append(row(*side, sizing_mode="stretch_width"))
    script, div = components(column(*plots, sizing_mode="stretch_width"))
    return str(script), str(div)


def sizes(parts: Sequence[str]) -> int:
    return sum(len(p) for p in parts)
