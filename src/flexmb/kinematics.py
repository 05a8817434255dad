"""Kinematics of all bodies: rotations, positions, V and W (eqs. 6-18).

Evaluated by the compiled kernels of :mod:`flexmb.kernels.tree`: one pass
over the tree from the ground out, O(n). Joints whose class computes its
own ``motion()`` (plugins) are called back from here, one batched call per
class.

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

from .kernels import dynamics as _dyn
from .kernels import tree as _tree
from .rotations import cross

__all__ = ["Kinematics"]

# the external joint motions' arrays when a model has none (tree_kinematics reads no row of them)
_NO_EXTERNAL = (np.empty((0, 3, 3)), np.empty((0, 3)), np.empty((0, 3)), np.empty((0, 3)), np.empty((0, 3)),
                np.empty((0, 3)))


class Kinematics:
    """Positions, velocities, partial velocities and bias accelerations.

    Parameters
    ----------
    topology : Topology
        The model's tree.
    t : float
        Time, s.
    x : ndarray, shape (n_coords,)
        Generalized coordinates q.
    xd : ndarray, shape (n_speeds,)
        Generalized speeds u (the partial velocities below are per speed).

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
    W, V : ndarray, shape (n_bodies + 1, 3, n_speeds)
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
        nb, n = topo.n_bodies, topo.n_speeds
        self.mass = topo.mass
        self._inertias = None
        self._composite = None  # assembly.composite_inertias

        # joint motions: generic joints compiled (inside tree_kinematics), others by their
        # class, one batched call per class
        ext = _NO_EXTERNAL
        if topo.external_groups:
            ext = (np.empty((nb, 3, 3)), np.empty((nb, 3)), np.empty((n, 3)), np.empty((n, 3)), np.empty((nb, 3)),
                   np.empty((nb, 3)))
            Rj, d, hw, hv, aw, av = ext
            for i, (cls, ks, qcols, ucols) in enumerate(topo.external_groups):
                if qcols.shape[1]:
                    R_, d_, Hw, Hv, aw_, av_ = cls.motion(x[qcols], xd[ucols])
                else:  # no coordinates: a constant motion, evaluated once per model
                    key = ("constant motion", i)
                    if key not in topo.cache:
                        topo.cache[key] = cls.motion(x[qcols], xd[ucols])
                    R_, d_, Hw, Hv, aw_, av_ = topo.cache[key]
                Rj[ks], d[ks], aw[ks], av[ks] = R_, d_, aw_, av_
                if ucols.shape[1]:
                    hw[ucols] = Hw.transpose(0, 2, 1)
                    hv[ucols] = Hv.transpose(0, 2, 1)

        (self.R, self.origin, self.r, self.omega, self.v, self.alpha_bias, self.a_bias, self.joint_point,
         self.Sw, self.Sv) = _tree.tree_kinematics(
            topo.parent, topo.coord_start, topo.coord_kind, topo.coord_axis, topo.external, topo.parent_frame,
            topo.child_frame, topo.lever, topo.child_point, topo.com, x, xd, *ext)

    @cached_property
    def W(self) -> np.ndarray:
        """Partial angular velocities of all bodies (eq. 7), shape (n_bodies + 1, 3, n_speeds)."""
        nb = self.topology.n_bodies
        W = np.zeros((nb + 1, 3, self.xd.shape[0]))
        W[:nb] = self.angular_partials(np.arange(nb))
        return W

    @cached_property
    def V(self) -> np.ndarray:
        """Partial velocities of all mass centres (eq. 17), shape (n_bodies + 1, 3, n_speeds)."""
        nb = self.topology.n_bodies
        V = np.zeros((nb + 1, 3, self.xd.shape[0]))
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
        return self._spatial()[0]

    def _spatial(self):
        if self._inertias is None:
            self._inertias = _dyn.spatial_inertias(self.R, self.r, self.mass, self.topology.inertia)
        return self._inertias

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
        topo = self.topology
        return _tree.upstream_rows(np.asarray(k, dtype=np.int64), topo.parent, topo.coord_start, topo.n_speeds)

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
        return self._spatial()[1]

    def kinetic_energy(self) -> float:
        """Kinetic energy of all bodies.

        Returns
        -------
        float
            ``sum m v^2 / 2 + omega . I omega / 2``, J.
        """
        w = self.omega[:-1]
        Iw = np.einsum("kij,kj->ki", self.inertia_world(), w)
        add = np.add.reduce  # np.sum's own reduction, without its Python wrapper
        return float(0.5 * add(self.mass * add(self.v[:-1] ** 2, axis=1)) + 0.5 * add(w * Iw, axis=None))
