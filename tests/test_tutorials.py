"""The tutorials run, and their numbers hold.

Each tutorial in ``tutorials/`` is executed with :func:`runpy.run_path`
(``run_name`` is not ``"__main__"``, so the plotting block is skipped) and
the module-level results it defines are checked against references it does
not compute itself: the elliptic-integral period of a physical pendulum,
loop closure, energy conservation and the work-energy theorem, agreement of
two complement strategies, Euler-Bernoulli beam theory with its
1/N^2 convergence, and the wiper's assembly, sweep, tip speed (the paper's
Fig. 6) and energy balance; a user's quadratic drag law (a falling ball's
tanh law, energy lost = drag work) and screw joint (finite differences, a
falling nut's constant acceleration), used from a scene by plugin name;
Southwell's coefficient of a spinning beam, the rigid inertia of a flexible
arm and its clamped-blade zeros, and a PD loop's static gain and its
nonlinear simulation against the linear prediction; the Whipple bicycle's
eigenvalues, weave and capsize speeds against Meijaard et al. (2007), a
rolling disc's steady precession and critical spin against their closed
forms, and a user's gear pair found through its entry point and run from a
scene file.
"""

from __future__ import annotations

import pathlib
import runpy
import sys
import types

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
TUTORIALS = ROOT / "tutorials"


@pytest.fixture(scope="module")
def run():
    """Run a tutorial once per test module and return its namespace."""
    cache = {}

    def _run(name):
        if name not in cache:
            cache[name] = runpy.run_path(str(TUTORIALS / name))
        return cache[name]

    return _run


def test_every_tutorial_is_tested():
    assert sorted(p.name for p in TUTORIALS.glob("[0-9][0-9]_*.py")) == [
        "01_pendulum.py", "02_fourbar.py", "03_cantilever.py", "04_wiper.py", "05_custom_elements.py",
        "06_export_paraview.py", "07_speed_vs_error.py", "08_parameter_study.py", "09_notebook.py",
        "10_linear_control.py", "11_contact.py", "12_velocity_constraints.py"]


def test_pendulum(run):
    ns = run("01_pendulum.py")
    # A = I_O = m L^2 / 3, V and W of a bar turning about z at the origin
    assert ns["mass_matrix_error"] < 1e-14
    assert ns["partials_error"] < 1e-14
    # T = 4 K(sin^2(theta0 / 2)) / omega0, omega0^2 = 3 g / (2 L), for 120 deg, g = 9.81, L = 1
    assert ns["period_exact"] == pytest.approx(2.248704929, abs=1e-9)
    assert ns["period_error"] < 1e-6


def test_fourbar(run):
    ns = run("02_fourbar.py")
    assert ns["max_residual"] < 1e-9
    assert ns["strategy_difference"] < 1e-8
    assert ns["energy_drift_rel"] < 1e-7
    # spatial revolute cut: 5 rows of rank 2, the same null space as the planar cut
    assert ns["psi_spatial"].shape == (5, 3)
    assert np.sum(ns["singular_values"] > 1e-10 * ns["singular_values"][0]) == 2
    # the driver's work equals the change of mechanical energy
    assert ns["driver_work_error"] < 1e-5
    assert 0.35 < ns["driver_torque_peak"] < 0.45


def test_cantilever(run):
    ns = run("03_cantilever.py")
    assert ns["static_ref"] == pytest.approx(0.0227031, rel=1e-5)
    assert ns["static_error_32"] < 1.5e-3
    assert ns["f1_error_32"] < 1e-3
    assert 1.8 < ns["order_static"] < 2.2
    assert 1.8 < ns["order_f1"] < 2.2
    # released from rest, the lightly damped tip swings to about twice its static deflection
    assert ns["res"].status == "finished"
    assert -2.1 * ns["static_ref"] < ns["tip_z_min"] < -1.9 * ns["static_ref"]
    assert ns["t_min"] == pytest.approx(0.5 / ns["freq_ref"][0], rel=0.05)


def test_wiper(run):
    ns = run("04_wiper.py")
    assert ns["assembly_residual"] < 1e-10
    # the arms' sweep and the tip speed of the paper's Fig. 6 (its axis reaches 2.5 m/s)
    assert 75 < ns["sweep_right_deg"] < 83
    assert 62 < ns["sweep_left_deg"] < 70
    assert 1.5 < ns["peak_tip_speed"] < 2.6
    # driver work = change of kinetic + elastic energy + friction and damping dissipation
    assert ns["energy_balance_error_rigid"] < 1e-6
    assert ns["energy_balance_error_flexible"] < 1e-6
    # blade root stress: the starting friction mu_s N on a 0.25 m blade alone gives
    # 6 (0.4 * 5 * 0.25) / (0.002 * 0.01^2) = 15 MPa; the blade's inertia adds a little
    assert 15e6 < ns["rigid_root_stress_peak"] < 19e6 and ns["clamp_vs_springs"] < 1e-9


