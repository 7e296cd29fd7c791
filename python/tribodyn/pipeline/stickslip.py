"""Stick-slip events (docs/method.md 6g); the breakaway COF per stroke is
``kernels.strokes.breakaway_peak`` (6c).

* :func:`find_stick_slip` (the search behind :func:`tribodyn.stick_slip`): the
  stick-slip events of a recording (a rise of the friction force while the contact sticks, ended by a drop as it slips,
  within a sample or over many; issue 35), their count, median whole drop
  and frequency, as a :class:`StickSlip`. It reads fy and fz again, once
  (in blocks; the noise of a long recording from a bounded sample), so
  :func:`tribodyn.analyze` stays as cheap as it was.
* :class:`ReadingPass`: the same search in the analysis' own reading
  (``analyze(stick_slip=True)``), an optional pass of
  :data:`tribodyn.pipeline.passes.PASSES`: :func:`reading_pass` builds it
  before the main pass, :func:`store` puts its result (else the search
  reading again) in the Results.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Iterator, Mapping, Sequence
from typing import Any, Callable, Dict, List, Optional, Tuple, Union

import numpy as np

from ..kernels._order import row_quantiles
from ..kernels.peaks import find_peaks
from ..results import Results
from .routes import PassInputs, Tap, choose_route

__all__ = [
    "StickSlip",
    "find_stick_slip",
    "ReadingPass",
    "reading_pass",
    "store",
]

#: A drop counts when its whole drop exceeds this many noise SDs (docs/method.md 6g).
K_SIGMA = 5.0
#: ... and this many steps of the export's resolution (a step of the value grid is no event).
Q_STEPS = 3.0
#: Samples averaged by the smoothed signal whose peaks and troughs delimit the falls (and by the noise's
#: drop statistic).
SMOOTH = 5
#: Samples between the two averages of the noise's drop statistic (``drop_samples``).
DROP_SAMPLES = 3
#: A drop may take this fraction of the stick before it at most (a slip is fast next to its stick) ...
SLIP_FRACTION = 0.2
#: ... and at most this many seconds (slips last milliseconds to about 0.1 s); a drop within one sample
#: interval always may (a log sampled more slowly than a slip lasts cannot show it: the drop is a step).
SLIP_MAX_S = 0.25
#: The stick before a drop must have risen by this share of the drop (the force the slip releases).
RISE_SHARE = 0.5
#: Share of a stick left out of its line at each end (the turns into and out of the slips).
MARGIN_SHARE = 0.1
#: Seconds the smoothed signal of the falls averages at least (at high rates: noise's swings within a stick
#: stay under the threshold).
SMOOTH_S = 0.001
#: 20-80 % width of a half-cosine fall (1 - cos(pi u)) / 2 over its duration: (acos(-0.6) - acos(0.6)) / pi.
HALF_COSINE_20_80 = 0.4096655
#: Samples each stick line needs.
MIN_FIT = 3
#: Rounds of merging falls under half the threshold into their sticks (noise's swings within a stick).
PRUNE_ROUNDS = 4
#: A first difference this many robust SDs below the median is a fall (a drop), left out of the noise.
FALL_SD = 3.5
#: The slope of the stick before a drop must be positive by this many standard errors (a rise).
RISE_T = 2.0
#: Seconds of a unidirectional test's COF grid (the COF subtracted, a median per this many seconds) and of
#: the window of the falls' prominence and of the stick lines (a stick-slip cycle up to about half of it).
GRID_S = 5.0
#: The export is quantised when its distinct values are at most this share of its samples.
QUANT_SHARE = 0.5
#: Stick-slip is "present" from this many events on ...
MIN_EVENTS = 3
#: ... whose sticks (each event's stick before it) fill at least this share of the time searched: a regime of
#: stick and slip, not drops far apart (a smooth recording of 2500 s with a low-frequency wander held 3-8).
MIN_STICK_SHARE = 0.05
#: Samples per block read at once (a fixed grid: the result does not depend on a reader's chunks); at most
#: 2^21, so that the stick lines' running integer sums of t^2 fit in int64.
BLOCK = 1 << 20
#: The noise and resolution of a longer search come from a sample of this many samples (docs/method.md 6g) ...
SAMPLE = 1 << 20
#: ... in this many evenly spread pieces.
SAMPLE_PIECES = 8


@dataclasses.dataclass(frozen=True)
class StickSlip:
    """The stick-slip of a recording (:func:`stick_slip`; docs/method.md 6g).

    Attributes
    ----------
    events : int
        Stick-slip events: fast drops of the friction force at least
        ``threshold`` (and the scatter of their sticks' lines) ended by
        each, after a rise (docs/method.md 6g).
    amplitude : float
        Median drop (N): each the whole drop, the stick line before it at
        the drop's start minus the stick line after it at its end.
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
        At least :data:`MIN_EVENTS` events whose sticks fill at least
        :data:`MIN_STICK_SHARE` of ``duration``.
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
    from ..io import open_recording
    from ..io.constant import is_recording

    rec = source if is_recording(source) else None
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
    smooth: int  # samples of the smoothed signal whose peaks and troughs delimit the falls
    fs: float


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
    """Events as columns: the sample after each drop (global), its drop (N), the mean normal force beside it (N),
    its segment's index, the drop's middle (global, in samples: 10.5 between samples 10 and 11) and the stick
    before it (samples)."""

    index: np.ndarray
    drop: np.ndarray
    fn: np.ndarray
    label: np.ndarray
    mid: np.ndarray
    stick: np.ndarray  # samples of the stick before each drop (its visible part where a segment cut it)

    FIELDS = ("index", "drop", "fn", "label", "mid", "stick")

    @staticmethod
    def none() -> "_Events":
        i = np.zeros(0, np.int64)
        return _Events(i, np.zeros(0), np.zeros(0), i, np.zeros(0), i)

    @staticmethod
    def concat(parts: Sequence["_Events"]) -> "_Events":
        if not parts:
            return _Events.none()
        return _Events(*(np.concatenate([getattr(p, f) for p in parts]) for f in _Events.FIELDS))

    def where(self, keep: np.ndarray) -> "_Events":
        return _Events(*(getattr(self, f)[keep] for f in _Events.FIELDS))

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


def _noise(r: np.ndarray, label: np.ndarray, drop_samples: int, quantum: float = 0.0) -> Optional[Tuple[float, float]]:
    """(white noise SD, coloured noise SD) of the friction signal r, or None with fewer than 10 differences
    (docs/method.md 6g).

    Falls: first differences (within a segment) below their median by more than :data:`FALL_SD` spreads (the
    drops; the spread 1.4826 MAD, at least ``quantum``). White noise: the robust SD of the other differences
    / sqrt 2 (their SD / sqrt 2 for a quantised export, ``quantum`` > 0: a MAD of quantised differences moves
    in whole steps). Coloured noise: sqrt(L / 2) x the robust SD of the drop statistic g (without a rise)
    where neither average holds a fall (coloured noise spreads g more than its differences tell), at least
    the white SD.
    """
    L, D = SMOOTH, drop_samples
    d = np.diff(r)
    valid = (label[1:] == label[:-1]) & (label[1:] >= 0) & np.isfinite(d)
    diffs = d[valid]
    if diffs.size < 10:
        return None
    centre = float(np.median(diffs))
    spread = max(1.4826 * float(np.median(np.abs(diffs - centre))), quantum)
    falls = valid & (d < centre - FALL_SD * spread)
    calm = diffs[~falls[valid]]
    if quantum > 0:  # a quantised export: its MAD moves in steps of the grid, the SD does not
        white = float(np.std(calm)) / np.sqrt(2.0)
    else:
        white = 1.4826 * float(np.median(np.abs(calm - np.median(calm)))) / np.sqrt(2.0)
    i, g, ok = _drop_statistic(r, label, 0.0, D)
    nf = np.concatenate([[0], np.cumsum(falls)])  # falls among the differences m .. : nf[m1] - nf[m0]
    clean = ok & ((nf[i + D + L - 1] - nf[i - L]) == 0)
    if clean.sum() < 10:
        return white, white
    gc = g[clean]
    mid = float(np.median(gc))
    coloured = 1.4826 * float(np.median(np.abs(gc - mid))) * np.sqrt(L / 2.0)
    return white, max(white, coloured)


def _quantum(x: np.ndarray) -> float:
    """The resolution of an export: the step of the grid its values lie on (0: not quantised; 6g).

    Values on a grid repeat: when the distinct values are at most half the samples, the step is the median
    gap between consecutive distinct values (a grid partly occupied reads larger: the floor is then the
    safer). Float data (nearly every value distinct) reads 0.
    """
    v = x[np.isfinite(x)]
    if v.size < 20:
        return 0.0
    u = np.unique(v)
    if u.size < 2 or u.size > QUANT_SHARE * v.size:
        return 0.0
    return float(np.median(np.diff(u)))


def _runs(label: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """(start, stop) of each run of one segment's samples (label >= 0), in order."""
    n = label.size
    change = np.flatnonzero(np.diff(label) != 0) + 1
    starts = np.concatenate([[0], change])
    stops = np.concatenate([change, [n]])
    keep = label[starts] >= 0
    return starts[keep], stops[keep]


def _extremes(s: np.ndarray, run: np.ndarray, gate: float, wlen: int) -> Tuple[np.ndarray, np.ndarray]:
    """(index, +1 peak / -1 trough) of the alternating extremes of the smoothed signal s whose prominence
    (within ``wlen`` samples) is at least ``gate``; of consecutive peaks of one run the highest, of troughs the
    lowest. ``s`` holds every run's smoothed signal, each followed by a separator (NaN; ``run`` its run's
    number, -1 at the separators): +inf to the peaks' search and to the troughs', so that no extreme lies at a
    run's edge and no prominence reaches past it (as each run searched alone)."""
    w = max(3, wlen | 1)
    sep = run < 0
    pk = find_peaks(np.where(sep, np.inf, s), prominence=gate, wlen=w)
    tr = find_peaks(np.where(sep, np.inf, -s), prominence=gate, wlen=w)
    pk, tr = pk[~sep[pk]], tr[~sep[tr]]
    at = np.concatenate([pk, tr])
    kind = np.concatenate([np.ones(pk.size, np.int64), -np.ones(tr.size, np.int64)])
    if at.size == 0:
        return at.astype(np.int64), kind
    o = np.argsort(at, kind="stable")
    at, kind = at[o], kind[o]
    first = np.concatenate([[0], np.flatnonzero((np.diff(kind) != 0) | (np.diff(run[at]) != 0)) + 1])
    group = np.repeat(np.arange(first.size), np.diff(np.append(first, at.size)))  # runs of one kind in one run
    score = s[at] * kind  # the highest peak, the lowest trough of each group
    best = score == np.maximum.reduceat(score, first)[group]
    _, pick = np.unique(group[best], return_index=True)
    chosen = np.flatnonzero(best)[pick]
    return at[chosen].astype(np.int64), kind[chosen]


def _detect(r: np.ndarray, fn: np.ndarray, label: np.ndarray, offset: int, *, sigma: float, quantum: float,
            coloured: float, k: float, fs: float, wlen: int, smooth: int) -> _Events:  # fmt: skip
    """The events of samples ``offset`` .. ``offset + len(r)`` (docs/method.md 6g).

    Per run of a segment: r smoothed over L samples; its alternating peaks and troughs whose prominence
    (within ``wlen`` samples) reaches the gate (half the larger of the threshold and k x the coloured noise
    SD); each peak followed by a trough is a fall, from its last sample on the stick (a) to its first after it
    (b). The stick before a fall runs from the previous fall's b (or the run's start + 2 L), the one after it
    to the next fall's a (or the run's end - 2 L); a fall whose whole drop is under the gate and whose swing
    (the smoothed signal at the peak minus at the trough) is under the threshold max(k sigma, Q_STEPS
    quantum) is merged into its sticks (:data:`PRUNE_ROUNDS` rounds). A fall is an event when its whole drop
    (:func:`_falls`) reaches the threshold and k x the scatter about its two stick lines (its swing half that), the
    sticks rose (the stick before rises, their common slope RISE_T standard errors above zero, the stick
    before by at least RISE_SHARE of the drop unless the run cut it) and it was fast: its duration within a
    sample, else at most SLIP_FRACTION of the stick before it and SLIP_MAX_S seconds.
    """
    L = smooth
    thr = max(k * sigma, Q_STEPS * quantum)
    gate = 0.5 * max(k * coloured, thr)  # (coloured noise swings more: fewer falls of noise)
    if not (thr > 0) or r.size < 2 * L:
        return _Events.none()
    starts, stops = _runs(label)
    keep = stops - starts >= 2 * L + 2
    starts, stops = starts[keep], stops[keep]
    if starts.size == 0:
        return _Events.none()
    # every run's mean over L samples (positions j: samples j .. j + L - 1 of one run), each run followed by a
    # separator; from running sums over the block
    m = stops - starts - L + 1
    slot0 = np.cumsum(m + 1) - (m + 1)  # each run's first slot
    run = np.repeat(np.arange(starts.size), m + 1)
    j = np.arange(run.size) - np.repeat(slot0, m + 1) + np.repeat(starts, m + 1)
    run[slot0 + m] = -1  # the separators
    j = np.where(run >= 0, j, 0)
    c = np.concatenate([[0.0], np.cumsum(np.where(np.isfinite(r), r, 0.0))])
    sm = np.where(run >= 0, (c[j + L] - c[j]) / L, np.nan)
    at, kind = _extremes(sm, run, gate, wlen)
    fall = np.flatnonzero((kind[:-1] == 1) & (kind[1:] == -1) & (run[at[:-1]] == run[at[1:]]))
    if fall.size == 0:
        return _Events.none()
    a = j[at[fall]] + L - 1  # the last sample of the window ending at the peak: the stick's last sample
    b = np.maximum(j[at[fall + 1]], a + 1)  # the first sample of the window starting at the trough
    ri = run[at[fall]]
    run0, run1 = starts[ri], stops[ri]
    swing = sm[at[fall]] - sm[at[fall + 1]]  # the smoothed signal at the peak minus at the trough
    for _ in range(PRUNE_ROUNDS):
        f = _falls(r, fn, a, b, run0=run0, run1=run1, wlen=wlen, L=L)
        # a fall whose drop is under the gate and whose swing is under the threshold is part of its stick:
        # merged into it (a real fall's swing stands out even where a neighbour spoils its lines)
        weak = ~(f.drop >= gate) & ~(swing >= thr)
        if not weak.any():
            break
        a, b, run0, run1, swing = a[~weak], b[~weak], run0[~weak], run1[~weak], swing[~weak]
    else:
        f = _falls(r, fn, a, b, run0=run0, run1=run1, wlen=wlen, L=L)
    sig = max(sigma, quantum / np.sqrt(12.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        fitted = (f.pre.count >= MIN_FIT) & (f.post.count >= MIN_FIT) & np.isfinite(f.mid)
        # the sticks rose: the stick before rises, and the common slope of both lines is RISE_T standard errors
        # above zero (both lines: a stick cut by the run's start has few samples)
        sxx = f.pre.sxx + f.post.sxx
        common = (f.pre.slope * f.pre.sxx + f.post.slope * f.post.sxx) / sxx
        rose = (f.pre.slope > 0) & (common * np.sqrt(sxx) >= RISE_T * sig)
        enough = f.cut | (f.pre.slope * f.stick >= RISE_SHARE * f.drop)
        # fast: within a sample (a slip shorter than the sampling), else at most SLIP_FRACTION of the stick and
        # SLIP_MAX_S seconds
        fast = f.tau <= np.maximum(1.0, np.minimum(SLIP_FRACTION * f.stick, SLIP_MAX_S * fs))
        # the scatter about the stick lines: the noise at the sticks' scale (coloured noise, a wander)
        scatter = np.sqrt((f.pre.ss + f.post.ss) / np.maximum(f.pre.count + f.post.count - 4, 1))
        floor = np.maximum(thr, k * scatter)
        ok = fitted & rose & enough & fast & (f.drop >= floor) & (swing >= 0.5 * floor)
    beside = (f.pre.fn + f.post.fn) / np.maximum(f.pre.count + f.post.count, 1)
    j = np.flatnonzero(ok)
    at = np.floor(f.mid[j]).astype(np.int64) + 1  # the first sample after the drop's middle
    return _Events(offset + at, f.drop[j], beside[j], label[at].astype(np.int64), offset + f.mid[j],
                   f.stick[j].astype(np.int64))  # fmt: skip


@dataclasses.dataclass(frozen=True)
class _FallFits:
    """Per fall: its stick lines before and after, its middle and duration (samples), whole drop, the stick
    before it (samples) and whether the run cut that stick."""

    pre: "_Fit"
    post: "_Fit"
    mid: np.ndarray
    tau: np.ndarray
    drop: np.ndarray
    stick: np.ndarray
    cut: np.ndarray


def _falls(r: np.ndarray, fn: np.ndarray, a: np.ndarray, b: np.ndarray, *, run0: np.ndarray, run1: np.ndarray,
           wlen: int, L: int) -> _FallFits:  # fmt: skip
    """The stick lines, middle, duration and whole drop of each fall a..b (docs/method.md 6g); L the samples of
    the smoothed signal."""
    same_prev = np.concatenate([[False], run0[1:] == run0[:-1]])
    same_next = np.concatenate([run0[1:] == run0[:-1], [False]])
    # the stick before: prev_b .. a; the one after: b .. next_a. No line reaches into the 2 L samples at a run's
    # edges: a drop there shows no whole fall of the smoothed signal, and would bend the line.
    prev_b = np.where(same_prev, np.concatenate([[0], b[:-1]]), run0 + 2 * L)
    next_a = np.where(same_next, np.concatenate([a[1:], [0]]), run1 - 1 - 2 * L)
    cap = max(wlen, 2 * L)  # (a stick line reaches at most this far from its fall: blocks give the same result)
    lo_pre = np.maximum(prev_b, a - cap)
    hi_post = np.minimum(next_a, b + cap)
    m_pre = np.maximum(1, np.round(MARGIN_SHARE * (a - lo_pre)).astype(np.int64))
    m_post = np.maximum(1, np.round(MARGIN_SHARE * (hi_post - b)).astype(np.int64))
    pre = _lines(r, fn, lo_pre + m_pre, a - m_pre + 1)
    post = _lines(r, fn, b + m_post, hi_post - m_post + 1)
    mid, tau = _crossings(r, a - (L - 1), b, pre=pre, post=post, L=L)
    drop = pre.at(mid - 0.5 * tau) - post.at(mid + 0.5 * tau)
    return _FallFits(pre, post, mid, tau, drop, a - prev_b, ~same_prev)


#: The crossings that time a fall: LOW and 1 - LOW of the way from the stick line before to the one after.
LOW = 0.2


def _crossings(r: np.ndarray, p: np.ndarray, q: np.ndarray, *, pre: "_Fit", post: "_Fit", L: int
               ) -> Tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """(middle, duration) of each fall in samples (docs/method.md 6g), from the mean of r over L samples
    starting at p .. q (centred (L - 1) / 2 later): its share of the way from the stick line before to the one
    after, f. The middle: where f first reaches 1/2 (interpolated); t20, t80: where f last rose through LOW
    before it and first reaches 1 - LOW after it; duration = sqrt(max(0, (t80 - t20)^2 - (0.6 L + 1)^2)) / 0.41:
    the box's own 20-80 % width 0.6 L and a sample of the crossings' jitter taken out (widths adding in
    quadrature), and a fall taken as a half cosine, whose 20-80 % width is 0.41 of its duration (a drop within
    a sample: 0). NaN where f never reaches 1/2."""
    c = np.concatenate([[0.0], np.cumsum(np.where(np.isfinite(r), r, 0.0))])
    width = np.maximum(q - p + 1, 1)
    rows = np.repeat(np.arange(p.size), width)
    j = np.arange(rows.size) - np.repeat(np.cumsum(width) - width, width) + np.repeat(p, width)
    j = np.clip(j, 0, r.size - L)
    tc = j + 0.5 * (L - 1)
    sm = (c[j + L] - c[j]) / L
    hi, lo = pre.at(tc, rows), post.at(tc, rows)
    with np.errstate(invalid="ignore", divide="ignore"):
        f = (hi - sm) / (hi - lo)
    f = np.where(np.isfinite(f), f, 0.0)
    start = np.cumsum(width) - width
    nan = np.full(p.size, np.nan)

    def first(mask: np.ndarray) -> np.ndarray:  # each row's first position where mask holds (-1: none)
        k = np.where(mask, np.arange(rows.size), rows.size)
        m = np.minimum.reduceat(k, start)
        return np.where(m < rows.size, m, -1)

    def interp(k: np.ndarray, level: float) -> np.ndarray:  # the crossing of `level` between k - 1 and k
        k0 = np.maximum(k - 1, start)
        d = f[k] - f[k0]
        u = np.where(d != 0, (level - f[k0]) / np.where(d != 0, d, 1.0), 1.0)
        return np.asarray(tc[k0] + np.clip(u, 0.0, 1.0) * (tc[k] - tc[k0]))

    k50 = first(f >= 0.5)
    ok = k50 >= 0
    k50 = np.where(ok, k50, start)
    mid = np.where(ok, interp(k50, 0.5), nan)
    # t10: after the last position before the middle with f < 0.1; t90: the first after it with f >= 0.9
    below = (f < LOW) & (np.arange(rows.size) < k50[rows])
    k = np.where(below, np.arange(rows.size), -1)
    last = np.maximum.reduceat(k, start)
    k10 = np.where(last >= 0, last + 1, start)
    k90 = first((f >= 1 - LOW) & (np.arange(rows.size) >= k50[rows]))
    k90 = np.where(k90 >= 0, k90, start + width - 1)
    w = interp(k90, 1 - LOW) - interp(k10, LOW)  # 20-80 % width of the smoothed fall
    # the box's width taken out, and a sample more: the noise's jitter of the crossings
    tau = np.sqrt(np.maximum(0.0, w * w - ((1 - 2 * LOW) * L + 1.0) ** 2)) / HALF_COSINE_20_80
    return mid, np.where(ok, tau, nan)


@dataclasses.dataclass(frozen=True)
class _Fit:
    """Least-squares lines of r over sample ranges: samples, slope, its sum of squares of times, the line's
    level at a given sample, the sum of Fn."""

    count: np.ndarray
    slope: np.ndarray
    sxx: np.ndarray
    tbar: np.ndarray
    ybar: np.ndarray
    fn: np.ndarray
    ss: np.ndarray  # the sum of squared residuals about the line

    def at(self, t: np.ndarray, rows: Optional[np.ndarray] = None) -> np.ndarray:
        """Each line's level at time t (samples; ``rows``: the line of each t)."""
        sel = slice(None) if rows is None else rows
        return np.asarray(self.ybar[sel] + self.slope[sel] * (t - self.tbar[sel]))


def _lines(r: np.ndarray, fn: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> _Fit:
    """The line fitted to the finite samples lo..hi-1 of r (each range).

    Sums of 1, t and t^2 are running integer sums (exact); of r, t r and Fn running float sums, with t
    counted from each range's start through the identity sum (t - t0) r = sum t r - t0 sum r.
    """
    if r.size >= 3_000_000:  # sum of t^2 over the block < 2^63 (BLOCK <= 2^21 with its margins)
        raise ValueError(f"stick-slip blocks hold at most 3e6 samples, got {r.size}")
    fin = np.isfinite(r)
    t = np.arange(r.size, dtype=np.int64)
    rz = np.where(fin, r, 0.0)

    def running(x: np.ndarray) -> np.ndarray:
        return np.concatenate([np.zeros(1, x.dtype), np.cumsum(x)])

    s1, st, stt = (running(v) for v in (fin.astype(np.int64), np.where(fin, t, 0), np.where(fin, t * t, 0)))
    sy, sty, sfn, syy = (running(v) for v in (rz, t * rz, np.where(fin, fn, 0.0), rz * rz))
    lo = np.clip(lo, 0, r.size)
    hi = np.clip(np.maximum(lo, hi), 0, r.size)
    c = s1[hi] - s1[lo]
    n = np.maximum(c, 1)
    tsum = st[hi] - st[lo]
    sxx = (n * (stt[hi] - stt[lo]) - tsum * tsum) / n
    ysum = sy[hi] - sy[lo]
    tbar, ybar = tsum / n, ysum / n
    sxy = (sty[hi] - sty[lo]) - tsum * ybar
    with np.errstate(invalid="ignore", divide="ignore"):
        slope = np.where(sxx > 0, sxy / np.where(sxx > 0, sxx, 1.0), np.nan)
    syy_c = (syy[hi] - syy[lo]) - ysum * ybar
    ss = np.maximum(0.0, syy_c - np.where(sxx > 0, slope * sxy, 0.0))
    return _Fit(c, slope, sxx, tbar, ybar, sfn[hi] - sfn[lo], ss)


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
                        _grid(fs), min_fn, tare_fy, tare_fz, _smooth(fs), fs)  # fmt: skip
        return seg, f"the central {frac:g} of each stroke"
    a0 = int(p.get("start") or 0)
    b0 = int(p["stop"]) if p.get("stop") is not None else n
    seg = _Segments(np.array([a0]), np.array([b0]), np.array([1.0]), np.array([np.nan]), _grid(fs),
                    min_fn, tare_fy, tare_fz, _smooth(fs), fs)  # fmt: skip
    return seg, "the samples in contact"


def _grid(fs: float) -> int:
    """Samples of the COF grid and of the falls' window: GRID_S seconds, at least 100 samples."""
    return max(100, round(GRID_S * fs))


def _smooth(fs: float) -> int:
    """Samples of the smoothed signal of the falls: SMOOTH_S seconds, at least SMOOTH samples."""
    return max(SMOOTH, round(SMOOTH_S * fs))


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
              ) -> Union[Tuple[float, "_Floors", float], StickSlip, None]:  # fmt: skip
        """Pass 1: (noise SD, the export's resolution, the recording's sign), or why it is not assessed. A sample that
        met no contact is estimated again from every block (None instead when ``every_block`` is False)."""
        D = self.drop_samples
        est = [_block_noise(self.seg, s, fetch(s), D) for s in self.first]
        if not self.whole and all(e is None for e, _, _ in est):  # the sample met no contact: every block
            if not every_block:
                return None
            est = [_block_noise(self.seg, s, fetch(s), D) for s in self.spans]
        sigmas = [e[0] for e, _, _ in est if e is not None]
        floors = [e[1] for e, _, _ in est if e is not None]
        if not sigmas:
            duration = sum(u for _, _, u in est) / self.fs  # pass 1 read every block here
            return _not_assessed(f"stick-slip not assessed: fewer than 10 samples in contact in {self.scope}",
                                 self.scope, duration)  # fmt: skip
        orientation = 1.0 if sum(y for _, y, _ in est) >= 0 else -1.0
        median = _Floors(float(np.median([f.quantum for f in floors])), float(np.median([f.coloured for f in floors])))
        return float(np.median(sigmas)), median, orientation

    def block(self, span: "_Span", d: Dict[str, np.ndarray], orientation: float, sigma: float, floors: "_Floors"
              ) -> Tuple[_Events, float, int]:  # fmt: skip
        """Pass 2 over one block: (events, sum of the friction force, samples in contact)."""
        return _search_block(self.seg, span, d, orientation, sigma=sigma, floors=floors, k=self.k,
                             drop_samples=self.drop_samples)  # fmt: skip

    def summary(self, found: List[Tuple[_Events, float, int]], orientation: float, sigma: float, floors: "_Floors",
                fetch: Callable[["_Span"], Dict[str, np.ndarray]]) -> StickSlip:  # fmt: skip
        """The recording's result from pass 2's blocks; a sample whose sign is not the recording's (friction
        changing sign) is searched again with the recording's."""
        events = _Events.concat([f[0] for f in found])
        signsum, used = sum(f[1] for f in found), sum(f[2] for f in found)
        if (1.0 if signsum >= 0 else -1.0) != orientation:
            events = _Events.concat([self.block(s, fetch(s), -orientation, sigma, floors)[0] for s in self.spans])
        return _summarise(events, sigma=sigma, quantum=floors.quantum, k=self.k, duration=used / self.fs, fs=self.fs,
                          scope=self.scope)  # fmt: skip

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
        sigma, floors, orientation = got
        found = [self.block(s, fetch(s), orientation, sigma, floors) for s in self.spans]
        return self.summary(found, orientation, sigma, floors, fetch)


class ReadingPass:
    """Stick-slip found in the analysis' own reading (``analyze(stick_slip=True)``, docs/method.md 6g).

    Built before the main pass: the noise and resolution of a long search come from
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
        self._noise: Union[Tuple[float, "_Floors", float], StickSlip, None] = None
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
        sigma, floors, orientation = self._noise
        spans = self.search.spans
        while self._done < len(spans) and spans[self._done].read[1] <= self._next:
            span = spans[self._done]
            self._found.append(self.search.block(span, self._take(*span.read), orientation, sigma, floors))
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
        sigma, floors, orientation = self._noise
        return self.search.summary(self._found, orientation, sigma, floors, lambda s: self.read(*s.read))


# -- the optional pass of analyze(stick_slip=True) (tribodyn.pipeline.passes.PASSES) -------------------------------


def reading_pass(given: PassInputs) -> Optional[ReadingPass]:
    """Stick-slip found in the main pass's chunks (docs/method.md 6g) when the route reads a unidirectional
    recording with its static level in order; None otherwise (:func:`store` then reads it again)."""
    if not (given.params.get("static_fz") and given.found.classical is not None and given.strokes is None):
        return None
    source, rec = given.source, given.rec
    if not (rec is not None or isinstance(source, Mapping)) or choose_route(source, rec, given.plan,
                                                                             given.found) != "stream":  # fmt: skip
        return None
    return ReadingPass.of(given.params, source, start=given.plan.start, stop=given.plan.stop)


def store(given: PassInputs, tap: Optional[Tap], res: Results) -> Results:
    """``res`` with its ``stick_slip``: the tap's result, else the recording read again (docs/method.md 6g)."""
    got = tap.result() if isinstance(tap, ReadingPass) else None
    return dataclasses.replace(res, stick_slip=got if got is not None else find_stick_slip(given.source, res))


@dataclasses.dataclass(frozen=True)
class _Span:
    """A block searched (``own``: the samples whose events it counts) and the samples read for it (``read``)."""

    own: Tuple[int, int]
    read: Tuple[int, int]


def _span(seg: _Segments, a: int, b: int, n: int, drop_samples: int) -> _Span:
    """Samples a..b with a margin (whole seconds of the COF grid) so that an event near its edge is seen whole."""
    p = seg.per_second
    margin = 2 * p + 2 * (SMOOTH + drop_samples) + 2  # (the falls' window and the stick lines: p each)
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


@dataclasses.dataclass(frozen=True)
class _Floors:
    """What the noise SD does not say: the export's resolution of r (N) and the noise SD its drop statistic's
    spread implies (coloured noise, N)."""

    quantum: float
    coloured: float


def _block_noise(seg: _Segments, span: _Span, d: Dict[str, np.ndarray], drop_samples: int
                 ) -> Tuple[Optional[Tuple[float, _Floors]], float, int]:  # fmt: skip
    """(noise SD and its floors or None, sum of the friction force, samples in contact) of a
    block's own samples, with the block's own sign (docs/method.md 6g).

    The resolution of r = F - mu Fn: the grid step of F plus mu times that of Fn (mu the median F / Fn).
    """
    (a, b), (ra, rb) = span.own, span.read
    own = slice(a - ra, b - ra)
    r, fn, label, y = _signal(seg, ra, rb, d["fy"], d["fz"], orientation=1.0)
    inside = label[own] >= 0
    ysum = float(np.sum(y[own][inside]))
    if ysum < 0:
        r, fn, label, y = _signal(seg, ra, rb, d["fy"], d["fz"], orientation=-1.0)
    yi, fi = y[own][inside], fn[own][inside]
    q = _quantum(yi) + float(np.median(np.abs(yi) / fi)) * _quantum(fi) if yi.size else 0.0
    got = _noise(r[own], label[own], drop_samples, q)
    if got is None:
        return None, ysum, int(inside.sum())
    return (got[0], _Floors(q, got[1])), ysum, int(inside.sum())


def _search_block(seg: _Segments, span: _Span, d: Dict[str, np.ndarray], orientation: float, *, sigma: float,
                  floors: "_Floors", k: float, drop_samples: int) -> Tuple[_Events, float, int]:  # fmt: skip
    """(events, sum of the friction force, samples in contact) of one block's own samples."""
    (a, b), (ra, rb) = span.own, span.read
    r, fn, label, y = _signal(seg, ra, rb, d["fy"], d["fz"], orientation=orientation)
    inside = label[a - ra : b - ra] >= 0
    signsum = orientation * float(np.sum(y[a - ra : b - ra][inside]))
    found = _detect(r, fn, label, ra, sigma=sigma, quantum=floors.quantum, coloured=floors.coloured, k=k,
                    fs=seg.fs,
                    wlen=seg.per_second, smooth=seg.smooth)  # fmt: skip
    return found.where((found.index >= a) & (found.index < b)), signsum, int(inside.sum())


def _summarise(events: _Events, *, sigma: float, quantum: float, k: float, duration: float, fs: float, scope: str
               ) -> StickSlip:  # fmt: skip
    """The recording's numbers and verdict from its events (docs/method.md 6g)."""
    events = events.where(np.argsort(events.index, kind="stable"))
    times = events.mid / fs  # the drop's middle (a drop within a sample: between two samples)
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
        near = iv[np.abs(iv - med) <= 0.25 * med]
        freq = 1.0 / (float(np.mean(near)) if near.size else med)  # (two far apart: none near their median)
    rate = len(events) / duration if duration > 0 else nan
    share = float(np.sum(events.stick)) / fs / duration if duration > 0 else 0.0
    present = len(events) >= MIN_EVENTS and share >= MIN_STICK_SHARE
    thr = max(k * sigma, Q_STEPS * quantum)
    floor = (f"{k:g} noise SDs ({k * sigma:.3g} N)" if k * sigma >= Q_STEPS * quantum
             else f"{Q_STEPS:g} steps of the export's resolution ({quantum:.3g} N)")  # fmt: skip
    if fs * SLIP_MAX_S < 1:  # a slip is shorter than a sample interval: none is resolved, drops are steps
        scope = f"{scope}; at {fs:.3g} Hz no slip is resolved, a drop is a step between two samples"
    if present:
        f_text = f"frequency {freq:.4g} Hz" if np.isfinite(freq) else "frequency unknown (no stroke holds two events)"
        verdict = (
            f"stick-slip present: {len(events)} events, amplitude {amp:.3g} N ({amp_cof:.3g} in COF units), "
            f"{f_text} ({rate:.3g} events/s over {duration:.4g} s of {scope})"
        )
    else:
        verdict = (
            f"no stick-slip: {len(events)} drop{'s' if len(events) != 1 else ''} after a rise larger than "
            f"{floor} in {duration:.4g} s of {scope}"
        )
        if len(events) >= MIN_EVENTS:  # drops far apart: their sticks fill little of the time
            verdict += f" (isolated: their sticks fill {share:.1%} of it, under {MIN_STICK_SHARE:.0%})"
    return StickSlip(len(events), amp, amp_cof, freq, rate, times, drops, sigma, thr, duration, present, verdict,
                     scope)  # fmt: skip
