"""Kane's equations from the tree: spatial inertias, mass matrix and force array (eqs. 1-5).

In Plucker form about the inertial origin, the spatial inertias of the
bodies a coordinate moves add up to a composite inertia ``IC`` (one pass
from the leaves in), and ``A[c, d] = S_c . IC S_d`` for the deeper of the
two coordinates' bodies (zero for coordinates on different branches): the
composite-rigid-body form of eq. 2, O(n depth) for the dense A. The
generalized forces (eq. 5) are the axes' projections of the subtree
wrenches, O(n).
"""

from __future__ import annotations

import numpy as np
from .cache import njit

__all__ = ["spatial_inertias", "spatial_inertias_into", "composite_inertias", "subtree_sums", "axis_projections",
           "mass_matrix", "generalized_force", "bias_wrenches", "bias_wrenches_into"]


@njit(cache=True)
def spatial_inertias(R, r, mass, inertia):
    """Central inertias in inertial axes and spatial inertias about the origin.

    Parameters
    ----------
    R : ndarray, shape (n_bodies + 1, 3, 3)
        Body rotations (the last row, the ground, is not used).
    r : ndarray, shape (n_bodies + 1, 3)
        Mass centres.
    mass : ndarray, shape (n_bodies,)
        Masses.
    inertia : ndarray, shape (n_bodies, 3, 3)
        Central inertia tensors in the body frames.

    Returns
    -------
    inertia_world : ndarray, shape (n_bodies, 3, 3)
        ``R_k I_k R_k^T``.
    spatial : ndarray, shape (n_bodies, 6, 6)
        ``[[I_c + m [r]^T [r], m [r]], [-m [r], m E]]`` acting on the
        Plucker velocity ``(omega, v_O)``.
    """
    nb = mass.shape[0]
    Iw = np.empty((nb, 3, 3))
    out = np.empty((nb, 6, 6))
    spatial_inertias_into(R, r, mass, inertia, Iw, out)
    return Iw, out


@njit(cache=True)
def spatial_inertias_into(R, r, mass, inertia, Iw, out):
    """:func:`spatial_inertias` into given arrays ``Iw`` (n_bodies, 3, 3) and ``out`` (n_bodies, 6, 6).

    Parameters
    ----------
    R, r, mass, inertia : ndarray
        As :func:`spatial_inertias`.
    Iw, out : ndarray
        Outputs: what :func:`spatial_inertias` returns (every entry written).
    """
    nb = mass.shape[0]
    for k in range(nb):
        Rk = R[k]
        for i in range(3):  # RI = R_k I_k, row i; Iw = RI R_k^T
            ri0 = Rk[i, 0] * inertia[k, 0, 0] + Rk[i, 1] * inertia[k, 1, 0] + Rk[i, 2] * inertia[k, 2, 0]
            ri1 = Rk[i, 0] * inertia[k, 0, 1] + Rk[i, 1] * inertia[k, 1, 1] + Rk[i, 2] * inertia[k, 2, 1]
            ri2 = Rk[i, 0] * inertia[k, 0, 2] + Rk[i, 1] * inertia[k, 1, 2] + Rk[i, 2] * inertia[k, 2, 2]
            for j in range(3):
                Iw[k, i, j] = ri0 * Rk[j, 0] + ri1 * Rk[j, 1] + ri2 * Rk[j, 2]
        m = mass[k]
        x, y, z = r[k, 0], r[k, 1], r[k, 2]
        # m [r]^T [r] = m (|r|^2 E - r r^T)
        rr = x * x + y * y + z * z
        rv = (x, y, z)
        for i in range(3):
            for j in range(3):
                out[k, i, j] = Iw[k, i, j] + m * ((rr if i == j else 0.0) - rv[i] * rv[j])
        # m [r] (skew), and its negative below
        out[k, 0, 3] = out[k, 1, 4] = out[k, 2, 5] = 0.0
        out[k, 0, 4] = -m * z
        out[k, 0, 5] = m * y
        out[k, 1, 3] = m * z
        out[k, 1, 5] = -m * x
        out[k, 2, 3] = -m * y
        out[k, 2, 4] = m * x
        for i in range(3):
            for j in range(3):
                out[k, 3 + i, j] = -out[k, i, 3 + j]
                out[k, 3 + i, 3 + j] = 0.0
            out[k, 3 + i, 3 + i] = m


