"""HDF5 files, read with h5py by slicing datasets per block.

Channels are the 1-D numeric datasets at any group depth, named by their
path without the leading ``/`` (``fy``, ``run1/forces/fz``); the last path
component alone is accepted where unique. All channels must have one length
(datasets of other lengths are skipped when the mapped channels agree, see
:func:`~tribodyn.io.base.equal_length_selection`).

The sampling rate is looked up on each channel's dataset, then its parent
groups up to the file root, as an attribute ``fs``, ``sampling_rate`` or
``sample_rate`` (Hz) or ``dt`` / ``wf_increment`` (s); a scalar dataset
named ``fs`` at the root works too; else ``time_channel=`` names a dataset
of times (s) whose median step gives fs. Units come from an attribute ``unit``,
``units`` or ``unit_string``.
"""

from __future__ import annotations

import math
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

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

__all__ = ["Hdf5Recording"]

_RATE_ATTRS = ("fs", "sampling_rate", "sample_rate")
_STEP_ATTRS = ("dt", "wf_increment")
_UNIT_ATTRS = ("unit", "units", "unit_string")


def _scalar(v: Any) -> Optional[float]:
    try:
        a = np.asarray(v)
        if a.size != 1 or a.dtype.kind not in "biuf":
            return None
        x = float(a.reshape(()))
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) and x > 0 else None


def _text(v: Any) -> Optional[str]:
    if isinstance(v, bytes):
        v = v.decode("utf-8", "replace")
    if isinstance(v, np.ndarray) and v.size == 1:
        return _text(v.reshape(()).item())
    if isinstance(v, str):
        return v.strip() or None
    return None


def _rate_of(obj: Any) -> Optional[Tuple[float, str]]:
    """(fs, source) from an object's attributes, or None."""
    for key in _RATE_ATTRS:
        if key in obj.attrs:
            v = _scalar(obj.attrs[key])
            if v is not None:
                return v, f"attribute {key!r} of {obj.name!r}"
    for key in _STEP_ATTRS:
        if key in obj.attrs:
            v = _scalar(obj.attrs[key])
            if v is not None:
                return rate_from_step(v), f"1/attribute {key!r} of {obj.name!r}"
    return None


class Hdf5Recording(Recording):
    """An HDF5 file; see the module docstring."""

    # h5py serialises calls with a global lock, but one handle's reads are
    # not proven safe to interleave: read from one thread at a time.
    random_access = True
    thread_safe = False

    format = "hdf5"

    def __init__(
        self,
        path: str,
        *,
        channels: Optional[Mapping[str, Optional[str]]] = None,
        fs: Optional[float] = None,
        scale: Optional[Mapping[str, float]] = None,
        units: Optional[Mapping[str, str]] = None,
        group: Optional[str] = None,
        time_channel: Optional[str] = None,
    ) -> None:
        super().__init__(path)
        import h5py  # local: keeps `import tribodyn.io` light

        self._h5: Any = None
        self._h5 = open_or_raise(
            lambda: h5py.File(self.path, "r"),
            self.path,
            "cannot open as HDF5 (truncated or corrupt?)",
            OSError,
        )
        with closing_on_error(self):
            self._open(h5py, channels, fs, scale, units, group, time_channel)

    def _open(
        self,
        h5py: Any,
        channels: Optional[Mapping[str, Optional[str]]],
        fs: Optional[float],
        scale: Optional[Mapping[str, float]],
        units: Optional[Mapping[str, str]],
        group: Optional[str],
        time_channel: Optional[str],
    ) -> None:
        root = self._h5
        if group is not None:
            if group not in root or not isinstance(root[group], h5py.Group):
                raise RecordingError(f"{self.path}: no HDF5 group {group!r}")
            root = root[group]
        found: Dict[str, Any] = {}
        skipped: List[str] = []

        def visit(name: str, obj: Any) -> None:
            if isinstance(obj, h5py.Dataset):
                full = obj.name.lstrip("/")
                if obj.ndim == 1 and obj.dtype.kind in "biuf" and obj.shape[0] > 0:
                    found[full] = obj
                elif obj.ndim != 0:
                    skipped.append(full)

        try:
            root.visititems(visit)
        except (OSError, RuntimeError) as exc:
            raise RecordingError(f"{self.path}: corrupt HDF5 file: {exc}") from None
        if not found:
            raise RecordingError(f"{self.path}: no 1-D numeric dataset in this HDF5 file")
        lengths = {k: int(d.shape[0]) for k, d in found.items()}
        wanted = [
            resolve_name(self.path, list(found), v, f"channel for role {k!r}")
            for k, v in (channels or {}).items()
            if v is not None
        ]
        names, n, other = equal_length_selection(self.path, lengths, wanted)
        skipped += other
        self._dsets = {k: found[k] for k in names}
        self._names = names
        self._n = n
        self._raw_units = {}
        for k, d in self._dsets.items():
            u = None
            for key in _UNIT_ATTRS:
                if key in d.attrs:
                    u = _text(d.attrs[key])
                    if u:
                        break
            self._raw_units[k] = u
        # sampling rate: per channel, nearest definition up the tree
        rates: Dict[str, Tuple[float, str]] = {}
        for k, d in self._dsets.items():
            obj = d
            while True:
                r = _rate_of(obj)
                if r is not None:
                    rates[k] = r
                    break
                if obj.name == "/":
                    break
                obj = obj.parent
        if not rates and "fs" in self._h5 and isinstance(self._h5["fs"], h5py.Dataset):
            v = _scalar(self._h5["fs"][()])
            if v is not None:
                rates = {k: (v, "dataset '/fs'") for k in self._dsets}
        if rates:
            vals = [r[0] for r in rates.values()]
            if max(vals) - min(vals) > 1e-9 * max(vals):
                detail = ", ".join(f"{k!r}: {r[0]:g} Hz" for k, r in rates.items())
                raise RecordingError(f"{self.path}: channels have different sampling rates ({detail})")
            self._file_fs, self._fs_source = next(iter(rates.values()))
        elif time_channel is not None:
            self._fs_from_time_channel(time_channel)
        self.metadata = {"attributes": {k: _attr(v) for k, v in self._h5.attrs.items()}}
        if skipped:
            self.metadata["skipped"] = skipped
        self._default_roles = roles_by_name(self._names)
        self._setup(channels, fs, scale, units)

    _owned_reads = True  # h5py returns a new array for every slice

    def _read_range(self, names: Sequence[str], start: int, stop: int) -> Dict[str, np.ndarray]:
        out = {}
        for nm in names:
            try:
                out[nm] = self._dsets[nm][start:stop]
            except (OSError, RuntimeError) as exc:
                raise RecordingError(f"{self.path}: cannot read {nm!r} (corrupt file?): {exc}") from None
        return out

    def _close(self) -> None:
        f, self._h5 = getattr(self, "_h5", None), None
        if f is not None:
            try:
                f.close()
            except Exception:  # noqa: BLE001, S110  # pragma: no cover - h5py closing a broken file
                pass


def _attr(v: Any) -> Any:
    t = _text(v)
    if t is not None:
        return t
    s = _scalar(v)
    if s is not None:
        return s
    return str(v)
