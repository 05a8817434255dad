"""The hand-written floor of B1: what numpy and scipy alone can do (BENCHMARKS.md, "Peers").

B1 (the planar cantilever of BENCHMARKS.md) written by hand as a planar
N-link chain in minimal coordinates, with nothing general about it:

- coordinates: the N relative bending angles eta_i (BENCHMARKS.md's eta2,
  a rotation about the moving y axis; the beam lies along +x, gravity
  along -z, so a positive angle bends the beam down), absolute angles
  ``theta = S eta`` with ``S`` the lower triangle of ones;
- segment i (0-based) of length l, mass m, central inertia about y
  ``J = m (l^2 + h^2) / 12``, its axis ``e_i = (cos theta_i, -sin theta_i)``
  in the x-z plane, its mass centre ``c_i = l sum_{j<i} e_j + (l/2) e_i``;
- Lagrange's equations in the absolute angles, closed form:
  ``M_theta = m l^2 (mu o cos(theta_j - theta_k)) + J I`` with
  ``mu_jk = N - max(j, k) - 1/2`` off the diagonal and ``N - j - 3/4`` on
  it (``mu_jk = sum_i a_ij a_ik``, ``a_ij = 1, 1/2, 0`` for ``j <, =, > i``),
  velocity products ``m l^2 (mu o sin(theta_j - theta_k)) thetad_k^2`` and
  gravity ``m g l (N - j - 1/2) cos theta_j``, all from outer products of
  ``cos theta`` and ``sin theta`` (no loop over segments);
- in the relative angles ``M = S^T M_theta S``, ``f = S^T f_theta - K eta
  - C etad`` with springs ``k = E I_y / l`` (the clamp joint ``2 k``) and
  dampers ``C = beta K``.

It is integrated by ``scipy.integrate.solve_ivp`` (BDF and Radau) given
the constant Jacobian of the straight state ``[[0, I], [-M0^-1 K,
-M0^-1 C]]`` (gravity's stiffness vanishes there: ``d/dtheta cos theta =
0`` at ``theta = 0``), over rtol 1e-3 .. 1e-8 (atol = rtol / 100, as in
``work_precision.py``), 1 s, released straight from rest, damped.

The script measures, on the same machine in the same run, the floor and
flexmb (``fm.simulate`` with Radau, BDF and ``auto``; flexmb's default is
``auto`` at rtol 1e-8) against flexmb's cached reference of the same model
(``work_precision.reference``, Radau rtol 1e-9): integration error of the
tip position at t = 1 s, median wall time of ``--repeat`` runs, and the
least wall time reaching an error <= 1e-6 m. The rtol grid has
half-decades (1e-3, 3e-4, ..., 1e-6, then 1e-7, 1e-8) so that "least wall
time" is not decided by where a decade happens to fall. Then the best
setting of each (least wall time at error <= 1e-6 m) is timed again,
alternately, ``--duel-repeat`` times: that ratio is the one to quote, as
both saw the same machine load. One JSON line per configuration
(BENCHMARKS.md fields, plus ``method``, ``status``, ``atol``, ``output``)
goes to ``benchmarks/results/floor_B1.jsonl``, the alternate-run ratios
to ``floor_B1_ratio.json``; a table with the ratios flexmb / floor is
printed.

Run::

    OPENBLAS_NUM_THREADS=1 python benchmarks/floor_b1.py                 # N = 16 and 64
    OPENBLAS_NUM_THREADS=1 python benchmarks/floor_b1.py --n 16 --skip-flexmb
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.linalg import cho_factor, cho_solve

HERE = os.path.dirname(os.path.abspath(__file__))
if HERE not in sys.path:
    sys.path.insert(0, HERE)

RESULTS = os.path.join(HERE, "results")
TOOL = "floor (hand-written numpy)"
TARGET = 1e-6  #: integration error (m) the "least wall time" is measured at
GRAVITY = 9.81

# B1 data of BENCHMARKS.md (written out here, not imported from flexmb: the floor is independent of it)
L, B, H = 1.0, 0.02, 0.005
E, RHO = 70e9, 2700.0
BETA = 7.7398e-4


@dataclass
class ChainB1:
    """The B1 beam as a planar N-link chain (minimal coordinates, dense numpy).

    Parameters
    ----------
    n : int
        Number of segments N.
    damped : bool
        Stiffness-proportional dampers ``C = beta K`` (BENCHMARKS.md).
    gravity : float
        Gravity along -z, m/s^2.
    """

    n: int
    damped: bool = True
    gravity: float = GRAVITY

    def __post_init__(self):
        n = self.n
        self.l = L / n
        self.m = RHO * B * H * self.l
        self.J = self.m * (self.l**2 + H**2) / 12.0
        k = E * (B * H**3 / 12.0) / self.l
        self.k = np.full(n, k)
        self.k[0] = 2.0 * k  # the clamp joint lumps half a segment
        self.c = (BETA if self.damped else 0.0) * self.k
        j = np.arange(n)
        mu = n - np.maximum.outer(j, j) - 0.5
        mu[j, j] = n - j - 0.75
        self.ml2mu = self.m * self.l**2 * mu
        self.grav = self.m * self.gravity * self.l * (n - j - 0.5)

    # -- the closed-form equations
    def mass_and_force(self, eta, etad):
        """Mass matrix and force array in the relative angles.

        Parameters
        ----------
        eta, etad : ndarray, shape (N,)
            Relative angles (rad) and their rates.

        Returns
        -------
        M : ndarray, shape (N, N)
            ``S^T M_theta S``.
        f : ndarray, shape (N,)
            ``S^T (gravity - velocity products) - K eta - C etad``.
        """
        theta = np.cumsum(eta)
        thd = np.cumsum(etad)
        c, s = np.cos(theta), np.sin(theta)
        cosd = np.outer(c, c) + np.outer(s, s)  # cos(theta_j - theta_k)
        sind = np.outer(s, c) - np.outer(c, s)  # sin(theta_j - theta_k)
        Mt = self.ml2mu * cosd
        Mt[np.diag_indices(self.n)] += self.J
        ft = self.grav * c - (self.ml2mu * sind) @ (thd * thd)
        # S^T A S: reversed cumulative sums over both axes
        M = np.cumsum(np.cumsum(Mt[::-1], axis=0)[::-1][:, ::-1], axis=1)[:, ::-1]
        f = np.cumsum(ft[::-1])[::-1] - self.k * eta - self.c * etad
        return M, f

    def accelerations(self, eta, etad):
        """Relative angular accelerations, rad/s^2 (Cholesky solve of ``M etadd = f``)."""
        M, f = self.mass_and_force(eta, etad)
        return cho_solve(cho_factor(M, check_finite=False), f, check_finite=False)

    def rhs(self, t, y):
        """``d/dt (eta, etad)`` for ``solve_ivp``."""
        n = self.n
        return np.concatenate([y[n:], self.accelerations(y[:n], y[n:])])

    def jacobian0(self):
        """Constant Jacobian of the straight state, ``[[0, I], [-M0^-1 K, -M0^-1 C]]``."""
        n = self.n
        M0, _ = self.mass_and_force(np.zeros(n), np.zeros(n))
        cf = cho_factor(M0)
        Jac = np.zeros((2 * n, 2 * n))
        Jac[:n, n:] = np.eye(n)
        Jac[n:, :n] = -cho_solve(cf, np.diag(self.k))
        Jac[n:, n:] = -cho_solve(cf, np.diag(self.c))
        return Jac

    def tip(self, eta):
        """Beam tip position (x, y, z), m: the outer end of the last segment."""
        theta = np.cumsum(eta)
        return np.array([self.l * np.sum(np.cos(theta)), 0.0, -self.l * np.sum(np.sin(theta))])

    def simulate(self, method="BDF", rtol=1e-6, atol=None, t_end=1.0, jac=None):
        """Released straight from rest; returns ``(tip at t_end, solve_ivp result)``."""
        n = self.n
        atol = rtol * 1e-2 if atol is None else atol
        jac = self.jacobian0() if jac is None else jac
        sol = solve_ivp(self.rhs, (0.0, t_end), np.zeros(2 * n), method=method, rtol=rtol, atol=atol, jac=jac)
        if sol.status != 0:
            raise RuntimeError(f"floor {method} rtol {rtol:g} failed: {sol.message}")
        return self.tip(sol.y[:n, -1]), sol


def model(n, damped=True, gravity=GRAVITY):
    """The floor's B1 model with N segments (see :class:`ChainB1`)."""
    return ChainB1(n, damped, gravity)


