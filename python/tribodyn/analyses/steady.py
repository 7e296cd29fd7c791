"""Running-in and steady state of the COF against time: :func:`steady_state` (docs/method.md 6h).

The series COF(t) is the headline's (docs/method.md 6e): the gated windows'
mu_r ("dynamic"; per cycle for direction-rectified strokes), the windows'
classical COF ("classical") or the cycles' COF ("per-stroke"). On it, three
models with the time origin ``t0`` at the start of the first point (where
sliding under load starts, as far as the series can tell)::

    flat          mu(t) = m
    exponential   mu(t) = m + A exp(-(t - t0) / tau)
    linear        mu(t) = m + a max(c - t, 0)        (a ramp that ends at c)

In each, the end of the running-in ``t_steady`` is the first time after
which ``|mu(t) - m| <= DELTA |mu(t0) - m|`` (DELTA = 2 %): ``t0 + tau ln 50``,
``c - 0.02 (c - t0)``, and ``t0`` for the flat model. For a fixed
``t_steady`` both transient models are linear in (m, amplitude): each is
fitted by least squares over a grid of ``t_steady`` (a quarter of the
points' spacing, at most 400 steps to the last point, then coarsely to 3
spans; refined on 41 points between the best's neighbours). The better of
the two replaces the flat model when its F statistic (two more parameters),
divided by the variance inflation ``(1 + rho) / (1 - rho)`` of the
residuals' lag-1 autocorrelation ``rho`` (bias-corrected), exceeds the 99 %
quantile of F(2, df), ``df = n (1 - rho^2) / (1 + rho^2) - 3``.

Intervals: the chosen fit plus AR(1) noise like its residuals (their
bias-corrected ``rho``, their innovations resampled, their variance with
the degrees of freedom of the fit restored) is refitted, with the model
choice, ``n_boot`` times; t_steady's interval is the replicates' percentiles
at Phi(-t(0.975, df)) and Phi(t(0.975, df)) (its sampling distribution is
skewed), the steady COF's the estimate +- t(0.975, df) times their standard
deviation. The steady COF is the mean of the points
at or after t_steady less the fitted transient's tail there (at most 2 % of
its initial size); each replicate uses its own t_steady, so the interval
holds where the steady part starts as well as the autocorrelation.

Verdict: "too short" under :data:`MIN_POINTS` points; "no steady state" when
the steady part holds fewer than 5 points or a fifth of all, when the upper
end of t_steady's interval reaches the last point, or when the residuals
still drift: a least-squares slope over the steady part or over its last
half, significant at 0.5 % each (its variance times ``(1 + rho) / (1 -
rho)``), that changes the COF over the steady part by more than 5 % of its
mean (:data:`DRIFT_TOLERANCE`: significant is not relevant); else "steady state reached", its line stating
the drift left.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Dict, List, Optional, Tuple

import numpy as np

from ..kernels.quantiles import f_ppf, t_ppf, t_sf

if TYPE_CHECKING:  # pragma: no cover
    from ..results import Results

__all__ = ["DELTA", "MODELS", "VERDICTS", "SteadyState", "fit_steady", "steady_series", "steady_state", "steady_states"]

#: Share of the transient left at t_steady (docs/method.md 6h).
DELTA = 0.02
#: The models, in the order of their codes in the fit.
MODELS = ("flat", "exponential", "linear")
#: The verdicts of :class:`SteadyState`.
VERDICTS = ("steady state reached", "no steady state", "too short")
#: Fewest points of the series for a fit.
MIN_POINTS = 10
#: Fewest points, and least share of the points, in the steady part.
MIN_STEADY_POINTS = 5
MIN_STEADY_FRACTION = 0.2
#: Level of the F-test of a transient against the flat model, and of the two drift tests together.
ALPHA_MODEL = 0.01
ALPHA_DRIFT = 0.01
#: A significant drift counts when it changes the COF over the steady part by more than this (relative): a
#: practical criterion beside the statistical one (issue 35 point 5; 2 % before, which called an hour within
#: 0.138-0.140 "still drifts").
DRIFT_TOLERANCE = 0.05
#: Bootstrap replicates.
N_BOOT = 400
#: Longer series are averaged over consecutive points down to at most this many.
MAX_POINTS = 1000
_LN = math.log(1.0 / DELTA)


@dataclass(frozen=True, eq=False)
class SteadyState:
    """Where running-in ends and the steady-state COF (docs/method.md 6h).

    Attributes
    ----------
    verdict : str
        "steady state reached", "no steady state" or "too short" (:data:`VERDICTS`).
    t_steady, t_steady_low, t_steady_high : float
        End of the running-in (s from the start of the recording) and its 95 % interval; the first time
        after which the fitted transient is within 2 % of its initial size. NaN unless the steady state
        is reached (``reasons`` gives the fit's value then).
    cof, cof_low, cof_high : float
        Steady-state COF: the mean of the series over the points at or after t_steady, and its 95 %
        interval (block bootstrap). NaN unless the steady state is reached.
    cof_initial : float
        The fitted COF at the start (t0); NaN when too short.
    method : str
        The headline method whose series was used ("dynamic", "classical", "per-stroke", "instrument"; "" for
        arrays).
    model : str
        "flat", "exponential" or "linear" (:data:`MODELS`); "" when too short.
    n, n_steady : int
        Points of the series, and in its steady part.
    t0, t_end : float
        Start of the first point (the time origin of the models) and time of the last point (s).
    tau : float
        Time constant of the exponential model (s), else NaN.
    drift, drift_p : float
        Least-squares slope (COF per s) of the residuals over the steady part, and its p-value.
    reasons : tuple of str
        Why there is no steady state, or why the series is too short.
    series, estimate, interval : str
        What the series is, how the values and the intervals are computed, in words.
    time, values, fitted : ndarray
        The series (s, COF) and the fitted model at its points.
    """

    verdict: str
    t_steady: float
    t_steady_low: float
    t_steady_high: float
    cof: float
    cof_low: float
    cof_high: float
    cof_initial: float
    method: str
    model: str
    n: int
    n_steady: int
    t0: float
    t_end: float
    tau: float = float("nan")
    drift: float = float("nan")
    drift_p: float = float("nan")
    reasons: Tuple[str, ...] = ()
    series: str = ""
    estimate: str = ""
    interval: str = ""
    time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    values: np.ndarray = field(default_factory=lambda: np.zeros(0))
    fitted: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def ok(self) -> bool:
        """True when the steady state is reached (t_steady and cof are numbers)."""
        return self.verdict == VERDICTS[0]

    @property
    def text(self) -> str:
        """One line: 'steady state from t = 310 s [265, 372]: COF 0.1503 (95 % 0.1489 to 0.1517); ...'."""
        if self.ok:
            return (
                f"steady state from t = {_g4(self.t_steady)} s [{_g4(self.t_steady_low)}, {_g4(self.t_steady_high)}]:"
                f" COF {self.cof:#.4g} (95 % {self.cof_low:#.4g} to {self.cof_high:#.4g}); running-in COF "
                f"{self.cof_initial:#.4g} at the start ({self.model} model, {self.method or 'series'} COF)"
                + self._drift_words()
            )
        return f"{self.verdict}: {'; '.join(self.reasons)}"

    def _drift_words(self) -> str:
        """'; drift over the steady part 0.8 % of the COF (p = 0.3), under 5 %' ('' without a drift test)."""
        span = self.t_end - self.t_steady
        if not (np.isfinite(self.drift) and np.isfinite(span) and self.cof):
            return ""
        share = 100 * abs(self.drift) * span / abs(self.cof)
        return (f"; drift over the steady part {share:.1f} % of the COF (p = {self.drift_p:.2g}), under "
                f"{100 * DRIFT_TOLERANCE:g} %")  # fmt: skip

    def __str__(self) -> str:
        return self.text

    def to_dict(self) -> Dict[str, Any]:
        """JSON-ready (NaN as None, without the series' arrays), ``text`` added."""

        def num(v: float) -> Optional[float]:
            return float(v) if math.isfinite(v) else None

        out: Dict[str, Any] = {"verdict": self.verdict}
        for k in ("t_steady", "t_steady_low", "t_steady_high", "cof", "cof_low", "cof_high", "cof_initial"):
            out[k] = num(getattr(self, k))
        out.update(method=self.method, model=self.model, n=int(self.n), n_steady=int(self.n_steady),
                   t0=num(self.t0), t_end=num(self.t_end), tau=num(self.tau), drift=num(self.drift),
                   drift_p=num(self.drift_p), reasons=list(self.reasons), series=self.series,
                   estimate=self.estimate, interval=self.interval, text=self.text)  # fmt: skip
        return out


def _g4(x: float) -> str:
    """``x`` to 4 significant digits, trailing zeros kept ("150.0"), no bare trailing point ("1007", not "1007.")."""
    text = f"{x:#.4g}"
    return text[:-1] if text.endswith(".") else text


# -- the series -----------------------------------------------------------------------


def steady_series(res: "Results") -> Tuple[np.ndarray, np.ndarray, float, str, str]:
    """(time, COF, t0, headline method, description) of the headline's series (docs/method.md 6h)."""
    from ..kernels.strokes import cycle_means

    head = res.headline
    table = res.table
    t = np.asarray(table["time"], dtype=float)
    t_start = np.asarray(table.get("t_start", t), dtype=float)
    st = res.strokes
    if head.method == "per-stroke":
        if st is None or not len(st.get("mu", [])):
            return np.zeros(0), np.zeros(0), float("nan"), head.method, "per-cycle COF (no strokes)"
        cyc = np.asarray(st["cycle"], dtype=np.int64)
        times = np.asarray([np.mean(np.asarray(st["time"], dtype=float)[cyc == c]) for c in np.unique(cyc)])
        mu = cycle_means(st)
        t0 = float(np.min(np.asarray(st["t_start"], dtype=float)))
        return times, mu, t0, head.method, "per-cycle COF (mean of the forward and backward strokes)"
    if head.method in ("classical", "instrument"):  # a COF-only export: its COF column per window (6e)
        column = "mu_classical" if head.method == "classical" else "mu_instrument"
        v = np.asarray(table.get(column, np.full(t.size, np.nan)), dtype=float)
        keep = np.isfinite(v) & np.isfinite(t)
        t0 = float(t_start[keep][0]) if keep.any() else float("nan")
        what = "classical COF of each window (mu_classical)" if column == "mu_classical" else (
            "the instrument's COF of each window (mu_instrument)")  # fmt: skip
        return t[keep], v[keep], t0, head.method, what
    ok = np.asarray(table["ok"], dtype=bool)
    mu = np.asarray(table["mu_r"], dtype=float)
    keep = ok & np.isfinite(mu) & np.isfinite(t)
    t0 = float(t_start[keep][0]) if keep.any() else float("nan")
    if res.params.get("rectified") and st is not None and len(st.get("direction", [])):
        # Each cycle: the mean of its forward and backward gated windows' means (as the headline, 6e).
        acq = np.asarray(table["acquisition"], dtype=np.int64)[keep]
        d = np.asarray(st["direction"], dtype=np.int64)[acq]
        cyc = np.asarray(st["cycle"], dtype=np.int64)[acq]
        tt, vv = t[keep], mu[keep]
        tc: List[float] = []
        vc: List[float] = []
        for c in np.unique(cyc):
            fw, bw = vv[(cyc == c) & (d == 1)], vv[(cyc == c) & (d == -1)]
            if fw.size and bw.size:
                tc.append(float(np.mean(tt[cyc == c])))
                vc.append(0.5 * (float(fw.mean()) + float(bw.mean())))
        return np.asarray(tc), np.asarray(vc), t0, head.method, "per-cycle mean of the forward and backward mu_r"
    return t[keep], mu[keep], t0, head.method, "mu_r of the gated windows"


def steady_state(res: "Results", *, n_boot: int = N_BOOT, seed: int = 0) -> SteadyState:
    """Where the running-in of ``res`` ends, and its steady-state COF (docs/method.md 6h).

    Parameters
    ----------
    res : Results
        An analysis (:func:`tribodyn.analyze`). The series is the headline's (docs/method.md 6e): mu_r of
        the gated windows ("dynamic"), ``mu_classical`` per window ("classical") or the per-cycle COF of
        ``res.strokes`` ("per-stroke").
    n_boot : int
        Bootstrap replicates of the intervals (default 400).
    seed : int
        Seed of the bootstrap (results repeat).

    Returns
    -------
    SteadyState
    """
    t, v, t0, method, what = steady_series(res)
    return fit_steady(t, v, t0=t0, n_boot=n_boot, seed=seed, method=method, series=what)


def steady_states(res: "Results", *, n_boot: int = N_BOOT, seed: int = 0) -> Tuple[SteadyState, ...]:
    """One running-in per test or step of a recording that holds several (docs/method.md 6h).

    A recording of separate acquisitions (a file whose time restarts at each test, a multi-step export's
    steps, LVM segments: the table's ``acquisition`` column) gets :func:`steady_state`'s fit for each, from
    its own first window (t0) on; a recording of one acquisition (or of strokes, whose acquisitions are
    strokes) gets its one fit. Each fit's ``series`` names its acquisition.
    """
    t, v, t0, method, what = steady_series(res)
    spans = _acquisition_spans(res)
    if method == "per-stroke" or res.params.get("rectified") or len(spans) < 2:
        return (fit_steady(t, v, t0=t0, n_boot=n_boot, seed=seed, method=method, series=what),)
    starts = np.array([a for _, a, _ in spans])
    where = np.searchsorted(starts, t, side="right") - 1
    out = []
    for k, (acq, a, _b) in enumerate(spans):
        sel = where == k
        out.append(fit_steady(t[sel], v[sel], t0=a, n_boot=n_boot, seed=seed, method=method,
                              series=f"{what}, acquisition {acq}"))  # fmt: skip
    return tuple(out)


def _acquisition_spans(res: "Results") -> List[Tuple[int, float, float]]:
    """(acquisition, first window's start, last window's end) of each acquisition in the table, in time order."""
    table = res.table
    if "acquisition" not in table or not len(table["acquisition"]):
        return []
    acq = np.asarray(table["acquisition"], dtype=np.int64)
    t_start = np.asarray(table.get("t_start", table["time"]), dtype=float)
    t_end = t_start + float(res.params.get("window", 0.0) or 0.0)
    spans = [(int(a), float(t_start[acq == a].min()), float(t_end[acq == a].max())) for a in np.unique(acq)]
    return sorted(spans, key=lambda s: s[1])


# -- the fit ----------------------------------------------------------------------------


def _shapes(t: np.ndarray, t0: float, ts: np.ndarray, family: int) -> np.ndarray:
    """The transient's shape g(t) (1 at t0, DELTA at ``ts``), shape ``ts.shape + t.shape``: exponential or linear."""
    dt = np.maximum(ts - t0, 1e-300)[..., None]
    if family == 0:
        return np.asarray(np.exp(-np.maximum(t - t0, 0.0) * _LN / dt))
    c = t0 + dt / (1.0 - DELTA)  # the ramp ends at c; 2 % of it is left at ts
    return np.asarray(np.maximum(c - t, 0.0) / (c - t0))


def _ls(yc: np.ndarray, g: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """(residual sum of squares, amplitude) of the centred rows ``yc`` (B, n) on the shapes ``g`` (B or 1, K, n)."""
    gc = g - g.mean(axis=-1, keepdims=True)
    css = np.einsum("bkn,bkn->bk", gc, gc)
    # a shape (almost) constant over the points fits nothing: never chosen
    css = np.where(css > 1e-10 * g.shape[-1], css, np.inf)
    cgy = np.einsum("bkn,bn->bk", gc, yc) if gc.shape[0] == yc.shape[0] else yc @ gc[0].T
    cyy = np.einsum("bn,bn->b", yc, yc)[:, None]
    return cyy - cgy * cgy / css, cgy / css


def _grid(t: np.ndarray, t0: float) -> np.ndarray:
    """Candidate t_steady: from t0 to the last point every quarter spacing (at most 400), then to 3 spans coarsely."""
    span = float(t[-1] - t0)
    dt = float(np.median(np.diff(t)))
    h = max(dt / 4.0, span / 400.0)
    fine = t0 + h * np.arange(1, int(span / h) + 2)
    coarse = t0 + span * np.linspace(1.0, 3.0, 41)[1:]
    return np.concatenate([fine, coarse])


def _lag1(r: np.ndarray, p: int) -> np.ndarray:
    """Lag-1 autocorrelation of each row of the residuals ``r`` of a ``p``-parameter fit, bias-corrected.

    The sample value is low by about (1 + 3 rho) / n (Kendall) and by p / n more for the fitted
    parameters; corrected and clipped to 0..0.95 (docs/method.md 6h).
    """
    n = r.shape[-1]
    rc = r - r.mean(axis=-1, keepdims=True)
    den = np.einsum("...n,...n->...", rc, rc)
    num = np.einsum("...n,...n->...", rc[..., 1:], rc[..., :-1])
    with np.errstate(invalid="ignore", divide="ignore"):
        rho = np.where(den > 0, num / den, 0.0)
    return np.asarray(np.clip(rho + (1.0 + 3.0 * np.maximum(rho, 0.0) + p) / n, 0.0, 0.95))


@dataclass(frozen=True)
class _Fits:
    """Per row of Y: model code (0 flat, 1 exponential, 2 linear), t_steady, level m, amplitude, fitted, rho."""

    code: np.ndarray
    ts: np.ndarray
    m: np.ndarray
    amp: np.ndarray
    fitted: np.ndarray
    rho: np.ndarray


def _noise_rho(Y: np.ndarray, t: np.ndarray, shapes: np.ndarray) -> np.ndarray:
    """The lag-1 autocorrelation of the noise of each row of ``Y``: from the residuals of the best transient
    plus a straight line (so that a drift the models lack does not pass for autocorrelation)."""
    q, _ = np.linalg.qr(np.stack([np.ones(t.size), t - t.mean()]).T)
    yd = Y - (Y @ q) @ q.T
    best = np.full(Y.shape[0], np.inf)
    resid = yd
    for f in (0, 1):
        gd = shapes[f] - (shapes[f] @ q) @ q.T
        gg = np.einsum("gn,gn->g", gd, gd)
        gg = np.where(gg > 1e-10 * t.size, gg, np.inf)
        cgy = yd @ gd.T
        rss = np.einsum("bn,bn->b", yd, yd)[:, None] - cgy * cgy / gg
        g = np.argmin(rss, axis=1)
        r = rss[np.arange(Y.shape[0]), g]
        better = r < best
        best = np.where(better, r, best)
        fit = (cgy[np.arange(Y.shape[0]), g] / gg[g])[:, None] * gd[g]
        resid = np.where(better[:, None], yd - fit, resid)
    return _lag1(resid, 4)


def _fit_rows(Y: np.ndarray, t: np.ndarray, t0: float, grid: np.ndarray, shapes: np.ndarray) -> _Fits:
    """The three models fitted to each row of ``Y`` and the F-test choice (docs/method.md 6h).

    ``shapes`` (2, G, n) are both transient shapes on ``grid``; the best grid point of each row is refined
    on 41 points between its neighbours. The test's autocorrelation is the noise's (:func:`_noise_rho`).
    """
    b, n = Y.shape
    ym = Y.mean(axis=1)
    yc = Y - ym[:, None]
    rows = np.arange(b)
    best = np.full(b, np.inf)
    fam = np.zeros(b, dtype=np.int64)
    ts = np.full(b, t0)
    amp = np.zeros(b)
    for f in (0, 1):
        rss, _ = _ls(yc, shapes[f][None])
        g = np.argmin(rss, axis=1)
        lo = grid[np.maximum(g - 1, 0)]
        lo = np.where(g == 0, t0 + 0.25 * (grid[0] - t0), lo)
        hi = grid[np.minimum(g + 1, grid.size - 1)]
        fine = lo[:, None] + (hi - lo)[:, None] * np.linspace(0.0, 1.0, 41)[None, :]
        rss_f, amp_f = _ls(yc, _shapes(t, t0, fine, f))
        k = np.argmin(rss_f, axis=1)
        r = rss_f[rows, k]
        better = r < best
        best = np.where(better, r, best)
        fam = np.where(better, f, fam)
        ts = np.where(better, fine[rows, k], ts)
        amp = np.where(better, amp_f[rows, k], amp)
    g_best = np.where((fam == 0)[:, None], _shapes(t, t0, ts, 0), _shapes(t, t0, ts, 1))
    m = ym - amp * g_best.mean(axis=1)
    fitted = m[:, None] + amp[:, None] * g_best
    rho = _noise_rho(Y, t, shapes)
    cyy = np.einsum("bn,bn->b", yc, yc)
    with np.errstate(divide="ignore", invalid="ignore"):
        fstat = (cyy - best) / 2.0 / (np.maximum(best, 1e-300) / (n - 3.0)) * (1.0 - rho) / (1.0 + rho)
    transient = np.isfinite(best) & (fstat > f_ppf(1.0 - ALPHA_MODEL, 2, _df(n, rho, 3)))
    return _Fits(
        code=np.where(transient, fam + 1, 0),
        ts=np.where(transient, ts, t0),
        m=np.where(transient, m, ym),
        amp=np.where(transient, amp, 0.0),
        fitted=np.where(transient[:, None], fitted, ym[:, None]),
        rho=np.where(transient, rho, _lag1(yc, 1)),
    )


def _df(n: int, rho: Any, p: int) -> Any:
    """Degrees of freedom of a residual variance from ``n`` AR(1) points (Bartlett: n (1 - rho^2) / (1 + rho^2)) less
    the ``p`` fitted parameters, at least 1."""
    r2 = np.square(rho)
    return np.maximum(n * (1.0 - r2) / (1.0 + r2) - p, 1.0)


def _average(t: np.ndarray, y: np.ndarray, most: int) -> Tuple[np.ndarray, np.ndarray]:
    """Means of consecutive groups of points, at most ``most`` of them."""
    k = math.ceil(t.size / most)
    edges = np.arange(0, t.size, k)
    cnt = np.diff(np.r_[edges, t.size])
    return np.add.reduceat(t, edges) / cnt, np.add.reduceat(y, edges) / cnt


def _ar1_noise(r: np.ndarray, rho: float, p: int, n_boot: int, seed: int) -> np.ndarray:
    """(n_boot, n) AR(1) series like the residuals ``r`` of a ``p``-parameter fit (docs/method.md 6h).

    Autocorrelation ``rho`` (bias-corrected), innovations resampled from the residuals' own, scaled so
    that the series' variance is the residuals' mean square times n_eff / (n_eff - p).
    """
    n = r.size
    rc = r - r.mean()
    innov = rc[1:] - rho * rc[:-1]
    innov = innov - innov.mean()
    sd = float(innov.std())
    n_eff = max(n * (1.0 - rho) / (1.0 + rho), p + 2.0)
    var = float(rc @ rc) / n * n_eff / (n_eff - p)
    innov = innov / sd * math.sqrt(var * (1.0 - rho * rho)) if sd > 0 else np.zeros(n - 1)
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 14]))
    burn = min(200, max(20, math.ceil(10.0 / max(1e-3, -math.log(max(rho, 1e-12))))))
    e = innov[rng.integers(0, innov.size, size=(n_boot, n + burn))]
    x = np.zeros((n_boot, n + burn))
    x[:, 0] = e[:, 0] / math.sqrt(max(1.0 - rho * rho, 1e-12))
    for k in range(1, n + burn):
        x[:, k] = rho * x[:, k - 1] + e[:, k]
    return x[:, burn:]


