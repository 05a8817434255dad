"""
Velocity constraints: the Whipple bicycle, a rolling disc, your own constraint
==============================================================================

Kane's method treats "holonomic and simple non-holonomic systems without
introducing undetermined multipliers": the orthogonal complement that
removes the loop rows removes velocity rows ``B(x, t) xd = b`` too
(``docs/constraints.md``). Three uses of it.

1. The benchmark Whipple bicycle of Meijaard, Papadopoulos, Ruina and Schwab
   (2007): four rigid bodies, two wheels rolling without slipping
   (:class:`flexmb.RollingDisc`: a contact row and two no-slip velocity rows
   each), three independent speeds. Its linear model about upright, straight
   running (:func:`flexmb.linearize_steady`) gives the eigenvalues of the
   lean and steer motion against the forward speed. They match the paper's
   Table 2 to about 5e-11 relative. The weave speed (4.2924 m/s: the
   oscillatory pair turns stable) and the capsize speed (6.0243 m/s: the
   slow lean mode turns unstable) match to about 1e-12. Between them the
   bicycle is self-stable. The built-in scene ``flexmb run bicycle``,
   pushed at 4.6 m/s, stays upright: its lean falls from 0.116 rad to
   below 0.02 rad within 5 s.
2. A thin disc rolling on the floor, on a ``yaw_lean_pitch`` joint (x, y,
   z, heading, lean, spin). Started with the spin the classical
   steady-motion condition gives for a lean of 0.2 rad and a heading rate
   of 3 rad/s, it keeps lean, heading rate and spin (to 5e-13 over 2 s). Upright, its
   linear model has the lean eigenvalues ``+-sqrt((4/5)(g/r - 3 s^2))``
   (to 1e-8): it falls below the critical spin ``s = sqrt(g / 3 r)`` and
   wobbles above it.
3. A constraint element of your own: a gear pair ``q1 = n q2`` written as a
   :class:`flexmb.ConstraintElement` (one position row), installed the
   way ``docs/plugins.md`` says (an entry point in the group
   ``flexmb.constraints``) and used from a scene file by name. The angles
   keep the ratio to 1e-14 rad, and the spring-loaded train swings at
   ``sqrt(k / (I1 + I2 / n^2))``, the reflected inertia (to 1.3e-10 rad).

Run as a script, it saves the bicycle's eigenvalues against speed with the
published values, and its lean and steer after the push, in
``results/12_velocity_constraints_*.png``.
"""

import os
import shutil
import sys
import tempfile
import textwrap

import numpy as np

import flexmb as fm
from flexmb import registry
from flexmb.scene import load_builtin
from flexmb.scenes.bicycle import benchmark_bicycle, upright_eigenvalues, weave_and_capsize_speeds

# %%
# Part 1: the Whipple bicycle
# ---------------------------
# :func:`flexmb.scenes.bicycle.benchmark_bicycle` builds the paper's Table 1
# bicycle: the rear frame (with the rider) on a ``yaw_lean_pitch`` joint,
# the front frame on the steer axis tilted back by pi/10, the two wheels on
# revolutes, each wheel a :class:`flexmb.RollingDisc`. Nine coordinates; six
# rows, four of them velocity rows, leave three independent speeds (lean,
# steer and forward speed), and a position that can reach anywhere on the
# floor.
bicycle = benchmark_bicycle().build()
print(f"{bicycle.n_coords} coordinates, {bicycle.dof()} independent speeds, rows: "
      f"{', '.join(bicycle.constraints.labels)}")

