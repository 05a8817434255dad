"""The windshield-wiper scene (``flexmb.scenes.wiper``) and ``flexmb run wiper``.

References the tests use, none computed by the scene itself:

* the points printed in the paper's Fig. 3 (``PRINTED_POINTS``): only RJ1
  and SJ5 are corrected;
* the work-energy theorem for ideal joints: the driver's power equals the
  rate of change of the kinetic energy minus the power of the friction
  forces, at every instant (``dKE/dt = sum m v . a + omega . I alpha``,
  from the kinematics and the accelerations);
* the friction law: a force in the glass plane, never doing positive work;
* the flexible blades' stiffness: tips close to the rigid ones;
* the degrees of freedom: 0 with the crank driven and rigid blades, two
  bending angles per segment and blade with flexible ones;
* the plots (``wiper.png``): the exact tip velocity is the limit of
  central differences of the sampled tip positions (second order in the
  output step); with the arms driven alike, flexible minus rigid tip
  position is the blade's own deflection in its clamp frame.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import attrs
import meshio
import numpy as np
import pytest

import flexmb as fm
from flexmb.result import _ARRAYS
from flexmb.post.motion import point_motion
from flexmb.scene import figures
from flexmb.scenes.wiper import POINTS, PRINTED_POINTS, WiperOptions, glass_normal, wiper

T_RIGID = 1.0
T_FLEX = 0.2
DT = 0.002  # output step of both runs, so that their first outputs coincide


def _tips(model, res, length=0.25):
    """Position and velocity of both blade tips at every output, from the kinematics."""
    system = model.build()
    out = {}
    for side in ("right", "left"):
        body = model[f"{side}_blade"]
        p, v = np.zeros((len(res.t), 3)), np.zeros((len(res.t), 3))
        for i, t in enumerate(res.t):
            kin = system.kinematics(t, res.x[i], res.xd[i])
            k, local = kin.locate(body, (length, 0.0, 0.0))
            p[i] = kin.point_position(k, local)
            v[i] = kin.point_velocity(k, p[i])
        out[side] = (p, v)
    return out


def _balance(res):
    """Largest |sum of works - change of kinetic energy| over the run, relative to the largest driver work."""
    work = sum(res.work.values())
    return np.abs(work - (res.kinetic - res.kinetic[0])).max() / np.abs(res.work["driver motor"]).max()


@pytest.fixture(scope="module")
def rigid():
    model, initial = wiper(WiperOptions(flexible=False))
    # a tight tolerance is cheap here (no elastic coordinates) and keeps the dense output between the
    # steps on the constraints to about 1e-9 m
    res = fm.simulate(model, T_RIGID, positions=initial, rtol=1e-8, n_out=round(T_RIGID / DT) + 1,
                      track_work=True)
    return model, initial, res


@pytest.fixture(scope="module")
def flexible():
    model, initial = wiper(WiperOptions(flexible=True, n_segments=2))
    res = fm.simulate(model, T_FLEX, positions=initial, rtol=1e-6, n_out=round(T_FLEX / DT) + 1,
                      track_work=True)
    return model, initial, res


# ----------------------------------------------------------------------------- geometry

def test_printed_points_kept_except_rj1_and_sj5():
    assert set(POINTS) == set(PRINTED_POINTS) == {"RJ1", "SJ2", "UJ3", "RJ4", "SJ5", "UJ6", "RJ7"}
    changed = {k for k in POINTS if tuple(POINTS[k]) != tuple(PRINTED_POINTS[k])}
    assert changed == {"RJ1", "SJ5"}
    # the corrections: a 4 cm crank beyond SJ2, and SJ5 with its leading "1" dropped
    assert np.linalg.norm(np.subtract(POINTS["SJ2"], POINTS["RJ1"])) == pytest.approx(4.0, abs=0.05)
    assert np.linalg.norm(np.subtract(PRINTED_POINTS["SJ2"], PRINTED_POINTS["RJ1"])) > 40.0
    assert tuple(POINTS["SJ5"]) == (1.5, 10.5, 8.4)


def test_points_lie_near_the_glass_plane():
    X = np.array(list(POINTS.values()))  # cm
    n = glass_normal()
    assert np.linalg.norm(n) == pytest.approx(1.0, abs=1e-14) and n[2] > 0
    # the best-fit plane passes through the centroid; its normal is the smallest singular direction
    smallest = np.linalg.svd(X - X.mean(axis=0))[2][2]
    assert abs(abs(smallest @ n) - 1.0) < 1e-12
    distances = (X - X.mean(axis=0)) @ n
    assert np.abs(distances).max() < 2.0


# ----------------------------------------------------------------------------- rigid blades

def test_rigid_model_structure(rigid):
    model, initial, _ = rigid
    system = model.build()
    assert system.n_coords == 9
    assert system.n_constraints == 9
    x0, xd0 = fm.initial_state(system, positions=initial)
    phi = system.constraints.evaluate(system.kinematics(0.0, x0, xd0), level=0).phi
    assert np.abs(phi).max() < 1e-10
    assert system.dof(0.0, x0) == 0
    # without the driver row the mechanism keeps exactly one freedom
    psi = system.constraints.evaluate(system.kinematics(0.0, x0, xd0), level=1).psi
    assert system.strategy.complement(psi[:-1]).p == 1


def test_rigid_kinematic_run(rigid):
    _, _, res = rigid
    assert res.status == "finished"
    assert res.n_dof == 0
    assert res.residual.max() < 1e-8
    assert np.abs(res.coordinate("RJ1") - 2 * np.pi * res.t).max() < 1e-9
    assert 75.0 < np.degrees(np.ptp(res.coordinate("RJ4"))) < 83.0
    assert 62.0 < np.degrees(np.ptp(res.coordinate("RJ7"))) < 70.0


def test_driver_torque_matches_the_power_balance(rigid):
    model, _, res = rigid
    system = model.build()
    frictions = [f for f in model.forces if f.name.endswith("friction")]
    assert len(frictions) == 2
    omega = 2 * np.pi  # 60 rpm
    driver_power = res.driver_effort("motor") * omega
    rate = np.zeros(len(res.t))
    friction_power = np.zeros(len(res.t))
    for i, t in enumerate(res.t):
        kin = system.kinematics(t, res.x[i], res.xd[i])
        a = np.einsum("kin,n->ki", kin.V[:-1], res.xdd[i]) + kin.a_bias[:-1]
        alpha = np.einsum("kin,n->ki", kin.W[:-1], res.xdd[i]) + kin.alpha_bias[:-1]
        I_alpha = np.einsum("kij,kj->ki", kin.inertia_world(), alpha)
        rate[i] = np.sum(kin.mass * np.einsum("ki,ki->k", kin.v[:-1], a)) + np.sum(kin.omega[:-1] * I_alpha)
        friction_power[i] = sum(f.power(kin) for f in frictions)
    scale = np.abs(driver_power).max()
    assert np.abs(driver_power - (rate - friction_power)).max() < 1e-6 * scale
    # integrated: driver work = change of kinetic energy + friction dissipation, at every output
    friction_work = sum(w for k, w in res.work.items() if k != "driver motor")
    gain = res.kinetic - res.kinetic[0] - friction_work
    assert np.abs(res.work["driver motor"] - gain).max() < 1e-6 * np.abs(res.work["driver motor"]).max()
    assert _balance(res) < 1e-6
    assert 0.5 < np.abs(res.driver_effort("motor")).max() < 1.0


def test_tip_friction_lies_in_the_glass_plane_and_dissipates(rigid):
    model, _, res = rigid
    system = model.build()
    n = glass_normal()
    frictions = [f for f in model.forces if f.name.endswith("friction")]
    tips = _tips(model, res)
    powers = np.zeros((len(res.t), 2))
    for i, t in enumerate(res.t):
        kin = system.kinematics(t, res.x[i], res.xd[i])
        for j, f in enumerate(frictions):
            force = f.force(kin)
            assert abs(force @ n) <= 1e-12 * max(np.linalg.norm(force), 1e-300)
            assert np.linalg.norm(force) <= f.normal_load * f.mu_static * (1 + 1e-12)
            powers[i, j] = f.power(kin)
            v_tip = tips[f.name.split("_")[0]][1][i]
            assert powers[i, j] == pytest.approx(force @ v_tip, rel=1e-9, abs=1e-12)
    assert np.all(powers <= 0.0)
    assert powers.min() < -1.0  # the tips do slide: about 2 N x 1-2 m/s


def test_peak_tip_speed(rigid):
    model, _, res = rigid
    speed = {side: np.linalg.norm(v, axis=1) for side, (_, v) in _tips(model, res).items()}
    assert 1.5 < speed["right"].max() < 2.6
    assert speed["left"].max() < speed["right"].max()


# ----------------------------------------------------------------------------- flexible blades

def test_flexible_blades(flexible, rigid):
    model, initial, res = flexible
    system = model.build()
    x0, _ = fm.initial_state(system, positions=initial)
    assert system.n_coords == 9 + 2 * 2 * 2
    assert system.dof(0.0, x0) == 2 * 2 * 2
    assert res.n_dof == 8
    assert res.status == "finished"
    assert res.residual.max() < 1e-8
    assert _balance(res) < 1e-6
    # elastic energy stored, damping dissipates
    elastic = [k for k in res.work if k.endswith("elasticity")]
    assert len(elastic) == 1
    damping = -(res.work[elastic[0]] + res.potential - res.potential[0])
    assert np.all(res.potential >= 0.0) and res.potential.max() > 0.0
    assert damping[-1] > 0.0
    # the stiff blades follow the rigid ones within a few mm
    rigid_model, _, rigid_res = rigid
    k = len(res.t)
    np.testing.assert_allclose(rigid_res.t[:k], res.t, atol=1e-12)
    flex_tips, rigid_tips = _tips(model, res), _tips(rigid_model, rigid_res)
    for side in ("right", "left"):
        gap = np.linalg.norm(flex_tips[side][0] - rigid_tips[side][0][:k], axis=1)
        assert gap.max() < 3e-3
    # Result.shape ends at the same tip
    np.testing.assert_allclose(res.shape("right_blade")[:, -1], flex_tips["right"][0], atol=1e-12)


# ----------------------------------------------------------------------------- plots (wiper.png)

def test_exact_tip_speed_is_the_limit_of_differences(rigid):
    model, _, res = rigid
    p, v = point_motion(res, "right_blade", (0.25, 0.0, 0.0), (0, 1), model.build())
    np.testing.assert_allclose(p, _tips(model, res)["right"][0], rtol=0, atol=1e-12)
    # central differences of the sampled positions (interior outputs) approach the exact velocity as the
    # output step h shrinks, at second order: the error with 2h is about 4 times the error with h
    errors = []
    for step in (1, 2, 4):
        d = np.gradient(p[::step], res.t[::step], axis=0)[1:-1]
        errors.append(np.abs(d - v[::step][1:-1]).max())
    speed = np.linalg.norm(v, axis=1)
    assert errors[0] < 2e-4 * speed.max()  # h = 2 ms
    for fine, coarse in zip(errors, errors[1:]):
        assert 3.0 < coarse / fine < 5.0


def _head(res, k):
    """The first k outputs of a result."""
    return attrs.evolve(res, **{a: getattr(res, a)[:k] for a in _ARRAYS},
                        work={n: w[:k] for n, w in res.work.items()})


@pytest.fixture(scope="module")
def figure(rigid, flexible):
    pytest.importorskip("matplotlib")
    (rigid_model, _, rigid_res), (flex_model, _, flex_res) = rigid, flexible
    runs = {"rigid": _head(rigid_res, len(flex_res.t)), "flexible": flex_res}
    systems = {"rigid": rigid_model.build(), "flexible": flex_model.build()}
    tips = {k: point_motion(runs[k], "right_blade", (0.25, 0.0, 0.0), (0, 1), systems[k]) for k in runs}
    return figures.wiper_figure(runs, systems, tips), runs, systems, tips


def test_wiper_figure_axes_and_units(figure):
    fig, runs, _, tips = figure
    ax = np.array(fig.axes).reshape(3, 2)
    units = [[ax[i, j].get_ylabel().rsplit("(", 1)[-1].rstrip(")") for j in range(2)] for i in range(3)]
    assert units == [["m", "mm"], ["m/s", "m/s"], ["N m", "N m"]]
    # what "displacement" means is on the axis
    assert "distance from its start point" in ax[0, 0].get_ylabel()
    assert [a.get_xlabel() for a in ax[-1]] == ["time (s)", "time (s)"]
    p, v = tips["flexible"]
    np.testing.assert_allclose(ax[0, 0].lines[1].get_ydata(), np.linalg.norm(p - p[0], axis=1))
    # the speed panel plots the exact speeds, not differences
    np.testing.assert_allclose(ax[1, 0].lines[1].get_ydata(), np.linalg.norm(v, axis=1))
    dv = np.linalg.norm(v, axis=1) - np.linalg.norm(tips["rigid"][1], axis=1)
    np.testing.assert_allclose(ax[1, 1].lines[0].get_ydata(), dv)
    assert np.abs(dv).max() > 1e-3  # the blade's vibration shows in the difference


def test_wiper_figure_difference_is_the_blade_deflection(figure):
    fig, runs, systems, tips = figure
    res = runs["flexible"]
    # the tip in the frame of the blade's clamp (its body frame "right_blade.base"): the elastic deflection
    k = res.body_names.index("right_blade.base")
    local = np.einsum("tji,tj->ti", res.rotations[:, k], tips["flexible"][0] - res.origins[:, k])
    deflection = local - (0.25, 0.0, 0.0)
    across = fig.axes[1].lines[0]
    assert "across" in across.get_label()
    # the crank drives a linkage without freedom: the arms move alike, and flexible - rigid is the deflection
    np.testing.assert_allclose(across.get_ydata(), 1e3 * deflection[:, 1], rtol=0, atol=1e-5)
    assert np.abs(deflection[:, 1]).max() > 1e-5  # bends by a fraction of a millimetre
    loads = res.section_loads(systems["flexible"].model["right_blade"])
    moment = fig.axes[5].lines[0]
    assert moment.get_label().startswith("Mz")
    np.testing.assert_allclose(moment.get_ydata(), loads.component("Mz")[:, 0])
    assert np.abs(moment.get_ydata()).max() > 0.01  # N m


# ----------------------------------------------------------------------------- the command line

def test_flexmb_run_wiper(tmp_path):
    out = tmp_path / "wiper"
    proc = subprocess.run([sys.executable, "-m", "flexmb", "run", "wiper", "--out", str(out), "--t-end", "0.2",
                           "--quiet"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["scene"] == "wiper"
    for label in ("rigid", "flexible"):
        run = summary[label]
        assert run["status"] == "finished"
        assert run["energy_balance_rel_error"] < 1e-6
        assert run["max_loop_residual"] < 1e-8
        res = fm.Result.load(out / f"wiper_{label}.npz")
        assert res.t[-1] == pytest.approx(0.2)
        assert "driver motor" in res.work
        pvd = out / f"vtk_{label}" / f"wiper_{label}.pvd"
        assert pvd.is_file() and run["vtk"] == f"vtk_{label}/wiper_{label}.pvd"  # relative to the folder
        assert "<VTKFile" in pvd.read_text()
    assert summary["rigid"]["n_dof"] == 0
    assert summary["flexible"]["n_dof"] == 2 * 2 * 6
    assert (out / "wiper.png").stat().st_size > 0
    # the VTK of the main job: bodies and joints named, exact velocities, the blades' stresses, and the
    # ParaView script that opens it
    from flexmb.export import vtk
    from flexmb.export.layout import _Layout

    script = out / "open_in_paraview.py"
    assert summary["paraview"] == script.name
    compile(script.read_text(), str(script), "exec")
    for label, flexible in (("rigid", False), ("flexible", True)):
        res = fm.Result.load(out / f"wiper_{label}.npz")
        model, _ = wiper(WiperOptions(flexible=flexible))
        system = model.build()
        # the summary's peak tip speed is the exact one (the kinematics of the stored states)
        v = point_motion(res, "right_blade", (0.25, 0.0, 0.0), 1, system)
        assert summary[label]["peak_tip_speed_m_s"] == pytest.approx(np.linalg.norm(v, axis=1).max(), rel=1e-12)
        i = len(res.t) // 2
        mesh = meshio.read(out / f"vtk_{label}" / f"wiper_{label}_{i:04d}.vtu")
        assert vtk.table_names(mesh.field_data) == ["crank", "right_arm", "left_arm", "drive_link",
                                                       "connecting_link", "right_blade", "left_blade"]
        assert vtk.table_names(mesh.field_data, "joint") == [j.name for j in model.joints]
        kin = system.kinematics(res.t[i], res.x[i], res.xd[i])
        exact = kin.point_partials(_Layout(res, system).row, mesh.points) @ res.xd[i]
        np.testing.assert_allclose(mesh.point_data["velocity"], exact, rtol=0, atol=1e-10)
        assert ("von_mises" in mesh.point_data) == flexible
    assert np.max(mesh.point_data["von_mises"]) > 1e5 and np.max(np.abs(mesh.point_data["moment_bend_y"])) > 0
