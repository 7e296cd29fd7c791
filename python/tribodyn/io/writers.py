"""Writing files safely: atomic replacement, checksums and recording writers.

:func:`atomic_write` writes through a temporary file in the target's
directory and renames it over the target (``os.replace``), so a reader never
sees a partial file and a failed write leaves nothing behind.
:func:`save_npz`, :func:`save_hdf5`, :func:`save_tdms` and :func:`save_npy`
write recordings (``tribodyn simulate --out FILE``) that
:func:`tribodyn.io.open_recording` reads back with the same channel names,
units and sampling rate (``.npy`` keeps neither names nor fs: see
:func:`save_npy`).
"""

from __future__ import annotations

import errno
import json
import math
import os
import tempfile
from typing import Any, Callable, Dict, List, Mapping, Optional, Union

import numpy as np

from .. import _core

__all__ = [
    "atomic_write",
    "save_hdf5",
    "save_npy",
    "save_npz",
    "save_recording",
    "save_tdms",
    "sha256_file",
]

PathLike = Union[str, "os.PathLike[str]"]

# Metadata members, and np.savez's own argument names (a channel "allow_pickle"
# would be taken as the flag and dropped; "file" would clash).
_RESERVED_NPZ = ("fs", "units", "dt", "sampling_rate", "file", "allow_pickle")


def atomic_write(path: PathLike, write_fn: Callable[[str], object], *, durable: bool = True) -> None:
    """Creates or replaces ``path`` atomically.

    Parameters
    ----------
    path : str or PathLike
        Target file.
    write_fn : callable
        Called with the path (str) of a fresh empty temporary file in the
        same directory; it must write the complete content there (opening it
        itself, e.g. ``open(tmp, 'wb')``, ``h5py.File(tmp, 'w')``).
    durable : bool
        Flush the file and its folder to disk (default). False for a file replaced again soon (a watch's live
        outputs): still atomic for every reader, but a power cut may leave the previous version.

    Raises
    ------
    OSError
        The directory is missing or not writable, the disk is full, the file
        system is read-only...: the error names ``path`` (not the temporary
        file), keeps its class and ``errno``.

    Notes
    -----
    The temporary file is flushed to disk and renamed over ``path``; its
    permissions follow the umask like a normally created file. A symbolic
    link at ``path`` is replaced by the file, never written through. If
    ``write_fn`` (or anything after it) raises, the temporary file is removed
    and the exception propagates: ``path`` is then either untouched or absent,
    never partial.
    """
    target = os.path.abspath(os.fspath(path))
    directory = os.path.dirname(target)
    if os.path.isdir(target):
        raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), target)
    base = os.path.basename(target)
    _, ext = os.path.splitext(base)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{base}.", suffix=f".tmp{ext}", dir=directory)
    except OSError as exc:
        raise _naming(exc, target) from None
    try:
        os.close(fd)
        write_fn(tmp)
        if durable:
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, target)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(exc, OSError) and exc.filename in (tmp, None):
            raise _naming(exc, target) from None
        raise
    if durable:
        _fsync_dir(directory)


def _naming(exc: OSError, target: str) -> OSError:
    """``exc`` (same class and errno) naming ``target`` instead of a temporary file."""
    if exc.errno is None:
        return exc
    try:
        return type(exc)(exc.errno, exc.strerror, target)
    except TypeError:  # pragma: no cover - an OSError subclass with another signature
        return exc


def _fsync_dir(directory: PathLike) -> None:
    """Best effort: makes a rename in ``directory`` durable (POSIX only)."""
    if os.name != "posix":
        return
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


#: Bytes of a file hashed per step of ``_core.FileDigest`` (a step runs without the GIL: ~50 ms at 1.3 GB/s).
DIGEST_STEP = 64 << 20


