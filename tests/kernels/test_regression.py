"""Closed-form, stable, mergeable least squares, Eqs. (6)-(8) (docs/method.md 3).

Tolerances
----------
Fields are compared in their natural units, so that a field near zero (an
intercept, an uncorrelated slope) is not held to a relative error it cannot
have: slope in sqrt(S_yy/S_xx), intercept in |mean_y| + |slope mean_x| +
sqrt(S_yy/n), r absolutely, resid_std in sqrt(S_yy/(n-2)), and the standard
errors relative to resid_std's unit scaled the same way. Two correct
algorithms (the Rust blockwise merge, the reference's two passes) round
differently; centring a sample of magnitude |v| carries an error of about
eps |v|, so in those units they may differ by about
``eps * n * cond`` with ``cond = max|x|/sd(x) + max|y|/sd(y)``, which is
about |offset|/sd for offset data. The tests allow 16 times that (measured:
under 0.1 times), and never less than 1e-12.

NIST StRD Norris: the certified values are parsed from the header of
``tests/data/nist/Norris.dat``. Adding 1e6 to x cannot be done exactly in
float64 (ulp(1e6) = 1.2e-10 while x has one decimal), which perturbs each
x by up to 5.8e-11 and moves resid SD and the slope's standard error by
~1e-11 relative, whatever the algorithm (shown with exact rational
arithmetic below). So the shifted fit is checked to 1e-12 against the exact
least squares of the float64 data the kernel actually received, and against
the certified values within the bound that this input rounding implies.
"""

from __future__ import annotations

import pickle
import re
import warnings
from decimal import Decimal, localcontext
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
import tribodyn as td
from hypothesis import example, given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy import stats
from tribodyn.kernels import reference as ref
from _paths import TESTS

EPS = np.finfo(np.float64).eps
NORRIS = TESTS / "data" / "nist" / "Norris.dat"
FIELDS = ("slope", "intercept", "r", "slope_stderr", "intercept_stderr", "resid_std")


# -- NIST StRD Norris ---------------------------------------------------------------


def parse_strd(path: Path) -> tuple[dict[str, Decimal], list[str], list[str]]:
    """Certified values (as exact decimals) and the data columns (as text)."""
    text = path.read_text()
    lines = text.splitlines()
    first, last = map(int, re.search(r"Data\s+\(lines (\d+) to (\d+)\)", text).groups())
    num = r"([-+]?\d+\.\d+(?:E[-+]?\d+)?)"
    cert = {}
    m = re.search(rf"^\s*B0\s+{num}\s+{num}\s*$", text, re.MULTILINE)
    cert["intercept"], cert["intercept_stderr"] = Decimal(m[1]), Decimal(m[2])
    m = re.search(rf"^\s*B1\s+{num}\s+{num}\s*$", text, re.MULTILINE)
    cert["slope"], cert["slope_stderr"] = Decimal(m[1]), Decimal(m[2])
    cert["resid_std"] = Decimal(re.search(rf"Residual\s+Standard Deviation\s+{num}", text)[1])
    cert["r2"] = Decimal(re.search(rf"R-Squared\s+{num}", text)[1])
    rows = [ln.split() for ln in lines[first - 1 : last]]
    ys, xs = [r[0] for r in rows], [r[1] for r in rows]  # columns: y x
    return cert, xs, ys


CERT, X_TEXT, Y_TEXT = parse_strd(NORRIS)
X = np.array([float(v) for v in X_TEXT])
Y = np.array([float(v) for v in Y_TEXT])
SHIFT = 10**6


