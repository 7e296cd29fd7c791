"""Many recordings, and very long ones, on a Dask cluster: ``analyze_many``.

Scaling out rests on two properties of :func:`tribodyn.analyze`: a window's
result depends only on its own samples, and ranges of a recording analysed
separately give exactly the windows of one pass when they are cut on the
window grid (``analyze(start=...)``). So the work is split into pure tasks,
one per recording or per range of a long recording, that take a *path*
(workers read the files themselves; no arrays cross the network) and return
the kernel's per-window statistics, not yet finished. Each recording's
ranges are then joined and finished once (``tribodyn.pipeline.analyze.combine``)
by a task of its own on a worker (:func:`finish_task`, so recordings finish in
parallel and only their Results travel to the client):
its orientation (docs/method.md 0) and the noise on fz of the corrected
estimator (docs/method.md 3c) come from all its windows, exactly as one
serial pass would.

Tasks are pure (same input, same output, no side effects), so a task lost
with a worker is simply recomputed: nothing is lost or counted twice. A
recording that fails (corrupt file, missing channel) is reported with its
error and does not stop the others.

Dask is optional (``pip install "tribodyn[dask]"``); with ``client=None`` the
same tasks run serially in this process.
"""

from __future__ import annotations

import contextlib
import dataclasses
import glob
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, Union, cast

import numpy as np

from ..results import Results
from .analyze import Partial, analyze_partial, combine
from .plan import Plan, check_options, make_plan

__all__ = ["analyze_many", "ManyResults", "RecordingFailure", "close_quietly", "expand_paths", "local_client"]

DASK_HINT = 'this needs Dask: pip install "tribodyn[dask]"'


@dataclass(frozen=True)
class RecordingFailure:
    """A recording that could not be analysed: its error, as text."""

    path: str
    error: str
    kind: str

    @classmethod
    def of(cls, path: str, exc: BaseException) -> "RecordingFailure":
        """The failure of ``path`` that ``exc`` says: ``error`` "TypeName: message", ``kind`` "TypeName"."""
        return cls(path=path, error=f"{type(exc).__name__}: {exc}", kind=type(exc).__name__)


@dataclass(frozen=True)
class ManyResults:
    """Results of :func:`analyze_many`.

    Attributes
    ----------
    results : dict of str -> Results
        Per recording (keyed by the path as given), in input order.
    failures : dict of str -> RecordingFailure
        Recordings that failed, with their error.
    tasks : int
        Tasks run (recordings x ranges).
    skipped : list of str
        Files of the folders given that no reader takes (``README.md``; :func:`expand_paths`), not analysed.
    """

    results: Dict[str, Results]
    failures: Dict[str, RecordingFailure] = field(default_factory=dict)
    tasks: int = 0
    skipped: List[str] = field(default_factory=list)

    @property
    def table(self) -> Dict[str, np.ndarray]:
        """All windows of all recordings in one table, with a ``recording`` column first."""
        if not self.results:
            return {"recording": np.zeros(0, dtype=str)}
        names = list(self.results)
        first = self.results[names[0]]
        out: Dict[str, np.ndarray] = {"recording": np.concatenate([np.full(len(self.results[n]), n) for n in names])}
        for col in first.table:
            out[col] = np.concatenate([self.results[n].table[col] for n in names])
        return out

    @property
    def headlines(self) -> Dict[str, np.ndarray]:
        """One row per recording: its headline (:class:`tribodyn.Headline`, docs/method.md 6e), in input order.

        Columns ``recording``, ``method``, ``value``, ``low``, ``high``,
        ``statistic``, ``n`` and ``fraction_used``; a failed recording is
        not a row (see :attr:`failures`).
        """
        heads = [(name, r.headline) for name, r in self.results.items()]
        cols: Dict[str, np.ndarray] = {"recording": np.asarray([n for n, _ in heads], dtype=str)}
        for key in ("method", "statistic"):
            cols[key] = np.asarray([getattr(h, key) for _, h in heads], dtype=str)
        for key in ("value", "low", "high", "fraction_used"):
            cols[key] = np.asarray([getattr(h, key) for _, h in heads], dtype=float)
        cols["n"] = np.asarray([h.n for _, h in heads], dtype=np.int64)
        return cols

    def to_pandas(self) -> Any:
        """The combined table as a ``pandas.DataFrame``."""
        import pandas as pd

        return pd.DataFrame(self.table)

    def summary(self) -> Dict[str, Any]:
        """Per-recording summaries and the failures."""
        return {
            "recordings": {name: r.summary() for name, r in self.results.items()},
            "failures": {name: {"error": f.error, "kind": f.kind} for name, f in self.failures.items()},
            "tasks": self.tasks,
            "skipped": list(self.skipped),
        }


