"""The headline's statistics for its uncertainty budget (docs/method.md 6i), without reading the file again.

:func:`statistics_of` gives the sufficient statistics
(:class:`~tribodyn.kernels.uncertainty.Moments`) of a Results' headline:
the classical COF's from the sums the main pass took
(``ClassicalTotals.budget``, :class:`tribodyn.pipeline.headline.BlockSums`),
the per-stroke COF's from the forces the strokes' reading already holds
(:func:`stroke_sums`, called by ``pipeline/strokes.py``), the dynamic COF's
from its table. Only where the main pass could not take them (a range not
seen whole, an in-memory source) are they read again
(:func:`classical_moments`, :func:`stroke_moments`). :func:`with_budget`
sets them as ``Results.budget_stats`` and gives the headline its budget
(``results/budget.py``'s ``attach``).
"""

from __future__ import annotations

import dataclasses
from typing import Any, Mapping, Optional, Tuple

import numpy as np

from ..kernels.strokes import ClassicalSpec
from ..kernels.uncertainty import NO_BUDGET, SHAPE, Moments, in_contact, ratio_sums
from ..results import Results
from ..results.budget import attach, dynamic_moments
from .headline import _blocks

__all__ = ["classical_moments", "from_sums", "statistics_of", "stroke_moments", "stroke_sums", "with_budget"]


def classical_moments(source: Any, rec: Any, spec: Any, start: int = 0, stop: Optional[int] = None
                      ) -> Optional[Moments]:  # fmt: skip
    """The classical COF's statistics over the samples in contact of ``start``..``stop`` (one more reading)."""
    got = _blocks(source, rec, int(start), stop)
    if got is None:
        return None
    total = np.zeros(SHAPE)
    for _, piece in got[1]:
        y, z = in_contact(piece["fy"], piece["fz"], spec)
        total += ratio_sums(y, z)
    return from_sums(total)


def from_sums(total: np.ndarray) -> Optional[Moments]:
    """The classical COF's statistics from the unweighted sums over its samples in contact (each weighs 1 / n)."""
    n = int(round(total[:, 0, 0].sum()))
    return Moments("classical", total / n, n) if n else None


def _read_forces(source: Any, rec: Any) -> Optional[Tuple[np.ndarray, np.ndarray]]:
    if rec is not None:
        d = rec.read(["fy", "fz"])
        return np.asarray(d["fy"], dtype=float), np.asarray(d["fz"], dtype=float)
    if isinstance(source, Mapping):
        return np.asarray(source["fy"], dtype=float), np.asarray(source["fz"], dtype=float)
    if isinstance(source, (list, tuple)) and source and all(isinstance(a, Mapping) for a in source):
        return (np.concatenate([np.asarray(a["fy"], dtype=float) for a in source]),
                np.concatenate([np.asarray(a["fz"], dtype=float) for a in source]))  # fmt: skip
    return None


def stroke_moments(source: Any, rec: Any, strokes: Mapping[str, np.ndarray], spec: Any, fraction: float
                   ) -> Optional[Moments]:  # fmt: skip
    """The per-stroke COF's statistics: each stroke's central samples weighted as the mean over cycles weighs them.

    The headline is the mean over the cycles holding both directions of
    (forward mean + backward mean) / 2, each direction's mean over its
    strokes in the cycle (``kernels.strokes.cycle_table``): a stroke's samples
    weigh 1 / (2 C m n) (C cycles, m strokes of its direction in its
    cycle, n its samples).
    """
    forces = _read_forces(source, rec)
    return None if forces is None else stroke_sums(forces[0], forces[1], strokes, spec, fraction)


def stroke_sums(fy: np.ndarray, fz: np.ndarray, strokes: Mapping[str, np.ndarray], spec: Any, fraction: float
                ) -> Optional[Moments]:  # fmt: skip
    """:func:`stroke_moments` of the whole recording's forces ``fy``, ``fz`` already read (the strokes' reading)."""
    spec = spec or ClassicalSpec(0.0)
    cyc = np.asarray(strokes["cycle"], dtype=np.int64)
    d = np.asarray(strokes["direction"], dtype=np.int64)
    mu = np.asarray(strokes["mu"], dtype=float)
    ok = np.isfinite(mu)
    valid = [c for c in np.unique(cyc) if np.any(ok & (cyc == c) & (d == 1)) and np.any(ok & (cyc == c) & (d == -1))]
    if not valid:
        return None
    total = np.zeros(SHAPE)
    n_used = 0
    for c in valid:
        for sign in (1, -1):
            ks = np.flatnonzero(ok & (cyc == c) & (d == sign))
            for k in ks.tolist():
                a, b = int(strokes["start"][k]), int(strokes["stop"][k])
                m = b - a
                c0 = a + int(round(m * (1 - fraction) / 2))
                c1 = max(c0 + 1, a + int(round(m * (1 + fraction) / 2)))
                y, z = in_contact(fy[c0:c1], fz[c0:c1], spec)
                if not y.size:
                    continue
                n_used += y.size
                total += ratio_sums(y, z) / (2.0 * len(valid) * ks.size * y.size)
    return Moments("per-stroke", total, n_used)


def statistics_of(res: Results, source: Any, rec: Any, spec: Any, span: Tuple[int, Optional[int]], *,
                  strokes: Optional[Moments] = None) -> Optional[Moments]:  # fmt: skip
    """The statistics of ``res``'s headline: the main pass's (classical: ``res.classical.budget``; per-stroke:
    ``strokes``, taken by the strokes' reading) or its table's (dynamic); read again from ``source`` only when
    those are missing."""
    head = res.headline
    if head.method == "dynamic":
        return dynamic_moments(res)
    if head.method == "per-stroke" and res.strokes is not None:
        if strokes is not None:
            return strokes
        return stroke_moments(source, rec, res.strokes, spec, float(res.params.get("stroke_fraction", 0.5)))
    if head.method == "classical" and spec is not None and res.classical is not None:
        if res.classical.budget is not None:
            return from_sums(res.classical.budget)
        return classical_moments(source, rec, spec, span[0], span[1])
    return None


def with_budget(res: Results, stats: Optional[Moments]) -> Results:
    """``res`` holding ``stats``, its headline with the budget (the dynamic bootstrap is not run again)."""
    out = res.replace(keep=("verdict", "mu_r_ci", "column_ci"), budget_stats=stats)  # what the statistics leave
    if "headline" in res.__dict__:  # computed: its budget attached (the bootstrap not run again)
        head = res.headline
        kept = tuple(r for r in head.reasons if not r.startswith(NO_BUDGET))
        out = out.replace(
            keep=("verdict", "mu_r_ci", "column_ci"),
            cached={"headline": attach(out, dataclasses.replace(head, uncertainty=None, reasons=kept))},
        )
    return out
