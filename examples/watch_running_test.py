"""Use case: watch a running test, with a trip limit (docs/method.md 11).

A writer thread plays a simulated dead-weight pin-on-disc test (1 kHz, 3 minutes of test time) into a CSV file
at 20x real time, as a tribometer's software appends rows while the test runs; the COF jumps from 0.20 to 0.34
at t = 120 s (a coating worn through). The watch reads the new rows every second, prints the headline so far and
trips on "cof>0.3 for 5s", then gives the analysis of the file as it was then.

Run:  python watch_running_test.py [OUT_DIR]      (default: ./watch-running-test)
Writes OUT_DIR/run.csv (the recording as written). The command line does the same with a live page:
    tribodyn watch OUT_DIR/run.csv --out OUT_DIR/live --interval 1 --trip "cof>0.3 for 5s"
"""

from __future__ import annotations

import sys
import threading
import time
from pathlib import Path

import numpy as np
import tribodyn as td

out = Path(sys.argv[1] if len(sys.argv) > 1 else "watch-running-test")
out.mkdir(parents=True, exist_ok=True)
path = out / "run.csv"
path.write_text("time,friction force (N),normal force (N)\n")

FS, DURATION, SPEED, STEP = 1000.0, 180.0, 20.0, 120.0
stop = threading.Event()


def writer() -> None:
    """Appends one second of the test every 1/SPEED s, as the rig's software would."""
    rng = np.random.default_rng(0)
    for second in range(int(DURATION)):
        if stop.is_set():
            return
        t = second + np.arange(int(FS)) / FS
        fz = 20.0 + rng.normal(0.0, 0.5, t.size)  # dead weight with rig vibration
        mu = np.where(t < STEP, 0.20, 0.34)
        fy = mu * fz + rng.normal(0.0, 0.05, t.size)
        rows = "".join(f"{a:.3f},{b:.4f},{c:.4f}\n" for a, b, c in zip(t, fy, fz))
        with open(path, "a") as fh:
            fh.write(rows)
        time.sleep(1.0 / SPEED)


thread = threading.Thread(target=writer)
thread.start()
try:
    watch = td.watch(path, interval=1.0, until_idle=5.0, trips=["cof>0.3 for 5s"], window=5.0, hop=2.5)
    for res in watch:
        head = res.headline
        kind = "complete file" if res.params["watch"]["final"] else "so far"
        print(f"t = {res.params['watch']['samples'] / FS:6.1f} s ({kind}): COF {head.value:.4f} "
              f"[{head.low:.4f}, {head.high:.4f}] {head.method}, {len(res)} windows")  # fmt: skip
finally:
    stop.set()
    thread.join()
print(f"watch ended: {watch.reason}")
if watch.tripped is not None:
    print(watch.tripped.message)
    print(f"the COF stepped at t = {STEP:g} s; the rule needs 5 s of windows above 0.3 (5 s windows, 2.5 s hop)")
