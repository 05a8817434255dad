"""Statics, reactions and output projection of looped models closed by the articulated strategy, in O(n m).

What is checked
---------------
* On the looped models of the tests (planar four-bar, the four-bar with a
  full revolute cut, Bricard's linkage, the flexible wiper, B6 with
  gravity at N = 4 and 40, B6 bent at N = 40, B7 at N = 4 and 40 with
  planar and spatial cuts, tilted either way), built with
  ``complement='articulated'``: :func:`flexmb.static_equilibrium` (its
  Newton iteration, now a Krylov solve preconditioned by the loops' Newton
  preconditioner with the springs as armature, T never formed),
  :meth:`flexmb.System.reactions` (the accelerations given, or solved), and the
  output projection near the parallelogram's flattened position
  (``_project_partial``) give main's results (their dense forms,
  tests/data/statics_loops_reference.npz, written by
  tests/data/make_statics_loops_reference.py) to 1e-10.
* No n x n array on these paths: at N = 2048 (n = 4097) the statics of B7
  and the reactions peak far below ``8 n^2`` bytes (tracemalloc).
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

import flexmb as fm
from conftest import fourbar, fourbar_initial
from flexmb.output_projection import _project_partial
from flexmb.simulate import _calibrated

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "benchmarks"))
sys.path.insert(0, HERE)

import scenes  # noqa: E402
import test_hard_cases as hc  # noqa: E402

REFERENCE = os.path.join(HERE, "data", "statics_loops_reference.npz")


def _wiper():
    pytest.importorskip("flexmb_friction")
    from flexmb.scenes.wiper import WiperOptions, wiper

    model, initial = wiper(WiperOptions(flexible=True, n_segments=6))
    return model, {"positions": initial}


def _b6(n, gravity):
    model, initial = scenes.b6(True, n)
    if gravity:
        model.add(fm.Gravity((0.0, -9.81, 0.0)))
    return model, {"positions": initial}


def _b7(n, theta=0.0, planar_cuts=True):
    model, initial = scenes.b7(n, planar_cuts)
    positions = {k: (theta if k.startswith("pin") else -theta) for k in initial["positions"]}
    return model, {"positions": positions}


#: the models, and their starts: assembled, then moved off by ``NOISE`` (0: as assembled)
MODELS = {
    "fourbar": lambda: (fourbar(), {"positions": fourbar_initial()}),
    "fourbar_revolute_cut": lambda: (fourbar(fm.Revolute), {"positions": fourbar_initial()}),
    "bricard": lambda: (hc.bricard(), {}),
    "wiper": _wiper,
    "b6_4_gravity": lambda: _b6(4, True),
    "b6_40_gravity": lambda: _b6(40, True),
    "b6_40_bent": lambda: _b6(40, False),
    "b7_4": lambda: _b7(4, 0.4),
    "b7_40": lambda: _b7(40, 0.4),
    "b7_40_hanging": lambda: _b7(40, 2.8),
    "b7_4_spatial_cuts": lambda: _b7(4, 0.4, planar_cuts=False),
    "b7_40_spatial_cuts": lambda: _b7(40, 0.4, planar_cuts=False),
}
NOISE = {"fourbar": 0.05, "fourbar_revolute_cut": 0.05, "bricard": 0.05, "wiper": 0.05, "b6_40_bent": 0.01}
STATICS = sorted(MODELS)
REACTIONS = sorted(MODELS)
PARTIAL = ["parallelogram", "parallelogram_revolute_cut", "parallelogram_chain", "b7_4_flat", "b7_40_flat",
           "b7_4_flat_spatial_cuts"]


def _system(name):
    model, initial = MODELS[name]()
    system = model.build(complement="articulated")
    x, xd = fm.initial_state(system, 0.0, **initial)
    return system, x, xd


def statics_case(name):
    """The system and the start of a statics case."""
    system, x, _ = _system(name)
    return system, x + NOISE.get(name, 0.0) * np.random.default_rng(3).normal(size=x.size)


def reaction_states(name):
    """(system, t, x, xd, xdd): the calibrated system at its assembled state and two states off it."""
    system, x, xd = _system(name)
    system = _calibrated(system, 0.0, x, xd)
    rng = np.random.default_rng(5)
    out = []
    for i, off in enumerate((0.0, 1e-4, 1e-3)):
        t = 0.1 * i
        xi, xdi = x + off * rng.normal(size=x.size), xd + off * rng.normal(size=x.size)
        xdd = system.state_rate(t, np.concatenate([xi, xdi]))[x.size:]
        out.append((system, t, xi, xdi, xdd))
    return out


def _flat(name, theta):
    """The parallelogram's (or the chain's) positions at crank angle theta, on its parallelogram branch."""
    positions = {"A": theta, "B": -theta, "D": theta}
    if name.endswith("chain"):
        positions.update({"E": -theta, "F": theta})
    return positions


def _b7_partial_states(name):
    """B7's states with the rods 1e-3 rad before, 2e-2 rad before and 1e-3 rad past flat, off the constraints.

    Half of psi's singular values fall below the singular window there (N of 2N).
    """
    n = int(name.split("_")[1])
    model, initial = scenes.b7(n, not name.endswith("spatial_cuts"))

    def at(theta):
        return {k: (theta if k.startswith("pin") else -theta) for k in initial["positions"]}

    system = model.build(complement="articulated")
    x, xd = fm.initial_state(system, 0.0, positions=at(0.4), speeds={"pin_0": -1.0})
    system = _calibrated(system, 0.0, x, xd)
    rng = np.random.default_rng(11)
    out = []
    for theta in (np.pi / 2 - 1e-3, np.pi / 2 - 2e-2, np.pi / 2 + 1e-3):
        x, xd = fm.initial_state(system, 0.0, positions=at(theta), speeds={"pin_0": -1.0})
        x, xd = x + 1e-5 * rng.normal(size=x.size), xd + 1e-5 * rng.normal(size=x.size)
        out.append((system, 0.0, x, xd, system.constraint_residual(0.0, x, xd)))
    return out


def partial_states(name):
    """(system, t, x, xd, residual): states near the flattened position, off the constraints."""
    if name.startswith("b7"):
        return _b7_partial_states(name)
    cut = fm.Revolute if name.endswith("revolute_cut") else fm.PlanarRevolute
    model = hc.parallelogram_chain(cut) if name.endswith("chain") else hc.parallelogram(cut)
    system = model.build(complement="articulated")
    x, xd = fm.initial_state(system, 0.0, positions=_flat(name, 0.5), speeds={"A": 1.0})
    system = _calibrated(system, 0.0, x, xd)  # the singular window is relative to the calibrated sigma
    rng = np.random.default_rng(7)
    out = []
    for theta in (1e-3, 2e-2, np.pi - 1e-3):
        x, xd = fm.initial_state(system, 0.0, positions=_flat(name, theta), speeds={"A": 1.0})
        x, xd = x + 1e-5 * rng.normal(size=x.size), xd + 1e-5 * rng.normal(size=x.size)
        out.append((system, 0.0, x, xd, system.constraint_residual(0.0, x, xd)))
    return out


def project_partial(system, t, x, xd, res):
    """:func:`flexmb.output_projection._project_partial` (the function the reference ran)."""
    return _project_partial(system, t, x, xd, res)


@pytest.fixture(scope="module")
def reference():
    return np.load(REFERENCE)


@pytest.mark.parametrize("name", STATICS)
def test_static_equilibrium_equals_main(name, reference, monkeypatch):
    system, x0 = statics_case(name)
    assert system._loop_kernel

    def dense(*args, **kwargs):
        raise AssertionError("the complement T was formed")

    monkeypatch.setattr(type(system), "complement", dense)
    x = fm.static_equilibrium(system, x0, continuation=False)
    assert np.max(np.abs(x - reference[f"statics/{name}"])) < 1e-10, name


def test_static_equilibrium_closed_forms():
    """B6 under no load straightens (crank at the driver's angle, slider at r + L); B7 stands up or hangs."""
    system, x0 = statics_case("b6_40_bent")
    x = fm.static_equilibrium(system, x0, continuation=False)
    rail = [i for i, c in enumerate(system.coordinate_names) if c.startswith("rail")]
    assert len(rail) == 1 and abs(x[rail[0]] - (scenes.B6_R + scenes.B6_L)) < 1e-12
    assert np.max(np.abs(np.delete(x, rail))) < 1e-12
    for name, angle in (("b7_40", 0.0), ("b7_40_hanging", np.pi)):
        system, x0 = statics_case(name)
        x = fm.static_equilibrium(system, x0, continuation=False)
        pins = np.array([x[i] for i, c in enumerate(system.coordinate_names) if c.startswith("pin")])
        assert np.max(np.abs(pins - angle)) < 1e-12, name


@pytest.mark.parametrize("name", REACTIONS)
def test_reactions_with_given_accelerations_equal_main(name, reference):
    for i, (system, t, x, xd, xdd) in enumerate(reaction_states(name)):
        lam, ref = system.reactions(t, x, xd, xdd), reference[f"reactions/{name}/{i}"]
        assert np.max(np.abs(lam - ref)) / max(1.0, np.max(np.abs(ref))) < 1e-10, (name, i)
        # solved here: the accelerations of state_rate (main solved them densely, off the manifold by the
        # dense complement's filter: 1e-6 from its own state_rate there)
        lam = system.reactions(t, x, xd)
        assert np.max(np.abs(lam - ref)) / max(1.0, np.max(np.abs(ref))) < 1e-10, (name, i, "solved")


@pytest.mark.parametrize("name", PARTIAL)
def test_partial_output_projection_equals_main(name, reference):
    for i, (system, t, x, xd, res) in enumerate(partial_states(name)):
        xp, vp = project_partial(system, t, x, xd, res)
        assert np.max(np.abs(xp - reference[f"partial/{name}/{i}/x"])) < 1e-10, (name, i)
        assert np.max(np.abs(vp - reference[f"partial/{name}/{i}/xd"])) < 1e-10, (name, i)


def test_a_mechanism_with_a_force_and_no_stiffness_is_reported():
    """A parallelogram pushed along its free motion: no equilibrium, the tangent stiffness is singular."""
    model = hc.parallelogram()
    model.add(fm.BodyTorque("push", model["A"].child, (0.0, 0.0, 1.0)))
    system = model.build(complement="articulated")
    x, _ = fm.initial_state(system, 0.0, positions=_flat("parallelogram", 0.5))
    with pytest.raises(fm.AssemblyError, match=r"Newton's method stopped at step 1: the tangent stiffness is "
                                               r"singular"):
        fm.static_equilibrium(system, x, continuation=False)


def test_a_massless_freedom_no_loop_fixes_is_named():
    """A slender bar's spin, free: the loops' solve is singular there, and the joint is named."""
    model = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    model.add(fm.Spherical("ball", model.ground, bar), fm.Gravity((0.0, -9.81, 0.0)))
    other = fm.RigidBody.slender_bar("other", 1.0, 1.0)
    model.add(fm.Revolute("pin", model.ground, other, parent_point=(1.0, 0.0, 0.0)),
              fm.Spherical("tie", bar, other, parent_point=(1.0, 0.0, 0.0), child_point=(0.0, 0.0, 0.0), cut=True))
    with pytest.raises(fm.AssemblyError, match=r"joint 'ball' moves no mass"):
        fm.static_equilibrium(model.build(complement="articulated"), continuation=False)


@pytest.mark.slow
def test_no_n_by_n_array_at_large_n():
    """B7 at N = 2048 (n = 4097): statics and reactions peak below a tenth of one n x n array (8 n^2 = 134 MB)."""
    import tracemalloc

    model, initial = _b7(2048, 0.4)
    system = model.build(complement="articulated")
    x, xd = fm.initial_state(system, 0.0, **initial)
    n = system.n_speeds
    fm.static_equilibrium(system, x, continuation=False)  # compiled, warm
    tracemalloc.start()
    x_eq = fm.static_equilibrium(system, x, continuation=False)
    statics_peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.reset_peak()
    xdd = system.state_rate(0.0, np.concatenate([x, xd]))[n:]
    system.reactions(0.0, x, xd, xdd)
    reactions_peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert np.max(np.abs(x_eq[: n // 2])) < 1e-10  # upright (pins and hinges 0)
    assert statics_peak < 0.1 * 8 * n * n and reactions_peak < 0.1 * 8 * n * n, (statics_peak, reactions_peak)


def _rank_limited_states():
    """Bricard's linkage (5 rows, rank 4) with a tiny singular window, off the constraints by 1e-3.

    Its redundant row's singular value (of the size of the violation) lies
    above the window and the rank rule's floor: the rank limit (4, from the
    calibration) is what cuts it.
    """
    system = hc.bricard().build(complement=fm.ArticulatedComplement(singular_window=1e-6))
    x, xd = fm.initial_state(system, 0.0)
    system = _calibrated(system, 0.0, x, xd)
    rng = np.random.default_rng(13)
    x, xd = x + 1e-3 * rng.normal(size=x.size), xd + 1e-3 * rng.normal(size=x.size)
    return system, x, xd


@pytest.mark.parametrize("name", PARTIAL + ["rank_limited"])
def test_partial_projection_by_the_filter_agrees_with_the_dense_form(name, monkeypatch):
    """The loops' form (psi sparse, rational filter, no complement formed) against the dense SVD form, live."""
    from flexmb.output_projection import _project_partial_dense

    if name == "rank_limited":
        system, x, xd = _rank_limited_states()
        states = [(system, 0.0, x, xd, system.constraint_residual(0.0, x, xd))]
        assert system.rank_limit == 4 and system.n_constraints == 5
    else:
        states = partial_states(name)
    for system, t, x, xd, res in states:
        xr, vr = _project_partial_dense(system, t, x, xd, res, system.singular_window(), 3)
        with monkeypatch.context() as m:
            m.setattr(type(system), "complement", lambda *a, **k: pytest.fail("the complement was formed"))
            xp, vp = project_partial(system, t, x, xd, res)
        assert np.max(np.abs(xp - xr)) < 1e-10 and np.max(np.abs(vp - vr)) < 1e-10, name
        assert np.max(np.abs(vp - xd)) > 1e-7, name  # the speeds were projected, not kept
