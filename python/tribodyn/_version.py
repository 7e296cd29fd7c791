"""The installed package's version (``tribodyn.__version__``), read once from its metadata."""

from __future__ import annotations

from functools import lru_cache

__all__ = ["version"]


@lru_cache(maxsize=1)
def version() -> str:
    """The version of the installed distribution ("0+unknown" when running from a source tree)."""
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as _dist_version

    try:
        return _dist_version("tribodyn")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "0+unknown"
