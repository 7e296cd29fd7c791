"""Reader plugins (issue 34, item 8): the worked example of docs/architecture.md, installed as a package in
the test run (a module and its ``.dist-info`` with the entry point, on ``sys.path``), reads a file that
then gets tribodyn's roles, unit conversion, checks and outputs; a broken plugin is not used and says
why."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tribodyn.io import RecordingError, detect_format, open_recording, plugins
from _paths import REPO

ROOT = REPO
PAGE = ROOT / "docs" / "architecture.md"


def _page_blocks() -> tuple:
    """The worked example's pyproject.toml and module, as the page shows them."""
    text = PAGE.read_text(encoding="utf-8")
    part = text[text.index("## Reader plugins") :]
    toml = re.search(r"```toml\n(.*?)```", part, re.S)
    code = re.search(r"```python\n(.*?)```", part, re.S)
    assert toml and code
    return toml.group(1), code.group(1)


def _install(site: Path, name: str, module: str, code: str, entry_points: str) -> None:
    """A package as pip leaves it: the module and a .dist-info holding its entry points."""
    (site / f"{module}.py").write_text(code, encoding="utf-8")
    info = site / f"{name.replace('-', '_')}-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(entry_points)


@pytest.fixture
def site(tmp_path, monkeypatch):
    """A site directory with the page's acme-tribo package installed, on sys.path; plugins looked for anew."""
    toml, code = _page_blocks()
    m = re.search(r'\[project.entry-points."tribodyn.readers"\]\n(\w+) = "([\w:.]+)"', toml)
    assert m, toml
    d = tmp_path / "site"
    d.mkdir()
    _install(d, "acme-tribo", "acme_tribo", code, f"[tribodyn.readers]\n{m.group(1)} = {m.group(2)}\n")
    monkeypatch.syspath_prepend(str(d))
    plugins.reload()
    yield d
    sys.modules.pop("acme_tribo", None)
    plugins.reload()


def _acme(path: Path, n: int = 3000, rate: float = 200.0, mu: float = 0.25) -> Path:
    rng = np.random.default_rng(3)
    fz = 12.0 + 0.2 * rng.standard_normal(n)
    fy_mn = 1e3 * (mu * fz + 0.02 * rng.standard_normal(n))
    rows = "".join(f"{a:.3f}\t{b:.5f}\n" for a, b in zip(fy_mn, fz))
    path.write_text(f"ACME-TRIBO 1\nrate {rate:g}\nFriction force [mN]\tNormal force [N]\n" + rows)
    return path


@pytest.mark.fast
def test_the_plugin_reads_its_files_with_tribodyns_roles_and_units(site, tmp_path):
    p = _acme(tmp_path / "run.acme")
    assert "acme" in plugins.plugins() and plugins.plugin_errors() == {}
    assert detect_format(p) == "acme"
    with open_recording(p) as rec:
        assert rec.format == "acme" and rec.fs == 200.0
        assert rec.roles == {"fy": "Friction force", "fz": "Normal force"}
        info = {c.name: c for c in rec.channels}
        assert info["Friction force"].unit == "N" and info["Friction force"].scale == 1e-3
        got = rec.read(["fy", "fz"])
    raw = np.loadtxt(p, skiprows=3, delimiter="\t")
    assert np.allclose(got["fy"], raw[:, 0] * 1e-3, rtol=1e-15) and np.array_equal(got["fz"], raw[:, 1])
    q = tmp_path / "run.unknown-ext"  # no extension it claims: its sniff recognises the content
    q.write_bytes(p.read_bytes())
    assert detect_format(q) == "acme"
    with open_recording(q, channels={"fy": "Normal force", "fz": "Friction force"}) as rec:  # a map, as always
        assert rec.roles["fy"] == "Normal force"
    c = tmp_path / "run.csv"  # tribodyn's own extensions stay its own
    c.write_bytes(p.read_bytes())
    assert detect_format(c) == "delimited"
    with open_recording(c, format="acme") as rec:
        assert rec.format == "acme"


def test_the_command_line_analyses_a_plugins_file(site, tmp_path):
    p = _acme(tmp_path / "run.acme")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(site), *sys.path]))
    r = subprocess.run(
        [sys.executable, "-m", "tribodyn", "analyze", str(p), "--out", str(tmp_path / "o")],
        capture_output=True, text=True, timeout=300, env=env,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    head = json.loads((tmp_path / "o" / "summary.json").read_text())["recordings"]["run.acme"]["headline"]
    assert r.stdout.startswith(f"run.acme: {head['text']}") and abs(head["value"] - 0.25) < 0.005


@pytest.mark.fast
def test_a_broken_plugin_is_not_used_and_says_why(tmp_path, monkeypatch):
    d = tmp_path / "site"
    d.mkdir()
    _install(d, "broken-reader", "broken_reader", "raise ImportError('needs libacme')\n",
             "[tribodyn.readers]\nbroken = broken_reader:Reader\n")  # fmt: skip
    _install(d, "greedy-reader", "greedy_reader",
             "from tribodyn.io.tables import TableRecording\n\nclass R(TableRecording):\n    format = 'npz'\n",
             "[tribodyn.readers]\ngreedy = greedy_reader:R\n")  # fmt: skip
    monkeypatch.syspath_prepend(str(d))
    plugins.reload()
    try:
        errors = plugins.plugin_errors()
        assert "cannot be loaded: ImportError: needs libacme" in errors["broken"]
        assert "format 'npz' is one of tribodyn's own" in errors["greedy"]
        assert plugins.plugins() == {}
        p = _acme(tmp_path / "run.acme")
        with pytest.raises(RecordingError, match=r"unknown format 'broken'.*reader plugin 'broken'.*libacme"):
            open_recording(p, format="broken")
        with open_recording(tmp_path / "run.acme", fs=1.0) as rec:  # text: read as delimited, as without plugins
            assert rec.format == "delimited"
    finally:
        for m in ("broken_reader", "greedy_reader"):
            sys.modules.pop(m, None)
        plugins.reload()
