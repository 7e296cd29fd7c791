"""One channel, one role (issue 21 point 4): a caller's map never binds one channel to two roles."""

from __future__ import annotations


import numpy as np
import pytest

import tribodyn as td
from tribodyn.io import RecordingError


def _csv(path, columns):
    """A plain CSV with a time column at 100 Hz and the given columns (name -> array)."""
    n = len(next(iter(columns.values())))
    t = np.arange(n) / 100.0
    rows = np.column_stack([t, *columns.values()])
    np.savetxt(path, rows, delimiter=",", header=",".join(["time", *columns]), comments="", fmt="%.6f")
    return path


def _unidirectional(n=3000, mu=0.3, seed=0):
    rng = np.random.default_rng(seed)
    fz = 200.0 + 2.0 * rng.standard_normal(n)
    friction = mu * fz * (1 + 0.03 * rng.standard_normal(n))
    return friction, fz, rng


def test_a_user_map_binding_one_channel_to_two_roles_is_refused(tmp_path):
    friction, fz, rng = _unidirectional(seed=9)
    p = _csv(tmp_path / "run.csv", {"Fx": friction, "Fy": rng.standard_normal(fz.size), "Fz": fz})
    with pytest.raises(ValueError, match=r"channel 'Fx' is bound to both 'fx' and 'fy'"):
        td.open_recording(p, channels={"fx": "Fx", "fy": "Fx"})
    assert issubclass(RecordingError, ValueError)
    pd = pytest.importorskip("pandas")
    df = pd.DataFrame({"Fx": friction, "Fz": fz})
    with pytest.raises(ValueError, match="bound to both"):
        td.analyze(df, fs=100.0, channels={"fy": "Fx", "fx": "Fx", "fz": "Fz"})


def test_mapping_fy_takes_the_channel_from_the_default_fx(tmp_path):
    """The audit's double binding: --map fy=Fx on a file whose names gave fx <- Fx."""
    friction, fz, rng = _unidirectional(seed=10)
    p = _csv(tmp_path / "run.csv", {"Fx": friction, "Fy": rng.standard_normal(fz.size), "Fz": fz})
    rec = td.open_recording(p, channels={"fy": "Fx"})
    assert rec.roles == {"fy": "Fx", "fz": "Fz"}
    assert rec.roles_given == {"fy": "Fx"}
