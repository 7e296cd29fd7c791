"""``tare="auto" | "start" | "none"`` (issue 34 point 5; docs/method.md 6a): which unloaded samples give the tare,
and whether a drag in the friction channel is taken away."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import tribodyn as td
from tribodyn.app.cli import main


FS = 100.0


def _drag_test(drag: float = 0.5, start_unloaded: bool = True, end_unloaded: bool = False, seed: int = 0):
    """A disc turning before and after the load: fy carries its drag unloaded; mu = 0.2 of the load."""
    rng = np.random.default_rng(seed)
    pieces = []
    if start_unloaded:
        pieces.append((np.zeros(1000), np.full(1000, drag)))
    fz = 10.0 + rng.normal(0.0, 0.05, 6000)
    pieces.append((fz, drag + 0.2 * fz))
    if end_unloaded:
        pieces.append((np.zeros(1000), np.full(1000, 2 * drag)))
    fz = np.concatenate([p[0] for p in pieces]) + rng.normal(0.0, 0.005, sum(len(p[0]) for p in pieces))
    fy = np.concatenate([p[1] for p in pieces]) + rng.normal(0.0, 0.005, fz.size)
    return {"fy": fy, "fz": fz}


@pytest.mark.fast
def test_auto_takes_the_unloaded_level_before_the_contact_away() -> None:
    res = td.analyze(_drag_test(), fs=FS)
    assert res.headline.method == "classical"
    assert res.headline.value == pytest.approx(0.2, rel=2e-3)
    assert res.params["tare_offsets"]["fy"] == pytest.approx(0.5, abs=0.01)


@pytest.mark.fast
def test_none_keeps_the_drag_in_the_friction() -> None:
    res = td.analyze(_drag_test(), fs=FS, tare="none")
    assert res.headline.value == pytest.approx(0.25, rel=2e-3)  # (0.5 + 2) / 10
    assert res.params["tare_offsets"]["fy"] == 0.0
    assert res.params["tare_offsets"]["fz"] == pytest.approx(0.0, abs=0.01)  # fz's zero still decides contact
    assert "fy not tared" in res.params["contact"]["rule"]
    assert res.params["tare"] == "none"


@pytest.mark.fast
def test_start_refuses_a_recording_that_starts_in_contact() -> None:
    data = _drag_test(start_unloaded=False, end_unloaded=True)
    with pytest.raises(ValueError, match="no unloaded samples before the first contact"):
        td.analyze(data, fs=FS, tare="start")
    res = td.analyze(data, fs=FS)  # auto: the unloaded samples after the contact
    assert res.params["tare_offsets"]["fy"] == pytest.approx(1.0, abs=0.01)


@pytest.mark.fast
def test_start_and_auto_agree_when_the_test_starts_unloaded() -> None:
    data = _drag_test(end_unloaded=True)
    a, s = td.analyze(data, fs=FS), td.analyze(data, fs=FS, tare="start")
    assert a.headline.value == s.headline.value
    assert s.params["tare_offsets"]["fy"] == pytest.approx(0.5, abs=0.01)


@pytest.mark.fast
@pytest.mark.parametrize("bad", ["end", "", "nonee"])
def test_a_bad_mode_is_refused_with_the_choices(bad: str) -> None:
    with pytest.raises(ValueError, match="auto, start, none"):
        td.analyze(_drag_test(), fs=FS, tare=bad)


@pytest.mark.fast
def test_a_mode_with_min_fn_is_refused() -> None:
    with pytest.raises(ValueError, match="give min_fn without it"):
        td.analyze(_drag_test(), fs=FS, tare="none", min_fn=1.0)


@pytest.mark.fast
def test_cli_tare_flag_takes_the_modes() -> None:
    from tribodyn.app.cli import _tare

    assert [_tare(t) for t in ("none", "Start", " auto ")] == ["none", "start", "auto"]
    assert _tare("2.5") == 2.5 and _tare("fy=0.1,fz=0") == {"fy": 0.1, "fz": 0.0}


def test_config_tare_mode(tmp_path: Path) -> None:
    d = _drag_test()
    t = np.arange(d["fy"].size) / FS
    p = tmp_path / "pod.csv"
    p.write_text("time,fy,fz\n" + "".join(f"{a:.2f},{b:.5f},{c:.5f}\n" for a, b, c in zip(t, d["fy"], d["fz"])))
    cfg = tmp_path / "c.toml"
    cfg.write_text('tare = "none"\n')
    assert main(["analyze", str(p), "--out", str(tmp_path / "o"), "--config", str(cfg), "-q"]) == 0
    import json

    head = json.loads((tmp_path / "o" / "summary.json").read_text())["recordings"]["pod.csv"]["headline"]
    assert head["value"] == pytest.approx(0.25, rel=3e-3)
