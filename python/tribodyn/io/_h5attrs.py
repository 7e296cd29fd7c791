"""Variable-length text attributes of HDF5 files, read in a helper process that can be abandoned.

libhdf5 can loop forever reading a variable-length string attribute whose
global heap is corrupt (seen on fuzzed files: a heap object of size 0), and
h5py holds the GIL while it does: no thread of the process can stop it, and
the process cannot go on. Such attributes (what h5py writes for a Python
``str``) are therefore read by a helper process with a time limit
(:data:`TIME_LIMIT`); a helper that does not answer in time is killed and the
file refused. Numbers and fixed-length text are stored in the attribute
message itself, never in the global heap: the reader reads those in-process.

The limit is on the helper's CPU time where the system can limit it
(``RLIMIT_CPU``: Linux, macOS): a loop in libhdf5 spends CPU time, a valid
file read on a loaded machine does not, so a busy machine no longer makes a
valid file fail (issue 34). The kernel ends a helper that passes its limit
(``SIGXCPU``); the wall-clock wait is then :data:`WALL_FACTOR` times longer,
for a read stalled in the file system. Where CPU time cannot be limited the
limit is wall-clock, as before.

One helper serves the whole process: it is started on first use (about
0.2 s: Python and h5py start), reused by every later open (a request costs
about a millisecond), replaced after a timeout or a crash, and ends when
the process does (its stdin closes). A child made by ``fork`` starts its own, under a new lock
(:func:`_after_fork_in_child`). A process that cannot start one
(``sys.executable`` cannot run ``-c``, as in some frozen applications) reads
the attributes in-process and says so in the recording's warnings.
"""

from __future__ import annotations

import atexit
import os
import pickle
import queue
import signal
import struct
import subprocess
import sys
import threading
from typing import IO, Any, List, Optional, Sequence, Tuple

__all__ = ["TIME_LIMIT", "HelperCrashed", "HelperUnavailable", "read_attributes"]

#: CPU seconds a request may take before the helper is stopped and the file refused (wall-clock seconds
#: where CPU time cannot be limited); a healthy read of a few attributes takes milliseconds.
TIME_LIMIT = 30.0
#: With a CPU-time limit, the wall-clock wait is this many times :data:`TIME_LIMIT` (a read stalled in
#: the file system spends no CPU time).
WALL_FACTOR = 10.0
#: Seconds the helper may take to start (import h5py) before it is given up as unavailable.
START_LIMIT = 60.0

# The helper: reads (path, [(object name, attribute key)]) requests from stdin, answers
# [("ok", value) or ("error", message)] per attribute. Messages are 8-byte lengths + pickles; the
# parent only unpickles what this code pickled (str, bytes, numbers, numpy arrays of them).
_HELPER = r"""
import sys
if sys.path and sys.path[0] in ("", "."):
    del sys.path[0]  # not the working directory's modules
import pickle, struct
try:
    import resource
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))  # no core file when the CPU limit ends the helper
    def limit_cpu(seconds):
        u = resource.getrusage(resource.RUSAGE_SELF)
        hard = resource.getrlimit(resource.RLIMIT_CPU)[1]
        soft = int(u.ru_utime + u.ru_stime + seconds) + 1
        if hard != resource.RLIM_INFINITY:
            soft = min(soft, hard)
        resource.setrlimit(resource.RLIMIT_CPU, (soft, hard))
    limit_cpu(3600)
except Exception:
    limit_cpu = None
inp, out = sys.stdin.buffer, sys.stdout.buffer
def send(obj):
    b = pickle.dumps(obj, protocol=4)
    out.write(struct.pack("<Q", len(b)) + b)
    out.flush()
def one_line(e):
    return " ".join(str(e).split()) or type(e).__name__
import h5py
send(("ready", h5py.__version__, limit_cpu is not None))
while True:
    head = inp.read(8)
    if len(head) < 8:
        break
    path, items, cpu = pickle.loads(inp.read(struct.unpack("<Q", head)[0]))
    if limit_cpu is not None:
        limit_cpu(cpu)
    try:
        with h5py.File(path, "r") as f:
            res = []
            for name, key in items:
                try:
                    res.append(("ok", f[name].attrs[key]))
                except Exception as e:
                    res.append(("error", one_line(e)))
    except Exception as e:
        res = [("error", one_line(e))] * len(items)
    send(("done", res))
"""


class HelperUnavailable(RuntimeError):
    """The helper process could not be started (the caller reads in-process)."""


class HelperCrashed(RuntimeError):
    """The helper process died while reading (the library crashed on the file)."""


def _recv(stream: IO[bytes]) -> Any:
    head = stream.read(8)
    if len(head) < 8:
        return None
    (n,) = struct.unpack("<Q", head)
    body = stream.read(n)
    if len(body) < n:
        return None
    return pickle.loads(body)


