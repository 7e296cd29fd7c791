"""Old positional forms of keyword-only options, kept working with a DeprecationWarning.

tribodyn's functions take the data positionally and every option by keyword
(``highpass(x, fs=1000.0)``, ``identify(fy, fz, fx=fx, fs=fs)``), as
scipy.signal does. Calls written for 0.2 (``highpass(x, 1000.0)``) still
work through :func:`positional_options`, which names the replacement.
"""

from __future__ import annotations

from typing import Any, Dict, Sequence

from .._deprecation import deprecated

__all__ = ["positional_options"]


def positional_options(func: str, args: Sequence[Any], names: Sequence[str], given: Dict[str, Any]) -> Dict[str, Any]:
    """The options passed positionally in ``args``, by name (``names`` in order), with a DeprecationWarning.

    ``given`` holds the same options as passed by keyword (None when not);
    an option passed both ways, or more positionals than ``names``, is a
    TypeError like Python's own.
    """
    if len(args) > len(names):
        raise TypeError(
            f"{func}() takes at most {len(names)} option(s) positionally ({', '.join(names)}), got {len(args)}"
        )
    out = dict(zip(names, args))
    for name in out:
        if given.get(name) is not None:
            raise TypeError(f"{func}() got multiple values for argument {name!r}")
    shown = ", ".join(f"{k}=..." for k in out)
    deprecated(f"{func}(): pass {shown} by keyword; the positional form is deprecated and will be removed",
               stacklevel=3)  # fmt: skip
    return out
