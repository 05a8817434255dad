"""Write ``docs/figures/statics_paths.png``: the load paths of ``docs/statics.md`` against their closed forms.

Left: the elastica (N = 64, a dead tip force P = alpha E I / L^2, alpha up
to 20) followed by ``fm.load_path``, tip drop against alpha, with the
elliptic-integral solution at alpha = 1, 2, 5, 10, 20. Right: the von Mises
truss of the page (N = 8 per bar) loaded to twice its limit load, apex drop
against load, with the closed form P(w) and the limit points. The models
and references are those of ``tests/test_statics.py``. Run from the
repository::

    python docs/figures/statics_paths.py
"""

import sys
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")

from matplotlib.figure import Figure  # noqa: E402
from scipy.optimize import minimize_scalar  # noqa: E402

import flexmb as fm  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "tests"))
import test_statics as t  # noqa: E402


def main():
    fig = Figure(figsize=(10.0, 4.0))
    left, right = fig.subplots(1, 2)

    alphas = np.array([1.0, 2.0, 5.0, 10.0, 20.0])
    path = fm.load_path(t.elastica(64, alphas[-1]), "P", options=fm.PathOptions(max_step=0.05))
    drop = [t.beam_tip(x)[1] for x in path.x]
    left.plot(alphas[-1] * path.lam, drop, ".-", label="load_path, N = 64")
    left.plot(alphas, [t.elastica_tip(a)[1] for a in alphas], "ko", mfc="none", label="closed form")
    left.set_xlabel("alpha = P L^2 / (E I) (-)")
    left.set_ylabel("tip drop v / L (-)")
    left.set_title("elastica")
    left.legend(fontsize="small")

    a, h = 1.0, 0.05
    _, _, k = t.von_mises_truss(1.0, a=a, h=h)
    best = minimize_scalar(lambda w: -t.truss_load(w, k, a, h), bounds=(0.0, h), method="bounded",
                           options={"xatol": 1e-12})
    p_lim = -best.fun
    system, bar, _ = t.von_mises_truss(2 * p_lim, a=a, h=h)
    path = fm.load_path(system, "P", options=fm.PathOptions(max_step=0.1))
    w = np.array([t.apex_drop(system, bar, x, h) for x in path.x])
    ws = np.linspace(0.0, w[-1], 400)
    right.plot(1e3 * ws, t.truss_load(ws, k, a, h) / 1e3, "k-", lw=0.8, label="closed form P(w)")
    right.plot(1e3 * w, 2 * p_lim * path.lam / 1e3, ".", label="load_path, N = 8 per bar")
    lim = path.limit_points
    right.plot([1e3 * t.apex_drop(system, bar, p.x, h) for p in lim], [2 * p_lim * p.lam / 1e3 for p in lim],
               "rv", label="limit points")
    right.set_xlabel("apex drop w (mm)")
    right.set_ylabel("load P (kN)")
    right.set_title("von Mises truss")
    right.legend(fontsize="small")
    fig.tight_layout()
    fig.savefig(HERE / "statics_paths.png", dpi=90)
    print(f"elastica: {len(drop)} points; truss: P_lim = {p_lim:.1f} N, {len(w)} points, "
          f"limit loads {[round(float(2 * p_lim * p.lam), 1) for p in lim]} N")


if __name__ == "__main__":
    main()
