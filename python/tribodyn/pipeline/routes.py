"""The routes of :func:`tribodyn.analyze`: reading a source and running the kernel on its windows (docs/method.md 6, 9).

The route is chosen from the plan and from what the source declares it can
do (:func:`choose_route`), before anything is read; :func:`run` takes it and
returns the kernel's per-window statistics, which
:func:`tribodyn.pipeline.finish.finish` turns into the table:

``"mapped"``
    The recording lays its channels out as contiguous float64 runs
    (``Recording.mappable`` and :meth:`~tribodyn.io.Recording.file_layout`):
    one call of ``_core.windows_stats_file`` maps the channels block by
    block, in parallel (raw input: high-passed one block ahead of the
    windows), with no Python per chunk.
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
``"segments"``
    A recording of separate acquisitions (``Recording.acquisitions``):
    each windowed from its own first sample, no window straddles two.
``"acquisitions"``
    A list of separate acquisitions, one window each.

The per-window table does not depend on the route, the chunk size or the
thread count. Every kernel call takes the analysis' one frozen
``_core.WindowSpec`` (:class:`KernelSpec`). An error of a reader or a kernel
surfaces as it is (the binding names a NaN or inf by its role, window and
time); no route falls back to another.
"""

from __future__ import annotations

import contextvars
import dataclasses
import os
from collections import deque
from collections.abc import Iterable, Mapping
from concurrent.futures import Future
from typing import Any, Deque, Dict, List, Optional, Protocol, Sequence, Tuple

import numpy as np

from .. import _core
from ..io.base import RecordingError, RecordingProtocol
from ..kernels._validate import as_signal
from ..kernels.filters import HighPass
from ..kernels.window_stats import compute, make_spec
from ..kernels.threads import thread_pool
from ..results import ClassicalTotals
from .headline import BlockSums
from .plan import Findings, Plan
from .windowing import Windower


class Tap(Protocol):
    """What takes the raw chunks of the route "stream" as they are read, in order (``run(taps=...)``)."""

    def push(self, first: int, piece: Mapping[str, np.ndarray]) -> None:
        """Samples ``first``.. (the recording's index) of the chunk ``piece``, raw, before any filter."""


@dataclasses.dataclass(frozen=True)
class PassInputs:
    """What an optional pass over the data (:data:`tribodyn.pipeline.passes.PASSES`) is given, to build its tap
    before the main pass and to store its result before ``settle``.

    Attributes
    ----------
    source, rec
        The source as the analysis reads it, and its recording (None for a mapping or chunks).
    plan, found
        The analysis' plan and what the pre-pass found (the classical COF's threshold and tare).
    params : mapping
        The pre-pass's findings as ``Results.params`` records them (docs/method.md 6a-6d), with ``fs``,
        ``start`` and ``stop``.
    strokes : mapping or None
        The per-stroke table of a reciprocating test (docs/method.md 6c), None otherwise.
    """

    source: Any
    rec: Optional[RecordingProtocol]
    plan: Plan
    found: Findings
    params: Mapping[str, Any]
    strokes: Optional[Mapping[str, np.ndarray]]


__all__ = [
    "KernelRun",
    "PassInputs",
    "Tap",
    "KernelSpec",
    "run",
    "choose_route",
    "concat_stats",
    "DEFAULT_CHUNK",
    "MAPPED_BLOCK",
    "FORCE_ROLES",
]

