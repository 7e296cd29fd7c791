"""Every bad argument raises the documented ``ValueError`` or ``TypeError``
(exactly that type: a Rust panic would surface as pyo3's PanicException, a
``BaseException``, and a NumPy error as some other class), and the inputs
the docs accept are accepted.
"""

from __future__ import annotations

import contextlib
import warnings

import numpy as np
import pytest
import tribodyn as td
from tribodyn import _core
from tribodyn.kernels import reference as ref


X = np.linspace(0.0, 1.0, 10) ** 2
Y = np.cos(np.arange(10.0))


@contextlib.contextmanager
def raises(exc: type, match: str):
    """pytest.raises that also insists on the exact class."""
    with pytest.raises(exc, match=match) as info:
        yield info
    assert type(info.value) is exc, f"{type(info.value).__module__}.{type(info.value).__name__}: {info.value}"


# (callable, exception, message pattern), for the fast path and the reference.
def bad_pairs(mod):
    return [
        ("unequal-lengths", lambda: mod.xcorr(X, Y[:5]), ValueError, "equal lengths"),
        ("empty", lambda: mod.xcorr([], []), ValueError, "at least 2 samples"),
        ("one-sample", lambda: mod.xcorr([1.0], [2.0]), ValueError, "at least 2 samples"),
        ("2-D", lambda: mod.xcorr(np.ones((2, 5)), np.ones((2, 5))), ValueError, "must be 1-D"),
        ("0-D", lambda: mod.xcorr(1.0, 2.0), ValueError, "must be 1-D"),
        ("strings", lambda: mod.xcorr(["a", "b"], ["c", "d"]), TypeError, "real numbers"),
        ("complex", lambda: mod.xcorr(X + 1j, Y), TypeError, "real numbers"),
        (
            "object",
            lambda: mod.xcorr(np.array(list(X), dtype=object), Y),
            TypeError,
            "real numbers",
        ),
        ("ragged", lambda: mod.xcorr([[1.0], [1.0, 2.0]], Y), TypeError, "array-like"),
        ("bytes", lambda: mod.xcorr(np.array([b"a", b"b"]), np.ones(2)), TypeError, "real numbers"),
        ("nan-x", lambda: mod.xcorr(np.r_[X[:-1], np.nan], Y), ValueError, "x contains NaN or inf"),
        ("inf-y", lambda: mod.xcorr(X, np.r_[-np.inf, Y[1:]]), ValueError, "y contains NaN or inf"),
        ("max_lag=n", lambda: mod.xcorr(X, Y, max_lag=10), ValueError, r"max_lag must be < n = 10"),
        ("max_lag<0", lambda: mod.xcorr(X, Y, max_lag=-1), ValueError, "max_lag must be >= 0"),
        (
            "max_lag-float",
            lambda: mod.xcorr(X, Y, max_lag=2.0),
            TypeError,
            "max_lag must be an integer",
        ),
        (
            "max_lag-bool",
            lambda: mod.xcorr(X, Y, max_lag=True),
            TypeError,
            "max_lag must be an integer",
        ),
        (
            "max_lag-str",
            lambda: mod.xcorr(X, Y, max_lag="3"),
            TypeError,
            "max_lag must be an integer",
        ),
        ("fs=0", lambda: mod.xcorr(X, Y, fs=0), ValueError, "fs must be a finite number > 0"),
        ("fs<0", lambda: mod.xcorr(X, Y, fs=-1000.0), ValueError, "fs must be a finite number > 0"),
        (
            "fs-nan",
            lambda: mod.xcorr(X, Y, fs=float("nan")),
            ValueError,
            "fs must be a finite number > 0",
        ),
        (
            "fs-inf",
            lambda: mod.xcorr(X, Y, fs=float("inf")),
            ValueError,
            "fs must be a finite number > 0",
        ),
        ("fs-str", lambda: mod.xcorr(X, Y, fs="1000"), TypeError, "fs must be a number"),
        ("pearson-unequal", lambda: mod.pearson(X, Y[:3]), ValueError, "equal lengths"),
        ("pearson-short", lambda: mod.pearson([1.0], [1.0]), ValueError, "at least 2 samples"),
        ("pearson-nan", lambda: mod.pearson(np.r_[np.nan, X[1:]], Y), ValueError, "NaN or inf"),
        ("pearson-complex", lambda: mod.pearson(X, Y * 1j), TypeError, "real numbers"),
        ("linfit-unequal", lambda: mod.linfit(X, Y[:3]), ValueError, "equal lengths"),
        ("linfit-empty", lambda: mod.linfit([], []), ValueError, "at least 1 samples"),
        (
            "linfit-2-D",
            lambda: mod.linfit(np.ones((2, 5)), np.ones((2, 5))),
            ValueError,
            "must be 1-D",
        ),
        ("linfit-0-D", lambda: mod.linfit(3.0, 4.0), ValueError, "must be 1-D"),
        (
            "linfit-nan",
            lambda: mod.linfit(np.r_[np.nan, X[1:]], Y),
            ValueError,
            "x contains NaN or inf",
        ),
        (
            "linfit-inf",
            lambda: mod.linfit(X, np.r_[Y[:-1], np.inf]),
            ValueError,
            "y contains NaN or inf",
        ),
        ("linfit-strings", lambda: mod.linfit(["a"] * 3, X[:3]), TypeError, "real numbers"),
        (
            "linfit-object",
            lambda: mod.linfit(X, np.array(list(Y), dtype=object)),
            TypeError,
            "real numbers",
        ),
        (
            "acc-unequal",
            lambda: mod.LinFitAccumulator().update(X, Y[:3]),
            ValueError,
            "equal lengths",
        ),
        (
            "acc-nan",
            lambda: mod.LinFitAccumulator().update(X, np.r_[np.nan, Y[1:]]),
            ValueError,
            "y contains NaN",
        ),
        (
            "acc-2-D",
            lambda: mod.LinFitAccumulator().update(np.ones((2, 2)), np.ones((2, 2))),
            ValueError,
            "1-D",
        ),
        (
            "acc-complex",
            lambda: mod.LinFitAccumulator().update(X * 1j, Y),
            TypeError,
            "real numbers",
        ),
        ("hp-fs=0", lambda: mod.HighPass(0), ValueError, "fs must be a finite number > 0"),
        ("hp-fs<0", lambda: mod.HighPass(-5.0), ValueError, "fs must be a finite number > 0"),
        (
            "hp-cutoff=fs/2",
            lambda: mod.HighPass(100.0, cutoff=50.0),
            ValueError,
            r"cutoff must be in \(0, fs/2\)",
        ),
        (
            "hp-cutoff>fs/2",
            lambda: mod.HighPass(100.0, cutoff=70.0),
            ValueError,
            r"cutoff must be in \(0, fs/2\)",
        ),
        (
            "hp-cutoff=0",
            lambda: mod.HighPass(100.0, cutoff=0.0),
            ValueError,
            "cutoff must be a finite number > 0",
        ),
        (
            "hp-cutoff<0",
            lambda: mod.HighPass(100.0, cutoff=-1.0),
            ValueError,
            "cutoff must be a finite number > 0",
        ),
        ("hp-cutoff-nan", lambda: mod.HighPass(100.0, cutoff=float("nan")), ValueError, "cutoff"),
        ("hp-order=0", lambda: mod.HighPass(100.0, order=0), ValueError, "order must be >= 1"),
        ("hp-order<0", lambda: mod.HighPass(100.0, order=-2), ValueError, "order must be >= 1"),
        (
            "hp-order-float",
            lambda: mod.HighPass(100.0, order=2.0),
            TypeError,
            "order must be an integer",
        ),
        (
            "sos-(2,5)",
            lambda: mod.HighPass(100.0, sos=np.ones((2, 5))),
            ValueError,
            r"shape \(n_sections, 6\)",
        ),
        (
            "sos-3-D",
            lambda: mod.HighPass(100.0, sos=np.ones((1, 2, 6))),
            ValueError,
            r"shape \(n_sections, 6\)",
        ),
        (
            "sos-empty",
            lambda: mod.HighPass(100.0, sos=np.ones((0, 6))),
            ValueError,
            r"shape \(n_sections, 6\)",
        ),
        ("sos-a0", lambda: mod.HighPass(100.0, sos=[[1.0, 0, 0, 2.0, 0, 0]]), ValueError, "a0 = 1"),
        (
            "sos-nan",
            lambda: mod.HighPass(100.0, sos=[[np.nan, 0, 0, 1.0, 0, 0]]),
            ValueError,
            "NaN or inf",
        ),
        (
            "sos-inf",
            lambda: mod.HighPass(100.0, sos=[[1.0, 0, 0, 1.0, np.inf, 0]]),
            ValueError,
            "NaN or inf",
        ),
        ("sos-strings", lambda: mod.HighPass(100.0, sos=[["a"] * 6]), TypeError, "real"),
        (
            "sos-complex",
            lambda: mod.HighPass(100.0, sos=np.array([[1 + 1j, 0, 0, 1, 0, 0]])),
            TypeError,
            "real",
        ),
        (
            "chunk-channels",
            lambda: mod.HighPass(100.0, channels=3).process(np.ones((2, 5))),
            ValueError,
            "channels",
        ),
        (
            "chunk-1-D-for-3",
            lambda: mod.HighPass(100.0, channels=3).process(np.ones(5)),
            ValueError,
            r"\(3, m\)",
        ),
        (
            "chunk-3-D",
            lambda: mod.HighPass(100.0).process(np.ones((1, 1, 5))),
            ValueError,
            "1-D or 2-D",
        ),
        ("chunk-0-D", lambda: mod.HighPass(100.0).process(3.0), ValueError, "1-D or 2-D"),
        ("chunk-nan", lambda: mod.HighPass(100.0).process([1.0, np.nan]), ValueError, "NaN or inf"),
        ("chunk-strings", lambda: mod.HighPass(100.0).process(["a"]), TypeError, "real numbers"),
        (
            "chunk-complex",
            lambda: mod.HighPass(100.0).process(np.ones(3) * 1j),
            TypeError,
            "real numbers",
        ),
        ("highpass-nan", lambda: mod.highpass([1.0, np.nan, 2.0], fs=100.0), ValueError, "NaN or inf"),
    ]


