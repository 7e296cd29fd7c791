"""Replicate tests compared: :func:`compare` (docs/method.md 10).

* Per test: its headline (docs/method.md 6e) and the standard error read
  from the headline's 95 % interval.
* Over the tests: a random-effects mean, DerSimonian-Laird between-test
  variance tau^2 and a Hartung-Knapp (Sidik-Jonkman) 95 % interval of the
  mean with the Knapp-Hartung factor kept >= 1, the sample SD of the tests'
  values, Cochran's Q, I^2 and a 95 % prediction interval of a further
  test's value (docs/method.md 10a).
* By group (laboratories, days, rigs): the ISO 5725-2 / ASTM E691
  repeatability and reproducibility standard deviations s_r, s_L, s_R, the
  limits r = 2.8 s_r and R = 2.8 s_R, and Mandel's h and k consistency
  statistics with their critical values at 1 % and 5 % (docs/method.md 10b).

A dynamic median and a classical (or per-stroke) mean are different
quantities: tests whose headlines come from different methods are refused
unless ``allow_mixed=True``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from ..kernels.quantiles import Z975, f_ppf, t_ppf  # a test's se: its 95 % interval's width / (2 Z975), 10a
from ..kernels.uncertainty import Uncertainty
from ..results import HEADLINE_METHODS, Headline

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    from matplotlib.figure import Figure

    from ..results import Results

__all__ = ["Comparison", "Precision", "Replicate", "compare", "headline_from_dict"]

#: The repeatability and reproducibility limits are this factor times s_r and s_R (ISO 5725-6 4.1.4: 1.96 sqrt 2).
LIMIT_FACTOR = 2.8
#: Significance levels of Mandel's h and k: outlier (1 %) and straggler (5 %), as ISO 5725-2 7.3.
LEVELS = (0.01, 0.05)

#: How the mean and its interval are computed (``Comparison.pooling``): on the log scale (a COF is positive, so
#: are its intervals), or on the COF's own scale when a value is not positive.
POOLING_RE = "random effects on the log scale: DerSimonian-Laird tau^2, Hartung-Knapp interval with t(k - 1)"
POOLING_UNWEIGHTED = "unweighted mean of the tests' log values, t(k - 1) interval from their sample SD"
POOLING_RE_LINEAR = "random effects: DerSimonian-Laird tau^2, Hartung-Knapp interval with t(k - 1)"
POOLING_UNWEIGHTED_LINEAR = "unweighted mean of the tests' values, t(k - 1) interval from their sample SD"
#: From this many tests on, the comparison says nothing more about what few tests can bound.
FEW_TESTS = 3

HeadlineLike = Union["Results", Headline, Mapping[str, Any]]


def _num(v: float) -> Optional[float]:
    return float(v) if math.isfinite(v) else None


@dataclass(frozen=True)
class Replicate:
    """One test of a comparison (docs/method.md 10a).

    Attributes
    ----------
    label : str
        The test's name.
    group : str or None
        Its group (laboratory, day...), when groups are given.
    headline : Headline
        The test's headline (docs/method.md 6e).
    se : float
        Its standard error, (high - low) / (2 x 1.96); NaN without an interval.
    weight : float
        Its share of the pooled mean (the weights add up to 1).
    """

    label: str
    group: Optional[str]
    headline: Headline
    se: float
    weight: float

    @property
    def value(self) -> float:
        return self.headline.value

    @property
    def low(self) -> float:
        return self.headline.low

    @property
    def high(self) -> float:
        return self.headline.high

    def to_dict(self) -> Dict[str, Any]:
        """JSON-ready (NaN as None), the headline as :meth:`Headline.to_dict`."""
        return {
            "label": self.label,
            "group": self.group,
            "value": _num(self.value),
            "low": _num(self.low),
            "high": _num(self.high),
            "se": _num(self.se),
            "weight": _num(self.weight),
            "headline": self.headline.to_dict(),
        }


@dataclass(frozen=True)
class Precision:
    """Repeatability and reproducibility over groups, ISO 5725-2 / ASTM E691 (docs/method.md 10b).

    Each test's headline value is one test result; a group (laboratory, day,
    rig) is a cell.

    Attributes
    ----------
    groups : tuple of str
        The groups, in order of first appearance.
    counts : tuple of int
        Tests per group, n_i.
    means : tuple of float
        Cell averages.
    sds : tuple of float
        Cell standard deviations (NaN for a group of one test).
    mean : float
        The general mean m = sum n_i mean_i / sum n_i.
    low, high : float
        Its 95 % interval from the between-group mean square, t(p - 1).
    s_r, s_L, s_R : float
        Repeatability, between-group and reproducibility standard deviations
        (s_R^2 = s_L^2 + s_r^2; s_L^2 set to 0 when its estimate is negative).
    r, R : float
        Repeatability and reproducibility limits, 2.8 s_r and 2.8 s_R.
    h, k : tuple of float
        Mandel's h and k per group (k NaN for a group of one test).
    h_critical, k_critical : tuple of two floats
        Critical values at 1 % and 5 % (h: p >= 3; k: same n in every group, n >= 2; else NaN).
    flags : tuple of str
        Per group: "" or e.g. "h outlier (1 %)", "k straggler (5 %)".
    balanced : bool
        Every group holds the same number of tests.
    """

    groups: Tuple[str, ...]
    counts: Tuple[int, ...]
    means: Tuple[float, ...]
    sds: Tuple[float, ...]
    mean: float
    low: float
    high: float
    s_r: float
    s_L: float
    s_R: float
    r: float
    R: float
    h: Tuple[float, ...]
    k: Tuple[float, ...]
    h_critical: Tuple[float, float]
    k_critical: Tuple[float, float]
    flags: Tuple[str, ...]
    balanced: bool

    @property
    def p(self) -> int:
        """Number of groups."""
        return len(self.groups)

    @property
    def text(self) -> str:
        """'s_r 0.0021, s_R 0.0043 (r 0.0059, R 0.012) over 3 groups of 3 tests'."""
        n = f"{self.counts[0]}" if self.balanced else f"{min(self.counts)} to {max(self.counts)}"
        return (
            f"repeatability s_r {self.s_r:#.3g}, reproducibility s_R {self.s_R:#.3g} "
            f"(limits r {self.r:#.3g}, R {self.R:#.3g}) over {self.p} groups of {n} tests"
        )

    def to_dict(self) -> Dict[str, Any]:
        """JSON-ready (NaN as None): one entry per group under ``"groups"``."""
        rows = [
            {"group": g, "n": n, "mean": _num(m), "sd": _num(s), "h": _num(h), "k": _num(k), "flag": f}
            for g, n, m, s, h, k, f in zip(self.groups, self.counts, self.means, self.sds, self.h, self.k, self.flags)
        ]
        return {
            "p": self.p,
            "balanced": self.balanced,
            "mean": _num(self.mean),
            "low": _num(self.low),
            "high": _num(self.high),
            "s_r": _num(self.s_r),
            "s_L": _num(self.s_L),
            "s_R": _num(self.s_R),
            "r": _num(self.r),
            "R": _num(self.R),
            "h_critical": {"1 %": _num(self.h_critical[0]), "5 %": _num(self.h_critical[1])},
            "k_critical": {"1 %": _num(self.k_critical[0]), "5 %": _num(self.k_critical[1])},
            "groups": rows,
            "text": self.text,
        }


@dataclass(frozen=True)
class Comparison:
    """Replicate tests of one COF compared (docs/method.md 10): :func:`compare`.

    Attributes
    ----------
    replicates : tuple of Replicate
        Per test: label, group, headline, standard error and weight.
    method : str
        The headlines' method ("dynamic", "classical", "per-stroke", "instrument"), or "mixed".
    statistic : str
        "median" or "mean" (the headlines'), or "mixed".
    mean : float
        The random-effects mean of the tests (docs/method.md 10a).
    low, high : float
        Its 95 % interval (``pooling`` says how).
    se : float
        Its standard error (the interval's half-width over t(0.975, k - 1)).
    tau : float
        Between-test SD beyond the tests' own uncertainty (DerSimonian-Laird);
        NaN when a test has no interval.
    sd : float
        Sample SD of the tests' values.
    q : float
        Cochran's Q (NaN when a test has no interval).
    i2 : float
        I^2 = max(0, (Q - (k - 1)) / Q): share of the spread that is between tests.
    prediction_low, prediction_high : float
        95 % prediction interval of a further test's value (k >= 3; :func:`prediction`).
    pooling : str
        How the mean and its interval are computed.
    precision : Precision or None
        ISO 5725 repeatability and reproducibility when groups are given.
    notes : tuple of str
        What the reader should know (mixed methods, tests without an interval...).
    """

    replicates: Tuple[Replicate, ...]
    method: str
    statistic: str
    mean: float
    low: float
    high: float
    se: float
    tau: float
    sd: float
    q: float
    i2: float
    prediction_low: float
    prediction_high: float
    pooling: str
    precision: Optional[Precision] = None
    notes: Tuple[str, ...] = ()
    #: The instrument's part when every test carries an uncertainty budget (docs/method.md 6i, 10a): ``u`` (the
    #: tests' weighted instrument u, common to all of them) and the mean's 95 % interval with it (``low``, ``high``).
    instrument: Optional[Dict[str, float]] = None

    @property
    def k(self) -> int:
        """Number of tests."""
        return len(self.replicates)

    @property
    def text(self) -> str:
        """The comparison in one line."""
        what = f"{self.method} {self.statistic}s" if self.method != "mixed" else "mixed methods"
        tau = f"between-test SD {self.tau:#.3g} (tau), " if math.isfinite(self.tau) else ""
        line = (
            f"mean COF {self.mean:#.4g} (95 % interval {self.low:#.4g} to {self.high:#.4g}) over {self.k} tests "
            f"({what}); {tau}SD of the tests {self.sd:#.3g}"
        )
        if math.isfinite(self.prediction_low):
            line += f"; a further test: {self.prediction_low:#.4g} to {self.prediction_high:#.4g} (95 %)"
        if self.precision is not None:
            line += f"; {self.precision.text}"
        if self.instrument is not None:
            line += (f"; with the instrument's shared part (u {self.instrument['u']:#.2g}): "
                     f"{self.instrument['low']:#.4g} to {self.instrument['high']:#.4g}")  # fmt: skip
        return line

    def __str__(self) -> str:
        return self.text

    def __repr__(self) -> str:
        return f"<Comparison: {self.text}>"

    def to_dict(self) -> Dict[str, Any]:
        """JSON-ready (NaN as None)."""
        return {
            "k": self.k,
            "method": self.method,
            "statistic": self.statistic,
            "mean": _num(self.mean),
            "low": _num(self.low),
            "high": _num(self.high),
            "se": _num(self.se),
            "tau": _num(self.tau),
            "sd": _num(self.sd),
            "q": _num(self.q),
            "i2": _num(self.i2),
            "prediction_low": _num(self.prediction_low),
            "prediction_high": _num(self.prediction_high),
            "pooling": self.pooling,
            "notes": list(self.notes),
            "text": self.text,
            "tests": [r.to_dict() for r in self.replicates],
            "precision": self.precision.to_dict() if self.precision is not None else None,
            "instrument": None if self.instrument is None else {k: _num(v) for k, v in self.instrument.items()},
        }

    def to_frame(self) -> "pd.DataFrame":
        """One row per test: label, group, method, statistic, value, low, high, se, weight, n, fraction_used."""
        import pandas as pd

        return pd.DataFrame(
            {
                "label": [r.label for r in self.replicates],
                "group": [r.group for r in self.replicates],
                "method": [r.headline.method for r in self.replicates],
                "statistic": [r.headline.statistic for r in self.replicates],
                "value": [r.value for r in self.replicates],
                "low": [r.low for r in self.replicates],
                "high": [r.high for r in self.replicates],
                "se": [r.se for r in self.replicates],
                "weight": [r.weight for r in self.replicates],
                "n": [r.headline.n for r in self.replicates],
                "fraction_used": [r.headline.fraction_used for r in self.replicates],
            }
        )

    def figure(self) -> "Figure":
        """All tests side by side: value with its 95 % interval, the mean and its band (docs/method.md 10)."""
        return _forest(self)


# -- inputs -------------------------------------------------------------------------------


def headline_from_dict(d: Mapping[str, Any]) -> Headline:
    """A :class:`Headline` from its :meth:`Headline.to_dict` form (``summary.json``; None as NaN).

    Raises
    ------
    ValueError
        A key is missing or a value has the wrong type.
    """
    missing = [k for k in ("method", "value", "low", "high", "statistic", "n") if k not in d]
    if missing:
        raise ValueError(f"a headline needs {', '.join(missing)} (has {', '.join(map(str, d)) or 'nothing'})")

    def num(key: str) -> float:
        v = d.get(key)
        if v is None:
            return float("nan")
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ValueError(f"headline {key} must be a number or null, got {v!r}")
        return float(v)

    method = d["method"]
    if method not in HEADLINE_METHODS:
        raise ValueError(f"headline method must be one of {', '.join(HEADLINE_METHODS)}, got {method!r}")
    n = d["n"]
    if isinstance(n, bool) or not isinstance(n, int):
        raise ValueError(f"headline n must be an integer, got {n!r}")
    reasons = d.get("reasons") or ()
    if not isinstance(reasons, (list, tuple)):
        raise ValueError(f"headline reasons must be a list, got {reasons!r}")
    unc = d.get("uncertainty")
    if unc is not None and not isinstance(unc, Mapping):
        raise ValueError(f"headline uncertainty must be a table or null, got {unc!r}")
    try:
        budget = None if unc is None else Uncertainty.from_dict(unc)
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"headline uncertainty is not a budget ({exc})") from None
    return Headline(
        method=str(method),
        value=num("value"),
        low=num("low"),
        high=num("high"),
        statistic=str(d["statistic"]),
        n=n,
        fraction_used=num("fraction_used"),
        reasons=tuple(str(r) for r in reasons),
        estimate=str(d.get("estimate") or ""),
        interval=str(d.get("interval") or ""),
        uncertainty=budget,
    )


def _as_headline(x: Any, where: str) -> Headline:
    if isinstance(x, Headline):
        return x
    head = getattr(x, "headline", None)
    if isinstance(head, Headline):  # a Results
        return head
    if isinstance(x, Mapping):
        try:
            return headline_from_dict(x.get("headline", x) if isinstance(x.get("headline"), Mapping) else x)
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None
    raise TypeError(f"{where}: expected a Results, a Headline or a headline dict, got {type(x).__name__}")


def _names(values: Optional[Sequence[Any]], k: int, what: str) -> Optional[List[str]]:
    if values is None:
        return None
    if isinstance(values, (str, bytes)) or not isinstance(values, Sequence):
        raise TypeError(f"{what} must be a list of names, one per test, got {type(values).__name__}")
    if len(values) != k:
        raise ValueError(f"{what}: {len(values)} given for {k} tests (one per test)")
    out = [str(v).strip() for v in values]
    empty = [i + 1 for i, v in enumerate(out) if not v]
    if empty:
        raise ValueError(f"{what}: test {empty[0]} has an empty name")
    return out


# -- the statistics ---------------------------------------------------------------------


def _t975(df: float) -> float:
    return float(t_ppf(0.975, df))


def random_effects(y: np.ndarray, v: np.ndarray) -> Dict[str, float]:
    """DerSimonian-Laird tau^2 and the Hartung-Knapp 95 % interval of the mean (docs/method.md 10a).

    ``y`` the tests' values, ``v`` their variances (> 0, finite), k >= 2.
    Returns mean, low, high, se, tau2, q and i2.
    """
    k = y.size
    w = 1.0 / v
    fixed = float(np.sum(w * y) / np.sum(w))
    q = float(np.sum(w * (y - fixed) ** 2))
    c = float(np.sum(w) - np.sum(w * w) / np.sum(w))
    tau2 = max(0.0, (q - (k - 1)) / c) if c > 0 else 0.0
    ws = 1.0 / (v + tau2)
    mu = float(np.sum(ws * y) / np.sum(ws))
    # Hartung-Knapp: the weighted residual variance scales Var(mu), not kept >= 1: with the factor truncated the
    # interval covered 98.6-100 % of tests of one condition (docs/method.md 10a)
    factor = float(np.sum(ws * (y - mu) ** 2)) / (k - 1)
    se = math.sqrt(factor / float(np.sum(ws)))
    h = _t975(k - 1) * se
    i2 = max(0.0, (q - (k - 1)) / q) if q > 0 else 0.0
    return {"mean": mu, "low": mu - h, "high": mu + h, "se": se, "tau2": tau2, "q": q, "i2": i2}


def _scaled(st: Dict[str, float], log: bool) -> Dict[str, float]:
    """Log-scale statistics back on the COF's scale (``log``): mean, low and high exponentiated (a geometric mean
    and an interval that stays positive), the standard error and tau times the mean (the delta method)."""
    if not log:
        return st
    m = math.exp(st["mean"])
    tau2 = st["tau2"] * m * m if math.isfinite(st["tau2"]) else st["tau2"]
    return {**st, "mean": m, "low": math.exp(st["low"]), "high": math.exp(st["high"]), "se": m * st["se"],
            "tau2": tau2}  # fmt: skip


def _random_effects_scaled(y: np.ndarray, se: np.ndarray, log: bool) -> Tuple[Dict[str, float], np.ndarray]:
    """(random effects on the log scale or the COF's own, normalised weights): a test's log value has the
    variance (se / y)^2 (the delta method)."""
    z, v = (np.log(y), (se / y) ** 2) if log else (y, se**2)
    st = random_effects(z, v)
    w = 1.0 / (v + st["tau2"])
    return _scaled(st, log), w / w.sum()


def _few_tests(k: int) -> str:
    """What 2 or 3 tests can and cannot bound (docs/method.md 10a)."""
    df = f"{k - 1} degree{'s' if k > 2 else ''} of freedom"
    further = (
        "nor where a further test will land (no prediction interval from 2 tests)"
        if k < 3
        else "and the interval of a further test is wide and itself uncertain"
    )
    return (
        f"with {k} tests the interval rests on the spread of {k} values ({df}): 95 % of such intervals cover the "
        "mean COF of the condition these tests sample, but their width varies widely (tests that agree by chance "
        "give a narrow one); they cannot bound the spread between tests (tau), "
        f"{further}; more tests narrow the interval and make its width reliable"
    )


def _unweighted(y: np.ndarray) -> Dict[str, float]:
    """The mean of the values with a t(k - 1) interval from their sample SD (docs/method.md 10a)."""
    k = y.size
    mu = float(np.mean(y))
    s = float(np.std(y, ddof=1))
    se = s / math.sqrt(k)
    h = _t975(k - 1) * se
    return {"mean": mu, "low": mu - h, "high": mu + h, "se": se, "tau2": float("nan"), "q": float("nan"),
            "i2": float("nan")}  # fmt: skip


def prediction(y: np.ndarray) -> Tuple[float, float]:
    """95 % prediction interval of a further test's value: mean +- t(k - 1) s sqrt(1 + 1 / k) (docs/method.md 10a).

    The mean and SD s of the tests' values: s holds both the between-test
    spread and the tests' own noise, as a further test's value will; exact
    for normal values of equal variance. NaN for k < 3.
    """
    k = y.size
    if k < 3:
        return float("nan"), float("nan")
    mu = float(np.mean(y))
    h = _t975(k - 1) * float(np.std(y, ddof=1)) * math.sqrt(1.0 + 1.0 / k)
    return mu - h, mu + h


def _critical_h(p: int, alpha: float) -> float:
    """Mandel's h critical value, ISO 5725-2 8.3: (p - 1) t / sqrt(p (t^2 + p - 2)), t two-sided alpha, p - 2 df."""
    if p < 3:
        return float("nan")
    t = float(t_ppf(1 - alpha / 2, p - 2))
    return (p - 1) * t / math.sqrt(p * (t * t + p - 2))


def _critical_k(p: int, n: int, alpha: float) -> float:
    """Mandel's k critical value, ISO 5725-2 8.3: sqrt(p / (1 + (p - 1) / F)), F upper alpha, (n-1, (p-1)(n-1)) df."""
    if p < 2 or n < 2:
        return float("nan")
    f = float(f_ppf(1 - alpha, n - 1, (p - 1) * (n - 1)))
    return math.sqrt(p / (1 + (p - 1) / f))


def precision(values: Sequence[float], groups: Sequence[str]) -> Precision:
    """ISO 5725-2 repeatability and reproducibility of ``values`` grouped by ``groups`` (docs/method.md 10b).

    Raises
    ------
    ValueError
        Fewer than 2 groups, or no group with 2 tests (no repeatability).
    """
    y = np.asarray(values, dtype=float)
    names = list(dict.fromkeys(groups))
    p = len(names)
    if p < 2:
        raise ValueError(f"groups: reproducibility needs at least 2 groups, got {p} ({', '.join(names)})")
    cells = [y[[g == name for g in groups]] for name in names]
    n = np.array([c.size for c in cells], dtype=float)
    if not np.any(n >= 2):
        raise ValueError("groups: repeatability needs a group with at least 2 tests (every group holds one)")
    means = np.array([c.mean() for c in cells])
    sds = np.array([c.std(ddof=1) if c.size >= 2 else np.nan for c in cells])
    dof = n - 1
    s_r2 = float(np.nansum(dof * np.where(n >= 2, sds, 0.0) ** 2) / dof.sum())
    total = float(n.sum())
    m = float(np.sum(n * means) / total)
    s_d2 = float(np.sum(n * (means - m) ** 2) / (p - 1))
    n_bar = (total - float(np.sum(n * n)) / total) / (p - 1)
    s_L2 = max(0.0, (s_d2 - s_r2) / n_bar)
    s_R2 = s_L2 + s_r2
    # Var(m) = s_L^2 sum n_i^2 / N^2 + s_r^2 / N (= s_d^2 / N when balanced), t with p - 1 df.
    var_m = s_L2 * float(np.sum(n * n)) / total**2 + s_r2 / total
    half = _t975(p - 1) * math.sqrt(var_m)
    spread = math.sqrt(float(np.sum((means - m) ** 2)) / (p - 1))
    h = (means - m) / spread if spread > 0 else np.full(p, np.nan)
    s_r = math.sqrt(s_r2)
    k = sds / s_r if s_r > 0 else np.full(p, np.nan)
    balanced = bool(np.all(n == n[0]))
    hc = (_critical_h(p, LEVELS[0]), _critical_h(p, LEVELS[1]))
    kc = (_critical_k(p, int(n[0]), LEVELS[0]), _critical_k(p, int(n[0]), LEVELS[1])) if balanced else (
        float("nan"), float("nan"))  # fmt: skip
    flags = []
    for hi, ki in zip(h, k):
        f = []
        for name, val, crit in (("h", abs(hi), hc), ("k", ki, kc)):
            if math.isfinite(val) and math.isfinite(crit[0]) and val > crit[0]:
                f.append(f"{name} outlier (1 %)")
            elif math.isfinite(val) and math.isfinite(crit[1]) and val > crit[1]:
                f.append(f"{name} straggler (5 %)")
        flags.append(", ".join(f))
    return Precision(
        groups=tuple(names), counts=tuple(int(x) for x in n), means=tuple(float(x) for x in means),
        sds=tuple(float(x) for x in sds), mean=m, low=m - half, high=m + half, s_r=s_r, s_L=math.sqrt(s_L2),
        s_R=math.sqrt(s_R2), r=LIMIT_FACTOR * s_r, R=LIMIT_FACTOR * math.sqrt(s_R2),
        h=tuple(float(x) for x in h), k=tuple(float(x) for x in k), h_critical=hc, k_critical=kc,
        flags=tuple(flags), balanced=balanced,
    )  # fmt: skip


# -- compare --------------------------------------------------------------------------


def _tests_and_labels(
    results: Union[Sequence[HeadlineLike], Mapping[str, HeadlineLike]], labels: Optional[Sequence[str]]
) -> Tuple[List[HeadlineLike], List[str]]:
    """The tests (at least 2) and their unique labels (given, the mapping's keys, or "test 1", ...)."""
    if isinstance(results, Mapping):
        items = list(results.items())
        default = [str(k) for k, _ in items]
        tests = [v for _, v in items]
    elif isinstance(results, (str, bytes)) or not isinstance(results, Sequence):
        raise TypeError(f"results must be a list of Results (or Headlines), got {type(results).__name__}")
    else:
        tests = list(results)
        default = [f"test {i + 1}" for i in range(len(tests))]
    k = len(tests)
    if k < 2:
        raise ValueError(f"compare needs at least 2 tests, got {k}")
    names = _names(labels, k, "labels") or default
    dup = sorted({x for x in names if names.count(x) > 1})
    if dup:
        raise ValueError(f"labels must be unique: {', '.join(repr(x) for x in dup)} given twice")
    return tests, names


def _methods(names: Sequence[str], heads: Sequence[Headline], allow_mixed: bool, notes: List[str]) -> List[str]:
    """The headlines' methods, in order; mixed methods refused unless ``allow_mixed`` (then noted)."""
    methods = list(dict.fromkeys(h.method for h in heads))
    if len(methods) > 1:
        by = "; ".join(f"{m}: {', '.join(n for n, h in zip(names, heads) if h.method == m)}" for m in methods)
        if not allow_mixed:
            raise ValueError(
                f"the tests' headlines come from different methods ({by}): a dynamic median and a classical mean "
                "are different quantities; compare tests of one method, or pass allow_mixed=True"
            )
        notes.append(f"mixed headline methods ({by}): the mean pools different quantities")
    return methods


def compare(
    results: Union[Sequence[HeadlineLike], Mapping[str, HeadlineLike]],
    labels: Optional[Sequence[str]] = None,
    groups: Optional[Sequence[str]] = None,
    *,
    allow_mixed: bool = False,
) -> Comparison:
    """Replicate tests compared: per test its headline, over tests a random-effects mean (docs/method.md 10).

    Parameters
    ----------
    results : sequence of Results, Headline or headline dict; or a mapping label -> one of them
        The tests (at least 2): ``Results`` objects (their ``headline``),
        ``Headline`` objects, or headline dicts as in ``summary.json``. A
        mapping (e.g. ``ManyResults.results``) gives the labels.
    labels : sequence of str, optional
        One name per test (default: the mapping's keys, else "test 1", "test 2", ...).
    groups : sequence of str, optional
        One group per test (laboratory, day, rig): adds the ISO 5725
        repeatability and reproducibility (:class:`Precision`, docs/method.md 10b).
    allow_mixed : bool
        Compare headlines of different methods (a dynamic median and a
        classical mean are different quantities: refused by default).

    Returns
    -------
    Comparison

    Raises
    ------
    ValueError
        Fewer than 2 tests, a test without a COF, labels or groups of the
        wrong length or not unique (labels), mixed methods without
        ``allow_mixed``, groups that give no repeatability.
    TypeError
        A test that is neither a Results, a Headline nor a headline dict.
    """
    tests, names = _tests_and_labels(results, labels)
    k = len(tests)
    grp = _names(groups, k, "groups")
    heads = [_as_headline(t, names[i]) for i, t in enumerate(tests)]
    empty = [(n, h) for n, h in zip(names, heads) if not h.ok]
    if empty:
        n, h = empty[0]
        why = "; ".join(h.reasons) or "no value"
        raise ValueError(f"test {n!r} has no COF ({why}): leave it out of the comparison")
    notes: List[str] = []
    methods = _methods(names, heads, allow_mixed, notes)
    statistics = list(dict.fromkeys(h.statistic for h in heads))

    y = np.array([h.value for h in heads], dtype=float)
    se = np.array([(h.high - h.low) / (2 * Z975) for h in heads], dtype=float)
    usable = np.isfinite(se) & (se > 0)
    log = bool(np.all(y > 0))
    if not log:
        notes.append(
            "a test's value is not positive: the mean and its intervals are computed on the COF's own scale and "
            "may reach below zero"
        )
    if usable.all():
        st, weights = _random_effects_scaled(y, se, log)
        pooling = POOLING_RE if log else POOLING_RE_LINEAR
    else:
        st = _scaled(_unweighted(np.log(y)), log) if log else _unweighted(y)
        weights = np.full(k, 1.0 / k)
        pooling = POOLING_UNWEIGHTED if log else POOLING_UNWEIGHTED_LINEAR
        without = [n for n, u in zip(names, usable) if not u]
        notes.append(
            f"no usable 95 % interval for {', '.join(without)}: the tests' own uncertainties are not used, the "
            "interval comes from the spread of their values alone and tau is not separated from it"
        )
    sd = float(np.std(y, ddof=1))
    if sd == 0:
        notes.append("the tests' values are identical: the intervals from their spread have zero width")
    pred = tuple(float(np.exp(p)) for p in prediction(np.log(y))) if log else prediction(y)
    if k <= FEW_TESTS:
        notes.append(_few_tests(k))
    prec = precision(y.tolist(), grp) if grp is not None else None
    if prec is not None:
        notes.append(
            "with groups, the tests of one group are not independent: the interval of the general mean "
            "(precision.low, precision.high) accounts for that, the random-effects interval does not"
        )
    instrument = _instrument_part(heads, weights, st, notes)
    reps = tuple(
        Replicate(label=n, group=grp[i] if grp else None, headline=h, se=float(se[i]), weight=float(weights[i]))
        for i, (n, h) in enumerate(zip(names, heads))
    )
    return Comparison(
        replicates=reps,
        method=methods[0] if len(methods) == 1 else "mixed",
        statistic=statistics[0] if len(statistics) == 1 else "mixed",
        mean=st["mean"],
        low=st["low"],
        high=st["high"],
        se=st["se"],
        tau=math.sqrt(st["tau2"]) if math.isfinite(st["tau2"]) else float("nan"),
        sd=sd,
        q=st["q"],
        i2=st["i2"],
        prediction_low=pred[0],
        prediction_high=pred[1],
        pooling=pooling,
        precision=prec,
        notes=tuple(notes),
        instrument=instrument,
    )


def _instrument_part(heads: Sequence[Headline], weights: np.ndarray, st: Mapping[str, float], notes: List[str]
                     ) -> Optional[Dict[str, float]]:  # fmt: skip
    """The instrument's part of the tests' budgets (docs/method.md 6i): shared, so it does not average out.

    The tests are compared on their statistical scatter (their headlines'
    intervals); the instrument's standard uncertainty, common to every test
    on one instrument (a systematic error), is the weighted mean of theirs
    and widens the mean's interval as sqrt(h^2 + (1.96 u)^2).
    """
    budgets = [h.uncertainty for h in heads]
    if all(b is None for b in budgets):
        return None
    if any(b is None for b in budgets):
        notes.append("only some tests carry an uncertainty budget: the instrument's part is left out of the comparison")
        return None
    u = float(np.sum(weights * np.array([b.instrument_u for b in budgets if b is not None])))
    names = {b.instrument for b in budgets if b is not None}
    half = 0.5 * (st["high"] - st["low"])
    h = math.hypot(half, Z975 * u)
    notes.append(
        "the tests are compared on their statistical scatter; the instrument's part of their budgets "
        f"(u {u:.2g}) is common to every test"
        + (" (one instrument)" if len(names) == 1 else " (stated for different instruments; taken as shared)")
        + f": it does not shrink with their number; the mean with it: {st['mean'] - h:.4g} to {st['mean'] + h:.4g}"
    )
    return {"u": u, "low": st["mean"] - h, "high": st["mean"] + h}


# -- the figure -------------------------------------------------------------------------


def _forest(cmp: Comparison) -> "Figure":
    """Tests top to bottom: value and 95 % interval, coloured by group; the mean, its band and the prediction."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    k = cmp.k
    fig = Figure(figsize=(7.5, 2.2 + 0.32 * (k + 2)), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    groups = list(dict.fromkeys(r.group for r in cmp.replicates if r.group is not None))
    colours = {g: f"C{i % 10}" for i, g in enumerate(groups)}
    band = f"mean, 95 % interval ({cmp.low:.4g} to {cmp.high:.4g})"
    ax.axvspan(cmp.low, cmp.high, color="0.85", zorder=0, label=band)
    ax.axvline(cmp.mean, color="0.3", lw=1.2, zorder=1)
    if math.isfinite(cmp.prediction_low):
        for x in (cmp.prediction_low, cmp.prediction_high):
            ax.axvline(x, color="0.5", lw=0.9, ls=":", zorder=1)
        ax.plot([], [], color="0.5", lw=0.9, ls=":", label="95 % prediction for a further test")
    seen: set[str] = set()
    for i, r in enumerate(cmp.replicates):
        yv = k - i
        c = colours.get(r.group, "C0") if r.group is not None else "C0"
        lab = None
        if r.group is not None and r.group not in seen:
            lab = f"group {r.group}"
            seen.add(r.group)
        if math.isfinite(r.low) and math.isfinite(r.high):
            ax.errorbar(r.value, yv, xerr=[[r.value - r.low], [r.high - r.value]], fmt="o", color=c, ms=5,
                        capsize=3, lw=1.2, label=lab, zorder=3)  # fmt: skip
        else:
            ax.plot(r.value, yv, "o", mfc="white", color=c, ms=5, label=lab, zorder=3)
    d = 0.3
    ax.fill([cmp.low, cmp.mean, cmp.high, cmp.mean], [-1, -1 + d, -1, -1 - d], color="0.2", zorder=3)
    ax.set_yticks([k - i for i in range(k)] + [-1])
    ax.set_yticklabels([r.label for r in cmp.replicates] + [f"mean of {k}"])
    ax.set_ylim(-1.8, k + 0.8)
    ax.axhline(0, color="0.7", lw=0.6)
    what = f"{cmp.method} {cmp.statistic}" if cmp.method != "mixed" else "mixed methods"
    ax.set_xlabel(f"COF (each test's headline: {what}; bars: 95 % interval)")
    ax.set_title(f"{k} tests: mean COF {cmp.mean:.4g} (95 % {cmp.low:.4g} to {cmp.high:.4g})", fontsize=10)
    ax.grid(axis="x", alpha=0.3)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2, fontsize=8, frameon=False)
    return fig
