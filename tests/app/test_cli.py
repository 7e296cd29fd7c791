"""The ``tribodyn`` command line end to end: outputs, exit codes, errors,
and no partial outputs after a failure."""

from __future__ import annotations

import csv
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from tribodyn import simulate
from tribodyn.app import cli
from _paths import TESTS

DATA = TESTS / "data" / "real"


def run(*args: str) -> int:
    return cli.main([str(a) for a in args])


def read_csv(path: Path) -> dict:
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: [r[k] for r in rows] for k in rows[0]} if rows else {}


def floats(col) -> np.ndarray:
    return np.array([float(v) if v != "" else np.nan for v in col])


def leftovers(directory: Path) -> list:
    return [p.name for p in directory.iterdir() if p.name.startswith(".tribodyn-partial-")]


@pytest.fixture
def demo_dir(demo_run):
    return demo_run[0]  # the session's demo (conftest.py)


def test_demo_writes_every_output(demo_dir):
    for name in ("report.html", "summary.json", "temperature_windows.csv", "current_density_windows.csv"):
        assert (demo_dir / name).is_file(), name
    figs = sorted((demo_dir / "figures").glob("*.png"))
    assert len(figs) >= 8
    summary = json.loads((demo_dir / "summary.json").read_text())
    rng_t = summary["temperature_test"]["operating_range"]
    rng_j = summary["current_density_test"]["operating_range"]
    assert 120 <= rng_t["optimum"][0] < rng_t["optimum"][1] <= 175
    assert 3.5 <= rng_j["optimum"][0] < rng_j["optimum"][1] <= 5.75
    assert summary["tribodyn_version"]
    html = (demo_dir / "report.html").read_text()
    assert html.count("data:image/png;base64,") >= len(figs)
    # Self-contained: nothing is loaded from the network (Bokeh's inline JavaScript mentions URLs in its text).
    assert not re.search(r"""<[a-z]+\s[^>]*\b(?:src|href)\s*=\s*["']?(?:https?:)?//""", html)
    assert not leftovers(demo_dir)


def test_demo_report_labels_are_words_and_units_consistent(demo_dir):
    html = (demo_dir / "report.html").read_text()
    text = re.sub(r"<script.*?</script>", "", html, flags=re.S)
    text = re.sub(r"data:image/png;base64,[A-Za-z0-9+/=]+", "", text)  # embedded PNGs can hold any letters
    for code in ("degC", "A/mm^2", "temperature_test:", "current_density_test:", "mu_r median", "tribodyn_version"):
        assert code not in text, code
    assert "temperature test: optimum temperature" in text and "°C" in text and "A/mm²" in text
    assert re.search(r"\d+(?:\.\d)? to \d+(?:\.\d)? °C", text)  # rounded to the intervals' width


def test_demo_prints_a_summary(demo_run):
    out = demo_run[1]
    assert "optimum" in out and "°C" in out and "A/mm²" in out
    # Readable units and numbers rounded to the data's precision ("133.5 to 157.9 °C", not "133.521..157.892 degC").
    assert "degC" not in out and "A/mm^2" not in out
    assert re.search(r"optimum \d+(?:\.\d)? to \d+(?:\.\d)? °C", out), out  # rounded to the intervals' width
    assert re.search(r"^temperature test: COF 0\.\d{4} \(95 % interval .*\): dynamic, median of mu_r", out, re.M), out


@pytest.mark.parametrize("name", ["cetr_umt2_HT-2n-6-4_2_001.csv", "cetr_umt2_HT-2n-6-4_2_002.csv"])
def test_cetr_classical_cof_matches_instrument(tmp_path, name):
    out = tmp_path / "out"
    assert run("analyze", DATA / name, "--out", out, "--window", "2", "--hop", "2", "--highpass", "0.1", "--quiet") == 0
    t = read_csv(out / "windows.csv")
    classic, instrument = floats(t["mu_classical"]), floats(t["mu_instrument"])
    assert len(classic) == 2 and np.all(np.isfinite(classic))
    np.testing.assert_allclose(classic, instrument, rtol=0.02)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["inputs"][0]["file"] == name and len(summary["inputs"][0]["sha256"]) == 64


