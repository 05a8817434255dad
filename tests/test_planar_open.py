"""The planar path of open trees (flexmb.kernels.planar): the same state rates as the spatial recursion.

A model whose joints all move in one plane gets its right-hand side from
the planar articulated-body recursion (``open_tree_rhs_into`` dispatches
on the packed model); built with ``planar=False`` the same model takes the
spatial one. The two are compared at the initial, a run's and random
states, with armature too, and over a whole CVODE run; detection refuses
every model outside the plane.

The distances are relative to the largest acceleration any one load gives
alone (:func:`_term_scale`, as benchmarks/prototypes/planar_bench.py
measures): near a balance (a beam hanging under gravity) the state rate
is much smaller than its terms, and either route's round-off is relative
to the terms (at B1 N = 32 both float64 routes are up to 5e-10 of the
largest acceleration from an 80-bit evaluation at a run's states: measured,
session 11).
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest
from attrs import frozen

import flexmb as fm
from flexmb.errors import AssemblyError, ModelError
from flexmb.kernels import planar as P
from flexmb.kernels.articulated import open_tree_rhs
from flexmb.kernels.packing import unpack_planar
from flexmb.scenes.fourbar import fourbar
from flexmb.scenes.wiper import WiperOptions, wiper

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")
sys.path.insert(0, BENCH)
import scenes  # noqa: E402
import test_hard_cases as hc  # noqa: E402

TOL = 1e-12


def _pendulum():
    """The README's model in a few lines (tutorial 01's too)."""
    model = fm.Model("pendulum")
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model.add(fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1)), fm.Gravity((0.0, -9.81, 0.0)))
    return model


def _mixed():
    """A planar tree off the coordinate planes: a cart, two pendulums on it, a welded mass, a second root.

    The plane's normal is (1, 1, 1) / sqrt(3); bodies with products of
    inertia and offset mass centres, joint springs and dampers, gravity
    with a component along the normal (it moves no coordinate).
    """
    n = np.array([1.0, 1.0, 1.0]) / np.sqrt(3.0)
    t = np.array([1.0, -1.0, 0.0]) / np.sqrt(2.0)  # in the plane
    w = np.cross(n, t)
    inertia = np.array([[0.02, 0.003, -0.001], [0.003, 0.03, 0.002], [-0.001, 0.002, 0.025]])
    model = fm.Model("mixed")
    cart = fm.RigidBody("cart", 2.0, inertia, 0.1 * w)
    link1 = fm.RigidBody("link1", 0.7, 1.3 * inertia, 0.3 * t + 0.05 * n)
    link2 = fm.RigidBody("link2", 0.4, 0.6 * inertia, 0.2 * t - 0.1 * w)
    blob = fm.RigidBody("blob", 0.3, 0.2 * inertia, 0.05 * w)
    arm = fm.RigidBody("arm", 0.9, inertia, 0.25 * w)
    model.add(fm.Prismatic("rail", model.ground, cart, axis=t),
              fm.Revolute("hinge1", cart, link1, axis=n, parent_point=0.1 * w),
              fm.Revolute("hinge2", link1, link2, axis=-n, parent_point=0.6 * t),
              fm.Fixed("weld", link2, blob, parent_point=0.4 * t + 0.1 * w),
              fm.Revolute("root2", model.ground, arm, axis=n, parent_point=0.5 * w),
              fm.JointSpringDamper("s1", "rail", 30.0, 1.5, 0.1),
              fm.JointSpringDamper("s2", "hinge2", 4.0, 0.2, -0.3),
              fm.Gravity(-9.81 * w + 2.0 * n))
    return model


def _cantilever():
    """Tutorial 03's cantilever: a uniform beam bending in the x-z plane under gravity."""
    model = fm.Model("cantilever")
    section, material = fm.Section.rectangular(0.01, 0.002), fm.Material(7850.0, 2.1e11, 0.3)
    beam = fm.FlexibleBody.uniform_beam("beam", 0.5, section, material, 6, keep=("bend_y",))
    model.add(fm.Fixed("clamp", model.ground, beam), fm.Gravity((0.0, 0.0, -9.81)))
    return model


