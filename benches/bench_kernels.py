"""Benchmarks of the tribodyn kernels against the NumPy reference and scipy.

Runs every kernel side by side in one process, at one analysis window
(2 000 samples), one hour at 1 kHz (3.6e6) and ten hours (3.6e7), repeats
each measurement, and writes the median times, their ratios and the
performance targets (met / missed) to ``benches/RESULTS.md``.

    python benches/bench_kernels.py            # full run (about 10 minutes)
    python benches/bench_kernels.py --quick    # 2 000 and 3.6e6 only, fewer repeats

Run it on an otherwise idle machine: with two cores, any other process moves
the numbers (the load average is recorded before and after).

The ``x @ y`` yardstick runs with ONE BLAS thread (threadpoolctl, or
OPENBLAS_NUM_THREADS=1 etc. set below before numpy is imported when
threadpoolctl is missing). See benches/README.md for OPENBLAS_CORETYPE.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import gc
import json
import os
import platform
import re
import resource
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional

try:
    import threadpoolctl
except ImportError:  # pin BLAS to one thread for the whole run instead
    threadpoolctl = None
    for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[_v] = "1"

import numpy as np  # noqa: E402
import scipy  # noqa: E402
import scipy.signal as ss  # noqa: E402
import scipy.stats as st  # noqa: E402
import tribodyn as tb  # noqa: E402
import tribodyn.kernels.reference as ref  # noqa: E402
from tribodyn import _core  # noqa: E402

HERE = Path(__file__).resolve().parent
FS = 1000.0
SIZES = {"window": 2_000, "1 h": 3_600_000, "10 h": 36_000_000}
WINDOW_LAG = 500  # +-500 lags on a 2 s window
RECORD_LAG = 1000  # +-1000 lags on a whole record
REF_BUDGET_S = 60.0  # skip a reference call predicted to take longer


# ----------------------------------------------------------------- timing


@dataclass
class Row:
    kernel: str
    size: str
    n: int
    impl: str
    times: list[float] = field(default_factory=list)
    note: str = ""

    @property
    def median(self) -> float:
        return statistics.median(self.times) if self.times else float("nan")

    @property
    def best(self) -> float:
        return min(self.times) if self.times else float("nan")


def one_blas_thread():
    """Context that limits BLAS to one thread (a no-op when pinned by env)."""
    if threadpoolctl is not None:
        return threadpoolctl.threadpool_limits(limits=1, user_api="blas")
    import contextlib

    return contextlib.nullcontext()


def calls_per_sample(f: Callable[[], object], min_time: float) -> int:
    """How many calls make one timed sample of at least ``min_time`` s."""
    t0 = time.perf_counter()
    f()
    dt = time.perf_counter() - t0
    if dt >= min_time:
        return 1
    return max(1, int(min_time / max(dt, 1e-7)))


class OneBlasThread:
    """Marks a callable to be timed inside :func:`one_blas_thread`, entered
    outside the timed loop (entering it costs about a millisecond)."""

    def __init__(self, f: Callable[[], object]) -> None:
        self.f = f

    def __call__(self) -> object:
        return self.f()


def bench(rows: list[Row], impls: dict[str, Callable[[], object]], repeats: int, min_time: float) -> None:
    """Times every implementation, interleaved round by round so that a
    passing disturbance hits all of them alike; one warm-up call each."""
    import contextlib

    def ctx(f):
        return one_blas_thread() if isinstance(f, OneBlasThread) else contextlib.nullcontext()

    number = {}
    for name, f in impls.items():
        with ctx(f):
            number[name] = calls_per_sample(f, min_time)  # also warms up
    for _ in range(repeats):
        for row in rows:
            f = impls[row.impl]
            k = number[row.impl]
            gc.collect()
            with ctx(f):
                t0 = time.perf_counter()
                for _ in range(k):
                    f()
                row.times.append((time.perf_counter() - t0) / k)


# ----------------------------------------------------------------- data


def signals(n: int, seed: int = 0) -> np.ndarray:
    """(3, n) forces like the paper's rig: fz with the lamella line, fy about
    0.15 fz, fx loosely coupled, offsets as from a DC-coupled amplifier."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FS
    out = np.empty((3, n))
    out[2] = 2.5 + np.sin(2 * np.pi * 100.0 * t) + 0.3 * np.sin(2 * np.pi * 4.17 * t) + 0.2 * rng.standard_normal(n)
    out[1] = 0.4 + 0.15 * (out[2] - 2.5) + 0.05 * rng.standard_normal(n)
    out[0] = 0.1 * (out[2] - 2.5) + 0.3 * rng.standard_normal(n)
    return out


