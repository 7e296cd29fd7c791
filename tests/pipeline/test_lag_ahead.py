"""find_lag on a thread of its own beside the pre-pass (issue 38 point 2): the same lag as after it, the pre-pass's
error first, a reciprocating test's look dropped (docs/architecture.md)."""

from __future__ import annotations

import threading
import time
from concurrent.futures import Future
from pathlib import Path
from typing import Any, Dict, List

import numpy as np
import pytest
import tribodyn
from tribodyn import simulate
from tribodyn.pipeline import analyze as orchestration


def _dynamic() -> Dict[str, np.ndarray]:
    parts = list(simulate.continuous(120.0, seed=4, fs=1000.0))
    return {k: np.concatenate([p[k] for p in parts]) for k in ("fx", "fy", "fz")}


def _spy(monkeypatch: pytest.MonkeyPatch) -> List[str]:
    """The names of the threads find_lag ran on."""
    seen: List[str] = []
    real = orchestration.find_lag

    def find_lag(*a: Any, **k: Any) -> Any:
        seen.append(threading.current_thread().name)
        return real(*a, **k)

    monkeypatch.setattr(orchestration, "find_lag", find_lag)
    return seen


@pytest.mark.fast
def test_the_lag_found_beside_the_prepass_is_the_one_found_after_it(monkeypatch: pytest.MonkeyPatch,
                                                                     tmp_path: Path) -> None:  # fmt: skip
    data = _dynamic()
    seen = _spy(monkeypatch)
    one = tribodyn.analyze(data, fs=1000.0, threads=1)
    two = tribodyn.analyze(data, fs=1000.0, threads=2)
    path = tmp_path / "rec.npy"
    np.save(path, np.vstack([data["fx"], data["fy"], data["fz"]]))
    with tribodyn.open_recording(path, fs=1000.0, names=["fx", "fy", "fz"]) as rec:
        filed = tribodyn.analyze(rec, threads=2)
    assert seen[0] == threading.current_thread().name  # one thread: after the pre-pass, on the caller's
    assert seen[1].startswith("tribodyn-side") and seen[2].startswith("tribodyn-side")
    assert one.params["iv_lag_rule"] == "data"
    for res in (two, filed):
        assert res.params["iv_lag_samples"] == one.params["iv_lag_samples"]
        assert res.params.get("iv_lag_shifts") == one.params.get("iv_lag_shifts")
        assert res.mu_r_ci == one.mu_r_ci and str(res.headline) == str(one.headline)
        for k in one.table:
            a, b = np.asarray(res.table[k]), np.asarray(one.table[k])
            assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), k


@pytest.mark.fast
def test_streams_and_given_lags_are_not_looked_at_ahead(monkeypatch: pytest.MonkeyPatch) -> None:
    data = _dynamic()
    seen = _spy(monkeypatch)
    chunks = ({k: v[a : a + 30_000] for k, v in data.items()} for a in range(0, data["fz"].size, 30_000))
    tribodyn.analyze(chunks, fs=1000.0, threads=2)  # a one-pass stream: find_lag reads nothing, on the caller's
    tribodyn.analyze({k: list(v) for k, v in data.items()}, fs=1000.0, threads=2)  # not NumPy arrays
    assert seen == [threading.current_thread().name] * 2
    seen.clear()
    tribodyn.analyze(data, fs=1000.0, threads=2, iv_lag=0.01)  # a given lag: nothing to look for
    assert seen == [threading.current_thread().name]


@pytest.mark.fast
def test_the_prepass_error_comes_first_and_after_the_look_has_ended(monkeypatch: pytest.MonkeyPatch) -> None:
    ended: List[bool] = []
    real = orchestration.find_lag

    def slow_lag(*a: Any, **k: Any) -> Any:
        time.sleep(0.2)
        try:
            raise RuntimeError("the look failed")
        finally:
            ended.append(True)

    def failing_prepass(*a: Any, **k: Any) -> Any:
        raise ValueError("the pre-pass failed")

    monkeypatch.setattr(orchestration, "find_lag", slow_lag)
    monkeypatch.setattr(orchestration, "prepass", failing_prepass)
    with pytest.raises(ValueError, match="the pre-pass failed"):
        tribodyn.analyze(_dynamic(), fs=1000.0, threads=2)
    assert ended == [True]  # the source is not closed under a running look
    monkeypatch.setattr(orchestration, "prepass", lambda *a, **k: {"motion": "unidirectional"})
    with pytest.raises(RuntimeError, match="the look failed"):  # the look's own error, when its lag is wanted
        tribodyn.analyze(_dynamic(), fs=1000.0, threads=2)
    monkeypatch.setattr(orchestration, "find_lag", real)


@pytest.mark.fast
def test_a_reciprocating_test_drops_the_look() -> None:
    failed: Future[Any] = Future()
    failed.set_exception(RuntimeError("the look failed"))
    assert orchestration._lag_of(failed, {"motion": "reciprocating"}) is None
    with pytest.raises(RuntimeError, match="the look failed"):
        orchestration._lag_of(failed, {"motion": "unidirectional"})
    found: Future[Any] = Future()
    found.set_result("lag")
    assert orchestration._lag_of(found, {"motion": "reciprocating"}) is None
    assert orchestration._lag_of(found, {}) == "lag"


@pytest.mark.fast
def test_the_side_thread_is_kept_and_a_forked_child_starts_its_own() -> None:
    """The look's thread is kept for the next call (starting one is a tenth of a short call's fixed part); a
    child made by fork after an analysis, where the parent's threads (the look's, the Rust kernels' pools) do
    not exist, starts its own (its first kernel call waited forever before)."""
    import multiprocessing
    import os

    from tribodyn.kernels.threads import side_job

    first = side_job(lambda: threading.current_thread())
    thread = first.result(timeout=30)
    assert side_job(lambda: threading.current_thread()).result(timeout=30) is thread
    if not hasattr(os, "fork"):
        pytest.skip("no fork on this platform")
    here = _child_headline()  # the parent's kernel pools and side thread exist before the fork
    ctx = multiprocessing.get_context("fork")
    with ctx.Pool(1) as pool:  # the child analyses with the look beside its pre-pass
        assert pool.apply_async(_child_headline).get(timeout=60) == here


def _child_headline() -> str:
    res = tribodyn.analyze(_dynamic(), fs=1000.0, threads=2)
    return str(res.headline)
