"""The promise: a per-window table never depends on the format, the chunk size
or the thread count.

Black-box tests against the public API only (``tribodyn.analyze``,
``open_recording``, ``get_threads``/``set_threads``, ``tribodyn.simulate`` and
the writers in ``tribodyn.io.writers``).

One short simulated recording (fx, fy, fz, i; 120 s at 1 kHz) is written in
every format the readers take: npy, npz, HDF5 and TDMS with the project's
writers (npz/HDF5/TDMS exactly as ``tribodyn simulate --out FILE`` writes
them), LVM and CSV by hand (the project has no writer for them). Each file is
analysed through ``open_recording`` with every thread count and chunk size
below, and every per-window table must be bit for bit the one of
``analyze(<mapping of the samples that format's reader returns>, threads=1)``.

Text formats round the samples when written, so each format's reference is
the mapping of what *its* reader returns (``rec.read()``);
:func:`test_round_trip` checks separately that those samples are the original
ones within the printed precision.
"""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, Callable, Dict, List, Tuple

import numpy as np
import pytest
import tribodyn as td
from tribodyn import simulate
from tribodyn.io.writers import save_npy, save_recording, save_tdms

FS = 1000.0
DURATION_S = 120.0
N = int(DURATION_S * FS)
ROLES = ("fx", "fy", "fz", "i")
UNITS = {"fx": "N", "fy": "N", "fz": "N", "i": "A"}

#: Files, by the format of each: "tdms" as ``tribodyn simulate`` writes it
#: (65536-sample segments), "tdms_1s" as a DAQ logger writing once a second
#: (1000-sample segments: many more segments for npTDMS to walk per read).
FORMATS = ("npy", "npz", "hdf5", "tdms", "tdms_1s", "lvm", "csv")
FORMAT_NAME = {"csv": "delimited", "tdms_1s": "tdms"}
#: printf formats of the hand-written text files: LabVIEW's default for LVM,
#: significant digits for CSV (so both kinds of rounding are met).
LVM_FMT = "%.6f"
CSV_FMT = "%.7g"

#: Window configurations (window s, hop s): a few hundred windows each.
CONFIGS = {
    # hop > window, not a divisor of the chunk sizes: 360 windows with gaps
    "gap": dict(window=0.25, hop=0.333),
    # hop == window: the recording tiled by 300 windows
    "tiled": dict(window=0.4, hop=0.4),
}
#: Chunk sizes in s: small (172 chunks, none a multiple of a window or
#: hop), large (3 chunks), and the default.
CHUNKS = (0.7, 47.3, None)
THREADS = (1, 2, 4)

#: Per-window arrays of a Results besides the table.
EXTRA = ("bin_counts", "bin_cof", "fz_min", "fz_max")


# ---------------------------------------------------------------------------
# The recordings
# ---------------------------------------------------------------------------
def _simulated(raw: bool) -> Dict[str, np.ndarray]:
    """120 s of the simulated rig at 1 kHz, constant current: fx, fy, fz, i (float64)."""
    parts = list(simulate.continuous(DURATION_S, chunk_s=30.0, current=3.0, seed=1, fs=FS, raw=raw))
    ch = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    assert set(ch) == set(ROLES) and all(v.dtype == np.float64 and v.size == N for v in ch.values())
    return ch


