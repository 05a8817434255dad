"""
The windshield wiper of the paper
=================================

The application of Amirouche & Huston (1988), after Haug: a crank turned at
60 rpm drives two wiper arms through two closed loops. Six bodies
(1 chassis = ground, 2 crank, 3 drive link, 4 right wiper arm,
5 connecting link, 6 left wiper arm) are joined by revolute (RJ),
spherical (SJ) and universal (UJ) joints at the seven points printed in the
paper's Fig. 3. Each arm carries a wiper blade, rigid or flexible, whose tip
rubs on the glass with a friction force that weakens with speed (Fig. 4).

The printed data is damaged and incomplete: two of the seven points are
corrected here, and every number the paper does not give (masses, blade
section, stiffness, damping, friction constants) is chosen and stated below.
The tutorial shows why each correction is needed, the glass plane and the
joint axes, that the loops assemble, the coordinates, constraint rows and
degrees of freedom, the sweep of the two arms, rigid against flexible
blades (tip displacement and tip speed against time, the paper's Figs. 5
and 6), the torque the crank motor supplies, and the energy balance

    driver work = change of kinetic energy + change of elastic energy
                  + friction dissipation + damping dissipation.

The one-command version writes the same runs (with 6-segment blades),
their plots, ``.npz`` results, VTK series and a ``summary.json``::

    flexmb run wiper --out results

The numbers to expect: the loops close to about 1e-16 m; rigid blades have
9 coordinates, 9 constraint rows and 0 degrees of freedom (16 for flexible
blades of 4 segments); the right arm sweeps 79.2 deg and the left 66.2 deg;
the right tip peaks at 2.08 m/s (the paper's Fig. 6 axis reaches 2.5); the
crank needs up to 0.75 N m; the flexible tip stays within half a
millimetre of the rigid one; the energy balance holds to about 3e-9
(rigid) and 1e-7 (flexible) of the driver work; the right blade's root
bending stress peaks at 17.0 MPa with a rigid blade and 21.7 MPa with a
flexible one (its ringing), both about 10 MPa rms.
"""

import numpy as np

import flexmb as fm
from flexmb.scenes.wiper import POINTS, PRINTED_POINTS, WiperOptions, glass_normal, wiper

# %%
# The short form
# --------------
# :func:`flexmb.scenes.wiper.wiper` builds the model from a
# :class:`~flexmb.scenes.wiper.WiperOptions` and returns it with the initial
# guess ``{"RJ1": 0}`` (crank angle 0, the rest assembled by Newton steps).
# The crank is driven (a :class:`~flexmb.Driver` named ``"motor"``), so the
# rigid-blade run is a kinematic one: the motion follows from the loops, the
# torque from Kane's equations. ``track_work=True`` integrates the work of the
# driver and of each class of force elements alongside the state
# (``res.work``). ``res.plot(["RJ4", "RJ7"])`` draws the two arm angles.
#
# Tolerances: the scene's default is ``rtol = 1e-6`` (what ``flexmb run
# wiper`` uses); the rigid run is cheap, so we take 1e-8 for it. After every
# step the state is projected back onto the loops when their residual
# exceeds 1e-10 m; between steps, the outputs come from the integrator's
# dense output and leave the loops by about ``rtol / 100`` m.

t_end = 1.0  # one crank revolution at 60 rpm, the span of the paper's Figs. 5-6
n_out = 501  # outputs every 2 ms
rtol_rigid = 1e-8  # cheap without elastic coordinates; keeps even the dense output on the loops to ~1e-9 m
rtol_flexible = 1e-6  # the scene's default (``flexmb run wiper``)

rigid_options = WiperOptions(flexible=False)
rigid_model, initial = wiper(rigid_options)
rigid = fm.simulate(rigid_model, t_end, positions=initial, rtol=rtol_rigid, n_out=n_out, track_work=True)
sweep_right_deg = np.degrees(np.ptp(rigid.coordinate("RJ4")))
sweep_left_deg = np.degrees(np.ptp(rigid.coordinate("RJ7")))
print(f"short form: {rigid.status} ({rigid.method}, {rigid.n_rhs} right-hand sides); "
      f"right arm sweeps {sweep_right_deg:.2f} deg, left arm {sweep_left_deg:.2f} deg")

