"""Pattern 3b: Dask LocalCluster whose worker processes are forked (multiprocessing-method fork/forkserver) from
a parent that has analysed first. Usage: python p3b_dask_fork.py {fork,forkserver}"""
import sys
import time

import dask
import tribodyn
import _common

FILES = [f for f in _common.FILES if not f.endswith(".npy")]

if __name__ == "__main__":
    serial = {f: _common.run(f) for f in FILES}
    t = time.time()
    with dask.config.set({"distributed.worker.multiprocessing-method": sys.argv[1]}):
        from dask.distributed import Client, LocalCluster

        with LocalCluster(n_workers=2, threads_per_worker=2, processes=True, dashboard_address=":0") as cluster:
            with Client(cluster) as client:
                many = tribodyn.analyze_many(FILES, client=client, split=30.0)
    bad = [f for f in FILES if not _common.same(serial[f], dict(many.results[f].table))]
    print(sys.argv[1], "failures", dict(many.failures), "different", bad, f"{time.time() - t:.1f}s", flush=True)
