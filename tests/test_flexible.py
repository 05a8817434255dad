"""Validation of flexible bodies (finite rigid segments with elastic joints).

Each test compares the segment model with an independent reference
(Euler-Bernoulli / Saint-Venant closed forms, the rigid-body limit, energy
balance, Southwell's rotating-beam estimate, a quasi-static solution) with
tolerances set by the requirements, and checks the observed convergence
order where the model claims one (1/N^2).

References used below:

* cantilever under its own weight:   w_tip = rho A g L^4 / (8 E I)
* cantilever under a tip force P:    w_tip = P L^3 / (3 E I)
* force P at x = a:                  w_tip = P a^2 (3 L - a) / (6 E I)
* cantilever bending frequencies:    f_i = (beta_i L)^2 / (2 pi) sqrt(E I / (rho A L^4))
* clamped-free shaft in torsion:     f_1 = sqrt(G J / (rho I_p)) / (4 L)
* rotating cantilever, first mode (Southwell): w^2 = w0^2 + k Omega^2 with
  k = 1.193 out of the plane of rotation, and k = 1.193 - 1 in the plane
  of rotation (the centrifugal stiffening minus the in-plane spin softening).
"""

from __future__ import annotations

import numpy as np
import pytest

import flexmb as fm
from conftest import fourbar_initial

G_ACC = 9.81
BETA_L = np.array([1.8751041, 4.6940911, 7.8547574])

# B1: aluminium strip 20 mm x 5 mm, 1 m long
B1_SECTION = fm.Section.rectangular(0.02, 0.005)
B1_MATERIAL = fm.Material.aluminium()
B1_L = 1.0


# ----------------------------------------------------------------------------- helpers

def cantilever(n, gravity=True, keep=("bend_y",), section=B1_SECTION, material=B1_MATERIAL, length=B1_L,
               **kw):
    """A flexible beam clamped to the ground by a Fixed joint; gravity along -z."""
    model = fm.Model("cantilever")
    beam = fm.FlexibleBody("beam", length, section, material, n_segments=n, keep=keep, **kw)
    model.add(fm.Fixed("clamp", model.ground, beam))
    if gravity:
        model.add(fm.Gravity((0.0, 0.0, -G_ACC)))
    return model, beam


def linear_tip_z(beam, eta):
    """Tip z of a clamped bend_y beam to first order: -sum_j eta_j (L - x_j), x_j = j l."""
    x_j = np.arange(beam.n_joints) * beam.segment_length
    return -float(np.sum(np.asarray(eta) * (beam.length - x_j)))


def tip_point(system, beam, x):
    """Inertial tip position of a flexible body from the (nonlinear) kinematics."""
    kin = system.kinematics(0.0, x, np.zeros_like(x))
    k = system.topology.index[system.topology.flexible[beam][1][-1]]
    return kin.origin[k] + kin.R[k][:, 0] * beam.segment_length


def elastic_columns(system, beam):
    return system.topology.elastic_columns(beam)


def order(errors, ns):
    """Observed convergence order from a log-log fit of |error| against N."""
    return -np.polyfit(np.log(ns), np.log(np.abs(errors)), 1)[0]


# ----------------------------------------------------------------------------- 1. B1 convergence

@pytest.fixture(scope="module")
def b1_results():
    """Linear-statics tip deflection and the first 3 frequencies of B1 at N = 16 and 32."""
    rho_a = B1_MATERIAL.density * B1_SECTION.area
    ei = B1_MATERIAL.E * B1_SECTION.Iy
    out = {"w_ref": rho_a * G_ACC * B1_L**4 / (8 * ei),
           "f_ref": BETA_L**2 / (2 * np.pi) * np.sqrt(ei / (rho_a * B1_L**4)),
           "N": (16, 32), "w": [], "f": []}
    for n in out["N"]:
        model, beam = cantilever(n)
        system = model.build()
        x = fm.linear_statics(system)
        out["w"].append(-linear_tip_z(beam, x[elastic_columns(system, beam)]))
        freqs, _ = fm.modes(cantilever(n, gravity=False)[0].build(), 3)
        out["f"].append(freqs)
    out["w"], out["f"] = np.array(out["w"]), np.array(out["f"])
    return out


