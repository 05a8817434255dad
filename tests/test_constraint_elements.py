"""Constraint elements (position and velocity rows) against closed forms: knife edge, rolling disc, gear pair.

Velocity rows ``B xd = b`` enter psi, the complement, the speed projections,
the initial-speed assembly and the reactions, never the position projection
(docs/constraints.md).
"""

from __future__ import annotations

import numpy as np
import pytest
from attrs import frozen

import flexmb as fm

G, R_DISC, M_DISC = 9.81, 0.3, 1.2
M_SLEIGH, I_SLEIGH, A_SLEIGH = 2.0, 0.05, 0.3


def sleigh_model():
    """A Chaplygin sleigh: a free body on a knife edge at its frame origin, mass centre a ahead along x."""
    model = fm.Model("sleigh")
    body = fm.RigidBody("sleigh", M_SLEIGH, (0.05, 0.05, I_SLEIGH), com=(A_SLEIGH, 0, 0))
    return model.add(fm.Free("free", model.ground, body), fm.KnifeEdge("blade", body))


def sleigh_closed_form(t, v0, w0):
    """Forward speed v and yaw rate w of the Chaplygin sleigh.

    The equations (Bloch, *Nonholonomic Mechanics and Control*, 2003, sec.
    1.7; Neimark and Fufaev, *Dynamics of Nonholonomic Systems*, 1972),
    with ``J = I + m a^2``, are ``v' = a w^2`` and ``J w' = -m a v w``. The
    energy ``E = (m v^2 + J w^2) / 2`` is conserved, so with ``c^2 = 2 E / m``,
    ``v' = (m a / J)(c^2 - v^2)``: ``v = c tanh(k (t - t0))``,
    ``w = sign(w0) sqrt(m / J) c sech(k (t - t0))`` with ``k = m a c / J``
    and ``t0 = -artanh(v0 / c) / k``.
    """
    J = I_SLEIGH + M_SLEIGH * A_SLEIGH**2
    c = np.sqrt((M_SLEIGH * v0**2 + J * w0**2) / M_SLEIGH)
    k = M_SLEIGH * A_SLEIGH * c / J
    t0 = -np.arctanh(v0 / c) / k
    return c * np.tanh(k * (t - t0)), np.sign(w0) * np.sqrt(M_SLEIGH / J) * c / np.cosh(k * (t - t0))


def sleigh_speeds(res):
    heading = res.x[:, 5]  # at rx = ry = 0 the Bryant rz is the heading and its rate the yaw rate
    forward = res.xd[:, 0] * np.cos(heading) + res.xd[:, 1] * np.sin(heading)
    lateral = -res.xd[:, 0] * np.sin(heading) + res.xd[:, 1] * np.cos(heading)
    return forward, lateral, res.xd[:, 5]


@pytest.mark.parametrize("method", ["DOP853", "Radau", "BDF", "CVODE_BDF", "IDA", "GeneralizedAlpha"])
def test_chaplygin_sleigh_follows_the_closed_form(method):
    """Forward speed and yaw rate against :func:`sleigh_closed_form`, with each kind of integrator."""
    if method in ("CVODE_BDF", "IDA"):
        pytest.importorskip("sksundae", reason="SUNDIALS needs scikit-sundae")
    v0, w0 = 0.5, 2.0
    tol = dict(rtol=1e-10, atol=1e-12) if method != "GeneralizedAlpha" else dict(rtol=1e-8, atol=1e-10)
    res = fm.simulate(sleigh_model(), 3.0, speeds={"free.x": v0, "free.rz": w0}, method=method, n_out=31, **tol)
    forward, lateral, yaw = sleigh_speeds(res)
    v, w = sleigh_closed_form(res.t, v0, w0)
    err = 1e-8 if method in ("DOP853", "Radau") else 1e-5
    assert np.max(np.abs(forward - v)) < err
    assert np.max(np.abs(yaw - w)) < err
    assert np.max(np.abs(lateral)) < 1e-9  # the knife edge holds
    assert np.max(np.abs(res.x[:, 2:5])) < 1e-9  # the motion stays in the plane


def test_sleigh_reaction_is_the_blade_force():
    """The row's multiplier is the lateral blade force ``m (a w' + v w)`` (Newton's law across the blade)."""
    v0, w0 = 0.5, 2.0
    res = fm.simulate(sleigh_model(), 1.0, speeds={"free.x": v0, "free.rz": w0}, rtol=1e-10, atol=1e-12, n_out=11)
    forward, _, yaw = sleigh_speeds(res)
    J = I_SLEIGH + M_SLEIGH * A_SLEIGH**2
    w_dot = -M_SLEIGH * A_SLEIGH * forward * yaw / J
    assert res.constraint_labels == ["blade.normal"]
    np.testing.assert_allclose(res.reactions[:, 0], M_SLEIGH * (A_SLEIGH * w_dot + forward * yaw), rtol=1e-8)


