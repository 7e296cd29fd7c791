"""``tribodyn compare`` end to end and the test record (``--meta``, ``[meta]``; docs/method.md 10): outputs, the
numbers against td.compare, one-line refusals with status 2 and nothing written."""

from __future__ import annotations

import csv
import hashlib
import json
from pathlib import Path

import numpy as np
import pytest
import tribodyn as td
from tribodyn import simulate
from tribodyn.app import cli
from tribodyn.app.record import FIELDS, parse_meta
from tribodyn.io.writers import save_recording
from tribodyn.results import Headline


def run(*args: object) -> int:
    return cli.main([str(a) for a in args])


def error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("tribodyn: error:") and "Traceback" not in err, err
    return lines[0]


def head(value: float, method: str = "classical") -> dict:
    stat = "median" if method == "dynamic" else "mean"
    return Headline(method=method, value=value, low=value - 0.002, high=value + 0.002, statistic=stat, n=50,
                    fraction_used=1.0, estimate="e", interval="i").to_dict()  # fmt: skip


def fake_out(folder: Path, heads: dict, **extra: object) -> Path:
    """An output folder as tribodyn analyze writes it, reduced to what compare reads."""
    folder.mkdir(parents=True)
    data = {"recordings": {name: {"headline": h} for name, h in heads.items()}, **extra}
    (folder / "summary.json").write_text(json.dumps(data))
    return folder


@pytest.fixture(scope="module")
def analysed(tmp_path_factory):
    """Two analyze output folders of simulated reciprocating tests: A (one recording, with a test record from
    --config and --meta) and B (two recordings)."""
    base = tmp_path_factory.mktemp("replicates")
    files = []
    for k, mu in enumerate((0.120, 0.124, 0.117)):
        sim = simulate.reciprocating(seed=k, cycles=10, mu_forward=mu + 0.01, mu_backward=mu - 0.01)
        p = base / f"rec{k}.npz"
        save_recording(p, sim.channels, sim.fs, units={"fy": "N", "fz": "N", "x": "m", "v": "m/s"})
        files.append(p)
    cfg = base / "run.toml"
    cfg.write_text('[meta]\nmaterials = "AISI 52100 steel"\nload = 10\noperator = "config"\nrig = "R2"\n'
                   'humidity = "45 %"\n')  # fmt: skip
    a, b = base / "A", base / "B"
    assert run("analyze", files[0], "--out", a, "-q", "--config", cfg, "--meta", "operator=ann",
               "--meta", "speed=20 mm/s", "--meta", "Counterpart=alumina ball, 6 mm") == 0  # fmt: skip
    assert run("analyze", files[1], files[2], "--out", b, "-q") == 0
    return {"A": a, "B": b, "files": files, "base": base}


# -- tribodyn compare ------------------------------------------------------------------------


