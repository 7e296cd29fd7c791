"""Pattern 4: os.fork from a thread while another thread is in the middle of a long analysis; the child then
analyses a small file (each format). A child that does not finish in 60 s is killed by SIGALRM (default action).
Usage: python p4_fork_mid_analysis.py LONGFILE [forks] [threads]"""
import os
import signal
import sys
import threading
import time

import _common

if __name__ == "__main__":
    long_file = sys.argv[1]
    forks = int(sys.argv[2]) if len(sys.argv) > 2 else 12
    threads = int(sys.argv[3]) if len(sys.argv) > 3 else None
    serial = {f: _common.run(f) for f in _common.FILES[:4]}
    stop = threading.Event()

    def long_work():
        n = 0
        while not stop.is_set():
            _common.run(long_file, threads)
            n += 1
        print("parent long analyses:", n, flush=True)

    worker = threading.Thread(target=long_work)
    worker.start()
    outcome = []

    def forker():
        for i in range(forks):
            time.sleep(0.05 + 0.13 * (i % 5))
            f = _common.FILES[i % 4]
            pid = os.fork()
            if pid == 0:
                signal.signal(signal.SIGALRM, signal.SIG_DFL)
                signal.alarm(60)
                try:
                    ok = _common.same(serial[f], _common.run(f))
                    os._exit(0 if ok else 3)
                except BaseException as exc:  # noqa: BLE001
                    print("child error", f, repr(exc), flush=True)
                    os._exit(4)
            t0 = time.time()
            _, status = os.waitpid(pid, 0)
            code = os.waitstatus_to_exitcode(status)
            outcome.append((f, code, round(time.time() - t0, 1)))
            print("fork", i, f, "exit", code, "(-14: hung, killed by the alarm)" if code == -14 else "", f"{time.time() - t0:.1f}s", flush=True)

    t = threading.Thread(target=forker)
    t.start()
    t.join()
    stop.set()
    worker.join()
    print("hung:", [o for o in outcome if o[1] == -14], "other failures:", [o for o in outcome if o[1] not in (0, -14)])
