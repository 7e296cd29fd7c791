"""The automatic role map by evidence (issue 21 point 4, docs/method.md 6f): the friction role goes to the
tangential channel that carries the friction, with its evidence in ``Results.params``; one channel is
never bound to two roles."""

from __future__ import annotations

import json

import numpy as np
import pytest
import tribodyn as td
from tribodyn import simulate
from tribodyn.app.cli import main
from tribodyn.io import RecordingError
from tribodyn.io import roles as R
from _paths import TESTS

DATA = TESTS / "data" / "real"
CETR_COLUMNS = ["Fx", "Fy", "Fz", "Z", "Y", "X", "V1", "V2", "V3", "T", "Ff", "COF"]
CETR_UNITS = ["g", "g", "g", "mm", "mm", "mm", "mm/sec", "mm/sec", "mm/sec", "sec", "g", ""]


def _cetr_csv(path, fx, fy, ff, fz, fs, x=None):
    """A CETR UMT export (preamble, names and units rows) whose COF column is |Fx|/|Fz|."""
    n = fz.size
    t = np.arange(n) / fs
    x = np.zeros(n) if x is None else x
    cols = [fx, fy, fz, np.zeros(n), np.zeros(n), x, np.gradient(x) * fs, np.zeros(n), np.zeros(n), t, ff]
    cols.append(np.abs(fx) / np.abs(fz))
    head = ["Created by CETR Data Viewer ver.2.19.106", "Total number of steps = 1", "", "Step No. 1"]
    lines = [*head, "Velocity     = 240", f"Data Count   = {n}", "", ",".join(CETR_COLUMNS), ",".join(CETR_UNITS), ""]
    lines += [",".join(f"{v:.6f}" for v in row) for row in zip(*cols)]
    path.write_text("\n".join(lines) + "\n")
    return path


def _csv(path, columns):
    """A plain CSV with a time column at 100 Hz and the given columns (name -> array)."""
    n = len(next(iter(columns.values())))
    t = np.arange(n) / 100.0
    rows = np.column_stack([t, *columns.values()])
    np.savetxt(path, rows, delimiter=",", header=",".join(["time", *columns]), comments="", fmt="%.6f")
    return path


def _unidirectional(n=3000, mu=0.3, seed=0):
    rng = np.random.default_rng(seed)
    fz = 200.0 + 2.0 * rng.standard_normal(n)
    friction = mu * fz * (1 + 0.03 * rng.standard_normal(n))
    return friction, fz, rng


def test_cetr_export_with_the_friction_on_fx_and_lateral_noise_on_fy_and_ff(tmp_path):
    friction, fz, rng = _unidirectional()
    p = _cetr_csv(tmp_path / "run.csv", fx=friction, fy=2.0 * rng.standard_normal(fz.size),
                  ff=3.0 * rng.standard_normal(fz.size), fz=-fz, fs=50.0)  # fmt: skip
    rec = td.open_recording(p)
    assert rec.format == "cetr"  # its vendor map names Ff the friction: the evidence overrules it
    assert rec.roles["fy"] == "Fx" and rec.roles["fz"] == "Fz" and rec.roles_source == "automatic"
    assert len(set(rec.roles.values())) == len(rec.roles)
    assert [c.role for c in rec.channels if c.name == "Fx"] == ["fy"]
    choice = rec.role_choice
    assert choice is not None and choice.rule == R.RULE_RATIO and not choice.ambiguous
    ev = {c.channel: c for c in choice.candidates}
    assert set(ev) == {"Fx", "Fy", "Ff"}
    assert ev["Fx"].ratio == pytest.approx(0.3, rel=0.02) and ev["Fx"].cv < 0.1
    assert ev["Fy"].ratio < 0.02 and ev["Ff"].ratio < 0.02 and ev["Fy"].cv > 0.5
    res = td.analyze(rec)
    evidence = res.params["roles_evidence"]
    assert evidence["friction"] == "Fx" and evidence["ambiguous"] is False
    assert evidence["candidates"]["Fx"]["ratio_median"] == pytest.approx(0.3, rel=0.02)
    assert res.params["roles"]["fy"] == "Fx" and res.params["roles_source"] == "automatic"
    assert res.summary()["roles_evidence"] == evidence
    assert res.params["motion"] == "unidirectional"
    assert res.summary()["verdict"]["cof"]["value"] == pytest.approx(0.3, rel=0.01)
    assert not any("ambiguous" in w for w in res.warnings)


