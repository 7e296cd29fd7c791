"""The pre-pass's bounded sample (issue 38 point 2): what a smaller sample changes, and what it saves.

The pre-pass (docs/method.md 6a-6c) looks at a bounded sample of fy and fz
(``tribodyn.io.sample.PREPASS_SAMPLES``, 256 evenly spread pieces of a
random-access recording, else its first samples); the friction-axis choice
(docs/method.md 6f) at a quarter of it (``tribodyn.io.roles.ROLE_SAMPLES``).
This script sets both at run time to 2^20, 2^18, 2^17 and 2^16 (the role
sample a quarter of each) and, for every case, opens and analyses it at each
size and compares with 2^20 and with the truth where the simulator knows it:

* ``min_fn``, the tare (fy, fz), the contact rule (numbers left out: the
  decision), ``static_fz``, the motion verdict, the friction-channel choice
  (channel and rule), and the headline (method, value, interval);
* cases: every file of ``tests/data/real`` and ``tests/data/formats`` (the
  files whose names map nothing get a map, as the tests give them), and
  simulated recordings written to ``.npy`` (a random-access recording: a
  mapping of arrays is looked at whole, whatever the sample): static
  recordings with lift-off (at the ends, intermittent, 40 % unloaded, a 2 s
  start), dead weight, a load ramp, a lower load step, the tare modes,
  reciprocating tests (2 Hz to 0.02 Hz, with fy alone, a position or a
  velocity channel: the motion channel's reversals are counted across the
  sample's pieces, docs/method.md 6c), dynamic recordings (``simulate.continuous``, the ``/tmp/perf``
  recordings), the temperature test (raw and high-passed), a running-in
  test and ``simulate.conditions(raw=True)``; 1 min to 3 h;
* times (``--time``): the opening (``open_recording``, the friction axis
  chosen) and the pre-pass alone, and the API call (open + analyze) of the
  1 h and 10 h recordings, warm, one process, the sizes interleaved round
  by round; medians.

Usage::

    python benches/bench_prepass_sample.py --data /tmp/perf --out /tmp/prepass_sample.json [--time] [--write]
"""

from __future__ import annotations

import argparse
import json
import math
import re
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable, Dict, Iterator, List, Optional, Tuple

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
SIZES = (20, 18, 17, 16)
FS = 1000.0
PERF_NAMES = ["fx", "fy", "fz", "i"]


def set_size(k: int) -> None:
    """The pre-pass sample 2^k, the role sample a quarter of it (as declared)."""
    from tribodyn.io import roles, sample

    sample.PREPASS_SAMPLES = 1 << k
    roles.ROLE_SAMPLES = 1 << (k - 2)


# -- cases ---------------------------------------------------------------------------


Case = Dict[str, Any]


def _save(path: Path, cols: Dict[str, np.ndarray]) -> Dict[str, Any]:
    np.save(path, np.vstack(list(cols.values())))
    return {"fs": FS, "names": list(cols)}


def static_liftoff(path: Path, duration: float, seed: int, pattern: str) -> Tuple[Dict[str, Any], Dict[str, Any]]:
    """A dead-weight test (10 N, mu 0.2 with a slow wander) with lift-off: fz -0.13 N and fy -0.05 N there."""
    rng = np.random.default_rng(seed)
    n = int(duration * FS)
    t = np.arange(n) / FS
    loaded = np.ones(n, bool)
    if pattern == "ends":  # 30 s before the contact, 60 s after it (a tenth of the recording each, at most)
        loaded[: int(min(30.0, duration / 10) * FS)] = False
        loaded[n - int(min(60.0, duration / 10) * FS) :] = False
    elif pattern == "intermittent":  # 20 s unloaded at the start and every 10 min
        loaded[(t % 600.0) < 20.0] = False
    elif pattern == "rotational":  # 40 % unloaded in blocks of 5 min
        loaded[(t % 300.0) >= 180.0] = False
    elif pattern == "short_start":  # 2 s before the contact
        loaded[: int(2 * FS)] = False
    off_z, off_y, load = -0.13, -0.05, 10.0
    mu = 0.2 + 0.01 * np.sin(2 * np.pi * t / 600.0)
    fz = off_z + np.where(loaded, load + 0.05 * rng.standard_normal(n), 0.002 * rng.standard_normal(n))
    fy = off_y + np.where(loaded, mu * (fz - off_z) + 0.02 * rng.standard_normal(n), 0.002 * rng.standard_normal(n))
    fx = 0.05 * rng.standard_normal(n)
    truth = {"load": load, "static": True, "motion": "unidirectional", "friction": "fy"}
    if not loaded.all():
        truth.update(tare_fy=off_y, tare_fz=off_z, min_fn=max(6 * 0.002, 0.05 * load))
    c = loaded
    truth["value"] = float(np.mean(np.abs(fy[c] - off_y) / np.abs(fz[c] - off_z)))
    return _save(path, {"fx": fx, "fy": fy, "fz": fz}), truth