def expand_paths(
    inputs: Union[str, os.PathLike[str], Sequence[Union[str, os.PathLike[str]]]], skipped: Optional[List[str]] = None
) -> List[str]:
    """Files from paths, directories (their files, sorted) and glob patterns, in order, without repeats.

    A directory's files that no reader takes (:func:`tribodyn.io.reader_takes`: ``README.md``, a photo) are
    skipped and appended to ``skipped`` when given; a file named as such, or matched by a pattern, is kept (its
    reader says what is wrong with it).
    """
    from ..io import reader_takes

    items = [inputs] if isinstance(inputs, (str, os.PathLike)) else list(inputs)
    out: Dict[str, None] = {}  # (dicts: in order, without repeats, each looked up at once)
    dropped: Dict[str, None] = {}
    for item in items:
        s = str(item)
        p = Path(s)
        if p.is_dir():
            inside = sorted(str(q) for q in p.iterdir() if q.is_file() and not q.name.startswith("."))
            taken = {q: reader_takes(q) for q in inside}
            found = [q for q in inside if taken[q]]
            dropped.update((q, None) for q in inside if not taken[q])
        elif any(c in s for c in "*?["):
            found = sorted(q for q in glob.glob(s) if Path(q).is_file())
            if not found:
                raise FileNotFoundError(f"no file matches {s!r}")
        else:
            found = [s]
        out.update((q, None) for q in found)
    if skipped is not None:
        skipped.extend(dropped)
    if not out:
        where = ", ".join(str(i) for i in items) or "(nothing given)"
        none = f"; {skipped_text(list(dropped))}" if dropped else ""
        raise FileNotFoundError(
            f"no input files in {where} (a folder's own files are read, not its sub-folders'){none}"
        )
    return list(out)


def skipped_text(skipped: Sequence[str]) -> str:
    """'skipped 1 file no reader takes: README.md' (:func:`expand_paths`'s ``skipped``, by their names)."""
    n = len(skipped)
    return f"skipped {n} file{'s' if n != 1 else ''} no reader takes: {', '.join(skipped_names(skipped))}"


def skipped_names(skipped: Sequence[str]) -> List[str]:
    """The names the stderr line and the report give :func:`expand_paths`'s ``skipped``: their file names, or their
    paths where two share one (README.md of two folders)."""
    names = [Path(q).name for q in skipped]
    return names if len(set(names)) == len(names) else [str(q) for q in skipped]


# -- tasks (module-level and pure, so Dask can ship and retry them) -----------


def plan_task(path: str, open_options: Dict[str, Any]) -> Union[Tuple[int, float, int], RecordingFailure]:
    """(n_samples, fs, acquisitions) of a recording, read from its header, or its failure.

    ``acquisitions``: how many separate acquisitions the recording holds (a multi-step export's steps,
    ``Recording.acquisitions``); each is windowed from its own first sample, so such a recording is not split.
    """
    from ..io import open_recording

    try:
        with open_recording(path, **open_options) as rec:
            acq = getattr(rec, "acquisitions", None)
            return int(rec.n_samples), float(rec.fs), max(1, len(acq or ()))
    except Exception as exc:  # a task reports, never raises: one bad file must not stop the rest
        return RecordingFailure.of(path, exc)


