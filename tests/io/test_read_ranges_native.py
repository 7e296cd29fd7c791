"""The native multi-range read of a ``.npy`` (``_core.pread_ranges``, issue 38 point 2) against NumPy's slices
and the Python read it replaced (one ``os.preadv`` a range)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Dict, List, Tuple

import numpy as np
import pytest
from tribodyn import _core
from tribodyn.io import RecordingError, open_recording
from tribodyn.io.numpy_files import NpyRecording

FS = 1000.0

#: Ranges of a 5000-sample recording: adjacent (merged into one read), gapped, empty ones (at the start, between,
#: at the end), overlapping, out of order, a single sample, the last samples, the whole recording.
RANGES: List[Tuple[int, int]] = [(0, 0), (0, 10), (10, 20), (20, 20), (20, 35), (100, 164), (164, 200), (150, 160),
                                 (4999, 5000), (7, 8), (4990, 5000), (5000, 5000), (0, 3), (0, 5000)]  # fmt: skip


def _want(arr: np.ndarray, ranges: List[Tuple[int, int]], row: int) -> np.ndarray:
    return np.concatenate([arr[row, a:b] for a, b in ranges]) if ranges else arr[row, :0]


def _read(path: Path, ranges: List[Tuple[int, int]], python: bool = False) -> Dict[str, np.ndarray]:
    with open_recording(path, fs=FS, names=["fy", "fz", "i"]) as rec:
        assert isinstance(rec, NpyRecording)
        if python:
            return rec._read_ranges_python(["fy", "fz", "i"], ranges)
        return rec._read_ranges(["fy", "fz", "i"], ranges)


@pytest.mark.fast
@pytest.mark.parametrize("dtype", ["<f8", "<f4", ">f8", ">i4", "<i2", "u1"])
def test_native_read_is_numpys_slicing_of_every_dtype(tmp_path: Path, dtype: str) -> None:
    arr = (np.random.default_rng(3).standard_normal((3, 5000)) * 100).astype(dtype)
    np.save(tmp_path / "r.npy", arr)
    for ranges in (RANGES, [(5, 5)], [(4999, 5000)], [], [(0, 5000)]):
        got, ref = _read(tmp_path / "r.npy", ranges), _read(tmp_path / "r.npy", ranges, python=True)
        for j, nm in enumerate(("fy", "fz", "i")):
            want = _want(arr, ranges, j).astype(arr.dtype)  # np.concatenate gives the native byte order
            assert got[nm].dtype == ref[nm].dtype == arr.dtype  # raw: the file's type and byte order
            assert got[nm].tobytes() == want.tobytes() == ref[nm].tobytes()
            assert got[nm].flags.owndata and got[nm].flags.writeable and got[nm].base is None


@pytest.mark.fast
@pytest.mark.parametrize("layout", ["fortran", "samples_first", "one_channel"])
def test_read_ranges_of_other_layouts(tmp_path: Path, layout: str) -> None:
    arr = np.random.default_rng(4).standard_normal((3, 5000))
    if layout == "fortran":
        np.save(tmp_path / "r.npy", np.asfortranarray(arr))
    elif layout == "samples_first":
        np.save(tmp_path / "r.npy", arr.T.copy())
    else:
        np.save(tmp_path / "r.npy", arr[1])
    names = ["fy"] if layout == "one_channel" else ["fx", "fy", "fz"]
    with open_recording(tmp_path / "r.npy", fs=FS, names=names) as rec:
        got = rec.read_ranges(RANGES, ["fy"])
    assert got["fy"].tobytes() == _want(arr, RANGES, 1).tobytes()


@pytest.mark.fast
def test_scaled_ranges_are_float64_and_scaled(tmp_path: Path) -> None:
    arr = np.arange(3 * 5000, dtype=np.int16).reshape(3, 5000)
    np.save(tmp_path / "r.npy", arr)
    with open_recording(tmp_path / "r.npy", fs=FS, names=["fy", "fz", "i"], scale={"fy": 0.5}) as rec:
        got = rec.read_ranges(RANGES, ["fy", "fz"])
    assert got["fy"].dtype == np.float64 and np.array_equal(got["fy"], _want(arr, RANGES, 0) * 0.5)
    assert np.array_equal(got["fz"], _want(arr, RANGES, 1).astype(np.float64))


@pytest.mark.fast
def test_large_reads_on_threads_are_the_same(tmp_path: Path) -> None:
    # over _PARALLEL_READ samples: the ranges are split over threads (byte-balanced groups)
    n = 600_000
    arr = np.random.default_rng(6).standard_normal((3, n))
    np.save(tmp_path / "r.npy", arr)
    ranges = [(a, min(a + 70_001, n)) for a in range(0, n, 90_000)] + [(0, n), (n - 1, n)]
    got, ref = _read(tmp_path / "r.npy", ranges), _read(tmp_path / "r.npy", ranges, python=True)
    for j, nm in enumerate(("fy", "fz", "i")):
        assert np.array_equal(got[nm], _want(arr, ranges, j)) and np.array_equal(ref[nm], got[nm])
    out = np.empty(arr[0].nbytes, dtype=np.uint8)
    fd = os.open(tmp_path / "r.npy", os.O_RDONLY)
    try:
        off = os.path.getsize(tmp_path / "r.npy") - arr.nbytes
        for threads in (1, 2, 3):
            _core.pread_ranges(fd, out, np.array([off], np.int64), np.array([out.size], np.int64), threads=threads)
            assert out.view(np.float64).tobytes() == arr[0].tobytes()
    finally:
        os.close(fd)


@pytest.mark.fast
def test_a_file_truncated_after_opening_is_a_recording_error(tmp_path: Path) -> None:
    arr = np.random.default_rng(7).standard_normal((3, 5000))
    np.save(tmp_path / "r.npy", arr)
    with open_recording(tmp_path / "r.npy", fs=FS, names=["fy", "fz", "i"]) as rec:
        os.truncate(tmp_path / "r.npy", os.path.getsize(tmp_path / "r.npy") - 800)
        assert rec.read_ranges([(0, 10)], ["fy"])["fy"].tobytes() == arr[0, :10].tobytes()
        with pytest.raises(RecordingError, match="file ends early"):
            rec.read_ranges([(0, 10), (4950, 5000)], ["i"])


@pytest.mark.fast
def test_pread_ranges_checks_its_arguments(tmp_path: Path) -> None:
    (tmp_path / "b").write_bytes(bytes(range(256)))
    fd = os.open(tmp_path / "b", os.O_RDONLY)
    try:
        out = np.empty(6, dtype=np.uint8)
        _core.pread_ranges(fd, out, np.array([10, 0, 250], np.int64), np.array([2, 0, 4], np.int64))
        assert out[:6].tolist() == [10, 11, 250, 251, 252, 253]
        i64 = lambda *v: np.array(v, dtype=np.int64)  # noqa: E731
        with pytest.raises(ValueError, match="the ranges hold 5 bytes, out 6"):
            _core.pread_ranges(fd, out, i64(0, 1), i64(2, 3))
        with pytest.raises(ValueError, match="2 offsets but 1 lengths"):
            _core.pread_ranges(fd, out, i64(0, 1), i64(6))
        with pytest.raises(ValueError, match="offset and a length >= 0"):
            _core.pread_ranges(fd, out, i64(-1), i64(6))
        with pytest.raises(ValueError, match="offset and a length >= 0"):
            _core.pread_ranges(fd, out, i64(0, 0), i64(7, -1))
        with pytest.raises(ValueError, match="the file ends before byte 257"):
            _core.pread_ranges(fd, out, i64(251), i64(6))
        with pytest.raises(ValueError, match="overflows"):
            _core.pread_ranges(fd, out, i64(2**63 - 2), i64(6))
        with pytest.raises(ValueError, match="C-contiguous uint8"):
            _core.pread_ranges(fd, np.empty(12, dtype=np.uint8)[::2], i64(0), i64(6))
        with pytest.raises(TypeError):
            _core.pread_ranges(fd, np.empty(6, dtype=np.float64), i64(0), i64(6))
        _core.pread_ranges(fd, np.empty(0, dtype=np.uint8), i64(), i64())  # nothing to read
    finally:
        os.close(fd)
    with pytest.raises(OSError):
        _core.pread_ranges(fd, np.empty(2, dtype=np.uint8), np.array([0], np.int64), np.array([2], np.int64))


def _ranges(n: int) -> List[Tuple[int, int]]:
    """Pieces as the pre-pass spreads them (sample_channels), and the edge cases of :data:`RANGES`."""
    spread = [(int(a), int(a) + 64) for a in np.linspace(0, n - 64, 97).astype(np.int64)]
    return spread + [(a, b) for a, b in RANGES if b <= n] + [(n - 1, n), (0, n), (n, n)]


def _batch_equals_one_range_at_a_time(path: Path, **kw: Any) -> int:
    """Asserts the native batch read (``_core.extents_read_ranges``) gives the bytes of ``Extents.read`` a range
    at a time (the Recording's own loop); returns the channels read by the batch."""
    from tribodyn.io.base import Recording

    calls: List[int] = []
    batch = _core.extents_read_ranges

    def counted(*a: Any) -> np.ndarray:
        calls.append(1)
        return batch(*a)

    with open_recording(path, **kw) as rec:
        names = list(rec.channel_names)
        ranges = _ranges(rec.n_samples)
        _core.extents_read_ranges = counted
        try:
            got = rec._read_ranges(names, ranges)
        finally:
            _core.extents_read_ranges = batch
        want = Recording._read_ranges(rec, names, ranges)
        for nm in names:
            assert got[nm].dtype == want[nm].dtype and got[nm].tobytes() == want[nm].tobytes(), nm
    return len(calls)


@pytest.mark.fast
def test_tdms_batch_read_is_the_range_read(tmp_path: Path) -> None:
    from tribodyn.io.tdms import write_daqmx_tdms
    from tribodyn.io.writers import save_tdms

    rng = np.random.default_rng(8)
    sig = {k: rng.normal(size=5003) * 10 for k in ("fx", "fy", "fz", "i")}
    for seg in (5003, 1000, 64, 7):  # one segment; a DAQ logger's; pieces across many segments
        save_tdms(tmp_path / f"s{seg}.tdms", sig, FS, segment_samples=seg)
        assert _batch_equals_one_range_at_a_time(tmp_path / f"s{seg}.tdms") == 4
    raw = {k: rng.integers(-32000, 32000, 5003).astype(np.int16) for k in ("fx", "fy", "fz", "i")}
    scales = {"fx": [("Linear", (0.001, 0.5))], "fy": [("Polynomial", [0.1, 2e-3, 1e-9])],
              "fz": [("Linear", (0.01, 20.0)), ("Polynomial", [1.0, 2.0])]}  # fmt: skip
    for seg in (5003, 1000):  # DAQmx raw int16, interleaved rows, scaled
        write_daqmx_tdms(str(tmp_path / f"d{seg}.tdms"), raw, FS, scales, segment_samples=seg)
        assert _batch_equals_one_range_at_a_time(tmp_path / f"d{seg}.tdms") == 4


@pytest.mark.fast
@pytest.mark.parametrize("dtype", ["<f8", ">f8", "<f4", "<i2", ">i4"])
def test_hdf5_batch_read_is_the_range_read(tmp_path: Path, dtype: str) -> None:
    h5py = pytest.importorskip("h5py")
    base = np.random.default_rng(9).normal(size=10_007) * 100
    for label, kw in (("contiguous", {}), ("chunked", {"chunks": (1000,)}), ("small_chunks", {"chunks": (37,)})):
        p = tmp_path / f"{label}.h5"
        with h5py.File(p, "w") as f:
            f.attrs["fs"] = FS
            for j, k in enumerate(("fx", "fy", "fz", "i")):
                f.create_dataset(k, data=(base + j).astype(dtype), **kw)
        assert _batch_equals_one_range_at_a_time(p) == 4


@pytest.mark.fast
def test_extents_read_ranges_refuses_a_range_past_the_end(tmp_path: Path) -> None:
    from tribodyn.io.writers import save_tdms

    save_tdms(tmp_path / "s.tdms", {"fy": np.arange(3000.0), "fz": np.ones(3000)}, FS, segment_samples=1000)
    with open_recording(tmp_path / "s.tdms") as rec:
        ext, fd = rec._objs["fy"].extents, rec._fd
        assert _core.extents_read_ranges(ext, fd, []).size == 0
        assert _core.extents_read_ranges(ext, fd, [(999, 1001), (5, 5), (2999, 3000)]).tolist() == [999, 1000, 2999]
        with pytest.raises(ValueError, match="^2990:3001: "):
            _core.extents_read_ranges(ext, fd, [(0, 2), (2990, 3001)])
