"""The sliding direction from a velocity or position channel, and a sign change once is no reciprocating test
(issue 34 point 6; docs/method.md 6c)."""

from __future__ import annotations

import numpy as np
import pytest
import tribodyn as td
from tribodyn import simulate


@pytest.fixture(scope="module")
def recip() -> simulate.ReciprocatingSimulation:
    return simulate.reciprocating(seed=1)


@pytest.mark.fast
@pytest.mark.parametrize("role", ["v", "x"])
def test_an_export_of_absolute_friction_is_reciprocating_by_its_motion_channel(recip, role) -> None:
    # an export whose friction force is |F| (no sign) with a velocity or a position column
    ch = {"fy": np.abs(recip.channels["fy"]), "fz": recip.channels["fz"], role: recip.channels[role]}
    res = td.analyze(ch, fs=recip.fs)
    assert res.params["motion"] == "reciprocating" and res.params["motion_detected"]
    assert ("velocity channel v" if role == "v" else "position channel x") in res.params["motion_evidence"]
    assert res.headline.method == "per-stroke" and res.headline.value == pytest.approx(0.11, rel=0.002)
    without = td.analyze({"fy": ch["fy"], "fz": ch["fz"]}, fs=recip.fs)  # fy alone cannot tell: -2.2 %
    assert without.params["motion"] == "unidirectional"


@pytest.mark.fast
def test_a_motion_channel_that_does_not_reverse_says_unidirectional(recip) -> None:
    n = recip.channels["fy"].size
    ch = {"fy": recip.channels["fy"], "fz": recip.channels["fz"], "v": np.full(n, 0.02)}
    res = td.analyze(ch, fs=recip.fs)
    assert res.params["motion"] == "unidirectional" and "0 reversals" in res.params["motion_evidence"]