@pytest.mark.parametrize("n", [1, 5, 32])
def test_b1_one_coordinate_per_segment(n):
    model, beam = cantilever(n)
    system = model.build()
    assert system.n_coords == n == beam.n_elastic == beam.n_joints
    assert system.coordinate_names == [f"beam.j{i}.bend_y" for i in range(n)]
    assert len(elastic_columns(system, beam)) == n


def test_b1_reference_values_from_data(b1_results):
    # the closed forms evaluated from the section and material data
    assert b1_results["w_ref"] == pytest.approx(0.0227031, rel=5e-6)
    assert b1_results["f_ref"][0] == pytest.approx(4.1126, rel=1e-4)


def test_b1_static_tip_deflection_converges_at_second_order(b1_results):
    w, ref = b1_results["w"], b1_results["w_ref"]
    err = (w - ref) / ref
    assert np.all(w > 0), "gravity along -z must bend the tip down"
    assert abs(err[-1]) < 0.15e-2, f"N = 32 static tip error {err[-1]:.3%}"
    p = np.log2(err[0] / err[1])
    assert 1.8 < p < 2.2, f"static tip deflection: observed order {p:.3f} (errors {err})"


def test_b1_static_tip_deflection_matches_kinematics():
    # the first-order tip formula agrees with the nonlinear kinematics at the linear-statics state
    model, beam = cantilever(16)
    system = model.build()
    x = fm.linear_statics(system)
    tip = tip_point(system, beam, x)
    assert tip[2] == pytest.approx(linear_tip_z(beam, x), rel=5e-4)
    assert tip[1] == 0.0


@pytest.mark.parametrize("i, tol", [(0, 0.1e-2), (1, 0.25e-2), (2, 0.4e-2)])
def test_b1_frequencies_converge_at_second_order(b1_results, i, tol):
    f, ref = b1_results["f"][:, i], b1_results["f_ref"][i]
    err = (f - ref) / ref
    assert abs(err[-1]) < tol, f"f{i + 1} at N = 32: {f[-1]:.5f} Hz vs {ref:.5f} Hz ({err[-1]:.3%})"
    p = np.log2(err[0] / err[1])
    assert 1.8 < p < 2.2, f"f{i + 1}: observed order {p:.3f} (errors {err})"


# ----------------------------------------------------------------------------- 2. nonlinear statics

def test_b1_nonlinear_statics_close_to_linear():
    n = 16
    model, beam = cantilever(n)
    system = model.build()
    x_lin = fm.linear_statics(system)
    x_nl = fm.static_equilibrium(system)
    w_lin = -linear_tip_z(beam, x_lin[elastic_columns(system, beam)])
    w_nl = -tip_point(system, beam, x_nl)[2]
    rel = (w_lin - w_nl) / w_lin
    # the elastica under its own weight sags a little less than linear theory
    assert 0.0 < rel < 1e-3, f"nonlinear tip {w_nl:.7f} m vs linear {w_lin:.7f} m ({rel:.4%} below)"
    # the generalized force residual vanishes at the equilibrium, not at the linear solution
    scale = beam.mass * G_ACC * beam.length
    resid_nl = np.max(np.abs(fm.linearize(system, x_nl).F))
    resid_lin = np.max(np.abs(fm.linearize(system, x_lin).F))
    assert resid_nl < 1e-10 * scale
    assert resid_lin > 1e-6 * scale


# ----------------------------------------------------------------------------- 3. torsion

