"""The per-window Rust kernel (``tribodyn.kernels.window_stats.compute``) against the
per-window NumPy reference (``tribodyn.kernels.reference.window_stats``), both at
orientation +1 (docs/method.md 3-5).

What is generated
-----------------
Window lengths 3..300 and window starts tiled, overlapping (sorted, any hop),
in random order with repeats, or reversed; forces drawn by
``hypothesis.extra.numpy.arrays`` (floats in [-50, 50], mixed with exact
zeros and the deadband's +-d) or, for long recordings, from a seeded NumPy
generator (uniform, sinusoid + noise, small integers full of ties, a large
offset); with or without fx, an auxiliary channel, raw forces; force and
sigma deadbands. Dedicated tests cover degenerate windows (constant fz,
constant fy, length 3), a deadband that excludes every sample, fz exactly on
the bin edges (and on the maximum), lengths 1 and 2, and that a pool of
threads and the calling thread give the same bits. Every statistic both
sides know is asked of the kernel (``COMPARED``), not only its defaults.

Tolerances
----------
Every float is compared with ``rtol = 1e-9`` plus an ``atol`` of 1e-9 in the
quantity's natural unit for its window, so that a value near zero (an
uncorrelated slope, an intercept, a perfect fit's residuals) is not held to
a relative error it cannot have. With sy = sqrt(S_yy) + n eps max|fy| and
sz = sqrt(S_zz) + n eps max|fz| (the spread of a channel, plus what an
ulp's error in its centre leaves of a constant channel: the kernel then
gives a slope or S_yz of 1e-30 where the reference gives 0): slope and its
standard error in sy / sqrt(S_zz); intercept in max|fy| + that times
max|fz|; r and the Pearson coefficients absolutely; S_yz in sy sz; SSE in
sy^2; resid_std in sy / sqrt(n - 2); mu_a, mu_b, bin_cof in max |fy/fz| over
the window's kept samples; means and extremes in max|channel|. Both sides
centre with two passes (the kernel in fixed lanes with the Chan et al.
correction, the reference in NumPy's order), so they differ by a few ulps
times n in those units (measured: every test still passes with 1e-14 in
place of 1e-9); a real error is far larger. S_zz, S_yy, the
deadband and mu_classic are relative only (so a constant channel must give
exactly S = 0 on both sides). NaN positions must match
exactly; counts (n, n_a, n_b, bin_count) must be equal.

With the sigma deadband, d = k sd(fz) is itself rounded differently on the
two sides, so a window with a sample within 1e-12 of d (relative) is skipped
(``assume``): which side of d such a sample falls on is a coin toss.
"""

from __future__ import annotations

import os

import numpy as np
import pytest
from hypothesis import assume, currently_in_test_context, given, note
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from tribodyn import _core
from tribodyn.columns import KERNEL_COLUMNS, kernel_columns
from tribodyn.kernels import reference as ref
from tribodyn.kernels.deadband import parse_deadband
from tribodyn.kernels.window_stats import compute as compute_spec
from tribodyn.kernels.window_stats import make_spec


def compute(fx, fy, fz, aux, starts, length, db, n_bins, columns=None, *, raw=None, threads=None):
    """``window_stats.compute`` with its spec made for the call (the reference's argument order)."""
    spec = make_spec(length, db, n_bins, columns, raw=raw is not None, threads=threads)
    return compute_spec(spec, fy, fz, np.asarray(starts, dtype=np.int64), fx=fx, aux=aux, raw=raw)


TOL = 1e-9
EPS = np.finfo(np.float64).eps
INT_KEYS = ("n", "n_a", "n_b", "out_of_range", "bin_count")


