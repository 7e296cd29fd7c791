"""Tests of the figures (tribodyn.app.figures) and the HTML report (tribodyn.app.report).

Figures are checked through their artists (axes, labels, lines, patches),
not pixels; the report through its text (embedded images, numbers, no
network reference) and the atomicity of its write.
"""

from __future__ import annotations

import base64
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import tribodyn
from matplotlib.figure import Figure
from tribodyn import simulate
from tribodyn.app import figures as F
from tribodyn.app import report as R

IMG = '<img src="data:image/png;base64,'
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


# --------------------------------------------------------------------------
# fixtures
# --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def cd_sim() -> simulate.Simulation:
    return simulate.current_density_test()


@pytest.fixture(scope="module")
def results(cd_sim):
    """Current-density test with J, a rise-and-fall temperature log (heating and cooling
    branches) and the contact-loss windows that fail the gate."""
    # Slower than covariates.MAX_RATE (0.1 degC/s): faster changes between readings flag the windows (T_gap).
    log = (np.array([0.0, 350.0, 700.0]), np.array([100.0, 130.0, 110.0]))
    return tribodyn.analyze(cd_sim.channels, fs=cd_sim.fs, window=2, hop=10, temperature=log, area_mm2=cd_sim.area_mm2)


@pytest.fixture(scope="module")
def window(cd_sim):
    a, b = 400_000, 402_000  # 400-402 s, in the optimum
    ch = {k: v[a:b] for k, v in cd_sim.channels.items()}
    res = tribodyn.identify(ch["fy"], ch["fz"], fx=ch["fx"], fs=cd_sim.fs, max_lag=200)
    return dict(fx=ch["fx"], fy=ch["fy"], fz=ch["fz"], fs=cd_sim.fs, result=res, t0=400.0)


@pytest.fixture
def nan_results() -> tribodyn.Results:
    """Three windows, every number NaN, every window failed."""
    n, k = 3, 4
    nan = np.full(n, np.nan)
    table = {c: nan.copy() for c in tribodyn.WINDOW_COLUMNS}
    table["time"] = np.array([1.0, 11.0, 21.0])
    table["ok"] = np.zeros(n, dtype=bool)
    table["reasons"] = np.array(["degenerate: fewer than 3 samples or constant fz"] * n)
    table["branch"] = np.zeros(n, dtype=np.int8)
    return tribodyn.Results(
        table=table,
        bin_counts=np.zeros((n, k), dtype=np.int64),
        bin_cof=np.full((n, k), np.nan),
        fz_min=nan.copy(),
        fz_max=nan.copy(),
        orientation=1,
        params={"fs": 1000.0},
    )


def _texts(fig: Figure) -> str:
    out = [t.get_text() for t in fig.texts]
    if fig._suptitle is not None:
        out.append(fig._suptitle.get_text())
    for ax in fig.axes:
        out += [t.get_text() for t in ax.texts]
        out += [ax.get_title(), ax.get_xlabel(), ax.get_ylabel()]
        leg = ax.get_legend()
        if leg is not None:
            out += [t.get_text() for t in leg.get_texts()]
    return "\n".join(out)


def _legend(ax) -> list:
    leg = ax.get_legend()
    return [] if leg is None else [t.get_text() for t in leg.get_texts()]


def _span_x(patch) -> tuple:
    """x extent in data units of an axvspan (a Rectangle in new matplotlib, a Polygon in old)."""
    if hasattr(patch, "get_width"):
        return patch.get_x(), patch.get_x() + patch.get_width()
    xs = np.asarray(patch.get_xy())[:, 0]
    return float(xs.min()), float(xs.max())


def _labelled(ax, prefix: str):
    return [ln for ln in ax.get_lines() if ln.get_label().startswith(prefix)]


