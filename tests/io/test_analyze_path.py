"""``td.analyze(path)`` opens the file as ``open_recording`` does (issue 21)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import tribodyn as td
from tribodyn.io import RecordingError


def _csv(tmp_path, names=("Time", "Fy", "Fz"), with_time=True, n=2000, fs=100.0):
    rng = np.random.default_rng(1)
    fz = 10 + rng.standard_normal(n)
    fy = 0.3 * fz + 0.02 * rng.standard_normal(n)
    cols = ([np.arange(n) / fs] if with_time else []) + [fy, fz]
    p = tmp_path / "run.csv"
    rows = "".join(",".join(f"{c[k]:.6f}" for c in cols) + "\n" for k in range(n))
    p.write_text(",".join(names) + "\n" + rows)
    return p


def _open_fds():
    return len(os.listdir("/proc/self/fd")) if os.path.isdir("/proc/self/fd") else None


@pytest.mark.fast
@pytest.mark.parametrize("kind", [str, Path])
def test_analyze_a_path_equals_analyze_the_opened_recording(tmp_path, kind):
    p = _csv(tmp_path)
    with td.open_recording(p) as rec:
        want = td.analyze(rec, window=2.0, hop=2.0)
    before = _open_fds()
    got = td.analyze(kind(p), window=2.0, hop=2.0)
    assert _open_fds() == before  # the file was closed
    assert got.params["fs"] == 100.0
    np.testing.assert_array_equal(got["mu_r"], want["mu_r"])
    np.testing.assert_array_equal(got["mu_classical"], want["mu_classical"])
    assert got.warnings == want.warnings


@pytest.mark.fast
def test_a_recording_without_fy_or_fz_names_its_channels_and_the_map(tmp_path):
    p = _csv(tmp_path, names=("Time", "A", "B"))
    for source in (p, td.open_recording(p)):  # the path and an open recording: one message, before any reading
        with pytest.raises(ValueError) as err:
            td.analyze(source)
        msg = str(err.value)
        assert msg.startswith(f"{p.name}: lacks the required channel(s) fy, fz (mapped: ")
        assert "'A', 'B'" in msg and "channels={'fy': CHANNEL, 'fz': CHANNEL}" in msg and "chunk" not in msg


@pytest.mark.fast
def test_channels_are_passed_to_open_recording(tmp_path):
    p = _csv(tmp_path, names=("Time", "A", "B"))
    with pytest.raises(ValueError, match="lacks the required channel"):
        td.analyze(p)
    res = td.analyze(p, channels={"fy": "A", "fz": "B"}, window=2.0, hop=2.0)
    assert res.params["roles"]["fy"] == "A" and len(res) == 10


@pytest.mark.fast
def test_fs_is_passed_to_open_recording(tmp_path):
    p = _csv(tmp_path, names=("Fy", "Fz"), with_time=False)
    with pytest.raises(RecordingError, match="sampling rate unknown"):
        td.analyze(str(p))
    res = td.analyze(str(p), fs=100.0, window=2.0, hop=2.0)
    assert res.params["fs"] == 100.0 and len(res) == 10


@pytest.mark.fast
def test_a_missing_path_is_a_recording_error(tmp_path):
    with pytest.raises(RecordingError):
        td.analyze(tmp_path / "missing.csv")