def test_shaft_torsion_frequency_converges():
    section, material = fm.Section.circular(0.02), fm.Material.steel()
    ref = np.sqrt(material.G * section.J / (material.density * section.polar)) / (4 * 1.0)
    ns = np.array([8, 16, 32])
    f = []
    for n in ns:
        model, shaft = cantilever(n, gravity=False, keep=("torsion",), section=section, material=material)
        system = model.build()
        assert system.coordinate_names == [f"beam.j{i}.torsion" for i in range(n)]
        f.append(fm.modes(system, 1)[0][0])
    err = (np.array(f) - ref) / ref
    assert abs(err[-1]) < 0.1e-2, f"N = 32: {f[-1]:.3f} Hz vs {ref:.3f} Hz"
    p = order(err, ns)
    assert 1.8 < p < 2.2, f"torsion: observed order {p:.3f} (errors {err})"


# ----------------------------------------------------------------------------- 4. rigid limit

PEND_T = np.linspace(0.0, 1.0, 101)
PEND_START = {"positions": {"pivot": np.pi / 2}, "speeds": {"pivot": 4.0}}


def _pendulum(body):
    model = fm.Model("pendulum")
    model.add(fm.Revolute("pivot", model.ground, body, axis=(0, 1, 0)), fm.Gravity((0.0, 0.0, -G_ACC)))
    return fm.simulate(model, 1.0, t_eval=PEND_T, rtol=1e-8, method="DOP853" if isinstance(body, fm.RigidBody)
                       else "Radau", **PEND_START)


def test_rigid_limit_of_a_pinned_flexible_pendulum():
    """A very stiff pinned beam swings like the rigid bar with the same mass and inertia.

    The pendulum starts hanging (along -z, pivot angle pi/2) with a speed: the
    undeformed beam is then exactly in quasi-static balance, so no elastic
    vibration is released and the rigid limit is clean. Swing amplitude ~1.1 rad.
    """
    L, rho, s = B1_L, B1_MATERIAL.density, B1_SECTION
    mass = rho * s.area * L
    # the segments carry rotary inertia rho l I: the rigid bar gets the same total
    inertia = np.diag([rho * L * s.polar, mass * L**2 / 12 + rho * L * s.Iy, mass * L**2 / 12 + rho * L * s.Iz])
    rigid = _pendulum(fm.RigidBody("bar", mass, inertia, (L / 2, 0.0, 0.0)))
    theta = rigid.coordinate("pivot") - np.pi / 2
    assert np.ptp(theta) > 1.0

    runs = {}
    for scale in (1e6, 1e9, 1e12):
        material = fm.Material(B1_MATERIAL.E * scale, rho, 0.33)
        beam = fm.FlexibleBody("beam", L, s, material, 4, keep=("bend_y",), clamped=False)
        res = _pendulum(beam)
        assert res.method == "Radau"
        assert res.coordinate_names[0] == "pivot.angle" and len(res.coordinate_names) == 4
        runs[scale] = res
        err = np.max(np.abs(res.coordinate("pivot") - np.pi / 2 - theta)) / np.max(np.abs(theta))
        assert err < 1e-5, f"E x {scale:g}: pivot angle differs from the rigid bar by {err:.2e} (relative)"
    # the elastic deflection is the quasi-static one, proportional to 1/E
    eta = {k: np.max(np.abs(r.x[:, 1:])) for k, r in runs.items()}
    assert 1e-10 < eta[1e6] < 1e-7
    assert 300 < eta[1e6] / eta[1e9] < 3000
    # Radau's work does not grow with the stiffness: E x 1e6 .. 1e12 spans 3 decades of
    # frequency at ~100-500 steps. (Measured at rtol 1e-8: E x 1e3 needs ~38,000 steps and
    # E x 1e5 ~20,000 -- there h omega ~ 1-50 and Radau resolves the tiny elastic
    # vibration; beyond ~1e6 the elastic modes are filtered out and the count settles.)
    steps = {k: r.n_steps for k, r in runs.items()}
    assert steps[1e9] <= 2 * steps[1e6] and steps[1e12] <= 2 * steps[1e6], steps
    assert max(steps.values()) < 2000, steps


# ----------------------------------------------------------------------------- 5. spin-up beam B3

