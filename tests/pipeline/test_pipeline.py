"""COF identification on simulated recordings (docs/method.md sections 4-7).

The simulator (tribodyn.simulate) knows the true COF; these tests check the
pipeline against it, its invariance to chunking, and its errors.
"""

from __future__ import annotations

import numpy as np
import pytest
import tribodyn as td
from tribodyn import simulate


def _median_rel_error(res, sim):
    ok = res.gated
    truth = sim.truth.mu_at(res["time"][ok])
    return float(np.median(np.abs(res["mu_r"][ok] / truth - 1)))


@pytest.mark.fast
def test_temperature_test_cof_within_2_percent(temp_res, temp_sim):
    assert len(temp_res) == 406  # 4060 s, a 2 s window every 10 s
    assert temp_res.gated.mean() > 0.95
    assert _median_rel_error(temp_res, temp_sim) <= 0.02
    assert temp_res.orientation == temp_sim.orientation == -1
    assert np.all(temp_res["mu_r"][temp_res.gated] > 0)  # reported positive


def test_current_density_test_cof_and_contact_loss(cd_res, cd_sim):
    assert _median_rel_error(cd_res, cd_sim) <= 0.02
    lost = cd_sim.truth.in_contact_loss(cd_res["time"], half_width=1.0)
    assert lost.any()
    # Windows inside contact loss fail the gate, with the reason.
    inside = cd_sim.truth.in_contact_loss(cd_res["time"], half_width=0.0) & lost
    assert not cd_res.gated[inside].any()
    assert all("contact loss" in r for r in cd_res["reasons"][inside])
    # Windows well clear of it pass.
    assert cd_res.gated[~lost].mean() > 0.95
    assert np.allclose(cd_res["J"], cd_res["i"] / cd_sim.area_mm2)


def test_temperature_optimum_overlaps_simulated(temp_res, temp_sim):
    opr = td.operating_range(temp_res, "temperature", bin_width=2.5, tol=0.05, min_count=3)
    lo, hi = opr.optimum
    tlo, thi = temp_sim.truth.optimum["temperature"]
    assert max(lo, tlo) < min(hi, thi)  # they overlap
    assert abs(lo - tlo) <= 5 and abs(hi - thi) <= 5
    assert abs(opr.mu_min - 0.1) < 0.01
    assert set(opr.curves) == {"all", "heating", "cooling"}


def test_current_density_optimum_and_onset(cd_res, cd_sim):
    opr = td.operating_range(cd_res, "current_density")
    lo, hi = opr.optimum
    tlo, thi = cd_sim.truth.optimum["current_density"]
    best = opr.curves["all"].centres[np.nanargmin(opr.curves["all"].median)]
    assert tlo - 0.5 <= best <= thi + 0.5
    assert abs(0.5 * (lo + hi) - 0.5 * (tlo + thi)) <= 0.5
    assert opr.onset is not None and thi < opr.onset <= 6.5


def test_chunk_size_never_changes_the_table():
    sim = simulate.temperature_test(seed=5)
    ch = {k: v[:300_000] for k, v in sim.channels.items()}
    # iv_lag given: a one-pass stream cannot be looked at before the windows, so the lag is not chosen from
    # its data (docs/method.md 3b); the chunking is what is tested here
    kw = dict(fs=sim.fs, window=2.0, hop=3.0, temperature=sim.temperature_log, iv_lag=0.2)
    whole = td.analyze(ch, **kw)
    for chunk in (1.0, 7.3):
        part = td.analyze(ch, chunk=chunk, **kw)
        for col in whole.columns:
            np.testing.assert_array_equal(part[col], whole[col], err_msg=col)
        np.testing.assert_array_equal(part.bin_cof, whole.bin_cof)
    # An iterator of uneven chunks as a reader would give.
    cuts = np.cumsum([1, 999, 2500, 1, 7300, 4])
    pieces = np.split(np.arange(300_000), cuts)
    it = ({k: v[p] for k, v in ch.items()} for p in pieces)
    streamed = td.analyze(it, **kw)
    np.testing.assert_array_equal(streamed["mu_r"], whole["mu_r"])


def test_raw_input_with_highpass_same_cof():
    dyn = simulate.temperature_test(seed=6)
    raw = simulate.temperature_test(seed=6, raw=True)
    n = 600_000
    a = td.analyze({k: v[:n] for k, v in dyn.channels.items()}, fs=dyn.fs, window=2.0, hop=10.0)
    b = td.analyze({k: v[:n] for k, v in raw.channels.items()}, fs=raw.fs, window=2.0, hop=10.0, highpass=0.1)
    ok = a.gated & b.gated
    assert ok.mean() > 0.9
    assert np.median(np.abs(b["mu_r"][ok] / a["mu_r"][ok] - 1)) <= 0.01
    # The classical COF of the raw forces is reported beside it.
    assert np.all(np.isfinite(b["mu_classical"])) and np.all(np.isnan(a["mu_classical"]))
    with pytest.warns(DeprecationWarning, match="mu_classical"):  # the old name still reads the one column
        np.testing.assert_array_equal(b["mu_classic"], b["mu_classical"])
    assert "mu_classic" not in b.table


