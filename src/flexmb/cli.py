"""The ``flexmb`` command line.

``flexmb run SCENE.toml --out DIR`` simulates a scene file (or a built-in
scene, ``fourbar`` or ``wiper``: the scene files shipped in
``flexmb/scene/builtin/``, run by the same code) and writes results, plots
and VTK; ``flexmb info
SCENE.toml`` describes a scene; ``flexmb view FOLDER`` writes ``FOLDER/view.html``,
the results of a run animated in 3-D in a browser (:mod:`flexmb.viz.viewer`);
``flexmb plugins`` lists the plugins. A run
locks its output folder (as a study does): a second run or study into the
same folder is refused; the outputs replace the previous run's only once
complete. ``flexmb study
SCENE.toml --vary KEY=SPEC ... --out DIR`` runs a parameter study
(:mod:`flexmb.study`; ``--time-limit SECONDS`` stops a case that takes
longer and records it as failed).

The exit status tells a script what happened (:data:`EXIT_STATUS`, also in
``flexmb --help`` and ``docs/scenes.md``): 0 done; 2 a usage error (the
command line: an unknown option, a missing argument); 3 an input error, with
one line ``flexmb: error: <file>: <key path>: <what>`` (the scene file, the
model it builds or the output folder is at fault: nothing was simulated); 4
a numerical failure (the simulation failed, after writing its partial
outputs; for ``flexmb study``, some case failed); 130 interrupted by Ctrl-C
(what was computed is written); 143 or 129 stopped by SIGTERM or SIGHUP
(a batch system's time limit, ``docker stop``, a closed terminal), handled
as Ctrl-C is: 128 + the signal's number (:mod:`flexmb._signals`). Any other
status (1, with a traceback) is a bug in flexmb or a plugin.
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import json
import logging
import os
import sys
import threading

from . import __version__, registry
from ._signals import as_interrupts, interrupted_status, interruption, received
from .errors import FlexmbError, SceneError, SimulationError

__all__ = ["EXIT_STATUS", "main"]

#: the exit statuses of the ``flexmb`` command, by what happened
EXIT_STATUS = {"done": 0, "usage": 2, "input": 3, "failed": 4, "system": 5, "interrupted": 130}
#: ... and 128 + N when signal N (SIGTERM 15, SIGHUP 1) stopped the command (handled as Ctrl-C)
EXIT_OK, EXIT_USAGE, EXIT_INPUT, EXIT_FAILED, EXIT_SYSTEM, EXIT_INTERRUPTED = EXIT_STATUS.values()

_EXIT_HELP = """exit status:
  0    done
  2    usage error: the command line (an unknown option, a missing argument)
  3    input error: the scene file, the model it builds or the output folder is at fault
  4    numerical failure: the simulation failed (partial outputs written); study: some case failed
  5    system error: the machine refused (disk full, a read-only or forbidden folder): nothing half-written
  130  interrupted (Ctrl-C): what was computed is written
  143  stopped by SIGTERM (129: SIGHUP), as Ctrl-C: what was computed is written"""


class _Stderr(logging.StreamHandler):
    """Writes each message alone to the ``sys.stderr`` of the moment (a redirected or captured one too)."""

    def __init__(self):
        super().__init__()
        self.setFormatter(logging.Formatter("%(message)s"))

    @property
    def stream(self):
        return sys.stderr

    @stream.setter
    def stream(self, value):
        pass


@contextlib.contextmanager
def _messages(quiet: bool):
    """Show the ``flexmb`` loggers' messages on stderr while a command runs: INFO and up, WARNING with --quiet."""
    logger = logging.getLogger("flexmb")
    handler, level = _Stderr(), logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.WARNING if quiet else logging.INFO)
    try:
        yield
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)


def _run(args) -> int:
    """Run a scene; Ctrl-C while the outputs are written leaves the folder's last complete run, exit 130."""
    if args.out is None:
        args.out = _default_out(args.scene)
    try:
        return _run_scene(args)
    except KeyboardInterrupt:
        print(f"\nflexmb: interrupted while writing the outputs: {args.out}/ holds the last complete run "
              "(summary.json says what it holds)", file=sys.stderr)
        return interrupted_status()


def _default_out(name: str) -> str:
    """The output folder of a run without ``--out``: ``results/<the scene file's name without .toml>``."""
    return os.path.join("results", os.path.splitext(os.path.basename(os.path.normpath(name)))[0] or "scene")


