"""The benchmark Whipple bicycle of Meijaard, Papadopoulos, Ruina and Schwab (2007).

J. P. Meijaard, J. M. Papadopoulos, A. Ruina and A. L. Schwab, "Linearized
dynamics equations for the balance and steer of a bicycle: a benchmark and
review", Proc. R. Soc. A 463 (2007) 1955-1982, Table 1 (the parameters) and
Table 2 (the eigenvalues of the upright, straight-running linearisation).

Four rigid bodies: the rear frame B (with the rider), the front frame H
(fork and handlebar) on a steer axis tilted back by lambda, and two wheels,
knife-edge thin, rolling without slipping on the level ground
(:class:`flexmb.RollingDisc`, two no-slip velocity rows each). The model is
built in flexmb's axes, x forward, y to the left, z up (the paper's are x
forward, y right, z down: a half turn about x, under which the paper's
``I_xz`` changes sign); its origin is the rear wheel's contact point in the
upright reference configuration.
"""

from __future__ import annotations

import numpy as np
import scipy.optimize as so

from ..analysis.steady import linearize_steady
from ..bodies import RigidBody
from ..constraint_elements import RollingDisc
from ..errors import ModelError
from ..forces import Gravity
from ..joints import Joint, Revolute
from ..model import Model

__all__ = ["BENCHMARK", "SPEEDS", "IGNORABLE", "YawLeanPitch", "benchmark_bicycle", "upright_state", "linearize_upright",
           "upright_eigenvalues", "weave_and_capsize_speeds"]

#: Meijaard et al. (2007), Table 1, in the paper's axes (x forward, y right, z down; positions of the
#: mass centres in the upright reference configuration from the rear contact point; inertia tensors
#: about the mass centres, kg m^2)
BENCHMARK = {
    "w": 1.02,  # wheelbase, m
    "c": 0.08,  # trail, m
    "lam": np.pi / 10,  # steer axis tilt, rad
    "g": 9.81,  # gravity, m/s^2
    "rR": 0.3, "mR": 2.0, "IRxx": 0.0603, "IRyy": 0.12,  # rear wheel R
    "xB": 0.3, "zB": -0.9, "mB": 85.0,  # rear body and frame B
    "IB": ((9.2, 0.0, 2.4), (0.0, 11.0, 0.0), (2.4, 0.0, 2.8)),
    "xH": 0.9, "zH": -0.7, "mH": 4.0,  # front handlebar and fork assembly H
    "IH": ((0.05892, 0.0, -0.00756), (0.0, 0.06, 0.0), (-0.00756, 0.0, 0.00708)),
    "rF": 0.35, "mF": 3.0, "IFxx": 0.1405, "IFyy": 0.28,  # front wheel F
}

#: the independent speeds and the ignorable coordinates of straight running (the paper's choice:
#: lean, steer and the rear wheel's rate; position, heading and wheel angles ignorable)
SPEEDS = ["frame.lean", "steer.angle", "rear_wheel.angle"]
IGNORABLE = ["frame.x", "frame.y", "frame.yaw", "rear_wheel.angle", "front_wheel.angle"]

_FLIP = np.diag([1.0, -1.0, -1.0])  # the paper's axes to flexmb's: a half turn about x


class YawLeanPitch(Joint):
    """The rear frame on the ground: translations x, y, z, then yaw (about z), lean (about the new x) and
    pitch (about the new y), as the bicycle literature orders them (coordinates x, y, z in m, yaw, lean,
    pitch in rad).

    Parameters
    ----------
    name, parent, child, parent_point, child_point, parent_frame, child_frame, cut
        As for :class:`flexmb.Joint`.
    """

    translation_axes = (0, 1, 2)
    rotation_axes = (2, 0, 1)
    coordinate_names = ("x", "y", "z", "yaw", "lean", "pitch")
    cut_point = False


def benchmark_bicycle(parameters=None) -> Model:
    """The benchmark bicycle as a flexmb model.

    Coordinates: ``frame.x``, ``frame.y``, ``frame.z`` (the rear axle),
    ``frame.yaw``, ``frame.lean``, ``frame.pitch`` (the rear frame),
    ``rear_wheel.angle``, ``steer.angle``, ``front_wheel.angle``; six
    constraint rows (each wheel's contact, a position row, and its two
    no-slip velocity rows) leave three independent speeds.

    Parameters
    ----------
    parameters : dict, optional
        Entries of :data:`BENCHMARK` to change (same keys, the paper's axes).

    Returns
    -------
    Model
        The bicycle, upright with zero steer at ``frame.z = rR`` and all
        other coordinates 0.

    Examples
    --------
    >>> from flexmb.scenes.bicycle import benchmark_bicycle
    >>> benchmark_bicycle().build().dof()
    3
    """
    p = dict(BENCHMARK)
    unknown = set(parameters or {}) - set(p)
    if unknown:
        raise ModelError(f"benchmark_bicycle: unknown parameters {sorted(unknown)}; known: {sorted(p)}")
    p.update(parameters or {})
    w, c, lam, rR, rF = p["w"], p["c"], p["lam"], p["rR"], p["rF"]
    rear_axle = np.array([0.0, 0.0, rR])  # the rear frame's origin, world coordinates at the reference
    steer_foot = np.array([w + c, 0.0, 0.0])  # where the steer axis meets the ground: the front frame's origin

    def up(x, z):  # a point of the paper (x forward, z down) in flexmb's axes
        return np.array([x, 0.0, -z])

    def tensor(m):
        return _FLIP @ np.asarray(m, dtype=float) @ _FLIP.T

    model = Model("bicycle")
    frame = RigidBody("rear_frame", p["mB"], tensor(p["IB"]), com=up(p["xB"], p["zB"]) - rear_axle)
    fork = RigidBody("front_frame", p["mH"], tensor(p["IH"]), com=up(p["xH"], p["zH"]) - steer_foot)
    rear = RigidBody("rear_wheel", p["mR"], (p["IRxx"], p["IRyy"], p["IRxx"]))
    front = RigidBody("front_wheel", p["mF"], (p["IFxx"], p["IFyy"], p["IFxx"]))
    steer_axis = (-np.sin(lam), 0.0, np.cos(lam))  # pointing up, tilted back
    model.add(
        YawLeanPitch("frame", model.ground, frame),
        Revolute("rear_wheel", frame, rear, axis=(0, 1, 0)),
        Revolute("steer", frame, fork, axis=steer_axis, parent_point=steer_foot - rear_axle),
        Revolute("front_wheel", fork, front, axis=(0, 1, 0), parent_point=np.array([w, 0.0, rF]) - steer_foot),
        RollingDisc("rear_contact", rear, rR, axis=(0, 1, 0)),
        RollingDisc("front_contact", front, rF, axis=(0, 1, 0)),
        Gravity((0.0, 0.0, -p["g"])),
    )
    return model


