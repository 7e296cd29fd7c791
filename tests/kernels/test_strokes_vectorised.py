"""The stroke finder and the role choice's own-sign share, vectorised over every acquisition at once (issue 38
point 2: a static recording's lateral noise channel cost ~0.3-1.3 s in ~500 percentiles and loops over ~26 000
"strokes"): the same strokes and shares as the loops they replace, bit for bit (docs/method.md 6c, 6f)."""

from __future__ import annotations

from typing import List, Sequence, Tuple

import numpy as np
import pytest
from tribodyn.io import roles
from tribodyn.kernels.strokes import _segment_p95, find_strokes


def _loop_strokes(sig: np.ndarray, boundaries: Sequence[Tuple[int, int]], kind: str) -> List[Tuple[int, int, int]]:
    """The loop of each acquisition and each cut it replaces (the reference)."""
    sig = np.asarray(sig, dtype=float)
    if kind == "x":
        sig = np.gradient(sig)
    out: List[Tuple[int, int, int]] = []
    for a, b in list(boundaries) or [(0, sig.size)]:
        seg = sig[a:b]
        if seg.size == 0:
            continue
        fin = seg[np.isfinite(seg)]
        thr = 0.3 * (float(np.percentile(np.abs(fin), 95)) if fin.size else 0.0)
        raw = np.zeros(seg.size, dtype=np.int8)
        with np.errstate(invalid="ignore"):
            raw[seg > thr] = 1
            raw[seg < -thr] = -1
        last = np.where(raw != 0, np.arange(seg.size), 0)
        np.maximum.accumulate(last, out=last)
        d = raw[last]
        nz = np.flatnonzero(d)
        if nz.size == 0:
            out.append((a, b, 1))
            continue
        d[: nz[0]] = d[nz[0]]
        moved: List[int] = []
        sign = np.sign(np.nan_to_num(seg, nan=0.0)).astype(np.int8).tolist()
        dirs = d.tolist()
        for c in (np.flatnonzero(np.diff(d)) + 1).tolist():
            lo, j = (moved[-1] if moved else 0) + 1, c
            while j > lo and sign[j - 1] == dirs[c]:
                j -= 1
            moved.append(j)
        edges = [0, *moved, seg.size]
        out += [(a + s0, a + s1, dirs[s1 - 1]) for s0, s1 in zip(edges[:-1], edges[1:]) if s1 - s0 >= 4]
    return out


def _loop_own_signs(ft: np.ndarray, strokes: Sequence[Tuple[int, int, int]]) -> float:
    hits = total = 0
    for a, b, d in strokes:
        m = b - a
        seg = ft[a + m // 4 : b - m // 4]
        seg = seg[np.isfinite(seg)]
        hits += int(np.count_nonzero(np.sign(seg) == d))
        total += seg.size
    return hits / total if total else 0.0


def _signal(rng: np.random.Generator) -> Tuple[np.ndarray, List[Tuple[int, int]], str]:
    n = int(rng.integers(1, 2500))
    kind = str(rng.choice(["fy", "v", "x"]))
    t = np.arange(n)
    sig = np.sin(2 * np.pi * rng.choice([0.001, 0.01, 0.05]) * t + rng.uniform(0, 6))
    sig = sig + rng.choice([0.0, 0.1, 1.0, 3.0]) * rng.standard_normal(n)
    if kind == "x":
        sig = np.cumsum(sig)
    if rng.random() < 0.3:
        sig[rng.random(n) < 0.2] = np.nan
    if rng.random() < 0.2:
        sig = np.round(sig * 2) / 2  # ties and zeros
    if rng.random() < 0.3:  # a stretch of NaN or zeros: acquisitions never decided
        m, w = int(rng.integers(0, n + 1)), int(rng.integers(0, 50))
        sig[m : m + w] = rng.choice([np.nan, 0.0])
    edges = np.unique(np.r_[0, np.sort(rng.integers(0, n + 1, size=int(rng.integers(0, 20)))), n])
    bounds = [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]
    if rng.random() < 0.2:
        bounds = []
    elif rng.random() < 0.1:
        bounds[-1] = (bounds[-1][0], bounds[-1][1] + 5)  # a range past the end, kept as given
    return sig, bounds, kind


def test_the_strokes_and_own_signs_are_the_loops_bit_for_bit() -> None:
    rng = np.random.default_rng(38)
    for _ in range(600):
        sig, bounds, kind = _signal(rng)
        want = _loop_strokes(sig, bounds, kind)
        got = find_strokes(sig, boundaries=bounds, kind=kind)
        assert got == want
        assert all(type(v) is int for row in got for v in row)
        assert roles._own_signs(sig, got) == _loop_own_signs(sig, want)


@pytest.mark.fast
def test_the_pieces_percentiles_are_numpys() -> None:
    rng = np.random.default_rng(2)
    segs = [rng.standard_normal(int(k)) for k in rng.integers(0, 40, size=200)]
    segs += [np.full(5, np.nan), np.r_[np.nan, 1.0, -2.0], rng.standard_normal(64) * 1e-300]
    got = _segment_p95(segs)
    for seg, p in zip(segs, got):
        fin = seg[np.isfinite(seg)]
        assert p == (float(np.percentile(np.abs(fin), 95)) if fin.size else 0.0)


@pytest.mark.fast
def test_a_lateral_noise_channel_over_the_pieces(tmp_path) -> None:
    # the case that was slow: a static recording's lateral noise channel over 256 pieces of the role sample
    rng = np.random.default_rng(0)
    n = 256 * 1024
    noise = 0.05 * rng.standard_normal(n)
    bounds = [(a, a + 1024) for a in range(0, n, 1024)]
    got = find_strokes(noise, boundaries=bounds, kind="fy")
    assert got == _loop_strokes(noise, bounds, "fy") and len(got) > 10_000
    assert roles._own_signs(noise, got) == _loop_own_signs(noise, got)