def test_custom_elements(monkeypatch):
    from flexmb import registry
    from flexmb.errors import ModelError

    # the tutorial registers its classes for the session: keep them out of the other tests
    monkeypatch.setattr(registry, "_session", {})
    ns = runpy.run_path(str(TUTORIALS / "05_custom_elements.py"))
    g = 9.81
    # AeroDrag: the batched apply_all adds the same loads as apply, element by element, and the
    # drag moment of 20 strips at radii s_i on a paddle turning at w is -1/2 rho Cd dA w^2 sum s_i^3
    assert ns["apply_difference"] < 1e-14
    assert ns["compiled_difference"] < 1e-14  # the compiled apply_all gives the same loads
    s = (np.arange(20) + 0.5) / 20
    assert ns["drag_moment"] == pytest.approx(-0.5 * 1.225 * 1.2 * 0.2 / 20 * 3.0**2 * np.sum(s**3), rel=1e-12)
    # falling ball with quadratic drag: v = -v_t tanh(g t / v_t), v_t = sqrt(2 m g / (rho Cd A))
    v_t = np.sqrt(2 * 0.1 * g / (1.225 * 0.47 * np.pi * 0.1**2 / 4))
    assert ns["v_terminal"] == pytest.approx(v_t, rel=1e-14) and v_t == pytest.approx(20.8299, abs=1e-4)
    res_ball = ns["res_ball"]
    np.testing.assert_allclose(res_ball.xd[:, 0], -v_t * np.tanh(g * res_ball.t / v_t), rtol=0, atol=1e-8 * v_t)
    assert ns["fall_error"] < 1e-8
    # paddle pendulum: the energy lost equals the drag's work, and most of it is lost in 10 s
    assert ns["energy_balance_error"] < 1e-6
    assert 0.85 < ns["energy_lost_fraction"] < 0.97
    assert np.all(np.diff(ns["drag_work"]) <= 1e-12)  # drag never does positive work
    # screw joint: partial velocities are derivatives of positions (joint alone, and on a turntable)
    assert ns["joint_fd_error"] < 1e-8 and ns["system_fd_error"] < 1e-8
    # falling nut: a = g / (1 + (2 pi / p)^2 I / m), I = m (r_o^2 + r_i^2) / 2 of a thick ring
    m, p, I_axis = 0.2, 0.04, 0.2 * (0.02**2 + 0.006**2) / 2
    a = g / (1 + (2 * np.pi / p) ** 2 * I_axis / m)
    assert ns["a_exact"] == pytest.approx(a, rel=1e-14) and a == pytest.approx(1.537874, abs=1e-6)
    res_nut = ns["res_nut"]
    np.testing.assert_allclose(res_nut.origins[:, 0, 2], -a * res_nut.t**2 / 2, rtol=0, atol=1e-8)
    assert ns["nut_error"] < 1e-8 and ns["nut_energy_drift"] < 1e-10
    # a subclass with another lead, in the same model: its own class group, its own acceleration
    a_fine = g / (1 + (2 * np.pi / 0.002) ** 2 * I_axis / m)
    np.testing.assert_allclose(ns["a_two"], [a, a_fine], rtol=1e-12)
    # the TOML scene uses the registered plugins by name and reproduces the Python model
    assert ns["session_plugins"] == [("forces", "aero_drag"), ("joints", "screw")]
    assert ns["scene"].types["screw"] == "screw" and ns["scene"].types["vane"] == "aero_drag"
    assert ns["scene_difference"] < 1e-12
    # the vane's drag brakes the fall
    assert -a / 2 < ns["braked_drop"] < 0
    # validators name the element
    with pytest.raises(ModelError, match="AeroDrag 'v': area must be > 0"):
        ns["AeroDrag"]("v", ns["nut"], area=0.0)


def test_speed_vs_error(run):
    ns = run("07_speed_vs_error.py")
    # tolerance proportionality: the integration error falls about as fast as rtol, and monotonically
    assert 0.8 < ns["slope_error"] < 1.6
    assert np.all(np.diff(ns["int_error"]) < 0) and np.all(np.diff(ns["rhs"]) > 0)
    # second-order convergence in N (the clamp spring is 2k), far above the integration error
    assert 1.8 < ns["order"] < 2.2
    assert ns["disc_error"].min() > 100 * ns["int_error"].max()
    # the choice meets the target: C / N^2 within 0.9 of it, the integration error within 0.1
    assert ns["C"] / ns["n_choice"] ** 2 <= 0.9 * ns["target"] < ns["C"] / (ns["n_choice"] / 2) ** 2
    assert ns["int_error"][list(ns["rtols"]).index(ns["rtol_choice"])] <= 0.1 * ns["target"]