@njit(cache=True)
def composite_inertias(parent, spatial):
    """Spatial inertia of each body's subtree (itself and everything after it).

    Parameters
    ----------
    parent : ndarray of int, shape (n_bodies,)
        Parent body (-1: ground); parents come before children.
    spatial : ndarray, shape (n_bodies, 6, 6)
        Spatial inertias about the origin.

    Returns
    -------
    ndarray, shape (n_bodies, 6, 6)
        Subtree sums, one pass from the leaves in.
    """
    IC = spatial.copy()
    for k in range(parent.shape[0] - 1, -1, -1):
        p = parent[k]
        if p >= 0:
            for i in range(6):
                for j in range(6):
                    IC[p, i, j] += IC[k, i, j]
    return IC


@njit(cache=True)
def subtree_sums(parent, values):
    """Sum per-body rows over each body's subtree (the body and everything after it).

    Parameters
    ----------
    parent : ndarray of int, shape (n_bodies,)
        Parent body (-1: ground); parents come before children.
    values : ndarray, shape (n_bodies, m)
        One row per body.

    Returns
    -------
    ndarray, shape (n_bodies, m)
        ``out[k] = sum of values[b]`` over the bodies b whose path from the
        ground passes through k.
    """
    out = values.copy()
    for k in range(parent.shape[0] - 1, -1, -1):
        p = parent[k]
        if p >= 0:
            out[p] += out[k]
    return out


@njit(cache=True)
def mass_matrix(parent, coord_start, coord_body, IC, Sw, Sv):
    """Generalized mass matrix (eq. 2) by composite inertias.

    Parameters
    ----------
    parent : ndarray of int, shape (n_bodies,)
        Parent body (-1: ground).
    coord_start : ndarray of int, shape (n_bodies + 1,)
        Coordinate ranges of the tree joints.
    coord_body : ndarray of int, shape (n,)
        Body whose tree joint owns each coordinate.
    IC : ndarray, shape (n_bodies, 6, 6)
        Composite inertias (:func:`composite_inertias`).
    Sw, Sv : ndarray, shape (n, 3)
        Plucker axes of the coordinates.

    Returns
    -------
    ndarray, shape (n, n)
        ``A[c, d] = S_c . IC_{body(d)} S_d`` for c on d's path from the
        ground (its own joint included), mirrored; zero across branches.
    """
    n = Sw.shape[0]
    A = np.zeros((n, n))
    F = np.empty(6)
    for d in range(n):
        k = coord_body[d]
        for i in range(6):
            F[i] = (IC[k, i, 0] * Sw[d, 0] + IC[k, i, 1] * Sw[d, 1] + IC[k, i, 2] * Sw[d, 2]
                    + IC[k, i, 3] * Sv[d, 0] + IC[k, i, 4] * Sv[d, 1] + IC[k, i, 5] * Sv[d, 2])
        j = k
        while j >= 0:
            for c in range(coord_start[j], coord_start[j + 1]):
                val = (Sw[c, 0] * F[0] + Sw[c, 1] * F[1] + Sw[c, 2] * F[2]
                       + Sv[c, 0] * F[3] + Sv[c, 1] * F[4] + Sv[c, 2] * F[5])
                A[c, d] = val
                if j != k:
                    A[d, c] = val
            j = parent[j]
    return A


@njit(cache=True)
def generalized_force(parent, coord_body, r, force, torque, Sw, Sv):
    """Project forces and torques on the bodies onto the coordinates (eq. 5).

    Parameters
    ----------
    parent : ndarray of int, shape (n_bodies,)
        Parent body (-1: ground).
    coord_body : ndarray of int, shape (n,)
        Body whose tree joint owns each coordinate.
    r : ndarray, shape (>= n_bodies, 3)
        Mass centres.
    force, torque : ndarray, shape (>= n_bodies, 3)
        Force at each mass centre and torque on each body, inertial.
    Sw, Sv : ndarray, shape (n, 3)
        Plucker axes of the coordinates.

    Returns
    -------
    ndarray, shape (n,)
        ``sum_k V_k^T force_k + W_k^T torque_k``: each coordinate's axis
        against the resultant wrench, about the origin, of the bodies it
        moves.
    """
    nb = parent.shape[0]
    total = np.empty((nb, 6))
    for k in range(nb):
        f0, f1, f2 = force[k, 0], force[k, 1], force[k, 2]
        total[k, 0] = torque[k, 0] + r[k, 1] * f2 - r[k, 2] * f1
        total[k, 1] = torque[k, 1] + r[k, 2] * f0 - r[k, 0] * f2
        total[k, 2] = torque[k, 2] + r[k, 0] * f1 - r[k, 1] * f0
        total[k, 3], total[k, 4], total[k, 5] = f0, f1, f2
    return axis_projections(parent, coord_body, Sw, Sv, total)


