"""Flat-bottomed piecewise-linear ("bathtub") fit of the COF against a covariate (docs/method.md 7).

Model, continuous in the covariate x::

    mu(x) = m + a_lo * max(b_lo - x, 0) + a_hi * max(x - b_hi, 0),   a_lo, a_hi >= 0,  b_lo <= b_hi

a flat bottom ``m`` between the breakpoints ``b_lo`` and ``b_hi`` and a
straight wall on either side; either wall may be absent. Four nested
families are fitted by weighted least squares: flat (1 parameter), lower
wall only or upper wall only (3: m, a, b) and both walls (5). For fixed
breakpoints the model is linear, so the breakpoints are found by an
exhaustive search over a grid of the covariate range (refined once around
the best pair); a wall needs at least ``min_wall`` windows beyond its
breakpoint. Weights are ``1 / (se_i^2 + tau^2)``: the windows' standard
errors plus a between-window variance ``tau^2`` chosen so that the
weighted residuals of the best fit have unit variance (Paule-Mandel).

Model choice by F-tests at level ``alpha`` (0.01): the covariate matters
when the best wall model beats the flat fit, counting each breakpoint as a
parameter (the search makes the plain F-test optimistic, hence the strict
level); both walls are kept when they beat the best single wall. Windows
that overlap (a hop shorter than the window: ``overlap`` = window / hop
windows share each sample) are not independent: the F statistic is divided
by ``overlap`` and its denominator has ``n / overlap - p`` degrees of
freedom, so the choice depends on the recording, not on the hop (issue 35).

Intervals: a moving-block bootstrap over time (blocks of consecutive
windows, ``overlap * max(3, ceil((n / overlap)^(1/3)))`` long: the same
stretch of time at every hop), refitting the chosen family on each resample
with the same weights; 95 % percentile intervals. The random generator is
seeded (``seed``, default 0), so results repeat.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Dict, Optional, Tuple

import numpy as np

from ..kernels.quantiles import f_sf

__all__ = ["Fit", "fit_bathtub", "bootstrap_indices", "block_length", "FAMILIES"]

#: Model families: no wall, lower wall, upper wall, both.
FAMILIES = ("flat", "lower", "upper", "both")
_NPAR = {"flat": 1, "lower": 3, "upper": 3, "both": 5}
_GRID = 48
_FINE = 25


@dataclass(frozen=True)
class Fit:
    """One weighted bathtub fit (docs/method.md 7).

    Attributes
    ----------
    family : str
        One of :data:`FAMILIES`.
    m : float
        Flat-bottom COF (mu_min).
    a_lo, a_hi : float
        Wall slopes (COF per covariate unit, >= 0; 0 when the wall is absent).
    b_lo, b_hi : float
        Breakpoints (NaN when the wall is absent).
    rss : float
        Weighted residual sum of squares.
    """

    family: str
    m: float
    a_lo: float
    a_hi: float
    b_lo: float
    b_hi: float
    rss: float

    def predict(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        y = np.full(x.shape, self.m)
        if self.a_lo > 0 and np.isfinite(self.b_lo):
            y = y + self.a_lo * np.maximum(self.b_lo - x, 0.0)
        if self.a_hi > 0 and np.isfinite(self.b_hi):
            y = y + self.a_hi * np.maximum(x - self.b_hi, 0.0)
        return y


_NONE = Fit("flat", math.nan, 0.0, 0.0, math.nan, math.nan, math.inf)


def _sums(x: np.ndarray, y: np.ndarray, w: np.ndarray, glo: np.ndarray, ghi: np.ndarray) -> Dict[str, Any]:
    L = np.maximum(glo[:, None] - x[None, :], 0.0)
    U = np.maximum(x[None, :] - ghi[:, None], 0.0)
    Lw, Uw = L * w, U * w
    return dict(
        S0=w.sum(), Sy=w @ y, Syy=w @ (y * y),
        SL=Lw.sum(1), SLL=(Lw * L).sum(1), SLy=Lw @ y,
        SU=Uw.sum(1), SUU=(Uw * U).sum(1), SUy=Uw @ y,
        SLU=Lw @ U.T,
        nlo=(x[None, :] < glo[:, None]).sum(1), nhi=(x[None, :] > ghi[:, None]).sum(1),
    )  # fmt: skip


def _one_wall(S0: Any, Sy: Any, Syy: Any, *, S: Any, SS: Any, Sy_: Any) -> Tuple[Any, Any, Any, Any]:
    """Slope, wall coefficient, RSS and determinant of one-wall fits, for every breakpoint."""
    det = S0 * SS - S * S
    with np.errstate(invalid="ignore", divide="ignore"):
        m = (SS * Sy - S * Sy_) / det
        a = (S0 * Sy_ - S * Sy) / det
    rss = Syy - m * Sy - a * Sy_
    return m, a, rss, det


def _best(
    x: np.ndarray, y: np.ndarray, w: np.ndarray, glo: np.ndarray, ghi: np.ndarray, *, family: str, min_wall: int
) -> Fit:
    s = _sums(x, y, w, glo, ghi)
    S0, Sy, Syy = s["S0"], s["Sy"], s["Syy"]
    if family == "flat":
        m = Sy / S0
        return Fit("flat", float(m), 0.0, 0.0, math.nan, math.nan, float(Syy - m * Sy))
    tiny = 1e-12 * max(S0, 1e-300)
    if family in ("lower", "upper"):
        key = "L" if family == "lower" else "U"
        g = glo if family == "lower" else ghi
        m, a, rss, det = _one_wall(S0, Sy, Syy, S=s[f"S{key}"], SS=s[f"S{key}{key}"], Sy_=s[f"S{key}y"])
        ok = (s["nlo"] if family == "lower" else s["nhi"]) >= min_wall
        ok &= np.isfinite(rss) & (a >= 0) & (np.abs(det) > tiny * np.maximum(1.0, s[f"S{key}{key}"]))
        if not ok.any():
            return _NONE
        k = int(np.argmin(np.where(ok, rss, np.inf)))
        b = float(g[k])
        return Fit(family, float(m[k]), float(a[k]) if family == "lower" else 0.0,
                   float(a[k]) if family == "upper" else 0.0, b if family == "lower" else math.nan,
                   b if family == "upper" else math.nan, float(rss[k]))  # fmt: skip
    # both walls: 3 x 3 normal equations for every (b_lo, b_hi) pair
    G1, G2 = len(glo), len(ghi)
    A = np.empty((G1, G2, 3, 3))
    A[..., 0, 0] = S0
    A[..., 0, 1] = A[..., 1, 0] = s["SL"][:, None]
    A[..., 0, 2] = A[..., 2, 0] = s["SU"][None, :]
    A[..., 1, 1] = s["SLL"][:, None]
    A[..., 2, 2] = s["SUU"][None, :]
    A[..., 1, 2] = A[..., 2, 1] = s["SLU"]
    r = np.empty((G1, G2, 3))
    r[..., 0] = Sy
    r[..., 1] = s["SLy"][:, None]
    r[..., 2] = s["SUy"][None, :]
    ok = (glo[:, None] <= ghi[None, :]) & (s["nlo"][:, None] >= min_wall) & (s["nhi"][None, :] >= min_wall)
    det = np.linalg.det(A)
    scale = S0 * np.maximum(s["SLL"][:, None], 1.0) * np.maximum(s["SUU"][None, :], 1.0)
    ok &= np.abs(det) > 1e-12 * scale
    if not ok.any():
        return _NONE
    A[~ok] = np.eye(3)
    beta = np.linalg.solve(A, r[..., None])[..., 0]
    rss = Syy - np.einsum("ijk,ijk->ij", beta, r)
    ok &= (beta[..., 1] >= 0) & (beta[..., 2] >= 0) & np.isfinite(rss)
    if not ok.any():
        return _NONE
    i, j = np.unravel_index(int(np.argmin(np.where(ok, rss, np.inf))), rss.shape)
    return Fit("both", float(beta[i, j, 0]), float(beta[i, j, 1]), float(beta[i, j, 2]), float(glo[i]),
               float(ghi[j]), float(rss[i, j]))  # fmt: skip


def _around(grid: np.ndarray, b: float) -> np.ndarray:
    k = int(np.clip(np.searchsorted(grid, b), 0, len(grid) - 1))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    return np.linspace(lo, hi, _FINE)


def fit_family(x: np.ndarray, y: np.ndarray, w: np.ndarray, family: str, min_wall: int = 3) -> Fit:
    """The best fit of one family: a grid of :data:`_GRID` breakpoints over the range, refined once."""
    if family == "flat":
        return _best(x, y, w, x[:1], x[:1], family="flat", min_wall=min_wall)
    lo, hi = float(x.min()), float(x.max())
    if not hi > lo:
        return _NONE
    grid = np.linspace(lo, hi, _GRID)
    f = _best(x, y, w, grid, grid, family=family, min_wall=min_wall)
    if not np.isfinite(f.rss):
        return f
    glo = _around(grid, f.b_lo) if family in ("lower", "both") else grid
    ghi = _around(grid, f.b_hi) if family in ("upper", "both") else grid
    g = _best(x, y, w, glo, ghi, family=family, min_wall=min_wall)
    return g if g.rss <= f.rss else f


def _tau2(x: np.ndarray, y: np.ndarray, se2: np.ndarray, fit_fn: Callable[[np.ndarray], Fit]) -> Tuple[float, Fit]:
    """Between-window variance (Paule-Mandel) and the fit with those weights."""
    tau2 = 0.0
    fit = fit_fn(1.0 / (se2 + tau2))
    for _ in range(4):
        r = y - fit.predict(x)
        dof = max(len(x) - _NPAR[fit.family], 1)

        def q(t2: float) -> float:
            return float(np.sum(r * r / (se2 + t2))) - dof

        if q(0.0) <= 0:
            new = 0.0
        else:
            hi = max(float(np.mean(r * r)), 1e-30)
            while q(hi) > 0:
                hi *= 4.0
            lo_ = 0.0
            for _ in range(60):
                mid = 0.5 * (lo_ + hi)
                lo_, hi = (mid, hi) if q(mid) > 0 else (lo_, mid)
            new = 0.5 * (lo_ + hi)
        if abs(new - tau2) <= 1e-3 * max(new, 1e-30):
            tau2 = new
            break
        tau2 = new
        fit = fit_fn(1.0 / (se2 + tau2))
    return tau2, fit


@dataclass(frozen=True)
class Selection:
    """The chosen family, its fit, the weights and the tests behind the choice."""

    fit: Fit
    weights: np.ndarray
    tau2: float
    p_flat: float
    p_both: float
    fits: Dict[str, Any]


def _f_p(rss0: float, rss1: float, df: int, dof: int, overlap: float = 1.0) -> float:
    """p-value of the F-test of ``df`` more parameters, the richer model leaving ``dof`` residual degrees of freedom
    on the windows; the windows share their samples ``overlap`` times: the statistic is divided by it and referred to
    ``dof / overlap`` degrees of freedom (docs/method.md 7)."""
    k = max(float(overlap), 1.0)
    if not (np.isfinite(rss0) and np.isfinite(rss1)) or dof <= 0 or df <= 0:
        return 1.0
    if rss1 <= 0:
        return 0.0 if rss0 > rss1 else 1.0
    f = ((rss0 - rss1) / df) / (rss1 / dof) / k
    return float(f_sf(max(f, 0.0), df, max(dof / k, 1.0)))


def fit_bathtub(
    x: np.ndarray, y: np.ndarray, se: np.ndarray, *, min_wall: int = 3, alpha: float = 0.01, overlap: float = 1.0
) -> Selection:
    """Fits the four families with weights 1 / (se^2 + tau^2) and chooses one (docs/method.md 7).

    ``tau^2`` is found for the two-wall model and then used for every
    family, so their weighted residual sums compare on one scale. ``overlap``:
    how many windows share each sample (window / hop, at least 1), for the
    F-tests.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    se = np.asarray(se, dtype=float)
    pos = se[np.isfinite(se) & (se > 0)]
    floor = 0.1 * float(np.median(pos)) if pos.size else 1e-6
    se2 = np.maximum(np.where(np.isfinite(se), se, np.inf), floor) ** 2

    def richest(w: np.ndarray) -> Fit:
        best = fit_family(x, y, w, "both", min_wall)
        for fam in ("lower", "upper", "flat"):
            if np.isfinite(best.rss):
                break
            best = fit_family(x, y, w, fam, min_wall)
        return best

    tau2, _ = _tau2(x, y, se2, richest)
    w = 1.0 / (se2 + tau2)
    fits = {fam: fit_family(x, y, w, fam, min_wall) for fam in FAMILIES}
    n = len(x)
    one = min((fits["lower"], fits["upper"]), key=lambda f: f.rss)
    best_wall = fits["both"] if fits["both"].rss < one.rss else one
    p_flat = _f_p(fits["flat"].rss, best_wall.rss, _NPAR[best_wall.family] - 1, n - _NPAR[best_wall.family], overlap)
    p_both = _f_p(one.rss, fits["both"].rss, 2, n - 5, overlap) if np.isfinite(one.rss) else 0.0
    if p_flat >= alpha or not np.isfinite(best_wall.rss):
        chosen = fits["flat"]
    elif np.isfinite(fits["both"].rss) and p_both < alpha:
        chosen = fits["both"]
    else:
        chosen = one
    return Selection(chosen, w, tau2, p_flat, p_both, fits)


def block_length(n: int, overlap: float = 1.0) -> int:
    """The bootstrap's default block, in windows: ``overlap * max(3, ceil((n / overlap)^(1/3)))`` (rounded up), the
    same stretch of time at every hop (docs/method.md 7)."""
    k = max(float(overlap), 1.0)
    return int(math.ceil(k * max(3, math.ceil((n / k) ** (1.0 / 3.0))) - 1e-9))


def bootstrap_indices(n: int, n_boot: int, seed: int, block: Optional[int] = None, overlap: float = 1.0) -> np.ndarray:
    """Moving-block bootstrap resamples of ``n`` time-ordered windows, shape (n_boot, n) (docs/method.md 7).

    Blocks of ``block`` consecutive windows (default :func:`block_length`, ``max(3, ceil(n ** (1/3)))`` when the
    windows do not overlap) start uniformly at random; the concatenation is cut to ``n``.
    """
    L = block_length(n, overlap) if block is None else int(block)
    L = max(1, min(L, n))
    k = math.ceil(n / L)
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 13]))
    starts = rng.integers(0, n - L + 1, size=(n_boot, k))
    idx = (starts[:, :, None] + np.arange(L)[None, None, :]).reshape(n_boot, k * L)[:, :n]
    return idx
