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
from attrs import define, field

from .._validate import state_time, state_vector
from ..errors import ModelError
from ..model import as_system
from ..threads import limited_blas
from .linear import Linearization, linearize
from .signals import _as_input, _as_output, _input_force, _output_rows

#: the most frequencies one response evaluates: each costs a Python-level solve, so 10^6 take minutes
MAX_FREQUENCIES = 10**6


def _check_frequencies(n_s: int, per_frequency: int, where: str) -> None:
    """Refuse ``n_s`` frequencies above :data:`MAX_FREQUENCIES`, or transfer matrices that would not fit in memory.

    Parameters
    ----------
    n_s : int
        Number of frequencies.
    per_frequency : int
        Complex entries stored per frequency.
    where : str
        The function, for the message.
    """
    from .. import memory

    if n_s > MAX_FREQUENCIES:
        raise ModelError(f"{where}: {n_s:.3g} frequencies, more than the {MAX_FREQUENCIES:,} one response "
                         "evaluates (each costs a solve); pass fewer, e.g. n=400 log-spaced")
    need, room = 16.0 * n_s * max(per_frequency, 1), memory.limit()
    if need > room:
        raise ModelError(f"{where}: the response at {n_s:,} frequencies needs {memory._size(need)}, more than the "
                         f"{memory._size(room)} available; pass fewer frequencies")

__all__ = ["StateSpace", "state_space", "EQUILIBRIUM_TOL"]

#: largest independent acceleration ``|M^-1 F|`` at the state linearised about, before
#: :func:`state_space` warns that the state is not an equilibrium (units of zdd)
EQUILIBRIUM_TOL = 1e-6


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

        Raises
        ------
        ModelError
            If there are more than :data:`MAX_FREQUENCIES` values of ``s``, or
            the transfer matrices would not fit in memory.
        """
        s = np.atleast_1d(np.asarray(s, dtype=complex))
        _check_frequencies(s.shape[0], self.C.shape[0] * self.B.shape[1], "StateSpace.response")
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

        python-control reserves ``'.'`` in input and output names (it
        separates a subsystem from its signal in ``interconnect``), while
        flexmb's default names use it (``'arm.j0.My'``, ``'hub.angle'``):
        there each ``'.'`` becomes ``'_'``. The state names keep theirs.

        Returns
        -------
        control.StateSpace
            A, B, C, D with ``inputs``, ``outputs`` and ``states`` as its signal labels.

        Raises
        ------
        ModelError
            If python-control is not installed, or two input or two output
            names become the same once ``'.'`` is replaced (name them).
        """
        try:
            import control
        except ImportError as exc:
            raise ModelError("to_control needs python-control: pip install 'flexmb[control]'") from exc
        labels = {}
        for kind, names in (("input", self.inputs), ("output", self.outputs)):
            labels[kind] = [n.replace(".", "_") for n in names]
            if len(set(labels[kind])) < len(labels[kind]):
                raise ModelError(f"to_control: the {kind} names {list(names)} are not unique once '.' becomes '_' "
                                 f"(python-control does not allow '.'); give them names")
        return control.ss(self.A, self.B, self.C, self.D, inputs=labels["input"], outputs=labels["output"],
                          states=list(self.states))


# ----------------------------------------------------------------------------- resolving names

def _about(system, about):
    """``(x0, xd0, t)`` from None, ``(x0, xd0[, t])`` or ``(result, t)``."""
    nq, n = system.n_coords, system.n_speeds
    if about is None:
        return system.layout.reference(), np.zeros(n), 0.0
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
    x0 = state_vector("state_space", "about's x0", first, nq)
    xd0 = state_vector("state_space", "about's xd0", about[1], n)
    t = state_time("state_space", about[2]) if len(about) == 3 else 0.0
    return x0, xd0, t


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
    system = as_system(system)
    x0, xd0, t = _about(system, about)
    for kind, given in (("inputs", inputs), ("outputs", outputs)):
        if not isinstance(given, (list, tuple)):
            raise ModelError(f"state_space: {kind} must be a list of names or {kind[:-1].capitalize()}s, got "
                             f"{type(given).__name__} {given!r:.60}")
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
    Q = np.array([_input_force(system, kin, s) for s in ins]).reshape(len(ins), system.n_speeds).T
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