def _write_lvm(path: Path, ch: Dict[str, np.ndarray]) -> None:
    """A LabVIEW Measurement file as LabVIEW's "Write To Measurement File" lays it
    out (one segment, no X column, tab separated, ``%.6f``). The project has no
    LVM writer, so the test writes it with numpy; the reader is the project's."""
    names = list(ROLES)
    k = len(names)

    def row(key: str, values) -> str:
        return key + "\t" + "\t".join(str(v) for v in values) + "\t\n"

    end_of_header = "***End_of_Header***" + "\t" * (k + 1) + "\n"
    columns = "X_Value\t" + "\t".join(names) + "\tComment\n"
    head = (
        "LabVIEW Measurement\t\nWriter_Version\t2\nReader_Version\t2\nSeparator\tTab\n"
        "Decimal_Separator\t.\nMulti_Headings\tNo\nX_Columns\tNo\nTime_Pref\tRelative\n"
        "Operator\ttribodyn-tests\nDate\t2024/01/01\nTime\t00:00:00\n***End_of_Header***\t\n\t\n"
        + row("Channels", [k] + [""] * (k - 1))
        + row("Samples", [N] * k)
        + row("Date", ["2024/01/01"] * k)
        + row("Time", ["00:00:00"] * k)
        + row("Y_Unit_Label", [UNITS[n] for n in names])
        + row("X_Dimension", ["Time"] * k)
        + row("X0", ["0.0000000000000000E+0"] * k)
        + row("Delta_X", ["1.000000E-3"] * k)
        + end_of_header
        + columns
    )
    with open(path, "w", newline="\n") as f:
        f.write(head)
        # an empty X column first, as LabVIEW writes with X_Columns No
        np.savetxt(f, np.column_stack([ch[n] for n in names]), fmt="\t" + "\t".join([LVM_FMT] * k))


def _write_csv(path: Path, ch: Dict[str, np.ndarray]) -> None:
    """A CSV export: a time column (fs comes from it), units in the names. The
    project has no CSV writer, so the test writes it with numpy."""
    t = np.arange(N) / FS
    with open(path, "w", newline="\n") as f:
        f.write("time [s]," + ",".join(f"{n} [{UNITS[n]}]" for n in ROLES) + "\n")
        rows = np.column_stack([t] + [ch[n] for n in ROLES])
        np.savetxt(f, rows, fmt=["%.3f"] + [CSV_FMT] * len(ROLES), delimiter=",")


def _write_all(directory: Path, ch: Dict[str, np.ndarray]) -> Dict[str, Tuple[Path, Dict[str, Any]]]:
    """Writes ``ch`` in every format; format -> (path, open_recording keyword arguments)."""
    out: Dict[str, Tuple[Path, Dict[str, Any]]] = {}
    # .npy holds neither names nor fs: a role map and fs= are needed.
    p = directory / "rec.npy"
    names = save_npy(p, ch)
    out["npy"] = (p, dict(fs=FS, channels={r: f"ch{names.index(r)}" for r in ROLES}))
    # npz, HDF5, TDMS: what `tribodyn simulate --out FILE` does (cli.py).
    for fmt, ext in (("npz", ".npz"), ("hdf5", ".h5"), ("tdms", ".tdms")):
        p = directory / f"rec{ext}"
        save_recording(p, ch, FS, units=UNITS)
        out[fmt] = (p, {})
    p = directory / "rec_1s.tdms"
    save_tdms(p, ch, FS, units=UNITS, segment_samples=int(FS))
    out["tdms_1s"] = (p, {})
    p = directory / "rec.lvm"
    _write_lvm(p, ch)
    out["lvm"] = (p, {})
    p = directory / "rec.csv"
    _write_csv(p, ch)
    out["csv"] = (p, {})
    return out


@pytest.fixture(scope="module")
def original() -> Dict[str, Dict[str, np.ndarray]]:
    """The simulated samples: "dynamic" (as the charge amplifier gives them) and "raw" (DC-coupled)."""
    return {"dynamic": _simulated(raw=False), "raw": _simulated(raw=True)}


@pytest.fixture(scope="module")
def files(tmp_path_factory, original) -> Dict[str, Dict[str, Tuple[Path, Dict[str, Any]]]]:
    """kind ("dynamic"/"raw") -> format -> (path, open_recording kwargs)."""
    out = {}
    for kind, ch in original.items():
        out[kind] = _write_all(tmp_path_factory.mktemp(f"paths_{kind}"), ch)
    return out


def _open(files, kind: str, fmt: str):
    path, kw = files[kind][fmt]
    return td.open_recording(path, **kw)


