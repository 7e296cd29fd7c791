"""HDF5 files, read with h5py by slicing datasets per block.

Channels are the 1-D numeric datasets at any group depth, named by their
path without the leading ``/`` (``fy``, ``run1/forces/fz``); the last path
component alone is accepted where unique. All channels must have one length
(datasets of other lengths are skipped when the mapped channels agree, see
:func:`~tribodyn.io.base.equal_length_selection`).

Groups nested more than :data:`MAX_DEPTH` deep or more than
:data:`MAX_OBJECTS` objects are refused (a walk of libhdf5's own takes minutes on
thousands of nested groups). A channel with samples never written (chunks not
allocated: HDF5 reads its fill value) is read with a warning, and refused when
those are most of it and more than :data:`MAX_UNWRITTEN` (a small file declaring
billions of samples).

The sampling rate is looked up on each channel's dataset, then its parent
groups up to the file root, as an attribute ``fs``, ``sampling_rate`` or
``sample_rate`` (Hz) or ``dt`` / ``wf_increment`` (s); a scalar dataset
named ``fs`` at the root works too; else ``time_channel=`` names a dataset
of times (s) whose median step gives fs. Units come from an attribute ``unit``,
``units`` or ``unit_string``.

Errors h5py raises while the metadata are read (a corrupt attribute or
object header gives ``OSError``, ``RuntimeError``, ``KeyError`` or
``ValueError``) are reported as a :class:`~tribodyn.io.base.RecordingError`
naming the file and the object. Only attributes holding numbers or text are
read: one of another type (a flipped type byte can turn a string into a
variable-length sequence, which h5py crashes the process reading) is refused
unread. Variable-length text attributes (what h5py writes for a ``str``)
live in the file's global heap, which libhdf5 can loop on forever when it
is corrupt: they are read by a helper process with a time limit
(:mod:`tribodyn.io._h5attrs`, 30 s of CPU time), a file whose read does not finish or
crashes the helper is refused, and they are never read where a number is
looked for (a rate). The file's size, mtime and inode are taken at open and checked again
after every read (:meth:`~tribodyn.io.base.Recording.check_unchanged`): HDF5
returns zeros past the end of a file truncated under it, so a file changed
while it is read is refused.

Datasets stored contiguously (``dataset.id.get_offset()``) or in
uncompressed chunks, all allocated (``get_chunk_info``), of a numeric type
in either byte order, are read natively: ``tribodyn._core.Extents`` read
them with ``pread`` on the recording's own duplicate of h5py's file
descriptor (any number of threads at once) and hand them to the mapped
windows kernel as they are. Compressed or filtered datasets, those with
chunks never written (HDF5 gives their fill value) and files with a user
block or another file driver are read through h5py.
"""

from __future__ import annotations

import math
import os
import sys
from typing import Any, Callable, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, TypeVar

import numpy as np

from .. import _core
from . import _h5attrs
from ._open import closing_on_error, open_or_raise
from .base import Recording, RecordingError, equal_length_selection, rate_from_step, resolve_name, roles_by_name

__all__ = ["Hdf5Recording"]

_T = TypeVar("_T")

#: What h5py raises on corrupt metadata (RecordingError, a ValueError, is passed on as it is).
_H5_ERRORS = (OSError, RuntimeError, KeyError, ValueError, TypeError)
#: Depth of groups, and objects in all, looked through at most for channels (issue 34).
MAX_DEPTH = 64
MAX_OBJECTS = 200_000
#: Samples of a channel that may be never written (fill values) when they are also most of it.
MAX_UNWRITTEN = 10_000_000

_RATE_ATTRS = ("fs", "sampling_rate", "sample_rate")
_STEP_ATTRS = ("dt", "wf_increment")
_UNIT_ATTRS = ("unit", "units", "unit_string")

#: Read contiguous and uncompressed chunked datasets natively (False: always through h5py).
_NATIVE = True


