"""The friction plugin (``plugins/flexmb_friction``): laws, closed forms, flexible tips, validation.

References used below (a block of mass m pressed on the plane by its weight,
N = m g, launched at v0 along x and left to the friction alone):

* Coulomb, ``dv/dt = -mu g``: stops at ``t_s = v0 / (mu g)`` after
  ``d = v0^2 / (2 mu g)``.
* velocity weakening, ``dv/dt = -g (mu_s - s v)`` while ``mu_s > s v``;
  with ``a = mu_s / s``: ``v(t) = a + (v0 - a) exp(g s t)``, so
  ``t_s = ln(a / (a - v0)) / (g s)`` and ``d = a t_s - v0 / (g s)``.
* viscous, ``m dv/dt = -c v``: ``x(t) = (m v0 / c) (1 - exp(-c t / m))``,
  ``x(inf) = m v0 / c``.

The regularised laws replace the unit vector ``v / |v|`` by
``v / sqrt(v^2 + e^2)`` (e the smoothing speed). For Coulomb the regularised
equation ``dv/dt = -mu g v / sqrt(v^2 + e^2)`` integrates in closed form:
with ``G(u) = sqrt(u^2 + e^2) - e ln((e + sqrt(u^2 + e^2)) / u)`` the speed
falls from v0 to u in ``(G(v0) - G(u)) / (mu g)``, and the block creeps to
``[v0 sqrt(v0^2 + e^2) + e^2 ln((v0 + sqrt(v0^2 + e^2)) / e)] / (2 mu g)``.
Hence, with ``tau = e / (mu g)``:

* the speed reaches e at ``t_s - 0.533 tau`` (``G(e) = e (sqrt 2 - asinh 1)``):
  an O(e) shift of the stopping time;
* at ``t_s`` the speed is ``0.662 e`` (root of ``G(u) = 0``): the speed
  history differs from the ideal one by at most O(e);
* the distance is off by ``e^2 (1/2 + ln(2 v0 / e)) / (2 mu g)``: O(e^2 ln e).

Near rest the velocity-weakening law is Coulomb's with ``mu = mu_s``, so the
same O(e) bounds hold for it.
"""

from __future__ import annotations

import numpy as np
import pytest

import flexmb as fm

try:
    import flexmb_friction  # noqa: F401  (installed from plugins/ by `pip install -e .`)
except ImportError:  # pragma: no cover - an install made before plugins/flexmb_friction existed
    flexmb_friction = None

G_ACC = 9.81


@pytest.fixture(scope="module")
def fr(request):
    """The ``flexmb_friction`` module."""
    if flexmb_friction is None:
        mp = pytest.MonkeyPatch()
        mp.syspath_prepend(str(request.config.rootpath / "plugins"))
        request.addfinalizer(mp.undo)
        import flexmb_friction as module

        return module
    return flexmb_friction


def _report(name, **values):
    """Print measured errors (visible with ``pytest -s`` / in failure output)."""
    print(f"[{name}] " + ", ".join(f"{k} = {v:.4g}" for k, v in values.items()))


# ----------------------------------------------------------------------------- helpers

def random_unit(rng):
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def free_puck(fr, rng, n_elements=4):
    """A rigid body on a Free joint with velocity-weakening friction at several points and planes."""
    model = fm.Model("puck")
    body = fm.RigidBody("puck", mass=1.5, inertia=(0.1, 0.2, 0.25), com=(0.05, -0.02, 0.01))
    model.add(fm.Free("float", model.ground, body))
    elements = [
        fr.VelocityWeakeningFriction(f"f{i}", body, point=rng.normal(scale=0.3, size=3),
                                     normal=rng.normal(size=3), normal_load=rng.uniform(1.0, 20.0),
                                     mu_static=0.4, slope=0.2, mu_min=0.0 if i % 2 == 0 else 0.05,
                                     smoothing_speed=10 ** rng.uniform(-4, -2))
        for i in range(n_elements)
    ]
    model.add(*elements)
    return model, body, elements


def point_velocity_fd(system, t, x, xd, row, local, h=1e-6):
    """Velocity of a body point by central differences of its position along xd."""
    p = [system.kinematics(t, x + s * h * xd, xd).point_position(row, local) for s in (1.0, -1.0)]
    return (p[0] - p[1]) / (2 * h)


