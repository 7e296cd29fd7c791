"""The statistics beyond the paper (issue 12; docs/method.md 3a-3f, 5).

Every test runs the project's simulator with a fixed seed
(``tribodyn.simulate.conditions``); tolerances have margin over what was
measured (docs/method.md 3f).
"""

from __future__ import annotations


import numpy as np
import pytest
import tribodyn
from tribodyn import _core, simulate
from tribodyn.kernels import reference
from tribodyn.results import DEPRECATED_COLUMNS
from tribodyn.kernels.estimators import BLOCKS, PRODUCTS, Z975, gate_precision, line_frequencies, slopes
from tribodyn.kernels import window_stats
from _paths import TESTS

MU = 0.1


def _run(sim, **kw):
    opts = dict(fs=sim.fs, window=2.0, hop=2.0, rpm=sim.rpm, n_lamellas=sim.n_lamellas)
    opts.update(kw)
    return tribodyn.analyze(dict(sim.channels), **opts)


# -- errors-in-variables: bias under noise on fz ---------------------------------------


@pytest.mark.parametrize("snr", [6.0, 10.0])
def test_default_estimator_is_unbiased_under_fz_noise(snr):
    sim = simulate.conditions(420, mu=MU, seed=11, snr_z=snr, y_noise=0.01)
    res = _run(sim)
    assert res.params["estimator"] == "corrected"
    mu = res["mu_r"]
    assert np.isfinite(mu).sum() >= 200
    assert abs(np.nanmean(mu) / MU - 1) <= 0.01
    # The paper's OLS column shows the attenuation 1 / (1 + 10^(-SNR/10)).
    att = 1.0 / (1.0 + 10 ** (-snr / 10))
    assert abs(np.nanmean(res["mu_ols"]) / MU / att - 1) <= 0.01
    # The noise measured by instruments is the simulated one.
    assert res.params["noise_z_std"] == pytest.approx(sim.truth.params["noise_z_std"], rel=0.03)
    # The attenuation test sees it in (nearly) every window.
    assert np.mean(res["attenuation_p"] < 0.05) > 0.9


@pytest.mark.fast
def test_every_estimator_on_one_recording():
    sim = simulate.conditions(200, mu=MU, seed=12, snr_z=10, y_noise=0.01)
    sz = sim.truth.params["noise_z_std"]
    for est, kw in (("iv", {}), ("corrected", {"noise": (0.01, sz)}), ("deming", {"noise": (0.01, sz)})):
        res = _run(sim, estimator=est, **kw)
        assert abs(np.nanmedian(res["mu_r"]) / MU - 1) < 0.02, est
    ols = _run(sim, estimator="ols")
    assert np.nanmedian(ols["mu_r"]) < 0.93 * MU  # attenuated by about 9 %


# -- intervals -----------------------------------------------------------------------

COVERAGE_CASES = {
    "white fy noise": dict(y_noise=0.05),
    "band fy noise": dict(y_noise=0.05, y_noise_kind="band"),
    "low-frequency fy disturbance": dict(y_noise=0.01, drift=0.05),
    "20 dB noise on fz": dict(y_noise=0.01, snr_z=20.0),
}


@pytest.mark.parametrize("case", list(COVERAGE_CASES))
def test_interval_coverage(case):
    sim = simulate.conditions(800, mu=MU, seed=13, **COVERAGE_CASES[case])
    res = _run(sim)
    lo, hi = res["mu_r_low"], res["mu_r_high"]
    assert len(res) >= 300
    cover = np.mean((lo <= MU) & (MU <= hi))
    assert 0.92 <= cover <= 0.98, f"{case}: coverage {cover:.3f}"


def test_summary_has_bootstrap_intervals():
    sim = simulate.conditions(200, mu=MU, seed=14, y_noise=0.02)
    s = _run(sim).summary()
    lo, hi = s["mu_r"]["ci"]["median"]
    assert lo <= s["mu_r"]["median"] <= hi
    assert lo <= MU <= hi
    assert s["mu_r"]["ci"]["mean"][0] < s["mu_r"]["ci"]["mean"][1]


