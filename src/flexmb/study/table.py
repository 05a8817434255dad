"""The table of a study (:class:`StudyResult`): columns, files, units, plot and summary."""

from __future__ import annotations

import csv
import io
import json
import os
from pathlib import Path
from typing import Any

import numpy as np
from attrs import define, field

from .._files import OutputFolder, atomic_write
from ..errors import FlexmbError
from ..scene.metrics import _is_real
from ..scene.keys import key_paths as _paths

#: columns of the table that are not parameters or outputs
META_COLUMNS = ("case", "case_id", "status", "error", "wall_time_s", "worker")

__all__ = ['StudyResult']


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
    units : dict of str to str
        Units of columns that the study's scene fixes and the name alone
        does not (``peak_effort:<driver>`` in N m or N, from the
        driver's joint); the others are read from the name (:meth:`unit`).
    """

    parameters: list
    outputs: list
    rows: list
    ran: list = field(factory=list)
    skipped: int = 0
    out: Any = None
    units: dict = field(factory=dict)

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
        ndarray, shape (n_cases,), (n_cases, n_t) or (n_cases, n_t, 3)
            Floats for numeric columns, a 2-d float array (padded with NaN)
            for time series, a 3-d one for time series of 3-vectors, else
            strings or objects.
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
            if all(v is None or (isinstance(v, list) and all(isinstance(x, list) and len(x) == 3
                                                             and all(_is_real(c) for c in x) for x in v))
                   for v in values):  # time series of 3-vectors (a point's velocity, a body's angular velocity)
                n_t = max(len(v) for v in values if v is not None)
                series = np.full((len(values), n_t, 3), np.nan)
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

        The folder is locked and the files replace the previous ones together
        (:class:`flexmb._files.OutputFolder`): a reader finds the old set or
        the new one, never a mix.

        Parameters
        ----------
        out : str or path-like
            Output folder.

        Returns
        -------
        dict of str to pathlib.Path
            The files written.
        """
        with OutputFolder(out) as folder:
            files = self._write_into(folder)
            folder.commit()
        return files

    def _write_into(self, folder) -> dict:
        """Stage the table files in an open :class:`~flexmb._files.OutputFolder`; return their final paths."""
        files = {}
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(self.columns)
        for cells in self.table():
            w.writerow(["" if v is None else repr(v) if isinstance(v, float) else json.dumps(v)
                        if isinstance(v, (list, dict)) else v for v in cells])
        atomic_write(folder.stage("table.csv"), lambda tmp: Path(tmp).write_text(buf.getvalue()))
        files["csv"] = "table.csv"
        arrays = {c: self.column(c) for c in self.columns}
        arrays = {c: (a.astype(str) if a.dtype == object else a) for c, a in arrays.items()}
        atomic_write(folder.stage("table.npz"), lambda tmp: np.savez(tmp, **arrays), suffix=".npz")
        files["npz"] = "table.npz"
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:
            pass
        else:
            tab = pa.table({c: (list(arrays[c]) if arrays[c].ndim > 1 else arrays[c]) for c in self.columns})
            atomic_write(folder.stage("table.parquet"), lambda tmp: pq.write_table(tab, tmp))
            files["parquet"] = "table.parquet"
        if self.plot(folder.stage("study.png")) is not None:
            files["plot"] = "study.png"
        text = self.summary()
        atomic_write(folder.stage("summary.txt"), lambda tmp: Path(tmp).write_text(text + "\n"))
        files["summary"] = "summary.txt"
        return {k: Path(folder.final(rel)) for k, rel in files.items()}

    def unit(self, name: str) -> str:
        """The unit of a parameter or output column: from :attr:`units`, else its name (``'-'`` when unknown).

        Parameters
        ----------
        name : str
            A parameter (scene key path) or output name.

        Returns
        -------
        str
            E.g. ``'kg'`` for ``bodies.bar.mass``, ``'m/s'`` for
            ``peak_speed:tip``, ``'rad'`` for ``final:pin.angle``, ``'N m'``
            for ``peak_effort:motor`` of a study whose motor turns a joint;
            ``'-'`` for a dimensionless number, a count, or a unit neither
            the name nor the scene fixes (``stiffness``, a bare joint name).
        """
        return self.units.get(name) or _column_unit(name)

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
        ran = set(self.ran)
        for r in bad:
            params = ", ".join(f"{k}={v}" for k, v in r["parameters"].items())
            before = "" if r.get("case_id") in ran else " (in an earlier run, not run again)"
            lines.append(f"  case {r['case']} ({params}) {r['status']}{before}: {r['error']}")
        stale = {r.get("case_id") for r in bad} - ran
        if stale:
            lines.append(f"  {len(stale)} failed case(s) are from an earlier run: retry_failed=True "
                         "(flexmb study --retry-failed) runs them again")
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
_TABLE_KEY_UNITS = {("bodies", "damping"): "s", ("initial", "velocity"): "m/s", ("initial", "omega"): "rad/s"}
#: outputs by kind: a fixed unit, or "coordinate" (the unit of the coordinate named)
_OUTPUT_UNITS = {"peak_speed": "m/s", "peak_speed_exact": "m/s", "max_displacement": "m", "driver_work": "J",
                 "energy_balance": "-", "position": "m", "velocity": "m/s", "acceleration": "m/s^2",
                 "peak_acceleration": "m/s^2", "angular_velocity": "rad/s", "body_angular_velocity": "rad/s",
                 "peak_angular_speed": "rad/s",
                 "final": "coordinate", "max": "coordinate", "min": "coordinate", "history": "coordinate",
                 "time": "s", "n_rhs": "-"}


def _scene_units(names, scene) -> dict:
    """Units of output columns that the scene fixes and their name alone does not.

    Parameters
    ----------
    names : iterable of str
        Output names.
    scene : flexmb.scene.Scene
        The study's scene (its first case).

    Returns
    -------
    dict of str to str
        ``peak_effort:<driver>``: the driver's
        :attr:`~flexmb.Driver.effort_unit` (``'N m'`` for a driven rotation,
        ``'N'`` for a driven translation).
    """
    drivers = {d.name: d for d in scene.model.drivers}
    units = {}
    for name in names:
        kind, _, arg = name.partition(":")
        if kind == "peak_effort" and arg in drivers and drivers[arg].effort_unit != "-":
            units[name] = drivers[arg].effort_unit
    return units


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
        from ..viz.plots import _joint_coordinate_units
        from ..flexible import ELASTIC_COORDINATES

        coord = arg.rpartition(".")[2] if "." in arg else ""
        if coord in ELASTIC_COORDINATES and ".j" in arg:
            unit = "m" if ELASTIC_COORDINATES[coord][0] == "t" else "rad"
        else:
            unit = _joint_coordinate_units().get(coord) or "-"
    return unit
