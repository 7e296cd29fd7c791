"""Use case 1: analyse one recording, read the verdict and the COF with its 95 % interval.

The recording is the simulated current-density test of the paper's rig (700 s,
1 kHz, forces fx, fy, fz and the brush current), written to a file first so
the example goes the way your own data would: a file on disk, opened with
``tribodyn.open_recording`` and a channel map, analysed window by window.

Run:  python analyse_a_recording.py [OUT_DIR]      (default: ./analyse-a-recording)
Writes OUT_DIR/run.npz (the recording), OUT_DIR/windows.csv and OUT_DIR/report.html.
"""

from __future__ import annotations

import sys
from pathlib import Path

import tribodyn as td
from tribodyn import simulate
from tribodyn.app.report import write_results_report
from tribodyn.io.writers import save_recording

out = Path(sys.argv[1] if len(sys.argv) > 1 else "analyse-a-recording")
out.mkdir(parents=True, exist_ok=True)

# 1. A recording on disk. Your own file goes here instead (TDMS, LVM, HDF5, NPY/NPZ, CSV, ...).
sim = simulate.current_density_test(seed=1)
path = out / "run.npz"
channels = {"Ft": sim.channels["fy"], "Fn": sim.channels["fz"], "Fx": sim.channels["fx"], "I": sim.channels["i"]}
save_recording(path, channels, sim.fs, units={"Ft": "N", "Fn": "N", "Fx": "N", "I": "A"})

# 2. Open it with a channel map (role = the file's channel name) and analyse 2 s windows every 10 s.
with td.open_recording(path, channels={"fy": "Ft", "fz": "Fn", "fx": "Fx", "i": "I"}) as rec:
    res = td.analyze(rec, window=2, hop=10, area_mm2=1.0)  # area_mm2: brush tip, for the current density J

# 3. Read the result: the headline (the one COF to read first, chosen by the verdict) with its 95 % interval.
print(repr(res))
head = res.headline  # method "dynamic", "classical" or "per-stroke" (docs/method.md 6e)
print("headline:", head.text)
print(f"  {head.method}: {head.value:.4f} ({head.low:.4f} to {head.high:.4f}), {head.statistic} of {head.n}")
s = res.summary()
print("verdict:", td.results.verdict_text(res.verdict) or "(none)")
print("windows that failed the quality gate, by reason:", s["gate_failures"] or "none")

# 4. The per-window table as a DataFrame (time index in s, units in df.attrs["units"]), a CSV and the report.
df = res.to_pandas()
print(df[["mu_r", "mu_r_low", "mu_r_high", "ok"]].head(3))
print("units:", {c: df.attrs["units"][c] for c in ("mu_r", "J")})
df.to_csv(out / "windows.csv")
write_results_report(out / "report.html", res, title="Example: a simulated current-density test")
print(f"wrote {out / 'windows.csv'} and {out / 'report.html'}")
