"""NI TDMS files, read natively (tribodyn's own index and reads) or through npTDMS.

The native reader (``tribodyn._core.tdms_index``, Rust) walks the segments
once, parses every segment's metadata (incremental metadata included) and
describes each channel as extents of one numeric type (contiguous or
interleaved data, DAQmx raw rows, either byte order) that
``_core.Extents.read`` and the mapped windows kernel read with ``pread``,
from any number of threads, with the channel's scaling (linear and
polynomial chains, DAQmx scalers). It makes the same checks as the walk
below (a truncated or damaged file is refused, naming the segment). A file
it does not read (strings, timestamps or booleans as data, another scale
type, DAQmx digital lines, a data type that changes) is detected before
any sample is read and read by npTDMS as below, with the reason in the
recording's ``warnings``. npTDMS is the oracle the native reader is tested
against (tests/io/test_tdms_native.py).

Through npTDMS, in streaming mode:

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
reported as a :class:`~tribodyn.io.base.RecordingError`. The walk also parses
each segment's metadata far enough to measure it: a raw-data offset that does
not point where the metadata ends (zero bytes between the two excepted: DAQmx
pads its metadata to 4 KiB) is refused, as npTDMS would read the samples from
the wrong place. After npTDMS has read the metadata, every segment's data
size must be a whole number of chunks of the size its channels declare,
segments holding the same channels must agree on the data layout
(interleaved or not), and no segment may hold data of an object that is no
channel (npTDMS drops an object whose path it cannot parse); anything else is
a corrupt segment header, refused naming the segment (1-based index and byte
position). A channel's scaling must be complete and supported (npTDMS would
raise ``KeyError`` for a missing ``NI_Scale[n]_*`` property, or hand out
unscaled values for an unknown scale type).

npTDMS's log records emitted during these calls are kept off the terminal:
those telling of inconsistent segment sizes become a RecordingError, the
others go into ``warnings``. The file's size, mtime and inode are checked
again after every read (:meth:`~tribodyn.io.base.Recording.check_unchanged`):
a file changed while it is read is refused instead of giving other numbers.
"""

from __future__ import annotations

import logging
import os
import struct
import threading
from dataclasses import dataclass
from typing import IO, Any, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .. import _core
from ._open import closing_on_error, open_or_raise
from .base import Recording, RecordingError, equal_length_selection, rate_from_step, resolve_name, roles_by_name

__all__ = ["TdmsRecording", "check_tdms_segments"]

_LEAD_IN = 28
_TOC_META_DATA = 1 << 1
_TOC_INTERLEAVED = 1 << 5
_TOC_BIG_ENDIAN = 1 << 6
_TOC_DAQMX = 1 << 7
_INCOMPLETE = 0xFFFFFFFFFFFFFFFF

# Raw data index headers of the metadata (npTDMS tdms_segment.py / daqmx.py).
_NO_DATA = 0xFFFFFFFF
_SAME_AS_PREVIOUS = 0x00000000
_DAQMX_SCALER_SIZES = {0x00001269: 20, 0x0000126A: 17}  # format changing / digital line scaler
_STRING = 0x20
# Sizes of the fixed-size TDMS property types (npTDMS types.py); strings are length-prefixed.
_PROP_SIZES = {
    1: 1, 2: 2, 3: 4, 4: 8, 5: 1, 6: 2, 7: 4, 8: 8, 9: 4, 10: 8,
    0x19: 4, 0x1A: 8, 0x21: 1, 0x44: 16, 0x08000C: 8, 0x10000D: 16,
}  # fmt: skip

#: Largest NI_Number_Of_Scales believed (NI's scale chains are a few scales long).
_MAX_SCALES = 64

# npTDMS log messages telling that a segment's sizes contradict its channels.
_INCONSISTENT = (
    "not a multiple of the chunk size",
    "Cropping data",
    "less data than expected",
    "metadata is incomplete",
)


@dataclass(frozen=True)
class _Segment:
    """One segment's lead-in, as found by :func:`_walk_segments`."""

    number: int  # 1-based
    position: int
    toc: int
    next_offset: int
    raw_offset: int

    def where(self) -> str:
        return f"segment {self.number} at byte {self.position}"


class _MetadataOverrun(Exception):
    """The metadata runs past the limit given to :class:`_MetadataReader`."""


class _MetadataReader:
    """Reads at most ``limit`` bytes of one segment's metadata and counts them."""

    def __init__(self, fh: IO[bytes], order: str, limit: int) -> None:
        self._fh = fh
        self._order = order
        self._left = limit
        self.used = 0

    def take(self, n: int) -> bytes:
        if n > self._left:
            raise _MetadataOverrun
        b = self._fh.read(n)
        if len(b) != n:
            raise _MetadataOverrun
        self._left -= n
        self.used += n
        return b

    def u32(self) -> int:
        return int(struct.unpack(self._order + "I", self.take(4))[0])


