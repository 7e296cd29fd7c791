"""The inputs' SHA-256 in a background thread (:class:`Digests`), started by the command line before it imports the
analysis (:func:`start_early`; stdlib only, so importing this module costs nothing of note: issue 38 point 3)."""

from __future__ import annotations

import hashlib
import os
import stat
import threading
from pathlib import Path
from typing import Dict, Iterable, List, Optional, Sequence, Union

PathLike = Union[str, "os.PathLike[str]"]


class Digests:
    """SHA-256 of files computed in a background thread started at once (issue 25).

    File reads and ``hashlib`` release the GIL, so the digests of the
    inputs overlap the analysis that reads the same files. :meth:`get`
    waits for a file's digest (computing it here if the thread did not);
    :meth:`cancel` stops the thread at its next block.
    """

    _BLOCK = 1 << 20

    def __init__(self, paths: Iterable[PathLike]) -> None:
        self._paths = [Path(p) for p in paths]
        self._done: Dict[str, Union[str, BaseException]] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="tribodyn-sha256", daemon=True)
        self._thread.start()

    @staticmethod
    def _key(p: PathLike) -> str:
        return os.path.realpath(os.fspath(p))

    def keys(self) -> List[str]:
        """The files' real paths, in the order they are hashed."""
        return [self._key(p) for p in self._paths]

    def _run(self) -> None:
        buf = bytearray(self._BLOCK)
        view = memoryview(buf)
        for p in self._paths:
            try:
                h = hashlib.sha256()
                with open(p, "rb", buffering=0) as fh:
                    while not self._stop.is_set():
                        k = fh.readinto(buf)
                        if not k:
                            break
                        h.update(view[:k])
                if self._stop.is_set():
                    return
                self._done[self._key(p)] = h.hexdigest()
            except BaseException as exc:  # noqa: BLE001 - get() computes it again and raises there
                self._done[self._key(p)] = exc

    def get(self, path: PathLike) -> str:
        """The hex SHA-256 of ``path`` (waits for the thread)."""
        from ..io.writers import sha256_file

        self._thread.join()
        got = self._done.get(self._key(path))
        return got if isinstance(got, str) else sha256_file(path)

    def cancel(self) -> None:
        self._stop.set()

    @classmethod
    def for_files(cls, files: Sequence[PathLike]) -> "Digests":
        """The digests of ``files``: those :func:`start_early` started when they are of the same files in the same
        order (the command line's arguments were the files themselves), else a new thread; an early thread of
        other files is cancelled."""
        early = _EARLY.pop("digests", None)
        if early is not None:
            if early.keys() == [cls._key(f) for f in files]:
                return early
            early.cancel()
        return cls(files)


_EARLY: Dict[str, Digests] = {}


def start_early(args: Sequence[str]) -> Optional[Digests]:
    """Starts hashing the command line's input arguments when every one of them is a regular file (no glob, no
    folder), before the command imports NumPy and the analysis (~0.3-0.5 s of one core that the hashing thread
    overlaps); :meth:`Digests.for_files` takes it over. None when an argument is not a regular file."""
    for a in args:
        try:
            if not stat.S_ISREG(os.stat(a).st_mode):
                return None
        except (OSError, ValueError):
            return None
    if not args:
        return None
    _EARLY["digests"] = Digests(args)
    return _EARLY["digests"]


def drop_early() -> None:
    """Cancels the thread :func:`start_early` started if nothing took it over."""
    early = _EARLY.pop("digests", None)
    if early is not None:
        early.cancel()
