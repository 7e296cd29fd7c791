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
    ``x_value``, ``Zeit``, ``Temps``, ``Tiempo``... with or without a unit:
    ``Zeit [s]``, ``Time (s)``, ``Zeit/ms``; or ``time_column=``) gives
    fs = 1 / median step, else a rate stated in the header (see
    :func:`tribodyn.io._text.header_rate`; a line may hold several
    ``key: value`` pairs separated by tabs).
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

Reading is two native passes (docs/method.md 9, "Text files"): a scan at
open follows the runs of data rows (counting rows, recording byte offsets of
the blocks and a checkpoint about every megabyte, keeping at most 200 000
time values; the lines around the runs are read line by line as before);
any range of samples is then parsed from the checkpoint before it, in
parallel pieces, so the file is random access and memory stays flat. A
separator of more than one character is read by the Python parser.
"""

from __future__ import annotations

import os
import re
from array import array
from typing import IO, Any, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from ._text import (
    TEXT_BLOCK_ROWS,
    Checkpoints,
    TextRecording,
    check_encoding,
    decode_header,
    default_roles,
    dropped_row_warning,
    duplicate_warnings,
    header_rate,
    incomplete_row_error,
    is_number,
    is_wide,
    iter_data_lines,
    native_dialect,
    native_scan,
    norm_words,
    parse_rows,
    row_defects,
    sniff_encoding,
    split_fields,
    to_float,
    unit_likeness,
)
from .base import RecordingError, fs_from_times
from .units import GRAM_FORCE, TIME_TO_S, is_known_unit, normalize_unit

__all__ = ["DelimitedRecording", "sniff_vendor"]

_HEAD_LINES = 400
_HEAD_BYTES = 1 << 20
_TIME_VALUES = 200_000  # time values kept in total to estimate fs
#: Largest irregularity of a time column read as uniform sampling: the 95th percentile of
#: |step / median step - 1| over the steps (restarts and gaps excluded). Above it the file is refused
#: unless ``resample=`` (linear interpolation) or ``fs=`` (taken as uniform) is given.
MAX_JITTER = 0.2
#: A time step longer than this many median steps is a gap: the recording is split there.
GAP_FACTOR = 5.0
_DELIMITERS: Tuple[Optional[str], ...] = ("\t", ";", ",", "|", None)
#: Names of a time column, in order of preference, compared after ``norm_words`` (case, accents, ``_-.``)
#: and without a unit (``Zeit [s]``, ``Time (s)``, ``Zeit/s``, ``Zeit in ms``, ``time_ms``).
_TIME_NAMES = (
    "time",
    "t",
    "test time",
    "time s",
    "elapsed time",
    "relative time",
    "timestamp",
    "x value",
    "zeit",
    "messzeit",
    "versuchszeit",
    "prufzeit",
    "laufzeit",
    "relative zeit",
    "rel zeit",
    "temps",
    "temps ecoule",
    "tiempo",
    "tiempo transcurrido",
    "tempo",
    "tijd",
    "tid",
    "czas",
    "aika",
    "время",
    "時間",
    "経過時間",
    "时间",
    "시간",
    "seconds",
    "sec",
    "s",
)
_TIME_UNIT_SUFFIX = re.compile(
    r"^(.*?\S)\s*(?:/|,|\bin\b|_|\s)\s*(" + "|".join(sorted(TIME_TO_S, key=len, reverse=True)) + r")\s*$",
    re.IGNORECASE,
)


def _time_name(name: str) -> Optional[Tuple[str, Optional[str]]]:
    """(the time name, the unit written in the name) when a column name names time, else None.

    ``'Zeit [s]'`` -> ``('zeit', 's')``, ``'Time/ms'`` -> ``('time', 'ms')``, ``'Temps'`` -> ``('temps', None)``.
    """
    n = name.strip()
    unit: Optional[str] = None
    m = _BRACKET_UNIT.match(n)
    if m:
        n, unit = m.group(1), (m.group(3) if m.group(3) is not None else m.group(4)).strip() or None
    w = norm_words(n)
    if w in _TIME_NAMES:
        return w, unit
    m2 = _TIME_UNIT_SUFFIX.match(n.strip())
    if m2 and unit is None:
        w = norm_words(m2.group(1))
        if w in _TIME_NAMES:
            return w, m2.group(2)
    return None


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


def _runs(lines: Sequence[str], delim: Optional[str], decimal: Optional[str]) -> List[Tuple[int, int, int]]:
    """Every run of >= 2 consecutive mostly-numeric rows of one field count: (first index, fields, rows)."""
    out: List[Tuple[int, int, int]] = []
    i, n = 0, len(lines)
    while i < n:
        ln = lines[i]
        if not ln.strip() or ln.lstrip().startswith("#"):
            i += 1
            continue
        f = split_fields(ln, delim)
        if not _numericish(f, decimal):
            i += 1
            continue
        nf = len(f)
        count = 1
        j = i + 1
        while j < n:
            ln2 = lines[j]
            if not ln2.strip():
                j += 1
                continue
            f2 = split_fields(ln2, delim)
            if len(f2) == nf and _numericish(f2, decimal):
                count += 1
                j += 1
            else:
                break
        if count >= 2 or j >= n:  # one numeric line among text lines is no table (unless the file ends)
            out.append((i, nf, count))
        i = max(j, i + 1)
    return out


def _find_data_start(
    lines: Sequence[str], delim: Optional[str], decimal: Optional[str]
) -> Optional[Tuple[int, int, int]]:
    """(index of the first data line, field count, rows of its run) of the data table, or None.

    The data table is the longest run of rows with one numeric layout (a ``key,value`` preamble or a
    short second table is not it); when the same layout starts earlier under the same column row (a
    multi-block export), the table starts at that first block.
    """
    runs = _runs(lines, delim, decimal)
    if not runs:
        return None
    best = max(runs, key=lambda r: (r[2], r[1], -r[0]))
    same = [r for r in runs if r[1] == best[1] and r[0] < best[0]]
    if same:
        above = _line_above(lines, best[0])
        for r in same:
            if above is not None and _line_above(lines, r[0]) == above:
                return r
    return best


def _line_above(lines: Sequence[str], i: int) -> Optional[str]:
    """The nearest non-empty line above line ``i`` (None at the top)."""
    for k in range(i - 1, -1, -1):
        if lines[k].strip():
            return lines[k].strip()
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


_KV = re.compile(r"^([^=:]{1,60}?)\s*[=:]\s*(.*)$")


def _tab_pairs(s: str) -> Optional[List[Tuple[str, str]]]:
    """The ``key: value`` / ``key=value`` / ``key<tab>value`` pairs of a line holding several of them
    separated by tabs (``Operator: A<tab>Sampling rate: 100``, ``Operator<tab>A<tab>Rate<tab>100``); None
    when the line is not such a line (one pair, or a row of a table such as ``Channel name<tab>Fy<tab><tab>Fz``).
    """
    fields = [f.strip() for f in s.split("\t")]
    while fields and not fields[-1]:
        fields.pop()
    segs = [f for f in fields if f]
    if len(segs) < 2:
        return None
    kv = [_KV.match(f) for f in segs]
    if any(m is not None and "\\" not in m.group(1) for m in kv):
        out: List[Tuple[str, str]] = []
        i = 0
        while i < len(segs):
            m = kv[i]
            if m is not None and "\\" not in m.group(1):
                if m.group(2).strip():
                    out.append((m.group(1).strip(), m.group(2).strip()))
                elif i + 1 < len(segs) and kv[i + 1] is None:  # "Key:<tab>value"
                    out.append((m.group(1).strip(), segs[i + 1]))
                    i += 1
            i += 1
        return out
    # key<tab>value<tab>key<tab>value: an even number of fields, none empty, keys that are not numbers
    if len(segs) >= 4 and len(segs) == len(fields) and len(segs) % 2 == 0:
        keys, vals = segs[0::2], segs[1::2]
        if not any(is_number(k) or is_number(k, ",") for k in keys) and any(is_number(v.split()[0]) for v in vals):
            return list(zip(keys, vals))
    return None


def _key_values(lines: Sequence[str], delim: Optional[str]) -> Dict[str, str]:
    """``key = value`` / ``key: value`` / ``key<delim>value`` header lines as a dict; a line holding several
    pairs separated by tabs gives each of them (see :func:`_tab_pairs`)."""
    out: Dict[str, str] = {}
    for ln in lines:
        s = ln.strip()
        if not s:
            continue
        pairs = _tab_pairs(s) if "\t" in s else None
        if pairs is not None:
            for k, v in pairs:
                out.setdefault(k, v)
            continue
        m = _KV.match(s)
        if m and "\\" not in m.group(1):
            out.setdefault(m.group(1).strip(), m.group(2).strip())
            continue
        if delim is not None and delim in s:
            parts = [p.strip() for p in s.split(delim)]
            vals = [p for p in parts[1:] if p]
            if parts[0] and vals:
                out.setdefault(parts[0], " ".join(vals))
    return out


class _ScanState:
    """The row-by-row state of :meth:`DelimitedRecording._scan`."""

    def __init__(self, between: List[str]) -> None:
        self.blocks: List[_Block] = []
        self.between = between  # lines since the last block (its info when a block starts)
        self.state = "await"  # "await" a block, in "data", "between" blocks, a repeated "units" row next
        self.offset = 0  # byte offset of the next line
        self.lineno = 0  # line number of the last line read
        self.ntimes = 0  # time values kept
        self.total = 0  # data rows so far (the next row's sample)
        # time restarts and gaps: (line, why, first sample)
        self.breaks: List[Tuple[int, str, int]] = []
        self.t_prev = float("nan")
        self.t_now = float("nan")
        # A row cut short (see _broken) is an error unless it is the file's last row: the
        # error is raised when another row follows it.
        self.broken: Optional[Tuple[int, int, bool]] = None  # (line number, fields, line end)
        self.last: Optional[Tuple[int, bytes, bool]] = None  # last data row: (line number, raw, time kept)


def _sample_rows(lines: Sequence[str], delim: Optional[str], nf: int) -> List[List[str]]:
    """Up to 400 data rows from the data start: the fields of rows with ``nf`` fields until one has not."""
    sample: List[List[str]] = []
    for ln in lines:
        if not ln.strip() or ln.lstrip().startswith("#"):
            continue
        f = split_fields(ln, delim)
        if len(f) != nf:
            break
        sample.append(f)
        if len(sample) >= 400:
            break
    return sample


class DelimitedRecording(TextRecording):
    """A delimited text file (generic, CETR or COMPEND); see the module docstring."""

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
        resample: Optional[float] = None,
    ) -> None:
        super().__init__(path)
        self._block_rows = TEXT_BLOCK_ROWS
        if time_column is None:
            time_column = time_channel
        if encoding:
            check_encoding(encoding)
        self._resample = None if resample is None else _check_resample(resample)
        self._fs_given = fs is not None
        self._mem: Optional[Dict[str, np.ndarray]] = None
        self._data_path = self.path
        self._tmp: Optional[str] = None
        enc = encoding or self._detect_encoding()
        if is_wide(enc):
            self._transcode(enc)  # UTF-16/32: read from a UTF-8 copy (byte offsets of ASCII rows)
            enc = "utf-8"
        self._source_encoding = encoding or self._sniffed
        head_raw = self._read_head()
        if any(_has_bare_cr(r) for r in head_raw):  # a CR without LF ends a line (old Mac line ends, as pandas
            self._split_bare_crs()  # reads them): read from a copy with LFs there
            head_raw = self._read_head()
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
        try:
            self._analyse_head(head, delimiter, decimal, time_column)
            n_warnings = len(self.warnings)
            try:
                self._scan(head_raw)
            except _BareCR:  # past the head: the lines the native scan leaves to Python are looked at
                del self.warnings[n_warnings:]
                self._split_bare_crs()
                self._scan(head_raw)
            self._vendor_fixups()
            if self._resample is not None:
                self._load_resampled(self._resample)
            self._setup(channels, fs, scale, units)
        except BaseException:
            self._close()
            raise
        #: Sample ranges that are separate acquisitions (no analysis window straddles two): every
        #: segment of a text file is one (a CETR step, a block under a repeated column row, a time
        #: restart or gap).
        self.acquisitions: List[Tuple[int, int]] = list(self._segments)
        if self._source_encoding not in ("utf-8", "utf-8-sig", "ascii"):
            self.metadata["encoding"] = self._source_encoding
        if self._vendor is None:  # the vendors' duplicates (COMPEND's 'Friction Force') are by design
            self.warnings += duplicate_warnings(self._file_names, self._names, self._columns, self.roles)

    # ------------------------------------------------------------------ head
    def _detect_encoding(self) -> str:
        """:func:`~tribodyn.io._text.sniff_encoding` of the first 64 KiB (UTF-8 when it finds none)."""
        with open(self.path, "rb") as fh:
            probe = fh.read(1 << 16)
        if not probe:
            raise RecordingError(f"{self.path}: empty file")
        enc = sniff_encoding(probe)
        if enc is None:
            raise RecordingError(
                f"{self.path}: binary content, not a delimited text file (no text encoding detected; "
                "pass encoding= if it is text)"
            )
        self._sniffed = enc
        return enc

    def _transcode(self, enc: str) -> None:
        """Writes the file as UTF-8 into a private temporary file, read instead of the original."""
        import codecs
        import tempfile

        fd, tmp = tempfile.mkstemp(prefix="tribodyn-", suffix=".txt")
        self._tmp = tmp
        try:
            with open(self.path, "rb") as src, os.fdopen(fd, "wb") as dst:
                dec = codecs.getincrementaldecoder(enc)(errors="strict")
                while True:
                    block = src.read(1 << 20)
                    text = dec.decode(block, final=not block)
                    if text:
                        dst.write(text.lstrip("\ufeff").encode("utf-8") if dst.tell() == 0 else text.encode("utf-8"))
                    if not block:
                        break
        except UnicodeDecodeError as exc:
            self._close()
            raise RecordingError(f"{self.path}: not valid {enc} text ({exc.reason} at byte {exc.start})") from None
        self._data_path = tmp

    def _split_bare_crs(self) -> None:
        """Copies the data into a private temporary file with every bare CR made an LF; reads that instead.

        Only a file with a bare CR in a line the native scan does not take (its head, or a line it stops
        at: a CR inside a row makes it a row of the wrong width or a field that is no number) is copied,
        so a file without one costs nothing more."""
        import tempfile

        fd, tmp = tempfile.mkstemp(prefix="tribodyn-", suffix=".txt")
        bare = 0
        try:
            with open(self._data_path, "rb") as src, os.fdopen(fd, "wb") as dst:
                carry = b""
                while True:
                    block = src.read(_CR_BLOCK)
                    data = carry + block
                    carry = data[-1:] if block and data.endswith(b"\r") else b""
                    if carry:
                        data = data[:-1]
                    out, k = _BARE_CR.subn(b"\n", data)
                    dst.write(out)
                    bare += k
                    if not block:
                        break
        except OSError as exc:
            os.unlink(tmp)
            raise RecordingError(f"{self.path}: cannot copy to split its bare CRs: {exc}") from None
        self._close()  # a UTF-8 copy of a UTF-16 file, if any, is replaced
        self._tmp = self._data_path = tmp
        self.warnings.append(
            f"{bare} bare carriage return(s) (CR without LF) read as line ends; line numbers count them"
        )

    def _close(self) -> None:
        if self._tmp is not None:
            try:
                os.unlink(self._tmp)
            except OSError:
                pass
            self._tmp = None

    def _read_head(self) -> List[bytes]:
        out: List[bytes] = []
        total = 0
        with open(self._data_path, "rb") as fh:
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
        """Reads the table's layout from the head: dialect, header rows, columns, time column, rate."""
        delim, found = self._find_table(head, delimiter, decimal)
        d0, nf, _ = found
        sample = _sample_rows(head[d0:], delim, nf)
        if decimal is None:
            if delim != "," and any("," in x for row in sample for x in row if is_number(x, ",")):
                decimal = ","
            else:
                decimal = "."
        self._delim = delim
        self._decimal = decimal
        self._nf = nf
        self._d0 = d0
        name_f, unit_f = self._header_rows(head)
        name_f, time_column = self._column_pairs(head, sample, name_f, time_column)
        self._choose_columns(sample, name_f, unit_f)
        self._find_time_column(sample, time_column, named=name_f is not None)
        self._header_rate = header_rate(_key_values(self._header_lines, delim))
        self._ref_step: Optional[float] = None
        if self._time_idx is not None:
            t = np.array([_num(r[self._time_idx], decimal) for r in sample if self._time_idx < len(r)])
            d = np.diff(t[np.isfinite(t)])
            d = d[d > 0]
            if d.size:
                self._ref_step = float(np.median(d))

    def _find_table(
        self, head: List[str], delimiter: Optional[str], decimal: Optional[str]
    ) -> Tuple[Optional[str], Tuple[int, int, int]]:
        """The delimiter (given, else the best candidate) and the head's data start (line, fields, rows)."""
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
        return delim, found

    def _header_rows(self, head: List[str]) -> Tuple[Optional[List[str]], Optional[List[str]]]:
        """The fields of the names row and of the units row above the data, if any (sets the header lines)."""
        delim, decimal, nf, d0 = self._delim, self._decimal, self._nf, self._d0
        above = [(i, ln) for i, ln in enumerate(head[:d0]) if ln.strip()]

        def same(ln: str) -> bool:
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
                and (
                    all(len(x.strip()) <= 16 for x in split_fields(l1[1], delim))
                    or unit_likeness(split_fields(above[-2][1], delim)) >= 0.5
                )
                and any(x.strip() for x in split_fields(l1[1], delim))
            ):
                name_idx, unit_idx = above[-2][0], l1[0]
                # names and units rows in either order: the units row is the one that reads as units
                if unit_likeness(split_fields(above[-2][1], delim)) > unit_likeness(split_fields(l1[1], delim)):
                    name_idx, unit_idx = unit_idx, name_idx
            else:
                name_idx = l1[0]
        if name_idx is not None:
            name_f = [_clean(x) for x in split_fields(head[name_idx], delim)]
        if unit_idx is not None:
            unit_f = [_clean(x) for x in split_fields(head[unit_idx], delim)]
        self._name_idx = name_idx
        self._unit_idx = unit_idx
        self._header_lines = [ln for i, ln in enumerate(head[:d0]) if i not in (name_idx, unit_idx)]
        return name_f, unit_f

    def _column_pairs(
        self, head: List[str], sample: List[List[str]], name_f: Optional[List[str]], time_column: Optional[str]
    ) -> Tuple[Optional[List[str]], Optional[str]]:
        """NI-style (time, value) column pairs sharing one time base: the names and time column read so."""
        nf = self._nf
        self._pair_times: List[int] = []
        paired = _paired_columns(sample, nf, self._decimal)
        if paired and name_f is not None:
            evens = {_clean(name_f[j]) for j in range(0, nf, 2)}
            if not (len(evens) == 1 or all(not e or e.lower() == "channel name" or _time_name(e) for e in evens)):
                paired = None  # named columns that merely increase (a position...), not pairs
        elif paired and not paired[1]:
            paired = None
        if not paired:
            return name_f, time_column
        if not paired[1]:
            raise RecordingError(
                f"{self.path}: (time, value) column pairs with different time bases: channels of different rates "
                "cannot be read as one recording; export them separately or map the channels of one rate"
            )
        chan = _channel_name_row(head[: self._d0], self._delim)
        pn: List[str] = list(name_f) if name_f is not None else [""] * nf
        for j in range(1, nf, 2):
            nm = pn[j] if j < len(pn) else ""
            if (not nm or nm.lower() in _GENERIC_VALUE_NAMES) and chan and (j // 2) < len(chan):
                pn[j] = chan[j // 2]
        for j in range(0, nf, 2):
            pn[j] = "Time" if j == 0 else ""
        self._pair_times = list(range(2, nf, 2))
        if time_column is None:
            time_column = "Time"
        self.warnings.append(
            f"read as {nf // 2} (time, value) column pairs with one time base (an NI-style export): "
            f"channels {', '.join(repr(pn[j]) for j in range(1, nf, 2))}"
        )
        return pn, time_column

    def _choose_columns(
        self, sample: List[List[str]], name_f: Optional[List[str]], unit_f: Optional[List[str]]
    ) -> None:
        """The numeric columns read, their (deduplicated) names and units; text columns set aside."""
        decimal = self._decimal
        use: List[int] = []
        names: List[str] = []
        raw_units: List[Optional[str]] = []
        text_cols: List[str] = []
        for j in range(self._nf):
            if j in self._pair_times:
                continue
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
            raise RecordingError(f"{self.path}: no numeric column found")
        self._file_names = list(names)
        self._columns = [j + 1 for j in use]
        names = _dedupe(names)
        self._usecols = use
        self._names = names
        self._raw_units = dict(zip(names, raw_units))
        self._text_cols = text_cols

    def _find_time_column(self, sample: List[List[str]], time_column: Optional[str], *, named: bool) -> None:
        """The time column: the one named, else one with a time name, else (no names) one that steps steadily."""
        names, use = self._names, self._usecols
        self._time_idx: Optional[int] = None
        self._time_name: Optional[str] = None
        if time_column is not None:
            hits = [k for k, n in enumerate(names) if n == time_column] or [
                k for k, n in enumerate(names) if n.lower() == time_column.lower()
            ]
            if not hits:
                avail = ", ".join(repr(n) for n in names)
                raise RecordingError(f"{self.path}: no time column {time_column!r}; available channels: {avail}")
            k: Optional[int] = hits[0]
        else:
            k = None
            timed = [_time_name(n) for n in names]
            for cand in _TIME_NAMES:
                for kk, tn in enumerate(timed):
                    if tn is not None and tn[0] == cand:
                        k = kk
                        break
                if k is not None:
                    break
            if k is not None:
                tn = timed[k]
                if tn is not None and tn[1] and not self._raw_units.get(names[k]):
                    self._raw_units[names[k]] = tn[1]  # 'Zeit/ms': the unit written in the name
        self._time_guessed = False
        if k is None and not named and self._vendor is None:
            k = _guess_time_column(sample, use, self._decimal)
            self._time_guessed = k is not None
        if k is not None:
            self._time_idx = use[k]
            self._time_name = names[k]
            if self._time_guessed:
                self.warnings.append(
                    f"no column names: column {names[k]!r} taken as time (it increases steadily); "
                    "pass time_column= (--time-column) to choose another"
                )

    # ------------------------------------------------------------------ scan
    def _is_data(self, fields: List[str]) -> bool:
        nf = self._nf
        if len(fields) != nf and not (len(fields) > nf and not "".join(fields[nf:]).strip()):
            return False
        probe = fields[self._usecols[0]].strip()
        return not probe or is_number(probe, self._decimal)

    def _scan(self, head_raw: List[bytes]) -> None:
        """Reads the file once: its blocks of data rows, time breaks, footer, sampling rate and metadata."""
        self._native = native_dialect(self._delim, self._decimal, self._comment) if self._use_native else None
        self._cps: List[Tuple[int, int, int]] = []
        self._marks: List[Tuple[int, int, int]] = []
        st = self._scan_rows(head_raw)
        footer = self._check_last_row(st)
        if not st.blocks:
            raise RecordingError(f"{self.path}: no data rows")
        self._index_blocks(st.blocks)
        self._footer = footer
        # sampling rate: the time column, else a rate written in the header
        for line, why, first in st.breaks:
            self.warnings.append(f"time {why} at line {line} (sample {first}): a new segment starts there")
        self._breaks = [{"line": line, "why": why, "sample": first} for line, why, first in st.breaks]
        self._find_rate(st.blocks)
        delim = self._delim
        self.metadata = {
            "header": _key_values(self._header_lines, delim),
            "delimiter": delim if delim is not None else "whitespace",
            "decimal": self._decimal,
            "blocks": [{"first_line": b.lineno, "rows": b.n, "info": _key_values(b.info, delim)} for b in st.blocks],
        }
        if self._text_cols:
            self.metadata["text_columns"] = list(self._text_cols)
        if footer:
            self.metadata["footer"] = footer[:20]

    def _scan_rows(self, head_raw: List[bytes]) -> _ScanState:
        """Goes through the file's lines after the head, row by row (plain runs natively)."""
        name_b = head_raw[self._name_idx].strip() if self._name_idx is not None else None
        unit_b = head_raw[self._unit_idx].strip() if self._unit_idx is not None else None
        comment = self._comment
        st = _ScanState(list(self._header_lines))
        with open(self._data_path, "rb") as fh:
            while True:
                if self._native is not None and st.state == "data":
                    self._native_run(fh, st)
                raw = fh.readline()
                if not raw:
                    break
                line_off = st.offset
                st.offset += len(raw)
                st.lineno += 1
                if st.lineno <= self._d0:
                    continue
                s = raw.strip()
                if not s or (comment is not None and s.startswith(comment.encode())):
                    continue
                if st.broken is not None:
                    raise RecordingError(
                        f"{self.path}: line {st.broken[0]} has {st.broken[1]} fields, expected {self._nf} "
                        "(truncated or corrupt file)"
                    )
                if _has_bare_cr(raw):
                    raise _BareCR
                fields = split_fields(raw.decode("latin-1").rstrip("\r\n"), self._delim)
                self._scan_row(st, raw, fields, line_off=line_off, heads=(s, name_b, unit_b))
        return st

    def _native_run(self, fh: IO[bytes], st: _ScanState) -> None:
        """The plain rows that follow, natively (the same rules, see tribodyn._core.text_scan)."""
        assert self._native is not None
        time_idx = self._time_idx
        run = native_scan(
            fh.fileno(), st.offset, self._native, nf=self._nf, probe=self._usecols[0], time=time_idx,
            gap=GAP_FACTOR * self._ref_step if self._ref_step is not None else float("nan"),
            t_prev=st.t_prev, keep_times=max(0, _TIME_VALUES - st.ntimes) if time_idx is not None else 0,
        )  # fmt: skip
        if run["rows"]:
            st.total, st.ntimes, st.last = self._take_run(
                run, st.lineno + 1, st.blocks, st.breaks, total=st.total, ntimes=st.ntimes
            )
            st.t_prev = run["t_prev"]
        st.offset = run["end"]
        st.lineno += run["lines"]
        fh.seek(st.offset)

    def _scan_row(
        self,
        st: _ScanState,
        raw: bytes,
        fields: List[str],
        *,
        line_off: int,
        heads: Tuple[bytes, Optional[bytes], Optional[bytes]],
    ) -> None:
        """One non-blank row, by the scan's state: a data row, a line between blocks, a repeated head."""
        s, name_b, unit_b = heads
        if st.state == "data":
            if self._is_data(fields):
                self._data_row(st, raw, fields, line_off)
                return
            st.state = "between"
            st.between = []
            self._non_data_row(st, raw, fields)
            return
        if st.state == "between":
            if name_b is not None and s == name_b:
                st.state = "units" if unit_b is not None else "await"
                return
            if self._is_data(fields):
                raise RecordingError(
                    f"{self.path}: line {st.lineno}: data row after non-data lines without a new "
                    "column row (corrupt file?)"
                )
            self._non_data_row(st, raw, fields)
            return
        if st.state == "units":
            st.state = "await"
            if not self._is_data(fields):
                if s != unit_b:
                    self.warnings.append(f"line {st.lineno}: units row differs from the first block's")
                return
        # await: the next data row starts a block
        if self._is_data(fields):
            self._first_row(st, raw, fields, line_off)
            return
        st.state = "between"
        self._non_data_row(st, raw, fields)

    def _data_row(self, st: _ScanState, raw: bytes, fields: List[str], line_off: int) -> None:
        """A data row in a block; a time restart or gap starts a new block."""
        time_idx = self._time_idx
        if time_idx is not None:
            st.t_now = _num(fields[time_idx], self._decimal)
            why = self._time_break(st.t_prev, st.t_now)
            st.t_prev = st.t_now if st.t_now == st.t_now else st.t_prev
            if why:
                st.breaks.append((st.lineno, why, st.total))
                st.blocks.append(_Block(line_off, st.lineno, []))
        blk = st.blocks[-1]
        blk.n += 1
        st.total += 1
        kept = time_idx is not None and st.ntimes < _TIME_VALUES
        if time_idx is not None and kept:
            blk.times.append(st.t_now)
            st.ntimes += 1
        st.last = (st.lineno, raw, kept)

    def _first_row(self, st: _ScanState, raw: bytes, fields: List[str], line_off: int) -> None:
        """The first data row of a block, the lines read since the last block its info."""
        time_idx = self._time_idx
        blk = _Block(line_off, st.lineno, st.between)
        blk.n = 1
        st.total += 1
        kept = time_idx is not None and st.ntimes < _TIME_VALUES
        if time_idx is not None:
            st.t_prev = _num(fields[time_idx], self._decimal)
            if kept:
                blk.times.append(st.t_prev)
                st.ntimes += 1
        st.last = (st.lineno, raw, kept)
        st.blocks.append(blk)
        st.between = []
        st.state = "data"

    def _non_data_row(self, st: _ScanState, raw: bytes, fields: List[str]) -> None:
        """A line that is not data: a row cut short (kept as ``broken``) or a line between blocks."""
        if self._broken(fields, raw):
            st.broken = (st.lineno, len(fields), raw.endswith((b"\n", b"\r")))
        else:
            st.between.append(decode_header(raw, self._encoding).rstrip("\r\n"))

    def _check_last_row(self, st: _ScanState) -> List[str]:
        """Refuses or drops an incomplete last row; returns the footer (the lines after the last block)."""
        footer: List[str] = []
        if st.state == "between" or st.state == "units" or st.state == "await":
            footer = st.between
        # The last row must be whole: newline-terminated (a line end is the last thing written) and
        # with every field. A vendor export always is, so it is refused; in other files the row is
        # dropped with a warning (it may be the row being written when the file was copied).
        strict = self._vendor is not None
        broken, last, blocks = st.broken, st.last, st.blocks
        if broken is not None:
            defects = row_defects(broken[1], self._nf, broken[2])
            if strict:
                raise incomplete_row_error(self.path, broken[0], defects)
            self.warnings.append(dropped_row_warning(broken[0], defects))
        elif last is not None and not last[1].endswith((b"\n", b"\r")):
            defects = row_defects(self._nf, self._nf, False)
            if strict:
                raise incomplete_row_error(self.path, last[0], defects)
            self.warnings.append(dropped_row_warning(last[0], defects))
            blk = blocks[-1]
            blk.n -= 1
            if last[2]:
                blk.times.pop()
            if blk.n == 0:
                blocks.pop()
                footer = blk.info
        return footer

    def _index_blocks(self, blocks: List[_Block]) -> None:
        """The blocks as the recording's segments and checkpoints (random access when native)."""
        self._blocks = blocks
        pos = 0
        ranges = []
        for b in blocks:
            ranges.append((pos, pos + b.n))
            self._cps.append((pos, b.offset, b.lineno))
            pos += b.n
        if self._native is not None:  # read at any sample from here on
            self._checkpoints, self._parse_dialect = Checkpoints(self._cps, pos, self._marks), self._native
            self.random_access = True
        self._n = pos
        self._segments = ranges

    def _find_rate(self, blocks: List[_Block]) -> None:
        """The sampling rate: from the time column's median step, else a rate written in the header."""
        hr = self._header_rate
        if self._time_name is not None:
            tu = normalize_unit(self._raw_units.get(self._time_name))
            factor = TIME_TO_S.get(tu.lower(), 1.0) if tu else 1.0
            self._time_factor = factor
            f = fs_from_times([np.asarray(b.times) for b in blocks], factor)
            if f is not None:
                self._file_fs = f
                self._fs_source = f"median step of time column {self._time_name!r}"
                self._check_jitter(blocks, factor, f)
                if hr is not None and abs(hr.hz - f) > 0.01 * f:
                    self.warnings.append(
                        f"the header's {hr.key!r} gives {hr.hz:g} Hz but time column {self._time_name!r} "
                        f"steps at {f:g} Hz: the time column is used"
                    )
        if self._file_fs is None and hr is not None:
            self._file_fs = hr.hz
            self._fs_source = f"header {hr.key!r}"
            if hr.how == "unit" and not self._fs_given:
                self.warnings.append(
                    f"sampling rate {hr.hz:g} Hz taken from the header's {hr.key!r} (a value in Hz under a key "
                    "not known as a sampling rate): pass fs= (--fs) if it is another frequency"
                )

    def _take_run(
        self, run: Dict[str, Any], first_line: int, blocks: List[_Block], breaks: List[Tuple[int, str, int]],
        *, total: int, ntimes: int,
    ) -> Tuple[int, int, Tuple[int, bytes, bool]]:  # fmt: skip
        """Adds a native run of data rows (see :func:`~tribodyn.io._text.native_scan`) to the scan's blocks.

        A time restart or gap inside the run starts a new block, as it would
        row by row. Returns the rows so far, the time values kept so far and
        the run's last row as the scan's ``last``.
        """
        rows = int(run["rows"])
        times = run["times"]
        cuts = [0] + [int(b[0]) for b in run["breaks"]] + [rows]
        for k in range(len(cuts) - 1):
            if k:
                _row, line, off, prev, now = run["breaks"][k - 1]
                breaks.append((first_line + int(line), self._time_break(prev, now), total))
                blocks.append(_Block(int(off), first_line + int(line), []))
            r0, r1 = cuts[k], cuts[k + 1]
            blk = blocks[-1]
            blk.n += r1 - r0
            if r0 < len(times):
                blk.times.extend(times[r0 : min(r1, len(times))].tolist())
            total += r1 - r0
        base = total - rows
        for row, off, line in run["checkpoints"]:
            self._cps.append((base + int(row), int(off), first_line + int(line)))
        self._marks += [(base + row, off, first_line + line) for row, off, line in run["marks"]]
        last_line = int(run["last"][0])
        return total, ntimes + len(times), (first_line + last_line, b"\n", rows - 1 < len(times))

    def _time_break(self, prev: float, now: float) -> str:
        """'restarts' / 'jumps ...' when the time column goes back or leaps a gap between two rows, else ''."""
        if not (now == now and prev == prev):
            return ""
        if now < prev:
            return f"restarts ({prev:g} -> {now:g})"
        ref = self._ref_step
        if ref is not None and now - prev > GAP_FACTOR * ref:
            return f"jumps {now - prev:g} (a gap of more than {GAP_FACTOR:g} steps of {ref:g})"
        return ""

    def _check_jitter(self, blocks: Sequence[_Block], factor: float, fs: float) -> None:
        """Refuses irregular sampling above :data:`MAX_JITTER` (unless resample= or fs=), warns above 1 %."""
        steps = np.concatenate([np.diff(np.asarray(b.times)) for b in blocks]) * factor
        steps = steps[np.isfinite(steps)]
        if not steps.size:
            return
        rel = np.abs(steps * fs - 1.0)
        jitter = float(np.percentile(rel, 95))
        self._jitter = jitter
        if jitter > MAX_JITTER and self._resample is None:
            msg = (
                f"irregular sampling: the steps of time column {self._time_name!r} vary by {100 * jitter:.0f} % "
                f"(95th percentile of |step x fs - 1|, fs = {fs:g} Hz from the median step; at most "
                f"{100 * MAX_JITTER:.0f} % is read as uniform)"
            )
            if not self._fs_given:
                raise RecordingError(
                    f"{self.path}: {msg}: pass resample=HZ (--resample HZ) to interpolate every channel linearly "
                    "onto a uniform grid, or fs= to take the rows as uniform"
                )
            self.warnings.append(msg + "; the rows are taken as uniform at the fs given")
            return
        off = rel > 0.01
        if off.mean() > 0.05 and self._resample is None:
            self.warnings.append(
                f"irregular sampling: {100 * off.mean():.0f} % of the steps of {self._time_name!r} differ from "
                f"1/fs by more than 1 % (95th percentile {100 * jitter:.1f} %, read as uniform at {fs:g} Hz)"
            )

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
    def _load_resampled(self, hz: float) -> None:
        """Reads every column and interpolates it linearly onto a uniform grid at ``hz`` per segment."""
        if self._time_name is None:
            raise RecordingError(f"{self.path}: resample= needs a time column (pass time_column=)")
        names = list(self._names)
        parts: Dict[str, List[np.ndarray]] = {n: [] for n in names}
        segments: List[Tuple[int, int]] = []
        pos = 0
        factor = getattr(self, "_time_factor", 1.0)
        raw = {n: np.concatenate([b[n] for b in self._iter_blocks(names, 1 << 16)]) for n in names}
        from ._resample import check_resample_size  # the resampled size bounded before anything is allocated

        total = 0
        for a, b in self._segments:
            t = raw[self._time_name][a:b] * factor
            t = t[np.isfinite(t)]
            if t.size >= 2:
                total += check_resample_size(self.path, hz, float(t.max() - t.min()), len(names), self._n)
        check_resample_size(self.path, hz, (total - 1) / hz, len(names), self._n)
        for a, b in self._segments:
            t = raw[self._time_name][a:b] * factor
            ok = np.isfinite(t)
            t = t[ok]
            if t.size < 2:
                continue
            if np.any(np.diff(t) <= 0):
                order = np.argsort(t, kind="stable")
                t = t[order]
            else:
                order = None
            grid = t[0] + np.arange(int(np.floor((t[-1] - t[0]) * hz + 1e-9)) + 1) / hz
            for n in names:
                v = raw[n][a:b][ok]
                if order is not None:
                    v = v[order]
                parts[n].append(np.interp(grid, t, v) if n != self._time_name else grid / factor)
            segments.append((pos, pos + grid.size))
            pos += grid.size
        if not segments:
            raise RecordingError(f"{self.path}: no segment with two time values to resample")
        self._mem = {n: np.concatenate(parts[n]) for n in names}
        self.random_access = True  # in memory
        self.warnings.append(
            f"resampled linearly onto a uniform grid at {hz:g} Hz from time column {self._time_name!r} "
            f"({self._n} rows -> {pos} samples)"
        )
        self._n = pos
        self._segments = segments
        self._file_fs = hz
        self._fs_source = f"resample={hz:g} (linear interpolation of time column {self._time_name!r})"

    def _text_path(self) -> str:
        return self._data_path  # the UTF-8 copy of a UTF-16/32 file

    def _read_ranges(self, names: Sequence[str], ranges: Sequence[Tuple[int, int]]) -> Dict[str, np.ndarray]:
        if self._mem is not None:  # resampled
            mem = self._mem
            return {n: np.concatenate([mem[n][a:b] for a, b in ranges]) if ranges else np.zeros(0) for n in names}
        return super()._read_ranges(names, ranges)

    def _iter_blocks(self, names: Sequence[str], block: int) -> Iterator[Dict[str, np.ndarray]]:
        if self.random_access:
            yield from super()._iter_blocks(names, block)
            return
        self.check_unchanged()
        pos = {n: k for k, n in enumerate(self._names)}
        usecols = [self._usecols[pos[n]] for n in names]
        comment = self._comment.encode() if self._comment else None
        with open(self._data_path, "rb") as fh:
            for b in self._blocks:
                for lines, nos in iter_data_lines(
                    fh, b.offset, b.lineno, b.n, block=block, path=self.path, comment=comment
                ):
                    a = parse_rows(
                        lines, nos, self._delim, self._decimal, usecols=usecols, colnames=list(names), path=self.path
                    )
                    yield {nm: a[:, c] for c, nm in enumerate(names)}


_CR_BLOCK = 1 << 24
_BARE_CR = re.compile(rb"\r(?!\n)")


class _BareCR(Exception):
    """A line of the scan holds a carriage return without a line feed (the file is then read from a copy)."""


def _has_bare_cr(raw: bytes) -> bool:
    """A CR in the line other than its line end (``\\r\\n``, or ``\\r`` ending the file)."""
    return b"\r" in raw.rstrip(b"\r\n")


def _num(s: str, decimal: str) -> float:
    """A field as a float, NaN when it is not a number."""
    try:
        return to_float(s, decimal)
    except ValueError:
        return float("nan")


#: Names NI-style exports give the value column of a (time, value) pair.
_GENERIC_VALUE_NAMES = ("value", "values", "y", "amplitude", "data", "channel name", "")


def _floats(rows: Sequence[Sequence[str]], j: int, decimal: str) -> Optional[np.ndarray]:
    """Column ``j`` of the sample rows as floats, None when any field is not a number."""
    out = []
    for r in rows:
        if j >= len(r):
            return None
        try:
            out.append(to_float(r[j], decimal))
        except ValueError:
            return None
    return np.asarray(out, dtype=float)


def _steady(t: np.ndarray) -> bool:
    """Strictly increasing with steps within :data:`MAX_JITTER` of their median (a time column)."""
    if t.size < 3:
        return False
    d = np.diff(t)
    if not np.all(d > 0):
        return False
    return bool(np.percentile(np.abs(d / np.median(d) - 1.0), 95) <= MAX_JITTER)


def _paired_columns(rows: Sequence[Sequence[str]], nf: int, decimal: str) -> Optional[Tuple[bool, bool]]:
    """(True, one time base) for (time, value) column pairs: every even column steadily increasing; else None."""
    if nf < 4 or nf % 2 or len(rows) < 3:
        return None
    times = [_floats(rows, j, decimal) for j in range(0, nf, 2)]
    if any(t is None or not _steady(t) for t in times):
        return None
    t0 = times[0]
    assert t0 is not None
    values = [_floats(rows, j, decimal) for j in range(1, nf, 2)]
    if all(v is not None and _steady(v) for v in values):
        return None  # every column increases: no pairs to tell apart
    same = all(t is not None and np.allclose(t, t0, rtol=1e-9, atol=1e-12) for t in times)
    return True, same


def _channel_name_row(lines: Sequence[str], delim: Optional[str]) -> List[str]:
    """The non-empty fields after the key of a ``Channel name`` header row (NI exports), else []."""
    for ln in lines:
        f = [_clean(x) for x in split_fields(ln, delim)]
        if f and f[0].lower().rstrip(":") in ("channel name", "channel names", "channel"):
            return [x for x in f[1:] if x]
    return []


def _guess_time_column(rows: Sequence[Sequence[str]], use: Sequence[int], decimal: str) -> Optional[int]:
    """Index (into ``use``) of the first column that increases steadily (files without column names)."""
    for k, j in enumerate(use):
        t = _floats(rows, j, decimal)
        if t is not None and _steady(t):
            return k
    return None


def _check_resample(x: object) -> float:
    try:
        v = float(x)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise RecordingError(f"resample must be a rate in Hz, got {x!r}") from None
    if not (np.isfinite(v) and v > 0):
        raise RecordingError(f"resample must be finite and > 0 Hz, got {x!r}")
    return v
