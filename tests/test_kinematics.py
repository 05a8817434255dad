"""Contract tests of the stacked kinematics, the joint motions and the constraint rows.

What is checked
---------------
For every joint type alone (Revolute, PlanarRevolute, Prismatic, Cylindrical,
Universal, Spherical, Fixed, Free) and for random mixed trees (branched and
unbranched) built by ``random_chain``, with ``kin = system.kinematics(t, x, xd)``:

* ``V @ xd`` and ``W @ xd`` equal the derivatives of the mass-centre
  positions ``r`` and of the rotations ``R`` (skew part of ``Rdot R^T``)
  along the path ``x(t) = x + xd t``, ground row included;
* column by column, ``V`` is the Jacobian ``dr/dx`` and ``W`` the vee of
  ``dR/dx_i R^T``;
* ``V xdd + a_bias`` and ``W xdd + alpha_bias`` equal the second derivatives
  along ``x(t) = x + xd t + xdd t^2 / 2`` (``alpha`` is the vee of the skew
  part of ``Rddot R^T``, as ``Rdot Rdot^T`` is symmetric);
* each joint class's ``motion(q, qd)``: ``R`` is a proper rotation, the
  markers coincide at ``q = 0``, ``Hw``/``Hv`` are the derivatives of
  ``R``/``d`` with respect to ``q`` and ``aw``/``av`` equal ``(d/dt H) qd``;
* ``point_position``/``point_velocity``/``point_partials``/
  ``point_bias_acceleration`` agree with the same derivatives for random
  body points (ground included);
* constraint rows of loops closed by every cut-joint type (planar four-bar
  with spatial and planar revolute cuts, a spatial RSSR, loops closed by
  Universal, Prismatic, Cylindrical, Fixed, Spherical and Revolute cuts, and
  random trees with a random cut): ``psi = dphi/dx``, ``b = 0`` and
  ``gamma = -(d/dt psi) xd`` at random, non-closed states; a cut joint that
  duplicates a tree joint between the same markers is satisfied identically
  (``phi = psi = gamma = 0``); the row counts follow the declared primitives.

Tolerances
----------
Derivatives use fourth-order central differences with step ``h = 1e-3``:
truncation ``O(h^4) ~ 1e-12`` times the fifth/sixth path derivatives, and
round-off ``~ eps |f| / h ~ 1e-13`` for first and ``~ eps |f| / h^2 ~ 1e-10``
for second derivatives (``|f|`` of a few metres). First derivatives are
asserted to ``1e-8`` and second derivatives to ``1e-6``, relative to
``max(1, |reference|)``: a hundred-fold margin over the errors observed
over many seeds, yet far below any sign or term error (order 1).
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import JOINT_TYPES, fourbar, fourbar_initial, random_body, random_chain, random_rotation

import flexmb as fm
from flexmb.errors import ModelError

H = 1e-3
TOL1 = 1e-8  # first derivatives
TOL2 = 1e-6  # second derivatives
OFFSETS = (-2, -1, 0, 1, 2)
D1 = np.array([1.0, -8.0, 0.0, 8.0, -1.0]) / (12.0 * H)
D2 = np.array([-1.0, 16.0, -30.0, 16.0, -1.0]) / (12.0 * H * H)

ALL_JOINTS = JOINT_TYPES + [fm.PlanarRevolute]


# -- helpers ---------------------------------------------------------------

def stencil(samples, weights):
    """Apply finite-difference weights to samples at ``OFFSETS * H``."""
    return np.tensordot(weights, np.asarray(samples), axes=1)


def vee(S):
    """Axial vector of the skew part of (stacked) 3x3 matrices."""
    A = 0.5 * (S - np.swapaxes(S, -1, -2))
    return np.stack([A[..., 2, 1], A[..., 0, 2], A[..., 1, 0]], axis=-1)


def assert_close(actual, expected, tol, what=""):
    actual, expected = np.asarray(actual), np.asarray(expected)
    assert actual.shape == expected.shape, (what, actual.shape, expected.shape)
    scale = max(1.0, float(np.max(np.abs(expected), initial=0.0)))
    err = float(np.max(np.abs(actual - expected), initial=0.0))
    assert err <= tol * scale, f"{what}: max error {err:.3e} > {tol:.1e} * {scale:.3g}"


def path(system, x, xd, xdd=None, t=0.0):
    """Kinematics at the stencil points of ``x(s) = x + xd s + xdd s^2 / 2``."""
    xdd = np.zeros_like(x) if xdd is None else xdd
    out = []
    for o in OFFSETS:
        s = o * H
        out.append(system.kinematics(t + s, x + xd * s + 0.5 * xdd * s * s, xd + xdd * s))
    return out


def random_state(system, rng, scale=1.0):
    n = system.n_coords
    return (rng.uniform(-scale, scale, n), rng.normal(size=n), rng.normal(size=n))


def single_type_model(cls, rng):
    """An unbranched chain: two joints of ``cls``, a revolute, ``cls`` again."""
    return random_chain(rng, types=[cls, cls, fm.Revolute, cls], branch=False)


def mixed_model(seed):
    rng = np.random.default_rng(seed)
    if seed % 3 == 0:
        types = None  # one of each, branched
        branch = True
    elif seed % 3 == 1:
        types = None
        branch = False
    else:
        types = list(rng.choice(np.array(JOINT_TYPES, dtype=object), 10))
        branch = True
    return random_chain(rng, types=types, branch=branch), rng


def model_cases():
    cases = []
    for cls in ALL_JOINTS:
        cases.append(pytest.param(("single", cls, 7), id=f"only-{cls.__name__}"))
    for seed in range(6):
        cases.append(pytest.param(("mixed", None, seed), id=f"mixed-{seed}"))
    return cases


def build_case(case):
    kind, cls, seed = case
    if kind == "single":
        rng = np.random.default_rng(seed)
        model = single_type_model(cls, rng)
    else:
        model, rng = mixed_model(seed)
    system = model.build()
    return system, rng


# -- stacked kinematics ----------------------------------------------------

@pytest.mark.parametrize("case", model_cases())
def test_velocities_are_path_derivatives(case):
    system, rng = build_case(case)
    x, xd, _ = random_state(system, rng)
    kin = system.kinematics(0.3, x, xd)
    ks = path(system, x, xd, t=0.3)
    nb = system.topology.n_bodies

    assert kin.R.shape == (nb + 1, 3, 3) and kin.V.shape == (nb + 1, 3, system.n_coords)
    # ground row
    np.testing.assert_array_equal(kin.R[-1], np.eye(3))
    np.testing.assert_array_equal(kin.r[-1], np.zeros(3))
    assert not np.any(kin.V[-1]) and not np.any(kin.W[-1])
    # rotations stay proper
    assert_close(kin.R @ np.swapaxes(kin.R, 1, 2), np.broadcast_to(np.eye(3), kin.R.shape), 1e-12, "R R^T")
    assert_close(np.linalg.det(kin.R), np.ones(nb + 1), 1e-12, "det R")

    r_dot = stencil([k.r for k in ks], D1)
    R_dot = stencil([k.R for k in ks], D1)
    omega_fd = vee(R_dot @ np.swapaxes(kin.R, 1, 2))
    # Rdot R^T must be skew: its symmetric part is d/dt (R R^T) / 2 = 0
    sym = 0.5 * (R_dot @ np.swapaxes(kin.R, 1, 2) + kin.R @ np.swapaxes(R_dot, 1, 2))
    assert_close(sym, np.zeros_like(sym), TOL1, "sym(Rdot R^T)")

    assert_close(kin.V @ xd, r_dot, TOL1, "V xd")
    assert_close(kin.W @ xd, omega_fd, TOL1, "W xd")
    assert_close(kin.v, r_dot, TOL1, "v")
    assert_close(kin.omega, omega_fd, TOL1, "omega")
    # the body origin moves consistently with the mass centre
    com = np.vstack([system.topology.com, np.zeros((1, 3))])
    assert_close(kin.r, kin.origin + np.einsum("kij,kj->ki", kin.R, com), 1e-12, "r = origin + R com")


@pytest.mark.parametrize("case", model_cases())
def test_partial_velocities_are_jacobians(case):
    system, rng = build_case(case)
    x, xd, _ = random_state(system, rng)
    kin = system.kinematics(0.0, x, xd)
    n = system.n_coords
    for i in range(n):
        e = np.zeros(n)
        e[i] = 1.0
        ks = path(system, x, e)
        dr = stencil([k.r for k in ks], D1)
        dR = stencil([k.R for k in ks], D1)
        assert_close(kin.V[:, :, i], dr, TOL1, f"V[:, :, {i}]")
        assert_close(kin.W[:, :, i], vee(dR @ np.swapaxes(kin.R, 1, 2)), TOL1, f"W[:, :, {i}]")


@pytest.mark.parametrize("case", model_cases())
def test_bias_accelerations_are_second_derivatives(case):
    system, rng = build_case(case)
    x, xd, xdd = random_state(system, rng)
    kin = system.kinematics(0.0, x, xd)
    ks = path(system, x, xd, xdd)
    r_dd = stencil([k.r for k in ks], D2)
    R_dd = stencil([k.R for k in ks], D2)
    alpha_fd = vee(R_dd @ np.swapaxes(kin.R, 1, 2))
    assert_close(kin.V @ xdd + kin.a_bias, r_dd, TOL2, "V xdd + a_bias")
    assert_close(kin.W @ xdd + kin.alpha_bias, alpha_fd, TOL2, "W xdd + alpha_bias")
    # also the angular acceleration as the derivative of omega along the path
    alpha_from_omega = stencil([k.omega for k in ks], D1)
    assert_close(kin.W @ xdd + kin.alpha_bias, alpha_from_omega, TOL1, "alpha = d omega / dt")
    # the bias terms alone: the accelerations at xdd = 0
    ks0 = path(system, x, xd)
    assert_close(kin.a_bias, stencil([k.r for k in ks0], D2), TOL2, "a_bias")
    assert_close(kin.alpha_bias, stencil([k.omega for k in ks0], D1), TOL1, "alpha_bias")


@pytest.mark.parametrize("case", model_cases())
def test_point_kinematics(case):
    system, rng = build_case(case)
    x, xd, xdd = random_state(system, rng)
    nb = system.topology.n_bodies
    k = np.append(np.arange(nb), -1)  # every body and the ground
    local = rng.normal(size=(nb + 1, 3))
    kin = system.kinematics(0.0, x, xd)
    P = kin.point_position(k, local)
    assert_close(P, np.einsum("kij,kj->ki", kin.R[k], local) + kin.origin[k], 1e-12, "point_position")
    assert_close(P[-1], local[-1], 0.0, "ground point")

    ks = path(system, x, xd, xdd)
    Ps = [kk.point_position(k, local) for kk in ks]
    ks0 = path(system, x, xd)
    Ps0 = [kk.point_position(k, local) for kk in ks0]
    Vp = kin.point_partials(k, P)
    assert Vp.shape == (nb + 1, 3, system.n_coords)

    v_fd = stencil(Ps0, D1)
    assert_close(Vp @ xd, v_fd, TOL1, "point_partials xd")
    assert_close(kin.point_velocity(k, P), v_fd, TOL1, "point_velocity")
    assert_close(kin.point_bias_acceleration(k, P), stencil(Ps0, D2), TOL2, "point_bias_acceleration")
    assert_close(Vp @ xdd + kin.point_bias_acceleration(k, P), stencil(Ps, D2), TOL2, "point acceleration")
    # column by column: the Jacobian of the point positions
    n = system.n_coords
    for i in rng.choice(n, size=min(n, 4), replace=False) if n else []:
        e = np.zeros(n)
        e[i] = 1.0
        dP = stencil([kk.point_position(k, local) for kk in path(system, x, e)], D1)
        assert_close(Vp[:, :, i], dP, TOL1, f"point_partials[:, :, {i}]")


def test_kinematics_depend_on_x_only():
    """Positions, rotations and partials do not depend on t or xd (scleronomic tree)."""
    rng = np.random.default_rng(3)
    system = random_chain(rng).build()
    x, xd, _ = random_state(system, rng)
    a = system.kinematics(0.0, x, xd)
    b = system.kinematics(5.0, x, -3.0 * xd)
    for name in ("R", "r", "origin", "V", "W"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert_close(b.omega, -3.0 * a.omega, 1e-14, "omega linear in xd")
    assert_close(b.a_bias, 9.0 * a.a_bias, 1e-12, "a_bias quadratic in xd")
    assert_close(b.alpha_bias, 9.0 * a.alpha_bias, 1e-12, "alpha_bias quadratic in xd")


def test_reference_configuration_places_markers_together():
    """At x = 0 each joint's child marker coincides with its parent marker."""
    rng = np.random.default_rng(11)
    model = random_chain(rng)
    system = model.build()
    kin = system.kinematics(0.0, np.zeros(system.n_coords), np.zeros(system.n_coords))
    for j in system.topology.tree_joints:
        fp, fc = j.frames()
        ip, ic = system.index(j.parent), system.index(j.child)
        assert_close(kin.point_position(ic, j.child_point), kin.point_position(ip, j.parent_point), 1e-12, j.name)
        assert_close(kin.R[ic] @ fc, kin.R[ip] @ fp, 1e-12, j.name)


