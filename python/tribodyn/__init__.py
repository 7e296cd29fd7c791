"""tribodyn: the coefficient of friction of a sliding contact from measured
dynamic forces.

The method (the paper's, made precise) is in docs/method.md; every public function
cites its section. Kernels run in Rust (``tribodyn._core``); a pure-NumPy
reference of each is in :mod:`tribodyn.reference`.

The namespace holds what ``__all__`` lists (and ``dir(tribodyn)`` shows
exactly that, with the module's dunder attributes). Names are imported on
first use (PEP 562), so ``import tribodyn`` stays light; submodules
(``tribodyn.simulate``, ``tribodyn.io``, ``tribodyn.reference``,
``tribodyn.results``, ...) are reached as attributes or imported as usual.
How the modules fit together: docs/architecture.md.
"""

# No `from __future__ import annotations` here: it would bind `annotations` in the namespace.
import importlib as _importlib
import typing as _typing

# analyze, identify and compare share their names with their modules: loading a submodule
# sets the package's attribute of that name, so the functions are bound first.
from .analyze import analyze
from .compare import compare
from .identify import identify

#: Public name -> the module (relative) it comes from, imported on first use.
_LAZY = {
    "xcorr": "correlation",
    "XcorrResult": "correlation",
    "pearson": "correlation",
    "ConstantInputWarning": "correlation",
    "HighPass": "filters",
    "highpass": "filters",
    "butter_highpass": "filters",
    "linfit": "regression",
    "LinFit": "regression",
    "LinFitAccumulator": "regression",
    "DegenerateInputWarning": "regression",
    "set_threads": "threads",
    "get_threads": "threads",
    "max_threads": "threads",
    "CofResult": "results",
    "BinTable": "results",
    "Results": "results",
    "WINDOW_COLUMNS": "results",
    "operating_range": "ranges",
    "OperatingRange": "ranges",
    "RangeCurve": "ranges",
    "BranchFit": "ranges",
    "Hysteresis": "ranges",
    "align_log": "covariates",
    "Deadband": "deadband",
    "parse_deadband": "deadband",
    "open_recording": "io",
    "Recording": "io",
    "RecordingError": "io",
    "analyze_many": "distributed",
    "ManyResults": "distributed",
    "Comparison": "compare",
    "Precision": "compare",
    "Replicate": "compare",
    "stick_slip": "stickslip",
    "StickSlip": "stickslip",
    "steady_state": "steady",
    "SteadyState": "steady",
    "Plan": "plan",
    "make_plan": "plan",
}

__all__ = [
    "__version__",
    "xcorr",
    "XcorrResult",
    "pearson",
    "ConstantInputWarning",
    "HighPass",
    "highpass",
    "butter_highpass",
    "linfit",
    "LinFit",
    "LinFitAccumulator",
    "DegenerateInputWarning",
    "set_threads",
    "get_threads",
    "max_threads",
    "columns",
    "identify",
    "CofResult",
    "BinTable",
    "analyze",
    "Plan",
    "make_plan",
    "Results",
    "WINDOW_COLUMNS",
    "operating_range",
    "OperatingRange",
    "RangeCurve",
    "BranchFit",
    "Hysteresis",
    "align_log",
    "Deadband",
    "parse_deadband",
    "open_recording",
    "Recording",
    "RecordingError",
    "analyze_many",
    "ManyResults",
    "compare",
    "Comparison",
    "Precision",
    "Replicate",
    "stick_slip",
    "StickSlip",
    "steady_state",
    "SteadyState",
]

if _typing.TYPE_CHECKING:  # what the lazy names are, for type checkers
    from . import columns
    from .compare import Comparison, Precision, Replicate
    from .correlation import ConstantInputWarning, XcorrResult, pearson, xcorr
    from .covariates import align_log
    from .deadband import Deadband, parse_deadband
    from .distributed import ManyResults, analyze_many
    from .filters import HighPass, butter_highpass, highpass
    from .io import Recording, RecordingError, open_recording
    from .plan import Plan, make_plan
    from .ranges import BranchFit, Hysteresis, OperatingRange, RangeCurve, operating_range
    from .regression import DegenerateInputWarning, LinFit, LinFitAccumulator, linfit
    from .steady import SteadyState, steady_state
    from .stickslip import StickSlip, stick_slip
    from .results import WINDOW_COLUMNS, BinTable, CofResult, Results
    from .threads import get_threads, max_threads, set_threads

    __version__: str


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("tribodyn")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "0+unknown"


if not _typing.TYPE_CHECKING:  # type checkers see the imports above, and no catch-all

    def __getattr__(name: str) -> object:
        """A public name (imported on first use and kept), or a submodule (``tribodyn.simulate``, ...)."""
        if name in _LAZY:
            value = getattr(_importlib.import_module(f".{_LAZY[name]}", __name__), name)
        elif name == "__version__":
            value = _version()
        elif name.isidentifier() and not name.startswith("__"):
            try:
                return _importlib.import_module(f".{name}", __name__)
            except ModuleNotFoundError as exc:
                if exc.name != f"{__name__}.{name}":
                    raise  # the submodule exists but needs something missing
                raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
        else:
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
        globals()[name] = value
        return value


def __dir__() -> "list[str]":
    """``__all__`` and the module's dunder attributes: nothing internal."""
    return sorted(set(__all__) | {k for k in globals() if k.startswith("__") and k.endswith("__")})
