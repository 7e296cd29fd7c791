"""Delimited text recordings (CSV, TSV, ...), including two vendor exports.

Generic files
    The first lines (up to 400 / 1 MB) are sniffed: the delimiter (tab, ``;``,
    ``,``, ``|`` or whitespace), the decimal separator (a decimal comma is
    recognised when the delimiter is not a comma), the first data row (the
    first mostly-numeric row followed by rows of the same width), the column
    row above it and, between them, an optional units row. Units may also be
    given in the names as ``Force [N]`` or ``Force (N)``. Columns holding
    text (e.g. clock times) are not channels (``metadata['text_columns']``).
    A numeric time column (named ``time``, ``t``, ``test time``,
    ``x_value``...; or ``time_column=``) gives fs = 1 / median step.
    Blank lines and lines starting with ``#`` are ignored; non-numeric lines
    after the data are a footer. The column row repeated further down starts
    a new *block* (a separate acquisition): blocks are concatenated and their
    sample ranges exposed as :attr:`Recording.segments`. The last row must be
    whole: one without its line end, or with too few fields, may have been cut
    off while the file was written or copied and is dropped with a warning (a
    short row before the end is an error). A column name met twice is read as
    ``name`` and ``name.1`` with a warning, and no role is mapped to either.

CETR UMT exports (``format='cetr'``, detected by ``CETR`` in the first lines)
    A text header, then one block per test "Step", each with a column row
    ``Fx,Fz,Z,Y,X,V1,V2,V3,T,Ff,COF`` and a units row. Forces are in ``g``,
    which CETR means as gram-force: converted to N (x 9.80665e-3). Each
    block's row count is checked against its ``Data Count`` line (fewer rows:
    truncated file). Default roles: ``fy='Ff'`` (friction force magnitude,
    ``Ff = |Fx|``; ``COF = Ff / |Fz|`` in these files), ``fz='Fz'`` (negative:
    compression), ``cof='COF'``. The signed friction force is the channel
    ``Fx``. fs from the ``T`` column (s, restarts at 0 in each block).
COMPEND pin-on-disc exports (``format='compend'``)
    About 16 header lines (``Data file``, ..., ``Test started at``), a
    tab-separated column row and decimal-comma data; a ``Test completed``
    footer. The file has no units row: ``Load`` and ``Friction Force`` are in
    N (the export's ``Load`` equals ``Mass`` [g] x 9.80665e-3) and ``Test
    Time`` in s, which gives fs (1 Hz). ``Time`` (clock time) is a text
    column; the second ``Friction Force`` column is named ``Friction
    Force.1``. Default roles: ``fy='Friction Force'``, ``fz='Load'``,
    ``cof='Friction Coefficient'``.

Both vendor exports write every row whole: there a cut last row is refused
(as in LVM files), not dropped.

Reading is streaming: a scan pass at open reads the file line by line
(counting rows, recording byte offsets of the blocks, keeping at most 200 000
time values); :meth:`Recording.chunks` then parses blocks of lines
from those offsets.
"""

from __future__ import annotations

import os
import re
from array import array
from typing import Dict, Iterator, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from ._text import (
    TEXT_BLOCK_ROWS,
    check_encoding,
    decode_header,
    default_roles,
    dropped_row_warning,
    duplicate_warnings,
    incomplete_row_error,
    is_number,
    iter_data_lines,
    parse_rows,
    row_defects,
    split_fields,
    to_float,
)
from .base import Recording, RecordingError, fs_from_times
from .units import GRAM_FORCE, TIME_TO_S, is_known_unit, normalize_unit

__all__ = ["DelimitedRecording", "sniff_vendor"]

_HEAD_LINES = 400
_HEAD_BYTES = 1 << 20
_TIME_VALUES = 200_000  # time values kept in total to estimate fs
_DELIMITERS: Tuple[Optional[str], ...] = ("\t", ";", ",", "|", None)
_TIME_NAMES = (
    "time",
    "t",
    "test time",
    "time_s",
    "elapsed time",
    "timestamp",
    "x_value",
    "seconds",
    "sec",
    "s",
)

_DATA_COUNT = re.compile(r"Data Count\s*=\s*(\d+)")
_CETR_ROLES = {"fy": "Ff", "fz": "Fz", "cof": "COF"}
_COMPEND_ROLES = {"fy": "Friction Force", "fz": "Load", "cof": "Friction Coefficient"}
_COMPEND_UNITS = {"Load": "N", "Friction Force": "N", "Friction Force.1": "N", "Test Time": "s"}


