"""Use case 3: eight replicate tests in two laboratories compared (docs/method.md 10).

Simulates eight reciprocating ball-on-flat tests (four per laboratory): each
laboratory has its own mean COF and each test its own COF around it, the
truth being known. Each test is analysed (its headline: the per-stroke COF
with a 95 % interval), then :func:`tribodyn.compare` pools them: the
random-effects mean with its 95 % interval, the between-test SD, where a
further test would land, and, with the laboratories as groups, the ISO 5725
repeatability s_r and reproducibility s_R with Mandel's h and k.

The same from the command line, after ``tribodyn analyze`` of each
laboratory's files (``--meta`` records the test conditions)::

    tribodyn analyze labA/*.npz --out labA --meta load=10 --meta "speed=20 mm/s"
    tribodyn analyze labB/*.npz --out labB --meta load=10 --meta "speed=20 mm/s"
    tribodyn compare labA labB --out replicates --groups A,B

Run:  python compare_replicates.py [OUT_DIR]      (default: ./compare-replicates)
Writes OUT_DIR/compare.png and OUT_DIR/compare.csv.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import tribodyn as td
from tribodyn import simulate
from tribodyn.app import figures

out = Path(sys.argv[1] if len(sys.argv) > 1 else "compare-replicates")
out.mkdir(parents=True, exist_ok=True)

rng = np.random.default_rng(42)
lab_mean = {"A": 0.118, "B": 0.125}  # each laboratory's true COF
within = 0.002  # true SD between tests of one laboratory (repeatability)
results, labels, groups, truth = [], [], [], []
for lab, mu_lab in lab_mean.items():
    for k in range(4):
        mu = mu_lab + within * rng.standard_normal()
        # forward and backward strokes differ (0.01): the per-stroke COF is their average
        sim = simulate.reciprocating(seed=10 * len(results) + 1, cycles=10, mu_forward=mu + 0.005,
                                     mu_backward=mu - 0.005)  # fmt: skip
        results.append(td.analyze(sim.channels, fs=sim.fs))
        labels.append(f"{lab}{k + 1}")
        groups.append(lab)
        truth.append(mu)

cmp = td.compare(results, labels=labels, groups=groups)
for rep, mu in zip(cmp.replicates, truth):
    print(f"{rep.label}: {rep.headline.short} (true COF {mu:.4f}), weight {100 * rep.weight:.1f} %")
print(cmp.text)
print(f"  how: {cmp.pooling}")
p = cmp.precision
assert p is not None
print(f"  general mean {p.mean:.4f} (95 % interval {p.low:.4f} to {p.high:.4f}); mean of the true COFs "
      f"{np.mean(truth):.4f}")  # fmt: skip
print(f"  repeatability s_r {p.s_r:.4f} (simulated {within}), reproducibility s_R {p.s_R:.4f}; limits r {p.r:.4f}, "
      f"R {p.R:.4f}")  # fmt: skip
for g, h, k, flag in zip(p.groups, p.h, p.k, p.flags):
    print(f"  laboratory {g}: Mandel's h {h:+.2f}, k {k:.2f}" + (f" ({flag})" if flag else ""))
for note in cmp.notes:
    print(f"  note: {note}")

figures.save_figure(cmp.figure(), out / "compare.png")
cmp.to_frame().to_csv(out / "compare.csv", index=False)
print(f"wrote {out}/compare.png and {out}/compare.csv")
