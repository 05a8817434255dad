"""Nonlinear statics that converge without help (issue #22, section 1).

References, all from outside the code:

* the elastica (a clamped beam under a dead tip force P, alpha = P L^2 / (E I)):
  ``theta'' + alpha cos(theta) = 0`` with s in units of L, theta(0) = 0,
  theta'(1) = 0. With ``m = (1 + sin theta_0) / 2`` and ``sin phi_1 =
  1 / sqrt(2 m)`` (theta_0 the tip angle),

      sqrt(alpha) = K(m) - F(phi_1, m),
      x_tip / L = sqrt(2 sin(theta_0) / alpha),
      v_tip / L = 1 - 2 (E(m) - E(phi_1, m)) / sqrt(alpha)

  (Bisshopp and Drucker 1945). Checked below against scipy's solve_bvp and
  against the published table of the elliptic-integral solution
  (Mattiasson 1981, five digits): alpha = 1: v/L = 0.30172, u/L = 1 - x/L =
  0.05643; 2: 0.49346, 0.16064; 5: 0.71379, 0.38763; 10: 0.81061, 0.55500.
* the von Mises truss (two bars of axial stiffness k pinned to the ground at
  x = 0 and 2a and to each other at the apex, rise h, bar length
  ``L0 = sqrt(a^2 + h^2)``, a dead load P down at the apex): with the apex
  lowered by w, a bar is ``L(w) = sqrt(a^2 + (h - w)^2)`` long and carries
  the compression ``N = k (L0 - L)``; the vertical balance of the apex,
  ``P = 2 N (h - w) / L``, gives

      P(w) = 2 k (L0 - L(w)) (h - w) / L(w) = 2 k L0 (1 / L(w) - 1 / L0) (h - w),

  (with k = EA / L0: ``2 EA (1/L - 1/L0) (h - w)``), odd about the flat
  position w = h: a maximum P_lim (the limit load) at w_lim < h, a minimum
  -P_lim at 2h - w_lim, zero again at the inverted position w = 2h, and
  rising beyond it. The finite-segment bar pinned at both ends
  (``clamped=False``) has N - 1 axial joint springs EA / l in series, its
  segments rigid: ``k = EA / ((N - 1) l)``, read from the body's joint
  stiffness.
* Euler's clamped-free column buckles at ``P_E = pi^2 E I / (4 L^2)``.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_bvp
from scipy.optimize import brentq, minimize_scalar
from scipy.special import ellipe, ellipeinc, ellipk, ellipkinc

import flexmb as fm

SECTION = fm.Section.rectangular(0.02, 0.005)
STEEL = fm.Material.steel()
EI = STEEL.E * SECTION.Iy
ALPHAS = (1.0, 2.0, 5.0, 10.0, 20.0)


# ----------------------------------------------------------------------------- references

def elastica_tip(alpha):
    """Tip (x/L, v/L) and tip angle of the elastica, from the elliptic integrals."""
    def mismatch(theta0):
        m = (1 + np.sin(theta0)) / 2
        return ellipk(m) - ellipkinc(np.arcsin(1 / np.sqrt(2 * m)), m) - np.sqrt(alpha)

    theta0 = brentq(mismatch, 1e-12, np.pi / 2 - 1e-15, xtol=1e-15)
    m = (1 + np.sin(theta0)) / 2
    phi1 = np.arcsin(1 / np.sqrt(2 * m))
    return np.sqrt(2 * np.sin(theta0) / alpha), 1 - 2 / np.sqrt(alpha) * (ellipe(m) - ellipeinc(phi1, m)), theta0


def elastica_bvp(alpha):
    """The same from solve_bvp on theta'' = -alpha cos(theta), x' = cos(theta), v' = sin(theta)."""
    s = np.linspace(0.0, 1.0, 101)
    guess = np.zeros((4, s.size))
    guess[2] = s
    sol = solve_bvp(lambda s, u: np.vstack([u[1], -alpha * np.cos(u[0]), np.cos(u[0]), np.sin(u[0])]),
                    lambda a, b: np.array([a[0], b[1], a[2], a[3]]), s, guess, tol=1e-10, max_nodes=100000)
    assert sol.status == 0
    return sol.y[2, -1], sol.y[3, -1], sol.y[0, -1]


def truss_load(w, k, a, h):
    """P(w) of the von Mises truss with bars of axial stiffness k."""
    L0, L = np.hypot(a, h), np.hypot(a, h - w)
    return 2 * k * (L0 - L) * (h - w) / L


# ----------------------------------------------------------------------------- models

def elastica(n, alpha):
    """A 1 m steel strip clamped at the origin along x, a dead tip force alpha E I / L^2 along -z."""
    model = fm.Model("elastica")
    beam = fm.FlexibleBody("beam", 1.0, SECTION, STEEL, n_segments=n, keep=("bend_y",))
    model.add(fm.Fixed("clamp", model.ground, beam),
              fm.PointForce("P", beam, (0.0, 0.0, -alpha * EI), point=(1.0, 0.0, 0.0)))
    return model.build()


def beam_tip(x):
    """Tip (x/L, v/L) of a clamped bend_y beam from its joint rotations (segments l = L/N)."""
    theta = np.cumsum(x)
    return np.array([np.sum(np.cos(theta)), np.sum(np.sin(theta))]) / len(x)


def _frames(direction):
    """A pin's joint frame in the ground (x along the bar, z along the ground y) and in the bar."""
    parent = np.column_stack([direction, np.cross((0.0, 1.0, 0.0), direction), (0.0, 1.0, 0.0)])
    child = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
    return parent, child


