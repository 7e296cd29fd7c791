"""How many threads the Rust kernels use (docs/method.md 9).

A thread count belongs to one call: ``analyze(threads=...)`` (and every
kernel wrapper that takes ``threads=``) passes its count down to the Rust
kernels, which run on a pool of exactly that many threads for that call
only, so concurrent calls never change each other's count. A call that
names none uses the ``TRIBODYN_THREADS`` environment variable, else the
process default that :func:`set_threads` sets (every core at first).
Counts run from 1 to :func:`max_threads` (4 x the CPU count).

Kernels split work at fixed boundaries and combine it in a fixed order, so
results never depend on the thread count.
"""

from __future__ import annotations

import contextlib
import contextvars
import numbers
import os
import threading
from concurrent.futures import Executor, Future
from typing import TYPE_CHECKING, Any, Callable, Iterator, Optional, Tuple, Type, TypeVar

from .. import _core

if TYPE_CHECKING:  # imported on first use (_pool_class)
    from concurrent.futures import ThreadPoolExecutor

__all__ = ["set_threads", "get_threads", "max_threads", "resolve_threads", "read_threads", "thread_pool", "side_job"]

_T = TypeVar("_T")

#: The thread count of the analysis running in this context (its readers' native parses use it).
_READ: contextvars.ContextVar[Optional[int]] = contextvars.ContextVar("tribodyn_read_threads", default=None)


def max_threads() -> int:
    """The largest thread count a call may ask for: 4 x the CPU count."""
    return int(_core.max_threads())


def set_threads(n: int) -> None:
    """Sets the thread count of calls that name none, for this process (0 = all cores).

    Raises ``TypeError`` for a non-integer and ``ValueError`` for n < 0 or
    n > :func:`max_threads`.
    """
    _core.set_threads(_count(n, "n", minimum=0))


def get_threads() -> int:
    """The thread count of calls that name none (``set_threads``; every core by default)."""
    return int(_core.get_threads())


def resolve_threads(threads: Optional[Any] = None) -> int:
    """The thread count of one call: ``threads``, else ``TRIBODYN_THREADS``, else :func:`get_threads`.

    Raises ``TypeError`` for a non-integer and ``ValueError`` outside
    1 .. :func:`max_threads` (naming where the count came from).
    """
    if threads is not None:
        return _count(threads, "threads", minimum=1)
    env = os.environ.get("TRIBODYN_THREADS", "").strip()
    if env:
        try:
            v = int(env)
        except ValueError:
            raise ValueError(f"TRIBODYN_THREADS must be a whole number, got {env!r}") from None
        return _count(v, "TRIBODYN_THREADS", minimum=1)
    return get_threads()


def _count(value: Any, name: str, *, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    v, top = int(value), max_threads()
    if not minimum <= v <= top:
        raise ValueError(f"{name} must be in [{minimum}, {top}] (4 x the {os.cpu_count()} CPUs), got {v}")
    return v


@contextlib.contextmanager
def reading(n: Optional[int]) -> Iterator[None]:
    """Within the block, :func:`read_threads` is ``n`` (None: the default) in this context."""
    token = _READ.set(n)
    try:
        yield
    finally:
        _READ.reset(token)


def read_threads() -> int:
    """Threads a reader's native parse uses: the running analysis's count, else :func:`resolve_threads`."""
    n = _READ.get()
    return n if n is not None else resolve_threads()


#: Side jobs running at once at most (concurrent analyses of one process each have one: find_lag).
SIDE_THREADS = 4
#: (process id, executor) of the side jobs' threads, kept for the process's later calls.
_SIDE: Optional[Tuple[int, Executor]] = None
_SIDE_LOCK = threading.Lock()


def side_job(fn: Callable[..., _T], *args: Any, **kwargs: Any) -> "Future[_T]":
    """``fn(*args, **kwargs)`` on a thread beside the caller, in a copy of the caller's context (its thread
    count), as a Future (issue 38 point 2: :func:`tribodyn.analyze` runs find_lag beside the pre-pass).

    The threads are kept for later calls (starting one costs ~0.3 ms, a tenth of a short analysis's fixed
    part): at most :data:`SIDE_THREADS`, started when every kept one is busy, each idle until its next job;
    they end with the interpreter. A child process made by ``fork`` starts its own (the parent's threads do
    not exist there). Once the interpreter is exiting, ``fn`` runs in the caller (:func:`thread_pool`).
    """
    global _SIDE
    ctx = contextvars.copy_context()
    with _SIDE_LOCK:
        if _SIDE is None or _SIDE[0] != os.getpid():
            _SIDE = (os.getpid(), thread_pool(SIDE_THREADS, "tribodyn-side"))
        return _SIDE[1].submit(ctx.run, fn, *args, **kwargs)


def thread_pool(workers: int, name: str) -> Executor:
    """A ``concurrent.futures.ThreadPoolExecutor`` of ``workers`` threads named ``name``, or, once the interpreter
    is exiting, an executor that runs each job in the caller, one after the other (the same results, later).

    An analysis in a thread that goes on after the main thread returned runs while the interpreter exits:
    ThreadPoolExecutor then refuses every new job ("cannot schedule new futures after interpreter shutdown")
    and its module, when not yet imported, cannot be ("can't register atexit after shutdown"), which failed
    such an analysis (issue 38 audit). Every thread pool of the package is made here.
    """
    try:
        cls = _pool_class()
    except RuntimeError:
        return _Here()
    return cls(workers, thread_name_prefix=name)


def _run_here(fn: Callable[..., _T], *args: Any, **kwargs: Any) -> "Future[_T]":
    """``fn(*args, **kwargs)`` run now, in the caller, as a done Future."""
    done: "Future[_T]" = Future()
    try:
        done.set_result(fn(*args, **kwargs))
    except BaseException as exc:  # noqa: BLE001 - the Future carries it, as a pool's would
        done.set_exception(exc)
    return done


class _Here(Executor):
    """Runs each job in the caller when it is submitted (``map`` too: Executor's map submits)."""

    def submit(self, fn: Callable[..., _T], /, *args: Any, **kwargs: Any) -> "Future[_T]":
        return _run_here(fn, *args, **kwargs)


_POOL: Optional[Type["ThreadPoolExecutor"]] = None


def _pool_class() -> Type["ThreadPoolExecutor"]:
    """ThreadPoolExecutor whose ``submit`` runs a job in the caller where the interpreter's exit refuses it
    (imported on first use: its module registers an exit hook, refused once the interpreter is exiting)."""
    global _POOL
    if _POOL is None:
        from concurrent.futures import ThreadPoolExecutor

        class Pool(ThreadPoolExecutor):
            def submit(self, fn: Callable[..., _T], /, *args: Any, **kwargs: Any) -> "Future[_T]":
                try:
                    return super().submit(fn, *args, **kwargs)
                except RuntimeError:  # "cannot schedule new futures after interpreter shutdown"
                    return _run_here(fn, *args, **kwargs)

        _POOL = Pool
    return _POOL
