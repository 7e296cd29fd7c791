"""The memory-mapped input path of ``tribodyn.analyze`` and ``Recording.chunks(copy=False)``.

A channels-first float64 ``.npy`` opened with ``open_recording`` is analysed
by one call of ``tribodyn._core.windows_stats_file`` (the kernel reads the
file's pages through memory maps, rust/core/src/io/mapped.rs). These tests check
that this path is taken, that its per-window table is identical, bit for
bit, to the one of the streaming path on the same samples given as a
mapping, that every recording it cannot read (scaled channels, another
dtype or layout, an instrument COF column, a NaN in a window) falls back to
the streaming path with the same results and the usual errors, that chunks
handed out as read-only views equal the copied ones, and that the kernel's
own argument checks raise instead of crashing.
"""

from __future__ import annotations

import os
from unittest import mock

import numpy as np
import pytest
import tribodyn as td
from hypothesis import given, settings
from hypothesis import strategies as st
from tribodyn import _core, simulate
from tribodyn.io import RecordingError, open_recording
from tribodyn.io.writers import save_hdf5, save_npz

FS = 1000.0
ROLES = ("fx", "fy", "fz", "i")
DURATION = 150.0  # s: 150 000 samples per channel
N = int(DURATION * FS)
KW = dict(window=2.0, n_bins=16, area_mm2=1.0)  # the benchmark's parameters (hop given per test)


# -- data and helpers --------------------------------------------------------------


@pytest.fixture(scope="module")
def data() -> np.ndarray:
    """(4, n) fx, fy, fz, i of a stationary simulated recording (fy ~ -0.12 fz + noise)."""
    parts = list(simulate.continuous(DURATION, chunk_s=40.0, current=4.0, seed=7, fs=FS, raw=False))
    a = np.stack([np.concatenate([p[r] for p in parts]) for r in ROLES])
    assert a.shape == (4, N) and a.dtype == np.float64 and np.isfinite(a).all()
    return a


@pytest.fixture(scope="module")
def npy(data, tmp_path_factory) -> str:
    p = tmp_path_factory.mktemp("mapped") / "rec.npy"
    np.save(p, data)
    return str(p)


def _write(path, arr) -> str:
    np.save(path, arr)
    return str(path)


def _mapping(a: np.ndarray, names=ROLES, origin: int = 0) -> dict:
    """The channels of ``a`` as a mapping, from sample ``origin`` on (unmapped names dropped)."""
    return {nm: a[k, origin:] for k, nm in enumerate(names) if nm in ("fx", "fy", "fz", "i", "u", "cof")}


def assert_same(got: td.Results, want: td.Results) -> None:
    """Identical per-window tables, bins and moments (NaN equal to NaN)."""
    assert sorted(got.table) == sorted(want.table)
    for key in want.table:
        np.testing.assert_array_equal(got.table[key], want.table[key], err_msg=f"column {key!r}")
        assert got.table[key].dtype == want.table[key].dtype, key
    for attr in ("bin_counts", "bin_cof", "fz_min", "fz_max"):
        np.testing.assert_array_equal(getattr(got, attr), getattr(want, attr), err_msg=attr)
    assert got.orientation == want.orientation
    assert sorted(got.moments) == sorted(want.moments)
    for key in want.moments:
        np.testing.assert_array_equal(got.moments[key], want.moments[key], err_msg=f"moment {key!r}")


@pytest.fixture
def file_calls(monkeypatch):
    """Records each call of ``_core.windows_stats_file`` (arguments and the error it raised, if any)."""
    calls = []
    real = _core.windows_stats_file

    def spy(*args, **kwargs):
        entry = {"args": args, "kwargs": kwargs, "error": None}
        calls.append(entry)
        try:
            return real(*args, **kwargs)
        except BaseException as exc:
            entry["error"] = exc
            raise

    monkeypatch.setattr(_core, "windows_stats_file", spy)
    return calls


def _mapped_ok(calls) -> bool:
    """The mapped path ran once and succeeded."""
    return len(calls) == 1 and calls[0]["error"] is None


# -- 1. the mapped path gives the streaming path's table ------------------------------