def exact_fit(xs, ys) -> dict[str, Decimal]:
    """Least squares in exact rational arithmetic; square roots to 40 digits."""
    xs, ys = [Fraction(v) for v in xs], [Fraction(v) for v in ys]
    n = len(xs)
    mx, my = sum(xs) / n, sum(ys) / n
    sxx = sum((a - mx) ** 2 for a in xs)
    syy = sum((b - my) ** 2 for b in ys)
    sxy = sum((a - mx) * (b - my) for a, b in zip(xs, ys))
    slope = sxy / sxx
    var = (syy - sxy * sxy / sxx) / (n - 2)
    with localcontext() as ctx:
        ctx.prec = 40

        def d(f):
            return Decimal(f.numerator) / Decimal(f.denominator)

        return {
            "slope": d(slope),
            "intercept": d(my - slope * mx),
            "r2": d(sxy * sxy / (sxx * syy)),
            "slope_stderr": d(var / sxx).sqrt(),
            "intercept_stderr": d(var * (Fraction(1, n) + mx * mx / sxx)).sqrt(),
            "resid_std": d(var).sqrt(),
        }


def as_dict(fit) -> dict[str, float]:
    out = {k: getattr(fit, k) for k in FIELDS if k != "r"}
    out["r2"] = fit.r**2
    return out


def rel_errors(fit, want: dict[str, Decimal]) -> dict[str, float]:
    got = as_dict(fit)
    with localcontext() as ctx:
        ctx.prec = 40
        return {k: float(abs(Decimal(got[k]) - want[k]) / abs(want[k])) for k in want}


def norris_accumulators(splits):
    """A tribodyn and a reference accumulator fed the chunks between `splits`."""
    cuts = [0, *sorted(splits), X.size]
    a, r = td.LinFitAccumulator(), ref.LinFitAccumulator()
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        a.update(X[lo:hi], Y[lo:hi])
        r.update(X[lo:hi], Y[lo:hi])
    return a, r


@pytest.mark.fast
def test_norris_file_is_the_nist_original():
    assert X.size == Y.size == 36
    assert (X[0], Y[0]) == (0.2, 0.1) and (X[-1], Y[-1]) == (0.5, 0.2)
    assert CERT["slope"] == Decimal("1.00211681802045")
    # The file's own ANOVA table agrees with the parsed R^2 and resid SD.
    text = NORRIS.read_text()
    ss_reg, ss_res = map(Decimal, re.search(r"Regression\s+1\s+(\S+).*\nResidual\s+34\s+(\S+)", text).groups())
    assert abs(ss_reg / (ss_reg + ss_res) - CERT["r2"]) < Decimal("1e-14")
    assert abs((ss_res / 34).sqrt() - CERT["resid_std"]) < Decimal("1e-14")


@pytest.mark.fast
@pytest.mark.parametrize("impl", [td.linfit, ref.linfit], ids=["rust", "reference"])
def test_norris_certified(impl):
    fit = impl(X, Y)
    assert fit.n == 36
    err = rel_errors(fit, CERT)
    assert max(err.values()) <= 1e-12, err


@given(st.lists(st.integers(0, 36), max_size=8))
@example([])
@example(list(range(37)))  # every sample alone, with empty chunks at the ends
@example([0, 0, 1, 1, 35])
def test_norris_certified_accumulated(splits):
    acc, racc = norris_accumulators(splits)
    assert acc.n == 36
    # B0 = mean_y - B1 mean_x cancels: |mean_y| / |B0| = 1600. Each merge
    # rounds the running means (mean_a + dx nb/n) by about an ulp, and an
    # ulp of mean_y alone is 2e-13 of B0: the intercept gets that allowance
    # per chunk (see test_norris_accumulated_contract for the strict form).
    n_chunks = len(splits) + 1
    b0_cond = float(
        (abs(Decimal(float(Y.mean()))) + abs(CERT["slope"] * Decimal(float(X.mean())))) / abs(CERT["intercept"])
    )
    b0_tol = 1e-12 + (n_chunks + 2) * EPS * b0_cond
    for fit in (acc.result(), racc.result()):
        err = rel_errors(fit, CERT)
        assert err.pop("intercept") <= b0_tol, (splits, b0_tol)
        assert max(err.values()) <= 1e-12, (splits, err)


