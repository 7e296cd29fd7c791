"""The native TDMS reader against npTDMS (the oracle, and the fallback).

Every TDMS file the project has or writes is opened twice, natively and
through npTDMS (``tribodyn.io.tdms._NATIVE = False``): both must refuse it
(a RecordingError) or both read it, with the same channels, samples (bit
for bit), rates, units, start time and metadata. The files: the real DAQmx
file of tests/data/real, the simulator's output,
npTDMS's writer in several layouts (segments, incremental metadata, every
numeric type, scaling), hand-written layouts npTDMS's writer cannot make
(interleaved, big-endian, DAQmx raw int16 with linear and polynomial
scalers), files the native reader leaves to npTDMS (strings, another scale
type: detected before reading, the reason in ``warnings``), and seeded
mutants of several of them. Tables of ``analyze`` are identical through
the native mapped route, the npTDMS route and the ``.npy`` of the same
samples, on any number of threads and chunk sizes.
"""

from __future__ import annotations

import random
import struct
import subprocess
import sys
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple

import numpy as np
import pytest
from _mutants import mutate
from tribodyn.io import RecordingError, open_recording
from tribodyn.io import tdms as T
from tribodyn.io.tdms import write_daqmx_tdms
from tribodyn.io.writers import save_tdms
from _paths import TESTS


HERE = TESTS
REAL = sorted((HERE / "data" / "real").glob("*.tdms"))
assert REAL, "tests/data/real holds the real DAQmx TDMS file"


def _read(path: Path, native: bool, monkeypatch: Any, **kw: Any) -> Tuple[str, Any]:
    """('refused', None) or ('read', what the recording says), through the native reader or npTDMS."""
    monkeypatch.setattr(T, "_NATIVE", native)
    try:
        with open_recording(path, **kw) as rec:
            names = rec.channel_names
            data = rec.read(names)
            said = {
                "names": names,
                "n": rec.n_samples,
                "fs": rec.fs,
                "units": {c.name: c.unit for c in rec.channels},
                "metadata": {k: v for k, v in rec.metadata.items()},
                "data": data,
                "native": getattr(rec, "_native", False),
                "warnings": list(rec.warnings),
                "roles": dict(rec.roles),
            }
            if len(names) and rec.n_samples > 3:  # a range in the middle, as the chunked routes read
                a = rec.n_samples // 3
                said["part"] = next(iter(rec.chunks(3, names, start=a, stop=a + 3)))
            return "read", said
    except RecordingError as exc:
        return "refused", str(exc)


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return a.shape == b.shape and bool(np.all((a == b) | (np.isnan(a) & np.isnan(b))))


def compare(path: Path, monkeypatch: Any, expect_native: Optional[bool] = True, **kw: Any) -> str:
    """Reads ``path`` both ways and asserts they agree; returns the outcome ('read' or 'refused')."""
    got, ref = _read(path, True, monkeypatch, **kw), _read(path, False, monkeypatch, **kw)
    assert got[0] == ref[0], (
        f"{path.name}: native {got[0]} ({str(got[1])[:300]}), npTDMS {ref[0]} ({str(ref[1])[:300]})"
    )
    if got[0] == "refused":
        return "refused"
    g, r = got[1], ref[1]
    if expect_native is not None:
        assert g["native"] is expect_native, f"{path.name}: native={g['native']}; warnings {g['warnings']}"
    for key in ("names", "n", "fs", "units", "metadata", "roles"):
        assert g[key] == r[key], f"{path.name}: {key} differ: {g[key]!r} vs {r[key]!r}"
    for name in r["names"]:
        assert _same(g["data"][name], r["data"][name]), f"{path.name}: channel {name!r} differs"
        if r.get("part") is not None:
            assert _same(g["part"][name], r["part"][name]), f"{path.name}: a range of {name!r} differs"
    return "read"


def _signals(n: int, seed: int = 0) -> Dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    fz = 20.0 + rng.normal(size=n)
    return {
        "fx": rng.normal(size=n),
        "fy": -0.2 * fz + 0.1 * rng.normal(size=n),
        "fz": fz,
        "i": 4.0 + rng.normal(size=n),
    }


# ------------------------------------------------------------------ hand-written TDMS


def _s(x: str, o: str = "<") -> bytes:
    b = x.encode()
    return struct.pack(o + "I", len(b)) + b


