"""Typed results of the COF identification (docs/method.md sections 4-7)."""

from __future__ import annotations

import html as _html
import dataclasses
from collections import Counter
from dataclasses import dataclass, field
from ._cache import cached
from typing import Any, Dict, List, Mapping, Optional, Tuple

import numpy as np

from .._deprecation import deprecated
from ..columns import UNITS, WINDOW_COLUMNS
from ..kernels.correlation import XcorrResult
from ..kernels.stats import bootstrap_ci, noise_resample
from ..kernels.uncertainty import Moments
from .headline import HEADLINE_METHODS, ClassicalTotals, Headline, choose, instrument_check
from .verdict import verdict as _verdict

__all__ = ["HEADLINE_METHODS", "BinTable", "ClassicalTotals", "CofResult", "Headline", "Params", "Results",
           "WINDOW_COLUMNS", "SUMMARY_COLUMNS", "CACHED"]  # fmt: skip

#: The table's columns that ``Results.summary()`` gives with their statistics and intervals, besides mu_r.
SUMMARY_COLUMNS = ("mu_a", "mu_b", "force_dependence", "dmu_dfn")


@dataclass(frozen=True)
class BinTable:
    """COF against normal force: equal-width fz bins (docs/method.md 4).

    Attributes
    ----------
    edges : ndarray (n_bins + 1,)
        Bin edges spanning [min fz, max fz] of the window (before the deadband).
    centres : ndarray (n_bins,)
        Bin centres (the fz,k of Fig. 9).
    counts : ndarray of int64 (n_bins,)
        Samples per bin outside the deadband.
    cof : ndarray (n_bins,)
        Per-bin COF_k: mean of s * fy_i / fz_i (Eq. 5 per sample); NaN if empty.
    """

    edges: np.ndarray
    centres: np.ndarray
    counts: np.ndarray
    cof: np.ndarray

    @classmethod
    def from_range(cls, lo: float, hi: float, counts: np.ndarray, cof: np.ndarray) -> "BinTable":
        edges = np.linspace(lo, hi, len(counts) + 1)
        return cls(
            edges=edges,
            centres=0.5 * (edges[:-1] + edges[1:]),
            counts=np.asarray(counts, dtype=np.int64),
            cof=np.asarray(cof, dtype=float),
        )


@dataclass(frozen=True)
class CofResult:
    """COF of one acquisition (``tribodyn.identify``; docs/method.md 3-5).

    Attributes
    ----------
    mu_r : float
        COF by regression: orientation * slope of fy on fz (Eqs. 6-8).
    f_y0 : float
        Intercept of the regression (N).
    r : float
        Pearson's r of fy and fz (= c_yz).
    mu_r_stderr : float
        Standard error of mu_r.
    mu_a, mu_b : float
        Sample-weighted mean of s*fy/fz over fz <= -d and fz >= +d (Sec. 3.3).
    force_dependence : float
        (mu_b - mu_a) / mu_r.
    bins : BinTable
        Per-bin COF against fz.
    c_xy, c_xz, c_yz : float
        Pearson coefficients at lag 0 (Sec. 3.1); NaN for x when fx is None.
    correlations : dict of XcorrResult, optional
        C_xy, C_xz, C_yz for lags up to ``max_lag`` (keys "xy", "xz", "yz").
    skew : int or None
        Lag (samples) of max |C_yz(j)|; non-zero means the channels are not
        sampled simultaneously. None unless ``max_lag`` was given.
    spectra : dict, optional
        |cross-spectrum| of "xy", "xz", "yz" at "f0" and "f_l" (N^2/Hz), when
        rpm and n_lamellas are given.
    ok : bool
        Quality gate passed.
    reasons : tuple of str
        Why the gate failed (empty when ok).
    orientation : int
        s in {+1, -1} used.
    deadband : float
        Deadband applied, in newtons.
    n : int
        Samples.
    """

    mu_r: float
    f_y0: float
    r: float
    mu_r_stderr: float
    mu_a: float
    mu_b: float
    force_dependence: float
    bins: BinTable
    c_xy: float
    c_xz: float
    c_yz: float
    ok: bool
    reasons: Tuple[str, ...]
    orientation: int
    deadband: float
    n: int
    correlations: Optional[Dict[str, XcorrResult]] = None
    skew: Optional[int] = None
    spectra: Optional[Dict[str, Dict[str, float]]] = None
    #: The slope estimator of ``mu_r`` (docs/method.md 3a-3c).
    estimator: str = "ols"
    #: The paper's least-squares COF (Eq. 8), whatever the estimator.
    mu_ols: float = float("nan")
    #: 95 % interval of mu_r (NaN with "ols": batch means need another estimator's sums).
    mu_r_low: float = float("nan")
    mu_r_high: float = float("nan")
    #: p-value of OLS = IV (docs/method.md 3b); NaN with "ols".
    attenuation_p: float = float("nan")
    #: d mu / d Fn from the instrumented quadratic fit (docs/method.md 3e); NaN with "ols".
    dmu_dfn: float = float("nan")
    dmu_dfn_stderr: float = float("nan")


