"""The Result's quantities of an open tree in one compiled call are the system's routes' state by state.

:func:`flexmb.kernels.tree_states.tree_state_quantities` (with the force
classes' ``potential_states``) replaces, for open trees whose joints and
loads are all compiled, the Python loop of ``flexmb.output_quantities``
(kept for other models): the same positions, origins, rotations,
accelerations and potential energies, bit for bit or to 1e-12, and the
kinetic energy to 1e-13 (its sums in another order): B1 N = 8 (gravity,
elasticity, material damping), a chain of free bodies in Euler parameters
with a spring between points (whose energy is taken state by state), and
given accelerations.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import flexmb as fm
from flexmb import output_quantities

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from scenes import b1  # noqa: E402

ARRAYS = ("positions", "origins", "rotations", "xdd", "kinetic", "potential", "reactions", "residual",
          "velocity_residual")


def _quaternion_chain():
    model = fm.Model("free chain")
    a = fm.RigidBody("a", mass=1.0, inertia=np.diag([0.1, 0.2, 0.3]), com=(0.3, 0.0, 0.0))
    b = fm.RigidBody("b", mass=0.5, inertia=np.diag([0.05, 0.04, 0.02]), com=(0.2, 0.1, 0.0))
    model.add(fm.Free("fa", model.ground, a, rotation="quaternion"),
              fm.Spherical("sb", a, b, parent_point=(0.6, 0.0, 0.0), rotation="quaternion"),
              fm.Gravity((0.0, -9.81, 0.0)),
              fm.SpringDamper("s", model.ground, (0.0, 1.0, 0.0), b, (0.4, 0.0, 0.0), stiffness=30.0,
                              damping=0.5, rest_length=0.2))
    return model.build()


def _run(system, t_end):
    return fm.simulate(system, t_end, method="CVODE_BDF", rtol=1e-6, atol=1e-8, n_out=21, progress=False)


@pytest.mark.parametrize("case", ["b1", "quaternions", "given_xdd"])
def test_compiled_tree_quantities_are_the_systems_routes(monkeypatch, case):
    system = _quaternion_chain() if case == "quaternions" else b1(8).build()
    assert output_quantities._tree_compiled(system)
    res = _run(system, 0.2)
    assert res.status == "finished", res.message
    xdd = res.xdd * 1.5 if case == "given_xdd" else None
    compiled = fm.Result.from_states(system, res.x, res.xd, xdd=xdd, t=res.t)
    monkeypatch.setattr(output_quantities, "_tree_compiled", lambda system: False)
    python = fm.Result.from_states(system, res.x, res.xd, xdd=xdd, t=res.t)
    for key in ARRAYS:
        a, b = np.asarray(getattr(compiled, key)), np.asarray(getattr(python, key))
        assert a.shape == b.shape, key
        if key in ("kinetic", "potential", "xdd"):
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.max(np.abs(b)), err_msg=key)
        else:
            assert np.array_equal(a, b), key
    assert np.any(compiled.potential != 0.0) and np.any(compiled.kinetic != 0.0)


def test_the_comparison_can_fail(monkeypatch):
    """Gravity's energy taken at the wrong mass centres differs from the system's route."""
    system = b1(8).build()
    res = _run(system, 0.2)
    monkeypatch.setattr(fm.Gravity, "potential_states",
                        classmethod(lambda cls, elements, topology, X, positions=None: np.zeros(len(X))))
    compiled = fm.Result.from_states(system, res.x, res.xd, t=res.t)
    monkeypatch.setattr(output_quantities, "_tree_compiled", lambda system: False)
    python = fm.Result.from_states(system, res.x, res.xd, t=res.t)
    assert not np.allclose(compiled.potential, python.potential, rtol=1e-12, atol=0.0)


def test_a_failing_state_gets_nan_accelerations():
    """A state whose accelerations fail (a point mass turning about itself): NaN, as the system's route gives it."""
    model = fm.Model("massless")
    a = fm.RigidBody("a", mass=1.0, inertia=np.diag([0.1, 0.1, 0.1]))
    b = fm.RigidBody("b", mass=1.0, inertia=np.zeros((3, 3)))
    model.add(fm.Revolute("ra", model.ground, a, axis=(0, 0, 1)),
              fm.Revolute("rb", a, b, axis=(0, 0, 1), parent_point=(1.0, 0.0, 0.0)))
    system = fm.System(model)  # (model.build refuses it; the recursion's own diagnosis is what is tested)
    assert output_quantities._tree_compiled(system)
    res = fm.Result.from_states(system, [[0.0, 0.1], [0.2, 0.3]])
    assert np.isnan(res.xdd).all()
    assert np.isfinite(res.positions).all() and np.isfinite(res.kinetic).all()
