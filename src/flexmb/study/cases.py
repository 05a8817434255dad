"""One case of a study: built from the scene document, simulated, reduced to its outputs; time limits."""

from __future__ import annotations

import ctypes
import os
import select
import signal
import socket
import threading
import time

from .._signals import interruption
from ..scene.metrics import _evaluate, _output_name
from ..scene.keys import key_paths as _paths, set_key as _set

__all__ = []


def _build(data: dict, source: str, fixed: dict, params: dict):
    from ..scene import scene_from_dict

    import copy

    doc = copy.deepcopy(data)
    for key, value in list(fixed.items()) + list(params.items()):
        for path in _paths(key):
            _set(doc, path, value, source)
    return scene_from_dict(doc, source)


def _run_case(task: dict) -> dict:
    """Build, simulate and reduce one case; never raises for a failing case (module level: picklable)."""
    t0 = time.perf_counter()
    row = {"case": task["case"], "case_id": task["case_id"], "parameters": task["parameters"], "outputs": {},
           "status": "failed", "error": "", "worker": f"{socket.gethostname()}:{os.getpid()}"}
    try:
        scene = _build(task["data"], task["source"], task["fixed"], task["parameters"])
        res = scene.simulate(progress=False)
        if res.status == "interrupted":  # Ctrl-C or a signal stopped the study, not this case: it is not recorded
            raise KeyboardInterrupt(res.message)
        row["status"] = res.status
        if res.status != "finished":
            row["error"] = res.message
        for spec in task["outputs"]:
            row["outputs"][_output_name(spec)] = _evaluate(spec, scene, res)
    except Exception as exc:  # recorded, and the study goes on
        stop = interruption(exc)
        if stop is not None:  # Ctrl-C or a signal as a compiled kernel returned (numba's SystemError): the study's
            raise stop from None
        row["status"] = "failed"
        row["error"] = f"{type(exc).__name__}: {exc}".replace("\n", " ")
    row["wall_time_s"] = time.perf_counter() - t0
    return row


def _failed_row(task: dict, message: str) -> dict:
    return {"case": task["case"], "case_id": task["case_id"], "parameters": task["parameters"], "outputs": {},
            "status": "failed", "error": message, "wall_time_s": float("nan"), "worker": ""}


class _CaseTimeout(BaseException):
    """Raised in the thread of a case that passed its time limit (a BaseException: no ``except Exception`` stops it)."""


def _timeout_message(limit: float) -> str:
    return f"exceeded the time limit of {limit:g} s per case; stopped"


def _run_case_limited(task: dict) -> dict:
    """:func:`_run_case` in this thread, stopped at ``task["time_limit"]`` seconds (serial and Dask executors).

    A timer thread raises :class:`_CaseTimeout` in this thread
    (``PyThreadState_SetAsyncExc``); it takes effect at the next Python
    bytecode, so a case stuck inside one long call of compiled code stops
    when that call returns. Raised just as a compiled kernel returns, it
    comes out as numba's ``SystemError`` instead, which the step loop
    records as a failure: a case that failed after the timer fired is
    recorded as stopped by its time limit all the same. The process
    executor kills the case's process instead (:func:`_execute_pool`).
    """
    limit = task.get("time_limit")
    if not limit:
        return _run_case(task)
    t0 = time.perf_counter()
    tid, lock, state = threading.get_ident(), threading.Lock(), {"done": False, "fired": False}

    def fire():
        with lock:  # never after the case has ended: the exception would hit the caller
            if not state["done"]:
                state["fired"] = True
                ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(tid), ctypes.py_object(_CaseTimeout))

    def stopped():
        row = _failed_row(task, _timeout_message(limit))
        row.update(wall_time_s=time.perf_counter() - t0, worker=f"{socket.gethostname()}:{os.getpid()}")
        return row

    timer = threading.Timer(limit, fire)
    timer.daemon = True
    try:
        try:
            timer.start()
            row = _run_case(task)
        finally:
            with lock:
                state["done"] = True
            timer.cancel()
        return stopped() if state["fired"] and row["status"] != "finished" else row
    except _CaseTimeout:
        return stopped()


def _watch_study(pid: int) -> None:
    """End this process (a case's) as soon as the study process ``pid`` ends, even by SIGKILL.

    On Linux a watcher *process* forked here waits on pidfds of the study
    and of this case and sends this case SIGKILL when the study ends first;
    it ends with the case. A thread would not do: it needs the GIL, which a
    case stuck in compiled code keeps (numba without ``nogil``, any C call
    made with the GIL held), and such a case would outlive its study.
    ``PR_SET_PDEATHSIG`` would not do either: under the ``forkserver`` start
    method the parent of a case's process is the fork server, not the
    study, and the fork server lives on while any case process holds its
    liveness pipe. Once the cases end, the fork server and the resource
    tracker see their pipes close and end too. Elsewhere (no pidfd) a daemon
    thread polls ``os.kill(pid, 0)`` twice a second and calls ``os._exit``.
    """
    try:
        study = os.pidfd_open(pid)
        case = os.pidfd_open(os.getpid())
    except ProcessLookupError:
        os._exit(70)
    except (AttributeError, OSError):
        threading.Thread(target=_poll_study, args=(pid,), name="flexmb-study-watchdog", daemon=True).start()
        return
    if os.fork() == 0:  # the watcher: holds no pipe of the case's, needs nothing of its interpreter
        try:
            low = 3
            for keep in sorted((study, case)):
                os.closerange(low, keep)
                low = keep + 1
            os.closerange(low, os.sysconf("SC_OPEN_MAX"))
            ready, _, _ = select.select([study, case], [], [])
            if study in ready and case not in ready:
                signal.pidfd_send_signal(case, signal.SIGKILL)  # that process, even if its pid were reused
        finally:
            os._exit(0)
    os.close(study)
    os.close(case)


def _poll_study(pid: int) -> None:
    """Wait for process ``pid`` to end, polling twice a second, then end this process."""
    while True:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            break
        except PermissionError:
            pass
        time.sleep(0.5)
    os._exit(70)


def _case_process(task: dict, conn, study_pid: int) -> None:
    """Body of the process of one case (process executor): run it, send its row back."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the study's: it stops its cases
    _watch_study(study_pid)
    row = _run_case(task)
    try:
        conn.send(row)
    except Exception as exc:  # e.g. an output that cannot be pickled
        conn.send(_failed_row(task, f"{type(exc).__name__}: {exc}"))
    conn.close()
