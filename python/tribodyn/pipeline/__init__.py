"""From an opened Recording to Results: the plan, the pre-pass, the routes, finishing and the headline
(docs/architecture.md). Imports ``io``, ``kernels``, ``results`` and the vocabulary, never ``analyses`` or ``app``.
"""

from .._lazy import submodules

__getattr__ = submodules(__name__)
