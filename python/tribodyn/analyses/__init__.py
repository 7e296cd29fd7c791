"""What a lab reads from Results beyond the headline: operating ranges, steady state, stick-slip,
replicates (docs/architecture.md). Imports ``pipeline`` and the layers below it, never ``app``.
"""

from .._lazy import submodules

__getattr__ = submodules(__name__)