FAST_ONLY = [
    ("method", lambda: td.xcorr(X, Y, method="fast"), ValueError, "method must be"),
    ("hp-channels=0", lambda: td.HighPass(100.0, channels=0), ValueError, "channels must be >= 1"),
    (
        "hp-channels-float",
        lambda: td.HighPass(100.0, channels=1.5),
        TypeError,
        "channels must be an integer",
    ),
    (
        "hp-init",
        lambda: td.HighPass(100.0, init="warm"),
        ValueError,
        "init must be 'steady' or 'zero'",
    ),
    (
        "hp-pole-at-1",
        lambda: td.HighPass(100.0, sos=[[1.0, 0, 0, 1.0, -1.0, 0]]),
        ValueError,
        "pole at z = 1",
    ),
    (
        "state-shape",
        lambda: setattr(td.HighPass(100.0, order=4), "state", np.zeros((1, 1, 2))),
        ValueError,
        r"state must have shape \(1, 2, 2\)",
    ),
    (
        "state-channels",
        lambda: setattr(td.HighPass(100.0, channels=2), "state", np.zeros((1, 1, 2))),
        ValueError,
        "state must have shape",
    ),
    (
        "state-nan",
        lambda: setattr(td.HighPass(100.0), "state", np.full((1, 1, 2), np.nan)),
        ValueError,
        "state contains NaN",
    ),
    (
        "highpass-axis",
        lambda: td.highpass(np.ones((2, 5)), fs=100.0, axis=2),
        ValueError,
        "axis 2 is out of range",
    ),
    ("highpass-0-D", lambda: td.highpass(3.0, fs=100.0), ValueError, "at least one dimension"),
    ("highpass-strings", lambda: td.highpass(["a", "b"], fs=100.0), TypeError, "real numbers"),
    ("highpass-complex", lambda: td.highpass(np.ones(4) * 1j, fs=100.0), TypeError, "real numbers"),
    (
        "highpass-object",
        lambda: td.highpass(np.ones(4, dtype=object), fs=100.0),
        TypeError,
        "real numbers",
    ),
    ("highpass-fs", lambda: td.highpass(np.ones(4), fs=0.0), ValueError, "fs must be"),
    ("butter-cutoff", lambda: td.butter_highpass(10.0, cutoff=5.0), ValueError, "cutoff"),
    ("merge-type", lambda: td.LinFitAccumulator().merge(object()), TypeError, "LinFitAccumulator"),
]


