"""Faults of the text readers (delimited and LVM) found by fuzzing: a row cut off at
the end of a file, duplicate column names, paths that are not regular files, an
unknown ``encoding=``, and, by a seeded fuzz of small valid files, that a damaged
file either reads with the file's own numbers or raises :class:`RecordingError`.
"""

from __future__ import annotations

import builtins
import collections
import os
import stat
import threading
from pathlib import Path
from typing import Any, Callable, Dict

import numpy as np
import pytest
from tribodyn.io import RecordingError, detect_format, open_recording
from _paths import TESTS


REAL = TESTS / "data" / "real"
N = 12
T = [f"{k * 0.001:.3f}" for k in range(N)]
FY = [f"{3.0 * np.sin(k):.6f}" for k in range(N)]
FZ = [f"{-10.0 - k / 7:.6f}" for k in range(N)]
REF = {"fy": np.array([float(v) for v in FY]), "fz": np.array([float(v) for v in FZ])}


def csv_text(delim: str = ",", decimal: str = ".") -> str:
    rows = [delim.join(v.replace(".", decimal) for v in r) for r in zip(T, FY, FZ)]
    return delim.join(["time [s]", "fy [N]", "fz [N]"]) + "\n" + "".join(r + "\n" for r in rows)


def lvm_text() -> str:
    return (
        "LabVIEW Measurement\t\nWriter_Version\t2\nSeparator\tTab\nDecimal_Separator\t.\nMulti_Headings\tNo\n"
        "X_Columns\tOne\n***End_of_Header***\t\n\nChannels\t2\t\n"
        f"Samples\t{N}\t{N}\nY_Unit_Label\tN\tN\nDelta_X\t0.001\t0.001\n***End_of_Header***\t\t\n"
        "X_Value\tfy\tfz\tComment\n" + "".join(f"{a}\t{b}\t{c}\n" for a, b, c in zip(T, FY, FZ))
    )


LVM_HEADER_LINES = lvm_text().count("\n") - N  # the first data row is line LVM_HEADER_LINES + 1


def bounded(fn: Callable[[], Any], timeout: float = 10.0) -> Any:
    """``fn()`` in a daemon thread: its result or exception, or a test failure after ``timeout`` s."""
    box: Dict[str, Any] = {}

    def run() -> None:
        try:
            box["value"] = fn()
        except BaseException as exc:  # noqa: BLE001 - handed back to the caller
            box["error"] = exc

    th = threading.Thread(target=run, daemon=True)
    th.start()
    th.join(timeout)
    if th.is_alive():
        pytest.fail(f"no answer after {timeout} s (hang)")
    if "error" in box:
        raise box["error"]
    return box["value"]


def read_all(path: Path, **kw: Any):
    """Opens and reads fy/fz both whole and in chunks; checks that sizes and contents agree."""
    with open_recording(path, **kw) as rec:
        d = rec.read(["fy", "fz"])
        parts = collections.defaultdict(list)
        for c in rec.chunks(5, ["fy", "fz"]):
            for k, v in c.items():
                parts[k].append(v)
        for k, v in d.items():
            assert len(v) == rec.n_samples
            got = np.concatenate(parts[k]) if parts[k] else np.empty(0)
            np.testing.assert_array_equal(got, v)
        assert rec.duration == rec.n_samples / rec.fs
        return d, list(rec.warnings), rec


# ------------------------------------------------------------------ the last row
@pytest.mark.fast
@pytest.mark.parametrize("delim, decimal, suffix", [(",", ".", ".csv"), ("\t", ".", ".tsv"), (";", ",", ".txt")])
def test_delimited_cut_inside_last_number_drops_the_row(tmp_path, delim, decimal, suffix):
    data = csv_text(delim, decimal).encode()
    p = tmp_path / f"cut{suffix}"
    p.write_bytes(data[:-3])  # "-11.571429\n" -> "-11.5714": every field there, no line end
    d, warnings, rec = read_all(p)
    assert rec.n_samples == N - 1 and rec.fs == 1000.0 and rec.duration == (N - 1) / 1000.0
    for k in ("fy", "fz"):
        np.testing.assert_array_equal(d[k], REF[k][: N - 1])
    assert warnings == [f"last row (line {N + 1}) has no line end: dropped as possibly cut off"]
    assert rec.segments == [(0, N - 1)]


