"""Submodules reached as attributes (``tribodyn.kernels.reference`` after ``import tribodyn``), PEP 562."""

from __future__ import annotations

import importlib
from types import ModuleType
from typing import Callable

__all__ = ["submodules"]


def submodules(package: str) -> Callable[[str], ModuleType]:
    """A module ``__getattr__`` for ``package`` that imports a submodule on first use (and only that)."""

    def __getattr__(name: str) -> ModuleType:
        if name.isidentifier() and not name.startswith("__"):
            try:
                return importlib.import_module(f"{package}.{name}")
            except ModuleNotFoundError as exc:
                if exc.name != f"{package}.{name}":
                    raise  # the submodule exists but needs something missing
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    return __getattr__
