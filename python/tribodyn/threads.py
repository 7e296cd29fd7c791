"""How many threads the Rust kernels use.

Kernels split work at fixed boundaries and combine it in a fixed order, so
results never depend on the thread count. The default is every core; the
``TRIBODYN_THREADS`` environment variable, ``analyze(threads=...)`` and
:func:`set_threads` limit it.
"""

from __future__ import annotations

from . import _core
from ._validate import check_int

__all__ = ["set_threads", "get_threads"]


def set_threads(n: int) -> None:
    """Sets the number of kernel threads for this process (0 = all cores).

    Raises ``TypeError`` for a non-integer and ``ValueError`` for n < 0.
    """
    _core.set_threads(check_int(n, "n", minimum=0))


def get_threads() -> int:
    """The number of threads the kernels use now."""
    return int(_core.get_threads())
