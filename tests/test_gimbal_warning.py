"""A joint in Bryant angles that nears gimbal lock is named once, with the remedy (flexmb.gimbal).

Seen: a rolling disc whose Bryant Free joint approached ry = -90 deg had not
finished after 600 s, taking ever shorter steps, with no word; in Euler
parameters the same run took 36 steps.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import flexmb as fm


def _tilting_body(rotation):
    """A free body turning about the joint's y axis at 1 rad/s: ry passes 90 deg at t = pi / 2 s."""
    model = fm.Model("tilt")
    body = fm.RigidBody("body", 1.0, (1.0, 2.0, 3.0))
    return model.add(fm.Spherical("ball", model.ground, body, rotation=rotation)).build()


def _run(rotation, t_end, method="DOP853"):
    speeds = {"ball": [0.0, 1.0, 0.0]}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = fm.simulate(_tilting_body(rotation), t_end, speeds=speeds, method=method, rtol=1e-8, progress=False)
    return res, [w for w in caught if issubclass(w.category, fm.GimbalLockWarning)]


@pytest.mark.parametrize("method", ["DOP853", "CVODE_BDF"])
def test_a_bryant_joint_near_gimbal_lock_is_named_once(method):
    res, warned = _run("bryant", np.pi / 2 - 1e-3, method)
    assert len(warned) == 1
    text = str(warned[0].message)
    assert "joint 'ball'" in text and "rotation='quaternion'" in text
    t = float(text.split("at t = ")[1].split(" s")[0])  # ry = t rad: within 1 deg of 90 from t = pi/2 - 1 deg on
    assert np.pi / 2 - np.radians(1.0) - 1e-5 <= t <= res.t[-1] + 1e-5  # the message has 6 digits
    ry = float(text.split("ry = ")[1].split(" deg")[0])
    assert ry == pytest.approx(np.degrees(t), abs=1e-2)


def test_no_warning_away_from_it_or_in_euler_parameters():
    _, warned = _run("bryant", 1.0)  # ry reaches 1 rad = 57 deg
    assert warned == []
    res, warned = _run("quaternion", np.pi)  # through ry = 90 deg: no singular position
    assert res.status == "finished" and warned == []