def _drift(t: np.ndarray, r: np.ndarray) -> Tuple[float, float]:
    """(slope, p-value) of the residuals ``r`` on ``t``: OLS, its variance times (1 + rho) / (1 - rho)."""
    n = t.size
    tc = t - t.mean()
    stt = float(tc @ tc)
    if n < 4 or stt <= 0:
        return float("nan"), float("nan")
    b = float(tc @ (r - r.mean())) / stt
    e = r - r.mean() - b * tc
    rho = float(_lag1(e[None, :], 2)[0])
    se = math.sqrt(float(e @ e) / (n - 2) / stt * (1.0 + rho) / (1.0 - rho))
    if se <= 0:
        return b, 0.0 if b != 0 else 1.0
    return b, float(2.0 * t_sf(abs(b) / se, float(_df(n, rho, 2))))


def fit_steady(
    time: Any,
    cof: Any,
    *,
    t0: Optional[float] = None,
    n_boot: int = N_BOOT,
    seed: int = 0,
    method: str = "",
    series: str = "COF series",
) -> SteadyState:
    """:func:`steady_state` of a COF series ``cof`` at ``time`` (s) that starts at ``t0`` (default: the first time).

    Non-finite points are dropped and the rest taken in time order (docs/method.md 6h).
    """
    if int(n_boot) < 50:
        raise ValueError(f"n_boot must be at least 50, got {n_boot!r}")
    n_boot = int(n_boot)
    t, y = _in_time_order(time, cof)
    nan = float("nan")
    start = float(t0) if t0 is not None and math.isfinite(t0) else (float(t[0]) if t.size else nan)
    if t.size and start > t[0]:
        start = float(t[0])
    interval = (f"t_steady: the {n_boot} bootstrap refits' percentiles at Phi(-+t(0.975, df)); the steady COF: "
                "estimate +- t(0.975, df) x their standard deviation (the refits: the fit plus AR(1) noise like its "
                "residuals, docs/method.md 6h)")  # fmt: skip
    common: Dict[str, Any] = dict(method=method, series=series, interval=interval, time=t, values=y)
    if t.size < MIN_POINTS or not t[-1] > start:
        why = f"{t.size} point{'s' if t.size != 1 else ''} of the {series}, at least {MIN_POINTS} needed"
        return SteadyState(VERDICTS[2], nan, nan, nan, nan, nan, nan, nan, model="", n=int(t.size), n_steady=0,
                           t0=start, t_end=float(t[-1]) if t.size else nan, reasons=(why,),
                           fitted=np.full(t.size, nan), **common)  # fmt: skip
    averaged = ""
    if t.size > MAX_POINTS:
        averaged = f" (its {t.size} points averaged in groups of {math.ceil(t.size / MAX_POINTS)})"
        t, y = _average(t, y, MAX_POINTS)
        common.update(time=t, values=y)
    n = t.size
    grid = _grid(t, start)
    shapes = np.stack([_shapes(t, start, grid, 0), _shapes(t, start, grid, 1)])
    fit = _fit_rows(y[None, :], t, start, grid, shapes)
    code, ts, m = int(fit.code[0]), float(fit.ts[0]), float(fit.m[0])
    fitted = fit.fitted[0]
    resid = y - fitted
    rho = float(fit.rho[0])
    p = 3 if code else 1
    model = MODELS[code]
    tau = (ts - start) / _LN if code == 1 else nan
    # the bootstrap: the chosen fit plus AR(1) noise like its residuals, refitted with the model choice
    noise = _ar1_noise(resid, rho, p, n_boot, seed)
    ts_b, cof_b = _refits(fitted + noise, t, start, grid, shapes)
    tq = float(t_ppf(0.975, float(_df(n, rho, p))))
    steady = t >= ts
    n_steady = int(steady.sum())
    drift, drift_p = _drift(t[steady], resid[steady]) if n_steady >= MIN_STEADY_POINTS else (nan, nan)
    cof_mean = float((resid + m)[steady].mean()) if n_steady else nan
    t_lo, t_hi = _percentiles(ts_b, ts, tq, start)
    reasons, drift, drift_p = _why_not_steady(t, resid, ts, _Steady(model, t_hi - ts, cof_mean), drift=(drift, drift_p))
    estimate = (f"least-squares fit of the {series}{averaged} from t0 = {start:.4g} s: {_model_text(code, tau)}; the "
                f"steady COF is the mean of the {n_steady} points at or after t_steady less the fitted transient's "
                "tail")  # fmt: skip
    common.update(model=model, n=n, n_steady=n_steady, t0=start, t_end=float(t[-1]), tau=tau, drift=drift,
                  drift_p=drift_p, estimate=estimate, fitted=fitted, cof_initial=m + float(fit.amp[0]))  # fmt: skip
    if reasons:
        return SteadyState(VERDICTS[1], nan, nan, nan, nan, nan, nan, reasons=tuple(reasons), **common)
    fin = cof_b[np.isfinite(cof_b)]
    c_half = tq * float(np.std(fin, ddof=1)) if fin.size > 1 else nan
    return SteadyState(VERDICTS[0], ts, t_lo, t_hi, cof_mean, cof_mean - c_half, cof_mean + c_half,
                       **common)  # fmt: skip


