"""Load paths of looped models closed by the articulated strategy, in O(n m): psi, T and the tangent never formed.

What is checked
---------------
On the looped models of the tests (the planar four-bar and the four-bar
with a full revolute cut, Bricard's linkage, B6 with gravity at N = 4
and 64, B7 at N = 4 and 40 with planar and spatial cuts and hanging, B7
at N = 4 turned by a torque through its flat, singular position, and the
von Mises truss, whose path passes a limit point and snaps through, also
as :func:`flexmb.static_equilibrium`'s continuation), built with
``complement='articulated'``: :func:`flexmb.load_path` follows the same
path as main's dense form (tests/data/path_loops_reference.npz, written by
tests/data/make_path_loops_reference.py) with the complement never formed;
B6 at N = 64 (p = 63) counts its stability from Davidson's lowest pairs.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

import flexmb as fm

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import test_statics as st  # noqa: E402
import test_statics_loops as sl  # noqa: E402

REFERENCE = os.path.join(HERE, "data", "path_loops_reference.npz")


def _homotopy(name):
    system, x0 = sl.statics_case(name)
    return fm.load_path(system, None, x0=x0)


def _b6_64():
    model, initial = sl._b6(64, True)
    system = model.build(complement="articulated")
    x, _ = fm.initial_state(system, 0.0, **initial)
    return fm.load_path(system, None, x0=x + 0.01 * np.random.default_rng(3).normal(size=x.size))


def _b7_past_flat():
    """B7 at N = 4 held by a spring on its first pin and turned by a torque through the flat, singular position."""
    model, _ = sl.scenes.b7(4)
    model.add(fm.JointSpringDamper("spring", "pin_0", 500.0, 0.0, 0.0), fm.BodyTorque("T", "rod_0", (0.0, 0.0, 950.0)))
    return fm.load_path(model.build(complement="articulated"), "T", options=fm.PathOptions(step=0.03, max_step=0.03))


def _truss_system():
    a, h = 1.0, 0.05
    _, _, k = st.von_mises_truss(1.0, a=a, h=h)
    best = st.minimize_scalar(lambda w: -st.truss_load(w, k, a, h), bounds=(0.0, h), method="bounded",
                              options={"xatol": 1e-12})
    return st.von_mises_truss(-2.0 * best.fun, a=a, h=h, complement="articulated")[0]


def _truss():
    return fm.load_path(_truss_system(), "P")


def _truss_statics():
    """static_equilibrium beyond the limit load: Newton's method alone fails, its continuation snaps through."""
    x, path = fm.static_equilibrium(_truss_system(), full_output=True)
    assert path is not None and np.array_equal(x, path.x[-1])
    return path


#: the cases: Newton's homotopy from the statics tests' starts, and the truss under a named load
CASES = {name: (lambda name=name: _homotopy(name)) for name in
         ("fourbar", "fourbar_revolute_cut", "bricard", "b6_4_gravity", "b7_4", "b7_40", "b7_40_hanging",
          "b7_4_spatial_cuts")}
CASES["b6_64_gravity"] = _b6_64
CASES["b7_4_past_flat"] = _b7_past_flat
CASES["truss"] = _truss
CASES["truss_statics"] = _truss_statics


def run(name):
    """The load path of a case."""
    return CASES[name]()


@pytest.fixture(scope="module")
def reference():
    return np.load(REFERENCE)


@pytest.mark.parametrize("name", sorted(CASES))
def test_load_path_equals_main(name, reference, monkeypatch):
    """Main's dense path, followed without T: the same points to the corrector's tolerance, the same stability.

    Measured: the load factors within 5e-9 (the truss, B6 at N = 4: the
    corrector stops on ``max |dx|`` where main stopped on ``max |dz|``, both
    below ``PathOptions.tol`` = 1e-8), 6e-10 through B7's flat position,
    1e-11 elsewhere; the coordinates within 1e-9 (through the flat position)
    and 1e-10 elsewhere; the limit points' load factors within 3e-11.
    """
    def dense(*args, **kwargs):
        raise AssertionError("the complement T was formed")

    monkeypatch.setattr(fm.System, "complement", dense)
    path = run(name)
    tol = fm.PathOptions().tol
    assert path.lam.shape == reference[f"{name}/lam"].shape
    assert np.max(np.abs(path.lam - reference[f"{name}/lam"])) < tol
    assert np.max(np.abs(path.x - reference[f"{name}/x"])) < tol
    assert path.n_unstable.tolist() == reference[f"{name}/n_unstable"].tolist()
    limits = np.array([p.lam for p in path.limit_points])  # (their arc lengths sum the steps: 3e-8 apart)
    assert limits.shape == reference[f"{name}/limits"][:, 0].shape
    assert np.max(np.abs(limits - reference[f"{name}/limits"][:, 0]), initial=0.0) < tol
    limit_x = np.array([p.x for p in path.limit_points]).reshape(-1, path.x.shape[1])
    assert np.max(np.abs(limit_x - reference[f"{name}/limit_x"]), initial=0.0) < tol


def test_truss_snaps_through_with_one_unstable_direction_between_its_limit_points():
    path = run("truss")
    first, second = path.limit_points
    assert (first.kind, second.kind) == ("maximum", "minimum")
    assert 2.0 * first.lam == pytest.approx(1.0, rel=1e-6) and 2.0 * second.lam == pytest.approx(-1.0, rel=1e-6)
    assert np.all(path.n_unstable[first.index + 1:second.index + 1] == 1)
    assert path.stable[:first.index + 1].all() and path.stable[second.index + 1:].all()


def test_the_stability_of_many_coordinates_comes_from_the_lowest_eigenvalues(monkeypatch):
    """B6 at N = 64 (p = 63 > SUBSPACE_MAX): Davidson's lowest pairs, not a basis of the whole null space."""
    from flexmb.analysis import loop_modes

    def whole(*args, **kwargs):
        raise AssertionError("a basis of the whole null space was formed")

    monkeypatch.setattr(loop_modes.LoopModes, "subspace", whole)
    path = run("b6_64_gravity")
    assert path.reached and not path.n_unstable.any()


def test_a_mechanism_with_no_stiffness_against_the_load_is_reported():
    """A parallelogram pushed along its free motion: the path's slope is undefined at the start."""
    model = sl.hc.parallelogram()
    model.add(fm.BodyTorque("push", model["A"].child, (0.0, 0.0, 1.0)))
    system = model.build(complement="articulated")
    x, _ = fm.initial_state(system, 0.0, positions=sl._flat("parallelogram", 0.5))
    with pytest.raises(fm.AssemblyError, match=r"the tangent stiffness is singular at the start .*a mechanism with "
                                               r"no stiffness against the load \(push\)"):
        fm.load_path(system, "push", x0=x)
