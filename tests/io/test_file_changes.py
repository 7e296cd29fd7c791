"""A recording truncated or overwritten while ``analyze`` reads it: an error, never a crash.

The kernel of the route "mapped" reads the file with ``pread`` (no memory
map: touching a mapped page past the end of a truncated file raises SIGBUS
and kills the process). Each case runs ``analyze`` in a child process in a
loop while the parent truncates or overwrites the file, and checks the
child ends with a worded error (or finishes before the change), never by a
signal.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

CHILD = textwrap.dedent(
    """
    import sys, time
    import tribodyn as td
    path, extra = sys.argv[1], eval(sys.argv[2])
    rec = td.open_recording(path, fs=1000.0, names=["fx", "fy", "fz", "i"])
    print("open", flush=True)
    t_end = time.monotonic() + 20
    runs = 0
    try:
        while time.monotonic() < t_end:
            td.analyze(rec, window=0.5, hop=0.5, threads=2, **extra)
            runs += 1
    except (td.RecordingError, ValueError) as exc:
        print("error", type(exc).__name__, str(exc).splitlines()[0], flush=True)
        sys.exit(0)
    print("no error after", runs, "runs", flush=True)
    """
)


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    from tribodyn import simulate

    ch = next(iter(simulate.continuous(1200.0, chunk_s=1200.0, current=4.0, seed=2, fs=1000.0)))
    a = np.stack([ch[r] for r in ("fx", "fy", "fz", "i")])
    p = tmp_path_factory.mktemp("changes") / "rec.npy"
    np.save(p, a)
    return p


def _truncate(p):
    with open(p, "r+b") as fh:
        fh.truncate(os.path.getsize(p) // 3)


def _overwrite_shorter(p):
    # As `cp short.npy p` does: the same inode, truncated, then written.
    with open(p, "wb") as fh:
        fh.write(b"\x93NUMPY" + b"\0" * 1000)


@pytest.mark.parametrize("change", [_truncate, _overwrite_shorter], ids=["truncate", "overwrite"])
@pytest.mark.parametrize("extra", ["{}", "{'highpass': 0.1}", "{'max_lag': 0}"], ids=["mapped", "mapped-raw", "spans"])
def test_change_during_analyze_is_an_error_not_a_signal(recording, tmp_path, change, extra):
    p = tmp_path / "rec.npy"
    shutil.copy(recording, p)
    proc = subprocess.Popen(
        [sys.executable, "-c", CHILD, str(p), extra], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    assert proc.stdout is not None
    assert proc.stdout.readline().strip() == "open"
    time.sleep(0.3)  # some runs under way
    change(p)
    out, err = proc.communicate(timeout=60)
    how = signal.Signals(-proc.returncode).name if proc.returncode < 0 else f"exit {proc.returncode}"
    assert proc.returncode == 0, f"child ended by {how}: {err[-500:]}"
    assert out.startswith("error RecordingError"), out + err[-500:]
    assert "truncated" in out or "ends early" in out or "changed" in out, out


@pytest.mark.parametrize("fmt", ["npy", "h5", "tdms", "csv"])
def test_a_file_rewritten_after_opening_is_refused_by_every_format(tmp_path, fmt):
    """Same size, other numbers (as `cp other file` does): the size/mtime/inode check catches it."""
    import tribodyn as td
    from tribodyn.io.writers import save_hdf5, save_npy, save_tdms

    rng = np.random.default_rng(1)
    fz = rng.normal(size=20_000)
    ch = {"fx": rng.normal(size=20_000), "fy": -0.1 * fz, "fz": fz, "i": np.full(20_000, 4.0)}
    p = tmp_path / f"r.{fmt}"

    def write(c):
        if fmt == "npy":
            if p.exists():  # in place, as `cp` does (save_npy renames a new file over the path)
                tmp = tmp_path / "new.npy"
                save_npy(tmp, c)
                with open(p, "r+b") as fh:
                    fh.write(tmp.read_bytes())
            else:
                save_npy(p, c)
        elif fmt == "h5":
            save_hdf5(p, c, 1000.0)
        elif fmt == "tdms":
            save_tdms(p, c, 1000.0)
        else:
            np.savetxt(p, np.column_stack([c[r] for r in ("fx", "fy", "fz", "i")]), fmt="%.6e", delimiter=",",
                       header="fx,fy,fz,i", comments="")  # fmt: skip

    write(ch)
    opts = {"names": ["fx", "fy", "fz", "i"]} if fmt == "npy" else {}
    with td.open_recording(p, fs=1000.0, **opts) as rec:
        size = os.path.getsize(p)
        time.sleep(0.01)
        write({k: v * 1.5 for k, v in ch.items()})  # same layout and size, other values
        assert os.path.getsize(p) == size
        with pytest.raises(td.RecordingError, match="changed|truncated|ends early"):
            td.analyze(rec, window=1.0, hop=1.0)
