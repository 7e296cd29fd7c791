"""Streaming high-pass filter (docs/method.md 2).

The Rust recurrence performs the same floating-point operations in the same
order as ``scipy.signal.sosfilt`` (transposed direct form II), so:
* chunked vs one-shot, multi-channel vs per-channel, state round trips and
  reset are compared bitwise (``np.array_equal``): the arithmetic is ours on
  both sides and must not depend on how the signal is cut;
* against scipy, the contract is 1e-12 relative to the signal's size (scipy
  could be compiled with FMA contraction some day); today it is bitwise,
  which is checked separately on the default design.
"""

from __future__ import annotations

import numpy as np
import pytest
import tribodyn as td
from hypothesis import example, given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy import signal
from tribodyn.kernels import reference as ref


finite = st.floats(-1e6, 1e6, allow_nan=False, allow_subnormal=False)


def scipy_filter(sos: np.ndarray, x: np.ndarray, init: str) -> np.ndarray:
    """The contract's definition: sosfilt along the last axis with zi per channel."""
    x2 = np.atleast_2d(x)
    if x2.shape[-1] == 0:
        return np.array(x, dtype=float)
    x0 = x2[:, 0] if init == "steady" else np.zeros(x2.shape[0])
    zi = signal.sosfilt_zi(sos)[:, None, :] * x0[None, :, None]
    y, _ = signal.sosfilt(sos, x2, axis=-1, zi=zi)
    return y.reshape(np.shape(x))


def assert_close_to_scipy(got: np.ndarray, want: np.ndarray, x: np.ndarray) -> None:
    scale = max(float(np.max(np.abs(x), initial=0.0)), 1e-300)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * scale)


@st.composite
def filter_case(draw):
    channels = draw(st.integers(1, 3))
    n = draw(st.integers(0, 300))
    x = draw(arrays(np.float64, (channels, n), elements=finite))
    x = x + draw(st.floats(-1e3, 1e3))  # a DC part, as in a DC-coupled signal
    fs = draw(st.sampled_from([1.0, 100.0, 1000.0, 25600.0]))
    cutoff = fs * draw(st.floats(1e-5, 0.45))
    order = draw(st.integers(1, 4))
    init = draw(st.sampled_from(["steady", "zero"]))
    return x, fs, cutoff, order, init


@st.composite
def chunk_sizes(draw, n: int):
    """Sizes summing to n, rich in empty and one-sample chunks."""
    sizes = []
    left = n
    while left > 0 and len(sizes) < 40:
        k = draw(st.one_of(st.integers(0, 1), st.integers(0, min(left, 3)), st.integers(0, left)))
        sizes.append(k)
        left -= k
    sizes.append(left)
    if draw(st.booleans()):
        sizes.insert(0, 0)  # an empty first chunk: "steady" must wait for a sample
    return sizes


# -- against scipy.signal ---------------------------------------------------------


@pytest.mark.fast
@given(filter_case())
@example((np.array([[3.0, 1.0]]), 1000.0, 0.1, 1, "steady"))
@example((np.array([[3.0]]), 1000.0, 0.1, 2, "zero"))
def test_matches_scipy_sosfilt(case):
    x, fs, cutoff, order, init = case
    sos = signal.butter(order, cutoff, "highpass", fs=fs, output="sos")
    hp = td.HighPass(fs, cutoff=cutoff, order=order, channels=x.shape[0], init=init)
    np.testing.assert_array_equal(hp.sos, sos)
    y = hp.process(x)
    assert y.shape == x.shape and y.dtype == np.float64
    assert_close_to_scipy(y, scipy_filter(sos, x, init), x)
    # The one-shot function and the reference agree too.
    assert_close_to_scipy(td.highpass(x, fs=fs, cutoff=cutoff, order=order, init=init), y, x)
    r = ref.HighPass(fs, cutoff=cutoff, order=order, channels=x.shape[0], init=init).process(x)
    assert_close_to_scipy(r, y, x)
    np.testing.assert_array_equal(ref.highpass(x, fs, cutoff=cutoff, order=order, init=init), r)


@pytest.mark.fast
@pytest.mark.parametrize("order", [1, 2, 3, 4])
@pytest.mark.parametrize("init", ["steady", "zero"])
def test_bitwise_equal_to_scipy_today(order, init):
    rng = np.random.default_rng(order)
    x = rng.standard_normal((3, 5000)) + 2.5
    sos = td.butter_highpass(1000.0, cutoff=0.1, order=order)
    np.testing.assert_array_equal(sos, signal.butter(order, 0.1, "highpass", fs=1000.0, output="sos"))
    hp = td.HighPass(1000.0, order=order, channels=3, init=init)
    y = hp.process(x)
    np.testing.assert_array_equal(y, scipy_filter(sos, x, init))
    # The carried state is scipy's zf, in (channels, n_sections, 2) layout.
    x0 = x[:, 0] if init == "steady" else np.zeros(3)
    _, zf = signal.sosfilt(sos, x, zi=signal.sosfilt_zi(sos)[:, None, :] * x0[None, :, None])
    np.testing.assert_array_equal(hp.state, np.moveaxis(zf, 1, 0))
    assert hp.state.shape == (3, sos.shape[0], 2)