class _Helper:
    """One helper process and the thread that reads its answers."""

    def __init__(self) -> None:
        self.pid = os.getpid()
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-c", _HELPER],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.DEVNULL,
            )
        except (OSError, ValueError) as exc:
            raise HelperUnavailable(f"cannot start {sys.executable!r}: {exc}") from None
        self.answers: "queue.Queue[Any]" = queue.Queue()
        threading.Thread(target=self._pump, name="tribodyn-h5attrs", daemon=True).start()
        try:
            first = self._answer(START_LIMIT)
        except TimeoutError:
            first = None
        if not (isinstance(first, tuple) and first[:1] == ("ready",)):
            self.kill()
            raise HelperUnavailable("the helper process did not start (h5py not importable by sys.executable?)")
        #: Whether the helper's CPU time is limited (else the limit is wall-clock).
        self.cpu_limited = len(first) > 2 and first[2] is True

    def _pump(self) -> None:
        stdout = self.proc.stdout
        assert stdout is not None
        while True:
            try:
                msg = _recv(stdout)
            except Exception:  # noqa: BLE001 - a broken pipe or a cut message: the helper is gone
                msg = None
            self.answers.put(msg)
            if msg is None:
                return

    def _answer(self, limit: float) -> Any:
        try:
            return self.answers.get(timeout=limit)
        except queue.Empty:
            raise TimeoutError from None

    def ask(self, path: str, items: Sequence[Tuple[str, str]], limit: float) -> List[Tuple[str, Any]]:
        stdin = self.proc.stdin
        assert stdin is not None
        body = pickle.dumps((path, list(items), limit), protocol=4)
        try:
            stdin.write(struct.pack("<Q", len(body)) + body)
            stdin.flush()
        except OSError:
            raise HelperCrashed("the helper process is gone") from None
        try:
            msg = self._answer(limit * WALL_FACTOR if self.cpu_limited else limit)
        except TimeoutError:
            raise TimeoutError(
                f"{limit:g} s" + (f" ({limit * WALL_FACTOR:g} s of wall-clock time)" if self.cpu_limited else "")
            ) from None
        if msg is None:
            code = self.proc.wait()
            if self.cpu_limited and code == -getattr(signal, "SIGXCPU", 0x7FFF):  # the kernel ended it at its limit
                raise TimeoutError(f"{limit:g} s of CPU time")
            raise HelperCrashed(f"the helper process died (exit code {code})")
        out: List[Tuple[str, Any]] = msg[1]
        return out

    def forget(self) -> None:
        """In a child made by ``fork``: its copies of this (the parent's) helper's pipes now lead to the null
        device, so that nothing the parent's thread left in the copied write buffer reaches the parent's helper
        (a request it would answer twice), no reused descriptor is written, and the helper sees its stdin close
        when the parent ends. The helper itself is the parent's: left alone."""
        null = os.open(os.devnull, os.O_RDWR)
        try:
            for stream in (self.proc.stdin, self.proc.stdout):
                if stream is not None:
                    os.dup2(null, stream.fileno())
        except (OSError, ValueError):  # pragma: no cover - a stream already closed
            pass
        finally:
            os.close(null)

    def kill(self) -> None:
        try:
            self.proc.kill()
        except OSError:  # pragma: no cover - already gone
            pass
        for s in (self.proc.stdin, self.proc.stdout):
            try:
                if s is not None:
                    s.close()
            except OSError:  # pragma: no cover
                pass
        self.proc.wait()


_lock = threading.Lock()
_helper: Optional[_Helper] = None


def read_attributes(
    path: str, items: Sequence[Tuple[str, str]], limit: Optional[float] = None
) -> List[Tuple[str, Any]]:
    """``[("ok", value) | ("error", message)]`` for each ``(object name, attribute key)`` of the HDF5 file.

    Raises
    ------
    TimeoutError
        No answer within ``limit`` s of CPU time (default :data:`TIME_LIMIT`; wall-clock where CPU time cannot
        be limited); the helper was stopped. Its message says which limit.
    HelperCrashed
        The helper died reading (e.g. the HDF5 library crashed on the file).
    HelperUnavailable
        No helper process can be started here.
    """
    global _helper
    wait = TIME_LIMIT if limit is None else float(limit)
    with _lock:
        if _helper is not None and _helper.pid != os.getpid():
            _helper = None  # a forked child: the parent's helper is not ours to use
        if _helper is None:
            _helper = _Helper()
        helper = _helper
        try:
            return helper.ask(os.path.abspath(path), items, wait)
        except (TimeoutError, HelperCrashed):
            _helper = None
            helper.kill()
            raise


def _stop() -> None:
    global _helper
    helper, _helper = _helper, None
    if helper is not None and helper.pid == os.getpid():
        helper.kill()


atexit.register(_stop)


def _after_fork_in_child() -> None:
    """A child made by ``fork`` (``multiprocessing`` on Linux) starts its own helper under a new lock: the copied
    lock may be held by a thread of the parent that is not in the child (reading attributes or starting the
    helper), and the child's first HDF5 open would wait for it forever (issue 38 audit)."""
    global _lock, _helper
    _lock = threading.Lock()
    old, _helper = _helper, None
    if old is not None and old.pid != os.getpid():
        old.forget()


if hasattr(os, "register_at_fork"):  # POSIX
    os.register_at_fork(after_in_child=_after_fork_in_child)
