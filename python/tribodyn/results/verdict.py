"""Whether the dynamic method applies to a recording, why not, and its motion (docs/method.md 6d)."""

from __future__ import annotations

import math
from typing import Any, Dict, List, Mapping, Optional

import numpy as np

from ..kernels.quantiles import Z975

__all__ = ["DEAD_WEIGHT_REL", "MIN_GATED", "MIN_POOLED", "POOL_P", "pooled", "verdict"]

#: Dead weight: the within-window std of fz is below this fraction of |mean fz| (median over windows).
DEAD_WEIGHT_REL = 0.01


#: Fewest gated windows for the dynamic method's COF.
MIN_GATED = 3
#: Fewest windows a pooled headline takes: windows that fail the gate only as imprecise (docs/method.md 5).
MIN_POOLED = 10
#: The imprecise windows agree when the homogeneity test of their mu_r against their standard errors keeps
#: them at this level (docs/method.md 5).
POOL_P = 0.01


def _chi2_sf(q: float, df: int) -> float:
    """P(chi2_df > q) by the Wilson-Hilferty cube-root approximation (to about 1e-3 for df >= 9)."""
    if df <= 0 or not np.isfinite(q):
        return float("nan")
    a = 2.0 / (9.0 * df)
    z = ((max(q, 0.0) / df) ** (1.0 / 3.0) - (1.0 - a)) / np.sqrt(a)
    return float(0.5 * math.erfc(z / np.sqrt(2.0)))


def pooled(table: Mapping[str, np.ndarray]) -> Optional[Dict[str, Any]]:
    """The windows that fail the gate only as imprecise, when there are :data:`MIN_POOLED` of them: their mask,
    count, the homogeneity test's p (Cochran's Q of mu_r against mu_r_stderr, chi-square with n - 1 degrees
    of freedom), whether they agree (p >= :data:`POOL_P`) and the median relative half-width of their
    expected intervals (docs/method.md 5). None with fewer."""
    reasons = table.get("reasons")
    if reasons is None or "mu_r_stderr" not in table:
        return None
    mu = np.asarray(table["mu_r"], dtype=float)
    se = np.asarray(table["mu_r_stderr"], dtype=float)
    only = np.array([isinstance(r, str) and r.startswith("imprecise:") and ";" not in r for r in reasons], dtype=bool)
    with np.errstate(invalid="ignore"):
        keep = only & np.isfinite(mu) & np.isfinite(se) & (se > 0)
    n = int(keep.sum())
    if n < MIN_POOLED:
        return None
    w = 1.0 / se[keep] ** 2
    m = float(np.sum(w * mu[keep]) / np.sum(w))
    q = float(np.sum(w * (mu[keep] - m) ** 2))
    p = _chi2_sf(q, n - 1)
    centre = abs(float(np.median(mu[keep])))
    rel = Z975 * float(np.median(se[keep])) / centre if centre > 0 else float("inf")
    return {"mask": keep, "n": n, "p": p, "agree": bool(p >= POOL_P), "rel_half_width": rel}


def verdict(table: Mapping[str, np.ndarray], params: Mapping[str, Any], strokes: Optional[Mapping[str, np.ndarray]],
            gated: int) -> Dict[str, Any]:  # fmt: skip
    """Whether the dynamic method applies, the reasons and the motion (docs/method.md 6d).

    The COF it leads to is :attr:`tribodyn.Results.headline` (``headline.choose``; docs/method.md 6e);
    ``Results.summary()["verdict"]["cof"]`` is that headline.
    """
    reasons: List[str] = []
    motion = params.get("motion", "unidirectional")
    fz_mean = np.asarray(table.get("fz_mean", []), dtype=float)
    fz_std = np.asarray(table.get("fz_std", []), dtype=float)
    good = np.isfinite(fz_mean) & np.isfinite(fz_std) & (np.abs(fz_mean) > 0)
    static = bool(params.get("static_fz"))
    if good.any() and static:
        rel = float(np.median(fz_std[good] / np.abs(fz_mean[good])))
        if rel < DEAD_WEIGHT_REL:
            reasons.append(
                f"dead weight: fz varies by {100 * rel:.2f} % of its mean within a window (median), under "
                f"{100 * DEAD_WEIGHT_REL:g} %: no dynamic normal-force excitation to regress on"
            )
    noise = params.get("noise_z_std")
    if good.any() and noise is not None and np.isfinite(noise) and noise > 0:
        if float(np.median(fz_std[good])) < 2.0 * float(noise):
            reasons.append("no dynamic normal-force excitation above the noise on fz")
    rectified = bool(params.get("rectified"))
    if motion == "reciprocating" and not rectified:  # a one-pass stream: fy could not be rectified
        evidence = params.get("motion_evidence") or "fy's sign changes"
        detected = f" (detected from {evidence})" if params.get("motion_detected") else ""
        reasons.append("reciprocating motion: friction changes sign with the sliding direction" + detected)
    if params.get("friction_from") == "cof":  # docs/method.md 6e: fy is the COF x fz, not a measured force
        reasons.append("the friction force is derived from the instrument's COF column: no measured dynamic "
                       "friction to regress")  # fmt: skip
    agree, r = params.get("orientation_agreement"), params.get("orientation_r")
    if agree is not None and r is not None and np.isfinite(agree) and np.isfinite(r):
        if agree < 0.9 or abs(r) < 0.2:
            reasons.append(f"orientation uncertain (r = {r:+.2f}, {100 * agree:.0f} % of windows agree)")
    out: Dict[str, Any] = {"motion": motion}
    if gated < MIN_GATED:
        # docs/method.md 5: windows each too imprecise alone, but many and in agreement, are pooled
        # (only where no classical COF stands in: a static normal force gives one, docs/method.md 6e)
        pool = pooled(table) if not reasons and not params.get("rectified") and not static else None
        if pool is not None and pool["agree"]:
            out["pooled"] = {k: v for k, v in pool.items() if k != "mask"}
        else:
            why = f"too few gated windows ({gated} < {MIN_GATED})"
            if pool is not None:
                why += (f"; the {pool['n']} windows that fail only as imprecise disagree beyond their standard "
                        f"errors (homogeneity p = {pool['p']:.2g} < {POOL_P:g}): they are not pooled")  # fmt: skip
            reasons.append(why)
    return {"dynamic_method": not reasons, "reasons": reasons, **out}
