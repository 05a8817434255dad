"""Writing files in a child process while the caller computes on (Linux), or inline elsewhere.

The main job writes two VTK series of a few hundred files each; the files
of one run are written by a forked child while the next run is simulated
and the plots are drawn, on the machine's second core. The child:

* is a fork, so it shares the parent's data and compiled kernels and
  starts at once;
* ignores Ctrl-C, SIGTERM and SIGHUP (the job is short; the parent handles
  the interruption and waits for it, so that what was written is complete:
  a terminal's Ctrl-C, SLURM and systemd signal the whole process group);
* dies with its parent (``PR_SET_PDEATHSIG``): a killed job leaves no
  process writing on;
* leaves by ``os._exit``, running none of the parent's clean-up.

The plot of the main job is drawn by a :class:`Worker`: a child forked
before the first run, which imports matplotlib at once (on the second core,
while the runs compute) and then waits for the one call the parent sends it
once the figure's data are ready.

Where ``os.fork`` is not available or safe (Windows, macOS) the function
runs inline, before :func:`in_background` (or :meth:`Worker.run`) returns.
"""

from __future__ import annotations

import contextlib
import logging
import os
import pickle
import select
import signal
import struct
import sys
import time
import traceback
import warnings

from ._signals import held

__all__ = ["in_background", "Job", "Worker", "start_worker", "wait_all"]

#: what a child ignores: its parent answers them (a terminal's Ctrl-C, SLURM and systemd signal the whole group)
_INTERRUPTIONS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n))

#: pipe capacity asked for the worker's message (Linux; a larger message is sent in pieces as the child reads)
_PIPE_SIZE = 1 << 20

#: seconds a worker may take to prepare (an import takes well under one); a child not ready by then is taken
#: for stuck (a lock another thread held at the fork) and killed, and its call is made in the parent
READY_TIMEOUT = 60.0

log = logging.getLogger("flexmb")


def _die_with_parent(parent: int) -> None:
    """Ask Linux to kill this process when its parent dies (best effort).

    The request only covers a parent alive when it is made: a parent that
    died between the fork and here (a busy machine can run it first) has
    already left this process to init, so it leaves at once too.
    """
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        PR_SET_PDEATHSIG = 1
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent:
        os._exit(1)


class Job:
    """A function running in a forked child (``pid``), or already run inline (``pid`` None).

    Parameters
    ----------
    pid : int or None
        The child's process id.
    fn : callable
        The function (rerun inline by :meth:`wait` if the child failed, to
        raise its error in the parent).
    """

    def __init__(self, pid, fn):
        self.pid = pid
        self.fn = fn

    def wait(self, rerun_on_failure: bool = True) -> bool:
        """Wait for the child; True if it succeeded (or ran inline).

        An interruption (Ctrl-C, SIGTERM) while waiting kills the child
        before it is raised here: what the child was writing goes with the
        staging folder of the interrupted write, and no child writes on
        into it once the caller has removed it.

        Parameters
        ----------
        rerun_on_failure : bool
            If the child failed, run the function again here, so that its
            error is raised in the caller (with its traceback).

        Returns
        -------
        bool
            Whether the work is done.
        """
        if self.pid is None:
            return True
        pid, self.pid = self.pid, None
        try:
            status = _reap(pid)
        except BaseException:
            _kill(pid)
            raise
        if os.waitstatus_to_exitcode(status) == 0:
            return True
        if rerun_on_failure:
            self.fn()
            return True
        return False

    def kill(self) -> None:
        """End the child at once (nothing if it ran inline or was waited for)."""
        pid, self.pid = self.pid, None
        if pid is not None:
            _kill(pid)


def _reap(pid: int) -> int:
    """The wait status of child ``pid``, once it has ended."""
    while True:
        try:
            return os.waitpid(pid, 0)[1]
        except InterruptedError:
            continue


