"""Pictures of results: off-screen renders and GIFs (pyvista), time histories (matplotlib), a 3-D viewer.

pyvista and matplotlib come with the ``viz`` extra (``pip install
flexmb[viz]``) and are imported inside the functions, so ``import flexmb``
never loads them.

Modules
-------
offscreen
    Off-screen pyvista plotters that skip VTK's attempt at a missing
    display (and its ``bad X server connection`` warning).
render
    Off-screen renders of the scene :mod:`flexmb.export.vtk` writes, and
    GIF animations.
viewer
    An interactive 3-D viewer: a self-contained HTML page (no extra
    needed), shown inline in a notebook.
plots
    Time histories of coordinates, and section-field envelopes and
    stations.
"""

from .plots import coordinate_units, plot, plot_envelope, plot_station
from .offscreen import offscreen_plotter
from .render import Picture, RenderOptions, animate, render_state
from .viewer import View, view_html, write_view

__all__ = ["Picture", "RenderOptions", "render_state", "animate", "offscreen_plotter", "plot", "coordinate_units",
           "plot_envelope", "plot_station", "View", "view_html", "write_view"]