@pytest.mark.parametrize("name", ["pod_PPS_60N_1.tsv", "pod_PPS_100N_1.tsv"])
def test_pin_on_disc_classical_cof_matches_instrument(tmp_path, name):
    out = tmp_path / "out"
    assert (
        run("analyze", DATA / name, "--out", out, "--window", "60", "--hop", "60", "--highpass", "0.01", "--quiet") == 0
    )
    t = read_csv(out / "windows.csv")
    classic, instrument = floats(t["mu_classical"]), floats(t["mu_instrument"])
    assert len(classic) == 30
    # The first samples of the run (|Ff| < 1 N, printed to 0.1 N) are coarse: skip window 0.
    np.testing.assert_allclose(classic[1:], instrument[1:], rtol=0.02)


# The two LVM files are a modal test's force and acceleration: mapped as fy and fz their units differ (m/s^2, N),
# which analyze refuses (issue 34 point 4) unless the caller says the scale (--scale fy=1: taken as given).
@pytest.mark.parametrize(
    "name, options",
    [
        (
            "lvm_read_long_single_header_multi_ch.lvm",
            ["--map", "fz=F,fy=m_1", "--scale", "fy=1", "--window", "1", "--hop", "1"],
        ),
        (
            "lvm_read_short.lvm",
            [
                "--map",
                "fz=Excitation (Trigger),fy=Response (Trigger)",
                "--scale",
                "fy=1",
                "--window",
                "0.0003",
                "--hop",
                "0.0003",
            ],  # fmt: skip
        ),
        ("nptdms_raw1_daqmx.tdms", ["--map", "fz=First  Channel,fy=Second Chan", "--window", "0.01", "--hop", "0.01"]),
        ("pyfrf_measurements_1.npy", ["--map", "fz=ch1,fy=ch2", "--fs", "25600", "--window", "0.1", "--hop", "0.1"]),
    ],
)
def test_analyze_reads_every_real_file(tmp_path, name, options):
    out = tmp_path / "out"
    assert run("analyze", DATA / name, "--out", out, "--quiet", *options) == 0
    assert (out / "windows.csv").is_file() and (out / "report.html").is_file()
    assert len(read_csv(out / "windows.csv")["mu_r"]) >= 1


@pytest.mark.fast
def test_an_acceleration_as_friction_is_refused_in_one_line(tmp_path, capsys):
    opts = ["--map", "fz=F,fy=m_1", "--window", "1", "--hop", "1"]
    assert run("analyze", DATA / "lvm_read_long_single_header_multi_ch.lvm", "--out", tmp_path / "o", *opts) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "fy ('m_1') is in m/s^2 and fz ('F') in N" in err and not (tmp_path / "o").exists()


def test_several_files_and_config(tmp_path):
    cfg = tmp_path / "run.toml"
    cfg.write_text("window = 2.0\nhop = 2.0\nhighpass = 0.1\n")
    out = tmp_path / "out"
    files = [DATA / "cetr_umt2_HT-2n-6-4_2_001.csv", DATA / "cetr_umt2_HT-2n-6-4_2_002.csv"]
    assert run("analyze", *files, "--out", out, "--config", cfg, "--quiet") == 0
    t = read_csv(out / "windows.csv")
    assert sorted(set(t["recording"])) == sorted(f.name for f in files)
    for f in files:
        assert (out / f.stem / "report.html").is_file()


@pytest.mark.fast
def test_when_every_file_fails_no_report_is_promised(tmp_path, capsys):
    """Issue 38 point 4: every recording failed: summary.json alone lists them (status 3); the last line said
    "outputs in DIR/ (open report.html)" of a folder without report.html."""
    files = [tmp_path / "a.csv", tmp_path / "b.csv"]
    for f in files:
        f.write_text("notes of the run\n")
    out = tmp_path / "out"
    assert run("analyze", *files, "--out", out) == cli.EXIT_SOME_FAILED
    said = capsys.readouterr().out
    assert "report.html" not in said and f"no recording analysed: {out}/summary.json lists each failure" in said
    assert sorted(json.loads((out / "summary.json").read_text())["failures"]) == ["a.csv", "b.csv"]
    assert not (out / "report.html").exists()


