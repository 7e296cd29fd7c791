"""Breakaway (static) COF per stroke and stick-slip events (docs/method.md 6c, 6g).

* :func:`breakaway_peak`: the static COF of one stroke, the largest moving
  average of |Ft|/Fn between its motion onset and its central part
  (``tribometer.stroke_table`` calls it for the ``mu_static`` column).
* :func:`stick_slip`: the stick-slip events of a recording (a slow rise of
  the friction force, then a sudden drop), their count, median amplitude
  and frequency, as a :class:`StickSlip`. It reads fy and fz again, once
  (in blocks; the noise of a long recording from a bounded sample), so
  :func:`tribodyn.analyze` stays as cheap as it was.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Iterator, Mapping, Sequence
from typing import Any, Callable, Dict, List, Optional, Tuple, Union

import numpy as np

from ..kernels._order import row_quantiles

__all__ = [
    "StickSlip",
    "find_stick_slip",
]

#: A drop counts when the detrended drop statistic exceeds this many noise SDs (docs/method.md 6g).
K_SIGMA = 5.0
#: A drop statistic above this many noise SDs (but under k) still bounds its neighbours' stick lines.
BOUND_K = 2.5
#: Samples averaged on each side of a drop by the drop statistic.
SMOOTH = 5
#: Samples a drop may take (the gap between the two averages).
DROP_SAMPLES = 3
#: A first difference this many robust SDs below the median is a fall (a drop), left out of the noise.
FALL_SD = 3.5
#: Most samples of each stick line fitted beside a drop.
FIT_MAX = 200
#: The common slope of the two stick lines must be positive by this many standard errors (a rise).
RISE_T = 2.0
#: Stick-slip is "present" from this many events on.
MIN_EVENTS = 3
#: Samples per block read at once (a fixed grid: the result does not depend on a reader's chunks); at most
#: 2^21, so that the stick lines' running integer sums of t^2 fit in int64.
BLOCK = 1 << 20
#: The noise and rise of a longer search come from a sample of this many samples (docs/method.md 6g) ...
SAMPLE = 1 << 20
#: ... in this many evenly spread pieces.
SAMPLE_PIECES = 8


@dataclasses.dataclass(frozen=True)
class StickSlip:
    """The stick-slip of a recording (:func:`stick_slip`; docs/method.md 6g).

    Attributes
    ----------
    events : int
        Stick-slip events: drops of the friction force larger than
        ``threshold`` within ``drop_samples`` samples, after a rise.
    amplitude : float
        Median drop (N): the offset between the stick lines before and after each drop.
    amplitude_cof : float
        Median drop over the mean normal force beside it (COF units).
    frequency : float
        1 / the median interval between consecutive events of one stroke
        (one run of contact) (Hz); NaN when no stroke holds two events.
    rate : float
        Events per second of the time searched (``duration``).
    times : ndarray
        Time of each drop (s from the recording's start).
    drops : ndarray
        Each event's drop (N).
    noise : float
        Noise SD of the friction signal (N): robust SD of its sample-to-sample differences / sqrt 2.
    threshold : float
        ``k`` x ``noise`` (N).
    duration : float
        Time searched (s): the strokes' central parts, or the samples in contact.
    present : bool
        At least :data:`MIN_EVENTS` events.
    verdict : str
        One line: "stick-slip present: N events, amplitude ..., frequency ..." or why not.
    scope : str
        What was searched.
    """

    events: int
    amplitude: float
    amplitude_cof: float
    frequency: float
    rate: float
    times: np.ndarray
    drops: np.ndarray
    noise: float
    threshold: float
    duration: float
    present: bool
    verdict: str
    scope: str

    def __str__(self) -> str:
        return self.verdict

    def to_dict(self) -> Dict[str, Any]:
        """JSON-ready fields (NaN as None), without the per-event ``times`` and ``drops``."""

        def num(v: float) -> Optional[float]:
            return float(v) if np.isfinite(v) else None

        return {
            "events": self.events,
            "amplitude": num(self.amplitude),
            "amplitude_cof": num(self.amplitude_cof),
            "frequency": num(self.frequency),
            "rate": num(self.rate),
            "noise": num(self.noise),
            "threshold": num(self.threshold),
            "duration": num(self.duration),
            "present": self.present,
            "verdict": self.verdict,
            "scope": self.scope,
        }


# -- reading ----------------------------------------------------------------------------------------------


def _reader(source: Any, open_options: Optional[Mapping[str, Any]]
            ) -> Tuple[Callable[[int, int], Dict[str, np.ndarray]], int, Callable[[], None]]:  # fmt: skip
    """(read(a, b) -> {"fy", "fz"}, n_samples, close) for a mapping, a list of acquisitions, a recording or a path."""
    if isinstance(source, Mapping):
        data = {r: np.asarray(source[r], dtype=float) for r in ("fy", "fz")}
        return (lambda a, b: {r: v[a:b] for r, v in data.items()}), int(data["fz"].size), (lambda: None)
    if isinstance(source, (list, tuple)):
        data = {r: np.concatenate([np.asarray(p[r], dtype=float) for p in source]) for r in ("fy", "fz")}
        return (lambda a, b: {r: v[a:b] for r, v in data.items()}), int(data["fz"].size), (lambda: None)
    if isinstance(source, Iterator):
        raise ValueError("stick_slip reads the recording again: pass a mapping, a recording or a path, not a stream")
    from ..io import Recording, open_recording

    rec = source if isinstance(source, Recording) else None
    close: Callable[[], None] = lambda: None  # noqa: E731
    if rec is None:
        if not isinstance(source, (str, os.PathLike)):
            raise TypeError(f"stick_slip: unsupported source {type(source).__name__}")
        rec = open_recording(source, **dict(open_options or {}))
        close = rec.close

    def read(a: int, b: int) -> Dict[str, np.ndarray]:
        parts = list(rec.chunks(max(1, b - a), ["fy", "fz"], start=a, stop=b))
        return {r: np.concatenate([p[r] for p in parts]) if parts else np.zeros(0) for r in ("fy", "fz")}

    return read, int(rec.n_samples), close


# -- the friction signal ------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class _Segments:
    """Where to search: per segment (a stroke's central part or the whole range) its bounds, sign and COF."""

    start: np.ndarray  # first sample
    stop: np.ndarray  # sample after
    sign: np.ndarray  # friction = sign (fy - tare)
    mu: np.ndarray  # the COF subtracted (NaN: a median per second of samples, unidirectional)
    per_second: int  # samples of a unidirectional test's COF block
    min_fn: float
    tare_fy: float
    tare_fz: float


def _signal(seg: _Segments, a: int, b: int, fy: np.ndarray, fz: np.ndarray, *, orientation: float
            ) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """(r, fn, label, friction) over samples a..b: r = friction - mu Fn (N; NaN out of the segments or of
    contact), Fn = |fz - tare|, label = the segment's index (-1 outside), friction = sign (fy - tare).

    Subtracting mu Fn removes what the normal force explains (a dynamic load), leaving the friction's own
    rises and drops (docs/method.md 6g).
    """
    n = b - a
    fn = np.abs(fz - seg.tare_fz)
    label = np.full(n, -1, dtype=np.int64)
    sgn = np.zeros(n)
    mu = np.full(n, np.nan)
    lo = np.searchsorted(seg.stop, a, side="right")
    hi = np.searchsorted(seg.start, b, side="left")
    for k in range(lo, hi):
        s0, s1 = max(int(seg.start[k]), a) - a, min(int(seg.stop[k]), b) - a
        if s1 > s0:
            label[s0:s1] = k
            sgn[s0:s1] = seg.sign[k] * orientation
            mu[s0:s1] = seg.mu[k]
    y = sgn * (fy - seg.tare_fy)
    with np.errstate(invalid="ignore"):
        inside = (label >= 0) & (fn >= seg.min_fn) & (fn > 0) & np.isfinite(y)
    if np.isnan(mu[label >= 0]).any():
        # unidirectional: the median |Ft|/Fn of each second of the fixed grid, interpolated linearly between
        # their centres (a step between two seconds would be a drop of the signal)
        centres, values = _second_medians(a, b, y, fn, inside, p=seg.per_second)
        if values.size:
            mu = np.where(label >= 0, np.interp(np.arange(n), centres, values), np.nan)
    r = np.where(inside, y - mu * fn, np.nan)
    label[~inside] = -1
    return r, fn, label, y


def _second_medians(a: int, b: int, y: np.ndarray, fn: np.ndarray, inside: np.ndarray, *, p: int
                    ) -> Tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """(centre, median F / Fn) of each second of the fixed grid (p samples from sample 0) that holds samples
    of a..b inside; centres in samples from a (the second's part within a..b)."""
    c0 = (a // p) * p
    rows = -(-(b - c0) // p)
    ratio = np.full(rows * p, np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio[a - c0 : b - c0] = np.where(inside, y / fn, np.nan)
    med, _ = row_quantiles(ratio.reshape(rows, p), [])  # (np.median of each second's samples, bit for bit)
    starts = np.maximum(c0 + p * np.arange(rows), a) - a
    stops = np.minimum(c0 + p * np.arange(1, rows + 1), b) - a
    has = _inside_any(inside, starts, stops)
    return (0.5 * (starts + stops - 1))[has], med[has]


def _inside_any(inside: np.ndarray, starts: np.ndarray, stops: np.ndarray) -> np.ndarray:
    """Whether each range starts[j]..stops[j] of ``inside`` holds a True."""
    cum = np.concatenate([[0], np.cumsum(inside)])
    return np.asarray(cum[stops] > cum[starts])


# -- detection ----------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class _Events:
    """Events as columns: the sample after each drop (global), its drop (N), the mean normal force beside it (N)
    and its segment's index."""

    index: np.ndarray
    drop: np.ndarray
    fn: np.ndarray
    label: np.ndarray

    @staticmethod
    def none() -> "_Events":
        return _Events(np.zeros(0, np.int64), np.zeros(0), np.zeros(0), np.zeros(0, np.int64))

    @staticmethod
    def concat(parts: Sequence["_Events"]) -> "_Events":
        if not parts:
            return _Events.none()
        return _Events(*(np.concatenate([getattr(p, f) for p in parts]) for f in ("index", "drop", "fn", "label")))

    def where(self, keep: np.ndarray) -> "_Events":
        return _Events(self.index[keep], self.drop[keep], self.fn[keep], self.label[keep])

    def __len__(self) -> int:
        return int(self.index.size)


def _drop_statistic(r: np.ndarray, label: np.ndarray, slope: float, drop_samples: int
                    ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """(i, g, ok): g_i = mean(r[i-L:i]) - mean(r[i+D:i+D+L]) + slope (L + D), the fall across samples i..i+D
    net of the stick's rise (L = :data:`SMOOTH`, D = ``drop_samples``); ok where both averages are whole and
    in one segment (docs/method.md 6g)."""
    n, L, D = r.size, SMOOTH, drop_samples
    fin = np.isfinite(r)
    c = np.concatenate([[0.0], np.cumsum(np.where(fin, r, 0.0))])
    cnt = np.concatenate([[0], np.cumsum(fin)])
    m = max(0, n - D - 2 * L + 1)  # positions i = L .. L + m - 1
    i = np.arange(L, L + m)
    a0, a1, b0, b1 = slice(0, m), slice(L, L + m), slice(L + D, L + D + m), slice(2 * L + D, 2 * L + D + m)
    ok = ((cnt[a1] - cnt[a0]) == L) & ((cnt[b1] - cnt[b0]) == L)
    ok &= (label[0:m] == label[L + D + L - 1 : L + D + L - 1 + m]) & (label[0:m] >= 0)
    g = (c[a1] - c[a0] - (c[b1] - c[b0])) / L + slope * (L + D)
    return i, g, ok


def _noise(r: np.ndarray, label: np.ndarray, drop_samples: int) -> Optional[Tuple[float, float]]:
    """(noise SD, rise per sample) of the friction signal r, or None with fewer than 10 differences (6g).

    Falls: first differences (within a segment) below their median by more than :data:`FALL_SD` robust
    SDs (the drops). White noise: the robust SD of the other differences / sqrt 2. Rise and coloured noise from
    the drop statistic g (without the rise) where neither average holds a fall: rise = -median(g) /
    (L + D), and sqrt(L / 2) x robust SD(g) is the white-noise SD that its spread implies (coloured
    noise spreads g more than its differences tell). The noise SD is the larger of the two.
    """
    L, D = SMOOTH, drop_samples
    d = np.diff(r)
    valid = (label[1:] == label[:-1]) & (label[1:] >= 0) & np.isfinite(d)
    diffs = d[valid]
    if diffs.size < 10:
        return None
    centre = float(np.median(diffs))
    falls = valid & (d < centre - FALL_SD * 1.4826 * float(np.median(np.abs(diffs - centre))))
    calm = diffs[~falls[valid]]
    white = 1.4826 * float(np.median(np.abs(calm - np.median(calm)))) / np.sqrt(2.0)
    i, g, ok = _drop_statistic(r, label, 0.0, D)
    nf = np.concatenate([[0], np.cumsum(falls)])  # falls among the differences m .. : nf[m1] - nf[m0]
    clean = ok & ((nf[i + D + L - 1] - nf[i - L]) == 0)
    if clean.sum() < 10:
        return white, float(np.median(calm))
    gc = g[clean]
    mid = float(np.median(gc))
    coloured = 1.4826 * float(np.median(np.abs(gc - mid))) * np.sqrt(L / 2.0)
    return max(white, coloured), -mid / (L + D)


def _candidates(r: np.ndarray, i: np.ndarray, g: np.ndarray, ok: np.ndarray, *, sigma: float, k: float,
                drop_samples: int) -> Tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """(the drop's sample of each candidate, whether it is strong: g > k sigma), in order (docs/method.md 6g).

    Each run of consecutive positions with g > min(k, BOUND_K) sigma gives one candidate at its (first)
    maximum; its drop's sample is the largest single fall among the samples the statistic saw there (near a
    segment's edge the statistic may see a drop in one of its averages, not in its gap). Consecutive runs that
    name the same sample are one candidate, strong when any of them is.
    """
    L, D = SMOOTH, drop_samples
    idx = np.flatnonzero(ok & (g > min(k, BOUND_K) * sigma))
    if idx.size == 0:
        return np.zeros(0, np.int64), np.zeros(0, bool)
    first = np.concatenate([[0], np.flatnonzero(np.diff(idx) > 1) + 1])  # each run's first position in idx
    gi = g[idx]
    run = np.repeat(np.arange(first.size), np.diff(np.append(first, idx.size)))
    top = gi == np.maximum.reduceat(gi, first)[run]
    _, at_top = np.unique(run[top], return_index=True)  # each run's first maximum (np.argmax's)
    peaks = idx[np.flatnonzero(top)[at_top]]
    ci = i[peaks]
    # the samples ci - L .. ci + D + L - 1 (inside r: i runs from L to r.size - D - L)
    falls = np.diff(r[ci[:, None] + np.arange(-L, D + L)[None, :]], axis=1)
    seen = np.isfinite(falls).any(axis=1)
    at = np.where(seen, ci - L + 1 + np.argmin(np.where(np.isnan(falls), np.inf, falls), axis=1), ci)
    strong = g[peaks] > k * sigma
    new = np.concatenate([[True], at[1:] != at[:-1]])  # a run naming the previous run's sample joins it
    starts = np.flatnonzero(new)
    return at[starts], np.logical_or.reduceat(strong, starts)


def _detect(r: np.ndarray, fn: np.ndarray, label: np.ndarray, offset: int, *, sigma: float, slope: float,
            k: float, drop_samples: int) -> _Events:  # fmt: skip
    """The events of samples ``offset`` .. ``offset + len(r)`` (docs/method.md 6g)."""
    n, L, D = r.size, SMOOTH, drop_samples
    if n < 2 * L + D or not (sigma > 0):
        return _Events.none()
    i, g, ok = _drop_statistic(r, label, slope, D)
    if not (ok & (g > k * sigma)).any():
        return _Events.none()
    cands, strong = _candidates(r, i, g, ok, sigma=sigma, k=k, drop_samples=D)
    # segment bounds of each sample: a run of one label
    change = np.flatnonzero(np.diff(label) != 0) + 1
    starts = np.concatenate([[0], change])
    stops = np.concatenate([change, [n]])
    edge = L + D - 1  # a drop this near a segment's edge may go unseen: no stick line reaches into it
    s = np.searchsorted(starts, cands, side="right") - 1
    # the stick lines: before the slip (at most D steps, one of them at) and after it, up to the neighbours
    prev = np.concatenate([[0], cands[:-1] + D - 1])
    nxt = np.concatenate([cands[1:] - D + 1, [n]])
    p0 = np.maximum.reduce([cands - D + 1 - FIT_MAX, starts[s] + edge, prev])
    q1 = np.minimum.reduce([cands + D - 1 + FIT_MAX, stops[s] - edge, nxt])
    j = np.flatnonzero(strong)
    drop, beside = _stick_lines(r, fn, cands[j], p0[j], q1[j], sigma=sigma, drop_samples=D)
    at = cands[j]
    keep = np.isfinite(drop)
    return _Events(offset + at[keep], drop[keep], beside[keep], label[at[keep]].astype(np.int64))


def _stick_lines(r: np.ndarray, fn: np.ndarray, at: np.ndarray, p0: np.ndarray, q1: np.ndarray, *, sigma: float,
                 drop_samples: int) -> Tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """(drop, mean Fn beside it) of each candidate from its two stick lines (docs/method.md 6g); NaN where it is
    no event: fewer than L finite samples on a side, or no rise by RISE_T standard errors.

    The stick before the slip is samples p0 .. at - D, the one after it at + D - 1 .. q1 - 1; their finite
    samples are fitted by two parallel lines (a common slope). Every candidate's sums come from running sums
    over the block: of 1, t and t^2 in integers (exact), of r, t r and Fn in floats (r is centred by the COF
    subtracted, so t r's running sum stays small: the drops agree with a direct fit of each line to about
    1e-9 relative, docs/method.md 6g).
    """
    D = drop_samples
    if r.size >= 3_000_000:  # sum of t^2 over the block < 2^63 (BLOCK <= 2^21 with its margins)
        raise ValueError(f"stick-slip blocks hold at most 3e6 samples, got {r.size}")
    fin = np.isfinite(r)
    t = np.arange(r.size, dtype=np.int64)
    rz = np.where(fin, r, 0.0)

    def running(x: np.ndarray) -> np.ndarray:
        return np.concatenate([np.zeros(1, x.dtype), np.cumsum(x)])

    sums = [running(v) for v in (fin.astype(np.int64), np.where(fin, t, 0), np.where(fin, t * t, 0))]
    sums += [running(v) for v in (rz, t * rz, np.where(fin, fn, 0.0))]

    def side(lo: np.ndarray, hi: np.ndarray) -> Tuple[np.ndarray, ...]:
        hi = np.maximum(lo, hi)
        c, st, stt, sy, sty, sfn = (x[hi] - x[lo] for x in sums)
        n = np.maximum(c, 1)
        sxx = (n * stt - st * st) / n  # (integers: exact)
        return c, st / n, sy / n, sxx, sty - st * (sy / n), sfn

    c_pre, m_pre, y_pre, sxx_pre, sxy_pre, fn_pre = side(p0, at - D + 1)
    c_post, m_post, y_post, sxx_post, sxy_post, fn_post = side(at + D - 1, q1)
    sxx, sxy = sxx_pre + sxx_post, sxy_pre + sxy_post
    with np.errstate(invalid="ignore", divide="ignore"):
        b = sxy / sxx  # the common slope of the two stick lines
        rose = (c_pre >= SMOOTH) & (c_post >= SMOOTH) & (sxx > 0) & (b * np.sqrt(sxx) >= RISE_T * sigma)
        drop = (y_pre - y_post) + b * (m_post - m_pre)  # the parallel lines' offset (a step, a fall: no event)
    beside = (fn_pre + fn_post) / np.maximum(c_pre + c_post, 1)
    return np.where(rose, drop, np.nan), np.where(rose, beside, np.nan)


def _segments(params: Mapping[str, Any], strokes: Optional[Mapping[str, np.ndarray]], n: int,
              fraction: Optional[float]) -> Tuple[_Segments, str]:  # fmt: skip
    """The segments searched: each stroke's central part, or the analysed range in contact (``params``: an
    analysis' ``Results.params``)."""
    p = params
    fs = float(p["fs"])
    tare = p.get("tare_offsets") or {}
    min_fn = float(p.get("min_fn") or 0.0)
    tare_fy, tare_fz = float(tare.get("fy", 0.0)), float(tare.get("fz", 0.0))
    st = strokes
    if st is not None and len(st.get("mu", [])):
        frac = float(p.get("stroke_fraction", 0.5) if fraction is None else fraction)
        if not (0 < frac <= 1):
            raise ValueError(f"fraction must be in (0, 1], got {fraction!r}")
        a = np.asarray(st["start"], dtype=np.int64)
        b = np.asarray(st["stop"], dtype=np.int64)
        m = b - a
        c0 = a + np.round(m * (1 - frac) / 2).astype(np.int64)
        c1 = np.maximum(c0 + 1, a + np.round(m * (1 + frac) / 2).astype(np.int64))
        mu = np.asarray(st["mu"], dtype=float)
        keep = np.isfinite(mu)
        seg = _Segments(c0[keep], c1[keep], np.asarray(st["direction"], dtype=float)[keep], mu[keep],
                        max(100, round(fs)), min_fn, tare_fy, tare_fz)  # fmt: skip
        return seg, f"the central {frac:g} of each stroke"
    a0 = int(p.get("start") or 0)
    b0 = int(p["stop"]) if p.get("stop") is not None else n
    seg = _Segments(np.array([a0]), np.array([b0]), np.array([1.0]), np.array([np.nan]), max(100, round(fs)),
                    min_fn, tare_fy, tare_fz)  # fmt: skip
    return seg, "the samples in contact"


def _check(k: float, drop_samples: int) -> None:
    if not (np.isfinite(k) and k > 0):
        raise ValueError(f"k must be > 0, got {k!r}")
    if not (isinstance(drop_samples, (int, np.integer)) and 1 <= drop_samples <= 100):
        raise ValueError(f"drop_samples must be an int in 1..100, got {drop_samples!r}")


def _not_assessed(why: str, scope: str = "nothing", duration: float = 0.0) -> StickSlip:
    nan = float("nan")
    return StickSlip(0, nan, nan, nan, nan, np.zeros(0), np.zeros(0), nan, nan, duration, False, why, scope)


#: Why a recording without the forces' static level is not searched.
NO_STATIC = ("stick-slip not assessed: fz carries no static level (high-passed forces), so the friction force's "
             "level and sign are unknown")  # fmt: skip


def find_stick_slip(
    source: Any,
    res: Any,
    *,
    k: float = K_SIGMA,
    drop_samples: int = DROP_SAMPLES,
    fraction: Optional[float] = None,
    open_options: Optional[Mapping[str, Any]] = None,
) -> StickSlip:
    """Stick-slip events of ``source`` given its analysis ``res`` (docs/method.md 6g): what
    :func:`tribodyn.stick_slip` returns; the analysis' own result when it holds one and the options are the
    defaults, else fy and fz read again in blocks."""
    _check(k, drop_samples)
    found = getattr(res, "stick_slip", None)
    if isinstance(found, StickSlip) and k == K_SIGMA and drop_samples == DROP_SAMPLES and fraction is None:
        return found
    if not res.params.get("static_fz"):
        return _not_assessed(NO_STATIC)
    read, n, close = _reader(source, open_options)
    try:
        search = _Search.of(res.params, res.strokes, n, fraction, k=k, drop_samples=drop_samples)
        return search.run(read)
    finally:
        close()


@dataclasses.dataclass(frozen=True)
class _Search:
    """One recording's search (docs/method.md 6g): where, in which blocks, and the sample of pass 1."""

    seg: _Segments
    scope: str
    spans: List["_Span"]
    first: List["_Span"]  # pass 1's blocks: every block of a short search, else the sample's pieces
    fs: float
    k: float
    drop_samples: int

    @staticmethod
    def of(params: Mapping[str, Any], strokes: Optional[Mapping[str, np.ndarray]], n: int,
           fraction: Optional[float], *, k: float, drop_samples: int) -> "_Search":  # fmt: skip
        seg, scope = _segments(params, strokes, n, fraction)
        spans = _spans(seg, n, drop_samples)
        lo, hi = _extent(seg, n)
        piece = max(SAMPLE // SAMPLE_PIECES, 4 * seg.per_second)  # (at least 4 s of the COF grid)
        whole = len(spans) == 1 or hi - lo <= SAMPLE_PIECES * piece
        first = spans if whole else _sample_spans(seg, lo, hi, m=piece, n=n, drop_samples=drop_samples)
        return _Search(seg, scope, spans, first, float(params["fs"]), float(k), int(drop_samples))

    @property
    def whole(self) -> bool:
        """Pass 1 reads every block (a short search)."""
        return self.first is self.spans

    def noise(self, fetch: Callable[["_Span"], Dict[str, np.ndarray]], *, every_block: bool = True
              ) -> Union[Tuple[float, float, float], StickSlip, None]:  # fmt: skip
        """Pass 1: (noise SD, rise per sample, the recording's sign), or why it is not assessed. A sample that
        met no contact is estimated again from every block (None instead when ``every_block`` is False)."""
        D = self.drop_samples
        est = [_block_noise(self.seg, s, fetch(s), D) for s in self.first]
        if not self.whole and all(e is None for e, _, _ in est):  # the sample met no contact: every block
            if not every_block:
                return None
            est = [_block_noise(self.seg, s, fetch(s), D) for s in self.spans]
        sigmas = [e[0] for e, _, _ in est if e is not None]
        slopes = [e[1] for e, _, _ in est if e is not None]
        if not sigmas:
            duration = sum(u for _, _, u in est) / self.fs  # pass 1 read every block here
            return _not_assessed(f"stick-slip not assessed: fewer than 10 samples in contact in {self.scope}",
                                 self.scope, duration)  # fmt: skip
        orientation = 1.0 if sum(y for _, y, _ in est) >= 0 else -1.0
        return float(np.median(sigmas)), float(np.median(slopes)), orientation

    def block(self, span: "_Span", d: Dict[str, np.ndarray], orientation: float, sigma: float, slope: float
              ) -> Tuple[_Events, float, int]:  # fmt: skip
        """Pass 2 over one block: (events, sum of the friction force, samples in contact)."""
        return _search_block(self.seg, span, d, orientation, sigma=sigma, slope=slope, k=self.k,
                             drop_samples=self.drop_samples)  # fmt: skip

    def summary(self, found: List[Tuple[_Events, float, int]], orientation: float, sigma: float, slope: float,
                fetch: Callable[["_Span"], Dict[str, np.ndarray]]) -> StickSlip:  # fmt: skip
        """The recording's result from pass 2's blocks; a sample whose sign is not the recording's (friction
        changing sign) is searched again with the recording's."""
        events = _Events.concat([f[0] for f in found])
        signsum, used = sum(f[1] for f in found), sum(f[2] for f in found)
        if (1.0 if signsum >= 0 else -1.0) != orientation:
            events = _Events.concat([self.block(s, fetch(s), -orientation, sigma, slope)[0] for s in self.spans])
        return _summarise(events, sigma=sigma, k=self.k, duration=used / self.fs, fs=self.fs, scope=self.scope)

    def run(self, read: Callable[[int, int], Dict[str, np.ndarray]]) -> StickSlip:
        """Both passes, reading with ``read(a, b)``: a search of one block reads it once for both."""
        kept: Dict[Tuple[int, int], Dict[str, np.ndarray]] = {}

        def fetch(span: _Span) -> Dict[str, np.ndarray]:
            if len(self.spans) == 1:  # one block: read once for both passes
                if span.read not in kept:
                    kept[span.read] = read(*span.read)
                return kept[span.read]
            return read(*span.read)

        got = self.noise(fetch)  # (every block when the sample met no contact: never None)
        if isinstance(got, StickSlip):
            return got
        assert got is not None
        sigma, slope, orientation = got
        found = [self.block(s, fetch(s), orientation, sigma, slope) for s in self.spans]
        return self.summary(found, orientation, sigma, slope, fetch)


class ReadingPass:
    """Stick-slip found in the analysis' own reading (``analyze(stick_slip=True)``, docs/method.md 6g).

    Built before the main pass: the noise and rise of a long search come from
    their sample then (read through ``read``), a short search keeps its
    blocks. The main pass then hands over every chunk of raw fy, fz in order
    (:meth:`push`, as :class:`tribodyn.pipeline.headline.BlockSums`); each block is
    searched when its last sample has arrived and dropped. :meth:`result` is
    bitwise the result of :func:`stick_slip` reading the recording again;
    None when the chunks did not cover the blocks in order (the caller then
    reads again).
    """

    def __init__(self, search: _Search, read: Callable[[int, int], Dict[str, np.ndarray]]) -> None:
        self.search, self.read = search, read
        self._next = search.spans[0].read[0] if search.spans else 0  # the next sample expected
        self._pieces: List[Tuple[int, Dict[str, np.ndarray]]] = []  # samples kept for blocks not yet searched
        self._found: List[Tuple[_Events, float, int]] = []
        self._broken = False
        self._done = 0  # blocks searched
        self._noise: Union[Tuple[float, float, float], StickSlip, None] = None
        if not search.whole:
            self._noise = search.noise(lambda s: read(*s.read), every_block=False)
            self._broken = self._noise is None  # (no contact in the sample: pass 1 reads every block)

    @staticmethod
    def of(params: Mapping[str, Any], source: Any, *, start: int, stop: Optional[int]) -> Optional["ReadingPass"]:
        """The pass of a unidirectional search of ``source`` (a mapping or a recording) with the defaults of
        :func:`stick_slip`, for a main pass over samples ``start``..``stop``; None when its blocks reach outside
        them (their margins: the recording is then read again)."""
        read, n, _ = _reader(source, None)  # (a mapping or a recording: nothing to close)
        search = _Search.of(params, None, n, None, k=K_SIGMA, drop_samples=DROP_SAMPLES)
        end = n if stop is None else min(int(stop), n)
        if not search.spans or search.spans[0].read[0] < start or search.spans[-1].read[1] > end:
            return None
        return ReadingPass(search, read)

    def push(self, first: int, piece: Mapping[str, np.ndarray]) -> None:
        """Samples ``first``.. of raw fy, fz, in order."""
        if self._broken or self._done == len(self.search.spans):
            return
        a, b = max(first, self._next), min(first + len(piece["fz"]), self.search.spans[-1].read[1])
        if b <= a:
            return
        if first > self._next:  # a gap: read again instead
            self._broken = True
            self._pieces = []
            return
        self._pieces.append((a, {r: np.asarray(piece[r][a - first : b - first]) for r in ("fy", "fz")}))
        self._next = b
        if isinstance(self._noise, tuple):
            self._search_ready()

    def _take(self, a: int, b: int) -> Dict[str, np.ndarray]:
        """Samples a..b of the pieces kept."""
        parts = [(s, d) for s, d in self._pieces if s < b and s + len(d["fz"]) > a]
        return {r: np.concatenate([d[r][max(0, a - s) : b - s] for s, d in parts]) for r in ("fy", "fz")}

    def _search_ready(self) -> None:
        assert isinstance(self._noise, tuple)
        sigma, slope, orientation = self._noise
        spans = self.search.spans
        while self._done < len(spans) and spans[self._done].read[1] <= self._next:
            span = spans[self._done]
            self._found.append(self.search.block(span, self._take(*span.read), orientation, sigma, slope))
            self._done += 1
            keep_from = spans[self._done].read[0] if self._done < len(spans) else self._next
            self._pieces = [(s, d) for s, d in self._pieces if s + len(d["fz"]) > keep_from]

    def result(self) -> Optional[StickSlip]:
        """The stick-slip of the recording, or None when the chunks missed samples of its blocks."""
        spans = self.search.spans
        if self._broken or (spans and self._next < spans[-1].read[1]):
            return None
        if self.search.whole:  # a short search: both passes over the blocks kept
            return self.search.run(self._take)
        if isinstance(self._noise, StickSlip):
            return self._noise
        assert isinstance(self._noise, tuple)
        sigma, slope, orientation = self._noise
        return self.search.summary(self._found, orientation, sigma, slope, lambda s: self.read(*s.read))


@dataclasses.dataclass(frozen=True)
class _Span:
    """A block searched (``own``: the samples whose events it counts) and the samples read for it (``read``)."""

    own: Tuple[int, int]
    read: Tuple[int, int]


def _span(seg: _Segments, a: int, b: int, n: int, drop_samples: int) -> _Span:
    """Samples a..b with a margin (whole seconds of the COF grid) so that an event near its edge is seen whole."""
    margin = 2 * (SMOOTH + drop_samples) + FIT_MAX + 2
    p = seg.per_second
    # (one more second each side: the COF interpolated between seconds needs its neighbours)
    return _Span((a, b), (max(0, ((a - margin) // p - 1) * p), min(n, (-(-(b + margin) // p) + 1) * p)))


def _extent(seg: _Segments, n: int) -> Tuple[int, int]:
    """The first sample of the segments and the one after their last (at most n)."""
    lo = int(seg.start.min()) if seg.start.size else 0
    hi = min(n, int(seg.stop.max())) if seg.stop.size else 0
    return lo, hi


def _spans(seg: _Segments, n: int, drop_samples: int) -> List[_Span]:
    """The blocks of :data:`BLOCK` samples, on a grid fixed by the recording, that cover the segments."""
    lo, hi = _extent(seg, n)
    return [_span(seg, a, min(a + BLOCK, hi), n, drop_samples) for a in range((lo // BLOCK) * BLOCK, hi, BLOCK)]


def _sample_spans(seg: _Segments, lo: int, hi: int, *, m: int, n: int, drop_samples: int) -> List[_Span]:
    """Pass 1's sample of samples lo..hi (more than :data:`SAMPLE_PIECES` x m): SAMPLE_PIECES pieces of m
    samples, centred at lo + (j + 1/2) (hi - lo) / SAMPLE_PIECES (docs/method.md 6g)."""
    centres = [lo + ((2 * j + 1) * (hi - lo)) // (2 * SAMPLE_PIECES) for j in range(SAMPLE_PIECES)]
    return [_span(seg, c - m // 2, c - m // 2 + m, n, drop_samples) for c in centres]


def _block_noise(seg: _Segments, span: _Span, d: Dict[str, np.ndarray], drop_samples: int
                 ) -> Tuple[Optional[Tuple[float, float]], float, int]:  # fmt: skip
    """(noise SD and rise per sample or None, sum of the friction force, samples in contact) of a block's
    own samples, with the block's own sign (docs/method.md 6g)."""
    (a, b), (ra, rb) = span.own, span.read
    own = slice(a - ra, b - ra)
    r, fn, label, y = _signal(seg, ra, rb, d["fy"], d["fz"], orientation=1.0)
    inside = label[own] >= 0
    ysum = float(np.sum(y[own][inside]))
    if ysum < 0:
        r, fn, label, y = _signal(seg, ra, rb, d["fy"], d["fz"], orientation=-1.0)
    return _noise(r[own], label[own], drop_samples), ysum, int(inside.sum())


def _search_block(seg: _Segments, span: _Span, d: Dict[str, np.ndarray], orientation: float, *, sigma: float,
                  slope: float, k: float, drop_samples: int) -> Tuple[_Events, float, int]:  # fmt: skip
    """(events, sum of the friction force, samples in contact) of one block's own samples."""
    (a, b), (ra, rb) = span.own, span.read
    r, fn, label, y = _signal(seg, ra, rb, d["fy"], d["fz"], orientation=orientation)
    inside = label[a - ra : b - ra] >= 0
    signsum = orientation * float(np.sum(y[a - ra : b - ra][inside]))
    found = _detect(r, fn, label, ra, sigma=sigma, slope=slope, k=k, drop_samples=drop_samples)
    return found.where((found.index >= a) & (found.index < b)), signsum, int(inside.sum())


def _summarise(events: _Events, *, sigma: float, k: float, duration: float, fs: float, scope: str) -> StickSlip:
    """The recording's numbers and verdict from its events (docs/method.md 6g)."""
    events = events.where(np.argsort(events.index, kind="stable"))
    times = (events.index - 0.5) / fs
    drops = events.drop
    cofs = (events.drop / events.fn)[events.fn > 0]
    idx, lab = events.index, events.label
    pair = (lab[1:] == lab[:-1]) & (idx[1:] > idx[:-1])  # consecutive events of one segment
    intervals = (idx[1:] - idx[:-1])[pair] / fs
    nan = float("nan")
    amp = float(np.median(drops)) if drops.size else nan
    amp_cof = float(np.median(cofs)) if cofs.size else nan
    freq = nan
    if intervals.size:  # the mean of the intervals near their median: robust to a missed event, finer than samples
        iv = np.asarray(intervals)
        med = float(np.median(iv))
        freq = 1.0 / float(np.mean(iv[np.abs(iv - med) <= 0.25 * med]))
    rate = len(events) / duration if duration > 0 else nan
    present = len(events) >= MIN_EVENTS
    thr = k * sigma
    if present:
        f_text = f"frequency {freq:.4g} Hz" if np.isfinite(freq) else "frequency unknown (no stroke holds two events)"
        verdict = (
            f"stick-slip present: {len(events)} events, amplitude {amp:.3g} N ({amp_cof:.3g} in COF units), "
            f"{f_text} ({rate:.3g} events/s over {duration:.4g} s of {scope})"
        )
    else:
        verdict = (
            f"no stick-slip: {len(events)} drop{'s' if len(events) != 1 else ''} after a rise larger than "
            f"{k:g} noise SDs ({thr:.3g} N) in {duration:.4g} s of {scope}"
        )
    return StickSlip(len(events), amp, amp_cof, freq, rate, times, drops, sigma, thr, duration, present, verdict,
                     scope)  # fmt: skip
