"""Write ``docs/figures/wiper_vtk.png`` (and ``wiper_paraview.png`` where ParaView is installed).

The flexible wiper of ``flexmb run wiper`` over its first half second,
exported with its system, read back from the VTK files with pyvista and
drawn at t = 0, 0.25 and 0.5 s: bodies coloured by name, lines as tubes,
joints as grey balls. With ParaView's ``pvbatch`` on the path (and
``xvfb-run`` without a display), also the picture the shipped
``open_in_paraview.py`` makes at t = 0.25 s. Run from the repository::

    python docs/figures/wiper_vtk.py
"""

import shutil
import subprocess
import tempfile
from pathlib import Path

import matplotlib
import numpy as np
import pyvista as pv

import flexmb as fm
from flexmb import viz
from flexmb.export.vtk import paraview_script, table_names
from flexmb.scenes.wiper import WiperOptions, wiper

HERE = Path(__file__).resolve().parent
TIMES = (0.0, 0.25, 0.5)


def main():
    model, initial = wiper(WiperOptions(flexible=True))
    system = model.build()
    res = fm.simulate(system, TIMES[-1], positions=initial, rtol=1e-6, n_out=11, progress=False)
    out = Path(tempfile.mkdtemp())
    pvd = res.export_vtk(out / "vtk_flexible", prefix="wiper_flexible", system=system)
    reader = pv.get_reader(str(pvd))
    grids = []
    for t in TIMES:
        reader.set_active_time_value(t)
        grids.append(reader.read()[0])
    # one camera for the three panels, looking down on the glass, fitting every frame
    lo = np.min([g.points.min(axis=0) for g in grids], axis=0)
    hi = np.max([g.points.max(axis=0) for g in grids], axis=0)
    size = (1200, 260)
    aspect = size[0] / len(TIMES) / size[1]
    centre = (lo + hi) / 2
    scale = 1.08 * max((hi - lo)[1] / 2, (hi - lo)[0] / 2 / aspect)
    pv.OFF_SCREEN = True
    p = viz.offscreen_plotter(shape=(1, len(TIMES)), window_size=size, border=False)
    p.set_background("white")
    cmap = matplotlib.colormaps["tab10"]
    for k, (t, grid) in enumerate(zip(TIMES, grids)):
        names = table_names(grid.field_data, "body")
        colours = [matplotlib.colors.to_hex(cmap(i)) for i in range(len(names))]
        p.subplot(0, k)
        p.add_mesh(grid.extract_cells(np.flatnonzero(grid.cell_data["part_id"] != 3)), scalars="body_id",
                   cmap=colours, clim=[-0.5, len(names) - 0.5], render_lines_as_tubes=True, line_width=5,
                   show_scalar_bar=False)
        joints = grid.extract_cells(np.flatnonzero(grid.cell_data["part_id"] == 3))
        p.add_mesh(pv.PolyData(np.asarray(joints.points)), color="dimgray", render_points_as_spheres=True,
                   point_size=9)
        p.add_text(f"t = {t:.2f} s", font_size=10, color="black")
        p.enable_parallel_projection()
        p.camera.focal_point = centre
        p.camera.position = centre + np.array([0.0, 0.0, 10.0])
        p.camera.up = (0.0, 1.0, 0.0)
        p.camera.parallel_scale = scale
        if k == 0:
            p.add_legend([[n, c] for n, c in zip(names, colours)], bcolor="white", face="rectangle",
                         loc="upper right", size=(0.42, 0.5))
    p.screenshot(str(HERE / "wiper_vtk.png"))
    p.close()
    print(f"wrote {HERE / 'wiper_vtk.png'}")
    pvbatch = shutil.which("pvbatch")
    if pvbatch:
        script = paraview_script(out / "open_in_paraview.py")
        prefix = ["xvfb-run", "-a"] if shutil.which("xvfb-run") else []
        subprocess.run([*prefix, pvbatch, str(script), "--time", "0.25", "--screenshot",
                        str(HERE / "wiper_paraview.png")], check=True, cwd=out)
        print(f"wrote {HERE / 'wiper_paraview.png'}")


if __name__ == "__main__":
    main()
