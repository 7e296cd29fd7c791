"""Every command of docs/tribometer-exports.md runs and prints the headline the page states (issue 21)."""

from __future__ import annotations

import json
import re
import shlex
from pathlib import Path
from typing import Callable, Dict, List, Tuple

import numpy as np
import pytest
from tribodyn.app.cli import main
from tribodyn.io.writers import save_tdms
from _paths import REPO

ROOT = REPO
REAL = ROOT / "tests" / "data" / "real"
PAGE = ROOT / "docs" / "tribometer-exports.md"


def _rows() -> List[Tuple[List[str], str]]:
    """(command as argv, the headline column or '') of every table row naming a `tribodyn analyze` command."""
    out = []
    for line in PAGE.read_text(encoding="utf-8").splitlines():
        m = re.match(r"\|[^|]*\| `(tribodyn analyze [^`]*)`[^|]*\|(?: ([^|]*)\|)?\s*$", line)
        if m:
            out.append((shlex.split(m.group(1))[1:], (m.group(2) or "").strip()))
    return out


ROWS = _rows()


def _dead_weight(n: int = 3000, fs: float = 100.0, mu: float = 0.2, jitter: float = 0.0):
    rng = np.random.default_rng(11)
    t = np.arange(n) / fs + (jitter / fs) * rng.uniform(-1, 1, n)
    fz = 10.0 + 0.01 * rng.standard_normal(n)
    fy = mu * fz + 0.005 * rng.standard_normal(n)
    return t, fy, fz


def _lvm(path: Path) -> None:
    t, fy, fz = _dead_weight()
    head = (
        "LabVIEW Measurement\t\nWriter_Version\t2\nReader_Version\t2\nSeparator\tTab\nDecimal_Separator\t.\n"
        "Multi_Headings\tNo\nX_Columns\tNo\nTime_Pref\tRelative\n***End_of_Header***\t\n\t\n"
        f"Channels\t2\t\nSamples\t{t.size}\t{t.size}\t\nY_Unit_Label\tN\tN\t\nX_Dimension\tTime\tTime\t\n"
        "X0\t0\t0\t\nDelta_X\t1.000000E-2\t1.000000E-2\t\n***End_of_Header***\t\t\t\nX_Value\tFt\tFn\tComment\n"
    )
    body = "".join(f"\t{a:.6f}\t{b:.6f}\n" for a, b in zip(fy, fz))
    path.write_text(head + body)


def _tdms(path: Path) -> None:
    _, fy, fz = _dead_weight()
    save_tdms(path, {"Ft": fy, "Fn": fz}, 100.0)


def _ni_pairs(path: Path) -> None:
    t, fy, fz = _dead_weight()
    rows = "".join(f"{a:.4f},{b:.6f},{a:.4f},{c:.6f}\n" for a, b, c in zip(t, fy, fz))
    path.write_text("Time,Friction Force,Time,Normal Force\n" + rows)


def _kyowa(path: Path) -> None:
    t, fy, fz = _dead_weight()
    rows = "".join(f"{a:.4f},{b:.6f},{c:.6f}\n" for a, b, c in zip(t, fy, fz))
    path.write_bytes(("測定器 PCD-400A\n時間,摩擦力,荷重\ns,N,N\n" + rows).encode("cp932"))


def _jittery(path: Path) -> None:
    t, fy, fz = _dead_weight(jitter=0.3, fs=10.0, n=1200)
    path.write_text("t,Ft,Fn\n" + "".join(f"{a:.5f},{b:.6f},{c:.6f}\n" for a, b, c in zip(t, fy, fz)))


#: Files the page names that this repository does not hold: written here with the channel names shown.
GENERATED: Dict[str, Callable[[Path], None]] = {
    "run.lvm": _lvm,
    "run.tdms": _tdms,
    "export.csv": _ni_pairs,
    "DATA.CSV": _kyowa,
    "log.csv": _jittery,
}


def test_the_page_has_every_command():
    names = [argv[1] for argv, _ in ROWS]
    assert len(ROWS) >= 9 and set(GENERATED) <= set(names)
    assert all((REAL / n).exists() or n in GENERATED for n in names)


@pytest.mark.parametrize("argv,expected", ROWS, ids=[" ".join(r[0][1:2] + r[0][3:]) for r in ROWS])
def test_documented_command(tmp_path, capsys, argv, expected):
    name = argv[1]
    src = tmp_path / name
    if (REAL / name).exists():
        src.write_bytes((REAL / name).read_bytes())
    else:
        GENERATED[name](src)
    args = [argv[0], str(src), *[str(tmp_path / a) if argv[k - 1] == "--out" else a for k, a in enumerate(argv[2:], 2)]]
    assert main(args) == 0
    first = capsys.readouterr().out.splitlines()[0]
    out = tmp_path / argv[argv.index("--out") + 1]
    head = json.loads((out / "summary.json").read_text(encoding="utf-8"))["recordings"][name]["headline"]
    assert first == f"{name}: {head['text']}" and head["value"] is not None
    if expected:  # "classical, 0.728 ...": the method and the value to the digits the page gives
        m = re.match(r"([a-z-]+), ([0-9.]+)", expected)
        assert m, expected
        assert head["method"] == m.group(1)
        assert f"{head['value']:.{len(m.group(2).split('.')[1])}f}" == m.group(2)
    else:  # the generated dead-weight files: mu = 0.2
        assert head["method"] == "classical" and abs(head["value"] - 0.2) < 0.002
