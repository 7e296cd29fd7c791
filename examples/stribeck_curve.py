"""Use case 3: a Stribeck curve, the COF against sliding speed, with its regimes and 95 % intervals.

Simulates a pin-on-disc test under a dead weight of 10 N whose sliding speed
rises from 1 mm/s to 1 m/s over 10 minutes (``simulate.stribeck_sweep``: a
known Stribeck curve, lowest COF 0.0614 at 0.0262 m/s), analyses it with
the velocity channel ``v`` (each window's mean |v| is its ``speed``), fits
the bathtub of docs/method.md 7a on log speed and compares the result with
the simulator's truth. The same analysis with a speed log instead of a
velocity channel is ``analyze(..., covariates={"speed": (t, v)})``.

Run:  python stribeck_curve.py [OUT_DIR]         (default: ./stribeck-curve)
Writes OUT_DIR/stribeck_curve.png.
"""

from __future__ import annotations

import sys
from pathlib import Path

import tribodyn as td
from tribodyn import simulate
from tribodyn.app import figures

out = Path(sys.argv[1] if len(sys.argv) > 1 else "stribeck-curve")
out.mkdir(parents=True, exist_ok=True)

sim = simulate.stribeck_sweep(seed=1)  # channels fy, fz (N) and v (m/s) at 100 Hz
res = td.analyze(sim.channels, fs=sim.fs, window=5, hop=5)
print(f"headline: {res.headline}")  # a dead weight: the classical COF

opr = td.operating_range(res, by="speed")  # log speed axis, the headline's COF per window
print(f"speed: verdict {opr.verdict!r} ({opr.n_windows} windows, {opr.cof} COF)")
print(f"  {opr.explanation}")
f = opr.fits["all"]
for side in ("lower", "upper"):
    b, ci = getattr(f, side), getattr(f, f"{side}_ci")
    if b is not None and ci is not None:
        print(f"  {side} breakpoint {b:.4f} m/s, 95 % interval {ci[0]:.4f} to {ci[1]:.4f} m/s")
if opr.mu_min_ci is not None:
    print(f"  lowest COF {opr.mu_min:.4f} (95 % interval {opr.mu_min_ci[0]:.4f} to {opr.mu_min_ci[1]:.4f})")
m = sim.model
# A smooth minimum has no flat floor: the optimum's ends sit next to it, within their 95 % intervals.
ci = opr.optimum_ci
inside = ci is not None and ci[0][0] <= m.v_min <= ci[1][1]
print(
    f"  true minimum: COF {m.mu_min:.4f} at {m.v_min:.4f} m/s ({'inside' if inside else 'outside'} the optimum "
    "with its 95 % intervals)"
)

# The same test with the controller's speed log (time in s, m/s) instead of the velocity channel.
forces = {k: v for k, v in sim.channels.items() if k != "v"}
res_log = td.analyze(forces, fs=sim.fs, window=5, hop=5, covariates={"speed": sim.speed_log})
opr_log = td.operating_range(res_log, "speed", n_boot=0)  # the fit alone, no intervals
print(f"from the speed log: optimum {opr_log.optimum[0]:.4f} to {opr_log.optimum[1]:.4f} m/s")

figures.save_figure(figures.stribeck_curve(res, opr), out / "stribeck_curve.png")
print(f"wrote the figure to {out}/")