@pytest.fixture(scope="module")
def read_back(files) -> Callable[[str, str], Dict[str, np.ndarray]]:
    """(kind, fmt) -> the float64 samples that format's reader returns (``rec.read()``), cached."""
    cache: Dict[Tuple[str, str], Dict[str, np.ndarray]] = {}

    def get(kind: str, fmt: str) -> Dict[str, np.ndarray]:
        if (kind, fmt) not in cache:
            with _open(files, kind, fmt) as rec:
                assert rec.fs == FS, (fmt, rec.fs)
                assert rec.n_samples == N, (fmt, rec.n_samples)
                data = rec.read()
            assert set(ROLES) <= set(data), (fmt, sorted(data))
            cache[kind, fmt] = {r: data[r] for r in ROLES}
        return cache[kind, fmt]

    return get


@pytest.fixture(scope="module")
def reference(read_back) -> Callable[..., Any]:
    """(kind, fmt, config[, highpass]) -> analyze(<in-memory mapping of that format's samples>, threads=1), cached."""
    cache: Dict[tuple, Any] = {}

    def get(kind: str, fmt: str, config: str, highpass=None) -> Any:
        key = (kind, fmt, config, highpass)
        if key not in cache:
            mapping = dict(read_back(kind, fmt))
            cache[key] = td.analyze(mapping, fs=FS, threads=1, highpass=highpass, **CONFIGS[config])
            n_win = len(cache[key].table["n"])
            assert 250 <= n_win <= 400, n_win  # a few hundred windows
        return cache[key]

    return get


# ---------------------------------------------------------------------------
# Comparison
# ---------------------------------------------------------------------------
def _same_array(got: Any, want: Any, what: str) -> None:
    got, want = np.asarray(got), np.asarray(want)
    assert got.dtype == want.dtype, f"{what}: dtype {got.dtype} != {want.dtype}"
    assert got.shape == want.shape, f"{what}: shape {got.shape} != {want.shape}"
    if want.dtype.kind in "fc":
        equal = np.array_equal(got, want, equal_nan=True)
        if equal:
            # bit for bit where not NaN (0.0 and -0.0 differ too)
            ok = ~np.isnan(want)
            equal = np.array_equal(got[ok].view(np.uint8), want[ok].view(np.uint8))
    else:
        equal = np.array_equal(got, want)
    if not equal:
        if want.dtype.kind in "fc":
            bad = ~((got == want) & (np.signbit(got) == np.signbit(want)) | (np.isnan(got) & np.isnan(want)))
        else:
            bad = got != want
        rows = np.unique(np.nonzero(bad)[0]) if bad.ndim else np.array([0])
        first = rows[:5].tolist()
        sample = [(int(k), got[k].tolist(), want[k].tolist()) for k in first[:2]] if got.ndim else []
        pytest.fail(
            f"{what}: {rows.size} of {len(want) if want.ndim else 1} windows differ "
            f"(first at {first}; got vs reference: {sample})"
        )


def assert_same_results(got: Any, want: Any, where: str) -> None:
    """Every per-window array of two Results bit for bit equal, same dtypes."""
    assert list(got.table) == list(want.table), f"{where}: table columns differ"
    for name in want.table:
        _same_array(got.table[name], want.table[name], f"{where}: table[{name!r}]")
    for name in EXTRA:
        _same_array(getattr(got, name), getattr(want, name), f"{where}: {name}")
    assert got.orientation == want.orientation, where


def _collect(call: Callable[[], Any], want: Any, where: str, failures: List[str]) -> None:
    """Runs ``call`` and compares its result; a difference or an exception becomes one line of ``failures``."""
    try:
        got = call()
    except BaseException as exc:  # noqa: BLE001 - a corrupted read may surface as any error, a panic too
        if isinstance(exc, (KeyboardInterrupt, SystemExit)):
            raise
        failures.append(f"{where}: raised {type(exc).__module__}.{type(exc).__qualname__}: {exc}")
        return
    try:
        assert_same_results(got, want, where)
    except (AssertionError, pytest.fail.Exception) as exc:
        failures.append(str(exc).splitlines()[0])