def von_mises_truss(p_ref, n=8, a=1.0, h=0.05, depth=0.06, complement="svd"):
    """Two flexible steel bars (axial and bending flexibility) pinned at the ground and at the apex."""
    section = fm.Section.rectangular(depth, depth)
    L0 = np.hypot(a, h)
    model = fm.Model("von Mises truss")
    left = fm.FlexibleBody("left", L0, section, STEEL, n_segments=n, keep=("axial", "bend_y"), clamped=False)
    right = fm.FlexibleBody("right", L0, section, STEEL, n_segments=n, keep=("axial", "bend_y"), clamped=False)
    p_left, child = _frames(np.array([a, 0.0, h]) / L0)
    p_right, _ = _frames(np.array([-a, 0.0, h]) / L0)
    model.add(fm.Revolute("pin_left", model.ground, left, parent_frame=p_left, child_frame=child),
              fm.Revolute("pin_right", model.ground, right, parent_point=(2 * a, 0, 0), parent_frame=p_right,
                          child_frame=child),
              fm.PlanarRevolute("apex", left, right, parent_point=(L0, 0, 0), child_point=(L0, 0, 0),
                                axis=(0, 1, 0)),
              fm.PointForce("P", left, (0.0, 0.0, -p_ref), point=(L0, 0.0, 0.0)))
    k = 1.0 / np.sum(1.0 / left.joint_stiffness()[:, 0])
    return model.build(complement=complement), left, k


def apex_drop(system, left, x, h):
    """w: how far the apex has moved down from its unloaded height h."""
    kin = system.kinematics(0.0, x, np.zeros_like(x))
    last = system.topology.index[system.topology.flexible[left][1][-1]]
    return h - (kin.origin[last] + kin.R[last][:, 0] * left.segment_length)[2]


@pytest.fixture(scope="module")
def truss():
    a, h = 1.0, 0.05
    _, _, k = von_mises_truss(1.0, a=a, h=h)
    best = minimize_scalar(lambda w: -truss_load(w, k, a, h), bounds=(0.0, h), method="bounded",
                           options={"xatol": 1e-12})
    p_lim, w_lim = -best.fun, best.x
    system, left, _ = von_mises_truss(2.0 * p_lim, a=a, h=h)
    return {"a": a, "h": h, "k": k, "p_lim": p_lim, "w_lim": w_lim, "system": system, "left": left,
            "path": fm.load_path(system, "P")}


# ----------------------------------------------------------------------------- 1. the elastica

def test_elastica_reference_agrees_with_bvp_and_the_published_table():
    table = {1.0: (0.30172, 0.05643), 2.0: (0.49346, 0.16064), 5.0: (0.71379, 0.38763), 10.0: (0.81061, 0.55500)}
    for alpha in ALPHAS:
        x, v, theta0 = elastica_tip(alpha)
        assert np.allclose((x, v, theta0), elastica_bvp(alpha), atol=1e-9, rtol=0)
        if alpha in table:
            assert v == pytest.approx(table[alpha][0], abs=6e-6)
            assert 1 - x == pytest.approx(table[alpha][1], abs=6e-6)


