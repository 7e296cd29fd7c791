"""Format-independent core of :mod:`tribodyn.io`.

:class:`Recording` is what :func:`tribodyn.io.open_recording` returns: a handle
on one recording file that knows its channels, their units, the sampling rate
and how the file's channels map to the physical *roles* the analysis needs

=========  =====================================================
``fy``     friction (tangential) force
``fz``     normal force
``fx``     axial force (third axis)
``i``      current
``u``      voltage (e.g. a shunt)
``cof``    a coefficient-of-friction column computed by the instrument
=========  =====================================================

(any other role name may be used too). Each file format subclasses
:class:`Recording` and supplies either random access to a range of samples
(``_read_range``) or a sequential block reader (``_iter_blocks``); this module
turns either into :meth:`Recording.chunks` (fixed-size chunks, bounded memory)
and :meth:`Recording.read` (whole arrays), scaling every channel to SI.

Errors a user can cause or meet in a file (missing file, unknown format,
unmapped channel, truncated or corrupt file, no sampling rate, unequal channel
lengths) are raised as :class:`RecordingError` with a one-line message.
"""

from __future__ import annotations

import contextvars
import math
import operator
import os
import re
import threading
from collections import deque
from dataclasses import dataclass
from typing import Any, Dict, Iterator, List, Mapping, Optional, Protocol, Sequence, Tuple, Union

import numpy as np

from .units import GRAM_FORCE, normalize_unit, si_conversion

__all__ = [
    "KNOWN_ROLES",
    "TANGENTIAL_NAMES",
    "ROLE_NAMES",
    "cof_like",
    "ChannelInfo",
    "Recording",
    "RecordingError",
    "base_name",
    "one_role_per_channel",
    "resolve_name",
    "roles_by_name",
]

#: Roles the analysis knows; other role names are accepted as well.
KNOWN_ROLES: Tuple[str, ...] = ("fx", "fy", "fz", "i", "u", "cof")
#: The roles that hold forces (N after conversion).
FORCE_ROLES: Tuple[str, ...] = ("fx", "fy", "fz")

#: Rows a backend reads at once when the requested chunk is smaller: bounds
#: the per-call overhead of tiny chunks while keeping memory O(block).
DEFAULT_BLOCK_ROWS = 65536

# Channel-name aliases used to map roles by name when a format has no
# vendor-specific default (exact, case-insensitive, unit suffix stripped).
#: The channel vocabulary: per role, tiers of base names (:func:`base_name`: lower case, unit stripped) in
#: order of precedence (docs/method.md 6f). The first tier that names exactly one of a file's channels maps
#: the role; a tier that names two or more leaves it unmapped (ambiguous: the caller maps it), and so does
#: none. Every reader's default map by name comes from here (:func:`roles_by_name`); vendor layouts with
#: fixed columns (CETR, COMPEND) keep their exact maps in their reader.
ROLE_NAMES: Dict[str, Tuple[Tuple[str, ...], ...]] = {
    "fx": (("fx",),),
    "fy": (
        ("fy", "friction force", "friction_force", "ff"),
        ("frictionforce", "reibkraft", "reibungskraft", "traction force", "tractionforce"),
    ),
    "fz": (
        ("fz", "normal force", "normal_force", "load", "fn"),
        ("normalforce", "normal load", "normalkraft", "applied load"),
        ("ball load",),
        ("pin load",),
    ),
    "i": (("i", "current"), ("strom",)),
    "u": (("u", "voltage"), ("spannung",)),
    "cof": (
        ("cof", "mu", "friction coefficient", "coefficient of friction"),
        ("traction coeff", "traction coefficient", "friction coeff", "reibwert", "reibungskoeffizient", "reibungszahl"),
    ),
    # a bare "x" or "v" is not taken (CETR's X is a constant radius): --map x=CHANNEL
    "x": (("position", "displacement"), ("x-position", "x position", "x_position", "position x", "weg")),
    "v": (
        ("velocity", "sliding velocity"),
        ("x-velocity", "x velocity", "x_velocity", "velocity x", "geschwindigkeit"),
    ),
}
#: Every base name of a role, over its tiers.
_ROLE_ALIASES: Dict[str, Tuple[str, ...]] = {r: tuple(n for tier in t for n in tier) for r, t in ROLE_NAMES.items()}


#: Base names (see :func:`base_name`) of tangential force channels: the candidates for the friction
#: role when the map is automatic and several compete (:mod:`tribodyn.io.roles`). Ft and "tangential
#: force" are not names of a role by themselves (a lone Ft is mapped by the caller).
TANGENTIAL_NAMES: Tuple[str, ...] = (
    *_ROLE_ALIASES["fx"],
    *_ROLE_ALIASES["fy"],
    "ft",
    "tangential force",
    "tangential_force",
)


#: True while :func:`tribodyn.io.open_recording` opens a file that is still being written (``appending=True``).
APPENDING: contextvars.ContextVar[bool] = contextvars.ContextVar("tribodyn_appending", default=False)


class RecordingError(ValueError):
    """A recording cannot be opened or read; the message says why in one line."""