def test_velocity_rows_do_not_move_positions_and_initial_speeds_satisfy_them():
    system = sleigh_model().build()
    assert system.constraints.holonomic.tolist() == [False] and system.dof() == 5
    x = np.array([0.3, -0.2, 0.0, 0.0, 0.0, 0.7])
    xd = np.array([1.0, 1.0, 0.0, 0.0, 0.0, 0.5])
    xp, vp = system.project(0.0, x, xd)
    np.testing.assert_array_equal(xp, x)  # a velocity row has no position form
    B = system.equations(0.0, xp, vp).psi
    assert abs(B[0] @ vp) < 1e-14
    # the initial-speed assembly: the yaw rate held, the lateral speed taken out
    x0, xd0 = fm.initial_state(system, x0=x, speeds={"free.x": 1.0, "free.rz": 0.5})
    assert abs(system.equations(0.0, x0, xd0).psi[0] @ xd0) < 1e-14 and xd0[5] == 0.5
    with pytest.raises(fm.ModelError, match="blade.normal"):  # a lateral speed held against the blade
        fm.initial_state(system, x0=x, speeds={"free.x": 1.0, "free.y": 1.0})


def test_auto_takes_the_dense_complement_and_articulated_refuses():
    system = sleigh_model().build(complement="auto")
    assert not system._loop_kernel
    res = fm.simulate(system, 0.5, speeds={"free.x": 0.5, "free.rz": 2.0}, rtol=1e-10, atol=1e-12, n_out=6)
    v, w = sleigh_closed_form(res.t, 0.5, 2.0)
    assert np.max(np.abs(sleigh_speeds(res)[2] - w)) < 1e-8
    with pytest.raises(fm.ModelError, match=r"articulated.*'blade'"):
        sleigh_model().build(complement="articulated")
    with pytest.raises(fm.ModelError, match=r"articulated.*'blade'"):
        fm.simulate(system, 0.1, complement="articulated")


def test_nonholonomic_linearisation_and_statics_are_refused_by_name():
    system = sleigh_model().build()
    with pytest.raises(fm.ModelError, match=r"linearize: .*velocity.*'blade'"):
        fm.linearize(system)
    with pytest.raises(fm.ModelError, match=r"static equilibrium: .*'blade'"):
        fm.static_equilibrium(system)


# --------------------------------------------------------------------------- rolling disc
def disc_model():
    """A thin uniform disc (radius r, mass m) rolling on the plane z = 0.

    Coordinates: the centre's x, y (prismatics), z and heading psi (a
    cylindrical joint about z), lean theta (about the heading direction) and
    spin phi (about the disc's axis, body y); the intermediate frames carry
    1e-12 kg and no inertia.
    """
    model = fm.Model("disc")
    frames = [fm.RigidBody(f"frame{i}", 1e-12, (0.0, 0.0, 0.0)) for i in range(4)]
    disc = fm.RigidBody("disc", M_DISC, (M_DISC * R_DISC**2 / 4, M_DISC * R_DISC**2 / 2, M_DISC * R_DISC**2 / 4))
    return model.add(
        fm.Prismatic("px", model.ground, frames[0], axis=(1, 0, 0)),
        fm.Prismatic("py", frames[0], frames[1], axis=(0, 1, 0)),
        fm.Cylindrical("heading", frames[1], frames[2], axis=(0, 0, 1)),
        fm.Revolute("lean", frames[2], frames[3], axis=(1, 0, 0)),
        fm.Revolute("spin", frames[3], disc, axis=(0, 1, 0)),
        fm.Gravity((0, 0, -G)), fm.RollingDisc("roll", disc, R_DISC, axis=(0, 1, 0)))


