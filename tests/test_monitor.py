"""Ringing modes: what method='auto' picks for them, and the StiffnessWarning of error-controlled runs.

The scenes: B6, the flexible slider-crank of BENCHMARKS.md (a steel rod of 8
segments, crank driven at 5 rev/s from rest: the rod rings in its segment
modes, 293 Hz to 11 kHz), undamped and with 2 % of critical damping; the
rigid four-bar B5; the damped cantilever B1; a stiff pinned beam swinging
from quasi-static balance (modes far above its motion, but not excited).
"""

import logging
import os
import sys
import warnings

import numpy as np
import pytest

import flexmb as fm
from flexmb.genalpha import amplification_matrix, numerical_damping
from flexmb.integrators import monitor
from flexmb.scenes.fourbar import fourbar

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))
scenes = pytest.importorskip("scenes")


@pytest.fixture(scope="module")
def b6_undamped():
    model, initial = scenes.b6(damped=False)
    return model.build(), initial


@pytest.fixture(scope="module")
def b6_damped():
    model, initial = scenes.b6(damped=True)
    return model.build(), initial


def run_until_warned(system, t_end, method, **kw):
    """simulate, stopped by the first StiffnessWarning: (result, [(message, filename, lineno)])."""
    seen = []

    def show(message, category, filename, lineno, file=None, line=None):
        seen.append((str(message), filename, lineno))
        if issubclass(category, fm.StiffnessWarning):
            raise KeyboardInterrupt  # simulate stops cleanly and returns what it has

    with warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.showwarning = show
        res = fm.simulate(system, t_end, method=method, progress=False, **kw)
    return res, seen


# ----------------------------------------------------------------------------- the modes


def test_b6_modes_ring_far_above_the_drive(b6_undamped, b6_damped):
    system, initial = b6_undamped
    x, xd = fm.initial_state(system, 0.0, initial)
    modes = monitor.ringing_modes(system, 0.0, 1.0, x, xd, 1e-8, 1e-10)
    # seven bending modes; the lowest is the pinned-pinned Euler-Bernoulli one
    assert len(modes.frequency) == 7
    assert modes.frequency[0] == pytest.approx(scenes.b6_rod_frequency(), rel=2e-3)
    assert np.all(modes.damping < 1e-6)
    assert modes.motion == pytest.approx(5.0)  # the crank's 5 rev/s
    # the impulsive start excites every mode far above the tolerance
    assert np.all(modes.excitation > 1e3) and modes.ringing().all()
    system, initial = b6_damped
    x, xd = fm.initial_state(system, 0.0, initial)
    modes = monitor.ringing_modes(system, 0.0, 1.0, x, xd, 1e-8, 1e-10)
    # stiffness-proportional: 2 % of critical in the first mode, more above
    assert modes.damping[0] == pytest.approx(scenes.B6_ZETA, rel=1e-2)
    assert np.all(np.diff(modes.damping) > 0) and not modes.ringing().any()


def test_motion_frequency_of_a_structure_is_its_first_mode():
    system = scenes.b1(8, damped=False).build()
    x, xd = np.zeros(8), np.zeros(8)
    modes = monitor.ringing_modes(system, 0.0, 1.0, x, xd, 1e-8, 1e-10)
    assert modes.motion == pytest.approx(modes.frequency[0]) and modes.frequency[0] > 1.0
    # released straight under gravity: excited, but nothing rings far above it at N = 8 but modes 3..8
    assert modes.ringing().sum() == np.sum(modes.frequency > monitor.FAR_ABOVE * modes.frequency[0])


def test_no_modes_without_coordinate_stiffness():
    model, initial, fixed = fourbar()
    system = model.build()
    x, xd = fm.initial_state(system, 0.0, initial, fixed=fixed)
    assert monitor.ringing_modes(system, 0.0, 1.0, x, xd, 1e-8, 1e-10) is None


# ----------------------------------------------------------------------------- method='auto'


def test_auto_dissipates_the_ringing_modes_of_undamped_b6_and_says_so(b6_undamped, caplog):
    system, initial = b6_undamped
    with caplog.at_level(logging.INFO, logger="flexmb"), warnings.catch_warnings():
        warnings.simplefilter("error", fm.StiffnessWarning)
        res = fm.simulate(system, 0.02, positions=initial, progress=False, track_work=True)
    assert res.status == "finished"
    assert res.method.startswith(f"GeneralizedAlpha(rho_inf={monitor.AUTO_RHO_INF:g}")
    # over 0.02 s the motion counts as 50 Hz: the modes above 500 Hz ring (1167 Hz and up)
    assert "1167 to 1.142e+04 Hz (6 modes)" in res.method_reason
    assert "dissipated, not resolved" in res.method_reason and "% of critical" in res.method_reason
    assert [r.levelname for r in caplog.records if r.message == res.method_reason] == ["WARNING"]
    min_step = float(res.method.split("min_step=")[1].rstrip(")"))
    assert min_step == pytest.approx(1 / (2 * np.pi * 1167.3), rel=1e-3)
    assert res.n_steps < 1.2 * 0.02 / min_step  # at the floor (Newton may halve a few steps)
    # the energy it removes is reported by the work balance: positive, a part of the initial energy
    removed = res.work["driver motor"][-1] - (res.kinetic[-1] - res.kinetic[0]) - (res.potential[-1] - res.potential[0])
    assert 0.0 < removed < 0.5 * res.kinetic[0]