# %%
# The printed points and the two corrections
# ------------------------------------------
# Fig. 3 prints the joint points without units. They are centimetres: the
# two wiper pivots RJ4 and RJ7 are 86.5 apart, the width between the wiper
# pivots of a car. The scene divides them by 100 (SI units throughout).
#
# Two points cannot be right as printed:
#
# * RJ1, the crank pivot, is printed as (83.52, 7.84, 2.81), nearly a copy of
#   RJ7 (83.52, 7.84, 2.91). The crank would then be 43 cm long, and the
#   first loop (crank, drive link, right lever) could close only over a small
#   arc of crank angles: the crank jams. No single-digit edit repairs it. The
#   scene puts the pivot 4 cm beyond SJ2, away from RJ4: (44.4, 3.8, 1.5),
#   a 4 cm crank, the short link of a crank-rocker.
# * SJ5, where the connecting link meets the right arm, is printed as
#   (11.5, 10.5, 8.4): a 15 cm right lever against a 7.6 cm left one, and the
#   second loop reaches a dead point (connecting link and left lever in line)
#   part way through the turn. Read as (1.5, 10.5, 8.4) (a table rule taken
#   for a "1"), the two levers are 6.4 and 7.6 cm and the connecting link
#   and the ground line 87.2 and 86.5 cm: the near-parallelogram of a real
#   wiper linkage.
#
# The other five points are kept as printed.

print(f"{'point':>5} {'printed (cm)':>24} {'used (cm)':>24}")
for name in POINTS:
    mark = "  <- corrected" if POINTS[name] != PRINTED_POINTS[name] else ""
    print(f"{name:>5} {str(PRINTED_POINTS[name]):>24} {str(POINTS[name]):>24}{mark}")
pivots_cm = np.linalg.norm(np.subtract(POINTS["RJ7"], POINTS["RJ4"]))
print(f"RJ4-RJ7 = {pivots_cm:.1f} cm; crank radius as printed "
      f"{np.linalg.norm(np.subtract(PRINTED_POINTS['SJ2'], PRINTED_POINTS['RJ1'])):.1f} cm, "
      f"corrected {np.linalg.norm(np.subtract(POINTS['SJ2'], POINTS['RJ1'])):.1f} cm")

# %%
# The glass plane
# ---------------
# The seven points are not coplanar; they scatter about their best-fit plane
# (least squares: the plane through their centroid normal to the smallest
# singular direction of the centred points), which we take as the glass.
# Its unit normal n, pointing to +z, is :func:`~flexmb.scenes.wiper.glass_normal`.

X = np.array(list(POINTS.values()))  # cm
centre = X.mean(axis=0)
_, _, Vt = np.linalg.svd(X - centre)
e1, e2, n = Vt
if n[2] < 0:
    n, e2 = -n, -e2
distance_cm = (X - centre) @ n
print("distance of each point to the best-fit plane [cm]: "
      + ", ".join(f"{k} {d:+.2f}" for k, d in zip(POINTS, distance_cm)))
plane_max_cm = np.abs(distance_cm).max()
print(f"largest {plane_max_cm:.2f} cm; normal n = {np.round(n, 5)} "
      f"(|n - glass_normal()| = {np.linalg.norm(n - glass_normal()):.0e})")

# %%
# A planar check of the corrections
# ---------------------------------
# Projected on the plane, the mechanism is two planar four-bars in series:
# crank RJ1-SJ2, drive link SJ2-UJ3, right lever UJ3-RJ4; then the right
# arm's second lever RJ4-SJ5, connecting link SJ5-UJ6 and left lever
# UJ6-RJ7. Turning the crank in steps, each loop closes where two circles
# meet (we keep the intersection nearest to the previous one, the same
# assembly branch). This needs nothing from flexmb and tells how far each
# set of points lets the crank turn.


def project(p):
    """In-plane coordinates (e1, e2) of a point, cm."""
    q = np.asarray(p, dtype=float) - centre
    return np.array([q @ e1, q @ e2])


