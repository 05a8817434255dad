"""Run a built-in scene and write its results, plots and VTK files.

Every run writes through one :class:`flexmb._files.OutputFolder`: the
folder is locked for the run, the files are written to a hidden staging
folder inside it and swapped into place at the end, ``summary.json`` last
(see ``docs/scenes.md``, "Output folders").
"""

from __future__ import annotations

import logging

import numpy as np

from .._background import in_background
from .._files import OutputFolder, atomic_write
from ..errors import FlexmbError
from ..simulate import simulate

__all__ = ["SCENES", "run_scene", "write_outputs", "point_motion", "wiper_figure"]

log = logging.getLogger(__name__)

SCENES = ("fourbar", "wiper")


def _plt():
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        log.warning("matplotlib is not installed (pip install -e '.[viz]'): no plots written")
        return None
    return plt


def _savefig(plt, fig, folder, rel, dpi):
    """Write a figure whole (through a temporary name) into the staging folder, and close it."""
    try:
        atomic_write(folder.stage(rel), lambda tmp: fig.savefig(tmp, format="png", dpi=dpi), suffix=".png")
    finally:
        plt.close(fig)


#: the ParaView script written beside the VTK series (pvpython open_in_paraview.py)
PARAVIEW_SCRIPT = "open_in_paraview.py"


def _vtk(res, folder, sub, prefix, system, jobs=None):
    """Write the VTK series into ``sub/`` of the staging folder; return the final ``.pvd`` path or None.

    With the system the run came from: bodies drawn through their joints, exact velocities, section
    loads and stresses. The ParaView script that opens the series comes along, once per folder. Given
    a list ``jobs``, the series is written by a child process (:mod:`flexmb._background`) appended to
    it, which the caller waits for before the folder is committed.
    """
    rel = f"{sub}/{prefix}.pvd"
    try:
        import meshio  # noqa: F401  (the export's writer)

        from ..export.vtk import paraview_script
    except ImportError as exc:  # meshio missing
        log.warning("no VTK written: %s", exc)
        return None
    if not folder.staged(PARAVIEW_SCRIPT):
        paraview_script(folder.stage(PARAVIEW_SCRIPT))
    where = folder.stage(rel).parent

    def export():
        res.export_vtk(where, prefix=prefix, system=system)

    if jobs is None:
        export()
    else:
        jobs.append(in_background(export))
    return folder.final(rel)


def run_fourbar(folder, t_end=None, rtol=1e-8, complement="svd", method="auto", n_out=501, progress=True):
    """B5 four-bar: coordinates, energy drift and loop residual, staged in an open OutputFolder."""
    from .fourbar import fourbar

    model, initial, fixed = fourbar()
    system = model.build(complement=complement)
    res = simulate(system, t_end or 5.0, positions=initial, fixed=fixed, rtol=rtol, method=method, n_out=n_out,
                   progress=progress)
    res.save(folder.stage("fourbar.npz"))
    summary = {"scene": "fourbar", "status": res.status, "t_end": float(res.t[-1]), "n_rhs": res.n_rhs,
               "wall_time_s": res.wall_time, "max_residual": float(res.residual.max()),
               "energy_drift_J": float(np.ptp(res.energy))}
    plt = _plt()
    if plt:
        _savefig(plt, _fourbar_figure(res, plt), folder, "fourbar.png", 120)
    pvd = _vtk(res, folder, "vtk", "fourbar", system)
    summary["vtk"] = pvd
    if pvd:
        summary["paraview"] = folder.final(PARAVIEW_SCRIPT)
    return summary


def run_wiper(folder, t_end=None, rtol=1e-6, complement="svd", method="auto", n_out=501, progress=True,
              n_segments=6):
    """The wiper, rigid and flexible blades (Figs. 5-6 of the paper), staged in an open OutputFolder.

    Each run's VTK series is written by a child process while the next run is simulated and the plots
    are drawn (:mod:`flexmb._background`); all of it is written before this returns.
    """
    jobs = []
    try:
        return _wiper_runs(folder, jobs, t_end or 1.0, rtol, complement, method, n_out, progress, n_segments)
    finally:
        for job in jobs:
            job.wait()


