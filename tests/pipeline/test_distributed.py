"""analyze_many: many recordings and ranges of long ones, serially and on a
Dask LocalCluster of two worker processes; failures and killed workers."""

from __future__ import annotations

import os
import threading
import time

import numpy as np
import pytest
import tribodyn as td
from tribodyn import simulate
from tribodyn.io.writers import save_recording
from tribodyn.pipeline.distributed import RecordingFailure, analyze_many, expand_paths
from _paths import TESTS

OPTS = dict(window=2.0, hop=5.0)


def _record(path, seconds, seed, current=None):
    chunks = list(simulate.continuous(seconds, chunk_s=30.0, seed=seed, current=current))
    channels = {k: np.concatenate([c[k] for c in chunks]) for k in chunks[0]}
    save_recording(path, channels, 1000.0)
    return path


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("many")
    paths = [
        _record(d / "a.h5", 60, 1),
        _record(d / "b.npz", 45, 2, current=3.0),
        _record(d / "long.h5", 400, 3),
    ]
    bad = d / "corrupt.tdms"
    raw = os.path.join(str(TESTS), "data", "real", "nptdms_raw1_daqmx.tdms")
    bad.write_bytes(open(raw, "rb").read()[:5000])
    return [str(p) for p in paths], str(bad)


def _serial(path):
    with td.open_recording(path) as rec:
        return td.analyze(rec, **OPTS)


def _same(a, b):
    assert a.columns == b.columns
    for col in a.columns:
        np.testing.assert_array_equal(a[col], b[col], err_msg=col)
    np.testing.assert_array_equal(a.bin_cof, b.bin_cof)
    assert a.orientation == b.orientation


def test_serial_many_equals_analyze_each(files):
    good, bad = files
    many = analyze_many(good + [bad], **OPTS)
    assert list(many.results) == good
    for p in good:
        _same(many.results[p], _serial(p))
    assert isinstance(many.failures[bad], RecordingFailure)
    assert "corrupt.tdms" not in many.failures[bad].error or many.failures[bad].error
    table = many.table
    assert len(table["recording"]) == sum(len(many.results[p]) for p in good)


def test_split_ranges_give_exactly_the_one_pass_windows(files):
    good, _ = files
    long = good[2]
    many = analyze_many([long], split=37.0, **OPTS)
    assert many.tasks > 5
    _same(many.results[long], _serial(long))


def test_expand_paths_directory_and_glob(files):
    good, bad = files
    d = os.path.dirname(good[0])
    assert expand_paths(d) == sorted(good + [bad])
    assert expand_paths(os.path.join(d, "*.h5")) == sorted(p for p in good if p.endswith(".h5"))
    with pytest.raises(FileNotFoundError):
        expand_paths(os.path.join(d, "*.nothing"))


@pytest.fixture(scope="module")
def client():
    distributed = pytest.importorskip("dask.distributed")
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0")
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def test_cluster_equals_serial_and_reports_failures(files, client):
    from dask.distributed import get_task_stream

    good, bad = files
    with get_task_stream(client) as stream:
        many = analyze_many(good + [bad], client=client, split=50.0, **OPTS)
    for p in good:
        _same(many.results[p], _serial(p))
    assert list(many.failures) == [bad]
    # each recording is finished on a worker, not in the client: by a task of its own after its ranges, or in
    # the task of its one range (b.npz); the corrupt file fails at its header, before any range
    finished = [t for t in stream.data if str(t["key"]).startswith(("finish_task", "_then"))]
    assert sum(str(t["key"]).startswith("_then") for t in finished) == 1
    assert len(finished) == len(good)
    assert all(t["worker"] in client.scheduler_info()["workers"] for t in finished)