def sha256_file(path: PathLike, chunk_size: int = DIGEST_STEP) -> str:
    """Hex SHA-256 digest of a file, hashed natively (``_core.FileDigest``, without the GIL) in steps of
    ``chunk_size`` bytes: a thread hashing a large input is not held back by a thread that holds the GIL, as
    ``hashlib`` is after each block (issue 38 point 3). OSError when the file cannot be read."""
    digest = _core.FileDigest(os.fspath(path))
    while not digest.advance(chunk_size):
        pass
    return str(digest.hexdigest())


def _checked(channels: Mapping[str, np.ndarray], fs: Optional[float]) -> Dict[str, np.ndarray]:
    """Channels as 1-D numeric arrays of one length; fs finite and > 0."""
    if fs is not None and not (isinstance(fs, (int, float, np.number)) and math.isfinite(float(fs)) and float(fs) > 0):
        raise ValueError(f"fs must be a finite number > 0, got {fs!r}")
    if not channels:
        raise ValueError("channels is empty")
    out: Dict[str, np.ndarray] = {}
    n = None
    for name, a in channels.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"channel names must be non-empty strings, got {name!r}")
        arr = np.asarray(a)
        if arr.ndim != 1 or arr.dtype.kind not in "biuf":
            raise ValueError(f"channel {name!r} must be a 1-D numeric array, got {arr.dtype} {arr.shape}")
        if n is None:
            n = arr.shape[0]
        elif arr.shape[0] != n:
            raise ValueError(f"channel {name!r} has {arr.shape[0]} samples, the first one {n}")
        out[name] = arr
    if not n:
        raise ValueError("channels hold no samples")
    return out


def _units_for(units: Optional[Mapping[str, str]], names: List[str]) -> Dict[str, str]:
    if not units:
        return {}
    extra = set(units) - set(names)
    if extra:
        raise ValueError(f"units names unknown channels: {sorted(extra)}")
    return {k: str(v) for k, v in units.items() if v is not None}


def save_npz(
    path: PathLike,
    channels: Mapping[str, np.ndarray],
    fs: float,
    units: Optional[Mapping[str, str]] = None,
    *,
    compress: bool = False,
) -> None:
    """Writes a recording as ``.npz``: one member per channel, plus ``fs`` and ``units``.

    Parameters
    ----------
    path : str or PathLike
        Target (``.npz`` is *not* appended).
    channels : mapping of str to array
        1-D arrays of one length; names ``fs``, ``units``, ``dt`` and
        ``sampling_rate`` are reserved.
    fs : float
        Sampling rate in Hz (stored as the scalar member ``fs``).
    units : mapping of str to str, optional
        Channel -> unit, stored as a JSON text member ``units``.
    compress : bool
        Use ``np.savez_compressed``.
    """
    ch = _checked(channels, fs)
    bad = [k for k in ch if k in _RESERVED_NPZ or "/" in k]
    if bad:
        raise ValueError(f"channel names {bad} are reserved or contain '/' (not allowed in .npz)")
    # Any: the members go to np.savez as keyword arguments (its stubs type them as ArrayLike or bool)
    members: Dict[str, Any] = dict(ch)
    members["fs"] = np.array(float(fs))
    u = _units_for(units, list(ch))
    if u:
        members["units"] = np.array(json.dumps(u))
    saver = np.savez_compressed if compress else np.savez

    def write(tmp: str) -> None:
        with open(tmp, "wb") as fh:
            saver(fh, **members)

    atomic_write(path, write)


def save_hdf5(
    path: PathLike,
    channels: Mapping[str, np.ndarray],
    fs: float,
    units: Optional[Mapping[str, str]] = None,
) -> None:
    """Writes a recording as HDF5: one dataset per channel, attribute ``fs`` on the file.

    Channel names may contain ``/`` (groups are created). Each dataset gets
    an attribute ``unit`` when ``units`` names it.
    """
    import h5py

    ch = _checked(channels, fs)
    u = _units_for(units, list(ch))

    def write(tmp: str) -> None:
        with h5py.File(tmp, "w") as f:
            f.attrs["fs"] = float(fs)
            f.attrs["creator"] = "tribodyn"
            for name, a in ch.items():
                d = f.create_dataset(name, data=a)
                if name in u:
                    d.attrs["unit"] = u[name]

    atomic_write(path, write)