def rotate(v, a):
    c, s = np.cos(a), np.sin(a)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def meet(p, r, q, s, near):
    """The point at distance r from p and s from q nearest to ``near``; None if there is none."""
    d = np.linalg.norm(q - p)
    if not abs(r - s) <= d <= r + s:
        return None
    e = (q - p) / d
    a = (r * r - s * s + d * d) / (2 * d)
    h = np.sqrt(max(r * r - a * a, 0.0)) * np.array([-e[1], e[0]])
    return min((p + a * e + h, p + a * e - h), key=lambda c: np.linalg.norm(c - near))


def planar_turn(points, step_deg=0.25):
    """Turn the projected crank once in steps.

    Returns the rows (crank angle, right and left lever angles) reached, in
    degrees, and the loop that jams (1 or 2; None after a full turn).
    """
    P = {k: project(v) for k, v in points.items()}
    L = {k: np.linalg.norm(P[a] - P[b]) for k, (a, b) in {
        "drive": ("SJ2", "UJ3"), "right": ("UJ3", "RJ4"), "link": ("SJ5", "UJ6"), "left": ("UJ6", "RJ7")}.items()}
    u3, u6, rows = P["UJ3"], P["UJ6"], []
    for a in np.radians(np.arange(0.0, 360.0 + step_deg / 2, step_deg)):
        u3 = meet(P["RJ1"] + rotate(P["SJ2"] - P["RJ1"], a), L["drive"], P["RJ4"], L["right"], u3)
        if u3 is None:
            return np.degrees(np.array(rows)), 1
        v0, v = P["UJ3"] - P["RJ4"], u3 - P["RJ4"]
        right = np.arctan2(v0[0] * v[1] - v0[1] * v[0], v0 @ v)
        u6 = meet(P["RJ4"] + rotate(P["SJ5"] - P["RJ4"], right), L["link"], P["RJ7"], L["left"], u6)
        if u6 is None:
            return np.degrees(np.array(rows)), 2
        w0, w = P["UJ6"] - P["RJ7"], u6 - P["RJ7"]
        rows.append((a, right, np.arctan2(w0[0] * w[1] - w0[1] * w[0], w0 @ w)))
    return np.degrees(np.array(rows)), None


for label, points in (("as printed RJ1", dict(POINTS, RJ1=PRINTED_POINTS["RJ1"])),
                      ("as printed SJ5", dict(POINTS, SJ5=PRINTED_POINTS["SJ5"])),
                      ("corrected", POINTS)):
    turn, jammed = planar_turn(points)
    if jammed:
        print(f"{label:>15}: loop {jammed} jams at a crank angle of {turn[-1, 0]:.1f} deg")
    else:
        print(f"{label:>15}: a full turn; the arms sweep {np.ptp(turn[:, 1]):.3f} and {np.ptp(turn[:, 2]):.3f} deg")
planar_sweeps = np.ptp(turn[:, 1]), np.ptp(turn[:, 2])

# %%
# With RJ1 as printed the first loop closes only for crank angles whose pin
# lies between ``l_drive - l_right`` and ``l_drive + l_right`` from RJ4:

P2 = {k: project(v) for k, v in dict(POINTS, RJ1=PRINTED_POINTS["RJ1"]).items()}
angles = np.radians(np.arange(0.0, 360.0, 0.5))
pins = np.array([P2["RJ1"] + rotate(P2["SJ2"] - P2["RJ1"], a) for a in angles])
d = np.linalg.norm(pins - P2["RJ4"], axis=1)
l_drive, l_right = np.linalg.norm(P2["UJ3"] - P2["SJ2"]), np.linalg.norm(P2["UJ3"] - P2["RJ4"])
closes = (d >= l_drive - l_right) & (d <= l_drive + l_right)
print(f"printed RJ1: the first loop closes on {100 * closes.mean():.0f} % of the crank angles "
      f"(about a fifth of a turn)")

# %%
# Nor does a misread digit explain it: replacing any one digit of the printed
# RJ1 by any other never lets the crank turn fully.

printed_rj1 = [f"{v:g}" for v in PRINTED_POINTS["RJ1"]]
edits = full_turns = 0
for c, text in enumerate(printed_rj1):
    for pos, ch in enumerate(text):
        for digit in "0123456789":
            if ch.isdigit() and digit != ch:
                rj1 = [float(v) for v in printed_rj1]
                rj1[c] = float(text[:pos] + digit + text[pos + 1:])
                edits += 1
                full_turns += planar_turn(dict(POINTS, RJ1=tuple(rj1)), step_deg=1.0)[1] is None
