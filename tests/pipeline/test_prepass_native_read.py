"""The pre-pass and the analysis of long ``.npy`` recordings are the same, bit for bit, whether the pre-pass
sample is read by the native multi-range read (``_core.pread_ranges``, issue 38 point 2) or by the Python read
it replaced (one ``os.preadv`` a range), on the simulators' recordings of every kind the pre-pass decides:
dynamic and raw forces, a tare, a reciprocating test with its position channel, a load step with lift-off."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Dict, List, Tuple

import numpy as np
import pytest
import tribodyn as td
from tribodyn import _core, simulate
from tribodyn.io.numpy_files import NpyRecording
from tribodyn.pipeline import prepass as P

FS = 1000.0


def _continuous(raw: bool, seed: int) -> np.ndarray:
    parts = list(simulate.continuous(100.0, chunk_s=50.0, current=None if raw else 3.0, seed=seed, raw=raw))
    keys = ("fx", "fy", "fz") if raw else ("fx", "fy", "fz", "i")
    return np.stack([np.concatenate([p[k] for p in parts]) for k in keys])


def _step() -> np.ndarray:
    # unloaded, loaded with friction reversing its sign, unloaded again: a tare and a reciprocating motion
    rng = np.random.default_rng(9)
    k = np.arange(120_000)
    fz = np.where((k > 20_000) & (k < 100_000), -20.0, 0.0) + 0.3 + rng.normal(0, 0.02, k.size)
    fy = np.where(fz < -5, 0.15 * -fz * np.sign(np.sin(k / 900.0)), 0.05) + rng.normal(0, 0.02, k.size)
    return np.stack([fy, fz])


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> Dict[str, Tuple[Path, List[str]]]:
    d = tmp_path_factory.mktemp("prepass_native")
    out: Dict[str, Tuple[Path, List[str]]] = {}
    cont = _continuous(False, 4)
    for name, arr in (("cont", cont), ("cont_f4", cont.astype(np.float32)), ("cont_be", cont.astype(">f8"))):
        np.save(d / f"{name}.npy", arr)
        out[name] = (d / f"{name}.npy", ["fx", "fy", "fz", "i"])
    np.save(d / "raw.npy", _continuous(True, 5))
    out["raw"] = (d / "raw.npy", ["fx", "fy", "fz"])
    sim = simulate.reciprocating(seed=3, cycles=140, offset=0.3)
    names = list(sim.channels)
    np.save(d / "recip.npy", np.stack([np.asarray(sim.channels[k], dtype=float) for k in names]))
    out["recip"] = (d / "recip.npy", names)
    np.save(d / "step.npy", _step())
    out["step"] = (d / "step.npy", ["fy", "fz"])
    return out


def _findings(path: Path, names: List[str], kw: Dict[str, Any]) -> Tuple[str, str, str]:
    motion = {"x": "x"} if "x" in names else None  # the position channel says the sliding direction
    with td.open_recording(path, fs=FS, names=names, channels=motion) as rec:
        assert isinstance(rec, NpyRecording) and rec.n_samples > 65536  # the sample is read in pieces
        pre = P.prepass(None, rec, FS, min_fn=kw.get("min_fn"), tare=kw.get("tare"), motion="auto")
        assert "motion_evidence" not in pre or ("position" in pre["motion_evidence"]) == (motion is not None)
        res = td.analyze(rec, **kw)
    table = {k: np.asarray(v) for k, v in res.table.items()}
    columns = {k: repr(list(v)) if v.dtype == object else v.tobytes().hex() for k, v in table.items()}
    as_text = lambda x: json.dumps(x, sort_keys=True, default=repr)  # noqa: E731
    return as_text(pre), as_text(res.params), as_text(columns)


CASES = [("cont", {}), ("cont", {"tare": 2.0}), ("cont_f4", {}), ("cont_be", {"min_fn": 1.0}), ("raw", {}),
         ("recip", {}), ("step", {}), ("step", {"tare": "start"})]  # fmt: skip


IDS = [f"{n}-{'-'.join(map(str, k.values())) or 'default'}" for n, k in CASES]


@pytest.mark.parametrize("name, kw", CASES, ids=IDS)
def test_prepass_and_analysis_equal_the_python_read(
    files: Dict[str, Tuple[Path, List[str]]], name: str, kw: Dict[str, Any], monkeypatch: pytest.MonkeyPatch
) -> None:
    path, names = files[name]
    native = _findings(path, names, kw)
    monkeypatch.delattr(_core, "pread_ranges")  # NpyRecording._read_ranges_python: one os.preadv a range
    assert _findings(path, names, kw) == native
