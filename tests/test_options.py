"""The options declared once (tribodyn.options, issue 22 point 1) and the public frozen Plan (point 2).

Every place that names an option is generated from ``OPTIONS`` or checked
against it here: ``analyze``'s signature and docstring, ``make_plan``, the
``Plan``'s fields, ``Results.params``, the command line's flags and
``--config`` keys, the README's table and docs/method.md's sections.
"""

from __future__ import annotations

import dataclasses
import inspect
import re
from pathlib import Path

import numpy as np
import pytest
import tribodyn as td
from tribodyn import simulate
from tribodyn.app import cli
from tribodyn.options import OPTIONS, defaults, markdown_table, option

ROOT = Path(__file__).resolve().parents[1]


FS = 1000.0


@pytest.fixture(scope="module")
def channels() -> dict:
    parts = list(simulate.continuous(120.0, current=4.0, seed=3))
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


@pytest.mark.fast
def test_analyze_signature_is_the_declaration() -> None:
    sig = inspect.signature(td.analyze)
    names = list(sig.parameters)
    assert names[:2] == ["source", "plan"]
    assert names[2:] == [o.name for o in OPTIONS]
    for o in OPTIONS:
        p = sig.parameters[o.name]
        assert p.kind is inspect.Parameter.KEYWORD_ONLY, o.name
        assert p.default == o.default, o.name


@pytest.mark.fast
def test_analyze_docstring_documents_every_option() -> None:
    doc = td.analyze.__doc__ or ""
    params = doc[doc.index("Parameters") : doc.index("Returns")]
    documented = set(re.findall(r"^    ([a-z_0-9, ]+?)(?: :|$)", params, flags=re.M))
    names = {n.strip() for line in documented for n in line.split(",")}
    missing = [o.name for o in OPTIONS if o.name not in names]
    assert not missing, f"analyze's docstring lacks {missing}"


@pytest.mark.fast
def test_analyze_docstring_entries_are_written_from_the_declaration() -> None:
    """Issue 33 point 3: each option's entry (``name : type`` and its text) comes from OPTIONS, in its order,
    after the hand-written source and plan; the rest of the docstring (numpydoc sections) stays as written."""
    from tribodyn.options import doc_type, parameters_doc

    doc = inspect.cleandoc(td.analyze.__doc__ or "")
    params = doc[doc.index("Parameters\n----------\n") : doc.index("\nReturns\n-------\n")]
    heads = re.findall(r"^(\w+) : (.+)$", params, flags=re.M)
    assert [h for h, _ in heads] == ["source", "plan"] + [o.name for o in OPTIONS]
    assert dict(heads)["stop"] == doc_type(option("stop")) == "int, optional"
    assert inspect.cleandoc("    x\n" + parameters_doc())[2:] in doc  # the generated entries, as generated
    assert "[each option" not in doc  # the placeholder was replaced
    assert max(map(len, parameters_doc().splitlines())) <= 80  # as help() shows it
    bare = dataclasses.replace(option("progress"), detail="", doc_type="")  # an option declared without them
    assert doc_type(bare) == "bool"
    assert doc_type(dataclasses.replace(bare, default=None, cli_type="float")) == "float, optional"


@pytest.mark.fast
def test_plan_params_record_every_field_as_declared() -> None:
    """Plan.params() records each field as it is under its own name unless plan.RECORDED says otherwise."""
    import json

    from tribodyn.pipeline.plan import PLAN_FIELDS, RECORDED

    assert set(RECORDED) <= PLAN_FIELDS, sorted(set(RECORDED) - PLAN_FIELDS)
    log = (np.array([0.0, 60.0]), np.array([100.0, 110.0]))
    plan = td.make_plan(fs=FS, tare={"fy": 0.1, "fz": 0.2}, temperature=log, current=2.0, area_mm2=1.5,
                        covariates={"speed": log}, uncertainty={"fy_rel": 0.01}, chunk=3.0)  # fmt: skip
    params = plan.params()
    for f in dataclasses.fields(td.Plan):
        if f.name not in RECORDED:
            assert params[f.name] == getattr(plan, f.name), f.name
    assert params["window_samples"] == plan.length and params["chunk_samples"] == 3000
    assert params["temperature_log_points"] == 2 and params["covariate_logs"] == {"speed": 2}
    assert params["tare"] == {"fy": 0.1, "fz": 0.2} and params["deadband"] == "0.35 N"
    assert not {"motion", "min_fn", "lines", "window_note"} & set(params)  # the pre-pass records its own
    json.dumps(params)  # provenance: plain values only


