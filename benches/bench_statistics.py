"""Bias, RMSE and interval coverage of every estimator on the simulator (docs/method.md 3f).

For each condition (noise on fz at SNR_z 40..6 dB, white or band-limited;
white, band or low-frequency noise on fy) one simulated recording
(``tribodyn.simulate.conditions``, fixed seed, mu = 0.1, 2 s windows
tiling it) is analysed with each estimator; over its windows:

- bias: mean(mu_r) / mu - 1;
- RMSE: sqrt(mean((mu_r - mu)^2)) / mu;
- coverage: the fraction of windows whose 95 % interval holds mu.

Run: ``python benches/bench_statistics.py [--seconds 800] [--markdown]``;
the table in docs/method.md 3f is its ``--markdown`` output.

``--intervals`` instead measures what issue 23 asked of the default
analysis over many recordings (``--recordings``, seeds 1000 ``--seed`` on, each
``--seconds`` long; 2 s windows tiling it): for each case of
:data:`INTERVAL_CASES`, over all windows the bias of mu_r and the coverage
of its 95 % interval; the fraction the "ci" gate keeps, the headline's
bias (mean over recordings of the median of the gated windows, minus the
truth) and the gated windows' coverage; the fraction of recordings whose
``summary()`` 95 % interval of the median (the headline's interval) and of
the mean hold the truth; and the coverage of the interval of ``dmu_dfn``
(``dmu_dfn_low``/``dmu_dfn_high``; in a version without them,
``dmu_dfn`` +- 1.96 ``dmu_dfn_stderr``). Then the window-by-window error
of the gated COF on the temperature test with 0.05 N white noise on fy
(docs/method.md 5). The tables in docs/method.md 3f are its ``--markdown``
output, run once with this version and once with the one before.

``--ranges`` instead measures the operating ranges of issue 23 point 5
(docs/method.md 7) over ``--recordings`` simulated tests per case (seeds
from 100 ``--seed``): the instability onset with a current drop in
contact loss, the breakpoints of a curved and of the paper's J bathtub,
the temperature test's breakpoints and hysteresis at hops of 10 s and 2 s
(and whether the heating branch's lower-edge verdict agrees between them),
and false optima on a flat COF (:func:`ranges`). The table in
docs/method.md 7 is its ``--markdown`` output.

``--instrument`` measures issue 23 point 3 (the instrument's lag chosen
from the data, the lower bound when no instrument is valid) on the cases of
:data:`INSTRUMENT_CASES`, ``--recordings`` recordings each (seeds 3000 on):
the lag used, per-window bias and coverage, the headline's bias, the
fraction of recordings whose headline interval holds the truth, how many
headlines are marked a lower bound, the median ``attenuation_p``.

``--pipeline HOURS`` instead times ``analyze`` end to end on a recording of
that many hours (1 kHz, fx, fy, fz, i, float64 ``.npy`` written by
``bench_pipeline.write_recording``; 2 s windows tiling it), in one process:
``method="paper"`` (the OLS path of tribodyn 0.2), the default estimator,
and the default with the rig's lines (``rpm``, ``n_lamellas``); medians of
``--repeats`` warm runs, and their ratios to the paper's path.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import tribodyn
from tribodyn import simulate

MU = 0.1
CONDITIONS = [
    ("SNR_z 40 dB", dict(snr_z=40.0, y_noise=0.02)),
    ("SNR_z 20 dB", dict(snr_z=20.0, y_noise=0.02)),
    ("SNR_z 10 dB", dict(snr_z=10.0, y_noise=0.02)),
    ("SNR_z 6 dB", dict(snr_z=6.0, y_noise=0.02)),
    ("SNR_z 10 dB, band noise", dict(snr_z=10.0, z_noise="band", y_noise=0.02)),
    ("fy noise 0.05 N, band", dict(snr_z=40.0, y_noise=0.05, y_noise_kind="band")),
    ("fy low-frequency disturbance 0.05 N", dict(snr_z=40.0, y_noise=0.01, drift=0.05)),
]
ESTIMATORS = ("corrected", "iv", "ols", "deming")
#: The cases of ``--intervals`` (issue 23): fz noise, a low-frequency fy disturbance, a force dependence.
INTERVAL_CASES = [
    ("SNR_z 40 dB", dict(snr_z=40.0, y_noise=0.02)),
    ("SNR_z 20 dB", dict(snr_z=20.0, y_noise=0.02)),
    ("SNR_z 10 dB", dict(snr_z=10.0, y_noise=0.02)),
    ("SNR_z 6 dB", dict(snr_z=6.0, y_noise=0.02)),
    ("fy low-frequency disturbance 0.05 N", dict(snr_z=40.0, y_noise=0.01, drift=0.05)),
    ("d mu/d Fn = 0.01 /N, SNR_z 10 dB", dict(snr_z=10.0, y_noise=0.02, beta=0.1)),
]


def run(seconds: float, seed: int = 1) -> list:
    rows = []
    for name, kw in CONDITIONS:
        sim = simulate.conditions(seconds, mu=MU, seed=seed, **kw)
        noise = (float(kw.get("y_noise", 0.0)) or 1e-6, sim.truth.params["noise_z_std"] or 1e-6)
        for est in ESTIMATORS:
            res = tribodyn.analyze(
                dict(sim.channels), fs=sim.fs, window=2.0, hop=2.0, rpm=sim.rpm, estimator=est,
                noise=noise if est == "deming" else None,
            )  # fmt: skip
            mu, lo, hi = res["mu_r"], res["mu_r_low"], res["mu_r_high"]
            good = np.isfinite(mu)
            rows.append(
                dict(
                    condition=name,
                    estimator=est,
                    windows=int(good.sum()),
                    bias=float(np.mean(mu[good]) / MU - 1),
                    rmse=float(np.sqrt(np.mean((mu[good] - MU) ** 2)) / MU),
                    coverage=float(np.mean((lo[good] <= MU) & (MU <= hi[good]))),
                )
            )
    return rows


def _within(lo: float, hi: float) -> bool:
    return bool(lo <= MU <= hi)


def intervals(recordings: int, seconds: float, seed: int = 1000) -> list:
    """One row per case of :data:`INTERVAL_CASES` over ``recordings`` simulated recordings (docs/method.md 3f)."""
    rows = []
    for name, kw in INTERVAL_CASES:
        acc: dict = {k: [] for k in ("bias", "head", "ci_median", "ci_mean", "dynamic")}
        cnt = dict(windows=0, covered=0, gated=0, gated_covered=0, dmu=0, dmu_covered=0)
        dmu_kind = ""
        for r in range(recordings):
            sim = simulate.conditions(seconds, mu=MU, seed=seed + r, **kw)
            res = tribodyn.analyze(dict(sim.channels), fs=sim.fs, window=2.0, hop=2.0, rpm=sim.rpm, threads=1)
            mu, lo, hi, ok = res["mu_r"], res["mu_r_low"], res["mu_r_high"], res.gated
            good = np.isfinite(mu)
            cover = (lo <= MU) & (MU <= hi)
            acc["bias"].append(float(np.mean(mu[good]) / MU - 1))
            cnt["windows"] += int(good.sum())
            cnt["covered"] += int(cover[good].sum())
            cnt["gated"] += int(ok.sum())
            cnt["gated_covered"] += int(cover[ok].sum())
            head = res.headline
            acc["dynamic"].append(head.method == "dynamic")
            ci = res.summary()["mu_r"].get("ci", {})
            if head.method == "dynamic":
                acc["head"].append(head.value / MU - 1)
            if ci:
                acc["ci_median"].append(_within(*ci["median"]))
                acc["ci_mean"].append(_within(*ci["mean"]))
            truth = sim.truth.params["dmu_dfn"]
            if truth != 0.0:
                if "dmu_dfn_low" in res.table:
                    dlo, dhi, dmu_kind = res["dmu_dfn_low"], res["dmu_dfn_high"], "t(0.975, 4) se"
                else:
                    d, dse = res["dmu_dfn"], res["dmu_dfn_stderr"]
                    dlo, dhi, dmu_kind = d - 1.959964 * dse, d + 1.959964 * dse, "1.96 se"
                fin = np.isfinite(dlo) & np.isfinite(dhi)
                cnt["dmu"] += int(fin.sum())
                cnt["dmu_covered"] += int(np.sum((dlo[fin] <= truth) & (truth <= dhi[fin])))
        if kw.get("beta"):  # mu_r is then the incremental COF d Ft / d Fn, not MU (docs/method.md 3e)
            for key in ("bias", "head", "ci_median", "ci_mean"):
                acc[key] = []
            cnt.update(covered=0, gated_covered=0)
        rows.append(
            dict(
                case=name,
                recordings=recordings,
                windows=cnt["windows"] / recordings,
                bias=float(np.mean(acc["bias"])) if acc["bias"] else float("nan"),
                coverage=cnt["covered"] / cnt["windows"] if cnt["windows"] and acc["bias"] else float("nan"),
                kept=cnt["gated"] / max(cnt["windows"], 1),
                headline=float(np.mean(acc["head"])) if acc["head"] else float("nan"),
                dynamic=int(np.sum(acc["dynamic"])),
                gated_coverage=cnt["gated_covered"] / cnt["gated"] if cnt["gated"] and acc["bias"] else float("nan"),
                ci_median=float(np.mean(acc["ci_median"])) if acc["ci_median"] else float("nan"),
                ci_mean=float(np.mean(acc["ci_mean"])) if acc["ci_mean"] else float("nan"),
                summaries=len(acc["ci_median"]),
                dmu=cnt["dmu_covered"] / cnt["dmu"] if cnt["dmu"] else float("nan"),
                dmu_kind=dmu_kind,
            )
        )
        print(rows[-1], flush=True)
    return rows


def _covers(ci, truth: float) -> bool:
    return ci is not None and bool(ci[0] <= truth <= ci[1])


def _range_stats(rows: list, name: str, n: int, **figs) -> dict:
    row = dict(case=name, recordings=n, **figs)
    rows.append(row)
    print(row, flush=True)
    return row


def ranges(recordings: int, seed: int = 100, only: str = "aJTd") -> list:
    """The operating-range cases of issue 23 point 5 over ``recordings`` simulated tests each (docs/method.md 7).

    ``only``: the groups to run, "a" (instability), "J" (J bathtubs), "T" (temperature), "d" (flat COF).
    """
    rows: list = []
    seeds = [seed + r for r in range(recordings)]
    # (a) contact loss lowers the measured current (30 %): the instability onset (truth 6.5 A/mm^2)
    on, cover, inside, lost_on = [], 0, 0, []
    for s in seeds if "a" in only else []:
        sim = simulate.current_density_test(seed=s, current_drop=0.3)
        res = tribodyn.analyze(sim.channels, fs=sim.fs, window=2.0, hop=10.0, area_mm2=sim.area_mm2, threads=1)
        opr = tribodyn.operating_range(res, "current_density")
        truth = sim.truth.params["instability_onset"]
        on.append(np.nan if opr.instability is None else opr.instability)
        cover += _covers(opr.instability_ci, truth)
        inside += opr.optimum is not None and opr.instability is not None and opr.instability <= opr.optimum[1]
        lost_on.append(getattr(opr, "contact_loss_onset", None) or np.nan)
    if "a" in only:
        _range_stats(rows, "J, contact loss with a 30 % current drop: instability onset (truth 6.5)", len(seeds),
                     mean=float(np.nanmean(on)), covered=int(cover), inside_optimum=int(inside),
                     contact_loss_windows_onset=float(np.nanmean(lost_on)))  # fmt: skip
    # (b) breakpoints of the J bathtubs (hop 10 s)
    for bathtub in ("curved", "paper") if "J" in only else ():
        acc: dict = {k: [] for k in ("lo", "hi", "lo_cov", "hi_cov", "verdict")}
        for s in seeds:
            sim = simulate.current_density_test(seed=s, bathtub=bathtub)
            res = tribodyn.analyze(sim.channels, fs=sim.fs, window=2.0, hop=10.0, area_mm2=sim.area_mm2, threads=1)
            f = tribodyn.operating_range(res, "current_density").fits["all"]
            lo_t, hi_t = sim.truth.optimum["current_density"]
            acc["verdict"].append(f.verdict == "optimum")
            acc["lo"].append(np.nan if f.lower is None else f.lower - lo_t)
            acc["hi"].append(np.nan if f.upper is None else f.upper - hi_t)
            acc["lo_cov"].append(_covers(f.lower_ci, lo_t))
            acc["hi_cov"].append(_covers(f.upper_ci, hi_t))
        lo = np.asarray(acc["lo"])
        _range_stats(rows, f"J, {bathtub} bathtub: breakpoints (truth {lo_t:g}, {hi_t:g})", len(seeds),
                     optimum=int(np.sum(acc["verdict"])), lower_err_mean=float(np.nanmean(lo)),
                     lower_err_max=float(np.nanmax(np.abs(lo))), lower_within_0_3=int(np.sum(np.abs(lo) <= 0.3)),
                     lower_covered=int(np.sum(acc["lo_cov"])), upper_err_mean=float(np.nanmean(acc["hi"])),
                     upper_covered=int(np.sum(acc["hi_cov"])))  # fmt: skip
    # (c) the temperature test: branches, hysteresis, the lower-edge verdict at two hops
    verdicts: dict = {}
    for hop in (10.0, 2.0) if "T" in only else ():
        acc = {k: [] for k in ("h_hi", "h_hi_cov", "c_hi", "c_hi_cov", "h_lo", "h_lo_cov", "hy", "hy_cov")}
        for s in seeds:
            sim = simulate.temperature_test(seed=s)
            res = tribodyn.analyze(sim.channels, fs=sim.fs, window=2.0, hop=hop, temperature=sim.temperature_log,
                                   threads=1)  # fmt: skip
            opr = tribodyn.operating_range(res, "temperature")
            h, c, hy = opr.fits["heating"], opr.fits["cooling"], opr.hysteresis
            (h_lo_t, h_hi_t), (_, c_hi_t) = (sim.truth.optimum["temperature_heating"],
                                             sim.truth.optimum["temperature_cooling"])  # fmt: skip
            acc["h_hi"].append(np.nan if h.upper is None else h.upper - h_hi_t)
            acc["h_hi_cov"].append(_covers(h.upper_ci, h_hi_t))
            acc["c_hi"].append(np.nan if c.upper is None else c.upper - c_hi_t)
            acc["c_hi_cov"].append(_covers(c.upper_ci, c_hi_t))
            acc["h_lo"].append(np.nan if h.lower is None else h.lower - h_lo_t)
            acc["h_lo_cov"].append(_covers(h.lower_ci, h_lo_t))
            acc["hy"].append(np.nan if hy is None or hy.upper is None else hy.upper - (h_hi_t - c_hi_t))
            acc["hy_cov"].append(hy is not None and _covers(hy.upper_ci, h_hi_t - c_hi_t))
            verdicts.setdefault(s, []).append("edge" if h.edge_lower else "wall")
        _range_stats(rows, f"T, hop {hop:g} s: heating upper (160), cooling upper (155), heating lower (135), "
                     "hysteresis (5)", len(seeds),
                     heat_upper_err=float(np.nanmean(acc["h_hi"])), heat_upper_covered=int(np.sum(acc["h_hi_cov"])),
                     cool_upper_err=float(np.nanmean(acc["c_hi"])), cool_upper_covered=int(np.sum(acc["c_hi_cov"])),
                     heat_lower_found=int(np.sum(np.isfinite(acc["h_lo"]))),
                     heat_lower_err=float(np.nanmean(acc["h_lo"])) if np.isfinite(acc["h_lo"]).any() else np.nan,
                     heat_lower_covered=int(np.sum(acc["h_lo_cov"])),
                     hysteresis_err=float(np.nanmean(acc["hy"])),
                     hysteresis_covered=int(np.sum(acc["hy_cov"])))  # fmt: skip
    flips = sum(len(set(v)) > 1 for v in verdicts.values())
    if "T" in only:
        _range_stats(rows, "T, heating lower-edge verdict, hop 10 s against hop 2 s", len(seeds), flips=int(flips),
                     walls_hop10=sum(v[0] == "wall" for v in verdicts.values()),
                     walls_hop2=sum(v[1] == "wall" for v in verdicts.values()))  # fmt: skip
    # (d) a flat COF on the temperature path: false optima per branch
    false: dict = {b: [0, 0] for b in ("all", "heating", "cooling")}
    for s in seeds if "d" in only else []:
        sim = simulate.temperature_test(seed=s, model="flat")
        res = tribodyn.analyze(sim.channels, fs=sim.fs, window=2.0, hop=10.0, temperature=sim.temperature_log,
                               threads=1)  # fmt: skip
        opr = tribodyn.operating_range(res, "temperature")
        for b, f in opr.fits.items():
            false[b][0] += f.verdict == "optimum"
            false[b][1] += f.verdict != "no dependence"
    if "d" in only:
        _range_stats(
            rows,
            "T, flat COF (hop 10 s): false optima (both walls / any wall) per branch",
            len(seeds),
            **{f"{b}": f"{v[0]} / {v[1]}" for b, v in false.items()},
        )
    return rows


#: The cases of ``--instrument`` (issue 23 point 3): separate 2 s acquisitions at SNR_z 6 dB without ``rpm``, at a
#: rig speed (228 rpm) where fz lagged by 200 samples (the old default) is nearly uncorrelated with fz; the same
#: with band-limited fz noise; a lag given at which no instrument is valid (0.12 s); and, for no loss, continuous
#: recordings at the usual 250 rpm with and without ``rpm``. (name, conditions, acquisitions, seconds each,
#: analyze options)
INSTRUMENT_CASES = [
    ("40 acquisitions of 2 s, SNR_z 6 dB, 228 rpm, no rpm", dict(snr_z=6.0, y_noise=0.02, rpm=228.0), 40, 2.0, {}),
    ("40 acquisitions of 2 s, SNR_z 6 dB band, 228 rpm, no rpm",
     dict(snr_z=6.0, z_noise="band", y_noise=0.02, rpm=228.0), 40, 2.0, {}),
    ("40 acquisitions of 2 s, SNR_z 6 dB, 228 rpm, iv_lag=0.12 s (no valid instrument)",
     dict(snr_z=6.0, y_noise=0.02, rpm=228.0), 40, 2.0, dict(iv_lag=0.12)),
    ("continuous 400 s, SNR_z 6 dB, rpm given", dict(snr_z=6.0, y_noise=0.02), 1, 400.0, "rpm"),
    ("continuous 400 s, SNR_z 6 dB, no rpm", dict(snr_z=6.0, y_noise=0.02), 1, 400.0, {}),
]  # fmt: skip


def instrument(recordings: int, seed: int = 3000) -> list:
    """One row per case of :data:`INSTRUMENT_CASES` over ``recordings`` simulated recordings (docs/method.md 3f)."""
    rows = []
    for name, kw, count, seconds, opts in INSTRUMENT_CASES:
        acc: dict = {k: [] for k in ("bias", "head", "head_cov", "ci_cov", "lag", "bound", "p")}
        cnt = dict(windows=0, covered=0)
        for r in range(recordings):
            sims = [simulate.conditions(seconds, mu=MU, seed=(seed + r) * 1000 + k, **kw) for k in range(count)]
            src = [dict(a.channels) for a in sims] if count > 1 else dict(sims[0].channels)
            extra = dict(rpm=sims[0].rpm) if opts == "rpm" else dict(opts)
            res = tribodyn.analyze(src, fs=sims[0].fs, window=2.0, hop=2.0, threads=1, **extra)
            mu, lo, hi = res["mu_r"], res["mu_r_low"], res["mu_r_high"]
            good = np.isfinite(mu)
            acc["bias"].append(float(np.mean(mu[good]) / MU - 1))
            cnt["windows"] += int(good.sum())
            cnt["covered"] += int(np.sum((lo[good] <= MU) & (MU <= hi[good])))
            head = res.headline
            acc["head"].append(head.value / MU - 1)
            acc["head_cov"].append(_within(head.low, head.high))
            acc["lag"].append(res.params.get("iv_lag_samples"))
            acc["bound"].append(getattr(head, "bound", "") == "lower")
            acc["p"].append(float(np.nanmedian(res["attenuation_p"])))
        rows.append(
            dict(
                case=name, recordings=recordings, acquisitions=count, windows=cnt["windows"] / recordings,
                bias=float(np.mean(acc["bias"])), coverage=cnt["covered"] / max(cnt["windows"], 1),
                headline=float(np.mean(acc["head"])), head_cov=float(np.mean(acc["head_cov"])),
                lag=float(np.median(acc["lag"])), lag_range=(min(acc["lag"]), max(acc["lag"])),
                bound=int(np.sum(acc["bound"])), p=float(np.median(acc["p"])),
            )
        )  # fmt: skip
        print(rows[-1], flush=True)
    return rows


def print_instrument(rows: list) -> None:
    print(
        "| case | recordings | windows each | instrument lag (median, range) | all windows: bias | "
        "all windows: coverage | headline bias | headline interval coverage | headline a lower bound | "
        "median attenuation_p |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        lo, hi = r["lag_range"]
        print(
            f"| {r['case']} | {r['recordings']} | {r['windows']:.0f} | {r['lag']:.0f} ({lo}-{hi}) | "
            f"{_pct(r['bias'])} | "
            f"{_frac(r['coverage'])} | {_pct(r['headline'])} | {_frac(r['head_cov'])} | "
            f"{r['bound']} of {r['recordings']} | {r['p']:.3f} |"
        )


def gate_accuracy(seed: int = 0, noise: float = 0.05) -> dict:
    """The gated COF window by window on the temperature test with white noise on fy (docs/method.md 5)."""
    sim = simulate.temperature_test(seed=seed)
    ch = dict(sim.channels)
    ch["fy"] = ch["fy"] + np.random.default_rng(5).normal(0.0, noise, ch["fy"].size)
    res = tribodyn.analyze(ch, fs=sim.fs, rpm=sim.rpm, n_lamellas=sim.n_lamellas, threads=1)
    truth = sim.truth.mu_at(res["time"])
    ok = res.gated
    err = res["mu_r"][ok] / truth[ok] - 1
    return dict(
        windows=len(res),
        kept=int(ok.sum()),
        median=float(np.median(err)),
        median_abs=float(np.median(np.abs(err))),
        p95_abs=float(np.percentile(np.abs(err), 95)),
        coverage=float(np.mean((res["mu_r_low"][ok] <= truth[ok]) & (truth[ok] <= res["mu_r_high"][ok]))),
        paper_kept=float(tribodyn.analyze(ch, fs=sim.fs, method="paper", threads=1).gated.mean()),
    )


def _pct(x: float) -> str:
    return "n/a" if not np.isfinite(x) else f"{100 * x:+.2f} %"


def _num(x: object) -> str:
    return f"{x:.3g}" if isinstance(x, float) else str(x)


def _frac(x: float) -> str:
    return "n/a" if not np.isfinite(x) else f"{x:.3f}"


def print_intervals(rows: list, acc: dict) -> None:
    print(
        "| case | recordings | windows each | all windows: bias | all windows: coverage | gate keeps | "
        "headline (gated median) bias | gated coverage | summary() median CI coverage | summary() mean CI coverage | "
        "dmu_dfn coverage |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        dmu = "" if not np.isfinite(r["dmu"]) else f"{r['dmu']:.3f} ({r['dmu_kind']})"
        dyn = "" if r["dynamic"] == r["recordings"] else f" ({r['dynamic']} dynamic)"
        print(
            f"| {r['case']} | {r['recordings']} | {r['windows']:.0f} | {_pct(r['bias'])} | {_frac(r['coverage'])} | "
            f"{_frac(r['kept'])} | {_pct(r['headline'])}{dyn} | {_frac(r['gated_coverage'])} | "
            f"{_frac(r['ci_median'])} | {_frac(r['ci_mean'])} | {dmu} |"
        )
    print(
        f"\nTemperature test, 0.05 N white noise on fy: the gate keeps {acc['kept']} of {acc['windows']} windows "
        f"(|C_yz| gate: {100 * acc['paper_kept']:.0f} %); gated error against the truth: median {_pct(acc['median'])}, "
        f"median |error| {100 * acc['median_abs']:.2f} %, 95th percentile of |error| {100 * acc['p95_abs']:.2f} %; "
        f"coverage {acc['coverage']:.3f}."
    )


def pipeline(hours: float, repeats: int) -> None:
    import os
    import sys
    import tempfile
    from pathlib import Path

    sys.path.insert(0, os.path.dirname(__file__))
    import bench_pipeline as bp

    with tempfile.TemporaryDirectory() as tmp:
        path = bp.write_recording(Path(tmp), "rec", hours * 3600.0, raw=False, formats=("npy",))["npy"]
        cases = {
            'method="paper" (OLS, the 0.2 path)': dict(method="paper"),
            "default (corrected, gate ci)": dict(),
            "default + rpm, n_lamellas (line spectra)": dict(rpm=simulate.RPM, n_lamellas=simulate.N_LAMELLAS),
        }
        times = {}
        for name, kw in cases.items():
            runs = []
            for _ in range(repeats + 1):  # the first run warms the page cache
                with bp.open_source(path) as rec:
                    t0 = time.perf_counter()
                    res = tribodyn.analyze(rec, window=2.0, hop=2.0, area_mm2=bp.AREA, **kw)
                    runs.append(time.perf_counter() - t0)
            times[name] = float(np.median(runs[1:]))
            print(f"{name}: {times[name]:.3f} s ({len(res)} windows, route {res.params['route']})", flush=True)
        base = times['method="paper" (OLS, the 0.2 path)']
        print(f"\n| {hours:g} h, 1 kHz, 4 channels, .npy | time (median of {repeats}) | ratio to the paper's path |")
        print("|---|---|---|")
        for name, t in times.items():
            print(f"| {name} | {t:.3f} s | {t / base:.2f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=800.0, help="length of each simulated recording (s)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--markdown", action="store_true", help="print the table of docs/method.md 3f")
    ap.add_argument("--pipeline", type=float, metavar="HOURS", help="time analyze end to end on HOURS of data instead")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--intervals", action="store_true", help="the issue-23 table: gate, summary and dmu_dfn intervals")
    ap.add_argument("--recordings", type=int, default=200, help="recordings per case of --intervals (--ranges: 20)")
    ap.add_argument("--ranges", action="store_true", help="the issue-23 point-5 operating-range cases")
    ap.add_argument("--only", default="aJTd", help="--ranges groups: a (instability), J, T, d (flat COF)")
    ap.add_argument("--instrument", action="store_true", help="the issue-23 point-3 table: the instrument's lag")
    args = ap.parse_args()
    if args.instrument:
        t0 = time.perf_counter()
        rows = instrument(args.recordings, seed=3000 * args.seed)
        if args.markdown:
            print_instrument(rows)
        print(f"\n({time.perf_counter() - t0:.0f} s, seeds from {3000 * args.seed})")
        return
    if args.ranges:
        t0 = time.perf_counter()
        n = args.recordings if args.recordings != 200 else 20
        rows = ranges(n, seed=100 * args.seed, only=args.only)
        if args.markdown:
            for r in rows:
                figs = "; ".join(f"{k} {_num(v)}" for k, v in r.items() if k not in ("case", "recordings"))
                print(f"| {r['case']} | {r['recordings']} | {figs} |")
        print(f"\n({time.perf_counter() - t0:.0f} s, seeds from {100 * args.seed})")
        return
    if args.pipeline:
        pipeline(args.pipeline, args.repeats)
        return
    if args.intervals:
        t0 = time.perf_counter()
        first = 1000 * args.seed  # seeds 1000, 1001, ... with the default --seed 1
        rows = intervals(args.recordings, args.seconds, seed=first)
        acc = gate_accuracy()
        if args.markdown:
            print_intervals(rows, acc)
        else:
            print(acc)
        print(f"\n({time.perf_counter() - t0:.0f} s, seeds from {first}, {args.seconds:g} s per recording)")
        return
    t0 = time.perf_counter()
    rows = run(args.seconds, args.seed)
    if args.markdown:
        print("| condition | estimator | windows | bias | RMSE | 95 % coverage |")
        print("|---|---|---|---|---|---|")
        for r in rows:
            print(
                f"| {r['condition']} | {r['estimator']} | {r['windows']} | {100 * r['bias']:+.2f} % | "
                f"{100 * r['rmse']:.2f} % | {r['coverage']:.3f} |"
            )
    else:
        for r in rows:
            print(r)
    print(f"\n({time.perf_counter() - t0:.0f} s, seed {args.seed}, {args.seconds:g} s per recording)")


if __name__ == "__main__":
    main()
