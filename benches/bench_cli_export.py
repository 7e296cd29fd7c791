"""The command line with its report against the API (issue 38 point 3): wall and CPU time of whole processes,
rounds interleaved with a baseline build.

    python benches/bench_cli_export.py [--rounds 5] [--baseline PYTHONPATH] [--build PYTHONPATH] [--data DIR]
        [--no-long] [--no-folder] [--no-small] [--long FILE] [--workers N ...] [--markdown FILE]

Cases (each run a fresh process; ``api``: ``python -c`` that imports tribodyn, opens the file, analyses it and
reads the headline; ``cli``: ``python -m tribodyn analyze FILE --out DIR -q``):

* ``small``: the pin-on-disc export tests/data/real/pod_PPS_100N_1.tsv (0.17 MB, 1800 rows): api, cli (default
  figures), cli ``--figures none`` and cli ``--figures all``;
* ``folder``: the exports of tests/data (:data:`FOLDER`, 8 files of 0.02-0.44 MB) as one ``tribodyn analyze
  DIR/*`` (default figures, and ``--figures none``) against one process that analyses them one after the other
  with the API;
* ``h10``: 10 h at 1 kHz, 4 channels ``.npy`` (1.15 GB, ``bench_fixed_costs.ensure_data`` in ``--data``), api
  and cli, by default and with ``--figures none`` (skipped with ``--no-long``): its 5 PNG figures are drawn by
  worker processes too when a core is free (``jobs._drawing_pool``, issue 38 point 3; their CPU is in the process
  tree's), and this build's cli again with ``TRIBODYN_DRAW_WORKERS`` = each of ``--workers`` (workers whatever the
  load).

``--long FILE``: that ``.npy`` recording ((4, n) float64 at 1 kHz: fx, fy, fz, i) instead of ``--data``'s 10 h one
(``benches/device_scaling.py`` passes the one it writes); ``--no-small`` leaves out the small export's cases;
``--markdown FILE`` writes the table there too.

``--baseline`` is the ``python/`` folder of another checkout (its own ``_core``); ``--build`` the ``python/`` folder
of this build (default: this checkout's; a copy keeps the measurement away from edits made while it runs). Every
process runs with the package's bytecode, as an installed package does (``PYTHONDONTWRITEBYTECODE`` is dropped from
the children's environment and one run warms ``__pycache__`` first). CPU is user + system time of the process tree.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Dict, List, Optional

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "tests/data/real/pod_PPS_100N_1.tsv"
#: The folder of exports: every text export of tests/data that analyses with default options.
FOLDER = [
    "real/pod_PPS_100N_1.tsv",
    "real/pod_PPS_60N_1.tsv",
    "real/cetr_umt2_HT-2n-6-4_2_001.csv",
    "real/cetr_umt2_HT-2n-6-4_2_002.csv",
    "formats/cof_only_pin_on_disc.csv",
    "formats/drag_rotational.csv",
    "formats/gram_force_ball_on_disc.csv",
    "formats/load_step_reciprocating.csv",
]

# a process tree timed from outside (wall time, CPU of the tree): bench_fixed_costs.WRAP
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_fixed_costs import WRAP  # noqa: E402

API = (
    "import sys, tribodyn as td\n"
    "for p in sys.argv[1:]:\n"
    "    kw = dict(fs=1000.0, names=['fx','fy','fz','i']) if p.endswith('.npy') else {}\n"
    "    with td.open_recording(p, **kw) as rec:\n"
    "        print(td.analyze(rec).headline)\n"
)


def env_for(pythonpath: str) -> Dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPATH"] = pythonpath
    return env


def wrapped(cmd: Any, pythonpath: str) -> Dict[str, Any]:
    """``cmd``: a command, or (command, environment variables to set)."""
    cmd, extra = (cmd[0], cmd[1]) if isinstance(cmd, tuple) else (cmd, {})
    p = subprocess.run([sys.executable, "-c", WRAP, json.dumps(cmd)], capture_output=True, text=True,
                       env={**env_for(pythonpath), **extra}, cwd=tempfile.gettempdir())  # fmt: skip
    out = dict(json.loads(p.stdout.strip().splitlines()[-1]))
    if out["rc"] not in (0, 3):  # 3: a file of a folder failed (the others' outputs are written)
        raise RuntimeError(f"{cmd} failed: {out['err']}")
    return out


def cli(files: List[str], out: Path, *extra: str) -> List[str]:
    cmd = [sys.executable, "-m", "tribodyn", "analyze", *files, "--out", str(out), "-q", "--overwrite", *extra]
    if files[0].endswith(".npy"):
        cmd += ["--fs", "1000", "--map", "fx=ch0,fy=ch1,fz=ch2,i=ch3"]
    return cmd


def cases(args: argparse.Namespace, builds: Dict[str, str], work: Path) -> Dict[str, Any]:
    """name -> (build, command) of every measurement."""
    folder = [str(ROOT / "tests/data" / f) for f in FOLDER]
    small = str(args.file)
    out: Dict[str, Any] = {}
    for b in builds:
        tag = b.replace(" ", "_")
        if not args.no_small:
            out[f"{b}|api small"] = [sys.executable, "-c", API, small]
            out[f"{b}|cli small"] = cli([small], work / f"{tag}-small")
        if not args.no_folder:
            out[f"{b}|api folder"] = [sys.executable, "-c", API, *folder]
            out[f"{b}|cli folder"] = cli(folder, work / f"{tag}-folder")
        for choice in () if args.no_small else ("none", "all"):
            out[f"{b}|cli small --figures {choice}"] = cli([small], work / f"{tag}-small-{choice}", "--figures", choice)
        if not args.no_folder:
            out[f"{b}|cli folder --figures none"] = cli(folder, work / f"{tag}-folder-none", "--figures", "none")
        if not args.no_long:
            h10 = str(args.long) if args.long else str(_h10(Path(args.data)))
            name = Path(args.long).name if args.long else "h10"
            out[f"{b}|api {name}"] = [sys.executable, "-c", API, h10]
            out[f"{b}|cli {name}"] = cli([h10], work / f"{tag}-h10")
            out[f"{b}|cli {name} --figures none"] = cli([h10], work / f"{tag}-h10-none", "--figures", "none")
            if b == "this build":  # the drawing workers whatever the load (the default starts none on busy cores)
                for n in args.workers:
                    out[f"{b}|cli {name}, {n} drawing workers"] = (
                        cli([h10], work / f"{tag}-h10-w{n}"),
                        {"TRIBODYN_DRAW_WORKERS": str(n)},
                    )
    return out


def _h10(data: Path) -> Path:
    sys.path.insert(0, str(ROOT / "benches"))
    from bench_fixed_costs import ensure_data  # type: ignore[import-not-found]

    return Path(ensure_data(data)["h10"])


def main(argv: Optional[List[str]] = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("file", nargs="?", default=str(SMALL))
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--baseline", help="PYTHONPATH of a baseline build (its python/ folder)")
    ap.add_argument("--data", default=str(Path(tempfile.gettempdir()) / "perf"), help="folder of the 10 h file")
    ap.add_argument("--no-long", action="store_true", help="leave out the 10 h recording")
    ap.add_argument("--no-folder", action="store_true", help="leave out the folder of exports")
    ap.add_argument("--workers", type=int, nargs="*", default=[1], help="TRIBODYN_DRAW_WORKERS of extra h10 cases")
    ap.add_argument("--build", default=str(ROOT / "python"), help="PYTHONPATH of this build (its python/ folder)")
    ap.add_argument("--long", help="the long .npy recording (default: --data's 10 h one, written if missing)")
    ap.add_argument("--no-small", action="store_true", help="leave out the small export's cases")
    ap.add_argument("--markdown", help="also write the table to this file")
    args = ap.parse_args(argv)
    builds = {"this build": args.build}
    if args.baseline:
        builds["baseline"] = args.baseline
    work = Path(tempfile.mkdtemp(prefix="bench_cli_"))
    try:
        todo = cases(args, builds, work)
        for b, path in builds.items():  # bytecode of every module the cases import, written once
            subprocess.run([sys.executable, "-c", "import tribodyn.app.jobs, tribodyn.app.cli, tribodyn.app.report, "
                            "tribodyn.app.figures"], env=env_for(path), check=True)  # fmt: skip
        load_before = os.getloadavg()
        runs: Dict[str, List[Dict[str, Any]]] = {k: [] for k in todo}
        for r in range(args.rounds):
            for key, cmd in todo.items():
                runs[key].append(wrapped(cmd, builds[key.split("|")[0]]))
                print(f"round {r + 1} {key:40s} {runs[key][-1]['seconds']:.2f} s", file=sys.stderr)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    lines = [
        f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {args.rounds} interleaved rounds, "
        f"{len(os.sched_getaffinity(0)) if hasattr(os, 'sched_getaffinity') else os.cpu_count()} usable cores; "
        f"load average before {tuple(round(x, 2) for x in load_before)}, "
        f"after {tuple(round(x, 2) for x in os.getloadavg())}",
        "",
        "| case | build | median wall | median CPU | walls |",
        "|---|---|---|---|---|",
    ]
    for key, v in runs.items():
        b, case = key.split("|")
        walls = [x["seconds"] for x in v]
        cpu = statistics.median(x["cpu"] for x in v)
        listed = ", ".join(f"{w:.2f}" for w in walls)
        lines.append(f"| {case} | {b} | {statistics.median(walls):.2f} s | {cpu:.2f} s | {listed} |")
    print("\n".join(lines))
    if args.markdown:
        Path(args.markdown).write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