@pytest.mark.parametrize("alpha", ALPHAS)
def test_elastica_converges_from_the_straight_beam_with_the_defaults(alpha):
    # the target: tip within 2e-4 L of the closed form at N = 64, from x0 = 0, default arguments
    x = fm.static_equilibrium(elastica(64, alpha))
    err = np.hypot(*(beam_tip(x) - elastica_tip(alpha)[:2]))
    assert err < 2e-4, f"alpha = {alpha}: tip {beam_tip(x)} vs {elastica_tip(alpha)[:2]} ({err:.2e} L)"


def test_elastica_tip_error_falls_as_one_over_n_squared():
    # the error left at N = 64 is the segment model's, not the solver's: it shrinks 4 times per doubling
    alpha = 20.0
    errs = [np.hypot(*(beam_tip(fm.static_equilibrium(elastica(n, alpha))) - elastica_tip(alpha)[:2]))
            for n in (32, 64)]
    assert 3.8 < errs[0] / errs[1] < 4.2, errs


def test_elastica_alpha_10_and_20_take_the_load_path_in_a_few_steps():
    # the issue: the previous solver stops at alpha = 10 (N = 32 and 64); Newton's method on the
    # reduced static equations alone gets through alpha = 10, not 20
    system = elastica(32, 10.0)
    assert _previous_static_equilibrium(system) is None
    with pytest.raises(fm.AssemblyError, match="did not converge in 50 Newton steps: last step"):
        fm.static_equilibrium(elastica(32, 20.0), continuation=False)
    for alpha in (10.0, 20.0):
        x, path = fm.static_equilibrium(elastica(32, alpha), full_output=True)
        assert path.reached and path.lam[0] == 0.0 and path.lam[-1] == 1.0
        assert np.all(np.diff(path.lam) > 0) and not path.limit_points and not path.bifurcations
        assert path.stable.all()
        assert np.array_equal(path.x[-1], x)
        assert np.max(path.residual) < 1e-6 * alpha * EI
        assert path.n_steps < 20 and path.n_rejected == 0 and path.n_iterations < 60


def _previous_static_equilibrium(system, tol=1e-10, max_iter=50):
    """The solver before continuation: Newton's method on fm.linearize's K and F from x = 0 (None: failed)."""
    x = np.zeros(system.n_coords)
    for _ in range(max_iter):
        lin = fm.linearize(system, x)
        dz = np.linalg.solve(lin.K, lin.F)
        x = x + lin.T @ dz
        if np.max(np.abs(dz)) < tol:
            return x
    return None


def _gravity_cantilever(n):
    model = fm.Model()
    beam = fm.FlexibleBody("beam", 1.0, SECTION, fm.Material.aluminium(), n_segments=n, keep=("bend_y",))
    model.add(fm.Fixed("clamp", model.ground, beam), fm.Gravity((0.0, 0.0, -9.81)))
    return model.build()


@pytest.mark.parametrize("make", [lambda: _gravity_cantilever(16), lambda: elastica(16, 1.0),
                                  lambda: elastica(16, 2.0), lambda: elastica(16, 5.0)],
                         ids=["gravity sag", "alpha=1", "alpha=2", "alpha=5"])
def test_the_defaults_give_the_previous_results(make):
    system = make()
    previous = _previous_static_equilibrium(system)
    x, path = fm.static_equilibrium(system, full_output=True)
    assert np.max(np.abs(x - previous)) < 1e-9
    if system.n_coords and np.max(np.abs(previous)) < 0.1:  # small deflection: Newton's method alone, as before
        assert path is None


# ----------------------------------------------------------------------------- 2. the von Mises truss

def test_truss_reference_has_a_limit_point_inside_the_rise(truss):
    a, h, k = truss["a"], truss["h"], truss["k"]
    assert 0.0 < truss["w_lim"] < h
    # shallow truss, L ~ a + (h - w)^2 / (2 a): P ~ k u (h^2 - u^2) / a^2 with u = h - w, largest at
    # u = h / sqrt(3): P_lim ~ 2 k h^3 / (3 sqrt(3) a^2), to relative order (h / a)^2
    assert truss["p_lim"] == pytest.approx(2 / (3 * np.sqrt(3)) * k * h**3 / a**2, rel=3 * (h / a) ** 2)
    assert truss_load(2 * h, k, a, h) == pytest.approx(0.0, abs=1e-9 * truss["p_lim"])


