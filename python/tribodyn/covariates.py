"""Covariates of each window: temperature and current density (docs/method.md 6).

Temperature comes from an intermittent log (paper: every 100-200 s with the
rotor stopped), interpolated linearly at the window centre (NaN outside the
log); the branch is the sign of dT/dt of the log segment holding the centre
(+1 heating, -1 cooling, 0 flat or outside), to keep the hysteresis of
Fig. 11 apart. Current comes from a channel (mean per window) or a log; the
current density is J = i / area_mm2 in A/mm^2.
"""

from __future__ import annotations

from typing import Any, Optional, Tuple

import numpy as np

__all__ = ["TimeLog", "as_log", "interpolate", "branch"]

TimeLog = Tuple[np.ndarray, np.ndarray]


def as_log(log: Any, name: str) -> TimeLog:
    """Validates a ``(t_s, values)`` log: equal lengths, >= 1 point, finite, t strictly increasing."""
    try:
        t, v = log
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a pair (t_s, values) of 1-D arrays") from None
    t = np.asarray(t, dtype=float)
    v = np.asarray(v, dtype=float)
    if t.ndim != 1 or v.ndim != 1 or t.size != v.size:
        raise ValueError(f"{name}: times and values must be 1-D of equal length, got shapes {t.shape} and {v.shape}")
    if t.size == 0:
        raise ValueError(f"{name} is empty")
    if not (np.isfinite(t).all() and np.isfinite(v).all()):
        raise ValueError(f"{name} contains NaN or inf")
    if t.size > 1 and not np.all(np.diff(t) > 0):
        raise ValueError(f"{name}: times must be strictly increasing (sort the log)")
    return t, v


def interpolate(log: TimeLog, at: np.ndarray) -> np.ndarray:
    """Linear interpolation at ``at``; NaN outside [t_first, t_last]."""
    t, v = log
    return np.interp(at, t, v, left=np.nan, right=np.nan)


def branch(log: TimeLog, at: np.ndarray) -> np.ndarray:
    """Sign of dT/dt of the log segment containing each time (0 outside or flat)."""
    t, v = log
    out = np.zeros(len(at), dtype=np.int8)
    if t.size < 2:
        return out
    k = np.searchsorted(t, at, side="right") - 1
    inside = (k >= 0) & (k < t.size - 1)
    # A centre exactly on the last point belongs to the last segment.
    last = np.asarray(at) == t[-1]
    k = np.where(last, t.size - 2, k)
    inside |= last
    slope = np.sign(np.diff(v))
    out[inside] = slope[k[inside]].astype(np.int8)
    return out


def constant_or_log(value: Any, name: str) -> Optional[TimeLog]:
    """A scalar becomes a flat log; a pair is validated as a log."""
    if value is None:
        return None
    if np.ndim(value) == 0:
        v = float(value)
        if not np.isfinite(v):
            raise ValueError(f"{name} must be finite, got {value!r}")
        return np.array([-np.inf]), np.array([v])
    return as_log(value, name)


def evaluate(log: TimeLog, at: np.ndarray) -> np.ndarray:
    """Like :func:`interpolate`, but a flat log (from a scalar) holds everywhere."""
    t, v = log
    if t.size == 1 and np.isneginf(t[0]):
        return np.full(len(at), v[0])
    return interpolate(log, at)
