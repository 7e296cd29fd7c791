"""Pattern 6: interpreter exit during or right after analyses. Usage: python p6_exit.py MODE
MODE: after (exit after one analysis), thread_exit (sys.exit from a thread while another analyses: only that
thread ends), daemon (exit while a daemon thread analyses), nondaemon_exit (os-level: main ends, worker thread
still analysing: waits for it), sigint (SIGINT to self during an analysis in the main thread)."""
import os
import signal
import sys
import threading
import time

import _common

LONG = "/tmp/hC/long.h5"

if __name__ == "__main__":
    mode = sys.argv[1]
    t0 = time.time()
    if mode == "after":
        _common.run(_common.FILES[1])
    elif mode == "thread_exit":
        def quit_():
            time.sleep(0.2)
            sys.exit(3)
        threading.Thread(target=quit_).start()
        _common.run(LONG)
    elif mode == "daemon":
        threading.Thread(target=lambda: [_common.run(LONG) for _ in range(100)], daemon=True).start()
        time.sleep(0.5)
    elif mode == "nondaemon":
        threading.Thread(target=lambda: _common.run(LONG)).start()
    elif mode == "sigint":
        threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
        try:
            for _ in range(100):
                _common.run(LONG)
            print("no KeyboardInterrupt")
        except KeyboardInterrupt:
            print(f"KeyboardInterrupt after {time.time() - t0:.2f}s")
    elif mode == "sigint_uncaught":
        threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
        for _ in range(100):
            _common.run(LONG)
    print(f"{mode}: main done at {time.time() - t0:.2f}s", flush=True)
