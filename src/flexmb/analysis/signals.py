"""Named inputs and outputs of a linearised model: loads on it and motions of it.

An :class:`Input` is a load on the model (a generalized force on a joint
coordinate, a force at a point of a body, an equal-and-opposite load across
a joint); an :class:`Output` is a motion of it (joint coordinates, speeds
and accelerations; positions, velocities and accelerations of body points;
section loads of flexible bodies). :func:`~flexmb.analysis.statespace.state_space`
turns them into the columns of B and the rows of C and D.
"""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from ..bodies import Body
from ..errors import ModelError
from ..fields import as_array, vector3
from ..flexible import FlexibleBody
from ..joints import Joint

__all__ = ["Input", "Output"]

#: finite-difference step for the speed-dependent parts of point velocities and accelerations
_H = 1e-6

_DERIVATIVES = {0: "", 1: "'", 2: "''"}


def _check_derivative(instance, attribute, value):
    if value not in (0, 1, 2):
        raise ModelError(f"{type(instance).__name__}: derivative must be 0, 1 or 2, got {value!r}")


def _check_kind(kinds):
    def check(instance, attribute, value):
        if value not in kinds:
            raise ModelError(f"{type(instance).__name__}: kind must be one of {list(kinds)}, got {value!r}")

    return check


def _element_name(e) -> str:
    return e if isinstance(e, str) else e.name


def _fmt(v) -> str:
    return "(" + ", ".join(f"{float(c):g}" for c in np.asarray(v, dtype=float)) + ")"


@frozen(eq=False)
class Input:
    """An input of a state-space model: a load on the model, per unit input.

    Build one with :meth:`joint`, :meth:`point_force` or
    :meth:`joint_load`; a string given
    to :func:`state_space` as an input is taken as :meth:`joint` (a joint's
    name, or a coordinate's name such as ``"hub.angle"``).

    Parameters
    ----------
    kind : {'joint', 'point', 'joint_torque', 'joint_force'}
        A generalized force on one joint coordinate, a force at a point
        of a body, or a torque or force across a joint (on its child, the
        reaction on its parent).
    element : Joint, Body or str
        The joint or body, or its name.
    coord : int or str
        Which coordinate of the joint (index or name, ``'joint'`` only).
    location : array_like, shape (3,)
        Point of application in the body frame, m (``'point'`` only).
    direction : array_like, shape (3,)
        Force (or torque) per unit input, inertial axes (not for
        ``'joint'``): the input is in N (N m) for a unit direction.
    name : str
        Label of the input (default from the element).

    Examples
    --------
    >>> import flexmb as fm
    >>> fm.Input.joint("hub").name
    'hub'
    >>> fm.Input.point_force("beam", (1.0, 0, 0), (0, 0, 1)).name
    'beam@(1, 0, 0).F(0, 0, 1)'
    """

    kind: str = field(validator=_check_kind(("joint", "point", "joint_force", "joint_torque")))
    element: object = field()
    coord: int | str = 0
    location: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)
    direction: np.ndarray = field(default=(0.0, 0.0, 1.0), converter=as_array, validator=vector3)
    name: str = ""

    @classmethod
    def joint_load(cls, joint, direction, torque: bool = True, name: str = "") -> "Input":
        """Equal and opposite loads across a joint: on its child, and the reaction on its parent.

        A torque (or a force at the joint point) along a fixed inertial
        direction, per unit input, on the child body, with its opposite on
        the parent: an actuator between the two bodies. Any joint works, a
        cut joint (closing a loop) or a :class:`~flexmb.Fixed` joint
        included; for a torque about a revolute's axis it equals
        :meth:`joint`.

        Parameters
        ----------
        joint : Joint or str
            The joint, or its name.
        direction : array_like, shape (3,)
            Torque (N m) or force (N) per unit input, inertial.
        torque : bool
            A torque (default) or a force at the joint point.
        name : str
            Label (default: joint, kind and direction).

        Returns
        -------
        Input
        """
        kind = "joint_torque" if torque else "joint_force"
        label = name or f"{_element_name(joint)}.{'T' if torque else 'F'}{_fmt(direction)}"
        return cls(kind, joint, 0, direction=direction, name=label)

    @classmethod
    def joint(cls, joint, coordinate: int | str = 0, name: str = "") -> "Input":
        """A generalized force (torque on an angle, N m; force on a slide, N) on a joint coordinate.

        Parameters
        ----------
        joint : Joint or str
            A tree joint, or its name, or a coordinate's name
            (``"hub.angle"``, as in ``System.coordinate_names``).
        coordinate : int or str
            Which coordinate of the joint.
        name : str
            Label (default: the joint's or coordinate's name).

        Returns
        -------
        Input
        """
        return cls("joint", joint, coordinate, name=name or _element_name(joint))

    @classmethod
    def point_force(cls, body, point, direction, name: str = "") -> "Input":
        """A force at a point of a body, along a fixed inertial direction, per unit input.

        Parameters
        ----------
        body : Body or str
            A rigid or flexible body, or its name.
        point : array_like, shape (3,)
            Point in the body frame, m (on a flexible body: its reference
            frame; the point moves with the segment it lies on).
        direction : array_like, shape (3,)
            Force per unit input, inertial, N.
        name : str
            Label (default: body, point and direction).

        Returns
        -------
        Input
        """
        label = name or f"{_element_name(body)}@{_fmt(point)}.F{_fmt(direction)}"
        return cls("point", body, 0, point, direction, name=label)


