"""Watching a running test: ``tribodyn.watch`` (docs/method.md 11).

A recording that a DAQ or a tribometer is still writing is followed
(:class:`tribodyn.io.follow.Follower`): at each update the whole windows
written since the last one are analysed on their own (the windows of a range
cut on the window grid are those of one pass, docs/method.md 9), joined to the
earlier ones and finished once (:func:`tribodyn.pipeline.analyze.combine`),
so an update costs the new data, not the recording. Each update gives a
:class:`~tribodyn.results.Results` snapshot: the table, the headline and its
interval, the verdict so far. Trip rules (:func:`parse_trip`) are checked on
the windows each update adds. When watching stops (the file idle for
``until_idle`` s, a trip, :meth:`Watch.stop`, Ctrl-C), the last Results is the
analysis of the complete file, that of :func:`tribodyn.analyze`: what the
pre-pass finds (tare, contact, motion) is then found from the whole file.
"""

from __future__ import annotations

import dataclasses
import math
import re
import time
from dataclasses import dataclass
from typing import Any, Callable, Dict, Iterator, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from ..io.base import Recording
from ..io.follow import Follower
from ..results import CACHED, ClassicalTotals, Results
from .analyze import Partial, analyze, analyze_partial, combine
from .instrument import lag_sample_held
from .plan import make_plan
from .routes import concat_stats
from .stickslip import find_stick_slip

__all__ = ["watch", "Watch", "TripRule", "Trip", "parse_trip", "cof_column", "TRIP_RULES", "DEFAULT_INTERVAL"]

#: Seconds between updates (``interval=``, ``--interval``).
DEFAULT_INTERVAL = 2.0
#: The stick-slip rule looks at the last this many seconds of samples at each update (at least 4 windows).
STICK_SLIP_SPAN_S = 30.0
#: A snapshot's bootstrap intervals (docs/method.md 3d) are drawn again once its gated windows have grown by this
#: share since they were drawn; in between, each is the last drawn, moved with its statistic, its ends' distances
#: scaled by sqrt(n_then / n_now) (docs/method.md 11).
REDRAW_GROWTH = 0.1

#: What the pre-pass finds (tare, contact threshold, motion) and the instrument lag are looked for again once the
#: recording has grown this many times since they were found (docs/method.md 11).
REFIND_GROWTH = 4

#: The rules a trip may name, with what each compares (docs/method.md 11).
TRIP_RULES = {
    "cof": "the COF of each new window (the column of the headline's method) against the limit",
    "fn": "the mean normal force |fz| of each new window [N] (recordings with a static normal force)",
    "stick-slip": "stick-slip present in the last 30 s (docs/method.md 6g)",
    "contact-loss": "a new window with contact loss (docs/method.md 7), or a mean normal force below the contact "
    "threshold min_fn",
    "no-data": "the file has not grown for the given time",
}

_RULE = re.compile(
    r"^\s*(?:(?P<q>cof|fn)\s*(?P<op><=|>=|<|>)\s*(?P<x>[-+0-9.eE]+)|(?P<flag>stick-slip|contact-loss|no-data))"
    r"(?:\s+for\s+(?P<d>[0-9.eE+]+)\s*s)?\s*$",
    re.IGNORECASE,
)


@dataclass(frozen=True)
class TripRule:
    """A trip rule (:func:`parse_trip`): ``quantity op limit [for duration s]``, or a flag."""

    text: str
    quantity: str  # "cof", "fn", "stick-slip", "contact-loss", "no-data"
    op: str = ""
    limit: float = math.nan
    duration: float = 0.0

    def holds(self, value: float) -> bool:
        """Whether ``value`` is beyond the limit (a NaN never is)."""
        if not math.isfinite(value):
            return False
        return {"<": value < self.limit, ">": value > self.limit, "<=": value <= self.limit,
                ">=": value >= self.limit}[self.op]  # fmt: skip


@dataclass(frozen=True)
class Trip:
    """A rule that tripped: the rule, when (s from the recording's start) and the value that tripped it."""

    rule: str
    time: float
    value: float
    message: str

    def as_dict(self) -> Dict[str, Any]:
        return dataclasses.asdict(self)


