"""The CLI's `analyze` (report, figures, SHA-256 thread, fsync pool) run by main() in a child forked while a thread
of the parent analyses (long.h5) and after the parent's own CLI run."""
import os
import shutil
import signal
import threading
import time

import tribodyn
from tribodyn.app.cli import main

if __name__ == "__main__":
    shutil.rmtree("/tmp/hC/out9", ignore_errors=True)
    shutil.rmtree("/tmp/hC/out9p", ignore_errors=True)
    assert main(["analyze", "/tmp/hC/s5.h5", "--out", "/tmp/hC/out9p", "-q"]) == 0
    stop = threading.Event()
    bg = threading.Thread(target=lambda: [tribodyn.analyze("/tmp/hC/long.h5") for _ in iter(stop.is_set, True)])
    bg.start()
    time.sleep(0.3)
    codes = []
    for k in range(3):
        pid = os.fork()
        if pid == 0:
            signal.signal(signal.SIGALRM, signal.SIG_DFL)
            signal.alarm(90)
            os._exit(main(["analyze", "/tmp/hC/s5.h5", "/tmp/hC/s6.tdms", "--out", f"/tmp/hC/out9_{k}", "-q",
                           "--figures", "all"]))
        codes.append(os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]))
        time.sleep(0.2)
    stop.set()
    bg.join()
    print("children's exit codes", codes, "(-14: hung)")
    print(sorted(os.listdir("/tmp/hC/out9_0")))