@frozen(eq=False)
class Output:
    """An output of a state-space model: a motion or a section load, as a deviation from the state linearised about.

    Build one with :meth:`coordinate`, :meth:`point` or
    :meth:`section_load`; a string given to :func:`state_space` as an
    output is taken as :meth:`coordinate`.

    Parameters
    ----------
    kind : {'coordinate', 'point', 'section'}
        A joint coordinate, a point's motion along a direction, or a section
        load of a flexible body.
    element : Joint, Body or str
        The joint or body, or its name.
    coord : int or str
        Which joint coordinate (``'coordinate'``).
    location : array_like, shape (3,)
        Point in the body frame, m (``'point'``).
    direction : array_like, shape (3,)
        Inertial direction the motion is projected on (``'point'``).
    derivative : {0, 1, 2}
        Position, velocity or acceleration (``'coordinate'``, ``'point'``).
    station : int
        Segment joint of the flexible body, counted from its root as in
        :func:`flexmb.post.sections.joint_stations` (``'section'``).
    component : {'N', 'Vy', 'Vz', 'Mx', 'My', 'Mz'}
        Section load component (``'section'``); the body must keep the
        matching elastic coordinate.
    name : str
        Label (default from the element).

    Examples
    --------
    >>> import flexmb as fm
    >>> fm.Output.coordinate("hub", derivative=1).name
    "hub'"
    >>> fm.Output.section_load("beam", 0, "My").name
    'beam.j0.My'
    """

    kind: str = field(validator=_check_kind(("coordinate", "point", "section")))
    element: object = field()
    coord: int | str = 0
    location: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)
    direction: np.ndarray = field(default=(0.0, 0.0, 1.0), converter=as_array, validator=vector3)
    derivative: int = field(default=0, validator=_check_derivative)
    station: int = 0
    component: str = "My"
    name: str = ""

    @classmethod
    def coordinate(cls, joint, coordinate: int | str = 0, derivative: int = 0, name: str = "") -> "Output":
        """A joint coordinate (rad or m), its speed or its acceleration.

        Parameters
        ----------
        joint : Joint or str
            A tree joint, or its name, or a coordinate's name.
        coordinate : int or str
            Which coordinate of the joint.
        derivative : {0, 1, 2}
            Coordinate, speed or acceleration.
        name : str
            Label (default: the name, with ``'`` per derivative).

        Returns
        -------
        Output
        """
        label = name or _element_name(joint) + _DERIVATIVES.get(derivative, "")
        return cls("coordinate", joint, coordinate, derivative=derivative, name=label)

    @classmethod
    def point(cls, body, point, direction, derivative: int = 0, name: str = "") -> "Output":
        """Displacement (m), velocity or acceleration of a body point along an inertial direction.

        Parameters
        ----------
        body : Body or str
            A rigid or flexible body, or its name.
        point : array_like, shape (3,)
            Point in the body frame, m.
        direction : array_like, shape (3,)
            Inertial direction (used as given: a unit vector gives the
            component).
        derivative : {0, 1, 2}
            Displacement, velocity or acceleration.
        name : str
            Label (default: body, point and direction).

        Returns
        -------
        Output
        """
        label = name or f"{_element_name(body)}@{_fmt(point)}.{_fmt(direction)}{_DERIVATIVES.get(derivative, '')}"
        return cls("point", body, 0, point, direction, derivative, name=label)

    @classmethod
    def section_load(cls, body, station: int = 0, component: str = "My", name: str = "") -> "Output":
        """A section load at a segment joint of a flexible body (N m for moments, N for forces).

        ``k eta + c etadot`` of the joint's spring and damper on the kept
        coordinate, as :func:`flexmb.post.sections.section_loads` reports it
        (same sign: the load of the outboard part on the inboard part).

        Parameters
        ----------
        body : FlexibleBody or str
            The body, or its name.
        station : int
            Segment joint, from the root (0: the clamp of a clamped body).
        component : {'N', 'Vy', 'Vz', 'Mx', 'My', 'Mz'}
            Which load.
        name : str
            Label (default ``"body.j<i>.<component>"``).

        Returns
        -------
        Output
        """
        return cls("section", body, station=station, component=component,
                   name=name or f"{_element_name(body)}.j{station}.{component}")


