"""Fixed costs of the API and the command line (issue 25), side by side with a baseline build.

Every measurement runs in a fresh process; the cases (and the two builds,
this checkout and ``--baseline``, a tree whose ``python/`` holds an older
``tribodyn`` package with the same ``_core``) are interleaved round by
round, so that both see the same load; medians. The load average is
recorded before and after.

Data: ``h1.npy`` and ``h10.npy`` ((4, n) float64, fx fy fz i at 1 kHz,
``bench_pipeline.write_recording``) in ``--data`` (written when missing),
and ``h10.tdms`` (the same samples, float64, 10 s segments, written from
``h10.npy`` into ``--data`` when missing).

Measures (each target of issue 25):

* ``api``: ``open_recording`` + ``analyze`` with default options (the call
  timed after ``import tribodyn`` and the lazy ``tribodyn.analyze``), its
  peak RSS; 1 h and 10 h ``.npy``, 10 h TDMS;
* ``yardstick``: ``fy @ fz`` over the 10 h in RAM (one BLAS thread);
* ``tiled``: window = hop = 2 s, threads 1 and 2, 10 h ``.npy``, with a
  digest of the table (every column) to check the tables are bitwise equal;
* ``api-process`` and ``cli``: the whole process (``python -c`` that imports,
  opens, analyses and reads the headline; ``python -m tribodyn analyze FILE
  --out DIR``), wall time and peak RSS of the process tree (the CLI's figure
  child included: ``RUSAGE_CHILDREN`` of a wrapper);
* ``demo``: ``python -m tribodyn demo --out DIR``;
* ``import``: ``import tribodyn`` in a fresh process.

Every process runs with the package's bytecode, as an installed package does
(``PYTHONDONTWRITEBYTECODE`` is dropped from the children's environment and
one import warms ``__pycache__`` first).

Usage::

    python benches/bench_fixed_costs.py --data /tmp/perf --baseline /tmp/base --rounds 5
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Dict, List, Optional

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
FS = 1000.0
NAMES = ["fx", "fy", "fz", "i"]

CHILD = r"""
import json, os, resource, sys, time
PHASES = ("prepass", "find_lag", "run", "finish", "settle")  # the steps of tribodyn.pipeline.analyze._analyze_body
job = json.loads(sys.argv[1])
kind = job["kind"]
out = {}
if kind == "import":
    t = time.perf_counter()
    import tribodyn
    out["seconds"] = time.perf_counter() - t
    out["heavy"] = sorted(m for m in ("scipy", "matplotlib", "pandas", "bokeh") if m in sys.modules)
elif kind == "yardstick":
    import numpy as np
    arr = np.load(job["path"], mmap_mode="r")
    fy, fz = np.array(arr[1]), np.array(arr[2])
    ts = []
    for _ in range(7):
        t = time.perf_counter(); fy @ fz; ts.append(time.perf_counter() - t)
    out["seconds"] = sorted(ts)[3]
    out["bytes"] = fy.nbytes + fz.nbytes
elif kind == "readfloor":
    # What any analysis of every channel pays before it computes: the file's samples copied out of the
    # page cache with pread (as the kernel reads), 8 MiB at a time, on two threads.
    from concurrent.futures import ThreadPoolExecutor
    size, block = os.path.getsize(job["path"]), 1 << 23
    def part(k):
        fd = os.open(job["path"], os.O_RDONLY); buf = bytearray(block); got = 0
        try:
            for at in range(k * block, size, 2 * block):
                got += os.preadv(fd, [buf], at)
        finally:
            os.close(fd)
        return got
    ts = []
    for _ in range(5):
        t = time.perf_counter()
        with ThreadPoolExecutor(2) as ex:
            assert sum(ex.map(part, (0, 1))) == size
        ts.append(time.perf_counter() - t)
    out["seconds"] = sorted(ts)[2]
