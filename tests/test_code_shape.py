"""Issue 22's code-shape rule, tightened by issue 33 (item 5), checked over the whole package.

"No Python function over 80 lines (docstrings aside) or with more than
5 positional parameters."  The body length runs from the first statement
after the docstring to the function's last line; the positional
parameters are the positional-only and regular ones, not counting a
method's ``self`` or ``cls``.  Nested functions and methods are checked
as functions of their own (an enclosing function's length includes them).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "python" / "tribodyn"
MAX_BODY_LINES = 80
MAX_POSITIONAL = 5

# Known violations, each "path relative to python/tribodyn:qualified name".
# The test fails on an entry that no longer violates, so the list cannot go stale.
# None: issue 33 (item 5) brought every function within 80 lines.
ALLOWED: frozenset[str] = frozenset()


def _body_lines(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """Lines from the first statement after the docstring to the end."""
    body = node.body
    first = body[0]
    if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str):
        if len(body) == 1:
            return 0
        first = body[1]
    end = node.end_lineno if node.end_lineno is not None else node.lineno
    return end - first.lineno + 1


def _positional(node: ast.FunctionDef | ast.AsyncFunctionDef, in_class: bool) -> int:
    """Positional-only plus regular parameters, less a method's self/cls."""
    names = [a.arg for a in (*node.args.posonlyargs, *node.args.args)]
    if in_class and names and names[0] in ("self", "cls"):
        names = names[1:]
    return len(names)


def _violations_in(path: Path) -> list[str]:
    """The rule's violations in one module, as "relpath:qualname: why"."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    rel = path.relative_to(PACKAGE).as_posix()
    found: list[str] = []

    def visit(node: ast.AST, prefix: str, in_class: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.ClassDef):
                visit(child, f"{prefix}{child.name}.", True)
            elif isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                name = f"{prefix}{child.name}"
                lines = _body_lines(child)
                npos = _positional(child, in_class)
                why = []
                if lines > MAX_BODY_LINES:
                    why.append(f"{lines} lines")
                if npos > MAX_POSITIONAL:
                    why.append(f"{npos} positional parameters")
                if why:
                    found.append(f"{rel}:{name}: {', '.join(why)}")
                visit(child, f"{name}.", False)
            else:
                visit(child, prefix, in_class)

    visit(tree, "", False)
    return found


def violations() -> list[str]:
    """Every violation of the rule in python/tribodyn."""
    out: list[str] = []
    for path in sorted(PACKAGE.rglob("*.py")):
        out.extend(_violations_in(path))
    return out


def _key(violation: str) -> str:
    """The "relpath:qualname" part of a violation."""
    return violation.split(": ", 1)[0]


@pytest.mark.fast
def test_no_function_breaks_the_shape_rule() -> None:
    found = [v for v in violations() if _key(v) not in ALLOWED]
    assert not found, "functions over the shape rule:\n" + "\n".join(found)


@pytest.mark.fast
def test_allow_list_is_not_stale() -> None:
    keys = {_key(v) for v in violations()}
    stale = sorted(ALLOWED - keys)
    assert not stale, "allowed violations that are gone; drop them:\n" + "\n".join(stale)


def test_checker_counts_as_the_rule_says() -> None:
    src = (
        "class A:\n"
        "    def m(self, a, b, c, d, e):\n"
        '        """Doc."""\n'
        "        return 1\n"
        "def f(a, /, b, c, d, e, f, *, g=1):\n"
        "    return 2\n"
    )
    tree = ast.parse(src)
    cls = tree.body[0]
    assert isinstance(cls, ast.ClassDef)
    meth = cls.body[0]
    fn = tree.body[1]
    assert isinstance(meth, ast.FunctionDef) and isinstance(fn, ast.FunctionDef)
    assert _positional(meth, True) == 5
    assert _body_lines(meth) == 1
    assert _positional(fn, False) == 6
    assert _body_lines(fn) == 1
