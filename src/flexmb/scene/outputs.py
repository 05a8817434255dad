"""What a scene run writes: the results (``.npz``), ``summary.json``, the plot and the VTK series.

Every run writes through one :class:`flexmb._files.OutputFolder`: the folder
is locked for the run, the files are written to a hidden staging folder
inside it and swapped into place at the end, ``summary.json`` last (see
``docs/scenes.md``, "Output folders"). A scene with ``[runs]`` runs each of
them in turn into one folder; the VTK series of each run is written by a
child process (:mod:`flexmb._background`) while the next run computes.
"""

from __future__ import annotations

import importlib.util
import logging
import os

import numpy as np

from .._background import Worker, in_background, start_worker, wait_all
from .._files import OutputFolder, atomic_write
from ..errors import SimulationError
from .figures import FIGURES

__all__ = ["PARAVIEW_SCRIPT", "run_into", "run_summary", "write_outputs"]

log = logging.getLogger(__name__)

#: the ParaView script written beside the VTK series (pvpython open_in_paraview.py)
PARAVIEW_SCRIPT = "open_in_paraview.py"


def _import_matplotlib() -> None:
    """What the plot worker imports while the runs compute: a bare Figure and the Agg canvas."""
    import matplotlib.backends.backend_agg  # noqa: F401
    import matplotlib.figure  # noqa: F401


def _draw_pngs(pngs) -> None:
    """Each ``(draw, data, path, dpi)``: ``draw(data)`` (a bare Figure) written whole to ``path`` as PNG.

    The plot worker's call (:func:`_plotter`), or made here.
    """
    for draw, data, path, dpi in pngs:
        fig = draw(data)
        atomic_write(path, lambda tmp, fig=fig, dpi=dpi: fig.savefig(tmp, format="png", dpi=dpi), suffix=".png")


def _plotter(scene, background: bool):
    """Who draws the scene's figures: a worker importing matplotlib now, or (``background`` False) this process.

    None if the scene draws no plot, or matplotlib is not installed (said once, as a warning).
    """
    if not scene.output.plots:
        return None
    if importlib.util.find_spec("matplotlib") is None:
        log.warning("matplotlib is not installed (pip install -e '.[viz]'): no plots written")
        return None
    return start_worker(_import_matplotlib) if background else Worker(None, None)


def _vtk(res, folder, sub, prefix, system, jobs=None):
    """Write the VTK series into ``sub/`` of the staging folder; return the ``.pvd``'s path in the folder, or None.

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
        in_background(export, jobs)
    return rel


def _owner(scene) -> str:
    """Who an output folder's run belongs to: the scene file's real path, else the scene's source and model.

    Parameters
    ----------
    scene : Scene
        The scene.

    Returns
    -------
    str
        The file's real path for a scene file (one file, however named on
        the command line), else ``"scene 'wiper' (model 'wiper')"``: a
        built-in scene's name, or the source given to
        :func:`~flexmb.loads_scene`, with the model's name.
    """
    source = os.fspath(scene.source)
    if os.path.isfile(source):
        return os.path.realpath(source)
    return f"scene {source!r} (model {scene.name!r})"


def run_into(scene, out, progress: bool, overrides: dict, overwrite: bool = False) -> dict:
    """Simulate a scene (each of its ``[runs]``, if any) and write its outputs into the folder ``out``.

    Parameters
    ----------
    scene : Scene
        The scene.
    out : str or path-like
        Output folder (created), locked for the run.
    progress : bool
        Progress bar on stderr.
    overrides : dict
        Fields of :class:`~flexmb.scene.SolverSettings` to replace (``None`` values are ignored).
    overwrite : bool
        Replace the outputs of another scene's run in ``out`` (else refused
        before simulating).

    Returns
    -------
    dict
        The summary.

    Raises
    ------
    SimulationError
        If a run fails (after its partial outputs are written).
    ExportError
        If another run is writing into ``out``, or ``out`` holds another
        scene's outputs and ``overwrite`` is False.
    """
    failure = None
    # locked and checked before simulating: a second run, or one over another scene's outputs, is refused at once
    with OutputFolder(out, owner=_owner(scene), overwrite=overwrite) as folder:
        plotter = _plotter(scene, background=True)  # imports matplotlib while the runs compute
        try:
            if scene.runs:
                summary, failure = _write_runs(scene, folder, progress, overrides, plotter)
            else:
                try:
                    result = scene.simulate(progress=progress, **overrides)
                except SimulationError as exc:
                    failure, result = exc, exc.result
                summary = _write_outputs(scene, result, folder, plotter)
        finally:
            if plotter is not None:
                plotter.cancel()  # nothing was drawn (a run failed), or the drawing was sent already
    if failure is not None:
        raise failure
    return summary


def write_outputs(scene, res, out, overwrite: bool = False) -> dict:
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
    overwrite : bool
        Replace the outputs of another scene's run in ``out`` (else refused).

    Returns
    -------
    dict
        The summary (also written to ``out/summary.json`` unless disabled);
        the files it names are paths relative to ``out``.

    Raises
    ------
    ExportError
        If another run is writing into ``out`` (the message names its pid),
        or ``out`` holds another scene's outputs and ``overwrite`` is False.
    """
    with OutputFolder(out, owner=_owner(scene), overwrite=overwrite) as folder:
        return _write_outputs(scene, res, folder, _plotter(scene, background=False))