def _scene(name):
    """The scene named on the command line: a scene file, or a built-in scene (when no such file exists)."""
    from .scene import builtin_scenes, load_builtin, load_scene

    if not os.path.exists(name):
        if name in builtin_scenes():
            return load_builtin(name)
        raise SceneError(f"{name}: cannot read the scene file: no such file, and no built-in scene of that "
                         f"name (the built-in scenes: {', '.join(builtin_scenes())})")
    return load_scene(name)


def _run_scene(args) -> int:
    """Run a scene file or a built-in scene; an interrupted run keeps (and writes) what it computed."""
    scene = _scene(args.scene)
    summary = scene.run(args.out, progress=not args.quiet, overwrite=args.overwrite, t_end=args.t_end,
                        rtol=args.rtol, complement=args.complement, method=args.method, n_out=args.n_out)
    print(json.dumps(summary, indent=2))
    print(f"wrote {args.out}/ ({', '.join(sorted(summary.get('files', {}))) or 'nothing'}"
          f"{', summary.json' if scene.output.summary else ''})")
    if summary["status"] == "interrupted":
        print(f"flexmb: interrupted: {summary['message']}; the outputs hold the run up to then", file=sys.stderr)
        return interrupted_status()
    return EXIT_OK


def _info(args) -> int:
    """Print what a scene file builds: bodies, joints, coordinates, constraints, freedoms."""
    print(_scene(args.scene).info())
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


def _view(args) -> int:
    """Write FOLDER/view.html, the 3-D viewer of a results folder; print its path (and open it with --open)."""
    from .scene.folder_view import view_folder

    kw = {} if args.max_frames is None else {"max_frames": args.max_frames}
    page, notes = view_folder(args.folder, args.out, **kw)
    for note in notes:
        print(f"flexmb: note: {note}", file=sys.stderr)
    print(page)
    if args.open:
        import webbrowser

        webbrowser.open(page.resolve().as_uri())
    return EXIT_OK


def _key_value(text: str, option: str):
    key, sep, value = text.partition("=")
    if not sep or not key.strip() or not value.strip():
        raise FlexmbError(f"{option} {text!r}: write KEY=VALUE, e.g. bodies.bar.mass=2.0")
    return key.strip(), value.strip()


def _study(args) -> int:
    """Run a parameter study of a scene file; exit 4 if some case failed (all others are in the table)."""
    from .study import Study, parse_spec, parse_value

    vary = dict(_key_value(v, "--vary") for v in args.vary)
    fixed = {k: parse_value(v) for k, v in (_key_value(s, "--set") for s in args.set)}
    study = Study.from_file(args.scene, {k: parse_spec(v) for k, v in vary.items()}, outputs=args.output,
                            fixed=fixed, samples=args.samples, seed=args.seed, sampling=args.sampling)
    executor = "serial" if args.serial else "process"
    try:
        result = study.run(args.out, executor=executor, workers=args.workers, scheduler=args.scheduler,
                           progress=not args.quiet, retry_failed=args.retry_failed, time_limit=args.time_limit,
                           overwrite=args.overwrite)
    except KeyboardInterrupt:
        print(f"\nflexmb: interrupted: the finished cases are in {args.out}/cases/; "
              "run the same command again to resume", file=sys.stderr)
        return interrupted_status()
    print(result.summary())
    print(f"wrote {args.out}/ (table.csv, table.npz, cases/, study.png, summary.txt)")
    return EXIT_FAILED if result.failed else EXIT_OK


