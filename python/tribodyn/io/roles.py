"""The automatic role map by evidence (docs/method.md 6f): which tangential channel carries the friction.

Names alone cannot say it: a rig sliding along x exports its friction as
``Fx`` and the lateral axis as ``Fy``. When the caller does not map ``fy``
and a recording has several tangential channels (:data:`~tribodyn.io.base.TANGENTIAL_NAMES`:
Fx, Fy, Ff, Ft, "Friction Force"...), :func:`choose_roles` looks at the
pre-pass sample (:func:`tribodyn.pipeline.prepass.sample_channels`) and binds ``fy``
to the channel that carries the friction:

* a channel whose sign follows the sliding direction (the strokes of a mapped
  ``v`` or ``x`` channel, else the channel's own sign reversals), on a
  reciprocating rig;
* otherwise the channel with the larger, steadier |Ft|/|Fn| (median and
  coefficient of variation over the samples in contact).

:func:`decide` is the rule on arrays; :class:`RoleChoice` holds the map, the
evidence per candidate and whether the choice is ambiguous.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .. import _core
from ..kernels import _order
from .sample import PREPASS_SAMPLES

__all__ = [
    "FOLLOW_SHARE",
    "MIN_STROKES",
    "RATIO_MARGIN",
    "ROLE_SAMPLES",
    "Candidate",
    "RoleChoice",
    "choose_roles",
    "decide",
    "missing_roles",
]

#: A channel follows the sliding direction when its sign agrees with it (either way round: the sign
#: depends on how the sensor is mounted) in at least this share of the strokes.
FOLLOW_SHARE = 0.9
#: Fewest strokes, both directions among them, for the sign evidence (a channel of noise follows
#: 4 strokes by chance one time in 8, and then still has to win on |Ft|/|Fn| among the followers).
MIN_STROKES = 4
#: One candidate is clearly the friction axis when its median |Ft|/|Fn| is at least this many times the
#: next one's, or it is larger and its coefficient of variation at most the next one's / RATIO_MARGIN.
RATIO_MARGIN = 1.5
#: Samples the choice looks at: the pre-pass sample's pieces (docs/method.md 6a), each a quarter as long.
ROLE_SAMPLES = PREPASS_SAMPLES // 4
#: Two channels are one axis (CETR's Ff = |Fx|) when |a| = |b| (within 0.1 %) on this share of samples.
SAME_AXIS_SHARE = 0.99

#: Why the names decide for dynamic forces (:attr:`RoleChoice.note`).
NOT_STATIC = "fz carries no static level (dynamic forces): |Ft|/|Fn| says nothing, the names decide"

#: Rules of :attr:`RoleChoice.rule`.
RULE_MOTION = "sign follows the motion"
RULE_REVERSALS = "sign reverses with its strokes"
RULE_RATIO = "larger, steadier |Ft|/|Fn|"
RULE_SAME = "one axis"
RULE_NAMES = "names"


@dataclasses.dataclass(frozen=True)
class Candidate:
    """The evidence on one tangential channel.

    Attributes
    ----------
    channel : str
        The channel.
    ratio : float
        Median |Ft|/|Fn| over the samples in contact (NaN when none).
    cv : float
        Coefficient of variation (std / mean) of |Ft|/|Fn| over those samples.
    follows : float or None
        Share of the strokes in which the channel's sign follows the sliding direction (of the motion
        channel, or its own strokes without one); None when fewer than :data:`MIN_STROKES` strokes.
    strokes : int
        Strokes judged for ``follows``.
    same_as : str or None
        The candidate it duplicates (equal magnitudes), which stands for both.
    """

    channel: str
    ratio: float
    cv: float
    follows: Optional[float] = None
    strokes: int = 0
    same_as: Optional[str] = None

    def text(self, motion: Optional[str], full: bool) -> str:
        """The evidence in words: ``full`` for the chosen channel, else the ratio only (and the sign)."""
        if self.same_as is not None:
            return f"{self.channel} the same axis (|{self.channel}| = |{self.same_as}|)"
        ratio = "no sample in contact" if not math.isfinite(self.ratio) else f"{self.ratio:.2f}"
        parts = [f"|Ft|/|Fn| {ratio}" if full else ratio]
        if math.isfinite(self.cv):
            parts.append(f"CV {self.cv:.2f}")
        if self.follows is not None and motion:
            parts.append(f"sign follows {motion} in {100 * self.follows:.0f} % of {self.strokes} strokes")
        elif self.follows is not None:
            parts.append(f"{self.strokes} strokes of its own sign, held {100 * self.follows:.0f} %")
        return ", ".join(parts) if full else f"{self.channel} {', '.join(parts)}"


@dataclasses.dataclass(frozen=True)
class RoleChoice:
    """The automatic binding of the friction role and its evidence (``Results.params["roles_evidence"]``).

    Attributes
    ----------
    roles : dict
        The whole role map chosen (role -> channel).
    friction : str or None
        The channel bound to ``fy`` (None: the names bound none and the evidence could not).
    rule : str
        What decided: "sign follows the motion", "sign reverses with its strokes", "larger, steadier
        |Ft|/|Fn|", "one axis" (the candidates are one signal) or "names" (no evidence: the names' map
        is kept, ``note`` says why).
    candidates : tuple of Candidate
        The evidence per tangential channel, in file order.
    ambiguous : bool
        The evidence does not single one channel out (two alike, or the sign and the ratio disagree):
        :attr:`warning` names both.
    motion : str or None
        The channel that gave the sliding direction (mapped ``v`` or ``x``), None without one.
    samples : int
        Samples in contact looked at.
    rival : str or None
        The other channel of an ambiguous choice.
    note : str
        Why the evidence was not used or what weakened it ('' when nothing).
    """

    roles: Dict[str, str]
    friction: Optional[str]
    rule: str
    candidates: Tuple[Candidate, ...] = ()
    ambiguous: bool = False
    motion: Optional[str] = None
    samples: int = 0
    rival: Optional[str] = None
    note: str = ""

    def _get(self, channel: Optional[str]) -> Optional[Candidate]:
        return next((c for c in self.candidates if c.channel == channel), None)

    def evidence_text(self) -> str:
        """``Fx (|Ft|/|Fn| 0.31, CV 0.10, sign follows x in 98 % of 40 strokes; Fy 0.02, CV 0.80)``."""
        chosen = self._get(self.friction)
        if chosen is None:
            return f"{self.friction or 'none'} ({self.note or self.rule})"
        others = [c.text(self.motion, False) for c in self.candidates if c is not chosen]
        return f"{self.friction} ({'; '.join([chosen.text(self.motion, True), *others])})"

    @property
    def warning(self) -> Optional[str]:
        """The one-line warning of an ambiguous choice, naming both channels (None when clear)."""
        if not self.ambiguous:
            return None
        a, b = self._get(self.friction), self._get(self.rival)
        ev_a = a.text(self.motion, True) if a else ""
        ev_b = b.text(self.motion, True) if b else ""
        why = f"; {self.note}" if self.note else ""
        return (
            f"friction channel ambiguous: fy <- {self.friction} ({ev_a}) but {self.rival} is alike ({ev_b}){why}; "
            f"check them and map the friction channel (--map fy={self.rival}, channels={{'fy': '{self.rival}'}})"
        )

    def as_dict(self) -> Dict[str, Any]:
        """Plain values for ``Results.params`` and summary.json (NaN as None)."""

        def num(v: float) -> Optional[float]:
            return float(v) if math.isfinite(v) else None

        return {
            "friction": self.friction,
            "rule": self.rule,
            "ambiguous": self.ambiguous,
            "rival": self.rival,
            "motion": self.motion,
            "samples": self.samples,
            "note": self.note,
            "candidates": {
                c.channel: {
                    "ratio_median": num(c.ratio),
                    "ratio_cv": num(c.cv),
                    "follows": c.follows,
                    "strokes": c.strokes,
                    "same_as": c.same_as,
                }  # fmt: skip
                for c in self.candidates
            },
            "text": self.evidence_text(),
        }


def _static(fz: np.ndarray) -> bool:
    """fz carries a static level (|median| > 3 MAD), as the pre-pass decides (docs/method.md 6a)."""
    finite = np.isfinite(fz)
    fin = fz if finite.all() else fz[finite]
    if fin.size == 0:
        return False
    med = _order.median(fin)  # NumPy's median and MAD, bit for bit, in a parallel pass each
    return abs(med) > 0 and abs(med) > 3.0 * _order.median_abs_dev(fin, med)


def _stroke_signs(ft: np.ndarray, strokes: Sequence[Tuple[int, int, int]]) -> Tuple[float, int]:
    """Share of the strokes whose central half has the median sign of the stroke's direction (or all the
    other way round: the larger of the two shares), and the strokes judged."""
    agree = against = judged = 0
    for a, b, d in strokes:
        m = b - a
        seg = ft[a + m // 4 : b - m // 4]
        seg = seg[np.isfinite(seg)]
        if seg.size == 0:
            continue
        judged += 1
        s = np.sign(np.median(seg))
        agree += int(s == d)
        against += int(s == -d)
    return (max(agree, against) / judged if judged else 0.0), judged


def _own_signs(ft: np.ndarray, strokes: Sequence[Tuple[int, int, int]]) -> float:
    """Share of the samples in the central halves of a channel's own strokes that carry the stroke's sign:
    counts of each sign and of the finite samples by differences of running sums (no loop over strokes)."""
    if not strokes:
        return 0.0
    a, b, d = np.asarray(strokes, dtype=np.int64).T
    m = b - a
    lo = np.minimum(a + m // 4, ft.size)  # as slices are cut: within the array, never reversed
    hi = np.maximum(np.minimum(b - m // 4, ft.size), lo)
    sign = np.sign(ft)  # NaN stays NaN: neither sign, and not finite

    def run(mask: np.ndarray) -> np.ndarray:
        return np.concatenate(([0], np.cumsum(mask, dtype=np.int64)))

    pos, neg, fin = run(sign == 1), run(sign == -1), run(np.isfinite(ft))
    hits = int(np.sum(np.where(d == 1, pos[hi] - pos[lo], np.where(d == -1, neg[hi] - neg[lo], 0))))
    total = int(np.sum(fin[hi] - fin[lo]))
    return hits / total if total else 0.0


def _reversing(strokes: Sequence[Tuple[int, int, int]]) -> bool:
    return len(strokes) >= MIN_STROKES and {d for _, _, d in strokes} == {-1, 1}


def _by_magnitude(cands: Sequence[Candidate]) -> Tuple[Candidate, Optional[Candidate], bool]:
    """The candidate of largest median |Ft|/|Fn|, the runner-up, and whether the first clearly wins."""
    order = sorted(cands, key=lambda c: c.ratio if math.isfinite(c.ratio) else -math.inf, reverse=True)
    best = order[0]
    if len(order) == 1:
        return best, None, True
    nxt = order[1]
    if not (math.isfinite(nxt.ratio) and nxt.ratio > 0):
        return best, nxt, math.isfinite(best.ratio)
    larger = best.ratio >= RATIO_MARGIN * nxt.ratio
    steadier = best.ratio > nxt.ratio and math.isfinite(best.cv) and best.cv * RATIO_MARGIN <= nxt.cv
    return best, nxt, bool(larger or steadier)


def _same_signals(ft: Mapping[str, np.ndarray], names: Sequence[str], preferred: Optional[str]) -> Dict[str, str]:
    """One signal exported twice (CETR's Ff = |Fx|): dropped channel -> the one that stands for both (the
    preferred name, else the first)."""
    same: Dict[str, str] = {}
    for i, a in enumerate(names):
        if a in same:
            continue
        for b in names[i + 1 :]:
            if b in same:
                continue
            ok = np.isfinite(ft[a]) & np.isfinite(ft[b])
            equal = np.isclose(np.abs(ft[a][ok]), np.abs(ft[b][ok]), rtol=1e-3, atol=0.0)
            if equal.size and float(np.mean(equal)) >= SAME_AXIS_SHARE:
                keep, drop = (b, a) if b == preferred else (a, b)
                same[drop] = keep
                if drop == a:
                    break
    return same


def _candidate(name: str, f: np.ndarray, absz: np.ndarray, ref_strokes: Sequence[Tuple[int, int, int]],
               boundaries: Sequence[Tuple[int, int]], *, same_as: Optional[str]) -> Candidate:  # fmt: skip
    """The evidence for one tangential channel ``f`` (NaN outside contact): its |Ft|/|Fn| and whether its
    sign follows the motion's strokes (or its own reversals without a motion channel)."""
    from ..kernels.strokes import find_strokes

    r = np.abs(f) / absz
    r = r[np.isfinite(r)]
    ratio = float(np.median(r)) if r.size else math.nan
    mean = float(np.mean(r)) if r.size else 0.0
    cv = float(np.std(r) / mean) if mean > 0 else math.nan
    follows: Optional[float] = None
    judged = 0
    if ref_strokes:
        share, judged = _stroke_signs(f, ref_strokes)
        follows = share if judged >= MIN_STROKES else None
    else:
        own = find_strokes(f, boundaries=boundaries, kind="fy")
        if _reversing(own):
            follows, judged = _own_signs(f, own), len(own)
    return Candidate(name, ratio, cv, follows, judged, same_as)