def _wiper_runs(folder, jobs, t_end, rtol, complement, method, n_out, progress, n_segments):
    """The body of :func:`run_wiper`; the VTK jobs it starts are appended to ``jobs``."""
    from .wiper import WiperOptions, wiper

    runs, tips, systems = {}, {}, {}
    summary = {"scene": "wiper", "t_end": t_end}
    for flexible in (False, True):
        label = "flexible" if flexible else "rigid"
        options = WiperOptions(flexible=flexible, n_segments=n_segments)
        model, initial = wiper(options)
        system = model.build(complement=complement)
        res = simulate(system, t_end, positions=initial, rtol=rtol, method=method, n_out=n_out, progress=progress,
                       track_work=True)
        res.save(folder.stage(f"wiper_{label}.npz"))
        runs[label], systems[label] = res, system
        work = sum(res.work.values())
        balance = float(np.max(np.abs(work - (res.kinetic - res.kinetic[0])))
                        / max(np.max(np.abs(res.work["driver motor"])), 1e-300))
        # the right blade's tip, exact velocities from the state (eq. 17)
        tips[label] = point_motion(res, system, "right_blade", (options.blade_length, 0.0, 0.0))
        speed = np.linalg.norm(tips[label][1], axis=1)
        summary[label] = {
            "status": res.status, "method": res.method, "method_reason": res.method_reason,
            "n_coords": len(res.coordinate_names),
            "n_dof": res.n_dof, "n_rhs": res.n_rhs, "wall_time_s": res.wall_time,
            "max_loop_residual": float(res.residual.max()), "peak_tip_speed_m_s": float(speed.max()),
            "peak_crank_torque_N_m": float(np.abs(res.driver_effort("motor")).max()),
            "driver_work_J": float(res.work["driver motor"][-1]),
            "energy_balance_rel_error": balance,
        }
        summary[label]["vtk"] = _vtk(res, folder, f"vtk_{label}", f"wiper_{label}", system, jobs)
        if summary[label]["vtk"]:
            summary["paraview"] = folder.final(PARAVIEW_SCRIPT)
        if res.status == "interrupted":  # Ctrl-C: keep what was written, start no further run
            summary["status"] = "interrupted"
            return summary
    plt = _plt()
    if plt:
        fig = wiper_figure(runs, systems, tips, plt=plt)
        _savefig(plt, fig, folder, "wiper.png", 120)
    return summary


def point_motion(res, system, body, point) -> tuple[np.ndarray, np.ndarray]:
    """Position and velocity of a body point at every output time, exact from the state.

    Parameters
    ----------
    res : Result
        A result of ``system``.
    system : System
        The system the result came from.
    body : Body or str
        The body (rigid or flexible), or its name.
    point : array_like, shape (3,)
        The point in the body's frame, m (on a flexible body: along its
        undeformed centre line, carried by the segment it falls in).

    Returns
    -------
    position, velocity : ndarray, shape (nt, 3)
        Inertial position (m) and velocity (m/s).

    Notes
    -----
    The velocity is ``v_k + omega_k x (p - r_k)`` of the body row carrying
    the point (eq. 17), from the kinematics at each output state
    ``(t, x, xd)``: no differences of sampled positions.
    """
    if isinstance(body, str):
        body = system.model[body]
    k, local = system.topology.locate(body, np.asarray(point, dtype=float))
    nt = len(res.t)
    p, v = np.empty((nt, 3)), np.empty((nt, 3))
    for i in range(nt):  # one compiled kinematics per output time
        kin = system.kinematics(res.t[i], res.x[i], res.xd[i])
        p[i] = kin.point_position(k, local)
        v[i] = kin.point_velocity(k, p[i])
    return p, v


