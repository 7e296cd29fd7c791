"""The quick report (issue 38 point 3): ``--figures auto|all|none``, the interactive views built by BokehJS in the
browser from the windows' numbers (Bokeh's Python package never imported), Matplotlib imported only to draw.
The speed itself is measured in benches/bench_cli_export.py (benches/RESULTS.md), not here."""

from __future__ import annotations

import base64
import json
import re
import subprocess
import sys

import numpy as np
import pytest

import tribodyn as td
from tribodyn.app import _interactive, jobs
from tribodyn.app.cli import main
from _paths import TESTS

EXPORT = TESTS / "data" / "real" / "pod_PPS_100N_1.tsv"  # a dead-weight export: classical headline


def _view_data(html: str) -> dict:
    m = re.search(r"var d = (\{.*?\}), id = ", html, re.S)
    assert m, html[:500]
    return json.loads(m.group(1))


def _floats(b64: str) -> np.ndarray:
    return np.frombuffer(base64.b64decode(b64), dtype="<f8")


def test_view_embeds_the_shown_windows_numbers_exactly():
    """The page's view carries the gated windows' time, COF, interval, T and J bit for bit (float64 in base64)
    and the failed windows' times and reasons; a "</script>" in a name cannot end the script."""
    sim = td.simulate.current_density_test(seed=3)
    res = td.analyze(sim.channels, fs=sim.fs, window=2.0, hop=10.0, area_mm2=sim.area_mm2)
    script, div = _interactive.cof_views(res, "a</script><b>")
    view_id = re.search(r'id="(tribodyn-view-\d+)"', div).group(1)
    assert f'id = "{view_id}"' in script and "</script>" not in script[:-9]
    d = _view_data(script)
    ok = np.asarray(res["ok"], dtype=bool) & np.isfinite(np.asarray(res["mu_r"], dtype=float))
    assert d["good"] == int(ok.sum()) and d["title"].startswith("a</script><b>: COF against time")
    for key, col in (("t", "time"), ("mu", "mu_r"), ("lo", "mu_r_low"), ("hi", "mu_r_high"), ("J", "J")):
        np.testing.assert_array_equal(_floats(d["cols"][key]), np.asarray(res[col], dtype=float)[ok])
    assert d["cols"]["T"] is None  # no temperature: the page fills NaN
    bad = ~np.asarray(res["ok"], dtype=bool)
    assert bad.any() and d["failed"]["why"] == [str(r) for r in np.asarray(res["reasons"])[bad]]
    np.testing.assert_array_equal(_floats(d["failed"]["t"]), np.asarray(res["time"], dtype=float)[bad])
    assert [s["key"] for s in d["side"]] == ["J"]
    lo, hi = d["y_range"]
    assert lo < np.median(_floats(d["cols"]["mu"])) < hi


@pytest.mark.parametrize(("name", "method"), [("drag_rotational.csv", "classical"),
                                               ("load_step_reciprocating.csv", "per-stroke")])  # fmt: skip
def test_the_view_of_an_export_has_no_row_of_failed_windows(name, method):
    """The row "windows that failed the quality gate" is the dynamic gate's: a recording whose headline is the
    classical or per-stroke COF (the gate plays no part in it) gets none, even with windows that fail the gate;
    its windows without that COF are gaps, counted in the legend (issue 33 point 3)."""
    res = td.analyze(str(TESTS / "data" / "formats" / name))
    assert res.headline.method == method and not np.asarray(res["ok"], dtype=bool).all()
    have = np.isfinite(np.asarray(res["mu_classical"], dtype=float))
    assert 0 < have.sum() < have.size
    script, _ = _interactive.cof_views(res, "x")
    d = _view_data(script)
    assert d["failed"] is None and "quality gate" not in script
    assert d["legend"] == f"classical COF per window ({have.sum()} of {have.size} windows)" and d["good"] == have.sum()
    np.testing.assert_array_equal(_floats(d["cols"]["mu"]), np.asarray(res["mu_classical"], dtype=float)[have])


