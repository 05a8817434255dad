"""Section loads, strains and stresses along flexible bodies; joint load recovery.

References from outside the code: beam statics (a tip force, self weight,
an end torque), the section formulas of strength of materials, Newton-Euler
for the whole beam with inertial forces computed here from the kinematics
(not from the springs), and finite differences of the simulated motion.
"""

from __future__ import annotations

import meshio
import numpy as np
import pytest

import flexmb as fm
from flexmb import post
from flexmb.export import vtk

from conftest import fourbar, fourbar_initial

L, B, H = 1.0, 0.02, 0.005
BETA = 7.7398e-4  # B1: 1 % of critical in the first bending mode


def aluminium():
    return fm.Material(70e9, 2700.0, 0.33, name="aluminium")


def cantilever(n, keep=("bend_y",), damping=0.0, section=None, loads=()):
    """The B1 beam (rebuilt here, not imported from benchmarks/) clamped at the origin."""
    model = fm.Model("cantilever")
    beam = fm.FlexibleBody("beam", L, section or fm.Section.rectangular(B, H), aluminium(), n, keep=keep,
                           damping=damping)
    model.add(fm.Fixed("clamp", model.ground, beam), *[f(beam) for f in loads])
    return model, beam


def statics(model):
    system = model.build()
    return system, fm.Result.from_states(system, fm.linear_statics(system))


# -- statics against closed forms


@pytest.mark.parametrize("n", [4, 7])
def test_tip_force_moments_and_root_stress(n):
    P = 3.0
    model, beam = cantilever(n, loads=[lambda b: fm.PointForce("tip", b, (0.0, 0.0, -P), point=(L, 0.0, 0.0))])
    system, res = statics(model)
    loads = res.section_loads(beam)
    assert loads.components == ("My",) and loads.units == ("N m",)
    np.testing.assert_allclose(loads.stations, np.arange(n) * L / n, rtol=0, atol=1e-15)
    np.testing.assert_allclose(loads.component("My")[0], P * (L - loads.stations), rtol=1e-9)
    sig = res.section_stresses(beam)
    assert sig.component("sigma_bend_y")[0, 0] == pytest.approx(6 * P * L / (B * H * H), rel=1e-9)
    # tension at z = +h/2 for a beam bent down; no torsion, so von Mises = |sigma|
    np.testing.assert_allclose(sig.component("von_mises"), np.abs(sig.component("sigma_bend_y")), rtol=1e-12)
    # strains: M = E I kappa, the clamp lumping half a segment
    kappa = res.section_strains(beam).component("kappa_y")[0]
    np.testing.assert_allclose(aluminium().E * B * H**3 / 12 * kappa, P * (L - loads.stations), rtol=1e-9)


@pytest.mark.parametrize("n", [5, 8])
def test_self_weight_moments(n):
    g = 9.81
    model, beam = cantilever(n, loads=[lambda b: fm.Gravity((0.0, 0.0, -g))])
    _, res = statics(model)
    loads = res.section_loads(beam)
    rho_a = 2700.0 * B * H
    np.testing.assert_allclose(loads.component("My")[0], rho_a * g * (L - loads.stations) ** 2 / 2, rtol=1e-9)


@pytest.mark.parametrize("section, radius", [(fm.Section.circular(0.01), 0.005),
                                             (fm.Section.tube(0.012, 0.008), 0.006)])
def test_shaft_end_torque(section, radius):
    T = 2.5
    model, shaft = cantilever(6, keep=("torsion", "bend_y", "bend_z"), section=section,
                              loads=[lambda b: fm.BodyTorque("twist", b, (T, 0.0, 0.0), point=(L, 0.0, 0.0))])
    _, res = statics(model)
    loads = res.section_loads(shaft)
    assert loads.components == ("Mx", "My", "Mz")
    np.testing.assert_allclose(loads.component("Mx")[0], T, rtol=1e-9)
    np.testing.assert_allclose(loads.values[0, :, 1:], 0.0, atol=1e-9 * T)
    J = section.J
    sig = res.section_stresses(shaft)
    np.testing.assert_allclose(sig.component("tau_torsion")[0], T * radius / J, rtol=1e-9)
    np.testing.assert_allclose(sig.component("von_mises")[0], np.sqrt(3) * T * radius / J, rtol=1e-9)
    # twist rate T / (G J) along the shaft
    G = aluminium().G
    np.testing.assert_allclose(res.section_strains(shaft).component("twist")[0], T / (G * J), rtol=1e-9)


