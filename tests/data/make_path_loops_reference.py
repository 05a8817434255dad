"""Write path_loops_reference.npz: load paths of the looped models on main (their dense form).

:func:`flexmb.load_path` formed psi, the complement T (a full SVD) and the
p x p tangent for models whose loops the articulated strategy closes
(issue 28 item 2). This script ran on main (2ad8ab4, the dense form: run
with PYTHONPATH=<main>/src); tests/test_path_loops.py asks the O(n m) form
to give the same path (load factors, coordinates, limit points, stability
counts) to its Newton tolerance.

    OPENBLAS_NUM_THREADS=1 python tests/data/make_path_loops_reference.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE.parent.parent / "benchmarks"))

import test_path_loops as case  # noqa: E402


def main():
    out = {}
    for name in case.CASES:
        path = case.run(name)
        out[f"{name}/lam"], out[f"{name}/x"] = path.lam, path.x
        out[f"{name}/n_unstable"] = path.n_unstable
        out[f"{name}/limits"] = np.array([[p.lam, p.arc] for p in path.limit_points]).reshape(-1, 2)
        out[f"{name}/limit_x"] = np.array([p.x for p in path.limit_points]).reshape(-1, path.x.shape[1])
        print(name, len(path.lam), path.lam[-1], path.n_unstable.tolist(), [p.lam for p in path.limit_points],
              flush=True)
    tmp = HERE / "path_loops_reference.npz.tmp"
    with open(tmp, "wb") as f:
        np.savez_compressed(f, **out)
    tmp.replace(HERE / "path_loops_reference.npz")


if __name__ == "__main__":
    main()
