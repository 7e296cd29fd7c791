"""Delimited text exports written in the tests (issue 14): each header variant read correctly or refused."""

from __future__ import annotations

import json

import numpy as np
import pytest
import tribodyn as td
from tribodyn.app.cli import main
from tribodyn.io import RecordingError


def _table(n=400, fs=50.0, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    fz = 10 + 0.5 * rng.standard_normal(n)
    fy = 0.2 * fz + 0.01 * rng.standard_normal(n)
    return t, fy, fz


def _rows(t, fy, fz, sep=","):
    return "".join(f"{a:.6f}{sep}{b:.6f}{sep}{c:.6f}\n" for a, b, c in zip(t, fy, fz))


@pytest.mark.fast
def test_key_value_preamble_is_not_the_table(tmp_path):
    t, fy, fz = _table()
    p = tmp_path / "pre.csv"
    p.write_text('"Sampling rate",50\n"Operator",1\n"Channels",3\n"Gain",2\n\nTime,Fy,Fz\n' + _rows(t, fy, fz))
    rec = td.open_recording(p)
    assert rec.n_samples == 400 and rec.channel_names == ["Time", "Fy", "Fz"]
    assert rec.fs == pytest.approx(50.0)
    np.testing.assert_allclose(rec.read(["fy"])["fy"], np.round(fy, 6))


@pytest.mark.fast
def test_second_short_table_after_the_data_is_a_footer_not_the_table(tmp_path):
    t, fy, fz = _table()
    p = tmp_path / "two.csv"
    p.write_text("Time,Fy,Fz\n" + _rows(t, fy, fz) + "\nSummary\nmean,1\nmax,2\n")
    rec = td.open_recording(p)
    assert rec.n_samples == 400


@pytest.mark.fast
def test_units_row_above_names_row(tmp_path):
    t, fy, fz = _table()
    p = tmp_path / "units.csv"
    p.write_text("s,N,N\nTime,Friction force,Normal force\n" + _rows(t, fy, fz))
    rec = td.open_recording(p)
    assert rec.channel_names == ["Time", "Friction force", "Normal force"]
    assert [c.unit for c in rec.channels] == ["s", "N", "N"]
    assert rec.roles["fy"] == "Friction force" and rec.roles["fz"] == "Normal force"


@pytest.mark.fast
@pytest.mark.parametrize("enc", ["utf-16", "utf-16-le", "cp932", "latin-1", "utf-8-sig"])
def test_encodings_detected(tmp_path, enc):
    t, fy, fz = _table()
    names = "時間,Fy,Fz\n" if enc in ("utf-16", "utf-16-le", "cp932", "utf-8-sig") else "Zeit (s),Fy,Fz\n"
    unit = "s,N,N\n"
    text = "測定器 PCD-400A\n" if enc != "latin-1" else "Gerät: Prüfstand\n"
    p = tmp_path / "enc.CSV"
    body = text + names + unit + _rows(t, fy, fz)
    p.write_bytes(body.encode(enc))
    rec = td.open_recording(p, time_column=names.split(",")[0])
    assert rec.n_samples == 400 and rec.fs == pytest.approx(50.0)
    assert rec.channel_names[0] == names.split(",")[0]
    np.testing.assert_allclose(rec.read(["Fz"])["Fz"], np.round(fz, 6))
    rec.close()


@pytest.mark.fast
def test_encoding_override(tmp_path):
    t, fy, fz = _table()
    p = tmp_path / "o.csv"
    p.write_bytes(("Kraft µ,Fy,Fz\n" + _rows(t, fy, fz)).encode("latin-1"))
    rec = td.open_recording(p, encoding="latin-1", fs=50.0)
    assert rec.channel_names[0] == "Kraft µ"


@pytest.mark.fast
@pytest.mark.parametrize(
    "line,fs",
    [
        ("Sampling rate [Hz]: 200", 200.0),
        ("Sampling fequency [Hz]: 100", 100.0),
        ("Sampling frequency = 2 kHz", 2000.0),
        ("Delta_X,0.001", 1000.0),
        ("Interval,0.0005", 2000.0),
        ("dt = 2 ms", 500.0),
        ("wf_increment,0.00002", 50000.0),
    ],
)
def test_header_rate_keys(tmp_path, line, fs):
    _, fy, fz = _table()
    p = tmp_path / "h.csv"
    p.write_text(line + "\nFy,Fz\n" + "".join(f"{a:.6f},{b:.6f}\n" for a, b in zip(fy, fz)))
    rec = td.open_recording(p)
    assert rec.fs == pytest.approx(fs)
    assert "header" in rec.info()["fs_source"] if "fs_source" in rec.info() else True


@pytest.mark.fast
def test_ni_paired_time_value_columns(tmp_path):
    t, fy, fz = _table(fs=2000.0)
    p = tmp_path / "ni.csv"
    head = "Channel name,Fy,,Fz\nInterval,0.0005,,0.0005\nSamples,400,,400\n\nTime,Value,Time,Value\n"
    p.write_text(head + "".join(f"{a:.6f},{b:.6f},{a:.6f},{c:.6f}\n" for a, b, c in zip(t, fy, fz)))
    rec = td.open_recording(p)
    assert rec.channel_names == ["Time", "Fy", "Fz"]
    assert rec.fs == pytest.approx(2000.0)
    assert rec.roles["fy"] == "Fy" and rec.roles["fz"] == "Fz"
    np.testing.assert_allclose(rec.read(["fz"])["fz"], np.round(fz, 6))


@pytest.mark.fast
def test_time_restart_splits_segments_and_windows(tmp_path):
    t, fy, fz = _table(n=600)
    t = np.concatenate([t[:300], t[:300]])  # the clock restarts
    p = tmp_path / "restart.csv"
    p.write_text("Time,Fy,Fz\n" + _rows(t, fy, fz))
    rec = td.open_recording(p)
    assert rec.segments == [(0, 300), (300, 600)] == rec.acquisitions
    assert any("restarts" in w for w in rec.warnings)
    res = td.analyze(rec, window=2.0, hop=2.0)
    starts = np.round(res["t_start"] * 50).astype(int)
    assert all(not (s < 300 < s + 100) for s in starts)  # no window straddles the restart
    assert 300 in starts.tolist()
    assert any("restarts" in w for w in res.warnings)


@pytest.mark.fast
def test_gap_splits_segments(tmp_path):
    t, fy, fz = _table(n=400)
    t[200:] += 30.0
    p = tmp_path / "gap.csv"
    p.write_text("Time,Fy,Fz\n" + _rows(t, fy, fz))
    rec = td.open_recording(p)
    assert rec.segments == [(0, 200), (200, 400)]


@pytest.mark.fast
def test_jitter_refused_with_the_jitter_and_resample_reads_it(tmp_path):
    rng = np.random.default_rng(3)
    steps = 0.02 * (1 + 0.3 * rng.uniform(-1, 1, 400))
    t = np.concatenate([[0.0], np.cumsum(steps)[:-1]])
    _, fy, fz = _table()
    p = tmp_path / "jitter.csv"
    p.write_text("Time,Fy,Fz\n" + _rows(t, fy, fz))
    with pytest.raises(RecordingError, match=r"vary by \d+ %.*resample=HZ"):
        td.open_recording(p)
    rec = td.open_recording(p, resample=50.0)
    assert rec.fs == 50.0
    assert rec.n_samples == int(np.floor(t[-1] * 50)) + 1
    got = rec.read(["fz"])["fz"]
    np.testing.assert_allclose(
        got, np.interp(np.arange(rec.n_samples) / 50.0, np.round(t, 6), np.round(fz, 6)), atol=1e-9
    )
    rec2 = td.open_recording(p, fs=50.0)  # taken as uniform, said so
    assert any("taken as uniform" in w for w in rec2.warnings)


def test_cli_time_column_encoding_and_roles(tmp_path, capsys):
    t, fy, fz = _table(n=2000, fs=100.0)
    p = tmp_path / "run.csv"
    p.write_bytes(
        (
            "測定\nzeit,Fx,Fy,Fz\n" + "".join(f"{a:.5f},{0.5 * b:.5f},{b:.5f},{c:.5f}\n" for a, b, c in zip(t, fy, fz))
        ).encode("cp932")
    )
    out = tmp_path / "out"
    assert main(["analyze", str(p), "--out", str(out), "--time-column", "zeit", "--encoding", "cp932", "-q"]) == 0
    s = json.loads((out / "summary.json").read_text())
    r = s["recordings"]["run.csv"]
    assert r["params"]["fs"] == pytest.approx(100.0)
    assert r["roles"] == {"fx": "Fx", "fy": "Fy", "fz": "Fz"} and r["roles_source"] == "automatic"
    assert abs(r["classical"]["median"] - 0.2) < 0.01
    assert main(["analyze", str(p), "--out", str(out), "--time-column", "zeit", "--overwrite"]) == 0
    printed = capsys.readouterr().out
    # Fx = Fy / 2: Fy carries the friction (docs/method.md 6f), said with its evidence.
    assert "fy <- Fy (|Ft|/|Fn| 0.20, CV" in printed and "; Fx 0.10" in printed and "(automatic; --map" in printed
    assert printed.startswith("run.csv: COF 0.2000 ") and "classical, mean |fy|/|fz|" in printed


def test_batch_where_every_file_fails_writes_summary_and_exits_3(tmp_path):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    a.write_text("x,y\n1,2\n3,4\n5,6\n")
    b.write_text("x,y\n1,2\n3,4\n5,6\n")
    out = tmp_path / "out"
    assert main(["analyze", str(a), str(b), "--out", str(out), "-q"]) == 3
    s = json.loads((out / "summary.json").read_text())
    assert set(s["failures"]) == {"a.csv", "b.csv"} and s["recordings"] == {}


@pytest.mark.fast
def test_dataframe_source_with_time_column_and_channels():
    pd = pytest.importorskip("pandas")
    t, fy, fz = _table(n=1000, fs=100.0)
    df = pd.DataFrame({"time": t, "Ft": fy, "Fn": fz})
    res = td.analyze(df, channels={"fy": "Ft", "fz": "Fn"})
    assert res.params["fs"] == pytest.approx(100.0)
    assert abs(res.summary()["classical"]["median"] - 0.2) < 0.01
