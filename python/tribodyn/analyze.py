"""Long recordings: ``tribodyn.analyze`` (docs/method.md section 6).

Reads a recording chunk by chunk, optionally high-passes raw (DC-coupled)
channels with the streaming filter, cuts windows of ``window`` s every
``hop`` s, computes each window's COF statistics in the Rust kernel, joins
temperature and current, and fixes the orientation once for the recording.
The per-window table does not depend on the chunk size or thread count, and
memory does not grow with the recording's length.

Three ways in, one result (bit for bit):

- a recording whose channels lie in the file as contiguous float64 runs (a
  channels-first ``.npy``): one call of ``_core.windows_stats_file`` reads
  the file's pages through memory maps, block by block, in parallel (raw
  input: high-passed one block ahead of the windows), with no Python per
  chunk (:func:`_stream_file`);
- another random-access recording (HDF5, TDMS, other ``.npy``) with dynamic
  input: spans read concurrently, one thread each (:func:`_stream_spans`);
- anything else (mappings, iterators, sequential formats, raw input): one
  stream of chunks, reading overlapped with the kernel (:func:`_run_chunks`).
"""

from __future__ import annotations

import contextlib
import os
from collections import deque
from collections.abc import Iterable, Iterator, Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, Deque, Dict, List, Optional, Sequence

import numpy as np

from . import _core
from ._validate import as_signal, check_fs, check_int, positive
from .covariates import as_log, branch, constant_or_log, evaluate, interpolate
from .deadband import DeadbandSpec, parse_deadband
from .filters import HighPass
from .identify import Orientation, check_gate, resolve_orientation
from .results import Results
from .window_stats import compute, gate_reasons, orient
from .windowing import Windower

__all__ = ["analyze", "threads_limited"]

FORCE_ROLES = ("fx", "fy", "fz")
#: Samples per chunk read from a recording by default: large enough that the
#: per-chunk Python work is small beside the kernel's, small enough to stay
#: in cache between reading and analysing (and a multiple of the readers'
#: 65536-row blocks, so no chunk is pieced together).
DEFAULT_CHUNK = 1 << 17
#: Samples per chunk when spans of a random-access recording are read
#: concurrently (one thread each, the kernel on that thread): larger, since
#: each chunk is one call of the kernel and, for a ``.npy``, one mapping of
#: the file (8 MiB per channel; two spans of four channels map 64 MiB).
SPAN_CHUNK = 1 << 20


@contextlib.contextmanager
def threads_limited(threads: Optional[int]) -> Iterator[None]:
    """Runs the block with the kernels limited to ``threads`` (None: unchanged)."""
    if threads is None:
        yield
        return
    n = check_int(threads, "threads", minimum=1)
    before = _core.get_threads()
    _core.set_threads(n)
    try:
        yield
    finally:
        _core.set_threads(before)


def _is_recording(source: Any) -> bool:
    return hasattr(source, "chunks") and hasattr(source, "fs") and not isinstance(source, Mapping)


def _check_chunk(chunk: Any, where: str, needed: Sequence[str]) -> Dict[str, np.ndarray]:
    if not isinstance(chunk, Mapping):
        raise TypeError(
            f"{where} must be a mapping of role -> array (roles fx, fy, fz, i, u), got {type(chunk).__name__}"
        )
    missing = [r for r in needed if r not in chunk]
    if missing:
        raise ValueError(
            f"{where} lacks the required channel(s) {', '.join(missing)} (has {', '.join(map(str, chunk)) or 'none'})"
        )
    # No NaN/inf scan here: the kernel refuses a non-finite sample in any
    # window as it sums it, and the high-pass filter checks every sample it
    # filters; samples outside every window change no result.
    out = {
        str(k): as_signal(v, f"{where}[{k!r}]", min_len=0, check_finite=False)
        for k, v in chunk.items()
        if k in ("fx", "fy", "fz", "i", "u", "cof")
    }
    lengths = {k: len(v) for k, v in out.items()}
    if len(set(lengths.values())) > 1:
        raise ValueError(f"{where}: channels must have equal lengths, got {lengths}")
    return out


