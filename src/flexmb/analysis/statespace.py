"""State-space models of the linearised motion: named inputs and outputs.

:func:`state_space` turns the linearisation of :func:`~flexmb.linearize`
(``M zdd + C zd + K z = F``, in the independent coordinates z of the
orthogonal complement, ``x = x0 + T z``: eqs. 36-39 linearised) into

    d/dt [z, zd] = A [z, zd] + B u (+ affine),    y = C [z, zd] + D u

with inputs that are loads on the model (a generalized force on a joint
coordinate, a force at a point of a body) and outputs that are motions of
it (joint coordinates, speeds and accelerations; positions, velocities and
accelerations of body points; section loads of flexible bodies). Inputs and
outputs are described by :class:`Input` and :class:`Output`, whose elements
are given by object or by name as everywhere in flexmb.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as sla
from attrs import define, field, frozen

from .._validate import as_array, vector3
from ..bodies import Body
from ..errors import ModelError
from ..flexible import FlexibleBody
from ..joints import Joint
from ..threads import limited_blas
from .linear import Linearization, linearize

__all__ = ["Input", "Output", "StateSpace", "state_space", "EQUILIBRIUM_TOL"]

#: largest independent acceleration ``|M^-1 F|`` at the state linearised about, before
#: :func:`state_space` warns that the state is not an equilibrium (units of zdd)
EQUILIBRIUM_TOL = 1e-6

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
        :func:`flexmb.stresses.joint_stations` (``'section'``).
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
        coordinate, as :func:`flexmb.stresses.section_loads` reports it
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


def _fmt(v) -> str:
    return "(" + ", ".join(f"{float(c):g}" for c in np.asarray(v, dtype=float)) + ")"


@define
class StateSpace:
    """A linear state-space model ``xi' = A xi + B u``, ``y = C xi + D u`` with named signals.

    The state is ``xi = [z, zd]``: the independent coordinates of the
    linearisation (``x = x0 + T z``) and their speeds. Each parameter is
    kept as the attribute of the same name.

    Parameters
    ----------
    A : ndarray, shape (2p, 2p)
        ``[[0, I], [-M^-1 K, -M^-1 C]]``.
    B : ndarray, shape (2p, m)
        ``[[0], [M^-1 T^T Q]]``, Q the generalized forces of the inputs.
    C : ndarray, shape (k, 2p)
        Outputs per state.
    D : ndarray, shape (k, m)
        Direct feed-through (accelerations).
    inputs, outputs, states : list of str
        Names of the signals.
    affine : ndarray, shape (2p,)
        ``[0, M^-1 F]``: the state rate at ``xi = 0``, nonzero where the
        state linearised about is not an equilibrium. It is not part of
        A, B, C, D (nor of :meth:`to_scipy`).
    linearization : Linearization
        M, C, K, F, T and the state linearised about.

    Examples
    --------
    >>> import flexmb as fm
    >>> m = fm.Model()
    >>> bob = fm.RigidBody("bob", 2.0, (1e-3, 1e-3, 1e-3), com=(0, 0, -0.5))
    >>> pin = fm.Revolute("pin", m.ground, bob, axis=(1, 0, 0))
    >>> system = m.add(pin, fm.Gravity((0, 0, -9.81))).build()
    >>> ss = fm.state_space(system, inputs=["pin"], outputs=["pin"])
    >>> ss.poles().imag.round(4)  # sqrt(m g d / I) = sqrt(9.81 / 0.501), I = 1e-3 + m d^2
    array([-4.425,  4.425])
    >>> round(float(ss.static_gain()[0, 0]), 6)  # 1 / (m g d), rad per N m
    0.101937
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    inputs: list
    outputs: list
    states: list
    affine: np.ndarray
    linearization: Linearization = field(repr=False)

    def poles(self) -> np.ndarray:
        """Eigenvalues of A, 1/s.

        Returns
        -------
        ndarray, shape (2p,), complex
            Sorted by frequency (absolute value), then by imaginary part.
        """
        lam = np.linalg.eigvals(self.A)
        return lam[np.lexsort((lam.imag, np.abs(lam)))]

    def static_gain(self) -> np.ndarray:
        """Steady-state output per unit constant input: ``D - C A^-1 B``.

        Returns
        -------
        ndarray, shape (k, m)
            Gain (output units per input unit).

        Raises
        ------
        ModelError
            If A is singular (a free rigid-body motion: no static gain).
        """
        try:
            return self.D - self.C @ np.linalg.solve(self.A, self.B)
        except np.linalg.LinAlgError:
            raise ModelError("static_gain: A is singular (a rigid-body mode without stiffness)") from None

    def response(self, s) -> np.ndarray:
        """Transfer matrix ``C (s I - A)^-1 B + D`` at complex frequencies.

        Parameters
        ----------
        s : complex or array_like of complex, shape (n_s,)
            Laplace variable, 1/s (``1j * w`` on the imaginary axis).

        Returns
        -------
        ndarray, shape (n_s, k, m), complex
            One transfer matrix per ``s``.
        """
        s = np.atleast_1d(np.asarray(s, dtype=complex))
        # Hessenberg form once: each frequency is then an O(p^2) solve (Laub 1981)
        H, Q = sla.hessenberg(self.A, calc_q=True)
        Bq, Cq = Q.T @ self.B, self.C @ Q
        eye = np.eye(H.shape[0])
        out = np.empty((s.shape[0], self.C.shape[0], self.B.shape[1]), dtype=complex)
        for i, si in enumerate(s):
            out[i] = Cq @ np.linalg.solve(si * eye - H, Bq) + self.D
        return out

    def index(self, name, kind: str = "input") -> int:
        """Position of a named input or output.

        Parameters
        ----------
        name : str or int
            Its name (an int is taken as the position).
        kind : {'input', 'output'}
            Which list.

        Returns
        -------
        int
            Its position in ``inputs`` or ``outputs``.

        Raises
        ------
        ModelError
            If there is no such signal (the message lists the names).
        """
        names = self.inputs if kind == "input" else self.outputs
        if isinstance(name, (int, np.integer)):
            if not -len(names) <= name < len(names):
                raise ModelError(f"no {kind} {name}: there are {len(names)}")
            return int(name) % len(names)
        if name not in names:
            raise ModelError(f"no {kind} named {name!r}; {kind}s: {names}")
        return names.index(name)

    def feedback(self, gain) -> "StateSpace":
        """The closed loop under output feedback ``u = v - gain y``, with v the new inputs.

        Parameters
        ----------
        gain : array_like, shape (m, k)
            Feedback gains, input units per output unit (e.g. ``[[Kp, Kd]]``
            for a PD law on a coordinate and its speed).

        Returns
        -------
        StateSpace
            Same signals; ``A - B G (I + D G)^-1 C`` and so on.

        Examples
        --------
        >>> import numpy as np
        >>> import flexmb as fm
        >>> m = fm.Model()
        >>> bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
        >>> pin = fm.Revolute("pin", m.ground, bar, axis=(0, 0, 1))
        >>> ss = fm.state_space(m.add(pin).build(), ["pin"], ["pin", fm.Output.coordinate("pin", derivative=1)])
        >>> closed = ss.feedback([[3.0, 2.0]])  # I = 1/3 kg m^2: s^2 + 6 s + 9
        >>> np.round(closed.poles().real, 6)
        array([-3., -3.])
        """
        G = np.atleast_2d(np.asarray(gain, dtype=float))
        k, m = self.D.shape
        if G.shape != (m, k):
            raise ModelError(f"feedback: gain must have shape {(m, k)} (inputs x outputs), got {G.shape}")
        E = np.linalg.inv(np.eye(k) + self.D @ G)  # y = E (C xi + D v)
        A = self.A - self.B @ G @ E @ self.C
        B = self.B - self.B @ G @ E @ self.D
        return StateSpace(A=A, B=B, C=E @ self.C, D=E @ self.D, inputs=list(self.inputs),
                          outputs=list(self.outputs), states=list(self.states), affine=self.affine,
                          linearization=self.linearization)

    def to_scipy(self):
        """As :class:`scipy.signal.StateSpace` (without names or the affine term).

        Returns
        -------
        scipy.signal.StateSpace
            The continuous-time model A, B, C, D.
        """
        from scipy.signal import StateSpace as ScipyStateSpace

        return ScipyStateSpace(self.A, self.B, self.C, self.D)

    def to_control(self):
        """As python-control's ``StateSpace``, with the signal names (``pip install 'flexmb[control]'``).

        Returns
        -------
        control.StateSpace
            A, B, C, D with ``inputs``, ``outputs`` and ``states`` as its signal labels.

        Raises
        ------
        ModelError
            If python-control is not installed.
        """
        try:
            import control
        except ImportError as exc:
            raise ModelError("to_control needs python-control: pip install 'flexmb[control]'") from exc
        return control.ss(self.A, self.B, self.C, self.D, inputs=list(self.inputs), outputs=list(self.outputs),
                          states=list(self.states))