@pytest.mark.fast
@pytest.mark.parametrize(
    "name, call, exc, match",
    bad_pairs(td) + FAST_ONLY,
    ids=lambda v: v if isinstance(v, str) and not v.startswith(("(", "\\")) else None,
)
def test_bad_input_raises(name, call, exc, match):
    with raises(exc, match):
        call()


@pytest.mark.fast
@pytest.mark.parametrize(
    "name, call, exc, match",
    bad_pairs(ref),
    ids=lambda v: v if isinstance(v, str) and not v.startswith(("(", "\\")) else None,
)
def test_reference_refuses_the_same(name, call, exc, match):
    with raises(exc, match):
        call()


@pytest.mark.fast
def test_failed_chunk_leaves_state_untouched():
    hp = td.HighPass(100.0, cutoff=1.0, order=2)
    x = np.sin(np.arange(200.0))
    want = td.HighPass(100.0, cutoff=1.0, order=2).process(x)
    first = hp.process(x[:100])
    with raises(ValueError, "NaN or inf"):
        hp.process(np.r_[x[100:150], np.nan])
    np.testing.assert_array_equal(np.concatenate([first, hp.process(x[100:])]), want)


# -- check_finite=False lets NaN and inf through ------------------------------------


@pytest.mark.fast
def test_check_finite_false_propagates_nan():
    xn = np.r_[X[:-1], np.nan]
    for method in ("direct", "fft"):
        c = td.xcorr(xn, Y, method=method, check_finite=False).c
        assert c.shape == (19,) and np.isnan(c).all()  # the global mean is NaN
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # NaN from NaN input: no ConstantInputWarning
        assert np.isnan(td.pearson(xn, Y, check_finite=False))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", td.DegenerateInputWarning)
        fit = td.linfit(xn, Y, check_finite=False)
    assert np.isnan(fit.slope) and fit.n == 10
    acc = td.LinFitAccumulator().update(X, np.r_[np.inf, Y[1:]], check_finite=False)
    assert acc.n == 10
    y = td.HighPass(100.0).process(np.r_[1.0, 2.0, np.nan, 3.0], check_finite=False)
    assert np.isfinite(y[:2]).all() and np.isnan(y[2:]).all()
    y = td.highpass(np.r_[1.0, np.inf], fs=100.0, check_finite=False)
    assert np.isfinite(y[0]) and not np.isfinite(y[1])
    assert np.isnan(ref.xcorr(xn, Y, check_finite=False).c).all()


