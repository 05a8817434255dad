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
