"""Long recordings: ``tribodyn.analyze`` (docs/method.md section 6).

Reads a recording chunk by chunk, optionally high-passes raw (DC-coupled)
channels with the streaming filter, cuts windows of ``window`` s every
``hop`` s, computes each window's COF statistics in the Rust kernel, joins
temperature and current, and fixes the orientation once for the recording.
The per-window table does not depend on the format, the chunk size or the
thread count, and memory does not grow with the recording's length.

The options are checked once into a :class:`~tribodyn.plan.Plan`; the
route is then chosen from the plan and from what the source declares it
can do (:func:`choose_route`), before anything is read, and one finishing
step (:func:`finish`) turns the kernel's statistics into the table:

``"mapped"``
    The recording lays its channels out as contiguous float64 runs
    (``Recording.mappable`` and :meth:`~tribodyn.io.Recording.file_layout`):
    one call of ``_core.windows_stats_file`` reads the channels with
    ``pread`` into reused buffers, block by block, in parallel (raw input:
    high-passed one block ahead of the windows), with no Python per chunk.
``"spans"``
    A recording that reads any range and may be read from several threads
    at once (``random_access`` and ``thread_safe``), with dynamic input:
    one span of windows per thread, each read and analysed on its thread.
``"stream"``
    Everything else (mappings, iterators of chunks, sequential formats,
    readers that are not thread-safe such as npTDMS and h5py, raw input):
    one stream of chunks read by the calling thread alone, the filter,
    windows and kernel on one worker thread (reading overlapped with the
    kernel when the call has two threads or more).
``"acquisitions"``
    A list of separate acquisitions, one window each.

An error of a reader or a kernel surfaces as it is (a NaN or inf names its
channel and window); no route falls back to another.
"""

from __future__ import annotations

import contextvars
import dataclasses
import os
from collections import deque
from collections.abc import Iterable, Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, Callable, Deque, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _core
from ._validate import as_signal
from .columns import TABLE
from .contact_loss import mark_contact_loss
from .covariates import align_to_recording, branch, evaluate, interpolate, log_quality
from .deadband import DeadbandSpec
from .filters import HighPass
from .headline import ClassicalTotals, classical_totals
from .identify import Orientation, resolve_orientation
from .io.base import RecordingError
from .plan import Plan, make_plan
from .results import Results
from .window_stats import compute, gate_reasons, orient
from .windowing import Windower

__all__ = ["analyze", "analyze_partial", "combine", "Partial", "choose_route", "finish", "sign_of_total_slope"]

FORCE_ROLES = ("fx", "fy", "fz")
#: Samples per chunk read from a recording by default: large enough that the
#: per-chunk Python work is small beside the kernel's, small enough to stay
#: in cache between reading and analysing (and a multiple of the readers'
#: 65536-row blocks, so no chunk is pieced together).
DEFAULT_CHUNK = 1 << 17
#: Samples per block of the route "mapped" (at most; a block is whole
#: windows): each thread reads a block's channels into buffers it reuses,
#: small enough to stay in cache between the read and the windows.
#: 2^15 measured fastest here (benches/RESULTS.md); ``chunk=`` overrides it.
MAPPED_BLOCK = 1 << 15
#: Fewest windows per concurrently read span.
_MIN_SPAN_WINDOWS = 64
#: Roles the pipeline reads from a source.
_ROLES = ("fx", "fy", "fz", "i", "u", "cof", "v")

Stats = Dict[str, np.ndarray]


def _is_recording(source: Any) -> bool:
    return hasattr(source, "chunks") and hasattr(source, "fs") and not isinstance(source, Mapping)