def scipy_xcorr(x: np.ndarray, y: np.ndarray, max_lag: int) -> np.ndarray:
    """Eq. (1) with scipy: correlate(method="fft") of the centred signals,
    denominators from prefix sums of squares."""
    n = x.size
    xc = x - x.mean()
    yc = y - y.mean()
    full = ss.correlate(yc, xc, mode="full", method="fft")  # lag j at index j + n - 1
    num = full[n - 1 - max_lag : n + max_lag]
    px = np.concatenate(([0.0], np.cumsum(xc * xc)))  # sum_{i<k} xc_i^2
    py = np.concatenate(([0.0], np.cumsum(yc * yc)))
    j = np.arange(-max_lag, max_lag + 1)
    a = np.abs(j)
    # j >= 0: S_xx = sum_{i<n-j} xc^2, S_yy = sum_{i>=j} yc^2; mirrored for j < 0.
    sxx = np.where(j >= 0, px[n - a], px[n] - px[a])
    syy = np.where(j >= 0, py[n] - py[a], py[n - a])
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.clip(num / np.sqrt(sxx * syy), -1.0, 1.0)


# ----------------------------------------------------------------- kernels


def bench_linfit(sizes: dict[str, int], repeats: int, min_time: float, log) -> list[Row]:
    rows: list[Row] = []
    for label, n in sizes.items():
        d = signals(n, 1)
        x, y = d[2].copy(), d[1].copy()
        del d

        impls = {
            "tribodyn.linfit": lambda x=x, y=y: tb.linfit(x, y),
            "reference.linfit": lambda x=x, y=y: ref.linfit(x, y),
            "scipy.stats.linregress": lambda x=x, y=y: st.linregress(x, y),
            "x @ y (1 BLAS thread)": OneBlasThread(lambda x=x, y=y: x @ y),
        }
        these = [Row("linfit", label, n, name) for name in impls]
        log(f"linfit n={n}")
        bench(these, impls, repeats if n > 10_000 else repeats * 3, min_time)
        a, b = tb.linfit(x, y), ref.linfit(x, y)
        these[1].note = f"slope diff {abs(a.slope - b.slope):.1e}"
        rows += these
    return rows