# --------------------------------------------------------------------------
# figures
# --------------------------------------------------------------------------
def test_forces_vs_time(window):
    w = window
    fig = F.forces_vs_time(w["fx"], w["fy"], w["fz"], w["fs"], t0=w["t0"])
    assert isinstance(fig, Figure)
    axes = fig.axes
    assert len(axes) == 3
    for ax, name in zip(axes, "xyz"):
        assert f"F_{{{name},d}}" in ax.get_ylabel() and "(N)" in ax.get_ylabel()
        traces = [ln for ln in ax.get_lines() if len(ln.get_xdata()) > 2]
        assert len(traces) == 1
        t = np.asarray(traces[0].get_xdata())
        assert t[0] == pytest.approx(400.0) and t[-1] == pytest.approx(400.0 + 1999 / 1000.0)
    assert "(s)" in axes[-1].get_xlabel()
    np.testing.assert_array_equal(axes[2].get_lines()[0].get_ydata(), w["fz"])


def test_forces_vs_time_long_trace_is_an_envelope_and_fx_optional():
    n = 200_001
    y = np.sin(np.arange(n) * 0.01)
    y[123_457] = 5.0  # a spike a plain stride would drop
    fig = F.forces_vs_time(None, y, y, 1000.0)
    trace = fig.axes[1].get_lines()[0]
    assert len(trace.get_ydata()) <= F.MAX_LINE_POINTS + 20
    assert np.max(trace.get_ydata()) == 5.0
    assert "not measured" in "\n".join(t.get_text() for t in fig.axes[0].texts)
    with pytest.raises(ValueError):
        F.forces_vs_time(y, y, y, 0.0)


def test_correlation_functions(window):
    res = window["result"]
    fig = F.correlation_functions(res)
    assert len(fig.axes) == 3
    for ax, pair in zip(fig.axes, ("x,y", "x,z", "y,z")):
        assert f"C_{{{pair}}}" in ax.get_ylabel()
        curve = max(ax.get_lines(), key=lambda ln: len(ln.get_xdata()))
        assert len(curve.get_xdata()) == 2 * 200 + 1
        assert np.asarray(curve.get_xdata())[-1] == pytest.approx(200.0)  # ms at 1 kHz
        assert ax.get_ylim() == pytest.approx((-1.05, 1.05))
    assert "ms" in fig.axes[-1].get_xlabel()
    assert f"{res.c_yz:+.3f}" in _texts(fig)
    # a dict of XcorrResult, with a pair missing; no fs: lags in samples
    d = {"yz": tribodyn.xcorr(window["fy"], window["fz"], max_lag=50)}
    fig2 = F.correlation_functions(d)
    assert "samples" in fig2.axes[-1].get_xlabel()
    assert "not computed" in _texts(fig2)
    # a CofResult without max_lag: notes, no crash
    plain = tribodyn.identify(window["fy"], window["fz"], fx=window["fx"], fs=1000.0)
    assert "not computed" in _texts(F.correlation_functions(plain))
    with pytest.raises(TypeError):
        F.correlation_functions(3.0)


def test_phase_plots(window):
    w, res = window, window["result"]
    fig = F.phase_plots(w["fx"], w["fy"], w["fz"], fit=res)
    assert len(fig.axes) == 3
    pairs = [(ax.get_xlabel(), ax.get_ylabel()) for ax in fig.axes]
    assert [(a[4], b[4]) for a, b in pairs] == [("x", "y"), ("x", "z"), ("z", "y")]
    for ax in fig.axes:
        assert len(ax.collections) == 1
        assert len(ax.collections[0].get_offsets()) == 2000
    line = [ln for ln in fig.axes[2].get_lines() if "mu_r" in ln.get_label()]
    assert len(line) == 1
    x, y = (np.asarray(v, dtype=float) for v in line[0].get_data())
    slope = (y[1] - y[0]) / (x[1] - x[0])
    assert slope == pytest.approx(res.orientation * res.mu_r, rel=1e-9)
    assert f"{res.mu_r:.4f}" in _texts(fig)
    # fit=None fits the data: same slope as linfit
    fig2 = F.phase_plots(w["fx"], w["fy"], w["fz"])
    x, y = (np.asarray(v, dtype=float) for v in fig2.axes[2].get_lines()[-1].get_data())
    assert (y[1] - y[0]) / (x[1] - x[0]) == pytest.approx(tribodyn.linfit(w["fz"], w["fy"]).slope, rel=1e-9)
    with pytest.raises(ValueError):
        F.phase_plots(w["fx"][:-1], w["fy"], w["fz"])


