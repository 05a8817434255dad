r"""
Write your own element: a drag law and a screw joint
====================================================

flexmb's force elements and joints are small attrs classes, and a class you
write takes the path the built-ins take. This tutorial writes two:

* ``AeroDrag``, a :class:`~flexmb.ForceElement`: the quadratic aerodynamic
  drag ``F = -1/2 rho Cd A |v| v`` at a point of a body. It is dissipative
  (no potential). It implements ``apply`` (one element) and the batched
  class method ``apply_all`` (all elements of the class in one vectorised
  call); both give the same loads, and the batched one is faster.
* ``Screw``, a :class:`~flexmb.Joint`: a helical joint with one coordinate,
  the rotation theta about the joint z axis, coupled to the translation
  ``p theta / (2 pi)`` along z (the lead p, m per turn: the pitch of a
  single-start thread). It overrides the class method ``motion``.

They are checked against numbers from outside the code:

1. The screw's partial velocities equal finite differences of its positions
   (the contract every joint passes, as in ``tests/test_kinematics.py``), to
   better than 1e-8.
2. A nut on a vertical screw under gravity. With ``z = k theta``,
   ``k = p / (2 pi)``, the kinetic energy is
   ``T = 1/2 m zd^2 + 1/2 I thetad^2 = 1/2 (m k^2 + I) thetad^2`` (I the
   nut's moment of inertia about the screw axis) and the potential energy is
   ``U = m g z = m g k theta``. Energy conservation, ``d(T + U)/dt = 0``,
   gives ``(m k^2 + I) thetadd = -m g k``, so the nut slides down with the
   constant acceleration

   .. math:: a = \frac{g}{1 + (2\pi/p)^2 \, I / m}.

   For the nut here (0.2 kg, I = 4.36e-5 kg m^2, lead 40 mm) that is
   a = 1.537874 m/s^2 (g / 6.3789), and the simulated fall
   ``z(t) = -a t^2 / 2`` matches it to better than 1e-8 m (z(1 s) =
   -0.768937 m). A one-line subclass with a 2 mm lead, in the same model,
   gives 0.004557 m/s^2, again as the closed form says.
3. A ball of 0.1 kg and 10 cm diameter falling on a vertical rail with
   ``AeroDrag`` (air, Cd = 0.47) follows the closed form
   ``v(t) = -v_t tanh(g t / v_t)`` with the terminal speed
   ``v_t = sqrt(2 m g / (rho Cd A)) = 20.83`` m/s, to better than 1e-8
   relative (v(3 s) = -18.4991 m/s).
4. A paddle pendulum (a 1 kg, 1 m plate, 20 cm wide, split into 20 drag
   strips), released horizontal, loses 4.51 J of its 4.905 J (92 %) in
   10 s, and the energy lost equals the work of the drag
   (``simulate(..., track_work=True)``) to better than 1e-6 relative.
5. Both classes, registered for the session with :func:`flexmb.register`,
   are used by name from a TOML scene (:func:`flexmb.loads_scene`); the
   scene's result equals the one of the model built in Python (difference
   0).

What you should see: one line per check, each printing the simulated
number next to its closed form and the error (about 1e-10 or smaller), and
the batched ``apply_all`` some 50 times faster than ``apply`` one by one on
400 drag strips, and a compiled ``apply_all`` (a numba kernel) faster again,
with the same loads (the timings depend on the machine and are not
checked). Run
as a script, it also saves ``results/05_custom_elements.png``: the ball's
speed on its tanh curve, and the paddle's energy loss on the drag's work.
"""

import time
from functools import lru_cache
from typing import ClassVar

import numpy as np
from attrs import field, frozen

import flexmb as fm
from flexmb.errors import ModelError
from flexmb.fields import as_array, as_float, as_unit_vector, label, positive, unit_vector, vector3
from flexmb.rotations import frame_from_axis

