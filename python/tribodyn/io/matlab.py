"""MATLAB MAT-files (``.mat``): versions 4 and 5 (incl. v7, compressed) through :func:`scipy.io.loadmat`,
version 7.3 (an HDF5 file behind a 512-byte MATLAB header) through h5py.

Channels are the numeric variables, by their MATLAB names:

* a vector, of shape ``(N,)``, ``(N, 1)`` or ``(1, N)``, is one channel named as the variable;
* a matrix of shape ``(N, k)`` with ``N >= 10 k`` (or ``(k, N)``, ``k`` up to 64) is ``k`` channels
  named ``name(:,1)`` ... ``name(:,k)`` (``name(1,:)`` ... for rows);
* a scalar struct's fields are channels too, named ``struct.field`` (structs within structs, up to
  three levels);
* a scalar ``fs``, ``Fs``, ``sampling_rate`` (Hz) or ``dt`` (s) gives the sampling rate; else a time
  vector (``t``, ``time``, ``Time``, ``Zeit``...; or ``time_column=``) gives it from its median step.

Channels of one length are kept: those of the channels mapped with ``channels=``, else the longest;
the others are listed in ``metadata['skipped']``. Text, cell arrays, logical and complex
variables are not channels. A MAT-file carries no units: a unit is taken only from ``units=``.
The file is read whole (MAT-files are compressed or laid out by variable, not by sample).
"""

from __future__ import annotations

from typing import Any, Dict, List, Mapping, Optional, Tuple

import numpy as np

from .base import RecordingError, equal_length_selection, rate_from_step, roles_by_name
from .detect import MAT73_HEADER, describe_content, is_mat73, sniff_mat
from .tables import TableRecording

__all__ = ["MAT73_HEADER", "MatRecording", "is_mat73", "sniff_mat"]

#: Columns (or rows) of a matrix read as channels at most.
_MAX_MATRIX_CHANNELS = 64
#: Variables and struct fields looked at, at most (a file of millions of tiny variables is refused).
_MAX_VARIABLES = 10_000
_RATE_NAMES = {"fs": "Hz", "sampling_rate": "Hz", "samplingrate": "Hz", "srate": "Hz", "dt": "s"}


class _Collector:
    """Numeric 1-D channels found among a file's variables, in file order."""

    def __init__(self, path: str) -> None:
        self.path = path
        self.columns: Dict[str, np.ndarray] = {}
        self.rate: Optional[Tuple[float, str]] = None
        self.other: List[str] = []
        self.seen = 0

    def add(self, name: str, value: Any, depth: int = 0) -> None:
        self.seen += 1
        if self.seen > _MAX_VARIABLES:
            raise RecordingError(f"{self.path}: more than {_MAX_VARIABLES} variables and fields: not a recording")
        if isinstance(value, dict):  # a struct read by h5py (v7.3)
            if depth >= 3:
                self.other.append(name)
                return
            for k, v in value.items():
                self.add(f"{name}.{k}", v, depth + 1)
            return
        a = np.asarray(value)
        if a.dtype.names is not None:  # a struct read by scipy: a record array
            if a.size != 1 or depth >= 3:
                self.other.append(name)
                return
            rec = a.reshape(-1)[0]
            for k in a.dtype.names:
                self.add(f"{name}.{k}", rec[k], depth + 1)
            return
        if a.dtype == object and a.size == 1:  # a struct field as scipy wraps it
            self.add(name, a.reshape(-1)[0], depth)
            return
        if a.dtype.kind not in "iuf":
            self.other.append(name)
            return
        if a.ndim > 2 and sum(s > 1 for s in a.shape) <= 2:
            a = a.reshape([s for s in a.shape if s > 1] or [1])
        if a.size == 1:
            key = name.rsplit(".", 1)[-1].lower()
            v = float(a.reshape(-1)[0])
            if self.rate is None and key in _RATE_NAMES and np.isfinite(v) and v > 0:
                hz = v if _RATE_NAMES[key] == "Hz" else rate_from_step(v)
                self.rate = (hz, f"variable {name!r}" if key != "dt" else f"1/variable {name!r}")
            return
        if a.ndim == 1 or (a.ndim == 2 and min(a.shape) == 1):
            self.columns[name] = a.reshape(-1)
            return
        if a.ndim == 2:
            rows, cols = a.shape
            if rows >= 10 * cols and cols <= _MAX_MATRIX_CHANNELS:
                for j in range(cols):
                    self.columns[f"{name}(:,{j + 1})"] = a[:, j]
                return
            if cols >= 10 * rows and rows <= _MAX_MATRIX_CHANNELS:
                for j in range(rows):
                    self.columns[f"{name}({j + 1},:)"] = a[j, :]
                return
        self.other.append(name)


