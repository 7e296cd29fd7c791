"""Figures of the seed paper, from tribodyn's results (docs/method.md sections 1-7).

One function per figure, each returning a :class:`matplotlib.figure.Figure`:

=======================================  ==============================================
function                                 paper figure
=======================================  ==============================================
:func:`forces_vs_time`                   Fig. 2, dynamic forces vs time
:func:`correlation_functions`            Figs. 3-5, C_xy, C_xz, C_yz vs tau
:func:`phase_plots`                      Figs. 6-8, force phase plots + regression
:func:`cof_vs_normal_force`              Fig. 9, per-bin COF vs F_z,d
:func:`cof_vs_time`                      COF vs time (no covariate)
:func:`cof_and_temperature_vs_time`      Fig. 10, COF and temperature vs time
:func:`cof_vs_temperature`               Fig. 11, COF vs temperature (hysteresis)
:func:`cof_and_current_density_vs_time`  Fig. 12, COF and current density vs time
:func:`cof_vs_current_density`           Sec. 4.2, COF vs J, optimum, instability onset
:func:`stribeck_curve`                   COF vs sliding speed (log axis), regimes (7a)
:func:`save_figure`                      atomic PNG
=======================================  ==============================================

The figures are plain ``Figure`` objects with an Agg canvas attached: nothing
goes through ``pyplot``, so no global state (backend, current figure,
rcParams) changes and a user's interactive session is left alone. Show one in
a notebook by evaluating it, or save it with :func:`save_figure` (atomic).

Missing data (NaN, no gated window, no covariate) never raises: the affected
axes carry a "no data" note instead.
"""

from __future__ import annotations

import io
import os
import warnings
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union, cast

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

__all__ = [
    "forces_vs_time",
    "correlation_functions",
    "phase_plots",
    "cof_vs_normal_force",
    "cof_vs_time",
    "cof_and_temperature_vs_time",
    "cof_vs_temperature",
    "cof_and_current_density_vs_time",
    "cof_vs_current_density",
    "stribeck_curve",
    "strokes_vs_cycle",
    "save_figure",
]

#: Default resolution of :func:`save_figure`, dots per inch.
DPI = 150
#: zlib level of the report's PNG figures (:func:`png_bytes`, :func:`encode_png`): 1 encodes in about half the CPU
#: time of Pillow's default 6 for files about 20 % larger, the same pixels (issue 38 point 3; benches/RESULTS.md).
PNG_COMPRESS_LEVEL = 1
#: Line plots with more samples are reduced to a min/max envelope of this many points.
MAX_LINE_POINTS = 20_000
#: Scatter plots with more samples are thinned (evenly spaced) to this many points.
MAX_SCATTER_POINTS = 20_000

_FORCE_LABEL = {"x": r"$F_{x,d}$ (N)", "y": r"$F_{y,d}$ (N)", "z": r"$F_{z,d}$ (N)"}
_FORCE_COLOUR = {"x": "tab:green", "y": "tab:red", "z": "tab:blue"}
_MU_STYLE = {
    "mu_r": dict(color="black", marker="o", label=r"$\mu_r$ (regression)"),
    "mu_a": dict(color="tab:blue", marker="v", label=r"$\mu_a$ ($F_{z,d} \leq -d$)"),
    "mu_b": dict(color="tab:orange", marker="^", label=r"$\mu_b$ ($F_{z,d} \geq +d$)"),
}
_OPTIMUM_COLOUR = "tab:green"
_ONSET_COLOUR = "tab:red"
_BRANCH_STYLE = {
    "heating": dict(color="tab:red", marker="^", label="heating windows"),
    "cooling": dict(color="tab:blue", marker="v", label="cooling windows"),
    "unknown": dict(color="0.45", marker="o", label="windows, dT/dt unknown"),
}


# --------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------
def _figure(nrows: int = 1, ncols: int = 1, *, figsize: Tuple[float, float], **subplot_kw: Any) -> Tuple[Figure, Any]:
    """A constrained-layout Figure with its own Agg canvas, and its axes."""
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, ncols, squeeze=False, **subplot_kw)
    return fig, axes


def _no_data(ax: Axes, message: str = "no data") -> None:
    """Marks an empty axes with a centred note."""
    ax.text(
        0.5, 0.5, message, transform=ax.transAxes, ha="center", va="center", fontsize=11, color="0.4", style="italic"
    )
    ax.set_xticks([])
    ax.set_yticks([])


def _signal(x: Any) -> Optional[np.ndarray]:
    """1-D float array, or None for None / empty."""
    if x is None:
        return None
    a = np.asarray(x, dtype=float).ravel()
    return a if a.size else None


