"""tribodyn: the coefficient of friction of a sliding contact from measured
dynamic forces.

The method (the paper's, made precise) is in docs/method.md; every public function
cites its section. Kernels run in Rust (``tribodyn._core``); a pure-NumPy
reference of each is in :mod:`tribodyn.kernels.reference`.

The namespace holds what ``__all__`` lists (and ``dir(tribodyn)`` shows
exactly that, with the module's dunder attributes). Names are imported on
first use (PEP 562), so ``import tribodyn`` stays light; submodules
(``tribodyn.simulate``, ``tribodyn.io``, ``tribodyn.kernels.reference``,
``tribodyn.results``, ...) are reached as attributes or imported as usual.
How the modules fit together: docs/architecture.md.
"""

# No `from __future__ import annotations` here: it would bind `annotations` in the namespace.
import importlib as _importlib
import typing as _typing

#: Public name -> the module (relative) it comes from, imported on first use.
_LAZY = {
    "analyze": "pipeline.analyze",
    "identify": "pipeline.identify",
    "compare": "analyses.compare",
    "xcorr": "kernels.correlation",
    "XcorrResult": "kernels.correlation",
    "pearson": "kernels.correlation",
    "ConstantInputWarning": "kernels.correlation",
    "HighPass": "kernels.filters",
    "highpass": "kernels.filters",
    "butter_highpass": "kernels.filters",
    "linfit": "kernels.regression",
    "LinFit": "kernels.regression",
    "LinFitAccumulator": "kernels.regression",
    "DegenerateInputWarning": "kernels.regression",
    "set_threads": "kernels.threads",
    "get_threads": "kernels.threads",
    "max_threads": "kernels.threads",
    "CofResult": "results",
    "BinTable": "results",
    "Results": "results",
    "WINDOW_COLUMNS": "results",
    "operating_range": "analyses.ranges",
    "OperatingRange": "analyses.ranges",
    "RangeCurve": "analyses.ranges",
    "BranchFit": "analyses.ranges",
    "Hysteresis": "analyses.ranges",
    "align_log": "pipeline.covariates",
    "Deadband": "kernels.deadband",
    "parse_deadband": "kernels.deadband",
    "open_recording": "io",
    "Recording": "io",
    "RecordingError": "io",
    "analyze_many": "pipeline.distributed",
    "ManyResults": "pipeline.distributed",
    "Comparison": "analyses.compare",
    "Precision": "analyses.compare",
    "Replicate": "analyses.compare",
    "stick_slip": "analyses.stickslip",
    "cof_curve": "analyses.curve",
    "CofCurve": "analyses.curve",
    "watch": "pipeline.watch",
    "Watch": "pipeline.watch",
    "Trip": "pipeline.watch",
    "StickSlip": "analyses.stickslip",
    "steady_state": "analyses.steady",
    "steady_states": "analyses.steady",
    "SteadyState": "analyses.steady",
    "Plan": "pipeline.plan",
    "make_plan": "pipeline.plan",
    "Headline": "results",
    "NonFiniteError": "errors",
    "OutputError": "errors",
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
    "cof_curve",
    "CofCurve",
    "watch",
    "Watch",
    "Trip",
    "Headline",
    "NonFiniteError",
    "OutputError",
    "steady_state",
    "steady_states",
    "SteadyState",
]

if _typing.TYPE_CHECKING:  # what the lazy names are, for type checkers
    from .analyses.compare import compare
    from .pipeline.analyze import analyze
    from .pipeline.identify import identify
    from . import columns
    from .analyses.compare import Comparison, Precision, Replicate
    from .analyses.ranges import BranchFit, Hysteresis, OperatingRange, RangeCurve, operating_range
    from .analyses.curve import CofCurve, cof_curve
    from .analyses.steady import SteadyState, steady_state, steady_states
    from .io import Recording, RecordingError, open_recording
    from .kernels.correlation import ConstantInputWarning, XcorrResult, pearson, xcorr
    from .kernels.deadband import Deadband, parse_deadband
    from .kernels.filters import HighPass, butter_highpass, highpass
    from .kernels.regression import DegenerateInputWarning, LinFit, LinFitAccumulator, linfit
    from .kernels.threads import get_threads, max_threads, set_threads
    from .pipeline.covariates import align_log
    from .pipeline.distributed import ManyResults, analyze_many
    from .pipeline.plan import Plan, make_plan
    from .pipeline.watch import Trip, Watch, watch
    from .analyses.stickslip import StickSlip, stick_slip
    from .errors import NonFiniteError, OutputError
    from .results import WINDOW_COLUMNS, BinTable, CofResult, Headline, Results

    __version__: str


if not _typing.TYPE_CHECKING:  # type checkers see the imports above, and no catch-all

    def __getattr__(name: str) -> object:
        """A public name (imported on first use and kept), or a submodule (``tribodyn.simulate``, ...)."""
        if name in _LAZY:
            value = getattr(_importlib.import_module(f".{_LAZY[name]}", __name__), name)
        elif name == "__version__":
            from ._version import version  # (the submodule's name: no function of that name here)

            value = version()
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
