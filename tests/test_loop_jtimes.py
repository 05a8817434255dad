"""The compiled ``J v`` of looped models (flexmb.kernels.loop_jtimes) is the compiled state Jacobian's product.

:func:`~flexmb.kernels.loop_jtimes.loop_state_jtimes` (G times a vector in
two passes over the tree, one constrained solve on the right-hand side's
factors) equals ``loop_state_jacobian(...) @ v`` (which tests/test_loop_jacobian.py
holds to ``System.state_jacobian``) to 1e-12 of the product, on and off
the constraint manifold; :func:`~flexmb.kernels.tangent.geometric_times`
equals ``geometric_stiffness(...) @ x`` on random trees of every joint
type; and the loops' CVODE with GMRES, given it through
``CVodeSetJacTimes``, ends within its tolerance of the dense run and of
the difference quotient's, evaluating no right-hand side for the products.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest
from conftest import JOINT_TYPES, random_chain

import flexmb as fm
from flexmb import stepping
from flexmb.assembly import composite_inertias
from flexmb.integrators import cvode_direct, cvode_direct_loops
from flexmb.kernels import tangent
from flexmb.kernels.loop_jacobian import loop_state_jacobian
from flexmb.kernels.loop_jtimes import loop_state_jtimes
from flexmb.system.tangent import NewtonPreconditioner

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))
scenes = pytest.importorskip("scenes")
from test_loop_jacobian import _b6, _sprung_fourbar  # noqa: E402


def _args(system):
    n = system.n_speeds
    K, C = NewtonPreconditioner.diagonal_terms(system)
    gamma_d = np.zeros(len(system.constraints.drivers))  # constant-speed drivers
    return n, K, C, gamma_d, system._loop_tol, system.singular_window()


# B6 on the spatial path (planar=False): the compiled J v is the spatial kernels' (GMRES runs keep the spatial
# right-hand side); the planar J's agreement with the spatial one is tests/test_planar_loop_jacobian.py's
@pytest.mark.parametrize("build", [_sprung_fourbar, lambda: _b6(8, False), lambda: _b6(32, False)],
                         ids=["fourbar", "b6_8", "b6_32"])
def test_the_product_is_the_compiled_jacobians(build):
    system, initial = build()
    assert cvode_direct.compiled_jacobian(system)
    res = fm.simulate(system, 0.05, method="CVODE_BDF", rtol=1e-7, n_out=3, progress=False, **initial)
    n, K, C, gamma_d, tol, window = _args(system)
    rng = np.random.default_rng(11)
    for k in range(len(res.t)):
        for scale in (0.0, 1e-3):  # on the manifold (the outputs are projected), and off it
            y = np.concatenate([res.x[k] + scale * rng.standard_normal(n),
                                res.xd[k] + 100 * scale * rng.standard_normal(n), [0.3]])  # a state nothing reads
            J = np.full((2 * n, 2 * n), np.nan)
            assert loop_state_jacobian(system._packed, system._loop_layout, y, n, K, C, gamma_d, tol, window, -1,
                                       J) == (0, -1)
            for v in (rng.standard_normal(2 * n + 1), np.r_[rng.standard_normal(n), np.zeros(n + 1)]):
                Jv = np.full(2 * n + 1, np.nan)
                assert loop_state_jtimes(system._packed, system._loop_layout, y, n, K, C, gamma_d, tol, window, -1,
                                         v, Jv) == 0
                ref = J @ v[: 2 * n]
                assert np.max(np.abs(Jv[: 2 * n] - ref)) <= 1e-12 * np.max(np.abs(ref))
                assert Jv[2 * n] == 0.0


@pytest.mark.parametrize("seed", range(5))
def test_geometric_times_is_g_times_the_vector(seed):
    """On random trees of every joint type and on ball and free joints in Euler parameters (seed 4), at speed."""
    rng = np.random.default_rng(seed)
    if seed < 4:
        types = list(rng.choice(np.array(JOINT_TYPES + [fm.PlanarRevolute], dtype=object), 7))
        system = random_chain(rng, types=types, branch=bool(seed % 2)).build()
    else:
        from test_quaternion_kernel import _mixed_chain

        system = _mixed_chain()
        assert (system.topology.coord_kind == 3).any()  # flexmb.kernels.QUATERNION
    layout = system.layout
    x = layout.normalized(layout.reference() + 0.3 * rng.normal(size=layout.nq))
    xd = rng.normal(size=system.n_speeds)
    kin = system.kinematics(0.0, x, xd)
    loads = system.forces.loads(kin)
    xdd = system.accelerations(0.0, x, xd)
    topo = kin.topology
    common = (topo.parent, topo.coord_start)
    rest = (kin.Sw, kin.Sv, xdd, kin.r, kin.omega, kin.v, kin.alpha_bias, kin.a_bias, kin.inertia_world(), kin.mass,
            composite_inertias(kin), loads.force[:-1], loads.torque[:-1])
    G = tangent.geometric_stiffness(*common, topo.coord_body, topo.coord_kind, *rest)
    u, hs, qs, y = tangent.geometric_terms(*common, topo.coord_kind, *rest)
    n, nb = system.n_speeds, len(topo.parent)
    for _ in range(3):
        v = rng.normal(size=n)
        out = np.full(n, np.nan)
        tangent.geometric_times(*common, topo.coord_kind, kin.Sw, kin.Sv, u, hs, qs, y, v, out, np.empty((nb, 6)),
                                np.empty((nb + 1, 9)))
        assert np.max(np.abs(out - G @ v)) <= 1e-12 * max(1.0, np.max(np.abs(G @ v)))


_CLOSE = cvode_direct_loops.DirectLoopCVODE.close


def _run(monkeypatch, system, initial, krylov_from, jtimes):
    monkeypatch.setattr(stepping, "KRYLOV_MIN_COORDS", krylov_from)
    monkeypatch.setattr(cvode_direct_loops, "COMPILED_JTIMES", jtimes)
    seen = {}

    def keep(self):
        if getattr(self, "_mem", None):
            seen.update(self.stats())
        _CLOSE(self)

    monkeypatch.setattr(cvode_direct_loops.DirectLoopCVODE, "close", keep)
    res = fm.simulate(system, 0.2, method="CVODE_BDF", rtol=1e-8, atol=1e-10, n_out=11, progress=False, **initial)
    assert res.status == "finished"
    return res, seen


@pytest.mark.parametrize("build", [_sprung_fourbar, lambda: _b6(8)], ids=["fourbar", "b6_8"])
@pytest.mark.parametrize("lagged", [True, False], ids=["lagged", "current"])
def test_gmres_runs_with_it_end_where_the_dense_and_the_difference_quotients_do(monkeypatch, build, lagged):
    """GMRES forced below KRYLOV_MIN_COORDS: with the compiled J v its products evaluate no right-hand side."""
    system, initial = build()
    monkeypatch.setattr(cvode_direct_loops, "LAGGED_JTIMES", lagged)
    dense, _ = _run(monkeypatch, system, initial, 10**9, True)
    quotient, q = _run(monkeypatch, system, initial, 0, False)
    new, s = _run(monkeypatch, system, initial, 0, True)
    assert "jtimes" not in q and s["jtimes"] > 0 and s["jtimes_rhs"] == 0 and s["lin_iters"] == s["jtimes"]
    assert s["rhs_ls"] == 0 and q["rhs_ls"] == q["lin_iters"] > 0  # the quotient's products: a right-hand side each
    for other in (dense, quotient):
        assert np.max(np.abs(new.x - other.x)) <= 1e-6 and np.max(np.abs(new.xd - other.xd)) <= 1e-4