def dead_weight(path: Path, duration: float, seed: int, ramp: bool = False) -> Tuple[Dict[str, Any], Dict[str, Any]]:
    """No unloaded cluster: min_fn = 4 noise SDs (0.05 N: 0.2 N), or a load ramp from 0 to 20 N."""
    rng = np.random.default_rng(seed)
    n = int(duration * FS)
    base = np.linspace(0.0, 20.0, n) if ramp else np.full(n, 10.0)
    fz = base + 0.05 * rng.standard_normal(n)
    fy = 0.2 * fz + 0.02 * rng.standard_normal(n)
    fx = 0.05 * rng.standard_normal(n)
    truth: Dict[str, Any] = {"load": 10.0, "static": True, "motion": "unidirectional", "friction": "fy"}
    if not ramp:
        truth.update(min_fn=0.2, tare_fy=0.0, tare_fz=0.0, value=float(np.mean(np.abs(fy) / np.abs(fz))))
    return _save(path, {"fx": fx, "fy": fy, "fz": fz}), truth


def load_step(path: Path, duration: float, seed: int) -> Tuple[Dict[str, Any], Dict[str, Any]]:
    """50 N (mu 0.16) for the first 10 %, then 180 N (mu 0.20): a lower load step, in contact, never a tare."""
    rng = np.random.default_rng(seed)
    n = int(duration * FS)
    n1 = n // 10
    fz = np.r_[np.full(n1, 50.0), np.full(n - n1, 180.0)] * (1 + 0.01 * rng.standard_normal(n))
    fy = np.r_[np.full(n1, 0.16), np.full(n - n1, 0.20)] * fz * (1 + 0.02 * rng.standard_normal(n))
    fx = 0.5 * rng.standard_normal(n)
    truth = {"load": 180.0, "static": True, "motion": "unidirectional", "friction": "fy", "tare_fy": 0.0,
             "tare_fz": 0.0, "value": float(np.mean(np.abs(fy) / np.abs(fz)))}  # fmt: skip
    return _save(path, {"fx": fx, "fy": fy, "fz": fz}), truth


def recip(path: Path, duration: float, seed: int, freq: float, motion: str) -> Tuple[Dict[str, Any], Dict[str, Any]]:
    """simulate.reciprocating (mu 0.12 / 0.10, 10 N), fx a lateral channel of noise, with x, v or neither."""
    from tribodyn import simulate

    sim = simulate.reciprocating(seed=seed, fs=FS, frequency=freq, cycles=max(4, int(round(duration * freq))))
    ch = sim.channels
    rng = np.random.default_rng(seed + 100)
    cols = {"fx": 0.05 * rng.standard_normal(ch["fy"].size), "fy": ch["fy"], "fz": ch["fz"]}
    if motion == "x":
        cols["position"] = ch["x"]
    elif motion == "v":
        cols["velocity"] = ch["v"]
    truth = {"load": 10.0, "static": True, "motion": "reciprocating", "friction": "fy", "value": 0.11}
    return _save(path, cols), truth