@pytest.mark.parametrize("snr", [6.0, 20.0])
def test_summary_intervals_cover_between_recordings(snr):
    """Issue 23: the recording-wide fz-noise estimate moves every window together; the window bootstrap
    alone covered 0.85-0.90 here, with half-widths 0.85 of the spread between recordings. Drawing the
    estimate anew in each resample: measured 0.95-1.0, half-widths 1.21 of the spread (docs/method.md 3f)."""
    cover = {"median": 0, "mean": 0}
    widths, medians = [], []
    for seed in range(40, 80):
        sim = simulate.conditions(200, mu=MU, seed=seed, snr_z=snr, y_noise=0.02)
        res = _run(sim, n_lamellas=None, threads=1)
        ci = res.summary()["mu_r"]["ci"]
        for key in cover:
            cover[key] += int(ci[key][0] <= MU <= ci[key][1])
        assert (res.headline.low, res.headline.high) == ci["median"]
        widths.append((ci["median"][1] - ci["median"][0]) / (2 * 1.96))
        medians.append(res.headline.value)
    assert cover["median"] / 40 >= 0.92 and cover["mean"] / 40 >= 0.92, cover
    assert 0.9 <= np.mean(widths) / np.std(medians) <= 1.5


@pytest.mark.fast
def test_expanded_percentiles_of_the_median_cover_with_few_blocks():
    """Issue 35 point 3: the headline's interval with rpm covers 0.96-0.99 (docs/method.md 3f, "The width of
    the interval with rpm"), but not because of the expansion: with 40 independent windows (10 blocks) the
    expanded percentile interval of the median covers 0.955 (3000 draws), the plain 2.5/97.5 one 0.91. A
    change that narrowed the headline's interval by dropping the expansion fails here."""
    from tribodyn.kernels.stats import BOOTSTRAP_SEED, _all_resample_stats, _block_starts, bootstrap_ci

    rng = np.random.default_rng(35)
    starts, ell = _block_starts(np.random.default_rng(BOOTSTRAP_SEED), 40)
    draws, expanded, plain = 400, 0, 0
    for _ in range(draws):
        v = MU + 0.001 * rng.standard_normal(40)
        lo, hi = bootstrap_ci(v, threads=1)["median"]
        expanded += lo <= MU <= hi
        med = _all_resample_stats(v, starts, ell, None, width=40, threads=1)[0]  # bootstrap_ci's resamples
        lo, hi = np.percentile(med, [2.5, 97.5])
        plain += lo <= MU <= hi
    assert 0.93 <= expanded / draws <= 0.98, expanded
    assert (expanded - plain) / draws >= 0.02, (expanded, plain)


def test_bootstrap_draws_the_noise_estimate_anew():
    from tribodyn.kernels.stats import NoiseResample, bootstrap_ci, noise_resample

    rng = np.random.default_rng(4)
    var = 0.01 + 0.002 * rng.standard_normal(300)  # every window's measurement of sigma_z^2
    keep = np.ones(300, dtype=bool)
    keep[::3] = False  # windows that failed the gate still measure the noise
    v = np.full(200, MU)
    assert bootstrap_ci(v)["median"] == (MU, MU)  # identical windows: nothing to resample ...
    noise = NoiseResample(var=var, index=np.flatnonzero(keep), dnoise=np.full(200, 0.5))
    lo, hi = bootstrap_ci(v, noise=noise)["median"]
    # ... but the noise estimate's error moves all of them: half-width about 1.96 * 0.5 * se(median(var))
    se = np.sqrt(np.pi / 2) * 0.002 / np.sqrt(300)
    assert lo < MU < hi
    assert 0.5 * (hi - lo) == pytest.approx(1.96 * 0.5 * se, rel=0.35)
    assert bootstrap_ci(v, noise=noise) == bootstrap_ci(v, noise=noise)  # fixed seed
    with pytest.raises(ValueError, match="one value per window"):
        bootstrap_ci(v[:-1], noise=noise)
    with pytest.raises(ValueError, match="point into"):
        bootstrap_ci(v, noise=NoiseResample(var=var[:100], index=noise.index, dnoise=noise.dnoise))
    # Only the corrected estimator measuring the noise depends on it.
    sim = simulate.conditions(60, mu=MU, seed=41, snr_z=10.0, y_noise=0.02)
    res = _run(sim)
    ok = res.gated
    assert noise_resample(res.table, ok) is not None
    assert np.median(res["noise_z_var"]) == pytest.approx(res.params["noise_z_std"] ** 2, rel=1e-12)
    for kw in (dict(estimator="ols"), dict(estimator="iv"), dict(noise=(0.02, 0.05)), dict(method="paper")):
        other = _run(sim, **kw)
        assert noise_resample(other.table, other.gated) is None, kw
        assert not np.any(other["mu_r_dnoise"]), kw


