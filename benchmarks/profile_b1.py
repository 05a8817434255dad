"""One flexmb run of B1 to profile (benchmarks/floor_b1.py compares it with the hand-written floor).

Run::

    OPENBLAS_NUM_THREADS=1 python -m cProfile -s tottime benchmarks/profile_b1.py 64 Radau 1e-4 | head -40
    OPENBLAS_NUM_THREADS=1 python -m cProfile -s cumulative benchmarks/profile_b1.py 64 BDF 1e-6 | head -60

Arguments: N (default 64), method (default Radau), rtol (default 1e-4;
atol = rtol / 100). Prints the solver counters and flexmb's own wall time.
"""

from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import flexmb as fm  # noqa: E402
from scenes import b1  # noqa: E402


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    n = int(argv[0]) if len(argv) > 0 else 64
    method = argv[1] if len(argv) > 1 else "Radau"
    rtol = float(argv[2]) if len(argv) > 2 else 1e-4
    system = b1(n).build()
    res = fm.simulate(system, 1.0, method=method, rtol=rtol, atol=rtol * 1e-2, n_out=2, progress=False)
    print(f"B1 N={n} {res.method} rtol {rtol:g}: {res.n_steps} steps, {res.n_rhs} rhs, {res.n_jac} Jacobians, "
          f"wall {res.wall_time:.3f} s")


if __name__ == "__main__":
    main()