# ----------------------------------------------------------------------------- measurements

def _row(n, **kw):
    row = {"tool": TOOL, "scene": "B1", "variant": "dynamics damped", "n_segments": n, "n_coords": n, "n_dof": n,
           "integrator": None, "rtol": None, "h": None, "setup_s": None, "wall_s": None, "steps": None,
           "rhs_evals": None, "jac_evals": None, "error": None, "error_kind": "integration", "reference": None}
    row.update(kw)
    return row


def run_floor(n, ref, ref_label, methods, rtols, repeat, log):
    """Rows of the floor over methods and rtols."""
    rows = []
    for method in methods:
        for rtol in rtols:
            setups, walls = [], []
            for _ in range(repeat):
                t0 = time.perf_counter()
                chain = model(n)
                jac = chain.jacobian0()
                setups.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                tip, sol = chain.simulate(method, rtol, jac=jac)
                walls.append(time.perf_counter() - t0)
            err = float(np.linalg.norm(tip - ref))
            rows.append(_row(n, integrator=f"scipy {method}, constant Jacobian of the straight state", rtol=rtol,
                             setup_s=statistics.median(setups), wall_s=statistics.median(walls),
                             steps=int(sol.t.size - 1), rhs_evals=int(sol.nfev), jac_evals=int(sol.njev),
                             error=err, reference=ref_label, status="finished", atol=rtol * 1e-2, t_end=1.0,
                             output=tip.tolist(), method=method, n_lu=int(sol.nlu)))
            log(f"  floor  {method:6s} rtol {rtol:7.0e}  wall {statistics.median(walls):8.3f} s  "
                f"rhs {sol.nfev:6d}  lu {sol.nlu:4d}  error {err:9.2e}")
    return rows


