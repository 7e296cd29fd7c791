"""Issue 38 points 1, 3 and 4 on a many-core machine, in one call of a few minutes (stdlib only).

Prepared for the 16-core device machine, which starts bare and cannot
download anything: it runs from the repository's working tree, the built
extension ``python/tribodyn/_core.abi3.so`` and a wheelhouse ``.whl/``
(``bash benches/make_wheelhouse.sh``), both named in the call's ``carry``.

1. Environment: imports numpy, h5py, nptdms, dask, distributed and
   tribodyn._core; for each wheel of the wheelhouse whose distribution is not
   installed it installs the wheel (``pip install --no-index --no-deps
   --target``); if an import still fails it installs every pure-Python wheel
   too, then prints exactly what is missing (and skips the stages that need it).
2. Formats: ``benches/bench_formats.py --threads ...`` (issue 38 point 1).
3. Many recordings: ``benches/bench_many.py --workers ...`` (issue 38 point 4).
4. The command line against the API (issue 38 point 3; ``--skip cli`` leaves
   it out): a ``--cli-hours`` (10 h) ``.npy`` at 1 kHz is written (one
   ``--cli-block-hours`` block of the simulator, 1 h, repeated: the seams
   cost a few windows, the work is a 10 h recording's), then
   ``benches/bench_cli_export.py --long FILE --no-small --no-folder`` times
   whole processes, ``--cli-rounds`` interleaved rounds: the API, ``tribodyn
   analyze`` with its report as it runs by default (drawing workers on free
   cores), with ``--figures none``, and with ``TRIBODYN_DRAW_WORKERS`` = each of ``--cli-workers``
   (default 0: every figure drawn in the process). It needs matplotlib and
   pyarrow too, which the wheelhouse does not hold: where the machine lacks
   them the stage says so and is skipped (the others run). ``--cli-budget``
   seconds (default 110) of ``--budget`` are kept for it: the other stages
   end that much earlier.

Each stage runs with a deadline so the whole call ends inside ``--budget``
seconds (a stage cut short leaves its per-case lines in the log). Written to
``--out`` (default ``$OUT``): ``log.txt``, ``formats.md``, ``many.md``,
``cli.md`` and ``fragment.md`` (the markdown to paste into
benches/RESULTS.md); the fragment is printed last.

On the device (one call, ~6-8 minutes)::

    PYTHONUNBUFFERED=1 python3 benches/device_scaling.py --out $OUT

Here, end to end with small sizes::

    python benches/device_scaling.py --threads 1 2 --hours 0.2 --workers 1 2 --recordings 4 \\
        --many-hours 0.05 --cli-hours 0.2 --cli-block-hours 0.1 --cli-rounds 1 --out /tmp/device-out
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Dict, List, Optional

ROOT = Path(__file__).resolve().parent.parent
BENCHES = ROOT / "benches"
#: module -> what provides it
NEEDED = {
    "numpy": "numpy",
    "scipy": "scipy (the simulator's filters; on the device image, not in the wheelhouse: 35 MB)",
    "h5py": "h5py",
    "nptdms": "npTDMS",
    "dask": "dask",
    "distributed": "distributed",
    "tribodyn._core": "python/tribodyn/_core.abi3.so (carry it: it is built, not tracked)",
}
FOR_FORMATS = ("numpy", "scipy", "h5py", "nptdms", "tribodyn._core")
FOR_MANY = ("numpy", "scipy", "h5py", "dask", "distributed", "tribodyn._core")
#: What the command line's stage needs besides NEEDED's (not in the wheelhouse: the stage is skipped without them).
CLI_NEEDS = {
    "matplotlib": "matplotlib (the report's figures)",
    "pyarrow": "pyarrow (windows.parquet; a 40 MB wheel)",
}
FOR_CLI = ("numpy", "scipy", "h5py", "tribodyn._core", *CLI_NEEDS)
BINARY_KEEP = ("numpy", "h5py")  # keep the machine's own pair when it imports


class Log:
    def __init__(self, path: Path) -> None:
        self.f = open(path, "a", buffering=1)

    def __call__(self, msg: str) -> None:
        print(msg, flush=True)
        self.f.write(msg + "\n")


def env_with(site: List[Path]) -> Dict[str, str]:
    env = dict(os.environ)
    parts = [str(p) for p in site] + [str(ROOT / "python")]
    if env.get("PYTHONPATH"):
        parts.append(env["PYTHONPATH"])
    env["PYTHONPATH"] = os.pathsep.join(parts)
    env["PYTHONUNBUFFERED"] = "1"
    return env


def missing_modules(env: Dict[str, str], modules: Optional[List[str]] = None) -> Dict[str, str]:
    """module -> the error of importing it, for every module of ``modules`` (default NEEDED) that fails (all in
    one fresh process)."""
    code = (
        "import importlib, json, sys\n"
        "bad = {}\n"
        "for m in sys.argv[1:]:\n"
        "    try:\n"
        "        importlib.import_module(m)\n"
        "    except Exception as e:\n"
        "        bad[m] = f'{type(e).__name__}: {e}'\n"
        "print(json.dumps(bad))\n"
    )
    mods = list(NEEDED) if modules is None else modules
    r = subprocess.run([sys.executable, "-c", code, *mods], env=env, capture_output=True, text=True, check=False)
    import json

    try:
        out: Dict[str, str] = json.loads(r.stdout.strip().splitlines()[-1])
    except (IndexError, ValueError):
        return {m: r.stderr[-500:] for m in mods}
    return out


def dist_name(wheel: Path) -> str:
    return wheel.name.split("-", 1)[0].lower().replace("_", "-")


def installed(dist: str, env: Dict[str, str]) -> bool:
    code = "import importlib.metadata as m, sys\ntry:\n    m.version(sys.argv[1])\nexcept Exception:\n    sys.exit(1)\n"
    return subprocess.run([sys.executable, "-c", code, dist], env=env, check=False).returncode == 0


def pip_install(wheels: List[Path], target: Path, log: Log) -> bool:
    if not wheels:
        return True
    log(f"installing {len(wheels)} wheels into {target}: {' '.join(w.name for w in wheels)}")
    r = subprocess.run(
        [sys.executable, "-m", "pip", "install", "-q", "--no-index", "--no-deps", "--no-compile", "--no-cache-dir"]
        + ["--upgrade", "--target", str(target)]
        + [str(w) for w in wheels],
        capture_output=True,
        text=True,
        check=False,
    )
    if r.returncode != 0:
        log(f"pip failed ({r.returncode}): {(r.stdout + r.stderr)[-2000:]}")
    return r.returncode == 0


def prepare(wheels_dir: Path, log: Log) -> tuple:
    """Returns (env, missing) after installing what the wheelhouse can give."""
    site: List[Path] = []
    env = env_with(site)
    bad = missing_modules(env)
    log(f"imports before: {'all there' if not bad else 'missing ' + ', '.join(sorted(bad))}")
    wheels = sorted(wheels_dir.glob("*.whl")) if wheels_dir.is_dir() else []
    if bad and not wheels:
        log(f"no wheelhouse at {wheels_dir} (make one here with `bash benches/make_wheelhouse.sh` and carry it)")
    if bad and wheels:
        first = Path("/tmp/tribodyn-site")
        shutil.rmtree(first, ignore_errors=True)
        todo = [w for w in wheels if not installed(dist_name(w), env)]
        pip_install(todo, first, log)
        site = [first]
        env = env_with(site)
        bad = missing_modules(env)
        if bad:  # an installed distribution too old or broken: every pure-Python wheel first on the path
            log(f"still missing after the missing wheels: {', '.join(sorted(bad))}; adding every pure-Python wheel")
            second = Path("/tmp/tribodyn-site-all")
            shutil.rmtree(second, ignore_errors=True)
            keep = set() if any(m in bad for m in BINARY_KEEP) else set(BINARY_KEEP)
            pip_install([w for w in wheels if dist_name(w) not in keep], second, log)
            site = [second, first]
            env = env_with(site)
            bad = missing_modules(env)
    for m, err in sorted(bad.items()):
        log(f"MISSING {m} (from {NEEDED[m]}): {err}")
    return env, bad


def run_stage(name: str, cmd: List[str], env: Dict[str, str], deadline: float, log: Log) -> Optional[int]:
    left = deadline - time.monotonic()
    if left < 20:
        log(f"{name}: skipped, {left:.0f} s left of the budget")
        return None
    log(f"{name}: {' '.join(cmd)} (at most {left:.0f} s)")
    t0 = time.monotonic()
    p = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=ROOT)
    assert p.stdout is not None
    rc: Optional[int] = None
    try:
        import selectors

        sel = selectors.DefaultSelector()
        sel.register(p.stdout, selectors.EVENT_READ)
        while True:
            if time.monotonic() > deadline:
                p.kill()
                log(f"{name}: stopped at the budget's end")
                break
            if sel.select(timeout=1.0):
                line = p.stdout.readline()
                if not line:
                    break
                log(line.rstrip("\n"))
        rc = p.wait()
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    log(f"{name}: exit {rc} after {time.monotonic() - t0:.0f} s")
    return rc


#: Writes the command line's recording: ``--cli-block-hours`` of the simulator (bench_pipeline.write_recording), then
#: that block repeated into a (4, n) float64 ``.npy`` of ``--cli-hours`` (argv: folder, hours, block hours).
WRITE_LONG = r"""
import sys
from pathlib import Path
import numpy as np
sys.path.insert(0, sys.argv[1])
from bench_pipeline import FS, write_recording
folder, hours, block = Path(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
path = folder / f"cli_{hours:g}h.npy"
if not path.exists():
    one = np.load(write_recording(folder, "cli_block", min(block, hours) * 3600.0, raw=False, formats=("npy",))["npy"],
                  mmap_mode="r")
    n = int(round(hours * 3600.0 * FS))
    tmp = folder / "cli_long.tmp.npy"
    out = np.lib.format.open_memmap(tmp, mode="w+", dtype=np.float64, shape=(one.shape[0], n))
    for a in range(0, n, one.shape[1]):
        b = min(n, a + one.shape[1])
        out[:, a:b] = one[:, : b - a]
        out.flush()
    del out
    tmp.replace(path)
print(path)
"""


def cli_stage(args: argparse.Namespace, env: Dict[str, str], py: List[str], work: Path, out: Path, deadline: float,
              log: Log) -> bool:  # fmt: skip
    """Issue 38 point 3: the recording written, then bench_cli_export.py's API and CLI cases (cli.md); False when
    the stage failed (True when it is skipped for a missing module: cli.md says which)."""
    bad = missing_modules(env, list(FOR_CLI))
    if bad:
        for m, err in sorted(bad.items()):
            log(f"cli: MISSING {m} ({CLI_NEEDS.get(m) or NEEDED.get(m)}): {err}")
        why = "skipped, missing " + ", ".join(f"{m} ({CLI_NEEDS.get(m) or NEEDED.get(m)})" for m in sorted(bad))
        log(f"cli: {why}")
        (out / "cli.md").write_text(f"The command line's stage: {why}.\n")
        return True
    t0 = time.monotonic()
    try:
        made = subprocess.run(py + ["-c", WRITE_LONG, str(BENCHES), str(work), f"{args.cli_hours:g}",
                                    f"{args.cli_block_hours:g}"], env=env, capture_output=True, text=True,
                              timeout=max(1.0, deadline - time.monotonic() - 20.0), check=False)  # fmt: skip
    except subprocess.TimeoutExpired:
        log(f"cli: the recording was not written within the budget ({time.monotonic() - t0:.0f} s)")
        return False
    if made.returncode != 0:
        log(f"cli: the recording was not written: {(made.stdout + made.stderr)[-1500:]}")
        return False
    long = made.stdout.strip().splitlines()[-1]
    log(f"cli: {long} ({Path(long).stat().st_size / 1e9:.2f} GB) written in {time.monotonic() - t0:.0f} s")
    cmd = py + [str(BENCHES / "bench_cli_export.py"), "--long", long, "--no-small", "--no-folder"]
    cmd += ["--rounds", str(args.cli_rounds), "--markdown", str(out / "cli.md")]
    cmd += ["--workers", *map(str, args.cli_workers)]
    return run_stage("cli", cmd, env, deadline, log) == 0


def main(argv: List[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2, 4, 8, 16])
    ap.add_argument("--hours", type=float, default=4.0, help="formats: length of the recording (default 4 h)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--formats", nargs="+", default=None, help="bench_formats.py --formats (default its own)")
    ap.add_argument("--workers", type=int, nargs="+", default=[2, 4, 8, 16])
    ap.add_argument("--recordings", type=int, default=32)
    ap.add_argument("--many-hours", type=float, default=1 / 3, help="many: length of each recording (20 min)")
    ap.add_argument("--many-repeat", type=int, default=3)
    ap.add_argument("--budget", type=float, default=470.0, help="seconds for the whole call (default 470)")
    ap.add_argument("--wheels", type=Path, default=ROOT / ".whl")
    ap.add_argument("--out", type=Path, default=Path(os.environ.get("OUT") or ROOT / "device-out"))
    ap.add_argument("--cli-hours", type=float, default=10.0, help="cli: length of the recording (default 10 h)")
    ap.add_argument("--cli-block-hours", type=float, default=1.0, help="cli: the simulated block repeated (1 h)")
    ap.add_argument("--cli-rounds", type=int, default=3)
    ap.add_argument("--cli-workers", type=int, nargs="*", default=[0], help="cli: TRIBODYN_DRAW_WORKERS of extra cases")
    ap.add_argument("--cli-budget", type=float, default=110.0, help="cli: seconds of --budget kept for it (110)")
    ap.add_argument("--skip", nargs="+", choices=("formats", "many", "cli"), default=[])
    args = ap.parse_args(argv)
    end = time.monotonic() + args.budget
    # the command line's stage comes last, with --cli-budget seconds kept for it (and what the others leave)
    deadline = end - (0.0 if "cli" in args.skip else min(args.cli_budget, 0.5 * args.budget))
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    log = Log(out / "log.txt")
    log(
        f"device_scaling: {platform.node()} {platform.machine()}, {os.cpu_count()} CPUs, "
        f"Python {platform.python_version()} ({sys.executable}); load {os.getloadavg()[0]:.1f}; "
        f"args {' '.join(argv)}"
    )
    env, bad = prepare(args.wheels, log)
    work = Path(os.environ.get("TMPDIR") or "/tmp")
    py = [sys.executable, "-u"]
    stages = []
    if "formats" not in args.skip:
        if any(m in bad for m in FOR_FORMATS):
            log("formats: skipped, missing " + ", ".join(m for m in FOR_FORMATS if m in bad))
        else:
            cmd = py + [str(BENCHES / "bench_formats.py"), "--threads", *map(str, args.threads)]
            cmd += ["--hours", f"{args.hours:g}", "--rounds", str(args.rounds), "--repeat", str(args.repeat)]
            cmd += ["--dir", str(work), "--markdown", str(out / "formats.md")]
            if args.formats:
                cmd += ["--formats", *args.formats]
            # leave the many-recordings stage about 40 % of what is left
            share = 1.0 if "many" in args.skip else 0.6
            run_stage("formats", cmd, env, time.monotonic() + share * (deadline - time.monotonic()), log)
            stages.append("formats.md")
    if "many" not in args.skip:
        if any(m in bad for m in FOR_MANY):
            log("many: skipped, missing " + ", ".join(m for m in FOR_MANY if m in bad))
        else:
            cmd = py + [str(BENCHES / "bench_many.py"), "--recordings", str(args.recordings)]
            cmd += ["--hours", f"{args.many_hours:.6g}", "--current", "--repeat", str(args.many_repeat)]
            cmd += ["--workers", *map(str, args.workers), "--no-write", "--dir", str(work)]
            cmd += ["--markdown", str(out / "many.md")]
            run_stage("many", cmd, env, deadline, log)
            stages.append("many.md")
    cli_ok = True
    if "cli" not in args.skip:
        cli_ok = cli_stage(args, env, py, work, out, end, log)
        stages.append("cli.md")
    parts = [
        f"<!-- device_scaling.py on {time.strftime('%Y-%m-%d %H:%M')} UTC, {os.cpu_count()} CPUs, "
        f"args: {' '.join(argv) or '(defaults)'} -->",
    ]
    for s in stages:
        f = out / s
        parts.append(f.read_text() if f.exists() else f"({s}: not written; the stage failed or ran out of time)\n")
    if bad:
        parts.append("Missing on this machine: " + ", ".join(f"{m} ({NEEDED[m]})" for m in sorted(bad)) + "\n")
    text = "\n".join(parts)
    (out / "fragment.md").write_text(text)
    print("\n===== fragment.md =====\n" + text, flush=True)
    return 0 if not bad and cli_ok and all((out / s).exists() for s in stages) else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
