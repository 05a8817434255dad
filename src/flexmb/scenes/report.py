"""Run a built-in scene and write its results, plots and VTK files.

Every run writes through one :class:`flexmb._files.OutputFolder`: the
folder is locked for the run, the files are written to a hidden staging
folder inside it and swapped into place at the end, ``summary.json`` last
(see ``docs/scenes.md``, "Output folders").
"""

from __future__ import annotations

import logging

import numpy as np

from .._files import OutputFolder, atomic_write
from ..errors import FlexmbError
from ..simulate import simulate

__all__ = ["SCENES", "run_scene", "write_outputs"]

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


def _vtk(res, folder, sub, prefix, system):
    """Write the VTK series into ``sub/`` of the staging folder; return the final ``.pvd`` path or None.

    With the system the run came from: bodies drawn through their joints, exact velocities, section
    loads and stresses. The ParaView script that opens the series comes along, once per folder.
    """
    rel = f"{sub}/{prefix}.pvd"
    try:
        from ..export.vtk import paraview_script

        res.export_vtk(folder.stage(rel).parent, prefix=prefix, system=system)
        if not folder.staged(PARAVIEW_SCRIPT):
            paraview_script(folder.stage(PARAVIEW_SCRIPT))
    except ImportError as exc:  # meshio missing
        log.warning("no VTK written: %s", exc)
        return None
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
        fig, ax = plt.subplots(3, 1, figsize=(7, 8), sharex=True)
        ax[0].plot(res.t, res.x)
        ax[0].legend(res.coordinate_names, fontsize=8)
        ax[0].set_ylabel("coordinates [rad]")
        ax[1].plot(res.t, res.energy - res.energy[0])
        ax[1].set_ylabel("energy drift [J]")
        ax[2].semilogy(res.t, np.maximum(res.residual, 1e-18))
        ax[2].set_ylabel("loop residual [m]")
        ax[2].set_xlabel("t [s]")
        fig.tight_layout()
        _savefig(plt, fig, folder, "fourbar.png", 120)
    pvd = _vtk(res, folder, "vtk", "fourbar", system)
    summary["vtk"] = pvd
    if pvd:
        summary["paraview"] = folder.final(PARAVIEW_SCRIPT)
    return summary


def run_wiper(folder, t_end=None, rtol=1e-6, complement="svd", method="auto", n_out=501, progress=True,
              n_segments=6):
    """The wiper, rigid and flexible blades (Figs. 5-6 of the paper), staged in an open OutputFolder."""
    from .wiper import WiperOptions, wiper

    t_end = t_end or 1.0
    runs = {}
    summary = {"scene": "wiper", "t_end": t_end}
    for flexible in (False, True):
        label = "flexible" if flexible else "rigid"
        model, initial = wiper(WiperOptions(flexible=flexible, n_segments=n_segments))
        system = model.build(complement=complement)
        res = simulate(system, t_end, positions=initial, rtol=rtol, method=method, n_out=n_out, progress=progress,
                       track_work=True)
        res.save(folder.stage(f"wiper_{label}.npz"))
        runs[label] = res
        work = sum(res.work.values())
        balance = float(np.max(np.abs(work - (res.kinetic - res.kinetic[0])))
                        / max(np.max(np.abs(res.work["driver motor"])), 1e-300))
        tip = _tip(res, flexible)
        speed = np.linalg.norm(np.gradient(tip, res.t, axis=0), axis=1)
        summary[label] = {
            "status": res.status, "method": res.method, "n_coords": len(res.coordinate_names),
            "n_dof": res.n_dof, "n_rhs": res.n_rhs, "wall_time_s": res.wall_time,
            "max_loop_residual": float(res.residual.max()), "peak_tip_speed_m_s": float(speed.max()),
            "peak_crank_torque_N_m": float(np.abs(res.driver_effort("motor")).max()),
            "driver_work_J": float(res.work["driver motor"][-1]),
            "energy_balance_rel_error": balance,
        }
        summary[label]["vtk"] = _vtk(res, folder, f"vtk_{label}", f"wiper_{label}", system)
        if summary[label]["vtk"]:
            summary["paraview"] = folder.final(PARAVIEW_SCRIPT)
        if res.status == "interrupted":  # Ctrl-C: keep what was written, start no further run
            summary["status"] = "interrupted"
            return summary
    plt = _plt()
    if plt:
        fig, ax = plt.subplots(4, 1, figsize=(7, 11), sharex=True)
        tips = {label: _tip(res, label == "flexible") for label, res in runs.items()}
        if len(runs["rigid"].t) == len(runs["flexible"].t):
            ax[3].plot(runs["flexible"].t, 1e3 * np.linalg.norm(tips["flexible"] - tips["rigid"], axis=1),
                       color="C1", label="flexible - rigid")
        ax[3].set_ylabel("tip deflection [mm]")
        for label, res in runs.items():
            tip = _tip(res, label == "flexible")
            disp = np.linalg.norm(tip - tip[0], axis=1)
            speed = np.linalg.norm(np.gradient(tip, res.t, axis=0), axis=1)
            ax[0].plot(res.t, disp, label=f"{label} blade")
            ax[1].plot(res.t, speed, label=f"{label} blade")
            ax[2].plot(res.t, res.driver_effort("motor"), label=f"{label} blades")
        ax[0].set_ylabel("right tip displacement [m]")
        ax[1].set_ylabel("right tip speed [m/s]")
        ax[2].set_ylabel("crank torque [N m]")
        ax[3].set_xlabel("t [s]")
        for a in ax:
            a.legend()
            a.grid(alpha=0.3)
        fig.suptitle("Windshield wiper at 60 rpm: rigid vs flexible blades (cf. Figs. 5-6)")
        fig.tight_layout()
        _savefig(plt, fig, folder, "wiper.png", 120)
    return summary


def _tip(res, flexible):
    if flexible:
        return res.shape("right_blade")[:, -1]
    k = res.body_names.index("right_blade")
    return res.origins[:, k] + res.rotations[:, k, :, 0] * 0.25


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
        "method": res.method, "complement": res.complement, "t_end": float(res.t[-1]) if len(res.t) else None,
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
            panels = 3 + bool(tracks) + bool(res.driver_names)
            fig, ax = plt.subplots(panels, 1, figsize=(7, 2.6 * panels), sharex=True)
            ax[0].plot(res.t, res.x)
            if len(res.coordinate_names) <= 12:
                ax[0].legend(res.coordinate_names, fontsize=7)
            ax[0].set_ylabel("coordinates [rad, m]")
            ax[1].plot(res.t, res.energy - res.energy[0])
            ax[1].set_ylabel("energy change [J]")
            ax[2].semilogy(res.t, np.maximum(res.residual, 1e-18))
            ax[2].set_ylabel("loop residual")
            i = 3
            if tracks:
                for k in tracks:
                    ax[i].plot(res.t, speeds[k], label=k)
                ax[i].set_ylabel("point speed [m/s]")
                ax[i].legend(fontsize=8)
                i += 1
            if res.driver_names:
                for d in res.driver_names:
                    ax[i].plot(res.t, res.driver_effort(d), label=d)
                ax[i].set_ylabel("driver effort [N m, N]")
                ax[i].legend(fontsize=8)
            ax[-1].set_xlabel("t [s]")
            fig.suptitle(f"{scene.name}: {res.status}")
            fig.tight_layout()
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