def test_phase_plots_thin_huge_input_and_fx_none():
    rng = np.random.default_rng(1)
    z = rng.normal(size=100_000)
    fig = F.phase_plots(None, 0.1 * z + 0.01 * rng.normal(size=z.size), z)
    assert len(fig.axes[2].collections[0].get_offsets()) <= F.MAX_SCATTER_POINTS
    assert "not measured" in "\n".join(t.get_text() for t in fig.axes[0].texts)


def test_cof_vs_normal_force(window):
    res = window["result"]
    fig = F.cof_vs_normal_force(res)
    (ax,) = fig.axes
    assert "F_{z,d}" in ax.get_xlabel() and "(N)" in ax.get_xlabel()
    bins = [ln for ln in ax.get_lines() if "per bin" in ln.get_label()]
    assert len(bins) == 1
    np.testing.assert_allclose(bins[0].get_xdata(), res.bins.centres)
    labels = "\n".join(_legend(ax))
    for name, v in (("mu_r", res.mu_r), ("mu_a", res.mu_a), ("mu_b", res.mu_b)):
        assert f"{v:.4f}" in labels, name
    (mu_r_line,) = [ln for ln in ax.get_lines() if "regression" in ln.get_label()]
    assert mu_r_line.get_ydata()[0] == pytest.approx(res.mu_r)
    spans = [p for p in ax.patches if "deadband" in p.get_label()]
    assert len(spans) == 1
    assert _span_x(spans[0]) == pytest.approx((-res.deadband, res.deadband))
    lo, hi = ax.get_ylim()
    assert lo < res.mu_r < hi


def test_cof_and_temperature_vs_time(results):
    fig = F.cof_and_temperature_vs_time(results, temperature_log=([0.0, 350.0, 700.0], [100.0, 150.0, 110.0]))
    assert len(fig.axes) == 2
    ax, ax2 = fig.axes
    assert ax.get_ylabel() == "COF" and "(s)" in ax.get_xlabel()
    assert "Temperature" in ax2.get_ylabel() and "°C" in ax2.get_ylabel()
    n_bad = int((~results.gated).sum())
    assert n_bad > 0
    labels = _legend(ax)
    assert f"gate failed ({n_bad} windows)" in labels
    assert any("mu_r" in s for s in labels) and any("mu_a" in s for s in labels) and any("mu_b" in s for s in labels)
    (mu,) = _labelled(ax, r"$\mu_r$")
    assert len(mu.get_xdata()) == int(results.gated.sum())
    assert any("readings" in ln.get_label() for ln in ax2.get_lines())


def test_cof_vs_temperature(results):
    opr = tribodyn.operating_range(results, by="temperature")
    fig = F.cof_vs_temperature(results, opr)
    (ax,) = fig.axes
    assert "Temperature" in ax.get_xlabel() and "°C" in ax.get_xlabel()
    labels = "\n".join(_legend(ax))
    assert "heating" in labels and "cooling" in labels and "optimum" in labels
    heat = _labelled(ax, "heating windows")
    cool = _labelled(ax, "cooling windows")
    assert heat and cool
    assert heat[0].get_color() != cool[0].get_color() and heat[0].get_marker() != cool[0].get_marker()
    (span,) = [p for p in ax.patches if "optimum" in p.get_label()]
    assert _span_x(span) == pytest.approx(opr.optimum)
    # without opr it is computed
    assert "optimum" in "\n".join(_legend(F.cof_vs_temperature(results).axes[0]))


def test_cof_and_current_density_vs_time(results):
    fig = F.cof_and_current_density_vs_time(results)
    _, ax2 = fig.axes
    assert "Current density" in ax2.get_ylabel() and "A/mm" in ax2.get_ylabel()
    j_line = [ln for ln in ax2.get_lines() if "current density" in ln.get_label()]
    assert len(j_line) == 1
    assert np.nanmax(j_line[0].get_ydata()) == pytest.approx(np.nanmax(results["J"]))


