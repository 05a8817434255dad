"""Wall time of the VTK export of the main job's two wiper runs (what `flexmb run wiper` writes).

    OPENBLAS_NUM_THREADS=1 python benchmarks/export_vtk.py [--n-out 501] [--repeat 5]

Simulates the rigid and the flexible wiper over 1 s as the main job does
(rtol 1e-6, 501 outputs), then times ``export_vtk(result, folder,
system=system)`` into a fresh temporary folder, ``--repeat`` times, and
prints the best and the median wall time per run. The export's cost is
mostly creating and renaming one file per output time, so it depends on
the file system as much as on the CPU.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time

import numpy as np

import flexmb as fm
from flexmb.export.vtk import export_vtk
from flexmb.scenes.wiper import WiperOptions, wiper


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-out", type=int, default=501)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args(argv)
    for flexible in (False, True):
        model, initial = wiper(WiperOptions(flexible=flexible))
        system = model.build(complement="svd")
        res = fm.simulate(system, 1.0, positions=initial, rtol=1e-6, n_out=args.n_out, progress=False)
        times = []
        for _ in range(args.repeat):
            folder = tempfile.mkdtemp()
            start = time.perf_counter()
            export_vtk(res, folder, prefix="wiper", system=system)
            times.append(time.perf_counter() - start)
            shutil.rmtree(folder)
        label = "flexible" if flexible else "rigid"
        print(f"{label:8s}: {len(res.t)} files, best {min(times):.3f} s, median {np.median(times):.3f} s")


if __name__ == "__main__":
    main()
