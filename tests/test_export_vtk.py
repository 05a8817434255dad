"""VTK export: files read back with meshio match the Result; the .pvd lists every step."""

from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import attrs
import meshio
import numpy as np
import pytest

import flexmb as fm
from flexmb.export import vtk

from conftest import fourbar, fourbar_initial

TOL = 1e-12


@pytest.fixture(scope="module")
def fourbar_result():
    return fm.simulate(fourbar(), 0.1, positions=fourbar_initial(), n_out=21)


@pytest.fixture(scope="module")
def cantilever():
    """Clamped aluminium beam sagging under gravity; returns (system, beam, result)."""
    model = fm.Model("cantilever")
    beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.01), fm.Material.aluminium(),
                           n_segments=4, keep=("bend_y", "bend_z"))
    model.add(fm.Fixed("clamp", model.ground, beam), fm.Gravity((0.0, 0.0, -9.81)))
    system = model.build()
    # explicit and loose: this short run is about the files, not the dynamics
    res = fm.simulate(system, 0.05, n_out=6, method="DOP853", rtol=1e-6)
    return system, beam, res


def _read_all(pvd: Path):
    root = ET.parse(pvd).getroot()
    sets = root.find("Collection").findall("DataSet")
    return root, [(float(d.get("timestep")), pvd.parent / d.get("file")) for d in sets]


