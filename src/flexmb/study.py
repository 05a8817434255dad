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

from __future__ import annotations

import csv
import ctypes
import hashlib
import inspect
import io
import json
import logging
import math
import multiprocessing
import os
import select
import signal
import socket
import threading
import time
import tomllib
from collections import deque
from pathlib import Path
from typing import Any, Callable

import numpy as np
from attrs import define, field, frozen

from ._files import atomic_write
from .progress import Progress
from .errors import FlexmbError, SceneError

log = logging.getLogger(__name__)

__all__ = ["Distribution", "DISTRIBUTIONS", "OUTPUTS", "SAMPLINGS", "Study", "StudyResult", "parse_spec",
           "parse_value", "run_study"]

#: random sampling schemes: Latin hypercube or plain Monte Carlo
SAMPLINGS = ("lhs", "mc")

#: columns of the table that are not parameters or outputs
META_COLUMNS = ("case", "case_id", "status", "error", "wall_time_s", "worker")


# ----------------------------------------------------------------------------- parameter specs


def _uniform(a, b):
    from scipy import stats

    return stats.uniform(loc=a, scale=b - a)


def _loguniform(a, b):
    from scipy import stats

    return stats.loguniform(a, b)


def _normal(a, b):
    from scipy import stats

    return stats.norm(loc=a, scale=b)


#: random distributions: name -> (``make(a, b)`` giving the frozen scipy.stats distribution, meaning of a and b)
DISTRIBUTIONS = {
    "uniform": (_uniform, "low, high"),
    "loguniform": (_loguniform, "low, high (both > 0)"),
    "normal": (_normal, "mean, standard deviation"),
}


def _check_kind(instance, attribute, value):
    if value not in DISTRIBUTIONS:
        raise FlexmbError(f"Distribution: unknown kind {value!r}; pick one of {', '.join(DISTRIBUTIONS)}")


@frozen
class Distribution:
    """A random parameter: values drawn by Monte Carlo or Latin hypercube sampling.

    Parameters
    ----------
    kind : {'uniform', 'loguniform', 'normal'}
        The distribution.
    a, b : float
        ``low, high`` (uniform, loguniform) or ``mean, std`` (normal).

    Examples
    --------
    >>> from flexmb.study import Distribution
    >>> Distribution("uniform", 1.0, 3.0).ppf([0.0, 0.5, 1.0])
    array([1., 2., 3.])
    """

    kind: str = field(validator=_check_kind)
    a: float = field(converter=float)
    b: float = field(converter=float)

    def __attrs_post_init__(self):
        if not (math.isfinite(self.a) and math.isfinite(self.b)):
            raise FlexmbError(f"Distribution {self.kind!r}: a and b must be finite, got {self.a}, {self.b}")
        if self.kind == "normal" and not self.b > 0:
            raise FlexmbError(f"Distribution 'normal': standard deviation must be > 0, got {self.b}")
        if self.kind != "normal" and not self.b > self.a:
            raise FlexmbError(f"Distribution {self.kind!r}: high must be > low, got {self.a}, {self.b}")
        if self.kind == "loguniform" and not self.a > 0:
            raise FlexmbError(f"Distribution 'loguniform': low must be > 0, got {self.a}")

    def as_scipy(self):
        """The distribution as a frozen :mod:`scipy.stats` distribution.

        Returns
        -------
        scipy.stats.rv_continuous_frozen
            ``uniform(loc=a, scale=b - a)``, ``loguniform(a, b)`` or
            ``norm(loc=a, scale=b)``: its ``ppf``, ``cdf``, ``mean()``, ...
        """
        return DISTRIBUTIONS[self.kind][0](self.a, self.b)

    def ppf(self, u) -> np.ndarray:
        """Inverse cumulative distribution: the value at probability ``u``.

        Parameters
        ----------
        u : array_like
            Probabilities in [0, 1].

        Returns
        -------
        ndarray
            Values, same shape as ``u``.
        """
        return np.asarray(self.as_scipy().ppf(np.asarray(u, dtype=float)), dtype=float)


def parse_value(text: str):
    """A TOML value from its text (``2`` is an integer, ``2.0`` a float, ``"x"`` or bare ``x`` a string).

    Parameters
    ----------
    text : str
        The value as written after ``=`` in a TOML file.

    Returns
    -------
    int, float, bool, str or list
        The value.

    Examples
    --------
    >>> from flexmb.study import parse_value
    >>> parse_value("4"), parse_value("2e11"), parse_value("true"), parse_value("Radau")
    (4, 200000000000.0, True, 'Radau')
    """
    text = text.strip()
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        try:
            return float(text)  # TOML rejects "1." and ".5"
        except ValueError:
            return text


def parse_spec(text: str):
    """Parse a parameter spec of the ``flexmb study --vary KEY=SPEC`` option.

    Parameters
    ----------
    text : str
        One of

        * ``v1,v2,...``: a list of values (TOML syntax: ``4`` is an integer,
          ``4.0`` a float);
        * ``lin:START:STOP:NUM``: ``NUM`` equally spaced values, ends included;
        * ``log:START:STOP:NUM``: ``NUM`` logarithmically spaced values;
        * ``uniform:LOW:HIGH``, ``loguniform:LOW:HIGH``, ``normal:MEAN:STD``:
          a random parameter, sampled ``samples`` times (Latin hypercube or
          Monte Carlo, with a seed).

    Returns
    -------
    list or Distribution
        The values, or the distribution to sample.

    Raises
    ------
    FlexmbError
        If the spec cannot be read.

    Examples
    --------
    >>> from flexmb.study import parse_spec
    >>> parse_spec("lin:2:8:4"), parse_spec("log:1e-3:1e-1:3")
    ([2, 4, 6, 8], [0.001, 0.01, 0.1])
    >>> parse_spec("normal:5:0.5")
    Distribution(kind='normal', a=5.0, b=0.5)
    """
    head, _, rest = text.partition(":")
    head = head.strip().lower()
    if head in ("lin", "log"):
        parts = rest.split(":")
        if len(parts) != 3:
            raise FlexmbError(f"spec {text!r}: write {head}:START:STOP:NUM")
        try:
            start, stop, num = float(parts[0]), float(parts[1]), int(parts[2])
        except ValueError:
            raise FlexmbError(f"spec {text!r}: START and STOP must be numbers and NUM an integer") from None
        if num < 1:
            raise FlexmbError(f"spec {text!r}: NUM must be >= 1, got {num}")
        if head == "log" and not (start > 0 and stop > 0):
            raise FlexmbError(f"spec {text!r}: a logarithmic range needs START and STOP > 0")
        values = np.linspace(start, stop, num) if head == "lin" else np.geomspace(start, stop, num)
        integral = all(isinstance(parse_value(p), int) for p in parts[:2])
        if integral and np.all(values == np.round(values)):
            return [int(round(v)) for v in values]
        return [float(v) for v in values]
    if head in DISTRIBUTIONS:
        parts = rest.split(":")
        if len(parts) != 2:
            raise FlexmbError(f"spec {text!r}: write {head}:A:B ({DISTRIBUTIONS[head][1]})")
        try:
            return Distribution(head, float(parts[0]), float(parts[1]))
        except ValueError:
            raise FlexmbError(f"spec {text!r}: A and B must be numbers") from None
    values = _split_list(text)
    if not values:
        raise FlexmbError(f"spec {text!r}: no values")
    return [parse_value(v) for v in values]