# -- joint motions ---------------------------------------------------------

@pytest.mark.parametrize("cls", ALL_JOINTS, ids=lambda c: c.__name__)
def test_joint_motion_partials(cls):
    rng = np.random.default_rng(21)
    m, nq = 5, len(cls.translation_axes) + len(cls.rotation_axes)
    q = rng.uniform(-1.2, 1.2, (m, nq))
    qd = rng.normal(size=(m, nq))
    R, d, Hw, Hv, aw, av = cls.motion(q, qd)
    assert R.shape == (m, 3, 3) and d.shape == (m, 3)
    assert Hw.shape == Hv.shape == (m, 3, nq) and aw.shape == av.shape == (m, 3)
    assert_close(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), 1e-13, "R R^T")
    assert_close(np.linalg.det(R), np.ones(m), 1e-13, "det R")

    def sample(direction, q0=q, rate=qd):
        return [cls.motion(q0 + o * H * direction, rate) for o in OFFSETS]

    # Hw, Hv column by column: derivatives of R and d w.r.t. each coordinate
    for i in range(nq):
        e = np.zeros(nq)
        e[i] = 1.0
        s = sample(e)
        dR = stencil([o[0] for o in s], D1)
        dd = stencil([o[1] for o in s], D1)
        S = dR @ np.swapaxes(R, 1, 2)
        assert_close(S + np.swapaxes(S, 1, 2), np.zeros_like(S), TOL1, "dR R^T skew")
        assert_close(Hw[:, :, i], vee(S), TOL1, f"Hw[:, :, {i}]")
        assert_close(Hv[:, :, i], dd, TOL1, f"Hv[:, :, {i}]")
    # aw, av: (d/dt H) qd along q + qd t (each joint moves along its own qd)
    s = [cls.motion(q + o * H * qd, qd) for o in OFFSETS]
    Hw_dot = stencil([o[2] for o in s], D1)
    Hv_dot = stencil([o[3] for o in s], D1)
    assert_close(aw, np.einsum("mij,mj->mi", Hw_dot, qd), TOL1, "aw")
    assert_close(av, np.einsum("mij,mj->mi", Hv_dot, qd), TOL1, "av")
    # and the angular acceleration of the relative motion is Hw qdd + aw
    R_dd = stencil([o[0] for o in s], D2)
    w = np.einsum("mij,mj->mi", Hw, qd)
    assert_close(vee(R_dd @ np.swapaxes(R, 1, 2)), aw, TOL2, "relative angular acceleration")
    assert_close(stencil([o[1] for o in s], D2), av, TOL2, "relative acceleration")
    assert_close(vee(stencil([o[0] for o in s], D1) @ np.swapaxes(R, 1, 2)), w, TOL1, "relative omega")


