"""MAT-files, spreadsheets and multi-step exports (issue 34, item 1): each reader against an independent
reading of the same file (scipy.io, h5py, the sheet's XML, the text split by hand), the detection's
messages naming what a file really holds, arrays of shape (N, 1) and (1, N) and ``--sheet``. The one
command of docs/tribometer-exports.md for each file: tests/app/test_format_commands.py."""

from __future__ import annotations

import io
import re
import sys
import zipfile
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Dict, List

import h5py
import numpy as np
import pytest
import scipy.io

from tribodyn.app import cli
from tribodyn.io import RecordingError, detect_format, open_recording
from _paths import TESTS


DATA = TESTS / "data" / "formats"
MAT5 = DATA / "matlab_v5_pin_on_disc.mat"
MAT4 = DATA / "matlab_v4_block_on_ring.mat"
MAT73 = DATA / "matlab_v73_struct.mat"
XLSX = DATA / "excel_reciprocating.xlsx"
ODS = DATA / "opendocument_pin_on_disc.ods"
STEPS = DATA / "multistep_traction.txt"


def one_error(capsys) -> str:
    err = capsys.readouterr().err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("tribodyn: error: ") and "Traceback" not in err, err
    return lines[0]


# ------------------------------------------------------------------------------------------ MAT-files
@pytest.mark.fast
def test_mat_v5_vectors_of_either_orientation_and_fs_variable():
    ref = scipy.io.loadmat(MAT5)
    assert ref["Ff"].shape[1] == 1 and ref["Fn"].shape[0] == 1  # a column and a row vector
    assert detect_format(MAT5) == "mat"
    with open_recording(MAT5) as rec:
        assert rec.format == "mat" and rec.metadata["version"] == "5"
        assert rec.fs == 2000.0 and rec.n_samples == 4000 and "variable 'fs'" in rec.info()["fs_source"]
        assert rec.roles == {"fy": "Ff", "fz": "Fn", "cof": "mu"}
        got = rec.read(["fy", "fz", "cof"])
    assert np.array_equal(got["fy"], ref["Ff"].ravel()) and np.array_equal(got["fz"], ref["Fn"].ravel())
    assert np.array_equal(got["cof"], ref["mu"].ravel())


@pytest.mark.fast
def test_mat_v4_has_no_signature_and_fs_comes_from_its_time_vector():
    ref = scipy.io.loadmat(MAT4)
    assert not MAT4.read_bytes().startswith(b"MATLAB")
    with open_recording(MAT4) as rec:
        assert rec.metadata["version"] == "4" and rec.fs == pytest.approx(500.0)
        assert "time column 'time'" in rec.info()["fs_source"]
        got = rec.read(["fy", "fz"])
    assert np.array_equal(got["fz"], ref["fz"].ravel())


@pytest.mark.fast
def test_mat_v73_is_read_with_its_matlab_names():
    with h5py.File(MAT73, "r") as f:  # MATLAB stores (N, 1) as (1, N) in HDF5
        want = np.asarray(f["test/friction_force"][()]).T.ravel()
    with open_recording(MAT73) as rec:
        assert rec.metadata["version"] == "7.3 (HDF5)"
        assert rec.channel_names == ["test.time", "test.friction_force", "test.normal_force"]
        assert rec.roles == {"fy": "test.friction_force", "fz": "test.normal_force"}
        assert rec.fs == pytest.approx(1000.0) and "1/variable 'dt'" in rec.info()["fs_source"]
        assert np.array_equal(rec.read("fy")["fy"], want)
    assert detect_format(MAT73) == "mat"  # not "hdf5": the MATLAB header decides


@pytest.mark.fast
def test_mat_matrix_columns_structs_and_lengths(tmp_path):
    t = np.arange(500) / 100.0
    data = np.column_stack([t, np.sin(t), np.cos(t)])
    p = tmp_path / "m.mat"
    scipy.io.savemat(p, {"data": data, "meta": {"fs": 100.0, "gain": np.arange(3.0)}, "label": "x"})
    with open_recording(p, fs=100.0) as rec:
        assert rec.channel_names == ["data(:,1)", "data(:,2)", "data(:,3)"]
        assert set(rec.metadata["skipped"]) == {"meta.gain", "label"}  # shorter vector, text
        assert np.array_equal(rec.read("data(:,2)")["data(:,2)"], data[:, 1])
    with open_recording(p, channels={"fy": "data(:,2)", "fz": "data(:,3)"}, time_column="data(:,1)") as rec:
        assert rec.fs == pytest.approx(100.0) and rec.roles["fy"] == "data(:,2)"


