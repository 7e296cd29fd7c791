"""The package's layers (docs/architecture.md): no import circle and no upward import, counting every
import statement of the package (deferred ones and those under ``TYPE_CHECKING`` included).

import-linter checks the same layers in `.ci/run` (``lint-imports``, from ``[tool.importlinter]`` in
pyproject.toml); this test reads that declaration and checks it without import-linter's exceptions: an
import of the namespace itself (``from .. import _core``) is resolved to the module it names.
"""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path
from typing import Dict, List, Set

import pytest

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
PKG = ROOT / "python" / "tribodyn"


def _modules() -> Dict[str, Path]:
    out = {}
    for path in sorted(PKG.rglob("*.py")):
        parts = list(path.relative_to(PKG).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(["tribodyn", *parts])] = path
    out["tribodyn._core"] = PKG / "_core.pyi"  # the compiled extension: imports nothing of the package
    return out


MODULES = _modules()


def _imports(name: str, path: Path) -> Set[str]:
    """The package's modules that ``name`` imports (every statement, wherever it stands)."""
    if path.suffix == ".pyi":
        return set()
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: Set[str] = set()
    for node in ast.walk(tree):
        targets: List[str] = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            targets = [f"{mod}.{a.name}" for a in node.names]
            targets = [t if t in MODULES else mod for t in targets]
        for t in targets:
            while t not in MODULES and "." in t:
                t = t.rpartition(".")[0]
            if t in MODULES and t != name and t.startswith("tribodyn"):
                found.add(t)
    return found


GRAPH = {name: _imports(name, path) for name, path in MODULES.items()}


def _layers() -> List[List[str]]:
    conf = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    contract = next(c for c in conf["tool"]["importlinter"]["contracts"] if c["type"] == "layers")
    return [[m.strip() for m in layer.split("|")] for layer in contract["layers"]]


def _layer_of(module: str, layers: List[List[str]]) -> int:
    """Index of the layer holding ``module`` (0 the top), -1 for the namespace and modules in no layer."""
    for i, layer in enumerate(layers):
        if any(module == top or module.startswith(top + ".") for top in layer):
            return i
    return -1


