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
from _forks import exit_code_of
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


def _small_results() -> td.Results:
    from tribodyn import simulate

    parts = list(simulate.continuous(60.0, seed=4, fs=1000.0))
    data = {k: np.concatenate([p[k] for p in parts]) for k in ("fx", "fy", "fz")}
    return td.analyze(data, fs=1000.0)


@pytest.mark.fast
def test_two_results_compute_their_values_at_once():
    """A Results' cached values (mu_r_ci, column_ci, verdict, headline) hold no lock shared by every instance
    (functools.cached_property before Python 3.12 does: the bootstraps of two threads ran one after the other);
    two threads asking for the same value of one instance get the one object (issue 38 audit)."""
    import threading

    from tribodyn.results._cache import cached

    met = threading.Barrier(2, timeout=10)

    class Two:
        @cached
        def value(self) -> object:
            met.wait()  # both instances inside at once, else BrokenBarrierError after 10 s
            return object()

    a, b = Two(), Two()
    with ThreadPoolExecutor(2) as ex:
        got = list(ex.map(lambda o: o.value, (a, b)))
    assert got == [a.value, b.value] and got[0] is not got[1]
    assert Two.value.__doc__ is None and isinstance(Two.__dict__["value"], cached)


@pytest.mark.fast
def test_a_child_forked_while_a_thread_computes_a_results_value_does_not_wait_forever(monkeypatch):
    """multiprocessing's fork while another thread computes a Results' interval: the child's own Results
    compute theirs (with functools.cached_property the child waited forever for the lock the parent's thread
    held; issue 38 audit). The child is killed after 30 s (SIGALRM) so that the test fails instead of hanging."""
    import os
    import signal
    import threading

    import tribodyn.results as results_module

    if not hasattr(os, "fork"):
        pytest.skip("no fork on this platform")
    res = _small_results()
    parent, inside, release = os.getpid(), threading.Event(), threading.Event()
    real = results_module.bootstrap_ci

    def slow_in_parent(*a, **k):
        if os.getpid() == parent:
            inside.set()
            release.wait(30)
        return real(*a, **k)

    monkeypatch.setattr(results_module, "bootstrap_ci", slow_in_parent)
    busy = threading.Thread(target=lambda: res.replace().mu_r_ci)
    busy.start()
    try:
        assert inside.wait(30)
        pid = os.fork()
        if pid == 0:  # the child: only this thread exists
            signal.signal(signal.SIGALRM, signal.SIG_DFL)
            signal.alarm(30)
            os._exit(0 if res.replace().mu_r_ci == res.mu_r_ci else 3)
        assert exit_code_of(pid, 40, "the forked child did not finish") == 0
    finally:
        release.set()
        busy.join(30)


_LATE = """
import sys, threading, time
import numpy as np
import tribodyn
from tribodyn import simulate
parts = list(simulate.continuous(60.0, seed=4, fs=1000.0))
data = {k: np.concatenate([p[k] for p in parts]) for k in ("fx", "fy", "fz")}
if sys.argv[1] == "warm":
    tribodyn.analyze(data, fs=1000.0)
def late():
    time.sleep(0.2)  # the main thread has returned: the interpreter is exiting
    print(tribodyn.analyze(data, fs=1000.0).headline.short, flush=True)
threading.Thread(target=late).start()
"""


@pytest.mark.parametrize("first", ["warm", "cold"])
def test_an_analysis_in_a_thread_that_outlives_the_main_thread_succeeds(first, tmp_path):
    """A thread analysing after the main thread returned (the interpreter exiting): the package's thread pools
    (find_lag's side job, the reading thread, the bootstrap's) run its jobs in the caller instead of refusing
    them (RuntimeError "cannot schedule new futures after interpreter shutdown", or, where their module was not
    yet imported, "can't register atexit after shutdown"; issue 38 audit)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    script = tmp_path / "late.py"
    script.write_text(_LATE, encoding="utf-8")
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(Path(td.__file__).parents[1]), os.environ.get("PYTHONPATH", "")]),
    }
    got = subprocess.run([sys.executable, str(script), first], capture_output=True, text=True, timeout=120, env=env)
    assert got.returncode == 0, got.stderr[-2000:]
    assert "Traceback" not in got.stderr, got.stderr[-2000:]
    assert got.stdout.startswith("dynamic COF"), got.stdout