def steady_spin(theta, omega):
    """The spin rate of a thin disc rolling steadily at lean ``theta`` with heading rate ``omega``.

    With the axis ``a = cos(theta) n + sin(theta) k`` (n horizontal, k up),
    ``w3 = omega sin(theta) + phi'`` the angular velocity along the axis, the
    centre moving at ``r w3`` on a circle: the moment of momentum about the
    centre (``I_a = m r^2 / 2``, ``I_d = m r^2 / 4``) and Newton's law give
    the classical steady-motion condition (e.g. Greenwood, *Principles of
    Dynamics*, 2nd ed. 1988, the rolling disc; O'Reilly, Nonlinear Dynamics
    10, 1996, 287-305)

        (I_a + m r^2) w3 omega cos(theta) - I_d omega^2 sin(theta) cos(theta) + m g r sin(theta) = 0.

    Returns ``phi'``.
    """
    Ia, Id = M_DISC * R_DISC**2 / 2, M_DISC * R_DISC**2 / 4
    s, c = np.sin(theta), np.cos(theta)
    w3 = (Id * omega**2 * s * c - M_DISC * G * R_DISC * s) / ((Ia + M_DISC * R_DISC**2) * omega * c)
    return w3 - omega * s


@pytest.mark.parametrize("theta, omega", [(0.2, 3.0), (-0.35, 5.0)])
def test_rolling_disc_keeps_its_steady_precession(theta, omega):
    spin = steady_spin(theta, omega)
    res = fm.simulate(disc_model(), 2.0, positions={"heading.slide": R_DISC, "lean": theta},
                      speeds={"heading.angle": omega, "lean": 0.0, "spin": spin}, fixed=["lean"],
                      rtol=1e-10, atol=1e-12, n_out=21)
    names = res.coordinate_names
    lean, yaw, phi = (names.index(n) for n in ("lean.angle", "heading.angle", "spin.angle"))
    assert np.max(np.abs(res.x[:, lean] - theta)) < 1e-8
    assert np.max(np.abs(res.xd[:, yaw] - omega)) < 1e-8
    assert np.max(np.abs(res.xd[:, phi] - spin)) < 1e-8
    # the contact row: the centre at r cos(theta) above the plane
    assert np.max(np.abs(res.x[:, names.index("heading.slide")] - R_DISC * np.cos(theta))) < 1e-10
    # the wrong relation (10 % more spin) does not stay steady: the test can fail
    off = fm.simulate(disc_model(), 2.0, positions={"heading.slide": R_DISC, "lean": theta},
                      speeds={"heading.angle": omega, "lean": 0.0, "spin": 1.1 * spin}, fixed=["lean"],
                      rtol=1e-10, atol=1e-12, n_out=21)
    assert np.max(np.abs(off.x[:, lean] - theta)) > 1e-3


@pytest.mark.parametrize("spin, rel", [(10.0, 1e-6), (2.0, 1e-4)])
def test_rolling_disc_upright_lean_history_follows_the_linear_closed_form(spin, rel):
    """A thin disc rolling upright at spin rate s, pushed to lean at rate theta'(0).

    Linearised about upright rolling (Euler's equations about the centre,
    the contact force from Newton's law; the same steps as
    :func:`steady_spin`, to first order in the lean theta and heading psi):
    ``(I_d + m r^2) theta'' = m g r theta + (I_a + m r^2) s psi'`` and
    ``I_d psi'' = -I_a s theta'``, so ``psi' = -(I_a / I_d) s theta`` and, for
    the thin disc, ``theta'' = (4 / 5)(g / r - 3 s^2) theta``: a lean
    oscillation at ``w^2 = (4 / 5)(3 s^2 - g / r)`` above the classical
    critical speed ``s^2 = g / (3 r)`` (the thin disc's self-stability, e.g.
    Neimark and Fufaev 1972; Astrom, Klein and Lennartsson, IEEE Control
    Systems 25, 2005, 26-47), an exponential fall below it. The relative
    tolerance covers the neglected terms, of the order of the squared lean
    amplitude (7e-5 and 7e-3 rad here).
    """
    lean_rate = 1e-3
    res = fm.simulate(disc_model(), 1.0, positions={"heading.slide": R_DISC},
                      speeds={"heading.angle": 0.0, "lean": lean_rate, "spin": spin}, fixed=["lean"],
                      rtol=1e-11, atol=1e-13, n_out=51)
    lean = res.x[:, res.coordinate_names.index("lean.angle")]
    rate2 = 0.8 * (G / R_DISC - 3 * spin**2)
    root = np.sqrt(abs(rate2))
    ref = lean_rate / root * (np.sinh(root * res.t) if rate2 > 0 else np.sin(root * res.t))
    assert np.max(np.abs(lean - ref)) < rel * np.max(np.abs(lean))


