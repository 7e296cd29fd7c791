"""Bit-for-bit check of the analysis between this checkout and a baseline tree (issue 38 point 2).

A speed change of the fixed part of a call (the pre-pass, the lag profile, the opening, the settle) must
leave every result as it was. This runs each case below with this checkout's ``tribodyn`` and with the
``--baseline`` tree's (a child process each, ``PYTHONPATH`` = ``TREE/python``) and compares, per case, a
digest of the per-window table (every column, bit for bit), the headline, ``mu_r_ci``, ``summary()``, the
instrument lag and its shifts, the parameters (``min_fn``, tare, motion...) and the warnings; an error
must be the same error.

Cases: every file of tests/data/real and tests/data/formats (opened as ``tests/test_real_files.py`` and
the format tests open them where options are needed), simulations (``simulate.conditions`` with white and
band-limited fz noise, delays, ``rpm``; raw amplifier output; acquisitions; reciprocating; the two
scenarios), the 0.1 h and 1 h ``.npy`` of ``bench_fixed_costs.py`` (``--data``), a mapping, and threads
1 and 2.

Usage::

    python benches/check_bitwise.py --baseline /tmp/base [--data /tmp/perf] [--jobs 2]

Prints one line per case (``same``, or what differs: with the same table and instrument lag, the largest
relative difference of the other values) and exits 1 when a table or a lag differs.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any, Dict, List

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

CHILD = r"""
import hashlib, json, sys, warnings
import numpy as np
import tribodyn as td
from tribodyn import simulate

ROOT, DATA, WHICH = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
REAL, FORMATS = ROOT + "/tests/data/real/", ROOT + "/tests/data/formats/"


def digest(res):
    h = hashlib.sha256()
    for k in sorted(res.table):
        v = np.asarray(res.table[k])
        h.update(k.encode())
        h.update(v.astype(str).tobytes() if v.dtype == object else v.tobytes())
    return h.hexdigest()


def text(x):
    # floats by their bits (repr is exact for a float64), arrays by their bytes
    if isinstance(x, np.ndarray):
        return "array:" + hashlib.sha256(x.tobytes()).hexdigest()[:16] + str(x.dtype) + str(x.shape)
    if isinstance(x, dict):
        return "{" + ", ".join(f"{k!r}: {text(v)}" for k, v in sorted(x.items(), key=lambda kv: str(kv[0]))) + "}"
    if isinstance(x, (list, tuple)):
        return "[" + ", ".join(text(v) for v in x) + "]"
    if isinstance(x, (float, np.floating)):
        return repr(float(x))
    return repr(x)


def numbers(x):
    # every float of x, in order (for the size of a difference of values that are not bit for bit)
    if isinstance(x, dict):
        return [v for k in sorted(x, key=str) for v in numbers(x[k])]
    if isinstance(x, (list, tuple)):
        return [v for e in x for v in numbers(e)]
    if isinstance(x, np.ndarray) and x.dtype.kind == "f":
        return [float(v) for v in x.ravel()]
    if isinstance(x, (float, np.floating)):
        return [float(x)]
    return []


def record(name, fn):
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = fn()
            out = {"table": digest(res), "rows": len(res), "headline": str(res.headline),
                   "mu_r_ci": text(res.mu_r_ci), "summary": text(res.summary()),
                   "params": text(res.params), "warnings": text(list(res.warnings)),
                   "lag": res.params.get("iv_lag_samples"), "shifts": numbers(res.params.get("iv_lag_shifts")),
                   "ci": numbers(res.mu_r_ci)}
    except Exception as exc:  # the same error both sides
        out = {"error": f"{type(exc).__name__}: {exc}"}
    return out


def sim(**kw):
    s = simulate.conditions(kw.pop("seconds", 120.0), **kw)
    return {k: np.array(v, dtype=float) for k, v in s.channels.items()}


