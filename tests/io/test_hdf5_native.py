"""HDF5 datasets read natively (pread of their contiguous bytes or uncompressed chunks) against h5py.

Each file is opened twice, natively and through h5py alone
(``tribodyn.io.hdf5._NATIVE = False``): the same channels and samples, bit
for bit. Contiguous and uncompressed chunked datasets of every numeric
type in both byte orders go natively (the recording is then mappable and
thread-safe); compressed ones and chunks never written stay with h5py.
``analyze`` gives the ``.npy`` path's table through the mapped route.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Dict, Tuple

import numpy as np
import pytest
from tribodyn.io import RecordingError, open_recording
from tribodyn.io import hdf5 as H


h5py = pytest.importorskip("h5py")


def _read(path: Path, native: bool, monkeypatch: Any) -> Tuple[str, Any]:
    monkeypatch.setattr(H, "_NATIVE", native)
    try:
        with open_recording(path) as rec:
            names = rec.channel_names
            part = next(iter(rec.chunks(5, names, start=rec.n_samples // 2, stop=rec.n_samples // 2 + 5)))
            return "read", (names, rec.read(names), part, sorted(getattr(rec, "_ext", {})), rec.thread_safe)
    except RecordingError as exc:
        return "refused", str(exc)


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return a.shape == b.shape and bool(np.all((a == b) | (np.isnan(a) & np.isnan(b))))


def _write(path: Path, datasets: Dict[str, Tuple[np.ndarray, Dict[str, Any]]]) -> None:
    with h5py.File(path, "w") as f:
        f.attrs["fs"] = 1000.0
        for k, (a, kw) in datasets.items():
            f.create_dataset(k, data=a, **kw)


@pytest.mark.fast
@pytest.mark.parametrize(
    "kw,native",
    [
        ({}, True),
        ({"chunks": (4096,)}, True),
        ({"chunks": (1000,)}, True),
        ({"chunks": (4096,), "compression": "gzip"}, False),
        ({"chunks": (4096,), "shuffle": True}, False),
    ],
)
@pytest.mark.parametrize("dtype", ["<f8", ">f8", "<f4", ">f4", "<i2", ">i4", "<u2", "i1", "u1", "<i8", ">u8"])
def test_same_samples_as_h5py(tmp_path, monkeypatch, kw, native, dtype):
    n = 10_007
    rng = np.random.default_rng(1)
    base = rng.normal(size=n) * 100
    p = tmp_path / "x.h5"
    data = {
        k: ((base + j).astype(dtype) if np.dtype(dtype).kind == "f" else (np.arange(n) * (j + 3) % 97).astype(dtype))
        for j, k in enumerate(("fx", "fy", "fz", "i"))
    }
    _write(p, {k: (a, kw) for k, a in data.items()})
    got, ref = _read(p, True, monkeypatch), _read(p, False, monkeypatch)
    assert got[0] == ref[0] == "read"
    (gn, gd, gp, gext, gsafe), (rn, rd, rp, _, _) = got[1], ref[1]
    assert gn == rn
    assert all(_same(gd[k], rd[k]) and _same(gp[k], rp[k]) for k in rn)
    assert (gext == sorted(rn)) is native and gsafe is native


@pytest.mark.fast
def test_unwritten_chunks_stay_with_h5py(tmp_path, monkeypatch):
    p = tmp_path / "sparse.h5"
    with h5py.File(p, "w") as f:
        f.attrs["fs"] = 1000.0
        f.create_dataset("fy", data=np.arange(5000.0), chunks=(1000,))
        d = f.create_dataset("fz", shape=(5000,), dtype="f8", chunks=(1000,), fillvalue=7.0)
        d[:1000] = 1.0  # the other chunks are never written
    got, ref = _read(p, True, monkeypatch), _read(p, False, monkeypatch)
    assert got[1][3] == ["fy"] and all(_same(got[1][1][k], ref[1][1][k]) for k in ref[1][0])


@pytest.mark.fast
def test_analyze_mapped_route_equals_npy(tmp_path, monkeypatch):
    import tribodyn
    from tribodyn import simulate

    parts: Dict[str, list] = {k: [] for k in ("fx", "fy", "fz", "i")}
    for c in simulate.continuous(60.0, chunk_s=30.0, current=4.0, seed=11, fs=1000.0, raw=False):
        for k in parts:
            parts[k].append(c[k])
    sig = {k: np.concatenate(v) for k, v in parts.items()}
    q = tmp_path / "rec.npy"
    np.save(q, np.stack([sig[k] for k in parts]))
    with open_recording(q, names=list(parts), fs=1000.0) as rec:
        want = tribodyn.analyze(rec, window=2, hop=2, method="paper").table
    for kw in ({}, {"chunks": (16384,)}, {"chunks": (1000,)}):
        p = tmp_path / f"rec{len(kw)}_{kw.get('chunks', [0])[0]}.h5"
        _write(p, {k: (v, kw) for k, v in sig.items()})
        for native in (True, False):
            monkeypatch.setattr(H, "_NATIVE", native)
            for opts in ({}, {"threads": 1}, {"chunk": 7000}):
                with open_recording(p) as rec:
                    res = tribodyn.analyze(rec, window=2, hop=2, method="paper", **opts)
                assert res.params["route"] == ("mapped" if native else "stream"), (kw, native, opts)
                got = res.table
                assert set(got) == set(want)
                assert all(_same(got[k], want[k]) for k in want if np.asarray(want[k]).dtype.kind in "fiu"), (kw, opts)
