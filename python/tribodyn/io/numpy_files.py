"""NumPy ``.npy`` and ``.npz`` files.

``.npy``
    Memory-mapped (``np.load(mmap_mode='r')``); chunks are slices of the map.
    A 1-D array is one channel; a 2-D array of shape ``(a, b)`` is read as
    ``(channels, samples)`` unless ``a >= 10 * b``, in which case it is
    ``(samples, channels)`` (e.g. ``(25600, 3)``: 3 channels). Pass
    ``layout='channels_first'`` or ``'samples_first'`` to decide yourself.
    Channels are named ``ch0``, ``ch1``... (or ``names=[...]``). A ``.npy``
    carries no sampling rate: pass ``fs=`` or ``time_channel='ch0'`` (fs from
    the median step of that channel).
``.npz``
    Each 1-D numeric member (or one of shape ``(N, 1)`` or ``(1, N)``) is a
    channel named by its key. Scalar members
    ``fs`` (Hz) or ``dt`` (s) give the sampling rate, a 0-d text member
    ``units`` a JSON object channel -> unit (as written by
    :func:`tribodyn.io.writers.save_npz`). A zip member cannot be
    memory-mapped, so each channel's member is *streamed*: its ``.npy`` header
    is parsed and then ``chunk`` samples at a time are read from the member
    (decompressing incrementally for ``savez_compressed`` files), so memory
    stays O(chunk) here too; only random access is missing (a re-read starts
    again from the member's beginning).
"""

from __future__ import annotations

import ast
import json
import math
import mmap
import os
import struct
import zipfile
import zlib
from typing import IO, Any, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, Type

import numpy as np

from .. import _core
from ..kernels.threads import read_threads, thread_pool
from .base import Recording, RecordingError, equal_length_selection, rate_from_step, resolve_name, roles_by_name

__all__ = ["NpyRecording", "NpzRecording"]


#: Largest header accepted (numpy's own default limit for loading untrusted files).
_MAX_HEADER = 10000
#: Samples a channel from which the ranges of several channels are read a channel a thread (below, starting the
#: threads costs more than they save: the pre-pass's 2^16-sample sample is read on the calling thread).
_PARALLEL_READ = 1 << 18

#: What zipfile raises on a corrupt or unreadable member: a bad CRC or header, a corrupt compressed
#: stream (zlib.error; bz2 and lzma raise OSError / LZMAError), an unknown compression method
#: (NotImplementedError) or one whose module this Python lacks (RuntimeError).
_ZIP_ERRORS: Tuple[Type[BaseException], ...] = (zipfile.BadZipFile, OSError, EOFError, zlib.error,
                                                 NotImplementedError, RuntimeError)  # fmt: skip
try:
    import lzma

    _ZIP_ERRORS += (lzma.LZMAError,)
except ImportError:  # pragma: no cover - a Python built without lzma
    pass
_ZIP_OR_VALUE_ERRORS: Tuple[Type[BaseException], ...] = _ZIP_ERRORS + (ValueError,)


def _member_error(path: str, member: str, exc: BaseException) -> RecordingError:
    """The RecordingError of a member zipfile cannot read (see :data:`_ZIP_ERRORS`)."""
    if isinstance(exc, (NotImplementedError, RuntimeError)):
        return RecordingError(
            f"{path}: member {member!r} uses a compression method that cannot be read ({exc}); "
            "numpy writes stored or deflated members"
        )
    return RecordingError(f"{path}: corrupt member {member!r}: {exc}")


def _read_header_3_0(fh: IO[bytes]) -> Tuple[Any, Any, Any]:
    """(shape, fortran_order, dtype) of a format 3.0 header: a 2.0 header (4-byte length) encoded as utf-8.

    numpy has no public reader for it; this parses it with the checks numpy
    applies (:func:`numpy.lib.format.read_array_header_2_0` does the same
    for latin-1 text).
    """
    raw = fh.read(4)
    if len(raw) != 4:
        raise EOFError("file ends in the array header length")
    (hlen,) = struct.unpack("<I", raw)
    if hlen > _MAX_HEADER:
        raise ValueError(f"header length {hlen} exceeds {_MAX_HEADER}")
    text = fh.read(hlen)
    if len(text) != hlen:
        raise EOFError("file ends in the array header")
    d = ast.literal_eval(text.decode("utf-8"))
    if not isinstance(d, dict):
        raise ValueError(f"header is not a dictionary: {d!r}")
    if set(d) != {"descr", "fortran_order", "shape"}:
        raise ValueError(f"header does not contain the correct keys: {sorted(map(repr, d))}")
    shape = d["shape"]
    if not isinstance(shape, tuple) or not all(isinstance(x, int) for x in shape):
        raise ValueError(f"shape is not valid: {shape!r}")
    if not isinstance(d["fortran_order"], bool):
        raise ValueError(f"fortran_order is not a valid bool: {d['fortran_order']!r}")
    return shape, d["fortran_order"], np.lib.format.descr_to_dtype(d["descr"])


