"""COF of one acquisition: ``tribodyn.identify`` (docs/method.md sections 3-5)."""

from __future__ import annotations

import warnings
from typing import Any, Dict, Optional, Tuple

import numpy as np

from ..kernels._validate import (
    Orientation,
    as_signal,
    check_bins,
    check_fs,
    check_gate,
    check_int,
    resolve_orientation,
    same_length,
)
from ..kernels.correlation import XcorrResult, xcorr
from ..kernels.deadband import parse_deadband
from ..kernels.quantiles import Z975
from ..kernels.estimators import T975, WEAK_INSTRUMENT, quadratic, slopes
from ..kernels.window_stats import compute, gate_reasons, make_spec, orient
from ..options import option
from .._deprecation import deprecated
from ..results import BinTable, CofResult
from .plan import Plan, check_statistics

__all__ = ["identify", "resolve_orientation", "cross_spectra", "check_gate", "Orientation"]


def cross_spectra(
    fx: Optional[np.ndarray], fy: np.ndarray, fz: np.ndarray, fs: float, *, rpm: float, n_lamellas: int
) -> Dict[str, Dict[str, float]]:
    """|Welch cross-spectrum| of xy, xz, yz at f0 = rpm/60 and f_l = n_lamellas f0 (docs/method.md 5).

    The segment length is the largest power of two up to fs/0.5 Hz resolution
    that fits the signal; each value is read at the bin nearest the frequency.
    """
    f0 = rpm / 60.0
    fl = n_lamellas * f0
    nper = int(min(len(fy), 2 ** int(np.floor(np.log2(max(2 * fs, 8))))))
    pairs = {"yz": (fy, fz)}
    if fx is not None:
        pairs.update({"xy": (fx, fy), "xz": (fx, fz)})
    out: Dict[str, Dict[str, float]] = {}
    for name, (a, b) in pairs.items():
        from scipy import signal as _signal  # lazy: slow to import

        f, p = _signal.csd(a, b, fs=fs, nperseg=nper)
        pick = {
            key: float(np.abs(p[int(np.argmin(np.abs(f - fq)))])) if fq <= fs / 2 else float("nan")
            for key, fq in (("f0", f0), ("f_l", fl))
        }
        out[name] = pick
    return out


#: The options of :func:`tribodyn.analyze` that apply to one acquisition (same names, defaults and checks).
IDENTIFY_OPTIONS = (
    "orientation", "deadband", "n_bins", "gate", "max_lag", "rpm", "n_lamellas", "estimator", "method", "max_rel_ci",
    "iv_lag", "noise",
)  # fmt: skip


