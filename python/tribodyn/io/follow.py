"""A recording that another program is still writing: :class:`Follower` (docs/method.md 11).

A DAQ or a tribometer appends to its file while the test runs. A follower
opens the file once it can be read and, at each :meth:`Follower.poll`, makes
the samples written since visible, whole samples only:

- **text** (CSV/TSV/LVM, read natively): the rows after the last whole line
  already seen are scanned (only the new bytes), and a row still being
  written (no line end yet) waits for its end. The recording object grows:
  its checkpoints, sample count and identity are extended, so reads of the
  new rows go through the reader's own parse, units and roles.
- **every other format** (TDMS, HDF5, ...): the file is opened again with the
  role map of the first opening (its metadata only: a TDMS index, an HDF5
  dataset's length; no role is chosen from the data again). A TDMS segment
  or an HDF5 dataset that is not yet whole is what the reader cannot open:
  the follower waits for it (:attr:`Follower.waiting` says why).

A file that shrinks, or is replaced by another (inode), is an error
(:class:`~tribodyn.io.base.RecordingError`), never a table of mixed data.
"""

from __future__ import annotations

import os
import time
from typing import Any, Callable, Dict, Optional, Tuple

from ._text import Checkpoints, TextRecording, native_scan
from .base import Recording, RecordingError

__all__ = ["Follower"]

#: Bytes read at most per poll of a text file (a poll after a long pause takes the rest at the next one).
MAX_POLL_BYTES = 256 * 1024 * 1024


class Follower:
    """Follows a growing recording file (docs/method.md 11).

    Parameters
    ----------
    path : str
        The file being written.
    opener : callable
        ``opener(path, **kw)`` returns a :class:`~tribodyn.io.base.Recording`
        (``tribodyn.io.open_recording`` with the reading options bound); it
        is called again with ``channels=`` the first opening's role map for
        formats that are re-opened.
    clock : callable
        Seconds (``time.monotonic``); tests pass their own.

    Attributes
    ----------
    recording : Recording or None
        The file's whole samples so far (None until it can be opened).
    waiting : str
        Why the last poll saw no new sample ('' when it did).
    grown_at : float
        ``clock()`` when new samples were last seen (or the follower was made).
    """

    def __init__(self, path: str, opener: Callable[..., Recording], *,
                 clock: Callable[[], float] = time.monotonic,
                 usable: Optional[Callable[[Recording], str]] = None) -> None:  # fmt: skip
        self.path = os.fspath(path)
        self._opener = opener
        #: ``usable(rec)``: '' when the first opening holds what the caller needs, else why not yet (a writer
        #: that creates its channels one after the other); the follower then opens the file again later.
        self._usable = usable
        self._clock = clock
        self.recording: Optional[Recording] = None
        self.waiting = "the file does not exist yet"
        self.grown_at = clock()
        self._inode: Optional[Tuple[int, int]] = None
        self._size = 0
        self._text: Optional[_TextTail] = None
        self._roles: Optional[Dict[str, str]] = None  # the first opening's role map
        self._seen = 0  # samples seen while the file is being opened again

    @property
    def n_samples(self) -> int:
        """Whole samples seen so far."""
        return self._seen if self.recording is None else int(self.recording.n_samples)

    def poll(self) -> int:
        """Makes the samples written since the last poll visible; returns how many are new (0: none yet)."""
        try:
            st = os.stat(self.path)
        except FileNotFoundError:
            if self._inode is not None:
                raise RecordingError(f"{self.path}: the file was removed while it was watched") from None
            self.waiting = "the file does not exist yet"
            return 0
        self._check_same_file(st)
        if st.st_size == self._size and self.recording is not None and self._size:
            self.waiting = "no new data"
            return 0
        before = self.n_samples
        if self._roles is None:
            self._first_open()
        elif self._text is not None and isinstance(self.recording, TextRecording):
            self._text.extend(self.recording)
        else:
            self._reopen()
        self._size = st.st_size
        new = self.n_samples - before
        if new > 0:
            self.grown_at = self._clock()
            self.waiting = ""
        elif not self.waiting:
            self.waiting = "no whole new sample (a row or segment still being written)"
        return new

    def _check_same_file(self, st: os.stat_result) -> None:
        ident = (st.st_ino, st.st_dev)
        if self._inode is not None and ident != self._inode:
            raise RecordingError(f"{self.path}: the file was replaced by another while it was watched")
        if st.st_size < self._size:
            raise RecordingError(
                f"{self.path}: the file shrank from {self._size} to {st.st_size} bytes while it was watched "
                "(truncated or rewritten): the samples read no longer hold"
            )
        self._inode = ident

    def _first_open(self) -> None:
        try:
            rec = self._opener(self.path)
        except (RecordingError, ValueError, OSError) as exc:  # not yet readable: a header or a segment in writing
            self.waiting = f"cannot be read yet: {exc}"
            return
        why = self._usable(rec) if self._usable is not None else ""
        if why:
            rec.close()
            self.waiting = f"cannot be used yet: {why}"
            return
        rec._appending = True
        rec.warnings[:] = [w for w in rec.warnings if "possibly cut off" not in w]  # the row being written
        self.recording = rec
        self._roles = dict(rec.roles)
        if isinstance(rec, TextRecording) and _TextTail.supports(rec):
            self._text = _TextTail(rec)
        self.waiting = ""

    def _reopen(self) -> None:
        # The earlier opening is closed first: a library that keeps one handle a file (HDF5) would give the
        # new opening the old one's view of it.
        if self.recording is not None:
            self._seen = int(self.recording.n_samples)
            self.recording.close()
            self.recording = None
        try:
            rec = self._opener(self.path, channels=self._roles)
        except (RecordingError, ValueError, OSError) as exc:  # a segment or dataset still being written
            self.waiting = f"waiting for the writer: {exc}"
            return
        if rec.n_samples < self._seen:
            rec.close()
            raise RecordingError(
                f"{self.path}: the file now holds {rec.n_samples} samples, fewer than the {self._seen} "
                "already read (rewritten while it was watched)"
            )
        rec._appending = True
        self.recording = rec

    def close(self) -> None:
        """Closes the recording."""
        if self.recording is not None:
            self.recording.close()