def _read_npy_header(fh: IO[bytes], where: str) -> Tuple[Tuple[int, ...], bool, np.dtype]:
    """(shape, fortran_order, dtype) from an open ``.npy`` stream positioned at its start.

    Uses numpy's public header readers (format 1.0 and 2.0) and
    :func:`_read_header_3_0`. Whatever a corrupt header makes them raise
    (``ValueError``, ``SyntaxError``, ``tokenize.TokenError``, ``TypeError``,
    ``OverflowError``...) is a :class:`RecordingError`, as are a negative
    dimension and a bool where an integer belongs.
    """
    fmt = np.lib.format
    try:
        version = fmt.read_magic(fh)
        if version == (1, 0):
            shape, fortran, dtype = fmt.read_array_header_1_0(fh, max_header_size=_MAX_HEADER)
        elif version == (2, 0):
            shape, fortran, dtype = fmt.read_array_header_2_0(fh, max_header_size=_MAX_HEADER)
        elif version == (3, 0):
            shape, fortran, dtype = _read_header_3_0(fh)
        else:
            raise ValueError(f"unknown .npy format version {version[0]}.{version[1]}")
        dtype = np.dtype(dtype)
    except Exception as exc:  # noqa: BLE001 - numpy's parsers raise assorted errors on corrupt headers
        msg = " ".join(str(exc).split())[:200] or type(exc).__name__
        raise RecordingError(f"{where}: not a valid .npy header ({msg})") from None
    if any(isinstance(s, bool) or s < 0 for s in shape):
        raise RecordingError(f"{where}: not a valid .npy header (shape {tuple(shape)!r})")
    return tuple(int(s) for s in shape), bool(fortran), dtype