@pytest.mark.fast
def test_norris_merged_in_any_grouping():
    parts = [(X[a:b], Y[a:b]) for a, b in [(0, 5), (5, 6), (6, 6), (6, 20), (20, 36)]]
    accs = [td.LinFitAccumulator().update(x, y) for x, y in parts]
    left = accs[0].merge(accs[1]).merge(accs[2]).merge(accs[3]).merge(accs[4])
    right = accs[0].merge(accs[1].merge(accs[2].merge(accs[3].merge(accs[4]))))
    for acc in (left, right):
        assert max(rel_errors(acc.result(), CERT).values()) <= 1e-12


@pytest.mark.fast
def test_norris_shifted_by_1e6():
    xs = X + SHIFT  # rounded: each x moves by up to ulp(1e6)/2
    exact = exact_fit(xs, Y)  # the least squares of the data as received

    # 1. The kernels solve the problem they were given to 12+ digits (one
    #    shot; for the accumulator see test_norris_shifted_accumulated).
    for fit in (td.linfit(xs, Y), ref.linfit(xs, Y), norris_acc_shifted([])):
        err = rel_errors(fit, exact)
        assert max(err.values()) <= 1e-12, err

    # 2. Against the certified values. slope and R^2 do not feel the input
    #    rounding: 12 digits as certified.
    fit = td.linfit(xs, Y)
    err = rel_errors(fit, CERT)
    assert err["slope"] <= 1e-12 and err["r2"] <= 1e-12, err

    # resid SD and the slope's standard error move with the rounding delta of
    # x: |d resid| <= |slope| ||delta|| / sqrt(n - 2) (the residuals move by
    # at most slope * delta_i), and S_xx by at most 2 ||delta|| sqrt(S_xx).
    # delta_i: the float64 x_i + 1e6 minus the exact decimal x_i + 1e6.
    xf = [Fraction(v) for v in X_TEXT]
    delta = np.array([float(Fraction(a) - (b + SHIFT)) for a, b in zip(xs, xf)])
    dnorm = float(np.linalg.norm(delta))
    sxx = float(sum((v - sum(xf) / 36) ** 2 for v in xf))
    bound = 1e-12 + abs(fit.slope) * dnorm / (np.sqrt(34.0) * float(CERT["resid_std"])) + 2 * dnorm / np.sqrt(sxx)
    assert 0 < dnorm < 36 * 2**-33  # |delta_i| <= ulp(1e6) / 2 = 2^-34
    assert err["resid_std"] <= bound and err["slope_stderr"] <= bound, (err, bound)
    # ... and the exact fit of the rounded data shows the gap is the data's:
    assert rel_errors(fit, exact)["resid_std"] <= 1e-12
    assert float(abs(exact["resid_std"] - CERT["resid_std"]) / CERT["resid_std"]) > 1e-13

    # 3. The intercept of the shifted line is B0 - B1 * 1e6 (exact decimal
    #    arithmetic on the certified values), to 12 digits.
    with localcontext() as ctx:
        ctx.prec = 40
        b0_shifted = CERT["intercept"] - CERT["slope"] * SHIFT
        # Its standard error: se(B1) sqrt(S_xx/n + (mean x + 1e6)^2), with
        # S_xx and mean x from the exact decimal data.
        xd = [Decimal(v) for v in X_TEXT]
        mx = sum(xd) / 36
        sxx_d = sum((v - mx) ** 2 for v in xd)
        se_b0_shifted = CERT["slope_stderr"] * (sxx_d / 36 + (mx + SHIFT) ** 2).sqrt()
        assert abs(CERT["slope_stderr"] * (sxx_d / 36 + mx**2).sqrt() - CERT["intercept_stderr"]) < Decimal("1e-15")
        assert abs(Decimal(fit.intercept) - b0_shifted) / abs(b0_shifted) <= Decimal("1e-12")
        assert float(abs(Decimal(fit.intercept_stderr) - se_b0_shifted) / se_b0_shifted) <= bound
        # Shifting back recovers B0 only to the slope's accuracy times 1e6
        # (plus the ulps of a number near 1e6): the digits are not in the
        # float64 intercept of the shifted data.
        back = Decimal(fit.intercept) + Decimal(fit.slope) * SHIFT
        assert abs(back - CERT["intercept"]) <= Decimal(1e-12 * SHIFT * abs(fit.slope) + 4 * np.spacing(1e6))


