"""Typed results of the COF identification (docs/method.md sections 4-7)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, Mapping, Optional, Tuple

import numpy as np

from .columns import WINDOW_COLUMNS
from .correlation import XcorrResult

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


@dataclass(frozen=True)
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
        )

    def __len__(self) -> int:
        return int(len(self.table["time"]))

    @property
    def columns(self) -> Tuple[str, ...]:
        return tuple(self.table)

    def __getitem__(self, column: str) -> np.ndarray:
        return self.table[column]

    def bins(self, k: int) -> BinTable:
        """The bin table of window ``k``."""
        return BinTable.from_range(float(self.fz_min[k]), float(self.fz_max[k]), self.bin_counts[k], self.bin_cof[k])

    def gated(self) -> np.ndarray:
        """Boolean mask of the windows that passed the quality gate."""
        return np.asarray(self.table["ok"], dtype=bool)

    def to_pandas(self) -> Any:
        """The per-window table as a ``pandas.DataFrame`` (needs pandas)."""
        try:
            import pandas as pd
        except ImportError as exc:  # pragma: no cover - depends on the environment
            raise ImportError("to_pandas needs pandas: pip install pandas") from exc
        return pd.DataFrame(dict(self.table))

    def summary(self) -> Dict[str, Any]:
        """COF statistics of the gated windows (for the JSON summary).

        Each statistic of ``mu_r`` (and of ``mu_a``, ``mu_b``,
        ``force_dependence``, ``dmu_dfn``) comes with a 95 % interval in
        ``"ci"``: a moving-block bootstrap over the gated windows in time
        order (docs/method.md 3d; :func:`bootstrap_ci`).
        """
        ok = self.gated()
        mu = np.asarray(self.table["mu_r"])[ok]
        mu = mu[np.isfinite(mu)]

        def stats(v: np.ndarray) -> Mapping[str, Any]:
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
                "ci": bootstrap_ci(v),
            }

        out: Dict[str, Any] = {
            "windows": len(self),
            "gated": int(ok.sum()),
            "gate_pass_fraction": float(ok.mean()) if len(self) else float("nan"),
            "orientation": self.orientation,
            "mu_r": stats(mu),
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
        return out


#: Resamples of :func:`bootstrap_ci` and its fixed seed (results are reproducible).
BOOTSTRAP_RESAMPLES = 999
BOOTSTRAP_SEED = 20061136


def bootstrap_ci(v: np.ndarray, level: float = 0.95) -> Dict[str, Tuple[float, float]]:
    """95 % intervals of the median, mean, p05 and p95 of ``v`` (windows in time order; docs/method.md 3d).

    Moving-block bootstrap (Kuensch 1989): blocks of l = ceil(n^(1/3))
    consecutive windows, drawn with replacement until n windows, 999
    resamples with a fixed seed; percentile intervals. Neighbouring windows
    are correlated (the temperature or the contact changes slowly), which
    blocks keep. Empty for fewer than 3 windows.
    """
    v = np.asarray(v, dtype=float)
    n = v.size
    if n < 3:
        return {}
    ell = int(np.ceil(n ** (1.0 / 3.0)))
    nblocks = -(-n // ell)
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    starts = rng.integers(0, n - ell + 1, size=(BOOTSTRAP_RESAMPLES, nblocks))
    idx = (starts[:, :, None] + np.arange(ell)[None, None, :]).reshape(BOOTSTRAP_RESAMPLES, -1)[:, :n]
    r = v[idx]
    a = (1.0 - level) / 2.0 * 100.0
    out: Dict[str, Tuple[float, float]] = {}
    for name, values in (
        ("median", np.median(r, axis=1)),
        ("mean", r.mean(axis=1)),
        ("p05", np.percentile(r, 5, axis=1)),
        ("p95", np.percentile(r, 95, axis=1)),
    ):
        lo, hi = np.percentile(values, [a, 100.0 - a])
        out[name] = (float(lo), float(hi))
    return out
