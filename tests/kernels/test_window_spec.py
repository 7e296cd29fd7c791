"""The kernel's frozen settings (``tribodyn._core.WindowSpec``) and the binding's one error map.

A spec is checked and converted once, when it is made: a bad setting is a
``ValueError`` or ``TypeError`` there (never a panic, never later inside a
window call), and the spec cannot be changed afterwards. A NaN or inf in a
window comes out of the binding already named in the recording's terms
(role, window, time) when the spec says how (``naming``).
"""

from __future__ import annotations

import numpy as np
import pytest
import tribodyn as td
from hypothesis import given, settings
from hypothesis import strategies as st
from tribodyn import _core
from tribodyn.columns import kernel_columns
from tribodyn.kernels.deadband import parse_deadband
from tribodyn.kernels.window_stats import compute, make_spec

COLS = list(kernel_columns(False))


def _spec(**kw):
    args = dict(length=50, deadband=("force", 0.35), n_bins=4, columns=COLS)
    args.update(kw)
    return _core.WindowSpec(args.pop("length"), args.pop("deadband"), args.pop("n_bins"), args.pop("columns"), **args)


def _forces(n=400, seed=0):
    rng = np.random.default_rng(seed)
    fz = 2.0 + np.sin(np.arange(n) * 0.3) + 0.1 * rng.standard_normal(n)
    return 0.3 * fz + 0.01 * rng.standard_normal(n), fz


@pytest.mark.fast
def test_spec_is_frozen():
    spec = _spec()
    for name, value in [("length", 3), ("n_bins", 2), ("columns", ["n"]), ("threads", 1), ("anything", 1)]:
        with pytest.raises(AttributeError):
            setattr(spec, name, value)
    assert spec.length == 50 and spec.n_bins == 4 and spec.columns == COLS and spec.deadband == ("force", 0.35)
    assert not spec.raw
    # The columns it hands out are a copy: changing them changes nothing.
    spec.columns.append("n")
    assert spec.columns == COLS


@pytest.mark.fast
def test_replace_makes_a_new_spec():
    spec = _spec()
    longer = spec.replace(length=80, threads=1)
    assert (spec.length, longer.length, longer.threads) == (50, 80, 1)
    assert longer.columns == spec.columns and longer.deadband == spec.deadband
    fy, fz = _forces()
    starts = np.array([0, 100, 300], dtype=np.int64)
    a = compute(longer, fy, fz, starts)
    b = compute(_spec(length=80, threads=1), fy, fz, starts)
    for key in COLS:
        assert a[key].tobytes() == b[key].tobytes(), key
    assert compute(spec, fy, fz, starts)["n"].tolist() == [50, 50, 50]


BAD = [
    (dict(length=0), ValueError, "at least 1 sample"),
    (dict(n_bins=0), ValueError, r"n_bins must be in \[1, "),
    (dict(n_bins=2**21), ValueError, r"n_bins must be in \[1, "),
    (dict(deadband=("bogus", 0.35)), ValueError, "deadband kind must be 'force' or 'sigma'"),
    (dict(deadband=0.35), TypeError, "deadband"),
    (dict(columns=["n", "bogus"]), ValueError, 'unknown kernel column "bogus"'),
    (dict(columns="n"), TypeError, "columns"),
    (dict(options=dict(lagg=3)), TypeError, 'unknown kernel option "lagg"'),
    (dict(options=dict(lag="x")), ValueError, 'kernel option "lag" must be'),
    (dict(options=dict(lag=-1)), ValueError, 'kernel option "lag" must be'),
    (dict(columns=["n", "spec"]), ValueError, "the column 'spec' needs 1 to"),
    (dict(columns=["n", "spec"], options=dict(lines=[0.7])), ValueError, "line frequency"),
    (dict(columns=["n", "ext"]), ValueError, "instrument lag must be at least 1"),
    (dict(columns=["mu_classical"]), ValueError, "classical"),
    (dict(options=dict(delay=float("nan"))), ValueError, "delay"),
    (dict(highpass=(np.zeros((2, 6)), np.zeros((3, 2)))), ValueError, r"zi must have shape \(2, 2\)"),
    (dict(highpass=(np.zeros((2, 5)), np.zeros((2, 2)))), ValueError, "sos must have shape"),
    (dict(threads=0), ValueError, r"threads must be in \[1, "),
    (dict(threads=-3), ValueError, r"threads must be in \[1, "),
    (dict(naming=("i", 0.0)), ValueError, "fs must be finite and > 0"),
    (dict(naming=("i", float("inf"))), ValueError, "fs must be finite and > 0"),
]


@pytest.mark.fast
@pytest.mark.parametrize("kw, exc, match", BAD, ids=[str(sorted(b[0])) + str(i) for i, b in enumerate(BAD)])
def test_bad_spec_arguments_are_clear_errors(kw, exc, match):
    with pytest.raises(exc, match=match):
        _spec(**kw)


