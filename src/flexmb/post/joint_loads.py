"""The force and moment every joint transmits (reaction recovery).

The loads every joint transmits (tree joints, cut joints, segment joints)
come from Newton-Euler on the subtree each tree joint carries, with the
constraint forces of the cut joints (the multipliers of
:meth:`System.reactions`) applied as body loads. Sign convention of
:mod:`flexmb.post`: the load the child exerts on the parent at the joint
point.
"""

from __future__ import annotations

import numpy as np

from ..errors import FlexmbError
from ..model import as_system
from ..rotations import cross
from ..kernels.dynamics import subtree_sums
from ..kinematics import Kinematics
from .fields import JointLoads

__all__ = ["joint_loads", "constraint_loads"]


def _cut_rows(system):
    """For the constraint blocks (points, directions, perpendiculars): the cut joint of each entry."""
    pts, drs, pps = [], [], []
    for c, j in enumerate(system.topology.cut_joints):
        if j.cut_point:
            pts.append(c)
        drs += [c] * len(j.cut_directions)
        pps += [c] * len(j.cut_perpendicular)
    return np.array(pts, dtype=int), np.array(drs, dtype=int), np.array(pps, dtype=int)


def constraint_loads(system, kin, lam):
    """Body forces and torques equivalent to the cut joints' constraint forces.

    ``psi^T lambda`` (eq. 29) written as loads on bodies: a point row pair
    pushes the parent with ``lambda`` at its point and the child with
    ``-lambda``; a direction row adds ``lambda d`` at the child's point,
    ``-lambda d`` and the torque ``lambda d x e`` on the parent; a
    perpendicularity row twists the parent by ``lambda a x b`` and the child
    by the opposite. Driver rows act on coordinates and are left out.

    Parameters
    ----------
    system : System
        The compiled model.
    kin : Kinematics
        The state.
    lam : ndarray, shape (m,)
        Constraint multipliers (:meth:`System.reactions`).

    Returns
    -------
    force, torque : ndarray, shape (n_bodies + 1, 3)
        Resultant force at each mass centre and torque about it (inertial;
        the last row is the ground).
    cut_force, cut_moment : ndarray, shape (n_cut, 3)
        Load each cut joint's child exerts on its parent, inertial, the
        moment about the parent's joint point.
    """
    from ..forces import Loads

    cons = system.constraints
    loads = Loads(kin)
    ncut = len(system.topology.cut_joints)
    cf, cm = np.zeros((ncut, 3)), np.zeros((ncut, 3))
    jp, jd, jq = _cut_rows(system)
    row = 0
    ri, pi, rj, pj = cons.pt
    if len(ri):
        lp = lam[row : row + 3 * len(ri)].reshape(-1, 3)
        row += 3 * len(ri)
        Pi, Pj = kin.point_position(ri, pi), kin.point_position(rj, pj)
        loads.add_point_force(ri, Pi, lp)
        loads.add_point_force(rj, Pj, -lp)
        np.add.at(cf, jp, lp)
    ri, pi, ai, rj, pj = cons.dr
    if len(ri):
        ld = lam[row : row + len(ri)]
        row += len(ri)
        Pi, Pj = kin.point_position(ri, pi), kin.point_position(rj, pj)
        d = np.einsum("mij,mj->mi", kin.R[ri], ai)
        tq = ld[:, None] * cross(d, Pj - Pi)
        loads.add_point_force(rj, Pj, ld[:, None] * d)
        loads.add_point_force(ri, Pi, -ld[:, None] * d)
        loads.add_torque(ri, tq)
        np.add.at(cf, jd, -ld[:, None] * d)
        np.add.at(cm, jd, tq)
    ri, ai, rj, bj = cons.pp
    if len(ri):
        lq = lam[row : row + len(ri)]
        a = np.einsum("mij,mj->mi", kin.R[ri], ai)
        b = np.einsum("mij,mj->mi", kin.R[rj], bj)
        tq = lq[:, None] * cross(a, b)
        loads.add_torque(ri, tq)
        loads.add_torque(rj, -tq)
        np.add.at(cm, jq, tq)
    return loads.force, loads.torque, cf, cm


