"""Operating ranges with confidence (docs/method.md 6-7; issue 13).

The segmented (bathtub) fit against the simulator's truth, the verdicts,
the branch labels and covariate checks of the temperature log, absolute
log times, and contact loss. Every simulation and bootstrap has a fixed seed.
"""

from __future__ import annotations

import datetime as dt

import numpy as np
import pytest
import tribodyn as td
from tribodyn import simulate
from tribodyn.pipeline.covariates import branch, log_quality


def _cat(gen) -> dict:
    parts = list(gen)
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def _truth_twin(res: td.Results, truth) -> td.Results:
    """The same windows with the simulator's noise-free COF (for the straight-wall truth)."""
    table = dict(res.table)
    table["mu_r"] = np.asarray(truth.mu_at(res["time"]), dtype=float)
    return td.Results(table=table, bin_counts=res.bin_counts, bin_cof=res.bin_cof, fz_min=res.fz_min,
                      fz_max=res.fz_max, orientation=res.orientation, params=res.params)  # fmt: skip


@pytest.fixture(scope="module")
def temp_range(temp_res):
    return td.operating_range(temp_res, "temperature")


def test_heating_breakpoints_near_the_simulated_flat_bottom(temp_range, temp_res, temp_sim):
    heat = temp_range.fits["heating"]
    assert heat.verdict == "optimum"
    lo_true, hi_true = temp_sim.truth.optimum["temperature_heating"]
    assert abs(heat.lower - lo_true) <= 3 and abs(heat.upper - hi_true) <= 3
    # The simulated walls are curved (C1 Huber): a straight-walled fit of the noise-free COF at the
    # same windows puts the edges where the straight walls meet the floor; the intervals hold them.
    twin = td.operating_range(_truth_twin(temp_res, temp_sim.truth), "temperature", n_boot=0).fits["heating"]
    assert heat.lower_ci[0] <= twin.lower <= heat.lower_ci[1]
    assert heat.upper_ci[0] <= twin.upper <= heat.upper_ci[1]
    assert heat.lower_ci[0] <= lo_true <= heat.lower_ci[1]
    assert abs(heat.mu_min - 0.1) < 0.002 and heat.mu_min_ci[0] <= heat.mu_min <= heat.mu_min_ci[1]


def test_branches_apart_and_hysteresis(temp_range, temp_sim):
    heat, cool = temp_range.fits["heating"], temp_range.fits["cooling"]
    assert abs(cool.upper - temp_sim.truth.optimum["temperature_cooling"][1]) <= 3
    assert heat.upper_ci[0] > cool.upper_ci[1]  # the upper edges' intervals do not overlap
    h = temp_range.hysteresis
    assert h is not None and h.upper > 0 and h.upper_ci[0] > 0
    assert h.upper_ci[0] <= heat.upper - cool.upper <= h.upper_ci[1]
    assert temp_range.verdict == "optimum" and temp_range.optimum == temp_range.fits["all"].optimum


def test_branch_argument_reports_that_branch(temp_res, temp_range):
    heat = td.operating_range(temp_res, "temperature", branch="heating")
    assert heat.optimum == temp_range.fits["heating"].optimum and heat.branch == "heating"
    with pytest.raises(ValueError, match="branch"):
        td.operating_range(temp_res, "temperature", branch="up")


def test_results_repeat_with_the_seed(temp_res, temp_range):
    again = td.operating_range(temp_res, "temperature")
    assert again.optimum_ci == temp_range.optimum_ci and again.seed == 0


def test_current_density_upper_breakpoint_and_onset(cd_res, cd_sim):
    opr = td.operating_range(cd_res, "current_density")
    assert opr.verdict == "optimum"
    twin = td.operating_range(_truth_twin(cd_res, cd_sim.truth), "current_density", n_boot=0)
    lo, hi = opr.optimum
    assert abs(hi - twin.optimum[1]) <= 0.25
    assert opr.optimum_ci[1][0] <= twin.optimum[1] <= opr.optimum_ci[1][1]
    # the simulated flat bottom [4.25, 4.75] lies inside the reported interval's reach
    t_lo, t_hi = cd_sim.truth.optimum["current_density"]
    assert opr.optimum_ci[0][0] <= t_hi and t_lo <= opr.optimum_ci[1][1]
    assert opr.onset is not None and hi < opr.onset <= 6.5
    assert opr.onset_ci[0] <= opr.onset <= opr.onset_ci[1]