print(f"{edits} single-digit edits of RJ1, {full_turns} of them give a full turn")

# %%
# The joint axes
# --------------
# The crank and both arms turn about the glass normal: RJ1, RJ4 and RJ7 have
# ``axis = n``. The universal joints UJ3 and UJ6 take n as their first axis
# (in the drive or connecting link) and, as the second axis of the cross,
# the direction in the glass plane perpendicular to the link,
# ``n x (link direction)`` (in the arm). With a spherical joint at each end
# a link could spin freely about its own axis (an idle freedom that makes
# the mass matrix of the reduced equations singular); the universal joint
# blocks that spin. The spherical joints SJ2 and SJ5 need no axes.

for name, link in (("UJ3", ("SJ2", "UJ3")), ("UJ6", ("SJ5", "UJ6"))):
    j = rigid_model[name]
    a1, a2 = j.axis / np.linalg.norm(j.axis), j.axis2 / np.linalg.norm(j.axis2)
    along = np.subtract(POINTS[link[1]], POINTS[link[0]])
    along = along / np.linalg.norm(along)
    print(f"{name}: axis . n = {a1 @ n:.12f}, axis2 . n = {a2 @ n:+.1e}, axis2 . link = {a2 @ along:+.1e}")
for name in ("RJ1", "RJ4", "RJ7"):
    print(f"{name}: axis . n = {rigid_model[name].axis @ n / np.linalg.norm(rigid_model[name].axis):.12f}")

# %%
# Masses, lengths, blade, friction
# --------------------------------
# Nothing of this survives in the paper; the values are those of a car
# wiper, all in :class:`~flexmb.scenes.wiper.WiperOptions`:
#
# * crank 0.10 kg, drive link 0.25 kg and connecting link 0.40 kg: uniform
#   slender bars between their joint points (``m L^2 / 12`` about the
#   transverse axes);
# * each arm: a rigid link bar of 0.25 m and 0.20 kg (a uniform slender bar
#   from its pivot, carrying the joint points of its short levers) plus a
#   0.25 m blade clamped to its end, so the tip is 0.5 m from the pivot;
#   the arms rest 5 deg above the line between the wiper pivots RJ4-RJ7
#   (projected on the glass) at t = 0 and sweep up from there;
# * the blade: a spring-steel carrier (E = 210 GPa, rho = 7850 kg/m^3,
#   nu = 0.3), 10 mm wide in the glass plane and 2 mm thick normal to it
#   (39 g). Rigid, it is a steel box of that size; flexible, it is
#   ``n_segments`` rigid segments whose joints bend in the glass plane
#   (``bend_z``, stiff) and out of it (``bend_y``, soft): 2 elastic
#   coordinates per segment, with the beam-theory springs ``E I / l``
#   (2k at the clamp);
# * blade damping: stiffness proportional (``c = beta k``), 2 % of critical
#   in the first out-of-plane cantilever mode, hence about 10 % in the
#   first in-plane one (the ratio grows with the frequency);
# * tip friction (``velocity_weakening_friction`` force plugin): normal load
#   N = 5 N, ``mu = max(mu_s - s v, 0)`` with mu_s = 0.4 and s = 0.1 s/m,
#   so F0 = 2 N at rest and 1 N at 2 m/s, regularised below the smoothing
#   speed 0.01 m/s (there the force fades linearly to zero instead of
#   jumping when the blade reverses); it acts at the blade tip, in the
#   glass plane against the tip's in-plane velocity.

print(rigid_options)
flexible_options = WiperOptions(flexible=True, n_segments=4)
flexible_model, _ = wiper(flexible_options)
blade = flexible_model["right_blade"]
s, steel = blade.section, blade.material
f_out, f_in = (1.8751040687**2 / (2 * np.pi) * np.sqrt(steel.E * I / (steel.density * s.area * blade.length**4))
               for I in (s.Iy, s.Iz))
friction = flexible_model["right_blade_friction"]
print(f"blade: {blade.mass * 1e3:.1f} g, E = {steel.E:.3g} Pa, rho = {steel.density:g} kg/m^3, "
      f"I out of plane {s.Iy:.3e} m^4, in plane {s.Iz:.3e} m^4")
