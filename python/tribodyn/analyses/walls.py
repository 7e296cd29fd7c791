"""Curved walls of the bathtub fit: where a curved COF leaves its floor (docs/method.md 7; issue 23).

A straight wall cannot follow a wall that bends into the floor (a curved
onset) or that is flat further out (a shoulder): least squares then tilts
the line and its breakpoint lands away from where the COF leaves the floor
(1.5-2 degC above the simulated upper temperature edge, 0.3 A/mm^2 inside
the simulated lower current-density edge). Each wall is here

    a * h(u; w, c),   h(u; w, c) = huber(min(u, c), w),   u = b - x (lower) or x - b (upper), u > 0

``huber(u, w)`` is ``u^2 / (2 w)`` for ``u < w`` and ``u - w / 2`` beyond
(``u`` when ``w = 0``): the wall leaves the floor at ``b`` with a curved
onset over ``w`` (none when ``w = 0``), rises with slope ``a`` and is flat
beyond ``b -/+ c`` (no shoulder when ``c = inf``). The straight wall of
:mod:`tribodyn.analyses.segmented` is ``w = 0, c = inf``. The onset widths ``w`` are
0, 3, 7, 12 and 20 % of the covariate range, the reaches ``c`` infinite or
10, 20, 30 and 45 % of it (``c >= w``); the breakpoint ``b`` runs over a grid
of the range, finer around the estimate.

For fixed shapes the model is linear in ``(m, a_lo, a_hi)``, and because
the walls do not overlap (``b_lo <= b_hi``) the two walls only share ``m``.
The fit is exact over all pairs of lower and upper candidates. The
bootstrap refits every resample at once: a resample is a count per window,
so the weighted sums of all candidates and resamples are matrix products;
each resample is then fitted by coordinate descent from the estimate's
``m`` (the best wall on either side given ``m``, then ``m`` given the
walls; the residual sum never increases).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, Tuple

import numpy as np

from .segmented import Fit

__all__ = ["CurvedFit", "fit_curved", "bootstrap_curved", "profile_interval", "WIDTHS", "REACHES"]

#: Onset widths ``w`` of the walls, as fractions of the covariate range.
WIDTHS = (0.0, 0.03, 0.07, 0.12, 0.2)
#: Reaches ``c`` of the walls (flat beyond), as fractions of the covariate range.
REACHES = (math.inf, 0.1, 0.2, 0.3, 0.45)
_GRID = 48
_FINE = 41
_ITER = 6


def huber(u: np.ndarray, w: float) -> np.ndarray:
    """0 for u <= 0, u^2 / (2 w) below w, u - w / 2 beyond (u itself when w = 0)."""
    u = np.maximum(u, 0.0)
    if w <= 0:
        return u
    return np.where(u < w, u * u / (2.0 * w), u - 0.5 * w)


def shape(u: np.ndarray, w: float, c: float) -> np.ndarray:
    """The wall's shape ``huber(min(u, c), w)`` (module docstring)."""
    return huber(np.minimum(u, c), w)


