"""The BLAS threads flexmb's evaluations use.

The matrices of one evaluation (mass matrices, complements, the n x n
Newton matrices of the implicit integrators) are small or medium: for
them a multi-threaded BLAS spends more on waking and synchronising its
threads than on arithmetic, and on a loaded machine (a parameter study
running one case per core) the threads wait for cores and a run can take
tens of times longer (docs/benchmarks.md, "BLAS threads"). flexmb
therefore runs its solvers with :data:`BLAS_THREADS` BLAS threads,
whatever ``OPENBLAS_NUM_THREADS`` or ``OMP_NUM_THREADS`` say, and restores
the caller's setting afterwards.

Set the environment variable ``FLEXMB_BLAS_THREADS`` (an integer >= 1) to
change it, e.g. for a model whose reduced mass matrix has thousands of
rows.
"""

from __future__ import annotations

import contextlib
import functools
import os
import sys
import threading

from .errors import ModelError

__all__ = ["BLAS_THREADS", "blas_threads", "limited_blas"]


def _threads_from_env() -> int:
    value = os.environ.get("FLEXMB_BLAS_THREADS", "1")
    try:
        n = int(value)
    except ValueError:
        n = 0
    if n < 1:
        raise ModelError(f"FLEXMB_BLAS_THREADS must be an integer >= 1, got {value!r}")
    return n


#: BLAS threads used inside :func:`~flexmb.simulate` and the static and
#: linear analyses (environment variable ``FLEXMB_BLAS_THREADS``, default 1).
BLAS_THREADS = _threads_from_env()

_controller = None
_lock = threading.Lock()
_active = 0  # blocks inside blas_threads, over all Python threads
_limiter = None


_modules_seen = -1  # len(sys.modules) when the controller was made


def _get_controller(refresh: bool = False):
    """The threadpoolctl controller; with ``refresh``, made anew if modules were imported since.

    Finding the loaded libraries reads the process's memory map (about a
    millisecond): a new BLAS comes with an imported extension module, so
    the controller is made again only when ``sys.modules`` has grown.
    """
    global _controller, _modules_seen
    if _controller is None or (refresh and len(sys.modules) != _modules_seen):
        from threadpoolctl import ThreadpoolController

        _controller = ThreadpoolController()
        _modules_seen = len(sys.modules)
    return _controller


class _BlasLimits:
    """``controller.limit(limits=n, user_api="blas")`` of threadpoolctl, without the full ``info()`` it reads.

    Each BLAS library's thread count is read, set to ``n``, and put back by
    :meth:`restore_original_limits` (the libraries of other kinds are left
    alone, as threadpoolctl leaves them).
    """

    def __init__(self, controller, n: int):
        self._original = [(lib, lib.num_threads) for lib in controller.lib_controllers if lib.user_api == "blas"]
        for lib, _ in self._original:
            lib.set_num_threads(n)

    def restore_original_limits(self) -> None:
        """Put each BLAS library's thread count back."""
        for lib, n in self._original:
            lib.set_num_threads(n)


@contextlib.contextmanager
def blas_threads(n: int | None = None):
    """Run a block with at most ``n`` BLAS threads, then restore the previous limits.

    The limit is process-wide (BLAS libraries have one thread pool): the
    first block to enter sets it, nested blocks and blocks entered from
    other Python threads meanwhile keep it, and the last to leave restores
    the caller's limits. Only the first block pays the call into each BLAS
    library. OpenBLAS applies a limit set from the main thread to all
    threads; one set from another Python thread may have no effect (process
    pool workers, as in :func:`~flexmb.run_study`, call from their main
    thread).

    Parameters
    ----------
    n : int, optional
        Thread limit (default: :data:`BLAS_THREADS`).

    Yields
    ------
    None
        The block runs with the limit in force.
    """
    global _active, _limiter
    with _lock:
        if _active == 0:
            # a controller of the libraries loaded now (an import since the last run may have
            # brought another BLAS, e.g. SUNDIALS')
            _limiter = _BlasLimits(_get_controller(refresh=True), BLAS_THREADS if n is None else n)
        _active += 1
    try:
        yield
    finally:
        with _lock:
            _active -= 1
            if _active == 0:
                _limiter.restore_original_limits()
                _limiter = None


def limited_blas(func):
    """Decorate a solver so that it runs with :data:`BLAS_THREADS` BLAS threads.

    Parameters
    ----------
    func : callable
        The function to wrap.

    Returns
    -------
    callable
        ``func`` run inside :func:`blas_threads`.
    """

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        with blas_threads():
            return func(*args, **kwargs)

    return wrapper
