"""Speed of the complement strategies (eigen, svd, qr, auto) on psi sizes typical of flexmb.

For each m x n shape, a random psi (full rank, or rank deficient where
marked) is complemented by each strategy; the table gives the best time per
call of ``strategy.complement(psi)`` in microseconds, single-threaded BLAS,
and checks that the null-space projectors agree with svd's. A second table
sweeps n to place the size threshold of ``auto`` (``AutoComplement.min_n``)
and of the WY form of Q (``flexmb.complements.qr.WY_MIN_N``).

Writes JSON lines to ``benchmarks/results/complements_speed.jsonl``.

Run: ``python benchmarks/complements_speed.py [--quick]``.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # threaded BLAS on a loaded machine times the scheduler, not the method

import argparse  # noqa: E402
import json  # noqa: E402
import timeit  # noqa: E402

import numpy as np  # noqa: E402

import flexmb as fm  # noqa: E402
from flexmb.complements import qr as qrmod  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
NAMES = ("eigen", "svd", "qr", "auto")

#: (label, m, n, rank or None for full rank)
SHAPES = [
    ("random, four-bar size, planar cut", 2, 3, None),
    ("random, wiper size", 9, 33, None),
    ("random, four-bar size, spatial cut", 5, 3, 2),
    ("medium", 30, 300, None),
    ("large", 100, 1000, None),
]


def make_psi(rng, m, n, rank=None):
    """Random psi with singular values in [0.5, 5] and the given rank."""
    r = min(m, n) if rank is None else rank
    U, _ = np.linalg.qr(rng.normal(size=(m, r)))
    V, _ = np.linalg.qr(rng.normal(size=(n, r)))
    return (U * rng.uniform(0.5, 5.0, r)) @ V.T


def wiper_psi():
    """The wiper's actual psi (9 x 33) at its assembled initial state."""
    from flexmb.scenes.wiper import wiper

    model, initial = wiper()
    system = model.build()
    x0, xd0 = fm.initial_state(system, positions=initial)
    psi = system.constraints.evaluate(system.kinematics(0.0, x0, xd0), level=1).psi
    return psi


def best_us(fn, repeat=5):
    """Best time of one call, microseconds."""
    timer = timeit.Timer(fn)
    number, _ = timer.autorange()
    return min(timer.repeat(repeat, number)) / number * 1e6


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="skip the 100 x 1000 case and the sweep's largest n")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    strategies = {name: fm.get_complement(name) for name in NAMES}
    rows = []
    print(f"{'case':<36} {'m x n':>10} " + " ".join(f"{n + ' us':>10}" for n in NAMES) + "  svd/qr  |dP|max")
    for label, m, n, rank in [*SHAPES, ("wiper, actual psi", 9, 33, "wiper")]:
        if args.quick and n > 500:
            continue
        psi = wiper_psi() if rank == "wiper" else make_psi(rng, m, n, rank)
        m, n = psi.shape
        ref = strategies["svd"].complement(psi)
        P = ref.T @ ref.T.T
        dev = max(np.abs(strategies[s].complement(psi).T @ strategies[s].complement(psi).T.T - P).max()
                  for s in NAMES)
        times = {s: best_us(lambda s=s: strategies[s].complement(psi)) for s in NAMES}
        print(f"{label:<36} {f'{m} x {n}':>10} " + " ".join(f"{times[s]:10.1f}" for s in NAMES)
              + f"  {times['svd'] / times['qr']:6.2f}  {dev:.1e}")
        rows.append({"case": label, "m": m, "n": n, "rank": rank, "us": times, "projector_dev": float(dev)})

    print("\nsweep (m = n // 3 + 1): qr with Q by dorgqr and by the WY product, svd")
    print(f"{'n':>6} {'svd us':>10} {'qr-orgqr us':>12} {'qr-wy us':>10}")
    saved = qrmod.WY_MIN_N
    try:
        for n in (3, 6, 9, 12, 16, 24, 33, 48, 64, 96, 128, 256):
            if args.quick and n > 128:
                continue
            psi = make_psi(rng, n // 3 + 1, n)
            t_svd = best_us(lambda: strategies["svd"].complement(psi))
            qrmod.WY_MIN_N = 10**9
            t_org = best_us(lambda: strategies["qr"].complement(psi))
            qrmod.WY_MIN_N = 0
            t_wy = best_us(lambda: strategies["qr"].complement(psi))
            qrmod.WY_MIN_N = saved
            print(f"{n:6d} {t_svd:10.1f} {t_org:12.1f} {t_wy:10.1f}")
            rows.append({"sweep_n": n, "m": n // 3 + 1, "us": {"svd": t_svd, "qr_orgqr": t_org, "qr_wy": t_wy}})
    finally:
        qrmod.WY_MIN_N = saved

    os.makedirs(os.path.join(HERE, "results"), exist_ok=True)
    with open(os.path.join(HERE, "results", "complements_speed.jsonl"), "a") as fh:
        for row in rows:
            fh.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
