"""Finding 3 (issue 38 audit): a fork made while another thread opens an HDF5 file whose text attributes are read
by the helper process (io/_h5attrs.py: h5py's str attributes, e.g. the writers' "unit") leaves the child waiting
forever in its first open of such a file: the module's lock is copied held (the helper's start takes ~0.2-0.5 s,
each request ~1 ms), and no thread of the child will release it.
Usage: python f3_h5attrs_lock_fork.py -> exit 1 when the child hung (killed by SIGALRM after 20 s)."""
import os
import signal
import sys
import threading
import time

import tribodyn
from tribodyn.io import _h5attrs

if __name__ == "__main__":
    opener = threading.Thread(target=lambda: tribodyn.open_recording("/tmp/hC/s5.h5").close())
    opener.start()  # the first HDF5 open of the process starts the helper, holding the module's lock
    deadline = time.monotonic() + 10
    while not _h5attrs._lock.locked() and time.monotonic() < deadline:
        time.sleep(0.001)
    print("lock held by the opening thread at fork:", _h5attrs._lock.locked(), flush=True)
    pid = os.fork()
    if pid == 0:
        signal.signal(signal.SIGALRM, signal.SIG_DFL)
        signal.alarm(20)
        with tribodyn.open_recording("/tmp/hC/s6.h5") as rec:
            os._exit(0 if rec.n_samples == 150_000 else 3)
    code = os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])
    opener.join()
    print("child exit", code, "(-14: hung, killed by the alarm)" if code == -14 else "")
    sys.exit(1 if code else 0)
