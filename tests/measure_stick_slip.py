"""Measures stick-slip detection on the simulator of tests/stick_slip_sim.py (issue 35 point 1): the table of
docs/method.md 6g.

    PYTHONPATH=python:tests python tests/measure_stick_slip.py [--seeds 40] [--only NAME]

Per positive case (slip duration x rate x quantised or not): the runs whose count is within 5 % of the
simulated slips, whose amplitude (median drop) is within 10 % of the simulated one, and that read "present";
per negative case, the runs that read "present" (false). Each with its 95 % Clopper-Pearson interval.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Callable, List, Tuple

import numpy as np
import stick_slip_sim as sim
from scipy.stats import beta

import tribodyn as td
from tribodyn import simulate


def clopper_pearson(x: int, n: int) -> Tuple[float, float]:
    lo = 0.0 if x == 0 else float(beta.ppf(0.025, x, n - x + 1))
    hi = 1.0 if x == n else float(beta.ppf(0.975, x + 1, n - x))
    return lo, hi


def _conditions(seed: int) -> sim.Case:
    s = simulate.conditions(30, seed=seed, raw=True, y_noise=0.02, drift=0.05)
    return sim.Case(s.channels, s.fs, 0.0, np.zeros(0), np.zeros(0))


def cases() -> List[Tuple[str, Callable[[int], sim.Case]]]:
    out: List[Tuple[str, Callable[[int], sim.Case]]] = []
    for fs in (100.0, 1000.0, 10000.0):
        for slip in (0.001, 0.01, 0.1):
            for q in (None, sim.QUANTUM):
                name = f"slip {slip * 1000:g} ms, {fs:g} Hz, {'quantised' if q else 'float'}"
                out.append((name, lambda s, fs=fs, slip=slip, q=q: sim.stick_slip(s, fs=fs, slip=slip, quantum=q)))
    for fs in (100.0, 1000.0, 10000.0):
        out.append((f"smooth, {fs:g} Hz", lambda s, fs=fs: sim.smooth(s, fs=fs)))
    out.append(("smooth, paper rig (conditions, raw, drift)", _conditions))
    out.append(("1 Hz log, 0.1 N export", lambda s: sim.low_rate(s)))
    out.append(("1 Hz log, float", lambda s: sim.low_rate(s, quantum=None)))
    out.append(("quantised steady, 1 Hz, noise 0.2 steps", lambda s: sim.quantised_steady(s, fs=1.0, duration=1800,
                                                                                         noise=0.2)))  # fmt: skip
    out.append(("quantised steady, 1 kHz, noise 0.1 steps", lambda s: sim.quantised_steady(s)))
    return out


def measure(make: Callable[[int], sim.Case], seeds: range) -> Tuple[int, int, int, int, List[float], List[float]]:
    """(runs present, count within 5 %, amplitude within 10 %, all three, count errors, amplitude errors)."""
    present = counted = sized = good = 0
    cerr: List[float] = []
    aerr: List[float] = []
    for seed in seeds:
        c = make(seed)
        res = td.analyze(c.channels, fs=c.fs, motion="unidirectional")
        ss = td.stick_slip(c.channels, res)
        present += ss.present
        if c.present:
            ce = ss.events / c.starts.size - 1
            ae = ss.amplitude / c.amplitude - 1 if ss.events else float("nan")
            cerr.append(ce)
            aerr.append(ae)
            counted += abs(ce) <= 0.05
            sized += bool(abs(ae) <= 0.10)
            good += bool(ss.present and abs(ce) <= 0.05 and abs(ae) <= 0.10)
    return present, counted, sized, good, cerr, aerr


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=40)
    ap.add_argument("--only", default="")
    args = ap.parse_args()
    seeds = range(1, args.seeds + 1)
    n = len(seeds)
    print("| case | present | count within 5 % | amplitude within 10 % | all three (95 % CI) | "
          "count error (median, worst) | amplitude error (median, worst) |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    for name, make in cases():
        if args.only and args.only not in name:
            continue
        t = time.perf_counter()
        present, counted, sized, good, cerr, aerr = measure(make, seeds)
        if cerr:
            lo, hi = clopper_pearson(good, n)
            ce, ae = np.asarray(cerr), np.asarray(aerr)
            worst_c = ce[np.nanargmax(np.abs(ce))]
            worst_a = ae[np.nanargmax(np.abs(np.nan_to_num(ae, nan=np.inf)))]
            print(f"| {name} | {present}/{n} | {counted}/{n} | {sized}/{n} | {good}/{n} ({lo:.3f}-{hi:.3f}) | "
                  f"{np.median(ce):+.1%}, {worst_c:+.1%} | {np.nanmedian(ae):+.1%}, {worst_a:+.1%} |")  # fmt: skip
        else:
            lo, hi = clopper_pearson(present, n)
            print(f"| {name} | {present}/{n} false ({lo:.3f}-{hi:.3f}) | | | | | |")
        print(f"  ({time.perf_counter() - t:.0f} s)", file=sys.stderr, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