@njit(cache=True)
def axis_projections(parent, coord_body, Sw, Sv, wrench):
    """Each coordinate's axis against the summed wrench of the bodies it moves (eqs. 2, 5).

    Parameters
    ----------
    parent : ndarray of int, shape (n_bodies,)
        Parent body (-1: ground); parents come before children.
    coord_body : ndarray of int, shape (n,)
        Body whose tree joint owns each coordinate.
    Sw, Sv : ndarray, shape (n, 3)
        Plucker axes of the coordinates.
    wrench : ndarray, shape (n_bodies, 6)
        Per-body wrenches (moment about the origin, force); summed over
        each subtree in place.

    Returns
    -------
    ndarray, shape (n,)
        ``S_c . sum of wrench over the subtree of c's body``.
    """
    for k in range(parent.shape[0] - 1, -1, -1):
        p = parent[k]
        if p >= 0:
            wrench[p] += wrench[k]
    n = Sw.shape[0]
    out = np.empty(n)
    for c in range(n):
        b = coord_body[c]
        out[c] = (Sw[c, 0] * wrench[b, 0] + Sw[c, 1] * wrench[b, 1] + Sw[c, 2] * wrench[b, 2]
                  + Sv[c, 0] * wrench[b, 3] + Sv[c, 1] * wrench[b, 4] + Sv[c, 2] * wrench[b, 5])
    return out


@njit(cache=True)
def bias_wrenches(mass, inertia_world, omega, alpha_bias, a_bias, force, torque):
    """Applied loads minus the velocity-dependent inertia forces (eq. 3 at ``xdd = 0``).

    Parameters
    ----------
    mass : ndarray, shape (n_bodies,)
        Masses.
    inertia_world : ndarray, shape (n_bodies, 3, 3)
        Central inertias in inertial axes.
    omega, alpha_bias, a_bias : ndarray, shape (>= n_bodies, 3)
        Angular velocities and bias accelerations.
    force, torque : ndarray, shape (>= n_bodies, 3)
        Applied forces at the mass centres and torques.

    Returns
    -------
    force, torque : ndarray, shape (n_bodies, 3)
        ``F - m a_bias`` and ``T - I alpha_bias - omega x I omega``.
    """
    nb = mass.shape[0]
    f = np.empty((nb, 3))
    t = np.empty((nb, 3))
    bias_wrenches_into(mass, inertia_world, omega, alpha_bias, a_bias, force, torque, f, t)
    return f, t


@njit(cache=True)
def bias_wrenches_into(mass, inertia_world, omega, alpha_bias, a_bias, force, torque, f, t):
    """:func:`bias_wrenches` into given arrays ``f`` and ``t`` (n_bodies, 3).

    Parameters
    ----------
    mass, inertia_world, omega, alpha_bias, a_bias, force, torque : ndarray
        As :func:`bias_wrenches`.
    f, t : ndarray
        Outputs: what :func:`bias_wrenches` returns.
    """
    nb = mass.shape[0]
    for k in range(nb):
        J = inertia_world[k]
        w0, w1, w2 = omega[k, 0], omega[k, 1], omega[k, 2]
        a0, a1, a2 = alpha_bias[k, 0], alpha_bias[k, 1], alpha_bias[k, 2]
        h0 = J[0, 0] * w0 + J[0, 1] * w1 + J[0, 2] * w2  # I omega
        h1 = J[1, 0] * w0 + J[1, 1] * w1 + J[1, 2] * w2
        h2 = J[2, 0] * w0 + J[2, 1] * w1 + J[2, 2] * w2
        for i in range(3):
            f[k, i] = force[k, i] - mass[k] * a_bias[k, i]
        t[k, 0] = torque[k, 0] - (J[0, 0] * a0 + J[0, 1] * a1 + J[0, 2] * a2) - (w1 * h2 - w2 * h1)
        t[k, 1] = torque[k, 1] - (J[1, 0] * a0 + J[1, 1] * a1 + J[1, 2] * a2) - (w2 * h0 - w0 * h2)
        t[k, 2] = torque[k, 2] - (J[2, 0] * a0 + J[2, 1] * a1 + J[2, 2] * a2) - (w0 * h1 - w1 * h0)

