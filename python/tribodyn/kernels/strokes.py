"""Strokes and cycles of a reciprocating test (docs/method.md 6c).

* :func:`find_strokes`: the strokes of a direction signal (the sign of fy, or of a velocity).
* :func:`stroke_table`: the classical COF of each stroke over its central ``stroke_fraction``, its
  breakaway peak (:func:`breakaway_peak`) and, with a position, its friction work.
* :func:`cycle_table`: one row per cycle (forward, backward, cycle COF, offset, loop energy).
"""

from __future__ import annotations

import dataclasses
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

#: Default central fraction of a stroke used for its COF (docs/method.md 6c).
STROKE_FRACTION = 0.5


@dataclasses.dataclass(frozen=True)
class ClassicalSpec:
    """How the classical COF is computed (docs/method.md 6a).

    Attributes
    ----------
    min_fn : float
        Least |fz| (N) of a sample counted.
    tare_fy, tare_fz : float
        Offsets subtracted from fy and fz first (N).
    """

    min_fn: float
    tare_fy: float = 0.0
    tare_fz: float = 0.0


def find_strokes(direction_signal: np.ndarray, *, boundaries: Sequence[Tuple[int, int]] = (),
                 kind: str = "fy") -> List[Tuple[int, int, int]]:  # fmt: skip
    """Strokes as (start, stop, direction) from a signed signal (fy, velocity or position), per acquisition.

    ``kind`` "x" (position): the direction is the sign of its slope; "v" and
    "fy": the sign of the signal itself. A direction holds until the signal
    crosses 30 % of its p95 magnitude with the other sign (hysteresis), so
    noise around zero does not cut strokes. Every acquisition is handled at
    once (NumPy over their samples joined, the state never carried from one
    to the next), so hundreds of them (the pre-pass sample's pieces) cost
    no Python loop each.
    """
    sig = np.asarray(direction_signal, dtype=float)
    if kind == "x":
        sig = np.gradient(sig)
    ranges = [(a, b) for a, b in (list(boundaries) or [(0, sig.size)]) if sig[a:b].size]
    if not ranges:
        return []
    parts = [sig[a:b] for a, b in ranges]
    sizes = np.array([q.size for q in parts])
    whole = parts[0] if len(parts) == 1 else np.concatenate(parts)
    stops = np.cumsum(sizes)
    starts = stops - sizes
    thr = np.repeat(0.3 * np.array(_segment_p95(parts)), sizes)
    # The direction of the last crossing of +-thr within the acquisition (forward filled), its undecided
    # start taking the first decided direction; an acquisition never decided is one stroke, forward.
    raw = np.zeros(whole.size, dtype=np.int8)
    with np.errstate(invalid="ignore"):
        raw[whole > thr] = 1
        raw[whole < -thr] = -1
    idx = np.arange(whole.size)
    first = np.searchsorted(np.flatnonzero(raw), starts)
    decided_at = np.flatnonzero(raw)
    has = first < decided_at.size
    has[has] = decided_at[first[has]] < stops[has]
    first_dir = np.zeros(len(parts), dtype=np.int8)
    first_dir[has] = raw[decided_at[first[has]]]
    own_start = np.repeat(starts, sizes)
    last = np.where(raw != 0, idx, own_start - 1)  # below the acquisition's start: none decided yet
    np.maximum.accumulate(last, out=last)
    d = np.where(last >= own_start, raw[np.maximum(last, 0)], np.repeat(first_dir, sizes))
    cuts = np.flatnonzero(d[1:] != d[:-1]) + 1
    cuts = cuts[own_start[cuts] != cuts]  # a change from one acquisition to the next is no cut
    moved = _moved_cuts(whole, d, cuts, own_start)
    return _stroke_list(ranges, moved, d, starts=starts, stops=stops, has=has)


