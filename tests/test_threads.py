"""Thread safety and determinism.

The kernels release the GIL and run on a shared Rust thread pool; results
must not depend on which Python thread calls, how many call at once, or the
pool's size (work is split at fixed boundaries and combined in a fixed
order, see rust/core/src/parallel.rs). So every comparison here is exact.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import tribodyn as td


N_THREADS = 8


def make_jobs(seed: int) -> list[dict]:
    """Different data per job; sizes reach the kernels' parallel paths
    (FFT correlation, regression above 2^18 samples, many channels)."""
    rng = np.random.default_rng(seed)
    jobs = []
    for k in range(N_THREADS):
        n = 20_000 + 1_000 * k
        x = np.cumsum(rng.standard_normal(n))
        jobs.append(
            {
                "x": x,
                "y": np.roll(x, k) + rng.standard_normal(n),
                "fz": rng.standard_normal(300_000 + 7 * k) + 2.0,
                "fy_noise": rng.standard_normal(300_000 + 7 * k),
                "chunk": rng.standard_normal((1 + k % 5, 10_000)) + k,
            }
        )
    return jobs


def run_job(job: dict) -> dict:
    x, y = job["x"], job["y"]
    fz = job["fz"]
    fy = -0.12 * fz + 0.3 + 0.05 * job["fy_noise"]
    hp = td.HighPass(1000.0, order=2, channels=job["chunk"].shape[0])
    first = hp.process(job["chunk"][:, :3_333])
    rest = hp.process(job["chunk"][:, 3_333:])
    acc = td.LinFitAccumulator().update(fz[:100_001], fy[:100_001]).update(fz[100_001:], fy[100_001:])
    return {
        "fft": td.xcorr(x, y, max_lag=2_000, method="fft").c,
        "direct": td.xcorr(x[:3_000], y[:3_000], max_lag=300, method="direct").c,
        "auto": td.xcorr(x, y, max_lag=50).c,
        "pearson": td.pearson(x, y),
        "linfit": td.linfit(fz, fy),
        "acc": acc.result(),
        "hp": np.concatenate([first, rest], axis=1),
        "hp_state": hp.state,
        "highpass": td.highpass(job["chunk"], fs=250.0, cutoff=1.0, order=3),
    }


def assert_identical(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for k, v in a.items():
        if isinstance(v, np.ndarray):
            np.testing.assert_array_equal(v, b[k], err_msg=k)
        else:
            assert v == b[k], k  # floats and LinFit tuples, exactly


@pytest.mark.fast
def test_concurrent_calls_equal_serial_calls():
    jobs = make_jobs(0)
    serial = [run_job(j) for j in jobs]
    with ThreadPoolExecutor(max_workers=N_THREADS) as pool:
        for _ in range(2):  # twice: the second round reuses warm pools
            parallel = list(pool.map(run_job, jobs))
            for s, p in zip(serial, parallel):
                assert_identical(s, p)


@pytest.mark.fast
def test_shared_filter_objects_stay_separate():
    # One HighPass per thread, all alive at once, fed interleaved chunks.
    rng = np.random.default_rng(1)
    signals = [rng.standard_normal(9_000) + k for k in range(N_THREADS)]
    want = [td.HighPass(500.0, cutoff=2.0).process(s) for s in signals]
    filters = [td.HighPass(500.0, cutoff=2.0) for _ in signals]

    def feed(k: int) -> np.ndarray:
        return np.concatenate([filters[k].process(signals[k][i : i + 700]) for i in range(0, 9_000, 700)])

    with ThreadPoolExecutor(max_workers=N_THREADS) as pool:
        got = list(pool.map(feed, range(N_THREADS)))
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)


@pytest.mark.fast
@pytest.mark.parametrize("threads", [1, 2, 3])
def test_thread_count_does_not_change_results(restore_threads, threads):
    jobs = make_jobs(2)[:3]
    td.set_threads(0)
    default = [run_job(j) for j in jobs]
    td.set_threads(threads)
    assert td.get_threads() == threads
    for j, d in zip(jobs, default):
        assert_identical(run_job(j), d)
    # Concurrent callers with a small pool: the same again.
    with ThreadPoolExecutor(max_workers=4) as pool:
        for got, d in zip(pool.map(run_job, jobs), default):
            assert_identical(got, d)


@pytest.mark.fast
def test_set_threads_zero_means_all_cores(restore_threads):
    td.set_threads(0)
    assert td.get_threads() == restore_threads >= 1
    td.set_threads(5)
    assert td.get_threads() == 5
