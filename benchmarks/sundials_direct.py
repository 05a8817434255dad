"""SUNDIALS 7's CVODE called directly through ctypes, on the libraries scikit-sundae's wheel bundles (issue 31 prototype).

:func:`libraries` finds the shared libraries in ``scikit_sundae.libs``
(their names mangled by auditwheel, ``libsundials_cvode-<hash>.so.7.9.0``)
through the distribution's file list (``importlib.metadata``), without
importing scikit-sundae (whose import brings scipy.optimize), and reads the
sizes of ``sunindextype`` and ``sunrealtype`` from its ``c_config.pxi``.
:class:`DirectCVODE` drives CVODE (BDF) on an open tree with the numba C
callbacks of :mod:`cvode_callbacks`: a dense Jacobian (dense LU) or the O(n)
Newton preconditioner (GMRES), CVODE's options as flexmb's
``CVODE_BDF`` sets them through scikit-sundae, and one Python call per
output time (:meth:`DirectCVODE.advance`). CVODE's failures become a
:class:`CVODEError` naming the flag, the time and, where a callback failed,
why; everything SUNDIALS allocated is freed by :meth:`DirectCVODE.close`
(or when the object is collected).

This is a benchmark's prototype, not part of flexmb.
"""

from __future__ import annotations

import ctypes
import importlib.metadata
import re
from ctypes import POINTER, byref, c_double, c_int, c_long, c_void_p

import numpy as np

#: the libraries needed, in the order they are loaded (each needs the ones before)
NEEDED = ("core", "nvecserial", "sunmatrixdense", "sunlinsoldense", "sunlinsolspgmr", "cvode")

CV_BDF, CV_NORMAL, CV_ONE_STEP, SUN_PREC_LEFT = 2, 1, 2, 1
KRYLOV_DIM, MAX_STEPS = 10, 10**9
#: steps of one compiled call before it returns to Python (which then handles signals: Ctrl-C, SIGTERM)
STEPS_PER_CALL = 1000

#: CVODE's return flags (cvode.h, cvode_ls.h) and what they mean
FLAGS = {
    -1: "CV_TOO_MUCH_WORK", -2: "CV_TOO_MUCH_ACC", -3: "CV_ERR_FAILURE (error test failed repeatedly or at the "
    "smallest step)", -4: "CV_CONV_FAILURE (the Newton iteration failed repeatedly or at the smallest step)",
    -5: "CV_LINIT_FAIL", -6: "CV_LSETUP_FAIL (the Jacobian or preconditioner set-up failed)",
    -7: "CV_LSOLVE_FAIL (the linear or preconditioner solve failed)", -8: "CV_RHSFUNC_FAIL (the right-hand side "
    "failed unrecoverably)", -9: "CV_FIRST_RHSFUNC_ERR (the right-hand side failed at the first call)",
    -10: "CV_REPTD_RHSFUNC_ERR (the right-hand side failed recoverably, repeatedly)",
    -11: "CV_UNREC_RHSFUNC_ERR", -20: "CV_MEM_FAIL", -21: "CV_MEM_NULL", -22: "CV_ILL_INPUT", -23: "CV_NO_MALLOC",
    -25: "CV_BAD_T", -27: "CV_TOO_CLOSE",
}
#: why a callback failed (user_data's STATUS), when it is not a joint index
CAUSES = {-2: "the state derivative or the Jacobian became non-finite", -3: "the mass matrix is not positive definite"}


class CVODEError(RuntimeError):
    """CVODE failed: its flag, the time, and the callback's cause where one failed."""


def _files(dist: str = "scikit-sundae") -> list[str]:
    d = importlib.metadata.distribution(dist)
    return [str(d.locate_file(f)) for f in d.files or ()]


