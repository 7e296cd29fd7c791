"""The uncertainty budget's numerics: the instrument combined with the statistics (docs/method.md 6i).

* :class:`Inputs`: what a lab knows of its instrument (``analyze(uncertainty=...)``,
  ``--uncertainty KEY=VALUE``, ``[uncertainty]`` in ``--config``, ``--calibration FILE``):
  the standard uncertainty of each channel's calibration (``fy_rel``, ``fz_rel``), of its
  offset (``fy_abs``, ``fz_abs``), of the angle between the tangential axis and the contact
  plane (``misalignment_deg``; a known ``misalignment_bias_deg`` is corrected) and of the
  crosstalk (``crosstalk``), each with its distribution and degrees of freedom
  (:func:`parse_inputs`, :func:`parse_item`).
* :class:`Moments`: the headline's sufficient statistics: over the samples (or windows) it
  averages, the weighted sums of r^j u^k (r = fy/fz, u = 1/fz, j <= 3, k <= 2) apart for each
  sign of r (:func:`ratio_sums`, :func:`slope_moments`); from them the headline's estimator is
  evaluated on the forces corrected by any instrument, without the samples (:func:`estimate`).
  Reading them from a recording is ``pipeline/budget.py``'s; the dynamic COF's come from the
  table (``results/budget.py``).
* :func:`propagate`: the Monte Carlo of JCGM 101 (GUM Supplement 1) through that estimator,
  the statistical interval entering as its own distribution, and the law of propagation of
  GUM (first-order sensitivities) as its check: an :class:`Uncertainty` with the budget.
* :func:`instrument`, :func:`through`: an instrument drawn from the stated distributions, and
  true forces measured through it (the coverage study, ``benches/bench_uncertainty.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Dict, Iterable, List, Mapping, Optional, Protocol, Sequence, Tuple

import numpy as np

from .. import _core
from .quantiles import Z975, t975

__all__ = [
    "DISTRIBUTIONS",
    "NO_BUDGET",
    "SHAPE",
    "SOURCES",
    "BudgetRow",
    "Inputs",
    "Instrument",
    "Interval",
    "Moments",
    "Source",
    "Uncertainty",
    "estimate",
    "in_contact",
    "instrument",
    "parse_inputs",
    "parse_item",
    "propagate",
    "ratio_sums",
    "rows_text",
    "sensitivities",
    "slope_moments",
    "through",
]

#: The instrument's sources: key -> (unit, meaning) (docs/method.md 6i).
SOURCES: Dict[str, Tuple[str, str]] = {
    "fy_rel": ("1", "relative standard uncertainty of the fy (friction) channel's calibration"),
    "fz_rel": ("1", "relative standard uncertainty of the fz (normal) channel's calibration"),
    "fy_abs": ("N", "standard uncertainty of the fy channel's offset (offset, drift, resolution)"),
    "fz_abs": ("N", "standard uncertainty of the fz channel's offset (offset, drift, resolution)"),
    "misalignment_deg": ("deg", "standard uncertainty of the angle between the tangential axis and the contact plane"),
    "crosstalk": ("1", "standard uncertainty of the fraction of fz seen on the fy channel, and of fy on fz"),
}
#: A known misalignment (degrees), corrected: fy reads fy cos(theta) + fz sin(theta) (docs/method.md 6i).
BIAS = "misalignment_bias_deg"
#: The distributions of an input, as GUM names them; the value given is always the standard uncertainty.
DISTRIBUTIONS = ("normal", "rectangular", "triangular")
#: Largest value of each source that the model holds (beyond it the instrument is not a load cell).
_LIMITS = {"fy_rel": 0.5, "fz_rel": 0.5, "misalignment_deg": 10.0, "crosstalk": 0.5, BIAS: 45.0}
#: Monte Carlo draws (JCGM 101 7.2: 10^6 / (1 - p) suggests 2e5 for p = 0.95 at two significant digits).
DRAWS = 200_000
#: How the reason begins when the inputs are given but the headline's statistics could not be read.
NO_BUDGET = "no uncertainty budget: "
#: Coverage probability of the interval.
COVERAGE = 0.95
#: An interval whose two sides differ by more than this share of its width is quoted by its ends, not +- U.
ASYMMETRY = 0.05
_DEG = math.pi / 180.0


# -- inputs ------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Source:
    """One input: ``u`` its standard uncertainty (in the key's unit), its distribution and degrees of freedom.

    ``u`` is always the standard deviation of the input's distribution: a
    normal input with ``dof`` degrees of freedom is a Student t with that
    standard deviation (scale u sqrt((dof - 2) / dof)), a rectangular one
    spans +- sqrt(3) u, a triangular one +- sqrt(6) u.
    """

    name: str
    u: float
    distribution: str = "normal"
    dof: Optional[float] = None

    def draw(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` draws of the input's error (mean zero, standard deviation ``u``)."""
        if self.u == 0:
            return np.zeros(n)
        if self.distribution == "rectangular":
            a = math.sqrt(3.0) * self.u
            return rng.uniform(-a, a, n)
        if self.distribution == "triangular":
            a = math.sqrt(6.0) * self.u
            return rng.triangular(-a, 0.0, a, n)
        if self.dof is not None and math.isfinite(self.dof):
            return self.u * math.sqrt((self.dof - 2.0) / self.dof) * rng.standard_t(self.dof, n)
        return self.u * rng.standard_normal(n)

    def to_dict(self) -> Dict[str, Any]:
        return {"u": self.u, "distribution": self.distribution, "dof": self.dof}


@dataclass(frozen=True)
class Inputs:
    """What a lab knows of its instrument (docs/method.md 6i): :func:`parse_inputs` of ``analyze(uncertainty=...)``."""

    sources: Tuple[Source, ...] = ()
    misalignment_bias_deg: float = 0.0
    instrument: str = ""

    def get(self, name: str) -> Optional[Source]:
        return next((s for s in self.sources if s.name == name), None)

    def to_dict(self) -> Dict[str, Any]:
        """JSON-ready, the form :func:`parse_inputs` takes back."""
        out: Dict[str, Any] = {s.name: s.to_dict() for s in self.sources}
        if self.misalignment_bias_deg:
            out[BIAS] = self.misalignment_bias_deg
        if self.instrument:
            out["instrument"] = self.instrument
        return out


def _number(v: Any, what: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise TypeError(f"{what} must be a number, got {v!r}")
    x = float(v)
    if not math.isfinite(x):
        raise ValueError(f"{what} must be finite, got {v!r}")
    return x


def _source(name: str, v: Any) -> Source:
    where = f"uncertainty[{name!r}]"
    if isinstance(v, Mapping):
        extra = sorted(set(map(str, v)) - {"u", "distribution", "dof"})
        if extra:
            raise ValueError(f"{where}: unknown field(s) {', '.join(extra)} (u, distribution, dof)")
        if "u" not in v:
            raise ValueError(f"{where} needs u, its standard uncertainty")
        u, dist, dof = v["u"], v.get("distribution", "normal"), v.get("dof")
    else:
        u, dist, dof = v, "normal", None
    x = _number(u, where)
    if x < 0:
        raise ValueError(f"{where} is a standard uncertainty, >= 0, got {u!r}")
    if name in _LIMITS and x > _LIMITS[name]:
        raise ValueError(f"{where} = {x:g} is beyond what a load cell can be ({_LIMITS[name]:g} at most)")
    if dist not in DISTRIBUTIONS:
        raise ValueError(f"{where}: distribution must be normal, rectangular or triangular, got {dist!r}")
    nu: Optional[float] = None
    if dof is not None:
        nu = _number(dof, f"{where} dof")
        if dist != "normal":
            raise ValueError(f"{where}: degrees of freedom apply to a normal (Student t) input, not a {dist} one")
        if nu <= 2:
            raise ValueError(f"{where}: dof must be > 2 (a Student t with <= 2 has no standard deviation), got {dof!r}")
    return Source(name, x, str(dist), nu)


def parse_inputs(value: Any) -> Optional[Inputs]:
    """``analyze(uncertainty=...)`` checked: None (or an empty mapping) for no budget, else :class:`Inputs`.

    ``value`` maps each key of :data:`SOURCES` to its standard uncertainty
    (a number: normal) or to ``{"u": ..., "distribution": ..., "dof": ...}``;
    ``misalignment_bias_deg`` is a number, ``instrument`` a name. Unknown
    keys and impossible values raise a one-line ValueError (TypeError for
    a wrong type) naming ``uncertainty``.
    """
    if value is None or isinstance(value, Inputs):
        return value
    if not isinstance(value, Mapping):
        raise TypeError(f"uncertainty must be a mapping of {', '.join(SOURCES)} to standard uncertainties")
    if not value:
        return None
    unknown = sorted(str(k) for k in value if k not in SOURCES and k not in (BIAS, "instrument"))
    if unknown:
        raise ValueError(f"uncertainty: unknown key(s) {', '.join(unknown)}; the keys are {', '.join(SOURCES)}, {BIAS}")
    sources = tuple(_source(k, value[k]) for k in SOURCES if k in value)
    bias = 0.0
    if BIAS in value:
        bias = _number(value[BIAS], f"uncertainty[{BIAS!r}]")
        if abs(bias) > _LIMITS[BIAS]:
            raise ValueError(f"uncertainty[{BIAS!r}] must be within +-{_LIMITS[BIAS]:g} degrees, got {bias!r}")
    name = value.get("instrument", "")
    if not isinstance(name, str):
        raise TypeError(f"uncertainty['instrument'] must be a name (text), got {name!r}")
    return Inputs(sources, bias, name)


def parse_item(text: str) -> Tuple[str, Any]:
    """``--uncertainty KEY=VALUE``: VALUE is ``U``, ``U:DISTRIBUTION`` or ``U:normal:DOF`` (bias: a number).

    Returns ``(key, value)`` for :func:`parse_inputs` (which checks the values).
    """
    key, eq, rest = text.partition("=")
    key = key.strip()
    if not eq or not key or not rest.strip():
        raise ValueError(f"--uncertainty takes KEY=VALUE (e.g. misalignment_deg=0.3:rectangular), got {text!r}")
    if key not in SOURCES and key != BIAS:
        raise ValueError(f"--uncertainty: unknown key {key!r}; the keys are {', '.join(SOURCES)}, {BIAS}")
    parts = [p.strip() for p in rest.split(":")]
    try:
        nums = [float(parts[0])] + ([float(parts[2])] if len(parts) > 2 else [])
    except ValueError:
        raise ValueError(f"--uncertainty {key}: {rest!r} is not U[:distribution[:dof]] with numbers") from None
    if key == BIAS:
        if len(parts) > 1:
            raise ValueError(f"--uncertainty {BIAS} is a known angle in degrees (a number), got {rest!r}")
        return key, nums[0]
    if len(parts) > 3:
        raise ValueError(f"--uncertainty {key}: {rest!r} is not U[:distribution[:dof]]")
    out: Dict[str, Any] = {"u": nums[0]}
    if len(parts) > 1:
        out["distribution"] = parts[1]
    if len(parts) > 2:
        out["dof"] = nums[1]
    return key, out


# -- sufficient statistics ---------------------------------------------------------------------------------------

#: Powers of r (0..3) and of u (0..2) kept: the estimator to third order in the instrument's errors.
_J, _K = 4, 3
#: Shape of the sums: (sign of r, power of r, power of u).
SHAPE = (2, _J, _K)


def ratio_sums(y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """sum r^j u^k (r = y/z, u = 1/z; j < 4, k < 3) over the samples, apart for r >= 0 [0] and r < 0 [1]."""
    u = 1.0 / np.asarray(z, dtype=float)
    r = np.asarray(y, dtype=float) * u
    neg = r < 0
    out = np.zeros((2, _J, _K))
    for side, sel in ((0, ~neg), (1, neg)):
        rs, us = r[sel], u[sel]
        if not rs.size:
            continue
        r2 = rs * rs
        rp = np.stack([np.ones_like(rs), rs, r2, r2 * rs])
        up = np.stack([np.ones_like(us), us, us * us])
        out[side] = rp @ up.T  # one matrix product: every sum of r^j u^k
    return out


@dataclass(frozen=True)
class Moments:
    """The headline's sufficient statistics (docs/method.md 6i).

    ``t[0]`` (r >= 0) and ``t[1]`` (r < 0) hold sum_i w_i r_i^j u_i^k over
    the samples (classical), the stroke centres' samples (per-stroke) or the
    direction medians (dynamic, u = 0) that the headline averages, with the
    weights w_i it gives them (summing to 1): the headline is
    sum_s s t[s][1, 0] and, measured through another instrument, the same
    sums of the corrected ratio.
    """

    method: str
    t: np.ndarray
    n: int

    @property
    def value(self) -> float:
        """The headline as these statistics give it (the nominal instrument)."""
        return float(self.t[0, 1, 0] - self.t[1, 1, 0])

    def signed(self, j: int, k: int) -> float:
        """sum_s s t[s][j, k]."""
        return float(self.t[0, j, k] - self.t[1, j, k])


def in_contact(y: np.ndarray, z: np.ndarray, spec: Any) -> Tuple[np.ndarray, np.ndarray]:
    """The tared samples in contact, as the classical COF takes them (``pipeline/headline.py``'s block sums, 6a)."""
    y = np.asarray(y, dtype=float) - spec.tare_fy
    z = np.asarray(z, dtype=float) - spec.tare_fz
    az = np.abs(z)
    keep = (np.abs(y) <= _core.FORCE_LIMIT) & (az <= _core.FORCE_LIMIT) & (az >= spec.min_fn) & (az > 0)
    return y[keep], z[keep]


def slope_moments(slopes: Sequence[Tuple[float, float]], n: int) -> Moments:
    """The dynamic COF's statistics from its slopes: ``(weight, slope)`` pairs, u = 0 (no static offset enters)."""
    t = np.zeros((2, _J, _K))
    for w, b in slopes:
        t[0 if b >= 0 else 1, :, 0] += w * b ** np.arange(_J)
    return Moments("dynamic", t, int(n))


# -- the instrument, and its inverse ------------------------------------------------------------------------------


@dataclass(frozen=True)
class Instrument:
    """An instrument's errors (docs/method.md 6i), arrays of draws or scalars.

    The channels read, from the true tangential Y and normal Z forces (each
    in the channel's own sign):
    ``fy = (1 + g_y) (Y cos t + Z sin t) + k_y Z + o_y`` and
    ``fz = (1 + g_z) (Z cos t - Y sin t) + k_z Y + o_z``.
    """

    g_y: Any = 0.0
    g_z: Any = 0.0
    o_y: Any = 0.0
    o_z: Any = 0.0
    theta: Any = 0.0
    k_y: Any = 0.0
    k_z: Any = 0.0

    def matrix(self) -> Tuple[Any, Any, Any, Any]:
        """(a11, a12, a21, a22): (fy, fz) - offsets = A (Y, Z)."""
        c, s = np.cos(self.theta), np.sin(self.theta)
        return ((1 + self.g_y) * c, (1 + self.g_y) * s + self.k_y, -(1 + self.g_z) * s + self.k_z, (1 + self.g_z) * c)


def instrument(inputs: Inputs, rng: np.random.Generator, n: Optional[int] = None) -> Instrument:
    """An instrument (or ``n`` of them) drawn from the stated distributions, the known bias added to the angle."""
    size = 1 if n is None else n

    def d(name: str) -> np.ndarray:
        src = inputs.get(name)
        return src.draw(rng, size) if src is not None else np.zeros(size)

    vals = dict(g_y=d("fy_rel"), g_z=d("fz_rel"), o_y=d("fy_abs"), o_z=d("fz_abs"),
                theta=(inputs.misalignment_bias_deg + d("misalignment_deg")) * _DEG, k_y=d("crosstalk"),
                k_z=d("crosstalk"))  # fmt: skip
    if n is None:
        return Instrument(**{k: float(v[0]) for k, v in vals.items()})
    return Instrument(**vals)


def through(inst: Instrument, fy: np.ndarray, fz: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """True forces (fy tangential, fz normal, N) as the instrument ``inst`` reads them."""
    a11, a12, a21, a22 = inst.matrix()
    y, z = np.asarray(fy, dtype=float), np.asarray(fz, dtype=float)
    return a11 * y + a12 * z + inst.o_y, a21 * y + a22 * z + inst.o_z


def estimate(mom: Moments, inst: Instrument) -> np.ndarray:
    """The headline's estimator on the forces corrected by ``inst`` (arrays of draws): to third order in its errors.

    Per sample, the corrected ratio is R(rho) = (a22 rho - a12) / (a11 - a21 rho)
    with rho = (r - o_y u) / (1 - o_z u); R is expanded in q = a21 / a11
    (up to rho^3) and rho^m in the offsets (to second order), so that its
    mean needs only the sums of r^j u^k (docs/method.md 6i).
    """
    a11, a12, a21, a22 = inst.matrix()
    q = a21 / a11
    coef = [-a12 / a11, (a22 - a12 * q) / a11, (a22 * q - a12 * q * q) / a11, a22 * q * q / a11]
    oy, oz = np.asarray(inst.o_y, dtype=float), np.asarray(inst.o_z, dtype=float)
    out = 0.0
    for side, sign in ((0, 1.0), (1, -1.0)):
        t = mom.t[side]
        if not t[0, 0]:
            continue
        acc = coef[0] * t[0, 0]
        for m in range(1, _J):
            # rho^m = r^m + m oz r^m u + m(m+1)/2 oz^2 r^m u^2 - m oy r^(m-1) u - m^2 oy oz r^(m-1) u^2
            #         + m(m-1)/2 oy^2 r^(m-2) u^2
            e = t[m, 0] + m * oz * t[m, 1] + 0.5 * m * (m + 1) * oz * oz * t[m, 2] - m * oy * t[m - 1, 1]
            e = e - m * m * oy * oz * t[m - 1, 2]
            if m >= 2:
                e = e + 0.5 * m * (m - 1) * oy * oy * t[m - 2, 2]
            acc = acc + coef[m] * e
        out = out + sign * acc
    return np.asarray(out, dtype=float)


# -- the budget ---------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class BudgetRow:
    """One source of the budget (docs/method.md 6i).

    ``value``: its standard uncertainty (``unit``); ``sensitivity``: dCOF /
    d(source) (per ``unit``), from GUM's law of propagation at the nominal
    instrument; ``contribution``: |sensitivity| x value; ``share``: the
    contribution's square over u_c^2 (GUM).
    """

    source: str
    value: float
    unit: str
    distribution: str
    dof: Optional[float]
    sensitivity: float
    contribution: float
    share: float

    def to_dict(self) -> Dict[str, Any]:
        def num(v: Optional[float]) -> Optional[float]:
            return float(v) if v is not None and math.isfinite(v) else None

        return {"source": self.source, "value": num(self.value), "unit": self.unit, "distribution": self.distribution,
                "dof": num(self.dof), "sensitivity": num(self.sensitivity), "contribution": num(self.contribution),
                "share": num(self.share)}  # fmt: skip


def _sig(x: float) -> int:
    """Decimals of ``x`` at two significant digits when its first digit is 1 or 2, else one (GUM 7.2.6)."""
    if not (math.isfinite(x) and x > 0):
        return 4
    e = math.floor(math.log10(x))
    lead = int(x / 10.0**e)
    return max(0, -e + (1 if lead < 3 else 0))


@dataclass(frozen=True)
class Uncertainty:
    """The headline's combined uncertainty: instrument and statistics (``Headline.uncertainty``; docs/method.md 6i).

    Attributes
    ----------
    value : float
        The COF (the headline's, corrected for ``misalignment_bias_deg``).
    u_c : float
        Combined standard uncertainty (the Monte Carlo's standard deviation).
    low, high : float
        The probabilistically symmetric 95 % coverage interval of the Monte Carlo.
    k : float or None
        U / u_c where a symmetric expanded uncertainty U = (high - low) / 2 is
        quoted (None when the interval is too asymmetric to be quoted +- U).
    budget : tuple of BudgetRow
        One row per source, the statistical one included.
    gum : dict
        GUM's law of propagation: u_c, effective degrees of freedom, k, U.
    instrument_u : float
        The instrument's part alone (GUM): shared by all tests on this instrument.
    """

    value: float
    u_c: float
    low: float
    high: float
    k: Optional[float]
    budget: Tuple[BudgetRow, ...]
    gum: Dict[str, Any] = field(default_factory=dict)
    instrument_u: float = float("nan")
    statistical_u: float = float("nan")
    correction: float = 0.0
    draws: int = DRAWS
    seed: int = 0
    notes: Tuple[str, ...] = ()
    instrument: str = ""

    @property
    def U(self) -> Optional[float]:
        """The expanded uncertainty (half the interval) when ``k`` is quoted."""
        return None if self.k is None else 0.5 * (self.high - self.low)

    @property
    def text(self) -> str:
        """'0.104 +- 0.009 (95 %, instrument and statistics)'."""
        if self.U is not None:
            dec = _sig(self.U)
            return f"{self.value:.{dec}f} +- {self.U:.{dec}f} (95 %, instrument and statistics)"
        dec = _sig(0.5 * (self.high - self.low))
        return f"{self.value:.{dec}f} (95 % {self.low:.{dec}f} to {self.high:.{dec}f}, instrument and statistics)"

    @staticmethod
    def from_dict(d: Mapping[str, Any]) -> "Uncertainty":
        """From its :meth:`to_dict` form (``summary.json``; None as NaN)."""

        def num(v: Any) -> float:
            return float("nan") if v is None else float(v)

        rows = tuple(
            BudgetRow(
                str(r["source"]),
                num(r.get("value")),
                str(r.get("unit") or ""),
                str(r.get("distribution")),
                None if r.get("dof") is None else float(r["dof"]),
                num(r.get("sensitivity")),
                num(r.get("contribution")),
                num(r.get("share")),
            )  # fmt: skip
            for r in d.get("budget") or ()
        )
        return Uncertainty(value=num(d.get("value")), u_c=num(d.get("u_c")), low=num(d.get("low")),
                           high=num(d.get("high")), k=None if d.get("k") is None else float(d["k"]), budget=rows,
                           gum={k: num(v) for k, v in (d.get("gum") or {}).items()},
                           instrument_u=num(d.get("instrument_u")), statistical_u=num(d.get("statistical_u")),
                           correction=num(d.get("correction") or 0.0), draws=int(d.get("draws") or DRAWS),
                           seed=int(d.get("seed") or 0), notes=tuple(map(str, d.get("notes") or ())),
                           instrument=str(d.get("instrument") or ""))  # fmt: skip

    def to_dict(self) -> Dict[str, Any]:
        def num(v: Optional[float]) -> Optional[float]:
            return float(v) if v is not None and math.isfinite(v) else None

        return {
            "value": num(self.value), "u_c": num(self.u_c), "low": num(self.low), "high": num(self.high),
            "k": num(self.k), "U": num(self.U), "coverage": COVERAGE,
            "budget": [r.to_dict() for r in self.budget],
            "gum": {k: (num(v) if isinstance(v, float) else v) for k, v in self.gum.items()},
            "instrument_u": num(self.instrument_u), "statistical_u": num(self.statistical_u),
            "correction": num(self.correction), "draws": self.draws, "seed": self.seed, "notes": list(self.notes),
            "instrument": self.instrument, "text": self.text,
        }  # fmt: skip


def sensitivities(mom: Moments) -> Dict[str, Tuple[float, ...]]:
    """GUM's first-order sensitivities of the headline to each source (docs/method.md 6i, per the key's unit).

    With S(j, k) = sum_s s t[s][j, k] (so that the COF is S(1, 0)):
    d/dg_y = -S(1,0), d/dg_z = +S(1,0), d/do_y = -S(0,1), d/do_z = +S(1,1),
    d/dtheta = -(S(0,0) + S(2,0)) (per radian), d/dk_y = -S(0,0), d/dk_z = +S(2,0).
    The crosstalk's two coefficients are drawn apart: two values.
    """
    S = mom.signed
    return {
        "fy_rel": (-S(1, 0),),
        "fz_rel": (S(1, 0),),
        "fy_abs": (-S(0, 1),),
        "fz_abs": (S(1, 1),),
        "misalignment_deg": (-(S(0, 0) + S(2, 0)) * _DEG,),
        "crosstalk": (-S(0, 0), S(2, 0)),
    }


def _t975(dof: float) -> float:
    return Z975 if not math.isfinite(dof) else t975(int(math.floor(dof)))


class Interval(Protocol):
    """What :func:`propagate` reads of a headline (a :class:`tribodyn.Headline`): its value and 95 % interval."""

    @property
    def value(self) -> float: ...

    @property
    def low(self) -> float: ...

    @property
    def high(self) -> float: ...


def statistical_part(head: Interval, dof: float) -> Tuple[float, float, float]:
    """(scale below, scale above, dof) of the headline's statistical interval: its half-widths over t(0.975, dof).

    The Student t with ``dof`` degrees of freedom and these scales gives back
    the headline's interval exactly (below and above the value apart when it
    is asymmetric, as the dynamic bootstrap's may be); fewer than 3 degrees of
    freedom (3 batches) are taken as 3, so that the part has a standard deviation.
    """
    if not (math.isfinite(head.low) and math.isfinite(head.high)):
        return float("nan"), float("nan"), dof
    q = _t975(dof)
    return max(0.0, head.value - head.low) / q, max(0.0, head.high - head.value) / q, max(3.0, dof)


def propagate(head: Interval, mom: Moments, inputs: Inputs, *, stat_dof: float = float("inf"),
              draws: int = DRAWS, seed: int = 0) -> Uncertainty:  # fmt: skip
    """The Monte Carlo of JCGM 101 through the headline's estimator, with GUM's budget as its check (6i).

    Each draw is an instrument from ``inputs`` (errors about the known bias)
    and a statistical error from the headline's interval (a Student t with
    ``stat_dof`` degrees of freedom scaled to it; below and above the value
    apart when the interval is asymmetric); the COF of the draw is the
    estimator on the corrected forces plus that error. u_c is the draws'
    standard deviation, the interval their 2.5 % and 97.5 % quantiles.
    Repeats exactly with ``seed``.
    """
    rng = np.random.default_rng(seed)
    nominal = Instrument(theta=inputs.misalignment_bias_deg * _DEG)
    value = float(estimate(mom, nominal))
    correction = value - mom.value
    inst = instrument(inputs, rng, draws)
    mu = estimate(mom, inst)
    lo_se, hi_se, dof = statistical_part(head, stat_dof)
    notes: List[str] = []
    if math.isfinite(lo_se):
        e = rng.standard_normal(draws) if not math.isfinite(dof) else rng.standard_t(dof, draws)
        mu = mu + np.where(e < 0, lo_se, hi_se) * e
    else:
        notes.append("the headline has no statistical interval: the budget holds the instrument only")
    u_c = float(np.std(mu, ddof=1))
    low, high = (float(x) for x in np.quantile(mu, [(1 - COVERAGE) / 2, (1 + COVERAGE) / 2]))
    half = 0.5 * (high - low)
    sym = abs((high - value) - (value - low)) <= ASYMMETRY * (high - low)
    k = half / u_c if sym and u_c > 0 else None
    # GUM: the law of propagation (first order), the check of the Monte Carlo
    sens = sensitivities(mom)
    rows: List[Tuple[str, float, str, str, Optional[float], float, float]] = []
    for src in inputs.sources:
        c = sens[src.name]
        cs = math.sqrt(sum(x * x for x in c))
        rows.append((src.name, src.u, SOURCES[src.name][0], src.distribution, src.dof, cs, cs * src.u))
    se = 0.5 * (lo_se + hi_se) if math.isfinite(lo_se) else float("nan")
    inst_var = sum(r[6] ** 2 for r in rows)
    if math.isfinite(se):
        if math.isfinite(dof):  # the t's standard deviation
            se *= math.sqrt(dof / (dof - 2.0))
        rows.append(("statistics", se, "1", "Student t" if math.isfinite(dof) else "normal", dof, 1.0, se))
    var = sum(r[6] ** 2 for r in rows)
    u_gum = math.sqrt(var)
    den = sum(r[6] ** 4 / r[4] for r in rows if r[4] is not None and math.isfinite(r[4]) and r[6] > 0)
    nu_eff = var * var / den if den > 0 else float("inf")
    k_gum = _t975(nu_eff)
    budget = tuple(BudgetRow(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[6] ** 2 / var if var > 0 else float("nan"))
                   for r in rows)  # fmt: skip
    gum = {"u_c": u_gum, "dof_eff": nu_eff, "k": k_gum, "U": k_gum * u_gum}
    return Uncertainty(value=value, u_c=u_c, low=low, high=high, k=k, budget=budget, gum=gum,
                       instrument_u=math.sqrt(inst_var), statistical_u=se, correction=correction, draws=draws,
                       seed=seed, notes=tuple(notes), instrument=inputs.instrument)  # fmt: skip


def rows_text(unc: Uncertainty) -> Iterable[str]:
    """The budget as lines of text (the CLI and repr)."""
    yield f"{'source':<18}{'value':>11} {'unit':<5}{'distribution':<13}{'sensitivity':>12}{'contrib.':>10}{'share':>7}"
    for r in unc.budget:
        yield (f"{r.source:<18}{r.value:>11.4g} {r.unit:<5}{r.distribution:<13}{r.sensitivity:>12.4g}"
               f"{r.contribution:>10.3g}{100 * r.share:>6.1f}%")  # fmt: skip