# %%
# The paper's Table 2: per speed (m/s) the castering eigenvalue, the weave
# pair (real, imaginary) and the capsize eigenvalue (1/s), computed there
# from independently derived equations (given to 14 digits).
TABLE2 = {
    1: (-7.11008014637442, (3.52696170990070, 0.80774027519930), -3.13423125066578),
    2: (-8.67387984831735, (2.68234517512745, 1.68066296590675), -3.07158645641514),
    3: (-10.35101467245920, (1.70675605663975, 2.31582447384325), -2.63366137253667),
    4: (-12.15861426576450, (0.41325331521125, 3.07910818603206), -1.42944427361326),
    5: (-14.07838969279820, (-0.77534188219585, 4.46486771378823), -0.32286642900409),
    6: (-16.08537123098030, (-1.52644486584142, 5.87673060598709), -0.00406690076970),
    7: (-18.15788466125262, (-2.13875644258362, 7.19525913329805), 0.10268170574766),
    8: (-20.27940894394569, (-2.69348683581097, 8.46037971396931), 0.14327879765713),
    9: (-22.43788559040858, (-3.21675402252485, 9.69377351531791), 0.15790184030917),
    10: (-24.62459635017404, (-3.72016840437287, 10.90681139476287), 0.16105338653172),
}
PUBLISHED_WEAVE, PUBLISHED_CAPSIZE = 4.29238253634111, 6.02426201538837


def published(v):
    """Table 2's four eigenvalues at speed v."""
    cast, (re, im), cap = TABLE2[v]
    return np.array([cast, complex(re, -im), complex(re, im), cap])


# %%
# :func:`~flexmb.scenes.bicycle.upright_eigenvalues` linearises about
# upright, straight running at speed v (:func:`flexmb.linearize_steady`, the
# position, heading and wheel angles ignorable) and returns the four
# eigenvalues of the lean and steer motion.
table_error = 0.0
for v in TABLE2:
    got = np.sort_complex(upright_eigenvalues(bicycle, float(v)))
    want = np.sort_complex(published(v))
    table_error = max(table_error, float(np.max(np.abs(got - want) / np.abs(want))))
print(f"eigenvalues at v = 1 ... 10 m/s against Table 2: largest relative difference {table_error:.1e}")

# %%
# The self-stable speed range. On a grid of speeds, the bicycle is stable
# where every eigenvalue has a negative real part. The range's ends are the
# weave speed (the oscillatory pair crosses the imaginary axis) and the
# capsize speed (the real capsize eigenvalue crosses 0), found by Brent's
# method on the eigenvalues.
speeds = np.linspace(0.0, 10.0, 101)
eigenvalues = np.array([upright_eigenvalues(bicycle, v) for v in speeds])
stable = np.max(eigenvalues.real, axis=1) < 0
print(f"stable on the grid from {speeds[stable].min():.1f} to {speeds[stable].max():.1f} m/s")
weave, capsize = weave_and_capsize_speeds(bicycle)
weave_error = abs(weave - PUBLISHED_WEAVE) / PUBLISHED_WEAVE
capsize_error = abs(capsize - PUBLISHED_CAPSIZE) / PUBLISHED_CAPSIZE
print(f"self-stable between the weave speed {weave:.10f} m/s (published {PUBLISHED_WEAVE}, {weave_error:.0e}) "
      f"and the capsize speed {capsize:.10f} m/s (published {PUBLISHED_CAPSIZE}, {capsize_error:.0e})")

# %%
# The nonlinear bicycle: the built-in scene ``flexmb run bicycle`` is a
# scene file (``flexmb/scene/builtin/bicycle.toml``) holding the same model,
# started upright at 4.6 m/s with a sideways push (a lean rate of
# 0.5 rad/s; the other speeds follow from the rolling rows). 4.6 m/s lies in
# the self-stable range: the lean and steer die out, with no rider's
# control. Rolling without slipping does no work, so the energy stays.
scene = load_builtin("bicycle")
ride = scene.simulate()
lean = ride.coordinate("frame.lean")
lean_first = float(np.max(np.abs(lean[ride.t <= 1.0])))
lean_last = float(np.max(np.abs(lean[ride.t >= 4.0])))
energy_drift = float(np.ptp(ride.energy) / ride.energy[0])
print(f"pushed at 4.6 m/s: largest lean {lean_first:.3f} rad in the first second, {lean_last:.4f} rad after "
      f"4 s; energy constant to {energy_drift:.0e}")

