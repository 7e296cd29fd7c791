"""``tribodyn watch``: a running test's COF in the terminal and on a live page (docs/method.md 11).

Each update (:class:`tribodyn.pipeline.watch.Watch`) prints the headline in
place (one refreshed line on a terminal, plain lines otherwise) and writes
``--out`` (:class:`LiveOutputs`): ``summary.json`` (the snapshot's summary and
a ``watch`` block) and ``live.html`` (refreshes itself; COF against time with
the headline's band and the trip limits, and when data last arrived). The
first update publishes them as one set (:class:`~tribodyn.app.outputs.OutputSet`:
the folder checked, its marker written); the next ones replace each file
atomically in place (a reader sees the old file or the new one, never a part). When watching ends, ``--out`` holds what
``tribodyn analyze`` of the complete file writes, and ``live.html`` says the
test ended and links the report. A trip prints one line, writes the outputs,
runs ``--on-trip`` and exits with status 3. A second watch of the same
``--out`` is refused (a lock file beside it).
"""

from __future__ import annotations

import argparse
import datetime
import html
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..io.writers import atomic_write
from ..pipeline.watch import Watch, cof_column, parse_trip, watch
from ..results import Results, verdict_text
from .outputs import MARKER, OutputSet, jsonable

__all__ = ["run_watch", "EXIT_TRIPPED", "live_page", "WatchLock", "LiveOutputs"]

#: ``tribodyn watch``'s status when a trip rule ended the watch (0: ended, 2: an error).
EXIT_TRIPPED = 3
LIVE_PAGE = "live.html"


class WatchLock:
    """``.<out>.tribodyn-watch`` beside ``--out``: one watch per output folder (a stale lock, whose process
    has ended, is taken over)."""

    def __init__(self, out: str) -> None:
        target = Path(os.path.abspath(out))
        self.path = target.parent / f".{target.name}.tribodyn-watch"

    def __enter__(self) -> "WatchLock":
        from .outputs import _pid_alive

        self.path.parent.mkdir(parents=True, exist_ok=True)
        for _ in range(2):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                try:
                    pid = int(self.path.read_text().strip() or "0")
                except (OSError, ValueError):
                    pid = 0
                if pid and _pid_alive(pid):
                    raise ValueError(f"another tribodyn watch (process {pid}) writes this output folder "
                                     f"(lock {self.path}); give another --out") from None  # fmt: skip
                self.path.unlink(missing_ok=True)  # stale: its process ended
                continue
            with os.fdopen(fd, "w") as f:
                f.write(str(os.getpid()))
            return self
        raise ValueError(f"cannot take the watch lock {self.path}")

    def __exit__(self, *exc: object) -> None:
        self.path.unlink(missing_ok=True)


def run_watch(ns: argparse.Namespace, open_opts: Dict[str, Any], opts: Dict[str, Any],
              protect: Sequence[str]) -> int:  # fmt: skip
    """``watch``: the loop, the outputs at each update and at the end; the exit status."""
    rules = [parse_trip(t) for t in ns.trip or ()]
    opts = dict(opts)
    meta = opts.pop("meta", None)
    analysis = {k: v for k, v in opts.items() if k not in ("temperature_file", "covariate_files")}
    open_opts = dict(open_opts)
    if open_opts.get("load") is not None:  # given to the analysis: the followed file stays the reader's own
        analysis["load"] = open_opts.pop("load")
    OutputSet(ns.out, overwrite=ns.overwrite, protect=[ns.file, *protect])  # refuse a bad --out before waiting
    with WatchLock(ns.out):
        w = watch(ns.file, interval=ns.interval, until_idle=ns.until_idle, trips=rules, final=False,
                  open_options=open_opts, **analysis)  # fmt: skip
        line = _Line(quiet=ns.quiet)
        w.on_wait = lambda why: line.show(f"waiting: {why}")  # the file not there yet, no new data...
        live = LiveOutputs(ns.out, overwrite=ns.overwrite, protect=[ns.file, *protect])
        try:
            for snap in w:
                line.show(_headline_text(snap, w))
                live.publish(snap, w)
        finally:
            line.end()
        if w.follower.recording is None:
            raise ValueError(f"{ns.file}: no data could be read ({w.follower.waiting})")
        return _finish(ns, w, (open_opts, opts, meta), protect)


