"""Work-precision runs of flexmb on the benchmark scenes B1, B2, B4, B5 (BENCHMARKS.md).

For every scene and N: a reference solution of the *same* model at the
tightest affordable settings (Radau, ``--ref-rtol``), cached as a small .npz
in ``benchmarks/results/refs/`` keyed by scene / variant / N / settings, and
a looser reference (10x ``--ref-rtol``) whose distance to it is the
reference's own uncertainty. Then every integrator (Radau, BDF, DOP853 where
the model is not too stiff for it, ``auto``) at every rtol is timed (median
of ``--repeat`` runs, model building timed apart as ``setup_s``) and its
integration error is measured against the reference. For B1 and B2 with
several N, the references themselves give the discretisation error against
the largest N run (written with ``error_kind = "discretisation"``).

One JSON line per configuration, with the fields of BENCHMARKS.md, goes to
``benchmarks/results/flexmb_<scene>.jsonl``.

Run::

    python benchmarks/work_precision.py --quick                # minutes
    python benchmarks/work_precision.py --scenes B2 --n 8 16 32 --rtols 1e-4 1e-6 1e-8

flexmb is used only through its public API (``fm.simulate``, ``Result``), so
a rerun measures whatever flexmb is installed.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import statistics
import sys
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import flexmb as fm  # noqa: E402
from scenes import b1, b2  # noqa: E402

RESULTS = os.path.join(HERE, "results")
REFS = os.path.join(RESULTS, "refs")

#: explicit steps (t_end * omega_max / 3) above which DOP853 is not tried (flexmb's own "auto" limit)
DOP853_STEP_LIMIT = 3000


# ----------------------------------------------------------------------------- scenes

@dataclass
class Scene:
    """How to build, run and read out one benchmark scene.

    ``build(n)`` returns ``(system, simulate_kwargs)``; ``output(result)`` the
    vector whose Euclidean distance to the reference's is the error.
    """

    name: str
    variant: str
    t_end: float
    build: Callable
    output: Callable
    ns: tuple = (0,)
    output_name: str = ""
    sim_kwargs: dict = field(default_factory=dict)


def _beam_tip(res):
    return res.shape("beam")[-1, -1]


def _b2_tip(res):
    return res.body_position("tip")[-1]


def _wiper_tip(res):
    if "right_blade" in res.flexible:
        return res.shape("right_blade")[-1, -1]
    k = res.body_names.index("right_blade")
    return res.origins[-1, k] + res.rotations[-1, k, :, 0] * 0.25


def _b4_build(flexible):
    def build(n):
        from flexmb.scenes.wiper import WiperOptions, wiper

        model, initial = wiper(WiperOptions(flexible=flexible, n_segments=max(n, 1)))
        return model.build(), {"positions": initial}
    return build


def _b5_build(spatial, complement):
    def build(n):
        from flexmb.scenes.fourbar import fourbar

        model, initial, fixed = fourbar(spatial=spatial)
        return model.build(complement=complement), {"positions": initial, "fixed": fixed}
    return build


def scenes(b4_t_end: float = 1.0) -> dict:
    """The scenes by key ``"B1"``, ``"B2"``, ``"B4-rigid"``, ``"B4-flexible"``, ``"B5-<joint>-<complement>"``."""
    out = {
        "B1": Scene("B1", "dynamics damped", 1.0, lambda n: (b1(n).build(), {}), _beam_tip,
                    (4, 8, 16, 32, 64, 128), "beam tip position at t_end, m"),
        "B2": Scene("B2", "dynamics damped", 1.0, lambda n: (b2(n).build(), {}), _b2_tip,
                    (8, 16, 32, 64, 128, 256), "tip mass position at t_end, m"),
        "B4-rigid": Scene("B4", "rigid blades", b4_t_end, _b4_build(False), _wiper_tip, (0,),
                          "right blade tip position at t_end, m"),
        "B4-flexible": Scene("B4", "flexible blades", b4_t_end, _b4_build(True), _wiper_tip, (2, 4, 6),
                             "right blade tip position at t_end, m"),
    }
    for spatial in (False, True):
        for comp in ("svd", "eigen"):
            joint = "spatial" if spatial else "planar"
            out[f"B5-{joint}-{comp}"] = Scene("B5", f"{joint} revolute, {comp} complement", 5.0,
                                              _b5_build(spatial, comp), lambda r: r.x[-1, [0]], (0,),
                                              "crank angle at t_end, rad")
    return out


def expand_scene_names(names, table) -> list:
    """``B5`` selects all B5 variants, ``B4`` both wiper variants, etc."""
    keys = []
    for name in names:
        hits = [k for k in table if k == name or k.split("-")[0] == name]
        if not hits:
            raise SystemExit(f"unknown scene {name!r}; pick from {sorted(table)}")
        keys += [k for k in hits if k not in keys]
    return keys


# ----------------------------------------------------------------------------- runs

def atol_for(rtol: float) -> float:
    """Absolute tolerance used with ``rtol``: flexmb's default ``rtol / 100``."""
    return rtol * 1e-2


