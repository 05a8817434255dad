"""The kernels run as Python: numba's ``NUMBA_DISABLE_JIT=1``.

numba's documented debugging switch makes its ``njit`` return the Python
function itself: the kernels then run in the interpreter (slowly, but
under a Python debugger, with Python's errors). Two things numba does not
carry over are handled here:

* **Intrinsics.** A kernel that calls a function written as machine code
  (``numba.extending.intrinsic``) cannot run as Python. The views of
  :mod:`flexmb.kernels.views` have a Python meaning (a slice reshaped):
  :func:`kernel` binds it in the module of every kernel declared while the
  JIT is disabled (nothing compiles then, so the intrinsics are not
  needed there).
* **C callbacks.** CVODE's compiled callbacks and step loops
  (:mod:`flexmb.kernels.cvode_callbacks`,
  :mod:`flexmb.kernels.cvode_loop_callbacks`) and the compiled
  generalized-alpha loop (:mod:`flexmb.kernels.genalpha_loop`) are machine
  code called by address: they cannot exist without the JIT. The runs
  that would use them step in Python instead (scikit-sundae's CVODE, the
  Python generalized-alpha step), and a class that needs them says so at
  set-up (:func:`require_jit`).
"""

from __future__ import annotations

import numba

from ..errors import FlexmbError
from .views import view2, view3

__all__ = ["disabled", "kernel", "require_jit"]


def disabled() -> bool:
    """Whether numba's JIT is disabled in this process (``NUMBA_DISABLE_JIT=1``).

    Returns
    -------
    bool
        numba's ``config.DISABLE_JIT``.
    """
    return bool(numba.config.DISABLE_JIT)


def _view2(buffer, offset, rows, cols):
    return buffer[offset:offset + rows * cols].reshape((rows, cols))


def _view3(buffer, offset, a, b, c):
    return buffer[offset:offset + a * b * c].reshape((a, b, c))


#: the intrinsics that have a Python meaning, and that meaning
_PYTHON = ((view2, _view2), (view3, _view3))


def kernel(func):
    """``func`` ready to run as Python: the intrinsics of its module bound to their Python meaning.

    Parameters
    ----------
    func : function
        A kernel's Python function (what numba's ``njit`` returns with the
        JIT disabled).

    Returns
    -------
    function
        ``func`` itself.
    """
    module = func.__globals__
    for name, value in list(module.items()):
        for compiled, python in _PYTHON:
            if value is compiled:
                module[name] = python
    return func


def require_jit(what: str) -> None:
    """Raise if numba's JIT is disabled: ``what`` is machine code called by address.

    Parameters
    ----------
    what : str
        What needs the JIT (e.g. ``"DirectCVODEBDF's compiled callbacks"``).

    Raises
    ------
    FlexmbError
        With ``NUMBA_DISABLE_JIT=1``.
    """
    if disabled():
        raise FlexmbError(f"{what} are machine code and cannot run with NUMBA_DISABLE_JIT=1 (numba's JIT "
                           f"disabled): unset NUMBA_DISABLE_JIT, or use an integrator that steps in Python "
                           f"(the default choice does so by itself when the JIT is disabled)")
