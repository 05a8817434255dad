"""Write ``docs/figures/contact_paraview.png``: a contact scene's VTK series in ParaView, contact force as an arrow.

Runs ``flexmb run docs/figures/cantilever_stop.toml`` (the cantilever of
``benchmarks/contact_stop.py`` falling onto its stop), reads the VTK files
back to find the output time of the largest contact force (the point data
``contact_force``), and renders that time with the ``open_in_paraview.py``
the run wrote (ParaView's ``pvbatch``, under ``xvfb-run`` without a
display), seen from the side. Run from the repository::

    python docs/figures/contact_paraview.py
"""

import glob
import random
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import meshio
import numpy as np


HERE = Path(__file__).resolve().parent

# pvbatch: open the series with the run's own script, then look along +y (the beam bends in x-z)
RENDER = """
import runpy, sys
ns = runpy.run_path(sys.argv[1], run_name="flexmb.open_in_paraview")
from paraview import simple as pv
ns["main"]([sys.argv[2], "--time", sys.argv[3]])
view = pv.GetActiveView()
view.CameraPosition = [0.5, -3.0, -0.01]
view.CameraFocalPoint = [0.5, 0.0, -0.01]
view.CameraViewUp = [0.0, 0.0, 1.0]
view.ResetCamera(True)
view.CameraParallelProjection = 1
bar = pv.GetScalarBar(pv.GetColorTransferFunction("von_mises"), view)
bar.WindowLocation = "Upper Center"  # clear of the beam, which the side view puts mid-height
bar.Orientation = "Horizontal"
stop = pv.Line(registrationName="stop", Point1=[0.9, 0.0, -0.0225], Point2=[1.1, 0.0, -0.0225])
shown = pv.Show(stop, view)
shown.AmbientColor = shown.DiffuseColor = (0.0, 0.0, 0.0)
shown.LineWidth = 3.0
pv.Render(view)
pv.SaveScreenshot(sys.argv[4], view, ImageResolution=[900, 420])
"""


def main():
    out = Path(tempfile.mkdtemp())
    subprocess.run([sys.executable, "-m", "flexmb", "run", str(HERE / "cantilever_stop.toml"), "--out", str(out),
                    "--quiet"], check=True)
    files = sorted(glob.glob(str(out / "vtk" / "*.vtu")))
    peaks = []
    for f in files:
        mesh = meshio.read(f)
        peaks.append((np.linalg.norm(mesh.point_data["contact_force"], axis=1).max(),
                      float(mesh.field_data["time"][0])))
    force, time = max(peaks)
    print(f"largest contact force in the VTK series: {force:.4g} N at t = {time:.4g} s")
    pvbatch = shutil.which("pvbatch")
    if not pvbatch:
        raise SystemExit("pvbatch (ParaView) is needed for the picture")
    script = out / "render.py"
    script.write_text(RENDER)
    png = HERE / "contact_paraview.png"
    png.unlink(missing_ok=True)
    for _ in range(3):  # a virtual display another process took first: try another number
        prefix = ["xvfb-run", "-n", str(random.randint(100, 999))] if shutil.which("xvfb-run") else []
        subprocess.run([*prefix, pvbatch, str(script), str(out / "open_in_paraview.py"),
                        str(out / "vtk" / "cantilever_stop.pvd"), repr(time), str(png)], cwd=out)
        if png.is_file():
            break
    else:
        raise SystemExit("pvbatch wrote no picture")
    print(f"wrote {png}")


if __name__ == "__main__":
    main()