def _metadata_length(fh: IO[bytes], order: str, limit: int) -> Optional[int]:
    """Bytes of metadata npTDMS parses for the segment whose metadata starts at ``fh``'s position.

    Follows npTDMS's parser (objects, raw data indexes including DAQmx ones,
    properties). Returns None when a property of a type npTDMS cannot size
    is met (the length is then unknown); raises :class:`_MetadataOverrun`
    when the metadata would need more than ``limit`` bytes.
    """
    m = _MetadataReader(fh, order, limit)
    for _ in range(m.u32()):
        m.take(m.u32())  # object path
        index = m.u32()
        scaler_size = _DAQMX_SCALER_SIZES.get(index)
        if scaler_size is not None:
            m.take(4)  # data type
            _dim, _chunk, n_scalers = struct.unpack(order + "IQI", m.take(16))
            m.take(n_scalers * scaler_size)
            m.take(4 * m.u32())  # raw data widths
        elif index not in (_NO_DATA, _SAME_AS_PREVIOUS):
            (data_type,) = struct.unpack(order + "I", m.take(16)[:4])  # type, dimension, number of values
            if data_type == _STRING:
                m.take(8)  # total size of the strings
        for _ in range(m.u32()):
            m.take(m.u32())  # property name
            kind = m.u32()
            if kind == _STRING:
                m.take(m.u32())
            elif kind in _PROP_SIZES:
                m.take(_PROP_SIZES[kind])
            else:
                return None
    return m.used


def _walk_segments(path: str) -> List[_Segment]:
    """The segments of a TDMS file, checked for a complete lead-in and metadata of the declared size.

    Raises
    ------
    RecordingError
        Not a TDMS file, a segment that runs past the end of the file or was
        never finished by its writer, or one whose raw data offset is not
        where its metadata ends.
    """
    size = os.path.getsize(path)
    pos = 0
    out: List[_Segment] = []
    with open(path, "rb") as fh:
        while pos < size:
            count = len(out)
            fh.seek(pos)
            lead = fh.read(_LEAD_IN)
            if len(lead) < _LEAD_IN:
                raise RecordingError(f"{path}: truncated TDMS file ({size - pos} stray bytes after segment {count})")
            if lead[:4] != b"TDSm":
                what = "not a TDMS file" if count == 0 else f"corrupt TDMS file at byte {pos}"
                raise RecordingError(f"{path}: {what} (bad segment tag {lead[:4]!r})")
            (toc,) = struct.unpack("<I", lead[4:8])
            order = ">" if toc & _TOC_BIG_ENDIAN else "<"
            _version, next_off, raw_off = struct.unpack(order + "IQQ", lead[8:28])
            seg = _Segment(count + 1, pos, toc, next_off, raw_off)
            if next_off == _INCOMPLETE:
                raise RecordingError(
                    f"{path}: TDMS {seg.where()} was never completed (writer aborted or file truncated)"
                )
            end = pos + _LEAD_IN + next_off
            if end > size:
                raise RecordingError(
                    f"{path}: truncated TDMS file: segment {count + 1} needs {end} bytes, the file has {size}"
                )
            _check_metadata_size(path, fh, seg, order)
            out.append(seg)
            pos = end
    if not out:
        raise RecordingError(f"{path}: empty TDMS file")
    return out


def _check_metadata_size(path: str, fh: IO[bytes], seg: _Segment, order: str) -> None:
    """Refuses a segment whose raw data offset is not the length of its metadata (``fh`` after its lead-in)."""
    bad = f"{path}: corrupt TDMS file: {seg.where()}"
    if seg.raw_offset > seg.next_offset:
        raise RecordingError(
            f"{bad}: raw data offset {seg.raw_offset} lies beyond the segment's end ({seg.next_offset} bytes)"
        )
    if not seg.toc & _TOC_META_DATA:
        if seg.raw_offset != 0:
            raise RecordingError(f"{bad}: raw data offset {seg.raw_offset} in a segment without metadata")
        return
    try:
        used = _metadata_length(fh, order, seg.raw_offset)
    except _MetadataOverrun:
        raise RecordingError(
            f"{bad}: its metadata runs past the raw data offset {seg.raw_offset} (corrupt segment header)"
        ) from None
    if used is not None and used != seg.raw_offset and not _zeros(fh, seg.raw_offset - used):
        raise RecordingError(
            f"{bad}: raw data offset {seg.raw_offset} but the metadata ends after {used} bytes (corrupt segment header)"
        )


def _zeros(fh: IO[bytes], n: int) -> bool:
    """True when the next ``n`` bytes of ``fh`` are all zero: padding (DAQmx pads metadata to 4 KiB), not data."""
    while n > 0:
        b = fh.read(min(n, 1 << 16))
        if not b or b.count(0) != len(b):
            return False
        n -= len(b)
    return True


def check_tdms_segments(path: str) -> int:
    """Walks the segment lead-ins of a TDMS file and checks they fit in the file.

    Each segment's metadata is measured too: its raw data offset must be
    where the metadata ends.

    Returns
    -------
    int
        Number of segments.

    Raises
    ------
    RecordingError
        Not a TDMS file, a segment that runs past the end of the file or
        was never finished by its writer, or a segment whose raw data offset
        contradicts its metadata.
    """
    return len(_walk_segments(path))


