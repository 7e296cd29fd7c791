"""Coverage and bias of :func:`tribodyn.steady_state` against the simulator's t_steady (docs/method.md 6h).

Each condition simulates ``--tests`` dead-weight tests (``tribodyn.simulate.running_in``, seeds 1000, 1001,
...; 1200 s at 50 Hz, analysed in 10 s windows tiling it: 120 points) and counts:

- verdict "steady state reached" (tests with a steady state) or "no steady state" (those without);
- coverage: the tests whose 95 % interval of t_steady (and of the steady COF) holds the truth (t_steady,
  and the plateau mu_ss: the process mean, not the realised mean of the wander);
- bias and SD of t_steady (s) and of the steady COF over the tests that reached a steady state.

Run: ``python benches/bench_steady.py [--tests 100] [--markdown]``; the table in docs/method.md 6h is its
``--markdown`` output.
"""

from __future__ import annotations

import argparse
import math
import time
from typing import Any, Dict, List, Tuple

import numpy as np
import tribodyn as td
from tribodyn import simulate

CONDITIONS: List[Tuple[str, Dict[str, Any]]] = [
    ("exponential, 0.30 -> 0.15, t_steady 300 s", {}),
    ("exponential, t_steady 700 s", dict(t_steady=700.0)),
    ("exponential, small: 0.17 -> 0.15", dict(mu_0=0.17)),
    ("exponential, rising: 0.10 -> 0.15", dict(mu_0=0.10)),
    ("linear ramp, t_steady 300 s", dict(shape="linear")),
    ("wander correlated over 5 s", dict(wander_time=5.0)),
    ("wander correlated over 60 s", dict(wander_time=60.0)),
    ("no wander (white noise only)", dict(wander=0.0)),
    ("flat (t_steady 0)", dict(t_steady=0.0)),
    ("still running in: t_steady 3000 s", dict(t_steady=3000.0)),
    ("drift +2e-5 per s (+16 % in the test)", dict(drift=2e-5)),
]


def run(kw: Dict[str, Any], tests: int) -> Dict[str, Any]:
    rows = []
    for k in range(tests):
        sim = simulate.running_in(seed=1000 + k, **kw)
        res = td.analyze(sim.channels, fs=sim.fs, window=10.0, hop=10.0)
        rows.append((sim, td.steady_state(res)))
    reached = [(s, r) for s, r in rows if r.ok]
    out: Dict[str, Any] = {"tests": tests, "reached": len(reached), "truth_reached": rows[0][0].reached}
    if reached:
        et = np.array([r.t_steady - s.t_steady for s, r in reached])
        ec = np.array([r.cof - s.mu_ss for s, r in reached])
        out.update(
            t_cover=sum(r.t_steady_low <= s.t_steady <= r.t_steady_high for s, r in reached),
            c_cover=sum(r.cof_low <= s.mu_ss <= r.cof_high for s, r in reached),
            t_bias=float(et.mean()), t_sd=float(et.std(ddof=1)) if et.size > 1 else math.nan,
            c_bias=float(ec.mean()), c_sd=float(ec.std(ddof=1)) if ec.size > 1 else math.nan,
            t_width=float(np.mean([r.t_steady_high - r.t_steady_low for _, r in reached])),
        )  # fmt: skip
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tests", type=int, default=100, help="simulated tests per condition (default 100)")
    ap.add_argument("--markdown", action="store_true", help="print the table of docs/method.md 6h")
    ns = ap.parse_args()
    start = time.perf_counter()
    print(
        "| condition | tests | verdict as the truth | t_steady in its 95 % interval | bias +- SD of t_steady (s) "
        "| mean width (s) | steady COF in its interval | bias +- SD of the steady COF |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name, kw in CONDITIONS:
        r = run(kw, ns.tests)
        n, ok = r["tests"], r["reached"]
        right = ok if r["truth_reached"] else n - ok
        if ok and r["truth_reached"]:
            cells = [
                f"{r['t_cover']} of {ok} ({100 * r['t_cover'] / ok:.0f} %)",
                f"{r['t_bias']:+.1f} +- {r['t_sd']:.1f}",
                f"{r['t_width']:.0f}",
                f"{r['c_cover']} of {ok} ({100 * r['c_cover'] / ok:.0f} %)",
                f"{r['c_bias']:+.5f} +- {r['c_sd']:.5f}",
            ]
        else:
            cells = ["-"] * 5
        print(f"| {name} | {n} | {right} of {n} | " + " | ".join(cells) + " |", flush=True)
    if not ns.markdown:
        print(f"({time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()
