"""Writing files in a child process while the caller computes on (Linux), or inline elsewhere.

The main job writes two VTK series of a few hundred files each; the files
of one run are written by a forked child while the next run is simulated
and the plots are drawn, on the machine's second core. The child:

* is a fork, so it shares the parent's data and compiled kernels and
  starts at once;
* ignores Ctrl-C (the job is short; the parent handles the interruption and
  waits for it, so that what was written is complete);
* dies with its parent (``PR_SET_PDEATHSIG``): a killed job leaves no
  process writing on;
* leaves by ``os._exit``, running none of the parent's clean-up.

Where ``os.fork`` is not available or safe (Windows, macOS) the function
runs inline, before :func:`in_background` returns.
"""

from __future__ import annotations

import os
import signal
import sys
import traceback
import warnings

__all__ = ["in_background", "Job"]


def _die_with_parent() -> None:
    """Ask Linux to kill this process when its parent dies (best effort)."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        PR_SET_PDEATHSIG = 1
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    except (OSError, AttributeError):
        pass


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
        while True:
            try:
                _, status = os.waitpid(pid, 0)
                break
            except InterruptedError:
                continue
        if os.waitstatus_to_exitcode(status) == 0:
            return True
        if rerun_on_failure:
            self.fn()
            return True
        return False


def in_background(fn) -> Job:
    """Start ``fn()`` in a forked child process (Linux), or run it now (elsewhere).

    Parameters
    ----------
    fn : callable
        Work without a result: writing files (the child's return value and
        changes to objects are lost).

    Returns
    -------
    Job
        :meth:`Job.wait` before using what ``fn`` writes.
    """
    if not sys.platform.startswith("linux") or not hasattr(os, "fork"):
        fn()
        return Job(None, fn)
    for stream in (sys.stdout, sys.stderr):
        stream.flush()
    with warnings.catch_warnings():
        # Python 3.12+ warns about forking a process with threads (BLAS pools, tqdm's monitor): the
        # child only runs numpy and file writes, no lock those threads could hold
        warnings.simplefilter("ignore", DeprecationWarning)
        pid = os.fork()
    if pid == 0:  # the child
        code = 1
        try:
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            _die_with_parent()
            fn()
            code = 0
        except BaseException:
            traceback.print_exc()
        finally:
            os._exit(code)
    return Job(pid, fn)
