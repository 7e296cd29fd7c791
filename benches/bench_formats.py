"""The same recording in the formats rigs write: tribodyn's time against the ``.npy`` path (issue 16).

A simulated 1 kHz recording of fx, fy, fz and i (``tribodyn.simulate.continuous``,
seed 11) is written as a channels-first float64 ``.npy``, as TDMS (float64
in 1 s segments, 10 s segments and one segment, all by npTDMS's writer
through ``tribodyn.io.writers.save_tdms``; DAQmx raw int16 with a linear
scaler per channel, 1 s segments, by ``tribodyn.io.tdms.write_daqmx_tdms``)
and as HDF5 (contiguous, and chunked 65536 uncompressed). Each file is
analysed (``open_recording`` + ``analyze(window=2, hop=2, method="paper",
motion="unidirectional")``, default threads; ``motion`` named because the
automatic detection finds the simulator's reciprocating strokes and adds
the per-stroke table, a whole-recording read and a Python loop per stroke
that are not what this measures) in a fresh subprocess: one warm-up, then ``--repeat``
timed runs (median), and the process's peak RSS; the route taken and the
table are checked (float64 formats: the ``.npy`` table bit for bit; DAQmx:
the npTDMS route's table on the short recording). Both lengths (``--hours``,
default 1 and 10) run in the same invocation, so the ratios to ``.npy``
and 10 h / 1 h come from one run. Files are warm (just written).

With ``--threads 1 2 4 8 16`` (issue 38 point 1) it times instead the
formats issue 38 names (``.npy``, HDF5 chunked and contiguous, TDMS 1 s and
10 s segments; ``--formats``) of one length (default 10 h) at each thread
count, each case x thread count in a fresh process with ``TRIBODYN_THREADS``
(and the BLAS threads) set to the count, one warm-up then ``--repeat`` timed
runs (median), ``--rounds`` rounds interleaved (median over the rounds),
wall and CPU time; beside them h5py's plain read of the same HDF5 datasets,
``np.load`` alone and the memory yardstick ``fy @ fz``. The ratio to
``.npy`` is per thread count; every table is checked bitwise against the
``.npy``'s at the first count. It prints a markdown section (``--markdown
FILE`` writes it) and leaves RESULTS.md alone. ``--keep --dir DIR`` leaves
the files in a folder under DIR; ``--reuse`` that folder times them again
without writing them (each 10 h format is ~1.1 GB).

Usage::

    python benches/bench_formats.py                 # 1 h and 10 h, writes a section of benches/RESULTS.md
    python benches/bench_formats.py --hours 0.1     # smoke run, prints only
    python benches/bench_formats.py --threads 1 2 4 8 16 --hours 10 --markdown /tmp/formats.md
    python benches/bench_formats.py --threads 1 2 --formats npy tdms_1s --reuse /tmp/f/tribodyn-formats-threads-XXXX
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Dict, List, Sequence

import numpy as np

FS = 1000.0
ROLES = ("fx", "fy", "fz", "i")
HERE = Path(__file__).resolve().parent
RESULTS = HERE / "RESULTS.md"
SECTION = "## Formats: TDMS, HDF5 against .npy (issue 16)"
FORMATS = ("npy", "tdms_1s", "tdms_10s", "tdms_one", "tdms_daqmx", "h5_contig", "h5_chunked")
LABELS = {
    "npy": "`.npy` (channels-first float64)",
    "tdms_1s": "TDMS float64, 1 s segments",
    "tdms_10s": "TDMS float64, 10 s segments",
    "tdms_one": "TDMS float64, one segment",
    "tdms_daqmx": "TDMS DAQmx raw int16 + linear scaler, 1 s segments",
    "h5_contig": "HDF5 contiguous",
    "h5_chunked": "HDF5 chunked 65536, uncompressed",
}
#: Targets of issue 16: ratio to the .npy path.
TARGET = {"tdms_1s": 3.0, "tdms_10s": 2.0, "tdms_one": 2.0, "tdms_daqmx": 3.0, "h5_contig": 2.0, "h5_chunked": 2.0}
DAQ_LSB = {"fx": 1e-3, "fy": 1e-3, "fz": 2e-3, "i": 2e-4}


def file_name(hours: float, fmt: str) -> str:
    """The name :func:`write_all` gives the recording of ``hours`` in format ``fmt``."""
    return f"{hours:g}h_{fmt}.{'npy' if fmt == 'npy' else 'tdms' if 'tdms' in fmt else 'h5'}"


def reused(directory: Path, hours: float, formats: Sequence[str]) -> Dict[str, Path]:
    """The files an earlier ``--keep`` run left in ``directory`` (``--reuse``), instead of writing them again
    (each 10 h format is ~1.1 GB); SystemExit naming the first one missing."""
    paths = {f: directory / file_name(hours, f) for f in formats}
    missing = [str(q) for q in paths.values() if not q.is_file()]
    if missing:
        raise SystemExit(f"--reuse: no {missing[0]} (write it with --keep --dir DIR, then --reuse DIR/<its folder>)")
    return paths


def write_all(directory: Path, hours: float, formats: Sequence[str] = FORMATS) -> Dict[str, Path]:
    """Writes the recording of ``hours`` in ``formats`` (always the ``.npy``); returns the paths."""
    import h5py
    from tribodyn import simulate
    from tribodyn.io.writers import save_tdms

    n = int(round(hours * 3600 * FS))
    p: Dict[str, Path] = {f: directory / file_name(hours, f) for f in FORMATS if f == "npy" or f in formats}
    arr = np.lib.format.open_memmap(p["npy"], mode="w+", dtype=np.float64, shape=(len(ROLES), n))
    pos = 0
    for chunk in simulate.continuous(hours * 3600, chunk_s=600.0, current=4.0, seed=11, fs=FS, raw=False):
        m = len(chunk["fz"])
        for j, r in enumerate(ROLES):
            arr[j, pos : pos + m] = chunk[r]
        pos += m
    arr.flush()
    assert pos == n
    ch = {r: arr[j] for j, r in enumerate(ROLES)}
    units = {"fx": "N", "fy": "N", "fz": "N", "i": "A"}
    for f, seg in (("tdms_1s", 1000), ("tdms_10s", 10_000), ("tdms_one", n)):
        if f in p:
            save_tdms(p[f], ch, FS, units, segment_samples=seg)
    if "tdms_daqmx" in p:
        _write_daqmx(p["tdms_daqmx"], ch, units)
    for f, chunks in (("h5_contig", None), ("h5_chunked", (min(n, 65536),))):
        if f not in p:
            continue
        with h5py.File(p[f], "w") as h:
            h.attrs["fs"] = FS
            for r in ROLES:
                d = h.create_dataset(r, shape=(n,), dtype="<f8", chunks=chunks)
                for a in range(0, n, 1 << 22):
                    d[a : a + (1 << 22)] = ch[r][a : a + (1 << 22)]
                d.attrs["unit"] = units[r]
    del arr, ch
    return p


def _write_daqmx(path: Path, ch: Dict[str, Any], units: Dict[str, str]) -> None:
    from tribodyn.io.tdms import write_daqmx_tdms

    raw = {r: np.clip(np.round(np.asarray(ch[r]) / DAQ_LSB[r]), -32768, 32767).astype(np.int16) for r in ROLES}
    write_daqmx_tdms(
        str(path),
        raw,
        FS,
        {r: [("Linear", (DAQ_LSB[r], 0.0))] for r in ROLES},
        segment_samples=1000,
        units=units,
    )
    del raw


_CHILD = r"""
import json, resource, sys, time
import numpy as np
import tribodyn as td
from tribodyn.io import open_recording
import tribodyn.io.tdms as T
path, repeat, table_out = sys.argv[1], int(sys.argv[2]), sys.argv[4]
native, cold = sys.argv[3] == "1", sys.argv[5] == "1"
T._NATIVE = native
import os
def evict():  # the file's pages out of the page cache (clean pages: no root needed)
    fd = os.open(path, os.O_RDONLY)
    try:
        os.posix_fadvise(fd, 0, 0, os.POSIX_FADV_DONTNEED)
    finally:
        os.close(fd)