def bench_highpass(sizes: dict[str, int], repeats: int, min_time: float, log) -> list[Row]:
    rows: list[Row] = []
    sos = tb.butter_highpass(FS)
    zi = ss.sosfilt_zi(sos)
    for label, n in sizes.items():
        X = signals(n, 2)
        warm = X.copy()
        state = np.zeros((3, sos.shape[0], 2))

        # Filters built once (the design is scipy.signal.butter, ~0.5 ms);
        # reset() before each call so every call starts in the steady state.
        hp, hp_ref = tb.HighPass(FS, channels=3), ref.HighPass(FS, channels=3)

        def rust(X=X, hp=hp):
            hp.reset()
            return hp.process(X)

        def reference(X=X, hp=hp_ref):
            hp.reset()
            return hp.process(X)

        def scipy_sosfilt(X=X):
            # The same output as HighPass(init="steady"): zi = sosfilt_zi * x[0].
            return ss.sosfilt(sos, X, axis=-1, zi=zi[:, None, :] * X[None, :, 0, None])[0]

        def kernel_only(warm=warm, state=state):
            # In place on memory already touched: the recursion alone.
            _core.sosfilt_inplace(sos, warm, state)

        def fresh_output(X=X):
            # What returning a new (3, n) array costs before any filtering.
            y = np.empty_like(X)
            y[...] = X
            return y

        impls = {
            "tribodyn.HighPass.process": rust,
            "reference.HighPass.process": reference,
            "scipy.signal.sosfilt": scipy_sosfilt,
            "kernel alone, in place, warm": kernel_only,
            "np.empty_like + copy (first touch)": fresh_output,
        }
        these = [Row("HighPass 3 ch", label, n, name) for name in impls]
        log(f"HighPass 3 x {n}")
        bench(these, impls, repeats if n > 10_000 else repeats * 3, min_time)
        same = np.array_equal(rust(), scipy_sosfilt())
        these[0].note = "bitwise equal to sosfilt" if same else "NOT bitwise equal to sosfilt"
        rows += these
        del X, warm
        gc.collect()
    return rows


def bench_xcorr(sizes: dict[str, int], repeats: int, min_time: float, log) -> list[Row]:
    rows: list[Row] = []
    for label, n in sizes.items():
        lag = WINDOW_LAG if n <= 10_000 else RECORD_LAG
        d = signals(n, 3)
        x, y = d[2].copy(), np.roll(d[1], 3).copy()
        del d
        kern = f"xcorr +-{lag}"
        impls: dict[str, Callable[[], object]] = {
            "tribodyn.xcorr (auto)": lambda x=x, y=y, lag=lag: tb.xcorr(x, y, max_lag=lag),
            'tribodyn.xcorr (method="fft")': lambda x=x, y=y, lag=lag: tb.xcorr(x, y, max_lag=lag, method="fft"),
            'tribodyn.xcorr (method="direct")': lambda x=x, y=y, lag=lag: tb.xcorr(x, y, max_lag=lag, method="direct"),
            "scipy correlate(fft) + Eq. 1 norm.": lambda x=x, y=y, lag=lag: scipy_xcorr(x, y, lag),
            "reference.xcorr (direct)": lambda x=x, y=y, lag=lag: ref.xcorr(x, y, max_lag=lag),
        }
        skipped: dict[str, str] = {}
        # The reference's lag loop makes three dot products of about n
        # samples per lag: predict one call from a dot product on the record
        # (plus a generous 50 us of Python per lag).
        if n > 10_000:
            t0 = time.perf_counter()
            for _ in range(3):
                np.dot(x, y)
            predicted = (2 * lag + 1) * ((time.perf_counter() - t0) + 50e-6)
            if predicted > REF_BUDGET_S:
                skipped["reference.xcorr (direct)"] = (
                    f"skipped: one call predicted {predicted:.0f} s (> {REF_BUDGET_S:.0f} s)"
                )
            # The direct O(nL) path on a 10 h record: once is enough to show it.
            if n > 10_000_000:
                skipped['tribodyn.xcorr (method="direct")'] = "timed once"
        run = {k: v for k, v in impls.items() if k not in skipped}
        these = [Row(kern, label, n, name) for name in run]
        log(f"xcorr n={n} L={lag}")
        bench(these, run, repeats if n > 10_000 else repeats * 3, min_time)
        for name, why in skipped.items():
            row = Row(kern, label, n, name, note=why)
            if why == "timed once":
                t0 = time.perf_counter()
                impls[name]()
                row.times.append(time.perf_counter() - t0)
            rows.append(row)
        r = tb.xcorr(x, y, max_lag=lag)
        by_name = {row.impl: row for row in these}
        by_name["tribodyn.xcorr (auto)"].note = f"auto -> {r.method}"
        diff = np.nanmax(np.abs(scipy_xcorr(x, y, lag) - r.c))
        by_name["scipy correlate(fft) + Eq. 1 norm."].note = f"max abs diff to tribodyn {diff:.1e}"
        rows += these
        del x, y
        gc.collect()
    return rows


