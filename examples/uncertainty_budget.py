"""A COF you can defend: the instrument's uncertainty budget combined with the statistics (docs/method.md 6i).

One simulated instrument, misaligned by 0.4 degree, its calibrations 0.3 %
off, with an fy offset and some crosstalk, measures two tests of a contact
whose true COF is 0.100: a unidirectional one and a reciprocating one. The
lab states what it knows of its instrument (standard uncertainties, a
calibration file); tribodyn propagates it through the headline's own
estimator by Monte Carlo (JCGM 101) and prints the budget. The statistical
interval alone misses the truth by far on the unidirectional test; the
budget's interval covers it, and the reciprocating test's per-stroke mean
cancels the misalignment (its share of the budget is near zero).

Run:  python uncertainty_budget.py [OUT_DIR]      (default: ./uncertainty-budget)
Writes OUT_DIR/calibration.toml (the lab's statement), OUT_DIR/reciprocating.npz
and OUT_DIR/report/ (``tribodyn analyze --calibration``: report.html with the
budget under the headline, summary.json).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

import tribodyn as td
from tribodyn import simulate
from tribodyn.app import cli
from tribodyn.kernels import uncertainty as unc

out = Path(sys.argv[1] if len(sys.argv) > 1 else "uncertainty-budget")
out.mkdir(parents=True, exist_ok=True)
MU = 0.100

# What the lab knows of its instrument (each a standard uncertainty; see docs/method.md 6i).
statement = {
    "fy_rel": 0.003,
    "fz_rel": 0.003,
    "fy_abs": {"u": 0.01, "distribution": "rectangular"},
    "fz_abs": 0.02,
    "misalignment_deg": {"u": 0.3, "distribution": "rectangular"},
    "crosstalk": {"u": 0.002, "distribution": "triangular"},
}
# The instrument as it is (unknown to the lab): within what the statement allows.
instrument = unc.Instrument(g_y=0.003, g_z=-0.002, o_y=0.012, o_z=0.01, theta=math.radians(0.4), k_y=0.002)
rng = np.random.default_rng(5)

# A unidirectional test: a dead weight of 10 N, 60 s at 1 kHz.
n = 60_000
load = 10.0 + 0.3 * np.sin(2 * np.pi * np.arange(n) / n)
fy, fz = unc.through(instrument, MU * load, load)
uni = {"fy": fy + 0.02 * rng.standard_normal(n), "fz": fz + 0.02 * rng.standard_normal(n)}
res = td.analyze(uni, fs=1000.0, motion="unidirectional", uncertainty=statement)
h = res.headline
print("unidirectional:", h.text)
print(f"  statistical interval alone: {h.low:.4f} to {h.high:.4f} (truth {MU:.3f}: outside)")
print("  budget:")
for line in unc.rows_text(h.uncertainty):  # type: ignore[arg-type]
    print("   ", line)

# A reciprocating test through the same instrument (the simulator's forces, noise-free, then measured).
sim = simulate.reciprocating(seed=2, cycles=30, mu_forward=MU, mu_backward=MU, noise=0.0)
ch = dict(sim.channels)
fy, fz = unc.through(instrument, ch["fy"], ch["fz"])
ch["fy"] = fy + 0.02 * rng.standard_normal(fy.size)
ch["fz"] = fz + 0.02 * rng.standard_normal(fz.size)
res_r = td.analyze(ch, fs=sim.fs, uncertainty=statement)
u = res_r.headline.uncertainty
assert u is not None
share = next(r.share for r in u.budget if r.source == "misalignment_deg")
print("reciprocating:", res_r.headline.text)
print(f"  misalignment's share of the budget: {100 * share:.3f} % (cancelled by the forward/backward mean)")
print(f"  Monte Carlo u_c {u.u_c:.2g}, GUM u_c {u.gum['u_c']:.2g}; the instrument's part {u.instrument_u:.2g}")

# The lab's calibration file, and the command line with it.
(out / "calibration.toml").write_text(
    'instrument = "rig 1, two-axis load cell"\n'
    "fy_rel = 0.003\nfz_rel = 0.003\n"
    'fy_abs = {u = 0.01, distribution = "rectangular"}\nfz_abs = 0.02\n'
    'misalignment_deg = {u = 0.3, distribution = "rectangular"}\n'
    'crosstalk = {u = 0.002, distribution = "triangular"}\n',
    encoding="utf-8",
)
np.savez(out / "reciprocating.npz", **ch)
args = ["analyze", str(out / "reciprocating.npz"), "--fs", "1000", "--calibration", str(out / "calibration.toml"),
        "--out", str(out / "report"), "--overwrite", "-q"]  # fmt: skip
status = cli.main(args)
print(f"report with the budget: {out / 'report' / 'report.html'} (exit status {status})")