def test_export_paraview(monkeypatch, tmp_path):
    # the tutorial writes to results/ below the working directory
    monkeypatch.chdir(tmp_path)
    ns = runpy.run_path(str(TUTORIALS / "06_export_paraview.py"))
    folder = tmp_path / "results" / "06_export_paraview"
    assert ns["pvd"] == pathlib.Path("results") / "06_export_paraview" / "beam.pvd"
    assert sorted(p.name for p in folder.glob("beam_*.vtu")) == [f"beam_{i:04d}.vtu" for i in range(16)]
    # the collection lists every output time, and the files read back what the Result holds
    assert ns["n_files"] == 16
    assert ns["time_error"] == 0.0
    assert ns["tip_error"] < 1e-15
    assert ns["warp_error"] < 1e-15  # the tip's elastic displacement: from the straight beam clamped to the ground
    assert ns["bending_error"] < 1e-15
    # static bending moment at the clamp carries the whole weight: rho A g L^2 / 2 (rho 2700, A 20 mm x 5 mm)
    assert ns["clamp_moment_ref"] == pytest.approx(2700.0 * 0.02 * 0.005 * 9.81 * 1.0**2 / 2, rel=1e-12)
    assert ns["static_moment_error"] < 1e-8
    # released from rest: the tip swings to about twice the Euler-Bernoulli static deflection
    # rho A g L^4 / (8 E I), after half a period of the first mode (4.1126 Hz)
    static_ref = 2700.0 * 1e-4 * 9.81 / (8 * 70e9 * 0.02 * 0.005**3 / 12)
    assert -2.1 * static_ref < ns["tip_z_min"] < -1.9 * static_ref
    assert abs(ns["t_min"] - 0.5 / 4.1126) <= 0.011
    # a step load on a structure at rest: the clamp moment overshoots to at most about twice the static one
    assert 1.7 < ns["clamp_moment_peak"] / ns["clamp_moment_ref"] < 2.05


def test_parameter_study(monkeypatch, tmp_path):
    # the tutorial writes its study to results/ below the working directory
    monkeypatch.chdir(tmp_path)
    ns = runpy.run_path(str(TUTORIALS / "08_parameter_study.py"))
    result = ns["result"]
    assert [r["status"] for r in result.rows] == ["finished"] * 4
    assert (tmp_path / "results" / "study_rigid" / "table.csv").is_file()
    assert len(list((tmp_path / "results" / "study_rigid" / "cases").glob("*.json"))) == 4
    # rigid blades: 0 degrees of freedom, so the motion ignores the friction and the motor's work
    # is affine in the normal load N (friction force = mu(v) N with v prescribed by the loops)
    assert ns["tip_speed_spread"] < 1e-6
    assert ns["work_nonlinearity"] < 1e-8
    assert ns["work_slope"] == pytest.approx(0.3151, rel=1e-3)
    assert np.all(np.diff(ns["torque"]) > 0)
    # sum of the works = change of kinetic energy, in every case
    assert np.all(ns["energy_balance"] < 1e-7)
    _full_sweep_is_the_documented_study(ns["full_study"]())


def _full_sweep_is_the_documented_study(study):
    """Tutorial 08's full sweep is docs/study.md's command, on the scene's solver: method 'auto' (issue #32: the
    tutorial pinned Radau where the page describes what 'auto' takes)."""
    import shlex

    from flexmb.study import Study, parse_spec

    text = (ROOT / "docs" / "study.md").read_text()
    start = text.index("flexmb study tutorials/04_wiper.toml")
    words = shlex.split(text[start:text.index("```", start)].replace("\\\n", " "))
    options = list(zip(words[3::2], words[4::2]))
    vary = dict(v.split("=", 1) for o, v in options if o == "--vary")
    documented = Study.from_file(ROOT / words[2], {k: parse_spec(v) for k, v in vary.items()},
                                 outputs=[v for o, v in options if o == "--output"])
    assert study.fixed == {} and study.data["solver"].get("method", "auto") == "auto"
    assert study.key() == documented.key() and study.cases() == documented.cases()