def test_rolling_disc_perturbed_run_conserves_energy_and_rolls():
    theta, omega = 0.2, 3.0
    res = fm.simulate(disc_model(), 3.0, positions={"heading.slide": R_DISC, "lean": theta},
                      speeds={"heading.angle": omega, "lean": 0.4, "spin": steady_spin(theta, omega)},
                      fixed=["lean"], rtol=1e-10, atol=1e-12, n_out=61)
    lean = res.x[:, res.coordinate_names.index("lean.angle")]
    assert np.ptp(lean) > 0.05  # it nutates
    assert np.ptp(res.energy) < 1e-8 * np.max(np.abs(res.energy))  # rolling without slipping does no work
    system = disc_model().build()
    worst = max(system.constraint_residual(t, x, xd) for t, x, xd in zip(res.t, res.x, res.xd))
    assert worst < 1e-9


# --------------------------------------------------------------------------- gear pair
def gear_model(ratio, k=40.0, I1=0.02, I2=0.5):
    model = fm.Model("gears")
    a = fm.RigidBody("wheel1", 1.0, (I1, I1, I1))
    b = fm.RigidBody("wheel2", 1.0, (I2, I2, I2))
    return model.add(fm.Revolute("shaft1", model.ground, a), fm.Revolute("shaft2", model.ground, b),
                     fm.JointSpringDamper("spring", "shaft1", k),
                     fm.GearPair("mesh", "shaft1", "shaft2", ratio=ratio))


@pytest.mark.parametrize("complement", ["svd", "auto", "eigen"])
def test_gear_pair_holds_the_ratio_and_oscillates_at_the_reflected_inertia(complement):
    """``q1 = n q2`` with a spring k on shaft 1: ``(I1 + I2 / n^2) q1'' + k q1 = 0``, so
    ``q1 = A cos(w t)`` with ``w = sqrt(k / (I1 + I2 / n^2))`` (the inertia reflected through the gears)."""
    n, k, I1, I2, A = -3.0, 40.0, 0.02, 0.5, 0.4
    res = fm.simulate(gear_model(n, k, I1, I2), 2.0, positions={"shaft1": A, "shaft2": 0.1}, fixed=["shaft1"],
                      complement=complement, rtol=1e-10, atol=1e-12, n_out=41)
    q1, q2 = res.x[:, 0], res.x[:, 1]
    assert abs(q2[0] - A / n) < 1e-12  # assembled by the ratio
    assert np.max(np.abs(q1 - n * q2)) < 1e-10
    w = np.sqrt(k / (I1 + I2 / n**2))
    assert np.max(np.abs(q1 - A * np.cos(w * res.t))) < 1e-7
    assert np.ptp(res.energy) < 1e-9 * res.energy[0]


def test_a_gear_pair_beside_a_quaternion_joint_sizes_its_rows_per_speed():
    """Beside a free body in Euler parameters (4 coordinates, 3 speeds) a model has more coordinates than speeds:
    a constraint element's rows are per speed (psi was sized by the coordinates and refused)."""
    n, k, I1, I2, A = -3.0, 40.0, 0.02, 0.5, 0.4
    model = gear_model(n, k, I1, I2)
    model.add(fm.Free("float", model.ground, fm.RigidBody("probe", 1.0, (0.1, 0.2, 0.3)), rotation="quaternion"))
    res = fm.simulate(model, 2.0, positions={"shaft1": A, "shaft2": 0.1}, fixed=["shaft1"],
                      speeds={"float.wx": 0.3, "float.wy": 2.0, "float.wz": 0.2}, rtol=1e-10, atol=1e-12, n_out=41)
    names = res.coordinate_names
    q1, q2 = res.x[:, names.index("shaft1.angle")], res.x[:, names.index("shaft2.angle")]
    assert res.x.shape[1] == res.xd.shape[1] + 1
    assert np.max(np.abs(q1 - n * q2)) < 1e-10
    w = np.sqrt(k / (I1 + I2 / n**2))
    assert np.max(np.abs(q1 - A * np.cos(w * res.t))) < 1e-7


def test_a_rack_and_pinion_is_a_gear_pair_of_a_prismatic_and_a_revolute():
    model = fm.Model("rack")
    rack, pinion = fm.RigidBody("rack", 2.0, (0.1, 0.1, 0.1)), fm.RigidBody("pinion", 1.0, (0.01, 0.01, 0.01))
    model.add(fm.Prismatic("slide", model.ground, rack, axis=(1, 0, 0)), fm.Revolute("pin", model.ground, pinion),
              fm.GearPair("teeth", "slide", "pin", ratio=0.05), fm.PointForce("push", rack, (3.0, 0, 0)))
    res = fm.simulate(model, 1.0, rtol=1e-10, atol=1e-12, n_out=11)
    # (m + I / r^2) s'' = F
    s_dd = 3.0 / (2.0 + 0.01 / 0.05**2)
    np.testing.assert_allclose(res.x[:, 0], 0.5 * s_dd * res.t**2, atol=1e-10)
    np.testing.assert_allclose(res.x[:, 0], 0.05 * res.x[:, 1], atol=1e-12)