def _kernel_names():
    """The reference's keys that the kernel can deliver (its vocabulary may shrink)."""
    fz = np.linspace(-1.0, 2.0, 8)
    names = []
    for key in ref.window_stats(None, fz, fz, None, [0], length=8, deadband=0.35, n_bins=2):
        try:
            compute(None, fz, fz, None, np.array([0]), 8, parse_deadband(0.35), 2, [key])
        except ValueError as e:
            assert "column" in str(e), e
        else:
            names.append(key)
    return tuple(names)


#: Every statistic both sides compute: all are asked of the kernel.
COMPARED = _kernel_names()
#: Thread counts a call may name (the kernel allows up to 4 x the cores).
MAX_THREADS = min(8, 4 * (os.cpu_count() or 1))


# -- Comparison ---------------------------------------------------------------------


def _windows(x, starts, length):
    return np.array([np.asarray(x[s : s + length], dtype=float) for s in starts]).reshape(len(starts), length)


def _units(fy, fz, aux, starts, length, want):
    """Per window (shape (m,) or (m, 1)), the natural unit of every float key."""
    y, z = _windows(fy, starts, length), _windows(fz, starts, length)
    ay, az = np.abs(y).max(axis=1), np.abs(z).max(axis=1)
    szz, syy = want["szz"], want["syy"]
    n = length
    # A channel's centre is off by about an ulp of its values, eps max|v|;
    # times the rounding of a sum of n deviations that leaves about
    # n eps max|v| of spread in a constant channel: sy, sz below.
    sy, sz = np.sqrt(syy) + n * EPS * ay, np.sqrt(szz) + n * EPS * az
    with np.errstate(invalid="ignore", divide="ignore"):
        sp = np.where(szz > 0, sy / np.sqrt(szz), 0.0)
        d = want["deadband"][:, None]
        keep = (np.abs(z) >= d) & (z != 0)
        ratio = np.where(keep, np.abs(y / np.where(z != 0, z, 1.0)), 0.0).max(axis=1)
    mz = np.abs(want["mean_z"])
    zero = np.zeros(len(starts))
    units = {
        "slope": sp,
        "intercept": ay + sp * az,
        "r": np.ones_like(sp),
        "slope_stderr": sp,
        "intercept_stderr": sp * (np.sqrt(szz / n) + mz),
        "resid_std": sy / np.sqrt(max(n - 2, 1)),
        "sse": sy * sy,
        "mean_z": az,
        "mean_y": ay,
        "szz": zero,
        "syy": zero,
        "syz": sz * sy,
        "c_xy": np.ones_like(sp),
        "c_xz": np.ones_like(sp),
        "c_yz": np.ones_like(sp),
        "deadband": zero,
        "mu_a": ratio,
        "mu_b": ratio,
        "fz_min": az,
        "fz_max": az,
        "aux_mean": np.abs(_windows(aux, starts, length)).max(axis=1) if aux is not None else zero,
        "mu_classic": zero,
        "bin_cof": ratio[:, None],
    }
    return units


def assert_matches(got, want, fy, fz, aux, starts, length):
    """The kernel's dict ``got`` equals the reference's ``want`` (module docs)."""
    keys = sorted(set(got) & set(want))
    assert keys, "the kernel and the reference share no key"
    units = _units(fy, fz, aux, starts, length, want)
    m = len(starts)
    for key in keys:
        a, b = np.asarray(got[key]), np.asarray(want[key])
        assert a.shape == b.shape, f"{key}: shape {a.shape} != {b.shape}"
        assert a.shape[0] == m
        if key in INT_KEYS:
            assert a.dtype.kind in "iu", f"{key}: dtype {a.dtype}"
            np.testing.assert_array_equal(a, b, err_msg=key)
            continue
        nan_a, nan_b = np.isnan(a), np.isnan(b)
        if not np.array_equal(nan_a, nan_b):
            rows = np.flatnonzero((nan_a != nan_b).reshape(m, -1).any(axis=1))
            raise AssertionError(
                f"{key}: NaN positions differ in windows {rows.tolist()} (starts {np.asarray(starts)[rows].tolist()}):"
                f" kernel {a[rows].tolist()} reference {b[rows].tolist()}"
            )
        assert not np.isinf(a).any() and not np.isinf(b).any(), f"{key}: inf"
        atol = TOL * np.broadcast_to(units.get(key, np.zeros(m)), a.shape)
        ok = nan_a | (np.abs(a - b) <= TOL * np.abs(b) + atol)
        if not ok.all():
            rows = np.flatnonzero(~ok.reshape(m, -1).all(axis=1))
            raise AssertionError(
                f"{key}: kernel and reference differ in windows {rows.tolist()}:"
                f" kernel {a[rows].tolist()} reference {b[rows].tolist()} atol {atol[rows].tolist()}"
            )


