"""Calibration of segment data to natural frequencies and mode shapes (flexmb.analysis.calibration).

References: the Euler-Bernoulli cantilever and free-free frequencies in
closed form, ``f_i = (beta_i L)^2 / (2 pi) sqrt(EI / (rho A L^4))``, and
the tapered cantilever's frequencies and mode shapes from the independent
solve_bvp computation of ``test_flexible_profile``. The tip response is
compared with the N = 256 model of the same beam (benchmark B1: aluminium
strip, 1 m, damped at 1 % in the first mode, released from rest under
gravity, 1 s).
"""

from __future__ import annotations

import numpy as np
import pytest

import flexmb as fm
from test_flexible_profile import EI0, RHOA0, RHOA_TIP, EI_TIP, continuum_frequencies, ei, rhoa

SECTION = fm.Section.rectangular(0.02, 0.005)
MATERIAL = fm.Material.aluminium()
EI = MATERIAL.E * SECTION.Iy
RHOA = MATERIAL.density * SECTION.area
FACTOR = np.sqrt(EI / RHOA) / (2 * np.pi)  # L = 1 m
F_CANTILEVER = np.array([1.8751041, 4.6940911, 7.8547574]) ** 2 * FACTOR  # 4.1126, 25.7733, 72.1659 Hz
F_FREE = np.array([4.7300408, 7.8532046, 10.9956078]) ** 2 * FACTOR


def b1_beam(n, **kw):
    return fm.FlexibleBody.uniform_beam("beam", 1.0, SECTION, MATERIAL, n, keep=("bend_y",), damping_ratio=0.01,
                                        **kw)


@pytest.fixture(scope="module")
def calibrated16():
    return fm.calibrate(b1_beam(16), F_CANTILEVER)


# ----------------------------------------------------------------------------- the done-when tests

def test_uniform_16_segment_beam_calibrated_to_euler_bernoulli(calibrated16):
    cal = calibrated16
    # uncalibrated: the N = 16 model is below Euler-Bernoulli by 1.8e-3 .. 1.0e-2 (order 2 in N)
    assert cal.error_before == pytest.approx([-1.794e-3, -6.214e-3, -1.020e-2], rel=2e-3)
    assert np.all(np.abs(cal.error_after) < 1e-6), f"after calibration: {cal.error_after}"
    assert cal.success and cal.rank == 3 and cal.parameters.shape == (3,)
    assert cal.before == pytest.approx(cal.target * (1 + cal.error_before))
    assert cal.residual < 1e-6
    # the calibrated body is a body like any other: the fitted factors sit on it, the masses untouched
    body = cal.body
    assert np.array_equal(body.stiffness_scale, cal.stiffness_scale) and body.mass_scale is None
    assert np.all(cal.mass_scale == 1.0)
    assert 0.98 < cal.stiffness_scale.min() and cal.stiffness_scale.max() < 1.15
    assert body.joint_stiffness() == pytest.approx(b1_beam(16).joint_stiffness() * cal.stiffness_scale[:, None])
    f, _ = fm.modes(cal.model.build(), 3)
    assert f == pytest.approx(F_CANTILEVER, rel=1e-6)
    assert "converged" in cal.summary() and "-1.794e-03" in cal.summary()


def tip_response(body, t_end=1.0, n_out=201):
    model = fm.Model("b1")
    model.add(fm.Fixed("clamp", model.ground, body), fm.Gravity((0.0, 0.0, -9.81)))
    res = fm.simulate(model, t_end, t_eval=np.linspace(0.0, t_end, n_out), rtol=1e-9)
    return res.shape("beam")[:, -1, 2]


def test_calibrated_tip_response_is_closer_to_the_fine_model(calibrated16):
    """B1 released under gravity for 1 s: RMS over time of the tip z against N = 256."""
    fine = tip_response(b1_beam(256))
    coarse = tip_response(b1_beam(16))
    calibrated = tip_response(calibrated16.body)

    def rms(d):
        return float(np.sqrt(np.mean(d**2)))

    before, after = rms(coarse - fine), rms(calibrated - fine)
    assert after < 0.1 * before, f"tip z RMS difference to N = 256: {before:.3e} m before, {after:.3e} m after"
    assert before > 0.01 * rms(fine)  # the uncalibrated N = 16 is visibly off (phase drift)


