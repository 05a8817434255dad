"""Generalized-alpha's matrix-free Newton solves (:mod:`flexmb.genalpha.krylov`, issue 28).

The preconditioner's solve of generalized-alpha's iteration matrix against
the dense formulation it replaces (the mass matrix and the complement T);
GMRES against a dense solve; and whole runs on the matrix-free path against
the dense path (B1, B6, a top in Euler parameters): with Newton's tolerance
tightened both paths solve the same step equations, so where they take the
same steps the states agree to round-off, and the counts are given.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

import flexmb as fm
from flexmb.genalpha import GeneralizedAlpha
from flexmb.genalpha.krylov import gmres

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))

import rotations as bench  # noqa: E402
import scenes  # noqa: E402


class _Tight(GeneralizedAlpha):
    """Newton's tolerance at 1e-12 (the solution of the step equations, not an approximation of it)."""

    def _configure(self, *args):
        super()._configure(*args)
        self.newton_tol = 1e-12
        self._par = self._par.copy()
        self._par[8] = self.newton_tol  # P_NEWTON_TOL


class _TightKrylov(_Tight):
    krylov_min_coords = krylov_min_loop_coords = 0


class _Krylov(GeneralizedAlpha):
    krylov_min_coords = krylov_min_loop_coords = 0


def test_gmres_solves_a_nonsymmetric_system_in_the_weighted_norm():
    rng = np.random.default_rng(3)
    n = 12
    S = np.eye(n) + 0.3 * rng.standard_normal((n, n))
    b = rng.standard_normal(n)
    w = rng.uniform(0.5, 2.0, n)
    x, k = gmres(lambda v: S @ v, b, w, 1e-12, max_dim=n)
    exact = np.linalg.solve(S, b)
    assert np.sqrt(np.mean((w * (S @ x - b)) ** 2)) <= 1e-12
    np.testing.assert_allclose(x, exact, rtol=0, atol=1e-10 * np.max(np.abs(exact)))
    assert k <= n
    x3, k3 = gmres(lambda v: S @ v, b, w, 1e-12, max_dim=3)  # a short space: the minimal residual there
    assert k3 == 3 and np.linalg.norm(w * (S @ x3 - b)) < np.linalg.norm(w * b)


def _dense_solution(system, x, r, c1, c2):
    """``(I + P D)^-1 r`` with ``P = T (T^T A T)^-1 T^T`` (A^-1 for a tree) and ``D = c1 C + c2 K``, densely."""
    from flexmb.assembly import mass_matrix
    from flexmb.system.tangent import NewtonPreconditioner

    n = system.n_speeds
    kin = system.kinematics(0.0, x, np.zeros(n))
    A = mass_matrix(kin)
    stiffness, damping = NewtonPreconditioner.diagonal_terms(system)
    D = np.diag(c1 * damping + c2 * stiffness)
    if system.n_constraints:
        T = system.complement(system.constraints.evaluate(kin).psi).T
        P = T @ np.linalg.solve(T.T @ A @ T, T.T)
    else:
        P = np.linalg.inv(A)
    return np.linalg.solve(np.eye(n) + P @ D, r)


@pytest.mark.parametrize("scene", ["b1", "b6"])
def test_the_preconditioner_solves_the_two_coefficient_matrix_of_its_model(scene):
    # open tree (articulated-body solve) and loop (constrained solve): the dense (I + P D)^-1 r to round-off
    if scene == "b1":
        system = scenes.b1(8).build()
        x = system.layout.reference() + 0.1 * np.sin(np.arange(system.layout.nq))
    else:  # an assembled position of the loop
        model, positions = scenes.b6(damped=True, n_segments=8)
        system = model.build(complement="articulated")
        x = fm.simulate(system, 1e-3, positions=positions, progress=False, n_out=2).x[-1]
    pre = system.newton_preconditioner()
    pre.setup(0.0, x, np.zeros(system.n_speeds))
    r = np.cos(np.arange(system.n_speeds) * 0.7)
    for c1, c2 in [(1e-3, 1e-6), (2e-2, 3e-5), (0.0, 1e-4)]:
        z = pre.solve_accelerations(r, c1, c2)
        exact = _dense_solution(system, x, r, c1, c2)
        np.testing.assert_allclose(z, exact, rtol=0, atol=1e-10 * np.max(np.abs(exact)))


def _b6(n_segments=8):
    model, positions = scenes.b6(damped=True, n_segments=n_segments)
    return model.build(complement="articulated"), dict(positions=positions)


def _top():
    q0, w0 = bench.initial_state("top", 80.0)
    positions, speeds = bench._flexmb_initial("top", "quaternion", q0, 0.25 * w0)
    return bench.flexmb_model("top"), dict(positions=positions, speeds=speeds)


CASES = {
    "B1 N=8": (lambda: (scenes.b1(8).build(), {}), 0.02, 1e-6),
    "B6 N=8": (_b6, 0.05, 1e-5),
    "top": (_top, 0.2, 1e-7),
}


@pytest.mark.parametrize("case, agree", [("B1 N=8", 1e-10), ("top", 1e-9)])
def test_matrix_free_steps_solve_the_same_step_equations_as_the_dense_path(case, agree):
    # the error filter (the preconditioner's solve for S's LU) takes the same decisions on these: same steps.
    # The top has no springs: its preconditioner is the identity, the filter differs from the dense S^-1 by
    # O(h |J|), the step sizes by round-off-sized amounts that leave 1.2e-10 (scaled) on the quaternions
    make, t_end, rtol = CASES[case]
    system, kw = make()
    dense, free = (fm.simulate(system, t_end, method=cls, rtol=rtol, n_out=11, progress=False, **kw)
                   for cls in (_Tight, _TightKrylov))
    assert dense.status == free.status == "finished"
    assert (free.n_steps, free.n_rhs - free.n_steps) > (0, 0) and free.n_steps == dense.n_steps
    scale = np.max(np.abs(dense.x), axis=0) + 1.0
    assert np.max(np.abs(free.x - dense.x) / scale) < agree
    assert np.max(np.abs(free.xd - dense.xd) / (np.max(np.abs(dense.xd), axis=0) + 1.0)) < 1e-8


