"""The viewer of a results folder (``flexmb view FOLDER``): its saved results, drawn with their scene's model.

A folder written by ``flexmb run`` holds each run's result (``<name>.npz``,
or ``<name>_<label>.npz`` per run of a scene with ``[runs]``) and
``summary.json``, which names them and the scene. :func:`view_folder`
loads the results, builds each run's model from the scene again (so that
the bodies are drawn through their joints, with stresses) and writes one
viewer page (:func:`flexmb.viz.write_view`), with a menu of the runs.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from ..errors import ExportError, FlexmbError

__all__ = ["view_folder"]


def _file(folder: Path, recorded: str) -> Path:
    """A file the summary names: as recorded (absolute, or relative to the folder), else by name in the folder."""
    path = Path(recorded)
    for candidate in (path if path.is_absolute() else folder / path, folder / path.name):
        if candidate.is_file():
            return candidate
    raise ExportError(f"{folder}: summary.json names {recorded}, which is not in the folder")


def _saved_results(folder: Path, summary: dict | None) -> dict[str, Path]:
    """The saved results by run label ("" for a scene without runs)."""
    if summary is None:
        found = {p.stem: p for p in sorted(folder.glob("*.npz"))}
        if not found:
            raise ExportError(f"{folder}: no summary.json and no .npz result: not a flexmb results folder")
        return found
    files = summary.get("files", {})
    out = {key.removeprefix("result_") if key != "result" else "": _file(folder, path)
           for key, path in files.items() if key == "result" or key.startswith("result_")}
    if not out:
        raise ExportError(f"{folder}: summary.json names no saved result (the scene's [output] npz = false?)")
    return out


def _scene(folder: Path, source: str | None):
    """The scene the folder's run came from, or the reason it cannot be read."""
    from .load import builtin_scenes, load_builtin, load_scene

    if not source:
        return None, "summary.json names no scene"
    for candidate in (Path(source), folder / source):
        if candidate.is_file():
            try:
                return load_scene(candidate), ""
            except FlexmbError as exc:
                return None, str(exc)
    if source in builtin_scenes():
        return load_builtin(source), ""
    return None, f"the scene {source} is not found (moved?)"


def _systems(scene, labels) -> dict:
    """Each run's model, by label."""
    if scene is None:
        return {}
    if scene.runs:
        return {label: scene.runs[label].system() for label in labels if label in scene.runs}
    return {"": scene.system()} if "" in labels else {}


def view_folder(folder, path=None, **options):
    """Write the viewer page of a results folder of ``flexmb run`` (what ``flexmb view FOLDER`` does).

    Parameters
    ----------
    folder : str or path-like
        The output folder of ``flexmb run``: its ``summary.json`` names the
        saved results and the scene (without ``summary.json``: every
        ``.npz`` in it).
    path : str or path-like, optional
        The HTML file (default: ``FOLDER/view.html``).
    **options
        ``max_frames``, ``max_bytes``: see :func:`flexmb.viz.write_view`.

    Returns
    -------
    page : flexmb.viz.View
        The HTML file.
    notes : list of str
        What the page lacks and why, e.g. that a run is drawn without its
        model (bodies as lines through frame origin and mass centre, no
        stresses) because the scene file is gone.

    Raises
    ------
    ExportError
        If the folder holds no saved result, or a result the summary names
        is missing.
    """
    from ..result import Result
    from ..viz.viewer import write_view

    folder = Path(os.fspath(folder))
    if not folder.is_dir():
        raise ExportError(f"{folder}: no such folder (give the output folder of flexmb run)")
    summary_file = folder / "summary.json"
    summary = json.loads(summary_file.read_text(encoding="utf-8")) if summary_file.is_file() else None
    files = _saved_results(folder, summary)
    results = {label: Result.load(p) for label, p in files.items()}
    scene, why = _scene(folder, (summary or {}).get("scene"))
    systems, notes = {}, []
    try:
        systems = _systems(scene, list(results))
    except FlexmbError as exc:
        why = f"its model cannot be built: {exc}"
    for label, res in results.items():
        sys_ = systems.get(label)
        if sys_ is not None and (list(sys_.body_names) != list(res.body_names) or sys_.n_coords != res.x.shape[1]):
            systems.pop(label)
            why = "the scene's model no longer matches the saved result (edited since the run?)"
        if label not in systems:
            notes.append(f"{files[label].name}: drawn without its model (bodies as lines through frame origin and "
                         f"mass centre, no stresses): {why or 'the scene has no such run'}")
    title = (summary or {}).get("model") or folder.name
    target = folder / "view.html" if path is None else path
    if list(results) == [""]:
        return write_view(results[""], target, system=systems.get(""), title=title, **options), notes
    return write_view(results, target, system=systems, title=title, **options), notes