def _props(props: Dict[str, Any], o: str = "<") -> bytes:
    out = struct.pack(o + "I", len(props))
    for k, v in props.items():
        out += _s(k, o)
        if isinstance(v, str):
            out += struct.pack(o + "I", 0x20) + _s(v, o)
        elif isinstance(v, int):
            out += struct.pack(o + "Ii", 3, v)
        else:
            out += struct.pack(o + "Id", 10, v)
    return out


_CODES = {"i1": 1, "i2": 2, "i4": 3, "i8": 4, "u1": 5, "u2": 6, "u4": 7, "u8": 8, "f4": 9, "f8": 10}


def _segment(objs: List[Tuple[str, Any, Dict[str, Any]]], data: bytes, toc: int, big: bool = False) -> bytes:
    """One segment: objs are (path, index, properties); index None (no data), 0 (same as before) or (dtype, count)."""
    o = ">" if big else "<"
    meta = b""
    if toc & 2:
        meta = struct.pack(o + "I", len(objs))
        for path, idx, props in objs:
            meta += _s(path, o)
            if idx is None:
                meta += struct.pack(o + "I", 0xFFFFFFFF)
            elif idx == 0:
                meta += struct.pack(o + "I", 0)
            else:
                meta += struct.pack(o + "IIIQ", 20, _CODES[idx[0]], 1, idx[1])
            meta += _props(props, o)
    toc |= 64 if big else 0
    return (
        b"TDSm" + struct.pack("<I", toc) + struct.pack(o + "IQQ", 4713, len(meta) + len(data), len(meta)) + meta + data
    )


META, NEW, RAW, INTER = 2, 4, 8, 32


def _hand_files(tmp: Path) -> List[Path]:
    """Layouts npTDMS's writer does not make: interleaved, big-endian, incremental object lists, mixed types."""
    out = []
    n = 300
    sig = _signals(2 * n, 3)
    g = "/'g'"
    chan = {k: f"/'g'/'{k}'" for k in sig}
    root = [("/", None, {"creator": "test"}), (g, None, {})]
    for big in (False, True):
        o = ">" if big else "<"
        # interleaved float64, two segments, the second reusing the metadata
        cols = np.stack([sig[k][:n] for k in sig], axis=1).astype(o + "f8")
        cols2 = np.stack([sig[k][n:] for k in sig], axis=1).astype(o + "f8")
        objs = root + [(chan[k], ("f8", n), {"wf_increment": 0.001}) for k in sig]
        b = _segment(objs, cols.tobytes(), META | NEW | RAW | INTER, big) + _segment(
            [], cols2.tobytes(), RAW | INTER, big
        )
        p = tmp / f"inter_{'be' if big else 'le'}.tdms"
        p.write_bytes(b)
        out.append(p)
        # contiguous, every numeric type, then an incremental segment with "same as previous" indexes
        types = ["i1", "i2", "i4", "i8", "u1", "u2", "u4", "u8", "f4", "f8"]
        vals = {t: (np.arange(n) % 100 + 1).astype(t) for t in types}
        objs = root + [(f"/'g'/'{t}'", (t, n), {"wf_increment": 0.01}) for t in types]
        data = b"".join(vals[t].astype(o + t).tobytes() for t in types)
        seg2 = [(f"/'g'/'{t}'", 0, {}) for t in types]
        b = _segment(objs, data, META | NEW | RAW, big) + _segment(seg2, data, META | RAW, big)
        p = tmp / f"types_{'be' if big else 'le'}.tdms"
        p.write_bytes(b)
        out.append(p)
    # incremental: a channel added in the second segment (object list continued), one with no data there
    a, c = sig["fy"][:n], sig["fz"][:n]
    inc = {"wf_increment": 0.001}
    s1 = _segment(
        root + [(chan["fy"], ("f8", n), inc), (chan["fz"], ("f8", n), inc)], a.tobytes() + c.tobytes(), META | NEW | RAW
    )
    s2 = _segment(
        [(chan["fy"], None, {}), (chan["fz"], None, {}), (chan["fx"], ("f8", n), {"unit_string": "N", **inc})],
        c.tobytes(),
        META | RAW,
    )
    s3 = _segment([(chan["fy"], 0, {}), (chan["fz"], 0, {})], a.tobytes() + c.tobytes() + a.tobytes(), META | RAW)
    p = tmp / "incremental.tdms"
    p.write_bytes(s1 + s2 + s3)
    out.append(p)
    # several chunks in one segment (a segment of 3 chunks, contiguous)
    chunk = sig["fy"][:100].tobytes() + sig["fz"][:100].tobytes()
    s = _segment(root + [(chan["fy"], ("f8", 100), inc), (chan["fz"], ("f8", 100), inc)], chunk * 3, META | NEW | RAW)
    p = tmp / "chunks.tdms"
    p.write_bytes(s)
    out.append(p)
    return out


