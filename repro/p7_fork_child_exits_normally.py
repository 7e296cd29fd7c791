"""A child made by os.fork after analyses in the parent (pools and side threads started there) analyses and then
ends through the interpreter's normal exit (sys.exit: atexit hooks, thread joins), not os._exit."""
import os
import signal
import sys

import _common

if __name__ == "__main__":
    for f in _common.FILES:
        _common.run(f)
    pid = os.fork()
    if pid == 0:
        signal.signal(signal.SIGALRM, signal.SIG_DFL)
        signal.alarm(30)
        _common.run(_common.FILES[1])
        sys.exit(0)
    code = os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])
    print("child exit", code, "(-14: hung)" if code == -14 else "")
