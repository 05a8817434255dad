"""The options flexmb gives CVODE on both of its paths: scikit-sundae's and the compiled loop's.

:mod:`~flexmb.integrators.sundials` passes them to scikit-sundae,
:mod:`~flexmb.integrators.cvode_direct` to CVODE itself, so that the two
paths take the same steps (tests/test_cvode_direct.py). This module
imports nothing: the compiled loop reads them without importing the
scikit-sundae classes (and scipy.integrate with them).
"""

__all__ = ["KRYLOV_DIM", "MAX_STEPS"]

#: Krylov dimension of the preconditioned GMRES (the Newton preconditioner leaves little to iterate on)
KRYLOV_DIM = 10

#: CVODE's bound on the internal steps of one call
MAX_STEPS = 10**9