@dataclass(frozen=True)
class ChannelInfo:
    """One channel of a recording.

    Attributes
    ----------
    name : str
        The channel's name in the file (TDMS: ``channel`` or ``group/channel``;
        HDF5: the dataset path; NumPy: ``ch0``... or the npz key).
    unit : str or None
        Unit of the values :meth:`Recording.chunks` returns (after scaling),
        None when unknown.
    role : str or None
        The role mapped to this channel (first one, if several), or None.
    raw_unit : str or None
        Unit as written in the file, None when the file has none.
    scale : float
        Factor applied to the file's values (1.0 when none).
    note : str
        How unit and scale were decided (e.g. automatic gram-force -> N).
    """

    name: str
    unit: Optional[str]
    role: Optional[str] = None
    raw_unit: Optional[str] = None
    scale: float = 1.0
    note: str = ""


def fs_from_times(times: Sequence[np.ndarray], factor: float = 1.0) -> Optional[float]:
    """Sampling rate from time columns: 1 / median positive time step.

    Parameters
    ----------
    times : sequence of ndarray
        Time values of one or more contiguous acquisitions (steps are only
        taken within each array, never across two).
    factor : float
        Multiplies the time values to give seconds.

    Returns
    -------
    float or None
        The rate in Hz, rounded to 9 significant digits (so 25599.9999948
        reads 25600), or None when there is no positive step.
    """
    steps = [np.diff(np.asarray(t, dtype=np.float64)) for t in times if len(t) > 1]
    if not steps:
        return None
    d = np.concatenate(steps) * factor
    d = d[np.isfinite(d) & (d > 0)]
    if d.size == 0:
        return None
    fs = 1.0 / float(np.median(d))
    return float(f"{fs:.9g}")


def rate_from_step(step: float) -> float:
    """``1 / step`` rounded to 12 significant digits (2e-5 s -> 50000.0, not 50000.00000000001)."""
    return float(f"{1.0 / step:.12g}")


def base_name(name: str) -> str:
    """Lower-case name without a group/dataset path and without a unit suffix."""
    s = name.strip().lower()
    for o, c in (("[", "]"), ("(", ")")):  # the unit first: it may hold a "/" (mm/s, N/m)
        if s.endswith(c) and o in s:
            s = s[: s.rindex(o)].strip()
    return s.rsplit("/", 1)[-1].strip()


def roles_by_name(names: Sequence[str]) -> Dict[str, str]:
    """Default role map from channel names alone (used where no vendor map applies).

    A role is mapped by the first tier of :data:`ROLE_NAMES` that names
    exactly one channel (base names, see :func:`base_name`); a tier naming
    two or more leaves it unmapped, so nothing is guessed when the names are
    ambiguous. A channel mapped to one role is not taken for another.
    """
    out: Dict[str, str] = {}
    bases = [base_name(n) for n in names]
    for role, tiers in ROLE_NAMES.items():
        for tier in tiers:
            hits = [n for n, b in zip(names, bases) if b in tier and n not in out.values()]
            if hits:
                if len(hits) == 1:
                    out[role] = hits[0]
                break
    return out


#: Words of a base name that make a channel a COF (another definition than the mapped ``cof``: a peak COF,
#: an effective-value COF, a traction coefficient).
_COF_WORDS = ("cof", "coefficient", "coeff", "reibwert", "reibungszahl", "reibungskoeffizient")


def cof_like(names: Sequence[str]) -> List[str]:
    """The channels whose names say they hold a COF (``Peak COF``, ``mu_eff``, ``Friction coefficient RMS``)."""
    out = []
    for n in names:
        b = base_name(n)
        words = set(re.split(r"[^a-z0-9µ]+", b))
        if any(w in b for w in _COF_WORDS) or words & {"mu", "µ"} or b.startswith(("mu_", "µ_")):
            out.append(n)
    return out


def one_role_per_channel(roles: Mapping[str, str], what: str) -> None:
    """Raises :class:`RecordingError` (a ValueError) when ``roles`` binds one channel to two roles."""
    seen: Dict[str, str] = {}
    for role, name in roles.items():
        if name in seen:
            raise RecordingError(
                f"{what}: channel {name!r} is bound to both {seen[name]!r} and {role!r}; "
                "a channel carries one role: map each role to its own channel"
            )
        seen[name] = role


def resolve_name(
    path: str,
    names: Sequence[str],
    name: str,
    what: str = "channel",
    aliases: Optional[Mapping[str, str]] = None,
) -> str:
    """Finds channel ``name`` among ``names``.

    Tries an exact match, then ``aliases`` (other spellings -> name, e.g.
    TDMS ``group/channel``), then the name without leading/trailing ``/``,
    then a unique match of the last path component (``channel`` for
    ``group/channel``), then a unique case-insensitive match.

    Raises
    ------
    RecordingError
        No match; the message lists the available channels.
    """
    if name in names:
        return name
    stripped = name.strip("/")
    for cand in (name, stripped):
        if aliases and cand in aliases and aliases[cand] in names:
            return aliases[cand]
    if stripped in names:
        return stripped
    suffix = [n for n in names if n.rsplit("/", 1)[-1] == stripped]
    if len(suffix) == 1:
        return suffix[0]
    folded = [n for n in names if n.lower() == stripped.lower()]
    if len(folded) == 1:
        return folded[0]
    avail = ", ".join(repr(n) for n in names)
    raise RecordingError(f"{path}: no channel {name!r} ({what}); available channels: {avail}")


def _as_str_list(x: Union[str, Sequence[str]]) -> List[str]:
    if isinstance(x, str):
        return [x]
    return [str(v) for v in x]


