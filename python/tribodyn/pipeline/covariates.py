"""Covariates of each window: temperature and current density (docs/method.md 6).

Temperature comes from an intermittent log (paper: every 100-200 s with the
rotor stopped), interpolated linearly at the window centre (NaN outside the
log). The branch is the sign of dT/dt of the log segment holding the centre
(+1 heating, -1 cooling), 0 where that segment's change is not
distinguishable from the log's reading noise (a plateau) or outside the
log, so the hysteresis of Fig. 11 is kept apart without random labels.
Each window also gets the quality of its temperature: a bound on the error
of the interpolation and a flag for windows inside a log gap over which the
temperature changed faster than :data:`MAX_RATE`. Current comes from a
channel (mean per window) or a log; the current density is
J = i / area_mm2 in A/mm^2.

Logs with absolute times (ISO 8601 strings, datetimes or epoch seconds)
are aligned with the recording's start time by :func:`align_log`.
"""

from __future__ import annotations

import datetime as _dt
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

__all__ = [
    "TimeLog",
    "as_log",
    "interpolate",
    "branch",
    "log_noise",
    "log_quality",
    "coverage_notes",
    "window_mean",
    "sweep_notes",
    "align_log",
    "to_epoch_seconds",
    "MAX_RATE",
    "PLATEAU_Z",
    "EPOCH_THRESHOLD",
]

TimeLog = Tuple[np.ndarray, np.ndarray]

#: Fastest change (log units per second, degC/s for temperature) across a
#: log gap that still leaves its windows in the fit (docs/method.md 7):
#: 0.1 degC/s = 6 degC/min. Faster, the log cannot say when in the gap the
#: temperature changed and the contact is far from thermal equilibrium.
MAX_RATE = 0.1
#: A log segment is a plateau (branch 0) unless its change exceeds
#: ``PLATEAU_Z * sqrt(2) * noise`` (docs/method.md 6).
PLATEAU_Z = 3.0
#: Numeric log times above this (s, about 3.2 years) are taken as epoch
#: seconds (Unix time, UTC), not seconds from the recording's start.
EPOCH_THRESHOLD = 1e8


def _absolute_hint(name: str, what: str) -> str:
    return (
        f"{name}: the times are absolute ({what}) but tribodyn needs seconds from the recording's start: the "
        f"recording's start time is missing. Align the log with tribodyn.align_log(log, start_time=...) (an ISO 8601 "
        "string, a datetime or epoch seconds), or read the recording from a file that stores its start (TDMS "
        "wf_start_time: Recording.start_time)"
    )


def as_log(log: Any, name: str) -> TimeLog:
    """Validates a ``(t_s, values)`` log: equal lengths, >= 1 point, finite, t strictly increasing.

    Times must be seconds from the recording's start; absolute times (ISO
    8601 strings, datetimes, or numbers above :data:`EPOCH_THRESHOLD`) raise
    a ValueError saying that the start time is missing (see :func:`align_log`).
    """
    try:
        t, v = log
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a pair (t_s, values) of 1-D arrays") from None
    traw = np.asarray(t)
    if traw.dtype.kind in "OUSM":
        first = traw.ravel()[0] if traw.size else ""
        raise ValueError(_absolute_hint(name, f"e.g. {str(first)!r}"))
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
    if t[0] > EPOCH_THRESHOLD:
        raise ValueError(_absolute_hint(name, f"epoch seconds, first {t[0]:.10g} s"))
    return t, v


def to_epoch_seconds(when: Any) -> np.ndarray:
    """Absolute times as float seconds since 1970-01-01 UTC.

    Accepts ISO 8601 strings (``2024-05-02T10:15:00``, ``...Z``,
    ``...+02:00``, a space for the ``T``), ``datetime`` objects,
    ``numpy.datetime64`` values and numbers (already epoch seconds), as a
    scalar or an array. Times without a UTC offset are taken as UTC (as
    npTDMS gives TDMS ``wf_start_time``); give the offset for local times.
    """
    arr = np.asarray(when)
    scalar = arr.ndim == 0
    flat = arr.reshape(-1)
    if flat.dtype.kind in "biuf":
        out = flat.astype(float)
    elif flat.dtype.kind == "M":
        out = (flat.astype("datetime64[ns]") - np.datetime64(0, "ns")).astype(np.int64) / 1e9
    else:
        out = np.array([_one_epoch(x) for x in flat.tolist()], dtype=float)
    return out.reshape(()) if scalar else out