def test_matrix_free_b6_takes_its_own_steps_as_close_to_the_motion():
    # the loop's dense Jacobian (System.state_jacobian) holds the geometric stiffness and the constraint
    # projection, the preconditioner only the springs and dampers: the error filters differ on the resolved
    # modes, so the steps differ (1,296 dense, 1,229 matrix-free here); both runs are as close to a tight
    # solution (CVODE_BDF at rtol 1e-11), to within the run's tolerance
    make, t_end, rtol = CASES["B6 N=8"]
    system, kw = make()
    dense, free = (fm.simulate(system, t_end, method=cls, rtol=rtol, n_out=11, progress=False, **kw)
                   for cls in (_Tight, _TightKrylov))
    tight = fm.simulate(system, t_end, method="CVODE_BDF", rtol=1e-11, atol=1e-13, n_out=11, progress=False, **kw)
    assert dense.status == free.status == "finished"
    assert (dense.n_steps, free.n_steps) == (1296, 1229)
    bound = rtol / 100 + rtol * np.max(np.abs(tight.x), axis=0)
    err_dense, err_free = np.abs(dense.x - tight.x).max(axis=0), np.abs(free.x - tight.x).max(axis=0)
    assert np.all(err_free[:3] <= err_dense[:3] + bound[:3])  # crank, slider, rod: the rigid motion
    # the rod's bending: what both runs dissipate of its vibration (rho_inf 0.8), more on fewer steps
    assert np.all(err_free[3:] <= 1.1 * err_dense[3:])


@pytest.mark.parametrize("case", ["B1 N=8", "top"])
def test_matrix_free_runs_at_the_default_newton_tolerance_are_as_close_to_the_motion(case):
    make, t_end, rtol = CASES[case]
    system, kw = make()
    dense, free = (fm.simulate(system, t_end, method=cls, rtol=rtol, n_out=11, progress=False, **kw)
                   for cls in (GeneralizedAlpha, _Krylov))
    tight = fm.simulate(system, t_end, method="DOP853", rtol=1e-12, atol=1e-14, n_out=11, progress=False, **kw)
    assert free.status == "finished"
    bound = rtol / 100 + rtol * np.max(np.abs(tight.x), axis=0)
    err_dense, err_free = np.abs(dense.x - tight.x).max(axis=0), np.abs(free.x - tight.x).max(axis=0)
    assert np.all(err_free <= err_dense + bound)


def test_f_max_with_a_preconditioner_is_refused():
    system = scenes.b1(8).build()
    y0 = np.zeros(2 * system.n_speeds)
    with pytest.raises(ValueError, match="f_max needs the dense Jacobian"):
        GeneralizedAlpha(lambda t, y: np.zeros_like(y), 0.0, y0, 1.0, f_max=100.0,
                         preconditioner=system.newton_preconditioner())


class _Gmres(GeneralizedAlpha):
    """The matrix-free path with GMRES from the first step (not only once the preconditioner alone failed)."""

    krylov_min_coords = krylov_min_loop_coords = 0
    made: list = []

    def _matrix_free(self, preconditioner, layout):
        krylov = super()._matrix_free(preconditioner, layout)
        krylov.exact = True
        _Gmres.made.append(self)
        return krylov


def test_simulate_gives_the_preconditioner_from_the_class_threshold():
    # from krylov_min_coords speeds on: no LU, the set-ups counted as Jacobians
    system = scenes.b1(8).build()
    dense = fm.simulate(system, 0.01, method=GeneralizedAlpha, rtol=1e-6, progress=False, n_out=2)
    free = fm.simulate(system, 0.01, method=_Krylov, rtol=1e-6, progress=False, n_out=2)
    assert dense.n_jac >= 1 and free.n_jac >= 1
    assert free.n_rhs == dense.n_rhs == 199 and free.n_steps == dense.n_steps == 99  # the preconditioner alone


@pytest.mark.parametrize("case", ["B1 N=8", "B6 N=8", "top"])
def test_gmres_corrections_give_the_motion_of_the_dense_path(case):
    # Newton-Krylov from the first step: products with S by differences, GMRES to 0.05 Newton's tolerance
    make, t_end, rtol = CASES[case]
    system, kw = make()
    _Gmres.made.clear()
    dense, free = (fm.simulate(system, t_end, method=cls, rtol=rtol, n_out=11, progress=False, **kw)
                   for cls in (_Tight, _Gmres))
    tight = fm.simulate(system, t_end, method="CVODE_BDF", rtol=1e-11, atol=1e-13, n_out=11, progress=False, **kw)
    assert free.status == "finished" and sum(s.n_krylov for s in _Gmres.made) > 0
    assert free.n_rhs > free.n_steps * 2  # the products are right-hand sides
    bound = rtol / 100 + rtol * np.max(np.abs(tight.x), axis=0)
    err_dense, err_free = np.abs(dense.x - tight.x).max(axis=0), np.abs(free.x - tight.x).max(axis=0)
    assert np.all(err_free <= 1.1 * err_dense + bound)