def check(fx, fy, fz, aux, starts, length, deadband, n_bins, raw=None, threads=None):
    """Runs both sides on the same windows and compares them; returns the kernel's dict."""
    db = parse_deadband(deadband)
    starts = np.asarray(starts, dtype=np.int64)
    got = compute(fx, fy, fz, aux, starts, length, db, n_bins, COMPARED, raw=raw, threads=threads)
    want = ref.window_stats(fx, fy, fz, aux, starts, length=length, deadband=db, n_bins=n_bins, raw=raw)
    if db.kind == "sigma":
        # A sample on d (to rounding) may fall on either side of it (module docs).
        z = np.abs(_windows(fz, starts, length))
        d = want["deadband"][:, None]
        tie = np.isclose(z, d, rtol=1e-12, atol=0).any()
        if currently_in_test_context():
            assume(not tie)
        else:
            assert not tie, "a sample lies on the sigma deadband"
    if currently_in_test_context():
        note(f"length={length} starts={starts.tolist()} deadband={deadband!r} n_bins={n_bins}")
    assert_matches(got, want, fy, fz, aux, starts, length)
    return got


# -- Strategies ---------------------------------------------------------------------

# Forces in [-50, 50] N; magnitudes under 1e-6 become exact zeros so that fy/fz
# stays bounded (a ratio of 50 / 1e-300 overflows: not the kernel's business).
force = st.floats(-50.0, 50.0, allow_nan=False, allow_subnormal=False).map(lambda v: v if abs(v) >= 1e-6 else 0.0)
deadbands = st.one_of(
    st.sampled_from([0.0, 0.35, 2.0, "0.7sigma", "0sigma", "1.5sigma"]),
    st.floats(0.0, 30.0, allow_subnormal=False),
    st.floats(0.0, 3.0, allow_subnormal=False).map(lambda k: f"{k!r}sigma"),
)


@st.composite
def layouts(draw, max_windows=12):
    """(length, starts, n_samples): tiled, overlapping, shuffled with repeats or reversed."""
    length = draw(st.integers(3, 300))
    m = draw(st.integers(1, max_windows))
    kind = draw(st.sampled_from(["tiled", "overlap", "random", "reversed"]))
    tail = draw(st.integers(0, 5))
    if kind in ("tiled", "reversed"):
        starts = np.arange(m) * length
        if kind == "reversed":
            starts = starts[::-1]
    elif kind == "overlap":
        hop = draw(st.integers(1, max(1, length - 1)))
        starts = np.arange(m) * hop
    else:
        span = draw(st.integers(0, 3 * length))
        starts = np.array(draw(st.lists(st.integers(0, span), min_size=m, max_size=m)))
    n = int(starts.max()) + length + tail
    return length, starts.astype(np.int64), n


