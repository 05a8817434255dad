"""The loops' state Jacobian on 3-vectors (flexmb.kernels.planar_loop_jacobian) against the spatial one.

Each planar model is built twice (planar, the default, and
``planar=False``, :func:`test_planar_loops.pair`);
:func:`flexmb.kernels.loop_jacobian.loop_state_jacobian` (the dispatch
CVODE's ``jac`` calls) must give the same J to round-off relative to its
largest entry, at the assembled state and at random states on the
constraints: B6 damped (N = 8, 32), B7 (N = 4, 40) and the planar
four-bar. Its P (``J[n:, n:] = -P`` with no springs and unit dampers) is
the derivative of the accelerations by a generalized force, by central
differences of the planar right-hand side.
"""

from __future__ import annotations

import numpy as np

from flexmb.kernels.loop_jacobian import loop_state_jacobian
from flexmb.kernels.loops import loop_rhs
from flexmb.kernels.packing import unpack_planar
from flexmb.kernels.planar_loop_jacobian import planar_loop_state_jacobian
from flexmb.system.tangent import NewtonPreconditioner
from test_planar_loops import AGREE, _consistent_states, _rhs, pair  # noqa: F401 (the fixture)


def _jacobian(system, t, x, xd, K, C, direct=False):
    n = system.n_speeds
    J = np.full((2 * n, 2 * n), np.nan)
    gamma_d = np.array([d.acceleration(t) for d in system.constraints.drivers], dtype=float)
    rank_limit = -1 if system._rank_limit is None else system._rank_limit
    args = (system._loop_layout, np.concatenate([x, xd]), n, K, C, gamma_d, system._loop_tol,
            system.singular_window(), rank_limit, J)
    if direct:
        ints, floats = unpack_planar(system._packed)
        status, body = planar_loop_state_jacobian(ints, floats, system.topology.arrays.coord_body, *args)
    else:
        status, body = loop_state_jacobian(system._packed, *args)
    assert (status, body) == (0, -1)
    return J


def test_planar_jacobian_equals_spatial(pair):
    """J with the model's diagonal springs and dampers, relative to its largest entry, at four states."""
    name, planar, spatial, x0, xd0 = pair
    tol = AGREE.get(name, 1e-12)
    K, C = NewtonPreconditioner.diagonal_terms(spatial)
    for t, x, xd in [(0.0, x0, xd0), *_consistent_states(spatial, x0, xd0)]:
        a, b = _jacobian(planar, t, x, xd, K, C), _jacobian(spatial, t, x, xd, K, C)
        assert np.all(np.isfinite(a)) and np.max(abs(b[planar.n_speeds:])) > 0
        assert np.max(abs(a - b)) <= tol * np.max(abs(b))


def test_its_P_is_the_accelerations_derivative_by_a_force(pair):
    """``-J[n:, n:]`` with K = 0, C = 1 against central differences of loop_rhs in ``generalized0``."""
    name, planar, spatial, x0, xd0 = pair
    n = planar.n_speeds
    t, x, xd = _consistent_states(spatial, x0, xd0, k=1)[0]
    P = -_jacobian(planar, t, x, xd, np.zeros(n), np.ones(n))[n:, n:]
    zeros = np.zeros((planar.topology.n_bodies + 1, 3))
    gamma_d = np.array([d.acceleration(t) for d in planar.constraints.drivers], dtype=float)
    rank_limit = -1 if planar._rank_limit is None else planar._rank_limit
    scale = np.max(abs(P))
    xdd = _rhs(planar, t, x, xd)[0]
    h = 1e-6 * max(1.0, np.max(abs(xdd))) / scale  # (linear in the force: no truncation; round-off of xdd / h)
    for j in range(0, n, max(1, n // 8)):
        f = np.zeros(n)
        out = []
        for s in (h, -h):
            f[j] = s
            out.append(loop_rhs(planar._packed, planar._loop_layout, np.concatenate([x, xd]), n, np.zeros(0), zeros,
                                zeros, f, gamma_d, planar._loop_tol, planar.singular_window(), rank_limit)[0])
        fd = (out[0] - out[1]) / (2 * h)
        assert np.max(abs(fd - P[:, j])) <= 1e-7 * scale


def test_the_dispatch_takes_the_planar_path(pair):
    """loop_state_jacobian on a planar model is planar_loop_state_jacobian's to the bit."""
    name, planar, spatial, x0, xd0 = pair
    K, C = NewtonPreconditioner.diagonal_terms(spatial)
    t, x, xd = _consistent_states(spatial, x0, xd0, k=1)[0]
    np.testing.assert_array_equal(_jacobian(planar, t, x, xd, K, C), _jacobian(planar, t, x, xd, K, C, direct=True))
