"""Linearisation about a steady motion, for models with velocity (nonholonomic) rows too.

A velocity row ``B(x, t) xd = b`` leaves fewer independent speeds than free
coordinates, so the second-order model of :func:`flexmb.linearize` (``x =
x0 + T z``) does not exist for it. About a **steady motion** (the
coordinates that move are ignorable: the equations do not depend on them;
the others stand still; the independent speeds are constant) the linear
model is first order, in the perturbations of

* the independent **coordinates** among the non-ignorable ones (those the
  position rows leave free: a bicycle's lean and steer, its pitch following
  from the wheels' contact), and
* the independent **speeds**, a selection of coordinate rates (the
  bicycle's lean, steer and rear-wheel rates), the other rates following
  from the linearised rows ``psi dxd = -d(psi xd0 - b)/dx dx``.

docs/constraints.md, "Linearisation with velocity rows", derives it.

The coordinates are perturbed along the speeds
(:meth:`flexmb.state_layout.StateLayout.displace`): a joint in Euler
parameters (``rotation='quaternion'``) is perturbed by a small rotation
vector ``c`` in the child's axes, ``R = R0 exp([c]x)``, three parameters
for its four coordinates, named by its speeds (``'pivot.wx'``: the small
rotation about the child's x axis). Along the steady motion ``R0`` turns at
the angular velocity ``omega0`` (in the child's axes), and the rotation
vector from it follows, linearised, ``c' = du - omega0 x c`` (from ``R' =
R [omega]x``: ``[c']x = [du]x + [c]x [omega0]x - [omega0]x [c]x``): the
linear model is written in axes that turn with the body, where a spinning
top's or a tumbling body's steady state stands still.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from attrs import define

from .._validate import state_time, state_vector
from ..errors import ModelError
from ..simulate import _coordinate_mask as _mask
from ..threads import limited_blas

__all__ = ["SteadyLinearization", "linearize_steady"]

#: the five-point central stencil of a first derivative: offsets and weights (error O(h^4))
_OFFSETS = (-2.0, -1.0, 1.0, 2.0)
_WEIGHTS = (1.0 / 12.0, -8.0 / 12.0, 8.0 / 12.0, -1.0 / 12.0)


@define
class SteadyLinearization:
    """First-order linear model ``ds/dt = A s`` about a steady motion, ``s = (dq, du)``.

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    A : ndarray, shape (k + p, k + p)
        State matrix.
    coordinates : list of str
        The k independent coordinates (the first k states): speed names,
        the coordinate's own where the speed is its rate, a quaternion's
        angular speed for the small rotation about that axis (module
        docstring).
    speeds : list of str
        The p independent speeds (the last p states): the coordinates whose
        rates they are, or a quaternion joint's angular speeds.
    ignorable : list of str
        The coordinates left out (the equations do not depend on them).
    X, Xd : ndarray, shape (n, k + p)
        The perturbation of the coordinates (along the speeds,
        :meth:`~flexmb.state_layout.StateLayout.displace`) and of the
        speeds, ``dx = X s``, ``dxd = Xd s`` (0 on the ignorable
        coordinates); n speeds.
    x0 : ndarray, shape (nq,)
        The coordinates of the steady motion linearised about.
    xd0 : ndarray, shape (n,)
        Its speeds.
    t : float
        Time, s.
    residual : float
        How far the state is from steady: the largest acceleration of an
        independent speed or of a non-ignorable coordinate, or speed of a
        non-ignorable coordinate.
    rotations : frozenset of str
        The speeds (by name) that are a quaternion joint's angular velocity
        (empty without Euler parameters).
    """

    A: np.ndarray
    coordinates: list
    speeds: list
    ignorable: list
    X: np.ndarray
    Xd: np.ndarray
    x0: np.ndarray
    xd0: np.ndarray
    t: float
    residual: float = 0.0

    rotations: frozenset = frozenset()

    @property
    def states(self) -> list[str]:
        """The state names: the coordinates, then the speeds.

        A coordinate's rate is ``'name rate'``; a quaternion joint's small
        rotation about an axis is ``'pivot.wx angle'``, its angular speed
        ``'pivot.wx'``.
        """
        return ([f"{c} angle" if c in self.rotations else c for c in self.coordinates]
                + [s if s in self.rotations else f"{s} rate" for s in self.speeds])

    def eigenvalues(self) -> np.ndarray:
        """The eigenvalues of ``A``, sorted by real part, then imaginary part.

        Returns
        -------
        ndarray of complex, shape (k + p,)
            1/s.
        """
        w = np.linalg.eigvals(self.A)
        return w[np.lexsort((w.imag, w.real))]


def _derivative(fun, h):
    """``fun'(0)`` by the five-point central stencil of step h."""
    return sum(w * fun(o * h) for o, w in zip(_OFFSETS, _WEIGHTS)) / h