# %%
# A force element: quadratic drag
# -------------------------------
# A force element is a frozen attrs class: its data are fields, converted
# and validated at construction, with messages that name the element
# (``AeroDrag 'vane': cd must be > 0, got -1.0``). Definitions are
# ``@frozen(eq=False)``: immutable and hashed by identity. The converters
# and validators flexmb's own elements use are in :mod:`flexmb.fields`:
# ``as_float`` and ``as_array`` (a read-only float copy) convert, and
# ``positive``, ``vector3`` and the others check and name the element.
#
# ``apply(state, loads)`` adds the element's loads for one kinematic state.
# ``state.locate(body, point)`` turns a point given in the body frame into
# the row of the per-body arrays (and, on a flexible body, the segment's local
# point); ``state.point_position`` and ``state.point_velocity`` give its
# inertial position and velocity. The assembler projects the force on the
# partial velocities (eq. 5). Drag only dissipates, so ``potential`` keeps
# the base class's 0 and the energy checks count its work instead.


@frozen(eq=False)
class AeroDrag(fm.ForceElement):
    """Quadratic aerodynamic drag at a body point, ``F = -1/2 rho Cd A |v| v``.

    Parameters
    ----------
    name : str
        Unique name.
    body : Body
        The body the point belongs to.
    area : float
        Reference (frontal) area A, m^2.
    cd : float
        Drag coefficient Cd (0.47 for a sphere, about 1.2 for a flat plate).
    rho : float
        Air density, kg/m^3.
    point : array_like, shape (3,)
        Point of application in the body frame, m (still air, velocity of the
        body point).

    Notes
    -----
    Dissipative: no potential energy; its power ``F . v = -1/2 rho Cd A |v|^3``
    is never positive. Enters Kane's equations through the generalized active
    force F (eq. 5).
    """

    body: fm.Body = field()
    area: float = field(converter=as_float, validator=positive)
    cd: float = field(default=1.0, converter=as_float, validator=positive)
    rho: float = field(default=1.225, converter=as_float, validator=positive)
    point: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)

    def apply(self, state, loads):
        """Add the drag force at the point (one element)."""
        k, local = state.locate(self.body, self.point)
        p = state.point_position(k, local)
        v = state.point_velocity(k, p)
        loads.add_point_force(k, p, -0.5 * self.rho * self.cd * self.area * np.linalg.norm(v) * v)

    @classmethod
    def apply_all(cls, elements, state, loads):
        """Add the drag of all elements of the class in one vectorised call."""
        rows, local, coef = _stacked(tuple(elements), state.topology)
        p = state.point_position(rows, local)  # (m, 3)
        v = state.point_velocity(rows, p)
        loads.add_point_force(rows, p, -coef[:, None] * np.linalg.norm(v, axis=1, keepdims=True) * v)


@lru_cache(maxsize=32)
def _stacked(elements, topology):
    """Rows, local points and 1/2 rho Cd A of the elements, gathered once per model."""
    located = [topology.locate(e.body, e.point) for e in elements]
    rows = np.array([r for r, _ in located], dtype=int)
    local = np.array([p for _, p in located], dtype=float).reshape(-1, 3)
    return rows, local, np.array([0.5 * e.rho * e.cd * e.area for e in elements])


# %%
# Bad input is refused at construction, with the element's name:

try:
    AeroDrag("vane", fm.RigidBody("plate", mass=1.0, inertia=(1.0, 1.0, 1.0)), area=0.01, cd=-1.0)
except ModelError as exc:
    print(f"ModelError: {exc}")

# %%
# ``apply`` and ``apply_all`` give the same loads
# -----------------------------------------------
# A paddle pendulum: a flat plate 1 m long and 20 cm wide, pinned at one end,
# swinging about z (gravity along -y); the plate lies in the x-z plane of its
# body frame, so it moves face-on and its inertia about z is that of a slender
# bar, ``m L^2 / 3`` about the pin. Its drag is split into 20 strips along
# its length, each an ``AeroDrag`` at the strip's centre with the strip's
# area and the flat-plate Cd = 1.2. We evaluate the loads once element by
# element and once in the batched call, at a state where the paddle swings at
# 3 rad/s, and time both on a finer paddle of 400 strips (the timing is only
# printed: it depends on the machine).

g, m_paddle, L, width, cd_plate = 9.81, 1.0, 1.0, 0.2, 1.2


def paddle_model(n_strips):
    model = fm.Model("paddle")
    plate = fm.RigidBody.slender_bar("plate", mass=m_paddle, length=L)
    pin = fm.Revolute("pin", model.ground, plate, axis=(0, 0, 1))
    strips = [AeroDrag(f"strip{i}", plate, area=width * L / n_strips, cd=cd_plate,
                      point=((i + 0.5) * L / n_strips, 0.0, 0.0)) for i in range(n_strips)]
    return model.add(pin, fm.Gravity((0.0, -g, 0.0)), *strips)