print(f"first cantilever modes: out of plane {f_out:.1f} Hz, in plane {f_in:.1f} Hz; "
      f"damping beta = 2 zeta / omega = {blade.damping:.3e} s")
print(f"friction: N = {friction.normal_load} N, mu_s = {friction.mu_static}, slope = {friction.slope} s/m, "
      f"F0 = {friction.normal_load * friction.mu_static:.1f} N, at 2 m/s "
      f"{friction.normal_load * (friction.mu_static - 2 * friction.slope):.1f} N, "
      f"smoothing speed {friction.smoothing_speed} m/s, normal {np.round(friction.normal, 5)}")

# %%
# Assembly, coordinates, degrees of freedom
# -----------------------------------------
# The tree grows from the ground: RJ1 carries the crank and SJ2 the drive
# link; RJ4 the right arm and SJ5 the connecting link; RJ7 the left arm; the
# blades are welded to the arms (flexible blades add their segment joints).
# UJ3 and UJ6 close the two loops: each writes 3 rows (the joint points
# coincide) and 1 row (the cross's axes stay perpendicular); the driver adds
# ``x_RJ1 - 2 pi t = 0``. :func:`flexmb.initial_state` closes the loops by
# Newton steps from the guess.

system = rigid_model.build()
x0, xd0 = fm.initial_state(system, positions=initial)
kin0 = system.kinematics(0.0, x0, xd0)
phi, psi, _, _ = system.constraints.evaluate(kin0, level=1)
assembly_residual = np.abs(phi).max()
loop_dof = system.strategy.complement(psi[:-1]).p  # without the driver row
print(f"assembly residual {assembly_residual:.1e} m")
print(f"rigid blades: {system.n_coords} coordinates {system.coordinate_names}")
print(f"  {system.n_constraints} constraint rows {system.constraints.labels}")
print(f"  degrees of freedom: {loop_dof} without the driver (the mechanism), "
      f"{system.dof(0.0, x0)} with it")

flexible_system = flexible_model.build()
xf0, _ = fm.initial_state(flexible_system, positions=initial)
flexible_dof = flexible_system.dof(0.0, xf0)
print(f"flexible blades, N = {flexible_options.n_segments}: {flexible_system.n_coords} coordinates, "
      f"{flexible_system.n_constraints} rows, {flexible_dof} degrees of freedom "
      f"(2 blades x 2 bending angles x {flexible_options.n_segments} segments)")

# %%
# The arms at rest make 5 degrees with the pivot line, in the glass plane:

pivot_line = np.subtract(POINTS["RJ7"], POINTS["RJ4"]) / 100.0
pivot_line -= n * (pivot_line @ n)
for side in ("right", "left"):
    k = system.index(rigid_model[f"{side}_blade"])
    arm = kin0.origin[k] - kin0.origin[system.index(rigid_model[f"{side}_arm"])]
    cos = arm @ pivot_line / np.linalg.norm(arm) / np.linalg.norm(pivot_line)
    print(f"{side} arm at t = 0: {np.degrees(np.arccos(cos)):.3f} deg from the pivot line, "
          f"{abs(arm @ n) / np.linalg.norm(arm):.1e} out of the glass plane")

# %%
# The rigid run
# -------------
# The crank follows ``2 pi t``, the loops stay closed, and the arms sweep
# 79 and 66 degrees (the planar check above gives the same). The tip
# positions and velocities are evaluated with the kinematics at each stored
# state: ``kin.locate(body, point)`` finds the body (or, for a flexible
# blade, the segment) that carries the tip.


def tip_history(model, res, side, length=rigid_options.blade_length):
    """Inertial position and velocity of a blade tip (``length`` from its root) at every output time."""
    sys_ = model.build()
    body = model[f"{side}_blade"]
    p, v = np.zeros((len(res.t), 3)), np.zeros((len(res.t), 3))
    for i, t in enumerate(res.t):
        kin = sys_.kinematics(t, res.x[i], res.xd[i])
        k, local = kin.locate(body, (length, 0.0, 0.0))
        p[i] = kin.point_position(k, local)
        v[i] = kin.point_velocity(k, p[i])
    return p, v