# %%
# Part 2: a rolling disc
# ----------------------
# A thin uniform disc of radius r on the floor. Its frame sits at its
# centre with its axis along the body y. The ``yaw_lean_pitch`` joint gives
# it the centre's x, y, z, then the heading (about z), the lean (about the
# new x) and the spin (the pitch, about the disc's axis). One
# :class:`flexmb.RollingDisc` adds the contact row (the lowest rim point on
# the floor) and the two no-slip rows.
G, R, M = 9.81, 0.3, 1.2
YawLeanPitch = registry.get("joints", "yaw_lean_pitch")


def disc_model():
    model = fm.Model("disc")
    disc = fm.RigidBody("disc", M, (M * R**2 / 4, M * R**2 / 2, M * R**2 / 4))
    return model.add(YawLeanPitch("disc_joint", model.ground, disc), fm.RollingDisc("roll", disc, R, axis=(0, 1, 0)),
                     fm.Gravity((0.0, 0.0, -G)))


disc = disc_model().build()
print(f"the disc: {disc.n_coords} coordinates, {disc.dof()} independent speeds")

# %%
# Steady precession. Leaning at theta with the heading turning at Omega,
# the disc rolls steadily on a circle when its angular velocity along the
# axis, ``w3 = Omega sin(theta) + phi'``, satisfies the classical condition
# (the moment of momentum about the centre with ``I_a = m r^2 / 2``,
# ``I_d = m r^2 / 4``, and Newton's law for the centre)
#
#     (I_a + m r^2) w3 Omega cos(theta) - I_d Omega^2 sin(theta) cos(theta) + m g r sin(theta) = 0.
#
# Given the lean (held while the contact row sets the height) and the
# three independent speeds, the initial state follows; the run keeps them.
theta, Omega = 0.2, 3.0
Ia, Id = M * R**2 / 2, M * R**2 / 4
w3 = (Id * Omega**2 * np.sin(theta) * np.cos(theta) - M * G * R * np.sin(theta)) / ((Ia + M * R**2) * Omega
                                                                                     * np.cos(theta))
spin = w3 - Omega * np.sin(theta)
steady = fm.simulate(disc, 2.0, positions={"disc_joint.z": R, "disc_joint.lean": theta},
                     speeds={"disc_joint.yaw": Omega, "disc_joint.lean": 0.0, "disc_joint.pitch": spin},
                     fixed=["disc_joint.lean"], rtol=1e-10, atol=1e-12, n_out=101)
steady_error = max(float(np.max(np.abs(steady.coordinate("disc_joint.lean") - theta))),
                   float(np.max(np.abs(steady.xd[:, steady.coordinate_names.index("disc_joint.yaw")] - Omega))),
                   float(np.max(np.abs(steady.xd[:, steady.coordinate_names.index("disc_joint.pitch")] - spin))))
print(f"steady precession at theta = {theta}, Omega = {Omega} rad/s (spin {spin:.4f} rad/s): lean, heading "
      f"rate and spin held to {steady_error:.1e} over 2 s")

# %%
# The angular velocity in the user's terms: ``Result.angular_velocity``
# gives it per body (inertial or body axes), as a scene's
# ``angular_velocity:BODY`` output and the VTK's cell data do. Along the
# disc's axis it is w3.
w_body = steady.angular_velocity("disc", frame="body")
print(f"angular velocity along the axis: {w_body[:, 1].min():.6f} ... {w_body[:, 1].max():.6f} rad/s "
      f"(w3 = {w3:.6f})")

