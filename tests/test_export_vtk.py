"""VTK export: files read back match the Result; bodies meet at their joints; the .pvd lists every step."""

from __future__ import annotations

import contextlib
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import attrs
import meshio
import numpy as np
import pytest

import flexmb as fm
from flexmb.export import snapshots, vtk, vtu
from flexmb.export.layout import _Layout

from conftest import fourbar, fourbar_initial, random_chain

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


def _cells(mesh, ctype):
    """Connectivity and cell data of one cell type of a mesh."""
    for k, block in enumerate(mesh.cells):
        if block.type == ctype:
            return block.data, {name: values[k] for name, values in mesh.cell_data.items()}
    return np.zeros((0, 1), dtype=int), {name: np.zeros(0, dtype=int) for name in mesh.cell_data}


def _markers(mesh):
    """(body id, joint id) -> position of that body's joint point."""
    data, cd = _cells(mesh, "vertex")
    part = vtk.PARTS.index("joint")
    return {(int(b), int(j)): mesh.points[p[0]] for p, b, j, q in
            zip(data, cd["body_id"], cd["joint_id"], cd["part_id"]) if q == part}


def _segment_distance(p, a, b):
    d = b - a
    s = np.clip(np.dot(p - a, d) / max(np.dot(d, d), 1e-300), 0.0, 1.0)
    return np.linalg.norm(p - (a + s * d))


def _on_body(mesh, body, p) -> float:
    """Distance from p to the drawn lines, faces and boxes of one body (joint vertices left out)."""
    best = np.inf
    for block, cb, part in zip(mesh.cells, mesh.cell_data["body_id"], mesh.cell_data["part_id"]):
        for cell in block.data[(cb == body) & (part != vtk.PARTS.index("joint"))]:
            X = mesh.points[cell]
            if block.type == "vertex":
                best = min(best, np.linalg.norm(p - X[0]))
            elif block.type == "line":
                best = min(best, _segment_distance(p, X[0], X[1]))
            elif block.type == "hexahedron":
                # a box (rectangular): the point in its edge frame, clipped to the edges
                o, axes = X[0], np.stack([X[1] - X[0], X[3] - X[0], X[4] - X[0]])
                s = np.clip(np.linalg.solve(axes.T, p - o), 0.0, 1.0)
                best = min(best, np.linalg.norm(p - (o + axes.T @ s)))
    return best