def test_force_dependence_sign_and_size():
    """mu = mu0 (1 + beta (N - N0) / N0): mu_b - mu_a follows beta's sign and grows with it."""
    n = 400_000
    diff = {}
    for beta in (-0.3, 0.0, 0.3, 0.6):
        sim = simulate.temperature_test(seed=7, force_dependence=beta)
        r = td.analyze({k: v[:n] for k, v in sim.channels.items()}, fs=sim.fs, window=2.0, hop=10.0)
        diff[beta] = float(np.median(r["mu_b"] - r["mu_a"]))
        if beta == 0.3:
            assert np.median(r["force_dependence"]) > 0
    assert diff[-0.3] < 0 < diff[0.3] < diff[0.6]
    assert abs(diff[0.0]) < 0.1 * diff[0.3]


def test_skewed_channel_is_reported():
    sim = simulate.temperature_test(seed=8, skew=3)
    ch = {k: v[:4000] for k, v in sim.channels.items()}
    r = td.identify(ch["fy"], ch["fz"], fx=ch["fx"], fs=sim.fs, max_lag=20)
    assert r.skew == 3
    assert not r.ok and any("skew" in why for why in r.reasons)
    res = td.analyze({k: v[:100_000] for k, v in sim.channels.items()}, fs=sim.fs, window=2.0, hop=10.0, max_lag=10)
    assert np.all(res["skew"] == 3)


def test_identify_one_window(temp_sim):
    ch = {k: v[20_000:22_000] for k, v in temp_sim.channels.items()}
    r = td.identify(ch["fy"], ch["fz"], fx=ch["fx"], fs=temp_sim.fs, rpm=250, n_lamellas=24, max_lag=50)
    mu = float(temp_sim.truth.mu_at(21.0))
    assert abs(r.mu_r / mu - 1) < 0.03
    assert r.ok and r.reasons == ()
    assert r.c_yz < -0.85 and abs(r.c_xz) < abs(r.c_yz) and abs(r.c_xy) < abs(r.c_yz)
    assert r.bins.counts.sum() == int(np.sum(np.abs(ch["fz"]) >= 0.35))
    assert r.bins.edges[0] == ch["fz"].min() and r.bins.edges[-1] == ch["fz"].max()
    np.testing.assert_allclose(np.nanmean(r.bins.cof), r.mu_r, rtol=0.1)
    # The yz cross-spectrum dominates at the lamella frequency (Sec. 3.1).
    assert r.spectra["yz"]["f_l"] > r.spectra["xy"]["f_l"]
    assert set(r.correlations) == {"xy", "xz", "yz"} and r.skew == 0
    # Orientation given explicitly flips the sign; the fit (same instrument lag: one revolution) does not move.
    r2 = td.identify(ch["fy"], ch["fz"], fs=temp_sim.fs, rpm=250, orientation=1)
    assert r2.mu_r == -r.mu_r and np.isnan(r2.c_xy)
    # Sigma deadband.
    r3 = td.identify(ch["fy"], ch["fz"], fs=temp_sim.fs, deadband="0.7sigma")
    assert r3.deadband == pytest.approx(0.7 * np.std(ch["fz"], ddof=1), rel=1e-9)


def test_identify_mu_a_mu_b_by_hand():
    rng = np.random.default_rng(0)
    fz = np.linspace(-1.36, 1.12, 2000)
    rng.shuffle(fz)
    fy = -np.where(fz < 0, 0.160, 0.155) * fz + 0.001 * rng.standard_normal(fz.size)
    r = td.identify(fy, fz, fs=1000.0, deadband=0.35)
    assert r.orientation == -1
    a = fz <= -0.35
    assert r.mu_a == pytest.approx(np.mean(-fy[a] / fz[a]), rel=1e-12)
    assert r.mu_a == pytest.approx(0.160, abs=1e-3) and r.mu_b == pytest.approx(0.155, abs=1e-3)


def test_deadband_excluding_everything_gives_nan_row_with_reason(temp_sim):
    ch = {k: v[:50_000] for k, v in temp_sim.channels.items()}
    res = td.analyze(ch, fs=temp_sim.fs, window=2.0, hop=10.0, deadband=100.0)
    assert np.all(np.isnan(res["mu_a"])) and np.all(np.isnan(res["mu_b"]))
    assert np.all(np.isfinite(res["mu_r"]))
    assert all("deadband" in r for r in res["reasons"])
    r = td.identify(ch["fy"][:2000], ch["fz"][:2000], fs=1000.0, deadband=100.0)
    assert np.isnan(r.mu_a) and not r.ok


