"""Pure-NumPy reference of every kernel: the maths in the fewest lines.

Same names and signatures as the fast path (``xcorr``, ``pearson``,
``HighPass``, ``highpass``, ``linfit``, ``LinFitAccumulator``). Written for
clarity, not speed: it is the baseline of the parity tests and the
benchmarks. Input checks are shared with the fast path, so both refuse the
same inputs with the same messages. The recursion of the high-pass filter
cannot be expressed in NumPy, so it uses ``scipy.signal.sosfilt``.
"""

from __future__ import annotations

from typing import Any, Optional

import numpy as np
from scipy import signal as _signal

from ._validate import as_channels, check_fs
from .correlation import XcorrResult, _max_lag, _prepare
from .filters import Init, _check_sos, butter_highpass
from .regression import LinFit, _pair, _result

__all__ = ["xcorr", "pearson", "HighPass", "highpass", "linfit", "LinFitAccumulator", "mean"]


def mean(x: np.ndarray) -> float:
    """Two-pass mean: exact for a constant input (METHOD.md 1, 3)."""
    m0 = x.sum() / x.size
    return float(m0 + (x - m0).sum() / x.size)


# -- Eq. (1) ------------------------------------------------------------------


def xcorr(
    x: Any,
    y: Any,
    *,
    max_lag: Optional[int] = None,
    fs: Optional[float] = None,
    method: str = "direct",
    check_finite: bool = True,
) -> XcorrResult:
    """Eq. (1) by its definition: one overlap dot product per lag."""
    xa, ya = _prepare(x, y, check_finite)
    n = xa.size
    lag = _max_lag(max_lag, n)
    xc, yc = xa - mean(xa), ya - mean(ya)
    lags = np.arange(-lag, lag + 1, dtype=np.int64)
    c = np.empty(lags.size)
    for k, j in enumerate(lags):
        # Overlap of x_i and y_{i+j}: i in [max(0, -j), min(n, n - j)).
        a = xc[max(0, -j) : min(n, n - j)]
        b = yc[max(0, j) : min(n, n + j)]
        den = np.sqrt(np.dot(a, a) * np.dot(b, b))
        c[k] = np.clip(np.dot(a, b) / den, -1.0, 1.0) if den > 0 else np.nan
    tau = None if fs is None else lags / check_fs(fs)
    return XcorrResult(lags=lags, c=c, tau=tau, method="direct")


def pearson(x: Any, y: Any, *, check_finite: bool = True) -> float:
    """C(0): Pearson's r, NaN for a constant input."""
    xa, ya = _prepare(x, y, check_finite)
    xc, yc = xa - mean(xa), ya - mean(ya)
    den = np.sqrt(np.dot(xc, xc) * np.dot(yc, yc))
    return float(np.clip(np.dot(xc, yc) / den, -1.0, 1.0)) if den > 0 else float("nan")


# -- High-pass (METHOD.md 2) ----------------------------------------------------


class HighPass:
    """Streaming SOS filter on top of ``scipy.signal.sosfilt`` with carried ``zi``."""

    def __init__(
        self,
        fs: float,
        *,
        cutoff: float = 0.1,
        order: int = 1,
        sos: Optional[Any] = None,
        channels: int = 1,
        init: Init = "steady",
    ) -> None:
        self.sos = butter_highpass(fs, cutoff=cutoff, order=order) if sos is None else _check_sos(sos)
        self.channels = channels
        self.init = init
        self.reset()

    def reset(self) -> None:
        self.state = np.zeros((self.channels, self.sos.shape[0], 2))
        self._started = self.init == "zero"

    def process(self, chunk: Any, *, check_finite: bool = True) -> np.ndarray:
        x = np.atleast_2d(as_channels(chunk, "chunk", check_finite=check_finite))
        if x.shape[1] == 0:
            return np.asarray(chunk, dtype=float).copy()
        if not self._started:
            self.state = _signal.sosfilt_zi(self.sos)[None, :, :] * x[:, 0, None, None]
            self._started = True
        # scipy's zi is (n_sections, channels, 2) for axis=-1 on (channels, m).
        y, zf = _signal.sosfilt(self.sos, x, axis=-1, zi=np.moveaxis(self.state, 0, 1))
        self.state = np.moveaxis(zf, 1, 0)
        return y[0] if np.ndim(chunk) == 1 else y


