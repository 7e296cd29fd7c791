"""The jobs behind the command line: the demo and the analysis of files.

Each job checks its output folder first (before the work: see
:class:`tribodyn.app.outputs.OutputSet`), analyses, then writes its outputs
all-or-nothing as one folder: per-window tables (CSV, Parquet),
``summary.json`` (COF statistics, optimum ranges, gate statistics, every
parameter, the tribodyn version, input names and SHA-256), figures (PNG) and
a self-contained ``report.html``. The folder then holds this set only (the
files of an earlier run into it are gone).
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import importlib
import os
import re
import threading
from pathlib import Path
from typing import Any, Callable, Dict, Iterator, List, Mapping, Optional, Sequence, Set, Tuple

import numpy as np

from ..analyses.ranges import OperatingRange, operating_range
from ..pipeline.analyze import analyze
from ..pipeline.identify import identify
from ..results import Results
from ._labels import fmt_interval, fmt_number, fmt_range, key_text, unit_text, units_in_text
from .outputs import (
    Digests,
    OutputSet,
    arrow_array,
    fill_digests,
    input_provenance,
    pyarrow_modules,
    write_json,
    write_table_csv,
    write_table_parquet,
)
from .record import Meta, metadata, record_html, summary_meta

__all__ = ["run_demo", "run_analysis", "read_log", "range_summary"]


def read_log(path: Any) -> Tuple[np.ndarray, np.ndarray]:
    """Reads a two-column log (time, value) from a CSV/TSV/whitespace file.

    Times are seconds from the recording's start, or absolute: ISO 8601
    (``2024-05-02T10:15:00``, also with a space for the ``T``) or epoch
    seconds, returned as epoch seconds, which :func:`tribodyn.analyze`
    aligns with the recording's start time (docs/method.md 6). Lines before
    the data that do not start with a time (headers, comments) are skipped;
    a decimal comma is accepted when the delimiter is not a comma.
    """
    from ..pipeline.covariates import to_epoch_seconds

    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"log file not found: {p}")
    t: List[float] = []
    v: List[float] = []
    with open(p, encoding="utf-8", errors="replace") as f:
        for line_no, line in enumerate(f, 1):
            s = line.strip()
            if not s or s[0] in "#%;":
                continue
            for delim in ("\t", ";", ",", None):
                parts = s.split(delim) if delim else s.split()
                if len(parts) >= 2:
                    break
            if len(parts) < 2:
                continue
            if delim is None and len(parts) >= 3 and parts[0][:1].isdigit() and "-" in parts[0] and ":" in parts[1]:
                parts = [f"{parts[0]}T{parts[1]}", *parts[2:]]  # date and time split by a space
            if delim != ",":
                parts = [parts[0], *(x.replace(",", ".") for x in parts[1:])]
            try:
                b = float(parts[1])
                try:
                    a = float(parts[0].replace(",", ".") if delim != "," else parts[0])
                except ValueError:
                    a = float(to_epoch_seconds(parts[0]))
            except (ValueError, TypeError):
                if t:  # a non-numeric row after data is an error, before it a header
                    raise ValueError(f"{p.name}, line {line_no}: not two numbers: {s!r}") from None
                continue
            t.append(a)
            v.append(b)
    if not t:
        raise ValueError(
            f"{p.name}: no (time, value) rows found (times in s from the recording's start, ISO 8601 or epoch seconds)"
        )
    return np.asarray(t), np.asarray(v)


def range_summary(opr: Optional[OperatingRange]) -> Optional[Dict[str, Any]]:
    """The JSON-ready essentials of an operating range."""
    if opr is None:
        return None
    out: Dict[str, Any] = dict(opr.to_dict())
    out.update(
        {
            "by": opr.by,
            "unit": opr.unit,
            "optimum": opr.optimum,
            "mu_min": opr.mu_min,
            "onset": opr.onset,
            "bin_width": opr.bin_width,
            "tol": opr.tol,
        }
    )
    for name, c in opr.curves.items():
        if name != "all":
            f = opr.fits.get(name)
            out[f"optimum_{name}"] = f.optimum if f is not None else c.optimum
    return out


def _truth_breakpoints(res: Results, truth: Any, by: str) -> Optional[Dict[str, Any]]:
    """The same segmented fit applied to the simulator's noise-free COF at the same windows (no bootstrap):
    where a straight-walled bathtub puts the simulated curve's edges (its walls are curved)."""
    table = dict(res.table)
    table["mu_r"] = np.asarray(truth.mu_at(res["time"]), dtype=float)
    twin = Results(table=table, bin_counts=res.bin_counts, bin_cof=res.bin_cof, fz_min=res.fz_min,
                   fz_max=res.fz_max, orientation=res.orientation, params=res.params)  # fmt: skip
    opr = _try_range(twin, by, n_boot=0)
    if opr is None:
        return None
    return {name: {"lower": f.lower, "upper": f.upper, "mu_min": f.mu_min} for name, f in opr.fits.items()}