def _coordinate_column(system, element, coordinate, where) -> int:
    """Column of x of a joint coordinate given by joint (object or name) or coordinate name."""
    names = system.coordinate_names
    if isinstance(element, str) and element in names and "." in element:
        return names.index(element)
    joint = system.model.element(element, Joint) if isinstance(element, (str, Joint)) else None
    if joint is None:
        raise ModelError(f"{where}: expected a joint, its name or a coordinate name, got {element!r}")
    sl = system.coordinate_slice(joint)
    count = sl.stop - sl.start
    if isinstance(coordinate, str):
        full = f"{joint.name}.{coordinate}"
        if full not in names[sl]:
            raise ModelError(f"{where}: joint {joint.name!r} has no coordinate {coordinate!r}; "
                             f"it has {[c.split('.')[-1] for c in names[sl]]}")
        return names.index(full)
    if not 0 <= int(coordinate) < count:
        raise ModelError(f"{where}: joint {joint.name!r} has {count} coordinate(s), no coordinate {coordinate}")
    return sl.start + int(coordinate)


def _point(system, kin, body, point, where):
    """Row and inertial position of a body point."""
    body = system.model.element(body, Body)
    k, local = kin.locate(body, point)
    if k < 0:
        raise ModelError(f"{where}: {body.name!r} is the ground: nothing moves there")
    return k, kin.point_position(k, local)


def _as_input(spec) -> Input:
    if isinstance(spec, Input):
        return spec
    if isinstance(spec, (str, Joint)):
        return Input.joint(spec)
    raise ModelError(f"state_space: an input is an Input, a joint or a coordinate name, got {spec!r}")


def _as_output(spec) -> Output:
    if isinstance(spec, Output):
        return spec
    if isinstance(spec, (str, Joint)):
        return Output.coordinate(spec)
    raise ModelError(f"state_space: an output is an Output, a joint or a coordinate name, got {spec!r}")


def _input_force(system, kin, spec: Input) -> np.ndarray:
    """Generalized force per unit input, shape (n,) (eq. 5: ``V_P^T F`` for a point force)."""
    where = f"input {spec.name!r}"
    Q = np.zeros(system.n_speeds)
    if spec.kind == "joint":
        Q[_coordinate_column(system, spec.element, spec.coord, where)] = 1.0
    elif spec.kind == "point":
        k, p = _point(system, kin, spec.element, spec.location, where)
        Q = kin.point_partials(np.array([k]), p[None])[0].T @ spec.direction
    else:  # across a joint: on the child, the reaction on the parent (eq. 5 for each)
        joint = system.model.element(spec.element, Joint)
        kc, local = kin.locate(joint.child, joint.child_point)
        kp = kin.locate(joint.parent, joint.parent_point)[0]
        rows = np.array([kc, kp])
        if spec.kind == "joint_torque":
            W = kin.angular_partials(rows)
            Q = (W[0] - W[1]).T @ spec.direction
        else:
            p = kin.point_position(kc, local)
            V = kin.point_partials(rows, np.array([p, p]))
            Q = (V[0] - V[1]).T @ spec.direction
    return Q


