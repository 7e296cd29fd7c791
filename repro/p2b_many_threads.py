"""Pattern 2b: more threads than side threads (10 > SIDE_THREADS = 4), the same files in several threads at once
(one open Recording shared by two threads too); tables equal to serial runs."""
import threading
import time

import tribodyn
import _common

if __name__ == "__main__":
    files = _common.FILES * 2
    serial = {f: _common.run(f) for f in _common.FILES}
    shared = tribodyn.open_recording("/tmp/hC/s6.h5")
    serial_shared = {k: v for k, v in tribodyn.analyze(shared).table.items()}
    got, errors = {}, []

    def work(i, f):
        try:
            got[i] = (f, _common.run(f, [1, 2, None][i % 3]))
            got[("shared", i)] = ("shared", dict(tribodyn.analyze(shared, threads=1 + i % 2).table))
        except BaseException as exc:  # noqa: BLE001
            errors.append(repr(exc))

    ts = [threading.Thread(target=work, args=(i, f)) for i, f in enumerate(files)]
    t0 = time.time()
    for t in ts:
        t.start()
    for t in ts:
        t.join(120)
    bad = [k for k, (f, tab) in got.items() if not _common.same(serial_shared if f == "shared" else serial[f], tab)]
    print(len(got), "runs; errors", errors, "different", bad, f"{time.time() - t0:.1f}s", "alive", sum(t.is_alive() for t in ts))
