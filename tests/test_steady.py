"""Running-in and steady state (issue 24 point 1, docs/method.md 6g) against the simulator's known t_steady."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tribodyn import simulate

DELTA = 0.02  # docs/method.md 6g


# -- the simulator's truth ---------------------------------------------------------------


@pytest.mark.fast
@pytest.mark.parametrize("shape", simulate.RUNNING_IN_SHAPES)
def test_simulated_t_steady_is_where_two_percent_of_the_transient_is_left(shape):
    sim = simulate.running_in(shape=shape, t_steady=300.0, mu_0=0.3, mu_ss=0.15, duration=100.0)
    assert simulate.STEADY_DELTA == DELTA
    t = np.linspace(0.0, 1000.0, 100001)
    left = np.abs(sim.mu_at(t) - sim.mu_ss) / abs(sim.mu_0 - sim.mu_ss)
    assert left[0] == pytest.approx(1.0)
    first = t[np.flatnonzero(left > DELTA)[-1] + 1]  # first time after which it stays within 2 %
    assert first == pytest.approx(300.0, abs=0.02)
    assert not sim.reached  # 300 s of running-in in a 100 s test


@pytest.mark.fast
def test_simulator_flat_drift_and_bad_options():
    flat = simulate.running_in(t_steady=0.0, duration=60.0, wander=0.0, noise=0.0)
    assert flat.reached and flat.t_steady == 0.0
    mu = flat.channels["fy"] / flat.channels["fz"]
    assert np.allclose(mu[1:], flat.mu_ss)
    drifting = simulate.running_in(drift=1e-5, duration=60.0)
    assert math.isnan(drifting.t_steady) and not drifting.reached
    w = simulate.running_in(t_steady=0.0, duration=4000.0, fs=10.0, noise=0.0, wander=0.01, wander_time=5.0, seed=1)
    x = w.channels["fy"] / w.channels["fz"] - w.mu_ss
    assert 0.009 < x.std() < 0.011  # the wander's stated SD
    lag = int(5.0 * w.fs)  # correlation exp(-1) at one correlation time
    assert 0.3 < np.corrcoef(x[lag:], x[:-lag])[0, 1] < 0.45
    with pytest.raises(ValueError, match="shape"):
        simulate.running_in(shape="cubic")
    with pytest.raises(ValueError, match="t_steady"):
        simulate.running_in(t_steady=-1.0)
    with pytest.raises(ValueError, match="fs"):
        simulate.running_in(fs=0.0)
