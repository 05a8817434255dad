"""The pieces of the equations of motion at one state, as :meth:`flexmb.System.equations` returns them."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..kinematics import Kinematics

__all__ = ["Equations"]


class Equations(NamedTuple):
    """The pieces of the equations of motion at one state (:meth:`System.equations`).

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    kin : Kinematics
        Kinematics at the state (eqs. 6-18).
    A : ndarray, shape (n, n)
        Generalized mass matrix (eq. 2).
    f : ndarray, shape (n,)
        Force array (eq. 3).
    phi : ndarray, shape (m,)
        Constraint residual (eq. 28).
    psi : ndarray, shape (m, n)
        Constraint Jacobian (eq. 29).
    b : ndarray, shape (m,)
        Right-hand side of ``psi xd = b``.
    gamma : ndarray, shape (m,)
        Right-hand side of ``psi xdd = gamma``.
    """

    kin: Kinematics
    A: np.ndarray
    f: np.ndarray
    phi: np.ndarray
    psi: np.ndarray
    b: np.ndarray
    gamma: np.ndarray