# ---------------------------------------------------------------------------
# The written files
# ---------------------------------------------------------------------------
def _printed(values: np.ndarray, fmt: str) -> np.ndarray:
    return np.array([float(fmt % v) for v in values.tolist()])


@pytest.mark.parametrize("kind", ["dynamic", "raw"])
@pytest.mark.parametrize("fmt", FORMATS)
def test_round_trip(files, original, read_back, fmt, kind):
    """Binary formats give back the very samples; text formats the printed ones."""
    got = read_back(kind, fmt)
    with _open(files, kind, fmt) as rec:
        assert rec.format == FORMAT_NAME.get(fmt, fmt)
    for r in ROLES:
        orig = original[kind][r]
        assert got[r].dtype == np.float64
        if fmt in ("lvm", "csv"):
            printf = LVM_FMT if fmt == "lvm" else CSV_FMT
            # exactly the numbers in the file...
            np.testing.assert_array_equal(got[r], _printed(orig, printf), err_msg=f"{fmt} {r}")
            # ...which are the original within half a unit of the last printed digit
            if fmt == "lvm":
                tol = np.full(orig.shape, 0.5e-6)
            else:
                digits = int(CSV_FMT.strip("%g.")) - 1
                mag = np.floor(np.log10(np.where(orig == 0, 1.0, np.abs(orig))))
                tol = 0.5 * 10.0 ** (mag - digits)
            err = np.abs(got[r] - orig)
            assert np.all(err <= tol * (1 + 1e-9) + 1e-300), (fmt, r, float(np.max(err / tol)))
            assert np.any(err > 0), f"{fmt} {r}: expected some rounding (the check would be vacuous)"
        else:
            np.testing.assert_array_equal(got[r], orig, err_msg=f"{fmt} {r}")
            assert np.array_equal(got[r].view(np.uint64), orig.view(np.uint64)), (fmt, r)


# ---------------------------------------------------------------------------
# 1. The matrix
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("threads", THREADS, ids=lambda t: f"threads{t}")
@pytest.mark.parametrize("chunk", CHUNKS, ids=lambda c: f"chunk{c}")
@pytest.mark.parametrize("config", list(CONFIGS))
@pytest.mark.parametrize("fmt", FORMATS)
def test_matrix(files, reference, fmt, config, chunk, threads):
    want = reference("dynamic", fmt, config)
    with _open(files, "dynamic", fmt) as rec:
        got = td.analyze(rec, chunk=chunk, threads=threads, **CONFIGS[config])
    assert_same_results(got, want, f"{fmt} {config} chunk={chunk} threads={threads}")


@pytest.mark.parametrize("fmt", FORMATS)
def test_matrix_raw_highpass(files, reference, fmt):
    """The raw (DC-coupled) path: streaming high-pass, state carried across chunks."""
    want = reference("raw", fmt, "tiled", highpass=0.1)
    assert np.isfinite(want.table["mu_classical"]).all()  # the raw path's classical column
    with _open(files, "raw", fmt) as rec:
        got = td.analyze(rec, chunk=0.7, threads=2, highpass=0.1, **CONFIGS["tiled"])
    assert_same_results(got, want, f"raw {fmt} highpass=0.1 chunk=0.7 threads=2")


def test_formats_agree_where_samples_agree(reference):
    """The binary formats hold the same samples, so their references are one table."""
    for config in CONFIGS:
        base = reference("dynamic", "npy", config)
        for fmt in ("npz", "hdf5", "tdms", "tdms_1s"):
            assert_same_results(reference("dynamic", fmt, config), base, f"{fmt} vs npy {config}")


# ---------------------------------------------------------------------------
# 2. Repetition (npTDMS is not thread-safe: corruption comes and goes)
# ---------------------------------------------------------------------------
#: How often: before the fix, npTDMS's races spoilt roughly 5-40 % of such
#: runs on a 2-core machine (more under load, more with 1 s segments), so
#: one run proves little and 50 leave a race little chance to hide.
REPEATS = 50


