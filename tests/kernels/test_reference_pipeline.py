"""The benchmark's pipeline against the NumPy reference (issue 5).

``benches/bench_pipeline.py`` times ``tribodyn.analyze`` on recordings written
by ``simulate.continuous`` to ``.npy`` and HDF5 against
``tribodyn.kernels.reference.analyze_tiled``. Here the same code runs on a 2-minute
recording, dynamic and raw (``highpass=0.1``), read the three ways the
benchmark reads it, and must give the reference's table: every column to
1e-9 relative, bin counts exactly. No timing is asserted.

Tolerance: both sides form the same centred sums, in different orders
(fixed SIMD lanes against NumPy's pairwise sums), so they agree to a few
ulps of each column's magnitude (measured: under 1e-13). Two columns are
differences of nearly equal numbers -- F_y0 = mean(fy) - slope mean(fz), a
few 1e-4 N for a zero-mean dynamic force, and (mu_b - mu_a) / mu_r -- so
every column is also allowed an absolute 1e-12 of its largest value.
"""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest
import tribodyn as td
from tribodyn.kernels import reference
from _paths import REPO


BENCH = REPO / "benches" / "bench_pipeline.py"


def _bench():
    spec = importlib.util.spec_from_file_location("bench_pipeline", BENCH)
    mod = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    spec.loader.exec_module(mod)
    return mod


bench = _bench()


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("recordings")
    return {
        "dyn": bench.write_recording(d, "dyn", 120.0, raw=False, chunk_s=17.0),
        "raw": bench.write_recording(d, "raw", 120.0, raw=True, chunk_s=17.0),
    }


def _assert_same(table, ref):
    for col in bench.COMPARED + ("bin_cof",):
        a, b = np.asarray(table[col], dtype=float), np.asarray(ref[col], dtype=float)
        scale = np.nanmax(np.abs(b)) if np.isfinite(b).any() else 0.0
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12 * scale, equal_nan=True, err_msg=col)
    np.testing.assert_array_equal(table["bin_count"], ref["bin_count"])
    assert table["bin_count"].dtype == np.int64


@pytest.mark.fast
@pytest.mark.parametrize("mode", ["dyn", "raw"])
@pytest.mark.parametrize("how", ["npy", "h5", "mmap"])
def test_pipeline_matches_reference(files, mode, how):
    raw = mode == "raw"
    ref = bench.run_reference(files[mode]["npy"], raw=raw)
    if how == "mmap":
        res = bench.run_pipeline_mmap(files[mode]["npy"], raw=raw)
    else:
        res = bench.run_pipeline(files[mode][how], raw=raw)
    assert len(res) == len(ref["time"]) == 60
    assert res.orientation == int(ref["orientation"]) == -1
    _assert_same(bench.table_of(res), ref)
    # The comparison helper of the benchmark agrees.
    assert max(bench.max_rel_diff(bench.table_of(res), ref).values()) < 1e-9
    # Sanity of the simulated truth (mu0 = 0.12, J = i / area).
    assert np.median(res["mu_r"]) == pytest.approx(0.12, rel=0.05)
    np.testing.assert_allclose(res["J"], bench.CURRENT / bench.AREA, rtol=0.05)
    if raw:
        assert np.all(np.isfinite(res["mu_classical"]))
    else:
        assert np.all(np.isnan(res["mu_classical"]))


@pytest.mark.fast
def test_sigma_deadband_and_explicit_orientation_match_reference(files):
    arr = np.load(files["dyn"]["npy"], mmap_mode="r")
    ch = {r: arr[j] for j, r in enumerate(bench.ROLES)}
    for kw in (dict(deadband="0.7sigma"), dict(orientation=1, n_bins=5), dict(deadband=0.0, n_bins=1)):
        res = td.analyze(ch, fs=bench.FS, window=2.0, hop=2.0, area_mm2=2.0, method="paper", **kw)
        ref = reference.analyze_tiled(ch, fs=bench.FS, window=2.0, area_mm2=2.0, **kw)
        _assert_same(bench.table_of(res), ref)


