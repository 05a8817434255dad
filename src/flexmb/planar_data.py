"""Whether a built model moves in one plane, and its planar data for :mod:`flexmb.kernels.planar`.

A model takes the planar evaluation path (docs/theory.md, "A planar path")
when, at the zero configuration, one normal n exists such that every
rotation coordinate's inertial axis is +-n and every translation's is
normal to n, with at most one coordinate per body, no Euler parameters, no
joints with their own motion (``external``), loads the planar kernels have
(gravity, coordinate springs and dampers) and cut rows that are in-plane
direction rows (:class:`flexmb.PlanarRevolute` cuts) or driver rows. The
test is on the joints' axes, not on a state: with every coordinate planar,
every state is. Everything else is refused (the spatial path stays correct
for every model): :func:`planar_data` gives the reason.
"""

from __future__ import annotations

import numpy as np

from .kernels.planar import NONE, PRISMATIC, REVOLUTE

__all__ = ["planar_data", "planar_choice", "TOL"]

#: how far from +-n a rotation axis (and from the plane a translation axis or a row direction) may be
TOL = 1e-12


def _basis(axes):
    """The plane's normal n (the first revolute axis) and an in-plane basis ``(e1, e2)``, ``e1 x e2 = n``."""
    n = axes[0] / np.linalg.norm(axes[0])
    e1 = np.cross(n, np.eye(3)[int(np.argmin(abs(n)))])
    e1 /= np.linalg.norm(e1)
    return n, e1, np.cross(n, e1)


def _refused_tree(tree):
    """Why the tree's joints cannot be planar, before any geometry ('' if they may be)."""
    if np.any(tree.external):
        return "a joint with its own motion (plugin joint)"
    if np.any(tree.coord_kind > 1):
        return "Euler parameters (a spherical or free joint)"
    if np.any(np.diff(tree.coord_start) > 1):
        return "a joint with several coordinates (spherical, universal, planar or free)"
    if not np.any(tree.coord_kind == 1):
        return "no revolute coordinate"
    return ""


def _refused_loads(tables):
    """Why the compiled loads cannot be planar ('' if they may be)."""
    names = {"pair_rows": "springs between points", "force_rows": "point forces", "torque_rows": "torques",
             "contact_rows": "contact", "sweep_rows": "contact"}
    for field, what in names.items():
        if np.asarray(getattr(tables, field)).shape[0]:
            return f"{what} (the planar loads are gravity and coordinate springs and dampers)"
    return ""


