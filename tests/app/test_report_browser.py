"""The report in a real browser: headless Chromium loads it, logs no console error, shows its figures,
and a screenshot is not blank. Skips (with the reason printed) only when no Chromium can be found."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

SHOTS = Path(os.environ.get("TRIBODYN_SCREENSHOTS", "/tmp/tribodyn-screenshots"))


def _chromium() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome", "chrome"):
        path = shutil.which(name)
        if path:
            return path
    print("no Chromium on PATH (.ci/run installs Debian's chromium)")
    pytest.skip("no Chromium on PATH")


def _browse(html: Path, shot: Path) -> tuple:
    exe = _chromium()
    common = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--allow-file-access-from-files",
              "--virtual-time-budget=8000", "--enable-logging=stderr", "--v=0"]  # fmt: skip
    shot.parent.mkdir(parents=True, exist_ok=True)
    r1 = subprocess.run([*common, f"--screenshot={shot}", "--window-size=1280,2000", html.as_uri()],
                        capture_output=True, text=True, timeout=180)  # fmt: skip
    r2 = subprocess.run([*common, "--dump-dom", html.as_uri()], capture_output=True, text=True, timeout=180)
    return r1.stderr + r2.stderr, r2.stdout


def _console_errors(log: str) -> list:
    return [ln for ln in log.splitlines() if "CONSOLE" in ln and ("Uncaught" in ln or "Error" in ln)]


def _not_blank(png: Path) -> float:
    from matplotlib.image import imread

    img = imread(str(png))[..., :3]
    return float(np.std(img))


def _check(out: Path, name: str) -> None:
    html = out / "report.html"
    log, dom = _browse(html, SHOTS / f"{name}.png")
    assert not _console_errors(log), _console_errors(log)
    assert "Verdict" in dom and dom.count("data:image/png;base64,") >= 6
    assert re.search(r'class="[^"]*bk', dom) or "data-root-id" in dom  # Bokeh rendered its view
    assert (SHOTS / f"{name}.png").is_file() and _not_blank(SHOTS / f"{name}.png") > 0.02
    print(f"screenshot: {SHOTS / f'{name}.png'}")


def test_analyze_report_in_chromium(cd_cli_run):
    _chromium()
    out = cd_cli_run[1]  # simulate current_density, analyze --area 1 (conftest.py)
    page = (out / "report.html").read_text(encoding="utf-8")
    for fig in ("fig02_forces_representative", "fig02_forces_worst", "fig03-05_correlations", "fig06-08_phase_plots",
                "fig09_cof_vs_normal_force", "fig12_cof_current_density_vs_time"):  # fmt: skip
        assert fig in page and any(p.name.startswith(fig) for p in (out / "figures").iterdir()), fig
    assert "representative gated window" in page and "worst failing window" in page
    assert "95 % interval" in page and "SHA-256" in page and "Parameters (with units)" in page
    _check(out, "analyze")


def test_demo_report_in_chromium(demo_run):
    _chromium()
    _check(demo_run[0], "demo")  # the session's demo (conftest.py)
