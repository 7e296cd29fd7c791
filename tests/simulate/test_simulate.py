"""Tests of the rig simulator (tribodyn.simulate), docs/method.md section 8.

Plain NumPy computations only: the simulator is the source of truth for the
analysis tests, so it is checked here independently of the analysis code.
"""

from __future__ import annotations

import numpy as np
import pytest
from tribodyn import simulate


FS = 1000.0
N0 = simulate.PRELOAD_N


# --------------------------------------------------------------------------
# fixtures and helpers
# --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def temp_sim() -> simulate.Simulation:
    return simulate.temperature_test()


@pytest.fixture(scope="module")
def cd_sim() -> simulate.Simulation:
    return simulate.current_density_test()


def _cat(chunks) -> dict:
    chunks = list(chunks)
    return {k: np.concatenate([c[k] for c in chunks]) for k in chunks[0]}


def _window(sim: simulate.Simulation, centre: float, width: float = 2.0) -> dict:
    a = round(float((centre - width / 2) * sim.fs))
    b = round(float((centre + width / 2) * sim.fs))
    return {k: v[a:b] for k, v in sim.channels.items()}


def _slope_mu(fy: np.ndarray, fz: np.ndarray, orientation: int) -> float:
    return float(np.polyfit(fz, fy, 1)[0]) * orientation


def _lagged_corr(x: np.ndarray, y: np.ndarray, max_lag: int):
    """docs/method.md Eq. (1): whole-input means, overlap sums (direct)."""
    n = x.size
    xc, yc = x - x.mean(), y - y.mean()
    lags = np.arange(-max_lag, max_lag + 1)
    out = np.empty(lags.size)
    for k, j in enumerate(lags):
        i0, i1 = max(0, -j), min(n, n - j)
        a, b = xc[i0:i1], yc[i0 + j : i1 + j]
        out[k] = np.sum(a * b) / np.sqrt(np.sum(a * a) * np.sum(b * b))
    return lags, out


# --------------------------------------------------------------------------
# structure
# --------------------------------------------------------------------------
@pytest.mark.fast
def test_temperature_test_structure(temp_sim: simulate.Simulation) -> None:
    s = temp_sim
    assert s.fs == FS
    assert set(s.channels) == {"fx", "fy", "fz"}
    for v in s.channels.values():
        assert v.dtype == np.float64 and v.shape == (4_060_000,)
    assert s.duration == pytest.approx(4060.0)
    assert s.time[1] == pytest.approx(1.0 / FS)
    assert s.rpm == 250 and s.n_lamellas == 24 and s.orientation == -1
    t_log, temp_log = s.temperature_log
    assert t_log.shape == temp_log.shape and np.all(np.diff(t_log) > 0)
    assert t_log[0] == 0.0 and t_log[-1] == pytest.approx(4060.0)
    # Readings every 100-200 s, plus one at each breakpoint of the path.
    breaks = [t for t, _ in simulate.TEMPERATURE_PATH if 0 < t < 4060]
    assert set(breaks) <= set(t_log.tolist())
    regular = np.array(sorted(set(t_log.tolist()) - set(breaks)))
    gaps = np.diff(regular)[:-1]  # the last reading closes the test
    assert np.all((gaps >= 99.9) & (gaps <= 200.1))
    assert np.all(np.abs(temp_log - s.truth.temperature_at(t_log)) < 1.5)
    tr = s.truth
    assert tr.t[0] == 0.0 and tr.t[-1] == pytest.approx(4060.0)
    assert tr.mu.shape == tr.t.shape == tr.temperature.shape
    assert tr.current_density is None and tr.contact_loss == ()
    assert tr.force_dependence == 0.0 and tr.skew == 0
    assert np.all(np.isnan(tr.mu_at([-1.0, 4061.0])))
    # the temperature path of the paper
    for t, temp in [(0, 155), (2000, 175), (3650, 130), (3800, 135), (4060, 100)]:
        assert tr.temperature_at(t) == pytest.approx(temp)


