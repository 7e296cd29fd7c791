"""The package as a user installs it: metadata, licence, changelog, abi3 wheel, import time, python -m."""

from __future__ import annotations

import glob
import os
import statistics
import subprocess
import sys
from pathlib import Path

import pytest

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parent.parent
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
#: Where a built wheel may be (``maturin build -o DIR``); the wheel-tag test skips without one.
WHEEL_DIR = os.environ.get("TRIBODYN_WHEEL_DIR", "/tmp/wheels")


def test_metadata_licence_and_changelog():
    project = PYPROJECT["project"]
    assert (ROOT / "LICENSE").read_text(encoding="utf-8").startswith("MIT License")
    assert project["authors"] and project["urls"]
    classifiers = project["classifiers"]
    assert "License :: OSI Approved :: MIT License" in classifiers
    assert any(c.startswith("Programming Language :: Python :: 3.9") for c in classifiers)
    changelog = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    assert f"## {project['version']}" in changelog
    assert "pandas" in " ".join(project["dependencies"]) and "bokeh" in " ".join(project["dependencies"])


def test_abi3_feature_configured():
    features = PYPROJECT["tool"]["maturin"]["features"]
    assert "pyo3/abi3-py39" in features, features


def test_built_wheel_is_abi3():
    wheels = sorted(glob.glob(os.path.join(WHEEL_DIR, "tribodyn-*.whl")))
    if not wheels:
        print(f"no wheel in {WHEEL_DIR} (build one: maturin build --release -o {WHEEL_DIR})")
        pytest.skip(f"no built wheel in {WHEEL_DIR}")
    tag = Path(wheels[-1]).name.split("-")[2:4]
    assert tag == ["cp39", "abi3"], wheels[-1]


def test_readme_states_the_rust_minimum():
    cargo = tomllib.loads((ROOT / "Cargo.toml").read_text(encoding="utf-8"))
    minimum = cargo["workspace"]["package"]["rust-version"]
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert f"{minimum} or newer" in readme and "cargo" in readme


def test_import_is_fast_and_lazy():
    code = (
        "import time, sys; t = time.perf_counter(); import tribodyn; d = time.perf_counter() - t; "
        "heavy = sorted({m.split('.')[0] for m in sys.modules} & {'scipy', 'matplotlib', 'pandas', 'bokeh'}); "
        "print(d, ','.join(heavy))"
    )
    times = []
    for _ in range(5):
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
        times.append(float(out[0]))
        assert len(out) == 1, f"import tribodyn imported {out[1]}"
    median = statistics.median(times)
    # The time is printed, not asserted: speed targets live in benches/ (shared, noisy machines).
    print(f"import tribodyn: median {median:.3f} s of {[round(t, 3) for t in times]}")


def test_python_m_tribodyn_help():
    r = subprocess.run([sys.executable, "-m", "tribodyn", "--help"], capture_output=True, text=True)
    assert r.returncode == 0 and "usage: tribodyn" in r.stdout and "--quiet" in r.stdout
