"""The fast order statistics of the pre-pass and the bootstrap are NumPy's, bit for bit (issue 25)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from tribodyn import _core
from tribodyn.kernels import stats as R
from tribodyn.kernels import _order


def _arrays(rng: np.random.Generator):
    n = 1 << 16
    t = np.arange(n)
    yield rng.normal(size=n)
    yield np.round(rng.normal(size=n), 2)  # ties
    yield np.sin(t * 0.001) + 0.01 * rng.normal(size=n)  # a slow wave: the strided sample is unrepresentative
    yield np.where(t < n // 3, 1e-3 * rng.normal(size=n), 10.0 + rng.normal(size=n))  # two clusters
    yield np.repeat(rng.normal(size=64), 1024)  # long runs of one value
    yield np.sort(rng.normal(size=n))[::-1].copy()
    yield rng.normal(size=n + 1)  # odd length
    yield rng.normal(size=100)  # short: NumPy itself


@pytest.mark.fast
@pytest.mark.parametrize("kernel", [True, False], ids=["kernel", "numpy"])
def test_median_and_percentile_match_numpy(kernel: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    if not kernel:
        monkeypatch.delattr(_core, "select_ranks")
    rng = np.random.default_rng(7)
    for x in _arrays(rng):
        assert _order.median(x) == float(np.median(x))
        for c in (0.0, float(np.median(x)), -3.5):
            assert _order.median_abs_dev(x, c) == float(np.median(np.abs(x - c)))
        for q in (0, 5, 37.5, 50, 95, 100):
            assert _order.percentile(x, q) == float(np.percentile(x, q))
    x = rng.normal(size=1 << 16)
    x[77] = np.nan
    assert np.isnan(_order.median(x)) and np.isnan(_order.median_abs_dev(x, 0.0))


@pytest.mark.fast
def test_select_ranks_kernel_is_exact_and_checks_its_ranks() -> None:
    x = np.random.default_rng(2).normal(size=(1 << 17) + 3)
    ks = [0, 5, 65537, 65538, (1 << 17) + 2]
    assert np.array_equal(_core.select_ranks(x, ks), np.sort(x)[ks])
    assert np.array_equal(_core.select_ranks(x, ks, centre=0.25), np.sort(np.abs(x - 0.25))[ks])
    assert _core.select_ranks(x, ks, centre=float("nan")) is None
    with pytest.raises(ValueError, match="rank"):
        _core.select_ranks(x, [x.size])


@pytest.mark.fast
def test_histogram_kernel_is_numpys() -> None:
    rng = np.random.default_rng(4)
    for x in (rng.normal(size=100_000), np.round(rng.normal(size=50_000), 1), np.linspace(-1, 1, 4097)):
        lo, hi = float(x.min()), float(x.max())
        want, edges = np.histogram(x, bins=1024, range=(lo, hi))
        assert np.array_equal(_core.histogram_uniform(x, np.linspace(lo, hi, 1025)), want)
        assert np.array_equal(edges, np.linspace(lo, hi, 1025))


@pytest.mark.fast
def test_side_medians_are_numpys() -> None:
    from tribodyn.pipeline.prepass import _side_medians

    rng = np.random.default_rng(5)
    for n in (1, 2, 3, 8, 1001, 1 << 16):
        for fy in (rng.normal(0.4, 1, n), np.round(rng.normal(-0.3, 1, n), 1), np.where(np.arange(n) % 3, 1.0, 0.0)):
            want = [float(np.median(np.abs(fy[s]))) if s.any() else 0.0 for s in (fy > 0, fy < 0)]
            assert [np.float64(v).tobytes() for v in _side_medians(fy)] == [np.float64(v).tobytes() for v in want]


@pytest.mark.fast
def test_order_stats_falls_back_when_the_bracket_misses(monkeypatch: pytest.MonkeyPatch) -> None:
    x = np.random.default_rng(1).normal(size=1 << 17)
    monkeypatch.delattr(_core, "select_ranks")  # the NumPy bracket (the kernel has its own test)
    monkeypatch.setattr(_order, "_SAMPLE", 4)  # a sample too small to bracket the ranks
    ks = [10, 60000, 60001, 131000]
    assert np.array_equal(_order.order_stats(x, ks), np.sort(x)[ks])


@pytest.mark.fast
@pytest.mark.parametrize("fn", [_order.row_quantiles, _order._row_quantiles_numpy], ids=["kernel", "numpy"])
@pytest.mark.parametrize("width", [0, 1, 2, 7, 40, 601, 1300])
def test_row_quantiles_match_nanmedian_and_nanpercentile(width: int, fn) -> None:
    rng = np.random.default_rng(width)
    for nan_share in (0.0, 0.3, 1.0):
        x = rng.normal(size=(13, width)) * 1e3
        x[rng.random(x.shape) < nan_share] = np.nan
        x[0, : width // 2] = np.nan
        qs = (5, 95, 50, 0, 100, 37.5)
        if width > 2:
            x[1, :3] = [np.inf, -np.inf, 0.0]
        med, got = fn(x, qs)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            want_med = np.nanmedian(x, axis=1) if width else np.full(13, np.nan)
            want = [np.nanpercentile(x, q, axis=1) if width else np.full(13, np.nan) for q in qs]
        assert np.array_equal(med, want_med, equal_nan=True)
        for a, b in zip(got, want):
            assert np.array_equal(a, b, equal_nan=True)


def _old_bootstrap_stats(v: np.ndarray, noise: R.NoiseResample | None) -> tuple:
    """The statistics of the resamples as bootstrap_ci computed them before issue 25 (all at once)."""
    rng = np.random.default_rng(R.BOOTSTRAP_SEED)
    if noise is None:
        r = v[R._blocks(rng, v.size)]
        return np.median(r, axis=1), r.mean(axis=1), np.percentile(r, 5, axis=1), np.percentile(r, 95, axis=1)
    var = noise.var
    fin = np.isfinite(var)
    used = max(float(np.median(var[fin])), 0.0)
    idx = R._blocks(rng, var.size)
    pos = np.full(var.size, -1, dtype=np.int64)
    pos[noise.index] = np.arange(v.size)
    p = pos[idx]
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        delta = np.maximum(np.nanmedian(var[idx], axis=1), 0.0) - used
        r = np.where(p >= 0, v[p] + noise.dnoise[p] * delta[:, None], np.nan)
        return (np.nanmedian(r, axis=1), np.nanmean(r, axis=1), np.nanpercentile(r, 5, axis=1),
                np.nanpercentile(r, 95, axis=1))  # fmt: skip


@pytest.mark.parametrize("n", [3, 50, 700])
@pytest.mark.parametrize("gated", [1.0, 0.7])
@pytest.mark.parametrize("kernel", [True, False], ids=["kernel", "numpy"])
def test_bootstrap_statistics_unchanged_by_chunks_and_threads(n: int, gated: float, kernel: bool, monkeypatch) -> None:
    if not kernel:
        monkeypatch.delattr(_core, "resample_stats")
    rng = np.random.default_rng(n)
    total = int(n / gated)
    v = 0.12 + 0.01 * rng.normal(size=n)
    keep = np.sort(rng.choice(total, n, replace=False))
    var = np.abs(rng.normal(1.0, 0.3, size=total))
    var[rng.random(total) < 0.05] = np.nan
    noise = R.NoiseResample(var=var, index=keep, dnoise=0.01 * rng.normal(size=n))
    monkeypatch.setattr(R, "_CHUNK_CELLS", 3000)  # many chunks
    for nz in (None, noise):
        want = _old_bootstrap_stats(v, nz)
        seen = []
        real = R._all_resample_stats

        def spy(*a, **k):
            out = real(*a, **k)
            seen.append(out)
            return out

        monkeypatch.setattr(R, "_all_resample_stats", spy)
        one = R.bootstrap_ci(v, noise=nz, threads=1)
        monkeypatch.setattr(R, "_all_resample_stats", real)
        (got,) = seen
        for a, b in zip(got, want):
            assert np.array_equal(a, b, equal_nan=True)
        assert R.bootstrap_ci(v, noise=nz, threads=2) == one


def _resample_cases(rng: np.random.Generator):
    for n in (3, 7, 130, 1001, 18000):
        v = rng.normal(size=n) * 0.01 + 0.12
        yield v, None
        w = v.copy()
        w[rng.random(n) < 0.05] = np.nan  # windows without a value
        yield w, None
        m = n + n // 3  # the recording's windows; v holds some of them
        var = np.abs(rng.normal(size=m)) * 1e-3
        var[rng.random(m) < 0.1] = np.nan
        index = np.sort(rng.choice(m, size=n, replace=False))
        dn = rng.normal(size=n) * 3.0
        yield v, R.NoiseResample(var=var, index=index, dnoise=dn)
        yield w, R.NoiseResample(var=np.full(m, np.nan), index=index, dnoise=dn)  # no noise estimate at all
        # quantised values and noise measurements (many ties: the counting path's order statistics)
        yield np.round(v, 2), None
        yield np.round(v, 2), R.NoiseResample(var=np.round(var, 4), index=index, dnoise=dn)


@pytest.mark.parametrize("threads", [1, 2])
def test_resample_stats_kernel_is_the_numpy_path(threads: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """The bootstrap's resample statistics: the Rust kernel gives _resample_stats' values bit for bit."""
    rng = np.random.default_rng(9)
    for v, noise in _resample_cases(rng):
        m = v.size if noise is None else noise.var.size
        starts, ell = R._block_starts(np.random.default_rng(3), m)
        args = None
        if noise is not None:
            pos = np.full(m, -1, dtype=np.int64)
            pos[noise.index] = np.arange(v.size)
            args = (noise.var, pos, noise.dnoise, max(float(np.nanmedian(noise.var)), 0.0) if np.isfinite(
                noise.var).any() else float("nan"))  # fmt: skip
        got = R._all_resample_stats(v, starts, ell, args, width=m, threads=threads)
        with monkeypatch.context() as mp, warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            mp.delattr(_core, "resample_stats")
            want = R._all_resample_stats(v, starts, ell, args, width=m, threads=threads)
        for g, w in zip(got, want):  # the same bits, NaN where NumPy gives NaN (its sign aside)
            assert np.array_equal(np.isnan(g), np.isnan(w)), (v.size, noise is not None)
            assert g[~np.isnan(g)].tobytes() == w[~np.isnan(w)].tobytes(), (v.size, noise is not None)


def _bytes(v: object) -> bytes:
    return np.float64(v).tobytes()


@pytest.mark.fast
def test_sorted_values_give_numpys_medians_and_deviations() -> None:
    """The pre-pass's one sort (``_order.Sorted``): medians, deviations and ranks of any run of it."""
    rng = np.random.default_rng(11)
    for x in [*_arrays(rng), np.array([2.5]), np.array([-1.0, 1.0]), 1e8 + 1e-8 * rng.normal(size=999)]:
        whole = _order.Sorted.of(x)
        for a, b in ((0, x.size), (0, max(1, x.size // 3)), (x.size // 2, x.size), (x.size - 1, x.size)):
            part = whole.part(a, b)
            v = part.values()
            assert _bytes(part.median()) == _bytes(np.median(v))
            for c in (0.0, float(np.median(v)), float(v[0]), float(v[-1]) + 2.0, float(v[0]) - 0.5, -3.5):
                assert _bytes(part.median_abs_dev(c)) == _bytes(np.median(np.abs(v - c)))
                ks = sorted({0, v.size // 3, v.size - 1})
                assert part.ranks(ks, c) == list(np.sort(np.abs(v - c))[ks])
            assert part.count_le(float(np.median(v))) == int(np.count_nonzero(v <= np.median(v)))
    # signed zeros: a zero distance is +0.0, as np.abs makes it
    for x in (np.array([-0.0, 0.0, -0.0, 1.0]), np.array([-0.0, -0.0]), np.array([0.0, -1.0, -0.0])):
        whole = _order.Sorted.of(x)
        for c in (0.0, -0.0):
            want = np.sort(np.abs(x - c))
            assert [_bytes(r) for r in whole.ranks(range(x.size), c)] == [_bytes(r) for r in want]
            assert _bytes(whole.median_abs_dev(c)) == _bytes(np.median(np.abs(x - c)))
    with pytest.raises(IndexError):
        _order.Sorted.of(np.arange(3.0)).ranks([3])


@pytest.mark.fast
def test_histogram_of_sorted_values_is_the_kernels(monkeypatch: pytest.MonkeyPatch) -> None:
    """Otsu's histogram from binary searches equals NumPy's (the kernel's) count, and falls back to
    the kernel where the edges are too close to tell (a range of a few ULPs)."""
    from tribodyn.pipeline.prepass import _histogram_sorted

    rng = np.random.default_rng(6)
    calls = []
    kernel = _core.histogram_uniform
    monkeypatch.setattr(_core, "histogram_uniform", lambda x, e: calls.append(1) or kernel(x, e))
    cases = [rng.normal(size=100_000), np.round(rng.normal(size=50_000), 1), np.linspace(-1, 1, 4097),
             rng.integers(-3, 4, 5000).astype(float), np.array([0.0, 1.0])]  # fmt: skip
    for x in cases:
        s = np.sort(x)
        edges = np.linspace(s[0], s[-1], 1025)
        want, _ = np.histogram(x, bins=1024, range=(s[0], s[-1]))
        assert np.array_equal(_histogram_sorted(s, edges), want)
    assert not calls  # no fallback on ordinary ranges
    tight = np.sort(1e8 + np.arange(40) * np.spacing(1e8))  # 40 ULPs over 1024 bins: edges repeat
    edges = np.linspace(tight[0], tight[-1], 1025)  # (np.histogram refuses this range; the kernel counts it)
    assert np.array_equal(_histogram_sorted(tight, edges), kernel(tight, edges))
    assert calls  # the kernel's count


@pytest.mark.fast
def test_unloaded_cluster_is_its_masked_samples() -> None:
    """The sorted cluster ``_unloaded`` returns holds exactly the samples of its mask."""
    from tribodyn.pipeline.prepass import _unloaded

    rng = np.random.default_rng(8)
    n = 60_000
    z = 0.02 * rng.normal(size=n)
    z[n // 5 : n // 2] += 8.0
    z[n // 2 : 4 * n // 5] += 0.6  # a low load step: the cluster narrows to its part nearer zero
    got = _unloaded(z, _order.Sorted.of(z))
    assert got is not None
    mask, cluster = got
    assert np.array_equal(cluster.values(), np.sort(z[mask]))
    assert 0.35 < mask.mean() < 0.45
    assert _unloaded(10.0 + 0.01 * rng.normal(size=n), _order.Sorted.of(10.0 + 0.01 * rng.normal(size=n))) is None


@pytest.mark.fast
def test_select_ranks_is_the_same_on_every_thread_count() -> None:
    """The bracket pass runs over a piece per thread; the kept values, and so the ranks, do not change."""
    rng = np.random.default_rng(3)
    x = np.concatenate([rng.normal(size=300_001), np.full(5000, 0.25)])  # ties at the centre
    ks = [0, 1234, x.size // 2, x.size - 1]
    want = np.sort(x)[ks]
    dev = np.sort(np.abs(x - 0.25))[ks]
    for threads in (1, 2, 3, 8):
        assert np.array_equal(_core.select_ranks(x, ks, threads=threads), want)
        assert np.array_equal(_core.select_ranks(x, ks, centre=0.25, threads=threads), dev)
    y = x.copy()
    y[-3] = np.nan
    assert _core.select_ranks(y, ks, threads=2) is None  # NaN in the last piece


@pytest.mark.fast
def test_block_sums_total_is_numpys_sum_bit_for_bit() -> None:
    """estimators.Sums adds the blocks in a loop: the same bits as ``blocks.sum(axis=2)``, signed zeros too."""
    from tribodyn.kernels.estimators import BLOCKS, PRODUCTS, Sums

    rng = np.random.default_rng(11)
    shape = (3000, BLOCKS, len(PRODUCTS))
    E = rng.normal(size=shape) * 10.0 ** rng.integers(-12, 12, shape)
    E[rng.random(shape) < 0.1] = -0.0
    E[:7] = -0.0  # every block -0.0: NumPy's sum is +0.0
    S = Sums(E)
    want = np.ascontiguousarray(E.transpose(2, 0, 1)).sum(axis=2)
    assert np.array_equal(S.total.view(np.int64), want.view(np.int64))