@pytest.mark.fast
@pytest.mark.parametrize(
    "content, message",
    [
        (b"MATLAB 5.0 MAT-file" + b" " * 97 + b"\x00" * 8 + b"\x00\x01IM" + b"\x00\x01", "not a readable MAT-file"),
        (b"time,fy\n0,1\n", "its content is text"),
    ],
)
def test_bad_mat_files_are_one_line(tmp_path, capsys, content, message):
    p = tmp_path / "bad.mat"
    p.write_bytes(content)
    assert cli.main(["info", str(p)]) == 2
    assert message in one_error(capsys)


@pytest.mark.fast
def test_mat_without_numbers(tmp_path):
    p = tmp_path / "text.mat"
    scipy.io.savemat(p, {"note": "no data"})
    with pytest.raises(RecordingError, match=r"no numeric vector in this MAT-file \(variables: note\)"):
        open_recording(p)


# -------------------------------------------------------------------------------------- spreadsheets
def _sheet_cells(path: Path, part: str) -> List[List[str]]:
    """The sheet's cells as text, straight from its XML (independent of calamine)."""
    ns = {"m": "http://schemas.openxmlformats.org/spreadsheetml/2006/main"}
    with zipfile.ZipFile(path) as z:
        root = ET.fromstring(z.read(part))
    rows = []
    for r in root.iterfind(".//m:row", ns):
        rows.append(["".join(c.itertext()) for c in r.iterfind("m:c", ns)])
    return rows


@pytest.mark.fast
def test_xlsx_first_numeric_sheet_units_row_and_values():
    cells = _sheet_cells(XLSX, "xl/worksheets/sheet2.xml")
    names, units = cells[2], cells[3]
    assert units == ["s", "N", "N", "mm", "-"]
    body = np.array([[float(x) for x in r] for r in cells[4:]])
    assert detect_format(XLSX) == "spreadsheet"
    with open_recording(XLSX) as rec:
        assert rec.metadata["sheet"] == "Data"  # the first sheet ("Info") holds no numeric table
        assert rec.channel_names == names and rec.fs == pytest.approx(50.0)
        info = {c.name: c for c in rec.channels}
        assert info["Position"].unit == "m" and info["Position"].scale == 1e-3 and info["Position"].raw_unit == "mm"
        assert info["Friction force"].unit == "N" and info["COF"].raw_unit is None
        got = rec.read(["fy", "fz", "x"])
    assert np.array_equal(got["fy"], body[:, 1]) and np.array_equal(got["fz"], body[:, 2])
    assert np.allclose(got["x"], body[:, 3] * 1e-3, rtol=1e-15)


@pytest.mark.fast
def test_ods_units_in_the_names():
    with open_recording(ODS) as rec:
        assert rec.metadata["sheet"] == "Pin on disc" and rec.fs == pytest.approx(10.0)
        assert rec.roles["fz"] == "Load (N)" and rec.roles["fy"] == "Friction force (N)"
        assert {c.name: c.unit for c in rec.channels}["Time (s)"] == "s"
        assert rec.n_samples == 1200


def test_sheet_option_in_the_api_the_cli_and_the_config(tmp_path, capsys):
    with open_recording(XLSX, sheet="data") as rec:  # case-insensitive when no sheet has the exact name
        assert rec.metadata["sheet"] == "Data"
    assert cli.main(["info", str(XLSX), "--sheet", "Info"]) == 2
    assert "sheet 'Info' holds no numeric table" in one_error(capsys)
    assert cli.main(["info", str(XLSX), "--sheet", "Results"]) == 2
    assert "no sheet 'Results'; sheets: 'Info', 'Data'" in one_error(capsys)
    cfg = tmp_path / "c.toml"
    cfg.write_text('sheet = "Info"\n')
    assert cli.main(["analyze", str(XLSX), "--out", str(tmp_path / "o"), "--config", str(cfg), "-q"]) == 2
    assert "sheet 'Info' holds no numeric table" in one_error(capsys)
    # another format has no sheets: ignored with a warning, so that a job of several files can name it
    with open_recording(DATA / "matlab_v5_pin_on_disc.mat", sheet="Data") as rec:
        assert "sheet='Data' ignored: a mat file has no sheets" in rec.warnings
    pod = DATA.parent / "real" / "pod_PPS_60N_1.tsv"
    assert cli.main(["analyze", str(XLSX), str(pod), "--sheet", "Data", "--out", str(tmp_path / "mix"), "-q"]) == 0
    assert "sheet='Data' ignored: a delimited file has no sheets" in capsys.readouterr().err


