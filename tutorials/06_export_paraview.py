"""
Export to ParaView: VTK time series, colouring by bending, an animation
=======================================================================

The flexible cantilever of tutorial 03 (benchmark B1: aluminium strip,
1 m x 20 mm x 5 mm, 8 segments bending in the x-z plane) is released
straight from rest under gravity and swings down. The tutorial writes the
run as a VTK time series (one ``.vtu`` per output time and a ``.pvd``
collection that ParaView opens as one time series), reads the files back to
show what they hold (the beam as its segments' 20 mm x 5 mm blocks around
its centre line, the clamp as a joint point, the bending angle, moment and
stress at every segment joint), turns the elastic coordinate ``bending_y``
into a bending moment, and, when run as a script, draws the beam coloured
by its bending moment and writes a GIF animation with pyvista, off-screen.

The numbers to expect: 16 files at t = 0, 0.01, ..., 0.15 s, whose times,
tip displacements and bending angles read back exactly as computed
(differences 0); the tip swings down to 46.7 mm at t = 0.12 s (about
twice the static deflection; tutorial 03); in the static state the bending
moment ``k_j eta_j`` at segment joint j equals the closed form
``rho A g (L - x_j)^2 / 2`` to about 1e-10 (1.3244 N m at the clamp,
where the joint spring is 2k); in the run the clamp moment peaks at
2.50 N m, 1.89 times the static one, at t = 0.14 s.

Run as a script (``python tutorials/06_export_paraview.py``, with the
``viz`` extra installed) it also writes, in
``results/06_export_paraview/``, ``swing_displacement.gif`` (the short
form: ``flexmb.viz.animate`` colouring by displacement, the tip turning
yellow at 0.047 m), ``bending.png`` (the beam at its lowest, coloured by
bending moment from 2.5 N m at the clamp to 0 at the tip, vertical scale
x5) and ``swing.gif`` (the swing coloured by bending moment).
"""

import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np

import flexmb as fm
from flexmb.export.snapshots import export_snapshot
from flexmb.export.vtk import table_names

# %%
# The run
# -------
# The beam is the one of tutorial 03, undamped; ``n_out=16`` output times,
# 0.01 s apart, are the frames of the time series. With 8 segments
# ``method="auto"`` finds the segment springs soft enough for the explicit
# DOP853 (tutorial 03 explains when it takes the implicit Radau instead).

L, g, N = 1.0, 9.81, 8
section = fm.Section.rectangular(0.02, 0.005)
material = fm.Material.aluminium()


def cantilever(n_segments=N):
    """The B1 cantilever under gravity (-z), bending in the x-z plane only."""
    model = fm.Model("cantilever")
    beam = fm.FlexibleBody.uniform_beam("beam", L, section, material, n_segments, keep=("bend_y",))
    model.add(fm.Fixed("clamp", model.ground, beam), fm.Gravity((0.0, 0.0, -g)))
    return model


model = cantilever()
system = model.build()
res = fm.simulate(system, 0.15, n_out=16, rtol=1e-6)
print(f"{res.method}: {res.n_steps} steps, status {res.status}")

# %%
# The short form: a VTK time series
# ---------------------------------
# ``res.export_vtk(folder, system=system)`` writes ``beam_0000.vtu`` ...
# ``beam_0015.vtu`` and ``beam.pvd`` and returns the ``.pvd`` path. The
# system (or the model) lets the export draw the beam as its segments'
# blocks through its clamp, make the ``velocity`` point data exact (from
# the speeds through the kinematics) and add the section moments and the
# von Mises stress; without it a Result alone gives the centre line and
# finite-difference velocities. In ParaView: **File > Open** ``beam.pvd``,
# **Apply**, then colour by ``von_mises``, ``moment_bend_y`` or
# ``body_id``; the time slider shows the real times. The points are where
# the beam is at each time; **Filters > Warp By Vector** (it takes
# ``elastic_displacement``) with a scale factor of 10 shows the bending 11
# times as large. ``flexmb run`` also writes ``open_in_paraview.py``
# (``flexmb.export.vtk.paraview_script``), which ``pvpython`` runs to open
# every series coloured by stress.