def sliding_block(fr, cls, mass=2.0, **law):
    """A block on a Prismatic joint along x, sliding on the plane z = 0."""
    model = fm.Model("block")
    block = fm.RigidBody("block", mass=mass, inertia=(0.01, 0.01, 0.01))
    model.add(fm.Prismatic("slide", model.ground, block, axis=(1.0, 0.0, 0.0)),
              cls("friction", block, point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), **law))
    return model


def crossing_time(t, v, level):
    """First time v falls to ``level``, interpolated linearly in log v (exponential decay near rest)."""
    i = int(np.argmax(v <= level))
    assert i > 0 and v[i] <= level < v[i - 1]
    return float(np.interp(np.log(level), [np.log(v[i]), np.log(v[i - 1])], [t[i], t[i - 1]]))


def sample_times(t_end, t_s, tau):
    """Output times: a coarse grid plus half-tau spacing around the expected stop (sampling only)."""
    return np.unique(np.concatenate([np.linspace(0.0, t_end, 301), t_s + tau * np.linspace(-20.0, 20.0, 81)]))


def G_reg(u, e):
    """``G(u)`` of the module docstring (time integral of the regularised Coulomb law)."""
    r = np.sqrt(u * u + e * e)
    return r - e * np.log((e + r) / u)


# ----------------------------------------------------------------------------- 1. the law at random states

def test_law_at_random_states_of_a_free_body(fr):
    rng = np.random.default_rng(7)
    model, body, elements = free_puck(fr, rng)
    system = model.build()
    n = system.n_coords
    a_max = 0.4 / 0.2  # speed where mu_s - slope v reaches 0
    n_above = n_slow = 0
    for _ in range(60):
        x = np.concatenate([rng.normal(size=3), rng.uniform(-1.0, 1.0, 3)])
        xd = rng.normal(size=n) * 10 ** rng.uniform(-4.5, 1.0)
        kin = system.kinematics(0.3, x, xd)
        for e in elements:
            row, local = kin.locate(e.body, e.point)
            v = point_velocity_fd(system, 0.3, x, xd, row, local)
            v_s_ref = v - (v @ e.normal) * e.normal
            v_s = e.sliding_velocity(kin)
            np.testing.assert_allclose(v_s, v_s_ref, rtol=1e-6, atol=1e-9 * (1 + np.linalg.norm(v)))
            F = e.force(kin)
            speed = np.linalg.norm(v_s)
            # in the contact plane
            assert abs(F @ e.normal) <= 1e-12 * (1.0 + np.linalg.norm(F))
            # magnitude: N max(mu_s - s |v_s|, mu_min) |v_s| / sqrt(|v_s|^2 + e^2), never negative
            law = e.normal_load * max(e.mu_static - e.slope * speed, e.mu_min)
            expected = law * speed / np.sqrt(speed**2 + e.smoothing_speed**2)
            assert np.linalg.norm(F) == pytest.approx(expected, rel=1e-12, abs=1e-14)
            # opposes the sliding velocity: antiparallel, F . v_s < 0 whenever the law is non-zero
            if expected > 0:
                assert F @ v_s < 0
                assert F @ v_s == pytest.approx(-np.linalg.norm(F) * speed, rel=1e-12)
            # power F . v <= 0, and equal to F . v_s
            P = e.power(kin)
            assert P <= 0.0
            v_exact = kin.point_velocity(row, kin.point_position(row, local))
            assert P == pytest.approx(F @ v_exact, rel=1e-10, abs=1e-15)
            if speed > a_max:
                n_above += 1
                assert np.linalg.norm(F) == pytest.approx(e.mu_min * e.normal_load * speed
                                                          / np.sqrt(speed**2 + e.smoothing_speed**2), rel=1e-12)
            if speed < e.smoothing_speed:
                n_slow += 1
    assert n_above > 20 and n_slow > 5, "the random speeds must cover both ends of the law"