def _xlsx(path: Path, rows: List[List[object]]) -> None:
    """A one-sheet workbook from rows (the generator's writer, reused)."""
    sys.path.insert(0, str(DATA))
    try:
        import make_format_files as m
    finally:
        sys.path.pop(0)
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        with zipfile.ZipFile(XLSX) as src:
            for name in src.namelist():
                if name == "xl/worksheets/sheet1.xml":
                    z.writestr(name, m._sheet_xml(rows))
                elif name == "xl/worksheets/sheet2.xml":
                    z.writestr(name, m._sheet_xml([["empty"]]))
                else:
                    z.writestr(name, src.read(name))
    path.write_bytes(buf.getvalue())


@pytest.mark.fast
def test_irregular_time_in_a_sheet(tmp_path):
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.5, 1.5, 400)) * 0.01
    rows: List[List[object]] = [["time", "fy", "fz"], ["s", "N", "N"]]
    rows += [[float(x), 1.0 + 0.1 * np.sin(x), 10.0] for x in t]
    p = tmp_path / "irr.xlsx"
    _xlsx(p, rows)
    with pytest.raises(RecordingError, match="irregular sampling.*resample=HZ"):
        open_recording(p)
    with open_recording(p, resample=100.0) as rec:
        assert rec.fs == 100.0 and rec.n_samples == int(np.floor((t[-1] - t[0]) * 100 + 1e-9)) + 1
        assert any("resampled linearly" in w for w in rec.warnings)
    with pytest.raises(RecordingError, match=r"resample=1e\+09 Hz would make .* GiB"):
        open_recording(p, resample=1e9)


# ------------------------------------------------------------------------------------ multi-step exports
def _blocks_by_hand(path: Path) -> Dict[int, Dict[str, List[float]]]:
    """Each step's numeric columns, by splitting the text at its 'Step N started at' lines."""
    out: Dict[int, Dict[str, List[float]]] = {}
    step, names = 0, []
    for line in path.read_text(encoding="utf-8").splitlines():
        m = re.match(r"Step (\d+) started at", line)
        if m:
            step, names = int(m.group(1)), []
            out[step] = {}
            continue
        f = line.split("\t")
        if step and len(f) > 2 and not names:
            names = f
            out[step] = {n: [] for n in names}
        elif step and names and len(f) == len(names):
            for n, v in zip(names, f):
                out[step][n].append(float(v))
    return out


@pytest.mark.fast
def test_multistep_export_steps_joined_time_continuous_mappers_apart():
    ref = _blocks_by_hand(STEPS)
    assert detect_format(STEPS) == "steps"
    with open_recording(STEPS) as rec:
        assert rec.format == "steps"
        assert rec.roles == {"fy": "Traction Force (N)", "fz": "Ball Load (N)", "cof": "Traction Coeff (-)"}
        assert rec.segments == [(0, 600), (600, 1200)] and rec.acquisitions == [(0, 600), (600, 1200)]
        got = rec.read(["fy", "Step Time (s)", "step"])
        steps = rec.metadata["steps"]
        other = rec.other_steps
        warnings = list(rec.warnings)
    assert np.array_equal(got["fy"], ref[1]["Traction Force (N)"] + ref[3]["Traction Force (N)"])
    t = got["Step Time (s)"]
    assert np.all(np.diff(t) > 0) and t[600] == t[599] + 1.0  # restarted at 0 in step 3, shifted
    assert [d["kind"] for d in steps] == ["test", "mapper", "test", "mapper"]
    assert steps[2]["time shifted by"] == pytest.approx(600.0)
    assert np.array_equal(np.unique(got["step"]), [1.0, 3.0])
    assert sorted(other) == ["step 2 (mapper)", "step 4 (mapper)"]
    assert np.array_equal(other["step 2 (mapper)"]["Average Film (nm)"], ref[2]["Average Film (nm)"])
    assert any("'Pot Temp (°C)' are not in every test step" in w for w in warnings)
    assert any("step 2 (mapper, 12 rows), step 4 (mapper, 12 rows)" in w for w in warnings)


