"""Any covariate and Stribeck curves (docs/method.md 7a): the speed column, covariate logs,
``operating_range(res, by=...)`` against the simulator's known Stribeck curve, the figure and the CLI."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
import tribodyn as td
from tribodyn import simulate
from tribodyn.app import figures
from tribodyn.app.cli import main
from tribodyn.columns import UNITS
from tribodyn.io import open_recording

WINDOW = dict(window=5.0, hop=5.0)


@pytest.fixture(scope="module")
def sweep():
    return simulate.stribeck_sweep(seed=3)


@pytest.fixture(scope="module")
def res(sweep):
    return td.analyze(sweep.channels, fs=sweep.fs, **WINDOW)


@pytest.fixture(scope="module")
def opr(res):
    return td.operating_range(res, by="speed")


# -- the simulator ---------------------------------------------------------------------------


def test_model_minimum_and_regimes():
    m = simulate.StribeckModel()
    v = np.geomspace(1e-4, 10.0, 400_001)
    mu = m.mu(v)
    assert m.v_min == pytest.approx(v[np.argmin(mu)], rel=1e-4)
    assert m.mu_min == pytest.approx(mu.min(), abs=1e-12)
    assert float(m.mu(0.0)) == m.mu_s and float(m.mu(-0.5)) == float(m.mu(0.5))
    drop = (m.mu_s - float(m.mu(m.v_boundary)) + m.k * m.v_boundary) / (m.mu_s - m.mu_c)
    assert drop == pytest.approx(0.1, rel=1e-9)
    assert math.isinf(simulate.StribeckModel(k=0.0).v_min)
    assert simulate.StribeckModel(k=100.0).v_min == 0.0  # the viscous rise outweighs the fall: minimum at rest


def test_sweep_is_the_documented_test(sweep):
    ch = sweep.channels
    assert set(ch) == {"fy", "fz", "v"} and len({len(a) for a in ch.values()}) == 1 and len(ch["fz"]) == 60_000
    t = np.arange(len(ch["fz"])) / sweep.fs
    lo, hi = sweep.params["speeds"]
    set_speed = lo * (hi / lo) ** (t / sweep.params["duration"])
    np.testing.assert_allclose(sweep.speed_at(t), set_speed, rtol=2e-3)  # a log ramp over three decades
    assert np.std(ch["v"] / set_speed - 1) == pytest.approx(sweep.params["speed_noise"], rel=0.05)
    cof = ch["fy"] / sweep.normal_force
    np.testing.assert_allclose(cof.mean(), sweep.model.mu(set_speed).mean(), atol=2e-3)
    np.testing.assert_allclose(sweep.mu_at(sweep.t), sweep.model.mu(sweep.speed_at(sweep.t)), rtol=1e-12)
    np.testing.assert_allclose(sweep.mu_at(t), sweep.model.mu(sweep.speed_at(t)), rtol=1e-6)  # 0.1 s grid
    assert np.std(ch["fz"]) == pytest.approx(sweep.params["noise"], rel=0.05)  # a dead weight
    again = simulate.stribeck_sweep(seed=3)
    np.testing.assert_array_equal(again.channels["fy"], ch["fy"])
    steps = simulate.stribeck_sweep(seed=3, steps=7, duration=70.0)
    assert len(np.unique(steps.speed_at(np.arange(0, 70.0, 0.5)))) == 7


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(speeds=(1.0, 0.1)), "speeds"),
        (dict(speeds=(0.0, 1.0)), "speeds"),
        (dict(steps=1), "steps"),
        (dict(steps=2.5), "steps"),
        (dict(normal_force=-1.0), "normal_force"),
        (dict(noise=-0.1), "noise"),
        (dict(fs=float("nan")), "fs"),
        (dict(model=simulate.StribeckModel(mu_s=0.05, mu_c=0.1)), "mu_s >= mu_c"),
    ],
)
def test_sweep_refuses_bad_settings(kw, match):
    with pytest.raises(ValueError, match=match):
        simulate.stribeck_sweep(**kw)


# -- the speed column and covariate logs ------------------------------------------------------


def test_speed_column_is_the_mean_abs_velocity_per_window(sweep, res):
    assert UNITS["speed"] == "m/s"
    v = sweep.channels["v"]
    n = int(res["n"][0])
    starts = np.round(np.asarray(res["t_start"]) * sweep.fs).astype(int)
    want = np.array([np.abs(v[s : s + n]).mean() for s in starts])
    np.testing.assert_array_equal(res["speed"], want)
    # any cut into chunks gives the same bits
    cuts = [0, 1, 777, 12_345, 30_001, 60_000]
    chunks = ({k: a[c0:c1] for k, a in sweep.channels.items()} for c0, c1 in zip(cuts[:-1], cuts[1:]))
    np.testing.assert_array_equal(td.analyze(chunks, fs=sweep.fs, **WINDOW)["speed"], res["speed"])


def test_speed_from_a_file_and_of_reciprocating_strokes(sweep, res, tmp_path):
    path = tmp_path / "sweep.npy"
    np.save(path, np.stack([sweep.channels[r] for r in ("fy", "fz", "v")]))
    with open_recording(path, fs=sweep.fs, names=["fy", "fz", "velocity"]) as rec:
        got = td.analyze(rec, **WINDOW)
    assert got.params["route"] != "mapped"  # the kernel reads forces and one auxiliary channel only
    np.testing.assert_array_equal(got["speed"], res["speed"])
    rc = simulate.reciprocating(cycles=10, stroke_length=0.01, frequency=2.0)
    r = td.analyze(rc.channels, fs=rc.fs)
    starts = np.round(np.asarray(r["t_start"]) * rc.fs).astype(int)
    want = [np.abs(rc.channels["v"][s : s + n]).mean() for s, n in zip(starts, r["n"])]
    np.testing.assert_allclose(r["speed"], want, rtol=1e-12)
    # the central half of each whole stroke: mean |cos| over [-pi/4, pi/4] = sin(pi/4) / (pi/4) of the peak speed
    peak = 0.5 * 0.01 * 2 * np.pi * 2.0
    np.testing.assert_allclose(np.asarray(r["speed"])[1:-1], peak * np.sin(np.pi / 4) / (np.pi / 4), rtol=0.01)


def test_covariate_logs(sweep, res):
    forces = {k: v for k, v in sweep.channels.items() if k != "v"}
    t, v = sweep.speed_log
    humid = (np.array([0.0, 600.0]), np.array([40.0, 52.0]))
    got = td.analyze(forces, fs=sweep.fs, covariates={"speed": (t, -v), "humidity": humid}, **WINDOW)
    # its magnitude's mean over each window, as the COF is a mean over the window's samples (issue 35 point 7):
    # the midpoint rule on 8 points per sample of the interpolated log, within the log (its part past the log's
    # last reading is unknown: left out)
    grid = [a + (np.arange(8 * m) + 0.5) / (8 * sweep.fs) for a, m in zip(got["t_start"], got["n"])]
    grid = [g[g <= t[-1]] for g in grid]
    np.testing.assert_allclose(got["speed"], [np.mean(np.interp(g, t, v)) for g in grid], rtol=1e-6)
    assert np.max(np.abs(got["speed"] / np.interp(got["time"], t, v) - 1)) > 1e-3  # not the value at the centre
    assert got.columns[-1] == "humidity" and list(got.columns[:-1]) == list(td.WINDOW_COLUMNS)
    np.testing.assert_allclose(got["humidity"], 40.0 + 12.0 * np.asarray(got["time"]) / 600.0)
    assert got.params["covariate_logs"] == {"speed": len(t), "humidity": 2}
    assert "humidity" in got.to_pandas().columns
    both = td.analyze(sweep.channels, fs=sweep.fs, covariates={"speed": 0.2}, **WINDOW)
    assert np.all(both["speed"] == 0.2)
    assert any("replaces the mean |v|" in w for w in both.warnings)
    assert not any("replaces" in w for w in res.warnings)


@pytest.mark.parametrize(
    "logs, match",
    [
        ({"temperature": (np.array([0.0, 1.0]), np.array([1.0, 2.0]))}, "temperature="),
        ({"mu_r": 0.1}, "column of the table"),
        ({"2x": 0.1}, "identifier"),
        ({"speed": None}, "is None"),
        ({"speed": (np.array([1.0, 0.0]), np.array([1.0, 2.0]))}, "increasing"),
        ([("speed", 0.1)], "mapping"),
    ],
)
def test_covariate_logs_refused(sweep, logs, match):
    with pytest.raises((ValueError, TypeError), match=match):
        td.analyze(sweep.channels, fs=sweep.fs, covariates=logs, **WINDOW)


# -- operating_range against the simulator's truth ---------------------------------------------


def _noise_free(res, sweep, by="speed"):
    """The same fit of the model's COF at the same windows: the straight-wall breakpoints of the true curve."""
    table = dict(res.table)
    table["mu_classical"] = sweep.mu_at(res["time"])
    return td.operating_range(dataclasses.replace(res, table=table), by, n_boot=0, cof="classical").fits["all"]


