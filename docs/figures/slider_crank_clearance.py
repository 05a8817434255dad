"""Write ``docs/figures/slider_crank_clearance.png``: Flores and Ambrosio's (2004) slider-crank with a clearance.

The data of P. Flores and J. Ambrosio, "Revolute joints with clearance in
multibody systems", Computers & Structures 82 (2004) 1359-1369: crank
0.05 m (0.30 kg, 1e-5 kg m^2) driven at 5000 rpm, connecting rod 0.12 m
(0.21 kg, 2.5e-4 kg m^2), slider 0.14 kg (1e-4 kg m^2); the joint between
the rod and the slider has a radial clearance of 0.5 mm (journal 10 mm,
bearing 10.5 mm), steel on steel (E = 207 GPa, nu = 0.3), the
Lankarani-Nikravesh law with e = 0.9 and Hertz's stiffness of two
cylinders in internal contact, no friction, gravity along -y. The run
starts at crank angle 0 with the journal centred and the ideal mechanism's
speeds; the figure shows the third and fourth crank turns (the first two
settle the start).

Left: the slider's acceleration against the crank angle, with the ideal
joint's closed form (:func:`ideal_acceleration`); right: the journal's centre relative to the bearing's, in
units of the clearance (the circle: the bearing's wall). Printed: the
peaks of the slider acceleration and of the contact force, at three
tolerances (the figure: the tightest). Run from the repository::

    python docs/figures/slider_crank_clearance.py
"""

import sys
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")

from matplotlib.figure import Figure  # noqa: E402

import flexmb as fm  # noqa: E402

HERE = Path(__file__).resolve().parent

CRANK, ROD = 0.05, 0.12
OMEGA = 5000.0 * 2.0 * np.pi / 60.0
R_JOURNAL, R_BEARING = 0.0100, 0.0105
YOUNG, POISSON = 207e9, 0.3
RESTITUTION = 0.9
TURN = 2.0 * np.pi / OMEGA


def stiffness():
    """Hertz's stiffness of two steel cylinders in internal contact (Flores and Ambrosio's K), N/m^1.5."""
    s = (1.0 - POISSON ** 2) / YOUNG
    return 4.0 / (3.0 * 2.0 * s) * np.sqrt(R_JOURNAL * R_BEARING / (R_BEARING - R_JOURNAL))


def model():
    m = fm.Model()
    crank = fm.RigidBody("crank", 0.30, np.diag([1e-5] * 3), com=(CRANK / 2, 0, 0))
    rod = fm.RigidBody("rod", 0.21, np.diag([2.5e-4] * 3), com=(ROD / 2, 0, 0))
    slider = fm.RigidBody("slider", 0.14, np.diag([1e-4] * 3))
    pivot = fm.Revolute("pivot", m.ground, crank)
    m.add(pivot, fm.Revolute("crankpin", crank, rod, parent_point=(CRANK, 0, 0)),
          fm.Prismatic("guide", m.ground, slider, axis=(1, 0, 0)),
          fm.Driver.constant_speed("motor", pivot, OMEGA), fm.Gravity((0, -9.81, 0)),
          fm.JournalBearingContact("gap", rod, R_JOURNAL, slider, R_BEARING,
                                   fm.LankaraniNikraveshLaw(stiffness(), RESTITUTION), pin_centre=(ROD, 0, 0)))
    return m


def ideal_acceleration(q):
    """The ideal slider-crank's slider acceleration at crank angle q (constant crank speed), m/s^2."""
    lam = CRANK / ROD
    root = np.sqrt(1.0 - lam ** 2 * np.sin(q) ** 2)
    return -CRANK * OMEGA ** 2 * (np.cos(q) + lam * np.cos(2 * q) / root
                                  + lam ** 3 * np.sin(2 * q) ** 2 / (4.0 * root ** 3))


def run(rtol, turns=4):
    mdl = model()
    system = mdl.build()
    x0, xd0 = np.zeros(3), np.zeros(3)
    at = {j: system.coordinate_slice(j).start for j in ("pivot", "crankpin", "guide")}
    x0[at["guide"]] = CRANK + ROD
    xd0[at["pivot"]] = OMEGA
    xd0[at["crankpin"]] = -CRANK * OMEGA / ROD - OMEGA
    t_eval = np.linspace((turns - 2) * TURN, turns * TURN, 4001)
    res = fm.simulate(system, turns * TURN, x0=x0, xd0=xd0, t_eval=t_eval, method="DOP853", rtol=rtol,
                      atol=rtol * 1e-3, max_step=1e-5, progress=False)
    accel = res.point_acceleration("slider")[:, 0]
    ecc = (res.point_position("rod", (ROD, 0, 0)) - res.point_position("slider"))[:, :2]
    force = res.contact_history("gap").normal_force
    angle = np.degrees(OMEGA * res.t) - 360.0 * (turns - 2)
    return angle, accel, ecc, force, res


def main():
    rows = []
    for rtol in (1e-6, 1e-8, 1e-10):
        angle, accel, ecc, force, res = run(rtol)
        rows.append((rtol, accel.max(), accel.min(), force.max(), np.abs(ecc).max() / (R_BEARING - R_JOURNAL),
                     res.n_steps))
        print(f"rtol {rtol:.0e}: slider acceleration max {accel.max():.4g}, min {accel.min():.4g} m/s^2; "
              f"contact force max {force.max():.4g} N; steps {res.n_steps}")
    ideal = ideal_acceleration(np.radians(angle))
    print(f"ideal joint: slider acceleration max {ideal.max():.4g}, min {ideal.min():.4g} m/s^2")

    fig = Figure(figsize=(11.0, 4.4))
    left, right = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.6, 1.0]})
    left.plot(angle, accel / 1e3, lw=0.7, label="clearance 0.5 mm (flexmb)")
    left.plot(angle, ideal / 1e3, "k--", lw=1.0, label="ideal joint (closed form)")
    left.set_xlabel("crank angle, degrees (third and fourth turns)")
    left.set_ylabel("slider acceleration, 10$^3$ m/s$^2$")
    left.set_xlim(0, 720)
    left.legend(loc="upper right", fontsize=8)
    c = R_BEARING - R_JOURNAL
    phi = np.linspace(0, 2 * np.pi, 361)
    right.plot(np.cos(phi), np.sin(phi), "k-", lw=0.8)
    right.plot(ecc[:, 0] / c, ecc[:, 1] / c, lw=0.7)
    right.set_aspect("equal")
    right.set_xlabel("journal centre x / clearance")
    right.set_ylabel("journal centre y / clearance")
    right.set_title("journal orbit in the bearing", fontsize=9)
    fig.tight_layout()
    out = HERE / "slider_crank_clearance.png"
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")
    return rows


if __name__ == "__main__":
    sys.exit(main() and 0)