def wiper_figure(runs, systems, tips, plt=None):
    """The figure of ``wiper.png``: rigid and flexible blades, and what differs between them.

    Left column, both runs: the right tip's distance from its start point
    (m), its speed (m/s) and the crank torque (N m). Right column, what the
    flexible blade adds: the flexible minus rigid tip position in the
    blade frame (mm; the crank drives a linkage without freedom, so the
    arms move alike and this is the blade's elastic tip deflection), the
    flexible minus rigid tip speed (m/s), and the bending moments at the
    flexible blade's root (N m, from its section loads).

    Parameters
    ----------
    runs : dict of str to Result
        ``'rigid'`` and ``'flexible'`` results at the same output times.
    systems : dict of str to System
        The systems they came from.
    tips : dict of str to (ndarray, ndarray)
        Per run, the right tip's positions and velocities, shape (nt, 3)
        (:func:`point_motion`).
    plt : module, optional
        ``matplotlib.pyplot`` (else a bare Figure is made).

    Returns
    -------
    matplotlib.figure.Figure
        Six axes, every one labelled with its unit.
    """
    if plt is None:
        from matplotlib.figure import Figure

        fig = Figure(figsize=(11, 8.5))
        ax = fig.subplots(3, 2, sharex=True)
    else:
        fig, ax = plt.subplots(3, 2, figsize=(11, 8.5), sharex=True)
    rigid, flexible = runs["rigid"], runs["flexible"]
    # the flexible curves thin and dark over the rigid ones wide and light: at this scale they coincide
    for (label, res), style in zip(runs.items(), (dict(color="C0", lw=3.0, alpha=0.45), dict(color="k", lw=0.9))):
        p, v = tips[label]
        ax[0, 0].plot(res.t, np.linalg.norm(p - p[0], axis=1), label=f"{label} blades", **style)
        ax[1, 0].plot(res.t, np.linalg.norm(v, axis=1), **style)
        ax[2, 0].plot(res.t, res.driver_effort("motor"), **style)
    ax[0, 0].set_ylabel("right tip: distance from its start point (m)")
    ax[1, 0].set_ylabel("right tip speed (m/s)")
    ax[2, 0].set_ylabel("crank torque (N m)")
    same = len(rigid.t) == len(flexible.t) and np.allclose(rigid.t, flexible.t, rtol=0, atol=1e-12)
    if same:
        # the tip's offset in the rigid blade's frame: x along the blade, y across it in the glass, z normal
        k = rigid.body_names.index("right_blade")
        d = np.einsum("tji,tj->ti", rigid.rotations[:, k], tips["flexible"][0] - tips["rigid"][0])
        for j, name in ((1, "across the blade, in the glass (its elastic deflection)"), (0, "along the blade"),
                        (2, "normal to the glass")):
            ax[0, 1].plot(flexible.t, 1e3 * d[:, j], label=name)
        dv = np.linalg.norm(tips["flexible"][1], axis=1) - np.linalg.norm(tips["rigid"][1], axis=1)
        ax[1, 1].plot(flexible.t, dv, color="k", lw=0.9)
    else:
        for a in ax[:2, 1]:
            a.text(0.5, 0.5, "runs at different output times", ha="center", transform=a.transAxes)
    ax[0, 1].set_ylabel("flexible - rigid tip position (mm)")
    ax[1, 1].set_ylabel("flexible - rigid tip speed (m/s)")
    loads = flexible.section_loads(systems["flexible"].model["right_blade"])
    for c, name in (("Mz", "Mz, in the glass plane"), ("My", "My, out of the plane")):
        if c in loads.components:
            ax[2, 1].plot(loads.t, loads.component(c)[:, 0], label=name)
    ax[2, 1].set_ylabel("flexible blade root moment (N m)")
    for a in ax[-1]:
        a.set_xlabel("time (s)")
    for a, loc in zip(ax.flat, ("upper left", "lower right", None, None, None, "upper right")):
        if loc:
            a.legend(fontsize=8, loc=loc)
        a.grid(alpha=0.3)
    fig.suptitle("Windshield wiper at 60 rpm, right blade: rigid vs flexible (cf. the paper's Figs. 5-6)")
    fig.subplots_adjust(left=0.08, right=0.98, bottom=0.07, top=0.94, hspace=0.12, wspace=0.22)
    return fig