class RecordingProtocol(Protocol):
    """What the pipeline needs of a recording (docs/architecture.md): its data and its declared capabilities.

    :class:`Recording` (every reader of :func:`tribodyn.io.open_recording`)
    satisfies it. :func:`tribodyn.pipeline.routes.choose_route` picks the route from
    the capabilities (``acquisitions``, ``mappable``, ``random_access``,
    ``thread_safe``, ``views``) before anything is read, never from a
    format's name.
    """

    path: str
    fs: float
    roles: Dict[str, str]
    warnings: List[str]
    #: Sample ranges of separate acquisitions to window apart, or None (one acquisition).
    acquisitions: Optional[List[Tuple[int, int]]]
    random_access: bool
    thread_safe: bool
    mappable: bool
    views: bool
    #: How ``fy`` was bound when the role map was chosen from the data (:class:`tribodyn.io.roles.RoleChoice`), or None.
    role_choice: Optional[Any]  # an io.roles.RoleChoice (io.roles builds on this module)

    @property
    def n_samples(self) -> int: ...

    @property
    def roles_source(self) -> str: ...

    def chunks(
        self,
        size: int,
        roles: Union[None, str, Sequence[str]] = None,
        *,
        start: int = 0,
        stop: Optional[int] = None,
        copy: bool = True,
    ) -> Iterator[Dict[str, np.ndarray]]: ...

    def read(self, roles: Union[None, str, Sequence[str]] = None) -> Dict[str, np.ndarray]: ...

    def file_layout(self, roles: Sequence[str]) -> Optional[Tuple[int, Dict[str, Any]]]: ...

    def check_unchanged(self) -> None: ...


