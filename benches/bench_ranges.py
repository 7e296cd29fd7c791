"""Operating ranges at hops of 10, 5 and 2 s of one recording, against the simulator's truth (docs/method.md 7).

Issue 35 point 2. Each seed simulates one recording per case (``tribodyn.simulate``, section 8), analyses it
with 10 s windows at hops of 10, 5 and 2 s (the windows overlap 1, 2 and 5 times) and fits
:func:`tribodyn.operating_range` (default settings, 400 resamples) at each hop:

- ``T``: the temperature test with a running-in on its 155 degC start plateau (``running_in=0.3``: the COF
  starts 30 % high and decays with a time constant of 150 s). Truth: heating optimum 135-160 degC, cooling
  135-155 degC, floor 0.100, hysteresis of the upper edge 5 degC; the running-in is no wall.
- ``F``: the same temperature path with a COF of 0.100 that does not depend on it (``model="flat"``; no
  running-in): every wall is false. Only the verdicts are kept (no bootstrap).
- ``J``: the current-density test (steps of 0.5 A/mm^2 every 70 s, contact lost from 632 s). Truth: optimum
  4.25-4.75 A/mm^2, floor 0.100, instability onset 6.5 A/mm^2 (the last step).

Per recording and hop it keeps the verdicts, breakpoints, floors, their intervals, the hysteresis and the
instability onset (``--out``: one JSON line each); ``--table`` prints the counts of docs/method.md 7 from such
files (coverage: the recordings whose 95 % interval holds the truth; agreement: the recordings whose verdict
is the same at all three hops, and those whose every wall at each hop lies in its interval at the other hops;
each count with the 95 % Clopper-Pearson interval of its rate).

Run: ``python benches/bench_ranges.py --seeds 0:40 --out ranges.jsonl`` then
``python benches/bench_ranges.py --table ranges.jsonl``.
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any, Dict, List, Optional

import numpy as np
import tribodyn as td
from tribodyn import simulate

WINDOW = 10.0
HOPS = (10.0, 5.0, 2.0)
RUNNING_IN = 0.3
TRUTH = {
    "heating": (135.0, 160.0),
    "cooling": (135.0, 155.0),
    "hysteresis": 5.0,
    "mu_min": 0.100,
    "J": (4.25, 4.75),
    "onset": 6.5,
}


def _fit(f: Any) -> Dict[str, Any]:
    keys = ("verdict", "family", "lower", "lower_ci", "upper", "upper_ci", "mu_min", "mu_min_ci", "optimum")
    return {k: getattr(f, k) for k in keys}


def run_t(seed: int) -> List[Dict[str, Any]]:
    sim = simulate.temperature_test(seed=1000 + seed, running_in=RUNNING_IN)
    out = []
    for hop in HOPS:
        res = td.analyze(sim.channels, fs=sim.fs, window=WINDOW, hop=hop, temperature=sim.temperature_log, threads=1)
        o = td.operating_range(res, "temperature")
        h = o.hysteresis
        out.append(dict(case="T", seed=seed, hop=hop, n=o.n_windows, excluded=o.excluded,
                        fits={k: _fit(f) for k, f in o.fits.items()},
                        hysteresis=None if h is None else dict(upper=h.upper, upper_ci=h.upper_ci)))  # fmt: skip
    return out


def run_f(seed: int) -> List[Dict[str, Any]]:
    sim = simulate.temperature_test(seed=1000 + seed, model="flat")
    out = []
    for hop in HOPS:
        res = td.analyze(sim.channels, fs=sim.fs, window=WINDOW, hop=hop, temperature=sim.temperature_log, threads=1)
        o = td.operating_range(res, "temperature", n_boot=0)
        out.append(dict(case="F", seed=seed, hop=hop, fits={k: {"verdict": f.verdict} for k, f in o.fits.items()}))
    return out


def run_j(seed: int) -> List[Dict[str, Any]]:
    sim = simulate.current_density_test(seed=1000 + seed)
    out = []
    for hop in HOPS:
        res = td.analyze(sim.channels, fs=sim.fs, window=WINDOW, hop=hop, area_mm2=sim.area_mm2, threads=1)
        o = td.operating_range(res, "current_density")
        lost = np.char.find(np.asarray(res["reasons"]).astype(str), "contact loss") >= 0
        clear = ~sim.truth.in_contact_loss(res["time"], WINDOW / 2)
        out.append(dict(case="J", seed=seed, hop=hop, n=o.n_windows, excluded=o.excluded, fit=_fit(o.fits["all"]),
                        instability=o.instability, instability_ci=o.instability_ci,
                        false_loss=int((lost & clear).sum())))  # fmt: skip
    return out


def _holds(ci: Optional[List[float]], v: float) -> bool:
    return ci is not None and ci[0] <= v <= ci[1]


def _pct(k: int, n: int) -> str:
    """k of n with the 95 % Clopper-Pearson interval of the rate (``_results.clopper_pearson``)."""
    from _results import clopper_pearson  # benches/ is on the path of a script run from it

    return clopper_pearson(k, n)


def table(rows: List[Dict[str, Any]]) -> str:
    """The markdown table of the JSON lines ``rows`` (module docstring)."""
    by = {(r["case"], r["seed"], r["hop"]): r for r in rows}
    out = ["| case | quantity (truth) | " + " | ".join(f"hop {h:g} s" for h in HOPS) + " |",
           "|---|---|" + "---|" * len(HOPS)]  # fmt: skip
    for case, lines in (("T", _t_lines), ("F", _f_lines), ("J", _j_lines)):
        seeds = sorted({s for c, s, _ in by if c == case and all((c, s, h) in by for h in HOPS)})
        if not seeds:
            continue
        per = {h: [by[(case, s, h)] for s in seeds] for h in HOPS}
        for name, fn in lines():
            out.append(f"| {case} | {name} | " + " | ".join(fn(per[h]) for h in HOPS) + " |")
        agree = _agreement(case, seeds, by)
        out.append(f"| {case} | verdicts the same at hops 10, 5 and 2 s | {agree} | | |")
        if case != "F":
            walls = _pct(sum(_walls_agree(case, [by[(case, s, h)] for h in HOPS]) for s in seeds), len(seeds))
            out.append(f"| {case} | every wall at each hop within its interval at the other hops | {walls} | | |")
    return "\n".join(out)


def _agreement(case: str, seeds: List[int], by: Dict[Any, Dict[str, Any]]) -> str:
    def key(r: Dict[str, Any]) -> Any:
        if case in "TF":
            return tuple(r["fits"][b]["verdict"] if b in r["fits"] else None for b in ("all", "heating", "cooling"))
        return r["fit"]["verdict"], r["instability"] is not None

    same = sum(len({key(by[(case, s, h)]) for h in HOPS}) == 1 for s in seeds)
    return _pct(same, len(seeds))


def _walls_agree(case: str, rs: List[Dict[str, Any]]) -> bool:
    """Every breakpoint (and the instability onset) found at one hop lies in its interval at each other hop."""
    fits = [r["fits"] for r in rs] if case == "T" else [{"all": r["fit"]} for r in rs]
    for a in range(len(rs)):
        for b in range(len(rs)):
            for branch, f in fits[a].items():
                for side in ("lower", "upper"):
                    g = fits[b].get(branch)
                    if f[side] is None or g is None or not _holds(g[f"{side}_ci"], f[side]):
                        if f[side] is not None:
                            return False
            if case == "J" and not (
                rs[a]["instability"] is None or _holds(rs[b]["instability_ci"], rs[a]["instability"])
            ):
                return False
    return True


def _t_lines() -> List[Any]:
    def cover(branch: str, side: str, truth: float) -> Any:
        return lambda rs: _pct(sum(_holds(r["fits"][branch][f"{side}_ci"], truth) for r in rs), len(rs))

    def mean(branch: str, side: str) -> Any:
        def f(rs: List[Dict[str, Any]]) -> str:
            v = [r["fits"][branch][side] for r in rs if r["fits"][branch][side] is not None]
            return f"{np.mean(v):.{4 if side == 'mu_min' else 2}f} ({len(v)})" if v else "-"

        return f

    def verdict(branch: str) -> Any:
        return lambda rs: _pct(sum(r["fits"][branch]["verdict"] == "optimum" for r in rs), len(rs))

    def narrow(rs: List[Dict[str, Any]]) -> str:
        k = sum(any(f["optimum"] is not None and f["optimum"][1] - f["optimum"][0] < 10 for f in r["fits"].values())
                for r in rs)  # fmt: skip
        return _pct(k, len(rs))

    def hyst(rs: List[Dict[str, Any]]) -> str:
        return _pct(sum(r["hysteresis"] is not None and _holds(r["hysteresis"]["upper_ci"], TRUTH["hysteresis"])
                        for r in rs), len(rs))  # fmt: skip

    def hyst_mean(rs: List[Dict[str, Any]]) -> str:
        v = [r["hysteresis"]["upper"] for r in rs if r["hysteresis"] and r["hysteresis"]["upper"] is not None]
        return f"{np.mean(v):.2f}" if v else "-"

    return [
        ("heating verdict 'optimum' (both walls)", verdict("heating")),
        ("cooling verdict 'optimum'", verdict("cooling")),
        ("an optimum under 10 degC wide (false wall)", narrow),
        ("heating lower edge: mean (n)", mean("heating", "lower")),
        ("heating lower edge in its interval (135)", cover("heating", "lower", 135.0)),
        ("heating upper edge: mean (n)", mean("heating", "upper")),
        ("heating upper edge in its interval (160)", cover("heating", "upper", 160.0)),
        ("cooling upper edge: mean (n)", mean("cooling", "upper")),
        ("cooling upper edge in its interval (155)", cover("cooling", "upper", 155.0)),
        ("heating floor: mean", mean("heating", "mu_min")),
        ("heating floor in its interval (0.100)", cover("heating", "mu_min", TRUTH["mu_min"])),
        ("hysteresis (upper): mean", hyst_mean),
        ("hysteresis in its interval (5.0)", hyst),
    ]


def _f_lines() -> List[Any]:
    def count(what: str) -> Any:
        def f(rs: List[Dict[str, Any]]) -> str:
            k = sum(any(v["verdict"] != "no dependence" if what == "wall" else v["verdict"] == "optimum"
                        for v in r["fits"].values()) for r in rs)  # fmt: skip
            return _pct(k, len(rs))

        return f

    return [
        ("a false wall on some branch (all, heating, cooling)", count("wall")),
        ("a false optimum (both walls) on some branch", count("optimum")),
    ]


def _j_lines() -> List[Any]:
    def cover(side: str, truth: float) -> Any:
        return lambda rs: _pct(sum(_holds(r["fit"][f"{side}_ci"], truth) for r in rs), len(rs))

    def mean(key: str) -> Any:
        def f(rs: List[Dict[str, Any]]) -> str:
            v = [r["fit"][key] if key in r["fit"] else r[key] for r in rs]
            v = [x for x in v if x is not None]
            return f"{np.mean(v):.3f} ({len(v)})" if v else "-"

        return f

    return [
        ("verdict 'optimum'", lambda rs: _pct(sum(r["fit"]["verdict"] == "optimum" for r in rs), len(rs))),
        ("lower edge: mean (n)", mean("lower")),
        ("lower edge in its interval (4.25)", cover("lower", 4.25)),
        ("upper edge: mean (n)", mean("upper")),
        ("upper edge in its interval (4.75)", cover("upper", 4.75)),
        ("floor in its interval (0.100)", cover("mu_min", TRUTH["mu_min"])),
        ("instability onset: mean (n)", mean("instability")),
        ("onset in its interval (6.5)", lambda rs: _pct(sum(_holds(r["instability_ci"], 6.5) for r in rs), len(rs))),
        ("recordings with 'contact loss' clear of it", lambda rs: _pct(sum(r["false_loss"] > 0 for r in rs), len(rs))),
    ]


def _read(paths: List[str]) -> List[Dict[str, Any]]:
    return [json.loads(line) for path in paths for line in open(path) if line.strip()]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0:40", help="seeds a:b (recording seeds 1000 + k; default 0:40)")
    ap.add_argument("--cases", default="TFJ", help="any of T, F and J (default TFJ)")
    ap.add_argument("--out", help="append one JSON line per recording and hop to this file")
    ap.add_argument("--table", nargs="*", help="print the table of these JSON-lines files and stop")
    ap.add_argument("--before", nargs="*", help="with --table: the same cases measured before, printed first")
    ap.add_argument("--write", action="store_true", help="with --table: write the section of benches/RESULTS.md")
    ns = ap.parse_args()
    if ns.table is not None:
        body = ""
        if ns.before:
            body = "Before (tribodyn before issue 35 point 2):\n\n" + table(_read(ns.before)) + "\n\nAfter:\n\n"
        body += table(_read(ns.table))
        print(body)
        if ns.write:
            from _results import write_section

            intro = (f"`python benches/bench_ranges.py --seeds 0:40`: one recording per seed and case, {WINDOW:g} s "
                     "windows at hops of 10, 5 and 2 s (docs/method.md 7). Counts k/n with the 95 % Clopper-Pearson "
                     "interval of the rate.")  # fmt: skip
            write_section("Operating ranges at hops of 10, 5 and 2 s (issue 35 point 2), 2026-11-27",
                          intro + "\n\n" + body)  # fmt: skip
        return
    a, b = (int(v) for v in ns.seeds.split(":"))
    start = time.perf_counter()
    for seed in range(a, b):
        for case in ns.cases:
            rows = run_t(seed) if case == "T" else run_f(seed) if case == "F" else run_j(seed)
            if ns.out:
                with open(ns.out, "a") as fh:
                    for r in rows:
                        fh.write(json.dumps(r, default=float) + "\n")
        print(f"seed {seed} done ({time.perf_counter() - start:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