B3_L, B3_T, B3_OMEGA = 10.0, 15.0, 6.0
# rho A = 1200 * 1e-3 = 1.2 kg/m; E I = 1.4e10 * 1e-6 = 1.4e4 N m^2 (about y and z)
B3_SECTION = fm.Section(area=1e-3, Iy=1e-6, Iz=1e-6, J=2e-6, name="B3")
B3_MATERIAL = fm.Material(E=1.4e10, density=1200.0, name="B3")


def spin_angle(t):
    T, w = B3_T, B3_OMEGA
    if t <= T:
        return w / T * (t * t / 2 + (T / (2 * np.pi)) ** 2 * (np.cos(2 * np.pi * t / T) - 1))
    return w * (t - T / 2)


def spin_rate(t):
    T, w = B3_T, B3_OMEGA
    if t <= T:
        return w / T * (t - T / (2 * np.pi) * np.sin(2 * np.pi * t / T))
    return w


def spin_acceleration(t):
    T, w = B3_T, B3_OMEGA
    if t <= T:
        return w / T * (1 - np.cos(2 * np.pi * t / T))
    return 0.0


def spinning_beam(n, driver, keep=("bend_z",)):
    model = fm.Model("spin-up")
    beam = fm.FlexibleBody("beam", B3_L, B3_SECTION, B3_MATERIAL, n, keep=keep, rotary_inertia=False)
    hub = fm.Revolute("hub", model.ground, beam, axis=(0, 0, 1))
    model.add(hub, driver(hub))
    return model, beam, hub


def test_spin_profile_derivatives_are_consistent():
    t = np.linspace(0.01, 19.99, 200)
    h = 1e-5
    th = np.array([spin_angle(s) for s in t])
    num_rate = (np.array([spin_angle(s + h) for s in t]) - np.array([spin_angle(s - h) for s in t])) / (2 * h)
    num_acc = (np.array([spin_rate(s + h) for s in t]) - np.array([spin_rate(s - h) for s in t])) / (2 * h)
    assert np.allclose(num_rate, [spin_rate(s) for s in t], atol=1e-8)
    assert np.allclose(num_acc, [spin_acceleration(s) for s in t], atol=1e-6)
    assert spin_angle(B3_T) == pytest.approx(B3_OMEGA * B3_T / 2) and th[0] > 0


@pytest.fixture(scope="module")
def spinup():
    """B3 spun up over T = 15 s to 6 rad/s, N = 4, simulated to t = 20 s."""
    model, beam, hub = spinning_beam(
        4, lambda hub: fm.Driver("spin", hub, spin_angle, spin_rate, spin_acceleration))
    system = model.build()
    res = fm.simulate(system, 20.0, n_out=401, rtol=1e-6)
    tip = res.shape("beam")[:, -1]
    a = res.coordinate("hub")
    # tip deflection transverse to the beam, in the frame rotating with the hub
    defl = -np.sin(a) * tip[:, 0] + np.cos(a) * tip[:, 1]
    return system, beam, hub, res, defl


def test_spinup_tip_deflection_bounded(spinup):
    system, beam, hub, res, defl = spinup
    assert res.status == "finished"
    # the hub follows the prescribed motion
    assert np.allclose(res.coordinate("hub"), [spin_angle(t) for t in res.t], rtol=0, atol=1e-8)
    # measured (N = 4): peak -0.612 m at t = 6.9 s, |residual| < 0.006 m after T
    peak = np.max(np.abs(defl))
    after = np.max(np.abs(defl[res.t >= B3_T]))
    # quasi-static bound: the Euler load rho A x theta'' (max 2 Omega / T) on a
    # cantilever without stiffening gives 11 q0 L^4 / (120 E I) at the tip
    q0 = 1.2 * 2 * B3_OMEGA / B3_T * B3_L
    bound = 11 * q0 * B3_L**4 / (120 * 1.4e4)
    assert 0.5 * bound < peak < 1.05 * bound, f"peak {peak:.4f} m, unstiffened quasi-static {bound:.4f} m"
    assert np.all(defl[(res.t > 0) & (res.t < 12.0)] < 0), "the beam lags behind the accelerating hub"
    # after the spin-up the beam keeps only a small residual vibration: bounded
    # (without centrifugal stiffening, at 6 rad/s it would diverge)
    assert after < 0.02, f"residual vibration {after:.4f} m after t = T"
    # the centre line keeps its length (rigid segments, no axial coordinate)
    shape = res.shape("beam")
    seg = np.linalg.norm(np.diff(shape, axis=1), axis=2)
    assert np.allclose(seg, beam.segment_length, rtol=1e-12)


