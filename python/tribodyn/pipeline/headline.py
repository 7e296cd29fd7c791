"""The one COF a user reads first: :class:`Headline`, chosen by the verdict (docs/method.md 6e).

* :class:`ClassicalTotals`: the classical COF's sums per block of the whole
  recording (every sample in contact, tail included), read in one pass by
  :func:`classical_totals` (docs/method.md 6a).
* :func:`batch_mean` / :func:`ratio_mean`: a mean with its 95 % interval by
  batch means over contiguous batches (docs/method.md 6e).
* :func:`choose`: the headline of a :class:`tribodyn.Results`: the dynamic
  COF when the dynamic method applies, else the classical COF of the whole
  recording (unidirectional) or the per-stroke COF (reciprocating).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Dict, Iterator, List, Mapping, Optional, Tuple

import numpy as np

from .. import _core
from ..kernels.stats import BATCHES
from ..kernels.uncertainty import SHAPE, in_contact, ratio_sums
from ..results import ClassicalTotals

if TYPE_CHECKING:  # pragma: no cover
    pass

__all__ = ["BlockSums", "block_length", "classical_totals"]

#: Largest block (samples) the classical pass reads at once; its blocks are the batch-means grid.
MAX_BLOCK = 1 << 20


# -- batch means ----------------------------------------------------------------------


# -- the classical COF over the whole recording -----------------------------------------


def block_length(n_total: int) -> int:
    """Block length of a recording of ``n_total`` samples: about BATCHES blocks, at most MAX_BLOCK samples."""
    return max(1, min(MAX_BLOCK, -(-int(n_total) // BATCHES)))


def _blocks(source: Any, rec: Any, start: int, stop: Optional[int]
            ) -> Optional[Tuple[int, Iterator[Tuple[int, Dict[str, np.ndarray]]]]]:  # fmt: skip
    """(block length, iterator of (first sample, {fy, fz[, cof]})) of the range, or None for a one-pass stream."""
    if rec is not None:
        n_all = int(rec.n_samples)
        roles = [r for r in ("fy", "fz", "cof") if r in rec.roles]
        length = block_length(n_all)
        hi = n_all if stop is None else min(int(stop), n_all)
        # start on the block grid: the first chunk ends at the next grid line
        first = min(hi, (start // length + 1) * length) if start % length else start

        def rec_iter() -> Iterator[Tuple[int, Dict[str, np.ndarray]]]:
            if first > start:
                for piece in rec.chunks(first - start, roles, start=start, stop=first):
                    yield start, piece
            pos = first
            for piece in rec.chunks(length, roles, start=first, stop=hi) if first < hi else ():
                yield pos, piece
                pos += len(piece["fz"])

        return length, rec_iter()
    if isinstance(source, Mapping):
        arrays = {r: np.asarray(source[r], dtype=float) for r in ("fy", "fz", "cof") if r in source}
    elif isinstance(source, (list, tuple)) and source and all(isinstance(a, Mapping) for a in source):
        keys = [r for r in ("fy", "fz", "cof") if all(r in a for a in source)]
        arrays = {r: np.concatenate([np.asarray(a[r], dtype=float) for a in source]) for r in keys}
    else:
        return None
    if "fy" not in arrays or "fz" not in arrays:
        return None
    n_all = arrays["fz"].size
    length = block_length(n_all)
    hi = n_all if stop is None else min(int(stop), n_all)

    def arr_iter() -> Iterator[Tuple[int, Dict[str, np.ndarray]]]:
        a = start
        while a < hi:
            b = min(hi, (a // length + 1) * length)
            yield a, {r: v[a:b] for r, v in arrays.items()}
            a = b

    return length, arr_iter()


def classical_totals(source: Any, rec: Any, spec: Any, start: int = 0, stop: Optional[int] = None
                     ) -> Optional[ClassicalTotals]:  # fmt: skip
    """The classical COF's block sums over samples ``start``..``stop`` (docs/method.md 6a, 6e); None for a stream.

    Reads fy, fz (and the instrument's ``cof`` when mapped) once, in blocks
    of :func:`block_length` samples on a grid fixed by the recording's
    length: the sums do not depend on how the reader chunks the file.
    """
    got = _blocks(source, rec, int(start), stop)
    if got is None:
        return None
    length, pieces = got
    sums: Dict[int, List[float]] = {}
    samples = 0
    for a, piece in pieces:
        if not len(piece["fz"]):
            continue
        cut = a + np.arange(len(piece["fz"]))
        ids = cut // length
        for k in np.unique(ids):
            sel = slice(int(np.searchsorted(ids, k)), int(np.searchsorted(ids, k, side="right")))
            row = _block_sums({r: v[sel] for r, v in piece.items()}, spec)
            samples += int(row[5])
            acc = sums.setdefault(int(k), [0.0] * 6)
            for j, v in enumerate((*row[:5], row[6])):
                acc[j] += v
    ids_arr = np.asarray(sorted(sums), dtype=np.int64)
    cols = np.asarray([sums[k] for k in ids_arr.tolist()], dtype=float).reshape(-1, 6)
    return ClassicalTotals(block=length, ids=ids_arr, count=cols[:, 0], ratio_sum=cols[:, 1],
                           signed_sum=cols[:, 2], inst_count=cols[:, 3], inst_sum=cols[:, 4],
                           samples=samples, raw_sum=cols[:, 5])  # fmt: skip


class BlockSums:
    """The classical COF's block sums taken from the main pass's chunks (docs/method.md 6e): the file read once.

    Chunks of the samples ``lo``..``hi`` arrive in any size (from one reader
    thread); each block of the grid of :func:`block_length` is summed once,
    when its last sample has arrived, so the totals are bitwise those of
    :func:`classical_totals` reading the file again. With ``budget`` (a plan
    with uncertainty inputs) each block also adds its samples in contact to
    the uncertainty budget's sums (``kernels.uncertainty.ratio_sums``,
    docs/method.md 6i): :attr:`budget_sums`, block by block in the order
    ``pipeline/budget.py``'s ``classical_moments`` would read them again.
    """

    def __init__(self, spec: Any, n_total: int, lo: int, hi: int, *, budget: bool = False) -> None:
        self.spec, self.lo, self.hi = spec, int(lo), int(hi)
        self._budget: Optional[np.ndarray] = np.zeros(SHAPE) if budget else None
        self.length = block_length(n_total)
        self._pending: List[Tuple[int, Dict[str, np.ndarray]]] = []  # pieces of the block being filled
        self._rows: Dict[int, Tuple[float, ...]] = {}
        self._next = self.lo  # the next sample expected
        self._broken = False

    def push(self, first: int, piece: Mapping[str, np.ndarray]) -> None:
        """Samples ``first``.. of fy, fz (raw, before any filter) and cof when present, in order."""
        n = len(piece["fz"])
        a, b = max(first, self.lo), min(first + n, self.hi)
        if b <= a:
            return
        if a != self._next or self._broken:  # a gap (samples outside every acquisition): read again instead
            self._broken = True
            return
        keys = [k for k in ("fy", "fz", "cof") if k in piece]
        while a < b:
            end = min(b, (a // self.length + 1) * self.length)
            self._pending.append((a, {k: np.asarray(piece[k][a - first : end - first]) for k in keys}))
            a = end
            if end % self.length == 0 or end == self.hi:
                self._close()
        self._next = b

    def _close(self) -> None:
        if not self._pending:
            return
        first = self._pending[0][0]
        keys = list(self._pending[0][1])
        if len(self._pending) == 1:
            block = self._pending[0][1]
        else:
            block = {k: np.concatenate([p[k] for _, p in self._pending]) for k in keys}
        self._rows[first // self.length] = _block_sums(block, self.spec)
        if self._budget is not None:
            self._budget += ratio_sums(*in_contact(block["fy"], block["fz"], self.spec))
        self._pending = []

    def budget_sums(self) -> Optional[np.ndarray]:
        """The budget's sums (``SHAPE``, unweighted) over every sample in contact seen; None when not asked for or
        when the range was not seen whole (docs/method.md 6i)."""
        self._close()
        if self._budget is None or self._broken or self._next != self.hi:
            return None
        return self._budget.copy()

    def totals(self) -> Optional[ClassicalTotals]:
        """The totals of every sample seen; None when the range was not seen whole."""
        self._close()
        if self._broken or self._next != self.hi:
            return None
        ids = np.asarray(sorted(self._rows), dtype=np.int64)
        cols = np.asarray([(*self._rows[k][:5], self._rows[k][6]) for k in ids.tolist()], dtype=float).reshape(-1, 6)
        samples = int(sum(self._rows[k][5] for k in ids.tolist()))
        return ClassicalTotals(block=self.length, ids=ids, count=cols[:, 0], ratio_sum=cols[:, 1],
                               signed_sum=cols[:, 2], inst_count=cols[:, 3], inst_sum=cols[:, 4],
                               samples=samples, budget=self.budget_sums(), raw_sum=cols[:, 5])  # fmt: skip


def _block_sums(piece: Mapping[str, np.ndarray], spec: Any) -> Tuple[float, ...]:
    """(contact count, sum |fy|/|fz|, sum fy/fz, instrument count, instrument sum, finite samples, sum of
    |fy|/|fz| with fy's raw level, its tare not subtracted) of one block (docs/method.md 6a)."""
    y = np.asarray(piece["fy"], dtype=float) - spec.tare_fy
    z = np.asarray(piece["fz"], dtype=float) - spec.tare_fz
    az = np.abs(z)
    fin = (np.abs(y) <= _core.FORCE_LIMIT) & (az <= _core.FORCE_LIMIT)  # finite and in range (docs/method.md 4)
    keep = fin & (az >= spec.min_fn) & (az > 0)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        r = y[keep] / z[keep]
    ratio = float(np.abs(r).sum())
    signed = float(r.sum())
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # the unloaded level kept (a drag)
        raw = float(np.abs((y[keep] + spec.tare_fy) / z[keep]).sum())
    ic = isum = 0.0
    if "cof" in piece:
        c = np.abs(np.asarray(piece["cof"], dtype=float)[keep])
        c = c[np.isfinite(c)]
        ic, isum = float(c.size), float(c.sum())
    return float(keep.sum()), ratio, signed, ic, isum, float(fin.sum()), raw


# -- the choice -------------------------------------------------------------------------