def _try_range(res: Results, by: str, **kw: Any) -> Optional[OperatingRange]:
    try:
        with one_blas_thread():
            return operating_range(res, by, **kw)
    except ValueError:
        return None


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Within the block, NumPy's OpenBLAS runs on one thread (found among the loaded libraries; nothing
    changes without one). The bathtub fits' grid searches (docs/method.md 7) multiply small matrices
    thousands of times: on a busy 2-core machine a second BLAS thread made them 6x slower (the
    operating ranges of ``tribodyn demo``: 37 s against 6 s) and changed no number (the products split
    by rows and columns, never along the sums)."""
    saved = []
    try:
        for get, put in _openblas_threads():
            n = int(get())
            if n > 1:
                put(1)
                saved.append((put, n))
        yield
    finally:
        for put, n in saved:
            put(n)


_BLAS: Optional[List[Tuple[Any, Any]]] = None


def _openblas_threads() -> List[Tuple[Any, Any]]:
    """(get_num_threads, set_num_threads) of each OpenBLAS this process has loaded (Linux; else none)."""
    global _BLAS
    if _BLAS is not None:
        return _BLAS
    found: List[Tuple[Any, Any]] = []
    try:
        import ctypes

        with open("/proc/self/maps", encoding="utf-8", errors="replace") as fh:
            paths = sorted({ln.split()[-1] for ln in fh if "openblas" in ln.lower() and ln.split()[-1].startswith("/")})
        for path in paths:
            lib = ctypes.CDLL(path, mode=os.RTLD_NOLOAD)
            for name in ("scipy_openblas", "openblas"):
                for suffix in ("64_", ""):
                    get = getattr(lib, f"{name}_get_num_threads{suffix}", None)
                    put = getattr(lib, f"{name}_set_num_threads{suffix}", None)
                    if get is not None and put is not None:
                        get.restype, get.argtypes = ctypes.c_int, []
                        put.restype, put.argtypes = None, [ctypes.c_int]
                        found.append((get, put))
                        break
                else:
                    continue
                break
    except (OSError, AttributeError, ValueError):
        found = []
    _BLAS = found
    return found


def _write_set(out: OutputSet, prefix: str, res: Results, extra: Optional[Dict[str, Any]] = None) -> List[str]:
    names = [f"{prefix}windows.csv"]
    write_table_csv(res, out.path(names[0]), extra=extra)
    if write_table_parquet(res, out.path(f"{prefix}windows.parquet"), extra=extra):
        names.append(f"{prefix}windows.parquet")
    if res.strokes is not None:  # a reciprocating test's per-stroke table (docs/method.md 6c)
        names += _write_strokes(out, prefix, res.strokes)
    return names


def _write_strokes(out: OutputSet, prefix: str, strokes: Mapping[str, np.ndarray]) -> List[str]:
    """strokes.csv and strokes.parquet."""
    import csv

    names = [f"{prefix}strokes.csv"]
    cols = list(strokes)
    with open(out.path(names[0]), "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for row in zip(*(strokes[c] for c in cols)):
            w.writerow(["" if isinstance(v, float) and v != v else repr(float(v)) if isinstance(v, float) else v
                        for v in (x.item() if hasattr(x, "item") else x for x in row)])  # fmt: skip
    pa, pq = pyarrow_modules()
    arrays = [arrow_array(pa, np.asarray(strokes[c])) for c in cols]  # (pa.table would import pyarrow.compute)
    pq.write_table(pa.Table.from_arrays(arrays, names=cols), out.path(f"{prefix}strokes.parquet"))
    return names + [f"{prefix}strokes.parquet"]


def _figures(
    res: Results,
    *,
    opr_t: Optional[OperatingRange],
    opr_j: Optional[OperatingRange],
    opr_v: Optional[OperatingRange] = None,
    example: Optional[Dict[str, Any]] = None,
    examples: Sequence[Dict[str, Any]] = (),
    loops: Sequence[Dict[str, Any]] = (),
    time_figure: bool = True,
    steady_state: Optional[Dict[str, Any]] = None,
) -> List[Tuple[str, str, Any]]:
    """(file name, caption, Figure) of every figure, named after the paper's figures (``time_figure=False``:
    without ``cof_vs_time``; ``steady_state``: the running-in shaded, docs/method.md 6h)."""
    from .report import build_named_figures

    exs = list(examples) + ([example] if example is not None else [])
    return build_named_figures(res, opr_temperature=opr_t, opr_current=opr_j, opr_speed=opr_v, examples=exs,
                               loops=loops, time_figure=time_figure, steady_state=steady_state)  # fmt: skip


def loop_examples(source: Any, res: Results, open_options: Optional[Dict[str, Any]] = None
                  ) -> List[Dict[str, Any]]:  # fmt: skip
    """fy and x of the first, a middle and the last whole cycle with an energy, for the friction loops (6c).

    ``source`` is an open recording, a recording path or a dict of channel
    arrays; only those cycles' samples are read again.
    """
    cy = res.cycles
    if cy is None:
        return []
    whole = np.flatnonzero(np.isfinite(np.asarray(cy["energy"], dtype=float)))
    if whole.size == 0:
        return []
    picks = list(dict.fromkeys(int(whole[i]) for i in (0, whole.size // 2, whole.size - 1)))
    names = {1: ("only",), 2: ("first", "last"), 3: ("first", "middle", "last")}[len(picks)]
    total = int(res.params.get("n_samples_total") or 0)
    out = []
    for k, name in zip(picks, names):
        a, b = int(cy["start"][k]), int(cy["stop"][k])
        b = min(b + 1, total) if total else b  # the next cycle's first sample closes the loop
        ch = _read_window(source, a, b - a, open_options or {}, roles=("fy", "x"))
        if ch is None or "x" not in ch or "fy" not in ch:
            return []
        out.append({"x": ch["x"], "fy": ch["fy"], "energy": float(cy["energy"][k]),
                    "label": f"{name} whole cycle (no. {int(cy['cycle'][k])})"})  # fmt: skip
    return out


def _save_figures(
    out: OutputSet,
    figs: Sequence[Tuple[str, str, Any]],
    prefix: str,
    meanwhile: Optional[Callable[[], Any]] = None,
    *,
    also: Optional[Callable[[], Any]] = None,
    pool: Optional[_DrawingPool] = None,
) -> Tuple[List[Tuple[str, str, bytes]], Any, Any]:
    """Each figure rendered once to PNG (``figures.DPI``), written to ``figures/``: (file name, caption, PNG)
    triples, the report embeds the same PNG bytes (no figure is drawn or encoded twice); what ``meanwhile()``
    returns and what ``also()`` returns (``figures.Rendering.finish_beside``: ``also()`` first, then
    ``meanwhile()`` in a second thread while this one draws, that thread encoding the PNGs too; with ``pool``,
    ``meanwhile()`` here while its workers draw)."""
    from ..io.writers import atomic_write

    if not figs:  # no PNG (--figures none): Matplotlib is not imported
        return [], meanwhile() if meanwhile is not None else None, also() if also is not None else None
    from .figures import Rendering

    render = Rendering([f for _, _, f in figs], also=also, pool=pool)
    extra = render.also_result()
    pngs, done = render.finish_beside(meanwhile)
    saved = []
    for (stem, caption, _), data in zip(figs, pngs):
        name = f"figures/{prefix}{stem}.png"
        atomic_write(out.path(name), _bytes_writer(data), durable=False)  # (the set is flushed as a whole)
        saved.append((name, caption, data))
    return saved, done, extra


def _bytes_writer(data: bytes) -> Callable[[str], None]:
    def write(tmp: str) -> None:
        Path(tmp).write_bytes(data)

    return write


def _captioned(saved: Sequence[Tuple[str, str, bytes]]) -> List[Tuple[str, bytes]]:
    """(caption naming the PNG file, PNG bytes) pairs for the report."""
    return [(f"{cap} [{Path(name).name}]", data) for name, cap, data in saved]


def pick_windows(res: Results) -> Dict[str, int]:
    """The windows whose diagnostic figures the report shows (docs/method.md 5).

    ``representative``: the gated window whose mu_r is closest to the median
    of the gated windows; ``worst``: the failed window with the smallest
    |C_yz(0)| (NaN counts as the worst). Either is absent when no window fits.
    """
    ok = np.asarray(res["ok"], dtype=bool)
    mu = np.asarray(res["mu_r"], dtype=float)
    out: Dict[str, int] = {}
    good = np.flatnonzero(ok & np.isfinite(mu))
    if good.size:
        out["representative"] = int(good[np.argmin(np.abs(mu[good] - np.median(mu[good])))])
    bad = np.flatnonzero(~ok)
    if bad.size:
        c = np.abs(np.asarray(res["c_yz"], dtype=float)[bad])
        out["worst"] = int(bad[np.argmin(np.where(np.isfinite(c), c, -1.0))])
    return out


def diagnostic_examples(
    source: Any, res: Results, open_options: Optional[Dict[str, Any]] = None
) -> List[Dict[str, Any]]:
    """Figs. 2-9 inputs for the representative gated window and the worst failing one.

    ``source`` is an open recording, a recording path or a dict of channel
    arrays; the window's samples are read again (high-passed like the analysis when it used
    ``highpass``) and identified with the analysis's settings.
    """
    fs = float(res.params.get("fs") or 0.0)
    n = int(res.params.get("window_samples") or 0)
    if fs <= 0 or n < 3:
        return []
    out: List[Dict[str, Any]] = []
    t_start = np.asarray(res["t_start"], dtype=float)
    for tag, k in pick_windows(res).items():
        start = int(round(float(t_start[k]) * fs)) - int(res.params.get("start") or 0)
        if start < 0:
            continue
        # the window's own length: a stroke's central part can be shorter than the plan's window (method.md 6c)
        n_k = min(n, int(np.asarray(res["n"])[k])) if "n" in res.table else n
        ch = _read_window(source, start, n_k, open_options or {})
        if ch is None or "fy" not in ch or "fz" not in ch or len(ch["fz"]) < 3:
            continue
        if res.params.get("highpass"):
            from ..kernels.filters import highpass

            ch = {r: highpass(v, fs=fs, cutoff=float(res.params["highpass"])) for r, v in ch.items()}
        lag = max(1, min(len(ch["fz"]) - 1, int(0.5 * fs)))
        one = identify(
            ch["fy"],
            ch["fz"],
            fx=ch.get("fx"),
            fs=fs,
            max_lag=lag,
            orientation=res.orientation,
            deadband=float(np.asarray(res["deadband"])[k]) if np.isfinite(res["deadband"][k]) else 0.35,
            method="paper",  # the diagnostic figures' own fit: the paper's, as drawn (no instrument warning)
        )
        t0 = float(t_start[k])
        if tag == "representative":
            label = f"representative gated window (no. {k}, t = {t0:g} s, COF closest to the median)"
            gate = "passed"
        else:
            why = str(np.asarray(res["reasons"])[k]) or "failed"
            label = f"worst failing window (no. {k}, t = {t0:g} s, smallest |C_yz(0)|; failed: {why})"
            gate = f"failed ({why})"
        out.append({**ch, "fs": fs, "t0": t0, "result": one, "label": label, "tag": tag, "gate_text": gate})
    return out


def _read_window(source: Any, start: int, n: int, open_options: Dict[str, Any],
                 roles: Sequence[str] = ("fx", "fy", "fz")) -> Optional[Dict[str, np.ndarray]]:  # fmt: skip
    if isinstance(source, Mapping):
        return {r: np.asarray(source[r][start : start + n], dtype=float) for r in roles if r in source}
    from ..io import open_recording
    from ..io.constant import is_recording

    if is_recording(source):
        return _window_of(source, start, n, roles)
    with open_recording(source, **open_options) as rec:
        return _window_of(rec, start, n, roles)


def _window_of(rec: Any, start: int, n: int, roles: Sequence[str]) -> Optional[Dict[str, np.ndarray]]:
    """Samples start..start + n of the ``roles`` an open recording has (None when it holds none of them)."""
    have = [r for r in roles if r in dict(rec.roles)]
    for chunk in rec.chunks(n, have, start=start, stop=start + n):
        return {r: np.asarray(chunk[r], dtype=float) for r in have}
    return None


def _interactive_view(res: Results, name: str) -> Tuple[str, str]:
    """(the interactive COF view's div and script, the report head's JavaScript): the windows' numbers for
    BokehJS, which draws the view in the browser (Bokeh's Python package is not imported)."""
    from ._interactive import cof_views

    script, div = cof_views(res, name)
    return div + script, _bokeh_head()


def _report_extras(res: Results, name: str, csv_name: str, view: Optional[str] = None) -> List[Tuple[str, str]]:
    """The interactive COF view (``view``: drawn already) and the table of windows, as report sections."""
    from .report import windows_table_html

    return [
        (f"{name}: interactive COF against time, temperature and current density",
         _interactive_view(res, name)[0] if view is None else view),
        (f"{name}: table of windows", windows_table_html(res, csv_name)),
    ]  # fmt: skip


#: The reports' head JavaScript (BokehJS and the views' builder), read once per process.
_BOKEH_HEAD: Dict[str, str] = {}


def _bokeh_head() -> str:
    if "js" not in _BOKEH_HEAD:
        from ._interactive import bokeh_resources

        _BOKEH_HEAD["js"] = bokeh_resources()
    return _BOKEH_HEAD["js"]


@dataclasses.dataclass(frozen=True)
class _DemoTest:
    """One simulated test of the demo: the simulation, its results and its operating range."""

    sim: Any
    res: Results
    opr: Optional[OperatingRange]


def run_demo(out_dir: Any, *, seed: int = 0, progress: bool = False, overwrite: bool = False) -> Dict[str, Any]:
    """Simulates the paper's two tests, analyses them and writes every output.

    ``out_dir`` is replaced as a whole (see :class:`~tribodyn.app.outputs.OutputSet`;
    ``overwrite`` allows replacing a folder that holds other files). Returns
    the summary (also written to ``summary.json``).
    """
    from .._version import version

    __version__ = version()
    output = OutputSet(out_dir, overwrite=overwrite)  # refuses an unusable folder before the work
    pool = _drawing_pool(True)  # its figures drawn by workers too, started now (issue 38 point 3)
    try:
        t, j = _demo_tests(seed, progress)
        summary = _demo_summary(__version__, seed, t, j)
        with output as out:
            _write_demo(out, summary, t, j, pool)
    finally:
        if pool is not None:
            pool.close()
    return summary


def _demo_summary(version: str, seed: int, t: _DemoTest, j: _DemoTest) -> Dict[str, Any]:
    """The demo's summary.json before its files are listed."""
    summary: Dict[str, Any] = {
        "tribodyn_version": version,
        "job": "demo: simulated temperature and current-density tests of the paper's rig (docs/method.md 8)",
        "seed": seed,
        "temperature_test": _demo_test_summary(t, "temperature"),
        "current_density_test": _demo_test_summary(j, "current_density"),
    }
    return summary


def _demo_tests(seed: int, progress: bool) -> Tuple[_DemoTest, _DemoTest]:
    """The paper's temperature and current-density tests simulated, analysed, and their operating ranges."""
    from .. import simulate

    sim_t = simulate.temperature_test(seed=seed)
    sim_j = simulate.current_density_test(seed=seed)
    res_t = analyze(
        sim_t.channels,
        fs=sim_t.fs,
        window=2.0,
        hop=10.0,
        temperature=sim_t.temperature_log,
        rpm=sim_t.rpm,
        n_lamellas=sim_t.n_lamellas,
        progress=progress,
    )
    res_j = analyze(
        sim_j.channels,
        fs=sim_j.fs,
        window=2.0,
        hop=10.0,
        area_mm2=sim_j.area_mm2,
        rpm=sim_j.rpm,
        n_lamellas=sim_j.n_lamellas,
        progress=progress,
    )
    with one_blas_thread():
        opr_t = operating_range(res_t, "temperature")
        opr_j = operating_range(res_j, "current_density")
    return _DemoTest(sim_t, res_t, opr_t), _DemoTest(sim_j, res_j, opr_j)


def _demo_test_summary(test: _DemoTest, by: str) -> Dict[str, Any]:
    """A simulated test's summary: the results', its operating range against ``by``, the simulator's truth."""
    return {
        **test.res.summary(),
        "operating_range": range_summary(test.opr),
        "simulated_optimum": dict(test.sim.truth.optimum),
        "simulated_breakpoints": _truth_breakpoints(test.res, test.sim.truth, by),
        "params": test.res.params,
    }


def _write_demo(out: OutputSet, summary: Dict[str, Any], t: _DemoTest, j: _DemoTest,
                pool: Optional[_DrawingPool] = None) -> None:  # fmt: skip
    """The demo's outputs: each test's tables, figures and report sections, summary.json and report.html."""
    from .report import verdict_lines, write_report

    res_t, res_j = t.res, j.res
    ex_t = diagnostic_examples(t.sim.channels, res_t)
    ex_j = diagnostic_examples(j.sim.channels, res_j)
    figs_t = _figures(res_t, opr_t=t.opr, opr_j=None, examples=ex_t)
    figs_j = _figures(res_j, opr_t=None, opr_j=j.opr, examples=ex_j)

    def meanwhile() -> Tuple[List[str], List[Tuple[str, str]]]:  # the tables and the views, beside the figures
        tables = _write_set(out, "temperature_", res_t) + _write_set(out, "current_density_", res_j)
        return tables, _report_extras(res_t, "temperature test", "temperature_windows.csv") + _report_extras(
            res_j, "current-density test", "current_density_windows.csv"
        )

    named = [(f"temperature_{s}", c, f) for s, c, f in figs_t] + [(f"current_density_{s}", c, f) for s, c, f in figs_j]
    pngs, (files, extras), _ = _save_figures(out, named, "", meanwhile, pool=pool)
    png_t, png_j = pngs[: len(figs_t)], pngs[len(figs_t) :]
    files += [name for name, _, _ in pngs]
    summary["files"] = files + ["summary.json", "report.html"]
    summary["columns"] = column_units()
    write_json(summary, out.path("summary.json"))
    s_t, s_j = summary["temperature_test"], summary["current_density_test"]
    verdict = verdict_lines("temperature test", s_t, res_t.params, {"temperature": s_t["operating_range"]})
    verdict += verdict_lines("current-density test", s_j, res_j.params, {"current_density": s_j["operating_range"]})
    write_report(
        out.path("report.html"),
        title="tribodyn demo: the paper's rig, simulated",
        summary=_flat_summary(summary),
        params={"temperature test": res_t.params, "current-density test": res_j.params},
        figures=[(f"Temperature test: {c}", f) for c, f in _captioned(png_t)]
        + [(f"Current-density test: {c}", f) for c, f in _captioned(png_j)],
        verdict=verdict,
        inputs=[],
        sections=extras,
        head_html=_bokeh_head(),
        durable=False,  # (OutputSet flushes the whole set before publishing it)
        quality={
            "temperature test": s_t["gate_failures"],  # the summaries above: summary() once per run
            "current-density test": s_j["gate_failures"],
        },
    )


def _interval(ci: Any) -> str:
    iv = fmt_interval(ci)
    return f" {iv}" if iv else ""


_BRANCH_TEXT = {"all": "all windows", "heating": "heating branch", "cooling": "cooling branch"}


def _breakpoint_rows(key: str, rng: Mapping[str, Any], val: Mapping[str, Any]) -> Dict[str, str]:
    """Breakpoints with their 95 % intervals per branch, next to the simulator's truth when known."""
    rows: Dict[str, str] = {}
    ci = rng.get("optimum_ci")
    if ci is None:
        return rows
    by, unit = rng["by"], unit_text(rng["unit"])
    sim = val.get("simulated_optimum") or {}
    bath = val.get("simulated_breakpoints") or {}
    fits = {"all": rng, **{k[4:]: v for k, v in rng.items() if k.startswith("fit_")}}
    for name, f in fits.items():
        if not f or not f.get("optimum") or not f.get("optimum_ci"):
            continue
        (lo, hi), (lci, hci) = f["optimum"], f["optimum_ci"]
        text = f"{fmt_number(lo)}{_interval(lci)} to {fmt_number(hi)}{_interval(hci)} {unit}"
        truth = sim.get(by if name == "all" else f"{by}_{name}")
        if truth is not None:
            text += f"; simulated flat bottom {fmt_range(truth[0], truth[1], unit)}"
        b = bath.get(name)
        if b is not None:
            lower, upper = ("none" if v is None else fmt_number(v) for v in (b["lower"], b["upper"]))
            text += f"; the same fit of the simulated COF {lower} to {upper} {unit}"
        branch = _BRANCH_TEXT.get(name, name)
        rows[f"{_NAME_TEXT.get(key, key)}: {key_text(by)} breakpoints with 95 % intervals, {branch}"] = text
    return rows


#: The demo's two tests as words.
_NAME_TEXT = {"temperature_test": "temperature test", "current_density_test": "current-density test"}
#: Top-level keys of the demo's summary as words.
_TOP_TEXT = {"tribodyn_version": "tribodyn version", "job": "job", "seed": "simulator seed"}


def column_units() -> List[Dict[str, str]]:
    """Name, unit and meaning of every column of ``windows.csv``, in order (``summary.json["columns"]``).

    The CSV itself holds one header row of names and then numbers only, so
    that every CSV reader and spreadsheet takes it as it is; its units are
    here, in the Parquet schema (field metadata ``unit``) and in
    ``Results.to_pandas().attrs["units"]``.
    """
    from ..columns import TABLE

    return [{"name": c.name, "unit": c.unit, "meaning": c.meaning} for c in TABLE]


def _headline_cell(head: Mapping[str, Any]) -> str:
    """'0.1492 (95 % interval 0.1427 to 0.1557), mean of 1801 samples, 100.0 % of the recording' or why none."""
    if head.get("value") is None:
        return "none: " + "; ".join(str(r) for r in head.get("reasons") or ())
    text = f"{head['value']:.4f}"
    if head.get("low") is not None and head.get("high") is not None:
        text += f" (95 % interval {head['low']:.4f} to {head['high']:.4f})"
    text += f", {head.get('statistic')} of {head.get('n')}"
    frac = head.get("fraction_used")
    if isinstance(frac, (int, float)):
        text += f", {100 * frac:.1f} % of the recording's samples"
    return text


def _flat_summary(summary: Mapping[str, Any]) -> Dict[str, Any]:
    """A short, readable summary for the report's first table: labels in words, units as °C, A/mm², N."""
    out: Dict[str, Any] = {}
    for key, val in summary.items():
        if isinstance(val, Mapping) and "mu_r" in val:
            name = _NAME_TEXT.get(key, str(key))  # a recording's file name stays as it is
            mu = val["mu_r"]
            out[f"{name}: windows analysed (passed the quality gate)"] = f"{val['windows']} ({val['gated']})"
            head = val.get("headline") or {}
            if head:
                out[f"{name}: COF (headline, {head.get('method')})"] = _headline_cell(head)
                how = f"{head.get('estimate')}; interval: {head.get('interval')}"
                out[f"{name}: how the headline is computed"] = how
            if val.get("verdict"):
                from ..results import verdict_text

                out[f"{name}: verdict"] = units_in_text(verdict_text(val["verdict"]))
            if mu.get("n") and head.get("method") == "dynamic":
                out[f"{name}: COF of the gated windows [5th, 95th percentile]"] = (
                    f"{mu['median']:.4f} [{mu['p05']:.4f}, {mu['p95']:.4f}]"
                )
            for rng in (val[k] for k in val if k.startswith("operating_range")):
                if not rng:
                    continue
                by = key_text(rng["by"])
                unit = unit_text(rng["unit"])
                if rng.get("verdict"):
                    verdict = f"{rng['verdict']}: {rng['explanation']}"
                    out[f"{name}: verdict on the optimum {by}"] = units_in_text(verdict)
                if not rng.get("optimum"):
                    continue
                lo, hi = rng["optimum"]
                out[f"{name}: optimum {by}"] = (
                    f"{fmt_range(lo, hi, unit, ci=rng.get('optimum_ci'))} (minimum COF {rng['mu_min']:.4f})"
                )
                out.update(_breakpoint_rows(key, rng, val))
                if rng.get("onset") is not None:
                    times = f"{1 + float(rng.get('rise') or 0.5):g} ×"
                    label = f"{name}: {by} where the COF reaches {times} its minimum"
                    out[label] = f"{fmt_number(rng['onset'])} {unit}"
        elif not isinstance(val, (Mapping, list)):
            out[_TOP_TEXT.get(key, key_text(key))] = units_in_text(val) if isinstance(val, str) else val
    # The readers' warnings go to the report's own section (report._pop_warnings).
    warns = [
        f"{key}: {w}" for key, val in summary.items() if isinstance(val, Mapping) for w in val.get("warnings") or ()
    ]
    if warns:
        out["warnings"] = warns
    return out


def run_analysis(
    paths: Sequence[Any],
    out_dir: Any,
    *,
    open_options: Optional[Dict[str, Any]] = None,
    analyze_options: Optional[Dict[str, Any]] = None,
    progress: bool = False,
    client: Any = None,
    split: Optional[float] = None,
    overwrite: bool = False,
    protect: Sequence[Any] = (),
    meta: Optional[Meta] = None,
    steady_state: bool = False,
    figures: str = "auto",
) -> Dict[str, Any]:
    """Analyses recording files and writes the outputs into ``out_dir``.

    ``paths`` may hold files, directories and glob patterns. One recording:
    its tables, figures and report at the top of ``out_dir``. Several: one
    sub-folder per recording plus a combined table (with a ``recording``
    column), summary and report at the top; each recording named by its file
    name, or, where inputs share one, by the end of its path that tells them
    apart (:func:`recording_labels`). A folder's files that no reader takes
    are skipped (``summary["skipped"]``). With a Dask ``client`` the
    recordings (and ranges of ``split`` seconds of long ones) run on the
    cluster (:func:`tribodyn.analyze_many`). A recording that fails is listed
    in ``summary["failures"]``; if every one fails, ``out_dir`` holds only
    ``summary.json`` with their errors, except that the error of a lone
    input is raised (a ValueError or RecordingError, as without ``client``).

    ``out_dir`` is checked before the work and replaced as a whole (see
    :class:`~tribodyn.app.outputs.OutputSet`): a folder holding anything but a
    previous output set is refused unless ``overwrite``; a folder holding
    an input file, or one of the files ``protect`` names, always.

    ``meta`` is the test record (:func:`tribodyn.app.record.parse_meta`,
    docs/method.md 10c): each recording's ``summary["recordings"][name]["meta"]``,
    ``metadata.json`` and the report's "Test record" section.

    ``steady_state``: also where each recording's running-in ends
    (:func:`tribodyn.steady_state`, docs/method.md 6h): its ``steady_state``
    entry in the summary, a verdict line, and the running-in shaded on the
    COF-against-time figure.

    ``figures``: which PNG figures are drawn (:data:`FIGURES`): ``"auto"``
    leaves out the window diagnostics (Figs. 2-9) of a recording whose
    headline is not the dynamic COF, ``"all"`` draws every figure, ``"none"``
    none (the report keeps its interactive views).
    """
    from ..pipeline.distributed import expand_paths

    if figures not in FIGURES:
        raise ValueError(f"figures must be one of {', '.join(FIGURES)}, got {figures!r}")
    if not paths:
        raise ValueError("no input file given")
    skipped: List[str] = []  # a folder's files that no reader takes (README.md): summary["skipped"]
    files = expand_paths(paths, skipped)
    check_distinct_names(files)
    output = OutputSet(out_dir, overwrite=overwrite, protect=[*files, *protect])
    # The inputs' SHA-256 in a thread while the analysis reads them; the output step's modules imported in
    # another (both mostly outside the GIL or while the kernel runs without it).
    # A long recording's figures are drawn by worker processes too, started now: they load Matplotlib meanwhile.
    pool = _drawing_pool(_pool_pays(figures, files))
    digests = Digests(files)
    imports = _import_in_background(_OUTPUT_MODULES if _drawing_likely(figures, files) else _TABLE_MODULES)
    try:
        return _run_analysis(files, output, digests, imports, open_options=open_options,
                             analyze_options=analyze_options, progress=progress, client=client, split=split,
                             meta=meta, steady_state=steady_state, figures=figures, pool=pool,
                             skipped=skipped)  # fmt: skip
    finally:
        digests.cancel()
        if pool is not None:
            pool.close()


def check_distinct_names(files: Sequence[str]) -> None:
    """Refuses one file given twice under two spellings (``runA/a.h5`` and ``runA/../runA/a.h5``): it would be
    analysed twice under two names; so is one reached through a link (``runs/latest`` -> ``runs/r3``), known by its
    device and inode. Inputs of one file name in different folders (``runA/a.h5``, ``runB/a.h5``) are analysed,
    each named by :func:`recording_labels` (they were refused, issue 38 point 4)."""
    seen: Dict[Any, str] = {}
    for f in files:
        try:
            st = os.stat(f)
            key: Any = (st.st_dev, st.st_ino)
        except OSError:  # (no such file: its reader says so)
            key = os.path.normcase(os.path.abspath(f))
        if key in seen:
            raise ValueError(f"{seen[key]} and {f} are one file: give it once")
        seen[key] = f


def recording_labels(files: Sequence[Any]) -> Dict[Path, str]:
    """Each input's name in the outputs, by ``Path(file)``: the summary's keys, the combined table's ``recording``
    column, the failures, the report and the inputs' provenance (``file``); one rule, declared here only.

    Its file name (``data.tdms``); among inputs of one file name, the shortest end of its absolute path that
    no other of them ends with (``runA/data.tdms``, ``runB/data.tdms``; ``/`` between the parts), so inputs
    of distinct names are named as before and no recording stands for another. Give each file once
    (:func:`check_distinct_names`).
    """
    parts = {Path(f): Path(os.path.abspath(f)).parts[1:] or (Path(f).name,) for f in files}
    by_name: Dict[str, List[Tuple[str, ...]]] = {}
    for ends in parts.values():
        by_name.setdefault(ends[-1], []).append(ends)
    labels: Dict[Path, str] = {}
    for p, ends in parts.items():
        others = [o for o in by_name[ends[-1]] if o != ends]  # (one file spelled twice: one label, `info`)
        k = 1
        while k < len(ends) and any(o[-k:] == ends[-k:] for o in others):
            k += 1
        labels[p] = "/".join(ends[-k:])
    return labels


def _run_analysis(
    files: Sequence[str],
    output: OutputSet,
    digests: Digests,
    imports: threading.Thread,
    *,
    open_options: Optional[Dict[str, Any]],
    analyze_options: Optional[Dict[str, Any]],
    progress: bool,
    client: Any,
    split: Optional[float],
    meta: Optional[Meta],
    steady_state: bool,
    figures: str,
    pool: Optional[_DrawingPool] = None,
    skipped: Sequence[str] = (),
) -> Dict[str, Any]:
    """:func:`run_analysis` once the output folder is checked and the digests started (and the drawing pool);
    ``skipped``: the folders' files no reader takes, listed in the summary (``skipped``: always, empty when none)
    and below the report's inputs."""
    from .._version import version

    __version__ = version()

    open_options = dict(open_options or {})
    opts = dict(analyze_options or {})
    log_file = opts.pop("temperature_file", None)  # the log's file name, for the report's inputs
    cov_files = opts.pop("covariate_files", None) or {}  # the same for the covariate logs (docs/method.md 7a)
    names = recording_labels(files)
    with contextlib.ExitStack() as stack:
        # A recording is opened once: the analysis' own stays open for the figures' windows, the channel
        # map and stick-slip (a text file's opening reads it whole; issue 22 point 5).
        runs, failures, kept = _analyse(stack, files, open_options, opts, progress=progress, client=client,
                                        split=split, names=names)  # fmt: skip
        if not runs:
            if len(files) == 1:  # one file: its error, as when it is analysed here (the CLI: one line, status 2)
                raise _failure_error(Path(files[0]), next(iter(failures.values())))
            # Every recording failed: summary.json still lists every error (the CLI exits with status 3).
            summary_failed: Dict[str, Any] = {
                "tribodyn_version": __version__,
                "inputs": [str(f) for f in files],
                "open_options": {k: v for k, v in open_options.items() if k != "appending"},  # (a mode: watch)
                "recordings": {},
                "failures": failures,
                "skipped": list(skipped),  # (always: an empty list when nothing was skipped)
            }
            with output as out:
                write_json(summary_failed, out.path("summary.json"))
            return summary_failed
        imports.join()  # before this thread imports any of them
        summary: Dict[str, Any] = {
            "tribodyn_version": __version__,
            # the digests are waited for only when written: the outputs are drawn while the thread hashes
            "inputs": input_provenance([p for p, _ in runs], later=True),
            "open_options": {k: v for k, v in open_options.items() if k != "appending"},  # (a mode: watch)
            "recordings": {},
            "failures": failures,
            "skipped": list(skipped),  # (always, as ManyResults.summary(): [] when nothing was skipped)
        }
        for entry, (p, _) in zip(summary["inputs"], runs):
            entry["file"] = names[p]  # (its file name, or where names collide the end of its path)
        inputs = {i["file"]: i for i in summary["inputs"]}
        for p, _ in runs:
            inputs[names[p]]["channels"] = {}  # (filled with the recording's outputs)
            inputs[names[p]]["logs"] = ([f"temperature: {Path(log_file).name}"] if log_file else []) + [
                f"{name}: {Path(f).name}" for name, f in cov_files.items()
            ]
        job = _Job(meta or Meta(), steady_state, len(runs) == 1 and not failures, inputs, summary, digests, figures,
                   pool=pool, names=names)  # fmt: skip
        with output as out:
            verdict: List[str] = []
            sections: List[Tuple[str, str]] = []
            all_figs: List[Tuple[str, bytes]] = []
            for (p, res), label in zip(runs, _folders([names[p] for p, _ in runs])):
                rec = kept[p] if p in kept else _open_once(stack, p, open_options)
                lines, extras, captioned = _recording_outputs(out, job, (p, res), label, rec)
                verdict += lines
                sections += extras
                all_figs += [(f"{names[p]}: {c}", f) for c, f in captioned]
            _write_top(out, job, runs, verdict, sections=sections, figures=all_figs)
    return summary


def _analyse(stack: contextlib.ExitStack, files: Sequence[str], open_options: Dict[str, Any], opts: Dict[str, Any],
             *, progress: bool, client: Any, split: Optional[float], names: Mapping[Path, str],
             ) -> Tuple[List[Tuple[Path, Results]], Dict[str, Any], Dict[Path, Any]]:  # fmt: skip
    """(path and Results of each recording analysed, failures by name (``names``: :func:`recording_labels`), the
    recordings still open by path)."""
    from ..pipeline.distributed import analyze_many

    if len(files) == 1 and client is None and split is None:
        # One file, here: read it directly (progress bar over its samples), kept open for the outputs.
        from ..io import open_recording

        rec = stack.enter_context(open_recording(files[0], **open_options))
        # stick-slip in the analysis' own reading (docs/method.md 6g): the recording is not read again for it
        try:
            res = analyze(rec, progress=progress, stick_slip=True, **opts)
        except ValueError as exc:  # the command's one line names the file, as a folder's failures do
            _name_the_file(exc, Path(files[0]))
            raise
        return [(Path(files[0]), res)], {}, {Path(files[0]): rec}
    if client is None and split is None and opts.get("align") is None:
        runs, failures, kept = _analyse_here(stack, files, open_options, opts, progress=progress, names=names)
        return [(p, _stick_slip_searched(r)) for p, r in runs], failures, kept
    many = analyze_many(files, client=client, open_options=open_options, split=split, progress=progress, **opts)
    failures = {names[Path(p)]: {"error": f.error, "kind": f.kind} for p, f in many.failures.items()}
    return [(Path(p), _stick_slip_searched(r)) for p, r in many.results.items()], failures, {}


def _stick_slip_searched(res: Results) -> Results:
    """``res`` whose params say that its stick-slip is searched (``stick_slip`` True), as the command searches
    every recording's (docs/method.md 6g): one file here in the analysis' own reading (``analyze(stick_slip=True)``),
    the others read again after the analysis (bit for bit the same events). So every route (one file, several,
    ``--split``, ``--scheduler``) gives the same params (it said False but for one file here)."""
    if res.params.get("stick_slip"):
        return res
    from ..results import CACHED

    return res.replace(keep=CACHED, params={**res.params, "stick_slip": True})


def _failure_error(path: Path, failure: Mapping[str, str]) -> ValueError:
    """The error of a recording that failed in :func:`tribodyn.analyze_many` (``{"error": "Kind: message",
    "kind": "Kind"}``) as one analysed here raises it: a RecordingError, else a ValueError, naming the file."""
    from ..io import RecordingError

    kind, text = failure["kind"], failure["error"]
    text = text[len(kind) + 2 :] if text.startswith(f"{kind}: ") else text
    exc = RecordingError(text) if kind == "RecordingError" else ValueError(text)
    _name_the_file(exc, path)
    return exc


def _name_the_file(exc: BaseException, path: Path) -> None:
    """Puts ``path``'s name before the message of ``exc`` (in place: its type and traceback stay) unless the message
    names the file already (a reader's errors say its path)."""
    if exc.args and isinstance(exc.args[0], str) and path.name not in exc.args[0]:
        exc.args = (f"{path.name}: {exc.args[0]}", *exc.args[1:])


def _analyse_here(stack: contextlib.ExitStack, files: Sequence[str], open_options: Dict[str, Any],
                  opts: Dict[str, Any], *, progress: bool, names: Mapping[Path, str],
                  ) -> Tuple[List[Tuple[Path, Results]], Dict[str, Any], Dict[Path, Any]]:  # fmt: skip
    """:func:`_analyse` of several files in this process, one after the other, as :func:`tribodyn.analyze_many`
    runs them without a client (the same tables and summary: ``analyze`` of each file), but each recording opened
    once and kept open for its outputs (the figures' windows, the channel map, stick-slip): a text export is
    parsed once, not twice (issue 38 point 3). A file that fails is listed with its
    error as ``analyze_many`` lists it (``"TypeName: message"``); the others go on."""
    from ..io import open_recording
    from ..pipeline._progress import progress_bar
    from ..pipeline.distributed import RecordingFailure

    runs: List[Tuple[Path, Results]] = []
    failures: Dict[str, Any] = {}
    kept: Dict[Path, Any] = {}
    opts = {k: v for k, v in opts.items() if k != "start"}  # (as analyze_many: a recording from its start)
    bar = progress_bar(len(files), unit="recording", desc="analyse") if progress else None
    for f in files:
        path = Path(f)
        with contextlib.ExitStack() as one:  # a recording that fails is closed at once, one analysed kept open
            try:
                rec = one.enter_context(open_recording(f, **open_options))
                res = analyze(rec, **opts)
            except Exception as exc:  # noqa: BLE001 - one bad file must not stop the rest (reported per recording)
                failed = RecordingFailure.of(f, exc)
                failures[names[path]] = {"error": failed.error, "kind": failed.kind}
            else:
                runs.append((path, res))
                kept[path] = rec
                stack.push(one.pop_all())
        if bar is not None:
            bar.update(1)
    if bar is not None:
        bar.close()
    return runs, failures, kept


def _open_once(stack: contextlib.ExitStack, path: Path, open_options: Mapping[str, Any]) -> Any:
    """The recording opened for its outputs (closed with ``stack``), or the exception that opening raised."""
    from ..io import open_recording

    try:
        return stack.enter_context(open_recording(path, **open_options))
    except Exception as exc:  # noqa: BLE001 - the analysis already read it; each output says what went wrong
        return exc


#: What ``tribodyn analyze --figures`` draws as PNG (figures/*.png and the report's figures): ``auto`` every figure
#: of a recording whose headline is the dynamic COF; of an export whose headline is the classical, per-stroke or
#: instrument COF, the figures the interactive view does not show (strokes, cycles, loops, temperature, current,
#: speed): neither the window diagnostics (Figs. 2-9: they diagnose the dynamic method) nor ``cof_vs_time`` (the
#: interactive view draws it, with the headline; drawn with ``--steady-state``, whose running-in it shades);
#: ``all`` every figure; ``none`` no PNG (issue 38 point 3).
FIGURES = ("auto", "all", "none")


def _diagnostics_drawn(figures: str, res: Results) -> bool:
    """Whether the window diagnostics (Figs. 2-9) and ``cof_vs_time`` are drawn (:data:`FIGURES`)."""
    return figures == "all" or (figures == "auto" and res.headline.method == "dynamic")


def _figure_windows(figures: str, rec: Any, res: Results) -> Tuple[List[Dict[str, Any]], List[Dict[str, Any]], Results]:
    """The samples the figures read again: (diagnostic examples, friction loops, ``res`` with a warning when they
    could not be read), as ``figures`` asks (:data:`FIGURES`). ``rec`` is the open recording or the exception that
    opening it raised."""
    if figures == "none":
        return [], [], res
    try:
        if isinstance(rec, Exception):
            raise rec
        examples = diagnostic_examples(rec, res) if _diagnostics_drawn(figures, res) else []
        return examples, loop_examples(rec, res), res
    except (OSError, ValueError) as exc:  # the figures of the windows are extra: say so, go on
        return [], [], _replaced(res, warnings=(*res.warnings, f"diagnostic figures not drawn: {exc}"))


def figures_note(figures: str, res: Results, name: str) -> str:
    """What the report says of the figures ``figures`` left out (:data:`FIGURES`), or ""."""
    if figures == "none":
        return (f"{name}: no PNG figures were drawn (--figures none); the interactive view below shows the COF "
                "against time; --figures auto or all draws them.")  # fmt: skip
    if not _diagnostics_drawn(figures, res):
        return (f"{name}: the window diagnostics (paper Figs. 2-9) are not drawn: the headline is the "
                f"{res.headline.method} COF, which they do not diagnose; the interactive view below shows the COF "
                "against time with the headline; --figures all draws every figure as PNG.")  # fmt: skip
    return ""


@dataclasses.dataclass(frozen=True)
class _Job:
    """What every recording's outputs share."""

    meta: Meta
    steady_state: bool
    single: bool  # one recording without failures: its outputs at the top of the folder
    inputs: Dict[str, Dict[str, Any]]  # recording's name (recording_labels) -> provenance (digest, channels, logs)
    summary: Dict[str, Any]  # summary.json, filled recording by recording
    digests: Digests  # the inputs' SHA-256, filled into ``inputs`` when written (fill_digests)
    figures: str = "auto"  # which PNG figures: FIGURES
    notes: List[str] = dataclasses.field(default_factory=list)  # what the report says of figures left out
    pool: Optional[_DrawingPool] = None  # the drawing workers (_drawing_pool), or None: drawn in this process
    names: Mapping[Path, str] = dataclasses.field(default_factory=dict)  # each input's name: recording_labels


def _recording_outputs(out: OutputSet, job: _Job, run: Tuple[Path, Results], label: str, rec: Any
                       ) -> Tuple[List[str], List[Tuple[str, str]], List[Tuple[str, bytes]]]:  # fmt: skip
    """One recording's tables and figures (and, among several, its summary.json and report.html), its entry in
    the job's summary: (verdict lines, report sections, captioned figures). ``rec`` is the open recording the
    figures' windows and stick-slip read, or the exception that opening it raised."""
    from ..analyses.stickslip import stick_slip
    from .report import verdict_lines, write_report

    p, res = run
    name = job.names[p]  # (recording_labels)
    prefix = "" if job.single else f"{label}/"
    job.inputs[name]["channels"] = _channel_map(rec)
    opr_t = _try_range(res, "temperature")
    opr_j = _try_range(res, "current_density")
    has_speed = bool(np.isfinite(np.asarray(res["speed"], dtype=float)).any())
    opr_v = _try_range(res, "speed") if has_speed else None  # the Stribeck curve (docs/method.md 7a)
    drawn = job.figures != "none"
    examples, loops, res = _figure_windows(job.figures, rec, res)
    try:  # docs/method.md 6g: found in the analysis' reading (one file), else fy and fz read again, once
        if isinstance(rec, Exception):
            raise rec
        slip: Optional[Dict[str, Any]] = stick_slip(rec, res).to_dict()
    except (OSError, ValueError) as exc:
        slip = None
        res = _replaced(res, warnings=(*res.warnings, f"stick-slip not assessed: {exc}"))
    steady = _steady_state(res) if job.steady_state else None
    figs = _figures(res, opr_t=opr_t, opr_j=opr_j, opr_v=opr_v, examples=examples, loops=loops,
                    time_figure=_diagnostics_drawn(job.figures, res) or bool(steady),
                    steady_state=steady) if drawn else []  # fmt: skip
    res_now = res

    def meanwhile() -> Tuple[List[str], Dict[str, Any]]:  # the tables and the summary, beside the figures
        return _write_set(out, prefix, res_now), res_now.summary()

    pngs, (written, res_summary), (view, head) = _save_figures(
        out, figs, prefix, meanwhile, also=lambda: _interactive_view(res_now, name), pool=job.pool
    )
    _BOKEH_HEAD.setdefault("js", head)
    extras = _report_extras(res_now, name, f"{prefix}windows.csv", view)
    written += [png for png, _, _ in pngs]
    rec_sum = {
        **res_summary,
        **({"steady_state": steady} if steady else {}),
        "operating_range_temperature": range_summary(opr_t),
        "operating_range_current_density": range_summary(opr_j),
        "operating_range_speed": range_summary(opr_v),
        "params": res.params,
        "files": written,
        "stick_slip": slip,
    }
    rec_sum["meta"] = summary_meta(job.meta, rec_sum["headline"])
    job.summary["recordings"][name] = rec_sum
    ranges = {"temperature": rec_sum["operating_range_temperature"],
              "current_density": rec_sum["operating_range_current_density"],
              "speed": rec_sum["operating_range_speed"]}  # fmt: skip
    lines = verdict_lines(name, rec_sum, res.params, ranges)
    if steady:  # right after the headline
        lines.insert(1, f"{name}: {steady['text']}.")
    if slip and slip["present"]:
        lines.append(f"{name}: {slip['verdict']}")
    captioned, note = _captioned(pngs), figures_note(job.figures, res, name)
    job.notes.extend([note] if note else [])
    if not job.single:
        fill_digests([job.inputs[name]], job.digests)
        write_json(rec_sum, out.path(f"{prefix}summary.json"))
        write_report(
            out.path(f"{prefix}report.html"),
            title=f"tribodyn: {name}",
            summary=_flat_summary({name: rec_sum}),
            params=res.params,
            figures=captioned,
            figures_note=note,
            quality=rec_sum["gate_failures"],
            verdict=lines,
            inputs=[job.inputs[name]],
            sections=_report_extras(res, name, "windows.csv", view),
            head_html=_bokeh_head(),
            durable=False,  # (OutputSet flushes the whole set before publishing it)
            record_html=record_html(job.meta, {name: rec_sum["headline"]}),
        )
    return lines, extras, captioned


def _write_top(out: OutputSet, job: _Job, runs: Sequence[Tuple[Path, Results]], verdict: List[str], *,
               sections: List[Tuple[str, str]], figures: List[Tuple[str, bytes]]) -> None:  # fmt: skip
    """The job's own outputs: the combined tables (several recordings), summary.json, metadata.json and
    report.html."""
    from .._version import version

    __version__ = version()
    from .report import write_report

    summary, failures = job.summary, job.summary["failures"]
    names = [job.names[p] for p, _ in runs]  # (recording_labels)
    if not job.single:
        combined = _combine([r for _, r in runs], names)
        write_table_csv(combined[0], out.path("windows.csv"), extra={"recording": combined[1]})
        write_table_parquet(combined[0], out.path("windows.parquet"), extra={"recording": combined[1]})
    summary["columns"] = column_units()
    fill_digests(summary["inputs"], job.digests)
    write_json(summary, out.path("summary.json"))
    heads = {n: r["headline"] for n, r in summary["recordings"].items()}
    write_json(metadata(job.meta, summary["inputs"], heads, __version__), out.path("metadata.json"))
    for name, f in failures.items():
        verdict.append(f"{name}: not analysed: {f['error']}")
    failed = [{"file": n, "sha256": "", "channels": {}, "logs": [f"failed: {f['error']}"]} for n, f in failures.items()]
    write_report(
        out.path("report.html"),
        title="tribodyn: " + ", ".join(names + list(failures)),
        summary=_flat_summary(summary["recordings"]),
        params={n: r.params for n, (_, r) in zip(names, runs)},
        figures=figures,
        figures_note=" ".join(job.notes),
        quality={n: summary["recordings"][n]["gate_failures"] for n in names},
        verdict=verdict,
        inputs=list(job.inputs.values()) + failed,
        sections=sections,
        head_html=_bokeh_head(),
        durable=False,  # (OutputSet flushes the whole set before publishing it)
        record_html=record_html(job.meta, heads),
        inputs_note=_skipped_note(summary["skipped"]),
    )


def _skipped_note(skipped: Sequence[str]) -> str:
    """The report's line below its inputs for a folder's files that no reader takes (as the stderr line names
    them), or "" when none was skipped."""
    from ..pipeline.distributed import skipped_names

    return f"skipped (no reader takes them): {', '.join(skipped_names(skipped))}" if skipped else ""


#: Modules the output step imports (tables; figures), imported during the analysis. Bokeh is never imported: the
#: interactive views are built by BokehJS in the browser (``_interactive``).
_TABLE_MODULES = ("pyarrow", "pyarrow.parquet")
_OUTPUT_MODULES = (*_TABLE_MODULES, "matplotlib.figure", "matplotlib.backends.backend_agg")


#: Inputs of at least this many bytes (together) have Matplotlib imported during their analysis by default.
_EARLY_MATPLOTLIB_BYTES = 16 << 20


def _drawing_likely(figures: str, files: Sequence[str]) -> bool:
    """Whether Matplotlib is imported during the analysis: with ``--figures all``, or by default for inputs of
    :data:`_EARLY_MATPLOTLIB_BYTES` or more (long recordings, whose analysis the import overlaps; a small
    export's report often draws no PNG, and its analysis is too short to hide the import)."""
    if figures != "auto":
        return figures == "all"
    return _input_bytes(files) >= _EARLY_MATPLOTLIB_BYTES


def _import_in_background(modules: Sequence[str] = _OUTPUT_MODULES) -> threading.Thread:
    """A started thread importing ``modules`` (third-party only: the analysis imports none of them, so no module
    is imported from two threads at once; join it before the output step)."""

    def run() -> None:
        for name in modules:
            try:
                importlib.import_module(name)
            except Exception:  # noqa: BLE001, S112 - the output step imports it again and reports what is wrong
                continue

    thread = threading.Thread(target=run, name="tribodyn-imports", daemon=True)
    thread.start()
    return thread


#: The most drawing workers a job starts (:func:`_drawing_pool`).
_MAX_DRAW_WORKERS = 4
#: Seconds without any worker's answer after which the figures still out are drawn here and the pool is closed.
_DRAW_TIMEOUT = 120.0

# A drawing worker's first lines: bound to die with its parent (Linux: PR_SET_PDEATHSIG = 1, SIGKILL = 9) before it
# imports anything heavy, gone at once when the parent already is; then figures.serve_drawing.
_WORKER_CODE = """
import os, sys
parent = int(sys.argv[1])
if sys.platform.startswith("linux"):
    try:
        import ctypes
        ctypes.CDLL(None).prctl(ctypes.c_int(1), ctypes.c_ulong(9), ctypes.c_ulong(0), ctypes.c_ulong(0),
                                ctypes.c_ulong(0))
    except Exception:
        pass
if os.getppid() != parent:
    os._exit(0)
sys.path.insert(0, sys.argv[2])
from tribodyn.app.figures import serve_drawing
serve_drawing(parent)
"""


def _usable_cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def _input_bytes(files: Sequence[str]) -> int:
    size = 0
    for f in files:
        with contextlib.suppress(OSError):
            size += os.path.getsize(f)
    return size


def _pool_pays(figures: str, files: Sequence[str]) -> bool:
    """Whether drawing workers are started for ``tribodyn analyze``: PNG figures are drawn (``figures`` not
    ``"none"``) of inputs of :data:`_EARLY_MATPLOTLIB_BYTES` or more, whose analysis hides the workers' start (a
    small export draws few figures, if any, and is done before a worker has loaded Matplotlib)."""
    return figures != "none" and _input_bytes(files) >= _EARLY_MATPLOTLIB_BYTES


def _drawing_pool(pays: bool) -> Optional["_DrawingPool"]:
    """A started :class:`_DrawingPool` when ``pays`` and a core is free for a worker, else None (also when starting
    it fails: the figures are then drawn in this process).

    Workers: ``TRIBODYN_DRAW_WORKERS`` when set (0: none), else two fewer than the usable cores (this process
    draws too, beside its SHA-256 thread and its tables), at most :data:`_MAX_DRAW_WORKERS`; on two cores one
    while the other core is idle (load average under 1); none on one core, nor while the machine's load average
    (1 minute) is at or above its core count. On cores already busy a worker's start (about 1 s of CPU: Python,
    NumPy, Matplotlib) only adds to the work and the drawing is not done sooner; on two idle vCPUs one worker
    drew a 10 h recording's report 0.6-0.9 s sooner (benches/RESULTS.md).
    """
    if not pays:
        return None
    cores = _usable_cores()
    asked = os.environ.get("TRIBODYN_DRAW_WORKERS", "").strip()
    if asked:
        workers = int(asked) if asked.isdigit() else 0
    elif cores < 2 or _busy() or (cores == 2 and _load() >= 1.0):
        workers = 0
    else:
        workers = max(1, min(_MAX_DRAW_WORKERS, cores - 2))
    if workers < 1:
        return None
    try:
        return _DrawingPool(workers)
    except Exception:  # noqa: BLE001 - drawn here instead
        return None


def _load() -> float:
    """The machine's 1-minute load average (0 where the system does not tell)."""
    try:
        return float(os.getloadavg()[0])
    except (AttributeError, OSError):
        return 0.0


def _busy() -> bool:
    """Whether the machine's 1-minute load average is at least its core count (no core free for a worker)."""
    return _load() >= _usable_cores()


class _DrawingPool:
    """Worker processes that draw pickled figures to PNG (issue 38 point 3; ``figures.Rendering`` uses it).

    Each worker is a fresh interpreter (``subprocess``: spawned, never a fork of this threaded process) running
    ``figures.serve_drawing``; started before the analysis, it imports Matplotlib and draws a small figure
    meanwhile. It dies with this process (Linux: ``PR_SET_PDEATHSIG`` = SIGKILL, set before its imports, and a
    check that the parent is still there; elsewhere it polls its parent). A thread here per worker feeds it one
    figure at a time from the queue of the current :meth:`batch` once it said it is ready, so a worker still
    starting holds no figure; ``Rendering.finish`` draws here whatever no worker took. Nothing is printed: a
    worker's stderr goes to the null device, and whatever fails is drawn here.
    """

    def __init__(self, workers: int) -> None:
        import queue
        import subprocess
        import sys

        if not sys.executable:
            raise RuntimeError("no Python executable to start a drawing worker with")
        self._tasks: "queue.Queue[Any]" = queue.Queue()
        self._closed = False
        root = str(Path(__file__).resolve().parents[2])  # the folder holding this tribodyn package
        env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
        self._procs: List[Any] = []
        self._threads: List[threading.Thread] = []
        try:
            for _ in range(workers):
                self._procs.append(subprocess.Popen(
                    [sys.executable, "-c", _WORKER_CODE, str(os.getpid()), root], stdin=subprocess.PIPE,
                    stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env, close_fds=True))  # fmt: skip
        except Exception:
            self.close()
            raise
        self._threads = [threading.Thread(target=self._feed, args=(proc,), name="tribodyn-draw", daemon=True)
                         for proc in self._procs]  # fmt: skip
        for thread in self._threads:
            thread.start()

    def _feed(self, proc: Any) -> None:
        """Gives ``proc`` one queued figure after another, each answer to its batch; ends with the worker."""
        import pickle

        try:
            if pickle.load(proc.stdout)[0] != "ready":  # noqa: S301 - this process' own worker
                return
            while True:
                task = self._tasks.get()
                if task is None:
                    return
                batch, key, data = task
                try:
                    pickle.dump((key, data, batch.dpi, batch.rc), proc.stdin, protocol=pickle.HIGHEST_PROTOCOL)
                    proc.stdin.flush()
                    got, reply, _ = pickle.load(proc.stdout)  # noqa: S301 - this process' own worker
                except BaseException:
                    batch.done.put((key, None))
                    raise
                batch.done.put((key, reply if got == key else None))
        except Exception:  # noqa: BLE001, S110 - the worker is gone: the others and this process draw the rest
            pass

    def working(self) -> bool:
        """Whether a worker may still answer (its process and the thread that feeds it are there)."""
        return not self._closed and any(t.is_alive() for t in self._threads)

    def batch(self, payloads: Sequence[Optional[bytes]], dpi: int, rc: Mapping[str, Any]) -> Optional["_Batch"]:
        """Queues the pickled figures (None: drawn here) for the workers; None when the pool is closed."""
        if self._closed:
            return None
        batch = _Batch(self, len(payloads), [k for k, data in enumerate(payloads) if data is None], dpi, dict(rc))
        for k, data in enumerate(payloads):
            if data is not None:
                self._tasks.put((batch, k, data))
        return batch

    def close(self) -> None:
        """Ends every worker (idle ones hold nothing: killed) and its thread; later batches are drawn here."""
        self._closed = True
        while True:  # whatever is still queued: the batch's Rendering has drawn or will draw it here
            try:
                self._tasks.get_nowait()
            except Exception:  # noqa: BLE001 - empty
                break
        for _ in self._procs:
            self._tasks.put(None)
        for proc in self._procs:
            with contextlib.suppress(Exception):
                proc.kill()
            with contextlib.suppress(Exception):
                proc.wait(timeout=5.0)
            for fh in (proc.stdin, proc.stdout):
                with contextlib.suppress(Exception):
                    fh.close()

    def __enter__(self) -> "_DrawingPool":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


class _Batch:
    """One ``Rendering``'s figures in a :class:`_DrawingPool`: :meth:`steal` gives this process the figures no
    worker has taken, then :meth:`replies` the workers' answers."""

    def __init__(self, pool: _DrawingPool, n: int, here: List[int], dpi: int, rc: Dict[str, Any]) -> None:
        import queue

        self.pool, self.dpi, self.rc = pool, dpi, rc
        self.done: "queue.Queue[Tuple[int, Any]]" = queue.Queue()
        self._n = n
        self._here = list(here)  # figures that did not pickle
        self._stolen: List[int] = []

    def steal(self) -> Optional[int]:
        """The index of a figure of this batch no worker has taken (now this process'), or None."""
        if self._here:
            k = self._here.pop(0)
            self._stolen.append(k)
            return k
        while True:
            try:
                task = self.pool._tasks.get_nowait()
            except Exception:  # noqa: BLE001 - empty: every figure is taken
                return None
            if task is None or task[0] is not self:  # a closing pool's end mark (put back for its thread)
                self.pool._tasks.put(task)
                return None
            self._stolen.append(task[1])
            return int(task[1])

    def replies(self) -> Iterator[Tuple[int, Any]]:
        """(index, (PNG bytes, warnings) or None) of each figure not given by :meth:`steal`; None: to be drawn here
        (it did not pickle, its worker failed, every worker is gone, or no worker answered for
        :data:`_DRAW_TIMEOUT` s, which closes the pool)."""
        import queue
        import time

        left = set(range(self._n)) - set(self._stolen)
        for k in self._here:
            left.discard(k)
            yield k, None
        last = time.monotonic()
        while left:
            try:
                k, reply = self.done.get(timeout=0.25)
            except queue.Empty:
                if time.monotonic() - last < _DRAW_TIMEOUT and self.pool.working():
                    continue
                self.pool.close()
                for k in sorted(left):
                    yield k, None
                return
            last = time.monotonic()
            if k in left:
                left.discard(k)
                yield k, reply


def _replaced(res: Results, **changes: Any) -> Results:
    """``res`` with new warnings, keeping the results already computed from the rest (headline, verdict, the mu_r
    bootstrap): none is computed twice."""
    return res.replace(keep=("headline", "verdict", "mu_r_ci"), **changes)


def _steady_state(res: Results) -> Dict[str, Any]:
    """:func:`tribodyn.steady_states` of ``res`` as JSON (docs/method.md 6h): the one fit's dict, or for a
    recording of several tests or steps (the table's acquisitions) ``{"verdict": "per acquisition",
    "acquisitions": [each fit's dict], "text": each fit's text after its acquisition}``."""
    from ..analyses.steady import steady_states

    fits = [f.to_dict() for f in steady_states(res)]
    if len(fits) == 1:
        return fits[0]
    text = "; ".join(f"{f['series'].rsplit(', ', 1)[-1]}: {f['text']}" for f in fits)
    return {"verdict": "per acquisition", "acquisitions": fits, "text": text}


def _channel_map(rec: Any) -> Dict[str, str]:
    """Role -> 'channel (unit)' of an open recording, as the analysis read it (or why it is unavailable:
    ``rec`` is then the exception that opening it raised)."""
    if isinstance(rec, Exception):
        return {"?": f"channel map unavailable: {rec}"}
    units = {c.name: c.unit for c in rec.channels}
    return {r: _with_unit(str(c), units.get(c)) for r, c in dict(rec.roles).items()}


def _with_unit(name: str, unit: Optional[str]) -> str:
    """'Fn (N)' once, not 'Fn (N) (N)'; a unit the reader converted to after the name's own: 'x (mm) -> m'."""
    m = re.search(r"[\(\[]([^\(\)\[\]]*)[\)\]]\s*$", name)
    if unit is None:
        return f"{name} (no unit)"
    if m is None:
        return f"{name} ({unit})"
    return name if m.group(1).strip() == unit else f"{name} -> {unit}"


def _folders(names: Sequence[str]) -> List[str]:
    """Sub-folder names of the recordings' names (:func:`recording_labels`): file stems (``data``), after the
    folders that tell inputs of one file name apart, joined by ``_`` (``runA/data.tdms``: ``runA_data``), made
    unique with a counter where they repeat, case aside (``A/data.csv``, ``a/data.csv``: ``A_data-1``,
    ``a_data-2``, not two folders that are one on macOS's and Windows' file systems).

    A stem that is no folder name of its own (``..npz`` has the stem ``.``; ``.x.csv`` would make a hidden
    folder) loses its leading and trailing dots, then falls back to the file name's, then to "recording"
    (issue 34: an input named ``..npz`` lost its per-recording files); so do the folders' names."""
    stems = []
    for name in names:
        *folders, last = name.split("/")
        p = Path(last)
        stem = p.stem.strip(".") or p.name.strip(".") or "recording"
        stems.append("_".join([d.strip(".") for d in folders if d.strip(".")] + [stem]))
    counts = collections.Counter(s.casefold() for s in stems)
    out: List[str] = []
    taken: Set[str] = set()  # (the names given so far, case aside)
    for k, s in enumerate(stems):
        base = s if counts[s.casefold()] == 1 else f"{s}-{k + 1}"
        name, n = base, 1
        while name.casefold() in taken:  # (an input's stem that is another's with its counter: x-2.csv beside x, X)
            n += 1
            name = f"{base}-{n}"
        out.append(name)
        taken.add(name.casefold())
    return out


def _combine(results: Sequence[Results], names: Sequence[str]) -> Tuple[Results, np.ndarray]:
    table = {k: np.concatenate([r.table[k] for r in results]) for k in results[0].table}
    rec = np.concatenate([np.full(len(r), n, dtype=object) for r, n in zip(results, names)])
    nb = max(r.bin_counts.shape[1] for r in results)
    if any(r.bin_counts.shape[1] != nb for r in results):
        raise ValueError("recordings analysed with different n_bins cannot be combined")
    merged = Results(
        table=table,
        bin_counts=np.concatenate([r.bin_counts for r in results]),
        bin_cof=np.concatenate([r.bin_cof for r in results]),
        fz_min=np.concatenate([r.fz_min for r in results]),
        fz_max=np.concatenate([r.fz_max for r in results]),
        orientation=results[0].orientation,
        params={"recordings": list(names)},
    )
    return merged, rec.astype(str)
