"""Whether the dynamic method applies to a recording, why not, and its motion (docs/method.md 6d)."""

from __future__ import annotations

from typing import Any, Dict, List, Mapping, Optional

import numpy as np

__all__ = ["DEAD_WEIGHT_REL", "MIN_GATED", "verdict"]

#: Dead weight: the within-window std of fz is below this fraction of |mean fz| (median over windows).
DEAD_WEIGHT_REL = 0.01


#: Fewest gated windows for the dynamic method's COF.
MIN_GATED = 3


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
    if gated < MIN_GATED:
        reasons.append(f"too few gated windows ({gated} < {MIN_GATED})")
    agree, r = params.get("orientation_agreement"), params.get("orientation_r")
    if agree is not None and r is not None and np.isfinite(agree) and np.isfinite(r):
        if agree < 0.9 or abs(r) < 0.2:
            reasons.append(f"orientation uncertain (r = {r:+.2f}, {100 * agree:.0f} % of windows agree)")
    dynamic = not reasons
    return {"dynamic_method": dynamic, "reasons": reasons, "motion": motion}