def highpass(
    x: Any,
    fs: float,
    *,
    cutoff: float = 0.1,
    order: int = 1,
    axis: int = -1,
    init: Init = "steady",
    sos: Optional[Any] = None,
    check_finite: bool = True,
) -> np.ndarray:
    """One-shot ``scipy.signal.sosfilt`` along ``axis``, other axes as channels."""
    moved = np.moveaxis(np.asarray(x, dtype=float), axis, -1)
    flat = moved.reshape(-1, moved.shape[-1])
    hp = HighPass(fs, cutoff=cutoff, order=order, sos=sos, channels=flat.shape[0], init=init)
    return np.moveaxis(hp.process(flat, check_finite=check_finite).reshape(moved.shape), -1, axis)


# -- Eqs. (6)-(8) ---------------------------------------------------------------


def _fit(n: int, mx: float, my: float, sxx: float, syy: float, sxy: float, sse: float) -> tuple:
    if n < 3 or not sxx > 0:
        nan = float("nan")
        return (nan, nan, nan, nan, nan, nan, n, True)
    slope = sxy / sxx
    den = np.sqrt(sxx * syy)
    r = float(np.clip(sxy / den, -1, 1)) if den > 0 else float("nan")
    var = sse / (n - 2)
    se = np.sqrt(var / sxx)
    return (slope, my - slope * mx, r, se, se * np.sqrt(sxx / n + mx * mx), np.sqrt(var), n, False)


def _moments(x: np.ndarray, y: np.ndarray) -> tuple:
    """(n, mean_x, mean_y, S_xx, S_yy, S_xy, SSE) by centred passes."""
    n = x.size
    if n == 0:
        return (0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    mx, my = mean(x), mean(y)
    dx, dy = x - mx, y - my
    sxx, syy, sxy = dx @ dx, dy @ dy, dx @ dy
    if sxx > 0:
        e = dy - (sxy / sxx) * dx
        sse = max(e @ e - e.sum() ** 2 / n, 0.0)
    else:
        sse = syy
    return (n, mx, my, sxx, syy, sxy, sse)


def linfit(x: Any, y: Any, *, check_finite: bool = True) -> LinFit:
    """OLS of y on x from centred sums; SSE from the residuals themselves."""
    xa, ya = _pair(x, y, check_finite, 1)
    return _result(_fit(*_moments(xa, ya)))


class LinFitAccumulator:
    """Chan et al. pairwise merge of centred moments, in plain Python."""

    def __init__(self) -> None:
        self.m: tuple = (0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    @staticmethod
    def _merge(a: tuple, b: tuple) -> tuple:
        na, mxa, mya, sxxa, syya, sxya, ssea = a
        nb, mxb, myb, sxxb, syyb, sxyb, sseb = b
        if nb == 0:
            return a
        if na == 0:
            return b
        n = na + nb
        dx, dy, w = mxb - mxa, myb - mya, na * nb / n
        sxx = sxxa + sxxb + dx * dx * w
        ba = sxya / sxxa if sxxa > 0 else 0.0
        bb = sxyb / sxxb if sxxb > 0 else 0.0
        # SSE of the union = SSE_a + SSE_b + the non-negative "between" term.
        if sxx > 0:
            between = (sxxa * sxxb * (ba - bb) ** 2 + sxxa * w * (ba * dx - dy) ** 2 + sxxb * w * (bb * dx - dy) ** 2) / sxx
        else:
            between = dy * dy * w
        return (n, mxa + dx * nb / n, mya + dy * nb / n, sxx, syya + syyb + dy * dy * w, sxya + sxyb + dx * dy * w, ssea + sseb + between)

    def update(self, x: Any, y: Any, *, check_finite: bool = True) -> "LinFitAccumulator":
        xa, ya = _pair(x, y, check_finite, 0)
        self.m = self._merge(self.m, _moments(xa, ya))
        return self

    def merge(self, other: "LinFitAccumulator") -> "LinFitAccumulator":
        out = LinFitAccumulator()
        out.m = self._merge(self.m, other.m)
        return out

    def result(self) -> LinFit:
        return _result(_fit(*self.m))