def test_acquisitions_are_one_window_each(temp_sim):
    acqs = [{k: v[s : s + 2000] for k, v in temp_sim.channels.items()} for s in (0, 10_000, 20_000)]
    acqs[1]["t0"] = 10.0
    res = td.analyze(acqs, fs=temp_sim.fs)
    assert len(res) == 3
    np.testing.assert_array_equal(res["acquisition"], [0, 1, 2])
    np.testing.assert_allclose(res["time"], [1.0, 11.0, 5.0])
    one = td.identify(acqs[2]["fy"], acqs[2]["fz"], fx=acqs[2]["fx"], fs=temp_sim.fs, orientation=-1)
    assert res["mu_ols"][2] == one.mu_ols  # the same least-squares slope of the same samples
    paper = td.identify(acqs[2]["fy"], acqs[2]["fz"], fx=acqs[2]["fx"], fs=temp_sim.fs, orientation=-1, method="paper")
    assert res["mu_ols"][2] == paper.mu_r  # method="paper" is the paper's OLS


def test_threads_do_not_change_results(temp_sim):
    ch = {k: v[:200_000] for k, v in temp_sim.channels.items()}
    a = td.analyze(ch, fs=temp_sim.fs, window=2.0, hop=2.0, threads=1)
    b = td.analyze(ch, fs=temp_sim.fs, window=2.0, hop=2.0, threads=2)
    for col in a.columns:
        np.testing.assert_array_equal(a[col], b[col])


def test_to_pandas_and_summary(temp_res):
    pd = pytest.importorskip("pandas")
    df = temp_res.to_pandas()
    assert isinstance(df, pd.DataFrame) and len(df) == len(temp_res)
    assert df.index.name == "time" and list(df.columns) == [c for c in td.WINDOW_COLUMNS if c != "time"]
    assert df.attrs["units"]["mu_r"] == "1"
    s = temp_res.summary()
    assert s["windows"] == 406 and 0.05 < s["mu_r"]["median"] < 0.3


# -- bad input ---------------------------------------------------------------

GOOD = {"fy": np.sin(np.arange(5000) * 0.1), "fz": np.cos(np.arange(5000) * 0.1)}


@pytest.mark.parametrize(
    "kwargs, exc, match",
    [
        (dict(fs=0), ValueError, "fs must be"),
        (dict(fs=-1.0), ValueError, "fs must be"),
        (dict(fs=1000.0, window=0), ValueError, "window must be"),
        (dict(fs=1000.0, hop=-2), ValueError, "hop must be"),
        (dict(fs=1000.0, window=10.0), ValueError, "shorter than one window"),
        (dict(fs=1000.0, temperature=([2.0, 1.0], [100.0, 110.0])), ValueError, "strictly increasing"),
        (dict(fs=1000.0, temperature=([1.0, 2.0], [np.nan, 110.0])), ValueError, "NaN"),
        (dict(fs=1000.0, orientation=2), ValueError, "orientation"),
        (dict(fs=1000.0, deadband="lots"), ValueError, "deadband"),
        (dict(fs=1000.0, gate=1.5), ValueError, "gate"),
        (dict(fs=1000.0, voltage=1.0), ValueError, "shunt_ohm"),
    ],
)
def test_analyze_bad_options(kwargs, exc, match):
    with pytest.raises(exc, match=match):
        td.analyze(GOOD, **kwargs)


@pytest.mark.fast
def test_analyze_bad_channels():
    with pytest.raises(ValueError, match="equal lengths"):
        td.analyze({"fy": np.zeros(5000), "fz": np.zeros(4000)}, fs=1000.0)
    with pytest.raises(ValueError, match="lacks the required channel"):
        td.analyze({"fy": np.zeros(5000)}, fs=1000.0)
    with pytest.raises(TypeError, match="fs="):
        td.analyze(GOOD)
    with pytest.raises(TypeError, match="mapping"):
        td.analyze([np.zeros(3)], fs=1000.0)
    with pytest.raises(ValueError, match="NaN"):
        td.analyze({"fy": np.full(5000, np.nan), "fz": np.zeros(5000)}, fs=1000.0)


@pytest.mark.fast
def test_identify_bad_input():
    with pytest.raises(ValueError, match="equal lengths"):
        td.identify(np.zeros(10), np.zeros(11), fs=1.0)
    with pytest.raises(ValueError, match="fs"):
        td.identify(np.zeros(10), np.zeros(10), fs=0)
    with pytest.raises(ValueError, match="n_bins"):
        td.identify(np.zeros(10), np.zeros(10), fs=1.0, n_bins=0)
    # Constant fz: a NaN result with its reason, not an exception.
    r = td.identify(np.arange(10.0), np.ones(10), fs=1.0)
    assert np.isnan(r.mu_r) and not r.ok and "degenerate" in r.reasons[0]