# -- accepted inputs -------------------------------------------------------------------


ACCEPTED = {
    "float32": lambda a: a.astype(np.float32),
    "int64": lambda a: np.round(a * 100).astype(np.int64),
    "int8": lambda a: np.round(a * 100).astype(np.int8),
    "uint16": lambda a: np.round(a * 100 + 200).astype(np.uint16),
    "bool": lambda a: a > 0.3,
    "big-endian": lambda a: a.astype(">f8"),
    "strided": lambda a: np.repeat(a, 2)[::2],
    "reversed": lambda a: a[::-1][::-1].copy()[::-1],
    "list": lambda a: a.tolist(),
    "tuple": lambda a: tuple(a.tolist()),
    "read-only": lambda a: np.frombuffer(a.tobytes(), dtype=np.float64),
}


@pytest.mark.fast
@pytest.mark.parametrize("kind", list(ACCEPTED))
def test_accepted_inputs_equal_float64(kind):
    rng = np.random.default_rng(0)
    xa, ya = rng.standard_normal(64), rng.standard_normal(64)
    xv, yv = ACCEPTED[kind](xa), ACCEPTED[kind](ya)
    xf = np.array(xv, dtype=np.float64)  # what the library must see
    yf = np.array(yv, dtype=np.float64)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", td.ConstantInputWarning)
        warnings.simplefilter("ignore", td.DegenerateInputWarning)
        np.testing.assert_array_equal(td.xcorr(xv, yv, max_lag=7).c, td.xcorr(xf, yf, max_lag=7).c)
        assert td.pearson(xv, yv) == td.pearson(xf, yf) or np.isnan(td.pearson(xf, yf))
        assert td.linfit(xv, yv) == td.linfit(xf, yf) or td.linfit(xf, yf).degenerate
        acc = td.LinFitAccumulator().update(xv, yv)
        assert acc.result() == td.linfit(xf, yf) or acc.result().degenerate
    np.testing.assert_array_equal(td.HighPass(100.0).process(xv), td.HighPass(100.0).process(xf))
    np.testing.assert_array_equal(td.highpass(xv, fs=100.0), td.highpass(xf, fs=100.0))
    if isinstance(xv, np.ndarray):
        np.testing.assert_array_equal(np.asarray(xv), ACCEPTED[kind](xa))  # inputs untouched