@pytest.mark.fast
def test_report_units_come_from_the_declaration() -> None:
    from tribodyn.app.report import PARAM_UNITS

    for o in OPTIONS:
        if o.unit:
            assert PARAM_UNITS[o.name] == o.unit, o.name


@pytest.mark.fast
def test_every_section_exists_in_method_md() -> None:
    text = (ROOT / "docs" / "method.md").read_text(encoding="utf-8")
    sections = set(re.findall(r"^## (\d+[a-z]?)\.", text, flags=re.M))
    assert {o.section for o in OPTIONS} <= sections


@pytest.mark.fast
def test_make_plan_takes_the_declared_defaults() -> None:
    plan = td.make_plan(fs=1000.0)
    assert (plan.window, plan.hop) == (2.0, 10.0)
    assert plan.n_bins == option("n_bins").default
    assert plan.orientation == option("orientation").default
    assert plan.stroke_fraction == option("stroke_fraction").default
    assert plan.motion == option("motion").default
    assert float(plan.deadband.value) == option("deadband").default
    with pytest.raises(TypeError, match="unknown option.*'windw'"):
        td.make_plan(fs=1000.0, windw=2.0)
    with pytest.raises(ValueError, match="stroke_fraction"):
        td.make_plan(fs=1000.0, stroke_fraction=1.5)
    with pytest.raises(ValueError, match="motion"):
        td.make_plan(fs=1000.0, motion="sideways")
    with pytest.raises(ValueError, match="min_fn"):
        td.make_plan(fs=1000.0, min_fn=-1.0)
    with pytest.raises(ValueError, match="tare must be one of auto, start, none"):  # a string names a mode
        td.make_plan(fs=1000.0, tare="3 s")
    with pytest.raises(TypeError, match="tare"):
        td.make_plan(fs=1000.0, tare=[3.0])


@pytest.mark.fast
def test_every_option_has_its_check_or_a_joint_one() -> None:
    """Issue 22 point 1: an option declares the rule that checks it alone (plan.CHECKS), or plan.JOINT says where
    it is checked with the options it depends on; never both, never neither, so no option comes without a check."""
    from tribodyn.pipeline.plan import CHECKS, JOINT

    names = {o.name for o in OPTIONS}
    assert set(JOINT) <= names, sorted(set(JOINT) - names)
    for o in OPTIONS:
        assert bool(o.check) != (o.name in JOINT), o.name
        assert not o.check or o.check in CHECKS, (o.name, o.check)
    assert {o.check for o in OPTIONS if o.check} == set(CHECKS)  # no rule without an option


#: A value each option with a rule of its own refuses (all but progress and stick_slip: any value is a truth value).
BAD = {
    "fs": 0.0, "highpass": -1.0, "orientation": 0, "temperature": "x", "current": float("inf"),
    "voltage": float("nan"), "shunt_ohm": -1.0, "area_mm2": 0.0, "covariates": [1], "chunk": -1.0,
    "deadband": "x", "max_lag": -1, "threads": 0, "start": -1, "stop": 1.5, "motion": "sideways", "min_fn": -1.0,
    "tare": "3 s", "stroke_fraction": 1.5, "uncertainty": {"fy_gain": 0.01},
}  # fmt: skip


@pytest.mark.fast
@pytest.mark.parametrize("name", sorted(BAD))
def test_make_plan_applies_each_declared_check(name: str) -> None:
    from tribodyn.pipeline.plan import checked

    assert option(name).check, name
    options = {name: BAD[name], "shunt_ohm": 1.0} if name == "voltage" else {name: BAD[name]}
    fs = options.pop("fs", FS)
    with pytest.raises((TypeError, ValueError), match=name) as how:
        td.make_plan(fs=fs, **options)
    with pytest.raises(how.type, match=re.escape(str(how.value))):
        checked(option(name), BAD[name])  # the same error: make_plan applies the declared rule
    assert {o.name for o in OPTIONS if o.check} - set(BAD) == {"progress", "stick_slip"}