def loads_both_ways(system, x, xd):
    kin = system.kinematics(0.0, x, xd)
    drags = [f for f in system.model.forces if isinstance(f, AeroDrag)]
    one, batch = fm.Loads(kin), fm.Loads(kin)
    for e in drags:
        e.apply(kin, one)
    AeroDrag.apply_all(drags, kin, batch)
    return kin, drags, one, batch


system = paddle_model(20).build()
x, xd = np.array([-0.3]), np.array([3.0])
kin, drags, one, batch = loads_both_ways(system, x, xd)
apply_difference = max(np.abs(one.force - batch.force).max(), np.abs(one.torque - batch.torque).max())
# by hand: the strip at radius s moves face-on at the speed s w, so its drag 1/2 rho Cd dA (s w)^2
# has the moment -1/2 rho Cd dA s^3 w ``|w|`` about the pin; gravity adds -m g (L / 2) cos q
s = (np.arange(20) + 0.5) * L / 20
drag_moment_exact = -0.5 * 1.225 * cd_plate * width * L / 20 * np.sum(s**3) * xd[0] ** 2
drag_moment = (system.forces.active_force(kin) - (-m_paddle * g * L / 2 * np.cos(x[0])))[0]
drag_moment_error = abs(drag_moment - drag_moment_exact) / abs(drag_moment_exact)
print(f"apply vs apply_all: largest difference in force/torque {apply_difference:.1e}; "
      f"drag moment about the pin {drag_moment:.9f} N m (by hand {drag_moment_exact:.9f})")

fine = paddle_model(400).build()
kin_f, drags_f, _, _ = loads_both_ways(fine, x, xd)
timings = {}
for route, fun in (("apply, one by one", lambda ld: [e.apply(kin_f, ld) for e in drags_f]),
                   ("apply_all, batched", lambda ld: AeroDrag.apply_all(drags_f, kin_f, ld))):
    t0 = time.perf_counter()
    for _ in range(20):
        fun(fm.Loads(kin_f))
    timings[route] = (time.perf_counter() - t0) / 20
print("400 strips: " + ", ".join(f"{k} {1e3 * v:.2f} ms" for k, v in timings.items()))

# %%
# The compiled route: a numba kernel in ``apply_all``
# ---------------------------------------------------
# flexmb's own elements compile their loops with numba (``cache=True``: the
# machine code is kept beside the source, so only the first run of a new
# installation compiles). A plugin can do the same: its ``apply_all`` calls
# a kernel that works on plain arrays. :mod:`flexmb.kernels.loads` gives the
# positions and velocities of body points (``body_points``) and scatters
# point forces onto the bodies (``add_point_forces``); the state's arrays
# ``R``, ``origin``, ``r``, ``omega`` and ``v`` have one row per body and the
# ground last (row -1). Everything else stays as above: the class is the
# same element, only faster. In a plugin package write ``@njit(cache=True)``;
# a script (like this tutorial, also run by ``runpy`` in the tests) compiles
# its kernel anew at each run, since numba cannot key a cache on a module
# that has no importable name.

from numba import njit  # noqa: E402

from flexmb.kernels.loads import add_point_forces, body_points  # noqa: E402


@njit
def _drag_forces(coef, v):
    out = np.empty_like(v)
    for i in range(v.shape[0]):
        speed = np.sqrt(v[i, 0] ** 2 + v[i, 1] ** 2 + v[i, 2] ** 2)
        for a in range(3):
            out[i, a] = -coef[i] * speed * v[i, a]
    return out


@frozen(eq=False)
class CompiledAeroDrag(AeroDrag):
    """:class:`AeroDrag` whose batched evaluation is compiled."""

    @classmethod
    def apply_all(cls, elements, state, loads):
        """Add the drag of all elements through compiled kernels."""
        rows, local, coef = _stacked(tuple(elements), state.topology)
        p, v = body_points(rows.astype(np.int64), local, state.R, state.origin, state.r, state.omega, state.v)
        add_point_forces(rows.astype(np.int64), p, _drag_forces(coef, v), state.r, loads.force, loads.torque)