def dynamic(path: Path, duration: float, seed: int) -> Tuple[Dict[str, Any], Dict[str, Any]]:
    """simulate.continuous (dynamic forces, mu 0.12)."""
    from tribodyn import simulate

    parts = list(simulate.continuous(duration, seed=seed, fs=FS))
    cols = {k: np.concatenate([p[k] for p in parts]) for k in ("fx", "fy", "fz")}
    return _save(path, cols), {"static": False, "motion": "unidirectional", "friction": "fy", "value": 0.12}


def temperature(path: Path, seed: int, raw: bool) -> Tuple[Dict[str, Any], Dict[str, Any]]:
    from tribodyn import simulate

    sim = simulate.temperature_test(seed=seed, raw=raw)
    kw = _save(path, {k: sim.channels[k] for k in ("fx", "fy", "fz")})
    kw["analyze"] = {"temperature": sim.temperature_log}
    return kw, {"motion": "unidirectional", "friction": "fy"}


def running_in(path: Path, duration: float, seed: int) -> Tuple[Dict[str, Any], Dict[str, Any]]:
    from tribodyn import simulate

    sim = simulate.running_in(seed=seed, duration=duration)
    np.save(path, np.vstack([sim.channels["fy"], sim.channels["fz"]]))
    return {"fs": sim.fs, "names": ["fy", "fz"]}, {"static": True, "motion": "unidirectional", "load": 10.0}


def conditions_raw(path: Path, duration: float, seed: int) -> Tuple[Dict[str, Any], Dict[str, Any]]:
    from tribodyn import simulate

    sim = simulate.conditions(duration, seed=seed, raw=True)
    # (its raw fx, the lateral noise, is larger than fy: the choice takes fx at every size, as the names do not)
    return _save(path, {k: sim.channels[k] for k in ("fx", "fy", "fz")}), {"motion": "unidirectional"}


def simulated(quick: bool) -> Iterator[Tuple[str, Callable[[Path], Tuple[Dict[str, Any], Dict[str, Any]]]]]:
    """(name, writer) of each simulated case: the writer saves the recording and returns (open kwargs, truth)."""
    M, H = 60.0, 3600.0
    cases: List[Tuple[str, Callable[[Path], Tuple[Dict[str, Any], Dict[str, Any]]]]] = []
    for pattern, runs in (("ends", [(1 * M, 0), (10 * M, 0), (10 * M, 1), (10 * M, 2), (H, 0), (H, 1), (H, 2),
                                     (3 * H, 0)]),
                          ("intermittent", [(10 * M, 0), (H, 0), (H, 1), (3 * H, 0)]),
                          ("rotational", [(10 * M, 0), (H, 0), (H, 1)]),
                          ("short_start", [(H, 0)])):  # fmt: skip
        for d, s in runs:
            cases.append((f"lift-off {pattern} {d / M:g} min s{s}",
                          lambda p, d=d, s=s, pat=pattern: static_liftoff(p, d, s, pat)))  # fmt: skip
    for d, s in ((10 * M, 0), (H, 0), (H, 1)):
        cases.append((f"dead weight {d / M:g} min s{s}", lambda p, d=d, s=s: dead_weight(p, d, s)))
    cases.append(("load ramp 60 min s0", lambda p: dead_weight(p, H, 0, ramp=True)))
    for d in (10 * M, H):
        cases.append((f"lower load step {d / M:g} min s0", lambda p, d=d: load_step(p, d, 0)))
    # (the per-stroke analysis costs ~10 s per 1000 cycles: 2 Hz for 10 min, slower tests for longer)
    # slow strokes (10-25 s) at 1 kHz: a piece of the sample holds a reversal less often the shorter it is
    for freq, d, mot in ((2.0, 10 * M, "x"), (2.0, 10 * M, "fy"), (0.5, 30 * M, "fy"), (0.1, H, "x"),
                         (0.1, H, "fy"), (0.1, 3 * H, "fy"), (0.05, H, "x"), (0.02, 2 * H, "x"),
                         (0.02, 2 * H, "v"), (0.02, 2 * H, "fy")):  # fmt: skip
        cases.append((f"reciprocating {freq:g} Hz {d / M:g} min {mot} s3",
                      lambda p, d=d, f=freq, m=mot: recip(p, d, 3, f, m)))  # fmt: skip
    for d, s in ((10 * M, 0), (10 * M, 1), (H, 0)):
        cases.append((f"dynamic {d / M:g} min s{s}", lambda p, d=d, s=s: dynamic(p, d, s)))
    cases.append(("temperature test (dynamic) s1", lambda p: temperature(p, 1, False)))
    cases.append(("temperature test raw s1", lambda p: temperature(p, 1, True)))
    cases.append(("running-in 50 Hz 180 min s0", lambda p: running_in(p, 3 * H, 0)))
    cases.append(("conditions raw 60 min s0", lambda p: conditions_raw(p, H, 0)))
    if quick:
        cases = cases[::6]
    yield from cases