def _pivots(a, tol):
    """Column indices of ``a`` in the order of a pivoted QR, and its rank."""
    if a.shape[1] == 0 or a.shape[0] == 0:
        return np.arange(a.shape[1]), 0
    _, r, piv = sla.qr(a, mode="economic", pivoting=True)
    d = np.abs(np.diag(r))
    rank = int(np.sum(d > tol * max(d[0], 1e-300))) if d.size else 0
    return piv, rank


def _rank(a, tol):
    if a.size == 0:
        return 0
    s = np.linalg.svd(a, compute_uv=False)
    return int(np.sum(s > tol * max(s[0], 1e-300)))


def _names_mask(system, names, what):
    """The mask of speeds (a coordinate's, where it is the coordinate's rate) named, or of the joints named."""
    if isinstance(names, str):
        raise ModelError(f"linearize_steady: {what} must be a list of coordinate or joint names, got the string "
                         f"{names!r}")
    return _mask(system, list(names), speeds=True)


def _kinematic_term(system, xd0):
    """``K`` with ``c' = du + K c`` for the perturbations along the speeds: ``-[omega0]x`` on each quaternion."""
    n = system.n_speeds
    K = np.zeros((n, n))
    for axes in system.topology.quaternions[1]:
        w = xd0[axes]
        K[np.ix_(axes, axes)] = -np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    return K


