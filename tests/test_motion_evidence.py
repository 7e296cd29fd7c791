"""The sliding direction from a velocity or position channel, and a sign change once is no reciprocating test
(issue 34 point 6; docs/method.md 6c)."""

from __future__ import annotations

import numpy as np
import pytest
import tribodyn as td
from tribodyn import simulate

pytestmark = pytest.mark.fast


@pytest.fixture(scope="module")
def recip() -> simulate.ReciprocatingSimulation:
    return simulate.reciprocating(seed=1)


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


def test_a_motion_channel_that_does_not_reverse_says_unidirectional(recip) -> None:
    n = recip.channels["fy"].size
    ch = {"fy": recip.channels["fy"], "fz": recip.channels["fz"], "v": np.full(n, 0.02)}
    res = td.analyze(ch, fs=recip.fs)
    assert res.params["motion"] == "unidirectional" and "0 reversals" in res.params["motion_evidence"]


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