def range_task(
    path: str,
    open_options: Dict[str, Any],
    options: Union[Dict[str, Any], Plan],
    span: Tuple[int, Optional[int]],
    host_slots: Optional[Mapping[str, int]] = None,
) -> Union[Partial, RecordingFailure]:
    """The kernel's statistics of the windows of samples ``start:stop`` (``span``) of one recording, not yet
    finished.

    The ranges of a recording are finished together by :func:`finish_task`
    (recording-wide orientation and noise on fz, docs/method.md 3c).
    ``options`` are analyze's options, or a :class:`~tribodyn.Plan` (this
    range's copy of it: its ``start`` and ``stop`` are the range's).
    ``host_slots``: the cluster's task slots per host (:func:`_host_slots`);
    on a Dask worker, options that name no ``threads``, or a plan made
    without them (``Plan.threads_asked``), and no ``TRIBODYN_THREADS`` there,
    get this worker's share of its host's cores (:func:`_worker_threads`,
    docs/method.md 9).
    """
    from ..io import open_recording

    start, stop = span
    try:
        with open_recording(path, **open_options) as rec:
            if isinstance(options, Plan):
                plan = dataclasses.replace(options, start=start, stop=stop)
                share = _worker_threads(host_slots) if host_slots and not options.threads_asked else None
                return analyze_partial(rec, plan if share is None else dataclasses.replace(plan, threads=share))
            fs = options.get("fs") or rec.fs
            opts = {k: v for k, v in options.items() if k != "fs"}
            if opts.get("threads") is None and host_slots:
                opts["threads"] = _worker_threads(host_slots)
            # The recording itself, so that analyze reads the range the
            # fastest way its format allows (a float64 .npy: straight from
            # the file's pages).
            return analyze_partial(rec, fs=fs, start=start, stop=stop, **opts)
    except Exception as exc:  # reported per recording, see plan_task
        return RecordingFailure.of(path, exc)


def _host_slots(client: Any) -> Optional[Dict[str, int]]:
    """The task slots (worker threads) of ``client``'s cluster per host, from the scheduler (one request);
    None for a client that cannot say (not a ``dask.distributed.Client``)."""
    try:
        from distributed.comm.addressing import get_address_host
    except ImportError:
        return None
    ask = getattr(client, "nthreads", None)
    if not callable(ask):
        return None
    slots: Dict[str, int] = {}
    for address, n in ask().items():
        host = get_address_host(address)
        slots[host] = slots.get(host, 0) + int(n)
    return slots