def test_spinup_follows_the_quasi_static_solution(spinup):
    """The slow spin-up (T >> first period 1.7 s) is nearly quasi-static.

    The quasi-static deflection at time t solves K z = F of the system
    linearised about the undeformed beam at hub angle theta(t) and rate
    theta'(t), with the driver acceleration theta''(t) (Euler load) and the
    centrifugal stiffening included.
    """
    system, beam, hub, res, defl = spinup
    hs = system.coordinate_slice(hub)
    cols = elastic_columns(system, beam)
    x_j = np.arange(beam.n_joints) * beam.segment_length
    for tq in (5.0, 7.5, 10.0):
        x0 = np.zeros(system.n_coords)
        xd0 = np.zeros(system.n_coords)
        x0[hs], xd0[hs] = spin_angle(tq), spin_rate(tq)
        lin = fm.linearize(system, x0, xd0, tq)
        x = x0 + lin.T @ np.linalg.solve(lin.K, lin.F)
        qs = float(np.sum(x[cols] * (B3_L - x_j)))  # transverse tip deflection (bend_z: +y)
        sim = defl[np.argmin(np.abs(res.t - tq))]
        assert sim == pytest.approx(qs, rel=0.1), f"t = {tq}: simulated {sim:.4f} m, quasi-static {qs:.4f} m"


@pytest.mark.parametrize("keep, k_southwell", [(("bend_z",), 1.193 - 1.0), (("bend_y",), 1.193)],
                         ids=["in-plane", "out-of-plane"])
def test_spinning_beam_frequency_rises_like_southwell(keep, k_southwell):
    """First bending frequency about steady spin at 0, 2, 4, 6 rad/s.

    In the plane of rotation (bend_z, spin about z) the centrifugal stiffening
    is partly cancelled by spin softening, so the Southwell coefficient is
    k - 1 = 0.193; out of the plane (bend_y) it is k = 1.193.
    """
    rates = np.array([0.0, 2.0, 4.0, 6.0])
    f = []
    for w in rates:
        model, beam, hub = spinning_beam(8, lambda hub: fm.Driver.constant_speed("spin", hub, w), keep=keep)
        system = model.build()
        xd0 = np.zeros(system.n_coords)
        xd0[system.coordinate_slice(hub)] = w
        f.append(fm.modes(system, 1, xd0=xd0, t=0.0)[0][0])
    f = np.array(f)
    f0_eb = BETA_L[0] ** 2 / (2 * np.pi) * np.sqrt(1.4e4 / (1.2 * B3_L**4))
    assert f[0] == pytest.approx(f0_eb, rel=1e-2)
    assert np.all(np.diff(f) > 0), f"frequencies {f} must rise with the spin rate"
    southwell = np.sqrt(f[0] ** 2 + k_southwell * rates**2 / (2 * np.pi) ** 2)
    assert np.allclose(f, southwell, rtol=0.1), f"{f} Hz vs Southwell {southwell} Hz"


# ----------------------------------------------------------------------------- 6. flexible coupler in the four-bar

# coupler: 0.3 m, 0.3 kg (rho A = 1 kg/m), E I ~ 2.6 N m^2: first elastic mode ~39 Hz
COUPLER_D = np.sqrt(4.0 / (np.pi * 7850.0))
COUPLER_SECTION = fm.Section.circular(COUPLER_D)
COUPLER_MATERIAL = fm.Material(2e9, 7850.0, 0.3, name="stiff polymer-steel")