@pytest.mark.fast
def test_fortran_ordered_2d_for_highpass():
    rng = np.random.default_rng(1)
    c = rng.standard_normal((3, 500)) + 2.0
    f = np.asfortranarray(c)
    assert not f.flags.c_contiguous
    want = td.highpass(c, fs=1000.0, order=2)
    np.testing.assert_array_equal(td.highpass(f, fs=1000.0, order=2), want)
    np.testing.assert_array_equal(td.HighPass(1000.0, order=2, channels=3).process(f), want)
    # Transposed (samples, channels) with axis=0: the same filter per channel.
    np.testing.assert_array_equal(td.highpass(c.T, fs=1000.0, order=2, axis=0), want.T)
    # A strided view of channels.
    big = rng.standard_normal((6, 1000))
    np.testing.assert_array_equal(td.highpass(big[::2, ::2], fs=10.0), td.highpass(big[::2, ::2].copy(), fs=10.0))


@pytest.mark.fast
def test_numpy_scalars_as_options():
    r = td.xcorr(X, Y, max_lag=np.int64(3), fs=np.float64(100.0))
    assert r.lags.size == 7
    np.testing.assert_array_equal(r.tau, r.lags / 100.0)
    hp = td.HighPass(np.float32(100.0), cutoff=np.float64(1.0), order=np.int32(2), channels=np.int64(1))
    assert hp.process(X).shape == (10,)


# -- the extension module itself never panics -------------------------------------------


SOS1 = np.array([[1.0, 0.0, 0.0, 1.0, 0.0, 0.0]])

CORE = [
    (
        "strided",
        lambda: _core.xcorr(np.arange(20.0)[::2], X, 3, "direct"),
        ValueError,
        "C-contiguous",
    ),
    ("int-array", lambda: _core.xcorr(np.arange(10), X, 3, "direct"), TypeError, ""),
    ("lag>=n", lambda: _core.xcorr(X, Y, 10, "fft"), ValueError, "max_lag must be in"),
    ("lag-huge", lambda: _core.xcorr(X, Y, 2**64 - 1, "direct"), ValueError, "max_lag"),
    ("lag<0", lambda: _core.xcorr(X, Y, -1, "direct"), OverflowError, ""),
    ("unequal", lambda: _core.xcorr(X, Y[:3], 1, "direct"), ValueError, "equal lengths"),
    ("short", lambda: _core.xcorr(X[:1], Y[:1], 0, "fft"), ValueError, "at least 2"),
    ("method", lambda: _core.xcorr(X, Y, 1, "bad"), ValueError, "method"),
    ("pearson-empty", lambda: _core.pearson(X[:0], Y[:0]), ValueError, "at least 2"),
    ("pearson-strided", lambda: _core.pearson(X[::2], Y[::2]), ValueError, "C-contiguous"),
    (
        "sos-cols",
        lambda: _core.sosfilt_inplace(np.ones((1, 5)), np.ones((1, 4)), np.zeros((1, 1, 2))),
        ValueError,
        "n_sections, 6",
    ),
    (
        "sos-none",
        lambda: _core.sosfilt_inplace(np.ones((0, 6)), np.ones((1, 4)), np.zeros((1, 0, 2))),
        ValueError,
        "at least one section",
    ),
    (
        "sos-a0",
        lambda: _core.sosfilt_inplace(np.array([[1.0, 0, 0, 2, 0, 0]]), np.ones((1, 4)), np.zeros((1, 1, 2))),
        ValueError,
        "a0 = 1",
    ),
    (
        "sos-nan",
        lambda: _core.sosfilt_inplace(np.array([[np.nan, 0, 0, 1, 0, 0]]), np.ones((1, 4)), np.zeros((1, 1, 2))),
        ValueError,
        "non-finite",
    ),
    (
        "state-shape",
        lambda: _core.sosfilt_inplace(SOS1, np.ones((2, 4)), np.zeros((1, 1, 2))),
        ValueError,
        "state must have shape",
    ),
    (
        "no-channels",
        lambda: _core.sosfilt_inplace(SOS1, np.ones((0, 4)), np.zeros((0, 1, 2))),
        ValueError,
        "channels",
    ),
    # Fortran order passed rust-numpy's as_slice and was read as C order.
    (
        "data-F-order",
        lambda: _core.sosfilt_inplace(SOS1, np.asfortranarray(np.ones((2, 4))), np.zeros((2, 1, 2))),
        ValueError,
        "C-contiguous",
    ),
    (
        "data-int",
        lambda: _core.sosfilt_inplace(SOS1, np.ones((1, 4), dtype=int), np.zeros((1, 1, 2))),
        TypeError,
        "",
    ),
    (
        "data-read-only",
        lambda: _core.sosfilt_inplace(SOS1, np.frombuffer(np.ones(4).tobytes()).reshape(1, 4), np.zeros((1, 1, 2))),
        TypeError,
        "not writeable",
    ),
    (
        "state-F-order",
        lambda: _core.sosfilt_inplace(SOS1, np.ones((2, 4)), np.asfortranarray(np.zeros((2, 1, 2)))),
        ValueError,
        "C-contiguous",
    ),
    (
        "into-x-F-order",
        lambda: _core.sosfilt_into(SOS1, np.asfortranarray(np.ones((2, 4))), np.zeros((2, 4)), np.zeros((2, 1, 2))),
        ValueError,
        "C-contiguous",
    ),
    (
        "into-out-F-order",
        lambda: _core.sosfilt_into(SOS1, np.ones((2, 4)), np.asfortranarray(np.zeros((2, 4))), np.zeros((2, 1, 2))),
        ValueError,
        "C-contiguous",
    ),
    (
        "into-out-shape",
        lambda: _core.sosfilt_into(SOS1, np.ones((2, 4)), np.zeros((2, 3)), np.zeros((2, 1, 2))),
        ValueError,
        "out must have the shape",
    ),
    (
        "into-state-shape",
        lambda: _core.sosfilt_into(SOS1, np.ones((2, 4)), np.zeros((2, 4)), np.zeros((1, 1, 2))),
        ValueError,
        "state must have shape",
    ),
    ("linfit-unequal", lambda: _core.linfit(X, Y[:2]), ValueError, "equal lengths"),
    ("moments-unequal", lambda: _core.Moments().update(X, Y[:2]), ValueError, "equal lengths"),
    ("moments-strided", lambda: _core.Moments().update(X[::2], Y[::2]), ValueError, "C-contiguous"),
    ("moments-merge", lambda: _core.Moments().merge(3), TypeError, "Moments"),
]