def _percentiles(ts_b: np.ndarray, ts: float, tq: float, start: float) -> Tuple[float, float]:
    """t_steady's interval: the replicates' expanded percentiles, the levels Phi(-tq) and Phi(tq) (the percentile
    interval widened for the fit's degrees of freedom, as Sec. 3d's bootstrap), holding the estimate and not
    before t0 (docs/method.md 6h). The replicates' distribution is skewed where the COF's wander hides the
    transient's tail: a symmetric interval covered 0.90 there, these 0.96."""
    fin = ts_b[np.isfinite(ts_b)]
    if fin.size < 2:
        return float("nan"), float("nan")
    a = 0.5 * math.erfc(tq / math.sqrt(2.0))
    lo, hi = (float(v) for v in np.quantile(fin, [a, 1.0 - a]))
    return max(start, min(lo, ts)), max(hi, ts)


def _in_time_order(time: Any, cof: Any) -> Tuple[np.ndarray, np.ndarray]:
    """The finite points of the series (time, COF), in time order (a stable sort: ties keep their order)."""
    t_all = np.asarray(time, dtype=float).ravel()
    y_all = np.asarray(cof, dtype=float).ravel()
    if t_all.shape != y_all.shape:
        raise ValueError(f"time and cof differ in length ({t_all.size} and {y_all.size})")
    keep = np.isfinite(t_all) & np.isfinite(y_all)
    order = np.argsort(t_all[keep], kind="stable")
    return t_all[keep][order], y_all[keep][order]


