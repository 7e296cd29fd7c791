"""Shared helpers of the audit's reproducers (issue 38 audit): files and a table comparison."""
import numpy as np
import tribodyn

FILES = ["/tmp/hC/s4.npy", "/tmp/hC/s5.h5", "/tmp/hC/s6.tdms", "/tmp/hC/s4.csv", "/tmp/hC/s5.tdms", "/tmp/hC/s6.h5"]


def run(path, threads=None):
    """analyze(path) -> its table (a dict of arrays)."""
    kw = {"fs": 1000.0} if path.endswith(".npy") else {}
    if path.endswith(".npy"):
        rec = tribodyn.open_recording(path, fs=1000.0, channels={"fx": "ch0", "fy": "ch1", "fz": "ch2"})
        res = tribodyn.analyze(rec, threads=threads)
    else:
        res = tribodyn.analyze(path, threads=threads, **{k: v for k, v in kw.items() if k != "fs"})
    return {k: np.asarray(v) for k, v in res.table.items()}


def same(a, b):
    if a.keys() != b.keys():
        return False
    for k in a:
        x, y = a[k], b[k]
        if x.dtype.kind == "f":
            if not np.array_equal(x, y, equal_nan=True):
                return False
        elif not np.array_equal(x, y):
            return False
    return True
