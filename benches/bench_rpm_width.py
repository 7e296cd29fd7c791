"""Why the headline's interval with ``rpm`` is wide at SNR_z 6 dB: its width taken apart (issue 35 point 3).

The recordings of ``bench_lag_choice.py`` (its simulation: the rig of ``tribodyn.simulate.conditions``,
mu = 0.1, 1 kHz, 250 rpm, 0.02 N white noise on fy, fz noise added by its ``add_noise``; "continuous" 400 s,
"acquisitions" 40 separate 2 s acquisitions; seeds as there), each simulated once and analysed at every SNR
asked with ``rpm=250`` (the lag one revolution; ``--rules data`` adds the defaults, the lag from the data).

Per recording the headline's bootstrap (``bootstrap_ci``, the same resamples) is taken apart:

- ``full``: the median over each resample with the fz-noise estimate drawn anew (``noise=``): the headline's;
- ``windows``: the same resamples with the noise estimate held (no ``noise=``);
- ``noise``: the resample's noise estimate sigma*^2 alone (its spread, and its move of the median);
- the interval from ``full``'s resamples as the headline takes it (expanded percentiles), as plain 2.5/97.5
  percentiles, and as +- 1.96 their standard deviation; the interval of ``windows`` as the headline would take
  it (expanded percentiles).

Against the truth between recordings: the headline's spread; the noise estimate's (sigma^2 of the
recording, ``params["noise_z_std"]^2``); and the "oracle" median (every window moved to the true noise
variance, first order: mu_r + mu_r_dnoise (sigma_true^2 - sigma^2)), the spread the windows alone give.
Each cell's line: coverage k/n (95 % Clopper-Pearson) of every interval; the ratio of the spread between
recordings to the root mean square of the bootstrap's standard deviation, for each part; the mean half-width
over the bootstrap's standard deviation (the expansion); the standard deviation of every recording's headline
error over its own bootstrap standard deviation (what the expansion must cover: 1.13 for Student's t with 9
degrees of freedom, the expansion's model with 10 blocks). ``--common-noise``: the acquisitions' fz noise of one
level (``bench_lag_choice`` scales each acquisition's to its own fz, about +-12 % in variance between them).

Run: ``python benches/bench_rpm_width.py [--recordings 200] [--snr 6 10 20] [--noise white]
[--layout continuous acquisitions] [--rules rpm] [--jobs 2] [--markdown]``: about 4 s a continuous
recording and 1 s an acquisitions one on one core. ``--independent 3000``: only the expansion's check on
independent windows (40 Gaussian windows, 10 blocks; coverage of the median's expanded and plain percentile
intervals).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import warnings
from concurrent.futures import ProcessPoolExecutor
from statistics import NormalDist
from typing import Any, Dict, List, Optional, Tuple

import numpy as np
from bench_lag_choice import FS, MU, add_noise

Job = Tuple[int, Tuple[float, ...], Optional[Tuple[float, float]], bool, Tuple[str, ...], bool]


def simulate(seed: int, acquisitions: bool) -> List[Dict[str, np.ndarray]]:
    """The noise-free channels of ``bench_lag_choice.record`` (one mapping, or 40)."""
    from tribodyn import simulate as sim

    def one(s: int, seconds: float) -> Dict[str, np.ndarray]:
        got = sim.conditions(seconds, mu=MU, seed=s, fs=FS, y_noise=0.02)
        return {k: np.array(v, dtype=float) for k, v in got.channels.items()}

    if acquisitions:
        return [one(seed * 1000 + k, 2.0) for k in range(40)]
    return [one(seed, 400.0)]


def with_noise(parts: List[Dict[str, np.ndarray]], seed: int, snr: float, band: Optional[Tuple[float, float]],
               acquisitions: bool, common: bool = False) -> Tuple[Any, float]:  # fmt: skip
    """The source ``bench_lag_choice.record`` gives, and the variance of the noise added to fz (N^2; the mean
    over acquisitions). ``common``: every acquisition's noise of one std, that of fz over them all (the root
    mean of their variances), instead of each its own fz's (``bench_lag_choice``)."""
    out, var = [], []
    pooled = float(np.sqrt(np.mean([np.var(ch["fz"]) for ch in parts])))
    for k, ch in enumerate(parts):
        s = seed * 1000 + k if acquisitions else seed
        c = dict(ch)
        scale = pooled / float(np.std(ch["fz"])) if common else 1.0
        noisy = add_noise(ch["fz"], snr, band, s)
        c["fz"] = ch["fz"] + scale * (noisy - ch["fz"]) if common else noisy
        var.append((scale * float(np.std(ch["fz"])) * 10.0 ** (-snr / 20.0)) ** 2)
        out.append(c)
    return (out if acquisitions else out[0]), float(np.mean(var))


