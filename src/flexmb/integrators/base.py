"""What an integrator can use, declared as class attributes; scipy's solvers described by a table.

An integrator is a :class:`scipy.integrate.OdeSolver` subclass (the base
class of the ``flexmb.integrators`` plugin kind). :func:`flexmb.simulate`
does not recognise integrators by identity: it reads what each one can use
from these class attributes,

``explicit``
    An explicit method, whose step is bounded by stability on stiff scenes
    (simulate warns, :class:`~flexmb.errors.StiffnessWarning`).
``uses_jacobian``
    The constructor takes ``jac``, a callable ``jac(t, y)`` returning the
    state Jacobian; simulate passes the analytic one when the model has it.
``second_order``
    The constructor takes ``n_second = n`` and then exploits the block form
    ``[[0, I], [Jx, Jv]]`` of the Jacobian of ``y = (x, xd, ...)``.
``has_dense_output``
    ``dense_output()`` gives the state between the last two steps (simulate
    needs it for its output times).
``needs_n_second``
    The method itself is written for ``y = (x, xd, ...)``: the constructor
    always takes ``n_second``, with or without a Jacobian
    (:class:`~flexmb.GeneralizedAlpha`); for a model whose coordinates are
    not the speeds' integrals (Euler parameters, ``qd = W(q) u``) also
    ``layout``, the :class:`~flexmb.state_layout.StateLayout` of ``y = (q,
    u, ...)``.
``cheap_restart``
    A restart from a projected state costs no more than a step (one-step
    methods). False for multistep methods that fall back to order one
    (CVODE): simulate then projects their state only when the constraint
    residual exceeds ``RESTART_ATOL_FACTOR * atol`` (at most
    ``RESTART_TOL_MAX``), and restart them without a first step (they
    choose it at the projected state; a cheap restart continues with the
    last step); the stored outputs are projected as for any integrator.
``uses_preconditioner``
    The constructor takes ``preconditioner``, a
    :class:`~flexmb.system.NewtonPreconditioner` (O(n) approximate Newton
    solves of an open tree) and then needs no Jacobian matrix; simulate
    passes one for open trees of ``KRYLOV_MIN_COORDS`` coordinates or more
    (:class:`~flexmb.integrators.CVODEBDF`).
``advances``
    The solver has ``advance(t, on_step=None)``: it steps until ``t`` (at
    most ``t_bound``) is reached, calling ``on_step(solver)`` after each
    step if given, returns the state at ``t`` and counts its steps in
    ``n_steps``. simulate uses it between the output times of a
    model without constraints, where nothing is checked or projected after
    a step (:class:`~flexmb.integrators.CVODE`).
``rebases``
    The solver has ``rebase(shift)``: it moves the origin of its state,
    ``y -> y - shift``, with its history and interpolant, the motion
    unchanged (the right-hand side is told of the shift). simulate moves
    the offsets of winding angles so (:mod:`flexmb.stepping`); an
    integrator without it is restarted from the moved state instead
    (:class:`~flexmb.GeneralizedAlpha` rebases, keeping its memory).
``moves``
    The solver has ``move_to(y)``: it continues from a state moved off
    the end of its last step (a projection onto the constraints), keeping
    its history, with no new solver. simulate then projects its state only
    past its own tolerance (``atol`` on ``|phi|``, ``atol / h`` on ``|psi
    xd - b|``, :meth:`flexmb.stepping.Run._restart_if_drifted`); any other
    integrator is restarted from the projected state
    (:class:`~flexmb.GeneralizedAlpha` moves).
``finds_roots``
    The constructor takes ``events = (g, m, direction)``, a function
    ``g(t, y)`` returning m values and the direction of the crossings to
    watch in each (+1 rising, -1 falling, 0 both), and each step ends at
    the first such sign change of any of them within it (CVODE's root
    finding), with ``root`` the array of
    the m directions that changed there (``+1`` rising, ``-1`` falling, 0
    unchanged) or None after a step that met none. simulate locates
    contact onsets and separations so (:mod:`flexmb.contact_events`); for
    any other integrator it locates them itself on the dense output.
``limits_order``
    The constructor takes ``max_order``, the largest order of a
    variable-order method; simulate lowers it where the higher orders cost
    steps (:data:`flexmb.stepping.OSCILLATION_MAX_ORDER`;
    :class:`~flexmb.integrators.CVODEBDF`).

flexmb's own integrators declare them; scipy's get them from
:data:`SCIPY_CAPABILITIES` (looked up along the class's bases, so a subclass
of ``RK45`` is explicit too), and Radau and BDF are replaced by their
second-order variants (:data:`SCIPY_ADAPTERS`), which are scipy's solvers
unchanged when no Jacobian is given. Both tables name scipy's classes as
:mod:`scipy.integrate` exports them (``"RK45"``): this module imports no
scipy, so that a run that never uses scipy's solvers does not import
scipy.integrate (and scipy.optimize, scipy.special and scipy.linalg with
it) to look its own integrator up.
"""

from __future__ import annotations

import contextlib
import importlib
import weakref

import attrs
from attrs import frozen

__all__ = ["Capabilities", "SCIPY_CAPABILITIES", "SCIPY_ADAPTERS", "capabilities", "adapt", "scipy_name"]