class NpyRecording(Recording):
    """A memory-mapped ``.npy`` file; see the module docstring."""

    # Reads with pread or from a read-only map (no shared file position);
    # float64 channels-first files are laid out for the kernel.
    random_access = True
    thread_safe = True
    mappable = True
    views = True

    format = "npy"

    def __init__(
        self,
        path: str,
        *,
        channels: Optional[Mapping[str, Optional[str]]] = None,
        fs: Optional[float] = None,
        scale: Optional[Mapping[str, float]] = None,
        units: Optional[Mapping[str, str]] = None,
        layout: Optional[str] = None,
        names: Optional[Sequence[str]] = None,
        time_channel: Optional[str] = None,
    ) -> None:
        super().__init__(path)
        self._arr: Any = None
        # One descriptor, opened here, for every read: the recording stays
        # the file it was opened on even if the path is later replaced.
        try:
            self._fd = os.open(self.path, os.O_RDONLY)
        except OSError as exc:
            raise RecordingError(f"{self.path}: cannot open: {exc.strerror or exc}") from None
        try:
            self._open_npy(channels, fs, scale, units, layout=layout, names=names, time_channel=time_channel)
        except BaseException:
            self._close()
            raise

    def _open_npy(
        self,
        channels: Optional[Mapping[str, Optional[str]]],
        fs: Optional[float],
        scale: Optional[Mapping[str, float]],
        units: Optional[Mapping[str, str]],
        *,
        layout: Optional[str],
        names: Optional[Sequence[str]],
        time_channel: Optional[str],
    ) -> None:
        assert self._fd is not None
        with open(self._fd, "rb", closefd=False) as fh:
            shape, fortran, dtype = _read_npy_header(fh, self.path)
            data_offset = fh.tell()
            if dtype.hasobject or dtype.kind not in "biuf":
                raise RecordingError(f"{self.path}: .npy of dtype {dtype} is not numeric signal data")
            expected = data_offset + math.prod(shape) * dtype.itemsize  # Python ints: no overflow
            size = os.fstat(self._fd).st_size
            if size < expected:
                raise RecordingError(f"{self.path}: truncated .npy file ({size} bytes, its header needs {expected})")
            try:
                # What np.load(mmap_mode="r") does, on this descriptor.
                arr = np.memmap(
                    fh, dtype=dtype, mode="r", offset=data_offset, shape=shape, order="F" if fortran else "C"
                )
            except (ValueError, OSError) as exc:
                raise RecordingError(f"{self.path}: cannot map .npy file: {exc}") from None
        if arr.ndim == 1:
            arr = arr.reshape(1, -1)  # type: ignore[assignment]  # a memmap's reshape is a memmap
            self._rows_are_channels = True
        elif arr.ndim == 2:
            if layout is None:
                self._rows_are_channels = not (arr.shape[0] >= 10 * arr.shape[1])
            elif layout in ("channels_first", "samples_first"):
                self._rows_are_channels = layout == "channels_first"
            else:
                raise RecordingError(f"layout must be 'channels_first' or 'samples_first', got {layout!r}")
        else:
            raise RecordingError(f"{self.path}: .npy array of shape {arr.shape}: need 1-D or 2-D")
        if arr.size == 0:
            raise RecordingError(f"{self.path}: .npy array of shape {tuple(shape)} holds no samples")
        self._arr = arr
        nch, n = arr.shape if self._rows_are_channels else arr.shape[::-1]
        if names is not None:
            names = [str(x) for x in names]
            if len(names) != nch or len(set(names)) != nch:
                raise RecordingError(
                    f"{self.path}: names must be {nch} distinct names (the file holds {nch} channels of {n} samples, "
                    f"{'one a row' if self._rows_are_channels else 'one a column'}), got {names!r}"
                )
            self._names = names
        else:
            self._names = [f"ch{k}" for k in range(nch)]
        self._n = int(n)
        self._raw_units = {nm: None for nm in self._names}
        self.metadata = {
            "shape": list(np.shape(self._arr)),
            "dtype": str(arr.dtype),
            "layout": "channels_first" if self._rows_are_channels else "samples_first",
        }
        if self._n == 0:
            raise RecordingError(f"{self.path}: .npy array holds no samples")
        if time_channel is not None:
            self._fs_from_time_channel(time_channel)
        self._default_roles = roles_by_name(self._names)
        self._setup(channels, fs, scale, units)

    def _read_range(self, names: Sequence[str], start: int, stop: int) -> Dict[str, np.ndarray]:
        idx = {nm: k for k, nm in enumerate(self._names)}
        if self._rows_are_channels:
            if self._direct_read_ok():
                return {nm: self._pread_row(idx[nm], start, stop) for nm in names}
            return {nm: self._arr[idx[nm], start:stop] for nm in names}
        return {nm: self._arr[start:stop, idx[nm]] for nm in names}

    def _read_ranges(self, names: Sequence[str], ranges: Sequence[Tuple[int, int]]) -> Dict[str, np.ndarray]:
        """Several ranges of each channel row read straight into one array per channel (the pre-pass
        samples: hundreds of short ranges, one ``preadv`` each instead of an array and a dict each)."""
        if not (self._rows_are_channels and self._direct_read_ok()):
            return super()._read_ranges(names, ranges)
        if hasattr(_core, "pread_ranges"):
            return self._read_ranges_native(names, ranges)
        return self._read_ranges_python(names, ranges)

    def _read_ranges_native(self, names: Sequence[str], ranges: Sequence[Tuple[int, int]]) -> Dict[str, np.ndarray]:
        """:meth:`_read_ranges` with one call of ``_core.pread_ranges`` a channel (every range read without the
        GIL, on several threads for a large read)."""
        r = np.asarray(_runs(ranges), dtype=np.int64).reshape(-1, 2)
        item, dtype = self._arr.itemsize, self._arr.dtype
        starts, lengths = r[:, 0] * item, (r[:, 1] - r[:, 0]) * item
        total = int(lengths.sum()) // item
        threads = read_threads() if total >= _PARALLEL_READ else 1
        fd = self._fd
        assert fd is not None, "open recordings hold their descriptor"
        idx = {nm: k for k, nm in enumerate(self._names)}
        out = {}
        for nm in names:  # an array of its own a channel (owned: handed out without a copy)
            buf = np.empty(total, dtype=dtype)
            if total:
                try:
                    _core.pread_ranges(fd, buf.view(np.uint8), starts + self._offset(idx[nm]), lengths, threads=threads)
                except ValueError:  # a range past the end of the file
                    raise RecordingError(f"{self.path}: file ends early (truncated since it was opened?)") from None
                except OSError as exc:
                    raise RecordingError(f"{self.path}: cannot read: {exc}") from None
            out[nm] = buf
        return out

    def _read_ranges_python(self, names: Sequence[str], ranges: Sequence[Tuple[int, int]]) -> Dict[str, np.ndarray]:
        """:meth:`_read_ranges` with one ``os.preadv`` a range (the reference of the native read; an extension
        without ``_core.pread_ranges``)."""
        idx = {nm: k for k, nm in enumerate(self._names)}
        total = sum(b - a for a, b in ranges)
        runs = _runs(ranges)

        fd, item, direct = self._fd, self._arr.itemsize, hasattr(os, "preadv")
        assert fd is not None, "open recordings hold their descriptor"

        def channel(nm: str) -> np.ndarray:
            buf = np.empty(total, dtype=self._arr.dtype)
            view = memoryview(buf).cast("B")  # type: ignore[arg-type]  # numpy's stubs lack the buffer protocol
            row, base = idx[nm], self._offset(idx[nm])
            at = 0
            for a, b in runs:  # one preadv a run (a short read: the careful loop)
                size = (b - a) * item
                if size and not (direct and os.preadv(fd, [view[at : at + size]], base + a * item) == size):
                    self._pread_into(buf[at // item : at // item + b - a], row, a)
                at += size
            return buf

        workers = min(len(names), read_threads()) if total >= _PARALLEL_READ else 1
        if workers > 1:  # a channel a thread: preadv releases the GIL
            with thread_pool(workers, "tribodyn-read") as pool:
                return dict(zip(names, pool.map(channel, names)))
        return {nm: channel(nm) for nm in names}

    def _f64_rows(self) -> bool:
        """Each channel is one contiguous, 8-byte aligned run of native float64 in the file.

        Aligned only: numpy refuses a misaligned view as a kernel input, and
        the kernel a misaligned offset.
        """
        a = self._arr
        return (
            self._rows_are_channels and self._direct_read_ok() and a.dtype == np.float64 and a.offset % a.itemsize == 0
        )

    def _offset(self, row: int, start: int = 0) -> int:
        """Byte offset in the file of sample ``start`` of channel row ``row`` (channels-first)."""
        a = self._arr
        return int(a.offset + (row * a.shape[1] + start) * a.itemsize)

    def file_layout(self, roles: Sequence[str]) -> Optional[Tuple[int, Dict[str, int]]]:
        if self._closed or self._fd is None or not self._f64_rows():
            return None
        out = {}
        for role in roles:
            name = self.roles.get(role)
            if name is None or self._scale[name] != 1.0:
                return None
            out[role] = self._offset(self._names.index(name))
        return self._fd, out

    def _can_view(self) -> bool:
        return self._f64_rows() and hasattr(mmap, "MAP_POPULATE")

    def _view_range(self, names: Sequence[str], start: int, stop: int) -> Dict[str, np.ndarray]:
        """Samples start:stop of each channel as a read-only view of its own mapping of the file.

        The range is mapped with ``MAP_POPULATE`` (its pages entered in one
        call, not faulted one by one) and unmapped when the view goes, so the
        resident set holds only the chunks alive: the kernel reads the page
        cache directly, with no copy.
        """
        a = self._arr
        assert self._fd is not None, "open recordings hold their descriptor"
        count = stop - start
        size = os.fstat(self._fd).st_size
        out = {}
        for nm in names:
            off = self._offset(self._names.index(nm), start)
            base = off - off % mmap.ALLOCATIONGRANULARITY
            length = off - base + count * a.itemsize
            if size < base + length:
                raise RecordingError(f"{self.path}: file ends early (truncated since it was opened?)")
            if count == 0:
                out[nm] = np.empty(0)
                continue
            m = mmap.mmap(self._fd, length, flags=mmap.MAP_SHARED | mmap.MAP_POPULATE, prot=mmap.PROT_READ, offset=base)
            out[nm] = np.frombuffer(m, dtype=a.dtype, count=count, offset=off - base)
        return out

    def _direct_read_ok(self) -> bool:
        a = self._arr
        return isinstance(a, np.memmap) and a.ndim == 2 and a.flags.c_contiguous and hasattr(os, "pread")

    def _pread_row(self, row: int, start: int, stop: int) -> np.ndarray:
        """Samples start:stop of one channel row, read straight into a new array.

        Reading with ``pread`` instead of copying out of the memory map spares
        a page fault per 4 KiB and keeps the resident set flat: the file's
        pages stay in the page cache, not in this process.
        """
        out = np.empty(stop - start, dtype=self._arr.dtype)
        self._pread_into(out, row, start)
        return out

    def _pread_into(self, out: np.ndarray, row: int, start: int) -> None:
        """Fills the contiguous ``out`` with samples ``start:start + out.size`` of one channel row."""
        offset = self._offset(row, start)
        assert self._fd is not None, "open recordings hold their descriptor"
        view = memoryview(out).cast("B")  # type: ignore[arg-type]  # numpy's stubs lack the buffer protocol
        done = 0
        while done < view.nbytes:
            got = os.preadv(self._fd, [view[done:]], offset + done) if hasattr(os, "preadv") else 0
            if got <= 0:
                raise RecordingError(f"{self.path}: file ends early (truncated since it was opened?)")
            done += got

    _fd: Optional[int] = None
    _owned_reads = True  # pread fills new arrays; memmap views are copied (not owned)

    def _close(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
        arr, self._arr = getattr(self, "_arr", None), None
        mm = getattr(arr, "_mmap", None)
        del arr
        if mm is not None:
            try:
                mm.close()
            except (BufferError, ValueError):  # views still alive elsewhere
                pass


class NpzRecording(Recording):
    """A ``.npz`` archive; members are streamed (see the module docstring)."""

    # Each read opens its own member streams; zipfile locks its shared file.
    thread_safe = True

    format = "npz"

    def __init__(
        self,
        path: str,
        *,
        channels: Optional[Mapping[str, Optional[str]]] = None,
        fs: Optional[float] = None,
        scale: Optional[Mapping[str, float]] = None,
        units: Optional[Mapping[str, str]] = None,
        time_channel: Optional[str] = None,
    ) -> None:
        super().__init__(path)
        self._zip: Optional[zipfile.ZipFile] = None
        try:
            self._zip = zipfile.ZipFile(self.path, "r")
        except (zipfile.BadZipFile, OSError, EOFError) as exc:
            raise RecordingError(f"{self.path}: not a readable .npz (truncated or corrupt?): {exc}") from None
        try:
            self._open(channels, fs, scale, units, time_channel)
        except BaseException:
            self._close()
            raise

    def _member_header(self, member: str) -> Tuple[Tuple[int, ...], bool, np.dtype, int]:
        assert self._zip is not None
        try:
            with self._zip.open(member) as fh:
                shape, fortran, dtype = _read_npy_header(fh, f"{self.path}[{member}]")
                offset = fh.tell()
        except _ZIP_ERRORS as exc:
            raise _member_error(self.path, member, exc) from None
        return shape, fortran, dtype, offset

    def _load_small(self, member: str) -> np.ndarray:
        assert self._zip is not None
        try:
            with self._zip.open(member) as fh:
                return np.lib.format.read_array(fh, allow_pickle=False)
        except _ZIP_OR_VALUE_ERRORS as exc:
            raise _member_error(self.path, member, exc) from None

    def _open(
        self,
        channels: Optional[Mapping[str, Optional[str]]],
        fs: Optional[float],
        scale: Optional[Mapping[str, float]],
        units: Optional[Mapping[str, str]],
        time_channel: Optional[str],
    ) -> None:
        assert self._zip is not None
        members: Dict[str, Tuple[str, np.dtype, int, int]] = {}
        lengths: Dict[str, int] = {}
        skipped: List[str] = []
        file_units: Dict[str, str] = {}
        meta_fs: Optional[Tuple[float, str]] = None
        try:
            infos = self._zip.infolist()
        except (zipfile.BadZipFile, OSError) as exc:  # pragma: no cover
            raise RecordingError(f"{self.path}: corrupt .npz: {exc}") from None
        for zi in infos:
            if not zi.filename.endswith(".npy"):
                continue
            key = zi.filename[:-4]
            shape, _fortran, dtype, offset = self._member_header(zi.filename)
            if len(shape) == 0:
                if key in ("fs", "sampling_rate", "dt") and dtype.kind in "biuf":
                    v = float(self._load_small(zi.filename))
                    if v > 0 and np.isfinite(v):
                        meta_fs = (v, f"member {key!r}") if key != "dt" else (rate_from_step(v), "1/member 'dt'")
                elif key == "units" and dtype.kind == "U":
                    try:
                        u = json.loads(str(self._load_small(zi.filename)))
                        if isinstance(u, dict):
                            file_units = {str(k): str(v) for k, v in u.items()}
                    except ValueError:
                        self.warnings.append("member 'units' is not JSON; ignored")
                continue
            if len(shape) == 2 and min(shape) == 1:  # (N, 1) or (1, N): the bytes of a 1-D array
                shape = (max(shape),)
            if len(shape) == 1 and dtype.kind in "biuf" and not dtype.hasobject and shape[0] > 0:
                members[key] = (zi.filename, dtype, offset, shape[0])
                lengths[key] = shape[0]
            else:
                skipped.append(key)
        if not members:
            from .detect import _zip_kind

            fmt, what = _zip_kind(self.path, "zip")
            if fmt != "npz":
                raise RecordingError(f"{self.path}: not a .npz: its content is {what}")
            raise RecordingError(f"{self.path}: no 1-D numeric member in this .npz")
        wanted = [
            resolve_name(self.path, list(members), v, f"channel for role {k!r}")
            for k, v in (channels or {}).items()
            if v is not None
        ]
        names, n, other = equal_length_selection(self.path, lengths, wanted)
        skipped += other
        self._members = {k: members[k] for k in names}
        self._names = names
        self._n = n
        self._raw_units = {k: file_units.get(k) for k in names}
        if meta_fs is not None:
            self._file_fs, self._fs_source = meta_fs
        elif time_channel is not None:
            self._fs_from_time_channel(time_channel)
        self.metadata = {"members": [zi.filename for zi in infos]}
        if skipped:
            self.metadata["skipped"] = skipped
        self._default_roles = roles_by_name(self._names)
        self._setup(channels, fs, scale, units)

    def _iter_blocks(self, names: Sequence[str], block: int) -> Iterator[Dict[str, np.ndarray]]:
        if self._zip is None:
            raise RecordingError(f"{self.path}: recording is closed")
        streams: Dict[str, Any] = {}
        try:
            for nm in names:
                member, dtype, offset, _ = self._members[nm]
                try:
                    fh = self._zip.open(member)
                    streams[nm] = fh
                    fh.read(offset)  # skip the .npy header
                except _ZIP_ERRORS as exc:
                    raise _member_error(self.path, member, exc) from None
            for start in range(0, self._n, block):
                m = min(block, self._n - start)
                out = {}
                for nm in names:
                    dtype = self._members[nm][1]
                    try:
                        buf = streams[nm].read(m * dtype.itemsize)
                    except _ZIP_ERRORS as exc:
                        raise _member_error(self.path, nm, exc) from None
                    if len(buf) != m * dtype.itemsize:
                        raise RecordingError(f"{self.path}: member {nm!r} is truncated")
                    out[nm] = np.frombuffer(buf, dtype=dtype)
                yield out
        finally:
            for fh in streams.values():
                fh.close()

    def _close(self) -> None:
        z, self._zip = getattr(self, "_zip", None), None
        if z is not None:
            z.close()


def _runs(ranges: Sequence[Tuple[int, int]]) -> List[Tuple[int, int]]:
    """``ranges`` without the empty ones, adjacent ones joined (the lag profile's tiling windows): one read each."""
    runs: List[Tuple[int, int]] = []
    for a, b in ranges:
        if b <= a:
            continue
        if runs and runs[-1][1] == a:
            runs[-1] = (runs[-1][0], int(b))
        else:
            runs.append((int(a), int(b)))
    return runs