def norris_acc_shifted(splits, cls=td.LinFitAccumulator):
    cuts = [0, *sorted(splits), X.size]
    acc = cls()
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        acc.update(X[lo:hi] + SHIFT, Y[lo:hi])
    return acc.result()


def test_norris_shifted_accumulated_within_mean_rounding():
    # Chunked, the accumulator merges blocks through the difference of their
    # stored means. A mean near 1e6 is stored to ulp(1e6)/2 = 5.8e-11, and
    # the merge's "between" term of the SSE is as sensitive to that
    # difference as a residual is: |slope| * 2 ulp(1e6) per merge, relative
    # to resid SD 0.88 that is ~1e-10 on SSE. So 10 digits, not 12, for
    # resid SD and the standard errors; slope, intercept and R^2 keep 12+.
    exact = exact_fit(X + SHIFT, Y)
    per_merge = 4 * abs(float(CERT["slope"])) * np.spacing(1e6) / float(CERT["resid_std"])
    for splits in ([1], [1, 17, 30], [5, 6, 20], list(range(1, 36))):
        for cls in (td.LinFitAccumulator, ref.LinFitAccumulator):
            err = rel_errors(norris_acc_shifted(splits, cls), exact)
            for k in ("slope", "intercept", "r2"):
                assert err[k] <= 1e-12, (splits, err)
            for k in ("slope_stderr", "intercept_stderr", "resid_std"):
                assert err[k] <= 1e-12 + per_merge * len(splits), (splits, err)


@pytest.mark.parametrize(
    "cls, case",
    # docs/method.md 3: any split of Norris (also + 1e6) to 1e-12. Met because the
    # accumulators keep their means as double-doubles, so merges never round
    # them (Norris B0 is a difference of numbers 1600 times larger).
    [
        (td.LinFitAccumulator, "norris"),
        (ref.LinFitAccumulator, "norris"),
        (td.LinFitAccumulator, "norris+1e6"),
        (ref.LinFitAccumulator, "norris+1e6"),
    ],
    ids=["rust-norris", "reference-norris", "rust-norris+1e6", "reference-norris+1e6"],
)
def test_norris_accumulated_contract(cls, case):
    if case == "norris":
        err = {}
        for splits in ([8, 26, 28, 33], [8, 17, 26, 35]):  # found by hypothesis
            cuts = [0, *splits, 36]
            acc = cls()
            for lo, hi in zip(cuts[:-1], cuts[1:]):
                acc.update(X[lo:hi], Y[lo:hi])
            for k, v in rel_errors(acc.result(), CERT).items():
                err[k] = max(err.get(k, 0.0), v)
    else:
        err = rel_errors(norris_acc_shifted([1, 17, 30], cls), exact_fit(X + SHIFT, Y))
    assert max(err.values()) <= 1e-12, err


def test_norris_shifted_in_y_and_scaled():
    # A constant added to y moves only the intercept; scaling by a power of
    # two is exact, so every field scales exactly as the maths says.
    base = td.linfit(X, Y)
    sy = td.linfit(X, Y + 1e6)
    for k in ("slope", "r", "slope_stderr", "resid_std"):
        np.testing.assert_allclose(getattr(sy, k), getattr(base, k), rtol=1e-12)
    np.testing.assert_allclose(sy.intercept - 1e6, base.intercept, rtol=0, atol=1e-12 * 1e6)
    sc = td.linfit(X * 2.0**-20, Y * 2.0**20)
    np.testing.assert_allclose(sc.slope, base.slope * 2.0**40, rtol=1e-14)
    np.testing.assert_allclose(sc.resid_std, base.resid_std * 2.0**20, rtol=1e-14)


