"""SIGTERM and SIGHUP answered as Ctrl-C is: the run stops where it is and writes what it computed.

A batch system at its wall-time limit (SLURM), ``docker stop``, systemd and a
dropped SSH session stop a process with SIGTERM or SIGHUP, whose default
action kills it on the spot: nothing written, the staging folder and the
lock left behind. Within :func:`as_interrupts` (the ``flexmb`` command) they
raise :class:`Terminated`, a KeyboardInterrupt, so every path that keeps a
Ctrl-C'd run keeps theirs too; the command then exits with 128 + the
signal's number, as a shell reports a process the signal ended (143 for
SIGTERM, 129 for SIGHUP).

Within :func:`as_interrupts` Ctrl-C raises KeyboardInterrupt as Python's own
handler does, with one difference shared by all three: a signal that
arrives while llvmlite calls back into Python (numba's object cache, as the
compiled kernels load or compile) is answered a moment later, once the
callback has returned. An exception raised inside such a callback cannot
propagate through the compiled caller: it was printed ("Exception ignored
on calling ctypes callback function"), the Ctrl-C was lost (a study went on
and exited 0), or the caller went on with a missing result (a segfault).

A signal that is ignored (``SIG_IGN``, as ``nohup`` leaves SIGHUP and a
shell's background command SIGINT) is left ignored by all of these
(:func:`flexmb_command.answered`): the run goes on through it.
"""

from __future__ import annotations

import _signal
import contextlib
import signal
import threading

__all__ = ["Terminated", "act_on_deferred", "as_interrupts", "deferred", "escaped", "held", "in_callback",
           "interrupted_status", "interruption", "who"]

#: the signals taken as an interruption, where the platform has them
SIGNALS = tuple(getattr(signal, s) for s in ("SIGTERM", "SIGHUP") if hasattr(signal, s))

#: the signals :func:`held` holds back: the interruptions and SIGQUIT, where the platform has them
HELD = tuple(getattr(signal, s) for s in ("SIGINT", "SIGTERM", "SIGHUP", "SIGQUIT") if hasattr(signal, s))

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


def _callback_codes() -> set:
    """The code objects of llvmlite's Python callbacks (empty until llvmlite is imported)."""
    import sys

    ee = getattr(sys.modules.get("llvmlite.binding.executionengine"), "ExecutionEngine", None)
    names = ("_raw_object_cache_notify", "_raw_object_cache_getbuffer")
    return {getattr(ee, n).__code__ for n in names if ee is not None and hasattr(getattr(ee, n, None), "__code__")}


def in_callback(frame) -> bool:
    """Whether ``frame`` runs inside a callback of llvmlite (called from compiled code, not from Python).

    Parameters
    ----------
    frame : frame or None
        The frame a signal handler was given.

    Returns
    -------
    bool
    """
    codes = _callback_codes()
    while frame is not None and codes:
        if frame.f_code in codes:
            return True
        frame = frame.f_back
    return False


def _restore(previous: dict) -> None:
    """Put back each signal's handler; an interruption raised meanwhile is raised once all are back."""
    pending = None
    for signum, handler in previous.items():
        while True:
            try:
                _signal.signal(signum, handler)  # (signal's C function: its wrapper's enum is not needed)
                break
            except KeyboardInterrupt as exc:  # a handler ran between two lines: set this one again
                pending = pending or exc
    if pending is not None:
        raise pending


@contextlib.contextmanager
def held():
    """Hold back Ctrl-C, SIGTERM, SIGHUP and SIGQUIT until the block ends, then let the first of them act.

    Blocking the signals is not enough: one that arrived just before the
    block may already be pending in the interpreter, whose Python handler
    (Ctrl-C's KeyboardInterrupt, :class:`Terminated`) would then raise inside
    the block. So, on the main thread, a handler that only records the
    signal stands in for each Python handler for the block's duration; the
    first recorded signal is handed to its own handler at the end. A signal
    left pending by the block acts as it arrives, once the mask is lifted.
    In a child forked inside the block, leaving it only lifts the mask: the
    child keeps the handlers it set (:mod:`flexmb._background` ignores the
    interruptions there).
    """
    import os

    caught, previous = [], {}
    pid = os.getpid()
    if threading.current_thread() is threading.main_thread():
        for signum in HELD:
            if callable(signal.getsignal(signum)):
                previous[signum] = signal.signal(signum, lambda s, frame: caught.append(s))
    block = getattr(signal, "pthread_sigmask", None)
    mask = block(signal.SIG_BLOCK, HELD) if block else None
    try:
        yield
    finally:
        try:
            if os.getpid() == pid:
                _restore(previous)
        finally:
            if block:
                block(signal.SIG_SETMASK, mask)
    if caught and os.getpid() == pid:
        previous[caught[0]](caught[0], None)  # Python's default handler raises KeyboardInterrupt