def _moved_cuts(whole: np.ndarray, d: np.ndarray, cuts: np.ndarray, own_start: np.ndarray) -> np.ndarray:
    """The hysteresis decides a change of direction late (at 30 % of p95): the stroke starts where the signal
    took its new sign (the reversal), so that a stroke's central part is centred. A cut c moves back over the
    run of samples of its new sign that ends at c - 1 (to r, the sample after the last one of another sign),
    but not to or before the previous moved cut of its acquisition (nor to its first sample):
    m_k = max(r_k, m_{k-1} + 1), m_{-1} = the acquisition's start, that is
    m_k = k + max over i <= k of v_i, v_i = r_i - i (and start + 1 - i at an acquisition's first cut). The
    running maximum is taken over every acquisition at once: an earlier acquisition's terms are below the
    later one's start term (its cuts end before that start)."""
    if not cuts.size:
        return cuts
    idx = np.arange(whole.size)
    sign = np.sign(np.nan_to_num(whole, nan=0.0))
    new = d[cuts]
    other_pos = np.maximum.accumulate(np.where(sign != 1, idx, -1))
    other_neg = np.maximum.accumulate(np.where(sign != -1, idx, -1))
    r = np.where(new == 1, other_pos[cuts - 1], other_neg[cuts - 1]) + 1
    k = np.arange(cuts.size)
    v = r - k
    opens = np.r_[True, own_start[cuts[1:]] != own_start[cuts[:-1]]]
    v[opens] = np.maximum(v[opens], own_start[cuts[opens]] + 1 - k[opens])
    out: np.ndarray = k + np.maximum.accumulate(v)
    return out


def _stroke_list(ranges: Sequence[Tuple[int, int]], moved: np.ndarray, d: np.ndarray, *, starts: np.ndarray,
                 stops: np.ndarray, has: np.ndarray) -> List[Tuple[int, int, int]]:  # fmt: skip
    """(start, stop, direction) in the recording's samples: each decided acquisition cut at the moved cuts
    (strokes of 4 samples or more, the direction of their last sample), an undecided one whole, forward."""
    points = np.sort(np.concatenate((starts[has], moved)))
    seg = np.searchsorted(starts, points, side="right") - 1
    ends = np.append(points[1:], 0)
    last_of_seg = np.append(seg[1:] != seg[:-1], True)[: seg.size]
    ends[last_of_seg] = stops[seg[last_of_seg]]
    keep = ends - points >= 4
    points, ends, seg = points[keep], ends[keep], seg[keep]
    first = np.array([a for a, _ in ranges])
    shift = first[seg] - starts[seg]
    got = list(zip((points + shift).tolist(), (ends + shift).tolist(), d[ends - 1].tolist()))
    if has.all():
        return got
    # the undecided acquisitions, in their place
    where = np.r_[points, starts[~has]]
    rows = got + [(ranges[g][0], ranges[g][1], 1) for g in np.flatnonzero(~has).tolist()]
    return [rows[i] for i in np.argsort(where, kind="stable").tolist()]


def _segment_p95(segments: Sequence[np.ndarray]) -> List[float]:
    """``np.percentile(|finite values|, 95)`` of each segment (0.0 for one without a finite value), NumPy's
    values bit for bit: the segments of one finite count are stacked and taken along an axis at once (the
    same order statistics, the same interpolation), not one call each."""
    out = [0.0] * len(segments)
    groups: Dict[int, List[int]] = {}
    finite: List[np.ndarray] = []
    for i, seg in enumerate(segments):
        fin = seg[np.isfinite(seg)]
        finite.append(fin)
        if fin.size:
            groups.setdefault(fin.size, []).append(i)
    for size, idx in groups.items():
        stack = np.abs(np.stack([finite[i] for i in idx])) if len(idx) > 1 else np.abs(finite[idx[0]])[None, :]
        for i, v in zip(idx, np.percentile(stack, 95, axis=1).tolist()):
            out[i] = float(v)
    return out


