"""The benchmark Whipple bicycle (Meijaard, Papadopoulos, Ruina and Schwab 2007) against its published values.

The model (:mod:`flexmb.scenes.bicycle`) is four rigid bodies in flexmb's
tree with two :class:`flexmb.RollingDisc` elements; the linear model comes
from :func:`flexmb.linearize_steady` about upright, straight running. The
references are the paper's Table 2 (eigenvalues at v = 0 ... 10 m/s, the
weave and capsize speeds, given to 14 decimals), computed there from the
independently derived matrices M, C1, K0 and K2.
"""

from __future__ import annotations

import numpy as np
import pytest

import flexmb as fm
from flexmb.scenes.bicycle import (benchmark_bicycle, linearize_upright, upright_eigenvalues, upright_state,
                                   weave_and_capsize_speeds)

#: Meijaard et al. (2007), Table 2: per speed (m/s) the castering, weave (real, imaginary) and capsize
#: eigenvalues, 1/s (at v = 0 the two real pairs +-3.13164324790656 and +-5.53094371765393)
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
WEAVE_SPEED, CAPSIZE_SPEED, WEAVE_FREQUENCY = 4.29238253634111, 6.02426201538837, 3.43503384866144


@pytest.fixture(scope="module")
def bicycle():
    return benchmark_bicycle().build()


def published(v):
    if v == 0:
        return np.array([-5.53094371765393, -3.13164324790656, 3.13164324790656, 5.53094371765393], dtype=complex)
    cast, (re, im), cap = TABLE2[v]
    return np.array([cast, complex(re, -im), complex(re, im), cap])


def test_the_model_and_its_straight_running(bicycle):
    assert bicycle.coordinate_names == ["frame.x", "frame.y", "frame.z", "frame.yaw", "frame.lean", "frame.pitch",
                                        "rear_wheel.angle", "steer.angle", "front_wheel.angle"]
    assert bicycle.dof() == 3 and bicycle.constraints.n_velocity == 4
    x0, xd0 = upright_state(bicycle, 5.0)
    assert max(bicycle.constraint_residuals(0.0, x0, xd0)) < 1e-15
    lin = linearize_upright(bicycle, 5.0)
    assert lin.coordinates == ["frame.lean", "steer.angle"]  # the pitch and the rear axle's height follow
    assert lin.residual < 1e-12  # straight running is steady


@pytest.mark.parametrize("v", range(11))
def test_eigenvalues_match_table_2(bicycle, v):
    got = np.sort_complex(upright_eigenvalues(bicycle, float(v)))
    want = np.sort_complex(published(v))
    np.testing.assert_allclose(got, want, rtol=1e-8, atol=0)


def test_weave_and_capsize_speeds(bicycle):
    weave, capsize = weave_and_capsize_speeds(bicycle)
    assert abs(weave - WEAVE_SPEED) < 1e-8 * WEAVE_SPEED
    assert abs(capsize - CAPSIZE_SPEED) < 1e-8 * CAPSIZE_SPEED
    ev = upright_eigenvalues(bicycle, WEAVE_SPEED)  # at the weave speed the weave pair is +-i 3.435...
    pair = ev[np.abs(ev.imag) > 1e-9]
    np.testing.assert_allclose(np.sort(pair.imag), [-WEAVE_FREQUENCY, WEAVE_FREQUENCY], rtol=1e-8)
    assert np.max(np.abs(pair.real)) < 1e-8
    # self-stable between them, not outside (the test can fail)
    assert np.max(upright_eigenvalues(bicycle, 5.0).real) < 0
    assert np.max(upright_eigenvalues(bicycle, 4.0).real) > 0 and np.max(upright_eigenvalues(bicycle, 6.5).real) > 0


def test_a_wrong_parameter_is_seen(bicycle):
    """The comparison can fail: the trail 1 mm longer moves the eigenvalues at 5 m/s by far more than 1e-8."""
    other = benchmark_bicycle({"c": 0.081}).build()
    assert np.max(np.abs(upright_eigenvalues(other, 5.0) - published(5)) / np.abs(published(5))) > 1e-4
    with pytest.raises(fm.ModelError, match=r"unknown parameters \['trail'\]"):
        benchmark_bicycle({"trail": 0.08})


def pushed(system, v, lean_rate, t_end, **kw):
    """A nonlinear run from upright, straight running at speed v, pushed sideways: the push leaves the
    rear frame leaning at ``lean_rate`` (rad/s), steer rate 0, the rear wheel's rate ``v / rR`` kept; the
    other speeds follow from the rolling rows."""
    x0, xd0 = upright_state(system, v)
    x0, xd0 = fm.initial_state(system, x0=x0, speeds={"frame.lean": lean_rate, "steer": 0.0, "rear_wheel": v / 0.3})
    return fm.simulate(system, t_end, x0=x0, xd0=xd0, **kw)