def _finish(ns: argparse.Namespace, w: Watch, given: Tuple[Dict[str, Any], Dict[str, Any], Any],
            protect: Sequence[str]) -> int:  # fmt: skip
    """The analysis of the complete file into --out (that of ``tribodyn analyze``), the end page, the trip."""
    from .jobs import run_analysis

    open_opts, opts, meta = given
    if "load" in opts:
        open_opts = {**open_opts, "load": opts.pop("load")}
    open_opts = {**open_opts, "appending": True}  # the writer may still be writing: its samples now
    if w.tripped is not None:
        print(f"tribodyn: {w.tripped.message}", file=sys.stderr)
    summary = run_analysis([ns.file], ns.out, open_options=open_opts, analyze_options=opts, overwrite=True,
                           protect=protect, meta=meta)  # fmt: skip
    rec: Dict[str, Any] = next(iter(summary.get("recordings", {}).values()), {})
    _add_end_page(ns.out, rec, w)
    if not ns.quiet:
        head = rec.get("headline", {})
        print(f"watch ended ({w.reason or 'stopped'}): {w.n_samples} samples; COF {_num(head.get('value'))} "
              f"[{_num(head.get('low'))}, {_num(head.get('high'))}] ({head.get('method', '')}); "
              f"report: {os.path.join(ns.out, 'report.html')}")  # fmt: skip
    for note in w.notes:
        print(f"tribodyn: warning: {note}", file=sys.stderr)
    if w.tripped is None:
        return 0
    if ns.on_trip:
        env = {**os.environ, "TRIBODYN_TRIP_RULE": w.tripped.rule, "TRIBODYN_TRIP_TIME": f"{w.tripped.time:g}",
               "TRIBODYN_TRIP_VALUE": f"{w.tripped.value:g}", "TRIBODYN_OUT": os.path.abspath(ns.out)}  # fmt: skip
        subprocess.run(ns.on_trip, shell=True, env=env, check=False)  # noqa: S602 - the user's own command
    return EXIT_TRIPPED


class _Line:
    """The headline in place on a terminal (one refreshed line), plain lines otherwise."""

    def __init__(self, quiet: bool) -> None:
        self.quiet, self.tty, self.width = quiet, sys.stdout.isatty(), 0

    def show(self, text: str) -> None:
        if self.quiet:
            return
        if self.tty:
            pad = max(0, self.width - len(text))
            sys.stdout.write("\r" + text + " " * pad)
            sys.stdout.flush()
            self.width = len(text)
        else:
            print(text, flush=True)

    def end(self) -> None:
        if self.tty and self.width and not self.quiet:
            sys.stdout.write("\n")
            sys.stdout.flush()


def _num(v: Any) -> str:
    return f"{v:.4f}" if isinstance(v, (int, float)) and math.isfinite(v) else "n/a"


def _headline_text(res: Results, w: Watch) -> str:
    h = res.headline
    rec = w.follower.recording
    t = w.n_samples / rec.fs if rec is not None else 0.0
    final = " (complete file)" if res.params.get("watch", {}).get("final") else ""
    return (f"t = {t:.1f} s: COF {_num(h.value)} [{_num(h.low)}, {_num(h.high)}] {h.method}, "
            f"{len(res)} windows{final}")  # fmt: skip


