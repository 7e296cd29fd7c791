"""A known constant normal force for a recording without a load channel (``load=``, docs/method.md 6a).

Many pin-on-disc and ball-on-disc exports carry the friction force (and often the instrument's COF) but
not the load, which is a test parameter (a dead weight). :class:`ConstantLoad` gives such a recording the
role ``fz`` as a constant channel of the value given: every reading path (chunks, ranges, whole channels)
hands it out beside the file's channels, so the classical COF is mean |fy| / load over the samples in
contact and the instrument's COF is checked against it. The constant is never read from the file: no
mapped route reads it (``file_layout`` is None) and the channel list names it "given by the caller".
"""

from __future__ import annotations

import math
from typing import Any, Dict, Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np

from .base import ChannelInfo, Recording, RecordingError, _as_str_list

__all__ = ["ConstantLoad", "LOAD_CHANNEL", "is_recording", "with_load"]

#: The name under which the given load appears among the recording's channels.
LOAD_CHANNEL = "load (given)"


def check_load(load: Any) -> float:
    """``load`` as a float in N: finite and > 0, else a ``ValueError`` that names it."""
    if isinstance(load, bool) or not isinstance(load, (int, float, np.integer, np.floating)):
        raise TypeError(f"load must be a number of newtons, got {type(load).__name__} {load!r}")
    v = float(load)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"load must be a finite force > 0 N, got {load!r}")
    return v


class ConstantLoad:
    """``rec`` with the role ``fz`` added as a constant ``load`` (N); every other attribute is ``rec``'s.

    Made by :func:`with_load`; refuses a recording that has a normal-force channel already (the file's own
    load wins: map it away with ``channels={"fz": None}`` to replace it).
    """

    #: No kernel reads the constant from the file's pages.
    mappable = False
    views = False

    def __init__(self, rec: Any, load: float) -> None:
        if "fz" in rec.roles:
            raise RecordingError(
                f"{rec.path}: load= is for a recording without a normal-force channel; fz is mapped to "
                f"{rec.roles['fz']!r} (pass channels={{'fz': None}} / --map fz= to use the given load instead)"
            )
        self._rec = rec
        self.load = check_load(load)
        self.roles: Dict[str, str] = {**rec.roles, "fz": LOAD_CHANNEL}
        self.roles_given: Dict[str, str] = {**getattr(rec, "roles_given", {}), "fz": LOAD_CHANNEL}
        self.channels: List[ChannelInfo] = [
            *rec.channels,
            ChannelInfo(LOAD_CHANNEL, "N", "fz", None, 1.0, f"a constant {self.load:g} N given by the caller (load=)"),
        ]

    def __getattr__(self, name: str) -> Any:
        return getattr(self._rec, name)

    def __enter__(self) -> "ConstantLoad":
        return self

    def __exit__(self, *exc: Any) -> None:
        self._rec.close()

    def __repr__(self) -> str:
        return f"ConstantLoad({self._rec!r}, load={self.load:g} N)"

    def _split(self, roles: Union[None, str, Sequence[str]]) -> Tuple[List[str], List[str], bool]:
        """(the keys asked for, in order; the keys the file reads; whether the constant is among them)."""
        keys = list(self.roles) if roles is None else list(dict.fromkeys(_as_str_list(roles)))
        if not keys:
            raise RecordingError("roles is empty: name at least one role or channel")
        want = any(k in ("fz", LOAD_CHANNEL) for k in keys)
        inner = [k for k in keys if k not in ("fz", LOAD_CHANNEL)]
        return keys, inner, want

    def _with(self, keys: List[str], got: Dict[str, np.ndarray], n: int) -> Dict[str, np.ndarray]:
        return {k: (np.full(n, self.load) if k in ("fz", LOAD_CHANNEL) else got[k]) for k in keys}

    def _any_role(self) -> List[str]:
        """One channel of the file to learn a block's length from when only the constant is asked for."""
        return [next(iter(self._rec.roles))] if self._rec.roles else [self._rec.channels[0].name]

    def chunks(self, size: int, roles: Union[None, str, Sequence[str]] = None, *, start: int = 0,
               stop: Optional[int] = None, copy: bool = True) -> Iterator[Dict[str, np.ndarray]]:  # fmt: skip
        """As :meth:`tribodyn.io.Recording.chunks`, ``fz`` the constant load."""
        keys, inner, _ = self._split(roles)
        read = inner or self._any_role()
        for got in self._rec.chunks(size, read, start=start, stop=stop, copy=copy):
            yield self._with(keys, got, len(got[read[0]]))

    def read(self, roles: Union[None, str, Sequence[str]] = None) -> Dict[str, np.ndarray]:
        """As :meth:`tribodyn.io.Recording.read`."""
        keys, inner, _ = self._split(roles)
        read = inner or self._any_role()
        got = self._rec.read(read)
        return self._with(keys, got, len(got[read[0]]))

    def read_ranges(self, ranges: Sequence[Tuple[int, int]], roles: Union[None, str, Sequence[str]] = None
                    ) -> Dict[str, np.ndarray]:  # fmt: skip
        """As :meth:`tribodyn.io.Recording.read_ranges`."""
        keys, inner, _ = self._split(roles)
        read = inner or self._any_role()
        got = self._rec.read_ranges(ranges, read)
        return self._with(keys, got, len(got[read[0]]))

    def file_layout(self, roles: Sequence[str]) -> None:
        """None: the constant lies in no file."""
        return None

    def info(self) -> Dict[str, Any]:
        """As :meth:`tribodyn.io.Recording.info`, with the given load among the roles and channels."""
        out = dict(self._rec.info())
        out["roles"] = dict(self.roles)
        c = self.channels[-1]
        out["channels"] = [*out["channels"], {"name": c.name, "unit": c.unit, "role": c.role,
                                              "raw_unit": c.raw_unit, "scale": c.scale, "note": c.note}]  # fmt: skip
        return out


def is_recording(obj: Any) -> bool:
    """Whether ``obj`` is an open recording: a :class:`~tribodyn.io.Recording` or one with a given load."""
    return isinstance(obj, (Recording, ConstantLoad))


def with_load(rec: Any, load: Optional[float]) -> Any:
    """``rec`` itself without ``load``, else :class:`ConstantLoad` of it."""
    return rec if load is None else ConstantLoad(rec, load)


def mapping_with_load(source: Any, load: Optional[float]) -> Any:
    """A mapping of channels (or a list of them: acquisitions) with ``fz`` the constant ``load``."""
    from collections.abc import Mapping

    if load is None:
        return source
    v = check_load(load)

    def one(ch: Mapping[str, Any]) -> Dict[str, Any]:
        if "fz" in ch:
            raise ValueError("load= is for a source without a normal force; this one has fz (drop it to use the load)")
        if "fy" in ch:
            n = len(ch["fy"])
        elif "cof" in ch:
            n = len(ch["cof"])
        else:
            raise ValueError("load= needs the friction force fy (or the instrument's COF, cof) to go with it")
        return {**ch, "fz": np.full(n, v)}

    if isinstance(source, Mapping):
        return one(source)
    if isinstance(source, (list, tuple)) and all(isinstance(c, Mapping) for c in source):
        return [one(c) for c in source]
    raise TypeError("load= applies to a recording, a mapping of channels or a list of them")