def test_a_pushed_bicycle_at_4_6_m_s_stays_upright(bicycle):
    """At 4.6 m/s (between the weave and capsize speeds, where every eigenvalue has a negative real part) a
    push to 0.5 rad/s of lean rate dies out. Rolling without slipping does no work: the energy stays, the
    lateral motion's energy goes into forward speed."""
    res = pushed(bicycle, 4.6, 0.5, 5.0, rtol=1e-9, atol=1e-11, n_out=501)
    names = res.coordinate_names
    lean, steer = res.x[:, names.index("frame.lean")], res.x[:, names.index("steer.angle")]
    first, last = res.t <= 1.0, res.t >= 4.0
    assert np.max(np.abs(lean)) < 0.15  # upright: the largest lean about 0.11 rad (6.6 deg)
    assert np.max(np.abs(lean[last])) < 0.25 * np.max(np.abs(lean[first]))
    assert np.max(np.abs(steer[last])) < 0.25 * np.max(np.abs(steer[first]))
    assert np.ptp(res.energy) < 1e-8 * res.energy[0]
    worst = max(max(bicycle.constraint_residuals(t, x, xd)) for t, x, xd in zip(res.t[::50], res.x[::50],
                                                                                   res.xd[::50]))
    assert worst < 1e-8


def test_a_small_push_follows_the_linear_model(bicycle):
    """A push to 1e-3 rad/s at 4.6 m/s: the nonlinear lean and steer histories over 3 s follow the linear
    model's ``exp(A t) s0`` to the neglected second-order terms (lean amplitude 2.3e-4 rad; they grow as
    its square: 7e-7 relative here, 7e-5 for a push ten times larger)."""
    import scipy.linalg as sla

    lin = linearize_upright(bicycle, 4.6)
    s0 = np.zeros(len(lin.states))
    s0[lin.states.index("frame.lean rate")] = 1e-3
    res = pushed(bicycle, 4.6, 1e-3, 3.0, rtol=1e-10, atol=1e-12, n_out=61)
    linear = np.array([sla.expm(lin.A * t) @ s0 for t in res.t])
    for name in ("frame.lean", "steer.angle"):
        got = res.x[:, res.coordinate_names.index(name)]
        want = linear[:, lin.states.index(name)]
        assert np.max(np.abs(got - want)) < 2e-6 * np.max(np.abs(want))


def test_the_builtin_scene_is_the_benchmark_bicycle(bicycle):
    """``flexmb run bicycle`` runs a scene file: the same model as :func:`benchmark_bicycle` (Table 2's
    eigenvalues from the scene's system) and the push at 4.6 m/s as :func:`pushed` runs it."""
    from flexmb.scene import load_builtin

    scene = load_builtin("bicycle")
    system = scene.system()
    assert system.coordinate_names == bicycle.coordinate_names and system.dof() == 3
    for v in (0, 5):
        np.testing.assert_allclose(np.sort_complex(upright_eigenvalues(system, float(v))),
                                   np.sort_complex(published(v)), rtol=1e-8, atol=0)
    res = scene.simulate(t_end=0.5, n_out=11)
    ref = pushed(bicycle, 4.6, 0.5, 0.5, rtol=scene.solver.rtol, atol=scene.solver.atol, n_out=11)
    np.testing.assert_allclose(res.x, ref.x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(res.xd, ref.xd, rtol=0, atol=1e-11)
    assert res.xd[0, res.coordinate_names.index("frame.x")] == pytest.approx(4.6, rel=1e-12)


def test_flexmb_run_bicycle(tmp_path, capsys):
    import json

    from flexmb.cli import main

    assert main(["run", "bicycle", "--out", str(tmp_path), "--t-end", "0.2", "--quiet"]) == 0
    capsys.readouterr()
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["status"] == "finished" and summary["scene"] == "bicycle"
    assert 0.05 < summary["max_lean_rad"] < 0.1 and summary["energy_balance"] < 1e-8
    # a body and a joint share a name (rear_wheel): each is described by its own type
    assert main(["info", "bicycle"]) == 0
    out = capsys.readouterr().out
    assert "  rear_wheel: rigid_body, mass 2 kg" in out and "  rear_wheel: revolute rear_frame -> rear_wheel" in out
    assert "  frame: yaw_lean_pitch ground -> rear_frame" in out
