"""Measures stick-slip detection on the simulator of tests/stick_slip_sim.py (issue 35 point 1): the table of
docs/method.md 6g.

    PYTHONPATH=python:tests python tests/measure_stick_slip.py [--seeds 40] [--only NAME]
    PYTHONPATH=python:tests python tests/measure_stick_slip.py --claims   # the other claims of 6g, re-measured
    PYTHONPATH=python:tests python tests/measure_stick_slip.py --sample   # a long search's sample against every block

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
from tribodyn.pipeline import stickslip


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


def _sure(sim: simulate.ReciprocatingSimulation, res: td.Results, edge: int) -> int:
    """Simulated drops at least ``edge`` samples inside the strokes' central halves."""
    a, b = res.strokes["start"], res.strokes["stop"]
    m = b - a
    c0 = a + np.round(m * 0.25).astype(int)
    c1 = a + np.round(m * 0.75).astype(int)
    j = sim.slip_times * sim.fs
    inside = np.zeros(j.size, bool)
    for x0, x1 in zip(c0, c1):
        inside |= (j >= x0 + edge) & (j <= x1 - edge)
    return int(inside.sum())


def claims() -> None:
    """The reciprocating and smooth claims of docs/method.md 6g, re-measured."""
    edge = 2 * stickslip.SMOOTH + 2
    counts = []
    amp = []
    freq = []
    for seed in range(1, 11):
        for period in (0.0233, 0.0271, 0.0307):
            sim = simulate.reciprocating(seed=seed, stick_slip=0.2, stick_slip_period=period, noise=0.02)
            res = td.analyze(sim.channels, fs=sim.fs)
            ss = td.stick_slip(sim.channels, res)
            counts.append((ss.events, _sure(sim, res, edge)))
            amp.append(ss.amplitude / 0.2 - 1)
            freq.append(ss.frequency * period - 1)
    ev = np.array(counts)
    print(f"reciprocating 20 dB, 30 tests: events {ev[:, 0].sum()} against {ev[:, 1].sum()} drops {edge} samples "
          f"inside the central halves (per test {np.min(ev[:, 0] - ev[:, 1])} to {np.max(ev[:, 0] - ev[:, 1])}); "
          f"median drop error {np.mean(amp):+.2%} mean, {np.max(np.abs(amp)):.2%} worst; frequency error "
          f"{np.max(np.abs(freq)):.2%} worst")  # fmt: skip
    for noise in (0.2 / 10 ** (17 / 20), 0.2 / 10 ** (15.6 / 20), 0.2 / 10 ** (14 / 20)):
        got = []
        for seed in (1, 2, 3):
            sim = simulate.reciprocating(seed=seed, stick_slip=0.2, stick_slip_period=0.0271, noise=noise)
            res = td.analyze(sim.channels, fs=sim.fs)
            ss = td.stick_slip(sim.channels, res)
            got.append((ss.events / max(_sure(sim, res, edge), 1), ss.amplitude / 0.2 - 1))
        snr = 20 * np.log10(0.2 / noise)
        print(f"SNR {snr:.1f} dB: found {', '.join(f'{g[0]:.0%}' for g in got)}; "
              f"median drop {', '.join(f'{g[1]:+.1%}' for g in got)}")  # fmt: skip
    smooth = []
    for seed in range(1, 11):
        for kw in ({}, {"fz_dynamic": 1.0}, {"breakaway": 0.04}):
            sim = simulate.reciprocating(seed=seed, **kw)  # type: ignore[arg-type]
            smooth.append(td.stick_slip(sim.channels, td.analyze(sim.channels, fs=sim.fs)).events)
    print(f"smooth reciprocating (plain, fz_dynamic 1 N, breakaway; 10 seeds each): events {smooth}")
    uni = []
    for seed in range(1, 21):
        for kw in (
            {"y_noise": 0.02, "drift": 0.05},
            {"y_noise": 0.02, "y_noise_kind": "band"},
            {"y_noise": 0.02, "snr_z": 20.0},
            {"y_noise": 0.02, "ripple": 0.05},
        ):
            s = simulate.conditions(30, seed=seed, raw=True, **kw)  # type: ignore[arg-type]
            r = td.stick_slip(s.channels, td.analyze(s.channels, fs=s.fs))
            uni.append((r.events, r.present))
    print(f"smooth unidirectional conditions(raw) x 30 s (drift; band noise; fz noise 20 dB; 5 % ripple; 20 seeds "
          f"each): {sum(e for e, _ in uni)} events in {sum(e > 0 for e, _ in uni)} of {len(uni)} recordings, "
          f"{sum(p for _, p in uni)} present")  # fmt: skip


def sample_against_blocks() -> None:
    """A long search's noise and events from the sample against both passes over every block (6g, One reading)."""
    import time

    runs = []
    for seed, period in ((1, 0.0233), (2, 0.0271), (3, 0.0307)):
        rec = simulate.reciprocating(seed=seed, cycles=5000, stick_slip=0.2, stick_slip_period=period)
        runs.append((f"reciprocating stick-slip {period * 1e3:.1f} ms, seed {seed}", rec))
    runs.append(("reciprocating breakaway + dynamic load, stick-slip, seed 4",
                 simulate.reciprocating(seed=4, cycles=5000, stick_slip=0.2, stick_slip_period=0.0271,
                                        breakaway=0.04, fz_dynamic=1.0)))  # fmt: skip
    runs.append(("reciprocating smooth, seed 5", simulate.reciprocating(seed=5, cycles=5000)))
    for seed in (1, 2):
        runs.append((f"conditions(2500, raw, drift), seed {seed}",
                     simulate.conditions(2500, seed=seed, raw=True, y_noise=0.02, drift=0.05)))  # fmt: skip
    for name, rec in runs:
        res = td.analyze(rec.channels, fs=rec.fs)
        t = time.perf_counter()
        one = td.stick_slip(rec.channels, res)
        t1 = time.perf_counter() - t
        keep = stickslip.SAMPLE
        stickslip.SAMPLE = 1 << 40  # every block for the noise: the recording read twice
        try:
            t = time.perf_counter()
            two = td.stick_slip(rec.channels, res)
            t2 = time.perf_counter() - t
        finally:
            stickslip.SAMPLE = keep
        print(f"{name}: noise {one.noise / two.noise - 1:+.2%}, events {one.events} against {two.events}; "
              f"{t1:.2f} s (sample) and {t2:.2f} s (every block twice)", flush=True)  # fmt: skip


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=40)
    ap.add_argument("--only", default="")
    ap.add_argument("--claims", action="store_true")
    ap.add_argument("--sample", action="store_true")
    args = ap.parse_args()
    if args.claims:
        claims()
        return 0
    if args.sample:
        sample_against_blocks()
        return 0
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