def test_binned_method_keeps_todays_results(cd_res):
    old = td.operating_range(cd_res, "current_density", method="binned")
    seg = td.operating_range(cd_res, "current_density")
    assert old.method == "binned" and old.optimum == old.curves["all"].optimum and old.optimum_ci is None
    assert seg.curves["all"].optimum == old.optimum  # the binned medians stay as points


def test_constant_current_density_is_no_optimum():
    ch = _cat(simulate.continuous(400.0, current=20.0, seed=1))
    res = td.analyze(ch, fs=1000.0, window=2, hop=10, area_mm2=4.0)
    opr = td.operating_range(res, "current_density")
    assert opr.verdict == "covariate constant" and opr.optimum is None and opr.optimum_ci is None
    assert "current density" in opr.explanation


def test_cof_independent_of_temperature_is_no_dependence():
    ch = _cat(simulate.continuous(1200.0, seed=2))
    rng = np.random.default_rng(0)
    log = (np.linspace(0, 1200, 13), np.round(np.linspace(100, 170, 13) + rng.normal(0, 0.3, 13), 1))
    res = td.analyze(ch, fs=1000.0, window=2, hop=10, temperature=log)
    opr = td.operating_range(res, "temperature")
    assert opr.verdict == "no dependence" and opr.optimum is None
    assert abs(opr.mu_min - 0.12) < 0.005


def test_data_on_one_wall_is_an_edge(temp_sim):
    n = 2_000_000  # 0-2000 s: 155 degC, then heating to 175: only the upper wall
    t, v = temp_sim.temperature_log
    keep = t <= 2000
    res = td.analyze({k: x[:n] for k, x in temp_sim.channels.items()}, fs=temp_sim.fs, window=2, hop=10,
                     temperature=(t[keep], v[keep]))  # fmt: skip
    opr = td.operating_range(res, "temperature")
    assert opr.verdict == "optimum at the edge of the tested range"
    assert opr.edge_lower and not opr.edge_upper
    assert opr.optimum[0] == pytest.approx(opr.fits["all"].x_range[0])
    assert opr.optimum_ci[0][0] == -np.inf


def test_too_few_windows(cd_res):
    table = {k: np.asarray(v)[:5] for k, v in cd_res.table.items()}
    small = td.Results(table=table, bin_counts=cd_res.bin_counts[:5], bin_cof=cd_res.bin_cof[:5],
                       fz_min=cd_res.fz_min[:5], fz_max=cd_res.fz_max[:5], orientation=cd_res.orientation)  # fmt: skip
    opr = td.operating_range(small, "current_density")
    assert opr.verdict == "too few windows" and opr.optimum is None


def test_plateau_with_a_noisy_log_is_branch_zero():
    rng = np.random.default_rng(5)
    t = np.cumsum(np.r_[0.0, rng.uniform(100, 200, 30)])
    v = np.round(150.0 + rng.normal(0, 0.3, t.size), 1)
    at = np.arange(5.0, t[-1], 10.0)
    assert np.all(branch((t, v), at) == 0)
    # a ramp in the same log noise keeps its sign
    ramp = np.round(100.0 + 0.02 * t + rng.normal(0, 0.3, t.size), 1)
    assert np.all(branch((t, ramp), at) == 1)


def test_plateau_windows_of_the_temperature_test_are_branch_zero(temp_res, temp_sim):
    tt = temp_res["time"]
    flat = np.abs(np.gradient(temp_sim.truth.temperature_at(tt))) < 1e-9
    assert np.all(temp_res["branch"][flat & (tt > 20) & (tt < 990)] == 0)  # 155 degC for 1000 s


def test_log_missing_a_fast_cool_down_flags_its_windows(temp_sim):
    t, v = temp_sim.temperature_log
    keep = ~np.isin(t, [3950.0, 4010.0])  # the readings at the start and end of the cool-down
    log = (t[keep], v[keep])
    res = td.analyze(temp_sim.channels, fs=temp_sim.fs, window=2, hop=10, temperature=log)
    err = np.abs(res["T"] - temp_sim.truth.temperature_at(res["time"]))
    affected = err > 3.0
    assert affected.sum() >= 5
    assert np.all(res["T_gap"][affected])
    assert np.all(res["T_uncertainty"][affected] >= err[affected] - 1.0)
    opr = td.operating_range(res, "temperature")
    assert opr.excluded["temperature log gap"] == int(res["T_gap"].sum())
    q = log_quality(log, res["time"])
    np.testing.assert_array_equal(q["T_gap"], res["T_gap"])


