"""The headline's uncertainty budget on a Results' fields (docs/method.md 6i).

:func:`attach` gives a headline its :class:`~tribodyn.kernels.uncertainty.Uncertainty`
from the inputs in ``Results.params["uncertainty"]`` and the statistics in
``Results.budget_stats`` (set by ``pipeline/budget.py``; the dynamic COF's are read
from the table, :func:`dynamic_moments`): a pure function of the fields, called by
``results/headline.py``'s ``choose``.
"""

from __future__ import annotations

import dataclasses
from typing import Any, List, Optional, Tuple

import numpy as np

from ..kernels.stats import batch_mean
from ..kernels.strokes import cycle_means
from ..kernels.uncertainty import NO_BUDGET, Moments, Uncertainty, parse_inputs, propagate, slope_moments

__all__ = ["attach", "dynamic_moments", "stat_dof"]

Results = Any  # a tribodyn.Results (this module sits below it)
Headline = Any  # a tribodyn.Headline (results/headline.py imports this module)


def dynamic_moments(res: Results) -> Optional[Moments]:
    """The dynamic COF's statistics: the median slope of each direction (u = 0: a static offset does not enter).

    The slope in the channels' own frame is s d m (s the orientation, d
    the stroke's direction for direction-rectified strokes, m the median
    of mu_r); the median of a monotone function of the slopes is that
    function of their median, so the headline through another instrument
    is the corrected slope of each median.
    """
    ok = np.asarray(res.table["ok"], dtype=bool)
    mu = np.asarray(res.table["mu_r"], dtype=float)
    keep = ok & np.isfinite(mu)
    if not keep.any():
        return None
    s = int(res.params.get("orientation_used", res.orientation) or 1)
    slopes: List[Tuple[float, float]] = []
    st = res.strokes
    if res.params.get("rectified") and st is not None and len(st.get("direction", [])):
        d = np.asarray(st["direction"])[np.asarray(res.table["acquisition"], dtype=np.int64)[keep]]
        parts = [(sign, mu[keep][d == sign]) for sign in (1, -1)]
        parts = [(sign, v) for sign, v in parts if v.size]
        if len(parts) == 2:
            slopes = [(0.5, s * sign * float(np.median(v))) for sign, v in parts]
    if not slopes:
        slopes = [(1.0, s * float(np.median(mu[keep])))]
    return slope_moments(slopes, int(keep.sum()))


def stat_dof(res: Results, head: Headline) -> float:
    """Degrees of freedom of the headline's interval: batches - 1 (classical, per-stroke); the bootstrap's: inf."""
    if head.method == "classical" and res.classical is not None:
        b = res.classical.mean()[3]
        return float(b - 1) if b >= 3 else float("inf")
    if head.method == "per-stroke" and res.strokes is not None:
        b = batch_mean(cycle_means(res.strokes))[3]
        return float(b - 1) if b >= 3 else float("inf")
    return float("inf")


def attach(res: Results, head: Headline) -> Headline:
    """``head`` with its :class:`Uncertainty` when ``res`` holds the inputs and the statistics; else unchanged."""
    inputs = parse_inputs(res.params.get("uncertainty"))
    mom: Optional[Moments] = getattr(res, "budget_stats", None)
    if inputs is None or not head.ok:
        return head
    if mom is None and head.method == "dynamic":
        mom = dynamic_moments(res)
    if mom is None or mom.method != head.method:
        why = f"{NO_BUDGET}the {head.method} COF's statistics were not read (a one-pass stream, or ranges combined)"
        return dataclasses.replace(head, reasons=head.reasons + (why,))
    if head.value < 0:  # a flipped orientation (Results.with_orientation): the budget of |COF|, mirrored
        pos = dataclasses.replace(head, value=-head.value, low=-head.high, high=-head.low)
        unc = _mirrored(propagate(pos, mom, inputs, stat_dof=stat_dof(res, pos)))
    else:
        unc = propagate(head, mom, inputs, stat_dof=stat_dof(res, head))
    return dataclasses.replace(head, uncertainty=unc)


def _mirrored(unc: Uncertainty) -> Uncertainty:
    """``unc`` of -COF: the value, interval, correction and sensitivities change sign (the spreads do not)."""
    rows = tuple(dataclasses.replace(r, sensitivity=-r.sensitivity) for r in unc.budget)
    return dataclasses.replace(unc, value=-unc.value, low=-unc.high, high=-unc.low, budget=rows,
                               correction=-unc.correction)  # fmt: skip
