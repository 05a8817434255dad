"""The README is a newcomer's page (issue #32, trap 12): what flexmb is, the two commands with how long they take,
a model in a few lines, where to go next; the measurement history lives in docs/benchmarks.md."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
QUICK_START = 'python -m pip install -e ".[viz]" && flexmb run wiper --out results'
TEST_COMMAND = 'python -m pip install -e ".[test]" && python -m pytest'


def _read(name):
    path = ROOT / name
    if not path.exists():
        pytest.skip(f"{name} is not in this installation (run from a source checkout)")
    return path.read_text()


def _sections(text):
    return [line[3:] for line in text.splitlines() if line.startswith("## ")]


def test_the_readme_is_a_newcomers_page():
    text = _read("README.md")
    assert _sections(text) == ["Quick start", "A model in a few lines", "Where to go next"]
    assert len(text.splitlines()) < 120, "one page: the details belong in docs/"
    quick = text.split("## Quick start", 1)[1].split("## ", 1)[0]
    for command in (QUICK_START, TEST_COMMAND):
        assert f"\n    {command}\n" in quick, command  # each on a line of its own, to copy
    assert "first run" in quick.lower() and "later runs" in quick.lower()  # how long, both times
    # no measurement history or benchmark tables
    assert not re.search(r"^\|.*\|$", text, flags=re.M), "a table: docs/benchmarks.md"
    assert "Exudyn" not in text.split("## Where to go next", 1)[0]


def test_the_readme_links_exist():
    text = _read("README.md")
    for target in re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", text):
        if "://" not in target:
            assert (ROOT / target).exists(), target


def test_the_readme_model_runs_as_printed():
    text = _read("README.md")
    code = text.split("## A model in a few lines", 1)[1].split("```python\n", 1)[1].split("```", 1)[0]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, "README.md", "exec"), {})
    status, *rest = out.getvalue().split()
    assert status == "finished"
    assert abs(float(rest[-1])) < 1e-8  # 'the energy changes by about 1e-10 J'


def test_the_benchmark_history_moved_to_docs_benchmarks():
    """What the README held (the compiled core's measurements, the tables against Exudyn) is in docs/benchmarks.md."""
    bench = _read("docs/benchmarks.md")
    for part in ("### The compiled core", "### Side by side with Exudyn",
                 "| B1 | 8 | 0.0372 s (CVODE_BDF, rtol 2e-5) | 0.0574 s (Newton 1e-5, h = 2.5e-4 s) | **0.65** |",
                 "| B6 damped | 512 | 22.7 s (CVODE_BDF, rtol 1e-5)", "B2 N = 64, 128, 256, 512, 1024"):
        assert part in bench, part
    started = _read("docs/getting_started.md")
    for part in ("## What is in flexmb", "`tutorials/10_linear_control.py`", "## Layout of the repository", "## Status"):
        assert part in started, part