def run_flexmb(n, scene, ref, ref_label, methods, rtols, repeat, log):
    """Rows of flexmb (``work_precision.run_once``) over methods and rtols."""
    import flexmb as fm
    import work_precision as wp

    rows = []
    for method in methods:
        for rtol in rtols:
            setups, walls = [], []
            for _ in range(repeat):
                s, w, _, res, system = wp.run_once(scene, n, method, rtol)
                setups.append(s)
                walls.append(w)
            out = np.asarray(scene.output(res), float)
            err = float(np.linalg.norm(out - ref))
            label = res.method if method != "auto" else f"auto ({res.method})"
            rows.append(wp._row(scene, n, n_coords=system.n_coords, n_dof=int(res.n_dof), integrator=label,
                                rtol=rtol, setup_s=statistics.median(setups), wall_s=statistics.median(walls),
                                steps=int(res.n_steps), rhs_evals=int(res.n_rhs), jac_evals=int(res.n_jac),
                                error=err, reference=ref_label, status="finished", atol=wp.atol_for(rtol),
                                t_end=scene.t_end, output=out.tolist(), method=method,
                                flexmb_version=getattr(fm, "__version__", "")))
            log(f"  flexmb {method:6s} rtol {rtol:7.0e}  wall {statistics.median(walls):8.3f} s  "
                f"rhs {res.n_rhs:6d}  jac {res.n_jac:4d}  error {err:9.2e}")
    return rows


def best(rows, target=TARGET):
    """The row of least wall time with an integration error <= target, or None."""
    ok = [r for r in rows if r.get("error") is not None and r["error"] <= target]
    return min(ok, key=lambda r: r["wall_s"]) if ok else None


def table(rows, ns, target=TARGET):
    """Markdown table: per N, the floor's and flexmb's least wall time at error <= target, and the ratios."""
    lines = [f"| N | tool | setting | error, m | wall, s | flexmb / floor |", "|---|---|---|---|---|---|"]
    for n in ns:
        at_n = [r for r in rows if r["n_segments"] == n]
        floor = best([r for r in at_n if r["tool"] == TOOL], target)
        fx = [r for r in at_n if r["tool"] == "flexmb"]
        default = [r for r in fx if r.get("method") == "auto" and r["rtol"] == 1e-8]  # fm.simulate's default
        picks = [("floor, best", floor)]
        picks += [(f"flexmb, best {m}", best([r for r in fx if r.get("method") == m], target))
                  for m in ("Radau", "BDF", "auto")]
        picks += [("flexmb, default (auto, rtol 1e-8)", default[0] if default else None)]
        for name, r in picks:
            if r is None:
                lines.append(f"| {n} | {name} | none reaches {target:g} | | | |")
                continue
            ratio = f"{r['wall_s'] / floor['wall_s']:.2f}" if floor and r["tool"] != TOOL else "—"
            lines.append(f"| {n} | {name} | {r['integrator'].split(',')[0]}, rtol {r['rtol']:g} | "
                         f"{r['error']:.1e} | {r['wall_s']:.3f} | {ratio} |")
    return "\n".join(lines)