@pytest.mark.fast
@pytest.mark.parametrize("extra", [[], ["--split", "600"]])
def test_two_inputs_of_one_name_are_named_by_their_folders(tmp_path, capsys, extra):
    """Stop 49: runA/x.tsv and runB/x.tsv (a lab's runs/*/data.tdms) were refused in one line; each is analysed and
    named by the shortest end of its path that tells them apart, in the summary, the combined table, the failures,
    the inputs and the report, with a sub-folder of its own; a file of a distinct name keeps its name."""
    for d in ("runA", "runB", "runC"):
        (tmp_path / "runs" / d).mkdir(parents=True)
    for d in ("runA", "runB"):
        shutil.copy(DATA / "pod_PPS_60N_1.tsv", tmp_path / "runs" / d / "x.tsv")
    (tmp_path / "runs" / "runC" / "x.tsv").write_text("notes of the run\n")  # fails: named as the others
    shutil.copy(DATA / "pod_PPS_60N_1.tsv", tmp_path / "y.tsv")
    out = tmp_path / "out"
    files = [tmp_path / "runs" / d / "x.tsv" for d in ("runA", "runB", "runC")] + [tmp_path / "y.tsv"]
    assert run("analyze", *files, "--out", out, "--figures", "none", "--quiet", *extra) == cli.EXIT_SOME_FAILED
    assert "tribodyn: warning: runC/x.tsv failed:" in capsys.readouterr().err
    s = json.loads((out / "summary.json").read_text())
    assert list(s["recordings"]) == ["runA/x.tsv", "runB/x.tsv", "y.tsv"] and list(s["failures"]) == ["runC/x.tsv"]
    assert [i["file"] for i in s["inputs"]] == ["runA/x.tsv", "runB/x.tsv", "y.tsv"]
    assert read_csv(out / "windows.csv")["recording"][0] == "runA/x.tsv"
    assert set(read_csv(out / "windows.csv")["recording"]) == {"runA/x.tsv", "runB/x.tsv", "y.tsv"}
    for folder in ("runA_x", "runB_x", "y"):
        assert (out / folder / "report.html").is_file()
    report = (out / "report.html").read_text()
    assert "runA/x.tsv" in report and "runB/x.tsv" in report and "runC/x.tsv: not analysed" in report


@pytest.mark.fast
def test_a_failure_line_names_the_file_once(tmp_path, capsys, monkeypatch):
    """Stop 49 (audit): "q/run.npz failed: run.npz lacks ..." named the file twice (the error's own naming was
    stripped only when it was the label); an error's path that says more than the label is kept (where the file
    is)."""
    monkeypatch.chdir(tmp_path)
    for d in ("p/q", "r"):
        (tmp_path / d).mkdir(parents=True)
    shutil.copy(DATA / "pod_PPS_60N_1.tsv", tmp_path / "r" / "x.tsv")
    (tmp_path / "p" / "q" / "x.tsv").write_text("notes of the run\n")
    for d in ("p/q", "r"):
        np.savez(tmp_path / d / "run.npz", a=np.arange(100.0), b=np.arange(100.0), fs=10.0)
    args = ["r/x.tsv", "p/q/x.tsv", "p/q/run.npz", "r/run.npz"]
    assert run("analyze", *args, "--out", "out", "--quiet", "--figures", "none") == cli.EXIT_SOME_FAILED
    said = [x for x in capsys.readouterr().err.splitlines() if " failed: " in x]
    no_table = "no table of numbers found (not a delimited text recording?)"
    # a path that says where the file is stays (p/q/x.tsv of the label q/x.tsv); the bare name is said once
    assert said[0] == f"tribodyn: warning: q/x.tsv failed: RecordingError: p/q/x.tsv: {no_table}"
    assert said[1].startswith("tribodyn: warning: q/run.npz failed: lacks the required channel(s) fy, fz")
    assert [x.count("run.npz") for x in said[1:]] == [1, 1]


