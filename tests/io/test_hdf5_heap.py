"""HDF5 text attributes whose read never ends (issue 21): a corrupt global heap makes libhdf5 loop forever
holding the GIL, so variable-length text attributes are read by a helper process with a time limit; a read
that does not finish is a RecordingError, never a hang. Numbers and fixed-length text stay in-process."""

from __future__ import annotations

import struct
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest
from _forks import exit_code_of
import tribodyn as td
from tribodyn.io import RecordingError, _h5attrs


def _h5(path, text_attrs=True):
    with h5py.File(path, "w") as f:
        f.attrs["fs"] = 100.0
        if text_attrs:
            f.attrs["title"] = "run 7"  # a Python str: variable-length text, in the global heap
        d = f.create_dataset("fy", data=np.arange(50.0))
        d.attrs["unit"] = "N" if text_attrs else np.bytes_("N")  # np.bytes_: fixed-length text
        f.create_dataset("fz", data=np.arange(50.0) + 1)
    return path


def _corrupt_heap(path):
    """Heap object 1 (the first text) of size 0: libhdf5 2.0 loops forever reading it."""
    b = bytearray(path.read_bytes())
    g = b.find(b"GCOL")
    assert g > 0 and b[g + 16 : g + 18] == b"\x01\x00", "layout of the global heap changed"
    b[g + 24 : g + 32] = struct.pack("<Q", 0)
    path.write_bytes(bytes(b))


def test_text_attributes_are_read(tmp_path):
    with td.open_recording(_h5(tmp_path / "a.h5")) as rec:
        assert rec.channels[0].raw_unit == "N"
        assert rec.metadata["attributes"] == {"fs": 100.0, "title": "run 7"}