def test_t_quantile_equals_scipy():
    from scipy import stats
    from tribodyn.kernels.quantiles import t_quantile

    for df in (1, 2):
        assert t_quantile(0.975, df) == pytest.approx(stats.t.ppf(0.975, df), rel=1e-12)
    tolerance = {3: (2e-3, 1e-2), 4: (5e-4, 3e-3), 8: (2e-5, 1e-4), 20: (1e-6, 1e-5), 100: (1e-9, 1e-8)}
    for df, (tol, tol_tail) in tolerance.items():
        for p in (0.95, 0.975, 0.995):
            rel = tol_tail if p > 0.975 else tol
            assert t_quantile(p, df) == pytest.approx(stats.t.ppf(p, df), rel=rel), (p, df)


# -- the gate -----------------------------------------------------------------------


def test_sign_test_fails_every_opposite_window():
    sim = simulate.conditions(100, mu=MU, seed=15, y_noise=0.01)
    ch = dict(sim.channels)
    fy = ch["fy"].copy()
    flipped = [3, 10, 11, 30]
    for k in flipped:
        fy[k * 2000 : (k + 1) * 2000] *= -1
    ch["fy"] = fy
    for gate in (None, 0.85):
        res = tribodyn.analyze(ch, fs=sim.fs, window=2.0, hop=2.0, gate=gate, orientation=-1, rpm=sim.rpm)
        bad = np.flatnonzero(np.char.find(res["reasons"].astype(str), "slope sign opposite") >= 0)
        assert list(bad) == flipped
        assert not res["ok"][flipped].any()


def test_ci_gate_keeps_good_windows_with_fy_noise():
    sim = simulate.temperature_test(seed=0)
    ch = dict(sim.channels)
    ch["fy"] = ch["fy"] + np.random.default_rng(5).normal(0.0, 0.05, ch["fy"].size)
    res = tribodyn.analyze(ch, fs=sim.fs, rpm=sim.rpm, n_lamellas=sim.n_lamellas)
    truth = sim.truth.mu_at(res["time"])
    ok = res.gated
    assert ok.mean() >= 0.9
    # Window by window the gated COF is unbiased (measured +0.2 %). The
    # summary median sits 2.1 % above the truth's median (0.1, the flat
    # bottom that half the windows share): noise spreads that point mass and
    # the walls above it pull the median up; the noise-free run's summary
    # median is 0.1003.
    assert abs(np.median(res["mu_r"][ok] / truth[ok]) - 1) <= 0.01
    assert abs(np.median(res["mu_r"][ok]) / np.median(truth[ok]) - 1) <= 0.025
    paper = tribodyn.analyze(ch, fs=sim.fs, method="paper")
    assert paper.gated.mean() < 0.6  # the |C_yz| gate rejects most of these good windows