@pytest.mark.fast
def test_current_density_structure(cd_sim: simulate.Simulation) -> None:
    s = cd_sim
    assert set(s.channels) == {"fx", "fy", "fz", "i"}
    assert all(v.shape == (700_000,) and v.dtype == np.float64 for v in s.channels.values())
    assert s.area_mm2 == 1.0
    tr = s.truth
    assert tr.current_density[0] == pytest.approx(2.0)
    assert tr.current_density[-1] == pytest.approx(6.5)
    assert np.all(np.diff(tr.current_density) >= 0)
    assert tr.optimum["current_density"] == (4.25, 4.75)
    assert len(tr.contact_loss) == 1 and tr.contact_loss[0][1] == pytest.approx(700.0)
    # current channel: J * area within ripple and noise, in a mid-step window
    i = _window(s, 70.0 * 5 + 35.0)["i"]  # middle of step 5: J = 4.5
    assert i.mean() == pytest.approx(4.5, abs=0.01)
    assert np.std(i) < 0.1


@pytest.mark.fast
def test_scenario_dispatch(cd_sim: simulate.Simulation) -> None:
    again = simulate.scenario("current_density")
    for k in cd_sim.channels:
        np.testing.assert_array_equal(again.channels[k], cd_sim.channels[k])
    with pytest.raises(ValueError):
        simulate.scenario("nope")


@pytest.mark.fast
def test_option_validation() -> None:
    with pytest.raises(ValueError):
        simulate.continuous(1.0, orientation=0)
    with pytest.raises(ValueError):
        simulate.continuous(1.0, seed=-1)
    with pytest.raises(ValueError):
        next(simulate.continuous(1.0, skew=5000))


# --------------------------------------------------------------------------
# determinism and streaming
# --------------------------------------------------------------------------
@pytest.mark.fast
def test_determinism_by_seed() -> None:
    a = _cat(simulate.continuous(5.0, seed=3, current=2.0))
    b = _cat(simulate.continuous(5.0, seed=3, current=2.0))
    c = _cat(simulate.continuous(5.0, seed=4, current=2.0))
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])
        assert not np.array_equal(a[k], c[k])


@pytest.mark.parametrize("skew", [0, 2, -3])
def test_continuous_chunk_invariance(skew: int) -> None:
    kw = {"seed": 7, "current": 5.0, "skew": skew, "force_dependence": 0.1}
    a = _cat(simulate.continuous(7.3, chunk_s=60.0, **kw))
    b = _cat(simulate.continuous(7.3, chunk_s=1.7, **kw))
    c = _cat(simulate.continuous(7.3, chunk_s=0.013, **kw))
    assert set(a) == {"fx", "fy", "fz", "i"}
    for k in a:
        assert a[k].shape == (7300,)
        np.testing.assert_array_equal(a[k], b[k])
        np.testing.assert_array_equal(a[k], c[k])


@pytest.mark.fast
def test_continuous_chunk_sizes() -> None:
    sizes = [c["fz"].size for c in simulate.continuous(10.0, chunk_s=3.0)]
    assert sizes == [3000, 3000, 3000, 1000]
    assert list(simulate.continuous(0.0)) == []


# --------------------------------------------------------------------------
# physics
# --------------------------------------------------------------------------
@pytest.mark.fast
def test_dynamic_force_range_and_zero_mean(temp_sim: simulate.Simulation) -> None:
    fz = temp_sim.channels["fz"]
    assert 1.0 < fz.max() < 2.3 and -2.3 < fz.min() < -1.0
    for k, v in temp_sim.channels.items():
        assert abs(v.mean()) < 0.01, k
    # a 2 s window spans roughly the paper's -1.36..+1.12 N
    w = _window(temp_sim, 501.0)["fz"]
    assert 0.8 < w.max() < 2.2 and -2.2 < w.min() < -0.8
    # 16-bit quantisation of +-10 N
    lsb = 20.0 / 2**16
    np.testing.assert_allclose(fz[:1000] / lsb, np.round(fz[:1000] / lsb), atol=1e-6)