def run_once(scene: Scene, n: int, method: str, rtol: float, atol: float | None = None):
    """Build and simulate once (``atol`` None: :func:`atol_for`; ``rtol`` and ``atol`` None: ``simulate``'s defaults).

    Returns
    -------
    tuple
        ``(setup_s, wall_s, cpu_s, result, system)``: the build's wall time,
        the simulation's wall time and its CPU time (this process's, which
        a loaded machine inflates less than the wall time).
    """
    t0 = time.perf_counter()
    system, kw = scene.build(n)
    setup = time.perf_counter() - t0
    t0, c0 = time.perf_counter(), time.process_time()
    if atol is None and rtol is not None:
        atol = atol_for(rtol)  # rtol None: simulate's defaults for both
    res = fm.simulate(system, scene.t_end, method=method, rtol=rtol, atol=atol,
                      n_out=2, progress=False, **kw)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return setup, wall, cpu, res, system


def _ref_path(refdir, scene, n, method, rtol):
    key = f"{scene.name}|{scene.variant}|{n}|{scene.t_end}|{method}|{rtol:g}|{atol_for(rtol):g}"
    digest = hashlib.sha1(key.encode()).hexdigest()[:8]
    return os.path.join(refdir, f"{scene.name}_N{n}_{method}_rtol{rtol:g}_{digest}.npz")


def reference(scene: Scene, n: int, rtol: float, refdir: str = REFS, method: str = "Radau") -> dict:
    """The cached reference solution (computed and stored on first use)."""
    path = _ref_path(refdir, scene, n, method, rtol)
    if os.path.exists(path):
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k].item() if z[k].ndim == 0 else z[k] for k in z.files}
    setup, wall, _, res, system = run_once(scene, n, method, rtol)
    ref = {"output": np.asarray(scene.output(res), float), "setup_s": setup, "wall_s": wall,
           "steps": res.n_steps, "rhs_evals": res.n_rhs, "jac_evals": res.n_jac, "n_coords": system.n_coords,
           "n_dof": res.n_dof, "rtol": rtol, "method": method}
    os.makedirs(refdir, exist_ok=True)
    from flexmb._files import atomic_write

    atomic_write(path, lambda tmp: np.savez(tmp, **ref), suffix=".npz")
    return ref


def _row(scene, n, **kw) -> dict:
    row = {"tool": "flexmb", "scene": scene.name, "variant": scene.variant, "n_segments": n,
           "n_coords": None, "n_dof": None, "integrator": None, "rtol": None, "h": None,
           "setup_s": None, "wall_s": None, "steps": None, "rhs_evals": None, "jac_evals": None,
           "error": None, "error_kind": "integration", "reference": None}
    row.update(kw)
    return row


def integrators_for(scene: Scene, n: int, wanted) -> list:
    """The integrators to run: DOP853 only where an explicit method stays affordable."""
    out = []
    for m in wanted:
        if m == "DOP853":
            system, kw = scene.build(n)
            x0, xd0 = fm.initial_state(system, 0.0, kw.get("positions"), fixed=kw.get("fixed"))
            if scene.t_end * system.highest_frequency(0.0, x0, xd0) / 3.0 > DOP853_STEP_LIMIT:
                continue
        out.append(m)
    return out


def prepare(scene: Scene, n: int, integrators, ref_rtol: float, refdir: str = REFS, log=None) -> dict:
    """What the timed runs of one scene and N need: the reference, its uncertainty, the integrators to run.

    Returns
    -------
    dict
        ``ref`` (from :func:`reference`), ``unc`` (its distance to the
        reference at 10x ``ref_rtol``), ``label`` (the rows' ``reference``)
        and ``methods`` (:func:`integrators_for`).
    """
    log = log or (lambda *a: print(*a, flush=True))
    ref = reference(scene, n, ref_rtol, refdir)
    loose = reference(scene, n, ref_rtol * 10, refdir)
    unc = float(np.linalg.norm(ref["output"] - loose["output"]))
    log(f"{scene.name} {scene.variant} N={n}: reference {ref['wall_s']:.1f} s, uncertainty {unc:.1e}")
    return {"ref": ref, "unc": unc, "label": f"flexmb Radau rtol={ref_rtol:g} atol={atol_for(ref_rtol):g} same N",
            "methods": integrators_for(scene, n, integrators)}