FORCE_ROLES = ("fx", "fy", "fz")
#: Samples per chunk read from a recording by default: large enough that the
#: per-chunk Python work is small beside the kernel's, small enough to stay
#: in cache between reading and analysing (and a multiple of the readers'
#: 65536-row blocks, so no chunk is pieced together).
DEFAULT_CHUNK = 1 << 17
#: Samples per block of the route "mapped" (at most; a block is whole
#: windows): each thread reads a block's channels into buffers it reuses,
#: small enough to stay in cache between the read and the windows (a block's
#: span, or only its windows' own samples when they are at least
#: ``_core.MAPPED_ALONE_GAP`` apart: the gaps are then not read).
#: 2^15 measured fastest here (benches/RESULTS.md); ``chunk=`` overrides it.
MAPPED_BLOCK = 1 << 15
#: Fewest windows per concurrently read span.
_MIN_SPAN_WINDOWS = 64
#: Roles the pipeline reads from a source.
PIPELINE_ROLES = ("fx", "fy", "fz", "i", "u", "cof", "v")

Stats = Dict[str, np.ndarray]


@dataclasses.dataclass(frozen=True)
class KernelRun:
    """What a route returns: the kernel's per-window statistics, not yet finished (docs/method.md 6)."""

    #: Per-window statistics, orientation +1 (``tribodyn.columns``), consumed by :func:`pipeline.finish.finish`.
    st: Stats
    #: "i" or "u" when the source has a current or shunt-voltage channel, else None.
    aux_role: Optional[str]
    #: The route taken (:func:`choose_route`).
    route: str
    #: The reader's warnings.
    warnings: Tuple[str, ...]
    #: The classical COF's block sums taken from the chunks read (docs/method.md 6e), or None.
    classical: Optional[ClassicalTotals] = None


@dataclasses.dataclass(frozen=True)
class KernelSpec:
    """The kernel's settings for one analysis, made once from its plan and findings (docs/architecture.md).

    ``window`` is the frozen ``_core.WindowSpec`` every kernel call of the
    analysis takes, its settings checked and converted once; :meth:`spec`
    gives its variants (an acquisition's own length, the auxiliary role,
    a span's one thread), each made once.
    """

    plan: Plan
    #: The kernel's settings: the plan's window, deadband, bins, columns, options, threads, high-pass of raw forces,
    #: and how a NaN or inf is named (role, time).
    window: _core.WindowSpec
    _variants: Dict[Tuple[Optional[int], Optional[str], Optional[int]], _core.WindowSpec] = dataclasses.field(
        default_factory=dict, repr=False, compare=False
    )

    @classmethod
    def of(cls, plan: Plan, found: Findings) -> "KernelSpec":
        columns, options = plan.kernel_columns(found), plan.kernel_options(found)
        highpass = None
        if plan.raw:
            hp = HighPass(plan.fs, cutoff=_cutoff(plan))
            highpass = (hp.sos, hp.steady_state)
        window = make_spec(plan.length, plan.deadband, plan.n_bins, columns, options=options, threads=plan.threads,
                           highpass=highpass, naming=("aux", plan.fs))  # fmt: skip
        return cls(plan, window)

    def spec(self, *, length: Optional[int] = None, aux_role: Optional[str] = None,
             threads: Optional[int] = None) -> _core.WindowSpec:  # fmt: skip
        """``window`` for windows of ``length`` samples, an auxiliary channel ``aux_role`` and ``threads``."""
        key = (
            None if length == self.plan.length else length,
            aux_role,
            None if threads == self.plan.threads else threads,
        )
        if key == (None, None, None):
            return self.window
        got = self._variants.get(key)
        if got is None:  # made once per variant (two threads may both make it: the same value)
            got = self._variants[key] = self.window.replace(length=key[0], aux=key[1], threads=key[2])
        return got