def _worker_threads(host_slots: Mapping[str, int]) -> Optional[int]:
    """Kernel threads of one task on this Dask worker: the cores :func:`~tribodyn.get_threads` counts, shared
    among the tasks its host runs at once (``host_slots``), at least 1; None (the call's default) off a worker,
    on a host not in ``host_slots`` (a worker that joined later), or with ``TRIBODYN_THREADS`` set here.

    Each of W workers on a host of C cores would otherwise run its kernels on C threads: W x C threads on C
    cores (issue 38 point 4). The count never changes a result (docs/method.md 9).
    """
    if os.environ.get("TRIBODYN_THREADS", "").strip():
        return None
    try:
        from distributed import get_worker
        from distributed.comm.addressing import get_address_host

        worker = get_worker()
    except (ImportError, ValueError):  # (get_worker raises ValueError outside a task)
        return None
    slots = host_slots.get(get_address_host(worker.address))
    if not slots:
        return None
    from ..kernels.threads import get_threads

    return max(1, get_threads() // slots)


def _ranges(n: int, fs: float, options: Union[Dict[str, Any], Plan], split_s: Optional[float],
            acquisitions: int = 1) -> List[Tuple[int, Optional[int]]]:  # fmt: skip
    """Sample ranges on the window grid, each holding whole windows: none lost, none twice.

    The grid is the analysis's: the plan's, or window and hop as ``analyze``
    chooses them from the options and the rate (docs/method.md 6b). Not cut
    (one range): a recording of several ``acquisitions`` (each windowed from
    its own first sample) or of raw forces (``highpass``).
    """
    raw = options.raw if isinstance(options, Plan) else options.get("highpass") is not None
    if split_s is None or raw or acquisitions > 1:
        # Raw forces are high-passed by an IIR filter whose state carries over every sample from the first: a
        # range would start its filter afresh (its first windows other than one pass's); separate acquisitions
        # are windowed each from its own start, not on one grid.
        return [(0, None)]
    if isinstance(options, Plan):
        grid = options
    else:
        try:
            grid = make_plan(fs=fs, window=options.get("window"), hop=options.get("hop"))
        except (TypeError, ValueError):
            return [(0, None)]  # a bad window or hop: the task reports it, per recording
    length, step, hop = grid.length, grid.step, grid.hop
    n_windows = 0 if n < length else (n - length) // step + 1
    per = max(1, int(split_s // hop))  # windows per range
    out: List[Tuple[int, Optional[int]]] = []
    for k0 in range(0, n_windows, per):
        k1 = min(k0 + per, n_windows)
        out.append((k0 * step, (k1 - 1) * step + length))
    # One range is the whole recording, read as without split (its params' stop None, as one pass's).
    return out if len(out) > 1 else [(0, None)]


def finish_task(path: str, parts: Sequence[Union[Partial, RecordingFailure]]) -> Union[Results, RecordingFailure]:
    """One recording's ranges joined in order and finished once (docs/method.md 0, 3c): the one-pass table.

    A task of its own, run where the ranges were (a worker), so recordings are
    finished in parallel and only their Results travel back to the client.
    Each part's plan carries the orientation asked for; "auto" is fixed here,
    from all the windows. The first range's failure, or the finish's, is the
    recording's failure.
    """
    bad = next((p for p in parts if isinstance(p, RecordingFailure)), None)
    if bad is not None:
        return bad
    try:
        return combine([cast(Partial, p) for p in parts])
    except Exception as exc:  # reported per recording, see plan_task
        return RecordingFailure.of(path, exc)


#: Tasks per recording: its name (path) and the arguments of each of its tasks.
Group = Tuple[str, List[Tuple[Any, ...]]]
#: ``run(fn, groups, then)``: ``fn(*args)`` for each task of each group, then per group ``then(name, outputs)``
#: (where the tasks ran: a worker) or, with ``then`` None, the group's one output; a list, one per group, in order.
Runner = Callable[[Callable[..., Any], List[Group], Optional[Callable[..., Any]]], List[Any]]


def _then(fn: Callable[..., Any], then: Callable[..., Any], name: str, args: Tuple[Any, ...]) -> Any:
    """A group of one task as one task: ``then(name, [fn(*args)])``."""
    return then(name, [fn(*args)])


def _runner(client: Any, progress: bool) -> Runner:
    """Runs groups of tasks serially here (``client`` None) or on a Dask cluster (each group's ``then`` a task
    of its own that takes the group's futures: recordings finished on the workers in parallel)."""
    if client is not None and not (callable(getattr(client, "submit", None)) and hasattr(client, "gather")):
        raise TypeError(
            f"client must be a dask.distributed.Client (or None to run serially), got {type(client).__name__}; "
            "tribodyn.pipeline.distributed.local_client() starts a local cluster"
        )
    if client is None:

        def serial(fn: Callable[..., Any], groups: List[Group], then: Optional[Callable[..., Any]]) -> List[Any]:
            bar = None
            if progress:
                from ._progress import progress_bar

                bar = progress_bar(sum(len(a) for _, a in groups), unit="task", desc=fn.__name__.replace("_task", ""))
            out = []
            for name, args in groups:
                got = []
                for a in args:
                    got.append(fn(*a))
                    if bar is not None:
                        bar.update(1)
                out.append(then(name, got) if then is not None else got[0])
            if bar is not None:
                bar.close()
            return out

        return serial

    def run(fn: Callable[..., Any], groups: List[Group], then: Optional[Callable[..., Any]]) -> List[Any]:
        # The tasks are pure functions of their arguments, so a task lost with
        # its worker is simply recomputed (retries). Keys are unique per call
        # (pure=False) so each call computes afresh rather than reusing a
        # result the cluster still holds from an earlier call. The tasks of a
        # stage go to the scheduler in one ``client.map`` each (one message and
        # one graph update, not one per task: issue 38 point 4).
        ones = [k for k, (_, args) in enumerate(groups) if then is None or len(args) == 1]
        many = [k for k, (_, args) in enumerate(groups) if then is not None and len(args) > 1]
        ends: List[Any] = [None] * len(groups)
        shown: List[Any] = []
        if ones:  # one task each: its end fused in (each task costs the client ~5-10 ms)
            names, first = [groups[k][0] for k in ones], [groups[k][1][0] for k in ones]
            if then is None:
                got = client.map(fn, *zip(*first), key=fn.__name__, pure=False, retries=3)
            else:
                n = len(ones)
                got = client.map(_then, [fn] * n, [then] * n, names, first, key="_then", pure=False, retries=3)
            for k, f in zip(ones, got):
                ends[k] = f
            shown += got
        if many and then is not None:  # the group's futures as an argument: Dask hands the task their values there
            parts = iter(client.map(fn, *zip(*[a for k in many for a in groups[k][1]]), key=fn.__name__, pure=False,
                                    retries=3))  # fmt: skip
            lists = [[next(parts) for _ in groups[k][1]] for k in many]
            got = client.map(then, [groups[k][0] for k in many], lists, key=then.__name__, pure=False, retries=3)
            for k, f in zip(many, got):
                ends[k] = f
            shown += [f for futures in lists for f in futures] + got
        if progress:
            from dask.distributed import progress as show

            cast(Any, show)(shown)
        out: List[Any] = client.gather(ends)
        return out

    return run


def analyze_many(
    paths: Union[str, os.PathLike[str], Sequence[Union[str, os.PathLike[str]]]],
    plan: Optional[Plan] = None,
    *,
    client: Any = None,
    open_options: Optional[Dict[str, Any]] = None,
    split: Optional[float] = None,
    chunk: Optional[float] = None,
    progress: bool = False,
    **analyze_options: Any,
) -> ManyResults:
    """Analyses many recordings, and long ones in ranges, serially or on Dask.

    Parameters
    ----------
    paths : path, directory, glob pattern, or a sequence of them
        Recording files (see :func:`tribodyn.open_recording`); a directory's files that no reader takes
        (``README.md``) are skipped (``ManyResults.skipped``).
    plan : Plan, optional
        The analysis's settings checked once (:func:`tribodyn.make_plan`),
        for recordings sampled at ``plan.fs``; no other analysis option with it.
    client : dask.distributed.Client, optional
        Run the tasks on this cluster (workers must reach the files at the
        same paths; a relative path is taken from this process's working
        folder). None: run them here, one after the other. Without a
        ``threads`` option (and without ``TRIBODYN_THREADS`` on the
        workers), a task's kernels run on its share of its host's cores:
        the cores over the cluster's task slots on that host, at least 1
        (docs/method.md 9); a ``plan`` keeps its own ``threads``.
    open_options : dict, optional
        Passed to ``open_recording`` (channels, scale, fs, format, ...).
    split : float, optional
        Cut each recording into ranges of about this many seconds (aligned
        to the window grid), one task each, so a very long recording uses
        several workers. None: one task per recording. A recording of
        separate acquisitions (a multi-step export's steps, each windowed
        from its own first sample) is one task, and so is every recording
        of raw forces (``highpass``: the filter runs from the first sample).
    chunk : float, optional
        Seconds read per chunk inside a task (``analyze``'s ``chunk``;
        default: its own). Never changes a result.
    progress : bool
        Show the tasks' progress (Dask's progress bar on a cluster).
    **analyze_options
        Options of :func:`tribodyn.analyze` (window, hop, highpass,
        orientation, temperature, area_mm2, ...). A temperature log applies
        to every recording. Each recording is analysed whole: ``start`` and
        ``stop`` (one recording's range) are refused. An option that is bad
        whatever the recording (``window=-1``) raises before any file is read
        (:func:`tribodyn.pipeline.plan.check_options`).

    Returns
    -------
    ManyResults
        Per-recording results identical to ``analyze`` run on each file
        serially, and the failures with their errors.
    """
    skipped: List[str] = []
    files = expand_paths(paths, skipped)
    open_options = dict(open_options or {})
    options = dict(analyze_options)
    channels = options.pop("channels", None)
    if channels is not None:  # as analyze(path, channels=...): how each file is read (it failed every recording)
        if open_options.get("channels", channels) != channels:
            raise TypeError("channels= and open_options['channels'] differ: give the map once")
        open_options["channels"] = channels
    if options.get("fs") is not None:  # as analyze(path, fs=...): a file that carries no rate is read at it too
        if open_options.get("fs", options["fs"]) != options["fs"]:
            raise TypeError("fs= and open_options['fs'] differ: give the rate once")
        open_options["fs"] = options["fs"]
    start, stop = options.pop("start", None), options.pop("stop", None)
    if start not in (None, 0) or stop is not None:  # (start was dropped unsaid; stop failed every recording)
        raise ValueError(
            f"analyze_many analyses each recording whole, not start={start!r}, stop={stop!r} (analyze's range of "
            "one recording): give split= to cut long recordings into ranges, or call analyze per file"
        )
    if plan is not None:
        if not isinstance(plan, Plan):
            raise TypeError(f"plan must be a tribodyn.Plan (tribodyn.make_plan(...)), got {type(plan).__name__}")
        if options:
            raise TypeError(f"analyze_many(..., plan=...) takes no other analysis options: {sorted(options)}")
        if plan.align is not None:
            raise ValueError("analyze_many does not align (align='auto' reads a recording twice): use analyze per file")
        if chunk is not None:
            plan = dataclasses.replace(plan, chunk=max(1, int(round(chunk * plan.fs))))
    if options.get("align") is not None:
        raise ValueError("analyze_many does not align (align='auto' reads a recording twice): use analyze per file")
    if options.get("stick_slip") or (plan is not None and plan.stick_slip):
        raise ValueError("analyze_many analyses ranges apart, not stick-slip (stick_slip=True): call "
                         "tribodyn.stick_slip(path, res) for each recording, or analyze per file")  # fmt: skip
    if split is not None and not (split > 0 and math.isfinite(split)):
        raise ValueError(f"split must be a finite number > 0 seconds, got {split!r}")
    check_options(**options)  # once, before any file is read (a bad window failed every recording alike)
    run = _runner(client, progress)
    asked = plan.threads_asked if plan is not None else options.get("threads") is not None
    slots = _host_slots(client) if client is not None and not asked else None

    # What the tasks open: on a cluster the path from this process's working folder (a worker has its own; a
    # relative path failed there as "no such file"); its failures then name the path as given.
    where = {f: os.path.abspath(f) if client is not None else f for f in files}

    def as_given(f: str, failed: RecordingFailure) -> RecordingFailure:
        return dataclasses.replace(failed, path=f, error=failed.error.replace(where[f], f))

    if split is None:
        plans: List[Any] = [None] * len(files)  # the files' (n_samples, fs), read only to split them
    else:
        plans = run(plan_task, [(f, [(where[f], open_options)]) for f in files], None)
    groups: List[Group] = []
    failures: Dict[str, RecordingFailure] = {}
    for f, head in zip(files, plans):
        if isinstance(head, RecordingFailure):
            failures[f] = as_given(f, head)
            continue
        if head is None:
            ranges: List[Tuple[int, Optional[int]]] = [(0, None)]
        else:
            n, fs, acquisitions = head
            fs = options.get("fs") or fs
            ranges = _ranges(n, fs, plan if plan is not None else options, split, acquisitions)
        opts: Union[Dict[str, Any], Plan]
        if plan is not None:
            opts = plan
        else:
            opts = dict(options, chunk=chunk) if chunk is not None else dict(options)
        groups.append((f, [(where[f], open_options, opts, span, slots) for span in ranges]))
    outputs = run(range_task, groups, finish_task)

    results: Dict[str, Results] = {}
    for (f, _), out in zip(groups, outputs):
        if isinstance(out, RecordingFailure):
            failures[f] = as_given(f, out)
        else:
            results[f] = out
    ordered_failures = {f: failures[f] for f in files if f in failures}
    return ManyResults(results=results, failures=ordered_failures, tasks=sum(len(a) for _, a in groups),
                       skipped=skipped)  # fmt: skip


#: The allocator's settings of :func:`local_client`'s worker processes, in place of Dask's
#: ``MALLOC_TRIM_THRESHOLD_=65536`` (``distributed.nanny.pre-spawn-environ``: freed memory handed back to the system at
#: once). With Dask's, glibc maps every block over 128 KiB afresh and unmaps it when freed: a task's read and kernel
#: arrays fault their pages in each time (~3000 faults for a 20 min recording of 4 channels), and each unmap
#: interrupts the cores of the process' other threads; ~8 ms of a ~55 ms task on 2 vCPUs (issue 38 point 4,
#: benches/RESULTS.md). These are the values glibc's own adaptive rule ends at in a process that frees such blocks
#: (what a serial run gets): blocks up to 32 MiB are kept in the heap for the next task, up to 64 MiB of free heap is
#: kept before it is handed back. A worker then holds about its tasks' peak memory between them.
WORKER_ENVIRON = {"MALLOC_MMAP_THRESHOLD_": 33554432, "MALLOC_TRIM_THRESHOLD_": 67108864}


def local_client(workers: int = 2, threads_per_worker: int = 1) -> Any:
    """A ``dask.distributed.Client`` on a LocalCluster of worker processes.

    A Ctrl-C reaches this process alone (:func:`_interrupts_held`): its workers are stopped when the client and
    the cluster are closed, without each printing its own traceback. The cluster's processes print their logs
    from level ERROR (a task cancelled by a Ctrl-C logs a WARNING in its worker). Its workers start with the
    allocator's settings :data:`WORKER_ENVIRON` (where this process' environment does not set them; Dask's
    nannies set them in this process' environment too, which is put back).
    """
    import logging

    try:
        import dask
        from dask.distributed import Client, LocalCluster
    except ImportError as exc:
        raise ImportError(DASK_HINT) from exc
    environ = {f"distributed.nanny.pre-spawn-environ.{name}": value for name, value in WORKER_ENVIRON.items()}
    here = {name: os.environ.get(name) for name in WORKER_ENVIRON}
    try:  # (the cluster's loop thread, and the worker processes it starts, never see Ctrl-C)
        with _interrupts_held(), dask.config.set(environ):
            cluster = cast(Any, LocalCluster)(
                n_workers=workers, threads_per_worker=threads_per_worker, processes=True, dashboard_address=":0",
                silence_logs=logging.ERROR,
            )  # fmt: skip
    finally:  # Dask's nannies set their workers' variables in this process' environment too: put back
        for name, value in here.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
    return cast(Any, Client)(cluster)


#: The loggers of Dask's shutdown: raised above CRITICAL while a client and its cluster close (:func:`close_quietly`).
_SHUTDOWN_LOGGERS = ("distributed", "tornado", "asyncio")


def close_quietly(client: Any, cluster: Any = None, *, workers: bool = True) -> None:
    """Closes ``client``, then ``cluster`` (None: not closed; a cluster at an address is not this process'), without
    Dask's shutdown logs.

    The work is done, but a worker whose heartbeat is in flight when its connections close logs "Failed to
    communicate with scheduler during heartbeat." and a ``CommClosedError`` traceback at ERROR (about 3 runs in
    30 of ``--scheduler local`` on a busy machine); the scheduler and nannies of a LocalCluster run here and may
    log a closed comm likewise. So the workers of ``cluster`` raise their loggers (:data:`_SHUTDOWN_LOGGERS`)
    above CRITICAL first (one ``client.run``, at most 5 s; a worker that does not answer is closed as it is; not
    with ``workers`` False: an interrupted run closes at once), and this process' loggers are raised while both
    close, then put back.
    """
    import logging

    if cluster is not None and workers:
        with contextlib.suppress(Exception):
            client.run(silence_dask_logs, on_error="ignore", callback_timeout=5.0)
    loggers = [logging.getLogger(name) for name in _SHUTDOWN_LOGGERS]
    levels = [log.level for log in loggers]
    for log in loggers:
        log.setLevel(logging.CRITICAL + 1)
    try:
        client.close()
        if cluster is not None:
            cluster.close()
    finally:
        for log, level in zip(loggers, levels):
            log.setLevel(level)


def silence_dask_logs() -> None:
    """Dask's, Tornado's and asyncio's loggers above CRITICAL in this process: on a worker (``client.run``) for its
    shutdown (:func:`close_quietly`), and in the command line for the rest of an interrupted run."""
    import logging

    for name in _SHUTDOWN_LOGGERS:
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


@contextlib.contextmanager
def _interrupts_held() -> Iterator[None]:
    """Within the block SIGINT is blocked in this thread (POSIX, main thread only), so that the threads it starts
    (a LocalCluster's event loop) and the processes they spawn (its workers) inherit the blocked signal: a Ctrl-C
    reaches this process alone, which stops the cluster (each worker printed its own KeyboardInterrupt
    traceback before). A Ctrl-C during the block is delivered here when it ends, not lost."""
    import signal
    import threading

    hold = getattr(signal, "pthread_sigmask", None)
    if hold is None or threading.current_thread() is not threading.main_thread():
        yield
        return
    from multiprocessing import resource_tracker

    # Started now, outside the block: starting it later would unblock SIGINT in this thread (multiprocessing
    # blocks and then unblocks SIGINT and SIGTERM around the tracker's start, whatever the mask was before).
    resource_tracker.ensure_running()
    before = hold(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        hold(signal.SIG_SETMASK, before)


#: Seconds a client waits for the scheduler at an address (:func:`connect`, ``tribodyn analyze --scheduler
#: tcp://host:port``) before the OSError "Timed out trying to connect"; Dask's own default
#: (``distributed.comm.timeouts.connect``) is 30 s, long to wait for a mistyped or stopped scheduler, where a
#: reachable one answers in milliseconds (a busy one in a few seconds).
CONNECT_TIMEOUT = 10.0


def connect(address: str, workers: int = 2) -> Any:
    """A client for ``address`` ("local" starts a LocalCluster of ``workers`` processes); an address where no Dask
    scheduler answers within :data:`CONNECT_TIMEOUT` seconds raises OSError (:func:`_hello`)."""
    if address == "local":
        return local_client(workers)
    try:
        from dask.distributed import Client
    except ImportError as exc:
        raise ImportError(DASK_HINT) from exc
    _hello(address)
    return cast(Any, Client)(address, timeout=CONNECT_TIMEOUT)


def _hello(address: str) -> None:
    """Dask's handshake with ``address`` and back, within :data:`CONNECT_TIMEOUT` seconds, or OSError.

    A client's timeout bounds its connection, not the handshake after it: a server of another protocol at the
    address (the scheduler's web dashboard, port 8787, for its port 8786) held ``tribodyn analyze --scheduler``
    forever, or, when it answered, made Dask read its reply as the length of a message (a MemoryError of
    exabytes). So the handshake is made once here, bounded as a whole, before the client's own.
    """
    import asyncio
    import importlib

    comm_connect: Any = importlib.import_module("distributed.comm.core").connect  # (untyped)
    # the client's connection arguments (TLS from Dask's configuration, as a Client without ``security`` reads it)
    args = importlib.import_module("distributed.security").Security().get_connection_args("client")

    async def hello() -> None:
        comm = await comm_connect(address, timeout=CONNECT_TIMEOUT, **args)
        await comm.close()

    try:
        asyncio.run(asyncio.wait_for(hello(), CONNECT_TIMEOUT + 1.0))  # (the connection's own timeout first)
    except asyncio.TimeoutError:
        raise OSError(
            f"no Dask scheduler answered within {CONNECT_TIMEOUT + 1.0:g} s (something at the address took the "
            "connection and said nothing: a web server, such as the scheduler's dashboard?)"
        ) from None
    except (OSError, ValueError, TypeError):  # (unreachable; a bad address: as the client says them)
        raise
    except Exception as exc:  # (another protocol's reply read as Dask's: a MemoryError, an unpacking error)
        raise OSError(f"the server there does not answer as a Dask scheduler ({type(exc).__name__})") from None