@pytest.mark.parametrize("start", [0, 12_345])
@pytest.mark.parametrize("chunk", [None, 3.0, 7.0])
@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("hop", [2.0, 3.0, 1.5])
def test_mapped_path_equals_mapping(data, npy, file_calls, hop, threads, chunk, start):
    with open_recording(npy, fs=FS, names=list(ROLES)) as rec:
        got = td.analyze(rec, hop=hop, threads=threads, chunk=chunk, start=start, **KW)
    assert _mapped_ok(file_calls), file_calls
    want = td.analyze(_mapping(data, origin=start), fs=FS, hop=hop, threads=threads, chunk=chunk, start=start, **KW)
    assert_same(got, want)

    step, length = int(round(hop * FS)), int(round(KW["window"] * FS))
    k0 = -(-start // step)
    k1 = (N - length) // step + 1
    starts = np.rint(got.table["t_start"] * FS).astype(np.int64)
    np.testing.assert_array_equal(starts, np.arange(k0, k1) * step)  # on the recording's grid, from start on
    assert np.all(got.table["n"] == length)
    # chunk= bounds the windows per mapped block.
    block = file_calls[0]["kwargs"]["block"]
    if chunk is not None:
        assert 1 <= block <= max(1, int(round(chunk * FS)) // step)
    # Sanity of the analysis itself (so equality is not between two empty tables).
    assert len(got) == k1 - k0
    assert got.table["ok"].mean() > 0.9
    np.testing.assert_allclose(np.median(got.table["mu_r"][got.table["ok"]]), 0.12, rtol=0.05)
    np.testing.assert_allclose(got.table["J"], got.table["i"] / 1.0)
    np.testing.assert_allclose(got.table["i"], 4.0, rtol=1e-3)  # a noisy 4 A current


def test_mapped_path_independent_of_threads_and_chunk(npy, file_calls):
    with open_recording(npy, fs=FS, names=list(ROLES)) as rec:
        results = [
            td.analyze(rec, hop=2.0, threads=t, chunk=c, **KW)
            for t, c in [(1, None), (2, None), (2, 2.0), (1, 5.0), (2, 149.0)]
        ]
    assert len(file_calls) == 5 and all(c["error"] is None for c in file_calls)
    for r in results[1:]:
        assert_same(r, results[0])


@pytest.mark.parametrize(
    "names, extra",
    [
        (["x", "fy", "fz", "i"], {}),  # no fx: no fx offset
        (["fx", "fy", "fz", "u"], {"shunt_ohm": 0.5}),  # aux = shunt voltage
        (["fx", "fy", "fz", "x"], {"current": 4.0}),  # no aux channel: a constant current
        (["fy", "fz", "fx", "i"], {}),  # roles in another file order
    ],
)
def test_mapped_path_roles(data, tmp_path, file_calls, names, extra):
    p = _write(tmp_path / "r.npy", data)
    with open_recording(p, fs=FS, names=names) as rec:
        layout = rec.file_layout([r for r in ("fx", "fy", "fz", "i", "u") if r in rec.roles])[1]
        got = td.analyze(rec, hop=3.0, threads=2, start=777, **extra, **KW)
    assert _mapped_ok(file_calls)
    offsets = file_calls[0]["args"][2]
    assert offsets == (layout.get("fx"), layout["fy"], layout["fz"], layout.get("i", layout.get("u")))
    assert (offsets[0] is None) == ("fx" not in names)
    assert (offsets[3] is None) == ("i" not in names and "u" not in names)
    want = td.analyze(_mapping(data, names, origin=777), fs=FS, hop=3.0, threads=2, start=777, **extra, **KW)
    assert_same(got, want)


def test_mapped_path_sigma_deadband_fixed_orientation_and_gate(data, npy, file_calls):
    kw = dict(KW, hop=2.5, deadband="0.7sigma", orientation=1, gate=0.95, n_bins=7)
    with open_recording(npy, fs=FS, names=list(ROLES)) as rec:
        got = td.analyze(rec, threads=2, chunk=4.0, **kw)
    assert _mapped_ok(file_calls)
    assert file_calls[0]["args"][0].deadband == ("sigma", 0.7)  # the analysis' frozen spec
    want = td.analyze(_mapping(data), fs=FS, threads=2, **kw)
    assert_same(got, want)
    assert got.orientation == 1 and got.bin_cof.shape == (len(got), 7)


def test_mapped_path_voltage_needs_shunt(data, tmp_path, file_calls):
    p = _write(tmp_path / "u.npy", data)
    with open_recording(p, fs=FS, names=["fx", "fy", "fz", "u"]) as rec:
        with pytest.raises(ValueError, match="shunt_ohm"):
            td.analyze(rec, hop=2.0, **KW)
    with pytest.raises(ValueError, match="shunt_ohm"):
        td.analyze(_mapping(data, ["fx", "fy", "fz", "u"]), fs=FS, hop=2.0, **KW)


@pytest.mark.parametrize("start", [N - 1999, N - 1, N])
def test_mapped_path_no_window_after_start(npy, file_calls, start):
    """A start past the last window: the usual error, not an empty table or a crash."""
    with open_recording(npy, fs=FS, names=list(ROLES)) as rec:
        with pytest.raises(ValueError, match="shorter than one window|holds no samples"):
            td.analyze(rec, hop=2.0, start=start, **KW)
    assert not any(c["error"] is None for c in file_calls)


def test_mapped_path_last_window_ends_at_the_last_sample(data, tmp_path, file_calls):
    """Windows tile the file exactly: the last one's final sample is the file's last byte."""
    a = data[:, : 60 * 2000]
    p = _write(tmp_path / "exact.npy", a)
    with open_recording(p, fs=FS, names=list(ROLES)) as rec:
        got = td.analyze(rec, hop=2.0, threads=2, **KW)
    assert _mapped_ok(file_calls)
    assert len(got) == 60
    assert_same(got, td.analyze(_mapping(a), fs=FS, hop=2.0, threads=2, **KW))


def test_mapped_path_other_settings_use_the_streaming_path(data, npy, file_calls):
    """highpass, max_lag and progress are not for the mapped path; results stay the mapping's."""
    with open_recording(npy, fs=FS, names=list(ROLES)) as rec:
        got = td.analyze(rec, hop=3.0, max_lag=5, threads=2, **KW)
    assert file_calls == []
    assert_same(got, td.analyze(_mapping(data), fs=FS, hop=3.0, max_lag=5, threads=2, **KW))


@pytest.mark.fast
@settings(max_examples=25, deadline=None)
@given(
    length=st.integers(3, 4000),
    step=st.integers(200, 6000),
    start=st.integers(0, 20_000),
    chunk_n=st.one_of(st.none(), st.integers(1, 30_000)),
    threads=st.sampled_from([1, 2]),
)
def test_mapped_path_equals_mapping_any_grid(data, npy, length, step, start, chunk_n, threads):
    """Any window, hop, start and chunk (in samples): the mapped table is the streaming one."""
    kw = dict(
        window=length / FS,
        hop=step / FS,
        n_bins=5,
        area_mm2=1.0,
        threads=threads,
        start=start,
        chunk=None if chunk_n is None else chunk_n / FS,
    )
    with mock.patch.object(_core, "windows_stats_file", wraps=_core.windows_stats_file) as spy:
        with open_recording(npy, fs=FS, names=list(ROLES)) as rec:
            got = td.analyze(rec, **kw)
    assert spy.call_count == 1
    want = td.analyze(_mapping(data, origin=start), fs=FS, **kw)
    assert_same(got, want)
    assert got.params["window_samples"] == length and got.params["hop_samples"] == step


# -- 2. fallbacks: NaN, scaling, dtype, layout -------------------------------------


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("hop, first", [(2.0, 50_000), (3.0, 51_000)])
@pytest.mark.parametrize("row, role, bad", [(1, "fy", np.nan), (2, "fz", np.nan), (0, "fx", np.inf), (3, "i", -np.inf)])
def test_non_finite_in_a_window_names_channel_and_window(
    data, tmp_path, file_calls, threads, hop, first, row, role, bad
):
    a = data.copy()
    a[row, 51_500] = bad
    p = _write(tmp_path / "nan.npy", a)
    msg = (
        rf"^{role} contains NaN or inf in the window starting at sample {first} "
        rf"\(t = {first / FS:g} s\)$"
    )
    with open_recording(p, fs=FS, names=list(ROLES)) as rec:
        with pytest.raises(ValueError, match=msg):
            td.analyze(rec, hop=hop, threads=threads, **KW)
    # The mapped path was tried and refused the window; the streaming path worded the error.
    assert len(file_calls) == 1 and isinstance(file_calls[0]["error"], ValueError)
    with pytest.raises(ValueError, match=msg):
        td.analyze(_mapping(a), fs=FS, hop=hop, threads=threads, **KW)


def test_nan_with_start_is_named_by_absolute_sample(data, tmp_path, file_calls):
    a = data.copy()
    a[1, 100_001] = np.nan
    p = _write(tmp_path / "nan.npy", a)
    with open_recording(p, fs=FS, names=list(ROLES)) as rec:
        with pytest.raises(
            ValueError,
            match=r"^fy contains NaN or inf in the window starting at sample 99000 "
            r"\(t = 99 s\)$",
        ):
            td.analyze(rec, hop=3.0, start=4321, threads=2, **KW)


@pytest.mark.parametrize("where", [2_500, 149_500, 13_000])  # a gap between windows, after the last, before start
def test_nan_outside_every_window_changes_nothing(data, tmp_path, file_calls, where):
    a = data.copy()
    a[1, where] = np.nan
    a[2, where] = np.inf
    p = _write(tmp_path / "gap.npy", a)
    with open_recording(p, fs=FS, names=list(ROLES)) as rec:
        got = td.analyze(rec, hop=3.0, start=12_345, threads=2, **KW)
    assert _mapped_ok(file_calls)
    assert_same(got, td.analyze(_mapping(a, origin=12_345), fs=FS, hop=3.0, start=12_345, threads=2, **KW))
    assert np.isfinite(got.table["mu_r"]).all()


def _variant(kind: str, a: np.ndarray, tmp_path):
    """(path, open_recording kwargs, the float64 channels the analysis must see)."""
    names = list(ROLES)
    if kind == "scale":
        want = a.copy()
        want[2] *= 2.0
        return _write(tmp_path / "s.npy", a), dict(names=names, scale={"fz": 2.0}), want, names
    if kind == "float32":
        a32 = a.astype(np.float32)
        return _write(tmp_path / "f32.npy", a32), dict(names=names), a32.astype(np.float64), names
    if kind == "samples_first":
        return _write(tmp_path / "sf.npy", np.ascontiguousarray(a.T)), dict(names=names), a, names
    if kind == "fortran":
        return _write(tmp_path / "fo.npy", np.asfortranarray(a)), dict(names=names), a, names
    if kind == "big_endian":
        return _write(tmp_path / "be.npy", a.astype(">f8")), dict(names=names), a, names
    if kind == "cof":
        names = ["fx", "fy", "fz", "cof"]
        return _write(tmp_path / "cof.npy", a), dict(names=names), a, names
    raise AssertionError(kind)


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("hop, start", [(1.0, 0), (3.0, 2_345)])  # 1 s tiles: 150 windows, two spans
@pytest.mark.parametrize("kind", ["scale", "float32", "samples_first", "fortran", "big_endian", "cof"])
def test_fallbacks_equal_mapping(data, tmp_path, file_calls, kind, hop, start, threads):
    path, kw, want_arr, names = _variant(kind, data, tmp_path)
    kwa = dict(KW, window=1.0) if hop == 1.0 else KW
    extra = {"current": 4.0} if kind == "cof" else {}
    with open_recording(path, fs=FS, **kw) as rec:
        if kind != "cof":  # the channels could be mapped, but the instrument's COF column is not read there
            assert rec.file_layout([r for r in ("fx", "fy", "fz", "i") if r in rec.roles]) is None
        got = td.analyze(rec, hop=hop, start=start, threads=threads, **extra, **kwa)
    assert file_calls == []  # nothing the kernel could map
    want = td.analyze(
        _mapping(want_arr, names, origin=start), fs=FS, hop=hop, start=start, threads=threads, **extra, **kwa
    )
    assert_same(got, want)
    if kind == "scale":
        # The scaled result is the unscaled one with fz doubled: mu halves.
        with open_recording(path, fs=FS, names=list(ROLES)) as rec:
            plain = td.analyze(rec, hop=hop, start=start, threads=threads, **kwa)
        np.testing.assert_allclose(got.table["mu_r"], plain.table["mu_r"] / 2, rtol=1e-12)
    if kind == "cof":
        assert np.isfinite(got.table["mu_instrument"]).all()


def test_samples_first_layout_given_explicitly_falls_back(data, tmp_path, file_calls):
    """A (n, 4) file read with layout='samples_first' explicitly (the 10x rule agrees)."""
    p = _write(tmp_path / "sf.npy", np.ascontiguousarray(data.T))
    with open_recording(p, fs=FS, names=list(ROLES), layout="samples_first") as rec:
        assert rec.metadata["layout"] == "samples_first"
        got = td.analyze(rec, hop=2.0, threads=2, chunk=11.0, **KW)
    assert file_calls == []
    assert_same(got, td.analyze(_mapping(data), fs=FS, hop=2.0, threads=2, **KW))


def test_closed_recording_is_refused(npy, file_calls):
    rec = open_recording(npy, fs=FS, names=list(ROLES))
    rec.close()
    with pytest.raises(RecordingError, match="closed"):
        td.analyze(rec, hop=2.0, **KW)
    assert file_calls == []


def test_truncated_after_opening_raises_not_crashes(data, tmp_path, file_calls):
    p = _write(tmp_path / "t.npy", data)
    with open_recording(p, fs=FS, names=list(ROLES)) as rec:
        with open(p, "r+b") as fh:
            fh.truncate(os.path.getsize(p) - 8 * (N + N // 2))  # fz cut in the middle, i gone
        for threads in (1, 2):
            with pytest.raises(RecordingError, match="file ends early|truncated"):
                td.analyze(rec, hop=2.0, threads=threads, **KW)
    # The pre-pass (docs/method.md 6a) may read the cut samples first; either way a RecordingError, and any
    # kernel call that saw the short file failed with a ValueError, never a crash.
    assert all(isinstance(c["error"], ValueError) for c in file_calls)


def _unaligned_npy(path, a: np.ndarray) -> int:
    """A valid v1.0 ``.npy`` (np.load reads it) whose data start at a byte offset that is not a multiple of 8."""
    header = "{'descr': '<f8', 'fortran_order': False, 'shape': %r, }" % (a.shape,)
    pad = (-(10 + len(header) + 1)) % 8 + 4
    header += " " * pad + "\n"
    with open(path, "wb") as fh:
        fh.write(b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header.encode("latin1"))
        fh.write(np.ascontiguousarray(a, dtype="<f8").tobytes())
    offset = 10 + len(header)
    assert offset % 8 == 4
    np.testing.assert_array_equal(np.load(path), a)
    return offset


def test_unaligned_npy_header_falls_back(data, tmp_path, file_calls):
    a = data[:, :20_000]
    p = tmp_path / "unaligned.npy"
    _unaligned_npy(p, a)
    with open_recording(p, fs=FS, names=list(ROLES)) as rec:
        got = td.analyze(rec, hop=2.0, threads=1, **KW)
    assert_same(got, td.analyze(_mapping(a), fs=FS, hop=2.0, threads=1, **KW))


def test_unaligned_npy_header_chunks_and_read(data, tmp_path):
    """What does work on such a file: the mapped kernel refuses the odd offset; copies read right."""
    a = data[:, :20_000]
    p = tmp_path / "unaligned.npy"
    off = _unaligned_npy(p, a)
    with open_recording(p, fs=FS, names=list(ROLES)) as rec:
        np.testing.assert_array_equal(rec.read()["fy"], a[1])
        views = list(rec.chunks(3000, copy=False))
        np.testing.assert_array_equal(np.concatenate([c["fz"] for c in views]), a[2])
    with pytest.raises(ValueError, match="multiple of 8"):
        _wsf(p, (None, off + 20_000 * 8, off + 2 * 20_000 * 8, None), 20_000, 0, 5, 2000, 2000, "force", 0.35, 16)


def test_mapped_path_reads_the_opened_file_not_a_replacement(data, tmp_path):
    """A file replaced (renamed over, as io.writers.atomic_write does) after opening: analyze(rec) reads what
    rec.read() reads, whatever path it takes."""
    p = _write(tmp_path / "r.npy", data[:, :40_000])
    with open_recording(p, fs=FS, names=list(ROLES)) as rec:
        old = rec.read()  # the recording's own file
        other = data[:, 40_000:80_000].copy()
        other[1] *= 3.0  # another COF
        _write(tmp_path / "new.npy", other)
        os.replace(tmp_path / "new.npy", p)
        np.testing.assert_array_equal(rec.read()["fy"], old["fy"])  # still the opened file
        streamed = td.analyze(rec, hop=2.0, max_lag=0, **KW)  # not the mapped path
        got = td.analyze(rec, hop=2.0, **KW)
    want = td.analyze(old, fs=FS, hop=2.0, max_lag=0, **KW)
    np.testing.assert_array_equal(streamed.table["mu_r"], want.table["mu_r"])
    np.testing.assert_array_equal(got.table["mu_r"], streamed.table["mu_r"])


# -- 3. Recording.chunks(copy=False) --------------------------------------------------


def _collect(rec, size, roles=None, **kw):
    """All chunks at once (a chunk handed out must stay valid while later ones are read)."""
    return list(rec.chunks(size, roles, **kw))


@pytest.mark.parametrize("size", [1, 4096, 7000, 65536, N, 2 * N])
@pytest.mark.parametrize("span", [None, (1234, 98_765), (0, 5), (N - 1, N), (5000, 5000), (4095, 4097)])
def test_npy_view_chunks(data, npy, size, span):
    if size == 1 and span in (None, (1234, 98_765)):
        pytest.skip("one-sample chunks of a long span: slow, nothing new")
    kw = {} if span is None else {"start": span[0], "stop": span[1]}
    a0, b0 = span or (0, N)
    with open_recording(npy, fs=FS, names=list(ROLES)) as rec:
        views = _collect(rec, size, copy=False, **kw)
        copies = _collect(rec, size, copy=True, **kw)
        sub = _collect(rec, size, ["fz", "fy"], copy=False, **kw)
        for k, nm in enumerate(ROLES):
            got = np.concatenate([v[nm] for v in views]) if views else np.empty(0)
            np.testing.assert_array_equal(got, data[k, a0:b0])
    assert len(views) == len(copies) == len(sub) == -(-(b0 - a0) // size)
    for v, c, s in zip(views, copies, sub):
        assert list(v) == list(c) == list(ROLES)
        assert list(s) == ["fz", "fy"]
        for k in ROLES:
            assert v[k].dtype == np.float64 and v[k].ndim == 1
            assert v[k].flags.writeable is False
            assert c[k].flags.writeable is True
            np.testing.assert_array_equal(v[k], c[k])
        for k in ("fz", "fy"):
            assert s[k].flags.writeable is False
            np.testing.assert_array_equal(s[k], c[k])
    if views:
        with pytest.raises(ValueError):
            views[0]["fy"][0] = 1.0  # read-only: the file's own pages
    # Still valid (and unchanged) after the recording is closed, as long as they are referenced.
    for k, nm in enumerate(ROLES):
        got = np.concatenate([v[nm] for v in views]) if views else np.empty(0)
        np.testing.assert_array_equal(got, data[k, a0:b0])
    np.testing.assert_array_equal(np.load(npy), data)  # nothing written into the file


def test_npy_view_chunks_scaled_are_not_views(data, npy):
    """copy=False never hands out the raw pages of a scaled channel."""
    with open_recording(npy, fs=FS, names=list(ROLES), scale={"fz": 2.0}) as rec:
        views = _collect(rec, 10_000, copy=False, start=333, stop=77_777)
    fz = np.concatenate([v["fz"] for v in views])
    np.testing.assert_array_equal(fz, data[2, 333:77_777] * 2.0)
    assert all(v["fz"].flags.writeable for v in views)
    assert not any(v["fy"].flags.writeable for v in views)
    np.testing.assert_array_equal(np.concatenate([v["fy"] for v in views]), data[1, 333:77_777])


def _other_format(kind, a, tmp_path):
    """(path, open kwargs) of a small recording of a's channels in another format."""
    ch = {r: a[k] for k, r in enumerate(ROLES)}
    if kind == "npz":
        p = tmp_path / "r.npz"
        save_npz(p, ch, FS)
        return p, {}
    if kind == "npz_compressed":
        p = tmp_path / "rc.npz"
        save_npz(p, ch, FS, compress=True)
        return p, {}
    if kind == "hdf5":
        p = tmp_path / "r.h5"
        save_hdf5(p, ch, FS)
        return p, {}
    if kind == "csv":
        p = tmp_path / "r.csv"
        np.savetxt(p, a.T, delimiter=",", header=",".join(ROLES), comments="", fmt="%.17g")
        return p, {"fs": FS}
    if kind == "npy_samples_first":
        return _write(tmp_path / "sf.npy", np.ascontiguousarray(a.T)), {"fs": FS, "names": list(ROLES)}
    if kind == "npy_float32":
        return _write(tmp_path / "f32.npy", a.astype(np.float32)), {"fs": FS, "names": list(ROLES)}
    if kind == "npy_fortran":
        return _write(tmp_path / "fo.npy", np.asfortranarray(a)), {"fs": FS, "names": list(ROLES)}
    raise AssertionError(kind)


@pytest.mark.parametrize(
    "kind", ["npz", "npz_compressed", "hdf5", "csv", "npy_samples_first", "npy_float32", "npy_fortran"]
)
def test_other_formats_copy_false_same_values(data, tmp_path, kind):
    a = data[:, :70_000] if kind != "csv" else data[:, :9_000]
    n = a.shape[1]
    path, kw = _other_format(kind, a, tmp_path)
    with open_recording(path, **kw) as rec:
        assert rec.n_samples == n
        # HDF5 datasets stored plainly are read by the kernel too (issue 16); the others are not
        assert (rec.file_layout(list(ROLES)) is not None) == (kind == "hdf5")
        whole = rec.read(list(ROLES))
        for size, span in [(4000, None), (65536, None), (3001, (123, n - 77)), (n, (n // 2, n))]:
            skw = {} if span is None else {"start": span[0], "stop": span[1]}
            lo, hi = span or (0, n)
            views = _collect(rec, size, list(ROLES), copy=False, **skw)
            copies = _collect(rec, size, list(ROLES), copy=True, **skw)
            assert [len(v["fy"]) for v in views] == [len(c["fy"]) for c in copies]
            for v, c in zip(views, copies):
                for r in ROLES:
                    assert v[r].dtype == np.float64
                    assert c[r].flags.writeable
                    np.testing.assert_array_equal(v[r], c[r])
            for r in ROLES:
                np.testing.assert_array_equal(np.concatenate([v[r] for v in views]), whole[r][lo:hi])
    if kind != "csv":  # the text round trip is exact with %.17g too, but keep the claim to binaries
        np.testing.assert_array_equal(whole["fy"], a[1].astype(np.float32) if kind == "npy_float32" else a[1])


# -- 4. windows_stats_file: same statistics as windows_stats, errors not crashes -----


@pytest.fixture(scope="module")
def layout(npy):
    with open_recording(npy, fs=FS, names=list(ROLES)) as rec:
        found = rec.file_layout(list(ROLES))
    assert found is not None
    return found[1]


KERNEL = list(td.columns.KERNEL_COLUMNS)


def _spec(length, kind="force", deadband=0.35, n_bins=16, columns=KERNEL, **kw):
    return _core.WindowSpec(length, (kind, deadband), n_bins, list(columns), **kw)


def _wsf(path, offsets, n, k0, k1, step, length, kind, deadband, n_bins, block=512):
    """``_core.windows_stats_file`` on a descriptor of ``path`` opened for the call (the table's kernel columns)."""
    spec = _spec(length, kind, deadband, n_bins)
    fd = os.open(path, os.O_RDONLY)
    try:
        return _core.windows_stats_file(spec, fd, offsets, n, (k0, k1, step), block=block)
    finally:
        os.close(fd)


def _offsets(lay, fx=True, aux=True):
    return (lay["fx"] if fx else None, lay["fy"], lay["fz"], lay["i"] if aux else None)


@pytest.mark.parametrize("fx, aux", [(True, True), (False, False), (True, False)])
@pytest.mark.parametrize("block", [1, 7, 1000])
def test_windows_stats_file_equals_windows_stats(data, npy, layout, fx, aux, block):
    step, length, k0 = 1700, 2100, 3
    k1 = (N - length) // step + 1
    got = _wsf(npy, _offsets(layout, fx, aux), N, k0, k1, step, length, "force", 0.35, 16, block)
    starts = np.arange(k0, k1, dtype=np.int64) * step
    want = _core.windows_stats(
        _spec(length), data[0] if fx else None, data[1], data[2], data[3] if aux else None, starts
    )
    assert sorted(got) == sorted(want)
    for key in want:
        assert got[key].dtype == want[key].dtype, key
        np.testing.assert_array_equal(got[key], want[key], err_msg=key)
    assert got["n"].shape == (k1 - k0,)


def test_windows_stats_file_no_window(npy, layout):
    for k0, k1 in [(0, 0), (5, 3)]:
        got = _wsf(npy, _offsets(layout), N, k0, k1, 2000, 2000, "force", 0.35, 16)
        assert got["n"].shape == (0,) and got["bin_count"].shape == (0, 16)


def test_windows_stats_file_errors(npy, layout, tmp_path):
    off = _offsets(layout)

    def call(path=npy, offsets=off, n=N, k0=0, k1=10, step=2000, length=2000, block=512):
        return _wsf(path, offsets, n, k0, k1, step, length, "force", 0.35, 16, block)

    assert call()["n"].shape == (10,)
    # The file holds fewer samples than n says (the last channel runs past its end).
    with pytest.raises(ValueError, match="runs past the file"):
        call(n=N + 1, k1=1)
    with pytest.raises(ValueError, match="runs past the file"):
        call(offsets=(None, off[1], off[3] + 8, None), k1=1)
    with pytest.raises(ValueError, match="runs past the file"):
        call(offsets=(None, off[1], 10**15, None), k1=1)
    with pytest.raises(ValueError, match="runs past the file"):
        call(n=2**62, k1=1)  # n * 8 overflows
    # An offset not a multiple of 8.
    for bad in [
        (off[0] + 4, off[1], off[2], off[3]),
        (None, off[1] + 1, off[2], None),
        (None, off[1], off[2], off[3] - 2),
    ]:
        with pytest.raises(ValueError, match="multiple of 8"):
            call(offsets=bad)
    # Windows past the end of the channels.
    k_last = (N - 2000) // 2000 + 1
    assert call(k0=k_last - 1, k1=k_last)["n"].shape == (1,)
    with pytest.raises(ValueError, match="run past"):
        call(k0=0, k1=k_last + 1)
    with pytest.raises(ValueError, match="run past"):
        call(k0=k_last, k1=k_last + 1)
    with pytest.raises(ValueError, match="run past"):
        call(k1=2**62, step=2**10)  # (k1 - 1) * step overflows
    with pytest.raises(ValueError, match="run past"):
        call(k1=1, length=N + 1)
    # Zero step, block or window length.
    for kw in ({"step": 0}, {"block": 0}, {"length": 0}):
        with pytest.raises(ValueError, match="at least 1"):
            call(**kw)
    # The spec's settings are refused when it is made, before any file is read.
    with pytest.raises(ValueError, match="deadband kind"):
        _spec(2000, "bogus")
    with pytest.raises(ValueError, match='unknown kernel column "bogus"'):
        _spec(2000, columns=["n", "bogus"])
    with pytest.raises(ValueError, match=r"threads must be in \[1, "):
        _spec(2000, threads=10**6)
    # A missing file, a directory, an empty file.
    with pytest.raises(OSError):
        call(path=tmp_path / "missing.npy")
    with pytest.raises((OSError, ValueError)):
        call(path=tmp_path)
    empty = tmp_path / "empty.bin"
    empty.write_bytes(b"")
    with pytest.raises(ValueError, match="runs past the file"):
        call(path=empty)
    # Descriptors that are not open files.
    with pytest.raises(ValueError, match="file descriptor"):
        _core.windows_stats_file(_spec(2000), -1, off, N, (0, 10, 2000))
    fd = os.open(npy, os.O_RDONLY)
    os.close(fd)
    with pytest.raises(OSError):
        _core.windows_stats_file(_spec(2000), fd, off, N, (0, 10, 2000))
    # Negative numbers do not wrap around.
    with pytest.raises(OverflowError):
        call(n=-1)
    with pytest.raises(OverflowError):
        call(offsets=(None, -8, off[2], None))


def test_windows_stats_file_non_finite(data, tmp_path):
    a = data[:, :30_000].copy()
    a[1, 7_777] = np.nan
    p = _write(tmp_path / "nan.npy", a)
    with open_recording(p, fs=FS, names=list(ROLES)) as rec:
        lay = rec.file_layout(list(ROLES))[1]
    with pytest.raises(ValueError, match="NaN or inf"):
        _wsf(p, _offsets(lay), 30_000, 0, 15, 2000, 2000, "force", 0.35, 16, 4)
    # Windows clear of it are fine (7_777 lies in window 3 only).
    got = _wsf(p, _offsets(lay), 30_000, 4, 15, 2000, 2000, "force", 0.35, 16, 4)
    assert got["n"].shape == (11,)


# -- 5. analyze(rec, start=, stop=): one range of a recording, straight from the file ---


@pytest.mark.parametrize("highpass", [None, 0.1])
@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize(
    "start, stop, hop",
    [(0, 40_000, 2.0), (12_345, 99_999, 2.0), (7_001, 120_000, 3.0), (0, N, 2.0), (50_000, 52_000, 2.0)],
)
def test_range_of_a_recording_equals_the_sliced_mapping(data, npy, file_calls, threads, start, stop, hop, highpass):
    with open_recording(npy, fs=FS, names=list(ROLES)) as rec:
        got = td.analyze(rec, hop=hop, threads=threads, start=start, stop=stop, highpass=highpass, **KW)
    assert _mapped_ok(file_calls)
    want = td.analyze(
        _mapping(data[:, :stop], origin=start), fs=FS, hop=hop, threads=threads, start=start, highpass=highpass, **KW
    )
    assert_same(got, want)
    starts = got.table["t_start"] * FS
    assert starts.min() >= start and (starts + 2000).max() <= stop
    assert got.params["stop"] == stop


def test_range_too_short_for_a_window_is_refused(npy):
    with open_recording(npy, fs=FS, names=list(ROLES)) as rec:
        with pytest.raises(ValueError, match="hold no whole window"):
            td.analyze(rec, hop=2.0, start=50_000, stop=51_999, **KW)


@pytest.mark.parametrize("kind", ["hdf5", "csv"])
def test_range_of_other_formats(data, tmp_path, kind):
    path, kw = _other_format(kind, data, tmp_path)
    with open_recording(path, **kw) as rec:
        got = td.analyze(rec, hop=2.0, start=3_001, stop=90_000, **KW)
        raw = td.analyze(rec, hop=2.0, start=3_001, stop=90_000, highpass=0.1, **KW)
    assert_same(got, td.analyze(_mapping(data[:, :90_000], origin=3_001), fs=FS, hop=2.0, start=3_001, **KW))
    want_raw = td.analyze(_mapping(data[:, :90_000], origin=3_001), fs=FS, hop=2.0, start=3_001, highpass=0.1, **KW)
    assert_same(raw, want_raw)


def test_stop_errors(data, npy):
    with open_recording(npy, fs=FS, names=list(ROLES)) as rec:
        for bad in (N + 1, 10):
            with pytest.raises(ValueError, match="stop must satisfy"):
                td.analyze(rec, hop=2.0, start=20, stop=bad, **KW)
        with pytest.raises(ValueError, match="stop must be"):
            td.analyze(rec, hop=2.0, stop=-1, **KW)
    with pytest.raises(ValueError, match="recording source"):
        td.analyze(_mapping(data), fs=FS, hop=2.0, stop=100, **KW)


@pytest.mark.fast
def test_read_ranges_of_adjacent_gapped_empty_and_overlapping_ranges(tmp_path) -> None:
    # issue 38 point 2: adjacent ranges are read by one preadv; every range still lands where it belongs
    arr = np.random.default_rng(5).standard_normal((3, 5000))
    np.save(tmp_path / "r.npy", arr)
    ranges = [(0, 10), (10, 20), (20, 20), (20, 35), (100, 164), (164, 200), (150, 160), (4990, 5000), (0, 3)]
    with open_recording(tmp_path / "r.npy", fs=FS, names=["fy", "fz", "i"]) as rec:
        got = rec.read_ranges(ranges, ["fy", "fz"])
    for j, role in enumerate(("fy", "fz")):
        want = np.concatenate([arr[j, a:b] for a, b in ranges])
        assert np.array_equal(got[role], want)