def _check_chunks(path: str, tdms_file: Any, walk: Sequence[_Segment]) -> Dict[str, int]:
    """Checks the segments as npTDMS parsed them; returns the samples per channel path their sizes imply.

    Every segment's data must be a whole number of chunks of the size its
    channels declare, and segments holding the same (two or more) channels
    with the same counts must agree on the layout (interleaved or not): a
    flipped layout bit otherwise reads every value from the wrong bytes.
    Uses npTDMS's parsed segments; with an npTDMS that does not keep them in
    the expected form nothing is checked here (and an empty dict returned).
    """
    segs = getattr(getattr(tdms_file, "_reader", None), "_segments", None)
    if not isinstance(segs, list):
        return {}
    by_pos = {s.position: s for s in walk}
    layouts: Dict[Tuple[Any, ...], Tuple[bool, _Segment]] = {}
    implied: Dict[str, int] = {}
    for seg in segs:
        try:
            info = by_pos.get(int(seg.position))
            data = int(seg.next_segment_pos) - int(seg.data_position)
            chunk = int(seg._get_chunk_size())
            n_chunks = int(seg.num_chunks)
            partial = seg.final_chunk_lengths_override is not None
            toc = int(seg.toc_mask)
            objs = [o for o in (seg.ordered_objects or ()) if o.has_data]
            counts = [(str(o.path), int(o.number_values), getattr(o, "daqmx_metadata", None) is not None) for o in objs]
        except Exception:  # noqa: BLE001 - another npTDMS's internals: leave it to the log records
            return {}
        if info is None:
            return {}
        if chunk > 0 and (partial or data % chunk or n_chunks != data // chunk):
            raise RecordingError(
                f"{path}: corrupt TDMS file: {info.where()}: its {data} bytes of data are not a whole number "
                f"of chunks of {chunk} bytes (segment header inconsistent with its channels)"
            )
        for p, nv, _ in counts:
            implied[p] = implied.get(p, 0) + nv * n_chunks
        if len(counts) < 2 or n_chunks == 0 or toc & _TOC_DAQMX or any(d for _, _, d in counts):
            continue  # one channel reads the same either way; DAQmx data ignore the flag
        key = tuple((p, nv, str(getattr(o, "data_type", ""))) for (p, nv, _), o in zip(counts, objs))
        inter = bool(toc & _TOC_INTERLEAVED)
        first_inter, first = layouts.setdefault(key, (inter, info))
        if first_inter != inter:

            def how(x: bool) -> str:
                return "interleaved" if x else "contiguous"

            raise RecordingError(
                f"{path}: corrupt TDMS file: {info.where()} declares {how(inter)} data but {first.where()} "
                f"holds the same channels {how(first_inter)} (corrupt table of contents)"
            )
    return implied


class _NptdmsLog(logging.Filter):
    """Collects npTDMS's log records of this thread while active, keeping them off the terminal.

    Installed as a filter on every ``nptdms`` logger for the duration of a
    ``with`` block (npTDMS gives each module logger its own console
    handler, so stopping propagation would not be enough); records of other
    threads pass untouched. Removed again on exit: nothing global changes.
    """

    def __init__(self) -> None:
        super().__init__()
        self._thread = threading.get_ident()
        self._loggers: List[logging.Logger] = []
        self.messages: List[str] = []

    def filter(self, record: logging.LogRecord) -> bool:
        if record.thread != self._thread:
            return True
        try:
            msg = record.getMessage()
        except Exception:  # noqa: BLE001 - a malformed record: keep its template
            msg = str(record.msg)
        if record.levelno >= logging.WARNING:
            self.messages.append(" ".join(msg.split())[:300])
        return False

    def __enter__(self) -> "_NptdmsLog":
        for name, lg in list(logging.Logger.manager.loggerDict.items()):
            if isinstance(lg, logging.Logger) and (name == "nptdms" or name.startswith("nptdms.")):
                lg.addFilter(self)
                self._loggers.append(lg)
        return self

    def __exit__(self, *exc: object) -> None:
        for lg in self._loggers:
            lg.removeFilter(self)
        self._loggers = []

    def inconsistent(self) -> Optional[str]:
        """The first message telling of segment sizes inconsistent with the channels, or None."""
        return next((m for m in self.messages if any(s in m for s in _INCONSISTENT)), None)


#: Read natively when the file allows (False: always through npTDMS).
_NATIVE = True


class _Fallback(Exception):
    """The native reader does not read this file: the reason, for the warnings."""


# Property values (TDMS type code -> struct format); 0x20 string, 0x21 boolean, 0x44 timestamp.
_PROP_FORMATS = {1: "b", 2: "h", 3: "i", 4: "q", 5: "B", 6: "H", 7: "I", 8: "Q", 9: "f", 10: "d", 0x19: "f", 0x1A: "d"}
_FLOAT_CODES = (9, 10, 0x19, 0x1A)
_TDMS_EPOCH = np.datetime64("1904-01-01 00:00:00", "s")
_FRACTIONS_PER_US = (10**-6) / 2**-64
_DAQMX_RAW = 0xFFFFFFFF
_RAW_SOURCE = 0xFFFFFFFF
# Channel data types without samples for tribodyn (npTDMS dtype kind neither b, i, u nor f): skipped.
_NOT_NUMERIC = (0x44, 0x08000C, 0x10000D, 0x20, 0)


def _prop_value(code: int, raw: bytes, big: bool) -> Any:
    """A property's value as npTDMS gives it (Python scalars, str, timestamps as datetime64[us])."""
    order = ">" if big else "<"
    if code == 0x20:
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError:
            return raw.decode("utf-8", errors="replace")
    if code == 0x21:
        return bool(struct.unpack(order + "b", raw)[0])
    if code == 0x44:
        seconds, fractions = struct.unpack(">qQ", raw) if big else struct.unpack("<Qq", raw)[::-1]
        return _TDMS_EPOCH + np.timedelta64(seconds, "s") + ((fractions / _FRACTIONS_PER_US) * np.timedelta64(1, "us"))
    return struct.unpack(order + _PROP_FORMATS[code], raw)[0]


class _NChannel:
    """A channel of the native index, with what :meth:`TdmsRecording._open` asks of an npTDMS channel."""

    def __init__(self, path: str, group: str, name: str, props: Dict[str, Any], obj: Tuple[Any, ...]) -> None:
        self.path = path
        self.name = name
        self.group = group
        self.properties = props
        _path, _props, self.code, self.n, self.runs, self.unsupported = obj
        self.extents: Any = None

    def __len__(self) -> int:
        return int(self.n)


class _NGroup:
    def __init__(self, name: str, props: Dict[str, Any]) -> None:
        self.name = name
        self.properties = props
        self._channels: List[_NChannel] = []

    def channels(self) -> List[_NChannel]:
        return self._channels


class _NFile:
    """The native index, shaped like the parts of npTDMS's ``TdmsFile`` the reader uses."""

    def __init__(self, path: str, idx: Mapping[str, Any]) -> None:
        objects = idx["objects"]
        self.properties: Dict[str, Any] = {}
        groups: Dict[str, _NGroup] = {}
        implied: List[Tuple[str, _NChannel]] = []
        for obj in objects:
            opath, props, _code, n, _runs, _unsupported = obj
            comps = _path_components(opath)
            if comps is None:
                raise _Fallback(f"object path {opath!r} is malformed")
            pd = {name: _prop_value(code, raw, big) for name, code, raw, big in props}
            if not comps:
                self.properties = pd
            elif len(comps) == 1:
                groups.setdefault(comps[0], _NGroup(comps[0], {})).properties = pd
            else:
                implied.append((comps[0], _NChannel(opath, comps[0], comps[1], pd, obj)))
            if n > 0 and len(comps) < 2:
                raise RecordingError(
                    f"{path}: corrupt TDMS file: data of object {opath!r}, which is no channel of a group "
                    "(malformed object path)"
                )
        # npTDMS's order: groups with a group object first, then those only named by channels.
        for gname, c in implied:
            if gname not in groups:
                groups[gname] = _NGroup(gname, {})
        for gname, c in implied:
            groups[gname]._channels.append(c)
        self._groups = list(groups.values())

    def groups(self) -> List[_NGroup]:
        return self._groups

    def close(self) -> None:
        pass


def _path_components(path: str) -> Optional[List[str]]:
    """Components of a TDMS object path ``/'group'/'channel'`` (quotes doubled inside); None when malformed."""
    out: List[str] = []
    i, n = 0, len(path)
    while i < n:
        if path[i] == "/" and i + 1 == n:
            break  # a trailing "/" (the root object is "/"), as npTDMS reads it
        if path[i] != "/" or path[i + 1] != "'":
            return None
        i += 2
        comp = []
        while True:
            if i >= n:
                return None
            if path[i] == "'":
                if i + 1 < n and path[i + 1] == "'":
                    comp.append("'")
                    i += 2
                    continue
                i += 1
                break
            comp.append(path[i])
            i += 1
        out.append("".join(comp))
    return out if len(out) <= 2 else None


def _scale_count(props: Mapping[str, Any]) -> Optional[int]:
    """npTDMS's number of scalings of one level of properties.

    NI_Number_Of_Scales, else one more than the highest n of NI_Scale[n]_Scale_Type; None without either.
    """
    if "NI_Number_Of_Scales" in props:
        return int(props["NI_Number_Of_Scales"])
    found = [k[9:].split("]")[0] for k in props if k.startswith("NI_Scale[") and k.endswith("]_Scale_Type")]
    nums = [int(k) for k in found if k.isdigit()]
    return max(nums) + 1 if nums else None


def _native_scaling(where: str, levels: Sequence[Mapping[str, Any]]) -> Optional[List[Tuple[str, Any]]]:
    """The channel's scaling chain as npTDMS would build it: None (unscaled) or a list of steps from the source.

    Steps: ("raw",), ("scaler", id), ("linear", slope, intercept), ("poly", coefficients). Raises
    RecordingError where npTDMS's path would too; :class:`_Fallback` for a scaling read only by npTDMS.
    """
    for props in levels:
        try:
            count = _scale_count(props)
        except (TypeError, ValueError):
            raise _Fallback("unreadable NI_Number_Of_Scales") from None
        if not count or props.get("NI_Scaling_Status", "unscaled") == "scaled":
            continue
        scales: List[Tuple[Any, ...]] = []
        for i in range(count):
            kind = props.get(f"NI_Scale[{i}]_Scale_Type")

            def prop(name: str) -> Any:
                try:
                    return props[name]
                except KeyError:
                    raise RecordingError(f"{where}: scaling property {name!r} is missing") from None

            if kind is None:
                scales.append(("scaler", i))
            elif kind == "Linear":
                src = props.get(f"NI_Scale[{i}]_Linear_Input_Source", _RAW_SOURCE)
                slope = prop(f"NI_Scale[{i}]_Linear_Slope")
                icpt = prop(f"NI_Scale[{i}]_Linear_Y_Intercept")
                scales.append(("linear", src, slope, icpt))
            elif kind == "Polynomial":
                size = props.get(f"NI_Scale[{i}]_Polynomial_Coefficients_Size", 4)
                src = props.get(f"NI_Scale[{i}]_Polynomial_Input_Source", _RAW_SOURCE)
                try:
                    k = int(size)
                except (TypeError, ValueError):
                    raise _Fallback("unreadable polynomial coefficient count") from None
                coeffs = [prop(f"NI_Scale[{i}]_Polynomial_Coefficients[{j}]") for j in range(k)]
                scales.append(("poly", src, coeffs))
            elif kind == "AdvancedAPI":
                scales.append(("noop", props.get(f"NI_Scale[{i}]_AdvancedAPI_Input_Source", _RAW_SOURCE)))
            elif kind in ("RTD", "Strain", "Table", "Thermistor", "Thermocouple", "Add", "Subtract"):
                raise _Fallback(f"scale type {kind!r} (read by npTDMS)")
            else:
                what = f"Unsupported scale type: {kind}".lower()  # as the npTDMS path words it
                raise RecordingError(f"{where}: {what} (values cannot be scaled)")
        steps: List[Tuple[str, Any]] = []
        at, seen = count - 1, 0
        while True:
            if at == _RAW_SOURCE:
                steps.append(("raw", None))
                break
            if not isinstance(at, int) or not 0 <= at < count or seen > count:
                raise _Fallback(f"scaling input source {at!r}")
            seen += 1
            sc = scales[at]
            if sc[0] == "scaler":
                steps.append(("scaler", sc[1]))
                break
            if sc[0] == "linear":
                if not all(isinstance(v, float) for v in sc[2:]):
                    raise _Fallback("linear scaling with non-float slope or intercept")
                steps.append(("linear", (sc[2], sc[3])))
            elif sc[0] == "poly":
                if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in sc[2]):
                    raise _Fallback("polynomial scaling with non-numeric coefficients")
                steps.append(("poly", [float(v) for v in sc[2]]))
            at = sc[1]
        return steps[::-1]
    return None


