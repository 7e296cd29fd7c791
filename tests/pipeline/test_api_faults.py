"""Misuse of the Python API meets a documented error, never a crash or a wrong type.

Each case comes from a fuzzing audit of the API: bounds checked before
anything is allocated, exception types as documented, thread-safe shared
objects, and valid but unusual arrays (unaligned) accepted.
"""

from __future__ import annotations

import concurrent.futures as cf
import os

import numpy as np
import pytest
import tribodyn as td
from tribodyn import _core
from tribodyn.kernels.filters import MAX_CHANNELS, MAX_ORDER


def _unaligned(a: np.ndarray) -> np.ndarray:
    """A C-contiguous float64 view of ``a`` at an odd byte offset (not aligned)."""
    buf = np.zeros(a.size * 8 + 1, dtype=np.uint8)
    view = np.frombuffer(buf.data, dtype=np.float64, count=a.size, offset=1)
    view.setflags(write=True)
    view[:] = a
    assert not view.flags.aligned and view.flags.c_contiguous
    return view


@pytest.mark.fast
def test_unaligned_arrays_are_accepted_with_the_same_results():
    rng = np.random.default_rng(3)
    fz = rng.normal(size=3000)
    fy = -0.12 * fz + 0.01 * rng.normal(size=3000)
    for f in (td.linfit, lambda x, y: td.pearson(x, y)):
        assert f(_unaligned(fz), _unaligned(fy)) == f(fz, fy)
    np.testing.assert_array_equal(td.xcorr(_unaligned(fy), _unaligned(fz), max_lag=5).c, td.xcorr(fy, fz, max_lag=5).c)
    np.testing.assert_array_equal(td.highpass(_unaligned(fz), fs=1000.0), td.highpass(fz, fs=1000.0))
    got = td.analyze({"fy": _unaligned(fy), "fz": _unaligned(fz)}, fs=1000.0, window=1.0, hop=1.0)
    want = td.analyze({"fy": fy, "fz": fz}, fs=1000.0, window=1.0, hop=1.0)
    np.testing.assert_array_equal(got["mu_r"], want["mu_r"])


@pytest.mark.fast
def test_the_kernel_names_alignment_when_given_an_unaligned_array():
    x = _unaligned(np.arange(10.0))
    with pytest.raises(ValueError, match="C-contiguous, aligned float64"):
        _core.pearson(x, x)


@pytest.mark.fast
def test_linfit_accumulator_shared_by_threads():
    rng = np.random.default_rng(5)
    chunks = [(rng.normal(size=20_000), rng.normal(size=20_000)) for _ in range(240)]
    acc = td.LinFitAccumulator()
    with cf.ThreadPoolExecutor(8) as ex:
        list(ex.map(lambda c: acc.update(*c), chunks))
    one = td.LinFitAccumulator()
    for c in chunks:
        one.update(*c)
    assert acc.n == one.n == 240 * 20_000
    assert acc.result().slope == pytest.approx(one.result().slope, rel=1e-12, abs=1e-15)


@pytest.mark.fast
@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: td.HighPass(1000.0, order=10**6), r"order must be in \[1, %d\]" % MAX_ORDER),
        (lambda: td.butter_highpass(1000.0, order=MAX_ORDER + 1), "order must be in"),
        (lambda: td.HighPass(1000.0, channels=10**9), r"channels must be in \[1, %d\]" % MAX_CHANNELS),
        (lambda: td.HighPass(1000.0, sos=np.tile([1.0, -1, 0, 1, -0.9, 0], (MAX_ORDER + 1, 1))), "at most"),
    ],
)
def test_filter_bounds_are_checked_before_allocating(call, match):
    with pytest.raises(ValueError, match=match):
        call()


@pytest.mark.fast
def test_operating_range_bounds_and_types():
    from tribodyn import simulate

    sim = simulate.current_density_test(seed=1)
    res = td.analyze(sim.channels, fs=sim.fs, window=2, hop=10, area_mm2=sim.area_mm2)
    with pytest.raises(ValueError, match="bins; at most"):
        td.operating_range(res, "current_density", bin_width=1e-9)
    with pytest.raises(TypeError, match="Results of tribodyn.analyze"):
        td.operating_range(dict(res.table), "current_density")  # type: ignore[arg-type]


@pytest.mark.fast
def test_analyze_many_client_must_be_a_client():
    with pytest.raises(TypeError, match="dask.distributed.Client"):
        td.analyze_many(["x.npy"], client="local", fs=1000.0)


@pytest.mark.fast
def test_a_table_that_cannot_fit_is_refused_before_reading():
    # The most bins allowed (1024 on a 4096-sample window), a window every
    # sample: about 17 kB per window, as many windows as the machine has
    # memory in 17 kB, so the table needs about twice half of it.
    have = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    n = have // (1024 * 16) + 4096
    src = {"fy": np.zeros(n), "fz": np.zeros(n)}
    with pytest.raises(ValueError, match=r"per-window table would need about .* GiB"):
        td.analyze(src, fs=1000.0, window=4.096, hop=0.001, n_bins=1024)


