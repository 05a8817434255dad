"""Pictures of results: off-screen renders and GIFs (pyvista), time histories (matplotlib).

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
plots
    Time histories of coordinates, and section-field envelopes and
    stations.
"""

from .plots import coordinate_units, plot, plot_envelope, plot_station
from .offscreen import offscreen_plotter
from .render import Picture, RenderOptions, animate, render_state

__all__ = ["Picture", "RenderOptions", "render_state", "animate", "offscreen_plotter", "plot", "coordinate_units",
           "plot_envelope", "plot_station"]
