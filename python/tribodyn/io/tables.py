"""Recordings held in memory as a table of columns: the common part of the readers of MAT-files,
spreadsheets and multi-step text exports (:mod:`tribodyn.io.matlab`, :mod:`tribodyn.io.spreadsheet`,
:mod:`tribodyn.io.steps`).

These formats are read whole by their libraries (scipy.io, h5py, python-calamine) or are small
vendor exports, so the reader builds one float64 array per column and serves any range of it
(random access, thread safe). What the reader decides from the columns is decided here once for
all three, as for delimited text (:mod:`tribodyn.io.delimited`):

* the time column: ``time_column=`` or the first column named as time (``time``, ``t``,
  ``Time (s)``, ``Zeit [s]``, ``Step Time (s)``...); its unit converts it to seconds;
* the sampling rate: ``1 / median step`` of the time column within each segment; a time restart
  (a step back) or a gap (a step over :data:`~tribodyn.io.delimited.GAP_FACTOR` median steps)
  starts a new segment, windowed apart; sampling more irregular than
  :data:`~tribodyn.io.delimited.MAX_JITTER` is refused unless ``resample=`` or ``fs=``;
* ``resample=HZ``: every channel interpolated linearly onto a uniform grid per segment, the
  result bounded by :data:`MAX_RESAMPLED_BYTES` (:func:`check_resample_size`);
* units: each column's unit converted to SI by :func:`tribodyn.io.units.si_conversion`;
* the default role map by name (:func:`tribodyn.io.base.roles_by_name`).
"""

from __future__ import annotations

import math
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .base import Recording, RecordingError, fs_from_times, roles_by_name
from ._resample import MAX_RESAMPLED_BYTES, check_resample_size
from .units import TIME_TO_S, normalize_unit

__all__ = ["MAX_RESAMPLED_BYTES", "TableRecording", "check_resample_size", "find_time_column"]

#: Names of a step's own clock in multi-step exports (restarting at each step), taken as time too.
_STEP_TIME_NAMES = ("step time", "steptime", "step time s")


def find_time_column(names: Sequence[str]) -> Optional[str]:
    """The first column named as time (see the module docstring), or None."""
    from .delimited import _time_name  # the names of a time column, declared once for text files

    for n in names:
        if _time_name(n) is not None:
            return n
    for n in names:
        from .base import base_name

        if " ".join(base_name(n).replace("_", " ").split()) in _STEP_TIME_NAMES:
            return n
    return None


def _time_unit(name: str, unit: Optional[str]) -> Optional[str]:
    """The time column's unit: the file's, else the one written in its name (``Time (ms)``)."""
    from .delimited import _time_name, _unit_from_name

    u = normalize_unit(unit)
    if u is None:
        hit = _time_name(name)
        u = hit[1] if hit is not None else None
        if u is None:
            u = _unit_from_name(name)  # 'Step Time (s)'; not 'data(:,1)'
    return u


