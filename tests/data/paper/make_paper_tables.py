"""Writes paper_tables.npz: the tables of tribodyn before issue 12 (commit b050354).

``analyze(..., method="paper")`` must reproduce these exactly
(tests/kernels/test_statistics.py). Kept to document how the fixture was made; run
with the build of commit b050354 to regenerate it.
"""

import numpy as np
import tribodyn
from tribodyn import simulate


def main() -> None:
    out = {}
    sim = simulate.current_density_test(seed=3)
    res = tribodyn.analyze(dict(sim.channels), fs=sim.fs, window=2.0, hop=5.0, area_mm2=sim.area_mm2)
    put(out, "cd", res)
    chunks = list(simulate.continuous(120.0, seed=5, raw=True, mu=0.15))
    ch = {k: np.concatenate([c[k] for c in chunks]) for k in chunks[0]}
    res = tribodyn.analyze(ch, fs=1000.0, window=1.0, hop=1.5, highpass=1.0, max_lag=5)
    put(out, "raw", res)
    np.savez_compressed("paper_tables.npz", **out)


def put(out, prefix, res) -> None:
    for name, col in res.table.items():
        col = np.asarray(col)
        out[f"{prefix}/{name}"] = col.astype(str) if col.dtype.kind in "OU" else col
    out[f"{prefix}/bin_cof"] = res.bin_cof
    out[f"{prefix}/bin_counts"] = res.bin_counts


if __name__ == "__main__":
    main()
