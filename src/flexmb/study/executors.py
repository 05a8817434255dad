"""Where the cases of a study run: serially, one process per case, or on a Dask cluster; and the progress bar."""

from __future__ import annotations

import ast
import contextlib
import io
import logging
import math
import multiprocessing
import os
import pickle
import socket
import sys
import time
import types
from collections import deque

from ..errors import FlexmbError
from ..progress import Progress
from .cases import _case_process, _failed_row, _run_case_limited, _timeout_message

# the study's messages keep the package's logger name
log = logging.getLogger("flexmb.study")

__all__ = ['WORKER_ENV', 'default_workers']


def _start_method() -> str:
    return "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"


def default_workers() -> int:
    """Number of CPUs this process may use (the default size of the process pool).

    Returns
    -------
    int
        ``len(os.sched_getaffinity(0))`` where available, else ``os.cpu_count()``.
    """
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:
        return max(1, os.cpu_count() or 1)


def _execute_serial(tasks, record, workers):
    for task in tasks:
        record(task, _run_case_limited(task))


#: environment of the worker processes: one BLAS thread each, as Dask's nanny sets it, so that the
#: workers do not oversubscribe the cores and the process pool and Dask give bit-identical results
WORKER_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def _from_main(tasks) -> list[str]:
    """The objects of the script run as ``__main__`` that the tasks hold (output functions defined there).

    Such objects are pickled by reference to ``__main__``, so a case
    process must import the script to find them; nothing else in a task
    needs it.
    """
    found = []

    class Finder(pickle.Pickler):
        def reducer_override(self, obj):
            named = isinstance(obj, (type, types.FunctionType))
            if (getattr(obj, "__module__", None) if named else type(obj).__module__) == "__main__":
                found.append(getattr(obj, "__qualname__", None) if named else type(obj).__qualname__)
            return NotImplemented

    try:
        Finder(io.BytesIO()).dump(tasks)
    except Exception:  # noqa: BLE001 - not picklable here: the case process will say why
        pass
    return sorted(set(n for n in found if n))


def _is_main_test(test) -> bool:
    """Whether an ``if`` test reads ``__name__ == "__main__"`` (either way round)."""
    if not (isinstance(test, ast.Compare) and len(test.ops) == 1 and isinstance(test.ops[0], ast.Eq)):
        return False
    sides = [test.left, test.comparators[0]]
    return (any(isinstance(x, ast.Name) and x.id == "__name__" for x in sides)
            and any(isinstance(x, ast.Constant) and x.value == "__main__" for x in sides))


def _guarded(statements, line: int) -> bool:
    """Whether ``line`` lies in the body of an ``if __name__ == "__main__":`` among these statements."""
    for node in statements:
        if not node.lineno <= line <= (node.end_lineno or node.lineno):
            continue
        if isinstance(node, ast.If) and _is_main_test(node.test) and any(
                n.lineno <= line <= (n.end_lineno or n.lineno) for n in node.body):
            return True
        blocks = [getattr(node, f, None) or [] for f in ("body", "orelse", "finalbody")]
        blocks += [h.body for h in getattr(node, "handlers", None) or []]
        return any(_guarded(b, line) for b in blocks if b and isinstance(b[0], ast.stmt))
    return False


def _unguarded_call() -> tuple[str, int] | None:
    """The script and line, if the script run as ``__main__`` calls this at its top level without the guard.

    A case process that imports the script runs its top level again;
    under ``if __name__ == "__main__":`` the study is not run again there.
    """
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if not path or not os.path.isfile(path):
        return None  # a notebook, python -c, an interactive session: nothing is imported again
    frame = sys._getframe(1)
    while frame is not None and not (frame.f_globals is vars(main) and frame.f_code.co_name == "<module>"):
        frame = frame.f_back
    if frame is None:
        return None
    try:
        with open(path, encoding="utf-8") as fh:
            tree = ast.parse(fh.read())
    except (OSError, SyntaxError, ValueError):
        return None
    return None if _guarded(tree.body, frame.f_lineno) else (path, frame.f_lineno)


@contextlib.contextmanager
def _script_not_imported():
    """Start processes that do not import the script run as ``__main__``.

    ``spawn`` and ``forkserver`` children import the parent's ``__main__``
    again (as ``__mp_main__``) when it has a file or a module name, running
    its top level: a study at the top level of a plain script would run
    again in every case process. While this block runs, ``__main__`` is an
    empty module, so the children have nothing to import.
    """
    main = sys.modules.get("__main__")
    sys.modules["__main__"] = types.ModuleType("__main__")
    try:
        yield
    finally:
        sys.modules["__main__"] = main


