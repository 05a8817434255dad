"""Linearisation and modes (after constraint reduction), and linear statics.

The stiffness and damping come from the analytic tangent of the equations
of motion where it is exact (:func:`tangent_gap` says where it is not),
else from central differences of the accelerations.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from attrs import define

from .._validate import state_time, state_vector, whole
from ..errors import ModelError
from ..forces import BeamElasticity, BodyTorque, Gravity, JointSpringDamper, PointForce
from ..threads import limited_blas
from .loop_modes import LoopModes, loop_modes, takes_loop_modes

__all__ = ["Linearization", "linearize", "modes", "linear_statics", "tangent_gap", "LINEARIZE_METHODS"]

#: how :func:`linearize` forms K and C
LINEARIZE_METHODS = ("auto", "analytic", "fd")

#: force-element classes whose whole dependence on the state the analytic tangent holds: coordinate
#: springs and dampers (their ``tangent_all``), and gravity, whose generalized forces change only through
#: the partial velocities (the geometric stiffness); constant point forces and torques are accepted
#: too (:func:`_exact_element`; their turning with the body is in :meth:`flexmb.System.load_stiffness`)
_EXACT_CLASSES = (Gravity, BeamElasticity, JointSpringDamper)


@define
class Linearization:
    """Linear equations ``M zdd + C zd + K z = F`` in independent coordinates z.

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    M, C, K : ndarray, shape (p, p)
        Mass, damping and stiffness matrices (eqs. 21, 36-39 linearised).
    F : ndarray, shape (p,)
        Generalized force left at the linearisation state (0 at an
        equilibrium).
    T : ndarray, shape (n, p)
        Orthogonal complement over the speeds (orthonormal columns with
        ``psi T = 0``): the coordinates are ``x0`` displaced by ``T z``
        (``x0 + T z`` while the speeds are the coordinates' rates;
        :meth:`flexmb.state_layout.StateLayout.displace`). Its basis is
        the strategy's: the SVD's (or QR's, eigen's) columns, or for loops
        closed by the articulated strategy p constrained solves
        (:meth:`flexmb.analysis.loop_modes.LoopModes.basis`); M, C, K and
        F are in that basis, what does not depend on it (``T M^-1 K T^T``,
        the modes, poles and transfer functions) is the same.
    x0 : ndarray, shape (nq,)
        The coordinates linearised about.
    xd0 : ndarray, shape (n,)
        The speeds linearised about.
    t : float
        Time, s.
    method : {'analytic', 'fd'}
        How K and C were formed: the analytic tangent, or central
        differences of the accelerations.
    reason : str
        Why central differences were used (empty for 'analytic').
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    F: np.ndarray
    T: np.ndarray
    x0: np.ndarray
    xd0: np.ndarray
    t: float
    method: str = "fd"
    reason: str = ""


def _exact_element(e) -> bool:
    """Whether the analytic tangent holds all of a force element's dependence on the state."""
    if type(e) is JointSpringDamper and e.joint.quaternions:  # a rotation spring's diagonal: exact at rest only
        return False
    if type(e) in _EXACT_CLASSES:
        return True
    if type(e) is PointForce:
        return not callable(e.force)
    if type(e) is BodyTorque:
        return not callable(e.torque)
    return False


def tangent_gap(system, x0, xd0, t: float = 0.0) -> str:
    """Why the analytic tangent of the accelerations is not exact at a state ('' if it is).

    The tangent (:meth:`flexmb.System.state_jacobian`, here formed in
    independent coordinates) holds the coordinate springs and dampers, the
    geometric stiffness of the loads, and the
    ``(dA/dx) xdd`` inertia terms. It is exact at a state at rest in an
    open tree or one closed only by drivers, when every force element is one
    whose state dependence it holds. Elsewhere it leaves terms out, and
    :func:`linearize` uses central differences instead:

    * at a moving state, the changes of the velocity-product (centrifugal,
      gyroscopic) terms, e.g. the stiffening of a spinning beam;
    * with closed loops, the changes of the constraint forces;
    * for a joint or force element written in Python (a plugin), a spring
      between points (:class:`~flexmb.SpringDamper`), or a load given by a
      function, the element's own dependence on the state.

    Parameters
    ----------
    system : System
        Compiled model.
    x0, xd0 : ndarray, shape (n,)
        The state.
    t : float
        Time, s.

    Returns
    -------
    str
        The reason, or '' where the tangent is exact.

    Examples
    --------
    >>> import numpy as np
    >>> import flexmb as fm
    >>> m = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    >>> system = m.add(fm.Revolute("pin", m.ground, bar), fm.Gravity((0, 0, -9.81))).build()
    >>> tangent_gap(system, np.zeros(1), np.zeros(1))
    ''
    >>> tangent_gap(system, np.zeros(1), np.ones(1))
    'the state moves: the velocity-product terms change with it'
    """
    drivers = system.constraints.drivers
    if np.any(np.asarray(xd0) != 0) or any(d.velocity(t) != 0 for d in drivers):
        return "the state moves: the velocity-product terms change with it"
    if system.n_constraints > len(drivers):
        return "closed loops: the constraint forces change with the state"
    if system.topology.external_groups:
        return "a joint class evaluated in Python: its motion's second derivatives are not known"
    if not system.layout.identity:  # kept on the differences they had while their motion was evaluated in Python
        return "joints in Euler parameters: linearised by differences along the speeds"
    others = sorted({type(e).__name__ for _, els in system.forces.groups for e in els if not _exact_element(e)})
    if others:
        return f"force elements whose state dependence the tangent lacks: {', '.join(others)}"
    return ""


