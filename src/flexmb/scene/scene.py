"""The :class:`Scene`: a model with its initial state, solver settings and outputs."""

from __future__ import annotations

from typing import Any

import numpy as np
from attrs import define, evolve, field

from .settings import InitialState, OutputSettings, SolverSettings

__all__ = ["Scene"]


@define
class Scene:
    """A model with its initial state, solver settings and outputs, as read from a scene file.

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    name : str
        Scene name (``[model] name``).
    model : Model
        The model.
    initial : InitialState
        Initial conditions.
    solver : SolverSettings
        Solver settings.
    output : OutputSettings
        What :meth:`run` writes.
    source : str
        The file the scene came from (for messages).
    types : dict of str to str
        Plugin name of each body, joint, force and constraint element, by
        element name, and by its table (``"bodies.crank"``, ``"joints.A"``),
        which tells apart a body and a joint that share a name.
    runs : dict of str to Scene
        The scene's ``[runs]``, in file order: each the scene with some keys
        replaced. :meth:`run` runs each of them in turn into one folder
        (empty: the scene runs once).

    See Also
    --------
    load_scene : Read a scene file.
    """

    name: str
    model: Any
    initial: InitialState
    solver: SolverSettings
    output: OutputSettings
    source: str = "<scene>"
    types: dict = field(factory=dict)
    runs: dict = field(factory=dict)
    #: the systems built of ``model``, by complement (see :meth:`system`); not a parameter
    _built: dict = field(factory=dict, init=False, repr=False, eq=False)

    def settings(self, **overrides) -> SolverSettings:
        """The solver settings with some replaced (``None`` values are ignored).

        Parameters
        ----------
        **overrides
            Fields of :class:`SolverSettings`.

        Returns
        -------
        SolverSettings
            The settings used.
        """
        return evolve(self.solver, **{k: v for k, v in overrides.items() if v is not None})

    def system(self, complement: str | None = None):
        """Compile the model (:meth:`flexmb.Model.build`), once per complement strategy.

        The scene's checks, its run and ``info`` share the system (a model
        of 100,000 segments takes seconds to build); a scene whose ``model``
        is replaced builds anew.

        Parameters
        ----------
        complement : str, optional
            Complement strategy (default: the scene's).

        Returns
        -------
        System
            The compiled system.
        """
        complement = complement or self.solver.complement
        key = (id(self.model), complement if isinstance(complement, str) else id(complement))
        model, system = self._built.get(key, (None, None))
        if model is not self.model:
            system = self.model.build(complement=complement)
            self._built[key] = (self.model, system)
        return system

    def initial_state(self, system=None):
        """Consistent initial coordinates and speeds (:func:`flexmb.initial_state`).

        Parameters
        ----------
        system : System, optional
            Compiled model (default: :meth:`system`).

        Returns
        -------
        x0, xd0 : ndarray, shape (n,)
            The assembled state.
        """
        from ..simulate import initial_state

        system = system or self.system()
        return initial_state(system, 0.0, self.initial.positions, self.initial.speeds_given(),
                             fixed=list(self.initial.fixed) or None, hold_speeds=self.initial.hold_speeds)

    def simulate(self, progress: bool | None = False, **overrides):
        """Simulate the scene.

        Parameters
        ----------
        progress : bool, optional
            Progress bar on stderr.
        **overrides
            Fields of :class:`SolverSettings` to replace (``t_end``, ``rtol``,
            ``method``, ``complement``, ``n_out``, ...).

        Returns
        -------
        Result
            The result; ``status`` is ``'interrupted'`` if the run was
            stopped with Ctrl-C (the outputs computed so far are kept).

        Raises
        ------
        SimulationError
            If the run fails; ``.result`` holds the partial result.
        """
        from ..simulate import simulate

        s = self.settings(**overrides)
        return simulate(self.system(s.complement), s.t_end, positions=self.initial.positions,
                        speeds=self.initial.speeds_given(),
                        fixed=list(self.initial.fixed) or None, hold_speeds=self.initial.hold_speeds, n_out=s.n_out,
                        method=s.method, rtol=s.rtol, atol=s.atol, complement=s.complement,
                        projection_tol=s.projection_tol, max_step=s.max_step, progress=progress,
                        track_work=s.track_work)

    def track(self, result) -> dict:
        """Trajectories of the ``[output.points]`` of the scene.

        Parameters
        ----------
        result : Result
            A result of this scene.

        Returns
        -------
        dict of str to ndarray, shape (nt, 3)
            Inertial positions of each tracked point, m.
        """
        from ..flexible import FlexibleBody

        out = {}
        for label, (body_name, point) in self.output.points.items():
            body = self.model[body_name]
            p = np.asarray(point, dtype=float)
            if isinstance(body, FlexibleBody):
                i, local = body.locate(p)
                row = result.flexible[body_name][0][i]
            else:
                row, local = result.body_names.index(body_name), p
            out[label] = result.origins[:, row] + result.rotations[:, row] @ local
        return out

    def run(self, out, progress: bool = True, overwrite: bool = False, **overrides) -> dict:
        """Simulate and write the outputs: ``.npz`` result, ``summary.json``, plots and VTK.

        A scene with ``[runs]`` runs each of them in turn, with the same
        overrides, into the one folder (see ``docs/scenes.md``, "Runs").
        A run stopped with Ctrl-C writes what it computed so far (the summary
        says ``"status": "interrupted"``); a failed run writes its partial
        result and then raises. The folder is locked for the whole run (a
        second run into it is refused) and the new files replace the previous
        run's only once all are written, ``summary.json`` last; files of the
        previous run that this one does not write are removed (see
        ``docs/scenes.md``, "Output folders"). A folder holding the outputs
        of another scene is refused before anything runs, unless
        ``overwrite``.

        Parameters
        ----------
        out : str or path-like
            Output folder (created).
        progress : bool
            Progress bar on stderr.
        overwrite : bool
            Replace the outputs of another scene's run in ``out``.
        **overrides
            Fields of :class:`SolverSettings` to replace.

        Returns
        -------
        dict
            The summary (also written to ``out/summary.json``); the files
            it names are paths relative to ``out``.

        Raises
        ------
        SimulationError
            If the run fails (after writing the partial outputs).
        ExportError
            If another run is writing into ``out`` (the message names its
            pid), or ``out`` holds another scene's outputs and ``overwrite``
            is False.
        """
        from .outputs import run_into

        return run_into(self, out, progress, overrides, overwrite=overwrite)

    def info(self) -> str:
        """Describe the scene: bodies, joints, coordinates, constraints, redundancy, freedoms.

        Returns
        -------
        str
            A text report (what ``flexmb info`` prints).
        """
        from .._describe import describe
        from ..simulate import _choose_method

        system = self.system()
        x0, xd0 = self.initial_state(system)
        lines = [f"scene {self.source}: model {self.name!r}", *describe(system, x0, xd0, types=self.types)]
        w = system.fastest_rate(0.0, x0, xd0)
        s = self.solver
        if w > 0:
            steps = s.t_end * w / 3.0
            atol = s.rtol / 100 if s.atol is None else s.atol
            method, reason = _choose_method(system, 0.0, s.t_end, x0, xd0, s.rtol, atol, log=False)
            lines.append(f"stiffness: highest spring frequency {system.highest_frequency(0.0, x0, xd0):.4g} rad/s, "
                         f"fastest rate with the dampers {w:.4g} rad/s; an explicit integrator needs about "
                         f"{steps:.3g} steps over {s.t_end:g} s to stay stable, so 'auto' picks "
                         f"{getattr(method, '__name__', method)}")
            lines.append(f"  ({reason})")
        else:
            lines.append("stiffness: no springs on coordinates; 'auto' picks DOP853 (explicit)")
        lines.append(f"solver: t_end {s.t_end:g} s, method {s.method}, rtol {s.rtol:g}, n_out {s.n_out}, "
                     f"complement {s.complement}")
        return "\n".join(lines)