def _split_list(text: str) -> list[str]:
    """Split ``a,b,[1,2],"x,y"`` at the top-level commas."""
    out, depth, quote, cur = [], 0, None, ""
    for ch in text:
        if quote:
            quote = None if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            out.append(cur)
            cur = ""
            continue
        cur += ch
    out.append(cur)
    return [v.strip() for v in out if v.strip()]


def _as_spec(key: str, spec):
    """A list of plain Python values or a Distribution, from what the user gave."""
    if isinstance(spec, str):
        return parse_spec(spec)
    if isinstance(spec, Distribution):
        return spec
    values = list(np.atleast_1d(np.asarray(spec, dtype=object))) if not isinstance(spec, (list, tuple)) \
        else list(spec)
    if not values:
        raise FlexmbError(f"parameter {key!r}: no values")
    return [_plain(v) for v in values]


def _plain(v):
    """numpy scalars to Python numbers (TOML-like and JSON-serialisable)."""
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    return v


def _paths(key: str) -> list[str]:
    """The key paths one parameter sets: ``a.b+c.d`` sets both to the same value."""
    return [p.strip() for p in key.split("+") if p.strip()]


def _set(data: dict, path: str, value, source: str) -> None:
    """Set ``data[a][b][c] = value`` for the key path ``a.b.c``; every table on the way must exist."""
    keys = path.split(".")
    node, walked = data, []
    for k in keys[:-1]:
        walked.append(k)
        child = node.get(k) if isinstance(node, dict) else None
        if not isinstance(child, dict):
            here = ".".join(walked)
            known = ", ".join(sorted(k2 for k2, v in node.items() if isinstance(v, dict))) or "none"
            what = "no such table" if child is None else "not a table"
            raise SceneError(f"{source}: {here}: {what} in the scene (varied key {path!r}); tables here: {known}",
                             here)
        node = child
    node[keys[-1]] = value


# ----------------------------------------------------------------------------- outputs


def _tracked(scene, res, label):
    return scene.track(res)[label]


def _peak_speed(scene, res, label):
    p = _tracked(scene, res, label)
    return float(np.linalg.norm(np.gradient(p, res.t, axis=0), axis=1).max())


def _max_displacement(scene, res, label):
    p = _tracked(scene, res, label)
    return float(np.linalg.norm(p - p[0], axis=1).max())


def _peak_effort(scene, res, driver):
    return float(np.abs(res.driver_effort(driver)).max())


def _driver_work(scene, res, driver):
    if f"driver {driver}" not in res.work:
        raise FlexmbError("driver_work needs [solver] track_work = true")
    return float(res.work[f"driver {driver}"][-1])


def _energy_balance(scene, res, _=None):
    # with track_work: sum of the works = change of kinetic energy; without: energy is conserved
    if res.work:
        works = np.array(list(res.work.values()))
        error = np.abs(works.sum(axis=0) - (res.kinetic - res.kinetic[0]))
        scale = max(np.abs(works).max(), np.abs(res.kinetic - res.kinetic[0]).max(), 1e-300)
    else:
        error = np.abs(res.energy - res.energy[0])
        scale = max(np.abs(res.kinetic).max(), np.abs(res.potential - res.potential[0]).max(), 1e-300)
    return float(error.max() / scale)


def _final(scene, res, coordinate):
    return float(res.coordinate(coordinate)[-1])


def _maximum(scene, res, coordinate):
    return float(res.coordinate(coordinate).max())


def _minimum(scene, res, coordinate):
    return float(res.coordinate(coordinate).min())


def _history(scene, res, coordinate):
    return res.coordinate(coordinate).tolist()


def _times(scene, res, _=None):
    return res.t.tolist()


def _max_residual(scene, res, _=None):
    return float(res.residual.max())


def _n_rhs(scene, res, _=None):
    return int(res.n_rhs)


#: built-in outputs: name -> (function(scene, result, argument), what the argument names or None, description)
OUTPUTS = {
    "peak_speed": (_peak_speed, "point", "largest speed of a tracked point ([output.points]), m/s"),
    "max_displacement": (_max_displacement, "point", "largest distance of a tracked point from its start, m"),
    "peak_effort": (_peak_effort, "driver", "largest |torque| (N m) or |force| (N) a driver supplies"),
    "driver_work": (_driver_work, "driver", "work of a driver over the run, J (needs track_work)"),
    "energy_balance": (_energy_balance, None, "energy-balance error relative to the largest work or energy"),
    "final": (_final, "coordinate", "value of a coordinate at t_end"),
    "max": (_maximum, "coordinate", "largest value of a coordinate"),
    "min": (_minimum, "coordinate", "smallest value of a coordinate"),
    "history": (_history, "coordinate", "a coordinate at every output time (a time series)"),
    "time": (_times, None, "the output times, s (a time series)"),
    "max_residual": (_max_residual, None, "largest loop-closure residual"),
    "n_rhs": (_n_rhs, None, "right-hand-side evaluations (the cost, machine-independent)"),
}


