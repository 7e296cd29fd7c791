"""Shared helpers of the text readers (LVM and delimited): number parsing,
block parsing of data lines, and sequential reading of a file's data rows.

Lines are read as bytes and decoded as latin-1 (numbers are ASCII, and
latin-1 never fails), so byte offsets found by a scan pass can be used to
seek straight to a data block later.
"""

from __future__ import annotations

import itertools
import warnings
from typing import IO, Iterator, List, Optional, Sequence, Tuple

import numpy as np

from .base import RecordingError

#: Lines parsed at once by the text readers (a block of lines costs far more
#: memory than its numbers, so text blocks are smaller than binary ones).
TEXT_BLOCK_ROWS = 8192

__all__ = [
    "TEXT_BLOCK_ROWS",
    "decode_header",
    "is_number",
    "iter_data_lines",
    "parse_rows",
    "split_fields",
    "to_float",
]


def to_float(s: str, decimal: str = ".") -> float:
    """Parses one field; ``decimal=','`` accepts a decimal comma. Raises ValueError."""
    s = s.strip()
    if decimal != ".":
        s = s.replace(decimal, ".")
    if "_" in s:  # float() accepts 1_000; a data file should not
        raise ValueError(s)
    return float(s)


def is_number(s: str, decimal: str = ".") -> bool:
    """True when ``s`` parses as a number (see :func:`to_float`)."""
    try:
        to_float(s, decimal)
    except ValueError:
        return False
    return True


def split_fields(line: str, delimiter: Optional[str]) -> List[str]:
    """Splits a line (without its end-of-line); ``delimiter=None`` splits on whitespace runs."""
    if delimiter is None:
        return line.split()
    return line.split(delimiter)


def decode_header(raw: bytes, encoding: str) -> str:
    """Decodes a header line with ``encoding``, falling back to latin-1."""
    try:
        return raw.decode(encoding)
    except UnicodeDecodeError:
        return raw.decode("latin-1")


def parse_rows(
    lines: Sequence[str],
    linenos: Sequence[int],
    delimiter: Optional[str],
    decimal: str,
    usecols: Sequence[int],
    colnames: Sequence[str],
    path: str,
) -> np.ndarray:
    """Parses data lines into a ``(len(lines), len(usecols))`` float64 array.

    Empty fields become NaN. A field that is not a number, or a line with
    too few fields, raises :class:`RecordingError` naming the line.

    Parameters
    ----------
    lines : sequence of str
        Data lines (end-of-line characters allowed).
    linenos : sequence of int
        1-based line numbers of ``lines`` in the file (for messages).
    delimiter : str or None
        Field separator; None for whitespace runs.
    decimal : str
        ``'.'`` or ``','``.
    usecols : sequence of int
        Field indices to keep.
    colnames : sequence of str
        Channel names of ``usecols`` (for messages).
    path : str
        File (for messages).
    """
    ncol = len(usecols)
    if not lines:
        return np.empty((0, ncol))
    if decimal == "," and delimiter != ",":
        fast_lines: Sequence[str] = [ln.replace(",", ".") for ln in lines]
    else:
        fast_lines = lines
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            a = np.loadtxt(
                fast_lines,
                delimiter=delimiter,
                usecols=list(usecols),
                dtype=np.float64,
                ndmin=2,
                comments=None,
                encoding=None,
            )
        if a.shape == (len(lines), ncol):
            return a
    except ValueError:
        pass
    # slow path: exact per-line checks, NaN for empty fields, precise errors
    out = np.empty((len(lines), ncol))
    need = max(usecols) + 1 if ncol else 0
    for r, (ln, no) in enumerate(zip(lines, linenos)):
        f = split_fields(ln.rstrip("\r\n"), delimiter)
        if len(f) < need:
            raise RecordingError(
                f"{path}: line {no} has {len(f)} fields, expected at least {need} (truncated or corrupt file)"
            )
        for c, (i, name) in enumerate(zip(usecols, colnames)):
            s = f[i].strip()
            if not s:
                out[r, c] = np.nan
                continue
            try:
                out[r, c] = to_float(s, decimal)
            except ValueError:
                raise RecordingError(
                    f"{path}: line {no}: {s[:40]!r} in channel {name!r} is not a number (corrupt file?)"
                ) from None
    return out


def iter_data_lines(
    fh: IO[bytes],
    offset: int,
    first_lineno: int,
    n_rows: int,
    block: int,
    path: str,
    comment: Optional[bytes] = None,
) -> Iterator[Tuple[List[str], List[int]]]:
    """Yields the data lines of one block of a text file, ``block`` lines at a time.

    Starts at byte ``offset`` (line number ``first_lineno``), skips blank lines
    (and lines starting with ``comment``), and stops after ``n_rows`` data
    lines. Raises :class:`RecordingError` if the file ends first.
    """
    fh.seek(offset)
    lineno = first_lineno - 1
    left = n_rows
    while left > 0:
        lines: List[str] = []
        nos: List[int] = []
        want = min(block, left)
        # read a few more than needed only if blank lines intervene
        while len(lines) < want:
            got_any = False
            for raw in itertools.islice(fh, want - len(lines)):
                got_any = True
                lineno += 1
                s = raw.strip()
                if not s or (comment is not None and s.startswith(comment)):
                    continue
                lines.append(raw.decode("latin-1"))
                nos.append(lineno)
            if not got_any:
                raise RecordingError(
                    f"{path}: file ended after line {lineno}, {left - len(lines)} data rows "
                    "short (file changed or truncated since it was opened?)"
                )
        left -= len(lines)
        yield lines, nos
