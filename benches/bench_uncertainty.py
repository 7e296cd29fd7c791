"""Coverage of the headline's uncertainty budget (issue 36; docs/method.md 6i), and the Monte Carlo's cost.

An instrument simulator: for each simulated instrument, its calibration
gains, offsets, misalignment and crosstalk are drawn from the stated
distributions (``uncertainty.instrument``), true forces are measured
through it (``uncertainty.through``), measurement noise is added, and the
recording is analysed with the same statement ``analyze(uncertainty=...)``.
Per case (unidirectional classical, reciprocating per-stroke, dynamic) it
counts how often the 95 % interval of the budget covers the true COF, how
often the statistical interval alone does, the misalignment's mean share of
the budget and the largest relative difference between the Monte Carlo's and
GUM's u_c. Then the Monte Carlo's cost on a 10 h recording's statistics
(they do not depend on the length: a 10 h recording's sums are the same
4 x 3 x 2 numbers).

Usage::

    python benches/bench_uncertainty.py --instruments 200
"""

from __future__ import annotations

import argparse
import time
from typing import Any, Dict, Tuple

import numpy as np

import tribodyn as td
from tribodyn import simulate
from tribodyn.kernels import uncertainty as unc
from tribodyn.results import Headline

#: The lab's statement of its instrument (the same in every case).
STATEMENT: Dict[str, Any] = {
    "fy_rel": {"u": 0.005, "distribution": "normal", "dof": 10},
    "fz_rel": 0.003,
    "fy_abs": {"u": 0.01, "distribution": "rectangular"},
    "fz_abs": 0.02,
    "misalignment_deg": {"u": 0.3, "distribution": "rectangular"},
    "crosstalk": {"u": 0.002, "distribution": "triangular"},
}
MU = 0.1
NOISE = 0.02  # N, each channel, after the instrument
FS = 1000.0


def unidirectional(inst: unc.Instrument, rng: np.random.Generator, seconds: float = 60.0) -> Dict[str, np.ndarray]:
    """A dead-weight test: fz = 10 N with a slow wander (no dynamic content the regression could use)."""
    n = int(seconds * FS)
    t = np.arange(n) / FS
    fz = 10.0 + 0.3 * np.sin(2 * np.pi * t / seconds + rng.uniform(0, 6.3))
    fy, fz = unc.through(inst, MU * fz, fz)
    return {"fy": fy + NOISE * rng.standard_normal(n), "fz": fz + NOISE * rng.standard_normal(n)}


def reciprocating(inst: unc.Instrument, rng: np.random.Generator, seed: int) -> Dict[str, np.ndarray]:
    """The simulator's reciprocating test (equal COF both ways), noise-free, measured through ``inst``."""
    sim = simulate.reciprocating(seed=seed, cycles=30, mu_forward=MU, mu_backward=MU, noise=0.0)
    ch = dict(sim.channels)
    fy, fz = unc.through(inst, ch["fy"], ch["fz"])
    n = fy.size
    ch["fy"] = fy + NOISE * rng.standard_normal(n)
    ch["fz"] = fz + NOISE * rng.standard_normal(n)
    return ch


def dynamic(inst: unc.Instrument, seed: int) -> Dict[str, np.ndarray]:
    """The paper's rig (dynamic forces, COF MU), its channels measured through ``inst``."""
    parts = list(simulate.continuous(120.0, mu=MU, seed=seed))
    ch = {k: np.concatenate([p[k] for p in parts]) for k in ("fy", "fz")}
    fy, fz = unc.through(inst, ch["fy"], ch["fz"])
    return {"fy": fy, "fz": fz}


def one(case: str, seed: int) -> Tuple[bool, bool, float, float, str]:
    """(budget covers, statistics cover, misalignment share, |MC - GUM| / GUM, method) of one instrument."""
    rng = np.random.default_rng(10_000 + seed)
    inputs = unc.parse_inputs(STATEMENT)
    assert inputs is not None
    inst = unc.instrument(inputs, rng)
    if case == "unidirectional":
        data, kw = unidirectional(inst, rng), {"motion": "unidirectional"}
    elif case == "reciprocating":
        data, kw = reciprocating(inst, rng, seed), {"motion": "reciprocating"}
    else:
        data, kw = dynamic(inst, seed), {}
    res = td.analyze(data, fs=FS, uncertainty=STATEMENT, **kw)
    h = res.headline
    u = h.uncertainty
    if u is None:
        raise RuntimeError(f"{case} seed {seed}: no budget ({h.text})")
    share = next((r.share for r in u.budget if r.source == "misalignment_deg"), float("nan"))
    gum = abs(u.u_c - u.gum["u_c"]) / u.gum["u_c"]
    return bool(u.low <= MU <= u.high), bool(h.low <= MU <= h.high), share, gum, h.method


def coverage(case: str, n: int, first: int = 0) -> Dict[str, Any]:
    rows = [one(case, s) for s in range(first, first + n)]
    cov = np.mean([r[0] for r in rows])
    stat = np.mean([r[1] for r in rows])
    p = 0.95
    return {
        "case": case,
        "methods": sorted({r[4] for r in rows}),
        "instruments": n,
        "budget_coverage": float(cov),
        "binomial_se": float(np.sqrt(p * (1 - p) / n)),
        "statistical_coverage": float(stat),
        "misalignment_share": float(np.mean([r[2] for r in rows])),
        "mc_vs_gum_max": float(np.max([r[3] for r in rows])),
    }


def cost(repeats: int = 5) -> Dict[str, float]:
    """Seconds of ``propagate`` (2e5 draws) on a 10 h recording's statistics (the sums of 36e6 samples)."""
    rng = np.random.default_rng(1)
    n = 2_000_000  # the sums of r^j u^k of 36e6 samples are those of any sample of them, scaled: 4 x 3 x 2 numbers
    fz = 10 + 0.02 * rng.standard_normal(n)
    fy = MU * fz + 0.02 * rng.standard_normal(n)
    mom = unc.Moments("classical", unc.ratio_sums(fy, fz) / n, 36_000_000)
    head = Headline("classical", mom.value, mom.value - 1e-5, mom.value + 1e-5, "mean", 36_000_000, 1.0)
    inputs = unc.parse_inputs(STATEMENT)
    assert inputs is not None
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        unc.propagate(head, mom, inputs, stat_dof=31)
        times.append(time.perf_counter() - t0)
    return {"propagate_median_s": float(np.median(times)), "propagate_max_s": float(np.max(times))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--instruments", type=int, default=200)
    ap.add_argument("--cases", default="unidirectional,reciprocating,dynamic")
    args = ap.parse_args()
    for case in args.cases.split(","):
        t0 = time.perf_counter()
        out = coverage(case, args.instruments)
        out["seconds"] = round(time.perf_counter() - t0, 1)
        print(out, flush=True)
    print(cost())


if __name__ == "__main__":
    main()
