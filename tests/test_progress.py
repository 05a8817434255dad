"""Progress of long runs (flexmb.progress): a bar in a terminal, whole lines in a log, nothing in CI."""

from __future__ import annotations

import io
import sys
import time

import numpy as np
import pytest

import flexmb as fm
from flexmb import progress


class Terminal(io.StringIO):
    def isatty(self):
        return True


def pendulum():
    model = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0.0, -9.81, 0.0)))
    return model


def test_default_is_shown_except_in_ci(monkeypatch):
    monkeypatch.delenv("CI", raising=False)
    assert progress.shown(None) and not progress.shown(False) and progress.shown(True)
    monkeypatch.setenv("CI", "true")
    assert not progress.shown(None) and progress.shown(True)


def test_terminal_gets_a_bar_with_rate_and_remaining_time(monkeypatch):
    stream = Terminal()
    monkeypatch.setattr(progress.sys, "stderr", stream)
    bar = progress.Progress(2.0, "simulating", "s")
    bar._bar.delay = 0.0
    bar._bar.mininterval = 0.0
    for k in range(1, 5):
        time.sleep(0.01)
        bar.update_to(0.5 * k)
    bar.close()
    out = stream.getvalue()
    assert "\r" in out and "simulating" in out and "2/2 s" in out
    assert "simulated s per wall-clock s" in out and "<" in out  # rate of simulated time, remaining time
    assert out.endswith("\n")  # the line ends: a message after it starts on its own line


def test_log_gets_whole_lines_and_nothing_for_short_runs(monkeypatch):
    stream = io.StringIO()
    monkeypatch.setattr(progress.sys, "stderr", stream)
    bar = progress.Progress(1.0, "simulating", "s")
    bar.update_to(0.5)
    bar.close()
    assert stream.getvalue() == ""  # shorter than LOG_INTERVAL: nothing
    monkeypatch.setattr(progress, "LOG_INTERVAL", 0.0)
    bar = progress.Progress(1.0, "simulating", "s")
    for k in range(1, 4):
        time.sleep(0.01)
        bar.update_to(k / 3)
    bar.close()
    out = stream.getvalue()
    assert out and "\r" not in out
    assert all(line.startswith("simulating:") for line in out.splitlines())


def test_simulate_reports_progress_and_the_error_starts_a_new_line(monkeypatch):
    stream = Terminal()
    monkeypatch.setattr(progress.sys, "stderr", stream)
    monkeypatch.setattr(progress, "Progress", _eager(progress.Progress))
    stepping = sys.modules["flexmb.stepping"]
    monkeypatch.setattr(stepping, "Progress", progress.Progress)
    res = fm.simulate(pendulum(), 1.0, positions={"pin": 0.5}, progress=True)
    assert res.status == "finished"
    out = stream.getvalue()
    assert "simulating" in out and "1/1 s" in out and out.endswith("\n")
    model = pendulum()
    model.add(fm.PointForce("kick", model["bar"], lambda t: (0.0, np.nan if t > 0.3 else 0.0, 0.0)))
    with pytest.raises(fm.SimulationError):
        fm.simulate(model, 1.0, positions={"pin": 0.5}, progress=True)
    assert stream.getvalue().endswith("\n")


def _eager(cls):
    """Progress shown from the first update (no delay, no minimum interval)."""

    class Eager(cls):
        def __init__(self, *args, **kw):
            super().__init__(*args, **kw)
            if self._bar is not None:
                self._bar.delay = 0.0
                self._bar.mininterval = 0.0

    return Eager


@pytest.mark.parametrize("speed", [4.0, 0.25])
def test_the_rate_of_simulated_time_never_flips(monkeypatch, speed):
    """Issue #32: tqdm shows a rate below 1 inverted, and with the unit s both read "s/s"; the rate now says
    which second is which and is simulated time per wall-clock second, above 1 as below."""
    stream = Terminal()
    monkeypatch.setattr(progress.sys, "stderr", stream)
    clock = {"t": 0.0}
    bar = progress.Progress(100.0, "simulating", "s")
    bar._bar._time = lambda: clock["t"]  # tqdm's clock: wall time under control
    bar._bar.start_t = bar._bar.last_print_t = 0.0
    bar._bar.delay = 0.0
    bar._bar.mininterval = 0.0
    for k in range(1, 5):
        clock["t"] = float(k)
        bar.update_to(speed * k)
    out = stream.getvalue()
    bar.close()
    last = out.split("\r")[-1]
    assert f"{speed:.3g} simulated s per wall-clock s" in last, last
    assert "s/s" not in out
