"""The native multi-range read of a ``.npy`` (``_core.pread_ranges``, issue 38 point 2) against NumPy's slices
and the Python read it replaced (one ``os.preadv`` a range)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Dict, List, Tuple

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