def test_cof_vs_current_density(results):
    opr = tribodyn.operating_range(results, by="current_density")
    assert opr.onset is not None
    fig = F.cof_vs_current_density(results, opr)
    (ax,) = fig.axes
    assert "A/mm" in ax.get_xlabel() and "COF" in ax.get_ylabel()
    onset = [ln for ln in ax.get_lines() if "instability onset" in ln.get_label()]
    assert len(onset) == 1 and onset[0].get_xdata()[0] == pytest.approx(opr.onset)
    assert any("optimum" in p.get_label() for p in ax.patches)
    assert any(s.startswith("gate failed") for s in _legend(ax))


def test_nan_and_empty_give_no_data_figures(nan_results, tmp_path):
    figs = [
        F.cof_vs_time(nan_results),
        F.cof_and_temperature_vs_time(nan_results),
        F.cof_vs_temperature(nan_results, None),
        F.cof_and_current_density_vs_time(nan_results),
        F.cof_vs_current_density(nan_results, None),
        F.forces_vs_time(np.full(10, np.nan), [], np.full(10, np.nan), 100.0),
        F.phase_plots(np.full(10, np.nan), np.full(10, np.nan), np.full(10, np.nan)),
        F.correlation_functions({}),
    ]
    nan_bins = tribodyn.identify(np.zeros(10), np.zeros(10), fs=100.0)  # constant fz: NaN bins
    figs.append(F.cof_vs_normal_force(nan_bins))
    for k, fig in enumerate(figs):
        assert isinstance(fig, Figure)
        text = _texts(fig)
        assert "no " in text or "not computed" in text, k
        F.save_figure(fig, tmp_path / f"f{k}.png", dpi=40)
    assert sorted(os.listdir(tmp_path)) == sorted(f"f{k}.png" for k in range(len(figs)))


# --------------------------------------------------------------------------
# saving
# --------------------------------------------------------------------------
def test_save_figure(tmp_path, window):
    fig = F.cof_vs_normal_force(window["result"])
    out = F.save_figure(fig, tmp_path / "fig9.png", dpi=50)
    assert out == str(tmp_path / "fig9.png")
    data = (tmp_path / "fig9.png").read_bytes()
    assert data.startswith(PNG_MAGIC)
    assert os.listdir(tmp_path) == ["fig9.png"]
    assert (os.stat(tmp_path / "fig9.png").st_mode & 0o777) == 0o644


def test_save_figure_is_atomic(tmp_path, monkeypatch, window):
    fig = F.cof_vs_normal_force(window["result"])

    def boom(*a, **k):
        raise RuntimeError("render failed")

    monkeypatch.setattr(fig, "savefig", boom)
    with pytest.raises(RuntimeError):
        F.save_figure(fig, tmp_path / "x.png")
    assert os.listdir(tmp_path) == []
    # an existing file is left untouched
    (tmp_path / "x.png").write_bytes(b"old")
    with pytest.raises(RuntimeError):
        F.save_figure(fig, tmp_path / "x.png")
    assert os.listdir(tmp_path) == ["x.png"] and (tmp_path / "x.png").read_bytes() == b"old"


def test_no_pyplot_no_global_state(tmp_path):
    code = textwrap.dedent(
        """
        import sys, matplotlib
        # (matplotlib.get_backend() and rcParams["backend"] would import pyplot
        # to resolve the default backend: compare the raw values instead.)
        rc = matplotlib.rcParams.copy()
        import numpy as np
        from tribodyn.app import figures as F
        x = np.sin(np.arange(500) * 0.1)
        fig = F.phase_plots(x, x, x)
        F.forces_vs_time(x, x, x, 100.0)
        F.save_figure(fig, sys.argv[1])
        assert "matplotlib.pyplot" not in sys.modules
        assert matplotlib.rcParams.copy() == rc
        assert type(fig.canvas).__name__ == "FigureCanvasAgg"
        """
    )
    subprocess.run([sys.executable, "-c", code, str(tmp_path / "f.png")], check=True, timeout=60)
    assert (tmp_path / "f.png").read_bytes().startswith(PNG_MAGIC)