def identify(
    fy: Any,
    fz: Any,
    *more: Any,
    fx: Optional[Any] = None,
    fs: Optional[float] = None,
    plan: Optional[Any] = None,
    **options: Any,
) -> CofResult:
    """COF of one acquisition from its dynamic forces (docs/method.md 3-5).

    The options are :func:`tribodyn.analyze`'s, with the same defaults
    (declared once in :data:`tribodyn.options.OPTIONS`): those that apply to
    one acquisition are listed below; ``method="paper"`` gives the paper's
    (OLS, |C_yz(0)| >= 0.85).

    Parameters
    ----------
    fy, fz : array_like, 1-D, equal length
        Dynamic tangential (friction) and normal forces in N.
    fx : array_like, optional, keyword-only
        Dynamic axial force in N (None: no x correlations). The 0.2 form
        ``identify(fx, fy, fz, fs=...)`` still works with a DeprecationWarning.
    fs : float
        Sampling rate, Hz (``plan.fs`` when a plan is given).
    plan : Plan, optional
        The options checked once (:func:`tribodyn.make_plan`); no other
        option with it. Its ``n_bins`` is bounded again by this
        acquisition's length.
    orientation : {+1, -1, "auto"}
        s in mu = s * slope. "auto" takes the sign of this acquisition's
        slope (it is the whole recording here; :func:`tribodyn.analyze` fixes
        it once for a long recording).
    deadband : float or str
        |fz| < d excluded from the bins and from mu_a, mu_b: a force in N
        (paper 0.35) or ``"0.7sigma"`` (k times the std of fz).
    n_bins : int
        Equal-width fz bins over [min fz, max fz] (default 16; at most
        max(16, n // 4) and 1024, docs/method.md 4).
    gate : float or "ci"
        Quality gate (docs/method.md 5): "ci" (default) passes when the 95 %
        half-width is at most ``max_rel_ci`` of |mu_r|; a number g is the
        paper's |C_yz(0)| >= g (0.85 with ``method="paper"``).
    max_rel_ci : float
        Largest relative half-width of gate "ci" (default 0.1).
    max_lag : int, optional
        Also compute C_xy, C_xz, C_yz for lags up to ``max_lag`` and the skew
        (lag of max |C_yz|); a non-zero skew fails the gate.
    rpm, n_lamellas : optional
        Rig data: cross-spectra at f0 and f_l (Welch); ``rpm`` also sets the
        instrument lag (one revolution).
    estimator : {"corrected", "iv", "ols", "deming"}
        The slope estimator (docs/method.md 3a-3c). Default "corrected", as
        :func:`tribodyn.analyze`'s: one acquisition has no other windows to
        measure the noise on fz from, so "corrected" here equals "iv" unless
        ``noise`` is given. Every estimator but "ols" adds the batch-means
        standard error, its 95 % interval, ``attenuation_p`` and ``dmu_dfn``.
    method : {None, "paper"}
        "paper": the paper's method exactly (OLS, |C_yz(0)| >= 0.85).
    iv_lag : float, optional
        Instrument lag in s (default: one revolution with ``rpm``, else a
        tenth of the acquisition, at least 10 samples).
    noise : (sigma_y, sigma_z), optional
        Measurement-noise standard deviations in N ("deming" needs them).

    Returns
    -------
    CofResult
        Degenerate input (constant fz, too few samples) gives NaN fields and
        ``ok=False`` with its reason, not an exception.
    """
    if more:
        if len(more) != 1 or fx is not None:
            raise TypeError("identify() takes the forces as identify(fy, fz, fx=None, fs=...)")
        deprecated("identify(fx, fy, fz, ...) is deprecated: use identify(fy, fz, fx=fx, fs=...)")
        fx, fy, fz = fy, fz, more[0]
    fs, o = _identify_options(fs, plan, options)
    fs_v = check_fs(fs)
    fy_a = as_signal(fy, "fy", min_len=1)
    fz_a = as_signal(fz, "fz", min_len=1)
    fx_a = None if fx is None else as_signal(fx, "fx", min_len=1)
    same_length(fy=fy_a, fz=fz_a, **({} if fx_a is None else {"fx": fx_a}))
    n = fz_a.size
    db = parse_deadband(o["deadband"])
    nb = check_bins(o["n_bins"], n)
    stats = _statistics_options(fs_v, n, o)
    st = compute(make_spec(n, db, nb), fy_a, fz_a, np.zeros(1, dtype=np.int64), fx=fx_a)
    s = resolve_orientation(o["orientation"], float(st["slope"][0]))
    o_st = orient(st, s)

    correlations, skew = _correlations(fx_a, fy_a, fz_a, fs_v, o["max_lag"])
    spectra = None
    rpm, n_lamellas = o["rpm"], o["n_lamellas"]
    if rpm is not None and n_lamellas is not None and n >= 8:
        lamellas = check_int(n_lamellas, "n_lamellas", minimum=1)
        spectra = cross_spectra(fx_a, fy_a, fz_a, fs_v, rpm=float(rpm), n_lamellas=lamellas)

    estimator = stats["estimator"]
    extra: Dict[str, float] = {}
    if estimator != "ols":
        extra = _estimate(fy_a, fz_a, s, stats, o_st)
        if not extra:  # a weak instrument: least squares, as analyze does (docs/method.md 3b)
            estimator = "ols"
    rel = None
    if stats["gate"] == "ci":  # docs/method.md 5: the 95 % half-width relative to |mu_r|
        se = float(o_st["mu_r_stderr"][0])
        with np.errstate(invalid="ignore", divide="ignore"):
            rel = np.array([Z975 * se / abs(float(o_st["mu_r"][0]))])
    skew_arr = None if skew is None else np.array([skew], dtype=float)
    reasons = gate_reasons(o_st, stats["gate"], skew_arr, rel_ci=rel, max_rel_ci=stats.get("max_rel_ci", 0.1))[0]
    o = o_st
    return CofResult(
        mu_r=float(o["mu_r"][0]),
        f_y0=float(o["f_y0"][0]),
        r=float(o["r"][0]),
        mu_r_stderr=float(o["mu_r_stderr"][0]),
        mu_a=float(o["mu_a"][0]),
        mu_b=float(o["mu_b"][0]),
        force_dependence=float(o["force_dependence"][0]),
        bins=BinTable.from_range(float(o["fz_min"][0]), float(o["fz_max"][0]), o["bin_count"][0], o["bin_cof"][0]),
        c_xy=float(o["c_xy"][0]),
        c_xz=float(o["c_xz"][0]),
        c_yz=float(o["c_yz"][0]),
        ok=reasons == "",
        reasons=tuple(r for r in reasons.split("; ") if r),
        orientation=s,
        deadband=float(o["deadband"][0]),
        n=n,
        correlations=correlations,
        skew=skew,
        spectra=spectra,
        estimator=estimator,
        mu_ols=extra.get("mu_ols", float(o["mu_r"][0])),
        mu_r_low=extra.get("mu_r_low", float("nan")),
        mu_r_high=extra.get("mu_r_high", float("nan")),
        attenuation_p=extra.get("attenuation_p", float("nan")),
        dmu_dfn=extra.get("dmu_dfn", float("nan")),
        dmu_dfn_stderr=extra.get("dmu_dfn_stderr", float("nan")),
    )