class GatedMask(np.ndarray):
    """``Results.gated``: the boolean mask of the gated windows, a plain array to NumPy.

    ``Results.gated`` was a method; calling the mask (``res.gated()``) still
    returns it, with a :class:`DeprecationWarning`. Arithmetic on it gives
    plain arrays.
    """

    def __call__(self) -> np.ndarray:
        deprecated("Results.gated is a property now: use res.gated instead of res.gated()")
        return self.view(np.ndarray)

    def __array_wrap__(self, obj: Any, context: Any = None, return_scalar: bool = False) -> Any:
        if return_scalar:
            return obj[()]
        return np.asarray(obj).view(np.ndarray)


#: Old column names and the column that replaced them (``res[old]`` still works, with a DeprecationWarning).
DEPRECATED_COLUMNS = {"mu_classic": "mu_classical"}

#: Columns shown by ``Results._repr_html_`` (those present and not all-NaN), in order.
_PREVIEW_COLUMNS = ("time", "mu_r", "mu_r_low", "mu_r_high", "mu_ols", "c_yz", "T", "J", "ok", "reasons")
#: Rows shown by ``Results._repr_html_``.
PREVIEW_ROWS = 5


class Params(Dict[str, Any]):
    """A Results' ``params``: a dict that cannot be changed after the Results is made (docs/architecture.md).

    It reads, copies (``dict(p)``, ``{**p, ...}``), compares, pickles and
    serialises (JSON) as a dict; ``p["k"] = v``, ``update``, ``pop`` and
    the like raise TypeError: a new value is a new Results
    (:meth:`Results.replace`).
    """

    __slots__ = ()

    def _refuse(self, *args: Any, **kwargs: Any) -> None:
        raise TypeError("a Results' params cannot be changed: make a new Results (Results.replace(params=...))")

    __setitem__ = __delitem__ = update = pop = popitem = clear = setdefault = _refuse  # type: ignore[assignment]
    __ior__ = _refuse  # type: ignore[assignment]

    def __reduce__(self) -> Tuple[Any, ...]:
        return (Params, (dict(self),))

    def copy(self) -> Dict[str, Any]:
        """A plain (changeable) dict of the same entries."""
        return dict(self)


#: The values a Results computes once from its fields, on first use (the cached properties).
CACHED = ("mu_r_ci", "column_ci", "verdict", "headline")