def sniff_vendor(head: str) -> Optional[str]:
    """``'cetr'``, ``'compend'`` or None from the first lines of a text file."""
    lines = head.splitlines()
    if any("CETR" in ln for ln in lines[:5]):
        return "cetr"
    if lines and lines[0].startswith("Data file") and any(ln.startswith("Test started at") for ln in lines[:40]):
        return "compend"
    return None


class _Block:
    __slots__ = ("info", "lineno", "n", "offset", "times")

    def __init__(self, offset: int, lineno: int, info: List[str]) -> None:
        self.offset = offset
        self.lineno = lineno
        self.n = 0
        self.info = info
        self.times: "array[float]" = array("d")


def _numericish(fields: Sequence[str], decimal: Optional[str]) -> bool:
    """Mostly numbers: >= 1 number and numbers are >= half of the non-empty fields."""
    nonempty = [f for f in fields if f.strip()]
    if not nonempty:
        return False
    if decimal is None:
        num = sum(1 for f in nonempty if is_number(f, ".") or is_number(f, ","))
    else:
        num = sum(1 for f in nonempty if is_number(f, decimal))
    return num >= 1 and 2 * num >= len(nonempty)


def _find_data_start(
    lines: Sequence[str], delim: Optional[str], decimal: Optional[str]
) -> Optional[Tuple[int, int, int]]:
    """(index of first data line, field count, data lines that follow) or None."""
    for i, ln in enumerate(lines):
        if not ln.strip() or ln.lstrip().startswith("#"):
            continue
        f = split_fields(ln, delim)
        if not _numericish(f, decimal):
            continue
        nf = len(f)
        ok = True
        count = 1
        for ln2 in lines[i + 1 :]:
            if not ln2.strip():
                continue
            f2 = split_fields(ln2, delim)
            if len(f2) == nf and _numericish(f2, decimal):
                count += 1
                if count > 50:
                    break
            else:
                ok = count >= 2  # one numeric line among text lines is no table
                break
        if ok:
            return i, nf, count
    return None


def _numeric_share(lines: Sequence[str], delim: Optional[str], decimal: Optional[str], nf: int) -> float:
    """Share of numbers among the non-empty fields of the first 50 rows of ``nf`` fields."""
    num = total = rows = 0
    for ln in lines:
        if not ln.strip() or ln.lstrip().startswith("#"):
            continue
        fields = split_fields(ln, delim)
        if len(fields) != nf:
            continue
        f = [x for x in fields if x.strip()]
        total += len(f)
        if decimal is None:
            num += sum(1 for x in f if is_number(x, ".") or is_number(x, ","))
        else:
            num += sum(1 for x in f if is_number(x, decimal))
        rows += 1
        if rows >= 50:
            break
    return num / total if total else 0.0


_BRACKET_UNIT = re.compile(r"^(.*?)\s*(\[([^\[\]]{1,16})\]|\(([^()]{1,12})\))\s*$")


def _unit_from_name(name: str) -> Optional[str]:
    m = _BRACKET_UNIT.match(name)
    if not m:
        return None
    if m.group(3) is not None:
        return m.group(3).strip() or None
    tok = m.group(4).strip()
    return tok if is_known_unit(tok) else None


def _clean(s: str) -> str:
    s = s.strip()
    if len(s) >= 2 and s[0] == s[-1] and s[0] in "\"'":
        s = s[1:-1].strip()
    return s


def _dedupe(names: List[str]) -> List[str]:
    seen: Dict[str, int] = {}
    out = []
    for n in names:
        if n in seen:
            k = seen[n] + 1
            while f"{n}.{k}" in seen:
                k += 1
            seen[n] = k
            m = f"{n}.{k}"
            seen[m] = 0
            out.append(m)
        else:
            seen[n] = 0
            out.append(n)
    return out


def _key_values(lines: Sequence[str], delim: Optional[str]) -> Dict[str, str]:
    """``key = value`` / ``key: value`` / ``key<delim>value`` header lines as a dict."""
    out: Dict[str, str] = {}
    for ln in lines:
        s = ln.strip()
        if not s:
            continue
        m = re.match(r"^([^=:]{1,60}?)\s*[=:]\s*(.*)$", s)
        if m and "\\" not in m.group(1):
            out.setdefault(m.group(1).strip(), m.group(2).strip())
            continue
        if delim is not None and delim in s:
            parts = [p.strip() for p in s.split(delim)]
            vals = [p for p in parts[1:] if p]
            if parts[0] and vals:
                out.setdefault(parts[0], " ".join(vals))
    return out