def stroke_table(fy: np.ndarray, fz: np.ndarray, strokes: Sequence[Tuple[int, int, int]], fs: float, *,
                 spec: Optional[ClassicalSpec], fraction: float, cof: Optional[np.ndarray] = None,
                 x: Optional[np.ndarray] = None) -> Dict[str, np.ndarray]:  # fmt: skip
    """Per stroke: time, direction and the classical COF over its central ``fraction`` (docs/method.md 6c),
    the static (breakaway) COF before it (6c: ``stickslip.breakaway_peak``); with a position ``x`` (m), the
    work of friction over the whole stroke and its sliding distance (6c)."""
    from .strokes import breakaway_peak

    if not (0 < fraction <= 1):
        raise ValueError(f"stroke_fraction must be in (0, 1], got {fraction!r}")
    spec = spec or ClassicalSpec(0.0)
    rows: Dict[str, List[Any]] = {k: [] for k in STROKE_COLUMNS}
    first_dir = strokes[0][2] if strokes else 1
    cycle = 0
    for k, (a, b, d) in enumerate(strokes):
        if k and d == first_dir and strokes[k - 1][2] != d:
            cycle += 1
        m = b - a
        c0 = a + int(round(m * (1 - fraction) / 2))
        c1 = max(c0 + 1, a + int(round(m * (1 + fraction) / 2)))
        y = np.abs(fy[c0:c1] - spec.tare_fy)
        z = np.abs(fz[c0:c1] - spec.tare_fz)
        keep = (z >= spec.min_fn) & (z > 0) & np.isfinite(y) & np.isfinite(z)
        r = y[keep] / z[keep] if keep.any() else np.zeros(0)
        rows["stroke"].append(k)
        rows["cycle"].append(cycle)
        rows["direction"].append(d)
        rows["t_start"].append(a / fs)
        rows["time"].append((a + b) / 2 / fs)
        rows["duration"].append(m / fs)
        rows["mu"].append(float(r.mean()) if r.size else np.nan)
        # the breakaway: the first part, from the motion onset (the stroke's first sample, a reversal) to the
        # central part; a stroke that does not follow a reversal (the first) has no onset in the record
        peak, at = float("nan"), -1
        if k and strokes[k - 1][1] == a and strokes[k - 1][2] != d:
            yb = np.abs(fy[a:c0] - spec.tare_fy)
            zb = np.abs(fz[a:c0] - spec.tare_fz)
            with np.errstate(invalid="ignore", divide="ignore"):
                rb = np.where((zb >= spec.min_fn) & (zb > 0), yb / zb, np.nan)
            peak, at = breakaway_peak(rb)
        rows["mu_static"].append(peak)
        rows["t_static"].append(at / fs if at >= 0 else np.nan)
        rows["mu_median"].append(float(np.median(r)) if r.size else np.nan)
        ci = np.abs(cof[c0:c1]) if cof is not None else np.zeros(0)
        ci = ci[np.isfinite(ci)]
        rows["mu_instrument"].append(float(ci.mean()) if ci.size else np.nan)
        rows["fz_mean"].append(float(np.mean(fz[c0:c1])))
        rows["n"].append(int(keep.sum()))
        rows["start"].append(a)
        rows["stop"].append(b)
        work, dist, span = _stroke_work(fy, x, a, b, spec) if x is not None else (np.nan, np.nan, np.nan)
        rows["work"].append(work)
        rows["distance"].append(dist)
        rows["x_span"].append(span)
        rows["fz_stroke"].append(float(np.nanmean(fz[a:b] - spec.tare_fz)))
    ints = {"stroke", "cycle", "direction", "n", "start", "stop"}
    return {k: np.asarray(v, dtype=np.int64 if k in ints else float) for k, v in rows.items()}


def _stroke_work(fy: np.ndarray, x: np.ndarray, a: int, b: int, spec: ClassicalSpec) -> Tuple[float, float, float]:
    """(work of friction sum fy dx (J), sliding distance sum |dx| (m), max x - min x (m)) over samples a..b.

    Trapezoids from sample a to sample b (the next stroke's first), so the
    strokes of a cycle add up to the whole loop (docs/method.md 6c); fy is
    tared, but a constant offset cancels over a closed loop anyway.
    """
    hi = min(b + 1, len(x))
    xs = np.asarray(x[a:hi], dtype=float)
    ys = np.asarray(fy[a:hi], dtype=float) - spec.tare_fy
    if xs.size < 2:
        return float("nan"), float("nan"), float("nan")
    dx = np.diff(xs)
    work = float(np.nansum(0.5 * (ys[1:] + ys[:-1]) * dx))
    return work, float(np.nansum(np.abs(dx))), float(np.nanmax(xs) - np.nanmin(xs))