def run_config(scene: Scene, n: int, method: str, rtol: float, prep: dict, atol: float | None = None) -> dict:
    """One timed run of one configuration: its row (``wall_s`` and ``setup_s`` of this run), or a failure row.

    Parameters
    ----------
    scene, n : Scene, int
        What to run.
    method : str
        flexmb method name (``"auto"`` lets flexmb choose).
    rtol : float
        Relative tolerance.
    prep : dict
        From :func:`prepare` for this scene and N.
    atol : float, optional
        Absolute tolerance (default :func:`atol_for`, ``rtol / 100``).
    """
    if atol is None and rtol is not None:
        atol = atol_for(rtol)  # rtol None: simulate's defaults for both
    try:
        s, w, cpu, res, _ = run_once(scene, n, method, rtol, atol)
    except fm.SimulationError as exc:
        return _row(scene, n, integrator=method, rtol=rtol, atol=atol, status=f"failed: {exc}",
                    reference=prep["label"])
    out = np.asarray(scene.output(res), float)
    ref = prep["ref"]
    return _row(
        scene, n, n_coords=int(ref["n_coords"]), n_dof=int(res.n_dof),
        integrator=res.method if method != "auto" else f"auto ({res.method})", rtol=rtol,
        setup_s=s, wall_s=w, cpu_s=cpu, steps=int(res.n_steps), rhs_evals=int(res.n_rhs), jac_evals=int(res.n_jac),
        error=float(np.linalg.norm(out - ref["output"])), reference=prep["label"],
        status="finished" if res.status == "finished" else f"failed: {res.status}: {res.message}",
        atol=atol, t_end=scene.t_end, ref_uncertainty=prep["unc"], output=out.tolist())


def run_scene(scene: Scene, ns, integrators=("Radau", "BDF", "DOP853", "auto"), rtols=(1e-3, 1e-5, 1e-7),
              repeat: int = 3, ref_rtol: float = 1e-10, refdir: str = REFS, log=None) -> list:
    """Work-precision rows (JSON-ready dicts) of one scene over N, integrators and rtols.

    Parameters
    ----------
    scene : Scene
        What to run.
    ns : iterable of int
        Segment counts.
    integrators : iterable of str
        flexmb method names (``"auto"`` lets flexmb choose).
    rtols : iterable of float
        Relative tolerances (``atol = rtol / 100``).
    repeat : int
        Runs per configuration, back to back; the median wall and setup
        times are reported. (``peers/compare.py`` times with
        :func:`run_config` in rounds alternating with the peers instead.)
    ref_rtol : float
        Radau tolerance of the reference; a second reference at 10x is the
        measure of its own error (``ref_uncertainty``).
    refdir : str
        Cache folder of the references.
    log : callable
        Progress printer.

    Returns
    -------
    list of dict
        One row per configuration (BENCHMARKS.md fields, plus ``status``,
        ``atol``, ``t_end``, ``ref_uncertainty``, ``output``).
    """
    log = log or (lambda *a: print(*a, flush=True))
    rows = []
    refs = {}
    for n in ns:
        prep = prepare(scene, n, integrators, ref_rtol, refdir, log)
        refs[n] = prep["ref"]
        for method in prep["methods"]:
            for rtol in rtols:
                runs = []
                for _ in range(repeat):
                    runs.append(run_config(scene, n, method, rtol, prep))
                    if runs[-1]["status"] != "finished":
                        break
                row = runs[-1]
                if row["status"] != "finished":
                    rows.append(row)
                    log(f"  {method:7s} rtol {rtol:7.0e}  {row['status']}")
                    continue
                row["setup_s"] = statistics.median(r["setup_s"] for r in runs)
                row["wall_s"] = statistics.median(r["wall_s"] for r in runs)
                rows.append(row)
                log(f"  {method:7s} rtol {rtol:7.0e}  wall {row['wall_s']:8.3f} s  "
                    f"rhs {row['rhs_evals']:7d}  error {row['error']:9.2e}")
    if len(refs) > 1 and scene.name in ("B1", "B2", "B4"):
        rows += discretisation_rows(scene, refs, ref_rtol)
    return rows


