"""Every public exception and warning of tribodyn, in one namespace (docs/architecture.md).

* :class:`RecordingError` (a ``ValueError``): a file or source that cannot be read as a recording.
* :class:`NonFiniteError` (a ``ValueError``): a NaN or inf inside a window, named by role, window and
  time (raised by the Rust kernels, docs/method.md 4).
* :class:`OutputError` (a ``ValueError``): an output folder that cannot take the output set.
* :class:`ConstantInputWarning`, :class:`DegenerateInputWarning` (``RuntimeWarning``): a constant or
  degenerate input whose result is a documented NaN (docs/method.md 2, 3).
* :class:`TribodynDeprecationWarning` (a ``DeprecationWarning``): an old name or form that still works; every
  deprecation of tribodyn's warns with it (``tribodyn._deprecation.deprecated``).

Every other error is a plain ``ValueError`` (a bad value) or ``TypeError`` (a bad type), with a message
that names the option or the channel.
"""

from ._core import NonFiniteError
from ._deprecation import TribodynDeprecationWarning
from .io.base import RecordingError
from .kernels.correlation import ConstantInputWarning
from .kernels.regression import DegenerateInputWarning

__all__ = [
    "ConstantInputWarning",
    "DegenerateInputWarning",
    "NonFiniteError",
    "OutputError",
    "RecordingError",
    "TribodynDeprecationWarning",
]


class OutputError(ValueError):
    """The output folder cannot take the output set (a file, a link, holds other files...)."""