def test_import_keeps_writers_out():
    code = ("import sys, flexmb, flexmb.export, flexmb.viz; "
            "print(*[m in sys.modules for m in ('meshio', 'pyvista', 'matplotlib')])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "False", "False"]


def test_fourbar_without_system_draws_bars_through_the_mass_centres(fourbar_result, tmp_path):
    res = fourbar_result
    pvd = res.export_vtk(tmp_path, prefix="fb")
    assert pvd == tmp_path / "fb.pvd"
    assert vtk.body_names(res) == res.body_names  # all rigid, in result order
    _, sets = _read_all(pvd)
    assert len(sets) == len(res.t)
    for i, (t, path) in enumerate(sets):
        mesh = meshio.read(path)
        # rigid body k: point 2k is its frame origin, point 2k + 1 the origin mirrored through the mass centre
        np.testing.assert_allclose(mesh.points[0::2], res.origins[i], rtol=0, atol=TOL)
        np.testing.assert_allclose(mesh.points[1::2], 2 * res.positions[i] - res.origins[i], rtol=0, atol=TOL)
        assert "displacement" not in mesh.point_data  # the points are where the bodies are
        assert mesh.field_data["time"][0] == res.t[i]
        assert [c.type for c in mesh.cells] == ["line"] and len(mesh.cells[0].data) == 3
        np.testing.assert_array_equal(mesh.cell_data_dict["body_id"]["line"], [0, 1, 2])
        assert vtk.table_names(mesh.field_data, "body") == res.body_names
        assert vtk.table_names(mesh.field_data, "joint") == []  # a Result keeps no joints
        for name in ("bending_y", "bending_z", "torsion"):
            np.testing.assert_array_equal(mesh.point_data[name], 0.0)


def test_fourbar_with_system_meets_at_the_joints(fourbar_result, tmp_path):
    res = fourbar_result
    model = fourbar()
    pvd = res.export_vtk(tmp_path, system=model)  # a Model is built
    names = ["A", "B", "D", "C"]
    assert vtk.joint_names(model) == names
    crank, coupler, rocker = (res.body_names.index(b) for b in ("crank", "coupler", "rocker"))
    for i, (_, path) in enumerate(_read_all(pvd)[1]):
        mesh = meshio.read(path)
        assert vtk.table_names(mesh.field_data, "joint") == names
        assert vtk.table_names(mesh.field_data, "part") == list(vtk.PARTS)
        # each slender bar is one line from its first joint to its second, its real length
        lines, cd = _cells(mesh, "line")
        shape = cd["part_id"] == vtk.PARTS.index("shape")
        np.testing.assert_array_equal(cd["body_id"][shape], [0, 1, 2])
        lengths = np.linalg.norm(np.diff(mesh.points[lines[shape]], axis=1)[:, 0], axis=1)
        np.testing.assert_allclose(lengths[[crank, coupler, rocker]], [0.1, 0.3, 0.25], rtol=1e-12)
        marks = _markers(mesh)
        # A and D: the ground is not drawn; B: crank and coupler; C (the cut joint): coupler and rocker
        assert sorted(marks) == sorted([(crank, 0), (crank, 1), (coupler, 1), (rocker, 2), (coupler, 3),
                                        (rocker, 3)])
        np.testing.assert_allclose(marks[crank, 1], marks[coupler, 1], rtol=0, atol=TOL)
        # the residual is the largest row |phi_i|: the points' distance, the norm of three rows, is within sqrt(3)
        assert np.linalg.norm(marks[coupler, 3] - marks[rocker, 3]) <= np.sqrt(3) * res.residual[i] + TOL
        np.testing.assert_allclose(marks[crank, 0], 0.0, atol=TOL)  # the crank pivot A
        for (body, _), p in marks.items():
            assert _on_body(mesh, body, p) < TOL
        # the joint cells carry the joint's id; the others -1
        verts, vd = _cells(mesh, "vertex")
        assert sorted(set(vd["joint_id"])) == [0, 1, 2, 3]
        assert set(cd["joint_id"]) == {-1}


def test_random_trees_meet_at_every_joint(rng):
    """Boxes of random inertia, joints at random points: levers join every joint point to its body."""
    model = random_chain(rng)
    system = model.build()
    x = rng.normal(scale=0.5, size=system.n_coords)
    xd = rng.normal(size=system.n_coords)
    res = fm.Result.from_states(system, x[None], xd[None], xdd=np.zeros((1, system.n_coords)), t=0.3)
    mesh = vtk.to_meshio(res, 0, system=system)
    assert {c.type for c in mesh.cells} == {"hexahedron", "line", "vertex"}
    marks = _markers(mesh)
    assert len(marks) == 2 * len(model.joints) - sum(j.parent is model.ground for j in model.joints)
    by_joint = {}
    for (body, joint), p in marks.items():
        assert _on_body(mesh, body, p) < 1e-12
        by_joint.setdefault(joint, []).append(p)
    # where a joint slides, a line joins its points on the two bodies; elsewhere they coincide
    lines, ld = _cells(mesh, "line")
    slides = {int(j): mesh.points[c] for c, j, q in zip(lines, ld["joint_id"], ld["part_id"])
              if q == vtk.PARTS.index("joint")}
    for j, joint in enumerate(model.joints):
        slide = bool(type(joint).translation_axes)
        assert (j in slides) == slide, joint.name
        points = by_joint[j]
        if slide and joint.parent is model.ground:
            points = [slides[j][0]] + points  # the slide's start on the ground
        if slide:
            np.testing.assert_allclose(sorted(map(tuple, slides[j])), sorted(map(tuple, points)), rtol=0, atol=0)
        else:
            np.testing.assert_allclose(points, points[:1] * len(points), rtol=0, atol=1e-12)
    # each box has its body's inertia: 8 corners, edges a_i with m (a_j^2 + a_k^2) / 12 = I_i
    hexes, hd = _cells(mesh, "hexahedron")
    for cell, b in zip(hexes, hd["body_id"]):
        body = model[res.body_names[b]]
        X = mesh.points[cell]
        e = np.stack([X[1] - X[0], X[3] - X[0], X[4] - X[0]])
        kin = system.kinematics(0.3, x, xd)
        R = kin.R[res.body_names.index(body.name)]
        inertia = body.mass / 12 * sum((np.dot(a, a) * np.eye(3) - np.outer(a, a)) for a in e)
        np.testing.assert_allclose(R.T @ inertia @ R, body.inertia, atol=1e-12 * np.abs(body.inertia).max())
        np.testing.assert_allclose(X.mean(axis=0), kin.r[res.body_names.index(body.name)], atol=1e-12)
    # velocities: the partial velocities of each point (eq. 17) times the speeds
    kin = system.kinematics(0.3, x, xd)
    layout = _Layout(res, system)
    rows = np.where(layout.row == layout.n_rows, -1, layout.row)  # the start of a slide on the ground
    exact = kin.point_partials(rows, mesh.points) @ xd
    np.testing.assert_allclose(mesh.point_data["velocity"], exact, rtol=0, atol=1e-10 * np.abs(exact).max())


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
        assert "displacement" not in mesh.point_data
        np.testing.assert_allclose(mesh.point_data["velocity"], fd_velocity[i], rtol=0, atol=TOL)
        # joint j<k> sits at centre-line point k; the tip carries no joint
        for coord, name in (("bend_y", "bending_y"), ("bend_z", "bending_z")):
            expected = [res.coordinate(f"beam.j{k}.{coord}")[i] for k in range(4)] + [0.0]
            np.testing.assert_allclose(mesh.point_data[name], expected, rtol=0, atol=TOL)
        np.testing.assert_array_equal(mesh.point_data["torsion"], 0.0)
        assert "axial" not in mesh.point_data
        np.testing.assert_array_equal(mesh.cell_data_dict["segment"]["line"], [0, 1, 2, 3])
    assert np.min(shape[-1, :, 2]) < -1e-3  # it did sag: the comparison is not of zeros


def test_cantilever_segments_are_drawn_as_their_sections(cantilever, tmp_path):
    system, beam, res = cantilever
    pvd = res.export_vtk(tmp_path, system=system)
    mesh = meshio.read(_read_all(pvd)[1][-1][1])
    shape = res.shape("beam")[-1]
    np.testing.assert_allclose(mesh.points[:5], shape, rtol=0, atol=TOL)  # the centre line comes first
    hexes, hd = _cells(mesh, "hexahedron")
    np.testing.assert_array_equal(hd["segment"], [0, 1, 2, 3])
    np.testing.assert_array_equal(hd["body_id"], 0)
    for k, cell in enumerate(hexes):
        X = mesh.points[cell]
        edges = np.linalg.norm([X[1] - X[0], X[3] - X[0], X[4] - X[0]], axis=1)
        np.testing.assert_allclose(edges, [0.25, 0.02, 0.01], rtol=1e-12)  # l, width b, thickness h
        # the block runs along the segment, centred on its centre line
        np.testing.assert_allclose(X[[0, 3, 4, 7]].mean(axis=0), shape[k], atol=TOL)
        np.testing.assert_allclose(X[[1, 2, 5, 6]].mean(axis=0), shape[k + 1], atol=TOL)
        # its corners carry the elastic coordinate and moment of the joint at their end
        for field in ("bending_y", "moment_bend_y", "von_mises"):
            np.testing.assert_array_equal(mesh.point_data[field][cell[[0, 3, 4, 7]]], mesh.point_data[field][k])
            np.testing.assert_array_equal(mesh.point_data[field][cell[[1, 2, 5, 6]]],
                                          mesh.point_data[field][k + 1])
    assert mesh.point_data["von_mises"][0] > 0  # the clamp carries the weight
    marks = _markers(mesh)
    assert list(marks) == [(0, 0)] and _on_body(mesh, 0, marks[0, 0]) < TOL  # the clamp, at the root


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
        mesh = vtk.to_meshio(res, i, system=system)
        exact = mesh.point_data["velocity"]
        layout = _Layout(res, system)
        kin = system.kinematics(res.t[i], res.x[i], res.xd[i])
        np.testing.assert_allclose(exact, kin.point_partials(layout.row, mesh.points) @ res.xd[i], rtol=0,
                                   atol=1e-10 * np.abs(exact).max())
        marks = _markers(mesh)
        np.testing.assert_allclose(exact[_cells(mesh, "vertex")[0][0, 0]], 0.0, atol=1e-12)  # the pivot A
        if 0 < i < len(res.t) - 1:
            # central differences over dt = 5 ms agree to O(dt^2)
            before, after = (vtk.to_meshio(res, k, system=system).points for k in (i - 1, i + 1))
            fd = (after - before) / (res.t[i + 1] - res.t[i - 1])
            np.testing.assert_allclose(fd, exact, atol=5e-3 * np.max(np.abs(exact)))
        assert len(marks) == 6


def test_triad_adds_body_axes(fourbar_result):
    mesh = vtk.to_meshio(fourbar_result, 3, triad=0.05)
    pts = mesh.points[6:].reshape(3, 4, 3)  # after the bars: per body its origin and its x, y, z tips
    axes = (pts[:, 1:] - pts[:, :1]) / 0.05
    np.testing.assert_allclose(axes.transpose(0, 2, 1), fourbar_result.rotations[3], atol=TOL)
    lines, cd = _cells(mesh, "line")
    assert len(lines) == 3 + 9 and np.sum(cd["part_id"] == vtk.PARTS.index("triad")) == 9


def test_snapshot(cantilever, tmp_path):
    system, beam, res = cantilever
    x, xd = res.x[-1], res.xd[-1]
    path = snapshots.export_snapshot(system, x, tmp_path / "snap.vtu", xd=xd, t=0.05)
    mesh = meshio.read(path)
    np.testing.assert_allclose(mesh.points[:5], system.shape(beam, x), rtol=0, atol=TOL)
    assert "displacement" not in mesh.point_data
    np.testing.assert_allclose(mesh.point_data["velocity"][0], 0.0, atol=TOL)  # clamped root
    assert mesh.field_data["time"][0] == 0.05
    # with a reference: drawn there, and the displacement carries the points to x
    ref = meshio.read(snapshots.export_snapshot(system, x, tmp_path / "ref.vtu", reference=0 * x))
    np.testing.assert_allclose(ref.points[:5], system.shape(beam, 0 * x), rtol=0, atol=TOL)
    np.testing.assert_allclose(ref.points + ref.point_data["displacement"], mesh.points, rtol=0, atol=TOL)


def test_modes(cantilever, tmp_path):
    system, beam, _ = cantilever
    f, shapes = fm.modes(system, 2)
    paths = snapshots.export_modes(system, f, shapes, tmp_path, scale=0.05)
    assert [p.name for p in paths] == ["mode_01.vtu", "mode_02.vtu"]
    for k, path in enumerate(paths):
        mesh = meshio.read(path)
        # the reference configuration, and the displacement to warp it by into the mode shape
        np.testing.assert_allclose(mesh.points[:5], system.shape(beam, 0 * shapes[:, k]), rtol=0, atol=TOL)
        np.testing.assert_allclose((mesh.points + mesh.point_data["displacement"])[:5],
                                   system.shape(beam, 0.05 * shapes[:, k]), rtol=0, atol=TOL)
        assert mesh.field_data["frequency"][0] == f[k]
        assert mesh.field_data["mode"][0] == k + 1


def test_files_hold_numbers_only_and_meshio_and_vtk_read_the_same(cantilever, tmp_path):
    """issue #32: meshio stopped at the string arrays ("Illegal data type 'String'", SystemExit); the names
    are now field-data entries holding their ids, which meshio, pyvista (VTK) and ParaView all read."""
    system, _, res = cantilever
    path = vtk.write_vtu(res, tmp_path, system=system)[2]
    assert 'type="String"' not in path.read_text()
    mesh = meshio.read(path)
    expected = vtk.to_meshio(res, 2, system=system)
    assert mesh.field_data.keys() == expected.field_data.keys()
    for name, value in expected.field_data.items():
        np.testing.assert_array_equal(mesh.field_data[name], value)
    assert vtk.table_names(mesh.field_data) == ["beam"] and vtk.table_names(mesh.field_data, "joint") == ["clamp"]
    assert mesh.field_data["TimeValue"][0] == mesh.field_data["time"][0] == res.t[2]
    np.testing.assert_array_equal(mesh.points, expected.points)
    for name, value in expected.point_data.items():
        np.testing.assert_array_equal(mesh.point_data[name], value)
    assert mesh.cell_data.keys() == expected.cell_data.keys() == {"body_id", "joint_id", "segment", "part_id",
                                                                  "angular_velocity"}
    for name, value in expected.cell_data.items():
        np.testing.assert_array_equal(np.concatenate(mesh.cell_data[name]), np.concatenate(value))
    pv = pytest.importorskip("pyvista")
    grid = pv.read(path)
    assert vtk.table_names(grid.field_data) == ["beam"]
    assert grid.field_data["TimeValue"][0] == res.t[2]
    np.testing.assert_array_equal(grid.points, mesh.points)
    for name in mesh.point_data:
        np.testing.assert_array_equal(grid.point_data[name], mesh.point_data[name])
    # the active vectors: what Warp By Vector takes (pyvista's and ParaView's)
    assert grid.point_data.active_vectors_name == "elastic_displacement"
    np.testing.assert_array_equal(grid.cell_data["body_id"], np.concatenate(mesh.cell_data["body_id"]))


def test_strings_are_refused_by_name(tmp_path):
    mesh = meshio.Mesh(np.zeros((1, 3)), [("vertex", [[0]])], field_data={"label": np.array(["a"])})
    with pytest.raises(fm.ExportError, match="'label'.*numbers only"):
        vtu._write_mesh(mesh, tmp_path / "a.vtu")
    assert list(tmp_path.iterdir()) == []


def test_table_names():
    assert vtk.table_names({"joint:b": [1], "joint:a": [0], "body:a": [0]}, "joint") == ["a", "b"]
    assert vtk.table_names({"time": [0.0]}) == []
    with pytest.raises(fm.ExportError, match="ids \\[0, 2\\]"):
        vtk.table_names({"body:a": [0], "body:b": [2]})
    with pytest.raises(fm.ExportError, match="table must be one of"):
        vtk.table_names({}, "bodies")


def _tip_load_model(n_segments, P, hub_angle=None):
    """A clamped aluminium strip (1 m x 20 mm x 5 mm) with a tip load P (N) along -z, bending about y.

    With ``hub_angle`` the strip is clamped to a rigid hub on a revolute about x at (0.3, -0.2, 0.5),
    0.2 m out along the hub, and the hub is turned by that angle (rad); else clamped to the ground."""
    model = fm.Model("tip_load")
    beam = fm.FlexibleBody.uniform_beam("beam", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material.aluminium(),
                                        n_segments, keep=("bend_y",))
    load = fm.PointForce("P", beam, (0.0, 0.0, -P), point=(1.0, 0.0, 0.0), frame="body")
    if hub_angle is None:
        model.add(fm.Fixed("clamp", model.ground, beam), load)
    else:
        hub = fm.RigidBody.slender_bar("hub", 1.0, 0.2)
        model.add(fm.Revolute("spin", model.ground, hub, parent_point=(0.3, -0.2, 0.5), axis=(1.0, 0.0, 0.0)),
                  fm.Fixed("clamp", hub, beam, parent_point=(0.2, 0.0, 0.0)), load)
    return model.build()


@pytest.mark.parametrize("n_segments", [4, 16])
def test_elastic_displacement_is_the_cantilever_deflection(n_segments, tmp_path):
    """issue #32 trap 10: the files carry the elastic displacement, so Warp By Vector shows the bending.

    A tip load P on a clamped strip: the tip's elastic displacement read back from the file is the
    finite-segment model's closed form P L^3 / (3 E I) (1 + 1 / (2 N^2)) (the clamp spring 2 E I / l, the
    others E I / l, the moments P (L - s_i); Euler-Bernoulli's P L^3 / (3 E I) as N grows), turned with
    the hub that carries the strip; the hub, a rigid body, gets zeros."""
    E, b, h, L, P = 70e9, 0.02, 0.005, 1.0, 0.02
    deflection = P * L**3 / (3 * E * b * h**3 / 12) * (1 + 1 / (2 * n_segments**2))
    assert 3e-4 < deflection < 5e-4  # the wiper blade's scale: invisible without warping
    elastic = fm.linear_statics(_tip_load_model(n_segments, P))  # the strip's joint rotations, clamped
    angle = 0.7
    system = _tip_load_model(n_segments, P, hub_angle=angle)
    x = np.zeros(system.n_coords)
    x[system.coordinate_names.index("spin.angle")] = angle
    x[[system.coordinate_names.index(f"beam.j{k}.bend_y") for k in range(n_segments)]] = elastic
    mesh = meshio.read(snapshots.export_snapshot(system, x, tmp_path / "bent.vtu"))
    d = mesh.point_data["elastic_displacement"]
    lines, cd = _cells(mesh, "line")
    centre = lines[cd["part_id"] == vtk.PARTS.index("centre line")]
    tip = centre[-1, 1]
    turn = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(angle), -np.sin(angle)], [0.0, np.sin(angle), np.cos(angle)]])
    # in the hub's axes: along the load the deflection, to O(theta^2) ~ 1e-7 of it (theta ~ 1.5 deflection / L,
    # the tip's slope); along the strip the shortening of a bent beam, the integral of w'^2 / 2, 3/5 deflection^2
    # / L for Euler-Bernoulli's cantilever, to O(1 / N^2); nothing across
    along, across, load = turn.T @ d[tip]
    assert load == pytest.approx(-deflection, rel=1e-6)
    assert along == pytest.approx(-0.6 * deflection**2 / L, rel=1 / n_segments**2)
    assert abs(across) < 1e-15  # round-off of metre-sized coordinates
    np.testing.assert_array_equal(d[centre[0, 0]], 0.0)  # the root: clamped
    body = np.concatenate(mesh.cell_data["body_id"])
    hub_points = np.unique(np.concatenate([c.data[cb == 0].ravel() for c, cb in zip(mesh.cells,
                                                                                   mesh.cell_data["body_id"])]))
    assert vtk.table_names(mesh.field_data) == ["hub", "beam"] and set(body) == {0, 1}
    np.testing.assert_array_equal(d[hub_points], 0.0)
    # Warp By Vector at scale s puts the tip s + 1 times as far from where the strip would be undeformed
    undeformed = mesh.points[tip] - d[tip]
    np.testing.assert_allclose(np.linalg.norm(mesh.points[tip] + 99.0 * d[tip] - undeformed), 100 * deflection,
                               rtol=1e-6)


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
    with pytest.raises(fm.ExportError, match="System or Model"):
        vtk.to_meshio(fourbar_result, 0, system="fourbar")
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
        snapshots.export_snapshot(system, np.zeros(3), tmp_path / "s.vtu")
    with pytest.raises(fm.ExportError, match="shapes"):
        snapshots.export_modes(system, [1.0, 2.0], np.zeros((system.n_coords, 3)), tmp_path)
    assert not (tmp_path / "a.pvd").exists() and not (tmp_path / "s.vtu").exists()