def _flexible_arm():
    """Tutorial 10's flexible arm: a hub on its motor joint and an aluminium blade clamped to it (x-y plane)."""
    model = fm.Model("flexible arm")
    hub = fm.RigidBody("hub", 1.0, (0.03, 0.03, 0.05))
    arm = fm.FlexibleBody.uniform_beam("arm", 1.0, fm.Section.rectangular(0.005, 0.02), fm.Material.aluminium(), 8,
                                       keep=("bend_z",), damping_ratio=0.005)
    motor = fm.Revolute("motor", model.ground, hub, axis=(0, 0, 1))
    model.add(motor, fm.Fixed("clamp", hub, arm, parent_point=(0.05, 0.0, 0.0)))
    return model


MODELS = {"B1 N=8": lambda: scenes.b1(8), "B1 N=32": lambda: scenes.b1(32), "pendulum": _pendulum,
          "mixed": _mixed, "cantilever": _cantilever, "flexible arm": _flexible_arm}


def _pair(name):
    planar, spatial = MODELS[name]().build(), MODELS[name]().build(planar=False)
    assert planar.planar and not spatial.planar and spatial.planar_reason == "planar=False"
    assert planar._packed_open is not None and spatial._packed_open is not None
    return planar, spatial


def _states(system, rng, count):
    n = system.n_coords
    yield np.zeros(2 * n)
    for _ in range(count):
        yield np.concatenate([rng.normal(0.0, 0.05, n), rng.normal(0.0, 3.0, n)])


def _planar_xdd(ints, floats, y, n):
    """The planar kernels' accelerations, step by step (the parts of ``planar_open_rhs_into``)."""
    nb = ints[0].shape[0]
    K, pA, IA, UD = np.zeros((nb + 1, 20)), np.zeros((nb + 1, 3)), np.zeros((nb + 1, 6)), np.zeros((nb + 1, 4))
    tau, uu, acc, xdd = np.zeros(n), np.zeros(nb + 1), np.zeros((nb + 1, 3)), np.zeros(n)
    P.kinematics(ints, floats, y[:n], y[n:], K)
    P.loads(ints, floats, y[:n], y[n:], K, pA, tau)
    P.inertias(floats, K, IA)
    assert P.factor(ints, K, IA, UD, np.zeros(n), 0.0, 0.0) == -1
    P.backward(ints, K, IA, UD, pA, tau, uu, True)
    P.forward(ints, K, UD, uu, True, acc, xdd)
    return xdd


def _term_scale(system, y):
    """The largest acceleration any one load gives alone at y.

    One load: one coordinate's spring, one coordinate's damper, gravity,
    the velocity products. In a beam the bending moments of neighbouring
    joints nearly cancel, so a single spring's acceleration, not the sum
    of all of them, is the size of the terms that round off.
    """
    ints, floats = (tuple(np.array(a) for a in part) for part in unpack_planar(system._packed))
    n = system.n_coords
    yx0, zero_g, zeros = np.concatenate([y[:n], np.zeros(n)]), np.zeros(2), np.zeros_like(floats[6])
    cases = [(yx0, floats[5], zeros, zeros), (y, zero_g, zeros, zeros)]
    for i in range(zeros.shape[0]):
        one = np.zeros_like(zeros)
        one[i] = 1.0
        cases += [(yx0, zero_g, floats[6] * one, zeros), (y, zero_g, zeros, floats[7] * one)]
    best = 0.0
    for yy, g, k, c in cases:
        xdd = _planar_xdd(ints, (*floats[:5], g, k, c, *floats[8:]), yy, n)
        best = max(best, float(np.max(abs(xdd))))
    return best