#: A cycle is whole (its loop closed) when it slides at least this fraction of twice its peak-to-peak position.
WHOLE_CYCLE = 0.9


#: Columns of :attr:`Results.cycles` with their units and meanings (docs/method.md 6c).
CYCLE_COLUMNS: Dict[str, Tuple[str, str]] = {
    "cycle": ("", "cycle number (one stroke each way)"),
    "t": ("s", "cycle centre"),
    "mu_forward": ("1", "per-stroke COF of the cycle's forward stroke(s) (direction +1; their mean)"),
    "mu_backward": ("1", "the same of the backward stroke(s) (direction -1)"),
    "mu_cycle": ("1", "(mu_forward + mu_backward) / 2: a load-cell offset cancels; the headline is its mean"),
    "offset": ("1", "(mu_forward - mu_backward) / 2: a load-cell offset (or a direction-dependent COF) over fz"),
    "energy": ("J", "energy dissipated: the friction loop's area, sum of fy dx over a whole cycle (with a position x)"),
    "distance": ("m", "sliding distance of the cycle, sum of |dx|"),
    "mu_energy": ("1", "energy COF: energy / (mean fz x distance)"),
    "slip_amplitude": ("m", "half the peak-to-peak position in the cycle"),
    "start": ("samples", "first sample of the cycle"),
    "stop": ("samples", "sample after the cycle"),
}


def cycle_table(strokes: Mapping[str, np.ndarray]) -> Dict[str, np.ndarray]:
    """One row per cycle of a reciprocating test (:data:`CYCLE_COLUMNS`; docs/method.md 6c).

    A cycle is one stroke each way (``strokes["cycle"]``); ``mu_cycle`` is NaN
    unless the cycle holds both directions with a COF; the energy columns
    are NaN without a position channel or unless both directions are there.
    """
    cyc = np.asarray(strokes["cycle"], dtype=np.int64)
    d = np.asarray(strokes["direction"], dtype=np.int64)
    cols: Dict[str, List[float]] = {k: [] for k in CYCLE_COLUMNS}
    for c in np.unique(cyc):
        sel = cyc == c
        both = bool(np.any(sel & (d == 1)) and np.any(sel & (d == -1)))
        means = []
        for sign in (1, -1):
            m = np.asarray(strokes["mu"], dtype=float)[sel & (d == sign)]
            m = m[np.isfinite(m)]
            means.append(float(m.mean()) if m.size else np.nan)
        work = np.asarray(strokes.get("work", np.full(cyc.size, np.nan)), dtype=float)[sel]
        dist = np.asarray(strokes.get("distance", np.full(cyc.size, np.nan)), dtype=float)[sel]
        span = np.asarray(strokes.get("x_span", np.full(cyc.size, np.nan)), dtype=float)[sel]
        fz = np.asarray(strokes.get("fz_stroke", np.full(cyc.size, np.nan)), dtype=float)[sel]
        # a whole cycle closes its loop: it slides about twice its peak-to-peak (a first or last part-stroke
        # does not); only a whole cycle has an energy
        whole = both and np.isfinite(dist).all() and float(dist.sum()) >= WHOLE_CYCLE * 2.0 * float(np.max(span))
        energy = abs(float(work.sum())) if whole and np.isfinite(work).all() else np.nan
        distance = float(dist.sum()) if whole else np.nan
        fz_mean = float(np.mean(np.abs(fz))) if np.isfinite(fz).all() else np.nan
        cols["cycle"].append(float(c))
        cols["t"].append(float(np.mean(np.asarray(strokes["time"], dtype=float)[sel])))
        cols["mu_forward"].append(means[0])
        cols["mu_backward"].append(means[1])
        cols["mu_cycle"].append(0.5 * (means[0] + means[1]))
        cols["offset"].append(0.5 * (means[0] - means[1]))
        cols["energy"].append(energy)
        cols["distance"].append(distance)
        cols["mu_energy"].append(energy / (fz_mean * distance) if distance and fz_mean else np.nan)
        cols["slip_amplitude"].append(0.5 * float(np.max(span)) if whole else np.nan)
        cols["start"].append(float(np.asarray(strokes.get("start", [0]))[sel].min()) if "start" in strokes else 0.0)
        cols["stop"].append(float(np.asarray(strokes.get("stop", [0]))[sel].max()) if "stop" in strokes else 0.0)
    ints = {"cycle", "start", "stop"}
    return {k: np.asarray(v, dtype=np.int64 if k in ints else float) for k, v in cols.items()}


