"""The :class:`Study`: which keys of a scene vary, how, and what each case reports; and :func:`run_study`."""

from __future__ import annotations

import hashlib
import json
import math
import os
import tomllib
from pathlib import Path

from attrs import field, frozen

from .._files import OutputFolder, atomic_write
from .._folder_lock import read_plain
from ..errors import FlexmbError, SceneError
from .cases import _build
from .executors import _check_pool, _execute_dask, _execute_pool, _execute_serial, _Progress, default_workers, log
from ..scene.metrics import _check_output, _is_real, _output_name, default_outputs
from .sampling import SAMPLINGS, Distribution, _unit_samples
from ..scene.keys import key_paths as _paths
from .spec import _as_spec
from .table import META_COLUMNS, StudyResult, _scene_units

__all__ = ['Study', 'case_id', 'run_study']


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
        return self._checked()[0]

    def _checked(self) -> tuple[list, dict]:
        """:meth:`validate`'s output specs, and the units of the columns the scene fixes (a driver's effort)."""
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
        return outputs, _scene_units(names, scene)

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
            time_limit: float | None = None, overwrite: bool = False) -> "StudyResult":
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
        overwrite : bool
            Replace the outputs of a run or a study of another scene in
            ``out`` (else refused before any case runs).

        Returns
        -------
        StudyResult
            The table of every case (done now and before).

        Raises
        ------
        SceneError, FlexmbError
            If a parameter, output or the time limit is invalid, or if the
            process pool cannot run the study from where it is called (a
            study at the top level of a script whose outputs are functions
            defined in that script; the message says what to add), or the
            Dask scheduler cannot be reached (a malformed address, none
            answering), before any case runs or anything is written.
        ExportError
            If another run or study is writing into ``out`` (the message
            names its pid), or ``out`` holds the outputs of another scene and
            ``overwrite`` is False, before any case runs.

        Notes
        -----
        Cases recorded as failed by an earlier run into ``out`` are not run
        again unless ``retry_failed``; a warning says so when the study
        starts, and :meth:`StudyResult.summary` marks them.

        The folder is locked for the study as for a run
        (:class:`flexmb._files.OutputFolder`): a second study or run into it
        is refused. Each case's file is written into ``cases/`` as the case
        ends; ``study.json`` and the tables, plot and summary replace the
        previous ones together at the end, so a study stopped or killed on
        the way leaves the previous study's set whole.
        """
        if client is not None or scheduler is not None:
            executor = "dask"
        if executor not in _EXECUTORS:
            raise FlexmbError(f"unknown executor {executor!r}; pick one of {', '.join(_EXECUTORS)}")
        outputs, units = self._checked()
        time_limit = self._time_limit(time_limit)
        study_key = self.key()
        manifest = self._manifest(study_key, outputs)
        # the cluster is reached before anything is written: an unreachable one leaves the folder as it was
        own_client = _dask_client(scheduler) if executor == "dask" and client is None else None
        try:
            with OutputFolder(out, owner=f"a study of {_source_name(self.source)}", overwrite=overwrite) as folder:
                result = self._run_cases(folder, study_key, outputs, units, time_limit, executor, workers,
                                         client or own_client, progress, retry_failed)
                result._write_into(folder)
                atomic_write(folder.stage("study.json"),
                             lambda tmp: Path(tmp).write_text(json.dumps(manifest, indent=2) + "\n"))
                folder.commit()
        finally:
            if own_client is not None:
                own_client.close()
        return result

    def _run_cases(self, folder, study_key, outputs, units, time_limit, executor, workers, client, progress,
                   retry_failed) -> "StudyResult":
        """Run the cases not yet done in the locked folder (each case's file in ``cases/`` as it ends)."""
        out = folder.path
        case_dir = folder.folder("cases")
        cases = self.cases()
        ids = [case_id(p) for p in cases]
        done = _done_cases(case_dir, ids, study_key, retry_failed)
        tasks = self._tasks(cases, ids, done, outputs, study_key, time_limit)
        if executor == "process":
            _check_pool(tasks)
        stale = sorted({cid for cid, row in done.items() if row["status"] != "finished"})
        if stale:
            log.warning("study: %d case(s) recorded as failed by an earlier run in %s are not run again; "
                        "retry_failed=True (flexmb study --retry-failed) runs them again", len(stale), out)
        bar = _Progress(len(set(ids)), len(done), progress)
        ran = []

        def record(task, row):
            row = dict(row, study=study_key)
            atomic_write(case_dir / f"{task['case_id']}.json",
                         lambda tmp: Path(tmp).write_text(json.dumps(row, indent=1) + "\n"))
            done[task["case_id"]] = row
            ran.append(task["case_id"])
            bar.update(row)

        try:
            _execute(executor, tasks, record, workers, client)
        finally:
            bar.close()
        rows = [dict(done[cid], case=i) for i, cid in enumerate(ids)]
        return StudyResult(self.parameters, [_output_name(o) for o in outputs], rows, ran=ran,
                           skipped=len(set(ids)) - len(set(ran)), out=out, units=units)

    def _manifest(self, study_key: str, outputs: list) -> dict:
        """What ``study.json`` records: the scene, the study's hash, parameters, specs and outputs."""
        return {"scene": self.source, "study": study_key, "parameters": self.parameters,
                "specs": {k: (repr(v) if isinstance(v, Distribution) else v) for k, v in self.vary.items()},
                "fixed": self.fixed, "outputs": [_output_name(o) for o in outputs],
                "samples": self.samples, "seed": self.seed, "sampling": self.sampling}

    def _tasks(self, cases: list, ids: list, done: dict, outputs: list, study_key: str, time_limit) -> list[dict]:
        """The cases still to run, one task each; cases with equal parameters (a repeated value) share one."""
        tasks = [{"case": i, "case_id": cid, "parameters": p, "data": self.data, "source": self.source,
                  "fixed": self.fixed, "outputs": outputs, "study": study_key, "time_limit": time_limit}
                 for i, (cid, p) in enumerate(zip(ids, cases)) if cid not in done]
        seen, unique = set(), []
        for t in tasks:
            if t["case_id"] not in seen:
                seen.add(t["case_id"])
                unique.append(t)
        return unique


_EXECUTORS = {"serial": _execute_serial, "process": _execute_pool, "dask": _execute_dask}


def _source_name(source) -> str:
    """A scene file's real path (one file, however named), else the source as given."""
    source = os.fspath(source)
    return os.path.realpath(source) if os.path.isfile(source) else source


def _done_cases(case_dir: Path, ids: list, study_key: str, retry_failed: bool) -> dict:
    """The cases of this study found done in ``case_dir`` (failed ones only if not retried), by id."""
    done = {}
    for i, cid in enumerate(ids):
        row = _read_case(case_dir / f"{cid}.json", study_key)
        if row is not None and (row["status"] == "finished" or not retry_failed):
            row["case"] = i
            done[cid] = row
    return done


def _dask_client(scheduler):
    """A Dask client of the scheduler at ``scheduler`` (a local cluster if None); a FlexmbError if it cannot be had."""
    try:
        from distributed import Client
    except ImportError as exc:
        raise FlexmbError("running on a Dask cluster needs dask.distributed: pip install -e '.[dask]'") from exc
    try:
        return Client(scheduler)
    except (ValueError, TypeError, OSError, TimeoutError) as exc:  # a malformed address, or none answering
        raise FlexmbError(f"Study: cannot reach the Dask scheduler {scheduler!r}: {exc}") from exc


def _execute(executor: str, tasks: list, record, workers, client) -> None:
    """Run ``tasks`` on the executor (``client``: Dask's, opened by :meth:`Study.run`), calling ``record(task, row)``."""
    arg = client if executor == "dask" else max(1, int(workers or default_workers()))
    _EXECUTORS[executor](tasks, record, arg)


def _read_case(path: Path, study_key: str) -> dict | None:
    """A case's row of this study, read from its file; None if missing, another study's or not a case's row."""
    data = read_plain(path)
    try:
        row = json.loads(data) if data is not None else None
    except ValueError:
        return None
    if not isinstance(row, dict) or row.get("study") != study_key or not isinstance(row.get("status"), str):
        return None
    # a file of the right study but the wrong shape (a crash, a hand edit) is no row: its case runs again
    shapes = {"outputs": dict, "parameters": dict, "case": int, "case_id": str}
    if any(not isinstance(row.get(k), t) or isinstance(row.get(k), bool) for k, t in shapes.items()):
        return None
    return row



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
