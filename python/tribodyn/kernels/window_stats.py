"""Per-window statistics and the quality gate, shared by ``identify`` and
``analyze`` (docs/method.md sections 3-5).

The Rust kernel ``_core.windows_stats`` computes, for every window, the
regression of fy on fz, the three Pearson coefficients, the deadband, the fz
bins and mu_a / mu_b in one task per window (GIL released, windows in
parallel). What every window of an analysis shares (length, deadband, bins,
columns, options beyond the paper, threads) is one frozen
``_core.WindowSpec``, checked and converted once (:func:`make_spec`;
``routes.KernelSpec`` makes the analysis' one). The kernel runs with
orientation +1; the recording's orientation s is applied afterwards by
:func:`orient`, which is exact (a sign flip), so the orientation can be
fixed once per recording after all windows are seen.
"""

from __future__ import annotations

from typing import Any, Dict, Optional, Sequence, Tuple, Union

import numpy as np

from .. import _core
from ..columns import kernel_columns
from .deadband import Deadband

__all__ = ["compute", "make_spec", "orient", "gate_reasons", "COF_KEYS"]

#: Quantities that change sign with the orientation s.
COF_KEYS = ("slope", "intercept", "mu_a", "mu_b", "bin_cof")


def make_spec(
    length: int,
    deadband: Deadband,
    n_bins: int,
    columns: Optional[Sequence[str]] = None,
    *,
    raw: bool = False,
    options: Optional[Dict[str, Any]] = None,
    threads: Optional[int] = None,
    highpass: Optional[Tuple[np.ndarray, np.ndarray]] = None,
    naming: Optional[Tuple[str, float]] = None,
) -> _core.WindowSpec:
    """The kernel's frozen settings for windows of ``length`` samples, checked once (``_core.WindowSpec``).

    ``columns`` names the statistics wanted, in order (default
    :data:`tribodyn.columns.KERNEL_COLUMNS`, plus ``mu_classic`` with
    ``raw``); the kernel returns exactly those. ``options`` are the
    kernel's options of the statistics beyond the paper
    (``Plan.kernel_options``: instrument lag, line frequencies, segments,
    fz delay, classical COF; docs/method.md 3a-3e). ``threads`` (default:
    the process default) never changes the results; 1 keeps the work on
    the calling thread. ``highpass`` = (sos, zi) of raw forces, for the
    file route. ``naming`` = (auxiliary role, fs): a NaN or inf is named by
    its role and time. A bad setting is a ``ValueError`` (an unknown option
    a ``TypeError``) here, before any window is read.
    """
    if columns is None:
        columns = kernel_columns(raw)
    return _core.WindowSpec(
        int(length), (deadband.kind, float(deadband.value)), int(n_bins), list(columns), options=options,
        highpass=highpass, threads=threads, naming=naming,
    )  # fmt: skip


def compute(
    spec: _core.WindowSpec,
    fy: np.ndarray,
    fz: np.ndarray,
    starts: np.ndarray,
    *,
    fx: Optional[np.ndarray] = None,
    aux: Optional[np.ndarray] = None,
    raw: Optional[Tuple[np.ndarray, np.ndarray]] = None,
    offset: int = 0,
) -> Dict[str, np.ndarray]:
    """Kernel statistics of windows ``[s, s + spec.length)`` for ``s`` in ``starts`` (orientation +1).

    Returns the spec's columns (:func:`make_spec`). ``raw`` (fy, fz before
    the high-pass) defines ``mu_classic``, the classical COF
    mean(|fy|/|fz|) per window. A NaN or inf sample in a window raises
    ``tribodyn._core.NonFiniteError`` (a ``ValueError``) naming the
    window's start counted from ``offset`` (and, with the spec's
    ``naming``, the channel's role and the time).
    """
    return _core.windows_stats(
        spec, fx, fy, fz, aux, np.ascontiguousarray(starts, dtype=np.int64), raw=raw, offset=int(offset)
    )


