"""Linearisation about a steady motion (:func:`flexmb.linearize_steady`), velocity rows included.

The upright rolling disc against its closed-form lean equation, a
holonomic model against :func:`flexmb.linearize`, and the refusals.
"""

from __future__ import annotations

import numpy as np
import pytest

import flexmb as fm
from test_constraint_elements import G, R_DISC, disc_model

DISC_IGNORABLE = ["px", "py", "heading.angle", "spin"]


def upright_disc(system, spin):
    return fm.initial_state(system, positions={"heading.slide": R_DISC},
                            speeds={"heading.angle": 0.0, "lean": 0.0, "spin": spin}, fixed=["lean"])


def test_linearize_refuses_velocity_rows_and_names_the_steady_linearisation():
    system = disc_model().build()
    with pytest.raises(fm.ModelError, match=r"linearize: .*velocity.*'roll'.*linearize_steady"):
        fm.linearize(system)


@pytest.mark.parametrize("spin", [10.0, 2.0, -6.0])
def test_upright_rolling_disc_lean_eigenvalues(spin):
    """About upright rolling at spin s (tests/test_constraint_elements.py derives it):
    ``(I_d + m r^2) theta'' = m g r theta + (I_a + m r^2) s psi'`` and ``I_d psi'' = -I_a s theta'``;
    for the thin disc (``I_a = m r^2 / 2``, ``I_d = m r^2 / 4``) the state ``(theta, psi', theta', phi')``
    has ``A = [[0, 0, 1, 0], [0, 0, -2 s, 0], [(4/5) g / r, (6/5) s, 0, 0], [0, 0, 0, 0]]``, eigenvalues
    ``0, 0, +-sqrt((4/5)(g/r - 3 s^2))``: a lean oscillation above the critical spin, a fall below it."""
    system = disc_model().build()
    x0, xd0 = upright_disc(system, spin)
    lin = fm.linearize_steady(system, x0, xd0, ignorable=DISC_IGNORABLE)
    assert lin.coordinates == ["lean.angle"]
    assert lin.speeds == ["heading.angle", "lean.angle", "spin.angle"]
    assert lin.states == ["lean.angle", "heading.angle rate", "lean.angle rate", "spin.angle rate"]
    A = np.array([[0, 0, 1, 0], [0, 0, -2 * spin, 0], [0.8 * G / R_DISC, 1.2 * spin, 0, 0], [0, 0, 0, 0]])
    np.testing.assert_allclose(lin.A, A, rtol=0, atol=1e-9 * np.max(np.abs(A)))
    root = np.sqrt(complex(0.8 * (G / R_DISC - 3 * spin**2)))
    ev = lin.eigenvalues()
    big = ev[np.abs(ev) > 1e-6]
    np.testing.assert_allclose(np.sort_complex(big), np.sort_complex(np.array([-root, root])), rtol=1e-8, atol=0)
    assert np.max(np.abs(ev[np.abs(ev) <= 1e-6])) < 1e-9 and len(big) == 2


def test_default_ignorable_are_the_moving_coordinates():
    """Left to infer, only the coordinates that move are ignorable; the lateral position and the heading
    stay in (two more zero eigenvalues), and the lean pair is unchanged."""
    system = disc_model().build()
    x0, xd0 = upright_disc(system, 10.0)
    lin = fm.linearize_steady(system, x0, xd0)
    assert lin.ignorable == ["px.slide", "spin.angle"]
    assert lin.coordinates == ["py.slide", "heading.angle", "lean.angle"]
    ev = lin.eigenvalues()
    root = np.sqrt(0.8 * (3 * 10.0**2 - G / R_DISC))
    np.testing.assert_allclose(np.sort(ev[np.abs(ev) > 1e-3].imag), [-root, root], rtol=1e-8)