compiled = fm.Loads(kin_f)
CompiledAeroDrag.apply_all(drags_f, kin_f, compiled)  # compiles on the first call (or loads the cache)
reference = fm.Loads(kin_f)
AeroDrag.apply_all(drags_f, kin_f, reference)
compiled_difference = max(np.abs(compiled.force - reference.force).max(),
                          np.abs(compiled.torque - reference.torque).max())
t0 = time.perf_counter()
for _ in range(20):
    CompiledAeroDrag.apply_all(drags_f, kin_f, fm.Loads(kin_f))
timings["apply_all, compiled"] = (time.perf_counter() - t0) / 20
print(f"compiled apply_all: same loads to {compiled_difference:.1e}; 400 strips "
      f"{1e3 * timings['apply_all, compiled']:.3f} ms")

# %%
# Drag against a closed form: a falling ball
# ------------------------------------------
# A ball of mass m on a vertical rail (a :class:`~flexmb.Prismatic` joint),
# released from rest, with ``AeroDrag`` at its centre. Newton's law
# ``m vd = -m g + 1/2 rho Cd A v^2`` has the solution
# ``v(t) = -v_t tanh(g t / v_t)`` and ``z(t) = -(v_t^2 / g) ln cosh(g t / v_t)``,
# with the terminal speed ``v_t = sqrt(2 m g / (rho Cd A))``.

m_ball, d_ball, cd_sphere, rho = 0.1, 0.1, 0.47, 1.225
area_ball = np.pi * d_ball**2 / 4
model = fm.Model("falling_ball")
ball = fm.RigidBody("ball", mass=m_ball, inertia=np.full(3, 0.4 * m_ball * (d_ball / 2) ** 2))
rail = fm.Prismatic("rail", model.ground, ball, axis=(0, 0, 1))
model.add(rail, fm.Gravity((0.0, 0.0, -g)), AeroDrag("air", ball, area=area_ball, cd=cd_sphere, rho=rho))
res_ball = fm.simulate(model, 3.0, rtol=1e-12, atol=1e-14, n_out=61)
v_terminal = np.sqrt(2 * m_ball * g / (rho * cd_sphere * area_ball))
v_exact = -v_terminal * np.tanh(g * res_ball.t / v_terminal)
z_exact = -(v_terminal**2 / g) * np.log(np.cosh(g * res_ball.t / v_terminal))
fall_error = max(np.abs(res_ball.xd[:, 0] - v_exact).max() / v_terminal,
                 np.abs(res_ball.x[:, 0] - z_exact).max() / np.abs(z_exact).max())
print(f"falling ball: terminal speed {v_terminal:.6f} m/s, v(3 s) = {res_ball.xd[-1, 0]:.9f} m/s "
      f"(closed form {v_exact[-1]:.9f}), relative error {fall_error:.1e}")

# %%
# Energy: the paddle pendulum with drag
# -------------------------------------
# Released horizontal, the paddle swings and its mechanical energy (kinetic
# plus gravity's potential) decays. ``track_work=True`` integrates, with the
# state, the work of each class of force elements; ``Result.work`` has one
# history per class, labelled by its elements' names. Gravity's work is
# already in the energy (as its potential), so the energy lost must equal the
# drag's work.

res_paddle = fm.simulate(system, 10.0, positions={"pin": 0.0}, rtol=1e-10, track_work=True, n_out=501)
drag_label = next(k for k in res_paddle.work if k.startswith("strip"))
drag_work = res_paddle.work[drag_label]
energy_change = res_paddle.energy - res_paddle.energy[0]
energy_balance_error = np.abs(energy_change - drag_work).max() / np.abs(drag_work).max()
E_max = res_paddle.energy[0] - (-m_paddle * g * L / 2)  # energy above the resting position
energy_lost_fraction = -energy_change[-1] / E_max
print(f"paddle: energy above rest {E_max:.4f} J, lost in 10 s {-energy_change[-1]:.6f} J "
      f"({100 * energy_lost_fraction:.1f} %), drag work {drag_work[-1]:.6f} J, "
      f"relative mismatch {energy_balance_error:.1e}")

