"""Shared statistics: the moving-block bootstrap of the per-window COF (docs/method.md 3d), batch
means of a ratio or a mean (6e), and Student's t quantiles."""

from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist
from typing import TYPE_CHECKING, Any, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from ._order import row_quantiles
from .quantiles import t975, t_quantile

if TYPE_CHECKING:
    pass


@dataclass(frozen=True)
class NoiseResample:
    """What :func:`bootstrap_ci` needs to draw the recording's fz-noise estimate anew (docs/method.md 3d).

    Attributes
    ----------
    var : ndarray
        Every window's measurement of sigma_z^2 (column ``noise_z_var``, N^2), in time order.
    index : ndarray of int64
        The positions in ``var`` of the windows whose values are bootstrapped, increasing.
    dnoise : ndarray
        d value / d sigma_z^2 of those windows (column ``mu_r_dnoise``, 1/N^2).
    """

    var: np.ndarray
    index: np.ndarray
    dnoise: np.ndarray


def noise_resample(table: Mapping[str, np.ndarray], keep: np.ndarray) -> Optional[NoiseResample]:
    """The :class:`NoiseResample` of the windows ``keep`` (a mask over the table's rows), or None when
    mu_r does not depend on a noise estimate of the recording (``mu_r_dnoise`` 0: OLS, IV, Deming, a
    given ``noise``, the paper's method; docs/method.md 3c, 3d)."""
    if "noise_z_var" not in table or "mu_r_dnoise" not in table:
        return None
    keep = np.asarray(keep, dtype=bool)
    dn = np.asarray(table["mu_r_dnoise"], dtype=float)[keep]
    dn = np.where(np.isfinite(dn), dn, 0.0)
    var = np.asarray(table["noise_z_var"], dtype=float)
    if not np.any(dn != 0) or not np.isfinite(var).any():
        return None
    return NoiseResample(var=var, index=np.flatnonzero(keep), dnoise=dn)


def _blocks(rng: np.random.Generator, n: int) -> np.ndarray:
    """Moving-block resamples of n windows: (BOOTSTRAP_RESAMPLES, n) indices, blocks of ceil(n^(1/3))."""
    starts, ell = _block_starts(rng, n)
    return _expand(starts, ell, n)