def _analytic(system, kin, T, xdd):
    """``K = T^T (K_c - G) T`` and ``C = T^T C_c T`` from the terms of the state-following tangent.

    With ``J = [[0, I], [P (G - K_c), -P C_c]]`` the state Jacobian
    (:meth:`flexmb.System.state_jacobian`, ``P = T M^-1 T^T``), these are
    ``-T^T A J T`` in independent coordinates; K_c, C_c and G are the
    system's own (:meth:`flexmb.System.coordinate_terms`,
    :meth:`flexmb.System.load_stiffness`).
    """
    n = system.n_speeds
    terms = system.coordinate_terms(kin)
    Kc, Cc = terms if terms is not None else (np.zeros((n, n)), np.zeros((n, n)))
    G = system.load_stiffness(kin, xdd)
    return T.T @ (Kc - G) @ T, T.T @ Cc @ T


@limited_blas
def linearize(system, x0=None, xd0=None, t: float = 0.0, h: float = 1e-6, method: str = "auto") -> Linearization:
    """Linearise the reduced equations of motion about a state.

    Parameters
    ----------
    system : System
        Compiled model.
    x0 : ndarray, shape (nq,), optional
        Coordinates (default zeros); the state should satisfy the constraints.
    xd0 : ndarray, shape (n,), optional
        Speeds (default zeros).
    t : float
        Time, s.
    h : float
        Finite-difference step for the Jacobians of the accelerations
        (method 'fd').
    method : {'auto', 'analytic', 'fd'}
        'analytic': K and C from the analytic tangent (the coordinate
        springs and dampers and the geometric stiffness, as
        :meth:`flexmb.System.state_jacobian`); 'fd': central differences
        of :meth:`flexmb.System.accelerations` along the columns of T (2p
        solves of the equations of motion); 'auto' (default): 'analytic'
        where the tangent is exact at the state (:func:`tangent_gap`),
        else 'fd', with the reason in ``Linearization.reason``.

    Returns
    -------
    Linearization
        ``M = T^T A T``, ``K = -T^T A dxdd/dx T``, ``C = -T^T A dxdd/dxd T``
        and ``F = T^T (f - A xdd_p)``.

    Raises
    ------
    ModelError
        If ``method`` is not one of :data:`LINEARIZE_METHODS`, or is
        'analytic' where the tangent is not exact (the message says why),
        or the model has velocity (nonholonomic) constraint rows (about a
        steady motion :func:`flexmb.linearize_steady` takes them).

    Notes
    -----
    The accelerations come from the reduced equations (eqs. 36-39), so the
    constraint forces never appear; centrifugal (geometric) stiffening and
    gyroscopic terms of a spinning state are included (by central
    differences: at a moving state the analytic tangent leaves them out).
    Where both apply they agree to the accuracy of the differences (about
    1e-10 relative with the default step; ``tests/test_state_space.py``).

    With a dense complement (``svd``, ``qr``, ``eigen``) A, psi and T are
    formed: O(n^3) time, n x n arrays. Where the articulated strategy
    closes the loops, none is: T comes from p constrained solves of the
    articulated-body recursion, ``A T`` from p passes of it, and K and C a
    column of differences at a time, O(p n m) time and a few n x p arrays
    (linear in n for few independent coordinates p; where p grows with n,
    as for a flexible body in a loop, the result itself is that size;
    ``tests/test_linearize_loops.py``).

    Examples
    --------
    A pendulum of mass m = 2 kg with its mass centre d = 0.5 m below the pin
    has the stiffness ``m g d`` = 9.81 N m/rad hanging down:

    >>> import flexmb as fm
    >>> m = fm.Model()
    >>> bob = fm.RigidBody("bob", 2.0, (1e-3, 1e-3, 1e-3), com=(0, 0, -0.5))
    >>> system = m.add(fm.Revolute("pin", m.ground, bob, axis=(1, 0, 0)), fm.Gravity((0, 0, -9.81))).build()
    >>> lin = fm.linearize(system)
    >>> lin.method, round(float(lin.K[0, 0]), 12)
    ('analytic', 9.81)
    """
    if method not in LINEARIZE_METHODS:
        raise ModelError(f"linearize: unknown method {method!r}; pick one of {list(LINEARIZE_METHODS)}")
    system.constraints.refuse_velocity_rows(
        "linearize", "about a steady motion, flexmb.linearize_steady takes it (naming the ignorable coordinates)")
    nq, n = system.n_coords, system.n_speeds
    t = state_time("linearize", t)
    x0 = system.layout.reference() if x0 is None else state_vector("linearize", "x0", x0, nq)
    xd0 = np.zeros(n) if xd0 is None else state_vector("linearize", "xd0", xd0, n)
    T, AT, M, F = _reduced(system, t, x0, xd0, h)
    reason = tangent_gap(system, x0, xd0, t) if method != "fd" else "asked for"
    if method == "analytic" and reason:
        raise ModelError(f"linearize: the analytic tangent is not exact here ({reason}); use method='auto' or 'fd'")
    if not reason:
        K, C = _analytic(system, system.kinematics(t, x0, xd0), T, system.accelerations(t, x0, xd0))
        return Linearization(M=M, C=C, K=K, F=F, T=T, x0=x0, xd0=xd0, t=t, method="analytic")
    p = T.shape[1]
    K, C = np.zeros((p, p)), np.zeros((p, p))
    move = system.layout.displace  # the coordinates perturbed along the speeds: x0 + W(x0) d
    for start in range(0, p, _BLOCK):  # a block of columns at a time: no n x p arrays beyond T and A T
        cols = range(start, min(start + _BLOCK, p))
        Jx, Jv = np.empty((n, len(cols))), np.empty((n, len(cols)))
        for j, i in enumerate(cols):
            d = h * T[:, i]
            Jx[:, j] = system.accelerations(t, move(x0, d), xd0) - system.accelerations(t, move(x0, -d), xd0)
            Jv[:, j] = system.accelerations(t, x0, xd0 + d) - system.accelerations(t, x0, xd0 - d)
        K[:, cols.start:cols.stop] = (AT.T @ Jx) / (-2 * h)
        C[:, cols.start:cols.stop] = (AT.T @ Jv) / (-2 * h)
    return Linearization(M=M, C=C, K=K, F=F, T=T, x0=x0, xd0=xd0, t=t, method="fd", reason=reason)