# ----------------------------------------------------------------- machine


def machine() -> dict[str, str]:
    info: dict[str, str] = {}
    try:
        cpuinfo = Path("/proc/cpuinfo").read_text()
        model = next((ln.split(":", 1)[1].strip() for ln in cpuinfo.splitlines() if ln.startswith("model name")), "?")
        flags = next((ln.split(":", 1)[1].split() for ln in cpuinfo.splitlines() if ln.startswith("flags")), [])
        info["CPU"] = model
        info["SIMD"] = ", ".join(f for f in ("sse2", "avx", "avx2", "fma", "avx512f") if f in flags)
    except OSError:
        info["CPU"] = platform.processor() or "?"
    info["cores"] = f"{os.cpu_count()} logical, {len(os.sched_getaffinity(0))} usable"
    try:
        mem = Path("/proc/meminfo").read_text().splitlines()
        kb = {ln.split(":")[0]: int(ln.split()[1]) for ln in mem if ln.split()[1].isdigit()}
        info["RAM"] = (
            f"{kb['MemTotal'] / 2**20:.1f} GiB total, {kb.get('MemAvailable', 0) / 2**20:.1f} GiB available at start"
        )
    except (OSError, KeyError):
        pass
    try:
        osr = dict(ln.split("=", 1) for ln in Path("/etc/os-release").read_text().splitlines() if "=" in ln)
        info["OS"] = f"{osr.get('PRETTY_NAME', '?').strip(chr(34))}, kernel {platform.release()}"
    except OSError:
        info["OS"] = platform.platform()
    info["Python"] = platform.python_version()
    info["numpy / scipy"] = f"{np.__version__} / {scipy.__version__}"
    info["tribodyn"] = f"{tb.__version__}, kernels on {_core.get_threads()} threads"
    try:
        info["rustc"] = subprocess.run(
            ["rustc", "--version"], capture_output=True, text=True, check=True
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        info["rustc"] = "not found"
    if threadpoolctl is not None:
        blas = [p for p in threadpoolctl.threadpool_info() if p.get("user_api") == "blas"]
        info["BLAS"] = (
            "; ".join(
                f"{p.get('internal_api')} {p.get('version')} kernel {p.get('architecture')}, "
                f"{p.get('num_threads')} threads"
                for p in blas
            )
            or "none found"
        )
        info["x @ y"] = "1 BLAS thread (threadpoolctl.threadpool_limits)"
    else:
        info["BLAS"] = "threadpoolctl missing: OPENBLAS/OMP/MKL_NUM_THREADS=1 set for the whole run"
        info["x @ y"] = "1 BLAS thread (environment)"
    env = {v: os.environ.get(v) for v in ("OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE")}
    info["OpenBLAS env"] = ", ".join(f"{k}={v}" if v is not None else f"{k} unset" for k, v in env.items())
    info["load average at start"] = " ".join(f"{v:.2f}" for v in os.getloadavg())
    info["date"] = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return info


# ----------------------------------------------------------------- report


def fmt_t(t: float) -> str:
    if not np.isfinite(t):
        return "-"
    if t < 1e-3:
        return f"{t * 1e6:.1f} us"
    if t < 1.0:
        return f"{t * 1e3:.2f} ms"
    return f"{t:.2f} s"


def find(rows: list[Row], kernel: str, size: str, impl: str) -> Optional[Row]:
    return next((r for r in rows if r.kernel.startswith(kernel) and r.size == size and r.impl == impl), None)


def ratio(rows: list[Row], kernel: str, size: str, num: str, den: str) -> float:
    a, b = find(rows, kernel, size, num), find(rows, kernel, size, den)
    if a is None or b is None or not a.times or not b.times:
        return float("nan")
    return a.median / b.median


def targets(rows: list[Row]) -> list[tuple[str, str, float, bool]]:
    """(target, measured as text, value, met)."""
    out = []
    if find(rows, "linfit", "10 h", "tribodyn.linfit"):
        v = ratio(rows, "linfit", "10 h", "reference.linfit", "tribodyn.linfit")
        out.append(("linfit 3.6e7: >= 5x faster than the reference", f"{v:.1f}x", v, v >= 5))
        v = ratio(rows, "linfit", "10 h", "tribodyn.linfit", "x @ y (1 BLAS thread)")
        out.append(("linfit 3.6e7: within 3x of x @ y (1 BLAS thread)", f"{v:.2f}x the time of x @ y", v, v <= 3))
    if find(rows, "HighPass", "10 h", "tribodyn.HighPass.process"):
        v = ratio(rows, "HighPass", "10 h", "scipy.signal.sosfilt", "tribodyn.HighPass.process")
        out.append(("HighPass 3 x 3.6e7: >= 3x faster than scipy.signal.sosfilt", f"{v:.2f}x", v, v >= 3))
    if find(rows, "xcorr", "window", "tribodyn.xcorr (auto)"):
        v = ratio(rows, "xcorr", "window", "reference.xcorr (direct)", "tribodyn.xcorr (auto)")
        out.append((f"xcorr 2 000 samples +-{WINDOW_LAG}: >= 30x faster than the reference", f"{v:.0f}x", v, v >= 30))
    if find(rows, "xcorr", "10 h", "tribodyn.xcorr (auto)"):
        v = ratio(rows, "xcorr", "10 h", "scipy correlate(fft) + Eq. 1 norm.", "tribodyn.xcorr (auto)")
        out.append(
            (f"xcorr 3.6e7 +-{RECORD_LAG}: >= 3x faster than scipy correlate(fft) + norm.", f"{v:.1f}x", v, v >= 3)
        )
    return out


BASELINE = {
    "linfit": "tribodyn.linfit",
    "HighPass 3 ch": "tribodyn.HighPass.process",
}


def table(rows: list[Row]) -> str:
    lines = [
        "| kernel | size | implementation | median | best | median / tribodyn | note |",
        "| --- | --- | --- | ---: | ---: | ---: | --- |",
    ]
    for r in rows:
        base_name = BASELINE.get(r.kernel, "tribodyn.xcorr (auto)")
        base = find(rows, r.kernel, r.size, base_name)
        rel = r.median / base.median if base and base.times and r.times else float("nan")
        rel_s = "-" if not np.isfinite(rel) else ("1 (baseline)" if r.impl == base_name else f"{rel:.2f}")
        lines.append(
            f"| {r.kernel} | {r.size} ({r.n:,}) | {r.impl} | {fmt_t(r.median)} | {fmt_t(r.best)} | {rel_s} | {r.note} |"
        )
    return "\n".join(lines)


def report_info(info: dict[str, str], args, elapsed: float) -> dict[str, str]:
    """The machine description completed at the end of a run."""
    info = dict(info)
    info["load average at end"] = " ".join(f"{v:.2f}" for v in os.getloadavg())
    info["peak RSS of the run"] = f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20:.2f} GiB"
    info["run"] = (
        f"`{' '.join(['python', 'benches/bench_kernels.py'] + sys.argv[1:])}`, "
        f"{args.repeats} repeats, {elapsed / 60:.1f} min"
    )
    return info