# %%
# A joint: the screw
# ------------------
# A joint's class data say how many coordinates it has and what it imposes
# when it closes a loop; ``motion(q, qd)`` maps the coordinates to the
# child marker's rotation ``R`` and position ``d`` in the parent marker frame,
# with the partial angular velocities ``Hw`` and partial velocities ``Hv``
# (eqs. 7, 17 for one joint) and the velocity-dependent accelerations
# ``aw = Hwdot qd``, ``av = Hvdot qd``. It is a class method: it is
# evaluated once for all joints of the class, with ``q`` of shape
# ``(m, n_coords)``, so the code is vectorised over the m joints. Because it
# sees only the coordinates, the lead is class data: a screw of another lead
# is a one-line subclass (``class FineScrew(Screw): lead = 0.002``).
#
# For the screw, ``R = Rz(theta)``, ``d = (0, 0, k theta)``, ``Hw = e_z``,
# ``Hv = k e_z`` with ``k = p / (2 pi)``; both are constant, so ``aw = av = 0``.
# The loop-closing primitives cannot express the helix: as a cut joint the
# screw would act as a cylindrical joint, so keep it in the tree.
#
# The axis field is normalised by ``as_unit_vector`` (``unit_vector`` rejects
# a zero vector). The lead is class data, not a field, so no field validator
# sees it: ``__attrs_post_init__`` checks it, and ``label(self)`` names the
# element in the message as the validators do.


@frozen(eq=False)
class Screw(fm.Joint):
    """A helical joint: rotation theta about ``axis`` with the advance ``lead * theta / (2 pi)`` along it.

    Parameters
    ----------
    axis : array_like, shape (3,)
        Screw axis in the parent body frame (the joint frame's z);
        normalised on construction.

    Attributes
    ----------
    lead : float
        Advance per turn, m (class data; negative for a left-hand thread).
    """

    lead: ClassVar[float] = 0.04
    rotation_axes = (2,)
    coordinate_names = ("angle",)
    # as a cut joint: a cylindrical joint (the helix is not a primitive)
    cut_point = False
    cut_directions = (0, 1)
    cut_perpendicular = ((2, 0), (2, 1))

    axis: np.ndarray = field(default=(0.0, 0.0, 1.0), converter=as_unit_vector, validator=unit_vector)

    def __attrs_post_init__(self):
        super().__attrs_post_init__()
        if not np.isfinite(self.lead) or self.lead == 0.0:
            raise ModelError(f"{label(self)}: lead must be finite and non-zero, got {self.lead!r}")

    def _default_frame(self):
        return frame_from_axis(self.axis)

    @classmethod
    def motion(cls, q, qd):
        """Rotation Rz(theta) and advance k theta along z, k = lead / (2 pi), for m screws at once."""
        m = q.shape[0]
        k = cls.lead / (2 * np.pi)
        c, s = np.cos(q[:, 0]), np.sin(q[:, 0])
        R = np.zeros((m, 3, 3))
        R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = c, -s, s, c, 1.0
        d = np.zeros((m, 3))
        d[:, 2] = k * q[:, 0]
        Hw = np.zeros((m, 3, 1))
        Hw[:, 2, 0] = 1.0
        Hv = np.zeros((m, 3, 1))
        Hv[:, 2, 0] = k
        return R, d, Hw, Hv, np.zeros((m, 3)), np.zeros((m, 3))


# %%
# Partial velocities against finite differences
# ---------------------------------------------
# First the joint alone, as the contract test does for every joint: the
# columns of ``Hw`` and ``Hv`` are the derivatives of R (as the axial vector
# of ``dR/dq R^T``) and of d with respect to the coordinate. Then the whole
# system, with the screw mounted on a turntable (a revolute about the
# inertial x axis, so the screw axis tumbles): the V and W that the
# kinematics build for the nut (eqs. 7, 17) against central differences of
# its mass-centre position and rotation along ``xd``, and the bias
# accelerations against differences of its velocities.


def vee(S):
    return np.stack([S[..., 2, 1], S[..., 0, 2], S[..., 1, 0]], axis=-1)


h = 1e-6
q = np.array([[0.3], [-1.1], [2.0]])
R, d, Hw, Hv, aw, av = Screw.motion(q, np.ones_like(q))
Rp, dp, *_ = Screw.motion(q + h, np.ones_like(q))
Rm, dm, *_ = Screw.motion(q - h, np.ones_like(q))
joint_fd_error = max(np.abs(vee((Rp - Rm) / (2 * h) @ R.transpose(0, 2, 1)) - Hw[:, :, 0]).max(),
                     np.abs((dp - dm) / (2 * h) - Hv[:, :, 0]).max())