def test_rectangle_torsion_formula():
    # Roark: tau_max = T (3 w + 1.8 t) / (w^2 t^2), w the long side; 4.8 T / a^3 for a square
    w, t = 0.02, 0.005
    assert fm.Section.rectangular(w, t).torsion_modulus() == pytest.approx(w * w * t * t / (3 * w + 1.8 * t))
    assert fm.Section.rectangular(t, w).torsion_modulus() == pytest.approx(w * w * t * t / (3 * w + 1.8 * t))
    assert 1 / fm.Section.rectangular(0.01, 0.01).torsion_modulus() == pytest.approx(4.8 / 1e-6)
    with pytest.raises(fm.ModelError, match="outer-fibre"):
        fm.Section(1e-4, 1e-9, 1e-9, 2e-9).torsion_modulus()


def test_circular_bending_combines_axes():
    # a tip force at 45 deg: sigma_max = |M| c / I with |M| = P (L - x)
    P = 1.0
    d = 0.01
    f = P * np.array([0.0, 1.0, -1.0]) / np.sqrt(2)
    model, beam = cantilever(4, keep=("bend_y", "bend_z"), section=fm.Section.circular(d),
                             loads=[lambda b: fm.PointForce("tip", b, f, point=(L, 0.0, 0.0))])
    _, res = statics(model)
    sig = res.section_stresses(beam)
    x = res.section_loads(beam).stations
    np.testing.assert_allclose(sig.component("sigma_max")[0], P * (L - x) * 32 / (np.pi * d**3), rtol=1e-9)


# -- joint loads (reaction recovery) against statics


