"""Channels a recording lacks, derived from what it has (docs/method.md 6a).

* ``load=``: many pin-on-disc and ball-on-disc exports carry the friction force (and often the instrument's
  COF) but not the load, which is a test parameter (a dead weight). The recording gets the role ``fz`` as a
  constant channel of the value given, so the classical COF is mean |fy| / load over the samples in contact
  and the instrument's COF is checked against it.
* A COF-only export (a ``cof`` column, no friction force; issue 34 point 2): the role ``fy`` becomes the
  instrument's COF times fz (the file's, the given load, or 1 N when neither: a unit load), so that the
  windows can be read; the headline is then the instrument's own COF (method ``"instrument"``,
  ``tribodyn.results.headline``), never a COF computed from the derived force.

:class:`ConstantLoad` hands the derived channels out on every reading path (chunks, ranges, whole channels);
no mapped route reads them (``file_layout`` is None) and the channel list names them "given by the caller"
or "derived".
"""

from __future__ import annotations

import math
from typing import Any, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from .base import ChannelInfo, Recording, RecordingError, _as_str_list

__all__ = [
    "ConstantLoad",
    "FRICTION_CHANNEL",
    "LOAD_CHANNEL",
    "UNIT_LOAD_CHANNEL",
    "derive",
    "is_recording",
    "with_load",
]

#: The name under which the given load appears among the recording's channels.
LOAD_CHANNEL = "load (given)"
#: The name of the friction force derived from a COF-only export's COF column.
FRICTION_CHANNEL = "friction (COF x fz, derived)"
#: The normal force of a COF-only export without a load channel or a given load: 1 N, a unit load.
UNIT_LOAD_CHANNEL = "unit load (derived)"


def check_load(load: Any) -> float:
    """``load`` as a float in N: finite and > 0, else a ``ValueError`` that names it."""
    if isinstance(load, bool) or not isinstance(load, (int, float, np.integer, np.floating)):
        raise TypeError(f"load must be a number of newtons, got {type(load).__name__} {load!r}")
    v = float(load)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"load must be a finite force > 0 N, got {load!r}")
    return v


def derive(got: Mapping[str, np.ndarray], load: Optional[float], from_cof: bool) -> Dict[str, np.ndarray]:
    """The derived channels of one read (the module's rules): ``fz`` the constant ``load`` (when given), ``fy``
    the COF times fz (the load, else ``got``'s fz) with the COF's sign kept (when ``from_cof``)."""
    n = len(next(iter(got.values())))
    fz = np.full(n, float(load)) if load is not None else np.asarray(got.get("fz", np.ones(n)), dtype=float)
    out = {"fz": fz} if load is not None else {}
    if from_cof:
        out["fy"] = np.asarray(got["cof"], dtype=float) * fz
    return out


