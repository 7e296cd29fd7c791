"""The deadband |fz| < d of Sec. 3.3 (docs/method.md section 4).

``d`` is a force in newtons (paper: 0.35 N) or a multiple k of the window's
fz standard deviation, written ``"0.7sigma"`` (paper footnote 1).
"""

from __future__ import annotations

import numbers
import re
from dataclasses import dataclass
from typing import Literal, Union

__all__ = ["Deadband", "parse_deadband"]

DeadbandSpec = Union[float, int, str, "Deadband"]

_SIGMA = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*(?:sigma|σ|sd|std)\s*$", re.IGNORECASE)


@dataclass(frozen=True)
class Deadband:
    """A parsed deadband: ``kind`` "force" (value in N) or "sigma" (value = k)."""

    kind: Literal["force", "sigma"]
    value: float

    def __str__(self) -> str:
        return f"{self.value:g} N" if self.kind == "force" else f"{self.value:g} sigma"


def parse_deadband(spec: DeadbandSpec) -> Deadband:
    """Parses ``0.35`` (newtons) or ``"0.7sigma"`` (k times std of fz).

    Raises ``ValueError`` for a negative, non-finite or unreadable value.
    """
    if isinstance(spec, Deadband):
        return spec
    if isinstance(spec, numbers.Real) and not isinstance(spec, bool):
        v = float(spec)
        if not (v >= 0 and v != float("inf")):
            raise ValueError(f"deadband must be a finite force >= 0 N, got {spec!r}")
        return Deadband("force", v)
    if isinstance(spec, str):
        m = _SIGMA.match(spec)
        if m:
            return Deadband("sigma", float(m.group(1)))
        try:
            return parse_deadband(float(spec.strip().removesuffix("N").strip()))
        except ValueError:
            pass
    raise ValueError(
        f"deadband must be a force in N (e.g. 0.35) or a multiple of sigma (e.g. '0.7sigma'), got {spec!r}"
    )