@dataclass(frozen=True)
class CurvedFit(Fit):
    """A bathtub fit with curved walls: a :class:`tribodyn.analyses.segmented.Fit` plus the walls' shapes.

    ``w_lo, c_lo`` (``w_hi, c_hi``): onset width and reach of the lower
    (upper) wall, in covariate units; ``a_lo``/``a_hi`` the slope of the
    wall's straight part.
    """

    w_lo: float = 0.0
    c_lo: float = math.inf
    w_hi: float = 0.0
    c_hi: float = math.inf

    def predict(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        y = np.full(x.shape, self.m)
        if self.a_lo > 0 and np.isfinite(self.b_lo):
            y = y + self.a_lo * shape(self.b_lo - x, self.w_lo, self.c_lo)
        if self.a_hi > 0 and np.isfinite(self.b_hi):
            y = y + self.a_hi * shape(x - self.b_hi, self.w_hi, self.c_hi)
        return y

    def rise_at(self, target: float) -> float:
        """Distance above ``b_hi`` where the upper wall reaches ``target`` (inf if it never does; NaN: no wall)."""
        if not (self.a_hi > 0 and np.isfinite(self.b_hi)):
            return math.nan
        v = target / self.a_hi
        if np.isfinite(self.c_hi) and v > float(shape(np.array(self.c_hi), self.w_hi, self.c_hi)):
            return math.inf
        w = self.w_hi
        return math.sqrt(2.0 * w * v) if w > 0 and v < 0.5 * w else v + 0.5 * w


@dataclass(frozen=True)
class _Side:
    b: np.ndarray  # (K,) breakpoints
    w: np.ndarray  # (K,) onset widths
    c: np.ndarray  # (K,) reaches
    col: np.ndarray  # (K, n) wall columns
    beyond: np.ndarray  # (K, n) windows beyond the breakpoint (float 0/1)


def _side(x: np.ndarray, lower: bool, breaks: np.ndarray) -> _Side:
    span = float(x.max() - x.min())
    shapes = [(w * span, c * span) for w in WIDTHS for c in REACHES if c >= w and (c * span > 0)]
    b = np.repeat(breaks, len(shapes))
    w = np.tile([s[0] for s in shapes], len(breaks))
    c = np.tile([s[1] for s in shapes], len(breaks))
    u = (b[:, None] - x[None, :]) if lower else (x[None, :] - b[:, None])
    col = np.maximum(u, 0.0)
    col = np.minimum(col, c[:, None])
    wc = w[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        col = np.where((wc > 0) & (col < wc), col * col / (2.0 * np.where(wc > 0, wc, 1.0)), col - 0.5 * wc)
    col = np.maximum(col, 0.0)
    return _Side(b, w, c, col, (u > 0).astype(float))


def _breaks(x: np.ndarray, around: float) -> np.ndarray:
    lo, hi = float(x.min()), float(x.max())
    coarse = np.linspace(lo, hi, _GRID)
    if not np.isfinite(around):
        return coarse
    step = (hi - lo) / (_GRID - 1)
    fine = np.linspace(max(lo, around - 3 * step), min(hi, around + 3 * step), _FINE)
    return np.unique(np.r_[coarse, fine])


def _sums(s: _Side, wc: np.ndarray, wy: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(S_L, S_LL, S_Ly) of every candidate for each row of weights ``wc`` (B, n); ``wy`` = wc * y."""
    return wc @ s.col.T, wc @ (s.col * s.col).T, wy @ s.col.T


def _pieces(SL: np.ndarray, SLL: np.ndarray, SLy: np.ndarray, ok: np.ndarray) -> Tuple[np.ndarray, ...]:
    """A = S_L^2/S_LL, B = S_L S_Ly/S_LL, C = S_Ly^2/S_LL; invalid candidates get NaN."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(ok, 1.0 / SLL, np.nan)
    return SL * SL * inv, SL * SLy * inv, SLy * SLy * inv


def fit_curved(
    x: np.ndarray, y: np.ndarray, w: np.ndarray, family: str, *, start: Tuple[float, float], min_wall: int = 3
) -> Tuple[CurvedFit, Dict[str, _Side], Dict[str, Tuple[np.ndarray, np.ndarray]]]:
    """The best curved-wall fit of ``family`` ("lower", "upper" or "both") with weights ``w``.

    ``start`` holds the straight-wall breakpoints (NaN when absent): the
    breakpoint grid is refined around them. Returns the fit, the
    candidates (for :func:`bootstrap_curved`) and, per wall ("lo", "hi"),
    the profile of the residual sum: (breakpoints, least residual sum over
    everything else at each; inf where no valid fit).
    """
    prof: Dict[str, Tuple[np.ndarray, np.ndarray]] = {}
    sides: Dict[str, _Side] = {}
    if family in ("lower", "both"):
        sides["lo"] = _side(x, True, _breaks(x, start[0]))
    if family in ("upper", "both"):
        sides["hi"] = _side(x, False, _breaks(x, start[1]))
    wy = w * y
    S0, Sy, Syy = float(w.sum()), float(wy.sum()), float(wy @ y)
    parts = {}
    for k, s in sides.items():
        SL, SLL, SLy = (v[0] for v in _sums(s, w[None, :], wy[None, :]))
        nb = s.beyond @ np.ones(len(x))
        ok = (nb >= min_wall) & (SLL > 1e-12 * max(S0, 1e-300))
        parts[k] = (SL, SLL, SLy, ok)
    if family == "both":
        Al, Bl, Cl = _pieces(*parts["lo"])
        Ah, Bh, Ch = _pieces(*parts["hi"])
        den = S0 - Al[:, None] - Ah[None, :]
        num = Sy - Bl[:, None] - Bh[None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            m = num / den
            rss = Syy - Cl[:, None] - Ch[None, :] - num * num / den
            a_lo = (parts["lo"][2][:, None] - m * parts["lo"][0][:, None]) / parts["lo"][1][:, None]
            a_hi = (parts["hi"][2][None, :] - m * parts["hi"][0][None, :]) / parts["hi"][1][None, :]
        good = np.isfinite(rss) & (den > 0) & (a_lo > 0) & (a_hi > 0)
        good &= sides["lo"].b[:, None] <= sides["hi"].b[None, :]
        if not good.any():
            return CurvedFit(family, math.nan, 0.0, 0.0, math.nan, math.nan, math.inf), sides, prof
        r = np.where(good, rss, np.inf)
        i, j = np.unravel_index(int(np.argmin(r)), rss.shape)
        lo, hi = sides["lo"], sides["hi"]
        prof["lo"], prof["hi"] = _profile(lo.b, r.min(1)), _profile(hi.b, r.min(0))
        both = CurvedFit("both", float(m[i, j]), float(a_lo[i, j]), float(a_hi[i, j]), float(lo.b[i]),
                         float(hi.b[j]), float(rss[i, j]), float(lo.w[i]), float(lo.c[i]), float(hi.w[j]),
                         float(hi.c[j]))  # fmt: skip
        return both, sides, prof
    key = "lo" if family == "lower" else "hi"
    A, B_, C = _pieces(*parts[key])
    SL, SLL, SLy, _ = parts[key]
    with np.errstate(divide="ignore", invalid="ignore"):
        den = S0 - A
        m1 = (Sy - B_) / den
        rss1 = Syy - C - (Sy - B_) ** 2 / den
        a = (SLy - m1 * SL) / SLL
    good = np.isfinite(rss1) & (den > 0) & (a > 0)
    if not good.any():
        return CurvedFit(family, math.nan, 0.0, 0.0, math.nan, math.nan, math.inf), sides, prof
    k1 = int(np.argmin(np.where(good, rss1, np.inf)))
    sd = sides[key]
    prof[key] = _profile(sd.b, np.where(good, rss1, np.inf))
    if family == "lower":
        f = CurvedFit(family, float(m1[k1]), float(a[k1]), 0.0, float(sd.b[k1]), math.nan, float(rss1[k1]),
                      float(sd.w[k1]), float(sd.c[k1]))  # fmt: skip
    else:
        f = CurvedFit(family, float(m1[k1]), 0.0, float(a[k1]), math.nan, float(sd.b[k1]), float(rss1[k1]),
                      w_hi=float(sd.w[k1]), c_hi=float(sd.c[k1]))  # fmt: skip
    return f, sides, prof


def _profile(b: np.ndarray, rss: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Least ``rss`` at each distinct breakpoint of ``b``."""
    u, inv = np.unique(b, return_inverse=True)
    best = np.full(u.size, np.inf)
    np.minimum.at(best, inv, rss)
    return u, best


def profile_interval(
    prof: Tuple[np.ndarray, np.ndarray], rss_min: float, scale: float, q: float = 3.841458820694124
) -> Tuple[float, float]:
    """The breakpoints whose profile residual sum is within ``q * scale`` of the least (hull, out to the grid's
    next points): a profile-likelihood interval, 95 % for ``q`` = chi^2_1(0.95) (docs/method.md 7)."""
    b, r = prof
    inside = np.flatnonzero(r - rss_min <= q * scale)
    if not inside.size:
        return math.nan, math.nan
    lo, hi = int(inside.min()), int(inside.max())
    return float(b[max(lo - 1, 0)]), float(b[min(hi + 1, b.size - 1)])


def bootstrap_curved(
    x: np.ndarray, y: np.ndarray, w: np.ndarray, counts: np.ndarray, *, fit: CurvedFit, sides: Dict[str, _Side],
    min_wall: int = 3,
) -> Dict[str, np.ndarray]:  # fmt: skip
    """The family of ``fit`` refitted on every resample (``counts``: (B, n) windows drawn per resample).

    Returns arrays (B,) "m", "b_lo", "b_hi", "a_lo", "a_hi", "w_lo", "c_lo",
    "w_hi", "c_hi" (NaN where a resample cannot be fitted).
    """
    B = counts.shape[0]
    wc = counts * w[None, :]
    wy = wc * y[None, :]
    S0, Sy = wc.sum(1), wy.sum(1)
    out = {k: np.full(B, np.nan) for k in ("m", "b_lo", "b_hi", "a_lo", "a_hi", "w_lo", "c_lo", "w_hi", "c_hi")}
    if B == 0:
        return out
    P = {}
    for k, s in sides.items():
        SL, SLL, SLy = _sums(s, wc, wy)
        nb = counts @ s.beyond.T
        ok = (nb >= min_wall) & (SLL > 1e-12 * np.maximum(S0, 1e-300)[:, None])
        P[k] = (SL, SLL, SLy, ok)
    m = np.full(B, fit.m)
    rows = np.arange(B)
    pick: Dict[str, np.ndarray] = {}
    a: Dict[str, np.ndarray] = {}
    for it in range(_ITER):
        score: Dict[str, np.ndarray] = {}
        for k in P:
            SL, SLL, SLy, ok = P[k]
            with np.errstate(divide="ignore", invalid="ignore"):
                r = SLy - m[:, None] * SL
                score[k] = np.where(ok & (r > 0), r * r / SLL, -np.inf)
        if "lo" in P and "hi" in P:
            # The best pair given m with b_lo <= b_hi: for each upper candidate the best lower one at or below it.
            order = np.argsort(sides["lo"].b, kind="stable")
            b_sorted = sides["lo"].b[order]
            prefix = np.maximum.accumulate(score["lo"][:, order], axis=1)
            at = np.searchsorted(b_sorted, sides["hi"].b, side="right") - 1
            best_lo = np.where(at[None, :] >= 0, prefix[:, np.maximum(at, 0)], -np.inf)
            j = np.argmax(score["hi"] + best_lo, axis=1)
            total = score["hi"][rows, j] + best_lo[rows, j]
            valid = np.isfinite(total)
            pick["hi"] = np.where(valid, j, -1)
            allowed = sides["lo"].b[None, :] <= sides["hi"].b[j][:, None]
            i = np.argmax(np.where(allowed, score["lo"], -np.inf), axis=1)
            pick["lo"] = np.where(valid, i, -1)
        else:
            for k in P:
                j = np.argmax(score[k], axis=1)
                pick[k] = np.where(np.isfinite(score[k][rows, j]), j, -1)
        if it == _ITER - 1:
            break  # the walls picked given m: their slopes are positive at this m
        # m given the walls
        num, den = Sy.copy(), S0.copy()
        for k, j in pick.items():
            SL, SLL, SLy, _ = P[k]
            jj = np.maximum(j, 0)
            sl, sll, sly = SL[rows, jj], SLL[rows, jj], SLy[rows, jj]
            use = j >= 0
            with np.errstate(divide="ignore", invalid="ignore"):
                num = num - np.where(use, sl * sly / sll, 0.0)
                den = den - np.where(use, sl * sl / sll, 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            m = np.where(den > 0, num / den, np.nan)
    good = np.isfinite(m)
    for k, j in pick.items():
        SL, SLL, SLy, _ = P[k]
        jj = np.maximum(j, 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            a[k] = (SLy[rows, jj] - m * SL[rows, jj]) / SLL[rows, jj]
        good &= (j >= 0) & (a[k] > 0)
        s = sides[k]
        out[f"b_{k}"] = np.where(good, s.b[jj], np.nan)
        out[f"w_{k}"] = np.where(good, s.w[jj], np.nan)
        out[f"c_{k}"] = np.where(good, s.c[jj], np.nan)
    for k in pick:
        out[f"a_{k}"] = np.where(good, a[k], np.nan)
        out[f"b_{k}"] = np.where(good, out[f"b_{k}"], np.nan)
    out["m"] = np.where(good, m, np.nan)
    return out