def flexible_fourbar(damping=0.0, gravity=True):
    """conftest.fourbar with the coupler a FlexibleBody (pinned root, N = 4), loop closed at its tip."""
    model = fm.Model("flexible fourbar")
    crank = fm.RigidBody.slender_bar("crank", 0.1, 0.1)
    coupler = fm.FlexibleBody("coupler", 0.3, COUPLER_SECTION, COUPLER_MATERIAL, 4, keep=("bend_z",),
                              clamped=False, damping=damping)
    rocker = fm.RigidBody.slender_bar("rocker", 0.25, 0.25)
    model.add(
        fm.Revolute("A", model.ground, crank, axis=(0, 0, 1)),
        fm.Revolute("B", crank, coupler, parent_point=(0.1, 0, 0), axis=(0, 0, 1)),
        fm.Revolute("D", model.ground, rocker, parent_point=(0.3, 0, 0), axis=(0, 0, 1)),
        fm.PlanarRevolute("C", coupler, rocker, parent_point=(0.3, 0, 0), child_point=(0.25, 0, 0),
                          axis=(0, 0, 1)),
    )
    if gravity:
        model.add(fm.Gravity((0.0, -9.81, 0.0)))
    return model, coupler


def _check_fourbar_conservative(res, coupler, system):
    assert res.status == "finished"
    assert np.max(res.residual) < 1e-9, f"loop residual {np.max(res.residual):.2e}"
    drift = np.max(np.abs(res.energy - res.energy[0])) / np.max(res.kinetic)
    assert drift < 1e-6, f"energy drift {drift:.2e} of the largest kinetic energy"
    assert np.ptp(res.coordinate("A")) > 1.0, "the mechanism swings"
    eta = res.x[:, elastic_columns(system, coupler)]
    assert 1e-5 < np.max(np.abs(eta)) < 0.02, "the coupler bends, a little"


def test_flexible_fourbar_conserves_energy():
    model, coupler = flexible_fourbar()
    system = model.build()
    assert system.coordinate_names[3:] == [f"coupler.j{i}.bend_z" for i in (1, 2, 3)]
    assert system.n_constraints == 2
    # the explicit DOP853 is the cheap integrator at this stiffness (~39 Hz)
    res = fm.simulate(system, 0.5, positions=fourbar_initial(), rtol=1e-9, method="DOP853")
    _check_fourbar_conservative(res, coupler, system)


@pytest.mark.slow
def test_flexible_fourbar_conserves_energy_radau():
    model, coupler = flexible_fourbar()
    system = model.build()
    res = fm.simulate(system, 0.5, positions=fourbar_initial(), rtol=1e-9, method="Radau")
    _check_fourbar_conservative(res, coupler, system)


def test_flexible_fourbar_damping_dissipates_the_elastic_energy():
    """No gravity; released with a bent coupler: the elastic energy decays."""
    model, coupler = flexible_fourbar(damping=1.6e-3, gravity=False)
    system = model.build()
    names = [f"coupler.j{i}.bend_z" for i in (1, 2, 3)]
    positions = dict(fourbar_initial(), **{n: 0.01 for n in names})
    res = fm.simulate(system, 0.2, positions=positions, fixed=names, rtol=1e-6)
    assert res.status == "finished"
    assert np.max(res.residual) < 1e-9
    cols = elastic_columns(system, coupler)
    assert np.allclose(res.x[0, cols], 0.01)
    # without gravity the potential energy is the elastic energy eta K eta / 2
    elastic = 0.5 * np.sum(coupler.joint_stiffness().ravel() * res.x[:, cols] ** 2, axis=1)
    assert np.allclose(res.potential, elastic, rtol=1e-12, atol=0)
    e0 = elastic[0]
    assert res.kinetic[0] == 0.0 and res.energy[0] == pytest.approx(e0)
    assert np.all(np.diff(res.energy) <= 1e-9 * e0), "the total energy never grows"
    assert np.max(elastic[res.t >= 0.15]) < 1e-3 * e0
    assert res.energy[-1] < 1e-3 * e0


