"""Every route of ``tribodyn.analyze``, timed against an earlier build in one run.

One simulated recording (fx, fy, fz, i at 1 kHz; 1 h by default) is
written as a channels-first float64 ``.npy`` (dynamic and raw forces), a
chunked HDF5 file, a TDMS file (10 s segments) and a CSV file; each is
opened with ``tribodyn.open_recording`` and analysed with 2 s windows tiling
it, the default thread count, in a fresh process per measurement. With
``--baseline DIR`` (a directory holding another build of the package, e.g.
a wheel of an older commit unpacked there) every case also runs with that
build first on ``PYTHONPATH``, interleaved with this one, so the ratio
new / baseline comes from one run on the same files. Each measurement
also records the route taken (``params["route"]``, this build only) and a
digest of the table, so a route that changed its answer is seen.

Usage::

    python benches/bench_routes.py                          # this build only
    python benches/bench_routes.py --baseline /tmp/base-pkg --repeats 5
    python benches/bench_routes.py --hours 0.1 --repeats 2  # smoke run

Prints a Markdown table (paste it into ``RESULTS.md``).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any, Dict, List, Optional

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import bench_pipeline as bp  # noqa: E402  (the recording writer and constants)

#: (label, file key, analyze options as Python source)
CASES = [
    ("npy dynamic", "npy", "{}"),
    ("npy raw, highpass=0.1", "npy_raw", "{'highpass': 0.1}"),
    ("npy dynamic, max_lag=0 (not mapped)", "npy", "{'max_lag': 0}"),
    ("HDF5 dynamic", "h5", "{}"),
    ("TDMS dynamic", "tdms", "{}"),
    ("CSV dynamic", "csv", "{}"),
]

CHILD = r"""
import hashlib, json, sys, time
import numpy as np
import tribodyn as td
path, fs, extra, threads = sys.argv[1], float(sys.argv[2]), eval(sys.argv[3]), sys.argv[4]
kw = dict(window=2.0, hop=2.0, area_mm2=1.0, **extra)
if threads != "default":
    kw["threads"] = int(threads)
t0 = time.perf_counter()
with td.open_recording(path, fs=fs, **({"names": ["fx", "fy", "fz", "i"]} if path.endswith(".npy") else {})) as rec:
    res = td.analyze(rec, **kw)
dt = time.perf_counter() - t0
h = hashlib.sha256()
for c in ("mu_r", "c_yz", "mu_a", "mu_b", "i"):
    h.update(np.ascontiguousarray(res.table[c]).tobytes())
# VmHWM: this process's peak (ru_maxrss would carry the parent's peak across exec).
rss = next(int(l.split()[1]) for l in open("/proc/self/status") if l.startswith("VmHWM")) / 1024
print(json.dumps({"s": dt, "route": res.params.get("route", "?"), "digest": h.hexdigest()[:12],
                  "gated": int(res.table["ok"].sum()), "windows": len(res), "rss_mb": rss}))
"""


def write_files(directory: Path, hours: float, keys: set) -> Dict[str, Path]:
    """The recording in the formats ``keys`` asks for (the dynamic ``.npy`` always)."""
    from tribodyn.io.writers import save_recording

    dur = hours * 3600.0
    paths = bp.write_recording(directory, "dyn", dur, raw=False, formats=("npy", "h5") if "h5" in keys else ("npy",))
    if "npy_raw" in keys:
        paths["npy_raw"] = bp.write_recording(directory, "raw", dur, raw=True, formats=("npy",))["npy"]
    if not keys & {"tdms", "csv"}:
        return paths
    arr = np.load(paths["npy"], mmap_mode="r")
    channels = {r: np.asarray(arr[j]) for j, r in enumerate(bp.ROLES)}
    paths["tdms"] = directory / "dyn.tdms"
    save_recording(paths["tdms"], channels, fs=bp.FS)
    # A tribometer-style CSV export: a header row, a time column, 9 digits.
    paths["csv"] = directory / "dyn.csv"
    t = np.arange(len(channels["fz"])) / bp.FS
    table = np.column_stack([t] + [channels[r] for r in bp.ROLES])
    np.savetxt(paths["csv"], table, fmt="%.9g", delimiter=",", header="time,fx,fy,fz,i", comments="")
    return paths


def measure(path: Path, extra: str, pythonpath: Optional[str], threads: str) -> Dict[str, Any]:
    env = dict(os.environ)
    if pythonpath:
        env["PYTHONPATH"] = pythonpath
    out = subprocess.run(
        [sys.executable, "-c", CHILD, str(path), str(bp.FS), extra, threads],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    if out.returncode != 0:
        return {"error": (out.stderr.strip().splitlines() or ["?"])[-1]}
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: Optional[List[str]] = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--hours", type=float, default=1.0, help="recording length (default 1 h)")
    ap.add_argument("--repeats", type=int, default=5, help="fresh processes per measurement")
    ap.add_argument("--baseline", help="directory of another build of tribodyn, put first on PYTHONPATH")
    ap.add_argument("--threads", default="default", help="threads= of every call (default: the default)")
    ap.add_argument("--tmp", help="directory for the temporary files")
    ap.add_argument("--only", help="run the cases whose label contains this text")
    args = ap.parse_args(argv)
    builds = [("this", None)] + ([("baseline", args.baseline)] if args.baseline else [])
    with tempfile.TemporaryDirectory(dir=args.tmp) as d:
        cases = [c for c in CASES if not args.only or args.only in c[0]]
        paths = write_files(Path(d), args.hours, {key for _, key, _ in cases})
        rows = []
        for label, key, extra in cases:
            runs: Dict[str, List[Dict[str, Any]]] = {b: [] for b, _ in builds}
            for _ in range(args.repeats):
                for b, pp in reversed(builds):  # interleaved, the baseline first
                    runs[b].append(measure(paths[key], extra, pp, args.threads))
            rows.append((label, runs))
            print(label, {b: [r.get("s", r.get("error")) for r in v] for b, v in runs.items()}, flush=True)
    print()
    print(f"{args.hours:g} h at 1 kHz, 4 channels, 2 s windows tiling it, threads={args.threads}, "
          f"medians of {args.repeats} fresh processes; {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} CPUs, Python {platform.python_version()}")  # fmt: skip
    head = "| case | route | this build | peak RSS | gated |"
    if args.baseline:
        head += " baseline | ratio this / baseline | same table |"
    print(head)
    print("|" + "---|" * (head.count("|") - 1))
    for label, runs in rows:
        mine = runs["this"]
        ok = [r for r in mine if "s" in r]
        if not ok:
            print(f"| {label} | error: {mine[0].get('error')} |")
            continue
        t = statistics.median(r["s"] for r in ok)
        line = (f"| {label} | {ok[0]['route']} | {t * 1e3:.1f} ms | {max(r['rss_mb'] for r in ok):.0f} MB | "
                f"{ok[0]['gated']}/{ok[0]['windows']} |")  # fmt: skip
        if args.baseline:
            base = [r for r in runs["baseline"] if "s" in r]
            if base:
                tb = statistics.median(r["s"] for r in base)
                digests = {r["digest"] for r in base} | {r["digest"] for r in ok}
                gated = sorted({r["gated"] for r in base})
                same = "yes" if len(digests) == 1 else f"no ({len(digests)} digests; baseline gated {gated})"
                line += f" {tb * 1e3:.1f} ms | {t / tb:.2f} | {same} |"
            else:
                line += f" error: {runs['baseline'][0].get('error')} | | |"
        print(line)


if __name__ == "__main__":
    main()
