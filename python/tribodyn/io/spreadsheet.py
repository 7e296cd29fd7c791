"""Spreadsheets: Excel ``.xlsx``, ``.xlsm``, ``.xls`` and OpenDocument ``.ods``, read with python-calamine.

The sheet
    ``sheet=NAME`` (CLI ``--sheet NAME``), else the first sheet that holds a numeric table.
The table
    The first row whose cells are mostly numbers and that the next rows continue with numbers in the
    same columns starts the data. Above it: the column names, and, between the names and the data,
    an optional units row (every cell a unit: ``N``, ``mm/s``, ``[N]``, ``(s)``, ``-``...); units may
    also be written in the names (``Force [N]``, ``Time (s)``). Rows above the names (a title, test
    parameters) are header, kept in ``metadata['header']``. The data end at the first row without a
    number; a column with a cell that is not a number (a date, a note, a blank) is not a channel
    (``metadata['text_columns']``). A column without a name is named by its letter (``C``).
Time, rate, units, roles
    As for every table (:mod:`tribodyn.io.tables`): a column named as time gives fs; units are
    converted to SI by :func:`tribodyn.io.units.si_conversion`.

The workbook is read whole (a zip of XML, or an OLE2 file for ``.xls``).
"""

from __future__ import annotations

import datetime
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .base import RecordingError
from .detect import describe_content
from .tables import TableRecording, numeric_column
from .units import is_known_unit, normalize_unit

__all__ = ["SpreadsheetRecording"]

#: Rows looked at for the table's start in each sheet.
_HEAD_ROWS = 200


