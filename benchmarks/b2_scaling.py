"""B2 cost against N up to N = 256: wall time per simulated second (Radau, rtol 1e-4).

rtol 1e-4 gives integration errors of 1e-8..1e-7 m at N = 16..64 against
the references of ``work_precision.py`` (``results/summary.md``); at
N = 128 and 256 no reference is computed (it would take hours), so these
rows have no error. Prints one JSON line per N; the committed run is
``results/flexmb_B2_scaling.jsonl``.

Run: ``python benchmarks/b2_scaling.py 16 32 64 128 256`` (about 2 minutes).
"""

import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import flexmb as fm  # noqa: E402
from scenes import b2  # noqa: E402

for N in [int(a) for a in sys.argv[1:]]:
    s = b2(N).build()
    t0 = time.perf_counter(); c0 = time.process_time()
    r = fm.simulate(s, 1.0, rtol=1e-4, method="Radau", n_out=2)
    row = {"tool": "flexmb", "scene": "B2", "variant": "scaling, no reference", "n_segments": N, "n_coords": s.n_coords,
           "integrator": "Radau", "rtol": 1e-4, "wall_s": time.perf_counter() - t0, "cpu_s": time.process_time() - c0,
           "steps": r.n_steps, "rhs_evals": r.n_rhs, "jac_evals": r.n_jac, "status": r.status}
    print(json.dumps(row), flush=True)