def run(source: Any, rec: Optional[RecordingProtocol], plan: Plan, found: Findings,
        classical_range: Optional[Tuple[int, int]] = None, *, taps: Sequence[Tap] = ()) -> KernelRun:  # fmt: skip
    """The kernel's statistics of every window of ``source`` on the route :func:`choose_route` picks.

    ``found`` (the pre-pass's classical-COF threshold and tare, the fz
    delay of ``align="auto"``) completes the kernel's options. With
    ``classical_range`` and a recording whose pre-pass found the classical
    COF's contact threshold, the chunks read also give the classical COF's
    block sums over that range (``KernelRun.classical``), and with the plan's
    uncertainty inputs the budget's sums too (docs/method.md 6i): the file is read once.
    On the route "stream" every raw chunk also goes to each of ``taps``
    (e.g. :class:`tribodyn.pipeline.stickslip.ReadingPass`), in order; elsewhere
    they get nothing (and say so: their result is None).
    """
    route = choose_route(source, rec, plan, found)
    total = _total(source, rec, plan)
    _check_table_size(plan, total)
    ks = KernelSpec.of(plan, found)
    sums = None
    if (
        rec is not None
        and found.classical is not None
        and classical_range is not None
        and route in ("stream", "segments")
    ):
        sums = BlockSums(found.classical, rec.n_samples, *classical_range, budget=plan.uncertainty is not None)
    if route == "acquisitions":
        st, aux_role = _acquisitions(source, ks)
    elif rec is not None and route == "segments":
        st, aux_role = _run_segments(rec, ks, rec.acquisitions or [], sums)
    elif rec is not None and route == "mapped":
        st, aux_role = _run_mapped(rec, ks)
    elif rec is not None and route == "spans":
        st, aux_role = _run_spans(rec, ks)
    else:
        st, aux_role = _run_stream(_chunk_source(source, rec, plan), ks, total, (sums, *taps) if sums else taps)
    if rec is not None:
        rec.check_unchanged()  # a file changed while it was read: an error, not a table of mixed data
    totals = sums.totals() if sums is not None else None
    return KernelRun(st, aux_role, route, tuple(rec.warnings) if rec is not None else (), totals)


