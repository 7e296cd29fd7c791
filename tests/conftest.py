"""Shared test configuration: hypothesis profiles, a fixture that restores the thread setting, the
simulated temperature and current-density tests with their analyses (module-scoped; a module may define
its own under the same names, with other seeds), and the command-line runs several tests read (the demo,
a simulated recording analysed), made once per session: the tests only read what they wrote.

"ci" (loaded when the CI environment variable is set): few examples, no
deadline, derandomized so a CI run is reproducible. "dev" otherwise: more
examples, random seeds, still no deadline (the first call of a kernel may
spin up the thread pool, which would trip a per-example deadline).
"""

from __future__ import annotations

import contextlib
import io
import os
from pathlib import Path
from typing import Tuple

# BLAS on one thread, set before NumPy loads (and inherited by the CLI subprocesses): OpenBLAS's
# threads spin on the small matrix products of the operating-range bootstrap when the cores are
# busy (the suite's own kernels, other jobs): one operating_range took 56 s instead of 5 s on the
# 2-core machine. Results do not depend on it.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import pytest  # noqa: E402
import tribodyn as td  # noqa: E402
from hypothesis import settings  # noqa: E402
from tribodyn import simulate  # noqa: E402


settings.register_profile("ci", max_examples=40, deadline=None, derandomize=True)
settings.register_profile("dev", max_examples=100, deadline=None)
settings.load_profile("ci" if os.environ.get("CI") else "dev")


@pytest.fixture
def restore_threads():
    """Puts the process-wide thread setting back as it was (0 = all cores, if it was that); yields the core count."""
    before = td.get_threads()
    td.set_threads(0)
    all_cores = td.get_threads()
    td.set_threads(before)
    yield all_cores
    td.set_threads(0 if before == all_cores else before)
    assert td.get_threads() == before


@pytest.fixture(scope="module")
def temp_sim() -> simulate.Simulation:
    return simulate.temperature_test(seed=3)


@pytest.fixture(scope="module")
def temp_res(temp_sim: simulate.Simulation) -> td.Results:
    return td.analyze(temp_sim.channels, fs=temp_sim.fs, window=2.0, hop=10.0, temperature=temp_sim.temperature_log)


@pytest.fixture(scope="module")
def cd_sim() -> simulate.Simulation:
    return simulate.current_density_test(seed=4)


@pytest.fixture(scope="module")
def cd_res(cd_sim: simulate.Simulation) -> td.Results:
    return td.analyze(cd_sim.channels, fs=cd_sim.fs, window=2.0, hop=10.0, area_mm2=cd_sim.area_mm2)


@pytest.fixture(scope="session")
def demo_run(tmp_path_factory: pytest.TempPathFactory) -> Tuple[Path, str]:
    """``tribodyn demo --out DIR`` once for the session: (DIR, what it printed on stdout)."""
    from tribodyn.app import cli

    out = tmp_path_factory.mktemp("demo") / "out"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert cli.main(["demo", "--out", str(out)]) == 0
    return out, printed.getvalue()


@pytest.fixture(scope="session")
def cd_cli_run(tmp_path_factory: pytest.TempPathFactory) -> Tuple[Path, Path]:
    """``tribodyn simulate current_density`` to HDF5, then ``tribodyn analyze --area 1``: (recording, output folder)."""
    from tribodyn.app import cli

    where = tmp_path_factory.mktemp("cd_cli")
    rec, out = where / "sim.h5", where / "out"
    assert cli.main(["simulate", "current_density", "--out", str(rec), "--quiet"]) == 0
    assert cli.main(["analyze", str(rec), "--out", str(out), "--area", "1", "--quiet"]) == 0
    return rec, out