@pytest.mark.fast
@pytest.mark.parametrize(
    "sos",
    [
        signal.cheby1(4, 0.5, 10.0, "highpass", fs=1000.0, output="sos"),
        signal.butter(3, [5.0, 80.0], "bandpass", fs=1000.0, output="sos"),
        signal.ellip(5, 0.1, 60.0, 0.2, "lowpass", output="sos"),
        np.array([[0.5, 0.1, 0.0, 1.0, -0.3, 0.0]]),
    ],
    ids=["cheby1-hp", "butter-bp", "ellip-lp", "first-order"],
)
@pytest.mark.parametrize("init", ["steady", "zero"])
def test_custom_sos(sos, init):
    rng = np.random.default_rng(7)
    x = rng.standard_normal((2, 3000)) - 4.0
    hp = td.HighPass(1000.0, sos=sos, channels=2, init=init)
    y = hp.process(x)
    np.testing.assert_array_equal(hp.sos, sos)
    assert hp.n_sections == sos.shape[0]
    assert_close_to_scipy(y, scipy_filter(sos, x, init), x)
    np.testing.assert_array_equal(td.highpass(x, fs=1000.0, sos=sos, init=init), y)
    np.testing.assert_array_equal(ref.HighPass(1000.0, sos=sos, channels=2, init=init).process(x), y)


@pytest.mark.fast
def test_pole_at_one_needs_zero_init():
    # An integrator has no steady state; with init="zero" it is a valid filter.
    integ = [[1.0, 0.0, 0.0, 1.0, -1.0, 0.0]]
    hp = td.HighPass(10.0, sos=integ, init="zero")
    np.testing.assert_array_equal(hp.process([1.0, 2.0, 3.0]), [1.0, 3.0, 6.0])
    with pytest.raises(ValueError, match="pole at z = 1"):
        td.HighPass(10.0, sos=integ)


# -- streaming ----------------------------------------------------------------------


