"""The compiled loops' user data: the int64 array through which their kernels reach a looped model.

One builder for both step loops of looped models that run in compiled code:
CVODE's (:class:`flexmb.integrators.cvode_direct_loops.DirectLoopCVODE`,
whose C callbacks get it as CVODE's ``user_data``) and generalized-alpha's
(:class:`flexmb.genalpha.compiled.CompiledLoopGeneralizedAlpha`, which
hands it to :func:`flexmb.kernels.genalpha_loops.advance`). The slots are
those of :mod:`flexmb.kernels.cvode_loop_callbacks`: the addresses and sizes
of the packed model, of the loop layout's arrays, of the Newton
preconditioner's buffers, of the winding offsets, of the float parameters
(``A_REAL``), and counters.
"""

from __future__ import annotations

import numpy as np

__all__ = ["loop_user_data", "driver_row", "compiled_loops_serve"]


def compiled_loops_serve(system) -> bool:
    """Whether the compiled loops' kernels can evaluate ``system`` (CVODE's and generalized-alpha's compiled loops).

    Parameters
    ----------
    system : System
        The model.

    Returns
    -------
    bool
        True for loops closed by the articulated strategy (``System._loop_kernel``),
        force elements all compiled, and drivers with a closed form (``Driver.law``).
    """
    if not system._loop_kernel:  # loops closed by a dense strategy, plugin joints, constraint elements
        return False
    if system._python_groups:  # force elements evaluated in Python
        return False
    return all(d.law is not None for d in system.constraints.drivers)  # (else a motion known only to Python)


def driver_row(driver, column) -> tuple:
    """The row ``(column, kind, p1, p2, p3)`` of :func:`flexmb.kernels.cvode_loop_callbacks.driver`.

    Parameters
    ----------
    driver : Driver
        A driver with a closed form (``Driver.law``).
    column : int
        Its speed's column.

    Returns
    -------
    tuple
        The row.
    """
    kind, *p = driver.law
    return (column, 0.0, *p, 0.0) if kind == "constant_speed" else (column, 1.0, *p)


def loop_user_data(system, m: int, offset, nonfinite_flag: int, getptr: int = 0, matdata: int = 0):
    """The user data of the compiled loops for ``system``, and the arrays its addresses point into.

    Parameters
    ----------
    system : System
        A model whose loops the articulated strategy closes, its force
        elements compiled, its drivers with a closed form.
    m : int
        The state's size.
    offset : ndarray or None
        The winding offsets (None: none, the buffer zero).
    nonfinite_flag : int
        What CVODE's right-hand side returns for a non-finite rate.
    getptr, matdata : int
        The addresses of ``N_VGetArrayPointer`` and ``SUNDenseMatrix_Data``
        (CVODE's callbacks; 0 where no N_Vector is handed over).

    Returns
    -------
    ud : ndarray of int64, shape (UD_SIZE,)
        The user data.
    arrays : dict
        The arrays it points into (to be kept alive as long as ``ud``).
    """
    from .kernels import cvode_loop_callbacks as cb
    from .kernels.constraint_matrix import DENSE_K  # K's eigenvectors V (m x m) only where it is factored densely
    from .system.tangent import NewtonPreconditioner

    n = system.n_speeds
    fl, it, fg, ix = system._packed
    lay = system._loop_layout
    K, C = NewtonPreconditioner.diagonal_terms(system)
    nb, mr, band = system.topology.n_bodies, lay.row_coord.shape[0], int(lay.band)
    drivers = system.constraints.drivers
    drv = np.array([driver_row(d, c) for d, c in zip(drivers, system.constraints.driver_cols)] or [(0.0,) * 5],
                   float)
    a = {
        "fl": fl, "it": it, "fg": fg, "ix": ix, "K": np.ascontiguousarray(K, float),
        "C": np.ascontiguousarray(C, float), "x": np.zeros(n), "drv": np.ascontiguousarray(drv.reshape(-1)),
        "real": np.zeros(cb.N_REAL), "Sw": np.zeros(n * 3), "Sv": np.zeros(n * 3), "W": np.zeros(mr * 12),
        "body": np.zeros(mr * 2, np.int64), "U": np.zeros(n * 6), "DUT": np.zeros(n * 6), "Dinv": np.zeros(n * 6),
        "lift": np.zeros(n), "Kb": np.zeros(mr * (band + 1)), "d": np.zeros(mr), "df": np.zeros(mr),
        "V": np.zeros(mr * mr if mr <= DENSE_K or 2 * band >= mr else 0), "fail_t": np.zeros(1),
        "fail_y": np.zeros(m), "offset": np.zeros(m) if offset is None else np.array(offset, dtype=float),
        "work": np.zeros(cb.work_size(nb, n, mr, len(drivers)))}
    for f in lay._fields[:-1]:
        a[f] = np.ascontiguousarray(getattr(lay, f), dtype=np.int64)
    ud = np.zeros(cb.UD_SIZE, dtype=np.int64)
    ud[cb.A_GETPTR], ud[cb.A_MATDATA] = getptr, matdata
    ud[cb.N], ud[cb.M], ud[cb.NB], ud[cb.MROWS], ud[cb.BAND] = n, m, nb, mr, band
    for slot, size, key in ((cb.A_FL, cb.N_FL, "fl"), (cb.A_IT, cb.N_IT, "it"), (cb.A_FG, cb.N_FG, "fg")):
        ud[slot], ud[size] = a[key].ctypes.data, a[key].size
    ud[cb.A_IX], ud[cb.N_IX] = ix.ctypes.data, ix.shape[0]
    ud[cb.N_VISIT], ud[cb.N_ROOTS], ud[cb.N_ROOT_ROWS] = a["visit"].size, a["root_ptr"].size - 1, a["root_rows"].size
    for key in ("row_body", "row_coord", "root_of", "row_roots", "visit_ptr", "visit", "root_ptr", "root_rows",
                "order", "position", "K", "C", "x", "drv", "real", "Sw", "Sv", "W", "body", "U", "DUT", "Dinv",
                "lift", "Kb", "d", "df", "V", "fail_t", "fail_y", "offset", "work"):
        ud[getattr(cb, "A_" + key.upper())] = a[key].ctypes.data
    ud[cb.N_DRV] = len(drivers)
    ud[cb.RANK_LIMIT] = -1 if system.rank_limit is None else system.rank_limit
    a["real"][cb.R_TOL], a["real"][cb.R_WINDOW] = system._loop_tol, system.singular_window()
    ud[cb.HAS_OFFSET] = offset is not None
    ud[cb.STATUS], ud[cb.NONFINITE_FLAG] = -1, nonfinite_flag
    return ud, a