def _is_num(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _blank(v: Any) -> bool:
    return v is None or (isinstance(v, str) and not v.strip())


def _numeric_cols(row: Sequence[Any]) -> Tuple[int, ...]:
    return tuple(j for j, v in enumerate(row) if _is_num(v))


def _is_data_row(row: Sequence[Any]) -> bool:
    filled = [v for v in row if not _blank(v)]
    nums = sum(1 for v in filled if _is_num(v))
    return nums >= 1 and nums * 2 >= len(filled)


def _is_units_row(row: Sequence[Any], cols: Sequence[int]) -> bool:
    """Every named cell of the data columns is a unit (or ``-``), at least one is."""
    cells = [row[j] if j < len(row) else "" for j in cols]
    if any(not isinstance(c, str) for c in cells if not _blank(c)):
        return False
    toks = [normalize_unit(str(c)) for c in cells if not _blank(c)]
    return bool(toks) and all(t is None or t in ("-", "1", "%") or is_known_unit(t) for t in toks)


def _letter(j: int) -> str:
    s = ""
    j += 1
    while j:
        j, r = divmod(j - 1, 26)
        s = chr(65 + r) + s
    return s


def find_table(rows: Sequence[Sequence[Any]]) -> Optional[Dict[str, Any]]:
    """The numeric table of a sheet's rows: names, units, first and last data row; None when there is none."""
    n = len(rows)
    for i in range(min(n, _HEAD_ROWS)):
        if not _is_data_row(rows[i]):
            continue
        cols = _numeric_cols(rows[i])
        follow = rows[i + 1 : i + 4]
        if follow and not all(set(cols) <= set(_numeric_cols(r)) for r in follow):
            continue
        above = [k for k in range(i) if not all(_blank(v) for v in rows[k])]
        units_row: Optional[int] = None
        names_row: Optional[int] = None
        if above and _is_units_row(rows[above[-1]], cols) and len(above) >= 2:
            units_row, names_row = above[-1], above[-2]
        elif above:
            names_row = above[-1]
        end = i
        while end < n and any(_is_num(v) for v in rows[end]):
            end += 1
        return {"start": i, "end": end, "names": names_row, "units": units_row, "cols": cols}
    return None


class SpreadsheetRecording(TableRecording):
    """A sheet of a workbook (see the module docstring)."""

    format = "spreadsheet"

    def __init__(
        self,
        path: str,
        *,
        channels: Optional[Mapping[str, Optional[str]]] = None,
        fs: Optional[float] = None,
        scale: Optional[Mapping[str, float]] = None,
        units: Optional[Mapping[str, str]] = None,
        sheet: Optional[str] = None,
        time_column: Optional[str] = None,
        time_channel: Optional[str] = None,
        resample: Optional[float] = None,
    ) -> None:
        super().__init__(path)
        if sheet is not None and not isinstance(sheet, str):
            raise TypeError(f"sheet must be a sheet name (str), got {type(sheet).__name__}")
        name, rows, table = self._choose_sheet(sheet)
        self.metadata["sheet"] = name
        start, end = table["start"], table["end"]
        names_row = rows[table["names"]] if table["names"] is not None else []
        units_row = rows[table["units"]] if table["units"] is not None else []
        if table["names"] is not None and table["names"] > 0:
            self.metadata["header"] = [
                " ".join(str(v) for v in r if not _blank(v)) for r in rows[: table["names"]] if any(map(_not_blank, r))
            ][:50]
        width = max(len(r) for r in rows[start:end])
        columns: Dict[str, np.ndarray] = {}
        col_units: Dict[str, Optional[str]] = {}
        text_columns: List[str] = []
        from .delimited import _unit_from_name

        for j in range(width):
            raw_name = names_row[j] if j < len(names_row) and not _blank(names_row[j]) else _letter(j)
            cname = _cell_text(raw_name)
            base = cname
            k = 1
            while cname in columns or cname in text_columns:
                cname = f"{base}.{k}"
                k += 1
            values = [r[j] if j < len(r) else "" for r in rows[start:end]]
            if all(_blank(v) for v in values):
                continue
            col = numeric_column(values)
            if col is None or np.isnan(col).any():
                text_columns.append(cname)
                continue
            columns[cname] = col
            unit = units_row[j] if j < len(units_row) and not _blank(units_row[j]) else None
            u = normalize_unit(str(unit)) if unit is not None else _unit_from_name(cname)
            col_units[cname] = None if u in ("-", "1") else u
        if text_columns:
            self.metadata["text_columns"] = text_columns
        self.metadata["rows"] = [start + 1, end]  # 1-based first and last data row in the sheet
        self.open_table(
            columns,
            col_units,
            channels=channels,
            fs=fs,
            scale=scale,
            given_units=units,
            time_column=time_column or time_channel,
            resample=resample,
        )

    def _choose_sheet(self, sheet: Optional[str]) -> Tuple[str, List[List[Any]], Dict[str, Any]]:
        import python_calamine as pc

        try:
            with open(self.path, "rb") as fh:  # from the content, not the extension (an .ods named .xlsx)
                wb = pc.CalamineWorkbook.from_filelike(fh)
        except Exception as exc:  # noqa: BLE001 - calamine raises its own errors (zip, XML, password, CFB)
            msg = " ".join(str(exc).split())[:200] or type(exc).__name__
            what = describe_content(self.path)
            hint = (
                f"its content is {what}"
                if "spreadsheet" not in what and "workbook" not in what
                else ("corrupt, encrypted or truncated?")
            )
            raise RecordingError(f"{self.path}: not a readable spreadsheet ({hint}): {msg}") from None
        try:
            names = list(wb.sheet_names)
            if sheet is not None:
                hit = [s for s in names if s == sheet] or [s for s in names if s.lower() == sheet.strip().lower()]
                if not hit:
                    raise RecordingError(f"{self.path}: no sheet {sheet!r}; sheets: {', '.join(map(repr, names))}")
                order = hit[:1]
            else:
                order = names
            for s in order:
                try:
                    rows = wb.get_sheet_by_name(s).to_python()
                except Exception as exc:  # noqa: BLE001 - as above
                    msg = " ".join(str(exc).split())[:200] or type(exc).__name__
                    raise RecordingError(f"{self.path}: cannot read sheet {s!r}: {msg}") from None
                table = find_table(rows)
                if table is not None:
                    return s, rows, table
                if sheet is not None:
                    raise RecordingError(f"{self.path}: sheet {s!r} holds no numeric table")
        finally:
            wb.close()
        raise RecordingError(
            f"{self.path}: no sheet holds a numeric table (sheets: {', '.join(map(repr, names)) or 'none'})"
        )


def _not_blank(v: Any) -> bool:
    return not _blank(v)


def _cell_text(v: Any) -> str:
    if isinstance(v, float) and v.is_integer():
        return str(int(v))
    if isinstance(v, (datetime.date, datetime.time, datetime.timedelta)):
        return v.isoformat() if not isinstance(v, datetime.timedelta) else str(v)
    return " ".join(str(v).split())