def _kill(pid: int) -> None:
    """SIGKILL child ``pid`` and reap it; an interruption meanwhile is raised once it is reaped."""
    with contextlib.suppress(ProcessLookupError):
        os.kill(pid, signal.SIGKILL)
    interrupted = None
    while True:
        try:
            _reap(pid)
            break
        except ChildProcessError:
            break
        except KeyboardInterrupt as exc:  # a second Ctrl-C: the child dies at once all the same
            interrupted = interrupted or exc
    if interrupted is not None:
        raise interrupted


def wait_all(jobs) -> None:
    """:meth:`Job.wait` for each of ``jobs``; an interruption kills the jobs not yet waited for, then is raised.

    Parameters
    ----------
    jobs : iterable of Job
        The jobs writing into a staging folder that is committed (or
        removed) once they have ended.
    """
    jobs = list(jobs)
    for i, job in enumerate(jobs):
        try:
            job.wait()
        except BaseException:
            for rest in jobs[i + 1:]:
                rest.kill()
            raise


def _can_fork() -> bool:
    return sys.platform.startswith("linux") and hasattr(os, "fork")


def _fork(register=None):
    """``os.fork()`` with the streams flushed first; in the child, interruptions ignored and death with the parent.

    The interruptions are blocked across the fork, so that none reaches the
    child before it ignores them (it would run the parent's handler there),
    and none interrupts the parent before ``register(pid)`` has recorded the
    child (a child nobody knows of would write on after an interruption).
    """
    for stream in (sys.stdout, sys.stderr):
        stream.flush()
    with held():
        with warnings.catch_warnings():
            # Python 3.12+ warns about forking a process with threads (BLAS pools, tqdm's monitor): the
            # child only runs numpy, matplotlib and file writes, no lock those threads could hold
            warnings.simplefilter("ignore", DeprecationWarning)
            parent = os.getpid()
            pid = os.fork()
        if pid == 0:
            for s in _INTERRUPTIONS:
                signal.signal(s, signal.SIG_IGN)
        elif register is not None:
            register(pid)
    if pid == 0:
        _die_with_parent(parent)
    return pid


def in_background(fn, jobs: list | None = None) -> Job:
    """Start ``fn()`` in a forked child process (Linux), or run it now (elsewhere).

    Parameters
    ----------
    fn : callable
        Work without a result: writing files (the child's return value and
        changes to objects are lost).
    jobs : list of Job, optional
        Where the job is appended, before an interruption can be raised:
        the caller that waits for ``jobs`` (:func:`wait_all`) then knows
        every child it started.

    Returns
    -------
    Job
        :meth:`Job.wait` before using what ``fn`` writes.
    """
    if not _can_fork():
        fn()
        job = Job(None, fn)
        if jobs is not None:
            jobs.append(job)
        return job
    made = []

    def register(pid):
        made.append(Job(pid, fn))
        if jobs is not None:
            jobs.append(made[0])

    pid = _fork(register)
    if pid == 0:  # the child
        code = 1
        try:
            fn()
            code = 0
        except BaseException:
            traceback.print_exc()
        finally:
            os._exit(code)
    return made[0]


def _read_exactly(fd: int, size: int) -> bytes:
    """``size`` bytes from ``fd``, or fewer if the other end closed first."""
    parts, left = [], size
    while left:
        part = os.read(fd, min(left, _PIPE_SIZE))
        if not part:
            break
        parts.append(part)
        left -= len(part)
    return b"".join(parts)


