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
  (pyvista, off-screen; ``pip install -e ".[viz]"``).

The model is the B5 four-bar of the benchmarks released from rest: a loop
closed by a cut joint. The numbers to expect: the loop stays closed to
1e-9 m and the energy to 1e-7 of its swing.
"""

import numpy as np

import flexmb as fm

# %%
# The four-bar: ground 0.4 m, crank 0.1 m, coupler 0.4 m, rocker 0.3 m, all
# uniform bars of 1 kg per metre, under gravity; the joint D closes the loop.

model = fm.Model("four-bar")
lengths = {"crank": 0.1, "coupler": 0.4, "rocker": 0.3}
bars = {name: fm.RigidBody.slender_bar(name, mass=length, length=length) for name, length in lengths.items()}
model.add(
    fm.Revolute("A", model.ground, bars["crank"]),
    fm.Revolute("B", bars["crank"], bars["coupler"], parent_point=(0.1, 0.0, 0.0)),
    fm.Revolute("C", model.ground, bars["rocker"], parent_point=(0.4, 0.0, 0.0)),
    fm.Revolute("D", bars["coupler"], bars["rocker"], parent_point=(0.4, 0.0, 0.0),
                child_point=(0.3, 0.0, 0.0)),
    fm.Gravity((0.0, -9.81, 0.0)),
)
system = model.build()

# %%
# Simulate 2 s from the crank at 60 degrees, at rest. In a notebook the
# progress bar shows under the cell; ``progress=None`` (the default) shows
# it everywhere but in a CI job.

result = fm.simulate(system, 2.0, positions={"A": np.radians(60.0)}, fixed=["A"], rtol=1e-9, n_out=201)

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
# model that made it (needs pyvista; in a notebook the picture appears
# inline, elsewhere ``show`` returns the PNG's path).

if __name__ == "__main__":
    picture = result.show(-1)