class deferred:
    """Within the block, Ctrl-C, SIGTERM, SIGHUP and SIGQUIT are recorded, not raised; :func:`act_on_deferred`
    (and the block's end) hands the first to its own handler.

    For compiled loops that call back into Python through ctypes (CVODE's
    Jacobian from Python): an exception raised by a signal handler at a
    callback's first line, before its ``try``, would be printed and lost.
    The handlers are swapped once per block (not per call, as :func:`held`
    does), so the loop can check for an interruption after each return from
    compiled code at the cost of a list's truth test. Nested blocks and
    other threads change nothing.
    """

    #: the signals recorded by the active block (None: no block active)
    caught: list | None = None
    #: the handlers the active block stands in for
    previous: dict = {}

    def __enter__(self):
        self._owner = deferred.caught is None and threading.current_thread() is threading.main_thread()
        if self._owner:
            caught = []
            record = lambda signum, frame: caught.append(signum)  # noqa: E731
            # signal's C functions, without the wrappers that turn their numbers into enums (a callable stays one)
            deferred.previous = {s: _signal.signal(s, record) for s in HELD if callable(_signal.getsignal(s))}
            deferred.caught = caught
        return self

    def __exit__(self, kind, exc, tb):
        if not self._owner:
            return False
        caught, previous = deferred.caught, deferred.previous
        deferred.caught, deferred.previous = None, {}
        _restore(previous)
        if caught and kind is None:
            previous[caught[0]](caught[0], None)  # Python's default handler raises KeyboardInterrupt
        return False


def act_on_deferred() -> None:
    """Within :class:`deferred`, hand the first interruption recorded so far to its own handler (which raises)."""
    caught = deferred.caught
    if caught:
        signum = caught[0]
        del caught[:]
        deferred.previous[signum](signum, None)


def _later(signum) -> None:
    """Send ``signum`` to this process again in a moment (the handler then runs outside the callback)."""
    import os

    timer = threading.Timer(0.005, os.kill, (os.getpid(), signum))
    timer.daemon = True
    timer.start()


def _raise(signum, frame):
    if in_callback(frame):
        _later(signum)
        return
    if signum == signal.SIGINT:
        raise KeyboardInterrupt
    received.append(signum)
    raise Terminated(signum)


@contextlib.contextmanager
def as_interrupts():
    """Within the block, SIGTERM and SIGHUP raise :class:`Terminated`, Ctrl-C KeyboardInterrupt.

    On the main thread; elsewhere nothing changes. A signal that arrives
    inside a callback of llvmlite is answered once the callback has
    returned (see the module's docstring). A signal ignored here
    (``SIG_IGN``: ``nohup``'s SIGHUP, a background command's SIGINT) stays
    ignored (:func:`flexmb_command.answered`).
    """
    from flexmb_command import answered

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.signal(s, _raise) for s in answered((signal.SIGINT, *SIGNALS))}
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


def escaped(exc: BaseException) -> BaseException | None:
    """A BaseException that is no Exception (a study case's time limit, SystemExit) behind numba's SystemError.

    Raised in this thread while a compiled kernel returned, it comes out as
    ``SystemError: CPUDispatcher(...) returned a result with an exception
    set``, the exception as its cause; it must go on as itself.

    Parameters
    ----------
    exc : BaseException

    Returns
    -------
    BaseException or None
    """
    seen = set()
    exc = exc.__cause__ or exc.__context__
    while exc is not None and id(exc) not in seen:
        if not isinstance(exc, Exception):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None