def _generated(draw, n, d):
    """fx, fy, fz, aux, raw fy, raw fz of n samples."""
    kinds = ["uniform", "sine", "integers", "offset"] + (["arrays"] if n <= 600 else [])
    kind = draw(st.sampled_from(kinds))
    if kind == "arrays":
        specials = st.sampled_from([0.0, -0.0, d, -d, 50.0, -50.0, 1.0])
        elem = st.one_of(force, specials)
        return tuple(draw(arrays(np.float64, n, elements=elem)) for _ in range(6))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    noise = draw(st.sampled_from([0.0, 1e-3, 0.1, 1.0]))
    if kind == "uniform":
        fz = rng.uniform(-50, 50, n)
        fy = rng.uniform(-0.5, 0.5) * fz + rng.uniform(-50, 50, n) * noise
    elif kind == "sine":
        t = np.arange(n)
        amp, freq, off = rng.uniform(0.1, 20), rng.uniform(0.001, 0.4), rng.uniform(-10, 10)
        fz = off + amp * np.sin(2 * np.pi * freq * t + rng.uniform(0, 6.3)) + noise * rng.normal(size=n)
        fy = rng.uniform(-0.5, 0.5) * fz + rng.uniform(-2, 2) + noise * rng.normal(size=n)
    elif kind == "integers":
        # Many exact ties, exact zeros and samples exactly on +-d.
        fz = rng.integers(-4, 5, n).astype(float) * 0.35
        fy = rng.integers(-5, 6, n).astype(float)
    else:
        # Small variations on a large offset: the means are far from zero.
        fz = 40.0 + rng.uniform(-1e-3, 1e-3, n)
        fy = -30.0 + 0.2 * (fz - 40.0) + noise * 1e-3 * rng.normal(size=n)
    fx = 0.3 * fz + rng.uniform(-5, 5, n)
    aux = rng.uniform(0, 5, n)
    return fx, fy, fz, aux, fy + rng.uniform(-1, 1, n), fz + rng.normal(size=n) * np.where(rng.random(n) < 0.1, 0, 1)


# -- Properties ---------------------------------------------------------------------


@pytest.mark.fast
def test_keys():
    """The reference covers every statistic the kernel delivers by default, and the kernel those."""
    fz = np.linspace(-2, 3, 40)
    want = ref.window_stats(None, 0.1 * fz, fz, None, [0], length=40, deadband=0.35, n_bins=4)
    for raw in (None, (fz, fz)):
        got = compute(None, 0.1 * fz, fz, None, np.array([0]), 40, parse_deadband(0.35), 4, raw=raw)
        assert tuple(got) == kernel_columns(raw is not None)
        assert set(got) <= set(want), f"not in the reference: {set(got) - set(want)}"
    assert set(KERNEL_COLUMNS) | {"mu_classic"} <= set(COMPARED)
    assert "window_stats" in ref.__all__


@pytest.mark.fast
@given(st.data())
def test_random_windows(data):
    """Any layout of windows, any forces, fx/aux/raw present or not, both deadband kinds."""
    length, starts, n = data.draw(layouts())
    deadband = data.draw(deadbands)
    d = parse_deadband(deadband).value if parse_deadband(deadband).kind == "force" else 0.35
    fx, fy, fz, aux, fy_raw, fz_raw = _generated(data.draw, n, d)
    with_fx, with_aux, with_raw = data.draw(st.tuples(st.booleans(), st.booleans(), st.booleans()))
    n_bins = data.draw(st.integers(1, 20))
    threads = data.draw(st.one_of(st.none(), st.integers(1, MAX_THREADS)))
    got = check(
        fx if with_fx else None,
        fy,
        fz,
        aux if with_aux else None,
        starts,
        length,
        deadband,
        n_bins,
        raw=(fy_raw, fz_raw) if with_raw else None,
        threads=threads,
    )
    # Conventions that do not depend on the reference.
    assert (got["n"] == length).all()
    np.testing.assert_array_equal(got["bin_count"].sum(axis=1), got["n_a"] + got["n_b"])
    if not with_fx:
        assert np.isnan(got["c_xy"]).all() and np.isnan(got["c_xz"]).all()
    if not with_aux:
        assert np.isnan(got["aux_mean"]).all()
    if not with_raw:
        assert np.isnan(got["mu_classic"]).all()