def test_import_keeps_writers_out():
    code = ("import sys, flexmb, flexmb.export, flexmb.viz; "
            "print(*[m in sys.modules for m in ('meshio', 'pyvista', 'matplotlib')])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "False", "False"]


def test_fourbar_files_match_result(fourbar_result, tmp_path):
    res = fourbar_result
    pvd = res.export_vtk(tmp_path, prefix="fb")
    assert pvd == tmp_path / "fb.pvd"
    assert vtk.body_names(res) == res.body_names  # all rigid, in result order
    _, sets = _read_all(pvd)
    assert len(sets) == len(res.t)
    for i, (t, path) in enumerate(sets):
        mesh = meshio.read(path)
        # rigid body k: point 2k is its frame origin, point 2k + 1 its mass centre
        np.testing.assert_allclose(mesh.points[0::2], res.origins[i], rtol=0, atol=TOL)
        np.testing.assert_allclose(mesh.points[1::2], res.positions[i], rtol=0, atol=TOL)
        ref0 = np.stack([res.origins[0], res.positions[0]], axis=1).reshape(-1, 3)
        np.testing.assert_allclose(mesh.point_data["displacement"], mesh.points - ref0, rtol=0, atol=TOL)
        assert mesh.field_data["time"][0] == res.t[i]
        assert mesh.cells_dict["line"].shape == (3, 2) and mesh.cells_dict["vertex"].shape == (3, 1)
        np.testing.assert_array_equal(mesh.cell_data_dict["body_id"]["line"], [0, 1, 2])
        for name in ("bending_y", "bending_z", "torsion"):
            np.testing.assert_array_equal(mesh.point_data[name], 0.0)


def test_cantilever_files_match_result(cantilever, tmp_path):
    system, beam, res = cantilever
    shape = res.shape("beam")
    pvd = vtk.export_vtk(res, tmp_path / "out")
    _, sets = _read_all(pvd)
    assert vtk.body_names(res) == ["beam"]  # segments and clamp frame drawn as one body
    fd_velocity = np.gradient(shape, res.t, axis=0, edge_order=2)
    for i, (t, path) in enumerate(sets):
        mesh = meshio.read(path)
        np.testing.assert_allclose(mesh.points, shape[i], rtol=0, atol=TOL)
        np.testing.assert_allclose(mesh.point_data["displacement"], shape[i] - shape[0], rtol=0, atol=TOL)
        np.testing.assert_allclose(mesh.point_data["velocity"], fd_velocity[i], rtol=0, atol=TOL)
        # joint j<k> sits at centre-line point k; the tip carries no joint
        for coord, name in (("bend_y", "bending_y"), ("bend_z", "bending_z")):
            expected = [res.coordinate(f"beam.j{k}.{coord}")[i] for k in range(4)] + [0.0]
            np.testing.assert_allclose(mesh.point_data[name], expected, rtol=0, atol=TOL)
        np.testing.assert_array_equal(mesh.point_data["torsion"], 0.0)
        assert "axial" not in mesh.point_data
        np.testing.assert_array_equal(mesh.cell_data_dict["segment"]["line"], [0, 1, 2, 3])
    assert np.min(shape[-1, :, 2]) < -1e-3  # it did sag: the comparison is not of zeros


def test_pvd_lists_every_step_in_order(fourbar_result, tmp_path):
    res = fourbar_result
    pvd = vtk.export_vtk(res, tmp_path)
    root, sets = _read_all(pvd)
    assert root.tag == "VTKFile" and root.get("type") == "Collection"
    times = [t for t, _ in sets]
    assert times == list(res.t)  # written with repr: exact
    files = [p for _, p in sets]
    assert all(p.is_file() for p in files)
    assert [p.name for p in files] == [f"flexmb_{i:04d}.vtu" for i in range(len(res.t))]
    for d in root.iter("DataSet"):
        assert not Path(d.get("file")).is_absolute()
    # nothing but the collection and its files, no temporary left over
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([pvd.name] + [p.name for p in files])


def test_write_pvd_in_another_folder(fourbar_result, tmp_path):
    paths = vtk.write_vtu(fourbar_result, tmp_path / "data", prefix="run")
    pvd = vtk.write_pvd(paths, fourbar_result.t, tmp_path / "run.pvd")
    _, sets = _read_all(pvd)
    assert [p.resolve() for _, p in sets] == [p.resolve() for p in paths]
    assert ET.parse(pvd).getroot().find("Collection")[0].get("file") == "data/run_0000.vtu"


def test_exact_velocities_with_the_system(fourbar_result):
    res = fourbar_result
    system = fourbar().build()
    for i in (0, 7, len(res.t) - 1):
        exact = vtk.to_meshio(res, i, system=system).point_data["velocity"]
        # crank origin is the ground pivot A: at rest
        np.testing.assert_allclose(exact[0], 0.0, atol=1e-12)
        if 0 < i < len(res.t) - 1:
            # central differences over dt = 5 ms agree to O(dt^2)
            fd = vtk.to_meshio(res, i).point_data["velocity"]
            np.testing.assert_allclose(fd, exact, atol=5e-3 * np.max(np.abs(exact)))


def test_triad_adds_body_axes(fourbar_result):
    mesh = vtk.to_meshio(fourbar_result, 3, triad=0.05)
    pts = mesh.points.reshape(3, 5, 3)  # per body: origin, mass centre, x, y, z tips
    axes = (pts[:, 2:] - pts[:, :1]) / 0.05
    np.testing.assert_allclose(axes.transpose(0, 2, 1), fourbar_result.rotations[3], atol=TOL)
    assert len(mesh.cells_dict["line"]) == 12


def test_snapshot(cantilever, tmp_path):
    system, beam, res = cantilever
    x, xd = res.x[-1], res.xd[-1]
    path = vtk.export_snapshot(system, x, tmp_path / "snap.vtu", xd=xd, t=0.05)
    mesh = meshio.read(path)
    np.testing.assert_allclose(mesh.points, system.shape(beam, x), rtol=0, atol=TOL)
    np.testing.assert_allclose(mesh.point_data["displacement"], system.shape(beam, x) - system.shape(beam, 0 * x),
                               rtol=0, atol=TOL)
    np.testing.assert_allclose(mesh.point_data["velocity"][0], 0.0, atol=TOL)  # clamped root
    assert mesh.field_data["time"][0] == 0.05


def test_modes(cantilever, tmp_path):
    system, beam, _ = cantilever
    f, shapes = fm.modes(system, 2)
    paths = vtk.export_modes(system, f, shapes, tmp_path, scale=0.05)
    assert [p.name for p in paths] == ["mode_01.vtu", "mode_02.vtu"]
    for k, path in enumerate(paths):
        mesh = meshio.read(path)
        np.testing.assert_allclose(mesh.points, system.shape(beam, 0.05 * shapes[:, k]), rtol=0, atol=TOL)
        assert mesh.field_data["frequency"][0] == f[k]
        assert mesh.field_data["mode"][0] == k + 1


@pytest.mark.parametrize("i", [21, -22, 1.5, "0"])
def test_bad_output_index(fourbar_result, i):
    with pytest.raises(fm.ExportError, match="output index"):
        vtk.to_meshio(fourbar_result, i)


def test_bad_results(fourbar_result, cantilever, tmp_path):
    with pytest.raises(fm.FlexmbError, match="no field"):
        vtk.to_meshio(object(), 0)
    with pytest.raises(fm.ExportError, match="origins"):
        vtk.write_vtu(attrs.evolve(fourbar_result, origins=fourbar_result.origins[:, :2]), tmp_path)
    _, _, res = cantilever
    with pytest.raises(fm.ExportError, match="segment rows"):
        vtk.to_meshio(attrs.evolve(res, flexible={"beam": ([1, 2, 99], 0.25)}), 0)
    with pytest.raises(fm.ExportError, match="system does not match"):
        vtk.to_meshio(fourbar_result, 0, system=cantilever[0])
    with pytest.raises(fm.ExportError, match="triad"):
        vtk.to_meshio(fourbar_result, 0, triad=-1.0)
    with pytest.raises(fm.ExportError, match="prefix"):
        vtk.write_vtu(fourbar_result, tmp_path, prefix="a/b")
    assert list(tmp_path.iterdir()) == []


def test_bad_pvd_and_state_input(cantilever, tmp_path):
    system, _, res = cantilever
    paths = vtk.write_vtu(res, tmp_path)
    with pytest.raises(fm.ExportError, match="one time per file"):
        vtk.write_pvd(paths, res.t[:-1], tmp_path / "a.pvd")
    with pytest.raises(fm.ExportError, match="increasing"):
        vtk.write_pvd(paths, res.t[::-1], tmp_path / "a.pvd")
    with pytest.raises(fm.ExportError, match="not found"):
        vtk.write_pvd([tmp_path / "missing.vtu"], [0.0], tmp_path / "a.pvd")
    with pytest.raises(fm.ExportError, match="coordinates"):
        vtk.export_snapshot(system, np.zeros(3), tmp_path / "s.vtu")
    with pytest.raises(fm.ExportError, match="shapes"):
        vtk.export_modes(system, [1.0, 2.0], np.zeros((system.n_coords, 3)), tmp_path)
    assert not (tmp_path / "a.pvd").exists() and not (tmp_path / "s.vtu").exists()


def test_failed_write_leaves_nothing(fourbar_result, tmp_path, monkeypatch):
    def broken(path, mesh, **kw):
        Path(path).write_text("<VTKFile")  # half a file, then the disk fills up
        raise OSError("disk full")

    monkeypatch.setattr(vtk.meshio, "write", broken)
    with pytest.raises(OSError, match="disk full"):
        vtk.export_vtk(fourbar_result, tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_mixed_model_layout(tmp_path):
    """A rigid hub carrying a clamped beam, and a pinned beam keeping axial and torsion."""
    model = fm.Model("mixed")
    hub = fm.RigidBody.slender_bar("hub", 1.0, 0.2)
    sec, mat = fm.Section.rectangular(0.02, 0.01), fm.Material.aluminium()
    blade = fm.FlexibleBody("blade", 1.0, sec, mat, n_segments=3, keep=("bend_z",))
    rod = fm.FlexibleBody("rod", 0.5, sec, mat, n_segments=3, keep=("axial", "torsion"), clamped=False)
    model.add(fm.Revolute("spin", model.ground, hub, axis=(0, 0, 1)),
              fm.Fixed("root", hub, blade, parent_point=(0.2, 0, 0)),
              fm.Revolute("pin", model.ground, rod, parent_point=(0, 1, 0), axis=(0, 0, 1)))
    system = model.build()
    x = np.random.default_rng(1).uniform(-0.05, 0.05, system.n_coords)
    mesh = meshio.read(vtk.export_snapshot(system, x, tmp_path / "s.vtu"))
    # hub: origin and mass centre; blade: 4 points; rod: 4 points
    assert len(mesh.points) == 2 + 4 + 4
    np.testing.assert_allclose(mesh.points[2:6], system.shape(blade, x), atol=TOL)
    np.testing.assert_allclose(mesh.points[6:], system.shape(rod, x), atol=TOL)
    names = system.coordinate_names
    value = {n: x[k] for k, n in enumerate(names)}
    np.testing.assert_array_equal(mesh.point_data["bending_z"][2:6], [value[f"blade.j{k}.bend_z"] for k in range(3)]
                                  + [0.0])
    # the unclamped rod has joints j1, j2 only: its root point carries none
    for coord in ("axial", "torsion"):
        np.testing.assert_array_equal(mesh.point_data[coord][6:],
                                      [0.0] + [value[f"rod.j{k}.{coord}"] for k in (1, 2)] + [0.0])
        np.testing.assert_array_equal(mesh.point_data[coord][:6], 0.0)
    np.testing.assert_array_equal(mesh.cell_data_dict["body_id"]["line"], [0, 1, 1, 1, 2, 2, 2])