def analyze(
    source: Any,
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
    fs : float
        Sampling rate in Hz (taken from a recording when omitted).
    window, hop : float
        Window length and start-to-start spacing in s (paper 2 and 10;
        ``hop == window`` tiles the recording). Only complete windows count.
        Not given: 2 s and 10 s, except for slow recordings (docs/method.md
        6b): a window of at least 100 samples and, below 100 Hz, hop =
        window; ``params["window_note"]`` says what was chosen.
    motion : {"auto", "unidirectional", "reciprocating"}
        "reciprocating" adds the per-stroke table ``Results.strokes``
        (strokes from the sign changes of the ``v`` role, of d``x``/dt, else
        of fy; docs/method.md 6c); "auto" detects it from fy's sign changes.
    min_fn : float, optional
        Classical COF: samples with |fz| below it (N) are left out (default
        5 % of the recording's median |fz|; docs/method.md 6a).
    tare : float or mapping, optional
        Classical COF: seconds at the start without contact (their mean fy
        and fz are subtracted), or explicit offsets ``{"fy": N, "fz": N}``.
    stroke_fraction : float
        Central part of each stroke used for its COF (default 0.5).
    channels : mapping, optional
        For a DataFrame source: role -> column; for a path: role -> channel,
        as ``open_recording``'s ``channels=``.
    highpass : float, optional
        Cut-off in Hz of a first-order Butterworth high-pass applied to raw,
        DC-coupled force channels first (streaming, state carried, "steady"
        start). None for dynamic forces as delivered by the paper's charge
        amplifier. With it, the table's ``mu_classical`` is the classical
        COF mean(|fy|/|fz|) of the raw forces.
    orientation : {+1, -1, "auto"}
        s in mu = s * slope; "auto" fixes it ONCE for the recording, as the
        sign of the least-squares slope of fy on fz over all windows
        (docs/method.md 0), never per window.
    temperature : (t_s, T_degC), optional
        Intermittent temperature log, interpolated linearly at each window
        centre (NaN outside the log); ``branch`` is the sign of dT/dt.
    current : (t_s, i_A) or float, optional
        Current log or constant, when the source has no ``i`` channel.
    voltage : (t_s, u_V) or float, optional
        Shunt voltage log or constant (needs ``shunt_ohm``); a ``u`` channel
        in the source is used likewise.
    shunt_ohm : float, optional
        Shunt resistance R: i = u / R.
    area_mm2 : float, optional
        Contact area; J = i / area_mm2 in A/mm^2.
    covariates : mapping of str -> (t_s, values) or float, optional
        Other logs, interpolated linearly at each window centre (NaN
        outside the log; absolute times aligned as ``temperature``'s):
        ``{"speed": (t, v)}`` fills the ``speed`` column (m/s, its
        magnitude; it replaces the mean |v| of a velocity channel ``v``),
        any other name a column of that name after the declared ones
        (docs/method.md 7a). Each may be the covariate of
        :func:`tribodyn.operating_range` (``by=NAME``).
    chunk : float, optional
        Seconds per chunk when reading a mapping or a recording (default
        131072 samples, about 2 min at 1 kHz, for a recording; a mapping is
        taken whole). For a channels-first float64 ``.npy`` the kernel reads
        the file itself, in blocks of at most this many seconds (default 2^15
        samples) per thread. Never changes a result.
    progress : bool
        Show a progress bar on stderr.
    deadband, n_bins, max_lag
        As for :func:`tribodyn.identify`, per window. ``max_lag`` adds the
        lag of max |C_yz(j)| per window (costly: one correlation function
        per window); a non-zero lag fails the gate.
    estimator : {"corrected", "iv", "ols", "deming"}, optional
        The slope estimator (docs/method.md 3a-3c). Default "corrected":
        least squares corrected for the noise on fz, whose variance is
        measured from the recording with instruments (or taken from
        ``noise``); unbiased under noise on fz and as precise as OLS
        without it (measured: docs/method.md 3f). "ols" is the paper's Eq. 8,
        "iv" instrumental variables (fz lagged by ``iv_lag``), "deming"
        needs ``noise``.
    method : {None, "paper"}
        "paper": the paper's method exactly (OLS, |C_yz(0)| >= 0.85, OLS
        standard errors, no alignment), the tables of tribodyn 0.2.
    gate : float or "ci", optional
        Quality gate (docs/method.md 5): "ci" (default) keeps a window when
        its expected 95 % half-width (its white-noise standard error times
        the recording's batch-means ratio) is at most +-``max_rel_ci`` of
        the recording's median COF; a
        number g is the paper's |C_yz(0)| >= g (0.85 with
        ``method="paper"``). With either, a window whose slope has the sign
        opposite to the recording's orientation fails.
    max_rel_ci : float, optional
        Largest expected half-width of the 95 % interval, relative to the
        recording's median COF, for gate "ci" (default 0.1).
    align : {None, "auto"}
        "auto": measure the delay of fz behind fy from the cross-spectral
        phase at the rig's lines (needs ``rpm``), and when it exceeds 0.05
        samples analyse again with fz advanced by it (a fractional-delay
        filter, docs/method.md 3e); ``params["delay_samples"]`` holds it.
        None leaves the data untouched (a measurable delay is then warned of).
    iv_lag : float, optional
        Instrument lag in s (default one revolution, 60 / rpm, when ``rpm``
        is given; else a tenth of the window, at least 10 samples).
    noise : (sigma_y, sigma_z), optional
        Standard deviations (N) of the measurement noise on fy and fz, e.g.
        the standard deviations of a record taken with the rig at rest
        (docs/method.md 3c); needed by "deming".
    rpm, n_lamellas : optional
        Rig data: the instrument lag (one revolution) and the line
        frequencies f0 = rpm/60, 2 f0, 3 f0, f_l = n_lamellas f0, 2 f_l of
        the columns ``skew``, ``h1_f0``, ``h1_fl``, ``coherence_fl``.
    threads : int, optional
        Kernel threads for this call only, 1 to 4 x the CPU count (default:
        the ``TRIBODYN_THREADS`` environment variable, else
        :func:`tribodyn.get_threads`, every core unless
        :func:`tribodyn.set_threads` changed it). Results do not depend on
        it, and concurrent calls do not change each other's count.
    start : int
        Sample index, within the whole recording, of the source's first
        sample (default 0). Windows stay on the recording's grid (starting
        at multiples of ``hop``), so consecutive ranges of a long recording
        analysed separately give exactly the windows of one pass (see
        :func:`tribodyn.analyze_many`). A recording source is read from
        ``start`` on.
    stop : int, optional
        For a recording source: the sample index (exclusive) where reading
        ends (default: the end). ``start``/``stop`` analyse one range of a
        long recording straight from the file, with the windows that lie
        wholly inside it.

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
    options = {k: v for k, v in locals().items() if k != "source"}
    if isinstance(source, (str, os.PathLike)):  # a file: opened as open_recording does by default
        from .io import open_recording

        with open_recording(source, fs=fs, channels=options.pop("channels")) as rec:
            return analyze(rec, **options)
    res = _analyze(source, options, partial=False)
    assert isinstance(res, Results)
    return res


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


def analyze_partial(source: Any, **options: Any) -> Partial:
    """:func:`analyze` up to the finishing step (same options; ``align`` must be None)."""
    if options.get("align") is not None:
        raise ValueError("align='auto' needs the whole recording: analyse it in one piece, or pass the delay yourself")
    return _analyze(source, options, partial=True)  # type: ignore[return-value]


def combine(parts: Sequence[Partial]) -> Results:
    """The ranges of one recording, in order, finished once (exactly the table of one pass over them)."""
    if not parts:
        raise ValueError("no ranges to combine")
    plan = dataclasses.replace(parts[0].plan, start=parts[0].plan.start, stop=parts[-1].plan.stop)
    st = _concat([dict(p.st) for p in parts])
    warnings = tuple(dict.fromkeys(w for p in parts for w in p.warnings))
    res = finish(st, parts[0].aux_role, plan, parts[0].route, warnings=warnings)
    res.params.update(parts[0].tribo)
    res.params["n_samples_total"] = sum(int(p.tribo.get("n_samples_total", 0)) for p in parts)
    totals = [p.classical for p in parts if p.classical is not None]
    res = dataclasses.replace(res, strokes=parts[0].strokes,
                              classical=ClassicalTotals.merge(totals) if totals else None)  # fmt: skip
    if len(parts) > 1:
        res.params.update(start=0, stop=None, ranges=len(parts))
    return settle(res)


def _analyze(source: Any, options: Dict[str, Any], partial: bool) -> Union[Results, Partial]:
    """:func:`_analyze_body` with the call's thread count for the readers' native parses (text files)."""
    from .threads import reading, resolve_threads

    try:
        n: Optional[int] = resolve_threads(options.get("threads"))
    except (TypeError, ValueError):
        n = None  # the plan says why
    with reading(n):
        return _analyze_body(source, options, partial)


def _analyze_body(source: Any, options: Dict[str, Any], partial: bool) -> Union[Results, Partial]:
    """:func:`analyze`'s body: ``options`` are its keyword arguments."""
    fs, temperature, current, voltage = (options.pop(k, None) for k in ("fs", "temperature", "current", "voltage"))
    logs = options.pop("covariates", None)
    extra = {k: options.pop(k, None) for k in ("motion", "min_fn", "tare", "stroke_fraction", "channels")}
    align = options.get("align")
    if _is_dataframe(source):
        from .tribometer import from_dataframe

        source, fs = from_dataframe(source, extra["channels"], fs)
    elif extra["channels"] is not None:
        raise TypeError("channels= maps the columns of a pandas DataFrame; map a recording's with open_recording")
    rec = source if _is_recording(source) else None
    if fs is None:
        if rec is None:
            raise TypeError("analyze needs fs= (the sampling rate in Hz)")
        fs = rec.fs
    motion = extra["motion"] if extra["motion"] is not None else "auto"
    if motion not in ("auto", "unidirectional", "reciprocating"):
        raise ValueError(f"motion must be 'auto', 'unidirectional' or 'reciprocating', got {motion!r}")
    window_note = ""
    if isinstance(fs, (int, float)) and not isinstance(fs, bool) and fs > 0:
        from .tribometer import auto_window

        options["window"], options["hop"], window_note = auto_window(float(fs), options.get("window"),
                                                                     options.get("hop"))  # fmt: skip
    else:
        options["window"] = 2.0 if options.get("window") is None else options["window"]
        options["hop"] = 10.0 if options.get("hop") is None else options["hop"]
    if rec is not None:  # logs with absolute times start at the reader's start time (docs/method.md 6)
        temperature, current, voltage = (
            align_to_recording(x, rec, nm)
            for x, nm in ((temperature, "temperature"), (current, "current"), (voltage, "voltage"))
        )
        if isinstance(logs, Mapping):
            logs = {k: align_to_recording(x, rec, f"covariates[{k!r}]") for k, x in logs.items()}
    plan = make_plan(fs=fs, temperature=temperature, current=current, voltage=voltage, covariates=logs, **options)
    from .tribometer import prepass

    pre = prepass(source, rec, plan.fs, min_fn=extra["min_fn"], tare=extra["tare"], motion=motion)
    plan = dataclasses.replace(plan, classical=pre.get("spec"))
    tribo = _tribometer_params(rec, pre, window_note)
    sf = extra["stroke_fraction"]
    stroke_fraction = 0.5 if sf is None else float(sf)
    if not (0 < stroke_fraction <= 1):
        raise ValueError(f"stroke_fraction must be in (0, 1], got {sf!r}")
    strokes: Optional[Dict[str, np.ndarray]] = None
    run_source, run_rec, run_plan = source, rec, plan
    if pre.get("motion") == "reciprocating":
        tribo["stroke_fraction"] = stroke_fraction
        found = _strokes(source, rec, plan, stroke_fraction, partition=partial)
        if found is not None:
            # docs/method.md 6c: the windows are the strokes' central parts, fy rectified (an acquisition each).
            strokes, run_source = found
            run_rec, run_plan = None, dataclasses.replace(plan, start=0, stop=None)
            tribo["rectified"] = True
            if not run_source:
                raise ValueError("no stroke's central part holds 3 samples: no window to analyse")
    contact = pre.get("contact")
    own = tuple(w for w in (window_note, contact.note if contact is not None else "") if w)  # the analysis's notes
    c_start, c_stop = _sample_range(source, rec, plan, partial)
    tribo["n_samples_total"] = c_stop - c_start
    totals = None

    def classical_pass() -> Optional[ClassicalTotals]:  # docs/method.md 6a, 6e: every sample in contact
        if plan.classical is None or strokes is not None:
            return None
        return classical_totals(source, rec, plan.classical, c_start, c_stop)

    if partial:  # the ranges are combined elsewhere, without the file: the sums are taken here
        totals = classical_pass()
        p = _partial(run_source, run_rec, run_plan)
        warnings = p.warnings + tuple(getattr(rec, "warnings", ())) + own
        return dataclasses.replace(p, plan=plan, warnings=tuple(dict.fromkeys(warnings)), tribo=tribo,
                                   strokes=strokes, classical=totals)  # fmt: skip
    res = _analyze_aligned(run_source, run_rec, run_plan, align)
    if run_rec is not rec and rec is not None:
        res = dataclasses.replace(res, warnings=tuple(dict.fromkeys((*rec.warnings, *res.warnings))))
    res.params.update(tribo)
    if run_plan is not plan:
        res.params.update(start=plan.start, stop=plan.stop)
    if own:
        res = dataclasses.replace(res, warnings=res.warnings + own)
    return settle(dataclasses.replace(res, strokes=strokes), classical_pass)


def _sample_range(source: Any, rec: Any, plan: Plan, partial: bool) -> Tuple[int, int]:
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


def settle(res: Results, classical: Optional[Callable[[], Optional[ClassicalTotals]]] = None) -> Results:
    """The results with their headline's sums and the warnings of the method in use (docs/method.md 6e).

    ``classical`` reads the classical COF's sums over the whole recording;
    it is called only when the verdict makes the classical COF the headline
    (a recording whose headline is the dynamic COF is not read again). The
    dynamic estimator's notes (``params["dynamic_notes"]``) are dropped
    when the headline is not the dynamic COF; a difference of the
    instrument's COF from the headline over 0.5 % is explained in a warning.
    """
    from .headline import instrument_check

    v = res.verdict
    if classical is not None and res.classical is None and not v["dynamic_method"] and v["motion"] != "reciprocating":
        res = dataclasses.replace(res, classical=classical())
    head = res.headline
    notes = set(res.params.get("dynamic_notes") or ())
    kept = [w for w in res.warnings if head.method == "dynamic" or w not in notes]
    _, more = instrument_check(res, head)
    out = dataclasses.replace(res, warnings=tuple(dict.fromkeys((*kept, *more))))
    for key in ("headline", "verdict", "mu_r_ci"):  # cached results that do not depend on the warnings
        if key in res.__dict__:
            out.__dict__[key] = res.__dict__[key]
    return out


def _is_dataframe(source: Any) -> bool:
    return type(source).__name__ == "DataFrame" and hasattr(source, "columns") and hasattr(source, "index")


def _tribometer_params(rec: Any, pre: Dict[str, Any], window_note: str) -> Dict[str, Any]:
    """What the pre-pass found and the role map, for ``Results.params`` (docs/method.md 6a-6d)."""
    out: Dict[str, Any] = {"motion": pre.get("motion", "unidirectional"),
                           "motion_detected": bool(pre.get("motion_detected"))}  # fmt: skip
    if "sign_flip_share" in pre:
        out["sign_flip_share"] = pre["sign_flip_share"]
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
    if rec is not None and getattr(rec, "roles", None) is not None:
        out["roles"] = dict(rec.roles)
        out["roles_source"] = getattr(rec, "roles_source", "given")
        choice = getattr(rec, "role_choice", None)
        if choice is not None:  # docs/method.md 6e
            out["roles_evidence"] = choice.as_dict()
    return out


#: Roles read for a reciprocating test: the pipeline's and the direction's (velocity, position).
_STROKE_ROLES = (*_ROLES, "x")
#: A window straddles a direction change when the direction signal, times the stroke's direction, falls
#: below -REVERSAL_SHARE x its p95 magnitude in it (docs/method.md 6c).
REVERSAL_SHARE = 0.05


def _strokes(source: Any, rec: Any, plan: Plan, fraction: float, partition: bool = False
             ) -> Optional[Tuple[Dict[str, np.ndarray], List[Dict[str, Any]]]]:  # fmt: skip
    """The per-stroke table of a reciprocating test and its windows as acquisitions (docs/method.md 6c).

    Reads the whole fy, fz (and fx, i, u, cof, x, v when present). The
    windows are the central ``fraction`` of each stroke (cut into windows of
    the plan's length every hop when longer than one), fy rectified as
    ``tare_fy + d (fy - tare_fy)`` with the stroke's direction d; each
    carries its stroke index and whether it straddles a direction change.
    Only windows within ``plan.start`` .. ``plan.stop`` are kept; with
    ``partition`` (a range of :func:`tribodyn.analyze_many`), those starting
    in ``plan.start`` .. the next range's start (``stop - length + step``),
    so that consecutive ranges keep each window once. None for a one-pass
    stream of chunks.
    """
    from .tribometer import ClassicalSpec, find_strokes, stroke_table

    if rec is not None:
        data = rec.read([r for r in _STROKE_ROLES if r in rec.roles])
        bounds = list(getattr(rec, "acquisitions", None) or [(0, rec.n_samples)])
    elif isinstance(source, Mapping):
        data = {k: np.asarray(v, dtype=float) for k, v in source.items() if k in _STROKE_ROLES}
        bounds = []
    elif isinstance(source, (list, tuple)):
        keys = [k for k in _STROKE_ROLES if all(k in a for a in source)]
        data = {k: np.concatenate([np.asarray(a[k], dtype=float) for a in source]) for k in keys}
        ends = np.cumsum([len(a["fz"]) for a in source])
        bounds = list(zip([0, *ends[:-1].tolist()], ends.tolist()))
    else:
        return None
    kind, sig = ("v", data["v"]) if "v" in data else (("x", data["x"]) if "x" in data else ("fy", data["fy"]))
    strokes = find_strokes(sig, boundaries=bounds, kind=kind)
    table = stroke_table(data["fy"], data["fz"], strokes, plan.fs, plan.classical, fraction, data.get("cof"),
                         data.get("x"))  # fmt: skip
    # The windows: each stroke's central part, fy rectified.
    dsig = np.gradient(np.asarray(sig, dtype=float)) if kind == "x" else np.asarray(sig, dtype=float)
    fin = np.abs(dsig[np.isfinite(dsig)])
    limit = REVERSAL_SHARE * float(np.percentile(fin, 95)) if fin.size else 0.0
    tare = (plan.classical or ClassicalSpec(0.0)).tare_fy
    n_all = len(data["fz"])
    stop = plan.stop if plan.stop is not None else n_all
    first_of_next = n_all if plan.stop is None else plan.stop - plan.length + plan.step
    roles = [r for r in _ROLES if r in data]
    pieces: List[Dict[str, Any]] = []
    for k, (a, b, d) in enumerate(strokes):
        m = b - a
        c0 = a + int(round(m * (1 - fraction) / 2))
        c1 = max(c0 + 1, a + int(round(m * (1 + fraction) / 2)))
        starts = [c0] if c1 - c0 <= plan.length else list(range(c0, c1 - plan.length + 1, plan.step))
        for s0 in starts:
            s1 = min(c1, s0 + plan.length)
            if s1 - s0 < 3 or s0 < plan.start or (s0 >= first_of_next if partition else s1 > stop):
                continue
            piece: Dict[str, Any] = {r: data[r][s0:s1] for r in roles}
            piece["fy"] = tare + d * (piece["fy"] - tare)
            piece["t0"] = s0 / plan.fs
            piece["stroke"] = k
            with np.errstate(invalid="ignore"):
                piece["reversal"] = bool(np.any(d * dsig[s0:s1] < -limit))
            pieces.append(piece)
    return table, pieces


def _analyze_aligned(source: Any, rec: Any, plan: Plan, align: Optional[str]) -> Results:
    """The analysis, with align="auto"'s second pass when asked."""
    if align == "auto":
        if not (rec is not None or isinstance(source, (Mapping, list, tuple))):
            raise ValueError(
                "align='auto' reads the source twice (to measure the delay, then to correct it): pass a mapping of "
                "arrays, a list of acquisitions or a recording, not a one-pass stream of chunks"
            )
        first = _analyze_plan(source, rec, dataclasses.replace(plan, align=None))
        delay = float(first.params.get("skew_median", float("nan")))
        if not (np.isfinite(delay) and abs(delay) > ALIGN_MIN):
            first.params.update(align="auto", delay_samples=0.0 if not np.isfinite(delay) else delay, aligned=False)
            return first
        res = _analyze_plan(source, rec, dataclasses.replace(plan, delay=delay))
        res.params.update(delay_samples=delay, aligned=True)
        return res
    return _analyze_plan(source, rec, plan)


def _analyze_plan(source: Any, rec: Any, plan: Plan) -> Results:
    """:func:`analyze` with its options checked into ``plan``."""
    p = _partial(source, rec, plan)
    return finish(p.st, p.aux_role, p.plan, p.route, warnings=p.warnings)


def _partial(source: Any, rec: Any, plan: Plan) -> Partial:
    """The kernel's statistics of every window of ``source`` (the routes), not yet finished."""
    if plan.stop is not None:
        if rec is None:
            raise ValueError(
                "stop= applies to a recording source (a mapping or a stream of chunks ends where it ends; slice it "
                "instead)"
            )
        n_rec = getattr(rec, "n_samples", None)
        if isinstance(n_rec, int) and plan.stop > n_rec:
            raise ValueError(
                f"stop must satisfy start <= stop <= {n_rec} (the recording's samples), "
                f"got start={plan.start}, stop={plan.stop}"
            )
    route = choose_route(source, rec, plan)
    total = _total(source, rec, plan)
    _check_table_size(plan, total)
    acq = getattr(rec, "acquisitions", None) if rec is not None else None
    if route != "acquisitions" and acq is not None and len(acq) > 1 and plan.start == 0 and plan.stop is None:
        route = "segments"
    if route == "segments":
        st, aux_role = _run_segments(rec, plan, acq or [])
    elif route == "acquisitions":
        st, aux_role = _acquisitions(source, plan)
    elif route == "mapped":
        st, aux_role = _run_mapped(rec, plan)
    elif route == "spans":
        st, aux_role = _run_spans(rec, plan)
    else:
        st, aux_role = _run_stream(_chunk_source(source, rec, plan), plan, total)
    if rec is not None and hasattr(rec, "check_unchanged"):
        rec.check_unchanged()  # a file changed while it was read: an error, not a table of mixed data
    return Partial(st, aux_role, plan, route, tuple(getattr(rec, "warnings", ())))


def choose_route(source: Any, rec: Any, plan: Plan) -> str:
    """The route for this source and plan: ``"acquisitions"``, ``"mapped"``, ``"spans"`` or ``"stream"``.

    Chosen before anything is read, from the plan and from the
    capabilities a recording declares (``mappable``, ``random_access``,
    ``thread_safe``; see :class:`tribodyn.io.Recording`).
    """
    if isinstance(source, (list, tuple)):
        return "acquisitions"
    if rec is None:
        if isinstance(source, Mapping) or (isinstance(source, Iterable) and not isinstance(source, (str, bytes))):
            return "stream"
        raise TypeError(
            "source must be a mapping, an iterable of mappings, a list of acquisitions or a recording, "
            f"got {type(source).__name__}"
        )
    if _mapped_layout(rec, plan) is not None:
        return "mapped"
    if (
        not plan.raw
        and getattr(rec, "random_access", False)
        and getattr(rec, "thread_safe", False)
        and _spans(rec, plan) is not None
    ):
        return "spans"
    return "stream"


#: Bytes per window of the table besides its bins (its columns and the
#: kernel's, at most twice at once while batches are joined).
_ROW_BYTES = 2 * 8 * 48


def _check_table_size(plan: Plan, total: Optional[int]) -> None:
    """Refuses, before reading, a table that would not fit in half of the machine's memory."""
    if total is None or total < plan.length:
        return
    windows = (plan.start + total - plan.length) // plan.step - _grid(0, plan)[0] + 1
    need = windows * (plan.n_bins * 16 + _ROW_BYTES)
    try:
        have = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not a POSIX system
        return
    if need > have // 2:
        raise ValueError(
            f"the per-window table would need about {need / 2**30:.1f} GiB ({windows} windows x {plan.n_bins} bins), "
            f"more than half of this machine's {have / 2**30:.1f} GiB: use fewer bins or a longer hop"
        )


# -- finishing: orientation, gate, covariates, table ---------------------------------


def _merged(st: Stats, a: str, b: str) -> float:
    """The centred cross-product S_ab of all windows merged (within + between windows; a, b in "z", "y").

    ``st`` holds per-window ``n``, ``mean_z``, ``mean_y`` and the within-window
    sums ``szz``, ``syy``, ``syz``.
    """
    n = np.asarray(st["n"], dtype=float)
    ma, mb = st[f"mean_{a}"], st[f"mean_{b}"]
    within = st["syz"] if {a, b} == {"z", "y"} else st[f"s{a}{b}"]
    if "out_of_range" in st and np.any(st["out_of_range"]):  # NaN moments (docs/method.md 4): left out
        keep = ~np.asarray(st["out_of_range"], dtype=bool)
        n, ma, mb, within = n[keep], ma[keep], mb[keep], within[keep]
    if n.sum() == 0:
        return float("nan")
    w = n / n.sum()
    da = ma - np.sum(w * ma)
    db = mb - np.sum(w * mb)
    return float(np.sum(within) + np.sum(n * da * db))


def sign_of_total_slope(st: Stats) -> float:
    """S_xy of fy on fz of all windows merged (within + between parts): its sign is the slope's.

    ``st`` holds per-window ``n``, ``mean_z``, ``mean_y`` and ``syz``.
    """
    return _merged(st, "z", "y")


def finish(st: Stats, aux_role: Optional[str], plan: Plan, route: str = "", warnings: Sequence[str] = ()) -> Results:
    """The kernel's per-window statistics (orientation +1) as a :class:`Results` (docs/method.md 0, 5, 6).

    Fixes the orientation once for all windows, applies the gate, joins the
    covariates and lays the table out as :data:`tribodyn.columns.TABLE`
    declares it. ``st`` is consumed (its arrays are flipped in place).
    ``warnings`` (the reader's) are kept, each once.
    """
    if len(st["n"]) == 0:
        w = plan.window
        if plan.stop is not None:
            raise ValueError(
                f"samples {plan.start}..{plan.stop} hold no whole window ({w:g} s = {plan.length} samples, "
                f"starting every {plan.step} samples from sample 0): no window to analyse"
            )
        raise ValueError(
            f"the recording is shorter than one window ({w:g} s = {plan.length} samples): no window to analyse"
        )
    fs, cov = plan.fs, plan.covariates
    s = resolve_orientation(plan.orientation, sign_of_total_slope(st))
    moments = {k: np.asarray(st[k], dtype=float) for k in ("n", "mean_z", "mean_y", "syz")}
    confidence = _orientation_confidence(st, s) if plan.orientation == "auto" and not plan.paper else {}
    o = orient(st, s, inplace=True)
    t_start = o["t0"] if "t0" in o else o["start"] / fs
    n_win = np.asarray(o["n"], dtype=np.int64)
    centre = t_start + 0.5 * n_win / fs
    found: Dict[str, Any] = {}
    notes: List[str] = []
    stats_cols = _statistics(o, plan, s, found, notes)
    o.update(stats_cols)
    skew_gate = o.get("skew_lag")
    reasons = gate_reasons(o, plan.gate, skew_gate, rel_ci=stats_cols.get("rel_ci"), max_rel_ci=plan.max_rel_ci)
    if confidence:
        found.update(confidence)
        if confidence["orientation_agreement"] < 0.9 or abs(confidence["orientation_r"]) < 0.2:
            notes.append(
                f"orientation 'auto' is uncertain: the whole recording's r is {confidence['orientation_r']:+.2f} and "
                f"{100 * confidence['orientation_agreement']:.0f} % of the windows agree with s = {s:+d}; pass "
                "orientation= if you know the sign"
            )

    def nan() -> np.ndarray:  # a fresh column each time: no two table columns share memory
        return np.full(len(centre), np.nan)

    cur = nan()
    if aux_role == "i":
        cur = o["aux_mean"]
    elif aux_role == "u":
        cur = o["aux_mean"] / cov.shunt_ohm
    elif cov.current is not None:
        cur = evaluate(cov.current, centre)
    elif cov.voltage is not None:
        cur = evaluate(cov.voltage, centre) / cov.shunt_ohm
    log = cov.temperature
    cov_notes: List[str] = []  # not the dynamic method's: kept whichever COF is the headline
    speed, extra = _covariate_columns(o, cov, centre, cov_notes)
    if "stroke_reversal" in o and np.any(o["stroke_reversal"]):  # docs/method.md 6c
        reasons = np.asarray(reasons, dtype=object).copy()
        for k in np.flatnonzero(o["stroke_reversal"]):
            reasons[k] = "; ".join(r for r in (reasons[k], "stroke reversal in the window") if r)
    if not plan.paper:  # the paper's preset keeps the paper's gate exactly
        reasons = mark_contact_loss(reasons, o, cur / cov.area_mm2 if cov.area_mm2 is not None else cur)  # method.md 7
    values: Stats = {
        **o,
        "time": centre,
        "t_start": t_start,
        "skew": o["skew"] if "skew" in o else nan(),
        "h1_f0": o.get("h1_f0", nan()),
        "h1_fl": o.get("h1_fl", nan()),
        "coherence_fl": o.get("coherence_fl", nan()),
        "ok": np.asarray(reasons == "", dtype=bool),
        "reasons": reasons.astype(str),
        "T": interpolate(log, centre) if log is not None else nan(),
        "branch": branch(log, centre) if log is not None else np.zeros(len(centre), dtype=np.int8),
        **log_quality(log, centre),  # T_uncertainty, T_gap (docs/method.md 6)
        "i": cur,
        "J": cur / cov.area_mm2 if cov.area_mm2 is not None else nan(),
        "speed": speed,
        "mu_instrument": o["mu_instrument"] if "mu_instrument" in o else nan(),
        # one classical column (docs/method.md 6a): the contact rule's; the paper's Sec. 5 mean over fz != 0 of
        # the raw forces with method="paper" or without a contact rule (highpass on a fz with no static level)
        "mu_classical": o["mu_classic"]
        if "mu_classic" in o and (plan.paper or "mu_classical" not in o)
        else o.get("mu_classical", nan()),
        "mu_classical_median": o["mu_classical_median"] if "mu_classical_median" in o else nan(),
        "fz_mean": o["fz_mean"] if "fz_mean" in o else (nan() if plan.raw else np.asarray(moments["mean_z"])),
        "fz_std": o["fz_std"] if "fz_std" in o else _fz_std(o, plan),
        "n": n_win,
        "acquisition": o.get("acquisition", np.zeros(len(centre), dtype=np.int64)),
    }
    table = {c.name: np.asarray(values[c.name], dtype=c.dtype if c.dtype != "str" else None) for c in TABLE}
    table.update(extra)  # the other covariate logs, after the declared columns (docs/method.md 7a)
    params = plan.params()
    params.update(orientation_used=s, start=plan.start, stop=plan.stop, threads=plan.threads, route=route)
    params.update(found)
    params["dynamic_notes"] = list(notes)  # the dynamic method's own notes (settle drops them when it does not apply)
    warnings = list(warnings) + notes + cov_notes
    return Results(
        table=table,
        bin_counts=np.asarray(o["bin_count"], dtype=np.int64),
        bin_cof=o["bin_cof"],
        fz_min=o["fz_min"],
        fz_max=o["fz_max"],
        orientation=s,
        params=params,
        moments=moments,
        warnings=tuple(dict.fromkeys(str(w) for w in warnings)),
    )


def _covariate_columns(o: Stats, cov: Any, centre: np.ndarray, notes: List[str]
                       ) -> Tuple[np.ndarray, Dict[str, np.ndarray]]:  # fmt: skip
    """The ``speed`` column and the other covariate logs' columns at the window centres (docs/method.md 7a).

    The speed is the kernel's mean |v| of a velocity channel, unless a speed
    log is given: that log's magnitude then (said in a note when both exist).
    """
    logs = dict(cov.logs)
    speed = np.asarray(o["speed"], dtype=float) if "speed" in o else np.full(len(centre), np.nan)
    if "speed" in logs:
        if "speed" in o:
            notes.append("the speed log given replaces the mean |v| of the velocity channel v in the speed column")
        speed = np.abs(evaluate(logs.pop("speed"), centre))
    return speed, {name: evaluate(log, centre) for name, log in logs.items()}


#: Normal quantile 0.975: the paper's intervals (mu_r +- 1.96 OLS standard errors).
_Z975 = 1.959963984540054
#: Below this median |r| of instrument and fz the instrument is weak (docs/method.md 3b).
WEAK_INSTRUMENT = 0.3
#: A recording-wide fz delay (samples) above which align="auto" corrects it
#: and align=None warns (docs/method.md 3e).
ALIGN_MIN = 0.05


def _statistics(o: Stats, plan: Plan, s: int, found: Dict[str, Any], notes: List[str]) -> Stats:
    """mu_r by the plan's estimator, its interval, the force dependence and the line statistics (docs/method.md 3a-3e).

    ``o`` holds the oriented kernel statistics (``mu_r`` = s * OLS slope);
    returns the columns that replace or join them. ``found`` gets what the
    recording revealed (for ``params``), ``notes`` the warnings.
    """
    from .estimators import T975, Sums, gate_precision, line_stats, pooled_noise, quadratic, slopes, window_noise

    k = len(o["n"])
    mu_ols = np.array(o["mu_r"], dtype=float)
    if plan.paper:
        se = np.asarray(o["mu_r_stderr"], dtype=float)
        out: Stats = {"mu_ols": mu_ols, "mu_r_low": mu_ols - _Z975 * se, "mu_r_high": mu_ols + _Z975 * se}
        for name in ("attenuation_p", "dmu_dfn", "dmu_dfn_stderr", "dmu_dfn_low", "dmu_dfn_high"):
            out[name] = np.full(k, np.nan)
        out["noise_z_var"] = np.full(k, np.nan)
        out["mu_r_dnoise"] = np.zeros(k)  # OLS shares no estimate between windows
        if "skew" in o:
            out["skew_lag"] = o["skew"]
        return out
    E = Sums(o.pop("ext"))
    n = np.asarray(o["n"])
    pooled = None
    if plan.estimator == "corrected" and plan.noise is None:
        pooled = pooled_noise(E, n)
        if not np.isfinite(pooled[0]):
            notes.append(
                f"the noise on fz could not be measured (instrument lag {plan.iv_lag} samples needs windows longer "
                "than twice it): mu_r is the least-squares slope; pass iv_lag= or noise="
            )
            pooled = (0.0, 0.0)
        found["noise_z_std"] = float(np.sqrt(pooled[0]))
    sl = slopes(E, n, plan.estimator, noise=plan.noise, pooled=pooled)
    r_inst = sl.instrument_r[np.isfinite(sl.instrument_r)]
    found["instrument_r"] = float(np.median(r_inst)) if r_inst.size else float("nan")
    weak = bool(r_inst.size) and abs(found["instrument_r"]) < WEAK_INSTRUMENT
    if weak and pooled is not None and pooled != (0.0, 0.0):
        # A weak instrument cannot measure the noise on fz: least squares, said so.
        pooled = (0.0, 0.0)
        found["noise_z_std"] = 0.0
        sl = slopes(E, n, plan.estimator, noise=plan.noise, pooled=pooled)
        notes.append(
            f"the noise on fz could not be measured: the instrument (fz lagged by {plan.iv_lag} samples) is weak "
            f"(median r = {found['instrument_r']:.2f}), so mu_r is the least-squares slope; pass rpm= (a lag of "
            "one revolution), iv_lag= or noise= (docs/method.md 3b)"
        )
    elif weak and plan.estimator == "iv":
        notes.append(
            f"the instrument (fz lagged by {plan.iv_lag} samples) is weak: median r = {found['instrument_r']:.2f}; "
            "IV slopes are imprecise; pass rpm= (a lag of one revolution) or iv_lag= (docs/method.md 3b)"
        )
    mu = s * sl.slope
    se = sl.se
    a2, a2_se = quadratic(E, n, instrumented=plan.estimator != "ols")
    rel, found["gate_se_ratio"], found["gate_cof"] = gate_precision(mu, se, sl.se_white)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = {
            "mu_r": mu,
            "mu_r_stderr": se,
            "noise_z_var": window_noise(E, n),
            "mu_r_dnoise": s * sl.dnoise,
            "mu_r_low": mu - T975 * se,
            "mu_r_high": mu + T975 * se,
            "mu_ols": mu_ols,
            "attenuation_p": sl.attenuation_p,
            "dmu_dfn": s * a2,
            "dmu_dfn_stderr": a2_se,
            "dmu_dfn_low": s * a2 - T975 * a2_se,
            "dmu_dfn_high": s * a2 + T975 * a2_se,
            "f_y0": o["mean_y"] - sl.slope * o["mean_z"],
            "force_dependence": (o["mu_b"] - o["mu_a"]) / mu,
            "rel_ci": rel,
        }
    if "skew" in o:
        out["skew_lag"] = o["skew"]
    if "spec" in o:
        ls = line_stats(o.pop("spec"), plan.lines, s)
        index = dict(plan.line_index)
        out["skew"] = ls["skew"]
        if "f0" in index:
            out["h1_f0"] = ls["h1"][:, index["f0"]]
        if "fl" in index:
            out["h1_fl"] = ls["h1"][:, index["fl"]]
            out["coherence_fl"] = ls["coherence"][:, index["fl"]]
        sk = ls["skew"][np.isfinite(ls["skew"])]
        delay = float(np.median(sk)) if sk.size else float("nan")
        found["skew_median"] = delay + plan.delay if np.isfinite(delay) else delay
        if plan.align is None and np.isfinite(delay) and abs(delay) > ALIGN_MIN:
            notes.append(
                f"fz lags fy by {delay:+.2f} samples (cross-spectral phase at the rig's lines, median over windows): "
                "mu_r is biased low by it; analyze(..., align='auto') corrects it (docs/method.md 3e)"
            )
    return out


def _fz_std(o: Stats, plan: Plan) -> np.ndarray:
    """Per-window standard deviation of fz from the kernel's centred sum of squares (NaN without it)."""
    if "szz" not in o:
        return np.full(len(o["n"]), np.nan)
    n = np.asarray(o["n"], dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        std: np.ndarray = np.sqrt(np.asarray(o["szz"], dtype=float) / n)
        return std


def _orientation_confidence(st: Stats, s: int) -> Dict[str, float]:
    """The recording's Pearson r of fy and fz (windows merged) and the fraction of windows whose slope has sign s."""
    n = np.asarray(st["n"], dtype=float)
    slope = np.asarray(st["slope"], dtype=float)
    good = np.isfinite(slope) & (slope != 0)
    agree = float(np.mean(np.sign(slope[good]) == s)) if good.any() else float("nan")
    r = float("nan")
    if "szz" in st and "syy" in st and n.sum() > 0:
        szz, syy = _merged(st, "z", "z"), _merged(st, "y", "y")
        if szz > 0 and syy > 0:
            r = _merged(st, "z", "y") / float(np.sqrt(szz * syy))
    return {"orientation_r": r, "orientation_agreement": agree}


# -- the kernel on windows of arrays -------------------------------------------------


def _kernel(
    ch: Dict[str, np.ndarray], rel: np.ndarray, absolute: np.ndarray, plan: Plan, aux_role: Optional[str], threads: int
) -> Stats:
    """The statistics of the windows starting at ``rel`` of the arrays ``ch`` (``absolute`` in the recording)."""
    aux = ch.get(aux_role) if aux_role else None
    raw = (ch["fy_raw"], ch["fz_raw"]) if plan.raw else None
    offset = int(absolute[0] - rel[0]) if len(rel) else 0
    try:
        st = compute(
            ch.get("fx"),
            ch["fy"],
            ch["fz"],
            aux,
            rel,
            plan.length,
            plan.deadband,
            plan.n_bins,
            plan.kernel_columns,
            raw=raw,
            threads=threads,
            offset=offset,
            options=plan.kernel_options,
        )
    except _core.NonFiniteError as exc:
        raise _non_finite(exc, plan, aux_role) from None
    st["start"] = absolute.astype(np.int64)
    if "cof" in ch:
        st["mu_instrument"] = _window_means(ch["cof"], rel, plan.length)
    if "v" in ch:  # the speed column, mean |v| (docs/method.md 7a)
        st["speed"] = _window_means(ch["v"], rel, plan.length)
    if plan.max_lag is not None:
        st["skew"] = _skews(ch["fy"], ch["fz"], rel, plan.length, plan.max_lag, threads)
    return st  # fmt: skip


def _non_finite(exc: Exception, plan: Plan, aux_role: Optional[str]) -> ValueError:
    """The kernel's NaN/inf error in the recording's terms: the role, the window (or sample) and its time."""
    _, channel, sample, window = exc.args
    role = {"aux": aux_role or "aux"}.get(channel, str(channel).removesuffix("_raw"))
    where = "in the window starting at sample" if window else "at sample"
    tail = "" if window else "; the high-pass filter needs every sample"
    return ValueError(f"{role} contains NaN or inf {where} {sample} (t = {sample / plan.fs:g} s{tail})")


#: Samples of windows :func:`_window_means` copies at once.
_MEANS_BATCH = 1 << 18


def _window_means(x: np.ndarray, rel: np.ndarray, length: int) -> np.ndarray:
    """Mean of |x| per window, NaN samples skipped (an instrument's COF column, a velocity).

    Windows are summed a batch at a time (rows of a sliding view: the same
    pairwise sums as one window's ``mean``, so the value does not depend on
    the chunk); a window holding NaN is averaged over its finite samples alone.
    """
    out = np.full(len(rel), np.nan)
    if len(rel) == 0 or len(x) < length:
        return out
    rows = np.lib.stride_tricks.sliding_window_view(x, length)
    batch = max(1, _MEANS_BATCH // length)
    for a in range(0, len(rel), batch):
        w = np.abs(rows[rel[a : a + batch]])
        fin = np.isfinite(w).all(axis=1)
        out[a : a + batch][fin] = w[fin].sum(axis=1) / length
        for k in np.flatnonzero(~fin):
            v = w[k][np.isfinite(w[k])]
            if v.size:
                out[a + k] = v.mean()
    return out


def _skews(fy: np.ndarray, fz: np.ndarray, rel: np.ndarray, length: int, max_lag: int, threads: int) -> np.ndarray:
    out = np.full(len(rel), np.nan)
    lag = min(max_lag, length - 1)
    for k, s in enumerate(rel):
        c = _core.xcorr(np.ascontiguousarray(fy[s : s + length]), np.ascontiguousarray(fz[s : s + length]), lag,
                        "auto", threads=threads)  # fmt: skip
        if np.isfinite(c).any():
            out[k] = int(np.nanargmax(np.abs(c))) - lag
    return out


def _concat(parts: List[Stats]) -> Stats:
    """Joins the batches column by column, freeing each column's pieces as it goes."""
    if not parts:
        return {"n": np.zeros(0, dtype=np.int64)}
    out = {}
    for k in list(parts[0]):
        out[k] = np.concatenate([p.pop(k) for p in parts]) if len(parts) > 1 else parts[0].pop(k)
    parts.clear()
    return out


def _aux_role(roles: Any, shunt: Optional[float]) -> Optional[str]:
    if "i" in roles:
        return "i"
    if "u" in roles:
        if shunt is None:
            raise ValueError("the source has a voltage channel 'u': give shunt_ohm (i = u / R)")
        return "u"
    return None


def _check_chunk(chunk: Any, where: str) -> Dict[str, np.ndarray]:
    if not isinstance(chunk, Mapping):
        raise TypeError(
            f"{where} must be a mapping of role -> array (roles fx, fy, fz, i, u), got {type(chunk).__name__}"
        )
    missing = [r for r in ("fy", "fz") if r not in chunk]
    if missing:
        raise ValueError(
            f"{where} lacks the required channel(s) {', '.join(missing)} (has {', '.join(map(str, chunk)) or 'none'})"
        )
    # No NaN/inf scan here: the kernel refuses a non-finite sample in any
    # window as it sums it, and the high-pass filter checks every sample it
    # filters; samples outside every window change no result.
    out = {
        str(k): as_signal(v, f"{where}[{k!r}]", min_len=0, check_finite=False) for k, v in chunk.items() if k in _ROLES
    }
    lengths = {k: len(v) for k, v in out.items()}
    if len(set(lengths.values())) > 1:
        raise ValueError(f"{where}: channels must have equal lengths, got {lengths}")
    return out


# -- route "segments" ----------------------------------------------------------------


def _run_segments(rec: Any, plan: Plan, ranges: Sequence[Tuple[int, int]]) -> Tuple[Stats, Optional[str]]:
    """Each separate acquisition of a recording windowed from its own first sample (no window straddles two)."""
    parts: List[Stats] = []
    aux_role: Optional[str] = None
    size = plan.chunk or DEFAULT_CHUNK
    for k, (a, b) in enumerate(ranges):
        if b - a < plan.length:
            continue
        batch, aux = _run_chunks(rec.chunks(size, start=a, stop=b, copy=_copies(rec)), 0, plan, None,
                                 threads=plan.threads)  # fmt: skip
        aux_role = aux_role or aux
        for st in batch:
            st["start"] = np.asarray(st["start"], dtype=np.int64) + a
            st["acquisition"] = np.full(len(st["n"]), k, dtype=np.int64)
            parts.append(st)
    return _concat(parts), aux_role


# -- route "mapped" ------------------------------------------------------------------


def _mapped_layout(rec: Any, plan: Plan) -> Optional[Tuple[int, Dict[str, Any], Optional[str]]]:
    """(descriptor, byte offsets, aux role) when the route "mapped" applies, else None (nothing is read)."""
    if not getattr(rec, "mappable", False) or plan.max_lag is not None or plan.progress:
        return None
    roles = rec.roles
    # The kernel reads forces and one auxiliary channel; an instrument's COF and a velocity are averaged in Python.
    if "cof" in roles or "v" in roles or not {"fy", "fz"} <= set(roles):
        return None
    if plan.raw and plan.step < plan.length:
        return None  # the mapped filter needs windows that do not overlap
    aux = _aux_role(roles, plan.covariates.shunt_ohm)
    found = rec.file_layout([r for r in FORCE_ROLES if r in roles] + ([aux] if aux else []))
    if found is None:
        return None
    return found[0], found[1], aux


def _grid(n: int, plan: Plan) -> Tuple[int, int]:
    """First window (index k) at or after ``plan.start`` and one past the last that ends by ``n``."""
    k0 = -(-plan.start // plan.step)
    k1 = (n - plan.length) // plan.step + 1 if n >= plan.length else 0
    return k0, max(k0, k1)


def _run_mapped(rec: Any, plan: Plan) -> Tuple[Stats, Optional[str]]:
    """One call of ``_core.windows_stats_file``: the file's pages, block by block (see the module doc)."""
    found = _mapped_layout(rec, plan)
    assert found is not None, "choose_route chose 'mapped'"
    fd, layout, aux = found
    n_rec = rec.n_samples
    k0, k1 = _grid(n_rec if plan.stop is None else plan.stop, plan)
    if k1 <= k0:
        return {"n": np.zeros(0, dtype=np.int64)}, aux
    # Windows per task: at most MAPPED_BLOCK samples (or the chunk asked
    # for), in equal blocks, a multiple of the threads in number, so that
    # the threads finish together and the buffers (a block per thread) do
    # not depend on the recording's length.
    count = k1 - k0
    cap = max(1, (plan.chunk or MAPPED_BLOCK) // plan.step)
    blocks = -(-count // cap)
    blocks = -(-blocks // plan.threads) * plan.threads
    block = max(1, -(-count // blocks))
    sos = zi = None
    if plan.raw:
        hp = HighPass(plan.fs, cutoff=_cutoff(plan))
        sos, zi, block = hp.sos, hp.steady_state, cap
    offsets = (layout.get("fx"), layout["fy"], layout["fz"], layout[aux] if aux else None)
    try:
        st = _core.windows_stats_file(
            fd, offsets, n_rec, k0, k1, plan.step, plan.length, 1.0, plan.deadband.kind, float(plan.deadband.value),
            plan.n_bins, list(plan.kernel_columns), block=block, sos=sos, zi=zi, origin=plan.start,
            threads=plan.threads, **plan.kernel_options,
        )  # fmt: skip
    except _core.NonFiniteError as exc:
        raise _non_finite(exc, plan, aux) from None
    except ValueError as exc:
        # The kernel checks the file's length before each block: a file
        # that shrank since it was opened is the recording's error.
        ends = [o + 8 * n_rec if isinstance(o, int) else o.end for o in offsets if o is not None]
        if os.fstat(fd).st_size < max(ends):
            raise RecordingError(f"{rec.path}: file ends early (truncated since it was opened?): {exc}") from None
        raise
    st["start"] = np.arange(k0, k1, dtype=np.int64) * plan.step
    return st, aux


# -- route "spans" -------------------------------------------------------------------


def _spans(rec: Any, plan: Plan) -> Optional[List[Tuple[int, int]]]:
    """Sample ranges of a recording, one per thread, on the window grid; None when too short to split.

    With one thread the whole recording is one span (read the same way:
    large chunks, views where the format has them, the kernel on the
    reading thread). Span j reads [k_j * step, (k_{j+1} - 1) * step + length)
    and holds exactly the windows k_j .. k_{j+1} - 1, so the spans' windows
    are the recording's, each once, with the same samples.
    """
    n = rec.n_samples if plan.stop is None else plan.stop
    k0, k1 = _grid(n, plan)
    count = k1 - k0
    parts = min(plan.threads, count // _MIN_SPAN_WINDOWS)
    if parts < 1:
        return None
    ks = [k0 + (count * j) // parts for j in range(parts + 1)]
    return [(ks[j] * plan.step, (ks[j + 1] - 1) * plan.step + plan.length) for j in range(parts)]


def _run_spans(rec: Any, plan: Plan) -> Tuple[Stats, Optional[str]]:
    """Reads and analyses the spans concurrently, one thread each (dynamic input: no filter state).

    Only for readers that declare ``thread_safe``. The reader's copies and
    the kernel release the GIL, so the spans run in parallel; the batches
    are joined in span order, so the table is the one of a single stream.
    """
    spans = _spans(rec, plan)
    assert spans is not None, "choose_route chose 'spans'"
    size = plan.chunk or DEFAULT_CHUNK
    bar = _progress(plan.progress, sum(b - a for a, b in spans))
    try:
        with ThreadPoolExecutor(len(spans), thread_name_prefix="tribodyn-span") as ex:
            copy = _copies(rec)
            futures = [
                ex.submit(
                    contextvars.copy_context().run,
                    _run_chunks,
                    rec.chunks(size, start=a, stop=b, copy=copy),
                    a,
                    plan,
                    bar,
                    threads=1,
                )
                for a, b in spans
            ]
            results = [f.result() for f in futures]
    finally:
        if bar is not None:
            bar.close()
    return _concat([st for parts, _ in results for st in parts]), results[0][1]


# -- route "stream" ------------------------------------------------------------------


def _chunk_source(source: Any, rec: Any, plan: Plan) -> Iterable[Any]:
    if rec is not None:
        chunks: Iterable[Any] = rec.chunks(
            plan.chunk or DEFAULT_CHUNK, start=plan.start, stop=plan.stop, copy=_copies(rec)
        )
        return chunks
    if isinstance(source, Mapping):
        n = len(next(iter(source.values()))) if source else 0
        size = plan.chunk or DEFAULT_CHUNK
        if n <= size:
            return [source]
        return ({k: v[s : s + size] for k, v in source.items()} for s in range(0, n, size))
    out: Iterable[Any] = source
    return out


def _copies(rec: Any) -> bool:
    """Whether the pipeline asks a recording for copies: only of a reader that would hand out views of a memory
    map (a file truncated while it is read must be an error, not a SIGBUS). Nothing in the pipeline writes into a
    chunk, so the arrays other readers make are used as they come (no second copy)."""
    return bool(getattr(rec, "views", False))


def _total(source: Any, rec: Any, plan: Plan) -> Optional[int]:
    if rec is not None:
        return (plan.stop if plan.stop is not None else rec.n_samples) - plan.start
    if isinstance(source, Mapping):
        return len(next(iter(source.values()))) if source else 0
    return None


def _run_stream(chunks: Iterable[Any], plan: Plan, total: Optional[int]) -> Tuple[Stats, Optional[str]]:
    bar = _progress(plan.progress, total)
    try:
        parts, aux_role = _run_chunks(chunks, plan.start, plan, bar, threads=plan.threads)
    finally:
        if bar is not None:
            bar.close()
    return _concat(parts), aux_role


def _run_chunks(chunks: Iterable[Any], origin: int, plan: Plan, bar: Any, *, threads: int,
                depth: int = 2) -> Tuple[List[Stats], Optional[str]]:  # fmt: skip
    """Checks, filters and windows a stream of chunks; the batches of window statistics, in order.

    The calling thread alone reads the chunks (so a reader that is not
    thread-safe is never read from two threads). With ``threads`` >= 2 one
    worker thread filters, windows and runs the kernel (which releases the
    GIL and uses ``threads`` kernel threads), chunk after chunk in order,
    at most ``depth`` chunks behind the reading: the filter state and the
    windower's tail are only ever touched by that worker. With one thread
    everything runs on the calling thread.
    """
    stage = _Stage(origin, plan, threads)
    if threads < 2:
        for i, raw_chunk in enumerate(chunks):
            stage.push(_check_chunk(raw_chunk, f"chunk {i}"))
            if bar is not None:
                bar.update(len(raw_chunk["fz"]))
        return stage.finish()
    pending: "Deque[Future[Any]]" = deque()
    with ThreadPoolExecutor(1, thread_name_prefix="tribodyn") as ex:
        try:
            for i, raw_chunk in enumerate(chunks):
                ch = _check_chunk(raw_chunk, f"chunk {i}")
                while len(pending) >= depth:
                    pending.popleft().result()
                pending.append(ex.submit(stage.push, ch))
                if bar is not None:
                    bar.update(len(ch["fz"]))
            while pending:
                pending.popleft().result()
        finally:
            for f in pending:
                f.cancel()
    return stage.finish()


class _Stage:
    """Filter, windower and kernel for one stream of chunks (used by one thread at a time)."""

    def __init__(self, origin: int, plan: Plan, threads: int) -> None:
        self.origin, self.plan, self.threads = origin, plan, threads
        self.parts: List[Stats] = []
        self.aux_role: Optional[str] = None
        self.windower: Optional[Windower] = None
        self.hp: Optional[HighPass] = None
        self.force_roles: List[str] = []
        self.seen = origin  # the recording's index of the next chunk's first sample

    def _windows(self, ch: Dict[str, np.ndarray], rel: np.ndarray, absolute: np.ndarray) -> None:
        self.parts.append(_kernel(ch, rel, absolute, self.plan, self.aux_role, self.threads))

    def push(self, ch: Dict[str, np.ndarray]) -> None:
        plan = self.plan
        if self.windower is None:
            self.aux_role = _aux_role(ch, plan.covariates.shunt_ohm)
            self.force_roles = [r for r in FORCE_ROLES if r in ch]
            self.windower = Windower(plan.length, plan.step, self._windows, origin=self.origin)
            if plan.raw:
                self.hp = HighPass(plan.fs, cutoff=_cutoff(plan), channels=len(self.force_roles), threads=self.threads)
        elif set(self.force_roles) - set(ch):
            missing = sorted(set(self.force_roles) - set(ch))
            raise ValueError(f"a chunk from sample {self.seen} on lacks channel(s) present in the first: {missing}")
        first, self.seen = self.seen, self.seen + len(ch["fz"])
        if self.hp is not None:
            # The filter refuses NaN/inf as it reads every sample.
            stacked = np.stack([ch[r] for r in self.force_roles])
            try:
                filtered = self.hp.process(stacked)
            except ValueError:
                bad = ~np.isfinite(stacked)
                if not bad.any():
                    raise
                k, j = np.argwhere(bad.T)[0]  # the first sample, then the first channel
                s = first + int(k)
                raise ValueError(
                    f"{self.force_roles[j]} contains NaN or inf at sample {s} "
                    f"(t = {s / plan.fs:g} s; the high-pass filter needs every sample)"
                ) from None
            ch["fy_raw"], ch["fz_raw"] = ch["fy"], ch["fz"]
            for k, r in enumerate(self.force_roles):
                ch[r] = filtered[k]
        self.windower.push(ch)

    def finish(self) -> Tuple[List[Stats], Optional[str]]:
        if self.windower is None:
            raise ValueError("the source holds no samples")
        return self.parts, self.aux_role


def _cutoff(plan: Plan) -> float:
    assert plan.highpass is not None, "only raw input is high-passed"
    return plan.highpass


def _progress(on: bool, total: Optional[int]) -> Any:
    if not on:
        return None
    from ._progress import progress_bar

    return progress_bar(total, unit="sample", unit_scale=True, desc="analyse")


# -- route "acquisitions" ------------------------------------------------------------


def _acquisitions(source: Sequence[Any], plan: Plan) -> Tuple[Stats, Optional[str]]:
    parts: List[Stats] = []
    t = 0.0
    aux_role: Optional[str] = None
    for k, acq in enumerate(source):
        ch = _check_chunk(acq, f"acquisition {k}")
        n = len(ch["fz"])
        if n < 3:
            raise ValueError(f"acquisition {k} has {n} samples; at least 3 are needed")
        aux_role = _aux_role(ch, plan.covariates.shunt_ohm) if k == 0 else aux_role
        if plan.raw:
            roles = [r for r in FORCE_ROLES if r in ch]
            hp = HighPass(plan.fs, cutoff=_cutoff(plan), channels=len(roles), threads=plan.threads)
            filtered = hp.process(np.stack([ch[r] for r in roles]))
            ch["fy_raw"], ch["fz_raw"] = ch["fy"], ch["fz"]
            for j, r in enumerate(roles):
                ch[r] = filtered[j]
        one = plan if n == plan.length else _with_length(plan, n)
        st = _kernel(ch, np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.int64), one, aux_role, plan.threads)
        t0 = acq.get("t0") if isinstance(acq, Mapping) else None
        st["t0"] = np.array([float(t0) if t0 is not None else t])
        st["acquisition"] = np.array([acq.get("stroke", k) if isinstance(acq, Mapping) else k], dtype=np.int64)
        if isinstance(acq, Mapping) and "reversal" in acq:  # a stroke's window (docs/method.md 6c)
            st["stroke_reversal"] = np.array([bool(acq["reversal"])])
        t += n / plan.fs
        parts.append(st)
    if not parts:
        raise ValueError("the list of acquisitions is empty")
    return _concat(parts), aux_role


def _with_length(plan: Plan, n: int) -> Plan:
    """The plan with one window of ``n`` samples (an acquisition is one window)."""
    return dataclasses.replace(plan, length=n)