@given(st.data())
def test_degenerate_windows(data):
    """Constant fz (NaN fit), constant fy (NaN r, C_yz, C_xy), length 3, repeated values."""
    length = data.draw(st.sampled_from([3, 3, 4, 5, 8, 9, 17, 64, 300]))
    m = data.draw(st.integers(1, 6))
    n = m * length
    value = data.draw(force)
    which = data.draw(st.sampled_from(["fz", "fy", "both", "two_values"]))
    fz = data.draw(arrays(np.float64, n, elements=force))
    fy = data.draw(arrays(np.float64, n, elements=force))
    fx = data.draw(arrays(np.float64, n, elements=force))
    if which in ("fz", "both"):
        fz[:] = value
    if which in ("fy", "both"):
        fy[:] = value
        fx[:] = data.draw(force)
    if which == "two_values":
        other = data.draw(force)
        # Two values a few ulps apart make fz constant but for rounding: its S_zz and Pearson coefficients are
        # then rounding noise on both sides (hypothesis found 50 and 50 - 1 ulp), not a property to compare.
        assume(value == other or abs(value - other) > 1e-9 * max(abs(value), abs(other)))
        fz = np.where(np.arange(n) % 2 == 0, value, other)
    starts = np.arange(m) * length
    deadband = data.draw(deadbands)
    n_bins = data.draw(st.integers(1, 8))
    got = check(fx, fy, fz, None, starts, length, deadband, n_bins)
    if which in ("fz", "both"):
        # docs/method.md 3: zero variance of fz -> NaN fit, not an exception.
        for key in ("slope", "intercept", "r", "slope_stderr", "c_yz"):
            assert np.isnan(got[key]).all(), key
        # Every sample of a constant window is in bin 0 (span 0).
        assert (got["bin_count"][:, 1:] == 0).all()
    if which in ("fy", "both"):
        assert np.isnan(got["c_yz"]).all() and np.isnan(got["r"]).all() and np.isnan(got["c_xy"]).all()
        assert np.isnan(got["c_xz"]).all()  # fx is constant too


@pytest.mark.fast
@pytest.mark.parametrize("length", [1, 2])
def test_shorter_than_three(length):
    """Fewer than 3 samples: NaN fit; with 1 sample no sigma deadband and no Pearson at all."""
    fz = np.array([0.5, -1.25, 2.0, 0.75])
    fy, fx = 0.2 * fz + np.array([0.01, -0.02, 0.03, 0.0]), np.array([1.0, 3.0, -2.0, 0.5])
    starts = np.arange(5 - length - 1)
    for deadband in (0.35, "0.7sigma"):
        got = check(fx, fy, fz, fx, starts, length, deadband, 3, raw=(fy, fz))
        assert np.isnan(got["slope"]).all()
        if length == 1 and deadband == "0.7sigma":
            assert np.isnan(got["deadband"]).all() and (got["bin_count"] == 0).all()


@given(st.data())
def test_deadband_excludes_everything(data):
    """d above every |fz|: no sample is kept, mu_a, mu_b and every bin_cof are NaN."""
    length, starts, n = data.draw(layouts(max_windows=6))
    fz = data.draw(arrays(np.float64, n, elements=force))
    fy = data.draw(arrays(np.float64, n, elements=force))
    deadband = data.draw(st.sampled_from([50.5, 1e9, np.nextafter(50.0, 51.0)]))
    n_bins = data.draw(st.integers(1, 16))
    got = check(None, fy, fz, None, starts, length, deadband, n_bins)
    assert (got["n_a"] == 0).all() and (got["n_b"] == 0).all() and (got["bin_count"] == 0).all()
    assert np.isnan(got["mu_a"]).all() and np.isnan(got["mu_b"]).all() and np.isnan(got["bin_cof"]).all()