def report(rows: list[Row], info: dict[str, str], args, elapsed: float, final: dict[str, str]) -> str:
    info = final
    tgt = targets(rows)
    out = [
        f"## {SECTION}",
        "",
        "Written by `benches/bench_kernels.py` (see `benches/README.md`). Times are",
        'medians over interleaved repeats; "median / tribodyn" > 1 means tribodyn is faster.',
        "",
    ]
    out += ["### Machine", "", "| | |", "| --- | --- |"]
    out += [f"| {k} | {v} |" for k, v in info.items()]
    out += ["", "### Targets", "", "| target | measured | met |", "| --- | --- | --- |"]
    out += [f"| {t} | {m} | {'met' if ok else '**missed**'} |" for t, m, _, ok in tgt]
    out += ["", "### All measurements", "", table(rows), ""]
    notes = HERE / "NOTES.md"
    if notes.exists():
        out += [notes.read_text().rstrip(), ""]
    return "\n".join(out)


SECTION = "Kernels: tribodyn vs reference vs scipy"
HEADER = "# Benchmark results\n\nMeasured on this project's machines; each section says how it was run.\n"


def write_section(path: Path, block: str) -> None:
    """Replaces (or appends) this script's ``## section`` of ``path``; other
    benchmark scripts keep their own sections of the same file."""
    text = path.read_text() if path.exists() else HEADER
    pattern = re.compile(rf"^## {re.escape(SECTION)}\n.*?(?=^## |\Z)", re.S | re.M)
    if pattern.search(text):
        text = pattern.sub(lambda _: block.rstrip("\n") + "\n\n", text)
    else:
        text = text.rstrip("\n") + "\n\n" + block
    path.write_text(text.rstrip("\n") + "\n")