def libraries(dist: str = "scikit-sundae") -> dict:
    """The bundled SUNDIALS libraries by short name, and the index and real types.

    Returns
    -------
    dict
        ``{"paths": {"cvode": path, ...}, "index": ctypes type, "real": ctypes type, "version": str}``.

    Raises
    ------
    FileNotFoundError
        If a needed library is missing from the distribution.
    """
    files = _files(dist)
    paths = {}
    for name in NEEDED:
        hits = [f for f in files if re.search(rf"/libsundials_{name}(-[0-9a-f]+)?\.so[.0-9]*$", f)]
        if not hits:
            raise FileNotFoundError(f"libsundials_{name} is not in {dist}'s files")
        paths[name] = hits[0]
    config = [f for f in files if f.endswith("c_config.pxi")]
    index, real = c_int, c_double  # scikit-sundae 1.x's build
    if config:
        text = open(config[0]).read()
        if re.search(r"ctypedef\s+long\s+sunindextype|ctypedef\s+int64_t\s+sunindextype", text):
            index = ctypes.c_int64
        if not re.search(r"ctypedef\s+double\s+sunrealtype", text):
            raise RuntimeError(f"{config[0]}: sunrealtype is not double")
    version = re.search(r"\.so\.([0-9.]+)$", paths["cvode"])
    return {"paths": paths, "index": index, "real": real, "version": version.group(1) if version else "?"}


def _declare(libs, index) -> dict:
    """The functions used, found in ``libs`` and declared (SUNDIALS 7: SUNComm is int without MPI)."""
    vp, d, i, L = c_void_p, c_double, c_int, c_long
    protos = {
        "SUNContext_Create": (i, [i, POINTER(vp)]), "SUNContext_Free": (i, [POINTER(vp)]),
        "SUNContext_ClearErrHandlers": (i, [vp]), "N_VNew_Serial": (vp, [index, vp]), "N_VDestroy": (None, [vp]),
        "N_VGetArrayPointer": (vp, [vp]), "SUNDenseMatrix": (vp, [index, index, vp]),
        "SUNDenseMatrix_Data": (vp, [vp]), "SUNMatDestroy": (None, [vp]), "SUNLinSolFree": (i, [vp]),
        "SUNLinSol_Dense": (vp, [vp, vp, vp]), "SUNLinSol_SPGMR": (vp, [vp, i, i, vp]),
        "CVodeCreate": (vp, [i, vp]), "CVodeInit": (i, [vp, vp, d, vp]), "CVodeSStolerances": (i, [vp, d, d]),
        "CVodeSetUserData": (i, [vp, vp]), "CVodeSetLinearSolver": (i, [vp, vp, vp]), "CVodeSetJacFn": (i, [vp, vp]),
        "CVodeSetPreconditioner": (i, [vp, vp, vp]), "CVodeSetMaxNonlinIters": (i, [vp, i]),
        "CVodeSetMaxConvFails": (i, [vp, i]), "CVodeSetInitStep": (i, [vp, d]), "CVodeSetMinStep": (i, [vp, d]),
        "CVodeSetMaxStep": (i, [vp, d]), "CVodeSetMaxOrd": (i, [vp, i]), "CVodeSetMaxNumSteps": (i, [vp, L]),
        "CVodeSetStopTime": (i, [vp, d]), "CVode": (i, [vp, d, vp, POINTER(d), i]),
        "CVodeGetDky": (i, [vp, d, i, vp]), "CVodeFree": (None, [POINTER(vp)]),
    }
    for stat in ("NumSteps", "NumRhsEvals", "NumLinRhsEvals", "NumJacEvals", "NumPrecEvals", "NumPrecSolves",
                 "NumLinIters", "NumNonlinSolvIters", "NumErrTestFails", "NumNonlinSolvConvFails", "NumLinSolvSetups"):
        protos[f"CVodeGet{stat}"] = (i, [vp, POINTER(L)])
    out = {}
    for name, (res, args) in protos.items():
        for lib in libs:
            if hasattr(lib, name):
                f = getattr(lib, name)
                f.restype, f.argtypes = res, args
                out[name] = f
                break
        else:
            raise AttributeError(f"no bundled SUNDIALS library defines {name}")
    return out


