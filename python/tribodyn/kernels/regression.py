"""Closed-form, numerically stable, mergeable least squares, Eqs. (6)-(8)
(docs/method.md section 3).

Ordinary least squares of y on x (in tribodyn: fy on fz): y = slope x +
intercept. The Rust kernel accumulates centred moments (n, means, S_xx,
S_yy, S_xy) and the residual sum of squares block by block and merges them
pairwise (Chan, Golub and LeVeque), so adding a constant to x or y changes
nothing and r near 1 loses no digits. ``LinFitAccumulator`` exposes that
accumulator: ``update`` chunk by chunk, ``merge`` partial results, and
``result`` at any time; any split gives the one-shot fit to 1e-12 relative.

Note: Eq. (8) of the paper as printed equals MINUS the least-squares slope,
i.e. the paper's orientation s = -1. tribodyn reports the plain slope here;
the COF is mu_r = s * slope (see :func:`tribodyn.identify`).
"""

from __future__ import annotations

import math
import threading
import warnings
from typing import Any, NamedTuple

import numpy as np

from .. import _core
from ._validate import as_signal, same_length

__all__ = ["LinFit", "LinFitAccumulator", "linfit", "DegenerateInputWarning"]


class DegenerateInputWarning(RuntimeWarning):
    """A fit is undefined (n < 3 or zero variance of x): its fields are NaN."""


class LinFit(NamedTuple):
    """Least-squares line y = slope * x + intercept (Eqs. 6-8).

    Attributes
    ----------
    slope, intercept : float
        The line. For fy on fz, ``intercept`` is F_y0 of the paper.
    r : float
        Pearson's correlation of x and y (NaN if y is constant).
    slope_stderr, intercept_stderr : float
        Standard errors under the usual OLS assumptions (n - 2 dof).
    resid_std : float
        Residual standard deviation sqrt(SSE / (n - 2)).
    n : int
        Number of samples.

    Degenerate input (n < 3 or zero variance of x) gives NaN in every float
    field and a :class:`DegenerateInputWarning`.
    """

    slope: float
    intercept: float
    r: float
    slope_stderr: float
    intercept_stderr: float
    resid_std: float
    n: int

    @property
    def degenerate(self) -> bool:
        """True when the fit is undefined (NaN fields)."""
        return bool(np.isnan(self.slope))


def _result(t: tuple[Any, ...], stacklevel: int = 3) -> LinFit:
    slope, intercept, r, se_s, se_i, rs, n, degenerate = t
    if degenerate:
        warnings.warn(
            f"linfit is undefined for n = {n} samples or zero variance of x: NaN result",
            DegenerateInputWarning,
            stacklevel=stacklevel,
        )
    return LinFit(slope, intercept, r, se_s, se_i, rs, int(n))


def _pair(x: Any, y: Any, check_finite: bool, min_len: int) -> tuple[np.ndarray, np.ndarray]:
    xa = as_signal(x, "x", min_len=min_len, check_finite=check_finite)
    ya = as_signal(y, "y", min_len=min_len, check_finite=check_finite)
    same_length(x=xa, y=ya)
    return xa, ya


def linfit(x: Any, y: Any, *, check_finite: bool = True) -> LinFit:
    """Ordinary least squares of ``y`` on ``x`` (Eqs. 6-8, docs/method.md 3).

    Parameters
    ----------
    x, y : array_like, 1-D, equal length
        Regressor (fz) and response (fy); converted to float64.
    check_finite : bool
        Refuse NaN and inf (default).

    Returns
    -------
    LinFit
        NaN fields plus a :class:`DegenerateInputWarning` for n < 3 or
        constant x (not an exception, so one bad window never stops a long
        analysis).

    Raises
    ------
    ValueError
        Unequal lengths, empty input, wrong ndim, NaN/inf.
    TypeError
        Non-numeric input.
    """
    try:
        xa, ya = _pair(x, y, False, 1)
    except (TypeError, ValueError):
        _pair(x, y, check_finite, 1)  # the same error, found in the same order as elsewhere
        raise
    t = _core.linfit(xa, ya)
    if check_finite and not _proves_finite(t):
        as_signal(xa, "x", check_finite=True)
        as_signal(ya, "y", check_finite=True)
    return _result(t)


def _proves_finite(t: tuple[Any, ...]) -> bool:
    """Whether a fit shows that its inputs were finite, sparing the check a pass.

    A NaN or inf anywhere in x or y makes that block's mean NaN, and NaN
    survives every merge, so a non-degenerate fit with finite fields (the
    intercept uses both means) comes from finite inputs. Otherwise (also on
    overflow) the inputs are checked as usual.
    """
    return not t[7] and all(math.isfinite(v) for v in t[:6])


class LinFitAccumulator:
    """Mergeable accumulator of the least-squares fit (docs/method.md 3).

    Examples
    --------
    >>> acc = LinFitAccumulator()
    >>> for fz_chunk, fy_chunk in chunks:
    ...     acc.update(fz_chunk, fy_chunk)
    >>> acc.result().slope

    One accumulator may be shared by threads: its calls take a lock (the
    kernel of an update still runs without the GIL), so concurrent updates
    are applied one after the other, in some order (the result does not
    depend on it, to rounding).
    """

    def __init__(self) -> None:
        self._m = _core.Moments()
        self._lock = threading.Lock()

    def update(self, x: Any, y: Any, *, check_finite: bool = True) -> "LinFitAccumulator":
        """Adds a chunk of samples (empty chunks are allowed); returns self."""
        xa, ya = _pair(x, y, check_finite, 0)
        with self._lock:
            self._m.update(xa, ya)
        return self

    def merge(self, other: "LinFitAccumulator") -> "LinFitAccumulator":
        """A new accumulator holding the samples of both."""
        if not isinstance(other, LinFitAccumulator):
            raise TypeError(f"other must be a LinFitAccumulator, got {type(other).__name__}")
        out = LinFitAccumulator()
        with self._lock:
            mine = _core.Moments.from_state(self._m.state())
        with other._lock:
            out._m = mine.merge(other._m)
        return out

    def result(self) -> LinFit:
        """The fit of everything accumulated so far."""
        with self._lock:
            return _result(self._m.fit())

    @property
    def n(self) -> int:
        """Samples accumulated so far."""
        with self._lock:
            return int(self._m.state()[0])

    def __getstate__(self) -> tuple[Any, ...]:
        with self._lock:
            return self._m.state()

    def __setstate__(self, state: tuple[Any, ...]) -> None:
        self._m = _core.Moments.from_state(state)
        self._lock = threading.Lock()

    def __repr__(self) -> str:
        return f"LinFitAccumulator(n={self.n})"
