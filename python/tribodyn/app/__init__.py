"""The command line and what it writes: jobs, tables, summary.json, figures and the report
(docs/architecture.md). The top layer: nothing in the package imports it.
"""

from .._lazy import submodules

__getattr__ = submodules(__name__)