def _block_starts(rng: np.random.Generator, n: int) -> Tuple[np.ndarray, int]:
    """The first window of every block of every resample (as :func:`_blocks` draws them) and the block length."""
    ell = int(np.ceil(n ** (1.0 / 3.0)))
    return rng.integers(0, n - ell + 1, size=(BOOTSTRAP_RESAMPLES, -(-n // ell))), ell


def _expand(starts: np.ndarray, ell: int, n: int) -> np.ndarray:
    """The window indices of the resamples whose blocks start at ``starts`` (rows of :func:`_block_starts`)."""
    idx: np.ndarray = (starts[:, :, None] + np.arange(ell)[None, None, :]).reshape(starts.shape[0], -1)[:, :n]
    return idx


def _row_chunks(rows: int, width: int) -> List[slice]:
    step = max(1, min(rows, _CHUNK_CELLS // max(width, 1)))
    return [slice(a, min(a + step, rows)) for a in range(0, rows, step)]


def _resample_stats(v: np.ndarray, starts: np.ndarray, ell: int, noise: Optional[Tuple[Any, ...]]
                    ) -> Tuple[np.ndarray, ...]:  # fmt: skip
    """(median, mean, p05, p95) of the resamples whose blocks start at ``starts`` (see :func:`bootstrap_ci`)."""
    if noise is None:
        r = v[_expand(starts, ell, v.size)]
        if np.isnan(r).any():  # NaN in v: NumPy's NaN-propagating statistics, as they always were
            return np.median(r, axis=1), r.mean(axis=1), np.percentile(r, 5, axis=1), np.percentile(r, 95, axis=1)
        med, (p05, p95) = row_quantiles(r, (5, 95))
        return med, r.mean(axis=1), p05, p95
    var, pos, dn, used = noise
    idx = _expand(starts, ell, var.size)
    p = pos[idx]
    # no warnings filter here (the resamples run on threads, and warnings.catch_warnings is process-wide)
    with np.errstate(invalid="ignore", divide="ignore"):
        delta = np.maximum(row_quantiles(var[idx], ())[0], 0.0) - used
        r = dn[p]  # v[p] + dn[p] * delta, in place (p < 0, a window not among v's: NaN)
        r *= delta[:, None]
        r += v[p]
        out = p < 0
        if out.any():
            r[out] = np.nan
        med, (p05, p95) = row_quantiles(r, (5, 95))
        nan = np.isnan(r)
        if not nan.any():
            return med, r.mean(axis=1), p05, p95
        # np.nanmean's sums and counts, without its warning for a resample without any of v's windows (NaN)
        mean = np.sum(np.where(nan, 0.0, r), axis=1) / np.sum(~nan, axis=1, dtype=np.intp)
        return med, mean, p05, p95


def _threads(threads: Optional[int]) -> int:
    if threads is None:
        from .threads import resolve_threads

        return resolve_threads()
    return max(1, int(threads))


def _all_resample_stats(v: np.ndarray, starts: np.ndarray, ell: int, noise: Optional[Tuple[Any, ...]], *, width: int,
                        threads: int) -> Tuple[np.ndarray, ...]:  # fmt: skip
    """(median, mean, p05, p95) of every resample: the Rust kernel (one pass per resample, rows on
    ``threads`` threads) when the extension has it, else :func:`_resample_stats` a bounded chunk of
    resamples at a time (every statistic is per resample: the same numbers as all at once)."""
    from .. import _core

    if hasattr(_core, "resample_stats"):
        nz = None if noise is None else (np.ascontiguousarray(noise[0], dtype=float),
                                         np.ascontiguousarray(noise[1], dtype=np.int64),
                                         np.ascontiguousarray(noise[2], dtype=float), float(noise[3]))  # fmt: skip
        flat = _core.resample_stats(np.ascontiguousarray(v, dtype=float), np.ascontiguousarray(starts, dtype=np.int64),
                                    ell, noise=nz, threads=threads)  # fmt: skip
        rows = starts.shape[0]
        return tuple(flat[j * rows : (j + 1) * rows] for j in range(4))
    chunks = _row_chunks(starts.shape[0], width)
    workers = min(len(chunks), threads)
    if workers < 2:
        parts = [_resample_stats(v, starts[c], ell, noise) for c in chunks]
    else:  # NumPy's selections, gathers and ufuncs release the GIL
        from .threads import thread_pool

        with thread_pool(workers, "tribodyn-bootstrap") as ex:
            parts = list(ex.map(lambda c: _resample_stats(v, starts[c], ell, noise), chunks))
    return tuple(np.concatenate([p[j] for p in parts]) for j in range(4))


def bootstrap_ci(
    v: np.ndarray,
    level: float = 0.95,
    *,
    noise: Optional[NoiseResample] = None,
    threads: Optional[int] = None,
    shifts: Sequence[float] = (),
) -> Dict[str, Tuple[float, float]]:
    """95 % intervals of the median, mean, p05 and p95 of ``v`` (windows in time order; docs/method.md 3d).

    Moving-block bootstrap (Kuensch 1989): blocks of l = ceil(n^(1/3))
    consecutive windows, drawn with replacement until n windows, 999
    resamples with a fixed seed. Neighbouring windows are correlated (the
    temperature or the contact changes slowly), which blocks keep.
    Expanded percentile intervals: the percentiles a and 1 - a with
    a = Phi(-sqrt(b / (b - 1)) t(1 - (1 - level) / 2, b - 1)), b the number
    of blocks (the percentile interval is too short for few independent
    blocks; Hesterberg 2015, with blocks for observations).

    With ``noise`` (``v`` depends on the recording's fz-noise estimate
    sigma^2, the median of every window's measurement), the blocks are drawn
    over all the recording's windows; each resample re-estimates sigma^2*
    as the median of its windows' ``noise.var`` (clipped at 0) and takes its
    windows among ``noise.index``, moved by ``noise.dnoise`` (sigma^2* -
    sigma^2). So the interval carries the error of the noise estimate, which
    moves every window together, and its correlation with the windows' own
    errors. Empty for fewer than 3 windows.

    With ``shifts`` (the moves of every value had another of the lags the
    instrument's lag was chosen among been chosen: ``ChosenLag.shifts``,
    docs/method.md 3d), the resamples pool over those lags: resample j takes
    lag j mod (K + 1), the chosen one (no move) and the K others in turn, and
    each of its statistics moves by that lag's shift.

    The resamples are taken a bounded chunk at a time (memory does not grow
    with the recording), on ``threads`` threads (default: the call's
    default, :func:`tribodyn.get_threads`); the numbers depend on neither.
    """
    v = np.asarray(v, dtype=float)
    n = v.size
    if n < 3:
        return {}
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    args: Optional[Tuple[Any, ...]] = None
    if noise is None:
        starts, ell = _block_starts(rng, n)
        width = n
    else:
        var = np.asarray(noise.var, dtype=float)
        index = np.asarray(noise.index, dtype=np.int64)
        dn = np.asarray(noise.dnoise, dtype=float)
        if index.shape != v.shape or dn.shape != v.shape:
            raise ValueError(f"noise.index and noise.dnoise must have one value per window ({n})")
        if var.ndim != 1 or (index.size and (index.min() < 0 or index.max() >= var.size)):
            raise ValueError("noise.index must point into noise.var")
        fin = np.isfinite(var)
        used = max(float(np.median(var[fin])), 0.0) if fin.any() else float("nan")
        starts, ell = _block_starts(rng, var.size)
        pos = np.full(var.size, -1, dtype=np.int64)
        pos[index] = np.arange(n)
        args, width = (var, pos, dn, used), var.size
    stats = _all_resample_stats(v, starts, ell, args, width=width, threads=_threads(threads))
    if len(shifts):  # pooled over the admissible lags (docs/method.md 3d): every window moves by the lag's shift
        move = np.array([0.0, *shifts], dtype=float)
        stats = tuple(s + move[np.arange(s.size) % move.size] for s in stats)
    b = -(-n // int(np.ceil(n ** (1.0 / 3.0))))
    a = 100.0 * NormalDist().cdf(-math.sqrt(b / (b - 1)) * t_quantile(1.0 - (1.0 - level) / 2.0, b - 1))
    out: Dict[str, Tuple[float, float]] = {}
    for name, values in zip(("median", "mean", "p05", "p95"), stats):
        values = values[np.isfinite(values)]
        if values.size == 0:
            continue
        lo, hi = np.percentile(values, [a, 100.0 - a])
        out[name] = (float(lo), float(hi))
    return out


#: Batches of the batch-means interval (docs/method.md 6e).
BATCHES = 32


def batch_sums(x: np.ndarray, batches: int = BATCHES) -> np.ndarray:
    """The sums of ``x`` (1-D, in time order, not empty) over at most ``batches`` contiguous batches of about
    equal size: the batches of the batch-means standard errors (:func:`ratio_mean`, docs/method.md 6e)."""
    edges = np.unique(np.linspace(0, x.size, min(batches, x.size) + 1).round().astype(np.int64))
    out: np.ndarray = np.add.reduceat(x, edges[:-1])
    return out


def ratio_mean(sums: np.ndarray, counts: np.ndarray, batches: int = BATCHES) -> Tuple[float, float, float, int]:
    """(mean, low, high, batches used): sum(sums) / sum(counts) with its 95 % batch-means interval.

    ``sums`` and ``counts`` are per block in time order; the blocks are
    grouped into at most ``batches`` contiguous batches of about equal
    size; the variance of the ratio mean is the linearised (delta-method)
    batch-means variance B / (B - 1) * sum_g (S_g - m N_g)^2 / N^2 over the
    B batches holding any count, and the interval is m +- t(0.975, B - 1)
    times its root (docs/method.md 6e). No interval from fewer than 3 batches.
    """
    s = np.asarray(sums, dtype=float)
    c = np.asarray(counts, dtype=float)
    total = float(c.sum())
    if total <= 0:
        return float("nan"), float("nan"), float("nan"), 0
    m = float(s.sum()) / total
    sg, cg = batch_sums(s, batches), batch_sums(c, batches)
    keep = cg > 0
    b = int(keep.sum())
    if b < 3:
        return m, float("nan"), float("nan"), b
    z = sg[keep] - m * cg[keep]
    se = math.sqrt(b / (b - 1) * float(np.sum(z * z))) / total
    h = t975(b - 1) * se
    return m, m - h, m + h, b


def batch_mean(values: np.ndarray, batches: int = BATCHES) -> Tuple[float, float, float, int]:
    """(mean, low, high, batches used) of ``values`` in time order (NaN dropped): :func:`ratio_mean` with counts 1."""
    v = np.asarray(values, dtype=float)
    fin = np.isfinite(v)
    return ratio_mean(np.where(fin, v, 0.0), fin.astype(float), batches)


#: Resamples of :func:`bootstrap_ci` and its fixed seed (results are reproducible).
BOOTSTRAP_RESAMPLES = 999


BOOTSTRAP_SEED = 20061136


#: Cells (resamples x windows) :func:`bootstrap_ci` holds at once: its memory does not grow with the recording.
_CHUNK_CELLS = 1 << 18