@dataclass(frozen=True, repr=False)
class Results:
    """Per-window results of ``tribodyn.analyze`` (docs/method.md section 6).

    Attributes
    ----------
    table : dict of str -> ndarray
        One entry per column of :data:`tribodyn.columns.TABLE` (the same
        names as :data:`WINDOW_COLUMNS`), one row per window.
    bin_counts, bin_cof : ndarray (n_windows, n_bins)
        Per-window COF against fz; bin edges span [fz_min, fz_max] per row.
    fz_min, fz_max : ndarray (n_windows,)
        Range of fz of each window's bins.
    orientation : int
        s in {+1, -1} applied to every window (fixed once per recording).
    params : dict
        Every parameter used, for provenance.
    moments : dict
        Per-window centred moments (n, mean_z, mean_y, syz) for merging.
    warnings : tuple of str
        What the reader found odd in the recording (``Recording.warnings``:
        e.g. a segment holding fewer rows than announced, irregular
        sampling, a last row dropped as cut off) and what the analysis
        noticed; each once, in order. They travel into ``summary()``,
        ``summary.json``, the report and the CLI's stderr.
    strokes : dict or None
        Per-stroke table of a reciprocating test (docs/method.md 6c).
    classical : ClassicalTotals or None
        The classical COF's sums over the recording (docs/method.md 6a, 6e).
    stick_slip : StickSlip or None
        The stick-slip events, found in the analysis' own reading when it
        was asked for (``analyze(stick_slip=True)``, docs/method.md 6g).
    budget_stats : uncertainty.Moments or None
        The headline's sufficient statistics for its uncertainty budget
        (``analyze(uncertainty=...)``, docs/method.md 6i).
    """

    table: Dict[str, np.ndarray]
    bin_counts: np.ndarray
    bin_cof: np.ndarray
    fz_min: np.ndarray
    fz_max: np.ndarray
    orientation: int
    params: Dict[str, Any] = field(default_factory=dict)
    #: Per-window n, mean_z, mean_y, syz (centred moments of fz, fy): lets
    #: separately analysed parts fix one orientation (docs/method.md 0).
    moments: Dict[str, np.ndarray] = field(default_factory=dict)
    warnings: Tuple[str, ...] = ()
    #: Per-stroke table of a reciprocating test (``tribometer.STROKE_COLUMNS``), or None (docs/method.md 6c).
    strokes: Optional[Dict[str, np.ndarray]] = None
    #: The classical COF's sums over the whole recording (docs/method.md 6a, 6e), or None.
    classical: Optional[ClassicalTotals] = None
    #: The stick-slip events found in the analysis' own reading (``analyze(stick_slip=True)``,
    #: docs/method.md 6g), or None when not asked for.
    stick_slip: Optional[Any] = None  # a tribodyn.StickSlip (defined in pipeline.stickslip, above this layer)
    #: The headline's sufficient statistics for its uncertainty budget (docs/method.md 6i), or None.
    budget_stats: Optional[Moments] = None

    def __post_init__(self) -> None:
        if not isinstance(self.params, Params):
            object.__setattr__(self, "params", Params(self.params))

    def replace(self, *, keep: Tuple[str, ...] = (), cached: Optional[Mapping[str, Any]] = None,
                **changes: Any) -> "Results":  # fmt: skip
        """``dataclasses.replace(self, **changes)`` carrying the values in ``keep`` (names of :data:`CACHED`)
        already computed from fields that ``changes`` leave valid, and taking ``cached`` (name: value) as
        computed: the one place such values pass from a Results to another (none is computed twice)."""
        unknown = set(keep) | set(cached or ())
        unknown -= set(CACHED)
        if unknown:
            raise ValueError(f"not a cached value of Results: {sorted(unknown)} (one of {CACHED})")
        out = dataclasses.replace(self, **changes)
        for key in keep:
            if key in self.__dict__:
                out.__dict__[key] = self.__dict__[key]
        for key, value in (cached or {}).items():
            out.__dict__[key] = value
        return out

    def computed(self, name: str) -> bool:
        """Whether the cached value ``name`` (one of :data:`CACHED`) has been computed (or given) already."""
        if name not in CACHED:
            raise ValueError(f"not a cached value of Results: {name!r} (one of {CACHED})")
        return name in self.__dict__

    def with_orientation(self, s: int) -> "Results":
        """The same results with orientation ``s`` (a sign flip of the COF columns; exact)."""
        if s not in (1, -1):
            raise ValueError(f"orientation must be +1 or -1, got {s!r}")
        if s == self.orientation:
            return self
        table = dict(self.table)
        for col in ("mu_r", "mu_a", "mu_b"):
            table[col] = -table[col]
        params = {**self.params, "orientation_used": s}
        # every other field carried as it is (stick_slip included); the verdict, headline and intervals
        # are computed anew from the flipped table
        return dataclasses.replace(self, table=table, bin_cof=-self.bin_cof, orientation=s, params=params)

    def __len__(self) -> int:
        return int(len(self.table["time"]))

    @property
    def columns(self) -> Tuple[str, ...]:
        return tuple(self.table)

    def __getitem__(self, column: str) -> np.ndarray:
        if column not in self.table and column in DEPRECATED_COLUMNS:
            new = DEPRECATED_COLUMNS[column]
            deprecated(f"column {column!r} is {new!r} now")
            column = new
        return self.table[column]

    def bins(self, k: int) -> BinTable:
        """The bin table of window ``k``."""
        return BinTable.from_range(float(self.fz_min[k]), float(self.fz_max[k]), self.bin_counts[k], self.bin_cof[k])

    @property
    def gated(self) -> np.ndarray:
        """Boolean mask of the windows that passed the quality gate (a property; ``res.gated()`` still works)."""
        return np.asarray(self.table["ok"], dtype=bool).view(GatedMask)

    @property
    def units(self) -> Dict[str, str]:
        """Unit of each column of the table (:data:`tribodyn.columns.UNITS`; ``""`` for labels)."""
        return {c: UNITS.get(c, "") for c in self.table}

    @property
    def cycles(self) -> Any:
        """One row per cycle of a reciprocating test, a ``pandas.DataFrame`` (None without strokes).

        Columns :data:`tribodyn.pipeline.prepass.CYCLE_COLUMNS` (units in
        ``df.attrs["units"]``): the forward, backward and cycle COF, the
        offset, and with a position channel ``x`` the energy dissipated (the
        friction loop's area), the sliding distance, the energy COF and the
        slip amplitude (docs/method.md 6c). The per-stroke headline is the
        mean of ``mu_cycle``.
        """
        if self.strokes is None or not len(self.strokes.get("mu", [])):
            return None
        import pandas as pd

        from ..kernels.strokes import CYCLE_COLUMNS, cycle_table

        df = pd.DataFrame(cycle_table(self.strokes))
        df.attrs["units"] = {k: u for k, (u, _) in CYCLE_COLUMNS.items()}
        return df

    @property
    def _gated_mu(self) -> Tuple[np.ndarray, np.ndarray]:
        """(mu_r of the gated windows with a finite mu_r, the mask of those windows over the table)."""
        ok = np.asarray(self.table["ok"], dtype=bool)
        mu = np.asarray(self.table["mu_r"], dtype=float)
        keep = ok & np.isfinite(mu)
        return mu[keep], keep

    @property
    def _threads(self) -> Optional[int]:
        """The analysis's thread count (``params["threads"]``), for the bootstraps; None: the default."""
        n = self.params.get("threads")
        return int(n) if isinstance(n, (int, np.integer)) and not isinstance(n, bool) and n >= 1 else None

    @property
    def _lag_shifts(self) -> Tuple[float, ...]:
        """mu_r's moves at the other lags the instrument's lag was chosen among (``params["iv_lag_shifts"]``,
        docs/method.md 3d): the headline's bootstrap pools over them; () when the lag was not chosen from the data."""
        return tuple(float(x) for x in self.params.get("iv_lag_shifts") or ())

    @cached
    def mu_r_ci(self) -> Dict[str, Tuple[float, float]]:
        """:func:`bootstrap_ci` of mu_r over the gated windows, the fz-noise estimate drawn anew in each
        resample and, when the instrument's lag was chosen from the data, pooled over the lags the choice could
        not tell apart (docs/method.md 3d): ``summary()["mu_r"]["ci"]`` and the dynamic headline's interval,
        computed once."""
        mu, keep = self._gated_mu
        ci = bootstrap_ci(mu, noise=noise_resample(self.table, keep), threads=self._threads, shifts=self._lag_shifts)
        gap = self.params.get("attenuation_gap")
        if self.params.get("mu_r_bound") == "lower" and gap is not None and np.isfinite(gap):
            # least squares is a lower bound: the upper ends reach the reverse regression (docs/method.md 3d)
            ci = {k: (lo, hi + float(gap)) for k, (lo, hi) in ci.items()}
        return ci

    def summary_columns(self) -> Dict[str, np.ndarray]:
        """The values whose statistics ``summary()`` gives besides mu_r's, each with its bootstrap interval
        (:attr:`column_ci`): :data:`SUMMARY_COLUMNS` over the gated windows; "classical" and "instrument" (the
        per-window classical and instrument COF) over every window; "strokes.forward", "strokes.backward" and
        "strokes.all" (a reciprocating test's per-stroke COF). Finite values only."""
        ok = np.asarray(self.table["ok"], dtype=bool)
        out: Dict[str, np.ndarray] = {}
        for col in SUMMARY_COLUMNS:
            if col in self.table:
                out[col] = np.asarray(self.table[col])[ok]
        for key, col in (("classical", "mu_classical"), ("instrument", "mu_instrument")):
            if col in self.table:
                out[key] = np.asarray(self.table[col], dtype=float)
        if self.strokes is not None and len(self.strokes.get("mu", [])):
            mu, d = np.asarray(self.strokes["mu"], dtype=float), np.asarray(self.strokes["direction"])
            out.update({"strokes.forward": mu[d == 1], "strokes.backward": mu[d == -1], "strokes.all": mu})
        return {k: np.asarray(v[np.isfinite(v)]) for k, v in out.items()}

    @cached
    def column_ci(self) -> Dict[str, Dict[str, Tuple[float, float]]]:
        """:func:`bootstrap_ci` of each of :meth:`summary_columns`: the intervals of ``summary()`` beside mu_r's
        (docs/method.md 3d), computed once."""
        return {k: bootstrap_ci(v, threads=self._threads) for k, v in self.summary_columns().items()}

    @cached
    def verdict(self) -> Dict[str, Any]:
        """Whether the dynamic method applies, why not, and the motion (``tribometer.verdict``; docs/method.md 6d)."""
        return _verdict(self.table, self.params, self.strokes, int(self.gated.sum()))

    @cached
    def headline(self) -> Headline:
        """The one COF to read first, chosen by the verdict (:class:`tribodyn.Headline`; docs/method.md 6e).

        The dynamic COF (median mu_r of the gated windows) when the dynamic
        method applies; else the classical COF of the whole recording
        (unidirectional) or the per-stroke COF (reciprocating), both means.
        ``str(res.headline)`` is its one-line text.
        """
        return choose(self, self.verdict)

    def __repr__(self) -> str:
        n = len(self)
        ok = np.asarray(self.table["ok"], dtype=bool) if n else np.zeros(0, dtype=bool)
        t = np.asarray(self.table["time"], dtype=float) if n else np.zeros(0)
        span = f", t {t.min():.6g}..{t.max():.6g} s" if n and np.isfinite(t).any() else ""
        text = f"<Results: {self.headline.short}; {n} windows, {int(ok.sum())} gated{span}>"
        return text if len(text) <= 300 else text[:296] + "...>"

    def _repr_html_(self) -> str:
        """Jupyter's view: the verdict (or the COF headline), the counts and the first rows with units."""
        esc = _html.escape
        n = len(self)
        cols = [
            c
            for c in _PREVIEW_COLUMNS
            if c in self.table
            and not (np.asarray(self.table[c]).dtype.kind == "f" and not np.isfinite(self.table[c]).any())
        ]
        head = "".join(
            f"<th>{esc(c)}"
            + (f" ({esc(_unit_text(UNITS.get(c, '')))})" if _unit_text(UNITS.get(c, "")) else "")
            + "</th>"
            for c in cols
        )
        rows: List[str] = []
        for k in range(min(n, PREVIEW_ROWS)):
            cells = "".join(f"<td>{esc(_cell_text(self.table[c][k]))}</td>" for c in cols)
            rows.append(f"<tr>{cells}</tr>")
        more = f"<p><i>First {min(n, PREVIEW_ROWS)} of {n} windows; all of them: <code>res.to_pandas()</code>.</i></p>"
        return (
            '<div class="tribodyn-results">'
            f"<p><b>tribodyn Results</b>: {n} windows, {int(np.sum(self.table['ok']))} passed the quality gate</p>"
            f"<p><b>{esc(self.headline.text)}</b></p>"
            f"<p>{esc(verdict_text(self.verdict))}</p>"
            f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>{more}</div>"
        )

    def to_pandas(self) -> Any:
        """The per-window table as a ``pandas.DataFrame``, indexed by the window centre ``time`` in s.

        The units of the columns (and of the index) are in ``df.attrs["units"]``
        (from :data:`tribodyn.columns.UNITS`: ``"1"`` dimensionless, ``""`` a
        label); ``df.attrs["params"]`` holds the analysis parameters.
        """
        import pandas as pd

        data = {k: v for k, v in self.table.items() if k != "time"}
        index = pd.Index(np.asarray(self.table["time"], dtype=float), name="time")
        df = pd.DataFrame(data, index=index)
        df.attrs["units"] = {"time": UNITS["time"], **{c: UNITS.get(c, "") for c in data}}
        df.attrs["params"] = dict(self.params)
        return df

    def summary(self) -> Dict[str, Any]:
        """COF statistics of the gated windows (for the JSON summary).

        Each statistic of ``mu_r`` (and of ``mu_a``, ``mu_b``,
        ``force_dependence``, ``dmu_dfn``) comes with a 95 % interval in
        ``"ci"``: a moving-block bootstrap over the gated windows in time
        order (docs/method.md 3d; :func:`bootstrap_ci`).
        """
        ok = np.asarray(self.table["ok"], dtype=bool)
        mu, _ = self._gated_mu

        def stats(v: np.ndarray, ci: Dict[str, Tuple[float, float]]) -> Mapping[str, Any]:
            if v.size == 0:
                return {"n": 0}
            q = np.percentile(v, [5, 25, 50, 75, 95])
            return {
                "n": int(v.size),
                "mean": float(v.mean()),
                "std": float(v.std()),
                "min": float(v.min()),
                "p05": float(q[0]),
                "p25": float(q[1]),
                "median": float(q[2]),
                "p75": float(q[3]),
                "p95": float(q[4]),
                "max": float(v.max()),
                "ci": ci,
            }

        out: Dict[str, Any] = {
            "windows": len(self),
            "gated": int(ok.sum()),
            "gate_pass_fraction": float(ok.mean()) if len(self) else float("nan"),
            "orientation": self.orientation,
            "mu_r": stats(mu, self.mu_r_ci),
            "warnings": list(self.warnings),
        }
        values, cis = self.summary_columns(), self.column_ci
        for col in SUMMARY_COLUMNS:
            if col in values:
                out[col] = stats(values[col], cis[col])
        for key in ("method", "estimator", "gate", "noise_z_std", "delay_samples", "orientation_r",
                    "orientation_agreement"):  # fmt: skip
            if self.params.get(key) is not None:
                out[key] = self.params[key]
        counts: Dict[str, int] = {}
        for r, times in Counter(self.table["reasons"].tolist()).items():  # each distinct reason split once
            for part in str(r).split("; ") if r else ():
                key = part.split(":")[0]
                counts[key] = counts.get(key, 0) + times  # (keys in the order the windows first give them)
        out["gate_failures"] = counts
        out.update(self._tribometer_summary(values, lambda key: stats(values[key], cis[key])))
        head = self.headline
        out["headline"] = head.to_dict()
        out["verdict"]["cof"] = out["headline"]
        comparison, _ = instrument_check(self, head)
        if comparison:
            out["instrument_comparison"] = comparison
        return out

    def _tribometer_summary(self, values: Mapping[str, np.ndarray], stats: Any) -> Dict[str, Any]:
        """ "classical", "instrument", "strokes", "roles", "motion" and "verdict" (docs/method.md 6a-6d); ``values``
        is :meth:`summary_columns`, ``stats`` gives the statistics of one of its entries by its key."""
        out: Dict[str, Any] = {}
        for key in ("classical", "instrument"):
            if values.get(key, np.zeros(0)).size:
                out[key] = dict(stats(key))
                if key == "classical":
                    med = np.asarray(self.table["mu_classical_median"], dtype=float)
                    out[key]["median_of_medians"] = float(np.nanmedian(med)) if np.isfinite(med).any() else None
                    out[key]["min_fn"] = self.params.get("min_fn")
                    out[key]["tare"] = self.params.get("tare_offsets")
                    raw = self.classical.without_fy_tare() if self.classical is not None else float("nan")
                    # the whole recording's classical COF with fy's tare not subtracted (a drag; 6a)
                    out[key]["without_fy_tare"] = raw if np.isfinite(raw) else None
        if self.strokes is not None and len(self.strokes.get("mu", [])):
            per: Dict[str, Any] = {"n": int(len(self.strokes["mu"]))}
            for name in ("forward", "backward", "all"):
                per[name] = dict(stats(f"strokes.{name}"))
            out["strokes"] = per
        for key in ("roles", "roles_source", "roles_evidence", "motion", "window_note", "contact"):
            if self.params.get(key) is not None:
                out[key] = self.params[key]
        out["verdict"] = dict(self.verdict)
        return out