def _envelope(t: np.ndarray, y: np.ndarray, max_points: int = MAX_LINE_POINTS) -> Tuple[np.ndarray, np.ndarray]:
    """Min/max envelope of a long trace (keeps the peaks a plain stride would drop)."""
    n = y.size
    if n <= max_points:
        return t, y
    k = int(np.ceil(n / (max_points // 2)))
    m = (n // k) * k
    blocks = y[:m].reshape(-1, k)
    lo = np.where(np.isnan(blocks), np.inf, blocks).argmin(axis=1)
    hi = np.where(np.isnan(blocks), -np.inf, blocks).argmax(axis=1)
    base = np.arange(blocks.shape[0]) * k
    idx = np.sort(np.concatenate([base + lo, base + hi]))
    idx = np.concatenate([idx, np.arange(m, n)])
    return t[idx], y[idx]


def _thin(n: int, max_points: int = MAX_SCATTER_POINTS) -> np.ndarray:
    """Evenly spaced indices, at most ``max_points`` of ``n``."""
    if n <= max_points:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, max_points).round().astype(np.int64))


def _finite(*arrays: np.ndarray) -> np.ndarray:
    keep = np.ones(arrays[0].shape, dtype=bool)
    for a in arrays:
        keep &= np.isfinite(a)
    return keep


def _pearson(x: np.ndarray, y: np.ndarray) -> float:
    keep = _finite(x, y)
    if keep.sum() < 2:
        return float("nan")
    a, b = x[keep] - x[keep].mean(), y[keep] - y[keep].mean()
    den = np.sqrt(np.dot(a, a) * np.dot(b, b))
    return float(np.dot(a, b) / den) if den > 0 else float("nan")


def _column(results: Any, name: str, n: int, fill: float = np.nan) -> np.ndarray:
    table = getattr(results, "table", results)
    if name in table:
        return np.asarray(table[name], dtype=float)
    return np.full(n, fill)


def _gated(results: Any, n: int) -> np.ndarray:
    table = getattr(results, "table", results)
    if "ok" in table:
        return np.asarray(table["ok"], dtype=bool)
    return np.ones(n, dtype=bool)


def _cof_limits(values: Sequence[np.ndarray]) -> Optional[Tuple[float, float]]:
    """COF axis: from 0 (or the lowest value if negative) to a robust top."""
    v = np.concatenate([np.asarray(a, dtype=float).ravel() for a in values]) if values else np.empty(0)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return None
    lo = min(0.0, float(np.percentile(v, 0.5)))
    hi = float(np.percentile(v, 99.5)) if v.size > 200 else float(v.max())
    hi = max(hi, float(np.median(v)) * 1.5, lo + 1e-3)
    return lo - 0.02 * (hi - lo) if lo < 0 else lo, hi + 0.1 * (hi - lo)


def _legend_above(ax: Axes, handles: Optional[List[Any]] = None, ncol: int = 3) -> None:
    """Legend in a frameless block just above the axes (the title goes in the suptitle)."""
    kw: Dict[str, Any] = {} if handles is None else {"handles": handles}
    hs = handles if handles is not None else ax.get_legend_handles_labels()[0]
    if not hs:
        return
    ax.legend(
        loc="lower left",
        bbox_to_anchor=(0.0, 1.01),
        ncol=max(1, min(ncol, len(hs))),
        fontsize=8,
        frameon=False,
        borderaxespad=0.0,
        columnspacing=1.5,
        handletextpad=0.5,
        **kw,
    )


def _fmt(v: Optional[float], spec: str = ".3g") -> str:
    if v is None or not np.isfinite(v):
        return "n/a"
    return format(float(v), spec)


# --------------------------------------------------------------------------
# Fig. 2: forces vs time
# --------------------------------------------------------------------------
def forces_vs_time(fx: Any, fy: Any, fz: Any, fs: float, *, t0: float = 0.0, title: Optional[str] = None) -> Figure:
    """Dynamic forces against time (paper Fig. 2; docs/method.md 0).

    Parameters
    ----------
    fx, fy, fz : array_like, 1-D
        Dynamic axial, tangential (friction) and normal forces in N. ``fx``
        may be None (its panel then says so). Traces longer than
        :data:`MAX_LINE_POINTS` are drawn as their min/max envelope.
    fs : float
        Sampling rate, Hz.
    t0 : float
        Time of the first sample, s.
    title : str, optional
        Figure title (default "Dynamic forces (cf. Fig. 2)").

    Returns
    -------
    matplotlib.figure.Figure
        Three stacked axes sharing the time axis (F_x,d, F_y,d, F_z,d).
    """
    fs_v = float(fs)
    if not (np.isfinite(fs_v) and fs_v > 0):
        raise ValueError(f"fs must be a positive number, got {fs!r}")
    fig, axes = _figure(3, 1, figsize=(9.0, 6.0), sharex=True)
    any_data = False
    for ax, name, sig in zip(axes[:, 0], "xyz", (fx, fy, fz)):
        y = _signal(sig)
        ax.set_ylabel(_FORCE_LABEL[name])
        if y is None or not np.isfinite(y).any():
            ax.text(
                0.5,
                0.5,
                "not measured" if sig is None else "no data",
                transform=ax.transAxes,
                ha="center",
                va="center",
                color="0.4",
                style="italic",
            )
            continue
        any_data = True
        t = float(t0) + np.arange(y.size) / fs_v
        tt, yy = _envelope(t, y)
        ax.plot(tt, yy, color=_FORCE_COLOUR[name], linewidth=0.6)
        ax.axhline(0.0, color="0.5", linewidth=0.5, zorder=0)
        ax.grid(True, alpha=0.3)
    axes[-1, 0].set_xlabel("Time $t$ (s)")
    if not any_data:
        for ax in axes[:, 0]:
            ax.set_yticks([])
    fig.suptitle(title or "Dynamic forces (cf. paper Fig. 2)")
    return fig


# --------------------------------------------------------------------------
# Figs. 3-5: correlation functions
# --------------------------------------------------------------------------
_PAIRS = (
    ("xy", r"$C_{x,y}(\tau)$", "Fig. 3"),
    ("xz", r"$C_{x,z}(\tau)$", "Fig. 4"),
    ("yz", r"$C_{y,z}(\tau)$", "Fig. 5"),
)


def correlation_functions(source: Any, *, title: Optional[str] = None) -> Figure:
    """Correlation functions C_xy, C_xz, C_yz against the time shift (paper Figs. 3-5; docs/method.md 1).

    Parameters
    ----------
    source : CofResult or dict of XcorrResult
        A :class:`~tribodyn.CofResult` from ``identify(..., max_lag=L)``
        (its ``correlations``), or a dict with keys "xy", "xz", "yz" of
        :class:`~tribodyn.XcorrResult` (missing keys give an empty panel).
        The abscissa is tau in ms when the results carry ``tau`` (``fs``
        given), otherwise the lag in samples.
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        Three stacked axes sharing the abscissa; C(0) (Pearson's r) is
        marked and printed in each.
    """
    corr = getattr(source, "correlations", source)
    if corr is not None and not isinstance(corr, Mapping):
        raise TypeError(
            f"correlation_functions takes a CofResult or a dict of XcorrResult, got {type(source).__name__}"
        )
    corr = dict(corr or {})
    fig, axes = _figure(3, 1, figsize=(8.0, 6.5), sharex=True)
    in_ms = True
    for ax, (key, label, paper) in zip(axes[:, 0], _PAIRS):
        ax.set_ylabel(label)
        res = corr.get(key)
        c = None if res is None else np.asarray(res.c, dtype=float)
        if c is None or c.size == 0 or not np.isfinite(c).any():
            ax.text(
                0.5,
                0.5,
                "no data" if res is not None else f"not computed ({paper})",
                transform=ax.transAxes,
                ha="center",
                va="center",
                color="0.4",
                style="italic",
            )
            ax.set_ylim(-1.05, 1.05)
            continue
        assert res is not None, "c is None whenever res is None, handled above"
        lags = np.asarray(res.lags)
        if res.tau is not None:
            x = np.asarray(res.tau, dtype=float) * 1e3
        else:
            x = lags.astype(float)
            in_ms = False
        ax.plot(x, c, color="tab:blue", linewidth=0.9)
        ax.axhline(0.0, color="0.5", linewidth=0.5)
        ax.axvline(0.0, color="0.5", linewidth=0.5, linestyle=":")
        zero = np.flatnonzero(lags == 0)
        if zero.size and np.isfinite(c[zero[0]]):
            c0 = float(c[zero[0]])
            ax.plot([0.0], [c0], "o", color="tab:red", markersize=4)
            ax.text(
                0.99,
                0.95,
                f"$C(0)$ = {c0:+.3f}  ({paper})",
                transform=ax.transAxes,
                ha="right",
                va="top",
                fontsize=9,
                bbox=dict(facecolor="white", edgecolor="0.8", alpha=0.9),
            )
        ax.set_ylim(-1.05, 1.05)
        ax.grid(True, alpha=0.3)
    axes[-1, 0].set_xlabel(r"Time shift $\tau$ (ms)" if in_ms else "Lag $j$ (samples)")
    fig.suptitle(title or "Correlation functions of the dynamic forces, Eq. (1) (cf. paper Figs. 3-5)")
    return fig


# --------------------------------------------------------------------------
# Figs. 6-8: phase plots
# --------------------------------------------------------------------------
def _line_of(fit: Any, fz: np.ndarray, fy: np.ndarray) -> Tuple[float, float, str]:
    """(slope, intercept, label) of the fy-on-fz regression line."""
    if fit is None:
        from ..kernels.regression import DegenerateInputWarning, linfit

        keep = _finite(fz, fy)
        if keep.sum() < 3:
            return float("nan"), float("nan"), ""
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DegenerateInputWarning)
            fit = linfit(fz[keep], fy[keep])
    if hasattr(fit, "mu_r") and hasattr(fit, "orientation"):  # CofResult
        s = int(fit.orientation)
        slope, icpt = s * float(fit.mu_r), float(fit.f_y0)
        return slope, icpt, rf"$\mu_r$ = {_fmt(fit.mu_r, '.4f')} (s = {s:+d}), $F_{{y,0}}$ = {_fmt(icpt, '.3f')} N"
    if hasattr(fit, "slope") and hasattr(fit, "intercept"):  # LinFit
        slope, icpt = float(fit.slope), float(fit.intercept)
        return slope, icpt, rf"slope = {_fmt(slope, '.4f')}, $F_{{y,0}}$ = {_fmt(icpt, '.3f')} N"
    if isinstance(fit, (tuple, list)) and len(fit) == 2:
        slope, icpt = float(fit[0]), float(fit[1])
        return slope, icpt, f"slope = {_fmt(slope, '.4f')}"
    raise TypeError(f"fit must be None, a CofResult, a LinFit or a (slope, intercept) pair, got {type(fit).__name__}")


def phase_plots(fx: Any, fy: Any, fz: Any, *, fit: Any = None, title: Optional[str] = None) -> Figure:
    """Force phase plots F_x-F_y, F_x-F_z and F_z-F_y with the regression line (paper Figs. 6-8; docs/method.md 3).

    Parameters
    ----------
    fx, fy, fz : array_like, 1-D, equal length
        Dynamic forces in N; ``fx`` may be None (its two panels are empty).
        More than :data:`MAX_SCATTER_POINTS` samples are thinned evenly.
    fit : CofResult, LinFit, (slope, intercept) or None
        The regression of F_y,d on F_z,d drawn on the third panel (Eqs. 6-8).
        A CofResult draws ``slope = s * mu_r`` and ``F_y0``; None fits the
        data given here with :func:`tribodyn.linfit`.
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        Three axes: (F_x,d, F_y,d), (F_x,d, F_z,d), (F_z,d, F_y,d), each
        with Pearson's r printed; the last carries the regression line.
    """
    x, y, z = _signal(fx), _signal(fy), _signal(fz)
    sizes = {len(a) for a in (x, y, z) if a is not None}
    if len(sizes) > 1:
        raise ValueError(f"fx, fy, fz must have equal lengths, got {sorted(sizes)}")
    fig, axes = _figure(1, 3, figsize=(13.0, 4.4))
    panels = ((x, y, "x", "y", "Fig. 6"), (x, z, "x", "z", "Fig. 7"), (z, y, "z", "y", "Fig. 8"))
    for ax, (a, b, na, nb, paper) in zip(axes[0], panels):
        ax.set_xlabel(_FORCE_LABEL[na])
        ax.set_ylabel(_FORCE_LABEL[nb])
        ax.set_title(f"{_FORCE_LABEL[nb].split(' ')[0]} vs {_FORCE_LABEL[na].split(' ')[0]} ({paper})", fontsize=10)
        if a is None or b is None:
            _no_data(ax, "not measured" if (fx is None and "x" in (na, nb)) else "no data")
            continue
        keep = _finite(a, b)
        if not keep.any():
            _no_data(ax)
            continue
        aa, bb = a[keep], b[keep]
        idx = _thin(aa.size)
        ax.scatter(aa[idx], bb[idx], s=2, alpha=0.25, color="tab:blue", linewidths=0, rasterized=True)
        ax.axhline(0.0, color="0.5", linewidth=0.5)
        ax.axvline(0.0, color="0.5", linewidth=0.5)
        ax.grid(True, alpha=0.3)
        r = _pearson(aa, bb)
        note = f"r = {_fmt(r, '+.3f')}" + (f"  ({idx.size} of {aa.size} points)" if idx.size < aa.size else "")
        ax.text(
            0.02,
            0.98,
            note,
            transform=ax.transAxes,
            ha="left",
            va="top",
            fontsize=9,
            bbox=dict(facecolor="white", edgecolor="0.8", alpha=0.9),
        )
        if (na, nb) == ("z", "y"):
            slope, icpt, label = _line_of(fit, aa, bb)
            if np.isfinite(slope) and np.isfinite(icpt):
                xs = np.array([aa.min(), aa.max()])
                ax.plot(xs, slope * xs + icpt, color="tab:red", linewidth=1.8, label=label)
                ax.legend(loc="upper right" if slope < 0 else "lower right", fontsize=8, framealpha=0.9)
    fig.suptitle(title or "Phase plots of the dynamic forces (cf. paper Figs. 6-8)")
    return fig


# --------------------------------------------------------------------------
# Fig. 9: COF against normal force
# --------------------------------------------------------------------------
def cof_vs_normal_force(cof_result: Any, *, title: Optional[str] = None) -> Figure:
    """Per-bin COF against the dynamic normal force (paper Fig. 9; docs/method.md 4).

    Parameters
    ----------
    cof_result : CofResult
        From :func:`tribodyn.identify`: its ``bins`` (fz centres, COF_k,
        counts), ``mu_r``, ``mu_a``, ``mu_b`` and ``deadband``.
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        One axes: COF_k against the bin centres (empty bins skipped), the
        regression mu_r as a dashed line across, mu_a over the negative
        range and mu_b over the positive range, the deadband |F_z,d| < d
        shaded.
    """
    bins = cof_result.bins
    centres = np.asarray(bins.centres, dtype=float)
    cof = np.asarray(bins.cof, dtype=float)
    counts = np.asarray(bins.counts)
    edges = np.asarray(bins.edges, dtype=float)
    d = float(getattr(cof_result, "deadband", np.nan))
    fig, axes = _figure(1, 1, figsize=(7.5, 4.8))
    ax = axes[0, 0]
    ax.set_xlabel(r"Dynamic normal force $F_{z,d}$ (N)")
    ax.set_ylabel("COF")
    fig.suptitle(title or "COF against the normal force (cf. paper Fig. 9)")
    keep = np.isfinite(cof) & np.isfinite(centres)
    if not keep.any():
        _no_data(ax, "no data (every bin empty)")
        return fig
    lo_x, hi_x = (
        (float(edges[0]), float(edges[-1]))
        if edges.size and np.isfinite(edges).all()
        else (float(centres[keep].min()), float(centres[keep].max()))
    )
    if np.isfinite(d) and d > 0:
        ax.axvspan(-d, d, color="0.85", alpha=0.7, zorder=0, label=rf"deadband $|F_{{z,d}}| < {d:.3g}$ N")
    # NaN (empty) bins break the line: no segment is drawn across the deadband.
    ax.plot(
        centres,
        np.where(keep, cof, np.nan),
        "o-",
        color="tab:purple",
        markersize=5,
        linewidth=1.0,
        label=rf"COF$_k$ per bin ({int(keep.sum())} of {cof.size} bins, Eq. 5)",
    )
    mu_r, mu_a, mu_b = (float(getattr(cof_result, k, np.nan)) for k in ("mu_r", "mu_a", "mu_b"))
    if np.isfinite(mu_r):
        ax.axhline(
            mu_r, color="black", linestyle="--", linewidth=1.3, label=rf"$\mu_r$ = {mu_r:.4f} (regression, Eq. 8)"
        )
    neg_hi = -d if np.isfinite(d) else 0.0
    if np.isfinite(mu_a):
        ax.hlines(
            mu_a,
            lo_x,
            min(neg_hi, 0.0),
            color="tab:blue",
            linestyle=":",
            linewidth=2.0,
            label=rf"$\mu_a$ = {mu_a:.4f} ($F_{{z,d}} \leq -d$)",
        )
    if np.isfinite(mu_b):
        ax.hlines(
            mu_b,
            max(-neg_hi, 0.0),
            hi_x,
            color="tab:orange",
            linestyle="-.",
            linewidth=2.0,
            label=rf"$\mu_b$ = {mu_b:.4f} ($F_{{z,d}} \geq +d$)",
        )
    # Zoom on the data (the paper's point is the spread across bins, < 15 %),
    # at least +-25 % around the centre so noise does not look like a trend.
    vals = np.concatenate([cof[keep], [v for v in (mu_r, mu_a, mu_b) if np.isfinite(v)]])
    centre = mu_r if np.isfinite(mu_r) else float(np.median(vals))
    half = max(0.25 * abs(centre), 1.15 * float(np.max(np.abs(vals - centre))), 1e-3)
    ax.set_ylim(centre - half, centre + half)
    pad = 0.03 * (hi_x - lo_x) if hi_x > lo_x else 0.5
    ax.set_xlim(lo_x - pad, hi_x + pad)
    fd = float(getattr(cof_result, "force_dependence", np.nan))
    if np.isfinite(fd):
        note = (
            rf"$(\mu_b - \mu_a)/\mu_r$ = {100 * fd:+.1f} %   "
            f"n = {int(counts.sum())} samples outside the deadband"
        )
        ax.text(0.99, 0.02, note, transform=ax.transAxes, ha="right", va="bottom", fontsize=8, color="0.3")
    ax.grid(True, alpha=0.3)
    _legend_above(ax, ncol=3)
    return fig


# --------------------------------------------------------------------------
# Figs. 10 and 12: COF and a covariate against time
# --------------------------------------------------------------------------
_COVARIATE = {
    "T": dict(label=r"Temperature $T$ (°C)", colour="tab:red", name="temperature", unit="°C"),
    "J": dict(label=r"Current density $J$ (A/mm$^2$)", colour="tab:green", name="current density", unit="A/mm²"),
}


#: Above this many gated windows the COF-against-time figures draw a running median and band.
BAND_FROM = 200
#: Points of the running median (equal-count blocks of consecutive gated windows).
BAND_BLOCKS = 200
#: Height of the strip at the top of the axes that holds the failed windows (axes fraction).
FAILED_STRIP = 0.07


def running_band(t: np.ndarray, v: np.ndarray, blocks: int = BAND_BLOCKS) -> Tuple[np.ndarray, ...]:
    """Median and 5th/95th percentiles of ``v`` over equal-count blocks of consecutive points in time order.

    Returns (t_centre, median, p05, p95), one value per block of
    ceil(n / blocks) points (at least 5). Readable from ten to 10^5
    windows; O(n log n).
    """
    order = np.argsort(t, kind="stable")
    t, v = t[order], v[order]
    m = max(5, int(np.ceil(t.size / blocks)))
    k = t.size // m
    if k < 2:
        return (np.empty(0),) * 4
    tb = t[: k * m].reshape(k, m)
    vb = v[: k * m].reshape(k, m)
    q = np.percentile(vb, [50, 5, 95], axis=1)
    return tb.mean(axis=1), q[0], q[1], q[2]


def failed_reasons(results: Any, bad: np.ndarray, top: int = 3) -> str:
    """The commonest gate-failure reasons of the windows ``bad``: 'reason (n), ...'."""
    table = getattr(results, "table", results)
    if "reasons" not in table:
        return ""
    counts: Dict[str, int] = {}
    for r in np.asarray(table["reasons"])[bad]:
        for part in str(r).split("; "):
            key = part.split(":")[0].strip()
            if key:
                counts[key] = counts.get(key, 0) + 1
    ranked = sorted(counts.items(), key=lambda kv: -kv[1])[:top]
    return ", ".join(f"{k} ({v})" for k, v in ranked)


def _failed_strip(ax: Axes, x: np.ndarray, results: Any, bad: np.ndarray) -> Any:
    """Failed windows as ticks in a grey strip along the top of the axes, apart from the COF values."""
    from matplotlib.patches import Rectangle
    from matplotlib.transforms import blended_transform_factory

    ax.add_patch(
        Rectangle(
            (0.0, 1.0 - FAILED_STRIP), 1.0, FAILED_STRIP, transform=ax.transAxes, color="0.93", zorder=0.5, linewidth=0
        )  # fmt: skip
    )
    trans = blended_transform_factory(ax.transData, ax.transAxes)
    xs = x[bad]
    (h,) = ax.plot(
        xs,
        np.full(xs.size, 1.0 - FAILED_STRIP / 2),
        transform=trans,
        color="0.45",
        marker="|",
        linestyle="none",
        markersize=7,
        alpha=0.8,
        label=f"gate failed ({int(bad.sum())} windows)",
        zorder=4,
        clip_on=False,
    )
    why = failed_reasons(results, bad)
    if why:
        ax.text(0.005, 1.0 - FAILED_STRIP - 0.005, f"failed (top strip): {why}", transform=ax.transAxes, fontsize=7,
                va="top", ha="left", color="0.3", zorder=5)  # fmt: skip
    return h


def _cof_time_axes(ax: Axes, results: Any, steady: Optional[Mapping[str, Any]] = None
                   ) -> Tuple[List[Any], List[Any]]:  # fmt: skip
    """mu_r, mu_a, mu_b of the gated windows (with a running median and 5-95 % band when there are many)
    and the failed windows in a strip at the top, the running-in of ``steady`` shaded; returns legend handles and
    the plotted COF values."""
    t = np.asarray(getattr(results, "table", results)["time"], dtype=float)
    n = t.size
    head = getattr(results, "headline", None)
    if head is not None and getattr(head, "method", "dynamic") != "dynamic":
        return _classical_time_axes(ax, results, head, t, steady)
    ok = _gated(results, n)
    handles: List[Any] = []
    tops = []
    many = int(ok.sum()) > BAND_FROM
    for col in ("mu_r", "mu_a", "mu_b"):
        v = _column(results, col, n)
        sel = ok & np.isfinite(v) & np.isfinite(t)
        if not sel.any():
            continue
        st = _MU_STYLE[col]
        small = col != "mu_r"
        if many:
            tc, med, lo, hi = running_band(t[sel], v[sel])
            if col == "mu_r":
                (h,) = ax.plot(t[sel], v[sel], linestyle="none", marker=".", markersize=1.5, color="0.35", alpha=0.35,
                               label=st["label"] + " per window", zorder=2, rasterized=True)  # fmt: skip
                handles.append(h)
                if tc.size:
                    band = ax.fill_between(tc, lo, hi, color="tab:purple", alpha=0.25, linewidth=0, zorder=2.5,
                                           label=r"5-95 % of $\mu_r$ (running)")  # fmt: skip
                    handles.append(band)
            if tc.size:
                (h,) = ax.plot(tc, med, color=st["color"] if small else "black", linewidth=1.0 if small else 1.6,
                               label=f"running median of {st['label']}", zorder=3)  # fmt: skip
                handles.append(h)
            tops.append(v[sel])
            continue
        (h,) = ax.plot(
            t[sel],
            v[sel],
            linestyle="-" if not small else "none",
            linewidth=0.6,
            marker=st["marker"],
            markersize=2.5 if small else 3,
            color=st["color"],
            alpha=0.6 if small else 0.9,
            label=st["label"],
            zorder=2 if small else 3,
        )
        handles.append(h)
        tops.append(v[sel])
    lim = _cof_limits(tops)
    if lim is None:
        lim = (0.0, 0.3)
    bad = ~ok & np.isfinite(t)
    if bad.any():  # room for the strip of failed windows above the data
        lim = (lim[0], lim[1] + (lim[1] - lim[0]) * FAILED_STRIP / (1 - FAILED_STRIP) * 1.6)
        handles.append(_failed_strip(ax, t, results, bad))
    ax.set_ylim(*lim)
    ax.set_xlabel("Time $t$ (s)")
    ax.set_ylabel("COF")
    ax.grid(True, alpha=0.3)
    return handles + _running_in(ax, steady), tops


def _running_in(ax: Axes, steady: Optional[Mapping[str, Any]]) -> List[Any]:
    """A light band from the first window to t_steady when ``steady`` (a :meth:`tribodyn.SteadyState.to_dict`,
    or one per acquisition under "acquisitions") says the steady state is reached (docs/method.md 6h): one band
    per test or step."""
    ss = steady or {}
    fits = ss.get("acquisitions") or [ss]
    bands: List[Any] = []
    for fit in fits:
        t0, ts = fit.get("t0"), fit.get("t_steady")
        if fit.get("verdict") != "steady state reached" or t0 is None or ts is None or not ts > t0:
            continue
        label = f"running-in (to t = {ts:.4g} s)" if len(fits) == 1 else "running-in of each test"
        bands.append(ax.axvspan(t0, ts, color="tab:orange", alpha=0.12, linewidth=0, zorder=0.5,
                                label=label if not bands else "_nolegend_"))  # fmt: skip
    return bands[:1]


def _classical_time_axes(ax: Axes, results: Any, head: Any, t: np.ndarray, steady: Optional[Mapping[str, Any]] = None
                         ) -> Tuple[List[Any], List[Any]]:  # fmt: skip
    """The classical COF of every window (and the instrument's) with the headline and its 95 % interval
    (a headline that is not the dynamic COF: docs/method.md 6e); the dynamic gate plays no part here."""
    n = t.size
    handles: List[Any] = []
    tops: List[Any] = []
    for col, label, colour, marker in (("mu_classical", "classical COF per window", "tab:blue", "o"),
                                       ("mu_instrument", "instrument COF per window", "tab:orange", "x")):  # fmt: skip
        v = _column(results, col, n)
        sel = np.isfinite(v) & np.isfinite(t)
        if not sel.any():
            continue
        many = int(sel.sum()) > BAND_FROM
        (h,) = ax.plot(t[sel], v[sel], linestyle="none" if many else "-", linewidth=0.6, marker=marker,
                       markersize=1.5 if many else 3, color=colour, alpha=0.8, label=label, zorder=3,
                       rasterized=many)  # fmt: skip
        handles.append(h)
        tops.append(v[sel])
    if getattr(head, "ok", False) and np.isfinite(t).any():
        span = (float(np.nanmin(t)), float(np.nanmax(t)))
        if np.isfinite(head.low) and np.isfinite(head.high):
            band = ax.axhspan(head.low, head.high, color="black", alpha=0.12, linewidth=0, zorder=1,
                              label="95 % interval of the headline")  # fmt: skip
            handles.append(band)
        (h,) = ax.plot(span, (head.value, head.value), color="black", linewidth=1.6, zorder=4,
                       label=f"headline: {head.method} COF {head.value:.4g} ({head.statistic})")  # fmt: skip
        handles.append(h)
        tops.append(np.asarray([head.value]))
    lim = _cof_limits(tops) or (0.0, 0.3)
    ax.set_ylim(*lim)
    ax.set_xlabel("Time $t$ (s)")
    ax.set_ylabel("COF")
    ax.grid(True, alpha=0.3)
    return handles + _running_in(ax, steady), tops


def _cof_time_frame(
    results: Any, title: str, figsize: Tuple[float, float], steady: Optional[Mapping[str, Any]] = None
) -> Tuple[Figure, Any, np.ndarray, List[Any]]:
    """A one-panel figure of the COF against time: (figure, axes, window times, legend handles); axes None
    (and the figure saying so) when there are no windows. Says on the axes when no window passed the gate."""
    fig, axes = _figure(1, 1, figsize=figsize)
    ax = axes[0, 0]
    fig.suptitle(title)
    table = getattr(results, "table", results)
    t = np.asarray(table["time"], dtype=float) if "time" in table else np.empty(0)
    if t.size == 0 or not np.isfinite(t).any():
        _no_data(ax, "no windows")
        return fig, None, t, []
    handles, tops = _cof_time_axes(ax, results, steady)
    if not tops:
        ax.text(0.5, 0.5, "no window passed the quality gate", transform=ax.transAxes, ha="center", va="center",
                color="0.4", style="italic")  # fmt: skip
    return fig, ax, t, list(handles)


def _cof_and_covariate_vs_time(
    results: Any,
    column: str,
    *,
    title: str,
    extra: Optional[Tuple[np.ndarray, np.ndarray]] = None,
    steady_state: Optional[Mapping[str, Any]] = None,
) -> Figure:
    spec = _COVARIATE[column]
    fig, ax, t, handles = _cof_time_frame(results, title, (10.0, 5.0), steady_state)
    if ax is None:
        return fig
    cov = _column(results, column, t.size)
    keep = np.isfinite(cov) & np.isfinite(t)
    if keep.any() or extra is not None:
        ax2 = ax.twinx()
        if keep.any():
            order = np.argsort(t[keep])
            (h,) = ax2.plot(
                t[keep][order],
                cov[keep][order],
                color=spec["colour"],
                linewidth=1.4,
                drawstyle="steps-mid" if column == "J" else "default",
                label=f"{spec['name']} at the window centres",
            )
            handles.append(h)
        if extra is not None:
            lt, lv = extra
            (h,) = ax2.plot(
                lt,
                lv,
                linestyle="none",
                marker="^",
                markersize=6,
                markerfacecolor="none",
                color=spec["colour"],
                label=f"{spec['name']} readings",
            )
            handles.append(h)
        ax2.set_ylabel(spec["label"], color=spec["colour"])
        ax2.tick_params(axis="y", colors=spec["colour"])
        vals = np.concatenate([cov[keep]] + ([np.asarray(extra[1], float)] if extra is not None else []))
        vals = vals[np.isfinite(vals)]
        if vals.size:
            lo, hi = float(vals.min()), float(vals.max())
            pad = max(0.08 * (hi - lo), 0.5 if column == "T" else 0.05)
            ax2.set_ylim(lo - pad, hi + pad)
        ax.set_zorder(ax2.get_zorder() + 1)  # COF markers above the covariate line
        ax.patch.set_visible(False)
    else:
        ax.text(
            0.99,
            0.02,
            f"no {spec['name']} data",
            transform=ax.transAxes,
            ha="right",
            va="bottom",
            color="0.4",
            style="italic",
            fontsize=9,
        )
    _legend_above(ax, handles, ncol=3)
    return fig


def cof_vs_time(results: Any, *, title: Optional[str] = None, steady_state: Optional[Mapping[str, Any]] = None
                ) -> Figure:  # fmt: skip
    """COF of every window against time (paper Figs. 10, 12 without a covariate; docs/method.md 6).

    Parameters
    ----------
    results : Results
        From :func:`tribodyn.analyze`. Gated windows show mu_r, mu_a and
        mu_b; windows that failed the quality gate are grey crosses (their
        mu_r clipped into view; NaN at the bottom).
    title : str, optional
        Axes title.
    steady_state : dict, optional
        :meth:`tribodyn.SteadyState.to_dict` (or ``{"acquisitions": [...]}``, one per test): the running-in
        shaded up to t_steady when the steady state is reached (docs/method.md 6h).

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax, _, handles = _cof_time_frame(results, title or "COF against time", (10.0, 4.6), steady_state)
    if ax is None:
        return fig
    _legend_above(ax, handles, ncol=4)
    return fig


def cof_and_temperature_vs_time(results: Any, *, temperature_log: Any = None, title: Optional[str] = None,
                                steady_state: Optional[Mapping[str, Any]] = None) -> Figure:  # fmt: skip
    """COF (mu_r, mu_a, mu_b) and temperature against time (paper Fig. 10; docs/method.md 6).

    Parameters
    ----------
    results : Results
        From :func:`tribodyn.analyze` with a temperature log (column ``T``).
        Gated windows show mu_r, mu_a, mu_b; failed windows are grey crosses.
    temperature_log : (t_s, T_degC), optional
        The intermittent readings themselves, drawn as open triangles (the
        paper's symbol); the line is ``T`` interpolated at window centres.
    title : str, optional
        Axes title.
    steady_state : dict, optional
        As :func:`cof_vs_time`'s.

    Returns
    -------
    matplotlib.figure.Figure
        COF on the left axis, temperature (°C) on a second y-axis.
    """
    extra = None
    if temperature_log is not None:
        lt, lv = (np.asarray(a, dtype=float).ravel() for a in temperature_log)
        if lt.size and lt.size == lv.size:
            extra = (lt, lv)
    title = title or "COF and temperature against time (cf. paper Fig. 10)"
    return _cof_and_covariate_vs_time(results, "T", title=title, extra=extra, steady_state=steady_state)


def cof_and_current_density_vs_time(results: Any, *, title: Optional[str] = None,
                                    steady_state: Optional[Mapping[str, Any]] = None) -> Figure:  # fmt: skip
    """COF (mu_r, mu_a, mu_b) and current density against time (paper Fig. 12; docs/method.md 6).

    Parameters
    ----------
    results : Results
        From :func:`tribodyn.analyze` with a current and ``area_mm2``
        (column ``J``, A/mm^2). Failed windows are grey crosses.
    title : str, optional
        Axes title.
    steady_state : dict, optional
        As :func:`cof_vs_time`'s.

    Returns
    -------
    matplotlib.figure.Figure
        COF on the left axis, J (A/mm^2) on a second y-axis.
    """
    title = title or "COF and current density against time (cf. paper Fig. 12)"
    return _cof_and_covariate_vs_time(results, "J", title=title, steady_state=steady_state)


# --------------------------------------------------------------------------
# Fig. 11 and COF vs J: COF against a covariate, with the operating range
# --------------------------------------------------------------------------
def _opr_of(results: Any, opr: Any, by: str) -> Any:
    if opr is not None:
        return opr
    try:
        from ..analyses.ranges import operating_range

        return operating_range(results, by=by)
    except (ValueError, KeyError, TypeError):
        return None


def _cof_vs_covariate(results: Any, opr: Any, column: str, by: str, *, title: str, branches: bool) -> Figure:
    spec = _COVARIATE[column]
    fig, axes = _figure(1, 1, figsize=(8.5, 6.0))
    ax = axes[0, 0]
    fig.suptitle(title)
    ax.set_xlabel(spec["label"])
    ax.set_ylabel(r"COF $\mu_r$")
    table = getattr(results, "table", results)
    n = len(np.asarray(table["mu_r"])) if "mu_r" in table else 0
    cov = _column(results, column, n)
    mu = _column(results, "mu_r", n)
    ok = _gated(results, n)
    good = ok & np.isfinite(cov) & np.isfinite(mu)
    bad = ~ok & np.isfinite(cov)
    if not good.any() and not bad.any():
        _no_data(ax, f"no {spec['name']} data")
        return fig
    opr = _opr_of(results, opr, by)
    lim = _cof_limits([mu[good]]) if good.any() else None
    if lim is None:
        lim = (0.0, 0.3)
    if opr is not None and opr.optimum is not None:
        lo, hi = opr.optimum
        ax.axvspan(
            lo,
            hi,
            color=_OPTIMUM_COLOUR,
            alpha=0.15,
            zorder=0,
            label=f"optimum {lo:.4g}–{hi:.4g} {spec['unit']} (min COF {_fmt(opr.mu_min, '.3f')})",
        )
    groups: Tuple[Tuple[str, np.ndarray], ...]
    br = _column(results, "branch", n, fill=0.0)
    if branches:
        groups = (("heating", br > 0), ("cooling", br < 0), ("unknown", br == 0))
    else:
        groups = (("all", np.ones(n, dtype=bool)),)
    # Windows whose temperature is interpolated across a fast gap of the log: drawn apart, as the
    # operating range leaves them out of its fit (docs/method.md 7).
    gap = (_column(results, "T_gap", n, fill=0.0) > 0) if column == "T" else np.zeros(n, dtype=bool)
    for name, sel in groups:
        sel = sel & good & ~gap
        if not sel.any():
            continue
        st = _BRANCH_STYLE.get(name, dict(color="tab:blue", marker="o", label="gated windows"))
        ax.plot(
            cov[sel],
            mu[sel],
            linestyle="none",
            marker=st["marker"],
            markersize=3.5,
            color=st["color"],
            alpha=0.35,
            label=f"{st['label']} ({int(sel.sum())})",
        )
    if (good & gap).any():
        ax.plot(cov[good & gap], mu[good & gap], linestyle="none", marker="o", markersize=5, markerfacecolor="none",
                markeredgecolor="0.3", label=f"windows in a log gap ({int((good & gap).sum())}; T interpolated, "
                "not fitted)")  # fmt: skip
    if bad.any():  # apart from the COF values, in a strip at the top (never at COF = 0)
        lim = (lim[0], lim[1] + (lim[1] - lim[0]) * FAILED_STRIP / (1 - FAILED_STRIP) * 1.6)
        _failed_strip(ax, cov, results, bad)
    if opr is not None:
        fitted = good & ~gap
        support = {"all": cov[fitted], "heating": cov[fitted & (br >= 0)], "cooling": cov[fitted & (br <= 0)]}
        _draw_range(ax, opr, spec=spec, column=column, branches=branches, support=support)
    ax.set_ylim(*lim)
    ax.grid(True, alpha=0.3)
    _legend_above(ax, ncol=2)
    return fig


def _draw_range(ax: Any, opr: Any, *, spec: Mapping[str, Any], column: str, branches: bool,
                support: Mapping[str, np.ndarray]) -> None:  # fmt: skip
    """The operating range on a COF-against-covariate figure: binned medians, the fit(s) (solid where
    ``support``, the fitted windows' covariate per fit, has windows) and the onset (docs/method.md 7)."""
    names = ("heating", "cooling") if branches and ("heating" in opr.curves or "cooling" in opr.curves) else ()
    for name in names:
        c = opr.curves.get(name)
        if c is None:
            continue
        if np.isfinite(c.median).any():  # NaN (empty) bins break the line
            st = _BRANCH_STYLE[name]
            ax.plot(
                c.centres,
                c.median,
                "-",
                marker=st["marker"],
                color=st["color"],
                markersize=7,
                markeredgecolor="black",
                markeredgewidth=0.6,
                linewidth=1.8,
                label=f"{name}: binned median",
            )
    c = opr.curves.get("all")
    if c is not None and np.isfinite(c.median).any():
        ax.plot(
            c.centres,
            c.median,
            "--" if names else "-",
            marker="s" if not names else None,
            color="black",
            markersize=5,
            linewidth=1.2 if names else 1.8,
            label=f"all: binned median ({_fmt(opr.bin_width, '.3g')} {spec['unit']} bins)",
        )
    _draw_fit(ax, opr, spec["unit"], branches, support)
    if opr.onset is not None and np.isfinite(opr.onset):
        what = "instability onset" if column == "J" else "onset of the COF rise"
        ax.axvline(
            opr.onset,
            color=_ONSET_COLOUR,
            linestyle="--",
            linewidth=1.4,
            label=f"{what} {opr.onset:.3g} {spec['unit']} (COF ≥ {1 + opr.rise:g} × min)",
        )


_FIT_STYLE = {"all": ("black", "-"), "heating": ("tab:red", "-"), "cooling": ("tab:blue", "-")}


def _supported(grid: np.ndarray, xs: np.ndarray, reach: float) -> np.ndarray:
    """Which points of ``grid`` lie within ``reach`` of a fitted window's covariate ``xs`` (all without either)."""
    if xs.size == 0 or not np.isfinite(reach):
        return np.ones(grid.shape, dtype=bool)
    xs = np.sort(xs)
    k = np.searchsorted(xs, grid)
    left, right = xs[np.clip(k - 1, 0, xs.size - 1)], xs[np.clip(k, 0, xs.size - 1)]
    return np.asarray(np.minimum(np.abs(grid - left), np.abs(grid - right)) <= reach)


def _draw_fit(ax: Any, opr: Any, unit: str, branches: bool, support: Optional[Mapping[str, np.ndarray]] = None
              ) -> None:  # fmt: skip
    """The segmented fit(s), their 95 % bands, the breakpoints with intervals and the verdict (docs/method.md 7).

    With ``support`` (the covariate of the windows each fit used), a fit is drawn solid and with its band
    only within one bin width of those windows, dotted across the stretches without any (a log gap)."""
    fits = getattr(opr, "fits", None) or {}
    if not fits:
        return
    names = [n for n in ("heating", "cooling") if n in fits] if branches else []
    names = names or ["all"]
    for name in names:
        f = fits[name]
        colour, ls = _FIT_STYLE.get(name, ("black", "-"))
        grid = np.asarray(f.grid, dtype=float)
        width = getattr(opr, "bin_width", None)
        width = float(width) if width is not None else float("nan")
        inside = _supported(grid, np.asarray((support or {}).get(name, []), dtype=float), width)
        if np.isfinite(f.band_low).any():
            ax.fill_between(grid, np.where(inside, f.band_low, np.nan), np.where(inside, f.band_high, np.nan),
                            color=colour, alpha=0.12, linewidth=0, label=f"{name}: 95 % band of the fit")  # fmt: skip
        if not inside.all():
            ax.plot(grid, f.curve, ":", color=colour, linewidth=1.0, label=f"{name}: fit where it has no window")
        ax.plot(grid, np.where(inside, f.curve, np.nan), ls, color=colour, linewidth=2.0,
                label=f"{name}: bathtub fit ({f.verdict})")  # fmt: skip
        for side in ("lower", "upper"):
            b, ci = getattr(f, side), getattr(f, f"{side}_ci")
            if b is None:
                continue
            txt = f"{name}: {side} breakpoint {b:.4g}"
            if ci is not None:
                txt += f" [{ci[0]:.4g}, {ci[1]:.4g}]"
                ax.axvspan(ci[0], ci[1], color=colour, alpha=0.06, zorder=0)
            ax.axvline(b, color=colour, linestyle=":", linewidth=1.2, label=f"{txt} {unit}")
    import textwrap

    ax.text(0.01, 0.99, textwrap.fill(f"Verdict: {opr.verdict}. {opr.explanation}", 95), transform=ax.transAxes,
            fontsize=7.5, va="top", ha="left", bbox=dict(facecolor="white", alpha=0.8, edgecolor="0.7"))  # fmt: skip


def cof_vs_temperature(results: Any, opr: Any = None, *, title: Optional[str] = None) -> Figure:
    """COF against temperature, heating and cooling branches apart (paper Fig. 11; docs/method.md 7).

    Parameters
    ----------
    results : Results
        From :func:`tribodyn.analyze` with a temperature log. Gated windows
        are drawn per branch (heating: red up-triangles, cooling: blue
        down-triangles, unknown dT/dt: grey); failed windows are grey crosses.
    opr : OperatingRange, optional
        ``operating_range(results, by="temperature")``: its binned medians
        per branch, the optimum interval (shaded) and the instability onset.
        Computed with the defaults when omitted (skipped if impossible).
    title : str, optional
        Axes title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    return _cof_vs_covariate(
        results, opr, "T", "temperature", branches=True, title=title or "COF against temperature (cf. paper Fig. 11)"
    )


def cof_vs_current_density(results: Any, opr: Any = None, *, title: Optional[str] = None) -> Figure:
    """COF against current density, with the optimum and the instability onset (paper Sec. 4.2; docs/method.md 7).

    Parameters
    ----------
    results : Results
        From :func:`tribodyn.analyze` with a current and ``area_mm2``.
        Gated windows are blue dots; failed windows (e.g. contact loss at
        high J) are grey crosses.
    opr : OperatingRange, optional
        ``operating_range(results, by="current_density")``: binned medians,
        optimum (shaded) and instability onset (dashed red line). Computed
        with the defaults when omitted (skipped if impossible).
    title : str, optional
        Axes title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    return _cof_vs_covariate(
        results,
        opr,
        "J",
        "current_density",
        branches=False,
        title=title or "COF against current density (cf. paper Sec. 4.2, Fig. 12)",
    )


# --------------------------------------------------------------------------
# Stribeck curve: COF against sliding speed, regimes (docs/method.md 7a)
# --------------------------------------------------------------------------
#: The regimes a Stribeck fit's walls and flat bottom stand for, with their shading (docs/method.md 7a).
STRIBECK_REGIMES = (
    ("boundary and mixed", "the COF falls with speed", "tab:orange"),
    ("lowest COF", "mixed, towards a full film", "tab:green"),
    ("hydrodynamic", "the COF rises with speed", "tab:blue"),
)
_COF_LABEL = {"dynamic": r"COF $\mu_r$ (dynamic)", "classical": r"COF $\mu$ (classical, mean |fy|/|fz|)"}


def stribeck_curve(results: Any, opr: Any = None, *, by: str = "speed", title: Optional[str] = None) -> Figure:
    """COF against sliding speed on a log axis, with the fit and the lubrication regimes (docs/method.md 7a).

    Parameters
    ----------
    results : Results
        From :func:`tribodyn.analyze` with a ``speed`` column (a velocity
        channel ``v`` or ``covariates={"speed": ...}``).
    opr : OperatingRange, optional
        ``operating_range(results, by="speed")``: the COF it fitted (dynamic
        or classical) is drawn per window, with the bathtub fit, its 95 %
        band, the breakpoints with their intervals and the binned medians.
        Computed with the defaults when omitted (skipped if impossible).
    by : str
        The covariate when ``opr`` is omitted (default "speed"; "load" for
        a traction curve against the normal load).
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
        The regimes are shaded where the fit finds them (:data:`STRIBECK_REGIMES`):
        below the lower breakpoint boundary and mixed lubrication (the COF
        falls with speed; a straight wall cannot split the boundary plateau
        from the mixed fall), between the breakpoints the lowest COF, above
        the upper one hydrodynamic lubrication (the COF rises again). They
        name the fitted walls, not a measured film thickness.
    """
    fig, axes = _figure(1, 1, figsize=(8.5, 6.0))
    ax = axes[0, 0]
    fig.suptitle(title or "Stribeck curve: COF against sliding speed")
    if opr is None:
        try:
            from ..analyses.ranges import operating_range

            opr = operating_range(results, by=by)
        except (ValueError, KeyError, TypeError) as exc:
            _no_data(ax, f"no Stribeck curve: {exc}"[:120])
            return fig
    table = getattr(results, "table", results)
    n = len(np.asarray(table["time"]))
    raw = _column(results, opr.column, n)
    x = np.abs(raw) if opr.by == "load" else raw
    mu = _column(results, "mu_r" if opr.cof == "dynamic" else "mu_classical", n)
    used = (_gated(results, n) if opr.cof == "dynamic" else np.ones(n, dtype=bool)) & np.isfinite(mu) & np.isfinite(x)
    if opr.log:
        used &= x > 0
        ax.set_xscale("log")
    unit = {"m/s": "m/s", "N": "N"}.get(opr.unit, opr.unit)
    ax.set_xlabel(f"{opr.by.replace('_', ' ').capitalize()}" + (f" ({unit})" if unit else ""))
    ax.set_ylabel(_COF_LABEL.get(opr.cof, "COF"))
    if not used.any():
        _no_data(ax, f"no window with a COF and a {opr.by.replace('_', ' ')}")
        return fig
    f = opr.fits.get("all") if getattr(opr, "fits", None) else None
    lo_x, hi_x = float(x[used].min()), float(x[used].max())
    if f is not None and f.verdict in ("optimum", "optimum at the edge of the tested range"):
        edges = [lo_x, f.lower if f.lower is not None else None, f.upper if f.upper is not None else None, hi_x]
        spans = ((edges[0], edges[1]), (edges[1] or lo_x, edges[2] or hi_x), (edges[2], edges[3]))
        for (a, b), (name, what, colour) in zip(spans, STRIBECK_REGIMES):
            if a is None or b is None or not b > a:
                continue
            ax.axvspan(a, b, color=colour, alpha=0.07, zorder=0, label=f"{name}: {what}")
    ax.plot(x[used], mu[used], linestyle="none", marker="o", markersize=3.5, color="tab:blue", alpha=0.4,
            label=f"windows ({int(used.sum())})")  # fmt: skip
    c = opr.curves.get("all") if getattr(opr, "curves", None) else None
    if c is not None and np.isfinite(c.median).any():
        per = "decade" if opr.log else unit
        ax.plot(c.centres, c.median, "s", color="black", markersize=5,
                label=f"binned median ({_fmt(opr.bin_width, '.3g')} {per} bins)")  # fmt: skip
    _draw_fit(ax, opr, unit, False)
    lim = _cof_limits([mu[used]])
    if lim is not None:
        ax.set_ylim(*lim)
    ax.grid(True, which="both", alpha=0.3)
    _legend_above(ax, ncol=2)
    return fig


# --------------------------------------------------------------------------
# saving
# --------------------------------------------------------------------------
# --------------------------------------------------------------------------
# reciprocating tests: per-stroke COF against cycle (docs/method.md 6c)
# --------------------------------------------------------------------------
_DIRECTION_STYLE = {
    1: dict(color="tab:red", marker="^", label="forward strokes (+1)"),
    -1: dict(color="tab:blue", marker="v", label="backward strokes (-1)"),
}


def strokes_vs_cycle(results: Any, *, title: Optional[str] = None) -> Figure:
    """Per-stroke classical COF against cycle number, one marker per direction (docs/method.md 6c).

    Parameters
    ----------
    results : Results or mapping
        :attr:`tribodyn.Results.strokes` (or the Results holding it): the
        columns ``cycle``, ``direction``, ``mu`` and, when the recording had
        an instrument COF column, ``mu_instrument`` (drawn as open markers).
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, axes = _figure(1, 1, figsize=(10.0, 4.6))
    ax = axes[0, 0]
    fig.suptitle(title or "Per-stroke COF against cycle")
    st = getattr(results, "strokes", results)
    if not st or len(st.get("mu", ())) == 0:
        _no_data(ax, "no strokes")
        return fig
    cycle = np.asarray(st["cycle"], dtype=float)
    direction = np.asarray(st["direction"], dtype=np.int64)
    mu = np.asarray(st["mu"], dtype=float)
    inst = np.asarray(st.get("mu_instrument", np.full(mu.shape, np.nan)), dtype=float)
    shown: List[np.ndarray] = []
    for d, style in _DIRECTION_STYLE.items():
        sel = direction == d
        if not sel.any():
            continue
        keep = sel & np.isfinite(mu)
        ax.plot(cycle[keep], mu[keep], linestyle="none", markersize=5, **style)
        shown.append(mu[keep])
        ik = sel & np.isfinite(inst)
        if ik.any():
            ax.plot(cycle[ik], inst[ik], linestyle="none", markersize=7, marker=style["marker"],
                    markerfacecolor="none", color=style["color"], alpha=0.7,
                    label=f"instrument COF, {str(style['label']).split()[0]} strokes")  # fmt: skip
            shown.append(inst[ik])
    lims = _cof_limits(shown)
    if lims is not None:
        ax.set_ylim(*lims)
    ax.set_xlabel("cycle (one stroke each way)")
    ax.set_ylabel(r"COF mean $|F_y|/|F_z|$ (central part of the stroke)")
    ax.grid(True, alpha=0.3)
    _legend_above(ax, ncol=4)
    return fig


def friction_loops(loops: Sequence[Mapping[str, Any]], *, title: Optional[str] = None) -> Figure:
    """Friction loops: the friction force against the position over whole cycles (docs/method.md 6c).

    Parameters
    ----------
    loops : sequence of mappings
        Each with ``x`` (m), ``fy`` (N) of one cycle, ``label`` and ``energy`` (J, the loop's area).
    title : str, optional
        Figure title.
    """
    fig, axes = _figure(1, 1, figsize=(7.5, 5.0))
    ax = axes[0, 0]
    fig.suptitle(title or "Friction loops")
    if not loops:
        _no_data(ax, "no whole cycle with a position channel")
        return fig
    for k, lp in enumerate(loops):
        x = 1e3 * np.asarray(lp["x"], dtype=float)
        ax.plot(x, np.asarray(lp["fy"], dtype=float), linewidth=1.0, color=f"C{k}",
                label=f"{lp['label']}: loop area {float(lp['energy']) * 1e3:.4g} mJ")  # fmt: skip
    ax.axhline(0.0, color="0.6", linewidth=0.6)
    ax.set_xlabel("position $x$ (mm)")
    ax.set_ylabel("friction force $F_y$ (N)")
    ax.grid(True, alpha=0.3)
    _legend_above(ax, ncol=1)
    return fig


def energy_vs_cycle(results: Any, *, title: Optional[str] = None) -> Figure:
    """The energy dissipated per cycle (the friction loop's area) and the energy COF against cycle (6c)."""
    fig, axes = _figure(1, 1, figsize=(10.0, 4.6))
    ax = axes[0, 0]
    fig.suptitle(title or "Energy dissipated per cycle")
    cy = getattr(results, "cycles", None)
    if cy is None or not np.isfinite(np.asarray(cy["energy"], dtype=float)).any():
        _no_data(ax, "no whole cycle with a position channel")
        return fig
    c = np.asarray(cy["cycle"], dtype=float)
    e = np.asarray(cy["energy"], dtype=float)
    m = np.asarray(cy["mu_energy"], dtype=float)
    keep = np.isfinite(e)
    (h1,) = ax.plot(c[keep], 1e3 * e[keep], marker="o", markersize=3, linewidth=0.8, color="tab:red",
                    label="energy per cycle (loop area)")  # fmt: skip
    ax.set_xlabel("cycle (one stroke each way)")
    ax.set_ylabel("energy per cycle (mJ)", color="tab:red")
    ax2 = ax.twinx()
    (h2,) = ax2.plot(c[keep], m[keep], marker="s", markersize=3, linestyle="none", color="tab:blue",
                     label="energy COF: energy / (F_n x distance)")  # fmt: skip
    ax2.set_ylabel("energy COF", color="tab:blue")
    lims = _cof_limits([m[keep]])
    if lims is not None:
        ax2.set_ylim(*lims)
    ax.grid(True, alpha=0.3)
    _legend_above(ax, [h1, h2], ncol=2)
    return fig


def png_bytes(fig: Figure, *, dpi: int = DPI) -> bytes:
    """``fig`` rendered once as PNG bytes (no timestamp or software in its metadata, so the bytes repeat; zlib level
    :data:`PNG_COMPRESS_LEVEL`)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, metadata={"Software": None},
                pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})  # fmt: skip
    return buf.getvalue()


class _Pixels(io.RawIOBase):
    """The file object :func:`rgba_pixels` hands to ``savefig(format="rgba")``: keeps the Agg renderer's buffer,
    which Matplotlib writes to it in one call, as an array (height, width, 4)."""

    def __init__(self) -> None:
        super().__init__()
        self.pixels: Optional[np.ndarray] = None

    def writable(self) -> bool:
        return True

    def write(self, data: Any) -> int:
        self.pixels = np.array(data, dtype=np.uint8, copy=True)  # the renderer's memoryview (height, width, 4)
        return int(self.pixels.nbytes)


def rgba_pixels(fig: Figure, *, dpi: int = DPI) -> np.ndarray:
    """``fig`` drawn once by Agg as :func:`png_bytes` draws it, its pixels (height, width, 4) not yet encoded
    (:func:`encode_png` makes them the same PNG bytes)."""
    grab = _Pixels()
    fig.savefig(cast(Any, grab), format="rgba", dpi=dpi)  # (a file object: io.RawIOBase)
    if grab.pixels is None or grab.pixels.ndim != 3 or grab.pixels.shape[2] != 4:  # (Matplotlib's print_raw)
        raise RuntimeError("Matplotlib did not hand over the figure's pixels")
    return grab.pixels


def encode_png(pixels: np.ndarray, *, dpi: int = DPI) -> bytes:
    """The PNG bytes of :func:`rgba_pixels`' pixels: what Matplotlib's Agg canvas does after drawing in
    :func:`png_bytes` (``image.imsave`` with the same arguments), so the bytes are those of :func:`png_bytes`.
    Pillow's encoder releases the GIL: another thread may encode while this one draws."""
    from matplotlib import image

    buf = io.BytesIO()
    no_software: Any = {"Software": None}  # (Matplotlib: None leaves the key out)
    image.imsave(buf, pixels, format="png", origin="upper", dpi=dpi, metadata=no_software,
                 pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})  # fmt: skip
    return buf.getvalue()


class _Beside:
    """A thread that runs ``meanwhile`` (the job's tables and summary: mostly outside the GIL, in pyarrow and the
    Rust core), then encodes the PNGs of the pixels the drawing thread hands it (:meth:`Rendering.finish_beside`).
    """

    def __init__(self, meanwhile: Optional[Callable[[], Any]], dpi: int) -> None:
        import queue
        import threading

        self._meanwhile = meanwhile
        self._dpi = dpi
        self._todo: "queue.SimpleQueue[Optional[Tuple[int, np.ndarray]]]" = queue.SimpleQueue()
        self.pngs: Dict[int, bytes] = {}
        self.result: Any = None
        self.error: Optional[BaseException] = None
        self._thread = threading.Thread(target=self._run, name="tribodyn-outputs", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            if self._meanwhile is not None:
                self.result = self._meanwhile()
            while (item := self._todo.get()) is not None:
                self.pngs[item[0]] = encode_png(item[1], dpi=self._dpi)
        except BaseException as exc:  # noqa: BLE001 - raised again by the drawing thread (join)
            self.error = exc

    def encode(self, k: int, pixels: np.ndarray) -> None:
        self._todo.put((k, pixels))

    def join(self, *, quiet: bool = False) -> None:
        """Waits for the thread (after the last :meth:`encode`); raises what it raised unless ``quiet``."""
        self._todo.put(None)
        self._thread.join()
        if self.error is not None and not quiet:
            raise self.error


class Rendering:
    """PNG bytes of figures, each drawn once (docs/architecture.md).

    Without ``pool`` every figure is drawn in this process when :meth:`finish` is called, after whatever the
    caller does meanwhile, or by :meth:`finish_beside` while a second thread does the caller's other work and
    encodes the PNGs. With ``pool`` (``jobs._DrawingPool``: fresh worker interpreters, never a fork of this
    process, issue 38 point 3) each figure is pickled now, before any drawing, and queued: the workers draw them
    while the caller does its other work, and :meth:`finish` draws here every figure no worker has taken yet,
    then collects the workers' PNG bytes (the same bytes: :func:`draw_pickled`); a figure that does not pickle, a
    worker that fails or does not answer, has its figure drawn here, so the set is always whole. ``also`` (more
    work of the same job, e.g. the interactive views) runs once, here, on the first :meth:`also_result`.
    """

    def __init__(self, figs: Sequence[Figure], *, dpi: int = DPI, also: Optional[Callable[[], Any]] = None,
                 pool: Any = None) -> None:  # fmt: skip
        self._figs = list(figs)
        self._dpi = dpi
        self._also = also
        self._also_done: Optional[Tuple[Any]] = None
        self._batch = _queued(self._figs, dpi, pool) if pool is not None and self._figs else None

    def finish(self) -> List[bytes]:
        """Every figure's PNG bytes, in order."""
        batch, self._batch = self._batch, None
        if batch is None:
            return [png_bytes(f, dpi=self._dpi) for f in self._figs]
        out: Dict[int, bytes] = {}
        for k in iter(batch.steal, None):  # the figures no worker has taken: here
            out[k] = png_bytes(self._figs[k], dpi=self._dpi)
        for k, reply in batch.replies():  # reply: (PNG bytes, warnings) or None (a worker failed: here)
            out[k] = png_bytes(self._figs[k], dpi=self._dpi) if reply is None else _rewarned(*reply)
        return [out[k] for k in range(len(self._figs))]

    def finish_beside(self, meanwhile: Optional[Callable[[], Any]] = None) -> Tuple[List[bytes], Any]:
        """(every figure's PNG bytes in order, what ``meanwhile()`` returned). Without ``pool`` ``meanwhile`` runs
        in a second thread while this one draws the figures, and that thread also encodes each drawn figure's
        PNG (:func:`encode_png`: the bytes of :func:`png_bytes`): the tables and summary of a job (pyarrow, the
        Rust core) and Pillow's encoder run outside the GIL beside Matplotlib's drawing, which holds it (issue 38
        point 3). With ``pool`` the workers draw while ``meanwhile()`` runs here, then :meth:`finish`. What
        ``meanwhile`` raises is raised here, once the figures drawn so far are encoded."""
        if self._batch is not None or not self._figs:
            done = meanwhile() if meanwhile is not None else None
            return self.finish(), done
        beside = _Beside(meanwhile, self._dpi)
        try:
            for k, fig in enumerate(self._figs):
                if beside.error is not None:  # meanwhile failed: the job fails, no more drawing
                    break
                beside.encode(k, rgba_pixels(fig, dpi=self._dpi))
        except BaseException:
            beside.join(quiet=True)  # (the thread writes nothing once this returns)
            raise
        beside.join()
        return [beside.pngs[k] for k in range(len(self._figs))], beside.result

    def also_result(self) -> Any:
        """What ``also()`` returned (None without ``also``), computed once."""
        if self._also is None:
            return None
        if self._also_done is None:
            self._also_done = (self._also(),)
        return self._also_done[0]


def _queued(figs: Sequence[Figure], dpi: int, pool: Any) -> Any:
    """``pool``'s batch of ``figs`` pickled (None in place of a figure that does not pickle), or None when the
    pool takes none (it is closed or broken)."""
    import pickle

    payloads: List[Optional[bytes]] = []
    for f in figs:
        try:
            payloads.append(pickle.dumps(f, protocol=pickle.HIGHEST_PROTOCOL))
        except Exception:  # noqa: BLE001 - drawn here instead
            payloads.append(None)
    return pool.batch(payloads, dpi, rc_changes())


def rc_changes() -> Dict[str, Any]:
    """The Matplotlib settings this process changed since it read its matplotlibrc (a style, an ``rcParams``
    entry), which a drawing worker applies while it draws (it reads the same matplotlibrc)."""
    import matplotlib

    orig = matplotlib.rcParamsOrig
    out: Dict[str, Any] = {}
    for k, v in dict.items(matplotlib.rcParams):  # (dict.items: reading "backend" would resolve it)
        if k in ("backend", "backend_fallback", "interactive"):
            continue
        try:
            if k not in orig or dict.__getitem__(orig, k) != v:
                out[k] = v
        except Exception:  # noqa: BLE001, S112 - a value that does not compare: sent as it is
            out[k] = v
    return out


def draw_pickled(data: bytes, dpi: int = DPI, rc: Optional[Mapping[str, Any]] = None
                 ) -> Tuple[bytes, List[Tuple[str, str, str, str, int]]]:  # fmt: skip
    """A pickled figure's :func:`png_bytes` with the settings ``rc`` (:func:`rc_changes`), and the warnings the
    drawing gave (message, category's module and name, file, line), in a drawing worker."""
    import pickle

    import matplotlib

    fig = pickle.loads(data)  # noqa: S301 - this process' own parent pickled it
    settings: Any = dict(rc or {})
    with warnings.catch_warnings(record=True) as caught, matplotlib.rc_context(settings):
        warnings.simplefilter("always")
        png = png_bytes(fig, dpi=dpi)
    return png, [(str(w.message), w.category.__module__, w.category.__qualname__, w.filename, w.lineno)
                 for w in caught]  # fmt: skip


def _rewarned(png: bytes, warns: Sequence[Tuple[str, str, str, str, int]]) -> bytes:
    """``png``, the warnings a worker's drawing gave issued here (as drawing it here would have)."""
    import importlib

    for message, module, name, filename, lineno in warns:
        try:
            category = getattr(importlib.import_module(module), name)
            if not (isinstance(category, type) and issubclass(category, Warning)):
                category = UserWarning
        except Exception:  # noqa: BLE001 - a category this process cannot import
            category = UserWarning
        warnings.warn_explicit(message, category, filename, lineno)
    return png


def serve_drawing(parent: int) -> None:
    """A drawing worker's loop (``jobs._DrawingPool``; started by its ``_WORKER_CODE``, which already bound it to
    die with ``parent``): says ``("ready", pid, None)`` once Matplotlib is loaded, then reads pickled ``(key,
    pickled figure, dpi, rc)`` from stdin until end of file and answers each with a pickled ``(key, (PNG bytes,
    warnings) or None, error)`` on what was its stdout (fd 1 then points to the null device: nothing printed
    mixes into the answers)."""
    import pickle
    import sys
    import threading
    import time

    out = os.fdopen(os.dup(1), "wb")
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)
    os.close(null)

    def watch() -> None:  # where PR_SET_PDEATHSIG is missing (not Linux): leave once the parent is gone
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(0)

    threading.Thread(target=watch, daemon=True).start()
    fig, axes = _figure(figsize=(2.0, 1.5))  # fonts, mathtext, layout and the PNG encoder loaded before the work
    axes[0, 0].plot([0.0, 1.0], [1.0, 0.0], label=r"$\mu_r$")
    axes[0, 0].set_xlabel(_FORCE_LABEL["z"])
    axes[0, 0].legend()
    png_bytes(fig, dpi=30)
    inp = sys.stdin.buffer
    reply: Tuple[Any, Any, Optional[str]] = ("ready", os.getpid(), None)
    while True:
        pickle.dump(reply, out, protocol=pickle.HIGHEST_PROTOCOL)
        out.flush()
        try:
            key, data, dpi, rc = pickle.load(inp)  # noqa: S301 - from this process' own parent
        except EOFError:  # the parent closed the pipe: done
            return
        try:
            reply = (key, draw_pickled(data, dpi, rc), None)
        except Exception as exc:  # noqa: BLE001 - the parent draws this figure itself
            reply = (key, None, repr(exc))


def save_figure(fig: Figure, path: Union[str, "os.PathLike[str]"], *, dpi: int = DPI) -> str:
    """Saves ``fig`` as PNG atomically: a temporary file in the same directory, then ``os.replace``.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    path : str or path-like
        Target file; its directory must exist. An existing file is replaced
        only once the new one is complete.
    dpi : int
        Resolution (default :data:`DPI`).

    Returns
    -------
    str
        The path written.

    Raises
    ------
    Exception
        Whatever rendering or writing raised; the target is then untouched
        and no temporary file is left behind.
    """
    from ..io.writers import atomic_write

    target = os.fspath(path)
    atomic_write(target, lambda tmp: fig.savefig(tmp, format="png", dpi=dpi))
    return target