class LiveOutputs:
    """``summary.json`` and ``live.html`` of each update in ``--out`` (docs/method.md 11).

    The first update publishes them as one set (:class:`~tribodyn.app.outputs.OutputSet`: the folder checked,
    its marker written); each later one replaces the two files in place, each atomically (written beside it,
    then renamed over it: a reader sees the old file or the new one, never a part), and again as a set if the
    folder no longer holds them. Neither is flushed to disk at each update (the end's outputs are). The live
    page's points are kept between updates (:class:`_Points`): an update formats only the windows that are
    new or changed.
    """

    def __init__(self, out: str, *, overwrite: bool, protect: Sequence[str]) -> None:
        self.out, self.overwrite, self.protect = out, overwrite, list(protect)
        self.points = _Points()
        self._published = False

    def publish(self, res: Results, w: Watch) -> None:
        """This update's summary.json and live.html."""
        now = time.time()
        info = _watch_info(w, now)
        # the snapshot's bootstrap intervals: drawn at this many gated windows, moved since (docs/method.md 11)
        info["intervals_drawn_at"] = (res.params.get("watch") or {}).get("intervals_drawn_at")
        files = {"summary.json": _json_text({"watch": info, "recording": res.summary()}),
                 LIVE_PAGE: live_page(res, w, info, interval=w.interval, points=self.points)}  # fmt: skip
        if self._published and self._intact():
            for name, text in files.items():  # (each written at once: the lambda's text is this one)
                path = os.path.join(self.out, name)
                atomic_write(path, lambda tmp: Path(tmp).write_text(text, "utf-8"), durable=False)
            return
        with OutputSet(self.out, overwrite=self.overwrite, protect=self.protect, durable=False) as o:
            for name, text in files.items():
                Path(o.path(name)).write_text(text, encoding="utf-8")
        self._published, self.overwrite = True, False  # the folder now holds our set

    def _intact(self) -> bool:
        """Whether ``--out`` still holds the set this watch published (its marker and both files)."""
        target = Path(self.out)
        return not target.is_symlink() and all((target / f).is_file() for f in (MARKER, "summary.json", LIVE_PAGE))


def _json_text(obj: Any) -> str:
    """``obj`` as JSON (NaN as null), one top-level entry a line: the entries by the C encoder (an indented
    dump goes through Python's, several ms for a summary)."""
    data = jsonable(obj)
    if not isinstance(data, dict) or not data:
        return json.dumps(data) + "\n"
    return "{\n" + ",\n".join(f"  {json.dumps(k)}: {json.dumps(v)}" for k, v in data.items()) + "\n}\n"


def _watch_info(w: Watch, now: float) -> Dict[str, Any]:
    idle = time.monotonic() - w.follower.grown_at
    rec = w.follower.recording
    return {
        "file": w.path,
        "samples": w.n_samples,
        "seconds": w.n_samples / rec.fs if rec is not None else 0.0,
        "updated": _iso(now),
        "last_data": _iso(now - idle),
        "seconds_since_data": idle,
        "updates": w.updates,
        "trips": [r.text for r in w.rules],
        "tripped": w.tripped.as_dict() if w.tripped is not None else None,
        "notes": list(w.notes),
        "final": False,
    }


def _clock_time(iso: str) -> str:
    """'2026-11-27T12:26:36+00:00' -> '12:26:36' (the day when it is not today)."""
    day, _, rest = iso.partition("T")
    today = datetime.date.today().isoformat()
    return rest[:8] if day == today else f"{day} {rest[:8]}"


def _iso(t: float) -> str:
    return datetime.datetime.fromtimestamp(t).astimezone().isoformat(timespec="seconds")


