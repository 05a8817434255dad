"""Open every VTK file below a folder with ParaView's own readers (run with pvpython, not pytest).

    pvpython --force-offscreen-rendering tests/paraview_reads.py FOLDER [FOLDER ...]

Every ``.vtu`` through ParaView's XML unstructured-grid reader, every
``.pvd`` through its PVD reader at each of its times: the number of points
and cells each holds (from the file's own ``Piece``), the times the
``.pvd`` lists, the body names in the field data, and Warp By Vector
taking ``elastic_displacement``. Prints one line per folder; exits 1
naming every file that fails. Needs ParaView's Python only (used by
``tests/test_export_readers.py`` and ``.ci/run``).
"""

import glob
import os
import sys
import xml.etree.ElementTree as ET

from paraview import simple as pv


def _piece(vtu):
    """Points and cells of a .vtu, from its XML."""
    piece = ET.parse(vtu).getroot().find("UnstructuredGrid/Piece")
    return int(piece.get("NumberOfPoints")), int(piece.get("NumberOfCells"))


def _check(reader, path, expected, problems, time=None):
    if time is None:
        reader.UpdatePipeline()
    else:
        reader.UpdatePipeline(time)
    info = reader.GetDataInformation()
    got = (info.GetNumberOfPoints(), info.GetNumberOfCells())
    if got != expected:
        problems.append(f"{path}{'' if time is None else f' at t = {time}'}: ParaView read {got[0]} points and "
                        f"{got[1]} cells, the file holds {expected[0]} and {expected[1]}")
    if not any(key.startswith("body:") for key in reader.FieldData.keys()):
        problems.append(f"{path}: no body names (field data 'body:<name>') in {reader.FieldData.keys()}")


def check_folder(folder, problems):
    """Read every file below ``folder``; append what is wrong to ``problems``; return the counts read."""
    vtus = sorted(glob.glob(os.path.join(folder, "**", "*.vtu"), recursive=True))
    pvds = sorted(glob.glob(os.path.join(folder, "**", "*.pvd"), recursive=True))
    if not vtus or not pvds:
        problems.append(f"{folder}: expected .vtu and .pvd files, found {len(vtus)} and {len(pvds)}")
    for path in vtus:
        _check(pv.XMLUnstructuredGridReader(FileName=[path]), path, _piece(path), problems)
    for path in pvds:
        sets = ET.parse(path).getroot().find("Collection").findall("DataSet")
        reader = pv.PVDReader(FileName=path)
        reader.UpdatePipelineInformation()
        times = reader.TimestepValues
        times = [float(times)] if isinstance(times, (int, float)) else [float(t) for t in times]
        listed = [float(d.get("timestep")) for d in sets]
        if times != listed:
            problems.append(f"{path}: ParaView's times {times} are not the listed ones {listed}")
        for d in sets:
            _check(reader, path, _piece(os.path.join(os.path.dirname(path), d.get("file"))), problems,
                   float(d.get("timestep")))
        vectors = list(pv.WarpByVector(Input=reader).Vectors)
        if vectors != ["POINTS", "elastic_displacement"]:
            problems.append(f"{path}: Warp By Vector takes {vectors}, not the elastic displacement")
    return len(vtus), len(pvds)


def main(folders):
    problems = []
    for folder in folders:
        n_vtu, n_pvd = check_folder(folder, problems)
        print(f"ParaView {pv.GetParaViewVersion()}: read {n_vtu} .vtu and {n_pvd} .pvd files below {folder}")
    for problem in problems:
        print(f"FAILED {problem}", file=sys.stderr)
    return 1 if problems or not folders else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
