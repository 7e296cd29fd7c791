"""Pattern 3: analyze_many serial and on a Dask LocalCluster (processes True/False), after a first analysis in
the parent or not; tables equal to serial. Usage: python p3_dask.py {proc,thread,none} {warm,cold} [split]"""
import sys
import time

import tribodyn
import _common

FILES = [f for f in _common.FILES if not f.endswith(".npy")]

if __name__ == "__main__":
    mode, warm = sys.argv[1:3]
    split = float(sys.argv[3]) if len(sys.argv) > 3 else None
    serial = {f: _common.run(f) for f in FILES} if warm == "warm" else None
    t = time.time()
    client = None
    if mode != "none":
        from dask.distributed import Client, LocalCluster

        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=(mode == "proc"), dashboard_address=":0")
        client = Client(cluster)
    many = tribodyn.analyze_many(FILES, client=client, split=split)
    if serial is None:
        serial = {f: _common.run(f) for f in FILES}
    bad = [f for f in FILES if not _common.same(serial[f], {k: v for k, v in many.results[f].table.items()})]
    print(mode, warm, split, "failures", dict(many.failures), "different", bad, f"{time.time() - t:.1f}s", flush=True)
    if client is not None:
        client.close()
        cluster.close()