def _unit_text(unit: str) -> str:
    """A unit as a reader writes it (°C, A/mm²); dimensionless ("1") and labels ("") as nothing."""
    return {"1": "", "degC": "°C", "A/mm^2": "A/mm²", "1/N": "1/N"}.get(unit, unit)


def _cell_text(v: Any) -> str:
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if isinstance(v, (float, np.floating)):
        return "NaN" if not np.isfinite(v) else format(float(v), ".4g")
    return str(v)


def verdict_text(verdict: Any) -> str:
    """``summary()["verdict"]`` in words: a text as it is; the dict form (dynamic_method, motion, reasons)
    as one sentence, without the COF (that is the headline's, :class:`tribodyn.Headline`); "" when there is none."""
    if not verdict:
        return ""
    if isinstance(verdict, str):
        return verdict
    if not isinstance(verdict, Mapping):
        return str(verdict)
    if verdict.get("text"):
        return str(verdict["text"])
    motion = f" ({verdict['motion']} motion)" if verdict.get("motion") else ""
    if verdict.get("dynamic_method", True):
        text = f"The dynamic method applies{motion}."
    else:
        text = f"The dynamic method does not apply{motion}."
    reasons = [str(r) for r in verdict.get("reasons") or ()]
    if reasons:
        text += " " + "; ".join(reasons) + "."
    pool = verdict.get("pooled")
    if isinstance(pool, Mapping):  # docs/method.md 5
        text += (f" No window passes the gate alone: its COF pools the {pool.get('n')} windows that fail only as "
                 f"imprecise, which agree (homogeneity p = {float(pool.get('p', float('nan'))):.2g}).")  # fmt: skip
    return text
