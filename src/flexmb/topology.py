"""Spanning tree, cut joints, coordinate numbering and index arrays.

Built once per model; every evaluation reuses these arrays. Bodies are
numbered in breadth-first order from the ground, so a parent always comes
before its children; the ground is index -1 (the extra last row of every
per-body array).
"""

from __future__ import annotations

from collections import defaultdict, deque

import numpy as np

from . import kernels
from .errors import ModelError
from .flexible import SegmentJoint
from .joints import Joint
from .kernels.tree import TreeArrays

__all__ = ["Topology"]


class Topology:
    """The tree structure of a model.

    Parameters
    ----------
    model : Model
        The model.

    Attributes
    ----------
    bodies : list of Body
        Non-ground bodies, breadth-first from the ground.
    tree_joints : list of Joint
        ``tree_joints[k]`` joins body k to its parent.
    cut_joints : list of Joint
        Joints that close loops (they give constraint equations).
    parent : ndarray of int, shape (n_bodies,)
        Parent body index (-1: ground).
    coord_body : ndarray of int, shape (n_speeds,)
        Body whose tree joint owns each speed (and the coordinate at its
        index).
    n_coords, n_speeds : int
        Numbers of generalized coordinates q and speeds u
        (:mod:`flexmb.state_layout`; equal unless a joint has Euler
        parameters, one coordinate more than speeds per quaternion).
    speed_names : list of str
        ``"joint.speed"`` names (the coordinates' names where the speeds
        are their rates).
    coord_start : ndarray of int, shape (n_bodies + 1,)
        Body k's tree joint owns the speeds ``xd[coord_start[k]:coord_start[k + 1]]``
        and the coordinates at the same indices (its others: ``joint_extra``).
    joint_slice, joint_extra : dict
        Per tree joint: the slice of its speeds, and the indices in x of
        its coordinates beyond them (``qw``; empty for most joints).
    quaternions : tuple of two ndarray of int
        The Euler parameters' indices in x, shape (k, 4), and their angular
        speeds' in xd, shape (k, 3) (:class:`~flexmb.state_layout.StateLayout`).
    coord_kind, coord_axis : ndarray of int, shape (n_speeds,)
        Translation, rotation or Euler parameters (:mod:`flexmb.kernels`)
        and the joint-frame axis of each coordinate of a generic joint
        motion (for Euler parameters, the index in x of their ``qw``).
    coord_angle : ndarray of bool, shape (n_coords,)
        Whether each coordinate is an angle, a rotation about one of its
        joint's ``rotation_axes`` (joints with their own ``motion()``
        included): a coordinate that may wind up without bound
        (:class:`flexmb.stepping.Run` keeps its tolerance from loosening).
        Not the elastic angles of a flexible body's segment joints, which
        stay small (and would cost a check per step on every segment).
    external : ndarray of bool, shape (n_bodies,)
        Tree joints whose class computes its own ``motion()``.

    Notes
    -----
    Every array is O(n): the tree is walked through ``parent``, never
    through a dense ancestor matrix.
    coordinate_names : list of str
        ``"joint.coordinate"`` names.

    Raises
    ------
    ModelError
        If a body cannot be reached from the ground, or a joint that must be
        cut cannot give constraint equations.
    """

    def __init__(self, model):
        self.model = model
        self.cache: dict = {}
        all_joints = self._expand(model)
        tree, problems = self._spanning_tree(model, all_joints)
        self._cut_joints(model, all_joints, set(tree.values()), problems)
        self._number_bodies(model.ground, list(tree), tree)
        self._number_coordinates()
        self._joint_motions()
        self._body_data()

    def _place(self, body, point, as_child):
        """Where a joint point of a flexible body lands: its root (as a child) or the segment carrying it."""
        if body not in self.flexible:
            return body, point
        root, segs, _ = self.flexible[body]
        if as_child:
            return root, point
        i, local = body.locate(point)
        return segs[i], local

    def _expand(self, model) -> list:
        """Flexible bodies expanded into segments and elastic joints; the model's joints redirected to them."""
        from attrs import evolve

        from .flexible import FlexibleBody

        self.flexible = {}
        internal = []
        for b in model.bodies:
            if isinstance(b, FlexibleBody):
                root, segs, joints = b.expand()
                self.flexible[b] = (root, segs, joints)
                internal += joints
        self.joint_map = {}
        redirected = []
        for j in model.joints:
            parent, pp = self._place(j.parent, j.parent_point, False)
            child, cp = self._place(j.child, j.child_point, j.child in self.flexible and not j.cut)
            if parent is not j.parent or child is not j.child:
                j2 = evolve(j, parent=parent, child=child, parent_point=pp, child_point=cp)
            else:
                j2 = j
            self.joint_map[j] = j2
            redirected.append(j2)
        return redirected + internal

    def _spanning_tree(self, model, all_joints) -> tuple[dict, list[str]]:
        """The tree joint of each body reached from the ground (breadth first), in the order reached.

        Also returns the problems found: bodies the ground does not reach.
        """
        ground = model.ground
        named_cut = {self.joint_map[j] for j in model.joints if j.cut}
        children = defaultdict(list)
        for j in all_joints:
            if j not in named_cut:
                children[j.parent].append(j)
        tree: dict = {}
        seen = {ground}
        queue = deque([ground])
        while queue:
            b = queue.popleft()
            for j in children[b]:
                if j.child in seen:
                    continue
                seen.add(j.child)
                tree[j.child] = j
                queue.append(j.child)
        problems = []
        for b in model.bodies:
            carrier = self.flexible[b][0] if b in self.flexible else b
            if carrier not in seen:
                problems.append(
                    f"body {b.name!r} is not connected to the ground through tree joints "
                    "(joints run parent -> child from the ground)"
                )
        return tree, problems

    def _cut_joints(self, model, all_joints, tree_set, problems) -> None:
        """The joints that close loops; every problem of the structure (``problems`` and more) raised at once."""
        from attrs import evolve

        for j in model.joints:
            j2 = self.joint_map[j]
            if j.child in self.flexible and j2 in tree_set and np.any(j.child_point != 0):
                problems.append(
                    f"joint {j.name!r}: flexible body {j.child.name!r} must be attached to its parent at "
                    f"its root (child_point = 0), got {j.child_point.tolist()}"
                )
            if j2 not in tree_set and j.child in self.flexible and not j.cut:
                # closes a loop: attach at the segment carrying the point
                child, cp = self._place(j.child, j.child_point, False)
                j3 = evolve(j2, child=child, child_point=cp)
                self.joint_map[j] = j3
                all_joints[all_joints.index(j2)] = j3
        self.cut_joints = [j for j in all_joints if j not in tree_set]
        for j in self.cut_joints:
            rows = 3 * j.cut_point + len(j.cut_directions) + len(j.cut_perpendicular)
            if rows == 0:
                problems.append(f"joint {j.name!r} ({type(j).__name__}) closes a loop but imposes no constraint")
        for d in model.drivers:
            if d.joint in self.joint_map and self.joint_map[d.joint] not in tree_set:
                problems.append(f"driver {d.name!r}: joint {d.joint.name!r} is a cut joint and has no coordinates")
            elif getattr(d.joint, "quaternions", ()):
                problems.append(f"driver {d.name!r}: joint {d.joint.name!r} describes its rotation by Euler "
                                "parameters, whose rates are not its speeds; drive a joint with rotation='bryant'")
        if problems:
            raise ModelError("; ".join(problems), problems)

    def _number_bodies(self, ground, order, tree) -> None:
        """Body indices in tree order, parents and the tree's depth."""
        self.bodies = order
        self.tree_joints = [tree[b] for b in order]
        self.index = {b: k for k, b in enumerate(order)}
        self.index[ground] = -1
        for b, (root, _, _) in self.flexible.items():
            self.index[b] = self.index[root]
        nb = len(order)
        self.n_bodies = nb
        self.parent = np.array([self.index[j.parent] for j in self.tree_joints], dtype=int)
        depth = np.zeros(nb, dtype=np.int64)
        for k in range(nb):
            p = self.parent[k]
            depth[k] = 1 + (depth[p] if p >= 0 else 0)
        self.depth = int(depth.max()) if nb else 0

    def _number_coordinates(self) -> None:
        """Speeds contiguous per tree joint, in body order; a coordinate per speed at its index, the rest after.

        A joint's first ``n_speeds`` coordinates share their speeds'
        indices; its coordinates beyond (a quaternion's ``qw``) follow all
        of those, joint after joint (:mod:`flexmb.state_layout`).
        """
        self.joint_slice, self.joint_extra = {}, {}
        names, extra_names, coord_body, angle = [], [], [], []
        start = 0
        for k, j in enumerate(self.tree_joints):
            ns = j.n_speeds
            self.joint_slice[j] = slice(start, start + ns)
            names += [f"{j.name}.{c}" for c in j.coordinate_names[:ns]]
            extra_names += [f"{j.name}.{c}" for c in j.coordinate_names[ns:]]
            coord_body += [k] * ns
            # a flexible body's elastic angles stay small: only joint angles may wind (not Euler parameters)
            angle += ([False] * ns if j.quaternions else
                      [False] * len(j.translation_axes) + [not isinstance(j, SegmentJoint)] * len(j.rotation_axes))
            start += ns
        self.n_speeds = start
        for j in self.tree_joints:
            self.joint_extra[j] = np.arange(start, start + j.n_coords - j.n_speeds)
            start += j.n_coords - j.n_speeds
        self.n_coords = start
        self.coordinate_names = names + extra_names
        self.speed_names = [f"{j.name}.{c}" for j in self.tree_joints for c in j.speed_names]
        self.coord_body = np.array(coord_body, dtype=np.int64)
        self.coord_angle = np.zeros(self.n_coords, dtype=bool)
        self.coord_angle[: len(angle)] = angle
        self.coord_start = np.array([0] + [self.joint_slice[j].stop for j in self.tree_joints], dtype=np.int64)
        starts = np.zeros(self.n_speeds, dtype=np.int64)
        for sl in self.joint_slice.values():
            starts[sl] = sl.start
        self.coord_joint_start = starts
        self.quaternions = self._quaternion_indices()

    def joint_coordinates(self, joint) -> np.ndarray:
        """Indices in q of a tree joint's coordinates, in the joint's own order.

        Parameters
        ----------
        joint : Joint
            A tree joint (as the topology holds it).

        Returns
        -------
        ndarray of int, shape (joint.n_coords,)
            Its speeds' indices, then its coordinates beyond its speeds.
        """
        sl = self.joint_slice[joint]
        return np.concatenate([np.arange(sl.start, sl.stop), self.joint_extra[joint]]).astype(np.int64)

    def _quaternion_indices(self):
        """The Euler parameters' coordinate indices (k, 4) and their angular speeds' indices (k, 3)."""
        qs, us = [], []
        for j in self.tree_joints:
            if not j.quaternions:
                continue
            coords, speeds = self.joint_coordinates(j), self.joint_slice[j].start
            for qpos, upos in j.quaternions:
                qs.append(coords[list(qpos)])
                us.append([speeds + p for p in upos])
        return (np.array(qs, dtype=np.int64).reshape(-1, 4), np.array(us, dtype=np.int64).reshape(-1, 3))

    def _joint_motions(self) -> None:
        """Joint motions: the generic one is compiled; a class overriding motion() is called back.

        The generic motion is translations along fixed axes, rotations
        about moving axes, then a set of Euler parameters
        (:meth:`flexmb.Joint.generic_motion`); a class with its own
        ``motion()`` is called back, one batched call per class.
        """
        nb = self.n_bodies
        kind, axis = [], []
        self.external = np.zeros(nb, dtype=np.bool_)
        groups = defaultdict(list)
        for k, j in enumerate(self.tree_joints):
            if getattr(type(j).motion, "__func__", None) is not Joint.motion.__func__:
                self.external[k] = True
                groups[type(j)].append(k)
                kind += [kernels.EXTERNAL] * j.n_speeds
                axis += [0] * j.n_speeds
                continue
            kinds, axes = type(j).generic_motion()
            coords = self.joint_coordinates(j)
            kind += kinds
            axis += [int(coords[a]) if c == kernels.QUATERNION else a for c, a in zip(kinds, axes)]
        self.coord_kind = np.array(kind, dtype=np.int64)
        self.coord_axis = np.array(axis, dtype=np.int64)
        self.parent = self.parent.astype(np.int64)
        self.external_groups = []
        for cls, ks in groups.items():
            ks = np.array(ks, dtype=np.int64)
            joints = [self.tree_joints[k] for k in ks]
            qcols = np.array([self.joint_coordinates(j) for j in joints], dtype=np.int64).reshape(len(ks), -1)
            ucols = np.array([np.arange(self.joint_slice[j].start, self.joint_slice[j].stop) for j in joints],
                             dtype=np.int64).reshape(len(ks), -1)
            self.external_groups.append((cls, ks, qcols, ucols))

    def _body_data(self) -> None:
        """Per-body constant data and the flat arrays of the compiled kernels (:class:`TreeArrays`)."""
        order, nb = self.bodies, self.n_bodies
        self.mass = np.array([b.mass for b in order], dtype=float)
        self.inertia = np.array([b.inertia for b in order], dtype=float).reshape(nb, 3, 3)
        self.com = np.array([b.com for b in order], dtype=float).reshape(nb, 3)
        frames = [j.frames() for j in self.tree_joints]
        self.parent_frame = np.array([f[0] for f in frames]).reshape(nb, 3, 3)
        self.child_frame = np.array([f[1] for f in frames]).reshape(nb, 3, 3)
        self.parent_point = np.array([j.parent_point for j in self.tree_joints]).reshape(nb, 3)
        self.child_point = np.array([j.child_point for j in self.tree_joints]).reshape(nb, 3)
        # the parent's own joint point, in the parent body frame (ground: origin)
        cp_ext = np.vstack([self.child_point, np.zeros((1, 3))])
        self.parent_joint_point = cp_ext[self.parent]
        self.lever = np.ascontiguousarray(self.parent_point - self.parent_joint_point)
        self.arrays = TreeArrays(self.parent, self.coord_start, self.coord_kind, self.coord_axis, self.external,
                                 self.parent_frame, self.child_frame, self.lever, self.child_point, self.com,
                                 self.mass, self.inertia, self.coord_body)

    def coordinate_slice(self, joint) -> slice:
        """Slice of ``xd`` holding a tree joint's speeds, and of ``x`` its first ``n_speeds`` coordinates.

        All its coordinates unless it has Euler parameters (their ``qw``:
        :meth:`joint_coordinates`).

        Parameters
        ----------
        joint : Joint
            A tree joint of the model.

        Returns
        -------
        slice
            Its speeds (and those coordinates).

        Raises
        ------
        ModelError
            If the joint is a cut joint or not in the model.
        """
        try:
            return self.joint_slice[self.joint_map.get(joint, joint)]
        except KeyError:
            kind = ("a cut joint (it closes a loop)" if self.joint_map.get(joint, joint) in self.cut_joints
                    else "not in the model")
            raise ModelError(f"joint {joint.name!r} has no coordinates: it is {kind}") from None

    def locate(self, body, point) -> tuple[int, np.ndarray]:
        """Body row and local point for a point given on a (possibly flexible) body.

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
            The point in that row's body frame.
        """
        if body in self.flexible:
            i, local = body.locate(point)
            return self.index[self.flexible[body][1][i]], local
        try:
            return self.index[body], np.asarray(point, dtype=float)
        except KeyError:
            raise ModelError(f"body {getattr(body, 'name', body)!r} is not in the model") from None

    def elastic_columns(self, body) -> np.ndarray:
        """Coordinate indices of a flexible body's elastic coordinates, joint by joint.

        Parameters
        ----------
        body : FlexibleBody
            The body.

        Returns
        -------
        ndarray of int, shape (n_joints * len(keep),)
            Indices into x, ordered (joint, kept coordinate).
        """
        joints = self.flexible[body][2]
        return np.concatenate([np.arange(self.joint_slice[j].start, self.joint_slice[j].stop) for j in joints])
