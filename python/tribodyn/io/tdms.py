"""NI TDMS files, read through npTDMS in streaming mode.

``nptdms.TdmsFile.open`` reads only the metadata; samples are read per block
with ``channel.read_data(offset, length)``, which applies the file's scaling
(DAQmx raw data with ``NI_Scale[n]_*`` properties come out in engineering
units, e.g. volts). Channels are named ``channel`` when that name is unique
in the file, else ``group/channel``; either form is accepted where a channel
is named. fs = 1 / ``wf_increment``; units come from ``unit_string``.

Only numeric channels with data are channels of the recording; channels of
another length than the mapped ones (or than all others) are listed in
``metadata['skipped']``.

Before npTDMS sees the file, the segment lead-ins are walked (28 bytes each)
so a file cut short (npTDMS would read the remainder with a log message) is
reported as a :class:`~tribodyn.io.base.RecordingError`.
"""

from __future__ import annotations

import os
import struct
from typing import Any, Dict, List, Mapping, Optional, Sequence

import numpy as np

from ._open import closing_on_error, open_or_raise
from .base import (
    Recording,
    RecordingError,
    equal_length_selection,
    rate_from_step,
    resolve_name,
    roles_by_name,
)

__all__ = ["TdmsRecording", "check_tdms_segments"]

_LEAD_IN = 28
_TOC_BIG_ENDIAN = 1 << 6
_INCOMPLETE = 0xFFFFFFFFFFFFFFFF


def check_tdms_segments(path: str) -> int:
    """Walks the segment lead-ins of a TDMS file and checks they fit in the file.

    Returns
    -------
    int
        Number of segments.

    Raises
    ------
    RecordingError
        Not a TDMS file, or a segment that runs past the end of the file or
        was never finished by its writer.
    """
    size = os.path.getsize(path)
    pos = 0
    count = 0
    with open(path, "rb") as fh:
        while pos < size:
            fh.seek(pos)
            lead = fh.read(_LEAD_IN)
            if len(lead) < _LEAD_IN:
                raise RecordingError(f"{path}: truncated TDMS file ({size - pos} stray bytes after segment {count})")
            if lead[:4] != b"TDSm":
                what = "not a TDMS file" if count == 0 else f"corrupt TDMS file at byte {pos}"
                raise RecordingError(f"{path}: {what} (bad segment tag {lead[:4]!r})")
            (toc,) = struct.unpack("<I", lead[4:8])
            order = ">" if toc & _TOC_BIG_ENDIAN else "<"
            _version, next_off, _raw_off = struct.unpack(order + "IQQ", lead[8:28])
            if next_off == _INCOMPLETE:
                raise RecordingError(
                    f"{path}: TDMS segment {count + 1} at byte {pos} was never completed "
                    "(writer aborted or file truncated)"
                )
            end = pos + _LEAD_IN + next_off
            if end > size:
                raise RecordingError(
                    f"{path}: truncated TDMS file: segment {count + 1} needs {end} bytes, the file has {size}"
                )
            pos = end
            count += 1
    if count == 0:
        raise RecordingError(f"{path}: empty TDMS file")
    return count