class _Sundials:
    """The loaded libraries: one handle whose attributes are the declared functions (loaded once per process)."""

    _loaded = None

    def __init__(self):
        info = libraries()
        libs = [ctypes.CDLL(info["paths"][name], mode=ctypes.RTLD_GLOBAL) for name in NEEDED]
        self.index, self.version = info["index"], info["version"]
        self.paths = info["paths"]
        self._libs = libs
        self.__dict__.update(_declare(libs, self.index))

    @classmethod
    def get(cls) -> "_Sundials":
        if cls._loaded is None:
            cls._loaded = cls()
        return cls._loaded


def _diagonal_terms_only(system) -> bool:
    """Whether ``System.state_jacobian`` of ``system`` is what the compiled Jacobian forms.

    That is: its coordinate terms are the diagonal K and C, and no
    constant point force or body torque adds turning terms.
    """
    from flexmb.forces import BodyTorque, PointForce

    kin = system.kinematics(0.0, system.layout.reference(), np.zeros(system.n_speeds))
    for cls, elements in system.forces.groups:
        if any(type(e) in (PointForce, BodyTorque) for e in elements):
            return False
        if cls.pair_tangent_all(elements, kin) is not None or cls.velocity_tangent_all(elements, kin) is not None:
            return False
    return True


def _addr(f) -> int:
    return ctypes.cast(f, c_void_p).value