def parse_trip(text: str) -> TripRule:
    """A trip rule from its text: ``cof>0.3``, ``cof<0.05``, ``cof>0.3 for 10s``, ``fn<1``, ``stick-slip``,
    ``contact-loss``, ``no-data for 30s`` (docs/method.md 11). A ValueError names the forms."""
    m = _RULE.match(str(text))
    if m is None:
        raise ValueError(
            f"trip rule {text!r} not understood: use cof>X, cof<X, fn<X, fn>X (optionally 'for S s'), stick-slip, "
            "contact-loss or 'no-data for S s'"
        )
    d = float(m["d"]) if m["d"] else 0.0
    if not (math.isfinite(d) and d >= 0):
        raise ValueError(f"trip rule {text!r}: the duration must be a finite number of seconds >= 0")
    if m["flag"]:
        flag = m["flag"].lower()
        if flag == "no-data" and d <= 0:
            raise ValueError(f"trip rule {text!r}: say for how long, e.g. 'no-data for 30s'")
        return TripRule(str(text).strip(), flag, duration=d)
    try:
        x = float(m["x"])
    except ValueError:
        raise ValueError(f"trip rule {text!r}: {m['x']!r} is not a number") from None
    if not math.isfinite(x):
        raise ValueError(f"trip rule {text!r}: the limit must be finite")
    return TripRule(str(text).strip(), m["q"].lower(), m["op"], x, d)


#: The per-window COF column of each headline method (a trip compares it with the limit).
_COF_COLUMN = {"dynamic": "mu_r", "classical": "mu_classical", "per-stroke": "mu_classical",
               "instrument": "mu_instrument"}  # fmt: skip


def cof_column(method: str) -> str:
    """The table's per-window COF of a headline method: what a trip compares and the live page plots."""
    return _COF_COLUMN.get(method, "mu_r")


class _TripState:
    """A rule's run of windows beyond the limit (its start time), kept across updates."""

    def __init__(self, rule: TripRule) -> None:
        self.rule = rule
        self.since: Optional[float] = None

    def windows(self, t: np.ndarray, v: np.ndarray, half: float) -> Optional[Trip]:
        """The first of the windows (centres ``t``, values ``v``) that completes the rule, or None."""
        r = self.rule
        for ti, vi in zip(t.tolist(), v.tolist()):
            if not r.holds(vi):
                self.since = None
                continue
            if self.since is None:
                self.since = ti - half
            if ti + half - self.since >= r.duration:
                return Trip(r.text, ti, vi, f"trip {r.text!r} at t = {ti:.1f} s: {r.quantity} = {vi:.4g}")
        return None