def test_ci_gate_does_not_select_by_the_windows_error():
    """Issue 23: under a low-frequency fy disturbance the gate judged each window's half-width against its own
    mu_r and kept over-estimated windows with too short intervals (pooled coverage 0.878, headline +0.60 % on
    these seeds); the expected half-width against the recording's COF keeps neither (measured 0.962, +0.19 %)."""
    kept = covered = 0
    heads = []
    for seed in range(30, 34):
        sim = simulate.conditions(800, mu=MU, seed=seed, y_noise=0.01, drift=0.05)
        res = _run(sim, n_lamellas=None)
        ok = res.gated
        kept += int(ok.sum())
        covered += int(np.sum((res["mu_r_low"][ok] <= MU) & (MU <= res["mu_r_high"][ok])))
        heads.append(res.headline.value)
        assert res.params["gate_cof"] == pytest.approx(np.median(res["mu_r"][np.isfinite(res["mu_r"])]))
    assert kept >= 150
    assert 0.92 <= covered / kept <= 0.98
    assert abs(np.mean(heads) / MU - 1) <= 0.005


def test_gate_precision_ignores_the_windows_own_slope_and_se_noise():
    rng = np.random.default_rng(3)
    mu = 0.1 + 0.004 * rng.standard_normal(200)
    se_w = 0.003 * (1 + rng.random(200))
    se = se_w * np.sqrt(rng.chisquare(4, 200) / 4)
    rel, scale, ref = gate_precision(mu, se, se_w)
    assert ref == np.median(mu)
    assert scale == pytest.approx(1.0, abs=0.15)  # white residuals: batch means agree with se_white
    bumped, se2 = mu.copy(), se.copy()
    bumped[7] *= 1.5  # a window's own error ...
    se2[7] *= 0.2  # ... and the sampling noise of its own standard error
    rel2, _, _ = gate_precision(bumped, se2, se_w)
    assert rel2[7] == pytest.approx(rel[7], rel=0.02)  # only through the recording's medians (1 of 200)
    np.testing.assert_allclose(rel, Z975 * scale * se_w / ref)
    # Autocorrelated residuals: the ratio R carries batch means' inflation to every window.
    _, scale3, _ = gate_precision(mu, 3 * se, se_w)
    assert scale3 == pytest.approx(3 * scale)


# -- force dependence ----------------------------------------------------------------


@pytest.mark.parametrize("beta", [0.05, 0.1, 0.2])
def test_dmu_dfn_recovers_the_dependence(beta):
    sim = simulate.conditions(300, mu=MU, seed=16, beta=beta, y_noise=0.01)
    res = _run(sim)
    assert np.nanmedian(res["dmu_dfn"]) == pytest.approx(MU * beta, rel=0.1)
    # The standard errors describe the spread of the windows' estimates.
    spread = np.nanstd(res["dmu_dfn"])
    assert 0.67 < np.nanmedian(res["dmu_dfn_stderr"]) / spread < 1.5


@pytest.mark.parametrize(
    "case", [dict(beta=0.1, y_noise=0.02), dict(beta=0.1, y_noise=0.02, snr_z=10.0), dict(beta=0.1, y_noise=0.05)]
)
def test_dmu_dfn_interval_coverage(case):
    """Issue 23: dmu_dfn +- t(0.975, 4) se holds the truth in 92-98 % of the windows (1.96 se: 0.87-0.89)."""
    sim = simulate.conditions(800, mu=MU, seed=19, **case)
    res = _run(sim)
    truth = sim.truth.params["dmu_dfn"]
    lo, hi = res["dmu_dfn_low"], res["dmu_dfn_high"]
    good = np.isfinite(lo)
    assert good.sum() >= 390
    np.testing.assert_allclose(0.5 * (lo + hi)[good], res["dmu_dfn"][good], rtol=1e-12)
    assert 0.92 <= np.mean((lo[good] <= truth) & (truth <= hi[good])) <= 0.98
    paper = _run(sim, method="paper")
    assert np.isnan(paper["dmu_dfn_low"]).all() and np.isnan(paper["dmu_dfn_high"]).all()


# -- skew and alignment --------------------------------------------------------------


