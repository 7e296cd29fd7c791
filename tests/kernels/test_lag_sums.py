"""The windows' kernel's instrument sums at extra lags (column ``lag_sums``; docs/method.md 3d, issue 35 point 3)."""

from __future__ import annotations

import numpy as np
import pytest
from tribodyn import _core
from tribodyn.kernels.deadband import parse_deadband
from tribodyn.kernels.window_stats import make_spec


def _forces(n: int, seed: int = 35) -> tuple:
    rng = np.random.default_rng(seed)
    t = np.arange(n)
    fz = 10.0 + np.sin(0.013 * t) + 0.3 * rng.standard_normal(n)
    fy = 0.1 * fz + 0.02 * rng.standard_normal(n)
    return fy, fz


def _numpy_sums(fy: np.ndarray, fz: np.ndarray, lag: int) -> tuple:
    """[S_wz, S_wy] of one window, w = fz lagged by ``lag`` (fz_{t+L} before L), all centred (docs/method.md 3b)."""
    n = fz.size
    if n <= 2 * lag:
        return float("nan"), float("nan")
    w = np.where(np.arange(n) >= lag, np.roll(fz, lag), np.roll(fz, -lag))
    wc, zc, yc = w - w.mean(), fz - fz.mean(), fy - fy.mean()
    return float(np.sum(wc * zc)), float(np.sum(wc * yc))


@pytest.mark.fast
def test_lag_sums_are_the_numpy_sums_on_every_thread_count_and_equal_ext_at_its_lag() -> None:
    fy, fz = _forces(20_000)
    lags = [9, 10, 13, 20, 700]
    starts = np.arange(0, 20_000 - 1000 + 1, 500, dtype=np.int64)  # overlapping windows, 1000 samples
    cols = ["n", "ext", "lag_sums"]
    got = {}
    for threads in (1, 2):
        spec = make_spec(1000, parse_deadband(0.0), 1, cols, options=dict(lag=10, lags=lags), threads=threads)
        got[threads] = _core.windows_stats(spec, None, fy, fz, None, starts)
    L = got[1]["lag_sums"]
    assert L.shape == (starts.size, len(lags), 2)
    np.testing.assert_array_equal(L, got[2]["lag_sums"])  # bit for bit on every thread count
    for k, s in enumerate(starts):
        for j, lag in enumerate(lags):
            want = _numpy_sums(fy[s : s + 1000], fz[s : s + 1000], lag)
            if lag == 700:  # the window cannot hold it: NaN, no error
                assert np.isnan(L[k, j]).all()
            else:
                np.testing.assert_allclose(L[k, j], want, rtol=1e-9, atol=1e-9)
    # at the block sums' own lag: the same S_wz, S_wy (products wz, wy summed over the blocks)
    from tribodyn.kernels.estimators import PRODUCTS

    E = got[1]["ext"]
    np.testing.assert_allclose(L[:, 1, 0], E[:, :, PRODUCTS.index("wz")].sum(axis=1), rtol=1e-10)
    np.testing.assert_allclose(L[:, 1, 1], E[:, :, PRODUCTS.index("wy")].sum(axis=1), rtol=1e-10, atol=1e-12)


@pytest.mark.fast
def test_lag_sums_need_one_to_eight_lags_of_at_least_one_sample() -> None:
    db = parse_deadband(0.0)
    for lags, match in (([], "1 to 8 extra lags"), (None, "1 to 8 extra lags"), (list(range(1, 10)), "1 to 8"),
                        ([3, 0], "at least 1 sample")):  # fmt: skip
        with pytest.raises(ValueError, match=match):
            make_spec(1000, db, 1, ["n", "lag_sums"], options=dict(lag=10, lags=lags))
    with pytest.raises(ValueError, match='"lags" must be'):
        make_spec(1000, db, 1, ["n", "lag_sums"], options=dict(lag=10, lags=[-1]))
    # not asked for: lags are not used and cost nothing
    fy, fz = _forces(3000)
    spec = make_spec(1000, db, 1, ["n", "ext"], options=dict(lag=10, lags=[12]))
    assert "lag_sums" not in _core.windows_stats(spec, None, fy, fz, None, np.array([0, 1000], dtype=np.int64))