def test_contact_loss_flagged_and_out_of_the_fit(cd_res, cd_sim):
    inside = cd_sim.truth.in_contact_loss(cd_res["time"])
    assert inside.sum() >= 5
    reasons = cd_res["reasons"]
    assert all("contact loss" in r for r in reasons[inside])
    assert not any("contact loss" in r for r in reasons[~cd_sim.truth.in_contact_loss(cd_res["time"], 1.0)])
    assert not cd_res.gated[inside].any()
    opr = td.operating_range(cd_res, "current_density")
    assert opr.excluded["contact loss"] == int(inside.sum())
    assert opr.n_windows == int(cd_res.gated.sum())
    assert opr.instability == pytest.approx(6.5, abs=0.01)
    assert opr.instability_ci[0] == pytest.approx(6.0 - 0.025, abs=0.01)  # widened by half the resolution
    assert cd_res.summary()["gate_failures"]["contact loss"] == int(inside.sum())


def _tdms_with_start(path, start: np.datetime64, sim) -> None:
    from nptdms import ChannelObject, TdmsWriter

    props = {"wf_start_time": start, "wf_increment": 1.0 / sim.fs}
    n = 60_000
    with TdmsWriter(str(path)) as w:
        w.write_segment([ChannelObject("g", r, sim.channels[r][:n], properties=props) for r in ("fx", "fy", "fz")])


def test_absolute_log_times_align_with_the_tdms_start(tmp_path, temp_sim):
    start = np.datetime64("2024-05-02T10:15:00")
    path = tmp_path / "run.tdms"
    _tdms_with_start(path, start, temp_sim)
    stamps = [str(start + np.timedelta64(s, "s")) for s in (0, 20, 40, 60)]
    values = [150.0, 152.0, 154.0, 156.0]
    with td.open_recording(path) as rec:
        assert rec.start_time == "2024-05-02T10:15:00.000000"
        aligned = td.align_log((stamps, values), rec.start_time)
        np.testing.assert_array_equal(aligned[0], [0.0, 20.0, 40.0, 60.0])
        res = td.analyze(rec, window=2, hop=10, temperature=(stamps, values))
    np.testing.assert_allclose(res["T"], 150.0 + 0.1 * res["time"], atol=1e-9)
    # epoch seconds and offsets are the same instants
    epoch = (start - np.datetime64(0, "s")).astype(int)
    t2, _ = td.align_log(([epoch + 20.0], [1.0]), "2024-05-02T12:15:00+02:00")
    assert t2[0] == 20.0
    t3, _ = td.align_log(([dt.datetime(2024, 5, 2, 10, 15, 40, tzinfo=dt.timezone.utc)], [1.0]), start)
    assert t3[0] == 40.0


def test_absolute_log_times_without_a_start_time_say_what_is_missing(temp_sim):
    ch = {k: v[:60_000] for k, v in temp_sim.channels.items()}
    for log in ((["2024-05-02T10:15:00", "2024-05-02T10:16:00"], [1.0, 2.0]), ([1.7e9, 1.7e9 + 60], [1.0, 2.0])):
        with pytest.raises(ValueError, match="start time is missing"):
            td.analyze(ch, fs=temp_sim.fs, window=2, hop=10, temperature=log)
    with pytest.raises(ValueError, match="start time is missing"):
        td.align_log((["2024-05-02T10:15:00"], [1.0]), None)


def test_report_and_summary_show_the_fit(cd_res):
    from tribodyn.app import report

    opr = td.operating_range(cd_res, "current_density")
    d = opr.to_dict()
    assert d["verdict"] == "optimum" and d["optimum_ci"] is not None and d["bootstrap"]["seed"] == 0
    figs = report.build_report_figures(cd_res, opr_current=opr)
    cap = [c for c, _ in figs if "against current density with" in c][0]
    assert "verdict: optimum" in cap and "upper breakpoint" in cap and "[" in cap and "contact loss" in cap.lower()
    ax = figs[-1][1].axes[0]
    labels = [h.get_label() for h in ax.get_lines()]
    assert any("bathtub fit" in s for s in labels) and any("upper breakpoint" in s for s in labels)


def test_log_file_with_iso_times_reads_as_epoch_seconds(tmp_path):
    from tribodyn.app.jobs import read_log

    path = tmp_path / "temp.csv"
    path.write_text("time,T\n2024-05-02T10:15:00,150.0\n2024-05-02T10:15:20,152.0\n")
    t, v = read_log(path)
    np.testing.assert_array_equal(td.align_log((t, v), "2024-05-02T10:15:00")[0], [0.0, 20.0])


