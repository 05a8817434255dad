"""Off-screen rendering (pyvista), GIFs and time-history plots (matplotlib)."""

from __future__ import annotations

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")
pytest.importorskip("matplotlib")
iio = pytest.importorskip("imageio.v3")

import flexmb as fm  # noqa: E402
from flexmb import viz  # noqa: E402
from flexmb.export import vtk  # noqa: E402
from flexmb.export.layout import _Layout  # noqa: E402

from conftest import fourbar, fourbar_initial  # noqa: E402

pv.OFF_SCREEN = True

SIZE = (240, 180)


@pytest.fixture(scope="module")
def result():
    return fm.simulate(fourbar(), 0.3, positions=fourbar_initial(), n_out=9)


def _foreground(img, background=255):
    """Mask of pixels that differ from a white background."""
    return np.any(img[..., :3] != background, axis=-1)


def test_render_state_draws_the_bodies(result, tmp_path):
    path = viz.render_state(result, 0, tmp_path / "state.png", window_size=SIZE)
    img = iio.imread(path)
    assert img.shape[:2] == SIZE[::-1]
    assert img.var() > 0
    fg = _foreground(img)
    h, w = fg.shape
    # the camera frames the mechanism: bodies in the centre region, margins clear
    assert fg[h // 4: 3 * h // 4, w // 4: 3 * w // 4].any()
    assert 0.005 < fg.mean() < 0.5
    assert not fg[:2].any() and not fg[-2:].any()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["state.png"]


def test_render_colours_by_velocity(result, tmp_path):
    path = viz.render_state(result, -1, tmp_path / "v.png", window_size=SIZE, scalars="velocity", view="iso")
    assert _foreground(iio.imread(path)).any()


def test_animate_writes_every_frame(result, tmp_path):
    path = viz.animate(result, tmp_path / "run.gif", stride=2, window_size=(120, 90))
    frames = iio.imread(path, index=None)
    assert path.stat().st_size > 0
    assert frames.shape[0] == 5  # outputs 0, 2, 4, 6, 8
    assert not np.array_equal(frames[0], frames[-1])  # the mechanism moved


def test_result_plot_writes_png(result, tmp_path):
    fig = result.plot(["A", "D.angle"], path=tmp_path / "history.png", energy=True)
    assert (tmp_path / "history.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [line.get_label() for line in fig.axes[0].lines] == ["A.angle", "D.angle"]
    assert len(fig.axes) == 2


def test_bad_viz_input(result, tmp_path):
    with pytest.raises(fm.ExportError, match="view"):
        viz.render_state(result, 0, tmp_path / "a.png", view="top")
    with pytest.raises(fm.ExportError, match="output index"):
        viz.render_state(result, 99, tmp_path / "a.png")
    with pytest.raises(fm.ExportError, match="no coordinate or joint"):
        result.plot("nope", path=tmp_path / "b.png")
    assert list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------------------- the wiper's VTK files

WIPER_BODIES = ["crank", "right_arm", "left_arm", "drive_link", "connecting_link", "right_blade", "left_blade"]


@pytest.fixture(scope="module")
def wiper_files(tmp_path_factory):
    """The flexible wiper over 0.3 s, exported with its system: (model, system, result, .pvd)."""
    from flexmb.scenes.wiper import WiperOptions, wiper

    model, initial = wiper(WiperOptions(flexible=True))
    system = model.build()
    res = fm.simulate(system, 0.3, positions=initial, rtol=1e-6, n_out=7)
    pvd = res.export_vtk(tmp_path_factory.mktemp("wiper"), prefix="wiper", system=system)
    return model, system, res, pvd


def test_wiper_vtk_renders_as_one_connected_mechanism(wiper_files, tmp_path):
    """At three times: names read back, every joint point of every body lies on that body's drawn cells,
    the bodies meet at their joints, velocities are the state's, and the render is not blank."""
    model, system, res, pvd = wiper_files
    reader = pv.get_reader(str(pvd))
    np.testing.assert_array_equal(reader.time_values, res.t)  # one time series
    joint_part = vtk.PARTS.index("joint")
    cut = {j.name for j in system.topology.cut_joints}
    assert cut == {"UJ3", "UJ6"}
    for i in (0, len(res.t) // 2, len(res.t) - 1):
        reader.set_active_time_value(reader.time_values[i])
        grid = reader.read()[0]
        assert vtk.table_names(grid.field_data) == WIPER_BODIES
        assert vtk.table_names(grid.field_data, "joint") == [j.name for j in model.joints]
        body_id, part = grid.cell_data["body_id"], grid.cell_data["part_id"]
        markers = np.flatnonzero(part == joint_part)
        ends = {}
        for c in markers:
            b, j = int(body_id[c]), int(grid.cell_data["joint_id"][c])
            p = grid.get_cell(c).points[0]
            shape = grid.extract_cells(np.flatnonzero((body_id == b) & (part != joint_part)))
            _, closest = shape.find_closest_cell(p[None], return_closest_point=True)
            assert np.linalg.norm(closest - p) <= 1e-12, (WIPER_BODIES[b], model.joints[j].name)
            ends.setdefault(model.joints[j].name, []).append(p)
        # each joint on both bodies it joins (the ground, not drawn, for RJ1, RJ4, RJ7)
        assert {k: len(v) for k, v in ends.items()} == {j.name: 1 + (j.parent is not model.ground)
                                                        for j in model.joints}
        for name, points in ends.items():
            gap = np.ptp(np.array(points), axis=0).max()
            assert gap <= (res.residual[i] + 1e-15 if name in cut else 1e-12), (name, gap)
        # velocities: the partial velocities of each point times the speeds (eq. 17)
        layout = _Layout(res, system)
        kin = system.kinematics(res.t[i], res.x[i], res.xd[i])
        exact = kin.point_partials(layout.row, grid.points) @ res.xd[i]
        np.testing.assert_allclose(grid.point_data["velocity"], exact, rtol=0, atol=1e-10)
        assert np.abs(exact).max() > 0.1  # the mechanism moves
        # the render: coloured by stress, lines as tubes, joints as balls; not blank
        plotter = pv.Plotter(off_screen=True, window_size=SIZE)
        plotter.set_background("white")
        plotter.add_mesh(grid, scalars="von_mises", render_lines_as_tubes=True, line_width=4,
                         render_points_as_spheres=True, point_size=8, show_scalar_bar=False)
        plotter.view_xy()
        img = plotter.screenshot(str(tmp_path / f"wiper_{i}.png"), return_img=True)
        plotter.close()
        fg = _foreground(img)
        assert 0.002 < fg.mean() < 0.5
    assert np.nanmax(grid.point_data["von_mises"]) > 1e5  # the blades bend: there is stress to colour by


def test_render_state_draws_the_wiper_with_its_system(wiper_files, tmp_path):
    model, system, res, _ = wiper_files
    path = viz.render_state(res, -1, tmp_path / "wiper.png", system=system, window_size=SIZE, legend=True)
    assert _foreground(iio.imread(path)).mean() > 0.002
    path = viz.render_state(res, -1, tmp_path / "stress.png", system=model, window_size=SIZE, scalars="von_mises")
    assert _foreground(iio.imread(path)).mean() > 0.002
    with pytest.raises(fm.ExportError, match="von_mises"):
        viz.render_state(res, -1, tmp_path / "x.png", scalars="von_mises")  # without the system: no stress


def test_show_renders_the_last_state_with_the_system_that_made_it(result, tmp_path):
    shown = result.show(path=tmp_path / "shown.png", window_size=SIZE)
    path = tmp_path / "shown.png"
    # the PNG's path, in a script as in a notebook, which shows itself as the picture (issue #32)
    assert isinstance(shown, viz.Picture) and shown == path and path.exists()
    assert shown._repr_png_() == path.read_bytes()
    assert shown._repr_html_().startswith('<img src="data:image/png;base64,')
    img = iio.imread(path)
    assert img.shape[:2] == SIZE[::-1] and _foreground(img).any()
    # the same picture as render_state of the last output with the result's own system
    ref = viz.render_state(result, len(result.t) - 1, tmp_path / "ref.png", system=result.system, window_size=SIZE)
    assert np.array_equal(iio.imread(ref), img)


# ----------------------------------------------------------------------------- no display (issue #32, trap 11)

_QUIET_RENDER = """
import flexmb as fm
model = fm.Model("pendulum")
bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0.0, -9.81, 0.0)))
res = fm.simulate(model, 0.1, positions={"pin": 1.0}, n_out=3, progress=False)
first = res.show(path=FIRST, window_size=(120, 90))
second = fm.viz.animate(res, GIF, window_size=(120, 90))
print(type(first).__name__, first, second)
"""


def test_rendering_without_a_display_logs_no_x_server_warning(tmp_path):
    """Every render without a display printed VTK's 'bad X server connection. DISPLAY=' (it tried X before EGL);
    offscreen_plotter asks for the EGL window there. In a fresh interpreter: VTK warns once per process."""
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "VTK_DEFAULT_OPENGL_WINDOW")}
    code = f"FIRST, GIF = {str(tmp_path / 'a.png')!r}, {str(tmp_path / 'a.gif')!r}\n" + _QUIET_RENDER
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "bad X server connection" not in proc.stderr, proc.stderr
    assert "VTK_DEFAULT_OPENGL_WINDOW" not in proc.stderr, proc.stderr  # EGL was there: no fallback either
    assert proc.stdout.split()[0] == "Picture"
    assert _foreground(iio.imread(tmp_path / "a.png")).any()
    assert iio.imread(tmp_path / "a.gif", index=None).shape[0] == 3


def test_offscreen_plotter_asks_for_egl_only_without_a_display_and_restores_the_environment(monkeypatch):
    import os

    from flexmb.viz import offscreen

    monkeypatch.delenv("VTK_DEFAULT_OPENGL_WINDOW", raising=False)
    monkeypatch.delenv("DISPLAY", raising=False)
    seen = []
    monkeypatch.setattr(pv, "Plotter", lambda **kw: seen.append((kw, os.environ.get("VTK_DEFAULT_OPENGL_WINDOW"))))
    viz.offscreen_plotter(window_size=(20, 20))
    assert seen[-1] == ({"window_size": (20, 20), "off_screen": True}, "vtkEGLRenderWindow")
    assert "VTK_DEFAULT_OPENGL_WINDOW" not in os.environ  # for the plotter's creation only
    monkeypatch.setenv("DISPLAY", ":0")  # a display: VTK's own choice
    viz.offscreen_plotter()
    assert seen[-1][1] is None and offscreen.headless_window() is None
    monkeypatch.delenv("DISPLAY")
    monkeypatch.setenv("VTK_DEFAULT_OPENGL_WINDOW", "vtkOSOpenGLRenderWindow")  # the user's choice is kept
    viz.offscreen_plotter()
    assert seen[-1][1] == os.environ["VTK_DEFAULT_OPENGL_WINDOW"] == "vtkOSOpenGLRenderWindow"


# ----------------------------------------------------------------------------- show() in a script (issue #32, trap 11)


def _fake_ipython(monkeypatch, shell):
    """An importable IPython whose get_ipython() returns ``shell`` and whose display.Image records its use."""
    import sys
    import types

    made = []
    ipython = types.ModuleType("IPython")
    ipython.get_ipython = lambda: shell
    display = types.ModuleType("IPython.display")
    display.Image = lambda *a, **kw: made.append((a, kw)) or ("Image", a, kw)
    ipython.display = display
    monkeypatch.setitem(sys.modules, "IPython", ipython)
    monkeypatch.setitem(sys.modules, "IPython.display", display)
    return made


@pytest.mark.parametrize("shell", [None, type("ZMQInteractiveShell", (), {})()], ids=["script", "notebook"])
def test_show_returns_the_path_with_ipython_installed_and_shows_the_png_in_a_shell(result, tmp_path, monkeypatch,
                                                                                   shell):
    """With IPython importable, show() returned an IPython Image even in a plain script (documented: the path).
    Now a Picture, the PNG's path, in a script; in a running IPython shell the same object, which IPython's
    display (the ``_repr_png_`` it looks up) shows as the picture."""
    made = _fake_ipython(monkeypatch, shell)
    shown = result.show(path=tmp_path / "s.png", window_size=SIZE)
    assert isinstance(shown, viz.Picture) and shown == tmp_path / "s.png" and not made
    assert shown._repr_png_() == (tmp_path / "s.png").read_bytes()
