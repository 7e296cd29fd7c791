"""Many recordings: serial analysis against a Dask LocalCluster (issue 6).

Writes 8 simulated 1-hour recordings (1 kHz, fx, fy, fz) as chunked HDF5
files in a temporary directory, analyses them with 2 s windows tiling each
recording, serially in this process and on a LocalCluster of 2 worker
processes (1 thread each), checks the tables are identical, and writes the
"## Many recordings on Dask" section of benches/RESULTS.md.

    python benches/bench_many.py [--quick] [--recordings 8] [--hours 1]

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
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _results import write_section  # noqa: E402


def make_recordings(directory: Path, n: int, hours: float) -> list:
    from tribodyn import simulate
    from tribodyn.io.writers import save_hdf5

    paths = []
    for k in range(n):
        chunks = simulate.continuous(hours * 3600.0, chunk_s=600.0, seed=100 + k)
        parts = list(chunks)
        channels = {c: np.concatenate([p[c] for p in parts]) for c in ("fx", "fy", "fz")}
        path = directory / f"rec{k}.h5"
        save_hdf5(path, channels, 1000.0)
        paths.append(str(path))
        del parts, channels
    return paths


def timed(fn, repeat: int) -> list:
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="2 recordings of 5 min (smoke run)")
    ap.add_argument("--recordings", type=int, default=8)
    ap.add_argument("--hours", type=float, default=1.0)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--no-write", action="store_true", help="do not update RESULTS.md")
    args = ap.parse_args()
    if args.quick:
        args.recordings, args.hours, args.repeat = 2, 5 / 60, 1

    # Workers run one kernel thread each, so 2 workers use the 2 cores; the
    # serial baseline is measured with 1 and with all kernel threads.
    os.environ["TRIBODYN_THREADS"] = "1"
    import tribodyn as td
    from dask.distributed import Client, LocalCluster

    opts = dict(window=2.0, hop=2.0)
    tmp = Path(tempfile.mkdtemp(prefix="tribodyn-bench-many-"))
    try:
        t0 = time.perf_counter()
        paths = make_recordings(tmp, args.recordings, args.hours)
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
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0")
        client = Client(cluster)
        try:
            # Warm-up: workers import tribodyn and read once before the timing.
            client.run(lambda: __import__("tribodyn") and None)
            td.analyze_many(paths[: min(2, len(paths))], client=client, **opts)
            res = {}
            dist = timed(lambda: res.setdefault("r", td.analyze_many(paths, client=client, **opts)), args.repeat)
            check = serial()
            for p in paths:
                a, b = check.results[p], res["r"].results[p]
                for col in a.columns:
                    np.testing.assert_array_equal(a[col], b[col])
        finally:
            client.close()
            cluster.close()
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
    )
    med = statistics.median
    ratio = med(ser) / med(dist)
    ratio_all = med(ser_all) / med(dist)
    mb = size / 1e6  # whole data set, MB
    rate_mb_s = size / len(paths) / 1e6 / max(t_task, 1e-9)
    body = f"""Run: `python benches/bench_many.py{cmd}` on {time.strftime("%Y-%m-%d")}.
{args.recordings} simulated recordings of {args.hours:g} h each (1 kHz, fx, fy, fz; chunked HDF5, {mb:.0f} MB in all,
generated in {gen:.0f} s), 2 s windows tiling each recording, {args.repeat} repeats, medians.
Workers: LocalCluster, 2 processes x 1 thread, one kernel thread each (TRIBODYN_THREADS=1).
Tables checked identical to the serial run.

| run | median time (s) | ratio to the cluster |
|---|---:|---:|
| serial, 1 kernel thread | {med(ser):.2f} | {ratio:.2f}x |
| serial, all kernel threads ({os.cpu_count()}) | {med(ser_all):.2f} | {ratio_all:.2f}x |
| LocalCluster, 2 workers | {med(dist):.2f} | 1.00x |

Target: >= 1.7x from serial to 2 workers: **{"met" if ratio >= 1.7 else "missed"}** ({ratio:.2f}x against the
one-thread serial run; {ratio_all:.2f}x against the serial run that already uses both cores in its kernels).

Per task (open, read and analyse one {args.hours:g} h recording): {t_task:.2f} s. On a real cluster (point the
same code at it: `tribodyn analyze DIR --scheduler tcp://HOST:8786 --out OUT`, or
`analyze_many(paths, client=Client("tcp://HOST:8786"))`), each worker needs the files at the same path
(shared storage); R recordings on W single-thread workers take about ceil(R / W) x {t_task:.2f} s plus a few ms
of scheduling per task, so the speed-up stays near W while the storage delivers W x {rate_mb_s:.0f} MB/s;
a very long recording is cut into ranges (`--split S`) so that it, too, spreads over the workers.
"""
    print(body)
    if not args.no_write:
        write_section("Many recordings on Dask", body)


if __name__ == "__main__":
    main()