@pytest.mark.fast
@pytest.mark.parametrize(
    "window, n_bins, limit",
    [(2.0, 501, 500), (2.0, 1 << 20, 500), (0.01, 17, 16), (60.0, 1025, 1024), (60.0, 10**30, 1024)],
)
def test_n_bins_is_bounded_before_anything_is_read(window, n_bins, limit):
    """At most max(16, window samples // 4) and 1024 bins (docs/method.md 4), refused by make_plan."""
    from tribodyn.pipeline.plan import make_plan

    with pytest.raises(ValueError, match=rf"n_bins must be at most {limit} for a window of \d+ samples"):
        make_plan(fs=1000.0, window=window, n_bins=n_bins)
    assert make_plan(fs=1000.0, window=window, n_bins=limit).n_bins == limit
    x = np.zeros(10)
    with pytest.raises(ValueError, match="n_bins must be at most 16 for a window of 10 samples"):
        td.identify(x, x, fs=1000.0, n_bins=17)


@pytest.mark.fast
@pytest.mark.parametrize("threads", [0, -1, 30000, 10**20])
def test_threads_out_of_range_are_value_errors_everywhere(threads):
    x = np.arange(100.0)
    for call in (
        lambda: td.analyze({"fy": x, "fz": x}, fs=10.0, window=1.0, threads=threads),
        lambda: _core.linfit(x, x, threads=threads),
        lambda: _core.xcorr(x, x, 3, "auto", threads=threads),
        lambda: td.HighPass(10.0, cutoff=1.0, threads=threads),
    ):
        with pytest.raises((ValueError, OverflowError)) as info:
            call()
        assert info.type is ValueError or threads == 10**20  # a Python int past i64 is numpy's OverflowError
    with pytest.raises(ValueError):
        td.set_threads(td.max_threads() + 1)


@pytest.mark.fast
@pytest.mark.parametrize(
    "kw, match",
    [
        ({"channels": ["fy"]}, "channels must be a mapping"),
        ({"channels": "fy"}, "channels must be a mapping"),
        ({"channels": {"fy": 5}}, r"channels\['fy'\] must be a channel name"),
        ({"scale": [1]}, "scale must be a mapping"),
        ({"scale": {"fy": "x"}}, r"scale\['fy'\] must be a number"),
        ({"units": 3}, "units must be a mapping"),
    ],
)
def test_open_recording_argument_types(tmp_path, kw, match):
    from tribodyn.io.writers import save_hdf5

    p = tmp_path / "x.h5"
    save_hdf5(p, {"fy": np.arange(10.0), "fz": np.arange(10.0)}, 10.0)
    with pytest.raises(TypeError, match=match):
        td.open_recording(p, **kw)
    with pytest.raises(TypeError, match="path must be"):
        td.open_recording(5)  # type: ignore[arg-type]
    with td.open_recording(p, scale={"fy": np.float32(2.0)}) as rec:
        assert rec.read()["fy"][1] == 2.0


@pytest.mark.fast
def test_table_columns_never_share_memory():
    """Columns that are all NaN (no temperature log, no current, dynamic input) are separate arrays."""
    rng = np.random.default_rng(2)
    fz = rng.normal(size=5000)
    res = td.analyze({"fy": -0.1 * fz, "fz": fz}, fs=1000.0, window=1.0, hop=1.0)
    cols = list(res.table.values())
    for a in range(len(cols)):
        for b in range(a + 1, len(cols)):
            assert not np.shares_memory(cols[a], cols[b])


@pytest.mark.fast
@pytest.mark.parametrize(
    ("kw", "error", "match"),
    [
        (dict(current="x"), TypeError, "current must be a number or a log"),
        (dict(voltage="3 V", shunt_ohm=1.0), TypeError, "voltage must be a number or a log"),
        # the paper's preset checks (and records) the rig data and the statistics' options it does not use
        (dict(method="paper", rpm=-5), ValueError, "rpm must be"),
        (dict(method="paper", n_lamellas=2.5), TypeError, "n_lamellas must be an integer"),
        (dict(method="paper", max_rel_ci=-1), ValueError, "max_rel_ci must be"),
        (dict(method="paper", iv_lag=-3), ValueError, "iv_lag must be"),
        (dict(method="paper", noise=(1,)), TypeError, "noise must be"),
    ],
)
def test_every_option_is_checked_whatever_the_preset(kw, error, match):
    with pytest.raises(error, match=match):
        td.make_plan(fs=1000.0, **kw)


@pytest.mark.fast
def test_the_plan_holds_the_checked_rig_data():
    for method in (None, "paper"):
        plan = td.make_plan(fs=1000.0, method=method, rpm=1500, n_lamellas=24)
        assert (plan.rpm, plan.n_lamellas) == (1500.0, 24) and isinstance(plan.rpm, float)