@frozen(eq=False)
class Belt(fm.ConstraintElement):
    """``w1 - w2 = s0 sin(f t)`` between two shafts: a rheonomic velocity row, which does work."""

    n_velocity = 1

    def rows(self, state):
        B = np.array([[1.0, -1.0]])
        return fm.velocity_rows(B, [0.3 * np.sin(4.0 * state.t)], [1.2 * np.cos(4.0 * state.t)])


def test_a_rheonomic_row_s_work_closes_the_energy_balance():
    model = fm.Model()
    a, b = fm.RigidBody("a", 1.0, (0.2, 0.2, 0.2)), fm.RigidBody("b", 1.0, (0.1, 0.1, 0.1))
    model.add(fm.Revolute("p", model.ground, a), fm.Revolute("q", model.ground, b), Belt("belt"))
    res = fm.simulate(model, 2.0, speeds={"p": 1.0}, rtol=1e-10, atol=1e-12, n_out=21, track_work=True)
    assert np.max(np.abs(res.xd[:, 0] - res.xd[:, 1] - 0.3 * np.sin(4.0 * res.t))) < 1e-10
    gain = res.kinetic - res.kinetic[0]
    assert np.ptp(gain) > 1e-3  # the slip changes the kinetic energy: the balance is not 0 = 0
    np.testing.assert_allclose(res.work["constraint belt"], gain, atol=1e-9)


# --------------------------------------------------------------------------- bad input
@frozen(eq=False)
class WrongShape(fm.ConstraintElement):
    n_velocity = 2

    def rows(self, state):
        return fm.velocity_rows(np.zeros((1, state.x.shape[0])), np.zeros(1), np.zeros(1))


@frozen(eq=False)
class Failing(fm.ConstraintElement):
    n_position = 1

    def rows(self, state):
        raise RuntimeError("boom")


@frozen(eq=False)
class BadCount(fm.ConstraintElement):
    n_velocity = -1


@frozen(eq=False)
class BadNames(fm.ConstraintElement):
    n_velocity = 2

    def row_names(self):
        return ["only"]


def _pendulum(*extra):
    model = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    return model.add(fm.Revolute("pin", model.ground, bar), *extra)


def test_bad_elements_are_named():
    with pytest.raises(fm.ModelError, match=r"constraint element 'w' \(WrongShape\).*psi of shape \(1, 1\), "
                                            r"expected \(2, 1\)"):
        _pendulum(WrongShape("w")).build()
    with pytest.raises(fm.ModelError, match=r"constraint element 'c' \(BadCount\): n_velocity must be a whole"):
        _pendulum(BadCount("c")).build()
    with pytest.raises(fm.ModelError, match=r"constraint element 'n' \(BadNames\): row_names\(\) gave 1 names"):
        _pendulum(BadNames("n")).build()
    with pytest.raises(fm.ModelError, match=r"constraint element 'f' \(Failing\) failed: RuntimeError: boom"):
        _pendulum(Failing("f")).build()
    with pytest.raises(fm.ModelError, match=r"no joint named 'nope'"):
        _pendulum(fm.GearPair("g", "pin", "nope")).build()
    with pytest.raises(fm.ModelError, match=r"constraint element 'g': coordinate2 = 3"):
        _pendulum(fm.GearPair("g", "pin", "pin", coordinate2=3)).build()
    with pytest.raises(fm.ModelError, match=r"RollingDisc 'r'.*radius"):
        fm.RollingDisc("r", "bar", -1.0)
    with pytest.raises(fm.ModelError, match=r"duplicate constraint element name 'k'"):
        _pendulum(fm.KnifeEdge("k", "bar"), fm.KnifeEdge("k", "bar")).build()


def test_flat_disc_is_refused_by_name():
    model = fm.Model()
    disc = fm.RigidBody("disc", 1.0, (1.0, 2.0, 1.0))
    model.add(fm.Free("free", model.ground, disc), fm.RollingDisc("roll", disc, 0.3, axis=(0, 0, 1)))
    with pytest.raises(fm.ModelError, match=r"'roll' \(RollingDisc\): the disc lies flat"):
        model.build()
