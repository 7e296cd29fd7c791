"""CSV and LVM: tribodyn end to end against pandas' C parser and pyarrow reading the same file (issue 16).

A simulated 1 kHz recording of fx, fy, fz and i (``tribodyn.simulate.continuous``,
seed 11, the recording of ``bench_formats.py``) is rounded to 6 decimals
(time to 3) and written as

* a CSV with a header row and a time column (``time,fx,fy,fz,i``), by
  pyarrow's CSV writer (shortest round-trip digits: ``0.016174``);
* an LVM file (LabVIEW Measurement: file and segment header, tab-separated,
  ``X_Value`` then the channels), the same digits;
* a channels-first float64 ``.npy`` of the same rounded values, so the text
  tables must equal the ``.npy`` table bit for bit.

Each is timed in a fresh process, one warm-up then ``--repeat`` runs
(median), files warm in the page cache:

* tribodyn: ``open_recording`` + ``analyze(window=2, hop=2, method="paper",
  motion="unidirectional")`` (as ``bench_formats.py``), its route and the
  process's peak RSS (VmHWM);
* pandas alone reading the file (``pandas.read_csv``, C engine, default
  options; LVM: ``sep="\\t"``, the header rows skipped) and its peak RSS;
* pyarrow's streaming CSV reader (``pyarrow.csv.open_csv``) reading every
  batch (the "best plain read" of a well-kept library), and its peak RSS.

Usage::

    python benches/bench_text.py               # 1 h and 10 h, writes a section of benches/RESULTS.md
    python benches/bench_text.py --hours 0.1   # smoke run, prints only
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Dict, List

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_formats import machine, same_tables, write_section  # noqa: E402

FS = 1000.0
ROLES = ("fx", "fy", "fz", "i")
SECTION = "## Text formats: CSV and LVM against pandas and pyarrow (issue 16)"
LVM_HEAD_ROWS = 23  # lines before the first data row in the LVM written here


def _lvm_header() -> str:
    names = "\t".join(ROLES)
    per = lambda v: "\t".join([v] * len(ROLES))  # noqa: E731
    return (
        "LabVIEW Measurement\t\nWriter_Version\t2\nReader_Version\t2\nSeparator\tTab\nDecimal_Separator\t.\n"
        "Multi_Headings\tNo\nX_Columns\tOne\nTime_Pref\tRelative\nOperator\tbench\nDate\t2026/11/22\n"
        "Time\t10:00:00\n***End_of_Header***\t\n\n"
        f"Channels\t{len(ROLES)}\t\nSamples\t{per('0')}\t\nDate\t{per('2026/11/22')}\t\n"
        f"Time\t{per('10:00:00')}\t\nY_Unit_Label\tN\tN\tN\tA\t\nX_Dimension\t{per('Time')}\t\n"
        f"X0\t{per('0')}\t\nDelta_X\t{per('0.001')}\t\n***End_of_Header***\t\n"
        f"X_Value\t{names}\tComment\n"
    )


def write_all(directory: Path, hours: float) -> Dict[str, Path]:
    """The rounded recording as .npy, CSV and LVM; returns the paths."""
    import pyarrow as pa
    import pyarrow.csv as pc
    from tribodyn import simulate

    n = int(round(hours * 3600 * FS))
    tag = f"{hours:g}h"
    p = {"npy": directory / f"{tag}.npy", "csv": directory / f"{tag}.csv", "lvm": directory / f"{tag}.lvm"}
    arr = np.lib.format.open_memmap(p["npy"], mode="w+", dtype=np.float64, shape=(len(ROLES), n))
    head = _lvm_header().replace("\tSamples\t0", f"\tSamples\t{n}")
    head = head.replace("Samples\t" + "\t".join(["0"] * len(ROLES)), "Samples\t" + "\t".join([str(n)] * len(ROLES)))
    assert head.count("\n") == LVM_HEAD_ROWS
    pos = 0
    csv_w = lvm_w = None
    with open(p["lvm"], "wb") as lvm_f:
        lvm_f.write(head.encode())
        for chunk in simulate.continuous(hours * 3600, chunk_s=600.0, current=4.0, seed=11, fs=FS, raw=False):
            m = len(chunk["fz"])
            cols = {r: np.round(np.asarray(chunk[r]), 6) for r in ROLES}
            for j, r in enumerate(ROLES):
                arr[j, pos : pos + m] = cols[r]
            t = np.round((pos + np.arange(m)) / FS, 3)
            tbl = pa.table({"time": t, **cols})
            if csv_w is None:
                csv_w = pc.CSVWriter(str(p["csv"]), tbl.schema, write_options=pc.WriteOptions(quoting_style="none"))
                lvm_w = pc.CSVWriter(
                    lvm_f, tbl.schema,
                    write_options=pc.WriteOptions(include_header=False, delimiter="\t", quoting_style="none"),
                )  # fmt: skip
            csv_w.write_table(tbl)
            lvm_w.write_table(tbl)  # type: ignore[union-attr]
            pos += m
        assert csv_w is not None and lvm_w is not None
        csv_w.close()
        lvm_w.close()
    arr.flush()
    assert pos == n
    del arr
    return p


_CHILD = r"""
import json, sys, time
import numpy as np
what, path, repeat, table_out = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
def rss():
    return [int(l.split()[1]) for l in open("/proc/self/status") if l.startswith("VmHWM:")][0] / 1024