def save(path: Path, rows: list[Row], info: dict[str, str], elapsed: float, argv: list[str]) -> None:
    """Raw times, so that --render can rewrite RESULTS.md (e.g. after
    editing NOTES.md) without measuring again."""
    data = {"info": info, "elapsed": elapsed, "argv": argv, "rows": [r.__dict__ for r in rows]}
    path.write_text(json.dumps(data, indent=1))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="2 000 and 3.6e6 samples only, fewer repeats")
    ap.add_argument("--repeats", type=int, default=None, help="timed repeats per measurement (default 5, quick 3)")
    ap.add_argument("--only", choices=["linfit", "highpass", "xcorr"], action="append", help="run only these kernels")
    ap.add_argument("--out", type=Path, default=HERE / "RESULTS.md", help="file whose kernel section is (re)written")
    ap.add_argument("--raw", type=Path, default=HERE / "bench_kernels.json", help="where to keep the raw times")
    ap.add_argument("--render", action="store_true", help="rewrite --out from --raw and NOTES.md, measuring nothing")
    args = ap.parse_args()
    if args.render:
        data = json.loads(args.raw.read_text())
        rows = [Row(**r) for r in data["rows"]]
        args.repeats = max((len(r.times) for r in rows), default=0)
        sys.argv = [sys.argv[0]] + data["argv"]
        write_section(args.out, report(rows, data["info"], args, data["elapsed"], final=data["info"]))
        return
    args.repeats = args.repeats or (3 if args.quick else 5)
    sizes = {k: v for k, v in SIZES.items() if not (args.quick and v > 10_000_000)}
    min_time = 0.05 if args.quick else 0.2
    kernels = args.only or ["linfit", "highpass", "xcorr"]

    def log(msg: str) -> None:
        print(f"[{time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)

    info = machine()
    for k, v in info.items():
        log(f"{k}: {v}")
    t0 = time.perf_counter()
    rows: list[Row] = []
    if "linfit" in kernels:
        rows += bench_linfit(sizes, args.repeats, min_time, log)
    if "highpass" in kernels:
        rows += bench_highpass(sizes, args.repeats, min_time, log)
    if "xcorr" in kernels:
        rows += bench_xcorr(sizes, args.repeats, min_time, log)
    elapsed = time.perf_counter() - t0
    info = report_info(info, args, elapsed)
    save(args.raw, rows, info, elapsed, sys.argv[1:])
    text = report(rows, info, args, elapsed, final=info)
    write_section(args.out, text)
    print(text)


if __name__ == "__main__":
    main()
