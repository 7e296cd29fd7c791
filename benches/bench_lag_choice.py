"""Coverage of the headline's 95 % interval when the instrument's lag is chosen from the data (issue 35 point 3).

Each recording: the rig of ``tribodyn.simulate.conditions`` (mu = 0.1, fs = 1 kHz, 250 rpm, 0.02 N white
noise on fy, no fz noise of its own) with measurement noise added here to the recorded fz: white, or
white noise through a 2nd-order Butterworth band-pass (``scipy.signal.butter``; 200-450 Hz by default, the
audit's band, or 20-200 Hz, the simulator's), of std ``std(fz) 10^(-SNR/20)``, from its own generator
(seed ``(seed, 35)``). A "continuous" recording is 400 s (200 windows of 2 s); an "acquisitions" one is 40
separate 2 s acquisitions (``conditions(2, seed=1000 seed + k)``), one window each. Each is analysed with
the defaults (``td.analyze(src, fs=1000)``: the lag chosen from the data) and, sharing the simulation, with
``rpm=`` (the lag one revolution); ``--fixed L`` adds ``iv_lag=L / fs`` (a lag given).

Per cell (noise, SNR, continuous or acquisitions, lag rule): how many of the recordings' headline 95 %
intervals hold mu (k/n, with the 95 % Clopper-Pearson interval of the rate: the binomial margin),
"before" the headline's bootstrap without the lag pooling (``bootstrap_ci`` without ``shifts``, the interval
of tribodyn before issue 35 point 3; bit for bit the same resamples) and "after" (``Results.mu_r_ci``,
pooled over the admissible lags, docs/method.md 3d); the mean width after / before; the headline's bias
(mean over recordings of headline / mu - 1) and its spread between recordings against the mean
half-width / 1.96 of the interval before; the lags used.

Run: ``python benches/bench_lag_choice.py [--recordings 40] [--snr 6 10 20] [--noise white band:200-450]
[--jobs 2] [--markdown]``: about 3 minutes a noise kind at 40 recordings on 2 cores.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from concurrent.futures import ProcessPoolExecutor
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

MU = 0.1
FS = 1000.0


def add_noise(fz: np.ndarray, snr: float, band: Optional[Tuple[float, float]], seed: int) -> np.ndarray:
    """``fz`` plus white (``band`` None) or band-limited noise of std ``std(fz) 10^(-snr/20)``."""
    from scipy import signal

    rng = np.random.default_rng([seed, 35])
    pre = 2000  # the filter's start-up, discarded
    w = rng.standard_normal(fz.size + pre)
    if band is not None:
        w = signal.sosfilt(signal.butter(2, band, btype="bandpass", fs=FS, output="sos"), w)
    w = w[pre:]
    return fz + w / w.std() * float(np.std(fz)) * 10.0 ** (-snr / 20.0)


def record(seed: int, snr: float, band: Optional[Tuple[float, float]], acquisitions: bool) -> Any:
    """The source to analyse: a mapping (400 s) or a list of 40 mappings (2 s each)."""
    from tribodyn import simulate

    def one(s: int, seconds: float) -> Dict[str, np.ndarray]:
        sim = simulate.conditions(seconds, mu=MU, seed=s, fs=FS, y_noise=0.02)
        ch = {k: np.array(v, dtype=float) for k, v in sim.channels.items()}
        ch["fz"] = add_noise(ch["fz"], snr, band, s)
        return ch

    if acquisitions:
        return [one(seed * 1000 + k, 2.0) for k in range(40)]
    return one(seed, 400.0)


def _before(res: Any) -> Tuple[float, float]:
    """The headline's interval without the pooling over lags (the same resamples as ``Results.mu_r_ci``)."""
    from tribodyn.kernels.stats import bootstrap_ci, noise_resample

    mu, keep = res._gated_mu
    ci = bootstrap_ci(mu, noise=noise_resample(res.table, keep), threads=1)
    lo, hi = ci.get("median", (float("nan"), float("nan")))
    gap = res.params.get("attenuation_gap")
    if res.params.get("mu_r_bound") == "lower" and gap is not None and np.isfinite(gap):
        hi += float(gap)
    return float(lo), float(hi)