@limited_blas
def linearize_steady(system, x0, xd0, ignorable=None, coordinates=None, speeds=None, t: float = 0.0,
                     h: float = 1e-3, tol: float = 1e-8) -> SteadyLinearization:
    """Linearise about a steady motion; velocity (nonholonomic) rows allowed.

    Parameters
    ----------
    system : System
        Compiled model.
    x0, xd0 : ndarray, shape (nq,) and (n,)
        A state of the steady motion, coordinates and speeds; it must
        satisfy the constraints (:func:`flexmb.initial_state` makes it so).
    ignorable : list of str, optional
        Coordinates (or joint names) the equations do not depend on: a
        vehicle's position and heading on a level plane, its wheels' angles.
        Default: those that move (``xd0 != 0``), which a steady motion
        requires to be ignorable. Every ignorable coordinate is checked: a
        dependence of the linear model on it is refused, by name.
    coordinates : list of str, optional
        The independent coordinates among the non-ignorable ones (default:
        chosen by a pivoted QR of the position rows, the others following
        from them).
    speeds : list of str, optional
        The coordinates whose rates are the independent speeds (default:
        the independent coordinates' rates, then rates chosen by a pivoted
        QR of the rows).

        A joint in Euler parameters is named by its speeds in all three
        (``'pivot.wz'``: its rotation about the child's z axis, a
        coordinate perturbed by a small rotation vector; module docstring),
        or by the joint's name.
    t : float
        Time, s.
    h : float
        Step of the five-point central differences (rad, m or per s).
    tol : float
        Largest residual accepted for the state to be steady (see
        :attr:`SteadyLinearization.residual`).

    Returns
    -------
    SteadyLinearization
        ``ds/dt = A s`` with ``s = (dq, du)``.

    Raises
    ------
    ModelError
        If the state is not steady, a moving coordinate is not named
        ignorable, a position row ties an ignorable coordinate to a
        non-ignorable one, the named coordinates or speeds are not
        independent, or the linear model depends on an ignorable
        coordinate; each message names the coordinates.

    Notes
    -----
    With ``r(x) = psi(x) xd0 - b(x)`` the rows' residual at the reference
    speeds, a perturbation ``(dx, dxd)`` is admissible when ``psi_h dx = 0``
    (the position rows) and ``psi dxd + (dr/dx) dx = 0`` (all rows,
    linearised). The independent coordinates fix ``dx`` (0 on the ignorable
    coordinates), the independent speeds with ``dx`` fix ``dxd``; the rates
    of the independent coordinates are rows of ``Xd``, and the derivatives
    of the independent speeds come from :meth:`flexmb.System.accelerations`
    by five-point central differences along each admissible direction. A
    perturbation ``dx`` is a displacement along the speeds, ``x0 + W dx``
    while the speeds are the coordinates' rates, a small rotation of an
    Euler-parameter joint (whose rate adds ``-omega0 x dx``, module
    docstring).
    Along those directions the differences see the constrained motion only:
    the perturbed states leave the constraints by O(h^2), symmetrically, and
    the stencil cancels that.

    Examples
    --------
    A pendulum hanging still (no velocity rows; nothing ignorable) is
    ``s = (angle, rate)`` with ``A = [[0, 1], [-g/l, 0]]``:

    >>> import numpy as np
    >>> import flexmb as fm
    >>> m = fm.Model()
    >>> bob = fm.RigidBody("bob", 1.0, (0, 0, 0), com=(0, 0, -1.0))
    >>> system = m.add(fm.Revolute("pin", m.ground, bob, axis=(1, 0, 0)), fm.Gravity((0, 0, -9.81))).build()
    >>> lin = fm.linearize_steady(system, np.zeros(1), np.zeros(1))
    >>> lin.states, np.round(lin.A, 9).tolist()
    (['pin.angle', 'pin.angle rate'], [[0.0, 1.0], [-9.81, 0.0]])
    """
    n = system.n_speeds
    names = system.speed_names
    t = state_time("linearize_steady", t)
    x0 = state_vector("linearize_steady", "x0", x0, system.n_coords)
    xd0 = state_vector("linearize_steady", "xd0", xd0, n)
    if not (h > 0 and np.isfinite(h)):
        raise ModelError(f"linearize_steady: h must be a positive step, got {h!r}")
    psi = system.equations(t, x0, xd0).psi
    psi_h = psi[system.constraints.holonomic] if psi.shape[0] else psi
    small = 1e-10 * max(1.0, float(np.max(np.abs(psi)))) if psi.size else 0.0
    ig = _ignorable(system, xd0, ignorable, psi_h, small)
    ind_c, Xc = _independent_coordinates(system, psi_h, ig, coordinates)
    ind_s, dep_s = _independent_speeds(system, psi, ind_c, speeds)
    ref = _Reference(system, t, x0, xd0, psi, ind_c, ind_s, dep_s, h)
    k, p = len(ind_c), len(ind_s)
    X = np.zeros((n, k + p))
    X[:, :k] = Xc
    Xd = np.column_stack([ref.speeds_of(Xc[:, j]) for j in range(k)]
                         + [ref.dependent_speeds(np.zeros(psi.shape[0]), np.eye(p)[j]) for j in range(p)])
    residual = _steady_residual(system, t, x0, xd0, ind_s, np.flatnonzero(~ig), tol)
    A = np.column_stack([ref.column(X[:, j], Xd[:, j]) for j in range(k + p)]) if k + p else np.zeros((0, 0))
    _check_ignorable(ref, ig, psi_h, small, A)
    rotations = frozenset(names[i] for i in system.topology.quaternions[1].ravel())
    return SteadyLinearization(A=A, coordinates=[names[i] for i in ind_c], speeds=[names[i] for i in ind_s],
                               ignorable=[names[i] for i in np.flatnonzero(ig)], X=X, Xd=Xd, x0=x0, xd0=xd0, t=t,
                               residual=residual, rotations=rotations)


