"""Watching a running test (docs/method.md 11; issue 37): ``tribodyn.watch`` and ``tribodyn watch``.

A writer process appends to a recording (CSV rows, TDMS segments, an HDF5
dataset under SWMR) in random pieces, faster than real time, while the file
is watched; the last Results must be the analysis of the complete file, bit
for bit, and every snapshot's windows the first windows of that analysis (an
update reads only what is new, and reads it right). The trip and the fault
cases are driven in this process: the watch's ``sleep`` writes the next piece.
"""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path
from typing import Callable, List

import numpy as np
import pytest
import tribodyn as td
from tribodyn.app.cli import main
from tribodyn.io import RecordingError
from tribodyn.io.follow import Follower
from tribodyn.pipeline.watch import parse_trip


FS = 1000.0
OPTS = {"window": 2.0, "hop": 1.0}


def _forces(n: int, mu: Callable[[np.ndarray], np.ndarray], seed: int = 0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FS
    fz = 10.0 + rng.normal(0.0, 1.0, n)
    fy = mu(t) * fz + rng.normal(0.0, 0.05, n)
    return t, fy, fz


def _csv_bytes(n: int, mu=lambda t: np.full(t.shape, 0.2), seed: int = 0) -> bytes:
    t, fy, fz = _forces(n, mu, seed)
    rows = "\n".join(f"{a:.4f},{b:.6f},{c:.6f}" for a, b, c in zip(t, fy, fz))
    return ("time,fy,fz\n" + rows + "\n").encode()


def _pieces(data: bytes, seed: int, lo: int = 200, hi: int = 40_000) -> List[bytes]:
    """``data`` cut at random places (inside rows too)."""
    rng = np.random.default_rng(seed)
    cuts, pos = [], 0
    while pos < len(data):
        k = int(rng.integers(lo, hi))
        cuts.append(data[pos : pos + k])
        pos += k
    return cuts


def _same_as_offline(path: Path, final: td.Results, snaps: List[td.Results], **opts) -> None:
    with td.open_recording(path) as rec:
        full = td.analyze(rec, **opts)
    assert final.params["watch"]["final"] is True
    for col in ("mu_r", "mu_r_low", "mu_r_high", "time", "fz_mean", "ok"):
        np.testing.assert_array_equal(np.asarray(final[col]), np.asarray(full[col]), err_msg=col)
    assert final.headline == full.headline
    same = [s for s in snaps if s.params.get("iv_lag_samples") == full.params.get("iv_lag_samples")]
    assert len(same) >= len(snaps) // 2  # the lag chosen from part of a short recording is most often the final one
    for snap in same:  # each snapshot at the final lag: the first windows of the complete file's (here: no tare)
        k = len(snap)
        np.testing.assert_array_equal(np.asarray(snap["mu_r"]), np.asarray(full["mu_r"])[:k])


# -- writer processes -----------------------------------------------------------------------------------

_TEXT_WRITER = """
import sys, time
src, dst, seed = sys.argv[1], sys.argv[2], int(sys.argv[3])
import random
random.seed(seed)
data = open(src, 'rb').read()
open(dst + ".ready", "w").close()
pos = 0
while pos < len(data):
    k = random.randint(200, 40000)
    with open(dst, 'ab') as fh:
        fh.write(data[pos:pos + k])
    pos += k
    time.sleep(random.uniform(0.0, 0.03))
"""

_TDMS_WRITER = """
import io, sys, time, random
import numpy as np
from nptdms import TdmsWriter, ChannelObject
dst, seed = sys.argv[1], int(sys.argv[2])
random.seed(seed)
rng = np.random.default_rng(seed)
open(dst + ".ready", "w").close()
for i in range(12):
    n = random.randint(1500, 6000)
    fz = 10 + rng.normal(0, 1, n)
    fy = 0.2 * fz + rng.normal(0, 0.05, n)
    buf = io.BytesIO()
    with TdmsWriter(buf) as w:
        props = {"wf_increment": 0.001}
        w.write_segment([ChannelObject("g", k, v, properties=props) for k, v in (("fy", fy), ("fz", fz))])
    b = buf.getvalue()
    cut = random.randint(1, len(b) - 1)
    with open(dst, 'ab') as fh:
        fh.write(b[:cut]); fh.flush()      # a segment in writing
        time.sleep(random.uniform(0.0, 0.05))
        fh.write(b[cut:])
    time.sleep(random.uniform(0.0, 0.03))
"""

_HDF5_WRITER = """
import sys, time, random
import numpy as np, h5py
dst, seed = sys.argv[1], int(sys.argv[2])
random.seed(seed)
rng = np.random.default_rng(seed)
f = h5py.File(dst, "w", libver="latest")
for k in ("fy", "fz"):
    f.create_dataset(k, shape=(0,), maxshape=(None,), dtype="f8", chunks=(4096,))
f.attrs["fs"] = 1000.0
f.swmr_mode = True
open(dst + ".ready", "w").close()
for i in range(12):
    n = random.randint(1500, 6000)
    fz = 10 + rng.normal(0, 1, n)
    fy = 0.2 * fz + rng.normal(0, 0.05, n)
    for k, v in (("fy", fy), ("fz", fz)):
        d = f[k]; d.resize((d.shape[0] + n,)); d[-n:] = v; d.flush()
    time.sleep(random.uniform(0.0, 0.05))
f.close()
"""


def _watch_writer(path: Path, args: List[str], code: str, **opts) -> None:
    """Watches ``path`` while a writer process runs ``code`` (from when it has imported its modules and says
    so); the writer ends first (its pauses are under 0.1 s), then the file idles."""
    proc = subprocess.Popen([sys.executable, "-c", textwrap.dedent(code), *args])
    ready = Path(str(path) + ".ready")
    try:
        for _ in range(600):
            if ready.exists() or proc.poll() is not None:
                break
            time.sleep(0.05)
        snaps = list(td.watch(path, interval=0.05, until_idle=2.0, **opts))
    finally:
        assert proc.wait(timeout=60) == 0
    assert len(snaps) >= 3, "the watch saw the file grow in several updates"
    final = snaps[-1]
    _same_as_offline(path, final, snaps[:-1], **opts)


def test_csv_rows_written_in_random_pieces_end_as_the_offline_analysis(tmp_path: Path) -> None:
    src = tmp_path / "complete.csv"
    src.write_bytes(_csv_bytes(30_000, seed=1))
    dst = tmp_path / "run.csv"
    dst.write_bytes(b"")
    _watch_writer(dst, [str(src), str(dst), "3"], _TEXT_WRITER, **OPTS)
    assert dst.read_bytes() == src.read_bytes()


def test_tdms_segments_in_writing_end_as_the_offline_analysis(tmp_path: Path) -> None:
    pytest.importorskip("nptdms")
    dst = tmp_path / "run.tdms"
    dst.write_bytes(b"")
    _watch_writer(dst, [str(dst), "4"], _TDMS_WRITER, window=1.0, hop=0.5)


def test_hdf5_dataset_growing_under_swmr_ends_as_the_offline_analysis(tmp_path: Path) -> None:
    h5py = pytest.importorskip("h5py")
    if not h5py.version.hdf5_version_tuple >= (1, 10, 0):
        pytest.skip("SWMR needs HDF5 1.10")
    dst = tmp_path / "run.h5"
    _watch_writer(dst, [str(dst), "5"], _HDF5_WRITER, window=1.0, hop=0.5)


# -- driven in this process ------------------------------------------------------------------------------


class _Writer:
    """Appends the next piece of ``data`` to ``path`` at each call (the watch's ``sleep``); a fake clock."""

    def __init__(self, path: Path, pieces: List[bytes], dt: float) -> None:
        self.path, self.pieces, self.dt, self.now = path, list(pieces), dt, 0.0

    def clock(self) -> float:
        return self.now

    def sleep(self, s: float) -> None:
        self.now += s
        if self.pieces:
            with open(self.path, "ab") as fh:
                fh.write(self.pieces.pop(0))


@pytest.mark.fast
def test_a_cof_step_trips_within_an_interval_and_a_window(tmp_path: Path) -> None:
    step_t, interval = 40.0, 2.0
    data = _csv_bytes(60_000, mu=lambda t: np.where(t < step_t, 0.2, 0.35))
    # written at 10x real time: an interval of 2 s brings 20 s of data
    rows = data.split(b"\n")
    per = int(interval * 10 * FS)
    pieces = [b"\n".join(rows[i : i + per]) + b"\n" for i in range(0, len(rows), per)]
    path = tmp_path / "run.csv"
    w = _Writer(path, pieces, interval)
    w.sleep(0.0)
    watch = td.watch(path, interval=interval, until_idle=10.0, trips=["cof>0.3"], clock=w.clock, sleep=w.sleep,
                     final=False, **OPTS)  # fmt: skip
    snaps = list(watch)
    assert watch.reason == "trip" and watch.tripped is not None
    trip = watch.tripped
    assert trip.rule == "cof>0.3" and trip.value > 0.3
    # the first window wholly after the step trips it: within a window (and a hop) of the step
    assert step_t <= trip.time <= step_t + OPTS["window"] + OPTS["hop"]
    seen = snaps[-1].params["watch"]["samples"] / FS  # the data the tripping update had
    assert seen - step_t <= 10 * interval + OPTS["window"] + OPTS["hop"]


@pytest.mark.fast
def test_a_rule_held_for_a_duration(tmp_path: Path) -> None:
    data = _csv_bytes(40_000, mu=lambda t: np.where((t > 10) & (t < 13), 0.4, np.where(t > 25, 0.4, 0.2)))
    path = tmp_path / "run.csv"
    w = _Writer(path, _pieces(data, 2, 20_000, 60_000), 1.0)
    w.sleep(0.0)
    watch = td.watch(path, interval=1.0, until_idle=5.0, trips=["cof>0.3 for 5s"], clock=w.clock,
                     sleep=w.sleep, final=False, **OPTS)  # fmt: skip
    list(watch)
    assert watch.tripped is not None
    assert 29.0 <= watch.tripped.time <= 32.0  # not the 3 s excursion at 10-13 s; 5 s after 25 s


@pytest.mark.fast
def test_no_data_trips_and_idle_ends(tmp_path: Path) -> None:
    path = tmp_path / "run.csv"
    data = _csv_bytes(8_000)
    w = _Writer(path, [data], 1.0)
    w.sleep(0.0)
    watch = td.watch(path, interval=1.0, trips=["no-data for 5s"], clock=w.clock, sleep=w.sleep, final=False,
                     **OPTS)  # fmt: skip
    list(watch)
    assert watch.reason == "trip" and watch.tripped is not None and watch.tripped.rule == "no-data for 5s"
    w2 = _Writer(path, [], 1.0)
    idle = td.watch(path, interval=1.0, until_idle=3.0, clock=w2.clock, sleep=w2.sleep, **OPTS)
    snaps = list(idle)
    assert idle.reason == "idle" and snaps[-1].params["watch"]["final"]


@pytest.mark.fast
def test_a_partial_last_row_waits_for_its_line_end(tmp_path: Path) -> None:
    path = tmp_path / "run.csv"
    data = _csv_bytes(5_000)
    cut = data.index(b"\n", 30_000) + 7  # inside a row
    path.write_bytes(data[:cut])
    f = Follower(str(path), td.open_recording)
    f.poll()
    n0 = f.n_samples
    with td.open_recording(path) as rec:  # the reader drops the cut row
        assert rec.n_samples == n0
    with open(path, "ab") as fh:
        fh.write(data[cut:])
    f.poll()
    _reads_as_the_file(f, path, 5_000)
    assert not any("cut off" in w for w in f.recording.warnings)


@pytest.mark.fast
def test_a_crlf_row_cut_between_its_cr_and_lf_waits_for_its_lf(tmp_path: Path) -> None:
    """A writer of CRLF rows whose write ends between a row's CR and its LF: the row waits for its LF (only an
    LF ends a row for the native scan), never an error or a row counted early."""
    path = tmp_path / "run.csv"
    data = _csv_bytes(5_000).replace(b"\n", b"\r\n")
    cut = data.index(b"\r\n", 30_000) + 1  # just after a CR
    path.write_bytes(data[:cut])
    f = Follower(str(path), td.open_recording)
    f.poll()
    n0 = f.n_samples
    cut2 = data.index(b"\r\n", cut + 20_000) + 1
    with open(path, "ab") as fh:
        fh.write(data[cut:cut2])  # more rows, the last one's LF not yet written
    f.poll()
    assert f.n_samples > n0
    with open(path, "ab") as fh:
        fh.write(data[cut2:])
    f.poll()
    _reads_as_the_file(f, path, 5_000)


@pytest.mark.fast
def test_snapshots_of_a_recording_of_orientation_minus_one_keep_their_signs(tmp_path: Path) -> None:
    """fy = -mu fz: each snapshot's windows are the first windows of the complete file's, their COF arrays
    flipped once (the finishing step flips its statistics in place: the watch's joined ones must stay as the
    kernel gave them, or every other snapshot had mu_a, mu_b and the bins' COF of the earlier windows negated)."""
    path = tmp_path / "run.csv"
    t, fy, fz = _forces(20_000, lambda t: np.full(t.shape, 0.2))
    data = ("time,fy,fz\n" + "\n".join(f"{a:.4f},{-b:.6f},{c:.6f}" for a, b, c in zip(t, fy, fz)) + "\n").encode()
    pieces = _pieces(data, 3, 40_000, 120_000)
    path.write_bytes(pieces[0])
    w = td.watch(path, interval=1.0, final=False, **OPTS)
    snaps = []
    for piece in [*pieces[1:], b""]:
        snap = w.update()
        if snap is not None:
            snaps.append(snap)
        with open(path, "ab") as fh:
            fh.write(piece)
    with td.open_recording(path) as rec:
        full = td.analyze(rec, **OPTS)
    assert full.orientation == -1 and len(snaps) >= 3
    for snap in snaps:
        k = len(snap)
        assert snap.orientation == -1
        np.testing.assert_array_equal(np.asarray(snap.bin_cof), np.asarray(full.bin_cof)[:k])
        for col in ("mu_r", "mu_a", "mu_b"):
            np.testing.assert_array_equal(np.asarray(snap[col]), np.asarray(full[col])[:k], err_msg=col)


def _reads_as_the_file(f: Follower, path: Path, n: int) -> None:
    """The follower holds ``n`` samples, read as a fresh opening of the complete file reads them."""
    assert f.n_samples == n
    got = f.recording.read(["fy", "fz"])
    with td.open_recording(path) as rec:
        ref = rec.read(["fy", "fz"])
    for k in ref:
        np.testing.assert_array_equal(got[k], ref[k])


@pytest.mark.fast
@pytest.mark.fast
@pytest.mark.parametrize("extra_rows", [1, 3, 40])
def test_rows_written_while_a_poll_scans_are_counted_once(tmp_path: Path, monkeypatch, extra_rows: int) -> None:
    """A writer that appends rows between the poll's read of the new bytes and its native scan (a race seen
    at 10x real time): the scan sees them too; they belong to the next poll, never counted twice."""
    from tribodyn.io import follow

    path = tmp_path / "run.csv"
    data = _csv_bytes(5_000)
    lines = data.split(b"\n")
    first = b"\n".join(lines[:2_001]) + b"\n"  # the header and 2,000 rows
    later = b"\n".join(lines[2_001 : 2_001 + 1_000]) + b"\n"
    during = b"\n".join(lines[3_001 : 3_001 + extra_rows]) + b"\n" + lines[3_001 + extra_rows][:5]  # and a cut row
    path.write_bytes(first)
    f = Follower(str(path), td.open_recording)
    f.poll()
    assert f.n_samples == 2_000
    scan = follow._TextTail._scan

    def racing(rec, start):  # the writer appends while the poll is between its read and its scan
        with open(path, "ab") as fh:
            fh.write(during)
        return scan(rec, start)

    with open(path, "ab") as fh:
        fh.write(later)
    monkeypatch.setattr(follow._TextTail, "_scan", staticmethod(racing))
    f.poll()
    monkeypatch.setattr(follow._TextTail, "_scan", staticmethod(scan))
    assert f.n_samples == 3_000
    with open(path, "ab") as fh:
        fh.write(data[len(first) + len(later) + len(during) :])
    f.poll()
    _reads_as_the_file(f, path, 5_000)


def _followed(tmp_path: Path, upto: int = 60_000) -> tuple:
    """(path, its whole bytes, a Follower that has read the first ``upto`` of them)."""
    path = tmp_path / "run.csv"
    data = _csv_bytes(5_000)
    path.write_bytes(data[:upto])
    f = Follower(str(path), td.open_recording)
    f.poll()
    return path, data, f


@pytest.mark.fast
def test_a_truncated_or_replaced_file_is_an_error_never_a_table(tmp_path: Path) -> None:
    path, data, f = _followed(tmp_path)
    path.write_bytes(data[:20_000])  # rewritten shorter
    with pytest.raises(RecordingError, match="shrank"):
        f.poll()
    g = Follower(str(path), td.open_recording)
    g.poll()
    other = tmp_path / "other.csv"
    other.write_bytes(data)
    os.replace(other, path)
    with pytest.raises(RecordingError, match="replaced"):
        g.poll()


@pytest.mark.fast
def test_a_footer_written_after_the_rows_stops_the_watch(tmp_path: Path) -> None:
    path, data, f = _followed(tmp_path, upto=10**9)
    with open(path, "ab") as fh:
        fh.write(b"1,2,3\nEnd of test: 5000 rows\n")
    with pytest.raises(RecordingError, match="not a data row"):
        f.poll()


@pytest.mark.fast
@pytest.mark.parametrize(
    "text, q, op, limit, d",
    [("cof>0.3", "cof", ">", 0.3, 0.0), ("COF < 0.05", "cof", "<", 0.05, 0.0),
     ("cof>0.3 for 10s", "cof", ">", 0.3, 10.0), ("fn<1", "fn", "<", 1.0, 0.0),
     ("no-data for 30s", "no-data", "", float("nan"), 30.0)],
)  # fmt: skip
def test_trip_rules_parse(text: str, q: str, op: str, limit: float, d: float) -> None:
    r = parse_trip(text)
    assert (r.quantity, r.op, r.duration) == (q, op, d)
    assert r.limit == limit or (np.isnan(r.limit) and np.isnan(limit))


@pytest.mark.fast
@pytest.mark.parametrize("text", ["cof>>0.3", "mu>0.3", "no-data", "cof>x", "cof>0.3 for -1s", "stick slip"])
def test_bad_trip_rules_are_refused_in_words(text: str) -> None:
    with pytest.raises(ValueError, match="trip rule"):
        parse_trip(text)


@pytest.mark.fast
def test_watch_checks_its_arguments_before_waiting(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="interval"):
        td.watch(tmp_path / "x.csv", interval=0)
    with pytest.raises(TypeError, match="analyze does not take"):
        td.watch(tmp_path / "x.csv", windw=2.0)
    with pytest.raises(ValueError, match="align"):
        td.watch(tmp_path / "x.csv", align="auto")


# -- the command line ---------------------------------------------------------------------------------------


def _cli(argv: List[str], capsys) -> tuple:
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_cli_watch_until_idle_writes_what_analyze_writes(tmp_path: Path, capsys) -> None:
    path = tmp_path / "run.csv"
    path.write_bytes(_csv_bytes(12_000))
    code, out, err = _cli(["watch", str(path), "--out", str(tmp_path / "w"), "--until-idle", "0.2",
                           "--interval", "0.1", "--window", "2", "--hop", "1"], capsys)  # fmt: skip
    assert code == 0, err
    assert "COF" in out and "watch ended (idle)" in out
    code, _, err = _cli(["analyze", str(path), "--out", str(tmp_path / "a"), "--window", "2", "--hop", "1", "-q"],
                        capsys)  # fmt: skip
    assert code == 0, err
    assert (tmp_path / "w" / "windows.csv").read_bytes() == (tmp_path / "a" / "windows.csv").read_bytes()
    s_w = json.loads((tmp_path / "w" / "summary.json").read_text())
    s_a = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert s_w["recordings"] == s_a["recordings"] and s_w["open_options"] == s_a["open_options"]
    live = (tmp_path / "w" / "live.html").read_text()
    assert "Watching ended (idle)" in live and "report.html" in live
    marker = json.loads((tmp_path / "w" / ".tribodyn-output").read_text())
    assert "live.html" in marker["files"]


def test_cli_trip_prints_one_line_runs_the_command_and_exits_3(tmp_path: Path, capsys) -> None:
    path = tmp_path / "run.csv"
    path.write_bytes(_csv_bytes(12_000, mu=lambda t: np.full(t.shape, 0.4)))
    flag = tmp_path / "tripped.txt"
    cmd = f"{sys.executable} -c \"import os; open(r'{flag}', 'w').write(os.environ['TRIBODYN_TRIP_RULE'])\""
    code, out, err = _cli(["watch", str(path), "--out", str(tmp_path / "w"), "--trip", "cof>0.3", "--on-trip", cmd,
                           "--window", "2", "--hop", "1", "-q"], capsys)  # fmt: skip
    assert code == 3
    lines = [ln for ln in err.splitlines() if "trip" in ln]
    assert len(lines) == 1 and "cof>0.3" in lines[0] and "t = " in lines[0]
    assert flag.read_text() == "cof>0.3"
    assert (tmp_path / "w" / "report.html").is_file()


def test_cli_a_second_watch_of_the_same_out_is_refused(tmp_path: Path, capsys) -> None:
    path = tmp_path / "run.csv"
    path.write_bytes(_csv_bytes(3_000))
    lock = tmp_path / ".w.tribodyn-watch"
    lock.write_text(str(os.getpid()))  # a live process holds it
    code, _, err = _cli(["watch", str(path), "--out", str(tmp_path / "w"), "--until-idle", "0.1"], capsys)
    assert code == 2 and "another tribodyn watch" in err and err.count("\n") == 1
    from tribodyn.app.watch_job import WatchLock

    lock.write_text("999999999")  # a process that has ended: taken over
    with WatchLock(str(tmp_path / "w")) as held:
        assert held.path == lock and lock.read_text() == str(os.getpid())
    assert not lock.exists()


@pytest.mark.fast
def test_cli_bad_trip_rule_is_one_line(tmp_path: Path, capsys) -> None:
    path = tmp_path / "run.csv"
    path.write_bytes(_csv_bytes(3_000))
    code, _, err = _cli(["watch", str(path), "--out", str(tmp_path / "w"), "--trip", "cof>>1"], capsys)
    assert code == 2 and err.startswith("tribodyn: error: trip rule") and err.count("\n") == 1
    assert not (tmp_path / "w").exists()


@pytest.mark.fast
def test_live_page_shows_the_headline_band_and_limits(tmp_path: Path) -> None:
    from tribodyn.app.watch_job import _watch_info, live_page

    path = tmp_path / "run.csv"
    path.write_bytes(_csv_bytes(12_000))
    w = td.watch(path, interval=1.0, trips=["cof>0.3", "fn<1"], final=False, **OPTS)
    snap = w.update()
    assert snap is not None
    page = live_page(snap, w, _watch_info(w, 0.0), interval=2.0)
    assert "http-equiv='refresh' content='2'" in page
    assert "trip cof&gt;0.3" in page and "<svg" in page and "last data arrived" in page
    assert f"{snap.headline.value:.4f}" in page


def test_live_outputs_are_a_set_first_then_each_file_replaced_in_place(tmp_path: Path) -> None:
    """The first update publishes --out as one set (marker); the next ones replace summary.json and live.html
    in place, each atomically (nothing left beside them); a folder removed meanwhile gets a set again."""
    from tribodyn.app.outputs import MARKER
    from tribodyn.app.watch_job import LiveOutputs

    path = tmp_path / "run.csv"
    data = _csv_bytes(12_000)
    cut = data.index(b"\n", len(data) // 2) + 1
    path.write_bytes(data[:cut])
    w = td.watch(path, interval=1.0, final=False, **OPTS)
    out = tmp_path / "live"
    live = LiveOutputs(str(out), overwrite=False, protect=[str(path)])
    live.publish(w.update(), w)
    marker = json.loads((out / MARKER).read_text())
    assert sorted(marker["files"]) == ["live.html", "summary.json"]
    folder = os.stat(out).st_ino
    with open(path, "ab") as fh:
        fh.write(data[cut:])
    snap = w.update()
    live.publish(snap, w)
    assert os.stat(out).st_ino == folder  # replaced in place, not as a new folder
    assert sorted(os.listdir(out)) == sorted([MARKER, "live.html", "summary.json"])
    got = json.loads((out / "summary.json").read_text())
    assert got["recording"]["windows"] == len(snap) and got["watch"]["samples"] == 12_000
    assert f"{snap.headline.value:.4f}" in (out / "live.html").read_text()
    import shutil

    shutil.rmtree(out)
    live.publish(snap, w)
    assert json.loads((out / MARKER).read_text())["files"] == marker["files"]


@pytest.mark.fast
@pytest.mark.fast
def test_live_page_thins_a_long_test_to_each_pixel_columns_extremes() -> None:
    from tribodyn.app.watch_job import LIVE_POINTS, _cof_svg, _Points, thinned

    rng = np.random.default_rng(7)
    n = 20_000  # a day at a 5 s hop
    t = np.arange(n) * 5.0
    mu = 0.2 + 0.01 * rng.standard_normal(n)
    mu[[3, 5000]] = [0.5, -0.1]  # spikes that thinning must keep
    mu[7] = np.nan
    ok = rng.random(n) > 0.1
    few = thinned(t[:LIVE_POINTS], mu[:LIVE_POINTS], ok[:LIVE_POINTS], 820)
    assert few.size == LIVE_POINTS - 1 and 7 not in few  # all finite windows while few
    keep = thinned(t, mu, ok, 820)
    assert keep.size <= 4 * 820 and np.all(np.diff(keep) > 0) and 7 not in keep
    assert {3, 5000} <= set(keep.tolist())
    col = np.minimum(((t - t[0]) / (t[-1] - t[0]) * 820).astype(int), 819)
    for c in (0, 400, 819):  # each column's extremes of the gated and of the failed windows
        for flag in (True, False):
            sel = np.flatnonzero((col == c) & (ok == flag) & np.isfinite(mu))
            assert {int(sel[np.argmin(mu[sel])]), int(sel[np.argmax(mu[sel])])} <= set(keep.tolist())
    svg = _cof_svg(t, mu, ok, (0.2, 0.19, 0.21), [])
    failed = int((~ok[keep]).sum())  # an open dot: a dark one and a white one on it
    assert svg.count("h0") == keep.size + failed and "19999 windows: each pixel column" in svg
    again = _Points()
    assert _cof_svg(t, mu, ok, (0.2, 0.19, 0.21), [], points=again) == svg  # the points kept between updates
    mu2 = mu.copy()
    mu2[3] = 0.6  # a window whose COF changed since (a recording-wide quantity moved it)
    assert _cof_svg(t, mu2, ok, (0.2, 0.19, 0.21), [], points=again) == _cof_svg(t, mu2, ok, (0.2, 0.19, 0.21), [])


@pytest.mark.fast
def test_writer_pieces_helper_is_exact() -> None:  # the helper the tests above rely on
    data = _csv_bytes(2_000)
    assert b"".join(_pieces(data, 0)) == data
    buf = io.BytesIO()
    for p in _pieces(data, 1, 1, 50):
        buf.write(p)
    assert buf.getvalue() == data


def _lvm_bytes(n: int, seed: int = 0) -> bytes:
    _, fy, fz = _forces(n, lambda t: np.full(t.shape, 0.25), seed)
    head = (
        "LabVIEW Measurement\t\nWriter_Version\t2\nReader_Version\t2\nSeparator\tTab\nDecimal_Separator\t.\n"
        "Multi_Headings\tNo\nX_Columns\tOne\nTime_Pref\tRelative\n***End_of_Header***\t\n\n"
        "Channels\t2\t\t\nY_Unit_Label\tN\tN\t\nX_Dimension\tTime\tTime\t\n"
        "X0\t0\t0\t\nDelta_X\t0.001\t0.001\t\n***End_of_Header***\t\t\t\nX_Value\tfy\tfz\tComment\n"
    )
    body = "".join(f"{r / FS:.3f}\t{a:.6f}\t{b:.6f}\n" for r, (a, b) in enumerate(zip(fy, fz)))
    return (head + body).encode()


@pytest.mark.fast
def test_lvm_rows_written_in_random_pieces_end_as_the_offline_analysis(tmp_path: Path) -> None:
    path = tmp_path / "run.lvm"
    w = _Writer(path, _pieces(_lvm_bytes(20_000), 7, 500, 30_000), 0.1)
    w.sleep(0.0)
    watch = td.watch(path, interval=0.1, until_idle=1.0, clock=w.clock, sleep=w.sleep, **OPTS)
    snaps = list(watch)
    assert len(snaps) >= 5 and watch.reason == "idle"
    assert watch.follower._text is not None  # followed by its new rows, not opened again
    _same_as_offline(path, snaps[-1], snaps[:-1], **OPTS)


def _case_csv(case, path: Path) -> bytes:
    fy, fz = case.channels["fy"], case.channels["fz"]
    t = np.arange(len(fy)) / case.fs
    rows = "".join(f"{a:.5f},{b:.5f},{c:.5f}\n" for a, b, c in zip(t, fy, fz))
    return ("time,fy,fz\n" + rows).encode()


@pytest.mark.fast
@pytest.mark.parametrize("kind", ["stick-slip", "smooth"])
def test_the_stick_slip_rule_trips_on_stick_slip_only(tmp_path: Path, kind: str) -> None:
    from stick_slip_sim import smooth, stick_slip

    case = stick_slip(1, fs=500.0, slip=0.02, cycles=40) if kind == "stick-slip" else smooth(1, fs=500.0, duration=40)
    path = tmp_path / "run.csv"
    w = _Writer(path, _pieces(_case_csv(case, path), 3, 40_000, 80_000), 1.0)
    w.sleep(0.0)
    watch = td.watch(path, interval=1.0, until_idle=3.0, trips=["stick-slip"], clock=w.clock, sleep=w.sleep,
                     final=False, window=2.0, hop=1.0)  # fmt: skip
    list(watch)
    if kind == "stick-slip":
        assert watch.tripped is not None and "stick-slip present" in watch.tripped.message
    else:
        assert watch.tripped is None and watch.reason == "idle"


@pytest.mark.fast
def test_a_rewritten_header_is_an_error(tmp_path: Path) -> None:
    path, data, f = _followed(tmp_path)
    with open(path, "r+b") as fh:
        fh.write(b"TIME,FY,FZ")  # same length, other names
        fh.seek(0, 2)
        fh.write(data[60_000:])
    with pytest.raises(RecordingError, match="header was rewritten"):
        f.poll()


@pytest.mark.fast
def test_the_reason_for_waiting_is_told_once_each_time_it_changes(tmp_path: Path) -> None:
    path = tmp_path / "later.csv"
    data = _csv_bytes(8_000)
    w = _Writer(path, [b"", b"", data[:70_000], b"", data[70_000:]], 1.0)
    watch = td.watch(path, interval=1.0, until_idle=3.0, clock=w.clock, sleep=w.sleep, final=False, **OPTS)
    events: List[str] = []
    watch.on_wait = events.append
    for _ in watch:
        events.append("<snapshot>")
    assert events[0] == "the file does not exist yet" and "<snapshot>" in events
    assert all(a != b for a, b in zip(events, events[1:]) if a != "<snapshot>")  # once while it lasts


def test_snapshot_intervals_between_bootstraps_are_the_last_one_moved(tmp_path: Path) -> None:
    """docs/method.md 11: a snapshot draws the bootstrap again only when its gated windows grew by 10 %; in
    between, its intervals are the last drawn, moved with the median and scaled: close to a fresh draw."""
    import dataclasses

    path = tmp_path / "run.csv"
    rows = _csv_bytes(60_000).split(b"\n")
    per = 1_500
    pieces = [b"\n".join(rows[i : i + per]) + b"\n" for i in range(0, len(rows) - 1, per)]
    w = _Writer(path, pieces, 1.0)
    w.sleep(0.0)
    opts = {"window": 0.5, "hop": 0.25}
    snaps = list(td.watch(path, interval=1.0, until_idle=2.0, clock=w.clock, sleep=w.sleep, **opts))
    moved = drawn = 0
    for snap in snaps[:-1]:
        gated = int(np.isfinite(np.asarray(snap["mu_r"])[np.asarray(snap["ok"], dtype=bool)]).sum())
        fresh = dataclasses.replace(snap)  # a copy without the cached intervals: drawn afresh
        at = snap.params["watch"]["intervals_drawn_at"]
        assert at is not None and at <= gated < 1.1 * at
        if at == gated:
            drawn += 1
            assert snap.mu_r_ci == fresh.mu_r_ci and snap.summary() == fresh.summary()
        else:  # the headline's: within 20 % of a fresh draw's half-width; the summary's other columns: looser
            moved += 1
            (lo, hi), (flo, fhi) = snap.mu_r_ci["median"], fresh.mu_r_ci["median"]
            assert max(abs(lo - flo), abs(hi - fhi)) < 0.2 * (fhi - flo) / 2
            assert (snap.headline.low, snap.headline.high) == (lo, hi)
            if "median" in fresh.column_ci["mu_a"]:
                (lo, hi), (flo, fhi) = snap.column_ci["mu_a"]["median"], fresh.column_ci["mu_a"]["median"]
                assert max(abs(lo - flo), abs(hi - fhi)) < 0.6 * (fhi - flo) / 2
    assert moved >= 10 and drawn >= 5
    _same_as_offline(path, snaps[-1], snaps[:-1], **opts)


def test_summary_column_intervals_are_drawn_only_when_read(tmp_path: Path) -> None:
    """docs/method.md 11: the summary's other columns' intervals are bootstrapped only when a snapshot's
    ``column_ci`` or ``summary()`` is read; once read at an update (as the command line does at each), the next
    snapshots get them moved from that draw until their values grew by 10 %."""
    import dataclasses

    path = tmp_path / "run.csv"
    rows = _csv_bytes(40_000).split(b"\n")
    pieces = [b"\n".join(rows[i : i + 1_500]) + b"\n" for i in range(0, len(rows) - 1, 1_500)]
    opts = {"window": 0.5, "hop": 0.25}
    for reading in (False, True):
        w = _Writer(path, pieces, 1.0)
        w.sleep(0.0)
        given = 0
        for snap in td.watch(path, interval=1.0, until_idle=2.0, clock=w.clock, sleep=w.sleep, final=False, **opts):
            if snap.computed("column_ci"):  # moved from an earlier snapshot's draw
                given += 1
                fresh = dataclasses.replace(snap).column_ci["mu_a"]
                if "median" in fresh:
                    (lo, hi), (flo, fhi) = snap.column_ci["mu_a"]["median"], fresh["median"]
                    assert max(abs(lo - flo), abs(hi - fhi)) < 0.6 * (fhi - flo) / 2
            if reading:
                snap.summary()
        assert (given > 5) if reading else (given == 0)
        path.unlink()


@pytest.mark.fast
def test_the_lag_windows_held_by_a_recording() -> None:
    """pipeline.instrument.lag_sample_held: the first SAMPLE_WINDOWS tiles, never across acquisitions."""
    from tribodyn.pipeline.instrument import SAMPLE_WINDOWS, lag_sample_held

    class Rec:
        segments = [(0, 10 * SAMPLE_WINDOWS - 5), (10 * SAMPLE_WINDOWS - 5, 10**6)]

    assert not lag_sample_held(Rec(), 10, 10 * SAMPLE_WINDOWS)  # the first acquisition holds 63 tiles
    assert not lag_sample_held(Rec(), 10, 10 * SAMPLE_WINDOWS + 4)
    assert lag_sample_held(Rec(), 10, 10 * SAMPLE_WINDOWS + 5)  # and the second its first
    assert lag_sample_held(object(), 10, 10 * SAMPLE_WINDOWS) and not lag_sample_held(object(), 10, 639)