@pytest.mark.fast
def test_raw_has_preload_and_positive_contact(cd_sim: simulate.Simulation) -> None:
    raw = simulate.current_density_test(raw=True)
    fz = raw.channels["fz"]
    t = raw.time
    outside = ~raw.truth.in_contact_loss(t)
    assert np.all(fz[outside] > 0.0)
    assert fz[outside].mean() == pytest.approx(N0, abs=0.05)
    # friction preload: fy ~ s * mu * N0 in the DC-coupled signal
    w = t < 60.0
    assert raw.channels["fy"][w].mean() == pytest.approx(-0.17 * N0, rel=0.05)
    # same dynamics as the high-passed recording (same seed)
    a, b = _window(raw, 300.0), _window(cd_sim, 300.0)
    assert np.corrcoef(a["fz"], b["fz"])[0, 1] > 0.999


@pytest.mark.fast
def test_continuous_raw_preload() -> None:
    d = _cat(simulate.continuous(30.0, raw=True, mu=0.12, orientation=1))
    assert d["fz"].mean() == pytest.approx(N0, abs=0.05)
    assert d["fz"].min() > 0.0
    assert d["fy"].mean() == pytest.approx(0.12 * N0, rel=0.05)


@pytest.mark.fast
@pytest.mark.parametrize("centre", [101.0, 901.0, 1501.0, 1901.0, 2301.0, 2701.0, 3401.0, 3651.0, 3991.0, 4041.0])
def test_slope_recovers_true_cof_temperature(temp_sim: simulate.Simulation, centre: float) -> None:
    w = _window(temp_sim, centre)
    mu = _slope_mu(w["fy"], w["fz"], temp_sim.orientation)
    assert mu == pytest.approx(float(temp_sim.truth.mu_at(centre)), rel=0.02)
    assert abs(np.corrcoef(w["fy"], w["fz"])[0, 1]) >= 0.85


@pytest.mark.fast
def test_slope_recovers_true_cof_current_density(cd_sim: simulate.Simulation) -> None:
    for centre in np.arange(35.0, 630.0, 70.0):  # mid-step windows
        w = _window(cd_sim, centre)
        mu = _slope_mu(w["fy"], w["fz"], cd_sim.orientation)
        assert mu == pytest.approx(float(cd_sim.truth.mu_at(centre)), rel=0.02)


@pytest.mark.fast
def test_orientation_plus_one() -> None:
    d = _cat(simulate.continuous(4.0, orientation=1, mu=0.15))
    assert np.corrcoef(d["fy"], d["fz"])[0, 1] > 0.9
    assert _slope_mu(d["fy"], d["fz"], 1) == pytest.approx(0.15, rel=0.02)


@pytest.mark.fast
def test_axial_force_weakly_correlated(temp_sim: simulate.Simulation) -> None:
    w = _window(temp_sim, 1001.0)
    c = np.corrcoef([w["fx"], w["fy"], w["fz"]])
    assert abs(c[1, 2]) > 0.9
    assert abs(c[0, 2]) < 0.5 and abs(c[0, 1]) < 0.5


