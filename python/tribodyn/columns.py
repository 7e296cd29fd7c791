"""The per-window table's columns, declared once (docs/method.md 3-6).

Every per-window quantity tribodyn reports is named here with its unit and
meaning: :data:`TABLE` is the table of :func:`tribodyn.analyze` (its
order is the table's, the CSV's and the Parquet file's), and
:func:`kernel_columns` the statistics asked of the Rust kernel (it returns
exactly those, in that order; orientation +1, flipped afterwards by
``window_stats.orient``). :data:`WINDOW_COLUMNS`, the writers, the NumPy
reference and the benchmarks read these declarations.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Tuple

__all__ = ["Column", "TABLE", "WINDOW_COLUMNS", "UNITS", "KERNEL_COLUMNS", "kernel_columns", "FLOAT_COLUMNS"]


@dataclass(frozen=True)
class Column:
    """One column of the per-window table.

    Attributes
    ----------
    name : str
        Column name (also the CSV header and the Parquet field).
    unit : str
        SI unit, ``"1"`` for a dimensionless number, ``""`` for a label.
    meaning : str
        What the column holds, with the section of docs/method.md.
    dtype : str
        NumPy dtype of the column: ``float64``, ``int64``, ``int8``,
        ``bool`` or ``str``.
    """

    name: str
    unit: str
    meaning: str
    dtype: str = "float64"


#: The table of :func:`tribodyn.analyze`, in order.
TABLE: Tuple[Column, ...] = (
    Column("time", "s", "window centre, from the start of the recording (docs/method.md 6)"),
    Column("t_start", "s", "window start, from the start of the recording"),
    Column("mu_r", "1", "COF by regression, s * slope of fy on fz, by the chosen estimator (docs/method.md 3a-3c)"),
    Column("mu_r_stderr", "1", "standard error of mu_r, batch means over 5 blocks (paper: OLS's; docs/method.md 3d)"),
    Column("mu_r_low", "1", "lower end of the 95 % interval of mu_r (docs/method.md 3d)"),
    Column("mu_r_high", "1", "upper end of the 95 % interval of mu_r (docs/method.md 3d)"),
    Column("mu_ols", "1", "COF by least squares, the paper's Eq. 8 (docs/method.md 3a)"),
    Column("noise_z_var", "N^2", "the window's measurement of the fz noise variance sigma_z^2 (docs/method.md 3c)"),
    Column(
        "mu_r_dnoise",
        "1/N^2",
        "d mu_r / d sigma_z^2: how mu_r moves with the recording's fz-noise estimate (0 unless measured; "
        "docs/method.md 3c, 3d)",
    ),
    Column("attenuation_p", "1", "p-value of OLS = IV (small: OLS attenuated by noise on fz; docs/method.md 3b)"),
    Column("dmu_dfn", "1/N", "d mu / d Fn from the quadratic fit (docs/method.md 3e)"),
    Column("dmu_dfn_stderr", "1/N", "standard error of dmu_dfn (docs/method.md 3e)"),
    Column("dmu_dfn_low", "1/N", "lower end of the 95 % interval of dmu_dfn (docs/method.md 3e)"),
    Column("dmu_dfn_high", "1/N", "upper end of the 95 % interval of dmu_dfn (docs/method.md 3e)"),
    Column("f_y0", "N", "regression intercept in the measured fy frame (Eq. 7)"),
    Column("r", "1", "Pearson r of fy and fz"),
    Column("mu_a", "1", "mean s*fy/fz over fz <= -d (Sec. 3.3; docs/method.md 4)"),
    Column("mu_b", "1", "mean s*fy/fz over fz >= +d (docs/method.md 4)"),
    Column("force_dependence", "1", "(mu_b - mu_a) / mu_r (docs/method.md 4)"),
    Column("c_xy", "1", "Pearson C_xy(0) (docs/method.md 1)"),
    Column("c_xz", "1", "Pearson C_xz(0)"),
    Column("c_yz", "1", "Pearson C_yz(0)"),
    Column(
        "skew",
        "samples",
        "fz delay behind fy: cross-spectral phase (with rpm), else lag of max |C_yz(j)| (max_lag; docs/method.md 3e)",
    ),
    Column("h1_f0", "1", "s Re(S_yz / S_zz) at f0 = rpm/60 (needs rpm; docs/method.md 3e)"),
    Column("h1_fl", "1", "s Re(S_yz / S_zz) at f_l = n_lamellas f0 (needs rpm and n_lamellas)"),
    Column("coherence_fl", "1", "coherence of fy and fz at f_l"),
    Column("ok", "", "quality gate passed (docs/method.md 5)", "bool"),
    Column("reasons", "", "why the gate failed ('' when ok)", "str"),
    Column("T", "degC", "temperature at the window centre (NaN outside the log; docs/method.md 6)"),
    Column("branch", "", "+1 heating, -1 cooling, 0 plateau or unknown (sign of dT/dt beyond the log's noise)", "int8"),
    Column("T_uncertainty", "degC", "bound on the error of the interpolated T (docs/method.md 6)"),
    Column("T_gap", "", "in a log gap where T changed faster than covariates.MAX_RATE (docs/method.md 6)", "bool"),
    Column("i", "A", "mean current"),
    Column("J", "A/mm^2", "mean current density"),
    Column(
        "speed",
        "m/s",
        "mean sliding speed: mean |v| of the velocity channel v in the window, or a speed log at the window centre "
        "(docs/method.md 7a)",
    ),
    Column("mu_instrument", "1", "mean of the instrument's own COF column ('cof' channel), if any"),
    Column("mu_classical", "1", "classical COF: mean |fy|/|fz| of the raw forces in contact (docs/method.md 6a)"),
    Column("mu_classical_median", "1", "median |fy|/|fz| over the same samples (docs/method.md 6a)"),
    Column("fz_mean", "N", "mean of the raw fz (after tare) in the window"),
    Column("fz_std", "N", "standard deviation of the raw fz in the window (dynamic normal-force excitation)"),
    Column("deadband", "N", "deadband applied (docs/method.md 4)"),
    Column("n", "samples", "samples in the window", "int64"),
    Column("acquisition", "", "index of the acquisition (file) the window comes from", "int64"),
)

#: Column -> meaning, in the table's order.
WINDOW_COLUMNS: Dict[str, str] = {c.name: c.meaning for c in TABLE}
#: Column -> unit, in the table's order.
UNITS: Dict[str, str] = {c.name: c.unit for c in TABLE}
#: The float columns of the table (what a numeric comparison of two tables covers).
FLOAT_COLUMNS: Tuple[str, ...] = tuple(c.name for c in TABLE if c.dtype == "float64")

#: Statistics asked of the kernel per window (docs/method.md 3-5), in order:
#: the fit (slope, intercept, r, slope_stderr), the moments that fix the
#: orientation of a recording (mean_z, mean_y, syz, n), the correlations,
#: the deadband and bins (deadband, n_a, n_b, fz_min, fz_max, bin_count,
#: bin_cof), mu_a, mu_b, the mean of the auxiliary channel, and
#: out_of_range (1: a force beyond ``_core.FORCE_LIMIT`` or sums that
#: overflow, every statistic NaN; docs/method.md 4).
KERNEL_COLUMNS: Tuple[str, ...] = (
    "slope",
    "intercept",
    "r",
    "slope_stderr",
    "mean_z",
    "mean_y",
    "syz",
    "c_xy",
    "c_xz",
    "c_yz",
    "deadband",
    "mu_a",
    "mu_b",
    "fz_min",
    "fz_max",
    "aux_mean",
    "n",
    "n_a",
    "n_b",
    "out_of_range",
    "bin_count",
    "bin_cof",
)


def kernel_columns(raw: bool) -> Tuple[str, ...]:
    """The kernel columns a table needs: :data:`KERNEL_COLUMNS`, plus ``mu_classic`` for raw input."""
    return KERNEL_COLUMNS + (("mu_classic",) if raw else ())