def _add_end_page(out: str, rec: Dict[str, Any], w: Watch) -> None:
    """live.html in the final set: the test ended, why, and the report (the set's marker lists it)."""
    head = rec.get("headline", {})
    trip = f"<p class='trip'>{html.escape(w.tripped.message)}</p>" if w.tripped is not None else ""
    whole = "the complete file" if w.reason == "idle" else "the file as it was when watching ended"
    body = (f"<h1>tribodyn watch: {html.escape(Path(w.path).name)}</h1>"
            f"<p>Watching ended ({html.escape(w.reason or 'stopped')}) after {w.n_samples} samples. The outputs are "
            f"those of <code>tribodyn analyze</code> of {whole}.</p>{trip}"
            f"<p class='head'>COF {_num(head.get('value'))} [{_num(head.get('low'))}, {_num(head.get('high'))}] "
            f"({html.escape(str(head.get('method', '')))})</p>"
            "<p><a href='report.html'>The report</a> · <a href='summary.json'>summary.json</a></p>")  # fmt: skip
    target = Path(out)
    tmp = target / f".{LIVE_PAGE}.tmp"
    tmp.write_text(_page(body, refresh=None), encoding="utf-8")
    os.replace(tmp, target / LIVE_PAGE)
    marker = target / MARKER
    data = json.loads(marker.read_text(encoding="utf-8"))
    if LIVE_PAGE not in data["files"]:
        data["files"].append(LIVE_PAGE)
        tmp = target / f"{MARKER}.tmp"
        tmp.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
        os.replace(tmp, marker)


_STYLE = ("body{font-family:system-ui,sans-serif;margin:2em;max-width:60em;color:#222}"
          ".head{font-size:1.6em;font-weight:600}.trip{color:#b00;font-weight:600}"
          ".muted{color:#666}svg{border:1px solid #ddd;background:#fff}")  # fmt: skip


def _page(body: str, refresh: Optional[float]) -> str:
    meta = f"<meta http-equiv='refresh' content='{max(1, int(math.ceil(refresh)))}'>" if refresh else ""
    return (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>{meta}<title>tribodyn watch</title>"
            f"<style>{_STYLE}</style></head><body>{body}</body></html>\n")  # fmt: skip


def live_page(res: Results, w: Watch, info: Dict[str, Any], *, interval: float,
              points: Optional["_Points"] = None) -> str:  # fmt: skip
    """The live page of a snapshot: the headline, COF against time with its band and the trip limits, when the
    data last arrived; it reloads itself every ``interval`` s. ``points``: the points of the previous update's
    page (:class:`LiveOutputs`), kept so that only new or changed windows are formatted."""
    h = res.headline
    name = html.escape(Path(w.path).name)
    limits = [(r.limit, r.text) for r in w.rules if r.quantity == "cof"]
    col = cof_column(h.method)
    t = np.asarray(res["time"], dtype=float)
    mu = np.abs(np.asarray(res[col], dtype=float))
    ok = np.asarray(res["ok"], dtype=bool) if h.method == "dynamic" else np.ones(len(t), dtype=bool)
    svg = _cof_svg(t, mu, ok, (h.value, h.low, h.high), limits, points=points)
    trip = f"<p class='trip'>{html.escape(w.tripped.message)}</p>" if w.tripped is not None else ""
    verdict = html.escape(verdict_text(res.verdict))
    notes = "".join(f"<p class='muted'>{html.escape(n)}</p>" for n in w.notes)
    rules = ", ".join(html.escape(r.text) for r in w.rules) or "none"
    body = (f"<h1>tribodyn watch: {name}</h1>{trip}"
            f"<p class='head'>COF {_num(h.value)} [{_num(h.low)}, {_num(h.high)}] <span class='muted'>"
            f"({html.escape(h.method)}, {h.n} {'windows' if h.method == 'dynamic' else 'samples/cycles'})</span></p>"
            f"<p>{verdict}</p>"
            f"<p class='muted'>{info['samples']} samples ({info['seconds']:.1f} s of the test), {len(res)} windows; "
            f"last data arrived at {_clock_time(info['last_data'])} ({info['seconds_since_data']:.0f} s before "
            f"this update at {_clock_time(info['updated'])}); trip rules: {rules}. This page reloads every "
            f"{max(1, int(math.ceil(interval)))} s; "
            f"the analysis so far: what the pre-pass finds is found again from the complete file at the end.</p>"
            f"{svg}{notes}")  # fmt: skip
    return _page(body, refresh=interval)