out = Path("results") / "06_export_paraview"
pvd = res.export_vtk(out, prefix="beam", system=system)
print(f"wrote {pvd}")

# %%
# What the collection holds
# -------------------------
# The ``.pvd`` is a small XML file listing every ``.vtu`` with its time
# (written with ``repr``, so the times read back exactly); file names are
# relative to the ``.pvd``, so the folder can be moved as a whole.

entries = ET.parse(pvd).getroot().find("Collection").findall("DataSet")
pvd_times = np.array([float(e.get("timestep")) for e in entries])
files = [pvd.parent / e.get("file") for e in entries]
n_files = len(files)
time_error = float(np.max(np.abs(pvd_times - res.t)))
print(f"{n_files} files, {files[0].name} ... {files[-1].name}; max |t_pvd - t| = {time_error:.1e} s")

# %%
# What a ``.vtu`` holds
# ---------------------
# ``meshio.read`` reads each file back (as do pyvista and ParaView: the
# files hold numbers only, the body names in the field data as entries
# ``"body:<name>"`` holding the ``body_id``, which ``table_names`` lists).
# A flexible body is its
# deformed centre line, N + 1 points (root, the N - 1 interior segment
# joints, tip) joined by N line cells, and one 8-corner block per segment,
# the section's width and height; the clamp is a vertex at the root. Point
# data: ``velocity`` (m/s), the elastic coordinate ``bending_y`` (rad) of
# the segment joint at each centre-line point (0 at the tip, where there is
# no joint) and the section loads there (``moment_bend_y``, N m;
# ``von_mises``, Pa); a block's corners carry the values of the joint at
# their end; ``elastic_displacement`` (m) is every point minus where it
# would be on the beam undeformed (here, clamped to the ground, the
# displacement from the straight beam). The tip read back, minus where it
# started, equals ``res.shape("beam")`` minus the initial shape, and equals
# the tip's elastic displacement.

meshes = [meshio.read(f) for f in files]
last = meshes[-1]
print(f"points {last.points.shape}, cells {[(c.type, len(c.data)) for c in last.cells]}, "
      f"point data {sorted(last.point_data)}, bodies {table_names(last.field_data)}")
shape = res.shape("beam")  # (n_times, N + 1, 3)
tip_from_files = np.array([m.points[N] - meshes[0].points[N] for m in meshes])  # the centre line comes first
tip_error = float(np.max(np.abs(tip_from_files - (shape[:, -1] - shape[0, -1]))))
warp_error = float(np.max(np.abs(tip_from_files - np.array([m.point_data["elastic_displacement"][N] for m in meshes]))))
names = [f"beam.j{j}.bend_y" for j in range(N)]
bending_from_files = np.array([m.point_data["bending_y"][:N] for m in meshes])
bending_error = float(np.max(np.abs(bending_from_files - np.column_stack([res.coordinate(n) for n in names]))))
tip_z = tip_from_files[:, 2]
i_min = int(np.argmin(tip_z))
tip_z_min, t_min = float(tip_z[i_min]), float(res.t[i_min])
print(f"read back: tip error {tip_error:.1e} m, elastic displacement error {warp_error:.1e} m, "
      f"bending error {bending_error:.1e} rad; "
      f"lowest tip {1e3 * tip_z_min:.2f} mm at t = {t_min:.2f} s")

# %%
# Colouring by bending
# --------------------
# ``bending_y`` is the rotation ``eta_j`` of the segment joint at point j.
# Times the joint spring ``k_j`` (``beam.joint_stiffness()``: ``E I_y / l``,
# and ``2 E I_y / l`` at the clamp) it is the bending moment there, N m: a
# field worth colouring by. In the static state (``fm.linear_statics``,
# written as one ``.vtu`` with ``export_snapshot``) the moment at joint j
# must carry the weight of the beam beyond it: ``M(x_j) = rho A g (L -
# x_j)^2 / 2``, exactly, for this lumped model.

