"""Forces out of range (docs/method.md 4): a window holding |f| > ``_core.FORCE_LIMIT`` is NaN with its reason.

Before, a 1e300 N sample gave mu_r = 0.0 (or a flipped orientation for the
whole recording) with NumPy overflow warnings. Now the kernel marks the
window, every route (arrays, a mapped ``.npy``, the high-pass) gives NaN and
the reason "force out of range", the other windows keep their values, and
nothing overflows (warnings are errors here).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import tribodyn as td
from tribodyn import _core
from tribodyn.io.writers import save_npy


FS = 1000.0
N = 20_000  # ten 2 s windows
SPIKE = 5_000  # in window 2
REASON = "force out of range"


def _forces(seed: int = 0):
    rng = np.random.default_rng(seed)
    # dynamic forces (no static fz level, hence no classical COF): a .npy of them takes the route "mapped"
    # (a static level would make it "stream", which reads every sample once for the classical COF, docs/method.md 6e)
    fz = rng.normal(size=N)
    fy = 0.3 * fz + 0.01 * rng.normal(size=N)
    fx = 0.2 * fz + rng.normal(size=N)
    return {"fx": fx, "fy": fy, "fz": fz}


def _analyze(channels, route, tmp_path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        if route == "npy":
            path = tmp_path / "rec.npy"
            save_npy(path, channels)
            rec = td.open_recording(path, fs=FS, names=list(channels))
            res = td.analyze(rec, window=2, hop=2, **kw)
            assert res.params["route"] == "mapped"
            return res
        return td.analyze(channels, fs=FS, window=2, hop=2, **kw)


@pytest.mark.fast
@pytest.mark.parametrize("value", [1e300, -1e160, 1.0000001 * _core.FORCE_LIMIT])
@pytest.mark.parametrize("role", ["fy", "fz", "fx"])
@pytest.mark.parametrize("route", ["arrays", "npy", "paper"])
def test_one_window_out_of_range(tmp_path, route, role, value):
    clean = _forces()
    spiked = {k: v.copy() for k, v in clean.items()}
    spiked[role][SPIKE] = value
    kw = {"method": "paper"} if route == "paper" else {}
    want = _analyze(clean, route, tmp_path, **kw)
    got = _analyze(spiked, route, tmp_path, **kw)
    bad = ~got["ok"]
    assert np.flatnonzero(bad).tolist() == [2]
    assert got["reasons"][2].startswith(REASON)
    for c in ("mu_r", "mu_ols", "mu_r_stderr", "c_yz", "mu_a", "mu_b"):
        assert np.isnan(got[c][2]), c
    assert got.bin_counts[2].sum() == 0 and np.isnan(got.bin_cof[2]).all()
    # The other windows, the orientation and the headline are those of the clean recording.
    keep = np.arange(len(got)) != 2
    assert got.orientation == want.orientation
    for c in ("mu_r", "mu_ols", "c_yz", "ok"):
        np.testing.assert_array_equal(got[c][keep], want[c][keep], err_msg=c)
    assert got.summary()["verdict"]["cof"]["method"] == "dynamic"
    assert got.summary()["verdict"]["cof"]["value"] == pytest.approx(want.summary()["verdict"]["cof"]["value"], 1e-3)


@pytest.mark.fast
@pytest.mark.parametrize("role", ["fy", "fz"])
def test_raw_forces_through_the_high_pass(tmp_path, role):
    """A spike in the raw forces: its window and those the filter's response carries past the limit."""
    spiked = _forces()
    spiked[role][SPIKE] = 1e300
    got = _analyze(spiked, "arrays", tmp_path, highpass=0.5)
    bad = np.flatnonzero(~got["ok"])
    assert bad[0] == 2 and all(r.startswith(REASON) for r in got["reasons"][bad])
    assert np.isnan(got["mu_r"][bad]).all() and (got["ok"][:2]).all()


@pytest.mark.fast
@pytest.mark.parametrize("estimator", ["corrected", "ols", "iv", "deming"])
def test_forces_up_to_the_limit_are_analysed_exactly(tmp_path, estimator):
    """The whole chain is scale-invariant up to the limit: the same COF, no overflow, no window lost."""
    clean = _forces()
    top = max(float(np.abs(v).max()) for v in clean.values())
    scale = 0.99 * _core.FORCE_LIMIT / top
    kw = {"estimator": estimator, "orientation": 1}
    if estimator == "deming":
        kw["noise"] = (0.01, 0.01)
    want = _analyze(clean, "arrays", tmp_path, **kw)
    if estimator == "deming":
        kw["noise"] = (0.01 * scale, 0.01 * scale)
    got = _analyze({k: v * scale for k, v in clean.items()}, "arrays", tmp_path, **kw, deadband=0.35 * scale)
    np.testing.assert_array_equal(got["ok"], want["ok"])
    np.testing.assert_allclose(got["mu_r"], want["mu_r"], rtol=1e-12)


@pytest.mark.fast
def test_every_sample_out_of_range_is_no_cof_not_zero(tmp_path):
    clean = _forces()
    got = _analyze({k: v * 1e70 for k, v in clean.items()}, "arrays", tmp_path)
    assert not got["ok"].any() and all(r.startswith(REASON) for r in got["reasons"])
    assert np.isnan(got["mu_r"]).all()
    assert got.summary()["verdict"]["cof"]["value"] is None