# --- issue 23, point 5: curved walls, intervals that hold the truth, the onset before contact loss ---


def test_curved_walls_recover_a_noise_free_bathtub():
    from tribodyn.analyses.walls import bootstrap_curved, fit_curved

    x = np.repeat(np.arange(2.0, 6.01, 0.5), 7) + np.tile(np.linspace(-0.01, 0.01, 7), 9)
    y = simulate.curved_bathtub(x, **simulate.CURVED_J)
    w = np.ones_like(x)
    f, sides, _ = fit_curved(x, y, w, "both", start=(4.6, 5.1))  # straight-wall breakpoints as the start
    # only the J set points carry data: the breakpoints lie between the levels that bracket the truth
    assert 4.0 < f.b_lo <= 4.5 and 4.5 <= f.b_hi < 5.0
    assert abs(f.m - 0.1) < 1e-3 and np.max(np.abs(f.predict(x) - y)) < 0.01
    # a resample drawing every window once is the data itself
    d = bootstrap_curved(x, y, w, np.ones((1, x.size)), fit=f, sides=sides)
    assert d["b_lo"][0] == pytest.approx(f.b_lo) and d["b_hi"][0] == pytest.approx(f.b_hi)
    assert d["m"][0] == pytest.approx(f.m, abs=1e-6)


def test_lower_current_density_edge_follows_the_curved_wall(cd_res, cd_sim):
    opr = td.operating_range(cd_res, "current_density")
    lo_true = cd_sim.truth.optimum["current_density"][0]
    # a straight wall through the paper's curve (flat below 3 A/mm^2) put it at 4.56
    assert abs(opr.optimum[0] - lo_true) <= 0.15
    assert opr.optimum_ci[0][0] <= lo_true <= opr.optimum_ci[0][1]
    assert opr.fits["all"].shape_lower is not None and opr.fits["all"].shape_lower[0] > 0


def test_temperature_edges_and_hysteresis_intervals_hold_the_truth(temp_range, temp_sim):
    heat, cool = temp_range.fits["heating"], temp_range.fits["cooling"]
    (h_lo, h_hi), (_, c_hi) = temp_sim.truth.optimum["temperature_heating"], temp_sim.truth.optimum[
        "temperature_cooling"]  # fmt: skip
    # straight walls put the heating upper edge at 162.0 with an interval 161.6-162.1
    assert abs(heat.upper - h_hi) <= 1.0 and heat.upper_ci[0] <= h_hi <= heat.upper_ci[1]
    assert cool.upper_ci[0] <= c_hi <= cool.upper_ci[1]
    assert heat.lower_ci[0] <= h_lo <= heat.lower_ci[1]
    h = temp_range.hysteresis
    assert h.upper_ci[0] <= h_hi - c_hi <= h.upper_ci[1]


def test_instability_onset_from_the_windows_before_contact_loss():
    sim = simulate.current_density_test(seed=4, current_drop=0.3)
    res = td.analyze(sim.channels, fs=sim.fs, window=2.0, hop=10.0, area_mm2=sim.area_mm2)
    opr = td.operating_range(res, "current_density", n_boot=0)
    lost = np.array(["contact loss" in r for r in res["reasons"]])
    assert lost.sum() >= 5 and np.all(res["J"][lost] < 5.0)  # the measured current fell in contact loss
    truth = sim.truth.params["instability_onset"]
    assert opr.instability == pytest.approx(truth, abs=0.01)
    assert opr.instability_ci[0] <= truth <= opr.instability_ci[1]
    assert opr.instability > opr.optimum[1]  # not inside the optimum
    # the contact-loss windows keep their own (lower) onset
    assert opr.contact_loss_onset == pytest.approx(float(res["J"][lost].min()))
    assert opr.to_dict()["contact_loss_onset"] == opr.contact_loss_onset


def test_simulator_options_keep_the_defaults_unchanged():
    a = simulate.current_density_test(seed=2)
    b = simulate.current_density_test(seed=2, current_drop=0.0, bathtub="paper")
    for k in a.channels:
        np.testing.assert_array_equal(a.channels[k], b.channels[k])
    c = simulate.current_density_test(seed=2, current_drop=0.3)
    lost = c.truth.in_contact_loss(np.arange(c.channels["i"].size) / c.fs)
    np.testing.assert_array_equal(a.channels["i"][~lost], c.channels["i"][~lost])
    assert np.mean(c.channels["i"][lost]) < 0.8 * np.mean(a.channels["i"][lost])
    flat = simulate.temperature_test(seed=2, model="flat")
    assert np.all(flat.truth.mu == 0.1) and flat.truth.optimum == {}
    with pytest.raises(ValueError, match="bathtub"):
        simulate.current_density_test(bathtub="round")