def test_names_would_take_the_lateral_axis_the_evidence_takes_the_friction(tmp_path):
    friction, fz, rng = _unidirectional(seed=1)
    p = _csv(tmp_path / "run.csv", {"Fx": friction, "Fy": 1.5 * rng.standard_normal(fz.size), "Fz": fz})
    assert td.io.base.roles_by_name(["time", "Fx", "Fy", "Fz"]) == {"fx": "Fx", "fy": "Fy", "fz": "Fz"}
    rec = td.open_recording(p)
    assert rec.roles == {"fx": "Fy", "fy": "Fx", "fz": "Fz"}  # fx: the remaining (lateral) axis
    res = td.analyze(rec)
    assert res.summary()["verdict"]["cof"]["value"] == pytest.approx(0.3, rel=0.01)
    # The friction on Fy, as the names say: the evidence agrees and keeps the names' map.
    q = _csv(tmp_path / "y.csv", {"Fx": 1.5 * rng.standard_normal(fz.size), "Fy": friction, "Fz": fz})
    assert td.open_recording(q).roles == {"fx": "Fx", "fy": "Fy", "fz": "Fz"}


def _recip_csv(path, lateral, *, seed=3, mu=0.12, position=True):
    sim = simulate.reciprocating(seed=seed, cycles=12, frequency=1.0, fs=200.0, mu_forward=mu, mu_backward=mu)
    ch = sim.channels
    cols = {"Fx": ch["fy"], "Fy": lateral(ch, np.random.default_rng(seed)), "Fz": ch["fz"]}
    if position:
        cols["Position"] = ch["x"]
    return _csv(path, cols)


def _lateral_square(ch, rng):
    """A lateral force that reverses on its own, 0.7x the stroke rate: it never follows the motion."""
    t = np.arange(ch["fz"].size) / 200.0
    return 0.11 * ch["fz"] * np.sign(np.sin(2 * np.pi * 0.7 * t + 0.3)) + 0.01 * rng.standard_normal(t.size)


def test_reciprocating_position_column_decides_between_two_reversing_axes(tmp_path):
    p = _recip_csv(tmp_path / "recip.csv", _lateral_square)
    # Without the position: both axes reverse, with the same |Ft|/|Fn|: ambiguous, said in one line.
    rec = td.open_recording(_recip_csv(tmp_path / "recip_nox.csv", _lateral_square, position=False))
    assert rec.role_choice is not None and rec.role_choice.ambiguous
    warning = rec.role_choice.warning
    assert warning is not None and "\n" not in warning and "Fx" in warning and "Fy" in warning
    assert warning in rec.warnings
    # With the position mapped, only Fx's sign follows the sliding direction.
    rec = td.open_recording(p, channels={"x": "Position"})
    choice = rec.role_choice
    assert choice is not None and not choice.ambiguous
    assert rec.roles["fy"] == "Fx" and rec.roles["x"] == "Position" and rec.roles_source == "partly given"
    assert choice.rule == R.RULE_MOTION and choice.motion == "Position"
    ev = {c.channel: c for c in choice.candidates}
    assert ev["Fx"].follows >= 0.95 and ev["Fx"].strokes >= 20
    assert ev["Fy"].follows < 0.8
    res = td.analyze(rec)
    assert res.params["motion"] == "reciprocating"
    assert res.params["roles_evidence"]["motion"] == "Position"
    assert res.summary()["verdict"]["cof"]["value"] == pytest.approx(0.12, rel=0.03)
    assert not any("ambiguous" in w for w in res.warnings)
    # A column named "Position" is the x role by its name: the same choice without a map.
    auto = td.open_recording(p)
    assert auto.roles["x"] == "Position" and auto.roles["fy"] == "Fx" and not auto.role_choice.ambiguous