@pytest.mark.fast
def test_concurrent_spans_give_the_single_stream_table(files, monkeypatch):
    """With two threads a random-access, thread-safe recording may be read as concurrent spans (dynamic input);
    an HDF5 file read through h5py (not thread-safe) is read as one stream. Either way the table is the
    one-thread table."""
    mod = importlib.import_module("tribodyn.pipeline.routes")
    from tribodyn.pipeline.plan import make_plan

    def plan(**kw):
        return make_plan(fs=bench.FS, window=2.0, **kw)

    one = {h: bench.table_of(bench.run_pipeline(files["dyn"][h], raw=False, threads=1)) for h in ("npy", "h5")}
    monkeypatch.setattr(mod, "_MIN_SPAN_WINDOWS", 4)
    with bench.open_source(files["dyn"]["npy"]) as rec:
        spans = mod._spans(rec, plan(hop=2.0, threads=2))
        assert spans == [(0, 60_000), (60_000, 120_000)]
        assert mod._spans(rec, plan(hop=3.0, threads=3)) == [(0, 38_000), (39_000, 77_000), (78_000, 119_000)]
        assert mod._spans(rec, plan(hop=2.0, threads=2, start=5000)) == [(6000, 62_000), (62_000, 120_000)]
        assert mod.choose_route(rec, rec, plan(hop=2.0, threads=2, max_lag=0)) == "spans"
    with bench.open_source(files["dyn"]["h5"]) as rec:  # uncompressed chunks: read natively (pread), issue 16
        assert mod.choose_route(rec, rec, plan(hop=2.0, threads=2)) == "mapped"
        assert mod.choose_route(rec, rec, plan(hop=2.0, threads=2, max_lag=0)) == "spans"
    monkeypatch.setattr(importlib.import_module("tribodyn.io.hdf5"), "_NATIVE", False)
    with bench.open_source(files["dyn"]["h5"]) as rec:  # through h5py alone: not thread-safe
        assert mod.choose_route(rec, rec, plan(hop=2.0, threads=2)) == "stream"
    monkeypatch.undo()
    monkeypatch.setattr(mod, "_MIN_SPAN_WINDOWS", 4)
    for h in ("npy", "h5"):
        for kw in (dict(threads=2), dict(threads=2, chunk=3.3)):
            two = bench.table_of(bench.run_pipeline(files["dyn"][h], raw=False, **kw))
            for col, v in one[h].items():
                np.testing.assert_array_equal(two[col], v, err_msg=f"{h} {col} {kw}")
    # Overlapping windows and a start inside the recording.
    with bench.open_source(files["dyn"]["h5"]) as rec:
        a = td.analyze(rec, window=2.0, hop=1.3, start=777, threads=1)
        b = td.analyze(rec, window=2.0, hop=1.3, start=777, threads=2)
    assert len(a) == len(b) > 80
    for col in a.columns:
        np.testing.assert_array_equal(a[col], b[col], err_msg=col)


@pytest.mark.fast
def test_threads_and_chunks_never_change_a_bit(files):
    base = bench.table_of(bench.run_pipeline(files["raw"]["npy"], raw=True))
    for kw in (dict(threads=1), dict(threads=2, chunk=7.3), dict(threads=1, chunk=0.9)):
        other = bench.table_of(bench.run_pipeline(files["raw"]["npy"], raw=True, **kw))
        for col, v in base.items():
            np.testing.assert_array_equal(other[col], v, err_msg=f"{col} {kw}")
    mm = bench.table_of(bench.run_pipeline_mmap(files["raw"]["npy"], raw=True, chunk=13.0, threads=2))
    for col, v in base.items():
        np.testing.assert_array_equal(mm[col], v, err_msg=col)


@pytest.mark.fast
def test_reference_refuses_a_recording_shorter_than_a_window():
    with pytest.raises(ValueError, match="shorter than one window"):
        reference.analyze_tiled({"fy": np.zeros(10), "fz": np.ones(10)}, fs=1000.0)


@pytest.mark.fast
def test_results_section_is_replaced_not_duplicated(tmp_path):
    p = tmp_path / "RESULTS.md"
    p.write_text("# Results\n\n## Kernels\n\nkernel table\n")
    bench.write_section(bench.SECTION + "\n\nfirst\n", p)
    bench.write_section(bench.SECTION + "\n\nsecond\n", p)
    text = p.read_text()
    assert text.count(bench.SECTION) == 1 and "second" in text and "first" not in text
    assert "## Kernels\n\nkernel table" in text
    p.write_text(bench.SECTION + "\n\nold\n\n## Kernels\n\nkeep\n")
    bench.write_section(bench.SECTION + "\n\nnew\n", p)
    text = p.read_text()
    assert "old" not in text and "new" in text and text.endswith("## Kernels\n\nkeep\n")