def _tracks(scene, res):
    """Tracked point positions and their speeds (central differences of the positions)."""
    tracks = scene.track(res) if len(res.t) else {}
    speeds = {k: (np.linalg.norm(np.gradient(p, res.t, axis=0), axis=1) if len(res.t) > 1 else np.zeros(len(p)))
              for k, p in tracks.items()}
    return tracks, speeds


def run_summary(scene, res, tracks: dict, speeds: dict) -> dict:
    """What ``summary.json`` says of one run: status, cost, residual, energy, work, drivers, points, metrics.

    Parameters
    ----------
    scene : Scene
        The scene that ran.
    res : Result
        Its result, possibly partial.
    tracks, speeds : dict of str to ndarray
        Tracked point positions, shape (nt, 3), and speeds, shape (nt,).

    Returns
    -------
    dict
        JSON-ready values; the ``[output.metrics]`` of the scene last.
    """
    summary = {
        "status": res.status, "message": res.message, "method": res.method, "method_reason": res.method_reason,
        "complement": res.complement, "t_end": float(res.t[-1]) if len(res.t) else None,
        "n_out": int(len(res.t)), "n_coords": len(res.coordinate_names), "n_dof": res.n_dof,
        "n_rhs": res.n_rhs, "n_steps": res.n_steps, "n_projections": res.n_projections,
        "n_cvode_projections": res.n_cvode_projections,
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
    summary["points"] = {k: {"max_displacement_m": float(np.linalg.norm(p - p[0], axis=1).max()),
                             "peak_speed_m_s": float(speeds[k].max())} for k, p in tracks.items()}
    if scene.output.metrics and len(res.t):
        from .metrics import _evaluate

        summary.update({key: _evaluate(spec, scene, res) for key, spec in scene.output.metrics.items()})
    return summary


def _write_outputs(scene, res, folder, plotter) -> dict:
    """Write the outputs of a scene-file run into an open :class:`OutputFolder` and commit them.

    The plot is drawn by ``plotter`` (:func:`_plotter`; None: no plot) while the VTK series is written.
    """
    o = scene.output
    tracks, speeds = _tracks(scene, res)
    summary = {"scene": scene.source, "model": scene.name, **run_summary(scene, res, tracks, speeds)}
    files, jobs = {}, []
    if o.npz:
        res.save(folder.stage(o.prefix + ".npz"))
        files["result"] = o.prefix + ".npz"
    try:
        if plotter is not None and len(res.t):
            figure = FIGURES[o.figure][1]
            rel = o.prefix + ".png"
            data = figure.data(scene, res, tracks, speeds)
            jobs.append(plotter.run(_draw_pngs, [(figure.draw, data, folder.stage(rel), 110)]))
            files["plot"] = rel
        if o.vtk and len(res.t):
            # "vtk" as in the entry of each run of a scene with [runs]
            summary["vtk"] = pvd = _vtk(res, folder, "vtk", o.prefix, scene.model)
            if pvd:
                files["vtk"] = pvd
                files["paraview"] = PARAVIEW_SCRIPT
    finally:
        wait_all(jobs)  # interrupted: the jobs are killed, no child writes on into the removed staging folder
    summary["files"] = files
    folder.commit(summary if o.summary else None)
    return summary


def _write_runs(scene, folder, progress: bool, overrides: dict, plotter):
    """Run each of ``scene.runs`` in turn into an open folder and commit; return the summary and any failure.

    Each run writes ``<prefix>_<label>.npz`` and ``vtk_<label>/<prefix>_<label>.pvd`` (by a child
    process, while the next run computes) and has its entry in the summary; a run that is interrupted
    or fails stops the sequence. Once all have finished, a ``'runs'`` figure is drawn once
    (``<prefix>.png``), a ``'run'`` figure once per run (``<prefix>_<label>.png``), by ``plotter``
    (:func:`_plotter`; None: no plots).
    """
    o = scene.output
    summary = {"scene": scene.source, "model": scene.name, "status": "finished",
               "t_end": scene.settings(**overrides).t_end}
    files, done, jobs, failure = {}, {}, [], None
    try:
        for label, run in scene.runs.items():
            try:
                res = run.simulate(progress=progress, **overrides)
            except SimulationError as exc:
                failure, res = exc, exc.result
            system = res.system if res.system is not None else run.system(run.settings(**overrides).complement)
            done[label] = (run, res, system)
            summary[label] = _write_run(run, res, system, folder, label, files, jobs)
            if res.status != "finished":  # Ctrl-C or a failure: keep what was written, start no further run
                summary.update(status=res.status, message=res.message)
                break
        if plotter is not None and summary["status"] == "finished":
            _plot_runs(scene, done, folder, files, plotter, jobs)
    finally:
        wait_all(jobs)  # interrupted: the jobs are killed, no child writes on into the removed staging folder
    if any(k.startswith("vtk_") for k in files):
        summary["paraview"] = files["paraview"] = PARAVIEW_SCRIPT
    summary["files"] = files
    folder.commit(summary if o.summary else None)
    return summary, failure


def _write_run(run, res, system, folder, label, files, jobs) -> dict:
    """One run's entry of the summary, its ``.npz`` and (in the background) its VTK series."""
    o = run.output
    stem = f"{o.prefix}_{label}"
    entry = run_summary(run, res, *_tracks(run, res))
    if o.npz:
        res.save(folder.stage(stem + ".npz"))
        files[f"result_{label}"] = stem + ".npz"
    if o.vtk and len(res.t):
        entry["vtk"] = _vtk(res, folder, f"vtk_{label}", stem, system, jobs)
        if entry["vtk"]:
            files[f"vtk_{label}"] = entry["vtk"]
    return entry


def _plot_runs(scene, done: dict, folder, files: dict, plotter, jobs: list) -> None:
    """The figure of a scene with runs, sent to ``plotter``: once for all (``'runs'`` kind) or once per run."""
    kind, figure, _ = FIGURES[scene.output.figure]
    prefix = scene.output.prefix
    if kind == "runs":
        pngs = [(figure.draw, figure.data(done), folder.stage(prefix + ".png"), 120)]
        files["plot"] = prefix + ".png"
    else:
        pngs = []
        for label, (run, res, _) in done.items():
            rel = f"{prefix}_{label}.png"
            pngs.append((figure.draw, figure.data(run, res, *_tracks(run, res)), folder.stage(rel), 110))
            files[f"plot_{label}"] = rel
    jobs.append(plotter.run(_draw_pngs, pngs))
