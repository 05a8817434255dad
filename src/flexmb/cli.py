"""The ``flexmb`` command line."""

from __future__ import annotations

import argparse
import json
import sys

from .errors import FlexmbError

__all__ = ["main"]


def _run(args) -> int:
    from .scenes.report import run_scene

    kw = dict(t_end=args.t_end, complement=args.complement, method=args.integrator, n_out=args.n_out,
              progress=not args.quiet)
    if args.rtol is not None:
        kw["rtol"] = args.rtol
    summary = run_scene(args.scene, args.out, **kw)
    print(json.dumps(summary, indent=2))
    print(f"wrote {args.out}/ (results .npz, summary.json, plots .png, VTK series)")
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
    run = sub.add_parser("run", help="simulate a built-in scene and write results, plots and VTK")
    run.add_argument("scene", help="fourbar or wiper")
    run.add_argument("--out", default="results", help="output folder")
    run.add_argument("--t-end", type=float, default=None, help="end time, s (default: the scene's)")
    run.add_argument("--rtol", type=float, default=None, help="relative tolerance (default: the scene's)")
    run.add_argument("--complement", default="svd", help="orthogonal complement strategy: svd or eigen")
    run.add_argument("--integrator", default="auto", help="auto, DOP853, Radau, BDF, ...")
    run.add_argument("--n-out", type=int, default=501, help="number of output times")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
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