@pytest.mark.parametrize("cls", ALL_JOINTS, ids=lambda c: c.__name__)
def test_joint_motion_layout(cls):
    """Coordinates: translations along fixed parent axes first, then rotations; zero is identity."""
    rng = np.random.default_rng(5)
    nt, nr = len(cls.translation_axes), len(cls.rotation_axes)
    assert len(cls.coordinate_names) == nt + nr
    zero = np.zeros((1, nt + nr))
    R0, d0, *_ = cls.motion(zero, zero)
    np.testing.assert_allclose(R0[0], np.eye(3), atol=1e-15)
    np.testing.assert_allclose(d0[0], np.zeros(3), atol=1e-15)
    q = rng.uniform(-1, 1, (3, nt + nr))
    R, d, Hw, Hv, *_ = cls.motion(q, np.zeros_like(q))
    expected_d = np.zeros((3, 3))
    for i, ax in enumerate(cls.translation_axes):
        expected_d[:, ax] += q[:, i]
    np.testing.assert_allclose(d, expected_d, atol=1e-15)
    # translations do not rotate; rotations do not translate the marker point
    assert not np.any(Hw[:, :, :nt]) and not np.any(Hv[:, :, nt:])
    if nr:
        # the first rotation is about a fixed axis of the parent marker
        np.testing.assert_allclose(Hw[:, :, nt], np.broadcast_to(np.eye(3)[cls.rotation_axes[0]], (3, 3)),
                                   atol=1e-15)


