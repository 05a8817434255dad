"""Stacked kinematics of all bodies: rotations, positions, V and W (eqs. 6-18).

Everything is computed for all bodies at once. Sums along the path from
the ground are products with the 0/1 ancestor matrix; the chained rotations
use pointer jumping (log2(depth) batched matrix products), so there is no
Python loop over bodies.

Notation (per tree joint j joining body k to its parent P):

* ``R_M = R_P F_p``: the parent marker frame in inertial axes;
* ``o'_k``: the joint point on the child side (inertial);
* ``s_k = o'_k - o'_P``: vector from the parent's joint point to this one.

For a coordinate c of joint j, its inertial partial angular velocity is
``G_w[:, c] = R_M h_w[:, c]`` and the partial velocity of a point P of any
body downstream of j is ``G_v[:, c] + G_w[:, c] x (r_P - o'_j)`` (eqs. 7,
17).
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from .rotations import cross, skew

__all__ = ["Kinematics"]

_EYE = np.eye(3)


class Kinematics:
    """Positions, velocities, partial velocities and bias accelerations.

    Parameters
    ----------
    topology : Topology
        The model's tree.
    t : float
        Time, s.
    x, xd : ndarray, shape (n_coords,)
        Generalized coordinates and speeds.

    Attributes
    ----------
    R : ndarray, shape (n_bodies + 1, 3, 3)
        Body rotations (body -> inertial); last row the ground.
    r : ndarray, shape (n_bodies + 1, 3)
        Mass-centre positions, m.
    origin : ndarray, shape (n_bodies + 1, 3)
        Body-frame origins, m.
    omega, v : ndarray, shape (n_bodies + 1, 3)
        Angular velocities (rad/s) and mass-centre velocities (m/s).
    alpha_bias, a_bias : ndarray, shape (n_bodies + 1, 3)
        Angular and mass-centre accelerations at zero ``xdd``
        (``Wdot xd`` and ``Vdot xd`` of eq. 3).
    W, V : ndarray, shape (n_bodies + 1, 3, n_coords)
        Partial angular velocities and partial velocities of the mass
        centres (eqs. 7, 17); formed on first access only (the assembler
        works from the per-coordinate ``Sw``, ``Sv``).
    Sw, Sv : ndarray, shape (n_coords, 3)
        Each coordinate's motion in Plucker form about the inertial origin:
        a point p of any body downstream of the coordinate has the partial
        velocity ``Sv + Sw x p`` and partial angular velocity ``Sw``.
    """

    def __init__(self, topology, t: float, x: np.ndarray, xd: np.ndarray):
        topo = topology
        self.topology = topo
        self.t = float(t)
        self.x = x
        self.xd = xd
        nb, n = topo.n_bodies, topo.n_coords
        self.mass = topo.mass
        self._inertia_world = None
        parent = topo.parent

        # joint motions, batched per joint class
        Rj = np.empty((nb, 3, 3))
        d = np.empty((nb, 3))
        aw = np.empty((nb, 3))
        av = np.empty((nb, 3))
        hw = np.zeros((3, n))
        hv = np.zeros((3, n))
        for i, (cls, ks, cols) in enumerate(topo.groups):
            if cols.shape[1]:
                R_, d_, Hw, Hv, aw_, av_ = cls.motion(x[cols], xd[cols])
            else:  # no coordinates: a constant motion, evaluated once per model
                key = ("constant motion", i)
                if key not in topo.cache:
                    topo.cache[key] = cls.motion(x[cols], xd[cols])
                R_, d_, Hw, Hv, aw_, av_ = topo.cache[key]
            Rj[ks], d[ks], aw[ks], av[ks] = R_, d_, aw_, av_
            if cols.shape[1]:
                hw[:, cols] = Hw.transpose(1, 0, 2)
                hv[:, cols] = Hv.transpose(1, 0, 2)

        # global rotations by pointer jumping: R_k = R_P F_p Rj F_c^T
        R = np.empty((nb + 1, 3, 3))
        R[:nb] = topo.parent_frame @ Rj @ topo.child_frame.transpose(0, 2, 1)
        R[nb] = _EYE
        for ptr in topo.jump_pointers:
            R[:nb] = R[ptr] @ R[:nb]
        self.R = R

        RP = R[parent]
        RM = RP @ topo.parent_frame
        s = np.einsum("kij,kj->ki", RP, topo.parent_point - topo.parent_joint_point)
        s += np.einsum("kij,kj->ki", RM, d)
        anc = topo.ancestors
        jp = anc @ s
        origin = np.zeros((nb + 1, 3))
        origin[:nb] = jp - np.einsum("kij,kj->ki", R[:nb], topo.child_point)
        r = origin.copy()
        r[:nb] += np.einsum("kij,kj->ki", R[:nb], topo.com)
        self.origin, self.r, self.joint_point = origin, r, jp

        # partial velocities (eqs. 7, 17), kept per coordinate: the column c of
        # V_k is G_v + G_w x (r_k - o'_j) for every body k downstream of c's
        # joint. In Plucker form about the inertial origin, a coordinate's
        # motion is S_c = (G_w, G_v - G_w x o'_j) and any body point p moves
        # with S_v + S_w x p, so V and W never need to be stored whole.
        cb = topo.coord_body
        Gw = np.einsum("cij,jc->ci", RM[cb], hw)  # (n, 3)
        Gv = np.einsum("cij,jc->ci", RM[cb], hv)
        self.Gw, self.Gv = Gw, Gv
        self.Sw, self.Sv = Gw, Gv - cross(Gw, jp[cb])
        ca = topo.coord_ancestors  # (nb, n)

        omega = np.zeros((nb + 1, 3))
        v = np.zeros((nb + 1, 3))
        omega[:nb] = ca @ (self.Sw * xd[:, None])
        v[:nb] = ca @ (self.Sv * xd[:, None]) + cross(omega[:nb], r[:nb])
        self.omega, self.v = omega, v

        # velocity-dependent accelerations (eqs. 13, 18 at xdd = 0)
        wP = omega[parent]
        w_rel = omega[:nb] - wP
        v_rel = topo.coord_incidence @ (Gv * xd[:, None])
        beta = cross(wP, w_rel) + np.einsum("kij,kj->ki", RM, aw)
        alpha = np.zeros((nb + 1, 3))
        alpha[:nb] = anc @ beta
        aP = alpha[parent]
        gamma = (cross(aP, s) + cross(wP, cross(wP, s) + 2.0 * v_rel)
                 + np.einsum("kij,kj->ki", RM, av))
        a_jp = anc @ gamma
        u = r[:nb] - jp
        acc = np.zeros((nb + 1, 3))
        acc[:nb] = a_jp + cross(alpha[:nb], u) + cross(omega[:nb], cross(omega[:nb], u))
        self.alpha_bias, self.a_bias = alpha, acc

    @cached_property
    def W(self) -> np.ndarray:
        """Partial angular velocities of all bodies (eq. 7), shape (n_bodies + 1, 3, n_coords)."""
        nb = self.topology.n_bodies
        W = np.zeros((nb + 1, 3, self.x.shape[0]))
        W[:nb] = self.angular_partials(np.arange(nb))
        return W

    @cached_property
    def V(self) -> np.ndarray:
        """Partial velocities of all mass centres (eq. 17), shape (n_bodies + 1, 3, n_coords)."""
        nb = self.topology.n_bodies
        V = np.zeros((nb + 1, 3, self.x.shape[0]))
        V[:nb] = self.point_partials(np.arange(nb), self.r[:nb])
        return V

    # -- lookups used by force elements and constraints
    def index(self, body) -> int:
        """Row of ``body`` in the per-body arrays.

        Parameters
        ----------
        body : Body
            A body of the model or the ground (a flexible body gives the row
            of its first segment).

        Returns
        -------
        int
            Row index (-1 for the ground).
        """
        return self.topology.index[body]

    def locate(self, body, point) -> tuple[int, np.ndarray]:
        """Row and local point of a point on a (rigid or flexible) body.

        See :meth:`flexmb.topology.Topology.locate`.

        Parameters
        ----------
        body : Body
            A body of the model (rigid, flexible or the ground).
        point : array_like, shape (3,)
            Point in the body's frame, m.

        Returns
        -------
        index : int
            Row in the per-body arrays (-1: ground).
        local : ndarray, shape (3,)
            The point in that row's body frame, m.
        """
        return self.topology.locate(body, point)

    def coordinate_slice(self, joint) -> slice:
        """Slice of ``x`` holding a tree joint's coordinates.

        Parameters
        ----------
        joint : Joint
            A tree (not cut) joint of the model.

        Returns
        -------
        slice
            Its coordinates' positions in ``x``.
        """
        return self.topology.coordinate_slice(joint)

    def inertia_world(self) -> np.ndarray:
        """Central inertia tensors in inertial axes (computed once per state).

        Returns
        -------
        ndarray, shape (n_bodies, 3, 3)
            ``R_k I_k R_k^T``, kg m^2.
        """
        if self._inertia_world is None:
            R = self.R[:-1]
            self._inertia_world = R @ self.topology.inertia @ R.transpose(0, 2, 1)
        return self._inertia_world

    def point_position(self, k, local) -> np.ndarray:
        """Inertial position of body-fixed points.

        Parameters
        ----------
        k : int or ndarray of int
            Body index (or indices, shape (m,)).
        local : array_like, shape (3,) or (m, 3)
            Points in the body frame, m.

        Returns
        -------
        ndarray, shape (3,) or (m, 3)
            Inertial positions, m.
        """
        return np.einsum("...ij,...j->...i", self.R[k], local) + self.origin[k]

    def point_velocity(self, k, p) -> np.ndarray:
        """Velocity of the body-k point at inertial position ``p``.

        Parameters
        ----------
        k : int or ndarray of int, shape (m,)
            Body index (or indices).
        p : ndarray, shape (3,) or (m, 3)
            Inertial positions of the points, m.

        Returns
        -------
        ndarray, shape (3,) or (m, 3)
            ``v_k + omega_k x (p - r_k)``, m/s.
        """
        return self.v[k] + cross(self.omega[k], p - self.r[k])

    def point_bias_acceleration(self, k, p) -> np.ndarray:
        """Acceleration at ``xdd = 0`` of the body-k point at inertial ``p``.

        Parameters
        ----------
        k : int or ndarray of int, shape (m,)
            Body index (or indices).
        p : ndarray, shape (3,) or (m, 3)
            Inertial positions of the points, m.

        Returns
        -------
        ndarray, shape (3,) or (m, 3)
            ``a_bias + alpha_bias x l + omega x (omega x l)`` with
            ``l = p - r_k``, m/s^2: the velocity-dependent part of the
            point's acceleration.
        """
        lever = p - self.r[k]
        w = self.omega[k]
        return self.a_bias[k] + cross(self.alpha_bias[k], lever) + cross(w, cross(w, lever))

    def point_partials(self, k, p) -> np.ndarray:
        """Partial velocities of body points, shape (m, 3, n_coords).

        Parameters
        ----------
        k : ndarray of int, shape (m,)
            Body indices (-1, the ground, gives zeros).
        p : ndarray, shape (m, 3)
            Inertial positions of the points.

        Returns
        -------
        ndarray, shape (m, 3, n_coords)
            ``V_P = V_k + W_k x (p - r_k)`` column by column (eq. 17),
            formed as ``Sv + Sw x p`` over the coordinates upstream of k.
        """
        k = np.atleast_1d(k)
        p = np.reshape(p, (-1, 3))
        cols = self.Sv[None] + cross(self.Sw[None], p[:, None, :])  # (m, n, 3)
        return (self._upstream(k)[:, :, None] * cols).transpose(0, 2, 1)

    def angular_partials(self, k) -> np.ndarray:
        """Partial angular velocities ``W_k`` of bodies (eq. 7), shape (m, 3, n_coords).

        Parameters
        ----------
        k : ndarray of int, shape (m,)
            Body indices (-1, the ground, gives zeros).

        Returns
        -------
        ndarray, shape (m, 3, n_coords)
            Column c is the coordinate's axis ``Sw[c]`` if c moves body k.
        """
        k = np.atleast_1d(k)
        return (self._upstream(k)[:, :, None] * self.Sw[None]).transpose(0, 2, 1)

    def _upstream(self, k) -> np.ndarray:
        """0/1 rows: which coordinates move each body in ``k`` (none for the ground)."""
        ca = self.topology.coord_ancestors
        return np.where((k >= 0)[:, None], ca[k], 0.0)

    def spatial_inertia(self) -> np.ndarray:
        """Spatial inertia of each body about the inertial origin, shape (n_bodies, 6, 6).

        Blocks ``[[I_c + m [r]^T [r], m [r]], [-m [r], m E]]`` act on the
        Plucker velocity ``(omega, v_O)``, so that the kinetic energy of
        body k is ``(omega, v_O) . I_O (omega, v_O) / 2`` and the
        inertias of a subtree add.

        Returns
        -------
        ndarray, shape (n_bodies, 6, 6)
            ``I_O`` of each body, SI units.
        """
        nb = self.topology.n_bodies
        m, r = self.mass, self.r[:nb]
        rx = skew(r)
        out = np.empty((nb, 6, 6))
        out[:, :3, :3] = self.inertia_world() - m[:, None, None] * (rx @ rx)
        out[:, :3, 3:] = m[:, None, None] * rx
        out[:, 3:, :3] = -out[:, :3, 3:]
        out[:, 3:, 3:] = m[:, None, None] * np.eye(3)
        return out

    def kinetic_energy(self) -> float:
        """Kinetic energy of all bodies.

        Returns
        -------
        float
            ``sum m v^2 / 2 + omega . I omega / 2``, J.
        """
        w = self.omega[:-1]
        Iw = np.einsum("kij,kj->ki", self.inertia_world(), w)
        return float(0.5 * np.sum(self.mass * np.sum(self.v[:-1] ** 2, axis=1)) + 0.5 * np.sum(w * Iw))
