"""Use case 3: breakaway (static against kinetic COF) and stick-slip of a reciprocating test.

Simulates a ball-on-flat reciprocating test (2 Hz, 10 mm stroke, 10 N dead
weight, 1 kHz) whose friction has a breakaway peak 0.04 above the plateau
after every reversal and a saw-tooth stick-slip (0.2 N drops every 27.1 ms,
20 dB above the 0.02 N noise), then reads per stroke the static and the
kinetic COF (docs/method.md 6c) and the stick-slip events, their amplitude
and frequency (6g), each against the simulator's truth.

Run:  python stick_slip.py [OUT_DIR]         (default: ./stick-slip)
Writes OUT_DIR/strokes.csv (the per-stroke table) and OUT_DIR/stick_slip.png
(the friction force over one stroke with the drops found in its central half).
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import tribodyn as td  # noqa: E402
from tribodyn import simulate  # noqa: E402

out = Path(sys.argv[1] if len(sys.argv) > 1 else "stick-slip")
out.mkdir(parents=True, exist_ok=True)

sim = simulate.reciprocating(seed=3, breakaway=0.04, stick_slip=0.2, stick_slip_period=0.0271)
res = td.analyze(sim.channels, fs=sim.fs)  # the motion (reciprocating) and the strokes are found from v
print("headline:", res.headline.text)

# Static (breakaway) and kinetic COF per stroke: mu_static before the central part, mu over it.
st = res.strokes
for d, name, truth in ((1, "forward", sim.mu_static_forward), (-1, "backward", sim.mu_static_backward)):
    sel = (st["direction"] == d) & np.isfinite(st["mu_static"])
    print(
        f"{name} strokes: static COF {np.mean(st['mu_static'][sel]):.4f} (simulated peak {truth:.4f}), "
        f"kinetic COF {np.mean(st['mu'][sel]):.4f}, breakaway {1e3 * np.mean(st['t_static'][sel]):.1f} ms "
        f"after the reversal ({int(sel.sum())} strokes)"
    )
with open(out / "strokes.csv", "w", encoding="utf-8") as f:
    f.write(",".join(st) + "\n")
    for row in zip(*st.values()):
        f.write(",".join(f"{v:.6g}" for v in row) + "\n")

# Stick-slip: a function of its own (analyze stays as cheap as it was); fy and fz are read again.
ss = td.stick_slip(sim.channels, res)
print(ss.verdict)
print(f"  simulated: drops of 0.2 N every {1e3 * 0.0271:.1f} ms ({1 / 0.0271:.2f} Hz); noise {ss.noise:.4f} N")

# One stroke's friction force with the drops found.
k = 5
a, b = int(st["start"][k]), int(st["stop"][k])
t = np.arange(a, b) / sim.fs
fig, ax = plt.subplots(figsize=(7, 3.5))
ax.plot(t, st["direction"][k] * sim.channels["fy"][a:b], lw=0.8, label="friction force (stroke %d)" % k)
m = b - a  # the part searched: the central half, where mu (the kinetic COF) is measured
ax.axvspan((a + round(m / 4)) / sim.fs, (a + round(3 * m / 4)) / sim.fs, color="0.9", label="central half (searched)")
hit = (ss.times >= a / sim.fs) & (ss.times < b / sim.fs)
ax.vlines(ss.times[hit], 0.9, 1.6, colors="C3", lw=0.8, label="stick-slip drops found")
ax.set_xlabel("time (s)")
ax.set_ylabel("friction force (N)")
ax.legend(loc="lower center")
fig.tight_layout()
fig.savefig(out / "stick_slip.png", dpi=100)
print(f"wrote {out / 'strokes.csv'} and {out / 'stick_slip.png'}")