def one_recording(job: Tuple[int, float, Optional[Tuple[float, float]], bool, Optional[int]]) -> List[Dict[str, Any]]:
    """Every lag rule's row of one recording."""
    import tribodyn as td

    seed, snr, band, acq, fixed = job
    src = record(seed, snr, band, acq)
    rules: List[Tuple[str, Dict[str, Any]]] = [("data", {}), ("rpm", {"rpm": 250.0})]
    if fixed:
        rules.append((f"iv_lag={fixed}", {"iv_lag": fixed / FS}))
    rows = []
    for rule, opts in rules:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = td.analyze(src, fs=FS, threads=1, **opts)
            h = res.headline
            before = _before(res)
        rows.append(
            dict(
                seed=seed,
                rule=rule,
                value=h.value,
                after=(h.low, h.high),
                before=before,
                lag=res.params.get("iv_lag_samples"),
                shifts=len(res.params.get("iv_lag_shifts") or ()),
            )
        )
    return rows


def _cp(k: int, n: int) -> str:
    """k/n with the 95 % Clopper-Pearson interval of the rate (``_results.clopper_pearson``)."""
    from _results import clopper_pearson  # benches/ is on the path of a script run from it

    return clopper_pearson(k, n)


def summarise(rows: List[Dict[str, Any]]) -> Dict[str, Any]:
    """One cell's figures (module docstring)."""
    v = np.array([r["value"] for r in rows])
    b = np.array([r["before"] for r in rows])
    a = np.array([r["after"] for r in rows])
    lags = [int(r["lag"]) for r in rows]
    return dict(
        n=len(rows), before=int(np.sum((b[:, 0] <= MU) & (MU <= b[:, 1]))),
        after=int(np.sum((a[:, 0] <= MU) & (MU <= a[:, 1]))),
        width=float(np.mean(a[:, 1] - a[:, 0]) / np.mean(b[:, 1] - b[:, 0])),
        bias=float(np.mean(v) / MU - 1), spread=float(np.std(v, ddof=1) / np.mean((b[:, 1] - b[:, 0]) / 2 / 1.96)),
        lags=f"{int(np.median(lags))} ({min(lags)}-{max(lags)})",
        pooled=f"{np.mean([r['shifts'] for r in rows]):.1f}",
    )  # fmt: skip


def main(argv: Optional[List[str]] = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--recordings", type=int, default=40)
    ap.add_argument("--seed", type=int, default=5000, help="recording r has seed SEED + r")
    ap.add_argument("--snr", type=float, nargs="+", default=[6.0, 10.0, 20.0])
    ap.add_argument("--noise", nargs="+", default=["white", "band:200-450"], help="white or band:LO-HI (Hz)")
    ap.add_argument("--layout", nargs="+", default=["continuous", "acquisitions"])
    ap.add_argument("--fixed", type=int, default=0, help="also analyse with iv_lag=FIXED samples")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args(argv)
    out = []
    with ProcessPoolExecutor(args.jobs) as ex:
        for noise in args.noise:
            band = None if noise == "white" else tuple(float(x) for x in noise.split(":")[1].split("-"))
            for layout in args.layout:
                for snr in args.snr:
                    jobs = [(args.seed + r, snr, band, layout == "acquisitions", args.fixed or None)
                            for r in range(args.recordings)]  # fmt: skip
                    rows = [x for got in ex.map(one_recording, jobs) for x in got]
                    for rule in dict.fromkeys(r["rule"] for r in rows):
                        cell = dict(noise=noise, layout=layout, snr=snr, rule=rule,
                                    **summarise([r for r in rows if r["rule"] == rule]))  # fmt: skip
                        out.append(cell)
                        print(json.dumps(cell), file=sys.stderr, flush=True)
    if args.markdown:
        print(
            "| fz noise | recordings | SNR_z | lag | lag used: median (range) | lags pooled (mean) | "
            "headline bias | spread between recordings / interval's sd | coverage before | coverage after | "
            "width after / before |"
        )
        print("|---|---|---|---|---|---|---|---|---|---|---|")
        for c in out:
            print(
                f"| {c['noise']} | {c['layout']} | {c['snr']:g} dB | {c['rule']} | {c['lags']} | {c['pooled']} | "
                f"{100 * c['bias']:+.2f} % | {c['spread']:.2f} | {_cp(c['before'], c['n'])} | "
                f"{_cp(c['after'], c['n'])} | {c['width']:.2f} |"
            )


if __name__ == "__main__":
    main()
