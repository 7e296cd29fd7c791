"""Lagged correlation function, Eq. (1) of the paper (docs/method.md section 1).

``xcorr`` returns C(j) = S_xy(j) / sqrt(S_xx(j) S_yy(j)) for lags
j = -L..L, the inputs centred on the means of the WHOLE signals and each sum
taken over the overlap of x_i and y_{i+j}. If y is x delayed by d samples,
C peaks at j = +d. A zero denominator gives NaN (not an error).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any, Literal, Optional

import numpy as np

from .. import _core
from ._validate import as_signal, check_fs, check_int, same_length

__all__ = ["XcorrResult", "xcorr", "pearson", "ConstantInputWarning"]

Method = Literal["direct", "fft", "auto"]


class ConstantInputWarning(RuntimeWarning):
    """An input has zero variance, so a correlation is undefined (NaN)."""


@dataclass(frozen=True)
class XcorrResult:
    """Correlation function of Eq. (1).

    Attributes
    ----------
    lags : ndarray of int64, shape (2L+1,)
        Lags j = -L..L in samples.
    c : ndarray of float64, shape (2L+1,)
        C(j); NaN where a denominator is zero.
    tau : ndarray of float64 or None
        Lags in seconds, j / fs, when ``fs`` was given.
    method : str
        The algorithm that ran ("direct" or "fft").
    """

    lags: np.ndarray
    c: np.ndarray
    tau: Optional[np.ndarray]
    method: str

    @property
    def peak_lag(self) -> int:
        """Lag of the largest |C(j)| (the channel skew when x, y are two channels)."""
        if np.all(np.isnan(self.c)):
            raise ValueError("C is NaN at every lag: no peak")
        return int(self.lags[int(np.nanargmax(np.abs(self.c)))])


def _prepare(x: Any, y: Any, check_finite: bool) -> tuple[np.ndarray, np.ndarray]:
    xa = as_signal(x, "x", min_len=2, check_finite=check_finite)
    ya = as_signal(y, "y", min_len=2, check_finite=check_finite)
    same_length(x=xa, y=ya)
    return xa, ya


def _max_lag(max_lag: Any, n: int) -> int:
    if max_lag is None:
        return n - 1
    lag = check_int(max_lag, "max_lag", minimum=0)
    if lag >= n:
        raise ValueError(f"max_lag must be < n = {n}, got {lag}")
    return lag


def xcorr(
    x: Any,
    y: Any,
    *,
    max_lag: Optional[int] = None,
    fs: Optional[float] = None,
    method: Method = "auto",
    check_finite: bool = True,
) -> XcorrResult:
    """Lagged correlation function of Eq. (1) (docs/method.md 1).

    Parameters
    ----------
    x, y : array_like, 1-D, equal length n >= 2
        Signals; converted to float64.
    max_lag : int, optional
        Largest |lag| L, 0 <= L <= n-1. Default n-1.
    fs : float, optional
        Sampling rate in Hz; when given, ``tau = lags / fs``.
    method : {"auto", "direct", "fft"}
        "direct" sums each overlap, O(n L); "fft" uses real FFTs, O(n log n),
        recomputing directly the edge lags whose overlap holds too little
        energy for the FFT's rounding. Both agree to 1e-10 absolute.
        "auto" picks the faster for (n, L).
    check_finite : bool
        Refuse NaN and inf (default). If False, non-finite values propagate.

    Returns
    -------
    XcorrResult
        ``lags`` (int64), ``c`` (float64), ``tau`` (s, or None), ``method``.

    Raises
    ------
    ValueError
        Unequal lengths, n < 2, max_lag outside [0, n-1], fs <= 0, NaN/inf,
        unknown method.
    TypeError
        Non-numeric input or non-integer max_lag.
    """
    xa, ya = _prepare(x, y, check_finite)
    n = xa.size
    lag = _max_lag(max_lag, n)
    if method not in ("direct", "fft", "auto"):
        raise ValueError(f"method must be 'direct', 'fft' or 'auto', got {method!r}")
    fs_v = None if fs is None else check_fs(fs)
    ran = _core.xcorr_auto_method(n, lag) if method == "auto" else method
    c = _core.xcorr(xa, ya, lag, ran)
    lags = np.arange(-lag, lag + 1, dtype=np.int64)
    tau = None if fs_v is None else lags / fs_v
    return XcorrResult(lags=lags, c=c, tau=tau, method=ran)


def pearson(x: Any, y: Any, *, check_finite: bool = True) -> float:
    """Pearson's r, C(0) of Eq. (1) (docs/method.md 1).

    Returns NaN, with a :class:`ConstantInputWarning`, when x or y is constant.
    Raises ``ValueError``/``TypeError`` on the same inputs as :func:`xcorr`.
    """
    xa, ya = _prepare(x, y, check_finite)
    r = _core.pearson(xa, ya)
    if np.isnan(r) and np.isfinite(xa).all() and np.isfinite(ya).all():
        warnings.warn("an input is constant: the correlation is undefined (NaN)", ConstantInputWarning, stacklevel=2)
    return float(r)
