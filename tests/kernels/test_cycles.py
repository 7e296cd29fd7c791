"""Cycles of reciprocating tests (issue 24 point 2, docs/method.md 6c): forward/backward, offset, energy."""

from __future__ import annotations

import numpy as np
import pytest
import tribodyn as td
from tribodyn import simulate
from tribodyn.kernels.strokes import CYCLE_COLUMNS


@pytest.mark.fast
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_cycle_cof_cancels_a_ten_percent_load_cell_offset(seed):
    mu_f, mu_b, load = 0.12, 0.10, 10.0
    offset = 0.1 * 0.5 * (mu_f + mu_b) * load  # 10 % of the friction force
    sim = simulate.reciprocating(seed=seed, mu_forward=mu_f, mu_backward=mu_b, normal_force=load, offset=offset)
    res = td.analyze(sim.channels, fs=sim.fs)
    cy = res.cycles
    assert list(cy.columns) == list(CYCLE_COLUMNS) and cy.attrs["units"]["energy"] == "J"
    full = cy[np.isfinite(cy["mu_cycle"])]
    assert abs(full["mu_cycle"].mean() / 0.11 - 1) < 0.005  # within 0.5 %
    # each direction is off by the offset, the cycle's average is not
    assert abs(full["mu_forward"].mean() - (mu_f + offset / load)) < 0.002
    assert abs(full["offset"].mean() - (0.5 * (mu_f - mu_b) + offset / load)) < 0.001
    assert res.headline.method == "per-stroke" and res.headline.value == pytest.approx(full["mu_cycle"].mean())


@pytest.mark.fast
def test_energy_is_the_loop_area_within_one_percent():
    sim = simulate.reciprocating(seed=4, offset=0.2)
    res = td.analyze(sim.channels, fs=sim.fs)
    cy = res.cycles
    whole = cy[np.isfinite(cy["energy"])]
    assert len(whole) >= len(cy) - 2  # only a first and a last part-cycle lack an energy
    np.testing.assert_allclose(whole["energy"], sim.energy_per_cycle, rtol=0.01)
    np.testing.assert_allclose(whole["distance"], 2 * 0.01, rtol=1e-3)  # two strokes of 10 mm
    np.testing.assert_allclose(whole["slip_amplitude"], 0.005, rtol=1e-3)
    assert abs(whole["mu_energy"].mean() / (sim.energy_per_cycle / (10.0 * 0.02)) - 1) < 0.01


@pytest.mark.fast
def test_no_position_no_energy_and_no_strokes_no_cycles():
    sim = simulate.reciprocating(seed=5)
    res = td.analyze({k: sim.channels[k] for k in ("fy", "fz", "v")}, fs=sim.fs)
    assert res.cycles is not None and np.isnan(res.cycles["energy"]).all()
    assert np.isfinite(res.cycles["mu_cycle"]).sum() >= 18
    uni = td.analyze({"fy": np.abs(sim.channels["fy"]), "fz": sim.channels["fz"]}, fs=sim.fs)
    assert uni.cycles is None
