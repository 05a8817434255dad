"""The ``flexmb`` command line."""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

from .errors import FlexmbError

__all__ = ["main"]


def _fourbar():
    """Benchmark B5: a planar four-bar falling under gravity (the demo scene until the wiper lands)."""
    from . import Gravity, Model, PlanarRevolute, Revolute, RigidBody

    model = Model("fourbar")
    crank = RigidBody.slender_bar("crank", 0.1, 0.1)
    coupler = RigidBody.slender_bar("coupler", 0.3, 0.3)
    rocker = RigidBody.slender_bar("rocker", 0.25, 0.25)
    model.add(
        Revolute("A", model.ground, crank),
        Revolute("B", crank, coupler, parent_point=(0.1, 0, 0)),
        Revolute("D", model.ground, rocker, parent_point=(0.3, 0, 0)),
        PlanarRevolute("C", coupler, rocker, parent_point=(0.3, 0, 0), child_point=(0.25, 0, 0)),
        Gravity((0.0, -9.81, 0.0)),
    )
    # coupler above the ground line: start near the closed configuration, crank at 45 deg
    initial = {"A": np.pi / 4, "B": -0.15, "D": 1.5}
    return model, initial, ["A"], 5.0


SCENES = {"fourbar": _fourbar}


def _run(args) -> int:
    from .simulate import simulate

    if args.scene not in SCENES:
        raise FlexmbError(f"unknown scene {args.scene!r}; pick one of {sorted(SCENES)}")
    model, initial, fixed, t_end = SCENES[args.scene]()
    t_end = args.t_end if args.t_end is not None else t_end
    res = simulate(model, t_end, positions=initial, fixed=fixed, rtol=args.rtol, complement=args.complement,
                   method=args.integrator, n_out=args.n_out, progress=True)
    os.makedirs(args.out, exist_ok=True)
    res.save(os.path.join(args.out, "result.npz"))
    summary = {
        "scene": args.scene, "t_end": float(res.t[-1]), "status": res.status, "n_rhs": res.n_rhs,
        "n_steps": res.n_steps, "n_projections": res.n_projections, "wall_time_s": res.wall_time,
        "max_residual": float(res.residual.max()),
        "energy_drift": float(np.ptp(res.energy)), "final_coordinates": dict(zip(res.coordinate_names,
                                                                                  res.x[-1].tolist())),
    }
    with open(os.path.join(args.out, "summary.json"), "w") as fh:
        json.dump(summary, fh, indent=2)
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not installed (pip install -e '.[viz]'): no plot written", file=sys.stderr)
    else:
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
        fig.savefig(os.path.join(args.out, f"{args.scene}.png"), dpi=120)
    print(json.dumps(summary, indent=2))
    print(f"wrote {args.out}/result.npz, summary.json" + ("" if "plt" not in dir() else f", {args.scene}.png"))
    return 0


def _plugins(args) -> int:
    """Print the plugin table: kind, name, origin, status (and why, for broken ones)."""
    from .registry import plugins

    rows = plugins(args.kind)
    header = ("kind", "name", "origin", "status")
    cells = [header] + [(p.kind, p.name, p.origin, p.status) for p in rows]
    widths = [max(len(c[i]) for c in cells) for i in range(len(header))]
    for c in cells:
        print("  ".join(v.ljust(w) for v, w in zip(c, widths)).rstrip())
    problems = [p for p in rows if p.status != "ok"]
    if problems:
        print()
    for p in problems:
        print(f"{p.kind}/{p.name} ({p.origin}): {p.error}")
    return 0


def main(argv=None) -> int:
    """Entry point of the ``flexmb`` command.

    Parameters
    ----------
    argv : list of str, optional
        Arguments (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status.
    """
    parser = argparse.ArgumentParser(prog="flexmb", description="flexible multibody dynamics")
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="simulate a built-in scene")
    run.add_argument("scene", help=f"one of {sorted(SCENES)}")
    run.add_argument("--out", default="results", help="output folder")
    run.add_argument("--t-end", type=float, default=None, help="end time, s")
    run.add_argument("--rtol", type=float, default=1e-8)
    run.add_argument("--complement", default="svd", help="svd or eigen")
    run.add_argument("--integrator", default="DOP853")
    run.add_argument("--n-out", type=int, default=501)
    run.set_defaults(func=_run)
    plug = sub.add_parser("plugins", help="list bodies, joints, forces, complements and integrators by name")
    plug.add_argument("--kind", default=None, help="bodies, joints, forces, complements or integrators")
    plug.set_defaults(func=_plugins)
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except FlexmbError as exc:
        print(f"flexmb: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