@pytest.mark.fast
def test_a_failure_line_speaks_in_the_commands_options(tmp_path, capsys, monkeypatch):
    """Stop 49: a .npy without its rate among several inputs failed with the library's "pass fs=... (Hz)"; the
    command's own words are "give --fs HZ", as for one file."""
    monkeypatch.chdir(tmp_path)
    np.save(tmp_path / "raw.npy", np.zeros((2, 100)))
    shutil.copy(DATA / "pod_PPS_60N_1.tsv", tmp_path / "x.tsv")
    assert run("analyze", "x.tsv", "raw.npy", "--out", "out", "--quiet", "--figures", "none") == cli.EXIT_SOME_FAILED
    said = [x for x in capsys.readouterr().err.splitlines() if " failed: " in x]
    assert len(said) == 1 and "give --fs HZ" in said[0] and "fs=" not in said[0], said


@pytest.mark.fast
def test_sub_folders_are_unique_case_aside(tmp_path):
    """Stop 49 (audit): A/data.tsv and a/data.tsv had the sub-folders A_data and a_data, one folder on macOS's and
    Windows' file systems (the second recording's outputs over the first's); a counter tells them apart, as for
    names that repeat exactly."""
    from tribodyn.app.jobs import _folders

    for d in ("A", "a"):
        (tmp_path / d).mkdir()
        shutil.copy(DATA / "pod_PPS_60N_1.tsv", tmp_path / d / "data.tsv")
    out = tmp_path / "out"
    assert run("analyze", tmp_path / "A" / "data.tsv", tmp_path / "a" / "data.tsv", "--out", out, "--quiet",
               "--figures", "none") == 0  # fmt: skip
    assert {p.name for p in out.iterdir() if p.is_dir()} == {"A_data-1", "a_data-2"}
    assert _folders(["d.csv", "D.tsv", "e.csv"]) == ["d-1", "D-2", "e"]
    assert _folders(["x-2.csv", "X.csv", "x.csv"]) == ["x-2", "X-2-2", "x-3"]  # (no counter makes another's name)


@pytest.mark.fast
def test_a_missing_input_among_several_is_refused_before_any_is_read(tmp_path, capsys, monkeypatch):
    """Stop 49 (audit): `analyze a.tsv nope.tsv` analysed a.tsv, then listed nope.tsv as a failed recording
    (status 3): a typo is one error line, status 2, naming every missing path, before any recording is read."""
    import tribodyn.io

    shutil.copy(DATA / "pod_PPS_60N_1.tsv", tmp_path / "a.tsv")
    opened = []
    real = tribodyn.io.open_recording
    monkeypatch.setattr(tribodyn.io, "open_recording", lambda *a, **k: opened.append(a) or real(*a, **k))
    out = tmp_path / "out"
    a, nope, zz = tmp_path / "a.tsv", tmp_path / "nope.tsv", tmp_path / "zz.tsv"
    assert run("analyze", a, nope, "--out", out) == cli.EXIT_USER_ERROR
    assert capsys.readouterr().err == f"tribodyn: error: {nope}: no such file (nothing analysed)\n"
    assert run("analyze", nope, a, zz, "--out", out) == cli.EXIT_USER_ERROR
    assert capsys.readouterr().err == f"tribodyn: error: no such files: {nope}, {zz} (nothing analysed)\n"
    assert not out.exists() and opened == []
    assert run("analyze", nope, "--out", out) == cli.EXIT_USER_ERROR  # (a lone input: as before)
    assert capsys.readouterr().err == f"tribodyn: error: {nope}: no such file\n"


def _runs_with_notes(tmp_path: Path) -> Path:
    """A folder of two recordings (a.tsv, b.tsv), a README.md and a photo.png: files no reader takes."""
    runs = tmp_path / "runs"
    runs.mkdir()
    for name in ("a.tsv", "b.tsv"):
        shutil.copy(DATA / "pod_PPS_60N_1.tsv", runs / name)
    (runs / "README.md").write_text("# runs of May\nthe rig's notes\n")
    (runs / "photo.png").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(64))
    return runs


