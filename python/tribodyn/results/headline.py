"""The one COF a user reads first: :class:`Headline`, chosen from a Results by its verdict
(docs/method.md 6e).

* :class:`ClassicalTotals`: the classical COF's sums per block of the whole recording (read in one pass
  by :func:`tribodyn.pipeline.headline.classical_totals`, docs/method.md 6a).
* :func:`choose`: the headline of a :class:`tribodyn.Results`: the dynamic COF when the dynamic method
  applies, else the classical COF of the whole recording (unidirectional) or the per-stroke COF
  (reciprocating).
* :func:`instrument_check`: the instrument's own COF over the headline's samples.

Every function here reads a Results' fields (duck-typed: ``table``, ``params``, ``strokes``,
``classical``, ``mu_r_ci``, ``gated``) and imports only the kernels below it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .._deprecation import deprecated
from ..kernels.stats import BATCHES, batch_mean, bootstrap_ci, noise_resample, ratio_mean
from ..kernels.strokes import cycle_means
from ..kernels.uncertainty import Uncertainty
from .budget import attach

__all__ = ["HEADLINE_METHODS", "ClassicalTotals", "Headline", "choose", "instrument_check"]

Results = Any  # a tribodyn.Results (this module sits below it: results/__init__.py imports it)


#: The methods a headline can come from (docs/method.md 6e).
HEADLINE_METHODS = ("dynamic", "classical", "per-stroke", "instrument")


#: An instrument COF that differs from the classical COF by more than this (relative) is explained in a warning.
INSTRUMENT_TOLERANCE = 0.005
#: fy's unloaded level (its tare: a turning disc's drag, an offset) that changes the classical COF by more than
#: this (relative) is said among the headline's reasons, with the COF without it (issue 34 point 5).
DRAG_SHARE = 0.10


@dataclass(frozen=True)
class Headline:
    """The COF of a recording that a user reads first (docs/method.md 6e).

    Attributes
    ----------
    method : str
        "dynamic" (regression of the dynamic forces, docs/method.md 3-5),
        "classical" (mean |fy|/|fz| over every sample in contact, 6a),
        "per-stroke" (mean over cycles of the forward/backward stroke means, 6c) or
        "instrument" (a COF-only export: the mean |COF| of its COF column, 6e).
    value : float
        The COF; NaN when the method that applies yields none (``reasons`` says why).
    low, high : float
        Its 95 % interval (``interval`` says how it is computed).
    statistic : str
        "median" (dynamic: the paper's median over gated windows) or "mean"
        (classical and per-stroke, as instruments report).
    n : int
        Windows (dynamic), samples (classical) or cycles (per-stroke) behind the value.
    fraction_used : float
        Share of the recording's samples that the value uses.
    reasons : tuple of str
        Why the dynamic method does not apply, and why there is no value (with what to pass).
    estimate : str
        How the value is computed, in words.
    interval : str
        How the interval is computed, in words.
    bound : str
        "lower" when the value is a lower bound of the COF (least squares
        attenuated by noise on fz that no valid instrument could measure;
        the interval then reaches up to the reverse regression, docs/method.md 3d), else "".
    uncertainty : Uncertainty or None
        With ``analyze(uncertainty=...)``, the combined uncertainty of the
        instrument and the statistics and its budget (docs/method.md 6i);
        None: ``low``, ``high`` are the statistical interval only.
    """

    method: str
    value: float
    low: float
    high: float
    statistic: str
    n: int
    fraction_used: float
    reasons: Tuple[str, ...] = ()
    estimate: str = ""
    interval: str = ""
    bound: str = ""
    uncertainty: Optional["Uncertainty"] = None

    @property
    def ok(self) -> bool:
        """True when there is a value."""
        return math.isfinite(self.value)

    @property
    def text(self) -> str:
        """The headline in one line, e.g. 'COF 0.1492 (95 % interval 0.1481 to 0.1503): classical, mean ...'."""
        if not self.ok:
            why = "; ".join(self.reasons) if self.reasons else "nothing to compute it from"
            return f"No {self.method} COF: {why}."
        lb = f" ({self.bound} bound)" if self.bound else ""
        if self.uncertainty is not None:  # docs/method.md 6i
            return f"COF {self.uncertainty.text}{lb}: {self.method}, {self.estimate}."
        iv = ""
        if math.isfinite(self.low):
            iv = f" (95 % interval {self.low:#.4g} to {self.high:#.4g}, statistical only)"
        return f"COF {self.value:#.4g}{lb}{iv}: {self.method}, {self.estimate}."

    @property
    def short(self) -> str:
        """'classical COF 0.1492 (95 % 0.1427 to 0.1557)' or 'no classical COF' (for ``repr``)."""
        if not self.ok:
            return f"no {self.method} COF"
        if self.uncertainty is not None:
            return f"{self.method} COF {self.uncertainty.text}"
        iv = f" (95 % {self.low:#.4g} to {self.high:#.4g})" if math.isfinite(self.low) else ""
        return f"{self.method} COF {self.value:#.4g}{iv}"

    def __str__(self) -> str:
        return self.text

    def __call__(self) -> str:
        """``res.headline()`` was a method returning the text: it still does, with a DeprecationWarning."""
        deprecated("Results.headline is a Headline object now: use res.headline.text (or str(res.headline))")
        return self.text

    def to_dict(self) -> Dict[str, Any]:
        """JSON-ready: NaN as None, ``text`` added."""

        def num(v: float) -> Optional[float]:
            return float(v) if math.isfinite(v) else None

        return {
            "method": self.method,
            "value": num(self.value),
            "low": num(self.low),
            "high": num(self.high),
            "statistic": self.statistic,
            "n": int(self.n),
            "fraction_used": num(self.fraction_used),
            "reasons": list(self.reasons),
            "estimate": self.estimate,
            "interval": self.interval,
            "bound": self.bound,
            "uncertainty": None if self.uncertainty is None else self.uncertainty.to_dict(),
            "text": self.text,
        }


@dataclass(frozen=True)
class ClassicalTotals:
    """The classical COF's sums per block of the recording (docs/method.md 6a, 6e).

    Block k holds samples ``k * block`` .. ``(k + 1) * block`` of the
    recording (the grid does not depend on the analysed range, so that the
    ranges of :func:`tribodyn.analyze_many` add up). A sample is in contact
    when fy and fz are finite and ``|fz - tare_fz| >= min_fn`` (and > 0).
    """

    block: int
    ids: np.ndarray
    count: np.ndarray
    ratio_sum: np.ndarray
    signed_sum: np.ndarray
    inst_count: np.ndarray
    inst_sum: np.ndarray
    samples: int
    #: The uncertainty budget's sums of r^j u^k over the samples in contact (``kernels.uncertainty.SHAPE``,
    #: unweighted) when the main pass took them for a plan with uncertainty inputs (docs/method.md 6i), else None.
    budget: Optional[np.ndarray] = None
    #: Per block, the sum of |fy| / |fz - tare_fz| with fy's unloaded level kept (its tare not subtracted: a
    #: turning disc's drag, issue 34 point 5), or None.
    raw_sum: Optional[np.ndarray] = None

    def without_fy_tare(self) -> float:
        """The classical COF with fy's tare not subtracted (NaN without the sums or a sample in contact)."""
        n = float(self.count.sum())
        return float(self.raw_sum.sum()) / n if self.raw_sum is not None and n > 0 else float("nan")

    @property
    def contact(self) -> int:
        """Samples in contact."""
        return int(self.count.sum())

    def mean(self) -> Tuple[float, float, float, int]:
        """:func:`ratio_mean` of the blocks."""
        return ratio_mean(self.ratio_sum, self.count)

    def instrument_mean(self) -> float:
        n = float(self.inst_count.sum())
        return float(self.inst_sum.sum()) / n if n > 0 else float("nan")

    def signed_mean(self) -> float:
        n = float(self.count.sum())
        return float(self.signed_sum.sum()) / n if n > 0 else float("nan")

    @staticmethod
    def merge(parts: Sequence["ClassicalTotals"]) -> "ClassicalTotals":
        """The totals of consecutive ranges of one recording (blocks cut by a range edge are added)."""
        ids = np.unique(np.concatenate([p.ids for p in parts]))
        keys = ["count", "ratio_sum", "signed_sum", "inst_count", "inst_sum"]
        if all(p.raw_sum is not None for p in parts):
            keys.append("raw_sum")
        out = {k: np.zeros(ids.size) for k in keys}
        for p in parts:
            pos = np.searchsorted(ids, p.ids)
            for k in out:
                np.add.at(out[k], pos, getattr(p, k))
        return ClassicalTotals(block=parts[0].block, ids=ids, samples=sum(p.samples for p in parts), **out)


def instrument_check(res: "Results", head: Headline) -> Tuple[Dict[str, Any], List[str]]:
    """The instrument's COF over the headline's samples, and a warning when it differs by over 0.5 %."""
    out: Dict[str, Any] = {}
    notes: List[str] = []
    tot = res.classical
    if head.method == "instrument":  # the headline is the instrument's COF itself
        return {}, []
    if head.method == "classical" and tot is not None and tot.inst_count.sum() > 0 and head.ok:
        inst = tot.instrument_mean()
        out = {"mean": inst, "n": int(tot.inst_count.sum()), "over": "the headline's samples"}
    elif head.method == "per-stroke" and res.strokes is not None and head.ok:
        st = res.strokes
        ins = np.asarray(st.get("mu_instrument", []), dtype=float)
        if np.isfinite(ins).any():
            inst = float(np.nanmean(cycle_means({**st, "mu": ins})))
            out = {"mean": inst, "n": int(np.isfinite(ins).sum()), "over": "the same stroke centres, per cycle"}
    if not out or not np.isfinite(out["mean"]):
        return {}, []
    diff = (out["mean"] - head.value) / head.value if head.value else float("nan")
    out["difference"] = diff
    if np.isfinite(diff) and abs(diff) > INSTRUMENT_TOLERANCE:
        hint = ""
        if head.method == "classical" and tot is not None:
            sm = tot.signed_mean()
            if np.isfinite(sm) and abs(abs(sm) - out["mean"]) < abs(head.value - out["mean"]):
                hint = f"; the signed mean fy/fz ({sm:.4g}) is closer: the instrument may keep the sign"
        notes.append(
            f"the instrument's COF column averages {out['mean']:.4g} over {out['over']}, {100 * diff:+.2f} % from "
            f"the {head.method} COF {head.value:.4g}: the instrument may use another tare, normal-force threshold, "
            f"filter or averaging{hint}"
        )
    return out, notes


def choose(res: "Results", verdict: Mapping[str, Any]) -> Headline:
    """The headline of ``res``, chosen by ``verdict`` (``tribometer.verdict``; docs/method.md 6e)."""
    total = res.params.get("n_samples_total")
    total = int(total) if isinstance(total, (int, np.integer)) and total > 0 else 0
    why = tuple(str(r) for r in verdict.get("reasons") or ())
    if res.params.get("friction_from") == "cof":  # a COF-only export: its own COF (docs/method.md 6e)
        head = _instrument(res, total, why, reciprocating=verdict.get("motion") == "reciprocating")
    elif verdict.get("dynamic_method") and verdict.get("pooled"):
        head = _pooled(res, total, verdict["pooled"])
    elif verdict.get("dynamic_method"):
        head = _dynamic(res, total)
    elif verdict.get("motion") == "reciprocating":
        head = _per_stroke(res, total, why)
    else:
        head = _classical(res, total, why)
    if res.params.get("uncertainty"):  # the instrument's budget (docs/method.md 6i)
        head = attach(res, head)
    return head


def _dynamic(res: "Results", total: int) -> Headline:

    ok = np.asarray(res.table["ok"], dtype=bool)
    mu = np.asarray(res.table["mu_r"], dtype=float)
    keep = ok & np.isfinite(mu)
    v = mu[keep]
    est = res.params.get("estimator") or "ols"
    used = float(np.asarray(res.table["n"])[keep].sum())
    frac = used / total if total else float("nan")
    interval = "moving-block bootstrap of the median over the gated windows (docs/method.md 3d)"
    st = res.strokes
    if res.params.get("rectified") and st is not None and len(st.get("direction", [])):
        # Reciprocating (docs/method.md 6e): each direction's median, then their mean (a cycle's COF); the
        # median of the pooled two-valued set would be one direction's value.
        d = np.asarray(st["direction"])[np.asarray(res.table["acquisition"], dtype=np.int64)[keep]]
        meds, halves = [], []
        for sign in (1, -1):
            part = v[d == sign]
            sel = keep.copy()
            sel[keep] = d == sign
            ci = bootstrap_ci(part, noise=noise_resample(res.table, sel), threads=res._threads).get("median")
            if part.size:
                meds.append(float(np.median(part)))
                halves.append(0.5 * (ci[1] - ci[0]) if ci else float("nan"))
        if len(meds) == 2:
            m = 0.5 * (meds[0] + meds[1])
            h = 0.5 * float(np.hypot(halves[0], halves[1]))
            return Headline(
                method="dynamic", value=m, low=m - h, high=m + h, statistic="median", n=int(v.size),
                fraction_used=frac,
                estimate=(f"mean of the forward ({meds[0]:.4g}) and backward ({meds[1]:.4g}) medians of mu_r "
                          f"({est} estimator, direction-rectified strokes) over {v.size} gated windows of {len(res)}"),
                interval="each direction's median by moving-block bootstrap, half-widths combined in quadrature / 2",
            )  # fmt: skip
    # the recording's fz-noise estimate is drawn anew in each resample (docs/method.md 3d); summary() shares it
    ci = res.mu_r_ci.get("median")
    rect = ", direction-rectified strokes" if res.params.get("rectified") else ""
    bound = "lower" if res.params.get("mu_r_bound") == "lower" else ""
    if bound:  # docs/method.md 3d: least squares attenuated by the noise on fz, which no instrument could measure
        rect += "; least squares, a lower bound: no valid instrument measured the noise on fz"
        interval += ", its upper end raised to the reverse regression's slope"
    return Headline(
        method="dynamic",
        value=float(np.median(v)) if v.size else float("nan"),
        low=ci[0] if ci else float("nan"),
        high=ci[1] if ci else float("nan"),
        statistic="median",
        n=int(v.size),
        fraction_used=frac,
        estimate=f"median of mu_r ({est} estimator{rect}) over {v.size} gated windows of {len(res)}",
        interval=interval,
        bound=bound,
    )


def _pooled(res: "Results", total: int, info: Mapping[str, Any]) -> Headline:
    """The dynamic COF from windows each too imprecise to pass the gate alone, which agree (docs/method.md 5):
    the median of their mu_r, its interval by the moving-block bootstrap over them."""
    from .verdict import pooled

    got = pooled(res.table)
    assert got is not None, "the verdict pooled these windows"
    keep = got["mask"]
    v = np.asarray(res.table["mu_r"], dtype=float)[keep]
    ci = bootstrap_ci(v, noise=noise_resample(res.table, keep), threads=res._threads,
                      shifts=res._lag_shifts).get("median")  # fmt: skip
    used = float(np.asarray(res.table["n"])[keep].sum())
    est = res.params.get("estimator") or "ols"
    why = (f"no window passes the gate alone (each window's expected 95 % interval about "
           f"+-{100 * info['rel_half_width']:.0f} % of the COF); the {got['n']} windows that fail only as "
           f"imprecise agree within their standard errors (homogeneity p = {got['p']:.2g}): "
           "they are pooled",)  # fmt: skip
    return Headline(
        method="dynamic", value=float(np.median(v)), low=ci[0] if ci else float("nan"),
        high=ci[1] if ci else float("nan"), statistic="median", n=int(v.size),
        fraction_used=used / total if total else float("nan"), reasons=why,
        estimate=f"median of mu_r ({est} estimator) over {v.size} pooled windows of {len(res)} (none gated alone)",
        interval="moving-block bootstrap of the median over the pooled windows (docs/method.md 3d, 5)",
    )  # fmt: skip


def _not_below_zero(lo: float, interval: str) -> Tuple[float, str]:
    """The lower end of a mean of |fy|/|fz| (never negative) and the interval's words: a lower end below zero
    (a t interval of few batches and a wide spread) is set to 0 and said (issue 34 point 5)."""
    if lo < 0:
        return 0.0, interval + f"; its lower end, {lo:.3g}, raised to 0: a mean of |fy|/|fz| is not negative"
    return lo, interval


def _drag_reason(res: "Results", tot: ClassicalTotals, m: float) -> Tuple[str, ...]:
    """The reason to give when fy's tare changes the classical COF by more than DRAG_SHARE (docs/method.md 6a)."""
    t_fy = float((res.params.get("tare_offsets") or {}).get("fy", 0.0))
    raw = tot.without_fy_tare()
    if t_fy == 0.0 or not (np.isfinite(raw) and m > 0) or abs(raw - m) <= DRAG_SHARE * m:
        return ()
    said = (
        f"fy's unloaded level ({t_fy:.4g} N: a turning disc's drag, or an offset) is subtracted as its tare; "
        f"without it the classical COF is {raw:.4g} ({100 * (raw / m - 1):+.0f} %; summary.json: "
        "classical.without_fy_tare): pass --tare none (tare='none') if the drag is part of the friction"
    )
    return (said,)


def _classical(res: "Results", total: int, why: Tuple[str, ...]) -> Headline:
    tot: Optional[ClassicalTotals] = res.classical
    interval = f"batch means over up to {BATCHES} contiguous blocks of the recording (docs/method.md 6e)"
    note = (res.params.get("contact") or {}).get("note")
    if note:  # the tare from the unloaded samples is uncertain (docs/method.md 6a)
        why = why + (str(note),)
    if tot is not None and tot.contact:
        m, lo, hi, b = tot.mean()
        lo, interval = _not_below_zero(lo, interval)
        why = why + _drag_reason(res, tot, m)
        excluded = tot.samples - tot.contact
        return Headline(
            method="classical",
            value=m,
            low=lo,
            high=hi,
            statistic="mean",
            n=tot.contact,
            fraction_used=tot.contact / total if total else float("nan"),
            reasons=why,
            estimate=(
                f"mean |fy|/|fz| over the {tot.contact} samples in contact of the whole recording"
                + (f" ({excluded} samples without contact excluded)" if excluded else "")
            ),
            interval=interval,
        )
    c = np.asarray(res.table.get("mu_classical", []), dtype=float)
    n = np.asarray(res.table.get("n", []), dtype=float)
    fin = np.isfinite(c)
    if tot is None and fin.any():  # a one-pass stream: only the windows were seen
        m, lo, hi, b = ratio_mean(np.where(fin, c * n, 0.0), np.where(fin, n, 0.0))
        lo, interval = _not_below_zero(lo, interval)
        return Headline(
            method="classical", value=m, low=lo, high=hi, statistic="mean", n=int(n[fin].sum()),
            fraction_used=float(n[fin].sum()) / total if total else float("nan"),
            reasons=why + ("a one-pass stream: the classical COF is the mean over the windows' samples only",),
            estimate="sample-weighted mean of the windows' classical COF", interval=interval,
        )  # fmt: skip
    if "static_fz" not in res.params and "min_fn" not in res.params:
        need = (
            "a one-pass stream cannot be looked at before the windows: pass min_fn= (and tare= offsets) for the "
            "classical COF of its windows"
        )
    elif res.params.get("static_fz") is False or "min_fn" not in res.params:
        need = (
            "fz carries no static level (high-passed or AC-coupled forces?): the classical COF needs the raw "
            "normal force; record it DC-coupled, or pass min_fn= / --min-fn N if fz is raw"
        )
    else:
        need = (
            f"no sample has |fz| >= min_fn = {res.params.get('min_fn'):.4g} N: pass a lower min_fn= / --min-fn N "
            "or the tare (--tare)"
        )
    return Headline(method="classical", value=float("nan"), low=float("nan"), high=float("nan"), statistic="mean",
                    n=0, fraction_used=0.0, reasons=why + (need,), estimate="", interval=interval)  # fmt: skip


def _instrument(res: "Results", total: int, why: Tuple[str, ...], *, reciprocating: bool) -> Headline:
    """A COF-only export's headline: the mean |COF| of its COF column over the samples in contact (per cycle of
    the strokes' centres for a reciprocating test), batch-means interval (docs/method.md 6e; issue 34 point 2)."""
    column = res.params.get("cof_channel", "cof")
    given = (res.params.get("roles") or {}).get("fz") in ("load (given)", "unit load (derived)")
    contact = "every sample (a constant load: no contact rule)" if given else "the samples in contact"
    why = why + (f"the file's only friction information is its COF column {column!r}: the headline is the "
                 "instrument's own COF",)  # fmt: skip
    others = res.params.get("other_cof_channels") or []
    if others:  # docs/method.md 6e: other COF definitions of the file are named, not used
        listed = ", ".join(repr(str(c)) for c in others)
        why = why + (f"the file holds other COF definitions, not used: {listed} (map one with --map cof=NAME)",)
    st = res.strokes
    if reciprocating and st is not None and np.isfinite(np.asarray(st.get("mu_instrument", []), dtype=float)).any():
        cyc = cycle_means({**st, "mu": np.asarray(st["mu_instrument"], dtype=float)})
        m, lo, hi, b = batch_mean(cyc)
        interval, n = f"batch means over up to {BATCHES} contiguous groups of cycles (docs/method.md 6e)", int(
            np.isfinite(cyc).sum())  # fmt: skip
        lo, interval = _not_below_zero(lo, interval)
        used = float(np.asarray(st["n"], dtype=float).sum())
        return Headline(method="instrument", value=m, low=lo, high=hi, statistic="mean", n=n,
                        fraction_used=used / total if total else float("nan"), reasons=why,
                        estimate=f"mean over {n} cycles of the forward and backward strokes' mean |COF| of the "
                                 f"column {column!r} (their central parts)", interval=interval)  # fmt: skip
    tot: Optional[ClassicalTotals] = res.classical
    interval = f"batch means over up to {BATCHES} contiguous blocks of the recording (docs/method.md 6e)"
    if tot is None or not tot.inst_count.sum():
        return Headline(method="instrument", value=float("nan"), low=float("nan"), high=float("nan"),
                        statistic="mean", n=0, fraction_used=0.0, interval=interval,
                        reasons=why + ("no sample of the COF column is in contact",))  # fmt: skip
    m, lo, hi, b = ratio_mean(tot.inst_sum, tot.inst_count)
    lo, interval = _not_below_zero(lo, interval)
    n = int(tot.inst_count.sum())
    return Headline(method="instrument", value=m, low=lo, high=hi, statistic="mean", n=n,
                    fraction_used=n / total if total else float("nan"), reasons=why,
                    estimate=f"mean |COF| of the column {column!r} over {contact} ({n} samples)",
                    interval=interval)  # fmt: skip


def _per_stroke(res: "Results", total: int, why: Tuple[str, ...]) -> Headline:
    st = res.strokes
    interval = f"batch means over up to {BATCHES} contiguous groups of cycles (docs/method.md 6e)"
    if st is None or not len(st.get("mu", [])):
        need = "no strokes were found (a one-pass stream cannot be cut into strokes: pass arrays or a file)"
        return Headline(method="per-stroke", value=float("nan"), low=float("nan"), high=float("nan"),
                        statistic="mean", n=0, fraction_used=0.0, reasons=why + (need,), interval=interval)  # fmt: skip
    cyc = cycle_means(st)
    m, lo, hi, b = batch_mean(cyc)
    lo, interval = _not_below_zero(lo, interval)
    used = float(np.asarray(st["n"], dtype=float).sum())
    n_cyc = int(np.isfinite(cyc).sum())
    if not n_cyc:
        need = "no cycle holds a forward and a backward stroke with samples in contact"
        return Headline(method="per-stroke", value=float("nan"), low=float("nan"), high=float("nan"),
                        statistic="mean", n=0, fraction_used=0.0, interval=interval, reasons=why + (need,))  # fmt: skip
    return Headline(
        method="per-stroke",
        value=m,
        low=lo,
        high=hi,
        statistic="mean",
        n=n_cyc,
        fraction_used=used / total if total else float("nan"),
        reasons=why,
        estimate=(
            f"mean over {n_cyc} cycle{'s' if n_cyc != 1 else ''} of the mean of the forward and backward "
            f"strokes' mean |fy|/|fz| (central {res.params.get('stroke_fraction', 0.5):g} of each stroke)"
        ),
        interval=interval,
    )