class ConstantLoad:
    """``rec`` with the channels it lacks derived (see the module): ``fz`` the constant ``load`` (N) when given,
    ``fy`` the COF column times fz when ``rec`` has a COF and no friction force; every other attribute is
    ``rec``'s. Made by :func:`with_load`; refuses a load beside a normal-force channel of the file's own (map it
    away with ``channels={"fz": None}`` to use the load instead).
    """

    #: No kernel reads a derived channel from the file's pages.
    mappable = False
    views = False

    def __init__(self, rec: Any, load: Optional[float], *, friction_from_cof: bool = False) -> None:
        if load is not None and "fz" in rec.roles:
            raise RecordingError(
                f"{rec.path}: load= is for a recording without a normal-force channel; fz is mapped to "
                f"{rec.roles['fz']!r} (pass channels={{'fz': None}} / --map fz= to use the given load instead)"
            )
        self._rec = rec
        self.load = None if load is None else check_load(load)
        #: fy is the instrument's COF times fz (a COF-only export): the headline is the instrument's COF.
        self.friction_from_cof = bool(friction_from_cof)
        self.roles: Dict[str, str] = dict(rec.roles)
        infos: List[ChannelInfo] = list(rec.channels)
        if self.load is not None:
            self.roles["fz"] = LOAD_CHANNEL
            infos.append(ChannelInfo(LOAD_CHANNEL, "N", "fz", None, 1.0,
                                     f"a constant {self.load:g} N given by the caller (load=)"))  # fmt: skip
        elif self.friction_from_cof and "fz" not in rec.roles:  # neither a load channel nor a load: 1 N
            self.load = 1.0
            self.roles["fz"] = UNIT_LOAD_CHANNEL
            note = "a COF-only export without a load: a unit load, every sample in contact"
            infos.append(ChannelInfo(UNIT_LOAD_CHANNEL, "N", "fz", None, 1.0, note))
        if self.friction_from_cof:
            self.roles["fy"] = FRICTION_CHANNEL
            fz_what = {LOAD_CHANNEL: "the given load", UNIT_LOAD_CHANNEL: "a unit load of 1 N"}.get(
                self.roles["fz"], "fz"
            )
            infos.append(ChannelInfo(FRICTION_CHANNEL, "N", "fy", None, 1.0,
                                     f"derived: the COF column {rec.roles['cof']!r} x {fz_what}"))  # fmt: skip
        self.roles_given: Dict[str, str] = {**getattr(rec, "roles_given", {}),
                                            **{r: n for r, n in self.roles.items() if r not in rec.roles}}  # fmt: skip
        self.channels = infos

    def __getattr__(self, name: str) -> Any:
        return getattr(self._rec, name)

    def __enter__(self) -> "ConstantLoad":
        return self

    def __exit__(self, *exc: Any) -> None:
        self._rec.close()

    def __repr__(self) -> str:
        return f"ConstantLoad({self._rec!r}, load={self.load}, friction_from_cof={self.friction_from_cof})"

    def _derived(self, key: str) -> Optional[str]:
        """The role a key asks for when it is a derived channel ("fz" or "fy"), else None."""
        if key in ("fz", LOAD_CHANNEL, UNIT_LOAD_CHANNEL) and self.load is not None:
            return "fz"
        if key in ("fy", FRICTION_CHANNEL) and self.friction_from_cof:
            return "fy"
        return None

    def _split(self, roles: Union[None, str, Sequence[str]]) -> Tuple[List[str], List[str]]:
        """(the keys asked for, in order; the keys the file reads for them)."""
        keys = list(self.roles) if roles is None else list(dict.fromkeys(_as_str_list(roles)))
        if not keys:
            raise RecordingError("roles is empty: name at least one role or channel")
        inner = [k for k in keys if self._derived(k) is None]
        if any(self._derived(k) == "fy" for k in keys):  # the COF, and the file's fz, to derive fy
            inner += [r for r in ("cof", "fz") if r in self._rec.roles and r not in inner]
        if not inner:
            inner = [next(iter(self._rec.roles))] if self._rec.roles else [self._rec.channels[0].name]
        return keys, inner

    def _with(self, keys: List[str], got: Dict[str, np.ndarray]) -> Dict[str, np.ndarray]:
        derived = derive(got, self.load, self.friction_from_cof)
        return {k: got[k] if self._derived(k) is None else derived[str(self._derived(k))].copy() for k in keys}

    def chunks(self, size: int, roles: Union[None, str, Sequence[str]] = None, *, start: int = 0,
               stop: Optional[int] = None, copy: bool = True) -> Iterator[Dict[str, np.ndarray]]:  # fmt: skip
        """As :meth:`tribodyn.io.Recording.chunks`, with the derived channels."""
        keys, inner = self._split(roles)
        for got in self._rec.chunks(size, inner, start=start, stop=stop, copy=copy):
            yield self._with(keys, got)

    def read(self, roles: Union[None, str, Sequence[str]] = None) -> Dict[str, np.ndarray]:
        """As :meth:`tribodyn.io.Recording.read`."""
        keys, inner = self._split(roles)
        return self._with(keys, self._rec.read(inner))

    def read_ranges(self, ranges: Sequence[Tuple[int, int]], roles: Union[None, str, Sequence[str]] = None
                    ) -> Dict[str, np.ndarray]:  # fmt: skip
        """As :meth:`tribodyn.io.Recording.read_ranges`."""
        keys, inner = self._split(roles)
        return self._with(keys, self._rec.read_ranges(ranges, inner))

    def file_layout(self, roles: Sequence[str]) -> None:
        """None: a derived channel lies in no file."""
        return None

    def info(self) -> Dict[str, Any]:
        """As :meth:`tribodyn.io.Recording.info`, with the derived channels among the roles and channels."""
        out = dict(self._rec.info())
        out["roles"] = dict(self.roles)
        extra = self.channels[len(self._rec.channels) :]
        out["channels"] = [*out["channels"], *({"name": c.name, "unit": c.unit, "role": c.role, "raw_unit": c.raw_unit,
                                                "scale": c.scale, "note": c.note} for c in extra)]  # fmt: skip
        return out


def is_recording(obj: Any) -> bool:
    """Whether ``obj`` is an open recording: a :class:`~tribodyn.io.Recording` or one with a given load."""
    return isinstance(obj, (Recording, ConstantLoad))


def with_load(rec: Any, load: Optional[float]) -> Any:
    """``rec`` itself when it lacks nothing (and no ``load``), else :class:`ConstantLoad` of it: with ``load``,
    and with fy from the COF column when ``rec`` has a COF but no friction force (a COF-only export)."""
    cof_only = "cof" in rec.roles and "fy" not in rec.roles
    if load is None and not cof_only:
        return rec
    return ConstantLoad(rec, load, friction_from_cof=cof_only)


def mapping_with_load(source: Any, load: Optional[float]) -> Any:
    """A mapping of channels (or a list of them: acquisitions) with ``fz`` the constant ``load`` and, for a
    COF-only mapping (``cof`` and no ``fy``), ``fy`` the COF times fz (the module's rules)."""
    from collections.abc import Mapping

    v = None if load is None else check_load(load)

    def one(ch: Mapping[str, Any]) -> Dict[str, Any]:
        if v is not None and "fz" in ch:
            raise ValueError("load= is for a source without a normal force; this one has fz (drop it to use the load)")
        if v is not None and "fy" not in ch and "cof" not in ch:
            raise ValueError("load= needs the friction force fy (or the instrument's COF, cof) to go with it")
        from_cof = "fy" not in ch and "cof" in ch
        # the mapping's own fz, else the load, else (a COF-only mapping without either) a unit load
        load = v if v is not None else (1.0 if from_cof and "fz" not in ch else None)
        return {**ch, **derive({k: ch[k] for k in ("fy", "cof", "fz") if k in ch}, load, from_cof)}

    if isinstance(source, Mapping):
        return one(source) if (v is not None or ("cof" in source and "fy" not in source)) else source
    if isinstance(source, (list, tuple)) and source and all(isinstance(c, Mapping) for c in source):
        if v is None and not all("cof" in c and "fy" not in c for c in source):
            return source
        return [one(c) for c in source]
    if v is None:
        return source
    raise TypeError("load= applies to a recording, a mapping of channels or a list of them")
