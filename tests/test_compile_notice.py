"""A compilation is said once per family of kernels, and kept off the progress bars' clocks (issue #31).

The fast tests compile small stand-in kernels that claim a module of
``flexmb.kernels`` (numba's compile events name the function, whose module
decides the family); the slow one runs the README's pendulum on an empty
``NUMBA_CACHE_DIR`` and again on the filled one.
"""

from __future__ import annotations

import io
import os
import re
import subprocess
import sys
import time

import numba
import pytest

from flexmb import progress
from flexmb.kernels import compiling, prebuilt

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _kernel(module: str, scale: float):
    """A new numba function (not compiled yet) that says it is defined in ``module``."""

    def kernel(x):
        s = 0.0
        for i in range(10):
            s += scale * x * i
        return s

    kernel.__module__ = module
    return numba.njit(kernel)


@pytest.fixture
def fresh(monkeypatch):
    """No family told yet in this process (the real kernels may have compiled earlier in the session), and no reason
    to tell why shipped machine code was not used (tests/test_prebuilt.py tests those)."""
    monkeypatch.setattr(compiling, "_told", set())
    monkeypatch.setattr(prebuilt, "unusable_reason", lambda stamp: None)


def test_a_family_compiling_is_said_once_on_stderr(fresh, capsys):
    _kernel("flexmb.kernels.loops", 1.0)(2.0)
    _kernel("flexmb.kernels.constraints", 2.0)(2.0)  # the same family: no second line
    _kernel("flexmb.kernels.tree", 3.0)(2.0)         # another family: its own line
    _kernel("flexmb.kernels.genalpha", 4.0)(2.0)     # a family not measured: no figure
    err = capsys.readouterr().err.splitlines()
    assert err == [f"flexmb: compiling flexmb's kernels for loops, once: ~{compiling.ESTIMATE_S['loops']} s "
                   "(later runs load them from the cache)",
                   f"flexmb: compiling flexmb's kernels for open trees, once: ~{compiling.ESTIMATE_S['open trees']} s "
                   "(later runs load them from the cache)",
                   "flexmb: compiling flexmb's kernels for generalized-alpha, once (later runs load them from the cache)"]


def test_other_functions_compiling_say_nothing_and_are_not_counted(fresh, capsys):
    before = compiling.compile_seconds()
    _kernel("userplugin", 1.0)(2.0)
    assert capsys.readouterr().err == ""
    assert compiling.compile_seconds() == before


def test_a_bar_starts_after_the_kernels_compiled(fresh, monkeypatch):
    class Terminal(io.StringIO):
        def isatty(self):
            return True

    stream = Terminal()
    monkeypatch.setattr(progress.sys, "stderr", stream)
    monkeypatch.setattr(compiling.sys, "stderr", io.StringIO())
    t0 = time.time()
    bar = progress.Progress(1.0, "simulating", "s")
    compiled = compiling.compile_seconds()
    _kernel("flexmb.kernels.tree", 1.0)(2.0)
    spent = compiling.compile_seconds() - compiled
    t1 = time.time()
    assert spent > 0
    # the bar's clock started at t0 and moved by the compilation: it starts after it, within the rest of the call
    assert t0 + spent <= bar.start_time <= t1 + 1e-3
    bar.update_to(0.5)
    assert stream.getvalue() == ""  # within the bar's delay after the compilation: not shown yet
    bar.close()


def _readme_pendulum() -> str:
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
        section = f.read().split("## A model in a few lines", 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


@pytest.mark.slow
def test_the_readme_pendulum_on_a_cold_cache_says_it_compiles_and_shows_no_bar_meanwhile(tmp_path):
    script = tmp_path / "pendulum.py"
    script.write_text(_readme_pendulum())
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), OPENBLAS_NUM_THREADS="1",
               FLEXMB_PREBUILT="0")  # the kernels compile, as without shipped machine code
    env.pop("CI", None)  # progress shown, as for a user: lines every half minute into this pipe
    runs = [subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=env, timeout=1800)
            for _ in range(2)]
    for run in runs:
        assert run.returncode == 0, run.stderr[-2000:]
    cold, warm = (run.stderr.splitlines() for run in runs)
    told = [line for line in cold if line.startswith("flexmb: compiling flexmb's kernels for ")]
    assert told and len(told) == len(set(told)), cold
    assert not any(line.startswith("simulating") for line in cold), cold  # the run itself takes under 30 s
    assert not any("compiling" in line for line in warm), warm