@pytest.mark.fast
def test_friction_that_changes_sign_once_is_not_reciprocating() -> None:
    # a disc that stops and turns back once (or a drag that reverses): two long stretches of each sign
    rng = np.random.default_rng(4)
    n = 20000
    fz = 10.0 + 0.05 * rng.standard_normal(n)
    fy = np.where(np.arange(n) < n // 2, 1.0, -1.0) * 0.3 * fz + 0.01 * rng.standard_normal(n)
    res = td.analyze({"fy": fy, "fz": fz}, fs=100.0)
    assert res.params["motion"] == "unidirectional" and "1 reversal" in res.params["motion_evidence"]
    many = np.where((np.arange(n) // 1000) % 2 == 0, 1.0, -1.0) * 0.3 * fz + 0.01 * rng.standard_normal(n)
    assert td.analyze({"fy": many, "fz": fz}, fs=100.0).params["motion"] == "reciprocating"


# -- the motion channel's reversals over the pre-pass sample's pieces (issue 38 point 2) -----------------------
#
# A random-access recording longer than the pre-pass sample is looked at in 256 evenly spread pieces. A
# stroke longer than a piece never crosses the hysteresis inside one, so the direction is carried from one
# piece to the next (docs/method.md 6c). The tests shrink the sample (pieces of 64 samples: 0.064 s at 1 kHz)
# so that strokes of 5-25 s are 80-400 pieces long, as 2^20's pieces are to 0.01 Hz strokes.

SMALL_SAMPLE = 1 << 14


@pytest.fixture
def small_sample(monkeypatch: pytest.MonkeyPatch) -> int:
    from tribodyn.io import sample

    monkeypatch.setattr(sample, "PREPASS_SAMPLES", SMALL_SAMPLE)
    return SMALL_SAMPLE


def _npy(path, cols, fs=1000.0):
    np.save(path, np.vstack(list(cols.values())))
    return td.open_recording(path, fs=fs, names=list(cols))


@pytest.mark.fast
def test_direction_changes_are_carried_over_the_gaps_between_pieces() -> None:
    from tribodyn.pipeline.prepass import _direction_changes, _reversals

    # 12 pieces of 10 samples, each inside one long stroke: + + + - - - + + + - - -
    sig = np.repeat(np.tile(np.repeat([1.0, -1.0], 3), 2), 10)
    runs = [(a, a + 10) for a in range(0, sig.size, 10)]
    assert _direction_changes(sig, runs) == (3, 0, 120)
    assert _reversals(sig, runs) == 0  # within the pieces: none (the old count)
    # a piece in the dead band (under 30 % of p95) carries the direction on; a reversal inside a piece counts once
    sig2 = np.r_[np.ones(10), 0.1 * np.ones(10), -np.ones(5), np.ones(5), np.ones(10)]
    assert _direction_changes(sig2, [(0, 10), (10, 20), (20, 30), (30, 40)]) == (2, 1, 30)


@pytest.mark.fast
@pytest.mark.parametrize("role", ["x", "v"])
@pytest.mark.parametrize("freq", [0.1, 0.05, 0.02])
def test_slow_strokes_longer_than_a_piece_are_reciprocating(tmp_path, small_sample, freq, role) -> None:
    # |F| exported (no sign): only the motion channel tells the direction; strokes of 5, 10 and 25 s
    sim = simulate.reciprocating(seed=3, fs=1000.0, frequency=freq, cycles=4)
    ch = sim.channels
    name = {"x": "position", "v": "velocity"}[role]
    rec = _npy(tmp_path / "slow.npy", {"fy": np.abs(ch["fy"]), "fz": ch["fz"], name: ch[role]})
    assert rec.n_samples > small_sample and rec.roles[role] == name
    res = td.analyze(rec)
    assert res.params["motion"] == "reciprocating", res.params["motion_evidence"]
    turns = int(res.params["motion_evidence"].split(" reversal")[0].rsplit(" ", 1)[1])
    assert turns >= 7  # 4 cycles: 7 reversals (8 strokes), each seen across the pieces
    assert res.headline.method == "per-stroke" and res.headline.value == pytest.approx(0.11, rel=0.005)


def _unidirectional(n: int, seed: int = 5):
    rng = np.random.default_rng(seed)
    fz = 10.0 + 0.05 * rng.standard_normal(n)
    return rng, 0.2 * fz + 0.02 * rng.standard_normal(n), fz


@pytest.mark.fast
@pytest.mark.parametrize(
    "case",
    ["velocity noise only", "velocity noisy and drifting", "velocity with spikes", "position noisy",
     "position drifting with noise"],
)  # fmt: skip
def test_unidirectional_with_a_noisy_or_drifting_motion_channel(tmp_path, small_sample, case) -> None:
    n = 200_000  # 200 s at 1 kHz: 256 pieces of 64 samples, 780 apart
    rng, fy, fz = _unidirectional(n)
    t = np.arange(n) / 1000.0
    noise = rng.standard_normal(n)
    sig, role = {
        # a velocity channel that does not move (the rig turns a disc): its sign is noise
        "velocity noise only": (1e-4 * noise, "v"),
        # forward at 10 -> 2 mm/s with noise of 2 mm/s: never held backwards
        "velocity noisy and drifting": (np.linspace(0.01, 0.002, n) + 0.002 * noise, "v"),
        # forward at 10 mm/s with a backward spike of the sensor every 10 s
        "velocity with spikes": (0.01 + 1e-4 * noise - 0.03 * (np.arange(n) % 10_000 == 0), "v"),
        # a position (wear depth) under its noise: its slope's sign is noise at the sample's rate
        "position noisy": (1e-6 * noise, "x"),
        "position drifting with noise": (1e-6 * t + 1e-6 * noise + 2e-6 * np.sin(2 * np.pi * t / 60), "x"),
    }[case]
    name = {"x": "position", "v": "velocity"}[role]
    rec = _npy(tmp_path / "uni.npy", {"fy": fy, "fz": fz, name: sig})
    assert rec.n_samples > small_sample and rec.roles[role] == name
    res = td.analyze(rec)
    assert res.params["motion"] == "unidirectional", res.params["motion_evidence"]
    assert res.headline.method == "classical"
    if "noise" in case and "drifting" not in case:
        assert "noise: under 8, not used" in res.params["motion_evidence"]


def test_a_noisy_motion_channel_leaves_the_decision_to_fy(tmp_path, small_sample) -> None:
    # a reciprocating test whose velocity channel is noise (a sensor not wired): fy's sign decides
    sim = simulate.reciprocating(seed=2, fs=1000.0, frequency=0.5, cycles=60)
    ch = sim.channels
    noise = 1e-4 * np.random.default_rng(9).standard_normal(ch["fy"].size)
    rec = _npy(tmp_path / "noisy_v.npy", {"fy": ch["fy"], "fz": ch["fz"], "velocity": noise})
    res = td.analyze(rec)
    assert res.params["motion"] == "reciprocating" and "not used); fy:" in res.params["motion_evidence"]