class Watch:
    """The updates of a recording being written (:func:`watch`): iterate for Results snapshots.

    Attributes
    ----------
    path : str
        The file.
    tripped : Trip or None
        The trip that ended the watch.
    reason : str
        Why watching ended ('' while it goes on): "idle", "trip", "stopped", "interrupted".
    n_samples : int
        Whole samples seen.
    updates : int
        Snapshots given.
    final : Results or None
        The analysis of the complete file, once watching ended (``final=True``).
    notes : list of str
        What the watch noticed (a rule that cannot apply to this recording).
    """

    def __init__(self, path: str, *, interval: float, until_idle: Optional[float], trips: Sequence[TripRule],
                 open_options: Mapping[str, Any], options: Mapping[str, Any], final: bool,
                 clock: Callable[[], float], sleep: Callable[[float], None]) -> None:  # fmt: skip
        self.path = str(path)
        self.interval, self.until_idle, self.final_wanted = interval, until_idle, final
        self.open_options, self.options = dict(open_options), dict(options)
        self._clock, self._sleep = clock, sleep
        self.follower = Follower(self.path, self._open, clock=clock, usable=self._usable)
        self.rules = tuple(trips)
        self._states = [_TripState(r) for r in self.rules if r.quantity in ("cof", "fn")]
        self._acc: Optional[Partial] = None  # the ranges analysed so far, joined (one Partial: an update's cost
        self._ranges = 0  # does not grow with the ranges before it)
        self._done = 0  # windows analysed
        self._rows = 0  # windows whose trips were checked
        self._found: Optional[Partial] = None  # the range whose findings the next ranges take
        self._found_at = 0  # the samples seen when they were found
        self._grid: Optional[Tuple[int, int]] = None
        self._drawn: Optional[_Drawn] = None  # the last bootstrap of a snapshot's mu_r
        self._draw = False  # whether this update's snapshot draws its intervals
        self._columns: Optional[_Drawn] = None  # the last bootstrap of the summary's other columns
        self._columns_moved = False  # whether the latest snapshot's column intervals were moved, not drawn
        self.tripped: Optional[Trip] = None
        self.reason = ""
        self.updates = 0
        self.final: Optional[Results] = None
        self.latest: Optional[Results] = None
        self.notes: List[str] = []
        self._stop = False
        #: Called with why nothing new was analysed at an update (the file missing, a row being written, no
        #: new data), each time that reason changes: the command line shows it.
        self.on_wait: Optional[Callable[[str], Any]] = None
        self._waiting = ""

    def _usable(self, rec: Recording) -> str:
        """Why the first opening cannot be analysed yet ('' when it can): a writer that has not yet created
        the friction or the normal-force channel (an HDF5 file's datasets, made one after the other)."""
        roles = rec.roles
        have = {"fy": "fy" in roles or "cof" in roles, "fz": "fz" in roles or self.options.get("load") is not None}
        missing = [r for r, ok in have.items() if not ok]
        return f"its channels do not (yet) include {' and '.join(missing)}" if missing else ""

    def _open(self, path: str, **kw: Any) -> Recording:
        from ..io import open_recording

        return open_recording(path, appending=True, **{**self.open_options, **kw})

    @property
    def n_samples(self) -> int:
        return self.follower.n_samples

    def stop(self) -> None:
        """Ends the watch at the next update (the analysis of the complete file is then the last Results)."""
        self._stop = True

    def __iter__(self) -> Iterator[Results]:
        try:
            while True:
                snap = self.update()
                if snap is not None:
                    self._waiting = ""
                    yield snap
                elif self.on_wait is not None and self.follower.waiting and self.follower.waiting != self._waiting:
                    self._waiting = self.follower.waiting
                    self.on_wait(self._waiting)
                if self.reason:
                    break
                self._sleep(self.interval)
        except KeyboardInterrupt:
            self.reason = "interrupted"
        finally:
            self.follower.close()
        if self.final_wanted and self.follower.recording is not None:
            self.final = self.complete()
            yield self.final

    def update(self) -> Optional[Results]:
        """One update: the new whole windows analysed and a snapshot (None when nothing new); ends the watch
        (:attr:`reason`) on a trip, idleness or :meth:`stop`."""
        if self._stop:
            self.reason = "stopped"
            return None
        self.follower.poll()
        snap = self._extend()
        self._check_idle()
        if snap is not None:
            self._check_trips(snap)
            self.latest = snap
            self.updates += 1
        return snap

    def _check_idle(self) -> None:
        idle = self._clock() - self.follower.grown_at
        for r in self.rules:
            if r.quantity == "no-data" and idle >= r.duration and self.tripped is None:
                t = self.n_samples / self.follower.recording.fs if self.follower.recording is not None else 0.0
                self.tripped = Trip(r.text, t, idle, f"trip {r.text!r}: no new data for {idle:.0f} s")
                self.reason = "trip"
        if not self.reason and self.until_idle is not None and idle >= self.until_idle:
            self.reason = "idle"

    def _extend(self) -> Optional[Results]:
        rec = self.follower.recording
        if rec is None:
            return None
        if self._grid is None:
            plan = make_plan(fs=rec.fs, window=self.options.get("window"), hop=self.options.get("hop"))
            self._grid = (plan.length, plan.step)
        length, step = self._grid
        n = rec.n_samples
        # the windows whose successor is whole too: the range's samples then end where the next range's start
        # (the classical COF's sums partition the samples, docs/method.md 6e)
        whole = 0 if n < length else (n - length) // step + 1
        upto = whole - 1
        if upto <= self._done:
            return None
        start, stop = self._done * step, (upto - 1) * step + length
        # What the pre-pass finds (tare, contact, motion) and the instrument lag are looked for again each time
        # the recording has grown REFIND_GROWTH times since they were found, else taken from that range
        # (docs/method.md 11). The lag's windows are the recording's first ones: once they were all there, it is
        # not looked for again.
        fresh = self._found_at == 0 or n >= REFIND_GROWTH * self._found_at
        held = fresh and self._found is not None and lag_sample_held(rec, length, self._found_at)
        part = analyze_partial(rec, start=start, stop=stop, reuse=None if fresh else self._found,
                               reuse_lag=self._found if held else None, **self.options)  # fmt: skip
        if fresh:
            self._found, self._found_at = part, n
            if self._acc is not None and self._acc.found.iv_lag_samples != part.found.iv_lag_samples:
                # A snapshot's windows all rest on one instrument lag (their sums are taken at it): the recording
                # so far is analysed again at the lag just found (only until the lag's windows were all held).
                part = analyze_partial(rec, start=0, stop=stop, reuse=part, **self.options)
                self._acc, self._ranges = None, 0
        self._acc = part if self._acc is None else _join(self._acc, part)
        self._ranges += 1
        self._done = upto
        self._draw = False
        self._note_columns_drawn()
        snap = combine([self._acc], intervals=self._intervals)  # (combine leaves the joined statistics as they are)
        drawn = self._drawn
        if self._draw:
            drawn = self._drawn = _Drawn.of(snap)
        at = drawn.columns["mu_r"].n if drawn is not None else None
        params = {**snap.params, "watch": {"samples": n, "final": False, "updates": self.updates + 1,
                                           "samples_analysed": stop, "intervals_drawn_at": at}}  # fmt: skip
        if self._ranges > 1:
            params.update(start=0, stop=None, ranges=self._ranges)
        return snap.replace(keep=CACHED, params=params)  # the watch's params change none of the cached values

    def _note_columns_drawn(self) -> None:
        """The latest snapshot's summary columns' intervals, when it drew them (someone read ``column_ci`` or
        ``summary()``, as the command line does at each update), become those the next snapshots move."""
        last = self.latest
        if last is not None and not self._columns_moved and last.computed("column_ci"):
            self._columns = _Drawn.of_columns(last)

    def _intervals(self, res: Results) -> Optional[Dict[str, Any]]:
        """The snapshot's bootstrap intervals from the last draw, moved and scaled (docs/method.md 11): mu_r's
        (drawn again when the windows grew by REDRAW_GROWTH or fell, or none was drawn) and, when a snapshot drew
        them and they still hold, the summary's other columns' (else they are drawn if and when they are read)."""
        d, mu = self._drawn, _values(res)
        out: Dict[str, Any] = {}
        if d is None or not d.holds(mu):
            self._draw = True
        else:
            out["mu_r_ci"] = d.moved(res, mu)["mu_r_ci"]
        c = self._columns
        columns = res.summary_columns() if c is not None else {}
        self._columns_moved = c is not None and c.holds(columns)
        if self._columns_moved:
            assert c is not None
            out["column_ci"] = c.moved(res, columns)["column_ci"]
        return out or None

    def _check_trips(self, snap: Results) -> None:
        if self.tripped is not None:
            return
        k = len(snap) - self._rows  # the windows this update added
        self._rows = len(snap)
        t = np.asarray(snap["time"], dtype=float)[-k:] if k else np.zeros(0)
        for state in self._states:
            values = self._values(snap, state.rule, k)
            if values is None:
                continue
            half = 0.5 * float(snap.params.get("window", 0.0) or 0.0)
            trip = state.windows(t, values, half)
            if trip is not None:
                self.tripped, self.reason = trip, "trip"
                return
        for r in self.rules:
            trip = self._flag(snap, r, k)
            if trip is not None:
                self.tripped, self.reason = trip, "trip"
                return

    def _values(self, snap: Results, rule: TripRule, k: int) -> Optional[np.ndarray]:
        if rule.quantity == "cof":
            col = cof_column(snap.headline.method)
            return np.asarray(np.abs(np.asarray(snap[col], dtype=float)[-k:]))
        if not snap.params.get("static_fz"):
            self._note(f"trip {rule.text!r} not checked: the recording has no static normal force (a dynamic "
                       "fz is high-passed)")  # fmt: skip
            return None
        return np.asarray(np.abs(np.asarray(snap["fz_mean"], dtype=float)[-k:]))

    def _flag(self, snap: Results, rule: TripRule, k: int) -> Optional[Trip]:
        t = np.asarray(snap["time"], dtype=float)[-k:]
        if rule.quantity == "contact-loss":
            lost = np.array(["contact loss" in str(r) for r in np.asarray(snap["reasons"])[-k:]], dtype=bool)
            min_fn = snap.params.get("min_fn")
            if snap.params.get("static_fz") and isinstance(min_fn, (int, float)) and math.isfinite(min_fn):
                lost |= np.abs(np.asarray(snap["fz_mean"], dtype=float)[-k:]) < float(min_fn)
            if lost.any():
                i = int(np.argmax(lost))
                return Trip(rule.text, float(t[i]), 1.0, f"trip {rule.text!r} at t = {t[i]:.1f} s")
        if rule.quantity == "stick-slip":
            return self._stick_slip(snap, rule)
        return None

    def _stick_slip(self, snap: Results, rule: TripRule) -> Optional[Trip]:
        rec = self.follower.recording
        if rec is None or not snap.params.get("static_fz"):
            self._note(f"trip {rule.text!r} not checked: stick-slip is found in recordings with a static normal "
                       "force (docs/method.md 6g)")  # fmt: skip
            return None
        assert self._grid is not None
        span = max(int(STICK_SLIP_SPAN_S * rec.fs), 4 * self._grid[0])
        b = int(snap.params["watch"]["samples_analysed"])
        a = max(0, b - span)
        recent = _range_of(rec, a, b)
        got = find_stick_slip(recent, analyze(recent, fs=rec.fs, **_reading_free(self.options)))
        if got.present:
            t = b / rec.fs
            return Trip(rule.text, t, float(got.amplitude_cof),
                        f"trip {rule.text!r} at t = {t:.1f} s: {got.verdict}")  # fmt: skip
        return None

    def _note(self, text: str) -> None:
        if text not in self.notes:
            self.notes.append(text)

    def complete(self) -> Results:
        """The analysis of the complete file (that of :func:`tribodyn.analyze`), marked final."""
        from ..io import open_recording

        with open_recording(self.path, appending=True, **self.open_options) as rec:  # a writer may hold it open
            res = analyze(rec, **self.options)
        said = {"samples": res.params.get("n_samples_total"), "final": True, "updates": self.updates,
                "reason": self.reason}  # fmt: skip
        return res.replace(keep=CACHED, params={**res.params, "watch": said})


