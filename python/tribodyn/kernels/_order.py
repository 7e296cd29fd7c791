"""Exact order statistics, faster than NumPy's for the pre-pass and the bootstrap (issue 25).

The values are NumPy's bit for bit: :func:`median` is ``np.median`` (the
mean of the middle one or two values) and the quantiles use NumPy's
"linear" method (its ``_get_indexes``, ``_get_gamma`` and ``_lerp``); only
the way the order statistics are found differs.

* :func:`order_stats` of a long 1-D array brackets the wanted ranks with a
  strided sample, counts the values below the bracket and selects among the
  few inside it (Floyd and Rivest 1975): three cheap passes instead of a
  partition of the whole array; exact, with a partition as the fallback
  when the bracket misses (a sample of an unusual ordering).
* :func:`row_quantiles` of a 2-D array, ignoring NaN, selects once per row
  for the median and every percentile together, where ``np.nanmedian`` and
  ``np.nanpercentile`` select once per statistic and, over 600 columns or
  with NaN, row by row from Python.
"""

from __future__ import annotations

from typing import List, Optional, Sequence, Tuple

import numpy as np

from .. import _core

#: Arrays up to this many values are simply partitioned.
_SMALL = 1 << 15
#: Largest size of the strided sample that brackets the ranks; a shorter array takes about n^(2/3) values, at
#: least ``_SAMPLE_MIN`` (Floyd and Rivest; as the Rust kernel's ``select_ranks``).
_SAMPLE = 1 << 14
_SAMPLE_MIN = 1 << 10


def _kernel_ranks(x: np.ndarray, ks: Sequence[int], centre: Optional[float] = None) -> Optional[np.ndarray]:
    """Ranks ``ks`` of the 1-D float64 ``x`` (with ``centre``: of ``|x - centre|``) by the Rust kernel
    ``_core.select_ranks`` (the bracket below in one pass); None without the kernel or when ``x`` holds NaN."""
    if not ks or x.ndim != 1 or x.dtype != np.float64 or not hasattr(_core, "select_ranks"):
        return None
    from .threads import read_threads  # the running analysis's thread count

    return _core.select_ranks(
        np.require(x, requirements=["C", "A"]), [int(k) for k in ks], centre=centre, threads=read_threads()
    )


def _middle(n: int) -> List[int]:
    """The rank(s) whose mean is the median of ``n`` values."""
    h = n // 2
    return [h] if n % 2 else [h - 1, h]


