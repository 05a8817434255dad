"""Random parameters (:mod:`flexmb.study.sampling`): seeded, Latin hypercube stratified, their distributions."""

from __future__ import annotations

import inspect

import numpy as np
import pytest
from scipy import stats
from scipy.stats import qmc

from flexmb.errors import FlexmbError
from flexmb.study import Distribution, Study

from pendulum_study import scene_file  # noqa: F401  (fixtures: scene_file)



@pytest.mark.parametrize("sampling", ["lhs", "mc"])
def test_random_parameters_are_seeded_and_latin_hypercube_stratified(scene_file, sampling):
    vary = {"bodies.bar.mass": "uniform:1:3", "bodies.bar.length": Distribution("loguniform", 0.1, 10.0),
            "initial.positions.pin": [0.0, 0.5]}
    study = Study.from_file(scene_file, vary, samples=50, seed=7, sampling=sampling)
    cases = study.cases()
    assert len(cases) == 100
    assert cases == Study.from_file(scene_file, vary, samples=50, seed=7, sampling=sampling).cases()
    assert cases != Study.from_file(scene_file, vary, samples=50, seed=8, sampling=sampling).cases()
    m = np.array([c["bodies.bar.mass"] for c in cases[:50]])
    L = np.array([c["bodies.bar.length"] for c in cases[:50]])
    assert np.all((1 <= m) & (m <= 3)) and np.all((0.1 <= L) & (L <= 10))
    strata_m = np.sort(np.floor((m - 1) / 2 * 50).astype(int))
    strata_L = np.sort(np.floor((np.log(L) - np.log(0.1)) / np.log(100) * 50).astype(int))
    if sampling == "lhs":  # exactly one sample in each of the 50 equal-probability strata
        assert np.array_equal(strata_m, np.arange(50)) and np.array_equal(strata_L, np.arange(50))
    else:
        assert len(set(strata_m)) < 50
    with pytest.raises(FlexmbError, match="need samples"):
        Study.from_file(scene_file, vary)


def test_normal_distribution_lhs_matches_its_moments(scene_file):
    study = Study.from_file(scene_file, {"bodies.bar.mass": "normal:5:0.5"}, samples=2000, seed=1)
    m = np.array([c["bodies.bar.mass"] for c in study.cases()])
    # stratified sampling: the mean and spread are far closer than Monte Carlo's 0.5 / sqrt(2000) = 0.011
    assert abs(m.mean() - 5.0) < 2e-3
    assert abs(m.std() - 0.5) < 5e-3


@pytest.mark.parametrize("sampling", ["lhs", "mc"])
def test_samples_follow_their_distributions(scene_file, sampling):
    """Each marginal passes a Kolmogorov-Smirnov test against its scipy.stats distribution."""
    vary = {"bodies.bar.mass": "uniform:1:3", "bodies.bar.length": "loguniform:0.1:10",
            "initial.positions.pin": "normal:0.2:0.05"}
    cases = Study.from_file(scene_file, vary, samples=400, seed=3, sampling=sampling).cases()
    dists = {"bodies.bar.mass": stats.uniform(loc=1, scale=2), "bodies.bar.length": stats.loguniform(0.1, 10),
             "initial.positions.pin": stats.norm(loc=0.2, scale=0.05)}
    for key, dist in dists.items():
        values = np.array([c[key] for c in cases])
        assert stats.kstest(values, dist.cdf).pvalue > 0.01, key
        if sampling == "lhs":  # one sample in each of the 400 equal-probability strata of every parameter
            assert np.array_equal(np.sort(np.floor(dist.cdf(values) * 400)), np.arange(400)), key


def test_latin_hypercube_is_scipy_qmc_with_the_seed(scene_file):
    vary = {"bodies.bar.mass": "uniform:1:3", "bodies.bar.length": "uniform:0.5:2.5"}
    cases = Study.from_file(scene_file, vary, samples=16, seed=11).cases()
    # the study's generator: numpy's default_rng(seed), handed to scipy.stats.qmc.LatinHypercube
    key = "rng" if "rng" in inspect.signature(qmc.LatinHypercube).parameters else "seed"
    u = qmc.LatinHypercube(2, **{key: np.random.default_rng(11)}).random(16)
    np.testing.assert_allclose([c["bodies.bar.mass"] for c in cases], 1 + 2 * u[:, 0], rtol=1e-15)
    np.testing.assert_allclose([c["bodies.bar.length"] for c in cases], 0.5 + 2 * u[:, 1], rtol=1e-15)
