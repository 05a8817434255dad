"""Exceptions raised by flexmb.

Every error flexmb raises on purpose derives from :class:`FlexmbError`, so a
caller can catch them all at once; the subclasses tell where it happened.
"""

from __future__ import annotations

__all__ = ["FlexmbError", "ModelError", "AssemblyError", "SimulationError", "ExportError", "PluginError", "SceneError",
           "StiffnessWarning", "GimbalLockWarning"]


class FlexmbError(Exception):
    """Base class of all errors raised by flexmb."""


class ModelError(FlexmbError, ValueError):
    """A model definition is invalid (raised at build time).

    Parameters
    ----------
    message : str
        What is wrong, naming the element.
    problems : list of str, optional
        All problems found, when several were collected at once.
    """

    def __init__(self, message: str, problems: list[str] | None = None):
        super().__init__(message)
        self.problems = list(problems) if problems else [message]


class AssemblyError(FlexmbError):
    """The constraints cannot be satisfied or the equations cannot be solved."""


class SimulationError(FlexmbError):
    """A simulation failed; the states computed so far are kept.

    Parameters
    ----------
    message : str
        The cause, with the time of failure.
    t : float
        Time at which the failure was detected, in s.
    result : Result or None
        The partial result up to the failure.
    """

    def __init__(self, message: str, t: float = float("nan"), result=None):
        super().__init__(message)
        self.t = t
        self.result = result


class ExportError(FlexmbError, ValueError):
    """A result or state cannot be exported or drawn (bad fields, index or file).

    Raised with one argument, the message: what is wrong, naming the field or
    argument.
    """


class PluginError(FlexmbError):
    """A plugin cannot be found, loaded or registered.

    Raised for an unknown name, a plugin that fails to import, an object that
    is not a subclass of its kind's base class, or a name claimed by two
    distributions. The message names the plugin, its distribution and the
    cause.
    """


class SceneError(ModelError):
    """A scene file is invalid: bad TOML, a missing or unknown key, a wrong value.

    The message starts with the file and the key path of the offending entry,
    e.g. ``scene.toml: joints.pin.axis: must have 3 components, got 2``.

    Parameters
    ----------
    message : str
        ``"<file>: <key path>: <what is wrong>"``.
    key_path : str
        Dotted key path of the offending entry (empty when the whole file is
        at fault, e.g. a TOML syntax error).
    """

    def __init__(self, message: str, key_path: str = ""):
        super().__init__(message)
        self.key_path = key_path


class GimbalLockWarning(UserWarning):
    """A joint in Bryant angles came close to gimbal lock during a run (:mod:`flexmb.gimbal`).

    Its middle angle ry within ``GIMBAL_MARGIN_DEG`` of +-90 deg: the
    angles' rates grow without bound there and the steps shrink. The
    remedy named: ``rotation='quaternion'`` (Euler parameters).
    """


class StiffnessWarning(UserWarning):
    """A run spends its steps on stiffness or on vibrations far above the scene's motion.

    Issued by :func:`flexmb.simulate` in three cases, each naming the
    frequency and the remedy:

    - before the run, when ``method`` is an explicit Runge-Kutta method
      ('RK45', 'RK23', 'DOP853') and the highest natural frequency of the
      coordinate springs (:meth:`System.highest_frequency`) would force more
      than ``EXPLICIT_STEP_LIMIT`` steps just to stay stable (remedy:
      'CVODE_BDF', 'Radau' or ``method='auto'``);
    - once, early in the run (after 100 steps or a few hundred), when an
      error-controlled method resolves nearly undamped modes far above the
      scene's motion and would take over 10 000 steps at that rate
      (:class:`flexmb.integrators.monitor.ResolutionMonitor`; remedy:
      ``method='auto'`` or :func:`flexmb.generalized_alpha` with a step
      floor, which dissipate them, or 'Radau' where they are hardly
      excited);
    - once, during the run, when a contact is held over thousands of steps
      a hundredth or less of those taken off contact
      (:mod:`flexmb.contact_events`; remedy: an implicit method for an
      explicit one, a softer or damped normal law, or a step floor).

    Turn it into an error with
    ``warnings.simplefilter("error", flexmb.StiffnessWarning)``.
    """