def _ignorable(system, xd0, ignorable, psi_h, small):
    """The mask of ignorable coordinates (default: those that move), checked against the state and the rows."""
    names = system.speed_names
    moving = np.abs(xd0) > 1e-12 * max(1.0, float(np.max(np.abs(xd0))))
    ig = moving.copy() if ignorable is None else _names_mask(system, ignorable, "ignorable")
    if np.any(moving & ~ig):
        raise ModelError(f"linearize_steady: {[names[i] for i in np.flatnonzero(moving & ~ig)]} move in the state "
                         "given (xd0 != 0) but are not named ignorable: a steady motion moves only ignorable "
                         "coordinates")
    for row in psi_h:  # a position row may hold ignorable coordinates together, or non-ignorable ones, not both
        on = np.abs(row) > small
        if np.any(on & ig) and np.any(on & ~ig):
            tied = [names[i] for i in np.flatnonzero(on & ig)]
            raise ModelError(f"linearize_steady: a position row ties the ignorable {tied} to "
                             f"{[names[i] for i in np.flatnonzero(on & ~ig)]}, which are not: name them all "
                             "ignorable or none")
    return ig


def _independent_coordinates(system, psi_h, ig, coordinates):
    """The independent coordinates among the non-ignorable ones, and ``Xc`` (``dx = Xc dq``, 0 where ignorable)."""
    names, n = system.speed_names, system.n_speeds
    N = np.flatnonzero(~ig)
    Pn = psi_h[:, N]
    rank_h = _rank(Pn, 1e-10)
    if coordinates is None:
        piv, _ = _pivots(Pn, 1e-10)
        dep_c = np.sort(N[piv[:rank_h]])
        ind_c = np.array([i for i in N if i not in set(dep_c)], dtype=int)
    else:
        chosen = _names_mask(system, coordinates, "coordinates")
        if np.any(chosen & ig):
            raise ModelError(f"linearize_steady: {[names[i] for i in np.flatnonzero(chosen & ig)]} are named both "
                             "coordinates and ignorable")
        ind_c, dep_c = np.flatnonzero(chosen), np.flatnonzero(~ig & ~chosen)
        if len(ind_c) != len(N) - rank_h or _rank(psi_h[:, dep_c], 1e-10) != rank_h:
            raise ModelError(f"linearize_steady: the coordinates {[names[i] for i in ind_c]} are not independent "
                             f"ones: the position rows leave {len(N) - rank_h} of the non-ignorable "
                             f"{[names[i] for i in N]} free, and the others must follow from them")
    k = len(ind_c)
    Xc = np.zeros((n, k))
    Xc[ind_c, np.arange(k)] = 1.0
    if len(dep_c):
        Xc[dep_c] = -np.linalg.lstsq(psi_h[:, dep_c], psi_h[:, ind_c], rcond=None)[0]
    return ind_c, Xc


def _independent_speeds(system, psi, ind_c, speeds):
    """The coordinates whose rates are the independent speeds, and the others (their rates from the rows)."""
    names, n = system.speed_names, system.n_speeds
    rank_v = _rank(psi, 1e-10) if psi.size else 0
    p = n - rank_v
    if speeds is None:  # the independent coordinates' rates first, if the rows leave them free
        rest = np.array([i for i in range(n) if i not in set(ind_c)], dtype=int)
        piv, r = _pivots(psi[:, rest], 1e-10)
        if r == rank_v:
            dep_s = np.sort(rest[piv[:rank_v]])
        else:
            piv, _ = _pivots(psi, 1e-10)
            dep_s = np.sort(piv[:rank_v])
        return np.array([i for i in range(n) if i not in set(dep_s)], dtype=int), dep_s
    chosen = _names_mask(system, speeds, "speeds")
    ind_s, dep_s = np.flatnonzero(chosen), np.flatnonzero(~chosen)
    if len(ind_s) != p or (rank_v and _rank(psi[:, dep_s], 1e-10) != rank_v):
        raise ModelError(f"linearize_steady: the rates of {[names[i] for i in ind_s]} are not independent "
                         f"speeds: the model has {p}, and the constraint rows must fix the rates of the others")
    return ind_s, dep_s


