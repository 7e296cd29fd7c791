"""The jobs behind the command line: the demo and the analysis of files.

Each job checks its output folder first (before the work: see
:class:`tribodyn.outputs.OutputSet`), analyses, then writes its outputs
all-or-nothing as one folder: per-window tables (CSV, Parquet),
``summary.json`` (COF statistics, optimum ranges, gate statistics, every
parameter, the tribodyn version, input names and SHA-256), figures (PNG) and
a self-contained ``report.html``. The folder then holds this set only (the
files of an earlier run into it are gone).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .analyze import analyze
from .identify import identify
from .outputs import OutputSet, input_provenance, write_json, write_table_csv, write_table_parquet
from .ranges import OperatingRange, operating_range
from .results import Results

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
    from .covariates import to_epoch_seconds

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
        return operating_range(res, by, **kw)  # type: ignore[arg-type]
    except ValueError:
        return None


def _example_window(channels: Mapping[str, np.ndarray], fs: float, start: int, n: int) -> Dict[str, Any]:
    ch = {k: np.asarray(v[start : start + n]) for k, v in channels.items() if k in ("fx", "fy", "fz")}
    res = identify(ch.get("fx"), ch["fy"], ch["fz"], fs=fs, max_lag=min(200, n - 1), rpm=250, n_lamellas=24)
    return {**ch, "fs": fs, "t0": start / fs, "result": res}


def _write_set(out: OutputSet, prefix: str, res: Results, extra: Optional[Dict[str, Any]] = None) -> List[str]:
    names = [f"{prefix}windows.csv"]
    write_table_csv(res, out.path(names[0]), extra=extra)
    if write_table_parquet(res, out.path(f"{prefix}windows.parquet"), extra=extra):
        names.append(f"{prefix}windows.parquet")
    return names


def _figures(
    res: Results,
    *,
    opr_t: Optional[OperatingRange],
    opr_j: Optional[OperatingRange],
    example: Optional[Dict[str, Any]],
):
    from .report import build_report_figures

    return build_report_figures(res, opr_temperature=opr_t, opr_current=opr_j, example=example)


def _save_figures(out: OutputSet, figs: Sequence[Tuple[str, Any]], prefix: str) -> List[str]:
    from .figures import save_figure

    names = []
    for k, (caption, fig) in enumerate(figs, 1):
        name = f"figures/{prefix}fig{k:02d}.png"
        save_figure(fig, out.path(name))
        names.append(name)
    return names


def run_demo(out_dir: Any, *, seed: int = 0, progress: bool = False, overwrite: bool = False) -> Dict[str, Any]:
    """Simulates the paper's two tests, analyses them and writes every output.

    ``out_dir`` is replaced as a whole (see :class:`~tribodyn.outputs.OutputSet`;
    ``overwrite`` allows replacing a folder that holds other files). Returns
    the summary (also written to ``summary.json``).
    """
    from . import __version__, simulate
    from .report import write_report

    output = OutputSet(out_dir, overwrite=overwrite)  # refuses an unusable folder before the work
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
    opr_t = operating_range(res_t, "temperature")
    opr_j = operating_range(res_j, "current_density")
    example = _example_window(sim_t.channels, sim_t.fs, start=1_500_000, n=2000)
    summary = {
        "tribodyn_version": __version__,
        "job": "demo: simulated temperature and current-density tests of the paper's rig (docs/method.md 8)",
        "seed": seed,
        "temperature_test": {
            **res_t.summary(),
            "operating_range": range_summary(opr_t),
            "simulated_optimum": dict(sim_t.truth.optimum),
            "simulated_breakpoints": _truth_breakpoints(res_t, sim_t.truth, "temperature"),
            "params": res_t.params,
        },
        "current_density_test": {
            **res_j.summary(),
            "operating_range": range_summary(opr_j),
            "simulated_optimum": dict(sim_j.truth.optimum),
            "simulated_breakpoints": _truth_breakpoints(res_j, sim_j.truth, "current_density"),
            "params": res_j.params,
        },
    }
    with output as out:
        files = _write_set(out, "temperature_", res_t) + _write_set(out, "current_density_", res_j)
        figs_t = _figures(res_t, opr_t=opr_t, opr_j=None, example=example)
        figs_j = _figures(res_j, opr_t=None, opr_j=opr_j, example=None)
        files += _save_figures(out, figs_t, "temperature_") + _save_figures(out, figs_j, "current_density_")
        summary["files"] = files + ["summary.json", "report.html"]
        write_json(summary, out.path("summary.json"))
        write_report(
            out.path("report.html"),
            title="tribodyn demo: the paper's rig, simulated",
            summary=_flat_summary(summary),
            params={"temperature test": res_t.params, "current-density test": res_j.params},
            figures=list(figs_t) + list(figs_j),
            quality={
                "temperature test": res_t.summary()["gate_failures"],
                "current-density test": res_j.summary()["gate_failures"],
            },
        )
    return summary


def _interval(ci: Any) -> str:
    if ci is None:
        return ""
    return f" [{ci[0]:.4g}, {ci[1]:.4g}]" if ci[0] is not None and ci[1] is not None else ""


def _breakpoint_rows(key: str, rng: Mapping[str, Any], val: Mapping[str, Any]) -> Dict[str, str]:
    """Breakpoints with their 95 % intervals per branch, next to the simulator's truth when known."""
    rows: Dict[str, str] = {}
    ci = rng.get("optimum_ci")
    if ci is None:
        return rows
    by, unit = rng["by"], rng["unit"]
    sim = val.get("simulated_optimum") or {}
    bath = val.get("simulated_breakpoints") or {}
    fits = {"all": rng, **{k[4:]: v for k, v in rng.items() if k.startswith("fit_")}}
    for name, f in fits.items():
        if not f or not f.get("optimum") or not f.get("optimum_ci"):
            continue
        (lo, hi), (lci, hci) = f["optimum"], f["optimum_ci"]
        text = f"{lo:.4g}{_interval(lci)} to {hi:.4g}{_interval(hci)} {unit}"
        truth = sim.get(by if name == "all" else f"{by}_{name}")
        if truth is not None:
            text += f"; simulated flat bottom {truth[0]:g} to {truth[1]:g}"
        b = bath.get(name)
        if b is not None:
            fmt = lambda v: "none" if v is None else f"{v:.4g}"  # noqa: E731
            text += f"; the same fit of the simulated COF {fmt(b['lower'])} to {fmt(b['upper'])}"
        rows[f"{key}: breakpoints [95 % interval], {name}"] = text
    return rows