def _contact_loss_loop(stats, j):
    """contact_loss_mask's history rule as first written, window by window (the reference of the vectorised
    one), on the same per-window criteria; with issue 35's rule, a jump at another current than the history's
    is a current step. Returns (contact loss, current step)."""
    from tribodyn.kernels.contact_loss import COF_JUMP, HISTORY, STEP, criteria

    crit = criteria(stats, j)
    if crit is None:
        return np.zeros(len(j), dtype=bool), np.zeros(len(j), dtype=bool)
    high, collapse, spread, lasting = crit
    mu = np.asarray(stats["mu_r"], dtype=float)
    out = np.zeros(len(j), dtype=bool)
    step = np.zeros(len(j), dtype=bool)
    level = STEP * np.nanmax(np.abs(j))
    history = []
    for k in range(len(j)):
        jump = moved = False
        if lasting[k] and np.isfinite(mu[k]) and history:
            ref = float(np.median([m for m, _ in history[-HISTORY:]]))
            jump = abs(mu[k] - ref) > COF_JUMP * abs(ref)
            js = [c for _, c in history[-HISTORY:] if np.isfinite(c)]
            moved = bool(js) and abs(j[k] - float(np.median(js))) > level
        out[k] = high[k] and (collapse[k] or (jump and not moved))
        step[k] = high[k] and not collapse[k] and jump and moved
        if not out[k] and not step[k] and not collapse[k] and np.isfinite(mu[k]) and not spread[k]:
            history.append((mu[k], j[k]))
    return out, step


def test_contact_loss_mask_flags_what_the_window_by_window_rule_flags():
    from tribodyn.kernels.contact_loss import classify, contact_loss_mask

    rng = np.random.default_rng(7)
    flagged = stepped = 0
    for _ in range(500):
        n = int(rng.integers(0, 120))
        c = rng.uniform(0, 1, n) * np.where(rng.random(n) < 0.2, 0.3, 1.0)
        se = rng.exponential(1, n) * np.where(rng.random(n) < 0.3, 10.0, 1.0)
        mu = np.where(rng.random(n) < 0.05, np.nan, 0.2 + rng.normal(0, 0.05, n))
        j = np.where(rng.random(n) < 0.05, np.nan, rng.uniform(0, 10, n))
        stats = {"c_yz": c, "mu_r": mu, "mu_r_stderr": se}
        want, step = _contact_loss_loop(stats, j)
        np.testing.assert_array_equal(contact_loss_mask(stats, j), want)
        np.testing.assert_array_equal(classify(stats, j)[1], step)
        flagged += int(want.sum())
        stepped += int(step.sum())
    assert flagged > 1000 and stepped > 100  # the cases flag windows, by collapse and by jumps, and steps


# --- issue 35, point 2: operating ranges independent of the hop ---


def test_windows_repeated_k_times_with_overlap_k_choose_as_the_windows_once():
    from tribodyn.analyses.segmented import block_length, fit_bathtub

    rng = np.random.default_rng(3)
    x = np.linspace(100.0, 170.0, 60)
    y = 0.1 + 0.002 * np.maximum(125.0 - x, 0.0) + rng.normal(0.0, 0.004, x.size)
    se = np.full(x.size, 0.004)
    once = fit_bathtub(x, y, se)
    five = fit_bathtub(np.repeat(x, 5), np.repeat(y, 5), np.repeat(se, 5), overlap=5.0)
    assert once.fit.family == five.fit.family == "lower"
    assert five.p_flat == pytest.approx(once.p_flat, rel=0.2)  # counted as independent it would be ~1e-40 smaller
    assert fit_bathtub(np.repeat(x, 5), np.repeat(y, 5), np.repeat(se, 5)).p_flat < 1e-6 * once.p_flat
    # the bootstrap's block spans the same time at every hop
    assert block_length(400) == 8 and block_length(2000, 5.0) == 40 and block_length(800, 2.0) == 16


@pytest.fixture(scope="module")
def cd_hops(cd_sim):
    """The current-density test in 10 s windows at hops of 10 and 2 s (they overlap 1 and 5 times)."""
    return {hop: td.analyze(cd_sim.channels, fs=cd_sim.fs, window=10.0, hop=hop, area_mm2=cd_sim.area_mm2)
            for hop in (10.0, 2.0)}  # fmt: skip


