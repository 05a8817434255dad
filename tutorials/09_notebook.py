r"""
flexmb in a notebook
====================

A notebook-style script (cells marked ``# %%``: open it in Jupyter with
jupytext, or run the cells in VS Code or Spyder) that shows what a notebook
user gets from flexmb:

* a progress bar while :func:`flexmb.simulate` runs (tqdm's notebook
  widget; a bar in a terminal, a line every half minute in a log);
* the :class:`~flexmb.Result` displayed as a short table: status, output
  times, the integrator and why ``method='auto'`` chose it, steps and
  right-hand sides, the largest constraint residuals, the energy at both
  ends;
* ``result.show()``: the mechanism drawn at an output time, inline
  (pyvista, off-screen; ``pip install -e ".[viz]"``): the last cell shows
  the four-bar at the end of its swing (without pyvista the tutorial says
  so and ends there).

The model is tutorial 02's four-bar (the B5 benchmark), read from its scene
file and released from rest: a loop closed by a cut joint. The numbers to
expect: the loop stays closed to 1e-9 m and the energy to 1e-7 of its swing.
"""

from pathlib import Path

import numpy as np

import flexmb as fm

# %%
# The four-bar of tutorial 02, from its scene file beside this script.

HERE = Path(__file__).resolve().parent if "__file__" in globals() else Path.cwd()  # sphinx-gallery: no __file__
scene = fm.load_scene(HERE / "02_fourbar.toml")

# %%
# Simulate 2 s with the scene's settings. In a notebook the progress bar
# shows under the cell; ``progress=None`` (the default) shows it everywhere
# but in a CI job.

result = scene.simulate(t_end=2.0, n_out=201, progress=None)

# %%
# The last expression of a cell is displayed: a Result shows itself as a
# short table (``Result._repr_html_``).

result

# %%
# The numbers behind the table.

max_residual = float(result.residual.max())
swing = float(np.ptp(result.potential))
energy_drift_rel = float(np.ptp(result.energy) / swing)
print(f"loop residual {max_residual:.1e} m, energy drift {energy_drift_rel:.1e} of the swing")

# %%
# The mechanism at the last output time, drawn through its joints with the
# model that made it. ``show`` draws with pyvista, which the ``viz`` and
# ``docs`` extras bring; without it (the ``test`` install) the tutorial says
# what to install and draws nothing.

try:
    import pyvista  # noqa: F401 - what result.show draws with

    can_draw = True
except ImportError:
    can_draw = False
    print("drawing the mechanism needs pyvista, which is not installed: pip install 'flexmb[viz]'")

# %%
# ``show`` returns the PNG's path; as the last expression of a cell it shows
# the picture, in a notebook as on this page.

result.show(-1) if can_draw else None