def _correlations(fx: Optional[np.ndarray], fy: np.ndarray, fz: np.ndarray, fs: float, max_lag: Any
                  ) -> Tuple[Optional[Dict[str, XcorrResult]], Optional[int]]:  # fmt: skip
    """C_yz (and C_xy, C_xz with fx) for lags up to ``max_lag`` and the skew, the lag of max |C_yz|
    (None, None without ``max_lag``; the skew None when no C_yz is finite)."""
    if max_lag is None:
        return None, None
    n = fz.size
    lag = check_int(max_lag, "max_lag", minimum=0)
    lag = min(lag, n - 1) if n >= 2 else 0
    correlations = {"yz": xcorr(fy, fz, max_lag=lag, fs=fs, check_finite=False)}
    if fx is not None:
        correlations["xy"] = xcorr(fx, fy, max_lag=lag, fs=fs, check_finite=False)
        correlations["xz"] = xcorr(fx, fz, max_lag=lag, fs=fs, check_finite=False)
    c = correlations["yz"].c
    skew = int(correlations["yz"].lags[int(np.nanargmax(np.abs(c)))]) if np.isfinite(c).any() else None
    return correlations, skew


def _identify_options(fs: Any, plan: Any, options: Dict[str, Any]) -> Tuple[Any, Dict[str, Any]]:
    """(fs, the options by name): from ``plan``, or ``options`` over the declared defaults (tribodyn.options)."""
    unknown = sorted(set(options) - set(IDENTIFY_OPTIONS))
    if unknown:
        raise TypeError(
            f"identify() got unknown option(s) {', '.join(map(repr, unknown))}; its options are "
            f"{', '.join(IDENTIFY_OPTIONS)}"
        )
    if plan is None:
        if fs is None:
            raise TypeError("identify() missing required keyword argument 'fs' (sampling rate, Hz)")
        return fs, {name: options.get(name, option(name).default) for name in IDENTIFY_OPTIONS}
    if not isinstance(plan, Plan):
        raise TypeError(f"plan must be a tribodyn.Plan (tribodyn.make_plan(...)), got {type(plan).__name__}")
    if options:
        raise TypeError(f"identify(..., plan=...) takes no other options; make the plan with them: {sorted(options)}")
    if fs is not None and float(fs) != plan.fs:
        raise ValueError(f"the plan is for fs = {plan.fs:g} Hz, the forces are sampled at {float(fs):g} Hz")
    o = {name: getattr(plan, name) for name in IDENTIFY_OPTIONS}
    o.update(method=plan.method or None, iv_lag=plan.iv_lag if not plan.paper else None)
    return plan.fs, o


def _statistics_options(fs: float, n: int, o: Dict[str, Any]) -> Dict[str, Any]:
    """The statistical options checked for an acquisition of ``n`` samples (``plan.check_statistics``)."""
    return check_statistics(
        fs, n, method=o["method"], estimator=o["estimator"], gate=o["gate"], max_rel_ci=o["max_rel_ci"],
        iv_lag=o["iv_lag"], noise=o["noise"], rpm=o["rpm"], n_lamellas=o["n_lamellas"],
    )  # fmt: skip


def _estimate(fy: np.ndarray, fz: np.ndarray, s: int, stats: Dict[str, Any], o: Dict[str, np.ndarray]
              ) -> Dict[str, float]:  # fmt: skip
    """The slope of ``stats["estimator"]`` and its statistics for one acquisition (docs/method.md 3a-3e).

    Updates ``o``; {} (``o`` untouched: least squares) when "corrected" has a weak instrument and no ``noise``.
    """

    n = fz.size
    spec = make_spec(n, parse_deadband(0.0), 1, ["n", "ext"], options=dict(lag=stats["iv_lag_samples"]))
    st = compute(spec, fy, fz, np.zeros(1, dtype=np.int64))
    E, nn = st["ext"], st["n"]
    sl = slopes(E, nn, stats["estimator"], noise=stats["noise"])
    r = float(sl.instrument_r[0])
    if stats["estimator"] == "corrected" and stats["noise"] is None and not abs(r) >= WEAK_INSTRUMENT:
        warnings.warn(
            f"identify: the instrument (fz lagged by {stats['iv_lag_samples']} samples) is weak (r = {r:.2f}): mu_r is "
            "the least-squares slope; pass rpm= (a lag of one revolution), iv_lag= or noise= (docs/method.md 3b)",
            RuntimeWarning,
            stacklevel=3,
        )
        return {}
    a2, a2_se = quadratic(E, nn, instrumented=True)
    mu, se = float(s * sl.slope[0]), float(sl.se[0])
    mu_ols = float(o["mu_r"][0])
    o["mu_r"] = np.array([mu])
    o["mu_r_stderr"] = np.array([se])
    with np.errstate(invalid="ignore", divide="ignore"):
        o["force_dependence"] = (o["mu_b"] - o["mu_a"]) / mu
    return dict(
        mu_ols=mu_ols, mu_r_low=mu - T975 * se, mu_r_high=mu + T975 * se,
        attenuation_p=float(sl.attenuation_p[0]), dmu_dfn=float(s * a2[0]), dmu_dfn_stderr=float(a2_se[0]),
    )  # fmt: skip