# -- constraint rows -------------------------------------------------------

def rssr():
    """Spatial RSSR: ground-crank revolute (z), crank-coupler and coupler-rocker (cut) spherical,
    ground-rocker revolute about a skew axis."""
    model = fm.Model("rssr")
    crank = fm.RigidBody.slender_bar("crank", 0.2, 0.1)
    coupler = fm.RigidBody.slender_bar("coupler", 0.5, 0.4)
    rocker = fm.RigidBody.slender_bar("rocker", 0.3, 0.3)
    model.add(
        fm.Revolute("A", model.ground, crank, axis=(0, 0, 1)),
        fm.Spherical("B", crank, coupler, parent_point=(0.1, 0, 0)),
        fm.Revolute("D", model.ground, rocker, parent_point=(0.35, 0.05, 0.1), axis=(1.0, 0.3, -0.2)),
        fm.Spherical("C", coupler, rocker, parent_point=(0.4, 0, 0), child_point=(0.3, 0, 0), cut=True),
        fm.Gravity((0.0, -9.81, 0.0)),
    )
    return model


def closed_by(cls, seed=0, to_ground=False):
    """A loop ground -R-> b1 -S-> b2 -P-> b3 closed by a cut joint of ``cls`` with random markers."""
    rng = np.random.default_rng(100 + seed)
    model = fm.Model(f"closed-by-{cls.__name__}")
    b1, b2, b3 = (random_body(rng, f"b{i}") for i in (1, 2, 3))

    def kw():
        return dict(parent_point=rng.normal(size=3), child_point=rng.normal(size=3),
                    parent_frame=random_rotation(rng), child_frame=random_rotation(rng))

    model.add(fm.Revolute("j1", model.ground, b1, **kw()),
              fm.Spherical("j2", b1, b2, **kw()),
              fm.Prismatic("j3", b2, b3, **kw()))
    ckw = kw()
    if cls is fm.Universal:
        Q = random_rotation(rng)
        ckw = dict(parent_point=ckw["parent_point"], child_point=ckw["child_point"], axis=Q[:, 0], axis2=Q[:, 1])
    model.add(cls("cut", model.ground if to_ground else b1, b3, cut=True, **ckw))
    return model


