"""Faults found by fuzzing the inputs (issue 34, item 10): each now a one-line error (exit 2) in bounded
time and memory, or read right: a config or summary nested hundreds deep, a resampling rate far above the
file's, HDF5 files of thousands of nested groups or of billions of samples never written, the HDF5 text
attribute helper's limit on a loaded machine, a bare carriage return in a CSV, an input named ``..npz``."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest

from tribodyn.app import cli
from tribodyn.io import RecordingError, _h5attrs, open_recording
from tribodyn.io.writers import save_npz

DATA = Path(__file__).parent / "data" / "formats"


def one_error(capsys) -> str:
    err = capsys.readouterr().err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("tribodyn: error: ") and "Traceback" not in err, err
    return lines[0]


@pytest.fixture
def rec(tmp_path) -> Path:
    rng = np.random.default_rng(0)
    fz = 10 + 0.1 * rng.standard_normal(4000)
    p = tmp_path / "rec.npz"
    save_npz(p, {"fy": 0.2 * fz + 0.01 * rng.standard_normal(4000), "fz": fz}, 1000.0)
    return p


@pytest.mark.fast
@pytest.mark.parametrize("toml", ["map = " + "[" * 500 + "]" * 500, "map = " + "{a = " * 500 + "1" + "}" * 500])
def test_a_config_nested_500_deep_is_one_line(tmp_path, rec, capsys, toml):
    cfg = tmp_path / "deep.toml"
    cfg.write_text(toml + "\n")
    assert cli.main(["analyze", str(rec), "--out", str(tmp_path / "o"), "--config", str(cfg)]) == 2
    assert "deep.toml: values nested too deeply" in one_error(capsys)
    assert not (tmp_path / "o").exists()


@pytest.mark.fast
def test_compare_of_a_deeply_nested_summary_is_one_line(tmp_path, capsys):
    d = tmp_path / "run"
    d.mkdir()
    (d / "summary.json").write_text('{"recordings":' + '{"a":' * 5000 + "1" + "}" * 5001)
    assert cli.main(["compare", str(d), str(d / "summary.json"), "--out", str(tmp_path / "o")]) == 2
    line = one_error(capsys)
    assert "JSON nested too deeply to read" in line or "given twice" in line
    assert cli.main(["compare", str(d), "--out", str(tmp_path / "o")]) == 2
    assert "summary.json is not a tribodyn summary (JSON nested too deeply to read)" in one_error(capsys)


@pytest.mark.fast
def test_resample_far_above_the_files_rate_is_refused_before_allocating(tmp_path, capsys):
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.5, 1.5, 3000)) * 1e-3  # irregular, about 1 kHz
    p = tmp_path / "irr.csv"
    p.write_text("time,fy,fz\n" + "".join(f"{x:.6f},{2 + np.sin(x):.4f},10.0\n" for x in t))
    t0 = time.monotonic()
    assert cli.main(["analyze", str(p), "--resample", "1e9", "--out", str(tmp_path / "o")]) == 2
    line = one_error(capsys)
    assert "resample=1e+09 Hz would make" in line and "at most 2 GiB" in line and "the file's own (about 10" in line
    assert time.monotonic() - t0 < 30
    with open_recording(p, resample=2000.0) as r:  # a sensible rate still works
        assert r.fs == 2000.0 and r.n_samples == int((t[-1] - t[0]) * 2000 + 1e-9) + 1


@pytest.mark.fast
def test_hdf5_groups_nested_2000_deep_are_refused_in_bounded_time(tmp_path):
    p = tmp_path / "nested.h5"
    with h5py.File(p, "w") as f:
        g = f
        for _ in range(2000):
            g = g.create_group("g")
        g.create_dataset("fy", data=np.ones(100))
        f.create_dataset("fz", data=np.ones(100))
    t0 = time.monotonic()
    with pytest.raises(RecordingError, match="HDF5 groups nested more than 64 deep"):
        open_recording(p, fs=100.0)
    assert time.monotonic() - t0 < 10  # libhdf5's visititems took 21 s here, the reader's rate search 100 s


@pytest.mark.fast
def test_hdf5_walk_keeps_visititems_order_and_reads_hard_links_once(tmp_path):
    p = tmp_path / "tree.h5"
    with h5py.File(p, "w") as f:
        f.attrs["fs"] = 100.0
        f.create_dataset("b/fz", data=np.ones(50))
        f.create_dataset("a/x/fy", data=np.arange(50.0))
        f.create_dataset("c", data=np.zeros(50))
        f["a/link"] = f["c"]  # a hard link: one object, two names
    with h5py.File(p, "r") as f:
        order = []
        f.visititems(lambda n, o: order.append(n) if isinstance(o, h5py.Dataset) else None)
    with open_recording(p) as r:
        assert r.channel_names == order == ["a/link", "a/x/fy", "b/fz"]


@pytest.mark.fast
def test_hdf5_samples_never_written(tmp_path):
    p = tmp_path / "huge.h5"
    with h5py.File(p, "w") as f:
        f.attrs["fs"] = 1000.0
        for name in ("fy", "fz"):
            f.create_dataset(name, shape=(300_000_000_000,), dtype="f8", chunks=(1 << 20,))
    t0 = time.monotonic()
    with pytest.raises(RecordingError, match="declares 300000000000 samples of which 300000000000 were never written"):
        open_recording(p)
    assert time.monotonic() - t0 < 10
    q = tmp_path / "sparse.h5"
    with h5py.File(q, "w") as f:
        f.attrs["fs"] = 1000.0
        f.create_dataset("fy", data=np.arange(5000.0), chunks=(1000,))
        d = f.create_dataset("fz", shape=(5000,), dtype="f8", chunks=(1000,), fillvalue=7.0)
        d[:1000] = 1.0
    with open_recording(q) as r:
        assert any("fz: 4000 of 5000 samples were never written" in w and "7.0" in w for w in r.warnings)
        assert r.read("fz")["fz"][-1] == 7.0


def _h5_with_unit(path: Path) -> Path:
    with h5py.File(path, "w") as f:
        f.attrs["fs"] = 100.0
        f.create_dataset("fy", data=np.ones(10)).attrs["unit"] = "N"
    return path


_SLOW_READY = (
    "import sys, struct, pickle, time\n"
    "def send(o):\n    b = pickle.dumps(o)\n    sys.stdout.buffer.write(struct.pack('<Q', len(b)) + b)\n"
    "    sys.stdout.buffer.flush()\n"
    "send(('ready', 'x', True))\n"
    "while True:\n    head = sys.stdin.buffer.read(8)\n    if len(head) < 8:\n        break\n"
    "    path, items, cpu = pickle.loads(sys.stdin.buffer.read(struct.unpack('<Q', head)[0]))\n"
    "    time.sleep(2.5)\n    send(('done', [('ok', 'N') for _ in items]))\n"
)


def test_a_slow_but_idle_helper_is_waited_for(tmp_path, monkeypatch):
    """A helper that spends no CPU time (a loaded machine, a slow disk) past the limit still answers."""
    _h5attrs._stop()
    monkeypatch.setattr(_h5attrs, "_HELPER", _SLOW_READY)
    monkeypatch.setattr(_h5attrs, "TIME_LIMIT", 1.0)
    with open_recording(_h5_with_unit(tmp_path / "a.h5")) as r:
        assert r.channels[0].raw_unit == "N"
    _h5attrs._stop()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="RLIMIT_CPU checked on Linux")
def test_a_helper_spinning_past_its_cpu_limit_is_stopped(tmp_path, monkeypatch):
    hook = "    if limit_cpu is not None:\n        limit_cpu(cpu)\n"
    assert hook in _h5attrs._HELPER
    _h5attrs._stop()
    monkeypatch.setattr(_h5attrs, "_HELPER", _h5attrs._HELPER.replace(hook, hook + "    while True:\n        pass\n"))
    monkeypatch.setattr(_h5attrs, "TIME_LIMIT", 1.0)
    t0 = time.monotonic()
    with pytest.raises(RecordingError, match=r"did not finish within 1 s of CPU time \(corrupt global heap\?\)"):
        open_recording(_h5_with_unit(tmp_path / "a.h5"))
    assert time.monotonic() - t0 < 10 + 5  # at most 2 s of CPU time; the wall-clock wait is 10 s
    assert _h5attrs._helper is None
    monkeypatch.undo()
    with open_recording(tmp_path / "a.h5") as r:  # a new helper reads it
        assert r.channels[0].raw_unit == "N"


@pytest.mark.fast
@pytest.mark.parametrize("where", [50, 1, 1500])  # in the head (400 lines), or where the native scan meets it
def test_a_bare_cr_is_a_line_end(tmp_path, where):
    rows = ["time,fy,fz"] + [f"{k * 0.001:.3f},{0.5 + 0.01 * (k % 7):.3f},5.0" for k in range(2000)]
    text = "\n".join(rows[:where]) + "\r" + "\n".join(rows[where:]) + "\n"
    p = tmp_path / "cr.csv"
    p.write_bytes(text.encode())
    want = pd.read_csv(p)  # pandas' C parser takes a CR as a line end
    with open_recording(p) as r:
        assert r.channel_names == ["time", "fy", "fz"] and r.n_samples == 2000 == len(want)
        assert r.roles == {"fy": "fy", "fz": "fz"}
        assert any("1 bare carriage return(s)" in w for w in r.warnings)
        got = r.read(["fy", "time"])
    assert np.array_equal(got["fy"], want["fy"].to_numpy()) and np.array_equal(got["time"], want["time"].to_numpy())
    crlf = tmp_path / "crlf.csv"
    crlf.write_bytes("\r\n".join(rows).encode() + b"\r\n")
    with open_recording(crlf) as r:  # CRLF line ends are not bare CRs
        assert r.n_samples == 2000 and not any("carriage" in w for w in r.warnings)


def test_an_input_named_dotdot_npz_keeps_its_own_outputs(tmp_path, rec, capsys):
    odd = tmp_path / "..npz"
    odd.write_bytes(rec.read_bytes())
    out = tmp_path / "o"
    assert cli.main(["analyze", str(odd), str(rec), "--out", str(out), "-q", "--window", "1", "--hop", "1"]) == 0
    assert (out / "npz" / "summary.json").is_file() and (out / "rec" / "summary.json").is_file()
    assert sorted(json.loads((out / "summary.json").read_text())["recordings"]) == ["..npz", "rec.npz"]