# ----------------------------------------------------------------------------- other set-ups

def test_free_free_calibration_needs_the_even_terms():
    """A uniform free-free beam is symmetric: the odd Legendre terms barely move its frequencies."""
    beam = fm.FlexibleBody("beam", 1.0, SECTION, MATERIAL, 16, keep=("bend_y",), clamped=False)
    cal = fm.calibrate(beam, F_FREE, configuration="free", n_stiffness=5)
    assert np.all(np.abs(cal.error_before) > 5e-5)
    assert np.all(np.abs(cal.error_after) < 1e-6), cal.summary()
    assert cal.rank == 3  # of 5 parameters: P1 and P3 are left where the solver found them
    # the same set-up written as a model: its 6 rigid-body modes skipped by hand
    model = fm.Model("free")
    model.add(fm.Free("free", model.ground, beam))
    again = fm.calibrate(model, F_FREE, n_stiffness=5, skip=6)
    assert again.after == pytest.approx(cal.after, rel=1e-9)


def test_stiffness_and_mass_from_frequencies_and_mode_shapes_of_a_taper():
    """'Measured' modes of the tapered beam, a uniform model of its mean section: fit both profiles."""
    stations = np.linspace(0.1, 1.0, 10)
    f_ref, shapes = continuum_frequencies(lambda xi: ei(xi) / EI0, lambda xi: rhoa(xi) / RHOA0,
                                          stations=stations)
    mean = fm.FlexibleBody("beam", 1.0, fm.Section(SECTION.area * (1 + RHOA_TIP) / 2, SECTION.Iy * (1 + EI_TIP) / 2,
                                                   SECTION.Iz, SECTION.J),
                           MATERIAL, 16, keep=("bend_y",), rotary_inertia=False)
    cal = fm.calibrate(mean, f_ref, shapes, stations=stations, fit=("stiffness", "mass"))
    assert cal.parameters.size == 5 and cal.rank == 5
    assert np.max(np.abs(cal.error_before)) > 0.2
    assert np.max(np.abs(cal.error_after)) < 0.01
    assert np.all(cal.mac_after > cal.mac_before) and np.all(cal.mac_after > 0.9995)
    # the fitted profiles fall from root to tip like the taper (stiffness by about 4, mass by about 2)
    ks, ms = cal.stiffness_scale, cal.mass_scale
    assert ks[0] / ks[-1] == pytest.approx(3.2, rel=0.1)
    assert ms[0] / ms[-1] == pytest.approx(1.8, rel=0.1)
    assert cal.body.mass == pytest.approx(mean.mass, rel=1e-12)  # the total mass is kept
    assert np.all(np.diff(ms) < 0)


def test_calibrating_a_model_keeps_its_other_elements():
    """A beam with a tip mass: the model is the test set-up; targets from a finer model of it."""

    def model_with(beam):
        model = fm.Model("tipmass")
        tip = fm.RigidBody("tip", 0.05, (1e-6, 1e-6, 1e-6))
        model.add(fm.Fixed("clamp", model.ground, beam), fm.Fixed("weld", beam, tip, parent_point=(1.0, 0, 0)),
                  fm.Gravity((0.0, 0.0, -9.81)))
        return model

    target, _ = fm.modes(model_with(b1_beam(64)).build(), 2)
    model = model_with(b1_beam(8))
    cal = fm.calibrate(model, target)
    assert np.all(np.abs(cal.error_after) < 1e-6)
    assert cal.model is not model and model["beam"].stiffness_scale is None  # the given model is left alone
    assert cal.model["weld"].parent is cal.body and cal.model["clamp"].child is cal.body
    assert cal.model["tip"] is model["tip"] and cal.model.ground is model.ground
    res = fm.simulate(cal.model, 0.02, n_out=3, rtol=1e-6)
    assert res.shape("beam").shape == (3, 9, 3)
    # the body can be named
    assert fm.calibrate(model, target, body="beam").after == pytest.approx(cal.after, rel=1e-9)