@pytest.mark.fast
def test_delimited_whole_file_reads_every_row_without_warning(tmp_path):
    p = tmp_path / "whole.csv"
    p.write_text(csv_text())
    d, warnings, rec = read_all(p)
    assert rec.n_samples == N and warnings == []
    np.testing.assert_array_equal(d["fy"], REF["fy"])
    p.write_text(csv_text()[:-1])  # no line end after a whole last row: still dropped (it may be cut)
    d, warnings, rec = read_all(p)
    assert rec.n_samples == N - 1 and warnings == [
        f"last row (line {N + 1}) has no line end: dropped as possibly cut off"
    ]


@pytest.mark.fast
@pytest.mark.parametrize(
    "tail, message",
    [
        ("0.012,1.5\n", "has 2 fields, expected 3: dropped"),  # with its line end
        ("0.012,1.5", "has 2 fields, expected 3 and no line end: dropped"),
        ("0.012,", "has 2 fields, expected 3 and no line end: dropped"),
        ("0.0", "has 1 fields, expected 3 and no line end: dropped"),
        ("0.012,1.5\n\n# end\n", "has 2 fields, expected 3: dropped"),  # blank and comment lines after it
    ],
)
def test_delimited_last_row_with_missing_fields_is_dropped(tmp_path, tail, message):
    p = tmp_path / "short.csv"
    p.write_text(csv_text() + tail)
    d, warnings, rec = read_all(p)
    assert rec.n_samples == N
    np.testing.assert_array_equal(d["fz"], REF["fz"])
    assert warnings == [f"last row (line {N + 2}) {message} as possibly cut off"]


@pytest.mark.fast
def test_delimited_short_row_before_the_end_is_still_an_error(tmp_path):
    p = tmp_path / "mid.csv"
    p.write_text(csv_text() + "0.012,1.5\n0.013,1.5,2.5\n")
    with pytest.raises(RecordingError, match=f"line {N + 2} has 2 fields, expected 3"):
        open_recording(p)


@pytest.mark.fast
def test_delimited_cut_row_alone_in_its_block(tmp_path):
    p = tmp_path / "blocks.csv"
    p.write_text("t,fy,fz\n0,1,2\n0.1,1.5,2.5\n\nrepeat 2\nt,fy,fz\n0,3,4.25")
    d, warnings, rec = read_all(p)
    assert rec.n_samples == 2 and rec.segments == [(0, 2)] and rec.fs == 10.0
    np.testing.assert_array_equal(d["fy"], [1.0, 1.5])
    assert warnings == ["last row (line 7) has no line end: dropped as possibly cut off"]


@pytest.mark.fast
def test_vendor_export_cut_inside_last_number_is_refused(tmp_path):
    data = (REAL / "cetr_umt2_HT-2n-6-4_2_001.csv").read_bytes().rstrip(b"\r\n")
    p = tmp_path / "cut.csv"
    p.write_bytes(data[:-2])  # "...,0.834374" -> "...,0.8343"
    with pytest.raises(RecordingError, match=r"last row \(line \d+\) has no line end: incomplete row, file truncated"):
        open_recording(p)


@pytest.mark.fast
def test_lvm_last_row_must_be_whole(tmp_path):
    data = lvm_text().encode()
    last = LVM_HEADER_LINES + N
    p = tmp_path / "cut.lvm"
    p.write_bytes(data[:-3])
    with pytest.raises(RecordingError, match=rf"last row \(line {last}\) has no line end: incomplete row"):
        open_recording(p)
    p.write_bytes(data[: data.rfind(b"\t")] + b"\n")  # a whole line missing its last field
    with pytest.raises(RecordingError, match=rf"last row \(line {last}\) has 2 fields, expected 3: incomplete row"):
        open_recording(p)
    p.write_bytes(data)
    d, warnings, rec = read_all(p)
    assert rec.n_samples == N and warnings == []
    np.testing.assert_array_equal(d["fy"], REF["fy"])


@pytest.mark.fast
def test_lvm_bad_header_numbers_are_recording_errors(tmp_path):
    p = tmp_path / "inf.lvm"
    p.write_text(lvm_text().replace(f"Samples\t{N}\t{N}", "Samples\tinf\tinf"))
    d, _, rec = read_all(p)  # an unusable announced count is ignored, the rows are counted
    assert rec.n_samples == N
    p = tmp_path / "channels.lvm"  # no column row: the channels come from "Channels"
    p.write_text(lvm_text().replace("X_Value\tfy\tfz\tComment\n", "").replace("Channels\t2", "Channels\t2000000000"))
    with pytest.raises(RecordingError, match="announces 2000000001 columns"):
        bounded(lambda: open_recording(p))


