"""Random parameters of a study: distributions and how their samples are drawn (Latin hypercube or Monte Carlo)."""

from __future__ import annotations

import inspect
import math

import numpy as np
from attrs import field, frozen

from ..errors import FlexmbError

__all__ = ['DISTRIBUTIONS', 'SAMPLINGS', 'Distribution']


#: random sampling schemes: Latin hypercube or plain Monte Carlo
SAMPLINGS = ("lhs", "mc")



def _uniform(a, b):
    from scipy import stats

    return stats.uniform(loc=a, scale=b - a)


def _loguniform(a, b):
    from scipy import stats

    return stats.loguniform(a, b)


def _normal(a, b):
    from scipy import stats

    return stats.norm(loc=a, scale=b)


#: random distributions: name -> (``make(a, b)`` giving the frozen scipy.stats distribution, meaning of a and b)
DISTRIBUTIONS = {
    "uniform": (_uniform, "low, high"),
    "loguniform": (_loguniform, "low, high (both > 0)"),
    "normal": (_normal, "mean, standard deviation"),
}


def _check_kind(instance, attribute, value):
    if value not in DISTRIBUTIONS:
        raise FlexmbError(f"Distribution: unknown kind {value!r}; pick one of {', '.join(DISTRIBUTIONS)}")


@frozen
class Distribution:
    """A random parameter: values drawn by Monte Carlo or Latin hypercube sampling.

    Parameters
    ----------
    kind : {'uniform', 'loguniform', 'normal'}
        The distribution.
    a, b : float
        ``low, high`` (uniform, loguniform) or ``mean, std`` (normal).

    Examples
    --------
    >>> from flexmb.study import Distribution
    >>> Distribution("uniform", 1.0, 3.0).ppf([0.0, 0.5, 1.0])
    array([1., 2., 3.])
    """

    kind: str = field(validator=_check_kind)
    a: float = field(converter=float)
    b: float = field(converter=float)

    def __attrs_post_init__(self):
        if not (math.isfinite(self.a) and math.isfinite(self.b)):
            raise FlexmbError(f"Distribution {self.kind!r}: a and b must be finite, got {self.a}, {self.b}")
        if self.kind == "normal" and not self.b > 0:
            raise FlexmbError(f"Distribution 'normal': standard deviation must be > 0, got {self.b}")
        if self.kind != "normal" and not self.b > self.a:
            raise FlexmbError(f"Distribution {self.kind!r}: high must be > low, got {self.a}, {self.b}")
        if self.kind == "loguniform" and not self.a > 0:
            raise FlexmbError(f"Distribution 'loguniform': low must be > 0, got {self.a}")

    def as_scipy(self):
        """The distribution as a frozen :mod:`scipy.stats` distribution.

        Returns
        -------
        scipy.stats.rv_continuous_frozen
            ``uniform(loc=a, scale=b - a)``, ``loguniform(a, b)`` or
            ``norm(loc=a, scale=b)``: its ``ppf``, ``cdf``, ``mean()``, ...
        """
        return DISTRIBUTIONS[self.kind][0](self.a, self.b)

    def ppf(self, u) -> np.ndarray:
        """Inverse cumulative distribution: the value at probability ``u``.

        Parameters
        ----------
        u : array_like
            Probabilities in [0, 1].

        Returns
        -------
        ndarray
            Values, same shape as ``u``.
        """
        return np.asarray(self.as_scipy().ppf(np.asarray(u, dtype=float)), dtype=float)



def _unit_samples(sampling: str, n: int, d: int, seed: int) -> np.ndarray:
    """``n`` points in the unit cube of dimension ``d``, reproducible by ``seed``.

    ``'lhs'``: a scrambled Latin hypercube (:class:`scipy.stats.qmc.LatinHypercube`),
    one point in each of the ``n`` equal strata of every dimension;
    ``'mc'``: independent uniform draws.
    """
    rng = np.random.default_rng(seed)
    if sampling == "mc":
        return rng.random((n, d))
    from scipy.stats import qmc

    # scipy >= 1.15 takes the generator as rng (SPEC 7); earlier releases as seed
    key = "rng" if "rng" in inspect.signature(qmc.LatinHypercube).parameters else "seed"
    return qmc.LatinHypercube(d, **{key: rng}).random(n)