# ----------------------------------------------------------------------------- bad input

@pytest.mark.parametrize("args, kw, message", [
    ((b1_beam(4), []), {}, r"frequencies must be finite numbers > 0, got \[\]"),
    ((b1_beam(4), [4.0, -1.0]), {}, r"frequencies must be finite numbers > 0"),
    ((b1_beam(4), [np.nan]), {}, r"frequencies must be finite numbers > 0"),
    ((b1_beam(4), "4 Hz"), {}, r"frequencies must be finite numbers > 0"),
    ((b1_beam(4), [4.0]), {"fit": ("mass",)}, r"fit must be \('stiffness',\) or \('stiffness', 'mass'\)"),
    ((b1_beam(4), [4.0]), {"configuration": "pinned"}, r"configuration must be one of \['clamped', 'free'\]"),
    ((b1_beam(4), [4.0]), {"configuration": "free"},
     r"FlexibleBody 'beam' has clamped = True .* a free-free test needs clamped = False"),
    ((b1_beam(4), [4.0]), {"body": "beam"}, r"body= is for a model"),
    ((b1_beam(4), [4.0]), {"skip": -1}, r"skip must be an integer >= 0, got -1"),
    (("beam", [4.0]), {}, r"target must be a FlexibleBody or a Model, got str"),
    ((b1_beam(4), [4.0]), {"mode_shapes": [[1.0]]}, r"mode_shapes need the stations"),
    ((b1_beam(4), [4.0, 25.0]), {"mode_shapes": [[1.0, 2.0]], "stations": [0.5, 1.0]},
     r"mode_shapes must have shape \(len\(stations\), len\(frequencies\)\) = \(2, 2\), got \(1, 2\)"),
    ((b1_beam(4), [4.0]), {"mode_shapes": [1.0, 2.0], "stations": [0.5, 1.5]},
     r"mode shapes must be finite and non-zero, stations within \[0, 1\] m"),
    ((b1_beam(4), [4.0]), {"mode_shapes": [0.0, 0.0], "stations": [0.5, 1.0]}, r"mode shapes must be finite and "
                                                                               r"non-zero"),
    ((fm.FlexibleBody("beam", 1.0, SECTION, MATERIAL, 4, keep=("bend_y", "bend_z")), [4.0]),
     {"mode_shapes": [0.5, 1.0], "stations": [0.5, 1.0]},
     r"mode shapes are transverse displacements in one plane; FlexibleBody 'beam' must keep exactly one of "
     r"'bend_y', 'bend_z'"),
    ((b1_beam(4), [4.0, 25.0]), {"fit": ("stiffness", "mass"), "n_stiffness": 2}, r"need n_stiffness >= 1 \(and "
                                                                                  r"n_mass >= 1 to fit masses\)"),
])
def test_bad_calibration_input_is_refused(args, kw, message):
    with pytest.raises(fm.ModelError, match=r"calibrate: " + message):
        fm.calibrate(*args, **kw)


def test_model_target_needs_a_flexible_body_named_when_several():
    model = fm.Model("two")
    a, b = b1_beam(4), fm.FlexibleBody("other", 1.0, SECTION, MATERIAL, 4, keep=("bend_y",))
    model.add(fm.Fixed("clamp", model.ground, a), fm.Fixed("weld", a, b, parent_point=(1.0, 0, 0)))
    with pytest.raises(fm.ModelError, match=r"calibrate: model 'two' has 2 flexible bodies \['beam', 'other'\]"):
        fm.calibrate(model, [1.0])
    with pytest.raises(fm.ModelError, match=r"configuration is for a bare body"):
        fm.calibrate(model, [1.0], body="beam", configuration="clamped")
    with pytest.raises(fm.ModelError, match=r"no flexible body named 'wing'"):
        fm.calibrate(model, [1.0], body="wing")
