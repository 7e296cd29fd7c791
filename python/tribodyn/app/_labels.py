"""Words and units for people: the labels and numbers of the report's summary and the CLI headline.

``summary.json`` keeps machine units ("degC", "A/mm^2") and code keys; what a
person reads goes through these helpers so every label is words and every
unit is written one way (°C, A/mm², N). Light on purpose: no NumPy,
Matplotlib or pandas, so the CLI can import it at no cost.
"""

from __future__ import annotations

import math
import numbers
import re
from typing import Any, Optional, Sequence

__all__ = ["unit_text", "units_in_text", "key_text", "fmt_value", "fmt_number", "fmt_range", "fmt_interval"]

#: Machine units -> the way a reader writes them ("1": dimensionless).
UNIT_TEXT = {"degC": "°C", "A/mm^2": "A/mm²", "mm^2": "mm²", "ohm": "Ω", "1": "", "": ""}

_UNITS_RE = re.compile(r"\bdegC\b|A/mm\^2|\bmm\^2")


def unit_text(unit: Any) -> str:
    """'degC' -> '°C', 'A/mm^2' -> 'A/mm²', dimensionless ('1', '') -> ''; other units as they are."""
    u = "" if unit is None else str(unit)
    return UNIT_TEXT.get(u, u)


def units_in_text(text: Any) -> str:
    """The same conversion inside prose ("between 133.5 and 157.9 degC" -> "... °C")."""
    return _UNITS_RE.sub(lambda m: UNIT_TEXT[m.group(0)], str(text))


def key_text(key: Any) -> str:
    """A code key as words: 'temperature_test' -> 'temperature test', 'tribodyn_version' -> 'tribodyn version'."""
    return str(key).replace("_", " ").strip()


def _decimals(spread: Optional[float]) -> Optional[int]:
    """Decimals that keep two significant digits of ``spread`` (an interval's width), None if unknown."""
    if spread is None or not math.isfinite(spread) or spread <= 0:
        return None
    return max(0, 1 - math.floor(math.log10(spread)))


def _spread(ci: Any) -> Optional[float]:
    try:
        lo, hi = float(ci[0]), float(ci[1])
    except (TypeError, ValueError, IndexError):
        return None
    return hi - lo if math.isfinite(lo) and math.isfinite(hi) else None


def fmt_value(value: Any) -> str:
    """A number as the report writes it: 4 significant digits (6 from 10^4 up), an integer whole, 'NaN', 'inf',
    '-inf', and '–' for None (the report's tables and the figures' captions)."""
    if value is None:
        return "–"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    f = float(value)
    if math.isnan(f):
        return "NaN"
    if math.isinf(f):
        return "inf" if f > 0 else "-inf"
    return format(f, ".4g") if abs(f) < 1e4 else format(f, ".6g")


def fmt_number(value: Any, *, spread: Optional[float] = None, digits: int = 4) -> str:
    """A number rounded to the data's precision: two significant digits of ``spread`` (the width of its
    interval) when known, else ``digits`` significant digits; '–' for None, 'NaN' for NaN."""
    if value is None:
        return "–"
    v = float(value)
    if not math.isfinite(v):
        return "NaN" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    d = _decimals(spread)
    if d is None:
        return format(v, f".{digits}g")
    return f"{v:.{min(d, 6)}f}"


def fmt_interval(ci: Any, *, spread: Optional[float] = None) -> str:
    """'[133.3, 135.1]' (rounded as :func:`fmt_number`: four significant digits unless ``spread``), ''
    when the interval is missing."""
    if not ci or len(ci) != 2 or ci[0] is None or ci[1] is None:
        return ""
    return f"[{fmt_number(ci[0], spread=spread)}, {fmt_number(ci[1], spread=spread)}]"


def fmt_range(lo: Any, hi: Any, unit: Any = "", *, ci: Optional[Sequence[Any]] = None) -> str:
    """An optimum range for a reader: '133.5 to 157.9 °C' (``ci``: the breakpoints' intervals, which set
    the rounding; without them four significant digits)."""
    spreads = [_spread(c) for c in (ci or ())]
    known = [s for s in spreads if s is not None and s > 0]
    spread = min(known) if known else None
    u = unit_text(unit)
    return f"{fmt_number(lo, spread=spread)} to {fmt_number(hi, spread=spread)}" + (f" {u}" if u else "")