#: Columns of :attr:`Results.strokes` with their units and meanings (docs/method.md 6c).
STROKE_COLUMNS: Dict[str, Tuple[str, str]] = {
    "stroke": ("", "stroke index"),
    "cycle": ("", "cycle number (a cycle is one stroke each way)"),
    "direction": ("", "+1 or -1: sliding direction (sign of v, of dx/dt or of fy)"),
    "t_start": ("s", "stroke start"),
    "time": ("s", "stroke centre"),
    "duration": ("s", "stroke duration"),
    "mu": ("1", "classical COF mean |fy|/|fz| over the central stroke_fraction, |fz| >= min_fn"),
    "mu_median": ("1", "median of |fy|/|fz| over the same samples"),
    "mu_static": ("1", "static (breakaway) COF: largest 5-sample mean of |fy|/|fz| before the central part (6c)"),
    "t_static": ("s", "time from the motion onset (the stroke's start) to the breakaway peak"),
    "mu_instrument": ("1", "mean of the instrument's COF column over the same samples"),
    "fz_mean": ("N", "mean fz over the same samples"),
    "n": ("samples", "samples used"),
    "start": ("samples", "first sample of the stroke"),
    "stop": ("samples", "sample after the stroke"),
    "work": ("J", "work of friction over the whole stroke, sum of (fy - tare) dx (with a position x; 6c)"),
    "distance": ("m", "sliding distance of the stroke, sum of |dx| (with a position x)"),
    "x_span": ("m", "max x - min x over the stroke (with a position x)"),
    "fz_stroke": ("N", "mean fz - tare over the whole stroke"),
}


#: Samples of the moving average whose maximum is the static COF (docs/method.md 6c).
BREAKAWAY_SMOOTH = 5
#: The noise-bias correction of the static COF (docs/method.md 6c; issue 35 point 6): resamples of the noise, the
#: half-width (samples) of the local quadratic fit that gives the breakaway's shape, and the generator's seed
#: (results are reproducible).
BREAKAWAY_RESAMPLES = 200
BREAKAWAY_SHAPE_HALF = 12
BREAKAWAY_SEED = 20061136


def _window_means(m: np.ndarray, w: int) -> np.ndarray:
    """Per row of ``m``, the mean of each run of ``w`` consecutive samples; -inf where the run holds a NaN."""
    fin = np.isfinite(m)
    c = np.concatenate([np.zeros((m.shape[0], 1)), np.cumsum(np.where(fin, m, 0.0), axis=1)], axis=1)
    n = np.concatenate([np.zeros((m.shape[0], 1), dtype=np.int64), np.cumsum(fin, axis=1)], axis=1)
    mean: np.ndarray = (c[:, w:] - c[:, :-w]) / w
    mean[(n[:, w:] - n[:, :-w]) != w] = -np.inf
    return mean


def _window_max(m: np.ndarray, w: int) -> Tuple[np.ndarray, np.ndarray]:
    """Per row of ``m``: (the largest mean of ``w`` consecutive finite samples, its window's first index);
    -inf and 0 for a row without a whole window (a window holding a NaN is skipped)."""
    mean = _window_means(m, w)
    k = np.argmax(mean, axis=1)
    return mean[np.arange(m.shape[0]), k], k