@pytest.mark.parametrize("fmt", ["tdms", "tdms_1s", "hdf5"])
def test_repeated_threads2(files, reference, fmt):
    want = reference("dynamic", fmt, "gap")
    failures: List[str] = []
    for k in range(REPEATS):
        chunk = CHUNKS[k % len(CHUNKS)]

        def run() -> Any:
            with _open(files, "dynamic", fmt) as rec:
                return td.analyze(rec, chunk=chunk, threads=2, **CONFIGS["gap"])

        _collect(run, want, f"{fmt} run {k} chunk={chunk} threads=2", failures)
    assert not failures, f"{len(failures)} of {REPEATS} runs are wrong:\n" + "\n".join(failures)


# ---------------------------------------------------------------------------
# 3. Concurrent calls
# ---------------------------------------------------------------------------
ROUNDS = 4
CALLERS = 8


@pytest.mark.parametrize("shared", [False, True], ids=["own-recordings", "one-shared-recording"])
def test_concurrent_calls(files, reference, restore_threads, shared):
    """8 Python threads analyse the same TDMS and HDF5 files at once, each with
    its own ``threads=``; every result is the serial one and the process-wide
    thread count is left alone."""
    jobs = [(fmt, t) for fmt in ("tdms", "hdf5") for t in (1, 2, 3, 4)]
    assert len(jobs) == CALLERS
    config = "gap"
    want = {fmt: reference("dynamic", fmt, config) for fmt in ("tdms", "hdf5")}
    shared_recs = {fmt: _open(files, "dynamic", fmt) for fmt in ("tdms", "hdf5")} if shared else {}
    start = threading.Barrier(CALLERS)

    def call(job: Tuple[str, int], chunk: Any, rnd: int) -> List[str]:
        fmt, t = job

        def run() -> Any:
            start.wait(timeout=30)  # all callers at once
            if shared:
                return td.analyze(shared_recs[fmt], chunk=chunk, threads=t, **CONFIGS[config])
            with _open(files, "dynamic", fmt) as rec:
                return td.analyze(rec, chunk=chunk, threads=t, **CONFIGS[config])

        out: List[str] = []
        _collect(run, want[fmt], f"round {rnd} {fmt} threads={t} chunk={chunk}", out)
        return out

    try:
        td.set_threads(3)
        assert td.get_threads() == 3
        failures: List[str] = []
        with ThreadPoolExecutor(CALLERS) as pool:
            for rnd in range(ROUNDS):
                chunk = CHUNKS[rnd % 2]
                for out in pool.map(call, jobs, [chunk] * len(jobs), [rnd] * len(jobs)):
                    failures += out
                now = td.get_threads()
                if now != 3:
                    failures.append(f"round {rnd}: get_threads() is {now} after the calls, set_threads(3) before")
        assert not failures, f"{len(failures)} problems:\n" + "\n".join(failures)
        assert td.get_threads() == 3
    finally:
        for rec in shared_recs.values():
            rec.close()


def test_threads_argument_leaves_setting_alone(restore_threads):
    """A serial call with ``threads=`` does not change the process-wide count."""
    td.set_threads(3)
    td.analyze(_small_mapping(), fs=FS, window=0.5, hop=0.5, threads=2)
    assert td.get_threads() == 3


# ---------------------------------------------------------------------------
# 4. Bounds of the thread count
# ---------------------------------------------------------------------------
def _small_mapping() -> Dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    fz = rng.standard_normal(20_000)
    return {"fy": -0.1 * fz + 0.01 * rng.standard_normal(fz.size), "fz": fz}


def _expect_value_error(fn: Callable[[], Any], what: str) -> ValueError:
    try:
        fn()
    except ValueError as exc:
        return exc
    except BaseException as exc:  # pyo3's PanicException derives from BaseException
        if isinstance(exc, (KeyboardInterrupt, SystemExit)):
            raise
        pytest.fail(f"{what}: expected ValueError, got {type(exc).__module__}.{type(exc).__qualname__}: {exc}")
    pytest.fail(f"{what}: expected ValueError, nothing was raised")