# --------------------------------------------------------------------------
# report
# --------------------------------------------------------------------------
def _small_figs(window):
    return [
        ("Phase plots (Figs. 6-8)", F.phase_plots(window["fx"], window["fy"], window["fz"], fit=window["result"])),
        ("COF vs F_z,d <Fig. 9> & more", F.cof_vs_normal_force(window["result"])),
    ]


def test_write_report(tmp_path, results, window):
    figs = _small_figs(window)
    summary = results.summary()
    target = tmp_path / "report.html"
    out = R.write_report(target, title="Test <report>", summary=summary, params=results.params, figures=figs, dpi=40)
    assert out == str(target)
    html = target.read_text(encoding="utf-8")
    assert html.count(IMG) == len(figs) == 2
    assert "http://" not in html and "https://" not in html
    assert "<script" not in html.lower() and "<link" not in html.lower()
    assert html.count('src="') == html.count('src="data:image/png;base64,')
    assert "Test &lt;report&gt;" in html and "COF vs F_z,d &lt;Fig. 9&gt; &amp; more" in html
    # the summary numbers
    for col in ("mu_r", "mu_a", "mu_b"):
        for stat in ("mean", "median", "p05", "p95"):
            assert R._fmt(summary[col][stat]) in html, (col, stat)
    assert f"<td>{summary['windows']}</td>" in html and f"<td>{summary['gated']}</td>" in html
    assert R._fmt(summary["gate_pass_fraction"]) in html
    for reason, count in summary["gate_failures"].items():
        assert reason in html and f"<td>{count}</td>" in html
    assert "window_samples" in html  # parameters
    # the embedded images decode to PNG
    start = html.index(IMG) + len(IMG)
    assert base64.b64decode(html[start : html.index('"', start)]).startswith(PNG_MAGIC)
    assert os.listdir(tmp_path) == ["report.html"]


def test_write_report_dict_figures_and_tables(tmp_path, window):
    figs = dict(_small_figs(window))
    table = {"a": np.arange(5), "b": np.linspace(0, 1, 5)}
    R.write_report(
        tmp_path / "r.html",
        title="t",
        summary={"mu_r": {"n": 1, "median": 0.1234}},
        params={"fs": 1000.0},
        figures=figs,
        tables={"My table": table},
        dpi=40,
        max_table_rows=3,
        quality={"gate_pass_fraction": 0.5, "gate_failures": {"low correlation": 7}},
    )
    html = (tmp_path / "r.html").read_text(encoding="utf-8")
    assert html.count(IMG) == 2
    assert "0.1234" in html and "My table" in html and "First 3 of 5 rows" in html
    assert "low correlation" in html and "<td>7</td>" in html and "50.0 %" in html
    with pytest.raises(TypeError):
        R.write_report(tmp_path / "bad.html", title="t", summary={}, params={}, figures=[("only caption",)])
    assert not (tmp_path / "bad.html").exists()


def test_write_report_is_atomic(tmp_path, monkeypatch, window):
    figs = _small_figs(window)

    def boom(*a, **k):
        raise RuntimeError("render failed")

    monkeypatch.setattr(figs[1][1], "savefig", boom)
    target = tmp_path / "report.html"
    with pytest.raises(RuntimeError):
        R.write_report(target, title="t", summary={}, params={}, figures=figs, dpi=40)
    assert not target.exists()
    assert os.listdir(tmp_path) == []
    # the write itself failing: nothing partial, an old report untouched
    target.write_text("old")
    from tribodyn.io import writers

    with monkeypatch.context() as m:
        m.setattr(writers.os, "replace", boom)  # the final rename fails
        with pytest.raises(RuntimeError):
            R.write_report(target, title="t", summary={}, params={}, figures=figs[:1], dpi=40)
    assert os.listdir(tmp_path) == ["report.html"] and target.read_text() == "old"