def test_failed_write_leaves_nothing(fourbar_result, tmp_path, monkeypatch):
    def broken(path, text):
        Path(path).write_text(text[: len(text) // 2])  # half a file, then the disk fills up
        raise OSError("disk full")

    monkeypatch.setattr(vtu, "_write_text", broken)
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
    mesh = meshio.read(snapshots.export_snapshot(system, x, tmp_path / "s.vtu"))
    # flexible bodies in the order of their first segments: the rod hangs from the ground, the blade from the hub
    assert vtk.table_names(mesh.field_data) == ["hub", "rod", "blade"]
    # the hub's bar (2 points), the rod's centre line (4) and blocks (3 x 8), the blade's (4 and 3 x 8),
    # then the joint points: spin on the hub, root on the hub and the blade, pin on the rod
    assert len(mesh.points) == 2 + 4 + 24 + 4 + 24 + 4
    np.testing.assert_allclose(mesh.points[2:6], system.shape(rod, x), atol=TOL)
    np.testing.assert_allclose(mesh.points[30:34], system.shape(blade, x), atol=TOL)
    names = system.coordinate_names
    value = {n: x[k] for k, n in enumerate(names)}
    np.testing.assert_array_equal(mesh.point_data["bending_z"][30:34],
                                  [value[f"blade.j{k}.bend_z"] for k in range(3)] + [0.0])
    # the unclamped rod has joints j1, j2 only: its root point carries none
    for coord in ("axial", "torsion"):
        np.testing.assert_array_equal(mesh.point_data[coord][2:6],
                                      [0.0] + [value[f"rod.j{k}.{coord}"] for k in (1, 2)] + [0.0])
        np.testing.assert_array_equal(mesh.point_data[coord][30:], 0.0)
    np.testing.assert_array_equal(mesh.cell_data_dict["body_id"]["line"][:7], [0, 1, 1, 1, 2, 2, 2])
    marks = _markers(mesh)
    assert sorted(marks) == [(0, 0), (0, 1), (1, 2), (2, 1)]
    np.testing.assert_allclose(marks[0, 1], marks[2, 1], rtol=0, atol=TOL)
    for (body, _), p in marks.items():
        assert _on_body(mesh, body, p) < TOL


# ----------------------------------------------------------------------------- the ParaView script


class _FakeParaView:
    """The few paraview.simple calls open_in_paraview.py makes, recorded (ParaView itself is not a dependency)."""

    def __init__(self):
        self.calls = []

        class Proxy:
            def __init__(proxy, **kw):
                proxy.__dict__.update(kw)

            def __getattr__(proxy, name):  # methods: recorded, return None
                return lambda *a, **k: self.calls.append((name, a, k))

        self.Proxy = Proxy

    def GetActiveViewOrCreate(self, kind):
        return self.Proxy(kind=kind)

    def PVDReader(self, registrationName, FileName):
        _, sets = _read_all(Path(FileName))
        mesh = meshio.read(sets[0][1])
        keys = lambda names: type("Keys", (), {"keys": lambda _: list(names)})()  # noqa: E731

        class FieldData:
            """reader.FieldData: its keys, and each array's range (ParaView's array information)."""

            def keys(self):
                return sorted(mesh.field_data)

            def __getitem__(self, name):
                values = np.ravel(mesh.field_data[name])
                return type("Info", (), {"GetRange": lambda _: (float(values.min()), float(values.max()))})()

        return self.Proxy(name=registrationName, TimestepValues=[t for t, _ in sets],
                          PointData=keys(mesh.point_data), CellData=keys(mesh.cell_data), FieldData=FieldData())

    def GetColorTransferFunction(self, name):
        return self.__dict__.setdefault("luts", {}).setdefault(name, self.Proxy(name=name))

    def Show(self, reader, view):
        return self.Proxy(reader=reader)

    def ColorBy(self, display, what):
        self.calls.append(("ColorBy", display.reader.name, what))

    def Hide(self, reader, view):
        self.calls.append(("Hide", reader.name))

    def GetAnimationScene(self):
        self.scene = self.Proxy()
        return self.scene

    def SaveScreenshot(self, path, view, **kw):
        self.calls.append(("SaveScreenshot", path))

    def __getattr__(self, name):
        return lambda *a, **k: self.Proxy()


def test_paraview_script_opens_the_series_coloured_by_stress(cantilever, fourbar_result, tmp_path, monkeypatch):
    system, _, res = cantilever
    res.export_vtk(tmp_path / "vtk_beam", prefix="beam", system=system)
    fourbar_result.export_vtk(tmp_path / "vtk_fourbar", prefix="fourbar", system=fourbar())
    script = vtk.paraview_script(tmp_path / "open_in_paraview.py")
    fake = _FakeParaView()
    paraview = type(sys)("paraview")
    paraview.simple = fake
    monkeypatch.setitem(sys.modules, "paraview", paraview)
    monkeypatch.setitem(sys.modules, "paraview.simple", fake)
    monkeypatch.setattr(sys, "argv", [str(script), "--time", "0.02", "--screenshot", str(tmp_path / "a.png")])
    import runpy

    runpy.run_path(str(script), run_name="__main__")  # as pvpython runs it
    colours = [c for c in fake.calls if c[0] == "ColorBy"]
    # the beam (section stresses) by von Mises stress, the four-bar (rigid) by body, as categories
    assert colours == [("ColorBy", "beam.pvd", ("POINTS", "von_mises")),
                       ("ColorBy", "fourbar.pvd", ("CELLS", "body_id"))]
    # issue #32: a string array gave one colour and an empty legend; each body now has its colour and its name
    names = vtk.table_names(meshio.read(_read_all(tmp_path / "vtk_fourbar" / "fourbar.pvd")[1][0][1]).field_data)
    assert len(names) >= 3
    lut = fake.__dict__["luts"]["body_id"]
    assert lut.InterpretValuesAsCategories == 1 and lut.AnnotationsInitialized == 1
    assert lut.Annotations == [text for k, name in enumerate(names) for text in (str(k), name)]
    assert len(lut.IndexedColors) == 3 * len(names) and len(set(zip(*[iter(lut.IndexedColors)] * 3))) == len(names)
    assert ("Hide", "fourbar.pvd") in fake.calls  # the series with stresses is the one shown
    assert fake.scene.AnimationTime == min(res.t, key=lambda t: abs(t - 0.02))
    assert ("SaveScreenshot", str(tmp_path / "a.png")) in fake.calls
    # imported as part of flexmb it does nothing
    import importlib

    assert importlib.import_module("flexmb.export.open_in_paraview").__all__ == ["main"]


@contextlib.contextmanager
def _display():
    """An X display for ParaView's renderer: $DISPLAY, else an Xvfb of our own, stopped on the way out.

    Debian's ParaView renders through X even with --force-offscreen-rendering. ``Xvfb -displayfd`` picks a
    free display itself and writes its number once it accepts clients; ``-noreset``: a server resets when
    its last client leaves (ParaView's first probe of OpenGL does) and writes its number again, and dies
    if that write fails. (``xvfb-run -a`` guesses a free number, which races other runs, and its Xvfb
    outlives a killed ``xvfb-run``.)
    """
    import os
    import select
    import shutil

    if os.environ.get("DISPLAY"):
        yield os.environ["DISPLAY"]
        return
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        pytest.skip("no display and no Xvfb to render ParaView's screenshot")
    read, write = os.pipe()
    server = subprocess.Popen([xvfb, "-displayfd", str(write), "-noreset", "-nolisten", "tcp", "-screen", "0",
                               "1024x768x24"], pass_fds=[write], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write)
    try:
        ready, _, _ = select.select([read], [], [], 120)
        number = os.read(read, 64).decode().strip() if ready else ""  # empty: the server died or hangs
        if not number:
            raise RuntimeError(f"Xvfb did not start within 120 s (exit status {server.poll()})")
        yield f":{number}"
    finally:
        server.terminate()
        try:
            server.wait(timeout=30)
        except subprocess.TimeoutExpired:
            server.kill()
            server.wait()
        os.close(read)


def test_paraview_script_in_pvbatch(cantilever, tmp_path):
    """With ParaView installed (pvbatch): the real thing renders a PNG, off screen, on a display of its own."""
    import os
    import shutil

    pvbatch = shutil.which("pvbatch")
    if pvbatch is None:
        pytest.skip("ParaView (pvbatch) is not installed")
    system, _, res = cantilever
    res.export_vtk(tmp_path / "vtk", prefix="beam", system=system)
    script = vtk.paraview_script(tmp_path / "open_in_paraview.py")
    with _display() as display:
        proc = subprocess.run([pvbatch, "--force-offscreen-rendering", str(script), "--screenshot",
                               str(tmp_path / "beam.png")], capture_output=True, text=True, timeout=600,
                              cwd=tmp_path, env={**os.environ, "DISPLAY": display})
    assert proc.returncode == 0, proc.stderr[:1500] + "\n...\n" + proc.stderr[-1000:]
    assert (tmp_path / "beam.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _top():
    model = fm.Model("top")
    body = fm.RigidBody("top", 2.0, (0.05, 0.08, 0.03), com=(0.1, 0.2, -0.5))
    return model.add(fm.Spherical("ball", model.ground, body), fm.Gravity((0.0, 0.0, -9.81)))


@pytest.mark.parametrize("which", ["fourbar", "top"])
def test_angular_velocity_cell_data_read_back_by_meshio(which, fourbar_result, tmp_path):
    """Every cell carries the angular velocity of the body it draws: exact with the system, O(dt^2) without."""
    if which == "fourbar":
        res, model = fourbar_result, fourbar()
    else:
        model = _top()
        res = fm.simulate(model, 0.2, speeds=[fm.AngularVelocity("top", (1.5, -0.5, 3.0))], n_out=41, rtol=1e-10,
                          atol=1e-12)
    system = model.build()
    exact = {b: res.angular_velocity(b, system=system) for b in res.body_names}
    assert max(np.abs(w).max() for w in exact.values()) > 0.5
    _, files = _read_all(vtk.export_vtk(res, tmp_path / "sys", system=system))
    _, plain = _read_all(vtk.export_vtk(res, tmp_path / "plain"))
    for i in (0, len(res.t) // 2, len(res.t) - 1):
        for path, tol in ((files[i][1], 1e-12), (plain[i][1], 2e-2)):
            mesh = meshio.read(path)
            names = vtk.table_names(mesh.field_data, "body")
            ids = np.concatenate(mesh.cell_data["body_id"])
            w = np.concatenate(mesh.cell_data["angular_velocity"])
            parts = np.concatenate(mesh.cell_data["part_id"])
            assert w.shape == (len(ids), 3)
            shape = parts == vtk.PARTS.index("shape")
            assert shape.sum() == len(res.body_names)
            for k, name in enumerate(names):
                on = shape & (ids == k)
                np.testing.assert_allclose(w[on], np.broadcast_to(exact[name][i], w[on].shape), rtol=0,
                                           atol=tol * max(1.0, np.abs(exact[name]).max()), err_msg=f"{name} {path}")