def upright_state(system, v: float):
    """The upright, straight-running state at forward speed v.

    Parameters
    ----------
    system : System
        The built :func:`benchmark_bicycle`.
    v : float
        Forward speed, m/s.

    Returns
    -------
    x0, xd0 : ndarray
        Coordinates and speeds (the wheels turn at ``v / r`` about their
        axes, to the left).
    """
    names = system.coordinate_names
    rR = float(system.constraints.elements[0].radius)
    rF = float(system.constraints.elements[1].radius)
    x0, xd0 = np.zeros(system.n_coords), np.zeros(system.n_coords)
    x0[names.index("frame.z")] = rR
    xd0[names.index("frame.x")] = v
    xd0[names.index("rear_wheel.angle")] = v / rR
    xd0[names.index("front_wheel.angle")] = v / rF
    return x0, xd0


def linearize_upright(system, v: float, **kw):
    """:func:`flexmb.linearize_steady` about upright, straight running at speed v.

    Parameters
    ----------
    system : System
        The built :func:`benchmark_bicycle`.
    v : float
        Forward speed, m/s.
    **kw
        Passed to :func:`flexmb.linearize_steady` (``h``, ``tol``).

    Returns
    -------
    SteadyLinearization
        States lean and steer, then the rates of lean, the rear wheel and
        steer.
    """
    x0, xd0 = upright_state(system, v)
    return linearize_steady(system, x0, xd0, ignorable=IGNORABLE, speeds=SPEEDS, **kw)


def upright_eigenvalues(system, v: float, **kw) -> np.ndarray:
    """The four eigenvalues of the lean and steer motion about upright, straight running (Table 2).

    The rear wheel's rate (the forward speed) is the fifth state: to first
    order nothing drives it (its row of A is 0), so its eigenvalue is 0 and
    it is left out.

    Parameters
    ----------
    system : System
        The built :func:`benchmark_bicycle`.
    v : float
        Forward speed, m/s.
    **kw
        Passed to :func:`flexmb.linearize_steady`.

    Returns
    -------
    ndarray of complex, shape (4,)
        Sorted by real part, then imaginary part, 1/s.
    """
    lin = linearize_upright(system, v, **kw)
    A = lin.A
    i = lin.states.index("rear_wheel.angle rate")
    if np.max(np.abs(A[i])) > 1e-9 * np.max(np.abs(A)):
        raise ModelError(f"upright_eigenvalues: the forward speed is driven to first order (row {A[i]})")
    rest = [j for j in range(A.shape[0]) if j != i]
    ev = np.linalg.eigvals(A[np.ix_(rest, rest)])
    return ev[np.lexsort((ev.imag, ev.real))]


def weave_and_capsize_speeds(system, bracket_weave=(3.0, 5.0), bracket_capsize=(5.5, 7.0), xtol=1e-12):
    """The weave speed (the oscillatory pair's real part crosses 0) and the capsize speed (the real
    eigenvalue of the slow lean motion crosses 0), by Brent's method on the eigenvalues.

    Parameters
    ----------
    system : System
        The built :func:`benchmark_bicycle`.
    bracket_weave, bracket_capsize : tuple of float
        Speeds (m/s) bracketing each crossing.
    xtol : float
        Absolute tolerance on the speeds, m/s.

    Returns
    -------
    weave, capsize : float
        m/s; the bicycle is self-stable between them.
    """
    def weave(v):
        ev = upright_eigenvalues(system, v)
        return float(np.max(ev.real[np.abs(ev.imag) > 1e-9]))

    def capsize(v):
        ev = upright_eigenvalues(system, v)
        real = ev.real[np.abs(ev.imag) <= 1e-9]
        return float(real[np.argmin(np.abs(real))])

    return (so.brentq(weave, *bracket_weave, xtol=xtol, rtol=4 * np.finfo(float).eps),
            so.brentq(capsize, *bracket_capsize, xtol=xtol, rtol=4 * np.finfo(float).eps))
