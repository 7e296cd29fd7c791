"""How much of a recording the command line reads (issue 22 point 5): ``/proc/self/io`` rchar, and how often
it opens it.

rchar counts every byte read by the process and the children it reaped, of every file: besides the
recording, the output step's modules, fonts and the report's scripts (tens of MB, whatever the
recording). So the CLI runs on two recordings of the same kind, n and 2 n samples, and the reads that
grow with the recording are the difference of the two runs over the difference of their sizes.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
import pytest
import tribodyn.io as tio
from tribodyn.app import cli
from tribodyn.io import sample as prepass_sample
from tribodyn.pipeline import stickslip

needs_proc_io = pytest.mark.skipif(
    not sys.platform.startswith("linux") or not os.path.exists("/proc/self/io"), reason="needs /proc/self/io"
)

#: Whole readings of the recording: the analysis, which also finds the stick-slip (docs/method.md 6g), and
#: the input's SHA-256 (a thread of its own: the analysis reads the channels of a channels-first .npy side by
#: side, so the hash cannot take its bytes in file order); the rest are bounded samples. With a tolerance for
#: the fonts and labels the two reports draw differently.
WHOLE_READS = 2
TOLERANCE = 0.25


def rchar() -> int:
    with open("/proc/self/io") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("rchar"))


def write_recording(path: Path, n: int) -> int:
    """A unidirectional test with a static load and a saw-tooth friction (stick-slip) as channels-first
    float64 .npy (fy, fz) at 1 kHz; its size in bytes."""
    rng = np.random.default_rng(n)
    k = np.arange(n)
    fz = 20.0 + 2.0 * np.sin(2 * np.pi * 13.0 * k / 1000.0) + 0.03 * rng.standard_normal(n)
    fy = -(0.2 * fz + 0.3 * (np.mod(k / 37.3, 1.0) - 0.5)) + 0.03 * rng.standard_normal(n)
    np.save(path, np.vstack([fy, fz]))
    return path.stat().st_size


def cli_reads(tmp_path: Path, n: int) -> tuple:
    """(rchar of one CLI analysis with its report, the recording's size in bytes)."""
    p = tmp_path / f"rec{n}.npy"
    size = write_recording(p, n)
    r0 = rchar()
    code = cli.main(["analyze", str(p), "--out", str(tmp_path / f"out{n}"), "--fs", "1000", "--map",
                     "fy=ch0,fz=ch1", "-q"])  # fmt: skip
    assert code == 0
    return rchar() - r0, size


@needs_proc_io
def test_the_cli_reads_a_recording_twice_and_bounded_samples(tmp_path, monkeypatch):
    # blocks and samples far shorter than the recordings (4 and 8 stick-slip blocks), as for hours at 1 kHz
    monkeypatch.setattr(stickslip, "BLOCK", 1 << 16)
    monkeypatch.setattr(stickslip, "SAMPLE", 1 << 15)
    monkeypatch.setattr(prepass_sample, "PREPASS_SAMPLES", 1 << 14)
    n = 1 << 18
    small, s1 = cli_reads(tmp_path, n)
    big, s2 = cli_reads(tmp_path, 2 * n)
    again, _ = cli_reads(tmp_path, n)  # the first run also imported the output step's modules here
    per_byte = (big - again) / (s2 - s1)
    assert per_byte <= WHOLE_READS + TOLERANCE, f"the CLI read the recording {per_byte:.2f} times"
    assert per_byte >= WHOLE_READS - TOLERANCE  # the measurement sees the reads it bounds
    assert small >= again - (1 << 20)


def test_the_cli_opens_a_recording_once(tmp_path, monkeypatch):
    # Opening a text file reads it whole: the channel map, the figures' windows and stick-slip read the
    # recording the analysis opened.
    import tribodyn.io as tio

    opened = []
    real = tio.open_recording

    def counted(*args, **kwargs):
        opened.append(args[0])
        return real(*args, **kwargs)

    monkeypatch.setattr(tio, "open_recording", counted)
    n = 20_000
    k = np.arange(n)
    fz = 20.0 + 0.03 * np.random.default_rng(1).standard_normal(n)
    fy = -(0.2 * fz + 0.3 * (np.mod(k / 37.3, 1.0) - 0.5))
    p = tmp_path / "rec.csv"
    np.savetxt(p, np.column_stack([k / 1000.0, fy, fz]), delimiter=",", header="time,fy,fz", comments="")
    assert cli.main(["analyze", str(p), "--out", str(tmp_path / "out"), "-q"]) == 0
    assert len(opened) == 1
    summary = (tmp_path / "out" / "summary.json").read_text()
    assert '"events"' in summary and "fy (" in summary  # stick-slip and the channel map, from that opening


@needs_proc_io
def test_a_text_recording_is_parsed_reading_each_byte_about_once(tmp_path):
    # Each piece between two of the scan's checkpoints reads about its own bytes: its last read is sized by
    # the bytes its remaining rows take, not a whole block past them (was 1.12x the file on 2 h).
    n = 400_000
    k = np.arange(n)
    rng = np.random.default_rng(3)
    fz = 20.0 + rng.standard_normal(n)
    fy = 0.2 * fz + 0.01 * rng.standard_normal(n)
    p = tmp_path / "rec.csv"
    np.savetxt(p, np.column_stack([k / 1000.0, fy, fz]), delimiter=",", fmt="%.6f", header="time,fy,fz", comments="")
    size = p.stat().st_size
    with tio.open_recording(p) as rec:
        r0 = rchar()
        got = sum(len(c["fz"]) for c in rec.chunks(1 << 17))
        per_byte = (rchar() - r0) / size
    assert got == n
    assert 0.95 <= per_byte <= 1.03, f"a pass over the samples read the file {per_byte:.3f} times"