m_nut, r_out, r_in, height = 0.2, 0.02, 0.006, 0.015
I_axis = m_nut * (r_out**2 + r_in**2) / 2  # a thick ring about its axis
I_trans = m_nut * (3 * (r_out**2 + r_in**2) + height**2) / 12


def nut_on_screw(parent_joint=False):
    model = fm.Model("screw")
    nut = fm.RigidBody("nut", mass=m_nut, inertia=(I_trans, I_trans, I_axis))
    if parent_joint:
        table = fm.RigidBody.box("table", 1.0, (0.3, 0.3, 0.05))
        model.add(fm.Revolute("turntable", model.ground, table, axis=(1, 0, 0)))
        model.add(Screw("screw", table, nut, parent_point=(0.0, 0.05, 0.0), axis=(0, 0, 1)))
    else:
        model.add(Screw("screw", model.ground, nut))
    return model.add(fm.Gravity((0.0, 0.0, -g))), nut


tumbling, nut = nut_on_screw(parent_joint=True)
sys_t = tumbling.build()
x, xd = np.array([0.4, 1.3]), np.array([0.7, -2.0])
kin = sys_t.kinematics(0.0, x, xd)
k = sys_t.index(nut)
plus, minus = sys_t.kinematics(0.0, x + h * xd, xd), sys_t.kinematics(0.0, x - h * xd, xd)
v_fd = (plus.r[k] - minus.r[k]) / (2 * h)
w_fd = vee((plus.R[k] - minus.R[k]) / (2 * h) @ kin.R[k].T)
a_fd = (plus.v[k] - minus.v[k]) / (2 * h)  # at xdd = 0: the bias acceleration Vdot xd
alpha_fd = (plus.omega[k] - minus.omega[k]) / (2 * h)
system_fd_error = max(np.abs(kin.V[k] @ xd - v_fd).max(), np.abs(kin.W[k] @ xd - w_fd).max(),
                      np.abs(kin.a_bias[k] - a_fd).max(), np.abs(kin.alpha_bias[k] - alpha_fd).max())
print(f"screw partials vs finite differences: joint {joint_fd_error:.1e}, nut on a turntable "
      f"{system_fd_error:.1e}")

# %%
# The falling nut
# ---------------
# On a fixed vertical screw, the nut released from rest falls with the
# constant acceleration ``a = g / (1 + (2 pi / p)^2 I / m)`` (derived in the
# header from the energy), while turning at ``thetadd = -a / k``.

screw_model, nut = nut_on_screw()
a_exact = g / (1 + (2 * np.pi / Screw.lead) ** 2 * I_axis / m_nut)
res_nut = fm.simulate(screw_model, 1.0, rtol=1e-10, n_out=101)
t = res_nut.t
z_nut = res_nut.origins[:, 0, 2]
theta_exact = -a_exact * t**2 / 2 / (Screw.lead / (2 * np.pi))
nut_error = max(np.abs(z_nut - (-a_exact * t**2 / 2)).max(), np.abs(res_nut.xdd[:, 0] * Screw.lead / (2 * np.pi)
                                                                     + a_exact).max())
nut_angle_error = np.abs(res_nut.coordinate("screw") - theta_exact).max()
nut_energy_drift = np.ptp(res_nut.energy)
print(f"nut: a = {a_exact:.6f} m/s^2 (g / {g / a_exact:.4f}); z(1 s) = {z_nut[-1]:.9f} m, "
      f"closed form {-a_exact / 2:.9f} m; largest error {nut_error:.1e} (angle {nut_angle_error:.1e} rad), "
      f"energy drift {nut_energy_drift:.1e} J")

# %%
# A screw of another lead is a one-line subclass. Joints are grouped by
# class for ``motion``, so a model may hold both: two nuts, one on a coarse
# and one on a fine (2 mm) screw, each accelerating at its own closed form.


class FineScrew(Screw):
    lead = 0.002


two = fm.Model("two_screws")
nuts = [fm.RigidBody(f"nut{i}", mass=m_nut, inertia=(I_trans, I_trans, I_axis)) for i in (1, 2)]
two.add(Screw("coarse", two.ground, nuts[0]), FineScrew("fine", two.ground, nuts[1], parent_point=(0.1, 0, 0)),
        fm.Gravity((0.0, 0.0, -g)))