def _check_output(spec, scene, system) -> None:
    """Raise if a named output does not fit the scene (checked once, before any case runs)."""
    if not isinstance(spec, str):
        if not (isinstance(spec, tuple) and len(spec) == 2 and isinstance(spec[0], str) and callable(spec[1])):
            raise FlexmbError(f"output {spec!r}: give a name such as 'peak_speed:tip' or a (name, function) pair")
        return
    name, _, arg = spec.partition(":")
    if name not in OUTPUTS:
        raise FlexmbError(f"unknown output {name!r}; pick one of {', '.join(OUTPUTS)} "
                          f"(or pass (name, function) in Python)")
    needs = OUTPUTS[name][1]
    if needs is None:
        if arg:
            raise FlexmbError(f"output {spec!r}: {name} takes no argument")
        return
    known = {"point": list(scene.output.points), "driver": [d.name for d in scene.model.drivers],
             "coordinate": list(system.coordinate_names)
             + sorted({n.rsplit(".", 1)[0] for n in system.coordinate_names})}[needs]
    if arg not in known:
        raise FlexmbError(f"output {spec!r}: write {name}:<{needs}>; {needs}s of this scene: "
                          f"{', '.join(known) or 'none'}")


def _is_real(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _output_name(spec) -> str:
    return spec if isinstance(spec, str) else spec[0]


def _evaluate(spec, scene, res):
    if isinstance(spec, str):
        name, _, arg = spec.partition(":")
        return OUTPUTS[name][0](scene, res, arg or None)
    value = spec[1](scene, res)
    return _plain(value)


def default_outputs(scene) -> list[str]:
    """The outputs of a study that names none: tracked points, drivers, energy balance, loop residual.

    Parameters
    ----------
    scene : Scene
        The scene.

    Returns
    -------
    list of str
        ``peak_speed:<point>`` for each tracked point, ``peak_effort:<driver>``
        for each driver, ``energy_balance``, ``max_residual`` and ``n_rhs``.
    """
    return ([f"peak_speed:{p}" for p in scene.output.points] + [f"peak_effort:{d.name}" for d in scene.model.drivers]
            + ["energy_balance", "max_residual", "n_rhs"])


# ----------------------------------------------------------------------------- one case (runs in a worker)


def _build(data: dict, source: str, fixed: dict, params: dict):
    from .scene import scene_from_dict

    import copy

    doc = copy.deepcopy(data)
    for key, value in list(fixed.items()) + list(params.items()):
        for path in _paths(key):
            _set(doc, path, value, source)
    return scene_from_dict(doc, source)


def _run_case(task: dict) -> dict:
    """Build, simulate and reduce one case; never raises for a failing case (module level: picklable)."""
    t0 = time.perf_counter()
    row = {"case": task["case"], "case_id": task["case_id"], "parameters": task["parameters"], "outputs": {},
           "status": "failed", "error": "", "worker": f"{socket.gethostname()}:{os.getpid()}"}
    try:
        scene = _build(task["data"], task["source"], task["fixed"], task["parameters"])
        res = scene.simulate(progress=False)
        row["status"] = res.status
        if res.status != "finished":
            row["error"] = res.message
        for spec in task["outputs"]:
            row["outputs"][_output_name(spec)] = _evaluate(spec, scene, res)
    except Exception as exc:  # recorded, and the study goes on
        row["status"] = "failed"
        row["error"] = f"{type(exc).__name__}: {exc}".replace("\n", " ")
    row["wall_time_s"] = time.perf_counter() - t0
    return row


def _failed_row(task: dict, message: str) -> dict:
    return {"case": task["case"], "case_id": task["case_id"], "parameters": task["parameters"], "outputs": {},
            "status": "failed", "error": message, "wall_time_s": float("nan"), "worker": ""}


class _CaseTimeout(BaseException):
    """Raised in the thread of a case that passed its time limit (a BaseException: no ``except Exception`` stops it)."""


def _timeout_message(limit: float) -> str:
    return f"exceeded the time limit of {limit:g} s per case; stopped"


def _run_case_limited(task: dict) -> dict:
    """:func:`_run_case` in this thread, stopped at ``task["time_limit"]`` seconds (serial and Dask executors).

    A timer thread raises :class:`_CaseTimeout` in this thread
    (``PyThreadState_SetAsyncExc``); it takes effect at the next Python
    bytecode, so a case stuck inside one long call of compiled code stops
    when that call returns. The process executor kills the case's process
    instead (:func:`_execute_pool`).
    """
    limit = task.get("time_limit")
    if not limit:
        return _run_case(task)
    t0 = time.perf_counter()
    tid, lock, state = threading.get_ident(), threading.Lock(), {"done": False}

    def fire():
        with lock:  # never after the case has ended: the exception would hit the caller
            if not state["done"]:
                ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(tid), ctypes.py_object(_CaseTimeout))

    timer = threading.Timer(limit, fire)
    timer.daemon = True
    try:
        try:
            timer.start()
            return _run_case(task)
        finally:
            with lock:
                state["done"] = True
            timer.cancel()
    except _CaseTimeout:
        row = _failed_row(task, _timeout_message(limit))
        row.update(wall_time_s=time.perf_counter() - t0, worker=f"{socket.gethostname()}:{os.getpid()}")
        return row


def _watch_study(pid: int) -> None:
    """End this process (a case's) as soon as the study process ``pid`` ends, even by SIGKILL.

    A daemon thread waits on a pidfd of the study process (Linux >= 5.3;
    elsewhere it polls ``os.kill(pid, 0)`` twice a second), then calls
    ``os._exit``. ``PR_SET_PDEATHSIG`` would not do: under the ``forkserver``
    start method the parent of a case's process is the fork server, not
    the study, and the fork server lives on while any case process holds its
    liveness pipe. Once the cases end, the fork server and the resource
    tracker see their pipes close and end too.
    """
    try:
        fd = os.pidfd_open(pid)
    except ProcessLookupError:
        os._exit(70)
    except (AttributeError, OSError):
        fd = None

    def watch():
        if fd is not None:
            select.select([fd], [], [])  # readable once the process has ended
        else:
            while True:
                try:
                    os.kill(pid, 0)
                except ProcessLookupError:
                    break
                except PermissionError:
                    pass
                time.sleep(0.5)
        os._exit(70)

    threading.Thread(target=watch, name="flexmb-study-watchdog", daemon=True).start()


