"""Finding 2 (issue 38 audit): an analysis in a (non-daemon) thread that runs on after the main thread has
returned fails: find_lag's side job goes to a concurrent.futures.ThreadPoolExecutor, which refuses new work once
the interpreter's shutdown has begun ("cannot schedule new futures after interpreter shutdown"), and whose module,
when first imported then, raises "can't register atexit after shutdown".
Usage: python f2_thread_after_main_exit.py {warm,cold}  -> exit 1 and the error when the thread's analysis failed."""
import os
import sys
import threading
import time

import tribodyn

FILE = "/tmp/hC/s5.h5"

if __name__ == "__main__":
    if sys.argv[1] == "warm":
        tribodyn.analyze(FILE)  # the executor's module imported, its threads started

    def late():
        time.sleep(0.3)  # the main thread has returned by now: the interpreter is shutting down
        try:
            res = tribodyn.analyze(FILE)
            print("thread's analysis:", res.headline.short, flush=True)
        except BaseException as exc:  # noqa: BLE001
            import traceback

            traceback.print_exc()
            print("thread's analysis FAILED:", type(exc).__name__, exc, flush=True)
            os._exit(1)

    threading.Thread(target=late).start()
    print("main returns", flush=True)