def _dataset_extents(h5py: Any, d: Any) -> Optional[Any]:
    """``_core.Extents`` of a 1-D dataset stored contiguously or in uncompressed, allocated chunks; else None."""
    dt = d.dtype
    if dt.kind not in "iuf" or dt.itemsize not in (1, 2, 4, 8) or (dt.kind == "f" and dt.itemsize == 2):
        return None
    name = f"{dt.kind}{dt.itemsize}"
    big = dt.byteorder == ">" or (dt.byteorder == "=" and sys.byteorder == "big")
    n = int(d.shape[0])
    plist = d.id.get_create_plist()
    layout = plist.get_layout()
    if layout == h5py.h5d.CONTIGUOUS:
        off = d.id.get_offset()
        return None if off is None else _core.Extents.contiguous(name, big, [(n, int(off))])
    if layout != h5py.h5d.CHUNKED or plist.get_nfilters() != 0 or d.chunks is None:
        return None
    clen = int(d.chunks[0])
    count = -(-n // clen)
    if d.id.get_num_chunks() != count:
        return None  # chunks never written read as the fill value: h5py knows it
    infos = sorted(_chunk_infos(d, count), key=lambda c: c.chunk_offset[0])
    if len(infos) != count:
        return None
    parts = []
    for j, ci in enumerate(infos):
        if ci.chunk_offset[0] != j * clen or ci.filter_mask != 0 or ci.byte_offset is None:
            return None
        if ci.size != clen * dt.itemsize:
            return None
        parts.append((min(clen, n - j * clen), int(ci.byte_offset)))
    return _core.Extents.contiguous(name, big, parts)


def _chunk_infos(d: Any, count: int) -> List[Any]:
    """The dataset's chunks' storage info: one ``chunk_iter`` call where h5py and libhdf5 have it (about 4x
    faster than ``count`` calls of ``get_chunk_info``: 20 ms of a 10 h, 4-channel file's open), else those."""
    chunk_iter = getattr(d.id, "chunk_iter", None)
    if chunk_iter is not None:
        infos: List[Any] = []
        try:
            chunk_iter(infos.append)
            return infos
        except (NotImplementedError, RuntimeError, OSError, ValueError):
            pass  # older libhdf5: one call per chunk
    return [d.id.get_chunk_info(i) for i in range(count)]


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


def _rate_of(attr: Callable[[str], Any], name: str) -> Optional[Tuple[float, str]]:
    """(fs, source) from the attributes of object ``name`` (``attr(key)`` gives one, None when absent), or None."""
    for key in _RATE_ATTRS:
        v = _scalar(attr(key))
        if v is not None:
            return v, f"attribute {key!r} of {name!r}"
    for key in _STEP_ATTRS:
        v = _scalar(attr(key))
        if v is not None:
            return rate_from_step(v), f"1/attribute {key!r} of {name!r}"
    return None


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


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
        self._h5py: Any = h5py
        identity = self._identity()  # before anything is read: a change during the opening counts too
        self._h5 = open_or_raise(
            lambda: _open_h5(h5py, self.path, self._appending),
            self.path,
            "cannot open as HDF5 (truncated or corrupt?)",
            _H5_ERRORS,
        )
        self._fd: Optional[int] = None
        self._ext: Dict[str, Any] = {}
        with closing_on_error(self):
            self._open(h5py, channels, fs, scale, units, group=group, time_channel=time_channel)
            if _NATIVE:
                self._open_native(h5py)
            self._identity_at_open = identity
            self.check_unchanged()

    def _identity(self) -> Optional[Tuple[int, int, int, int]]:
        """(size, mtime_ns, inode, device) of the path: a file renamed over it counts as a change, as it always
        did for HDF5, though the native reads' descriptor would still read the file opened."""
        try:
            st = os.stat(self.path)
        except OSError:
            return None
        return (st.st_size, st.st_mtime_ns, st.st_ino, st.st_dev)

    def _open_native(self, h5py: Any) -> None:
        """Extents of the channels stored plainly (see the module doc); all of them: reads from any thread."""
        h5 = self._h5
        if h5.driver != "sec2" or h5.userblock_size != 0:
            return
        try:
            ext = {nm: _dataset_extents(h5py, d) for nm, d in self._dsets.items()}
            handle = h5.id.get_vfd_handle()
        except _H5_ERRORS:
            return  # h5py reads it as before
        self._ext = {nm: e for nm, e in ext.items() if e is not None and e.n >= self._n}
        if not self._ext:
            return
        self._fd = os.dup(int(handle))  # the very file h5py opened, not the path's file now
        self.mappable = True
        if len(self._ext) == len(self._dsets):
            self.thread_safe = True  # pread only: no h5py call per read

    def file_layout(self, roles: Sequence[str]) -> Optional[Tuple[int, Dict[str, Any]]]:
        """(descriptor, {role: ``_core.Extents``}) when every role's dataset is read natively, else None."""
        if self._closed or self._fd is None:
            return None
        out: Dict[str, Any] = {}
        for role in roles:
            name = self.roles.get(role)
            if name is None or name not in self._ext or self._scale[name] != 1.0:
                return None
            out[role] = self._ext[name]
        return self._fd, out

    def _meta(self, what: str, fn: Callable[[], _T]) -> _T:
        """``fn()``, reading metadata of ``what``; h5py's errors become a RecordingError naming it."""
        try:
            return fn()
        except RecordingError:
            raise
        except _H5_ERRORS as exc:
            raise RecordingError(f"{self.path}: corrupt HDF5 file: cannot read {what}: {_one_line(exc)}") from None

    def _attr_of(self, obj: Any, name: str, key: str, display: bool = False, number: bool = False) -> Any:
        """Attribute ``key`` of the object at ``name``, None when it has none.

        Only numbers and text are read: an attribute of another type (e.g. a
        variable-length sequence, what a flipped type byte can make of a
        string, and which h5py may crash reading) is refused, or with
        ``display`` shown as its type without reading it. Variable-length
        text comes from the helper process (:meth:`_heap_texts`); with
        ``number`` (a number is looked for) it is not read at all: None.
        """

        def get() -> Any:
            if key not in obj.attrs:
                return None
            dt = obj.attrs.get_id(key).dtype
            text = self._h5py.check_string_dtype(dt)
            if not (dt.kind in "biufSU" or text is not None):
                if display:
                    return f"<HDF5 attribute of type {dt}, not shown>"
                raise RecordingError(
                    f"{self.path}: attribute {key!r} of {name!r} is of type {dt}, neither a number nor text "
                    "(corrupt file?)"
                )
            if text is not None and text.length is None:  # in the global heap: see the module docstring
                return None if number else self._heap_texts([(obj, name, key)])[0]
            return obj.attrs[key]

        return self._meta(f"attribute {key!r} of {name!r}", get)

    def _in_heap(self, obj: Any, name: str, key: str) -> bool:
        """Whether attribute ``key`` of ``obj`` is variable-length text (stored in the global heap)."""

        def check() -> bool:
            if key not in obj.attrs:
                return False
            text = self._h5py.check_string_dtype(obj.attrs.get_id(key).dtype)
            return text is not None and text.length is None

        return self._meta(f"attribute {key!r} of {name!r}", check)

    def _heap_texts(self, wanted: Sequence[Tuple[Any, str, str]]) -> List[Any]:
        """Values of the variable-length text attributes ``(obj, name, key)``: from the cache, the rest read in
        one request to the helper process (:mod:`tribodyn.io._h5attrs`) and cached."""
        keys = [(self._meta(f"the name of {name!r}", lambda: str(obj.name)), key) for obj, name, key in wanted]
        todo = [(k, w) for k, w in zip(keys, wanted) if k not in self._heap]
        if todo:
            what = ", ".join(f"{key!r} of {name!r}" for _k, (_o, name, key) in todo[:4])
            what += f" and {len(todo) - 4} more" if len(todo) > 4 else ""
            try:
                answers = _h5attrs.read_attributes(self.path, [k for k, _w in todo])
            except TimeoutError as exc:
                raise RecordingError(
                    f"{self.path}: reading the text attribute(s) {what} did not finish within "
                    f"{str(exc) or f'{_h5attrs.TIME_LIMIT:g} s'} (corrupt global heap?): file refused"
                ) from None
            except _h5attrs.HelperCrashed:
                raise RecordingError(
                    f"{self.path}: the HDF5 library crashed reading the text attribute(s) {what} (corrupt file?)"
                ) from None
            except _h5attrs.HelperUnavailable as exc:
                self.warnings.append(f"text attributes read in this process, without a time limit: {exc}")
                answers = []
                for _k, (obj, _name, key) in todo:
                    try:
                        answers.append(("ok", obj.attrs[key]))
                    except _H5_ERRORS as e:
                        answers.append(("error", _one_line(e)))
            self._heap.update(zip([k for k, _w in todo], answers))
        out = []
        for k, (_obj, name, key) in zip(keys, wanted):
            status, value = self._heap[k]
            if status != "ok":
                raise RecordingError(
                    f"{self.path}: corrupt HDF5 file: cannot read attribute {key!r} of {name!r}: {value}"
                )
            out.append(value)
        return out

    def _open(
        self,
        h5py: Any,
        channels: Optional[Mapping[str, Optional[str]]],
        fs: Optional[float],
        scale: Optional[Mapping[str, float]],
        units: Optional[Mapping[str, str]],
        *,
        group: Optional[str],
        time_channel: Optional[str],
    ) -> None:
        root = self._h5
        if group is not None:
            g = self._meta(f"group {group!r}", lambda: root[group] if group in root else None)
            if not isinstance(g, h5py.Group):
                raise RecordingError(f"{self.path}: no HDF5 group {group!r}")
            root = g
        found: Dict[str, Any] = {}
        lengths: Dict[str, int] = {}
        skipped: List[str] = []

        def visit(name: str, obj: Any) -> None:
            def describe() -> None:
                if isinstance(obj, h5py.Dataset):
                    full = obj.name.lstrip("/")
                    if obj.ndim == 1 and obj.dtype.kind in "biuf" and obj.shape[0] > 0:
                        found[full] = obj
                        lengths[full] = int(obj.shape[0])
                    elif obj.ndim != 0:
                        skipped.append(full)

            self._meta(f"object {name!r}", describe)

        self._meta("the object tree", lambda: self._walk(h5py, root, visit))
        if not found:
            raise RecordingError(f"{self.path}: no 1-D numeric dataset in this HDF5 file")
        wanted = [
            resolve_name(self.path, list(found), v, f"channel for role {k!r}")
            for k, v in (channels or {}).items()
            if v is not None
        ]
        names, n, other = equal_length_selection(self.path, lengths, wanted)
        skipped += other
        self._dsets = {k: found[k] for k in names}
        for k, d in self._dsets.items():
            self._meta(f"the storage of {k!r}", lambda: self._check_written(k, d))
        self._names = names
        self._n = n
        root_attrs = self._units()
        rates = self._rates(h5py)
        if rates:
            vals = [r[0] for r in rates.values()]
            if max(vals) - min(vals) > 1e-9 * max(vals):
                detail = ", ".join(f"{k!r}: {r[0]:g} Hz" for k, r in rates.items())
                raise RecordingError(f"{self.path}: channels have different sampling rates ({detail})")
            self._file_fs, self._fs_source = next(iter(rates.values()))
        elif time_channel is not None:
            self._fs_from_time_channel(time_channel)
        self.metadata = {"attributes": {k: _attr(self._attr_of(self._h5, "/", k, display=True)) for k in root_attrs}}
        if skipped:
            self.metadata["skipped"] = skipped
        self._default_roles = roles_by_name(self._names)
        self._setup(channels, fs, scale, units)

    def _units(self) -> List[str]:
        """Reads each channel's unit attribute (``_raw_units``) and returns the root's attribute names; the
        variable-length texts among them (units, the root's for the metadata) in one helper request."""
        self._heap: Dict[Tuple[str, str], Tuple[str, Any]] = {}
        root_attrs: List[str] = self._meta("the attributes of '/'", lambda: list(self._h5.attrs))
        texts = [(d, k, key) for k, d in self._dsets.items() for key in _UNIT_ATTRS if self._in_heap(d, k, key)]
        texts += [(self._h5, "/", key) for key in root_attrs if self._in_heap(self._h5, "/", key)]
        if texts:
            self._heap_texts(texts)
        self._raw_units = {}
        for k, d in self._dsets.items():
            u = None
            for key in _UNIT_ATTRS:
                u = _text(self._attr_of(d, k, key))
                if u:
                    break
            self._raw_units[k] = u
        return root_attrs

    def _rates(self, h5py: Any) -> Dict[str, Tuple[float, str]]:
        """Sampling rate per channel (Hz, where it was found): the nearest definition up the tree, else a
        root dataset ``fs`` for every channel; empty when none is found."""
        rates: Dict[str, Tuple[float, str]] = {}
        for k, d in self._dsets.items():
            obj = d
            while True:
                oname = self._meta(f"the name of an ancestor of {k!r}", lambda: str(obj.name))
                r = _rate_of(lambda key: self._attr_of(obj, oname, key, number=True), oname)
                if r is not None:
                    rates[k] = r
                    break
                if oname == "/":
                    break
                obj = self._meta(f"the parent group of {oname!r}", lambda: obj.parent)
        if not rates:
            fs_d = self._meta("dataset '/fs'", lambda: self._h5["fs"] if "fs" in self._h5 else None)
            if isinstance(fs_d, h5py.Dataset) and fs_d.dtype.kind in "biuf" and fs_d.size == 1:  # numbers only
                v = _scalar(self._meta("dataset '/fs'", lambda: fs_d[()]))
                if v is not None:
                    rates = {k: (v, "dataset '/fs'") for k in self._dsets}
        return rates

    def _walk(self, h5py: Any, root: Any, visit: Callable[[str, Any], None]) -> None:
        """Calls ``visit(name, obj)`` for every object under ``root``, each once, in the order of
        ``visititems`` (depth first, by name), refusing a tree deeper than :data:`MAX_DEPTH` groups or of
        more than :data:`MAX_OBJECTS` objects (libhdf5's own ``visititems`` takes minutes on groups nested
        thousands deep: issue 34)."""
        seen = {hash(root.id)}
        stack: List[Tuple[Any, Iterator[str], str]] = [(root, iter(list(root)), "")]
        count = 0
        while stack:
            group, keys, prefix = stack[-1]
            key = next(keys, None)
            if key is None:
                stack.pop()
                continue
            count += 1
            if count > MAX_OBJECTS:
                raise RecordingError(f"{self.path}: more than {MAX_OBJECTS} HDF5 objects: not a recording layout")
            obj = group.get(key)
            if obj is None:  # a dangling soft or external link
                continue
            ident = hash(obj.id)  # h5py hashes an object by file and address: a hard link twice is one object
            if ident in seen:
                continue
            seen.add(ident)
            name = f"{prefix}{key}"
            visit(name, obj)
            if isinstance(obj, h5py.Group):
                if len(stack) >= MAX_DEPTH:
                    raise RecordingError(
                        f"{self.path}: HDF5 groups nested more than {MAX_DEPTH} deep (at {name[:80]!r}...): "
                        "not a recording layout"
                    )
                stack.append((obj, iter(list(obj)), name + "/"))

    def _check_written(self, name: str, d: Any) -> None:
        """Warns of samples never written (HDF5 reads its fill value there) and refuses a channel mostly
        unwritten beyond :data:`MAX_UNWRITTEN` samples (a 1 kB file declaring 3e11 samples: issue 34)."""
        n = int(d.shape[0])
        if d.chunks is not None:
            written = min(n, int(d.id.get_num_chunks()) * int(d.chunks[0]))
        elif d.external:
            return
        else:
            written = n if d.id.get_storage_size() > 0 else 0
        unwritten = n - written
        if unwritten <= 0:
            return
        if unwritten > MAX_UNWRITTEN and unwritten > written:
            raise RecordingError(
                f"{self.path}: dataset {name!r} declares {n} samples of which {unwritten} were never written "
                f"(no storage allocated; the file is {os.path.getsize(self.path)} bytes): truncated or "
                "pre-allocated and never filled"
            )
        self.warnings.append(
            f"{name}: {unwritten} of {n} samples were never written: HDF5 reads its fill value ({d.fillvalue!r}) there"
        )

    _owned_reads = True  # h5py returns a new array for every slice

    def _read_ranges(self, names: Sequence[str], ranges: Sequence[Tuple[int, int]]) -> Dict[str, np.ndarray]:
        """Several ranges of each channel, one native call a channel (``_core.extents_read_ranges``) when every
        channel is read natively (the pre-pass's hundreds of pieces; issue 38 point 2)."""
        fd = self._fd
        native = self.thread_safe and fd is not None and hasattr(_core, "extents_read_ranges")
        if fd is None or not (native and all(self._ext.get(nm) is not None for nm in names)):
            return super()._read_ranges(names, ranges)
        return self._extents_ranges(fd, self._ext, names, ranges)

    def _read_range(self, names: Sequence[str], start: int, stop: int) -> Dict[str, np.ndarray]:
        out = {}
        for nm in names:
            ext = self._ext.get(nm)
            if ext is not None and self._fd is not None:
                try:
                    out[nm] = ext.read(self._fd, start, stop)
                except ValueError as exc:
                    self.check_unchanged()
                    raise RecordingError(f"{self.path}: cannot read {nm!r}: {exc}") from None
                continue
            if self.thread_safe:
                raise RecordingError(f"{self.path}: {nm!r} is not read natively")  # pragma: no cover
            try:
                out[nm] = self._dsets[nm][start:stop]
            except _H5_ERRORS as exc:
                self.check_unchanged()  # a changed file explains the error better
                raise RecordingError(f"{self.path}: cannot read {nm!r} (corrupt file?): {_one_line(exc)}") from None
            if len(out[nm]) != stop - start:
                raise RecordingError(f"{self.path}: {nm!r} gave {len(out[nm])} samples for {start}:{stop}")
        # HDF5 fills what lies past the end of a truncated file with zeros: check the file is the one opened
        self.check_unchanged()
        return out

    def _close(self) -> None:
        fd, self._fd = getattr(self, "_fd", None), None
        if fd is not None:
            os.close(fd)
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


def _open_h5(h5py: Any, path: str, appending: bool) -> Any:
    """The file for reading; one still being written (``appending``) as a reader of its single writer (SWMR) when
    the writer allows it (an HDF5 file of the latest format in SWMR mode), plainly otherwise."""
    if appending:
        try:
            return h5py.File(path, "r", swmr=True)
        except (OSError, ValueError):
            pass  # not an SWMR file: read plainly
    return h5py.File(path, "r")