def test_reciprocating_without_position_the_force_reversals_decide(tmp_path):
    p = _recip_csv(tmp_path / "recip.csv", lambda ch, rng: 0.02 * ch["fz"] * rng.standard_normal(ch["fz"].size),
                   position=False)  # fmt: skip
    rec = td.open_recording(p)
    choice = rec.role_choice
    assert choice is not None and choice.rule == R.RULE_REVERSALS and not choice.ambiguous
    assert rec.roles["fy"] == "Fx"
    ev = {c.channel: c for c in choice.candidates}
    assert ev["Fx"].follows >= 0.95 and ev["Fy"].follows is not None and ev["Fy"].follows < 0.85
    assert td.analyze(rec).params["motion"] == "reciprocating"


def test_sign_against_magnitude_is_ambiguous(tmp_path):
    """A lateral axis with a large steady offset: the motion and |Ft|/|Fn| disagree."""

    def offset_lateral(ch, rng):
        return 0.25 * ch["fz"] + 0.01 * rng.standard_normal(ch["fz"].size)

    p = _recip_csv(tmp_path / "recip.csv", offset_lateral)
    with_x = td.open_recording(p, channels={"x": "Position"}).role_choice
    assert with_x is not None and with_x.friction == "Fx" and with_x.ambiguous and with_x.rival == "Fy"
    without = td.open_recording(_recip_csv(tmp_path / "nox.csv", offset_lateral, position=False)).role_choice
    # Without a motion channel a force's own reversals do not overrule the ratio, but the doubt is said.
    assert without is not None and without.friction == "Fy" and without.ambiguous and without.rival == "Fx"
    assert "the sign says Fx" in (without.warning or "")


def test_two_alike_candidates_warn_naming_both(tmp_path):
    friction, fz, rng = _unidirectional(seed=5)
    other = 0.28 * fz * (1 + 0.03 * rng.standard_normal(fz.size))
    p = _csv(tmp_path / "alike.csv", {"Fx": friction, "Fy": other, "Fz": fz})
    res = td.analyze(td.open_recording(p))
    ev = res.params["roles_evidence"]
    assert ev["ambiguous"] is True and ev["friction"] == "Fx" and ev["rival"] == "Fy"
    lines = [w for w in res.warnings if w.startswith("friction channel ambiguous")]
    assert len(lines) == 1 and "fy <- Fx" in lines[0] and "--map fy=Fy" in lines[0]