@frozen
class Capabilities:
    """What an integrator class can use (see the module docstring).

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    explicit : bool
        An explicit method (stability-limited on stiff scenes).
    uses_jacobian : bool
        Takes ``jac=`` (a callable ``jac(t, y)``).
    second_order : bool
        Takes ``n_second=`` and exploits the Jacobian's block form
        ``[[0, I], [Jx, Jv]]``.
    has_dense_output : bool
        ``dense_output()`` interpolates over the last step.
    needs_n_second : bool
        Always takes ``n_second=`` (a method for second-order systems).
    uses_preconditioner : bool
        Takes ``preconditioner=`` (a Krylov-solved implicit method).
    cheap_restart : bool
        A restart after a projection is cheap (see the module docstring).
    advances : bool
        Has ``advance(t)``: steps to ``t`` without simulate's per-step checks.
    rebases : bool
        Has ``rebase(shift)``: moves the origin of its state in place.
    moves : bool
        Has ``move_to(y)``: continues in place from a projected state.
    finds_roots : bool
        Takes ``events=(g, m, direction)`` and ends a step at the first root of ``g``.
    limits_order : bool
        Takes ``max_order=`` (a variable-order method's largest order).

    Examples
    --------
    >>> from flexmb.integrators import Capabilities
    >>> Capabilities(explicit=True).uses_jacobian
    False
    """

    explicit: bool = False
    uses_jacobian: bool = False
    second_order: bool = False
    has_dense_output: bool = True
    needs_n_second: bool = False
    uses_preconditioner: bool = False
    cheap_restart: bool = True
    advances: bool = False
    rebases: bool = False
    moves: bool = False
    finds_roots: bool = False
    limits_order: bool = False


#: scipy's solvers, which declare nothing themselves, by their name in scipy.integrate (:func:`scipy_name`).
#: LSODA could take a Jacobian too; it is left without, as before, so its results do not change.
SCIPY_CAPABILITIES = {
    "RK45": Capabilities(explicit=True),
    "RK23": Capabilities(explicit=True),
    "DOP853": Capabilities(explicit=True),
    "Radau": Capabilities(uses_jacobian=True),
    "BDF": Capabilities(uses_jacobian=True),
    "LSODA": Capabilities(),
}

#: the class simulate instantiates for a scipy solver asked for by name or class: scipy's name -> the
#: ``module:qualname`` of flexmb's variant (imported when asked for)
SCIPY_ADAPTERS = {"Radau": "flexmb.integrators.second_order:SecondOrderRadau",
                  "BDF": "flexmb.integrators.second_order:SecondOrderBDF"}


def scipy_name(solver_cls: type) -> str | None:
    """The name scipy.integrate exports ``solver_cls`` under, if ``solver_cls`` is one of its classes, else None.

    Read from the class itself (its module and name), without importing
    scipy: a class defined by scipy.integrate has it imported already.

    Parameters
    ----------
    solver_cls : type
        Any class.

    Returns
    -------
    str or None
        ``solver_cls.__name__`` for a class defined in a scipy.integrate module
        and exported by it, else None.

    Examples
    --------
    >>> from scipy.integrate import RK45
    >>> from flexmb.integrators.base import scipy_name
    >>> scipy_name(RK45), scipy_name(int)
    ('RK45', None)
    """
    module = getattr(solver_cls, "__module__", None) or ""
    if not module.startswith("scipy.integrate"):
        return None
    name = getattr(solver_cls, "__name__", "")
    exported = getattr(importlib.import_module("scipy.integrate"), name, None)
    return name if exported is solver_cls else None


def capabilities(solver_cls: type) -> Capabilities:
    """What ``solver_cls`` can use: its class attributes, else scipy's table, else the defaults (read once per class).

    Parameters
    ----------
    solver_cls : type
        An :class:`scipy.integrate.OdeSolver` subclass.

    Returns
    -------
    Capabilities
        The attributes the class (or a base) declares, the entry of its
        nearest base in :data:`SCIPY_CAPABILITIES` for the others, and the
        defaults of :class:`Capabilities` for the rest.

    Examples
    --------
    >>> from scipy.integrate import DOP853
    >>> from flexmb.integrators import capabilities
    >>> capabilities(DOP853).explicit
    True
    """
    try:
        return _CAPABILITIES[solver_cls]
    except (KeyError, TypeError):  # (TypeError: not weakly referable, worked out every time)
        pass
    found = next((SCIPY_CAPABILITIES[name] for name in map(scipy_name, getattr(solver_cls, "__mro__", ()))
                  if name in SCIPY_CAPABILITIES), Capabilities())
    declared = {a.name: bool(getattr(solver_cls, a.name)) for a in attrs.fields(Capabilities)
                if hasattr(solver_cls, a.name)}
    caps = attrs.evolve(found, **declared)
    with contextlib.suppress(TypeError):
        _CAPABILITIES[solver_cls] = caps
    return caps


#: :func:`capabilities` of the classes asked about so far (a class's declarations are read once)
_CAPABILITIES: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def adapt(solver_cls: type) -> type:
    """The class to instantiate for ``solver_cls``: scipy's Radau and BDF become their second-order variants.

    Parameters
    ----------
    solver_cls : type
        An :class:`scipy.integrate.OdeSolver` subclass.

    Returns
    -------
    type
        :class:`SecondOrderRadau` for ``Radau``, :class:`SecondOrderBDF` for
        ``BDF`` (both scipy's solvers unchanged unless given ``n_second``),
        ``solver_cls`` itself otherwise.

    Examples
    --------
    >>> from scipy.integrate import Radau
    >>> from flexmb.integrators import adapt
    >>> adapt(Radau).__name__
    'SecondOrderRadau'
    """
    adapter = SCIPY_ADAPTERS.get(scipy_name(solver_cls))
    if adapter is None:
        return solver_cls
    module, _, qualname = adapter.partition(":")
    return getattr(importlib.import_module(module), qualname)
