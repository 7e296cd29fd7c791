"""The finishing step of :func:`tribodyn.analyze`: the kernel's statistics as a table (docs/method.md 0, 3-7).

:func:`finish` fixes the orientation once for the recording, computes each
window's mu_r by the plan's estimator with its interval (docs/method.md
3a-3e), applies the gate (5), joins the covariates (6, 7a) and lays the
table out as :data:`tribodyn.columns.TABLE` declares it. :func:`settle`
then adds the headline's sums and keeps the warnings of the method in use
(6e).
"""

from __future__ import annotations

from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..columns import TABLE
from ..kernels._validate import resolve_orientation
from ..kernels.contact_loss import mark_contact_loss
from ..kernels.estimators import (  # fmt: skip
    PRODUCTS,
    T975,
    WEAK_INSTRUMENT,
    Slopes,
    Sums,
    gate_precision,
    line_stats,
    pooled_noise,
    quadratic,
    reverse_slope,
    slopes,
    window_noise,
)
from ..kernels.quantiles import Z975
from ..kernels.window_stats import gate_reasons, orient
from ..results import ClassicalTotals, Results
from ..results.headline import instrument_check
from .covariates import branch, coverage_notes, log_quality, sweep_notes, window_mean
from .plan import Covariates, Findings, Plan

__all__ = ["finish", "settle", "sign_of_total_slope", "WEAK_INSTRUMENT", "ALIGN_MIN"]

Stats = Dict[str, np.ndarray]


def settle(res: Results, classical: Optional[Callable[[], Optional[ClassicalTotals]]] = None) -> Results:
    """The results with their headline's sums and the warnings of the method in use (docs/method.md 6e).

    ``classical`` reads the classical COF's sums over the whole recording;
    it is called only when the verdict makes the classical COF the headline
    (a recording whose headline is the dynamic COF is not read again). The
    dynamic estimator's notes (``params["dynamic_notes"]``) are dropped
    when the headline is not the dynamic COF; a difference of the
    instrument's COF from the headline over 0.5 % is explained in a warning.
    """
    v = res.verdict
    if classical is not None and res.classical is None and not v["dynamic_method"] and v["motion"] != "reciprocating":
        res = res.replace(keep=("verdict", "mu_r_ci", "column_ci"), classical=classical())  # the verdict's own
    head = res.headline
    notes = set(res.params.get("dynamic_notes") or ())
    kept = [w for w in res.warnings if head.method == "dynamic" or w not in notes]
    _, more = instrument_check(res, head)
    warnings = tuple(dict.fromkeys((*kept, *more)))
    return res.replace(keep=("headline", "verdict", "mu_r_ci", "column_ci"), warnings=warnings)  # they do not read them


def _merged(st: Stats, a: str, b: str) -> float:
    """The centred cross-product S_ab of all windows merged (within + between windows; a, b in "z", "y").

    ``st`` holds per-window ``n``, ``mean_z``, ``mean_y`` and the within-window
    sums ``szz``, ``syy``, ``syz``.
    """
    n = np.asarray(st["n"], dtype=float)
    ma, mb = st[f"mean_{a}"], st[f"mean_{b}"]
    within = st["syz"] if {a, b} == {"z", "y"} else st[f"s{a}{b}"]
    if "out_of_range" in st and np.any(st["out_of_range"]):  # NaN moments (docs/method.md 4): left out
        keep = ~np.asarray(st["out_of_range"], dtype=bool)
        n, ma, mb, within = n[keep], ma[keep], mb[keep], within[keep]
    if n.sum() == 0:
        return float("nan")
    w = n / n.sum()
    da = ma - np.sum(w * ma)
    db = mb - np.sum(w * mb)
    return float(np.sum(within) + np.sum(n * da * db))


def sign_of_total_slope(st: Stats) -> float:
    """S_xy of fy on fz of all windows merged (within + between parts): its sign is the slope's.

    ``st`` holds per-window ``n``, ``mean_z``, ``mean_y`` and ``syz``.
    """
    return _merged(st, "z", "y")


