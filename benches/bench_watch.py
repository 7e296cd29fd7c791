"""Watching a running test (issue 37): CPU of ``tribodyn.watch`` over a recording written faster than real time,
against one offline analysis of the final file; memory; the time an update takes.

    python benches/bench_watch.py [--minutes 120] [--fs 1000] [--speed 10] [--interval 2] [--format csv|h5]

The writer is this process: at each of the watch's pauses (``sleep``, a clock of its own: the run goes as fast
as the machine allows) it appends the rows (CSV) or samples (HDF5) that ``speed`` x ``interval`` seconds of the
test bring. The watch's CPU is the process's CPU during the watch less the writer's own (timed apart). The
offline analysis reads the final file once (``tribodyn.analyze`` of ``open_recording``), in the same process,
after the watch (its CPU: the median of 3 such analyses). Each snapshot whose mu_r intervals were moved from an
earlier bootstrap (docs/method.md 11) is compared with a bootstrap drawn afresh (outside the watch's CPU).
Latency: a sample written waits for the next update (at most ``interval``), then for its window and the next
window to be whole (window + hop of the test's time, written at ``speed``), plus the update's own time
(measured: its median and maximum).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import resource
import shutil
import statistics
import tempfile
import time
from pathlib import Path
from typing import Optional

import numpy as np
import tribodyn as td
from tribodyn.app.watch_job import LiveOutputs


def _rows(t0: int, n: int, fs: float, rng: np.random.Generator) -> bytes:
    t = (t0 + np.arange(n)) / fs
    fz = 10.0 + rng.normal(0.0, 1.0, n)
    fy = (0.2 + 0.02 * np.exp(-t / 600.0)) * fz + rng.normal(0.0, 0.05, n)
    block = np.column_stack([t, fy, fz])
    return (("%.4f,%.6f,%.6f\n" * n) % tuple(block.ravel().tolist())).encode()  # as np.savetxt, faster


class _Writer:
    def __init__(self, path: Path, fs: float, per_update: int, total: int, kind: str) -> None:
        self.path, self.fs, self.per, self.total, self.kind = path, fs, per_update, total, kind
        self.done, self.now, self.cpu = 0, 0.0, 0.0
        self.rng = np.random.default_rng(0)
        self.h5 = None
        if kind == "csv":
            path.write_bytes(b"time,fy,fz\n")
        else:
            import h5py

            self.h5 = h5py.File(path, "w", libver="latest")
            for k in ("fy", "fz"):
                self.h5.create_dataset(k, shape=(0,), maxshape=(None,), dtype="f8", chunks=(65536,))
            self.h5.attrs["fs"] = fs
            self.h5.swmr_mode = True

    def clock(self) -> float:
        return self.now

    def sleep(self, s: float) -> None:
        self.now += s
        if self.done >= self.total:
            if self.h5 is not None:
                self.h5.close()
                self.h5 = None
            return
        c = time.process_time()
        n = min(self.per, self.total - self.done)
        if self.h5 is None:
            with open(self.path, "ab") as fh:
                fh.write(_rows(self.done, n, self.fs, self.rng))
        else:
            fz = 10.0 + self.rng.normal(0.0, 1.0, n)
            fy = 0.2 * fz + self.rng.normal(0.0, 0.05, n)
            for k, v in (("fy", fy), ("fz", fz)):
                d = self.h5[k]
                d.resize((d.shape[0] + n,))
                d[-n:] = v
                d.flush()
        self.done += n
        self.cpu += time.process_time() - c


def _moved_against_fresh(snap: td.Results) -> Optional[float]:
    """For a snapshot whose mu_r intervals were moved from an earlier bootstrap (docs/method.md 11): the larger
    distance of its median interval's ends from those of a bootstrap drawn afresh, over the fresh half-width."""
    info = snap.params["watch"]
    gated = np.asarray(snap["mu_r"])[np.asarray(snap["ok"], dtype=bool)]
    if info.get("intervals_drawn_at") in (None, int(np.isfinite(gated).sum())):
        return None
    lo, hi = snap.mu_r_ci["median"]
    flo, fhi = dataclasses.replace(snap).mu_r_ci["median"]  # a copy without the cached intervals: drawn afresh
    half = 0.5 * (fhi - flo)
    return max(abs(lo - flo), abs(hi - fhi)) / half if half > 0 else None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=120.0)
    ap.add_argument("--fs", type=float, default=1000.0)
    ap.add_argument("--speed", type=float, default=10.0)
    ap.add_argument("--interval", type=float, default=2.0)
    ap.add_argument("--window", type=float, default=10.0)
    ap.add_argument("--hop", type=float, default=5.0)
    ap.add_argument("--format", choices=["csv", "h5"], default="csv")
    ap.add_argument("--summary", action="store_true", help="each snapshot's summary() too, as the command line")
    ap.add_argument("--outputs", action="store_true", help="each snapshot's summary.json and live.html written")
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="bench_watch_"))
    path = work / f"run.{args.format}"
    total = int(args.minutes * 60 * args.fs)
    per = int(args.speed * args.interval * args.fs)
    w = _Writer(path, args.fs, per, total, args.format)
    w.sleep(0.0)
    opts = {"window": args.window, "hop": args.hop}
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    c0, t0 = time.process_time(), time.perf_counter()
    watch = td.watch(path, interval=args.interval, until_idle=3 * args.interval, clock=w.clock, sleep=w.sleep,
                     final=False, **opts)  # fmt: skip
    update_s, rss, moved, check_cpu = [], [], [], 0.0
    summary_cpu = fresh_summary_cpu = outputs_cpu = 0.0
    live = LiveOutputs(str(work / "out"), overwrite=True, protect=[str(path)])

    while True:
        u = time.perf_counter()
        snap = watch.update()
        if snap is not None:
            update_s.append(time.perf_counter() - u)
            rss.append(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
            if args.summary:  # what the command line writes at each update (summary.json)
                c = time.process_time()
                snap.summary()
                summary_cpu += time.process_time() - c
            if args.outputs:  # the command line's outputs of an update: summary.json and live.html
                c = time.process_time()
                live.publish(snap, watch)
                outputs_cpu += time.process_time() - c
            c = time.process_time()
            moved.append(_moved_against_fresh(snap))
            if args.summary:  # the same summary with every interval drawn afresh (before docs/method.md 11's moves)
                c2 = time.process_time()
                dataclasses.replace(snap).summary()
                fresh_summary_cpu += time.process_time() - c2
            check_cpu += time.process_time() - c
        if watch.reason:
            break
        w.sleep(args.interval)
    watch.follower.close()
    cpu_watch = time.process_time() - c0 - w.cpu - check_cpu
    wall_watch = time.perf_counter() - t0
    offline = []
    for _ in range(3):  # the offline analysis's CPU: the median of 3 (this machine's timings vary between runs)
        c1 = time.process_time()
        with td.open_recording(path) as rec:
            full = td.analyze(rec, **opts)
        offline.append(time.process_time() - c1)
    cpu_offline = statistics.median(offline)
    final = watch.complete()
    same = np.array_equal(np.asarray(final["mu_r"]), np.asarray(full["mu_r"]), equal_nan=True)
    size = os.path.getsize(path) / 1e6
    print(f"{args.format}: {args.minutes:g} min at {args.fs:g} Hz ({total} samples, {size:.0f} MB), written at "
          f"{args.speed:g}x real time, interval {args.interval:g} s, window {args.window:g} s, hop {args.hop:g} s; "
          f"threads {td.get_threads()}, cores {os.cpu_count()}")  # fmt: skip
    print(f"  updates: {len(update_s)}, each median {statistics.median(update_s) * 1e3:.0f} ms, "
          f"max {max(update_s) * 1e3:.0f} ms, last {update_s[-1] * 1e3:.0f} ms")  # fmt: skip
    print(f"  CPU: watch {cpu_watch:.2f} s (wall {wall_watch - w.cpu:.2f} s), offline analysis {cpu_offline:.2f} s: "
          f"ratio {cpu_watch / cpu_offline:.2f}")  # fmt: skip
    if args.summary:
        print(f"  summary() of each snapshot (in the watch CPU above): {summary_cpu:.2f} s; every interval drawn "
              f"afresh it would be {fresh_summary_cpu:.2f} s")  # fmt: skip
    if args.outputs:
        print(f"  summary.json and live.html of each snapshot (in the watch CPU above): {outputs_cpu:.2f} s")
    half = len(rss) // 2
    print(f"  max RSS: {rss0 / 1024:.0f} MB before, {rss[half] / 1024:.0f} MB half way, {rss[-1] / 1024:.0f} MB "
          "at the end")  # fmt: skip
    print(f"  final == offline (mu_r bit for bit): {same}; headline {final.headline.value:.5f}")
    dev = [d for d in moved if d is not None]
    if dev:
        print(f"  intervals moved from an earlier bootstrap in {len(dev)} of {len(moved)} snapshots: ends within "
              f"{100 * max(dev):.1f} % (median {100 * statistics.median(dev):.1f} %) of the fresh bootstrap's "
              "half-width")  # fmt: skip
    latency = args.interval + (args.window + args.hop) / args.speed + max(update_s)
    print(f"  latency bound: interval + (window + hop)/speed + slowest update = {latency:.2f} s")
    shutil.rmtree(work)


if __name__ == "__main__":
    main()