# tare and min_fn options on one recording (lift-off at the ends, 1 h, seed 0)
TARE_CASES: List[Tuple[str, Dict[str, Any]]] = [
    ("tare=start", {"tare": "start"}),
    ("tare=none", {"tare": "none"}),
    ("tare=5 s", {"tare": 5.0}),
    ("tare offsets", {"tare": {"fy": -0.05, "fz": -0.13}}),
    ("min_fn=1", {"min_fn": 1.0}),
]

R_EFF = 2.0 / 3.0 * 4e-3  # the Newport files' effective radius (tests/test_real_files.py)


def data_files() -> List[Tuple[str, Path, Dict[str, Any], Dict[str, Any]]]:
    """(name, path, open kwargs, analyze kwargs) of every file of tests/data/real and tests/data/formats."""
    out = []
    for sub in ("real", "formats"):
        for p in sorted((ROOT / "tests" / "data" / sub).iterdir()):
            if p.suffix == ".py":
                continue
            okw: Dict[str, Any] = {}
            akw: Dict[str, Any] = {}
            if p.name.startswith("newport"):
                okw = {"time_column": "col1", "channels": {"fy": "col3", "fz": "col2"}, "scale": {"fy": 1 / R_EFF}}
            if p.name.startswith("cof_only"):
                okw = {"load": 10.0}
            if p.name.startswith("pyfrf"):  # time, hammer force, acceleration at 25.6 kHz: no rate in the file
                okw = {"fs": 25600.0, "names": ["t", "fz", "fy"]}
            out.append((f"{sub}/{p.name}", p, okw, akw))
    return out


# -- one analysis ---------------------------------------------------------------------------


def _decision(rule: Any) -> str:
    """The contact rule without its numbers: the decision (cluster, lower load step, none)."""
    return re.sub(r"[-+]?\d[\d.e+-]*", "#", str(rule or ""))


def observe(path: Path, okw: Dict[str, Any], akw: Dict[str, Any]) -> Dict[str, Any]:
    import tribodyn as td

    try:
        rec = td.open_recording(path, **okw)
    except Exception as exc:  # noqa: BLE001 - recorded: the same at every size or a change
        return {"error": f"open: {type(exc).__name__}: {exc}"}
    o: Dict[str, Any] = {"n": int(rec.n_samples)}
    rc = rec.role_choice
    o["roles"] = dict(rec.roles)
    o["role_rule"] = None if rc is None else rc.rule
    o["role_ambiguous"] = None if rc is None else bool(rc.ambiguous)
    try:
        res = td.analyze(rec, **akw)
    except Exception as exc:  # noqa: BLE001
        o["error"] = f"analyze: {type(exc).__name__}: {str(exc)[:160]}"
        if "fy" not in rec.roles or "fz" not in rec.roles:  # a map from the first channels: the pre-pass runs
            names = [c for c in rec.channel_names]
            if len(names) >= 2:
                return {**observe(path, {**okw, "channels": {"fz": names[0], "fy": names[1]}}, akw), "mapped": True}
        return o
    p = res.params
    contact = p.get("contact") or {}
    tare = p.get("tare_offsets") or {}
    h = res.headline
    o.update(
        static=bool(p.get("static_fz", False)),
        motion=p.get("motion"),
        motion_evidence=p.get("motion_evidence"),
        min_fn=None if p.get("min_fn") is None else float(p["min_fn"]),
        tare_fy=float(tare.get("fy", 0.0)),
        tare_fz=float(tare.get("fz", 0.0)),
        contact=_decision(contact.get("rule")),
        contact_rule=str(contact.get("rule", ""))[:200],
        excluded=contact.get("excluded_fraction"),
        dynamic=bool(res.verdict["dynamic_method"]),
        method=h.method,
        value=float(h.value),
        low=float(h.low),
        high=float(h.high),
        count=int(h.n),
    )
    return o