class MatRecording(TableRecording):
    """A MAT-file (see the module docstring)."""

    format = "mat"

    def __init__(
        self,
        path: str,
        *,
        channels: Optional[Mapping[str, Optional[str]]] = None,
        fs: Optional[float] = None,
        scale: Optional[Mapping[str, float]] = None,
        units: Optional[Mapping[str, str]] = None,
        time_column: Optional[str] = None,
        time_channel: Optional[str] = None,
        resample: Optional[float] = None,
    ) -> None:
        super().__init__(path)
        with open(self.path, "rb") as fh:
            head = fh.read(128)
        found = _Collector(self.path)
        if is_mat73(head):
            self.metadata["version"] = "7.3 (HDF5)"
            _read_73(self.path, found)
        else:
            self.metadata["version"] = "5" if head[:116].startswith(b"MATLAB") else "4"
            _read_v45(self.path, found)
        if not found.columns:
            kinds = f" (variables: {', '.join(found.other[:8])})" if found.other else ""
            raise RecordingError(f"{self.path}: no numeric vector in this MAT-file{kinds}")
        wanted = [v for v in (channels or {}).values() if v is not None and v in found.columns]
        lengths = {k: int(v.size) for k, v in found.columns.items()}
        if wanted:
            names, _n, skipped = equal_length_selection(self.path, lengths, wanted)
        else:
            longest = max(lengths.values())
            names = [k for k, v in lengths.items() if v == longest]
            skipped = [k for k, v in lengths.items() if v != longest]
        if skipped or found.other:
            self.metadata["skipped"] = skipped + found.other
        cols = {k: found.columns[k] for k in names}
        # Roles by name from a struct field's own name (test.friction_force -> friction_force) when unique.
        short = [k.rsplit(".", 1)[-1] for k in names]
        by_short = {s: k for s, k in zip(short, names) if short.count(s) == 1}
        roles = {r: by_short[s] for r, s in roles_by_name(list(by_short)).items()}
        self.open_table(
            cols,
            {k: None for k in names},
            channels=channels,
            fs=fs,
            scale=scale,
            given_units=units,
            time_column=time_column or time_channel,
            resample=resample,
            file_fs=found.rate if (time_column or time_channel) is None else None,
            default_roles=roles,
        )


def _read_v45(path: str, found: _Collector) -> None:
    import scipy.io

    try:
        data = scipy.io.loadmat(path, squeeze_me=False, struct_as_record=True, mat_dtype=False)
    except NotImplementedError as exc:  # "Please use HDF reader for matlab v7.3 files"
        raise RecordingError(f"{path}: cannot read this MAT-file: {exc}") from None
    except (ValueError, TypeError, OSError, EOFError, MemoryError, OverflowError, IndexError, KeyError) as exc:
        msg = " ".join(str(exc).split())[:200] or type(exc).__name__
        what = describe_content(path)
        hint = (
            "corrupt or truncated?"
            if what in ("a MATLAB MAT-file", "binary content of no supported kind")
            else (f"its content is {what}")
        )
        raise RecordingError(f"{path}: not a readable MAT-file ({hint}): {msg}") from None
    for name, value in data.items():
        if not name.startswith("__"):
            found.add(name, value)


def _read_73(path: str, found: _Collector) -> None:
    import h5py

    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise RecordingError(f"{path}: not a readable MAT-file 7.3 (corrupt HDF5?): {exc}") from None
    with f:
        for name, obj in f.items():
            if name.startswith("#"):  # #refs#, #subsystem#: MATLAB's own
                continue
            value = _h5_value(path, obj, 0)
            if value is not None:
                found.add(name, value)


def _h5_value(path: str, obj: Any, depth: int) -> Any:
    """A v7.3 variable as a NumPy array (transposed back to MATLAB's shape) or a dict (struct), None if not numeric."""
    import h5py

    cls = obj.attrs.get("MATLAB_class", b"")
    cls = cls.decode("ascii", "replace") if isinstance(cls, bytes) else str(cls)
    if isinstance(obj, h5py.Group):
        if cls != "struct" or depth >= 3:
            return None
        return {k: v for k, v in ((k, _h5_value(path, o, depth + 1)) for k, o in obj.items()) if v is not None}
    if not isinstance(obj, h5py.Dataset) or cls not in ("double", "single", "int8", "uint8", "int16", "uint16",
                                                       "int32", "uint32", "int64", "uint64"):  # fmt: skip
        return None
    if obj.attrs.get("MATLAB_empty", 0):
        return None
    if obj.dtype.kind not in "iuf" or obj.ndim > 2:
        return None
    nbytes = obj.size * obj.dtype.itemsize
    stored = obj.id.get_storage_size()
    if obj.compression is None and stored < nbytes:
        raise RecordingError(
            f"{path}: variable {obj.name.lstrip('/')!r} declares {obj.size} values but holds {stored} of "
            f"{nbytes} bytes (truncated or never written)"
        )
    try:
        a = obj[()]
    except (OSError, ValueError) as exc:
        raise RecordingError(f"{path}: cannot read variable {obj.name.lstrip('/')!r}: {exc}") from None
    return np.asarray(a).T  # HDF5 holds MATLAB's column-major arrays transposed
