"""The installed package's version (``tribodyn.__version__``), read once from its metadata."""

from __future__ import annotations

import os
import sys
from functools import lru_cache
from typing import Optional

__all__ = ["version"]

_DIST = "tribodyn"


@lru_cache(maxsize=1)
def version() -> str:
    """The version of the installed distribution ("0+unknown" when running from a source tree).

    Read from the ``Version:`` line of the distribution's ``METADATA`` in the first ``tribodyn-*.dist-info``
    folder on ``sys.path`` (the one ``importlib.metadata`` finds first): about 1 ms, where importing
    ``importlib.metadata`` alone takes 15-20 ms of a command's start (issue 38 point 3). Anything unusual (no
    such folder, an egg, a zip) falls back to ``importlib.metadata``.
    """
    found = _from_dist_info()
    if found is not None:
        return found
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as _dist_version

    try:
        return _dist_version(_DIST)
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "0+unknown"


def _from_dist_info() -> Optional[str]:
    """The ``Version`` of the first ``tribodyn-*.dist-info/METADATA`` on ``sys.path``, or None."""
    for entry in sys.path:
        try:
            with os.scandir(entry or ".") as it:
                names = [e.name for e in it if e.name.endswith(".dist-info") and _named(e.name)]
        except OSError:
            continue
        for name in sorted(names):
            try:
                with open(os.path.join(entry or ".", name, "METADATA"), encoding="utf-8") as fh:
                    for line in fh:
                        if line.startswith("Version:"):
                            return line.split(":", 1)[1].strip() or None
                        if not line.strip():  # the end of the headers
                            break
            except OSError:
                pass
            return None  # that folder is the distribution's, however it reads: importlib.metadata decides
    return None


def _named(folder: str) -> bool:
    """Whether a ``NAME-VERSION.dist-info`` folder is this distribution's (the name normalised as PEP 503)."""
    return folder.partition("-")[0].replace("_", "-").replace(".", "-").lower() == _DIST