def band(ch, lo, hi, seed, snr=10.0):
    from scipy import signal
    rng = np.random.default_rng([seed, 38])
    w = rng.standard_normal(ch["fz"].size + 2000)
    w = signal.sosfilt(signal.butter(2, (lo, hi), btype="bandpass", fs=1000.0, output="sos"), w)[2000:]
    out = dict(ch)
    out["fz"] = ch["fz"] + w / w.std() * float(np.std(ch["fz"])) * 10.0 ** (-snr / 20.0)
    return out


def opened(path, **kw):
    def go():
        with td.open_recording(path, **kw) as rec:
            return td.analyze(rec, **an)
    an = kw.pop("analyze", {})
    return go


cases = {}
for f in sorted(__import__("os").listdir(REAL)):
    kw = {}
    if f.startswith("newport"):
        kw = dict(time_column="col1", channels={"fy": "col3", "fz": "col2"}, scale={"fy": 1 / (2.0 / 3.0 * 4e-3)})
    if f.startswith("lvm_read_long"):
        kw = dict(channels={"fz": "F", "fy": "m_1"}, scale={"fy": 1.0}, analyze=dict(window=1.0, hop=1.0))
    if f.startswith("lvm_read_short"):
        kw = dict(channels={"fz": "Excitation (Trigger)", "fy": "Response (Trigger)"}, scale={"fy": 1.0},
                  analyze=dict(window=0.0003, hop=0.0003))
    if f.startswith("nptdms"):
        kw = dict(channels={"fz": "First  Channel", "fy": "Second Chan"}, analyze=dict(window=0.01, hop=0.01))
    if f.endswith(".npy"):
        kw = dict(channels={"fz": "ch1", "fy": "ch2"}, fs=25600.0, analyze=dict(window=0.1, hop=0.1))
    cases["real/" + f] = opened(REAL + f, **kw)
for f in sorted(__import__("os").listdir(FORMATS)):
    if f.endswith(".py"):
        continue
    cases["formats/" + f] = opened(FORMATS + f)
for seed in (1, 2, 3):
    cases[f"sim white seed {seed}"] = lambda seed=seed: td.analyze(sim(seed=seed, y_noise=0.02), fs=1000.0)
    cases[f"sim band 200-450 seed {seed}"] = lambda seed=seed: td.analyze(
        band(sim(seed=seed, y_noise=0.02), 200.0, 450.0, seed), fs=1000.0)
    cases[f"sim band 20-200 seed {seed}"] = lambda seed=seed: td.analyze(
        band(sim(seed=seed, y_noise=0.02), 20.0, 200.0, seed, snr=6.0), fs=1000.0)
cases["sim delay 3 ms"] = lambda: td.analyze(sim(seed=4, delay=0.003, y_noise=0.02), fs=1000.0)
cases["sim snr_z 20 band"] = lambda: td.analyze(sim(seed=5, snr_z=20.0, z_noise="band"), fs=1000.0)
cases["sim rpm given"] = lambda: td.analyze(sim(seed=6, y_noise=0.02), fs=1000.0, rpm=250.0)
cases["sim raw"] = lambda: td.analyze(sim(seed=7, raw=True), fs=1000.0)
cases["sim drift ripple"] = lambda: td.analyze(sim(seed=8, drift=0.2, ripple=0.1), fs=1000.0)
cases["sim threads 1"] = lambda: td.analyze(band(sim(seed=9), 200.0, 450.0, 9), fs=1000.0, threads=1)
cases["sim threads 2"] = lambda: td.analyze(band(sim(seed=9), 200.0, 450.0, 9), fs=1000.0, threads=2)
cases["sim paper"] = lambda: td.analyze(sim(seed=10), fs=1000.0, method="paper")
cases["acquisitions 40 x 2 s"] = lambda: td.analyze(
    [dict(a.channels) for a in simulate.acquisitions(40, 2.0, seed=3, y_noise=0.02)], fs=1000.0)
cases["acquisitions band"] = lambda: td.analyze(
    [band({k: np.array(v, float) for k, v in a.channels.items()}, 200.0, 450.0, k)
     for k, a in enumerate(simulate.acquisitions(40, 2.0, seed=4, y_noise=0.02))], fs=1000.0)