class _TextTail:
    """The end of a text recording's data rows, extended by the rows appended since (native layouts)."""

    def __init__(self, rec: TextRecording) -> None:
        cp = rec._checkpoints
        assert cp is not None and len(cp.sample)
        # The rows of the last checkpoint on, scanned again to find where the last whole row ends.
        #: The bytes before the first data row (the header), which a writer must not rewrite.
        self.head = _read_bytes(rec._text_path(), 0, int(cp.offset[0]))
        s, off, line = int(cp.sample[-1]), int(cp.offset[-1]), int(cp.line[-1])
        run = self._scan(rec, off)
        rows = min(int(run["rows"]), rec.n_samples - s)
        if s + rows < rec.n_samples:  # the reader took a last row ended by a CR whose LF is not yet written:
            _hold(rec, s + rows)  # it waits for its LF, as the next rows do (the scan's rows are the whole ones)
        #: Byte offset after the last whole row seen, and the lines before it.
        self.end, self.line = _after_rows(rec, off, line - 1, rows)

    @staticmethod
    def supports(rec: TextRecording) -> bool:
        """Whether the recording is read natively, as one acquisition without a time break."""
        cp = rec._checkpoints
        return (cp is not None and rec._parse_dialect is not None and len(cp.sample) > 0
                and len(rec.segments) == 1 and rec._text_path() == rec.path)  # fmt: skip

    @staticmethod
    def _scan(rec: TextRecording, start: int) -> Dict[str, Any]:
        nf = getattr(rec, "_nf", None)
        fd = os.open(rec._text_path(), os.O_RDONLY | getattr(os, "O_BINARY", 0))
        try:
            assert rec._parse_dialect is not None
            return native_scan(fd, start, rec._parse_dialect, nf=nf, probe=int(rec._usecols[0]))
        finally:
            os.close(fd)

    def extend(self, rec: TextRecording) -> None:
        """Adds the whole rows written after :attr:`end` to ``rec`` (its checkpoints, sample count, identity).

        The new bytes are read once, by the native scan (rows, lines, checkpoints); Python reads only the
        header (to see that it was not rewritten) and the end of the new bytes (the last line end)."""
        path = rec._text_path()
        with open(path, "rb") as fh:
            size = os.fstat(fh.fileno()).st_size
            if size <= self.end:
                return
            if fh.read(len(self.head)) != self.head:
                raise RecordingError(
                    f"{rec.path}: the header was rewritten while the file was watched: the rows read may no "
                    "longer hold; analyse the file once it is complete"
                )
            whole_end = _last_line_end(fh, self.end, min(size, self.end + MAX_POLL_BYTES))
        if whole_end <= self.end:
            return  # a row still being written
        run = self._scan(rec, self.end)
        rows, stop, lines = int(run["rows"]), int(run["end"]), int(run["lines"])
        if stop > whole_end:  # rows written after the size was read, which the scan saw too: the next poll's
            extra = _read_bytes(path, whole_end, stop - whole_end)  # whole lines (both ends follow a line end)
            rows -= _data_lines(rec, extra)
            lines -= extra.count(b"\n")
        elif stop < whole_end:
            rest = _read_bytes(path, stop, whole_end - stop)
            if rest.strip():
                raise RecordingError(
                    f"{rec.path}: line {self.line + 1 + lines} is not a data row like those before it (the writer "
                    "changed the layout or wrote a footer): watching stops here; analyse the file"
                )
            lines += rest.count(b"\n")
        n0 = rec.n_samples
        first = self.line + 1
        cps = [(n0 + int(r), int(o), first + int(ln)) for r, o, ln in run["checkpoints"] if int(r) < rows]
        marks = [(n0 + int(r), int(o), first + int(ln)) for r, o, ln in run["marks"] if int(r) < rows]
        cps.append((n0, self.end, first))  # (Checkpoints keeps one entry a sample: the earliest offset)
        n = n0 + rows
        assert rec._checkpoints is not None
        rec._checkpoints = rec._checkpoints.extended(cps, n, marks)  # only the new rows' entries sorted
        rec._n = n
        a = rec._segments[-1][0] if rec._segments else 0
        rec._segments = [*rec._segments[:-1], (a, n)]
        self.end, self.line = whole_end, self.line + lines
        rec._identity_at_open = rec._identity()