Intervals = Dict[str, Tuple[float, float]]


@dataclass(frozen=True)
class _Column:
    """One column's bootstrap intervals (``Results.mu_r_ci`` or an entry of ``Results.column_ci``), with the
    statistics and the window count they were drawn at."""

    n: int
    points: Dict[str, float]
    ci: Intervals

    def moved(self, v: np.ndarray, up: float = 0.0, up_then: float = 0.0) -> Intervals:
        """Each interval moved with its statistic over ``v`` (the column's gated windows now), the distances of its
        ends scaled by sqrt(n_then / n_now); ``up``: the upper ends' raise now (``up_then`` at the draw)."""
        now, p = _statistics(v), self.points
        f = math.sqrt(self.n / v.size) if v.size else 1.0
        return {k: (now[k] + f * (lo - p[k]), now[k] + f * (hi - up_then - p[k]) + up)
                for k, (lo, hi) in self.ci.items() if k in now and k in p}  # fmt: skip


@dataclass(frozen=True)
class _Drawn:
    """A snapshot's bootstrap intervals: mu_r's (``Results.mu_r_ci``) and the summary's other columns'
    (``Results.column_ci``), to be moved to the next snapshots (docs/method.md 11)."""

    columns: Dict[str, _Column]
    gap: float  # mu_r's upper ends' raise to the reverse regression (least squares as a lower bound, method.md 3d)

    @classmethod
    def of(cls, res: Results) -> "_Drawn":
        """mu_r's intervals (``Results.mu_r_ci``) as drawn for ``res``."""
        v = _values(res)["mu_r"]
        return cls({"mu_r": _Column(int(v.size), _statistics(v), dict(res.mu_r_ci))}, _raise(res))

    @classmethod
    def of_columns(cls, res: Results) -> "_Drawn":
        """The summary's other columns' intervals (``Results.column_ci``) as drawn for ``res``."""
        cis = res.column_ci
        values = res.summary_columns()
        return cls({k: _Column(int(v.size), _statistics(v), dict(cis[k])) for k, v in values.items()}, 0.0)

    def holds(self, values: Dict[str, np.ndarray]) -> bool:
        """Whether the same columns are summarised (``values``: the snapshot's, as drawn from) and each one's
        values number n_then to (1 + REDRAW_GROWTH) n_then (else the intervals are drawn again)."""
        if set(values) != set(self.columns):
            return False
        return all(c.n == values[k].size == 0 or c.n <= values[k].size < (1.0 + REDRAW_GROWTH) * c.n
                   for k, c in self.columns.items())  # fmt: skip

    def moved(self, res: Results, values: Dict[str, np.ndarray]) -> Dict[str, Any]:
        """The intervals moved to ``values`` (of ``res``: :func:`_values`, or ``Results.summary_columns``):
        "mu_r_ci" when this draw is mu_r's, "column_ci" when it is the other columns'."""
        if "mu_r" in self.columns:
            return {"mu_r_ci": self.columns["mu_r"].moved(values["mu_r"], _raise(res), self.gap)}
        return {"column_ci": {k: c.moved(values[k]) for k, c in self.columns.items()}}