@pytest.mark.fast
def test_plan_is_frozen_and_holds_every_plan_option() -> None:
    plan = td.make_plan(fs=1000.0, tare={"fy": 0.1, "fz": 0.2})
    fields = {f.name for f in dataclasses.fields(td.Plan)}
    # where the options that are not fields of their own live
    elsewhere = {"temperature", "current", "voltage", "covariates", "shunt_ohm", "area_mm2"}  # Plan.covariates
    for o in OPTIONS:
        if o.kind == "source":
            continue
        assert o.name in fields or o.name in elsewhere, o.name
    with pytest.raises(dataclasses.FrozenInstanceError):
        plan.window = 3.0  # type: ignore[misc]
    with pytest.raises(TypeError):
        plan.tare["fy"] = 1.0  # a read-only mapping
    assert not {"classical", "delay"} & fields  # what the data reveal is in Findings, not the plan


@pytest.mark.fast
def test_results_params_record_every_plan_option(channels: dict) -> None:
    log = (np.array([0.0, 120.0]), np.array([100.0, 110.0]))
    res = td.analyze(channels, fs=FS, temperature=log, area_mm2=1.0)
    renamed = {
        "iv_lag": "iv_lag_samples", "chunk": "chunk_samples", "temperature": "temperature_log_points",
        "covariates": "covariate_logs", "current": "current_log_points", "voltage": "voltage_log_points",
    }  # fmt: skip
    for o in OPTIONS:
        # min_fn is recorded as the pre-pass resolved it, only when there is a classical COF (docs/method.md 6a)
        if o.kind == "source" or o.name == "min_fn":
            continue
        assert renamed.get(o.name, o.name) in res.params, o.name
    raw = td.analyze({"fy": channels["fy"] + 5.0, "fz": channels["fz"] + 40.0}, fs=FS, min_fn=2.0)
    assert raw.params["min_fn"] == 2.0


@pytest.mark.fast
def test_analyze_with_a_plan_is_analyze_with_its_options(channels: dict) -> None:
    opts = dict(window=2.0, hop=5.0, n_bins=12, max_rel_ci=0.2)
    a = td.analyze(channels, fs=FS, **opts)
    plan = td.make_plan(fs=FS, **opts)
    b = td.analyze(channels, plan)
    for name in a.table:
        np.testing.assert_array_equal(a.table[name], b.table[name], err_msg=name)
    assert a.headline == b.headline
    with pytest.raises(TypeError, match="takes no other options.*n_bins"):
        td.analyze(channels, plan, n_bins=8)
    with pytest.raises(ValueError, match="plan is for fs = 100"):
        td.analyze(channels, td.make_plan(fs=100.0), fs=FS)
    with pytest.raises(TypeError, match="tribodyn.Plan"):
        td.analyze(channels, {"window": 2.0})  # type: ignore[arg-type]


@pytest.mark.fast
def test_cli_flags_and_config_keys_come_from_the_declaration() -> None:
    parser = cli._parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    analyze = sub.choices["analyze"]  # type: ignore[attr-defined]
    flags = {s for a in analyze._actions for s in a.option_strings}
    for o in OPTIONS:
        if o.flag is not None:
            assert o.flag in flags, o.flag
            assert o.config in cli._CONFIG_KEYS, o.config
            assert cli._CONFIG_KEYS[o.config] == o.config_type, o.config


@pytest.mark.fast
def test_cli_passes_every_plan_option_through(tmp_path: Path) -> None:
    """Each flag of kind "plan" arrives under its option's name (one declaration, no hand-kept table)."""
    values = {"float": "0.5", "int": "3", "orientation": "-1", "deadband": "0.2", "gate": "0.8", "pair": "0.1,0.2",
              "tare": "1.5", "uncertainty": "fy_rel=0.005"}  # fmt: skip
    argv = ["analyze", "x.npy", "--out", str(tmp_path / "o")]
    want = {}
    for o in OPTIONS:
        if o.kind != "plan" or o.flag is None:
            continue
        text = o.choices[0] if o.cli_type == "choice" else values[o.cli_type]
        argv += [o.flag, text]
        want[o.name] = text
    ns = cli._parser().parse_args(argv)
    _, opts, _ = cli._analysis_options(ns)
    assert set(want) <= set(opts)