@given(filter_case(), st.data())
def test_any_chunking_equals_one_shot(case, data):
    x, fs, cutoff, order, init = case
    channels, n = x.shape
    whole = td.HighPass(fs, cutoff=cutoff, order=order, channels=channels, init=init).process(x)
    hp = td.HighPass(fs, cutoff=cutoff, order=order, channels=channels, init=init)
    rhp = ref.HighPass(fs, cutoff=cutoff, order=order, channels=channels, init=init)
    parts, rparts, start = [], [], 0
    for k in data.draw(chunk_sizes(n)):
        chunk = x[:, start : start + k]
        out = hp.process(chunk)
        assert out.shape == chunk.shape
        parts.append(out)
        rparts.append(rhp.process(chunk))
        start += k
    assert start == n
    np.testing.assert_array_equal(np.concatenate(parts, axis=1), whole)
    np.testing.assert_array_equal(np.concatenate(rparts, axis=1), whole)
    if channels == 1:  # 1-D chunks of a one-channel filter: same again
        hp1 = td.HighPass(fs, cutoff=cutoff, order=order, init=init)
        out1 = [hp1.process(x[0, a:b]) for a, b in [(0, n // 3), (n // 3, n // 3), (n // 3, n)]]
        assert all(o.ndim == 1 for o in out1)
        np.testing.assert_array_equal(np.concatenate(out1), whole[0])


@pytest.mark.fast
@given(filter_case())
def test_multichannel_equals_per_channel(case):
    x, fs, cutoff, order, init = case
    together = td.HighPass(fs, cutoff=cutoff, order=order, channels=x.shape[0], init=init).process(x)
    for c in range(x.shape[0]):
        alone = td.HighPass(fs, cutoff=cutoff, order=order, init=init).process(x[c])
        np.testing.assert_array_equal(together[c], alone)


@pytest.mark.fast
@pytest.mark.parametrize("channels", [1, 2, 3, 4, 5, 8, 9])
def test_many_channels_equal_per_channel(channels):
    # Channels are filtered in lockstep groups of up to 4 over the thread
    # pool: the grouping must not change any channel.
    rng = np.random.default_rng(channels)
    x = rng.standard_normal((channels, 4500)) + np.arange(channels)[:, None]
    y = td.HighPass(1000.0, order=2, channels=channels).process(x)
    for c in range(channels):
        np.testing.assert_array_equal(y[c], td.HighPass(1000.0, order=2).process(x[c]))


@pytest.mark.fast
@pytest.mark.parametrize("order", [1, 2, 4])
def test_steady_init_removes_dc_transient(order):
    fs = 1000.0
    t = np.arange(int(2 * fs)) / fs
    x = 5.0 + 0.01 * np.sin(2 * np.pi * 10.0 * t)  # a big DC part, a small signal
    steady = td.highpass(x, fs=fs, order=order)
    zero = td.highpass(x, fs=fs, order=order, init="zero")
    # "steady": the output starts near 0 and stays at the sine's size. (Not
    # exactly 0: scipy's sosfilt_zi solves a system whose condition grows as
    # (fs / cutoff)^2 for the poles near z = 1; ~1e-9 of the DC level.)
    assert abs(steady[0]) < 1e-6 * 5.0
    assert np.max(np.abs(steady)) < 0.02
    # "zero": the filter sees a step of 5; its output starts near the
    # constant and decays only with the 0.1 Hz time constant.
    assert abs(zero[0] - 5.0) < 0.01
    assert np.all(zero[: int(0.1 * fs)] > 4.0)
    if order == 1:  # a plain RC decay: still above 5 exp(-2 pi 0.1) after 1 s
        assert np.all(zero[: int(fs)] > 2.6)
    # An exactly constant input stays at (numerically) 0 with "steady".
    assert np.max(np.abs(td.highpass(np.full(3000, -7.25), fs=fs, order=order))) < 1e-6 * 7.25


@pytest.mark.fast
def test_state_round_trip_resumes_identically():
    rng = np.random.default_rng(3)
    x = rng.standard_normal((3, 2000)) + 1.0
    full = td.HighPass(500.0, cutoff=1.0, order=3, channels=3).process(x)
    a = td.HighPass(500.0, cutoff=1.0, order=3, channels=3)
    first = a.process(x[:, :700])
    saved = a.state
    assert saved.shape == (3, 2, 2)  # order 3: two sections
    saved_copy = saved.copy()
    saved[...] = 1e9  # the getter returns a copy: the filter is unaffected
    # A fresh filter (either init) given the state continues exactly.
    for init in ("steady", "zero"):
        b = td.HighPass(500.0, cutoff=1.0, order=3, channels=3, init=init)
        b.state = saved_copy
        np.testing.assert_array_equal(np.concatenate([first, b.process(x[:, 700:])], axis=1), full)
    np.testing.assert_array_equal(a.process(x[:, 700:]), full[:, 700:])
    # Setting the state from a list works (it is converted).
    c = td.HighPass(500.0, cutoff=1.0, order=3, channels=3)
    c.state = saved_copy.tolist()
    np.testing.assert_array_equal(c.process(x[:, 700:]), full[:, 700:])


@pytest.mark.fast
def test_state_before_first_chunk():
    hp = td.HighPass(1000.0, order=4)
    np.testing.assert_array_equal(hp.state, np.zeros((1, 2, 2)))
    hp.process(np.empty(0))  # an empty chunk does not fix the steady state
    np.testing.assert_array_equal(hp.state, np.zeros((1, 2, 2)))
    y = hp.process([4.0, 4.0, 4.0])
    assert np.max(np.abs(y)) < 1e-6 * 4.0
    # A constant input keeps the steady state (to the rounding of the zi solve).
    np.testing.assert_allclose(hp.state[0], signal.sosfilt_zi(hp.sos) * 4.0, rtol=1e-9, atol=1e-9 * 4.0)


@pytest.mark.fast
def test_reset_starts_a_new_signal():
    rng = np.random.default_rng(4)
    x, other = rng.standard_normal(1500) + 3.0, rng.standard_normal(900) - 8.0
    for init in ("steady", "zero"):
        hp = td.HighPass(1000.0, cutoff=2.0, order=4, init=init)
        first = hp.process(x)
        hp.process(other)
        hp.reset()
        np.testing.assert_array_equal(hp.state, np.zeros((1, 2, 2)))
        np.testing.assert_array_equal(hp.process(x), first)


@pytest.mark.fast
def test_process_does_not_modify_its_input():
    x = np.linspace(0.0, 1.0, 100)
    keep = x.copy()
    td.HighPass(100.0).process(x)
    td.highpass(x, fs=100.0)
    np.testing.assert_array_equal(x, keep)


@pytest.mark.fast
def test_empty_chunks_and_signals():
    hp = td.HighPass(100.0, channels=2)
    out = hp.process(np.empty((2, 0)))
    assert out.shape == (2, 0) and out.dtype == np.float64
    assert td.highpass(np.empty(0), fs=100.0).shape == (0,)
    assert td.highpass(np.empty((0, 5)), fs=100.0).shape == (0, 5)


@pytest.mark.fast
@pytest.mark.parametrize("axis", [0, 1, 2, -1, -2])
def test_highpass_axis(axis):
    rng = np.random.default_rng(5)
    x = rng.standard_normal((3, 4, 50)) + 1.0
    y = td.highpass(x, fs=100.0, cutoff=3.0, order=2, axis=axis)
    assert y.shape == x.shape
    want = np.moveaxis(
        scipy_filter(
            td.butter_highpass(100.0, cutoff=3.0, order=2),
            np.moveaxis(x, axis, -1).reshape(-1, x.shape[axis]),
            "steady",
        ).reshape(np.moveaxis(x, axis, -1).shape),
        -1,
        axis,
    )
    np.testing.assert_array_equal(y, want)
    np.testing.assert_array_equal(ref.highpass(x, 100.0, cutoff=3.0, order=2, axis=axis), y)
