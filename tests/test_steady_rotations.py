"""Linearisation about steady spins of joints in Euler parameters (:func:`flexmb.linearize_steady`, #29).

The rotation is perturbed by a small rotation vector in the child's axes; the
closed forms are the free rigid body's spin about a principal axis (the
intermediate one unstable at ``sqrt((I1 - I2)(I2 - I3) / (I1 I3)) omega``)
and the sleeping top (stable above ``I3 Omega = 2 sqrt(I1 m g l)``).
"""

from __future__ import annotations

import numpy as np
import pytest

import flexmb as fm

INERTIA = (1.0, 2.0, 3.0)
TOP_INERTIA, TOP_COM, G = (0.02, 0.02, 0.01), 0.1, 9.81


def _free_body(rotation="quaternion"):
    model = fm.Model("free body")
    body = fm.RigidBody("body", 1.0, INERTIA)
    return model.add(fm.Spherical("ball", model.ground, body, rotation=rotation)).build()


def _top(rotation="quaternion"):
    model = fm.Model("top")
    top = fm.RigidBody("top", 1.0, TOP_INERTIA, com=(0.0, 0.0, TOP_COM))
    return model.add(fm.Spherical("pivot", model.ground, top, rotation=rotation), fm.Gravity((0.0, 0.0, -G))).build()


def _sorted(values):
    values = np.asarray(values, dtype=complex)
    return values[np.lexsort((np.round(values.imag, 9), np.round(values.real, 9)))]


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_free_body_spinning_about_a_principal_axis(axis):
    system = _free_body()
    omega = 2.0
    w0 = np.zeros(3)
    w0[axis] = omega
    lin = fm.linearize_steady(system, system.layout.reference(), w0)
    spin = "ball.w" + "xyz"[axis]
    others = [f"ball.w{c}" for i, c in enumerate("xyz") if i != axis]
    assert lin.ignorable == [spin] and lin.coordinates == others and lin.speeds == ["ball.wx", "ball.wy", "ball.wz"]
    assert lin.states == [f"{c} angle" for c in others] + ["ball.wx", "ball.wy", "ball.wz"]
    i, j, k = axis, (axis + 1) % 3, (axis + 2) % 3
    Ii, Ij, Ik = INERTIA[i], INERTIA[j], INERTIA[k]
    # Euler's equations about the spin: lambda^2 = (Ii - Ij)(Ik - Ii) / (Ij Ik) omega^2; the small rotations turn
    # with the body (+-i omega), the spin speed is neutral (0)
    lam2 = (Ii - Ij) * (Ik - Ii) / (Ij * Ik) * omega**2
    lam = np.sqrt(complex(lam2))
    expected = [lam, -lam, 1j * omega, -1j * omega, 0.0]
    np.testing.assert_allclose(_sorted(lin.eigenvalues()), _sorted(expected), atol=1e-8)
    if axis == 1:  # the intermediate axis: growth at sqrt((I1 - I2)(I2 - I3) / (I1 I3)) omega
        I1, I2, I3 = INERTIA
        growth = np.sqrt((I1 - I2) * (I2 - I3) / (I1 * I3)) * omega
        assert lin.eigenvalues().real.max() == pytest.approx(growth, rel=1e-9)
    else:
        assert np.max(np.abs(lin.eigenvalues().real)) < 1e-9


@pytest.mark.parametrize("ratio", [0.5, 0.9, 1.1, 2.0])
def test_sleeping_top_stability_limit(ratio):
    system = _top()
    I1, I3, mgl = TOP_INERTIA[0] + TOP_COM**2, TOP_INERTIA[2], G * TOP_COM
    critical = 2.0 * np.sqrt(I1 * mgl) / I3
    spin = ratio * critical
    lin = fm.linearize_steady(system, system.layout.reference(), np.array([0.0, 0.0, spin]))
    assert lin.ignorable == ["pivot.wz"]
    # the tilt in inertial axes: I1 xi'' - i I3 Omega xi' - m g l xi = 0 (xi = tilt about x + i tilt about y);
    # in the axes that spin with the top, every root less i Omega, and their conjugates
    roots = [(1j * I3 * spin + s * np.sqrt(complex(4 * I1 * mgl - (I3 * spin) ** 2))) / (2 * I1) for s in (1, -1)]
    body = [r - 1j * spin for r in roots]
    expected = body + [np.conj(r) for r in body] + [0.0]
    np.testing.assert_allclose(_sorted(lin.eigenvalues()), _sorted(expected), atol=1e-7)
    growth = lin.eigenvalues().real.max()
    if ratio < 1:
        assert growth == pytest.approx(np.sqrt(4 * I1 * mgl - (I3 * spin) ** 2) / (2 * I1), rel=1e-8)
    else:
        assert abs(growth) < 1e-8


def test_upright_top_at_rest_as_with_bryant_angles():
    # no spin: the Euler-parameter and Bryant-angle joints linearise alike, lambda = +-sqrt(m g l / I1) twice
    lin_q = fm.linearize_steady(_top(), _top().layout.reference(), np.zeros(3))
    lin_b = fm.linearize_steady(_top("bryant"), np.zeros(3), np.zeros(3))
    np.testing.assert_allclose(_sorted(lin_q.eigenvalues()), _sorted(lin_b.eigenvalues()), atol=1e-9)
    rate = np.sqrt(G * TOP_COM / (TOP_INERTIA[0] + TOP_COM**2))
    np.testing.assert_allclose(_sorted(lin_q.eigenvalues()), _sorted([rate, rate, -rate, -rate, 0.0, 0.0]),
                               atol=1e-9)


def test_refusals_name_the_rotation():
    system = _top()
    x0, w0 = system.layout.reference(), np.array([0.0, 0.0, 50.0])
    with pytest.raises(fm.ModelError, match=r"'pivot.wx'.*named ignorable"):
        fm.linearize_steady(system, x0, w0, ignorable=["pivot"])
    with pytest.raises(fm.ModelError, match=r"\['pivot.wz'\] move"):
        fm.linearize_steady(system, x0, w0, ignorable=[])
    tilted = system.layout.displace(x0, np.array([0.3, 0.0, 0.0]))
    with pytest.raises(fm.ModelError, match="not a steady motion"):
        fm.linearize_steady(system, tilted, w0)