def random_tree_with_cut(cls, seed):
    rng = np.random.default_rng(200 + seed)
    model = random_chain(rng)
    bodies = [model.ground] + model.bodies
    i, j = sorted(rng.choice(len(bodies), 2, replace=False))
    kw = dict(parent_point=rng.normal(size=3), child_point=rng.normal(size=3))
    if cls is fm.Universal:
        Q = random_rotation(rng)
        kw.update(axis=Q[:, 0], axis2=Q[:, 1])
    else:
        kw.update(parent_frame=random_rotation(rng), child_frame=random_rotation(rng))
    model.add(cls("cut", bodies[i], bodies[j], cut=True, **kw))
    return model


CUT_TYPES = [fm.Revolute, fm.PlanarRevolute, fm.Prismatic, fm.Cylindrical, fm.Universal, fm.Spherical, fm.Fixed]
CUT_ROWS = {fm.Revolute: 5, fm.PlanarRevolute: 2, fm.Prismatic: 5, fm.Cylindrical: 4, fm.Universal: 4,
            fm.Spherical: 3, fm.Fixed: 6}


def loop_cases():
    cases = [
        pytest.param(lambda: fourbar(fm.Revolute), 5, id="fourbar-Revolute"),
        pytest.param(lambda: fourbar(fm.PlanarRevolute), 2, id="fourbar-PlanarRevolute"),
        pytest.param(rssr, 3, id="RSSR"),
    ]
    for cls in CUT_TYPES:
        rows = CUT_ROWS[cls]
        cases.append(pytest.param(lambda c=cls: closed_by(c), rows, id=f"closed-by-{cls.__name__}"))
        cases.append(pytest.param(lambda c=cls: closed_by(c, 1, to_ground=True), rows,
                                  id=f"closed-by-{cls.__name__}-to-ground"))
        cases.append(pytest.param(lambda c=cls: random_tree_with_cut(c, 0), rows,
                                  id=f"random-tree-{cls.__name__}"))
    return cases