if what == "tribodyn":
    import tribodyn as td
    from tribodyn.io import open_recording
    def run():
        kw = {"fs": 1000.0, "names": ["fx", "fy", "fz", "i"]} if path.endswith(".npy") else {}
        t0 = time.perf_counter()
        with open_recording(path, **kw) as rec:
            res = td.analyze(rec, window=2.0, hop=2.0, method="paper", motion="unidirectional")
        return time.perf_counter() - t0, res
elif what == "pandas":
    import pandas as pd
    def run():
        t0 = time.perf_counter()
        if path.endswith(".lvm"):
            df = pd.read_csv(path, sep="\t", skiprows=%d, header=None)
        else:
            df = pd.read_csv(path)
        return time.perf_counter() - t0, len(df)
else:
    import pyarrow.csv as pc
    def run():
        t0 = time.perf_counter()
        if path.endswith(".lvm"):
            r = pc.open_csv(path, read_options=pc.ReadOptions(skip_rows=%d, autogenerate_column_names=True),
                            parse_options=pc.ParseOptions(delimiter="\t"))
        else:
            r = pc.open_csv(path)
        n = sum(b.num_rows for b in r)
        return time.perf_counter() - t0, n
_, res = run()
times = [run()[0] for _ in range(repeat)]
out = {"times": times, "rss_mb": rss()}
if what == "tribodyn":
    out["route"] = res.params["route"]
    if table_out != "-":
        np.savez(table_out, **{k: np.asarray(v) for k, v in res.table.items() if np.asarray(v).dtype.kind in "fiub"})
