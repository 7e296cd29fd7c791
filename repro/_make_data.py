"""Writes the audit's small recordings into /tmp/hC/ (npy, h5, tdms, csv)."""
import numpy as np
import tribodyn
from tribodyn.io import writers

out = "/tmp/hC"
for seed, dur in [(4, 120.0), (5, 90.0), (6, 150.0)]:
    chunks = list(tribodyn.simulate.continuous(dur, seed=seed, fs=1000.0))
    ch = {k: np.concatenate([c[k] for c in chunks]) for k in chunks[0]}
    ch = {k: v for k, v in ch.items() if k in ("fx", "fy", "fz")}
    writers.save_hdf5(f"{out}/s{seed}.h5", ch, 1000.0, {k: "N" for k in ch})
    writers.save_tdms(f"{out}/s{seed}.tdms", ch, 1000.0, {k: "N" for k in ch}, segment_samples=1000)
    names = writers.save_npy(f"{out}/s{seed}.npy", ch)
    with open(f"{out}/s{seed}.csv", "w") as f:
        f.write("time,fx,fy,fz\n")
        t = np.arange(len(ch["fy"])) / 1000.0
        np.savetxt(f, np.column_stack([t, ch["fx"], ch["fy"], ch["fz"]]), delimiter=",", fmt="%.6g")
    print(seed, names, len(ch["fy"]))
# a long one for the fork-during-analysis case
chunks = list(tribodyn.simulate.continuous(3600.0, seed=7, fs=1000.0))
ch = {k: np.concatenate([c[k] for c in chunks]) for k in ("fx", "fy", "fz")}
writers.save_hdf5(f"{out}/long.h5", ch, 1000.0, {k: "N" for k in ch})
writers.save_npy(f"{out}/long.npy", ch)