def run_case(path: Path, okw: Dict[str, Any], akw: Dict[str, Any], sizes: Tuple[int, ...]) -> Dict[int, Dict[str, Any]]:
    out = {}
    for k in sizes:
        set_size(k)
        out[k] = observe(path, okw, akw)
    set_size(20)
    return out


# -- comparison ---------------------------------------------------------------------------

CATEGORIES = ("error", "roles", "role_rule", "role_ambiguous", "static", "motion", "contact", "dynamic", "method")
NUMBERS = ("min_fn", "tare_fy", "tare_fz", "value", "low", "high", "count", "excluded")


def _rel(a: Optional[float], b: Optional[float]) -> float:
    if a is None or b is None:
        return 0.0 if a == b else math.inf
    if a == b or (math.isnan(a) and math.isnan(b)):
        return 0.0
    return abs(a - b) / abs(b) if b else math.inf


def compare(base: Dict[str, Any], got: Dict[str, Any], truth: Dict[str, Any]) -> Dict[str, Any]:
    """What changed against 2^20 (categories, relative changes, the headline's change in half-widths)."""
    cats = [c for c in CATEGORIES if base.get(c) != got.get(c)]
    both_nan = {c for c in NUMBERS if isinstance(base.get(c), float) and math.isnan(base[c])
                and isinstance(got.get(c), float) and math.isnan(got[c])}  # fmt: skip
    nums = [c for c in NUMBERS if c in base and base.get(c) != got.get(c) and c not in both_nan]
    c: Dict[str, Any] = {"changed": bool(cats or nums), "categories": cats, "numbers": nums}
    if "value" in base and "value" in got:
        half = (base["high"] - base["low"]) / 2
        dv = abs(got["value"] - base["value"])
        c["rel_value"] = _rel(got["value"], base["value"])
        c["value_in_half_widths"] = dv / half if half > 0 else (0.0 if dv == 0 else math.inf)
        c["rel_min_fn"] = _rel(got.get("min_fn"), base.get("min_fn"))
        load = truth.get("load") or abs(base["value"]) or 1.0
        # a tare's change as a COF: delta tare_fy / load (fy's offset), delta tare_fz / load (relative)
        c["tare_fy_cof"] = abs(got["tare_fy"] - base["tare_fy"]) / load if truth.get("load") else math.nan
        c["tare_fz_rel"] = abs(got["tare_fz"] - base["tare_fz"]) / load if truth.get("load") else math.nan
        c["tare_in_half_widths"] = (c["tare_fy_cof"] / half) if half > 0 and truth.get("load") else math.nan
    return c


def against_truth(got: Dict[str, Any], truth: Dict[str, Any]) -> Dict[str, Any]:
    out: Dict[str, Any] = {}
    if "value" not in got:
        return out
    half = (got["high"] - got["low"]) / 2
    for key in ("static", "motion"):
        if key in truth:
            out[f"{key}_ok"] = got[key] == truth[key]
    if "friction" in truth:
        out["friction_ok"] = got["roles"].get("fy") == truth["friction"]
    if "value" in truth:
        out["value_err"] = (got["value"] - truth["value"]) / truth["value"]
        out["value_err_half_widths"] = abs(got["value"] - truth["value"]) / half if half > 0 else math.nan
    if "min_fn" in truth and got.get("min_fn") is not None:
        out["min_fn_err"] = (got["min_fn"] - truth["min_fn"]) / truth["min_fn"]
    for k in ("tare_fy", "tare_fz"):
        if k in truth:
            out[f"{k}_err"] = got[k] - truth[k]
    return out