def test_truss_path_follows_the_closed_form(truss):
    path, system, left, h = truss["path"], truss["system"], truss["left"], truss["h"]
    w = np.array([apex_drop(system, left, x, h) for x in path.x])
    p = path.lam * 2.0 * truss["p_lim"]
    assert np.max(np.abs(p - truss_load(w, truss["k"], truss["a"], h))) < 1e-6 * truss["p_lim"]
    # the bars stay straight: the bending coordinates carry nothing on the symmetric path
    bending = [i for i, name in enumerate(system.coordinate_names) if name.endswith("bend_y")]
    assert np.max(np.abs(path.x[:, bending])) < 1e-10


def test_truss_path_passes_the_limit_point_and_snaps_through(truss):
    path, system, left, h = truss["path"], truss["system"], truss["left"], truss["h"]
    assert path.reached and path.lam[-1] == 1.0
    first, second = path.limit_points
    # limit load within 1e-6 of the closed form, at the closed form's apex drop
    assert (first.kind, second.kind) == ("maximum", "minimum")
    assert 2.0 * first.lam == pytest.approx(1.0, rel=1e-6)
    assert apex_drop(system, left, first.x, h) == pytest.approx(truss["w_lim"], rel=1e-4)
    assert 2.0 * second.lam == pytest.approx(-1.0, rel=1e-6)
    assert apex_drop(system, left, second.x, h) == pytest.approx(2 * h - truss["w_lim"], rel=1e-4)
    # the end: the inverted truss, apex below the supports, where P(w) = 2 P_lim on the far branch
    w_end = apex_drop(system, left, path.x[-1], h)
    w_ref = brentq(lambda w: truss_load(w, truss["k"], truss["a"], h) - 2.0 * truss["p_lim"], 2 * h, 10 * h,
                   xtol=1e-14)
    assert w_end > 2 * h
    assert w_end == pytest.approx(w_ref, rel=1e-8)
    assert path.n_steps < 40 and path.n_rejected <= 2
    # stable up to the limit load, unstable (one direction) between the limit points, stable when inverted
    assert not path.bifurcations
    assert path.stable[:first.index + 1].all() and path.stable[second.index + 1:].all()
    assert np.all(path.n_unstable[first.index + 1:second.index + 1] == 1)


@pytest.mark.parametrize("complement", ["eigen", "qr"])
def test_truss_limit_load_does_not_depend_on_the_complement(truss, complement):
    # the tangent is formed from g + psi^T mu, smooth in x, whatever basis of the null space T is
    system, _, _ = von_mises_truss(2.0 * truss["p_lim"], a=truss["a"], h=truss["h"], complement=complement)
    path = fm.load_path(system, "P")
    assert [p.lam for p in path.limit_points] == pytest.approx([p.lam for p in truss["path"].limit_points],
                                                               abs=1e-9)


def test_static_equilibrium_below_the_limit_load_stays_on_the_near_branch(truss):
    a, h, k = truss["a"], truss["h"], truss["k"]
    system, left, _ = von_mises_truss(0.9 * truss["p_lim"], a=a, h=h)
    w = apex_drop(system, left, fm.static_equilibrium(system), h)
    w_ref = brentq(lambda w: truss_load(w, k, a, h) - 0.9 * truss["p_lim"], 0.0, truss["w_lim"], xtol=1e-15)
    assert w == pytest.approx(w_ref, rel=1e-8)


def test_static_equilibrium_beyond_the_limit_load_finds_the_inverted_truss(truss):
    system, left, h = truss["system"], truss["left"], truss["h"]
    x = fm.static_equilibrium(system)
    assert apex_drop(system, left, x, h) == pytest.approx(apex_drop(system, left, truss["path"].x[-1], h),
                                                          rel=1e-8)


# ----------------------------------------------------------------------------- 3. buckling: a bifurcation