def _values(res: Results) -> Dict[str, np.ndarray]:
    """What the headline's bootstrap draws from: mu_r over the gated windows with a finite value."""
    v = np.asarray(res["mu_r"], dtype=float)[np.asarray(res["ok"], dtype=bool)]
    return {"mu_r": np.asarray(v[np.isfinite(v)])}


def _statistics(v: np.ndarray) -> Dict[str, float]:
    """The statistics whose intervals ``bootstrap_ci`` draws: median, mean, p05, p95."""
    if v.size == 0:
        return {}
    q = np.percentile(v, [5, 50, 95])  # one call for the three (percentile 50 is np.median up to rounding)
    return {"median": float(q[1]), "mean": float(v.mean()), "p05": float(q[0]), "p95": float(q[2])}


def _raise(res: Results) -> float:
    """mu_r's upper ends' raise to the reverse regression when least squares is a lower bound (docs/method.md 3d)."""
    gap = res.params.get("attenuation_gap")
    lower = res.params.get("mu_r_bound") == "lower" and isinstance(gap, (int, float)) and math.isfinite(gap)
    return float(gap) if lower and isinstance(gap, (int, float)) else 0.0


def _join(a: Partial, b: Partial) -> Partial:
    """Two consecutive ranges of one recording as one (what :func:`~tribodyn.pipeline.analyze.combine` of all the
    ranges joins: the statistics in order, the classical sums added block by block, the warnings once)."""
    classical = [p.classical for p in (a, b) if p.classical is not None]
    tribo = {
        **a.tribo,
        "n_samples_total": int(a.tribo.get("n_samples_total", 0)) + int(b.tribo.get("n_samples_total", 0)),
    }
    return dataclasses.replace(
        a,
        st=concat_stats([dict(a.st), dict(b.st)]),
        plan=dataclasses.replace(a.plan, stop=b.plan.stop),
        warnings=tuple(dict.fromkeys((*a.warnings, *b.warnings))),
        tribo=tribo,
        strokes=b.strokes if b.strokes is not None else a.strokes,
        classical=ClassicalTotals.merge(classical) if classical else None,
    )


