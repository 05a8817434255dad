"""flexmb with numba's JIT disabled (``NUMBA_DISABLE_JIT=1``): the kernels run as Python.

numba's debugging switch makes its ``njit`` return the Python function;
flexmb must then import and run (slowly), its kernels' intrinsic views
given their Python meaning, the runs that would call compiled C callbacks
stepping in Python instead (:mod:`flexmb.kernels.interpreted`). The runs
are compared with the same runs compiled, in this process.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np

#: a pendulum (CVODE BDF, generalized-alpha) and a four-bar (CVODE BDF, a loop): final coordinates and counts
RUNS = r"""
import numpy as np
import flexmb as fm


def runs():
    model = fm.Model("pendulum")
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model.add(fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1)), fm.Gravity((0.0, -9.81, 0.0)))
    out = {}
    for method in ("CVODE_BDF", "GeneralizedAlpha"):
        res = fm.simulate(model, t_end=1.0, positions={"pin": np.radians(30.0)}, method=method, n_out=11)
        out["pendulum " + method] = (res.status, res.coordinate("pin").tolist(), float(np.ptp(res.energy)),
                                     res.n_steps, res.n_rhs)
    loop = fm.Model("fourbar")
    crank = fm.RigidBody.slender_bar("crank", mass=0.1, length=0.1)
    coupler = fm.RigidBody.slender_bar("coupler", mass=0.3, length=0.3)
    rocker = fm.RigidBody.slender_bar("rocker", mass=0.25, length=0.25)
    loop.add(fm.Revolute("A", loop.ground, crank), fm.Revolute("B", crank, coupler, parent_point=(0.1, 0, 0)),
             fm.Revolute("D", loop.ground, rocker, parent_point=(0.3, 0, 0)),
             fm.PlanarRevolute("C", coupler, rocker, parent_point=(0.3, 0, 0), child_point=(0.25, 0, 0)),
             fm.Gravity((0.0, -9.81, 0.0)))
    res = fm.simulate(loop, t_end=0.2, positions={"A": np.pi / 4}, method="CVODE_BDF", n_out=5)
    out["fourbar"] = (res.status, res.coordinate("A").tolist(), float(np.ptp(res.energy)), res.n_steps, res.n_rhs)
    return out
"""

#: in the process with the JIT disabled: the kernels are Python functions, the compiled loops refused clearly
NOJIT = RUNS + r"""
import json
import numba
from flexmb.errors import FlexmbError
from flexmb.genalpha.compiled import CompiledGeneralizedAlpha, compiled_genalpha
from flexmb.integrators.cvode_direct import DirectCVODEBDF
from flexmb.integrators.direct_choice import compiled_loop
from flexmb.integrators.sundials import CVODEBDF
from flexmb.kernels import tree, views

assert numba.config.DISABLE_JIT
assert type(tree.tree_kinematics).__name__ == "function", type(tree.tree_kinematics)
assert tree.view3 is not views.view3  # the intrinsic bound to its Python meaning in the kernels' module
for cls in (DirectCVODEBDF, CompiledGeneralizedAlpha):
    try:
        cls(None, 0.0, np.zeros(2), 1.0, rtol=1e-6, atol=1e-8, system=None)
    except FlexmbError as e:
        assert "NUMBA_DISABLE_JIT" in str(e), e
    else:
        raise AssertionError(f"{cls.__name__} made without the JIT")
system = fm.Model("p")
system.add(fm.Revolute("pin", system.ground, fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)))
system = system.build()
assert compiled_loop(system, CVODEBDF, False, None) is None
assert compiled_genalpha(system, fm.GeneralizedAlpha, False, None, False) is None
print("RUNS", json.dumps(runs()))
"""


def test_flexmb_runs_with_the_jit_disabled():
    env = dict(os.environ, NUMBA_DISABLE_JIT="1", OPENBLAS_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", NOJIT], capture_output=True, text=True, env=env, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    python = json.loads(out.stdout.split("RUNS ", 1)[1])
    namespace = {}
    exec(RUNS, namespace)  # noqa: S102 - the same runs, compiled
    compiled = json.loads(json.dumps(namespace["runs"]()))
    assert python.keys() == compiled.keys()
    for name, (status, coords, drift, steps, rhs) in compiled.items():
        assert status == "finished", (name, status)
        assert python[name][0] == status, name
        np.testing.assert_allclose(python[name][1], coords, rtol=0, atol=1e-10, err_msg=name)
        assert python[name][3:] == [steps, rhs], (name, python[name][3:], steps, rhs)
        assert abs(python[name][2] - drift) <= 1e-10, (name, python[name][2], drift)