@pytest.mark.fast
def test_a_folders_files_no_reader_takes_are_skipped_in_one_line(tmp_path, capsys):
    """Stop 49: a README or a photo in an input folder was a failed recording (status 3); it is skipped, named in
    one line on stderr and in summary.json. Named on the command line, it stays a failure."""
    runs = _runs_with_notes(tmp_path)
    out = tmp_path / "out"
    assert run("analyze", runs, "--out", out, "--quiet", "--figures", "none") == 0
    said = [x for x in capsys.readouterr().err.splitlines() if "skipped" in x or "failed" in x]
    assert said == ["tribodyn: warning: skipped 2 files no reader takes: README.md, photo.png"]
    s = json.loads((out / "summary.json").read_text())
    assert list(s["recordings"]) == ["a.tsv", "b.tsv"] and not s["failures"]
    assert [Path(p).name for p in s["skipped"]] == ["README.md", "photo.png"]
    named = run("analyze", runs / "a.tsv", runs / "README.md", "--out", tmp_path / "o2", "--quiet", "--figures", "none")
    assert named == cli.EXIT_SOME_FAILED and "README.md failed" in capsys.readouterr().err


@pytest.mark.fast
def test_the_report_lists_the_skipped_files_below_its_inputs(tmp_path):
    """Stop 49 (audit): the skipped files were on stderr and in summary.json, not in report.html (the lab
    notebook's record of the run); they are listed right below its inputs."""
    runs = _runs_with_notes(tmp_path)
    out = tmp_path / "out"
    assert run("analyze", runs, "--out", out, "--quiet", "--figures", "none") == 0
    report = (out / "report.html").read_text()
    note = '<p class="note">skipped (no reader takes them): README.md, photo.png</p>'
    assert note in report
    start = report.index('<h2 id="inputs">Inputs</h2>')
    assert report.index("</table>", start) < report.index(note) < report.index("<h2", start + 1)
    (runs / "README.md").unlink()
    (runs / "photo.png").unlink()
    assert run("analyze", runs, "--out", out, "--quiet", "--figures", "none", "--overwrite") == 0
    assert "skipped (no reader takes them)" not in (out / "report.html").read_text()


@pytest.mark.fast
@pytest.mark.parametrize("content", ["good", "bad"])
def test_summary_json_always_has_skipped_as_many_results_does(tmp_path, content):
    """Stop 49 (audit): ManyResults.summary() always has "skipped", summary.json had it only when a file was
    skipped; both have it, an empty list when nothing was (also when every recording failed)."""
    from tribodyn import analyze_many

    files = [tmp_path / "a.tsv", tmp_path / "b.tsv"]
    for f in files:
        if content == "good":
            shutil.copy(DATA / "pod_PPS_60N_1.tsv", f)
        else:
            f.write_text("notes of the run\n")
    out = tmp_path / "out"
    expected = 0 if content == "good" else cli.EXIT_SOME_FAILED
    assert run("analyze", *files, "--out", out, "--quiet", "--figures", "none") == expected
    s = json.loads((out / "summary.json").read_text())
    assert s["skipped"] == [] and analyze_many([str(f) for f in files]).summary()["skipped"] == []
    assert set(analyze_many([str(f) for f in files]).summary()) <= set(s) | {"tasks"}


@pytest.mark.fast
def test_an_empty_file_no_reader_takes_is_skipped_too(tmp_path, capsys):
    """Stop 49 (audit): an empty README.md (or notes.md, a placeholder) in an input folder was taken, then failed
    ("empty file", status 3), where one with text in it is skipped, and so was Excel's ~$a.xlsx beside an open
    workbook; an empty .csv still fails (a reader's)."""
    from tribodyn.io import reader_takes

    runs = tmp_path / "runs"
    runs.mkdir()
    shutil.copy(DATA / "pod_PPS_60N_1.tsv", runs / "a.tsv")
    (runs / "README.md").write_bytes(b"")
    (runs / "zero.csv").write_bytes(b"")
    # Excel's owner file beside a workbook open in it (the user's name, 162 bytes): failed as a corrupt .xlsx
    (runs / "~$a.xlsx").write_bytes(b"\x05Maria" + b" " * 48 + b"\x00" * 108)
    assert not reader_takes(runs / "README.md") and reader_takes(runs / "zero.csv")
    assert not reader_takes(runs / "~$a.xlsx")
    assert run("analyze", runs, "--out", tmp_path / "out", "--quiet", "--figures", "none") == cli.EXIT_SOME_FAILED
    said = [x for x in capsys.readouterr().err.splitlines() if "skipped" in x or "failed" in x]
    assert said[0] == "tribodyn: warning: skipped 2 files no reader takes: README.md, ~$a.xlsx"
    assert len(said) == 2 and "zero.csv failed" in said[1]