def finish(st: Stats, aux_role: Optional[str], plan: Plan, found: Findings, *, route: str = "",
           warnings: Sequence[str] = (), span: Optional[Tuple[int, Optional[int]]] = None) -> Results:  # fmt: skip
    """The kernel's per-window statistics (orientation +1) as a :class:`Results` (docs/method.md 0, 5, 6).

    Fixes the orientation once for all windows, applies the gate, joins the
    covariates and lays the table out as :data:`tribodyn.columns.TABLE`
    declares it. ``st`` is consumed (its arrays are flipped in place).
    ``warnings`` (the reader's) are kept, each once. ``span``: the sample
    range analysed when not the plan's (the ranges of :func:`tribodyn.combine`).
    """
    start, stop = span if span is not None else (plan.start, plan.stop)
    if len(st["n"]) == 0:
        raise _no_window(plan, start, stop)
    fs, cov = plan.fs, plan.covariates
    s = resolve_orientation(plan.orientation, sign_of_total_slope(st))
    moments = {k: np.asarray(st[k], dtype=float) for k in ("n", "mean_z", "mean_y", "syz")}
    confidence = _orientation_confidence(st, s) if plan.orientation == "auto" and not plan.paper else {}
    o = orient(st, s, inplace=True)
    t_start = o["t0"] if "t0" in o else o["start"] / fs
    n_win = np.asarray(o["n"], dtype=np.int64)
    centre = t_start + 0.5 * n_win / fs
    within = (t_start, t_start + n_win / fs)  # each window's samples, each holding 1/fs: the logs' means over it
    seen: Dict[str, Any] = {}
    notes: List[str] = []
    if not plan.paper:  # where the instrument lag comes from (docs/method.md 3b)
        seen["iv_lag_rule"] = _iv_lag_rule(plan, found)
    ext = o.get("ext")  # the chosen lag's instrument sums (_statistics takes the column), for the lags' moves
    stats_cols = _statistics(o, plan, found.delay, s, found=seen, notes=notes, lag=plan.lag(found))
    o.update(stats_cols)
    skew_gate = o.get("skew_lag")
    reasons = gate_reasons(o, plan.gate, skew_gate, rel_ci=stats_cols.get("rel_ci"), max_rel_ci=plan.max_rel_ci)
    if confidence:
        seen.update(confidence)
        if confidence["orientation_agreement"] < 0.9 or abs(confidence["orientation_r"]) < 0.2:
            notes.append(
                f"orientation 'auto' is uncertain: the whole recording's r is {confidence['orientation_r']:+.2f} and "
                f"{100 * confidence['orientation_agreement']:.0f} % of the windows agree with s = {s:+d}; pass "
                "orientation= if you know the sign"
            )
    cur = _current(o, aux_role, cov, within)
    cov_notes: List[str] = []  # not the dynamic method's: kept whichever COF is the headline
    speed, extra = _covariate_columns(o, cov, within, cov_notes)
    logs = {
        "temperature": cov.temperature,
        "current": None if aux_role else cov.current,
        "voltage": None if aux_role else cov.voltage,
        **dict(cov.logs),
    }  # the logs the table reads
    cov_notes += coverage_notes(logs, centre) + sweep_notes(logs, *within)
    reasons = _more_reasons(reasons, o, plan, cur)
    values = _window_values(o, plan, centre=centre, span=within, reasons=reasons, cur=cur, speed=speed,
                            mean_z=moments["mean_z"])  # fmt: skip
    table = {c.name: np.asarray(values[c.name], dtype=c.dtype if c.dtype != "str" else None) for c in TABLE}
    table.update(extra)  # the other covariate logs, after the declared columns (docs/method.md 7a)
    lag_sums = o.pop("lag_sums", None)
    if not plan.paper:  # over the windows the headline uses (docs/method.md 3d)
        gated = np.asarray(table["ok"], dtype=bool) & np.isfinite(np.asarray(table["mu_r"], dtype=float))
        seen.update(_lag_shifts(plan, found, seen, s, ext=ext, lag_sums=lag_sums, gated=gated))
    params = plan.params()
    params.update(orientation_used=s, start=start, stop=stop, threads=plan.threads, route=route)
    params.update(seen)
    params["dynamic_notes"] = list(notes)  # the dynamic method's own notes (settle drops them when it does not apply)
    warnings = list(warnings) + notes + cov_notes
    return Results(
        table=table,
        bin_counts=np.asarray(o["bin_count"], dtype=np.int64),
        bin_cof=o["bin_cof"],
        fz_min=o["fz_min"],
        fz_max=o["fz_max"],
        orientation=s,
        params=params,
        moments=moments,
        warnings=tuple(dict.fromkeys(str(w) for w in warnings)),
    )