def _case_process(task: dict, conn, study_pid: int) -> None:
    """Body of the process of one case (process executor): run it, send its row back."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the study's: it stops its cases
    _watch_study(study_pid)
    row = _run_case(task)
    try:
        conn.send(row)
    except Exception as exc:  # e.g. an output that cannot be pickled
        conn.send(_failed_row(task, f"{type(exc).__name__}: {exc}"))
    conn.close()


# ----------------------------------------------------------------------------- executors


def _start_method() -> str:
    return "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"


def default_workers() -> int:
    """Number of CPUs this process may use (the default size of the process pool).

    Returns
    -------
    int
        ``len(os.sched_getaffinity(0))`` where available, else ``os.cpu_count()``.
    """
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:
        return max(1, os.cpu_count() or 1)


def _execute_serial(tasks, record, workers):
    for task in tasks:
        record(task, _run_case_limited(task))


#: environment of the worker processes: one BLAS thread each, as Dask's nanny sets it, so that the
#: workers do not oversubscribe the cores and the process pool and Dask give bit-identical results
WORKER_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def _execute_pool(tasks, record, workers):
    """Each case in its own process, at most ``workers`` at a time; the study kills a case at its time limit.

    A process per case (forked by the ``forkserver``, which has imported
    flexmb once, so a case starts in milliseconds) makes both failures
    exact: a case that passes ``task["time_limit"]`` is killed by this
    process, recorded as failed with the reason, and the study goes on; a
    case that kills its process is recorded as failed, and no other case is
    disturbed. Each case process ends when the study process ends
    (:func:`_watch_study`), even if it is killed.
    """
    from multiprocessing.connection import wait

    ctx = multiprocessing.get_context(_start_method())
    if ctx.get_start_method() == "forkserver":
        ctx.set_forkserver_preload(["__main__", "flexmb.study"])
    queue, running = deque(tasks), {}
    saved = {k: os.environ.get(k) for k in WORKER_ENV}
    os.environ.update(WORKER_ENV)  # read by the cases' BLAS when they start (this process's is loaded)
    try:
        while queue or running:
            while queue and len(running) < workers:
                task = queue.popleft()
                reader, writer = ctx.Pipe(duplex=False)
                proc = ctx.Process(target=_case_process, args=(task, writer, os.getpid()), daemon=True,
                                   name=f"flexmb-case-{task['case_id']}")
                proc.start()
                writer.close()
                limit = task.get("time_limit")
                running[proc.sentinel] = (proc, reader, task, time.perf_counter(), limit or math.inf)
            now = time.perf_counter()
            timeout = min(t0 + limit for _, _, _, t0, limit in running.values()) - now
            ready = set(wait([r for _, r, _, _, _ in running.values()] + list(running),
                             timeout=None if math.isinf(timeout) else max(timeout, 0.0)))
            now = time.perf_counter()
            for sentinel, (proc, reader, task, t0, limit) in list(running.items()):
                row = None
                if reader in ready or sentinel in ready:
                    try:
                        row = reader.recv() if reader.poll() else None
                    except (EOFError, OSError):
                        row = None
                    if row is None and sentinel not in ready:
                        continue  # (not a row yet: the pipe only closed) wait for the process
                    if row is None:
                        row = _failed_row(task, "worker process died while running this case")
                elif now - t0 >= limit:
                    proc.kill()
                    row = _failed_row(task, _timeout_message(limit))
                    row.update(wall_time_s=now - t0, worker=f"{socket.gethostname()}:{proc.pid}")
                else:
                    continue
                proc.join(5.0)
                if proc.is_alive():
                    proc.kill()
                    proc.join()
                reader.close()
                proc.close()
                del running[sentinel]
                record(task, row)
    finally:
        for proc, reader, *_ in running.values():
            proc.kill()
            proc.join()
            reader.close()
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _execute_dask(tasks, record, client):
    from distributed import as_completed

    futures = {client.submit(_run_case_limited, task, pure=False, key=f"flexmb-case-{task['case_id']}-{task['study'][:8]}"):
               task for task in tasks}
    try:
        for fut in as_completed(list(futures)):
            task = futures[fut]
            try:
                row = fut.result()
            except Exception as exc:  # KilledWorker, lost connection, ...
                row = _failed_row(task, f"{type(exc).__name__}: {exc}".replace("\n", " "))
            record(task, row)
    finally:
        client.cancel([f for f in futures if not f.done()])


class _Progress:
    """The study's progress bar (:mod:`flexmb.progress`): cases done, failed ones noted, time left."""

    def __init__(self, total: int, already: int, enabled: bool):
        self.total, self.already, self.enabled = total, already, enabled
        self.done = self.failed = 0
        if already:
            log.info("study: %d of %d cases done before, running the other %d", already, total, total - already)
        self.bar = Progress(total, "study", "cases", enabled=enabled, initial=already)

    def update(self, row: dict) -> None:
        self.done += 1
        self.failed += row["status"] != "finished"
        if self.failed:
            self.bar.note(f"{self.failed} failed")
        self.bar.update_to(self.already + self.done)

    def close(self) -> None:
        self.bar.close()


# ----------------------------------------------------------------------------- the study


def _hash(obj) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=repr).encode()).hexdigest()


def case_id(parameters: dict) -> str:
    """The id of a case: a hash of its parameter names and values (its file is ``cases/<id>.json``).

    Parameters
    ----------
    parameters : dict
        ``{key path: value}``.

    Returns
    -------
    str
        16 hexadecimal digits.

    Examples
    --------
    >>> from flexmb.study import case_id
    >>> case_id({"bodies.bar.mass": 1.0}) == case_id({"bodies.bar.mass": 1.0})
    True
    """
    return _hash(parameters)[:16]


def _unit_samples(sampling: str, n: int, d: int, seed: int) -> np.ndarray:
    """``n`` points in the unit cube of dimension ``d``, reproducible by ``seed``.

    ``'lhs'``: a scrambled Latin hypercube (:class:`scipy.stats.qmc.LatinHypercube`),
    one point in each of the ``n`` equal strata of every dimension;
    ``'mc'``: independent uniform draws.
    """
    rng = np.random.default_rng(seed)
    if sampling == "mc":
        return rng.random((n, d))
    from scipy.stats import qmc

    # scipy >= 1.15 takes the generator as rng (SPEC 7); earlier releases as seed
    key = "rng" if "rng" in inspect.signature(qmc.LatinHypercube).parameters else "seed"
    return qmc.LatinHypercube(d, **{key: rng}).random(n)


def _check_vary(instance, attribute, value):
    if not isinstance(value, dict) or not value:
        raise FlexmbError("Study: vary must be a non-empty dict {key path: spec}")