def test_tasks_on_workers_share_their_hosts_cores(files, client):
    """Issue 38 point 4: W workers of one host, each running its kernels on every core, oversubscribe the host
    W times; a task that names no threads gets the host's cores over its task slots (here 2 slots)."""
    from tribodyn.pipeline.distributed import _host_slots, _worker_threads

    good, _ = files
    slots = _host_slots(client)
    assert slots is not None and sum(slots.values()) == 2
    share = max(1, td.get_threads() // 2)
    many = analyze_many(good[:2], client=client, **OPTS)
    assert {many.results[p].params["threads"] for p in good[:2]} == {share}
    for p in good[:2]:
        _same(many.results[p], _serial(p))
    asked = analyze_many(good[:1], client=client, threads=2, **OPTS)  # a count asked for is kept
    assert asked.results[good[0]].params["threads"] == 2
    assert _worker_threads({"127.0.0.1": 2}) is None  # not on a worker: the call's default
    assert _host_slots(object()) is None


def test_a_worker_with_tribodyn_threads_keeps_it(monkeypatch):
    from tribodyn.pipeline import distributed as dist

    monkeypatch.setenv("TRIBODYN_THREADS", "1")
    assert dist._worker_threads({"127.0.0.1": 1}) is None  # resolve_threads reads the variable


def test_finish_task_reports_the_first_failed_range():
    from tribodyn.pipeline.distributed import finish_task

    first, second = RecordingFailure("x.h5", "OSError: one", "OSError"), RecordingFailure("x.h5", "E: two", "E")
    assert finish_task("x.h5", [first, second]) is first
    got = finish_task("x.h5", [])  # combine refuses no ranges: reported, not raised
    assert isinstance(got, RecordingFailure) and got.kind == "ValueError" and "no ranges" in got.error


def test_killed_worker_loses_and_duplicates_nothing(files, client):
    good, _ = files
    long = good[2]
    want = _serial(long)
    result = {}

    def work():
        result["many"] = analyze_many([long], client=client, split=10.0, **OPTS)

    before = set(client.scheduler_info()["workers"])
    t = threading.Thread(target=work)
    t.start()
    victim = None
    deadline = time.time() + 60
    while victim is None and time.time() < deadline and t.is_alive():
        busy = [w for w, tasks in client.processing().items() if any("range_task" in str(k) for k in tasks)]
        victim = busy[0] if busy else None
        time.sleep(0.005)
    assert victim is not None, "the run ended before a worker could be killed"
    try:
        client.run(os._exit, 1, workers=[victim])
    except Exception:
        pass  # the worker dies before it can answer
    t.join(timeout=120)
    assert not t.is_alive()
    # The killed worker is gone (its nanny starts a new one at another address).
    deadline = time.time() + 30
    while victim in client.scheduler_info()["workers"] and time.time() < deadline:
        time.sleep(0.1)
    assert victim not in client.scheduler_info()["workers"] and victim in before
    got = result["many"].results[long]
    _same(got, want)
    assert len(np.unique(got["t_start"])) == len(got)


def test_cli_on_a_local_cluster_with_a_bad_file(files, tmp_path):
    from tribodyn.app import cli

    good, bad = files
    out = tmp_path / "out"
    code = cli.main(
        [
            "analyze",
            *good,
            bad,
            "--out",
            str(out),
            "--window",
            "2",
            "--hop",
            "5",
            "--scheduler",
            "local",
            "--workers",
            "2",
            "--split",
            "100",
            "--quiet",
        ]
    )
    assert code == 3  # some recordings failed, the others were written
    import json

    s = json.loads((out / "summary.json").read_text())
    assert list(s["failures"]) == ["corrupt.tdms"]
    assert sorted(s["recordings"]) == sorted(os.path.basename(p) for p in good)
    for p in good:
        assert (out / os.path.splitext(os.path.basename(p))[0] / "report.html").is_file()
    assert (out / "report.html").is_file() and (out / "windows.csv").is_file()


def test_without_dask_the_error_says_how_to_install(monkeypatch):
    import builtins

    from tribodyn.pipeline import distributed

    real = builtins.__import__

    def no_dask(name, *a, **k):
        if name.startswith("dask"):
            raise ImportError("No module named 'dask'")
        return real(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", no_dask)
    with pytest.raises(ImportError, match=r"pip install \"tribodyn\[dask\]\""):
        distributed.local_client()