def _iv_lag_rule(plan: Plan, found: Findings) -> str:
    """Where the instrument lag comes from (docs/method.md 3b): "data", "default", "rpm" or "given"."""
    fs = plan.fs
    rpm_lag = plan.rpm is not None and plan.iv_lag_samples == int(round(60.0 * fs / float(plan.rpm)))
    return ("data" if found.iv_lag_samples else "default") if plan.iv_lag_from_data else ("rpm" if rpm_lag else "given")


def _lag_shifts(plan: Plan, found: Findings, seen: Dict[str, Any], s: int, *, ext: Optional[np.ndarray],
                lag_sums: Optional[np.ndarray], gated: np.ndarray) -> Dict[str, Any]:  # fmt: skip
    """``iv_lag_shifts``: mu_r's moves at the other lags the choice from the data could not tell from the one used
    (docs/method.md 3d), when mu_r rests on that lag (the IV and the corrected estimator with the fz noise
    measured, not fallen back to least squares); {} otherwise.

    Per extra lag L' (``Plan.extra_lags``), the move is b(L') - b(L) of the pooled IV slopes b = sum S_wy /
    sum S_wz over the ``gated`` windows (the headline's), from the kernel's sums (``ext`` at the lag L,
    ``lag_sums`` at the L'), times the orientation ``s``; its standard error is the batch-means one over
    the windows in time order (:func:`lag_moves`). ``iv_lag_shifts`` are the resolved moves: each shrunk
    towards 0 by its standard error (0 under it). ``iv_lag_moves`` and ``iv_lag_move_se`` keep both.
    """
    others = plan.extra_lags(found)
    if not others or seen.get("iv_lag_rule") != "data" or seen.get("mu_r_bound") == "lower":
        return {}
    if ext is None or lag_sums is None:
        raise RuntimeError("the kernel did not return the instrument sums the plan asked for (ext, lag_sums)")
    moves, se = lag_moves(np.asarray(ext, dtype=float), np.asarray(lag_sums, dtype=float), gated)
    moves = s * moves
    resolved = np.sign(moves) * np.maximum(np.abs(moves) - np.where(np.isfinite(se), se, 0.0), 0.0)
    keep = np.isfinite(moves)
    return {
        "iv_lag_shifts": [float(x) + 0.0 for x in resolved[keep]],  # + 0.0: no -0.0
        "iv_lag_moves": [float(x) for x in moves[keep]],
        "iv_lag_move_se": [float(x) for x in se[keep]],
        "iv_lag_pooled": [int(k) for k, ok in zip(others, keep) if ok],
    }


