"""Seeded fuzz of the .npz reader: every mutant is refused with RecordingError or read as np.load reads it."""

from __future__ import annotations

import collections

import numpy as np
import pytest
import tribodyn as td
from tribodyn.io.writers import save_npz


@pytest.mark.fast
def test_npz_mutants_are_refused_or_read_like_np_load(tmp_path):
    rng = np.random.default_rng(7)
    base = tmp_path / "base.npz"
    save_npz(base, {"fy": rng.normal(size=3000), "fz": rng.normal(size=3000)}, 1000.0)
    raw = base.read_bytes()
    outcomes: collections.Counter = collections.Counter()
    for k in range(100):
        b = bytearray(raw)
        i = int(rng.integers(0, len(b)))
        kind = k % 4
        if kind == 0:
            del b[i:]  # truncation
        elif kind == 1:
            b[i] ^= 1 << int(rng.integers(0, 8))  # bit flip
        elif kind == 2:
            b[i:i] = bytes([int(rng.integers(0, 256))])  # insertion
        else:
            del b[i]  # deletion
        p = tmp_path / f"m{k}.npz"
        p.write_bytes(bytes(b))
        try:
            with td.open_recording(p) as rec:
                got = rec.read()
        except td.RecordingError:
            outcomes["refused"] += 1
            continue
        ref = np.load(p)
        for role in ("fy", "fz"):
            np.testing.assert_array_equal(got[role], ref[role], err_msg=f"mutant {k}")
        outcomes["read like np.load"] += 1
    assert sum(outcomes.values()) == 100, outcomes
