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


def _band_recording(seed: int, seconds: float = 400.0, snr: float = 6.0) -> dict:
    # the audit's rig (issue 35 point 3): fz noise band-limited to 200-450 Hz (2nd-order Butterworth) at SNR 6 dB
    from scipy import signal

    ch = {
        k: np.array(v, dtype=float) for k, v in simulate.conditions(seconds, seed=seed, y_noise=0.02).channels.items()
    }
    w = np.random.default_rng([seed, 35]).standard_normal(ch["fz"].size + 2000)
    w = signal.sosfilt(signal.butter(2, (200.0, 450.0), btype="bandpass", fs=1000.0, output="sos"), w)[2000:]
    ch["fz"] = ch["fz"] + w / w.std() * ch["fz"].std() * 10 ** (-snr / 20)
    return ch


def _unpooled(res: tribodyn.Results) -> tuple:
    from tribodyn.kernels.stats import bootstrap_ci, noise_resample

    mu, keep = res._gated_mu
    return bootstrap_ci(mu, noise=noise_resample(res.table, keep), threads=1)["median"]


@pytest.mark.fast
def test_the_chosen_lag_carries_the_iv_slopes_moves_at_the_lags_it_was_chosen_among() -> None:
    import pickle

    from tribodyn.pipeline.instrument import STRONG, ChosenLag, admissible_lags, chosen_lag

    p = lag_profile(sample_windows(_band_recording(5003, 130.0), None, 2000), 999)
    lag = chosen_lag(p, 0.3)
    assert isinstance(lag, ChosenLag) and lag.samples == choose_lag(p, 0.3)
    adm = admissible_lags(p, lag.samples)
    # the lags choose_lag accepts from the chosen one up to twice the next one it accepts
    assert adm[0] == lag.samples and len(adm) >= 2 and all(lag.samples < k <= 2 * adm[1] for k in adm[1:])
    for k in adm:  # each strong, and every strong lag up to twice it agrees with the reference lag
        assert abs(p.r[k]) >= STRONG and all(abs(p.t[j]) <= 3.0 for j in range(k, 2 * k + 1) if abs(p.r[j]) >= STRONG)
    assert lag.shifts == tuple(p.b[k] - p.b[lag.samples] for k in adm[1:]) and lag.shifts
    assert pickle.loads(pickle.dumps(lag)) == lag


@pytest.mark.fast
def test_the_bootstrap_pools_over_the_lags_and_is_unchanged_without_them() -> None:
    from tribodyn.kernels.stats import bootstrap_ci

    v = 0.1 + 0.001 * np.random.default_rng(3).standard_normal(200)
    plain = bootstrap_ci(v, threads=1)
    assert bootstrap_ci(v, threads=1, shifts=()) == plain
    moved = bootstrap_ci(v, threads=1, shifts=(0.004,))
    for k, (lo, hi) in plain.items():
        assert moved[k][0] >= lo - 1e-12 and moved[k][1] > hi + 0.001  # half the resamples moved up by 0.004
    both = bootstrap_ci(v, threads=1, shifts=(0.004, -0.004))
    assert both["median"][0] < plain["median"][0] - 0.001 and both["median"][1] > plain["median"][1] + 0.001


@pytest.mark.fast
@pytest.mark.parametrize("seed", [5007, 5011])
def test_band_noise_headline_interval_holds_the_truth_with_the_lag_from_the_data(seed: int) -> None:
    # docs/method.md 3d (issue 35 point 3): the lag chosen (9 samples) sits in the band noise's correlation and its
    # headline is biased by about -0.6 %; the interval that treats it as fixed misses mu, the pooled one holds it
    src = _band_recording(seed)
    res = tribodyn.analyze(src, fs=1000.0, threads=1)
    assert res.params["iv_lag_rule"] == "data" and res.params["iv_lag_samples"] == 9
    assert len(res.params["iv_lag_shifts"]) >= 1
    lo, hi = _unpooled(res)
    assert not lo <= MU <= hi
    head = res.headline
    assert head.low <= MU <= head.high and head.high - head.low > hi - lo
    assert res.summary()["mu_r"]["ci"]["median"] == (head.low, head.high)
    # a lag given or from rpm: nothing pooled, the interval as before
    for opts in (dict(rpm=250.0), dict(iv_lag=0.009)):
        other = tribodyn.analyze(src, fs=1000.0, threads=1, **opts)
        assert "iv_lag_shifts" not in other.params
        assert (other.headline.low, other.headline.high) == _unpooled(other)
    assert "iv_lag_shifts" not in tribodyn.analyze(src, fs=1000.0, threads=1, method="paper").params