#: columns of the differences held at once by :func:`linearize` (n x _BLOCK each): products by blocks
_BLOCK = 64


def _reduced(system, t, x0, xd0, h):
    """T, ``A T``, ``M = T^T A T`` and ``F = T^T (f - A xdd_p)`` at a state.

    With dense complements from the equations (A, psi and T by the
    system's strategy: n x n arrays). Where the articulated strategy
    closes the loops (:attr:`System._loop_kernel`) without an n x n array:
    T an orthonormal basis of ``psi v = 0`` from p constrained solves
    (:meth:`flexmb.analysis.loop_modes.LoopModes.basis`), ``A T`` by p
    passes of the recursion, and ``F = M T^T xdd`` (equal to the above:
    ``xdd_p = (I - T T^T) xdd`` is the particular solution of least norm,
    and ``T^T (f - A xdd) = 0`` are the reduced equations, eq. 39).
    O(p n m) time, n x p memory.
    """
    if system._loop_kernel:
        ops = LoopModes(system, x0, xd0, t, h, where="linearize")
        V, AT = ops.basis(system.dof(t, x0))
        T = _axes_first(V)
        if T is not V:
            for j in range(T.shape[1]):
                AT[:, j] = ops.mass_times(T[:, j])
        M = T.T @ AT
        return T, AT, M, M @ (T.T @ system.accelerations(t, x0, xd0))
    eq = system.equations(t, x0, xd0)
    c = system.complement(eq.psi)
    T = c.T
    AT = eq.A @ T
    xdd_p = c.particular(eq.gamma) if c.rank else np.zeros(system.n_speeds)
    return T, AT, T.T @ AT, T.T @ (eq.f - eq.A @ xdd_p)


def _axes_first(V):
    """The same space as V's orthonormal columns, with the coordinate axes in it as columns of their own.

    A coordinate that no loop or driver row holds (``e_j`` in the space:
    a row of V of unit norm) keeps its own column, first and in
    coordinate order, as psi's SVD gives it, so that its states are named
    after it; the rest is an orthonormal basis of the vectors of the space
    that leave those coordinates at zero (their SVD).

    Parameters
    ----------
    V : ndarray, shape (n, p)
        Orthonormal columns.

    Returns
    -------
    ndarray, shape (n, p)
        Orthonormal columns spanning the same space.
    """
    n, p = V.shape
    axes = np.flatnonzero(np.abs(np.einsum("ij,ij->i", V, V) - 1.0) < 1e-12)
    if axes.size == 0:
        return V
    T = np.zeros((n, p))
    T[axes, np.arange(axes.size)] = 1.0
    if axes.size < p:
        rest = V.copy()
        rest[axes] = 0.0
        T[:, axes.size:] = np.linalg.svd(rest, full_matrices=False)[0][:, :p - axes.size]
    return T