def _view_parser(sub) -> None:
    """The ``flexmb view`` command's arguments."""
    from .viz.viewer import MAX_BYTES, MAX_FRAMES

    view = sub.add_parser("view", help="write FOLDER/view.html: the results of flexmb run animated in 3-D, "
                                       "in any browser (self-contained, no network)",
                          epilog=_EXIT_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    view.add_argument("folder", help="the output folder of flexmb run (its summary.json and .npz results)")
    view.add_argument("--out", default=None, metavar="FILE", help="the HTML file (default: FOLDER/view.html)")
    view.add_argument("--max-frames", type=int, default=None, metavar="N",
                      help=f"keep at most N output times, evenly spaced (default: {MAX_FRAMES}; the page also "
                           f"keeps at most {MAX_BYTES / 1e6:g} MB of frame data)")
    view.add_argument("--open", action="store_true", help="open the page in the web browser")
    view.set_defaults(func=_view)


def _deprecated_aliases(parser, args) -> None:
    """``flexmb run --integrator NAME`` (the old name of ``--method``): taken as ``--method NAME``, with a note."""
    alias = getattr(args, "integrator", None)
    if alias is None:
        return
    if args.method is not None and args.method != alias:
        parser.error(f"--integrator {alias} and --method {args.method}: give --method alone "
                     "(--integrator is its deprecated alias)")
    print("flexmb: note: --integrator is deprecated, use --method (the scene's [solver] method, "
          "simulate(method=...)); it still works for now", file=sys.stderr)
    args.method = alias


def _plugins_parser(sub) -> None:
    """The ``plugins`` sub-command's parser, added to ``sub``."""
    plug = sub.add_parser("plugins", help="list bodies, joints, forces, constraints, contacts, complements and "
                                          "integrators by name")
    plug.add_argument("--kind", default=None, help="bodies, joints, forces, constraints, contacts, complements or "
                                                   "integrators")
    plug.set_defaults(func=_plugins)


def main(argv=None) -> int:
    """Entry point of the ``flexmb`` command.

    Parameters
    ----------
    argv : list of str, optional
        Arguments (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status (:data:`EXIT_STATUS`): 0 done, 3 input error, 4
        numerical failure, 5 system error (a file or folder refused), 130
        interrupted; a usage error exits with 2 (``SystemExit``, from
        :mod:`argparse`).
    """
    from .scene import builtin_scenes

    scene_help = f"a scene file SCENE.toml, or a built-in scene: {' or '.join(builtin_scenes())}"
    parser = argparse.ArgumentParser(prog="flexmb", description="flexible multibody dynamics", epilog=_EXIT_HELP,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"flexmb {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="simulate a scene file (or a built-in scene) and write results, plots and VTK",
                         epilog=_EXIT_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    run.add_argument("scene", help=scene_help)
    run.add_argument("--out", default=None, metavar="DIR",
                     help="output folder (default: results/NAME, NAME the scene file's name without .toml, or "
                          "the built-in scene's name); a folder holding another scene's outputs is refused")
    run.add_argument("--overwrite", action="store_true",
                     help="replace the outputs of another scene's run in the output folder")
    run.add_argument("--t-end", type=float, default=None, help="end time, s (default: the scene's)")
    run.add_argument("--rtol", type=float, default=None, help="relative tolerance (default: the scene's)")
    run.add_argument("--complement", default=None, help="orthogonal complement strategy: "
                     f"{', '.join(registry.names('complements'))} (default: the scene's)")
    run.add_argument("--method", default=None, metavar="NAME",
                     help=f"integrator, as the scene's [solver] method and simulate(method=...): auto, "
                          f"{', '.join(registry.names('integrators'))} (default: the scene's)")
    run.add_argument("--integrator", default=None, metavar="NAME",
                     help="deprecated alias of --method (still accepted, with a note on stderr)")
    run.add_argument("--n-out", type=int, default=None, help="number of output times (default: the scene's)")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    run.set_defaults(func=_run)
    info = sub.add_parser("info", help="describe a scene file: bodies, coordinates, constraints, freedoms")
    info.add_argument("scene", help=scene_help)
    info.set_defaults(func=_info)
    _view_parser(sub)
    _plugins_parser(sub)
    st = sub.add_parser("study", help="run a parameter study of a scene file on a process pool or a Dask cluster",
                        epilog=_EXIT_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    st.add_argument("scene", help="a scene file SCENE.toml")
    st.add_argument("--vary", action="append", required=True, metavar="KEY=SPEC",
                    help="a scene key path and its values: v1,v2,... | lin:START:STOP:N | log:START:STOP:N | "
                         "uniform:LOW:HIGH | loguniform:LOW:HIGH | normal:MEAN:STD (repeatable; a+b sets both keys)")
    st.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a scene key set to one value in every case, e.g. solver.t_end=0.5 (repeatable)")
    st.add_argument("--output", action="append", default=[], metavar="NAME",
                    help="an output per case, e.g. peak_speed:tip, peak_effort:motor, energy_balance, final:pin "
                         "(repeatable; default: tracked points, drivers, energy balance, residual)")
    st.add_argument("--out", required=True, help="output folder (a study run again there resumes); a folder "
                                                 "holding a run's or another scene's study's outputs is refused")
    st.add_argument("--overwrite", action="store_true",
                    help="replace the outputs of a run or of another scene's study in the output folder")
    st.add_argument("--samples", type=int, default=None, help="number of samples of the random parameters")
    st.add_argument("--seed", type=int, default=0, help="seed of the random samples")
    st.add_argument("--sampling", default="lhs", choices=["lhs", "mc"], help="Latin hypercube or Monte Carlo")
    st.add_argument("--workers", type=int, default=None, help="size of the local process pool (default: CPUs)")
    st.add_argument("--scheduler", default=None, metavar="ADDRESS",
                    help="run on this Dask scheduler, e.g. tcp://10.0.0.1:8786 (pip install -e '.[dask]')")
    st.add_argument("--serial", action="store_true", help="run the cases one after another in this process")
    st.add_argument("--retry-failed", action="store_true", help="run again the cases recorded as failed")
    st.add_argument("--time-limit", type=float, default=None, metavar="SECONDS",
                    help="wall-clock seconds one case may take; a case that takes longer is stopped and recorded "
                         "as failed (default: the scene's [study] time_limit, else none)")
    st.add_argument("--quiet", action="store_true", help="no progress on stderr")
    st.set_defaults(func=_study)
    args = parser.parse_args(argv)
    _deprecated_aliases(parser, args)
    _import_what_it_runs(args.command)
    received.clear()
    try:
        with _messages(getattr(args, "quiet", False)), as_interrupts():
            return args.func(args)
    except (KeyboardInterrupt, SystemError) as exc:  # before a run or a study began: nothing to keep
        if interruption(exc) is None:  # a SystemError not caused by Ctrl-C or a signal: a bug
            raise
        print("\nflexmb: interrupted", file=sys.stderr)
        return interrupted_status()
    except (FlexmbError, OSError) as exc:
        if isinstance(exc, BrokenPipeError):  # flexmb ... | head: console() ends quietly
            raise
        return _error(exc)


def _import_what_it_runs(command: str) -> None:
    """Import what ``flexmb run`` and ``flexmb study`` simulate with before they begin.

    ``import flexmb`` leaves the integrators (and scipy.integrate) to the
    first simulation; the commands import them before they begin, so that a
    signal meanwhile ends the command at once with nothing written
    (:mod:`flexmb_command`), as during the command's other imports.
    """
    if command in ("run", "study"):
        from . import integrators  # noqa: F401


def _error(exc: BaseException) -> int:
    """Print ``flexmb: error: ...`` on one line; the exit status of the error.

    A failed simulation is 4 (its partial outputs are written), another
    flexmb error 3 (the input), an OSError 5 (the machine refused a file or
    folder: disk full, read-only; files are written whole or not at all).
    """
    print(f"flexmb: error: {exc}".replace("\n", " "), file=sys.stderr)
    if isinstance(exc, SimulationError):
        return EXIT_FAILED
    return EXIT_INPUT if isinstance(exc, FlexmbError) else EXIT_SYSTEM


if __name__ == "__main__":
    raise SystemExit(main())


def console() -> None:
    """The ``flexmb`` command (and ``python -m flexmb``): :func:`main`, then a prompt exit.

    Outside :func:`main` (the imports before it, the exit after it) SIGINT,
    SIGTERM and SIGHUP end the process at once with one line and exit
    status 128 + the signal (:mod:`flexmb_command`).

    Once :func:`main` has returned, the process has nothing left to do but
    free its objects one by one, the compiled kernels and their machine
    code among them: after the main job, about 0.3 s. With the standard
    streams flushed and the exit handlers run (``atexit``: logging's, a
    plugin's), the process leaves with :func:`os._exit` instead. It exits
    the usual way if a thread of its own that the interpreter would wait for
    (not a daemon) still runs, or if :func:`main` raised. A daemon thread
    (the timer that answers a signal deferred out of llvmlite's callback) is
    no reason to free everything: an interruption can leave numba's
    compiler half-way, and an interrupted study whose files were all written
    crashed once in some 600 signal deliveries as it exited that way.
    Writing into a pipe that its reader closed (``flexmb plugins | head
    -3``) ends the command quietly, with status 1.
    """
    from flexmb_command import install

    install()  # `python -m flexmb`: from here on (and once main has returned) a signal ends the process at once
    try:
        code = main()
    except BrokenPipeError:  # flexmb ... | head: the reader has what it wanted (Python's "Note on SIGPIPE")
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        sys.exit(1)
    if any(t.is_alive() and not t.daemon for t in threading.enumerate() if t is not threading.main_thread()):
        sys.exit(code)  # a thread would be cut short: let the interpreter join it
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe (flexmb ... | head): what the reader wanted, it has
            code = code or 1
    os._exit(code)