def run():
    kw = {"fs": 1000.0, "names": ["fx", "fy", "fz", "i"]} if path.endswith(".npy") else {}
    if cold:
        evict()
    t0 = time.perf_counter()
    with open_recording(path, **kw) as rec:
        res = td.analyze(rec, window=2.0, hop=2.0, method="paper", motion="unidirectional")
    return time.perf_counter() - t0, res
_, res = run()
times = [run()[0] for _ in range(repeat)]
if table_out != "-":
    np.savez(table_out, **{k: np.asarray(v) for k, v in res.table.items() if np.asarray(v).dtype.kind in "fiub"})
# VmHWM, not ru_maxrss: that one survives exec and may be the parent's (the writer's) peak
hwm = [int(l.split()[1]) for l in open("/proc/self/status") if l.startswith("VmHWM:")]
rss = hwm[0] / 1024 if hwm else resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps({"times": times, "route": res.params["route"], "threads": res.params.get("threads"), "rss_mb": rss}))
"""


_CHILD_THREADS = r"""
import json, os, sys, time
path, kind, repeat, table_out = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
import numpy as np
ROLES = ("fx", "fy", "fz", "i")
route = threads = None
if kind == "analyze":
    import tribodyn as td
    from tribodyn.io import open_recording
    kw = {"fs": 1000.0, "names": list(ROLES)} if path.endswith(".npy") else {}
    def once():
        with open_recording(path, **kw) as rec:
            return td.analyze(rec, window=2.0, hop=2.0, method="paper", motion="unidirectional")
