"""The COF against a covariate that sweeps faster than a window: per sample, binned (docs/method.md 7b).

A traction curve of a slide-roll sweep (6-7 s per sweep) or the Stribeck curve of a speed ramp changes its
covariate within one window of the analysis: a window's COF is a mean over a span of the covariate, and the
per-window curve (``operating_range``, Sec. 7-7a) averages the dependence away. :func:`cof_curve` pools instead
every sample in contact by the covariate's value at that sample: each sample's classical COF |fy - tare_y| /
|fz - tare_z| (the analysis's contact threshold and tare, Sec. 6a) goes to the bin of the covariate (a log
interpolated at the sample's time, or a channel of the recording); a bin's COF is the mean over its samples,
its interval the batch-means interval (:func:`tribodyn.kernels.stats.ratio_mean`) over its *visits* (each run
of consecutive samples inside the bin, in time order: the sweeps), so that the samples' correlation within a
visit does not narrow it. One reading of fy, fz (and the covariate channel), chunk by chunk.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping
from typing import Any, Dict, Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np

from ..kernels.stats import ratio_mean
from ..pipeline.covariates import as_log

__all__ = ["CofCurve", "cof_curve"]

#: Samples read at once.
CHUNK = 1 << 20


@dataclasses.dataclass(frozen=True)
class CofCurve:
    """The COF against a covariate, per sample, binned (docs/method.md 7b).

    Attributes
    ----------
    covariate : str
        What the bins are of (a log's name, or the channel).
    edges : ndarray
        The bins' edges (``bins + 1``).
    centre, cof, low, high : ndarray
        Per bin: its centre, the mean COF of its samples and the 95 % interval (NaN with fewer than 3 batches of
        visits).
    samples, visits : ndarray
        Per bin: the samples in contact in it, and the runs of consecutive samples (sweeps through it).
    text : str
        One line: what was binned, how.
    """

    covariate: str
    edges: np.ndarray
    centre: np.ndarray
    cof: np.ndarray
    low: np.ndarray
    high: np.ndarray
    samples: np.ndarray
    visits: np.ndarray
    text: str

    def to_dict(self) -> Dict[str, Any]:
        """Plain values (lists; NaN as None) for JSON."""

        def clean(a: np.ndarray) -> List[Any]:
            return [None if not np.isfinite(x) else float(x) for x in np.asarray(a, dtype=float)]

        return {"covariate": self.covariate, "edges": clean(self.edges), "centre": clean(self.centre),
                "cof": clean(self.cof), "low": clean(self.low), "high": clean(self.high),
                "samples": [int(x) for x in self.samples], "visits": [int(x) for x in self.visits],
                "text": self.text}  # fmt: skip

    def __repr__(self) -> str:
        rows = [f"CofCurve({self.text})", f"  {self.covariate:>14}  {'COF':>8}  {'95 % interval':>19}  samples  visits"]
        for c, m, lo, hi, n, v in zip(self.centre, self.cof, self.low, self.high, self.samples, self.visits):
            rows.append(f"  {c:>14.5g}  {m:>8.4f}  {lo:>8.4f} to {hi:<8.4f}  {n:>7d}  {v:>6d}")
        return "\n".join(rows)


def _spec(res: Any) -> Tuple[float, float, float]:
    """(min_fn, tare_fy, tare_fz) of the analysis: the classical COF's contact rule (docs/method.md 6a)."""
    params = getattr(res, "params", {}) or {}
    if "min_fn" not in params:
        raise ValueError(
            "cof_curve needs the classical COF's contact rule: the analysis found no static normal force (raw, "
            "DC-coupled forces); analyse with min_fn= if fz is raw"
        )
    tare = params.get("tare_offsets") or {}
    return float(params["min_fn"]), float(tare.get("fy", 0.0)), float(tare.get("fz", 0.0))


def _chunks(source: Any, roles: Sequence[str], open_options: Mapping[str, Any]) -> Iterator[Dict[str, np.ndarray]]:
    """The source's ``roles``, chunk by chunk: a mapping of arrays, an open recording or a path."""
    if isinstance(source, Mapping):
        arrays = {r: np.asarray(source[r], dtype=float) for r in roles}
        n = len(arrays[roles[0]])
        for a in range(0, n, CHUNK):
            yield {r: v[a : a + CHUNK] for r, v in arrays.items()}
        return
    from ..io import open_recording
    from ..io.constant import is_recording

    if is_recording(source):
        yield from source.chunks(CHUNK, list(roles))
        return
    if not isinstance(source, (str, os.PathLike)):
        raise TypeError(f"cof_curve: unsupported source {type(source).__name__} (a mapping, a recording or a path)")
    with open_recording(source, **dict(open_options)) as rec:
        yield from rec.chunks(CHUNK, list(roles))


def _edges(source: Any, covariate: Any, bins: int, open_options: Mapping[str, Any]) -> np.ndarray:
    """Uniform edges over the covariate's range: the log's values, or one look at the channel's."""
    if isinstance(covariate, str):
        lo, hi = np.inf, -np.inf
        for ch in _chunks(source, [covariate], open_options):
            v = ch[covariate][np.isfinite(ch[covariate])]
            if v.size:
                lo, hi = min(lo, float(v.min())), max(hi, float(v.max()))
    else:
        v = covariate[1]
        lo, hi = float(np.min(v)), float(np.max(v))
    if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
        raise ValueError("cof_curve: the covariate takes a single value (or none): nothing to bin")
    return np.linspace(lo, hi, bins + 1)


def cof_curve(
    source: Any,
    res: Any,
    covariate: Union[str, Tuple[Any, Any]],
    *,
    bins: Union[int, Sequence[float]] = 20,
    name: Optional[str] = None,
    open_options: Optional[Mapping[str, Any]] = None,
) -> CofCurve:
    """The COF against ``covariate`` per sample, binned and pooled over sweeps (docs/method.md 7b).

    Parameters
    ----------
    source : mapping, Recording or path
        The recording ``res`` is the analysis of (read once more, chunk by chunk).
    res : Results
        Its analysis: the contact threshold and tare of the classical COF (``params["min_fn"]``,
        ``params["tare_offsets"]``) and the sampling rate.
    covariate : str or (t_s, values)
        A channel of the source (e.g. ``"v"``, or the slide-roll ratio's column) or a log of times in s from
        the recording's start and values, interpolated at each sample (samples outside the log are left out).
    bins : int or sequence of float
        The number of uniform bins over the covariate's range (default 20), or the edges.
    name : str, optional
        What the covariate is, for the text (default: the channel, or "covariate").
    open_options : mapping, optional
        ``open_recording``'s keywords when ``source`` is a path.

    Returns
    -------
    CofCurve
    """
    opts = dict(open_options or {})
    min_fn, t_y, t_z = _spec(res)
    fs = float(res.params["fs"])
    start = int(res.params.get("start") or 0)
    log = None if isinstance(covariate, str) else as_log(covariate, "covariate")
    if isinstance(bins, (int, np.integer)):
        if bins < 1:
            raise ValueError(f"bins must be >= 1, got {bins}")
        edges = _edges(source, covariate if log is None else log, int(bins), opts)
    else:
        edges = np.asarray(bins, dtype=float)
        if edges.ndim != 1 or edges.size < 2 or not np.all(np.diff(edges) > 0):
            raise ValueError("bins must be an integer or increasing edges (at least two)")
    k = edges.size - 1
    roles = ["fy", "fz"] + ([covariate] if isinstance(covariate, str) else [])
    runs_b: List[np.ndarray] = []  # per run of consecutive samples in one bin (-1: none), in time order
    runs_s: List[np.ndarray] = []  # ... the sum of its samples' COF
    runs_n: List[np.ndarray] = []  # ... and its samples in contact
    at = 0
    for ch in _chunks(source, roles, opts):
        m = len(ch["fy"])
        if m == 0:
            continue
        if log is None:
            x = np.asarray(ch[str(covariate)], dtype=float)
        else:
            x = np.interp((start + at + np.arange(m)) / fs, log[0], log[1], left=np.nan, right=np.nan)
        at += m
        z = ch["fz"] - t_z
        with np.errstate(invalid="ignore"):
            keep = (np.abs(z) >= min_fn) & np.isfinite(x) & (x >= edges[0]) & (x <= edges[-1])
        b = np.where(keep, np.clip(np.searchsorted(edges, x, side="right") - 1, 0, k - 1), -1)
        c = np.where(keep, np.abs(ch["fy"] - t_y) / np.where(keep, np.abs(z), 1.0), 0.0)
        starts = np.concatenate([[0], np.flatnonzero(np.diff(b) != 0) + 1])
        runs_b.append(b[starts])
        runs_s.append(np.add.reduceat(c, starts))
        runs_n.append(np.add.reduceat(keep.astype(float), starts))
    rb = np.concatenate(runs_b) if runs_b else np.zeros(0, dtype=np.int64)
    rs = np.concatenate(runs_s) if runs_s else np.zeros(0)
    rn = np.concatenate(runs_n) if runs_n else np.zeros(0)
    if rb.size:  # a run cut by a chunk's end goes on in the next chunk: one visit
        first = np.concatenate([[0], np.flatnonzero(np.diff(rb) != 0) + 1])
        rb, rs, rn = rb[first], np.add.reduceat(rs, first), np.add.reduceat(rn, first)
    inside = rb >= 0
    vb, vs, vn = rb[inside], rs[inside], rn[inside]
    out = np.full((3, k), np.nan)
    samples = np.zeros(k, dtype=np.int64)
    visits = np.zeros(k, dtype=np.int64)
    for j in range(k):
        sel = vb == j
        if not sel.any():
            continue
        samples[j], visits[j] = int(vn[sel].sum()), int(sel.sum())
        out[:, j] = ratio_mean(vs[sel], vn[sel])[:3]
    label = name or (str(covariate) if isinstance(covariate, str) else "covariate")
    text = (f"classical COF of {int(samples.sum())} samples in contact binned by {label} into {k} bins; "
            "intervals: batch means over each bin's visits (sweeps)")  # fmt: skip
    return CofCurve(label, edges, 0.5 * (edges[:-1] + edges[1:]), out[0], out[1], out[2], samples, visits, text)