def _nptdms_files(tmp: Path) -> List[Path]:
    from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

    out = []
    sig = _signals(3000, 1)
    for seg in (3000, 1000, 7, 1):
        p = tmp / f"save_{seg}.tdms"
        save_tdms(
            p,
            {k: v[: 100 if seg == 1 else 3000] for k, v in sig.items()},
            1000.0,
            {"fy": "N", "fz": "N"},
            segment_samples=seg,
        )
        out.append(p)
    # scaled channels (linear, polynomial, chained), int16 raw data, a timestamp property
    raw = (np.arange(500) * 37 % 2000 - 1000).astype(np.int16)
    scales = {
        "lin": {
            "NI_Number_Of_Scales": 1,
            "NI_Scale[0]_Scale_Type": "Linear",
            "NI_Scale[0]_Linear_Slope": 0.01,
            "NI_Scale[0]_Linear_Y_Intercept": 2.5,
        },
        "poly": {
            "NI_Number_Of_Scales": 1,
            "NI_Scale[0]_Scale_Type": "Polynomial",
            "NI_Scale[0]_Polynomial_Coefficients_Size": 3,
            "NI_Scale[0]_Polynomial_Coefficients[0]": 1.0,
            "NI_Scale[0]_Polynomial_Coefficients[1]": 0.5,
            "NI_Scale[0]_Polynomial_Coefficients[2]": 1e-4,
        },
        "chain": {
            "NI_Number_Of_Scales": 2,
            "NI_Scale[0]_Scale_Type": "Linear",
            "NI_Scale[0]_Linear_Slope": 2.0,
            "NI_Scale[0]_Linear_Y_Intercept": 0.0,
            "NI_Scale[1]_Scale_Type": "Polynomial",
            "NI_Scale[1]_Polynomial_Coefficients_Size": 2,
            "NI_Scale[1]_Polynomial_Coefficients[0]": 3.0,
            "NI_Scale[1]_Polynomial_Coefficients[1]": 0.25,
            "NI_Scale[1]_Polynomial_Input_Source": 0,
        },
        "scaled_status": {
            "NI_Number_Of_Scales": 1,
            "NI_Scaling_Status": "scaled",
            "NI_Scale[0]_Scale_Type": "Linear",
            "NI_Scale[0]_Linear_Slope": 7.0,
            "NI_Scale[0]_Linear_Y_Intercept": 0.0,
        },
    }
    p = tmp / "scaled.tdms"
    with TdmsWriter(str(p)) as w:
        objs = [RootObject({"start": np.datetime64("2024-05-01T12:00:00.250000")}), GroupObject("g", {"x": 1})]
        objs += [ChannelObject("g", k, raw, properties={**v, "wf_increment": 0.001}) for k, v in scales.items()]
        w.write_segment(objs)
        w.write_segment([ChannelObject("g", k, raw[::-1].copy()) for k in scales])
    out.append(p)
    return out


def _fallback_files(tmp: Path) -> List[Tuple[Path, str]]:
    """Files the native reader leaves to npTDMS, with a word of the reason it gives."""
    from nptdms import ChannelObject, GroupObject, TdmsWriter

    out = []
    sig = _signals(200, 2)
    p = tmp / "strings.tdms"
    with TdmsWriter(str(p)) as w:
        inc = {"wf_increment": 0.001}
        w.write_segment(
            [
                ChannelObject("g", "fy", sig["fy"], inc),
                ChannelObject("g", "fz", sig["fz"], inc),
                ChannelObject("g", "note", np.array(["a"] * 200)),
            ]
        )
    out.append((p, "string"))
    p = tmp / "thermo.tdms"
    props = {
        "NI_Number_Of_Scales": 1,
        "NI_Scale[0]_Scale_Type": "Thermocouple",
        "NI_Scale[0]_Thermocouple_Type": 10072,
        "NI_Scale[0]_Temperature_Offset": 0.0,
    }
    with TdmsWriter(str(p)) as w:
        inc = {"wf_increment": 0.001}
        w.write_segment(
            [ChannelObject("g", "fy", sig["fy"], inc), ChannelObject("g", "t", sig["fz"], {**props, **inc})]
        )
    out.append((p, "Thermocouple"))
    # group-level linear scaling of float32 data (npTDMS scales in float32)
    raw = (np.arange(500) * 37 % 2000 - 1000).astype(np.int16)
    p = tmp / "group_scaled.tdms"
    with TdmsWriter(str(p)) as w:
        inc = {"wf_increment": 0.001}
        w.write_segment(
            [
                GroupObject(
                    "g",
                    {
                        "NI_Number_Of_Scales": 1,
                        "NI_Scale[0]_Scale_Type": "Linear",
                        "NI_Scale[0]_Linear_Slope": 0.01,
                        "NI_Scale[0]_Linear_Y_Intercept": 2.5,
                    },
                ),
                ChannelObject("g", "a", raw.astype(np.float32), inc),
                ChannelObject("g", "b", raw.astype(np.float64), inc),
            ]
        )
    out.append((p, "float32"))
    return out


