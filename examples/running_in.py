"""Use case 3: where the running-in of a test ends, and the steady-state COF (docs/method.md 6h).

The recording is a simulated dead-weight pin-on-disc test (20 min at 50 Hz): the COF runs in from 0.30 to
0.15, exponentially, and the truth is known: the running-in ends at t_steady = 300 s (2 % of the transient
left). The COF wanders about its plateau (SD 0.002, correlated over 20 s), as on a real tribometer.

Run:  python running_in.py [OUT_DIR]      (default: ./running-in)
Writes OUT_DIR/cof_vs_time.png (the classical COF per window, the running-in shaded) and
OUT_DIR/steady_state.json.
"""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import tribodyn as td
from tribodyn import simulate
from tribodyn.app.figures import cof_vs_time, save_figure

out = Path(sys.argv[1] if len(sys.argv) > 1 else "running-in")
out.mkdir(parents=True, exist_ok=True)

# 1. A test with a known running-in (your own recording: td.open_recording(...) instead).
sim = simulate.running_in(seed=3, duration=1200.0, mu_0=0.30, mu_ss=0.15, t_steady=300.0)
res = td.analyze(sim.channels, fs=sim.fs, window=10, hop=10)  # 10 s windows tiling the test: 120 points
print("headline:", res.headline.text)  # the classical COF of the whole test, running-in included

# 2. The running-in and the steady state, on the headline's series (here the classical COF per window).
ss = td.steady_state(res)
print(ss.text)
print(f"verdict: {ss.verdict}; model {ss.model}, {ss.n_steady} of {ss.n} windows in the steady part")
print(f"truth: t_steady = {sim.t_steady:g} s, steady COF {sim.mu_ss:g}, initial COF {sim.mu_0:g}")
inside = ss.t_steady_low <= sim.t_steady <= ss.t_steady_high and ss.cof_low <= sim.mu_ss <= ss.cof_high
print("the truth lies in both 95 % intervals" if inside else "the truth lies outside an interval (1 test in 20)")
print("how:", ss.estimate)
print("intervals:", ss.interval)

# 3. A test that is still running in when it stops, and one too short to tell.
for label, kw in (("a test still running in at its end", dict(t_steady=3000.0)), ("an 80 s test", dict(duration=80.0))):
    other = simulate.running_in(seed=3, **kw)
    r = td.steady_state(td.analyze(other.channels, fs=other.fs, window=10, hop=10))
    print(f"{label}: {r.text}")

# 4. The COF against time with the running-in shaded (the figure reads it from params, as the CLI's
#    --steady-state does), and the result as JSON.
shaded = dataclasses.replace(res, params={**res.params, "steady_state": ss.to_dict()})
save_figure(cof_vs_time(shaded, title="Running-in and steady state"), out / "cof_vs_time.png")
(out / "steady_state.json").write_text(json.dumps(ss.to_dict(), indent=2), encoding="utf-8")
print(f"wrote {out / 'cof_vs_time.png'} and {out / 'steady_state.json'}")
