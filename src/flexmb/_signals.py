"""SIGTERM and SIGHUP answered as Ctrl-C is: the run stops where it is and writes what it computed.

A batch system at its wall-time limit (SLURM), ``docker stop``, systemd and a
dropped SSH session stop a process with SIGTERM or SIGHUP, whose default
action kills it on the spot: nothing written, the staging folder and the
lock left behind. Within :func:`as_interrupts` (the ``flexmb`` command) they
raise :class:`Terminated`, a KeyboardInterrupt, so every path that keeps a
Ctrl-C'd run keeps theirs too; the command then exits with 128 + the
signal's number, as a shell reports a process the signal ended (143 for
SIGTERM, 129 for SIGHUP).
"""

from __future__ import annotations

import contextlib
import signal
import threading

__all__ = ["Terminated", "as_interrupts", "interrupted_status", "interruption", "interruption_behind", "who"]

#: the signals taken as an interruption, where the platform has them
SIGNALS = tuple(getattr(signal, s) for s in ("SIGTERM", "SIGHUP") if hasattr(signal, s))

#: the signals received within :func:`as_interrupts` in this process, in order
received: list[int] = []


class Terminated(KeyboardInterrupt):
    """A SIGTERM or SIGHUP, raised where Ctrl-C's KeyboardInterrupt would be.

    Parameters
    ----------
    signum : int
        The signal's number.
    """

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def _raise(signum, frame):
    received.append(signum)
    raise Terminated(signum)


@contextlib.contextmanager
def as_interrupts():
    """Within the block, SIGTERM and SIGHUP raise :class:`Terminated` (on the main thread; elsewhere no change)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.signal(s, _raise) for s in SIGNALS}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


def interrupted_status() -> int:
    """The exit status of an interrupted command: 128 + the last terminating signal received, else 130 (Ctrl-C).

    Returns
    -------
    int
    """
    return 128 + int(received[-1]) if received else 130


def who(exc: BaseException) -> str:
    """Who interrupted: ``'SIGTERM'``, ``'SIGHUP'`` or ``'the user'`` (Ctrl-C).

    Parameters
    ----------
    exc : KeyboardInterrupt

    Returns
    -------
    str
    """
    return signal.Signals(exc.signum).name if isinstance(exc, Terminated) else "the user"


def interruption(exc: BaseException):
    """The Ctrl-C or signal behind ``exc``, or None.

    A KeyboardInterrupt raised while a compiled kernel returns comes out as
    numba's ``SystemError: CPUDispatcher(...) returned a result with an
    exception set``, the interruption as its cause: it is the interruption
    all the same.

    Parameters
    ----------
    exc : BaseException

    Returns
    -------
    KeyboardInterrupt or None
    """
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


def interruption_behind(exc: BaseException):
    """:func:`interruption` of a numba ``SystemError``; any other BaseException behind it is raised.

    An exception that is not an :class:`Exception` (a study case's time
    limit, ``SystemExit``) raised while a compiled kernel returns comes out
    as numba's ``SystemError`` too; it must go on, as it would have without
    the kernel in between.

    Parameters
    ----------
    exc : BaseException

    Returns
    -------
    KeyboardInterrupt or None

    Raises
    ------
    BaseException
        The one behind ``exc``, if it is neither an Exception nor a KeyboardInterrupt.
    """
    seen = set()
    cause = exc
    while cause is not None and id(cause) not in seen:
        if not isinstance(cause, (Exception, KeyboardInterrupt)):
            raise cause from exc
        seen.add(id(cause))
        cause = cause.__cause__ or cause.__context__
    return interruption(exc)