@pytest.mark.parametrize("delay", [0.5, 3.0])
def test_delay_is_measured_and_corrected(delay):
    sim = simulate.conditions(200, mu=MU, seed=17, delay=delay, y_noise=0.01)
    # A 3-sample delay leaves windows about +-10.3 % precise, which fails the default gate (+-10 %); without a
    # gated window the dynamic notes leave the warnings (docs/method.md 6e), so the gate is widened here.
    plain = _run(sim, max_rel_ci=0.2)
    assert plain.params["skew_median"] == pytest.approx(delay, abs=0.05)
    assert any("fz lags fy" in w for w in plain.warnings)
    aligned = _run(sim, align="auto")
    assert aligned.params["aligned"] is True
    assert aligned.params["delay_samples"] == pytest.approx(delay, abs=0.05)
    assert abs(np.nanmedian(aligned["mu_r"]) / MU - 1) <= 0.005
    assert abs(np.nanmedian(aligned["skew"])) < 0.05
    assert not any("fz lags fy" in w for w in aligned.warnings)


def test_no_delay_no_alignment():
    sim = simulate.conditions(60, mu=MU, seed=18, y_noise=0.01)
    res = _run(sim, align="auto")
    assert res.params["aligned"] is False
    assert abs(res.params["delay_samples"]) < 0.05


def test_ripple_shows_in_h1_at_the_lamella_frequency():
    flat = _run(simulate.conditions(100, mu=MU, seed=19, y_noise=0.01))
    ripple = _run(simulate.conditions(100, mu=MU, seed=19, y_noise=0.01, ripple=0.05))
    assert np.nanmedian(flat["h1_fl"]) == pytest.approx(MU, rel=0.01)
    assert np.nanmedian(flat["h1_f0"]) == pytest.approx(MU, rel=0.01)
    assert np.nanmedian(flat["coherence_fl"]) > 0.95
    assert abs(np.nanmedian(ripple["h1_fl"]) / MU - 1) > 0.02


# -- the paper's preset --------------------------------------------------------------


@pytest.mark.fast
def test_method_paper_reproduces_the_tables_before_issue_12():
    want = np.load(TESTS / "data" / "paper" / "paper_tables.npz")
    sim = simulate.current_density_test(seed=3)
    got = {"cd": tribodyn.analyze(dict(sim.channels), fs=sim.fs, window=2.0, hop=5.0, area_mm2=sim.area_mm2,
                                  method="paper")}  # fmt: skip
    chunks = list(simulate.continuous(120.0, seed=5, raw=True, mu=0.15))
    ch = {k: np.concatenate([c[k] for c in chunks]) for k in chunks[0]}
    got["raw"] = tribodyn.analyze(ch, fs=1000.0, window=1.0, hop=1.5, highpass=1.0, max_lag=5, method="paper")
    for prefix, res in got.items():
        names = [k.split("/", 1)[1] for k in want.files if k.startswith(prefix + "/")]
        for name in names:
            old = want[f"{prefix}/{name}"]
            column = DEPRECATED_COLUMNS.get(name, name)  # the tables were stored under the old names
            new = res.bin_cof if name == "bin_cof" else res.bin_counts if name == "bin_counts" else res[column]
            if old.dtype.kind in "US":
                assert list(np.asarray(new).astype(str)) == list(old), name
            else:
                np.testing.assert_array_equal(np.asarray(new), old, err_msg=f"{prefix}/{name}")


def test_method_paper_refuses_contradicting_options():
    sim = simulate.conditions(20, mu=MU, seed=1)
    with pytest.raises(ValueError, match="paper"):
        _run(sim, method="paper", estimator="iv")
    with pytest.raises(ValueError, match="paper"):
        _run(sim, method="paper", gate="ci")
    with pytest.raises(ValueError, match="estimator must be"):
        _run(sim, estimator="tls")
    with pytest.raises(ValueError, match="deming"):
        _run(sim, estimator="deming")
    with pytest.raises(ValueError, match="rpm"):
        tribodyn.analyze(dict(sim.channels), fs=sim.fs, align="auto")
    with pytest.raises(ValueError, match="twice"):
        tribodyn.analyze(iter([dict(sim.channels)]), fs=sim.fs, rpm=sim.rpm, n_lamellas=24, align="auto")