#: Windows the live page draws one by one; beyond, each pixel column draws its lowest and highest COF of the gated
#: and of the failed windows (a 24 h test at a 5 s hop has 17,280 windows; the page stays light).
LIVE_POINTS = 2000


def thinned(t: np.ndarray, mu: np.ndarray, ok: np.ndarray, columns: int, most: int = LIVE_POINTS) -> np.ndarray:
    """The indices of the windows to draw: every finite one up to ``most``; beyond, the lowest and the highest COF
    of the gated and of the failed windows in each of ``columns`` equal columns of time, in order of time."""
    keep = np.flatnonzero(np.isfinite(mu) & np.isfinite(t))
    if keep.size <= most:
        return keep
    tk = t[keep]
    span = float(tk.max() - tk.min()) or 1.0
    col = np.minimum(((tk - tk.min()) / span * columns).astype(np.int64), columns - 1)
    group = 2 * col + ok[keep].astype(np.int64)
    order = np.lexsort((mu[keep], group))  # by group, then by COF within it
    g = group[order]
    first = np.r_[True, g[1:] != g[:-1]]
    last = np.r_[g[1:] != g[:-1], True]
    return np.asarray(np.sort(keep[order[first | last]]))


class _Points:
    """Each window's point of the live page's plot, in the data's coordinates (``M t cof h0``), kept between
    updates: only windows whose time or COF differ from the last update's are formatted again."""

    def __init__(self) -> None:
        self.t = np.zeros(0)
        self.mu = np.zeros(0)
        self.text: List[str] = []

    def of(self, t: np.ndarray, mu: np.ndarray) -> List[str]:
        """The points of windows ``t``, ``mu`` (finite or not: those drawn are picked by the caller)."""
        k = min(len(self.t), len(t))
        same = np.zeros(len(t), dtype=bool)
        same[:k] = ((self.t[:k] == t[:k]) | (np.isnan(self.t[:k]) & np.isnan(t[:k]))) & (
            (self.mu[:k] == mu[:k]) | (np.isnan(self.mu[:k]) & np.isnan(mu[:k]))
        )
        text = self.text[: len(t)] + [""] * max(0, len(t) - len(self.text))
        for i in np.flatnonzero(~same).tolist():
            text[i] = f"M{t[i]:.7g} {mu[i]:.6g}h0"
        self.t, self.mu, self.text = t.copy(), mu.copy(), text
        return text


