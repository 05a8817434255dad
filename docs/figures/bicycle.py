"""Write ``docs/figures/bicycle.png``: the benchmark bicycle of ``docs/validation.md``.

Left: the eigenvalues of the upright, straight-running linearisation
(``flexmb.scenes.bicycle.upright_eigenvalues``) against the forward speed,
real parts solid, imaginary parts dotted, with the values of Meijaard et al.
(2007), Table 2, as circles and the weave and capsize speeds found by
``weave_and_capsize_speeds``. Right: the nonlinear run at 4.6 m/s after a
push to a lean rate of 0.5 rad/s (``tests/test_bicycle.py``), lean and
steer, with the linear model's ``exp(A t) s0`` dashed. Run from the
repository::

    python docs/figures/bicycle.py
"""

import sys
from pathlib import Path

import matplotlib
import numpy as np
import scipy.linalg as sla

matplotlib.use("Agg")

from matplotlib.figure import Figure  # noqa: E402

from flexmb.scenes.bicycle import (benchmark_bicycle, linearize_upright, upright_eigenvalues,  # noqa: E402
                                   weave_and_capsize_speeds)

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "tests"))
import test_bicycle as t  # noqa: E402


def main():
    system = benchmark_bicycle().build()
    fig = Figure(figsize=(11.0, 4.2))
    left, right = fig.subplots(1, 2)

    speeds = np.linspace(0.0, 10.0, 201)
    ev = np.array([np.sort_complex(upright_eigenvalues(system, v)) for v in speeds])
    for k in range(4):
        left.plot(speeds, ev[:, k].real, "k.", ms=1.5)
        left.plot(speeds, np.abs(ev[:, k].imag), ".", color="tab:blue", ms=1.0)
    for v in range(11):
        ref = t.published(v)
        left.plot([v] * 4, ref.real, "o", mfc="none", color="tab:red", ms=6)
        left.plot([v] * 4, np.abs(ref.imag), "s", mfc="none", color="tab:blue", ms=5)
    weave, capsize = weave_and_capsize_speeds(system)
    for s in (weave, capsize):
        left.axvline(s, color="0.6", lw=0.8)
    left.axhline(0.0, color="0.3", lw=0.6)
    left.set_ylim(-10, 10)
    left.set_xlabel("forward speed v, m/s")
    left.set_ylabel("eigenvalue, 1/s")
    left.set_title(f"real (black), |imag| (blue); Table 2 circles\nweave {weave:.8f}, capsize {capsize:.8f} m/s",
                   fontsize=9)

    v, push, t_end = 4.6, 0.5, 5.0
    res = t.pushed(system, v, push, t_end, rtol=1e-9, atol=1e-11, n_out=501)
    lin = linearize_upright(system, v)
    s0 = np.zeros(len(lin.states))
    s0[lin.states.index("frame.lean rate")] = push
    linear = np.array([sla.expm(lin.A * tt) @ s0 for tt in res.t])
    for name, colour in (("frame.lean", "tab:red"), ("steer.angle", "tab:green")):
        right.plot(res.t, np.degrees(res.x[:, res.coordinate_names.index(name)]), color=colour,
                   label=f"{name}, nonlinear")
        right.plot(res.t, np.degrees(linear[:, lin.states.index(name)]), "--", color=colour, lw=0.9,
                   label=f"{name}, linear")
    right.axhline(0.0, color="0.3", lw=0.6)
    right.set_xlabel("time, s")
    right.set_ylabel("angle, deg")
    right.set_title("pushed at 4.6 m/s to a lean rate of 0.5 rad/s", fontsize=9)
    right.legend(fontsize=8)
    fig.tight_layout()
    out = HERE / "bicycle.png"
    fig.savefig(out, dpi=110)
    print(out)


if __name__ == "__main__":
    main()