def _flat_summary(summary: Mapping[str, Any]) -> Dict[str, Any]:
    """A short, readable summary for the report's first table."""
    out: Dict[str, Any] = {}
    for key, val in summary.items():
        if isinstance(val, Mapping) and "mu_r" in val:
            mu = val["mu_r"]
            out[f"{key}: windows (gated)"] = f"{val['windows']} ({val['gated']})"
            if mu.get("n"):
                out[f"{key}: mu_r median [p05, p95]"] = f"{mu['median']:.4f} [{mu['p05']:.4f}, {mu['p95']:.4f}]"
                ci = (mu.get("ci") or {}).get("median")
                if ci is not None:
                    out[f"{key}: mu_r median, 95 % interval"] = f"{ci[0]:.4f} to {ci[1]:.4f}"
            for rng in (val[k] for k in val if k.startswith("operating_range")):
                if rng and rng.get("verdict"):
                    out[f"{key}: verdict ({rng['by'].replace('_', ' ')})"] = f"{rng['verdict']}: {rng['explanation']}"
                if not rng or not rng.get("optimum"):
                    continue
                lo, hi = rng["optimum"]
                by = rng["by"].replace("_", " ")
                out[f"{key}: optimum {by}"] = f"{lo:g} to {hi:g} {rng['unit']} (mu_min {rng['mu_min']:.4f})"
                out.update(_breakpoint_rows(key, rng, val))
                if rng.get("onset") is not None:
                    out[f"{key}: instability onset ({by})"] = f"{rng['onset']:.3g} {rng['unit']}"
        elif not isinstance(val, (Mapping, list)):
            out[key] = val
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
) -> Dict[str, Any]:
    """Analyses recording files and writes the outputs into ``out_dir``.

    ``paths`` may hold files, directories and glob patterns. One recording:
    its tables, figures and report at the top of ``out_dir``. Several: one
    sub-folder per recording plus a combined table (with a ``recording``
    column), summary and report at the top. With a Dask ``client`` the
    recordings (and ranges of ``split`` seconds of long ones) run on the
    cluster (:func:`tribodyn.analyze_many`). A recording that fails is listed
    in ``summary["failures"]``; if every one fails, the first error is raised.

    ``out_dir`` is checked before the work and replaced as a whole (see
    :class:`~tribodyn.outputs.OutputSet`): a folder holding anything but a
    previous output set is refused unless ``overwrite``; a folder holding
    an input file, or one of the files ``protect`` names, always.
    """
    from . import __version__
    from .distributed import analyze_many, expand_paths
    from .report import write_report

    open_options = dict(open_options or {})
    opts = dict(analyze_options or {})
    if not paths:
        raise ValueError("no input file given")
    files = expand_paths(paths)
    output = OutputSet(out_dir, overwrite=overwrite, protect=[*files, *protect])
    if len(files) == 1 and client is None and split is None:
        # One file, here: read it directly (progress bar over its samples).
        from .io import open_recording

        with open_recording(files[0], **open_options) as rec:
            runs = [(Path(files[0]), analyze(rec, progress=progress, **opts))]
        failures: Dict[str, Any] = {}
    else:
        many = analyze_many(files, client=client, open_options=open_options, split=split, progress=progress, **opts)
        if not many.results:
            first = next(iter(many.failures.values()))
            raise ValueError(f"{Path(first.path).name}: {first.error}")
        runs = [(Path(p), r) for p, r in many.results.items()]
        failures = {Path(p).name: {"error": f.error, "kind": f.kind} for p, f in many.failures.items()}

    summary: Dict[str, Any] = {
        "tribodyn_version": __version__,
        "inputs": input_provenance([p for p, _ in runs]),
        "open_options": open_options,
        "recordings": {},
        "failures": failures,
    }
    single = len(runs) == 1 and not failures
    labels = _labels([p for p, _ in runs])
    with output as out:
        all_figs = []
        for (p, res), label in zip(runs, labels):
            prefix = "" if single else f"{label}/"
            opr_t = _try_range(res, "temperature")
            opr_j = _try_range(res, "current_density")
            files = _write_set(out, prefix, res)
            figs = _figures(res, opr_t=opr_t, opr_j=opr_j, example=None)
            files += _save_figures(out, figs, prefix)
            rec_sum = {
                **res.summary(),
                "operating_range_temperature": range_summary(opr_t),
                "operating_range_current_density": range_summary(opr_j),
                "params": res.params,
                "files": files,
            }
            summary["recordings"][p.name] = rec_sum
            if not single:
                write_json(rec_sum, out.path(f"{prefix}summary.json"))
                write_report(
                    out.path(f"{prefix}report.html"),
                    title=f"tribodyn: {p.name}",
                    summary=_flat_summary({p.name: rec_sum}),
                    params=res.params,
                    figures=figs,
                    quality=rec_sum["gate_failures"],
                )
            all_figs += [(f"{p.name}: {c}", f) for c, f in figs]
        if not single:
            combined = _combine([r for _, r in runs], [p.name for p, _ in runs])
            write_table_csv(combined[0], out.path("windows.csv"), extra={"recording": combined[1]})
            write_table_parquet(combined[0], out.path("windows.parquet"), extra={"recording": combined[1]})
        write_json(summary, out.path("summary.json"))
        write_report(
            out.path("report.html"),
            title="tribodyn: " + ", ".join(p.name for p, _ in runs),
            summary=_flat_summary(summary["recordings"]),
            params={p.name: r.params for p, r in runs},
            figures=all_figs,
            quality={p.name: r.summary()["gate_failures"] for p, r in runs},
        )
    return summary


def _labels(paths: Sequence[Path]) -> List[str]:
    """Sub-folder names: file stems, made unique with a counter where they repeat."""
    stems = [p.stem for p in paths]
    return [s if stems.count(s) == 1 else f"{s}-{k + 1}" for k, s in enumerate(stems)]


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