def lag_moves(ext: np.ndarray, lag_sums: np.ndarray, gated: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """(moves, standard errors) of the pooled IV slope between the chosen lag and each extra lag (docs/method.md 3d).

    ``ext``: the kernel's block sums (windows, BLOCKS, PRODUCTS) at the chosen lag L; ``lag_sums``: (windows, K, 2)
    [S_wz, S_wy] at the K extra lags; ``gated``: the windows used. Per lag L', over the gated windows where
    every sum is finite: b(L') - b(L), b = sum S_wy / sum S_wz, and the batch-means standard error of that
    difference from the windows' influences u_i = (C'_i - b' A'_i) / sum A' - (C_i - b A_i) / sum A summed in
    at most :data:`~tribodyn.kernels.stats.BATCHES` contiguous batches (NaN with fewer than 3).
    """
    from ..kernels.stats import batch_sums

    A0 = ext[:, :, _WZ].sum(axis=1)
    C0 = ext[:, :, _WY].sum(axis=1)
    k = lag_sums.shape[1]
    moves, ses = np.full(k, np.nan), np.full(k, np.nan)
    for j in range(k):
        A1, C1 = lag_sums[:, j, 0], lag_sums[:, j, 1]
        use = gated & np.isfinite(A0) & np.isfinite(C0) & np.isfinite(A1) & np.isfinite(C1)
        if not use.any():
            continue
        a0, c0, a1, c1 = A0[use], C0[use], A1[use], C1[use]
        sa0, sa1 = float(a0.sum()), float(a1.sum())
        if sa0 == 0.0 or sa1 == 0.0:
            continue
        b0, b1 = float(c0.sum()) / sa0, float(c1.sum()) / sa1
        moves[j] = b1 - b0
        u = (c1 - b1 * a1) / sa1 - (c0 - b0 * a0) / sa0
        g = batch_sums(u)
        if g.size >= 3:
            ses[j] = float(np.sqrt(g.size / (g.size - 1) * np.sum(g * g)))
    return moves, ses


#: The products S_wz and S_wy of the kernel's block sums.
_WZ, _WY = PRODUCTS.index("wz"), PRODUCTS.index("wy")


def _more_reasons(reasons: np.ndarray, o: Stats, plan: Plan, cur: np.ndarray) -> np.ndarray:
    """The gate's reasons with a stroke reversal (docs/method.md 6c) and contact loss (docs/method.md 7) added."""
    cov = plan.covariates
    if "stroke_reversal" in o and np.any(o["stroke_reversal"]):  # docs/method.md 6c
        reasons = np.asarray(reasons, dtype=object).copy()
        for k in np.flatnonzero(o["stroke_reversal"]):
            reasons[k] = "; ".join(r for r in (reasons[k], "stroke reversal in the window") if r)
    if not plan.paper:  # the paper's preset keeps the paper's gate exactly
        reasons = mark_contact_loss(reasons, o, cur / cov.area_mm2 if cov.area_mm2 is not None else cur)  # method.md 7
    return reasons


def _window_values(o: Stats, plan: Plan, *, centre: np.ndarray, span: Tuple[np.ndarray, np.ndarray],
                   reasons: np.ndarray, cur: np.ndarray, speed: np.ndarray, mean_z: np.ndarray) -> Stats:  # fmt: skip
    """Every per-window column by name: the kernel's and the statistics' (``o``), time, the gate's verdict, the
    covariates and what the kernel did not compute as NaN (:data:`tribodyn.columns.TABLE` picks them)."""
    cov = plan.covariates
    log = cov.temperature

    def nan() -> np.ndarray:  # a fresh column each time: no two table columns share memory
        return np.full(len(centre), np.nan)

    return {
        **o,
        "time": centre,
        "t_start": span[0],
        "skew": o["skew"] if "skew" in o else nan(),
        "h1_f0": o.get("h1_f0", nan()),
        "h1_fl": o.get("h1_fl", nan()),
        "coherence_fl": o.get("coherence_fl", nan()),
        "ok": np.asarray(reasons == "", dtype=bool),
        "reasons": reasons.astype(str),
        "T": window_mean(log, *span) if log is not None else nan(),  # the mean over the window (7a)
        "branch": branch(log, centre) if log is not None else np.zeros(len(centre), dtype=np.int8),
        **log_quality(log, centre),  # T_uncertainty, T_gap (docs/method.md 6)
        "i": cur,
        "J": cur / cov.area_mm2 if cov.area_mm2 is not None else nan(),
        "speed": speed,
        "mu_instrument": o["mu_instrument"] if "mu_instrument" in o else nan(),
        # one classical column (docs/method.md 6a): the contact rule's; the paper's Sec. 5 mean over fz != 0 of
        # the raw forces with method="paper" or without a contact rule (highpass on a fz with no static level)
        "mu_classical": o["mu_classic"]
        if "mu_classic" in o and (plan.paper or "mu_classical" not in o)
        else o.get("mu_classical", nan()),
        "mu_classical_median": o["mu_classical_median"] if "mu_classical_median" in o else nan(),
        "fz_mean": o["fz_mean"] if "fz_mean" in o else (nan() if plan.raw else np.asarray(mean_z)),
        "fz_std": o["fz_std"] if "fz_std" in o else _fz_std(o, plan),
        "n": np.asarray(o["n"], dtype=np.int64),
        "acquisition": o.get("acquisition", np.zeros(len(centre), dtype=np.int64)),
    }


def _no_window(plan: Plan, start: int, stop: Optional[int]) -> ValueError:
    """The error of an analysis that holds no whole window."""
    w = plan.window
    if stop is not None:
        return ValueError(
            f"samples {start}..{stop} hold no whole window ({w:g} s = {plan.length} samples, "
            f"starting every {plan.step} samples from sample 0): no window to analyse"
        )
    return ValueError(
        f"the recording is shorter than one window ({w:g} s = {plan.length} samples): no window to analyse"
    )


def _current(o: Stats, aux_role: Optional[str], cov: Covariates, span: Tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """The current at each window (A): the source's i or u channel, else its log (docs/method.md 6)."""
    if aux_role == "i":
        return np.asarray(o["aux_mean"])
    if aux_role == "u":
        return np.asarray(o["aux_mean"] / float(cov.shunt_ohm or np.nan))
    if cov.current is not None:
        return window_mean(cov.current, *span)
    if cov.voltage is not None:
        return np.asarray(window_mean(cov.voltage, *span) / float(cov.shunt_ohm or np.nan))
    return np.full(len(span[0]), np.nan)


def _covariate_columns(o: Stats, cov: Any, span: Tuple[np.ndarray, np.ndarray], notes: List[str]
                       ) -> Tuple[np.ndarray, Dict[str, np.ndarray]]:  # fmt: skip
    """The ``speed`` column and the other covariate logs' columns at the window centres (docs/method.md 7a).

    The speed is the kernel's mean |v| of a velocity channel, unless a speed
    log is given: that log's magnitude then (said in a note when both exist).
    """
    logs = dict(cov.logs)
    speed = np.asarray(o["speed"], dtype=float) if "speed" in o else np.full(len(span[0]), np.nan)
    if "speed" in logs:
        if "speed" in o:
            notes.append("the speed log given replaces the mean |v| of the velocity channel v in the speed column")
        t, v = logs.pop("speed")
        speed = window_mean((t, np.abs(v)), *span)  # the mean |v| over the window, as the kernel's of a channel
    return speed, {name: window_mean(log, *span) for name, log in logs.items()}


#: A recording-wide fz delay (samples) above which align="auto" corrects it
#: and align=None warns (docs/method.md 3e).
ALIGN_MIN = 0.05


def _statistics(o: Stats, plan: Plan, delay0: float, s: int, *, found: Dict[str, Any], notes: List[str],
                lag: Optional[int] = None) -> Stats:  # fmt: skip
    """mu_r by the plan's estimator, its interval, the force dependence and the line statistics (docs/method.md 3a-3e).

    ``o`` holds the oriented kernel statistics (``mu_r`` = s * OLS slope);
    returns the columns that replace or join them. ``found`` gets what the
    recording revealed (for ``params``), ``notes`` the warnings; ``delay0`` is
    the fz delay already corrected in every window (``align="auto"``); ``lag``
    the instrument lag of the kernel's sums (default ``plan.iv_lag_samples``).

    When the noise on fz cannot be measured (no valid instrument) and the
    estimator falls back to least squares, that slope is a lower bound of
    |mu|: each window's interval then reaches up to the reverse regression's
    slope (``mu_r_high``), and ``params["mu_r_bound"] = "lower"`` with
    ``params["attenuation_gap"]`` (median over windows of the reverse minus
    the least-squares slope) widen the summary's and the headline's
    intervals (docs/method.md 3b, 3d).
    """
    lag = plan.iv_lag_samples if lag is None else int(lag)

    mu_ols = np.array(o["mu_r"], dtype=float)
    if plan.paper:
        return _paper_statistics(o, mu_ols)
    E = Sums(o.pop("ext"))
    n = np.asarray(o["n"])
    found["iv_lag_samples"] = lag
    sl, bound = _slopes(E, n, plan, lag, found=found, notes=notes)
    mu = s * sl.slope
    se = sl.se
    a2, a2_se = quadratic(E, n, instrumented=plan.estimator != "ols")
    rel, found["gate_se_ratio"], found["gate_cof"] = gate_precision(mu, se, sl.se_white)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = {
            "mu_r": mu,
            "mu_r_stderr": se,
            "noise_z_var": window_noise(E, n),
            "mu_r_dnoise": s * sl.dnoise,
            "mu_r_low": mu - T975 * se,
            "mu_r_high": mu + T975 * se,
            "mu_ols": mu_ols,
            "attenuation_p": sl.attenuation_p,
            "dmu_dfn": s * a2,
            "dmu_dfn_stderr": a2_se,
            "dmu_dfn_low": s * a2 - T975 * a2_se,
            "dmu_dfn_high": s * a2 + T975 * a2_se,
            "f_y0": o["mean_y"] - sl.slope * o["mean_z"],
            "force_dependence": (o["mu_b"] - o["mu_a"]) / mu,
            "rel_ci": rel,
        }
    if bound:  # least squares, attenuated by the noise on fz: up to the reverse regression (docs/method.md 3d)
        _lower_bound(E, s, out, found)
    if "skew" in o:
        out["skew_lag"] = o["skew"]
    if "spec" in o:
        _line_columns(o.pop("spec"), plan, s, delay0, out=out, found=found, notes=notes)
    return out


def _paper_statistics(o: Stats, mu_ols: np.ndarray) -> Stats:
    """The paper's preset: the least-squares slope with its normal interval, none of the later statistics."""
    k = len(o["n"])
    se = np.asarray(o["mu_r_stderr"], dtype=float)
    out: Stats = {"mu_ols": mu_ols, "mu_r_low": mu_ols - Z975 * se, "mu_r_high": mu_ols + Z975 * se}
    for name in ("attenuation_p", "dmu_dfn", "dmu_dfn_stderr", "dmu_dfn_low", "dmu_dfn_high"):
        out[name] = np.full(k, np.nan)
    out["noise_z_var"] = np.full(k, np.nan)
    out["mu_r_dnoise"] = np.zeros(k)  # OLS shares no estimate between windows
    if "skew" in o:
        out["skew_lag"] = o["skew"]
    return out


def _slopes(E: Sums, n: np.ndarray, plan: Plan, lag: int, *, found: Dict[str, Any], notes: List[str]
            ) -> Tuple[Slopes, bool]:  # fmt: skip
    """The slopes by the plan's estimator, and whether they fell back to least squares (a lower bound of |mu|).

    The corrected estimator measures the noise on fz (pooled over windows)
    with the instrument, fz lagged by ``lag``; when that cannot be measured
    (windows too short for the lag, or a weak instrument) the slopes are
    least squares, said in ``notes`` (docs/method.md 3b).
    """
    pooled = None
    bound = False  # the fallback to least squares: mu_r is a lower bound of |mu| (docs/method.md 3b)
    if plan.estimator == "corrected" and plan.noise is None:
        pooled = pooled_noise(E, n)
        if not np.isfinite(pooled[0]):
            notes.append(
                f"the noise on fz could not be measured (instrument lag {lag} samples needs windows longer "
                "than twice it): mu_r is the least-squares slope, a lower bound; pass iv_lag= or noise="
            )
            pooled = (0.0, 0.0)
            bound = True
        found["noise_z_std"] = float(np.sqrt(pooled[0]))
    sl = slopes(E, n, plan.estimator, noise=plan.noise, pooled=pooled)
    r_inst = sl.instrument_r[np.isfinite(sl.instrument_r)]
    found["instrument_r"] = float(np.median(r_inst)) if r_inst.size else float("nan")
    weak = bool(r_inst.size) and abs(found["instrument_r"]) < WEAK_INSTRUMENT
    if weak and pooled is not None and pooled != (0.0, 0.0):
        # A weak instrument cannot measure the noise on fz: least squares, said so.
        pooled = (0.0, 0.0)
        found["noise_z_std"] = 0.0
        sl = slopes(E, n, plan.estimator, noise=plan.noise, pooled=pooled)
        bound = True
        notes.append(
            f"the noise on fz could not be measured: the instrument (fz lagged by {lag} samples) is weak "
            f"(median r = {found['instrument_r']:.2f}), so mu_r is the least-squares slope, a lower bound (its "
            "intervals reach up to the reverse regression's slope); pass rpm= (a lag of one revolution), iv_lag= "
            "or noise= (docs/method.md 3b)"
        )
    elif weak and plan.estimator == "iv":
        notes.append(
            f"the instrument (fz lagged by {lag} samples) is weak: median r = {found['instrument_r']:.2f}; "
            "IV slopes are imprecise; pass rpm= (a lag of one revolution) or iv_lag= (docs/method.md 3b)"
        )
    return sl, bound


def _line_columns(spec: np.ndarray, plan: Plan, s: int, delay0: float, *, out: Stats, found: Dict[str, Any],
                  notes: List[str]) -> None:  # fmt: skip
    """The line statistics into ``out`` (the fz delay, H1 at f0 and fl, coherence at fl); ``found`` gets the median
    delay, and ``notes`` says when an uncorrected delay biases mu_r (docs/method.md 3e)."""
    ls = line_stats(spec, plan.lines, s)
    index = dict(plan.line_index)
    out["skew"] = ls["skew"]
    if "f0" in index:
        out["h1_f0"] = ls["h1"][:, index["f0"]]
    if "fl" in index:
        out["h1_fl"] = ls["h1"][:, index["fl"]]
        out["coherence_fl"] = ls["coherence"][:, index["fl"]]
    sk = ls["skew"][np.isfinite(ls["skew"])]
    delay = float(np.median(sk)) if sk.size else float("nan")
    found["skew_median"] = delay + delay0 if np.isfinite(delay) else delay
    if plan.align is None and np.isfinite(delay) and abs(delay) > ALIGN_MIN:
        notes.append(
            f"fz lags fy by {delay:+.2f} samples (cross-spectral phase at the rig's lines, median over windows): "
            "mu_r is biased low by it; analyze(..., align='auto') corrects it (docs/method.md 3e)"
        )


def _lower_bound(E: Any, s: int, out: Stats, found: Dict[str, Any]) -> None:
    """Least squares as a lower bound (docs/method.md 3b, 3d): each window's ``mu_r_high`` up to the reverse
    regression's slope plus t_{0.975,4} of its standard error; ``found`` gets ``mu_r_bound`` and the
    median gap between the reverse and the least-squares slope (``attenuation_gap``)."""

    b_rev, se_rev = reverse_slope(E)
    high = s * b_rev + T975 * se_rev
    out["mu_r_high"] = np.where(np.isfinite(high), np.maximum(high, out["mu_r_high"]), out["mu_r_high"])
    gap = s * b_rev - out["mu_r"]
    gap = gap[np.isfinite(gap)]
    found["mu_r_bound"] = "lower"
    found["attenuation_gap"] = float(max(np.median(gap), 0.0)) if gap.size else float("nan")


def _fz_std(o: Stats, plan: Plan) -> np.ndarray:
    """Per-window standard deviation of fz from the kernel's centred sum of squares (NaN without it)."""
    if "szz" not in o:
        return np.full(len(o["n"]), np.nan)
    n = np.asarray(o["n"], dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        std: np.ndarray = np.sqrt(np.asarray(o["szz"], dtype=float) / n)
        return std


def _orientation_confidence(st: Stats, s: int) -> Dict[str, float]:
    """The recording's Pearson r of fy and fz (windows merged) and the fraction of windows whose slope has sign s."""
    n = np.asarray(st["n"], dtype=float)
    slope = np.asarray(st["slope"], dtype=float)
    good = np.isfinite(slope) & (slope != 0)
    agree = float(np.mean(np.sign(slope[good]) == s)) if good.any() else float("nan")
    r = float("nan")
    if "szz" in st and "syy" in st and n.sum() > 0:
        szz, syy = _merged(st, "z", "z"), _merged(st, "y", "y")
        if szz > 0 and syy > 0:
            r = _merged(st, "z", "y") / float(np.sqrt(szz * syy))
    return {"orientation_r": r, "orientation_agreement": agree}
