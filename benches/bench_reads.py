"""How often one analysis reads its input (issue 22 point 5): ``/proc/<pid>/io`` rchar of ``analyze`` and of
the command line with its report, on recordings of a few hours.

rchar counts every byte a process reads through ``read``-like calls, of every file, and (read here from the
parent) those of the children it reaped: the recording, but also the modules imported, Matplotlib's glyphs
(FreeType reads DejaVu Sans in small pieces for every text it draws: tens of MB per report, all from the
page cache) and Bokeh's scripts. So each case runs twice, on the recording of ``--hours`` and on a 6-minute
one of the same kind, and the table gives

* ``total``: rchar of the long run / the recording's size (the issue's measure, fixed reads included);
* ``fixed``: rchar of the short run minus its recording's size times ``per byte`` (what does not grow);
* ``per byte``: (rchar long - rchar short) / (size long - size short), the reads that grow with the
  recording (whole readings of it, and bounded samples, which stop growing once the recording is longer
  than the sample).

Recordings (channels-first float64 ``.npy``, 1 kHz, fx fy fz i; CSV: time and the four channels):

* ``static``: a static normal load of 20 N with a 13 Hz ripple and a saw-tooth friction (stick-slip every
  37.3 ms, 190,000 events in 2 h): the classical COF and stick-slip are searched (route "stream");
* ``dynamic``: ``simulate.continuous(..., current=4.0)`` (AC-coupled forces: route "mapped", no stick-slip).

Usage::

    python benches/bench_reads.py                 # 2 h, writes its section of benches/RESULTS.md
    python benches/bench_reads.py --hours 0.5 --no-write
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Dict, List, Tuple

import numpy as np

MAP = "fx=ch0,fy=ch1,fz=ch2,i=ch3"
SHORT_H = 0.1


def rchar() -> int:
    with open("/proc/self/io") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("rchar"))


def static_recording(path: Path, hours: float) -> None:
    n = int(hours * 3600 * 1000)
    rng = np.random.default_rng(0)
    k = np.arange(n)
    fz = 20.0 + 2.0 * np.sin(2 * np.pi * 13.0 * k / 1000.0) + 0.03 * rng.standard_normal(n)
    fy = -(0.2 * fz + 0.3 * (np.mod(k / 37.3, 1.0) - 0.5)) + 0.03 * rng.standard_normal(n)
    np.save(path, np.vstack([0.05 * rng.standard_normal(n), fy, fz, 4.0 + 0.01 * rng.standard_normal(n)]))


def dynamic_recording(path: Path, hours: float) -> None:
    from tribodyn import simulate

    parts = list(simulate.continuous(hours * 3600.0, current=4.0, seed=3))
    np.save(path, np.vstack([np.concatenate([p[r] for p in parts]) for r in ("fx", "fy", "fz", "i")]))


def csv_recording(path: Path, npy: Path) -> None:
    a = np.load(npy)
    t = np.arange(a.shape[1]) / 1000.0
    np.savetxt(path, np.column_stack([t, *a]), delimiter=",", fmt="%.6f", header="time,fx,fy,fz,i", comments="")


def timed(cmd: List[str]) -> Tuple[int, float]:
    """(rchar of the command's process and its children, seconds)."""
    r0, t0 = rchar(), time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "PYTHONDONTWRITEBYTECODE": ""})
    if p.returncode != 0:
        raise RuntimeError(f"{cmd} failed: {p.stderr[-2000:]}")
    return rchar() - r0, time.perf_counter() - t0


def cli(path: Path, out: Path) -> List[str]:
    extra = [] if path.suffix == ".csv" else ["--fs", "1000", "--map", MAP]
    return [sys.executable, "-m", "tribodyn", "analyze", str(path), "--out", str(out), "-q", *extra]


def api(path: Path) -> List[str]:
    opened = "" if path.suffix == ".csv" else ", fs=1000.0, channels=dict(fx='ch0', fy='ch1', fz='ch2', i='ch3')"
    code = f"import tribodyn as td\nwith td.open_recording({str(path)!r}{opened}) as rec: td.analyze(rec)"
    return [sys.executable, "-c", code]


def measure(long: Path, short: Path, work: Path) -> Dict[str, Dict[str, float]]:
    sizes = (long.stat().st_size, short.stat().st_size)
    out: Dict[str, Dict[str, float]] = {}
    for name, make in (("analyze", lambda p: api(p)), ("CLI with report", lambda p: cli(p, work / "out"))):
        runs = []
        for p in (long, short):
            shutil.rmtree(work / "out", ignore_errors=True)
            runs.append(timed(make(p)))
        (r_long, t_long), (r_short, _) = runs
        per_byte = (r_long - r_short) / (sizes[0] - sizes[1])
        fixed = (r_short - per_byte * sizes[1]) / 1e6
        out[name] = {"total": r_long / sizes[0], "per_byte": per_byte, "fixed_mb": fixed, "seconds": t_long}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--hours", type=float, default=2.0)
    ap.add_argument("--csv-hours", type=float, default=None, help="length of the CSV case (default --hours; 0: none)")
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory(prefix="tribodyn-reads-") as tmp:
        work = Path(tmp)
        cases = [("static .npy", static_recording, args.hours), ("dynamic .npy", dynamic_recording, args.hours)]
        csv_hours = args.hours if args.csv_hours is None else args.csv_hours
        if csv_hours > 0:
            cases.append(("static CSV", static_recording, csv_hours))
        for label, make, hours in cases:
            paths = []
            for h, tag in ((hours, "long"), (min(SHORT_H, hours / 4), "short")):
                npy = work / f"{tag}.npy"
                make(npy, h)
                if label.endswith("CSV"):
                    csv_recording(work / f"{tag}.csv", npy)
                    npy.unlink()
                    npy = work / f"{tag}.csv"
                paths.append(npy)
            got = measure(paths[0], paths[1], work)
            size = paths[0].stat().st_size / 1e6
            for what, m in got.items():
                rows.append(
                    f"| {label}, {hours:g} h ({size:.0f} MB) | {what} | {m['total']:.2f} | {m['per_byte']:.2f} | "
                    f"{m['fixed_mb']:.0f} MB | {m['seconds']:.2f} s |"
                )
                print(rows[-1], flush=True)
            for p in paths:
                p.unlink()
    load = os.getloadavg()
    body = "\n".join(
        [
            f"`python benches/bench_reads.py --hours {args.hours:g}` ({time.strftime('%Y-%m-%d')}), load average "
            f"after the run {load[0]:.2f}, {load[1]:.2f}, {load[2]:.2f}. rchar read from the parent (the children "
            "included); total = rchar / the recording's size; per byte = the reads that grow with the recording "
            "(the long run against a 6-min one); fixed = what does not grow (imports, Matplotlib's glyph reads, "
            "Bokeh). Issue 22 asks at most 1.2x for `analyze` and 2.2x for the CLI with its report on 2 h.",
            "",
            "| recording | run | total | per byte | fixed | time |",
            "|---|---|---|---|---|---|",
            *rows,
        ]
    )
    if not args.no_write:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from _results import write_section  # type: ignore[import-not-found]

        write_section("Reads per analysis (issue 22)", body)
    print(body)


if __name__ == "__main__":
    main()
