"""SUNDIALS 7's CVODE through ctypes, on the libraries that scikit-sundae's wheel bundles.

:func:`libraries` finds the shared libraries in ``scikit_sundae.libs``
(their names mangled by auditwheel, ``libsundials_cvode-<hash>.so.7.9.0``)
through the distribution's file list (``importlib.metadata``), without
importing scikit-sundae (whose import brings scipy.optimize), and reads the
sizes of ``sunindextype`` and ``sunrealtype`` from its ``c_config.pxi``.
:func:`sundials` loads them once per process and declares the functions
:class:`~flexmb.integrators.cvode_direct.DirectCVODE` calls.
"""

from __future__ import annotations

import ctypes
import importlib.metadata
import re
from ctypes import POINTER, c_double, c_int, c_long, c_void_p

__all__ = ["libraries", "sundials", "CVODEError", "FLAGS", "NEEDED"]

#: the libraries needed, in the order they are loaded (each needs the ones before)
NEEDED = ("core", "nvecserial", "sunmatrixdense", "sunlinsoldense", "sunlinsolspgmr", "cvode")

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


class CVODEError(RuntimeError):
    """CVODE failed: its flag, the time, and the callback's cause where one failed."""


def _files(dist: str) -> list[str]:
    d = importlib.metadata.distribution(dist)
    return [str(d.locate_file(f)) for f in d.files or ()]


def libraries(dist: str = "scikit-sundae") -> dict:
    """The bundled SUNDIALS libraries by short name, and the index and real types.

    Parameters
    ----------
    dist : str
        The distribution that bundles them.

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
        with open(config[0], encoding="utf-8") as f:
            text = f.read()
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
        "CVodeSVtolerances": (i, [vp, d, vp]),
        "CVodeSetUserData": (i, [vp, vp]), "CVodeSetLinearSolver": (i, [vp, vp, vp]), "CVodeSetJacFn": (i, [vp, vp]),
        "CVodeSetPreconditioner": (i, [vp, vp, vp]), "CVodeSetMaxNonlinIters": (i, [vp, i]),
        "CVodeSetMaxConvFails": (i, [vp, i]), "CVodeSetInitStep": (i, [vp, d]), "CVodeSetMinStep": (i, [vp, d]),
        "CVodeSetMaxStep": (i, [vp, d]), "CVodeSetMaxOrd": (i, [vp, i]), "CVodeSetMaxNumSteps": (i, [vp, L]),
        "CVodeSetStopTime": (i, [vp, d]), "CVode": (i, [vp, d, vp, POINTER(d), i]),
        "CVodeGetDky": (i, [vp, d, i, vp]), "CVodeFree": (None, [POINTER(vp)]),
        "CVodeGetLastStep": (i, [vp, POINTER(d)]), "CVodeGetLastOrder": (i, [vp, POINTER(i)]),
        "CVodeGetEstLocalErrors": (i, [vp, vp]), "CVodeGetErrWeights": (i, [vp, vp]),
        "CVodeSetStabLimDet": (i, [vp, i]), "CVodeSetProjFn": (i, [vp, vp]), "CVodeSetProjErrEst": (i, [vp, i]),
        "CVodeSetJacTimes": (i, [vp, vp, vp]),
    }
    for stat in ("NumSteps", "NumRhsEvals", "NumLinRhsEvals", "NumJacEvals", "NumPrecEvals", "NumPrecSolves",
                 "NumLinIters", "NumNonlinSolvIters", "NumErrTestFails", "NumNonlinSolvConvFails", "NumLinSolvSetups",
                 "NumProjEvals", "NumProjFails", "NumStabLimOrderReds"):
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
    """The loaded libraries: one handle whose attributes are the declared functions."""

    def __init__(self):
        info = libraries()
        self._libs = [ctypes.CDLL(info["paths"][name], mode=ctypes.RTLD_GLOBAL) for name in NEEDED]
        self.index, self.version, self.paths = info["index"], info["version"], info["paths"]
        self.__dict__.update(_declare(self._libs, self.index))


_loaded: list = []


def sundials() -> _Sundials:
    """The bundled SUNDIALS libraries, loaded and declared once per process.

    Returns
    -------
    object
        Its attributes are the declared functions (``CVodeCreate``, ...),
        ``index`` (ctypes' ``sunindextype``), ``version`` and ``paths``.
    """
    if not _loaded:
        _loaded.append(_Sundials())
    return _loaded[0]
