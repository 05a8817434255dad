"""Parameter studies: many runs of one scene file with some keys varied, serially, on a process pool or on Dask.

A study takes a scene file (:mod:`flexmb.scene`), a set of *parameters* --
scene key paths such as ``bodies.bar.mass``, ``materials.spring_steel.E``,
``forces.right_blade_friction.normal_load`` or ``drivers.motor.rpm`` -- each
with a *spec* (a list of values, a linear or logarithmic range, or a random
distribution), and a list of named *outputs* (scalars such as the peak speed
of a tracked point, the peak driver effort, the energy-balance error). Every
*case* is the scene's TOML document with the varied key paths replaced,
built by the same loader as a scene file (:func:`flexmb.scene.scene_from_dict`),
simulated, and reduced to its outputs. The cases run

* serially (``executor="serial"``),
* on local processes (the default; one process per case, at most
  ``workers`` at a time, with the ``forkserver`` or ``spawn`` start method;
  a case past its time limit is killed, and every case process ends when
  the study process ends, even if it is killed), or
* on a Dask cluster (``scheduler="tcp://host:8786"`` or a
  ``dask.distributed.Client``; ``pip install -e ".[dask]"``, imported only
  then),

and give the same table. Each finished case is written at once, atomically,
to ``OUT/cases/<case id>.json``; the case id is a hash of its parameter
values, so a study started again with the same arguments runs only the
cases that are not yet done. A case that fails (the scene does not build,
the run goes non-finite, the worker process dies, the case passes its
time limit: ``time_limit`` seconds, the ``[study] time_limit`` scene key or
``flexmb study --time-limit``) is recorded with its error and the study
goes on. At the end the table is written as ``table.csv``,
``table.npz`` (and ``table.parquet`` if pyarrow is installed), each output
is plotted against each parameter (``study.png``) and a summary is printed.

Examples
--------
>>> import flexmb as fm
>>> study = fm.Study.from_file("tutorials/01_pendulum.toml",  # doctest: +SKIP
...                            vary={"bodies.bar.mass": [1.0, 2.0], "initial.positions.pin": "lin:0:1:3"},
...                            outputs=["peak_speed:tip", "final:pin"], fixed={"solver.t_end": 0.5})
>>> result = study.run("results/study")  # doctest: +SKIP
>>> result.column("peak_speed:tip")  # doctest: +SKIP
"""

from .sampling import DISTRIBUTIONS, SAMPLINGS, Distribution
from .spec import parse_spec, parse_value
from ..scene.metrics import OUTPUTS, default_outputs
from .executors import WORKER_ENV, default_workers
from .table import StudyResult
from .study import Study, case_id, run_study

__all__ = ["Distribution", "DISTRIBUTIONS", "OUTPUTS", "SAMPLINGS", "Study", "StudyResult", "parse_spec",
           "parse_value", "run_study"]