def _refits(
    Y_all: np.ndarray, t: np.ndarray, start: float, grid: np.ndarray, shapes: np.ndarray
) -> Tuple[np.ndarray, np.ndarray]:
    """Each bootstrap series (a row of ``Y_all``: the chosen fit plus AR(1) noise) refitted with the model choice:
    its t_steady and its steady COF (the mean of its points from t_steady on, less the fitted transient's tail)."""
    n_boot = Y_all.shape[0]
    ts_b = np.empty(n_boot)
    cof_b = np.empty(n_boot)
    for a in range(0, n_boot, 50):  # in slices: memory (50 x 41 x n) whatever n_boot
        Y = Y_all[a : a + 50]
        fb = _fit_rows(Y, t, start, grid, shapes)
        ts_b[a : a + 50] = fb.ts
        after = t[None, :] >= fb.ts[:, None]
        level = Y - fb.fitted + fb.m[:, None]  # the points less the fitted transient's tail
        with np.errstate(invalid="ignore", divide="ignore"):
            cof_b[a : a + 50] = (level * after).sum(axis=1) / after.sum(axis=1)
    return ts_b, cof_b


@dataclass(frozen=True)
class _Steady:
    """What the fit found: its model's name, the half-width of t_steady's interval and the steady COF."""

    model: str
    t_half: float  # the upper end of t_steady's interval less t_steady
    cof_mean: float