@pytest.mark.fast
def test_the_import_graph_has_no_circle():
    index: Dict[str, int] = {}
    low: Dict[str, int] = {}
    stack: List[str] = []
    on: Set[str] = set()
    circles: List[List[str]] = []
    counter = [0]

    def visit(v: str) -> None:  # Tarjan's strongly connected components
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(GRAPH[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                circles.append(sorted(comp))

    for v in sorted(GRAPH):
        if v not in index:
            visit(v)
    assert circles == []


@pytest.mark.fast
def test_each_layer_imports_only_the_layers_below_it():
    layers = _layers()
    upward = []
    for src, targets in GRAPH.items():
        a = _layer_of(src, layers)
        for dst in targets:
            b = _layer_of(dst, layers)
            if dst == "tribodyn" and src not in ("tribodyn.__main__",):
                upward.append(f"{src} -> the namespace (import from the module that defines the name)")
            elif a >= 0 and b >= 0 and b < a:
                upward.append(f"{src} -> {dst}")
            elif a >= 0 and b == a and len(layers[a]) > 1:
                tops = [t for t in layers[a] if src == t or src.startswith(t + ".")]
                if not (dst == tops[0] or dst.startswith(tops[0] + ".")):
                    upward.append(f"{src} -> {dst} (independent siblings)")
    assert upward == []


@pytest.mark.fast
def test_every_module_is_in_a_layer():
    layers = _layers()
    free = {"tribodyn", "tribodyn.__main__", "tribodyn._core", "tribodyn.simulate"}
    assert [m for m in sorted(MODULES) if m not in free and _layer_of(m, layers) < 0] == []
    assert GRAPH["tribodyn.simulate"] == set()  # the simulators stand alone


@pytest.mark.fast
def test_the_graph_sees_deferred_and_type_checking_imports(tmp_path):
    # the test itself must be able to fail: a deferred upward import and a TYPE_CHECKING one are edges
    src = (
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n    from ..app import cli\n"
        "def f():\n    from ..pipeline.analyze import analyze\n    return analyze\n"
    )
    path = tmp_path / "probe.py"
    path.write_text(src, encoding="utf-8")
    assert _imports("tribodyn.kernels.probe", path) == {"tribodyn.app.cli", "tribodyn.pipeline.analyze"}


@pytest.mark.fast
def test_with_orientation_keeps_every_field_and_flips_the_cof():
    import dataclasses

    import numpy as np
    import tribodyn as td

    rng = np.random.default_rng(3)
    fz = 20.0 + np.sin(np.arange(60_000) * 0.37) + 0.1 * rng.standard_normal(60_000)
    fy = -0.2 * fz + 0.02 * rng.standard_normal(60_000)
    res = td.analyze({"fy": fy, "fz": fz}, fs=1000.0, window=2.0, hop=5.0)
    res = dataclasses.replace(res, stick_slip="kept")  # any value: the field must travel
    flipped = res.with_orientation(-res.orientation)
    assert flipped.stick_slip == "kept" and flipped.strokes is res.strokes and flipped.classical is res.classical
    assert flipped.warnings == res.warnings and flipped.moments is res.moments
    np.testing.assert_array_equal(flipped["mu_r"], -res["mu_r"])
    assert flipped.orientation == -res.orientation and flipped.params["orientation_used"] == -res.orientation


@pytest.mark.fast
def test_public_errors_and_headline_are_reachable():
    import tribodyn as td
    from tribodyn import _core, errors

    assert td.Headline is td.results.Headline
    assert td.NonFiniteError is _core.NonFiniteError is errors.NonFiniteError
    assert issubclass(td.errors.RecordingError, ValueError) and td.RecordingError is errors.RecordingError
    assert issubclass(td.OutputError, ValueError)
    assert errors.ConstantInputWarning is td.ConstantInputWarning


@pytest.mark.fast
@pytest.mark.fast
def test_results_params_cannot_change_and_replace_carries_only_what_it_is_told():
    import json
    import pickle

    import numpy as np
    import tribodyn as td
    from tribodyn.results import CACHED

    rng = np.random.default_rng(5)
    fz = 20.0 + np.sin(np.arange(30_000) * 0.37) + 0.1 * rng.standard_normal(30_000)
    res = td.analyze({"fy": 0.2 * fz + 0.02 * rng.standard_normal(30_000), "fz": fz}, fs=1000.0, window=2.0)
    for change in (lambda p: p.__setitem__("window", 9.0), lambda p: p.update(window=9.0),
                   lambda p: p.pop("window"), lambda p: p.setdefault("new", 1), lambda p: p.clear(),
                   lambda p: p.__delitem__("window")):  # fmt: skip
        with pytest.raises(TypeError, match="cannot be changed"):
            change(res.params)
    assert res.params["window"] == 2.0
    # it reads, copies, pickles and serialises as a dict
    assert json.loads(json.dumps(res.params))["window"] == 2.0 and pickle.loads(pickle.dumps(res)).params == res.params
    mine = dict(res.params)
    mine["window"] = 9.0
    assert res.params["window"] == 2.0
    head = res.headline  # computed once
    kept = res.replace(keep=("headline",), warnings=res.warnings + ("a note",))
    assert kept.headline is head and "a note" in kept.warnings and kept.params == res.params
    fresh = res.replace(warnings=())
    assert "headline" not in fresh.__dict__ and fresh.headline == head  # computed again, the same
    given = res.replace(cached={"mu_r_ci": {"median": (0.0, 1.0)}})
    assert given.mu_r_ci == {"median": (0.0, 1.0)} and res.mu_r_ci != given.mu_r_ci
    with pytest.raises(ValueError, match="not a cached value"):
        res.replace(keep=("table",))
    assert set(CACHED) == {"mu_r_ci", "column_ci", "verdict", "headline"}


@pytest.mark.fast
@pytest.mark.fast
def test_public_names_follow_the_scheme():
    """docs/architecture.md, "Names": interval ends in pairs, pairs held as `_ci`, standard errors as `_stderr`
    (a class's own: `se`), no bare `t`; on the table's columns and every public result class's fields."""
    import dataclasses

    import tribodyn as td
    from tribodyn.columns import TABLE

    groups = {"columns": [c.name for c in TABLE]}
    for name in td.__all__:
        obj = getattr(td, name)
        if isinstance(obj, type) and dataclasses.is_dataclass(obj) and name != "Plan":
            groups[name] = [f.name for f in dataclasses.fields(obj)]
            groups[name] += [k for k, v in vars(obj).items() if isinstance(v, property) and not k.startswith("_")]
    assert len(groups) > 15, sorted(groups)  # the result classes were found
    bad = []
    for where, names in groups.items():
        have = set(names)
        for n in names:
            stem, _, end = n.rpartition("_")
            if n in ("low", "high") and {"low", "high"} - have:
                bad.append(f"{where}.{n}: an interval end without its pair")
            if end in ("low", "high") and stem and {f"{stem}_low", f"{stem}_high"} - have:
                bad.append(f"{where}.{n}: an interval end without its pair")
            if end in ("lo", "hi", "lower", "upper") and stem.endswith("ci"):
                bad.append(f"{where}.{n}: interval ends are _low/_high")
            if end in ("se", "sem", "err", "stde") and stem:
                bad.append(f"{where}.{n}: a standard error is <x>_stderr")
            if n == "t":
                bad.append(f"{where}.{n}: a time is `time` or `t_<event>`")
    assert not bad, bad
    ci_fields = [(c.__name__, f.name, str(f.type)) for c in (td.OperatingRange, td.Hysteresis)
                 for f in dataclasses.fields(c) if f.name.endswith("_ci")]  # fmt: skip
    assert ci_fields and all(any(k in t for k in ("Tuple", "tuple", "Interval")) for _, _, t in ci_fields), ci_fields


def test_the_tests_mirror_the_layers():
    """Each folder of tests/ is a layer's folder of the package (docs/architecture.md, "Tests"), and the inner loop is
    marked case by case: no test module marks all its cases fast (a slow case added later would join the loop)."""
    tests = Path(__file__).resolve().parent
    package = tests.parent / "python" / "tribodyn"
    layers = {p.name for p in package.iterdir() if p.is_dir() and (p / "__init__.py").exists()} | {"simulate"}
    folders = {p.name for p in tests.iterdir() if p.is_dir() and p.name not in ("data", "__pycache__")}
    assert folders and folders <= layers, sorted(folders - layers)
    whole = [p.relative_to(tests).as_posix() for p in tests.rglob("test_*.py")
             if re.search(r"^pytestmark\s*=.*\bfast\b", p.read_text(encoding="utf-8"), re.M)]  # fmt: skip
    assert not whole, whole
