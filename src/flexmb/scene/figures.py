"""The figures a scene run draws, by name: ``[output] figure`` picks one of :data:`FIGURES`.

Each is a :class:`SceneFigure`: its curves as plain data, then the
drawing from those alone. A figure of kind ``'run'`` is drawn for one run
(its curves ``data(scene, result, tracks, speeds)``); one of kind ``'runs'``
once for all the runs of a scene with ``[runs]`` (``data(runs)`` with
``runs = {label: (scene, result, system)}``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from ..post.motion import point_motion

__all__ = ["FIGURES", "RUNS_OF_FIGURES", "SceneFigure", "wiper_figure", "wiper_data", "draw_wiper"]


def _column(n, figsize):
    """A bare Figure with a column of ``n`` axes sharing the time axis."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    return fig, fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]


def _coordinate_curves(res) -> list:
    """The coordinates grouped by (kind, unit): ``[(kind, unit, [(name, values), ...]), ...]``."""
    from ..viz.plots import _coordinate_groups

    return [(kind, unit, [(res.coordinate_names[c], res.x[:, c]) for c in cols])
            for kind, unit, cols in _coordinate_groups(res, range(len(res.coordinate_names)))]


def _plot_coordinates(axes, t, curves, fontsize=7):
    """One axis per (kind, unit) group of coordinates, labelled with the unit."""
    for ax, (kind, unit, lines) in zip(axes, curves):
        for name, values in lines:
            ax.plot(t, values, label=name)
        ax.set_ylabel(f"{kind} ({unit})")
        if len(lines) <= 12:
            ax.legend(fontsize=fontsize, loc="upper right")


def _fourbar_data(res) -> dict:
    """The curves of ``fourbar.png``: coordinates, energy drift, loop residual."""
    return {"t": res.t, "coordinates": _coordinate_curves(res), "energy": res.energy - res.energy[0],
            "residual": np.maximum(res.residual, 1e-18)}


def _draw_fourbar(data: dict):
    """``fourbar.png``: coordinates (one axis per unit), energy drift (J), loop residual (m)."""
    curves = data["coordinates"]
    fig, ax = _column(len(curves) + 2, (7, 2.6 * (len(curves) + 2) + 0.2))
    _plot_coordinates(ax, data["t"], curves, fontsize=8)
    ax[-2].plot(data["t"], data["energy"])
    ax[-2].set_ylabel("energy drift (J)")
    ax[-1].semilogy(data["t"], data["residual"])
    ax[-1].set_ylabel("loop residual (m)")
    ax[-1].set_xlabel("time (s)")
    fig.tight_layout()
    return fig


def _fourbar_figure(res):
    """``fourbar.png`` of a result."""
    return _draw_fourbar(_fourbar_data(res))


def _scene_data(scene, res, tracks, speeds) -> dict:
    """The curves of a scene-file run's plot: coordinates, energy, residual, tracked speeds, driver efforts."""
    drivers = {}
    for d in scene.model.drivers:
        if d.name in res.driver_names:
            drivers.setdefault(d.effort_unit, []).append((d.name, res.driver_effort(d.name)))
    return {"t": res.t, "coordinates": _coordinate_curves(res), "energy": res.energy - res.energy[0],
            "residual": np.maximum(res.residual, 1e-18), "speeds": {k: speeds[k] for k in tracks},
            "drivers": list(drivers.items()), "title": f"{scene.name}: {res.status}"}


def _draw_scene(data: dict):
    """The plot of a scene-file run: coordinates and driver efforts one axis per unit, energy, residual, speeds."""
    t, curves = data["t"], data["coordinates"]
    panels = len(curves) + 2 + bool(data["speeds"]) + len(data["drivers"])
    fig, ax = _column(panels, (7, 2.6 * panels))
    _plot_coordinates(ax, t, curves)
    i = len(curves)
    ax[i].plot(t, data["energy"])
    ax[i].set_ylabel("energy change (J)")
    ax[i + 1].semilogy(t, data["residual"])
    ax[i + 1].set_ylabel("loop residual (m or rad)")
    i += 2
    if data["speeds"]:
        for k, speed in data["speeds"].items():
            ax[i].plot(t, speed, label=k)
        ax[i].set_ylabel("point speed (m/s)")
        ax[i].legend(fontsize=8)
        i += 1
    for unit, efforts in data["drivers"]:
        for name, effort in efforts:
            ax[i].plot(t, effort, label=name)
        what = {"N m": "driver torque", "N": "driver force"}.get(unit, "driver effort")
        ax[i].set_ylabel(f"{what} ({unit})")
        ax[i].legend(fontsize=8)
        i += 1
    ax[-1].set_xlabel("time (s)")
    fig.suptitle(data["title"])
    fig.tight_layout()
    return fig


