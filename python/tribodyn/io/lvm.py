"""LabVIEW Measurement files (``.lvm``), read by a streaming parser of our own.

Layout (NI's LVM specification): a file header (``LabVIEW Measurement`` ...
``***End_of_Header***``) with ``Separator``, ``Decimal_Separator``,
``X_Columns`` (No / One / Multi) and ``Multi_Headings``; then data segments,
each optionally preceded by a segment header (``Channels``, ``Samples``,
``Y_Unit_Label``, ``Delta_X``... ``***End_of_Header***``) and a column row
(``X_Value  name1  name2 ... Comment``). Values in header lines sit in the
same column as the data they describe.

How this reader behaves:

* One scan pass at open finds the segments and counts their data rows
  (nothing is kept but offsets, counts and checkpoints): the headers line
  by line, the runs of data rows natively (docs/method.md 9, "Text
  files"). The
  row count of the data is trusted over the ``Samples`` announced in the
  header (a warning is recorded when they differ). A blank line or a new
  segment header starts a new segment; with ``Multi_Headings No`` a segment
  holding an exact multiple k of its announced ``Samples`` is taken as k
  consecutive headerless segments (each call of LabVIEW's writer appends one).
* Any range of samples is then parsed natively from the checkpoint before
  it, in parallel pieces (decimal comma handled): the file is random access.
* fs = 1 / ``Delta_X`` (all channels must agree). Units are the
  ``Y_Unit_Label`` values; only unambiguous ones are converted (``g`` is
  left alone: in LVM files it is as often an acceleration as a force).
* Channels whose announced ``Samples`` is 0 in every segment (LabVIEW's empty
  "Untitled" columns) are skipped and listed in ``metadata['skipped']``.
* Header values are parsed as numbers or kept as text, never evaluated; no
  cache file is written anywhere.
* The last data row must be whole: a row without its end-of-line, or with
  fewer fields than the channels need, is reported as a truncated file
  (LabVIEW writes every row whole, line end included).
* A channel name appearing more than once is read as ``name``, ``name.1``...
  with a warning, and no role is mapped to it automatically.
"""

from __future__ import annotations

import math
from typing import IO, Any, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from ._text import (
    TEXT_BLOCK_ROWS,
    Checkpoints,
    TextRecording,
    check_encoding,
    decode_header,
    default_roles,
    duplicate_warnings,
    incomplete_row_error,
    iter_data_lines,
    native_dialect,
    native_scan,
    parse_rows,
    row_defects,
    to_float,
)
from .base import RecordingError, rate_from_step

__all__ = ["LvmRecording"]

_END = b"***End_of_Header***"


class _Segment:
    __slots__ = ("announced", "cps", "header", "lineno", "marks", "n", "offset")

    def __init__(self, offset: int, lineno: int, header: Dict[str, List[str]]) -> None:
        self.cps: List[Tuple[int, int, int]] = []  # (row of the segment, byte offset, line): parse starts
        self.marks: List[Tuple[int, int, int]] = []  # more of them, only to start a read near a sample
        self.offset = offset
        self.lineno = lineno
        self.n = 0
        self.header = header
        self.announced: Optional[int] = None


class _LvmScan:
    """The line-by-line state of :meth:`LvmRecording._scan`."""

    def __init__(self, offset: int, lineno: int, sep: bytes) -> None:
        self.offset = offset  # byte offset of the next line
        self.lineno = lineno  # line number of the last line read
        self.sep = sep
        self.segments: List[_Segment] = []
        self.colnames: Optional[List[str]] = None  # column row of the layout in force
        self.cur_header: Dict[str, List[str]] = {}
        self.state = "between"  # between | header | after_header | data
        self.last_raw = b""
        self.last_lineno = 0
        self.seg: Optional[_Segment] = None


def _hval(sg: _Segment, key: str, i: int) -> str:
    """Field ``i`` of the segment header's ``key`` row, '' without one."""
    v = sg.header.get(key)
    return v[i] if v is not None and i < len(v) else ""


def _hnum(sg: _Segment, key: str, i: int, decimal: str) -> Optional[float]:
    """:func:`_hval` as a number, None when empty or not a number."""
    s = _hval(sg, key, i)
    if not s:
        return None
    try:
        return to_float(s, decimal)
    except ValueError:
        return None


