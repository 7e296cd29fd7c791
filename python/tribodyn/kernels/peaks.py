"""Local maxima and their prominence, as ``scipy.signal.find_peaks`` finds them (docs/method.md 6g).

The stick-slip search needs one function of ``scipy.signal``, whose import costs about two seconds per
process on a small machine; :func:`find_peaks` is the same search in the Rust core
(``rust/core/src/numerics/peaks.rs``), index for index (``tests/kernels/test_peaks.py`` compares the two).
"""

from __future__ import annotations

import numpy as np

from .. import _core

__all__ = ["find_peaks"]


def find_peaks(x: np.ndarray, *, prominence: float, wlen: int) -> np.ndarray:
    """Indices (int64, ascending) of the local maxima of the 1-D ``x`` whose prominence within ``wlen``
    samples (``wlen // 2`` each side; ``wlen < 2``: the whole array) is at least ``prominence``.

    Equal to ``scipy.signal.find_peaks(x, prominence=prominence, wlen=wlen)[0]`` for ``wlen >= 2``: a flat
    peak is its middle sample (rounded down), the first and last samples are never peaks, +inf is a wall
    that no prominence search crosses.
    """
    if not np.isfinite(prominence) and not prominence == -np.inf:
        raise ValueError(f"find_peaks: prominence must be a number, got {prominence!r}")
    if int(wlen) < 0:
        raise ValueError(f"find_peaks: wlen must be >= 0, got {wlen!r}")
    a = np.ascontiguousarray(np.asarray(x, dtype=np.float64))
    if a.ndim != 1:
        raise ValueError(f"find_peaks: x must be 1-D, got shape {a.shape}")
    at: np.ndarray = _core.find_peaks(a, prominence=float(prominence), wlen=int(wlen))
    return at
