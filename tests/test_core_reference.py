"""The compiled evaluation path reproduces the numpy path it replaced, to 1e-10.

``tests/data/core_reference.npz`` holds the numpy implementation's
kinematics, mass matrix, force array, constraint arrays, accelerations and
state Jacobians for random trees of every joint type, a spatial beam, the
planar and spatial four-bar (on and off the constraint manifold) and the
flexible wiper with friction (written by ``tests/data/make_core_reference.py``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

DATA = Path(__file__).resolve().parent / "data"
sys.path.insert(0, str(DATA))

import make_core_reference as ref  # noqa: E402

REFERENCE = np.load(DATA / "core_reference.npz")
CASES = {name: (model, x, xd) for name, model, x, xd in ref.cases()}


@pytest.mark.parametrize("name", sorted(CASES))
def test_matches_numpy_reference(name):
    model, x, xd = CASES[name]
    np.testing.assert_array_equal(x, REFERENCE[f"{name}/x"])  # the same state was rebuilt
    new = ref.evaluate(model, x, xd)
    keys = sorted(k.split("/", 1)[1] for k in REFERENCE if k.startswith(name + "/"))
    assert set(keys) == set(new), "the same quantities exist"
    for key in keys:
        old = REFERENCE[f"{name}/{key}"]
        scale = max(1.0, float(np.max(np.abs(old)))) if old.size else 1.0
        np.testing.assert_allclose(np.asarray(new[key]), old, rtol=1e-10, atol=1e-10 * scale,
                                   err_msg=f"{name}: {key}")