class TdmsRecording(Recording):
    """A TDMS file; see the module docstring."""

    # npTDMS seeks and reads one shared file object: never from two threads.
    random_access = True
    thread_safe = False

    format = "tdms"

    def __init__(
        self,
        path: str,
        *,
        channels: Optional[Mapping[str, Optional[str]]] = None,
        fs: Optional[float] = None,
        scale: Optional[Mapping[str, float]] = None,
        units: Optional[Mapping[str, str]] = None,
        group: Optional[str] = None,
    ) -> None:
        super().__init__(path)
        self._file: Any = None
        from nptdms import TdmsFile  # local: keeps `import tribodyn.io` light

        n_segments = check_tdms_segments(self.path)
        # npTDMS raises assorted errors on bad metadata, hence Exception
        self._file = open_or_raise(lambda: TdmsFile.open(self.path), self.path, "cannot read TDMS metadata", Exception)
        with closing_on_error(self):
            self._open(channels, fs, scale, units, group, n_segments)

    def _open(
        self,
        channels: Optional[Mapping[str, Optional[str]]],
        fs: Optional[float],
        scale: Optional[Mapping[str, float]],
        units: Optional[Mapping[str, str]],
        group: Optional[str],
        n_segments: int,
    ) -> None:
        objs = []
        skipped: List[str] = []
        groups = self._file.groups()
        if group is not None:
            groups = [g for g in groups if g.name == group]
            if not groups:
                avail = ", ".join(repr(g.name) for g in self._file.groups())
                raise RecordingError(f"{self.path}: no TDMS group {group!r}; groups: {avail}")
        for g in groups:
            for c in g.channels():
                kind = np.dtype(c.dtype).kind if c.dtype is not None else "O"
                if kind in "biuf" and len(c) > 0:
                    objs.append((g.name, c))
                else:
                    skipped.append(f"{g.name}/{c.name}")
        counts: Dict[str, int] = {}
        for _, c in objs:
            counts[c.name] = counts.get(c.name, 0) + 1
        full: Dict[str, Any] = {}
        for gname, c in objs:
            name = c.name if counts[c.name] == 1 else f"{gname}/{c.name}"
            full[name] = c
        lengths = {n: len(c) for n, c in full.items()}
        aliases = {f"{gname}/{c.name}": (c.name if counts[c.name] == 1 else f"{gname}/{c.name}") for gname, c in objs}
        self._aliases = aliases
        wanted = [
            resolve_name(self.path, list(full), v, f"channel for role {k!r}", aliases)
            for k, v in (channels or {}).items()
            if v is not None
        ]
        names, n, other = equal_length_selection(self.path, lengths, wanted)
        skipped += other
        self._objs = {nm: full[nm] for nm in names}
        self._names = names
        self._n = n
        self._raw_units = {
            nm: (str(c.properties.get("unit_string")).strip() or None)
            if c.properties.get("unit_string") is not None
            else None
            for nm, c in self._objs.items()
        }
        incs = {}
        for nm, c in self._objs.items():
            inc = c.properties.get("wf_increment")
            if inc is not None:
                try:
                    incs[nm] = float(inc)
                except (TypeError, ValueError):
                    pass
        if incs:
            vals = list(incs.values())
            if max(vals) - min(vals) > 1e-9 * max(abs(v) for v in vals):
                detail = ", ".join(f"{k!r}: {v:g}" for k, v in incs.items())
                raise RecordingError(
                    f"{self.path}: channels have different wf_increment ({detail}); "
                    "map channels of one rate with channels="
                )
            if vals[0] > 0:
                self._file_fs = rate_from_step(vals[0])
                self._fs_source = f"1/wf_increment ({vals[0]:g} s)"
        self.metadata = {
            "properties": {k: _plain(v) for k, v in self._file.properties.items()},
            "groups": [g.name for g in self._file.groups()],
            "tdms_segments": n_segments,
        }
        if skipped:
            self.metadata["skipped"] = skipped
        self._default_roles = roles_by_name(self._names)
        self._setup(channels, fs, scale, units)

    def _read_range(self, names: Sequence[str], start: int, stop: int) -> Dict[str, np.ndarray]:
        out = {}
        for nm in names:
            try:
                a = self._objs[nm].read_data(start, stop - start)
            except Exception as exc:  # noqa: BLE001 - npTDMS errors vary
                raise RecordingError(f"{self.path}: cannot read channel {nm!r}: {exc}") from None
            if len(a) != stop - start:
                raise RecordingError(
                    f"{self.path}: channel {nm!r} has {len(a)} samples in {start}:{stop} (truncated or corrupt file)"
                )
            out[nm] = np.asarray(a)
        return out

    def _close(self) -> None:
        f, self._file = getattr(self, "_file", None), None
        if f is not None:
            f.close()


def _plain(v: Any) -> Any:
    """Property value for display: numpy scalars and datetimes as Python/str."""
    if isinstance(v, np.generic):
        return v.item() if v.dtype.kind in "biuf" else str(v)
    return v if isinstance(v, (int, float, str, bool)) or v is None else str(v)
