"""Pattern 1: Pool.map / ProcessPoolExecutor with fork, forkserver, spawn; with and without a first analysis
in the parent. Usage: python p1_multiprocessing.py CONTEXT {pool,executor} {warm,cold} [threads]"""
import multiprocessing as mp
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import _common

if __name__ == "__main__":
    ctx_name, kind, warm = sys.argv[1:4]
    threads = int(sys.argv[4]) if len(sys.argv) > 4 else None
    serial = {f: _common.run(f, threads) for f in _common.FILES} if warm == "warm" else None
    ctx = mp.get_context(ctx_name)
    t = time.time()
    args = [(f, threads) for f in _common.FILES]
    if kind == "pool":
        with ctx.Pool(2) as p:
            got = p.starmap(_common.run, args)
    else:
        with ProcessPoolExecutor(2, mp_context=ctx) as ex:
            got = list(ex.map(_common.run, *zip(*args)))
    if serial is None:
        serial = {f: _common.run(f, threads) for f in _common.FILES}
    ok = all(_common.same(serial[f], g) for f, g in zip(_common.FILES, got))
    print(ctx_name, kind, warm, threads, "equal" if ok else "DIFFERENT", f"{time.time() - t:.1f}s")