def test_figures_auto_draws_no_png_the_view_shows_for_an_export(tmp_path):
    """--figures auto (the default): an export whose headline is the classical COF gets neither the window
    diagnostics nor the COF-against-time PNG (its interactive view shows the COF with the headline and the
    instrument's COF), and the report says so and how to get them; --figures none says it drew none; the tables
    and summary are those of every choice."""
    assert main(["analyze", str(EXPORT), "--out", str(tmp_path / "auto"), "-q"]) == 0
    assert main(["analyze", str(EXPORT), "--out", str(tmp_path / "none"), "-q", "--figures", "none"]) == 0
    auto, none = (tmp_path / "auto"), (tmp_path / "none")
    for d in (auto, none):
        assert not (d / "figures").exists() or not any((d / "figures").iterdir())
    page = (auto / "report.html").read_text(encoding="utf-8")
    assert "window diagnostics (paper Figs. 2-9) are not drawn: the headline is the classical COF" in page
    assert "--figures all draws every figure as PNG" in page and '<figure id="fig' not in page
    view = _view_data(page)
    head = td.analyze(str(EXPORT)).headline
    assert view["headline"]["value"] == head.value and view["headline"]["low"] == head.low
    assert view["cols"]["inst"] is not None and view["legend"].startswith("classical COF per window")
    page_none = (none / "report.html").read_text(encoding="utf-8")
    assert '<figure id="fig' not in page_none and "no PNG figures were drawn (--figures none)" in page_none
    assert "tribodynCofViews" in page_none and "/* BEGIN bokeh-api.min.js */" in page_none
    assert (auto / "windows.csv").read_bytes() == (none / "windows.csv").read_bytes()
    s_auto, s_none = (json.loads((d / "summary.json").read_text()) for d in (auto, none))
    rec = EXPORT.name
    assert s_auto["recordings"][rec]["headline"] == s_none["recordings"][rec]["headline"]
    assert s_auto["recordings"][rec]["files"] == s_none["recordings"][rec]["files"]


def test_which_figures_each_choice_draws():
    """FIGURES: auto draws the diagnostics only for a dynamic headline, all always, none never; the note."""
    export = td.analyze(str(EXPORT))
    sim = td.simulate.current_density_test(seed=3)
    dynamic = td.analyze(sim.channels, fs=sim.fs, window=2.0, hop=10.0, area_mm2=sim.area_mm2)
    assert export.headline.method == "classical" and dynamic.headline.method == "dynamic"
    drawn = {(c, r.headline.method): jobs._diagnostics_drawn(c, r) for c in jobs.FIGURES for r in (export, dynamic)}
    assert drawn == {("auto", "classical"): False, ("auto", "dynamic"): True, ("all", "classical"): True,
                     ("all", "dynamic"): True, ("none", "classical"): False, ("none", "dynamic"): False}  # fmt: skip
    assert jobs.figures_note("auto", dynamic, "x") == "" and jobs.figures_note("all", export, "x") == ""
    assert "classical COF" in jobs.figures_note("auto", export, "x")
    names = [n for n, _, _ in jobs._figures(export, opr_t=None, opr_j=None, time_figure=False)]
    assert names == [] and [n for n, _, _ in jobs._figures(export, opr_t=None, opr_j=None)] == ["cof_vs_time"]
    with pytest.raises(ValueError, match="figures must be one of auto, all, none"):
        jobs.run_analysis([str(EXPORT)], "unused", figures="some")