elif kind == "h5py":  # h5py's plain read of the same datasets into memory
    import h5py
    def once():
        with h5py.File(path, "r") as h:
            return [h[r][:] for r in ROLES]
elif kind == "npload":
    def once():
        return np.load(path)
elif kind == "yardstick":  # the memory yardstick: fy @ fz on loaded arrays
    a = np.load(path)
    fy, fz = a[1], a[2]
    def once():
        return fy @ fz
else:
    raise SystemExit("unknown kind " + kind)
def timed():
    c0, t0 = time.process_time(), time.perf_counter()
    out = once()
    return time.perf_counter() - t0, time.process_time() - c0, out
res = timed()[2]  # warm-up
runs = [timed()[:2] for _ in range(repeat)]
if kind == "analyze":
    route, threads = res.params["route"], res.params.get("threads")
    if table_out != "-":
        tab = {k: np.asarray(v) for k, v in res.table.items()}
        np.savez(table_out, **{k: v for k, v in tab.items() if v.dtype.kind in "fiub"})
hwm = [int(l.split()[1]) for l in open("/proc/self/status") if l.startswith("VmHWM:")]
print(json.dumps({"times": [w for w, _ in runs], "cpu": [c for _, c in runs], "route": route,
                  "threads": threads, "rss_mb": hwm[0] / 1024 if hwm else float("nan")}))