def _range_of(rec: Recording, a: int, b: int) -> Dict[str, np.ndarray]:
    """Samples ``a:b`` of fy and fz (and the roles the stick-slip search reads), as a mapping."""
    roles = [r for r in ("fy", "fz") if r in rec.roles]
    got = rec.read_ranges([(a, b)], roles)
    return {r: np.asarray(got[r]) for r in roles}


def _reading_free(options: Mapping[str, Any]) -> Dict[str, Any]:
    """The options that apply to a mapping of samples (not those of a covariate's time base)."""
    keep = ("min_fn", "tare", "motion", "load")
    return {k: v for k, v in options.items() if k in keep and v is not None}


def _check_names(options: Mapping[str, Any]) -> None:
    """An option analyze does not take is a TypeError now, before the file is waited for."""
    import inspect

    known = set(inspect.signature(analyze).parameters) - {"source", "plan"}
    unknown = sorted(set(options) - known)
    if unknown:
        raise TypeError(f"watch() got option(s) analyze does not take: {unknown}")


def watch(
    source: Any,
    *,
    interval: float = DEFAULT_INTERVAL,
    until_idle: Optional[float] = None,
    trips: Sequence[Any] = (),
    callback: Optional[Callable[[Results], Any]] = None,
    final: bool = True,
    open_options: Optional[Mapping[str, Any]] = None,
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
    **options: Any,
) -> Watch:
    """Follows a recording that is still being written and analyses it as it grows (docs/method.md 11).

    Parameters
    ----------
    source : str or PathLike
        The file (CSV/TSV/LVM rows appended, TDMS segments appended, an HDF5 dataset that grows, or any other
        format tribodyn reads, opened again at each update).
    interval : float
        Seconds between updates (default 2).
    until_idle : float, optional
        Stop when the file has not grown for this many seconds; None (default): until :meth:`Watch.stop`,
        a trip or Ctrl-C.
    trips : sequence of str or TripRule
        Trip rules (:func:`parse_trip`): ``"cof>0.3"``, ``"cof>0.3 for 10s"``, ``"fn<1"``, ``"stick-slip"``,
        ``"contact-loss"``, ``"no-data for 30s"``. The first that trips ends the watch (:attr:`Watch.tripped`).
    callback : callable, optional
        Called with each Results (the notebook form): the watch then runs to its end here and is returned.
    final : bool
        Give the analysis of the complete file as the last Results (default True).
    open_options : mapping, optional
        How to read the file: :func:`tribodyn.open_recording`'s keywords (``channels``, ``fs``, ``scale``...).
    **options
        :func:`tribodyn.analyze`'s options (``window``, ``hop``, ``load``, ...; ``align`` is refused: it needs
        the whole recording).

    Returns
    -------
    Watch
        Iterate over it for the snapshots (each a :class:`~tribodyn.results.Results` with
        ``params["watch"]``: samples so far, ``final``).

    Examples
    --------
    >>> for res in td.watch("run.csv", until_idle=30, trips=["cof>0.3 for 10s"]):   # doctest: +SKIP
    ...     print(res.headline.value)
    """
    if not (isinstance(interval, (int, float)) and math.isfinite(interval) and interval > 0):
        raise ValueError(f"interval must be a number of seconds > 0, got {interval!r}")
    if until_idle is not None and not (isinstance(until_idle, (int, float)) and math.isfinite(until_idle)
                                       and until_idle > 0):  # fmt: skip
        raise ValueError(f"until_idle must be a number of seconds > 0 or None, got {until_idle!r}")
    if options.get("align") is not None:
        raise ValueError("align='auto' needs the whole recording: analyse the file once it is complete")
    rules = [r if isinstance(r, TripRule) else parse_trip(r) for r in trips]
    _check_names(options)
    w = Watch(str(source), interval=float(interval), until_idle=until_idle, trips=rules,
              open_options=open_options or {}, options=options, final=final, clock=clock, sleep=sleep)  # fmt: skip
    if callback is not None:
        for res in w:
            callback(res)
    return w