class _Collector:
    """Receives windows from the Windower and keeps their statistics, in order."""

    def __init__(
        self,
        *,
        length: int,
        fs: float,
        deadband: Any,
        n_bins: int,
        max_lag: Optional[int],
        aux_role: Optional[str],
        raw: bool,
        parallel: bool = True,
    ) -> None:
        self.length, self.fs, self.deadband, self.n_bins = length, fs, deadband, n_bins
        self.max_lag, self.aux_role, self.raw, self.parallel = max_lag, aux_role, raw, parallel
        self.parts: List[Dict[str, np.ndarray]] = []

    def __call__(self, ch: Dict[str, np.ndarray], rel: np.ndarray, absolute: np.ndarray) -> None:
        self.parts.append(self._batch(ch, rel, absolute))

    def finish(self) -> List[Dict[str, np.ndarray]]:
        """The statistics of every window so far, in order (one dict per batch)."""
        return self.parts

    def _batch(self, ch: Dict[str, np.ndarray], rel: np.ndarray, absolute: np.ndarray) -> Dict[str, np.ndarray]:
        aux = ch.get(self.aux_role) if self.aux_role else None
        raw = (ch["fy_raw"], ch["fz_raw"]) if self.raw else None
        try:
            st = compute(
                ch.get("fx"),
                ch["fy"],
                ch["fz"],
                aux,
                rel,
                self.length,
                self.deadband,
                self.n_bins,
                raw=raw,
                parallel=self.parallel,
            )
        except ValueError:
            _raise_non_finite(ch, rel, absolute, self.length, self.fs)
            raise
        for key in _UNUSED:
            del st[key]
        st["start"] = absolute.astype(np.int64)
        if not self.raw:
            del st["mu_classic"]
        if "cof" in ch:
            st["mu_instrument"] = _window_means(ch["cof"], rel, self.length)
        if self.max_lag is not None:
            st["skew"] = _skews(ch["fy"], ch["fz"], rel, self.length, self.max_lag)
        return st


#: Kernel outputs the table does not use (dropped per batch: a long
#: recording's table is then about 60 doubles per window, held once).
_UNUSED = ("intercept_stderr", "resid_std", "sse", "szz", "syy")


def _raise_non_finite(ch: Dict[str, np.ndarray], rel: np.ndarray, absolute: np.ndarray, length: int, fs: float) -> None:
    """Names the first window holding NaN or inf (the kernel's error speaks of chunk offsets)."""
    for s, a in zip(rel, absolute):
        for role in ("fz", "fy", "fx", "i", "u", "fz_raw", "fy_raw"):
            if role in ch and not np.isfinite(ch[role][s : s + length]).all():
                raise ValueError(
                    f"{role.removesuffix('_raw')} contains NaN or inf in the window starting at "
                    f"sample {a} (t = {a / fs:g} s)"
                )


def _window_means(x: np.ndarray, rel: np.ndarray, length: int) -> np.ndarray:
    """Mean of |x| per window, NaN samples skipped (an instrument's COF column)."""
    out = np.full(len(rel), np.nan)
    for k, s in enumerate(rel):
        v = np.abs(x[s : s + length])
        v = v[np.isfinite(v)]
        if v.size:
            out[k] = v.mean()
    return out


def _skews(fy: np.ndarray, fz: np.ndarray, rel: np.ndarray, length: int, max_lag: int) -> np.ndarray:
    out = np.full(len(rel), np.nan)
    lag = min(max_lag, length - 1)
    for k, s in enumerate(rel):
        c = _core.xcorr(np.ascontiguousarray(fy[s : s + length]), np.ascontiguousarray(fz[s : s + length]), lag, "auto")
        if np.isfinite(c).any():
            out[k] = int(np.nanargmax(np.abs(c))) - lag
    return out