def test_build_report_figures_and_full_report(tmp_path, results, window):
    figs = R.build_report_figures(results, example=window)
    captions = [c for c, _ in figs]
    assert all(isinstance(f, Figure) for _, f in figs)
    assert len(figs) == 4 + 2 + 2
    for ref in ("Fig. 2", "Figs. 3-5", "Figs. 6-8", "Fig. 9", "Fig. 10", "Fig. 11", "Fig. 12", "Sec. 4.2"):
        assert any(ref in c for c in captions), ref
    # without covariates: COF vs time only
    plain = tribodyn.analyze(
        {k: v for k, v in window.items() if k in ("fx", "fy", "fz")}, fs=1000.0, window=0.5, hop=0.5
    )
    only = R.build_report_figures(plain)
    assert len(only) == 1 and "COF against time" in only[0][0]
    # example without a CofResult: computed, with correlations
    ex = {k: window[k] for k in ("fx", "fy", "fz", "fs")}
    assert len(R.build_report_figures(plain, example=ex)) == 5

    summary = R.build_report_summary(results)
    assert set(summary["operating_ranges"]) == {"temperature", "current_density"}
    path = R.write_results_report(tmp_path / "report.html", results, example=window, dpi=30)
    with open(path, encoding="utf-8") as fh:
        html = fh.read()
    assert html.count(IMG) == 8
    assert "http://" not in html and "https://" not in html
    opt = summary["operating_ranges"]["current_density"]["optimum"]
    assert R._fmt(opt) in html
    assert "Per-window results" in html and "median |C_yz(0)|" in html
    assert os.listdir(tmp_path) == ["report.html"]


def _long_results(n: int, seed: int = 0) -> tribodyn.Results:
    """A synthetic analysis of ``n`` windows (10 s apart): a slow COF drift with noise, a heating ramp,
    5 % of the windows failing the gate."""
    rng = np.random.default_rng(seed)
    t = 1.0 + 10.0 * np.arange(n)
    mu = 0.12 + 0.02 * np.sin(t / t[-1] * 6.0) + rng.normal(0.0, 0.004, n)
    table = {c: np.full(n, np.nan) for c in tribodyn.WINDOW_COLUMNS}
    ok = rng.random(n) > 0.05
    table.update(
        time=t,
        mu_r=mu,
        mu_r_low=mu - 0.002,
        mu_r_high=mu + 0.002,
        mu_a=mu + rng.normal(0.0, 0.002, n),
        mu_b=mu + rng.normal(0.0, 0.002, n),
        c_yz=np.where(ok, -0.97, -0.5),
        T=np.interp(t, [t[0], t[-1]], [100.0, 175.0]),
        ok=ok,
        reasons=np.where(ok, "", "low correlation: |C_yz(0)| = 0.500 < 0.85"),
        branch=np.ones(n, dtype=np.int8),
    )
    return tribodyn.Results(
        table=table,
        bin_counts=np.zeros((n, 4), dtype=np.int64),
        bin_cof=np.full((n, 4), np.nan),
        fz_min=np.full(n, np.nan),
        fz_max=np.full(n, np.nan),
        orientation=-1,
        params={"fs": 1000.0, "window": 2.0, "hop": 10.0},
    )


def test_cof_vs_time_of_20000_windows_renders_fast_with_the_rolling_band():
    """The report's COF-against-time figure of a 20,000-window recording: built and rendered to the report's
    PNG in well under the issue's 5 s (asserted generously; the measured time is printed), legible: a running
    median with its 5-95 % band, the failed windows in the strip at the top, never at COF = 0."""
    import time

    res = _long_results(20_000)
    start = time.perf_counter()
    fig = F.cof_and_temperature_vs_time(res)
    png = R._png_base64(fig, R.REPORT_DPI)
    elapsed = time.perf_counter() - start
    print(f"COF-vs-time figure of 20,000 windows: {elapsed:.2f} s (target < 5 s)")
    assert elapsed < 20.0
    assert base64.b64decode(png).startswith(PNG_MAGIC)
    ax = fig.axes[0]
    labels = [str(a.get_label()) for a in (*ax.collections, *ax.lines)]
    assert any("5-95 %" in s and "running" in s for s in labels), labels
    median = [ln for ln in ax.lines if str(ln.get_label()).startswith("running median of")]
    assert median and len(median[0].get_xdata()) <= F.BAND_BLOCKS  # a line of block medians, not 20,000 points
    failed = [ln for ln in ax.lines if str(ln.get_label()).startswith("gate failed")]
    assert failed and int(np.sum(~res.table["ok"])) == len(failed[0].get_xdata())
    # Failed windows sit in the strip at the top (axes coordinates), not at a COF value such as 0.
    assert np.all(np.asarray(failed[0].get_ydata()) > 1.0 - F.FAILED_STRIP)
    assert failed[0].get_transform() != ax.transData