def _check_sampling(instance, attribute, value):
    if value not in SAMPLINGS:
        raise FlexmbError(f"Study: unknown sampling {value!r}; pick one of {', '.join(SAMPLINGS)}")


@frozen(eq=False)
class Study:
    """A parameter study of a scene: which keys vary, how, and what each case reports.

    Parameters
    ----------
    data : dict
        The scene's TOML document (``tomllib`` output).
    source : str
        Where it came from (for messages and the manifest).
    vary : dict of str to (list or str or Distribution)
        ``{key path: spec}``. A key path names a scene key
        (``bodies.blade.n_segments``); ``a.b+c.d`` sets several keys to one
        value. A spec is a list of values, a spec string (:func:`parse_spec`)
        or a :class:`Distribution`. Lists and ranges form a full grid; random
        parameters are sampled ``samples`` times together and crossed with
        the grid.
    outputs : tuple of (str or (str, callable)), optional
        Named outputs (:data:`OUTPUTS`, e.g. ``"peak_speed:tip"``,
        ``"peak_effort:motor"``, ``"energy_balance"``) or ``(name,
        function(scene, result) -> float)`` pairs (module-level functions, so
        that they reach worker processes). Default: :func:`default_outputs`.
    fixed : dict, optional
        Key paths set to one value in every case (``{"solver.t_end": 0.5}``).
    samples : int, optional
        Number of random samples (needed if a parameter is random).
    seed : int
        Seed of the random samples.
    sampling : {'lhs', 'mc'}
        Latin hypercube (one sample in each of ``samples`` equal-probability
        strata of every random parameter) or plain Monte Carlo.

    See Also
    --------
    run_study : The short form.

    Examples
    --------
    >>> import flexmb as fm
    >>> study = fm.Study.from_file("tutorials/01_pendulum.toml",  # doctest: +SKIP
    ...                            vary={"bodies.bar.length": "lin:0.5:1.5:3"}, outputs=["final:pin"])
    >>> len(study.cases())  # doctest: +SKIP
    3
    """

    data: dict
    source: str
    vary: dict = field(validator=_check_vary)
    outputs: tuple = field(default=(), converter=tuple)
    fixed: dict = field(factory=dict)
    samples: int | None = None
    seed: int = 0
    sampling: str = field(default="lhs", validator=_check_sampling)

    def __attrs_post_init__(self):
        specs = {k: _as_spec(k, v) for k, v in self.vary.items()}
        object.__setattr__(self, "vary", specs)
        random = [k for k, v in specs.items() if isinstance(v, Distribution)]
        if random and not (isinstance(self.samples, int) and self.samples >= 1):
            raise FlexmbError(f"Study: random parameters ({', '.join(random)}) need samples >= 1, "
                              f"got {self.samples!r}")
        overlap = {p for k in specs for p in _paths(k)} & {p for k in self.fixed for p in _paths(k)}
        if overlap:
            raise FlexmbError(f"Study: keys both varied and fixed: {', '.join(sorted(overlap))}")

    @classmethod
    def from_file(cls, path, vary: dict, **kw) -> "Study":
        """A study of a scene file.

        Parameters
        ----------
        path : str or path-like
            The ``.toml`` scene file.
        vary : dict
            ``{key path: spec}`` (see :class:`Study`).
        **kw
            ``outputs``, ``fixed``, ``samples``, ``seed``, ``sampling``.

        Returns
        -------
        Study
            The study (nothing has run yet).

        Raises
        ------
        SceneError
            If the file cannot be read or is not valid TOML.
        """
        path = os.fspath(path)
        try:
            with open(path, "rb") as fh:
                data = tomllib.load(fh)
        except OSError as exc:
            raise SceneError(f"{path}: cannot read the scene file: {exc.strerror or exc}") from exc
        except tomllib.TOMLDecodeError as exc:
            raise SceneError(f"{path}: invalid TOML: {exc}") from exc
        return cls(data, path, vary, **kw)

    @property
    def parameters(self) -> list[str]:
        """The varied key paths, in the order given."""
        return list(self.vary)

    def cases(self) -> list[dict]:
        """The parameter values of every case, in case order.

        Returns
        -------
        list of dict
            ``{key path: value}`` per case: the grid of the listed values
            (last parameter fastest), crossed with the random samples.
        """
        grid = [k for k, v in self.vary.items() if not isinstance(v, Distribution)]
        random = [k for k, v in self.vary.items() if isinstance(v, Distribution)]
        rows = [{}]
        for k in grid:
            rows = [dict(r, **{k: v}) for r in rows for v in self.vary[k]]
        if random:
            n = self.samples
            u = _unit_samples(self.sampling, n, len(random), self.seed)
            draws = {k: [float(v) for v in self.vary[k].ppf(u[:, j])] for j, k in enumerate(random)}
            rows = [dict(r, **{k: draws[k][i] for k in random}) for r in rows for i in range(n)]
        return rows

    def key(self) -> str:
        """Hash of what every case shares (scene document, fixed keys, outputs): case files of another study are not reused.

        Returns
        -------
        str
            64 hexadecimal digits.
        """
        outs = [o if isinstance(o, str) else [o[0], getattr(o[1], "__module__", ""),
                                              getattr(o[1], "__qualname__", repr(o[1]))] for o in self.outputs]
        return _hash({"scene": self.data, "fixed": self.fixed, "outputs": outs})

    def validate(self) -> list:
        """Build the first case: bad key paths and outputs fail here, before any case runs.

        Returns
        -------
        list
            The output specs (the defaults of the scene if none were given).

        Raises
        ------
        SceneError
            If a key path is not in the scene or the first case does not build.
        FlexmbError
            If an output does not fit the scene.
        """
        # every case sets the same key paths, so the first case checks them all
        scene = _build(self.data, self.source, self.fixed, self.cases()[0])
        outputs = list(self.outputs) or default_outputs(scene)
        system = scene.system()
        for spec in outputs:
            _check_output(spec, scene, system)
        names = [_output_name(o) for o in outputs]
        clash = (set(names) & set(self.vary)) | (set(names) & set(META_COLUMNS)) | (set(self.vary) & set(META_COLUMNS))
        if clash or len(set(names)) != len(names):
            raise FlexmbError(f"Study: column names must be unique; clash: {sorted(clash) or names}")
        return outputs

    def _time_limit(self, value) -> float | None:
        """The time limit per case: ``value``, else the scene's ``[study] time_limit`` (checked by the loader)."""
        if value is None:
            study = self.data.get("study")
            value = study.get("time_limit") if isinstance(study, dict) else None
            value = self.fixed.get("study.time_limit", value)
            return None if value is None else float(value)
        if isinstance(value, bool) or not _is_real(value) or not (math.isfinite(value) and value > 0):
            raise FlexmbError(f"Study: time_limit must be a finite number of seconds > 0, got {value!r}")
        return float(value)

    def run(self, out, executor: str = "process", workers: int | None = None, client=None,
            scheduler: str | None = None, progress: bool = True, retry_failed: bool = False,
            time_limit: float | None = None) -> "StudyResult":
        """Run the cases not yet done, write the table, the plot and the summary.

        Parameters
        ----------
        out : str or path-like
            Output folder: ``cases/<id>.json`` per case, ``study.json``,
            ``table.csv``, ``table.npz`` (``table.parquet`` with pyarrow),
            ``study.png`` (with matplotlib), ``summary.txt``.
        executor : {'process', 'serial', 'dask'}
            Where the cases run (``'dask'`` is implied by ``client`` or
            ``scheduler``).
        workers : int, optional
            Size of the process pool (default: the CPUs available).
        client : dask.distributed.Client, optional
            Run on this Dask cluster (left open).
        scheduler : str, optional
            Address of a Dask scheduler (``"tcp://host:8786"``); a client is
            opened and closed here.
        progress : bool
            Print progress on stderr.
        retry_failed : bool
            Run again the cases recorded as failed.
        time_limit : float, optional
            Wall-clock seconds one case may take (default: the scene's
            ``[study] time_limit``, else no limit). A case that takes longer
            is stopped and recorded as failed with the reason, and the study
            goes on. The process executor kills the case's process; the
            serial and Dask executors interrupt the case's thread (see
            ``docs/study.md``).

        Returns
        -------
        StudyResult
            The table of every case (done now and before).

        Raises
        ------
        SceneError, FlexmbError
            If a parameter, output or the time limit is invalid (before any
            case runs).
        """
        if client is not None or scheduler is not None:
            executor = "dask"
        executors = {"serial": _execute_serial, "process": _execute_pool, "dask": _execute_dask}
        if executor not in executors:
            raise FlexmbError(f"unknown executor {executor!r}; pick one of {', '.join(executors)}")
        outputs = self.validate()
        time_limit = self._time_limit(time_limit)
        out = Path(os.fspath(out))
        study_key = self.key()
        manifest = {"scene": self.source, "study": study_key, "parameters": self.parameters,
                    "specs": {k: (repr(v) if isinstance(v, Distribution) else v) for k, v in self.vary.items()},
                    "fixed": self.fixed, "outputs": [_output_name(o) for o in outputs],
                    "samples": self.samples, "seed": self.seed, "sampling": self.sampling}
        atomic_write(out / "study.json", lambda tmp: Path(tmp).write_text(json.dumps(manifest, indent=2) + "\n"))
        cases = self.cases()
        ids = [case_id(p) for p in cases]
        done = {}
        for i, cid in enumerate(ids):
            row = _read_case(out / "cases" / f"{cid}.json", study_key)
            if row is not None and (row["status"] == "finished" or not retry_failed):
                row["case"] = i
                done[cid] = row
        tasks = [{"case": i, "case_id": cid, "parameters": p, "data": self.data, "source": self.source,
                  "fixed": self.fixed, "outputs": outputs, "study": study_key, "time_limit": time_limit}
                 for i, (cid, p) in enumerate(zip(ids, cases)) if cid not in done]
        # cases with equal parameters (a repeated value) share one id: run it once
        seen, unique = set(), []
        for t in tasks:
            if t["case_id"] not in seen:
                seen.add(t["case_id"])
                unique.append(t)
        bar = _Progress(len(set(ids)), len(done), progress)
        ran = []

        def record(task, row):
            row = dict(row, study=study_key)
            atomic_write(out / "cases" / f"{task['case_id']}.json",
                         lambda tmp: Path(tmp).write_text(json.dumps(row, indent=1) + "\n"))
            done[task["case_id"]] = row
            ran.append(task["case_id"])
            bar.update(row)

        own_client = None
        if executor == "dask" and client is None:
            try:
                from distributed import Client
            except ImportError as exc:
                raise FlexmbError("running on a Dask cluster needs dask.distributed: "
                                  "pip install -e '.[dask]'") from exc
            client = own_client = Client(scheduler)
        try:
            arg = client if executor == "dask" else max(1, int(workers or default_workers()))
            executors[executor](unique, record, arg)
        finally:
            bar.close()
            if own_client is not None:
                own_client.close()
        rows = []
        for i, cid in enumerate(ids):
            row = dict(done[cid])
            row["case"] = i
            rows.append(row)
        result = StudyResult(self.parameters, [_output_name(o) for o in outputs], rows, ran=ran,
                             skipped=len(set(ids)) - len(set(ran)), out=out)
        result.write(out)
        return result


