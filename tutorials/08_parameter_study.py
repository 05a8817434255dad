"""
Parameter studies
=================

Engineers rarely run one simulation: they vary the blade stiffness, the
friction, the crank speed or the number of segments, and compare.
:class:`flexmb.Study` runs one scene file many times with some of its keys
replaced -- a parameter is any scene key path, such as
``materials.spring_steel.E`` or ``forces.right_blade_friction.normal_load``
-- reduces each run to a few named outputs, and writes one table with a row
per case (``table.csv``, ``table.npz``), a plot of each output against each
parameter (``study.png``) and a summary. The cases run serially, on a local
process pool (the default) or on a Dask cluster, and each finished case is
saved at once, so a study that is stopped resumes where it was.

The short run below sweeps the tip friction of the rigid-blade wiper
(``tutorials/04_wiper_rigid.toml``): 4 normal loads, half a crank turn. With
rigid blades the wiper is a mechanism with 0 degrees of freedom, so its
motion does not depend on the friction, the friction force is proportional
to the normal load N, and the crank torque and the motor's work are *affine*
in N: ``W(N) = W(0) + N dW/dN``. The numbers to expect (``rtol = 1e-9``):
the motor's work over half a turn lies on a straight line in N to about
1e-9 of its value (its second differences vanish), it grows by 0.315 J per
newton of normal load, the peak tip speed is 1.9945 m/s in every case (the
same to 1e-7), the peak crank torque grows from 0.29 to 0.98 N m, and the
energy balance of every case holds to about 2e-9.

The full sweep, the flexible-blade wiper with the friction load crossed with
the blades' Young's modulus, runs on the process pool when this file is run
as a script (``python tutorials/08_parameter_study.py``; a few minutes on 2
cores). The same study from the command line::

    flexmb study tutorials/04_wiper.toml \\
        --vary "forces.right_blade_friction.normal_load+forces.left_blade_friction.normal_load=lin:2:8:4" \\
        --vary materials.spring_steel.E=7e10,1.4e11,2.1e11 \\
        --output peak_speed:right_tip --output peak_effort:motor --output energy_balance \\
        --out results/study_wiper

and with ``--scheduler tcp://HOST:8786`` it runs on a Dask cluster.
"""

from pathlib import Path

import numpy as np

import flexmb as fm

# the scene files beside this script (sphinx-gallery runs it in its own folder, without __file__)
TUTORIALS = Path(__file__).resolve().parent if "__file__" in globals() else Path.cwd()

# %%
# The short form
# --------------
# :func:`flexmb.run_study` takes the scene file, ``{key path: values}`` and an
# output folder. A key path ``a+b`` sets several keys to one value: here the
# normal load of both blades' friction. ``fixed`` sets keys in every case
# (half a crank turn), and ``outputs`` names what each case reports (see
# :data:`flexmb.study.OUTPUTS`): the peak speed of a tracked point, the peak
# torque and the work of the motor, the energy-balance error.
# ``results/study_rigid/`` is relative to the working folder.
# ``executor="serial"`` runs the 4 short cases in this process; leave it out
# to use every core.

FRICTION = "forces.right_blade_friction.normal_load+forces.left_blade_friction.normal_load"
loads = np.array([1.0, 3.0, 5.0, 7.0])  # N (the friction plugin needs > 0)

result = fm.run_study(
    TUTORIALS / "04_wiper_rigid.toml",
    {FRICTION: loads.tolist()},
    "results/study_rigid",
    outputs=["peak_speed:right_tip", "peak_effort:motor", "driver_work:motor", "energy_balance"],
    fixed={"solver.t_end": 0.5, "solver.n_out": 101, "solver.rtol": 1e-9},
    executor="serial",
    progress=False,
)
print(result.summary())

# %%
# The table
# ---------
# ``result.column(name)`` gives one column (NaN where a case failed);
# ``result.rows`` holds each case's parameters, outputs, status, error text,
# wall time and the worker that ran it. ``results/study_rigid/table.csv`` is
# the same table for a spreadsheet.

work = result.column("driver_work:motor")
torque = result.column("peak_effort:motor")
tip_speed = result.column("peak_speed:right_tip")
energy_balance = result.column("energy_balance")
print("normal load [N]   motor work [J]   peak torque [N m]   peak tip speed [m/s]")
for row in zip(loads, work, torque, tip_speed):
    print("{:15.1f} {:16.6f} {:19.4f} {:22.4f}".format(*row))

# %%
# The work is affine in the load: its second differences vanish (relative
# to the work), and its slope is the friction's share of the work per newton.
work_slope = float(np.polyfit(loads, work, 1)[0])  # J/N
work_nonlinearity = float(np.max(np.abs(np.diff(work, 2))) / np.max(np.abs(work)))
tip_speed_spread = float(np.ptp(tip_speed))  # the motion does not depend on the friction
print(f"dW/dN = {work_slope:.4f} J/N; second differences / work = {work_nonlinearity:.1e}; "
      f"tip speed spread {tip_speed_spread:.1e} m/s")

# %%
# The long form
# -------------
# :class:`flexmb.Study` holds the same description and runs it with
# :meth:`~flexmb.Study.run`, choosing where: ``executor="process"`` with
# ``workers=N`` (a local process pool), ``client=dask.distributed.Client(...)``
# or ``scheduler="tcp://host:8786"`` (a Dask cluster). Ranges and random
# parameters are written as strings (:func:`flexmb.study.parse_spec`):
# ``"lin:2:8:4"``, ``"log:7e10:2.1e11:3"``, ``"uniform:2:8"`` (with
# ``samples`` and ``seed``, Latin hypercube by default). Run again into the
# same folder, a study runs only the cases not yet done.


def full_study():
    """The flexible-blade wiper: friction load (4) x Young's modulus (3), one crank turn, 12 cases.

    The scene's own solver settings: ``method = 'auto'`` (CVODE_BDF here, see docs/study.md), rtol 1e-6.
    """
    return fm.Study.from_file(
        TUTORIALS / "04_wiper.toml",
        {FRICTION: "lin:2:8:4", "materials.spring_steel.E": [7e10, 1.4e11, 2.1e11]},
        outputs=["peak_speed:right_tip", "peak_effort:motor", "energy_balance"],
    )


def full_sweep(out="results/study_wiper", workers=None):
    """Run :func:`full_study` on the process pool into ``out``."""
    return full_study().run(out, workers=workers)


if __name__ == "__main__":
    full = full_sweep()
    print(full.summary())
    print("plot: results/study_wiper/study.png")