elif kind in ("api", "tiled"):
    import hashlib
    import numpy as np
    import tribodyn as td
    td.analyze, td.open_recording  # the lazy namespace: analyze's module imported before the clock
    p = job["path"]
    kw = dict(fs=1000.0, names=["fx", "fy", "fz", "i"]) if p.endswith(".npy") else {}
    opts = dict(window=2.0, hop=2.0) if kind == "tiled" else {}
    if job.get("threads"):
        opts["threads"] = job["threads"]
    # the profile: wall time of the analysis' steps (the functions analyze's module calls by name)
    import functools, importlib
    phases = {}
    try:  # the orchestration's module (tribodyn.analyze before the package's layers)
        mod = importlib.import_module("tribodyn.pipeline.analyze")
    except ImportError:
        mod = importlib.import_module("tribodyn.analyze")
    spans = []  # (start, end) of every timed step: find_lag may run beside the pre-pass (on its own thread)
    def timed(name, f):
        @functools.wraps(f)
        def g(*a, **k):
            t0 = time.perf_counter()
            try:
                return f(*a, **k)
            finally:
                t1 = time.perf_counter()
                phases[name] = phases.get(name, 0.0) + t1 - t0
                spans.append((name, t0, t1))
        return g
    def union(items):
        total, end = 0.0, -1e300
        for a, b in sorted(items):
            if b > end:
                total += b - max(a, end)
                end = b
        return total
    for name in PHASES:
        if callable(getattr(mod, name, None)):
            setattr(mod, name, timed(name, getattr(mod, name)))
    before = set(sys.modules)
    t = time.perf_counter()
    rec = td.open_recording(p, **kw)
    phases["open_recording"] = time.perf_counter() - t
    spans.append(("open_recording", t, t + phases["open_recording"]))
    with rec:
        res = td.analyze(rec, **opts)
    out["seconds"] = time.perf_counter() - t
    phases["prepass+find_lag"] = union([(a, b) for k, a, b in spans if k in ("prepass", "find_lag")])
    phases["other"] = out["seconds"] - union([(a, b) for _, a, b in spans])
    out["phases"] = phases
    out["imported"] = sorted(set(sys.modules) - before)
    out["headline"] = str(res.headline)
    out["windows"] = len(res)
    h = hashlib.sha256()
    for k in sorted(res.table):
        v = np.asarray(res.table[k])
        h.update(k.encode()); h.update(v.astype(str).tobytes() if v.dtype == object else v.tobytes())
    out["table"] = h.hexdigest()[:16]
else:
    raise SystemExit(f"unknown job {kind}")
ru = resource.getrusage(resource.RUSAGE_SELF)
out["peak_rss_mb"] = ru.ru_maxrss / 1024
out["cpu"] = ru.ru_utime + ru.ru_stime
print(json.dumps(out))
"""

#: A process tree timed from outside: wall time and the largest RSS of the tree.
WRAP = r"""
import json, resource, subprocess, sys, time
cmd = json.loads(sys.argv[1])
t = time.perf_counter()
p = subprocess.run(cmd, capture_output=True, text=True)
wall = time.perf_counter() - t
ru = resource.getrusage(resource.RUSAGE_CHILDREN)
print(json.dumps({"seconds": wall, "rc": p.returncode, "err": p.stderr[-2000:], "peak_rss_mb": ru.ru_maxrss / 1024,
                  "cpu": ru.ru_utime + ru.ru_stime}))