def _read_case(path: Path, study_key: str) -> dict | None:
    try:
        row = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return row if row.get("study") == study_key else None


@define
class StudyResult:
    """The table of a study: one row per case with its parameters, outputs, status and error.

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    parameters : list of str
        Varied key paths (columns).
    outputs : list of str
        Output names (columns).
    rows : list of dict
        Per case, in case order: ``case``, ``case_id``, ``parameters``,
        ``outputs``, ``status``, ``error``, ``wall_time_s``, ``worker``.
    ran : list of str
        Ids of the cases run by this call (the others were done before).
    skipped : int
        Number of cases found done and not run again.
    out : pathlib.Path or None
        The output folder.
    """

    parameters: list
    outputs: list
    rows: list
    ran: list = field(factory=list)
    skipped: int = 0
    out: Any = None

    @property
    def columns(self) -> list[str]:
        """Column names: ``case, case_id``, parameters, outputs, ``status, error, wall_time_s, worker``."""
        return ["case", "case_id"] + self.parameters + self.outputs + ["status", "error", "wall_time_s", "worker"]

    @property
    def failed(self) -> list[dict]:
        """Rows of the cases that did not finish."""
        return [r for r in self.rows if r["status"] != "finished"]

    def column(self, name: str) -> np.ndarray:
        """One column as an array (outputs of failed cases are NaN).

        Parameters
        ----------
        name : str
            A column name (see :attr:`columns`).

        Returns
        -------
        ndarray, shape (n_cases,) or (n_cases, n_t)
            Floats for numeric columns, a 2-d float array (padded with NaN)
            for time series, else strings or objects.
        """
        if name not in self.columns:
            raise FlexmbError(f"no column {name!r}; columns: {', '.join(self.columns)}")
        values = [self._cell(r, name) for r in self.rows]
        if name in self.outputs and any(isinstance(v, list) for v in values):
            if all(v is None or (isinstance(v, list) and all(_is_real(x) for x in v)) for v in values):
                n_t = max(len(v) for v in values if v is not None)
                series = np.full((len(values), n_t), np.nan)
                for i, v in enumerate(values):
                    if v:
                        series[i, :len(v)] = v
                return series
        numeric = all(v is None or (isinstance(v, (int, float)) and not isinstance(v, bool)) for v in values)
        if numeric and name not in ("case_id",):
            return np.array([np.nan if v is None else v for v in values], dtype=float if name != "case" else int)
        if all(isinstance(v, str) for v in values):
            return np.array(values, dtype=str)
        return np.array(values, dtype=object)

    @property
    def scalar_outputs(self) -> list[str]:
        """The outputs that are one number per case (not time series)."""
        return [o for o in self.outputs if self.column(o).ndim == 1 and self.column(o).dtype.kind in "fi"]

    @staticmethod
    def _cell(row: dict, name: str):
        if name in row["parameters"]:
            return row["parameters"][name]
        if name in META_COLUMNS:
            return row.get(name)
        return row["outputs"].get(name)

    def table(self) -> list[list]:
        """The rows as lists of cells, in :attr:`columns` order.

        Returns
        -------
        list of list
            One list per case.
        """
        return [[self._cell(r, c) for c in self.columns] for r in self.rows]

    def write(self, out) -> dict:
        """Write ``table.csv``, ``table.npz``, ``table.parquet`` (with pyarrow), ``study.png`` and ``summary.txt``.

        Parameters
        ----------
        out : str or path-like
            Output folder.

        Returns
        -------
        dict of str to pathlib.Path
            The files written.
        """
        out = Path(os.fspath(out))
        files = {}
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(self.columns)
        for cells in self.table():
            w.writerow(["" if v is None else repr(v) if isinstance(v, float) else json.dumps(v)
                        if isinstance(v, (list, dict)) else v for v in cells])
        files["csv"] = atomic_write(out / "table.csv", lambda tmp: Path(tmp).write_text(buf.getvalue()))
        arrays = {c: self.column(c) for c in self.columns}
        arrays = {c: (a.astype(str) if a.dtype == object else a) for c, a in arrays.items()}
        files["npz"] = atomic_write(out / "table.npz", lambda tmp: np.savez(tmp, **arrays), suffix=".npz")
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:
            pass
        else:
            tab = pa.table({c: (list(arrays[c]) if arrays[c].ndim > 1 else arrays[c]) for c in self.columns})
            files["parquet"] = atomic_write(out / "table.parquet", lambda tmp: pq.write_table(tab, tmp))
        png = self.plot(out / "study.png")
        if png is not None:
            files["plot"] = png
        text = self.summary()
        files["summary"] = atomic_write(out / "summary.txt", lambda tmp: Path(tmp).write_text(text + "\n"))
        return files

    def unit(self, name: str) -> str:
        """The unit of a parameter or output column, read from its name (``'-'`` when unknown).

        Parameters
        ----------
        name : str
            A parameter (scene key path) or output name.

        Returns
        -------
        str
            E.g. ``'kg'`` for ``bodies.bar.mass``, ``'m/s'`` for
            ``peak_speed:tip``, ``'rad'`` for ``final:pin.angle``; ``'-'``
            for a dimensionless number, a count, or a unit the name does not
            fix (``stiffness``, ``peak_effort:<driver>``, a bare joint name).
        """
        return _column_unit(name)

    def figure(self):
        """Each output against each parameter, one panel each, axes labelled with units.

        Returns
        -------
        matplotlib.figure.Figure or None
            The figure (not drawn through pyplot), or None if no case
            finished or there is no scalar output.

        Raises
        ------
        ImportError
            If matplotlib is not installed.
        """
        from matplotlib.figure import Figure

        ok = np.array([r["status"] == "finished" for r in self.rows])
        outputs = self.scalar_outputs
        if not ok.any() or not outputs:
            return None
        n_o, n_p = len(outputs), len(self.parameters)
        fig = Figure(figsize=(3.4 * n_p + 0.6, 2.6 * n_o + 0.6))
        axes = fig.subplots(n_o, n_p, squeeze=False)
        for j, p in enumerate(self.parameters):
            x = self.column(p)
            others = [q for q in self.parameters if q != p]
            # colour by the other parameters' combination, so each curve is one setting of them
            combo = [tuple(self._cell(r, q) for q in others) for r in self.rows]
            groups = list(dict.fromkeys(combo))
            for i, o in enumerate(outputs):
                ax = axes[i, j]
                if i == n_o - 1:
                    ax.set_xlabel(f"{p} ({self.unit(p)})", fontsize=8)
                if j == 0:
                    ax.set_ylabel(f"{o} ({self.unit(o)})", fontsize=8)
                y = self.column(o)
                if x.dtype.kind not in "fi" or y.dtype.kind not in "fi":
                    ax.text(0.5, 0.5, "not numeric", ha="center", transform=ax.transAxes)
                    continue
                for g, key in enumerate(groups):
                    sel = ok & np.array([c == key for c in combo])
                    order = np.argsort(x[sel], kind="stable")
                    label = ", ".join(f"{q.rsplit('.', 1)[-1]}={v:.3g}" if isinstance(v, float) else
                                      f"{q.rsplit('.', 1)[-1]}={v}" for q, v in zip(others, key))
                    style = "o-" if len(groups) <= 8 and sel.sum() > 1 else "o"
                    ax.plot(x[sel][order], y[sel][order], style, ms=4, color=f"C{g % 10}" if len(groups) <= 10
                            else "C0", label=label if (i == 0 and label and len(groups) <= 8) else None)
                bad = ~ok & np.isfinite(x)
                if bad.any():
                    ax.plot(x[bad], np.full(bad.sum(), np.nanmin(y[ok])), "rx", label="failed" if i == 0 else None)
                if np.all(x[np.isfinite(x)] > 0) and np.nanmax(x) / max(np.nanmin(x), 1e-300) > 50:
                    ax.set_xscale("log")
                ax.grid(alpha=0.3)
                ax.tick_params(labelsize=7)
            if axes[0, j].get_legend_handles_labels()[0]:
                axes[0, j].legend(fontsize=6)
        fig.suptitle(f"{sum(ok)} of {len(self.rows)} cases finished", fontsize=9)
        fig.tight_layout()
        return fig

    def plot(self, path):
        """Each output against each parameter, one panel each (matplotlib, PNG); see :meth:`figure`.

        Parameters
        ----------
        path : str or path-like
            The PNG file.

        Returns
        -------
        pathlib.Path or None
            The file, or None if matplotlib is not installed or nothing finished.
        """
        try:
            fig = self.figure()
        except ImportError:
            return None
        if fig is None:
            return None
        target = Path(os.fspath(path))
        atomic_write(target, lambda tmp: fig.savefig(tmp, dpi=100), suffix=".png")
        return target

    def summary(self) -> str:
        """A short text report: counts, failures with their messages, the range of each output.

        Returns
        -------
        str
            What ``flexmb study`` prints at the end.
        """
        n, bad = len(self.rows), self.failed
        lines = [f"{n} cases: {n - len(bad)} finished, {len(bad)} failed; "
                 f"{len(set(self.ran))} run now, {self.skipped} done before"]
        for r in bad:
            params = ", ".join(f"{k}={v}" for k, v in r["parameters"].items())
            lines.append(f"  case {r['case']} ({params}) {r['status']}: {r['error']}")
        if self.outputs and n > len(bad):
            width = max(len(o) for o in self.outputs)
            lines.append(f"  {'output'.ljust(width)}  {'min':>12}  {'max':>12}  (case of max)")
            for o in self.scalar_outputs:
                y = self.column(o)
                if not np.isfinite(y).any():
                    continue
                k = int(np.nanargmax(y))
                lines.append(f"  {o.ljust(width)}  {np.nanmin(y):12.6g}  {np.nanmax(y):12.6g}  ({k})")
        wall = np.array([r.get("wall_time_s") for r in self.rows if r.get("wall_time_s") is not None], dtype=float)
        wall = wall[np.isfinite(wall)]
        if wall.size:
            lines.append(f"  wall time per case: median {np.median(wall):.3g} s, total {wall.sum():.3g} s")
        return "\n".join(lines)