# %%
# Upright rolling and its critical spin. About upright rolling at spin s
# (the position, heading and spin ignorable), Euler's equations give the
# lean equation ``theta'' = (4/5)(g/r - 3 s^2) theta`` once the heading
# rate is eliminated: eigenvalues ``+-sqrt((4/5)(g/r - 3 s^2))``, real (a
# fall) below the critical spin ``s = sqrt(g / 3 r)``, imaginary (a wobble)
# above.
critical = np.sqrt(G / (3 * R))
print(f"critical spin sqrt(g / 3 r) = {critical:.4f} rad/s")
disc_error = 0.0
for s in (0.5 * critical, 2.0 * critical):
    x0, xd0 = fm.initial_state(disc, positions={"disc_joint.z": R}, fixed=["disc_joint.lean"],
                               speeds={"disc_joint.yaw": 0.0, "disc_joint.lean": 0.0, "disc_joint.pitch": s})
    lin = fm.linearize_steady(disc, x0, xd0, ignorable=["disc_joint.x", "disc_joint.y", "disc_joint.yaw",
                                                        "disc_joint.pitch"])
    ev = lin.eigenvalues()
    pair = np.sort_complex(ev[np.abs(ev) > 1e-6])
    root = np.sqrt(complex(0.8 * (G / R - 3 * s**2)))
    disc_error = max(disc_error, float(np.max(np.abs(pair - np.sort_complex(np.array([-root, root]))))
                                       / abs(root)))
    print(f"spin {s:6.3f} rad/s: lean eigenvalues {pair[0]:.6f}, {pair[1]:.6f} (closed form +-{root:.6f})")

# %%
# Part 3: a constraint element of your own
# ----------------------------------------
# A gear pair ``q1 = n q2`` between two joints' first coordinates is one
# position row: ``phi = q1 - n q2``, its Jacobian ``psi`` (1 at q1, -n at
# q2), ``b = 0`` and ``gamma = 0`` (psi is constant). A constraint element
# is an attrs class with a name, its data as fields (joints by
# ``fm.reference``, so that a scene can name them), ``n_position`` and a
# ``rows(state)`` method (``docs/plugins.md``, "Constraint elements"). This
# is the plugin's module, ``tutorial_gears.py``:
PLUGIN = textwrap.dedent('''
    import numpy as np
    from attrs import field, frozen

    import flexmb as fm
    from flexmb.fields import as_float, finite_number


    @frozen(eq=False)
    class UserGearPair(fm.ConstraintElement):
        """q1 = n q2 between two joints' first coordinates: one position row."""

        joint1: fm.Joint = fm.reference(fm.Joint)
        joint2: fm.Joint = fm.reference(fm.Joint)
        n: float = field(default=-1.0, converter=as_float, validator=finite_number)

        n_position = 1

        def row_names(self):
            return ["mesh"]

        def rows(self, state):
            i = state.coordinate_slice(self.joint1).start
            j = state.coordinate_slice(self.joint2).start
            psi = np.zeros((1, state.xd.shape[0]))  # a row per constraint, a column per speed
            psi[0, i], psi[0, j] = 1.0, -self.n
            return np.array([state.x[i] - self.n * state.x[j]]), psi, np.zeros(1), np.zeros(1)
''')

# %%
# Installed with ``pip``, the plugin's ``pyproject.toml`` declares it as an
# entry point::
#
#     [project.entry-points."flexmb.constraints"]
#     user_gear_pair = "tutorial_gears:UserGearPair"
#
# and pip writes that into the installed distribution's metadata
# (``*.dist-info/entry_points.txt``), where flexmb's registry finds it.
# Here the same is done by hand in a temporary folder put on the path (what
# ``pip install`` would write into site-packages), so that the tutorial
# leaves nothing installed.
site = tempfile.mkdtemp(prefix="flexmb_tutorial_")
with open(os.path.join(site, "tutorial_gears.py"), "w", encoding="utf-8") as f:
    f.write(PLUGIN)
info = os.path.join(site, "tutorial_gears-1.0.dist-info")
os.makedirs(info)
with open(os.path.join(info, "METADATA"), "w", encoding="utf-8") as f:
    f.write("Metadata-Version: 2.1\nName: tutorial-gears\nVersion: 1.0\n")
with open(os.path.join(info, "entry_points.txt"), "w", encoding="utf-8") as f:
    f.write("[flexmb.constraints]\nuser_gear_pair = tutorial_gears:UserGearPair\n")
sys.path.insert(0, site)
registry.refresh()  # entry points are read once per session: read them again
origin = {p.name: p.origin for p in fm.plugins("constraints")}["user_gear_pair"]
print(f"constraint plugins: {', '.join(registry.names('constraints'))}; user_gear_pair from {origin}")