print(json.dumps(out))
""" % (LVM_HEAD_ROWS, LVM_HEAD_ROWS)


def measure(what: str, path: Path, repeat: int, table_out: str = "-") -> Dict[str, Any]:
    r = subprocess.run(
        [sys.executable, "-c", _CHILD, what, str(path), str(repeat), table_out], capture_output=True, text=True,
        check=False,
    )  # fmt: skip
    if r.returncode != 0:
        raise RuntimeError(f"{what} {path.name}: {r.stderr[-3000:]}")
    out: Dict[str, Any] = json.loads(r.stdout.strip().splitlines()[-1])
    out["median"] = statistics.median(out["times"])
    return out


def main(argv: List[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--hours", type=float, nargs="+", default=[1.0, 10.0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--dir", type=Path, default=None)
    args = ap.parse_args(argv)
    full = sorted(args.hours) == [1.0, 10.0]
    work = Path(tempfile.mkdtemp(prefix="tribodyn-text-", dir=args.dir))
    res: Dict[float, Dict[str, Any]] = {}
    try:
        for h in sorted(args.hours):
            t0 = time.perf_counter()
            paths = write_all(work, h)
            print(f"{h:g} h written in {time.perf_counter() - t0:.0f} s", flush=True)
            res[h] = {}
            for f in ("npy", "csv", "lvm"):
                table = str(work / f"{h:g}h_{f}_table.npz")
                r = measure("tribodyn", paths[f], args.repeat, table)
                r["size_mb"] = paths[f].stat().st_size / 2**20
                r["same_table"] = True if f == "npy" else same_tables(table, str(work / f"{h:g}h_npy_table.npz"))
                if f != "npy":
                    r["pandas"] = measure("pandas", paths[f], args.repeat)
                    r["pyarrow"] = measure("pyarrow", paths[f], args.repeat)
                res[h][f] = r
                line = f"{h:g} h {f}: tribodyn {r['median']:.3f} s, rss {r['rss_mb']:.0f} MB, route {r['route']}"
                if f != "npy":
                    line += (f"; pandas {r['pandas']['median']:.3f} s ({r['pandas']['rss_mb']:.0f} MB), pyarrow "
                             f"{r['pyarrow']['median']:.3f} s; same table {r['same_table']}")  # fmt: skip
                print(line, flush=True)
            for q in paths.values():
                q.unlink()
    finally:
        shutil.rmtree(work, ignore_errors=True)
    text = render(res, args.repeat)
    print(text)
    if full:
        write_section(text, SECTION)
    return 0


def render(res: Dict[float, Dict[str, Any]], repeat: int) -> str:
    hours = sorted(res)
    long, short = hours[-1], hours[0]
    lines = [
        SECTION,
        "",
        f"Machine: {machine()}. `python benches/bench_text.py` ({time.strftime('%Y-%m-%d')}), warm files, each "
        f"measurement in a fresh process, median of {repeat} after a warm-up (in-process times: interpreter "
        "start and imports excluded); peak RSS is that process's VmHWM. tribodyn: `open_recording` + "
        '`analyze(window=2, hop=2, method="paper", motion="unidirectional")`; pandas: `read_csv` alone (C engine); '
        "pyarrow: `pyarrow.csv.open_csv`, every batch read. Values have 6 decimals, so the text tables are "
        "compared bit for bit with the `.npy` table of the same values.",
        "",
        f"| format | tribodyn {long:g} h | ratio to `.npy` | pandas read alone | tribodyn / pandas | pyarrow read "
        f"| peak RSS tribodyn {short:g} h / {long:g} h | pandas RSS | {long:g} h / {short:g} h | same table |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    base = res[long]["npy"]["median"]
    for f in ("npy", "csv", "lvm"):
        r = res[long][f]
        growth = r["median"] / res[short][f]["median"] if short != long else float("nan")
        if f == "npy":
            lines.append(
                f"| `.npy` ({r['size_mb']:.0f} MB) | {r['median']:.3f} s | 1.00x | - | - | - | "
                f"{res[short][f]['rss_mb']:.0f} / {r['rss_mb']:.0f} MB | - | {growth:.1f} | - |"
            )
            continue
        pd_t, pa_t = r["pandas"]["median"], r["pyarrow"]["median"]
        lines.append(
            f"| {f.upper()} ({r['size_mb']:.0f} MB) | {r['median']:.2f} s | {r['median'] / base:.1f}x | "
            f"{pd_t:.2f} s | {r['median'] / pd_t:.2f} ({'met' if r['median'] < pd_t else '**missed**'}) | "
            f"{pa_t:.2f} s | {res[short][f]['rss_mb']:.0f} / {r['rss_mb']:.0f} MB "
            f"({'met' if r['rss_mb'] <= 300 else '**missed**'}) | {r['pandas']['rss_mb']:.0f} MB | {growth:.1f} | "
            f"{'yes' if r['same_table'] and res[short][f]['same_table'] else 'no'} |"
        )
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