"""

API_PROCESS = (
    "import sys, tribodyn as td; p = sys.argv[1]; "
    "kw = dict(fs=1000.0, names=['fx','fy','fz','i']) if p.endswith('.npy') else {}; "
    "rec = td.open_recording(p, **kw); res = td.analyze(rec); print(res.headline)"
)


def env_for(build: Optional[str], **extra: str) -> Dict[str, str]:
    # As an installed package runs: with its bytecode (pip compiles it at install; a source tree writes
    # __pycache__ on the first import, :func:`run` warms it). A PYTHONDONTWRITEBYTECODE=1 of the shell
    # would compile every module of the package at each start instead (about 60 ms more per process).
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env.update(extra)
    if build:
        env["PYTHONPATH"] = str(Path(build) / "python")
    return env


def child(job: Dict[str, Any], build: Optional[str], **extra: str) -> Dict[str, Any]:
    p = subprocess.run([sys.executable, "-c", CHILD, json.dumps(job)], capture_output=True, text=True,
                       env=env_for(build, **extra), cwd=tempfile.gettempdir())  # fmt: skip
    if p.returncode:
        raise RuntimeError(f"{job} failed: {p.stderr[-3000:]}")
    return dict(json.loads(p.stdout.strip().splitlines()[-1]))


def wrapped(cmd: List[str], build: Optional[str]) -> Dict[str, Any]:
    p = subprocess.run([sys.executable, "-c", WRAP, json.dumps(cmd)], capture_output=True, text=True,
                       env=env_for(build), cwd=tempfile.gettempdir())  # fmt: skip
    out = dict(json.loads(p.stdout.strip().splitlines()[-1]))
    if out["rc"]:
        raise RuntimeError(f"{cmd} failed: {out['err']}")
    return out


def ensure_data(data: Path) -> Dict[str, Path]:
    data.mkdir(parents=True, exist_ok=True)
    paths = {"h1": data / "h1.npy", "h10": data / "h10.npy", "h10tdms": data / "h10.tdms"}
    sys.path.insert(0, str(HERE))
    from bench_pipeline import write_recording  # type: ignore[import-not-found]

    for name, secs in (("h1", 3600.0), ("h10", 36000.0)):
        if not paths[name].exists():
            write_recording(data, name, secs, raw=False, formats=("npy",))
    if not paths["h10tdms"].exists():
        import numpy as np
        from tribodyn.io.writers import save_tdms

        arr = np.load(paths["h10"], mmap_mode="r")
        save_tdms(paths["h10tdms"], {r: arr[j] for j, r in enumerate(NAMES)}, FS, segment_samples=10_000)
    return paths


def cli_cmd(path: Path, out: Path) -> List[str]:
    cmd = [sys.executable, "-m", "tribodyn", "analyze", str(path), "--out", str(out), "-q", "--overwrite"]
    if path.suffix == ".npy":
        cmd += ["--fs", "1000", "--map", "fx=ch0,fy=ch1,fz=ch2,i=ch3"]
    return cmd


def run(args: argparse.Namespace) -> Dict[str, Any]:
    paths = ensure_data(Path(args.data))
    builds: Dict[str, Optional[str]] = {"this": None}
    if args.baseline:
        builds["baseline"] = args.baseline
    tmp = Path(tempfile.mkdtemp(prefix="tribodyn-fixed-"))
    cases: Dict[str, Any] = {}
    for b in builds:
        cases[f"{b}|api h1"] = lambda b=b: child({"kind": "api", "path": str(paths["h1"])}, builds[b])
        cases[f"{b}|api h10"] = lambda b=b: child({"kind": "api", "path": str(paths["h10"])}, builds[b])
        cases[f"{b}|api h10 tdms"] = lambda b=b: child({"kind": "api", "path": str(paths["h10tdms"])}, builds[b])
        for th in (1, 2):
            cases[f"{b}|tiled h10 t{th}"] = lambda b=b, th=th: child(
                {"kind": "tiled", "path": str(paths["h10"]), "threads": th}, builds[b]
            )
        for key in ("h10", "h10tdms"):
            cases[f"{b}|api-process {key}"] = lambda b=b, key=key: wrapped(
                [sys.executable, "-c", API_PROCESS, str(paths[key])], builds[b]
            )
            cases[f"{b}|cli {key}"] = lambda b=b, key=key: wrapped(cli_cmd(paths[key], tmp / f"{b}-{key}"), builds[b])
        cases[f"{b}|import"] = lambda b=b: child({"kind": "import"}, builds[b])
        if not args.no_demo:
            cases[f"{b}|demo"] = lambda b=b: wrapped(
                [sys.executable, "-m", "tribodyn", "demo", "--out", str(tmp / f"{b}-demo"), "-q", "--overwrite"],
                builds[b],
            )
    cases["yardstick"] = lambda: child({"kind": "yardstick", "path": str(paths["h10"])}, None,
                                       OPENBLAS_NUM_THREADS="1")  # fmt: skip
    cases["readfloor"] = lambda: child({"kind": "readfloor", "path": str(paths["h10"])}, None)
    got: Dict[str, List[Dict[str, Any]]] = {k: [] for k in cases}
    for b in builds:  # bytecode of every module the cases import (the CLI's output step included)
        subprocess.run([sys.executable, "-c", "import tribodyn.app.jobs, tribodyn.app.cli, tribodyn.app.report"],
                       env=env_for(builds[b]), check=True, cwd=tempfile.gettempdir())  # fmt: skip
    load_before = os.getloadavg()
    t0 = time.time()
    for r in range(args.rounds):
        for k, fn in cases.items():
            if k.endswith("|demo") and r >= args.demo_rounds:
                continue
            got[k].append(fn())
            print(f"round {r + 1} {k:28s} {got[k][-1]['seconds']:.3f} s", file=sys.stderr)
    out = {
        "when": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(t0)),
        "load_before": load_before,
        "load_after": os.getloadavg(),
        "rounds": args.rounds,
        "builds": builds,
        "baseline_label": args.baseline_label,
        "same_core": same_core(args.baseline) if args.baseline else None,
        "runs": got,
    }
    return out


def same_core(tree: str) -> bool:
    """Whether the baseline's ``_core`` is this build's, byte for byte (its Python alone differs then)."""
    import tribodyn

    def digest(pkg: Path) -> str:
        return "".join(hashlib.sha256(f.read_bytes()).hexdigest() for f in sorted(pkg.glob("_core*.so")))

    return digest(Path(tribodyn.__file__).parent) == digest(Path(tree) / "python" / "tribodyn")


def med(runs: List[Dict[str, Any]], key: str = "seconds") -> float:
    return float(statistics.median(r[key] for r in runs))


def report(o: Dict[str, Any]) -> str:
    g = o["runs"]
    has_base = "baseline" in o["builds"]
    yard = med(g["yardstick"])

    def fmt(x: float) -> str:
        return f"{x * 1e3:.0f} ms" if x < 1 else f"{x:.2f} s"

    def both(k: str, key: str = "seconds", f: Any = fmt) -> str:
        s = f(med(g[f"this|{k}"], key))
        if has_base:
            s += f" (baseline {f(med(g[f'baseline|{k}'], key))})"
        return s

    rows = []

    def row(target: str, wanted: str, measured: str, ok: bool) -> None:
        rows.append(f"| {target} | {wanted} | {measured} | {'met' if ok else '**missed**'} |")

    a1, a10 = med(g["this|api h1"]), med(g["this|api h10"])
    row("`.npy` 10 h, default options: API time vs `fy @ fz` over 10 h", "<= 4x",
        f"{a10 / yard:.1f}x ({fmt(a10)} / {fmt(yard)})" + (f"; baseline {med(g['baseline|api h10']) / yard:.1f}x"
                                                          if has_base else ""), a10 <= 4 * yard)  # fmt: skip
    if "readfloor" in g:
        floor = med(g["readfloor"])
        rows.append(f"| (floor: the whole 10 h file read out of the page cache with pread, 2 threads) | | "
                    f"{fmt(floor)} = {floor / yard:.1f}x the yardstick | - |")  # fmt: skip
    base_ratio = f"; baseline {med(g['baseline|api h10']) / med(g['baseline|api h1']):.2f}" if has_base else ""
    row("`.npy` default options: time 10 h / 1 h", ">= 7", f"{a10 / a1:.2f} ({fmt(a1)} -> {fmt(a10)}){base_ratio}",
        a10 / a1 >= 7)  # fmt: skip
    for key, name in (("h10", ".npy"), ("h10tdms", "TDMS")):
        c, a = med(g[f"this|cli {key}"]), med(g[f"this|api-process {key}"])
        extra = ""
        if has_base:
            extra = (f"; baseline CLI {fmt(med(g[f'baseline|cli {key}']))}, "
                     f"API {fmt(med(g[f'baseline|api-process {key}']))}")  # fmt: skip
        row(f"CLI with its report, 10 h {name}: whole process vs the API's whole process", "<= API + 1.5 s",
            f"{fmt(c)} vs {fmt(a)} (+{c - a:.2f} s){extra}", c <= a + 1.5)  # fmt: skip
        rss = max(r["peak_rss_mb"] for r in g[f"this|cli {key}"])
        brss = f" (baseline {max(r['peak_rss_mb'] for r in g[f'baseline|cli {key}']):.0f} MB)" if has_base else ""
        row(f"CLI peak RSS, 10 h {name} (largest process of the tree)", "<= 250 MB", f"{rss:.0f} MB{brss}", rss <= 250)
    if "this|demo" in g:
        d = med(g["this|demo"])
        row("`tribodyn demo` (whole process)", "<= 10 s", both("demo"), d <= 10)
    imp = med(g["this|import"])
    heavy = sorted({m for r in g["this|import"] for m in r.get("heavy", [])})
    row("`import tribodyn`", "<= 150 ms, none of SciPy, Matplotlib, pandas, Bokeh",
        both("import") + (f"; imports {', '.join(heavy)}" if heavy else ""), imp <= 0.150 and not heavy)  # fmt: skip
    t1, t2 = med(g["this|tiled h10 t1"]), med(g["this|tiled h10 t2"])
    bt = ""
    if has_base:
        bt = f"; baseline {med(g['baseline|tiled h10 t1']) / med(g['baseline|tiled h10 t2']):.2f}x"
    row("1 -> 2 threads, 10 h `.npy`, window = hop = 2 s", ">= 1.7x", f"{t1 / t2:.2f}x ({fmt(t1)} -> {fmt(t2)}){bt}",
        t1 / t2 >= 1.7)  # fmt: skip
    td = med(g["this|api h10 tdms"])
    row("TDMS (float64, 10 s segments) vs `.npy`, 10 h, default options", "<= 2x", f"{td / a10:.2f}x ({fmt(td)})",
        td <= 2 * a10)  # fmt: skip
    r1 = max(r["peak_rss_mb"] for r in g["this|api h1"])
    r10 = max(r["peak_rss_mb"] for r in g["this|api h10"])
    row("API peak RSS 1 h -> 10 h (`.npy`, default options)", "within 10 %",
        f"{r1:.0f} -> {r10:.0f} MB ({100 * (r10 / r1 - 1):+.1f} %)", abs(r10 / r1 - 1) <= 0.10)  # fmt: skip
    tables = {}
    for k in ("tiled h10 t1", "tiled h10 t2"):
        for b in o["builds"]:
            tables[f"{b} {k}"] = {r["table"] for r in g[f"{b}|{k}"]}
    for k in ("api h1", "api h10", "api h10 tdms"):
        for b in o["builds"]:
            tables[f"{b} {k}"] = {r["table"] for r in g[f"{b}|{k}"]}
    same_tiled = len(set().union(*(v for k, v in tables.items() if "tiled" in k))) == 1
    same_default = all(
        len(set().union(*(v for k, v in tables.items() if k.endswith(c)))) == 1 for c in ("api h1", "api h10")
    )
    row("tables bitwise unchanged (digest of every column): threads 1 and 2, this build and the baseline; "
        "default options this build and the baseline", "identical",
        f"tiled: {'identical' if same_tiled else 'DIFFERENT'}; default: {'identical' if same_default else 'DIFFERENT'}",
        same_tiled and same_default)  # fmt: skip
    heads = {b: {r["headline"] for r in g[f"{b}|api h10"]} for b in o["builds"]}
    imported = sorted({m for r in g["this|api h1"] for m in r["imported"] if not m.startswith("_")})
    lines = [
        f"`python benches/bench_fixed_costs.py --rounds {o['rounds']}`, run {o['when']}; "
        f"{o['rounds']} interleaved rounds of fresh processes (with the package's bytecode, as installed), medians"
        + (
            f"; `baseline` = {o.get('baseline_label') or 'the Python package of ' + str(o['builds']['baseline'])}"
            + {True: " with the same `_core`", False: " with its own `_core`"}.get(o.get("same_core"), "")
            if has_base
            else ""
        )
        + ".",  # fmt: skip
        "",
        f"Load average before / after: {', '.join(f'{x:.2f}' for x in o['load_before'])} / "
        f"{', '.join(f'{x:.2f}' for x in o['load_after'])} (2 cores shared with other jobs: the figures are noisy).",
        "",
        "| target | wanted | measured | |",
        "|---|---|---|---|",
        *rows,
        "",
        "Headline, 10 h `.npy`: " + "; ".join(f"{b}: {', '.join(sorted(h))}" for b, h in heads.items()),
        "",
        f"Modules the first `analyze` call imports (1 h `.npy`): {', '.join(imported) or 'none'}.",
        "",
        "Wall time (and CPU time, user + system of the process tree, which the other jobs on the machine "
        "disturb less):",
        "",
        "| measurement | this build | " + ("baseline |" if has_base else "") + " runs (this build) | peak RSS |",
        "|---|---|" + ("---|" if has_base else "") + "---|---|",
    ]
    for k in sorted({k.split("|", 1)[1] for k in g if "|" in k}):
        cells = [f"{fmt(med(g[f'this|{k}']))} (CPU {fmt(med(g[f'this|{k}'], 'cpu'))})"]
        if has_base:
            cells.append(f"{fmt(med(g[f'baseline|{k}']))} (CPU {fmt(med(g[f'baseline|{k}'], 'cpu'))})")
        runs = ", ".join(fmt(r["seconds"]) for r in g[f"this|{k}"])
        rss = max(r["peak_rss_mb"] for r in g[f"this|{k}"])
        lines.append(f"| {k} | " + " | ".join(cells) + f" | {runs} | {rss:.0f} MB |")
    lines.append(f"| yardstick `fy @ fz`, 10 h in RAM, one BLAS thread | {fmt(yard)} | " + ("|" if has_base else "")
                 + f" {', '.join(fmt(r['seconds']) for r in g['yardstick'])} | |")  # fmt: skip
    return "\n".join(lines) + "\n" + profile(g)


def profile(g: Dict[str, List[Dict[str, Any]]]) -> str:
    """The profile of the API's misses: wall time of each step of the call (this build; medians)."""
    keys = [k for k in ("api h1", "api h10", "api h10 tdms", "tiled h10 t1", "tiled h10 t2") if f"this|{k}" in g]
    steps = ["open_recording", "prepass", "find_lag", "prepass+find_lag", "run", "finish", "settle", "other"]
    what = {"open_recording": "opening (the friction axis chosen from a sample)",
            "prepass": "pre-pass (its bounded sample: contact, tare, motion)",
            "find_lag": "find_lag (IV lag; on a thread beside the pre-pass where the source allows)",
            "prepass+find_lag": "pre-pass and find_lag together (the union of their spans)",
            "run": "the windows' kernel (reads the file)", "finish": "finish (estimators, gate, table)",
            "settle": "settle (headline and its bootstrap)", "other": "the rest"}  # fmt: skip
    out = ["", "Profile of the API call (this build, wall time of each step, medians of the runs; "
           "`tribodyn.analyze`'s steps timed by name in the child):", "",
           "| step | " + " | ".join(keys) + " |", "|---|" + "---|" * len(keys)]  # fmt: skip
    for st in steps:
        cells = [f"{1e3 * statistics.median(r['phases'].get(st, 0.0) for r in g[f'this|{k}']):.0f} ms" for k in keys]
        out.append(f"| {what[st]} | " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


def main(argv: Optional[List[str]] = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=os.path.join(tempfile.gettempdir(), "perf"))
    ap.add_argument("--baseline", help="a tree whose python/ holds the baseline tribodyn package (with a _core)")
    ap.add_argument("--baseline-label", help="what the baseline is, for the report (e.g. a commit)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--demo-rounds", type=int, default=3)
    ap.add_argument("--no-demo", action="store_true")
    ap.add_argument("--json", help="save the raw runs")
    ap.add_argument("--render", help="render a --json file of an earlier run")
    ap.add_argument("--results", action="store_true", help="write the section into benches/RESULTS.md")
    args = ap.parse_args(argv)
    o = json.loads(Path(args.render).read_text()) if args.render else run(args)
    if args.json:
        Path(args.json).write_text(json.dumps(o, indent=1))
    text = report(o)
    print(text)
    if args.results:
        sys.path.insert(0, str(HERE))
        from _results import write_section  # type: ignore[import-not-found]

        write_section("Fixed costs: the API and the command line (issue 25)", text)


if __name__ == "__main__":
    main()