def _window_iv_sums(fy: np.ndarray, fz: np.ndarray, lag: int) -> tuple:
    """[S_wz, S_wy] of one window in NumPy: w = fz lagged by ``lag`` (fz_{t+L} before L), all centred."""
    n = fz.size
    w = np.where(np.arange(n) >= lag, np.roll(fz, lag), np.roll(fz, -lag))
    wc, zc, yc = w - w.mean(), fz - fz.mean(), fy - fy.mean()
    return float(np.sum(wc * zc)), float(np.sum(wc * yc))


@pytest.fixture(scope="module")
def band_200s() -> tuple:
    src = _band_recording(5003, 200.0)  # the lag profile reads its first 64 windows of 2 s, tiling
    return src, tribodyn.analyze(src, fs=1000.0, threads=1)


@pytest.mark.fast
def test_the_pooled_moves_are_the_all_window_iv_slopes_at_those_lags(band_200s: tuple) -> None:
    # docs/method.md 3d (issue 35 point 3): each move b(L') - b(L) is of the pooled IV slopes sum S_wy / sum S_wz
    # over the headline's windows (all of them, not the lag profile's 64), times the orientation, with its
    # batch-means standard error over those windows; iv_lag_shifts are the moves shrunk by it
    from tribodyn.kernels.stats import BATCHES
    from tribodyn.pipeline.instrument import admissible_lags, extra_lags

    src, res = band_200s
    p = res.params
    lag, others, n = p["iv_lag_samples"], p["iv_lag_pooled"], p["window_samples"]
    p64 = lag_profile(sample_windows(src, None, n), (n - 1) // 2)
    assert p64 is not None and p64.windows == 64 and len(res.table["n"]) == 200 // (p["hop_samples"] // 1000)
    assert p["iv_lag_rule"] == "data" and tuple(others) == extra_lags(admissible_lags(p64, lag)) and others
    keep = np.asarray(res.table["ok"], bool) & np.isfinite(res.table["mu_r"])
    starts = np.round(np.asarray(res.table["t_start"]) * 1000.0).astype(int)[keep]
    fy, fz = np.asarray(src["fy"], float), np.asarray(src["fz"], float)

    def sums(k: int) -> np.ndarray:
        return np.array([_window_iv_sums(fy[a : a + n], fz[a : a + n], k) for a in starts])

    s = p["orientation_used"]
    S0 = sums(lag)
    b0 = S0[:, 1].sum() / S0[:, 0].sum()
    moves, ses = [], []
    for k in others:
        S = sums(k)
        b = S[:, 1].sum() / S[:, 0].sum()
        moves.append(s * (b - b0))
        u = (S[:, 1] - b * S[:, 0]) / S[:, 0].sum() - (S0[:, 1] - b0 * S0[:, 0]) / S0[:, 0].sum()
        g = [x.sum() for x in np.array_split(u, min(BATCHES, u.size))]
        ses.append(np.sqrt(len(g) / (len(g) - 1) * np.sum(np.square(g))))
    np.testing.assert_allclose(p["iv_lag_moves"], moves, rtol=1e-7, atol=1e-12)
    np.testing.assert_allclose(p["iv_lag_move_se"], ses, rtol=1e-7)
    want = [np.sign(m) * max(abs(m) - e, 0.0) for m, e in zip(moves, ses)]
    np.testing.assert_allclose(p["iv_lag_shifts"], want, rtol=1e-6, atol=1e-12)
    assert res._lag_shifts == tuple(p["iv_lag_shifts"])
    # not the lag profile's moves over its 64 windows (the pooling before, whose moves carried their own noise)
    old = [s * (p64.b[k] - p64.b[lag]) for k in others]
    assert np.max(np.abs(np.subtract(old, moves))) > 0.05 * np.max(np.abs(moves))
    # least squares does not rest on the lag: no sums asked of the kernel, nothing pooled, the interval unpooled
    ols = tribodyn.analyze(src, fs=1000.0, threads=1, estimator="ols")
    assert not any(k in ols.params for k in ("iv_lag_shifts", "iv_lag_moves", "iv_lag_pooled"))
    assert (ols.headline.low, ols.headline.high) == _unpooled(ols)


@pytest.mark.fast
def test_the_extra_lags_are_all_admissible_ones_or_eight_spread_over_them() -> None:
    from tribodyn.pipeline.instrument import EXTRA_LAGS, extra_lags

    assert extra_lags([9]) == () and extra_lags([9, 10, 12]) == (10, 12)
    assert extra_lags(list(range(9, 18))) == tuple(range(10, 18))  # 8 others: all
    got = extra_lags(list(range(40, 61)))  # 20 others: 8, the nearest and the farthest kept, evenly by rank
    assert len(got) == EXTRA_LAGS and got[0] == 41 and got[-1] == 60 and list(got) == sorted(set(got))


def test_the_pooled_moves_are_the_same_from_ranges_of_the_recording(band_200s: tuple, tmp_path) -> None:
    # the per-window sums travel with the windows: ranges of one recording combined (analyze_many's split, the
    # watch's parts) give the same moves as one pass
    from tribodyn.io.writers import save_recording
    from tribodyn.pipeline.distributed import analyze_many

    src, res = band_200s
    path = str(tmp_path / "band.h5")
    save_recording(path, {k: np.asarray(v) for k, v in src.items()}, 1000.0)
    with tribodyn.open_recording(path) as rec:
        whole = tribodyn.analyze(rec, threads=1)
    many = analyze_many([path], split=37.0, threads=1).results[path]
    keys = ("iv_lag_samples", "iv_lag_pooled", "iv_lag_moves", "iv_lag_move_se", "iv_lag_shifts")
    assert whole.params.get("iv_lag_moves") and all(whole.params[k] == many.params[k] for k in keys)
    assert (many.headline.low, many.headline.high) == (whole.headline.low, whole.headline.high)
    two = tribodyn.analyze(src, fs=1000.0, threads=2)
    assert all(two.params[k] == res.params[k] for k in keys)


def _direct_profile(segs: list, max_lag: int) -> tuple:
    # r, b, t and ref of lag_profile's docstring by direct sums over t >= L (no FFT), windows in range only
    lim = tribodyn._core.FORCE_LIMIT
    keep = [(y, z) for y, z in segs if np.all(np.abs(y) <= lim) and np.all(np.abs(z) <= lim)]
    top = max(np.max(np.abs(z)) for _, z in keep)
    n, lags = keep[0][0].size, np.arange(max_lag + 1)
    A, C = np.zeros((len(keep), max_lag + 1)), np.zeros((len(keep), max_lag + 1))
    for j, (y, z) in enumerate(keep):
        y, z = y / top - np.mean(y / top), z / top - np.mean(z / top)
        for L in lags:
            A[j, L], C[j, L] = z[L:] @ z[: n - L], y[L:] @ z[: n - L]
    r = np.median((A / (n - lags)) / (A[:, :1] / n), axis=0)
    b = C.sum(axis=0) / A.sum(axis=0)
    ref = max_lag // 2 + int(np.argmax(np.abs(r[max_lag // 2 :])))
    U = C - b * A
    phi = U / A.sum(axis=0) - (U[:, ref] / A[:, ref].sum())[:, None]
    with np.errstate(invalid="ignore"):  # 0 / 0 at the reference lag
        t = (b - b[ref]) / np.sqrt(len(keep) / (len(keep) - 1) * np.sum(phi * phi, axis=0))
    t[ref] = 0.0
    return r, b, t, ref, len(keep)


@pytest.mark.fast
@pytest.mark.parametrize("n", [101, 160])
def test_lag_profile_is_the_direct_lagged_sums(n: int) -> None:
    # issue 38 point 2: the FFT is only as long as the lags need (n + max_lag + 1, 2^a 3^b 5^c), each window on its own
    # (in the Rust core); no lag wraps round, and windows out of the kernel's range (or holding NaN) are left out
    rng = np.random.default_rng(n)
    segs = []
    for k in range(11):
        z = 5.0 + rng.standard_normal(n) + 0.8 * np.sin(np.arange(n) / 3.0 + k)
        y = 0.1 * np.roll(z, 2) + 0.05 * rng.standard_normal(n)
        segs.append((y, z))
    segs[3][1][7] = np.nan
    segs[6][0][0] = 2.0 * tribodyn._core.FORCE_LIMIT
    max_lag = (n - 1) // 2
    p = lag_profile(segs, max_lag)
    r, b, t, ref, k = _direct_profile(segs, max_lag)
    assert p is not None and p.windows == k == 9 and p.ref == ref
    np.testing.assert_allclose(p.r, r, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(p.b, b, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(p.t, t, rtol=1e-8, atol=1e-8)


@pytest.mark.fast
@pytest.mark.parametrize("n", [2000, 157, 12])
def test_the_kernels_lagged_sums_are_the_direct_sums_with_the_same_bits_at_any_thread_count(n: int) -> None:
    # issue 38 point 2: the lag profile's FFTs in the Rust core (2^a 3^b 5^c long: 3000 for 2 s windows at 1 kHz),
    # each window on its own: no lag wraps round, and the thread count changes no bit
    rng = np.random.default_rng(n)
    k, max_lag, scale = 6, (n - 1) // 2, 3.5
    z = 5.0 + rng.standard_normal((k, n)) + 0.5 * np.sin(np.arange(n) / 4.0)
    y = 0.1 * z + 0.05 * rng.standard_normal((k, n))
    A1, C1 = tribodyn._core.lagged_sums(y, z, max_lag, scale, threads=1)
    A2, C2 = tribodyn._core.lagged_sums(y, z, max_lag, scale, threads=2)
    assert A1.shape == C1.shape == (k, max_lag + 1)
    assert A1.tobytes() == A2.tobytes() and C1.tobytes() == C2.tobytes()
    yc = y / scale - (y / scale).mean(axis=1, keepdims=True)
    zc = z / scale - (z / scale).mean(axis=1, keepdims=True)
    for lag in (0, 1, max_lag // 2, max_lag):
        a = np.sum(zc[:, lag:] * zc[:, : n - lag], axis=1)
        c = np.sum(yc[:, lag:] * zc[:, : n - lag], axis=1)
        np.testing.assert_allclose(A1[:, lag], a, rtol=0, atol=1e-12 * A1[:, 0].max())
        np.testing.assert_allclose(C1[:, lag], c, rtol=0, atol=1e-12 * A1[:, 0].max())


@pytest.mark.fast
def test_the_kernels_lagged_sums_refuse_bad_input_with_an_error() -> None:
    y = np.ones((4, 10))
    with pytest.raises(ValueError, match="shape"):
        tribodyn._core.lagged_sums(y, np.ones((4, 9)), 4, 1.0)
    with pytest.raises(ValueError):
        tribodyn._core.lagged_sums(y, y, 10, 1.0)  # no lag of a window's length
    with pytest.raises(ValueError, match="scale"):
        tribodyn._core.lagged_sums(y, y, 4, 0.0)
    with pytest.raises(ValueError):
        tribodyn._core.lagged_sums(np.asfortranarray(np.ones((4, 10))), y, 4, 1.0)
    with pytest.raises(ValueError, match="whole windows of n samples"):
        tribodyn._core.lagged_sums(np.ones((4, 0)), np.ones((4, 0)), 0, 1.0)  # windows of no sample
    A, C = tribodyn._core.lagged_sums(np.ones((0, 10)), np.ones((0, 10)), 4, 1.0)  # no window
    assert A.shape == C.shape == (0, 5)


@pytest.mark.fast
def test_a_short_first_window_is_left_out_of_the_profile_not_the_rest() -> None:
    # the windows of one length longer than 2 max_lag are taken: a first pair too short for the lags is skipped
    rng = np.random.default_rng(5)
    segs = []
    for _ in range(8):
        z = 5.0 + rng.standard_normal(200)
        segs.append((0.1 * np.roll(z, 2) + 0.05 * rng.standard_normal(200), z))
    whole = lag_profile(segs, 60)
    short = lag_profile([(segs[0][0][:100], segs[0][1][:100]), *segs], 60)
    rows = lag_profile((np.stack([y for y, _ in segs]), np.stack([z for _, z in segs])), 60)
    assert whole is not None and short is not None and rows is not None
    assert whole.windows == short.windows == rows.windows == 8
    np.testing.assert_array_equal(short.b, whole.b)
    np.testing.assert_array_equal(rows.r, whole.r)