#: Bytes read at a time from the end of the new bytes, looking for their last line end.
_TAIL_BLOCK = 64 * 1024


def _last_line_end(fh: Any, lo: int, hi: int) -> int:
    """The byte offset just after the last ``\\n`` in bytes ``lo:hi`` of the open file ``fh`` (``lo``: none).

    Only ``\\n`` ends a row for the native scan: a ``\\r`` just written waits for its ``\\n`` (a CRLF writer
    whose write ends between the two)."""
    b = hi
    while b > lo:
        a = max(lo, b - _TAIL_BLOCK)
        fh.seek(a)
        at = int(fh.read(b - a).rfind(b"\n"))
        if at >= 0:
            return a + at + 1
        b = a
    return lo


def _hold(rec: TextRecording, n: int) -> None:
    """``rec`` cut to its first ``n`` samples (its checkpoints, sample count, last segment, identity)."""
    cp = rec._checkpoints
    assert cp is not None
    entries = list(zip(cp.sample.tolist(), cp.offset.tolist(), cp.line.tolist()))
    marks = [m for m in zip(cp.mark_sample.tolist(), cp.mark_offset.tolist(), cp.mark_line.tolist()) if m[0] < n]
    rec._checkpoints = Checkpoints(entries, n, marks)
    rec._n = n
    a = rec._segments[-1][0] if rec._segments else 0
    rec._segments = [*rec._segments[:-1], (a, n)]
    rec._identity_at_open = rec._identity()


def _data_lines(rec: Recording, data: bytes) -> int:
    """The lines of ``data`` that are rows (neither blank nor comments), an unterminated last one included."""
    return sum(1 for line in data.split(b"\n") if line.strip() and not _is_comment(rec, line.strip()))


def _is_comment(rec: Recording, stripped: bytes) -> bool:
    dialect = getattr(rec, "_parse_dialect", None) or {}
    comment = dialect.get("comment")
    return bool(comment) and stripped.startswith(str(comment).encode())


def _after_rows(rec: TextRecording, off: int, lines_before: int, rows: int) -> Tuple[int, int]:
    """(byte offset, lines before it) just after ``rows`` whole data rows from byte ``off``."""
    pos, ln, seen = off, lines_before, 0
    with open(rec._text_path(), "rb") as fh:
        fh.seek(off)
        while seen < rows:
            raw = fh.readline()
            if not raw.endswith((b"\n", b"\r")):
                break  # a row still being written
            pos += len(raw)
            ln += 1
            s = raw.strip()
            if s and not _is_comment(rec, s):
                seen += 1
    return pos, ln


def _read_bytes(path: str, start: int, n: int) -> bytes:
    with open(path, "rb") as fh:
        fh.seek(start)
        return fh.read(n)
