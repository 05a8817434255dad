"""Where the cases of a study run: serially, one process per case, or on a Dask cluster; and the progress bar."""

from __future__ import annotations

import logging
import math
import multiprocessing
import os
import socket
import time
from collections import deque

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


def _execute_pool(tasks, record, workers):
    """Each case in its own process, at most ``workers`` at a time; the study kills a case at its time limit.

    A process per case (forked by the ``forkserver``, which has imported
    flexmb once, so a case starts in milliseconds) makes both failures
    exact: a case that passes ``task["time_limit"]`` is killed by this
    process, recorded as failed with the reason, and the study goes on; a
    case that kills its process is recorded as failed, and no other case is
    disturbed. Each case process ends when the study process ends
    (:func:`_watch_study`), even if it is killed.
    """
    from multiprocessing.connection import wait

    ctx = multiprocessing.get_context(_start_method())
    if ctx.get_start_method() == "forkserver":
        ctx.set_forkserver_preload(["__main__", "flexmb.study"])
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