def test_notebook(monkeypatch, capsys):
    """The numbers and the table; without pyvista (the ``test`` install) it runs to its end and names the extra."""
    monkeypatch.setitem(sys.modules, "pyvista", None)  # not installed: ``import pyvista`` raises ImportError
    ns = runpy.run_path(str(TUTORIALS / "09_notebook.py"))
    assert "pip install 'flexmb[viz]'" in capsys.readouterr().out
    res = ns["result"]
    assert res.status == "finished" and len(res.t) == 201
    assert ns["max_residual"] < 1e-9
    assert ns["swing"] > 0.1 and ns["energy_drift_rel"] < 1e-7  # it swings, and keeps its energy
    html = res._repr_html_()
    assert "flexmb Result" in html and "largest residuals" in html and res.method in html


def test_notebook_draws_with_pyvista(monkeypatch):
    """With pyvista, the picture is the last cell's value (a notebook and the docs page show it, issue #32)."""
    import ast

    import flexmb as fm

    last = ast.parse((TUTORIALS / "09_notebook.py").read_text()).body[-1]
    shows = last.value.body if isinstance(last, ast.Expr) and isinstance(last.value, ast.IfExp) else None
    assert isinstance(shows, ast.Call) and shows.func.attr == "show", \
        "the last cell is an expression whose value, with pyvista, is result.show(...)"
    shown = []
    monkeypatch.setitem(sys.modules, "pyvista", types.ModuleType("pyvista"))  # the render itself: tests/viz
    monkeypatch.setattr(fm.Result, "show", lambda self, i=-1, **kw: shown.append(i))
    runpy.run_path(str(TUTORIALS / "09_notebook.py"))
    assert shown == [-1]


def test_linear_control(run):
    ns = run("10_linear_control.py")
    # Southwell & Gough (1921): K1 = 1.193 for a uniform cantilever's first mode, no hub radius;
    # in the plane of rotation the spin softening subtracts 1
    assert ns["K_southwell"][0] == pytest.approx(1.1933, abs=1e-4)
    assert ns["K_in_plane"][0] == pytest.approx(0.1933, abs=1e-4)
    # the B3 model at rest against Euler-Bernoulli, w_i = (beta_i L)^2 sqrt(E I / (rho A L^4))
    eb = np.array([1.8751041, 4.6940911, 7.8547574]) ** 2 * np.sqrt(1.4e4 / (1.2 * 10.0**4))
    assert np.all(np.abs(ns["omega"][0] / eb - 1) < 0.015)
    # frequencies rise with the rate; the first stays below Southwell's Rayleigh quotient, within 3 %
    omega, dev = ns["omega"], ns["deviation"]
    assert np.all(np.diff(omega, axis=0) > 0) and np.min(ns["campbell_b3"].mac) > 0.99
    assert np.all(dev[:, 0] <= 1e-7) and np.all(dev[:, 0] > -3.0) and dev[-1, 0] < -2.0
    assert np.all(np.abs(dev[:, 1:]) < 0.1)
    # the slope of w1^2 against Omega^2 near rest is K1 - 1, up to the 16-segment model's O(1/N^2) error
    assert ns["slope"][0] == pytest.approx(0.1933, rel=0.025)
    # flexible arm, open loop: the free rotation is a double pole at 0, the flexible modes are damped
    assert np.all(np.abs(ns["rigid_poles"]) < 1e-6)
    others = ns["open_poles"][np.abs(ns["open_poles"]) > 1e-6]
    assert len(others) == len(ns["open_poles"]) - 2 and np.all(others.real < 0)
    # torque -> angle is 1 / (J s^2) at low frequency: J = hub 0.05 + blade rho A ((R0 + L)^3 - R0^3) / 3
    # + m b^2 / 12 (aluminium 2700 kg/m^3, 5 mm x 20 mm, R0 = 0.05 m, L = 1 m)
    rho_a = 2700.0 * 0.005 * 0.02
    assert ns["J_rigid"] == pytest.approx(0.05 + rho_a * (1.05**3 - 0.05**3) / 3 + rho_a * 0.005**2 / 12, rel=1e-6)
    # collocated zeros are the clamped blade's modes: Euler-Bernoulli f1 = 1.8751^2 / (2 pi) sqrt(E I / (rho A L^4))
    f_clamped = 1.8751041**2 / (2 * np.pi) * np.sqrt(70e9 * 0.02 * 0.005**3 / 12 / rho_a)
    assert ns["f_hub_zeros"][0] == pytest.approx(f_clamped, rel=0.01) and f_clamped == pytest.approx(4.1126, abs=1e-3)
    assert ns["f_hub_zeros"][0] < ns["f_flexible"][0]  # zeros and poles interlace
    assert ns["tip_zero_rhp"] > 0  # non-minimum phase to the tip
    # closed loop: stable, settles at theta_ref (static gain 1 / kp to the hub, (R0 + L) / kp to the tip)
    assert np.all(ns["closed_poles"].real < 0)
    kp = ns["kp"]
    assert ns["closed"].static_gain()[0, 0] == pytest.approx(1 / kp, rel=1e-8)
    assert ns["closed"].static_gain()[2, 0] == pytest.approx(1.05 / kp, rel=1e-6)
    assert ns["closed_damping"][0] > 0.6 and ns["closed_damping"][1] > 0.1
    assert np.all(ns["closed_damping"][1:4] >= ns["open_damping"][:3] - 1e-6)  # collocated: damping only added
    # the same law on the non-collocated tip is unstable
    assert np.all(ns["tip_feedback_growth"] > 0)
    # the nonlinear simulation with the PD force element against lsim of the closed loop
    assert ns["res_small"].status == "finished" and ns["res_large"].status == "finished"
    assert max(ns["small_step_error"].values()) < 1e-6
    # a 1 rad step: the tip runs on a circle, (R0 + L) sin(theta), 1 - sin(1) = 16 % short of the tangent
    large = ns["large_step_error"]
    assert 0.15 < large["tip y"] < 0.25 and large["tip bending"] < 1e-2 and large["hub angle"] < 1e-3
    theta, tip_y = ns["large"]["hub angle"][0], ns["large"]["tip y"][0]
    assert tip_y[-1] == pytest.approx(1.05 * np.sin(theta[-1]), abs=1e-3)


