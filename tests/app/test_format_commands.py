"""The one command of docs/tribometer-exports.md for each generated MAT-file, spreadsheet and multi-step
export (tests/data/formats) runs and prints the headline the page states (issue 34)."""

from __future__ import annotations

import json

import pytest

from tribodyn.app.cli import main
from _paths import REPO

ROOT = REPO
DATA = ROOT / "tests" / "data" / "formats"
PAGE = ROOT / "docs" / "tribometer-exports.md"

#: Each file, the flags of its one command beyond ``--out`` and the start of its headline.
COMMANDS = [
    ("matlab_v5_pin_on_disc.mat", [], "COF 0.1500 (95 % interval 0.1498 to 0.1501, statistical only): classical"),
    ("matlab_v4_block_on_ring.mat", [], "COF 0.3000 (95 % interval 0.2998 to 0.3002, statistical only): classical"),
    ("matlab_v73_struct.mat", [], "COF 0.4202 (95 % interval 0.4200 to 0.4203, statistical only): classical"),
    ("excel_reciprocating.xlsx", [], "COF 0.1099 (95 % interval 0.1097 to 0.1102, statistical only): per-stroke"),
    ("opendocument_pin_on_disc.ods", [], "COF 0.5532 (95 % interval 0.5439 to 0.5859, statistical only): dynamic"),
    ("multistep_traction.txt", [], "COF 0.06193 (95 % interval 0.06170 to 0.06216, statistical only): classical"),
    ("cof_only_pin_on_disc.csv", ["--load", "10"],
     "COF 0.3650 (95 % interval 0.3541 to 0.3760, statistical only): instrument"),
    ("load_step_reciprocating.csv", [], "COF 0.1100 (95 % interval 0.1100 to 0.1100, statistical only): per-stroke"),
    ("drag_rotational.csv", [], "COF 0.05992 (95 % interval 0.05989 to 0.05995, statistical only): classical"),
    ("gram_force_ball_on_disc.csv", [], "COF 0.2000 (95 % interval 0.1999 to 0.2001, statistical only): classical"),
]  # fmt: skip


def test_the_page_names_every_file_its_command_and_headline():
    page = PAGE.read_text(encoding="utf-8")
    for name, flags, headline in COMMANDS:
        row = next((ln for ln in page.splitlines() if f"`tests/data/formats/{name}`" in ln), "")
        assert f"`tribodyn analyze {' '.join([name, *flags])} --out " in row and headline in row, name
    assert sorted(p.name for p in DATA.iterdir() if p.is_file() and p.suffix != ".py") == sorted(c[0] for c in COMMANDS)


@pytest.mark.parametrize("name, flags, headline", COMMANDS, ids=[c[0] for c in COMMANDS])
def test_documented_command_gives_its_headline(tmp_path, capsys, name, flags, headline):
    out = tmp_path / "out"
    assert main(["analyze", str(DATA / name), "--out", str(out), *flags]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    head = json.loads((out / "summary.json").read_text(encoding="utf-8"))["recordings"][name]["headline"]
    assert first == f"{name}: {head['text']}" and first.startswith(f"{name}: {headline}"), first
