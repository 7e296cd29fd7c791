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
    Column("mu_r", "1", "COF by regression, s * slope of fy on fz (Eqs. 6-8; docs/method.md 3)"),
    Column("mu_r_stderr", "1", "standard error of mu_r (docs/method.md 3)"),
    Column("f_y0", "N", "regression intercept in the measured fy frame (Eq. 7)"),
    Column("r", "1", "Pearson r of fy and fz"),
    Column("mu_a", "1", "mean s*fy/fz over fz <= -d (Sec. 3.3; docs/method.md 4)"),
    Column("mu_b", "1", "mean s*fy/fz over fz >= +d (docs/method.md 4)"),
    Column("force_dependence", "1", "(mu_b - mu_a) / mu_r (docs/method.md 4)"),
    Column("c_xy", "1", "Pearson C_xy(0) (docs/method.md 1)"),
    Column("c_xz", "1", "Pearson C_xz(0)"),
    Column("c_yz", "1", "Pearson C_yz(0)"),
    Column("skew", "samples", "lag of max |C_yz(j)| (NaN unless max_lag given; docs/method.md 5)"),
    Column("ok", "", "quality gate passed (docs/method.md 5)", "bool"),
    Column("reasons", "", "why the gate failed ('' when ok)", "str"),
    Column("T", "degC", "temperature at the window centre (NaN outside the log; docs/method.md 6)"),
    Column("branch", "", "+1 heating, -1 cooling, 0 unknown (sign of dT/dt)", "int8"),
    Column("i", "A", "mean current"),
    Column("J", "A/mm^2", "mean current density"),
    Column("mu_classic", "1", "classical COF mean(|fy|/|fz|) of the raw forces (only with highpass)"),
    Column("mu_instrument", "1", "mean of the instrument's own COF column ('cof' channel), if any"),
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
#: bin_cof), mu_a, mu_b and the mean of the auxiliary channel.
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
    "bin_count",
    "bin_cof",
)


def kernel_columns(raw: bool) -> Tuple[str, ...]:
    """The kernel columns a table needs: :data:`KERNEL_COLUMNS`, plus ``mu_classic`` for raw input."""
    return KERNEL_COLUMNS + (("mu_classic",) if raw else ())