def run_scene(name, out, **kw):
    """Run a built-in scene, writing into folder ``out``.

    Parameters
    ----------
    name : {'fourbar', 'wiper'}
        The scene.
    out : str
        Output folder (created). It is locked for the run; the previous
        run's files are replaced only once the new run is written whole.
    **kw
        ``t_end``, ``rtol``, ``complement``, ``method``, ``n_out``, ``progress``.

    Returns
    -------
    dict
        The summary also written to ``out/summary.json``.

    Raises
    ------
    FlexmbError
        For an unknown scene name.
    ExportError
        If another run is writing into ``out`` (the message names its pid).
    """
    runners = {"fourbar": run_fourbar, "wiper": run_wiper}
    if name not in runners:
        raise FlexmbError(f"unknown scene {name!r}; pick one of {sorted(runners)}")
    with OutputFolder(out) as folder:
        summary = runners[name](folder, **kw)
        folder.commit(summary)
    return summary


def write_outputs(scene, res, out) -> dict:
    """Write the outputs of a scene-file run: ``.npz``, ``summary.json``, a plot and VTK.

    Parameters
    ----------
    scene : flexmb.scene.Scene
        The scene (its ``output`` settings say what to write).
    res : Result
        Its result, possibly partial (interrupted or failed).
    out : str or path-like
        Output folder (created). It is locked while writing; the files of
        the previous run written there are replaced, or removed if this run
        does not write them, only once this run is written whole.

    Returns
    -------
    dict
        The summary (also written to ``out/summary.json`` unless disabled).

    Raises
    ------
    ExportError
        If another run is writing into ``out`` (the message names its pid).
    """
    with OutputFolder(out) as folder:
        return _write_outputs(scene, res, folder)


def _write_outputs(scene, res, folder) -> dict:
    """Write the outputs of a scene-file run into an open :class:`OutputFolder` and commit them."""
    o = scene.output
    summary = {
        "scene": scene.source, "model": scene.name, "status": res.status, "message": res.message,
        "method": res.method, "method_reason": res.method_reason, "complement": res.complement, "t_end": float(res.t[-1]) if len(res.t) else None,
        "n_out": int(len(res.t)), "n_coords": len(res.coordinate_names), "n_dof": res.n_dof,
        "n_rhs": res.n_rhs, "n_steps": res.n_steps, "n_projections": res.n_projections,
        "wall_time_s": res.wall_time,
    }
    if len(res.t):
        summary["max_loop_residual"] = float(res.residual.max())
        summary["energy_J"] = {"initial": float(res.energy[0]), "final": float(res.energy[-1]),
                               "max_change": float(np.max(np.abs(res.energy - res.energy[0])))}
        if res.work:
            summary["work_J"] = {k: float(v[-1]) for k, v in res.work.items()}
        summary["drivers"] = {d: {"peak_effort": float(np.abs(res.driver_effort(d)).max())}
                              for d in res.driver_names}
    tracks = scene.track(res) if len(res.t) else {}
    speeds = {k: (np.linalg.norm(np.gradient(p, res.t, axis=0), axis=1) if len(res.t) > 1 else np.zeros(len(p)))
              for k, p in tracks.items()}
    summary["points"] = {k: {"max_displacement_m": float(np.linalg.norm(p - p[0], axis=1).max()),
                             "peak_speed_m_s": float(speeds[k].max())} for k, p in tracks.items()}
    files = {}
    if o.npz:
        res.save(folder.stage(o.prefix + ".npz"))
        files["result"] = folder.final(o.prefix + ".npz")
    if o.plots and len(res.t):
        plt = _plt()
        if plt:
            fig = _scene_figure(scene, res, tracks, speeds, plt)
            _savefig(plt, fig, folder, o.prefix + ".png", 110)
            files["plot"] = folder.final(o.prefix + ".png")
    if o.vtk and len(res.t):
        pvd = _vtk(res, folder, "vtk", o.prefix, scene.model)
        if pvd:
            files["vtk"] = pvd
            files["paraview"] = folder.final(PARAVIEW_SCRIPT)
    summary["files"] = files
    folder.commit(summary if o.summary else None)
    return summary