# ----------------------------------------------------------------------------- resolving names

def _about(system, about):
    """``(x0, xd0, t)`` from None, ``(x0, xd0[, t])`` or ``(result, t)``."""
    n = system.n_coords
    if about is None:
        return np.zeros(n), np.zeros(n), 0.0
    if not isinstance(about, (tuple, list)) or len(about) not in (2, 3):
        raise ModelError("state_space: about must be None, (x0, xd0), (x0, xd0, t) or (result, t), got "
                         f"{type(about).__name__}")
    first = about[0]
    if hasattr(first, "t") and hasattr(first, "xd") and hasattr(first, "x"):  # a Result and a time
        if len(about) != 2:
            raise ModelError("state_space: about=(result, t) takes a result and one time")
        times = np.asarray(first.t, dtype=float)
        i = int(np.argmin(np.abs(times - float(about[1]))))
        return (np.array(first.x[i], dtype=float), np.array(first.xd[i], dtype=float), float(times[i]))
    x0 = np.asarray(first, dtype=float)
    xd0 = np.asarray(about[1], dtype=float)
    t = float(about[2]) if len(about) == 3 else 0.0
    if x0.shape != (n,) or xd0.shape != (n,):
        raise ModelError(f"state_space: about's x0 and xd0 must have shape ({n},), got {x0.shape} and {xd0.shape}")
    return x0, xd0, t


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
    Q = np.zeros(system.n_coords)
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
    from ..stresses import LOAD_COMPONENTS

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
        for i in range(p):
            e = _H * T[:, i]
            dz[i] = (measure(x0 + e, xd0) - measure(x0 - e, xd0)) / (2 * _H)
            if spec.derivative == 2:
                dzd[i] = (measure(x0, xd0 + e) - measure(x0, xd0 - e)) / (2 * _H)
    if spec.derivative == 1:
        return dz, VP, zero
    return dz, dzd, VP


