"""Initial speeds in the user's terms, and initial speeds that contradict the constraints.

Benchmarks state initial conditions as the velocity of a point (IFToMM A02:
the crank tip at 1 m/s) or a body's angular velocity. :class:`PointVelocity`
and :class:`AngularVelocity`, given in ``speeds`` beside coordinate speeds,
become rows ``C xd = c`` of the partial velocities (eqs. 7, 17: a point's
velocity is ``V_P xd``, a body's angular velocity ``W_k xd``), held with
the coordinate speeds named while the other speeds take the minimum-norm
correction onto ``psi xd = b`` (eq. 29).

Speeds that the constraints or the drivers do not allow (a driven crank
given another speed, a loop's rocker given a speed its crank contradicts)
are refused, naming both sides, unless ``hold_speeds=False`` says the
constraints win: then the given speeds are only the starting guess of the
correction.
"""

from __future__ import annotations

import numpy as np
from attrs import define, field

from .bodies import Body
from .errors import ModelError
from .fields import as_array, vector3

__all__ = ["PointVelocity", "AngularVelocity", "SPEED_TOL"]

#: largest ``|psi xd - b|`` (relative to the speeds' scale) that an initial state may keep: more is a
#: contradiction between the speeds held and the constraints (assembly reaches about 1e-15)
SPEED_TOL = 1e-9


def _directions(value):
    if value is None:
        return None
    d = np.array(value, dtype=float)
    if d.ndim == 1:
        d = d[None]
    return d


@define(frozen=True, eq=False)
class PointVelocity:
    """An initial velocity of a point fixed in a body (in ``speeds``, beside coordinate speeds).

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    body : Body or str
        The body (rigid or flexible: the segment the point lies on), or its
        name.
    point : array_like, shape (3,)
        The point in the body's frame, m.
    velocity : array_like, shape (3,)
        Its inertial velocity, m/s.
    directions : array_like, shape (3,) or (k, 3), optional
        Hold only the velocity's components along these inertial directions
        (e.g. ``(1, 0, 0)``: the x speed only; the others are left to the
        assembly). Default: all three.
    name : str, optional
        What messages call it besides its description (keyword only; a
        scene file names its table, ``initial.point_velocities.tip``).

    Examples
    --------
    IFToMM A02: the crank's tip (1 m up the first rod) moving at 1 m/s along x.

    >>> import flexmb as fm
    >>> v = fm.PointVelocity("rod0", (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))
    """

    body: object
    point: np.ndarray = field(converter=as_array, validator=vector3)
    velocity: np.ndarray = field(converter=as_array, validator=vector3)
    directions: np.ndarray | None = field(default=None, converter=_directions)
    name: str | None = field(default=None, kw_only=True)

    def __attrs_post_init__(self):
        d = self.directions
        if d is not None and (d.ndim != 2 or d.shape[1] != 3 or not d.shape[0] or not np.all(np.isfinite(d))
                              or np.any(np.linalg.norm(d, axis=1) == 0)):
            raise ModelError(f"PointVelocity on {_name(self.body)!r}: directions must be non-zero 3-vectors, "
                             f"got {self.directions!r}")

    def label(self) -> str:
        """What the rows are called in messages.

        Returns
        -------
        str
            E.g. "the velocity of point (0.1, 0.0, 0.0) of 'crank'", followed
            by the ``name`` in parentheses if there is one.
        """
        return _named(f"the velocity of point {tuple(float(c) for c in self.point)} of {_name(self.body)!r}", self.name)


@define(frozen=True, eq=False)
class AngularVelocity:
    """An initial angular velocity of a body (in ``speeds``, beside coordinate speeds).

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    body : Body or str
        The body, or its name.
    omega : array_like, shape (3,)
        The angular velocity, rad/s.
    frame : {'inertial', 'body'}
        The axes of ``omega``.
    directions : array_like, shape (3,) or (k, 3), optional
        Hold only the components along these directions (in ``frame``).
    name : str, optional
        What messages call it besides its description (keyword only).
    """

    body: object
    omega: np.ndarray = field(converter=as_array, validator=vector3)
    frame: str = "inertial"
    directions: np.ndarray | None = field(default=None, converter=_directions)
    name: str | None = field(default=None, kw_only=True)

    def __attrs_post_init__(self):
        if self.frame not in ("inertial", "body"):
            raise ModelError(f"AngularVelocity on {_name(self.body)!r}: frame must be 'inertial' or 'body', "
                             f"got {self.frame!r}")
        PointVelocity.__attrs_post_init__(self)

    def label(self) -> str:
        """What the rows are called in messages.

        Returns
        -------
        str
            E.g. "the angular velocity of 'coupler'", followed by the
            ``name`` in parentheses if there is one.
        """
        return _named(f"the angular velocity of {_name(self.body)!r}", self.name)


def _name(body) -> str:
    return body if isinstance(body, str) else getattr(body, "name", repr(body))


def _named(description: str, name: str | None) -> str:
    return description if name is None else f"{description} ({name})"


def split_speeds(speeds):
    """``speeds`` as (coordinate speeds dict, list of point and angular velocities).

    Parameters
    ----------
    speeds : dict, list or None
        A dict ``{coordinate or joint: value}``, or a list mixing such
        dicts, :class:`PointVelocity` and :class:`AngularVelocity`.

    Returns
    -------
    dict, list
    """
    if speeds is None or isinstance(speeds, dict):
        return speeds, []
    if isinstance(speeds, (PointVelocity, AngularVelocity)):
        speeds = [speeds]
    if not isinstance(speeds, (list, tuple)):
        raise ModelError(f"speeds must be a dict {{coordinate: value}} or a list of dicts, PointVelocity and "
                         f"AngularVelocity, got {type(speeds).__name__}")
    coords, motions = {}, []
    for item in speeds:
        if isinstance(item, dict):
            coords.update(item)
        elif isinstance(item, (PointVelocity, AngularVelocity)):
            motions.append(item)
        else:
            raise ModelError(f"speeds: an entry must be a dict, a PointVelocity or an AngularVelocity, got "
                             f"{type(item).__name__} {item!r}")
    return coords, motions