def test_one_signal_exported_twice_is_one_axis_and_the_vendor_name_stays(tmp_path):
    friction, fz, rng = _unidirectional(seed=6)
    signed = friction * np.where(np.arange(fz.size) < fz.size // 2, -1.0, 1.0)
    p = _cetr_csv(tmp_path / "run.csv", fx=signed, fy=np.zeros(fz.size), ff=np.abs(signed), fz=-fz, fs=50.0)
    rec = td.open_recording(p)
    choice = rec.role_choice
    assert choice is not None and choice.friction == "Ff" and not choice.ambiguous
    assert {c.channel: c.same_as for c in choice.candidates} == {"Fx": "Ff", "Fy": None, "Ff": None}
    assert rec.roles == {"fy": "Ff", "fz": "Fz", "cof": "COF", "fx": "Fy"}
    assert "Fx the same axis (|Fx| = |Ff|)" in choice.evidence_text()


def test_dynamic_forces_keep_the_names(tmp_path):
    """High-passed forces (fz without its static level): |Ft|/|Fn| means nothing, the names decide."""
    rng = np.random.default_rng(7)
    fz = rng.standard_normal(4000)
    p = _csv(tmp_path / "dyn.csv", {"Fx": 5 * rng.standard_normal(4000), "Fy": 0.2 * fz, "Fz": fz})
    rec = td.open_recording(p)
    assert rec.roles == {"fx": "Fx", "fy": "Fy", "fz": "Fz"}
    assert rec.role_choice is not None and rec.role_choice.rule == R.RULE_NAMES and not rec.role_choice.ambiguous


def test_the_choice_reads_a_bounded_sample(tmp_path, monkeypatch):
    from tribodyn.io import save_npz

    monkeypatch.setattr(R, "ROLE_SAMPLES", 256 * 64)
    sim = simulate.reciprocating(seed=8, cycles=60, frequency=1.0, fs=1000.0)
    rng = np.random.default_rng(8)
    ch = sim.channels
    p = tmp_path / "long.npz"
    save_npz(p, {"Fx": ch["fy"], "Fy": 0.01 * ch["fz"] * rng.standard_normal(ch["fz"].size), "Fz": ch["fz"],
                 "pos": ch["x"]}, sim.fs)  # fmt: skip
    rec = td.open_recording(p, channels={"x": "pos"})
    assert rec.n_samples == 60000 and rec.role_choice is not None
    assert rec.role_choice.samples <= 256 * 64
    assert rec.roles["fy"] == "Fx" and rec.role_choice.rule == R.RULE_MOTION


@pytest.mark.parametrize("seed", range(5))
def test_decide_on_arrays_picks_the_friction_over_noise(seed):
    friction, fz, rng = _unidirectional(n=2000, seed=seed)
    noise = 0.05 * fz * rng.standard_normal(fz.size)
    choice = R.decide({"a": noise, "b": friction}, fz)
    assert choice.friction == "b" and not choice.ambiguous
    with pytest.raises(ValueError, match="two tangential"):
        R.decide({"a": noise}, fz)


# -- one channel, one role -------------------------------------------------------------


def test_a_user_map_binding_one_channel_to_two_roles_is_refused(tmp_path):
    friction, fz, rng = _unidirectional(seed=9)
    p = _csv(tmp_path / "run.csv", {"Fx": friction, "Fy": rng.standard_normal(fz.size), "Fz": fz})
    with pytest.raises(ValueError, match=r"channel 'Fx' is bound to both 'fx' and 'fy'"):
        td.open_recording(p, channels={"fx": "Fx", "fy": "Fx"})
    assert issubclass(RecordingError, ValueError)
    pd = pytest.importorskip("pandas")
    df = pd.DataFrame({"Fx": friction, "Fz": fz})
    with pytest.raises(ValueError, match="bound to both"):
        td.analyze(df, fs=100.0, channels={"fy": "Fx", "fx": "Fx", "fz": "Fz"})


def test_mapping_fy_takes_the_channel_from_the_default_fx(tmp_path):
    """The audit's double binding: --map fy=Fx on a file whose names gave fx <- Fx."""
    friction, fz, rng = _unidirectional(seed=10)
    p = _csv(tmp_path / "run.csv", {"Fx": friction, "Fy": rng.standard_normal(fz.size), "Fz": fz})
    rec = td.open_recording(p, channels={"fy": "Fx"})
    assert rec.roles == {"fy": "Fx", "fz": "Fz"} and rec.role_choice is None
    assert rec.roles_source == "partly given"
    assert rec.roles_given == {"fy": "Fx"}


def test_scale_by_role_while_the_friction_is_chosen_is_refused(tmp_path):
    friction, fz, rng = _unidirectional(seed=11)
    p = _csv(tmp_path / "run.csv", {"Fx": friction, "Fy": rng.standard_normal(fz.size), "Fz": fz})
    with pytest.raises(RecordingError, match="scale/units name role 'fy'.*key the scale by channel name"):
        td.open_recording(p, scale={"fy": 2.0})
    assert td.open_recording(p, scale={"Fx": 2.0}).roles["fy"] == "Fx"


# -- the CLI ---------------------------------------------------------------------------


def test_cli_prints_the_choice_and_its_evidence_in_one_line(tmp_path, capsys):
    friction, fz, rng = _unidirectional(seed=12)
    p = _csv(tmp_path / "run.csv", {"Fx": friction, "Fy": 1.5 * rng.standard_normal(fz.size), "Fz": fz})
    out = tmp_path / "out"
    assert main(["analyze", str(p), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    line = next(ln for ln in printed.splitlines() if "roles:" in ln)
    assert "fy <- Fx (|Ft|/|Fn| 0.30, CV" in line and "; Fy 0.0" in line
    assert "fx <- Fy" in line and "fz <- Fz" in line and line.endswith("(automatic; --map ROLE=CHANNEL to change)")
    s = json.loads((out / "summary.json").read_text())["recordings"]["run.csv"]
    assert s["roles_evidence"]["friction"] == "Fx"
    assert main(["analyze", str(p), "--out", str(out), "--overwrite", "--map", "fx=Fx,fy=Fx"]) == 2
    err = capsys.readouterr().err
    assert "bound to both 'fx' and 'fy'" in err and len(err.strip().splitlines()) == 1


# -- the real files of tests/data/real -------------------------------------------------


@pytest.mark.parametrize("name", ["cetr_umt2_HT-2n-6-4_2_001.csv", "cetr_umt2_HT-2n-6-4_2_002.csv"])
def test_real_cetr_friction_is_ff_one_axis_with_fx(name):
    """CETR computes COF = Ff/|Fz|, and Ff = |Fx| sample by sample: Fx carries the friction; Ff stands for it."""
    rec = td.open_recording(DATA / name)
    raw = rec.read(["Fx", "Ff", "COF"])
    np.testing.assert_allclose(np.abs(raw["Fx"]), raw["Ff"], rtol=1e-6)
    choice = rec.role_choice
    assert choice is not None and choice.rule == R.RULE_SAME and not choice.ambiguous
    assert rec.roles == {"fy": "Ff", "fz": "Fz", "cof": "COF"}
    assert {c.channel: c.same_as for c in choice.candidates} == {"Fx": "Ff", "Ff": None}
    res = td.analyze(rec)
    s = res.summary()
    instrument_mean = float(np.mean(raw["COF"]))
    assert abs(s["classical"]["mean"] / instrument_mean - 1) < 0.01
    assert abs(s["verdict"]["cof"]["value"] / instrument_mean - 1) < 0.01


@pytest.mark.parametrize(
    "names, want",
    [
        (["Zeit (s)", "Reibkraft (N)", "Normalkraft (N)", "Reibwert (-)"],
         {"fy": "Reibkraft (N)", "fz": "Normalkraft (N)", "cof": "Reibwert (-)"}),
        (["Step Time (s)", "Traction Force (N)", "Ball Load (N)", "Pin Load (N)", "Traction Coeff (-)"],
         {"fy": "Traction Force (N)", "fz": "Ball Load (N)", "cof": "Traction Coeff (-)"}),
        (["t", "FrictionForce", "Pin Load (N)"], {"fy": "FrictionForce", "fz": "Pin Load (N)"}),
        # the first tier wins over the later ones; two names of one tier leave the role to the caller
        (["t", "Fz", "Normal Load"], {"fz": "Fz"}),
        (["t", "Fz", "Load"], {}),
    ],
)  # fmt: skip
def test_the_vocabulary_maps_by_its_tiers(names, want) -> None:
    from tribodyn.io.base import roles_by_name

    got = roles_by_name(names)
    assert {r: c for r, c in got.items() if r in ("fy", "fz", "cof")} == want


def test_a_unit_with_a_slash_is_stripped_before_the_path() -> None:
    from tribodyn.io.base import base_name, roles_by_name

    assert base_name("x-Velocity (mm/s)") == "x-velocity"
    assert base_name("/group/fy [N]") == "fy"
    assert base_name("Speed [m/s]") == "speed"
    got = roles_by_name(["Time (s)", "Friction force (N)", "Normal force (N)", "x-Position (mm)", "x-Velocity (mm/s)"])
    assert got == {"fy": "Friction force (N)", "fz": "Normal force (N)", "x": "x-Position (mm)",
                   "v": "x-Velocity (mm/s)"}  # fmt: skip