def _state_names(system, T) -> list[str]:
    """Coordinate names where T's columns are coordinate axes, else ``z<i>``."""
    names = []
    for i in range(T.shape[1]):
        j = int(np.argmax(np.abs(T[:, i])))
        names.append(system.coordinate_names[j] if abs(abs(T[j, i]) - 1.0) < 1e-12 else f"z{i}")
    return names + [s + "'" for s in names]


@limited_blas
def state_space(system, inputs=(), outputs=(), about=None, *, method: str = "auto",
                equilibrium_tol: float = EQUILIBRIUM_TOL) -> StateSpace:
    """State-space model of the motion linearised about a state, with named inputs and outputs.

    Parameters
    ----------
    system : System or Model
        What to linearise (a Model is built first).
    inputs : sequence of Input, Joint or str
        Loads, per unit input: :meth:`Input.joint` (a generalized force on a
        joint coordinate; a joint or a coordinate name is taken as that),
        :meth:`Input.point_force` (a force at a body point) or
        :meth:`Input.joint_load` (a torque or force across a joint).
    outputs : sequence of Output, Joint or str
        :meth:`Output.coordinate` (a joint or a coordinate name is taken
        as that), :meth:`Output.point` or :meth:`Output.section_load`:
        deviations from their values at the state linearised about.
    about : None, tuple
        The state: None (default: zero coordinates and speeds at t = 0),
        ``(x0, xd0)``, ``(x0, xd0, t)``, or ``(result, t)`` for the stored
        output of a :class:`~flexmb.Result` nearest to time t. It should
        satisfy the constraints; it need not be an equilibrium (see
        ``equilibrium_tol``).
    method : {'auto', 'analytic', 'fd'}
        How K and C are formed, see :func:`~flexmb.linearize`: the analytic
        tangent where it is exact (a state at rest, no loops, built-in
        elements), central differences elsewhere (the reason is kept in
        ``result.linearization.reason``).
    equilibrium_tol : float
        A warning is issued if the state is not an equilibrium: if the
        independent accelerations ``M^-1 F`` there exceed this (units of
        zdd). They are kept as ``StateSpace.affine``.

    Returns
    -------
    StateSpace
        A, B, C, D with the signal names; ``.to_scipy()``,
        ``.to_control()``, ``.poles()``, ``.static_gain()``,
        ``.response(s)``, ``.feedback(gain)``.

    Raises
    ------
    ModelError
        If an input or output names no element of the model, or a
        coordinate, station or component it lacks.

    Warns
    -----
    UserWarning
        If the state is not an equilibrium (``equilibrium_tol``).

    Notes
    -----
    With ``M zdd + C zd + K z = F + T^T Q u`` from :func:`~flexmb.linearize`
    (eqs. 36-39 linearised; Q the generalized forces of the inputs, eq. 5:
    ``V_P^T F`` for a force F at a point P, eq. 17), the state
    ``xi = [z, zd]`` obeys ``xi' = A xi + B u + affine`` with
    ``A = [[0, I], [-M^-1 K, -M^-1 C]]``, ``B = [[0], [M^-1 T^T Q]]``.
    An output ``y(x, xd, xdd)`` is linearised with ``dx = T z``,
    ``dxd = T zd`` and ``dxdd = T zdd``: a point's displacement is
    ``d . V_P T z`` (eq. 17); accelerations take ``zdd`` from the second
    block row and so feed the inputs through (D). Section loads are the
    segment-joint spring and damper loads ``k eta + c etadot`` (eqs. 25-27).

    Examples
    --------
    A 1 m aluminium strip clamped at the root: tip deflection per newton of
    tip force, against Euler-Bernoulli's ``L^3 / (3 E I)`` = 0.022857 m/N
    (16 segments: 0.2 % more, the finite-segment error, ``1 / (2 N^2)``):

    >>> import flexmb as fm
    >>> m = fm.Model()
    >>> beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005),
    ...                        fm.Material.aluminium(), 16, keep=("bend_y",))
    >>> system = m.add(fm.Fixed("clamp", m.ground, beam)).build()
    >>> tip = ((1.0, 0, 0), (0, 0, 1))
    >>> ss = fm.state_space(system, [fm.Input.point_force("beam", *tip)], [fm.Output.point("beam", *tip)])
    >>> round(float(ss.static_gain()[0, 0]), 6)
    0.022902
    """
    if not hasattr(system, "n_coords"):
        system = system.build()
    x0, xd0, t = _about(system, about)
    ins = [_as_input(s) for s in inputs]
    outs = [_as_output(s) for s in outputs]
    for kind, specs in (("input", ins), ("output", outs)):
        names = [s.name for s in specs]
        dup = sorted({v for v in names if names.count(v) > 1})
        if dup:
            raise ModelError(f"state_space: {kind} names must be unique; repeated: {dup} (give name=...)")
    lin = linearize(system, x0, xd0, t, method=method)
    T = lin.T
    p = T.shape[1]
    kin = system.kinematics(t, x0, xd0)
    Q = np.array([_input_force(system, kin, s) for s in ins]).reshape(len(ins), system.n_coords).T
    cho = sla.cho_factor(lin.M)
    Minv = lambda rhs: sla.cho_solve(cho, rhs)  # noqa: E731
    A = np.zeros((2 * p, 2 * p))
    A[:p, p:] = np.eye(p)
    A[p:, :p] = -Minv(lin.K)
    A[p:, p:] = -Minv(lin.C)
    Bz = Minv(T.T @ Q)  # (p, m)
    B = np.vstack([np.zeros((p, len(ins))), Bz])
    affine = np.concatenate([np.zeros(p), Minv(lin.F)])
    zdd0 = affine[p:]
    if zdd0.size and np.max(np.abs(zdd0)) > equilibrium_tol:
        warnings.warn(f"state_space: the state is not an equilibrium (independent accelerations up to "
                      f"{np.max(np.abs(zdd0)):.3g}); the constant term is kept in StateSpace.affine",
                      UserWarning, stacklevel=2)
    xdd0 = system.accelerations(t, x0, xd0) if outs and any(o.derivative for o in outs) else np.zeros(len(x0))
    C = np.zeros((len(outs), 2 * p))
    D = np.zeros((len(outs), len(ins)))
    for r, spec in enumerate(outs):
        dz, dzd, dzdd = _output_rows(system, kin, spec, T, xd0, xdd0, t)
        C[r, :p] = dz + dzdd @ A[p:, :p]
        C[r, p:] = dzd + dzdd @ A[p:, p:]
        D[r] = dzdd @ Bz
    return StateSpace(A=A, B=B, C=C, D=D, inputs=[s.name for s in ins], outputs=[s.name for s in outs],
                      states=_state_names(system, T), affine=affine, linearization=lin)