def test_stribeck_minimum_and_breakpoints_against_the_truth(sweep, res, opr):
    assert res.headline.method == "classical" and opr.cof == "classical"  # a dead weight: the classical COF
    assert opr.by == "speed" and opr.unit == "m/s" and opr.log and opr.column == "speed"
    assert opr.verdict == "optimum" and opr.n_windows == len(res)
    lo, hi = opr.optimum
    # A smooth minimum has no flat floor: curved walls leave the floor next to it (straight walls, meeting the
    # floor far out, made a bottom wide enough to hold it); the ends' intervals hold it.
    assert lo <= 1.1 * sweep.model.v_min < hi
    assert opr.optimum_ci[0][0] <= sweep.model.v_min <= opr.optimum_ci[1][1]
    truth = _noise_free(res, sweep)
    f = opr.fits["all"]
    assert f.lower_ci[0] <= truth.lower <= f.lower_ci[1] and f.upper_ci[0] <= truth.upper <= f.upper_ci[1]
    assert abs(math.log10(f.lower / truth.lower)) < 0.1 and abs(math.log10(f.upper / truth.upper)) < 0.2
    assert opr.mu_min == pytest.approx(sweep.model.mu_min, abs=0.005)
    assert f.mu_min_ci[0] <= f.mu_min <= f.mu_min_ci[1]  # resamples refit both walls as a pair (b_lo <= b_hi)
    assert f.grid[0] == pytest.approx(res["speed"].min()) and f.x_range[1] == pytest.approx(res["speed"].max())
    d = opr.to_dict()
    assert d["scale"] == "log" and d["cof"] == "classical" and json.dumps(d, default=str)