def motion_rows(system, t, x, motions):
    """The rows ``C xd = c`` of point and angular velocities at positions ``x``.

    Returns
    -------
    C : ndarray, shape (k, n)
    c : ndarray, shape (k,)
    owner : list of int
        The index in ``motions`` of each row.
    """
    kin = system.kinematics(t, x, np.zeros(system.n_speeds))
    C, c, owner = [], [], []
    for j, spec in enumerate(motions):
        body = system.model.element(spec.body, Body)
        if isinstance(spec, PointVelocity):
            k, local = system.topology.locate(body, spec.point)
            if k < 0:
                raise ModelError(f"{spec.label()}: the ground does not move")
            p = kin.point_position(k, local)
            P, value = kin.point_partials(np.array([k]), p[None])[0], spec.velocity
        else:
            k, _ = system.topology.locate(body, np.zeros(3))
            if k < 0:
                raise ModelError(f"{spec.label()}: the ground does not move")
            P, value = kin.angular_partials(np.array([k]))[0], spec.omega
            if spec.frame == "body":
                P = kin.R[k].T @ P
        D = np.eye(3) if spec.directions is None else spec.directions / np.linalg.norm(spec.directions, axis=1)[:, None]
        C.append(D @ P)
        c.append(D @ value)
        owner += [j] * D.shape[0]
    return np.vstack(C), np.concatenate(c), owner


def held_speeds(system, t, x, xd, held, motions, hold):
    """The initial speeds: the held ones kept, the rest corrected by the least change onto ``psi xd = b``.

    Parameters
    ----------
    system : System
    t : float
    x : ndarray, shape (nq,)
        Assembled coordinates.
    xd : ndarray, shape (n,)
        Speeds given (zeros where none).
    held : ndarray of bool, shape (n,)
        The speeds given.
    motions : list
        Point and angular velocities given.
    hold : bool
        True: what is given is kept, and a contradiction with the
        constraints is refused; False: the constraints win, and what is
        given is the least-squares target.

    Returns
    -------
    ndarray, shape (n,)

    Raises
    ------
    ModelError
        If the speeds held contradict the constraints or drivers, naming
        both.
    """
    n = system.n_speeds
    if not motions:
        if not system.n_constraints:
            return xd
        if not hold:
            return system.project(t, x, xd, fixed=None)[1]
        xd = system.project(t, x, xd, fixed=held)[1]
        if system._constraint_residuals(t, x, xd)[1] > SPEED_TOL * _scale(xd):  # psi formed only to name rows
            rows = system._rows(t, x, xd)
            _check(system, t, x, xd, rows.psi, rows.b, held, [], None, None)
        return xd
    rows = system._rows(t, x, xd) if system.n_constraints else None
    C, c, owner = motion_rows(system, t, x, motions)
    psi = np.zeros((0, n)) if rows is None else rows.psi
    b = np.zeros(0) if rows is None else rows.b
    E = np.eye(n)[held]
    if hold:  # the constraints and everything given, exactly where they agree
        A = np.vstack([psi, C, E])
        r = np.concatenate([b, c, xd[held]])
        xd = xd + np.linalg.lstsq(A, r - A @ xd, rcond=None)[0]
        _check(system, t, x, xd, psi, b, held, motions, C, c)
        return xd
    # the constraints win: the closest speeds on psi xd = b to what was given
    target = np.linalg.lstsq(np.vstack([C, E]), np.concatenate([c, xd[held]]) - np.vstack([C, E]) @ xd,
                             rcond=None)[0] + xd
    return system.project(t, x, target, fixed=None)[1] if rows is not None else target


def _scale(xd) -> float:
    """The scale of :data:`SPEED_TOL`: one plus the largest speed."""
    return 1.0 + float(np.max(np.abs(xd))) if xd.size else 1.0


def _check(system, t, x, xd, psi, b, held, motions, C, c):
    """Refuse speeds held that leave the constraints (or the point/angular velocities given) unmet."""
    scale = _scale(xd)
    res_psi = psi @ xd - b if psi.shape[0] else np.zeros(0)
    res_c = C @ xd - c if C is not None else np.zeros(0)
    worst = max(float(np.max(np.abs(res_psi), initial=0.0)), float(np.max(np.abs(res_c), initial=0.0)))
    if worst <= SPEED_TOL * scale:
        return
    given = [system.speed_names[i] for i in np.flatnonzero(held)] + [m.label() for m in motions]
    labels = list(system.constraints.labels)
    order = np.argsort(-np.abs(res_psi))[:3]
    violated = ", ".join(f"{labels[i]} (by {abs(res_psi[i]):.3g})" for i in order if abs(res_psi[i]) > SPEED_TOL * scale)
    if not violated:  # no constraint row is left unmet: the joints themselves cannot move so
        violated = "the joints' motion" if len(given) == 1 else "one another or the joints' motion"
    raise ModelError(
        f"the initial speeds given ({', '.join(given)}) contradict {violated}: they cannot all hold at t = {t:g} s. "
        "Give fewer speeds (the assembly finds the others), or pass hold_speeds=False to let the constraints win "
        "(the speeds given are then the closest the constraints allow)")