@pytest.mark.fast
def test_readme_option_table_is_generated() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert markdown_table() in readme, "README's option table is stale: regenerate it from tribodyn.options"


@pytest.mark.fast
def test_defaults_helper() -> None:
    assert defaults()["n_bins"] == 16
    with pytest.raises(KeyError, match="no option 'bins'"):
        option("bins")


@pytest.mark.fast
def test_identify_has_analyze_defaults_and_takes_a_plan(channels: dict) -> None:
    fy, fz = channels["fy"][:4000], channels["fz"][:4000]
    sig = inspect.signature(td.identify)
    assert "plan" in sig.parameters
    with pytest.warns(RuntimeWarning, match="instrument .* is weak"):  # white noise: no instrument
        one = td.identify(fy, fz, fs=FS, rpm=600.0)
    assert one.estimator == option("estimator").default or (option("estimator").default is None
                                                             and one.estimator in ("corrected", "ols"))  # fmt: skip
    plan = td.make_plan(fs=FS, rpm=600.0, window=4.0)  # the instrument lag: one revolution, whatever the window
    with pytest.warns(RuntimeWarning, match="weak"):
        same = td.identify(fy, fz, plan=plan)
    assert (same.mu_r, same.mu_r_stderr, same.ok, same.estimator) == (one.mu_r, one.mu_r_stderr, one.ok, one.estimator)
    paper = td.identify(fy, fz, fs=FS, method="paper")
    assert paper.estimator == "ols" and paper.mu_r == one.mu_ols
    with pytest.raises(TypeError, match="unknown option.*'window'"):
        td.identify(fy, fz, fs=FS, window=2.0)
    with pytest.raises(TypeError, match="no other options"):
        td.identify(fy, fz, plan=plan, n_bins=8)


@pytest.mark.fast
def test_analyze_many_with_a_plan_is_analyze(tmp_path: Path, channels: dict) -> None:
    path = tmp_path / "rec.npy"
    np.save(path, np.stack([channels[k] for k in ("fx", "fy", "fz", "i")]))
    rec_opts = {"names": ["fx", "fy", "fz", "i"], "fs": FS}
    plan = td.make_plan(fs=FS, hop=2.0)
    with td.open_recording(path, **rec_opts) as rec:
        one = td.analyze(rec, plan)
    many = td.analyze_many([path], plan, open_options=rec_opts, split=30.0)
    got = many.results[str(path)]
    assert many.tasks > 1
    for name in one.table:
        np.testing.assert_array_equal(one.table[name], got.table[name], err_msg=name)
    with pytest.raises(TypeError, match="no other analysis options"):
        td.analyze_many([path], plan, open_options=rec_opts, window=3.0)


@pytest.mark.fast
def test_analyze_many_splits_on_the_grid_chosen_from_the_rate(tmp_path: Path) -> None:
    """A slow recording's window and hop come from its rate (docs/method.md 6b); split ranges follow them."""
    rng = np.random.default_rng(5)
    n = 6000  # 10 Hz: windows of 10 s tiling the recording
    fz = 20.0 + rng.normal(0.0, 1.0, n)
    fy = 0.2 * fz + rng.normal(0.0, 0.05, n)
    path = tmp_path / "slow.npy"
    np.save(path, np.stack([fy, fz]))
    rec_opts = {"names": ["fy", "fz"], "fs": 10.0}
    with td.open_recording(path, **rec_opts) as rec:
        one = td.analyze(rec)
    got = td.analyze_many([path], open_options=rec_opts, split=60.0).results[str(path)]
    np.testing.assert_array_equal(one["t_start"], got["t_start"])
    np.testing.assert_array_equal(one["mu_r"], got["mu_r"])