def _why_not_steady(
    t: np.ndarray, resid: np.ndarray, ts: float, found: _Steady, *, drift: Tuple[float, float]
) -> Tuple[List[str], float, float]:
    """Why the series has no steady state (none: it has one), with the drift (slope, p-value) to report.

    Too few points after t_steady, t_steady's interval reaching the last
    point, or a drift of the residuals after t_steady (over the steady part
    or its last half) beyond :data:`DRIFT_TOLERANCE` of the COF
    (docs/method.md 6h); ``drift`` is the steady part's, kept unless a drift
    is the reason.
    """
    n = t.size
    steady = t >= ts
    n_steady = int(steady.sum())
    need = max(MIN_STEADY_POINTS, math.ceil(MIN_STEADY_FRACTION * n))
    reasons: List[str] = []
    if n_steady < need:
        reasons.append(f"the fitted running-in ({found.model} model) ends at t = {ts:.4g} s, leaving {n_steady} of "
                       f"{n} points after it (at least {need}, a fifth, needed)")  # fmt: skip
    elif ts + found.t_half >= t[-1]:
        reasons.append(f"the fitted running-in ends at t = {ts:.4g} s but its 95 % interval reaches the last "
                       f"point ({t[-1]:.4g} s)")  # fmt: skip
    else:
        span = float(t[-1] - ts)
        late = steady & (t >= ts + 0.5 * span)
        cof_mean = found.cof_mean
        for where, sel in (("the steady part", steady), ("its last half", late)):
            b, pv = _drift(t[sel], resid[sel])
            if pv < ALPHA_DRIFT / 2 and abs(b) * span > DRIFT_TOLERANCE * abs(cof_mean):
                reasons.append(f"the COF still drifts after t = {ts:.4g} s: {b:+.3g} per s over {where}, "
                               f"{100 * abs(b) * span / abs(cof_mean):.1f} % of the COF over the steady part "
                               f"(p = {pv:.2g})")  # fmt: skip
                return reasons, b, pv
    return reasons, drift[0], drift[1]


def _model_text(code: int, tau: float) -> str:
    """The chosen model in words (``code``: 0 flat, 1 exponential, 2 linear; ``tau`` the exponential's)."""
    return {0: "the flat model (no running-in) beats both transient models",
            1: f"exponential approach to a plateau, tau = {tau:.4g} s, t_steady = t0 + tau ln 50",
            2: "a linear ramp to a plateau, t_steady where 2 % of the ramp is left"}[code]  # fmt: skip