def duel(n, scene, floor_row, flexmb_row, ref, repeat, log):
    """The two best settings timed again, alternately, so that both see the same machine load.

    Returns
    -------
    dict
        Median wall times of each and their ratio flexmb / floor.
    """
    import work_precision as wp

    chain = model(n)
    jac = chain.jacobian0()
    walls = {"floor": [], "flexmb": []}
    for _ in range(repeat):
        t0 = time.perf_counter()
        tip, _ = chain.simulate(floor_row["method"], floor_row["rtol"], jac=jac)
        walls["floor"].append(time.perf_counter() - t0)
        _, w, _, res, _ = wp.run_once(scene, n, flexmb_row["method"], flexmb_row["rtol"])
        walls["flexmb"].append(w)
    out = {"n_segments": n, "floor": f"{floor_row['method']} rtol {floor_row['rtol']:g}",
           "flexmb": f"{flexmb_row['integrator']} rtol {flexmb_row['rtol']:g}",
           "floor_wall_s": statistics.median(walls["floor"]), "flexmb_wall_s": statistics.median(walls["flexmb"]),
           "floor_error": float(np.linalg.norm(tip - ref)),
           "flexmb_error": float(np.linalg.norm(np.asarray(scene.output(res), float) - ref)), "repeat": repeat}
    out["ratio"] = out["flexmb_wall_s"] / out["floor_wall_s"]
    log(f"  alternate runs, N={n}: floor {out['floor']} {out['floor_wall_s']:.3f} s, flexmb {out['flexmb']} "
        f"{out['flexmb_wall_s']:.3f} s, ratio {out['ratio']:.2f}")
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", nargs="+", type=int, default=[16, 64])
    ap.add_argument("--rtols", nargs="+", type=float,
                    default=[1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 1e-7, 1e-8])
    ap.add_argument("--auto-rtols", nargs="+", type=float, default=[1e-8],
                    help="rtols of flexmb's 'auto' (default: 1e-8, flexmb's default; it picks Radau on B1)")
    ap.add_argument("--methods", nargs="+", default=["BDF", "Radau"], help="the floor's scipy methods")
    ap.add_argument("--flexmb-methods", nargs="+", default=["Radau", "BDF", "auto"])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--duel-repeat", type=int, default=5,
                    help="alternate runs of the best floor and best flexmb setting per N (0: none)")
    ap.add_argument("--ref-rtol", type=float, default=1e-9)
    ap.add_argument("--skip-flexmb", action="store_true")
    ap.add_argument("--out", default=os.path.join(RESULTS, "floor_B1.jsonl"))
    args = ap.parse_args(argv)
    import work_precision as wp

    log = lambda *a: print(*a, flush=True)  # noqa: E731
    scene = wp.scenes()["B1"]
    rows, duels = [], []
    for n in args.n:
        ref = wp.reference(scene, n, args.ref_rtol)
        ref_out = np.asarray(ref["output"], float)
        ref_label = f"flexmb Radau rtol={args.ref_rtol:g} atol={wp.atol_for(args.ref_rtol):g} same N"
        log(f"B1 N={n}: reference tip {ref_out}")
        at_n = run_floor(n, ref_out, ref_label, args.methods, args.rtols, args.repeat, log)
        if not args.skip_flexmb:
            for method in args.flexmb_methods:
                rtols = args.auto_rtols if method == "auto" else args.rtols
                at_n += run_flexmb(n, scene, ref_out, ref_label, [method], rtols, args.repeat, log)
        rows += at_n
        wp.write_jsonl(rows, args.out)  # after every N, so an interrupted run keeps what it did
        b_floor, b_fm = best([r for r in at_n if r["tool"] == TOOL]), best([r for r in at_n if r["tool"] == "flexmb"])
        if args.duel_repeat and b_floor and b_fm:
            duels.append(duel(n, scene, b_floor, b_fm, ref_out, args.duel_repeat, log))
    print(f"wrote {len(rows)} lines to {args.out}")
    if duels:
        path = os.path.splitext(args.out)[0] + "_ratio.json"
        with open(path, "w") as fh:
            json.dump(duels, fh, indent=1)
        print(f"wrote {path}")
    print(table(rows, args.n))
    for d in duels:
        print(f"N = {d['n_segments']}: alternate runs ({d['repeat']} each), flexmb {d['flexmb']} "
              f"{d['flexmb_wall_s']:.3f} s / floor {d['floor']} {d['floor_wall_s']:.3f} s = {d['ratio']:.2f}")


if __name__ == "__main__":
    main()