def test_steady_precession_linearises_and_is_time_invariant():
    """A disc precessing steadily (heading turning, ignorable): the linear model is the same at two
    points of the motion half a turn apart (it cannot depend on the heading), and its spectrum is that of a
    reversible system, symmetric under ``lambda -> -lambda`` (rolling without slipping does no work and the
    equations are unchanged by reversing time with the speeds); this slow precession is unstable."""
    from test_constraint_elements import steady_spin

    theta, omega = 0.2, 3.0
    spin = steady_spin(theta, omega)
    system = disc_model().build()
    lins = []
    for heading in (0.0, np.pi):
        at = {"heading.slide": R_DISC, "lean": theta, "heading.angle": heading}
        x0, xd0 = fm.initial_state(system, positions=at,
                                   speeds={"heading.angle": omega, "lean": 0.0, "spin": spin},
                                   fixed=["lean", "heading.angle"])
        lins.append(fm.linearize_steady(system, x0, xd0, ignorable=DISC_IGNORABLE))
    assert lins[0].residual < 1e-9
    np.testing.assert_allclose(lins[1].A, lins[0].A, atol=1e-9 * np.max(np.abs(lins[0].A)))
    ev = lins[0].eigenvalues()
    big = np.sort_complex(ev[np.abs(ev) > 1e-6])
    assert len(big) == 2
    np.testing.assert_allclose(np.sort_complex(-big), big, rtol=1e-8)


def test_a_holonomic_model_agrees_with_linearize():
    """A double pendulum hanging still: the eigenvalues ``+-i w`` of the first-order model are the
    natural frequencies of :func:`flexmb.modes` (an independent formulation, M and K in x = x0 + T z)."""
    model = fm.Model()
    a = fm.RigidBody.slender_bar("a", 1.0, 0.6)
    b = fm.RigidBody.slender_bar("b", 0.5, 0.4)
    system = model.add(fm.Revolute("p1", model.ground, a, axis=(0, 1, 0)),
                       fm.Revolute("p2", a, b, axis=(0, 1, 0), parent_point=(0.6, 0, 0)),
                       fm.Gravity((0, 0, -9.81))).build()
    x0 = np.array([np.pi / 2, 0.0])  # the bars hang along -z
    lin = fm.linearize_steady(system, x0, np.zeros(2))
    f, _ = fm.modes(system, x0=x0)
    w = np.sort(lin.eigenvalues().imag[lin.eigenvalues().imag > 0])
    np.testing.assert_allclose(w, 2 * np.pi * f, rtol=1e-9)
    assert np.max(np.abs(lin.eigenvalues().real)) < 1e-9


def test_refusals_name_the_coordinates():
    system = disc_model().build()
    x0, xd0 = upright_disc(system, 10.0)
    with pytest.raises(fm.ModelError, match=r"\['px.slide', 'spin.angle'\] move .* not named ignorable"):
        fm.linearize_steady(system, x0, xd0, ignorable=["py", "heading"])
    with pytest.raises(fm.ModelError, match=r"depends on 'lean.angle', named ignorable"):
        fm.linearize_steady(system, x0, xd0, ignorable=DISC_IGNORABLE + ["lean"])
    with pytest.raises(fm.ModelError, match=r"rates of \['lean.angle'\] are not independent speeds"):
        fm.linearize_steady(system, x0, xd0, ignorable=DISC_IGNORABLE, speeds=["lean"])
    with pytest.raises(fm.ModelError, match=r"coordinates \['heading.slide'\] are not independent"):
        fm.linearize_steady(system, x0, xd0, ignorable=DISC_IGNORABLE, coordinates=["heading.slide"])
    # leaning but not precessing: it falls, the state is not steady
    x1, xd1 = fm.initial_state(system, positions={"heading.slide": R_DISC, "lean": 0.2},
                               speeds={"heading.angle": 0.0, "lean": 0.0, "spin": 10.0}, fixed=["lean"])
    with pytest.raises(fm.ModelError, match=r"not a steady motion"):
        fm.linearize_steady(system, x1, xd1, ignorable=DISC_IGNORABLE)


def test_a_position_row_tying_an_ignorable_coordinate_is_refused():
    model = disc_model().add(fm.GearPair("gear", "spin", "lean", ratio=2.0))
    system = model.build()
    x0, xd0 = fm.initial_state(system, positions={"heading.slide": R_DISC})
    with pytest.raises(fm.ModelError, match=r"position row ties the ignorable \['spin.angle'\] to \['lean.angle'\]"):
        fm.linearize_steady(system, x0, xd0, ignorable=DISC_IGNORABLE)