def test_contact(run):
    ns = run("11_contact.py")
    events = ns["events"]
    # a flexible beam into a stop: onsets and separations alternate; the first strike within 0.1 % of a
    # rigid bar's time (closed form); the ledger closes; the tip never through the pad
    assert ns["beam_res"].status == "finished"
    assert [e[2] for e in events] == ["onset", "separation"] * (len(events) // 2) and len(events) >= 4
    assert abs(ns["first_impact_lag"]) < 1e-3
    assert ns["ledger_error"] < 1e-5
    assert 0 < ns["max_penetration"] < 0.05 * ns["radius"]
    # the wiper pressed by a spring: the blades touch and stay on the glass, pressed with a load of the
    # order of the 5 N the preload is set for, and the tips follow the prescribed-load wiper's
    pressed = ns["pressed"]
    assert pressed.status == "finished" and pressed.n_contact_onsets >= 8
    assert 5.0 < ns["right_normal_mean"] < 20.0
    assert ns["tip_gap"] < 2e-3
    assert ns["friction_work"]["pressed by a spring"] > ns["friction_work"]["prescribed load"] > 0


def test_velocity_constraints(run):
    import sys

    from flexmb import registry

    ns = run("12_velocity_constraints.py")
    # Meijaard et al. (2007), Table 2 and the weave and capsize speeds (published to 14 digits)
    assert ns["table_error"] < 1e-8
    assert ns["weave_error"] < 1e-8 and ns["capsize_error"] < 1e-8
    assert ns["weave"] == pytest.approx(4.29238253634111, rel=1e-8)
    assert ns["capsize"] == pytest.approx(6.02426201538837, rel=1e-8)
    stable = ns["speeds"][ns["stable"]]
    assert stable.min() == pytest.approx(4.3) and stable.max() == pytest.approx(6.0)
    # the push at 4.6 m/s dies out; rolling does no work
    assert ns["lean_first"] > 0.1 and ns["lean_last"] < 0.25 * ns["lean_first"]
    assert ns["energy_drift"] < 1e-8
    # the disc: steady precession held, the critical spin's eigenvalues, omega along the axis = w3
    assert ns["steady_error"] < 1e-8
    assert ns["disc_error"] < 1e-8
    assert ns["critical"] == pytest.approx(np.sqrt(9.81 / 0.9), rel=1e-15)
    np.testing.assert_allclose(ns["w_body"][:, 1], ns["w3"], rtol=1e-9)
    # the user's gear pair, found through its entry point: the ratio, and the reflected inertia's swing
    assert ns["origin"] == "tutorial-gears 1.0"
    assert ns["ratio_error"] < 1e-10
    assert ns["w"] == pytest.approx(np.sqrt(40.0 / (0.02 + 0.5 / 9.0)), rel=1e-15)
    assert ns["swing_error"] < 1e-7
    # and it leaves nothing installed
    assert "user_gear_pair" not in registry.names("constraints") and "tutorial_gears" not in sys.modules
