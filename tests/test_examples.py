"""Every script in examples/ runs on a fresh machine: in a temporary folder, in a subprocess, with a guard against a
hang, without test data or any file from outside the repository, and writes what its docstring promises."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
SCRIPTS = sorted(EXAMPLES.glob("*.py"))
#: Seconds for all the examples together (they run side by side).
#: A guard against a hanging script, not a speed target (speed lives in benches/; these machines are shared).
HANG = 600.0

#: What each example must print and write (file names under its output folder).
EXPECT = {
    "analyse_a_recording.py": (
        ["<Results: dynamic COF", "70 windows", "headline: COF", "95 % interval", "verdict:"],
        ["report.html", "windows.csv"],
    ),
    "running_in.py": (
        [
            "steady state from t = ",
            "verdict: steady state reached",
            "truth: t_steady = 300 s",
            "the truth lies in both 95 % intervals",
            "a test still running in at its end: no steady state",
            "an 80 s test: too short",
        ],
        ["cof_vs_time.png", "steady_state.json"],
    ),
    "operating_ranges.py": (
        ["temperature: verdict 'optimum'", "current density: verdict 'optimum'", "°C", "A/mm²"],
        ["cof_vs_temperature.png", "cof_vs_current_density.png"],
    ),
    "stribeck_curve.py": (
        [
            "headline: COF",
            "speed: verdict 'optimum'",
            "lower breakpoint",
            "95 % interval",
            "(inside the optimum with its 95 % intervals)",
            "from the speed log: optimum",
        ],
        ["stribeck_curve.png"],
    ),
    "compare_replicates.py": (
        ["mean COF", "95 % interval", "over 8 tests (per-stroke means)", "repeatability s_r", "Mandel's h"],
        ["compare.png", "compare.csv"],
    ),
    "uncertainty_budget.py": (
        [
            "unidirectional: COF",
            "(95 %, instrument and statistics)",
            "(truth 0.100: outside)",
            "misalignment_deg",
            "cancelled by the forward/backward mean",
            "exit status 0",
        ],
        ["calibration.toml", "report/report.html"],
    ),
    "watch_running_test.py": (
        ["(so far): COF", "(complete file): COF", "watch ended: trip", "trip 'cof>0.3 for 5s' at t = 122.5 s"],
        ["run.csv"],
    ),
    "stick_slip.py": (
        ["forward strokes: static COF", "kinetic COF", "stick-slip present: 156 events", "Hz"],
        ["strokes.csv", "stick_slip.png"],
    ),
}


def test_every_example_is_tested():
    assert SCRIPTS, "no examples"
    assert sorted(p.name for p in SCRIPTS) == sorted(EXPECT)


def test_examples_use_no_shared_data():
    for p in SCRIPTS:
        text = p.read_text(encoding="utf-8")
        assert "shared" not in text and "data/real" not in text, p.name  # a user has the package, not the tests


def test_examples_run(tmp_path):
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONWARNINGS": "error::DeprecationWarning:tribodyn"}
    start = time.perf_counter()
    procs = {}
    for p in SCRIPTS:
        cwd = tmp_path / p.stem
        cwd.mkdir()
        procs[p.name] = (
            cwd,
            subprocess.Popen(
                [sys.executable, str(p), "out"],
                cwd=cwd,
                env=env,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
                encoding="utf-8",
            ),
        )
    failures = []
    for name, (cwd, proc) in procs.items():
        try:
            out, err = proc.communicate(timeout=max(1.0, HANG - (time.perf_counter() - start)))
        except subprocess.TimeoutExpired:
            proc.kill()
            out, err = proc.communicate()
            failures.append(f"{name}: timed out\n{err[-2000:]}")
            continue
        if proc.returncode != 0:
            failures.append(f"{name}: exit status {proc.returncode}\n{err[-3000:]}")
            continue
        texts, files = EXPECT[name]
        failures += [f"{name}: {t!r} not printed\n{out}" for t in texts if t not in out]
        failures += [f"{name}: {f} not written" for f in files if not (cwd / "out" / f).is_file()]
    elapsed = time.perf_counter() - start
    print(f"examples: {len(procs)} scripts in {elapsed:.1f} s")
    assert not failures, "\n\n".join(failures)
