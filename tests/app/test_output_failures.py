"""A failed write to a new output folder leaves nothing behind (issue 21): not the folder, not its new parents."""

from __future__ import annotations

import errno

import numpy as np
import pytest
from tribodyn.app import cli, jobs
from tribodyn.app.outputs import OutputSet
from tribodyn.io.writers import save_npz


@pytest.fixture
def rec(tmp_path):
    rng = np.random.default_rng(0)
    fz = 10 + rng.standard_normal(4000)
    path = tmp_path / "in" / "rec.npz"
    path.parent.mkdir()
    save_npz(path, {"fy": 0.2 * fz + 0.01 * rng.standard_normal(4000), "fz": fz}, 200.0)
    return path


def test_a_failed_set_removes_the_folders_it_created(tmp_path):
    out = tmp_path / "a" / "b" / "out"
    with pytest.raises(RuntimeError, match="figure failed"):
        with OutputSet(out) as s:
            s.path("figures/x.png").write_bytes(b"partial")
            raise RuntimeError("figure failed")
    assert list(tmp_path.iterdir()) == []


def test_a_failed_set_keeps_a_folder_that_was_there(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    with pytest.raises(RuntimeError):
        with OutputSet(out):
            raise RuntimeError("boom")
    assert out.is_dir() and list(out.iterdir()) == [] and list(tmp_path.iterdir()) == [out]


def test_a_failed_publish_removes_the_new_folder(tmp_path, monkeypatch):
    import tribodyn.app.outputs as outputs

    def fail(stage, target, **kw):
        raise OSError(errno.EXDEV, "Invalid cross-device link", str(stage), None, str(target))

    monkeypatch.setattr(outputs, "publish", fail)
    with pytest.raises(OSError):
        with OutputSet(tmp_path / "new" / "out") as s:
            s.path("x.txt").write_text("x")
    assert list(tmp_path.iterdir()) == []


def test_a_successful_set_keeps_its_folder(tmp_path):
    with OutputSet(tmp_path / "new" / "out") as s:
        s.path("x.txt").write_text("x")
    assert (tmp_path / "new" / "out" / "x.txt").read_text() == "x"


def test_cli_writer_failure_leaves_no_output_folder(rec, tmp_path, monkeypatch, capsys):
    def full_disk(obj, path):
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(jobs, "write_json", full_disk)
    out = tmp_path / "results" / "run1"
    assert cli.main(["analyze", str(rec), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "No space left on device" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in"]  # neither results/ nor results/run1/


def test_cli_analysis_failure_leaves_no_output_folder(tmp_path, capsys):
    bad = tmp_path / "in.npz"
    save_npz(bad, {"fy": np.ones(100), "fz": np.ones(100)}, 100.0)  # shorter than one window
    out = tmp_path / "out"
    assert cli.main(["analyze", str(bad), "--out", str(out), "--window", "5", "--quiet"]) == 2
    assert not out.exists()


@pytest.mark.fast
def test_every_file_of_a_set_is_flushed_before_it_is_published_and_a_failed_flush_publishes_nothing(
    tmp_path, monkeypatch
):
    """OutputSet flushes each file and folder of the set (from several threads at once, issue 38 point 3) before
    publishing it; a flush that fails (EIO) is raised and the previous set stays as it was."""
    import os
    import threading

    out = tmp_path / "out"
    with OutputSet(out) as s:
        s.path("old.txt").write_text("old")
    names = [f"f{k}.txt" for k in range(20)] + [f"sub/g{k}.txt" for k in range(5)]
    flushed, threads = [], set()
    real_fsync = os.fsync

    def recording_fsync(fd):
        flushed.append(os.path.basename(os.readlink(f"/proc/self/fd/{fd}")))
        threads.add(threading.get_ident())
        return real_fsync(fd)

    monkeypatch.setattr(os, "fsync", recording_fsync)
    with OutputSet(out) as s:
        for n in names:
            s.path(n).write_text(n)
    assert {os.path.basename(n) for n in names} <= set(flushed) and "sub" in flushed
    assert len(threads) > 1 and (out / "sub" / "g4.txt").read_text() == "sub/g4.txt"

    def failing_fsync(fd):
        if os.readlink(f"/proc/self/fd/{fd}").endswith("f7.txt"):
            raise OSError(errno.EIO, "Input/output error")
        return real_fsync(fd)

    monkeypatch.setattr(os, "fsync", failing_fsync)
    with pytest.raises(OSError, match="Input/output error"):
        with OutputSet(out) as s:
            for n in names:
                s.path(n).write_text("new")
    assert (out / "f7.txt").read_text() == "f7.txt" and (out / "sub" / "g4.txt").read_text() == "sub/g4.txt"
