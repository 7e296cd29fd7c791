"""Finding 1 (issue 38 audit): a fork made while another thread computes a Results property (mu_r_ci: the
bootstrap) leaves the child waiting forever for the first such property of *any* Results.

functools.cached_property (Python <= 3.11) holds one RLock per property for every instance while it computes;
a child made by fork inherits the lock held, with no thread to release it. Also (threads, no fork): the
bootstraps of different Results in different threads run one at a time.
Usage: python f1_cached_property_fork.py [tries]  -> prints the hung children (exit -14)."""
import os
import signal
import sys
import threading
import time

import tribodyn

if __name__ == "__main__":
    tries = int(sys.argv[1]) if len(sys.argv) > 1 else 10
    base = tribodyn.analyze("/tmp/hC/s5.h5")
    stop = threading.Event()

    def compute():  # a fresh Results' bootstrap over and over (as analyze does for each recording)
        while not stop.is_set():
            base.replace().mu_r_ci

    threading.Thread(target=compute, daemon=True).start()
    hung = 0
    for i in range(tries):
        time.sleep(0.03)
        pid = os.fork()
        if pid == 0:
            signal.signal(signal.SIGALRM, signal.SIG_DFL)
            signal.alarm(10)
            base.replace().mu_r_ci  # any Results (here a fresh copy) asks for its interval
            os._exit(0)
        code = os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])
        hung += code == -14
        print("fork", i, "exit", code, "(hung: killed by the alarm after 10 s)" if code == -14 else "", flush=True)
    stop.set()
    print(f"{hung}/{tries} children hung")
    sys.exit(1 if hung else 0)