def decide(
    forces: Mapping[str, np.ndarray],
    fz: np.ndarray,
    *,
    motion: Optional[np.ndarray] = None,
    motion_kind: str = "x",
    motion_name: Optional[str] = None,
    boundaries: Sequence[Tuple[int, int]] = (),
    preferred: Optional[str] = None,
) -> RoleChoice:
    """Which of ``forces`` (channel -> samples, at least two, file order) carries the friction.

    ``fz`` is the normal force over the same samples; ``motion`` a velocity (``motion_kind`` "v") or
    position ("x") over them, named ``motion_name``; ``boundaries`` the contiguous runs of samples
    (strokes are not found across two); ``preferred`` the channel the names bound to ``fy``, kept
    among channels that are one signal. The returned choice's ``roles`` is empty (see
    :func:`choose_roles`).
    """
    from ..kernels.strokes import find_strokes
    from .sample import MIN_FN_FRACTION

    names = list(forces)
    if len(names) < 2:
        raise ValueError("decide needs at least two tangential channels")
    fz = np.asarray(fz, dtype=float)
    first = preferred if preferred in forces else names[0]
    if not _static(fz):
        return RoleChoice({}, first, RULE_NAMES, note=NOT_STATIC)
    absz = np.abs(fz)
    contact = np.isfinite(fz) & (absz >= MIN_FN_FRACTION * float(np.median(absz[np.isfinite(absz)]))) & (absz > 0)
    ft = {n: np.where(contact, np.asarray(forces[n], dtype=float), np.nan) for n in names}
    same = _same_signals(ft, names, preferred)
    ref_strokes: List[Tuple[int, int, int]] = []
    note = ""
    if motion is not None:
        ref_strokes = find_strokes(np.asarray(motion, dtype=float), boundaries=boundaries, kind=motion_kind)
        if not _reversing(ref_strokes):
            note = f"{motion_name or motion_kind} shows fewer than {MIN_STROKES} strokes: its sign not used"
            ref_strokes = []
    cands = [_candidate(n, ft[n], absz, ref_strokes, boundaries, same_as=same.get(n)) for n in names]
    samples = int(np.count_nonzero(contact))
    reps = [c for c in cands if c.same_as is None]
    if len(reps) == 1:
        return RoleChoice({}, reps[0].channel, RULE_SAME, tuple(cands), samples=samples, note=note)
    by_ratio, _, _ = _by_magnitude(reps)
    followers = [c for c in reps if c.follows is not None and c.follows >= FOLLOW_SHARE]
    rule = RULE_MOTION if ref_strokes else RULE_REVERSALS
    mname = motion_name if ref_strokes else None
    if followers:
        best, nxt, clear = _by_magnitude(followers)
        top = by_ratio
        if top not in followers and top.ratio >= RATIO_MARGIN * best.ratio:
            # The sign and the magnitude disagree: a motion channel is the stronger evidence; a force's
            # own reversals are not (a lateral channel drifting through zero reverses too).
            why = f"the sign says {best.channel}, |Ft|/|Fn| says {top.channel}"
            note = "; ".join(x for x in (note, why) if x)
            if ref_strokes:
                return RoleChoice({}, best.channel, rule, tuple(cands), True, mname, samples, top.channel, note)
            return RoleChoice({}, top.channel, RULE_RATIO, tuple(cands), True, mname, samples, best.channel, note)
        rival = None if clear or nxt is None else nxt.channel
        return RoleChoice({}, best.channel, rule, tuple(cands), not clear, mname, samples, rival, note)
    best, nxt, clear = _by_magnitude(reps)
    ambiguous = not clear
    if ref_strokes:
        note = "; ".join(x for x in (note, f"no tangential channel's sign follows {mname}") if x)
        ambiguous = True
    rival = nxt.channel if ambiguous and nxt is not None else None
    return RoleChoice({}, best.channel, RULE_RATIO, tuple(cands), ambiguous, mname, samples, rival, note)


