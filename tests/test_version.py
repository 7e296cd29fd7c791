"""The package's version, read from its dist-info without importlib.metadata (issue 38 point 3)."""

from __future__ import annotations

import sys
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import pytest

from tribodyn import _version


@pytest.mark.fast
def test_the_version_is_importlib_metadatas() -> None:
    try:
        want = version("tribodyn")
    except PackageNotFoundError:  # a source tree without an installed distribution
        want = "0+unknown"
    assert _version.version() == want


@pytest.mark.fast
def test_the_first_dist_info_on_the_path_gives_the_version(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    first, second = tmp_path / "a", tmp_path / "b"
    for root, v in ((first, "9.8.7"), (second, "1.0")):
        info = root / f"tribodyn-{v}.dist-info"
        info.mkdir(parents=True)
        (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: tribodyn\nVersion: {v}\n\nVersion: 0\n")
    (first / "tribodyn_extra-1.0.dist-info").mkdir()  # another distribution's folder is not taken
    monkeypatch.setattr(sys, "path", [str(tmp_path / "missing"), str(first), str(second)])
    assert _version._from_dist_info() == "9.8.7"
    monkeypatch.setattr(sys, "path", [str(second)])
    assert _version._from_dist_info() == "1.0"
    monkeypatch.setattr(sys, "path", [str(tmp_path / "missing")])
    assert _version._from_dist_info() is None  # (version() then asks importlib.metadata)
    (second / "tribodyn-1.0.dist-info" / "METADATA").write_text("Name: tribodyn\n\n")
    monkeypatch.setattr(sys, "path", [str(second), str(first)])
    assert _version._from_dist_info() is None  # the first distribution found decides, unreadable or not
