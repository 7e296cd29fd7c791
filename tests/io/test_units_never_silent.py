"""Units are converted or refused, never taken silently (issue 34 point 4; docs/method.md 6f)."""

from __future__ import annotations

import numpy as np
import pytest
import tribodyn as td
from tribodyn import simulate
from tribodyn.io.units import GRAM_FORCE


def _csv(path, names, cols):
    np.savetxt(path, np.column_stack(cols), delimiter=",", comments="", header=",".join(names))
    return path


@pytest.fixture(scope="module")
def forces():
    rng = np.random.default_rng(2)
    n = 2000
    fz = 10.0 + 0.05 * rng.standard_normal(n)
    fy = 0.25 * fz * (1 + 0.02 * rng.standard_normal(n))
    return np.arange(n) / 100.0, fy, fz


@pytest.mark.fast
def test_a_force_in_g_is_gram_force_on_every_text_path(tmp_path, forces) -> None:
    t, fy, fz = forces
    p = _csv(tmp_path / "g.csv", ["Time [s]", "Fx [g]", "Fz [g]"], [t, fy / GRAM_FORCE, fz / GRAM_FORCE])
    with td.open_recording(p, channels={"fy": "Fx [g]", "fz": "Fz [g]"}) as rec:
        units = {c.role: (c.unit, c.note) for c in rec.channels if c.role}
        assert units["fy"][0] == units["fz"][0] == "N" and "gram-force" in units["fy"][1]
        np.testing.assert_allclose(rec.read(["fz"])["fz"], fz, rtol=1e-12)


@pytest.mark.fast
def test_fy_and_fz_in_different_units_are_refused(tmp_path, forces) -> None:
    t, fy, fz = forces
    p = _csv(tmp_path / "mixed.csv", ["Time [s]", "Ff [V]", "Fn [N]"], [t, fy, fz])
    with pytest.raises(ValueError, match=r"fy \('Ff \[V\]'\) is in V and fz \('Fn \[N\]'\) in N"):
        td.analyze(p, channels={"fy": "Ff [V]", "fz": "Fn [N]"})
    torque = _csv(tmp_path / "torque.csv", ["Time [s]", "Torque [N m]", "Fn [N]"], [t, fy * 0.02, fz])
    with pytest.raises(ValueError, match=r"a friction torque: --scale fy=1/r"):
        td.analyze(torque, channels={"fy": "Torque [N m]", "fz": "Fn [N]"})
    # one side without a unit: analysed, with the reason said
    q = _csv(tmp_path / "half.csv", ["Time [s]", "Ff", "Fn [N]"], [t, fy, fz])
    res = td.analyze(q, channels={"fy": "Ff", "fz": "Fn [N]"})
    assert any("has no unit: the COF takes them as the same unit" in w for w in res.warnings)


@pytest.mark.fast
def test_a_velocity_in_rpm_is_no_sliding_speed(tmp_path, forces) -> None:
    t, fy, fz = forces
    p = _csv(tmp_path / "rpm.csv", ["Time [s]", "Ff [N]", "Fn [N]", "Speed [rpm]"], [t, fy, fz, np.full(t.size, 120.0)])
    chans = {"fy": "Ff [N]", "fz": "Fn [N]", "v": "Speed [rpm]"}
    with pytest.raises(ValueError, match="rotational speed, not a sliding speed"):
        td.analyze(p, channels=chans)
    with td.open_recording(p, channels=chans, scale={"v": 2 * np.pi * 0.01 / 60}) as rec:  # r = 10 mm
        res = td.analyze(rec)
    assert np.nanmedian(res.table["speed"]) == pytest.approx(120.0 * 2 * np.pi * 0.01 / 60, rel=1e-9)


@pytest.mark.fast
def test_a_position_without_a_unit_gives_no_energy(tmp_path) -> None:
    sim = simulate.reciprocating(seed=2)
    ch = sim.channels
    t = np.arange(ch["fy"].size) / sim.fs
    p = _csv(tmp_path / "x.csv", ["Time [s]", "Ff [N]", "Fn [N]", "Position"], [t, ch["fy"], ch["fz"], ch["x"]])
    chans = {"fy": "Ff [N]", "fz": "Fn [N]", "x": "Position"}
    with td.open_recording(p, channels=chans) as rec:
        assert any("position channel 'Position' has no unit" in w for w in rec.warnings)
        res = td.analyze(rec)
    assert res.headline.method == "per-stroke" and not np.isfinite(res.cycles["energy"]).any()
    with td.open_recording(p, channels=chans, scale={"x": 1.0}) as rec:  # metres, said by the caller
        assert not any("position channel" in w for w in rec.warnings)
        res = td.analyze(rec)
    whole = res.cycles[np.isfinite(res.cycles["energy"])]
    np.testing.assert_allclose(whole["energy"], sim.energy_per_cycle, rtol=0.01)