@pytest.mark.fast
def test_decimal_comma_semicolon_file_is_not_split_at_its_commas(tmp_path):
    """'1,5;2,5;3,5' holds three numbers split at ';' (it was read as "1", "5;2", "5;3", "5")."""
    p = tmp_path / "eu.csv"
    p.write_text("a;b;c\n1,5;2,5;3,5\n1,6;2,6;3,6\n1,7;2,7;3,7\n")
    with open_recording(p, fs=1) as rec:
        assert rec.metadata["delimiter"] == ";" and rec.metadata["decimal"] == ","
        assert rec.channel_names == ["a", "b", "c"]
        np.testing.assert_array_equal(rec.read()["c"], [3.5, 3.6, 3.7])


# ------------------------------------------------------------- duplicate names
DUP_CSV = "time [s],fy [N],fy [N],fz [N]\n" + "".join(f"{k / 10},{k},{-k},{k * 2}\n" for k in range(5))
DUP_LVM = lvm_text().replace("X_Value\tfy\tfz\tComment", "X_Value\tfy\tfy\tComment")


@pytest.mark.fast
def test_duplicate_names_map_no_role_automatically(tmp_path):
    p = tmp_path / "dup.csv"
    p.write_text(DUP_CSV)
    with open_recording(p) as rec:
        assert rec.channel_names == ["time [s]", "fy [N]", "fy [N].1", "fz [N]"]
        assert rec.roles == {"fz": "fz [N]"}  # fy: two candidates, none chosen
        assert rec.warnings == [
            "channel name 'fy [N]' appears in columns 2 and 3: read as 'fy [N]' and 'fy [N].1'; "
            "role 'fy' left unmapped (ambiguous): map one with channels="
        ]
        with pytest.raises(RecordingError, match="'fy' is neither a mapped role"):
            rec.read(["fy"])


@pytest.mark.fast
@pytest.mark.parametrize("name, column, values", [("fy [N]", 2, [0, 1, 2, 3, 4]), ("fy [N].1", 3, [0, -1, -2, -3, -4])])
def test_duplicate_names_mapped_explicitly(tmp_path, name, column, values):
    p = tmp_path / "dup.csv"
    p.write_text(DUP_CSV)
    with open_recording(p, channels={"fy": name}) as rec:
        assert rec.roles == {"fy": name, "fz": "fz [N]"}
        np.testing.assert_array_equal(rec.read(["fy"])["fy"], values)
        assert rec.warnings == [
            "channel name 'fy [N]' appears in columns 2 and 3: read as 'fy [N]' and 'fy [N].1'; "
            f"role 'fy' mapped to {name!r} (column {column})"
        ]


@pytest.mark.fast
def test_duplicate_names_in_lvm(tmp_path):
    p = tmp_path / "dup.lvm"
    p.write_text(DUP_LVM)
    with open_recording(p) as rec:
        assert rec.channel_names == ["fy", "fy.1"] and rec.roles == {}
        assert rec.warnings == [
            "channel name 'fy' appears in columns 2 and 3: read as 'fy' and 'fy.1'; "
            "role 'fy' left unmapped (ambiguous): map one with channels="
        ]
    with open_recording(p, channels={"fy": "fy.1"}) as rec:
        np.testing.assert_array_equal(rec.read()["fy"], REF["fz"])
        assert rec.warnings[-1].endswith("role 'fy' mapped to 'fy.1' (column 3)")


# ------------------------------------------------------ not a regular file
@pytest.fixture
def no_open_of(monkeypatch):
    """Makes opening the given paths fail at once, so a reader that would block on
    them (or read them forever) fails the test instead of hanging it."""
    guarded = set()
    real_open = builtins.open

    def guard(file, *a, **k):
        if isinstance(file, (str, bytes, os.PathLike)) and os.fspath(file) in guarded:
            raise AssertionError(f"{file} was opened")
        return real_open(file, *a, **k)

    monkeypatch.setattr(builtins, "open", guard)
    return guarded


@pytest.mark.fast
@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
@pytest.mark.parametrize("fmt", ["auto", "csv", "lvm", "tdms"])
def test_fifo_is_refused_without_blocking(tmp_path, no_open_of, fmt):
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    no_open_of.add(str(fifo))
    with pytest.raises(RecordingError, match="pipe.csv: not a regular file"):
        bounded(lambda: open_recording(fifo, format=fmt), timeout=5.0)