def _subplots(plt, n, figsize, **kw):
    """A column of ``n`` axes sharing the time axis: with pyplot, or a bare Figure without it."""
    if plt is None:
        from matplotlib.figure import Figure

        fig = Figure(figsize=figsize)
        return fig, fig.subplots(n, 1, sharex=True, squeeze=False, **kw)[:, 0]
    fig, ax = plt.subplots(n, 1, figsize=figsize, sharex=True, squeeze=False, **kw)
    return fig, ax[:, 0]


def _plot_coordinates(axes, res, groups, fontsize=7):
    """One axis per (kind, unit) group of coordinates, labelled with the unit."""
    for ax, (kind, unit, cols) in zip(axes, groups):
        for c in cols:
            ax.plot(res.t, res.x[:, c], label=res.coordinate_names[c])
        ax.set_ylabel(f"{kind} ({unit})")
        if len(cols) <= 12:
            ax.legend(fontsize=fontsize, loc="upper right")


def _fourbar_figure(res, plt=None):
    """``fourbar.png``: coordinates (one axis per unit), energy drift (J), loop residual (m)."""
    from ..viz import _coordinate_groups

    groups = _coordinate_groups(res, range(len(res.coordinate_names)))
    fig, ax = _subplots(plt, len(groups) + 2, (7, 2.6 * (len(groups) + 2) + 0.2))
    _plot_coordinates(ax, res, groups, fontsize=8)
    ax[-2].plot(res.t, res.energy - res.energy[0])
    ax[-2].set_ylabel("energy drift (J)")
    ax[-1].semilogy(res.t, np.maximum(res.residual, 1e-18))
    ax[-1].set_ylabel("loop residual (m)")
    ax[-1].set_xlabel("time (s)")
    fig.tight_layout()
    return fig


def _effort_unit(driver) -> str:
    """N m for a driven rotation, N for a driven translation, '-' when the joint does not say."""
    joint = type(driver.joint)
    n_t, n_r = len(joint.translation_axes), len(joint.rotation_axes)
    if len(joint.coordinate_names) != n_t + n_r:
        return "-"
    return "N" if driver.coordinate < n_t else "N m"


def _scene_figure(scene, res, tracks, speeds, plt=None):
    """The plot of a scene-file run: coordinates and driver efforts one axis per unit, energy, residual, speeds."""
    from ..viz import _coordinate_groups

    groups = _coordinate_groups(res, range(len(res.coordinate_names)))
    drivers = {}
    for d in scene.model.drivers:
        if d.name in res.driver_names:
            drivers.setdefault(_effort_unit(d), []).append(d.name)
    panels = len(groups) + 2 + bool(tracks) + len(drivers)
    fig, ax = _subplots(plt, panels, (7, 2.6 * panels))
    _plot_coordinates(ax, res, groups)
    i = len(groups)
    ax[i].plot(res.t, res.energy - res.energy[0])
    ax[i].set_ylabel("energy change (J)")
    ax[i + 1].semilogy(res.t, np.maximum(res.residual, 1e-18))
    ax[i + 1].set_ylabel("loop residual (m or rad)")
    i += 2
    if tracks:
        for k in tracks:
            ax[i].plot(res.t, speeds[k], label=k)
        ax[i].set_ylabel("point speed (m/s)")
        ax[i].legend(fontsize=8)
        i += 1
    for unit, names in drivers.items():
        for d in names:
            ax[i].plot(res.t, res.driver_effort(d), label=d)
        what = {"N m": "driver torque", "N": "driver force"}.get(unit, "driver effort")
        ax[i].set_ylabel(f"{what} ({unit})")
        ax[i].legend(fontsize=8)
        i += 1
    ax[-1].set_xlabel("time (s)")
    fig.suptitle(f"{scene.name}: {res.status}")
    fig.tight_layout()
    return fig