# -- random data: scipy, the reference, any split -----------------------------------


@st.composite
def xy(draw, min_n: int = 3, max_n: int = 300):
    """Scaled, offset, sometimes exactly linear or constant data."""
    n = draw(st.integers(min_n, max_n))
    # Away from underflow: below ~1e-154 a square is 0 and S_xx with it.
    unit = st.floats(-1.0, 1.0).filter(lambda v: v == 0 or abs(v) > 1e-100)
    sx, sy = (draw(st.floats(-6.0, 6.0).map(lambda e: 10.0**e)) for _ in range(2))
    ox, oy = (draw(st.one_of(st.just(0.0), st.floats(-1e6, 1e6, allow_subnormal=False))) for _ in range(2))
    u = draw(arrays(np.float64, n, elements=unit))
    noise = draw(arrays(np.float64, n, elements=unit))
    kind = draw(st.sampled_from(["noisy", "exact_line", "noise_only", "constant_x", "constant_y"]))
    a = draw(st.floats(-3.0, 3.0).filter(lambda v: v == 0 or abs(v) > 1e-100))
    v = {"noisy": a * u + noise, "exact_line": a * u, "noise_only": noise}.get(kind, a * u + noise)
    x = sx * u + ox
    y = sy * v + oy
    if kind == "constant_x" and n:
        x = np.full(n, x[0])
    if kind == "constant_y" and n:
        y = np.full(n, y[0])
    return x, y


def scales(x: np.ndarray, y: np.ndarray) -> tuple[dict[str, float], float]:
    """Natural units of each field, and cond (module docstring).

    The units of the y-scaled fields get a floor of eps max|y| sqrt(n): the
    size of what centring y can leave behind, which is all there is when y
    is constant (S_yy = 0 exactly, yet S_xy may keep a residue of 1e-30).
    """
    n = x.size
    dx, dy = x - ref.mean(x), y - ref.mean(y)
    sxx, syy = dx @ dx, dy @ dy
    slope = (dx @ dy) / sxx
    ry = np.sqrt(syy) + EPS * np.max(np.abs(y)) * np.sqrt(n)  # ~ sqrt(S_yy)
    resid = ry / np.sqrt(n - 2)
    u = {
        "slope": ry / np.sqrt(sxx),
        "intercept": abs(ref.mean(y)) + abs(slope * ref.mean(x)) + ry / np.sqrt(n),
        "r": 1.0,
        "resid_std": resid,
        "slope_stderr": resid / np.sqrt(sxx),
        "intercept_stderr": resid / np.sqrt(sxx) * np.sqrt(sxx / n + ref.mean(x) ** 2),
    }
    cond_y = np.max(np.abs(y)) / np.sqrt(syy / n) if syy > 0 else 1.0
    cond = np.max(np.abs(x)) / np.sqrt(sxx / n) + cond_y + 1.0
    return u, cond


def assert_fits_close(got, want, x, y, *, floor: float = 1e-12) -> None:
    assert got.n == want.n
    if np.isnan(want.slope):  # degenerate: every float field NaN in both
        assert all(np.isnan(getattr(got, k)) for k in FIELDS)
        assert all(np.isnan(getattr(want, k)) for k in FIELDS)
        return
    unit, cond = scales(x, y)
    tol = max(floor, 16 * EPS * x.size * cond)
    for k in FIELDS:
        g, w = getattr(got, k), getattr(want, k)
        if k == "r" and np.isnan(w):  # constant y: r is undefined
            assert np.isnan(g)
            continue
        assert abs(g - w) <= tol * unit[k], (k, g, w, tol, cond)