def _cof_svg(t: np.ndarray, mu: np.ndarray, ok: np.ndarray, head: Tuple[float, float, float],
             limits: List[Tuple[float, str]], *, points: Optional[_Points] = None) -> str:  # fmt: skip
    """COF of each window against time (gated windows filled, the others open; beyond :data:`LIVE_POINTS`
    windows, each pixel column's extremes), the headline's band, the trip limits (SVG). The windows are drawn
    in the data's coordinates, mapped to the plot by one transform (dots: round caps of zero-length lines of a
    fixed width on screen), so a window's point is the same text at every update (``points`` keeps them)."""
    width, height, left, bottom, top, right = 900, 360, 60, 40, 20, 20
    fin = np.isfinite(mu)
    ends = [x for x in (*head, *(x for x, _ in limits)) if math.isfinite(x)]
    if fin.any():
        ends += [float(mu[fin].min()), float(mu[fin].max())]
    lo, hi = (min(ends), max(ends)) if ends else (0.0, 1.0)
    pad = 0.08 * (hi - lo) if hi > lo else 0.05 * max(abs(hi), 0.1)
    lo, hi = lo - pad, hi + pad
    t0, t1 = (float(t.min()), float(t.max())) if len(t) else (0.0, 1.0)
    t1 = t1 if t1 > t0 else t0 + 1.0
    sx, sy = (width - left - right) / (t1 - t0), (height - top - bottom) / (hi - lo)

    def x(v: float) -> float:
        return left + (v - t0) * sx

    def y(v: float) -> float:
        return top + (hi - v) * sy

    parts = [f"<svg xmlns='http://www.w3.org/2000/svg' width='{width}' height='{height}' role='img' "
             "aria-label='COF against time'>"]  # fmt: skip
    v, low, high = head
    if math.isfinite(low) and math.isfinite(high):
        parts.append(f"<rect x='{left}' y='{y(high):.1f}' width='{width - left - right}' "
                     f"height='{max(1.0, y(low) - y(high)):.1f}' fill='#1f77b4' opacity='0.15'/>")  # fmt: skip
    if math.isfinite(v):
        parts.append(f"<line x1='{left}' x2='{width - right}' y1='{y(v):.1f}' y2='{y(v):.1f}' stroke='#1f77b4'/>")
    for lim, text in limits:
        parts.append(f"<line x1='{left}' x2='{width - right}' y1='{y(lim):.1f}' y2='{y(lim):.1f}' stroke='#c00' "
                     f"stroke-dasharray='6 4'/><text x='{width - right - 4}' y='{y(lim) - 4:.1f}' "
                     f"text-anchor='end' font-size='12' fill='#c00'>trip {html.escape(text)}</text>")  # fmt: skip
    drawn = thinned(t, mu, ok, width - left - right)
    dots = (points or _Points()).of(t, mu)
    gated = "".join(dots[i] for i in drawn[ok[drawn]].tolist())
    failed = "".join(dots[i] for i in drawn[~ok[drawn]].tolist())
    dot = "fill='none' stroke-linecap='round' vector-effect='non-scaling-stroke'"
    parts.append(f"<g class='windows' transform='matrix({sx!r} 0 0 {-sy!r} {left - t0 * sx!r} {top + hi * sy!r})'>"
                 f"<path class='gated' d='{gated}' stroke='#222' stroke-width='5' {dot}/>"
                 f"<path class='failed' d='{failed}' stroke='#222' stroke-width='6' {dot}/>"
                 f"<path d='{failed}' stroke='#fff' stroke-width='3' {dot}/></g>")  # fmt: skip
    finite = int(fin.sum())
    if drawn.size < finite:
        parts.append(f"<text x='{width - right}' y='{top - 6}' text-anchor='end' font-size='11' fill='#555'>"
                     f"{finite} windows: each pixel column's lowest and highest drawn</text>")  # fmt: skip
    for k in range(5):  # axes' ticks
        yv = lo + (hi - lo) * k / 4
        tv = t0 + (t1 - t0) * k / 4
        parts.append(f"<text x='{left - 6}' y='{y(yv) + 4:.1f}' text-anchor='end' font-size='11'>{yv:.3g}</text>")
        parts.append(f"<text x='{x(tv):.1f}' y='{height - bottom + 16}' text-anchor='middle' "
                     f"font-size='11'>{tv:.0f}</text>")  # fmt: skip
    parts.append(f"<line x1='{left}' x2='{left}' y1='{top}' y2='{height - bottom}' stroke='#888'/>"
                 f"<line x1='{left}' x2='{width - right}' y1='{height - bottom}' y2='{height - bottom}' "
                 f"stroke='#888'/><text x='{(left + width) / 2}' y='{height - 6}' text-anchor='middle' "
                 "font-size='12'>time [s]; line and band: the headline and its 95 % interval; filled: windows "
                 "that pass the gate</text>"
                 f"<text x='14' y='{(top + height) / 2}' font-size='12' transform='rotate(-90 14 "
                 f"{(top + height) / 2})' text-anchor='middle'>COF</text></svg>")  # fmt: skip
    return "".join(parts)
