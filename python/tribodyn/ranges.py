"""Operating ranges: COF against temperature or current density
(docs/method.md section 7, paper Secs. 4.1-4.2).

From the quality-gated windows, the COF (mu_r) is binned on the covariate
(median per bin). The optimum is the contiguous run of bins around the
lowest median whose medians stay within ``tol`` (relative) of that minimum.
The instability onset is the first covariate value above the optimum where
the binned COF reaches ``(1 + rise)`` times the minimum (linear
interpolation between bin centres): the paper's steep rise before sparking
and loss of contact. For temperature, heating and cooling branches (sign of
dT/dt) are also binned apart to show the hysteresis of Fig. 11.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Literal, Optional, Tuple

import numpy as np

from .results import Results

__all__ = ["RangeCurve", "OperatingRange", "operating_range"]

By = Literal["temperature", "current_density"]
_COLUMN = {"temperature": "T", "current_density": "J"}
_DEFAULT_WIDTH = {"temperature": 5.0, "current_density": 0.5}
_UNIT = {"temperature": "degC", "current_density": "A/mm^2"}


@dataclass(frozen=True)
class RangeCurve:
    """Binned COF against a covariate, for one branch.

    Attributes
    ----------
    edges : ndarray (k + 1,)
        Covariate bin edges.
    centres : ndarray (k,)
    median : ndarray (k,)
        Median mu_r of the gated windows in each bin (NaN if fewer than
        ``min_count``).
    count : ndarray of int (k,)
    mu_min : float
        Lowest binned COF (NaN if no bin is populated).
    optimum : (float, float) or None
        Covariate interval (bin edges) of the optimum.
    onset : float or None
        Instability onset above the optimum, or None if the COF never
        reaches (1 + rise) mu_min there.
    """

    edges: np.ndarray
    centres: np.ndarray
    median: np.ndarray
    count: np.ndarray
    mu_min: float
    optimum: Optional[Tuple[float, float]]
    onset: Optional[float]


@dataclass(frozen=True)
class OperatingRange:
    """Result of :func:`operating_range`.

    ``curves`` holds "all", and for temperature also "heating" and
    "cooling". ``optimum``, ``mu_min`` and ``onset`` repeat the "all" curve's.
    """

    by: str
    unit: str
    bin_width: float
    tol: float
    rise: float
    curves: Dict[str, RangeCurve]
    optimum: Optional[Tuple[float, float]]
    mu_min: float
    onset: Optional[float]


def _curve(cov: np.ndarray, mu: np.ndarray, edges: np.ndarray, tol: float, rise: float, min_count: int) -> RangeCurve:
    k = len(edges) - 1
    idx = np.clip(np.searchsorted(edges, cov, side="right") - 1, 0, k - 1)
    count = np.bincount(idx, minlength=k)
    med = np.full(k, np.nan)
    for b in range(k):
        if count[b] >= min_count:
            med[b] = np.median(mu[idx == b])
    centres = 0.5 * (edges[:-1] + edges[1:])
    if not np.isfinite(med).any():
        return RangeCurve(edges, centres, med, count, float("nan"), None, None)
    b0 = int(np.nanargmin(med))
    mu_min = float(med[b0])
    within = np.isfinite(med) & (med <= mu_min * (1 + tol) if mu_min >= 0 else med <= mu_min * (1 - tol))
    lo = hi = b0
    while lo > 0 and within[lo - 1]:
        lo -= 1
    while hi < k - 1 and within[hi + 1]:
        hi += 1
    onset = None
    level = mu_min * (1 + rise)
    prev = hi
    for b in range(hi + 1, k):
        if not np.isfinite(med[b]):
            continue
        if med[b] >= level:
            # Interpolate between the last populated centre and this one.
            c0, c1, m0, m1 = centres[prev], centres[b], med[prev], med[b]
            onset = float(c1 if m1 == m0 else c0 + (level - m0) * (c1 - c0) / (m1 - m0))
            onset = max(onset, float(edges[hi + 1]))
            break
        prev = b
    return RangeCurve(edges, centres, med, count, mu_min, (float(edges[lo]), float(edges[hi + 1])), onset)


#: The most covariate bins :func:`operating_range` makes (a bin width far
#: below the covariate's resolution is a mistake, not a finer answer).
MAX_BINS = 10_000


def operating_range(
    results: Results,
    by: By = "temperature",
    *,
    bin_width: Optional[float] = None,
    tol: float = 0.15,
    rise: float = 0.5,
    min_count: int = 1,
) -> OperatingRange:
    """Optimum covariate range of the COF (docs/method.md 7).

    Parameters
    ----------
    results : Results
        From :func:`tribodyn.analyze`, with ``T`` (a temperature log) or
        ``J`` (a current and ``area_mm2``) filled in.
    by : {"temperature", "current_density"}
    bin_width : float, optional
        Covariate bin width (default 5 degC or 0.5 A/mm^2). Bins are aligned
        centred on multiples of the width.
    tol : float
        Relative tolerance above the minimum COF that still counts as optimum
        (default 0.15).
    rise : float
        Relative COF rise over the minimum that marks the instability onset
        (default 0.5, i.e. 1.5 x the minimum).
    min_count : int
        Gated windows a bin needs to count (default 1).

    Raises
    ------
    ValueError
        Unknown ``by``, bad widths/tolerances, or no gated window with a
        finite covariate.
    """
    if not isinstance(results, Results):
        raise TypeError(f"results must be the Results of tribodyn.analyze, got {type(results).__name__}")
    if by not in _COLUMN:
        raise ValueError(f"by must be 'temperature' or 'current_density', got {by!r}")
    width = _DEFAULT_WIDTH[by] if bin_width is None else float(bin_width)
    if not (np.isfinite(width) and width > 0):
        raise ValueError(f"bin_width must be > 0, got {bin_width!r}")
    if not (tol >= 0 and rise > 0 and min_count >= 1):
        raise ValueError("tol must be >= 0, rise > 0 and min_count >= 1")
    cov = np.asarray(results[_COLUMN[by]], dtype=float)
    mu = np.asarray(results["mu_r"], dtype=float)
    keep = results.gated() & np.isfinite(cov) & np.isfinite(mu)
    if not keep.any():
        what = "a temperature log" if by == "temperature" else "a current and area_mm2"
        raise ValueError(f"no quality-gated window has a {by.replace('_', ' ')} (did analyze get {what}?)")
    # Bin centres on multiples of the width, so set points such as J = 4.5
    # A/mm^2 fall mid-bin, never on an edge.
    k_lo = int(np.floor(cov[keep].min() / width + 0.5))
    k_hi = int(np.floor(cov[keep].max() / width + 0.5))
    if k_hi - k_lo + 1 > MAX_BINS:
        raise ValueError(
            f"bin_width = {width:g} cuts the {by.replace('_', ' ')} range "
            f"[{cov[keep].min():g}, {cov[keep].max():g}] into {k_hi - k_lo + 1} bins; at most {MAX_BINS} are allowed"
        )
    edges = (np.arange(k_lo, k_hi + 2) - 0.5) * width
    curves = {"all": _curve(cov[keep], mu[keep], edges, tol, rise, min_count)}
    if by == "temperature":
        br = np.asarray(results["branch"])[keep]
        for name, sign in (("heating", 1), ("cooling", -1)):
            sel = br == sign
            if sel.any():
                curves[name] = _curve(cov[keep][sel], mu[keep][sel], edges, tol, rise, min_count)
    a = curves["all"]
    return OperatingRange(
        by=by,
        unit=_UNIT[by],
        bin_width=width,
        tol=tol,
        rise=rise,
        curves=curves,
        optimum=a.optimum,
        mu_min=a.mu_min,
        onset=a.onset,
    )
