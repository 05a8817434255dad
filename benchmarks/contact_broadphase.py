"""CPU cost of one right-hand side with a contact group, against the number of segments N (#30 item 4).

    OPENBLAS_NUM_THREADS=1 python benchmarks/contact_broadphase.py
    OPENBLAS_NUM_THREADS=1 python benchmarks/contact_broadphase.py --n 64 256 1024 --repeats 3

Two cases, each timed with and without its contact group (the difference
is the contact's own cost):

* ``plane``: a clamped beam of N segments (bending in the x-z plane) lying
  on the ground's plane, every segment a capsule against it
  (``ContactGroup([Capsules(beam)], [Plane()])``: 2 N rows, about half of
  them touching): the issue's "1,000-segment body against a plane";
* ``beam_on_beam`` (``--pairs``): the same beam's N capsules against a
  second beam's N capsules, crossed above its middle: N^2 pairs, a few
  touching. The group is a block of the tables: the broad phase
  (``flexmb.kernels.broadphase``, a uniform grid) finds the pairs whose
  boxes overlap, about linear in N; ``brute`` times the same group with
  every pair tested (``ContactGroup``'s ``BROAD_PHASE_PAIRS`` raised past
  N^2), quadratic.

CPU time (process_time) per call of ``System.state_rate`` over many calls
after a warm-up, the least of ``--repeats``; the summary fits
``cost ~ N^p`` to the contact's share and to the whole. Rows go to
``benchmarks/results/contact_broadphase.jsonl``.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

import flexmb as fm
import flexmb.forces.contact_groups as groups
from flexmb.forces.tables import class_tables
from flexmb.kernels.broadphase import block_candidates

BROAD = groups.BROAD_PHASE_PAIRS
HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "results", "contact_broadphase.jsonl")
R = 0.0025


def _beam(name, n):
    return fm.FlexibleBody(name, 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material.aluminium(), n_segments=n,
                           keep=("bend_y",))


def build(case, n, with_contact, broad=True):
    """The system of a case at N, and a state with half of the beam's segments pressed into the plane.

    ``broad=False``: a group against a group has every pair tested (no block for the broad phase).
    """
    groups.BROAD_PHASE_PAIRS = BROAD if broad else 10 ** 18
    model = fm.Model()
    beam = _beam("beam", n)
    law = fm.LinearContactLaw(1e5, 20.0)
    model.add(fm.Fixed("root", model.ground, beam, parent_point=(0, 0, R + 2.5e-4)), fm.Gravity((0, 0, -9.81)))
    if case == "plane":
        if with_contact:
            model.add(fm.ContactGroup("floor", [fm.Capsules(beam, R)], [fm.Plane()], law, fm.CoulombLaw(0.3, 1e-3)))
    else:
        other = _beam("other", n)
        model.add(fm.Fixed("root2", model.ground, other, parent_point=(0.5, -0.5, 2 * R - 1e-4),
                           parent_frame=_rot_z(np.pi / 2), child_frame=np.eye(3)))
        if with_contact:
            model.add(fm.ContactGroup("cross", [fm.Capsules(beam, R)], [fm.Capsules(other, R)], law))
    system = model.build()
    rng = np.random.default_rng(0)
    x = np.zeros(system.n_coords)
    # bent down (2e-3 rad over the length, the tip 1 mm lower): its outer half in the plane, its middle on the
    # crossed beam
    x[: n] = 2e-3 / n * (1.0 + 0.1 * rng.normal(size=n))
    xd = 1e-3 * rng.normal(size=system.n_coords)
    return system, np.concatenate([x, xd])


def _rot_z(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def cost(fn, calls):
    fn()
    t = time.process_time()
    for _ in range(calls):
        fn()
    return (time.process_time() - t) / calls


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, nargs="+", default=[16, 64, 256, 1024])
    p.add_argument("--pairs", type=int, nargs="*", default=[16, 32, 64, 128, 256, 500],
                   help="N of the beam_on_beam case (none: skip it)")
    p.add_argument("--calls", type=int, default=200)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--out", default=OUT)
    a = p.parse_args(argv)
    cases = [("plane", n) for n in a.n] + [("beam_on_beam", n) for n in a.pairs]
    systems = {(c, n, w): build(c, n, w) for c, n in cases for w in (True, False)}
    systems.update({("beam_on_beam", n, "brute"): build("beam_on_beam", n, True, broad=False) for n in a.pairs})
    best = {}
    for _ in range(a.repeats):
        for key, (system, y) in systems.items():
            best[key] = min(best.get(key, np.inf), cost(lambda: system.state_rate(0.0, y), a.calls))
    rows = []
    for c, n in cases:
        system, y = systems[c, n, True]
        group = next(e for e in system.model.forces if isinstance(e, fm.ContactGroup))
        kin = system.kinematics(0.0, y[: system.n_coords], y[system.n_coords:])
        _, _, fn, _, _, _, _, _ = fm.ContactGroup.row_states([group], kin)
        rows.append({"case": c, "n_segments": n, "n_rows": int(fn.size), "n_touching": int(np.sum(fn > 0)),
                     "rhs_cpu_us": 1e6 * best[c, n, True], "rhs_without_contact_cpu_us": 1e6 * best[c, n, False],
                     "contact_cpu_us": 1e6 * (best[c, n, True] - best[c, n, False]),
                     "calls": a.calls, "repeats": a.repeats, "load_avg_1min": os.getloadavg()[0]})
        t = class_tables(fm.ContactGroup, [group], system.topology)
        if len(t.contact_blocks):  # the broad phase's pairs, and the same group with every pair tested
            found = block_candidates(t.contact_blocks, t.sweep_rows, t.sweep_local, t.sweep_radius,
                                     t.contact_block_map, kin.R, kin.origin)
            brute, z = systems[c, n, "brute"]
            same = bool(np.array_equal(system.state_rate(0.0, y), brute.state_rate(0.0, z)))
            rows[-1].update({"n_pairs_found": int(found.size), "identical_to_every_pair": same,
                             "brute_rhs_cpu_us": 1e6 * best[c, n, "brute"],
                             "brute_contact_cpu_us": 1e6 * (best[c, n, "brute"] - best[c, n, False])})
        print(json.dumps(rows[-1]), flush=True)
    for c in ("plane", "beam_on_beam"):
        mine = [r for r in rows if r.get("case") == c]
        if len(mine) > 1:
            logn = np.log([r["n_segments"] for r in mine])
            fit = {k: float(np.polyfit(logn, np.log([max(r[k], 1e-3) for r in mine]), 1)[0])
                   for k in ("rhs_cpu_us", "contact_cpu_us", "brute_contact_cpu_us") if k in mine[0]}
            rows.append({"summary": c, "fitted_exponent": fit, "n": [r["n_segments"] for r in mine]})
            print(json.dumps(rows[-1]), flush=True)
    os.makedirs(os.path.dirname(a.out), exist_ok=True)
    text = "".join(json.dumps(r) + "\n" for r in rows)
    tmp = a.out + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(tmp, a.out)


if __name__ == "__main__":
    main()
