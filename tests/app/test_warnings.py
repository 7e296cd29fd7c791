"""Reader warnings travel with the results: ``Results.warnings``, ``summary()`` and the report."""

from __future__ import annotations

import numpy as np
import tribodyn as td
from tribodyn.app.report import write_report
from tribodyn.io.writers import save_hdf5


def _recording(tmp_path):
    from tribodyn import simulate

    ch = next(iter(simulate.continuous(60.0, chunk_s=60.0, current=4.0, seed=3, fs=1000.0)))
    p = tmp_path / "w.h5"
    save_hdf5(p, {r: ch[r] for r in ("fx", "fy", "fz", "i")}, 1000.0)
    return p


def test_reader_warnings_reach_results_summary_and_report(tmp_path):
    p = _recording(tmp_path)
    with td.open_recording(p, fs=1000.5) as rec:  # overrides the file's rate: the reader warns
        assert rec.warnings
        res = td.analyze(rec, window=2.0, hop=2.0)
    assert res.warnings == tuple(rec.warnings)
    assert res.summary()["warnings"] == list(rec.warnings)
    assert res.with_orientation(-res.orientation).warnings == res.warnings
    page = tmp_path / "r.html"
    write_report(page, title="t", summary={"one": res.summary()}, params=res.params, figures=[])
    text = page.read_text(encoding="utf-8")
    assert '<h2 id="warnings">' in text and "overrides the file" in text


def test_no_warnings_no_section(tmp_path):
    p = _recording(tmp_path)
    with td.open_recording(p) as rec:
        res = td.analyze(rec, window=2.0, hop=2.0)
    assert res.warnings == () and res.summary()["warnings"] == []
    page = tmp_path / "r.html"
    write_report(page, title="t", summary=res.summary(), params=res.params, figures=[])
    assert 'id="warnings"' not in page.read_text(encoding="utf-8")
    assert np.isfinite(res["mu_r"]).all()


def test_cli_prints_each_reader_warning_once_on_stderr(tmp_path):
    import json
    import subprocess
    import sys

    p = _recording(tmp_path)
    out = tmp_path / "out"
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "tribodyn.app.cli",
            "analyze",
            str(p),
            "--out",
            str(out),
            "--fs",
            "1000.5",
            "--hop",
            "2",
        ],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if "overrides the file" in ln]
    assert len(lines) == 1 and lines[0].startswith("tribodyn: warning: w.h5: ")
    summary = json.loads((out / "summary.json").read_text())
    assert any("overrides the file" in w for w in summary["recordings"]["w.h5"]["warnings"])
    assert "overrides the file" in (out / "report.html").read_text(encoding="utf-8")
