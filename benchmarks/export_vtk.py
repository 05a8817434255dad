"""Wall time of the VTK export of the main job's two wiper runs: flexmb's writer against VTK's own.

    OPENBLAS_NUM_THREADS=1 python benchmarks/export_vtk.py [--n-out 501] [--repeat 5]

Simulates the rigid and the flexible wiper over 1 s as the main job does
(rtol 1e-6, 501 outputs), then writes each run's files, ``--repeat``
rounds, alternating in every round:

* ``flexmb``: ``export_vtk(result, folder, system=system)``, flexmb's own
  XML writer (:mod:`flexmb.export.vtu`, inline base64 binary);
* ``vtk``: the same meshes (the same layout, positions, velocities and
  section data) written by VTK's ``vtkXMLUnstructuredGridWriter`` (the
  ``viz`` extra: ``vtk`` comes with pyvista), with its defaults (appended
  binary, zlib) and with the compressor off (``vtk_raw``), each file
  through a temporary name and ``os.replace`` as flexmb does, and the
  same ``.pvd``. The cells and cell data are built once per run (they do
  not change), each frame sets its points, point data and field data.

Each variant writes into a fresh temporary folder. Prints and appends to
``benchmarks/results/export_vtk.jsonl`` the least wall time of each
variant over the rounds and its ratio to flexmb's. The export's cost is
mostly creating and renaming one file per output time, so it depends on
the file system as much as on the CPU.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

import flexmb as fm
from flexmb.export.layout import _VTK_CELLS
from flexmb.export.meshes import _meshes
from flexmb.export.vtk import _check_prefix, export_vtk, write_pvd
from flexmb.scenes.wiper import WiperOptions, wiper

RESULTS = Path(__file__).resolve().parent / "results"


def export_with_vtk(result, folder, prefix, system, compress=True) -> Path:
    """The files of :func:`export_vtk`, written by VTK's XML writer (for this benchmark only)."""
    from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray
    from vtkmodules.vtkCommonCore import VTK_UNSIGNED_CHAR
    from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkUnstructuredGrid
    from vtkmodules.vtkCommonCore import vtkPoints
    from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridWriter

    prefix = _check_prefix(prefix)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    nt = len(result.t)
    width = max(4, len(str(nt - 1)))
    writer = vtkXMLUnstructuredGridWriter()
    writer.SetHeaderTypeToUInt64()
    if not compress:
        writer.SetCompressorTypeToNone()
    grid, keep, paths = None, [], []
    for i, mesh in enumerate(_meshes(result, range(nt), system, 0.0)):
        if grid is None:  # the cells and cell data, once
            grid = vtkUnstructuredGrid()
            conn = np.concatenate([np.asarray(b.data, dtype=np.int64).ravel() for b in mesh.cells])
            offsets = np.concatenate([[0], np.cumsum([n for b in mesh.cells for n in [b.data.shape[1]] * len(b.data)])])
            types = np.concatenate([np.full(len(b.data), _VTK_CELLS[b.type], dtype=np.uint8) for b in mesh.cells])
            cells = vtkCellArray()
            keep += [conn, offsets, types]
            cells.SetData(numpy_to_vtkIdTypeArray(offsets.astype(np.int64)), numpy_to_vtkIdTypeArray(conn))
            grid.SetCells(numpy_to_vtk(types, deep=True, array_type=VTK_UNSIGNED_CHAR), cells)
            for name, values in mesh.cell_data.items():
                a = numpy_to_vtk(np.concatenate(values), deep=True)
                a.SetName(name)
                grid.GetCellData().AddArray(a)
        points = vtkPoints()
        points.SetData(numpy_to_vtk(np.ascontiguousarray(mesh.points), deep=True))
        grid.SetPoints(points)
        pd = grid.GetPointData()
        for name, values in mesh.point_data.items():
            a = numpy_to_vtk(np.ascontiguousarray(values), deep=True)
            a.SetName(name)
            pd.AddArray(a)
        pd.SetActiveVectors("elastic_displacement")
        fd = grid.GetFieldData()
        fd.Initialize()
        for name, values in mesh.field_data.items():
            a = numpy_to_vtk(np.ravel(values), deep=True)
            a.SetName(name)
            fd.AddArray(a)
        path = folder / f"{prefix}_{i:0{width}d}.vtu"
        tmp = folder / f".{path.name}.tmp"
        writer.SetFileName(str(tmp))
        writer.SetInputData(grid)
        if writer.Write() != 1:
            raise RuntimeError(f"VTK could not write {tmp}")
        os.replace(tmp, path)
        paths.append(path)
    return write_pvd(paths, result.t, folder / f"{prefix}.pvd")


VARIANTS = {
    "flexmb": lambda res, folder, system: export_vtk(res, folder, prefix="wiper", system=system),
    "vtk": lambda res, folder, system: export_with_vtk(res, folder, "wiper", system),
    "vtk_raw": lambda res, folder, system: export_with_vtk(res, folder, "wiper", system, compress=False),
}


def _size(folder) -> int:
    return sum(p.stat().st_size for p in Path(folder).iterdir())


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-out", type=int, default=501)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--out", default=str(RESULTS / "export_vtk.jsonl"))
    args = parser.parse_args(argv)
    rows = []
    for flexible in (False, True):
        label = "flexible" if flexible else "rigid"
        model, initial = wiper(WiperOptions(flexible=flexible))
        system = model.build(complement="svd")
        res = fm.simulate(system, 1.0, positions=initial, rtol=1e-6, n_out=args.n_out, progress=False)
        times = {name: [] for name in VARIANTS}
        sizes = {}
        for _ in range(args.repeat):  # alternating: every variant once per round
            for name, run in VARIANTS.items():
                folder = tempfile.mkdtemp()
                start = time.perf_counter()
                run(res, folder, system)
                times[name].append(time.perf_counter() - start)
                sizes[name] = _size(folder)
                shutil.rmtree(folder)
        best = {name: min(v) for name, v in times.items()}
        for name, v in times.items():
            row = {"benchmark": "export_vtk", "run": label, "writer": name, "files": len(res.t),
                   "repeat": args.repeat, "min_s": best[name], "median_s": float(np.median(v)), "times_s": v,
                   "ratio_to_flexmb": best[name] / best["flexmb"], "bytes": sizes[name],
                   "host": platform.node(), "blas_threads": os.environ.get("OPENBLAS_NUM_THREADS"),
                   "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
            rows.append(row)
            print(f"{label:8s} {name:8s}: {len(res.t)} files, {sizes[name] / 1e6:.1f} MB, min {best[name]:.3f} s, "
                  f"median {np.median(v):.3f} s, {best[name] / best['flexmb']:.2f} x flexmb")
    with open(args.out, "a", encoding="utf-8") as f:
        for row in rows:
            f.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