# -- timing ---------------------------------------------------------------------------


def timing(data: Path, static_path: Path, rounds: int) -> Dict[str, Any]:
    """Warm, one process, the sizes interleaved round by round (rotated): medians in seconds."""
    import tribodyn as td
    from tribodyn.pipeline.prepass import prepass

    files = {"dyn 1 h": (data / "h1.npy", {"fs": FS, "names": PERF_NAMES}),
             "static 1 h": (static_path, {"fs": FS, "names": ["fx", "fy", "fz"]})}  # fmt: skip
    api = {"api 1 h": files["dyn 1 h"], "api 10 h": (data / "h10.npy", {"fs": FS, "names": PERF_NAMES})}
    got: Dict[str, Dict[int, List[float]]] = {}

    def clock(key: str, k: int, f: Callable[[], Any]) -> None:
        t = time.perf_counter()
        f()
        got.setdefault(key, {}).setdefault(k, []).append(time.perf_counter() - t)

    for r in range(rounds + 1):  # round 0 warms up and is dropped
        order = list(SIZES[r % len(SIZES) :] + SIZES[: r % len(SIZES)])
        for k in order:
            set_size(k)
            for name, (path, kw) in files.items():
                clock(f"opening, {name}", k, lambda: td.open_recording(path, **kw))
                rec = td.open_recording(path, **kw)
                clock(f"pre-pass, {name}", k, lambda: prepass(None, rec, FS, min_fn=None, tare=None, motion="auto"))
            for name, (path, kw) in api.items():
                clock(name, k, lambda: td.analyze(td.open_recording(path, **kw)))
    set_size(20)
    return {key: {k: statistics.median(v[1:]) for k, v in per.items()} for key, per in got.items()}


# -- report ---------------------------------------------------------------------------


def summarise(results: List[Dict[str, Any]]) -> Dict[str, Any]:
    summ: Dict[str, Any] = {}
    for k in SIZES[1:]:
        rows = [r for r in results if k in r["compare"]]
        cmp_ = [r["compare"][k] for r in rows]

        def worst(key: str, group: Optional[str] = None) -> Tuple[float, str]:
            # over the cases whose verdicts held (a changed verdict is listed on its own)
            vals = [(r["compare"][k].get(key, 0.0), r["name"]) for r in rows
                    if (group is None or r["group"] == group) and not r["compare"][k]["categories"]
                    and not math.isnan(r["compare"][k].get(key, 0.0))]  # fmt: skip
            return max(vals) if vals else (0.0, "")

        s: Dict[str, Any] = {}
        for group in ("real", "formats", "sim"):
            g = [r for r in rows if r["group"] == group]
            s[group] = {
                "cases": len(g),
                "sampled": sum(1 for r in g if r["sampled"][k]),
                "changed": sum(1 for r in g if r["compare"][k]["changed"]),
                "categories": sorted({(c, r["name"]) for r in g for c in r["compare"][k]["categories"]}),
                "worst_rel_value": worst("rel_value", group),
                "worst_value_half_widths": worst("value_in_half_widths", group),
                "worst_rel_min_fn": worst("rel_min_fn", group),
                "worst_tare_fy_cof": worst("tare_fy_cof", group),
                "worst_tare_fz_rel": worst("tare_fz_rel", group),
            }
        s["changed_total"] = sum(1 for c in cmp_ if c["changed"])
        summ[str(k)] = s
    return summ


def fmt_worst(w: Tuple[float, str], pct: bool = True) -> str:
    v, name = w
    if v == 0:
        return "0"
    return (f"{100 * v:.3g} %" if pct else f"{v:.3g}") + f" ({name})"


