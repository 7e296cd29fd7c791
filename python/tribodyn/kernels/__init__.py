"""Numerics: the Rust kernels' wrappers, their NumPy twin and the shared statistics (docs/architecture.md).

The lowest layer of the package: it imports only ``tribodyn._core`` and the vocabulary at the root
(``options``, ``columns``), never ``io``, ``pipeline``, ``analyses`` or ``app``.
"""

from .._lazy import submodules

__getattr__ = submodules(__name__)