def _loads_at(system, t, x, xd, xdd, lam):
    """Joint loads at one state (inertial), tree joints then cut joints."""
    kin = system.kinematics(t, x, xd)
    topo = system.topology
    applied = system.forces.loads(kin)
    cforce, ctorque, cut_f, cut_m = constraint_loads(system, kin, lam)
    F = (applied.force + cforce)[:-1]
    tau = (applied.torque + ctorque)[:-1]
    # V xdd and W xdd: the velocities are linear in the speeds (v = V xd, omega = W xd, eqs. 7, 17), so
    # one O(n) pass of the tree with xdd as the speeds gives them, the partial velocities never formed
    # (they are (n_bodies + 1) x 3 x n: quadratic in memory for a flexible body)
    at_xdd = Kinematics(topo, t, kin.x, np.ascontiguousarray(xdd, dtype=float))
    a = at_xdd.v[:-1] + kin.a_bias[:-1]
    alpha = at_xdd.omega[:-1] + kin.alpha_bias[:-1]
    I = kin.inertia_world()
    w = kin.omega[:-1]
    # Newton-Euler residual of each body: what its parent joint must supply
    D = kin.mass[:, None] * a - F
    H = np.einsum("kij,kj->ki", I, alpha) + cross(w, np.einsum("kij,kj->ki", I, w)) - tau
    r = kin.r[:-1]
    # what each subtree's bodies need, summed over the subtree
    f = subtree_sums(topo.parent, np.ascontiguousarray(D))
    m = subtree_sums(topo.parent, cross(r, D) + H) - cross(kin.joint_point, f)
    frames = kin.R[:-1] @ topo.child_frame
    # the child side exerts minus what the joint supplies to it
    force = -np.einsum("kji,kj->ki", frames, f)
    moment = -np.einsum("kji,kj->ki", frames, m)
    if topo.cut_joints:
        idx = topo.index
        rows = np.array([idx[j.child] for j in topo.cut_joints], dtype=int)
        fc = np.array([j.frames()[1] for j in topo.cut_joints]).reshape(-1, 3, 3)
        cfr = kin.R[rows] @ fc
        force = np.vstack([force, np.einsum("kji,kj->ki", cfr, cut_f)])
        moment = np.vstack([moment, np.einsum("kji,kj->ki", cfr, cut_m)])
    return force, moment


def joint_loads(result, system) -> JointLoads:
    """Force and moment transmitted by every joint, at every output time (reaction recovery).

    Parameters
    ----------
    result : Result
        A simulation result of ``system``.
    system : System or Model
        The model it came from.

    Returns
    -------
    JointLoads
        Per joint (tree joints in body order, then cut joints), the force
        and moment the child side exerts on the parent side at the joint,
        in the joint's child marker frame.

    Raises
    ------
    FlexmbError
        If the system does not match the result.

    Notes
    -----
    For the tree joint of body k, Newton-Euler on the subtree S_k it
    carries (eqs. 13, 18 for the accelerations ``a = V xdd + Vdot xd``,
    ``alpha = W xdd + Wdot xd``)::

        f_k = sum_{b in S_k} (m_b a_b - F_b)
        m_k = sum_{b in S_k} [(r_b - p_k) x (m_b a_b - F_b) + I_b alpha_b + w_b x I_b w_b - T_b]

    is what the joint supplies to the child; the tables hold ``-f_k``,
    ``-m_k``. F and T hold the applied loads and the cut joints'
    constraint forces (:func:`constraint_loads`). Generalized forces on
    coordinates (joint springs, segment springs, drivers) act inside a
    joint: inside the subtree they cancel, and on the joint itself they are
    part of what it transmits, so they need no term. For a segment joint
    the moment about a kept axis equals the spring plus damper moment of
    :func:`section_loads`. A cut joint's load is its constraint force on
    the parent, moment about the parent's joint point.
    """
    system = as_system(system)
    x = np.asarray(result.x, dtype=float)
    if x.shape[1] != system.n_coords or list(system.body_names) != list(result.body_names):
        raise FlexmbError("the system does not match the result: different bodies or number of coordinates")
    lam = np.asarray(result.reactions, dtype=float)
    if lam.shape != (len(result.t), system.n_constraints):
        raise FlexmbError(f"result.reactions has shape {lam.shape}, expected "
                          f"{(len(result.t), system.n_constraints)}")
    nt = len(result.t)
    nj = system.topology.n_bodies + len(system.topology.cut_joints)
    force = np.zeros((nt, nj, 3))
    moment = np.zeros((nt, nj, 3))
    for i in range(nt):  # one kinematics per output time; vectorised over bodies and joints
        force[i], moment[i] = _loads_at(system, result.t[i], x[i], result.xd[i], result.xdd[i], lam[i])
    names = [j.name for j in system.topology.tree_joints] + [j.name for j in system.topology.cut_joints]
    return JointLoads(np.asarray(result.t, dtype=float), names, force, moment)