@limited_blas
def modes(system_or_lin, n_modes: int | None = None, **kw):
    """Natural frequencies and mode shapes (undamped, ``K phi = w^2 M phi``).

    Parameters
    ----------
    system_or_lin : System or Linearization
        What to analyse (a System is linearised about ``**kw``).
    n_modes : int, optional
        How many of the lowest modes to return (default all).
    **kw
        Passed to :func:`linearize`.

    Returns
    -------
    frequencies : ndarray, shape (k,)
        Natural frequencies, Hz, ascending.
    shapes : ndarray, shape (n, k)
        Mode shapes in the generalized coordinates x (``T phi``), each
        normalised to unit largest entry.

    Notes
    -----
    The dense path linearises (:func:`linearize`: p columns of
    differences) and solves the p x p eigenproblem: O(p^3) time and
    O(p^2 + n p) memory (O(n^3) and n x n arrays with a dense complement
    of psi). A model whose loops the articulated
    strategy closes, with at least
    ``flexmb.analysis.loop_modes.SPARSE_MODES_MIN`` coordinates and
    ``n_modes`` given, takes ``flexmb.analysis.loop_modes`` instead:
    Davidson iteration preconditioned by the constrained articulated-body
    recursion, a fixed number of O(n m) solves, no n x n array (for few
    independent coordinates, their whole basis: O(p n m)). Both difference
    the accelerations, so they agree to the differences' noise (about 1e-8
    of the largest eigenvalue found), not to round-off. Away from an
    equilibrium, where the stiffness is not symmetric, the sparse path
    stops with a ModelError that names the dense one.

    Examples
    --------
    >>> import flexmb as fm
    >>> m = fm.Model()
    >>> beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005),
    ...                        fm.Material.aluminium(), 16, keep=("bend_y",))
    >>> _ = m.add(fm.Fixed("clamp", m.ground, beam))
    >>> f, _ = fm.modes(m.build(), 1)
    >>> round(float(f[0]), 2)
    4.11
    """
    if n_modes is not None:
        n_modes = whole("modes", "n_modes", n_modes)
    if not isinstance(system_or_lin, Linearization) and takes_loop_modes(system_or_lin, n_modes,
                                                                         kw.get("method", "auto")):
        w2, shapes = _loop_modes(system_or_lin, n_modes, **kw)
    else:
        lin = system_or_lin if isinstance(system_or_lin, Linearization) else linearize(system_or_lin, **kw)
        K = 0.5 * (lin.K + lin.K.T)
        w2, phi = sla.eigh(K, lin.M)
        order = np.argsort(w2)
        w2, phi = w2[order][:n_modes], phi[:, order][:, :n_modes]
        shapes = lin.T @ phi
    shapes /= shapes[np.argmax(np.abs(shapes), axis=0), np.arange(shapes.shape[1])]
    return np.sqrt(np.maximum(w2, 0.0)) / (2 * np.pi), shapes


def _loop_modes(system, k, x0=None, xd0=None, t=0.0, h=1e-6, method="auto"):
    """:func:`~flexmb.analysis.loop_modes.loop_modes` with :func:`linearize`'s arguments and checks."""
    system.constraints.refuse_velocity_rows(
        "modes", "about a steady motion, flexmb.linearize_steady takes it (naming the ignorable coordinates)")
    t = state_time("modes", t)
    x0 = system.layout.reference() if x0 is None else state_vector("modes", "x0", x0, system.n_coords)
    xd0 = np.zeros(system.n_speeds) if xd0 is None else state_vector("modes", "xd0", xd0, system.n_speeds)
    return loop_modes(system, k, x0, xd0, t, h)


@limited_blas
def linear_statics(system, x0=None, t: float = 0.0):
    """Static deflection of the model linearised about ``x0``: ``K z = F``.

    Parameters
    ----------
    system : System
        Compiled model.
    x0 : ndarray, shape (nq,), optional
        Reference configuration (default zeros).
    t : float
        Time, s.

    Returns
    -------
    ndarray, shape (nq,)
        ``x0`` displaced by ``T K^-1 F``: the linear-statics coordinates.
    """
    lin = linearize(system, x0, None, t)
    return system.layout.displace(lin.x0, lin.T @ np.linalg.solve(lin.K, lin.F))