@pytest.mark.fast
def test_one_file_through_a_link_is_one_file(tmp_path):
    """Stop 49 (audit): runs/latest -> runs/r3 made runs/*/data.csv hold r3's file twice, analysed twice under two
    names (two tests of one recording in the summary and the combined table); it is refused as one file given
    twice."""
    from tribodyn.app.jobs import check_distinct_names

    (tmp_path / "r3").mkdir()
    shutil.copy(DATA / "pod_PPS_60N_1.tsv", tmp_path / "r3" / "data.tsv")
    try:
        (tmp_path / "latest").symlink_to("r3", target_is_directory=True)
    except OSError:  # pragma: no cover - a file system without links
        pytest.skip("no symbolic links here")
    with pytest.raises(ValueError, match="are one file: give it once"):
        check_distinct_names([str(tmp_path / "latest" / "data.tsv"), str(tmp_path / "r3" / "data.tsv")])
    check_distinct_names([str(tmp_path / "r3" / "data.tsv"), str(tmp_path / "r3" / "other.tsv")])  # (no file)


@pytest.mark.fast
def test_recording_labels_are_the_shortest_distinct_ends_of_the_paths(tmp_path):
    from tribodyn.app.jobs import check_distinct_names, recording_labels

    files = ["a/x/data.tdms", "b/x/data.tdms", "c/data.tdms", "c/other.csv", "data.tdms"]
    got = recording_labels([tmp_path / f for f in files])
    assert list(got.values()) == [
        "a/x/data.tdms",
        "b/x/data.tdms",
        "c/data.tdms",
        "other.csv",
        f"{tmp_path.name}/data.tdms",
    ]
    assert recording_labels(["run/a.csv", "b.csv"]) == {Path("run/a.csv"): "a.csv", Path("b.csv"): "b.csv"}
    # one file spelled twice (`tribodyn info` takes it; analyze refuses it): one label, not its whole path twice
    twice = recording_labels(["r1/a.csv", "r1/../r1/a.csv", "r2/a.csv"])
    assert list(twice.values()) == ["r1/a.csv", "r1/a.csv", "r2/a.csv"]
    with pytest.raises(ValueError, match="are one file: give it once"):
        check_distinct_names([str(tmp_path / "a" / "x.csv"), str(tmp_path / "a" / ".." / "a" / "x.csv")])


@pytest.mark.fast
def test_info_names_inputs_of_one_name_as_analyze_does(tmp_path, capsys):
    """Stop 49 (audit): `tribodyn info runs/*/x.tsv` headed each file by its name alone (three "x.tsv" one after
    the other, which is which unsaid), where analyze names them runA/x.tsv, runB/x.tsv; its failure lines too."""
    for d in ("runA", "runB", "runC"):
        (tmp_path / "runs" / d).mkdir(parents=True)
    for d in ("runA", "runB"):
        shutil.copy(DATA / "pod_PPS_60N_1.tsv", tmp_path / "runs" / d / "x.tsv")
    (tmp_path / "runs" / "runC" / "x.tsv").write_text("notes of the run\n")
    shutil.copy(DATA / "pod_PPS_60N_1.tsv", tmp_path / "y.tsv")
    files = [tmp_path / "runs" / d / "x.tsv" for d in ("runA", "runB", "runC")] + [tmp_path / "y.tsv"]
    assert run("info", *files) == cli.EXIT_SOME_FAILED
    said = capsys.readouterr()
    heads = [line for line in said.out.splitlines() if line and not line.startswith((" ", "="))]
    assert heads == ["runA/x.tsv", "runB/x.tsv", "y.tsv"]
    assert said.err.startswith("tribodyn: error: runC/x.tsv: ")