def report(o: Dict[str, Any]) -> str:
    lines = [f"Cases: {len(o['results'])} ({o['started']} UTC, load {o['load'][0]:.1f} -> {o['load'][1]:.1f}); "
             "each analysed at every size, compared with 2^20 (the role sample a quarter of each).", ""]  # fmt: skip
    lines += ["| size | group | cases | sampled | changed | verdicts changed (motion, roles, contact, static, "
              "method) | worst headline change (verdicts held) | in half-widths | worst min_fn | worst tare fy (COF) |",
              "|---|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for k, s in o["summary"].items():
        for group in ("real", "formats", "sim"):
            g = s[group]
            cats = "; ".join(f"{c}: {n}" for c, n in g["categories"]) or "none"
            worst = (fmt_worst(g["worst_rel_value"]), fmt_worst(g["worst_value_half_widths"], False),
                     fmt_worst(g["worst_rel_min_fn"]), fmt_worst(g["worst_tare_fy_cof"], False))  # fmt: skip
            lines.append(f"| 2^{k} | {group} | {g['cases']} | {g['sampled']} | {g['changed']} | {cats} | "
                         + " | ".join(worst) + " |")  # fmt: skip
    lines += ["", "Against the truth (simulated cases that know it; worst over cases, each size):", "",
              "| size | motion wrong | friction channel wrong | static wrong | worst headline error | "
              "in its half-widths (worst) | worst min_fn error | worst tare error (N) |",
              "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for k in SIZES:
        ts = [(r["name"], r["truth_cmp"][k]) for r in o["results"] if r["group"] == "sim" and k in r["truth_cmp"]]

        def count(key: str) -> int:
            return sum(1 for _, t in ts if t.get(key) is False)

        def wmax(key: str, absolute: bool = True) -> str:
            vals = [(abs(t[key]) if absolute else t[key], n) for n, t in ts if key in t and not math.isnan(t[key])]
            if not vals:
                return "-"
            v, n = max(vals)
            return f"{v:.3g} ({n})"

        tare = [(abs(t[key]), n) for n, t in ts for key in ("tare_fy_err", "tare_fz_err") if key in t]
        tw = f"{max(tare)[0]:.3g} ({max(tare)[1]})" if tare else "-"
        cells = [str(count("motion_ok")), str(count("friction_ok")), str(count("static_ok")), wmax("value_err"),
                 wmax("value_err_half_widths"), wmax("min_fn_err"), tw]  # fmt: skip
        lines.append(f"| 2^{k} | " + " | ".join(cells) + " |")
    if o.get("timing"):
        tm = o["timing"]
        lines += ["", "Times (warm, one process, sizes interleaved; medians of "
                  f"{o['rounds']} rounds; ms):", "",
                  "| step | " + " | ".join(f"2^{k}" for k in SIZES) + " |", "|---|" + "---|" * len(SIZES)]  # fmt: skip
        for key, per in tm.items():
            lines.append(f"| {key} | " + " | ".join(f"{1e3 * per[k]:.1f}" for k in SIZES) + " |")
        if "api 1 h" in tm and "api 10 h" in tm:
            lines.append("| 10 h / 1 h | " + " | ".join(f"{tm['api 10 h'][k] / tm['api 1 h'][k]:.2f}"
                                                      for k in SIZES) + " |")  # fmt: skip
    return "\n".join(lines)


def _load() -> float:
    try:
        return float(open("/proc/loadavg").read().split()[0])
    except OSError:
        return math.nan


def main(argv: Optional[List[str]] = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=Path("/tmp/perf"), help="h1.npy, h10.npy (bench_fixed_costs)")
    ap.add_argument("--out", type=Path, default=None, help="JSON of every case and size")
    ap.add_argument("--time", action="store_true", help="also time the opening, the pre-pass and the API call")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--quick", action="store_true", help="a sixth of the simulated cases, no tests/data")
    ap.add_argument("--write", action="store_true", help="write the section of benches/RESULTS.md")
    ap.add_argument("--from-json", type=Path, default=None, help="report (and --write) a saved --out, run nothing")
    ap.add_argument("--only", default="", help="only the cases whose name holds this text")
    args = ap.parse_args(argv)
    if args.from_json:
        return _report(json.loads(args.from_json.read_text()), args.write)
    started = time.strftime("%Y-%m-%d %H:%M", time.gmtime())
    load0 = _load()
    results: List[Dict[str, Any]] = []

    def add(name: str, group: str, path: Path, okw: Dict[str, Any], akw: Dict[str, Any], truth: Dict[str, Any]) -> None:
        if args.only not in name:
            return
        t = time.perf_counter()
        per = run_case(path, okw, akw, SIZES)
        base = per[20]
        n = base.get("n", 0)
        r = {"name": name, "group": group, "n": n, "per_size": per, "truth": truth,
             "sampled": {k: n > (1 << k) for k in SIZES},
             "compare": {k: compare(base, per[k], truth) for k in SIZES[1:]},
             "truth_cmp": {k: against_truth(per[k], truth) for k in SIZES}}  # fmt: skip
        results.append(r)
        flag = ", ".join(f"2^{k}: {'+'.join(r['compare'][k]['categories'] + r['compare'][k]['numbers']) or '='}"
                         for k in SIZES[1:])  # fmt: skip
        print(f"{name:48s} n={n:>9d} {time.perf_counter() - t:5.1f} s  {flag}", flush=True)

    if not args.quick:
        for name, path, okw, akw in data_files():
            add(name, name.split("/")[0], path, okw, akw, {})
    with tempfile.TemporaryDirectory(prefix="prepass_sample_") as tmp:
        for name, writer in simulated(args.quick):
            if args.only not in name and not (name == "lift-off ends 60 min s0" and args.only in "tare min_fn"):
                continue
            path = Path(tmp) / "case.npy"
            kw, truth = writer(path)
            akw = kw.pop("analyze", {})
            add(name, "sim", path, kw, akw, truth)
            if name == "lift-off ends 60 min s0":
                for tname, tkw in TARE_CASES:
                    t2 = dict(truth)
                    if tname == "tare=none":  # fy's unloaded level stays in the friction
                        t2.pop("tare_fy", None)
                        t2.pop("value", None)
                    if tname == "min_fn=1":  # no tare found
                        t2 = {k: v for k, v in t2.items() if k not in ("tare_fy", "tare_fz", "min_fn", "value")}
                    add(f"{name}, {tname}", "sim", path, kw, tkw, t2)
            path.unlink()
        for name in ("h1", "h10"):
            p = args.data / f"{name}.npy"
            if p.exists():
                add(f"/tmp/perf {name}.npy (dynamic)", "sim", p, {"fs": FS, "names": PERF_NAMES}, {},
                    {"static": False, "motion": "unidirectional", "friction": "fy"})  # fmt: skip
        timing_out = None
        if args.time:
            static_path = Path(tmp) / "static1h.npy"
            static_liftoff(static_path, 3600.0, 0, "ends")
            timing_out = timing(args.data, static_path, args.rounds)
    o = {"started": started, "load": (load0, _load()), "results": results, "summary": summarise(results),
         "timing": timing_out, "rounds": args.rounds}  # fmt: skip
    if args.out:
        args.out.write_text(json.dumps(o, indent=1, default=str))
    _report(json.loads(json.dumps(o, default=str)), args.write)


def _report(o: Dict[str, Any], write: bool) -> None:
    """Prints the tables (of a run, or of its JSON: sizes as strings) and writes the section with ``write``."""
    for r in o["results"]:
        for key in ("per_size", "compare", "truth_cmp", "sampled"):
            r[key] = {int(k): v for k, v in r[key].items()}
    if o.get("timing"):
        o["timing"] = {key: {int(k): v for k, v in per.items()} for key, per in o["timing"].items()}
    o["summary"] = summarise(o["results"])
    text = report(o)
    print(text)
    if write:
        sys.path.insert(0, str(HERE))
        from _results import write_section

        write_section("The pre-pass's bounded sample (issue 38 point 2)", text)


if __name__ == "__main__":
    main()