# -- kernel against the NumPy reference ---------------------------------------------


def test_block_sums_and_line_spectra_match_the_reference():
    sim = simulate.conditions(12, mu=MU, seed=20, snr_z=20, delay=0.3)
    fy, fz = sim.channels["fy"], sim.channels["fz"]
    starts = np.array([0, 1500, 3001, 7000], dtype=np.int64)
    lines, _ = line_frequencies(sim.fs, sim.rpm, sim.n_lamellas)
    db = tribodyn.kernels.deadband.parse_deadband(0.35)
    for threads in (1, 2):
        spec = window_stats.make_spec(
            2000, db, 16, ["n", "ext", "spec"], threads=threads, options=dict(lag=240, lines=list(lines), segments=4)
        )
        st = window_stats.compute(spec, fy, fz, starts)
        assert st["ext"].shape == (4, BLOCKS, len(PRODUCTS))
        for k, s0 in enumerate(starts):
            want = reference.block_sums(fy[s0 : s0 + 2000], fz[s0 : s0 + 2000], 240)
            np.testing.assert_allclose(st["ext"][k], want, rtol=1e-9, atol=1e-9)
            spec = reference.line_spectra(fy[s0 : s0 + 2000], fz[s0 : s0 + 2000], lines)
            np.testing.assert_allclose(st["spec"][k], spec, rtol=1e-8, atol=1e-9)


def test_estimators_from_reference_sums():
    """OLS from the block sums is the kernel's slope; IV is the ratio of the instrument's covariances."""
    sim = simulate.conditions(20, mu=MU, seed=21, snr_z=10)
    fy, fz = sim.channels["fy"][:2000], sim.channels["fz"][:2000]
    E = reference.block_sums(fy, fz, 240)[None]
    sl = slopes(E, np.array([2000]), "iv")
    assert sl.ols[0] == pytest.approx(np.polyfit(fz, fy, 1)[0], rel=1e-12)
    w = np.concatenate([fz[240:480], fz[:-240]])
    w = w - w.mean()
    assert sl.iv[0] == pytest.approx(np.sum(w * (fy - fy.mean())) / np.sum(w * (fz - fz.mean())), rel=1e-12)


def test_delay_correction_is_window_local_and_route_independent(tmp_path):
    sim = simulate.conditions(60, mu=MU, seed=22, delay=0.7, y_noise=0.01)
    ch = {k: sim.channels[k] for k in ("fx", "fy", "fz")}
    path = tmp_path / "rec.npy"
    np.save(path, np.stack([ch["fx"], ch["fy"], ch["fz"]]))
    a = _run(sim, align="auto")
    rec = tribodyn.open_recording(path, fs=sim.fs, names=["fx", "fy", "fz"])
    b = tribodyn.analyze(rec, window=2.0, hop=2.0, rpm=sim.rpm, n_lamellas=sim.n_lamellas, align="auto")
    assert b.params["route"] == "mapped"
    for col in ("mu_r", "mu_r_stderr", "dmu_dfn", "skew", "h1_fl", "n"):
        np.testing.assert_array_equal(a[col], b[col], err_msg=col)
    assert a["n"][0] == 2000 - 2 * 16  # the filter's taps stay inside the window


def test_identify_estimators():
    sim = simulate.conditions(4, mu=MU, seed=23, snr_z=6)
    fy, fz = sim.channels["fy"], sim.channels["fz"]
    ols = tribodyn.identify(fy, fz, fs=sim.fs)
    iv = tribodyn.identify(fy, fz, fs=sim.fs, rpm=sim.rpm, estimator="iv")
    assert ols.estimator == "ols" and np.isnan(ols.mu_r_low)
    assert ols.mu_r < 0.85 * MU
    assert iv.mu_r == pytest.approx(MU, rel=0.05)
    assert iv.mu_ols == pytest.approx(ols.mu_r)
    assert iv.mu_r_low < iv.mu_r < iv.mu_r_high
    assert iv.attenuation_p < 0.05