@pytest.mark.parametrize("threads", [0, -1])
def test_bad_threads_argument(restore_threads, threads):
    td.set_threads(3)
    _expect_value_error(
        lambda: td.analyze(_small_mapping(), fs=FS, window=0.5, hop=0.5, threads=threads), f"threads={threads}"
    )
    assert td.get_threads() == 3


# A thread count far above the cores (the documented bound is 4 x os.cpu_count())
# is checked in a child process: before the bound existed, such a call started
# thread after thread without end, which must not take this process with it.
# A watchdog in the child stops it as soon as it runs far more threads than
# the bound allows (Linux: /proc/self/status), the deadline below otherwise.
_PROBE = r"""
import json, os, sys, threading, time
import numpy as np
import tribodyn as td

LIMIT = 4 * (os.cpu_count() or 1) + 64  # the bound, plus numpy's and Python's own threads

def watchdog():
    while True:
        try:
            with open("/proc/self/status") as f:
                n = int(next(line for line in f if line.startswith("Threads:")).split()[1])
        except (OSError, StopIteration, ValueError):
            return
        if n > LIMIT:
            print(json.dumps({"raised": None, "runaway_threads": n}), flush=True)
            os._exit(0)
        time.sleep(0.05)

threading.Thread(target=watchdog, daemon=True).start()
what = sys.argv[1]
rng = np.random.default_rng(0)
fz = rng.standard_normal(20_000)
m = {"fy": -0.1 * fz + 0.01 * rng.standard_normal(fz.size), "fz": fz}
try:
    if what == "set_threads":
        td.set_threads(30000)
    else:
        td.analyze(m, fs=1000.0, window=0.5, hop=0.5, **({"threads": 30000} if what == "analyze" else {}))
except BaseException as exc:
    out = {"raised": f"{type(exc).__module__}.{type(exc).__qualname__}",
           "value_error": isinstance(exc, ValueError), "message": str(exc)}
else:
    out = {"raised": None, "threads": td.get_threads()}
print(json.dumps(out), flush=True)
os._exit(0)
"""
PROBE_TIMEOUT_S = 30.0


@pytest.fixture(scope="module")
def probes():
    """The three 30000-thread probes, started at once (they run side by side)."""
    procs = {}
    deadline = time.monotonic() + PROBE_TIMEOUT_S
    for what in ("analyze", "env", "set_threads"):
        with pytest.MonkeyPatch.context() as mp:
            if what == "env":
                mp.setenv("TRIBODYN_THREADS", "30000")
            else:
                mp.delenv("TRIBODYN_THREADS", raising=False)
            procs[what] = subprocess.Popen(
                [sys.executable, "-c", _PROBE, what], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
            )
    yield procs, deadline
    for p in procs.values():
        if p.poll() is None:
            p.kill()
            p.wait()


@pytest.mark.parametrize(
    "what",
    ["analyze", "env", "set_threads"],
    ids=["analyze-threads-30000", "TRIBODYN_THREADS-30000", "set_threads-30000"],
)
def test_huge_thread_count_is_a_value_error(probes, what):
    procs, deadline = probes
    p = procs[what]
    try:
        # one deadline for the three probes, which run side by side
        out, err = p.communicate(timeout=max(0.1, deadline - time.monotonic()))
    except subprocess.TimeoutExpired:
        p.kill()
        p.communicate()
        pytest.fail(f"{what}: 30000 threads did not raise ValueError within {PROBE_TIMEOUT_S:g} s (still running)")
    assert p.returncode == 0, f"{what}: probe exited {p.returncode}: {err[-2000:]}"
    assert out.strip(), f"{what}: probe printed nothing: {err[-2000:]}"
    got = json.loads(out.strip().splitlines()[0])
    if "runaway_threads" in got:
        pytest.fail(f"{what}: no ValueError; the process ran {got['runaway_threads']} threads and counting")
    assert got["raised"] is not None, f"{what}: no error raised (get_threads() then {got.get('threads')})"
    assert got["value_error"], f"{what}: expected ValueError, got {got['raised']}: {got['message']}"
