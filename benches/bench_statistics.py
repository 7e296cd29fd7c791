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
    args = ap.parse_args()
    if args.pipeline:
        pipeline(args.pipeline, args.repeats)
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
