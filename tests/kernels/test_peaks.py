"""The stick-slip search's peaks are scipy.signal.find_peaks', index for index (docs/method.md 6g)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from tribodyn.kernels.peaks import find_peaks


def _signals(rng: np.random.Generator):
    n = 4000
    t = np.arange(n)
    yield rng.normal(size=n)
    yield np.round(rng.normal(size=n), 1)  # plateaus and ties
    yield np.round(np.cumsum(rng.normal(size=n)), 0)  # a quantised random walk: long flat runs
    saw = (t % 97) / 97.0 + 0.02 * rng.normal(size=n)  # stick-slip's sawtooth
    yield saw
    walls = saw.copy()
    walls[rng.choice(n, 25, replace=False)] = np.inf  # the separators between runs
    yield walls
    yield np.repeat(rng.normal(size=40), 100)  # wide plateaus
    yield np.zeros(n)
    yield rng.normal(size=3)
    yield np.array([1.0, 2.0])


@pytest.mark.fast
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_find_peaks_is_scipys(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for x in _signals(rng):
        for sign in (1.0, -1.0):
            y = np.where(np.isinf(x), np.inf, sign * x)  # the troughs' search keeps the walls at +inf
            for prom in (0.0, 0.05, 0.5, 2.0):
                for wlen in (3, 4, 11, 101, 10001):
                    want = signal.find_peaks(y, prominence=prom, wlen=wlen)[0]
                    got = find_peaks(y, prominence=prom, wlen=wlen)
                    np.testing.assert_array_equal(got, want, err_msg=f"prominence {prom}, wlen {wlen}")
                    assert got.dtype == np.int64


@pytest.mark.fast
def test_find_peaks_refuses_bad_arguments() -> None:
    with pytest.raises(ValueError, match="1-D"):
        find_peaks(np.zeros((3, 3)), prominence=0.1, wlen=3)
    with pytest.raises(ValueError, match="prominence"):
        find_peaks(np.zeros(5), prominence=float("nan"), wlen=3)
    with pytest.raises(ValueError, match="wlen"):
        find_peaks(np.zeros(5), prominence=0.1, wlen=-1)