class TdmsRecording(Recording):
    """A TDMS file; see the module docstring."""

    # npTDMS seeks and reads one shared file object: never from two threads.
    # Natively read files say otherwise per instance (pread, any thread;
    # their channels go to the mapped kernel as extents).
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
        self._fd: Optional[int] = None
        self._native = False
        identity = self._identity()  # before anything is read: a change during the opening counts too
        if _NATIVE:
            try:
                self._fd = os.open(self.path, os.O_RDONLY)
            except OSError as exc:
                raise RecordingError(f"{self.path}: cannot open: {exc.strerror or exc}") from None
            with closing_on_error(self):
                reason = self._open_native(channels, fs, scale, units, group)
                if reason is None:
                    self._identity_at_open = identity
                    self.check_unchanged()
                    return
            self._close()
            self.warnings.append(f"TDMS read by npTDMS, not natively: {reason}")
        from nptdms import TdmsFile  # local: keeps `import tribodyn.io` light

        walk = _walk_segments(self.path)
        with _NptdmsLog() as log:
            # npTDMS raises assorted errors on bad metadata, hence Exception
            self._file = open_or_raise(
                lambda: TdmsFile.open(self.path), self.path, "cannot read TDMS metadata", Exception
            )
        with closing_on_error(self):
            implied = _check_chunks(self.path, self._file, walk)
            self._npt_messages(log, "reading the metadata")
            self._open(channels, fs, scale, units, group, n_segments=len(walk), implied=implied)
            self._identity_at_open = identity
            self.check_unchanged()

    def _identity(self) -> Optional[Tuple[int, int, int, int]]:
        """(size, mtime_ns, inode, device) of the path: a file renamed over it counts as a change, as it always
        did for TDMS, though the native reader's descriptor would still read the file opened."""
        try:
            st = os.stat(self.path)
        except OSError:
            return None
        return (st.st_size, st.st_mtime_ns, st.st_ino, st.st_dev)

    def _open_native(
        self,
        channels: Optional[Mapping[str, Optional[str]]],
        fs: Optional[float],
        scale: Optional[Mapping[str, float]],
        units: Optional[Mapping[str, str]],
        group: Optional[str],
    ) -> Optional[str]:
        """Opens the file with the native index; returns why not (then nothing is kept) or None."""
        assert self._fd is not None
        index_fd = None
        try:
            index_fd = os.open(self.path + "_index", os.O_RDONLY)  # NI's .tdms_index beside the data, if any
        except OSError:
            pass
        try:
            idx = _core.tdms_index(self._fd, index_fd)
        except ValueError as exc:
            raise RecordingError(f"{self.path}: {exc}") from None
        finally:
            if index_fd is not None:
                os.close(index_fd)
        if idx["fallback"] is not None:
            return str(idx["fallback"])
        try:
            nfile = _NFile(self.path, idx)
            self._file = nfile
            self._native = True
            self._open(channels, fs, scale, units, group, n_segments=int(idx["segments"]), implied={})
        except _Fallback as why:
            self._file, self._native = None, False
            self._names, self._n = [], 0
            return str(why)
        for w in idx["warnings"]:
            self.warnings.append(f"TDMS: {w}")
        self.thread_safe = True  # pread: no shared file position
        self.mappable = True
        return None

    def _native_dtype(self, g: Any, c: _NChannel) -> Any:
        """The channel's dtype kind marker and its scaled extents (``c.extents``); errors as :meth:`_dtype`."""
        where = f"{self.path}: TDMS channel '{g.name}/{c.name}'"
        levels = (c.properties, g.properties, self._file.properties)
        for level in levels:
            n = level.get("NI_Number_Of_Scales")
            try:
                count = float(n) if n is not None else 0.0
            except (TypeError, ValueError):
                count = -1.0
            if not (count.is_integer() and 0 <= count <= _MAX_SCALES):
                raise RecordingError(f"{where}: implausible scaling property NI_Number_Of_Scales = {n!r}")
        if c.code is None or c.n == 0:
            return None
        if c.code in _NOT_NUMERIC:
            return None  # skipped, as npTDMS's dtype is not numeric
        if c.unsupported is not None:
            raise _Fallback(str(c.unsupported))
        steps = _native_scaling(where, levels)
        daqmx_raw = c.code == _DAQMX_RAW
        if steps is None:
            if daqmx_raw:
                raise RecordingError(f"{where}: DAQmx raw data without scaling properties (NI_Scale[n]_...)")
            base, ops = -1, []
        else:
            src, arg = steps[0]
            if src == "raw":
                if daqmx_raw:
                    raise _Fallback("DAQmx raw data scaled from the raw input source")
                base = -1
            else:
                if not daqmx_raw:
                    raise _Fallback("a DAQmx scaler source for a channel that is not DAQmx raw data")
                base = int(arg)
            ops = [(kind, list(a) if kind == "linear" else a) for kind, a in steps[1:]]
        ext = c.runs.get(base)
        if ext is None:
            raise _Fallback(f"channel '{g.name}/{c.name}' has no data for scale {base}")
        if ops and ops[0][0] == "linear" and ext.dtype == "f4":
            raise _Fallback("linear scaling of float32 data (npTDMS computes it in float32)")
        if len(c.runs) > 1 and not daqmx_raw:
            raise _Fallback("several DAQmx scalers for one channel")
        if ext.n != c.n:
            raise _Fallback(f"channel '{g.name}/{c.name}': {ext.n} samples in its segments, {c.n} declared")
        c.extents = ext.scaled(ops) if ops else ext
        return np.float64 if ops else np.dtype(ext.dtype)

    def file_layout(self, roles: Sequence[str]) -> Optional[Tuple[int, Dict[str, Any]]]:
        """(descriptor, {role: ``_core.Extents``}) for natively read files (see the module doc), else None."""
        if not self._native or self._closed or self._fd is None:
            return None
        out: Dict[str, Any] = {}
        for role in roles:
            name = self.roles.get(role)
            if name is None or self._scale[name] != 1.0:
                return None
            out[role] = self._objs[name].extents
        return self._fd, out

    def _npt_messages(self, log: _NptdmsLog, what: str) -> None:
        """Turns the npTDMS log records of one call into a RecordingError (inconsistent sizes) or warnings."""
        bad = log.inconsistent()
        if bad is not None:
            raise RecordingError(f"{self.path}: corrupt TDMS file: npTDMS, {what}: {bad}")
        for m in log.messages:
            w = f"npTDMS, {what}: {m}"
            if w not in self.warnings:
                self.warnings.append(w)

    def _dtype(self, g: Any, c: Any) -> Any:
        """The channel's (scaled) dtype; a missing or unusable scaling property is a RecordingError."""
        gname = g.name
        where = f"{self.path}: TDMS channel '{gname}/{c.name}'"
        for level in (c.properties, g.properties, self._file.properties):
            n = level.get("NI_Number_Of_Scales")
            try:
                count = float(n) if n is not None else 0.0
            except (TypeError, ValueError):
                count = -1.0
            if not (count.is_integer() and 0 <= count <= _MAX_SCALES):
                # npTDMS would build that many scalings (a flipped bit: 134 million, for minutes)
                raise RecordingError(f"{where}: implausible scaling property NI_Number_Of_Scales = {n!r}")
        try:
            with _NptdmsLog() as log:
                dt = c.dtype
        except KeyError as exc:
            prop = exc.args[0] if exc.args else "?"
            raise RecordingError(f"{where}: scaling property {prop!r} is missing") from None
        except Exception as exc:  # noqa: BLE001 - npTDMS's scaling code raises assorted errors
            raise RecordingError(f"{where}: unusable scaling properties: {' '.join(str(exc).split())}") from None
        unsupported = next((m for m in log.messages if "Unsupported scale type" in m), None)
        if unsupported is not None:
            # npTDMS would hand out the raw, unscaled values
            raise RecordingError(f"{where}: {unsupported.lower()} (values cannot be scaled)")
        self._npt_messages(log, f"channel '{gname}/{c.name}'")
        if getattr(c.data_type, "__name__", "") == "DaqMxRawData" and np.dtype(dt).kind not in "biuf":
            # npTDMS found no scaling for the channel's DAQmx raw bytes: it cannot give values
            raise RecordingError(f"{where}: DAQmx raw data without scaling properties (NI_Scale[n]_...)")
        return dt

    def _check_sizes(self, objs: Sequence[Tuple[str, Any]], implied: Mapping[str, int]) -> None:
        """Refuses a file whose segments hold data for an object that is no channel, or whose channels' lengths
        differ from what the segments' sizes imply (a corrupt file)."""
        known = {str(c.path) for g in self._file.groups() for c in g.channels()}
        lost = [p for p, k in implied.items() if k > 0 and p not in known]
        if lost:
            # npTDMS drops an object it cannot place in a group (e.g. a path with a flipped quote)
            raise RecordingError(
                f"{self.path}: corrupt TDMS file: data of object {lost[0]!r}, which is no channel of a group "
                "(malformed object path)"
            )
        for gname, c in objs:
            expect = implied.get(str(c.path))
            if expect is not None and expect != len(c):
                raise RecordingError(
                    f"{self.path}: corrupt TDMS file: channel '{gname}/{c.name}' has {len(c)} samples but "
                    f"its segments' sizes imply {expect}"
                )

    def _rate_from_increments(self) -> None:
        """The file's rate from the channels' ``wf_increment`` (one value for all, else refused)."""
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

    def _open(
        self,
        channels: Optional[Mapping[str, Optional[str]]],
        fs: Optional[float],
        scale: Optional[Mapping[str, float]],
        units: Optional[Mapping[str, str]],
        group: Optional[str],
        *,
        n_segments: int,
        implied: Mapping[str, int],
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
                dt = self._native_dtype(g, c) if self._native else self._dtype(g, c)
                kind = np.dtype(dt).kind if dt is not None else "O"
                if kind in "biuf" and len(c) > 0:
                    objs.append((g.name, c))
                else:
                    skipped.append(f"{g.name}/{c.name}")
        self._check_sizes(objs, implied)
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
        self._rate_from_increments()
        self.metadata = {
            "properties": {k: _plain(v) for k, v in self._file.properties.items()},
            "groups": [g.name for g in self._file.groups()],
            "tdms_segments": n_segments,
        }
        if skipped:
            self.metadata["skipped"] = skipped
        starts = [c.properties.get("wf_start_time") for c in self._objs.values()]
        starts = [st for st in starts if st is not None]
        if starts:  # the first sample's absolute time (UTC), for logs with absolute times (docs/method.md 6)
            self.metadata["start_time"] = str(np.datetime64(starts[0], "us"))
        self._default_roles = roles_by_name(self._names)
        self._setup(channels, fs, scale, units)

    def _read_ranges(self, names: Sequence[str], ranges: Sequence[Tuple[int, int]]) -> Dict[str, np.ndarray]:
        """Several ranges of each channel, one native call a channel (``_core.extents_read_ranges``: the
        pre-pass's hundreds of pieces without a call, an array and a descriptor each; issue 38 point 2)."""
        if not (self._native and self.thread_safe and hasattr(_core, "extents_read_ranges")):
            return super()._read_ranges(names, ranges)
        assert self._fd is not None
        return self._extents_ranges(self._fd, {nm: self._objs[nm].extents for nm in names}, names, ranges)

    def _read_range(self, names: Sequence[str], start: int, stop: int) -> Dict[str, np.ndarray]:
        if self._native:
            assert self._fd is not None
            try:
                got = {nm: self._objs[nm].extents.read(self._fd, start, stop) for nm in names}
            except ValueError as exc:
                self.check_unchanged()  # a changed file explains the error better
                raise RecordingError(f"{self.path}: cannot read TDMS samples {start}:{stop}: {exc}") from None
            self.check_unchanged()
            return got
        out = {}
        for nm in names:
            try:
                with _NptdmsLog() as log:
                    a = self._objs[nm].read_data(start, stop - start)
            except Exception as exc:  # noqa: BLE001 - npTDMS errors vary
                self.check_unchanged()  # a changed file explains the error better
                raise RecordingError(f"{self.path}: cannot read channel {nm!r}: {exc}") from None
            self._npt_messages(log, f"reading channel {nm!r}")
            if len(a) != stop - start:
                self.check_unchanged()
                raise RecordingError(
                    f"{self.path}: channel {nm!r} has {len(a)} samples in {start}:{stop} (truncated or corrupt file)"
                )
            out[nm] = np.asarray(a)
        self.check_unchanged()  # one stat per read: a file changed under npTDMS gives other numbers
        return out

    def _close(self) -> None:
        f, self._file = getattr(self, "_file", None), None
        if f is not None:
            f.close()
        fd, self._fd = getattr(self, "_fd", None), None
        if fd is not None:
            os.close(fd)


def _plain(v: Any) -> Any:
    """Property value for display: numpy scalars and datetimes as Python/str."""
    if isinstance(v, np.generic):
        return v.item() if v.dtype.kind in "biuf" else str(v)
    return v if isinstance(v, (int, float, str, bool)) or v is None else str(v)


def _tdms_string(s: str) -> bytes:
    b = s.encode("utf-8")
    return struct.pack("<I", len(b)) + b


def _tdms_props(props: Mapping[str, Any]) -> bytes:
    out = struct.pack("<I", len(props))
    for k, v in props.items():
        out += _tdms_string(k)
        if isinstance(v, str):
            out += struct.pack("<I", 0x20) + _tdms_string(v)
        elif isinstance(v, (int, np.integer)) and not isinstance(v, bool):
            out += struct.pack("<Ii", 3, int(v))
        else:
            out += struct.pack("<Id", 10, float(v))
    return out


def write_daqmx_tdms(
    path: str,
    raw: Mapping[str, np.ndarray],
    fs: float,
    scaling: Mapping[str, Sequence[Tuple[str, Any]]],
    *,
    group: str = "tribodyn",
    segment_samples: int = 1000,
    units: Optional[Mapping[str, str]] = None,
) -> None:
    """Writes int16 channels as a DAQmx raw TDMS file (as NI-DAQmx logs: interleaved int16 rows, one format-changing
    scaler per channel, metadata in the first segment only), for tests and benchmarks (npTDMS cannot write DAQmx).

    ``scaling[name]`` is the channel's scale chain after the DAQmx scaler (scale 0): ("Linear", (slope, intercept))
    or ("Polynomial", [c0, c1, ...]) steps, each taking the previous one as input.
    """
    names = list(raw)
    arrs = [np.asarray(raw[k], dtype="<i2") for k in names]
    n = len(arrs[0])
    width = 2 * len(names)
    rows = np.empty((n, len(names)), dtype="<i2")
    for j, a in enumerate(arrs):
        rows[:, j] = a
    with open(path, "wb") as fh:
        for start in range(0, n, segment_samples):
            stop = min(start + segment_samples, n)
            data = rows[start:stop].tobytes()
            if start == 0 or stop - start != min(segment_samples, n):  # a shorter last segment: its own metadata
                meta = struct.pack("<I", 2 + len(names))
                meta += _tdms_string("/") + struct.pack("<I", _NO_DATA) + _tdms_props({"name": "daqmx"})
                meta += _tdms_string(f"/'{group}'") + struct.pack("<I", _NO_DATA) + _tdms_props({})
                for j, nm in enumerate(names):
                    meta += _tdms_string(f"/'{group}'/'{nm}'") + struct.pack("<I", 0x1269)
                    meta += struct.pack("<IIQI", _DAQMX_RAW, 1, stop - start, 1)
                    meta += struct.pack("<IIIII", 3, 0, 2 * j, 0, 0)  # int16, buffer 0, byte offset, bitmap, id 0
                    meta += struct.pack("<II", 1, width)
                    steps = list(scaling.get(nm, ()))
                    props: Dict[str, Any] = {"NI_Scaling_Status": "unscaled", "NI_Number_Of_Scales": 1 + len(steps)}
                    for i, (kind, arg) in enumerate(steps, start=1):
                        props[f"NI_Scale[{i}]_Scale_Type"] = kind
                        if kind == "Linear":
                            props[f"NI_Scale[{i}]_Linear_Slope"] = float(arg[0])
                            props[f"NI_Scale[{i}]_Linear_Y_Intercept"] = float(arg[1])
                            props[f"NI_Scale[{i}]_Linear_Input_Source"] = i - 1
                        else:
                            props[f"NI_Scale[{i}]_Polynomial_Coefficients_Size"] = len(arg)
                            for k, c in enumerate(arg):
                                props[f"NI_Scale[{i}]_Polynomial_Coefficients[{k}]"] = float(c)
                            props[f"NI_Scale[{i}]_Polynomial_Input_Source"] = i - 1
                    props["wf_increment"] = 1.0 / fs
                    if units and nm in units:
                        props["unit_string"] = units[nm]
                    meta += _tdms_props(props)
                toc = _TOC_META_DATA | (1 << 2) | (1 << 3) | _TOC_DAQMX | _TOC_INTERLEAVED
            else:
                meta = b""
                toc = (1 << 3) | _TOC_DAQMX | _TOC_INTERLEAVED
            fh.write(b"TDSm" + struct.pack("<IIQQ", toc, 4713, len(meta) + len(data), len(meta)))
            fh.write(meta)
            fh.write(data)
