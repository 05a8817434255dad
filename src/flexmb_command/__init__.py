"""The ``flexmb`` command's entry point: Ctrl-C and signals answered from its first instant.

The command's code lives in :mod:`flexmb.cli`, but importing it imports
:mod:`flexmb` first: numba, scipy and the compiled kernels, seconds of
start-up during which a Ctrl-C raised KeyboardInterrupt somewhere inside an
import (a traceback), or inside llvmlite's callback while the kernels
loaded (a crash). This package imports nothing heavy: :func:`console`
installs :func:`leave_at_once` for SIGINT, SIGTERM and SIGHUP, then imports
the command. Until the command has begun (and again once it has ended, while
the process exits) such a signal ends the process at once, with one line,
``flexmb: interrupted``, and exit status 128 + the signal's number (130 for
Ctrl-C): nothing has been written yet, or all of it has. While the command
runs, its own handlers answer them (:mod:`flexmb._signals`): the run stops
where it is and writes what it computed.

A signal the process started with ignored stays ignored, here and while
the command runs (:func:`answered`): ``nohup flexmb run ...`` goes on
through a hangup (SIGHUP), and a command a shell script started in the
background (``flexmb run ... &``, SIGINT ignored) goes on through the
terminal's Ctrl-C, as a Unix command does.

``python -m flexmb`` imports the package :mod:`flexmb` before it reaches
``flexmb/__main__.py``: the package calls :func:`install` first thing when
:func:`module_run` says that it is being imported for ``-m flexmb``.
"""

import os
import signal

__all__ = ["SIGNALS", "answered", "console", "install", "leave_at_once", "module_run"]

#: the signals answered, where the platform has them
SIGNALS = tuple(getattr(signal, s) for s in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, s))


def leave_at_once(signum, frame) -> None:
    """A signal handler: write ``flexmb: interrupted`` to stderr and end the process with 128 + ``signum``.

    :func:`os._exit` leaves wherever the interpreter is (an import, a
    callback from compiled code) without unwinding it.

    Parameters
    ----------
    signum : int
        The signal's number.
    frame : frame or None
        Unused.
    """
    try:
        os.write(2, b"\nflexmb: interrupted\n")
    except OSError:
        pass
    os._exit(128 + signum)


#: the interpreter's options that take a value as the next argument (``-X importtime``, ``-W error``)
_OPTIONS_WITH_VALUE = ("-X", "-W", "--check-hash-based-pycs")


def module_run(orig_argv) -> str | None:
    """The module that ``python ... -m MODULE ...`` runs, or None if the interpreter was started otherwise.

    Parameters
    ----------
    orig_argv : sequence of str
        The interpreter's own command line (:data:`sys.orig_argv`).

    Returns
    -------
    str or None
        ``"flexmb"`` for ``python -X importtime -m flexmb run wiper``;
        None for a script, ``-c`` or an interactive interpreter.
    """
    args = list(orig_argv[1:])
    while args:
        arg = args.pop(0)
        if arg == "-m":
            return args[0] if args else None
        if arg.startswith("-m"):
            return arg[2:]
        if arg in _OPTIONS_WITH_VALUE:
            args = args[1:]
        elif arg == "-" or not arg.startswith("-") or arg.startswith("-c"):
            return None  # a script, standard input or -c: no module
    return None


def answered(signals) -> tuple:
    """Those of ``signals`` that flexmb may answer: every one not ignored (``SIG_IGN``) in this process.

    A signal ignored when the process started (``nohup`` ignores SIGHUP; a
    shell without job control starts a background command with SIGINT and
    SIGQUIT ignored) was ignored on purpose by whoever started it: flexmb
    never installs a handler in its place, so it stays ignored for the
    process's life, and in the processes it starts (an ignored signal
    stays ignored across ``fork`` and ``exec``). flexmb itself ignores
    signals only in processes it starts for its own work: the forked
    writers of :mod:`flexmb._background` (all three; they end with their
    parent) and a study's case processes (Ctrl-C, which the study answers).

    Parameters
    ----------
    signals : iterable of int
        Signal numbers.

    Returns
    -------
    tuple of int
        Those whose handler is not ``SIG_IGN``, in their order.
    """
    return tuple(s for s in signals if signal.getsignal(s) != signal.SIG_IGN)


def install() -> None:
    """Answer SIGINT, SIGTERM and SIGHUP by :func:`leave_at_once` (the main thread only), those not ignored."""
    for s in answered(SIGNALS):
        signal.signal(s, leave_at_once)


def console() -> None:
    """The ``flexmb`` command: :func:`install`, then :func:`flexmb.cli.console`."""
    install()
    from flexmb.cli import console as run

    run()
