"""CVODE_BDF held to order 3 on flexible bodies in loops at loose tolerances (flexmb.stepping.OSCILLATION_MAX_ORDER).

B6 (the slider-crank with a flexible rod, benchmarks/scenes.py): BDF
orders 4-5 are not stable near the imaginary axis, where the rod's lightly
damped modes sit, and at loose tolerances they take more steps than order
3 (docs/benchmarks.md, "What limits CVODE's step on B6"). The references:
the same run at order 5, a tight run (rtol 1e-9) for the accuracy, and
the models the cap must leave alone (tight tolerances, a rigid four-bar).
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

import flexmb as fm
import flexmb.stepping as stepping
from flexmb.integrators import CVODEBDF

from conftest import fourbar, fourbar_initial

sys.path.insert(0, os.path.join(os.path.dirname(__file__), os.pardir, "benchmarks"))
import scenes  # noqa: E402


class SpyBDF(CVODEBDF):
    """CVODE_BDF recording the ``max_order`` each instance was given."""

    given: list = []

    def __init__(self, *args, max_order=None, **kw):
        SpyBDF.given.append(max_order)
        super().__init__(*args, max_order=max_order, **kw)


def b6_run(rtol, t_end=0.1, method="CVODE_BDF", n_segments=4):
    model, positions = scenes.b6(damped=True, n_segments=n_segments)
    return fm.simulate(model.build(), t_end, positions=positions, complement="articulated", method=method,
                       rtol=rtol, atol=rtol / 100, n_out=21, progress=False)


@pytest.mark.parametrize("rtol, expected", [(3e-3, 3), (1e-4, 3), (1e-5, None)])
def test_order_cap_given_to_cvode_on_b6_at_loose_tolerances_only(rtol, expected):
    SpyBDF.given = []
    res = b6_run(rtol, t_end=0.02, method=SpyBDF)
    assert res.status == "finished"
    assert SpyBDF.given and set(SpyBDF.given) == {expected}


def test_rigid_loop_keeps_order_five():
    SpyBDF.given = []
    system = fourbar().build()
    res = fm.simulate(system, 0.2, positions=fourbar_initial(), method=SpyBDF, rtol=3e-3, n_out=11, progress=False)
    assert res.status == "finished"
    assert SpyBDF.given and set(SpyBDF.given) == {None}


def test_order_three_takes_fewer_steps_within_the_error_target(monkeypatch):
    capped = b6_run(3e-3, t_end=0.3, n_segments=8)
    monkeypatch.setattr(stepping, "OSCILLATION_MAX_ORDER", 5)
    uncapped = b6_run(3e-3, t_end=0.3, n_segments=8)
    monkeypatch.undo()
    tight = b6_run(1e-9, t_end=0.3, n_segments=8)
    x = {k: np.asarray(r.coordinate("rail"), float) for k, r in (("capped", capped), ("uncapped", uncapped),
                                                               ("tight", tight))}
    assert capped.n_steps < 0.8 * uncapped.n_steps
    assert np.max(np.abs(x["capped"] - x["tight"])) < 1e-6