def _column(n, p_ref):
    """The strip as a column: clamped, a dead compressive force p_ref at its tip along -x."""
    model = fm.Model("column")
    beam = fm.FlexibleBody("column", 1.0, SECTION, STEEL, n_segments=n, keep=("bend_y",))
    model.add(fm.Fixed("clamp", model.ground, beam), fm.PointForce("P", beam, (-p_ref, 0.0, 0.0), point=(1, 0, 0)))
    return model.build()


def test_column_buckling_is_found_as_a_bifurcation_at_the_euler_load():
    # Euler's clamped-free column buckles at P_E = pi^2 E I / (4 L^2); loaded to 2 P_E the straight
    # path (no limit point) loses stability at a bifurcation, lambda = P_E / (2 P_E) = 1/2, and the
    # segment model's buckling load converges to P_E as 1/N^2
    p_e = np.pi**2 * EI / 4
    errs = []
    for n in (16, 32):
        path = fm.load_path(_column(n, 2 * p_e), "P")
        assert path.reached and not path.limit_points and np.max(np.abs(path.x)) == 0.0
        (bif,) = path.bifurcations
        assert bif.kind == "bifurcation" and path.lam[bif.index] < bif.lam < path.lam[bif.index + 1]
        assert path.stable[:bif.index + 1].all() and np.all(path.n_unstable[bif.index + 1:] == 1)
        errs.append(2 * bif.lam - 1)
    assert abs(errs[1]) < 3e-4, errs
    assert 3.8 < errs[0] / errs[1] < 4.2, errs


# ----------------------------------------------------------------------------- 4. failures that say why

def _pendulum(torque):
    """A 1 kg, 1 m bar hanging from a pin (gravity along +x) and a torque about the pin: it holds m g L / 2."""
    model = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model.add(fm.Revolute("pin", model.ground, bar, axis=(0, 1, 0)), fm.Gravity((9.81, 0.0, 0.0)),
              fm.BodyTorque("lift", bar, (0.0, torque, 0.0)))
    return model.build()


def test_a_load_the_structure_cannot_carry_is_reported_with_the_largest_load_factor():
    system = _pendulum(2 * 9.81 / 2)  # twice what the weight can hold
    with pytest.raises(fm.AssemblyError, match=r"static equilibrium: load factor 1 not reached .* limit points") \
            as info:
        fm.static_equilibrium(system)
    assert "carries load factors up to 0.5" in str(info.value)
    assert "residual" in str(info.value)
    path = info.value.path
    assert not path.reached
    assert path.limit_points[0].lam == pytest.approx(0.5, abs=1e-9)
    assert abs(path.limit_points[0].x[0]) == pytest.approx(np.pi / 2, abs=1e-4)


def test_a_mechanism_without_stiffness_is_reported():
    model = fm.Model()
    block = fm.RigidBody.box("block", 1.0, (0.1, 0.1, 0.1))
    model.add(fm.Prismatic("rail", model.ground, block, axis=(1, 0, 0)), fm.PointForce("push", block, (1.0, 0, 0)))
    with pytest.raises(fm.AssemblyError, match=r"tangent stiffness is singular at the start \(load factor 0, "
                                               r"residual 0, load to carry 1\): a mechanism"):
        fm.static_equilibrium(model.build())
    with pytest.raises(fm.AssemblyError, match=r"Newton's method stopped at step 1: the tangent stiffness is "
                                               r"singular \(a mechanism with an unloaded free motion\?\)"):
        fm.static_equilibrium(model.build(), continuation=False)


def test_a_failed_step_names_the_load_step_and_the_residual():
    options = fm.PathOptions(step=0.1, min_step=0.06, max_iter=1)
    with pytest.raises(fm.AssemblyError, match=r"load path stopped at load step 1 from load factor 0 .*residual") \
            as info:
        fm.load_path(elastica(16, 10.0), "P", options=options)
    assert info.value.path.lam.tolist() == [0.0] and info.value.path.n_rejected == 1


def test_a_failed_solve_at_the_target_names_the_load_step_and_the_residual(monkeypatch):
    # the last step crosses lambda = 1 and Newton's method there fails however short the step gets
    from flexmb.analysis import path_following

    newton = path_following._newton

    def failing_at_the_target(eq, x, lam, *args, **kw):
        if lam == 1.0:
            raise path_following._NotConverged("no convergence in 20 Newton steps", 1e-3, 2.5, 20)
        return newton(eq, x, lam, *args, **kw)

    monkeypatch.setattr(path_following, "_newton", failing_at_the_target)
    with pytest.raises(fm.AssemblyError, match=r"no equilibrium found at the target load factor 1 near load step "
                                               r"\d+: no convergence in 20 Newton steps; residual 2.5$"):
        fm.load_path(elastica(8, 1.0), "P")