@pytest.mark.fast
@pytest.mark.parametrize("name, call, exc, match", CORE, ids=[c[0] for c in CORE])
def test_core_errors_are_exceptions_not_panics(name, call, exc, match):
    with pytest.raises(exc, match=match) as info:
        call()
    # pyo3 maps a panic to PanicException (a BaseException): never that.
    assert type(info.value).__name__ != "PanicException"
    assert isinstance(info.value, (ValueError, TypeError, OverflowError))


@pytest.mark.fast
def test_core_degenerate_input_is_a_value_not_an_error():
    assert _core.linfit(X[:0], Y[:0])[-1] is True  # empty: degenerate flag, no exception
    m = _core.Moments.from_state((0, 1.0, 1.0, -1.0, -1.0, 0.0, 0.0))
    assert np.isnan(m.fit()[0])
    assert _core.xcorr_auto_method(0, 0) in ("direct", "fft")
    assert _core.xcorr_auto_method(2**40, 2**39) == "fft"


@pytest.mark.fast
@pytest.mark.parametrize("shape", ["column", "row", "scalar"])
def test_analyze_of_channels_that_are_not_1d_names_the_shape(shape: str) -> None:
    """A mapping of 2-D or 0-d channels meets the pipeline's own shape error, whatever the pre-pass
    does with in-range forces first (its fast path looks at 1-D channels only)."""
    rng = np.random.default_rng(0)
    fz = np.r_[np.zeros(500), np.full(1000, 10.0), np.zeros(500)] + rng.normal(0.0, 0.01, 2000)
    shaped = {"column": lambda v: v[:, None], "row": lambda v: v[None, :], "scalar": lambda v: np.float64(v[700])}
    src = {"fy": shaped[shape](0.3 * fz), "fz": shaped[shape](fz)}
    with raises(ValueError, match="must be 1-D"):
        td.analyze(src, fs=1000.0)