class DelimitedRecording(Recording):
    """A delimited text file (generic, CETR or COMPEND); see the module docstring."""

    # Each read opens its own file handle.
    thread_safe = True

    format = "delimited"

    def __init__(
        self,
        path: str,
        *,
        vendor: Optional[str] = None,
        channels: Optional[Mapping[str, Optional[str]]] = None,
        fs: Optional[float] = None,
        scale: Optional[Mapping[str, float]] = None,
        units: Optional[Mapping[str, str]] = None,
        delimiter: Optional[str] = None,
        decimal: Optional[str] = None,
        encoding: Optional[str] = None,
        time_column: Optional[str] = None,
        time_channel: Optional[str] = None,
    ) -> None:
        super().__init__(path)
        self._block_rows = TEXT_BLOCK_ROWS
        if time_column is None:
            time_column = time_channel
        if encoding:
            check_encoding(encoding)
        self._stat = os.stat(self.path)
        head_raw = self._read_head()
        enc = encoding or _guess_encoding(head_raw)
        self._encoding = enc
        head = [decode_header(r, enc).rstrip("\r\n") for r in head_raw]
        if head and head[0].startswith("\ufeff"):
            head[0] = head[0][1:]
        if vendor is None:
            vendor = sniff_vendor("\n".join(head[:40]))
        elif vendor not in ("cetr", "compend", "generic"):
            raise RecordingError(f"unknown delimited-text vendor {vendor!r}")
        vendor = None if vendor == "generic" else vendor
        self._vendor = vendor
        if vendor == "cetr":
            self.format = "cetr"
            delimiter = "," if delimiter is None else delimiter
            decimal = decimal or "."
        elif vendor == "compend":
            self.format = "compend"
            delimiter = "\t" if delimiter is None else delimiter
            decimal = decimal or ","
            time_column = time_column or "Test Time"
        if decimal not in (None, ".", ","):
            raise RecordingError(f"decimal must be '.' or ',', got {decimal!r}")
        self._comment = None if vendor else "#"
        self._analyse_head(head, delimiter, decimal, time_column)
        self._scan(head_raw)
        self._vendor_fixups()
        self._setup(channels, fs, scale, units)
        if self._vendor is None:  # the vendors' duplicates (COMPEND's 'Friction Force') are by design
            self.warnings += duplicate_warnings(self._file_names, self._names, self._columns, self.roles)

    # ------------------------------------------------------------------ head
    def _read_head(self) -> List[bytes]:
        out: List[bytes] = []
        total = 0
        with open(self.path, "rb") as fh:
            for raw in fh:
                out.append(raw)
                total += len(raw)
                if len(out) >= _HEAD_LINES or total >= _HEAD_BYTES:
                    break
        if not out:
            raise RecordingError(f"{self.path}: empty file")
        if any(b"\x00" in r for r in out[:50]):
            raise RecordingError(f"{self.path}: binary content, not a delimited text file")
        return out

    def _analyse_head(
        self,
        head: List[str],
        delimiter: Optional[str],
        decimal: Optional[str],
        time_column: Optional[str],
    ) -> None:
        path = self.path
        if delimiter is not None:
            delim: Optional[str] = None if delimiter in ("whitespace", " ") else delimiter
            found = _find_data_start(head, delim, decimal if decimal else (None if delim != "," else "."))
            if found is None:
                raise RecordingError(f"{path}: no data rows found with delimiter {delimiter!r}")
        else:
            best = None
            for cand in _DELIMITERS:
                dec = "." if cand == "," else decimal
                if cand == "," and decimal == ",":
                    continue
                r = _find_data_start(head, cand, dec)
                if r is None:
                    continue
                # The share of numbers decides between candidates that find as many rows: "1,5;2,5;3,5"
                # is three numbers split at ';', not "1", "5;2", "5;3", "5" split at ','.
                score = (r[1] >= 2, r[2], _numeric_share(head[r[0] :], cand, dec, r[1]), -r[0], r[1])
                if best is None or score > best[0]:
                    best = (score, cand, r)
            if best is None:
                raise RecordingError(f"{path}: no table of numbers found (not a delimited text recording?)")
            delim, found = best[1], best[2]
        d0, nf, _ = found
        # sample data rows
        sample: List[List[str]] = []
        for ln in head[d0:]:
            if not ln.strip() or ln.lstrip().startswith("#"):
                continue
            f = split_fields(ln, delim)
            if len(f) != nf:
                break
            sample.append(f)
            if len(sample) >= 50:
                break
        if decimal is None:
            if delim != "," and any("," in x for row in sample for x in row if is_number(x, ",")):
                decimal = ","
            else:
                decimal = "."
        self._delim = delim
        self._decimal = decimal
        self._nf = nf
        self._d0 = d0
        # header rows above the data
        above = [(i, ln) for i, ln in enumerate(head[:d0]) if ln.strip()]

        def same(ln):
            return len(split_fields(ln, delim)) == nf

        name_f: Optional[List[str]] = None
        unit_f: Optional[List[str]] = None
        name_idx = unit_idx = None
        if above and same(above[-1][1]) and not _numericish(split_fields(above[-1][1], delim), decimal):
            l1 = above[-1]
            if (
                len(above) >= 2
                and same(above[-2][1])
                and not _numericish(split_fields(above[-2][1], delim), decimal)
                and all(len(x.strip()) <= 16 for x in split_fields(l1[1], delim))
                and any(x.strip() for x in split_fields(l1[1], delim))
            ):
                name_idx, unit_idx = above[-2][0], l1[0]
            else:
                name_idx = l1[0]
        if name_idx is not None:
            name_f = [_clean(x) for x in split_fields(head[name_idx], delim)]
        if unit_idx is not None:
            unit_f = [_clean(x) for x in split_fields(head[unit_idx], delim)]
        self._name_idx = name_idx
        self._unit_idx = unit_idx
        self._header_lines = [ln for i, ln in enumerate(head[:d0]) if i not in (name_idx, unit_idx)]
        # columns
        use: List[int] = []
        names: List[str] = []
        raw_units: List[Optional[str]] = []
        text_cols: List[str] = []
        for j in range(nf):
            nm = name_f[j] if name_f is not None else ""
            vals = [row[j].strip() for row in sample]
            nonempty = [v for v in vals if v]
            if not nonempty and not nm:
                continue  # empty column (leading/trailing delimiter)
            if 2 * sum(1 for v in nonempty if not is_number(v, decimal)) > len(nonempty):
                text_cols.append(nm or f"col{j}")
                continue
            use.append(j)
            names.append(nm or f"col{j}")
            u = unit_f[j] if unit_f is not None else None
            if not u and nm:
                u = _unit_from_name(nm)
            raw_units.append(u or None)
        if not use:
            raise RecordingError(f"{path}: no numeric column found")
        self._file_names = list(names)
        self._columns = [j + 1 for j in use]
        names = _dedupe(names)
        self._usecols = use
        self._names = names
        self._raw_units = dict(zip(names, raw_units))
        self._text_cols = text_cols
        # time column
        self._time_idx: Optional[int] = None
        self._time_name: Optional[str] = None
        if time_column is not None:
            hits = [k for k, n in enumerate(names) if n == time_column] or [
                k for k, n in enumerate(names) if n.lower() == time_column.lower()
            ]
            if not hits:
                avail = ", ".join(repr(n) for n in names)
                raise RecordingError(f"{path}: no time column {time_column!r}; available channels: {avail}")
            k = hits[0]
        else:
            k = None
            bases = [n.lower() for n in names]
            stripped = []
            for n in names:
                m = _BRACKET_UNIT.match(n)
                stripped.append((m.group(1) if m else n).strip().lower())
            for cand in _TIME_NAMES:
                for kk, (b, s) in enumerate(zip(bases, stripped)):
                    if b == cand or s == cand:
                        k = kk
                        break
                if k is not None:
                    break
        if k is not None:
            self._time_idx = use[k]
            self._time_name = names[k]

    # ------------------------------------------------------------------ scan
    def _is_data(self, fields: List[str]) -> bool:
        nf = self._nf
        if len(fields) != nf and not (len(fields) > nf and not "".join(fields[nf:]).strip()):
            return False
        probe = fields[self._usecols[0]].strip()
        return not probe or is_number(probe, self._decimal)

    def _scan(self, head_raw: List[bytes]) -> None:
        path = self.path
        delim, decimal = self._delim, self._decimal
        name_b = head_raw[self._name_idx].strip() if self._name_idx is not None else None
        unit_b = head_raw[self._unit_idx].strip() if self._unit_idx is not None else None
        comment = self._comment
        time_idx = self._time_idx
        blocks: List[_Block] = []
        between: List[str] = list(self._header_lines)
        footer: List[str] = []
        state = "await"
        offset = 0
        lineno = 0
        ntimes = 0
        # A row cut short (see _broken) is an error unless it is the file's last row: the
        # error is raised when another row follows it.
        broken: Optional[Tuple[int, int, bool]] = None  # (line number, fields, line end)
        last: Optional[Tuple[int, bytes, bool]] = None  # last data row: (line number, raw, time kept)
        with open(path, "rb") as fh:
            for raw in fh:
                line_off = offset
                offset += len(raw)
                lineno += 1
                if lineno <= self._d0:
                    continue
                s = raw.strip()
                if not s or (comment is not None and s.startswith(comment.encode())):
                    continue
                if broken is not None:
                    raise RecordingError(
                        f"{path}: line {broken[0]} has {broken[1]} fields, expected {self._nf} "
                        "(truncated or corrupt file)"
                    )
                text = raw.decode("latin-1").rstrip("\r\n")
                fields = split_fields(text, delim)
                if state == "data":
                    if self._is_data(fields):
                        blk = blocks[-1]
                        blk.n += 1
                        kept = time_idx is not None and ntimes < _TIME_VALUES
                        if time_idx is not None and kept:
                            _append_time(blk.times, fields[time_idx], decimal)
                            ntimes += 1
                        last = (lineno, raw, kept)
                        continue
                    state = "between"
                    between = []
                    if self._broken(fields, raw):
                        broken = (lineno, len(fields), raw.endswith((b"\n", b"\r")))
                    else:
                        between.append(decode_header(raw, self._encoding).rstrip("\r\n"))
                    continue
                if state == "between":
                    if name_b is not None and s == name_b:
                        state = "units" if unit_b is not None else "await"
                        continue
                    if self._is_data(fields):
                        raise RecordingError(
                            f"{path}: line {lineno}: data row after non-data lines without a new "
                            "column row (corrupt file?)"
                        )
                    if self._broken(fields, raw):
                        broken = (lineno, len(fields), raw.endswith((b"\n", b"\r")))
                    else:
                        between.append(decode_header(raw, self._encoding).rstrip("\r\n"))
                    continue
                if state == "units":
                    state = "await"
                    if not self._is_data(fields):
                        if s != unit_b:
                            self.warnings.append(f"line {lineno}: units row differs from the first block's")
                        continue
                # await: the next data row starts a block
                if self._is_data(fields):
                    blk = _Block(line_off, lineno, between)
                    blk.n = 1
                    kept = time_idx is not None and ntimes < _TIME_VALUES
                    if time_idx is not None and kept:
                        _append_time(blk.times, fields[time_idx], decimal)
                        ntimes += 1
                    last = (lineno, raw, kept)
                    blocks.append(blk)
                    between = []
                    state = "data"
                    continue
                state = "between"
                if self._broken(fields, raw):
                    broken = (lineno, len(fields), raw.endswith((b"\n", b"\r")))
                else:
                    between.append(decode_header(raw, self._encoding).rstrip("\r\n"))
        if state == "between" or state == "units" or state == "await":
            footer = between
        # The last row must be whole: newline-terminated (a line end is the last thing written) and
        # with every field. A vendor export always is, so it is refused; in other files the row is
        # dropped with a warning (it may be the row being written when the file was copied).
        strict = self._vendor is not None
        if broken is not None:
            defects = row_defects(broken[1], self._nf, broken[2])
            if strict:
                raise incomplete_row_error(path, broken[0], defects)
            self.warnings.append(dropped_row_warning(broken[0], defects))
        elif last is not None and not last[1].endswith((b"\n", b"\r")):
            defects = row_defects(self._nf, self._nf, False)
            if strict:
                raise incomplete_row_error(path, last[0], defects)
            self.warnings.append(dropped_row_warning(last[0], defects))
            blk = blocks[-1]
            blk.n -= 1
            if last[2]:
                blk.times.pop()
            if blk.n == 0:
                blocks.pop()
                footer = blk.info
        if not blocks:
            raise RecordingError(f"{path}: no data rows")
        self._blocks = blocks
        pos = 0
        ranges = []
        for b in blocks:
            ranges.append((pos, pos + b.n))
            pos += b.n
        self._n = pos
        self._segments = ranges
        self._footer = footer
        # sampling rate from the time column
        if self._time_name is not None:
            tu = normalize_unit(self._raw_units.get(self._time_name))
            factor = TIME_TO_S.get(tu.lower(), 1.0) if tu else 1.0
            f = fs_from_times([np.asarray(b.times) for b in blocks], factor)
            if f is not None:
                self._file_fs = f
                self._fs_source = f"median step of time column {self._time_name!r}"
                steps = np.concatenate([np.diff(np.asarray(b.times)) for b in blocks]) * factor
                steps = steps[np.isfinite(steps)]
                if steps.size:
                    off = np.abs(steps * f - 1.0) > 0.01
                    if off.mean() > 0.05:
                        self.warnings.append(
                            f"irregular sampling: {100 * off.mean():.0f} % of the steps of "
                            f"{self._time_name!r} differ from 1/fs by more than 1 %"
                        )
        self.metadata = {
            "header": _key_values(self._header_lines, delim),
            "delimiter": delim if delim is not None else "whitespace",
            "decimal": decimal,
            "blocks": [{"first_line": b.lineno, "rows": b.n, "info": _key_values(b.info, delim)} for b in blocks],
        }
        if self._text_cols:
            self.metadata["text_columns"] = list(self._text_cols)
        if footer:
            self.metadata["footer"] = footer[:20]

    def _broken(self, fields: List[str], raw: bytes) -> bool:
        """True for a row cut short: too few fields and either the file's unterminated last
        line or all numbers (a text line is a footer)."""
        if len(fields) >= self._nf:
            return False
        nonempty = [f for f in fields if f.strip()]
        if not nonempty:
            return False
        unterminated = not raw.endswith((b"\n", b"\r"))
        all_numbers = len(nonempty) >= 2 and all(is_number(f, self._decimal) for f in nonempty)
        return (unterminated and _numericish(fields, self._decimal)) or all_numbers

    # --------------------------------------------------------------- vendors
    def _vendor_fixups(self) -> None:
        names = self._names
        if self._vendor == "cetr":
            for n in names:
                u = normalize_unit(self._raw_units.get(n))
                if u == "g":
                    self._auto[n] = (
                        GRAM_FORCE,
                        "N",
                        "CETR 'g' is gram-force: converted to N (x9.80665e-3)",
                    )
            self._default_roles = {r: c for r, c in _CETR_ROLES.items() if c in names}
            # rows against each step's "Data Count"
            for k, b in enumerate(self._blocks, 1):
                counts = [int(m.group(1)) for m in (_DATA_COUNT.search(ln) for ln in b.info) if m]
                if not counts:
                    continue
                if b.n < counts[-1]:
                    raise RecordingError(
                        f"{self.path}: step {k} holds {b.n} rows but announces Data Count "
                        f"{counts[-1]} (truncated file?)"
                    )
                if b.n > counts[-1]:
                    self.warnings.append(f"step {k} holds {b.n} rows, its Data Count says {counts[-1]}")
        elif self._vendor == "compend":
            for n in names:
                if n in _COMPEND_UNITS and self._raw_units.get(n) is None:
                    u = _COMPEND_UNITS[n]
                    self._auto[n] = (1.0, u, f"unit not in the file; COMPEND exports {n!r} in {u}")
            self._default_roles = {r: c for r, c in _COMPEND_ROLES.items() if c in names}
            if not any(ln.startswith("Test completed") for ln in self._footer):
                self.warnings.append("no 'Test completed' line at the end: test aborted or file truncated?")
        else:
            self._default_roles = default_roles(self._file_names, names)

    # ---------------------------------------------------------------- reading
    def _iter_blocks(self, names: Sequence[str], block: int) -> Iterator[Dict[str, np.ndarray]]:
        st = os.stat(self.path)
        if (st.st_size, st.st_mtime_ns) != (self._stat.st_size, self._stat.st_mtime_ns):
            raise RecordingError(f"{self.path}: file changed since it was opened")
        pos = {n: k for k, n in enumerate(self._names)}
        usecols = [self._usecols[pos[n]] for n in names]
        comment = self._comment.encode() if self._comment else None
        with open(self.path, "rb") as fh:
            for b in self._blocks:
                for lines, nos in iter_data_lines(fh, b.offset, b.lineno, b.n, block, self.path, comment):
                    a = parse_rows(lines, nos, self._delim, self._decimal, usecols, list(names), self.path)
                    yield {nm: a[:, c] for c, nm in enumerate(names)}


def _append_time(times: "array[float]", s: str, decimal: str) -> None:
    try:
        times.append(to_float(s, decimal))
    except ValueError:
        times.append(float("nan"))


def _guess_encoding(head_raw: List[bytes]) -> str:
    try:
        b"".join(head_raw).decode("utf-8")
        return "utf-8"
    except UnicodeDecodeError:
        return "cp1252"
