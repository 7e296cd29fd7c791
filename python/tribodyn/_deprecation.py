"""The one way tribodyn deprecates a name or a form (docs/architecture.md, "Names").

:func:`deprecated` warns with :class:`TribodynDeprecationWarning`, a ``DeprecationWarning`` of tribodyn's own:
a user filters it apart from other libraries' (``warnings.simplefilter("error",
tribodyn.errors.TribodynDeprecationWarning)``), and the test suite turns it into an error
(``pyproject.toml``, ``filterwarnings``) so that the project itself never calls an old form unawares.
It sits at the root with the vocabulary so that every layer can use it.
"""

from __future__ import annotations

import warnings

__all__ = ["TribodynDeprecationWarning", "deprecated"]


class TribodynDeprecationWarning(DeprecationWarning):
    """An old name or form of tribodyn's that still works; the message names the new one."""


def deprecated(message: str, *, stacklevel: int = 2) -> None:
    """Warns ``message`` as a :class:`TribodynDeprecationWarning` (``stacklevel`` as for ``warnings.warn``, counted
    from the caller of this function)."""
    warnings.warn(message, TribodynDeprecationWarning, stacklevel=stacklevel + 1)