def test_damping_matrix_is_beta_times_stiffness():
    beta = 2e-4
    model, beam = cantilever(8, gravity=False, damping=beta)
    lin = fm.linearize(model.build())
    assert np.allclose(lin.K, np.diag(beam.joint_stiffness().ravel()), rtol=1e-6, atol=1e-9 * np.max(lin.K))
    assert np.allclose(lin.C, beta * lin.K, rtol=1e-6, atol=1e-9 * beta * np.max(lin.K))


# ----------------------------------------------------------------------------- 7. attachments

def tip_force_deflection(n, where, p=1.0):
    """Linear-statics tip deflection (m, downwards) of the clamped B1 beam under a force P along -z.

    where: "mass" (a tip mass welded at (L, 0, 0) carries the force) or a
    body-frame x (m) for a PointForce on the beam.
    """
    model, beam = cantilever(n, gravity=False)
    force = (0.0, 0.0, -p)
    if where == "mass":
        tip = fm.RigidBody("tipmass", 0.5, (1e-4, 1e-4, 1e-4))
        model.add(fm.Fixed("weld", beam, tip, parent_point=(beam.length, 0, 0)),
                  fm.PointForce("load", tip, force))
    else:
        model.add(fm.PointForce("load", beam, force, point=(where, 0, 0)))
    system = model.build()
    x = fm.linear_statics(system)
    return -linear_tip_z(beam, x[elastic_columns(system, beam)]), system, beam, x


@pytest.mark.parametrize("where", ["mass", B1_L], ids=["tip mass", "point force"])
def test_tip_force_deflection(where):
    ei = B1_MATERIAL.E * B1_SECTION.Iy
    w, system, beam, x = tip_force_deflection(32, where)
    ref = B1_L**3 / (3 * ei)
    assert w == pytest.approx(ref, rel=0.5e-2), f"{w:.6g} vs {ref:.6g}"
    if where == "mass":
        # the welded mass rides on the last segment's end
        kin = system.kinematics(0.0, x, np.zeros_like(x))
        k = system.index(system.model["tipmass"])
        assert np.allclose(kin.origin[k], tip_point(system, beam, x), atol=1e-15)


@pytest.mark.parametrize("a", [0.5, 0.3, 0.75])
def test_point_force_inside_the_beam(a):
    """A force at x = a (a segment end for 0.5 and 0.75, mid-segment for 0.3)."""
    ei = B1_MATERIAL.E * B1_SECTION.Iy
    w, *_ = tip_force_deflection(32, a)
    ref = a**2 * (3 * B1_L - a) / (6 * ei)
    assert w == pytest.approx(ref, rel=0.5e-2), f"{w:.6g} vs {ref:.6g}"


def test_tip_mass_lands_on_the_last_segment():
    model, beam = cantilever(8, gravity=False)
    tip = fm.RigidBody("tipmass", 0.5, (1e-4, 1e-4, 1e-4))
    weld = fm.Fixed("weld", beam, tip, parent_point=(beam.length, 0, 0))
    model.add(weld)
    system = model.build()
    j = system.topology.joint_map[weld]
    segs = system.topology.flexible[beam][1]
    assert j.parent is segs[-1]
    assert np.allclose(j.parent_point, (beam.segment_length, 0, 0))
    for point, seg, local in [((0.0, 0, 0), 0, 0.0), ((0.2, 0, 0), 1, 0.075), ((0.125, 0, 0), 1, 0.0),
                              ((0.999, 0, 0), 7, 0.124), ((1.0, 0, 0), 7, 0.125)]:
        k, loc = system.topology.locate(beam, point)
        assert k == system.topology.index[segs[seg]]
        assert loc[0] == pytest.approx(local)


def test_flexible_body_attached_off_its_root_is_rejected():
    model = fm.Model("bad")
    beam = fm.FlexibleBody("beam", 1.0, B1_SECTION, B1_MATERIAL, 4, keep=("bend_y",))
    model.add(fm.Fixed("clamp", model.ground, beam, child_point=(0.5, 0, 0)))
    with pytest.raises(fm.ModelError, match=r"joint 'clamp': flexible body 'beam' must be attached .* root"):
        model.build()


