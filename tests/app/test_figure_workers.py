"""Figures drawn by worker processes (``jobs._DrawingPool``, issue 38 point 3): the same PNG bytes as drawn in the
process, every failure drawn in the process instead (a whole set, said nowhere), no pool for a small export, and
no worker left behind a killed command line."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import tribodyn as td
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter
from tribodyn.analyses.ranges import operating_range
from tribodyn.app import figures as F
from tribodyn.app import jobs
from _paths import REPO

ROOT = REPO
POD = ROOT / "tests/data/real/pod_PPS_100N_1.tsv"


@pytest.fixture(scope="module")
def pool():
    p = jobs._DrawingPool(2)
    yield p
    p.close()


def _small(k: int) -> Figure:
    fig, axes = F._figure(figsize=(2.0, 1.5))
    axes[0, 0].plot([0, k + 1], [1, 0], label=r"$\mu_r$")
    axes[0, 0].legend()
    return fig


def _by_workers(figs, pool):
    """index -> (PNG bytes, warnings) or None, every figure drawn by the workers (none taken by this process)."""
    return dict(F._queued(figs, F.DPI, pool).replies())


class _Reduce:
    """An attribute of a figure that runs ``call(*args)`` where the figure is unpickled: in a worker only."""

    def __init__(self, call, *args):
        self.call, self.args = call, args

    def __reduce__(self):
        return self.call, self.args


def test_workers_draw_the_same_bytes_as_this_process(cd_sim, cd_res, temp_res, pool):
    """Every figure of a dynamic recording (the window diagnostics, COF against time, J) and of the demo's
    temperature test (its operating range): the workers' PNG bytes are those drawn here, bytewise."""
    examples = jobs.diagnostic_examples(cd_sim.channels, cd_res)
    with jobs.one_blas_thread():
        opr_j = operating_range(cd_res, "current_density")
        opr_t = operating_range(temp_res, "temperature")
    named = jobs._figures(cd_res, opr_t=None, opr_j=opr_j, examples=examples)
    named += jobs._figures(temp_res, opr_t=opr_t, opr_j=None)
    figs = [f for _, _, f in named]
    got = _by_workers(figs, pool)
    assert len(figs) >= 8 and sorted(got) == list(range(len(figs)))
    for k, (stem, _, fig) in enumerate(named):
        assert got[k] is not None, stem
        assert got[k][0] == F.png_bytes(fig), stem


def test_an_export_analysed_with_workers_writes_the_same_files(tmp_path, monkeypatch):
    """tribodyn analyze of the pin-on-disc export, --figures all, every figure drawn by the workers: the same PNG
    files and report images as drawn in the process."""
    here, there = tmp_path / "here", tmp_path / "there"
    monkeypatch.setattr(jobs, "_drawing_pool", lambda pays: None)
    jobs.run_analysis([POD], here, figures="all")
    replies = []
    original = jobs._Batch.replies

    def counted(self):
        for k, reply in original(self):
            replies.append(reply is not None)
            yield k, reply

    monkeypatch.setattr(jobs, "_drawing_pool", lambda pays: jobs._DrawingPool(1))
    monkeypatch.setattr(jobs._Batch, "steal", lambda self: None)  # the workers draw every figure
    monkeypatch.setattr(jobs._Batch, "replies", counted)
    jobs.run_analysis([POD], there, figures="all")
    pngs = sorted(p.relative_to(here) for p in here.rglob("*.png"))
    assert pngs and pngs == sorted(p.relative_to(there) for p in there.rglob("*.png"))
    assert replies == [True] * len(pngs)
    for name in pngs:
        assert (here / name).read_bytes() == (there / name).read_bytes(), name
    images = re.compile(r"data:image/png;base64,[A-Za-z0-9+/=]+")
    assert images.findall((here / "report.html").read_text()) == images.findall((there / "report.html").read_text())


def test_what_fails_in_a_worker_is_drawn_here(pool, recwarn):
    """A figure that does not pickle, one whose unpickling fails in the worker and one that ends its worker: each
    drawn here; the set is whole and the same as drawn here, and nothing is printed or warned."""

    def figs():  # fresh each time: a constrained-layout figure drawn a second time may differ
        unpicklable = _small(1)
        unpicklable.axes[0].xaxis.set_major_formatter(FuncFormatter(lambda x, _: f"{x:.1f}"))
        failing = _small(2)
        failing._tribodyn_test = _Reduce(int, "not a number")  # ValueError where unpickled
        fatal = _small(3)
        fatal._tribodyn_test = _Reduce(os._exit, 3)  # the worker ends where unpickled
        return [_small(0), unpicklable, failing, fatal, _small(4)]

    expected = [F.png_bytes(f) for f in figs()]
    dying = jobs._DrawingPool(1)
    try:
        got = dict(F._queued(figs(), F.DPI, dying).replies())  # nothing stolen: each goes to the worker
    finally:
        dying.close()
    assert got[0] is not None and got[0][0] == expected[0]
    assert [got[k] for k in (1, 2, 3, 4)] == [None] * 4  # the last: its worker is gone (no wait for a timeout)
    assert F.Rendering(figs(), pool=pool).finish() == expected
    assert not [w for w in recwarn if "tribodyn" in str(w.filename)]