def test_zero_speed_gives_zero_force_and_weakening_stops_at_zero(fr):
    model = fm.Model("m")
    body = fm.RigidBody("b", mass=1.0, inertia=(1.0, 1.0, 1.0))
    e = fr.VelocityWeakeningFriction("w", body, (0, 0, 0), (0, 0, 1), normal_load=10.0, mu_static=0.4,
                                     slope=0.2, smoothing_speed=1e-3)
    model.add(fm.Free("j", model.ground, body), e)
    system = model.build()
    x = np.zeros(6)
    assert np.all(e.force(system.kinematics(0.0, x, np.zeros(6))) == 0.0)
    # sliding only normal to the plane gives no friction
    assert np.all(e.force(system.kinematics(0.0, x, np.array([0, 0, 3.0, 0, 0, 0]))) == 0.0)
    for speed in (2.0, 2.5, 10.0, 1e6):  # at and above mu_s / slope the magnitude is 0, not negative
        F = e.force(system.kinematics(0.0, x, np.array([speed, 0, 0, 0, 0, 0])))
        assert np.all(F == 0.0)
    F = e.force(system.kinematics(0.0, x, np.array([1.0, 0, 0, 0, 0, 0])))
    assert F[0] == pytest.approx(-10.0 * 0.2 / np.sqrt(1 + 1e-6), rel=1e-14)