class DirectCVODE:
    """CVODE (BDF) on an open tree with compiled callbacks: one Python call per output time.

    Parameters
    ----------
    system : flexmb.System
        An open tree whose joints and force elements are all compiled
        (``system._packed_open`` set), without angle coordinates (the
        winding offsets are not in this prototype).
    y0 : ndarray, shape (2 n,)
        The initial state ``(q, u)``.
    t0, t_bound : float
        Start and end (CVODE's stop time).
    rtol, atol : float
        Tolerances.
    krylov : bool
        GMRES with the O(n) Newton preconditioner (flexmb's choice from 48
        coordinates on) instead of the dense Jacobian and LU.
    max_step : float
        Largest step.
    first_step : float, optional
        First step (default: CVODE's estimate).
    monitor : ResolutionMonitor, optional
        flexmb's monitor, given the steps at its checkpoints.
    nonfinite_flag : int
        What the right-hand side returns when its result is not finite: 1
        (recoverable: CVODE retries with a smaller step) or -1.
    jacobian : callable, optional
        ``jacobian(t, y) -> (m, m)`` called from Python (a ctypes callback)
        instead of the compiled Jacobian: flexmb's own ``state_jacobian``,
        to check that this loop takes the very steps of flexmb's.
    rhs : callable, optional
        ``rhs(t, y) -> ydot`` called from Python (a ctypes callback) instead
        of the compiled right-hand side: what a model with Python force
        elements or plugin joints would need. An exception it raises stops
        CVODE (an unrecoverable flag) and is raised again by :meth:`advance`.
    """

    def __init__(self, system, y0, t0, t_bound, *, rtol, atol, krylov=False, max_step=np.inf, first_step=None,
                 monitor=None, nonfinite_flag=1, jacobian=None, rhs=None):
        import cvode_callbacks as cb

        if system._packed_open is None:
            raise ValueError("DirectCVODE needs an open tree whose joints and force elements are all compiled")
        if system.topology.coord_angle.any():
            raise ValueError("DirectCVODE does not move winding offsets: this model has angle coordinates")
        self._cb, self.system, self.monitor = cb, system, monitor
        self._S = S = _Sundials.get()
        self.t, self.t_bound, self.n_steps = float(t0), float(t_bound), 0
        self.steps_per_call = STEPS_PER_CALL
        self._mem = self._ls = self._A = self._y = self._out = None
        self._ctx = c_void_p()
        self._py_jac = None if jacobian is None else self._python_jacobian(jacobian)
        self._py_rhs = None if rhs is None else self._python_rhs(rhs)
        self._raised = None  # an exception of a Python callback, raised again after CVODE returns
        n, m, nb = system.n_speeds, len(y0), system.topology.n_bodies
        self.n, self.m = n, m
        if not (krylov or jacobian is not None or _diagonal_terms_only(system)):
            raise ValueError("the compiled Jacobian holds diagonal coordinate springs and dampers and the compiled "
                             "loads only; this model has point forces, body torques or pair or velocity tangents: "
                             "pass krylov=True or jacobian=")
        self._ud = self._user_data(system, n, m, nb, nonfinite_flag)
        self._check(S.SUNContext_Create(0, byref(self._ctx)), "SUNContext_Create")
        S.SUNContext_ClearErrHandlers(self._ctx)  # failures become CVODEError, not lines on stderr
        self._y, self._out = S.N_VNew_Serial(m, self._ctx), S.N_VNew_Serial(m, self._ctx)
        if not (self._y and self._out):
            raise MemoryError("N_VNew_Serial returned NULL")
        self.y = self._data(self._y)
        self.y[:] = y0
        self._mem = S.CVodeCreate(CV_BDF, self._ctx)
        if not self._mem:
            raise MemoryError("CVodeCreate returned NULL")
        self._setup(rtol, atol, krylov, max_step, first_step)
        self._tret = np.array([self.t])
        self._lp = np.array([_addr(S.CVode), _addr(S.CVodeGetDky), self._mem, self._y, self.y.ctypes.data, self._out,
                             self._tret.ctypes.data, m, _addr(S.N_VGetArrayPointer)], dtype=np.int64)

    def _user_data(self, system, n, m, nb, nonfinite_flag):
        from flexmb.system.tangent import NewtonPreconditioner

        cb = self._cb
        fl, it, fg, ix = system._packed_open
        K, C = NewtonPreconditioner.diagonal_terms(system)
        self._arrays = arrays = dict(fl=fl, it=it, fg=fg, ix=ix, K=np.ascontiguousarray(K, float),
                                     C=np.ascontiguousarray(C, float), spatial=np.zeros(nb * 36),
                                     Sw=np.zeros(n * 3), Sv=np.zeros(n * 3), r=np.zeros((nb + 1) * 3),
                                     fail_t=np.zeros(1))
        ud = np.zeros(cb.UD_SIZE, dtype=np.int64)
        S = self._S
        ud[cb.A_GETPTR], ud[cb.A_MATDATA], ud[cb.N], ud[cb.M], ud[cb.NB] = (
            _addr(S.N_VGetArrayPointer), _addr(S.SUNDenseMatrix_Data), n, m, nb)
        for slot, size, key in ((cb.A_FL, cb.N_FL, "fl"), (cb.A_IT, cb.N_IT, "it"), (cb.A_FG, cb.N_FG, "fg")):
            ud[slot], ud[size] = arrays[key].ctypes.data, arrays[key].size
        ud[cb.A_IX], ud[cb.N_IX] = ix.ctypes.data, ix.shape[0]
        for slot, key in ((cb.A_K, "K"), (cb.A_C, "C"), (cb.A_SPATIAL, "spatial"), (cb.A_SW, "Sw"), (cb.A_SV, "Sv"),
                          (cb.A_R, "r"), (cb.A_FAIL_T, "fail_t")):
            ud[slot] = arrays[key].ctypes.data
        ud[cb.STATUS], ud[cb.NONFINITE_FLAG] = -1, nonfinite_flag
        return ud

    def _setup(self, rtol, atol, krylov, max_step, first_step):
        """CVODE's options in scikit-sundae's order, as flexmb's CVODE_BDF gives them."""
        S, cb, mem, ck = self._S, self._cb, self._mem, self._check
        ck(S.CVodeSetUserData(mem, self._ud.ctypes.data), "CVodeSetUserData")
        f = cb.rhs.address if self._py_rhs is None else _addr(self._py_rhs)
        ck(S.CVodeInit(mem, f, self.t, self._y), "CVodeInit")
        ck(S.CVodeSStolerances(mem, float(rtol), float(atol)), "CVodeSStolerances")
        if krylov:
            self._ls = S.SUNLinSol_SPGMR(self._y, SUN_PREC_LEFT, KRYLOV_DIM, self._ctx)
        else:
            self._A = S.SUNDenseMatrix(self.m, self.m, self._ctx)
            self._ls = S.SUNLinSol_Dense(self._y, self._A, self._ctx)
        if not self._ls or not (krylov or self._A):
            raise MemoryError("the SUNDIALS matrix or linear solver constructor returned NULL")
        ck(S.CVodeSetLinearSolver(mem, self._ls, self._A), "CVodeSetLinearSolver")
        if krylov:
            ck(S.CVodeSetPreconditioner(mem, cb.psetup.address, cb.psolve.address), "CVodeSetPreconditioner")
        else:
            jac = cb.jac.address if self._py_jac is None else _addr(self._py_jac)
            ck(S.CVodeSetJacFn(mem, jac), "CVodeSetJacFn")
        ck(S.CVodeSetMaxNonlinIters(mem, 3), "CVodeSetMaxNonlinIters")
        ck(S.CVodeSetMaxConvFails(mem, 10), "CVodeSetMaxConvFails")
        ck(S.CVodeSetInitStep(mem, 0.0 if first_step is None else float(first_step)), "CVodeSetInitStep")
        ck(S.CVodeSetMinStep(mem, 0.0), "CVodeSetMinStep")
        ck(S.CVodeSetMaxStep(mem, 0.0 if not np.isfinite(max_step) else float(max_step)), "CVodeSetMaxStep")
        ck(S.CVodeSetMaxOrd(mem, 5), "CVodeSetMaxOrd")
        ck(S.CVodeSetMaxNumSteps(mem, MAX_STEPS), "CVodeSetMaxNumSteps")
        ck(S.CVodeSetStopTime(mem, self.t_bound), "CVodeSetStopTime")

    def _python_rhs(self, rhs):
        """A ctypes callback (CVRhsFn) filling ``ydot`` with ``rhs(t, y)``; -1 (and the exception kept) if it raises."""
        proto = ctypes.CFUNCTYPE(c_int, c_double, c_void_p, c_void_p, c_void_p)

        def f(t, y, ydot, user_data):
            try:
                self._ud[self._cb.RHS] += 1
                self._data(ydot)[:] = rhs(t, self._data(y))
                return 0
            except BaseException as exc:  # noqa: BLE001 - nothing may cross into C; advance raises it again
                self._raised = exc
                return -1

        return proto(f)

    def _python_jacobian(self, jacobian):
        """A ctypes callback (CVLsJacFn) filling the dense matrix with ``jacobian(t, y)``; -1 if it raises."""
        proto = ctypes.CFUNCTYPE(c_int, c_double, c_void_p, c_void_p, c_void_p, c_void_p, c_void_p, c_void_p,
                                 c_void_p)

        def jac(t, y, fy, J, user_data, tmp1, tmp2, tmp3):
            try:
                self._ud[self._cb.JACS] += 1
                m = self.m
                data = np.ctypeslib.as_array((c_double * (m * m)).from_address(self._S.SUNDenseMatrix_Data(J)))
                data.reshape((m, m), order="F")[:] = jacobian(t, self._data(y))
                return 0
            except Exception:  # noqa: BLE001 - nothing may cross into C; CVODE reports CV_LSETUP_FAIL
                return -1

        return proto(jac)

    def _data(self, v) -> np.ndarray:
        return np.ctypeslib.as_array((c_double * self.m).from_address(self._S.N_VGetArrayPointer(v)))

    @staticmethod
    def _check(flag, what):
        if flag < 0:
            raise CVODEError(f"{what} failed: {FLAGS.get(flag, flag)}")

    def advance(self, t_stop: float) -> np.ndarray:
        """Step until ``t_stop`` (one compiled loop; back in Python only at the monitor's checkpoints).

        Returns
        -------
        ndarray, shape (m,)
            The state at ``t_stop`` (CVODE's interpolant if the last step passed it).

        Raises
        ------
        CVODEError
            If CVODE fails (its flag, the time, the callback's cause).
        """
        if self._mem is None:
            raise CVODEError("this DirectCVODE is closed")
        t_stop = min(float(t_stop), self.t_bound)
        mon = self.monitor
        while True:
            live = mon is not None and not mon.warned
            times = np.empty(max(mon.next_check - mon.n_steps, 1) if live else 0)
            t_entry = self._tret[0]
            code, k = self._cb.advance(self._lp, t_stop, self.t_bound, times, self.steps_per_call)
            self.n_steps += k
            self.t = float(self._tret[0])
            if live and k:
                self._feed(mon, np.concatenate(([t_entry], times[: min(k, len(times))])))
            if code < 0:
                if self._raised is not None:
                    raise self._raised
                raise self._error(code)
            if code == self._cb.REACHED:
                return self._data(self._out).copy()

    def _feed(self, mon, times):
        """Give the monitor the steps between ``times`` as its ``step`` takes them one by one."""
        h = np.diff(times)
        mon.steps.extend(h[:-1].tolist())
        mon.n_steps += len(h) - 1
        last = _Step(times[-1], times[-2], self.y.copy())
        mon.step(last)

    def _error(self, code) -> CVODEError:
        cb, ud = self._cb, self._ud
        what = f"CVODE failed at t = {self.t:.9g} s: {FLAGS.get(code, code)}"
        status = int(ud[cb.STATUS])
        if status != -1:
            t_fail = self._arrays["fail_t"][0]
            if status >= 0:
                cause = (f"joint {self.system.topology.tree_joints[status].name!r} moves no mass or inertia along "
                         "one of its freedoms")
            else:
                cause = CAUSES.get(status, f"status {status}")
            what += f"; at t = {t_fail:.9g} s {cause}"
        return CVODEError(what)

    def stats(self) -> dict:
        """CVODE's counters, and the callbacks' own."""
        S, cb, out = self._S, self._cb, {}
        for key, name in (("steps", "NumSteps"), ("rhs_cvode", "NumRhsEvals"), ("rhs_ls", "NumLinRhsEvals"),
                          ("err_test_fails", "NumErrTestFails"), ("newton_iters", "NumNonlinSolvIters"),
                          ("newton_fails", "NumNonlinSolvConvFails"), ("lin_iters", "NumLinIters"),
                          ("lin_setups", "NumLinSolvSetups")):
            v = c_long()
            self._check(getattr(S, f"CVodeGet{name}")(self._mem, byref(v)), f"CVodeGet{name}")
            out[key] = v.value
        out["rhs"] = int(self._ud[cb.RHS])
        out["jac"] = int(self._ud[cb.SETUPS] if self._A is None else self._ud[cb.JACS])
        return out

    def close(self) -> None:
        """Free CVODE, the linear solver, the matrix, the vectors and the context (once)."""
        S = getattr(self, "_S", None)
        if S is None:
            return
        if self._mem:
            S.CVodeFree(byref(c_void_p(self._mem)))
        if self._ls:
            S.SUNLinSolFree(self._ls)
        if self._A:
            S.SUNMatDestroy(self._A)
        for v in (self._y, self._out):
            if v:
                S.N_VDestroy(v)
        if self._ctx:
            S.SUNContext_Free(byref(self._ctx))
        self._mem = self._ls = self._A = self._y = self._out = None
        self.y = None
        self._S = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        self.close()


class _Step:
    """What the monitor reads of a solver after a step."""

    def __init__(self, t, t_old, y):
        self.t, self.t_old, self.y = float(t), float(t_old), y