sys_two = two.build()
xdd_two = sys_two.accelerations(0.0, np.zeros(2), np.zeros(2))
a_two = -xdd_two * np.array([Screw.lead, FineScrew.lead]) / (2 * np.pi)
a_two_exact = g / (1 + (2 * np.pi / np.array([Screw.lead, FineScrew.lead])) ** 2 * I_axis / m_nut)
two_screws_error = np.abs(a_two - a_two_exact).max()
print(f"coarse and fine screw: a = {a_two} m/s^2, closed forms {a_two_exact}, error {two_screws_error:.1e}")

# %%
# From a scene file
# -----------------
# Registered for the session, the two classes are plugins like the built-ins:
# a scene names them by ``type``, and the other keys of a table are passed
# to the class as keyword arguments (``body = "nut"`` is resolved to the
# body). Here the nut gets a small vane on its rim, so the drag brakes its
# spin. ``replace=True`` lets the script run twice in one session.
#
# For a package, declare the classes as entry points in its
# ``pyproject.toml`` instead (see ``docs/plugins.md``); after ``pip install``
# they are found by name in every session::
#
#     [project.entry-points."flexmb.forces"]
#     aero_drag = "my_elements:AeroDrag"
#
#     [project.entry-points."flexmb.joints"]
#     screw = "my_elements:Screw"

fm.register("forces", "aero_drag", AeroDrag, replace=True)
fm.register("joints", "screw", Screw, replace=True)
session_plugins = sorted((p.kind, p.name) for p in fm.plugins() if p.origin == "session")
print(f"plugins registered for this session: {session_plugins}")

scene = fm.loads_scene(f"""
[model]
name = "nut_with_vane"

[bodies.nut]
mass = {m_nut!r}                  # kg
inertia = [{I_trans!r}, {I_trans!r}, {I_axis!r}]   # kg m^2, about the body axes

[joints.screw]
type = "screw"
parent = "ground"
child = "nut"

[forces.gravity]
type = "gravity"
g = [0.0, 0.0, -9.81]

[forces.vane]
type = "aero_drag"
body = "nut"
area = 4e-4                 # m^2
cd = 1.2
point = [0.02, 0.0, 0.0]    # on the rim, m

[solver]
t_end = 1.0
rtol = 1e-10
""", source="nut_with_vane.toml")
res_toml = scene.simulate()

model_py, nut_py = nut_on_screw()
model_py.add(AeroDrag("vane", nut_py, area=4e-4, cd=1.2, point=(0.02, 0.0, 0.0)))
res_py = fm.simulate(model_py, 1.0, rtol=1e-10)
scene_difference = max(np.abs(res_toml.x - res_py.x).max(), np.abs(res_toml.xd - res_py.xd).max())
braked_drop = res_toml.origins[-1, 0, 2]
print(f"scene types {scene.types}; z(1 s) with the vane {braked_drop:.6f} m (without {z_nut[-1]:.6f} m); "
      f"TOML vs Python difference {scene_difference:.1e}")

# %%
# Plot
# ----
# The falling ball against its closed form, and the paddle's energy with the
# drag's work.

if __name__ == "__main__":
    import os

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed (pip install -e '.[viz]'): no plot")
    else:
        fig, ax = plt.subplots(2, 1, figsize=(7, 6))
        ax[0].plot(res_ball.t, res_ball.xd[:, 0], "o", ms=3, label="flexmb")
        ax[0].plot(res_ball.t, v_exact, label="-v_t tanh(g t / v_t)")
        ax[0].set_xlabel("t [s]")
        ax[0].set_ylabel("ball speed [m/s]")
        ax[0].legend()
        ax[1].plot(res_paddle.t, energy_change, label="E(t) - E(0)")
        ax[1].plot(res_paddle.t, drag_work, "--", label="drag work")
        ax[1].set_xlabel("t [s]")
        ax[1].set_ylabel("J")
        ax[1].legend()
        fig.tight_layout()
        os.makedirs("results", exist_ok=True)
        fig.savefig(os.path.join("results", "05_custom_elements.png"), dpi=120)
        print("wrote results/05_custom_elements.png")