@pytest.mark.parametrize("kw, message", [
    ({"keep": ("bend_x",)}, r"unknown elastic coordinate.*bend_x"),
    ({"keep": ()}, r"keep at least one elastic coordinate"),
    ({"keep": ("bend_y", "bend_y")}, r"keep lists a coordinate twice"),
    ({"n_segments": 0}, r"n_segments must be an integer >= 1, got 0"),
    ({"n_segments": 2.5}, r"n_segments must be an integer >= 1"),
    ({"section": "rect"}, r"section must be a Section, got str"),
    ({"material": B1_SECTION}, r"material must be a Material, got Section"),
    ({"damping": -1.0}, r"damping must be finite and >= 0"),
    ({"length": 0.0}, r"length must be > 0"),
])
def test_bad_flexible_body_input_names_the_body(kw, message):
    args = dict(length=1.0, section=B1_SECTION, material=B1_MATERIAL, n_segments=4, keep=("bend_y",))
    args.update(kw)
    with pytest.raises(fm.ModelError, match=r"FlexibleBody 'wing': " + message):
        fm.FlexibleBody("wing", **args)


# ----------------------------------------------------------------------------- 8. Result.shape

def test_result_shape_runs_from_clamp_to_tip():
    """A clamped beam with a tip mass, clamp off the origin and turned; short free vibration."""
    n = 6
    material = fm.Material(7e9, 2700.0, 0.33)  # softer than aluminium: cheap to integrate
    model = fm.Model("shape")
    beam = fm.FlexibleBody("beam", 1.0, B1_SECTION, material, n, keep=("bend_y", "bend_z"))
    tip = fm.RigidBody("tipmass", 0.05, (1e-5, 1e-5, 1e-5))
    clamp_point = np.array([0.1, 0.2, 0.3])
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # beam along +y
    model.add(fm.Fixed("clamp", model.ground, beam, parent_point=clamp_point, parent_frame=turn,
                       child_frame=np.eye(3)),
              fm.Fixed("weld", beam, tip, parent_point=(1.0, 0, 0)),
              fm.Gravity((0.0, 0.0, -G_ACC)))
    res = fm.simulate(model, 0.3, n_out=31, rtol=1e-6)
    shape = res.shape("beam")
    assert shape.shape == (31, n + 1, 3)
    assert np.allclose(shape[:, 0], clamp_point, atol=1e-14)
    assert np.allclose(shape[0], clamp_point + np.outer(np.linspace(0, 1, n + 1), [0, 1, 0]), atol=1e-14)
    assert np.allclose(shape[:, -1], res.origins[:, res.body_names.index("tipmass")], atol=1e-12)
    assert np.allclose(np.linalg.norm(np.diff(shape, axis=1), axis=2), 1.0 / n, rtol=1e-12)
    assert np.min(shape[:, -1, 2]) < clamp_point[2] - 1e-3, "the tip sags under gravity"
    with pytest.raises(fm.FlexmbError, match="no flexible body 'tipmass'"):
        res.shape("tipmass")


def test_result_shape_of_the_spinning_beam(spinup):
    system, beam, hub, res, defl = spinup
    shape = res.shape("beam")
    assert shape.shape == (len(res.t), beam.n_segments + 1, 3)
    assert np.allclose(shape[:, 0], 0.0, atol=1e-14)
    a = res.coordinate("hub")
    along = np.cos(a) * shape[:, -1, 0] + np.sin(a) * shape[:, -1, 1]
    assert np.all(along > 0.97 * B3_L) and np.all(along <= B3_L + 1e-12)


# ----------------------------------------------------------------------------- coordinate names of segment joints

def test_segment_joint_names_select_their_coordinates():
    model, beam = cantilever(4, gravity=False)
    res = fm.simulate(model, 1e-3, positions={"beam.j1": 1e-3}, n_out=2, rtol=1e-6)
    assert res.x[0, 1] == 1e-3 and np.all(res.x[0, [0, 2, 3]] == 0.0)
    assert np.array_equal(res.coordinate("beam.j1"), res.x[:, 1])
