"""Pattern 2: several Python threads analyse different files at once (threads= 1, 2, 3, None), while the main
thread changes tribodyn.set_threads; tables must equal serial runs. Usage: python p2_threads.py {warm,cold}"""
import sys
import threading
import time

import tribodyn
import _common

if __name__ == "__main__":
    warm = sys.argv[1] == "warm"
    serial = {f: _common.run(f) for f in _common.FILES} if warm else None
    got, errors = {}, []
    counts = [1, 2, 3, None, 4, 1]

    def work(i, f):
        try:
            for rep in range(3):
                got[(i, rep)] = (f, _common.run(f, counts[i]))
        except BaseException as exc:  # noqa: BLE001
            errors.append(repr(exc))

    ts = [threading.Thread(target=work, args=(i, f)) for i, f in enumerate(_common.FILES)]
    t0 = time.time()
    for t in ts:
        t.start()
    k = 0
    while any(t.is_alive() for t in ts):
        tribodyn.set_threads([0, 1, 2, 5][k % 4])
        k += 1
        time.sleep(0.01)
    for t in ts:
        t.join(60)
    tribodyn.set_threads(0)
    if serial is None:
        serial = {f: _common.run(f) for f in _common.FILES}
    bad = [key for key, (f, tab) in got.items() if not _common.same(serial[f], tab)]
    print("warm" if warm else "cold", len(got), "runs", "errors", errors, "different", bad, f"{time.time() - t0:.1f}s")