"""
#: Formats timed per thread count (``--threads``): the ones issue 38 point 1 names.
THREAD_FORMATS = ("npy", "h5_chunked", "h5_contig", "tdms_1s", "tdms_10s")
THREAD_SECTION = "## Formats at 1 to 16 threads (issue 38 point 1)"
EXTRA_LABELS = {
    "h5py": "h5py's plain read of the 4 datasets ({f})",
    "npload": "`np.load` of the `.npy` alone",
    "yardstick": "yardstick `fy @ fz` on loaded arrays",
}


def measure_threads(path: Path, kind: str, threads: int, repeat: int, table_out: str = "-") -> Dict[str, Any]:
    """One case in a fresh process limited to ``threads`` (tribodyn's kernels and BLAS): wall and CPU medians."""
    env = dict(os.environ)
    for k in ("TRIBODYN_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        env[k] = str(threads)
    r = subprocess.run(
        [sys.executable, "-c", _CHILD_THREADS, str(path), kind, str(repeat), table_out],
        capture_output=True,
        text=True,
        check=False,
        env=env,
    )
    if r.returncode != 0:
        raise RuntimeError(f"{path.name} {kind} at {threads} threads: {r.stderr[-3000:]}")
    out: Dict[str, Any] = json.loads(r.stdout.strip().splitlines()[-1])
    out["median"] = statistics.median(out["times"])
    out["cpu_median"] = statistics.median(out["cpu"])
    return out


def thread_cases(formats: Sequence[str]) -> List[tuple]:
    """(key, format, kind) of every case timed per thread count."""
    cases = [(f, f, "analyze") for f in formats]
    cases += [(f"h5py:{f}", f, "h5py") for f in formats if f.startswith("h5")]
    cases += [("npload", "npy", "npload"), ("yardstick", "npy", "yardstick")]
    return cases


def run_threads(args: argparse.Namespace) -> str:
    """``--threads``: every case x thread count in a fresh process, rounds interleaved; returns the markdown."""
    formats = list(dict.fromkeys(["npy", *args.formats]))
    hours = args.hours[0]
    threads = args.threads
    cases = thread_cases(formats)
    work = Path(tempfile.mkdtemp(prefix="tribodyn-formats-threads-", dir=args.dir))
    load0 = os.getloadavg()
    t_start = time.perf_counter()
    runs: Dict[tuple, List[Dict[str, Any]]] = {}
    same: Dict[tuple, bool] = {}
    try:
        t0 = time.perf_counter()
        if args.reuse is not None:
            paths = reused(args.reuse, hours, formats)
            print(f"{hours:g} h files of {args.reuse} ({', '.join(formats)})", flush=True)
        else:
            paths = write_all(work, hours, formats)
            print(f"{hours:g} h written in {time.perf_counter() - t0:.0f} s ({', '.join(formats)})", flush=True)
        sizes = {f: paths[f].stat().st_size / 2**20 for f in formats}
        for rnd in range(args.rounds):
            for t in threads:
                for key, f, kind in cases:
                    table = str(work / f"table_{f}_{t}.npz") if rnd == 0 and kind == "analyze" else "-"
                    m = measure_threads(paths[f], kind, t, args.repeat, table)
                    runs.setdefault((key, t), []).append(m)
                    print(
                        f"round {rnd + 1} threads {t:2d} {key:16s} {m['median'] * 1e3:8.1f} ms wall "
                        f"{m['cpu_median'] * 1e3:8.1f} ms CPU" + (f"  route {m['route']}" if m["route"] else ""),
                        flush=True,
                    )
        for f in formats:
            ref = "tdms_daqmx" if f == "tdms_daqmx" else "npy"
            for t in threads:
                same[(f, t)] = same_tables(
                    str(work / f"table_{f}_{t}.npz"), str(work / f"table_{ref}_{threads[0]}.npz")
                )
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
    info = {
        "hours": hours,
        "threads": threads,
        "rounds": args.rounds,
        "repeat": args.repeat,
        "load": (load0, os.getloadavg()),
        "elapsed": time.perf_counter() - t_start,
        "sizes": sizes,
    }
    return render_threads(formats, cases, runs, same, info)


def _fmt_s(x: float) -> str:
    return f"{x * 1e3:.1f} ms" if x < 0.1 else f"{x * 1e3:.0f} ms" if x < 10 else f"{x:.1f} s"


def render_threads(
    formats: Sequence[str],
    cases: Sequence[tuple],
    runs: Dict[tuple, List[Dict[str, Any]]],
    same: Dict[tuple, bool],
    info: Dict[str, Any],
) -> str:
    threads = info["threads"]
    med = statistics.median
    wall = {k: med(m["median"] for m in v) for k, v in runs.items()}
    cpu = {k: med(m["cpu_median"] for m in v) for k, v in runs.items()}
    (l0, l1) = info["load"]
    ncpu = os.cpu_count() or 1
    over = [t for t in threads if t > ncpu]
    hdr = "| case | " + " | ".join(f"{t} thread{'s' if t > 1 else ''}" for t in threads) + " |"
    sep = "|---|" + "---|" * len(threads)
    lines = [
        THREAD_SECTION,
        "",
        f"Machine: {machine()}; load average {l0[0]:.1f} / {l0[1]:.1f} before, {l1[0]:.1f} / {l1[1]:.1f} after "
        f"(1 / 5 min). `python benches/bench_formats.py --threads {' '.join(map(str, threads))} --hours "
        f"{info['hours']:g}` ({time.strftime('%Y-%m-%d %H:%M')}, {info['elapsed']:.0f} s in all): "
        f'`open_recording` + `analyze(window=2, hop=2, method="paper", motion="unidirectional")` of a '
        f"{info['hours']:g} h, 1 kHz, 4-channel recording, warm files; each case x thread count a fresh process "
        f"(TRIBODYN_THREADS and the BLAS threads set to the count; one warm-up, then the median of "
        f"{info['repeat']}), {info['rounds']} rounds interleaved, median over the rounds."
        + (f" Thread counts above the {ncpu} cores ({', '.join(map(str, over))}) oversubscribe them." if over else ""),
        "",
        "Wall time, and in brackets the ratio to `.npy` at the same thread count (HDF5 and TDMS: target <= 1.5x; "
        "h5py rows: tribodyn's HDF5 analysis over h5py's plain read of the same file, target < 1):",
        "",
        hdr,
        sep,
    ]
    for key, f, kind in cases:
        if kind == "analyze":
            label = f"{LABELS[f]} ({info['sizes'][f]:.0f} MB)"
        else:
            label = EXTRA_LABELS[kind].format(f=LABELS.get(f, f))
        cells = []
        for t in threads:
            w = wall[(key, t)]
            if kind == "analyze" and f != "npy":
                r = w / wall[("npy", t)]
                mark = "" if f == "tdms_daqmx" else (" ok" if r <= 1.5 else " **>1.5**")
                cells.append(f"{_fmt_s(w)} ({r:.2f}x{mark})")
            elif kind == "h5py":
                r = wall[(f, t)] / w
                cells.append(f"{_fmt_s(w)} (analysis {r:.2f}x{' ok' if r < 1 else ' **>=1**'})")
            else:
                cells.append(_fmt_s(w))
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    lines += ["", "CPU time of the same runs (all threads of the process; medians):", "", hdr, sep]
    for key, f, kind in cases:
        label = LABELS[f] if kind == "analyze" else EXTRA_LABELS[kind].format(f=LABELS.get(f, f))
        lines.append(f"| {label} | " + " | ".join(_fmt_s(cpu[(key, t)]) for t in threads) + " |")
    routes = sorted({f"{f}: {runs[(f, t)][0]['route']}" for f in formats for t in threads})
    bad = [f"{f} at {t}" for (f, t), ok in same.items() if not ok]
    got = {runs[(f, t)][0]["threads"] for f in formats for t in threads}
    lines += [
        "",
        f"Routes: {', '.join(routes)}. Threads reported by the analyses: {sorted(got, key=str)}. "
        "Tables bitwise equal to the `.npy`'s at "
        f"{threads[0]} thread{'s' if threads[0] > 1 else ''} (DAQmx: to its own): "
        + ("yes, every format and thread count." if not bad else f"**no**: {', '.join(bad)}."),
    ]
    return "\n".join(lines) + "\n"


def measure(path: Path, repeat: int, native: bool = True, table_out: str = "-", cold: bool = False) -> Dict[str, Any]:
    r = subprocess.run(
        [sys.executable, "-c", _CHILD, str(path), str(repeat), "1" if native else "0", table_out, "1" if cold else "0"],
        capture_output=True,
        text=True,
        check=False,
    )
    if r.returncode != 0:
        raise RuntimeError(f"{path.name}: {r.stderr[-3000:]}")
    out = json.loads(r.stdout.strip().splitlines()[-1])
    out["median"] = statistics.median(out["times"])
    return out


def same_tables(a: str, b: str) -> bool:
    x, y = np.load(a), np.load(b)
    return set(x.files) == set(y.files) and all(
        x[k].shape == y[k].shape and bool(np.all((x[k] == y[k]) | (np.isnan(x[k]) & np.isnan(y[k])))) for k in x.files
    )


def machine() -> str:
    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = ""
    try:
        kb = int(re.search(r"MemTotal:\s+(\d+)", Path("/proc/meminfo").read_text()).group(1))  # type: ignore[union-attr]
        mem = f", {kb / 2**20:.0f} GiB RAM"
    except (OSError, AttributeError):
        pass
    system = f"{platform.system()} {platform.release()}"
    return f"{cpu}, {os.cpu_count()} cores{mem}, {system}, Python {platform.python_version()}"


def main(argv: List[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--hours", type=float, nargs="+", default=None, help="default 1 10 (--threads: 10)")
    ap.add_argument("--repeat", type=int, default=None, help="timed runs per process (default 5; --threads: 2)")
    ap.add_argument("--keep", action="store_true")
    ap.add_argument("--dir", type=Path, default=None)
    ap.add_argument(
        "--threads",
        type=int,
        nargs="+",
        default=None,
        help="time every case at these thread counts (e.g. 1 2 4 8 16), each in a fresh process, rounds "
        "interleaved; prints the table (and writes --markdown) instead of the default run",
    )
    ap.add_argument("--formats", nargs="+", choices=FORMATS, default=list(THREAD_FORMATS), help="with --threads")
    ap.add_argument("--rounds", type=int, default=3, help="with --threads: interleaved rounds")
    ap.add_argument("--markdown", type=Path, default=None, help="with --threads: write the section to this file")
    ap.add_argument(
        "--reuse", type=Path, default=None, help="with --threads: the files an earlier --keep run left (no writing)"
    )
    args = ap.parse_args(argv)
    if args.threads:
        if any(t < 1 for t in args.threads):
            ap.error("--threads: counts must be >= 1")
        args.hours = args.hours or [10.0]
        if len(args.hours) != 1:
            ap.error("--threads takes one --hours")
        args.repeat = args.repeat or 2
        text = run_threads(args)
        print(text)
        if args.markdown:
            args.markdown.write_text(text)
        return 0
    args.hours = args.hours or [1.0, 10.0]
    args.repeat = args.repeat or 5
    full = sorted(args.hours) == [1.0, 10.0]
    work = Path(tempfile.mkdtemp(prefix="tribodyn-formats-", dir=args.dir))
    res: Dict[float, Dict[str, Any]] = {}
    try:
        for h in args.hours:
            t0 = time.perf_counter()
            paths = write_all(work, h)
            print(f"{h:g} h written in {time.perf_counter() - t0:.0f} s", flush=True)
            res[h] = {}
            tables = {}
            for f in FORMATS:
                tables[f] = str(work / f"{h:g}h_{f}_table.npz")
                res[h][f] = measure(paths[f], args.repeat, table_out=tables[f])
                res[h][f]["size_mb"] = paths[f].stat().st_size / 2**20
                if h == max(args.hours):
                    res[h][f]["cold"] = measure(paths[f], 3, cold=True)["median"]
                print(
                    f"{h:g} h {f:11s} {res[h][f]['median'] * 1e3:8.1f} ms  route {res[h][f]['route']:7s} "
                    f"rss {res[h][f]['rss_mb']:.0f} MB",
                    flush=True,
                )
            for f in FORMATS:
                if f == "tdms_daqmx":
                    if h <= 1.0:  # the npTDMS route as the oracle (slow on long files)
                        ref = str(work / f"{h:g}h_daqmx_nptdms.npz")
                        res[h][f]["nptdms_median"] = measure(paths[f], 1, native=False, table_out=ref)["median"]
                        res[h][f]["same_table"] = same_tables(tables[f], ref)
                else:
                    res[h][f]["same_table"] = same_tables(tables[f], tables["npy"])
            for f in FORMATS:
                if f != "npy":
                    paths[f].unlink()
            paths["npy"].unlink()
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
    text = render(res, args.repeat)
    print(text)
    if full:
        write_section(text)
    return 0


def render(res: Dict[float, Dict[str, Any]], repeat: int) -> str:
    hours = sorted(res)
    long, short = hours[-1], hours[0]
    lines = [
        SECTION,
        "",
        f"Machine: {machine()}. `python benches/bench_formats.py` ({time.strftime('%Y-%m-%d')}): "
        f'`open_recording` + `analyze(window=2, hop=2, method="paper", motion="unidirectional")`, default threads, '
        f"warm files, "
        f"median of {repeat} after a warm-up, each format in a fresh process (peak RSS of that process).",
        "",
        f"| format | {long:g} h | ratio to `.npy` | target | cold ({long:g} h), ratio | route | "
        f"peak RSS {short:g} h / {long:g} h | {long:g} h / {short:g} h time | same table |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    base = res[long]["npy"]["median"]
    cold_base = res[long]["npy"].get("cold", float("nan"))
    for f in FORMATS:
        r = res[long][f]
        ratio = r["median"] / base
        tgt = TARGET.get(f)
        tgt_s = "-" if tgt is None else (f"<= {tgt:g}x " + ("met" if ratio <= tgt else "**missed**"))
        growth = r["median"] / res[short][f]["median"] if short != long else float("nan")
        same = r.get("same_table", res[short][f].get("same_table"))
        cold = r.get("cold", float("nan"))
        cold_s = f"{cold:.2f} s, {cold / cold_base:.2f}x" + (
            "" if f == "npy" else " (<= 1.5x " + ("met)" if cold / cold_base <= 1.5 else "**missed**)")
        )
        lines.append(
            f"| {LABELS[f]} ({r['size_mb']:.0f} MB) | {r['median'] * 1e3:.0f} ms | {ratio:.2f}x | {tgt_s} | {cold_s} | "
            f"{r['route']} | {res[short][f]['rss_mb']:.0f} / {r['rss_mb']:.0f} MB | {growth:.1f} | "
            f"{'yes' if same else 'no' if same is not None else '-'} |"
        )
    d = res[short].get("tdms_daqmx", {})
    if "nptdms_median" in d:
        lines += [
            "",
            f"DAQmx {short:g} h through npTDMS (the fallback): {d['nptdms_median']:.2f} s against "
            f"{d['median'] * 1e3:.0f} ms natively; same table: {'yes' if d.get('same_table') else 'no'}.",
        ]
    return "\n".join(lines) + "\n"


def write_section(text: str, section: str = SECTION) -> None:
    """Replaces (or appends) the section of benches/RESULTS.md whose heading is ``section``, keeping its
    hand-written end (``_results.KEEP``)."""
    from _results import kept

    old = RESULTS.read_text() if RESULTS.exists() else ""
    if section in old:
        start = old.index(section)
        nxt = old.find("\n## ", start + len(section))
        text = text.rstrip("\n") + "\n" + kept(old[start : nxt if nxt >= 0 else len(old)])
        old = old[:start] + (old[nxt + 1 :] if nxt >= 0 else "")
    RESULTS.write_text(old.rstrip("\n") + "\n\n" + text)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