def test_stribeck_steps_and_a_linear_axis(sweep):
    st = simulate.stribeck_sweep(seed=5, steps=12)
    r = td.analyze(st.channels, fs=st.fs, **WINDOW)
    o = td.operating_range(r, "v", n_boot=100)  # the role's name
    # between speed steps the data cannot place the breakpoints: the minimum lies within their intervals
    assert o.by == "speed" and o.verdict == "optimum" and o.optimum_ci[0][0] <= st.model.v_min <= o.optimum_ci[1][1]
    lin = td.operating_range(r, "speed", log=False, n_boot=0)
    assert not lin.log and lin.fits["all"].grid[1] - lin.fits["all"].grid[0] == pytest.approx(
        lin.fits["all"].grid[-1] - lin.fits["all"].grid[-2]
    )
    binned = td.operating_range(r, "speed", method="binned")
    c = binned.curves["all"]
    assert np.all(np.diff(c.edges) > 0) and c.edges[0] > 0 and binned.optimum[0] <= st.model.v_min * 1.8
    assert np.allclose(np.diff(np.log10(c.edges)), binned.bin_width)  # bins of 0.25 decades


def test_load_and_other_covariates():
    # COF against a stepped dead weight: lowest between 20 and 40 N (fz negative: a sensor mounted upside down)
    rng = np.random.default_rng(1)
    fs, n = 100.0, 60_000
    w = np.repeat(np.linspace(5.0, 60.0, 12), n // 12)
    mu = 0.1 + 0.004 * np.maximum(20.0 - w, 0) + 0.003 * np.maximum(w - 40.0, 0)
    data = {"fy": mu * w + 0.02 * rng.standard_normal(n), "fz": -w + 0.02 * rng.standard_normal(n)}
    r = td.analyze(data, fs=fs, **WINDOW)
    o = td.operating_range(r, "load", n_boot=200)
    assert o.by == "load" and o.unit == "N" and o.column == "fz_mean" and not o.log
    assert o.verdict == "optimum" and 10 < o.optimum[0] <= 20.5 and 39.5 <= o.optimum[1] < 50
    signed = td.operating_range(r, "fz_mean", n_boot=0)  # the column as it is
    assert signed.by == "fz_mean" and signed.optimum[1] < 0
    r2 = td.analyze(data, fs=fs, covariates={"load": (np.array([0.0, 600.0]), np.array([5.0, 60.0]))}, **WINDOW)
    assert td.operating_range(r2, "load", n_boot=0).column == "load"  # a log of that name comes first


def test_by_errors(res):
    with pytest.raises(ValueError, match="by must be temperature, current_density, current, speed, load"):
        td.operating_range(res, "humidity")
    with pytest.raises(ValueError, match="numeric column"):
        td.operating_range(res, "reasons")
    with pytest.raises(ValueError, match=r"no window has a temperature \(did analyze get a temperature log\?\)"):
        td.operating_range(res, "temperature")
    with pytest.raises(ValueError, match="cof must be"):
        td.operating_range(res, "speed", cof="mean")
    with pytest.raises(ValueError, match="branch applies to by='temperature' only"):
        td.operating_range(res, "speed", branch="heating")
    with pytest.raises(TypeError, match="log must be"):
        td.operating_range(res, "speed", log="yes")
    with pytest.raises(ValueError, match="no quality-gated window has a speed.*cof='classical'"):
        td.operating_range(res, "speed", cof="dynamic")  # no window passes the dynamic method's gate


def test_log_axis_leaves_out_windows_at_rest(res):
    table = dict(res.table)
    speed = np.array(res["speed"])
    speed[:4] = 0.0
    table["speed"] = speed
    o = td.operating_range(dataclasses.replace(res, table=table), "speed", n_boot=0)
    assert o.excluded == {"covariate <= 0 (log axis)": 4} and o.n_windows == len(res) - 4


# -- figure, report, command line ---------------------------------------------------------------


def test_stribeck_figure(res, opr):
    fig = figures.stribeck_curve(res, opr)
    ax = fig.axes[0]
    assert ax.get_xscale() == "log"
    labels = ax.get_legend_handles_labels()[1]
    for name, _what, _colour in figures.STRIBECK_REGIMES:
        assert any(lab.startswith(name) for lab in labels), name
    assert any("lower breakpoint" in lab for lab in labels) and any("windows (120)" in lab for lab in labels)
    none = figures.stribeck_curve(td.analyze({"fy": res["mu_r"], "fz": res["fz_mean"]}, fs=1.0, window=3, hop=3))
    assert "no Stribeck curve" in none.axes[0].texts[0].get_text()


def test_report_has_the_stribeck_curve(res, opr):
    from tribodyn.app.report import build_named_figures

    names = [name for name, _cap, _fig in build_named_figures(res, opr_speed=opr)]
    assert "stribeck_curve" in names


def test_cli_covariate(sweep, tmp_path, capsys):
    t = np.arange(len(sweep.channels["fz"])) / sweep.fs
    rec = tmp_path / "sweep.csv"
    np.savetxt(rec, np.column_stack([t, sweep.channels["fy"], sweep.channels["fz"]]), delimiter=",",
               header="time,friction force,normal force", comments="", fmt="%.7g")  # fmt: skip
    log = tmp_path / "speed.csv"
    np.savetxt(log, np.column_stack(sweep.speed_log), delimiter=",", header="t,speed", comments="", fmt="%.7g")
    out = tmp_path / "out"
    assert main(["analyze", str(rec), "--covariate", f"speed={log}", "--window", "5", "--hop", "5",
                 "--out", str(out)]) == 0  # fmt: skip
    assert "optimum speed:" in capsys.readouterr().out
    s = json.loads((out / "summary.json").read_text())
    rng = next(iter(s["recordings"].values()))["operating_range_speed"]
    assert rng["verdict"] == "optimum" and rng["optimum"][0] <= 1.1 * sweep.model.v_min < rng["optimum"][1]
    assert rng["optimum_ci"][0][0] <= sweep.model.v_min <= rng["optimum_ci"][1][1]
    assert (out / "figures" / "stribeck_curve.png").is_file()
    assert "speed: speed.csv" in (out / "report.html").read_text()
    cfg = tmp_path / "c.toml"
    cfg.write_text(f'window = 5.0\nhop = 5.0\n[covariates]\nspeed = "{log}"\n')
    assert main(["analyze", str(rec), "--config", str(cfg), "--out", str(tmp_path / "out2"), "-q"]) == 0
    assert np.isfinite(json.loads((tmp_path / "out2" / "summary.json").read_text())["recordings"]["sweep.csv"]
                       ["operating_range_speed"]["mu_min"])  # fmt: skip


@pytest.mark.parametrize(
    "arg, match",
    [
        ("speed", "takes NAME=FILE"),
        ("speed=missing.csv", "log file not found"),
        ("temperature=x.csv", "--temperature FILE"),
        ("current=x.csv", "--map i=CHANNEL"),
        ("1a=x.csv", "letters, digits"),
    ],
)
def test_cli_covariate_errors(tmp_path, capsys, arg, match):
    rec = tmp_path / "r.csv"
    rec.write_text("time,friction force,normal force\n0,1,10\n0.01,1,10\n")
    assert main(["analyze", str(rec), "--covariate", arg, "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert match in err and err.count("\n") == 1 and "Traceback" not in err