class Worker:
    """A child that ran ``prepare()`` as soon as it was forked and waits for one call.

    Made by :func:`start_worker`. The call is sent by :meth:`run`, its
    function and arguments pickled through a pipe (the function by name:
    a module-level function); :meth:`cancel` lets the child go without one.

    Parameters
    ----------
    pid : int or None
        The child's process id (None: no child, :meth:`run` runs inline).
    fd : int or None
        The writing end of the pipe to the child.
    ready : int or None
        The reading end of the pipe on which the child says it has prepared.
    """

    def __init__(self, pid, fd, ready=None):
        self.pid = pid
        self.fd = fd
        self.ready = ready
        self.started = time.monotonic()

    def _take(self):
        """The child's pid and pipes, once: the worker is spent."""
        taken = self.pid, self.fd, self.ready
        self.pid = self.fd = self.ready = None
        return taken

    def _prepared(self, ready) -> bool:
        """Whether the child said it has prepared, waiting until ``READY_TIMEOUT`` after its fork."""
        if ready is None:
            return True
        try:
            left = max(0.0, READY_TIMEOUT - (time.monotonic() - self.started))
            return bool(select.select([ready], [], [], left)[0])
        finally:
            os.close(ready)

    def run(self, fn, *args) -> Job:
        """Have the child call ``fn(*args)`` (or call it here if there is no child).

        Parameters
        ----------
        fn : callable
            A module-level function (pickled by name); work without a result,
            as for :func:`in_background`.
        *args
            Its arguments: plain, picklable data.

        Returns
        -------
        Job
            :meth:`Job.wait` before using what ``fn`` writes; a failure in
            the child runs ``fn(*args)`` again here to raise its error.
        """
        def call():
            fn(*args)

        if self.pid is None:
            call()
            return Job(None, call)
        pid, fd, ready = self._take()
        if not self._prepared(ready):  # stuck: the call is made here instead
            log.warning("a worker child (pid %d) did not prepare within %g s: its call is made in this process",
                        pid, READY_TIMEOUT)
            os.close(fd)
            os.kill(pid, signal.SIGKILL)
            Job(pid, None).wait(rerun_on_failure=False)
            call()
            return Job(None, call)
        message = pickle.dumps((fn, args), protocol=pickle.HIGHEST_PROTOCOL)
        try:
            os.write(fd, struct.pack("<Q", len(message)))
            view = memoryview(message)
            while view:
                view = view[os.write(fd, view):]
        except BrokenPipeError:  # the child is gone: Job.wait sees it failed and calls fn here
            pass
        finally:
            os.close(fd)
        return Job(pid, call)

    def cancel(self) -> None:
        """Let the child leave without a call, and wait for it (nothing if :meth:`run` was called)."""
        if self.pid is None:
            return
        pid, fd, ready = self._take()
        if ready is not None:
            os.close(ready)
        os.close(fd)  # the child reads the end of the pipe and leaves
        Job(pid, None).wait(rerun_on_failure=False)


def _serve(fd: int, ready: int, prepare) -> int:
    """The worker child's life: prepare, say so, read one call, make it; the exit code."""
    with contextlib.suppress(Exception):  # the call then fails the same way, and is rerun in the parent
        prepare()
    with contextlib.suppress(OSError):  # the parent gave up waiting: it reads no more
        os.write(ready, b"1")
    os.close(ready)
    header = _read_exactly(fd, 8)
    if len(header) < 8:  # cancelled (or the parent is gone)
        return 0
    (size,) = struct.unpack("<Q", header)
    message = _read_exactly(fd, size)
    if len(message) < size:  # the parent stopped while sending (Ctrl-C): nothing to do
        return 0
    fn, args = pickle.loads(message)
    fn(*args)
    return 0


def start_worker(prepare) -> Worker:
    """Fork a :class:`Worker` that calls ``prepare()`` at once (Linux), or a stand-in that runs calls inline.

    Parameters
    ----------
    prepare : callable
        What the child does while the parent computes on, before it waits
        (e.g. importing matplotlib). Its failure is not reported here: the
        call sent later fails the same way and is then rerun in the parent.

    Returns
    -------
    Worker
        Send it the call with :meth:`Worker.run`, or :meth:`Worker.cancel` it.
    """
    if not _can_fork():
        return Worker(None, None)
    read_fd, write_fd = os.pipe()
    ready_r, ready_w = os.pipe()
    import fcntl

    with contextlib.suppress(AttributeError, OSError):  # else the message goes in pieces, as the child reads
        fcntl.fcntl(write_fd, fcntl.F_SETPIPE_SZ, _PIPE_SIZE)
    pid = _fork()
    if pid == 0:  # the child
        code = 1
        try:
            os.close(write_fd)
            os.close(ready_r)
            code = _serve(read_fd, ready_w, prepare)
        except BaseException:
            traceback.print_exc()
        finally:
            os._exit(code)
    os.close(read_fd)
    os.close(ready_w)
    return Worker(pid, write_fd, ready_r)
