"""Tests of simulate.conditions (issue 12): measurement conditions on the rig.

Plain NumPy computations only, independent of the analysis code.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from tribodyn import simulate

MU = 0.1
F_L = simulate.N_LAMELLAS * simulate.RPM / 60.0


def _dft(x: np.ndarray, f: float, fs: float) -> complex:
    n = np.arange(x.size)
    return complex(np.sum(x * np.exp(-2j * np.pi * f * n / fs)))


def test_deterministic_for_a_seed_and_differs_between_seeds():
    kw = dict(snr_z=10.0, z_noise="band", y_noise=0.02, drift=0.03, ripple=0.05, delay=0.7, beta=0.1)
    a = simulate.conditions(5.0, seed=3, **kw)
    b = simulate.conditions(5.0, seed=3, **kw)
    c = simulate.conditions(5.0, seed=4, **kw)
    assert set(a.channels) == {"fx", "fy", "fz"}
    for k in a.channels:
        assert a.channels[k].shape == (5000,)
        np.testing.assert_array_equal(a.channels[k], b.channels[k])
        assert not np.array_equal(a.channels[k], c.channels[k])
    tr = a.truth
    assert tr.params["scenario"] == "conditions"
    assert tr.skew == 1 and tr.force_dependence == 0.1
    assert tr.params["dmu_dfn"] == pytest.approx(MU * 0.1)
    assert tr.t[0] == 0.0 and tr.t[-1] == pytest.approx(5.0) and np.all(tr.mu == MU)
    assert a.temperature_log is None and a.area_mm2 is None and a.orientation == -1


def test_snr_z_attenuates_ols_slope():
    sim = simulate.conditions(60.0, snr_z=10.0)
    fy, fz = sim.channels["fy"], sim.channels["fz"]
    slope = np.polyfit(fz, fy, 1)[0]
    expected = -MU / (1.0 + 10.0 ** (-1.0))
    assert slope == pytest.approx(expected, rel=0.01)
    # the reported noise std is the stated fraction of std(N)
    clean = simulate.conditions(60.0)
    ratio = sim.truth.params["noise_z_std"] / np.std(clean.channels["fz"])
    assert ratio == pytest.approx(10.0 ** (-0.5), rel=0.01)


def test_integer_delay_moves_cross_correlation_peak():
    sim = simulate.conditions(10.0, delay=3)
    fy, fz = sim.channels["fy"], sim.channels["fz"]
    lags = np.arange(-10, 11)
    n = fy.size
    c = [np.dot(fy[max(0, -j) : n - max(0, j)], fz[max(0, j) : n - max(0, -j)]) for j in lags]
    assert lags[int(np.argmax(np.abs(c)))] == 3
    assert sim.truth.skew == 3


def test_fractional_delay_from_cross_spectrum_phase():
    fs = 1000.0
    sim = simulate.conditions(24.0, delay=0.5)  # 100 revolutions: f_l on a bin
    y = _dft(sim.channels["fy"], F_L, fs)
    z = _dft(sim.channels["fz"], F_L, fs)
    s_yz = np.conj(y) * z * sim.orientation  # = mu |N|^2 exp(-2j pi f d)
    d = -np.angle(s_yz) / (2.0 * np.pi * F_L / fs)
    assert d == pytest.approx(0.5, abs=0.02)


def test_drift_adds_stated_std():
    a = simulate.conditions(100.0, drift=0.05)
    b = simulate.conditions(100.0)
    extra = np.std(a.channels["fy"] - b.channels["fy"])
    assert extra == pytest.approx(0.05, rel=0.15)
    np.testing.assert_array_equal(a.channels["fz"], b.channels["fz"])


def test_beta_quadratic_coefficient_raw():
    beta = 0.1
    sim = simulate.conditions(30.0, beta=beta, raw=True)
    fy, fz = sim.channels["fy"], sim.channels["fz"]
    assert np.mean(fz) == pytest.approx(simulate.PRELOAD_N, abs=0.1)
    a = np.column_stack([np.ones_like(fz), fz, fz**2])
    coef = np.linalg.lstsq(a, fy, rcond=None)[0]
    assert coef[2] == pytest.approx(sim.orientation * MU * beta, rel=0.05)


def test_ripple_adds_line_at_lamella_frequency():
    fs = 1000.0
    r = 0.05
    a = simulate.conditions(24.0, ripple=r)
    b = simulate.conditions(24.0)
    diff = a.channels["fy"] - b.channels["fy"]
    spec = np.abs(np.fft.rfft(diff)) * 2.0 / diff.size
    f = np.fft.rfftfreq(diff.size, 1.0 / fs)
    k = int(np.argmin(np.abs(f - F_L)))
    assert int(np.argmax(spec)) == k
    # amplitude of the extra line: mu r N0
    assert spec[k] == pytest.approx(MU * r * simulate.PRELOAD_N, rel=0.05)


def test_band_noise_is_band_limited():
    fs = 1000.0
    a = simulate.conditions(20.0, y_noise=0.05, y_noise_kind="band")
    b = simulate.conditions(20.0)
    e = a.channels["fy"] - b.channels["fy"]
    assert np.std(e) == pytest.approx(0.05, rel=0.02)
    p = np.abs(np.fft.rfft(e)) ** 2
    f = np.fft.rfftfreq(e.size, 1.0 / fs)
    inband = p[(f > 20) & (f < 200)].sum() / p.sum()
    assert inband > 0.75


@pytest.mark.parametrize(
    "kw",
    [
        dict(z_noise="pink"),
        dict(y_noise_kind="red"),
        dict(y_noise=-0.1),
        dict(drift=-1.0),
        dict(snr_z=math.nan),
        dict(delay=math.inf),
        dict(beta=math.nan),
        dict(ripple=-0.1),
        dict(mu=math.nan),
        dict(delay=5000.0),
    ],
)
def test_invalid_options(kw):
    with pytest.raises(ValueError):
        simulate.conditions(2.0, **kw)


def test_invalid_duration():
    with pytest.raises(ValueError):
        simulate.conditions(math.nan)
    with pytest.raises(ValueError):
        simulate.conditions(0.0)