class Recording:
    """A recording file opened for reading; use :func:`tribodyn.io.open_recording`.

    Attributes
    ----------
    path : str
        The file.
    format : str
        ``tdms``, ``lvm``, ``hdf5``, ``npy``, ``npz``, ``delimited``, ``cetr``,
        ``compend``, ``steps``, ``mat``, ``spreadsheet``, or a reader plugin's.
    fs : float
        Sampling rate in Hz.
    n_samples : int
        Samples per channel.
    duration : float
        ``n_samples / fs`` in seconds.
    channels : list of ChannelInfo
        All channels, in file order.
    roles : dict
        Role -> channel name.
    segments : list of (int, int)
        ``(start, stop)`` sample ranges of the separate acquisitions the file
        holds (CETR steps, LVM segments); one range covering everything for
        single-acquisition files.
    metadata : dict
        Header information of the file (format dependent, for display).
    warnings : list of str
        Oddities found while opening (e.g. an LVM segment holding more rows
        than its header announced).

    Notes
    -----
    The object is a context manager; :meth:`close` releases the file.
    Chunks are float64 arrays, scaled to SI, keyed by role (or by the raw
    channel name when a requested key is not a role).
    """

    format: str = "?"
    #: Whether :meth:`chunks` reads the file incrementally (False for formats
    #: where the library must hold a whole member).
    streaming: bool = True

    # -- Capabilities, declared by each reader class. The pipeline chooses
    # its route from these before it reads (tribodyn.pipeline.routes.choose_route),
    # never from a format's name.
    #: Reads any range of samples directly (``chunks(start=, stop=)`` does
    #: not read what comes before), not only in order.
    random_access: bool = False
    #: May be read from several threads at once. The reads of a reader that
    #: is not (npTDMS and h5py keep one file position per handle) go
    #: through the recording's own lock, and the pipeline reads it from one
    #: thread only.
    thread_safe: bool = False
    #: Channels may lie in the file as contiguous float64 runs that a kernel
    #: reads itself (:meth:`file_layout` then says where, per file).
    mappable: bool = False
    #: ``chunks(copy=False)`` may hand out read-only views of the file's
    #: pages instead of copies.
    views: bool = False
    #: Sample ranges of the separate acquisitions the pipeline windows apart
    #: (CETR steps, time restarts, LVM segments marked discontinuous), or
    #: None: one acquisition.
    acquisitions: Optional[List[Tuple[int, int]]] = None

    def __init__(self, path: Union[str, "os.PathLike[str]"]) -> None:
        self.path: str = os.fspath(path)
        #: The file may grow while it is read, never shrink or be replaced (``open_recording(appending=True)``,
        #: :class:`tribodyn.io.follow.Follower`): :meth:`check_unchanged` then allows a larger size and a later
        #: modification time, and an HDF5 file is opened for a single writer's readers (SWMR).
        self._appending: bool = APPENDING.get()
        self._closed = False
        self._names: List[str] = []
        self._raw_units: Dict[str, Optional[str]] = {}
        self._auto: Dict[str, Tuple[float, Optional[str], str]] = {}
        self._n = 0
        self._file_fs: Optional[float] = None
        self._fs_source = ""
        self._segments: List[Tuple[int, int]] = []
        self._default_roles: Dict[str, str] = {}
        #: How ``fy`` was bound when the map is automatic and several tangential channels compete
        #: (:func:`tribodyn.io.roles.choose_roles`, run by :func:`~tribodyn.io.open_recording`); None otherwise.
        self.role_choice: Optional[Any] = None
        self.metadata: Dict[str, Any] = {}
        self.warnings: List[str] = []
        self._block_rows = DEFAULT_BLOCK_ROWS
        self._aliases: Dict[str, str] = {}
        self._lock = threading.Lock()

    # ------------------------------------------------------------------ setup
    def _setup(
        self,
        channels: Optional[Mapping[str, Optional[str]]],
        fs: Optional[float],
        scale: Optional[Mapping[str, float]],
        units: Optional[Mapping[str, str]] = None,
    ) -> None:
        """Finishes opening once the backend has filled the raw description.

        Resolves the role map (defaults overridden by ``channels``), the
        sampling rate (``fs`` overrides the file's) and per-channel scaling
        (``scale`` overrides automatic unit conversion).
        """
        if not self._names:
            raise RecordingError(f"{self.path}: no readable channel in this {self.format} file")
        # roles
        roles: Dict[str, str] = dict(self._default_roles)
        given: Dict[str, str] = {}
        if channels is not None:
            if not isinstance(channels, Mapping):
                raise RecordingError("channels must be a mapping role -> channel name")
            for role, name in channels.items():
                if name is None:
                    roles.pop(role, None)
                else:
                    given[str(role)] = self._resolve(str(name), what=f"channel for role {role!r}")
            one_role_per_channel(given, "channels")
            # A channel the caller binds is taken from the default role that had it (--map fy=Fx on a
            # file whose names gave fx <- Fx must not leave fx and fy on one channel).
            roles = {r: n for r, n in roles.items() if r in given or n not in given.values()}
            roles.update(given)
        self.roles: Dict[str, str] = roles
        #: Roles the caller bound (the rest come from the format's or the evidence's default map).
        self.roles_given: Dict[str, str] = given
        # sampling rate
        if fs is not None:
            try:
                fs_v = float(fs)
            except (TypeError, ValueError):
                raise RecordingError(f"fs must be a number, got {fs!r}") from None
            if not (math.isfinite(fs_v) and fs_v > 0):
                raise RecordingError(f"fs must be finite and > 0, got {fs!r}")
            if self._file_fs is not None and abs(fs_v - self._file_fs) > 1e-9 * self._file_fs:
                self.warnings.append(
                    f"fs={fs_v:g} Hz given overrides the file's {self._file_fs:g} Hz ({self._fs_source})"
                )
            self.fs: float = fs_v
            self._fs_source = "given by the caller"
        elif self._file_fs is not None:
            if not (math.isfinite(self._file_fs) and self._file_fs > 0):
                raise RecordingError(f"{self.path}: the file's sampling rate is invalid ({self._file_fs!r}); pass fs=")
            self.fs = float(self._file_fs)
        else:
            raise RecordingError(
                f"{self.path}: sampling rate unknown (this {self.format} file does not carry it); pass fs=... (Hz)"
            )
        self._scaling_args = (scale, units)
        self._scale, self.channels = self._scaling(self.roles)
        if not self._segments:
            self._segments = [(0, self._n)]
        self._identity_at_open = self._identity()

    def _scaling(self, roles: Mapping[str, str]) -> Tuple[Dict[str, float], List[ChannelInfo]]:
        """Per-channel factor to SI and the channel list under the role map ``roles`` (the keys of the
        ``scale`` and ``units`` given at opening are roles or channels: a role's follows its channel)."""
        scale, units = self._scaling_args
        user_scale: Dict[str, float] = {}
        for key, f in (scale or {}).items():
            name = self._key_to_name(key, f"scale key {key!r}", roles)
            try:
                fv = float(f)
            except (TypeError, ValueError):
                raise RecordingError(f"scale[{key!r}] must be a number, got {f!r}") from None
            if not (math.isfinite(fv) and fv != 0):
                raise RecordingError(f"scale[{key!r}] must be finite and non-zero, got {f!r}")
            user_scale[name] = fv
        user_units: Dict[str, str] = {}
        for key, u in (units or {}).items():
            name = self._key_to_name(key, f"units key {key!r}", roles)
            user_units[name] = str(u)
        role_of: Dict[str, str] = {}
        for role, name in roles.items():
            role_of.setdefault(name, role)
        infos: List[ChannelInfo] = []
        factors: Dict[str, float] = {}
        for name in self._names:
            raw = self._raw_units.get(name)
            if name in user_scale:
                f = user_scale[name]
                unit = user_units.get(name)
                note = f"scaled by the caller (x{f:g})"
            elif name in self._auto:
                f, unit, note = self._auto[name]
            elif role_of.get(name) in FORCE_ROLES and normalize_unit(raw) in ("g", "G"):
                # a force in "g" can only be gram-force (standard gravity is no force): issue 34 point 4
                f, unit, note = GRAM_FORCE, "N", "'g' on a force channel is gram-force: converted to N (x9.80665e-3)"
            else:
                f, unit, note = si_conversion(raw)
            if name in user_units:
                unit = user_units[name]
                note = (note + "; " if note else "") + "unit given by the caller"
            factors[name] = f
            infos.append(ChannelInfo(name, unit, role_of.get(name), raw, f, note))
        return factors, infos

    @property
    def roles_source(self) -> str:
        """ "automatic" (the caller bound no role), "given" (the caller bound every role of the map) or
        "partly given"."""
        if not self.roles_given:
            return "automatic"
        return "given" if all(self.roles_given.get(r) == n for r, n in self.roles.items()) else "partly given"

    @property
    def keys_by_role(self) -> List[str]:
        """The keys of the ``scale`` and ``units`` given at opening that name a role, not a channel."""
        scale, units = self._scaling_args
        return sorted({k for k in (*(scale or {}), *(units or {})) if k in self.roles})

    def _rebind(self, roles: Mapping[str, str]) -> None:
        """Replaces the role map (the automatic choice by evidence, :mod:`tribodyn.io.roles`); a scale or unit
        given by role follows its role to the new channel."""
        roles = dict(roles)
        one_role_per_channel(roles, "role map")
        missing = [n for n in roles.values() if n not in self._names]
        if missing:
            raise RecordingError(f"{self.path}: no channel {missing[0]!r} to map")
        self._scale, self.channels = self._scaling(roles)
        self.roles = roles

    def _identity(self) -> Optional[Tuple[int, int, int, int]]:
        """(size, mtime_ns, inode, device) of the file read: of the recording's own descriptor when it holds one
        (a path renamed over later names another file, which is not read), else of the path."""
        try:
            fd = getattr(self, "_fd", None)
            st = os.fstat(fd) if isinstance(fd, int) else os.stat(self.path)
        except OSError:
            return None
        return (st.st_size, st.st_mtime_ns, st.st_ino, st.st_dev)

    def check_unchanged(self) -> None:
        """Raises :class:`RecordingError` when the file changed since it was opened (size, mtime or inode).

        Called after the last read of :meth:`chunks` and :meth:`read`, and by
        :func:`tribodyn.analyze` after a recording's last window: a file
        truncated, rewritten or replaced while it was read is an error, not a
        table of mixed data.
        """
        before = getattr(self, "_identity_at_open", None)
        now = self._identity()
        if before is None or now == before:
            return
        if self._appending and now is not None and now[0] >= before[0] and now[2:] == before[2:]:
            return  # a followed file (tribodyn.io.follow) grows; what was read stays as it was
        what = [
            name for name, a, b in zip(("size", "modification time", "inode", "device"), before, now or ()) if a != b
        ]
        raise RecordingError(
            f"{self.path}: file changed while it was read ({', '.join(what) or 'gone'} differ from when it was opened)"
        )

    def _fs_from_time_channel(self, time_channel: str) -> None:
        """Sets the file's fs from the median step of a time channel (in seconds).

        Only the first 100 001 samples are read.
        """
        name = self._resolve(time_channel, "time_channel")
        m = min(self._n, 100_001)
        blocks = self._iter_blocks([name], m)
        try:
            t = np.asarray(next(blocks)[name][:m], dtype=np.float64)
        finally:
            close = getattr(blocks, "close", None)  # a generator: release its file now
            if close is not None:
                close()
        f = fs_from_times([t])
        if f is None:
            raise RecordingError(f"{self.path}: time channel {name!r} has no increasing steps")
        self._file_fs = f
        self._fs_source = f"median step of time channel {name!r}"

    def _resolve(self, name: str, what: str = "channel") -> str:
        """File channel name for ``name`` (see :func:`resolve_name`)."""
        return resolve_name(self.path, self._names, name, what, self._aliases)

    # ------------------------------------------------------------- properties
    @property
    def n_samples(self) -> int:
        """Samples per channel."""
        return self._n

    @property
    def duration(self) -> float:
        """Length of the recording in seconds (``n_samples / fs``)."""
        return self._n / self.fs

    @property
    def segments(self) -> List[Tuple[int, int]]:
        """``(start, stop)`` sample ranges of the file's separate acquisitions."""
        return list(self._segments)

    @property
    def start_time(self) -> Optional[str]:
        """Absolute time of the first sample as an ISO 8601 string (UTC), or None when the file does not say.

        TDMS: the mapped channels' ``wf_start_time``. Logs with absolute
        times are aligned with it (docs/method.md 6).
        """
        st = self.metadata.get("start_time")
        return None if st is None else str(st)

    @property
    def closed(self) -> bool:
        """True once :meth:`close` was called."""
        return self._closed

    @property
    def channel_names(self) -> List[str]:
        """Names of all channels, in file order."""
        return list(self._names)

    def info(self) -> Dict[str, Any]:
        """Summary for display (``tribodyn info FILE``).

        Returns
        -------
        dict
            ``path``, ``format``, ``size_bytes``, ``fs``, ``fs_source``,
            ``n_samples``, ``duration``, ``segments``, ``roles``,
            ``roles_source``, ``roles_evidence`` (see :attr:`role_choice`),
            ``channels`` (list of dicts: name, unit, role, raw_unit, scale,
            note), ``streaming``, ``metadata``, ``warnings``.
        """
        try:
            size = os.path.getsize(self.path)
        except OSError:
            size = None
        return {
            "path": self.path,
            "format": self.format,
            "size_bytes": size,
            "fs": self.fs,
            "fs_source": self._fs_source,
            "n_samples": self._n,
            "duration": self.duration,
            "segments": self.segments,
            "roles": dict(self.roles),
            "roles_source": self.roles_source,
            "roles_evidence": self.role_choice.as_dict() if self.role_choice is not None else None,
            "channels": [
                {
                    "name": c.name,
                    "unit": c.unit,
                    "role": c.role,
                    "raw_unit": c.raw_unit,
                    "scale": c.scale,
                    "note": c.note,
                }
                for c in self.channels
            ],
            "streaming": self.streaming,
            "metadata": dict(self.metadata),
            "warnings": list(self.warnings),
        }

    # ---------------------------------------------------------------- reading
    def _keys(self, roles: Union[None, str, Sequence[str]]) -> List[Tuple[str, str]]:
        """(output key, file channel name) pairs for a roles argument."""
        if roles is None:
            if self.roles:
                return list(self.roles.items())
            return [(n, n) for n in self._names]
        out: List[Tuple[str, str]] = []
        seen = set()
        for key in _as_str_list(roles):
            if key in seen:
                continue
            seen.add(key)
            out.append((key, self._key_to_name(key)))
        if not out:
            raise RecordingError("roles is empty: name at least one role or channel")
        return out

    def _key_to_name(self, key: str, what: str = "", roles: Optional[Mapping[str, str]] = None) -> str:
        """File channel of a role or channel name given by the caller.

        A mapped role (of ``roles``, default the recording's map) wins; an
        unmapped known role (``fx``...) only matches a channel of exactly that
        name, never a look-alike such as ``Fx``.
        """
        roles = self.roles if roles is None else roles
        if key in roles:
            return roles[key]
        try:
            if key in KNOWN_ROLES and key not in self._names:
                raise RecordingError(key)
            return self._resolve(key)
        except RecordingError:
            mapped = ", ".join(f"{r}={n!r}" for r, n in roles.items()) or "none"
            avail = ", ".join(repr(n) for n in self._names)
            where = f" ({what})" if what else ""
            raise RecordingError(
                f"{self.path}: {key!r}{where} is neither a mapped role (mapped: {mapped}) "
                f"nor a channel; available channels: {avail}"
            ) from None

    def _check_open(self) -> None:
        if self._closed:
            raise RecordingError(f"{self.path}: recording is closed")

    #: True when every array the backend returns is newly allocated for the
    #: call and kept nowhere else, so chunks may hand it out without a copy.
    _owned_reads: bool = False

    def _read_range(self, names: Sequence[str], start: int, stop: int) -> Dict[str, np.ndarray]:
        """Raw (unscaled) samples ``start:stop`` of the named channels (random-access formats)."""
        raise NotImplementedError  # pragma: no cover - every backend overrides one reader

    def _read(self, names: Sequence[str], start: int, stop: int) -> Dict[str, np.ndarray]:
        """:meth:`_read_range`, under the recording's lock unless the reader is :attr:`thread_safe`."""
        if self.thread_safe:
            return self._read_range(names, start, stop)
        with self._lock:
            self._check_open()
            return self._read_range(names, start, stop)

    def _read_ranges(self, names: Sequence[str], ranges: Sequence[Tuple[int, int]]) -> Dict[str, np.ndarray]:
        """Raw samples of several ranges, concatenated (random-access formats; text files read them in one call)."""
        parts = [self._read(names, a, b) for a, b in ranges]
        return {n: np.concatenate([p[n] for p in parts]) if parts else np.zeros(0) for n in names}

    def _extents_ranges(self, fd: int, extents: Mapping[str, Any], names: Sequence[str],
                        ranges: Sequence[Tuple[int, int]]) -> Dict[str, np.ndarray]:  # fmt: skip
        """:meth:`_read_ranges` of channels the native reader describes (``extents``: name -> ``_core.Extents``),
        one call of ``_core.extents_read_ranges`` a channel on the open file ``fd`` (the pre-pass's hundreds of
        pieces; issue 38 point 2); a read that fails after the file changed says so."""
        from .. import _core

        spans = [(int(a), int(b)) for a, b in ranges]
        out = {}
        for nm in names:
            try:
                out[nm] = _core.extents_read_ranges(extents[nm], fd, spans)
            except ValueError as exc:  # "a:b: why"
                self.check_unchanged()  # a changed file explains the error better
                raise RecordingError(f"{self.path}: cannot read {nm!r}: samples {exc}") from None
        self.check_unchanged()  # (HDF5 fills what lies past the end of a truncated file with zeros)
        return out

    def read_ranges(self, ranges: Sequence[Tuple[int, int]], roles: Union[None, str, Sequence[str]] = None
                    ) -> Dict[str, np.ndarray]:  # fmt: skip
        """Samples ``a:b`` of every ``(a, b)`` in ``ranges``, concatenated, scaled to SI (random-access formats).

        Keyed as :meth:`chunks`; used to look at spread-out parts of a long
        recording without reading all of it.
        """
        self._check_open()
        if not self.random_access:
            raise RecordingError(f"{self.path}: read_ranges needs a random-access format")
        for a, b in ranges:
            if not (0 <= a <= b <= self._n):
                raise RecordingError(f"ranges must satisfy 0 <= a <= b <= {self._n}, got ({a}, {b})")
        keys = self._keys(roles)
        names = list(dict.fromkeys(n for _, n in keys))
        return self._scaled(keys, self._read_ranges(names, ranges))

    def _iter_blocks(self, names: Sequence[str], block: int) -> Iterator[Dict[str, np.ndarray]]:
        """Raw (unscaled) consecutive blocks of about ``block`` rows covering the recording.

        The default reads ranges with :meth:`_read`; sequential formats
        override this instead.
        """
        for start in range(0, self._n, block):
            yield self._read(names, start, min(start + block, self._n))

    def file_layout(self, roles: Sequence[str]) -> Optional[Tuple[int, Dict[str, Any]]]:
        """(file descriptor, byte offset of sample 0 of each role's channel, or its ``_core.Extents``), or None.

        Not None only when every channel asked for is stored as one
        contiguous, 8-byte aligned run of little-endian float64 samples
        needing no scaling (a channels-first float64 ``.npy``): then a kernel
        can read the file's pages directly
        (``tribodyn._core.windows_stats_file``). The descriptor is the one
        the recording opened (the file it was opened on, even if the path
        now names another) and stays the recording's.
        """
        return None

    def _can_view(self) -> bool:
        """True when this file's :meth:`_view_range` hands out views (readers declaring :attr:`views`)."""
        return False

    def _view_range(self, names: Sequence[str], start: int, stop: int) -> Dict[str, np.ndarray]:
        """Read-only views of raw samples ``start:stop`` without a copy (when :meth:`_can_view`).

        Backends that can hand out the file's own pages (npy) override this;
        :meth:`chunks` uses it with ``copy=False``.
        """
        raise NotImplementedError  # pragma: no cover

    def _scaled(
        self, key_names: Sequence[Tuple[str, str]], raw: Dict[str, np.ndarray], copy: bool = True
    ) -> Dict[str, np.ndarray]:
        out: Dict[str, np.ndarray] = {}
        for key, name in key_names:
            r = raw[name]
            f = self._scale[name]
            if not copy and r.dtype == np.float64 and f == 1.0:
                out[key] = r  # may be a read-only view (copy=False)
                continue
            # Hand out a fresh, owned array: reuse one the backend just made
            # (it owns its data, nothing else refers to it), copy anything else.
            fresh = (
                self._owned_reads and r.dtype == np.float64 and r.flags.owndata and r.flags.writeable and r.base is None
            )
            a = r if fresh else np.array(r, dtype=np.float64)
            if f != 1.0:
                a *= f
            out[key] = a
        return out

    def chunks(
        self,
        size: int,
        roles: Union[None, str, Sequence[str]] = None,
        *,
        start: int = 0,
        stop: Optional[int] = None,
        copy: bool = True,
    ) -> Iterator[Dict[str, np.ndarray]]:
        """Consecutive chunks of ``size`` samples (the last one may be shorter).

        ``start`` and ``stop`` (sample indices, like a slice) restrict the
        chunks to part of the recording: random-access formats (TDMS, HDF5,
        npy) read only that part; sequential ones (text, npz) skip ahead.

        With ``copy=False`` a chunk's arrays may be read-only views without
        a copy: for a channels-first float64 ``.npy``, views of the file's
        pages, mapped for that chunk alone (the mapping goes when the last
        array of the chunk does, so memory stays flat) and valid as long as
        they are referenced. The file must not be truncated while such
        views are alive (reading a page past its end then kills the
        process, as with any memory map). Other formats return what they
        would with ``copy=True``, minus the copy where one is not needed.

        Parameters
        ----------
        size : int
            Samples per chunk, >= 1.
        roles : sequence of str, optional
            Roles and/or channel names to read. None: every mapped role, or
            every channel (keyed by name) when no role is mapped.

        Yields
        ------
        dict of str to ndarray
            float64 arrays of equal length, scaled to SI, keyed by the names
            asked for.

        Raises
        ------
        RecordingError
            Unknown role/channel (raised at the call), or a corrupt or
            truncated file (raised when the bad part is reached).

        Notes
        -----
        The file is read incrementally: peak memory is of the order of
        ``max(size, 65536)`` samples per channel, whatever the file's length
        (npz members written compressed are decompressed incrementally too).
        """
        try:
            size = operator.index(size)
        except TypeError:
            raise RecordingError(f"chunk size must be an integer, got {size!r}") from None
        if size < 1:
            raise RecordingError(f"chunk size must be >= 1, got {size}")
        self._check_open()
        stop = self._n if stop is None else stop
        if not (isinstance(start, int) and isinstance(stop, int) and 0 <= start <= stop <= self._n):
            raise RecordingError(f"start/stop must satisfy 0 <= start <= stop <= {self._n}, got {start}, {stop}")
        keys = self._keys(roles)
        names = list(dict.fromkeys(n for _, n in keys))
        copy = bool(copy)
        if not copy and self.views and self._can_view():
            # Views: one mapping per chunk, so a chunk never straddles two.
            return self._chunk_gen(
                size, keys, names, self._view_blocks(names, size, start, stop), expected=stop - start, copy=False
            )
        block = max(size, self._block_rows)
        if start == 0 and stop == self._n:
            return self._chunk_gen(size, keys, names, self._iter_blocks(names, block), expected=self._n, copy=copy)
        return self._chunk_gen(
            size, keys, names, self._range_blocks(names, block, start, stop), expected=stop - start, copy=copy
        )

    def _view_blocks(self, names: Sequence[str], size: int, start: int, stop: int) -> Iterator[Dict[str, np.ndarray]]:
        for a in range(start, stop, size):
            self._check_open()
            yield self._view_range(names, a, min(a + size, stop))

    def _range_blocks(self, names: Sequence[str], block: int, start: int, stop: int) -> Iterator[Dict[str, np.ndarray]]:
        """Raw blocks covering samples ``start:stop`` only."""
        if self.random_access:
            for a in range(start, stop, block):
                yield self._read(names, a, min(a + block, stop))
            return
        pos = 0
        for blk in self._iter_blocks(names, block):
            m = len(blk[names[0]])
            lo, hi = max(start - pos, 0), min(stop - pos, m)
            pos += m
            if lo < hi:
                yield {n: blk[n][lo:hi] for n in names}
            if pos >= stop:
                return

    def _chunk_gen(
        self,
        size: int,
        keys: List[Tuple[str, str]],
        names: List[str],
        blocks: Iterator[Dict[str, np.ndarray]],
        *,
        expected: int,
        copy: bool = True,
    ) -> Iterator[Dict[str, np.ndarray]]:
        pending: deque[Tuple[Dict[str, np.ndarray], int]] = deque()
        offset = 0  # rows of pending[0] already handed out
        buffered = 0
        total = 0

        def take(k: int) -> Dict[str, np.ndarray]:
            nonlocal offset, buffered
            parts: Dict[str, List[np.ndarray]] = {n: [] for n in names}
            need = k
            while need:
                blk, m = pending[0]
                t = min(m - offset, need)
                for n in names:
                    parts[n].append(blk[n][offset : offset + t])
                need -= t
                if offset + t == m:
                    pending.popleft()
                    offset = 0
                else:
                    offset += t
            buffered -= k
            raw = {n: (p[0] if len(p) == 1 else np.concatenate(p)) for n, p in parts.items()}
            return self._scaled(keys, raw, copy)

        for blk in blocks:
            self._check_open()
            m = len(blk[names[0]])
            if any(len(blk[n]) != m for n in names):
                raise RecordingError(f"{self.path}: unequal channel lengths in a block")
            if m == 0:
                continue
            total += m
            pending.append((blk, m))
            buffered += m
            while buffered >= size:
                yield take(size)
        if buffered:
            yield take(buffered)
        self.check_unchanged()
        if total != expected:
            raise RecordingError(
                f"{self.path}: read {total} samples but expected {expected} of the {self._n} announced "
                "(file changed or truncated since it was opened?)"
            )

    def read(self, roles: Union[None, str, Sequence[str]] = None) -> Dict[str, np.ndarray]:
        """Whole channels as float64 arrays scaled to SI.

        Parameters
        ----------
        roles : sequence of str, optional
            As for :meth:`chunks`.

        Returns
        -------
        dict of str to ndarray
        """
        self._check_open()
        keys = self._keys(roles)
        names = list(dict.fromkeys(n for _, n in keys))
        out = {k: np.empty(self._n, dtype=np.float64) for k, _ in keys}
        pos = 0
        for blk in self._iter_blocks(names, self._block_rows):
            m = len(blk[names[0]])
            if pos + m > self._n:
                raise RecordingError(f"{self.path}: more samples than announced (file changed?)")
            for k, n in keys:
                if len(blk[n]) != m:
                    raise RecordingError(f"{self.path}: unequal channel lengths in a block")
                dst = out[k][pos : pos + m]
                dst[...] = blk[n]
                f = self._scale[n]
                if f != 1.0:
                    dst *= f
            pos += m
        self.check_unchanged()
        if pos != self._n:
            raise RecordingError(
                f"{self.path}: read {pos} samples but the file announced {self._n} "
                "(file changed or truncated since it was opened?)"
            )
        return out

    # -------------------------------------------------------------- lifetime
    def _close(self) -> None:
        """Backend hook: release handles."""

    def close(self) -> None:
        """Releases the file; further reads raise :class:`RecordingError`."""
        if not self._closed:
            self._closed = True
            self._close()

    def __enter__(self) -> "Recording":
        return self

    def __reduce_ex__(self, protocol: Any) -> Any:
        """An open recording holds a file and its lock: it is not pickled (sent to a worker process) or
        copied; its path is (issue 38 audit: the error was pickle's "cannot pickle '_thread.lock' object")."""
        raise TypeError(
            f"an open recording ({os.path.basename(str(self.path))}) cannot be pickled or copied: send its path "
            "to the worker and open it there (tribodyn.open_recording), or use tribodyn.analyze_many"
        )

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:  # pragma: no cover - best effort
        try:
            self.close()
        except Exception:  # noqa: BLE001, S110 - never raise from a finalizer
            pass

    def __repr__(self) -> str:
        state = "closed" if self._closed else f"{len(self._names)} channels"
        fs = getattr(self, "fs", None)
        return (
            f"<Recording {self.format} {os.path.basename(self.path)!r}: {state}, "
            f"{self._n} samples, fs={fs!r} Hz, roles={getattr(self, 'roles', {})}>"
        )


def equal_length_selection(
    path: str, lengths: Mapping[str, int], wanted: Sequence[str]
) -> Tuple[List[str], int, List[str]]:
    """Chooses the channels of a file whose members may differ in length.

    Parameters
    ----------
    path : str
        For messages.
    lengths : mapping
        Channel name -> number of samples (file order).
    wanted : sequence of str
        Names the caller mapped explicitly (may be empty).

    Returns
    -------
    names, n, skipped
        The channels of the common length (those of the wanted channels, or
        of all channels when none is wanted), that length, and the others.

    Raises
    ------
    RecordingError
        When the wanted channels (or, with none wanted, all channels) do not
        share one length.
    """
    if not lengths:
        raise RecordingError(f"{path}: no channel found")
    pool = [n for n in wanted if n in lengths] or list(lengths)
    ls = {lengths[n] for n in pool}
    if len(ls) != 1:
        detail = ", ".join(f"{n!r}={lengths[n]}" for n in pool)
        raise RecordingError(f"{path}: unequal channel lengths ({detail}); map channels of one length with channels=")
    n = ls.pop()
    names = [k for k, v in lengths.items() if v == n]
    skipped = [k for k, v in lengths.items() if v != n]
    return names, n, skipped