# %%
# Used from a scene file by its plugin name, as any built-in: two wheels on
# shafts geared 3 : 1 (``n = -3``: they turn opposite ways), a torsion
# spring on the first shaft, released from 0.4 rad.
I1, I2, K, N = 0.02, 0.5, 40.0, -3.0
SCENE = f"""
[model]
name = "gear train"

[bodies.wheel1]
mass = 1.0
inertia = [{I1}, {I1}, {I1}]
[bodies.wheel2]
mass = 1.0
inertia = [{I2}, {I2}, {I2}]

[joints.shaft1]
type = "revolute"
parent = "ground"
child = "wheel1"
[joints.shaft2]
type = "revolute"
parent = "ground"
child = "wheel2"

[forces.spring]
type = "joint_spring_damper"
joint = "shaft1"
stiffness = {K}

[constraints.mesh]
type = "user_gear_pair"
joint1 = "shaft1"
joint2 = "shaft2"
n = {N}

[initial]
positions = {{ shaft1 = 0.4 }}
fixed = ["shaft1"]

[solver]
t_end = 2.0
rtol = 1e-10
atol = 1e-12
n_out = 41
"""
gears = fm.loads_scene(SCENE)
train = gears.simulate()
q1, q2 = train.coordinate("shaft1.angle"), train.coordinate("shaft2.angle")
ratio_error = float(np.max(np.abs(q1 - N * q2)))
# the train swings at the first shaft's reflected inertia: T = (I1 + I2 / n^2) q1'^2 / 2
w = np.sqrt(K / (I1 + I2 / N**2))
swing_error = float(np.max(np.abs(q1 - 0.4 * np.cos(w * train.t))))
print(f"element {type(gears.model.element('mesh')).__name__} ({train.constraint_labels[0]}): q1 - n q2 within "
      f"{ratio_error:.1e} rad; q1 = 0.4 cos({w:.4f} t) to {swing_error:.1e} rad")

# a plugin installed for good would stay; this one leaves with its folder (the gallery may have reset the path)
sys.path[:] = [p for p in sys.path if p != site]
shutil.rmtree(site)
sys.modules.pop("tutorial_gears", None)
registry.refresh()

if __name__ == "__main__":
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed (pip install -e '.[viz]'): no plot")
    else:
        os.makedirs("results", exist_ok=True)
        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10.0, 4.0))
        for ax, part, label in ((ax1, np.real, "real part"), (ax2, np.imag, "imaginary part")):
            ax.plot(speeds, part(eigenvalues), ".", ms=2.5, color="C0")
            table = np.array([published(v) for v in TABLE2])
            ax.plot(list(TABLE2), part(table), "o", mfc="none", color="C3", ms=6)
            ax.set_xlabel("forward speed v (m/s)")
            ax.set_ylabel(f"eigenvalue, {label} (1/s)")
            ax.grid(True, alpha=0.3)
        ax1.axvspan(weave, capsize, color="C2", alpha=0.15, label="self-stable")
        ax1.set_ylim(-10, 10)
        ax1.plot([], [], ".", color="C0", label="flexmb")
        ax1.plot([], [], "o", mfc="none", color="C3", label="Meijaard et al. (2007), Table 2")
        ax1.legend(fontsize="small", loc="upper right")
        fig.suptitle("The benchmark bicycle: lean and steer eigenvalues against speed")
        fig.tight_layout()
        fig.savefig(os.path.join("results", "12_velocity_constraints_bicycle.png"), dpi=120)

        fig, ax = plt.subplots(figsize=(7.0, 3.5))
        ax.plot(ride.t, lean, label="lean (rad)")
        ax.plot(ride.t, ride.coordinate("steer.angle"), label="steer (rad)")
        ax.set_xlabel("t (s)")
        ax.set_title("flexmb run bicycle: pushed at 4.6 m/s, it rights itself")
        ax.legend(fontsize="small")
        ax.grid(True, alpha=0.3)
        fig.tight_layout()
        fig.savefig(os.path.join("results", "12_velocity_constraints_push.png"), dpi=120)
        plt.show()