@pytest.mark.fast
def test_cof_curves_and_optimum(temp_sim: simulate.Simulation, cd_sim: simulate.Simulation) -> None:
    opt = temp_sim.truth.optimum
    for branch in ("heating", "cooling"):
        lo, hi = opt[f"temperature_{branch}"]
        inside = np.linspace(lo, hi, 11)
        np.testing.assert_allclose(simulate.cof_vs_temperature(inside, branch), 0.1)
        assert np.all(simulate.cof_vs_temperature([lo - 1.0, hi + 1.0], branch) > 0.1)
    # hysteresis: higher COF on cooling above the cooling optimum
    assert simulate.cof_vs_temperature(170.0, "cooling") > simulate.cof_vs_temperature(170.0, "heating")
    # along the run: COF about 0.1 in the optimum, 0.15-0.2+ outside
    tr = temp_sim.truth
    assert tr.mu_at(500.0) == pytest.approx(0.1)
    assert 0.15 <= tr.mu_at(2000.0) <= 0.2
    assert tr.mu_at(4050.0) > 0.2
    assert np.max(np.abs(np.diff(tr.mu))) < 0.005  # smooth, no jumps
    # current density: minimum 0.1 on the optimum, 0.25 at 6 A/mm^2
    lo, hi = cd_sim.truth.optimum["current_density"]
    j = np.linspace(2.0, 6.5, 91)
    mu_j = simulate.cof_vs_current_density(j)
    assert mu_j.min() == pytest.approx(0.1)
    np.testing.assert_allclose(mu_j[(j >= lo) & (j <= hi)], 0.1)
    assert simulate.cof_vs_current_density(6.0) == pytest.approx(0.25)
    assert cd_sim.truth.mu_at(35.0 + 70.0 * 5) == pytest.approx(0.1, abs=1e-6)  # J = 4.5


@pytest.mark.fast
def test_force_dependence_sign() -> None:
    def mu_a_b(beta: float):
        d = _cat(simulate.continuous(60.0, mu=0.12, force_dependence=beta, seed=1))
        fy, fz = d["fy"], d["fz"]
        big = np.abs(fz) >= 0.35
        ratio = -fy[big] / fz[big]  # orientation -1
        return ratio[fz[big] <= -0.35].mean(), ratio[fz[big] >= 0.35].mean()

    a0, b0 = mu_a_b(0.0)
    a3, b3 = mu_a_b(0.3)
    assert b3 > a3
    assert (b3 - a3) > 5 * abs(b0 - a0)
    assert abs(b0 - a0) / 0.12 < 0.01


@pytest.mark.fast
def test_contact_loss_breaks_correlation(cd_sim: simulate.Simulation) -> None:
    tr = cd_sim.truth
    t0, t1 = tr.contact_loss[0]
    centres = np.arange(t0 + 1.0, t1 - 1.0 + 1e-9, 2.0)
    assert centres.size > 20
    assert np.all(tr.in_contact_loss(centres, 1.0))
    for c in centres:
        w = _window(cd_sim, c)
        assert abs(np.corrcoef(w["fy"], w["fz"])[0, 1]) < 0.85
    # outside contact loss every window passes the gate
    good = np.arange(1.0, t0 - 1.0, 10.0)
    assert not np.any(tr.in_contact_loss(good, 1.0))
    for c in good:
        w = _window(cd_sim, c)
        assert abs(np.corrcoef(w["fy"], w["fz"])[0, 1]) >= 0.85


@pytest.mark.fast
def test_contact_loss_contact_force_zero() -> None:
    raw = simulate.current_density_test(raw=True, seed=2)
    t = raw.time
    t0, _t1 = raw.truth.contact_loss[0]
    fz = raw.channels["fz"][t > t0 + 2.0]
    # measured force = contact force + brush ringing; the contact force itself
    # is zero for a good part of the time, so the DC level collapses
    assert fz.mean() < 0.5 * N0
    assert np.mean(fz < 0.0) > 0.1


@pytest.mark.fast
@pytest.mark.parametrize("skew", [0, 3, -2, 7])
def test_skew_shows_as_lag(skew: int) -> None:
    d = _cat(simulate.continuous(10.0, skew=skew, seed=5))
    lags, c = _lagged_corr(d["fy"], d["fz"], 12)
    assert lags[np.argmax(np.abs(c))] == skew
    # fz is fy's partner delayed by `skew` samples
    if skew > 0:
        ref = _cat(simulate.continuous(10.0, skew=0, seed=5))
        np.testing.assert_array_equal(d["fy"], ref["fy"])


@pytest.mark.fast
def test_skew_in_scenario_truth() -> None:
    s = simulate.current_density_test(skew=4)
    assert s.truth.skew == 4
    w = _window(s, 100.0)
    lags, c = _lagged_corr(w["fy"], w["fz"], 10)
    assert lags[np.argmax(np.abs(c))] == 4
