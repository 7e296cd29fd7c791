"""The command line on a small tribometer export (issue 38 point 3): wall time of `tribodyn analyze` with its
report, each run a fresh process, rounds interleaved with a baseline build.

    python benches/bench_cli_export.py [--rounds 5] [--baseline PYTHONPATH] [FILE]

``--baseline`` is the ``python/`` folder of another checkout (its own ``_core``); the default file is the
pin-on-disc export tests/data/real/pod_PPS_100N_1.tsv (0.17 MB, 1 Hz, 1800 rows).
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("file", nargs="?", default=str(ROOT / "tests/data/real/pod_PPS_100N_1.tsv"))
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--baseline", help="PYTHONPATH of a baseline build (its python/ folder)")
    args = ap.parse_args()
    builds = {"this build": str(ROOT / "python")}
    if args.baseline:
        builds["baseline"] = args.baseline
    times: dict = {k: [] for k in builds}
    work = Path(tempfile.mkdtemp(prefix="bench_cli_"))
    try:
        for r in range(args.rounds):
            for name, path in builds.items():
                out = work / f"{r}-{name.replace(' ', '_')}"
                env = dict(os.environ, PYTHONPATH=path)
                t = time.perf_counter()
                p = subprocess.run([sys.executable, "-m", "tribodyn.app.cli", "analyze", args.file, "--out", str(out),
                                    "-q"], env=env, capture_output=True, text=True)  # fmt: skip
                times[name].append(time.perf_counter() - t)
                if p.returncode != 0:
                    raise SystemExit(f"{name}: exit {p.returncode}: {p.stderr[-500:]}")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(f"{Path(args.file).name}, {args.rounds} interleaved rounds, load average {os.getloadavg()}")
    for name, v in times.items():
        runs = ", ".join(f"{x:.2f}" for x in v)
        print(f"| {name} | {statistics.median(v):.2f} s | {runs} |")


if __name__ == "__main__":
    main()