def test_apply_all_matches_one_at_a_time_and_the_kane_power(fr):
    """The vectorised class call equals the per-element calls, rigid and flexible; powers agree with F.xd."""
    rng = np.random.default_rng(3)
    model, body, elements = free_puck(fr, rng, n_elements=3)
    # pinned at its root (clamped=False): a clamped root on a hinge would make the mass matrix singular
    beam = fm.FlexibleBody("beam", 0.4, fm.Section.rectangular(0.01, 0.002), fm.Material.steel(), n_segments=4,
                           keep=("bend_y", "bend_z"), clamped=False)
    model.add(fm.Revolute("hinge", body, beam, parent_point=(0.1, 0.0, 0.0), axis=(0.0, 0.0, 1.0)))
    elements.append(fr.VelocityWeakeningFriction("tip", beam, (0.4, 0.0, 0.0), (0.0, 0.2, 1.0), normal_load=3.0,
                                                 mu_static=0.5, slope=0.1, smoothing_speed=1e-2))
    elements.append(fr.VelocityWeakeningFriction("mid", beam, (0.15, 0.0, 0.0), (1.0, 0.0, 0.0), normal_load=1.0,
                                                 mu_static=0.3, slope=0.3))
    model.add(*elements[-2:])
    system = model.build()
    x = rng.normal(scale=0.3, size=system.n_coords)
    xd = rng.normal(size=system.n_coords)
    kin = system.kinematics(0.0, x, xd)
    batch, single = fm.Loads(kin), fm.Loads(kin)
    fr.VelocityWeakeningFriction.apply_all(elements, kin, batch)
    for e in elements:
        e.apply(kin, single)
    np.testing.assert_allclose(batch.force, single.force, rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose(batch.torque, single.torque, rtol=1e-13, atol=1e-14)
    # the tip force lands on the last segment, at the tip
    tip = elements[-2]
    row, local = kin.locate(beam, tip.point)
    assert row == system.topology.index[system.topology.flexible[beam][1][-1]]
    np.testing.assert_allclose(local, (0.1, 0.0, 0.0), atol=1e-15)
    # power through Kane's equations (F_l = V_kl . f_k + W_kl . t_k, then F . xd) equals sum F . v
    group = [cls for cls, _ in system.forces.groups].index(fr.VelocityWeakeningFriction)
    kane = system.forces.group_powers(kin)[group]
    total = fr.VelocityWeakeningFriction.power_all(elements, kin)
    assert np.all(total <= 0.0)
    assert kane == pytest.approx(total.sum(), rel=1e-10)


# ----------------------------------------------------------------------------- 2. a block sliding to rest

def test_coulomb_block_stops_as_the_closed_form(fr):
    mu, v0, e = 0.3, 1.0, 1e-5
    model = sliding_block(fr, fr.CoulombFriction, normal_load=2.0 * G_ACC, mu=mu, smoothing_speed=e)
    t_s, d = v0 / (mu * G_ACC), v0**2 / (2 * mu * G_ACC)
    tau = e / (mu * G_ACC)
    # a small smoothing speed makes the law a stiff damper (time constant tau) near rest: Radau
    res = fm.simulate(model, 1.5 * t_s, speeds={"slide": v0}, t_eval=sample_times(1.5 * t_s, t_s, tau),
                      method="Radau", rtol=1e-9)
    t, x, v = res.t, res.x[:, 0], res.xd[:, 0]
    t_stop = crossing_time(t, v, e)
    v_err = np.max(np.abs(v - np.maximum(v0 - mu * G_ACC * t, 0.0)))
    _report("coulomb", stop_time_error_over_tau=(t_stop - t_s) / tau, distance_error=x[-1] - d,
            speed_error_over_e=v_err / e, n_rhs=res.n_rhs)
    # against the ideal law: O(e) in time and speed, O(e^2 ln e) in distance (+ rtol 1e-9 on x ~ 0.17 m)
    assert abs(t_stop - t_s) < tau
    assert v_err < e
    assert abs(x[-1] - d) < 1e-8
    # against the regularised closed form: the differences above are the smoothing's, not the integrator's
    t_reg = (G_reg(v0, e) - G_reg(e, e)) / (mu * G_ACC)  # = t_s - 0.533 tau
    assert t_stop == pytest.approx(t_reg, abs=0.05 * tau)
    assert v_err / e == pytest.approx(0.662, abs=0.02)
    creep = (v0 * np.hypot(v0, e) + e**2 * np.log((v0 + np.hypot(v0, e)) / e)) / (2 * mu * G_ACC)
    assert x[-1] == pytest.approx(creep, abs=2e-10)
    assert np.all(np.diff(x) >= -1e-12), "friction alone never reverses the block"


def test_velocity_weakening_block_stops_as_the_closed_form(fr):
    mu_s, s, v0, e = 0.4, 0.2, 1.0, 1e-5
    a = mu_s / s  # speed where the coefficient reaches 0; v0 < a, so the block decelerates from the start
    t_s = np.log(a / (a - v0)) / (G_ACC * s)
    d = a * t_s - v0 / (G_ACC * s)
    tau = e / (mu_s * G_ACC)
    model = sliding_block(fr, fr.VelocityWeakeningFriction, normal_load=2.0 * G_ACC, mu_static=mu_s, slope=s,
                          smoothing_speed=e)
    res = fm.simulate(model, 1.5 * t_s, speeds={"slide": v0}, t_eval=sample_times(1.5 * t_s, t_s, tau),
                      method="Radau", rtol=1e-9)
    t, x, v = res.t, res.x[:, 0], res.xd[:, 0]
    ideal_v = np.where(t < t_s, a + (v0 - a) * np.exp(G_ACC * s * t), 0.0)
    ideal_x = np.where(t < t_s, a * t - (a - v0) * np.expm1(G_ACC * s * t) / (G_ACC * s), d)
    t_stop = crossing_time(t, v, e)
    v_err = np.max(np.abs(v - ideal_v))
    _report("velocity weakening", t_s=t_s, d=d, stop_time_error_over_tau=(t_stop - t_s) / tau,
            distance_error=x[-1] - d, speed_error_over_e=v_err / e, n_rhs=res.n_rhs)
    # the weakening lengthens the slide compared with Coulomb at mu_s
    assert t_s > v0 / (mu_s * G_ACC) and d > v0**2 / (2 * mu_s * G_ACC)
    # O(e) in stop time and speed (near rest the law is Coulomb's at mu_s: -0.53 tau and 0.66 e expected)
    assert abs(t_stop - t_s) < tau
    assert (t_stop - t_s) / tau == pytest.approx(-0.533, abs=0.05)
    assert v_err < e
    # O(e^2 ln e) in distance, along the whole path
    assert np.max(np.abs(x - ideal_x)) < 1e-8
    assert abs(x[-1] - d) < 1e-8


def test_viscous_block_glides_m_v0_over_c(fr):
    m, c, v0 = 2.0, 3.0, 1.0
    model = sliding_block(fr, fr.ViscousFriction, mass=m, damping=c)
    t_end = 20 * m / c
    res = fm.simulate(model, t_end, speeds={"slide": v0}, method="DOP853", rtol=1e-10)
    x_ref = m * v0 / c * -np.expm1(-c * res.t / m)
    err = np.max(np.abs(res.x[:, 0] - x_ref))
    x_inf = res.x[-1, 0] + res.xd[-1, 0] * m / c  # the glide left after t_end is v m / c
    _report("viscous", x_inf_error=x_inf - m * v0 / c, path_error=err, n_rhs=res.n_rhs)
    assert err < 1e-8
    assert x_inf == pytest.approx(m * v0 / c, abs=1e-9)


# ----------------------------------------------------------------------------- 3. a flexible tip

def test_friction_at_a_flexible_tip_dissipates(fr):
    """A blade driven round at 1 rev/s rubs its tip on the plane z = 0; friction power <= 0 throughout.

    The point is given on the FlexibleBody and found on its last segment through ``state.locate``.
    """
    L = 0.2
    model = fm.Model("sweep")
    blade = fm.FlexibleBody.uniform_beam("blade", L, fm.Section.rectangular(0.004, 0.002), fm.Material.steel(),
                                         n_segments=3, keep=("bend_z",), damping_ratio=0.02)
    pin = fm.Revolute("root", model.ground, blade, axis=(0.0, 0.0, 1.0))
    tip = fr.VelocityWeakeningFriction("tip", blade, (L, 0.0, 0.0), (0.0, 0.0, 1.0), normal_load=2.0,
                                       mu_static=0.4, slope=0.1, smoothing_speed=1e-2)
    model.add(pin, tip, fm.Driver.constant_speed("motor", pin, 2 * np.pi))
    system = model.build()
    # blade frequencies near 7000 rad/s with weak damping: explicit (Radau's approximate Jacobian
    # leaves out the driven rotation's terms and needs more steps here)
    res = fm.simulate(system, 0.1, n_out=41, method="DOP853", rtol=1e-6, track_work=True)
    assert res.status == "finished"
    P, speed = [], []
    for t, x, xd in zip(res.t, res.x, res.xd):
        kin = system.kinematics(t, x, xd)
        P.append(tip.power(kin))
        speed.append(np.linalg.norm(tip.sliding_velocity(kin)))
        F = tip.force(kin)
        assert abs(F[2]) < 1e-12
    P, speed = np.array(P), np.array(speed)
    bend = np.abs(res.x[:, 1:]).max()
    _report("flexible tip", max_power=P.max(), min_power=P.min(), max_bend=bend, work=res.work["tip"][-1],
            n_rhs=res.n_rhs)
    assert np.all(P <= 0.0)
    assert np.all(P >= -tip.normal_load * tip.mu_static * speed - 1e-12)
    # friction works against every sliding tip (speeds stay below mu_s / slope = 4 m/s); the slope's
    # negative damping (N s = 0.2 N s/m) feeds the blade's vibration, so the tip speed swings between
    # nearly 0 and twice the sweep speed
    assert np.all(speed < tip.mu_static / tip.slope)
    assert np.all(P[speed > 0.0] < 0.0)
    assert bend > 1e-4, "the tip friction must bend the blade"
    # the work integrated by the simulator through Kane's F . xd never increases
    assert np.all(np.diff(res.work["tip"]) <= 1e-12)
    assert res.work["tip"][-1] < 0.0


# ----------------------------------------------------------------------------- 4. construction

def _valid(fr):
    body = fm.RigidBody("b", mass=1.0, inertia=(1.0, 1.0, 1.0))
    return {
        fr.VelocityWeakeningFriction: dict(name="tip", body=body, point=(0, 0, 0), normal=(0, 0, 1),
                                           normal_load=5.0, mu_static=0.4, slope=0.1),
        fr.CoulombFriction: dict(name="tip", body=body, point=(0, 0, 0), normal=(0, 0, 1), normal_load=5.0,
                                 mu=0.4),
        fr.ViscousFriction: dict(name="tip", body=body, point=(0, 0, 0), normal=(0, 0, 1), damping=2.0),
    }


@pytest.mark.parametrize("cls_name", ["VelocityWeakeningFriction", "CoulombFriction", "ViscousFriction"])
def test_valid_construction_and_repr(fr, cls_name):
    cls = getattr(fr, cls_name)
    e = cls(**_valid(fr)[cls])
    assert isinstance(e, fm.ForceElement)
    assert "'tip'" in repr(e) and cls_name in repr(e)
    assert e.potential(None) == 0.0
    with pytest.raises(AttributeError):
        e.normal_load = 1.0 if hasattr(e, "normal_load") else e.damping
    # the normal is normalised and read-only
    e2 = cls(**{**_valid(fr)[cls], "normal": (0.0, 3.0, 4.0)})
    np.testing.assert_allclose(e2.normal, (0.0, 0.6, 0.8), rtol=1e-15)
    assert not e2.normal.flags.writeable


def test_defaults(fr):
    e = fr.VelocityWeakeningFriction(**_valid(fr)[fr.VelocityWeakeningFriction])
    assert e.smoothing_speed == fr.DEFAULT_SMOOTHING_SPEED == 1e-3
    assert e.mu_min == 0.0
    e = fr.VelocityWeakeningFriction(**_valid(fr)[fr.VelocityWeakeningFriction], mu_min=0.4)  # mu_min = mu_s is fine
    assert e.mu_min == e.mu_static


@pytest.mark.parametrize("cls_name, change, message", [
    ("VelocityWeakeningFriction", {"normal": (0, 0, 0)}, "normal must be a nonzero vector"),
    ("VelocityWeakeningFriction", {"normal": (0, np.nan, 1)}, "normal must be finite"),
    ("VelocityWeakeningFriction", {"normal": (0, 1)}, "normal must have shape (3,)"),
    ("VelocityWeakeningFriction", {"normal_load": -1.0}, "normal_load must be > 0"),
    ("VelocityWeakeningFriction", {"normal_load": 0.0}, "normal_load must be > 0"),
    ("VelocityWeakeningFriction", {"normal_load": np.inf}, "normal_load must be a finite number"),
    ("VelocityWeakeningFriction", {"mu_static": np.nan}, "mu_static must be a finite number"),
    ("VelocityWeakeningFriction", {"mu_static": "high"}, "mu_static must be a finite number"),
    ("VelocityWeakeningFriction", {"mu_static": -0.1}, "mu_static must be >= 0"),
    ("VelocityWeakeningFriction", {"slope": -0.1}, "slope must be >= 0"),
    ("VelocityWeakeningFriction", {"mu_min": 0.5}, "mu_min must be <= mu_static"),
    ("VelocityWeakeningFriction", {"mu_min": -0.5}, "mu_min must be >= 0"),
    ("VelocityWeakeningFriction", {"smoothing_speed": 0.0}, "smoothing_speed must be > 0"),
    ("VelocityWeakeningFriction", {"body": 3}, "body must be a Body, got int (or give the body's name)"),
    ("VelocityWeakeningFriction", {"point": (0, 0, np.inf)}, "point must be finite"),
    ("VelocityWeakeningFriction", {"point": "tip"}, "point must be numbers"),
    ("CoulombFriction", {"mu": -0.3}, "mu must be >= 0"),
    ("CoulombFriction", {"normal_load": -9.81}, "normal_load must be > 0"),
    ("CoulombFriction", {"smoothing_speed": -1e-3}, "smoothing_speed must be > 0"),
    ("CoulombFriction", {"normal": [0, 0, 0]}, "normal must be a nonzero vector"),
    ("ViscousFriction", {"damping": 0.0}, "damping must be > 0"),
    ("ViscousFriction", {"damping": np.nan}, "damping must be a finite number"),
    ("ViscousFriction", {"body": None}, "body must be a Body, got NoneType"),
])
def test_invalid_construction_names_the_element(fr, cls_name, change, message):
    cls = getattr(fr, cls_name)
    with pytest.raises(fm.ModelError) as info:
        cls(**{**_valid(fr)[cls], **change})
    assert f"{cls_name} 'tip'" in str(info.value)
    assert message in str(info.value)


def test_body_outside_the_model_is_reported(fr):
    model = fm.Model("m")
    body = fm.RigidBody("b", mass=1.0, inertia=(1.0, 1.0, 1.0))
    stranger = fm.RigidBody("stranger", mass=1.0, inertia=(1.0, 1.0, 1.0))
    model.add(fm.Prismatic("slide", model.ground, body, axis=(1, 0, 0)),
              fr.CoulombFriction("rub", stranger, (0, 0, 0), (0, 0, 1), normal_load=1.0, mu=0.2))
    with pytest.raises(fm.ModelError, match="'rub'.*'stranger' is not in the model"):
        model.validate()


def test_body_given_by_name_is_the_body(fr):
    """A friction element may name its body (flexmb.reference): the same loads as with the object."""

    def sliding_block(by_name):
        model = fm.Model("m")
        block = fm.RigidBody("block", mass=2.0, inertia=(1.0, 1.0, 1.0))
        rub = fr.CoulombFriction("rub", "block" if by_name else block, (0, 0, 0), (0, 0, 1), normal_load=9.81,
                                 mu=0.3)
        model.add(fm.Prismatic("slide", model.ground, block, axis=(1, 0, 0)), rub)
        return fm.simulate(model, 0.2, speeds={"slide": 1.0}, n_out=5, method="DOP853", rtol=1e-9)

    by_name, by_object = sliding_block(True), sliding_block(False)
    assert np.abs(by_name.xd[-1] - by_object.xd[-1]).max() == 0.0
    assert by_object.xd[-1, 0] < 1.0 - 0.2 * 0.3 * 9.81 / 2.0 * 0.9  # it is braked