@pytest.mark.fast
def test_multistep_export_with_decimal_comma_and_no_test_step(tmp_path):
    p = tmp_path / "s.txt"
    p.write_text(
        "Step 1 started at 10:00\nTime (s);Friction force (N);Load (N)\n"
        + "".join(f"{k},0;{0.5 + 0.01 * k:.2f}".replace(".", ",") + ";5,0\n" for k in range(20))
        + "Step 2 Mapper started at 10:10\nSpeed (mm/s);Film (nm)\n1,0;2,0\n"
    )
    with open_recording(p) as rec:
        assert rec.n_samples == 20 and rec.read("fy")["fy"][3] == pytest.approx(0.53)
        assert list(rec.other_steps) == ["step 2 (mapper)"]
    p.write_text("Step 1 mapper started at 10:00\nSpeed (mm/s)\tFilm (nm)\n1.0\t2.0\n")
    with pytest.raises(RecordingError, match=r"no test step with data rows among 1 step\(s\) \(step 1: mapper"):
        open_recording(p)


# -------------------------------------------------------------------- detection names the real content
@pytest.mark.fast
@pytest.mark.parametrize(
    "source, name, message",
    [
        (XLSX, "export.npz", "its content is an Excel workbook"),
        (ODS, "export.npz", "its content is an OpenDocument spreadsheet"),
        (XLSX, "export.mat", "its content is an Excel workbook"),
        (MAT5, "export.xlsx", "its content is a MATLAB MAT-file"),
        (STEPS, "export.xls", "its content is a multi-step text export"),
    ],
)
def test_content_is_named_in_the_error(tmp_path, capsys, source, name, message):
    p = tmp_path / name
    p.write_bytes(source.read_bytes())
    assert cli.main(["info", str(p)]) == 2
    line = one_error(capsys)
    assert message in line and "no 1-D numeric member" not in line


@pytest.mark.fast
@pytest.mark.parametrize(
    "source, fmt, message",
    [
        (XLSX, "mat", "not a readable MAT-file (its content is an Excel workbook)"),
        (MAT5, "spreadsheet", "not a readable spreadsheet (its content is a MATLAB MAT-file)"),
        (STEPS, "xlsx", "not a readable spreadsheet (its content is a multi-step text export)"),
    ],
)
def test_a_format_forced_on_other_content_names_the_content(tmp_path, source, fmt, message):
    with pytest.raises(RecordingError, match=re.escape(message)):
        open_recording(source, format=fmt)


@pytest.mark.fast
def test_an_excel_workbook_read_as_npz_says_so(tmp_path):
    p = tmp_path / "x.npz"
    p.write_bytes(XLSX.read_bytes())
    with pytest.raises(RecordingError, match="not a .npz: its content is an Excel workbook"):
        open_recording(p, format="npz")
    z = tmp_path / "other.npz"
    with zipfile.ZipFile(z, "w") as f:
        f.writestr("readme.txt", "hello")
    with pytest.raises(RecordingError, match=r"its content is a zip archive \(no .npy member\)"):
        open_recording(z)


@pytest.mark.fast
def test_an_ole2_file_is_taken_for_an_excel_97_workbook(tmp_path):
    ole2 = b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1" + bytes(504)
    p = tmp_path / "old.xls"
    p.write_bytes(ole2)
    assert detect_format(p) == "spreadsheet"
    with pytest.raises(
        RecordingError, match=r"old.xls: not a readable spreadsheet \(corrupt, encrypted or truncated\?\)"
    ):
        open_recording(p)
    q = tmp_path / "old.npz"
    q.write_bytes(ole2)
    with pytest.raises(RecordingError, match=r"its content is an OLE2 compound file \(an Excel 97-2003 workbook\?\)"):
        open_recording(q)


@pytest.mark.fast
def test_a_workbook_named_as_another_spreadsheet_is_read_by_content(tmp_path):
    p = tmp_path / "really_ods.xlsx"
    p.write_bytes(ODS.read_bytes())
    with open_recording(p) as rec:
        assert rec.n_samples == 1200


# ---------------------------------------------------------------------------- (N, 1) and (1, N) arrays
@pytest.mark.fast
def test_column_and_row_arrays_are_channels(tmp_path):
    fy, fz = np.linspace(0, 1, 300), np.linspace(1, 2, 300)
    p = tmp_path / "a.npz"
    np.savez(p, fy=fy[:, None], fz=fz[None, :], fs=100.0)
    with open_recording(p) as rec:
        assert rec.channel_names == ["fy", "fz"] and rec.n_samples == 300
        got = rec.read(["fy", "fz"])
    assert np.array_equal(got["fy"], fy) and np.array_equal(got["fz"], fz)
    q = tmp_path / "a.npy"
    np.save(q, fy[:, None])
    with open_recording(q, fs=100.0) as rec:
        assert rec.channel_names == ["ch0"] and np.array_equal(rec.read("ch0")["ch0"], fy)
