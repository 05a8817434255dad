"""Smoke tests: the package imports lean and a pendulum runs."""

import subprocess
import sys

import numpy as np

import flexmb as fm


def test_import_leaves_meshio_and_pyvista_out():
    code = "import sys, flexmb; print('meshio' in sys.modules, 'pyvista' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "False"]


def test_pendulum_conserves_energy():
    model = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0, -9.81, 0)))
    res = fm.simulate(model, 1.0, positions={"pin": 0.5}, rtol=1e-10, atol=1e-12)
    assert res.status == "finished"
    assert np.ptp(res.energy) < 1e-8 * abs(res.potential).max()


def test_projection_restart_near_end_time():
    """A projection restart close to t_end must not ask scipy for a first step past the end."""
    import sys, os
    sys.path.insert(0, os.path.dirname(__file__))
    from conftest import fourbar, fourbar_initial

    res = fm.simulate(fourbar(), 2.0, positions=fourbar_initial(), fixed=["A"], rtol=1e-8)
    assert res.status == "finished"
    assert res.n_projections > 0
    assert res.residual.max() < 1e-8
