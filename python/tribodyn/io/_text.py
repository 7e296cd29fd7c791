"""Shared helpers of the text readers (LVM and delimited): number parsing,
block parsing of data lines, and sequential reading of a file's data rows.

Lines are read as bytes and decoded as latin-1 (numbers are ASCII, and
latin-1 never fails), so byte offsets found by a scan pass can be used to
seek straight to a data block later.
"""

from __future__ import annotations

import codecs
import itertools
import warnings
from typing import IO, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .base import RecordingError, roles_by_name

#: Lines parsed at once by the text readers (a block of lines costs far more
#: memory than its numbers, so text blocks are smaller than binary ones).
TEXT_BLOCK_ROWS = 8192

__all__ = [
    "TEXT_BLOCK_ROWS",
    "check_encoding",
    "decode_header",
    "default_roles",
    "duplicate_warnings",
    "dropped_row_warning",
    "incomplete_row_error",
    "is_number",
    "iter_data_lines",
    "parse_rows",
    "row_defects",
    "split_fields",
    "to_float",
]


def check_encoding(encoding: object) -> str:
    """``encoding`` when it names a text encoding Python knows; raises :class:`RecordingError` otherwise."""
    if not isinstance(encoding, str):
        raise RecordingError(f"encoding must be a string such as 'utf-8', got {encoding!r} (encoding=)")
    try:
        codecs.lookup(encoding)
    except LookupError:
        raise RecordingError(f"unknown encoding {encoding!r} (encoding=)") from None
    try:
        b"0".decode(encoding)
    except LookupError:  # 'base64', 'rot13'...: codecs, but not text encodings
        raise RecordingError(f"{encoding!r} is not a text encoding (encoding=)") from None
    except UnicodeError:  # a text encoding that wants more than one byte
        pass
    return encoding


def row_defects(nfields: int, expected: int, terminated: bool) -> str:
    """What is wrong with a last row, for messages: missing fields and/or line end ('' when nothing)."""
    out = []
    if nfields < expected:
        out.append(f"{nfields} fields, expected {expected}")
    if not terminated:
        out.append("no line end")
    return " and ".join(out)


def dropped_row_warning(lineno: int, defects: str) -> str:
    """Warning for a last row dropped because it may have been cut off (see :func:`row_defects`)."""
    return f"last row (line {lineno}) has {defects}: dropped as possibly cut off"


def incomplete_row_error(path: str, lineno: int, defects: str) -> RecordingError:
    """Error for a last row that is refused because it may have been cut off (see :func:`row_defects`)."""
    return RecordingError(f"{path}: last row (line {lineno}) has {defects}: incomplete row, file truncated or corrupt")


def _and(items: Sequence[str]) -> str:
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def _duplicated(names: Sequence[str]) -> Dict[str, List[int]]:
    """Names met more than once -> their indices."""
    where: Dict[str, List[int]] = {}
    for k, n in enumerate(names):
        where.setdefault(n, []).append(k)
    return {n: ks for n, ks in where.items() if len(ks) > 1}


def default_roles(names: Sequence[str], unique: Sequence[str]) -> Dict[str, str]:
    """Default role map of a text file's columns: :func:`~tribodyn.io.base.roles_by_name` of the names
    as written in the file (``names``), as the unique channel names the reader gave them (``unique``).

    A role is never mapped to a column whose name appears more than once in the file (see
    :func:`duplicate_warnings`).
    """
    return {role: unique[names.index(n)] for role, n in roles_by_name(names).items()}


def duplicate_warnings(
    names: Sequence[str], unique: Sequence[str], columns: Sequence[int], roles: Mapping[str, str]
) -> List[str]:
    """One warning per channel name appearing more than once in a file's column row.

    Parameters
    ----------
    names : sequence of str
        Channel names as written in the file.
    unique : sequence of str
        The distinct names the reader gave them (``'fy [N]'``, ``'fy [N].1'``...).
    columns : sequence of int
        1-based column of each channel in the file.
    roles : mapping
        The recording's role map, to say what happened to a role such a name would have had.
    """
    out = []
    for name, ks in _duplicated(names).items():
        given = [unique[k] for k in ks]
        msg = (
            f"channel name {name!r} appears in columns {_and([str(columns[k]) for k in ks])}: "
            f"read as {_and([repr(g) for g in given])}"
        )
        for role in roles_by_name([name]):
            mapped = roles.get(role)
            if mapped is None:
                msg += f"; role {role!r} left unmapped (ambiguous): map one with channels="
            elif mapped in given:
                msg += f"; role {role!r} mapped to {mapped!r} (column {columns[ks[given.index(mapped)]]})"
        out.append(msg)
    return out


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
