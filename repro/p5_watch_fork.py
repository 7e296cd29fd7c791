"""Pattern 5: `tribodyn watch` run in a forked child (after an analysis in the parent, or not) while the parent
appends rows to the CSV being watched. Usage: python p5_watch_fork.py {warm,cold} [threadwarm]"""
import os
import shutil
import signal
import sys
import threading
import time

import numpy as np

import tribodyn

SRC = "/tmp/hC/s4.csv"

if __name__ == "__main__":
    warm = sys.argv[1] == "warm"
    base = f"/tmp/hC/watch_{sys.argv[1]}"
    shutil.rmtree(base, ignore_errors=True)
    os.makedirs(base)
    live = f"{base}/live.csv"
    lines = open(SRC).read().splitlines(keepends=True)
    with open(live, "w") as f:
        f.writelines(lines[: 30001])
    if warm:
        tribodyn.analyze("/tmp/hC/s5.h5")
    bg = None
    if len(sys.argv) > 2:  # a thread of the parent analysing while the fork happens
        bg = threading.Thread(target=lambda: [tribodyn.analyze("/tmp/hC/long.h5") for _ in range(3)])
        bg.start()
        time.sleep(0.2)
    pid = os.fork()
    if pid == 0:
        signal.signal(signal.SIGALRM, signal.SIG_DFL)
        signal.alarm(90)
        from tribodyn.app.cli import main

        os._exit(main(["watch", live, "--out", f"{base}/out", "--interval", "0.5", "--until-idle", "3", "-q"]))
    for k in range(30001, len(lines), 10000):  # the rig writes on
        time.sleep(0.7)
        with open(live, "a") as f:
            f.writelines(lines[k : k + 10000])
    t0 = time.time()
    code = os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])
    if bg:
        bg.join()
    print(sys.argv[1:], "watch child exit", code, "(-14: hung)" if code == -14 else "", f"{time.time() - t0:.1f}s after the last write;",
          "outputs:", sorted(os.listdir(f"{base}/out")) if os.path.isdir(f"{base}/out") else None)
    import json
    s = json.load(open(f"{base}/out/summary.json"))
    print("windows in the last update:", s.get("recordings", s).get("n_windows") if isinstance(s, dict) else s)