@pytest.mark.fast
def test_one_file_that_fails_is_the_same_error_with_split(tmp_path, capsys):
    """Issue 38 point 4: one input that fails gave one line and status 2 here, but through analyze_many (--split,
    --scheduler) a warning, status 3 and an output folder of summary.json alone."""
    bad = tmp_path / "x.csv"
    bad.write_text("notes of the run\n")
    lines = []
    for extra in ([], ["--split", "600"]):
        out = tmp_path / f"out{len(extra)}"
        assert run("analyze", bad, "--out", out, *extra) == 2
        lines.append(capsys.readouterr().err)
        assert not out.exists()
    assert lines[0] == lines[1] and lines[0].count("\n") == 1 and "x.csv" in lines[0]


def test_simulate_then_info_and_analyze(cd_cli_run, capsys):
    path, out = cd_cli_run  # simulate, then analyze --area 1 (conftest.py)
    assert run("info", path) == 0
    assert "fs" in capsys.readouterr().out
    s = json.loads((out / "summary.json").read_text())
    rec = next(iter(s["recordings"].values()))
    assert rec["operating_range_current_density"]["optimum"] is not None


@pytest.mark.fast
@pytest.mark.parametrize(
    "args, message",
    [
        (["analyze", "nope.tdms", "--out", "{out}"], "no such file"),
        (["analyze", "{data}/lvm_read_short.lvm", "--out", "{out}", "--map", "fz=Nope,fy=Response (Trigger)"], "Nope"),
        (["analyze", "{data}/pod_PPS_60N_1.tsv", "--out", "{out}", "--window", "-1"], "window"),
        (["analyze", "{data}/pyfrf_measurements_1.npy", "--out", "{out}", "--map", "fz=ch1,fy=ch2"], "fs"),
        (["analyze", "{data}/pod_PPS_60N_1.tsv", "--out", "{out}", "--format", "bogus"], "format"),
        (["analyze", "{data}/pod_PPS_60N_1.tsv", "--out", "{out}", "--config", "missing.toml"], "config"),
        (["info", "{bad}"], "tdms"),
    ],
)
def test_user_errors_one_line_exit_2(tmp_path, capsys, args, message):
    bad = tmp_path / "cut.tdms"
    raw = (DATA / "nptdms_raw1_daqmx.tdms").read_bytes()
    bad.write_bytes(raw[: len(raw) // 2])
    out = tmp_path / "out"
    argv = [a.format(out=out, data=DATA, bad=bad) for a in args]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("tribodyn: error:") and "\n" not in err and "Traceback" not in err
    assert message.lower() in err.lower()
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.fast
def test_debug_shows_the_traceback(tmp_path):
    with pytest.raises(Exception):
        cli.main(["analyze", "nope.tdms", "--out", str(tmp_path / "o"), "--debug"])


def test_no_partial_outputs_after_a_forced_failure(tmp_path, monkeypatch):
    from tribodyn.app import report

    def boom(*a, **k):
        raise ValueError("forced failure while writing the report")

    monkeypatch.setattr(report, "write_report", boom)
    out = tmp_path / "out"
    assert run("analyze", DATA / "pod_PPS_60N_1.tsv", "--out", out, "--window", "60", "--hop", "60", "--quiet") == 2
    assert not out.exists() and list(tmp_path.iterdir()) == []  # no folder, no staging folder (issue 21)


@pytest.mark.fast
def test_console_script_is_installed():
    exe = shutil.which("tribodyn")
    assert exe is not None
    r = subprocess.run([exe, "--version"], capture_output=True, text=True, check=False)
    assert r.returncode == 0 and r.stdout.startswith("tribodyn ")
    r = subprocess.run(
        [sys.executable, "-m", "tribodyn.app.cli", "analyze", "nope.tdms", "--out", "x"], capture_output=True, text=True
    )
    assert r.returncode == 2 and "Traceback" not in r.stderr


def test_npy_without_rate_asks_for_the_cli_option(tmp_path, capsys):
    """A .npy carries no sampling rate: the error names --fs, and --fs makes info and analyze work."""
    p = tmp_path / "rec.npy"
    rng = np.random.default_rng(3)
    fz = rng.normal(size=(4000,))
    np.save(p, np.stack([fz * 0.2, fz]))
    # info describes the file anyway, and says what is missing.
    assert cli.main(["info", str(p)]) == 0
    out = capsys.readouterr().out
    assert "sampling rate: unknown (give --fs HZ)" in out and "fs=..." not in out
    assert cli.main(["analyze", str(p), "--out", str(tmp_path / "o")]) == cli.EXIT_USER_ERROR
    err = capsys.readouterr().err
    assert "sampling rate unknown" in err and "give --fs HZ" in err and "fs=..." not in err
    assert cli.main(["info", str(p), "--fs", "1000"]) == 0
    assert "sampling rate: 1000 Hz" in capsys.readouterr().out


# -- the outputs of reciprocating and stick-slip recordings (moved from the analyses' fast files: CLI runs)


def test_the_cli_reports_stick_slip_only_when_present(tmp_path, capsys):
    from tribodyn.app.cli import main
    from tribodyn.io.writers import save_npz

    for name, kw in (("slip", {"stick_slip": 0.2, "stick_slip_period": 0.0233}), ("smooth", {})):
        sim = simulate.reciprocating(seed=11, cycles=4, **kw)
        p = tmp_path / f"{name}.npz"
        save_npz(p, sim.channels, sim.fs)
        assert main(["analyze", str(p), "--out", str(tmp_path / name)]) == 0
        out = capsys.readouterr().out
        summary = json.loads((tmp_path / name / "summary.json").read_text())
        ss = summary["recordings"][f"{name}.npz"]["stick_slip"]
        html = (tmp_path / name / "report.html").read_text()
        if name == "slip":
            assert ss["present"] and ss["events"] > 20
            assert "stick-slip present:" in out and "stick-slip present:" in html
        else:
            assert not ss["present"] and ss["events"] == 0
            assert "stick-slip" not in out and "stick-slip present" not in html


def test_the_report_draws_the_friction_loops_and_the_energy(tmp_path):
    from tribodyn.app.cli import main
    from tribodyn.io.writers import save_npz

    sim = simulate.reciprocating(seed=6, cycles=6)
    p = tmp_path / "recip.npz"
    save_npz(p, sim.channels, sim.fs)
    # an npz carries no unit: the position's is said (metres), else no energy or loop (issue 34 point 4)
    assert main(["analyze", str(p), "--out", str(tmp_path / "u"), "--map", "x=x", "-q"]) == 0
    assert "friction_loops.png" not in {f.name for f in (tmp_path / "u" / "figures").iterdir()}
    assert main(["analyze", str(p), "--out", str(tmp_path / "o"), "--map", "x=x", "--scale", "x=1", "-q"]) == 0
    figs = {f.name for f in (tmp_path / "o" / "figures").iterdir()}
    assert {"friction_loops.png", "energy_vs_cycle.png", "strokes_cof_vs_cycle.png"} <= figs
    html = (tmp_path / "o" / "report.html").read_text()
    assert "Friction loops" in html and "Energy dissipated per cycle" in html


@pytest.mark.fast
def test_info_takes_the_reading_options_of_analyze_and_says_what_it_refuses(capsys):
    lvm = DATA / "lvm_read_long_single_header_multi_ch.lvm"
    assert run("info", lvm, "--map", "fz=F,fy=m_1", "--json") == 0
    info = json.loads(capsys.readouterr().out)[0]
    assert info["roles"] == {"fz": "F", "fy": "m_1"} and "fy ('m_1') is in m/s^2" in info["analyze_refuses"][0]
    assert run("info", lvm, "--map", "fz=F,fy=m_1", "--scale", "fy=1") == 0
    out = capsys.readouterr().out
    assert "analyze refuses" not in out and "scaled by the caller" in out