#: units of scene keys by their last part (``'-'``: dimensionless or a count); a key whose unit
#: depends on the element (``stiffness``, ``damping`` of a force, a driver's ``speed``) is not here
_KEY_UNITS = {
    "E": "Pa", "G": "Pa", "density": "kg/m^3", "nu": "-",
    "b": "m", "h": "m", "d": "m", "d_out": "m", "d_in": "m", "area": "m^2", "Iy": "m^4", "Iz": "m^4",
    "J": "m^4", "Ip": "m^4", "c_y": "m", "c_z": "m",
    "mass": "kg", "length": "m", "size": "m", "vector": "m", "com": "m", "inertia": "kg m^2",
    "n_segments": "-", "damping_ratio": "-", "frequency": "Hz",
    "parent_point": "m", "child_point": "m", "point": "m", "point1": "m", "point2": "m", "rest_length": "m",
    "g": "m/s^2", "normal_load": "N", "mu_static": "-", "mu": "-", "slope": "s/m", "smoothing_speed": "m/s",
    "force": "N", "torque": "N m",
    "rpm": "rev/min",
    "t_end": "s", "max_step": "s", "rtol": "-", "n_out": "-", "time_limit": "s",
}
#: keys whose unit depends on their table: (first part, last part) -> unit
_TABLE_KEY_UNITS = {("bodies", "damping"): "s"}
#: outputs by kind: a fixed unit, or "coordinate" (the unit of the coordinate named)
_OUTPUT_UNITS = {"peak_speed": "m/s", "max_displacement": "m", "driver_work": "J", "energy_balance": "-",
                 "final": "coordinate", "max": "coordinate", "min": "coordinate", "history": "coordinate",
                 "time": "s", "n_rhs": "-"}