def test_a_dead_or_silent_pool_draws_here(monkeypatch):
    """Workers that died before the job, and a worker that does not answer (:data:`jobs._DRAW_TIMEOUT`): the
    figures are drawn here; the silent pool is closed, its worker gone."""

    def figs():
        return [_small(k) for k in range(3)]

    expected = [F.png_bytes(f) for f in figs()]
    dead = jobs._DrawingPool(1)
    for proc in dead._procs:
        proc.kill()
        proc.wait()
    assert F.Rendering(figs(), pool=dead).finish() == expected
    dead.close()
    monkeypatch.setattr(jobs, "_DRAW_TIMEOUT", 1.0)
    silent = jobs._DrawingPool(1)
    slow = _small(5)
    slow._tribodyn_test = _Reduce(time.sleep, 60.0)
    batch = F._queued([slow], F.DPI, silent)
    assert list(batch.replies()) == [(0, None)]  # no steal: waited for the worker, which did not answer
    assert silent._closed and all(p.poll() is not None for p in silent._procs)
    assert F.Rendering(figs(), pool=silent).finish() == expected  # a closed pool takes nothing
    assert not [p for p in silent._procs if p.poll() is None]


def test_the_pool_is_started_for_long_recordings_only(tmp_path, monkeypatch):
    """No worker for a small export (nothing to gain: few figures, a short analysis) nor with --figures none;
    workers for inputs of 16 MiB or more, unless no core is free or TRIBODYN_DRAW_WORKERS=0."""
    big = tmp_path / "big.npy"
    with open(big, "wb") as fh:
        fh.truncate(jobs._EARLY_MATPLOTLIB_BYTES)  # (sparse: only its size is read)
    assert not jobs._pool_pays("auto", [str(POD)]) and not jobs._pool_pays("all", [str(POD)])
    assert jobs._pool_pays("auto", [str(big)]) and jobs._pool_pays("all", [str(big)])
    assert not jobs._pool_pays("none", [str(big)])
    assert jobs._drawing_pool(False) is None
    started = []
    monkeypatch.setattr(jobs, "_DrawingPool", lambda n: started.append(n) or object())
    monkeypatch.setattr(jobs, "_usable_cores", lambda: 2)
    monkeypatch.setattr(jobs, "_load", lambda: 1.2)  # two cores, the second one busy: none
    assert jobs._drawing_pool(True) is None
    monkeypatch.setattr(jobs, "_load", lambda: 0.3)  # two cores, one idle: one worker
    assert jobs._drawing_pool(True) is not None and started == [1]
    monkeypatch.setattr(jobs, "_usable_cores", lambda: 1)
    assert jobs._drawing_pool(True) is None
    monkeypatch.undo()
    monkeypatch.setattr(jobs, "_usable_cores", lambda: 16)
    monkeypatch.setenv("TRIBODYN_DRAW_WORKERS", "0")
    assert jobs._drawing_pool(True) is None
    monkeypatch.delenv("TRIBODYN_DRAW_WORKERS")
    monkeypatch.setattr(jobs, "_busy", lambda: True)
    assert jobs._drawing_pool(True) is None
    monkeypatch.setenv("TRIBODYN_DRAW_WORKERS", "1")  # asked for: started even on busy cores
    pool = jobs._drawing_pool(True)
    assert pool is not None and len(pool._procs) == 1
    pool.close()


def _children(pid: int) -> list:
    out = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        with open(task / "children") as fh:
            out += [int(c) for c in fh.read().split()]
    return out


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"  # a zombie holds nothing
    except OSError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux") or len(os.sched_getaffinity(0)) < 2,
                    reason="Linux with two cores or more (the pool, /proc)")  # fmt: skip
def test_a_killed_command_line_leaves_no_worker(tmp_path):
    """``tribodyn analyze`` of a 20 MB recording, killed (SIGKILL) while its workers draw: none survives it."""
    rng = np.random.default_rng(0)
    n = 640_000  # 4 channels of float64: 20 MB
    fz = 50.0 + rng.normal(0.0, 5.0, n)
    data = np.vstack([rng.normal(0.0, 1.0, n), 0.3 * fz + rng.normal(0.0, 0.5, n), fz, np.ones(n)])
    rec = tmp_path / "rec.npy"
    np.save(rec, data)
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(Path(td.__file__).resolve().parents[1]), "TRIBODYN_DRAW_WORKERS": "2"}
    cli = subprocess.Popen([sys.executable, "-m", "tribodyn", "analyze", str(rec), "--out", str(out), "-q", "--fs",
                            "1000", "--map", "fx=ch0,fy=ch1,fz=ch2,i=ch3"], env=env,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # fmt: skip
    try:
        deadline = time.monotonic() + 120.0
        workers = []
        while time.monotonic() < deadline and cli.poll() is None:
            workers = workers or _children(cli.pid)
            if workers and list(tmp_path.glob("out.tribodyn-staging-*/windows.csv")):
                break  # the tables are written after the figures went to the workers: they are drawing
            time.sleep(0.02)
        assert cli.poll() is None, "the command line ended before it drew: nothing to kill"
        assert workers, "no drawing worker was started"
        os.kill(cli.pid, signal.SIGKILL)
        cli.wait()
        gone = time.monotonic() + 5.0
        while time.monotonic() < gone and any(_alive(w) for w in workers):
            time.sleep(0.05)
        assert not [w for w in workers if _alive(w)]
    finally:
        if cli.poll() is None:
            cli.kill()
            cli.wait()
