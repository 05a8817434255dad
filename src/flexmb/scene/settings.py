"""The settings a scene file holds besides its model: ``[solver]``, ``[output]``, ``[initial]``, and the section table."""

from __future__ import annotations

import math
import re

from attrs import field, frozen

from ..errors import SceneError

__all__ = ["SECTIONS", "STUDY_KEYS", "InitialState", "OutputSettings", "SolverSettings"]

#: top-level tables of a scene file and what each holds
SECTIONS = {
    "model": "name and default complement strategy",
    "materials": "named materials for flexible bodies",
    "sections": "named beam cross-sections",
    "bodies": "rigid and flexible bodies by plugin name",
    "joints": "joints by plugin name",
    "forces": "force elements by plugin name",
    "constraints": "constraint elements by plugin name (rolling, knife edges, gears, a user's rows)",
    "drivers": "prescribed joint motions",
    "initial": "initial positions, speeds (of coordinates, points and bodies) and held coordinates",
    "solver": "end time, integrator, tolerances, outputs times, complement",
    "output": "files to write and points to track",
    "study": "settings of parameter studies of the scene (time_limit per case)",
    "runs": "named runs of the scene, each with some keys replaced, written side by side into one folder",
}

#: keys of the ``[study]`` table (read by :mod:`flexmb.study`; a plain run ignores them)
STUDY_KEYS = ("time_limit",)

_TOML_TYPES = {bool: "a boolean", int: "an integer", float: "a float", str: "a string", list: "an array",
               dict: "a table"}


def _toml_type(value) -> str:
    return _TOML_TYPES.get(type(value), f"a {type(value).__name__}")


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


@frozen
class SolverSettings:
    """Settings of :func:`flexmb.simulate` read from ``[solver]``.

    Parameters
    ----------
    t_end : float
        End time, s.
    method : str
        Integrator name (``'auto'``, ``'DOP853'``, ``'Radau'``, ... or a plugin).
    rtol : float
        Relative tolerance.
    atol : float or None
        Absolute tolerance (default ``rtol / 100``).
    n_out : int
        Number of equally spaced output times.
    complement : str
        Orthogonal complement strategy (``'svd'``, ``'eigen'`` or a plugin).
    projection_tol : float
        Largest constraint residual tolerated before projecting.
    max_step : float
        Largest step, s.
    track_work : bool
        Integrate the work of drivers and force classes (``Result.work``).
    """

    t_end: float
    method: str = "auto"
    rtol: float = 1e-8
    atol: float | None = None
    n_out: int = 201
    complement: str = "svd"
    projection_tol: float = 1e-10
    max_step: float = math.inf
    track_work: bool = False


def _prefix_problem(prefix) -> str | None:
    """What is wrong with an output file-name stem, or None.

    A stem starts with a letter, digit or underscore and holds only those and
    ``.`` and ``-``: no folder, no hidden file (``.x``, ``..``), nothing a
    shell would read as an option.
    """
    if not isinstance(prefix, str):
        return f"must be a string, got {_toml_type(prefix)}"
    if len(prefix) > 200 or not re.fullmatch(r"\w[\w.\-]*", prefix):
        return (f"must be a plain file-name stem (letters, digits, _ . -, starting with a letter, digit or _), "
                f"got {prefix!r}")
    return None


def _check_prefix(instance, attribute, value) -> None:
    problem = _prefix_problem(value)
    if problem:
        raise SceneError(f"output.prefix: {problem}", "output.prefix")


@frozen
class OutputSettings:
    """What ``Scene.run`` writes, read from ``[output]``.

    Parameters
    ----------
    npz, summary, plots, vtk : bool
        Write the result (``<name>.npz``), ``summary.json``, ``<name>.png``
        and the VTK series (``vtk/<name>.pvd``).
    prefix : str
        File-name stem (default: the model name): letters, digits, ``_``,
        ``.`` and ``-``, starting with a letter, digit or ``_``.
    points : dict of str to (str, tuple of float)
        Points to track: ``{label: (body name, point in the body frame, m)}``.
    figure : str
        The plot drawn, a name of :data:`flexmb.scene.figures.FIGURES`
        (default ``'scene'``).
    metrics : dict of str to str
        Named outputs of :data:`flexmb.study.OUTPUTS` written into the
        summary of each run: ``{summary key: output}``, e.g.
        ``{"peak_crank_torque_N_m": "peak_effort:motor"}``.

    Raises
    ------
    SceneError
        If ``prefix`` is not a plain file-name stem (the message names it).
    """

    npz: bool = True
    summary: bool = True
    plots: bool = True
    vtk: bool = True
    prefix: str = field(default="scene", validator=_check_prefix)
    points: dict = field(factory=dict)
    figure: str = "scene"
    metrics: dict = field(factory=dict)


@frozen
class InitialState:
    """Initial conditions read from ``[initial]`` (see :func:`flexmb.initial_state`).

    Parameters
    ----------
    positions, speeds : dict
        ``{coordinate or joint name: value}``, rad or m and rad/s or m/s.
    fixed : tuple of str
        Coordinates held at their given values while the loops are closed.
    hold_speeds : bool
        True (default): the speeds given are kept, and speeds that
        contradict a driver or a constraint are refused naming both; False:
        the constraints and drivers win, the speeds given are the closest
        they allow (see :func:`flexmb.initial_state`).
    point_velocities : dict of str to PointVelocity
        ``[initial.point_velocities.<label>]``: velocities of points held as
        the coordinate speeds are, by label.
    angular_velocities : dict of str to AngularVelocity
        ``[initial.angular_velocities.<label>]``: angular velocities of
        bodies, by label.
    """

    positions: dict = field(factory=dict)
    speeds: dict = field(factory=dict)
    fixed: tuple = ()
    hold_speeds: bool = True
    point_velocities: dict = field(factory=dict)
    angular_velocities: dict = field(factory=dict)

    def speeds_given(self):
        """The ``speeds`` argument of :func:`flexmb.initial_state` and :func:`flexmb.simulate`.

        Returns
        -------
        dict or list
            The coordinate speeds alone, or a list of them followed by the
            point and angular velocities.
        """
        motions = [*self.point_velocities.values(), *self.angular_velocities.values()]
        return [self.speeds, *motions] if motions else self.speeds

    def gives_speeds(self) -> bool:
        """Whether any speed is given (coordinate speeds, point or angular velocities).

        Returns
        -------
        bool
            True if ``[initial]`` gives a speed of any kind.
        """
        return bool(self.speeds or self.point_velocities or self.angular_velocities)