def quiet(f, *a):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", td.DegenerateInputWarning)
        return f(*a)


@given(xy(min_n=1))
@example((np.array([1.0, 2.0]), np.array([3.0, 5.0])))
@example((np.array([1.0, 2.0, 4.0]), np.array([3.0, 5.0, 0.0])))
@example((np.full(3, 1e6), np.array([1e-6, 0.0, 2e-6])))
def test_linfit_matches_reference(case):
    x, y = case
    got, want = quiet(td.linfit, x, y), quiet(ref.linfit, x, y)
    assert isinstance(got, td.LinFit) and isinstance(got.n, int)
    assert got.degenerate == want.degenerate == (x.size < 3 or np.ptp(x) == 0)
    assert_fits_close(got, want, x, y)
    if not got.degenerate:
        assert -1.0 <= got.r <= 1.0 or np.isnan(got.r)
        assert got.resid_std >= 0 and got.slope_stderr >= 0 and got.intercept_stderr >= 0


@given(xy(min_n=0, max_n=200), st.data())
def test_any_split_equals_one_shot(case, data):
    x, y = case
    n = x.size
    cuts = sorted(data.draw(st.lists(st.one_of(st.integers(0, n), st.sampled_from([0, 1, n])), max_size=10)))
    bounds = list(zip([0, *cuts], [*cuts, n]))
    acc, racc = td.LinFitAccumulator(), ref.LinFitAccumulator()
    for lo, hi in bounds:
        acc.update(x[lo:hi], y[lo:hi])
        racc.update(x[lo:hi], y[lo:hi])
    assert acc.n == n
    if n == 0:
        with pytest.warns(td.DegenerateInputWarning):
            assert acc.result().n == 0
        return
    one = quiet(td.linfit, x, y)
    assert_fits_close(quiet(acc.result), one, x, y)
    assert_fits_close(quiet(racc.result), one, x, y)
    # Merging per-chunk accumulators pairwise, as a tree, gives it too.
    parts = [td.LinFitAccumulator().update(x[lo:hi], y[lo:hi]) for lo, hi in bounds]
    while len(parts) > 1:
        parts = [parts[i].merge(parts[i + 1]) if i + 1 < len(parts) else parts[i] for i in range(0, len(parts), 2)]
    assert_fits_close(quiet(parts[0].result), one, x, y)


def test_one_million_samples_chunked():
    # Above the kernel's parallel task size: blockwise, parallel and chunked
    # reductions all agree to 1e-12 in natural units.
    rng = np.random.default_rng(11)
    x = rng.standard_normal(1_000_003) * 0.7 + 2.5
    y = -0.15 * x + 0.2 + 0.05 * rng.standard_normal(x.size)
    one = td.linfit(x, y)
    acc = td.LinFitAccumulator()
    for lo, hi in [(0, 1), (1, 1), (1, 300_000), (300_000, 300_001), (300_001, 1_000_003)]:
        acc.update(x[lo:hi], y[lo:hi])
    assert_fits_close(acc.result(), one, x, y)
    assert_fits_close(ref.linfit(x, y), one, x, y, floor=1e-12)


