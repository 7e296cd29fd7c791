"""Real tribometer exports of tests/data/real (issue 14): read, analysed, verdict and classical COF.

Provenance and licence of each file: tests/data/README.md (MIT-licensed sources, texts in tests/data/licences).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import tribodyn as td


REAL = Path(__file__).resolve().parent / "data" / "real"  # in the repository: a missing file fails, never skips


@pytest.mark.fast
@pytest.mark.parametrize("name", ["cetr_umt2_HT-2n-6-4_2_001.csv", "cetr_umt2_HT-2n-6-4_2_002.csv"])
def test_cetr_per_stroke_no_window_across_the_boundary(name):
    rec = td.open_recording(REAL / name)
    assert len(rec.acquisitions) == 2
    res = td.analyze(rec)
    # one window per step (stroke), each starting at its step's first sample
    starts = (res["t_start"] * rec.fs).round().astype(int)
    assert [a for a, _ in rec.acquisitions] == starts.tolist()
    assert res["acquisition"].tolist() == [0, 1]
    for (a, b), s, n in zip(rec.acquisitions, starts, res["n"]):
        assert a <= s and s + n <= b
    np.testing.assert_allclose(res["mu_classical"], res["mu_instrument"], rtol=5e-3)
    s = res.summary()
    assert abs(s["classical"]["median"] / s["instrument"]["median"] - 1) < 5e-3
    assert s["verdict"]["dynamic_method"] is False


@pytest.mark.fast
@pytest.mark.parametrize("name,load", [("pod_PPS_60N_1.tsv", 59.841), ("pod_PPS_100N_1.tsv", 98.1)])
def test_pin_on_disc_dead_weight_classical(name, load):
    res = td.analyze(td.open_recording(REAL / name))
    s = res.summary()
    v = s["verdict"]
    assert v["dynamic_method"] is False
    assert any("dead weight" in r for r in v["reasons"])
    assert v["cof"]["method"] == "classical" and v["cof"]["statistic"] == "mean"
    assert abs(s["classical"]["median"] / s["instrument"]["median"] - 1) < 5e-3
    assert abs(v["cof"]["value"] / s["instrument"]["median"] - 1) < 5e-3
    # 1 Hz: window and hop chosen from the rate, the recording tiled
    assert res.params["window"] == res.params["hop"] == 100.0
    assert "chosen from the rate" in res.params["window_note"]
    assert s["roles"] == {"fy": "Friction Force", "fz": "Load", "cof": "Friction Coefficient"}
    np.testing.assert_allclose(np.nanmedian(res["fz_mean"]), load, rtol=1e-3)


R_EFF = 2.0 / 3.0 * 4e-3  # m: the authors' effective radius (tests/data/README.md)


@pytest.mark.fast
@pytest.mark.parametrize("name", ["newport_motor_oil_glass_1rps5N.txt", "newport_motor_oil_glass_0-1rps0-5N.txt"])
def test_newport_rate_from_time_column_and_torque_over_radius(name):
    path = REAL / name
    rec = td.open_recording(path, time_column="col1", channels={"fy": "col3", "fz": "col2"}, scale={"fy": 1 / R_EFF})
    raw = np.loadtxt(path, delimiter=";", skiprows=1)
    t = raw[:, 1]
    assert rec.fs == pytest.approx(1 / np.median(np.diff(t)), rel=1e-6)
    assert 9.9 < rec.fs < 10.0
    # the authors' processing: subtract the first sample's force and the minimum torque of the first 10 s
    f0 = raw[0, 2]
    m0 = raw[t <= t[0] + 10, 3].min()
    res = td.analyze(rec, tare={"fy": m0 / R_EFF, "fz": f0})
    force, torque = raw[:, 2] - f0, raw[:, 3] - m0
    spec_min = res.params["min_fn"]
    assert spec_min == pytest.approx(0.05 * np.median(np.abs(force)), rel=0.05)
    n, length = len(res), res.params["window_samples"]
    want = []
    for k in range(n):
        s0 = int(round(res["t_start"][k] * rec.fs))
        z, y = np.abs(force[s0 : s0 + length]), np.abs(torque[s0 : s0 + length]) / R_EFF
        keep = (z >= spec_min) & (z > 0)
        want.append(np.mean(y[keep] / z[keep]) if keep.any() else np.nan)
    np.testing.assert_allclose(res["mu_classical"], want, rtol=1e-9)


@pytest.mark.fast
def test_newport_time_column_guessed_without_names():
    rec = td.open_recording(REAL / "newport_motor_oil_glass_1rps5N.txt")
    assert 9.9 < rec.fs < 10.0
    assert any("taken as time" in w for w in rec.warnings)


@pytest.mark.fast
def test_lvm_segments_continuous_are_one_acquisition():
    rec = td.open_recording(REAL / "lvm_read_long_single_header_multi_ch.lvm")
    assert len(rec.segments) == 2 and rec.acquisitions == [(0, 16384)]