def _distance(system, a, b, y):
    """``max |a - b|`` over the term scale (where no load acts, 0 if equal, else infinite)."""
    scale, diff = _term_scale(system, y), np.max(abs(a - b))
    return diff / scale if scale > 0.0 else (0.0 if diff == 0.0 else np.inf)


@pytest.mark.parametrize("name", ["B1 N=8", "pendulum", "mixed", "cantilever", "flexible arm"])
def test_planar_rhs_is_the_spatial_one(name):
    planar, spatial = _pair(name)
    n, rng = planar.n_coords, np.random.default_rng(7)
    for y in _states(planar, rng, 8):
        a, b = planar.state_rate(0.0, y), spatial.state_rate(0.0, y)
        assert _distance(planar, a, b, y) <= TOL
        arm = rng.uniform(0.0, 2.0, n)  # the Newton matrices' diagonal: A + diag(armature)
        (ya, sa), (yb, sb) = open_tree_rhs(planar._packed_open, y, n, arm), open_tree_rhs(spatial._packed_open, y, n,
                                                                                         arm)
        assert sa == sb == -1 and _distance(planar, ya, yb, y) <= TOL


def test_b1_32_agrees_at_a_run_s_states():
    """B1 N = 32 at the states of a run (random states of 32 independent bending angles: see the report)."""
    planar, spatial = _pair("B1 N=32")
    res = fm.simulate(planar, 0.2, n_out=11, progress=False)
    for x, xd in zip(res.x, res.xd):
        y = np.concatenate([x, xd])
        assert _distance(planar, planar.state_rate(0.0, y), spatial.state_rate(0.0, y), y) <= TOL


@pytest.mark.parametrize("method, rtol", [("CVODE_BDF", 1e-10), ("GeneralizedAlpha", 1e-8)])
def test_a_run_planar_and_spatial_agree(method, rtol):
    """CVODE's compiled callback and the compiled generalized-alpha loop, planar and spatial, agree to their tolerance."""
    model = MODELS["mixed"]()
    x0 = {"rail": 0.2, "hinge1": 1.0, "hinge2": -0.5, "root2": 0.3}
    runs = [fm.simulate(model.build(planar=p), 1.0, positions=x0, rtol=rtol, atol=rtol / 100, method=method,
                        progress=False) for p in (None, False)]
    assert all(r.status == "finished" for r in runs)
    scale = np.max(abs(runs[1].x))
    assert np.max(abs(runs[0].x - runs[1].x)) <= rtol * scale  # the integrator's tolerance


@pytest.mark.parametrize("build, why", [
    (lambda: scenes.b2(4).build(), "several coordinates"),
    (lambda: fourbar(spatial=True)[0].build(), "points"),
    (lambda: hc.bricard().build(), "points"),
    (lambda: wiper(WiperOptions(flexible=True, n_segments=4))[0].build(), ""),
])
def test_models_outside_the_plane_are_not_planar(build, why):
    system = build()
    assert not system.planar and why in system.planar_reason
    assert "evaluation: spatial (not planar" in str(system)


def test_a_point_force_or_python_force_is_not_planar():
    model = _pendulum()
    model.add(fm.PointForce("push", "bar", (1.0, 0.0, 0.0), (1.0, 0.0, 0.0)))
    system = model.build()
    assert not system.planar and "point forces" in system.planar_reason
    with pytest.raises(ModelError, match="planar=True: model 'pendulum' is not planar: point forces"):
        model.build(planar=True)
    with pytest.raises(ModelError, match="planar must be True, False or None"):
        _pendulum().build(planar="yes")


def _with(*items):
    """The README pendulum with ``items`` added."""
    model = _pendulum()
    model.add(*items)
    return model


def _bar2():
    return fm.RigidBody("bar2", 0.5, (0.01, 0.02, 0.03), (0.4, 0.0, 0.0))