def test_a_current_step_is_no_contact_loss_and_the_onset_stays_at_any_hop(cd_hops, cd_sim):
    from tribodyn.analyses.ranges import held, overlap

    for hop, res in cd_hops.items():
        reasons = res["reasons"]
        lost = np.array(["contact loss" in r for r in reasons])
        # windows clear of the simulated contact loss are never flagged (at hop 2 s they were: the onset read 5.3)
        assert not lost[~cd_sim.truth.in_contact_loss(res["time"], 5.0)].any()
        opr = td.operating_range(res, "current_density", n_boot=0)
        assert opr.instability == pytest.approx(6.5, abs=0.01), hop
        assert opr.instability_ci[0] == pytest.approx(6.0 - 0.025, abs=0.01)  # the last level held: 6.0
        assert overlap(res) == pytest.approx(10.0 / hop)
    res = cd_hops[2.0]
    stepped = np.array(["current step" in r for r in res["reasons"]])
    assert stepped.any() and res.summary()["gate_failures"]["current step"] == int(stepped.sum())
    # those windows lie at the steps (every 70 s): they straddle one, or follow it within the COF's response
    assert np.all(np.minimum(res["t_start"][stepped] % 70.0, 70.0 - res["t_start"][stepped] % 70.0) <= 12.0)
    still = held(res, np.asarray(res["J"]), 0.05)
    straddle = (res["t_start"] % 70.0 > 60.5) & (res["t_start"] % 70.0 < 69.5)  # 10 s windows over a step
    assert not still[straddle & (res["t_start"] < 620)].any() and still[res["t_start"] % 70.0 == 0].all()


def test_verdict_and_walls_the_same_at_hops_10_and_2(cd_hops):
    fits = {hop: td.operating_range(res, "current_density", n_boot=100) for hop, res in cd_hops.items()}
    a, b = fits[10.0], fits[2.0]
    assert a.verdict == b.verdict == "optimum"
    for side in (0, 1):
        # each edge lies in the other hop's interval
        assert a.optimum_ci[side][0] <= b.optimum[side] <= a.optimum_ci[side][1]
        assert b.optimum_ci[side][0] <= a.optimum[side] <= b.optimum_ci[side][1]
    assert a.mu_min_ci[0] <= b.mu_min <= a.mu_min_ci[1] and b.mu_min_ci[0] <= a.mu_min <= b.mu_min_ci[1]
    # the windows that straddle a step (none at a hop of 10 s: they start at the steps) stay out of the fit
    assert "covariate step in the window" not in a.excluded and b.excluded["covariate step in the window"] >= 20


def test_a_running_in_on_the_start_plateau_is_no_wall():
    """simulate.temperature_test(running_in=0.3): the COF starts 30 % high on the 155 degC plateau."""
    from tribodyn.analyses.ranges import running_in_end

    sim = simulate.temperature_test(seed=5, running_in=0.3)
    res = td.analyze(sim.channels, fs=sim.fs, window=10.0, hop=10.0, temperature=sim.temperature_log)
    opr = td.operating_range(res, "temperature", n_boot=0)
    end = sim.truth.params["running_in_end_s"]
    n_in = int(np.sum(res["time"] < end))
    assert opr.excluded["running-in"] == pytest.approx(n_in, abs=0.3 * n_in)
    heat, cool = opr.fits["heating"], opr.fits["cooling"]
    # with the running-in fitted, the cooling edge read 149 (truth 155) and the floor 0.103
    assert abs(cool.upper - 155.0) <= 1.5 and abs(heat.mu_min - 0.100) < 0.001
    # the same on one window per window length: a series at hop 2 s thinned five times gives the same end
    t = np.arange(5.0, 1000.0, 2.0)
    y = 0.1 * (1 + 0.3 * np.exp(-t / 150.0)) + np.random.default_rng(1).normal(0, 0.002, t.size)
    x = np.full(t.size, 155.0)
    x[-50:] = 160.0
    assert running_in_end(t, x, y, 1.0, overlap=5.0) == pytest.approx(150.0 * np.log(50.0), rel=0.15)
    assert running_in_end(t, x, np.full(t.size, 0.1), 1.0, overlap=5.0) == -np.inf  # no running-in


def test_the_default_temperature_test_has_no_running_in(temp_range):
    assert "running-in" not in temp_range.excluded