def missing_roles(roles: Mapping[str, Any], names: Sequence[Any]) -> Tuple[List[str], str, str]:
    """The parts of a "lacks the required channel(s)" message (the API's, ``pipeline.analyze``, and the command
    line's): the required roles fy and fz that ``roles`` lacks, the map in words ("fy='A', fz='B'" or "none"),
    and the channels ``names`` in words (the first 30 and how many more, or "none")."""
    missing = [r for r in ("fy", "fz") if r not in roles]
    mapped = ", ".join(f"{r}={c!r}" for r, c in roles.items()) or "none"
    shown = ", ".join(repr(str(n)) for n in names[:30]) + (f" and {len(names) - 30} more" if len(names) > 30 else "")
    return missing, mapped, shown or "none"


def choose_roles(rec: Any, channels: Optional[Mapping[str, Optional[str]]]) -> Optional[RoleChoice]:
    """Binds ``fy`` of an open recording by evidence when the caller did not map it and the recording has
    two tangential channels or more (see the module docstring); None when there is nothing to choose.

    Reads the pre-pass sample of the candidates, ``fz`` and the motion channel (``v``, else ``x``, when
    mapped), rebinds the recording's map (``fx`` goes to the remaining lateral axis, Fx or Fy, when
    there is one) and adds the warning of an ambiguous choice to ``rec.warnings``.
    """
    from .base import TANGENTIAL_NAMES, RecordingError, base_name
    from .sample import in_range, sample_channels

    if channels is not None and "fy" in channels:
        return None
    given = dict(getattr(rec, "roles_given", {}) or {})
    roles = dict(rec.roles)
    names = [n for n in rec.channel_names if base_name(n) in TANGENTIAL_NAMES and n not in given.values()]
    fz = roles.get("fz")
    if len(names) < 2 or fz is None or fz in names:
        return None
    by_role = [k for k in rec.keys_by_role if k in ("fx", "fy") and k not in given]
    if by_role:
        raise RecordingError(
            f"{rec.path}: scale/units name role {by_role[0]!r}, but the friction channel is chosen from the data "
            f"among {', '.join(names)}: map it (--map fy=CHANNEL) or key the scale by channel name"
        )
    kind = "v" if "v" in roles else ("x" if "x" in roles else None)
    mchan = roles[kind] if kind else None

    def in_kernel_range(v: np.ndarray) -> np.ndarray:
        # Forces beyond the kernel's range count as missing, as in the pre-pass (docs/method.md 4).
        return v if in_range(v) else np.where(np.abs(v) <= _core.FORCE_LIMIT, v, np.nan)

    try:
        # fz first: without its static level the names decide (:func:`decide`), and the tangential channels
        # are not read (the same samples: the pieces depend on the recording's length only).
        data, bounds = sample_channels(rec, [fz], limit=ROLE_SAMPLES)
        data[fz] = in_kernel_range(data[fz])
        if not _static(data[fz]):
            return RoleChoice(roles, roles.get("fy"), RULE_NAMES, note=NOT_STATIC)
        data.update(sample_channels(rec, [*names, *([mchan] if mchan else [])], limit=ROLE_SAMPLES)[0])
    except RecordingError as exc:
        # A damaged body: opening still works (``tribodyn info`` lists the channels) and the read that
        # needs the damaged rows fails with their line; the map stays the names' and says why.
        rec.warnings.append(f"the friction channel could not be chosen from the data ({exc}): the names decide")
        return None
    data.update({n: in_kernel_range(data[n]) for n in names})
    forces = {n: data[n] for n in names}
    preferred = roles.get("fy") if roles.get("fy") in names else None
    choice = decide(forces, data[fz], motion=data[mchan] if mchan else None, motion_kind=kind or "x",
                    motion_name=mchan, boundaries=bounds, preferred=preferred)  # fmt: skip
    if choice.rule == RULE_NAMES:
        return dataclasses.replace(choice, roles=roles, friction=roles.get("fy"))
    # Roles the caller gave stay; the automatic fx and fy are bound anew, and no other automatic role keeps
    # the friction channel.
    new = {r: c for r, c in roles.items() if r in given or (r not in ("fx", "fy") and c != choice.friction)}
    new["fy"] = choice.friction
    if "fx" not in new:
        lateral = [
            c.channel
            for c in choice.candidates
            if c.channel != choice.friction and c.same_as is None and base_name(c.channel) in ("fx", "fy")
        ]
        if len(lateral) == 1:
            new["fx"] = lateral[0]
    order = [r for r in roles if r in new] + [r for r in new if r not in roles]
    new = {r: new[r] for r in order}
    if new != roles:
        rec._rebind(new)
    choice = dataclasses.replace(choice, roles=new)
    if choice.warning:
        rec.warnings.append(choice.warning)
    return choice