def test_compare_writes_every_output_and_matches_td_compare(analysed, tmp_path, capsys):
    out = tmp_path / "cmp"
    assert run("compare", analysed["A"], analysed["B"], "--out", out, "--groups", "lab1,lab2") == 0
    printed = capsys.readouterr().out
    assert "A [lab1]: COF" in printed and "B/rec1.npz [lab2]" in printed and "mean COF" in printed
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == [
        "compare.csv", "compare.json", "compare.png", "report.html"]  # fmt: skip
    data = json.loads((out / "compare.json").read_text())
    heads = []
    for folder in ("A", "B"):
        s = json.loads((analysed[folder] / "summary.json").read_text())
        heads += [r["headline"] for r in s["recordings"].values()]
    ref = td.compare(heads, groups=["lab1", "lab2", "lab2"])
    cmp = data["comparison"]
    assert (cmp["mean"], cmp["low"], cmp["high"]) == pytest.approx((ref.mean, ref.low, ref.high), rel=1e-12)
    assert cmp["precision"]["s_R"] == pytest.approx(ref.precision.s_R)
    assert [t["label"] for t in cmp["tests"]] == ["A", "B/rec1.npz", "B/rec2.npz"]
    assert cmp["tests"][0]["meta"]["operator"] == "ann"  # the test record travels with the test
    assert cmp["method"] == "per-stroke"
    assert abs(cmp["mean"] - np.mean([0.120, 0.124, 0.117])) < 5e-4
    digest = hashlib.sha256((analysed["A"] / "summary.json").read_bytes()).hexdigest()
    assert data["inputs"][0]["sha256"] == digest
    with open(out / "compare.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["label"] for r in rows] == ["A", "B/rec1.npz", "B/rec2.npz"]
    assert [float(r["value"]) for r in rows] == [h["value"] for h in heads]
    assert [r["group"] for r in rows] == ["lab1", "lab2", "lab2"]
    page = (out / "report.html").read_text()
    assert "data:image/png;base64," in page and "Repeatability and reproducibility" in page
    assert "http://" not in page and "https://" not in page and "<script" not in page  # self-contained


def test_labels_one_per_test_and_a_duplicate_recording_warns(analysed, tmp_path, capsys):
    again = tmp_path / "again"
    assert run("analyze", analysed["files"][0], "--out", again, "-q") == 0
    out = tmp_path / "cmp"
    assert run("compare", analysed["A"], analysed["B"], again, "--out", out, "--labels", "x,y,z,w", "-q") == 0
    err = capsys.readouterr().err
    assert "the same recording (SHA-256) as" in err and "one test counted twice" in err
    data = json.loads((out / "compare.json").read_text())
    assert [t["label"] for t in data["comparison"]["tests"]] == ["x", "y", "z", "w"]
    assert any("counted twice" in w for w in data["warnings"])


def test_mixed_methods_refused_then_allowed(tmp_path, capsys):
    a = fake_out(tmp_path / "a", {"a.csv": head(0.12, "dynamic")})
    b = fake_out(tmp_path / "b", {"b.csv": head(0.13), "c.csv": head(0.125)})
    out = tmp_path / "cmp"
    assert run("compare", a, b, "--out", out) == 2
    line = error_line(capsys.readouterr().err)
    assert "different methods (dynamic: a; classical: b/b.csv, b/c.csv)" in line
    assert "different quantities" in line and "pass --allow-mixed" in line
    assert not out.exists()
    assert run("compare", a, b, "--out", out, "--allow-mixed", "-q") == 0
    assert json.loads((out / "compare.json").read_text())["comparison"]["method"] == "mixed"


def test_failed_recordings_are_named(tmp_path, capsys):
    a = fake_out(tmp_path / "a", {"a.csv": head(0.12)}, failures={"bad.csv": {"error": "no fz", "kind": "x"}})
    b = fake_out(tmp_path / "b", {"b.csv": head(0.13)})
    assert run("compare", a, b / "summary.json", "--out", tmp_path / "cmp", "-q") == 0
    assert "bad.csv failed in the analysis (no fz): not compared" in capsys.readouterr().err


@pytest.mark.parametrize(
    "setup, args, message",
    [
        (None, ["{a}", "{tmp}/nope"], "nope: no such folder"),
        ("empty", ["{a}", "{tmp}/empty"], "holds no summary.json"),
        ("notjson", ["{a}", "{tmp}/notjson"], "is not valid JSON (line 1"),
        ("demo", ["{a}", "{tmp}/demo"], "not the summary of tribodyn analyze"),
        ("nohead", ["{a}", "{tmp}/nohead"], "recording x.csv has no headline"),
        ("nocof", ["{a}", "{tmp}/nocof"], "test 'nocof' has no COF (no fz): leave it out"),
        (None, ["{a}"], "at least 2 tests, got 1"),
        (None, ["{a}", "{a}"], "is given twice"),
        (None, ["{a}", "{b}", "--labels", "p"], "--labels: 1 given for 3 tests in 2 folders"),
        (None, ["{a}", "{b}", "--labels", "p,,q"], "an empty name"),
        (None, ["{a}", "{b}", "--groups", "g,g"], "at least 2 groups"),
        (None, ["{a}", "{b}", "--out", "{a}"], "holds the input"),
    ],
)
def test_compare_errors_are_one_line_and_write_nothing(tmp_path, capsys, setup, args, message):
    a = fake_out(tmp_path / "a", {"a.csv": head(0.12)})
    b = fake_out(tmp_path / "b", {"b.csv": head(0.13), "c.csv": head(0.125)})
    if setup == "empty":
        (tmp_path / "empty").mkdir()
    elif setup == "notjson":
        (tmp_path / "notjson").mkdir()
        (tmp_path / "notjson" / "summary.json").write_text("{oops")
    elif setup == "demo":
        fake_out(tmp_path / "demo", {})
        (tmp_path / "demo" / "summary.json").write_text(json.dumps({"temperature_test": {}}))
    elif setup == "nohead":
        fake_out(tmp_path / "nohead", {})
        (tmp_path / "nohead" / "summary.json").write_text(json.dumps({"recordings": {"x.csv": {"windows": 3}}}))
    elif setup == "nocof":
        empty = {**head(0.1), "value": None, "low": None, "high": None, "reasons": ["no fz"]}
        fake_out(tmp_path / "nocof", {"n.csv": empty})
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    argv = ["compare", *(x.format(a=a, b=b, tmp=tmp_path) for x in args)]
    if "--out" not in argv:
        argv += ["--out", str(tmp_path / "cmp")]
    assert cli.main(argv) == 2
    assert message in error_line(capsys.readouterr().err)
    assert not (tmp_path / "cmp").exists()
    assert {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()} == before


def test_a_recordings_sub_folder_is_refused_with_what_to_give(tmp_path, capsys):
    """Stop 49 (audit): `compare out/r1_data` (one recording's sub-folder of an output of several) was refused as
    "the demo's output"; the line says what it is and names the output folder to give instead."""
    b = fake_out(tmp_path / "b", {"b.csv": head(0.13), "c.csv": head(0.125)})
    (b / "b").mkdir()
    (b / "b" / "summary.json").write_text(json.dumps({"headline": head(0.13), "windows": 3}))
    a = fake_out(tmp_path / "a", {"a.csv": head(0.12)})
    assert run("compare", a, b / "b", "--out", tmp_path / "cmp") == 2
    line = error_line(capsys.readouterr().err)
    assert line == (
        f"tribodyn: error: {b / 'b'} is one recording's sub-folder of the output of tribodyn analyze with several "
        f"recordings: give the output folder {b} instead (each of its recordings is one test)"
    )
    assert "demo" not in line and not (tmp_path / "cmp").exists()
    assert run("compare", a, b, "--out", tmp_path / "cmp", "-q") == 0  # (what it says to give)


# -- the test record -------------------------------------------------------------------------


def test_meta_in_summary_metadata_and_report(analysed):
    a = analysed["A"]
    summary = json.loads((a / "summary.json").read_text())
    rec = summary["recordings"]["rec0.npz"]
    meta = rec["meta"]
    # the command line wins over the config; standard fields in the record's order, own keys after them
    assert list(meta) == ["materials", "counterpart", "load", "speed", "humidity", "operator", "rig", "result"]
    assert meta["operator"] == "ann" and meta["counterpart"] == "alumina ball, 6 mm" and meta["load"] == 10
    how = meta["result"]
    assert how["cof"] == rec["headline"]["value"] and how["method"] == "per-stroke"
    assert how["how_computed"] == rec["headline"]["estimate"] and how["interval"] == rec["headline"]["interval"]
    md = json.loads((a / "metadata.json").read_text())
    assert md["schema"] == "tribodyn-test-record/1" and md["software"]["version"] == td.__version__
    assert md["standard_fields"] == [f.key for f in FIELDS]
    assert md["fields"]["speed"] == {"given": "20 mm/s", "value": pytest.approx(0.02), "unit": "m/s",
                                     "meaning": "sliding speed"}  # fmt: skip
    assert md["fields"]["humidity"]["value"] == 45.0 and md["fields"]["rig"] == {"given": "R2"}
    digest = hashlib.sha256(analysed["files"][0].read_bytes()).hexdigest()
    assert md["inputs"] == [{"file": "rec0.npz", "bytes": analysed["files"][0].stat().st_size, "sha256": digest}]
    assert md["results"][0]["cof"] == rec["headline"]["value"] and md["results"][0]["recording"] == "rec0.npz"
    page = (a / "report.html").read_text()
    section = page[page.index('<h2 id="record">Test record</h2>') : page.index('<h2 id="summary">')]
    for text in ("AISI 52100 steel", "alumina ball, 6 mm", "20 mm/s (0.02 m/s)", "10 N", "ann", "R2",
                 "how computed", "not given"):  # fmt: skip
        assert text in section, text
    assert section.index("materials") < section.index("load") < section.index("operator") < section.index("rig")


def test_without_meta_the_record_still_says_how_the_cof_was_computed(analysed):
    b = analysed["B"]
    summary = json.loads((b / "summary.json").read_text())
    for name, rec in summary["recordings"].items():
        assert list(rec["meta"]) == ["result"] and rec["meta"]["result"]["cof"] == rec["headline"]["value"]
    md = json.loads((b / "metadata.json").read_text())
    assert md["fields"] == {} and [r["recording"] for r in md["results"]] == ["rec1.npz", "rec2.npz"]
    page = (b / "report.html").read_text()
    assert "No test record given: pass --meta KEY=VALUE" in page
    assert "rec1.npz: how computed" in page and "rec2.npz: how computed" in page
    sub = (b / "rec1" / "report.html").read_text()
    assert '<h2 id="record">Test record</h2>' in sub


@pytest.mark.parametrize(
    "args, config, message",
    [
        (["--meta", "load"], None, "--meta takes KEY=VALUE, got 'load'"),
        (["--meta", "load=-3"], None, "load must be >= 0 N, got '-3'"),
        (["--meta", "humidity=120"], None, "humidity must be within 0 to 100 %"),
        (["--meta", "temperature=-300 °C"], None, "temperature must be >= -273.15"),
        (["--meta", "speed=3 furlongs"], None, "unknown unit 'furlongs' (use m/s, mm/s, cm/s"),
        (["--meta", "materail=steel"], None, "did you mean materials?"),
        (["--meta", "load=1", "--meta", "LOAD=2"], None, "load is given twice"),
        (["--meta", "operator="], None, "operator is empty"),
        (["--meta", "result=1"], None, "'result' is reserved"),
        (["--meta", "my key=1"], None, "is not a field name"),
        ([], "meta = 3", "meta must be a table of field"),
        ([], '[meta]\nload = "heavy"\nlubricant = [1, 2]', "lubricant must be text or a number"),
        ([], "[meta]\nload = inf", "load must be finite"),
    ],
)
def test_bad_meta_is_one_line_and_writes_nothing(analysed, tmp_path, capsys, args, config, message):
    extra = []
    if config is not None:
        cfg = tmp_path / "run.toml"
        cfg.write_text(config + "\n")
        extra = ["--config", str(cfg)]
    out = tmp_path / "out"
    assert cli.main(["analyze", str(analysed["files"][0]), "--out", str(out), *extra, *args]) == 2
    assert message in error_line(capsys.readouterr().err)
    assert not out.exists()


def test_parse_meta_units_and_text():
    m = parse_meta({"Load": "2 kN", "stroke": "5 mm", "temperature": "300 K", "duration": "1.5 h",
                    "distance": 120, "temperature_note": "ambient", "lubricant": "PAO 8"})  # fmt: skip
    e = {x.key: x for x in m.entries}
    assert [x.key for x in m.entries] == ["load", "stroke", "distance", "temperature", "lubricant", "duration",
                                          "temperature_note"]  # fmt: skip
    assert e["load"].value == 2000.0 and e["load"].unit == "N"
    assert e["stroke"].value == pytest.approx(0.005) and e["duration"].value == 5400.0
    assert e["temperature"].value == pytest.approx(26.85) and e["distance"].value == 120.0
    assert e["lubricant"].value is None and e["temperature_note"].given == "ambient"
    assert parse_meta({"temperature": "room"}).entries[0].value is None  # text without a number is kept as text
