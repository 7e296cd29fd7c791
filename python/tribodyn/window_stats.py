"""Per-window statistics and the quality gate, shared by ``identify`` and
``analyze`` (METHOD.md sections 3-5).

The Rust kernel ``_core.windows_stats`` computes, for every window, the
regression of fy on fz, the three Pearson coefficients, the deadband, the fz
bins and mu_a / mu_b in one task per window (GIL released, windows in
parallel). It runs with orientation +1; the recording's orientation s is
applied afterwards by :func:`orient`, which is exact (a sign flip), so the
orientation can be fixed once per recording after all windows are seen.
"""

from __future__ import annotations

from typing import Dict, Optional

import numpy as np

from . import _core
from .deadband import Deadband

__all__ = ["compute", "orient", "gate_reasons", "COF_KEYS"]

#: Quantities that change sign with the orientation s.
COF_KEYS = ("slope", "intercept", "mu_a", "mu_b", "bin_cof")


def compute(
    fx: Optional[np.ndarray],
    fy: np.ndarray,
    fz: np.ndarray,
    aux: Optional[np.ndarray],
    starts: np.ndarray,
    length: int,
    deadband: Deadband,
    n_bins: int,
) -> Dict[str, np.ndarray]:
    """Kernel statistics of windows ``[s, s + length)`` for ``s`` in ``starts`` (orientation +1)."""
    return _core.windows_stats(
        fx, fy, fz, aux, np.ascontiguousarray(starts, dtype=np.int64), int(length), 1.0, deadband.kind, float(deadband.value), int(n_bins)
    )


def orient(stats: Dict[str, np.ndarray], s: int) -> Dict[str, np.ndarray]:
    """Applies orientation ``s`` (METHOD.md 0): mu = s * slope, and so on.

    Returns a new dict with ``mu_r``, ``mu_r_stderr``, ``f_y0`` and
    ``force_dependence`` added. F_y0 is the intercept in the measured fy
    frame (not flipped), as in the paper's Eq. (7).
    """
    out = dict(stats)
    for key in ("mu_a", "mu_b", "bin_cof"):
        out[key] = s * stats[key]
    out["mu_r"] = s * stats["slope"]
    out["mu_r_stderr"] = stats["slope_stderr"]
    out["f_y0"] = stats["intercept"]
    with np.errstate(invalid="ignore", divide="ignore"):
        out["force_dependence"] = (out["mu_b"] - out["mu_a"]) / out["mu_r"]
    return out


def gate_reasons(stats: Dict[str, np.ndarray], gate: float, skew: Optional[np.ndarray] = None) -> np.ndarray:
    """Why each window fails the quality gate (METHOD.md 5); '' when it passes.

    Reasons: the fit is degenerate (fewer than 3 samples, constant fz);
    |C_yz(0)| below ``gate``; the deadband excludes every sample; a channel
    skew (max |C_yz(j)| away from lag 0).
    """
    n = len(stats["c_yz"])
    reasons = np.empty(n, dtype=object)
    for k in range(n):
        why = []
        c = stats["c_yz"][k]
        if not np.isfinite(stats["slope"][k]):
            why.append("degenerate: fewer than 3 samples or constant fz")
        elif not (abs(c) >= gate):
            why.append(f"low correlation: |C_yz(0)| = {abs(c):.3f} < {gate:g}")
        if stats["n_a"][k] + stats["n_b"][k] == 0:
            why.append(f"deadband: {stats['deadband'][k]:.4g} N excludes every sample")
        if skew is not None and np.isfinite(skew[k]) and skew[k] != 0:
            why.append(f"skew: max |C_yz| at lag {int(skew[k])}, not 0")
        reasons[k] = "; ".join(why)
    return reasons