@pytest.mark.fast
@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_fifo_is_refused_by_detect_format_and_for_real(tmp_path):
    fifo = tmp_path / "pipe.lvm"
    os.mkfifo(fifo)
    try:
        with pytest.raises(RecordingError, match="not a regular file"):
            bounded(lambda: detect_format(fifo), timeout=5.0)
        with pytest.raises(RecordingError, match="not a regular file"):
            bounded(lambda: open_recording(fifo), timeout=5.0)
    finally:  # release a reader blocked on the FIFO, if any
        try:
            os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
        except OSError:
            pass


@pytest.mark.fast
@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="no /dev/zero")
@pytest.mark.parametrize("fmt", ["auto", "csv", "lvm"])
def test_dev_zero_is_refused(no_open_of, fmt):
    assert stat.S_ISCHR(os.stat("/dev/zero").st_mode)
    no_open_of.add("/dev/zero")
    with pytest.raises(RecordingError, match="/dev/zero: not a regular file"):
        bounded(lambda: open_recording("/dev/zero", format=fmt), timeout=5.0)


# ------------------------------------------------------------------ encoding
@pytest.mark.fast
@pytest.mark.parametrize("fmt", ["csv", "lvm"])
@pytest.mark.parametrize(
    "encoding, message",
    [
        ("xyz", "unknown encoding 'xyz' (encoding=)"),
        ("base64", "'base64' is not a text encoding (encoding=)"),
        (5, "encoding must be a string"),
    ],
)
def test_unknown_encoding(tmp_path, fmt, encoding, message):
    p = tmp_path / f"x.{fmt}"
    p.write_text(csv_text() if fmt == "csv" else lvm_text())
    with pytest.raises(RecordingError) as e:
        open_recording(p, encoding=encoding)
    assert str(e.value) == message if isinstance(encoding, str) else message in str(e.value)
    with open_recording(p, encoding="cp1252") as rec:
        assert rec.n_samples == N


# --------------------------------------------------------------------- fuzz
def _mutants(data: bytes, n: int, seed: int):
    rng = np.random.default_rng(seed)
    line_ends = [k for k, c in enumerate(data) if c == ord("\n")]
    for k in range(n):
        kind = ("truncate", "flip", "insert", "delete")[k % 4]
        b = bytearray(data)
        i = int(rng.integers(len(b)))
        if kind == "truncate":  # at any byte, or (one in three) just after a line end
            b = b[: (i if k % 3 else line_ends[i % len(line_ends)]) + 1]
        elif kind == "flip":
            b[i] ^= 1 << int(rng.integers(8))
        elif kind == "insert":
            b[i:i] = bytes([int(rng.integers(256))])
        else:
            del b[i]
        yield kind, bytes(b)


@pytest.mark.fast
@pytest.mark.parametrize("name, text, suffix, seed", [("csv", csv_text(), ".csv", 1), ("lvm", lvm_text(), ".lvm", 2)])
def test_fuzz_mutants_read_true_values_or_raise_recording_error(tmp_path, name, text, suffix, seed):
    """100 mutants: each opens and reads, or raises RecordingError; a truncated file read
    successfully holds the original numbers for the rows it holds (none silently changed)."""
    outcomes: collections.Counter = collections.Counter()
    for k, (kind, data) in enumerate(_mutants(text.encode(), 100, seed)):
        p = tmp_path / f"m{k}{suffix}"
        p.write_bytes(data)
        try:
            d, _, _ = bounded(lambda p=p: read_all(p), timeout=10.0)
        except RecordingError:
            outcomes[kind, "RecordingError"] += 1
            continue
        except Exception as exc:  # noqa: BLE001 - reported below with the mutant
            pytest.fail(f"{name} mutant {k} ({kind}): {type(exc).__name__}: {exc}; tail {data[-80:]!r}")
        if kind == "truncate":
            n = len(d["fy"])
            for key in ("fy", "fz"):
                assert np.array_equal(d[key], REF[key][:n]), f"{name} mutant {k}: {key} changed; tail {data[-80:]!r}"
        outcomes[kind, "read"] += 1
    assert outcomes["truncate", "read"] >= 2 and outcomes["truncate", "RecordingError"] >= 5, outcomes