@pytest.mark.parametrize("make, rows", loop_cases())
def test_constraint_jacobian_and_bias(make, rows):
    system = make().build()
    assert system.n_constraints == rows == len(system.constraints.labels)
    rng = np.random.default_rng(rows)
    x, xd, xdd = random_state(system, rng)
    n = system.n_coords
    kin = system.kinematics(0.0, x, xd)
    phi, psi, b, gamma = system.constraints.evaluate(kin)
    assert phi.shape == b.shape == gamma.shape == (rows,) and psi.shape == (rows, n)
    assert np.max(np.abs(phi)) > 1e-3  # really evaluated off the closed configuration
    np.testing.assert_array_equal(b, np.zeros(rows))
    # level 0 and 1 give the same rows
    np.testing.assert_array_equal(system.constraints.evaluate(kin, level=0).phi, phi)
    psi1 = system.constraints.evaluate(kin, level=1).psi
    np.testing.assert_array_equal(psi1, psi)

    def phi_at(k):
        return system.constraints.evaluate(k, level=0).phi

    psi_fd = np.empty((rows, n))
    for i in range(n):
        e = np.zeros(n)
        e[i] = 1.0
        psi_fd[:, i] = stencil([phi_at(k) for k in path(system, x, e)], D1)
    assert_close(psi, psi_fd, TOL1, "psi = dphi/dx")

    ks = path(system, x, xd)
    psi_dot = stencil([system.constraints.evaluate(k, level=1).psi for k in ks], D1)
    assert_close(gamma, -psi_dot @ xd, TOL1, "gamma = -(d/dt psi) xd")
    # equivalently phi'' = psi xdd - gamma along x + xd t + xdd t^2 / 2
    phi_dd = stencil([phi_at(k) for k in path(system, x, xd, xdd)], D2)
    assert_close(psi @ xdd - gamma, phi_dd, TOL2, "phi''")