def _column_unit(name: str) -> str:
    """Unit of a study column from its name: a scene key path or an output name; '-' when unknown."""
    if "." in name and ":" not in name:  # a key path, or several joined by '+'
        found = set()
        for path in _paths(name):
            parts = path.split(".")
            leaf = parts[-1].split("[", 1)[0]
            found.add(_TABLE_KEY_UNITS.get((parts[0], leaf), _KEY_UNITS.get(leaf, "-")))
        return found.pop() if len(found) == 1 else "-"
    kind, _, arg = name.partition(":")
    unit = _OUTPUT_UNITS.get(kind, "-")
    if unit == "coordinate":
        from .viz import _joint_coordinate_units
        from .flexible import ELASTIC_COORDINATES

        coord = arg.rpartition(".")[2] if "." in arg else ""
        if coord in ELASTIC_COORDINATES and ".j" in arg:
            unit = "m" if ELASTIC_COORDINATES[coord][0] == "t" else "rad"
        else:
            unit = _joint_coordinate_units().get(coord) or "-"
    return unit


def run_study(scene, vary: dict, out, *, outputs=(), fixed=None, samples=None, seed: int = 0,
              sampling: str = "lhs", **run_kw) -> StudyResult:
    """Run a parameter study of a scene file (the short form of :class:`Study`).

    Parameters
    ----------
    scene : str or path-like
        The scene file.
    vary : dict
        ``{key path: spec}``; see :class:`Study` and :func:`parse_spec`.
    out : str or path-like
        Output folder.
    outputs, fixed, samples, seed, sampling
        As in :class:`Study`.
    **run_kw
        ``executor``, ``workers``, ``client``, ``scheduler``, ``progress``,
        ``retry_failed`` of :meth:`Study.run`.

    Returns
    -------
    StudyResult
        The table.

    Examples
    --------
    >>> import flexmb as fm
    >>> res = fm.run_study("tutorials/01_pendulum.toml", {"bodies.bar.mass": [1.0, 2.0]},  # doctest: +SKIP
    ...                    "results/study", outputs=["peak_speed:tip"], executor="serial")
    """
    study = Study.from_file(scene, vary, outputs=outputs, fixed=dict(fixed or {}), samples=samples, seed=seed,
                            sampling=sampling)
    return study.run(out, **run_kw)