def test_joint_loads_hold_the_straight_beam():
    g, n = 9.81, 6
    model, beam = cantilever(n, loads=[lambda b: fm.Gravity((0.0, 0.0, -g))])
    system = model.build()
    x0 = np.zeros(system.n_coords)
    res = fm.Result.from_states(system, x0, xdd=x0)  # the loads that hold it straight and at rest
    jl = res.joint_loads(system)
    assert jl.names == ["clamp"] + [f"beam.j{i}" for i in range(n)]
    m = 2700.0 * B * H * L
    force, moment = jl.joint("clamp")
    np.testing.assert_allclose(force[0], [0.0, 0.0, -m * g], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(moment[0], [0.0, m * g * L / 2, 0.0], rtol=1e-12, atol=1e-12)
    xs = np.arange(n) * L / n
    np.testing.assert_allclose(jl.moment[0, 1:, 1], m / L * g * (L - xs) ** 2 / 2, rtol=1e-12)
    np.testing.assert_allclose(jl.force[0, 1:, 2], -m / L * g * (L - xs), rtol=1e-12)


def test_section_loads_with_system_fill_the_rigid_directions():
    P = 3.0
    model, beam = cantilever(4, loads=[lambda b: fm.PointForce("tip", b, (0.0, 0.0, -P), point=(L, 0.0, 0.0))])
    system = model.build()
    x = fm.linear_statics(system)
    res = fm.Result.from_states(system, x, xdd=np.zeros_like(x))  # held at rest in the deflected shape
    full = res.section_loads(beam, system)
    assert full.components == ("N", "Vy", "Vz", "Mx", "My", "Mz")
    kept = res.section_loads(beam).component("My")
    np.testing.assert_array_equal(full.component("My"), kept)
    # the tip force seen in each (slightly rotated) segment frame: |(N, Vz)| = P
    np.testing.assert_allclose(np.hypot(full.component("N"), full.component("Vz"))[0], P, rtol=1e-9)
    np.testing.assert_allclose(full.component("Mz")[0], 0.0, atol=1e-12)
    # by name, through the system
    np.testing.assert_array_equal(res.section_loads("beam", system).values, full.values)


# -- dynamics: the damped B1 beam


@pytest.fixture(scope="module")
def b1_run():
    model, beam = cantilever(4, damping=BETA, loads=[lambda b: fm.Gravity((0.0, 0.0, -9.81))])
    system = model.build()
    res = fm.simulate(system, 0.2, n_out=9, method="Radau", rtol=1e-7)
    return system, beam, res


def test_root_moment_balances_gravity_and_inertia(b1_run):
    system, beam, res = b1_run
    root = res.section_loads(beam).component("My")[:, 0]  # 2k eta + 2c etadot
    g = np.array([0.0, 0.0, -9.81])
    rows = [system.topology.index[s] for s in system.topology.flexible[beam][1]]
    checked = 0
    for i in range(1, len(res.t)):
        kin = system.kinematics(res.t[i], res.x[i], res.xd[i])
        # accelerations from the kinematics (eqs. 13, 18), not from the springs
        a = (kin.V @ res.xdd[i] + kin.a_bias)[rows]
        alpha = (kin.W @ res.xdd[i] + kin.alpha_bias)[rows]
        I = kin.inertia_world()[rows]
        w = kin.omega[rows]
        m = kin.mass[rows][:, None]
        force = m * (g - a)
        torque = -(np.einsum("kij,kj->ki", I, alpha) + np.cross(w, np.einsum("kij,kj->ki", I, w)))
        about_clamp = np.sum(np.cross(kin.r[rows], force) + torque, axis=0)
        assert root[i] == pytest.approx(about_clamp[1], rel=1e-6)
        assert abs(about_clamp[1] - m.sum() * 9.81 * L / 2) > 1e-3 * abs(root[i])  # inertia matters here
        checked += 1
    assert checked == 8


def test_root_moment_against_differenced_motion(b1_run):
    # inertial forces from finite differences of the mass-centre positions over the output times
    system, beam, res = b1_run
    fine = fm.simulate(system, 0.02, n_out=41, method="Radau", rtol=1e-8, atol=1e-11)
    rows = [system.topology.index[s] for s in system.topology.flexible[beam][1]]
    r = fine.positions[:, rows]
    a = np.gradient(np.gradient(r, fine.t, axis=0), fine.t, axis=0)
    m = 2700.0 * B * H * L / 4
    l = L / 4
    # segment pitch = sum of the joint angles (planar); its angular acceleration by differences too
    theta = np.cumsum(fine.x, axis=1)
    theta_dd = np.gradient(np.gradient(theta, fine.t, axis=0), fine.t, axis=0)
    f = m * (np.array([0.0, 0.0, -9.81]) - a)
    approx = np.cross(r, f).sum(axis=1)[:, 1] - m * (l * l + H * H) / 12 * theta_dd.sum(axis=1)
    root = fine.section_loads(beam).component("My")[:, 0]
    inner = slice(5, -5)
    assert np.abs(root[inner] - approx[inner]).max() < 2e-3 * np.abs(root).max()


def test_joint_loads_match_the_springs_in_motion(b1_run):
    system, beam, res = b1_run
    jl = res.joint_loads(system)
    sec = res.section_loads(beam).component("My")
    scale = np.abs(sec).max()
    np.testing.assert_allclose(jl.moment[:, 1:, 1], sec, rtol=0, atol=1e-9 * scale)
    # the clamp and the root segment joint carry the same load (the clamp frame is massless)
    np.testing.assert_allclose(jl.moment[:, 0, 1], sec[:, 0], rtol=0, atol=1e-9 * scale)


def test_fourbar_constraint_loads_and_body_balance():
    model = fourbar()
    system = model.build()
    res = fm.simulate(system, 0.3, positions=fourbar_initial(), n_out=61, rtol=1e-10, atol=1e-12)
    i = 30
    kin = system.kinematics(res.t[i], res.x[i], res.xd[i])
    force, torque, _, _ = post.constraint_loads(system, kin, res.reactions[i])
    gen = np.einsum("kin,ki->n", kin.V[:-1], force[:-1]) + np.einsum("kin,ki->n", kin.W[:-1], torque[:-1])
    psi = system.constraints.evaluate(kin, level=1).psi
    np.testing.assert_allclose(gen, psi.T @ res.reactions[i], atol=1e-10)
    # rocker: ground pin D and cut pin C (rocker is the child of both) plus gravity = m a,
    # a from differences of the simulated mass-centre path
    jl = res.joint_loads(system)
    k = res.body_names.index("rocker")
    R = res.rotations[i, k]
    total = -(R @ jl.joint("D")[0][i]) - (R @ jl.joint("C")[0][i]) + 0.25 * np.array([0.0, -9.81, 0.0])
    a = np.gradient(np.gradient(res.positions[:, k], res.t, axis=0), res.t, axis=0)[i]
    np.testing.assert_allclose(total, 0.25 * a, atol=2e-3 * 0.25 * 9.81)


def test_pendulum_pin_force_closed_form():
    # slender bar, pivot at its end, gravity -y: at angle theta and rate w the pin must supply
    # m (a_c - g), a_c = alpha x r_c - w^2 r_c, alpha = -3 g cos(theta) / (2 L)
    m, length, g, theta, w = 1.3, 0.8, 9.81, 0.4, 2.0
    model = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", m, length)
    model.add(fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1)), fm.Gravity((0.0, -g, 0.0)))
    system = model.build()
    res = fm.Result.from_states(system, [theta], [w])
    e = np.array([np.cos(theta), np.sin(theta), 0.0])
    rc = 0.5 * length * e
    alpha = -3 * g * np.cos(theta) / (2 * length)
    a_c = np.cross([0.0, 0.0, alpha], rc) - w * w * rc
    pin = m * (a_c - np.array([0.0, -g, 0.0]))
    force, moment = res.joint_loads(system).joint("pin")
    R = res.rotations[0, 0]
    np.testing.assert_allclose(R @ force[0], -pin, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(moment[0], 0.0, atol=1e-12)  # a pin transmits no moment about its axis here


# -- envelope, interpolation, bad input


def test_envelope_and_at():
    model, beam = cantilever(4, loads=[lambda b: fm.Gravity((0.0, 0.0, -9.81))])
    system = model.build()
    x = fm.linear_statics(system)
    res = fm.Result.from_states(system, [x, -2 * x, 0.5 * x])
    loads = res.section_loads(beam)
    env = loads.envelope()
    np.testing.assert_array_equal(env.index, 1)
    np.testing.assert_array_equal(env.time, res.t[1])
    np.testing.assert_allclose(env.value, -2 * loads.values[0])
    np.testing.assert_allclose(env.component("My"), 2 * np.abs(loads.values[0, :, 0]))
    np.testing.assert_allclose(loads.at(0.5), -0.5 * loads.values[0])
    assert loads.at([0.0, 2.0]).shape == (2, 4, 1)


def test_bad_input_is_named(tmp_path):
    model, beam = cantilever(4, loads=[lambda b: fm.Gravity((0.0, 0.0, -9.81))])
    bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    model.add(fm.Fixed("weld", beam, bar, parent_point=(L, 0.0, 0.0)))
    system = model.build()
    res = fm.simulate(system, 0.01, n_out=3, method="Radau")
    with pytest.raises(fm.FlexmbError, match="'bar' is not a flexible body"):
        res.section_loads(bar)
    with pytest.raises(fm.FlexmbError, match="'bar' is not a flexible body of the result"):
        res.section_stresses("bar", system)
    # a result keeps the system it came from, so a name works; a loaded one does not keep it
    np.testing.assert_array_equal(res.section_loads("beam").values, res.section_loads(beam).values)
    res.save(tmp_path / "r.npz")
    with pytest.raises(fm.FlexmbError, match="pass the FlexibleBody"):
        fm.Result.load(tmp_path / "r.npz").section_loads("beam")
    with pytest.raises(fm.FlexmbError, match=r"time 0.5 s is outside the result, which covers \[0, 0.01\]"):
        res.section_loads(beam).at(0.5)
    with pytest.raises(fm.FlexmbError, match="no component 'Mx'"):
        res.section_loads(beam).component("Mx")
    other, _ = cantilever(3)
    with pytest.raises(fm.FlexmbError, match="does not match the result"):
        res.joint_loads(other.build())


# -- export and plots


def test_vtk_section_fields_read_back(tmp_path):
    model, beam = cantilever(4, keep=("torsion", "bend_y", "bend_z"), damping=BETA,
                             loads=[lambda b: fm.Gravity((0.0, -3.0, -9.0))])
    # a rigid tip mass: its points come first in the files, before the beam's centre line
    model.add(fm.Fixed("mount", beam, fm.RigidBody("tip", 0.02, np.eye(3) * 1e-6, (0.0, 0.02, 0.0)),
                       parent_point=(L, 0.0, 0.0)))
    system = model.build()
    res = fm.simulate(system, 0.01, n_out=3, method="Radau", rtol=1e-6)
    pvd = res.export_vtk(tmp_path, system=system)
    loads = res.section_loads(beam)
    vm = res.section_stresses(beam).component("von_mises")
    for i in range(len(res.t)):
        mesh = meshio.read(pvd.parent / f"flexmb_{i:04d}.vtu")
        # the beam's centre line: its root, joints 1..3 and tip; the tip mass's box comes first in the files
        line = [k for k, c in enumerate(mesh.cells) if c.type == "line"][0]
        centre = mesh.cells[line].data[mesh.cell_data["part_id"][line] == vtk.PARTS.index("centre line")]
        stations = np.append(centre[:, 0], centre[-1, 1])
        others = np.setdiff1d(np.arange(len(mesh.points)), stations)
        hexes = [c for c in mesh.cells if c.type == "hexahedron"][0].data
        box = hexes[0]  # the tip mass, drawn as the box of its inertia
        assert len(stations) == 5 and stations[0] > box.max()
        for field, comp in vtk.SECTION_FIELDS.items():
            np.testing.assert_allclose(mesh.point_data[field][stations[:4]], loads.component(comp)[i], rtol=1e-12,
                                       atol=0)
            np.testing.assert_array_equal(mesh.point_data[field][[*box, stations[4]]], 0.0)
        np.testing.assert_allclose(mesh.point_data["von_mises"][stations[:4]], vm[i], rtol=1e-12, atol=0)
        # the segments' blocks carry the values of the joints at their ends
        assert set(np.unique(mesh.point_data["von_mises"][others])) <= set(mesh.point_data["von_mises"][stations])
    assert np.abs(loads.component("Mx")[-1]).max() > 0  # the offset tip mass twists the beam
    assert "von_mises" not in vtk.to_meshio(res, 0).point_data  # without a system: no section data


def test_stress_plots(b1_run, tmp_path):
    pytest.importorskip("matplotlib")
    from flexmb import viz

    _, beam, res = b1_run
    sig = res.section_stresses(beam)
    fig = viz.plot_envelope(sig, tmp_path / "env.png")
    line = fig.axes[0].lines[0]
    np.testing.assert_allclose(line.get_ydata(), 1e-6 * sig.envelope().component("sigma_max"))
    fig = viz.plot_station(sig, tmp_path / "root.png", components="sigma_bend_y")
    np.testing.assert_allclose(fig.axes[0].lines[0].get_ydata(), 1e-6 * sig.component("sigma_bend_y")[:, 0])
    assert (tmp_path / "env.png").stat().st_size > 0 and (tmp_path / "root.png").stat().st_size > 0
    with pytest.raises(fm.ExportError, match="station 9"):
        viz.plot_station(sig, station=9)


def test_joint_loads_default_to_the_system_that_made_the_result(tmp_path):
    model, beam = cantilever(4, loads=[lambda b: fm.Gravity((0.0, 0.0, -9.81))])
    res = fm.simulate(model, 0.01, n_out=3)
    own = res.joint_loads()
    given = res.joint_loads(res.system)
    assert own.names == given.names
    np.testing.assert_array_equal(own.moment, given.moment)
    res.save(tmp_path / "r.npz")
    with pytest.raises(fm.ModelError, match="needs the system the result came from"):
        fm.Result.load(tmp_path / "r.npz").joint_loads()


def _free_top():
    """A free body (Euler parameters) under gravity with a pendulum hanging from it: a spatial tree."""
    model = fm.Model()
    top = fm.RigidBody("top", 2.0, (0.1, 0.2, 0.3))
    bob = fm.RigidBody("bob", 0.5, (0.02, 0.03, 0.04))
    model.add(fm.Free("float", model.ground, top), fm.Spherical("ball", top, bob, parent_point=(0.1, 0.0, 0.2)),
              fm.Gravity((0.0, 0.0, -9.81)))
    return model


@pytest.mark.parametrize("make", ["cantilever", "fourbar", "free_top"])
def test_accelerations_by_a_second_pass_equal_the_partial_velocity_form(make):
    """joint_loads' body accelerations: ``v`` and ``omega`` of the tree at the speeds xdd are ``V xdd``, ``W xdd``.

    The identity that lets :func:`flexmb.post.joint_loads` skip the partial
    velocity arrays (quadratic in memory), on a flexible body, a loop and a
    free body (Euler parameters), at a random state.
    """
    model = {"cantilever": lambda: cantilever(4, keep=("bend_y", "bend_z", "torsion"))[0], "fourbar": fourbar,
             "free_top": _free_top}[make]()
    system = model.build()
    rng = np.random.default_rng(2)
    x = system.layout.reference() + 0.3 * rng.normal(size=system.n_coords)
    x = system.layout.normalized(x)  # unit Euler parameters
    xd, xdd = rng.normal(size=system.n_speeds), rng.normal(size=system.n_speeds)
    kin = system.kinematics(0.0, x, xd)
    at_xdd = system.kinematics(0.0, x, xdd)
    np.testing.assert_allclose(at_xdd.v, kin.V @ xdd, rtol=0, atol=1e-13 * max(1.0, np.abs(kin.V @ xdd).max()))
    np.testing.assert_allclose(at_xdd.omega, kin.W @ xdd, rtol=0, atol=1e-13 * max(1.0, np.abs(kin.W @ xdd).max()))