@given(
    x=arrays(np.float64, st.integers(3, 300), elements=st.floats(-100.0, 100.0, allow_subnormal=False)),
    slope=st.floats(-5.0, 5.0),
    sigma=st.floats(0.01, 10.0),
    seed=st.integers(0, 2**32 - 1),
)
def test_linfit_matches_scipy_linregress(x, slope, sigma, seed):
    if np.ptp(x) < 1e-3 * max(1.0, np.max(np.abs(x))):
        x = x + np.linspace(0.0, 1.0, x.size)  # scipy has no NaN path for constant x
    y = slope * x + 1.5 + sigma * np.random.default_rng(seed).standard_normal(x.size)
    got = td.linfit(x, y)
    want = stats.linregress(x, y)
    unit, _ = scales(x, y)
    # linregress computes the standard errors as sqrt((1 - r^2) S_yy / S_xx
    # / (n - 2)): r carries the rounding of n-term sums (~n eps) and 1 - r^2
    # amplifies it by 1 / (1 - r^2).
    se_rtol = 1e-12 + 2 * EPS * x.size / max(1.0 - want.rvalue**2, 1e-300)
    tol = 1e-12 + 4 * EPS * x.size
    assert abs(got.slope - want.slope) <= tol * unit["slope"]
    assert abs(got.intercept - want.intercept) <= tol * unit["intercept"]
    assert abs(got.r - want.rvalue) <= tol
    np.testing.assert_allclose(got.slope_stderr, want.stderr, rtol=se_rtol)
    np.testing.assert_allclose(got.intercept_stderr, want.intercept_stderr, rtol=se_rtol)


# -- degenerate input, the accumulator's interface -----------------------------------


@pytest.mark.fast
@pytest.mark.parametrize(
    "x, y",
    [
        ([1.0], [2.0]),
        ([1.0, 2.0], [1.0, 2.0]),
        ([0.3] * 10, list(range(10))),
        ([5, 5, 5], [1, 2, 3]),
    ],
    ids=["n=1", "n=2", "constant-x", "constant-int-x"],
)
def test_degenerate_gives_nan_and_warns(x, y):
    for impl in (td.linfit, ref.linfit):
        with pytest.warns(td.DegenerateInputWarning, match="undefined"):
            fit = impl(x, y)
        assert fit.degenerate and fit.n == len(x)
        assert all(np.isnan(getattr(fit, k)) for k in FIELDS)
    acc = td.LinFitAccumulator().update(x, y)
    with pytest.warns(td.DegenerateInputWarning):
        assert acc.result().degenerate


@pytest.mark.fast
def test_constant_y_is_a_flat_line_not_degenerate():
    x = np.arange(10.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no DegenerateInputWarning
        fit = td.linfit(x, np.full(10, 4.25))
    assert fit.slope == 0.0 and fit.intercept == 4.25 and np.isnan(fit.r)
    assert fit.resid_std == 0.0 and fit.slope_stderr == 0.0 and not fit.degenerate


@pytest.mark.fast
def test_exact_line():
    x = np.linspace(-3.0, 7.0, 101)
    fit = td.linfit(x, 2.5 * x - 1.0)
    np.testing.assert_allclose([fit.slope, fit.intercept, fit.r], [2.5, -1.0, 1.0], rtol=1e-14)
    assert fit.resid_std < 1e-14 and fit.slope_stderr < 1e-14


@pytest.mark.fast
def test_accumulator_interface():
    rng = np.random.default_rng(2)
    x, y = rng.standard_normal(100), rng.standard_normal(100)
    acc = td.LinFitAccumulator()
    assert acc.n == 0 and repr(acc) == "LinFitAccumulator(n=0)"
    assert acc.update(x[:40], y[:40]) is acc  # chains
    other = td.LinFitAccumulator().update(x[40:], y[40:])
    merged = acc.merge(other)
    assert merged is not acc and merged is not other
    assert (acc.n, other.n, merged.n) == (40, 60, 100)
    assert_fits_close(merged.result(), td.linfit(x, y), x, y)
    # Merging with an empty accumulator, either side, changes nothing.
    empty = td.LinFitAccumulator()
    assert merged.merge(empty).result() == merged.result()
    assert empty.merge(merged).result() == merged.result()
    # Pickling keeps the exact state.
    back = pickle.loads(pickle.dumps(merged))
    assert back.result() == merged.result() and back.n == 100
    with pytest.raises(TypeError, match="LinFitAccumulator"):
        acc.merge(ref.LinFitAccumulator())  # type: ignore[arg-type]