def test_kernel_rejects_bad_extended_options():
    x = np.zeros(100)
    with pytest.raises(ValueError, match="line"):  # refused by the spec, before any window
        _core.WindowSpec(100, ("force", 0.1), 4, ["spec"], options=dict(lines=[0.7]))
    spec = _core.WindowSpec(20, ("force", 0.1), 4, ["n"], options=dict(delay=0.5))
    with pytest.raises(ValueError, match="too short"):
        _core.windows_stats(spec, None, x, x, None, np.zeros(1, dtype=np.int64))


def test_classical_cof_kernel_matches_the_reference():
    from tribodyn.kernels.strokes import ClassicalSpec

    sim = simulate.conditions(12, mu=MU, seed=24, raw=True, y_noise=0.01)
    fy, fz = sim.channels["fy"], sim.channels["fz"]
    starts = np.array([0, 1700, 5003], dtype=np.int64)
    spec = ClassicalSpec(min_fn=2.6, tare_fy=0.01, tare_fz=0.02)  # leaves out part of each window
    db = tribodyn.kernels.deadband.parse_deadband(0.35)
    names = ["mu_classical", "mu_classical_median", "fz_mean", "fz_std"]
    st = window_stats.compute(
        window_stats.make_spec(2000, db, 16, names, options=dict(classical=(2.6, 0.01, 0.02))),
        fy,
        fz,
        starts,
    )
    want = reference.classical_windows(fy, fz, starts, 2000, spec)
    for name in names:
        np.testing.assert_allclose(st[name], want[name], rtol=1e-10, err_msg=name)


def test_student4_cdf_equals_scipy():
    from scipy import special
    from tribodyn.kernels.estimators import student4_cdf

    t = np.r_[np.linspace(-80, 80, 20001), -np.inf, np.inf, 0.0]
    np.testing.assert_allclose(student4_cdf(t), special.stdtr(4, t), rtol=0, atol=1e-15)


def test_quantile_constants_equal_scipy():
    from scipy import stats
    from tribodyn.kernels.estimators import CHI2_4_MEDIAN, T975

    assert CHI2_4_MEDIAN == pytest.approx(stats.chi2.ppf(0.5, 4), rel=1e-15)
    assert Z975 == pytest.approx(stats.norm.ppf(0.975), rel=1e-15)
    assert T975 == pytest.approx(stats.t.ppf(0.975, 4), rel=1e-15)


def test_t_and_f_distributions_are_those_of_scipy_stats():
    """kernels.quantiles' exact t and F functions (scipy.special, without importing scipy.stats): the same floats
    as scipy.stats, arrays and numbers, invalid degrees of freedom NaN."""
    from scipy import stats
    from tribodyn.kernels.quantiles import f_ppf, f_sf, t_ppf, t_sf

    rng = np.random.default_rng(3)
    p, x = rng.uniform(0.001, 0.999, 500), rng.uniform(-10.0, 30.0, 500)
    d1, d2 = rng.uniform(0.5, 200.0, 500), np.r_[rng.uniform(0.5, 500.0, 497), 0.0, -1.0, np.inf]
    np.testing.assert_array_equal(t_ppf(p, d2), stats.t.ppf(p, d2))
    np.testing.assert_array_equal(t_sf(x, d2), stats.t.sf(x, d2))
    np.testing.assert_array_equal(f_ppf(p, d1, d2), stats.f.ppf(p, d1, d2))
    np.testing.assert_array_equal(f_sf(np.abs(x), d1, d2), stats.f.sf(np.abs(x), d1, d2))
    assert float(t_ppf(0.975, 4)) == float(stats.t.ppf(0.975, 4)) and float(t_sf(1.5, 7)) == float(stats.t.sf(1.5, 7))
