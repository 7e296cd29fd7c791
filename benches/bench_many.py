"""Many recordings: serial analysis against a Dask LocalCluster (issues 6 and 38).

Writes 8 simulated 1-hour recordings (1 kHz, fx, fy, fz; ``--current`` adds
i) as HDF5 files (``tribodyn.io.writers.save_hdf5``) in a temporary
directory, analyses them with 2 s windows tiling each recording, serially
in this process (one kernel thread, and every core) and on a LocalCluster
of worker processes (1 thread each, one kernel thread each), checks the
tables are identical, and writes the "## Many recordings on Dask" section
of benches/RESULTS.md.

    python benches/bench_many.py [--quick] [--recordings 8] [--hours 1]
    python benches/bench_many.py --recordings 32 --hours 0.3333 --current --workers 1 2 4 8 16 \
        --no-write --markdown /tmp/many.md          # issue 38 point 4: >= 12x serial at 16 workers

``--workers`` (default 2) takes a list: one LocalCluster per count, started
outside the timing, warmed up (imports and one read per worker), then
``--repeat`` timed runs; each run's tables are checked equal to the serial
run's. The speed-up is against the serial run at one kernel thread. The
clusters are those of ``tribodyn analyze --scheduler local``
(``distributed.local_client``: the workers' allocator set by
``distributed.WORKER_ENVIRON``); ``--dask-defaults`` starts plain
``LocalCluster``s, with Dask's worker environment (its
MALLOC_TRIM_THRESHOLD_=65536: about 8 ms more per 20 min recording on 2
vCPUs, issue 38 point 4).

Per-task costs measured here (open + read + analyse one recording) let one
estimate a real cluster: with W workers and R recordings of equal length,
time ~ ceil(R / W) * t_task + the scheduler's overhead per task (a few ms),
as long as every worker reads its files at full speed (shared storage).
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _results import machine_description, write_section  # noqa: E402

#: Target of issue 6 (2 workers) and of issue 38 point 4 (16 workers), speed-up over serial at 1 thread.
TARGETS = {2: 1.7, 16: 12.0}


def _write_one(args: tuple) -> str:
    directory, k, hours, current = args
    from tribodyn import simulate
    from tribodyn.io.writers import save_hdf5

    parts = list(simulate.continuous(hours * 3600.0, chunk_s=600.0, seed=100 + k, current=4.0 if current else None))
    names = ("fx", "fy", "fz", "i") if current else ("fx", "fy", "fz")
    channels = {c: np.concatenate([p[c] for p in parts]) for c in names}
    path = Path(directory) / f"rec{k}.h5"
    save_hdf5(path, channels, 1000.0)
    return str(path)


def make_recordings(directory: Path, n: int, hours: float, current: bool = False, jobs: int = 1) -> list:
    """Writes ``n`` recordings (seeds 100, 101, ...), in ``jobs`` processes; returns their paths in order."""
    todo = [(str(directory), k, hours, current) for k in range(n)]
    if jobs <= 1 or n == 1:
        return [_write_one(a) for a in todo]
    with ProcessPoolExecutor(max_workers=min(jobs, n)) as ex:
        return list(ex.map(_write_one, todo))


def timed(fn, repeat: int) -> list:
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return out


def check_equal(a_many, b_many, paths) -> None:
    """The per-recording tables of two ``analyze_many`` runs are identical (NaN where NaN)."""
    assert not a_many.failures and not b_many.failures, (a_many.failures, b_many.failures)
    for p in paths:
        a, b = a_many.results[p], b_many.results[p]
        assert list(a.columns) == list(b.columns), p
        for col in a.columns:
            np.testing.assert_array_equal(a[col], b[col])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="2 recordings of 5 min (smoke run)")
    ap.add_argument("--recordings", type=int, default=8)
    ap.add_argument("--hours", type=float, default=1.0)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--workers", type=int, nargs="+", default=[2], help="LocalCluster sizes (default 2)")
    ap.add_argument("--current", action="store_true", help="recordings with a current channel i (4 channels)")
    ap.add_argument("--no-write", action="store_true", help="do not update RESULTS.md")
    ap.add_argument("--markdown", type=Path, default=None, help="also write the section to this file")
    ap.add_argument("--dir", type=Path, default=None, help="where the temporary recordings go")
    ap.add_argument("--dask-defaults", action="store_true",
                    help="plain LocalClusters (Dask's worker environment), not tribodyn's local_client")  # fmt: skip
    args = ap.parse_args()
    if args.quick:
        args.recordings, args.hours, args.repeat = 2, 5 / 60, 1
    if any(w < 1 for w in args.workers):
        ap.error("--workers: counts must be >= 1")

    # Workers run one kernel thread each, so W workers use W cores; the
    # serial baseline is measured with 1 and with all kernel threads.
    os.environ["TRIBODYN_THREADS"] = "1"
    import tribodyn as td
    from dask.distributed import Client, LocalCluster
    from tribodyn.pipeline.distributed import local_client

    opts = dict(window=2.0, hop=2.0)
    load0 = os.getloadavg()
    tmp = Path(tempfile.mkdtemp(prefix="tribodyn-bench-many-", dir=args.dir))
    dist = {}
    start_s = {}
    try:
        t0 = time.perf_counter()
        paths = make_recordings(tmp, args.recordings, args.hours, args.current, jobs=os.cpu_count() or 1)
        gen = time.perf_counter() - t0
        size = sum(os.path.getsize(p) for p in paths)

        def serial():
            return td.analyze_many(paths, **opts)

        def serial_all_threads():
            return td.analyze_many(paths, threads=os.cpu_count(), **opts)

        one = {}
        t_task = timed(lambda: one.setdefault("r", td.analyze_many(paths[:1], **opts)), 1)[0]
        ser = timed(serial, args.repeat)
        ser_all = timed(serial_all_threads, args.repeat)
        check = serial()
        for w in args.workers:
            t0 = time.perf_counter()
            if args.dask_defaults:
                cluster = LocalCluster(n_workers=w, threads_per_worker=1, processes=True, dashboard_address=":0")
                client = Client(cluster)
            else:
                client = local_client(w, 1)
                cluster = client.cluster
            try:
                client.wait_for_workers(w)
                start_s[w] = time.perf_counter() - t0
                # Warm-up: workers import tribodyn and read once before the timing.
                client.run(lambda: __import__("tribodyn") and None)
                td.analyze_many(paths[: min(w, len(paths))], client=client, **opts)
                res = {}
                dist[w] = timed(lambda: res.setdefault("r", td.analyze_many(paths, client=client, **opts)), args.repeat)
                check_equal(check, res["r"], paths)
            finally:
                client.close()
                cluster.close()
            print(f"{w} workers: {statistics.median(dist[w]):.2f} s (tables equal to serial)", flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)

    cmd = (
        " --quick"
        if args.quick
        else "".join(
            f" --{k} {v:g}"
            for k, v in (("recordings", args.recordings), ("hours", args.hours), ("repeat", args.repeat))
            if v != ap.get_default(k)
        )
        + (" --current" if args.current else "")
        + ("" if args.workers == [2] else " --workers " + " ".join(map(str, args.workers)))
        + (" --dask-defaults" if args.dask_defaults else "")
    )
    med = statistics.median
    mb = size / 1e6  # whole data set, MB
    rate_mb_s = size / len(paths) / 1e6 / max(t_task, 1e-9)
    chans = "fx, fy, fz, i" if args.current else "fx, fy, fz"
    ncpu = os.cpu_count()
    rows = [
        f"| serial, 1 kernel thread | {med(ser):.2f} | 1.00x | - |",
        f"| serial, all kernel threads ({ncpu}) | {med(ser_all):.2f} | {med(ser) / med(ser_all):.2f}x | - |",
    ]
    verdicts = []
    for w in args.workers:
        r = med(ser) / med(dist[w])
        tgt = TARGETS.get(w)
        tgt_s = "-" if tgt is None else f">= {tgt:g}x " + ("met" if r >= tgt else "**missed**")
        rows.append(f"| LocalCluster, {w} worker{'s' if w > 1 else ''} | {med(dist[w]):.2f} | {r:.2f}x | {tgt_s} |")
        if tgt is not None:
            verdicts.append(f"{w} workers {r:.2f}x (target >= {tgt:g}x: {'met' if r >= tgt else 'missed'})")
    over = [w for w in args.workers if ncpu and w > ncpu]
    l1 = os.getloadavg()
    body = f"""Run: `python benches/bench_many.py{cmd}` on {time.strftime("%Y-%m-%d")}; load average \
{load0[0]:.1f} before, {l1[0]:.1f} after.
{args.recordings} simulated recordings of {args.hours:g} h each (1 kHz, {chans}; HDF5, {mb:.0f} MB in all,
generated in {gen:.0f} s), 2 s windows tiling each recording, {args.repeat} repeats, medians.
Workers: {"LocalCluster (Dask's defaults)" if args.dask_defaults else "`local_client` (the CLI's LocalCluster)"} of \
worker processes x 1 thread, one kernel thread each (TRIBODYN_THREADS=1), started
and warmed up (import, one read each) outside the timing (start of the largest: {start_s[max(args.workers)]:.1f} s).
Tables checked identical to the serial run for every cluster.{
        f" Worker counts above the {ncpu} cores ({', '.join(map(str, over))}) oversubscribe them." if over else ""
    }

| run | median time (s) | speed-up over serial at 1 thread | target |
|---|---:|---:|---|
{chr(10).join(rows)}

Targets: {"; ".join(verdicts) if verdicts else "none at these worker counts"}.

Per task (open, read and analyse one {args.hours:g} h recording): {t_task:.2f} s. On a real cluster (point the
same code at it: `tribodyn analyze DIR --scheduler tcp://HOST:8786 --out OUT`, or
`analyze_many(paths, client=Client("tcp://HOST:8786"))`), each worker needs the files at the same path
(shared storage); R recordings on W single-thread workers take about ceil(R / W) x {t_task:.2f} s plus a few ms
of scheduling per task, so the speed-up stays near W while the storage delivers W x {rate_mb_s:.0f} MB/s;
a very long recording is cut into ranges (`--split S`) so that it, too, spreads over the workers.
"""
    print(body)
    if args.markdown:
        title = "Many recordings on Dask" + (
            "" if args.workers == [2] else f", {' '.join(map(str, args.workers))} workers (issue 38 point 4)"
        )
        args.markdown.write_text(f"## {title}\n\nMachine: {machine_description()}\n\n{body}")
    if not args.no_write:
        write_section("Many recordings on Dask", body)


if __name__ == "__main__":
    main()
