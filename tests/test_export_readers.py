"""Every VTK file of a `flexmb run` opens in meshio, pyvista and ParaView, and holds what the Result holds.

issue #32, section 2: meshio stopped at flexmb's string arrays ("Illegal data type 'String'",
SystemExit). The runs: the main job's wiper (a short one) and tutorial 06's cantilever scene. meshio
is a core dependency; pyvista comes with the viz extra and ParaView (pvpython) from the system: those
tests skip without them (.ci/run installs both).
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np
import pytest

import flexmb as fm
from flexmb.export import vtk
from flexmb.scenes.wiper import WiperOptions, wiper

TUTORIALS = Path(__file__).resolve().parent.parent / "tutorials"
TOL = 1e-12


def _run(*args):
    proc = subprocess.run([sys.executable, "-m", "flexmb", "run", *map(str, args), "--quiet"], capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """(folder, [(Result, the system it came from, the .pvd)]) of a short wiper run and of tutorial 06's scene."""
    root = tmp_path_factory.mktemp("runs")
    _run("wiper", "--out", root / "wiper", "--t-end", 0.05, "--n-out", 6)
    _run(TUTORIALS / "06_export_paraview.toml", "--out", root / "cantilever", "--t-end", 0.03, "--n-out", 4)
    out = []
    for label in ("rigid", "flexible"):
        model, _ = wiper(WiperOptions(flexible=label == "flexible"))
        out.append((fm.Result.load(root / "wiper" / f"wiper_{label}.npz"), model.build(),
                    root / "wiper" / f"vtk_{label}" / f"wiper_{label}.pvd"))
    scene = fm.load_scene(TUTORIALS / "06_export_paraview.toml")
    out.append((fm.Result.load(root / "cantilever" / "cantilever.npz"), scene.model.build(),
                root / "cantilever" / "vtk" / "cantilever.pvd"))
    return root, out


def _listed(pvd):
    """(time, file) of every data set of a .pvd."""
    return [(float(d.get("timestep")), pvd.parent / d.get("file"))
            for d in ET.parse(pvd).getroot().find("Collection").findall("DataSet")]


def _centre_line(mesh, body):
    """The points of a flexible body's centre line, root to tip."""
    for block, b, part, seg in zip(mesh.cells, *(mesh.cell_data[k] for k in ("body_id", "part_id", "segment"))):
        if block.type == "line":
            lines = block.data[(b == body) & (part == vtk.PARTS.index("centre line"))]
            order = np.argsort(seg[(b == body) & (part == vtk.PARTS.index("centre line"))])
            if len(lines):
                return np.append(lines[order, 0], lines[order[-1], 1])
    raise AssertionError(f"no centre line for body {body}")