def take_apart(res: Any) -> Dict[str, Any]:
    """The headline bootstrap's parts (module docstring), from ``bootstrap_ci``'s own resamples."""
    from tribodyn.kernels import stats
    from tribodyn.kernels.quantiles import t_quantile

    mu, keep = res._gated_mu
    nr = stats.noise_resample(res.table, keep)
    n = mu.size
    rng = np.random.default_rng(stats.BOOTSTRAP_SEED)
    out: Dict[str, Any] = {"n": int(n)}
    if nr is None:
        starts, ell = stats._block_starts(rng, n)
        full = stats._all_resample_stats(mu, starts, ell, None, width=n, threads=1)[0]
        win = full
        delta = np.zeros_like(full)
    else:
        var = np.asarray(nr.var, dtype=float)
        fin = np.isfinite(var)
        used = max(float(np.median(var[fin])), 0.0)
        starts, ell = stats._block_starts(rng, var.size)
        pos = np.full(var.size, -1, dtype=np.int64)
        pos[nr.index] = np.arange(n)
        full = stats._all_resample_stats(mu, starts, ell, (var, pos, nr.dnoise, used), width=var.size, threads=1)[0]
        zero = np.zeros_like(nr.dnoise)
        win = stats._all_resample_stats(mu, starts, ell, (var, pos, zero, used), width=var.size, threads=1)[0]
        idx = stats._expand(starts, ell, var.size)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            delta = np.maximum(np.nanmedian(var[idx], axis=1), 0.0) - used
        out["dnoise"] = float(np.median(nr.dnoise))
    b = -(-n // int(np.ceil(n ** (1.0 / 3.0))))
    a = 100.0 * NormalDist().cdf(-math.sqrt(b / (b - 1)) * t_quantile(0.975, b - 1))
    both = np.isfinite(win) & np.isfinite(delta)
    corr = float(np.corrcoef(win[both], delta[both])[0, 1]) if np.std(delta[both]) > 0 else 0.0
    full = full[np.isfinite(full)]
    win = win[np.isfinite(win)]
    out.update(
        below_full=float(np.mean(full < MU) + 0.5 * np.mean(full == MU)),
        below_win=float(np.mean(win < MU) + 0.5 * np.mean(win == MU)),
        blocks=int(b), a=a, sd_full=float(np.std(full)), sd_win=float(np.std(win)),
        sd_delta=float(np.std(delta)), corr=corr,
        expanded=tuple(float(x) for x in np.percentile(full, [a, 100 - a])),
        plain=tuple(float(x) for x in np.percentile(full, [2.5, 97.5])),
    )  # fmt: skip
    return out


def one_recording(job: Job) -> List[Dict[str, Any]]:
    """Every (SNR, rule) row of one recording."""
    import tribodyn as td

    seed, snrs, band, acq, rules, common = job
    parts = simulate(seed, acq)
    rows = []
    for snr in snrs:
        src, true_var = with_noise(parts, seed, snr, band, acq, common)
        for rule in rules:
            opts = {"rpm": 250.0} if rule == "rpm" else {}
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = td.analyze(src, fs=FS, threads=1, **opts)
                h = res.headline
                parts_ = take_apart(res)
            mu, keep = res._gated_mu
            s2 = float(res.params.get("noise_z_std") or 0.0) ** 2
            dn = np.asarray(res.table["mu_r_dnoise"], dtype=float)[keep]
            rows.append(dict(seed=seed, snr=snr, rule=rule, value=h.value, ci=(h.low, h.high), noise_est=s2,
                             true_noise=true_var, oracle=float(np.median(mu + dn * (true_var - s2))),
                             **parts_))  # fmt: skip
    return rows


def summarise(rows: List[Dict[str, Any]]) -> Dict[str, Any]:
    """One cell's coverages and spreads (module docstring)."""

    def cover(lo_hi: np.ndarray) -> int:
        return int(np.sum((lo_hi[:, 0] <= MU) & (MU <= lo_hi[:, 1])))

    def rms(x: np.ndarray) -> float:
        return float(np.sqrt(np.mean(np.square(x))))

    v = np.array([r["value"] for r in rows])
    full = np.array([r["sd_full"] for r in rows])
    ci = np.array([r["ci"] for r in rows])
    exp_ = np.array([r["expanded"] for r in rows])
    plain = np.array([r["plain"] for r in rows])
    normal = np.stack([v - 1.96 * full, v + 1.96 * full], axis=1)
    noise = np.array([r["noise_est"] for r in rows])
    truth = np.array([r["true_noise"] for r in rows])
    dn = np.array([r.get("dnoise", 0.0) for r in rows])
    oracle = np.array([r["oracle"] for r in rows])

    def inside(key: str) -> int:
        return int(sum(r["a"] / 100 <= r[key] <= 1 - r["a"] / 100 for r in rows))

    return dict(
        n=len(rows), headline=cover(ci), windows_only=inside("below_win"), expanded=cover(exp_),
        plain=cover(plain), normal=cover(normal),
        bias=float(np.mean(v) / MU - 1),
        sd_between=float(np.std(v, ddof=1)), sd_boot=rms(full),
        ratio_full=float(np.std(v, ddof=1) / rms(full)),
        ratio_windows=float(np.std(oracle, ddof=1) / rms(np.array([r["sd_win"] for r in rows]))),
        ratio_noise=float(np.std(noise - truth, ddof=1) / rms(np.array([r["sd_delta"] for r in rows])))
        if np.any(dn) else float("nan"),
        noise_bias=float(np.mean(noise) / np.mean(truth) - 1),
        corr_boot=float(np.mean([r["corr"] for r in rows])),
        corr_between=float(np.corrcoef(oracle, dn * (noise - truth))[0, 1]) if np.any(dn) else float("nan"),
        halfwidth_over_sd=float(np.mean((exp_[:, 1] - exp_[:, 0]) / 2 / full)),
        studentized=float(np.std((v - MU) / full)),
        blocks=int(rows[0]["blocks"]), windows=int(np.median([r["n"] for r in rows])),
    )  # fmt: skip


def independent(draws: int, n: int = 40, seed: int = 2) -> Dict[str, float]:
    """Coverage of the median's intervals from ``bootstrap_ci``'s resamples over ``draws`` sets of ``n``
    independent Gaussian windows: expanded percentiles (the headline's) and plain 2.5/97.5 ones."""
    from tribodyn.kernels import stats

    rng = np.random.default_rng(seed)
    starts, ell = stats._block_starts(np.random.default_rng(stats.BOOTSTRAP_SEED), n)
    got = {"expanded": 0, "plain": 0}
    for _ in range(draws):
        v = rng.standard_normal(n)
        lo, hi = stats.bootstrap_ci(v, threads=1)["median"]
        got["expanded"] += int(lo <= 0.0 <= hi)
        lo, hi = np.percentile(stats._all_resample_stats(v, starts, ell, None, width=n, threads=1)[0], [2.5, 97.5])
        got["plain"] += int(lo <= 0.0 <= hi)
    return {k: v / draws for k, v in got.items()}


def main(argv: Optional[List[str]] = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--recordings", type=int, default=200)
    ap.add_argument("--seed", type=int, default=5000, help="recording r has seed SEED + r")
    ap.add_argument("--snr", type=float, nargs="+", default=[6.0, 10.0, 20.0])
    ap.add_argument("--noise", nargs="+", default=["white"], help="white or band:LO-HI (Hz)")
    ap.add_argument("--layout", nargs="+", default=["continuous", "acquisitions"])
    ap.add_argument("--rules", nargs="+", default=["rpm"], help="rpm (rpm=250) and/or data (the defaults)")
    ap.add_argument(
        "--common-noise",
        action="store_true",
        help="acquisitions: one noise std for all (fz's over them all), not each its own fz's",
    )
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--rows", help="write every recording's row here (JSON lines)")
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument(
        "--independent",
        type=int,
        default=0,
        metavar="DRAWS",
        help="only the check on DRAWS sets of 40 independent Gaussian windows",
    )
    args = ap.parse_args(argv)
    if args.independent:
        print(json.dumps(independent(args.independent)))
        return
    out = []
    sink = open(args.rows, "w") if args.rows else None
    with ProcessPoolExecutor(args.jobs) as ex:
        for noise in args.noise:
            band = None if noise == "white" else tuple(float(x) for x in noise.split(":")[1].split("-"))
            for layout in args.layout:
                jobs = [(args.seed + r, tuple(args.snr), band, layout == "acquisitions", tuple(args.rules),
                         args.common_noise)
                        for r in range(args.recordings)]  # fmt: skip
                rows = []
                for got in ex.map(one_recording, jobs):
                    rows += got
                    for r in got if sink else ():
                        print(json.dumps(dict(noise=noise, layout=layout, **r)), file=sink, flush=True)
                for snr in args.snr:
                    for rule in args.rules:
                        mine = [r for r in rows if r["snr"] == snr and r["rule"] == rule]
                        cell = dict(noise=noise, layout=layout, snr=snr, rule=rule, **summarise(mine))
                        out.append(cell)
                        print(json.dumps(cell), file=sys.stderr, flush=True)
    if sink:
        sink.close()
    if args.markdown:
        from _results import clopper_pearson as cp

        print(
            "| fz noise | layout | SNR_z | lag | windows (blocks) | coverage: headline | without the noise resample | "
            "plain percentile | +-1.96 sd | spread between / bootstrap sd: headline | windows alone | "
            "noise estimate | half-width / bootstrap sd | sd of (headline - mu) / bootstrap sd |"
        )
        print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        for c in out:
            print(
                f"| {c['noise']} | {c['layout']} | {c['snr']:g} dB | {c['rule']} | {c['windows']} ({c['blocks']}) | "
                f"{cp(c['headline'], c['n'])} | {cp(c['windows_only'], c['n'])} | {cp(c['plain'], c['n'])} | "
                f"{cp(c['normal'], c['n'])} | {c['ratio_full']:.2f} | {c['ratio_windows']:.2f} | "
                f"{c['ratio_noise']:.2f} | {c['halfwidth_over_sd']:.2f} | {c['studentized']:.2f} |"
            )


if __name__ == "__main__":
    main()
