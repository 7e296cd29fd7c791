"""Reciprocating tests beyond the per-stroke table (issue 14): the strokes figure and report,
direction-rectified regression (docs/method.md 6c) and analyze_many's tribometer params."""

from __future__ import annotations

import numpy as np
import pytest
import tribodyn as td
from tribodyn import simulate
from tribodyn.app import figures as F
from _paths import TESTS


def test_strokes_figure_markers_per_direction_and_instrument():
    sim = simulate.reciprocating(seed=4, cycles=8)
    ch = dict(sim.channels)
    ch["cof"] = np.abs(ch["fy"]) / ch["fz"]
    res = td.analyze(ch, fs=sim.fs)
    assert res.strokes is not None
    fig = F.strokes_vs_cycle(res)
    ax = fig.axes[0]
    labels = [ln.get_label() for ln in ax.get_lines()]
    assert "forward strokes (+1)" in labels and "backward strokes (-1)" in labels
    assert any(lb.startswith("instrument COF") for lb in labels)
    assert ax.get_xlabel().startswith("cycle")
    fwd = next(ln for ln in ax.get_lines() if ln.get_label() == "forward strokes (+1)")
    assert len(fwd.get_xdata()) == int(np.sum((res.strokes["direction"] == 1) & np.isfinite(res.strokes["mu"])))
    assert "no strokes" in F.strokes_vs_cycle({"mu": np.zeros(0)}).axes[0].texts[0].get_text()


def test_cli_writes_the_strokes_figure_and_the_report_shows_it(tmp_path):
    from tribodyn.app.cli import main
    from tribodyn.io import save_npz

    sim = simulate.reciprocating(seed=2, cycles=6)
    p = tmp_path / "recip.npz"
    save_npz(p, sim.channels, sim.fs)
    out = tmp_path / "out"
    assert main(["analyze", str(p), "--out", str(out), "-q"]) == 0
    png = out / "figures" / "strokes_cof_vs_cycle.png"
    assert png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    html = (out / "report.html").read_text()
    assert "per-stroke classical COF" in html and "[strokes_cof_vs_cycle.png]" in html
    # a unidirectional test has no strokes figure
    uni = simulate.reciprocating(seed=2, cycles=6)
    save_npz(tmp_path / "uni.npz", {"fy": np.abs(uni.channels["fy"]), "fz": uni.channels["fz"]}, uni.fs)
    assert main(["analyze", str(tmp_path / "uni.npz"), "--out", str(tmp_path / "u"), "-q"]) == 0
    assert not (tmp_path / "u" / "figures" / "strokes_cof_vs_cycle.png").exists()


@pytest.mark.parametrize("roles", [("fy", "fz", "v"), ("fy", "fz", "x"), ("fy", "fz")])
def test_rectified_regression_gives_the_simulated_cof_per_direction(roles):
    sim = simulate.reciprocating(seed=7, mu_forward=0.12, mu_backward=0.09, fz_dynamic=1.0)
    res = td.analyze({k: sim.channels[k] for k in roles}, fs=sim.fs)
    assert res.params["motion"] == "reciprocating" and res.params["rectified"]
    assert res.params["route"] == "acquisitions"
    t = res.table
    direction = res.strokes["direction"][t["acquisition"]]  # acquisition = stroke index
    ok = t["ok"]
    assert ok.mean() > 0.8
    assert abs(np.median(t["mu_r"][ok & (direction == 1)]) / 0.12 - 1) < 0.02
    assert abs(np.median(t["mu_r"][ok & (direction == -1)]) / 0.09 - 1) < 0.02
    # every window lies inside its stroke's central half
    for k, t0, n in zip(t["acquisition"], t["t_start"], t["n"]):
        s0 = res.strokes["t_start"][k]
        assert s0 <= t0 and t0 + n / sim.fs <= s0 + res.strokes["duration"][k] + 1e-9


def test_rectified_mu_r_is_the_headline_of_a_reciprocating_test_with_dynamic_load(tmp_path):
    from tribodyn.io import save_npz

    sim = simulate.reciprocating(seed=3, mu_forward=0.11, mu_backward=0.11, fz_dynamic=1.0)
    unrectified = td.analyze(sim.channels, fs=sim.fs, motion="unidirectional", window=0.125, hop=0.125)
    assert not abs(np.nanmedian(unrectified["mu_r"]) / 0.11 - 1) < 0.2  # what the sign flips do to it
    p = tmp_path / "recip.npz"
    save_npz(p, sim.channels, sim.fs)
    for source in (sim.channels, td.open_recording(p)):
        v = td.analyze(source, fs=sim.fs).summary()["verdict"]
        assert v["dynamic_method"] and v["motion"] == "reciprocating", v
        assert v["cof"]["method"] == "dynamic" and "direction-rectified" in v["cof"]["estimate"]
        assert abs(v["cof"]["value"] / 0.11 - 1) < 0.02


