"""Typed results of the COF identification (docs/method.md sections 4-7)."""

from __future__ import annotations

import html as _html
import math
import warnings as _warnings
from dataclasses import dataclass, field
from functools import cached_property
from statistics import NormalDist
from typing import TYPE_CHECKING, Any, Dict, List, Mapping, Optional, Tuple

import numpy as np

from .columns import UNITS, WINDOW_COLUMNS
from ._order import row_quantiles
from .correlation import XcorrResult
from .headline import ClassicalTotals, Headline

if TYPE_CHECKING:
    from .stickslip import StickSlip
    from .uncertainty import Moments

__all__ = ["BinTable", "CofResult", "Results", "WINDOW_COLUMNS"]


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
        _warnings.warn(
            "Results.gated is a property now: use res.gated instead of res.gated()", DeprecationWarning, stacklevel=2
        )
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
    stick_slip: Optional["StickSlip"] = None
    #: The headline's sufficient statistics for its uncertainty budget (docs/method.md 6i), or None.
    budget_stats: Optional["Moments"] = None

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
        return Results(
            table=table,
            bin_counts=self.bin_counts,
            bin_cof=-self.bin_cof,
            fz_min=self.fz_min,
            fz_max=self.fz_max,
            orientation=s,
            params=params,
            moments=self.moments,
            warnings=self.warnings,
            strokes=self.strokes,
            classical=self.classical,
            budget_stats=self.budget_stats,
        )

    def __len__(self) -> int:
        return int(len(self.table["time"]))

    @property
    def columns(self) -> Tuple[str, ...]:
        return tuple(self.table)

    def __getitem__(self, column: str) -> np.ndarray:
        if column not in self.table and column in DEPRECATED_COLUMNS:
            new = DEPRECATED_COLUMNS[column]
            _warnings.warn(f"column {column!r} is {new!r} now", DeprecationWarning, stacklevel=2)
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

        Columns :data:`tribodyn.tribometer.CYCLE_COLUMNS` (units in
        ``df.attrs["units"]``): the forward, backward and cycle COF, the
        offset, and with a position channel ``x`` the energy dissipated (the
        friction loop's area), the sliding distance, the energy COF and the
        slip amplitude (docs/method.md 6c). The per-stroke headline is the
        mean of ``mu_cycle``.
        """
        if self.strokes is None or not len(self.strokes.get("mu", [])):
            return None
        import pandas as pd

        from .tribometer import CYCLE_COLUMNS, cycle_table

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

    @cached_property
    def mu_r_ci(self) -> Dict[str, Tuple[float, float]]:
        """:func:`bootstrap_ci` of mu_r over the gated windows, the fz-noise estimate drawn anew in each
        resample (docs/method.md 3d): ``summary()["mu_r"]["ci"]`` and the dynamic headline's interval,
        computed once."""
        mu, keep = self._gated_mu
        ci = bootstrap_ci(mu, noise=noise_resample(self.table, keep), threads=self._threads)
        gap = self.params.get("attenuation_gap")
        if self.params.get("mu_r_bound") == "lower" and gap is not None and np.isfinite(gap):
            # least squares is a lower bound: the upper ends reach the reverse regression (docs/method.md 3d)
            ci = {k: (lo, hi + float(gap)) for k, (lo, hi) in ci.items()}
        return ci

    @cached_property
    def verdict(self) -> Dict[str, Any]:
        """Whether the dynamic method applies, why not, and the motion (``tribometer.verdict``; docs/method.md 6d)."""
        from .tribometer import verdict

        return verdict(self.table, self.params, self.strokes, int(self.gated.sum()))

    @cached_property
    def headline(self) -> Headline:
        """The one COF to read first, chosen by the verdict (:class:`tribodyn.Headline`; docs/method.md 6e).

        The dynamic COF (median mu_r of the gated windows) when the dynamic
        method applies; else the classical COF of the whole recording
        (unidirectional) or the per-stroke COF (reciprocating), both means.
        ``str(res.headline)`` is its one-line text.
        """
        from .headline import choose

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

        def stats(v: np.ndarray, ci: Optional[Dict[str, Tuple[float, float]]] = None) -> Mapping[str, Any]:
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
                "ci": bootstrap_ci(v, threads=self._threads) if ci is None else ci,
            }

        out: Dict[str, Any] = {
            "windows": len(self),
            "gated": int(ok.sum()),
            "gate_pass_fraction": float(ok.mean()) if len(self) else float("nan"),
            "orientation": self.orientation,
            "mu_r": stats(mu, self.mu_r_ci),
            "warnings": list(self.warnings),
        }
        for col in ("mu_a", "mu_b", "force_dependence", "dmu_dfn"):
            if col not in self.table:
                continue
            v = np.asarray(self.table[col])[ok]
            out[col] = stats(v[np.isfinite(v)])
        for key in ("method", "estimator", "gate", "noise_z_std", "delay_samples", "orientation_r",
                    "orientation_agreement"):  # fmt: skip
            if self.params.get(key) is not None:
                out[key] = self.params[key]
        reasons = [r for r in self.table["reasons"] if r]
        counts: Dict[str, int] = {}
        for r in reasons:
            for part in str(r).split("; "):
                key = part.split(":")[0]
                counts[key] = counts.get(key, 0) + 1
        out["gate_failures"] = counts
        out.update(self._tribometer_summary(stats))
        head = self.headline
        out["headline"] = head.to_dict()
        out["verdict"]["cof"] = out["headline"]
        from .headline import instrument_check

        comparison, _ = instrument_check(self, head)
        if comparison:
            out["instrument_comparison"] = comparison
        return out

    def _tribometer_summary(self, stats: Any) -> Dict[str, Any]:
        """ "classical", "instrument", "strokes", "roles", "motion" and "verdict" (docs/method.md 6a-6d)."""
        out: Dict[str, Any] = {}
        for key, col in (("classical", "mu_classical"), ("instrument", "mu_instrument")):
            v = np.asarray(self.table.get(col, []), dtype=float)
            v = v[np.isfinite(v)]
            if v.size:
                out[key] = dict(stats(v))
                if key == "classical":
                    med = np.asarray(self.table["mu_classical_median"], dtype=float)
                    out[key]["median_of_medians"] = float(np.nanmedian(med)) if np.isfinite(med).any() else None
                    out[key]["min_fn"] = self.params.get("min_fn")
                    out[key]["tare"] = self.params.get("tare_offsets")
        if self.strokes is not None and len(self.strokes.get("mu", [])):
            st = self.strokes
            per: Dict[str, Any] = {"n": int(len(st["mu"]))}
            for d, name in ((1, "forward"), (-1, "backward")):
                m = np.asarray(st["mu"])[np.asarray(st["direction"]) == d]
                m = m[np.isfinite(m)]
                per[name] = dict(stats(m)) if m.size else {"n": 0}
            allm = np.asarray(st["mu"], dtype=float)
            per["all"] = dict(stats(allm[np.isfinite(allm)]))
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
    return text


#: Resamples of :func:`bootstrap_ci` and its fixed seed (results are reproducible).
BOOTSTRAP_RESAMPLES = 999
BOOTSTRAP_SEED = 20061136


@dataclass(frozen=True)
class NoiseResample:
    """What :func:`bootstrap_ci` needs to draw the recording's fz-noise estimate anew (docs/method.md 3d).

    Attributes
    ----------
    var : ndarray
        Every window's measurement of sigma_z^2 (column ``noise_z_var``, N^2), in time order.
    index : ndarray of int64
        The positions in ``var`` of the windows whose values are bootstrapped, increasing.
    dnoise : ndarray
        d value / d sigma_z^2 of those windows (column ``mu_r_dnoise``, 1/N^2).
    """

    var: np.ndarray
    index: np.ndarray
    dnoise: np.ndarray


def noise_resample(table: Mapping[str, np.ndarray], keep: np.ndarray) -> Optional[NoiseResample]:
    """The :class:`NoiseResample` of the windows ``keep`` (a mask over the table's rows), or None when
    mu_r does not depend on a noise estimate of the recording (``mu_r_dnoise`` 0: OLS, IV, Deming, a
    given ``noise``, the paper's method; docs/method.md 3c, 3d)."""
    if "noise_z_var" not in table or "mu_r_dnoise" not in table:
        return None
    keep = np.asarray(keep, dtype=bool)
    dn = np.asarray(table["mu_r_dnoise"], dtype=float)[keep]
    dn = np.where(np.isfinite(dn), dn, 0.0)
    var = np.asarray(table["noise_z_var"], dtype=float)
    if not np.any(dn != 0) or not np.isfinite(var).any():
        return None
    return NoiseResample(var=var, index=np.flatnonzero(keep), dnoise=dn)


def t_quantile(p: float, df: int) -> float:
    """Student's t quantile: exact for 1 and 2 degrees of freedom, else the Cornish-Fisher expansion in
    1/df to the 4th order (Abramowitz and Stegun 26.7.5; at p = 0.975 within 0.12 % at df = 3 and 1e-5
    at df >= 8; at p = 0.995 within 0.8 % at df = 3)."""
    if df == 1:
        return math.tan(math.pi * (p - 0.5))
    if df == 2:
        return (2.0 * p - 1.0) / math.sqrt(2.0 * p * (1.0 - p))
    z = NormalDist().inv_cdf(p)
    g1 = (z**3 + z) / 4
    g2 = (5 * z**5 + 16 * z**3 + 3 * z) / 96
    g3 = (3 * z**7 + 19 * z**5 + 17 * z**3 - 15 * z) / 384
    g4 = (79 * z**9 + 776 * z**7 + 1482 * z**5 - 1920 * z**3 - 945 * z) / 92160
    return float(z + g1 / df + g2 / df**2 + g3 / df**3 + g4 / df**4)


def _blocks(rng: np.random.Generator, n: int) -> np.ndarray:
    """Moving-block resamples of n windows: (BOOTSTRAP_RESAMPLES, n) indices, blocks of ceil(n^(1/3))."""
    starts, ell = _block_starts(rng, n)
    return _expand(starts, ell, n)


def _block_starts(rng: np.random.Generator, n: int) -> Tuple[np.ndarray, int]:
    """The first window of every block of every resample (as :func:`_blocks` draws them) and the block length."""
    ell = int(np.ceil(n ** (1.0 / 3.0)))
    return rng.integers(0, n - ell + 1, size=(BOOTSTRAP_RESAMPLES, -(-n // ell))), ell


def _expand(starts: np.ndarray, ell: int, n: int) -> np.ndarray:
    """The window indices of the resamples whose blocks start at ``starts`` (rows of :func:`_block_starts`)."""
    idx: np.ndarray = (starts[:, :, None] + np.arange(ell)[None, None, :]).reshape(starts.shape[0], -1)[:, :n]
    return idx


#: Cells (resamples x windows) :func:`bootstrap_ci` holds at once: its memory does not grow with the recording.
_CHUNK_CELLS = 1 << 18


def _row_chunks(rows: int, width: int) -> List[slice]:
    step = max(1, min(rows, _CHUNK_CELLS // max(width, 1)))
    return [slice(a, min(a + step, rows)) for a in range(0, rows, step)]


def _resample_stats(v: np.ndarray, starts: np.ndarray, ell: int, noise: Optional[Tuple[Any, ...]]
                    ) -> Tuple[np.ndarray, ...]:  # fmt: skip
    """(median, mean, p05, p95) of the resamples whose blocks start at ``starts`` (see :func:`bootstrap_ci`)."""
    if noise is None:
        r = v[_expand(starts, ell, v.size)]
        if np.isnan(r).any():  # NaN in v: NumPy's NaN-propagating statistics, as they always were
            return np.median(r, axis=1), r.mean(axis=1), np.percentile(r, 5, axis=1), np.percentile(r, 95, axis=1)
        med, (p05, p95) = row_quantiles(r, (5, 95))
        return med, r.mean(axis=1), p05, p95
    var, pos, dn, used = noise
    idx = _expand(starts, ell, var.size)
    p = pos[idx]
    with np.errstate(invalid="ignore"), _warnings.catch_warnings():
        _warnings.simplefilter("ignore", RuntimeWarning)  # a resample without any of v's windows is NaN
        delta = np.maximum(row_quantiles(var[idx], ())[0], 0.0) - used
        r = dn[p]  # v[p] + dn[p] * delta, in place (p < 0, a window not among v's: NaN)
        r *= delta[:, None]
        r += v[p]
        out = p < 0
        if out.any():
            r[out] = np.nan
        med, (p05, p95) = row_quantiles(r, (5, 95))
        # without NaN, np.nanmean is np.mean (the same sums over the same count)
        mean = np.nanmean(r, axis=1) if np.isnan(r).any() else r.mean(axis=1)
        return med, mean, p05, p95


def _threads(threads: Optional[int]) -> int:
    if threads is None:
        from .threads import resolve_threads

        return resolve_threads()
    return max(1, int(threads))


def _all_resample_stats(v: np.ndarray, starts: np.ndarray, ell: int, noise: Optional[Tuple[Any, ...]], *, width: int,
                        threads: int) -> Tuple[np.ndarray, ...]:  # fmt: skip
    """(median, mean, p05, p95) of every resample: the Rust kernel (one pass per resample, rows on
    ``threads`` threads) when the extension has it, else :func:`_resample_stats` a bounded chunk of
    resamples at a time (every statistic is per resample: the same numbers as all at once)."""
    from . import _core

    if hasattr(_core, "resample_stats"):
        nz = None if noise is None else (np.ascontiguousarray(noise[0], dtype=float),
                                         np.ascontiguousarray(noise[1], dtype=np.int64),
                                         np.ascontiguousarray(noise[2], dtype=float), float(noise[3]))  # fmt: skip
        flat = _core.resample_stats(np.ascontiguousarray(v, dtype=float), np.ascontiguousarray(starts, dtype=np.int64),
                                    ell, noise=nz, threads=threads)  # fmt: skip
        rows = starts.shape[0]
        return tuple(flat[j * rows : (j + 1) * rows] for j in range(4))
    chunks = _row_chunks(starts.shape[0], width)
    workers = min(len(chunks), threads)
    if workers < 2:
        parts = [_resample_stats(v, starts[c], ell, noise) for c in chunks]
    else:  # NumPy's selections, gathers and ufuncs release the GIL
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(workers) as ex:
            parts = list(ex.map(lambda c: _resample_stats(v, starts[c], ell, noise), chunks))
    return tuple(np.concatenate([p[j] for p in parts]) for j in range(4))


def bootstrap_ci(
    v: np.ndarray,
    level: float = 0.95,
    *,
    noise: Optional[NoiseResample] = None,
    threads: Optional[int] = None,
) -> Dict[str, Tuple[float, float]]:
    """95 % intervals of the median, mean, p05 and p95 of ``v`` (windows in time order; docs/method.md 3d).

    Moving-block bootstrap (Kuensch 1989): blocks of l = ceil(n^(1/3))
    consecutive windows, drawn with replacement until n windows, 999
    resamples with a fixed seed. Neighbouring windows are correlated (the
    temperature or the contact changes slowly), which blocks keep.
    Expanded percentile intervals: the percentiles a and 1 - a with
    a = Phi(-sqrt(b / (b - 1)) t(1 - (1 - level) / 2, b - 1)), b the number
    of blocks (the percentile interval is too short for few independent
    blocks; Hesterberg 2015, with blocks for observations).

    With ``noise`` (``v`` depends on the recording's fz-noise estimate
    sigma^2, the median of every window's measurement), the blocks are drawn
    over all the recording's windows; each resample re-estimates sigma^2*
    as the median of its windows' ``noise.var`` (clipped at 0) and takes its
    windows among ``noise.index``, moved by ``noise.dnoise`` (sigma^2* -
    sigma^2). So the interval carries the error of the noise estimate, which
    moves every window together, and its correlation with the windows' own
    errors. Empty for fewer than 3 windows.

    The resamples are taken a bounded chunk at a time (memory does not grow
    with the recording), on ``threads`` threads (default: the call's
    default, :func:`tribodyn.get_threads`); the numbers depend on neither.
    """
    v = np.asarray(v, dtype=float)
    n = v.size
    if n < 3:
        return {}
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    args: Optional[Tuple[Any, ...]] = None
    if noise is None:
        starts, ell = _block_starts(rng, n)
        width = n
    else:
        var = np.asarray(noise.var, dtype=float)
        index = np.asarray(noise.index, dtype=np.int64)
        dn = np.asarray(noise.dnoise, dtype=float)
        if index.shape != v.shape or dn.shape != v.shape:
            raise ValueError(f"noise.index and noise.dnoise must have one value per window ({n})")
        if var.ndim != 1 or (index.size and (index.min() < 0 or index.max() >= var.size)):
            raise ValueError("noise.index must point into noise.var")
        fin = np.isfinite(var)
        used = max(float(np.median(var[fin])), 0.0) if fin.any() else float("nan")
        starts, ell = _block_starts(rng, var.size)
        pos = np.full(var.size, -1, dtype=np.int64)
        pos[index] = np.arange(n)
        args, width = (var, pos, dn, used), var.size
    stats = _all_resample_stats(v, starts, ell, args, width=width, threads=_threads(threads))
    b = -(-n // int(np.ceil(n ** (1.0 / 3.0))))
    a = 100.0 * NormalDist().cdf(-math.sqrt(b / (b - 1)) * t_quantile(1.0 - (1.0 - level) / 2.0, b - 1))
    out: Dict[str, Tuple[float, float]] = {}
    for name, values in zip(("median", "mean", "p05", "p95"), stats):
        values = values[np.isfinite(values)]
        if values.size == 0:
            continue
        lo, hi = np.percentile(values, [a, 100.0 - a])
        out[name] = (float(lo), float(hi))
    return out