def _check_pool(tasks) -> None:
    """Refuse, before any case runs, a study the process pool cannot run from where it was called.

    Parameters
    ----------
    tasks : list of dict
        The cases to run.

    Raises
    ------
    FlexmbError
        If the tasks hold functions defined in the script run as
        ``__main__`` (which each case process must then import) and the
        script runs the study at its top level without ``if __name__ ==
        "__main__":`` (importing it would run the study again): the message
        says what to add.
    """
    names = _from_main(tasks)
    where = _unguarded_call() if names else None
    if where is None:
        return
    path, line = where
    raise FlexmbError(
        f"{path}, line {line}: the study runs at the top level of the script, and its outputs use "
        f"{', '.join(names)} defined in that script, so each case process imports the script, which would run "
        "the study again. Put the study under\n\n    if __name__ == \"__main__\":\n        ...\n\nat the end "
        f"of the script, or move {', '.join(names)} into a module of its own, or run with executor='serial'")


def _execute_pool(tasks, record, workers):
    """Each case in its own process, at most ``workers`` at a time; the study kills a case at its time limit.

    A process per case (forked by the ``forkserver``, which has imported
    flexmb once, so a case starts in milliseconds) makes both failures
    exact: a case that passes ``task["time_limit"]`` is killed by this
    process, recorded as failed with the reason, and the study goes on; a
    case that kills its process is recorded as failed, and no other case is
    disturbed. Each case process ends when the study process ends
    (:func:`_watch_study`), even if it is killed. The case processes import
    the script run as ``__main__`` only if a task holds a function defined
    there (:func:`_check_pool`), so a study works from the top level of a
    plain script, and the script's other top-level code runs once.
    """
    from multiprocessing.connection import wait

    ctx = multiprocessing.get_context(_start_method())
    if ctx.get_start_method() == "forkserver":
        ctx.set_forkserver_preload(["flexmb.study"])
    hide = contextlib.nullcontext if _from_main(tasks) else _script_not_imported
    queue, running = deque(tasks), {}
    saved = {k: os.environ.get(k) for k in WORKER_ENV}
    os.environ.update(WORKER_ENV)  # read by the cases' BLAS when they start (this process's is loaded)
    try:
        while queue or running:
            while queue and len(running) < workers:
                task = queue.popleft()
                reader, writer = ctx.Pipe(duplex=False)
                proc = ctx.Process(target=_case_process, args=(task, writer, os.getpid()), daemon=True,
                                   name=f"flexmb-case-{task['case_id']}")
                with hide():
                    proc.start()
                writer.close()
                limit = task.get("time_limit")
                running[proc.sentinel] = (proc, reader, task, time.perf_counter(), limit or math.inf)
            now = time.perf_counter()
            timeout = min(t0 + limit for _, _, _, t0, limit in running.values()) - now
            ready = set(wait([r for _, r, _, _, _ in running.values()] + list(running),
                             timeout=None if math.isinf(timeout) else max(timeout, 0.0)))
            now = time.perf_counter()
            for sentinel, (proc, reader, task, t0, limit) in list(running.items()):
                row = None
                if reader in ready or sentinel in ready:
                    try:
                        row = reader.recv() if reader.poll() else None
                    except (EOFError, OSError):
                        row = None
                    if row is None and sentinel not in ready:
                        continue  # (not a row yet: the pipe only closed) wait for the process
                    if row is None:
                        row = _failed_row(task, "worker process died while running this case")
                elif now - t0 >= limit:
                    proc.kill()
                    row = _failed_row(task, _timeout_message(limit))
                    row.update(wall_time_s=now - t0, worker=f"{socket.gethostname()}:{proc.pid}")
                else:
                    continue
                proc.join(5.0)
                if proc.is_alive():
                    proc.kill()
                    proc.join()
                reader.close()
                proc.close()
                del running[sentinel]
                record(task, row)
    finally:
        for proc, reader, *_ in running.values():
            proc.kill()
            proc.join()
            reader.close()
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _execute_dask(tasks, record, client):
    from distributed import as_completed

    futures = {client.submit(_run_case_limited, task, pure=False, key=f"flexmb-case-{task['case_id']}-{task['study'][:8]}"):
               task for task in tasks}
    try:
        for fut in as_completed(list(futures)):
            task = futures[fut]
            try:
                row = fut.result()
            except Exception as exc:  # KilledWorker, lost connection, ...
                row = _failed_row(task, f"{type(exc).__name__}: {exc}".replace("\n", " "))
            record(task, row)
    finally:
        client.cancel([f for f in futures if not f.done()])


class _Progress:
    """The study's progress bar (:mod:`flexmb.progress`): cases done, failed ones noted, time left."""

    def __init__(self, total: int, already: int, enabled: bool):
        self.total, self.already, self.enabled = total, already, enabled
        self.done = self.failed = 0
        if already:
            log.info("study: %d of %d cases done before, running the other %d", already, total, total - already)
        self.bar = Progress(total, "study", "cases", enabled=enabled, initial=already)

    def update(self, row: dict) -> None:
        self.done += 1
        self.failed += row["status"] != "finished"
        if self.failed:
            self.bar.note(f"{self.failed} failed")
        self.bar.update_to(self.already + self.done)

    def close(self) -> None:
        self.bar.close()