@pytest.mark.parametrize("joint", ["Revolute", "PlanarRevolute"])
def test_fourbar_closed_configuration(joint):
    """At the analytically closed angles phi = 0, and psi xd = 0 for the closed-loop speeds."""
    system = fourbar(getattr(fm, joint)).build()
    ang = fourbar_initial(0.7)
    names = [c.split(".")[0] for c in system.coordinate_names]
    x = np.array([ang[nm] for nm in names])
    kin = system.kinematics(0.0, x, np.zeros(3))
    phi, psi, _, _ = system.constraints.evaluate(kin, level=1)
    assert_close(phi, np.zeros_like(phi), 1e-14, "phi at closure")
    # crank-angle derivative of the closed angles by differences of the analytic solution
    dang = [fourbar_initial(0.7 + o * H) for o in OFFSETS]
    xd = stencil([[a[nm] for nm in names] for a in dang], D1)
    assert_close(psi @ xd, np.zeros(psi.shape[0]), TOL1, "psi xd on the loop")


@pytest.mark.parametrize("cls", CUT_TYPES, ids=lambda c: c.__name__)
def test_cut_joint_admits_its_own_motion(cls):
    """A cut joint duplicating a tree joint (same markers) is satisfied identically.

    The tree joint moves the child exactly as the joint allows, so the cut
    rows must give phi = 0, psi = 0 and gamma = 0 at every state: this ties
    the cut primitives of each class to its motion.
    """
    rng = np.random.default_rng(31)
    model = fm.Model("dup")
    b1, b2 = random_body(rng, "b1"), random_body(rng, "b2")
    kw = dict(parent_point=rng.normal(size=3), child_point=rng.normal(size=3))
    if cls is fm.Universal:
        Q = random_rotation(rng)
        kw.update(axis=Q[:, 0], axis2=Q[:, 1])
    else:
        kw.update(parent_frame=random_rotation(rng), child_frame=random_rotation(rng))
    model.add(fm.Free("free", model.ground, b1, parent_point=rng.normal(size=3)),
              cls("tree", b1, b2, **kw), cls("cut", b1, b2, cut=True, **kw))
    system = model.build()
    assert system.topology.cut_joints == [model["cut"]]
    for _ in range(3):
        x, xd, _ = random_state(system, rng)
        phi, psi, b, gamma = system.constraints.evaluate(system.kinematics(0.0, x, xd))
        assert phi.shape == (CUT_ROWS[cls],)
        assert_close(phi, np.zeros_like(phi), 1e-12, "phi")
        assert_close(psi, np.zeros_like(psi), 1e-12, "psi")
        assert_close(gamma, np.zeros_like(gamma), 1e-12, "gamma")


@pytest.mark.parametrize("cls", CUT_TYPES, ids=lambda c: c.__name__)
def test_cut_rows_remove_the_joint_constrained_freedoms(cls):
    """Free body cut to the ground: rank(psi) = 6 - joint freedoms, and T spans the joint's motion."""
    rng = np.random.default_rng(41)
    model = fm.Model("free-cut")
    b = random_body(rng, "b")
    kw = dict(parent_point=rng.normal(size=3), child_point=rng.normal(size=3))
    if cls is fm.Universal:
        Q = random_rotation(rng)
        kw.update(axis=Q[:, 0], axis2=Q[:, 1])
    else:
        kw.update(parent_frame=random_rotation(rng), child_frame=random_rotation(rng))
    cut = cls("cut", model.ground, b, cut=True, **kw)
    model.add(fm.Free("free", model.ground, b), cut)
    system = model.build()
    x = rng.uniform(-1, 1, 6)
    psi = system.constraints.evaluate(system.kinematics(0.0, x, np.zeros(6)), level=1).psi
    s = np.linalg.svd(psi, compute_uv=False)
    rank = int(np.sum(s > 1e-10 * s[0]))
    expected = 2 if cls is fm.PlanarRevolute else 6 - cut.n_coords
    assert rank == expected


def test_free_cut_joint_is_rejected():
    model = fm.Model()
    b = fm.RigidBody("b", mass=1.0, inertia=(1.0, 1.0, 1.0))
    model.add(fm.Revolute("j", model.ground, b), fm.Free("loose", model.ground, b, cut=True))
    with pytest.raises(ModelError, match="imposes no constraint"):
        model.build()