def test_a_start_of_the_wrong_shape_is_refused():
    with pytest.raises(fm.ModelError, match=r"x0 must have shape \(16,\), got \(3,\)"):
        fm.static_equilibrium(elastica(16, 1.0), x0=np.zeros(3))


# ----------------------------------------------------------------------------- 5. the API

def test_load_given_by_name_object_or_list_gives_the_same_path():
    system = _pendulum(9.81)
    by_name = fm.load_path(system, "lift", lam_end=0.4)
    by_object = fm.load_path(system, system.model.element("lift"), lam_end=0.4)
    by_list = fm.load_path(system, ["lift"], lam_end=0.4)
    assert by_name.load == "lift"
    assert abs(by_name.x[-1][0]) == pytest.approx(np.arcsin(0.8), abs=1e-10)
    for other in (by_object, by_list):
        assert np.array_equal(other.lam, by_name.lam)


def test_an_unknown_load_lists_the_force_elements():
    with pytest.raises(fm.ModelError, match="no force element named 'lfit'.*'lift'"):
        fm.load_path(_pendulum(9.81), "lfit")


def test_gravity_as_the_followed_load_starts_from_the_unloaded_state():
    # with a named load, lambda = 0 is solved first: here the beam without its tip force is straight
    system = _gravity_cantilever(8)
    path = fm.load_path(system, "gravity")
    assert path.lam[0] == 0.0 and np.allclose(path.x[0], 0.0)
    assert np.max(np.abs(path.x[-1] - fm.static_equilibrium(system))) < 1e-9


def test_path_options_are_checked():
    with pytest.raises(fm.ModelError, match="step must be > 0"):
        fm.PathOptions(step=-1.0)
    with pytest.raises(fm.ModelError, match="max_iter must be an integer >= 1, got 0"):
        fm.PathOptions(max_iter=0)
    with pytest.raises(fm.ModelError, match="max_steps must be an integer >= 1, got None"):
        fm.PathOptions(max_steps=None)  # was a TypeError from int(None)
    with pytest.raises(fm.ModelError, match="tol must be a finite number, got 'tight'"):
        fm.PathOptions(tol="tight")
    with pytest.raises(fm.ModelError, match="max_turn must be a cosine"):
        fm.PathOptions(max_turn=1.0)
    with pytest.raises(fm.ModelError, match="need min_step <= step <= max_step, got 1e-06, 0.6, 0.5"):
        fm.PathOptions(step=0.6)


def test_load_path_repr_and_coordinate(truss):
    path = truss["path"]
    assert repr(path).startswith("LoadPath(load='P', ")
    assert "limit points at lambda = 0.5, -0.5" in repr(path)
    assert np.array_equal(path.coordinate("pin_left.angle"), path.x[:, 0])
    with pytest.raises(fm.ExportError, match="no coordinate 'nope'"):
        path.coordinate("nope")


def test_load_path_plot(truss, tmp_path):
    pytest.importorskip("matplotlib")
    path, system, left, h = truss["path"], truss["system"], truss["left"], truss["h"]

    def apex(x):
        return apex_drop(system, left, x, h)

    fig = path.plot(apex, path=tmp_path / "truss.png")
    assert (tmp_path / "truss.png").stat().st_size > 0
    ax = fig.axes[0]
    assert ax.get_ylabel() == "load factor (-)" and ax.get_xlabel() == "apex"
    line, marks = ax.lines
    assert np.allclose(line.get_ydata(), path.lam)
    assert np.allclose(marks.get_ydata(), [0.5, -0.5], atol=1e-6)
    assert path.plot("pin_left.angle", path=tmp_path / "angle.png").axes[0].get_xlabel() == "pin_left.angle"
    column = fm.load_path(_column(8, np.pi**2 * EI / 2), "P")
    line, marks = column.plot(0, path=tmp_path / "column.png", xlabel="rotation (rad)").axes[0].lines
    assert marks.get_label() == "bifurcations" and np.allclose(marks.get_ydata(), [column.bifurcations[0].lam])
