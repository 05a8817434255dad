"""Flexible bodies whose section and material vary along them (tapered and stepped beams).

The reference for the tapered cantilever is computed here, independently
of flexmb: the Euler-Bernoulli eigenproblem ``(EI w'')'' = omega^2 rho A w``
with EI and rho A varying along the beam, clamped at s = 0 and free at
s = L, solved by scipy's collocation solver ``solve_bvp`` with the
eigenvalue as an unknown parameter (and ``w(L) = 1`` fixing the scale). The
solver is first checked against the uniform closed form
``beta L = 1.8751041, 4.6940911, 7.8547574``.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_bvp

import flexmb as fm

BETA_L = np.array([1.8751041, 4.6940911, 7.8547574])
SECTION = fm.Section.rectangular(0.02, 0.005)
MATERIAL = fm.Material.aluminium()
L = 1.0
EI0 = MATERIAL.E * SECTION.Iy
RHOA0 = MATERIAL.density * SECTION.area
# linear taper: EI falls by a factor 4 from root to tip, rho A by a factor 2
EI_TIP, RHOA_TIP = 0.25, 0.5


def ei(s):
    return EI0 * (1.0 + (EI_TIP - 1.0) * np.asarray(s) / L)


def rhoa(s):
    return RHOA0 * (1.0 + (RHOA_TIP - 1.0) * np.asarray(s) / L)


def continuum_frequencies(e, r, n_modes=3, stations=None):
    """Cantilever frequencies (Hz) of ``(EI0 e w'')'' = omega^2 rhoA0 r w`` by solve_bvp.

    Nondimensional in xi = s / L: y = (w, w', M, V) with M = e w'', V = M',
    eigenvalue Lambda = omega^2 rhoA0 L^4 / EI0; the uniform mode shapes are
    the initial guesses. With ``stations`` (m), also the mode shapes w there,
    shape (len(stations), n_modes), scaled to w(L) = 1.
    """
    out, shapes = [], []
    x = np.linspace(0.0, 1.0, 201)
    for b in BETA_L[:n_modes]:
        sig = (np.cosh(b) + np.cos(b)) / (np.sinh(b) + np.sin(b))
        y = np.array([np.cosh(b * x) - np.cos(b * x) - sig * (np.sinh(b * x) - np.sin(b * x)),
                      b * (np.sinh(b * x) + np.sin(b * x) - sig * (np.cosh(b * x) - np.cos(b * x))),
                      b**2 * (np.cosh(b * x) + np.cos(b * x) - sig * (np.sinh(b * x) + np.sin(b * x))),
                      b**3 * (np.sinh(b * x) - np.sin(b * x) - sig * (np.cosh(b * x) + np.cos(b * x)))])
        y /= y[0, -1]

        def rhs(xi, y, p):
            return np.vstack([y[1], y[2] / e(xi), y[3], p[0] * r(xi) * y[0]])

        def bc(ya, yb, p):
            return np.array([ya[0], ya[1], yb[2], yb[3], yb[0] - 1.0])

        sol = solve_bvp(rhs, bc, x, y, p=[b**4], tol=1e-8, max_nodes=100000)
        assert sol.success, sol.message
        out.append(np.sqrt(sol.p[0] * EI0 / (RHOA0 * L**4)) / (2 * np.pi))
        if stations is not None:
            shapes.append(sol.sol(np.asarray(stations) / L)[0])
    return np.array(out) if stations is None else (np.array(out), np.array(shapes).T)


@pytest.fixture(scope="module")
def tapered_reference():
    return continuum_frequencies(lambda xi: ei(xi * L) / EI0, lambda xi: rhoa(xi * L) / RHOA0)


def cantilever_frequencies(body, n_modes=3):
    model = fm.Model()
    model.add(fm.Fixed("clamp", model.ground, body))
    return fm.modes(model.build(), n_modes)[0]


def profiles():
    """The same linear taper given three ways: a table, functions of s, sections of s."""
    a0, i0 = SECTION.area, SECTION.Iy
    return {
        "table": fm.BeamProfile.table([0.0, L], EIy=[EI0, EI_TIP * EI0], rhoA=[RHOA0, RHOA_TIP * RHOA0]),
        "functions": fm.BeamProfile.from_functions(EIy=ei, rhoA=rhoa),
        "sections": fm.BeamProfile.from_sections(
            lambda s: fm.Section(a0 * (1 + (RHOA_TIP - 1) * s / L), i0 * (1 + (EI_TIP - 1) * s / L),
                                 SECTION.Iz, SECTION.J), MATERIAL),
    }


def tapered(n, profile):
    # the continuum has no rotary inertia: slender segments
    return fm.FlexibleBody("beam", L, SECTION, MATERIAL, n, keep=("bend_y",), rotary_inertia=False,
                           profile=profile)


# ----------------------------------------------------------------------------- the reference

def test_continuum_reference_reproduces_the_uniform_closed_form():
    f = continuum_frequencies(lambda xi: np.ones_like(xi), lambda xi: np.ones_like(xi))
    closed = BETA_L**2 / (2 * np.pi) * np.sqrt(EI0 / (RHOA0 * L**4))
    assert f == pytest.approx(closed, rel=1e-6)


def test_tapered_reference_differs_from_the_uniform_beam(tapered_reference):
    # a root-heavy taper: the first frequency rises, the higher ones fall
    uniform = BETA_L**2 / (2 * np.pi) * np.sqrt(EI0 / (RHOA0 * L**4))
    assert tapered_reference[0] > 1.15 * uniform[0]
    assert np.all(tapered_reference[1:] < uniform[1:])


# ----------------------------------------------------------------------------- convergence

@pytest.mark.parametrize("how", ["table", "functions", "sections"])
def test_tapered_cantilever_frequencies_converge_at_second_order(tapered_reference, how):
    ns = np.array([8, 16, 32])
    profile = profiles()[how]
    err = np.array([cantilever_frequencies(tapered(n, profile)) / tapered_reference - 1.0 for n in ns])
    for i in range(3):
        p = -np.polyfit(np.log(ns), np.log(np.abs(err[:, i])), 1)[0]
        assert 1.7 < p < 2.3, f"f{i + 1}: observed order {p:.3f} (errors {err[:, i]})"
    assert np.all(np.abs(err[-1]) < [1e-3, 2e-3, 3e-3]), f"N = 32 errors {err[-1]}"


def test_the_three_ways_of_giving_a_taper_agree():
    bodies = {k: tapered(16, p) for k, p in profiles().items()}
    ref = bodies["table"]
    for body in bodies.values():
        assert body.joint_stiffness() == pytest.approx(ref.joint_stiffness(), rel=1e-12)
        for a, b in zip(body.segment_properties(), ref.segment_properties()):
            assert a == pytest.approx(b, rel=1e-12, abs=1e-18)


# ----------------------------------------------------------------------------- segment data

@pytest.mark.parametrize("clamped", [True, False])
def test_a_uniform_profile_reproduces_the_uniform_body(clamped):
    keep = ("torsion", "bend_y", "bend_z", "axial", "shear_y", "shear_z")
    uniform = fm.FlexibleBody("b", 0.8, SECTION, MATERIAL, 6, keep=keep, clamped=clamped)
    profiled = fm.FlexibleBody("b", 0.8, SECTION, MATERIAL, 6, keep=keep, clamped=clamped,
                               profile=fm.BeamProfile.from_sections(SECTION, MATERIAL))
    assert profiled.joint_stiffness() == pytest.approx(uniform.joint_stiffness(), rel=1e-14)
    m, inertia, com = uniform.segment_mass_properties()
    pm, pi, pc = profiled.segment_properties()
    assert pm == pytest.approx(np.full(6, m), rel=1e-14)
    assert pi == pytest.approx(np.broadcast_to(inertia, (6, 3, 3)), rel=1e-12, abs=1e-20)
    assert pc == pytest.approx(np.broadcast_to(com, (6, 3)), rel=1e-14)
    assert profiled.mass == pytest.approx(uniform.mass, rel=1e-14)


def test_tapered_segment_mass_centre_and_inertia_are_integrated():
    """rho A linear on each segment: mass, centroid and second moment in closed form."""
    n = 4
    body = tapered(n, profiles()["table"])
    m, inertia, com = body.segment_properties()
    l = L / n
    a = rhoa(np.arange(n) * l)  # rho A at each segment's start and end
    b = rhoa((np.arange(n) + 1) * l)
    assert m == pytest.approx(0.5 * (a + b) * l, rel=1e-14)
    c = l * (a + 2 * b) / (3 * (a + b))  # centroid of a trapezoid
    assert com[:, 0] == pytest.approx(c, rel=1e-13)
    slope = (b - a) / l
    second = a * l**3 / 3 + slope * l**4 / 4 - m * c**2  # int rho A (s - c)^2 over the segment
    assert inertia[:, 1, 1] == pytest.approx(second, rel=1e-11)
    assert np.all(inertia[:, 0, 0] == 0)  # no rotary inertia: slender segments
    assert body.mass == pytest.approx(0.5 * (RHOA0 + RHOA_TIP * RHOA0) * L, rel=1e-14)


def test_tapered_joint_springs_are_the_flexibility_of_their_span():
    """EI linear: int ds / EI = ln(EI(a) / EI(b)) / slope, over [s_i - l/2, s_i + l/2] ([0, l/2] at the clamp)."""
    n = 8
    body = tapered(n, profiles()["table"])
    l = L / n
    lo = np.maximum((np.arange(n) - 0.5) * l, 0.0)
    hi = (np.arange(n) + 0.5) * l
    slope = (EI_TIP - 1.0) * EI0 / L
    k = slope / np.log(ei(hi) / ei(lo))
    assert body.joint_stiffness()[:, 0] == pytest.approx(k, rel=1e-9)


def test_stepped_beam_per_segment_sections():
    """A step at a segment end: the joint there is two half segments in series."""
    thick, thin = fm.Section.rectangular(0.02, 0.006), fm.Section.rectangular(0.02, 0.004)
    sections = [thick] * 3 + [thin] * 3
    body = fm.FlexibleBody.varying_beam("stepped", 0.6, sections, MATERIAL, 6)
    l = 0.1
    ei_a, ei_b = MATERIAL.E * thick.Iy, MATERIAL.E * thin.Iy
    k = body.joint_stiffness()[:, 0]
    assert k[0] == pytest.approx(2 * ei_a / l, rel=1e-14)
    assert k[1:3] == pytest.approx(ei_a / l, rel=1e-14)
    assert k[3] == pytest.approx(1.0 / (0.5 * l / ei_a + 0.5 * l / ei_b), rel=1e-14)
    assert k[4:] == pytest.approx(ei_b / l, rel=1e-14)
    rho = MATERIAL.density
    assert body.segment_properties()[0] == pytest.approx(rho * l * np.array([thick.area] * 3 + [thin.area] * 3),
                                                         rel=1e-14)
    assert body.section is thick


def test_step_inside_a_segment_is_integrated_exactly():
    """A step table whose step falls mid-segment: the quadrature splits there."""
    body = fm.FlexibleBody("b", 1.0, SECTION, MATERIAL, 4, keep=("bend_y",), rotary_inertia=False,
                           profile=fm.BeamProfile.table([0.0, 0.3, 1.0], EIy=[2.0, 1.0], rhoA=[3.0, 1.0],
                                                        interpolation="step"))
    m = body.segment_properties()[0]
    assert m == pytest.approx([0.25 * 3.0, 0.05 * 3.0 + 0.2 * 1.0, 0.25, 0.25], rel=1e-14)
    k = body.joint_stiffness()[:, 0]
    # joint 1 at s = 0.25 spans [0.125, 0.375]: 0.175 m at EI 2, 0.075 m at EI 1
    assert k[1] == pytest.approx(1.0 / (0.175 / 2.0 + 0.075 / 1.0), rel=1e-14)


def test_scale_factors_multiply_springs_masses_and_dampers():
    base = fm.FlexibleBody("b", 1.0, SECTION, MATERIAL, 4, keep=("bend_y", "torsion"), damping=1e-3)
    ks, ms = np.array([1.0, 1.1, 1.2, 1.3]), np.array([0.5, 1.0, 1.5, 2.0])
    scaled = fm.FlexibleBody("b", 1.0, SECTION, MATERIAL, 4, keep=("bend_y", "torsion"), damping=1e-3,
                             stiffness_scale=ks, mass_scale=ms)
    assert scaled.joint_stiffness() == pytest.approx(base.joint_stiffness() * ks[:, None], rel=1e-15)
    m0, i0, _ = base.segment_mass_properties()
    m, inertia, _ = scaled.segment_properties()
    assert m == pytest.approx(m0 * ms) and inertia == pytest.approx(i0 * ms[:, None, None])
    assert scaled.mass == pytest.approx(np.sum(m0 * ms))
    assert scaled.varying and not base.varying
    # the assembled model carries them: K = diag(k) for a clamped beam at rest
    model = fm.Model()
    model.add(fm.Fixed("clamp", model.ground, scaled))
    lin = fm.linearize(model.build())
    assert np.diag(lin.K) == pytest.approx(scaled.joint_stiffness().ravel(), rel=1e-6)
    assert np.diag(lin.C) == pytest.approx(1e-3 * scaled.joint_stiffness().ravel(), rel=1e-6)


def test_a_tapered_beam_simulates_and_exports_its_shape():
    body = fm.FlexibleBody.varying_beam("taper", 1.0, lambda s: fm.Section.rectangular(0.02, 0.005 * (1 - s / 2)),
                                        MATERIAL, 8, damping=1e-3)
    model = fm.Model()
    model.add(fm.Fixed("clamp", model.ground, body), fm.Gravity((0.0, 0.0, -9.81)))
    res = fm.simulate(model, 0.05, n_out=11, rtol=1e-6)
    shape = res.shape("taper")
    assert shape.shape == (11, 9, 3) and shape[-1, -1, 2] < 0
    with pytest.raises(fm.FlexmbError, match="varies along it"):
        res.section_stresses("taper", model.build())


def test_profile_table_interpolates_linearly():
    p = fm.BeamProfile.table([0.0, 0.5, 2.0], EIy=[4.0, 2.0, 1.0], rhoA=[1.0, 1.0, 4.0])
    assert p.at(0.25)["EIy"] == pytest.approx(3.0)
    assert p.at(1.25)["rhoA"] == pytest.approx(2.5)
    assert p.at(1.0)["rhoIy"] == 0.0 and np.isnan(p.at(1.0)["EA"])
    assert p.domain == (0.0, 2.0)
    assert "linear table, 3 stations" in repr(p)


# ----------------------------------------------------------------------------- bad input

def _table(**kw):
    args = dict(EIy=[1.0, 1.0], rhoA=[1.0, 1.0])
    args.update(kw)
    return fm.BeamProfile.table([0.0, 1.0], **args)


@pytest.mark.parametrize("kw, message", [
    ({"profile": _table(EIy=[1.0, -1.0])}, r"EIy \(needed by 'bend_y'\) must be finite and > 0 along the body, "
                                           r"got -0\.\d+ at s = 0\.\d+ m"),
    ({"profile": _table(EIy=[0.0, 1.0])}, r"EIy \(needed by 'bend_y'\) must be finite and > 0"),
    ({"profile": _table(rhoA=[1.0, 0.0])}, r"rhoA \(mass per length\) must be finite and > 0 .* at s = "),
    ({"profile": fm.BeamProfile.from_functions(EIy=lambda s: np.where(s > 0.5, np.nan, 1.0), rhoA=1.0)},
     r"EIy \(needed by 'bend_y'\) must be finite and > 0 along the body, got nan at s = 0\.5"),
    ({"profile": fm.BeamProfile.from_functions(EIy=1.0, rhoA=lambda s: float("nan"))},
     r"rhoA \(mass per length\) must be finite and > 0 along the body, got nan"),
    ({"profile": fm.BeamProfile.table([0.0, 0.8], EIy=[1.0, 1.0], rhoA=[1.0, 1.0])},
     r"its profile 'profile' covers s in \[0, 0\.8\] m, not the whole body \[0, 1\] m"),
    ({"profile": fm.BeamProfile.table([0.1, 1.0], EIy=[1.0, 1.0], rhoA=[1.0, 1.0])},
     r"its profile 'profile' covers s in \[0\.1, 1\] m, not the whole body"),
    ({"profile": _table(), "keep": ("bend_z",)}, r"EIz \(needed by 'bend_z'\) must be finite and > 0 .* got nan"),
    ({"profile": _table(rhoIy=[-1.0, 0.0])}, r"rhoIy \(rotary inertia per length\) must be finite and >= 0"),
    ({"profile": "taper"}, r"profile must be a BeamProfile or None, got str"),
    ({"profile": fm.BeamProfile.from_sections(lambda s: 1 / 0, MATERIAL)},
     r"profile 'profile': section failed at s = .* m: ZeroDivisionError"),
    ({"profile": fm.BeamProfile.from_sections(lambda s: 0.02, MATERIAL)},
     r"profile 'profile': section returned float at s = .* m, expected a Section"),
    ({"profile": fm.BeamProfile.from_sections(lambda s: fm.Section.rectangular(0.02, 0.005 * (1 - 2 * s)),
                                              MATERIAL)},
     r"profile 'profile': section at s = 0\.\d+ m: Section.rectangular: h must be a finite number > 0, got -0\.000\d+"),
    ({"stiffness_scale": [1.0, 1.0]}, r"stiffness_scale must have shape \(4,\) or \(4, 1\), got \(2,\)"),
    ({"stiffness_scale": [1.0, 1.0, -1.0, 1.0]}, r"stiffness_scale must be finite and > 0"),
    ({"mass_scale": [1.0, np.nan, 1.0, 1.0]}, r"mass_scale must be finite and > 0"),
    ({"mass_scale": "heavy"}, r"mass_scale must be an array of numbers"),
])
def test_bad_profile_input_names_the_body(kw, message):
    args = dict(length=1.0, section=SECTION, material=MATERIAL, n_segments=4, keep=("bend_y",))
    args.update(kw)
    with pytest.raises(fm.ModelError, match=r"FlexibleBody 'wing': " + message):
        fm.FlexibleBody("wing", **args)


@pytest.mark.parametrize("section, material, message", [
    ([SECTION] * 3, MATERIAL, r"section as a list needs one Section per segment \(4\), got 3 items"),
    (SECTION, [MATERIAL] * 5, r"material as a list needs one Material per segment \(4\), got 5 items"),
    (3.0, MATERIAL, r"section must be a Section, a function of s returning one, or a list"),
    (lambda s: fm.Section.rectangular(0.02, 0.005 * (1 - 2 * s)), MATERIAL,
     r"profile 'wing profile': section at s = 0\.\d+ m: Section.rectangular"),
])
def test_bad_varying_beam_input_names_the_body(section, material, message):
    with pytest.raises(fm.ModelError, match=r"FlexibleBody 'wing': " + message):
        fm.FlexibleBody.varying_beam("wing", 1.0, section, material, 4)


@pytest.mark.parametrize("args, kw, message", [
    (([1.0, 0.5],), {"EIy": [1, 1]}, r"stations must be at least 2 finite, strictly increasing"),
    (([0.0, np.nan],), {"EIy": [1, 1]}, r"stations must be at least 2 finite"),
    (([0.0, 1.0],), {"EIy": [1, 1, 1]}, r"EIy must be 2 numbers \(one per station\)"),
    (([0.0, 1.0],), {"EIy": [1.0], "interpolation": "cubic"}, r"interpolation must be 'linear' or 'step'"),
    (([0.0, 1.0],), {"EI": [1, 1]}, r"unknown beam property \['EI'\]"),
    (([0.0, 1.0],), {}, r"give sections \(and materials\) or property columns"),
    (([0.0, 1.0], [SECTION]), {"materials": MATERIAL}, r"'linear' needs 2 sections and materials"),
    (([0.0, 1.0], [SECTION, "x"]), {"materials": MATERIAL}, r"entry 1 is not a Section and a Material"),
])
def test_bad_profile_table_is_refused(args, kw, message):
    with pytest.raises(fm.ModelError, match=r"BeamProfile 'profile': " + message):
        fm.BeamProfile.table(*args, **kw)


def test_profile_function_of_the_wrong_shape_is_refused():
    bad = fm.BeamProfile(lambda s: np.zeros((len(s), 3)), name="short")
    with pytest.raises(fm.ModelError, match=r"FlexibleBody 'wing': profile 'short': BeamProfile 'short': function "
                                            r"returned shape \(\d+, 3\), expected \(\d+, 8\)"):
        fm.FlexibleBody("wing", 1.0, SECTION, MATERIAL, 4, keep=("bend_y",), profile=bad)
    with pytest.raises(fm.ModelError, match=r"BeamProfile 'profile': function must be callable"):
        fm.BeamProfile(3.0)


def test_profile_repr():
    body = fm.FlexibleBody.varying_beam("b", 1.0, [SECTION] * 2, MATERIAL, 2)
    assert "one per segment: 2 Section" in repr(body.profile)
    assert "functions of s: EIy" in repr(fm.BeamProfile.from_functions(EIy=1.0))