class LvmRecording(TextRecording):
    """A LabVIEW Measurement file; see the module docstring."""

    format = "lvm"

    def __init__(
        self,
        path: str,
        *,
        channels: Optional[Mapping[str, Optional[str]]] = None,
        fs: Optional[float] = None,
        scale: Optional[Mapping[str, float]] = None,
        units: Optional[Mapping[str, str]] = None,
        encoding: Optional[str] = None,
        time_column: Optional[str] = None,
        resample: Optional[float] = None,
    ) -> None:
        super().__init__(path)
        self._block_rows = TEXT_BLOCK_ROWS
        self._encoding = check_encoding(encoding or "utf-8")
        if resample is not None:
            raise RecordingError(f"{path}: resample= applies to delimited text; LVM files are uniformly sampled")
        if time_column is not None and time_column != "X_Value":
            self.warnings.append(f"time_column={time_column!r} ignored: LVM files carry X0 and Delta_X")
        self._scan()
        self._default_roles = default_roles(self._file_names, self._names)
        self._setup(channels, fs, scale, units)
        self.warnings += duplicate_warnings(self._file_names, self._names, self._columns, self.roles)

    # ------------------------------------------------------------------ scan
    def _scan(self) -> None:
        """Reads the file once: its file header, segments (headers, column rows, data rows) and layout."""
        path = self.path
        with open(path, "rb") as fh:
            first = fh.readline()
            if not first.lstrip(b"\xef\xbb\xbf").startswith(b"LabVIEW Measurement"):
                raise RecordingError(f"{path}: not a LabVIEW Measurement file (no 'LabVIEW Measurement' line)")
            file_header, offset, lineno = self._file_header(fh, len(first))
            x_columns = file_header.get("X_Columns", "One")
            multi_headings = file_header.get("Multi_Headings", "Yes")
            st = _LvmScan(offset, lineno, self._sep.encode())
            self._scan_segments(fh, st, x_columns)
        segments, colnames, last_raw, last_lineno = st.segments, st.colnames, st.last_raw, st.last_lineno
        if not segments:
            raise RecordingError(f"{path}: LVM file without data rows")
        for sg in segments:
            sg.header.setdefault("__columns__", list(colnames or []))
        # the last data row must be whole: line end and every field (a cut inside it would lose them)
        terminated = last_raw.endswith((b"\n", b"\r"))
        if not terminated:
            raise incomplete_row_error(path, last_lineno, row_defects(1, 1, False))
        self._layout(segments, x_columns, multi_headings, file_header)
        tail = last_raw.decode("latin-1").rstrip("\r\n").split(self._sep)
        if len(tail) < max(self._usecols) + 1:
            raise incomplete_row_error(path, last_lineno, row_defects(len(tail), max(self._usecols) + 1, terminated))

    def _file_header(self, fh: IO[bytes], offset: int) -> Tuple[Dict[str, str], int, int]:
        """The file header after the first line: its keys, and the offset and line number of its end."""
        path = self.path
        lineno = 1
        file_header: Dict[str, str] = {}
        header_lines: List[bytes] = []
        while True:
            raw = fh.readline()
            if not raw:
                raise RecordingError(f"{path}: truncated LVM file: no end of the file header")
            offset += len(raw)
            lineno += 1
            s = raw.rstrip(b"\r\n")
            if s.split(b"\t", 1)[0].split(b",", 1)[0].strip() == _END:
                break
            header_lines.append(s)
        sep = b"\t"
        for s in header_lines:
            if s.startswith(b"Separator"):
                val = s[len(b"Separator") + 1 :].strip().lower()
                if val.startswith(b"comma"):
                    sep = b","
                break
        for s in header_lines:
            parts = s.split(sep)
            key = decode_header(parts[0], self._encoding).strip()
            if key:
                val = parts[1] if len(parts) > 1 else b""
                file_header[key] = decode_header(val, self._encoding).strip()
        decimal = file_header.get("Decimal_Separator", ".") or "."
        if decimal not in (".", ","):
            raise RecordingError(f"{path}: unsupported Decimal_Separator {decimal!r}")
        if decimal == "," and sep == b",":
            raise RecordingError(f"{path}: comma used both as separator and decimal separator")
        self._sep = sep.decode()
        self._decimal = decimal
        return file_header, offset, lineno

    def _scan_segments(self, fh: IO[bytes], st: _LvmScan, x_columns: str) -> None:
        """Goes through the lines after the file header, line by line (plain data rows natively)."""
        native = native_dialect(self._sep, self._decimal, None, skip_blank=False) if self._use_native else None
        self._native = native
        while True:
            if native is not None and st.state == "data":
                self._native_run(fh, st, native)
            raw = fh.readline()
            if not raw:
                break
            line_off = st.offset
            st.offset += len(raw)
            st.lineno += 1
            self._scan_line(st, raw, line_off=line_off, x_columns=x_columns)
        if st.state in ("header",):
            raise RecordingError(f"{self.path}: truncated LVM file: a segment header has no end")

    def _native_run(self, fh: IO[bytes], st: _LvmScan, native: Dict[str, Any]) -> None:
        """The plain rows that follow, natively (the same rules, see tribodyn._core.text_scan)."""
        seg = st.seg
        assert seg is not None
        run = native_scan(fh.fileno(), st.offset, native, nf=None, probe=0)
        if run["rows"]:
            for row, off, line in run["checkpoints"]:
                seg.cps.append((seg.n + int(row), int(off), st.lineno + 1 + int(line)))
            seg.marks += [(seg.n + row, off, st.lineno + 1 + line) for row, off, line in run["marks"]]
            seg.n += int(run["rows"])
            st.last_lineno = st.lineno + 1 + int(run["last"][0])
            fh.seek(int(run["last"][1]))
            st.last_raw = fh.readline()
        st.offset = int(run["end"])
        st.lineno += int(run["lines"])
        fh.seek(st.offset)

    def _scan_line(self, st: _LvmScan, raw: bytes, *, line_off: int, x_columns: str) -> None:
        """One line, by the scan's state: a data row, a segment header's line, a column row."""
        path, sep, lineno = self.path, st.sep, st.lineno
        s = raw.rstrip(b"\r\n")
        first_field = s.split(sep, 1)[0].strip()
        blank = not s.replace(sep, b"").strip()
        if st.state == "data":
            if blank:
                st.state = "between"
                return
            if first_field and _is_key(first_field):
                st.state = "between"  # fall through: a new header starts here
            else:
                assert st.seg is not None
                st.seg.n += 1
                st.last_raw, st.last_lineno = raw, lineno
                return
        if st.state == "between":
            if blank:
                return
            if first_field == b"X_Value":
                st.colnames = self._column_row(s, sep)
                st.cur_header = st.cur_header or {}
                st.state = "after_header"
                return
            if first_field and _is_key(first_field):
                st.cur_header = {}
                st.state = "header"
            else:
                # data resuming without a new header: same layout
                if st.colnames is None and not st.segments:
                    raise RecordingError(f"{path}: line {lineno}: data before any segment header (corrupt LVM file?)")
                seg = _Segment(line_off, lineno, st.segments[-1].header if st.segments else st.cur_header)
                seg.n = 1
                st.seg = seg
                st.segments.append(seg)
                st.last_raw, st.last_lineno = raw, lineno
                st.state = "data"
                return
        if st.state == "header":
            if first_field == _END:
                st.state = "after_header"
                return
            hfields = [decode_header(p, self._encoding).strip() for p in s.split(sep)]
            if hfields[0]:
                st.cur_header[hfields[0]] = hfields
            return
        if st.state == "after_header":
            if blank:
                return
            if first_field == b"X_Value":
                st.colnames = self._column_row(s, sep)
                return
            seg = _Segment(line_off, lineno, st.cur_header)
            seg.n = 1
            st.seg = seg
            st.segments.append(seg)
            st.last_raw, st.last_lineno = raw, lineno
            st.state = "data"
            if st.colnames is None:
                st.colnames = self._implicit_columns(st.cur_header, x_columns, len(s.split(sep)), path, lineno)
            seg.header = dict(st.cur_header)
            seg.header["__columns__"] = list(st.colnames)

    def _column_row(self, s: bytes, sep: bytes) -> List[str]:
        return [decode_header(p, self._encoding).strip() for p in s.split(sep)]

    @staticmethod
    def _implicit_columns(
        header: Dict[str, List[str]], x_columns: str, nfields: int, path: str, lineno: int
    ) -> List[str]:
        """Column row when the file has none: X column(s) plus ``Untitled`` channels.

        ``nfields`` is the field count of the first data row (line ``lineno``): a
        ``Channels`` count the row cannot hold is refused as a corrupt header
        (before a list of that many names is built).
        """
        try:
            nch = int(header.get("Channels", ["", "0"])[1])
        except (ValueError, IndexError):
            nch = 0
        ncols = 2 * nch if x_columns == "Multi" else nch + 1
        if ncols > nfields + 1:  # + 1: an X column is counted even with X_Columns No
            raise RecordingError(
                f"{path}: line {lineno} has {nfields} fields but the segment header announces {ncols} columns "
                "(corrupt LVM file?)"
            )
        if x_columns == "Multi":
            cols = []
            for k in range(nch):
                cols += ["X_Value", f"Untitled {k}" if k else "Untitled"]
            return cols
        return ["X_Value"] + [f"Untitled {k}" if k else "Untitled" for k in range(nch)]

    def _layout(
        self,
        segments: List[_Segment],
        x_columns: str,
        multi_headings: str,
        file_header: Dict[str, str],
    ) -> None:
        """The channels, units, rate, segments and acquisitions from the segments' headers and rows."""
        cols0, idx = self._channel_columns(segments)
        keep, skipped = self._kept_channels(segments, cols0, idx)
        self._file_names = [cols0[i] or "Untitled" for i in keep]
        self._columns = [i + 1 for i in keep]
        names = _dedupe(self._file_names)
        self._usecols = keep
        self._names = names
        self._raw_units = {n: (_hval(segments[0], "Y_Unit_Label", i) or None) for n, i in zip(names, keep)}
        dx0 = self._sampling_interval(segments, names, keep)
        self._index_segments(segments, keep[0], multi_headings)
        step = dx0 if dx0 is not None and dx0 > 0 else None
        self.acquisitions: List[Tuple[int, int]] = self._acquisitions(segments, keep[0], step)
        self.metadata = {
            "header": dict(file_header),
            "segments_in_file": len(segments),
            "samples_announced": [_hnum(sg, "Samples", keep[0], self._decimal) for sg in segments],
        }
        if skipped:
            self.metadata["skipped"] = skipped

    def _channel_columns(self, segments: List[_Segment]) -> Tuple[List[str], List[int]]:
        """The column row (the same in every segment) and its channel columns (not X_Value, not a last Comment)."""
        path = self.path
        cols0 = segments[0].header["__columns__"]
        for k, sg in enumerate(segments[1:], 2):
            if sg.header["__columns__"] != cols0:
                raise RecordingError(
                    f"{path}: segment {k} has other channels than segment 1 "
                    f"({sg.header['__columns__']} vs {cols0}); not supported"
                )
        # channel columns: not X_Value, not the trailing Comment column
        idx = [i for i, n in enumerate(cols0) if n != "X_Value" and not (n == "Comment" and i == len(cols0) - 1)]
        if not idx:
            raise RecordingError(f"{path}: LVM file without data channels")
        return cols0, idx

    def _kept_channels(self, segments: List[_Segment], cols0: List[str], idx: List[int]) -> Tuple[List[int], List[str]]:
        """The channel columns kept and the names of those announced empty in every segment (skipped)."""
        path, decimal = self.path, self._decimal
        keep = []
        skipped = []
        for i in idx:
            ann_all = [_hnum(sg, "Samples", i, decimal) for sg in segments]
            if all(a == 0 for a in ann_all):
                skipped.append(cols0[i])
            else:
                keep.append(i)
        if not keep:
            raise RecordingError(f"{path}: every LVM channel is announced empty (Samples 0)")
        for k, sg in enumerate(segments, 1):
            ann_by_name = {cols0[i]: _hnum(sg, "Samples", i, decimal) for i in keep}
            known = {v for v in ann_by_name.values() if v is not None}
            if len(known) > 1:
                detail = ", ".join(f"{n!r}={v:g}" for n, v in ann_by_name.items() if v is not None)
                raise RecordingError(f"{path}: unequal channel lengths in segment {k} ({detail})")
        return keep, skipped

    def _sampling_interval(self, segments: List[_Segment], names: List[str], keep: List[int]) -> Optional[float]:
        """The first segment's Delta_X (the same for every channel; sets the rate when > 0), None without one."""
        decimal = self._decimal
        first = segments[0]
        dxs = {}
        for n, i in zip(names, keep):
            dx = _hnum(first, "Delta_X", i, decimal)
            if dx is not None:
                dxs[n] = dx
        if not dxs:
            return None
        vals = list(dxs.values())
        if max(vals) - min(vals) > 1e-9 * max(abs(v) for v in vals):
            detail = ", ".join(f"{n!r}: {v:g}" for n, v in dxs.items())
            raise RecordingError(f"{self.path}: channels have different Delta_X ({detail})")
        if vals[0] > 0:
            self._file_fs = rate_from_step(vals[0])
            self._fs_source = f"1/Delta_X ({vals[0]:g} s)"
        for k, sg in enumerate(segments[1:], 2):
            dx = _hnum(sg, "Delta_X", keep[0], decimal)
            if dx is not None and abs(dx - vals[0]) > 1e-9 * abs(vals[0]):
                self.warnings.append(f"segment {k} has Delta_X {dx:g}, segment 1 {vals[0]:g}")
        return vals[0]

    def _index_segments(self, segments: List[_Segment], col: int, multi_headings: str) -> None:
        """The segments' rows as blocks, sample ranges and checkpoints: the data rows are trusted."""
        ranges: List[Tuple[int, int]] = []
        blocks: List[Tuple[int, int, int]] = []
        pos = 0
        for k, sg in enumerate(segments, 1):
            ann_n = _hnum(sg, "Samples", col, self._decimal)
            ok = ann_n is not None and math.isfinite(ann_n) and ann_n >= 0 and ann_n == int(ann_n)
            ann_i = int(ann_n) if ok and ann_n is not None else None
            if ann_i is not None and ann_i != sg.n:
                self.warnings.append(
                    f"segment {k} announces {ann_i} samples but holds {sg.n} data rows (the data rows are used)"
                )
            blocks.append((sg.offset, sg.lineno, sg.n))
            if multi_headings.lower() == "no" and ann_i and sg.n > ann_i and sg.n % ann_i == 0:
                for j in range(sg.n // ann_i):
                    ranges.append((pos + j * ann_i, pos + (j + 1) * ann_i))
            else:
                ranges.append((pos, pos + sg.n))
            pos += sg.n
        self._blocks = blocks
        self._n = pos
        self._segments = ranges
        cps: List[Tuple[int, int, int]] = []
        marks: List[Tuple[int, int, int]] = []
        base = 0
        for sg in segments:
            cps.append((base, sg.offset, sg.lineno))
            cps += [(base + r, off, line) for r, off, line in sg.cps]
            marks += [(base + r, off, line) for r, off, line in sg.marks]
            base += sg.n
        if self._native is not None:  # the parse skips blank lines (none is inside a segment)
            self._checkpoints = Checkpoints(cps, pos, marks)
            self._parse_dialect = dict(self._native, skip_blank=True)
            self.random_access = True  # read at any sample from the checkpoints

    def _acquisitions(self, segments: List[_Segment], col: int, step: Optional[float]) -> List[Tuple[int, int]]:
        """Separate acquisitions: a segment whose X0 does not continue the previous one's time.

        (X0 + rows x Delta_X, within half a step) is discontinuous; no analysis window straddles it.
        """
        acq: List[Tuple[int, int]] = []
        pos = 0
        prev_end: Optional[float] = None
        for k, sg in enumerate(segments, 1):
            x0 = _hnum(sg, "X0", col, self._decimal)
            cont = k == 1 or (x0 is not None and step is not None and prev_end is not None
                              and abs(x0 - prev_end) <= 0.5 * step) or x0 is None  # fmt: skip
            if cont and acq:
                acq[-1] = (acq[-1][0], pos + sg.n)
            else:
                acq.append((pos, pos + sg.n))
            prev_end = None if x0 is None or step is None else x0 + sg.n * step
            pos += sg.n
        return acq

    # ---------------------------------------------------------------- reading
    def _iter_blocks(self, names: Sequence[str], block: int) -> Iterator[Dict[str, np.ndarray]]:
        if self.random_access:
            yield from super()._iter_blocks(names, block)
            return
        self.check_unchanged()
        pos = {n: k for k, n in enumerate(self._names)}
        sel = [pos[n] for n in names]
        usecols = [self._usecols[k] for k in sel]
        with open(self.path, "rb") as fh:
            for offset, lineno, n in self._blocks:
                for lines, nos in iter_data_lines(fh, offset, lineno, n, block=block, path=self.path):
                    a = parse_rows(
                        lines, nos, self._sep, self._decimal, usecols=usecols, colnames=list(names), path=self.path
                    )
                    yield {nm: a[:, c] for c, nm in enumerate(names)}


def _is_key(field: bytes) -> bool:
    """True when a line's first field is a header tag rather than a number."""
    if field in (b"X_Value", _END):
        return True
    c = field[:1]
    if not c.isalpha():
        return False
    try:
        float(field.replace(b",", b"."))
        return False  # nan, inf
    except ValueError:
        return True


def _dedupe(names: List[str]) -> List[str]:
    seen: Dict[str, int] = {}
    out = []
    for n in names:
        n = n or "Untitled"
        if n in seen:
            seen[n] += 1
            m = f"{n}.{seen[n]}"
            while m in seen:
                seen[n] += 1
                m = f"{n}.{seen[n]}"
            seen[m] = 0
            out.append(m)
        else:
            seen[n] = 0
            out.append(n)
    return out
