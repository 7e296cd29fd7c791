"""The instrument's lag chosen from the data and the lower bound without one (docs/method.md 3b, 3d; issue 23.3)."""

from __future__ import annotations

import numpy as np
import pytest
import tribodyn
from tribodyn import simulate
from tribodyn.kernels.estimators import BLOCKS, PRODUCTS, reverse_slope
from tribodyn.pipeline.instrument import choose_lag, lag_profile, sample_windows

MU = 0.1


def _acquisitions(count: int = 20, **kw: object) -> list:
    # 228 rpm: fz lagged by 200 samples (a tenth of a 2 s window, the old default) is nearly uncorrelated with fz
    cond = dict(snr_z=6.0, y_noise=0.02, rpm=228.0)
    cond.update(kw)
    return [dict(a.channels) for a in simulate.acquisitions(count, 2.0, seed=7, **cond)]


@pytest.mark.fast
def test_separate_acquisitions_without_rpm_get_a_strong_lag_from_the_data() -> None:
    res = tribodyn.analyze(_acquisitions(), fs=1000.0, window=2.0, hop=2.0, threads=1)
    assert res.params["iv_lag_rule"] == "data"
    assert 2 <= res.params["iv_lag_samples"] < 200
    assert abs(res.params["instrument_r"]) >= 0.3
    head = res.headline
    assert head.bound == "" and "lower" not in head.text
    assert abs(head.value / MU - 1) < 0.03  # least squares would be -20 %
    assert head.low <= MU <= head.high


@pytest.mark.fast
def test_the_old_default_lag_falls_back_to_a_lower_bound_whose_interval_holds_the_truth() -> None:
    res = tribodyn.analyze(_acquisitions(), fs=1000.0, window=2.0, hop=2.0, threads=1, iv_lag=0.2)
    assert res.params["iv_lag_rule"] == "given" and res.params["iv_lag_samples"] == 200
    assert res.params["mu_r_bound"] == "lower" and res.params["attenuation_gap"] > 0
    head = res.headline
    assert head.bound == "lower" and "lower bound" in head.text and head.to_dict()["bound"] == "lower"
    assert head.value < 0.9 * MU  # the attenuated least-squares slope
    assert head.low <= MU <= head.high  # never a tight interval around it
    ci = res.summary()["mu_r"]["ci"]["median"]
    assert ci[0] <= MU <= ci[1]
    assert np.mean((res["mu_r_low"] <= MU) & (MU <= res["mu_r_high"])) >= 0.9
    assert np.all(res["mu_r_high"] >= res["mu_r"])
    assert any("lower bound" in w for w in res.warnings)


@pytest.mark.fast
def test_rpm_or_a_given_lag_wins_over_the_data() -> None:
    acq = _acquisitions(6)
    a = tribodyn.analyze(acq, fs=1000.0, window=2.0, hop=2.0, threads=1, rpm=228.0)
    assert a.params["iv_lag_rule"] == "rpm" and a.params["iv_lag_samples"] == round(60e3 / 228.0)
    b = tribodyn.analyze(acq, fs=1000.0, window=2.0, hop=2.0, threads=1, iv_lag=0.05)
    assert b.params["iv_lag_rule"] == "given" and b.params["iv_lag_samples"] == 50
    p = tribodyn.analyze(acq, fs=1000.0, window=2.0, hop=2.0, threads=1, method="paper")
    assert "iv_lag_rule" not in p.params


@pytest.mark.fast
def test_band_noise_pushes_the_lag_past_its_correlation_time() -> None:
    white = lag_profile(sample_windows(_acquisitions(30), None, 2000), 999)
    band = lag_profile(sample_windows(_acquisitions(30, z_noise="band"), None, 2000), 999)
    lw, lb = choose_lag(white, 0.3), choose_lag(band, 0.3)
    assert lw is not None and lb is not None
    # the band noise (20-200 Hz) is correlated over tens of samples: its short lags' IV slopes disagree
    assert lb > lw
    assert np.min(band.t[2 : lw + 1]) < -3.0
    assert abs(band.b[lb] / band.b[band.ref] - 1) < 0.02


@pytest.mark.fast
def test_a_profile_needs_windows_and_finite_correlations() -> None:
    z = [(np.zeros(100), np.zeros(100))] * 8
    assert lag_profile(z, 49) is None and choose_lag(None, 0.3) is None
    assert lag_profile(z[:3], 49) is None


@pytest.mark.fast
def test_reverse_slope_bounds_the_slope_from_above() -> None:
    rng = np.random.default_rng(0)
    n = 5000
    N = rng.standard_normal(n)
    z = N + 0.5 * rng.standard_normal(n)
    y = 0.1 * N + 0.02 * rng.standard_normal(n)
    E = np.zeros((1, BLOCKS, len(PRODUCTS)))
    at = {k: i for i, k in enumerate(PRODUCTS)}
    zc, yc = z - z.mean(), y - y.mean()
    for k in range(BLOCKS):
        s = slice(k * n // BLOCKS, (k + 1) * n // BLOCKS)
        E[0, k, at["zz"]] = zc[s] @ zc[s]
        E[0, k, at["zy"]] = zc[s] @ yc[s]
        E[0, k, at["yy"]] = yc[s] @ yc[s]
    b, se = reverse_slope(E)
    ols = (zc @ yc) / (zc @ zc)
    assert b[0] == pytest.approx((yc @ yc) / (zc @ yc))
    assert ols < 0.1 < b[0] and 0 < se[0] < b[0] - 0.1 + 0.05
