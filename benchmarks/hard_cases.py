"""Hard cases of docs/stability.md: runs the scenes of tests/test_hard_cases.py and draws the figures.

Writes ``docs/figures/hard_*.png`` and prints the numbers quoted on the page;
``--long`` adds the 100 s four-bar run (a few minutes).

Run: ``python benchmarks/hard_cases.py [--long]`` (needs matplotlib).
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import flexmb as fm  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "tests"))  # the scenes are those the tests check
sys.path.insert(0, os.path.join(ROOT, "plugins"))
from conftest import fourbar, fourbar_initial  # noqa: E402
from test_hard_cases import (PARA_TH0, PARA_W, SS_M, G_ACC, bricard, energy_drift, heavy_top,  # noqa: E402
                             parallelogram, stick_slip_block, stick_slip_reference, stiff_pendulum)

FIG = os.path.join(ROOT, "docs", "figures")


def save(fig, name):
    fig.tight_layout()
    path = os.path.join(FIG, name)
    from flexmb._files import atomic_write

    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=110), suffix=".png")
    plt.close(fig)
    print(f"  wrote {os.path.relpath(path, ROOT)}")


def rel_energy(res):
    e = res.energy
    return np.abs(e - e[0]) / max(np.abs(res.kinetic).max(), np.abs(res.potential).max())


def redundant():
    print("1. Bricard linkage (Grubler 0, mobility 1), 10 s, DOP853 rtol 1e-10")
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.6))
    for comp, style in (("svd", "-"), ("eigen", "--")):
        system = bricard().build(complement=comp)
        res = fm.simulate(system, 10.0, rtol=1e-10, n_out=1001, method="DOP853")
        print(f"  {comp:5s}: dof {res.n_dof}, max residual {res.residual.max():.2e} m, energy drift "
              f"{energy_drift(res):.2e}, steps {res.n_steps}, projections {res.n_projections}")
        if comp == "svd":
            for j in ("R0", "R1", "R5"):
                ax[0].plot(res.t, res.coordinate(j), style, label=j)
        ax[1].semilogy(res.t, np.maximum(res.residual, 1e-17), style, label=f"residual |phi| ({comp})")
        ax[1].semilogy(res.t, np.maximum(rel_energy(res), 1e-17), style, label=f"energy drift ({comp})")
    ax[0].set(xlabel="t (s)", ylabel="joint angle (rad)", title="Bricard: R0 = R2, R1 = R3 = -R5 (R4 cut)")
    ax[0].legend()
    ax[1].set(xlabel="t (s)", title="loop residual (m) and relative energy drift")
    ax[1].legend(fontsize=7)
    save(fig, "hard_bricard.png")


def singular():
    print("2. Parallelogram through its flattened positions, 3 s (6 passes), no gravity")
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.6))
    start = dict(positions={"A": PARA_TH0, "B": -PARA_TH0, "D": PARA_TH0}, speeds={"A": PARA_W}, fixed=["A"],
                 rtol=1e-10, n_out=601, method="DOP853")
    for label, strategy in (("svd, default (singular_window = 0.1)", fm.SVDComplement()),
                            ("svd, singular_rtol = 1e-2", fm.SVDComplement(singular_rtol=1e-2)),
                            ("svd, filter off (singular_window = 0)", fm.SVDComplement(singular_window=0.0))):
        res = fm.simulate(parallelogram().build(complement=strategy), 3.0, **start)
        A, B = res.coordinate("A"), res.coordinate("B")
        err = A - (PARA_TH0 + PARA_W * res.t)
        print(f"  {label}: crank error {np.abs(err).max():.2e} rad, coupler angle {np.abs(A + B).max():.2e} rad,"
              f" residual {res.residual.max():.2e}, drift {energy_drift(res):.2e}, steps {res.n_steps}")
        ax[0].plot(res.t, err, label=label)
        ax[1].plot(res.t, A + B, label=label)
    for a in ax:
        for k in range(1, 7):
            a.axvline((k * np.pi - PARA_TH0) / PARA_W, color="0.85", lw=0.8, zorder=0)
    ax[0].set(xlabel="t (s)", ylabel="crank angle - (th0 + w t) (rad)", title="crank against the closed form")
    ax[1].set(xlabel="t (s)", ylabel="coupler angle (rad)", title="branch: the coupler must stay horizontal")
    ax[0].legend(fontsize=8)
    save(fig, "hard_parallelogram.png")


def stiffness():
    print("3. Stiff segments: pendulum with a clamped strip, E = 1e9 ... 1e13 Pa, Radau rtol 1e-6, 0.5 s")
    Es = [1e9, 1e10, 1e11, 1e12, 1e13]
    steps, rhs, omega, pin = [], [], [], []
    for E in Es:
        system = stiff_pendulum(E).build()
        w = system.highest_frequency(0.0, np.zeros(system.n_coords), np.zeros(system.n_coords))
        res = fm.simulate(system, 0.5, method="Radau", rtol=1e-6, n_out=51)
        steps.append(res.n_steps), rhs.append(res.n_rhs), omega.append(w), pin.append(res.coordinate("pin")[-1])
        print(f"  E = {E:.0e}: omega_max {w:8.1f} rad/s, Radau steps {res.n_steps:4d}, rhs {res.n_rhs:5d}, "
              f"jac {res.n_jac:2d}, explicit bound ~ {0.5 * w / 3:7.0f} steps, pin(0.5 s) {pin[-1]:.6f} rad")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warnings.simplefilter("error", fm.StiffnessWarning)
        try:
            fm.simulate(stiff_pendulum(1e13), 10.0, method="RK45")
        except fm.StiffnessWarning as w:
            print(f"  RK45 on E = 1e13 over 10 s: StiffnessWarning: {w}")
    del caught
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.6))
    ax[0].loglog(Es, steps, "o-", label="Radau steps (measured)")
    ax[0].loglog(Es, 0.5 * np.array(omega) / 3, "s--", label="explicit stability bound, t w_max / 3")
    ax[0].set(xlabel="E (Pa)", ylabel="steps over 0.5 s", title="cost against stiffness")
    ax[0].legend(fontsize=8)
    ax[1].loglog(Es[:-1], np.abs(np.array(pin[:-1]) - pin[-1]), "o-")
    ax[1].set(xlabel="E (Pa)", ylabel="|pin(E) - pin(1e13)| at 0.5 s (rad)", title="convergence to the rigid limit")
    save(fig, "hard_stiffness.png")


def friction():
    print("4. Stick-slip: block, Coulomb mu = 0.3, F = 2 Fc sin(2 pi t), Radau rtol 1e-6, 3 s")
    import flexmb_friction as fr

    t = np.linspace(0.0, 3.0, 601)
    ref, phases = stick_slip_reference(t)
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.6))
    ax[0].plot(t, ref, "k", lw=3, alpha=0.3, label="exact (ideal Coulomb)")
    for eps in (1e-2, 1e-3, 1e-4, 1e-5, 1e-6):
        res = fm.simulate(stick_slip_block(fr, eps), 3.0, t_eval=t, method="Radau", rtol=1e-6)
        err = np.abs(res.coordinate("slide") - ref).max()
        print(f"  smoothing speed {eps:.0e} m/s: steps {res.n_steps:4d}, rhs {res.n_rhs:5d}, "
              f"max |x - x_exact| {err:.2e} m")
        if eps in (1e-2, 1e-5):
            ax[0].plot(t, res.coordinate("slide"), "--", label=f"flexmb, e = {eps:g} m/s")
            ax[1].plot(t, res.xd[:, 0], label=f"e = {eps:g} m/s")
    print(f"  {len(phases)} stick phases; mass {SS_M} kg, g = {G_ACC}")
    ax[0].set(xlabel="t (s)", ylabel="x (m)", title="stick-slip against the exact solution")
    ax[0].legend(fontsize=8)
    ax[1].set(xlabel="t (s)", ylabel="v (m/s)", title="sliding speed (stuck: v = 0 for short spells)")
    ax[1].legend(fontsize=8)
    save(fig, "hard_stick_slip.png")


def gyroscope():
    print("5. Heavy symmetric top spinning at 200 rad/s, tilted 0.3 rad, 10 s, DOP853 rtol 1e-10")
    model, top = heavy_top()
    system = model.build()
    res = fm.simulate(system, 10.0, positions={"pivot.rx": 0.3}, speeds={"pivot.rz": 200.0}, rtol=1e-10,
                      n_out=2001, method="DOP853")
    k = system.index(top)
    axis, Lz = np.empty((len(res.t), 3)), np.empty(len(res.t))
    for i, (ti, x, xd) in enumerate(zip(res.t, res.x, res.xd)):
        kin = system.kinematics(ti, x, xd)
        R = kin.R[k]
        H = R @ np.diag([0.02, 0.02, 0.01]) @ R.T @ kin.omega[k] + np.cross(kin.r[k], kin.v[k])
        axis[i], Lz[i] = R[:, 2], H[2]
    az = np.unwrap(np.arctan2(axis[:, 1], axis[:, 0]))
    rate = np.polyfit(res.t, az, 1)[0]
    print(f"  precession {rate:.5f} rad/s (fast-top m g l / (I3 w3) = {G_ACC * 0.1 / (0.01 * 200):.5f}), "
          f"|dLz|/Lz {np.abs(Lz - Lz[0]).max() / abs(Lz[0]):.2e}, energy drift {energy_drift(res):.2e}, "
          f"steps {res.n_steps}")
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.6))
    ax[0].plot(axis[:, 0], axis[:, 1], lw=0.6)
    ax[0].set(xlabel="axis x", ylabel="axis y", title="symmetry axis seen from above (precession, nutation)",
              aspect="equal")
    ax[1].semilogy(res.t, np.maximum(np.abs(Lz - Lz[0]) / abs(Lz[0]), 1e-17), label="|Lz - Lz0| / Lz0")
    ax[1].semilogy(res.t, np.maximum(rel_energy(res), 1e-17), label="energy drift")
    ax[1].set(xlabel="t (s)", title="conserved quantities")
    ax[1].legend(fontsize=8)
    save(fig, "hard_gyroscope.png")


def long_run():
    print("6. B5 four-bar, 100 s, DOP853 (auto) rtol 1e-10")
    res = fm.simulate(fourbar(), 100.0, positions=fourbar_initial(np.pi / 4), fixed=["A"], rtol=1e-10, n_out=5001)
    print(f"  residual {res.residual.max():.2e} m, energy drift {energy_drift(res):.2e}, steps {res.n_steps}, "
          f"projections {res.n_projections}, wall {res.wall_time:.0f} s")
    fig, ax = plt.subplots(figsize=(6, 3.4))
    ax.semilogy(res.t, np.maximum(res.residual, 1e-17), lw=0.5, label="loop residual (m)")
    ax.semilogy(res.t, np.maximum(rel_energy(res), 1e-17), lw=0.5, label="relative energy drift")
    ax.set(xlabel="t (s)", title="B5 four-bar over 100 s")
    ax.legend(fontsize=8)
    save(fig, "hard_long_run.png")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--long", action="store_true", help="also the 100 s four-bar run")
    parser.add_argument("--only", nargs="*", help="run only these cases (by function name)")
    args = parser.parse_args()
    cases = [redundant, singular, stiffness, friction, gyroscope] + ([long_run] if args.long else [])
    for case in cases:
        if not args.only or case.__name__ in args.only:
            case()


if __name__ == "__main__":
    main()
