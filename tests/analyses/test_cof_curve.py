"""The COF against a covariate that sweeps faster than a window, per sample (issue 35 point 7; method.md 7b)."""

from __future__ import annotations

import numpy as np
import pytest
import tribodyn as td


FS, SWEEP, SWEEPS = 100.0, 6.5, 40


def _traction(s: np.ndarray) -> np.ndarray:
    return 0.0085 + (0.057 - 0.0085) * (1 - np.exp(-s / 0.08))


@pytest.fixture(scope="module")
def slide_roll():
    """40 slide-roll sweeps of 6.5 s (ratio 0 to 0.5), the traction coefficient rising 0.0085 -> 0.057."""
    rng = np.random.default_rng(1)
    n = int(SWEEPS * SWEEP * FS)
    t = np.arange(n) / FS
    srr = 0.5 * ((t % SWEEP) / SWEEP)
    fz = 20.0 * (1 + 0.005 * rng.standard_normal(n))
    fy = _traction(srr) * fz + 0.01 * rng.standard_normal(n)
    log = (t[::10], srr[::10])
    res = td.analyze({"fy": fy, "fz": fz}, fs=FS, window=60, hop=60, covariates={"srr": log})
    return fy, fz, srr, log, res


@pytest.mark.fast
def test_the_per_window_curve_is_flat_and_says_why(slide_roll) -> None:
    *_, res = slide_roll
    assert np.ptp(res.table["srr"]) < 0.02 and np.ptp(res.table["mu_classical"]) < 0.002  # averaged away
    assert any("srr log sweeps" in w and "cof_curve" in w for w in res.warnings)


@pytest.mark.fast
def test_cof_curve_recovers_the_traction_curve(slide_roll) -> None:
    fy, fz, srr, log, res = slide_roll
    c = td.cof_curve({"fy": fy, "fz": fz}, res, log, bins=10, name="slide-roll ratio")
    assert c.covariate == "slide-roll ratio" and c.edges.size == 11 and c.samples.sum() > 0.99 * fy.size
    b = np.clip(np.searchsorted(c.edges, srr, side="right") - 1, 0, 9)
    truth = np.array([_traction(srr[b == j]).mean() for j in range(10)])  # the truth's mean over each bin
    # from the log (a reading every 10 samples): the interpolation across each sweep's reset puts a few samples
    # of high COF into the low bins: 1.8 % in the first
    np.testing.assert_allclose(c.cof, truth, rtol=0.02)
    assert np.all(np.diff(c.cof) > 0) and np.all(c.low <= c.cof) and np.all(c.cof <= c.high)
    assert np.all(c.visits >= SWEEPS)  # each sweep visits each bin
    # the same from the channel itself, and in chunks that cut visits (a visit goes on across a chunk's end)
    from tribodyn.analyses import curve

    ch = td.cof_curve({"fy": fy, "fz": fz, "srr": srr}, res, "srr", bins=c.edges)
    np.testing.assert_allclose(ch.cof, truth, rtol=0.002)
    old = curve.CHUNK
    try:
        curve.CHUNK = 777
        cut = td.cof_curve({"fy": fy, "fz": fz, "srr": srr}, res, "srr", bins=c.edges)
    finally:
        curve.CHUNK = old
    np.testing.assert_array_equal(cut.visits, ch.visits)
    np.testing.assert_allclose(cut.cof, ch.cof, rtol=1e-12)
    d = c.to_dict()
    assert d["cof"][0] == pytest.approx(c.cof[0]) and "slide-roll ratio" in repr(c)


@pytest.mark.fast
def test_cof_curve_refuses_what_it_cannot_bin(slide_roll) -> None:
    fy, fz, srr, log, res = slide_roll
    with pytest.raises(ValueError, match="single value"):
        td.cof_curve({"fy": fy, "fz": fz, "k": np.ones(fy.size)}, res, "k")
    with pytest.raises(ValueError, match="increasing edges"):
        td.cof_curve({"fy": fy, "fz": fz}, res, log, bins=[0.3, 0.1])
    dyn = td.analyze({"fy": fy - fy.mean(), "fz": fz - fz.mean()}, fs=FS, window=60, hop=60)
    with pytest.raises(ValueError, match="contact rule"):
        td.cof_curve({"fy": fy, "fz": fz}, dyn, log)
