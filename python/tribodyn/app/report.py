"""A self-contained HTML report of an analysis (docs/method.md sections 4-7).

:func:`write_report` writes ONE ``report.html``: inline CSS, every figure
embedded as a base64 PNG, no script and no network reference, so the file
can be mailed or archived on its own. It holds the summary (COF statistics,
optimum ranges), the measurement quality (gate pass fraction, failure
reasons), the parameters, every figure with its caption and optional tables.
The write is atomic: the figures are rendered in memory first, the page goes
to a temporary file in the target's directory and is renamed over the target
(``os.replace``) only when complete; on any error nothing is left behind.

:func:`build_report_figures` makes the paper's figures for a
:class:`~tribodyn.Results` (plus an optional one-window example for Figs.
2-9), :func:`build_report_summary` and :func:`quality_from_results` the
summary and quality dicts, and :func:`write_results_report` chains them.
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
import math
import numbers
import os
from typing import TYPE_CHECKING, Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from ..options import OPTIONS
from . import _labels
from .figure_registry import build_named_figures
from .figure_registry import range_or_none as _range_or_none

if TYPE_CHECKING:  # Matplotlib is imported where a figure is drawn: a report of PNG bytes needs none of it
    from matplotlib.figure import Figure

__all__ = [
    "write_report",
    "verdict_lines",
    "windows_table_html",
    "inputs_table_html",
    "PARAM_UNITS",
    "build_report_figures",
    "build_named_figures",
    "build_report_summary",
    "quality_from_results",
    "write_results_report",
]

FigureList = Union[Mapping[str, Union["Figure", bytes]], Sequence[Tuple[str, Union["Figure", bytes]]]]
#: The first bytes of every PNG file.
_PNG = b"\x89PNG\r\n\x1a\n"

#: Resolution of the embedded PNGs (dots per inch).
REPORT_DPI = 110
#: Rows of a table shown in the report (the rest is summarised in a note).
MAX_TABLE_ROWS = 1000

#: Keys of ``Results.summary()`` that belong to the quality section.
_QUALITY_KEYS = ("windows", "gated", "gate_pass_fraction", "gate_failures", "orientation")

_CSS = """
body { font-family: -apple-system, "Segoe UI", Helvetica, Arial, sans-serif; margin: 2em auto;
       max-width: 1100px; padding: 0 1em; color: #222; line-height: 1.45; }
h1 { border-bottom: 2px solid #444; padding-bottom: .2em; }
h2 { margin-top: 2em; border-bottom: 1px solid #bbb; padding-bottom: .15em; }
h3 { margin-bottom: .3em; }
.meta { color: #666; font-size: .9em; }
table { border-collapse: collapse; margin: .5em 0 1em; font-size: .9em; }
th, td { border: 1px solid #ccc; padding: .25em .6em; text-align: right; vertical-align: top; }
th { background: #f0f0f0; }
td.key, th.key { text-align: left; font-family: monospace; }
td.text { text-align: left; }
.scroll { max-height: 32em; overflow: auto; border: 1px solid #ddd; margin-bottom: 1em; }
.scroll table { margin: 0; }
figure { margin: 1.5em 0; text-align: center; }
figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { font-size: .92em; color: #333; margin-top: .4em; text-align: left; }
.note { color: #666; font-style: italic; }
.bad { color: #a00; }
.verdict { border: 2px solid #2a6; background: #f3fbf5; padding: .6em 1em; margin: 1em 0; }
.verdict li { margin: .2em 0; }
.verdict .headline { font-size: 1.15em; font-weight: bold; }
tr.failed td { background: #fff3f3; }
.bk-root, .bk { margin: 0 auto; }
"""

#: Units of the entries of ``Results.params`` recorded under names that are no option's (``Plan.params``,
#: ``plan.RECORDED``, and what finishing adds), and the words a count is shown with.
_OTHER_PARAM_UNITS: Dict[str, str] = {
    "window_samples": "samples",
    "hop_samples": "samples",
    "iv_lag_samples": "samples",
    "iv_lag_pooled": "samples",
    "chunk_samples": "samples",
    "temperature_log_points": "readings",
    "skew_median": "samples",
    "noise_z_std": "N",
    "n_bins": "bins",
    "n_lamellas": "lamellas",
    "threads": "threads",
    "gate": "|C_yz(0)| or ci",
    "max_rel_ci": "1",
}
#: Unit of each parameter of ``Results.params`` (shown next to its value; "" for none): each option's declared
#: unit (:data:`tribodyn.options.OPTIONS`), then the entries above.
PARAM_UNITS: Dict[str, str] = {**{o.name: o.unit for o in OPTIONS if o.unit}, **_OTHER_PARAM_UNITS}


def unit_text(unit: str) -> str:
    """'degC' -> '°C', 'A/mm^2' -> 'A/mm²', dimensionless and labels -> '' (:func:`tribodyn.app._labels.unit_text`)."""
    return _labels.unit_text(unit)


class HeadlineLine(str):
    """A verdict line that is a recording's headline (docs/method.md 6e): the report sets it in bold.

    ``budget_html``: its uncertainty budget's table (docs/method.md 6i), set under it; "" without one.
    """

    budget_html: str = ""


def _verdict_item(line: str) -> str:
    """A verdict line as HTML: a recording's headline (:class:`HeadlineLine`) in bold, its budget under it."""
    text = html.escape(line)
    return f"<b>{text}</b>{getattr(line, 'budget_html', '')}" if isinstance(line, HeadlineLine) else text


def budget_table_html(unc: Mapping[str, Any]) -> str:
    """The headline's uncertainty budget (``summary()["headline"]["uncertainty"]``; docs/method.md 6i) as HTML."""

    def num(v: Any, fmt: str = ".3g") -> str:
        return "" if v is None else format(v, fmt)

    rows = []
    for r in unc.get("budget") or ():
        unit = unit_text(str(r.get("unit") or ""))
        share = "" if r.get("share") is None else f"{100 * r['share']:.1f} %"
        rows.append(
            f"<tr><td class='key'>{html.escape(str(r['source']))}</td><td>{num(r.get('value'), '.4g')}"
            f"{' ' + html.escape(unit) if unit else ''}</td><td>{html.escape(str(r.get('distribution')))}</td>"
            f"<td>{num(r.get('dof'), '.3g') or '&infin;'}</td><td>{num(r.get('sensitivity'), '.4g')}</td>"
            f"<td>{num(r.get('contribution'), '.3g')}</td><td>{share}</td></tr>"
        )
    gum = unc.get("gum") or {}
    k = unc.get("k")
    note = (
        f"u<sub>c</sub> = {num(unc.get('u_c'), '.3g')}, 95 % coverage interval {num(unc.get('low'), '.4g')} to "
        f"{num(unc.get('high'), '.4g')} (Monte Carlo, JCGM 101, {unc.get('draws')} draws, seed {unc.get('seed')}"
        + (f"; k = {k:.2f}" if k is not None else "; asymmetric: quoted by its ends")
        + f"). GUM's law of propagation: u<sub>c</sub> = {num(gum.get('u_c'), '.3g')}, k = {num(gum.get('k'), '.3f')}. "
        f"The instrument's part, u = {num(unc.get('instrument_u'), '.3g')}, is shared by every test on this "
        "instrument: it does not shrink with their number."
    )
    if unc.get("instrument"):
        note = f"Instrument: {html.escape(str(unc['instrument']))}. " + note
    if unc.get("correction"):
        note += f" Corrected for the known misalignment: {unc['correction']:+.4g}."
    for n in unc.get("notes") or ():
        note += " " + html.escape(str(n)) + "."
    head = (
        "<tr><th class='key'>source</th><th>standard uncertainty</th><th>distribution</th><th>dof</th>"
        "<th>sensitivity</th><th>contribution (COF)</th><th>share</th></tr>"
    )
    return f'<table class="budget">{head}{"".join(rows)}</table><p class="note">{note}</p>'


def verdict_lines(name: str, summary: Mapping[str, Any], params: Mapping[str, Any],
                  ranges: Optional[Mapping[str, Any]] = None) -> List[str]:  # fmt: skip
    """The verdict of one recording in words and numbers, headline first (docs/method.md 3d, 5, 7).

    1. the headline (``summary["headline"]``, :class:`tribodyn.Headline`:
    the COF chosen by the verdict, its 95 % interval and how it is
    computed); 2. the verdict in words; 3. the optimum
    ranges with their intervals and verdicts; 4. the quality: gated
    fraction and the main failure reasons; 5. how many reader warnings.
    """
    from ..results import verdict_text

    lines: List[str] = []
    verdict = verdict_text(summary.get("verdict"))
    head = summary.get("headline") or {}
    mu = summary.get("mu_r") or {}
    method = " (the paper's method)" if params.get("method") == "paper" else ""
    lines.append(HeadlineLine(f"{name}: {head.get('text', 'no headline')}{method}"))
    if head.get("method") == "dynamic" and mu.get("n"):
        lines[0] = HeadlineLine(
            f"{lines[0]} 90 % of the gated windows lie between {mu['p05']:.4f} and {mu['p95']:.4f}."
        )
    if head.get("uncertainty"):  # the budget under the headline (docs/method.md 6i)
        first = HeadlineLine(lines[0])
        first.budget_html = budget_table_html(head["uncertainty"])
        lines[0] = first
    if verdict:
        lines.append(f"{name}: {_labels.units_in_text(verdict)}")
    for by, rng in (ranges or {}).items():
        if not rng:
            continue
        unit = unit_text(str(rng.get("unit", "")))
        what = str(by).replace("_", " ")
        if rng.get("optimum"):
            lo, hi = rng["optimum"]
            ci = rng.get("optimum_ci") or (None, None)
            ivs = [_labels.fmt_interval(c) for c in ci]
            text = f"{name}: optimum {what} {_labels.fmt_range(lo, hi, unit, ci=rng.get('optimum_ci'))}"
            if all(ivs):
                text += f" (95 % intervals of the edges {ivs[0]} and {ivs[1]})"
            if rng.get("mu_min") is not None:
                text += f", minimum COF {rng['mu_min']:.4f}"
        else:
            text = f"{name}: no optimum {what} found"
        if rng.get("verdict"):
            text += f"; verdict: {rng['verdict']}"
        lines.append(text + ".")
    frac = summary.get("gate_pass_fraction")
    if isinstance(frac, (int, float)) and math.isfinite(frac):
        fails = summary.get("gate_failures") or {}
        top = sorted(fails.items(), key=lambda kv: -kv[1])[:3]
        why = "; main reasons: " + ", ".join(f"{k} ({v} windows)" for k, v in top) if top else ""
        lines.append(
            f"{name}: quality: {summary.get('gated')} of {summary.get('windows')} windows ({100 * frac:.1f} %) "
            f"passed the quality gate{why}."
        )
    warns = summary.get("warnings") or ()
    if warns:
        lines.append(f"{name}: {len(warns)} reader warning(s), listed under Warnings below.")
    return lines


def inputs_table_html(inputs: Sequence[Mapping[str, Any]]) -> str:
    """Inputs: file, size, SHA-256, format, channel map with units, logs used."""
    if not inputs:
        return '<p class="note">No input files (simulated data).</p>'
    head = (
        '<tr><th class="key">file</th><th>size (bytes)</th><th>SHA-256</th><th>channel map (role = channel, unit)</th>'
        "<th>logs</th></tr>"
    )
    rows = []
    for i in inputs:
        cmap = i.get("channels") or {}
        cm = ", ".join(f"{r} = {c}" for r, c in cmap.items()) if isinstance(cmap, Mapping) else str(cmap)
        logs = ", ".join(str(x) for x in i.get("logs") or ()) or "none"
        rows.append(
            f'<tr><td class="key">{html.escape(str(i.get("file")))}</td>{_cell(i.get("bytes"))}'
            f'<td class="key">{html.escape(str(i.get("sha256", "")))}</td><td class="text">{html.escape(cm)}</td>'
            f'<td class="text">{html.escape(logs)}</td></tr>'
        )
    return "<table>" + head + "".join(rows) + "</table>"


def windows_table_html(results: Any, csv_name: Optional[str] = None, *, edge_rows: int = 5,
                       max_failures: int = 500) -> str:  # fmt: skip
    """The first and last ``edge_rows`` windows and every failed one (up to ``max_failures``), units in the
    header, with a link to the full CSV."""
    from ..columns import UNITS

    table = results.table
    n = len(table["time"])
    ok = np.asarray(table["ok"], dtype=bool)
    keep_cols = [c for c in ("time", "mu_r", "mu_r_low", "mu_r_high", "mu_ols", "c_yz", "T", "branch", "J",
                             "mu_classical", "mu_instrument", "ok", "reasons") if c in table]  # fmt: skip
    cols = [
        c
        for c in keep_cols
        if not (np.asarray(table[c]).dtype.kind == "f" and not np.isfinite(np.asarray(table[c])).any())
    ]
    failed = np.flatnonzero(~ok)
    rows = sorted(set(range(min(edge_rows, n))) | set(range(max(0, n - edge_rows), n)) | set(failed[:max_failures]))
    head = (
        "<tr><th>window</th>"
        + "".join(
            "<th>"
            + html.escape(c + (f" ({unit_text(UNITS.get(c, ''))})" if unit_text(UNITS.get(c, "")) else ""))
            + "</th>"
            for c in cols
        )
        + "</tr>"
    )
    body = []
    prev = -1
    for k in rows:
        if k != prev + 1:
            body.append(
                f'<tr><td colspan="{len(cols) + 1}" class="text note">… windows {prev + 1} to {k - 1} …</td></tr>'
            )
        cls = ' class="failed"' if not ok[k] else ""
        cells = "".join(_cell(np.asarray(table[c])[k].item()) for c in cols)
        body.append(f"<tr{cls}>{_cell(int(k))}{cells}</tr>")
        prev = k
    if prev < n - 1:
        body.append(f'<tr><td colspan="{len(cols) + 1}" class="text note">… windows {prev + 1} to {n - 1} …</td></tr>')
    link = (
        f' All {n} windows and every column: <a href="{html.escape(csv_name)}">{html.escape(csv_name)}</a>.'
        if csv_name
        else ""
    )
    more = f" (the first {max_failures} of {failed.size} failures shown)" if failed.size > max_failures else ""
    note = f'<p class="note">First and last {edge_rows} windows and every window that failed the gate{more}.{link}</p>'
    return note + f'<div class="scroll"><table>{head}{"".join(body)}</table></div>'


def _params_with_units(params: Mapping[str, Any]) -> Dict[str, Any]:
    """Parameter rows 'name (unit)' -> value; nested dicts (one per recording) keep their own rows."""
    out: Dict[str, Any] = {}
    for k, v in params.items():
        if isinstance(v, Mapping):
            out[k] = _params_with_units(v)
            continue
        u = unit_text(PARAM_UNITS.get(str(k), ""))
        out[f"{k} ({u})" if u else str(k)] = v
    return out


# --------------------------------------------------------------------------
# formatting
# --------------------------------------------------------------------------
def _fmt(v: Any) -> str:
    """A value as text: floats to 4 significant digits (6 from 10^4 up), NaN as 'NaN'."""
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if v is None or isinstance(v, numbers.Real):
        return _labels.fmt_value(v)
    if isinstance(v, (list, tuple, np.ndarray)):
        items = list(np.asarray(v).ravel()) if isinstance(v, np.ndarray) else list(v)
        if len(items) > 12:
            return "[" + ", ".join(_fmt(x) for x in items[:12]) + f", … ({len(items)} items)]"
        return "[" + ", ".join(_fmt(x) for x in items) + "]"
    return str(v)


def _esc(v: Any) -> str:
    return html.escape(_fmt(v), quote=True)


def _is_scalar(v: Any) -> bool:
    return v is None or isinstance(v, (str, bytes, numbers.Number, np.generic))


def _is_stats(v: Any) -> bool:
    """A statistics dict like ``Results.summary()["mu_r"]`` (n, mean, median, ...)."""
    return (
        isinstance(v, Mapping)
        and bool(v)
        and ("n" in v or "mean" in v or "median" in v)
        and all(_is_scalar(x) for k, x in v.items() if k != "ci")
    )


def _with_intervals(stats: Mapping[str, Any]) -> Dict[str, Any]:
    """A statistics dict with its bootstrap intervals ("ci") as "median 95 % CI" and "mean 95 % CI" cells."""
    out = {k: x for k, x in stats.items() if k != "ci"}
    for name in ("median", "mean"):
        lo_hi = (stats.get("ci") or {}).get(name)
        if lo_hi is not None:
            out[f"{name} 95 % CI"] = f"[{_fmt(lo_hi[0])}, {_fmt(lo_hi[1])}]"
    return out


def _cell(v: Any) -> str:
    cls = "" if isinstance(v, (numbers.Number, np.generic)) and not isinstance(v, (bool, np.bool_)) else ' class="text"'
    return f"<td{cls}>{_esc(v)}</td>"


def _kv_table(d: Mapping[str, Any]) -> str:
    rows = []
    for k, v in d.items():
        if isinstance(v, Mapping):
            inner = _render_value(v)
            rows.append(f'<tr><td class="key">{html.escape(str(k))}</td><td class="text">{inner}</td></tr>')
        else:
            rows.append(f'<tr><td class="key">{html.escape(str(k))}</td>{_cell(v)}</tr>')
    return "<table>\n" + "\n".join(rows) + "\n</table>"


def _matrix_table(d: Mapping[str, Mapping[str, Any]]) -> str:
    """Rows = keys of ``d``, columns = union of the inner keys (in first-seen order)."""
    cols: List[str] = []
    for inner in d.values():
        for c in inner:
            if c not in cols:
                cols.append(c)
    head = '<tr><th class="key"></th>' + "".join(f"<th>{html.escape(str(c))}</th>" for c in cols) + "</tr>"
    rows = []
    for k, inner in d.items():
        cells = "".join(_cell(inner.get(c)) if c in inner else "<td></td>" for c in cols)
        rows.append(f'<tr><td class="key">{html.escape(str(k))}</td>{cells}</tr>')
    return "<table>\n" + head + "\n" + "\n".join(rows) + "\n</table>"


def _render_value(v: Any) -> str:
    """Nested dicts: a dict of scalar-valued dicts is a matrix, otherwise key/value rows."""
    if isinstance(v, Mapping):
        if not v:
            return '<span class="note">none</span>'
        if all(
            isinstance(x, Mapping) and x and all(_is_scalar(y) or isinstance(y, (list, tuple)) for y in x.values())
            for x in v.values()
        ):
            return _matrix_table(v)
        return _kv_table(v)
    return _esc(v)


def _columns_table(table: Any, max_rows: int) -> str:
    """A column dict (like ``Results.table``), a list of row dicts, or anything with ``.table``."""
    table = getattr(table, "table", table)
    if isinstance(table, Mapping):
        cols = list(table)
        arrays = [np.asarray(table[c]) for c in cols]
        n = max((a.shape[0] if a.ndim else 1) for a in arrays) if arrays else 0
        rows = ([a[i] if a.ndim else a for a in arrays] for i in range(min(n, max_rows)))
    else:
        records = list(table)
        cols = []
        for rec in records:
            for c in rec:
                if c not in cols:
                    cols.append(c)
        n = len(records)
        rows = ([rec.get(c) for c in cols] for rec in records[:max_rows])
    head = "<tr>" + "".join(f"<th>{html.escape(str(c))}</th>" for c in cols) + "</tr>"
    body = "\n".join(
        "<tr>" + "".join(_cell(x.item() if isinstance(x, np.generic) else x) for x in row) + "</tr>" for row in rows
    )
    note = f'<p class="note">First {max_rows} of {n} rows.</p>' if n > max_rows else ""
    return f'<div class="scroll"><table>\n{head}\n{body}\n</table></div>{note}'


def _png_base64(fig: Union[Figure, bytes], dpi: int) -> str:
    """A Figure rendered at ``dpi``, or PNG bytes rendered before (the files' own), as base64."""
    if isinstance(fig, (bytes, bytearray)):
        return base64.b64encode(bytes(fig)).decode("ascii")
    from .figures import png_bytes  # (a Figure given: Matplotlib is imported)

    return base64.b64encode(png_bytes(fig, dpi=dpi)).decode("ascii")


def _figure_list(figures: Optional[FigureList]) -> List[Tuple[str, Union[Figure, bytes]]]:
    if figures is None:
        return []
    items = list(figures.items()) if isinstance(figures, Mapping) else list(figures)
    out = []
    for item in items:
        if not (isinstance(item, (tuple, list)) and len(item) == 2):
            raise TypeError("figures must be a dict caption -> Figure or a list of (caption, Figure) pairs")
        caption, fig = item
        if not (hasattr(fig, "savefig") or (isinstance(fig, (bytes, bytearray)) and bytes(fig[:8]) == _PNG)):
            raise TypeError(f"figure {caption!r} is not a matplotlib Figure or PNG bytes (got {type(fig).__name__})")
        out.append((str(caption), fig))
    return out


def _quality_section(quality: Mapping[str, Any]) -> str:
    q = dict(quality)
    parts = []
    frac = q.pop("gate_pass_fraction", None)
    head: Dict[str, Any] = {}
    for k in ("windows", "gated"):
        if k in q:
            head[k] = q.pop(k)
    if frac is not None:
        head["gate_pass_fraction"] = frac
    failures = q.pop("gate_failures", None)
    head.update({k: v for k, v in q.items() if not isinstance(v, Mapping)})
    nested = {k: v for k, v in q.items() if isinstance(v, Mapping)}
    if head:
        parts.append(_kv_table(head))
        if frac is not None and isinstance(frac, numbers.Real) and not math.isnan(float(frac)):
            cls = ' class="bad"' if float(frac) < 0.5 else ""
            parts.append(f"<p{cls}>{100 * float(frac):.1f} % of the windows passed the quality gate.</p>")
    if failures is not None:
        parts.append("<h3>Gate failures by reason</h3>")
        if failures:
            rows = "".join(
                f'<tr><td class="key">{html.escape(str(k))}</td>{_cell(v)}</tr>' for k, v in failures.items()
            )
            parts.append(f'<table><tr><th class="key">reason</th><th>windows</th></tr>{rows}</table>')
        else:
            parts.append('<p class="note">No window failed the gate.</p>')
    for k, v in nested.items():
        parts.append(f"<h3>{html.escape(str(k))}</h3>" + _render_value(v))
    return "\n".join(parts) if parts else '<p class="note">No quality statistics.</p>'


# --------------------------------------------------------------------------
# the report
# --------------------------------------------------------------------------
def write_report(
    path: Union[str, "os.PathLike[str]"],
    *,
    title: str,
    summary: Mapping[str, Any],
    params: Mapping[str, Any],
    figures: Optional[FigureList] = None,
    tables: Optional[Mapping[str, Any]] = None,
    quality: Optional[Mapping[str, Any]] = None,
    dpi: int = REPORT_DPI,
    max_table_rows: int = MAX_TABLE_ROWS,
    verdict: Optional[Sequence[str]] = None,
    inputs: Optional[Sequence[Mapping[str, Any]]] = None,
    sections: Optional[Sequence[Tuple[str, str]]] = None,
    head_html: str = "",
    record_html: str = "",
    figures_note: str = "",
    durable: bool = True,
    inputs_note: str = "",
) -> str:
    """Writes one self-contained HTML report, atomically (docs/method.md 4-7).

    Parameters
    ----------
    path : str or path-like
        Target file (e.g. ``out/report.html``); its directory must exist.
    title : str
        Page title.
    summary : dict
        E.g. ``Results.summary()`` or :func:`build_report_summary`: scalars
        become key/value rows, a dict of statistics dicts (``mu_r``,
        ``mu_a``, ...) a matrix, ``operating_ranges`` its own table.
    params : dict
        Every parameter of the analysis (``Results.params``).
    figures : dict caption -> Figure, or list of (caption, Figure)
        Embedded in order as base64 PNG, each with its caption.
    tables : dict name -> table, optional
        Extra tables: a dict of columns (e.g. ``Results.table``), a list of
        row dicts, or an object with ``.table``; at most ``max_table_rows``
        rows each are shown.
    quality : dict, optional
        Quality statistics (see :func:`quality_from_results`). When omitted
        the quality keys of ``summary`` (windows, gated, gate_pass_fraction,
        gate_failures, orientation) are shown as the quality section.
    dpi : int
        Resolution of the embedded figures.
    max_table_rows : int
        Rows shown per table.
    verdict : list of str, optional
        The verdict lines (:func:`verdict_lines`), shown first in a box;
        the first line is the headline.
    inputs : list of dict, optional
        The input files (file, bytes, sha256, channels, logs), after the verdict.
    sections : list of (title, html), optional
        Further sections (interactive views, the table of windows), after the figures.
    head_html : str
        Inline ``<script>`` added to the head (Bokeh's JavaScript; no network reference).
    record_html : str
        The "Test record" section's content (:func:`tribodyn.app.record.record_html`), after the inputs.
    figures_note : str
        A note at the head of the figures (e.g. which figures were left out, and the flag that draws them).
    durable : bool
        Flush the page to disk before it replaces the target (default). False where something else flushes it
        (a job's outputs: :class:`~tribodyn.app.outputs.OutputSet` flushes its whole set before publishing it).
    inputs_note : str
        A note right below the inputs (with ``inputs``): the files of the folders given that no reader takes,
        skipped ("skipped (no reader takes them): README.md, photo.png").

    Returns
    -------
    str
        The path written.

    Raises
    ------
    Exception
        Whatever a figure's rendering or the write raised. Figures are
        rendered before anything is written, and the page goes through a
        temporary file renamed over the target, so on error the target is
        unchanged (absent if it did not exist) and no temporary file remains.
    """
    target = os.fspath(path)
    figs = _figure_list(figures)
    # Render everything first: a failing figure must not leave a file behind.
    images = [(caption, _png_base64(fig, dpi)) for caption, fig in figs]

    summary = dict(summary)
    warns = _pop_warnings(summary)
    if quality is None:
        quality = {k: summary.pop(k) for k in _QUALITY_KEYS if k in summary}
    out = _page_head(title, head_html, len(images))
    if verdict:
        out += _verdict_box(verdict)
    if inputs is not None:
        out.append('<h2 id="inputs">Inputs</h2>')
        out.append(inputs_table_html(inputs))
        if inputs_note:
            out.append(f'<p class="note">{html.escape(inputs_note)}</p>')
    if record_html:
        out.append('<h2 id="record">Test record</h2>')
        out.append(record_html)
    if warns:
        out.append('<h2 id="warnings">Warnings</h2>')
        out.append('<p class="note">What the readers found odd in the input, and what the analysis noticed:</p>')
        out.append("<ul>" + "".join(f"<li>{html.escape(w)}</li>" for w in warns) + "</ul>")
    out += _summary_section(summary)

    out.append('<h2 id="quality">Measurement quality</h2>')
    out.append(_quality_section(quality))

    out += _figures_section(images, figures_note)

    for sec_no, (sec_title, sec_html) in enumerate(sections or (), 1):
        out.append(f'<h2 id="section{sec_no}">{html.escape(sec_title)}</h2>')
        out.append(sec_html)

    out.append('<h2 id="parameters">Parameters (with units)</h2>')
    out.append(_kv_table(_params_with_units(params)) if params else '<p class="note">No parameters.</p>')

    for name, table in (tables or {}).items():
        out.append(f"<h2>{html.escape(str(name))}</h2>")
        out.append(_columns_table(table, max_table_rows))

    out += ["</body>", "</html>", ""]
    _atomic_write_text(target, "\n".join(out), durable=durable)
    return target


def _page_head(title: str, head_html: str, n_figures: int) -> List[str]:
    """The page up to its title line: the head (styles, ``head_html``) and the version, time and figure count."""
    try:
        from .._version import version as _version

        version = _version()
    except ImportError:  # pragma: no cover
        version = "unknown"
    stamp = _dt.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M:%S %Z")
    return [
        "<!DOCTYPE html>",
        '<html lang="en">',
        "<head>",
        '<meta charset="utf-8">',
        f"<title>{html.escape(title)}</title>",
        f"<style>{_CSS}</style>",
        head_html,
        "</head>",
        "<body>",
        f"<h1>{html.escape(title)}</h1>",
        (
            f'<p class="meta">tribodyn {html.escape(str(version))} &middot; {html.escape(stamp)} &middot; '
            f"{n_figures} figure{'s' if n_figures != 1 else ''}</p>"
        ),
    ]


def _verdict_box(verdict: Sequence[str]) -> List[str]:
    """The verdict box: the headline (with its budget, if any) and the further lines."""
    first, rest = verdict[0], verdict[1:]
    out = ['<div class="verdict" id="verdict"><h2 style="margin-top:0">Verdict</h2>']
    out.append(f'<p class="headline">{html.escape(first)}</p>{getattr(first, "budget_html", "")}')
    if rest:  # the headline of every further recording in bold too (one headline per recording)
        out.append("<ul>" + "".join(f"<li>{_verdict_item(x)}</li>" for x in rest) + "</ul>")
    out.append("</div>")
    return out


def _summary_section(summary: Mapping[str, Any]) -> List[str]:
    """The summary: its scalars, the COF statistics as a matrix, then each further dict under its own heading."""
    out = ['<h2 id="summary">Summary</h2>']
    scalars = {k: v for k, v in summary.items() if not isinstance(v, Mapping)}
    nested = {k: v for k, v in summary.items() if isinstance(v, Mapping)}
    stats = {k: v for k, v in nested.items() if _is_stats(v)}
    if scalars:
        out.append(_kv_table(scalars))
    if stats:
        out.append("<h3>COF statistics of the gated windows</h3>")
        out.append(_matrix_table({k: _with_intervals(v) for k, v in stats.items()}))
    for k, v in nested.items():
        if k in stats:
            continue
        heading = "Operating ranges" if k == "operating_ranges" else str(k)
        out.append(f"<h3>{html.escape(heading)}</h3>")
        out.append(_render_value(v))
    if not summary:
        out.append('<p class="note">No summary.</p>')
    return out


def _figures_section(images: Sequence[Tuple[str, str]], note: str = "") -> List[str]:
    """The figures, numbered, each a base64 PNG with its caption, after ``note`` (if any)."""
    out = ['<h2 id="figures">Figures</h2>']
    if note:
        out.append(f'<p class="note">{html.escape(note)}</p>')
    if not images and not note:
        out.append('<p class="note">No figures.</p>')
    for fig_no, (caption, b64) in enumerate(images, 1):
        cap = html.escape(caption)
        out.append(
            f'<figure id="fig{fig_no}"><img src="data:image/png;base64,{b64}" alt="{cap}">'
            f"<figcaption><b>Figure {fig_no}.</b> {cap}</figcaption></figure>"
        )
    return out


def _pop_warnings(summary: Dict[str, Any]) -> List[str]:
    """Takes the ``warnings`` lists out of a summary (and of the per-recording dicts in it), in order, each once."""
    found: List[str] = [str(w) for w in summary.pop("warnings", None) or ()]
    for key, value in list(summary.items()):
        if isinstance(value, Mapping) and "warnings" in value:
            sub = dict(value)
            found += [f"{key}: {w}" for w in sub.pop("warnings") or ()]
            summary[key] = sub
    return list(dict.fromkeys(found))


def _atomic_write_text(target: str, text: str, *, durable: bool = True) -> None:
    from ..io.writers import atomic_write

    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)

    atomic_write(target, write, durable=durable)


# --------------------------------------------------------------------------
# from a Results object
# --------------------------------------------------------------------------
def build_report_figures(
    results: Any,
    *,
    opr_temperature: Any = None,
    opr_current: Any = None,
    example: Optional[Mapping[str, Any]] = None,
    temperature_log: Any = None,
) -> List[Tuple[str, Figure]]:
    """The paper's figures for an analysis, as (caption, Figure) pairs (Figs. 2-12).

    Parameters
    ----------
    results : Results
        From :func:`tribodyn.analyze`.
    opr_temperature, opr_current : OperatingRange, optional
        From :func:`tribodyn.operating_range`; computed with the defaults
        when omitted and the covariate is present.
    example : dict, optional
        One window for Figs. 2-9: ``fx`` (may be None), ``fy``, ``fz``
        (arrays, N), ``fs`` (Hz), optional ``result`` (alias ``cof``: its
        :class:`~tribodyn.CofResult`, computed with
        ``identify(..., max_lag=fs/2)`` when absent; the correlation
        functions are computed if it has none) and optional ``t0`` (s).
    temperature_log : (t_s, T_degC), optional
        The readings, drawn as triangles on the Fig. 10 analogue.

    Returns
    -------
    list of (str, Figure)
        Figs. 2-9 for the example, then COF and temperature vs time and COF
        vs temperature (Figs. 10-11) when ``T`` has data, COF and current
        density vs time and COF vs J (Fig. 12) when ``J`` has data, or COF
        vs time alone when neither has.
    """
    return [(c, f) for _, c, f in build_named_figures(
        results, opr_temperature=opr_temperature, opr_current=opr_current,
        examples=[example] if example is not None else (), temperature_log=temperature_log)]  # fmt: skip


def _range_dict(opr: Any) -> Dict[str, Any]:
    d: Dict[str, Any] = dict(opr.to_dict()) if hasattr(opr, "to_dict") else {}
    d.pop("by", None)
    d.update(
        {
            "unit": opr.unit,
            "optimum": None if opr.optimum is None else list(opr.optimum),
            "mu_min": opr.mu_min,
            "onset": opr.onset,
            "bin_width": opr.bin_width,
            "tol": opr.tol,
            "rise": opr.rise,
        }
    )
    for name in ("heating", "cooling"):
        c = opr.curves.get(name)
        if c is not None:
            d[f"optimum_{name}"] = None if c.optimum is None else list(c.optimum)
    return d


def build_report_summary(results: Any, *, opr_temperature: Any = None, opr_current: Any = None,
                         summary: Optional[Mapping[str, Any]] = None) -> Dict[str, Any]:  # fmt: skip
    """``results.summary()`` (or ``summary``, when already computed) plus the optimum ranges, for
    :func:`write_report` (docs/method.md 7).

    The operating ranges are computed with the defaults when not given and
    the covariate has data; they go under ``"operating_ranges"`` keyed by
    "temperature" / "current_density" (unit, optimum, mu_min, onset, ...).
    """
    summary = dict(results.summary() if summary is None else summary)
    ranges: Dict[str, Any] = {}
    for by, opr in (("temperature", opr_temperature), ("current_density", opr_current)):
        o = _range_or_none(results, opr, by)
        if o is not None:
            ranges[by] = _range_dict(o)
    if ranges:
        summary["operating_ranges"] = ranges
    return summary


def quality_from_results(results: Any, summary: Optional[Mapping[str, Any]] = None) -> Dict[str, Any]:
    """Quality statistics of an analysis (docs/method.md 5): gate pass fraction, failure reasons, correlations.

    Returns windows, gated, gate_pass_fraction, the gate threshold,
    orientation, gate_failures (reason -> windows) and, over all windows,
    the median and 5th percentile of |C_yz(0)|, the medians of |C_xy(0)| and
    |C_xz(0)|, and the number of windows with a non-zero channel skew.
    ``summary``: ``results.summary()`` when already computed.
    """
    s = results.summary() if summary is None else summary
    q: Dict[str, Any] = {k: s[k] for k in ("windows", "gated", "gate_pass_fraction") if k in s}
    params = getattr(results, "params", {}) or {}
    if "gate" in params:
        q["gate (min |C_yz(0)|)"] = params["gate"]
    q["orientation"] = s.get("orientation")
    table = results.table
    for col, stats in (("c_yz", ("median", "p05")), ("c_xy", ("median",)), ("c_xz", ("median",))):
        v = np.abs(np.asarray(table.get(col, []), dtype=float))
        v = v[np.isfinite(v)]
        for st in stats:
            key = f"{st} |C_{col[2:]}(0)|"
            q[key] = float("nan") if v.size == 0 else float(np.median(v) if st == "median" else np.percentile(v, 5))
    skew = np.asarray(table.get("skew", []), dtype=float)
    if np.isfinite(skew).any():
        q["windows with channel skew"] = int(np.sum(np.isfinite(skew) & (skew != 0)))
    q["gate_failures"] = s.get("gate_failures", {})
    return q


def write_results_report(
    path: Union[str, "os.PathLike[str]"],
    results: Any,
    *,
    title: str = "tribodyn: coefficient of friction",
    opr_temperature: Any = None,
    opr_current: Any = None,
    example: Optional[Mapping[str, Any]] = None,
    temperature_log: Any = None,
    include_table: bool = True,
    dpi: int = REPORT_DPI,
) -> str:
    """The full report of an analysis: :func:`build_report_summary`, :func:`quality_from_results`,
    :func:`build_report_figures` and the per-window table, written by :func:`write_report`."""
    opr_t = _range_or_none(results, opr_temperature, "temperature")
    opr_j = _range_or_none(results, opr_current, "current_density")
    figs = build_report_figures(
        results, opr_temperature=opr_t, opr_current=opr_j, example=example, temperature_log=temperature_log
    )
    once = results.summary()  # one summary (its bootstraps) for both sections
    summary = build_report_summary(results, opr_temperature=opr_t, opr_current=opr_j, summary=once)
    for k in _QUALITY_KEYS:  # shown in the quality section
        summary.pop(k, None)
    tables = None
    if include_table:
        # Columns that are NaN in every window (no current, no skew, ...) only add noise.
        cols = {
            k: v
            for k, v in results.table.items()
            if not (np.asarray(v).dtype.kind == "f" and not np.isfinite(np.asarray(v)).any())
        }
        tables = {"Per-window results": cols}
    return write_report(
        path,
        title=title,
        summary=summary,
        params=dict(results.params),
        figures=figs,
        tables=tables,
        quality=quality_from_results(results, once),
        dpi=dpi,
    )
