"""Operating ranges: COF against temperature, current density or any covariate
(docs/method.md sections 7 and 7a, paper Secs. 4.1-4.2).

The covariate (``by``) is a column of the per-window table or the name of
a role or log: "temperature" (``T``), "current_density" (``J``), "current"
(``i``), "speed" (``speed``, m/s, fitted on a log axis: a Stribeck curve),
"load" (|``fz_mean``|, N) or a covariate log given to
:func:`tribodyn.analyze`. The COF fitted is the one the headline uses
(``cof="auto"``): the dynamic ``mu_r`` of the gated windows, or the
classical ``mu_classical`` of each window when the dynamic method does not
apply (a dead weight).

``method="segmented"`` (the default) fits a continuous, flat-bottomed
piecewise-linear curve ("bathtub") to the COF of the usable windows against
the covariate, weighted by the windows' standard errors
(:mod:`tribodyn.analyses.segmented`): the flat bottom is the optimum, its height the
minimum COF, the walls the rise on either side (either may be absent). For
temperature the heating and cooling branches are fitted apart (plateau
windows, branch 0, enter both), and their difference of breakpoints is the
hysteresis of Fig. 11. The walls the F-tests keep are then refitted
curved (:mod:`tribodyn.analyses.walls`: a curved onset and a flat shoulder), so a
breakpoint is where the COF leaves its floor. 95 % intervals come from a
moving-block bootstrap over time with a fixed seed; a breakpoint's interval
is joined with its profile-likelihood interval, widened by the covariate's
reading noise (the temperature log's) and moved out to the nearest tested
covariates. The instability onset is read from the windows before contact
loss (contact loss can lower the measured current). The result says what it found in
``verdict``: "optimum", "optimum at the edge of the tested range", "no
dependence", "covariate constant" or "too few windows", with a sentence.

Usable windows passed the quality gate (so no "contact loss" window, see
:mod:`tribodyn.kernels.contact_loss`), have a finite COF, standard error and
covariate, and, for temperature, do not lie in a fast log gap
(``T_gap``, :func:`tribodyn.pipeline.covariates.log_quality`); the others are
counted by reason in ``excluded``.

``method="binned"`` is the earlier method, kept as it was: the gated COF is
binned on the covariate (median per bin); the optimum is the contiguous run
of bins around the lowest median whose medians stay within ``tol``
(relative) of that minimum; the onset is the first covariate value above
the optimum where the binned COF reaches ``(1 + rise)`` times the minimum.
Both methods return the binned curves (``curves``), drawn as points.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, Literal, NamedTuple, Optional, Sequence, Tuple

import numpy as np

from ..kernels.contact_loss import REASON as _CONTACT_LOSS
from ..kernels.quantiles import Z975
from ..results import Results
from .segmented import Fit, Selection, bootstrap_indices, fit_bathtub
from .walls import CurvedFit, bootstrap_curved, fit_curved, profile_interval

__all__ = ["RangeCurve", "OperatingRange", "BranchFit", "Hysteresis", "operating_range", "VERDICTS"]

#: A covariate: a column of the table or the name of a role or log (docs/method.md 7a).
By = str
Method = Literal["segmented", "binned"]
#: The COF fitted: the headline's ("auto"), the dynamic mu_r or the classical per-window COF.
Cof = Literal["auto", "dynamic", "classical"]
_BRANCHES = {"heating": 1, "cooling": -1}

#: The verdicts of :func:`operating_range` (docs/method.md 7).
VERDICTS = (
    "optimum",
    "no dependence",
    "covariate constant",
    "optimum at the edge of the tested range",
    "too few windows",
)
#: Fewest usable windows a fit needs (5 parameters and walls of 3 windows).
MIN_WINDOWS = 10
#: The constant-covariate threshold of a covariate without its own, relative to its largest |value|.
RELATIVE_RESOLUTION = 0.01


@dataclass(frozen=True)
class Covariate:
    """What :func:`operating_range` fits against (docs/method.md 7a).

    Attributes
    ----------
    by : str
        The name reported (``OperatingRange.by``).
    column : str
        The table column read.
    unit : str
    log : bool
        Fitted on a log10 axis (breakpoints and intervals reported in the column's unit).
    magnitude : bool
        The column's absolute value (a load from a signed fz).
    width : float or None
        Default bin width of the binned curves, in fit units (decades when ``log``); None: a tenth of the range.
    resolution : float or None
        Spread below which the covariate is constant, in fit units; None: :data:`RELATIVE_RESOLUTION`.
    needs : str
        What analyze needs to fill the column (for the error saying it is empty).
    """

    by: str
    column: str
    unit: str
    log: bool = False
    magnitude: bool = False
    width: Optional[float] = None
    resolution: Optional[float] = None
    needs: str = ""

    def inverse(self, x: Any) -> Any:
        """A value in fit units in the column's unit (10**x on a log axis); None stays None."""
        if x is None or not self.log:
            return x
        return 10.0 ** float(x)


_KNOWN = (
    Covariate("temperature", "T", "degC", width=5.0, resolution=1.0, needs="a temperature log"),
    Covariate("current_density", "J", "A/mm^2", width=0.5, resolution=0.05, needs="a current and area_mm2"),
    Covariate("current", "i", "A", width=0.5, resolution=0.05, needs="a current (channel i, u or current=)"),
    Covariate(
        "speed", "speed", "m/s", log=True, width=0.25, resolution=0.05, needs="a velocity channel v or a speed log"
    ),
    Covariate("load", "fz_mean", "N", magnitude=True, needs="forces with their static level (fz_mean)"),
)
#: Below this spread (max - min over the usable windows) the covariate
#: counts as constant: 1 degC, 0.05 A/mm^2, 0.05 A; for speed 0.05 decades
#: of its log axis (a factor 1.12). Other covariates: 1 % of their largest
#: magnitude (:data:`RELATIVE_RESOLUTION`).
RESOLUTION = {c.by: c.resolution for c in _KNOWN if c.resolution is not None}
#: Names of the known covariates and of their roles and columns (docs/method.md 7a).
_ALIASES: Dict[str, Covariate] = {
    **{c.by: c for c in _KNOWN},
    **{c.column: c for c in _KNOWN if c.column != "fz_mean"},
    "v": _KNOWN[3], "velocity": _KNOWN[3], "sliding_speed": _KNOWN[3],
    "normal_load": _KNOWN[4], "fz": _KNOWN[4], "fn": _KNOWN[4],
}  # fmt: skip


def covariate(results: Results, by: str, log: Optional[bool] = None) -> Covariate:
    """The covariate ``by`` names in ``results`` (docs/method.md 7a): a known name or role, else a float column.

    A known name (:data:`_ALIASES`: temperature, current_density, current,
    speed, load and their roles and columns) comes first unless the table
    has a covariate log of that name; then any float column of the table.
    ``log`` overrides the axis (default: log for speed only).
    """
    from ..columns import UNITS

    if not isinstance(by, str):
        raise TypeError(f"by must be a column or covariate name (a string), got {type(by).__name__}")
    table = results.table
    spec = _ALIASES.get(by) if by in _ALIASES and not (by in table and by not in UNITS) else None
    if spec is None:
        if by not in table or np.asarray(table[by]).dtype.kind != "f":
            known = ", ".join(c.by for c in _KNOWN)
            logs = [k for k in table if k not in UNITS]
            more = f", the covariate logs {', '.join(logs)}" if logs else ""
            raise ValueError(f"by must be {known}{more} or a numeric column of the table (e.g. fz_std), got {by!r}")
        spec = Covariate(by, by, UNITS.get(by, ""), needs=f"the column {by}")
    if log is not None:
        if not isinstance(log, (bool, np.bool_)):
            raise TypeError(f"log must be True, False or None, got {log!r}")
        if bool(log) != spec.log:
            spec = dataclasses.replace(spec, log=bool(log), width=None, resolution=None)
    return spec


#: Level of the F-tests that choose the model (docs/method.md 7).
ALPHA = 0.01
Interval = Tuple[float, float]


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
class BranchFit:
    """The segmented fit of one branch ("all", "heating" or "cooling"; docs/method.md 7).

    Attributes
    ----------
    branch : str
    verdict : str
        One of :data:`VERDICTS`.
    explanation : str
        The verdict in one sentence.
    n_windows : int
        Windows in the fit.
    family : str
        "flat", "lower", "upper" or "both": the walls the data support.
    optimum : (float, float) or None
        The flat bottom; an absent wall's side is the end of the tested
        range. None unless the verdict is an optimum.
    optimum_ci : ((float, float), (float, float)) or None
        95 % intervals of the lower and upper end; an absent wall's side is
        ``(-inf, x_min)`` or ``(x_max, inf)``: the edge lies at or beyond
        the tested range.
    lower, upper : float or None
        Breakpoints (None when that wall is absent).
    lower_ci, upper_ci : (float, float) or None
        Their 95 % intervals.
    mu_min, mu_min_ci : float, (float, float) or None
        Height of the flat bottom (the weighted mean for a flat fit).
    onset, onset_ci : float or None, (float, float) or None
        Where the upper wall reaches ``(1 + rise) mu_min``; None beyond the
        tested range (the interval's upper end is then inf).
    slope_lower, slope_upper : float
        Wall slopes (COF per covariate unit; 0 when absent).
    edge_lower, edge_upper : bool
        The optimum's end is the end of the tested range (that wall absent).
    p_flat : float
        F-test p-value of the flat fit against the best wall model.
    tau : float
        Between-window standard deviation added to the standard errors.
    x_range : (float, float)
        Tested covariate range (usable windows).
    grid, curve, band_low, band_high : ndarray
        The fit and its 95 % pointwise bootstrap band on a grid of the range.
    shape_lower, shape_upper : (float, float) or None
        The curved wall's onset width ``w`` and reach ``c`` (flat beyond;
        inf: no shoulder), in fit units (decades on a log axis); None when
        the wall is absent (docs/method.md 7, :mod:`tribodyn.analyses.walls`).
    """

    branch: str
    verdict: str
    explanation: str
    n_windows: int
    family: str
    optimum: Optional[Interval]
    optimum_ci: Optional[Tuple[Interval, Interval]]
    lower: Optional[float]
    lower_ci: Optional[Interval]
    upper: Optional[float]
    upper_ci: Optional[Interval]
    mu_min: float
    mu_min_ci: Optional[Interval]
    onset: Optional[float]
    onset_ci: Optional[Interval]
    slope_lower: float
    slope_upper: float
    edge_lower: bool
    edge_upper: bool
    p_flat: float
    tau: float
    x_range: Interval
    grid: np.ndarray
    curve: np.ndarray
    band_low: np.ndarray
    band_high: np.ndarray
    shape_lower: Optional[Interval] = None
    shape_upper: Optional[Interval] = None


@dataclass(frozen=True)
class Hysteresis:
    """Heating minus cooling breakpoints, with 95 % intervals from the same bootstrap resamples (docs/method.md 7).

    ``lower``/``upper`` are None when a branch lacks that wall.
    """

    lower: Optional[float]
    lower_ci: Optional[Interval]
    upper: Optional[float]
    upper_ci: Optional[Interval]


@dataclass(frozen=True)
class OperatingRange:
    """Result of :func:`operating_range` (docs/method.md section 7).

    ``optimum``, ``optimum_ci``, ``mu_min`` (and interval), ``onset`` (and
    interval), the edge flags, ``verdict`` and ``explanation`` are those of
    the fit of the requested branch (``fits[branch or "all"]``). ``curves``
    holds the binned medians ("all", and for temperature "heating" and
    "cooling"), which are the whole answer of ``method="binned"``.

    Attributes
    ----------
    by, unit : str
    bin_width, tol, rise : float
        The binned curves' settings; ``rise`` also defines ``onset``.
    curves : dict of RangeCurve
    optimum : (float, float) or None
    mu_min : float
    onset : float or None
    method : str
        "segmented" or "binned".
    branch : str or None
    verdict : str
        One of :data:`VERDICTS`.
    explanation : str
    optimum_ci, mu_min_ci, onset_ci
        95 % intervals (None for "binned").
    edge_lower, edge_upper : bool
    fits : dict of BranchFit
        "all", and for temperature "heating" and "cooling" when they have windows.
    hysteresis : Hysteresis or None
        Temperature only.
    n_windows : int
        Usable windows (all branches).
    excluded : dict of str -> int
        Windows left out, by reason: "gate", "contact loss", "temperature
        log gap", "no covariate", "no COF", "running-in" (on the start
        plateau) and "covariate step in the window" (docs/method.md 7).
    instability, instability_ci : float or None, (float, float) or None
        Instability onset: the covariate of the windows just before the
        first contact loss (the highest of the last three without contact
        loss), and the interval from the highest covariate held below it
        (by more than the resolution) without contact loss up to it
        (docs/method.md 7).
    contact_loss_onset : float or None
        Lowest covariate measured in a contact-loss window (what
        ``instability`` was before issue 23): contact loss can lower the
        measured current, so this may lie far below the onset.
    n_boot, seed : int
        Bootstrap resamples and the generator's seed.
    column : str
        The table column fitted against (``T``, ``J``, ``speed``, ...).
    log : bool
        Fitted on a log10 axis of the covariate (speed): breakpoints,
        intervals, the onset, ``x_range`` and ``grid`` are in the column's
        unit, wall slopes in COF per decade, ``bin_width`` in decades; an
        absent wall's interval starts at 0 instead of -inf.
    cof : str
        The COF fitted: "dynamic" (``mu_r`` of the gated windows, weighted
        by ``mu_r_stderr``) or "classical" (``mu_classical`` of each
        window, equal weights; docs/method.md 7a).
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
    method: str = "binned"
    branch: Optional[str] = None
    verdict: str = ""
    explanation: str = ""
    optimum_ci: Optional[Tuple[Interval, Interval]] = None
    mu_min_ci: Optional[Interval] = None
    onset_ci: Optional[Interval] = None
    edge_lower: bool = False
    edge_upper: bool = False
    fits: Dict[str, BranchFit] = field(default_factory=dict)
    hysteresis: Optional[Hysteresis] = None
    n_windows: int = 0
    excluded: Dict[str, int] = field(default_factory=dict)
    instability: Optional[float] = None
    instability_ci: Optional[Interval] = None
    n_boot: int = 0
    seed: int = 0
    column: str = ""
    log: bool = False
    cof: str = "dynamic"
    contact_loss_onset: Optional[float] = None

    def to_dict(self) -> Dict[str, Any]:
        """The JSON-ready essentials (for ``summary.json`` and the report)."""
        out: Dict[str, Any] = {
            "by": self.by,
            "unit": self.unit,
            "method": self.method,
            "branch": self.branch,
            "verdict": self.verdict,
            "explanation": self.explanation,
            "optimum": self.optimum,
            "optimum_ci": self.optimum_ci,
            "mu_min": self.mu_min,
            "mu_min_ci": self.mu_min_ci,
            "onset": self.onset,
            "onset_ci": self.onset_ci,
            "edge_lower": self.edge_lower,
            "edge_upper": self.edge_upper,
            "n_windows": self.n_windows,
            "excluded": dict(self.excluded),
            "instability": self.instability,
            "instability_ci": self.instability_ci,
            "contact_loss_onset": self.contact_loss_onset,
            "bin_width": self.bin_width,
            "tol": self.tol,
            "rise": self.rise,
            "column": self.column,
            "scale": "log" if self.log else "linear",
            "cof": self.cof,
        }
        for name, f in self.fits.items():
            if name == "all":
                continue
            out[f"fit_{name}"] = {
                k: getattr(f, k)
                for k in ("verdict", "n_windows", "optimum", "optimum_ci", "mu_min", "mu_min_ci", "onset", "onset_ci")
            }
        if self.hysteresis is not None:
            h = self.hysteresis
            out["hysteresis"] = {"lower": h.lower, "lower_ci": h.lower_ci, "upper": h.upper, "upper_ci": h.upper_ci}
        if self.method == "segmented":
            out["bootstrap"] = {"n_boot": self.n_boot, "seed": self.seed}
        return out


@dataclass(frozen=True)
class _Binning:
    """The binned curves' settings (``method="binned"``, docs/method.md 7).

    ``width`` is the bin width in fit units; a bin's median counts when it
    has ``min_count`` windows; the optimum is the run of bins within ``tol``
    (relative) of the lowest median, the onset where the medians reach
    ``(1 + rise)`` times it.
    """

    width: float
    tol: float
    rise: float
    min_count: int


def _curve(cov: np.ndarray, mu: np.ndarray, edges: np.ndarray, bins: _Binning) -> RangeCurve:
    tol, rise, min_count = bins.tol, bins.rise, bins.min_count
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


def _pct(v: np.ndarray) -> Optional[Interval]:
    """95 % percentile interval of bootstrap values (NaN replicates dropped; None if most are NaN)."""
    v = np.asarray(v, dtype=float)
    v = v[~np.isnan(v)]
    if v.size < 20:
        return None
    lo, hi = np.percentile(v, [2.5, 97.5])
    return float(lo), float(hi)


#: Largest factor by which autocorrelated residuals widen the profile interval.
MAX_INFLATION = 10.0


def _profile_scale(x: np.ndarray, y: np.ndarray, w: np.ndarray, f: CurvedFit, overlap: float = 1.0) -> float:
    """Residual variance of the curved fit times the windows' overlap and the autocorrelation inflation
    (1 + rho) / (1 - rho).

    Windows that share samples (``overlap`` = window / hop > 1) repeat each
    residual that many times, so a residual sum grows ``overlap`` times faster
    than its information; rho is the autocorrelation of the weighted
    residuals in time order at a lag of one window (``overlap`` windows: the
    nearest window sharing no sample; neighbouring windows share a slow
    drift), the factor at least 1 and at most :data:`MAX_INFLATION`; the
    fit's parameters: m and, per wall, a, b, w, c (docs/method.md 7).
    """
    r = np.sqrt(w) * (y - f.predict(x))
    p = 1 + 4 * ((f.family in ("lower", "both")) + (f.family in ("upper", "both")))
    k = max(float(overlap), 1.0)
    s2 = float(r @ r) / max(len(r) / k - p, 1.0) / k
    lag = max(1, int(round(k)))
    rho = float(np.corrcoef(r[:-lag], r[lag:])[0, 1]) if len(r) > lag + 3 and np.std(r) > 0 else 0.0
    rho = min(max(rho, 0.0), 0.99) if np.isfinite(rho) else 0.0
    return k * s2 * min((1.0 + rho) / (1.0 - rho), MAX_INFLATION)


def _hull(ci: Optional[Interval], prof: Any, rss_min: float, scale: float) -> Optional[Interval]:
    """The bootstrap interval joined with the profile-likelihood interval (either may be missing)."""
    pi = profile_interval(prof, rss_min, scale) if prof is not None and np.isfinite(scale) else (math.nan, math.nan)
    if not np.isfinite(pi[0]):
        return ci
    if ci is None:
        return pi
    return min(ci[0], pi[0]), max(ci[1], pi[1])


def _widen(ci: Optional[Interval], b: float, x_noise: float) -> Optional[Interval]:
    """Each half of ``ci`` (about the estimate ``b``) joined in quadrature with 1.96 times the covariate's noise.

    The covariate is a reading (the temperature is a log interpolated
    between readings, each with its noise): an edge found at a reading is
    the true edge only up to that reading's error (docs/method.md 7).
    """
    if ci is None or not (x_noise > 0 and np.isfinite(b)):
        return ci
    e = (Z975 * x_noise) ** 2
    return b - math.sqrt(max(b - ci[0], 0.0) ** 2 + e), b + math.sqrt(max(ci[1] - b, 0.0) ** 2 + e)


def _to_data(ci: Optional[Interval], x: np.ndarray) -> Optional[Interval]:
    """A breakpoint's interval out to the nearest tested covariates (docs/method.md 7).

    Between two tested values (a current density held at steps) the COF is
    not observed, so the data cannot place an edge inside that gap: the
    interval's ends move out to the nearest window covariate below and above.
    """
    if ci is None:
        return None
    below, above = x[x <= ci[0]], x[x >= ci[1]]
    return (float(below.max()) if below.size else ci[0], float(above.min()) if above.size else ci[1])


def _onset(f: CurvedFit, rise: float, x_max: float) -> float:
    """Where the upper wall reaches (1 + rise) m; inf beyond the tested range (or its reach), NaN without a wall."""
    if not (f.a_hi > 0 and np.isfinite(f.b_hi)):
        return math.inf if np.isfinite(f.m) else math.nan
    x = f.b_hi + f.rise_at(rise * abs(f.m))
    return x if x <= x_max else math.inf


def _curved(f: Fit) -> CurvedFit:
    """A straight-walled fit as a :class:`~tribodyn.analyses.walls.CurvedFit` (onset width 0, no reach)."""
    return CurvedFit(f.family, f.m, f.a_lo, f.a_hi, f.b_lo, f.b_hi, f.rss)


#: The windows' key in ``OperatingRange.excluded`` of a running-in on the start plateau (issue 35).
RUNNING_IN = "running-in"


class _RunningIn(NamedTuple):
    """A running-in fitted on the start plateau: its end t_steady, start t0, amplitude and shape (0 exponential, 1
    linear; :mod:`tribodyn.analyses.steady`), and how many of the windows given make the plateau."""

    end: float
    t0: float
    amp: float
    shape: int
    plateau: int

    def tail(self, t: np.ndarray) -> np.ndarray:
        """The fitted transient at times ``t`` (at most 2 % of its amplitude from ``end`` on)."""
        from .steady import _shapes

        return np.asarray(self.amp * _shapes(np.asarray(t, dtype=float), self.t0, np.array([self.end]), self.shape)[0])


def _running_in(t: np.ndarray, x: np.ndarray, y: np.ndarray, resolution: float, overlap: float) -> Optional[_RunningIn]:
    """The running-in of the start plateau (:func:`running_in_end`), or None."""
    from .steady import MAX_POINTS, _average, _fit_rows, _grid, _shapes

    if t.size < MIN_WINDOWS:
        return None
    x0 = float(np.median(x[:MIN_WINDOWS]))
    away = np.flatnonzero(np.abs(x - x0) > resolution)
    if not away.size:
        return None
    stride = max(1, int(round(overlap)))
    tt, yy = t[: int(away[0]) : stride], y[: int(away[0]) : stride]
    if tt.size < MIN_WINDOWS or not tt[-1] > tt[0]:
        return None
    if tt.size > MAX_POINTS:
        tt, yy = _average(tt, yy, MAX_POINTS)
    t0 = float(tt[0])
    grid = _grid(tt, t0)
    fit = _fit_rows(yy[None, :], tt, t0, grid, np.stack([_shapes(tt, t0, grid, 0), _shapes(tt, t0, grid, 1)]))
    code = int(fit.code[0])
    return _RunningIn(float(fit.ts[0]), t0, float(fit.amp[0]), code - 1, int(away[0])) if code else None


def running_in_end(t: np.ndarray, x: np.ndarray, y: np.ndarray, resolution: float, overlap: float = 1.0) -> float:
    """Where a running-in on the start plateau ends (s; -inf when there is none), docs/method.md 7.

    The start plateau: the usable windows (``t`` their times, ``x`` covariate, ``y`` COF, in time order) from the
    first up to the first whose covariate leaves the median of the first :data:`MIN_WINDOWS` by more than
    ``resolution``; none when they all stay (the covariate is then constant) or fewer than :data:`MIN_WINDOWS`
    independent windows are there. On one window per window length of it (``overlap``: windows sharing each sample,
    so the answer does not depend on the hop), the running-in fit of docs/method.md 6h (flat, exponential or linear
    transient, F-test at 1 % with the noise's autocorrelation): a transient ends at its t_steady, beyond which at
    most 2 % of it is left. A COF that changes over time at one covariate is no wall: the windows before it stay out
    of the fit, and the fitted transient's tail is taken off the COF of those after it.
    """
    r = _running_in(t, x, y, resolution, overlap)
    return -math.inf if r is None else r.end


def _without_running_in(
    results: Results, cov: np.ndarray, mu: np.ndarray, usable_excluded: Tuple[np.ndarray, Dict[str, int]], *,
    resolution: float, shared: float,
) -> Tuple[np.ndarray, Dict[str, int], np.ndarray]:  # fmt: skip
    """The usable windows less those of a running-in on the start plateau (:func:`running_in_end`), counted in
    ``excluded`` as :data:`RUNNING_IN`, and the COF less the fitted transient's tail after it."""
    usable, excluded = usable_excluded
    pos = np.flatnonzero(usable)
    t = np.asarray(results["time"], dtype=float)
    r = _running_in(t[pos], cov[pos], mu[pos], resolution, shared) if pos.size else None
    if r is None:
        return usable, excluded, mu
    plateau = pos[: r.plateau]
    out = plateau[t[plateau] < r.end]
    after = pos[t[pos] >= r.end]
    mu = mu.copy()
    mu[after] = mu[after] - r.tail(t[after])
    if not out.size:
        return usable, excluded, mu
    usable = usable.copy()
    usable[out] = False
    return usable, {**excluded, RUNNING_IN: int(out.size)}, mu


#: The windows' key in ``OperatingRange.excluded`` that straddle a step of the covariate (issue 35).
STEPPED = "covariate step in the window"


def _without_steps(
    results: Results, cov: np.ndarray, usable_excluded: Tuple[np.ndarray, Dict[str, int]], *, resolution: float,
    by: str,
) -> Tuple[np.ndarray, Dict[str, int]]:  # fmt: skip
    """The usable windows less those that straddle a step of the covariate (not :func:`held`), counted in
    ``excluded`` as :data:`STEPPED`: such a window reads a mixture of two levels and a COF mixed from both, which
    is no point of the curve; at a hop shorter than the window several windows straddle each step, at a hop of a
    window at most one (docs/method.md 7). Temperature is read from a log interpolated between readings, which has
    no steps within a window: its windows are all kept."""
    usable, excluded = usable_excluded
    if by == "temperature":
        return usable, excluded
    out = usable & ~held(results, cov, resolution)
    if not out.any():
        return usable, excluded
    return usable & ~out, {**excluded, STEPPED: int(out.sum())}


def _excluded(
    results: Results, by: str, cov: np.ndarray, fitted: _FittedCof, nonpositive: Optional[np.ndarray] = None
) -> Tuple[np.ndarray, Dict[str, int]]:
    """Usable windows and the others counted by reason; ``fitted.ok`` the windows the COF allows (the rest are
    counted as "gate" for the dynamic COF, "stroke reversal" for the classical)."""
    mu, se, ok = fitted.mu, fitted.se, fitted.ok
    gate = "gate" if fitted.which == "dynamic" else "stroke reversal"
    reasons = np.asarray(results["reasons"]).astype(str)
    lost = np.char.find(reasons, _CONTACT_LOSS) >= 0
    gap = np.asarray(results.table.get("T_gap", np.zeros(len(ok), dtype=bool)), dtype=bool)
    if by != "temperature":
        gap = np.zeros(len(ok), dtype=bool)
    has = np.isfinite(cov)
    counts = {
        "no covariate": int((~has).sum()) - (0 if nonpositive is None else int(nonpositive.sum())),
        "covariate <= 0 (log axis)": 0 if nonpositive is None else int(nonpositive.sum()),
        "contact loss": int((has & lost).sum()),
        gate: int((has & ~ok & ~lost).sum()),
        "temperature log gap": int((has & ok & gap).sum()),
    }
    usable = has & ok & ~gap
    bad = usable & ~(np.isfinite(mu) & np.isfinite(se) & (se >= 0))
    counts["no COF"] = int(bad.sum())
    return usable & ~bad, {k: v for k, v in counts.items() if v}


@dataclass(frozen=True)
class _FitContext:
    """What the fits of every branch share: the covariate, its resolution (fit units), the relative rise
    that marks the onset, the covariate's reading noise (standard deviation, fit units) and how many windows share
    each sample (:func:`overlap`)."""

    cv: Covariate
    resolution: float
    rise: float
    x_noise: float = 0.0
    overlap: float = 1.0


def _explain(verdict: str, f: CurvedFit, sel: Optional[Selection], ctx: _FitContext, *, n: int, rng: Interval) -> str:
    """The verdict in one sentence; ``f``'s breakpoints and ``rng`` in the column's unit."""
    cv, resolution = ctx.cv, ctx.resolution
    what, unit = cv.by.replace("_", " "), cv.unit
    span = f"{rng[0]:.4g}-{rng[1]:.4g} {unit}"
    if verdict == "too few windows":
        return f"Only {n} usable windows (at least {MIN_WINDOWS} are needed), so no range is fitted."
    if verdict == "covariate constant":
        less = f"a factor {10.0**resolution:.3g}" if cv.log else f"{resolution:.3g} {unit}"
        return f"The {what} only spans {span} (less than {less}), so the COF's dependence on it cannot be identified."
    p = sel.p_flat if sel is not None else float("nan")
    if verdict == "no dependence":
        return (
            f"A constant COF of {f.m:.4f} fits as well as a bathtub (F-test p = {p:.2g} >= {ALPHA:g}): the COF "
            f"does not depend on the {what} over {span}."
        )
    lo = f"{f.b_lo:.4g}" if np.isfinite(f.b_lo) else None
    hi = f"{f.b_hi:.4g}" if np.isfinite(f.b_hi) else None
    if verdict == "optimum":
        return (
            f"The COF is lowest ({f.m:.4f}) between {lo} and {hi} {unit} and rises on both sides "
            f"(flat fit rejected, p = {p:.2g})."
        )
    if lo is None:
        return (
            f"The COF is lowest ({f.m:.4f}) from the lowest tested {what}, {rng[0]:.4g} {unit}, up to {hi} {unit}: "
            "the optimum may extend below the tested range."
        )
    return (
        f"The COF is lowest ({f.m:.4f}) from {lo} {unit} up to the highest tested {what}, {rng[1]:.4g} {unit}: "
        "the optimum may extend above the tested range."
    )


def _branch_fit(
    name: str, x: np.ndarray, y: np.ndarray, se: np.ndarray, boot: Sequence[np.ndarray], *, ctx: _FitContext
) -> Tuple[BranchFit, Dict[str, np.ndarray]]:
    """The fit of one branch and its bootstrap draws (``boot``: resampled positions into x; x in fit units)."""
    bf, draws = _branch_fit_units(name, x, y, se, boot, ctx=ctx)
    return _in_column_units(bf, ctx.cv), draws


def _in_column_units(bf: BranchFit, cv: Covariate) -> BranchFit:
    """A fit on a log axis with its covariate values in the column's unit (docs/method.md 7a)."""
    if not cv.log:
        return bf
    inv: Callable[[Any], Any] = cv.inverse

    def pair(p: Any) -> Any:
        return None if p is None else (inv(p[0]), inv(p[1]))

    return dataclasses.replace(
        bf, optimum=pair(bf.optimum),
        optimum_ci=None if bf.optimum_ci is None else (pair(bf.optimum_ci[0]), pair(bf.optimum_ci[1])),
        lower=inv(bf.lower), lower_ci=pair(bf.lower_ci), upper=inv(bf.upper), upper_ci=pair(bf.upper_ci),
        onset=inv(bf.onset), onset_ci=pair(bf.onset_ci), x_range=pair(bf.x_range), grid=10.0**bf.grid,
    )  # fmt: skip


def _branch_fit_units(
    name: str, x: np.ndarray, y: np.ndarray, se: np.ndarray, boot: Sequence[np.ndarray], *, ctx: _FitContext
) -> Tuple[BranchFit, Dict[str, np.ndarray]]:
    n = len(x)
    grid = np.linspace(float(x.min()), float(x.max()), 121) if n else np.zeros(0)
    rng: Interval = (float(x.min()), float(x.max())) if n else (math.nan, math.nan)
    inverse = ctx.cv.inverse
    shown: Interval = (inverse(rng[0]), inverse(rng[1])) if n else rng

    def explain(verdict: str, f: CurvedFit, sel: Optional[Selection]) -> str:
        g = dataclasses.replace(f, b_lo=inverse(f.b_lo), b_hi=inverse(f.b_hi))
        return _explain(verdict, g, sel, ctx, n=n, rng=shown)

    if n < MIN_WINDOWS or not (rng[1] - rng[0] >= ctx.resolution):
        verdict = "too few windows" if n < MIN_WINDOWS else "covariate constant"
        return _unfitted_branch(name, verdict, y, se, rng=rng, grid=grid, explain=explain), {}
    sel = fit_bathtub(x, y, se, alpha=ALPHA, overlap=ctx.overlap)
    f, sides, prof = _curved_walls(x, y, sel)
    draws, curves = _bootstrap(x, y, sel.weights, f, boot, sides=sides, grid=grid, rise=ctx.rise, x_max=rng[1])
    empty = np.full(len(grid), np.nan)
    band_lo, band_hi = (np.nanpercentile(curves, q, axis=0) for q in (2.5, 97.5)) if np.isfinite(
        curves).any() else (empty, empty)  # fmt: skip
    has_lo, has_hi = f.family in ("lower", "both"), f.family in ("upper", "both")
    verdict = _verdict_of(f)
    lower_ci, upper_ci = _breakpoint_intervals(x, y, sel, f, draws, prof=prof, x_noise=ctx.x_noise,
                                               overlap=ctx.overlap)  # fmt: skip
    on = _onset(f, ctx.rise, rng[1])
    onset_ci = _onset_interval(draws["onset"], rng[1]) if has_hi else None
    optimum, optimum_ci = _optimum(f, verdict, rng, lower_ci, upper_ci)
    bf = BranchFit(
        branch=name,
        verdict=verdict,
        explanation=explain(verdict, f, sel),
        n_windows=n,
        family=f.family,
        optimum=optimum,
        optimum_ci=optimum_ci,
        lower=f.b_lo if has_lo else None,
        lower_ci=lower_ci,
        upper=f.b_hi if has_hi else None,
        upper_ci=upper_ci,
        mu_min=f.m,
        mu_min_ci=_pct(draws["m"]),
        onset=on if np.isfinite(on) else None,
        onset_ci=onset_ci,
        slope_lower=f.a_lo,
        slope_upper=f.a_hi,
        edge_lower=verdict != "no dependence" and not has_lo,
        edge_upper=verdict != "no dependence" and not has_hi,
        p_flat=sel.p_flat,
        tau=math.sqrt(sel.tau2),
        x_range=rng,
        grid=grid,
        curve=f.predict(grid),
        band_low=band_lo,
        band_high=band_hi,
        shape_lower=(f.w_lo, f.c_lo) if has_lo else None,
        shape_upper=(f.w_hi, f.c_hi) if has_hi else None,
    )
    return bf, draws


def _unfitted_branch(
    name: str, verdict: str, y: np.ndarray, se: np.ndarray, *, rng: Interval, grid: np.ndarray,
    explain: Callable[[str, CurvedFit, Optional[Selection]], str],
) -> BranchFit:  # fmt: skip
    """A branch too small or too narrow to fit (``verdict``): its weighted mean COF, flat, without intervals."""
    n = len(y)
    empty = np.full(len(grid), np.nan)
    w = 1.0 / np.maximum(se, 1e-12) ** 2 if n else np.zeros(0)
    m = float(np.sum(w * y) / np.sum(w)) if n else math.nan
    f = CurvedFit("flat", m, 0.0, 0.0, math.nan, math.nan, math.nan)
    return BranchFit(
        name, verdict, explain(verdict, f, None), n, "flat", None, None, None, None, None,
        None, m, None, None, None, 0.0, 0.0, False, False, math.nan, math.nan, rng, grid,
        np.full(len(grid), m), empty, empty,
    )  # fmt: skip


def _curved_walls(x: np.ndarray, y: np.ndarray, sel: Selection) -> Tuple[CurvedFit, Dict[str, Any], Dict[str, Any]]:
    """The selected family's walls refitted curved, with each wall's fit ("sides") and profile ("prof").

    The family is chosen with straight walls (F-tests, :func:`fit_bathtub`);
    its walls are then refitted curved (tribodyn.analyses.walls): the
    breakpoint is where the COF leaves its floor, not where a straight line
    through a bent wall meets it. A flat fit, or walls that could not be
    curved, keep the straight fit with no sides and no profile.
    """
    f = _curved(sel.fit)
    sides: Dict[str, Any] = {}
    prof: Dict[str, Any] = {}
    if f.family != "flat":
        g, sides, prof = fit_curved(x, y, sel.weights, f.family, start=(f.b_lo, f.b_hi))
        if np.isfinite(g.rss):
            f = g
        else:
            sides, prof = {}, {}
    return f, sides, prof


def _verdict_of(f: CurvedFit) -> str:
    """The verdict of a fitted branch from the walls its fit has."""
    if f.family == "flat":
        return "no dependence"
    if f.family == "both":
        return "optimum"
    return "optimum at the edge of the tested range"


def _breakpoint_intervals(
    x: np.ndarray, y: np.ndarray, sel: Selection, f: CurvedFit, draws: Dict[str, np.ndarray], *,
    prof: Dict[str, Any], x_noise: float, overlap: float = 1.0,
) -> Tuple[Optional[Interval], Optional[Interval]]:  # fmt: skip
    """95 % intervals of the lower and upper breakpoints (None for an absent wall): the bootstrap's joined with the
    profile's, widened by the covariate's reading noise, out to the nearest tested covariates (docs/method.md 7)."""
    has_lo, has_hi = f.family in ("lower", "both"), f.family in ("upper", "both")
    scale = _profile_scale(x, y, sel.weights, f, overlap) if prof else math.nan
    lower_ci = _to_data(_widen(_hull(_pct(draws["b_lo"]), prof.get("lo"), f.rss, scale), f.b_lo, x_noise), x) \
        if has_lo else None  # fmt: skip
    upper_ci = _to_data(_widen(_hull(_pct(draws["b_hi"]), prof.get("hi"), f.rss, scale), f.b_hi, x_noise), x) \
        if has_hi else None  # fmt: skip
    return lower_ci, upper_ci


def _optimum(
    f: CurvedFit, verdict: str, rng: Interval, lower_ci: Optional[Interval], upper_ci: Optional[Interval]
) -> Tuple[Optional[Interval], Optional[Tuple[Interval, Interval]]]:
    """The flat bottom and the intervals of its ends (an absent wall's side: the end of the tested range, its
    interval out to infinity); None, None when the COF does not depend on the covariate."""
    if verdict == "no dependence":
        return None, None
    has_lo, has_hi = f.family in ("lower", "both"), f.family in ("upper", "both")
    optimum = (f.b_lo if has_lo else rng[0], f.b_hi if has_hi else rng[1])
    lo_ci = lower_ci if has_lo else (-math.inf, rng[0])
    hi_ci = upper_ci if has_hi else (rng[1], math.inf)
    return optimum, ((lo_ci, hi_ci) if lo_ci is not None and hi_ci is not None else None)


def _bootstrap(
    x: np.ndarray, y: np.ndarray, weights: np.ndarray, f: CurvedFit, boot: Sequence[np.ndarray], *,
    sides: Dict[str, Any], grid: np.ndarray, rise: float, x_max: float,
) -> Tuple[Dict[str, np.ndarray], np.ndarray]:  # fmt: skip
    """The bootstrap draws of the fit ``f`` ("b_lo", "b_hi", "m", "onset") and each resample's curve on ``grid``.

    A resample is a count per window (``boot``: resampled positions into x);
    the chosen family is refitted on each with the same weights (its curved
    walls from ``sides``, :func:`tribodyn.analyses.walls.bootstrap_curved`; a flat
    fit, or walls that could not be curved, refit the mean only). A
    resample of fewer than :data:`MIN_WINDOWS` windows, or whose fit fails,
    draws NaN.
    """
    n = len(x)
    counts = np.zeros((len(boot), n))
    for b, idx in enumerate(boot):
        if len(idx) >= MIN_WINDOWS:
            counts[b] = np.bincount(idx, minlength=n)
    fitted = counts.sum(1) > 0
    draws = {k: np.full(len(boot), np.nan) for k in ("b_lo", "b_hi", "m", "onset")}
    curves = np.full((len(boot), len(grid)), np.nan)
    if f.family == "flat" or not sides:
        wc = counts * weights[None, :]
        with np.errstate(invalid="ignore", divide="ignore"):
            draws["m"] = np.where(fitted, (wc @ y) / wc.sum(1), np.nan)
        curves[:] = draws["m"][:, None]
        return draws, curves
    d = bootstrap_curved(x, y, weights, counts, fit=f, sides=sides)
    draws["m"] = np.where(fitted, d["m"], np.nan)
    draws["b_lo"] = np.where(fitted, d["b_lo"], np.nan)
    draws["b_hi"] = np.where(fitted, d["b_hi"], np.nan)

    def at(key: str, b: int, default: float) -> float:
        v = float(d[key][b])
        return default if math.isnan(v) else v

    for b in map(int, np.flatnonzero(np.isfinite(draws["m"]))):
        g = CurvedFit(f.family, at("m", b, 0.0), at("a_lo", b, 0.0), at("a_hi", b, 0.0), at("b_lo", b, math.nan),
                      at("b_hi", b, math.nan), 0.0, at("w_lo", b, 0.0), at("c_lo", b, math.inf),
                      at("w_hi", b, 0.0), at("c_hi", b, math.inf))  # fmt: skip
        draws["onset"][b] = _onset(g, rise, x_max)
        curves[b] = g.predict(grid)
    return draws, curves


def _onset_interval(onsets: np.ndarray, x_max: float) -> Optional[Interval]:
    """95 % interval of the onset from its bootstrap draws (None from fewer than 20 that are not NaN)."""
    v = onsets[~np.isnan(onsets)]
    if v.size < 20:
        return None
    # Resamples whose onset lies beyond the tested range count as +inf.
    lo_, hi_ = np.percentile(np.where(np.isinf(v), np.finfo(float).max, v), [2.5, 97.5])
    # An end beyond the tested range is interpolated towards a resample without onset: inf.
    return (math.inf if lo_ > x_max else float(lo_), math.inf if hi_ > x_max else float(hi_))


#: Non-lost windows just before the first contact loss whose covariate is the instability onset.
ONSET_WINDOWS = 3


def _spans(results: Results) -> Optional[Tuple[np.ndarray, np.ndarray]]:
    """Each window's start and end (s), from ``t_start`` and its samples ``n`` at the recording's rate; None when
    the table lacks them."""
    fs = results.params.get("fs")
    if "t_start" not in results.table or "n" not in results.table or not isinstance(fs, (int, float)) or not fs > 0:
        return None
    start = np.asarray(results["t_start"], dtype=float)
    return start, start + np.asarray(results["n"], dtype=float) / float(fs)


def overlap(results: Results) -> float:
    """How many windows share each sample: the windows' median length over the median step between their starts, at
    least 1 (window / hop; 1 without the table's spans). Fits and intervals count ``n / overlap`` independent windows,
    so that they depend on the recording, not on the hop (docs/method.md 7; issue 35)."""
    spans = _spans(results)
    if spans is None or len(spans[0]) < 2:
        return 1.0
    start, end = spans
    step = np.diff(np.sort(start))
    step = step[step > 0]
    if not step.size:
        return 1.0
    k = float(np.median(end - start)) / float(np.median(step))
    return max(k, 1.0) if np.isfinite(k) else 1.0


def held(results: Results, cov: np.ndarray, resolution: float) -> np.ndarray:
    """Windows that read a level the covariate held (docs/method.md 7): the windows overlapping one in time on its
    earlier side, or those on its later side (itself with either), read the same covariate within ``resolution``.
    A window that straddles a step of the covariate reads a mixture of two levels, unlike the windows overlapping it
    on either side; at a hop shorter than the window there are more of them, which is why the instability onset is
    read from held windows only (issue 35). Windows that overlap none (hop >= window) are all held, and so are those
    without a finite covariate."""
    n = len(cov)
    out = np.ones(n, dtype=bool)
    spans = _spans(results)
    if spans is None or n < 2:
        return out
    start, end = spans
    order = np.argsort(start, kind="stable")
    s, e, c = start[order], end[order], np.asarray(cov, dtype=float)[order]
    # Windows overlapping window k: those starting before its end and ending after its start (starts sorted).
    first = np.searchsorted(np.maximum.accumulate(e), s, side="right")
    last = np.searchsorted(s, e, side="left")
    ok = np.ones(n, dtype=bool)

    def same(v: np.ndarray) -> bool:
        v = v[np.isfinite(v)]
        return not v.size or float(v.max() - v.min()) <= resolution

    for k in np.flatnonzero(np.isfinite(c) & (last - first > 1)):
        ok[k] = same(c[first[k] : k + 1]) or same(c[k : last[k]])
    out[order] = ok
    return out


def _instability(
    results: Results, cov: np.ndarray, resolution: float
) -> Tuple[Optional[float], Optional[Interval], Optional[float]]:
    """The instability onset from the windows before contact loss, its interval and the lost windows' own onset.

    Contact loss can change the covariate it is measured by (a burned-out
    contact conducts less, so the measured current falls): the onset is the
    highest covariate of the last :data:`ONSET_WINDOWS` windows without
    contact loss before the first contact-loss window (in time), or the highest covariate of the contact-loss
    windows starting within one window of it when that is higher (contact loss only lowers the
    measured current, so it bounds the set point from below; a window overlapping the first may read its level whole),
    and its interval runs from the highest covariate below it by more than the
    resolution among the earlier held windows (:func:`held`) without contact loss (the last
    level held without losing contact) up to it, each end widened by half
    the resolution (the covariate is a reading). The third value is the
    lowest covariate measured in a contact-loss window (docs/method.md 7).
    """
    reasons = np.asarray(results["reasons"]).astype(str)
    lost = (np.char.find(reasons, _CONTACT_LOSS) >= 0) & np.isfinite(cov)
    if not lost.any():
        return None, None, None
    own = float(cov[lost].min())
    first = int(np.flatnonzero(lost)[0])
    before = np.flatnonzero(np.isfinite(cov[:first]) & ~lost[:first])
    if not before.size:
        return own, (own, own), own
    spans = _spans(results)
    lost_first = [first]
    if spans is not None:
        start, end = spans
        lost_first = np.flatnonzero(lost & (start >= start[first]) & (start < end[first])).tolist() or [first]
    # Contact loss only lowers the measured current: the first lost windows' covariate bounds its set point below.
    onset = max(float(cov[before[-ONSET_WINDOWS:]].max()), float(cov[lost_first].max()))
    # The last level held without losing contact: a window straddling a step reads a mixture (issue 35).
    steady = before[held(results, cov, resolution)[before]]
    steady = steady if steady.size else before
    lower = cov[steady][cov[steady] < onset - resolution]
    low = float(lower.max()) if lower.size else onset
    # Both ends are readings of the covariate: half its resolution either way.
    return onset, (low - 0.5 * resolution, onset + 0.5 * resolution), own


def _binned_curves(x: np.ndarray, y: np.ndarray, br: np.ndarray, by: str, bins: _Binning) -> Dict[str, RangeCurve]:
    """The binned curves of the COF ``y`` against the covariate ``x`` (fit units): "all", and for temperature
    each branch with windows (``br``: +1 heating, -1 cooling)."""
    width = bins.width
    # Bin centres on multiples of the width, so set points such as J = 4.5
    # A/mm^2 fall mid-bin, never on an edge.
    k_lo = int(np.floor(x.min() / width + 0.5))
    k_hi = int(np.floor(x.max() / width + 0.5))
    if k_hi - k_lo + 1 > MAX_BINS:
        raise ValueError(
            f"bin_width = {width:g} cuts the {by.replace('_', ' ')} range "
            f"[{x.min():g}, {x.max():g}] into {k_hi - k_lo + 1} bins; at most {MAX_BINS} are allowed"
        )
    edges = (np.arange(k_lo, k_hi + 2) - 0.5) * width
    curves = {"all": _curve(x, y, edges, bins)}
    if by == "temperature":
        for name, sign in _BRANCHES.items():
            sel = br == sign
            if sel.any():
                curves[name] = _curve(x[sel], y[sel], edges, bins)
    return curves


def _curve_in_column_units(c: RangeCurve, cv: Covariate) -> RangeCurve:
    """A binned curve of a log axis with its edges, centres, optimum and onset in the column's unit."""
    if not cv.log:
        return c
    opt = None if c.optimum is None else (cv.inverse(c.optimum[0]), cv.inverse(c.optimum[1]))
    return dataclasses.replace(c, edges=10.0**c.edges, centres=10.0**c.centres, optimum=opt,
                               onset=cv.inverse(c.onset))  # fmt: skip


class _FittedCof(NamedTuple):
    """The COF fitted (docs/method.md 7a): which ("dynamic" or "classical"), per window its value, its
    standard error, and whether the window may enter the fit."""

    which: str
    mu: np.ndarray
    se: np.ndarray
    ok: np.ndarray


def _cof_of(results: Results, cof: str) -> _FittedCof:
    """(which, COF, standard error, windows that may enter) of the COF fitted (docs/method.md 7a).

    "dynamic": mu_r of the windows that passed the quality gate, with its
    standard error. "classical": mu_classical of every window but those
    straddling a stroke reversal or losing contact, without a per-window
    standard error (zeros: equal weights, the scatter between windows is
    tau^2). "auto": "classical" when the headline is not the dynamic COF
    and some window has a classical COF, else "dynamic".
    """
    if cof not in ("auto", "dynamic", "classical"):
        raise ValueError(f"cof must be 'auto', 'dynamic' or 'classical', got {cof!r}")
    classical = np.asarray(results.table.get("mu_classical", np.full(len(results), np.nan)), dtype=float)
    which = cof
    if cof == "auto":
        dynamic = results.headline.method == "dynamic" or not np.isfinite(classical).any()
        which = "dynamic" if dynamic else "classical"
    if which == "dynamic":
        mu_r, stderr = np.asarray(results["mu_r"], dtype=float), np.asarray(results["mu_r_stderr"], dtype=float)
        return _FittedCof(which, mu_r, stderr, np.asarray(results.gated, dtype=bool))
    if not np.isfinite(classical).any():
        raise ValueError(
            "no window has a classical COF (mu_classical: forces with their static level, docs/method.md 6a); "
            "fit the dynamic COF with cof='dynamic'"
        )
    reasons = np.asarray(results["reasons"]).astype(str)
    ok = (np.char.find(reasons, "stroke reversal") < 0) & (np.char.find(reasons, _CONTACT_LOSS) < 0)
    return _FittedCof(which, classical, np.zeros(len(classical)), ok)


def operating_range(
    results: Results,
    by: By = "temperature",
    method: Method = "segmented",
    branch: Optional[str] = None,
    *,
    bin_width: Optional[float] = None,
    tol: float = 0.15,
    rise: float = 0.5,
    min_count: int = 1,
    n_boot: int = 400,
    seed: int = 0,
    block: Optional[int] = None,
    log: Optional[bool] = None,
    cof: Cof = "auto",
) -> OperatingRange:
    """Optimum covariate range of the COF, with 95 % intervals and a verdict (docs/method.md 7, 7a).

    Parameters
    ----------
    results : Results
        From :func:`tribodyn.analyze`, with the covariate's column filled
        in: ``T`` (a temperature log), ``J`` (a current and ``area_mm2``),
        ``speed`` (a velocity channel ``v`` or a speed log), ``fz_mean``
        (forces with their static level) or a covariate log.
    by : str
        The covariate: "temperature", "current_density", "current",
        "speed" (also "v", "velocity", "sliding_speed"), "load" (also
        "normal_load", "fz", "fn": |fz_mean| in N), the name of a covariate
        log given to :func:`tribodyn.analyze`, or any numeric column of the
        table (e.g. "T", "J", "speed", "fz_std"). Default "temperature".
    method : {"segmented", "binned"}
        "segmented" (default): the weighted bathtub fit with block-bootstrap
        intervals (docs/method.md 7). "binned": the earlier binned medians
        within ``tol`` of the minimum (no intervals; kept for comparison).
    branch : {None, "heating", "cooling"}
        Temperature only: whose fit the top-level fields report (default
        None: all usable windows together). Every branch is fitted anyway
        (``fits``), with the hysteresis between them.
    bin_width : float, optional
        Covariate bin width of the binned curves (default 5 degC, 0.5
        A/mm^2, 0.5 A, 0.25 decades of speed, else a tenth of the range; in
        decades on a log axis). Bins are aligned centred on multiples of the width.
    tol : float
        "binned": relative tolerance above the minimum COF that still counts
        as optimum (default 0.15).
    rise : float
        Relative COF rise over the minimum that marks the onset (default
        0.5, i.e. 1.5 x the minimum): on the fitted upper wall
        ("segmented"), between bin centres ("binned").
    min_count : int
        Gated windows a bin needs to count (default 1).
    n_boot : int
        Bootstrap resamples (default 400; 0 skips the intervals).
    seed : int
        Seed of the bootstrap (default 0: results repeat exactly).
    block : int, optional
        Bootstrap block length in windows (default ``k max(3, ceil((n / k)^(1/3)))``, ``k`` = window / hop
        when the windows overlap, else 1: the same stretch of time at every hop).
    log : bool, optional
        Fit on a log10 axis of the covariate (default: True for speed, a
        Stribeck curve spanning decades; False otherwise). Windows whose
        covariate is <= 0 are then left out.
    cof : {"auto", "dynamic", "classical"}
        The COF fitted (docs/method.md 7a): "auto" (default) the headline's
        method: the dynamic ``mu_r`` of the gated windows when the dynamic
        method applies, else the classical ``mu_classical`` of each window
        (equal weights).

    Returns
    -------
    OperatingRange

    Raises
    ------
    ValueError
        Unknown ``by``, ``method``, ``branch`` or ``cof``, bad
        widths/tolerances, or no usable window with a finite covariate.
    """
    if not isinstance(results, Results):
        raise TypeError(f"results must be the Results of tribodyn.analyze, got {type(results).__name__}")
    cv = covariate(results, by, log)
    by = cv.by
    _check_settings(by, method=method, branch=branch, bin_width=bin_width, tol=tol, rise=rise, min_count=min_count,
                    n_boot=n_boot, block=block)  # fmt: skip
    fitted = _cof_of(results, cof)
    which, mu, se, may = fitted
    raw, cov, nonpositive = _on_fit_axis(results, cv)
    keep = may & np.isfinite(cov) & np.isfinite(mu)
    if not keep.any():
        raise _no_usable_window(cv, raw, cov, which)
    span = float(np.max(np.abs(cov[keep])))
    resolution = cv.resolution if cv.resolution is not None else RELATIVE_RESOLUTION * span
    width = _bin_width(bin_width, cv, cov[keep], span)
    br_all = np.asarray(results["branch"]) if "branch" in results.table else np.zeros(len(cov), dtype=np.int8)
    curves = _binned_curves(cov[keep], mu[keep], br_all[keep], by, _Binning(width, tol, rise, min_count))
    raw_resolution = resolution if not cv.log else 0.0
    instability, instability_ci, lost_onset = _instability(results, raw, raw_resolution)
    common: Dict[str, Any] = dict(
        by=by, unit=cv.unit, bin_width=width, tol=tol, rise=rise, branch=branch, instability=instability,
        instability_ci=instability_ci, column=cv.column, log=cv.log, cof=which, contact_loss_onset=lost_onset,
    )  # fmt: skip
    if method == "binned":
        return _binned_range(curves, cv, branch=branch, n_windows=int(keep.sum()), common=common)
    usable, excluded = _excluded(results, by, cov, fitted, nonpositive)
    shared = overlap(results)
    usable, excluded, mu = _without_running_in(results, cov, mu, (usable, excluded), resolution=resolution,
                                               shared=shared)  # fmt: skip
    usable, excluded = _without_steps(results, cov, (usable, excluded), resolution=resolution, by=by)
    pos = np.flatnonzero(usable)  # time order: the table's
    boot = bootstrap_indices(len(pos), n_boot, seed, block, shared) if len(pos) and n_boot else np.zeros((0, 0), int)
    x_noise = _reading_noise(results, by, pos)
    ctx = _FitContext(cv, resolution, rise, x_noise, shared)
    fits, draws = _fit_branches(cov[pos], mu[pos], se[pos], br_all[pos], boot, ctx=ctx)
    hysteresis = None
    if "heating" in fits and "cooling" in fits:
        hysteresis = _hysteresis(fits, draws, x_noise)
    f = fits[branch] if branch is not None and branch in fits else fits["all"]
    if branch is not None and branch not in fits:
        raise ValueError(f"no usable window on the {branch} branch (see the branch column: +1 heating, -1 cooling)")
    return OperatingRange(
        optimum=f.optimum, mu_min=f.mu_min, onset=f.onset, method="segmented", verdict=f.verdict,
        explanation=f.explanation, optimum_ci=f.optimum_ci, mu_min_ci=f.mu_min_ci, onset_ci=f.onset_ci,
        edge_lower=f.edge_lower, edge_upper=f.edge_upper, fits=fits, hysteresis=hysteresis,
        n_windows=len(pos), excluded=excluded, n_boot=int(n_boot), seed=int(seed),
        curves={k: _curve_in_column_units(v, cv) for k, v in curves.items()}, **common,
    )  # fmt: skip


def _on_fit_axis(results: Results, cv: Covariate) -> Tuple[np.ndarray, np.ndarray, Optional[np.ndarray]]:
    """The covariate per window as read (its magnitude where the covariate is one) and on the fit axis (log10 on a
    log axis, NaN where <= 0), with the windows left out for that (None on a linear axis)."""
    raw = np.asarray(results[cv.column], dtype=float)
    raw = np.abs(raw) if cv.magnitude else raw
    nonpositive = None
    if cv.log:
        nonpositive = np.isfinite(raw) & (raw <= 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            cov = np.where(raw > 0, np.log10(np.where(raw > 0, raw, 1.0)), np.nan)
    else:
        cov = raw
    return raw, cov, nonpositive


def _no_usable_window(cv: Covariate, raw: np.ndarray, cov: np.ndarray, which: str) -> ValueError:
    """Why no window can enter the fit: none has the covariate, or none that has it has the COF fitted."""
    what = cv.by.replace("_", " ") + (" > 0" if cv.log and np.isfinite(raw).any() else "")
    if not np.isfinite(cov).any():
        return ValueError(f"no window has a {what} (did analyze get {cv.needs}?)")
    if which == "dynamic":
        return ValueError(f"no quality-gated window has a {what} (the dynamic COF; cof='classical' fits the "
                          "classical COF of each window)")  # fmt: skip
    return ValueError(f"no window with a classical COF has a {what}")


def _bin_width(bin_width: Optional[float], cv: Covariate, kept: np.ndarray, span: float) -> float:
    """The binned curves' width: the one given, else the covariate's default, else a tenth of the kept range."""
    if bin_width is not None:
        return float(bin_width)
    if cv.width is not None:
        return cv.width
    return float(np.ptp(kept)) / 10 or max(span, 1.0) * RELATIVE_RESOLUTION


def _binned_range(
    curves: Dict[str, RangeCurve], cv: Covariate, *, branch: Optional[str], n_windows: int, common: Dict[str, Any]
) -> OperatingRange:
    """The operating range of ``method="binned"``: the chosen branch's binned curve, without intervals."""
    width, tol = common["bin_width"], common["tol"]
    c = curves[branch or "all"] if (branch or "all") in curves else curves["all"]
    edges = c.edges
    verdict = "too few windows" if c.optimum is None else (
        "optimum at the edge of the tested range" if c.optimum[0] <= edges[0] or c.optimum[1] >= edges[-1]
        else "optimum")  # fmt: skip
    c = _curve_in_column_units(c, cv)
    per = "decade" if cv.log else cv.unit
    return OperatingRange(
        optimum=c.optimum, mu_min=c.mu_min, onset=c.onset, method="binned", verdict=verdict,
        explanation=(f"Binned medians ({width:g} {per} bins): the optimum is the run of bins within "
                     f"{100 * tol:g} % of the lowest median; no intervals (method='binned')."),
        edge_lower=c.optimum is not None and c.optimum[0] <= c.edges[0],
        edge_upper=c.optimum is not None and c.optimum[1] >= c.edges[-1],
        n_windows=n_windows, curves={k: _curve_in_column_units(v, cv) for k, v in curves.items()},
        **common,
    )  # fmt: skip


def _fit_branches(
    x: np.ndarray, y: np.ndarray, s: np.ndarray, br: np.ndarray, boot: np.ndarray, *, ctx: _FitContext
) -> Tuple[Dict[str, BranchFit], Dict[str, Dict[str, np.ndarray]]]:
    """The segmented fit of "all" usable windows and, for temperature, of each branch with windows (``br``: +1
    heating, -1 cooling, 0 both), with their bootstrap draws from the same resamples of the whole series."""
    names = ["all"] + ([b for b in _BRANCHES] if ctx.cv.by == "temperature" else [])
    fits: Dict[str, BranchFit] = {}
    draws: Dict[str, Dict[str, np.ndarray]] = {}
    for name in names:
        member = np.ones(len(x), dtype=bool) if name == "all" else (br == _BRANCHES[name]) | (br == 0)
        if name != "all" and not (br == _BRANCHES[name]).any():
            continue
        # Positions in the branch's own arrays for each resampled window of the whole series.
        where = np.cumsum(member) - 1
        sub = [where[idx[member[idx]]] for idx in boot]
        fits[name], draws[name] = _branch_fit(name, x[member], y[member], s[member], sub, ctx=ctx)
    return fits, draws


def _check_settings(
    by: str, *, method: str, branch: Optional[str], bin_width: Optional[float], tol: float, rise: float,
    min_count: int, n_boot: int, block: Optional[int],
) -> None:  # fmt: skip
    """ValueError unless :func:`operating_range`'s settings are valid for the covariate ``by`` (its name)."""
    if method not in ("segmented", "binned"):
        raise ValueError(f"method must be 'segmented' or 'binned', got {method!r}")
    if branch is not None and branch not in _BRANCHES:
        raise ValueError(f"branch must be None, 'heating' or 'cooling', got {branch!r}")
    if branch is not None and by != "temperature":
        raise ValueError(f"branch applies to by='temperature' only ({by.replace('_', ' ')} has no heating/cooling "
                         "branches)")  # fmt: skip
    if bin_width is not None and not (isinstance(bin_width, (int, float, np.number)) and np.isfinite(bin_width)
                                      and bin_width > 0):  # fmt: skip
        raise ValueError(f"bin_width must be > 0, got {bin_width!r}")
    if not (tol >= 0 and rise > 0 and min_count >= 1):
        raise ValueError("tol must be >= 0, rise > 0 and min_count >= 1")
    if not (isinstance(n_boot, (int, np.integer)) and 0 <= n_boot <= 100_000):
        raise ValueError(f"n_boot must be an integer in [0, 100000], got {n_boot!r}")
    if block is not None and not (isinstance(block, (int, np.integer)) and block >= 1):
        raise ValueError(f"block must be an integer >= 1, got {block!r}")


def _reading_noise(results: Results, by: str, pos: np.ndarray) -> float:
    """Reading noise of the covariate (standard deviation; 0 when not known): for temperature the log's, the
    smallest ``T_uncertainty`` of the usable windows (the noise of a reading, section 6 of docs/method.md)."""
    if by != "temperature" or "T_uncertainty" not in results.table or not len(pos):
        return 0.0
    u = np.asarray(results["T_uncertainty"], dtype=float)[pos]
    return float(np.nanmin(u)) if np.isfinite(u).any() else 0.0


def _hysteresis(
    fits: Dict[str, BranchFit], draws: Dict[str, Dict[str, np.ndarray]], x_noise: float = 0.0
) -> Hysteresis:
    h, c = fits["heating"], fits["cooling"]
    out: Dict[str, Any] = {}
    for side, key in (("lower", "b_lo"), ("upper", "b_hi")):
        a, b = getattr(h, side), getattr(c, side)
        if a is None or b is None or key not in draws["heating"] or key not in draws["cooling"]:
            out[side], out[f"{side}_ci"] = None, None
            continue
        out[side] = a - b
        # Two edges read at different readings: their reading errors add in quadrature (sqrt(2) x_noise).
        out[f"{side}_ci"] = _widen(_pct(draws["heating"][key] - draws["cooling"][key]), a - b,
                                   math.sqrt(2.0) * x_noise)  # fmt: skip
    return Hysteresis(**out)