def order_stats(x: np.ndarray, ks: Sequence[int]) -> np.ndarray:
    """The values of ranks ``ks`` (0-based, ascending order) of the 1-D NaN-free array ``x``, exactly."""
    x = np.asarray(x)
    n = x.size
    ks = [int(k) for k in ks]
    got = _kernel_ranks(x, ks)
    if got is not None:
        return got
    if n <= _SMALL or not ks:
        return np.partition(x, ks)[ks] if ks else np.zeros(0, dtype=x.dtype)
    want = min(max(int(n ** (2.0 / 3.0)), _SAMPLE_MIN), _SAMPLE)
    sample = np.sort(x[:: max(1, n // want)])
    m = sample.size
    margin = 3.0 * np.sqrt(m) + 8.0
    lo_j = int(min(ks) / n * m - margin)
    hi_j = int(np.ceil(max(ks) / n * m + margin))
    lo = sample[lo_j] if lo_j > 0 else None
    hi = sample[hi_j] if hi_j < m - 1 else None
    if lo is None and hi is None:
        return np.partition(x, ks)[ks]
    below = int(np.count_nonzero(x < lo)) if lo is not None else 0
    if lo is None:
        inside = x[x <= hi]
    elif hi is None:
        inside = x[x >= lo]
    else:
        inside = x[(x >= lo) & (x <= hi)]
    rel = [k - below for k in ks]
    if rel[0] < 0 or rel[-1] >= inside.size:  # the bracket missed: select in the whole array
        return np.partition(x, ks)[ks]
    return np.partition(inside, rel)[rel]


def median(x: np.ndarray) -> float:
    """``float(np.median(x))`` of a 1-D array (NaN when it holds NaN, as NumPy's)."""
    x = np.asarray(x, dtype=float)
    n = x.size
    got = _kernel_ranks(x, _middle(n)) if n else None
    if got is None and (n == 0 or n <= _SMALL or np.isnan(x).any()):
        return float(np.median(x))
    return float(np.mean(got if got is not None else order_stats(x, _middle(n))))


def median_abs_dev(x: np.ndarray, centre: float) -> float:
    """``float(np.median(np.abs(x - centre)))`` of a 1-D array, without the temporary array (Rust)."""
    x = np.asarray(x, dtype=float)
    got = _kernel_ranks(x, _middle(x.size), float(centre)) if x.size else None
    return float(np.mean(got)) if got is not None else median(np.abs(x - centre))


class Sorted:
    """A sorted 1-D NaN-free float64 array whose order statistics (and those of its distances to a
    centre) are read without a selection: the pre-pass sorts its sample of fz once and takes every
    median, median absolute deviation and class of Otsu's splits from it (issue 25).

    The values are those of :func:`median` and :func:`median_abs_dev` of the same values, bit for
    bit: a rank of ``s`` is an index, and the distances ``|s_i - c|`` (``c - s_i`` left of ``c``,
    ``s_i - c`` right of it, rounded the same way as ``|s_i - c|``) form two sorted runs whose
    k-th smallest is found by a binary search over how many of them come from the left run.
    ``a:b`` is the part looked at (a class of Otsu's split), without copies.
    """

    __slots__ = ("s", "a", "b")

    def __init__(self, s: np.ndarray, a: int = 0, b: Optional[int] = None) -> None:
        self.s, self.a, self.b = s, int(a), int(s.size if b is None else b)

    @classmethod
    def of(cls, x: np.ndarray) -> "Sorted":
        """``x`` sorted (a copy)."""
        return cls(np.sort(np.asarray(x, dtype=np.float64)))

    @property
    def size(self) -> int:
        return self.b - self.a

    def part(self, a: int, b: int) -> "Sorted":
        """Values ``a:b`` of this part (indices relative to it)."""
        return Sorted(self.s, self.a + a, self.a + b)

    def values(self) -> np.ndarray:
        """This part's values (a view)."""
        return self.s[self.a : self.b]

    def count_le(self, t: float) -> int:
        """How many values are <= ``t``."""
        return int(np.searchsorted(self.values(), t, side="right"))

    def ranks(self, ks: Sequence[int], centre: Optional[float] = None) -> List[float]:
        """The values of ranks ``ks`` (0-based, ascending) of this part, or with ``centre`` of the
        distances ``|value - centre|`` (:func:`order_stats`, ``_core.select_ranks`` with a centre)."""
        n, a, s = self.size, self.a, self.s
        if any(k < 0 or k >= n for k in ks):
            raise IndexError(f"rank out of range for {n} values")
        if centre is None:
            return [float(s[a + k]) for k in ks]
        c = float(centre)
        j = int(np.searchsorted(self.values(), c, side="left"))  # values < c on the left
        n_left, n_right = j, n - j

        def left(i: int) -> float:  # i-th smallest distance on the left: c - s[j - 1 - i]
            return c - float(s[a + j - 1 - i])

        def right(i: int) -> float:
            return float(s[a + j + i]) - c

        out = []
        for k in ks:
            # i = how many of the k + 1 smallest distances are on the left
            lo, hi = max(0, k + 1 - n_right), min(k + 1, n_left)
            while True:
                i = (lo + hi) // 2
                r = k + 1 - i  # taken on the right
                if i > 0 and r < n_right and left(i - 1) > right(r):
                    hi = i - 1
                elif r > 0 and i < n_left and right(r - 1) > left(i):
                    lo = i + 1
                else:
                    break
            got = [left(i - 1)] if i > 0 else []
            if r > 0:
                got.append(right(r - 1))
            out.append(abs(max(got)))  # |.|: a zero distance is +0.0, as NumPy's np.abs gives it
        return out

    def median(self) -> float:
        """:func:`median` of this part's values."""
        if not self.size:
            return float("nan")
        return float(np.mean(np.array(self.ranks(_middle(self.size)))))

    def median_abs_dev(self, centre: float) -> float:
        """:func:`median_abs_dev` of this part's values."""
        if not self.size:
            return float("nan")
        return float(np.mean(np.array(self.ranks(_middle(self.size), centre))))


def percentile(x: np.ndarray, q: float) -> float:
    """``float(np.percentile(x, q))`` of a 1-D array (method "linear")."""
    x = np.asarray(x, dtype=float)
    n = x.size
    if n == 0:
        return float(np.percentile(x, q))
    pi, ni, gamma = _indexes(np.array([n]), np.true_divide(q, 100))
    ks = [int(pi[0]), int(ni[0])]
    got = _kernel_ranks(x, ks)
    if got is None:
        if n <= _SMALL or np.isnan(x).any():
            return float(np.percentile(x, q))
        got = order_stats(x, sorted(set(ks)))
        got = got[[sorted(set(ks)).index(k) for k in ks]]
    return float(lerp(got[:1], got[1:], gamma)[0])


def abs_percentile(x: np.ndarray, q: float) -> float:
    """``float(np.percentile(np.abs(x), q))`` of a 1-D array (method "linear"), without the array of
    magnitudes: the kernel selects among ``|x - 0.0|``, which is ``|x|`` bit for bit."""
    x = np.asarray(x, dtype=float)
    n = x.size
    if n:
        pi, ni, gamma = _indexes(np.array([n]), np.true_divide(q, 100))
        got = _kernel_ranks(x, [int(pi[0]), int(ni[0])], 0.0)
        if got is not None:
            return float(lerp(got[:1], got[1:], gamma)[0])
    return percentile(np.abs(x), q)


def _indexes(k: np.ndarray, quant: np.floating) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For rows of ``k`` values each: the ranks below and above NumPy's virtual index and the weight gamma."""
    vi = (k - 1) * quant
    prev = np.floor(vi)
    nxt = prev + 1
    above = vi >= k - 1
    prev[above] = -1
    nxt[above] = -1
    pi, ni = prev.astype(np.intp), nxt.astype(np.intp)
    gamma = np.asarray(vi - pi, dtype=vi.dtype)
    return np.where(pi < 0, k + pi, pi), np.where(ni < 0, k + ni, ni), gamma


def lerp(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    """NumPy's linear interpolation of its quantiles (``numpy.lib._function_base_impl._lerp``), elementwise."""
    diff = np.subtract(b, a)
    out = np.asarray(np.add(a, diff * t))
    np.subtract(b, diff * (1 - t), out=out, where=t >= 0.5)
    return out


def row_quantiles(x: np.ndarray, qs: Sequence[float], *, threads: int = 1) -> Tuple[np.ndarray, List[np.ndarray]]:
    """Per row of ``x``, ignoring NaN: the median and the percentiles ``qs``, bit for bit
    ``np.nanmedian(x, axis=1)`` and ``np.nanpercentile(x, q, axis=1)`` (an all-NaN row gives NaN).

    The Rust kernel (``_core.row_quantiles``: a selection per order statistic within one copy of the
    row, rows on ``threads`` threads) when the extension has it, else :func:`_row_quantiles_numpy`.
    """
    x = np.asarray(x)
    if x.ndim == 2 and x.dtype == np.float64 and hasattr(_core, "row_quantiles"):
        fracs = [float(np.true_divide(q, 100)) for q in qs]
        med, flat = _core.row_quantiles(np.require(x, requirements=["C", "A"]), fracs, threads=threads)
        return med, [flat[j * x.shape[0] : (j + 1) * x.shape[0]] for j in range(len(fracs))]
    return _row_quantiles_numpy(x, qs)


def _row_quantiles_numpy(x: np.ndarray, qs: Sequence[float]) -> Tuple[np.ndarray, List[np.ndarray]]:
    """:func:`row_quantiles` in NumPy: one selection per row (``np.partition`` at every order statistic
    needed; a sort, NaN last, when some rows hold NaN) serves the median and all the percentiles."""
    m, w = x.shape
    k = np.full(m, w, dtype=np.int64)
    quants = [np.true_divide(q, 100) for q in qs]
    if w and np.isnan(x).any():
        k -= np.count_nonzero(np.isnan(x), axis=1)
        s = np.sort(x, axis=1)
    elif w:
        kth = {max(w // 2 - 1, 0), w // 2}
        for q in quants:
            lo = int(np.floor((w - 1) * q))
            kth.update((min(lo, w - 1), min(lo + 1, w - 1)))
        s = np.partition(x, sorted(kth), axis=1)
    else:
        s = np.full((m, 1), np.nan)
    rows = np.arange(m)
    has = k > 0
    kk = np.maximum(k, 1)
    # the median: numpy.median of the row's values, the mean of the middle one or two
    h = kk // 2
    med = np.full(m, np.nan)
    odd = has & (kk % 2 == 1)
    even = has & (kk % 2 == 0)
    if odd.any():
        med[odd] = np.mean(s[rows[odd], h[odd]][:, None], axis=1)
    if even.any():
        r = rows[even]
        med[even] = np.mean(np.stack((s[r, h[even] - 1], s[r, h[even]]), axis=1), axis=1)
    out: List[np.ndarray] = []
    for q in quants:
        pi, ni, gamma = _indexes(kk, q)
        val = lerp(s[rows, pi], s[rows, ni], gamma)
        val[~has] = np.nan
        out.append(val)
    return med, out