def orient(stats: Dict[str, np.ndarray], s: int, *, inplace: bool = False) -> Dict[str, np.ndarray]:
    """Applies orientation ``s`` (docs/method.md 0): mu = s * slope, and so on.

    Returns a new dict with ``mu_r``, ``mu_r_stderr``, ``f_y0`` and
    ``force_dependence`` added. F_y0 is the intercept in the measured fy
    frame (not flipped), as in the paper's Eq. (7). With ``inplace`` the
    COF arrays of ``stats`` are flipped in place (no copies of a long
    table), and ``slope`` becomes ``mu_r``.
    """
    out = dict(stats)
    for key in ("mu_a", "mu_b", "bin_cof"):
        if not inplace:
            out[key] = s * stats[key]
        elif s != 1:
            np.negative(stats[key], out=stats[key])
    if inplace:
        if s != 1:
            np.negative(stats["slope"], out=stats["slope"])
        out["mu_r"] = out.pop("slope")
    else:
        out["mu_r"] = s * stats["slope"]
    out["mu_r_stderr"] = stats["slope_stderr"]
    out["f_y0"] = stats["intercept"]
    with np.errstate(invalid="ignore", divide="ignore"):
        out["force_dependence"] = (out["mu_b"] - out["mu_a"]) / out["mu_r"]
    return out


def gate_reasons(
    stats: Dict[str, np.ndarray],
    gate: Union[float, str],
    skew: Optional[np.ndarray] = None,
    *,
    rel_ci: Optional[np.ndarray] = None,
    max_rel_ci: float = 0.1,
    sign: bool = True,
) -> np.ndarray:
    """Why each window fails the quality gate (docs/method.md 5); '' when it passes.

    Reasons: a force out of range (beyond ``_core.FORCE_LIMIT`` N in
    magnitude, or sums that overflow: the kernel's ``out_of_range``,
    docs/method.md 4); the fit is degenerate (fewer than 3 samples, constant fz, no
    variance of fz beyond its noise); with a number ``gate``, |C_yz(0)|
    below it (the paper's gate); with ``gate="ci"``, an expected 95 %
    half-width ``rel_ci``, relative to the recording's COF, above
    ``max_rel_ci`` (``estimators.gate_precision``); with ``sign``, a
    slope whose sign is opposite to the recording's orientation (mu_r < 0);
    the deadband excludes every sample; a channel skew (max |C_yz(j)| away
    from lag 0, with ``max_lag``). Returns an object array of str.
    """
    c = np.abs(np.asarray(stats["c_yz"], dtype=float))
    mu = np.asarray(stats["mu_r"] if "mu_r" in stats else stats["slope"], dtype=float)
    degenerate = ~np.isfinite(mu)
    out = np.asarray(stats["out_of_range"], dtype=bool) if "out_of_range" in stats else np.zeros(len(c), dtype=bool)
    low = np.zeros(len(c), dtype=bool)
    wide = np.zeros(len(c), dtype=bool)
    with np.errstate(invalid="ignore"):
        if gate == "ci":
            if rel_ci is None:
                raise ValueError("gate='ci' needs the intervals' relative half-widths")
            rel = np.asarray(rel_ci, dtype=float)
            wide = ~degenerate & ~(rel <= max_rel_ci)
        else:
            low = ~degenerate & ~(c >= float(gate))
        opposite = ~degenerate & (mu < 0) if sign else np.zeros(len(c), dtype=bool)
    empty = (stats["n_a"] + stats["n_b"]) == 0
    skewed = np.zeros(len(c), dtype=bool)
    if skew is not None:
        sk = np.asarray(skew, dtype=float)
        with np.errstate(invalid="ignore"):
            skewed = np.isfinite(sk) & (sk != 0)
    reasons = np.full(len(c), "", dtype=object)
    # Strings only for the windows that fail (few, in a good recording).
    empty &= ~out  # an out-of-range window counts no sample: its reason says why
    for k in np.flatnonzero(degenerate | low | wide | opposite | empty | skewed):
        why = []
        if out[k]:
            why.append(f"force out of range: |force| > {_core.FORCE_LIMIT:g} N or its products overflow")
        elif degenerate[k]:
            why.append("degenerate: fewer than 3 samples, constant fz or no fz variance beyond its noise")
        elif low[k]:
            why.append(f"low correlation: |C_yz(0)| = {c[k]:.3f} < {float(gate):g}")
        elif wide[k]:
            why.append(
                f"imprecise: expected 95 % interval +-{100 * rel[k]:.1f} % of the recording's COF "
                f"> +-{100 * max_rel_ci:g} %"
            )
        if opposite[k]:
            why.append("slope sign opposite to the recording's orientation")
        if empty[k]:
            why.append(f"deadband: {stats['deadband'][k]:.4g} N excludes every sample")
        if skewed[k]:
            why.append(f"skew: max |C_yz| at lag {int(skew[k])}, not 0")  # type: ignore[index]
        reasons[k] = "; ".join(why)
    return reasons