def planar_data(tree, tables, cuts, drivers):
    """The planar data of a model whose motion lies in one plane, or the reason why it does not.

    Parameters
    ----------
    tree : TreeArrays
        The tree's layout and body data (:attr:`flexmb.topology.Topology.arrays`).
    tables : LoadTables
        The compiled force elements' tables.
    cuts : tuple of ndarray
        The cut joints' rows (:attr:`flexmb.constraints.Constraints.cut_arrays`).
    drivers : ndarray of int
        The driver rows' coordinates.

    Returns
    -------
    data : tuple or None
        ``(ints, floats)`` (:mod:`flexmb.kernels.planar`), None if the model
        is not planar.
    reason : str
        Why not ('' if planar).
    """
    from .kernels.tree import tree_state

    reason = _refused_tree(tree) or _refused_loads(tables)
    pt_i, _, _, _, dr_i, dr_pi, dr_ai, dr_j, dr_pj, pp_i, _, _, _ = cuts
    if not reason and (pt_i.shape[0] or pp_i.shape[0]):
        reason = "cut rows on points or perpendicular directions (only in-plane direction rows are planar)"
    if reason:
        return None, reason
    nb, n = tree.parent.shape[0], tree.coord_start[-1]
    R0 = tree_state(tree, np.zeros(n), np.zeros(n))[0]  # body rotations at the zero configuration, ground last
    parent = np.where(tree.parent < 0, nb, tree.parent)
    axes = [R0[parent[tree.coord_body[c]]] @ tree.parent_frame[tree.coord_body[c]][:, tree.coord_axis[c]]
            for c in range(n)]
    nrm, e1, e2 = _basis([a for a, kind in zip(axes, tree.coord_kind) if kind == 1])
    P2 = np.array([e1, e2])
    kind, coord, axis = np.full(nb, NONE), np.full(nb, -1), np.zeros((nb, 2))
    for c in range(n):
        k = tree.coord_body[c]
        kind[k], coord[k] = (PRISMATIC, REVOLUTE)[tree.coord_kind[c]], c
        if tree.coord_kind[c] == 1:
            if abs(abs(axes[c] @ nrm) - 1.0) > TOL:
                return None, f"coordinate {c} turns about an axis off the plane's normal"
            axis[k, 0] = np.sign(axes[c] @ nrm)
        else:
            if abs(axes[c] @ nrm) > TOL:
                return None, f"coordinate {c} slides off the plane"
            axis[k] = P2 @ axes[c]
    lever = np.array([P2 @ (R0[parent[k]] @ tree.lever[k]) for k in range(nb)]).reshape(nb, 2)
    u = np.array([P2 @ (R0[k] @ (tree.com[k] - tree.child_point[k])) for k in range(nb)]).reshape(nb, 2)
    J = np.array([nrm @ R0[k] @ tree.inertia[k] @ R0[k].T @ nrm for k in range(nb)], dtype=float)
    nc = dr_i.shape[0]
    ri, rj = np.where(dr_i < 0, nb, dr_i), np.where(dr_j < 0, nb, dr_j)
    cp = np.vstack([tree.child_point, np.zeros((1, 3))])
    wi = np.array([P2 @ (R0[ri[q]] @ (dr_pi[q] - cp[ri[q]])) for q in range(nc)]).reshape(nc, 2)
    wj = np.array([P2 @ (R0[rj[q]] @ (dr_pj[q] - cp[rj[q]])) for q in range(nc)]).reshape(nc, 2)
    d0 = np.array([R0[ri[q]] @ dr_ai[q] for q in range(nc)]).reshape(nc, 3)
    if nc and np.max(abs(d0 @ nrm)) > TOL:
        return None, "a cut's direction row off the plane"
    i64 = lambda a: np.ascontiguousarray(a, dtype=np.int64)  # noqa: E731
    f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    ints = tuple(i64(a) for a in (parent, coord, kind, tables.coord_cols, ri, rj, drivers))
    floats = tuple(f64(a) for a in (axis, lever, u, tree.mass, J, P2 @ np.asarray(tables.gravity, float),
                                    tables.coord_k, tables.coord_c, tables.coord_rest, wi, wj, d0 @ P2.T))
    return (ints, floats), ""


def planar_choice(system, tables, wanted):
    """Decide whether a system being built takes the planar path; set ``system.planar`` and ``planar_reason``.

    Parameters
    ----------
    system : flexmb.System
        The system, built up to its force tables.
    tables : sequence of ndarray
        Its compiled force elements' tables (merged), the fields of
        :class:`~flexmb.kernels.loads.LoadTables`.
    wanted : bool or None
        :class:`~flexmb.System`'s ``planar``: None (where planar), False
        (never) or True (where planar, else refused).

    Returns
    -------
    tuple or None
        The planar data to pack, None if the spatial path evaluates.

    Raises
    ------
    ModelError
        If ``wanted`` is True and the model is not planar, or ``wanted``
        is not a bool or None.
    """
    from .errors import ModelError

    if wanted not in (None, True, False):
        raise ModelError(f"planar must be True, False or None, got {wanted!r}")
    data, reason = None, "planar=False"
    if wanted is not False:
        reason = _refused_system(system)
        if not reason:
            from .kernels.loads import LoadTables

            data, reason = planar_data(system.topology.arrays, LoadTables(*tables), system.constraints.cut_arrays,
                                       system.constraints.driver_cols)
    if wanted and data is None:
        raise ModelError(f"planar=True: model {system.model.name!r} is not planar: {reason}")
    system.planar, system.planar_reason = data is not None, reason
    return data


def _refused_system(system):
    """Why a system cannot be planar for what its arrays do not show ('' if it may be)."""
    if system.topology.external_groups:
        return "a joint with its own motion (plugin joint)"
    if system._python_groups:
        return "force elements evaluated in Python"
    if system.constraints.elements:
        return "constraint elements (rows written in Python)"
    return ""