@frozen(eq=False)
class _Drag(fm.ForceElement):
    """A force element written in Python (no compiled table)."""

    body: fm.Body = fm.reference(fm.Body)

    def apply(self, state, loads):
        i = state.index(self.body)
        loads.add_point_force(i, state.r[i], -0.1 * state.v[i])


@pytest.mark.parametrize("items, why", [
    (lambda: [fm.Revolute("pin2", "bar", _bar2(), axis=(1, 0, 0), parent_point=(1, 0, 0))], "off the plane's normal"),
    (lambda: [fm.Prismatic("rail", "bar", _bar2(), axis=(0, 0, 1))], "slides off the plane"),
    (lambda: [fm.Universal("u", "bar", _bar2(), parent_point=(1, 0, 0))], "several coordinates"),
    (lambda: [fm.Spherical("s", "bar", _bar2(), parent_point=(1, 0, 0))], "several coordinates"),
    (lambda: [fm.Spherical("s", "bar", _bar2(), parent_point=(1, 0, 0), rotation="quaternion")], "Euler parameters"),
    (lambda: [fm.BodyTorque("t", "bar", (0.0, 0.0, 1.0))], "torques"),
    (lambda: [fm.SpringDamper("k", "ground", (0, 1, 0), "bar", (1, 0, 0), 10.0, 0.1, 0.5)], "springs between points"),
    (lambda: [_Drag("drag", "bar")], "force elements evaluated in Python"),
])
def test_open_trees_outside_the_plane_are_not_planar(items, why):
    system = _with(*items()).build()
    assert not system.planar and why in system.planar_reason


def test_a_singular_joint_reports_the_same_body():
    """A point mass pinned at its centre (tests/test_articulated.py's model): both routes name its joint."""
    def model():
        m = fm.Model("massless")
        bar = fm.RigidBody("bar", 1.0, np.diag([0.1, 0.1, 0.1]))
        tip = fm.RigidBody("tip", 1.0, (0.0, 0.0, 0.0))
        m.add(fm.Revolute("pin", m.ground, bar, axis=(0, 0, 1)))
        m.add(fm.Revolute("tip_pin", bar, tip, parent_point=(1, 0, 0), axis=(0, 0, 1)))
        return m

    planar, spatial = fm.System(model(), sparse=True), fm.System(model(), sparse=True, planar=False)
    assert planar.planar and not spatial.planar
    y = np.zeros(4)  # D = 0 exactly in both routes (elsewhere it is round-off of either sign)
    (_, sa), (_, sb) = (open_tree_rhs(s._packed_open, y, 2, np.zeros(2)) for s in (planar, spatial))
    assert sa == sb == [j.name for j in planar.topology.tree_joints].index("tip_pin")
    for system in (planar, spatial):
        with pytest.raises(AssemblyError, match="singular at t = 0 s: joint 'tip_pin' moves no mass"):
            system.state_rate(0.0, y)


def test_the_packed_planar_data_are_the_prototype_s():
    """unpack_planar gives exactly benchmarks/prototypes/planar.py's tuples (the loops' stage builds on them)."""
    sys.path.insert(0, os.path.join(BENCH, "prototypes"))
    from planar import planar_model

    for model in (scenes.b1(8), scenes.b6(damped=True, n_segments=8)[0], scenes.b7(4)[0]):
        system = model.build()
        assert system.planar
        for want, have in zip(planar_model(system), unpack_planar(system._packed)):
            assert len(want) == len(have)
            for a, b in zip(want, have):
                assert a.dtype == b.dtype and a.shape == b.shape
                np.testing.assert_array_equal(a, b)
    empty = unpack_planar(_pendulum().build(planar=False)._packed)
    assert all(a.size == 0 for part in empty for a in part)


def test_the_planar_work_fits_the_open_tree_s():
    from flexmb.kernels.articulated import rhs_work_size

    for nb, n in ((1, 1), (9, 8), (513, 512), (5, 3)):
        assert P.planar_work_size(nb, n) <= rhs_work_size(nb, n)