def test_rendering_draws_here_and_runs_also_once():
    """figures.Rendering draws every figure in this process (no forked child that could deadlock on a
    threaded parent or outlive a killed command line) and runs ``also`` once."""
    from matplotlib.figure import Figure
    from tribodyn.app import figures

    def fig(k):
        f = Figure(figsize=(2, 2))
        f.add_subplot().plot([0, k], [1, 0])
        return f

    calls = []

    def also():
        calls.append(os.getpid())
        return {"pid": os.getpid(), "html": "<div>x</div>"}

    render = figures.Rendering([fig(k) for k in range(3)], also=also)
    forks = []
    if hasattr(os, "register_at_fork"):
        os.register_at_fork(before=lambda: forks.append(1))
    got = render.finish()
    assert got == [figures.png_bytes(fig(k)) for k in range(3)]
    extra = render.also_result()
    assert extra["html"] == "<div>x</div>" and render.also_result() is extra
    assert calls == [os.getpid()] and forks == []


def test_fig11_shows_log_gap_windows_apart_and_no_solid_fit_without_windows(temp_res):
    """Windows whose T is interpolated across a log gap are left out of the operating range's fit; the figure
    draws them apart (hollow, "not fitted") and draws a fit solid only near the windows it used."""
    from tribodyn.app import figures as F

    table = temp_res.table
    gap = np.asarray(table["T_gap"], dtype=bool) & np.asarray(table["ok"], dtype=bool)
    assert gap.any(), "the simulated temperature test has a fast log gap"
    fig = F.cof_vs_temperature(temp_res)
    ax = fig.axes[0]
    labels = {str(ln.get_label()): ln for ln in ax.lines}
    hollow = [ln for k, ln in labels.items() if k.startswith("windows in a log gap")]
    assert hollow and len(hollow[0].get_xdata()) == int(gap.sum())
    scattered = sum(len(ln.get_xdata()) for k, ln in labels.items() if k.startswith(("heating windows",
                    "cooling windows", "windows, dT/dt unknown")))  # fmt: skip
    assert scattered == int((np.asarray(table["ok"], dtype=bool) & np.isfinite(table["T"]) & ~gap).sum())
    used = np.asarray(table["T"])[np.asarray(table["ok"], dtype=bool) & ~gap]
    width = tribodyn.operating_range(temp_res, "temperature").bin_width
    for ln in ax.lines:
        if "bathtub fit" in str(ln.get_label()):
            x, y = np.asarray(ln.get_xdata(), float), np.asarray(ln.get_ydata(), float)
            solid = x[np.isfinite(y)]
            # every solid point lies within a bin width of a window the fit used
            assert np.all(np.min(np.abs(solid[:, None] - used[None, :]), axis=1) <= width + 1e-9)


def test_an_exports_report_leads_with_its_cof_and_the_diagnostics_follow(results, window):
    # issue 34 point 9: where the dynamic method gives no headline, COF against time comes first
    ex = {k: window[k] for k in ("fx", "fy", "fz", "fs")}
    rng = np.random.default_rng(0)
    fz = 10.0 + 0.01 * rng.standard_normal(6000)  # a dead weight: the classical COF is the headline
    dead = tribodyn.analyze({"fy": 0.2 * fz, "fz": fz}, fs=100.0)
    assert dead.headline.method == "classical"
    names = [n for n, _, _ in R.build_named_figures(dead, examples=[{**ex, "tag": "worst"}])]
    assert names[0] == "cof_vs_time" and names[1].startswith("fig02_forces")
    assert results.headline.method == "dynamic"  # the paper's test: its diagnostics lead
    names = [n for n, _, _ in R.build_named_figures(results, examples=[{**ex, "tag": "worst"}])]
    assert names[0].startswith("fig02_forces") and names[4] == "fig10_cof_temperature_vs_time"
