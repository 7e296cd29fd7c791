"""A known constant load for files without a load channel (issue 34 point 2; docs/method.md 6a)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import tribodyn as td
from tribodyn.app import cli

LOAD, MU = 20.0, 0.35


@pytest.fixture(scope="module")
def pod_csv(tmp_path_factory: pytest.TempPathFactory):
    """A pin-on-disc export: time, friction force and the instrument's COF, no load (it is a dead weight)."""
    rng = np.random.default_rng(1)
    n = 3000
    fy = MU * LOAD * (1 + 0.05 * rng.standard_normal(n))
    cof = fy / LOAD * (1 + 0.001 * rng.standard_normal(n))
    p = tmp_path_factory.mktemp("load") / "pod.csv"
    np.savetxt(p, np.c_[np.arange(n) / 10.0, fy, cof], delimiter=",", comments="",
               header="Time (s),Friction Force (N),Friction Coefficient")  # fmt: skip
    return p, fy, cof


@pytest.mark.fast
def test_load_makes_the_classical_cof_of_a_file_without_fz(pod_csv) -> None:
    p, fy, cof = pod_csv
    with pytest.raises(ValueError, match=r"lacks the required channel\(s\) fz .*pass load="):
        td.analyze(p)
    res = td.analyze(p, load=LOAD)
    assert res.headline.method == "classical"
    assert res.headline.value == pytest.approx(float(np.mean(np.abs(fy))) / LOAD, rel=1e-12)
    assert res.headline.low < float(np.mean(cof)) < res.headline.high
    assert res.params["roles"]["fz"] == "load (given)"
    with td.open_recording(p, load=LOAD) as rec:  # the same through an open recording and a mapping
        a = td.analyze(rec)
        assert rec.roles["fz"] == "load (given)" and rec.channels[-1].role == "fz"
        assert rec.read(["fz"])["fz"].tolist() == [LOAD] * 3000
        ranges = rec.read_ranges([(0, 5), (10, 12)], ["fz", "fy"]) if rec.random_access else None
        assert ranges is None or ranges["fz"].tolist() == [LOAD] * 7
    b = td.analyze({"fy": fy, "cof": cof}, fs=10.0, load=LOAD)
    assert a.headline.value == res.headline.value == pytest.approx(b.headline.value, rel=1e-12)


@pytest.mark.fast
def test_load_is_refused_where_it_cannot_apply(pod_csv) -> None:
    p, fy, _ = pod_csv
    with pytest.raises(ValueError, match="finite force > 0"):
        td.analyze(p, load=-1.0)
    with pytest.raises(TypeError, match="number of newtons"):
        td.analyze(p, load="20")
    with pytest.raises(ValueError, match="has fz"):
        td.analyze({"fy": fy, "fz": np.full(fy.size, LOAD)}, fs=10.0, load=LOAD)
    with pytest.raises(td.RecordingError, match="without a normal-force channel; fz is mapped"):
        td.open_recording(p, channels={"fz": "Friction Coefficient"}, load=LOAD)


def test_cli_load_and_info(pod_csv, tmp_path, capsys) -> None:
    p, fy, _ = pod_csv
    assert cli.main(["analyze", str(p), "--out", str(tmp_path / "bad"), "-q"]) == 2
    assert "--load N" in capsys.readouterr().err
    assert cli.main(["analyze", str(p), "--load", "20", "--out", str(tmp_path / "out"), "-q"]) == 0
    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    head = s["recordings"]["pod.csv"]["headline"]
    assert head["method"] == "classical" and head["value"] == pytest.approx(float(np.mean(np.abs(fy))) / LOAD)
    assert s["open_options"]["load"] == 20.0
    capsys.readouterr()
    assert cli.main(["info", str(p), "--load", "20", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)[0]
    assert info["roles"]["fz"] == "load (given)" and info["channels"][-1]["unit"] == "N"


@pytest.mark.fast
def test_a_cof_only_export_gets_the_instruments_own_cof(tmp_path) -> None:
    # issue 34 point 2: a file whose only friction information is its COF column
    rng = np.random.default_rng(2)
    n = 3000
    cof = 0.35 * (1 + 0.05 * rng.standard_normal(n))
    p = tmp_path / "cof.csv"
    np.savetxt(p, np.c_[np.arange(n) / 10.0, cof], delimiter=",", comments="", header="Time (s),Friction Coefficient")
    for res in (td.analyze(p), td.analyze(p, load=LOAD), td.analyze({"cof": cof}, fs=10.0)):
        head = res.headline
        assert head.method == "instrument" and head.value == pytest.approx(float(np.mean(np.abs(cof))), rel=1e-12)
        assert head.low < head.value < head.high and not res.verdict["dynamic_method"]
        assert any("only friction information is its COF column" in r for r in head.reasons)
    # with a load channel: the samples in contact only (a lift-off at the start and the end)
    fz = np.r_[np.zeros(300), np.full(n - 600, 10.0), np.zeros(300)] + 0.01 * rng.standard_normal(n)
    c = np.where(fz > 5, cof, 0.02 * rng.standard_normal(n))
    res = td.analyze({"cof": c, "fz": fz}, fs=10.0)
    assert res.headline.method == "instrument" and res.headline.n == n - 600
    assert res.headline.value == pytest.approx(float(np.mean(np.abs(c[300:-300]))), rel=1e-12)


@pytest.mark.fast
def test_a_reciprocating_cof_only_export_is_averaged_per_cycle() -> None:
    from tribodyn import simulate

    sim = simulate.reciprocating(seed=3)
    cof = sim.channels["fy"] / sim.channels["fz"]  # the signed COF an instrument exports
    res = td.analyze({"cof": cof, "fz": sim.channels["fz"]}, fs=sim.fs)
    assert res.params["motion"] == "reciprocating" and res.headline.method == "instrument"
    assert res.headline.value == pytest.approx(0.11, rel=0.01) and "cycles" in res.headline.estimate


def test_other_cof_definitions_are_named_not_used(tmp_path) -> None:
    """issue 34 point 2: the headline names the COF column it used and lists the file's other COF columns."""
    rng = np.random.default_rng(4)
    n = 2000
    cof = 0.3 + rng.normal(0.0, 0.01, n)
    p = tmp_path / "pod.csv"
    rows = "".join(f"{k / 10:.1f},{c:.5f},{c + 0.05:.5f},{c * 0.9:.5f},{20 + k / 1e3:.3f}\n" for k, c in enumerate(cof))
    p.write_text("Time (s),COF,Peak COF,mu_eff,Temperature (C)\n" + rows)
    res = td.analyze(td.open_recording(p, load=10.0))
    assert res.headline.method == "instrument"
    assert res.headline.value == pytest.approx(np.mean(np.abs(np.round(cof, 5))), rel=1e-9)
    text = " ".join(res.headline.reasons)
    assert "'COF'" in text and "other COF definitions, not used: 'Peak COF', 'mu_eff'" in text
    assert "Temperature" not in text
