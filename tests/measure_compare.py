"""Measures the coverage of td.compare's 95 % interval (issue 35 point 8): the tables of docs/method.md 10a.

    PYTHONPATH=python python tests/measure_compare.py [--trials 3000] [--sim 200]

1. Synthetic: k tests with known standard errors s_i (uniform in a range), true values mu + u_i (u_i ~ N(0, tau^2)),
   observed y_i ~ N(true, s_i^2); the interval of the mean covers mu? (and the prediction interval a further test?)
2. Simulator: k replicate reciprocating tests of one condition (simulate.reciprocating, 10 cycles, COF 0.12 both
   ways, seeds apart), analysed; each per-stroke headline's interval and value as the analysis gives them; the
   interval of the comparison covers 0.12?
Each count with its 95 % Clopper-Pearson interval.
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.stats import beta

import tribodyn as td
from tribodyn import simulate
from tribodyn.results.headline import Headline

Z975 = 1.959963984540054


def cp(x: int, n: int) -> str:
    lo = 0.0 if x == 0 else float(beta.ppf(0.025, x, n - x + 1))
    hi = 1.0 if x == n else float(beta.ppf(0.975, x + 1, n - x))
    return f"{x}/{n} = {x / n:.3f} ({lo:.3f}-{hi:.3f})"


def head(value: float, se: float) -> Headline:
    h = Z975 * se
    return Headline(method="classical", value=value, low=value - h, high=value + h, statistic="mean", n=100,
                    fraction_used=1.0, estimate="synthetic", interval="synthetic")  # fmt: skip


def synthetic(trials: int) -> None:
    rng = np.random.default_rng(35)
    mu = 0.12
    cells = [(0.0, (0.001, 0.004)), (0.0, (0.0005, 0.003)), (0.002, (0.001, 0.004)), (0.005, (0.0005, 0.003))]
    print("| tests k | " + " | ".join(f"tau {t:g}, s_i {a:g}-{b:g}" for t, (a, b) in cells) + " |")
    print("|---" * (len(cells) + 1) + "|")
    for k in (2, 3, 5, 8, 12):
        row = []
        for tau, rg in cells:
            cover = predict = 0
            for _ in range(trials):
                se = rng.uniform(*rg, size=k)
                y = mu + tau * rng.standard_normal(k) + se * rng.standard_normal(k)
                c = td.compare([head(v, s) for v, s in zip(y, se)])
                cover += c.low <= mu <= c.high
                new = mu + tau * rng.standard_normal() + rng.uniform(*rg) * rng.standard_normal()
                predict += k >= 3 and c.prediction_low <= new <= c.prediction_high
            row.append(f"{cover / trials:.1%}" + (f" ({predict / trials:.1%})" if k >= 3 else ""))
        print(f"| {k} | " + " | ".join(row) + " |", flush=True)


def simulated(n: int) -> None:
    print("| tests k | comparisons covering 0.12 (95 % CI) | median width | widest | narrowest | low <= 0 |")
    print("|---|---|---|---|---|---|")
    for k, count in ((2, n), (3, n), (5, max(40, n // 2)), (8, max(40, n // 2))):
        cover = below = 0
        widths = []
        for trial in range(count):
            heads = []
            for j in range(k):
                sim = simulate.reciprocating(seed=100_000 * k + 100 * trial + j, cycles=10, mu_forward=0.12,
                                             mu_backward=0.12)  # fmt: skip
                heads.append(td.analyze(sim.channels, fs=sim.fs).headline)
            c = td.compare(heads)
            cover += c.low <= 0.12 <= c.high
            below += c.low <= 0
            widths.append(c.high - c.low)
        w = np.asarray(widths)
        print(f"| {k} | {cp(cover, count)} | {np.median(w):.2g} | {w.max():.2g} | {w.min():.2g} | {below} |",
              flush=True)  # fmt: skip


def between_tests(n: int) -> None:
    """8 reciprocating tests, each its own COF from N(0.12, 0.004^2), forward and backward +-0.01."""
    rng = np.random.default_rng(2035)
    cover = 0
    taus = []
    worst = 0.0
    for trial in range(n):
        mus = 0.12 + 0.004 * rng.standard_normal(8)
        heads = []
        for j, m in enumerate(mus):
            sim = simulate.reciprocating(seed=7_000_000 + 100 * trial + j, cycles=10, mu_forward=m + 0.01,
                                         mu_backward=m - 0.01)  # fmt: skip
            heads.append(td.analyze(sim.channels, fs=sim.fs).headline)
        worst = max(worst, max(abs(h.value - m) for h, m in zip(heads, mus)))
        c = td.compare(heads)
        cover += c.low <= 0.12 <= c.high
        taus.append(c.tau)
    t = np.asarray(taus)
    print(f"8 tests, tau 0.004: covered {cp(cover, n)}; tau {np.sqrt(np.mean(t * t)):.4f} (root mean square; median "
          f"{np.median(t):.4f}); every headline within {worst:.1e} of its test's COF")  # fmt: skip


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--trials", type=int, default=3000)
    ap.add_argument("--sim", type=int, default=200)
    ap.add_argument("--between", type=int, default=0, help="comparisons of 8 tests with tau 0.004 (only these)")
    args = ap.parse_args()
    if args.between:
        between_tests(args.between)
        return 0
    synthetic(args.trials)
    print()
    simulated(args.sim)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