def save_tdms(
    path: PathLike,
    channels: Mapping[str, np.ndarray],
    fs: float,
    units: Optional[Mapping[str, str]] = None,
    *,
    group: str = "tribodyn",
    segment_samples: int = 65536,
) -> None:
    """Writes a recording as TDMS (npTDMS ``TdmsWriter``), one group of channels.

    Each channel carries ``wf_increment = 1/fs``, ``wf_start_offset = 0`` and
    ``wf_samples``, plus ``unit_string`` when ``units`` names it. Data are
    written in segments of ``segment_samples`` samples, as a DAQ logger
    would: npTDMS reads a whole raw-data chunk at a time, so this keeps the
    reader's memory bounded.
    """
    if segment_samples < 1:
        raise ValueError(f"segment_samples must be >= 1, got {segment_samples}")
    from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

    ch = _checked(channels, fs)
    u = _units_for(units, list(ch))
    if any("/" in k for k in ch):
        raise ValueError("TDMS channel names must not contain '/'")

    def write(tmp: str) -> None:
        n = next(iter(ch.values())).shape[0]
        with TdmsWriter(tmp) as w:
            for start in range(0, n, segment_samples):
                stop = min(start + segment_samples, n)
                objs: List[Any] = []
                if start == 0:
                    objs = [RootObject(properties={"creator": "tribodyn"}), GroupObject(group)]
                for name, a in ch.items():
                    props: Dict[str, Union[str, float, int]] = {}
                    if start == 0:
                        props = {
                            "wf_increment": 1.0 / float(fs),
                            "wf_start_offset": 0.0,
                            "wf_samples": int(n),
                        }
                        if name in u:
                            props["unit_string"] = u[name]
                    block = np.ascontiguousarray(a[start:stop])
                    objs.append(ChannelObject(group, name, block, properties=props))
                w.write_segment(objs)

    atomic_write(path, write)


def save_npy(path: PathLike, channels: Mapping[str, np.ndarray]) -> List[str]:
    """Writes channels as one ``(n_channels, n_samples)`` float64 ``.npy`` array.

    A ``.npy`` holds no names and no sampling rate: read it back with
    ``open_recording(path, fs=...)``; channel ``ch{k}`` is the k-th entry of
    the returned list. The reader takes a 2-D array as channels x samples
    unless ``n_channels >= 10 * n_samples``; such (odd) input is refused here
    so the round trip is exact.

    Returns
    -------
    list of str
        The channel names in row order.
    """
    ch = _checked(channels, None)
    names = list(ch)
    arr = np.stack([np.asarray(a, dtype=np.float64) for a in ch.values()])
    if arr.shape[0] >= 10 * arr.shape[1]:
        raise ValueError(
            "more channels than 1/10 of the samples: the reader would take the array as samples x channels"
        )

    def write(tmp: str) -> None:
        with open(tmp, "wb") as fh:
            np.save(fh, arr)

    atomic_write(path, write)
    return names


def save_recording(
    path: PathLike,
    channels: Mapping[str, np.ndarray],
    fs: float,
    units: Optional[Mapping[str, str]] = None,
) -> None:
    """Writes a recording in the format given by the extension (.npz, .h5/.hdf5, .tdms)."""
    ext = os.path.splitext(os.fspath(path))[1].lower()
    if ext == ".npz":
        save_npz(path, channels, fs, units)
    elif ext in (".h5", ".hdf5", ".hdf"):
        save_hdf5(path, channels, fs, units)
    elif ext == ".tdms":
        save_tdms(path, channels, fs, units)
    else:
        raise ValueError(f"cannot write recordings as {ext!r}: use .npz, .h5/.hdf5 or .tdms")