def _quadratic_shape(r: np.ndarray, h: int) -> np.ndarray:
    """The value at each sample of a least-squares parabola through the finite samples within ``h`` of it (a
    Savitzky-Golay smoothing that keeps a peak's height, the ends and NaN included: each sample's normal
    equations; NaN where fewer than 4 samples lie there)."""
    out = np.full(r.size, np.nan)
    x = np.arange(-h, h + 1, dtype=float)
    idx = np.arange(r.size)[:, None] + np.arange(-h, h + 1)[None, :]
    inside = np.clip(idx, 0, r.size - 1)
    ok = (idx >= 0) & (idx < r.size) & np.isfinite(r[inside])
    y = np.where(ok, r[inside], 0.0)
    m = [np.sum(ok * x**k, axis=1) for k in range(5)]
    a = np.stack([np.stack(m[j : j + 3], -1) for j in range(3)], -2)
    rhs = np.stack([np.sum(y * x**k, axis=1) for k in range(3)], -1)
    enough = ok.sum(axis=1) >= 4
    if enough.any():
        out[enough] = np.linalg.solve(a[enough], rhs[enough][..., None])[:, 0, 0]
    return out


def _noise_bias(r: np.ndarray, w: int) -> float:
    """The expected excess of the largest ``w``-sample mean of ``r`` over its noise-free value: the noise's
    upward bias of a maximum (docs/method.md 6c). The shape is :func:`_quadratic_shape` of ``r``; the noise SD
    comes from r's second differences (1.4826 MAD / sqrt 6: white noise, the shape's curvature negligible); the
    bias is the mean over BREAKAWAY_RESAMPLES of the shape plus fresh noise, less the shape's own maximum, on
    the windows that could hold the maximum (within 8 noise SDs of a w-mean of the shape's top). 0 with fewer
    than 3 w finite samples or no noise."""
    fin = np.isfinite(r)
    if fin.sum() < 3 * w:
        return 0.0
    d2 = (r[2:] - 2 * r[1:-1] + r[:-2])[fin[2:] & fin[1:-1] & fin[:-2]]
    if d2.size < 3:
        return 0.0
    sigma = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / np.sqrt(6.0)
    shape = _quadratic_shape(r, BREAKAWAY_SHAPE_HALF)
    shape[~fin] = np.nan  # the sims skip the windows the data skip
    window = _window_means(shape[None, :], w)[0]
    top = float(window.max())
    if not (sigma > 0 and np.isfinite(top)):
        return 0.0
    near = np.flatnonzero(window >= top - 8.0 * sigma / np.sqrt(w))  # holds the top's own window
    part = shape[int(near.min()) : int(near.max()) + w]
    rng = np.random.default_rng(BREAKAWAY_SEED)
    sims = part[None, :] + sigma * rng.standard_normal((BREAKAWAY_RESAMPLES, part.size))
    got, _ = _window_max(sims, w)
    return float(np.mean(got[np.isfinite(got)]) - top) if np.isfinite(got).any() else 0.0


def breakaway_peak(ratio: np.ndarray, smooth: int = BREAKAWAY_SMOOTH, *, correct: bool = True) -> Tuple[float, int]:
    """(static COF, index of the centre of its window) of |Ft|/Fn samples from a motion onset on (6c).

    The largest mean of ``smooth`` consecutive samples (fewer when there are
    fewer); a window holding a NaN (a sample out of contact) is skipped.
    (NaN, -1) when no window is whole. With ``correct`` (the default), less
    the noise's upward bias of that maximum (:func:`_noise_bias`; issue 35
    point 6).
    """
    r = np.asarray(ratio, dtype=float)
    w = min(int(smooth), r.size)
    if w < 1:
        return float("nan"), -1
    got, k = _window_max(r[None, :], w)
    if not np.isfinite(got[0]):
        return float("nan"), -1
    peak = float(got[0]) - (_noise_bias(r, w) if correct else 0.0)
    return peak, int(k[0]) + (w - 1) // 2


def cycle_means(strokes: Mapping[str, np.ndarray]) -> np.ndarray:
    """Per cycle, ``mu_cycle``: the mean of its forward and backward stroke means (:func:`cycle_table`)."""
    return cycle_table(strokes)["mu_cycle"]
