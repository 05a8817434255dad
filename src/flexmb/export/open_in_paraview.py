"""Open flexmb's VTK series in ParaView, coloured by stress.

``flexmb run`` copies this file into its output folder as
``open_in_paraview.py``. It needs ParaView's Python, not flexmb::

    pvpython open_in_paraview.py                      # every .pvd below its folder
    pvpython open_in_paraview.py vtk_flexible/wiper_flexible.pvd
    pvpython open_in_paraview.py --screenshot wiper.png   # render the last time to a PNG
    pvpython open_in_paraview.py --time 0.25 --screenshot wiper.png
    paraview --script=open_in_paraview.py             # the same in the ParaView window

Each series opens as one time series (the ``.pvd``): bodies as their shapes
(lines drawn as tubes, joints as balls), coloured by the von Mises stress
(``von_mises``, Pa, range over all times) where a series carries section
stresses, else by body: the cell data ``body_id`` as categories, one colour
each (matplotlib's tab10, as ``flexmb.viz`` draws them), labelled in the
legend with the body names (the field data ``body:<name>``, holding the
body's id). The first
series with stresses is shown, the others are loaded and hidden (the eye
icon in the Pipeline Browser shows them). Run interactively (``pvpython
-i``, or in the ParaView window) the time slider steps through the run.

Importing this module as part of flexmb does nothing; it runs when
executed as a script.
"""

import glob
import os
import sys

__all__ = ["main"]


def _arguments(argv):
    """The .pvd files, the screenshot path and the time named in ``argv`` (other words are ignored)."""
    files, shot, time = [], None, None
    args = list(argv)
    while args:
        a = args.pop(0)
        if a == "--screenshot" and args:
            shot = args.pop(0)
        elif a == "--time" and args:
            time = float(args.pop(0))
        elif a.endswith(".pvd"):
            files.append(a)
    return files, shot, time


def _times(reader):
    """A reader's time steps as a list (ParaView gives a single number for a single step)."""
    values = reader.TimestepValues
    if isinstance(values, (int, float)):
        return [float(values)]
    return [float(t) for t in values] or [0.0]


#: matplotlib's tab10, the colours flexmb.viz gives the bodies
_TAB10 = [(0.122, 0.467, 0.706), (1.0, 0.498, 0.055), (0.173, 0.627, 0.173), (0.839, 0.153, 0.157),
          (0.580, 0.404, 0.741), (0.549, 0.337, 0.294), (0.890, 0.467, 0.761), (0.498, 0.498, 0.498),
          (0.737, 0.741, 0.133), (0.090, 0.745, 0.812)]


def _body_names(reader):
    """The body names of a series, index = ``body_id``: its field data ``body:<name>`` holds the id."""
    ids = {}
    for key in reader.FieldData.keys():
        if key.startswith("body:"):
            ids[key[len("body:"):]] = int(reader.FieldData[key].GetRange()[0])
    return sorted(ids, key=ids.get)


def _colour_by_body(pv, display, view, names):
    """Colour by ``body_id`` as categories, each labelled with its body's name in the legend."""
    pv.ColorBy(display, ("CELLS", "body_id"))
    lut = pv.GetColorTransferFunction("body_id")
    lut.InterpretValuesAsCategories = 1
    lut.AnnotationsInitialized = 1
    lut.Annotations = [text for k, name in enumerate(names) for text in (str(k), name)]
    lut.IndexedColors = [c for k in range(len(names)) for c in _TAB10[k % len(_TAB10)]]
    lut.IndexedOpacities = [1.0] * len(names)
    bar = pv.GetScalarBar(lut, view)
    bar.Title = "body"
    bar.ComponentTitle = ""


def _series(files, folder):
    if files:
        return [os.path.abspath(f) for f in files]
    return sorted(glob.glob(os.path.join(folder, "**", "*.pvd"), recursive=True))


def main(argv=None, folder=None):
    """Open the series in ParaView; optionally save a screenshot of the last time.

    Parameters
    ----------
    argv : list of str, optional
        ``.pvd`` files, ``--time T`` (s; default the last output) and
        ``--screenshot PNG`` (default: the command line).
    folder : str, optional
        Where to look for ``.pvd`` files when ``argv`` names none (default:
        this script's folder, else the working folder).

    Returns
    -------
    list
        The readers, one per series.
    """
    from paraview import simple as pv

    if folder is None:
        here = globals().get("__file__")
        folder = os.path.dirname(os.path.abspath(here)) if here else os.getcwd()
    files, shot, time = _arguments(sys.argv[1:] if argv is None else argv)
    paths = _series(files, folder)
    if not paths:
        raise SystemExit(f"open_in_paraview: no .pvd file named or found below {folder}")
    view = pv.GetActiveViewOrCreate("RenderView")
    readers, shown = [], None
    for path in paths:
        reader = pv.PVDReader(registrationName=os.path.basename(path), FileName=path)
        reader.UpdatePipelineInformation()
        reader.UpdatePipeline(_times(reader)[-1])
        display = pv.Show(reader, view)
        display.RenderLinesAsTubes = 1
        display.LineWidth = 4.0
        display.RenderPointsAsSpheres = 1
        display.PointSize = 10.0
        if "von_mises" in reader.PointData.keys():
            pv.ColorBy(display, ("POINTS", "von_mises"))
            display.RescaleTransferFunctionToDataRangeOverTime()
            lut = pv.GetColorTransferFunction("von_mises")
            lut.ApplyPreset("Viridis (matplotlib)", True)
            bar = pv.GetScalarBar(lut, view)
            bar.Title = "von Mises stress"
            bar.ComponentTitle = "(Pa)"
        elif "body_id" in reader.CellData.keys():
            _colour_by_body(pv, display, view, _body_names(reader))
        display.SetScalarBarVisibility(view, True)
        if shown is None and "von_mises" in reader.PointData.keys():
            shown = reader
        readers.append(reader)
    shown = shown or readers[0]
    for reader in readers:
        if reader is not shown:
            pv.Hide(reader, view)
    pv.SetActiveSource(shown)
    scene = pv.GetAnimationScene()
    scene.UpdateAnimationUsingDataTimeSteps()
    times = _times(shown)
    scene.AnimationTime = times[-1] if time is None else min(times, key=lambda t: abs(t - time))
    view.ResetCamera(True)  # fit the bounding box, not its sphere
    pv.Render(view)
    if shot:
        pv.SaveScreenshot(shot, view, ImageResolution=[800, 600])
    return readers


if not __name__.startswith("flexmb."):  # run as a script (pvpython, paraview --script, Run Script)
    main()