def discretisation_rows(scene: Scene, refs: dict, ref_rtol: float) -> list:
    """Discretisation error of each N's reference against the largest N's (``error_kind = "discretisation"``).

    Parameters
    ----------
    scene : Scene
        The scene the references belong to.
    refs : dict of int to dict
        References by N (from :func:`reference`).
    ref_rtol : float
        Their tolerance (for the labels).

    Returns
    -------
    list of dict
        One row per N below the largest.
    """
    n_top = max(refs)
    rows = []
    for n, ref in sorted(refs.items()):
        if n == n_top:
            continue
        rows.append(_row(
            scene, n, n_coords=int(ref["n_coords"]), n_dof=int(ref["n_dof"]), integrator=str(ref["method"]),
            rtol=float(ref["rtol"]), setup_s=float(ref["setup_s"]), wall_s=float(ref["wall_s"]),
            steps=int(ref["steps"]), rhs_evals=int(ref["rhs_evals"]), jac_evals=int(ref["jac_evals"]),
            error=float(np.linalg.norm(ref["output"] - refs[n_top]["output"])), error_kind="discretisation",
            reference=f"flexmb N={n_top} Radau rtol={ref_rtol:g}", status="finished", t_end=scene.t_end,
            output=np.asarray(ref["output"]).tolist()))
    return rows


def write_jsonl(rows, path: str) -> None:
    """Write rows as JSON lines (atomically)."""
    from flexmb._files import atomic_write

    def write(tmp):
        with open(tmp, "w") as fh:
            for r in rows:
                fh.write(json.dumps(r) + "\n")

    atomic_write(path, write)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=["B1", "B2", "B4", "B5"],
                    help="B1 B2 B4 B5 or variants such as B4-rigid, B5-planar-svd")
    ap.add_argument("--n", nargs="+", type=int, help="segment counts (default: the scene's list; --quick: small)")
    ap.add_argument("--integrators", nargs="+", default=["Radau", "BDF", "DOP853", "auto"])
    ap.add_argument("--rtols", nargs="+", type=float, default=[1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--ref-rtol", type=float, default=1e-10)
    ap.add_argument("--b4-t-end", type=float, default=1.0)
    ap.add_argument("--quick", action="store_true",
                    help="small N (B1 8 16, B2 4 8, B4 rigid 0.25 s), rtols 1e-3 1e-5 1e-7, ref rtol 1e-9")
    ap.add_argument("--out", default=RESULTS)
    ap.add_argument("--discretisation-only", action="store_true",
                    help="only write flexmb_<scene>_discretisation.jsonl from the references already cached for --n")
    args = ap.parse_args(argv)
    if args.discretisation_only:
        table = scenes(args.b4_t_end)
        for key in expand_scene_names(args.scenes, table):
            sc = table[key]
            refs = {n: reference(sc, n, args.ref_rtol, os.path.join(args.out, "refs")) for n in (args.n or sc.ns)}
            rows = discretisation_rows(sc, refs, args.ref_rtol)
            path = os.path.join(args.out, f"flexmb_{sc.name}_discretisation.jsonl")
            write_jsonl(rows, path)
            print(f"wrote {len(rows)} lines to {path}")
        return
    if args.quick:
        args.rtols = [1e-3, 1e-5, 1e-7]
        args.ref_rtol = min(max(args.ref_rtol, 1e-9), 1e-9)
        args.b4_t_end = 0.25
    table = scenes(args.b4_t_end)
    keys = expand_scene_names(args.scenes, table)
    if args.quick:
        keys = [k for k in keys if k != "B4-flexible"]
    quick_n = {"B1": (8, 16), "B2": (4, 8), "B4": (2,), "B5": (0,)}
    variants = {table[k].variant for k in keys}
    by_scene = {}
    for key in keys:
        sc = table[key]
        ns = args.n if args.n and sc.name in ("B1", "B2") else (quick_n[sc.name] if args.quick else sc.ns)
        if sc.name == "B4" and args.n and sc.variant.startswith("flexible"):
            ns = args.n
        if sc.ns == (0,):  # rigid scenes have no segment count
            ns = (0,)
        path = os.path.join(args.out, f"flexmb_{sc.name}.jsonl")
        if sc.name not in by_scene:  # keep the other variants' rows of an earlier run of this scene
            by_scene[sc.name] = []
            if os.path.exists(path):
                with open(path) as fh:
                    by_scene[sc.name] = [r for r in map(json.loads, fh) if r.get("variant") not in variants]
        rows = by_scene[sc.name]
        rows.extend(run_scene(sc, ns, args.integrators, args.rtols, args.repeat, args.ref_rtol,
                              os.path.join(args.out, "refs")))
        write_jsonl(rows, path)  # after every scene variant, so an interrupted run keeps what it did
        print(f"wrote {len(rows)} lines to {path}", flush=True)


if __name__ == "__main__":
    main()
