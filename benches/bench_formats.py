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

Usage::

    python benches/bench_formats.py                 # 1 h and 10 h, writes a section of benches/RESULTS.md
    python benches/bench_formats.py --hours 0.1     # smoke run, prints only
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
from typing import Any, Dict, List

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


def write_all(directory: Path, hours: float) -> Dict[str, Path]:
    """Writes the recording of ``hours`` in every format; returns the paths."""
    import h5py
    from tribodyn import simulate
    from tribodyn.io.tdms import write_daqmx_tdms
    from tribodyn.io.writers import save_tdms

    n = int(round(hours * 3600 * FS))
    tag = f"{hours:g}h"
    p: Dict[str, Path] = {
        f: directory / f"{tag}_{f}.{'npy' if f == 'npy' else 'tdms' if 'tdms' in f else 'h5'}" for f in FORMATS
    }
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
        save_tdms(p[f], ch, FS, units, segment_samples=seg)
    raw = {r: np.clip(np.round(np.asarray(ch[r]) / DAQ_LSB[r]), -32768, 32767).astype(np.int16) for r in ROLES}
    write_daqmx_tdms(
        str(p["tdms_daqmx"]),
        raw,
        FS,
        {r: [("Linear", (DAQ_LSB[r], 0.0))] for r in ROLES},
        segment_samples=1000,
        units=units,
    )
    del raw
    for f, chunks in (("h5_contig", None), ("h5_chunked", (min(n, 65536),))):
        with h5py.File(p[f], "w") as h:
            h.attrs["fs"] = FS
            for r in ROLES:
                d = h.create_dataset(r, shape=(n,), dtype="<f8", chunks=chunks)
                for a in range(0, n, 1 << 22):
                    d[a : a + (1 << 22)] = ch[r][a : a + (1 << 22)]
                d.attrs["unit"] = units[r]
    del arr, ch
    return p


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
    ap.add_argument("--hours", type=float, nargs="+", default=[1.0, 10.0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--keep", action="store_true")
    ap.add_argument("--dir", type=Path, default=None)
    args = ap.parse_args(argv)
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
