"""The set-up contract: the README's test command is the one CI runs, on the `test` extra alone."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TEST_COMMAND = 'python -m pip install -e ".[test]" && python -m pytest'


def _read(name):
    path = ROOT / name
    if not path.exists():
        pytest.skip(f"{name} is not in this installation (run from a source checkout)")
    return path.read_text()


def test_readme_and_ci_run_the_same_test_command():
    assert TEST_COMMAND in _read("README.md")
    ci = _read(".ci/run")
    assert TEST_COMMAND in ci.splitlines(), "the README's test command, exactly, on a line of its own"
    assert "venv" in ci, ".ci/run runs it in a fresh virtual environment"


def test_test_extra_has_what_unconditional_tests_import():
    """matplotlib: the main job's and the studies' plots are asserted on without importorskip."""
    extras = tomllib.loads(_read("pyproject.toml"))["project"]["optional-dependencies"]
    names = {re.split(r"[<>=\[ ]", req, maxsplit=1)[0] for req in extras["test"]}
    assert {"pytest", "hypothesis", "numpydoc", "matplotlib"} <= names


#: flexmb calls in a tutorial that need a package of an extra: ``result.show()`` and the renders (pyvista)
_CALLS_NEEDING = {"show": {"pyvista"}, "render_state": {"pyvista"}, "animate": {"pyvista", "imageio"}}


def _needed_by(source: str) -> set[str]:
    """Third-party modules a tutorial needs to run: its imports and the packages behind the flexmb calls it
    makes, but those in the body of a ``try`` whose ``except ImportError`` does without them."""
    import ast
    import sys

    tree = ast.parse(source)
    optional = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Try) and any(
                isinstance(h.type, ast.Name) and h.type.id in ("ImportError", "ModuleNotFoundError")
                for h in node.handlers):
            # the try's own body may fail with ImportError; its else branch runs when that import worked
            # (in the docs build, where the docs extra has it), so what the else branch needs counts
            optional |= {id(n) for stmt in node.body for n in ast.walk(stmt)}
    needed = set()
    for node in ast.walk(tree):
        if id(node) in optional:
            continue
        if isinstance(node, ast.Import):
            needed |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            needed.add(node.module.split(".")[0])
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in _CALLS_NEEDING:
            needed |= _CALLS_NEEDING[node.func.attr]
    return {m for m in needed if m not in sys.stdlib_module_names and m not in ("flexmb", "flexmb_friction")}


def test_docs_extra_has_what_the_tutorials_need():
    """The README's docs command runs every tutorial (sphinx-gallery) in a venv with the `docs` extra alone:
    each package a tutorial needs must come with it or with the core dependencies (issue #32: tutorial 09's
    ``result.show()`` needs pyvista)."""
    project = tomllib.loads(_read("pyproject.toml"))["project"]
    name = lambda req: re.split(r"[<>=\[ ;]", req, maxsplit=1)[0].lower().replace("-", "_")  # noqa: E731
    available = {name(r) for r in project["dependencies"] + project["optional-dependencies"]["docs"]}
    missing = {}
    for path in sorted((ROOT / "tutorials").glob("[0-9][0-9]_*.py")):
        for module in _needed_by(path.read_text()) - available:
            missing.setdefault(module, []).append(path.name)
    assert not missing, f"not in the docs extra nor the dependencies: {missing}"