def _daqmx_files(tmp: Path) -> List[Path]:
    rng = np.random.default_rng(5)
    raw = {k: rng.integers(-32000, 32000, 5003).astype(np.int16) for k in ("fx", "fy", "fz", "i")}
    out = []
    for seg in (5003, 1000, 64):
        p = tmp / f"daqmx_{seg}.tdms"
        write_daqmx_tdms(
            str(p),
            raw,
            1000.0,
            {
                "fx": [("Linear", (0.001, 0.5))],
                "fy": [("Polynomial", [0.1, 2e-3, 1e-9])],
                "fz": [("Linear", (0.01, 20.0)), ("Polynomial", [1.0, 2.0])],
            },
            segment_samples=seg,
            units={"fy": "N"},
        )
        out.append(p)
    return out


# ------------------------------------------------------------------ tests


@pytest.mark.fast
@pytest.mark.parametrize("path", REAL, ids=[p.name for p in REAL])
def test_real_files(path, monkeypatch):
    assert compare(path, monkeypatch) == "read"


@pytest.mark.parametrize("raw", [False, True])
def test_simulator_output(tmp_path, monkeypatch, raw):
    p = tmp_path / "sim.tdms"
    cmd = [sys.executable, "-m", "tribodyn", "simulate", "current_density", "--quiet", "--out", str(p)]
    r = subprocess.run(cmd + (["--raw"] if raw else []), capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert compare(p, monkeypatch) == "read"


@pytest.mark.fast
def test_nptdms_writer_layouts(tmp_path, monkeypatch):
    for p in _nptdms_files(tmp_path):
        assert compare(p, monkeypatch) == "read", p.name


@pytest.mark.fast
def test_hand_written_layouts(tmp_path, monkeypatch):
    for p in _hand_files(tmp_path):
        assert compare(p, monkeypatch) == "read", p.name


@pytest.mark.fast
def test_daqmx_linear_and_polynomial(tmp_path, monkeypatch):
    for p in _daqmx_files(tmp_path):
        assert compare(p, monkeypatch) == "read", p.name


@pytest.mark.fast
def test_fallback_is_detected_and_said(tmp_path, monkeypatch):
    for p, why in _fallback_files(tmp_path):
        assert compare(p, monkeypatch, expect_native=False) == "read", p.name
        monkeypatch.setattr(T, "_NATIVE", True)
        with open_recording(p) as rec:
            assert any("read by npTDMS" in w and why in w for w in rec.warnings), rec.warnings


@pytest.mark.fast
def test_native_recordings_are_thread_safe_and_mappable(tmp_path):
    p = _daqmx_files(tmp_path)[1]
    with open_recording(p) as rec:
        assert rec._native and rec.thread_safe and rec.mappable
        fd, layout = rec.file_layout(["fx", "fy", "fz", "i"])
        assert set(layout) == {"fx", "fy", "fz", "i"} and fd >= 0
        want = rec.read(rec.channel_names)
        from concurrent.futures import ThreadPoolExecutor

        def part(a: int) -> Dict[str, np.ndarray]:
            return next(iter(rec.chunks(700, rec.channel_names, start=a, stop=a + 700)))

        with ThreadPoolExecutor(4) as ex:
            parts = list(ex.map(part, range(0, 4200, 700)))
        for a, got in zip(range(0, 4200, 700), parts):
            assert all(_same(got[k], want[k][a : a + 700]) for k in got)


def _simulated(seconds: float) -> Dict[str, np.ndarray]:
    from tribodyn import simulate

    parts: Dict[str, List[np.ndarray]] = {k: [] for k in ("fx", "fy", "fz", "i")}
    for c in simulate.continuous(seconds, chunk_s=30.0, current=4.0, seed=11, fs=1000.0, raw=False):
        for k in parts:
            parts[k].append(c[k])
    return {k: np.concatenate(v) for k, v in parts.items()}


def test_analyze_tables_equal_across_routes(tmp_path, monkeypatch):
    import tribodyn

    sig = _simulated(90.0)
    q = tmp_path / "rec.npy"
    np.save(q, np.stack([sig[k] for k in ("fx", "fy", "fz", "i")]))
    files = []
    for seg in (1000, 10_000, 90_000):
        p = tmp_path / f"rec_{seg}.tdms"
        save_tdms(p, sig, 1000.0, {"fy": "N", "fz": "N"}, segment_samples=seg)
        files.append(p)
    d = tmp_path / "rec_daqmx.tdms"
    write_daqmx_tdms(
        str(d),
        {k: np.round(v * 1000).astype(np.int16) for k, v in sig.items()},
        1000.0,
        {k: [("Linear", (0.001, 0.0))] for k in sig},
        segment_samples=1000,
    )

    def table(path: Path, native: bool, **kw: Any) -> Tuple[str, Dict[str, np.ndarray]]:
        monkeypatch.setattr(T, "_NATIVE", native)
        extra = {"names": ["fx", "fy", "fz", "i"], "fs": 1000.0} if path.suffix == ".npy" else {}
        with open_recording(path, **extra) as rec:
            res = tribodyn.analyze(rec, window=2, hop=2, method="paper", **kw)
        return res.params["route"], {k: np.asarray(v) for k, v in res.table.items()}

    def equal(a: Dict[str, np.ndarray], b: Dict[str, np.ndarray]) -> bool:
        return set(a) == set(b) and all(_same(a[k], b[k]) for k in a if a[k].dtype.kind in "fiu")

    route, want = table(q, True)
    assert route == "mapped"
    for p in files:
        for native in (True, False):
            for kw in ({}, {"threads": 1}, {"threads": 2, "chunk": 5000}):
                route, got = table(p, native, **kw)
                assert route == ("mapped" if native else "stream"), (p.name, native, kw, route)
                assert equal(got, want), (p.name, native, kw)
    _, ref = table(d, False)
    for kw in ({}, {"threads": 1}, {"threads": 2, "chunk": 3000}):
        route, got = table(d, True, **kw)
        assert route == "mapped" and equal(got, ref), kw


@pytest.mark.fast
def test_many_small_segments_and_a_channel_no_role_asks_for(tmp_path, monkeypatch):
    """Segments of 20 samples (1500 of them: more runs in a block than one vectored read takes) with a
    channel no role asks for between the forces: the mapped route reads the spans of the forces' runs
    straight into their buffers (the other channel and the heads into scratch), and its table equals the
    ``.npy``'s bit for bit, at 1 and 2 threads and in small blocks."""
    import tribodyn

    sig = _simulated(30.0)
    q = tmp_path / "rec.npy"
    np.save(q, np.stack([sig[k] for k in ("fx", "fy", "fz", "i")]))
    p = tmp_path / "rec.tdms"
    chans = {"fx": sig["fx"], "fy": sig["fy"], "temperature": 20.0 + 0.01 * sig["fz"], "fz": sig["fz"], "i": sig["i"]}
    save_tdms(p, chans, 1000.0, {"fy": "N", "fz": "N"}, segment_samples=20)
    monkeypatch.setattr(T, "_NATIVE", True)

    def table(path: Path, **kw: Any) -> Tuple[str, Dict[str, np.ndarray]]:
        extra = {"names": ["fx", "fy", "fz", "i"], "fs": 1000.0} if path.suffix == ".npy" else {}
        with open_recording(path, **extra) as rec:
            res = tribodyn.analyze(rec, window=2, hop=2, method="paper", **kw)
        return res.params["route"], {k: np.asarray(v) for k, v in res.table.items()}

    route, want = table(q)
    assert route == "mapped"
    for kw in ({"threads": 1}, {"threads": 2, "chunk": 5000}):
        route, got = table(p, **kw)
        assert route == "mapped", kw
        assert set(got) == set(want) and all(_same(got[k], want[k]) for k in want if want[k].dtype.kind in "fiu"), kw


# ------------------------------------------------------------------ fuzz

N_FUZZ = 120


def test_fuzzed_mutants_agree(tmp_path, monkeypatch):
    src = tmp_path / "src"
    src.mkdir()
    sig = {k: v[:40] for k, v in _signals(40, 4).items()}
    base = src / "base.tdms"
    save_tdms(base, sig, 1000.0, {"fy": "N", "fz": "N"}, segment_samples=16)
    raw = {k: (v * 1000).astype(np.int16) for k, v in sig.items()}
    daq = src / "daq.tdms"
    write_daqmx_tdms(
        str(daq), raw, 1000.0, {"fy": [("Linear", (0.001, 0.0))], "fz": [("Linear", (0.001, 0.0))]}, segment_samples=16
    )
    inter = [p for p in _hand_files(src) if p.name == "inter_le.tdms"][0]
    rng = random.Random(20261122)
    outcomes: Dict[str, int] = {}
    failures = []
    for original in (base, daq, inter):
        data = original.read_bytes()
        for i in range(N_FUZZ):
            what, mutant = mutate(data, rng, ("truncate", "flip", "flip", "insert", "delete"))
            p = tmp_path / f"m_{original.stem}_{i}.tdms"
            p.write_bytes(mutant)
            try:
                out = compare(p, monkeypatch, expect_native=None)
            except AssertionError as exc:
                failures.append(f"{original.name} {what}: {str(exc)[:400]}")
                continue
            outcomes[out] = outcomes.get(out, 0) + 1
            p.unlink()
    print(outcomes)
    assert not failures, "\n".join(failures)
    assert outcomes.get("refused", 0) > 0 and outcomes.get("read", 0) > 0


@pytest.mark.fast
def test_index_file_is_used_when_it_matches(tmp_path, monkeypatch):
    from nptdms import ChannelObject, TdmsWriter

    sig = _signals(3000, 6)
    p = tmp_path / "with_index.tdms"
    with TdmsWriter(str(p), index_file=True) as w:
        for a in range(0, 3000, 500):
            w.write_segment(
                [
                    ChannelObject("g", k, v[a : a + 500], {"wf_increment": 0.001} if a == 0 else {})
                    for k, v in sig.items()
                ]
            )
    idx = Path(str(p) + "_index")
    assert idx.exists()
    assert compare(p, monkeypatch) == "read"
    monkeypatch.setattr(T, "_NATIVE", True)
    with open_recording(p) as rec:
        assert not [w for w in rec.warnings if "tdms_index" in w], rec.warnings
        want = rec.read(rec.channel_names)
    # a stale index (of another file): ignored, said, and the data file's own metadata read
    q = tmp_path / "other.tdms"
    with TdmsWriter(str(q), index_file=True) as w:
        w.write_segment([ChannelObject("g", k, v[:700], {"wf_increment": 0.001}) for k, v in sig.items()])
    idx.write_bytes(Path(str(q) + "_index").read_bytes())
    with open_recording(p) as rec:
        assert any(".tdms_index file was not used" in w for w in rec.warnings), rec.warnings
        got = rec.read(rec.channel_names)
    assert all(_same(got[k], want[k]) for k in want)


@pytest.mark.fast
def test_segments_walked_by_their_heads(tmp_path, monkeypatch):
    """Segments of 4 KiB or more are walked by reading their heads only (issue 38): metadata longer than the
    head read (many channels with long names, properties changing from segment to segment) and segments of
    changing lengths still read as npTDMS reads them."""
    from nptdms import ChannelObject, TdmsWriter

    rng = np.random.default_rng(38)
    p = tmp_path / "heads.tdms"
    names = ["fy", "fz"] + [f"channel_with_a_rather_long_name_{k:02d}" for k in range(10)]
    with TdmsWriter(str(p)) as w:
        for seg, n in enumerate((600, 600, 900, 600, 5000, 600)):
            props = {"wf_increment": 0.001, "unit_string": "N", "note": f"segment {seg} " + "x" * 40 * seg}
            w.write_segment([ChannelObject("g", c, rng.normal(size=n), properties=props) for c in names])
    assert compare(p, monkeypatch) == "read"
    base = tmp_path / "heads_save.tdms"
    sig = {"fy": rng.normal(size=20_000), "fz": 10 + rng.normal(size=20_000)}
    save_tdms(base, sig, 1000.0, {"fy": "N", "fz": "N"}, segment_samples=300)  # 4.8 KiB segments
    assert compare(base, monkeypatch) == "read"