def test_corrupt_global_heap_is_refused_within_the_limit(tmp_path):
    # In a child: a reader that still hung would hang this test instead of failing it.
    p = _h5(tmp_path / "hang.h5")
    _corrupt_heap(p)
    code = (
        "import sys, time\nfrom tribodyn.io import open_recording, RecordingError, _h5attrs\n"
        "_h5attrs.TIME_LIMIT = 2.0\nt = time.monotonic()\n"
        "try:\n    open_recording(sys.argv[1])\nexcept RecordingError as e:\n"
        "    print(round(time.monotonic() - t, 1), e)\n"
    )
    r = subprocess.run([sys.executable, "-c", code, str(p)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    took, _, msg = r.stdout.strip().partition(" ")
    assert "attribute(s) 'unit' of 'fy'" in msg and str(p) in msg, msg
    assert float(took) < 2.0 + 30.0  # the limit, plus the helper's start on a loaded machine


def test_a_read_that_does_not_answer_is_abandoned(tmp_path, monkeypatch):
    """A helper that never answers (a simulated hang, independent of libhdf5) is killed at the limit."""
    sleeper = (
        "import sys, struct, pickle, time\n"
        "b = pickle.dumps(('ready', 'x'))\nsys.stdout.buffer.write(struct.pack('<Q', len(b)) + b)\n"
        "sys.stdout.buffer.flush()\ntime.sleep(600)\n"
    )
    _h5attrs._stop()
    monkeypatch.setattr(_h5attrs, "_HELPER", sleeper)
    monkeypatch.setattr(_h5attrs, "TIME_LIMIT", 1.0)
    p = _h5(tmp_path / "a.h5")
    t = time.monotonic()
    with pytest.raises(RecordingError, match=r"did not finish within 1 s \(corrupt global heap\?\): file refused"):
        td.open_recording(p)
    assert time.monotonic() - t < 1.0 + 30.0
    assert _h5attrs._helper is None  # killed, not kept
    monkeypatch.undo()
    with td.open_recording(p) as rec:  # a new helper reads the same file
        assert rec.channels[0].raw_unit == "N"


def test_a_helper_that_dies_is_a_recording_error(tmp_path, monkeypatch):
    dies = (
        "import sys, struct, pickle, os\n"
        "b = pickle.dumps(('ready', 'x'))\nsys.stdout.buffer.write(struct.pack('<Q', len(b)) + b)\n"
        "sys.stdout.buffer.flush()\nsys.stdin.buffer.read(8)\nos._exit(3)\n"
    )
    _h5attrs._stop()
    monkeypatch.setattr(_h5attrs, "_HELPER", dies)
    with pytest.raises(RecordingError, match=r"the HDF5 library crashed reading the text attribute\(s\) 'unit'"):
        td.open_recording(_h5(tmp_path / "a.h5"))
    _h5attrs._stop()


def test_without_a_helper_the_attributes_are_read_in_process_with_a_warning(tmp_path, monkeypatch):
    _h5attrs._stop()
    monkeypatch.setattr(sys, "executable", str(tmp_path / "no-python"))
    with td.open_recording(_h5(tmp_path / "a.h5")) as rec:
        assert rec.channels[0].raw_unit == "N" and rec.metadata["attributes"]["title"] == "run 7"
        assert any("without a time limit" in w for w in rec.warnings)
    _h5attrs._stop()


def test_numbers_and_fixed_text_never_start_the_helper(tmp_path, monkeypatch):
    def refuse(*a, **k):
        raise AssertionError("helper asked")

    monkeypatch.setattr(_h5attrs, "read_attributes", refuse)
    with td.open_recording(_h5(tmp_path / "a.h5", text_attrs=False)) as rec:
        assert rec.channels[0].raw_unit == "N" and rec.fs == 100.0
    p = tmp_path / "b.h5"  # a text attribute where a rate is looked for: never read
    with h5py.File(p, "w") as f:
        f.attrs["fs"] = 50.0
        g = f.create_group("run")
        g.attrs["fs"] = "100"
        g.create_dataset("fy", data=np.arange(50.0))
        g.create_dataset("fz", data=np.arange(50.0))
    with td.open_recording(p) as rec:
        assert rec.fs == 50.0 and rec.info()["fs_source"] == "attribute 'fs' of '/'"


def test_one_helper_serves_every_open(tmp_path):
    p = _h5(tmp_path / "a.h5")
    td.open_recording(p).close()
    helper = _h5attrs._helper
    assert helper is not None
    for _ in range(5):
        td.open_recording(p).close()
    assert _h5attrs._helper is helper and helper.proc.poll() is None


@pytest.mark.fast
def test_a_child_forked_while_another_thread_asks_the_helper_opens_hdf5(tmp_path):
    """multiprocessing's fork while a thread of the parent holds the helper's lock (starting the helper, ~0.2 s,
    or asking it): the child starts its own helper under a new lock and reads the file's text attributes (it
    waited forever for the copied lock before; issue 38 audit). Its copies of the parent's helper pipes lead
    nowhere, so the parent's helper goes on answering the parent. The child is killed after 30 s (SIGALRM) so
    that the test fails instead of hanging."""
    import os
    import signal

    if not hasattr(os, "fork"):
        pytest.skip("no fork on this platform")
    p = _h5(tmp_path / "a.h5")
    td.open_recording(p).close()  # the parent's helper started
    helper = _h5attrs._helper
    with _h5attrs._lock:  # as a thread of the parent asking the helper at the moment of the fork
        pid = os.fork()
        if pid == 0:
            signal.signal(signal.SIGALRM, signal.SIG_DFL)
            signal.alarm(30)
            with td.open_recording(p) as rec:
                ok = rec.metadata["attributes"]["title"] == "run 7" and _h5attrs._helper is not helper
            os._exit(0 if ok else 3)
        code = exit_code_of(pid, 40, "the forked child did not open the file")
    assert code == 0  # (checked once the helper's lock is released)
    with td.open_recording(p) as rec:  # the parent's helper, unharmed
        assert rec.metadata["attributes"]["title"] == "run 7"
    assert _h5attrs._helper is helper and helper.proc.poll() is None
