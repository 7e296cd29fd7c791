"""What tribometer exports need beyond the dynamic method (docs/method.md 6a-6d).

* :func:`prepass`: one look at the normal and friction force before the
  windows: whether fz carries its static level (raw forces: the classical
  COF applies), the reference ``min_fn`` (5 % of the median |fz|), the
  tare offsets and the motion (reciprocating when fy changes sign).
* the classical COF per window (6a) is computed by the Rust kernel
  (``_core`` columns ``mu_classical``, ...; ``reference.classical_windows``
  is its NumPy reference).
* :func:`find_strokes` and :func:`stroke_table`: the strokes of a
  reciprocating test and the per-stroke classical COF over the central
  ``stroke_fraction`` of each stroke (6c).
* :func:`verdict`: whether the dynamic method applies, why not, and the
  headline COF with the name of its estimate (6d).
* :func:`auto_window`: window and hop chosen from the rate for slow
  recordings (6b); :func:`from_dataframe`: a pandas DataFrame as a source.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Dict, List, Mapping, Optional, Tuple

import numpy as np

from .. import _core
from ..io.sample import MIN_FN_FRACTION, _sample_recording, in_range
from ..kernels import _order
from ..kernels.strokes import ClassicalSpec

__all__ = ["Contact", "auto_window", "detect_contact", "prepass"]

#: Fewest samples of a window (docs/method.md 6b): a slower recording gets a longer window.
MIN_WINDOW_SAMPLES = 100
#: Below this rate (Hz) the default hop equals the window (the windows tile the recording).
SLOW_RATE = 100.0
#: fy changes sign when both signs hold at least this share of the samples beyond 30 % of p95 |fy|.
SIGN_FLIP_SHARE = 0.15
#: Reciprocating needs the median |fy| of each sign at least this many noise SDs (sample-to-sample differences).
RECIPROCATING_SNR = 5.0
#: ... and at least this many reversals of the sliding direction (with the strokes' hysteresis, 30 % of p95):
#: a disc that stops once, or a friction that changes sign once, is not a reciprocating test (issue 34 point 6).
MIN_REVERSALS = 3
#: A motion channel's direction must be held, on average, for at least this many decided samples (beyond 30 % of
#: its p95) between two reversals: white noise holds its sign for about 2 (docs/method.md 6c).
MIN_HELD_SAMPLES = 8


def auto_window(fs: float, window: Optional[float], hop: Optional[float]) -> Tuple[float, float, str]:
    """(window, hop, note) for a recording at ``fs`` (docs/method.md 6b).

    Defaults are the paper's 2 s and 10 s. A window under
    :data:`MIN_WINDOW_SAMPLES` samples (not given, or given under 3 samples)
    becomes ``MIN_WINDOW_SAMPLES / fs``; below :data:`SLOW_RATE` Hz the hop
    defaults to the window (tiling: a slow log is not thinned out). The note
    says what was chosen ('' when nothing was).
    """
    notes = []
    w = 2.0 if window is None else float(window)
    if window is None and w * fs < MIN_WINDOW_SAMPLES:
        w = MIN_WINDOW_SAMPLES / fs
        notes.append(f"window {w:g} s ({MIN_WINDOW_SAMPLES} samples at {fs:g} Hz)")
    elif window is not None and w > 0 and round(w * fs) < 3:
        w = MIN_WINDOW_SAMPLES / fs
        notes.append(
            f"window {window:g} s is under 3 samples at {fs:g} Hz: window {w:g} s ({MIN_WINDOW_SAMPLES} samples)"
        )
    if hop is None:
        h = w if fs < SLOW_RATE else max(10.0, w)
        if fs < SLOW_RATE:
            notes.append(f"hop {h:g} s = the window (a slow recording at {fs:g} Hz is tiled)")
    else:
        h = float(hop)
    note = ("chosen from the rate: " + "; ".join(notes)) if notes else ""
    return w, h, note


# -- contact ---------------------------------------------------------------------------

#: An unloaded cluster's robust spread must be under this fraction of its distance to the loaded samples.
UNLOADED_TIGHT = 0.1
#: Least share of the samples an unloaded cluster holds (and at least 5 samples).
UNLOADED_MIN_SHARE = 0.005
#: A cluster on the load's side of zero above this share of the loaded median is a lower load step (contact),
#: never a tare (issue 34 point 5: a 50 N run-in before 180 N was taken as unloaded, -19.8 %).
TARE_MAX_SHARE = 0.2
#: ... and above TARE_PROPORTIONAL_SHARE when fy / fz in it is within TARE_RATIO_TOLERANCE of the loaded ratio
#: (friction proportional to the load: a load step; a sensor's zero offsets carry no such ratio).
TARE_PROPORTIONAL_SHARE = 0.05
TARE_RATIO_TOLERANCE = 0.25
#: min_fn beyond an unloaded level: this many of its robust standard deviations ...
CONTACT_SIGMAS = 6.0
#: ... and at least this fraction of the distance between the unloaded level and the loaded median.
CONTACT_GAP_FRACTION = 0.05
#: Without an unloaded cluster: min_fn is 4 noise standard deviations (from sample-to-sample differences),
#: at least this fraction of the median |fz| and at most MIN_FN_FRACTION of it.
CONTACT_FLOOR_FRACTION = 0.01
#: The unloaded fy before and after the contact may differ by this fraction of the friction force without a warning.
FY_TARE_SPREAD = 0.1
#: fz has a static level when at least this share of the samples beyond min_fn has one sign.
STATIC_SIGN_SHARE = 0.95


@dataclasses.dataclass(frozen=True)
class Contact:
    """Which samples are in contact, decided from the distribution of fz (docs/method.md 6a).

    Attributes
    ----------
    min_fn : float
        Least |fz - tare_fz| (N) of a sample in contact.
    tare_fy, tare_fz : float
        The unloaded level of fy and fz (median over the unloaded cluster; 0 without one).
    unloaded_fraction : float
        Share of the samples looked at that lie in the unloaded cluster (0 without one).
    excluded_fraction : float
        Share of the samples looked at that are not in contact.
    static : bool
        fz carries a static level (raw forces): the classical COF applies.
    rule : str
        How min_fn was decided, in words.
    """

    min_fn: float
    tare_fy: float
    tare_fz: float
    unloaded_fraction: float
    excluded_fraction: float
    static: bool
    rule: str
    #: A warning about the tare ('' when none): the unloaded fy differs before and after the contact.
    note: str = ""
    #: Where the tare comes from: "start" (the unloaded samples before the first contact), "all" (every
    #: unloaded sample: fewer than 5 before the first contact), "" (no unloaded cluster).
    tare_from: str = ""


def _robust_sd(v: np.ndarray, centre: Optional[float] = None) -> float:
    """1.4826 x the median absolute deviation (``centre``: the median of ``v`` when already known)."""
    if not v.size:
        return 0.0
    m = _order.median(v) if centre is None else centre
    return 1.4826 * _order.median_abs_dev(v, m)


def _noise_sd(v: np.ndarray, scratch: Optional[List[np.ndarray]] = None) -> float:
    """The noise's standard deviation from sample-to-sample differences: ``_robust_sd(np.diff(v)) / sqrt 2``
    (0 under two samples). ``scratch``: a list holding a buffer the differences may be written into (and
    where a new one is left), so that the pre-pass's two looks (fz, then fy) share one array of the sample's
    size instead of each allocating its own (fresh pages cost more than the subtraction)."""
    if v.size < 2:
        return 0.0
    m = v.size - 1
    if scratch is None:
        d = np.diff(v)
    else:
        if not scratch or scratch[0].size < m or scratch[0].dtype != v.dtype:
            scratch[:] = [np.empty(v.size, dtype=v.dtype)]
        d = np.subtract(v[1:], v[:-1], out=scratch[0][:m])  # np.diff's own operation
    return float(_robust_sd(d) / np.sqrt(2.0))


def _sorted_robust_sd(v: _order.Sorted, centre: float) -> float:
    """:func:`_robust_sd` of sorted values around their median ``centre``."""
    return 1.4826 * v.median_abs_dev(centre) if v.size else 0.0


def _bins_of(x: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """The bin ``_core.histogram_uniform`` (NumPy's histogram) puts each value of ``x`` (within the
    edges' range) in: ``(x - first) / (last - first) * bins`` truncated, moved by one beside an edge."""
    bins = edges.size - 1
    i = np.minimum((((x - edges[0]) / (edges[-1] - edges[0])) * bins).astype(np.int64), bins - 1)
    down = x < edges[i]
    up = ~down & (x >= edges[i + 1]) & (i != bins - 1)
    out: np.ndarray = i - down + up
    return out


def _histogram_sorted(v: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """``_core.histogram_uniform(v, edges)`` of sorted ``v`` spanning exactly the edges' range.

    A value's bin (:func:`_bins_of`) never decreases as the value grows, so a bin's count is the
    distance between the first values at or past its edges: found by a binary search for each edge
    and checked by the bins of the values either side of it (the kernel's own count when a check
    fails, as it may for edges a few ULPs apart).
    """
    n, bins = v.size, edges.size - 1
    cut = np.searchsorted(v, edges[1:-1], side="left")  # first value >= each inner edge
    j = np.arange(1, bins)
    before, at = cut > 0, cut < n
    ok = np.all(_bins_of(v[cut[before] - 1], edges) < j[before]) and np.all(_bins_of(v[cut[at]], edges) >= j[at])
    if not ok:
        return _core.histogram_uniform(np.require(v, requirements=["C", "A"]), edges)
    return np.diff(np.concatenate(([0], cut, [n]))).astype(np.int64)


def _otsu(v: _order.Sorted, bins: int = 1024) -> float:
    """Otsu's threshold of sorted finite values: the split of their histogram with the largest
    between-class variance (NumPy's histogram of ``bins`` uniform bins over their range)."""
    lo, hi = v.ranks([0, v.size - 1])
    if not hi > lo:
        return hi
    if np.isfinite(hi - lo):
        edges = np.linspace(lo, hi, bins + 1, endpoint=True)  # np.histogram's edges
        h = _histogram_sorted(v.values(), edges)
    else:
        h, edges = np.histogram(v.values(), bins=bins, range=(lo, hi))
    centres = 0.5 * (edges[:-1] + edges[1:])
    w = np.cumsum(h)[:-1].astype(float)
    m = np.cumsum(h * centres)[:-1]
    total, mt = float(h.sum()), float((h * centres).sum())
    w2 = total - w
    with np.errstate(divide="ignore", invalid="ignore"):
        between = w * w2 * (m / w - (mt - m) / w2) ** 2
    between[~np.isfinite(between)] = -1.0
    return float(edges[int(np.argmax(between)) + 1])


def _mask_of(z: np.ndarray, steps: List[Tuple[float, bool]]) -> np.ndarray:
    """The samples of ``z`` on the kept side of every (threshold, low side) narrowing step."""
    mask = np.ones(z.size, dtype=bool)
    for thr, side in steps:
        mask &= (z <= thr) if side else ~(z <= thr)
    return mask


def _is_lower_step(fy: Optional[np.ndarray], z: np.ndarray, level: float, loaded: float,
                   steps: List[Tuple[float, bool]]) -> bool:  # fmt: skip
    """Whether a tight cluster of ``z`` at ``level`` (its samples: ``steps``) is a lower load step, not a tare,
    against the loaded median ``loaded`` (docs/method.md 6a): on the load's side of zero and above TARE_MAX_SHARE
    of it, or above TARE_PROPORTIONAL_SHARE with fy / fz there within TARE_RATIO_TOLERANCE of the loaded ratio."""
    if not (level * loaded > 0):  # zero, or across zero from the load: an offset, never a load
        return False
    share = level / loaded
    if share > TARE_MAX_SHARE:
        return True
    if fy is None or share <= TARE_PROPORTIONAL_SHARE:
        return False
    inside = _mask_of(z, steps)
    rest = ~inside
    if inside.sum() < 5 or rest.sum() < 5:
        return False
    r_in = _order.median(fy[inside]) / level
    r_out = _order.median(fy[rest]) / _order.median(z[rest])
    return bool(r_out != 0 and abs(r_in / r_out - 1.0) <= TARE_RATIO_TOLERANCE)


def _unloaded(z: np.ndarray, order: _order.Sorted, fy: Optional[np.ndarray] = None,
              steps_seen: Optional[List[Tuple[float, float]]] = None
              ) -> Optional[Tuple[np.ndarray, _order.Sorted]]:  # fmt: skip
    """The mask of the unloaded cluster of the finite ``z`` (``order``: ``z`` sorted) and its values
    sorted, or None (docs/method.md 6a).

    Otsu's split of fz into two classes; the class nearer zero is an
    unloaded cluster when it holds at least UNLOADED_MIN_SHARE of the
    samples and its robust spread is under UNLOADED_TIGHT of the distance
    between the two classes' medians. A cluster that splits again the same
    way (lift-off below a low load step) is narrowed to its part nearer zero. A tight cluster that is a
    lower load step (:func:`_is_lower_step`) is contact, not a tare: the search narrows on into it, and
    ``steps_seen`` gets its (level, loaded median).
    """
    n = z.size
    # The classes are value ranges: each step keeps the values of one side of a threshold, a run of
    # the sorted values; the samples are selected by the thresholds' conditions at the end.
    v = order
    steps: List[Tuple[float, bool]] = []  # (threshold, low side) of each narrowing
    found: Optional[Tuple[List[Tuple[float, bool]], _order.Sorted]] = None
    for _ in range(3):
        if v.size < 10:
            break
        thr = _otsu(v)
        k = v.count_le(thr)
        if k == v.size or k == 0:
            break
        va, vb = v.part(0, k), v.part(k, v.size)
        ma, mb = va.median(), vb.median()
        side = abs(ma) <= abs(mb)
        u, other, mu_u = (va, mb, ma) if side else (vb, ma, mb)
        gap = abs(other - mu_u)
        if u.size < max(5, UNLOADED_MIN_SHARE * n) or not gap > 0:
            break
        if _sorted_robust_sd(u, mu_u) <= UNLOADED_TIGHT * gap:
            if not _is_lower_step(fy, z, mu_u, other, [*steps, (thr, side)]):
                found = ([*steps, (thr, side)], u)
            elif steps_seen is not None:
                steps_seen.append((float(mu_u), float(other)))
        elif found is not None:
            break
        v = u  # narrow: the class nearer zero may still hold a tighter cluster (lift-off below a low step)
        steps.append((thr, side))
    if found is None:
        return None
    return _mask_of(z, found[0]), found[1]


def detect_contact(fy: np.ndarray, fz: np.ndarray) -> Contact:
    """The samples in contact, from the distribution of fz (finite samples; docs/method.md 6a).

    With an unloaded cluster (:func:`_unloaded`: before loading, lift-off),
    fy and fz are tared by its medians and a sample is in contact when
    |fz - tare| >= max(CONTACT_SIGMAS x its robust SD, CONTACT_GAP_FRACTION x
    the distance to the loaded median). Without one (a dead weight, a load
    ramp), there is no tare and min_fn = 4 noise SDs (robust SD of the
    sample-to-sample differences / sqrt 2), clipped to
    [CONTACT_FLOOR_FRACTION, MIN_FN_FRACTION] x the median |fz|.
    """
    fy, fz = np.asarray(fy, dtype=float), np.asarray(fz, dtype=float)
    if fy.shape != fz.shape or fz.ndim != 1:
        raise ValueError(f"fy and fz must be 1-D of equal lengths, got shapes {fy.shape} and {fz.shape}")
    if not (np.isfinite(fy).all() and np.isfinite(fz).all()):
        raise ValueError("fy and fz must be finite (drop or interpolate NaN and inf first)")
    return _contact(fy, fz, _order.Sorted.of(fz))[0]


def _steps_words(seen: List[Tuple[float, float]]) -> str:
    """The rule's words for the lower load steps taken as contact ('' for none)."""
    if not seen:
        return ""
    said = ", ".join(f"fz = {lv:.4g} N ({100 * lv / ld:.0f} % of the load above it)" for lv, ld in seen)
    return (
        f"; the tight cluster at {said} is a lower load step, in contact, not a tare (a tare lies near zero: "
        f"at most {100 * TARE_MAX_SHARE:.0f} % of the load; pass --tare fy=N,fz=N if it is the sensor's zero)"
    )


def _shifted(order: _order.Sorted, tare: float) -> _order.Sorted:
    """The sorted values of :func:`_untared` (the whole of ``order``): ``value - tare`` keeps the order."""
    return order if tare == 0.0 and not np.signbit(tare) else _order.Sorted(order.values() - tare)


def _contact(fy: np.ndarray, fz: np.ndarray, order: _order.Sorted,
             scratch: Optional[List[np.ndarray]] = None) -> Tuple[Contact, _order.Sorted]:  # fmt: skip
    """:func:`detect_contact` with ``order``, fz sorted; and fz tared by the contact's tare, sorted. The
    medians and counts of fz are read from the sorted values (one sort instead of a selection each).
    ``scratch``: :func:`_noise_sd`'s."""
    n = fz.size
    if n == 0:
        return Contact(0.0, 0.0, 0.0, 0.0, 0.0, False, "no samples"), order
    seen: List[Tuple[float, float]] = []
    got = _unloaded(fz, order, fy, seen) if np.isfinite(order.ranks([0, n - 1])).all() else None
    note = ""
    if got is not None:
        unl, cluster = got
        loaded_idx = np.flatnonzero(~unl)
        before = unl.copy()
        before[loaded_idx[0] :] = False  # the unloaded samples before the first loaded one (as tare= S takes them)
        after = unl.copy()
        after[: loaded_idx[-1] + 1] = False
        ref = before if before.sum() >= 5 else unl
        t_fz = _order.median(fz[ref]) if ref is before else cluster.median()
        t_fy = _order.median(fy[ref])
        # the loaded samples are the sorted values either side of the cluster's run
        m, at, width = n - cluster.size, cluster.a, cluster.size
        loaded = float(np.mean(np.array(order.ranks([r if r < at else r + width for r in _order._middle(m)]))))
        sd = _sorted_robust_sd(cluster, cluster.median())
        thr = max(CONTACT_SIGMAS * sd, CONTACT_GAP_FRACTION * abs(loaded - t_fz))
        where = "before the first contact" if ref is before else "of the whole recording"
        unl_frac = cluster.size / n
        rule = (
            f"unloaded cluster at fz = {t_fz:.4g} N ({100 * unl_frac:.1f} % of the samples; fy there "
            f"{t_fy:.4g} N), its median {where} taken as the tare; in contact when |fz - tare| >= {thr:.4g} N"
        )
        if ref is before and after.sum() >= 5:
            fy_after = _order.median(fy[after])
            friction = abs(_order.median(fy[~unl]) - t_fy)
            if abs(fy_after - t_fy) > FY_TARE_SPREAD * max(friction, 1e-300):
                note = (
                    f"the unloaded fy differs before the contact ({t_fy:.4g} N) and after it ({fy_after:.4g} N) by "
                    f"{abs(fy_after - t_fy):.4g} N, {100 * abs(fy_after - t_fy) / max(friction, 1e-300):.0f} % of the "
                    "friction force: the tare is taken before the contact (drag while sliding unloaded, or sensor "
                    "drift?); pass --tare fy=N,fz=N (tare=) if another offset is right"
                )
        static = True
    else:
        t_fz = t_fy = 0.0
        absz = order.median_abs_dev(0.0)
        noise = _noise_sd(fz, scratch)
        thr = min(max(4.0 * noise, CONTACT_FLOOR_FRACTION * absz), MIN_FN_FRACTION * absz)
        rule = f"no unloaded cluster: in contact when |fz| >= {thr:.4g} N (4 noise SDs, within 1-5 % of median |fz|)"
        rule += _steps_words(seen)
        v = order.values()
        if thr > 0:  # |fz| >= thr: at or above thr, or at or below -thr
            pos, neg = n - int(np.searchsorted(v, thr, "left")), int(np.searchsorted(v, -thr, "right"))
        elif thr <= 0:  # every sample
            pos, neg = n - int(np.searchsorted(v, 0.0, "right")), int(np.searchsorted(v, 0.0, "left"))
        else:  # NaN: none
            pos = neg = 0
        size = pos + neg if thr > 0 or not thr <= 0 else n
        share = max(pos / size, neg / size) if size else 0.0
        static = bool(share >= STATIC_SIGN_SHARE and size >= 0.5 * n)
        unl_frac = 0.0
    tared = _shifted(order, t_fz)
    v = tared.values()
    if thr > 0:  # |fz - tare| < thr
        inside = int(np.searchsorted(v, thr, "left")) - int(np.searchsorted(v, -thr, "right"))
    else:  # fz == tare
        raw = order.values()
        inside = int(np.searchsorted(raw, t_fz, "right")) - int(np.searchsorted(raw, t_fz, "left"))
    tare_from = "" if got is None else ("start" if ref is before else "all")
    return Contact(float(thr), t_fy, t_fz, unl_frac, inside / n, static, rule, note, tare_from), tared


# -- pre-pass -------------------------------------------------------------------------


def _tare_mode(contact: Contact, mode: str) -> Contact:
    """The contact's tare under ``tare="start"`` (only the unloaded samples before the first contact) or
    ``"none"`` (fy not tared; fz's zero still decides the contact); as found otherwise (docs/method.md 6a)."""
    if mode == "start":
        if contact.tare_from != "start":
            raise ValueError(
                "tare='start': no unloaded samples before the first contact (at least 5 are needed); the recording "
                "starts in contact: use tare='auto' (the unloaded samples after it) or give the offsets fy=N,fz=N"
            )
        return contact
    if mode == "none":
        rule = contact.rule + f"; fy not tared (tare='none': its unloaded level {contact.tare_fy:.4g} N stays in it)"
        return dataclasses.replace(contact, tare_fy=0.0, rule=rule, note="")
    return contact


def _at_least(v: np.ndarray, thr: float) -> np.ndarray:
    """``np.abs(v) >= thr`` without the array of magnitudes: |v| >= thr exactly when v >= thr or v <= -thr
    (a negation is exact; NaN fails both, as it fails the first)."""
    out: np.ndarray = v >= thr
    out |= v <= -thr
    return out


def _untared(v: np.ndarray, tare: float) -> np.ndarray:
    """``v - tare`` (``v`` itself for a tare of +0.0, which leaves every value as it is)."""
    return v if tare == 0.0 and not np.signbit(tare) else v - tare


def _side_medians(fy: np.ndarray) -> List[float]:
    """[median |fy| over fy > 0, over fy < 0] (0.0 for an empty side) of NaN-free ``fy``, without copies.

    The positive values are the top ``p`` of the sorted fy and the negative ones its bottom ``q``, so
    each side's median is the mean of one or two order statistics of fy itself; the negative side's
    |.| reverses its order and negates the mean exactly, so the values equal
    ``np.median(np.abs(fy[fy > 0]))`` and ``np.median(np.abs(fy[fy < 0]))`` bit for bit.
    """
    n = fy.size
    p, q = int(np.count_nonzero(fy > 0)), int(np.count_nonzero(fy < 0))
    sides = []
    for count, first, sign in ((p, n - p, 1.0), (q, 0, -1.0)):
        h = count // 2
        sides.append(([] if not count else [first + h] if count % 2 else [first + h - 1, first + h], sign))
    # both sides' order statistics in one selection (the same values as a selection each)
    wanted = sorted({k for ranks, _ in sides for k in ranks})
    got = dict(zip(wanted, _order.order_stats(fy, wanted))) if wanted else {}
    return [sign * float(np.mean(np.array([got[k] for k in ranks]))) if ranks else 0.0 for ranks, sign in sides]


def prepass(
    source: Any,
    rec: Any,
    fs: float,
    *,
    min_fn: Optional[float],
    tare: Any,
    motion: str,
) -> Dict[str, Any]:
    """The look at fy and fz before the windows (see the module docstring); {} when the source is a stream.

    Returns a dict with ``static`` (fz carries a static level), ``spec``
    (:class:`ClassicalSpec` or None), ``motion`` ("unidirectional" or
    "reciprocating"), ``motion_detected`` and ``sign_flip_share``.
    """
    tare_s = float(tare) if isinstance(tare, (int, float)) and not isinstance(tare, bool) else 0.0
    tare_n = int(round(tare_s * fs))
    data = _forces_sample(source, rec, tare_n)
    if data is None or data["fz"].size == 0 or data["fy"].shape != data["fz"].shape:
        # Nothing to look at (or channels of unequal lengths, which the pipeline refuses with its own error);
        # a given min_fn (and tare offsets) still define the classical COF of the windows.
        out0: Dict[str, Any] = {"motion": "unidirectional" if motion == "auto" else motion, "motion_detected": False}
        if min_fn is not None:
            offsets = tare if isinstance(tare, Mapping) else {}
            out0["spec"] = ClassicalSpec(float(min_fn), float(offsets.get("fy", 0.0)), float(offsets.get("fz", 0.0)))
        return out0
    mode = tare if isinstance(tare, str) else ""  # "start", "none" (docs/method.md 6a)
    if mode and min_fn is not None:
        raise ValueError(f"tare={mode!r} finds the tare with the contact, from the unloaded samples: give min_fn "
                         "without it, or tare as offsets fy=N,fz=N")  # fmt: skip
    fy, fz, t_fy, t_fz = _tare_offsets(data["fy"], data["fz"], None if mode else tare, tare_s, tare_n)
    out: Dict[str, Any] = {}
    contact: Optional[Contact] = None
    order = _order.Sorted.of(fz)  # fz sorted once: its medians and classes below (docs/method.md 6a)
    scratch: List[np.ndarray] = []  # one buffer for the sample-to-sample differences of fz, then of fy
    if not isinstance(tare, Mapping) and tare_n == 0 and min_fn is None:
        contact, order = _contact(fy, fz, order, scratch)
        contact = _tare_mode(contact, mode)
        t_fy, t_fz = contact.tare_fy, contact.tare_fz
    else:
        order = _shifted(order, t_fz)
    fy, fz = _untared(fy, t_fy), _untared(fz, t_fz)
    med = order.median() if fz.size else 0.0
    mad = order.median_abs_dev(med) if fz.size else 0.0
    static = bool(abs(med) > 0 and abs(med) > 3.0 * mad) or bool(contact is not None and contact.static)
    out["static"] = static
    absz = order.median_abs_dev(0.0)
    out["median_abs_fz"] = absz
    if contact is not None:
        out["contact"] = contact
    if static or min_fn is not None or (tare is not None and not mode):
        if min_fn is not None:
            thr = float(min_fn)
        elif contact is not None:
            thr = contact.min_fn
        else:
            thr = MIN_FN_FRACTION * absz
        if not np.isfinite(thr) or thr < 0:
            raise ValueError(f"min_fn must be finite and >= 0, got {min_fn!r}")
        out["spec"] = ClassicalSpec(thr, t_fy, t_fz)
    # motion, from the samples in contact only (unloaded fy is an offset or drag, not friction)
    if "spec" in out:
        touching = _at_least(fz, out["spec"].min_fn)
        if touching.any() and not touching.all():  # every sample in contact: fy itself, without the copy
            fy = fy[touching]
    out.update(_motion(fy, static, motion, _motion_channel(source, rec), scratch=scratch))
    return out


def _motion_channel(source: Any, rec: Any) -> Optional[Tuple[str, np.ndarray, List[Tuple[int, int]]]]:
    """(role, its direction signal, contiguous runs) of a velocity ``v`` or position ``x`` channel, which says
    the sliding direction better than fy (issue 34 point 6; docs/method.md 6c): the pre-pass sample of the
    recording (pieces apart), or a mapping's array; None without one. A position's direction is its slope."""
    from ..io.sample import sample_channels

    for role in ("v", "x"):
        if rec is not None and role in getattr(rec, "roles", {}):
            data, runs = sample_channels(rec, [role])
            sig = np.asarray(data[role], dtype=float)
        elif isinstance(source, Mapping) and role in source:
            sig = np.asarray(source[role], dtype=float)
            runs = [(0, sig.size)]
        else:
            continue
        if role == "x":
            d = np.full(sig.size, np.nan)
            for a, b in runs:
                if b - a >= 2:
                    d[a:b] = np.gradient(sig[a:b])
            sig = d
        return role, sig, list(runs)
    return None


def _reversals(sig: np.ndarray, runs: List[Tuple[int, int]]) -> int:
    """Changes of direction of ``sig`` (a signed direction signal) with the strokes' hysteresis: the sign
    holds until the signal crosses 30 % of its p95 magnitude with the other sign (``find_strokes``), counted
    within each run."""
    return _direction_changes(sig, runs)[1]


def _direction_changes(sig: np.ndarray, runs: List[Tuple[int, int]]) -> Tuple[int, int, int]:
    """(reversals, of which within a run, decided samples) of the direction signal ``sig`` whose contiguous
    runs are ``runs`` (the pre-pass sample's pieces, in time order; docs/method.md 6c).

    The direction is decided with the strokes' hysteresis (beyond 30 % of the p95 magnitude; it holds
    through the dead band between). It is carried over the gap between two runs: when the first direction
    decided in a run differs from the last one decided before it, the motion changed direction in the gap
    (an odd number of times, so at least once): a reversal, whatever the gap's length (the count is a lower
    bound; a stroke longer than a piece is counted). Decided samples are those beyond the threshold.
    """
    parts = [sig[a:b] for a, b in runs if b > a]
    if not parts:
        return 0, 0, 0
    whole = parts[0] if len(parts) == 1 else np.concatenate(parts)
    fin = np.abs(whole[np.isfinite(whole)])
    if fin.size == 0:
        return 0, 0, 0
    thr = 0.3 * float(np.percentile(fin, 95))
    with np.errstate(invalid="ignore"):
        raw = np.where(whole > thr, 1, np.where(whole < -thr, -1, 0))
    at = np.flatnonzero(raw)
    changed = np.diff(raw[at]) != 0
    piece = np.searchsorted(np.cumsum([p.size for p in parts]), at, side="right")
    within = changed & (piece[1:] == piece[:-1])
    return int(np.count_nonzero(changed)), int(np.count_nonzero(within)), int(at.size)


def _forces_sample(source: Any, rec: Any, tare_n: int) -> Optional[Dict[str, np.ndarray]]:
    """fy and fz to look at: the recording's bounded sample, or a mapping's or list of mappings' arrays (None for
    a stream); with channels of equal length, only the samples within the kernel's force range."""
    data: Optional[Dict[str, np.ndarray]] = None
    if rec is not None:
        data = _sample_recording(rec, ("fy", "fz"), tare_n)
    elif isinstance(source, Mapping) and "fy" in source and "fz" in source:
        data = {r: np.asarray(source[r], dtype=float) for r in ("fy", "fz")}
    elif isinstance(source, (list, tuple)) and source and all(isinstance(a, Mapping) and "fz" in a and "fy" in a
                                                            for a in source):  # fmt: skip
        data = {r: np.concatenate([np.asarray(a[r], dtype=float) for a in source]) for r in ("fy", "fz")}
    if data is not None and data["fy"].shape == data["fz"].shape and not in_range(data["fy"], data["fz"]):
        # Finite samples within the kernel's range (docs/method.md 4): a window holding another is out of range.
        ok = (np.abs(data["fy"]) <= _core.FORCE_LIMIT) & (np.abs(data["fz"]) <= _core.FORCE_LIMIT)
        data = {r: v[ok] for r, v in data.items()}
    return data


def _tare_offsets(
    fy: np.ndarray, fz: np.ndarray, tare: Any, tare_s: float, tare_n: int
) -> Tuple[np.ndarray, np.ndarray, float, float]:
    """(fy, fz, offset of fy, offset of fz): offsets given as a mapping, or the means of the first ``tare_n``
    samples (``tare_s`` seconds, then left out), else 0."""
    t_fy = t_fz = 0.0
    if isinstance(tare, Mapping):
        t_fy, t_fz = float(tare.get("fy", 0.0)), float(tare.get("fz", 0.0))
    elif tare_n > 0:
        if tare_n >= fz.size:
            raise ValueError(f"tare = {tare_s:g} s covers the whole recording")
        t_fy, t_fz = float(np.mean(fy[:tare_n])), float(np.mean(fz[:tare_n]))
        fy, fz = fy[tare_n:], fz[tare_n:]
    elif tare is not None and not isinstance(tare, (int, float)):
        raise TypeError("tare must be seconds (a number) or a mapping {'fy': N, 'fz': N} of offsets")
    return fy, fz, t_fy, t_fz


def _motion(fy: np.ndarray, static: bool, motion: str,
            channel: Optional[Tuple[str, np.ndarray, List[Tuple[int, int]]]] = None, *,
            scratch: Optional[List[np.ndarray]] = None) -> Dict[str, Any]:  # fmt: skip
    """The share of fy's sign flips, their signal-to-noise ratio and the motion: ``motion`` as given, or with
    "auto" from a velocity or position ``channel`` when there is one (both directions, each at least
    SIGN_FLIP_SHARE of the samples, and MIN_REVERSALS reversals, counted across the sample's pieces), unless its
    direction is held for fewer than MIN_HELD_SAMPLES decided samples per reversal (noise: fy decides), else
    reciprocating when fz has a static level and fy clearly takes both signs, MIN_REVERSALS times or more
    (docs/method.md 6c)."""
    out: Dict[str, Any] = {}
    if channel is not None and motion == "auto":
        role, sig, runs = channel
        fin = sig[np.isfinite(sig)]
        p95 = float(np.percentile(np.abs(fin), 95)) if fin.size else 0.0
        both = min(float(np.mean(fin > 0.3 * p95)), float(np.mean(fin < -0.3 * p95))) if p95 > 0 else 0.0
        turns, _, decided = _direction_changes(sig, runs)
        held = decided / max(turns, 1)
        what = {"v": "the velocity channel v", "x": "the slope of the position channel x"}[role]
        said = f"{what}: {100 * both:.0f} % of the samples in its rarer direction, {turns} reversal" + (
            "" if turns == 1 else "s")  # fmt: skip
        if held >= MIN_HELD_SAMPLES:
            recip = both >= SIGN_FLIP_SHARE and turns >= MIN_REVERSALS
            out.update(motion="reciprocating" if recip else "unidirectional", motion_detected=True,
                       sign_flip_share=both, motion_evidence=said)  # fmt: skip
            return out
        # Its direction is not held: noise (a channel that does not move, or a position's slope under its
        # noise) says nothing about the motion, and fy decides (docs/method.md 6c).
        out = _motion(fy, static, motion, None, scratch=scratch)
        out["motion_evidence"] = (f"{said}, each direction held {held:.2g} samples (noise: under "
                                  f"{MIN_HELD_SAMPLES}, not used); " + out["motion_evidence"])  # fmt: skip
        return out
    p95 = _order.abs_percentile(fy, 95) if fy.size else 0.0
    share = 0.0
    if p95 > 0:  # np.mean of the comparisons, without a float array: an exact count over the size
        pos = np.count_nonzero(fy > 0.3 * p95) / fy.size
        neg = np.count_nonzero(fy < -0.3 * p95) / fy.size
        share = min(pos, neg)
    out["sign_flip_share"] = share
    # Both directions' friction must stand out of the noise: a friction near zero (a tare that takes
    # most of it, a lubricated contact) changes sign with the noise alone.
    noise = _noise_sd(fy, scratch)
    sides = _side_medians(fy)
    snr = min(sides) / noise if noise > 0 else np.inf
    out["sign_snr"] = float(snr)
    if motion == "auto":
        # Only forces with their static level tell the sliding direction: a
        # dynamic (high-passed) fy changes sign with every oscillation.
        recip = static and share >= SIGN_FLIP_SHARE and snr >= RECIPROCATING_SNR
        turns = _reversals(fy, [(0, fy.size)]) if recip else 0
        recip = recip and turns >= MIN_REVERSALS
        out["motion"] = "reciprocating" if recip else "unidirectional"
        out["motion_detected"] = True
        said = f", {turns} reversal{'' if turns == 1 else 's'}" if turns else ""
        out["motion_evidence"] = (f"fy: {100 * share:.0f} % of the samples in its rarer sign, both sides "
                                  f"{snr:.3g} noise SDs{said}")  # fmt: skip
    else:
        out["motion"] = motion
        out["motion_detected"] = False
    return out


# -- classical COF per window ---------------------------------------------------------


# -- strokes --------------------------------------------------------------------------
