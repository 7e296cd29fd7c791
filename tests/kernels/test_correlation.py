"""Lagged correlation function, Eq. (1) (docs/method.md 1): the Rust kernels
against the NumPy reference and against their own contract.

Tolerances
----------
* direct vs FFT: 1e-10 absolute, the contract of docs/method.md 1. Both methods
  centre the inputs identically and share the denominators, so nothing
  data-dependent is allowed here.
* Rust vs reference: the two centre on means computed by different
  summations (lane-split in Rust, pairwise in NumPy), which may differ by an
  ulp or two of |mean|. Shifting the centred x by dx changes C(j) by at most
  about 2 (a + b) with a = |dx| sqrt(n_j / S_xx(j)) (Cauchy-Schwarz on the
  overlap sums; b likewise for y), so each lag gets
  ``atol_j = 1e-10 + 4 (a + b) (1 + a + b)`` with dx = 4 eps max|x|. That is
  the conditioning of C(j) itself: it is tiny unless the overlap barely
  varies around the global mean (large offsets on small-scale data, or the
  last one or two lags). The summation order adds at most about n eps, well
  under the 1e-10 floor.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import tribodyn as td
from hypothesis import example, given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from tribodyn import _core
from tribodyn.kernels import reference as ref


EPS = np.finfo(np.float64).eps

# Unit-scale samples; the tests scale and offset them. Subnormals excluded:
# they only exercise the FPU, not the kernels.
unit = st.floats(-1.0, 1.0, allow_nan=False, allow_subnormal=False)
scales = st.floats(-6.0, 6.0).map(lambda e: 10.0**e)  # 1e-6 .. 1e6
offsets = st.one_of(st.just(0.0), st.floats(-1e6, 1e6, allow_subnormal=False))


@st.composite
def signal_pair(draw, min_n: int = 2, max_n: int = 200):
    """(x, y, max_lag, kind): scaled, offset signals; sometimes constant."""
    n = draw(st.integers(min_n, max_n))
    x = draw(arrays(np.float64, n, elements=unit)) * draw(scales) + draw(offsets)
    y = draw(arrays(np.float64, n, elements=unit)) * draw(scales) + draw(offsets)
    kind = draw(st.sampled_from(["random", "constant_x", "constant_y", "related"]))
    if kind == "constant_x":
        x = np.full(n, x[0])
    elif kind == "constant_y":
        y = np.full(n, y[-1])
    elif kind == "related":
        y = 3.0 * x[::-1] - 2.0  # strongly correlated at some lags
    max_lag = draw(st.one_of(st.just(n - 1), st.integers(0, n - 1)))
    return x, y, max_lag


def shift_atol(x: np.ndarray, y: np.ndarray, lags: np.ndarray) -> np.ndarray:
    """Per-lag tolerance for means differing by a few ulps (module docstring)."""
    n = x.size
    xc, yc = x - ref.mean(x), y - ref.mean(y)
    dx, dy = 4 * EPS * np.max(np.abs(x)), 4 * EPS * np.max(np.abs(y))
    out = np.empty(lags.size)
    with np.errstate(divide="ignore", invalid="ignore"):
        for k, j in enumerate(lags):
            a_ = xc[max(0, -j) : min(n, n - j)]
            b_ = yc[max(0, j) : min(n, n + j)]
            nj = a_.size
            a = dx * np.sqrt(nj / (a_ @ a_))
            b = dy * np.sqrt(nj / (b_ @ b_))
            out[k] = 1e-10 + 4 * (a + b) * (1 + a + b)
    return np.nan_to_num(out, nan=np.inf, posinf=np.inf)


def assert_same_nan(a: np.ndarray, b: np.ndarray) -> None:
    np.testing.assert_array_equal(np.isnan(a), np.isnan(b))


# -- direct == FFT ----------------------------------------------------------------


@pytest.mark.fast
@given(signal_pair(max_n=300))
@example((np.array([1.0, 2.0]), np.array([0.5, -3.0]), 1))
@example((np.array([1.0, 2.0, 4.0]), np.array([0.5, -3.0, 7.0]), 2))
@example((np.array([1e6, 1e6 + 1e-6, 1e6]), np.array([1e-6, 0.0, 3e-6]), 2))
def test_direct_equals_fft(case):
    x, y, max_lag = case
    d = td.xcorr(x, y, max_lag=max_lag, method="direct")
    f = td.xcorr(x, y, max_lag=max_lag, method="fft")
    assert d.method == "direct" and f.method == "fft"
    np.testing.assert_array_equal(d.lags, f.lags)
    assert_same_nan(d.c, f.c)
    np.testing.assert_allclose(f.c, d.c, rtol=0, atol=1e-10, equal_nan=True)


@pytest.mark.fast
@pytest.mark.parametrize("n", [2, 3, 4, 5, 64, 1000, 4097])
def test_direct_equals_fft_full_lag_range(n):
    rng = np.random.default_rng(n)
    x = np.cumsum(rng.standard_normal(n)) + 1e3  # red noise: energy unevenly spread
    y = rng.standard_normal(n) * 1e-3
    y[n // 2] = 50.0  # a spike: most lags overlap little of y's energy
    d = td.xcorr(x, y, method="direct").c
    f = td.xcorr(x, y, method="fft").c
    assert d.size == 2 * n - 1
    np.testing.assert_allclose(f, d, rtol=0, atol=1e-10)


@pytest.mark.fast
def test_auto_reports_the_method_it_ran():
    rng = np.random.default_rng(0)
    for n, lag in [(10, 9), (5000, 3), (5000, 4999), (2, 0)]:
        x, y = rng.standard_normal(n), rng.standard_normal(n)
        res = td.xcorr(x, y, max_lag=lag)
        assert res.method == _core.xcorr_auto_method(n, lag)
        assert res.method in ("direct", "fft")
        np.testing.assert_allclose(res.c, td.xcorr(x, y, max_lag=lag, method="direct").c, rtol=0, atol=1e-10)


# -- Rust == reference ----------------------------------------------------------


@given(signal_pair())
@example((np.array([1.0, 2.0]), np.array([3.0, 3.0]), 1))
@example((np.array([7.0, 7.0, 7.0]), np.array([1.0, 0.0, 2.0]), 2))
@example((np.full(3, 1e6), np.full(3, -1e-6), 2))
def test_xcorr_matches_reference(case):
    x, y, max_lag = case
    want = ref.xcorr(x, y, max_lag=max_lag)
    for method in ("direct", "fft", "auto"):
        got = td.xcorr(x, y, max_lag=max_lag, method=method)
        np.testing.assert_array_equal(got.lags, want.lags)
        assert got.lags.dtype == np.int64 and got.c.dtype == np.float64
        assert_same_nan(got.c, want.c)
        ok = np.isnan(want.c) | (np.abs(got.c - want.c) <= shift_atol(x, y, want.lags))
        assert ok.all(), (method, got.c[~ok], want.c[~ok])
        assert np.all(np.isnan(got.c) | (np.abs(got.c) <= 1.0))
    if np.ptp(x) == 0 or np.ptp(y) == 0:  # a constant input: NaN at every lag
        assert np.isnan(want.c).all()


@given(signal_pair())
def test_pearson_matches_reference(case):
    x, y, _ = case
    want = ref.pearson(x, y)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", td.ConstantInputWarning)
        got = td.pearson(x, y)
    assert isinstance(got, float)
    if np.isnan(want):
        assert np.isnan(got)
    else:
        assert abs(got - want) <= shift_atol(x, y, np.array([0]))[0]


@pytest.mark.fast
def test_constant_input_gives_nan_and_warns():
    x = np.full(10, 0.1)
    y = np.arange(10.0)
    for a, b in [(x, y), (y, x), (x, x)]:
        with pytest.warns(td.ConstantInputWarning, match="constant"):
            assert np.isnan(td.pearson(a, b))
        assert np.isnan(ref.pearson(a, b))
        for method in ("direct", "fft"):
            assert np.isnan(td.xcorr(a, b, max_lag=4, method=method).c).all()


@pytest.mark.fast
def test_zero_overlap_variance_is_nan_not_error():
    # Centred x is [0, 0, -1, 1]: the overlaps of the first two samples only
    # have S_xx = 0 (NaN there), the rest is defined.
    x = np.array([1.0, 1.0, 0.0, 2.0])
    y = np.array([0.5, -1.0, 2.0, 3.0])
    for method in ("direct", "fft"):
        c = td.xcorr(x, y, method=method).c
        cr = ref.xcorr(x, y).c
        assert_same_nan(c, cr)
        assert np.isnan(c).any() and not np.isnan(c).all()
        np.testing.assert_allclose(c, cr, atol=1e-12, equal_nan=True)


# -- properties of Eq. (1) ------------------------------------------------------


@pytest.mark.fast
@given(
    n=st.integers(64, 400),
    frac=st.floats(0.0, 0.25),
    seed=st.integers(0, 2**32 - 1),
    method=st.sampled_from(["direct", "fft", "auto"]),
)
@example(n=64, frac=0.0, seed=0, method="fft")
def test_delayed_copy_peaks_at_plus_d(n, frac, seed, method):
    rng = np.random.default_rng(seed)
    d = int(frac * n)
    x = rng.standard_normal(n) + 5.0
    y = np.empty(n)
    y[d:] = x[: n - d]  # y_i = x_{i-d}: y is x delayed by d samples
    y[:d] = rng.standard_normal(d) + 5.0
    res = td.xcorr(x, y, max_lag=n // 2, method=method)
    assert res.peak_lag == d
    assert res.lags[np.argmax(res.c)] == d
    # Swapping the roles flips the sign of the lag (C_yx(j) = C_xy(-j)).
    assert td.xcorr(y, x, max_lag=n // 2, method=method).peak_lag == -d


@pytest.mark.fast
@given(signal_pair(max_n=120))
def test_swapping_inputs_reverses_lags(case):
    x, y, max_lag = case
    a = td.xcorr(x, y, max_lag=max_lag, method="direct").c
    b = td.xcorr(y, x, max_lag=max_lag, method="direct").c
    # Same products in the same order, except that at lag 0 the full sums of
    # squares come from a prefix sum for one input and a suffix sum for the
    # other: equal to the rounding of an n-term sum, n eps.
    np.testing.assert_allclose(a, b[::-1], rtol=0, atol=4 * x.size * EPS, equal_nan=True)
    lag0 = np.arange(a.size) != max_lag
    np.testing.assert_array_equal(a[lag0], b[::-1][lag0])
    f = td.xcorr(y, x, max_lag=max_lag, method="fft").c
    np.testing.assert_allclose(a, f[::-1], rtol=0, atol=1e-10)


@given(
    # Away from underflow: a spread below ~1e-154 squares to 0 in S_xx, so C
    # is NaN (in the reference too) where corrcoef, scaling first, is not.
    x=arrays(
        np.float64,
        st.integers(2, 300),
        elements=st.floats(-1e3, 1e3).filter(lambda v: v == 0 or abs(v) > 1e-100),
    ),
    seed=st.integers(0, 2**32 - 1),
)
def test_c0_equals_numpy_corrcoef(x, seed):
    y = 0.3 * x + np.random.default_rng(seed).standard_normal(x.size)
    with np.errstate(invalid="ignore", divide="ignore"):
        want = np.corrcoef(x, y)[0, 1]
    res = td.xcorr(x, y, max_lag=0)
    np.testing.assert_array_equal(res.lags, [0])
    if np.ptp(x) == 0:
        assert np.isnan(res.c[0])
        return
    # corrcoef centres with a one-pass mean: agreement to rounding only.
    np.testing.assert_allclose(res.c[0], want, rtol=0, atol=1e-12)
    np.testing.assert_allclose(td.pearson(x, y), want, rtol=0, atol=1e-12)


@pytest.mark.fast
@pytest.mark.parametrize("fs", [1.0, 1000.0, 3.3, np.float32(250.0), 7])
def test_tau_is_lags_over_fs(fs):
    x = np.sin(np.arange(50.0))
    y = np.cos(np.arange(50.0))
    res = td.xcorr(x, y, max_lag=10, fs=fs)
    np.testing.assert_array_equal(res.lags, np.arange(-10, 11))
    assert res.lags.dtype == np.int64
    assert res.tau is not None and res.tau.dtype == np.float64
    np.testing.assert_array_equal(res.tau, res.lags / float(fs))
    assert td.xcorr(x, y, max_lag=10).tau is None
    assert ref.xcorr(x, y, max_lag=10, fs=fs).tau is not None
    np.testing.assert_array_equal(ref.xcorr(x, y, max_lag=10, fs=fs).tau, res.tau)


@pytest.mark.fast
def test_default_max_lag_is_n_minus_1():
    x, y = np.arange(6.0), np.array([1.0, 0.0, 3.0, -1.0, 2.0, 5.0])
    res = td.xcorr(x, y)
    np.testing.assert_array_equal(res.lags, np.arange(-5, 6))
    # The outermost lags overlap one sample: C = sign(xc_0 * yc_5).
    assert abs(res.c[0]) == 1.0 and abs(res.c[-1]) == 1.0


@pytest.mark.fast
def test_result_is_frozen():
    res = td.xcorr([1.0, 2.0, 4.0], [3.0, 1.0, 0.0])
    with pytest.raises(AttributeError):
        res.c = np.zeros(5)  # type: ignore[misc]


@pytest.mark.fast
def test_all_nan_peak_lag_raises():
    res = td.xcorr(np.ones(5), np.arange(5.0), max_lag=2)
    with pytest.raises(ValueError, match="NaN at every lag"):
        _ = res.peak_lag