def _scene_figure(scene, res, tracks, speeds):
    """The plot of a scene-file run, drawn here."""
    return _draw_scene(_scene_data(scene, res, tracks, speeds))


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
        (:func:`flexmb.post.motion.point_motion`).
    plt : module, optional
        ``matplotlib.pyplot`` (else a bare Figure is made).

    Returns
    -------
    matplotlib.figure.Figure
        Six axes, every one labelled with its unit.

    See Also
    --------
    wiper_data, draw_wiper : The two halves: the curves, then the drawing.
    """
    return draw_wiper(wiper_data(runs, systems, tips), plt)


def wiper_data(runs, systems, tips) -> dict:
    """The curves of :func:`wiper_figure`, as plain arrays (what :func:`draw_wiper` draws).

    Parameters
    ----------
    runs, systems, tips
        As for :func:`wiper_figure`.

    Returns
    -------
    dict
        ``'left'``: per run label, ``(t, distance, speed, torque)``;
        ``'deflection'``: ``(t, d_mm, dv)`` with ``d_mm`` the flexible minus
        rigid tip position in the rigid blade's frame (mm, shape (nt, 3)),
        or None if the runs have different output times; ``'root'``:
        ``(t, {component: moment})``, the flexible blade's root moments.
    """
    rigid, flexible = runs["rigid"], runs["flexible"]
    left = {}
    for label, res in runs.items():
        p, v = tips[label]
        left[label] = (res.t, np.linalg.norm(p - p[0], axis=1), np.linalg.norm(v, axis=1), res.driver_effort("motor"))
    deflection = None
    if len(rigid.t) == len(flexible.t) and np.allclose(rigid.t, flexible.t, rtol=0, atol=1e-12):
        # the tip's offset in the rigid blade's frame: x along the blade, y across it in the glass, z normal
        k = rigid.body_names.index("right_blade")
        d = np.einsum("tji,tj->ti", rigid.rotations[:, k], tips["flexible"][0] - tips["rigid"][0])
        dv = np.linalg.norm(tips["flexible"][1], axis=1) - np.linalg.norm(tips["rigid"][1], axis=1)
        deflection = (flexible.t, 1e3 * d, dv)
    loads = flexible.section_loads(systems["flexible"].model["right_blade"])
    root = {c: loads.component(c)[:, 0] for c in ("Mz", "My") if c in loads.components}
    return {"left": left, "deflection": deflection, "root": (loads.t, root)}


def draw_wiper(data: dict, plt=None):
    """Draw :func:`wiper_figure` from its curves (:func:`wiper_data`): matplotlib only, no model.

    Parameters
    ----------
    data : dict
        :func:`wiper_data`'s curves.
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
    # the flexible curves thin and dark over the rigid ones wide and light: at this scale they coincide
    styles = (dict(color="C0", lw=3.0, alpha=0.45), dict(color="k", lw=0.9))
    for (label, (t, distance, speed, torque)), style in zip(data["left"].items(), styles):
        ax[0, 0].plot(t, distance, label=f"{label} blades", **style)
        ax[1, 0].plot(t, speed, **style)
        ax[2, 0].plot(t, torque, **style)
    ax[0, 0].set_ylabel("right tip: distance from its start point (m)")
    ax[1, 0].set_ylabel("right tip speed (m/s)")
    ax[2, 0].set_ylabel("crank torque (N m)")
    if data["deflection"] is not None:
        t, d_mm, dv = data["deflection"]
        for j, name in ((1, "across the blade, in the glass (its elastic deflection)"), (0, "along the blade"),
                        (2, "normal to the glass")):
            ax[0, 1].plot(t, d_mm[:, j], label=name)
        ax[1, 1].plot(t, dv, color="k", lw=0.9)
    else:
        for a in ax[:2, 1]:
            a.text(0.5, 0.5, "runs at different output times", ha="center", transform=a.transAxes)
    ax[0, 1].set_ylabel("flexible - rigid tip position (mm)")
    ax[1, 1].set_ylabel("flexible - rigid tip speed (m/s)")
    t, root = data["root"]
    for c, name in (("Mz", "Mz, in the glass plane"), ("My", "My, out of the plane")):
        if c in root:
            ax[2, 1].plot(t, root[c], label=name)
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


def _fourbar_run_data(scene, res, tracks, speeds) -> dict:
    """The curves of ``fourbar.png`` of a scene run."""
    return _fourbar_data(res)


def _wiper_runs_data(runs) -> dict:
    """The curves of ``wiper.png`` from the runs ``rigid`` and ``flexible``: the tip is the first tracked point."""
    scene = next(iter(runs.values()))[0]
    body, point = next(iter(scene.output.points.values()))
    results = {label: res for label, (_, res, _) in runs.items()}
    systems = {label: system for label, (_, _, system) in runs.items()}
    tips = {label: point_motion(results[label], body, point, (0, 1), systems[label]) for label in runs}
    return wiper_data(results, systems, tips)


class SceneFigure(NamedTuple):
    """A figure a scene run draws, in two halves: the curves, then the drawing.

    ``flexmb run`` draws it in a child that imported matplotlib while the
    runs computed (:func:`flexmb._background.start_worker`): only plain
    data cross to it.

    Parameters
    ----------
    data : callable
        The curves, as plain arrays and strings, computed where the model
        is: ``data(scene, result, tracks, speeds)`` for a figure of kind
        ``'run'``, ``data(runs)`` with ``runs = {label: (scene, result,
        system)}`` for one of kind ``'runs'``.
    draw : callable
        ``draw(data)``: the ``matplotlib.figure.Figure``, drawn from those
        alone.
    """

    data: Callable
    draw: Callable


#: named figures: name -> (kind, SceneFigure, what it shows); ``'runs'`` figures need ``[runs]``
FIGURES = {
    "scene": ("run", SceneFigure(_scene_data, _draw_scene),
              "coordinates and driver efforts one axis per unit, energy, residual, tracked point speeds"),
    "fourbar": ("run", SceneFigure(_fourbar_run_data, _draw_fourbar),
                "coordinates, energy drift and loop residual (benchmark B5)"),
    "wiper": ("runs", SceneFigure(_wiper_runs_data, draw_wiper),
              "the paper's Figs. 5-6: runs 'rigid' and 'flexible' side by side (the first tracked point is the "
              "blade tip; the driver is 'motor')"),
}

#: the runs a ``'runs'`` figure draws, by label
RUNS_OF_FIGURES = {"wiper": ("rigid", "flexible")}