def _section_column(system, spec: Output):
    """Column of x, spring and damper constants of a kept section load."""
    from ..post.fields import LOAD_COMPONENTS

    where = f"output {spec.name!r}"
    body = system.model.element(spec.element, FlexibleBody)
    if spec.component not in LOAD_COMPONENTS:
        raise ModelError(f"{where}: unknown component {spec.component!r}; pick one of {list(LOAD_COMPONENTS)}")
    coord = LOAD_COMPONENTS[spec.component][0]
    if coord not in body.keep:
        raise ModelError(f"{where}: {body.name!r} does not keep {coord!r}, so {spec.component} is a constraint "
                         f"reaction, not in the linear model; it keeps {list(body.keep)}")
    if not 0 <= spec.station < body.n_joints:
        raise ModelError(f"{where}: {body.name!r} has segment joints 0..{body.n_joints - 1}, no station "
                         f"{spec.station}")
    first = 0 if body.clamped else 1
    col = system.coordinate_names.index(f"{body.name}.j{first + spec.station}.{coord}")
    from ..flexible import segment_joint_class

    j = list(segment_joint_class(body.keep).coordinate_names).index(coord)
    k = float(body.joint_stiffness()[spec.station, j])
    return col, k, float(body.damping) * k


def _output_rows(system, kin, spec: Output, T, xd0, xdd0, t):
    """``dy/dz``, ``dy/dzd``, ``dy/dzdd`` of one output at the state, each shape (p,)."""
    n, p = T.shape
    zero = np.zeros(p)
    if spec.kind == "coordinate":
        row = T[_coordinate_column(system, spec.element, spec.coord, f"output {spec.name!r}")]
        return [(row, zero, zero), (zero, row, zero), (zero, zero, row)][spec.derivative]
    if spec.kind == "section":
        col, k, c = _section_column(system, spec)
        return k * T[col], c * T[col], zero
    k, p0 = _point(system, kin, spec.element, spec.location, f"output {spec.name!r}")
    local = kin.locate(system.model.element(spec.element, Body), spec.location)[1]
    d = spec.direction
    VP = d @ kin.point_partials(np.array([k]), p0[None])[0] @ T  # eq. 17: d . V_P T
    if spec.derivative == 0:
        return VP, zero, zero
    x0 = kin.x

    def measure(x, xd):
        """The velocity (with ``xdd0``: the acceleration) of the point along d at (x, xd)."""
        kn = system.kinematics(t, x, xd)
        pk = kn.point_position(k, local)
        if spec.derivative == 1:
            return d @ kn.point_velocity(k, pk)
        return d @ (kn.point_partials(np.array([k]), pk[None])[0] @ xdd0 + kn.point_bias_acceleration(k, pk))

    # the speed-dependent parts (d(V_P xd)/dx, the velocity-product accelerations) vanish at rest;
    # at a moving state they come from central differences of the kinematics (no equations solved)
    moving = np.any(xd0 != 0) or (spec.derivative == 2 and np.any(xdd0 != 0))
    dz, dzd = zero.copy(), zero.copy()
    if moving:
        move = system.layout.displace  # the coordinates perturbed along the speeds
        for i in range(p):
            e = _H * T[:, i]
            dz[i] = (measure(move(x0, e), xd0) - measure(move(x0, -e), xd0)) / (2 * _H)
            if spec.derivative == 2:
                dzd[i] = (measure(x0, xd0 + e) - measure(x0, xd0 - e)) / (2 * _H)
    if spec.derivative == 1:
        return dz, VP, zero
    return dz, dzd, VP