crank_error = np.abs(rigid.coordinate("RJ1") - 2 * np.pi * rigid.t).max()
torque = rigid.driver_effort("motor")
rigid_tips = {side: tip_history(rigid_model, rigid, side) for side in ("right", "left")}
rigid_speed = {side: np.linalg.norm(v, axis=1) for side, (_, v) in rigid_tips.items()}
peak_tip_speed = rigid_speed["right"].max()
print(f"crank angle - 2 pi t: {crank_error:.1e} rad; max loop residual {rigid.residual.max():.1e} m")
print(f"sweep: right {sweep_right_deg:.3f} deg, left {sweep_left_deg:.3f} deg "
      f"(planar check {planar_sweeps[0]:.3f}, {planar_sweeps[1]:.3f})")
print(f"peak tip speed: right {peak_tip_speed:.3f} m/s at t = {rigid.t[rigid_speed['right'].argmax()]:.3f} s, "
      f"left {rigid_speed['left'].max():.3f} m/s")
print(f"crank torque: peak {np.abs(torque).max():.4f} N m at t = {rigid.t[np.abs(torque).argmax()]:.3f} s, "
      f"mean {torque.mean():.4f} N m")

# %%
# Flexible blades
# ---------------
# The same mechanism with 4-segment blades (the ``flexmb run wiper`` command
# uses 6). The segment springs make the equations stiff, so
# ``method='auto'`` takes an implicit integrator (CVODE_BDF). The flexible tip
# is compared with the rigid one at the same output times: the blade bends
# under its own inertia and the tip friction. Both act in the glass plane,
# and every axis of the mechanism is normal to it, so the out-of-plane
# bending (the soft direction) is not excited at all: the blade bends in
# the plane only, by a fraction of a millimetre, with a ringing of its
# first in-plane mode (134 Hz) after each start and reversal, when the
# friction force flips.

flexible = fm.simulate(flexible_model, t_end, positions=initial, rtol=rtol_flexible, n_out=n_out,
                       track_work=True)
flexible_tips = {side: tip_history(flexible_model, flexible, side) for side in ("right", "left")}
flexible_speed = {side: np.linalg.norm(v, axis=1) for side, (_, v) in flexible_tips.items()}
print(f"flexible: {flexible.status} ({flexible.method}, {flexible.n_steps} steps, {flexible.n_rhs} right-hand "
      f"sides, {flexible.wall_time:.1f} s); max loop residual {flexible.residual.max():.1e} m")
for side in ("right", "left"):
    gap = flexible_tips[side][0] - rigid_tips[side][0]
    normal = gap @ n
    in_plane = np.linalg.norm(gap - normal[:, None] * n, axis=1)
    print(f"{side} tip, flexible - rigid: up to {1e3 * in_plane.max():.3f} mm in the glass plane, "
          f"{1e3 * np.abs(normal).max():.1e} mm normal to it; peak speed {flexible_speed[side].max():.3f} m/s "
          f"(rigid {rigid_speed[side].max():.3f})")
print(f"crank torque with flexible blades: peak {np.abs(flexible.driver_effort('motor')).max():.4f} N m")

# %%
# The histories of the paper's Figs. 5 and 6 every 0.1 s: the right tip's
# displacement from its start and its speed, and the crank torque.

