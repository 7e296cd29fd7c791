"""The instrument's lag chosen from the data before the windows (docs/method.md 3b).

:func:`lag_profile` measures, on a bounded sample of windows (pooled over
acquisitions), the instrument's strength r(L) and the IV slope b(L) of fy on
fz lagged by L, for every lag L < n / 2; :func:`choose_lag` takes the
shortest lag past the noise's correlation time at which the instrument is
strong; :func:`sample_windows` reads the windows the profile is measured on. The lag
found (:class:`ChosenLag`) carries the IV slope's moves at the other lags the
choice could not tell from it (:func:`admissible_lags`), which the headline's
interval pools over (docs/method.md 3b, 3d).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from .. import _core
from ..kernels.threads import resolve_threads

__all__ = [
    "STRONG",
    "AGREE_T",
    "SAMPLE_WINDOWS",
    "LagProfile",
    "ChosenLag",
    "lag_profile",
    "choose_lag",
    "admissible_lags",
    "chosen_lag",
    "extra_lags",
    "EXTRA_LAGS",
    "sample_windows",
    "lag_sample_held",
]

#: Most other admissible lags whose instrument sums the windows' kernel adds (``_core``'s MAX_EXTRA_LAGS; the
#: pooled moves, docs/method.md 3d).
EXTRA_LAGS = 8
#: The instrument is strong at a lag where the median over windows of |r(w, fz)| is at least this.
STRONG = 0.5
#: A lag is past the noise's correlation time when its IV slope differs from the reference lag's by at
#: most this many standard errors of the difference (and so does every strong lag up to twice it).
AGREE_T = 3.0
#: Windows read for the profile at most (the first ones of the analysed samples, acquisition by acquisition).
SAMPLE_WINDOWS = 64


@dataclass(frozen=True)
class LagProfile:
    """r(L) and b(L) for L = 0..max_lag (index = lag) over ``windows`` windows; ``t`` against ``ref``."""

    r: np.ndarray
    b: np.ndarray
    t: np.ndarray
    ref: int
    windows: int


def lag_profile(segments: Union[Tuple[np.ndarray, np.ndarray], Sequence[Tuple[np.ndarray, np.ndarray]]],
                max_lag: int) -> Optional[LagProfile]:  # fmt: skip
    """The instrument's strength and IV slope at every lag 0..max_lag over ``segments``: windows of (fy, fz) of
    one length, as the two (windows, n) arrays :func:`sample_windows` gives or a sequence of (fy, fz) pairs (those
    of the first pair's length, longer than 2 max_lag, are taken).

    Per window (centred), A(L) = sum_t z_t z_{t-L} and C(L) = sum_t y_t z_{t-L}
    (t >= L; by FFT); r(L) = median over windows of (A(L) / (n - L)) / (A(0) / n);
    b(L) = sum C(L) / sum A(L) over the windows. The reference lag is the
    strongest among the longer half (L >= max_lag / 2); t(L) is
    (b(L) - b(ref)) over the batch-means standard error of that difference
    with the windows as batches. None with fewer than 4 windows or max_lag < 2.
    """
    if max_lag < 2:
        return None
    Y, Z = _as_rows(segments)
    n = Y.shape[1]
    if Y.shape[0] < 4 or n <= 2 * max_lag:
        return None
    lim = _core.FORCE_LIMIT
    # a window holding a sample beyond the kernel's range (or NaN, which fails the comparisons) is left out
    # (docs/method.md 4)
    zmin, zmax = Z.min(axis=1), Z.max(axis=1)
    keep = (Y.min(axis=1) >= -lim) & (Y.max(axis=1) <= lim) & (zmin >= -lim) & (zmax <= lim)
    if int(keep.sum()) < 4:
        return None
    if not keep.all():
        Y, Z, zmin, zmax = Y[keep], Z[keep], zmin[keep], zmax[keep]
    top = max(float(zmax.max()), -float(zmin.min()))
    k = Y.shape[0]
    scale = top or 1.0  # max |z|: r and b do not depend on a common scale
    A, C = _core.lagged_sums(Y, Z, max_lag, scale, threads=resolve_threads())  # by FFT, no lag wrapping round
    lags = np.arange(max_lag + 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        # (A(L) / (n - L)) / (A(0) / n) per window, laid out lag by window for the medians over the windows
        x = np.divide(A.T, (n - lags)[:, None], order="C")
        x /= A[:, 0] / n
        r = _row_medians(x)
        del x
        sa = A.sum(axis=0)
        b = C.sum(axis=0) / sa
        lo = max(2, max_lag // 2)
        if not np.isfinite(r[lo:]).any():
            return None
        ref = lo + int(np.nanargmax(np.abs(r[lo:])))
        # phi = U / sa - U(ref) / sa(ref), U = C - b A per window (in place: one array)
        phi = np.multiply(b, A, out=A)
        np.subtract(C, phi, out=phi)
        phi /= sa
        phi -= phi[:, ref].copy()[:, None]
        se = np.sqrt(k / (k - 1) * np.sum(np.square(phi, out=phi), axis=0))
        t = (b - b[ref]) / se
    t[ref] = 0.0
    return LagProfile(r=r, b=b, t=t, ref=ref, windows=k)


def _as_rows(segments: Any) -> Tuple[np.ndarray, np.ndarray]:
    """(Y, Z), (windows, n) C-order float64: ``segments`` as :func:`lag_profile` takes them."""
    if (
        isinstance(segments, tuple)
        and len(segments) == 2
        and all(isinstance(a, np.ndarray) and a.ndim == 2 for a in segments)
    ):
        Y, Z = (np.ascontiguousarray(a, dtype=float) for a in segments)
        if Y.shape != Z.shape:
            raise ValueError(f"fy and fz windows must have one shape, got {Y.shape} and {Z.shape}")
        return Y, Z
    segs = [(np.asarray(y, float), np.asarray(z, float)) for y, z in segments]
    segs = [(y, z) for y, z in segs if y.ndim == 1 and y.size == z.size]
    n = segs[0][0].size if segs else 0
    segs = [(y, z) for y, z in segs if y.size == n]  # one length: the first window's
    if not segs:
        return np.zeros((0, 0)), np.zeros((0, 0))
    return np.stack([y for y, _ in segs]), np.stack([z for _, z in segs])


def _row_medians(x: np.ndarray) -> np.ndarray:
    """``np.median(x, axis=1)`` of a 2-D array (lags by windows), bit for bit: a row holding NaN is NaN; the
    others by the kernel's row selection (``_order.row_quantiles``), on the calling thread (a few hundred
    microseconds of work, beside the pre-pass: a second thread would only wait for a core)."""
    from ..kernels._order import row_quantiles

    if x.shape[1] == 0 or np.isnan(x).any():
        return np.asarray(np.median(x, axis=1))
    return row_quantiles(np.ascontiguousarray(x), (), threads=1)[0]


def choose_lag(p: Optional[LagProfile], weak: float) -> Optional[int]:
    """The shortest lag past the noise's correlation time at which the instrument is strong (docs/method.md 3b).

    Past the correlation time: the lag's IV slope agrees with the reference
    lag's (|t| <= :data:`AGREE_T`), and so does every strong lag up to twice
    it. Strong: |r| >= :data:`STRONG`. None when no lag qualifies or the
    reference lag itself is weak (|r| < ``weak``): no valid instrument found.
    """
    if p is None or not abs(p.r[p.ref]) >= weak:
        return None
    ok = _accepted(p)
    return next((L for L in range(2, len(p.r)) if ok[L]), None)


def _accepted(p: LagProfile) -> np.ndarray:
    """Per lag: strong, and its IV slope and every strong lag's up to twice it agree with the reference lag's."""
    strong = np.abs(p.r) >= STRONG
    agree = np.abs(p.t) <= AGREE_T
    ok = np.where(strong, agree, True)
    lags = np.arange(len(p.r))
    # the first lag at or after each lag where a strong lag disagrees (len(r) when none)
    first_bad = np.minimum.accumulate(np.where(ok, len(p.r), lags)[::-1])[::-1]
    out: np.ndarray = strong & (first_bad > np.minimum(2 * lags, len(p.r) - 1)) & (lags >= 2)
    return out


def admissible_lags(p: LagProfile, lag: int) -> List[int]:
    """The lags the choice of ``lag`` could not tell from it: those :func:`choose_lag` accepts (strong, their IV
    slope and every strong lag's up to twice it in agreement with the reference lag's) from ``lag`` up to twice
    the next one it accepts (docs/method.md 3b, 3d); ``lag`` first."""
    ok = _accepted(p)
    after = int(lag) + 1 + np.flatnonzero(ok[int(lag) + 1 :])
    top = min(2 * int(after[0]), len(p.r) - 1) if after.size else int(lag)
    return [int(lag)] + [int(k) for k in after[after <= top]]


@dataclass(frozen=True)
class ChosenLag:
    """The instrument lag chosen from the data and what the choice could not tell apart (docs/method.md 3b, 3d).

    Attributes
    ----------
    samples : int
        The lag, samples.
    shifts : tuple of float
        b(L') - b(L) over the other :func:`admissible_lags` L' (the pooled IV slope of fy on fz at L' less the
        one at the lag L, over the profile's windows, the data's orientation). The corrected slope with the fz
        noise measured at a lag is, to first order, the IV slope at that lag, so these are the moves of mu_r
        (times the orientation) had another of those lags been chosen. For information: 64 windows carry
        their own noise, so the headline's interval pools over the same moves measured on all the analysed
        windows (``others``; docs/method.md 3d).
    others : tuple of int
        The other admissible lags at which the windows' kernel adds the instrument's sums (column
        ``lag_sums``): all of them, or :data:`EXTRA_LAGS` spread evenly over them, the farthest kept
        (:func:`extra_lags`). :class:`~tribodyn.pipeline.plan.Findings` carries the three.
    """

    samples: int
    shifts: Tuple[float, ...] = ()
    others: Tuple[int, ...] = ()


def chosen_lag(p: Optional[LagProfile], weak: float) -> Optional[ChosenLag]:
    """:func:`choose_lag` with the IV slope's moves at the other :func:`admissible_lags` (:class:`ChosenLag`)."""
    lag = choose_lag(p, weak)
    if lag is None or p is None:
        return None
    b = p.b
    adm = admissible_lags(p, lag)
    moves = [float(b[k] - b[lag]) for k in adm if k != lag and np.isfinite(b[k] - b[lag])]
    return ChosenLag(int(lag), tuple(moves), extra_lags(adm))


def extra_lags(admissible: Sequence[int]) -> Tuple[int, ...]:
    """The lags other than the chosen one (``admissible[0]``) at which the windows' kernel adds the instrument's
    sums: all when at most :data:`EXTRA_LAGS`, else that many spread evenly over them by rank, the nearest
    and the farthest kept: the moves' range (the interval's widening comes from the farthest) with a bounded
    cost per window (docs/method.md 3d)."""
    rest = [int(k) for k in admissible[1:]]
    if len(rest) <= EXTRA_LAGS:
        return tuple(rest)
    pick = np.unique(np.round(np.linspace(0, len(rest) - 1, EXTRA_LAGS)).astype(int))
    return tuple(rest[i] for i in pick)


def sample_windows(source: Any, rec: Any, length: int, *, start: int = 0, stop: Optional[int] = None,
                   limit: int = SAMPLE_WINDOWS) -> Tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The first ``limit`` windows of ``length`` samples of (fy, fz), tiling, never across two acquisitions: two
    (windows, length) float64 arrays, one window a row (:func:`lag_profile` takes them as they are).

    ``source`` a mapping of arrays or a list of them (acquisitions), or
    ``rec`` a recording (its segments are acquisitions); no window for a
    one-pass stream (which cannot be read twice: the plan's default lag then).
    """
    none = np.zeros((0, max(int(length), 0)))
    if rec is not None:
        if not all(r in getattr(rec, "roles", {}) for r in ("fy", "fz")):
            return none, none
        n_tot = int(rec.n_samples) if stop is None else min(int(stop), int(rec.n_samples))
        segs = getattr(rec, "segments", None) or [(0, n_tot)]
        ranges = _spread([(max(a, start), min(b, n_tot)) for a, b in segs], length, limit)
        if not ranges:
            return none, none
        lo, hi = ranges[0][0], ranges[-1][1]
        if getattr(rec, "random_access", False) and hasattr(rec, "read_ranges"):  # as the pre-pass reads
            got = rec.read_ranges(ranges, ["fy", "fz"])
            shape = (len(ranges), length)
            return np.asarray(got["fy"], float).reshape(shape), np.asarray(got["fz"], float).reshape(shape)
        if getattr(rec, "random_access", False):
            parts = list(rec.chunks(hi - lo, ["fy", "fz"], start=lo, stop=hi))
        else:  # from the start: the first windows only
            parts, lo = list(rec.chunks(hi, ["fy", "fz"], stop=hi)), 0
        fy = np.concatenate([np.asarray(p["fy"], float) for p in parts])
        fz = np.concatenate([np.asarray(p["fz"], float) for p in parts])
        return _rows(fy, fz, [(a - lo, b - lo) for a, b in ranges], length)
    if isinstance(source, Mapping):
        acqs: Sequence[Any] = [source]
    elif isinstance(source, (list, tuple)) and source and all(isinstance(a, Mapping) for a in source):
        acqs = source
    else:
        return none, none
    if not all("fy" in a and "fz" in a for a in acqs):
        return none, none
    bounds, at = [], 0
    for a in acqs:
        size = min(len(a["fy"]), len(a["fz"]))
        bounds.append((at, at + size))
        at += size
    if len(acqs) == 1:
        bounds = [(max(start, 0), bounds[0][1] if stop is None else min(stop, bounds[0][1]))]
    ranges = _spread(bounds, length, limit)
    Y, Z = np.empty((len(ranges), length)), np.empty((len(ranges), length))
    for j, (a, b) in enumerate(ranges):
        k = next(i for i, (u, v) in enumerate(bounds) if u <= a < v) if len(acqs) > 1 else 0
        off = a - (bounds[k][0] if len(acqs) > 1 else 0)
        Y[j] = acqs[k]["fy"][off : off + length]
        Z[j] = acqs[k]["fz"][off : off + length]
    return Y, Z


def _rows(fy: np.ndarray, fz: np.ndarray, ranges: Sequence[Tuple[int, int]], length: int
          ) -> Tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The ``ranges`` (each ``length`` samples) of ``fy`` and ``fz`` as the rows of two arrays."""
    Y, Z = np.empty((len(ranges), length)), np.empty((len(ranges), length))
    for j, (a, b) in enumerate(ranges):
        Y[j], Z[j] = fy[a:b], fz[a:b]
    return Y, Z


def lag_sample_held(rec: Any, length: int, n: int) -> bool:
    """Whether the first ``n`` samples of ``rec`` hold every window :func:`find_lag` reads from a recording's
    start (``whole``; :data:`SAMPLE_WINDOWS` tiles of ``length``): the lag chosen from them stays the same as the
    recording grows (docs/method.md 11)."""
    segs = getattr(rec, "segments", None) or [(0, n)]
    held = [(a, min(b, n)) for a, b in segs if a < n]
    return len(_spread(held, length, SAMPLE_WINDOWS)) >= SAMPLE_WINDOWS


def _spread(bounds: Sequence[Tuple[int, int]], length: int, limit: int) -> List[Tuple[int, int]]:
    """The first ``limit`` ranges of ``length`` samples tiling the (start, stop) bounds.

    The first ones, whatever the source: a mapping, a random-access or a
    sequential recording of the same samples give the same lag.
    """
    tiles = ((a + j * length, a + (j + 1) * length) for a, b in bounds if b - a >= length
             for j in range((b - a) // length))  # fmt: skip
    return list(itertools.islice(tiles, limit))


def find_lag(source: Any, rec: Any, plan: Any, pre: Mapping[str, Any], whole: bool = False, *,
             earlier: Any = None) -> Optional[ChosenLag]:  # fmt: skip
    """:func:`chosen_lag` on :func:`sample_windows` of the analysed samples, when the plan leaves the lag to the data.

    ``whole``: from the recording's first windows, not the plan's range
    (the ranges of one recording, :func:`tribodyn.analyze_partial`, then share
    one lag with the analysis of the whole). None (the plan's default lag) with ``method="paper"``, a given ``iv_lag``
    or ``rpm``, a reciprocating test, a one-pass stream or no valid lag. ``earlier``: the findings
    (``Findings``) of a look at the same first windows (``whole``) of a growing recording that held them all
    then (:func:`lag_sample_held`): their lag, the windows not read again (docs/method.md 11). The lag found
    is a :class:`ChosenLag`: the lag with the IV slope's moves at the other admissible lags (docs/method.md 3d).
    """
    from ..kernels.estimators import WEAK_INSTRUMENT

    if plan.paper or not plan.iv_lag_from_data or pre.get("motion") == "reciprocating":
        return None
    if earlier is not None and whole:
        if earlier.iv_lag_samples is None:
            return None
        return ChosenLag(int(earlier.iv_lag_samples), tuple(earlier.iv_lag_shifts), tuple(earlier.iv_lag_others))
    n = int(plan.length)
    if rec is not None and not whole:
        windows = sample_windows(source, rec, n, start=plan.start, stop=plan.stop)
    else:
        windows = sample_windows(source, rec, n)
    return chosen_lag(lag_profile(windows, (n - 1) // 2), WEAK_INSTRUMENT)