def choose_route(source: Any, rec: Optional[RecordingProtocol], plan: Plan, found: Optional[Findings] = None) -> str:
    """The route for this source and plan (docs/method.md 9), one of the module's five.

    Chosen before anything is read, from the plan and from the
    capabilities a recording declares (``acquisitions``, ``mappable``,
    ``random_access``, ``thread_safe``; see :class:`tribodyn.io.Recording`):
    a recording of several separate acquisitions analysed whole takes
    ``"segments"`` (each windowed from its own first sample). A recording
    whose pre-pass found a classical COF (``found.classical``) is read in
    order, every sample once (``"stream"``), so that the classical COF's
    sums come from the same pass (docs/method.md 6e).
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
    acq = rec.acquisitions
    if acq is not None and len(acq) > 1 and plan.start == 0 and plan.stop is None:
        return "segments"
    if found is not None and found.classical is not None:
        return "stream"
    if _mapped_layout(rec, plan) is not None:
        return "mapped"
    if not plan.raw and rec.random_access and rec.thread_safe and _spans(rec, plan) is not None:
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


# -- the kernel on windows of arrays -------------------------------------------------


def _kernel(ch: Dict[str, np.ndarray], rel: np.ndarray, absolute: np.ndarray, ks: KernelSpec, *,
            aux_role: Optional[str], threads: int, length: Optional[int] = None) -> Stats:  # fmt: skip
    """The statistics of the windows starting at ``rel`` of the arrays ``ch`` (``absolute`` in the recording).

    ``length``: the windows' samples when not the plan's (an acquisition is one window).
    """
    plan = ks.plan
    length = plan.length if length is None else length
    aux = ch.get(aux_role) if aux_role else None
    raw = (ch["fy_raw"], ch["fz_raw"]) if plan.raw else None
    offset = int(absolute[0] - rel[0]) if len(rel) else 0
    # A NaN or inf comes out named by the binding: role, window and time.
    spec = ks.spec(length=length, aux_role=aux_role, threads=threads)
    st = compute(spec, ch["fy"], ch["fz"], rel, fx=ch.get("fx"), aux=aux, raw=raw, offset=offset)
    st["start"] = absolute.astype(np.int64)
    if "cof" in ch:
        st["mu_instrument"] = _window_means(ch["cof"], rel, length)
    if "v" in ch:  # the speed column, mean |v| (docs/method.md 7a)
        st["speed"] = _window_means(ch["v"], rel, length)
    if plan.max_lag is not None:
        st["skew"] = _skews(ch["fy"], ch["fz"], rel, length, plan.max_lag, threads=threads)
    return st  # fmt: skip


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


def _skews(fy: np.ndarray, fz: np.ndarray, rel: np.ndarray, length: int, max_lag: int, *, threads: int) -> np.ndarray:
    out = np.full(len(rel), np.nan)
    lag = min(max_lag, length - 1)
    for k, s in enumerate(rel):
        c = _core.xcorr(np.ascontiguousarray(fy[s : s + length]), np.ascontiguousarray(fz[s : s + length]), lag,
                        "auto", threads=threads)  # fmt: skip
        if np.isfinite(c).any():
            out[k] = int(np.nanargmax(np.abs(c))) - lag
    return out


def concat_stats(parts: List[Stats]) -> Stats:
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
        hint = "; a test whose load is a constant: pass load= (--load N)" if missing == ["fz"] and "fy" in chunk else ""
        raise ValueError(
            f"{where} lacks the required channel(s) {', '.join(missing)} (has {', '.join(map(str, chunk)) or 'none'})"
            + hint
        )
    # No NaN/inf scan here: the kernel refuses a non-finite sample in any
    # window as it sums it, and the high-pass filter checks every sample it
    # filters; samples outside every window change no result.
    out = {
        str(k): as_signal(v, f"{where}[{k!r}]", min_len=0, check_finite=False)
        for k, v in chunk.items()
        if k in PIPELINE_ROLES
    }
    lengths = {k: len(v) for k, v in out.items()}
    if len(set(lengths.values())) > 1:
        raise ValueError(f"{where}: channels must have equal lengths, got {lengths}")
    return out


# -- route "segments" ----------------------------------------------------------------


def _run_segments(rec: RecordingProtocol, ks: KernelSpec, ranges: Sequence[Tuple[int, int]],
                  sums: Optional[BlockSums] = None) -> Tuple[Stats, Optional[str]]:  # fmt: skip
    """Each separate acquisition of a recording windowed from its own first sample (no window straddles two)."""
    plan = ks.plan
    parts: List[Stats] = []
    aux_role: Optional[str] = None
    size = plan.chunk_samples or DEFAULT_CHUNK
    for k, (a, b) in enumerate(ranges):
        if b - a < plan.length:
            continue
        batch, aux = _run_chunks(rec.chunks(size, start=a, stop=b, copy=_copies(rec)), 0, ks, None,
                                 threads=plan.threads, taps=(sums,) if sums else (), base=a)  # fmt: skip
        aux_role = aux_role or aux
        for st in batch:
            st["start"] = np.asarray(st["start"], dtype=np.int64) + a
            st["acquisition"] = np.full(len(st["n"]), k, dtype=np.int64)
            parts.append(st)
    return concat_stats(parts), aux_role


# -- route "mapped" ------------------------------------------------------------------


def _mapped_layout(rec: RecordingProtocol, plan: Plan) -> Optional[Tuple[int, Dict[str, Any], Optional[str]]]:
    """(descriptor, byte offsets, aux role) when the route "mapped" applies, else None (nothing is read)."""
    if not rec.mappable or plan.max_lag is not None or plan.progress:
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


def _run_mapped(rec: RecordingProtocol, ks: KernelSpec) -> Tuple[Stats, Optional[str]]:
    """One call of ``_core.windows_stats_file``: the file's pages, block by block (see the module doc)."""
    plan = ks.plan
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
    # the samples a window takes in a block: its span to the next, or its own when the gaps are not read
    per = plan.length if not plan.raw and _core.mapped_windows_alone(plan.step, plan.length) else plan.step
    cap = max(1, (plan.chunk_samples or MAPPED_BLOCK) // per)
    blocks = -(-count // cap)
    blocks = -(-blocks // plan.threads) * plan.threads
    block = max(1, -(-count // blocks))
    if plan.raw:
        block = cap  # the spec's high-pass runs one block ahead of the windows
    offsets = (layout.get("fx"), layout["fy"], layout["fz"], layout[aux] if aux else None)
    try:
        st = _core.windows_stats_file(ks.spec(aux_role=aux), fd, offsets, n_rec, (k0, k1, plan.step), block=block,
                                      origin=plan.start)  # fmt: skip
    except _core.NonFiniteError:
        raise  # named by the binding: role, window and time
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


def _spans(rec: RecordingProtocol, plan: Plan) -> Optional[List[Tuple[int, int]]]:
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


def _run_spans(rec: RecordingProtocol, ks: KernelSpec) -> Tuple[Stats, Optional[str]]:
    """Reads and analyses the spans concurrently, one thread each (dynamic input: no filter state).

    Only for readers that declare ``thread_safe``. The reader's copies and
    the kernel release the GIL, so the spans run in parallel; the batches
    are joined in span order, so the table is the one of a single stream.
    """
    plan = ks.plan
    spans = _spans(rec, plan)
    assert spans is not None, "choose_route chose 'spans'"
    size = plan.chunk_samples or DEFAULT_CHUNK
    bar = _progress(plan.progress, sum(b - a for a, b in spans))
    try:
        with thread_pool(len(spans), "tribodyn-span") as ex:
            copy = _copies(rec)
            futures = [
                ex.submit(
                    contextvars.copy_context().run,
                    _run_chunks,
                    rec.chunks(size, start=a, stop=b, copy=copy),
                    a,
                    ks,
                    bar,
                    threads=1,
                )
                for a, b in spans
            ]
            results = [f.result() for f in futures]
    finally:
        if bar is not None:
            bar.close()
    return concat_stats([st for parts, _ in results for st in parts]), results[0][1]


# -- route "stream" ------------------------------------------------------------------


def _chunk_source(source: Any, rec: Optional[RecordingProtocol], plan: Plan) -> Iterable[Any]:
    if rec is not None:
        chunks: Iterable[Any] = rec.chunks(
            plan.chunk_samples or DEFAULT_CHUNK, start=plan.start, stop=plan.stop, copy=_copies(rec)
        )
        return chunks
    if isinstance(source, Mapping):
        n = len(next(iter(source.values()))) if source else 0
        size = plan.chunk_samples or DEFAULT_CHUNK
        if n <= size:
            return [source]
        return ({k: v[s : s + size] for k, v in source.items()} for s in range(0, n, size))
    out: Iterable[Any] = source
    return out


def _copies(rec: RecordingProtocol) -> bool:
    """Whether the pipeline asks a recording for copies: only of a reader that would hand out views of a memory
    map (a file truncated while it is read must be an error, not a SIGBUS). Nothing in the pipeline writes into a
    chunk, so the arrays other readers make are used as they come (no second copy)."""
    return bool(rec.views)


def _total(source: Any, rec: Optional[RecordingProtocol], plan: Plan) -> Optional[int]:
    if rec is not None:
        return (plan.stop if plan.stop is not None else rec.n_samples) - plan.start
    if isinstance(source, Mapping):
        return len(next(iter(source.values()))) if source else 0
    return None


def _run_stream(chunks: Iterable[Any], ks: KernelSpec, total: Optional[int], taps: Sequence[Tap] = ()
                ) -> Tuple[Stats, Optional[str]]:  # fmt: skip
    plan = ks.plan
    bar = _progress(plan.progress, total)
    # A range of one chunk (a watched recording's update) runs on the calling thread: a worker thread to read
    # ahead of would only cost its start (the kernel still uses plan.threads; the same table either way)
    one = total is not None and total <= (plan.chunk_samples or DEFAULT_CHUNK)
    try:
        parts, aux_role = _run_chunks(chunks, plan.start, ks, bar, threads=plan.threads, taps=taps, pipelined=not one)
    finally:
        if bar is not None:
            bar.close()
    return concat_stats(parts), aux_role


def _run_chunks(chunks: Iterable[Any], origin: int, ks: KernelSpec, bar: Any, *, threads: int, depth: int = 2,
                taps: Sequence[Tap] = (), base: int = 0, pipelined: bool = True
                ) -> Tuple[List[Stats], Optional[str]]:  # fmt: skip
    """Checks, filters and windows a stream of chunks; the batches of window statistics, in order.

    The calling thread alone reads the chunks (so a reader that is not
    thread-safe is never read from two threads). With ``threads`` >= 2 one
    worker thread filters, windows and runs the kernel (which releases the
    GIL and uses ``threads`` kernel threads), chunk after chunk in order,
    at most ``depth`` chunks behind the reading: the filter state and the
    windower's tail are only ever touched by that worker. With one thread
    everything runs on the calling thread. ``taps`` take the raw chunks
    (the classical COF's sums, stick-slip; ``base``: the recording's index
    of ``origin``). ``pipelined=False``: the calling thread does it all
    (the kernel still runs on ``threads``).
    """
    stage = _Stage(origin, ks, threads, taps=taps, base=base)
    if threads < 2 or not pipelined:
        for i, raw_chunk in enumerate(chunks):
            stage.push(_check_chunk(raw_chunk, f"chunk {i}"))
            if bar is not None:
                bar.update(len(raw_chunk["fz"]))
        return stage.finish()
    pending: "Deque[Future[Any]]" = deque()
    with thread_pool(1, "tribodyn") as ex:
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

    def __init__(self, origin: int, ks: KernelSpec, threads: int, *, taps: Sequence[Tap] = (),
                 base: int = 0) -> None:  # fmt: skip
        self.origin, self.ks, self.plan, self.threads = origin, ks, ks.plan, threads
        self.taps, self.base = tuple(taps), base
        self.parts: List[Stats] = []
        self.aux_role: Optional[str] = None
        self.windower: Optional[Windower] = None
        self.hp: Optional[HighPass] = None
        self.force_roles: List[str] = []
        self.seen = origin  # the recording's index of the next chunk's first sample

    def _windows(self, ch: Dict[str, np.ndarray], rel: np.ndarray, absolute: np.ndarray) -> None:
        self.parts.append(_kernel(ch, rel, absolute, self.ks, aux_role=self.aux_role, threads=self.threads))

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
        for tap in self.taps:  # the classical COF's sums, stick-slip: from the raw samples (docs/method.md 6e, 6g)
            tap.push(self.base + first, ch)
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


def _acquisitions(source: Sequence[Any], ks: KernelSpec) -> Tuple[Stats, Optional[str]]:
    """Each acquisition of a list one window of its own length (docs/method.md 6)."""
    plan = ks.plan
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
        zero = np.zeros(1, dtype=np.int64)
        st = _kernel(ch, zero, zero, ks, aux_role=aux_role, threads=plan.threads, length=n)
        t0 = acq.get("t0") if isinstance(acq, Mapping) else None
        st["t0"] = np.array([float(t0) if t0 is not None else t])
        st["acquisition"] = np.array([acq.get("stroke", k) if isinstance(acq, Mapping) else k], dtype=np.int64)
        if isinstance(acq, Mapping) and "reversal" in acq:  # a stroke's window (docs/method.md 6c)
            st["stroke_reversal"] = np.array([bool(acq["reversal"])])
        t += n / plan.fs
        parts.append(st)
    if not parts:
        raise ValueError("the list of acquisitions is empty")
    return concat_stats(parts), aux_role
