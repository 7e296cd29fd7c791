"""Parquet outputs in every install (issue 21): pyarrow is a dependency, windows.parquet and strokes.parquet
are written next to the CSV files and read back equal to them."""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from tribodyn.app import cli
from tribodyn.app.outputs import write_table_parquet
from _paths import REPO

ROOT = REPO
DATA = ROOT / "tests" / "data" / "real"

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


def _csv_columns(path: Path) -> dict:
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    return {k: [r[k] for r in rows] for k in rows[0]}


def _assert_same(parquet: Path, csv_path: Path) -> None:
    table = pq.read_table(parquet)
    text = _csv_columns(csv_path)
    assert table.column_names == list(text)
    assert table.num_rows == len(next(iter(text.values()))) > 0
    for name in table.column_names:
        values = table.column(name).to_numpy(zero_copy_only=False)
        cells = text[name]
        if values.dtype.kind == "f":
            want = np.array([float(c) if c != "" else np.nan for c in cells])
            np.testing.assert_array_equal(values, want, err_msg=name)
        elif values.dtype.kind == "b":
            assert [("true" if v else "false") for v in values] == cells, name
        elif values.dtype.kind in "iu":
            assert [str(int(v)) for v in values] == cells, name
        else:
            assert [str(v) for v in values] == [c.lstrip("'") for c in cells], name


def test_pyarrow_is_a_dependency_not_only_an_extra():
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    assert any(d.replace(" ", "").startswith("pyarrow>=") for d in meta["dependencies"])


def test_analyze_writes_windows_parquet_equal_to_the_csv(tmp_path):
    out = tmp_path / "pod"
    assert cli.main(["analyze", str(DATA / "pod_PPS_60N_1.tsv"), "--out", str(out), "--quiet"]) == 0
    assert (out / "windows.parquet").is_file()
    _assert_same(out / "windows.parquet", out / "windows.csv")


def test_reciprocating_writes_strokes_parquet_equal_to_the_csv(tmp_path):
    out = tmp_path / "cetr"
    args = ["analyze", str(DATA / "cetr_umt2_HT-2n-6-4_2_001.csv"), "--out", str(out), "--quiet",
            "--map", "fy=Fx", "--motion", "reciprocating"]  # fmt: skip
    assert cli.main(args) == 0
    assert (out / "strokes.parquet").is_file() and (out / "windows.parquet").is_file()
    _assert_same(out / "strokes.parquet", out / "strokes.csv")
    _assert_same(out / "windows.parquet", out / "windows.csv")


def test_a_missing_pyarrow_is_an_error_not_a_missing_file(tmp_path, monkeypatch):
    import tribodyn as td

    res = td.analyze({"fy": np.full(400, 1.0), "fz": np.full(400, 10.0)}, fs=100.0, window=2.0, hop=2.0)
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    with pytest.raises(ImportError, match="pip install pyarrow"):
        write_table_parquet(res, tmp_path / "w.parquet")
    assert not (tmp_path / "w.parquet").exists()


def test_columns_built_from_buffers_equal_pyarrow_s_own_and_need_no_pandas(tmp_path):
    """outputs.arrow_array makes the array pa.array makes (type, values, nulls), without importing pandas."""
    import subprocess

    code = (
        "import sys, numpy as np, pyarrow as pa\n"
        "from tribodyn.app.outputs import arrow_array\n"
        "rng = np.random.default_rng(0)\n"
        "cases = [rng.normal(size=7), np.array([np.nan, 1.0, -np.inf]), np.arange(9, dtype=np.int32),\n"
        "         np.arange(4, dtype=np.uint8), np.array([True, False, True]),\n"
        "         np.array(['a', 'bé', '', '=x'], dtype=object),\n"
        "         np.array(['a', 'b']), np.zeros(0), rng.normal(size=20)[::2], np.arange(5, dtype=np.float32)]\n"
        "got = [arrow_array(pa, c) for c in cases]\n"
        "assert 'pandas' not in sys.modules\n"
        "for c, g in zip(cases, got):\n"
        "    w = pa.array(c.astype(str) if c.dtype == object else c)\n"
        "    g.validate(full=True)\n"
        "    assert g.type == w.type and g.null_count == w.null_count == 0, (c, g.type, w.type)\n"
        "    assert repr(g.to_pylist()) == repr(w.to_pylist()), c\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, cwd=tmp_path)
