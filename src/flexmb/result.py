"""The Result of a simulation: time histories and counters."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from attrs import define, field

from ._files import atomic_write
from ._names import name_of
from .bodies import Body
from .drivers import Driver
from .errors import FlexmbError, ModelError
from .joints import Joint
from .output_quantities import evaluate_states
from .post.accessors import ResultPost

__all__ = ["Result"]

_ARRAYS = ("t", "x", "xd", "xdd", "positions", "origins", "rotations", "kinetic", "potential",
           "residual", "velocity_residual", "reactions")
_LISTS = ("coordinate_names", "body_names", "constraint_labels", "driver_names")
_SCALARS = ("n_dof", "n_rhs", "n_jac", "n_steps", "n_complements", "n_projections", "n_cvode_projections",
            "n_rebases", "n_refused", "wall_time",
            "status", "message", "method", "complement", "method_reason", "rtol")


@define
class Result(ResultPost):
    """Time histories of a simulation.

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    t : ndarray, shape (nt,)
        Output times, s.
    x : ndarray, shape (nt, nq)
        Generalized coordinates q.
    xd, xdd : ndarray, shape (nt, n)
        Generalized speeds u and their rates (:mod:`flexmb.state_layout`:
        ``qd = W(q) u``; for joints whose speeds are their coordinates'
        rates, as every joint's today, ``W = I`` and ``xd`` is the rate of
        ``x``).
    positions : ndarray, shape (nt, n_bodies, 3)
        Mass-centre positions, m.
    origins : ndarray, shape (nt, n_bodies, 3)
        Body-frame origins, m.
    rotations : ndarray, shape (nt, n_bodies, 3, 3)
        Body rotation matrices (body -> inertial).
    kinetic, potential : ndarray, shape (nt,)
        Kinetic and potential energy, J.
    residual : ndarray, shape (nt,)
        max ``|phi|`` (eq. 28), m or rad.
    velocity_residual : ndarray, shape (nt,)
        max ``|psi xd - b|`` (eq. 29).
    reactions : ndarray, shape (nt, m)
        Constraint multipliers, labelled by ``constraint_labels``.
    coordinate_names : list of str
        ``"joint.coordinate"`` per column of ``x``.
    body_names : list of str
        Body names, one per row of ``positions``, ``origins`` and
        ``rotations``.
    constraint_labels : list of str
        One label per constraint row (column of ``reactions``).
    driver_names : list of str
        Names of the model's drivers.
    flexible : dict of str to (list of int, float)
        For each flexible body, its segments' rows in the per-body arrays and
        the segment length l = L / N, m (used by :meth:`shape`).
    n_dof : int
        Number of independent speeds p = n - rank(psi) at the start.
    n_rhs, n_jac, n_steps, n_complements, n_rebases : int
        Work counters (right-hand sides, Jacobians, steps, complements,
        moves of the winding angles' offsets: :mod:`flexmb.stepping`).
    n_projections : int
        Projections of the state onto the constraints by the run's drift
        check after a step (:meth:`flexmb.stepping.Run._restart_if_drifted`):
        each one restarts the integrator (generalized-alpha continues in
        place). The output states' projection is not counted.
    n_cvode_projections : int
        Projections made by CVODE itself (its ``CVodeSetProjFn`` step,
        after the corrector), counted where they moved the state: on the
        compiled loops' BDF where the run holds it to order 3 (flexible
        bodies in loops, rtol >= 1e-4:
        :class:`~flexmb.integrators.cvode_direct_loops.DirectLoopCVODE`),
        which then keeps the state on the constraints without restarts; 0
        elsewhere. A projection CVODE's callback refuses (not converged,
        too large) leaves the state to the drift check
        (``n_projections``).
    n_refused : int
        Steps refused because they carried a touching body through its
        surface, and taken again shorter (:mod:`flexmb.contact_events`).
    wall_time : float
        Wall-clock time of the integration, s.
    work : dict of str to ndarray, shape (nt,)
        With ``simulate(..., track_work=True)``: work done since the start
        by each driver (``"driver <name>"``) and each class of force
        elements, J.
    status : {'finished', 'failed', 'interrupted', 'running'}
        How the run ended; ``message`` says why.
    message : str
        Why the run ended as it did (``"reached t_end"`` when it finished).
    method : str
        Name of the integrator used (after ``'auto'`` chose one).
    method_reason : str
        With ``method='auto'``: why it chose that integrator, and for a
        dissipative one the step floor and the damping it adds to the modes
        it dissipates (empty otherwise).
    complement : str
        Name of the complement strategy used.
    rtol : float
        The relative tolerance the integrator was given (0 where none was).
    contact_events : list of (float, str, str, float)
        The contacts' onsets and separations located during the run,
        ``(time, contact name, 'onset' or 'separation', rate)`` in time
        order, with the rate of penetration there (m/s: the impact speed at
        an onset, minus the speed of separation at a separation)
        (:mod:`flexmb.contact_events`; empty without contacts);
        :attr:`n_contact_onsets` and :attr:`n_contact_separations` count
        them.
    system : System, optional
        The compiled model the result came from (set by
        :func:`~flexmb.simulate`), so that bodies can be given by name to
        :meth:`section_loads` and the like. Neither saved by :meth:`save`
        nor pickled.
    """

    t: np.ndarray
    x: np.ndarray
    xd: np.ndarray
    xdd: np.ndarray
    positions: np.ndarray
    origins: np.ndarray
    rotations: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    residual: np.ndarray
    velocity_residual: np.ndarray
    reactions: np.ndarray
    coordinate_names: list = field(factory=list)
    body_names: list = field(factory=list)
    constraint_labels: list = field(factory=list)
    driver_names: list = field(factory=list)
    flexible: dict = field(factory=dict)
    work: dict = field(factory=dict)
    n_dof: int = 0
    n_rhs: int = 0
    n_jac: int = 0
    n_steps: int = 0
    n_complements: int = 0
    n_projections: int = 0
    n_cvode_projections: int = 0
    n_rebases: int = 0
    wall_time: float = 0.0
    status: str = "running"
    message: str = ""
    method: str = ""
    method_reason: str = ""
    complement: str = ""
    rtol: float = 0.0
    contact_events: list = field(factory=list)
    n_refused: int = 0
    system: object = field(default=None, repr=False, eq=False)

    @property
    def n_contact_onsets(self) -> int:
        """Number of contact onsets located during the run (:attr:`contact_events`)."""
        return sum(1 for e in self.contact_events if e[2] == "onset")

    @property
    def n_contact_separations(self) -> int:
        """Number of contact separations located during the run (:attr:`contact_events`)."""
        return sum(1 for e in self.contact_events if e[2] == "separation")

    def __getstate__(self):
        # the compiled system holds the model's callables (drivers, loads), often lambdas
        return {a.name: getattr(self, a.name) for a in type(self).__attrs_attrs__ if a.name != "system"}

    def __setstate__(self, state):
        for k, v in state.items():
            object.__setattr__(self, k, v)
        object.__setattr__(self, "system", None)

    @classmethod
    def from_states(cls, system, x, xd=None, *, xdd=None, t=0.0, **fields) -> "Result":
        """A Result holding given states: the one constructor every route uses.

        :func:`~flexmb.simulate`, statics, snapshots and mode shapes build
        their results here, so that loads, stresses, plots and VTK export
        apply to them all.

        Parameters
        ----------
        system : System or Model
            The model (a Model is built with the default options).
        x : array_like, shape (nq,) or (m, nq)
            Coordinates of one or m states (e.g. from
            :func:`flexmb.linear_statics`).
        xd : array_like, shape (n,) or (m, n), optional
            Speeds (default zero).
        xdd : array_like, shape (n,) or (m, n), optional
            Accelerations; default: from the equations of motion (eqs.
            36-39), with the reactions of the same solve (a state where the
            solve fails gets NaN accelerations and reactions). Pass zeros for
            the loads that hold a configuration in equilibrium.
        t : float or array_like, shape (m,)
            Time of the states, s: one time for all (the states are then
            evaluated at ``t`` and labelled ``t, t + 1, ...`` so that they
            can be told apart and interpolated), or one per state.
        **fields
            Other attributes (counters, ``status``, ``message``, ...).

        Returns
        -------
        Result
            With positions, rotations, energies, constraint residuals,
            accelerations and constraint multipliers filled in; ``status``
            ``'finished'`` unless given.

        Raises
        ------
        FlexmbError
            If the states do not hold ``nq`` finite coordinates and ``n``
            finite speeds each.

        Examples
        --------
        >>> import flexmb as fm
        >>> model = fm.Model("pendulum")
        >>> bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
        >>> _ = model.add(bar, fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1)),
        ...               fm.Gravity((0.0, -9.81, 0.0)))
        >>> res = fm.Result.from_states(model, [[0.0], [-1.5707963267948966]])
        >>> res.positions.shape, res.t
        ((2, 1, 3), array([0., 1.]))
        >>> res.xdd[:, 0].round(3) + 0.0  # horizontal, then hanging
        array([-14.715,   0.   ])
        """
        from .model import as_system

        system = as_system(system)
        nq, n = system.n_coords, system.n_speeds
        X = np.atleast_2d(np.asarray(x, dtype=float))
        XD = np.zeros((len(X), n)) if xd is None else np.atleast_2d(np.asarray(xd, dtype=float))
        if (X.shape[1:] != (nq,) or XD.shape != (len(X), n)
                or not (np.isfinite(X).all() and np.isfinite(XD).all())):
            what = f"{n} finite coordinates" if nq == n else f"{nq} finite coordinates and {n} speeds"
            raise FlexmbError(f"x and xd must hold {what} per state, got shapes {X.shape}, {XD.shape}")
        nt = len(X)
        at = (np.array(t, dtype=float) if isinstance(t, np.ndarray) and t.shape == (nt,)  # (the same, quicker)
              else np.broadcast_to(np.asarray(t, dtype=float), (nt,)).copy())
        if not np.isfinite(at).all():
            raise ModelError(f"Result.from_states: the times must be finite, got {t!r}")
        times = at + np.arange(nt) if np.ndim(t) == 0 else at
        XDD = None if xdd is None else np.atleast_2d(np.asarray(xdd, dtype=float)).reshape(XD.shape)
        arrays = evaluate_states(system, at, X, XD, XDD, fields.get("contact_events"))
        topo = system.topology
        fields.setdefault("status", "finished")
        return cls(
            t=times, x=X.copy(), xd=XD.copy(), **arrays, coordinate_names=list(system.coordinate_names),
            body_names=list(system.body_names), constraint_labels=list(system.constraints.labels),
            driver_names=[d.name for d in system.constraints.drivers],
            flexible={b.name: ([topo.index[sg] for sg in segs], b.segment_length)
                      for b, (_, segs, _) in topo.flexible.items()},
            system=system, **fields)

    @property
    def energy(self) -> np.ndarray:
        """Total mechanical energy (kinetic + potential), J."""
        return self.kinetic + self.potential

    def _summary_rows(self) -> list[tuple[str, str]]:
        """What a notebook shows of a result: status, integrator, cost, residuals and energy."""
        t = np.asarray(self.t)
        span = f"{t[0]:.4g} ... {t[-1]:.4g} s, {len(t)} outputs" if len(t) else "no outputs"
        rows = [("status", f"{self.status}: {self.message}"), ("time", span),
                ("integrator", self.method + (f" ({self.method_reason})" if self.method_reason else "")),
                ("cost", f"{self.n_steps} steps, {self.n_rhs} right-hand sides, {self.n_jac} Jacobians, "
                         f"{self.n_projections} drift projections, "
                         + (f"{self.n_cvode_projections} CVODE projections, " if self.n_cvode_projections else "")
                         + f"{self.wall_time:.3g} s"),
                ("model", f"{len(self.coordinate_names)} coordinates, {self.n_dof} freedoms, "
                          f"{len(self.body_names)} bodies, {len(self.constraint_labels)} constraint rows")]
        if len(t) and len(self.constraint_labels):
            rows.append(("largest residuals", f"positions {np.max(self.residual):.2e}, "
                                              f"velocities {np.max(self.velocity_residual):.2e}"))
        if len(t):
            e = self.energy
            rows.append(("energy", f"{e[0]:.6g} J at the start, {e[-1]:.6g} J at the end (kinetic + potential; "
                                   "drivers and dampers change it)"))
        return rows

    def __repr__(self) -> str:
        """One screen: the rows of the notebook table and the arrays' shapes (not their values)."""
        arrays = ", ".join(f"{a} {tuple(np.shape(getattr(self, a)))}" for a in _ARRAYS)
        return "\n".join(["<flexmb Result", *(f"  {k}: {v}" for k, v in self._summary_rows()), f"  arrays: {arrays}>"])

    def _repr_html_(self) -> str:
        """A short table for Jupyter: status, times, integrator, cost, residuals, energy."""
        from html import escape

        cells = "".join(f"<tr><th style='text-align:left'>{escape(k)}</th><td style='text-align:left'>"
                        f"{escape(v)}</td></tr>" for k, v in self._summary_rows())
        return f"<table><caption style='text-align:left'><b>flexmb Result</b></caption>{cells}</table>"

    def show(self, i: int = -1, *, system=None, path=None, **options):
        """Render the mechanism at output ``i`` (pyvista, off-screen), shown inline in a notebook.

        Parameters
        ----------
        i : int
            Output index (default: the last).
        system : System or Model, optional
            The model the result came from (default: the one that made it,
            if kept): bodies drawn through their joints, coloured by stress.
        path : str or path-like, optional
            Where to write the PNG (default: a temporary file).
        **options
            Options of :class:`flexmb.viz.RenderOptions` (``scalars``,
            ``window``, ...).

        Returns
        -------
        flexmb.viz.Picture
            The PNG's path (a :class:`pathlib.Path`), shown as the picture
            when it ends a notebook cell or a sphinx-gallery block.

        Raises
        ------
        FlexmbError
            If pyvista is not installed (``pip install -e '.[viz]'``).
        """
        import tempfile

        from .viz import Picture, render_state

        if path is None:
            path = Path(tempfile.mkdtemp(prefix="flexmb_show_")) / "state.png"
        out = render_state(self, i % len(self.t), path, system=self.system if system is None else system,
                           **options)
        return Picture(out)

    def view(self, path=None, *, system=None, **options):
        """The mechanism animated in 3-D: a self-contained HTML page, shown inline in a notebook.

        A time slider, play/pause, the playing speed, colour by body, speed
        or von Mises stress, the camera turned with the mouse; no network
        and no extra needed (:mod:`flexmb.viz.viewer`).

        Parameters
        ----------
        path : str or path-like, optional
            Where to write the HTML file (default: a temporary file).
        system : System or Model, optional
            The model the result came from (default: the one that made it,
            if kept): bodies drawn through their joints, with stresses.
        **options
            ``title``, ``max_frames``, ``max_bytes``: see
            :func:`flexmb.viz.write_view`.

        Returns
        -------
        flexmb.viz.View
            The HTML file's path (a :class:`pathlib.Path`: open it in a
            browser), shown as the viewer when it ends a notebook cell.

        Raises
        ------
        ExportError
            On a bad result, system or option.
        """
        import tempfile

        from .viz.viewer import write_view

        if path is None:
            path = Path(tempfile.mkdtemp(prefix="flexmb_view_")) / "view.html"
        return write_view(self, path, system=self.system if system is None else system, **options)

    def coordinate(self, name) -> np.ndarray:
        """History of one coordinate by its name (``"joint.coordinate"``), or a joint's first coordinate.

        Parameters
        ----------
        name : str or Joint
            Coordinate name; a joint, or its name alone, selects its first
            coordinate.

        Returns
        -------
        ndarray, shape (nt,)
            Values at the output times.

        Raises
        ------
        ModelError
            If no coordinate has that name; the message lists them.
        """
        name = name_of(name, Joint, "Result.coordinate")
        names = self.coordinate_names
        if name in names:
            return self.x[:, names.index(name)]
        for i, c in enumerate(names):
            if c.rsplit(".", 1)[0] == name:
                return self.x[:, i]
        raise ModelError(f"no coordinate {name!r}; known: {names}")

    def body_position(self, name) -> np.ndarray:
        """Mass-centre position history of a body.

        Parameters
        ----------
        name : str or Body
            The body or its name.

        Returns
        -------
        ndarray, shape (nt, 3)
            Mass-centre positions, inertial, m.

        Raises
        ------
        ModelError
            If no body has that name; the message lists them.
        """
        name = name_of(name, Body, "Result.body_position")
        try:
            return self.positions[:, self.body_names.index(name)]
        except ValueError:
            raise ModelError(f"no body {name!r}; known: {self.body_names}") from None

    def shape(self, name) -> np.ndarray:
        """Deformed centre line of a flexible body: the segment ends.

        Parameters
        ----------
        name : str or FlexibleBody
            A :class:`~flexmb.FlexibleBody` or its name.

        Returns
        -------
        ndarray, shape (nt, n_segments + 1, 3)
            Inertial positions of the root, every segment joint and the tip, m.

        Raises
        ------
        ModelError
            If no flexible body has that name; the message lists them.
        """
        name = name_of(name, Body, "Result.shape")
        if name not in self.flexible:
            raise ModelError(f"no flexible body {name!r}; flexible bodies: {sorted(self.flexible)}")
        rows, l = self.flexible[name]
        rows = np.asarray(rows, dtype=int)
        ends = self.origins[:, rows]
        tip = ends[:, -1] + self.rotations[:, rows[-1], :, 0] * l
        return np.concatenate([ends, tip[:, None]], axis=1)

    def driver_effort(self, name) -> np.ndarray:
        """Torque (N m) or force (N) a driver supplies, shape (nt,).

        Parameters
        ----------
        name : str or Driver
            The driver or its name.

        Returns
        -------
        ndarray, shape (nt,)
            The effort applied to the driven coordinate.

        Raises
        ------
        ModelError
            If no driver has that name; the message lists them.
        """
        name = name_of(name, Driver, "Result.driver_effort")
        label = f"driver {name}"
        if label not in self.constraint_labels:
            raise ModelError(f"no driver {name!r}; known: {self.driver_names}")
        return self.reactions[:, self.constraint_labels.index(label)]

    def export_vtk(self, folder, **kw):
        """Write the result for ParaView: a ``.vtu`` per output time and a ``.pvd``.

        Parameters
        ----------
        folder : str or path-like
            Output folder (created if missing).
        **kw
            ``prefix``, ``system``, ``triad``: see :func:`flexmb.export.vtk.export_vtk`.

        Returns
        -------
        pathlib.Path
            The ``.pvd`` file; open it in ParaView.
        """
        from .export.vtk import export_vtk

        return export_vtk(self, folder, **kw)

    def plot(self, coords=None, path=None, **kw):
        """Time histories of coordinates (matplotlib), one axis per kind and unit; see :func:`flexmb.viz.plot`.

        Joint angles (rad), joint translations (m) and the elastic rotations
        (rad) and displacements (m) of flexible bodies each get their own
        axis, labelled with the unit.

        Parameters
        ----------
        coords : list of str or Joint, optional
            Coordinate names, or joints or their names (default all).
        path : str or path-like, optional
            Save the figure there (PNG, PDF, ... by its ending).
        **kw
            Passed to :func:`flexmb.viz.plot` (``energy=True`` adds an
            energy axis, J).

        Returns
        -------
        matplotlib.figure.Figure
            The figure.
        """
        from .viz import plot

        return plot(self, coords, path, **kw)

    def save(self, path) -> None:
        """Save to a ``.npz`` file (written to a temporary name, then renamed).

        The file gets the permissions of any other file written under the
        umask in force (:func:`flexmb._files.atomic_write`).

        Parameters
        ----------
        path : str or path-like
            Target file.
        """
        path = os.fspath(path)
        data = {k: getattr(self, k) for k in _ARRAYS}
        data.update({k: np.array(getattr(self, k), dtype=str) for k in _LISTS})
        data.update({k: np.array(getattr(self, k)) for k in _SCALARS})
        wnames = list(self.work)
        data["work_names"] = np.array(wnames, dtype=str)
        data["event_times"] = np.array([e[0] for e in self.contact_events], dtype=float)
        data["event_names"] = np.array([e[1] for e in self.contact_events], dtype=str)
        data["event_kinds"] = np.array([e[2] for e in self.contact_events], dtype=str)
        data["event_rates"] = np.array([e[3] for e in self.contact_events], dtype=float)
        for i, k in enumerate(wnames):
            data[f"work_{i}"] = self.work[k]
        names = sorted(self.flexible)
        data["flexible_names"] = np.array(names, dtype=str)
        data["flexible_lengths"] = np.array([self.flexible[k][1] for k in names], dtype=float)
        for i, k in enumerate(names):
            data[f"flexible_rows_{i}"] = np.asarray(self.flexible[k][0], dtype=int)
        atomic_write(path, lambda tmp: np.savez_compressed(tmp, **data), suffix=".npz")

    @classmethod
    def load(cls, path) -> "Result":
        """Load a result written by :meth:`save`.

        Parameters
        ----------
        path : str or path-like
            File written by :meth:`save`.

        Returns
        -------
        Result
            The result, identical to the one saved.
        """
        with np.load(path) as z:
            kw = {k: z[k] for k in _ARRAYS}
            kw.update({k: [str(s) for s in z[k]] for k in _LISTS})
            kw.update({k: z[k].item() for k in _SCALARS if k in z})  # method_reason: absent from older files
            kw["work"] = {str(k): z[f"work_{i}"] for i, k in enumerate(z["work_names"])} if "work_names" in z else {}
            if "event_times" in z:  # absent from older files
                kw["contact_events"] = [(float(t), str(n), str(k), float(r)) for t, n, k, r in
                                        zip(z["event_times"], z["event_names"], z["event_kinds"], z["event_rates"])]
            kw["flexible"] = {str(k): (z[f"flexible_rows_{i}"].tolist(), float(z["flexible_lengths"][i]))
                              for i, k in enumerate(z["flexible_names"])}
        return cls(**kw)