def test_auto_resolves_damped_b6_with_cvode(b6_damped, caplog):
    system, initial = b6_damped
    with caplog.at_level(logging.INFO, logger="flexmb"):
        res = fm.simulate(system, 0.01, positions=initial, progress=False)
    assert res.method == "CVODE_BDF" and res.method_reason.startswith("'auto' chose CVODE_BDF: the scene is stiff")
    assert [r.levelname for r in caplog.records if r.message == res.method_reason] == ["INFO"]


def test_auto_keeps_explicit_for_a_rigid_pendulum():
    model = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0, -9.81, 0)))
    res = fm.simulate(model, 1.0, positions={"pin": 0.5}, progress=False)
    assert res.method == "DOP853" and "'auto' chose DOP853" in res.method_reason


def test_auto_says_a_fully_driven_scene_has_nothing_to_keep_stable():
    model = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    pin = fm.Revolute("pin", model.ground, bar)
    model.add(pin, fm.Gravity((0, -9.81, 0)), fm.Driver.constant_speed("motor", pin, speed=2 * np.pi))
    res = fm.simulate(model, 0.5, progress=False)
    assert res.method == "DOP853"
    assert res.method_reason == "'auto' chose DOP853: the scene has no vibration to keep stable (its fastest rate is 0 rad/s)"


def stiff_pendulum():
    """A stiff beam (E x 1e6, modes from 18 kHz) pinned, hanging, swinging at 4 rad/s: in quasi-static balance."""
    s, mat = fm.Section.rectangular(0.02, 0.005), fm.Material.aluminium()
    beam = fm.FlexibleBody("beam", 1.0, s, fm.Material(mat.E * 1e6, mat.density, 0.33), 4, keep=("bend_y",),
                           clamped=False)
    model = fm.Model("pendulum")
    model.add(fm.Revolute("pivot", model.ground, beam, axis=(0, 1, 0)), fm.Gravity((0.0, 0.0, -9.81)))
    return model.build()


def test_auto_steps_over_modes_that_are_not_excited_with_radau():
    """Modes far above the swing, undamped, but still: not dissipated, stepped over by Radau (not CVODE)."""
    system = stiff_pendulum()
    x, xd = fm.initial_state(system, 0.0, {"pivot": np.pi / 2}, {"pivot": 4.0})
    modes = monitor.ringing_modes(system, 0.0, 1.0, x, xd, 1e-8, 1e-10)
    # the swing itself (0.6 Hz, gravity's stiffness) is the motion; the beam's modes are far above it
    assert modes.frequency[0] < 1.0 and modes.excitation[0] > 1e6
    assert modes.ringing(excited=False)[1:].all() and not modes.ringing().any()
    with warnings.catch_warnings():
        warnings.simplefilter("error", fm.StiffnessWarning)
        res = fm.simulate(system, 0.2, positions={"pivot": np.pi / 2}, speeds={"pivot": 4.0}, progress=False)
    assert res.method == "Radau" and "hardly excited" in res.method_reason
    assert res.n_steps < 2000  # CVODE_BDF: some 270,000


# ----------------------------------------------------------------------------- the StiffnessWarning


@pytest.mark.parametrize("method", ["Radau", "CVODE_BDF"])
def test_error_controlled_run_resolving_ringing_modes_is_warned_early(b6_undamped, method):
    system, initial = b6_undamped
    # 0.05 s would take Radau some 65,000 steps (minutes): the warning comes at the first check
    res, seen = run_until_warned(system, 0.05, method, positions=initial)
    assert res.status == "interrupted" and res.n_steps == monitor.CHECK_STEPS
    (message, filename, lineno), = seen
    assert filename == __file__  # stacklevel: the caller's line, not flexmb's
    assert message.startswith(f"{method} is resolving nearly undamped modes at ")
    band = message.split("modes at ")[1].split(", far above")[0]
    assert float(band.split(" ")[0]) == pytest.approx(scenes.b6_rod_frequency(), rel=2e-3)  # from 292.9 Hz
    assert "Hz" in band and "(about 20 Hz)" in message  # the motion over 0.05 s
    assert "method='auto'" in message and "fm.generalized_alpha(rho_inf=" in message