def sign_of_total_slope(st: Dict[str, np.ndarray]) -> float:
    """S_xy of fy on fz of all windows merged (within + between parts): its sign is the slope's.

    ``st`` holds per-window ``n``, ``mean_z``, ``mean_y`` and ``syz``.
    """
    n = st["n"]
    if n.sum() == 0:
        return float("nan")
    w = n / n.sum()
    mz, my = np.sum(w * st["mean_z"]), np.sum(w * st["mean_y"])
    return float(np.sum(st["syz"]) + np.sum(n * (st["mean_z"] - mz) * (st["mean_y"] - my)))


def _chunks_of(source: Any, fs_chunk: int) -> Iterable[Any]:
    if isinstance(source, Mapping):
        n = len(next(iter(source.values()))) if source else 0
        if fs_chunk <= 0 or n <= fs_chunk:
            return [source]
        return ({k: v[s : s + fs_chunk] for k, v in source.items()} for s in range(0, n, fs_chunk))
    return source


def analyze(
    source: Any,
    *,
    fs: Optional[float] = None,
    window: float = 2.0,
    hop: float = 10.0,
    highpass: Optional[float] = None,
    orientation: Orientation = "auto",
    temperature: Any = None,
    current: Any = None,
    voltage: Any = None,
    shunt_ohm: Optional[float] = None,
    area_mm2: Optional[float] = None,
    chunk: Optional[float] = None,
    progress: bool = False,
    deadband: DeadbandSpec = 0.35,
    n_bins: int = 16,
    gate: float = 0.85,
    max_lag: Optional[int] = None,
    rpm: Optional[float] = None,
    n_lamellas: Optional[int] = None,
    threads: Optional[int] = None,
    start: int = 0,
    stop: Optional[int] = None,
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
        - a recording from :func:`tribodyn.open_recording` (read in chunks).
    fs : float
        Sampling rate in Hz (taken from a recording when omitted).
    window, hop : float
        Window length and start-to-start spacing in s (paper 2 and 10;
        ``hop == window`` tiles the recording). Only complete windows count.
    highpass : float, optional
        Cut-off in Hz of a first-order Butterworth high-pass applied to raw,
        DC-coupled force channels first (streaming, state carried, "steady"
        start). None for dynamic forces as delivered by the paper's charge
        amplifier. With it, the table also has ``mu_classic``, the classical
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
    chunk : float, optional
        Seconds per chunk when reading a mapping or a recording (default
        131072 samples, about 2 min at 1 kHz, for a recording; a mapping is
        taken whole). For a channels-first float64 ``.npy`` the kernel reads
        the file's pages itself, in blocks of at most this many seconds
        (default 2^20 samples) per thread. Never changes a result.
    progress : bool
        Show a progress bar on stderr.
    deadband, n_bins, gate, max_lag, rpm, n_lamellas
        As for :func:`tribodyn.identify`, per window. ``max_lag`` adds the
        channel skew per window (costly: one correlation function per window).
        ``rpm``/``n_lamellas`` are recorded in ``params`` (spectra are per
        acquisition, in :func:`tribodyn.identify`).
    threads : int, optional
        Threads for the kernels (default: all cores, or the TRIBODYN_THREADS
        environment variable). Results do not depend on it.
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
        Per-window table, bins and the parameters used.

    Raises
    ------
    ValueError, TypeError
        fs <= 0, window or hop <= 0, a window longer than the recording, a
        missing or unequal channel, a bad temperature log, a voltage without
        ``shunt_ohm``.
    """
    rec = source if _is_recording(source) else None
    if fs is None:
        if rec is None:
            raise TypeError("analyze needs fs= (the sampling rate in Hz)")
        fs = rec.fs
    fs_v = check_fs(fs)
    w_s = positive(window, "window")
    h_s = positive(hop, "hop")
    length = int(round(w_s * fs_v))
    step = int(round(h_s * fs_v))
    if length < 3:
        raise ValueError(f"window = {window} s is under 3 samples at fs = {fs_v:g} Hz")
    if step < 1:
        raise ValueError(f"hop = {hop} s is under one sample at fs = {fs_v:g} Hz")
    db = parse_deadband(deadband)
    nb = check_int(n_bins, "n_bins", minimum=1)
    g = check_gate(gate)
    if max_lag is not None:
        check_int(max_lag, "max_lag", minimum=0)
    if (
        isinstance(orientation, str)
        and orientation != "auto"
        or (not isinstance(orientation, str) and orientation not in (1, -1))
    ):
        raise ValueError(f"orientation must be +1, -1 or 'auto', got {orientation!r}")
    temp_log = None if temperature is None else as_log(temperature, "temperature")
    if voltage is not None or shunt_ohm is not None:
        if shunt_ohm is None:
            raise ValueError("voltage needs shunt_ohm (i = u / R)")
        shunt = positive(shunt_ohm, "shunt_ohm")
    else:
        shunt = None
    cur_log = constant_or_log(current, "current")
    volt_log = constant_or_log(voltage, "voltage")
    area = None if area_mm2 is None else positive(area_mm2, "area_mm2")
    hp_fc = None if highpass is None else positive(highpass, "highpass")
    chunk_n = None if chunk is None else max(1, int(round(positive(chunk, "chunk") * fs_v)))
    origin = check_int(start, "start", minimum=0)
    end: Optional[int] = None
    if stop is not None:
        if rec is None:
            raise ValueError(
                "stop= applies to a recording source (a mapping or a stream of chunks ends where it "
                "ends; slice it instead)"
            )
        end = check_int(stop, "stop", minimum=0)
        n_rec = getattr(rec, "n_samples", None)
        if end < origin or (isinstance(n_rec, int) and end > n_rec):
            raise ValueError(
                f"stop must satisfy start <= stop <= {n_rec} (the recording's samples), got start={origin}, stop={end}"
            )

    params: Dict[str, Any] = dict(
        fs=fs_v,
        window=w_s,
        hop=h_s,
        window_samples=length,
        hop_samples=step,
        highpass=hp_fc,
        orientation=orientation,
        deadband=str(db),
        n_bins=nb,
        gate=g,
        max_lag=max_lag,
        rpm=rpm,
        n_lamellas=n_lamellas,
        area_mm2=area,
        shunt_ohm=shunt,
        chunk_samples=chunk_n,
        temperature_log_points=None if temp_log is None else int(temp_log[0].size),
    )

    with threads_limited(threads if threads is not None else _env_threads()):
        if isinstance(source, (list, tuple)):
            st, aux_role = _acquisitions(source, fs_v, db, nb, hp_fc, max_lag, shunt)
        else:
            st, aux_role = _stream(
                source, rec, fs_v, length, step, db, nb, hp_fc, max_lag, chunk_n, progress, shunt, origin, end
            )

    if len(st["n"]) == 0:
        if end is not None:
            raise ValueError(
                f"samples {origin}..{end} hold no whole window ({w_s:g} s = {length} samples, starting "
                f"every {step} samples from sample 0): no window to analyse"
            )
        raise ValueError(
            f"the recording is shorter than one window ({w_s:g} s = {length} samples): no window to analyse"
        )
    s = resolve_orientation(orientation, sign_of_total_slope(st))
    moments = {k: np.asarray(st[k], dtype=float) for k in ("n", "mean_z", "mean_y", "syz")}
    if "acquisition" not in st:
        st["acquisition"] = np.zeros(len(st["n"]), dtype=np.int64)
    o = orient(st, s, inplace=True)
    del st
    t_start = o["start"] / fs_v
    if "t0" in o:
        t_start = o["t0"]
    n_win = o["n"]
    centre = t_start + 0.5 * n_win / fs_v
    reasons = gate_reasons(o, g, o.get("skew"))

    cur = np.full(len(centre), np.nan)
    if aux_role == "i":
        cur = o["aux_mean"]
    elif aux_role == "u":
        cur = o["aux_mean"] / shunt  # type: ignore[operator]
    elif cur_log is not None:
        cur = evaluate(cur_log, centre)
    elif volt_log is not None:
        cur = evaluate(volt_log, centre) / shunt  # type: ignore[operator]
    table: Dict[str, np.ndarray] = {
        "time": centre,
        "t_start": t_start,
        "mu_r": o["mu_r"],
        "mu_r_stderr": o["mu_r_stderr"],
        "f_y0": o["f_y0"],
        "r": o["r"],
        "mu_a": o["mu_a"],
        "mu_b": o["mu_b"],
        "force_dependence": o["force_dependence"],
        "c_xy": o["c_xy"],
        "c_xz": o["c_xz"],
        "c_yz": o["c_yz"],
        "skew": o.get("skew", np.full(len(centre), np.nan)),
        "ok": np.asarray(reasons == "", dtype=bool),
        "reasons": reasons.astype(str),
        "T": interpolate(temp_log, centre) if temp_log is not None else np.full(len(centre), np.nan),
        "branch": branch(temp_log, centre) if temp_log is not None else np.zeros(len(centre), dtype=np.int8),
        "i": cur,
        "J": cur / area if area is not None else np.full(len(centre), np.nan),
        "mu_classic": o.get("mu_classic", np.full(len(centre), np.nan)),
        "mu_instrument": o.get("mu_instrument", np.full(len(centre), np.nan)),
        "deadband": o["deadband"],
        "n": np.asarray(n_win, dtype=np.int64),
        "acquisition": o["acquisition"],
    }
    params["orientation_used"] = s
    params["start"] = origin
    params["stop"] = end
    return Results(
        table=table,
        bin_counts=np.asarray(o["bin_count"], dtype=np.int64),
        bin_cof=o["bin_cof"],
        fz_min=o["fz_min"],
        fz_max=o["fz_max"],
        orientation=s,
        params=params,
        moments=moments,
    )


def _env_threads() -> Optional[int]:
    v = os.environ.get("TRIBODYN_THREADS")
    if not v:
        return None
    try:
        return max(1, int(v))
    except ValueError:
        raise ValueError(f"TRIBODYN_THREADS must be a whole number, got {v!r}") from None


def _concat(parts: List[Dict[str, np.ndarray]]) -> Dict[str, np.ndarray]:
    """Joins the batches column by column, freeing each column's pieces as it goes."""
    if not parts:
        return {"n": np.zeros(0, dtype=np.int64)}
    out = {}
    for k in list(parts[0]):
        out[k] = np.concatenate([p.pop(k) for p in parts]) if len(parts) > 1 else parts[0].pop(k)
    parts.clear()
    return out


def _aux_role(chunk: Mapping, shunt: Optional[float]) -> Optional[str]:
    if "i" in chunk:
        return "i"
    if "u" in chunk:
        if shunt is None:
            raise ValueError("the source has a voltage channel 'u': give shunt_ohm (i = u / R)")
        return "u"
    return None


def _stream(
    source: Any,
    rec: Any,
    fs: float,
    length: int,
    step: int,
    db: Any,
    nb: int,
    hp_fc: Optional[float],
    max_lag: Optional[int],
    chunk_n: Optional[int],
    progress: bool,
    shunt: Optional[float],
    origin: int = 0,
    end: Optional[int] = None,
):
    threads = _core.get_threads()
    if rec is not None and max_lag is None and not progress:
        mapped = _stream_file(rec, origin, fs, length, step, db, nb, hp_fc, chunk_n, shunt, threads, end)
        if mapped is not None:
            return mapped
    if rec is not None:
        size = chunk_n or DEFAULT_CHUNK
        total = end if end is not None else getattr(rec, "n_samples", None)
        spans = _spans(rec, origin, length, step, threads, end) if hp_fc is None else None
        if spans:
            # Large chunks where they are views of the file (no copy); the
            # default where the reader copies, so that copies stay small.
            views = getattr(rec, "_can_view", lambda: False)()
            return _stream_spans(
                rec,
                spans,
                chunk_n or (SPAN_CHUNK if views else DEFAULT_CHUNK),
                fs,
                length,
                step,
                db,
                nb,
                max_lag,
                progress,
                shunt,
            )
        # Views where the format has them: nothing here writes into a chunk.
        chunks: Iterable[Any] = rec.chunks(size, start=origin, stop=end, copy=False)
    elif isinstance(source, Mapping):
        chunks = _chunks_of(source, chunk_n or DEFAULT_CHUNK)
        total = len(next(iter(source.values()))) if source else 0
    elif isinstance(source, Iterable) and not isinstance(source, (str, bytes)):
        chunks = source
        total = None
    else:
        raise TypeError(
            "source must be a mapping, an iterable of mappings, a list of acquisitions or a recording, "
            f"got {type(source).__name__}"
        )
    bar = _progress(progress, total)
    try:
        # Overlap reading with the kernel only when two threads may run: with
        # one, the whole pipeline stays on one core.
        parts, aux_role = _run_chunks(
            chunks, origin, fs, length, step, db, nb, hp_fc, max_lag, shunt, bar, pipelined=threads >= 2
        )
    finally:
        if bar is not None:
            bar.close()
    return _concat(parts), aux_role


def _stream_file(
    rec: Any,
    origin: int,
    fs: float,
    length: int,
    step: int,
    db: Any,
    nb: int,
    hp_fc: Optional[float],
    chunk_n: Optional[int],
    shunt: Optional[float],
    threads: int,
    end: Optional[int] = None,
):
    """A recording whose channels the kernel can read from the file's own pages (a float64 ``.npy``).

    One call of ``_core.windows_stats_file``: the file is memory-mapped a
    block of windows at a time, with no copy and no Python per chunk. For
    dynamic input the blocks run in parallel; raw input is high-passed
    block after block (the same filter, state and bits as ``HighPass``),
    one block ahead of the windows. None when the recording does not allow
    it (another format, scaled channels, an instrument ``cof`` column,
    overlapping windows with ``highpass``) or the call fails (a NaN, say):
    the streaming path then runs and words any error.
    """
    roles = getattr(rec, "roles", None)
    layout_of = getattr(rec, "file_layout", None)
    if not isinstance(roles, Mapping) or layout_of is None or "cof" in roles or not {"fy", "fz"} <= set(roles):
        return None
    aux = _aux_role(roles, shunt)
    wanted = [r for r in FORCE_ROLES if r in roles] + ([aux] if aux else [])
    found = layout_of(wanted)
    n_rec = getattr(rec, "n_samples", None)
    if found is None or not isinstance(n_rec, int):
        return None
    n = n_rec if end is None else end  # windows end by here
    fd, layout = found
    k0 = -(-origin // step)
    k1 = (n - length) // step + 1 if n >= length else 0
    if k1 <= k0:
        return None
    # Windows per task: at most SPAN_CHUNK samples (or the chunk asked
    # for), in equal blocks, a multiple of the threads in number, so that
    # the threads finish together and the memory mapped at once (a block
    # per thread) hardly depends on the recording's length.
    count = k1 - k0
    cap = max(1, (chunk_n or SPAN_CHUNK) // step)
    blocks = -(-count // cap)
    blocks = -(-blocks // threads) * threads
    block = max(1, -(-count // blocks))
    offsets = (layout.get("fx"), layout["fy"], layout["fz"], layout[aux] if aux else None)
    sos = zi = None
    if hp_fc is not None:
        if step < length:
            return None
        hp = HighPass(fs, cutoff=hp_fc)
        sos, zi = hp.sos, hp._zi
        block = cap
    try:
        st = _core.windows_stats_file(
            fd, offsets, n_rec, k0, k1, step, length, 1.0, db.kind, float(db.value), nb, block, sos, zi, origin
        )
    except (ValueError, OSError):
        return None
    for key in _UNUSED + (() if hp_fc is not None else ("mu_classic",)):
        del st[key]
    st["start"] = np.arange(k0, k1, dtype=np.int64) * step
    return st, aux


#: Formats whose readers read any range of samples directly.
_RANDOM_ACCESS = ("npy", "hdf5", "tdms")
#: Fewest windows per concurrently read span.
_MIN_SPAN_WINDOWS = 64


def _spans(
    rec: Any, origin: int, length: int, step: int, threads: int, end: Optional[int] = None
) -> Optional[List[tuple]]:
    """Sample ranges of a recording, one per thread, on the window grid; None to read it as one stream.

    With one thread the whole recording is one span (read the same way:
    large chunks, views where the format has them, the kernel on the
    reading thread).

    Span j reads [k_j * step, (k_{j+1} - 1) * step + length) and holds exactly
    the windows k_j .. k_{j+1} - 1, so the spans' windows are the recording's,
    each once, with the same samples.
    """
    n = getattr(rec, "n_samples", None)
    if getattr(rec, "format", None) not in _RANDOM_ACCESS or not isinstance(n, int):
        return None
    n = n if end is None else end
    k0 = -(-origin // step)
    k1 = (n - length) // step + 1 if n >= length else 0  # one past the last window
    count = k1 - k0
    parts = min(threads, count // _MIN_SPAN_WINDOWS)
    if parts < 1:
        return None
    ks = [k0 + (count * j) // parts for j in range(parts + 1)]
    return [(ks[j] * step, (ks[j + 1] - 1) * step + length) for j in range(parts)]


def _stream_spans(
    rec: Any,
    spans: List[tuple],
    size: int,
    fs: float,
    length: int,
    step: int,
    db: Any,
    nb: int,
    max_lag: Optional[int],
    progress: bool,
    shunt: Optional[float],
):
    """Reads and analyses the spans concurrently, one thread each (dynamic input only: no filter state).

    The reader's copies and the kernel release the GIL, so the spans run in
    parallel; the batches are joined in span order, so the table is the one
    of a single stream.
    """
    bar = _progress(progress, sum(b - a for a, b in spans))
    try:
        with ThreadPoolExecutor(len(spans), thread_name_prefix="tribodyn-span") as ex:
            futures = [
                ex.submit(
                    _run_chunks,
                    rec.chunks(size, start=a, stop=b, copy=False),
                    a,
                    fs,
                    length,
                    step,
                    db,
                    nb,
                    None,
                    max_lag,
                    shunt,
                    bar,
                    pipelined=False,
                    parallel=False,
                )
                for a, b in spans
            ]
            results = [f.result() for f in futures]
    finally:
        if bar is not None:
            bar.close()
    return _concat([st for parts, _ in results for st in parts]), results[0][1]


def _run_chunks(
    chunks: Iterable[Any],
    origin: int,
    fs: float,
    length: int,
    step: int,
    db: Any,
    nb: int,
    hp_fc: Optional[float],
    max_lag: Optional[int],
    shunt: Optional[float],
    bar: Any,
    *,
    pipelined: bool,
    depth: int = 2,
    parallel: bool = True,
):
    """Checks, filters and windows a stream of chunks; the batches of window statistics, in order.

    With ``pipelined``, the caller's thread only reads (the reader's copies
    release the GIL) while one worker thread filters, windows and runs the
    kernel (which releases the GIL and uses the kernel threads), chunk after
    chunk in order, at most ``depth`` chunks ahead: the filter state and the
    windower's tail are only ever touched by that worker.
    """
    stage = _Stage(origin, fs, length, step, db, nb, hp_fc, max_lag, shunt, parallel)
    if not pipelined:
        for i, raw_chunk in enumerate(chunks):
            stage.push(_check_chunk(raw_chunk, f"chunk {i}", ("fy", "fz")), i)
            if bar is not None:
                bar.update(len(raw_chunk["fz"]))
        return stage.finish()
    pending: Deque[Future] = deque()
    with ThreadPoolExecutor(1, thread_name_prefix="tribodyn") as ex:
        try:
            for i, raw_chunk in enumerate(chunks):
                ch = _check_chunk(raw_chunk, f"chunk {i}", ("fy", "fz"))
                while len(pending) >= depth:
                    pending.popleft().result()
                pending.append(ex.submit(stage.push, ch, i))
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

    def __init__(
        self,
        origin: int,
        fs: float,
        length: int,
        step: int,
        db: Any,
        nb: int,
        hp_fc: Optional[float],
        max_lag: Optional[int],
        shunt: Optional[float],
        parallel: bool = True,
    ) -> None:
        self.origin, self.fs, self.length, self.step, self.db, self.nb = origin, fs, length, step, db, nb
        self.parallel = parallel
        self.hp_fc, self.max_lag, self.shunt = hp_fc, max_lag, shunt
        self.collector: Optional[_Collector] = None
        self.windower: Optional[Windower] = None
        self.hp: Optional[HighPass] = None
        self.force_roles: List[str] = []

    def push(self, ch: Dict[str, np.ndarray], i: int) -> None:
        if self.collector is None:
            aux = _aux_role(ch, self.shunt)
            self.force_roles = [r for r in FORCE_ROLES if r in ch]
            self.collector = _Collector(
                length=self.length,
                fs=self.fs,
                deadband=self.db,
                n_bins=self.nb,
                max_lag=self.max_lag,
                aux_role=aux,
                raw=self.hp_fc is not None,
                parallel=self.parallel,
            )
            self.windower = Windower(self.length, self.step, self.collector, origin=self.origin)
            if self.hp_fc is not None:
                self.hp = HighPass(self.fs, cutoff=self.hp_fc, channels=len(self.force_roles))
        elif set(self.force_roles) - set(ch):
            missing = sorted(set(self.force_roles) - set(ch))
            raise ValueError(f"chunk {i} lacks channel(s) present in the first chunk: {missing}")
        if self.hp is not None:
            # The filter refuses NaN/inf as it reads every sample.
            try:
                filtered = self.hp.process(np.stack([ch[r] for r in self.force_roles]))
            except ValueError:
                bad = [r for r in self.force_roles if not np.isfinite(ch[r]).all()]
                if not bad:
                    raise
                raise ValueError(
                    f"{bad[0]} contains NaN or inf in chunk {i} (the high-pass filter needs every sample)"
                ) from None
            ch["fy_raw"], ch["fz_raw"] = ch["fy"], ch["fz"]
            for k, r in enumerate(self.force_roles):
                ch[r] = filtered[k]
        assert self.windower is not None
        self.windower.push(ch)

    def finish(self) -> tuple:
        if self.collector is None:
            raise ValueError("the source holds no samples")
        return self.collector.finish(), self.collector.aux_role


def _progress(on: bool, total: Optional[int]) -> Any:
    if not on:
        return None
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover - tqdm is a dependency
        return None
    return tqdm(total=total, unit="sample", unit_scale=True, desc="analyse", leave=False)


def _acquisitions(
    source: Sequence[Any],
    fs: float,
    db: Any,
    nb: int,
    hp_fc: Optional[float],
    max_lag: Optional[int],
    shunt: Optional[float],
):
    parts: List[Dict[str, np.ndarray]] = []
    t = 0.0
    aux_role: Optional[str] = None
    for k, acq in enumerate(source):
        ch = _check_chunk(acq, f"acquisition {k}", ("fy", "fz"))
        n = len(ch["fz"])
        if n < 3:
            raise ValueError(f"acquisition {k} has {n} samples; at least 3 are needed")
        aux_role = _aux_role(ch, shunt) if k == 0 else aux_role
        if hp_fc is not None:
            roles = [r for r in FORCE_ROLES if r in ch]
            filtered = HighPass(fs, cutoff=hp_fc, channels=len(roles)).process(np.stack([ch[r] for r in roles]))
            ch["fy_raw"], ch["fz_raw"] = ch["fy"], ch["fz"]
            for j, r in enumerate(roles):
                ch[r] = filtered[j]
        col = _Collector(
            length=n, fs=fs, deadband=db, n_bins=nb, max_lag=max_lag, aux_role=aux_role, raw=hp_fc is not None
        )
        st = col._batch(ch, np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.int64))
        t0 = acq.get("t0") if isinstance(acq, Mapping) else None
        st["t0"] = np.array([float(t0) if t0 is not None else t])
        st["acquisition"] = np.array([k], dtype=np.int64)
        t += n / fs
        parts.append(st)
    if not parts:
        raise ValueError("the list of acquisitions is empty")
    return _concat(parts), aux_role