class TableRecording(Recording):
    """A recording whose columns are held in memory (see the module docstring)."""

    random_access = True
    thread_safe = True
    streaming = False
    _owned_reads = False  # slices of the table: chunks copies them

    def __init__(self, path: str) -> None:
        super().__init__(path)
        self._table: Dict[str, np.ndarray] = {}

    def open_table(
        self,
        columns: Mapping[str, np.ndarray],
        units: Mapping[str, Optional[str]],
        *,
        channels: Optional[Mapping[str, Optional[str]]],
        fs: Optional[float],
        scale: Optional[Mapping[str, float]],
        given_units: Optional[Mapping[str, str]],
        time_column: Optional[str],
        resample: Optional[float],
        segments: Optional[List[Tuple[int, int]]] = None,
        file_fs: Optional[Tuple[float, str]] = None,
        default_roles: Optional[Mapping[str, str]] = None,
    ) -> None:
        """Finishes opening from the columns read: the public step of a reader (or a reader plugin) built on it.

        Parameters
        ----------
        columns : mapping
            Channel name -> 1-D array, all of one length, in file order.
        units : mapping
            Channel name -> unit as written in the file (None: none), converted to SI here.
        channels, fs, scale, given_units
            What :func:`~tribodyn.io.open_recording` was given (``channels``, ``fs``, ``scale``,
            ``units``), passed on as they came.
        time_column, resample
            The reading options of that name (None: the time column is found by name).
        segments : list of (int, int), optional
            Separate acquisitions the file holds (steps), windowed apart.
        file_fs : (float, str), optional
            A rate the file states and where (``(1000.0, "header 'Rate'")``); else from the time column.
        default_roles : mapping, optional
            Role -> channel of the format's own default map; else by name
            (:func:`~tribodyn.io.base.roles_by_name`).
        """
        self._names = list(columns)
        if not self._names:
            raise RecordingError(f"{self.path}: no numeric column in this {self.format} file")
        self._table = {n: np.ascontiguousarray(columns[n], dtype=np.float64) for n in self._names}
        self._n = int(self._table[self._names[0]].size)
        if self._n == 0:
            raise RecordingError(f"{self.path}: the table holds no rows")
        self._raw_units = {n: units.get(n) for n in self._names}
        self._segments = list(segments or [(0, self._n)])
        if time_column is not None:
            tname: Optional[str] = self._resolve(time_column, "time_column")
        else:
            tname = find_time_column(self._names)
        self._time_name = tname
        if file_fs is not None:
            self._file_fs, self._fs_source = file_fs
        if tname is not None and file_fs is None:
            self._rate_from_time(tname, fs_given=fs is not None, resample=resample)
        if resample is not None:
            self._resampled(float(resample))
        self._default_roles = dict(default_roles) if default_roles is not None else roles_by_name(self._names)
        self._default_roles = {r: c for r, c in self._default_roles.items() if c != tname}
        self._setup(channels, fs, scale, given_units)
        self.acquisitions = list(self._segments) if len(self._segments) > 1 else None

    def _time_seconds(self, name: str) -> np.ndarray:
        unit = _time_unit(name, self._raw_units.get(name))
        factor = TIME_TO_S.get(unit.lower(), 1.0) if unit else 1.0
        if unit and unit.lower() not in TIME_TO_S:
            raise RecordingError(f"{self.path}: time column {name!r} is in {unit!r}, not a unit of time")
        return self._table[name] * factor

    def _rate_from_time(self, name: str, *, fs_given: bool, resample: Optional[float]) -> None:
        """fs from the time column's median step; segments split at restarts and gaps; jitter checked."""
        from .delimited import GAP_FACTOR, MAX_JITTER

        t = self._time_seconds(name)
        if not np.all(np.isfinite(t)):
            bad = int(np.flatnonzero(~np.isfinite(t))[0])
            raise RecordingError(f"{self.path}: time column {name!r} has a missing value at row {bad + 1}")
        pieces = [t[a:b] for a, b in self._segments]
        f = fs_from_times(pieces)
        if f is None:
            raise RecordingError(f"{self.path}: time column {name!r} has no increasing steps")
        d = np.diff(t)
        cuts = {int(c) + 1 for c in np.flatnonzero((d <= 0) | (d > GAP_FACTOR / f))}
        bounds = sorted({a for a, _ in self._segments} | {b for _, b in self._segments} | cuts)
        self._segments = [(a, b) for a, b in zip(bounds[:-1], bounds[1:]) if b > a]
        steps = np.concatenate([np.diff(t[a:b]) for a, b in self._segments])
        rel = np.abs(steps * f - 1.0)
        jitter = float(np.percentile(rel, 95)) if rel.size else 0.0
        if jitter > MAX_JITTER and resample is None:
            msg = (
                f"irregular sampling: the steps of time column {name!r} vary by {100 * jitter:.0f} % (95th "
                f"percentile of |step x fs - 1|, fs = {f:g} Hz from the median step; at most "
                f"{100 * MAX_JITTER:.0f} % is read as uniform)"
            )
            if not fs_given:
                raise RecordingError(
                    f"{self.path}: {msg}: pass resample=HZ (--resample HZ) to interpolate every channel linearly "
                    "onto a uniform grid, or fs= to take the rows as uniform"
                )
            self.warnings.append(msg + "; the rows are taken as uniform at the fs given")
        self._file_fs = f
        self._fs_source = f"median step of time column {name!r}"

    def _resampled(self, hz: float) -> None:
        """Every column interpolated linearly onto a uniform grid at ``hz`` in each segment."""
        if not (math.isfinite(hz) and hz > 0):
            raise RecordingError(f"resample must be finite and > 0 Hz, got {hz!r}")
        if self._time_name is None:
            raise RecordingError(f"{self.path}: resample= needs a time column (pass time_column=)")
        t_all = self._time_seconds(self._time_name)
        total = 0
        plan = []
        for a, b in self._segments:
            if b - a < 2:
                continue
            t = t_all[a:b]
            total += check_resample_size(self.path, hz, float(t[-1] - t[0]), len(self._names), b - a)
            plan.append((a, b))
        check_resample_size(self.path, hz, (total - 1) / hz, len(self._names), self._n)
        if not plan:
            raise RecordingError(f"{self.path}: no segment with two time values to resample")
        parts: Dict[str, List[np.ndarray]] = {n: [] for n in self._names}
        segments: List[Tuple[int, int]] = []
        pos = 0
        for a, b in plan:
            t = t_all[a:b]
            grid = t[0] + np.arange(math.floor((t[-1] - t[0]) * hz + 1e-9) + 1) / hz
            for n in self._names:
                parts[n].append(np.interp(grid, t, self._table[n][a:b]))
            segments.append((pos, pos + grid.size))
            pos += grid.size
        self.warnings.append(
            f"resampled linearly onto a uniform grid at {hz:g} Hz from time column {self._time_name!r} "
            f"({self._n} rows -> {pos} samples)"
        )
        self._table = {n: np.concatenate(parts[n]) for n in self._names}
        self._n = pos
        self._segments = segments
        self._file_fs = hz
        self._fs_source = f"resample={hz:g} (linear interpolation of time column {self._time_name!r})"

    def _read_range(self, names: Sequence[str], start: int, stop: int) -> Dict[str, np.ndarray]:
        self._check_open()
        return {n: self._table[n][start:stop] for n in names}

    def _close(self) -> None:
        self._table = {}


def numeric_column(values: Sequence[object]) -> Optional[np.ndarray]:
    """The values as float64 when every one is a number (empty cells NaN), else None."""
    out = np.empty(len(values), dtype=np.float64)
    for k, v in enumerate(values):
        if isinstance(v, bool):
            return None
        if isinstance(v, (int, float, np.integer, np.floating)):
            out[k] = float(v)
        elif v is None or (isinstance(v, str) and not v.strip()):
            out[k] = np.nan
        else:
            return None
    return out
