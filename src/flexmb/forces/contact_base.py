"""The base class of the contact elements: their rows in the load tables, their states, tangents and energy.

A contact element lays out one or more rows of the load tables
(:mod:`flexmb.forces.tables`; a sphere on a plane one, a capsule on a plane
two, a group of shapes one per pair): each row is a pair of surfaces that
push apart where they overlap, evaluated by the compiled kernels
(:mod:`flexmb.kernels.contact_geometry`, :mod:`flexmb.kernels.contact`).
:mod:`flexmb.forces.contact` has the overview and the laws.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from attrs import frozen

from ..errors import ModelError
from ..fields import label
from ..kernels import contact as _k
from ..kernels.loads import contact_states
from .base import ForceElement
from .tables import LoadTables, class_tables

__all__ = ["Contact", "compiled_tables", "merge_rows", "radius_check", "ZERO"]

#: an unused point of a row
ZERO = np.zeros(3)

def radius_check(instance, attribute, value):
    """Validator of a radius: a finite number >= 0.

    Parameters
    ----------
    instance : Contact
        The element.
    attribute : attrs.Attribute
        Its field.
    value : object
        The value given.

    Raises
    ------
    ModelError
        Naming the element and the field, if the value is not a finite number >= 0.
    """
    if not isinstance(value, float) or not np.isfinite(value) or value < 0:
        raise ModelError(f"{label(instance)}: {attribute.name} must be a finite number >= 0, got {value!r}")


@frozen(eq=False)
class Contact(ForceElement):
    """Base class of the compiled contact elements (spheres, capsules, journals, groups of shapes).

    A subclass gives its rows of the load tables (:meth:`layout`: pairs of
    surfaces of the compiled geometries), a ``normal_law`` and a
    ``friction`` field (:func:`~flexmb.forces.law_tables.normal_law_field`,
    :func:`~flexmb.forces.law_tables.friction_field`) and names
    ``load_tables = compiled_tables`` to be compiled; the laws, the loads,
    the powers, the implicit Jacobian's tangents and the elastic energy are
    shared, and so are the histories of a result
    (:func:`flexmb.post.contact_history`). A plugin's geometry does the
    same (docs/plugins.md).

    Parameters
    ----------
    name : str
        Unique name.
    """

    geometry: ClassVar[int] = -1

    def layout(self, topology) -> list:
        """This contact's rows of the load tables (a subclass's geometry; once per model).

        Parameters
        ----------
        topology : Topology
            The model's tree: :meth:`locate` gives a body's row and a point
            in that row's frame.

        Returns
        -------
        list of tuple
            One ``(rows, points, radii, geometry)`` per pair of touching
            surfaces: the two body rows, four points (or directions) in
            their frames (shape (4, 3)), the two radii and the geometry's
            code, as :mod:`flexmb.kernels.contact_geometry` lays them out
            (a sphere on a plane: ``(centre, plane point, plane normal, 0)``
            and ``(r, 0)``).
        """
        raise NotImplementedError

    def _rows(self, topology):
        """:meth:`layout`, once per model (kept in the topology's cache)."""
        key = ("contact layout", id(self))
        if key not in topology.cache:
            topology.cache[key] = self.layout(topology)
        return topology.cache[key]

    @staticmethod
    def _body(topology, body):
        """The body of the model a name names (the element held by the caller keeps names), or ``body``."""
        if isinstance(body, str):
            return next((b for b in [*topology.flexible, *topology.index] if getattr(b, "name", None) == body),
                        body)
        return body

    @staticmethod
    def locate(topology, body, point) -> tuple[int, np.ndarray]:
        """The body row carrying a point and the point in that row's frame (a flexible body's segment).

        Parameters
        ----------
        topology : Topology
            The model's tree.
        body : Body or str
            A body of the model, or its name.
        point : array_like, shape (3,)
            The point in the body's frame, m.

        Returns
        -------
        row : int
            Body row (-1: the ground).
        local : ndarray, shape (3,)
            The point in that row's frame.
        """
        return topology.locate(Contact._body(topology, body), point)

    def _sides(self):
        """The two bodies in contact, the sphere's first."""
        raise NotImplementedError

    def check(self, model) -> list[str]:
        """Refuse a contact of a body with itself or of the ground with the ground.

        Parameters
        ----------
        model : Model
            The model the element belongs to.

        Returns
        -------
        list of str
            One message per problem, naming the element.
        """
        a, b = self._sides()
        if a is b or (isinstance(a, str) and a == getattr(b, "name", b)):
            return [f"{label(self)}: both sides are on the body {getattr(a, 'name', a)!r}"]
        return []

    def blocks(self, topology) -> list:
        """Blocks of this contact's rows that the broad phase evaluates (:mod:`flexmb.kernels.broadphase`).

        Parameters
        ----------
        topology : Topology
            The model's tree.

        Returns
        -------
        list of tuple
            One ``(shapes1, shapes2, pairs)`` per block: two lists of
            shapes ``(body row, ends in its frame (2, 3), radius)`` and the
            row (among this contact's, :meth:`layout`) of each pair, shape
            (n1, n2), -1 for none; empty (the default): every row is
            evaluated at every evaluation.
        """
        return []

    @classmethod
    def _tables(cls, elements, topology) -> LoadTables:
        """The contacts' rows: bodies, points, radii, law codes and parameters (``load_tables``); their blocks."""
        rows, local, geom, laws, par = [], [], [], [], []
        blocks = _Blocks()
        for e in elements:
            friction = [0.0] * _k.N_FRICTION if e.friction is None else e.friction.row()
            blocks.add(e.blocks(topology), len(rows))
            for (i, j), pts, radii, kind in e._rows(topology):
                # bodies have mass > 0 (their constructors say so); the ground's is infinite
                m_eff = 1.0 / sum(1.0 / float(topology.mass[k]) for k in (i, j) if k >= 0)
                rows.append((i, j))
                local.append(pts)
                geom.append(radii)
                laws.append((kind, e.normal_law.code, 0 if e.friction is None else e.friction.code))
                par.append(e.normal_law.row(m_eff) + friction)
        return LoadTables.of(contact_rows=np.reshape(rows, (-1, 2)), contact_local=np.reshape(local, (-1, 4, 3)),
                             contact_geom=np.reshape(geom, (-1, 2)), contact_laws=np.reshape(laws, (-1, 3)),
                             contact_par=np.reshape(par, (-1, _k.N_NORMAL + _k.N_FRICTION)),
                             **blocks.fields(len(rows)))

    @classmethod
    def _owners(cls, elements, topology) -> np.ndarray:
        """The element (index into ``elements``) of each row of the tables, kept in the topology's cache."""
        key = ("contact owners", cls, tuple(id(e) for e in elements))
        if key not in topology.cache:
            topology.cache[key] = np.repeat(np.arange(len(elements)),
                                            [len(e._rows(topology)) for e in elements]).astype(np.int64)
        return topology.cache[key]

    @classmethod
    def row_states(cls, elements, state, held=None):
        """What each row of the elements' tables does at a kinematic state (one row per touching pair).

        Parameters
        ----------
        elements : sequence of Contact
            Elements of this class in the model.
        state : Kinematics
            The kinematic state.
        held : ndarray, shape (c,), optional
            The impact speeds the rows of a restitution law hold, m/s (0:
            none; :mod:`flexmb.impact_speeds`); default: what they hold now
            (in a run, since their onsets; none outside one).

        Returns
        -------
        tuple of ndarray
            delta, rate, normal force, elastic energy (shape (c,)), point,
            normal, force, slip (shape (c, 3)), as
            :func:`~flexmb.kernels.loads.contact_states` returns them, c
            the number of rows (a capsule on a plane has two: its ends; a
            :class:`~flexmb.forces.contact_groups.ContactGroup` one per pair).
        """
        t = class_tables(cls, elements, state.topology)
        par = t.contact_par
        if held is not None:
            par = par.copy()
            restitution = t.contact_laws[:, 1] == _k.RESTITUTION
            par[restitution, 4] = np.broadcast_to(np.asarray(held, dtype=float), len(par))[restitution]
        return contact_states(t.contact_rows, t.contact_local, t.contact_geom, t.contact_laws, par,
                              state.R, state.origin, state.r, state.omega, state.v)

    @classmethod
    def states_all(cls, elements, state, held=None):
        """What each element does at a kinematic state, its rows merged (:meth:`row_states`).

        An element of several rows reports: its deepest row's penetration,
        rate, normal and slip; its rows' normal forces, forces and energies
        summed; the point where the normal forces' resultant acts (their
        weighted mean; the deepest row's point while none pushes).

        Parameters
        ----------
        elements : sequence of Contact
            Elements of this class in the model.
        state : Kinematics
            The kinematic state.
        held : ndarray, shape (c,), optional
            The impact speeds the rows hold (:meth:`row_states`).

        Returns
        -------
        tuple of ndarray
            delta, rate, normal force, elastic energy (shape (e,)), point,
            normal, force, slip (shape (e, 3)), e the number of elements.
        """
        rows = cls.row_states(elements, state, held)
        owner = cls._owners(elements, state.topology)
        if len(owner) == len(elements):
            return rows
        return merge_rows(owner, len(elements), *rows)

    @classmethod
    def pair_tangent_all(cls, elements, state):
        """Stiffness and damping of the touching contacts, on the relative motion of their two bodies' points.

        With F the force on the first body (the sphere's, the pin's) as a
        function of the penetration (``d delta = -n . d(p1 - p2)``) and of
        the relative velocity u at the contact point: ``K = F_delta n n^T -
        k_N F_delta t n^T`` and ``D = F_rate n n^T + k P + 2 k' t t^T -
        k_N F_rate t n^T``, with ``F_delta``, ``F_rate`` the normal law's
        derivatives, ``k`` the friction factor (force ``-k t``), ``k'`` its
        derivative in the squared slip ``|t|^2``, ``k_N`` in the normal
        force, ``t`` the slip and ``P = I - n n^T``; the laws' derivatives
        by central differences of their compiled functions. The turning of
        the normal is left out. Without these the implicit integrators'
        Newton iterations would not see a stiff contact or a regularised
        friction at rest (a block sticking on a belt took 600 times the
        steps).

        Parameters
        ----------
        elements : sequence of Contact
            Elements of this class in the model.
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        tuple of (rows, points, K, D)
            The second body's row first (the force is on the second end of
            each pair), both ends at the contact point; zeros for contacts
            that do not touch.
        """
        t = class_tables(cls, elements, state.topology)
        delta, rate, fn, _, point, normal, _, slip = cls.row_states(elements, state)
        m = len(delta)
        rows = np.ascontiguousarray(t.contact_rows[:, ::-1])
        points = np.repeat(point[:, None, :], 2, axis=1)
        K, D = np.zeros((m, 3, 3)), np.zeros((m, 3, 3))
        for a in range(m):
            if fn[a] <= 0.0:
                continue
            law, friction = t.contact_laws[a, 1], t.contact_laws[a, 2]
            par = t.contact_par[a]
            n, u_t = normal[a], slip[a]
            hd, hr = 1e-6 * delta[a], 1e-6 * max(abs(rate[a]), 1e-6)
            f_delta = (_k.normal_force(law, par[:5], delta[a] + hd, rate[a])
                       - _k.normal_force(law, par[:5], delta[a] - hd, rate[a])) / (2 * hd)
            f_rate = (_k.normal_force(law, par[:5], delta[a], rate[a] + hr)
                      - _k.normal_force(law, par[:5], delta[a], rate[a] - hr)) / (2 * hr)
            nn = np.outer(n, n)
            K[a], D[a] = f_delta * nn, f_rate * nn
            if friction == _k.NO_FRICTION:
                continue
            s2 = float(u_t @ u_t)
            k = _k.friction_factor(friction, par[5:], fn[a], s2)
            k_n = _k.friction_factor(friction, par[5:], fn[a] + 1.0, s2) - k  # the factors are affine in the load
            h2 = 1e-6 * s2
            k_s2 = 0.0 if h2 == 0.0 else (_k.friction_factor(friction, par[5:], fn[a], s2 + h2)
                                          - _k.friction_factor(friction, par[5:], fn[a], s2 - h2)) / (2 * h2)
            tn = np.outer(u_t, n)
            K[a] -= k_n * f_delta * tn
            D[a] += k * (np.eye(3) - nn) + 2.0 * k_s2 * np.outer(u_t, u_t) - k_n * f_rate * tn
        return rows, points, K, D

    def apply(self, state, loads) -> None:
        """Add this contact's forces (compiled, with the rest of its class).

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.
        loads : Loads
            Accumulator to add to.
        """
        type(self).apply_all([self], state, loads)

    @classmethod
    def potential_all(cls, elements, state) -> float:
        """Elastic energy stored in the penetrations, ``K delta^(n+1) / (n + 1)`` summed, J.

        Parameters
        ----------
        elements : sequence of Contact
            The model's elements of this class.
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        float
            J.
        """
        return float(np.sum(cls.states_all(elements, state)[3]))

    def potential(self, state) -> float:
        """Elastic energy of this contact's penetration, J.

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        float
            J (0 while separated).
        """
        return type(self).potential_all([self], state)


class _Blocks:
    """The blocks of a class's contacts, laid out as the fields of the load tables (``contact_blocks``, ...)."""

    def __init__(self):
        self.blocks, self.rows, self.local, self.radius, self.map = [], [], [], [], []

    def add(self, blocks, first_row):
        """Add an element's blocks (:meth:`Contact.blocks`), its rows starting at ``first_row``."""
        for shapes1, shapes2, pairs in blocks:
            pairs = np.asarray(pairs, dtype=np.int64)
            self.blocks.append((len(self.rows), len(shapes1), len(shapes2), sum(len(m) for m in self.map)))
            for row, ends, radius in [*shapes1, *shapes2]:
                self.rows.append(row)
                self.local.append(np.asarray(ends, dtype=float))
                self.radius.append(radius)
            self.map.append(np.where(pairs >= 0, pairs + first_row, -1).ravel())

    def fields(self, n_rows) -> dict:
        """The fields: the blocks, their shapes and pairs' rows, and the rows outside every block."""
        pairs = np.concatenate(self.map) if self.map else np.zeros(0, dtype=np.int64)
        inside = np.zeros(n_rows, dtype=bool)
        inside[pairs[pairs >= 0]] = True
        return {"contact_always": np.flatnonzero(~inside), "contact_blocks": np.reshape(self.blocks, (-1, 4)),
                "sweep_rows": np.asarray(self.rows, dtype=np.int64),
                "sweep_local": np.reshape(self.local, (-1, 2, 3)), "sweep_radius": np.asarray(self.radius, dtype=float),
                "contact_block_map": pairs}


def _compiled_tables(cls, elements, topology) -> LoadTables:
    """The contacts' bodies, geometry, law codes and parameters (compiled, :mod:`flexmb.forces.tables`).

    Parameters
    ----------
    elements : sequence of Contact
        The model's elements of one class.
    topology : Topology
        The model's tree.

    Returns
    -------
    LoadTables
        Their ``contact_*`` rows.
    """
    return cls._tables(elements, topology)


#: the ``load_tables`` of each compiled contact class (a class has a compiled form if it names one itself,
#: :func:`flexmb.forces.tables.class_tables`: a user's subclass written in Python is not taken for compiled)
compiled_tables = classmethod(_compiled_tables)


def merge_rows(owner, n, delta, rate, fn, energy, point, normal, force, slip):
    """Merge the rows of each element into one (:meth:`Contact.states_all` says how).

    Parameters
    ----------
    owner : ndarray of int, shape (c,)
        The element of each row.
    n : int
        Number of elements.
    delta, rate, fn, energy, point, normal, force, slip : ndarray
        The rows' states (:meth:`Contact.row_states`).

    Returns
    -------
    tuple of ndarray
        The same, one row per element.
    """
    out_delta = np.full(n, -np.inf)
    deepest = np.zeros(n, dtype=np.int64)
    for row, e in enumerate(owner):
        if delta[row] > out_delta[e]:
            out_delta[e], deepest[e] = delta[row], row
    total = np.bincount(owner, fn, minlength=n)
    summed = [np.stack([np.bincount(owner, a[:, x], minlength=n) for x in range(3)], axis=1)
              for a in (fn[:, None] * point, force)]
    pushing = total > 0
    centre = point[deepest].copy()
    centre[pushing] = summed[0][pushing] / total[pushing, None]
    return (out_delta, rate[deepest], total, np.bincount(owner, energy, minlength=n), centre, normal[deepest],
            summed[1], slip[deepest])
