"""tribodyn: the coefficient of friction of a sliding contact from measured
dynamic forces.

The method (the paper's, made precise) is in docs/method.md; every public function
cites its section. Kernels run in Rust (``tribodyn._core``); a pure-NumPy
reference of each is in :mod:`tribodyn.reference`.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version as _version

from .threads import get_threads, max_threads, set_threads
from . import columns
from .correlation import ConstantInputWarning, XcorrResult, pearson, xcorr
from .filters import HighPass, butter_highpass, highpass
from .regression import DegenerateInputWarning, LinFit, LinFitAccumulator, linfit
from .deadband import Deadband, parse_deadband
from .results import WINDOW_COLUMNS, BinTable, CofResult, Results
from .identify import identify
from .analyze import analyze
from .ranges import BranchFit, Hysteresis, OperatingRange, RangeCurve, operating_range
from .covariates import align_log
from .io import Recording, RecordingError, open_recording
from .distributed import ManyResults, analyze_many
from .compare import Comparison, Precision, Replicate, compare
from .stickslip import StickSlip, stick_slip
from .steady import SteadyState, steady_state

try:
    __version__ = _version("tribodyn")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0+unknown"

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