print(f"{'t [s]':>6} {'displacement [m]':>22} {'speed [m/s]':>18} {'torque [N m]':>18}")
print(f"{'':>6} {'rigid':>11}{'flexible':>11} {'rigid':>9}{'flexible':>9} {'rigid':>9}{'flexible':>9}")
for i in range(0, n_out, (n_out - 1) // 10):
    row = []
    for res, tips, speed in ((rigid, rigid_tips, rigid_speed), (flexible, flexible_tips, flexible_speed)):
        p = tips["right"][0]
        row.append((np.linalg.norm(p[i] - p[0]), speed["right"][i], res.driver_effort("motor")[i]))
    (d0, v0, m0), (d1, v1, m1) = row
    print(f"{rigid.t[i]:6.2f} {d0:11.5f}{d1:11.5f} {v0:9.4f}{v1:9.4f} {m0:9.4f}{m1:9.4f}")

# %%
# The energy balance
# ------------------
# ``res.work`` holds the work of the driver (``"driver motor"``), of the
# friction elements and, with flexible blades, of the blade elasticity
# (spring and damper together) from t = 0. The sum of all works equals the
# change of kinetic energy. The elasticity work is minus the change of the
# elastic energy (``res.potential``: there is no gravity) plus the (negative)
# work of the blade dampers, so
#
#     driver work = dKE + dU + friction dissipation + damping dissipation
#
# with ``friction dissipation = -W_friction`` and
# ``damping dissipation = -(W_elasticity + dU)``, both >= 0. The error is
# the largest mismatch over the run, relative to the largest driver work.


def energy_terms(res):
    """Histories of the balance terms, J."""
    w = {"driver": res.work["driver motor"], "friction": np.zeros_like(res.t), "elasticity": np.zeros_like(res.t)}
    for name, values in res.work.items():
        if name.endswith("friction"):
            w["friction"] = w["friction"] + values
        elif name.endswith("elasticity"):
            w["elasticity"] = w["elasticity"] + values
    dU = res.potential - res.potential[0]
    return {"driver work": w["driver"], "kinetic energy change": res.kinetic - res.kinetic[0],
            "elastic energy change": dU, "friction dissipation": -w["friction"],
            "damping dissipation": 0.0 - w["elasticity"] - dU}


balance = {}
print(f"{'[J]':>24} {'rigid':>13} {'flexible':>13}")
terms = {label: energy_terms(r) for label, r in (("rigid", rigid), ("flexible", flexible))}
for key in terms["rigid"]:
    print(f"{key:>24} {terms['rigid'][key][-1]:13.8f} {terms['flexible'][key][-1]:13.8f}")
for label, e in terms.items():
    rhs = sum(v for k, v in e.items() if k != "driver work")
    balance[label] = np.abs(e["driver work"] - rhs).max() / np.abs(e["driver work"]).max()
print(f"{'sum of the right side':>24} "
      + " ".join(f"{sum(v[-1] for k, v in terms[lb].items() if k != 'driver work'):13.8f}" for lb in terms))
print(f"{'relative error':>24} {balance['rigid']:13.1e} {balance['flexible']:13.1e}")
energy_balance_error_rigid, energy_balance_error_flexible = balance["rigid"], balance["flexible"]

# %%
# As a check of the split of the elasticity work, the damping dissipation
# can be integrated directly from the damper forces,
# ``sum_i beta k_i etadot_i^2``, on the stored outputs (trapezoidal rule:
# close, but only as accurate as the 2 ms output step allows):

cols = np.concatenate([flexible_system.topology.elastic_columns(flexible_model[f"{side}_blade"])
                       for side in ("right", "left")])
c = np.concatenate([flexible_model[f"{side}_blade"].damping
                    * flexible_model[f"{side}_blade"].joint_stiffness().ravel() for side in ("right", "left")])
damping_power = (flexible.xd[:, cols] ** 2) @ c
direct = np.sum(0.5 * (damping_power[1:] + damping_power[:-1]) * np.diff(flexible.t))
print(f"damping dissipation: from res.work {terms['flexible']['damping dissipation'][-1]:.4e} J, "
      f"integrated directly {direct:.4e} J")

# %%
# Root bending stress of the blades
# ---------------------------------
# Does the blade survive? ``res.section_stresses(blade)`` gives the stresses
# at every segment joint of a flexible blade from its spring and damper
# moments (``M = k eta + c etadot``; see ``docs/stresses.md``), and
# ``res.joint_loads(model)`` the force and moment every joint transmits
# (reaction recovery, in the joint's child frame), so a rigid blade's root
# load is the load of its clamp joint. The root stress is the bending
# stress at the outer fibre corner, ``|My| c_z / I_y + |Mz| c_y / I_z``
# (``sigma_max`` without the axial force, which the blades do not keep).
# Here only the in-plane moment Mz acts (the friction and the inertia lie
# in the glass plane). The flexible blade rings after each start and
# reversal, so its peak is higher; its mean level is the rigid blade's.

blade_section = flexible_model["right_blade"].section
rigid_joint_loads = rigid.joint_loads(rigid_model)
flexible_joint_loads = flexible.joint_loads(flexible_system)
root_stress = {}
for side in ("right", "left"):
    _, M = rigid_joint_loads.joint(f"{side}_clamp")
    rigid_root = (np.abs(M[:, 1]) * blade_section.c_z / blade_section.Iy
                  + np.abs(M[:, 2]) * blade_section.c_y / blade_section.Iz)
    blade = flexible_model[f"{side}_blade"]
    flexible_root = flexible.section_stresses(blade).component("sigma_max")[:, 0]
    root_stress[side] = (rigid_root, flexible_root)
    rms = [np.sqrt(np.mean(v**2)) / 1e6 for v in (rigid_root, flexible_root)]
    print(f"{side} blade root stress: rigid peak {rigid_root.max() / 1e6:.2f} MPa at t = "
          f"{rigid.t[rigid_root.argmax()]:.3f} s, rms {rms[0]:.2f} MPa; flexible peak "
          f"{flexible_root.max() / 1e6:.2f} MPa at t = {flexible.t[flexible_root.argmax()]:.3f} s, "
          f"rms {rms[1]:.2f} MPa")
rigid_root_stress_peak = root_stress["right"][0].max()
root_stress_rms_ratio = np.sqrt(np.mean(root_stress["right"][1] ** 2) / np.mean(root_stress["right"][0] ** 2))
# the load path: the flexible blade's clamp joint carries exactly its root segment joint's spring moments
_, clamp_moment = flexible_joint_loads.joint("right_clamp")
spring_moment = flexible.section_loads(flexible_model["right_blade"]).values[:, 0]
clamp_vs_springs = np.abs(clamp_moment[:, 1:] - spring_moment).max() / np.abs(spring_moment).max()
print(f"flexible right blade: clamp joint moment (reaction recovery) - root spring moment: {clamp_vs_springs:.1e} "
      "relative")

# %%
# Plot
# ----
# Tip displacement from the start and tip speed against time (the paper's
# Figs. 5 and 6), the crank torque, and how far the flexible tip is from
# the rigid one.

if __name__ == "__main__":
    import os

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed (pip install -e '.[viz]'): no plot")
    else:
        fig, ax = plt.subplots(4, 1, figsize=(7, 11), sharex=True)
        for label, res, tips, speed, style in (("rigid", rigid, rigid_tips, rigid_speed, "-"),
                                               ("flexible", flexible, flexible_tips, flexible_speed, "--")):
            for side, color in (("right", "C0"), ("left", "C1")):
                p = tips[side][0]
                ax[0].plot(res.t, np.linalg.norm(p - p[0], axis=1), style, color=color, label=f"{side}, {label}")
                ax[1].plot(res.t, speed[side], style, color=color, label=f"{side}, {label}")
            ax[2].plot(res.t, res.driver_effort("motor"), style, color="C2", label=f"{label} blades")
        for side, color in (("right", "C0"), ("left", "C1")):
            gap = np.linalg.norm(flexible_tips[side][0] - rigid_tips[side][0], axis=1)
            ax[3].plot(flexible.t, 1e3 * gap, color=color, label=side)
        ax[0].set_ylabel("tip displacement [m]")
        ax[1].set_ylabel("tip speed [m/s]")
        ax[2].set_ylabel("crank torque [N m]")
        ax[3].set_ylabel("flexible - rigid tip [mm]")
        ax[3].set_xlabel("t [s]")
        for a in ax:
            a.legend(fontsize=8)
            a.grid(alpha=0.3)
        fig.suptitle("Windshield wiper at 60 rpm: rigid vs flexible blades (cf. Figs. 5-6)")
        fig.tight_layout()
        os.makedirs("results", exist_ok=True)
        fig.savefig(os.path.join("results", "04_wiper.png"), dpi=120)
        print("wrote results/04_wiper.png")
        from flexmb import viz

        stresses_right = flexible.section_stresses(flexible_model["right_blade"])
        viz.plot_envelope(stresses_right, os.path.join("results", "04_wiper_blade_envelope.png"))
        viz.plot_station(stresses_right, os.path.join("results", "04_wiper_blade_root.png"), components="sigma_max")
        print("wrote results/04_wiper_blade_envelope.png, results/04_wiper_blade_root.png")