def _check_against_result(mesh, res, system, i):
    """A file read back (a meshio mesh) against output i of the Result it was written from."""
    names = vtk.body_names(res)
    assert mesh.field_data["time"][0] == mesh.field_data["TimeValue"][0] == res.t[i]
    assert vtk.table_names(mesh.field_data) == names
    assert vtk.table_names(mesh.field_data, "joint") == [j.name for j in system.model.joints]
    assert vtk.table_names(mesh.field_data, "part") == list(vtk.PARTS)
    d = mesh.point_data["elastic_displacement"]
    body_of_point = np.full(len(mesh.points), -1)
    for block, b in zip(mesh.cells, mesh.cell_data["body_id"]):
        body_of_point[block.data] = b[:, None]
    rows = list(res.body_names)
    for b, name in enumerate(names):
        if name in res.flexible:
            # the centre line is the Result's shape; its elastic displacement is the shape minus the straight
            # body carried by its clamp frame (or first segment), from the Result's frames
            line = _centre_line(mesh, b)
            np.testing.assert_allclose(mesh.points[line], res.shape(name)[i], rtol=0, atol=TOL)
            seg_rows, length = res.flexible[name]
            frame = rows.index(f"{name}.base") if f"{name}.base" in rows else seg_rows[0]
            s = length * np.arange(len(seg_rows) + 1)
            straight = res.origins[i, frame] + np.outer(s, res.rotations[i, frame][:, 0])
            np.testing.assert_allclose(d[line], res.shape(name)[i] - straight, rtol=0, atol=TOL)
            for k in range(len(seg_rows)):
                assert mesh.point_data["bending_y"][line[k]] == res.coordinate(f"{name}.j{k}.bend_y")[i]
        else:
            np.testing.assert_array_equal(d[body_of_point == b], 0.0)  # rigid: nothing to warp
            shape = [blk.data[(bb == b) & (p == vtk.PARTS.index("shape"))] for blk, bb, p in
                     zip(mesh.cells, mesh.cell_data["body_id"], mesh.cell_data["part_id"])]
            ends = mesh.points[np.concatenate([c.ravel() for c in shape])]
            k = rows.index(name)
            # the uniform box (or bar) of the body's inertia, centred at its mass centre
            np.testing.assert_allclose(ends.mean(axis=0), res.positions[i, k], rtol=0, atol=TOL)
            if len(ends) == 2:  # a bar from its frame origin through its mass centre and as far again
                assert np.linalg.norm(ends - res.origins[i, k], axis=1).min() < TOL


def test_every_file_reads_in_meshio_and_matches_the_result(runs):
    root, sets = runs
    for res, system, pvd in sets:
        listed = _listed(pvd)
        assert [t for t, _ in listed] == list(res.t)
        assert sorted(p.name for _, p in listed) == sorted(p.name for p in pvd.parent.glob("*.vtu"))
        with pytest.raises(meshio.ReadError):  # meshio has no reader for a collection: read what it lists
            meshio.read(pvd)
        for i, (_, path) in enumerate(listed):
            mesh = meshio.read(path)
            _check_against_result(mesh, res, system, i)
        if res.flexible:  # at the last output something has bent: the comparisons are not of zeros
            assert np.abs(mesh.point_data["elastic_displacement"]).max() > 1e-5
            assert np.nanmax(mesh.point_data["von_mises"]) > 1e5
    assert sum(len(_listed(pvd)) for *_, pvd in sets) == 6 + 6 + 4


def test_every_file_reads_in_pyvista_as_in_meshio(runs):
    pv = pytest.importorskip("pyvista", reason="pyvista comes with the viz extra")
    root, sets = runs
    for res, system, pvd in sets:
        reader = pv.get_reader(str(pvd))
        np.testing.assert_array_equal(reader.time_values, res.t)
        for i, (t, path) in enumerate(_listed(pvd)):
            mesh = meshio.read(path)
            reader.set_active_time_value(t)
            for grid in (pv.read(path), reader.read()[0]):
                np.testing.assert_array_equal(grid.points, mesh.points)
                assert set(grid.point_data.keys()) == set(mesh.point_data)
                for name, values in mesh.point_data.items():
                    np.testing.assert_array_equal(grid.point_data[name], values)
                for name, values in mesh.cell_data.items():
                    np.testing.assert_array_equal(grid.cell_data[name], np.concatenate(values))
                assert set(grid.field_data.keys()) == set(mesh.field_data)
                assert vtk.table_names(grid.field_data) == vtk.body_names(res)
                assert grid.point_data.active_vectors_name == "elastic_displacement"


def test_every_file_reads_in_paraview(runs):
    pvpython = shutil.which("pvpython")
    if pvpython is None:
        pytest.skip("ParaView (pvpython) is not installed (Debian: apt-get install paraview)")
    root, _ = runs
    script = Path(__file__).resolve().parent / "paraview_reads.py"
    proc = subprocess.run([pvpython, "--force-offscreen-rendering", str(script), str(root / "wiper"),
                           str(root / "cantilever")], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    assert "read 12 .vtu and 2 .pvd files" in proc.stdout and "read 4 .vtu and 1 .pvd files" in proc.stdout
