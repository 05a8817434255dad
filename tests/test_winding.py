"""Angles that wind up do not loosen the error control (flexmb.stepping: the integrator holds y - c).

A run whose angles start 1000 turns further on is the same motion; its
error against a reference from outside the run under test (scipy's DOP853
at rtol 1e-13 on the pendulum's own equation, a tight run of the unshifted
four-bar) must be that of the run from one turn on (the integrator then
sees the same states) and near that from 0, not the error of an integrator
weighing ``rtol |angle|`` with angles of 6,000 rad. Without the offsets
(``stepping.WINDING_BOUND = inf``) these tests fail for DOP853, BDF,
LSODA, CVODE_BDF, CVODE_Adams and GeneralizedAlpha (up to 150 times the
error from one turn on).
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import flexmb as fm

from conftest import fourbar, fourbar_initial

G = 9.81
W0 = 10.0  # rad/s: the pendulum goes over the top, about 6 turns in 4 s
T = 4.0
TURNS = 1000


def pendulum():
    model = fm.Model("pendulum")
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0.0, -G, 0.0)))
    return model


def pendulum_angle(t_end):
    """The pin angle at t_end, from the bar's own equation theta'' = -(3 g / 2 L) cos(theta)."""
    sol = solve_ivp(lambda t, y: [y[1], -1.5 * G * np.cos(y[0])], (0.0, t_end), [0.0, W0], method="DOP853",
                    rtol=1e-13, atol=1e-14)
    return sol.y[0, -1]


@pytest.mark.parametrize("method", ["DOP853", "RK45", "Radau", "BDF", "LSODA", "CVODE_BDF", "CVODE_Adams", "IDA",
                                    "GeneralizedAlpha"])
@pytest.mark.parametrize("n_out", [2, 41])
def test_pendulum_error_does_not_grow_with_winding(method, n_out):
    """The end angle's error from 1000 turns on is that from one turn on, and near that from 0.

    From one turn on and from 1000 the integrator sees the same state (the
    offsets absorb the whole turns), so the errors agree to rounding; from
    0 it moves the offsets at other times, and the error differs within
    what the tolerance allows.

    ``n_out=2``: integrators that step between outputs in their own loop
    (CVODE on an open tree) move the offsets after the step that wound,
    not at the next output.
    """
    ref = pendulum_angle(T)
    model = pendulum()
    errors = {}
    for k in (0, 1, TURNS):
        res = fm.simulate(model, T, positions={"pin": 2 * np.pi * k}, speeds={"pin": W0}, method=method,
                          n_out=n_out, progress=False)
        assert res.status == "finished"
        assert res.n_rebases >= 5  # about once per turn
        errors[k] = abs(res.x[-1, 0] - 2 * np.pi * k - ref)
        # the stored angles are the unwrapped ones
        assert abs(res.x[0, 0] - 2 * np.pi * k) < 1e-12 * max(1.0, 2 * np.pi * k)
    assert errors[TURNS] <= 1.5 * errors[1] + 1e-9, errors
    assert errors[TURNS] <= 3.0 * max(errors[0], errors[1]) + 1e-7, errors


def test_angles_that_do_not_wind_keep_zero_offsets():
    """A pendulum swinging below the horizontal never moves an offset: its run is the plain one."""
    res = fm.simulate(pendulum(), 3.0, positions={"pin": -1.0}, method="CVODE_BDF", progress=False)
    assert res.n_rebases == 0
    assert np.max(np.abs(res.x[:, 0])) < 3.0


def test_work_of_a_winding_pendulum_balances_its_energy():
    """The offsets touch the angles only: the integrated work still equals the change of kinetic energy."""
    res = fm.simulate(pendulum(), T, speeds={"pin": W0}, method="CVODE_BDF", track_work=True, progress=False)
    assert res.n_rebases >= 5
    work = sum(res.work.values())
    np.testing.assert_allclose(work, res.kinetic - res.kinetic[0], atol=1e-5 * res.kinetic[0])


@functools.lru_cache(maxsize=None)
def fourbar_reference(t_end):
    """A tight run of the crank-rocker, the crank at 20 rad/s (winding to about 30 rad: 3e-11 rad at rtol 1e-12)."""
    return fm.simulate(fourbar(), t_end, positions=fourbar_initial(0.3), speeds={"A": 20.0}, fixed=["A"],
                       method="DOP853", rtol=1e-12, atol=1e-14, n_out=31, progress=False)


@pytest.mark.parametrize("method", ["DOP853", "CVODE_BDF", "GeneralizedAlpha"])
def test_fourbar_crank_error_does_not_grow_with_winding(method):
    """A crank-rocker whose crank spins (about 5 turns, loop projections and offset moves together).

    The reference is a tight run of the unshifted four-bar; in the shifted
    runs every angle starts one or 1000 turns on (the rocker's too, which
    then only rocks).
    """
    model = fourbar()
    speeds = {"A": 20.0}
    t_end = 1.5
    start = fourbar_initial(0.3)
    ref = fourbar_reference(t_end)
    errors = {}
    for k in (0, 1, TURNS):
        positions = {"A": start["A"] + 2 * np.pi * k, "B": start["B"] - 2 * np.pi * k,
                     "D": start["D"] + 2 * np.pi * k}
        res = fm.simulate(model, t_end, positions=positions, speeds=speeds, fixed=["A"], method=method, n_out=31,
                          progress=False)
        assert res.status == "finished" and res.n_rebases >= 3
        # the rocker's tip: a position that does not depend on the turns
        i = res.body_names.index("rocker")
        errors[k] = float(np.max(np.linalg.norm(res.origins[:, i] + 0.25 * res.rotations[:, i, :, 0]
                                                - ref.origins[:, i] - 0.25 * ref.rotations[:, i, :, 0], axis=1)))
    assert errors[TURNS] <= 1.5 * errors[1] + 1e-9, errors
    assert errors[TURNS] <= 5.0 * max(errors[0], errors[1]) + 1e-9, errors


def test_rebase_of_generalized_alpha_keeps_its_state():
    """GeneralizedAlpha moves its state, its interpolant and its memory for restarts in place."""
    from flexmb.genalpha import GeneralizedAlpha

    shift = np.zeros(2)
    f = lambda t, y: np.array([y[1], -1.5 * G * np.cos(y[0])])  # noqa: E731
    g = lambda t, y: f(t, y + shift)  # noqa: E731  (the right-hand side told of the shift)
    a = GeneralizedAlpha(f, 0.0, np.array([0.0, W0]), 1.0, n_second=1, rtol=1e-8, atol=1e-10)
    b = GeneralizedAlpha(g, 0.0, np.array([0.0, W0]), 1.0, n_second=1, rtol=1e-8, atol=1e-10)
    for _ in range(5):
        a.step()
        b.step()
    shift = np.array([2 * np.pi, 0.0])
    b.rebase(shift)
    t_mid = 0.5 * (a.t_old + a.t)
    np.testing.assert_allclose(b.y + shift, a.y, rtol=0, atol=1e-15)
    np.testing.assert_allclose(b.dense_output()(t_mid) + shift, a.dense_output()(t_mid), rtol=0, atol=1e-14)
    # a restart from the moved state continues from the memory: the accelerations are not "corrected"
    # by the Jacobian times the shift
    c = GeneralizedAlpha(g, b.t, b.y, 1.0, n_second=1, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(c.a, a.a, rtol=0, atol=1e-12)
    assert c.h_abs == b.h_abs
