"""Accuracy of the Stribeck curve against the simulator's truth (docs/method.md 7a).

For each seed, ``simulate.stribeck_sweep`` (600 s, 100 Hz, speed 1e-3 -> 1
m/s log-uniform, dead weight 10 N, the default Stribeck model: minimum 0.0614
at 0.0262 m/s) is analysed with 5 s windows tiling it and
``operating_range(res, "speed")`` fits the bathtub on log speed (the
classical COF per window: a dead weight). Counted over the seeds:

- the verdict "optimum";
- the true minimum-COF speed v_min inside the reported optimum [lower, upper],
  and inside it widened by the breakpoints' 95 % intervals;
- the straight-wall breakpoints of the noise-free curve (the same fit on the
  model's COF at the same windows, no bootstrap) inside the 95 % intervals
  of the lower and upper breakpoint, and their distance in decades;
- the flat-bottom COF against the true minimum and against the noise-free fit's.

Run: ``python benches/bench_stribeck.py [--seeds 20] [--steps 0] [--markdown]``.

``--cost`` instead times the speed column on one hour at 1 kHz (fx, fy, fz
with and without a velocity channel, float64 channels-first ``.npy`` in a
temporary folder, 2 threads, best of 3) for three window grids.
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np
import tribodyn as td
from tribodyn import simulate


def one(seed: int, steps: int) -> dict:
    sim = simulate.stribeck_sweep(seed=seed, steps=steps)
    res = td.analyze(sim.channels, fs=sim.fs, window=5.0, hop=5.0)
    opr = td.operating_range(res, "speed")
    table = dict(res.table)
    table["mu_classical"] = sim.mu_at(res["time"])
    twin = td.operating_range(dataclasses.replace(res, table=table), "speed", n_boot=0, cof="classical")
    f, t = opr.fits["all"], twin.fits["all"]
    m = sim.model
    out = dict(verdict=opr.verdict, cof=opr.cof, twin_verdict=twin.verdict)
    if f.lower is None or f.upper is None or t.lower is None or t.upper is None:
        return out
    out.update(
        vmin_in=f.lower <= m.v_min <= f.upper,
        vmin_ci=f.lower_ci is not None and f.upper_ci is not None and f.lower_ci[0] <= m.v_min <= f.upper_ci[1],
        lower_in=f.lower_ci is not None and f.lower_ci[0] <= t.lower <= f.lower_ci[1],
        upper_in=f.upper_ci is not None and f.upper_ci[0] <= t.upper <= f.upper_ci[1],
        d_lower=abs(np.log10(f.lower / t.lower)),
        d_upper=abs(np.log10(f.upper / t.upper)),
        mu_err=f.mu_min - m.mu_min,
        mu_twin_err=f.mu_min - t.mu_min,
        mu_ci_twin=f.mu_min_ci is not None and f.mu_min_ci[0] <= t.mu_min <= f.mu_min_ci[1],
        mu_ci_true=f.mu_min_ci is not None and f.mu_min_ci[0] <= m.mu_min <= f.mu_min_ci[1],
        lower=f.lower,
        upper=f.upper,
        twin_lower=t.lower,
        twin_upper=t.upper,
    )
    return out


def cost() -> None:
    fs, n = 1000.0, 3_600_000
    rng = np.random.default_rng(0)
    fz = rng.standard_normal(n)
    chans = [0.1 * rng.standard_normal(n), -0.12 * fz + 0.01 * rng.standard_normal(n), fz]
    v = 0.28 * (1 + 0.01 * rng.standard_normal(n))
    with tempfile.TemporaryDirectory() as tmp:
        f3, f4 = Path(tmp) / "f3.npy", Path(tmp) / "f4.npy"
        np.save(f3, np.stack(chans))
        np.save(f4, np.stack([*chans, v]))
        del chans, v, fz

        def run(path: Path, names: list, **kw: float) -> tuple:
            best, route = float("inf"), ""
            for _ in range(3):
                with td.open_recording(path, fs=fs, names=names) as rec:
                    t0 = time.perf_counter()
                    res = td.analyze(rec, threads=2, **kw)
                    best = min(best, time.perf_counter() - t0)
                    route = res.params["route"]
            return best, route, len(res)

        for win, hop in ((2.0, 10.0), (2.0, 2.0), (0.1, 0.1)):
            a = run(f3, ["fx", "fy", "fz"], window=win, hop=hop)
            b = run(f4, ["fx", "fy", "fz", "velocity"], window=win, hop=hop)
            print(f"window {win} s, hop {hop} s ({a[2]} windows): forces {a[0]:.2f} s ({a[1]}), "
                  f"with v {b[0]:.2f} s ({b[1]}), ratio {b[0] / a[0]:.2f}")  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--steps", type=int, default=0, help="0: a continuous log ramp; n: n speed steps")
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument("--cost", action="store_true", help="time the speed column on one hour at 1 kHz instead")
    ns = ap.parse_args()
    if ns.cost:
        cost()
        return
    rows = [one(s, ns.steps) for s in range(ns.seeds)]
    n = len(rows)
    fitted = [r for r in rows if "vmin_in" in r]
    k = len(fitted)

    def count(key: str) -> str:
        return f"{sum(bool(r[key]) for r in fitted)}/{k}"

    d_lo = np.array([r["d_lower"] for r in fitted])
    d_hi = np.array([r["d_upper"] for r in fitted])
    mu = np.array([r["mu_err"] for r in fitted])
    mut = np.array([r["mu_twin_err"] for r in fitted])
    tw = fitted[0] if fitted else {}
    sweep = "continuous log ramp" if ns.steps == 0 else f"{ns.steps} steps"
    lines = [
        f"| {sweep}, {n} seeds | |",
        "| --- | --- |",
        f"| verdict 'optimum' | {sum(r['verdict'] == 'optimum' for r in rows)}/{n} (COF fitted: {rows[0]['cof']}) |",
        f"| true v_min = {simulate.StribeckModel().v_min:.4f} m/s inside [lower, upper]; inside [lower's 2.5 %, "
        f"upper's 97.5 %] | {count('vmin_in')}; {count('vmin_ci')} |",
        f"| noise-free breakpoints ({tw.get('twin_lower', float('nan')):.4f}, {tw.get('twin_upper', float('nan')):.3f}"
        f" m/s) in the 95 % intervals | lower {count('lower_in')}, upper {count('upper_in')} |",
        f"| distance to them, decades (median, max) | lower {np.median(d_lo):.3f}, {d_lo.max():.3f}; "
        f"upper {np.median(d_hi):.3f}, {d_hi.max():.3f} |",
        f"| flat bottom - true minimum COF (median, max abs); true minimum in its 95 % interval | "
        f"{np.median(mu):+.4f}, {np.abs(mu).max():.4f}; {count('mu_ci_true')} |",
        f"| flat bottom - noise-free fit's (median, max abs); in its 95 % interval | {np.median(mut):+.4f}, "
        f"{np.abs(mut).max():.4f}; {count('mu_ci_twin')} |",
    ]
    print("\n".join(lines) if ns.markdown else "\n".join(line.strip("|").replace(" | ", ": ") for line in lines))


if __name__ == "__main__":
    main()