def test_window_across_an_undetected_reversal_fails():
    sim = simulate.reciprocating(seed=5, cycles=4, fz_dynamic=1.0)
    ch = dict(sim.channels)
    v = ch["v"].copy()
    # a short back-motion (20 % of the peak speed: under the 30 % hysteresis) in the middle of stroke 3
    vmax = np.abs(v).max()
    mid = int(round(0.25 * 3.5 * sim.fs / 2 + 0.5 * 0.25 * sim.fs))  # centre of the fourth stroke
    k = mid + np.arange(-5, 5)
    v[k] = -np.sign(v[mid]) * 0.2 * vmax
    ch["v"] = v
    res = td.analyze(ch, fs=sim.fs)
    t = res.table
    bad = np.array(["stroke reversal in the window" in r for r in t["reasons"]])
    assert bad.sum() == 1 and not t["ok"][bad].any()
    k_bad = int(t["acquisition"][bad][0])
    s0, dur = res.strokes["t_start"][k_bad], res.strokes["duration"][k_bad]
    assert s0 < mid / sim.fs < s0 + dur


def _cetr_like(path, sim, every=5):
    """A CETR UMT-like text export: preamble, names row, units row, Fx (signed friction), Fz, time, COF."""
    fy, fz = sim.channels["fy"][::every], sim.channels["fz"][::every]
    t = np.arange(fy.size) * every / sim.fs
    lines = ["Created by CETR Data Viewer ver.2.19.106", "Total number of steps = 1", "", "Step No. 1",
             "Velocity     = 240", "Data Count   = %d" % fy.size, "", "Fx,Fz,T,COF", "g,g,sec,", ""]  # fmt: skip
    lines += [f"{a:.6f},{b:.6f},{c:.4f},{abs(a) / b:.6f}" for a, b, c in zip(fy, fz, t)]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("dynamic", [0.0, 1.0])
def test_analyze_many_keeps_the_tribometer_params_and_verdict(tmp_path, dynamic):
    from tribodyn.pipeline.distributed import analyze_many

    sim = simulate.reciprocating(seed=11, cycles=10, frequency=0.5, fz_dynamic=dynamic)
    p = _cetr_like(tmp_path / "cetr_like.csv", sim, every=20)  # 50 Hz, as CETR UMT files: a window note
    opts = {"channels": {"fy": "Fx", "fz": "Fz", "cof": "COF"}}
    one = td.analyze(td.open_recording(p, **opts))
    many = analyze_many([p], open_options=opts)
    assert not many.failures
    res = many.results[str(p)]
    assert res.summary()["verdict"] == one.summary()["verdict"]
    assert res.summary()["verdict"]["motion"] == "reciprocating"
    for key in ("motion", "motion_detected", "roles", "roles_source", "window_note", "min_fn", "static_fz",
                "stroke_fraction", "rectified"):  # fmt: skip
        assert res.params.get(key) == one.params.get(key), key
    assert res.params["rectified"] and one.params.get("window_note")
    assert res.strokes is not None and set(res.strokes) == set(one.strokes)
    for k in one.strokes:
        np.testing.assert_array_equal(res.strokes[k], one.strokes[k])
    np.testing.assert_array_equal(res["mu_r"], one["mu_r"])
    assert one.warnings and set(one.warnings) <= set(res.warnings)


def test_analyze_many_split_reciprocating_ranges_give_the_one_pass_windows(tmp_path):
    from tribodyn.io import save_npz
    from tribodyn.pipeline.distributed import analyze_many

    sim = simulate.reciprocating(seed=12, cycles=40, fz_dynamic=1.0)
    p = tmp_path / "recip.npz"
    save_npz(p, sim.channels, sim.fs)
    one = td.analyze(td.open_recording(p), window=0.05, hop=0.05)
    many = analyze_many([p], split=2.0, window=0.05, hop=0.05)
    res = many.results[str(p)]
    assert res.params["ranges"] > 3
    assert len(res) == len(one) > 80
    for c in ("t_start", "acquisition", "mu_r", "ok"):
        np.testing.assert_array_equal(res[c], one[c])
    assert res.summary()["verdict"] == one.summary()["verdict"]


REAL = TESTS / "data" / "real"


def test_analyze_many_on_a_real_cetr_file_gives_the_verdict_of_analyze():
    from tribodyn.pipeline.distributed import analyze_many

    p = REAL / "cetr_umt2_HT-2n-6-4_2_001.csv"
    one = td.analyze(td.open_recording(p))
    res = analyze_many([p]).results[str(p)]
    assert res.summary()["verdict"] == one.summary()["verdict"]
    assert res.summary()["roles"] == one.summary()["roles"] and res.params["route"] == "segments"
