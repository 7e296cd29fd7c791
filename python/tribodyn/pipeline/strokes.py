"""The windows of a reciprocating test: each stroke's central part, fy rectified (docs/method.md 6c)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

from ..io.base import RecordingProtocol
from ..kernels.uncertainty import Moments
from .budget import stroke_sums
from .plan import Findings, Plan
from .routes import PIPELINE_ROLES

__all__ = ["stroke_windows", "REVERSAL_SHARE"]


#: Roles read for a reciprocating test: the pipeline's and the direction's (velocity, position).
_STROKE_ROLES = (*PIPELINE_ROLES, "x")
#: A window straddles a direction change when the direction signal, times the stroke's direction, falls
#: below -REVERSAL_SHARE x its p95 magnitude in it (docs/method.md 6c).
REVERSAL_SHARE = 0.05


def stroke_windows(source: Any, rec: Optional[RecordingProtocol], plan: Plan, found: Findings, partition: bool = False
             ) -> Optional[Tuple[Dict[str, np.ndarray], List[Dict[str, Any]], Optional[Moments]]]:  # fmt: skip
    """The per-stroke table of a reciprocating test, its windows as acquisitions (docs/method.md 6c) and, when the
    plan has uncertainty inputs, the per-stroke COF's statistics for its budget (6i; else None).

    Reads the whole fy, fz (and fx, i, u, cof, x, v when present). The
    windows are the central ``plan.stroke_fraction`` of each stroke (cut into windows of
    the plan's length every hop when longer than one), fy rectified as
    ``tare_fy + d (fy - tare_fy)`` with the stroke's direction d; each
    carries its stroke index and whether it straddles a direction change.
    Only windows within ``plan.start`` .. ``plan.stop`` are kept; with
    ``partition`` (a range of :func:`tribodyn.analyze_many`), those starting
    in ``plan.start`` .. the next range's start (``stop - length + step``),
    so that consecutive ranges keep each window once. None for a one-pass
    stream of chunks. The statistics come from the forces read here
    (``pipeline/budget.py``'s :func:`~tribodyn.pipeline.budget.stroke_sums`):
    the file is not read again for the budget.
    """
    from ..kernels.strokes import ClassicalSpec, find_strokes, stroke_table

    fraction = plan.stroke_fraction

    if rec is not None:
        data = rec.read([r for r in _STROKE_ROLES if r in rec.roles])
        bounds = list(getattr(rec, "acquisitions", None) or [(0, rec.n_samples)])
    elif isinstance(source, Mapping):
        data = {k: np.asarray(v, dtype=float) for k, v in source.items() if k in _STROKE_ROLES}
        bounds = []
    elif isinstance(source, (list, tuple)):
        keys = [k for k in _STROKE_ROLES if all(k in a for a in source)]
        data = {k: np.concatenate([np.asarray(a[k], dtype=float) for a in source]) for k in keys}
        ends = np.cumsum([len(a["fz"]) for a in source])
        bounds = list(zip([0, *ends[:-1].tolist()], ends.tolist()))
    else:
        return None
    kind, sig = ("v", data["v"]) if "v" in data else (("x", data["x"]) if "x" in data else ("fy", data["fy"]))
    strokes = find_strokes(sig, boundaries=bounds, kind=kind)
    table = stroke_table(data["fy"], data["fz"], strokes, plan.fs, spec=found.classical, fraction=fraction,
                         cof=data.get("cof"), x=data.get("x") if _metres(rec) else None)  # fmt: skip
    # The windows: each stroke's central part, fy rectified.
    dsig = np.gradient(np.asarray(sig, dtype=float)) if kind == "x" else np.asarray(sig, dtype=float)
    fin = np.abs(dsig[np.isfinite(dsig)])
    limit = REVERSAL_SHARE * float(np.percentile(fin, 95)) if fin.size else 0.0
    tare = (found.classical or ClassicalSpec(0.0)).tare_fy
    n_all = len(data["fz"])
    stop = plan.stop if plan.stop is not None else n_all
    first_of_next = n_all if plan.stop is None else plan.stop - plan.length + plan.step
    roles = [r for r in PIPELINE_ROLES if r in data]
    pieces: List[Dict[str, Any]] = []
    for k, (a, b, d) in enumerate(strokes):
        m = b - a
        c0 = a + int(round(m * (1 - fraction) / 2))
        c1 = max(c0 + 1, a + int(round(m * (1 + fraction) / 2)))
        starts = [c0] if c1 - c0 <= plan.length else list(range(c0, c1 - plan.length + 1, plan.step))
        for s0 in starts:
            s1 = min(c1, s0 + plan.length)
            if s1 - s0 < 3 or s0 < plan.start or (s0 >= first_of_next if partition else s1 > stop):
                continue
            piece: Dict[str, Any] = {r: data[r][s0:s1] for r in roles}
            piece["fy"] = tare + d * (piece["fy"] - tare)
            piece["t0"] = s0 / plan.fs
            piece["stroke"] = k
            with np.errstate(invalid="ignore"):
                piece["reversal"] = bool(np.any(d * dsig[s0:s1] < -limit))
            pieces.append(piece)
    stats = None
    if plan.uncertainty is not None and not partition:  # docs/method.md 6i (analyze_many gives no budget)
        stats = stroke_sums(data["fy"], data["fz"], table, found.classical, fraction)
    return table, pieces, stats


def _metres(rec: Any) -> bool:
    """Whether a recording's position channel ``x`` is in metres: a unit from the file or a scale given by the
    caller (a mapping's arrays are SI by contract); without, no distance or energy comes from it (docs/method.md
    6c; the warning is the reader's, ``tribodyn.io.units.check_role_units``)."""
    if rec is None:
        return True
    info = next((c for c in getattr(rec, "channels", ()) if c.role == "x"), None)
    return info is None or info.unit == "m" or "by the caller" in (info.note or "")