k = model["beam"].joint_stiffness().ravel()  # (N,), N m/rad; joint j at x_j = j L / N
x_joint = np.arange(N) * L / N
moment_ref = material.density * section.area * g * (L - x_joint) ** 2 / 2
x_static = fm.linear_statics(system)
static_file = export_snapshot(system, x_static, out / "static.vtu")
static_moment = k * meshio.read(static_file).point_data["bending_y"][:N]
static_moment_error = float(np.max(np.abs(static_moment - moment_ref)) / moment_ref[0])
clamp_moment_ref = float(moment_ref[0])
print(f"static bending moment [N m]: {static_moment.round(4)}")
print(f"closed form             : {moment_ref.round(4)} (relative error {static_moment_error:.1e})")

# The same field over the run: released from rest, the beam overshoots its
# static shape and the clamp moment swings to about twice the static one.
moment = bending_from_files * k  # (n_times, N)
clamp_moment_peak = float(np.max(np.abs(moment[:, 0])))
print(f"dynamic clamp moment peaks at {clamp_moment_peak:.4f} N m "
      f"({clamp_moment_peak / clamp_moment_ref:.3f} x static) at t = {res.t[np.argmax(np.abs(moment[:, 0]))]:.2f} s")

# %%
# Pictures with pyvista
# ---------------------
# The short form, ``flexmb.viz.animate``, colours by ``|displacement|``.
# The long form reads the ``.pvd`` with pyvista, adds the bending moment as
# point data, draws the centre line as a tube and writes a PNG and a GIF,
# off-screen (:func:`flexmb.viz.offscreen_plotter`: without a display, VTK's
# EGL or OSMesa window, with no attempt at X and no warning about it).

if __name__ == "__main__":
    try:
        import pyvista as pv

        from flexmb import viz
    except ImportError:
        print("pyvista is not installed (pip install -e '.[viz]'): no pictures")
    else:
        pv.OFF_SCREEN = True
        viz.animate(res, out / "swing_displacement.gif", system=system, scalars="displacement", view="xz", fps=10)
        print(f"wrote {out / 'swing_displacement.gif'}")

        reader = pv.get_reader(str(pvd))
        clim = [min(0.0, float(moment.min())), float(moment.max())]
        radius = 0.004 * L

        def frame(i):
            """The centre line at output i as a tube carrying the bending moment, N m."""
            reader.set_active_time_value(reader.time_values[i])
            grid = reader.read()[0]  # an UnstructuredGrid: the centre line's N + 1 points come first
            line = pv.PolyData(grid.points[: N + 1], lines=np.column_stack([np.full(N, 2), np.arange(N),
                                                                            np.arange(1, N + 1)]).ravel())
            line.point_data["bending moment"] = np.append(k, 0.0) * grid.point_data["bending_y"][: N + 1]
            return line.tube(radius=radius, n_sides=16)

        def plotter(first):
            """A plotter looking along -y at the beam of output ``first``, z scaled 5 times."""
            p = viz.offscreen_plotter(window_size=[800, 400])
            p.set_background("white")
            p.set_scale(zscale=5.0)  # the deflection is 5 % of the length: exaggerate it
            p.add_mesh(frame(first), scalars="bending moment", cmap="viridis", clim=clim, name="beam",
                       scalar_bar_args=dict(title="bending moment (N m), z scale x5", color="black",
                                            fmt="%.2f", n_labels=3))
            p.view_xz()
            p.reset_camera()
            return p

        p = plotter(i_min)
        p.screenshot(str(out / "bending.png"))
        p.close()
        print(f"wrote {out / 'bending.png'}")

        p = plotter(i_min)  # the camera frames the lowest shape, so every frame fits
        p.open_gif(str(out / "swing.gif"), fps=10)
        for i in range(len(res.t)):
            p.add_mesh(frame(i), scalars="bending moment", cmap="viridis", clim=clim, name="beam",
                       show_scalar_bar=False)
            p.write_frame()
        p.close()
        print(f"wrote {out / 'swing.gif'}")