def _one_epoch(x: Any) -> float:
    if isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool):
        return float(x)
    if isinstance(x, np.datetime64):
        return float(to_epoch_seconds(x))
    if isinstance(x, _dt.datetime):
        d = x
    elif isinstance(x, _dt.date):
        d = _dt.datetime(x.year, x.month, x.day)
    elif isinstance(x, (str, bytes)):
        s = (x.decode() if isinstance(x, bytes) else x).strip()
        s = s[:-1] + "+00:00" if s.endswith(("Z", "z")) else s
        try:
            d = _dt.datetime.fromisoformat(s)
        except ValueError:
            raise ValueError(f"not an ISO 8601 time: {x!r}") from None
    else:
        raise TypeError(f"not a time: {x!r} ({type(x).__name__})")
    if d.tzinfo is None:
        d = d.replace(tzinfo=_dt.timezone.utc)
    return d.timestamp()


def align_log(log: Any, start_time: Any, *, name: str = "log") -> TimeLog:
    """A log with absolute times as ``(t_s, values)`` in seconds from ``start_time`` (docs/method.md 6).

    Parameters
    ----------
    log : (times, values)
        Times as ISO 8601 strings, datetimes, ``datetime64`` or epoch
        seconds (see :func:`to_epoch_seconds`); values numeric.
    start_time : str, datetime, datetime64 or float
        The recording's start (its first sample), e.g. a TDMS file's
        ``wf_start_time`` (``Recording.start_time``).
    name : str
        Named in errors.

    Returns
    -------
    (ndarray, ndarray)
        Seconds from the start (negative before it) and the values, sorted
        check as :func:`as_log` does.

    Raises
    ------
    ValueError
        ``start_time`` is None (named as missing), or a time is not a time.
    """
    if start_time is None:
        raise ValueError(_absolute_hint(name, "ISO 8601 or epoch seconds"))
    try:
        t, v = log
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a pair (times, values)") from None
    t0 = float(to_epoch_seconds(start_time))
    rel = to_epoch_seconds(t) - t0
    return as_log((np.atleast_1d(rel), np.atleast_1d(np.asarray(v, dtype=float))), name)


def is_absolute(log: Any) -> bool:
    """Whether a ``(times, values)`` log holds absolute times (strings, datetimes or epoch seconds)."""
    try:
        t, _ = log
    except (TypeError, ValueError):
        return False
    arr = np.asarray(t)
    if arr.dtype.kind in "OUSM":
        return arr.size > 0
    if arr.dtype.kind in "biuf" and arr.size and np.ndim(arr) == 1:
        return bool(np.isfinite(arr[0]) and arr[0] > EPOCH_THRESHOLD)
    return False


def align_to_recording(log: Any, rec: Any, name: str) -> Any:
    """``log`` aligned with the reader's start time when its times are absolute; else ``log`` as it is."""
    if log is None or np.isscalar(log) or not is_absolute(log):
        return log
    start = getattr(rec, "start_time", None)
    if start is None:
        return log  # as_log then says what is missing
    return align_log(log, start, name=name)


def interpolate(log: TimeLog, at: np.ndarray) -> np.ndarray:
    """Linear interpolation at ``at``; NaN outside [t_first, t_last]."""
    t, v = log
    out: np.ndarray = np.interp(at, t, v, left=np.nan, right=np.nan)
    return out


def log_noise(log: TimeLog) -> float:
    """Reading noise (standard deviation) of a log, from the log itself (docs/method.md 6).

    Each interior reading is compared with the straight line through its two
    neighbours; the residuals, scaled to unit variance for white reading
    noise, give a robust standard deviation (1.4826 x their median absolute
    value). Course changes of the logged quantity are outliers of this
    median. Floored at the log's rounding step / sqrt(12) (the coarsest
    power of ten dividing every reading), which is also the answer for a
    log of fewer than 6 readings.
    """
    t, v = log
    floor = float(_resolution(v) / np.sqrt(12.0))
    if t.size < 6:  # under 4 residuals the course changes would dominate the median
        return floor
    a = (t[2:] - t[1:-1]) / (t[2:] - t[:-2])  # weight of the left neighbour
    pred = a * v[:-2] + (1.0 - a) * v[2:]
    r = (v[1:-1] - pred) / np.sqrt(1.0 + a * a + (1.0 - a) ** 2)
    return max(float(1.4826 * np.median(np.abs(r))), floor)


def _resolution(v: np.ndarray) -> float:
    """The coarsest power of ten (10^-6 .. 10^2) of which every reading is a multiple (their rounding step)."""
    for k in range(2, -7, -1):
        q = 10.0**k
        if np.all(np.abs(v / q - np.round(v / q)) < 1e-6):
            return q
    return 0.0