@pytest.mark.fast
def test_bad_replace_arguments():
    spec = _spec(naming=("aux", 100.0))
    with pytest.raises(ValueError, match="at least 1 sample"):
        spec.replace(length=0)
    with pytest.raises(ValueError, match=r"threads must be in \[1, "):
        spec.replace(threads=0)
    with pytest.raises(TypeError):
        spec.replace(50)  # keyword-only


@pytest.mark.fast
def test_calls_take_a_spec_only():
    fy, fz = _forces()
    with pytest.raises(TypeError):
        _core.windows_stats(None, None, fy, fz, None, np.zeros(1, dtype=np.int64))
    with pytest.raises(TypeError):
        _core.windows_stats(("force", 0.35), None, fy, fz, None, np.zeros(1, dtype=np.int64))


@pytest.mark.fast
def test_make_spec_from_a_deadband():
    spec = make_spec(40, parse_deadband("0.7sigma"), 8, raw=True)
    assert spec.deadband == ("sigma", 0.7) and spec.columns == list(kernel_columns(True)) and spec.length == 40


# -- NaN and inf: named by the binding ----------------------------------------------------------------------------


@settings(max_examples=60, deadline=None)
@given(
    fs=st.floats(0.1, 1e7, allow_nan=False),
    at=st.integers(0, 349),
    role=st.sampled_from(["i", "u"]),
    channel=st.sampled_from(["fy", "fz", "aux", "fy_raw", "fz_raw", "fx"]),
)
def test_non_finite_named_by_role_window_and_time(fs, at, role, channel):
    fy, fz = _forces()
    ch = {"fy": fy, "fz": fz, "fx": fz.copy(), "aux": fz.copy(), "fy_raw": fy.copy(), "fz_raw": fz.copy()}
    ch[channel] = ch[channel].copy()
    ch[channel][at] = np.nan
    starts = np.arange(0, 350, 50, dtype=np.int64)
    spec = make_spec(50, parse_deadband(0.35), 4, raw=True, naming=("aux", fs)).replace(aux=role)
    offset = 1000
    with pytest.raises(_core.NonFiniteError) as info:
        compute(spec, ch["fy"], ch["fz"], starts, fx=ch["fx"], aux=ch["aux"],
                raw=(ch["fy_raw"], ch["fz_raw"]), offset=offset)  # fmt: skip
    # The first window (in start order) holding the sample, counted from offset.
    first = offset + int(starts[(starts <= at) & (at < starts + 50)][0])
    want_role = {"aux": role}.get(channel, channel.removesuffix("_raw"))
    assert str(info.value) == f"{want_role} contains NaN or inf in the window starting at sample {first} " \
                              f"(t = {first / fs:g} s)"  # fmt: skip
    assert (info.value.channel, info.value.sample, info.value.window) == (want_role, first, True)
    assert info.value.args == (str(info.value),)


@pytest.mark.fast
def test_non_finite_without_naming_is_in_the_kernels_words():
    fy, fz = _forces()
    aux = fz.copy()
    aux[120] = np.inf
    with pytest.raises(_core.NonFiniteError) as info:
        compute(make_spec(50, parse_deadband(0.35), 4), fy, fz, np.array([100]), aux=aux, offset=7)
    assert str(info.value) == "aux contains NaN or inf in the window starting at sample 107"
    assert (info.value.channel, info.value.sample, info.value.window) == ("aux", 107, True)


@pytest.mark.parametrize("threads", [1, 2])
def test_raw_nan_has_one_message_on_every_route(tmp_path, threads):
    """A NaN in raw forces stops the high-pass: the file kernel (named by the binding) and the stream route
    (named in Python) say the same."""
    from tribodyn.kernels.filters import HighPass

    sim = td.simulate.conditions(30, mu=0.3, seed=5, raw=True)
    a = np.stack([sim.channels["fy"], sim.channels["fz"]])
    a[1, 12_345] = np.nan
    path = tmp_path / "raw.npy"
    np.save(path, a)
    want = (
        r"^fz contains NaN or inf at sample 12345 \(t = "
        + f"{12_345 / sim.fs:g}"
        + r" s; the high-pass filter needs every sample\)$"
    )
    length = int(round(2.0 * sim.fs))
    hp = HighPass(sim.fs, cutoff=0.5)
    spec = make_spec(length, parse_deadband(0.35), 16, raw=True, threads=threads,
                     highpass=(hp.sos, hp.steady_state), naming=("aux", sim.fs))  # fmt: skip
    with td.open_recording(path, fs=sim.fs, names=["fy", "fz"]) as rec:
        fd, layout = rec.file_layout(["fy", "fz"])[:2]
        n = rec.n_samples
        with pytest.raises(_core.NonFiniteError, match=want):
            _core.windows_stats_file(spec, fd, (None, layout["fy"], layout["fz"], None), n, (0, n // length, length))
    with pytest.raises(ValueError, match=want):
        td.analyze({"fy": a[0], "fz": a[1]}, fs=sim.fs, window=2.0, hop=2.0, highpass=0.5, threads=threads)