cases["reciprocating"] = lambda: td.analyze(dict(simulate.reciprocating(seed=1).channels), fs=1000.0)
for name in ("temperature", "current_density"):
    cases["scenario " + name] = lambda name=name: (lambda s: td.analyze(dict(s.channels), fs=s.fs))(
        simulate.scenario(name, seed=1))
cases["sim 400 s band 200-450"] = lambda: td.analyze(band(sim(seconds=400.0, seed=11, y_noise=0.02), 200.0, 450.0, 11),
                                                     fs=1000.0)
cases["sim 400 s white"] = lambda: td.analyze(sim(seconds=400.0, seed=12, y_noise=0.02), fs=1000.0)
for h in ("h01", "h1"):
    for th in (1, 2):
        cases[f"{h}.npy threads {th}"] = opened(f"{DATA}/{h}.npy", fs=1000.0, names=["fx", "fy", "fz", "i"],
                                                  analyze={"threads": th})
cases["h01 mapping"] = lambda: td.analyze(
    {r: np.array(a) for r, a in zip(["fx", "fy", "fz", "i"], np.load(f"{DATA}/h01.npy"))}, fs=1000.0)
names = list(cases) if WHICH is None else WHICH
print(json.dumps({n: record(n, cases[n]) for n in names}))
"""


def run(tree: str, data: str, which: Any) -> Dict[str, Any]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPATH"] = str(Path(tree) / "python")
    p = subprocess.run([sys.executable, "-c", CHILD, str(ROOT), data, json.dumps(which)], capture_output=True,
                       text=True, env=env, cwd=tempfile.gettempdir())  # fmt: skip
    if p.returncode:
        raise RuntimeError(p.stderr[-3000:])
    return dict(json.loads(p.stdout.strip().splitlines()[-1]))


def main(argv: Any = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--baseline", required=True, help="a tree whose python/ holds the baseline tribodyn")
    ap.add_argument("--data", default=os.path.join(tempfile.gettempdir(), "perf"))
    ap.add_argument("--only", nargs="*", help="case names (default: all)")
    args = ap.parse_args(argv)
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(2) as ex:
        this_f = ex.submit(run, str(ROOT), args.data, args.only)
        base_f = ex.submit(run, args.baseline, args.data, args.only)
        this, base = this_f.result(), base_f.result()
    bad: List[str] = []
    near: List[str] = []
    for name in this:
        a, b = this[name], base.get(name)
        diff = [k for k in sorted(set(a) | set(b or {})) if b is None or a.get(k) != b.get(k)]
        state = "same" if not diff else "DIFFERS in " + ", ".join(diff)
        if diff and b is not None and a.get("table") == b.get("table") and a.get("lag") == b.get("lag"):
            # the lag and the table the same: the size of the other differences (the lag's shifts, the interval)
            rel = {}
            for key in ("shifts", "ci"):
                u, v = a.get(key, []), b.get(key, [])
                if len(u) == len(v):
                    rel[key] = max([abs(x - y) / max(abs(y), 1e-300) for x, y in zip(u, v) if x != y] or [0.0])
            if len(rel) == 2 and set(diff) <= {"shifts", "ci", "params", "mu_r_ci", "summary"}:
                state = (
                    f"table and lag same; differ: {', '.join(diff)}: the lag's shifts within "
                    f"{rel['shifts']:.1e}, mu_r_ci within {rel['ci']:.1e} relative"
                )
                near.append(name)
        extra = f" (error: {a['error']})" if "error" in a else f" ({a['rows']} windows)"
        print(f"{name:48s} {state}{extra}")
        if diff and name not in near:
            bad.append(name)
    same = len(this) - len(bad) - len(near)
    print(
        f"{same} of {len(this)} cases bit for bit the same; {len(near)} with the same table and lag (the rest of "
        f"the results within the relative difference shown); {len(bad)} differ"
    )
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
