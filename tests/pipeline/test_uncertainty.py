"""The headline's uncertainty budget: instrument and statistics (issue 36; docs/method.md 6i).

The coverage over 200 simulated instruments per case is measured by
``benches/bench_uncertainty.py`` (docs/method.md 6i gives the figures);
here a few fixed instruments, the model against the exact per-sample
inversion, the Monte Carlo against GUM, the inputs' checks and the outputs.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Dict

import numpy as np
import pytest

import tribodyn as td
from tribodyn import simulate
from tribodyn.app import cli
from tribodyn.kernels import uncertainty as unc
from tribodyn.results.budget import stat_dof
from tribodyn.analyses.compare import compare, headline_from_dict

STATEMENT: Dict[str, Any] = {
    "fy_rel": {"u": 0.005, "distribution": "normal", "dof": 10},
    "fz_rel": 0.003,
    "fy_abs": {"u": 0.01, "distribution": "rectangular"},
    "fz_abs": 0.02,
    "misalignment_deg": {"u": 0.3, "distribution": "rectangular"},
    "crosstalk": {"u": 0.002, "distribution": "triangular"},
}
MU = 0.1
FS = 1000.0


def _unidirectional(inst: unc.Instrument, seed: int, seconds: float = 30.0) -> Dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    n = int(seconds * FS)
    fz = 10.0 + 0.3 * np.sin(2 * np.pi * np.arange(n) / n + rng.uniform(0, 6.3))
    fy, fz = unc.through(inst, MU * fz, fz)
    return {"fy": fy + 0.02 * rng.standard_normal(n), "fz": fz + 0.02 * rng.standard_normal(n)}


def _reciprocating(inst: unc.Instrument, seed: int) -> Dict[str, np.ndarray]:
    sim = simulate.reciprocating(seed=seed, cycles=20, mu_forward=MU, mu_backward=MU, noise=0.0)
    ch = dict(sim.channels)
    rng = np.random.default_rng(seed)
    fy, fz = unc.through(inst, ch["fy"], ch["fz"])
    ch["fy"] = fy + 0.02 * rng.standard_normal(fy.size)
    ch["fz"] = fz + 0.02 * rng.standard_normal(fz.size)
    return ch


@pytest.fixture(scope="module")
def recip() -> td.Results:
    inst = unc.Instrument(g_y=0.004, theta=0.005, o_y=0.02, k_y=0.002)
    return td.analyze(_reciprocating(inst, 1), fs=FS, uncertainty=STATEMENT, motion="reciprocating")


@pytest.fixture(scope="module")
def uni() -> td.Results:
    inst = unc.Instrument(g_y=0.004, theta=0.004, o_y=0.01)
    return td.analyze(_unidirectional(inst, 2), fs=FS, uncertainty=STATEMENT, motion="unidirectional")


@pytest.fixture(scope="module")
def dyn() -> td.Results:
    parts = list(simulate.continuous(120.0, mu=MU, seed=4))
    ch = {k: np.concatenate([p[k] for p in parts]) for k in ("fy", "fz")}
    fy, fz = unc.through(unc.Instrument(theta=0.003, o_y=0.3, o_z=-0.2), ch["fy"], ch["fz"])
    return td.analyze({"fy": fy, "fz": fz}, fs=FS, uncertainty=STATEMENT)


# -- the inputs ----------------------------------------------------------------------------------------------------


@pytest.mark.fast
def test_inputs_parse_and_refuse_in_one_line() -> None:
    got = unc.parse_inputs({**STATEMENT, "misalignment_bias_deg": 0.2, "instrument": "rig 2"})
    assert got is not None and got.get("fy_rel") == unc.Source("fy_rel", 0.005, "normal", 10.0)
    assert got.misalignment_bias_deg == 0.2 and got.instrument == "rig 2"
    assert unc.parse_inputs(got.to_dict()) == got
    assert unc.parse_inputs(None) is None and unc.parse_inputs({}) is None
    bad = [
        ({"fy_gain": 0.1}, ValueError, "unknown key"),
        ({"fy_rel": -0.1}, ValueError, ">= 0"),
        ({"fy_rel": float("nan")}, ValueError, "finite"),
        ({"fy_rel": "x"}, TypeError, "number"),
        ({"fy_rel": 0.9}, ValueError, "beyond"),
        ({"crosstalk": {"u": 0.01, "distribution": "gaussian"}}, ValueError, "distribution"),
        ({"crosstalk": {"u": 0.01, "distribution": "rectangular", "dof": 5}}, ValueError, "normal"),
        ({"crosstalk": {"u": 0.01, "dof": 2}}, ValueError, "dof must be > 2"),
        ({"crosstalk": {"v": 0.01}}, ValueError, "unknown field"),
        ({"misalignment_bias_deg": 90}, ValueError, "45"),
    ]
    for value, kind, words in bad:
        with pytest.raises(kind, match=words) as how:
            unc.parse_inputs(value)
        assert "\n" not in str(how.value) and "uncertainty" in str(how.value)
    with pytest.raises(ValueError, match="uncertainty"):
        td.make_plan(fs=FS, uncertainty={"fy_rel": -1})
    assert unc.parse_item("misalignment_deg=0.3:rectangular") == (
        "misalignment_deg", {"u": 0.3, "distribution": "rectangular"})  # fmt: skip
    assert unc.parse_item("fy_rel=0.005:normal:12") == ("fy_rel", {"u": 0.005, "distribution": "normal", "dof": 12.0})
    assert unc.parse_item("misalignment_bias_deg=-0.2") == ("misalignment_bias_deg", -0.2)
    for text in ("fy_rel", "nope=1", "fy_rel=x", "fy_rel=1:normal:3:4", "misalignment_bias_deg=1:normal"):
        with pytest.raises(ValueError, match="--uncertainty"):
            unc.parse_item(text)


@pytest.mark.fast
def test_drawn_inputs_have_the_stated_standard_deviation() -> None:
    rng = np.random.default_rng(0)
    for dist, dof in (("normal", None), ("normal", 5.0), ("rectangular", None), ("triangular", None)):
        x = unc.Source("fy_rel", 0.01, dist, dof).draw(rng, 400_000)
        assert abs(np.std(x) / 0.01 - 1) < 0.02, (dist, dof)


# -- the model -----------------------------------------------------------------------------------------------------


@pytest.mark.fast
def test_estimator_from_sums_matches_the_exact_inversion() -> None:
    """The corrected classical COF from the sums of r^j u^k equals the per-sample inversion to 1e-4 (relative)."""
    rng = np.random.default_rng(3)
    n = 50_000
    fz = 10 + rng.standard_normal(n)
    sign = np.where(np.arange(n) % 3 == 0, -1.0, 1.0)  # both signs of the ratio
    fy = sign * 0.12 * fz + 0.05 * rng.standard_normal(n)
    mom = unc.Moments("classical", unc.ratio_sums(fy, fz) / n, n)
    assert mom.value == pytest.approx(np.mean(np.abs(fy / fz)), rel=1e-12)
    for k in range(5):
        r = np.random.default_rng(k)
        inst = unc.Instrument(g_y=r.normal(0, 0.01), g_z=r.normal(0, 0.01), o_y=r.normal(0, 0.05),
                              o_z=r.normal(0, 0.1), theta=r.normal(0, 0.01), k_y=r.normal(0, 0.005),
                              k_z=r.normal(0, 0.005))  # fmt: skip
        a11, a12, a21, a22 = inst.matrix()
        y, z = fy - inst.o_y, fz - inst.o_z
        true_y, true_z = a22 * y - a12 * z, a11 * z - a21 * y  # A^-1 times det (it cancels in the ratio)
        exact = np.mean(np.abs(true_y / true_z))
        assert float(unc.estimate(mom, inst)) == pytest.approx(exact, rel=1e-4)
    # and through(): the instrument's reading inverted gives the true forces back
    inst = unc.Instrument(g_y=0.01, theta=0.02, k_z=0.01, o_y=0.1)
    my, mz = unc.through(inst, fy, fz)
    back = float(unc.estimate(unc.Moments("classical", unc.ratio_sums(my, mz) / n, n), inst))
    assert back == pytest.approx(mom.value, rel=1e-5)


def test_mc_agrees_with_gum_and_repeats_with_a_seed(uni: td.Results, recip: td.Results, dyn: td.Results) -> None:
    for res, method in ((uni, "classical"), (recip, "per-stroke"), (dyn, "dynamic")):
        h = res.headline
        assert h.method == method
        u = h.uncertainty
        assert u is not None
        assert abs(u.u_c / u.gum["u_c"] - 1) < 0.10, method
        assert u.low < h.value < u.high and u.k is not None and 1.6 < u.k < 2.3  # 1.65 for a rectangular alone
        again = unc.propagate(h, res.budget_stats, unc.parse_inputs(STATEMENT), stat_dof=stat_dof(res, h))
        assert (again.u_c, again.low, again.high) == (u.u_c, u.low, u.high)
        other = unc.propagate(h, res.budget_stats, unc.parse_inputs(STATEMENT), seed=1)
        assert other.low != u.low
        stat = next(r for r in u.budget if r.source == "statistics")
        assert sum(r.share for r in u.budget) == pytest.approx(1.0)
        assert stat.sensitivity == 1.0 and res.budget_stats.value == pytest.approx(h.value, rel=1e-9)


def test_reciprocating_cancels_misalignment_and_fy_offset(uni: td.Results, recip: td.Results, dyn: td.Results) -> None:
    def share(res: td.Results, source: str) -> float:
        u = res.headline.uncertainty
        assert u is not None
        return next(r.share for r in u.budget if r.source == source)

    assert share(recip, "misalignment_deg") < 0.001 and share(recip, "fy_abs") < 0.001
    assert share(recip, "crosstalk") < 0.001
    assert share(uni, "misalignment_deg") > 0.5  # about theta (1 + mu^2) one way
    sens = {r.source: r.sensitivity for r in dyn.headline.uncertainty.budget}  # type: ignore[union-attr]
    assert sens["fy_abs"] == 0 and sens["fz_abs"] == 0  # a static offset does not move a dynamic slope
    assert sens["misalignment_deg"] == pytest.approx((1 + MU**2) * math.pi / 180, rel=0.05)


def test_a_few_instruments_are_covered() -> None:
    """Fixed instruments (the bench draws 200 per case): the budget covers the truth, the statistics alone do not."""
    inputs = unc.parse_inputs(STATEMENT)
    assert inputs is not None
    covered = stat_covered = 0
    for seed in range(4):
        inst = unc.instrument(inputs, np.random.default_rng(100 + seed))
        res = td.analyze(_unidirectional(inst, seed, 20.0), fs=FS, uncertainty=STATEMENT, motion="unidirectional")
        u = res.headline.uncertainty
        assert u is not None
        covered += u.low <= MU <= u.high
        stat_covered += res.headline.low <= MU <= res.headline.high
    assert covered >= 3 and stat_covered <= 1


def test_known_misalignment_is_corrected() -> None:
    inst = unc.Instrument(theta=0.5 * math.pi / 180)
    data = _unidirectional(inst, 7)
    plain = td.analyze(data, fs=FS, motion="unidirectional").headline
    fixed = td.analyze(data, fs=FS, motion="unidirectional", uncertainty={"misalignment_bias_deg": 0.5}).headline
    assert abs(plain.value - MU) > 0.008  # about 0.5 deg (1 + mu^2)
    assert fixed.uncertainty is not None and abs(fixed.uncertainty.value - MU) < 0.0005
    assert fixed.uncertainty.correction == pytest.approx(fixed.uncertainty.value - plain.value)


# -- the outputs ---------------------------------------------------------------------------------------------------


def test_without_inputs_nothing_changes_and_the_interval_says_statistical(recip: td.Results) -> None:
    data = _reciprocating(unc.Instrument(), 1)
    res = td.analyze(data, fs=FS, motion="reciprocating")
    h = res.headline
    assert h.uncertainty is None and res.budget_stats is None and res.params["uncertainty"] is None
    assert "statistical only" in h.text
    assert res.summary()["headline"]["uncertainty"] is None
    with_budget = recip.headline
    assert "+-" in with_budget.text and "(95 %, instrument and statistics)" in with_budget.text
    assert "+-" in repr(recip)
    d = recip.summary()["headline"]["uncertainty"]
    assert {"u_c", "low", "high", "k", "budget"} <= set(d)
    assert {"source", "value", "distribution", "sensitivity", "contribution", "share"} <= set(d["budget"][0])
    assert d["budget"][-1]["source"] == "statistics"
    json.dumps(recip.summary())


def test_headline_text_quotes_the_expanded_uncertainty() -> None:
    u = unc.Uncertainty(value=0.1037, u_c=0.0045, low=0.0949, high=0.1125, k=1.96, budget=())
    assert u.text == "0.104 +- 0.009 (95 %, instrument and statistics)"
    v = unc.Uncertainty(value=0.1037, u_c=0.0011, low=0.1015, high=0.1059, k=2.0, budget=())
    assert v.text == "0.1037 +- 0.0022 (95 %, instrument and statistics)"
    w = unc.Uncertainty(value=0.1037, u_c=0.004, low=0.1, high=0.12, k=None, budget=())
    assert "(95 % 0.100 to 0.120, instrument and statistics)" in w.text


def test_compare_keeps_the_instrument_part_apart(recip: td.Results) -> None:
    d = recip.summary()["headline"]
    back = headline_from_dict(json.loads(json.dumps(d)))
    assert back.uncertainty is not None and back.uncertainty.u_c == pytest.approx(recip.headline.uncertainty.u_c)
    other = dict(d, value=d["value"] * 1.001, low=d["low"] * 1.001, high=d["high"] * 1.001)
    c = compare([d, other])
    assert c.instrument is not None and c.instrument["u"] > 0
    assert c.instrument["high"] - c.instrument["low"] > c.high - c.low
    assert any("does not shrink with their number" in n for n in c.notes)
    plain = dict(d, uncertainty=None)
    assert compare([plain, dict(plain, value=d["value"] * 1.001)]).instrument is None


def test_report_and_cli_carry_the_budget(tmp_path: Path) -> None:
    sim = simulate.reciprocating(seed=3, cycles=12)
    np.savez(tmp_path / "r.npz", **sim.channels)
    cal = tmp_path / "cal.toml"
    cal.write_text('instrument = "rig 2"\nfy_rel = 0.005\nmisalignment_deg = {u = 0.3, distribution = "rectangular"}\n')
    cfg = tmp_path / "c.toml"
    cfg.write_text("[uncertainty]\nfz_rel = 0.003\n")
    out = tmp_path / "o"
    args = ["analyze", str(tmp_path / "r.npz"), "--fs", "1000", "--out", str(out), "--calibration", str(cal),
            "--config", str(cfg), "--uncertainty", "crosstalk=0.002:triangular", "-q"]  # fmt: skip
    assert cli.main(args) == 0
    s = json.loads((out / "summary.json").read_text())
    summary = s["recordings"]["r.npz"]
    got = summary["headline"]["uncertainty"]
    assert [r["source"] for r in got["budget"]] == ["fy_rel", "fz_rel", "misalignment_deg", "crosstalk", "statistics"]
    assert got["instrument"] == "rig 2"
    page = (out / "report.html").read_text()
    assert 'class="budget"' in page and "instrument and statistics" in page
    for bad in (["--uncertainty", "fy_gain=1"], ["--uncertainty", "fy_rel=-1"], ["--calibration", str(cfg)]):
        assert cli.main([*args[:5], "--out", str(tmp_path / "x"), *bad, "-q"]) == cli.EXIT_USER_ERROR


def test_a_flipped_orientation_flips_the_budget_with_the_headline(dyn: td.Results) -> None:
    head = dyn.headline
    flipped = dyn.with_orientation(-dyn.orientation).headline
    assert head.uncertainty is not None and flipped.uncertainty is not None
    assert np.sign(flipped.value) == np.sign(flipped.uncertainty.value) == -np.sign(head.value)
    assert flipped.uncertainty.low <= flipped.value <= flipped.uncertainty.high
    assert flipped.uncertainty.u_c == pytest.approx(head.uncertainty.u_c, rel=0.01)  # the same spread


# -- read once (docs/method.md 6i) ---------------------------------------------------------------------------------


def _counted(rec: Any, seen: Dict[str, int]) -> Any:
    """``rec`` whose readers add the fz samples they hand out to ``seen["fz"]``."""
    chunks, read = rec.chunks, rec.read

    def counted_chunks(*args: Any, **kwargs: Any) -> Any:
        for piece in chunks(*args, **kwargs):
            seen["fz"] += len(piece.get("fz", ()))
            yield piece

    def counted_read(*args: Any, **kwargs: Any) -> Any:
        got = read(*args, **kwargs)
        seen["fz"] += len(got.get("fz", ()))
        return got

    rec.chunks, rec.read = counted_chunks, counted_read
    return rec


def _spec(res: td.Results) -> Any:
    from tribodyn.kernels.strokes import ClassicalSpec

    tare = res.params["tare_offsets"]
    return ClassicalSpec(res.params["min_fn"], tare["fy"], tare["fz"])


@pytest.mark.parametrize("threads", [1, 2])
def test_a_classical_budget_reads_the_file_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, threads: int) -> None:
    """The budget's sums of a classical headline come from the main pass: no more samples read than without inputs,
    the fallback never called, and bitwise the sums of reading the file again, whatever the chunk size."""
    import sys

    from tribodyn.io.writers import save_npy
    from tribodyn.pipeline import budget

    p = tmp_path / "uni.npy"
    save_npy(p, _unidirectional(unc.Instrument(g_y=0.004, theta=0.004, o_y=0.01), 5, 12.0))
    mod = sys.modules["tribodyn.pipeline.budget"]
    calls: list = []
    reread = budget.classical_moments
    monkeypatch.setattr(mod, "classical_moments", lambda *a, **k: calls.append(a) or reread(*a, **k))
    for chunk in (None, 7.3, 41.0):
        seen = {"fz": 0}
        with td.open_recording(p, fs=FS, names=["fy", "fz"]) as rec:
            plain = td.analyze(_counted(rec, seen), chunk=chunk, threads=threads, motion="unidirectional")
        without = seen["fz"]
        seen["fz"] = 0
        with td.open_recording(p, fs=FS, names=["fy", "fz"]) as rec:
            res = td.analyze(_counted(rec, seen), chunk=chunk, threads=threads, motion="unidirectional",
                             uncertainty=STATEMENT)  # fmt: skip
            assert seen["fz"] == without and not calls
            again = reread(rec, rec, _spec(res), 0, rec.n_samples)
        assert res.headline.method == "classical" and res.budget_stats is not None and again is not None
        assert res.budget_stats.n == again.n == res.classical.contact
        np.testing.assert_array_equal(res.budget_stats.t, again.t)  # the same blocks, summed in the same order
        assert res.headline.value == plain.headline.value and res.headline.low == plain.headline.low
        assert res.table.keys() == plain.table.keys()
        for name, col in res.table.items():
            np.testing.assert_array_equal(col, plain.table[name], err_msg=name)
        assert res.headline.uncertainty is not None


def test_a_per_stroke_budget_reads_the_file_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The per-stroke budget's sums come from the forces the strokes' reading holds: bitwise the re-read's."""
    import sys

    from tribodyn.io.writers import save_npy
    from tribodyn.pipeline import budget

    ch = _reciprocating(unc.Instrument(g_y=0.004, theta=0.005, o_y=0.02), 2)
    p = tmp_path / "rec.npy"
    save_npy(p, {k: ch[k] for k in ("fy", "fz", "x")})
    mod = sys.modules["tribodyn.pipeline.budget"]
    calls: list = []
    reread = budget.stroke_moments
    monkeypatch.setattr(mod, "stroke_moments", lambda *a, **k: calls.append(a) or reread(*a, **k))
    counts = []
    for given in (None, STATEMENT):
        seen = {"fz": 0}
        with td.open_recording(p, fs=FS, names=["fy", "fz", "x"]) as rec:
            res = td.analyze(_counted(rec, seen), motion="reciprocating", uncertainty=given)
            counts.append(seen["fz"])
            if given is not None:
                again = reread(rec, rec, res.strokes, _spec(res), res.params["stroke_fraction"])
    assert counts[0] == counts[1] and not calls
    assert res.headline.method == "per-stroke" and res.budget_stats is not None and again is not None
    assert res.budget_stats.n == again.n
    np.testing.assert_array_equal(res.budget_stats.t, again.t)
