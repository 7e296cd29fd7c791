"""Shared test configuration: hypothesis profiles, a fixture that restores the thread setting, and the
simulated temperature and current-density tests with their analyses (module-scoped; a module may define
its own under the same names, with other seeds).

"ci" (loaded when the CI environment variable is set): few examples, no
deadline, derandomized so a CI run is reproducible. "dev" otherwise: more
examples, random seeds, still no deadline (the first call of a kernel may
spin up the thread pool, which would trip a per-example deadline).
"""

from __future__ import annotations

import os

import pytest
from hypothesis import settings

import tribodyn as td
from tribodyn import simulate

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