def _segments(t: np.ndarray, at: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Index of the log segment holding each time, and whether it is inside the log."""
    at = np.asarray(at, dtype=float)
    k = np.searchsorted(t, at, side="right") - 1
    inside = (k >= 0) & (k < t.size - 1)
    # A centre exactly on the last point belongs to the last segment.
    last = at == t[-1]
    k = np.where(last, t.size - 2, k)
    inside |= last
    return np.clip(k, 0, max(t.size - 2, 0)), inside & (t.size > 1)


def branch(log: TimeLog, at: np.ndarray, *, noise: Optional[float] = None, z: float = PLATEAU_Z) -> np.ndarray:
    """Heating (+1), cooling (-1) or neither (0) at each time (docs/method.md 6).

    The sign of the change of the log segment holding each time, when that
    change exceeds ``z * sqrt(2) * noise`` (the difference of two readings
    with reading noise ``noise``, default :func:`log_noise`). Otherwise the
    sign of the least-squares slope of the segment's readings and one more
    on each side, when that slope exceeds ``z`` times its standard error
    and agrees with the segment's change; otherwise 0: a plateau, whose
    sign would be the noise's. 0 outside the log.
    """
    t, v = log
    out = np.zeros(len(at), dtype=np.int8)
    if t.size < 2:
        return out
    sigma = log_noise(log) if noise is None else float(noise)
    dv = np.diff(v)
    sign = np.where(np.abs(dv) > z * np.sqrt(2.0) * sigma, np.sign(dv), 0.0)
    # A short segment's change may hide in the noise while the readings
    # around it show a clear slope: fit a line to the segment's readings and
    # one more on each side, and take its sign if it is significant and
    # agrees with the segment's own change.
    for j in np.flatnonzero(sign == 0):
        a, b = max(j - 1, 0), min(j + 3, t.size)
        tt, vv = t[a:b], v[a:b]
        sxx = float(np.sum((tt - tt.mean()) ** 2))
        if tt.size < 3 or sxx <= 0:
            continue
        slope = float(np.sum((tt - tt.mean()) * (vv - vv.mean())) / sxx)
        if abs(slope) > z * sigma / np.sqrt(sxx) and np.sign(slope) * dv[j] >= 0:
            sign[j] = np.sign(slope)
    k, inside = _segments(t, at)
    out[inside] = sign.astype(np.int8)[k[inside]]
    return out


def log_quality(
    log: Optional[TimeLog], at: np.ndarray, *, max_rate: float = MAX_RATE, noise: Optional[float] = None
) -> Dict[str, np.ndarray]:
    """Quality of the interpolated temperature per window: ``T_uncertainty`` and ``T_gap`` (docs/method.md 6).

    ``T_uncertainty`` bounds the error of the linear interpolation: the
    reading noise plus the distance (s) to the nearer reading times the
    local rate of change (the largest |slope| of the segment holding the
    time and of its two neighbours): the temperature may have changed
    course anywhere in the gap at the rate seen around it. NaN outside the
    log. ``T_gap`` is True for windows in a segment whose change exceeds the
    reading noise (as in :func:`branch`) at a rate above ``max_rate`` per
    second (:data:`MAX_RATE`, 0.1 degC/s): the log cannot place that change
    in time, and those windows are kept out of the operating-range fits.
    Without a log: NaN and False.
    """
    n = len(at)
    unc = np.full(n, np.nan)
    gap = np.zeros(n, dtype=bool)
    if log is None:
        return {"T_uncertainty": unc, "T_gap": gap}
    t, v = log
    if t.size < 2:
        return {"T_uncertainty": unc, "T_gap": gap}
    sigma = log_noise(log) if noise is None else float(noise)
    dt = np.diff(t)
    dv = np.diff(v)
    rate = np.abs(dv) / dt
    local = rate.copy()
    local[1:] = np.maximum(local[1:], rate[:-1])
    local[:-1] = np.maximum(local[:-1], rate[1:])
    k, inside = _segments(t, at)
    at = np.asarray(at, dtype=float)
    d = np.minimum(at - t[k], t[k + 1] - at)
    unc[inside] = sigma + np.maximum(d[inside], 0.0) * local[k[inside]]
    real = np.abs(dv) > PLATEAU_Z * np.sqrt(2.0) * sigma
    fast = real & (rate > max_rate)
    gap[inside] = fast[k[inside]]
    return {"T_uncertainty": unc, "T_gap": gap}


def constant_or_log(value: Any, name: str) -> Optional[TimeLog]:
    """A scalar becomes a flat log; a pair is validated as a log."""
    if value is None:
        return None
    if np.ndim(value) == 0:
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise TypeError(f"{name} must be a number or a log (t_s, values), got {value!r}") from None
        if not np.isfinite(v):
            raise ValueError(f"{name} must be finite, got {value!r}")
        return np.array([-np.inf]), np.array([v])
    return as_log(value, name)


def window_mean(log: TimeLog, start: np.ndarray, stop: np.ndarray) -> np.ndarray:
    """The mean of the log's linear interpolation over each window ``start`` .. ``stop`` (s), as the COF is a
    mean over the window's samples (issue 35 point 7; docs/method.md 7a): exact for the piecewise-linear log
    (its integral, from the knots' cumulative trapezoids and the partial segments at each end). The part of a
    window outside the log is left out; a window whose centre lies outside the log is NaN, as :func:`interpolate`
    gives there. A flat log (a constant) holds everywhere."""
    t, v = log
    start, stop = np.asarray(start, dtype=float), np.asarray(stop, dtype=float)
    centre = 0.5 * (start + stop)
    if t.size == 1 and np.isneginf(t[0]):
        return np.full(centre.size, v[0])
    out = interpolate(log, centre)
    if t.size < 2:
        return out
    knots = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])

    def primitive(x: np.ndarray) -> np.ndarray:  # the integral of the interpolation from t[0] to x
        k = np.clip(np.searchsorted(t, x, side="right") - 1, 0, t.size - 2)
        dx = x - t[k]
        slope = (v[k + 1] - v[k]) / (t[k + 1] - t[k])
        return np.asarray(knots[k] + dx * (v[k] + 0.5 * slope * dx))

    a, b = np.clip(start, t[0], t[-1]), np.clip(stop, t[0], t[-1])
    wide = np.isfinite(out) & (b > a)
    out[wide] = (primitive(b[wide]) - primitive(a[wide])) / (b[wide] - a[wide])
    return out


def _covered(log: TimeLog, at: np.ndarray) -> float:
    """Share of the times ``at`` inside the log's span (1 for a constant, 0 for no time)."""
    t, _ = log
    if at.size == 0 or (t.size == 1 and np.isneginf(t[0])):
        return 1.0
    return float(np.mean((at >= t[0]) & (at <= t[-1])))


def coverage_notes(logs: Dict[str, Optional[TimeLog]], at: np.ndarray) -> List[str]:
    """A warning for each log that covers only part of the window centres ``at`` (issue 34 point 7;
    docs/method.md 6): the share covered and both spans, for the windows outside it have no value (NaN)."""
    out = []
    at = np.asarray(at, dtype=float)
    for name, log in logs.items():
        if log is None:
            continue
        share = _covered(log, at)
        if share >= 1.0:
            continue
        t = log[0]
        span = f"t = {t[0]:.6g} to {t[-1]:.6g} s" if t.size else "no reading"
        rec = f"{at.min():.6g} to {at.max():.6g} s" if at.size else "none"
        if share == 0.0:
            out.append(
                f"the {name} log ({span}) does not overlap the windows (centres {rec}): no window has a "
                f"{name}; check the log's time base (seconds from the recording's start, or absolute times)"
            )
        else:
            out.append(
                f"the {name} log ({span}) covers {100 * share:.1f} % of the windows (centres {rec}); "
                f"the others have no {name} (NaN) and stay out of the fits against it"
            )
    return out


#: A log whose median swing within one window exceeds this share of its whole range sweeps faster than a window.
FAST_SWEEP = 0.25


def sweep_notes(logs: Dict[str, Optional[TimeLog]], start: np.ndarray, stop: np.ndarray) -> List[str]:
    """A note for each log that sweeps a large part of its range within one window (issue 35 point 7;
    docs/method.md 7b): the per-window COF is then a mean over a span of the covariate, and the per-window
    curve flattens the dependence; :func:`tribodyn.cof_curve` bins the COF per sample instead. The swing of a
    window is the range of the interpolated log at 17 points across it (median over the windows)."""
    out: List[str] = []
    start, stop = np.asarray(start, dtype=float), np.asarray(stop, dtype=float)
    if start.size == 0:
        return out
    grid = start[:, None] + (stop - start)[:, None] * np.linspace(0.0, 1.0, 17)[None, :]
    for name, log in logs.items():
        if log is None or log[0].size < 2 or np.isneginf(log[0][0]):
            continue
        full = float(np.ptp(log[1]))
        if not full > 0:
            continue
        at = np.interp(grid, log[0], log[1], left=np.nan, right=np.nan)
        swing = np.nanmax(at, axis=1) - np.nanmin(at, axis=1) if np.isfinite(at).any() else np.zeros(0)
        swing = swing[np.isfinite(swing)]
        if swing.size and float(np.median(swing)) > FAST_SWEEP * full:
            out.append(
                f"the {name} log sweeps {100 * float(np.median(swing)) / full:.0f} % of its range within a "
                f"window (median): each window's COF is a mean over that span, the per-window curve "
                f"flattens the dependence; tribodyn.cof_curve bins the COF per sample (docs/method.md 7b)"
            )
    return out