def _steady_residual(system, t, x0, xd0, ind_s, N, tol):
    """How far from steady: the largest acceleration of an independent speed or a kept coordinate ``N``, or
    speed of a kept coordinate; above ``tol`` it is refused."""
    names, n = system.speed_names, system.n_speeds
    a0 = system.accelerations(t, x0, xd0)
    held = np.union1d(ind_s, N).astype(int)
    residual = float(max(np.max(np.abs(a0[held]), initial=0.0), np.max(np.abs(xd0[N]), initial=0.0)))
    if residual > tol:
        worst = int(np.argmax(np.abs(a0) * np.isin(np.arange(n), held)))
        raise ModelError(f"linearize_steady: the state is not a steady motion: residual {residual:.3g} > tol = "
                         f"{tol:.3g} (the acceleration of {names[worst]!r} is {a0[worst]:.3g}); a steady motion "
                         "keeps the non-ignorable coordinates and the independent speeds constant")
    return residual


class _Reference:
    """The steady state linearised about, and the admissible perturbations' speeds and derivatives."""

    def __init__(self, system, t, x0, xd0, psi, ind_c, ind_s, dep_s, h):
        self.system, self.t, self.x0, self.xd0, self.psi, self.h = system, t, x0, xd0, psi, h
        self.ind_c, self.ind_s, self.dep_s = ind_c, ind_s, dep_s
        self.n = system.n_speeds
        self.move = system.layout.displace  # x0 + W dx, a quaternion turned by the rotation vector dx
        self.K = _kinematic_term(system, xd0)

    def rows_residual(self, dx):
        """``psi(x0 + dx) xd0 - b(x0 + dx)`` (``x0 + dx``: displaced along the speeds)."""
        e = self.system.equations(self.t, self.move(self.x0, dx), self.xd0)
        return e.psi @ self.xd0 - e.b

    def dependent_speeds(self, G, given):
        """``dxd`` with ``given`` on the independent speeds, the rest from ``psi dxd = -G``."""
        out = np.zeros(self.n)
        out[self.ind_s] = given
        if len(self.dep_s):
            out[self.dep_s] = np.linalg.lstsq(self.psi[:, self.dep_s], -G - self.psi[:, self.ind_s] @ given,
                                              rcond=None)[0]
        return out

    def speeds_of(self, dx):
        """The speeds' perturbation that a coordinate perturbation ``dx`` needs, the independent speeds held."""
        G = _derivative(lambda s: self.rows_residual(s * dx), self.h) if self.psi.size else np.zeros(0)
        return self.dependent_speeds(G, np.zeros(len(self.ind_s)))

    def column(self, dx, dxd):
        """The derivative of ``(rates of the independent coordinates, independent speeds' accelerations)``."""
        acc = _derivative(lambda s: self.system.accelerations(self.t, self.move(self.x0, s * dx), self.xd0 + s * dxd),
                          self.h)
        return np.concatenate([(dxd + self.K @ dx)[self.ind_c], acc[self.ind_s]])


def _check_ignorable(ref, ig, psi_h, small, A):
    """Refuse, by name, an ignorable coordinate that the linear model depends on."""
    names, n = ref.system.speed_names, ref.n
    scale = max(1.0, float(np.max(np.abs(A)))) if A.size else 1.0
    I = np.flatnonzero(ig)
    if not len(I):
        return
    Pi = psi_h[:, I]
    free = np.all(np.abs(Pi) <= small, axis=0)
    basis = [np.eye(len(I))[:, i] for i in np.flatnonzero(free)]
    tied = np.flatnonzero(~free)
    if len(tied):  # ignorable coordinates held together by position rows move together
        Z = sla.null_space(Pi[:, tied])
        basis += [np.eye(len(I))[:, tied] @ Z[:, c] for c in range(Z.shape[1])]
    for v in basis:
        dx = np.zeros(n)
        dx[I] = v
        c = ref.column(dx, ref.speeds_of(dx))
        if np.max(np.abs(c), initial=0.0) > 1e-6 * scale:
            who = names[I[int(np.argmax(np.abs(v)))]]
            raise ModelError(f"linearize_steady: the linear model depends on {who!r}, named ignorable "
                             f"(a change of {np.max(np.abs(c)):.3g} per unit, against {scale:.3g} in A): keep "
                             "it among the coordinates, or choose independent speeds that do not turn with it "
                             "(speeds=)")
