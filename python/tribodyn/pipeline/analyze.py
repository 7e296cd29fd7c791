"""Long recordings: ``tribodyn.analyze`` (docs/method.md section 6; the pipeline: docs/architecture.md).

Reads a recording chunk by chunk, optionally high-passes raw (DC-coupled)
channels with the streaming filter, cuts windows of ``window`` s every
``hop`` s, computes each window's COF statistics in the Rust kernel, joins
temperature and current, and fixes the orientation once for the recording.
The per-window table does not depend on the format, the chunk size or the
thread count, and memory does not grow with the recording's length.

This module orchestrates one analysis: the options are checked once into a
:class:`~tribodyn.pipeline.plan.Plan`; the tribometer pre-pass (docs/method.md 6a-6d)
and, for a reciprocating test, the strokes (:mod:`tribodyn.pipeline.strokes`) are
found; :mod:`tribodyn.pipeline.routes` reads the source on the route it chooses and
runs the kernel; :mod:`tribodyn.pipeline.finish` turns the kernel's statistics into
the table and settles the headline.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping
from concurrent.futures import Future
from typing import Any, Callable, Dict, Optional, Sequence, Tuple, Union

import numpy as np

# NumPy's submodules an analysis uses (find_lag's FFT, the bootstrap's generator, np.median's NaN check
# imports numpy.ma), imported with this module rather than inside the first call (issue 25: no imports
# inside analyze; `import tribodyn` itself stays lazy).
import numpy.fft  # noqa: F401
import numpy.ma  # noqa: F401
import numpy.random  # noqa: F401

from ..io.base import RecordingProtocol, cof_like
from ..io.dataframe import from_dataframe
from ..io.constant import mapping_with_load, with_load
from ..io.units import check_role_units
from ..kernels._validate import Orientation, check_1d
from ..kernels.deadband import DeadbandSpec
from ..kernels.threads import reading, resolve_threads, side_job
from ..options import defaults, parameters_doc
from ..results import ClassicalTotals, Results
from .covariates import align_to_recording
from .finish import ALIGN_MIN, finish, settle
from .budget import statistics_of, with_budget
from .headline import classical_totals
from .instrument import ChosenLag, find_lag
from .plan import Findings, Plan, make_plan
from .prepass import prepass
from . import passes
from .routes import PIPELINE_ROLES, PassInputs, Tap, concat_stats, run
from .strokes import stroke_windows

__all__ = ["analyze", "analyze_partial", "combine", "Partial"]


#: The line of :func:`analyze`'s docstring that the options' entries replace (docs/architecture.md: an option is
#: declared once, with its docstring entry, in :data:`tribodyn.options.OPTIONS`).
_OPTIONS_DOC = "    [each option of tribodyn.options.OPTIONS, written here at import by options.parameters_doc]"


def _is_recording(source: Any) -> bool:
    return hasattr(source, "chunks") and hasattr(source, "fs") and not isinstance(source, Mapping)


def analyze(
    source: Any,
    plan: Optional[Plan] = None,
    *,
    fs: Optional[float] = None,
    window: Optional[float] = None,
    hop: Optional[float] = None,
    highpass: Optional[float] = None,
    orientation: Orientation = "auto",
    temperature: Any = None,
    current: Any = None,
    voltage: Any = None,
    shunt_ohm: Optional[float] = None,
    area_mm2: Optional[float] = None,
    covariates: Optional[Mapping[str, Any]] = None,
    chunk: Optional[float] = None,
    progress: bool = False,
    deadband: DeadbandSpec = 0.35,
    n_bins: int = 16,
    gate: Union[float, str, None] = None,
    max_lag: Optional[int] = None,
    rpm: Optional[float] = None,
    n_lamellas: Optional[int] = None,
    threads: Optional[int] = None,
    start: int = 0,
    stop: Optional[int] = None,
    estimator: Optional[str] = None,
    method: Optional[str] = None,
    max_rel_ci: Optional[float] = None,
    align: Optional[str] = None,
    iv_lag: Optional[float] = None,
    noise: Any = None,
    motion: str = "auto",
    min_fn: Optional[float] = None,
    tare: Any = None,
    stroke_fraction: float = 0.5,
    stick_slip: bool = False,
    uncertainty: Optional[Mapping[str, Any]] = None,
    load: Optional[float] = None,
    channels: Optional[Mapping[str, str]] = None,
) -> Results:
    """COF of every window of a long recording (docs/method.md 6).

    Parameters
    ----------
    source : mapping, iterable of mappings, list of acquisitions, or Recording
        - a mapping role -> 1-D array with ``fy``, ``fz`` (required), ``fx``,
          ``i`` (current, A) or ``u`` (shunt voltage, V), and ``cof`` (an
          instrument's own COF column, averaged per window as
          ``mu_instrument`` for comparison);
        - an iterator of such mappings: consecutive chunks of one recording
          (how a reader streams from disk);
        - a list (or tuple) of mappings: separate acquisitions, each one
          window (an optional scalar ``"t0"`` entry gives its start time in
          s; otherwise acquisitions are taken as back to back);
        - a recording from :func:`tribodyn.open_recording` (read in chunks);
          its separate acquisitions (``Recording.acquisitions``: CETR steps,
          time restarts, LVM segments marked discontinuous) are windowed
          apart, each from its first sample: no window straddles two;
        - a pandas DataFrame: columns named by role, or mapped with
          ``channels={"fy": "Ft", ...}``; fs from a ``time`` column or the
          index when not given;
        - a path (str or os.PathLike): the file is opened with
          ``tribodyn.open_recording(path, fs=fs, channels=channels)`` (its
          other options at their defaults; open it yourself to set them),
          analysed and closed.
    plan : Plan, optional
        Every option below checked once (:func:`tribodyn.make_plan`), for a
        source sampled at ``plan.fs``; with a plan no other option is given
        (``channels`` and ``fs`` excepted, which say how to read the source).
        The options, their defaults, units, flags and sections are declared
        once in :data:`tribodyn.options.OPTIONS`.
    [each option of tribodyn.options.OPTIONS, written here at import by options.parameters_doc]

    Returns
    -------
    Results
        Per-window table (columns in :data:`tribodyn.columns.TABLE`), bins
        and the parameters used (``params["route"]`` names the route taken).

    Raises
    ------
    ValueError, TypeError
        fs <= 0, window or hop <= 0, threads outside 1 .. 4 x the CPU count,
        a window longer than the recording, a missing or unequal channel, a
        NaN or inf in a window (naming the channel and the window), a bad
        temperature log, a voltage without ``shunt_ohm``.
    RecordingError
        The recording cannot be read.
    """
    options = {k: v for k, v in locals().items() if k not in ("source", "plan")}
    if isinstance(source, (str, os.PathLike)):  # a file: opened as open_recording does by default
        from ..io import open_recording

        with open_recording(source, fs=fs, channels=options.pop("channels"), load=options.pop("load")) as rec:
            return analyze(rec, plan, **options)
    res = _analyze(source, plan, options, partial=False)
    assert isinstance(res, Results)
    return res


if analyze.__doc__:  # (None under python -OO)
    analyze.__doc__ = analyze.__doc__.replace(_OPTIONS_DOC + "\n", parameters_doc())


@dataclasses.dataclass(frozen=True)
class Partial:
    """The kernel's statistics of one range of a recording, before the finishing step (docs/method.md 6, 9).

    What a worker of :func:`tribodyn.analyze_many` returns for a range:
    :func:`combine` joins the ranges of one recording and finishes them
    once, so that every recording-wide quantity (the orientation, the
    noise on fz of the corrected estimator) comes from all its windows and
    the table is exactly the one of a single pass.
    """

    st: Dict[str, np.ndarray]
    aux_role: Optional[str]
    plan: Plan
    route: str
    warnings: Tuple[str, ...]
    #: What the pre-pass found and the role map (docs/method.md 6a-6d), for ``Results.params``.
    tribo: Dict[str, Any] = dataclasses.field(default_factory=dict)
    #: The per-stroke table of a reciprocating test (the whole recording's, the same in every range).
    strokes: Optional[Dict[str, np.ndarray]] = None
    #: The classical COF's block sums over this range (docs/method.md 6a, 6e), or None.
    classical: Optional[ClassicalTotals] = None
    #: What the pre-pass found in the data (the classical COF's threshold and tare).
    found: Findings = Findings()
    #: The pre-pass's own result (motion, contact, tare; docs/method.md 6a-6d), for a later range's ``reuse``.
    pre: Dict[str, Any] = dataclasses.field(default_factory=dict)


def analyze_partial(source: Any, plan: Optional[Plan] = None, *, reuse: Optional[Partial] = None,
                    reuse_lag: Optional[Partial] = None, **options: Any) -> Partial:  # fmt: skip
    """:func:`analyze` up to the finishing step (same options; ``align`` must be None).

    ``reuse``: an earlier range of the same recording whose pre-pass findings and instrument lag this range
    takes as they are, without looking at the data again (a watched recording, docs/method.md 11).
    ``reuse_lag``: an earlier range whose instrument lag this range takes while the pre-pass looks again: the
    recording then held every window the lag is chosen from (``pipeline.instrument.lag_sample_held``).
    """
    if options.get("align") is not None or (plan is not None and plan.align is not None):
        raise ValueError("align='auto' needs the whole recording: analyse it in one piece, or pass the delay yourself")
    return _analyze(source, plan, options, partial=True, reuse=reuse, reuse_lag=reuse_lag)  # type: ignore[return-value]


def combine(parts: Sequence[Partial], *,
            intervals: Optional[Callable[[Results], Optional[Mapping[str, Any]]]] = None) -> Results:  # fmt: skip
    """The ranges of one recording, in order, finished once (exactly the table of one pass over them).

    ``intervals``: called with the finished Results before its headline is chosen; the bootstrap intervals it
    returns (``{"mu_r_ci": ..., "column_ci": ...}``, the values of those properties of Results) stand in for the
    bootstrap's, None lets the bootstrap run (a watched recording's snapshot between two bootstraps,
    docs/method.md 11).
    """
    if not parts:
        raise ValueError("no ranges to combine")
    # finish flips a recording's COF arrays in place (orientation -1; no copy of a long table): a lone part's
    # arrays are copied (several are joined into new ones), so its parts stay as the kernel gave them and can be
    # combined again (a watch's snapshots)
    st = concat_stats(
        [dict(p.st) for p in parts] if len(parts) > 1 else [{k: np.array(v, copy=True) for k, v in parts[0].st.items()}]
    )
    warnings = tuple(dict.fromkeys(w for p in parts for w in p.warnings))
    span = (parts[0].plan.start, parts[-1].plan.stop)
    res = finish(st, parts[0].aux_role, parts[0].plan, parts[0].found, route=parts[0].route, warnings=warnings,
                 span=span)  # fmt: skip
    params = {**res.params, **parts[0].tribo}
    params["n_samples_total"] = sum(int(p.tribo.get("n_samples_total", 0)) for p in parts)
    if len(parts) > 1:
        params.update(start=0, stop=None, ranges=len(parts))
    totals = [p.classical for p in parts if p.classical is not None]
    res = dataclasses.replace(res, strokes=parts[0].strokes, params=params,
                              classical=ClassicalTotals.merge(totals) if totals else None)  # fmt: skip
    given = intervals(res) if intervals is not None else None
    if given is not None:  # the cached properties' values (settle keeps them)
        res = res.replace(cached={k: dict(given[k]) for k in ("mu_r_ci", "column_ci") if k in given})
    return settle(res)


def _analyze(source: Any, plan: Optional[Plan], options: Dict[str, Any], partial: bool,
             reuse: Optional[Partial] = None, *,
             reuse_lag: Optional[Partial] = None) -> Union[Results, Partial]:  # fmt: skip
    """:func:`_analyze_body` with the call's thread count for the readers' native parses (text files)."""
    if plan is not None and not isinstance(plan, Plan):
        raise TypeError(f"plan must be a tribodyn.Plan (tribodyn.make_plan(...)), got {type(plan).__name__}")
    try:
        n: Optional[int] = plan.threads if plan is not None else resolve_threads(options.get("threads"))
    except (TypeError, ValueError):
        n = None  # the plan says why
    with reading(n):
        return _analyze_body(source, plan, options, partial, reuse, reuse_lag=reuse_lag)


def _as_source(source: Any, options: Dict[str, Any]) -> Tuple[Any, Optional[RecordingProtocol], Any]:
    """(source, recording or None, fs): a DataFrame as a mapping of its columns by role (``channels=``)."""
    fs, channels, load = options.pop("fs", None), options.pop("channels", None), options.pop("load", None)
    if _is_dataframe(source):
        source, fs = from_dataframe(source, channels, fs)
    elif channels is not None:
        raise TypeError("channels= maps the columns of a pandas DataFrame; map a recording's with open_recording")
    # docs/method.md 6a: a given load is the channel fz; a COF-only source's fy is its COF x fz (the headline is
    # then the instrument's COF: params["friction_from"])
    source = with_load(source, load) if _is_recording(source) else mapping_with_load(source, load)
    rec: Optional[RecordingProtocol] = source if _is_recording(source) else None
    if rec is not None:
        _check_roles(rec)
    if rec is not None and hasattr(rec, "channels"):  # units that make the COF wrong (docs/method.md 6f)
        errors = check_role_units(rec.channels)[0]
        if errors:
            raise ValueError(f"{os.path.basename(str(rec.path))}: {errors[0]}")
    if fs is None and rec is not None:
        fs = rec.fs
    if rec is None:
        _check_shapes(source)
    return source, rec, fs


def _check_roles(rec: Any) -> None:
    """A recording without ``fy`` or ``fz`` is refused before any reading, with its channels and how to map
    them (the pipeline's own message would name its first chunk)."""
    from ..io.roles import missing_roles

    roles = getattr(rec, "roles", None)
    if not isinstance(roles, Mapping):
        return
    missing, mapped, shown = missing_roles(roles, list(getattr(rec, "channel_names", None) or []))
    if not missing:
        return
    example = ", ".join(f"{r!r}: CHANNEL" for r in missing)
    raise ValueError(
        f"{os.path.basename(str(getattr(rec, 'path', '') or 'the recording'))}: lacks the required channel(s) "
        f"{', '.join(missing)} (mapped: {mapped}); its channels: {shown}; map them with "
        f"channels={{{example}}} (open_recording, or analyze of the file's path)"
        + ("; a test whose load is a constant: pass load= (--load N)" if missing == ["fz"] else "")
    )


def _check_shapes(source: Any) -> None:
    """A mapping's (or a list of mappings') channels are 1-D, checked before the pre-pass and the lag search
    look at them (the message is the pipeline's own, which names each chunk)."""
    acqs = [source] if isinstance(source, Mapping) else source if isinstance(source, (list, tuple)) else ()
    for i, chunk in enumerate(acqs):
        if not isinstance(chunk, Mapping):
            return  # the pipeline names what a chunk must be
        for k, v in chunk.items():
            if k in PIPELINE_ROLES:
                check_1d(np.shape(v), f"chunk {i}[{k!r}]")


def _plan_of(given: Optional[Plan], fs: Any, rec: Optional[RecordingProtocol], options: Dict[str, Any]) -> Plan:
    """The analysis's plan: ``given`` (no other option with it), else made from ``options`` (docs/method.md 6)."""
    if given is not None:
        default = defaults()
        changed = sorted(k for k, v in options.items() if not _is_default(v, default.get(k)))
        if changed:
            raise TypeError(f"analyze(..., plan=...) takes no other options; make the plan with them: {changed}")
        if fs is not None and float(fs) != given.fs:
            raise ValueError(f"the plan is for fs = {given.fs:g} Hz, the source is sampled at {float(fs):g} Hz")
        return given
    if fs is None:
        raise TypeError("analyze needs fs= (the sampling rate in Hz)")
    if rec is not None:  # logs with absolute times start at the reader's start time (docs/method.md 6)
        for name in ("temperature", "current", "voltage"):
            options[name] = align_to_recording(options.get(name), rec, name)
        logs = options.get("covariates")
        if isinstance(logs, Mapping):
            options["covariates"] = {k: align_to_recording(x, rec, f"covariates[{k!r}]") for k, x in logs.items()}
    return make_plan(fs=fs, **options)


def _is_default(value: Any, default: Any) -> bool:
    """Whether an option was left at its default (a value compared only when it is a plain scalar)."""
    plain = (type(None), bool, int, float, str)
    return value is default or (type(value) in plain and type(default) in plain and value == default)


def _check_range(source: Any, rec: Optional[RecordingProtocol], plan: Plan) -> None:
    """``stop=`` applies to a recording, within its samples."""
    if plan.stop is None:
        return
    if rec is None:
        raise ValueError(
            "stop= applies to a recording source (a mapping or a stream of chunks ends where it ends; slice it instead)"
        )
    if plan.stop > rec.n_samples:
        raise ValueError(
            f"stop must satisfy start <= stop <= {rec.n_samples} (the recording's samples), "
            f"got start={plan.start}, stop={plan.stop}"
        )


def _analyze_body(source: Any, given: Optional[Plan], options: Dict[str, Any], partial: bool,
                  reuse: Optional[Partial] = None, *,
                  reuse_lag: Optional[Partial] = None) -> Union[Results, Partial]:  # fmt: skip
    """:func:`analyze`'s body: ``options`` are its keyword arguments (without ``plan``); ``reuse``: an earlier
    range whose findings this one takes, ``reuse_lag`` one whose lag it takes (:func:`analyze_partial`)."""
    from_cof = _cof_only(source)  # before _as_source derives fy from the COF (docs/method.md 6a)
    source, rec, fs = _as_source(source, options)
    plan = _plan_of(given, fs, rec, options)
    _check_range(source, rec, plan)
    if reuse is not None and reuse.pre:
        pre, found = reuse.pre, reuse.found
    else:
        earlier = reuse_lag.found if reuse_lag is not None else None
        ahead = _lag_ahead(source, rec, plan, partial, earlier)  # find_lag beside the pre-pass, when it may
        try:
            pre = prepass(source, rec, plan.fs, min_fn=plan.min_fn, tare=plan.tare, motion=plan.motion)
        except BaseException:
            if ahead is not None:  # nothing of the analysis reads the source after this call returns
                ahead.exception()
            raise
        lag = find_lag(source, rec, plan, pre, partial, earlier=earlier) if ahead is None else _lag_of(ahead, pre)
        found = Findings(
            classical=pre.get("spec"),
            iv_lag_samples=None if lag is None else lag.samples,
            iv_lag_shifts=() if lag is None else lag.shifts,
            iv_lag_others=() if lag is None else lag.others,
        )  # docs/method.md 3b, 3d
    tribo = _tribometer_params(rec, pre, plan.window_note)
    if from_cof:  # the headline is the instrument's own COF (docs/method.md 6e)
        tribo["friction_from"] = "cof"
        tribo["cof_channel"] = str(rec.roles["cof"]) if rec is not None else "cof"
    strokes: Optional[Dict[str, np.ndarray]] = None
    stroke_stats = None  # the per-stroke COF's statistics for its budget (docs/method.md 6i)
    run_source, run_rec = source, rec
    if pre.get("motion") == "reciprocating":
        tribo["stroke_fraction"] = plan.stroke_fraction
        cut = stroke_windows(source, rec, plan, found, partition=partial)
        if cut is not None:
            # docs/method.md 6c: the windows are the strokes' central parts, fy rectified (an acquisition each).
            strokes, run_source, stroke_stats = cut
            run_rec = None
            tribo["rectified"] = True
            if not run_source:
                raise ValueError("no stroke's central part holds 3 samples: no window to analyse")
    contact = pre.get("contact")
    own = tuple(w for w in (plan.window_note, contact.note if contact is not None else "") if w)  # its notes
    c_start, c_stop = _sample_range(source, rec, plan, partial)
    tribo["n_samples_total"] = c_stop - c_start

    def classical_pass(sums: Optional[ClassicalTotals]) -> Optional[ClassicalTotals]:  # docs/method.md 6a, 6e
        """The classical COF's sums over every sample in contact: the main pass's, else read again."""
        if found.classical is None or strokes is not None:
            return None
        return sums if sums is not None else classical_totals(source, rec, found.classical, c_start, c_stop)

    span = (c_start, c_stop) if strokes is None else None
    if partial:  # the ranges are combined elsewhere, without the file: the sums are taken here
        k = run(run_source, run_rec, plan, found, span)
        warnings = k.warnings + tuple(rec.warnings if rec is not None else ()) + own
        return Partial(k.st, k.aux_role, plan, k.route, tuple(dict.fromkeys(warnings)), tribo=tribo,
                       strokes=strokes, classical=classical_pass(k.classical), found=found, pre=pre)  # fmt: skip
    # the optional passes (pipeline/passes.py): their taps see the main pass's chunks
    inputs = PassInputs(source, rec, plan, found, {**tribo, "fs": plan.fs, "start": plan.start, "stop": plan.stop},
                        strokes)  # fmt: skip
    tapped = passes.taps(inputs)
    res, sums = _analyze_aligned(run_source, run_rec, plan, found, span, taps=[t for t in tapped if t is not None])
    if run_rec is not rec and rec is not None:
        res = dataclasses.replace(res, warnings=tuple(dict.fromkeys((*rec.warnings, *res.warnings))))
    res = dataclasses.replace(res, params={**res.params, **tribo})
    if own:
        res = dataclasses.replace(res, warnings=res.warnings + own)
    res = dataclasses.replace(res, strokes=strokes)
    res = passes.store(inputs, tapped, res)  # (before settle, which keeps the headline it computes: no copy after it)
    res = settle(res, lambda: classical_pass(sums))
    if plan.uncertainty is not None:  # docs/method.md 6i: the headline's statistics, then its budget
        res = with_budget(res, statistics_of(res, source, rec, found.classical, (c_start, c_stop),
                                             strokes=stroke_stats))  # fmt: skip
    return res


def _lag_ahead(source: Any, rec: Optional[RecordingProtocol], plan: Plan, partial: bool,
               earlier: Optional[Findings]) -> "Optional[Future[Optional[ChosenLag]]]":  # fmt: skip
    """:func:`find_lag` started on a thread of its own, to run while the pre-pass runs (issue 38 point 2), or None
    (then it runs after the pre-pass, as it always may).

    Only where the two cannot tell they ran together: a call with two threads or more that would read the
    source (the plan leaves the lag to the data, no earlier range gives it), and a source read by position
    with no state and no warning: a recording whose channels are plain contiguous runs read by ``pread``
    (``mappable``, ``random_access`` and ``thread_safe``), or a mapping or list of mappings of NumPy arrays.
    The lag does not depend on the pre-pass's findings except that a reciprocating test takes none
    (:func:`_lag_of`); the thread sees the call's context (its thread count).
    """
    if plan.threads < 2 or plan.paper or not plan.iv_lag_from_data or (earlier is not None and partial):
        return None
    if rec is not None:
        if not all(getattr(rec, k, False) is True for k in ("mappable", "random_access", "thread_safe")):
            return None
    else:
        acqs = [source] if isinstance(source, Mapping) else source if isinstance(source, (list, tuple)) else ()
        if not acqs or not all(isinstance(a, Mapping) and all(isinstance(a.get(r), np.ndarray) for r in ("fy", "fz"))
                               for a in acqs):  # fmt: skip
            return None
    return side_job(find_lag, source, rec, plan, {}, partial, earlier=earlier)


def _lag_of(job: "Future[Optional[ChosenLag]]", pre: Mapping[str, Any]) -> Optional[ChosenLag]:
    """The lag :func:`_lag_ahead` found, as :func:`find_lag` with the pre-pass's findings gives it: none for a
    reciprocating test (whose lag would not have been looked for: an error of that look is not raised)."""
    if pre.get("motion") == "reciprocating":
        job.exception()
        return None
    return job.result()


def _sample_range(source: Any, rec: Optional[RecordingProtocol], plan: Plan, partial: bool) -> Tuple[int, int]:
    """The samples ``(a, b)`` the headline's classical pass covers (docs/method.md 6e); (0, 0) for a stream.

    The analysed range ``plan.start``..``plan.stop``; for a range of
    :func:`tribodyn.analyze_many` (``partial``), up to the next range's
    first window (ranges of overlapping or spaced windows partition the
    samples), and the last one to the end of the recording.
    """
    if rec is not None:
        n = int(rec.n_samples)
    elif isinstance(source, Mapping) and "fz" in source:
        n = len(source["fz"])
    elif isinstance(source, (list, tuple)) and source and all(isinstance(a, Mapping) and "fz" in a for a in source):
        n = sum(len(a["fz"]) for a in source)
    else:
        return 0, 0
    stop = n if plan.stop is None else min(int(plan.stop), n)
    if partial and plan.stop is not None:
        nxt = int(plan.stop) - plan.length + plan.step
        stop = n if nxt + plan.length > n else min(nxt, n)
    start = min(int(plan.start), stop)
    return start, stop


def _is_dataframe(source: Any) -> bool:
    return type(source).__name__ == "DataFrame" and hasattr(source, "columns") and hasattr(source, "index")


def _cof_only(source: Any) -> bool:
    """Whether the source's only friction information is a COF column (``cof`` and no ``fy``)."""
    if isinstance(source, Mapping):
        return "cof" in source and "fy" not in source
    if isinstance(source, (list, tuple)) and source and all(isinstance(c, Mapping) for c in source):
        return all("cof" in c and "fy" not in c for c in source)
    if _is_recording(source):
        return bool(getattr(source, "friction_from_cof", False)) or ("cof" in source.roles and "fy" not in source.roles)
    return False


def _tribometer_params(rec: Optional[RecordingProtocol], pre: Dict[str, Any], window_note: str) -> Dict[str, Any]:
    """What the pre-pass found and the role map, for ``Results.params`` (docs/method.md 6a-6d)."""
    out: Dict[str, Any] = {"motion": pre.get("motion", "unidirectional"),
                           "motion_detected": bool(pre.get("motion_detected"))}  # fmt: skip
    if "sign_flip_share" in pre:
        out["sign_flip_share"] = pre["sign_flip_share"]
    if pre.get("motion_evidence"):
        out["motion_evidence"] = pre["motion_evidence"]
    if "static" in pre:
        out["static_fz"] = bool(pre["static"])
    spec = pre.get("spec")
    if spec is not None:
        out["min_fn"] = spec.min_fn
        out["tare_offsets"] = {"fy": spec.tare_fy, "fz": spec.tare_fz}
    contact = pre.get("contact")
    if contact is not None:
        out["contact"] = {"rule": contact.rule, "unloaded_fraction": contact.unloaded_fraction,
                          "excluded_fraction": contact.excluded_fraction, "note": contact.note}  # fmt: skip
    if window_note:
        out["window_note"] = window_note
    if rec is not None:
        out["roles"] = dict(rec.roles)
        out["roles_source"] = rec.roles_source
        cof = rec.roles.get("cof")
        names = list(getattr(rec, "channel_names", None) or [])
        others = [c for c in cof_like(names) if c != cof and c not in rec.roles.values()]
        if cof is not None and others:  # docs/method.md 6e: the COF column used is named, the others listed
            out["other_cof_channels"] = others
        choice = rec.role_choice
        if choice is not None:  # docs/method.md 6e
            out["roles_evidence"] = choice.as_dict()
    return out


def _analyze_aligned(source: Any, rec: Optional[RecordingProtocol], plan: Plan, found: Findings,
                     span: Optional[Tuple[int, int]] = None, *, taps: Sequence[Tap] = ()
                     ) -> Tuple[Results, Optional[ClassicalTotals]]:  # fmt: skip
    """The analysis, with align="auto"'s second pass when the plan asks for it (docs/method.md 3e), and the
    classical COF's sums over ``span`` when the main pass took them (:func:`tribodyn.pipeline.routes.run`); ``taps``
    take the first pass's raw chunks."""
    if plan.align == "auto":
        if not (rec is not None or isinstance(source, (Mapping, list, tuple))):
            raise ValueError(
                "align='auto' reads the source twice (to measure the delay, then to correct it): pass a mapping of "
                "arrays, a list of acquisitions or a recording, not a one-pass stream of chunks"
            )
        first, sums = _analyze_plan(source, rec, plan, found, span, taps=taps)
        delay = float(first.params.get("skew_median", float("nan")))
        if not (np.isfinite(delay) and abs(delay) > ALIGN_MIN):
            said = {"align": "auto", "delay_samples": 0.0 if not np.isfinite(delay) else delay, "aligned": False}
            return dataclasses.replace(first, params={**first.params, **said}), sums
        res, _ = _analyze_plan(source, rec, plan, dataclasses.replace(found, delay=delay))
        res = dataclasses.replace(res, params={**res.params, "delay_samples": delay, "aligned": True})
        return res, sums  # the sums are of the raw samples: the delay does not change them
    return _analyze_plan(source, rec, plan, found, span, taps=taps)


def _analyze_plan(source: Any, rec: Optional[RecordingProtocol], plan: Plan, found: Findings,
                  span: Optional[Tuple[int, int]] = None, *, taps: Sequence[Tap] = ()
                  ) -> Tuple[Results, Optional[ClassicalTotals]]:  # fmt: skip
    """The windows of ``source`` on their route, finished, and the classical COF's sums of ``span`` (or None)."""
    k = run(source, rec, plan, found, span, taps=taps)
    return finish(k.st, k.aux_role, plan, found, route=k.route, warnings=k.warnings), k.classical