def test_the_command_line_never_imports_bokeh_and_matplotlib_only_to_draw(tmp_path):
    """In a fresh process: an export's default report imports neither Matplotlib nor Bokeh; --figures all then
    draws with Matplotlib and still imports no Bokeh (the views are BokehJS's, in the page)."""
    code = (
        "import sys\n"
        "from tribodyn.app.cli import main\n"
        f"assert main(['analyze', {str(EXPORT)!r}, '--out', {str(tmp_path / 'a')!r}, '-q']) == 0\n"
        "first = sorted(m for m in ('matplotlib', 'bokeh') if m in sys.modules)\n"
        f"assert main(['analyze', {str(EXPORT)!r}, '--out', {str(tmp_path / 'b')!r}, '-q', '--figures', 'all']) == 0\n"
        "print(first, sorted(m for m in ('matplotlib', 'bokeh') if m in sys.modules))\n"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    assert p.stdout.strip().splitlines()[-1] == "[] ['matplotlib']"


def _fig(k: int):
    """A constrained-layout figure with a mathtext label and a legend, as the report's (fresh each time: a
    constrained-layout figure drawn twice may differ)."""
    from tribodyn.app import figures

    fig, axes = figures._figure(figsize=(3.0, 2.0))
    axes[0, 0].plot(np.arange(50.0), np.sin(np.arange(50.0) / (k + 2)), label=r"$\mu_r$ (regression)")
    axes[0, 0].set_ylabel(r"$F_{y,d}$ (N)")
    axes[0, 0].legend()
    return fig


@pytest.mark.fast
def test_figures_drawn_beside_the_tables_are_the_same_bytes():
    """``Rendering.finish_beside``: ``meanwhile`` (the tables and summary) runs once in a second thread, which
    also encodes the PNGs; the bytes are those of ``png_bytes`` (drawn and encoded at once), in order."""
    import threading

    from tribodyn.app import figures

    ran = []

    def meanwhile():
        ran.append(threading.get_ident())
        return "tables"

    pngs, done = figures.Rendering([_fig(k) for k in range(3)]).finish_beside(meanwhile)
    assert done == "tables" and len(ran) == 1 and ran[0] != threading.get_ident()
    assert pngs == [figures.png_bytes(_fig(k)) for k in range(3)]
    assert figures.encode_png(figures.rgba_pixels(_fig(1))) == pngs[1]
    assert figures.Rendering([]).finish_beside(lambda: 7) == ([], 7)


@pytest.mark.fast
def test_what_the_tables_raise_beside_the_figures_is_raised():
    """A failure of ``meanwhile`` is raised by ``finish_beside`` (the job fails as before), and a failure of the
    drawing is raised once the thread is done."""
    from tribodyn.app import figures

    def failing():
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        figures.Rendering([_fig(k) for k in range(2)]).finish_beside(failing)

    class Broken:
        def savefig(self, *a, **k):
            raise ValueError("cannot draw")

    ran = []
    with pytest.raises(ValueError, match="cannot draw"):
        figures.Rendering([Broken()]).finish_beside(lambda: ran.append(1))  # type: ignore[list-item]
    assert ran == [1]


def _idat_zlib_header(png: bytes) -> bytes:
    """The first two bytes of a PNG's zlib stream (its first IDAT chunk's data)."""
    k = png.index(b"IDAT")
    return png[k + 4 : k + 6]


@pytest.mark.fast
def test_the_report_pngs_hold_the_drawn_pixels_encoded_fast():
    """The report's PNGs (``png_bytes``, and ``encode_png`` beside the drawing) decode to exactly the pixels Agg
    drew, their zlib stream at the fastest level class (``PNG_COMPRESS_LEVEL`` 1: about half the encoding CPU of
    the default level 6; issue 38 point 3)."""
    import io

    from PIL import Image

    from tribodyn.app import figures

    pixels = figures.rgba_pixels(_fig(0))
    for png in (figures.png_bytes(_fig(0)), figures.encode_png(pixels)):
        decoded = np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"))
        np.testing.assert_array_equal(decoded, pixels)
        cmf, flg = _idat_zlib_header(png)
        assert cmf & 0x0F == 8 and flg >> 6 == 0  # deflate; FLEVEL 0: the fastest level class (levels 0-1)
    assert figures.PNG_COMPRESS_LEVEL == 1


def test_a_folder_opens_each_recording_once_with_analyze_manys_tables(tmp_path, monkeypatch):
    """Several files analysed here (no cluster): each recording is opened once, for its analysis and its outputs
    (a text export parsed once; issue 38 point 3), its table is byte for byte what ``analyze_many`` gives, and a
    file that fails is listed with ``analyze_many``'s error while the others are written."""
    import tribodyn.io as tio
    from tribodyn.app.outputs import write_table_csv

    bad = tmp_path / "not_a_recording.csv"
    bad.write_text("no numbers here\njust words\n", encoding="utf-8")
    files = [str(EXPORT), str(TESTS / "data" / "formats" / "drag_rotational.csv"), str(bad)]
    opened = []
    real_open = tio.open_recording

    def counting_open(path, *a, **k):
        opened.append(str(path))
        return real_open(path, *a, **k)

    monkeypatch.setattr(tio, "open_recording", counting_open)
    summary = jobs.run_analysis(files, tmp_path / "out", figures="none")
    monkeypatch.setattr(tio, "open_recording", real_open)
    assert sorted(opened) == sorted(files)
    many = td.analyze_many(files)
    assert summary["failures"] == {bad.name: {"error": many.failures[str(bad)].error,
                                              "kind": many.failures[str(bad)].kind}}  # fmt: skip
    for f in files[:2]:
        write_table_csv(many.results[f], tmp_path / "expected.csv")
        stem = f.rsplit("/", 1)[-1].rsplit(".", 1)[0]
        got = (tmp_path / "out" / stem / "windows.csv").read_bytes()
        assert got == (tmp_path / "expected.csv").read_bytes(), f


def _csv_module_text(results, extra=None) -> bytes:
    """windows.csv as csv.writer (the excel dialect) writes the cells of ``write_table_csv``: the reference."""
    import csv
    import io

    from tribodyn.app import outputs

    cols = outputs._columns(results, extra)
    buf = io.StringIO(newline="")
    w = csv.writer(buf)
    w.writerow([outputs._safe_text(str(n)) for n in cols])
    w.writerows(zip(*(outputs._column_cells(v) for v in cols.values())))
    return buf.getvalue().encode("utf-8")


@pytest.mark.fast
def test_windows_csv_is_the_text_of_the_csv_module(tmp_path, temp_res):
    """windows.csv, built a line at a time (issue 38 point 3), is byte for byte what csv.writer writes of the same
    cells: floats as repr (17 significant digits, round trip), NaN empty, bools, integers, and text cells quoted as
    csv quotes them (a comma, a quote, CR or LF in a recording's name or a reason), formula starts made safe; also
    with no row, and with one column (csv quotes a row of one empty field)."""
    from tribodyn.app.outputs import write_table_csv

    class Table:  # what write_table_csv reads of a Results: its table and its length
        def __init__(self, table):
            self.table = table

        def __len__(self):
            return len(next(iter(self.table.values())))

    n = len(temp_res)
    names = np.array(["a,b", 'x"y', "=1+2", "l\nf", "c\rr", "", " s", "é;t", "'q"] * n)[:n]
    empty = Table({k: np.asarray(v)[:0] for k, v in temp_res.table.items()})
    out = tmp_path / "w.csv"
    for res, extra in ((temp_res, None), (temp_res, {"recording": names}), (empty, {"recording": names[:0]})):
        write_table_csv(res, out, extra=extra)
        assert out.read_bytes() == _csv_module_text(res, extra)
    assert b'"a,b"' in _csv_module_text(temp_res, {"recording": names})  # (the cases above reach the quoting)
    one = Table({"reasons": np.array(["", "a,b"])})
    write_table_csv(one, out)
    assert out.read_bytes() == _csv_module_text(one) == b'reasons\r\n""\r\n"a,b"\r\n'
