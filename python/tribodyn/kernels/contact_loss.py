"""Contact loss and sparking at high current density (docs/method.md 7).

When the brush loses contact (paper Sec. 4.2: beyond the optimum current
density the contact burns out and sparks), the forcemeter measures the
brush's ringing instead of friction. A window is flagged "contact loss"
when the current density is high, i.e. in the upper half of the recording's
range of J (all windows when J does not vary), and either

* the friction/normal correlation collapses: ``|C_yz(0)|`` below
  :data:`COLLAPSE` (0.7) times the median ``|C_yz(0)|`` of the recording, or
* the COF and its spread jump together: ``mu_r_stderr`` above
  :data:`SPREAD_JUMP` (4) times the recording's median standard error, in
  this window and in a neighbouring one (a step of the current moves the
  COF within one window, which widens one window's spread only), and
  ``mu_r`` more than :data:`COF_JUMP` (10 %) away from the median of the
  preceding :data:`HISTORY` (5) unflagged windows, at the current of those
  windows (within :data:`STEP` of the recording's largest ``|J|``).

A COF jump whose window's current differs from that of the windows it is
compared with is the COF following a step of the current (windows that
straddle the step, or lie within the COF's response after it: more of them
the shorter the hop; issue 35), not a loss of contact: that window gets the
reason "current step: ..." instead. Either reason is appended to the
window's gate reasons, so the window fails the gate and stays out of every
fit; only "contact loss" counts for the instability onset (docs/method.md 7).
"""

from __future__ import annotations

from typing import Mapping, Optional, Tuple

import numpy as np

__all__ = ["mark_contact_loss", "contact_loss_mask", "classify", "COLLAPSE", "SPREAD_JUMP", "COF_JUMP", "HISTORY",
           "STEP", "REASON", "STEP_REASON"]  # fmt: skip

COLLAPSE = 0.7
SPREAD_JUMP = 4.0
COF_JUMP = 0.10
HISTORY = 5
#: A current further than this (relative to the recording's largest |J|) from the median current of the windows a
#: COF jump is compared with has stepped: the jump is the COF following it (issue 35).
STEP = 0.02
#: The reason's key in ``Results["reasons"]`` (and ``summary()["gate_failures"]``).
REASON = "contact loss"
#: The key of a COF jump that follows a step of the current.
STEP_REASON = "current step"


def contact_loss_mask(stats: Mapping[str, np.ndarray], j: np.ndarray) -> np.ndarray:
    """Windows showing contact loss (criteria in the module docstring; docs/method.md 7).

    ``stats`` holds ``c_yz``, ``mu_r`` and ``mu_r_stderr`` per window; ``j``
    the current density (or the current: only its ordering matters). No
    finite ``j``: nothing is flagged.
    """
    return classify(stats, j)[0]


def classify(stats: Mapping[str, np.ndarray], j: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Per window (contact loss, COF jump after a current step): :func:`contact_loss_mask` and the jumps a step of
    the current explains (module docstring; docs/method.md 7). The two never overlap."""
    j = np.asarray(j, dtype=float)
    crit = criteria(stats, j)
    if crit is None:
        return np.zeros(j.size, dtype=bool), np.zeros(j.size, dtype=bool)
    high, collapse, spread, lasting = crit
    mu = np.asarray(stats["mu_r"], dtype=float)
    out: np.ndarray = high & collapse
    step = np.zeros(j.size, dtype=bool)
    level = STEP * float(np.nanmax(np.abs(j)))
    # The history of calm windows: neither collapsed nor spread, with a COF (a window that is neither is
    # never flagged, so the history does not depend on the flags); a lasting spread jumps when its COF
    # leaves the median of the last HISTORY calm windows before it by more than COF_JUMP. A jump at
    # another current than theirs follows a step of the current.
    calm = np.flatnonzero(~collapse & np.isfinite(mu) & ~spread)
    for k in np.flatnonzero(lasting & np.isfinite(mu) & high & ~collapse):
        before = calm[: np.searchsorted(calm, k)][-HISTORY:]
        if before.size:
            ref = float(np.median(mu[before]))
            jump = abs(mu[k] - ref) > COF_JUMP * abs(ref)
            ref_j = np.asarray(j[before])
            ref_j = ref_j[np.isfinite(ref_j)]
            moved = bool(ref_j.size) and abs(j[k] - float(np.median(ref_j))) > level
            out[k], step[k] = jump and not moved, jump and moved
    return out, step


def criteria(stats: Mapping[str, np.ndarray], j: np.ndarray
             ) -> Optional[Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:  # fmt: skip
    """Per window (high current, |C_yz| collapsed, spread jumped, spread lasting), or None without a finite
    ``j`` (:func:`contact_loss_mask`)."""
    j = np.asarray(j, dtype=float)
    fin = np.isfinite(j)
    if not fin.any():
        return None
    lo, hi = float(j[fin].min()), float(j[fin].max())
    with np.errstate(invalid="ignore"):
        high = fin & (j >= 0.5 * (lo + hi)) & (np.abs(j) > 0)
    c = np.abs(np.asarray(stats["c_yz"], dtype=float))
    se = np.asarray(stats["mu_r_stderr"], dtype=float)
    c_med = float(np.nanmedian(c)) if np.isfinite(c).any() else np.nan
    se_med = float(np.nanmedian(se)) if np.isfinite(se).any() else np.nan
    with np.errstate(invalid="ignore"):
        collapse = np.isfinite(c) & (c < COLLAPSE * c_med)
        spread = np.isfinite(se) & (se > SPREAD_JUMP * se_med)
    # A spread that lasts: a step of the current moves the COF within one
    # window (a wide spread once) without any loss of contact.
    lasting = spread & (np.r_[spread[1:], False] | np.r_[False, spread[:-1]])
    return high, collapse, spread, lasting


def mark_contact_loss(reasons: np.ndarray, stats: Mapping[str, np.ndarray], j: np.ndarray) -> np.ndarray:
    """``reasons`` (the gate's, one str per window) with ``"contact loss: ..."`` appended where
    :func:`contact_loss_mask` flags a window and ``"current step: ..."`` where a step of the current explains a COF
    jump (:func:`classify`; docs/method.md 7). Returns a new object array."""
    out = np.asarray(reasons, dtype=object).copy()
    lost, step = classify(stats, j)
    c = np.abs(np.asarray(stats["c_yz"], dtype=float))
    se = np.asarray(stats["mu_r_stderr"], dtype=float)
    for k in np.flatnonzero(lost | step):
        if lost[k]:
            why = f"{REASON}: |C_yz(0)| = {c[k]:.3f} at a current in the upper half of the range"
        else:
            why = (f"{STEP_REASON}: the COF moved with the current (its standard error {se[k]:.2g}, |C_yz(0)| = "
                   f"{c[k]:.3f}: in contact)")  # fmt: skip
        out[k] = f"{out[k]}; {why}" if out[k] else why
    return out