@given(st.data())
def test_sigma_deadband(data):
    """d = k sd(fz) with n - 1, on realistic and on hand-made windows."""
    length, starts, n = data.draw(layouts(max_windows=8))
    k = data.draw(st.one_of(st.just(0.7), st.floats(0.0, 4.0, allow_subnormal=False)))
    fx, fy, fz, aux, _, _ = _generated(data.draw, n, 0.35)
    n_bins = data.draw(st.integers(1, 16))
    got = check(fx, fy, fz, aux, starts, length, f"{k!r}sigma", n_bins)
    z = _windows(fz, starts, length)
    # np.std leaves ~1e-16 N of a constant window, the kernel 0.
    atol = k * length * EPS * np.abs(z).max(axis=1)
    assert (np.abs(got["deadband"] - k * z.std(axis=1, ddof=1)) <= 1e-9 * got["deadband"] + atol).all()


@given(st.data())
def test_bin_edges(data):
    """fz exactly on the bin edges lo + j span / n_bins, the maximum included.

    With a power-of-two step every edge is exact in floating point, so edge j
    must fall in bin j and the maximum in the last bin; with any lo and span
    the kernel and the reference must still place every sample alike.
    """
    n_bins = data.draw(st.integers(1, 24))
    exact = data.draw(st.booleans())
    if exact:
        step = 2.0 ** -data.draw(st.integers(-1, 6))
        lo = data.draw(st.integers(-40, 40)) * step
        span = n_bins * step
    else:
        lo = data.draw(force.filter(lambda v: abs(v) <= 40))
        span = data.draw(st.floats(1e-3, 60, allow_subnormal=False))
    edges = np.array([lo + j * span / n_bins for j in range(n_bins + 1)])
    assume(np.abs(edges).max() <= 100 and np.all(np.diff(edges) > 0))
    picks = data.draw(st.lists(st.integers(0, n_bins), min_size=1, max_size=200))
    picks = sorted(set(picks) | {0, n_bins}) + picks  # both ends present
    order = data.draw(st.permutations(range(len(picks))))
    idx = np.asarray(picks)[list(order)]
    fz = edges[idx]
    length = len(fz)
    fy = data.draw(arrays(np.float64, length, elements=force))
    deadband = data.draw(st.sampled_from([0.0, 0.35, float(np.abs(edges[len(edges) // 2]))]))
    got = check(None, fy, fz, None, [0], length, deadband, n_bins)
    if exact:
        keep = (np.abs(fz) >= parse_deadband(deadband).value) & (fz != 0)
        expect = np.bincount(np.minimum(idx[keep], n_bins - 1), minlength=n_bins)
        np.testing.assert_array_equal(got["bin_count"][0], expect)


@given(st.data())
def test_classic_cof(data):
    """raw = (fy_raw, fz_raw) gives mu_classic = mean |fy_raw| / |fz_raw| over fz_raw != 0."""
    length, starts, n = data.draw(layouts(max_windows=8))
    fy_raw = data.draw(arrays(np.float64, n, elements=force))
    fz_raw = data.draw(arrays(np.float64, n, elements=st.one_of(force, st.just(0.0))))
    if data.draw(st.booleans()):
        fz_raw[starts[0] : starts[0] + length] = 0.0  # a window with fz_raw == 0 throughout: NaN
    fz = np.sin(np.arange(n) * 0.37) * 3
    got = check(None, 0.1 * fz, fz, None, starts, length, 0.35, 4, raw=(fy_raw, fz_raw))
    for k, s in enumerate(starts):
        az = np.abs(fz_raw[s : s + length])
        if not (az > 0).any():
            assert np.isnan(got["mu_classic"][k])
        else:
            assert got["mu_classic"][k] >= 0


@given(st.data())
def test_threads_give_the_same_bits(data):
    """The windows on the calling thread (threads=1) and on a pool give the same bits.

    (``compute``'s ``parallel=True/False`` became ``threads``; 8 windows or
    more with threads > 1 run on the pool.)
    """
    length, _, _ = data.draw(layouts(max_windows=1))
    m = data.draw(st.integers(8, 64))
    hop = data.draw(st.integers(1, length))
    starts = np.arange(m) * hop
    if data.draw(st.booleans()):
        starts = starts[np.asarray(data.draw(st.permutations(range(m))))]
    n = int(starts.max()) + length
    fx, fy, fz, aux, fy_raw, fz_raw = _generated(data.draw, n, 0.35)
    deadband = parse_deadband(data.draw(deadbands))
    n_bins = data.draw(st.integers(1, 16))
    threads = data.draw(st.one_of(st.none(), st.integers(2, MAX_THREADS)))
    args = (fx, fy, fz, aux, starts, length, deadband, n_bins, COMPARED)
    a = compute(*args, raw=(fy_raw, fz_raw), threads=threads)
    b = compute(*args, raw=(fy_raw, fz_raw), threads=1)
    assert tuple(a) == tuple(b) == COMPARED
    for key in a:
        assert a[key].dtype == b[key].dtype and a[key].shape == b[key].shape, key
        assert a[key].tobytes() == b[key].tobytes(), f"{key}: threads={threads} and threads=1 differ"


@given(st.data())
def test_forces_out_of_range(data):
    """A force beyond _core.FORCE_LIMIT in any channel makes the windows holding it out of range on both sides.

    Every statistic of those windows NaN and their counts 0 (docs/method.md 4); at the limit itself a
    window is analysed; the other windows are untouched.
    """
    length, starts, n = data.draw(layouts(max_windows=6))
    fx, fy, fz, aux, fy_raw, fz_raw = _generated(data.draw, n, 0.35)
    channels = [fx, fy, fz, fy_raw, fz_raw]
    which = data.draw(st.integers(0, 4))
    at = data.draw(st.integers(0, n - 1))
    factor = data.draw(st.sampled_from([1.0, 1.0000001, 2.0, 1e200]))
    channels[which] = channels[which].copy()
    channels[which][at] = data.draw(st.sampled_from([1.0, -1.0])) * factor * _core.FORCE_LIMIT
    fx, fy, fz, fy_raw, fz_raw = channels
    n_bins = data.draw(st.integers(1, 8))
    with np.errstate(over="ignore"):  # the tolerances' units of a window holding 1e260 N
        got = check(fx, fy, fz, aux, starts, length, "0.7sigma", n_bins, raw=(fy_raw, fz_raw))
    inside = (starts <= at) & (at < starts + length) & (factor > 1.0)
    np.testing.assert_array_equal(got["out_of_range"], inside.astype(np.int64))
    for key in ("slope", "mean_z", "mean_y", "c_yz", "c_xy", "mu_a", "mu_b", "fz_min", "mu_classic"):
        assert np.isnan(got[key][inside]).all(), key
    assert (got["bin_count"][inside] == 0).all() and (got["n_a"][inside] + got["n_b"][inside] == 0).all()
    assert (got["n"] == length).all() and np.isfinite(got["aux_mean"]).all()


@pytest.mark.fast
def test_no_windows():
    """No start: every column has zero rows (bins: shape (0, n_bins))."""
    fz = np.linspace(-1.0, 1.0, 10)
    check(fz, fz, fz, fz, np.zeros(0, dtype=np.int64), 3, 0.35, 4, raw=(fz, fz))


@pytest.mark.fast
def test_bad_starts_are_refused():
    """A window past the end, or a negative start, is a ValueError, not a crash."""
    fz = np.linspace(-1, 1, 10)
    db = parse_deadband(0.35)
    with pytest.raises(ValueError):
        compute(None, fz, fz, None, np.array([5]), 6, db, 4)
    with pytest.raises(ValueError):
        compute(None, fz, fz, None, np.array([-1]), 3, db, 4)