def test_cvode_that_cannot_step_over_still_modes_is_told_to_use_radau():
    res, seen = run_until_warned(stiff_pendulum(), 0.2, "CVODE_BDF", positions={"pivot": np.pi / 2},
                                 speeds={"pivot": 4.0})
    assert res.status == "interrupted" and res.n_steps <= 4 * monitor.CHECK_STEPS
    (message, filename, _), = seen
    assert filename == __file__
    assert message.startswith("CVODE_BDF is resolving nearly undamped modes at 1.801e+04")
    assert "hardly excited" in message and "method='Radau' (or method='auto')" in message


def test_the_warning_is_given_once(b6_undamped, monkeypatch):
    system, initial = b6_undamped
    monkeypatch.setattr(monitor, "CHECK_STEPS", 20)
    monkeypatch.setattr(monitor, "RESOLVE_STEP_LIMIT", 0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = fm.simulate(system, 0.003, positions=initial, method="CVODE_BDF", progress=False)
    assert res.n_steps > 8 * 20  # checked at 20 steps, then not again
    assert [w.category for w in caught] == [fm.StiffnessWarning]


def _quiet_run(system, t_end, method, monkeypatch, **kw):
    """A run in which every checkpoint is judged (no step budget): it must not warn."""
    monkeypatch.setattr(monitor, "RESOLVE_STEP_LIMIT", 0)
    monkeypatch.setattr(monitor, "CHECK_STEPS", 50)
    with warnings.catch_warnings():
        warnings.simplefilter("error", fm.StiffnessWarning)
        res = fm.simulate(system, t_end, method=method, progress=False, **kw)
    assert res.status == "finished" and res.n_steps > 2 * 50  # judged at least twice
    return res


def test_damped_b6_is_not_warned(b6_damped, monkeypatch):
    system, initial = b6_damped
    _quiet_run(system, 0.005, "Radau", monkeypatch, positions=initial)


def test_rigid_fourbar_is_not_warned(monkeypatch):
    model, initial, fixed = fourbar()
    _quiet_run(model.build(), 2.0, "Radau", monkeypatch, positions=initial, fixed=fixed)


@pytest.mark.parametrize("method", ["Radau", "CVODE_BDF"])
def test_b1_is_not_warned(method, monkeypatch):
    _quiet_run(scenes.b1(8).build(), 1.0, method, monkeypatch)


def test_step_floored_and_explicit_runs_are_not_monitored(b6_undamped):
    system, _ = b6_undamped
    caps = fm.integrators.capabilities
    floored = fm.generalized_alpha(0.5, min_step=1e-3)
    assert monitor.ResolutionMonitor.for_run(system, floored, caps(floored), 0, 1, 1e-8, 1e-10, "x") is None
    from scipy.integrate import DOP853

    assert monitor.ResolutionMonitor.for_run(system, DOP853, caps(DOP853), 0, 1, 1e-8, 1e-10, "x") is None
    ga = fm.GeneralizedAlpha
    assert monitor.ResolutionMonitor.for_run(system, ga, caps(ga), 0, 1, 1e-8, 1e-10, "x") is not None


# ----------------------------------------------------------------------------- the damping it states


def test_numerical_damping_is_the_decay_per_step_of_an_undamped_mode():
    for rho, hw in [(0.5, 1.0), (0.5, 40.0), (0.8, 3.0), (0.0, 2.0)]:
        r = np.max(np.abs(np.linalg.eigvals(amplification_matrix(rho, hw))))
        assert np.exp(-numerical_damping(rho, hw) * hw) == pytest.approx(r, rel=1e-12)
    assert numerical_damping(1.0, 5.0) == 0.0
    # the motion far below the step floor is not damped
    assert numerical_damping(monitor.AUTO_RHO_INF, 2 * np.pi * 5.0 / (2 * np.pi * 293.0)) < 1e-5


def test_method_reason_is_saved_and_older_files_load(tmp_path, b6_damped):
    system, initial = b6_damped
    res = fm.simulate(system, 1e-3, positions=initial, n_out=3, progress=False)
    res.save(tmp_path / "r.npz")
    assert fm.Result.load(tmp_path / "r.npz").method_reason == res.method_reason != ""
    with np.load(tmp_path / "r.npz") as z:  # a file written before the field existed
        np.savez(tmp_path / "old.npz", **{k: z[k] for k in z.files if k != "method_reason"})
    assert fm.Result.load(tmp_path / "old.npz").method_reason == ""


@pytest.mark.parametrize("count", [1, 2, 3, 100, 101, 400])
def test_median_is_numpys_to_the_bit(count):
    rng = np.random.default_rng(count)
    steps = (rng.lognormal(-7.0, 1.0, count) * (1 + rng.normal(0.0, 1e-3, count))).tolist()
    steps[: count // 3] = [steps[0]] * (count // 3)  # repeated values, as equal steps give
    got = monitor.median(steps)
    assert type(got) is float and got == float(np.median(steps))
    assert monitor.median([0.1, 0.3]) == float(np.median([0.1, 0.3])) == 0.2
