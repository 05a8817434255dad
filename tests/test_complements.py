"""Tests of the orthogonal complement strategies (eqs. 30-39).

What is checked
---------------
* Selection: every strategy in ``flexmb.COMPLEMENTS`` is reachable through
  ``fm.get_complement`` by name, by class and by instance (the instance is
  returned as is); an unknown name (or an unhashable/foreign object) raises
  ``fm.ModelError`` listing the valid names; ``rank_tol`` overrides the
  per-strategy default zero tolerance.
* For each strategy, on random constraint Jacobians psi that are full rank
  (``m < n``, ``m = n``) and rank deficient (duplicate rows, linear
  combinations of rows, zero rows, ``m > n``, products of thin factors):
  ``psi T = 0`` and ``T^T T = I`` to round-off, ``p = n - rank`` with the
  rank known by construction, ``[basis, T]`` is an orthogonal matrix,
  ``particular(rhs)`` is the minimum-norm solution of ``psi x = rhs`` for
  consistent ``rhs`` (it solves the system, is orthogonal to ``T`` and
  equals ``pinv(psi) rhs``) and the least-squares one otherwise.
* Round-off-sized perturbations do not raise the numerical rank, the rank
  and null space do not depend on the overall scale of psi, empty and
  all-zero psi give ``T = I``, non-finite psi raises ``AssemblyError``.
* The eigen and SVD strategies give the same null-space projector
  ``T T^T`` to ``1e-10``.
* ``qr`` and ``auto`` (also forced through its QR branch with ``min_n=1``)
  give the same rank, null-space projector ``T T^T`` and row-space
  projector as ``svd`` and ``eigen`` to ``1e-10``, and particular solutions
  equal to LAPACK's minimum-norm least squares (``np.linalg.lstsq``) for
  consistent and inconsistent right-hand sides, on the random cases above,
  on larger ones (9 x 33 up to 70 x 60, redundant rows) and on a Sarrus
  6R loop (two triples of parallel axes: rank 5 by construction); Q from
  LAPACK ``dorgqr`` and from the compact WY product agree; ``auto`` picks
  the SVD for small n and for diagonal ratios near ``rank_tol``; four-bar
  runs with ``qr`` and ``auto`` follow the ``svd`` run to ``1e-8``.
* The planar four-bar with a spatial revolute cut joint has 3 coordinates,
  5 constraint rows and ``rank(psi) = 2`` (three rows are redundant), so
  ``p = 1``; ``T`` is the direction of the loop's motion obtained
  independently from the analytic closure, and the planar cut joint gives
  the same ``T``.

Tolerances
----------
The random matrices are at most 12 x 12 with nonzero singular values in
``[0.5, 5]`` per factor (condition number below ~100 on the row space);
observed residuals such as ``|psi T| / |psi|`` are below ``2e-15`` for both
strategies over many draws, even though the eigen strategy squares the
condition number. Identities are asserted to ``1e-12`` relative to the
largest singular value, and the eigen/SVD projector comparison to ``1e-10``.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import fourbar, fourbar_initial

import flexmb as fm
from flexmb.complements import Complement, ComplementStrategy
from flexmb.errors import AssemblyError

STRATEGIES = sorted(fm.COMPLEMENTS)
TOL = 1e-12


# -- selection ---------------------------------------------------------------

def test_registry_holds_eigen_svd_qr_auto_articulated():
    assert fm.COMPLEMENTS == {"eigen": fm.EigenComplement, "svd": fm.SVDComplement, "qr": fm.QRComplement,
                              "auto": fm.AutoComplement, "articulated": fm.ArticulatedComplement}
    for name, cls in fm.COMPLEMENTS.items():
        assert issubclass(cls, ComplementStrategy)
        assert cls.name == name


@pytest.mark.parametrize("name", STRATEGIES)
def test_get_complement_by_name_class_instance(name):
    cls = fm.COMPLEMENTS[name]
    by_name = fm.get_complement(name)
    by_class = fm.get_complement(cls)
    assert type(by_name) is cls and type(by_class) is cls
    inst = cls(rank_tol=1e-6)
    assert fm.get_complement(inst) is inst
    assert inst.tol == 1e-6
    assert by_name.tol == cls.default_rank_tol
    # a built system uses the requested strategy
    system = fourbar(fm.Revolute).build(complement=name)
    assert type(system.strategy) is cls


@pytest.mark.parametrize("bad", ["lu", "SVD", "", 42, ["svd"], int, None])
def test_unknown_strategy_raises_model_error_listing_names(bad):
    with pytest.raises(fm.ModelError) as info:
        fm.get_complement(bad)
    msg = str(info.value)
    for name in fm.COMPLEMENTS:
        assert repr(name) in msg
    assert isinstance(info.value, ValueError)


def test_unknown_strategy_rejected_at_build():
    with pytest.raises(fm.ModelError, match="unknown complement strategy 'lu'"):
        fourbar().build(complement="lu")


# -- random Jacobians ---------------------------------------------------------

def well_conditioned(rng, m, n):
    """Random m x n matrix of full rank min(m, n) with singular values in [0.5, 5]."""
    k = min(m, n)
    U, _ = np.linalg.qr(rng.normal(size=(m, m)))
    V, _ = np.linalg.qr(rng.normal(size=(n, n)))
    s = rng.uniform(0.5, 5.0, k)
    return U[:, :k] @ np.diag(s) @ V[:, :k].T


def low_rank(rng, m, n, r):
    return well_conditioned(rng, m, r) @ well_conditioned(rng, r, n)


def psi_cases():
    """(id, builder(rng) -> psi, rank) for full-rank and rank-deficient Jacobians."""

    def dup(rng):
        a = well_conditioned(rng, 4, 9)
        return np.vstack([a, a[1], a[3]])  # two duplicated rows

    def combo(rng):
        a = well_conditioned(rng, 5, 8)
        c = rng.normal(size=(3, 5))
        return np.vstack([a, c @ a])[rng.permutation(8)]  # rows mixed up

    def zero_rows(rng):
        a = well_conditioned(rng, 4, 7)
        return np.insert(a, [0, 2, 4], 0.0, axis=0)

    def tall(rng):
        return well_conditioned(rng, 12, 6)

    def tall_deficient(rng):
        return low_rank(rng, 11, 7, 4)

    def wide(rng):
        return well_conditioned(rng, 3, 10)

    def square(rng):
        return well_conditioned(rng, 6, 6)

    def square_deficient(rng):
        return low_rank(rng, 6, 6, 5)

    def single_row(rng):
        return rng.normal(size=(1, 5))

    return [
        pytest.param(wide, 3, id="full-rank-m<n"),
        pytest.param(square, 6, id="full-rank-square"),
        pytest.param(tall, 6, id="full-rank-m>n"),
        pytest.param(single_row, 1, id="single-row"),
        pytest.param(dup, 4, id="duplicate-rows"),
        pytest.param(combo, 5, id="combination-rows"),
        pytest.param(zero_rows, 4, id="zero-rows"),
        pytest.param(tall_deficient, 4, id="deficient-m>n"),
        pytest.param(square_deficient, 5, id="deficient-square"),
    ]


def check_complement(c, psi, rank, tol=TOL):
    m, n = psi.shape
    smax = np.linalg.norm(psi, 2) if psi.size else 1.0
    smax = smax or 1.0
    assert isinstance(c, Complement)
    assert c.rank == rank
    assert c.p == n - rank
    assert c.T.shape == (n, n - rank)
    assert c.basis.shape == (n, rank) and c.scale.shape == (rank,) and c.left.shape == (m, rank)
    assert np.max(np.abs(psi @ c.T), initial=0.0) <= tol * smax
    assert np.max(np.abs(c.T.T @ c.T - np.eye(n - rank)), initial=0.0) <= tol
    Q = np.hstack([c.basis, c.T])  # row space + null space = R^n, orthogonal
    assert np.max(np.abs(Q.T @ Q - np.eye(n))) <= tol
    # psi basis = left K, with orthonormal left; K = diag(scale) for an SVD, upper triangular otherwise
    K = np.diag(c.scale) if c.factor is None else c.factor
    assert K.shape == (rank, rank) and np.allclose(np.abs(np.diag(K)), c.scale, rtol=1e-14, atol=0)
    assert np.all(np.tril(K, -1) == 0.0)
    assert np.max(np.abs(psi @ c.basis - c.left @ K), initial=0.0) <= tol * smax
    assert np.max(np.abs(c.left.T @ c.left - np.eye(rank)), initial=0.0) <= tol


@pytest.mark.parametrize("name", STRATEGIES)
@pytest.mark.parametrize("make, rank", psi_cases())
def test_complement_of_random_psi(name, make, rank):
    rng = np.random.default_rng(2024 + rank)
    strategy = fm.get_complement(name)
    for _ in range(3):
        psi = make(rng)
        assert np.linalg.matrix_rank(psi) == rank  # the case is what it says
        c = strategy.complement(psi)
        check_complement(c, psi, rank)

        # consistent right-hand side: minimum-norm exact solution
        n = psi.shape[1]
        rhs = psi @ rng.normal(size=n)
        xp = c.particular(rhs)
        smax = np.linalg.norm(psi, 2)
        assert np.max(np.abs(psi @ xp - rhs)) <= TOL * smax * max(1.0, np.abs(xp).max())
        assert np.max(np.abs(c.T.T @ xp), initial=0.0) <= TOL * max(1.0, np.abs(xp).max())
        np.testing.assert_allclose(xp, np.linalg.pinv(psi) @ rhs, rtol=0, atol=1e-10 * max(1.0, np.abs(xp).max()))
        # adding a null-space component to any solution only makes it longer
        if c.p:
            other = xp + c.T @ rng.normal(size=c.p)
            assert np.max(np.abs(psi @ other - rhs)) <= 1e-10 * smax * np.abs(other).max()
            assert np.linalg.norm(other) > np.linalg.norm(xp)
        # an inconsistent right-hand side (rank < m): least squares
        if rank < psi.shape[0]:
            bad = rhs + rng.normal(size=psi.shape[0])
            np.testing.assert_allclose(c.particular(bad), np.linalg.lstsq(psi, bad, rcond=None)[0],
                                       rtol=0, atol=1e-10 * max(1.0, np.abs(xp).max()))


@pytest.mark.parametrize("make, rank", psi_cases())
def test_eigen_and_svd_give_same_projector(make, rank):
    rng = np.random.default_rng(7 + rank)
    for _ in range(3):
        psi = make(rng)
        ce = fm.EigenComplement().complement(psi)
        cs = fm.SVDComplement().complement(psi)
        assert ce.rank == cs.rank == rank
        np.testing.assert_allclose(ce.T @ ce.T.T, cs.T @ cs.T.T, rtol=0, atol=1e-10)
        np.testing.assert_allclose(ce.basis @ ce.basis.T, cs.basis @ cs.basis.T, rtol=0, atol=1e-10)
        rhs = psi @ rng.normal(size=psi.shape[1])
        np.testing.assert_allclose(ce.particular(rhs), cs.particular(rhs), rtol=0, atol=1e-10)


@pytest.mark.parametrize("name", STRATEGIES)
def test_round_off_does_not_raise_rank(name):
    rng = np.random.default_rng(99)
    a = well_conditioned(rng, 4, 8)
    psi = np.vstack([a, a[:2] + 1e-15 * rng.normal(size=(2, 8)), 2.0 * a[3] - a[0] + 1e-15 * rng.normal(size=8)])
    c = fm.get_complement(name).complement(psi)
    assert c.rank == 4 and c.p == 4
    assert np.abs(psi @ c.T).max() <= 1e-11 * np.linalg.norm(psi, 2)


@pytest.mark.parametrize("name", STRATEGIES)
def test_rank_tol_decides_what_counts_as_zero(name):
    cls = fm.COMPLEMENTS[name]
    V, _ = np.linalg.qr(np.random.default_rng(3).normal(size=(4, 4)))
    psi = np.diag([2.0, 1.0, 1e-4]) @ V[:3]  # singular values 2, 1, 1e-4 (squares 4, 1, 1e-8)
    assert cls().complement(psi).rank == 3
    loose = cls(rank_tol=1e-6 if name == "eigen" else 1e-3).complement(psi)
    assert loose.rank == 2 and loose.p == 2
    np.testing.assert_allclose(loose.T @ loose.T.T, V[2:].T @ V[2:], rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", STRATEGIES)
@pytest.mark.parametrize("scale", [1e-6, 1e-2, 1e3, 1e6])
def test_rank_and_null_space_are_scale_invariant(name, scale):
    rng = np.random.default_rng(5)
    psi = low_rank(rng, 6, 8, 4)
    strategy = fm.get_complement(name)
    ref = strategy.complement(psi)
    c = strategy.complement(scale * psi)
    assert c.rank == ref.rank == 4
    np.testing.assert_allclose(c.T @ c.T.T, ref.T @ ref.T.T, rtol=0, atol=1e-10)
    rhs = psi @ rng.normal(size=8)
    np.testing.assert_allclose(c.particular(scale * rhs), ref.particular(rhs), rtol=0, atol=1e-10)


@pytest.mark.parametrize("name", STRATEGIES)
def test_empty_and_zero_psi(name):
    strategy = fm.get_complement(name)
    for psi in (np.zeros((0, 4)), np.zeros((3, 4))):
        c = strategy.complement(psi)
        assert c.rank == 0 and c.p == 4
        np.testing.assert_array_equal(c.T, np.eye(4))
        np.testing.assert_array_equal(c.particular(np.zeros(psi.shape[0])), np.zeros(4))


@pytest.mark.parametrize("name", STRATEGIES)
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_psi_raises(name, bad):
    psi = np.eye(3)
    psi[1, 2] = bad
    with pytest.raises(AssemblyError, match="not finite"):
        fm.get_complement(name).complement(psi)


# -- four-bar -------------------------------------------------------------------

def fourbar_state(system, theta):
    ang = fourbar_initial(theta)
    return np.array([ang[c.split(".")[0]] for c in system.coordinate_names])


@pytest.mark.parametrize("name", STRATEGIES)
@pytest.mark.parametrize("theta", [0.3, np.pi / 4, 2.0])
def test_fourbar_spatial_revolute_cut_is_rank_two(name, theta):
    system = fourbar(fm.Revolute).build(complement=name)
    assert system.n_coords == 3 and system.n_constraints == 5
    x = fourbar_state(system, theta)
    kin = system.kinematics(0.0, x, np.zeros(3))
    phi, psi, b, _ = system.constraints.evaluate(kin, level=1)
    assert np.abs(phi).max() < 1e-14  # closed
    assert psi.shape == (5, 3)
    c = system.complement(psi)
    check_complement(c, psi, 2)
    assert system.dof(0.0, x) == 1
    # T spans the loop motion: d x / d theta from the analytic closure
    h = 1e-4
    tangent = (fourbar_state(system, theta + h) - fourbar_state(system, theta - h)) / (2 * h)
    tangent /= np.linalg.norm(tangent)
    assert abs(abs(c.T[:, 0] @ tangent) - 1.0) < 1e-8  # O(h^2) difference error
    # the planar cut writes only the two independent rows, with the same null space
    planar = fourbar(fm.PlanarRevolute).build(complement=name)
    psi2 = planar.constraints.evaluate(planar.kinematics(0.0, x, np.zeros(3)), level=1).psi
    assert psi2.shape == (2, 3)
    c2 = planar.complement(psi2)
    check_complement(c2, psi2, 2)
    np.testing.assert_allclose(c2.T @ c2.T.T, c.T @ c.T.T, rtol=0, atol=1e-10)


def test_system_counts_complement_calls():
    system = fourbar(fm.Revolute).build()
    x = fourbar_state(system, 0.5)
    before = system.n_complements
    system.accelerations(0.0, x, np.zeros(3))
    assert system.n_complements == before + 1


# -- qr and auto: against svd and eigen ------------------------------------------

def sarrus_psi(rng):
    """Loop Jacobian (6 x 6 twists) of a Sarrus linkage: two groups of three parallel revolute axes.

    Each group of parallel axes (direction a) spans the twists {(t a; v), v
    perpendicular to a} (dimension 3); the two spans meet in the pure
    translation along a x b, so rank 5 and one degree of freedom, whatever
    the axis positions (overconstrained, like Bricard's 6R loops).
    """
    a, b = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.6, 0.8])
    points = rng.uniform(-0.5, 0.5, size=(6, 3))
    axes = np.array([a, a, a, b, b, b])
    return np.vstack([axes.T, np.cross(points, axes).T])  # (omega; p x omega) per column


def large_cases():
    """(id, builder(rng) -> psi, rank) with n >= AutoComplement.min_n, so auto takes its QR branch."""

    def wiper_like(rng):
        return well_conditioned(rng, 9, 33)

    def medium(rng):
        return well_conditioned(rng, 30, 300)

    def medium_deficient(rng):
        return low_rank(rng, 40, 120, 27)

    def tall_deficient(rng):
        return low_rank(rng, 70, 60, 45)

    def redundant_rows(rng):
        a = well_conditioned(rng, 20, 80)
        return np.vstack([a, rng.normal(size=(6, 20)) @ a])[rng.permutation(26)]

    return [
        pytest.param(wiper_like, 9, id="9x33"),
        pytest.param(medium, 30, id="30x300"),
        pytest.param(medium_deficient, 27, id="40x120-rank27"),
        pytest.param(tall_deficient, 45, id="70x60-rank45"),
        pytest.param(redundant_rows, 20, id="26x80-redundant"),
    ]


QR_LIKE = [pytest.param(lambda: fm.QRComplement(), id="qr"),
           pytest.param(lambda: fm.AutoComplement(), id="auto"),
           pytest.param(lambda: fm.AutoComplement(min_n=1), id="auto-always-tries-qr")]


def check_against_svd_and_eigen(c, psi, rank, rng):
    cs = fm.SVDComplement().complement(psi)
    ce = fm.EigenComplement().complement(psi)
    assert c.rank == cs.rank == ce.rank == rank
    P = c.T @ c.T.T
    np.testing.assert_allclose(P, cs.T @ cs.T.T, rtol=0, atol=1e-10)
    np.testing.assert_allclose(P, ce.T @ ce.T.T, rtol=0, atol=1e-10)
    np.testing.assert_allclose(c.basis @ c.basis.T, cs.basis @ cs.basis.T, rtol=0, atol=1e-10)
    scale = np.linalg.norm(psi, 2)
    for rhs in (psi @ rng.normal(size=psi.shape[1]), rng.normal(size=psi.shape[0])):  # consistent, and not
        x = c.particular(rhs)
        ref = np.linalg.lstsq(psi, rhs, rcond=None)[0]  # LAPACK gelsd: minimum-norm least squares
        size = max(1.0, np.abs(ref).max())
        np.testing.assert_allclose(x, ref, rtol=0, atol=1e-10 * size)
        np.testing.assert_allclose(x, cs.particular(rhs), rtol=0, atol=1e-10 * size)
        assert np.linalg.norm(psi.T @ (psi @ x - rhs)) <= 1e-10 * scale**2 * size  # normal equations


@pytest.mark.parametrize("make_strategy", QR_LIKE)
@pytest.mark.parametrize("make, rank", [*psi_cases(), *large_cases()])
def test_qr_and_auto_match_svd_and_eigen(make_strategy, make, rank):
    rng = np.random.default_rng(31 + rank)
    strategy = make_strategy()
    for _ in range(2):
        psi = make(rng)
        c = strategy.complement(psi)
        check_complement(c, psi, rank)
        check_against_svd_and_eigen(c, psi, rank, rng)


@pytest.mark.parametrize("make_strategy", QR_LIKE)
def test_sarrus_loop_is_rank_five(make_strategy):
    rng = np.random.default_rng(6)
    for _ in range(5):
        psi = sarrus_psi(rng)
        c = make_strategy().complement(psi)
        check_complement(c, psi, 5)
        check_against_svd_and_eigen(c, psi, 5, rng)


def test_both_ways_of_forming_q_agree(monkeypatch):
    """Q from LAPACK dorgqr and from the compact WY product I - V S V^T give the same complement."""
    from flexmb.complements import qr as qrmod

    rng = np.random.default_rng(12)
    for psi in (low_rank(rng, 40, 120, 27), well_conditioned(rng, 12, 20), well_conditioned(rng, 8, 5),
                low_rank(rng, 9, 9, 9)):
        runs = []
        for threshold in (0, 10**9):
            monkeypatch.setattr(qrmod, "WY_MIN_N", threshold)
            Q, R, piv = qrmod.pivoted_qr(psi)
            np.testing.assert_allclose(Q.T @ Q, np.eye(psi.shape[1]), rtol=0, atol=1e-13)
            np.testing.assert_allclose(Q[:, :R.shape[0]] @ R, psi.T[:, piv], rtol=0, atol=1e-13 * np.abs(psi).max())
            runs.append(Q)
        np.testing.assert_allclose(runs[0], runs[1], rtol=0, atol=1e-12)


def test_qr_diagonal_orders_and_reveals_rank():
    from flexmb.complements.qr import pivoted_qr

    rng = np.random.default_rng(4)
    psi = low_rank(rng, 10, 14, 6)
    _, R, piv = pivoted_qr(psi)
    d = np.abs(np.diag(R))
    assert np.all(np.diff(d) <= 1e-14 * d[0])  # non-increasing
    assert d[5] / d[0] > 1e-3 and d[6] / d[0] < 1e-14
    assert sorted(piv) == list(range(10))


def test_auto_chooses_by_size_and_conditioning():
    rng = np.random.default_rng(8)
    auto = fm.AutoComplement()
    assert auto.min_n == 20 and auto.band == 100.0
    assert auto.choose(well_conditioned(rng, 2, 3)) == "svd"  # tiny: svd
    assert auto.choose(well_conditioned(rng, 6, 19)) == "svd" and auto.choose(well_conditioned(rng, 6, 20)) == "qr"
    assert auto.choose(low_rank(rng, 5, 3, 2)) == "svd"
    assert auto.choose(well_conditioned(rng, 30, 300)) == "qr"  # large, clear rank
    assert auto.choose(low_rank(rng, 40, 120, 27)) == "qr"
    assert auto.choose(np.zeros((3, 50))) == "svd" and auto.choose(np.zeros((0, 50))) == "svd"
    # singular values 1 ... and one at 1e-9 or 3e-11: the last diagonal ratio falls within
    # a factor 100 of rtol = 1e-10, so the SVD decides the rank (20 and 19)
    U, _ = np.linalg.qr(rng.normal(size=(20, 20)))
    V, _ = np.linalg.qr(rng.normal(size=(60, 20)))
    for small, rank in ((1e-9, 20), (3e-11, 19)):
        s = np.r_[rng.uniform(0.5, 2.0, 19), small]
        psi = (U * s) @ V.T
        assert auto.choose(psi) == "svd"
        c = auto.complement(psi)
        assert c.rank == rank and c.factor is None  # an SVD complement
        cs = fm.SVDComplement().complement(psi)
        np.testing.assert_allclose(c.T @ c.T.T, cs.T @ cs.T.T, rtol=0, atol=1e-12)
    # the same spectrum with the small value well below the band: qr
    s = np.r_[rng.uniform(0.5, 2.0, 19), 1e-14]
    assert auto.choose((U * s) @ V.T) == "qr"
    assert auto.complement((U * s) @ V.T).rank == 19
    # a narrower band hands the 1e-9 case to qr, whose rank agrees
    narrow = fm.AutoComplement(band=5.0)
    psi = (U * np.r_[rng.uniform(0.5, 2.0, 19), 1e-9]) @ V.T
    assert narrow.choose(psi) == "qr" and narrow.complement(psi).rank == 20


def test_auto_and_qr_construction_and_repr():
    assert repr(fm.AutoComplement()) == ("AutoComplement(rank_tol=None, singular_rtol=0.0, singular_window=0.1, "
                                         "min_n=20, band=100.0)")
    assert repr(fm.QRComplement(rank_tol=1e-8)) == "QRComplement(rank_tol=1e-08, singular_rtol=0.0, singular_window=0.1)"
    assert fm.QRComplement().tol == 1e-10 and fm.AutoComplement(rank_tol=1e-6).tol == 1e-6
    for bad in ({"min_n": 0}, {"band": 0.0}, {"band": -2.0}):
        (key, value), = bad.items()
        with pytest.raises(ValueError, match=f"AutoComplement: {key} must be > 0, got {value!r}"):
            fm.AutoComplement(**bad)


@pytest.mark.parametrize("cut", [fm.PlanarRevolute, fm.Revolute], ids=["planar-cut", "spatial-cut"])
def test_fourbar_simulation_with_qr_and_auto_agrees_with_svd(cut):
    runs = {}
    # "auto" takes the svd branch on this 3-coordinate loop; min_n=1 sends it through its qr branch
    for key, strategy in (("svd", "svd"), ("qr", "qr"), ("auto", "auto"), ("auto-qr", fm.AutoComplement(min_n=1))):
        res = fm.simulate(fourbar(cut), 0.3, positions=fourbar_initial(), fixed=["A"], complement=strategy,
                          rtol=1e-10, atol=1e-12, t_eval=np.linspace(0.0, 0.3, 31))
        assert res.complement == key.split("-")[0] and res.status == "finished"
        runs[key] = res
    ref = runs["svd"]
    assert np.ptp(ref.x[:, 0]) > 0.1  # it moves
    for name in ("qr", "auto", "auto-qr"):
        assert np.abs(runs[name].x - ref.x).max() < 1e-8
        assert np.abs(runs[name].xd - ref.xd).max() < 1e-8 * np.abs(ref.xd).max()


@pytest.mark.parametrize("comp", ["svd", "eigen", "qr", "auto"])
def test_round_off_psi_has_rank_zero(comp):
    psi = 1e-16 * np.random.default_rng(3).normal(size=(5, 3))
    c = fm.get_complement(comp).complement(psi)
    assert c.rank == 0 and c.p == 3


def test_a_loop_that_constrains_nothing_runs():
    """A cut revolute between two welded bodies, frames off by round-off: psi ~ 1e-16.

    Hypothesis found this loop (tests/test_properties.py): a relative rank test counted
    the noise as rank 2, the singular-position filter scaled by sigma ~ 1e-16, and DOP853
    stalled.
    """
    weld = np.array([[-1.0, -1.33532024e-07, 0.0], [-1.33532024e-07, 1.0, 0.0], [0.0, 0.0, -1.0]])
    c, s_ = 0.897173091, 0.441679120
    model = fm.Model("welded")
    b0 = fm.RigidBody("b0", 2.776, np.diag([0.05, 0.33333333, 0.29461961]))
    b1 = fm.RigidBody("b1", 0.99999, np.diag([0.35173296, 0.92541643, 1.09903008]))
    model.add(fm.Spherical("j0", model.ground, b0, parent_point=(0.0, -0.21506409, 0.0),
                           child_point=(0.0, 0.85721794, 0.0), parent_frame=np.diag([-1.0, -1.0, 1.0]),
                           child_frame=np.array([[c, -s_, 0.0], [-s_, -c, 0.0], [0.0, 0.0, -1.0]])))
    point = (-0.83696619, -0.08763643, -1.0)
    model.add(fm.Fixed("j1", b0, b1, child_point=point, parent_frame=weld, child_frame=np.eye(3)))
    model.add(fm.Revolute("cut0", b1, b0, parent_point=point, parent_frame=np.eye(3), child_frame=weld, cut=True))
    model.add(fm.Gravity((0.0, -9.81, 0.0)))
    for comp in ("svd", "eigen"):
        system = model.build(complement=comp)
        assert system.dof(0.0, np.zeros(3)) == 3
        res = fm.simulate(system, 0.2, speeds={"j0": (0.3, -0.2, 0.4)}, rtol=1e-10, method="DOP853", n_out=5)
        assert res.status == "finished" and res.n_steps < 500


def test_simulate_leaves_the_callers_system_unchanged():
    """A run calibrates a copy (rank cap, singular-position scale, strategy): the System passed in is not
    written to (#19 item 6)."""
    system = fourbar(fm.Revolute).build()
    strategy = system.strategy
    res = fm.simulate(system, 0.05, x0=fourbar_state(system, 0.5), n_out=3, complement="eigen")
    assert res.status == "finished" and res.complement == "eigen"
    assert system.strategy is strategy and system.strategy.name == "svd"
    assert system.rank_limit is None and system.sigma_ref is None
    calibrated = system.calibrated(2, 0.5)
    assert (calibrated.rank_limit, calibrated.sigma_ref) == (2, 0.5) and system.rank_limit is None


@pytest.mark.parametrize("name", ["svd", "eigen", "qr"])
def test_multipliers_are_the_least_squares_reactions(name, rng):
    """``Complement.multipliers(r)`` is the minimum-norm solution of psi^T lambda = r, also with a redundant row."""
    psi = rng.normal(size=(4, 7))
    psi = np.vstack([psi, psi[0] + 2.0 * psi[2]])  # a redundant row: rank 4
    c = fm.get_complement(name).complement(psi)
    r = rng.normal(size=7)
    expected = np.linalg.lstsq(psi.T, r, rcond=None)[0]
    np.testing.assert_allclose(c.multipliers(r), expected, rtol=1e-10, atol=1e-12)
