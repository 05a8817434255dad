"""The results of path following: the load path, its critical points, and the follower's options.

See :mod:`flexmb.analysis.path_following` for the method.
"""

from __future__ import annotations

import numpy as np
from attrs import define, field, frozen

from ..errors import ExportError, ModelError
from ..fields import as_count, as_float, count, finite_number

__all__ = ["LoadPath", "CriticalPoint", "PathOptions"]


def _positive(instance, attribute, value):
    if not (np.isfinite(value) and value > 0):
        raise ModelError(f"PathOptions: {attribute.name} must be > 0, got {value!r}")


def _cosine(instance, attribute, value):
    if not -1.0 <= value < 1.0:
        raise ModelError(f"PathOptions: {attribute.name} must be a cosine in [-1, 1), got {value!r}")


@frozen
class PathOptions:
    """Step control of the load-path follower (:func:`load_path`, :func:`static_equilibrium`).

    Arc lengths are measured in load-factor units: a path step of length
    ``ds`` is ``sqrt(|dx|^2 / c^2 + dlambda^2) = ds``, with ``c = |dx/dlambda|``
    at the start of the path, so at the start a step ``ds`` raises the load
    factor by about ``ds / sqrt(2)``.

    Parameters
    ----------
    step : float
        First arc-length step.
    min_step : float
        Smallest step: when a step this short fails, the path stops with an
        :class:`~flexmb.AssemblyError`.
    max_step : float
        Largest step.
    max_steps : int
        Path steps allowed (accepted ones).
    iterations : int
        Newton iterations a step should take: fewer grow the next step
        (up to 1.5 times), more shrink it.
    max_iter : int
        Newton iterations allowed in one step before it is halved.
    tol : float
        Convergence of a path point: the largest Newton correction of a
        coordinate (rad or m) and of the load factor below ``tol``. The
        point where the path meets its target load factor is converged to
        the caller's own tolerance.
    max_turn : float
        Smallest cosine of the angle between the path's tangents at the two
        ends of a step; a step that turns more is halved, so that the
        corrector does not jump to another branch of the path.
    max_limit_points : int
        Limit points passed before the path is given up: a path that turns
        back and forth (a mechanism that goes round and round, as a
        pendulum under a torque it cannot hold) never reaches its target.

    Examples
    --------
    >>> import flexmb as fm
    >>> fm.PathOptions(step=0.05).max_step
    0.5
    """

    step: float = field(default=0.1, converter=as_float, validator=[finite_number, _positive])
    min_step: float = field(default=1e-6, converter=as_float, validator=[finite_number, _positive])
    max_step: float = field(default=0.5, converter=as_float, validator=[finite_number, _positive])
    max_steps: int = field(default=500, converter=as_count, validator=count)
    iterations: int = field(default=4, converter=as_count, validator=count)
    max_iter: int = field(default=10, converter=as_count, validator=count)
    tol: float = field(default=1e-8, converter=as_float, validator=[finite_number, _positive])
    max_turn: float = field(default=0.5, converter=as_float, validator=[finite_number, _cosine])
    max_limit_points: int = field(default=8, converter=as_count, validator=count)

    def __attrs_post_init__(self):
        if not self.min_step <= self.step <= self.max_step:
            raise ModelError(f"PathOptions: need min_step <= step <= max_step, got {self.min_step!r}, "
                             f"{self.step!r}, {self.max_step!r}")


@define
class CriticalPoint:
    """A critical point of a load path: a limit point or a bifurcation point.

    At both the tangent stiffness is singular. At a limit point the load
    factor is extreme (the path turns back: snap-through under load
    control); at a bifurcation point it is not, and another equilibrium
    path crosses this one (buckling of a perfect structure).

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    lam : float
        Load factor at the point.
    x : ndarray, shape (n,)
        Coordinates there.
    arc : float
        Arc length along the path (load-factor units, see :class:`PathOptions`).
    index : int
        The point lies between path points ``index`` and ``index + 1``.
    kind : {'maximum', 'minimum', 'bifurcation'}
        Whether the load factor peaks or dips there, or a bifurcation.
    """

    lam: float
    x: np.ndarray
    arc: float
    index: int
    kind: str


@define
class LoadPath:
    """Equilibrium states along a load path, from :func:`load_path` or :func:`static_equilibrium`.

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    lam : ndarray, shape (m,)
        Load factors of the path points.
    x : ndarray, shape (m, n)
        Coordinates of the path points.
    residual : ndarray, shape (m,)
        Largest generalized force left in the static equations at each point
        (N or N m).
    arc : ndarray, shape (m,)
        Arc length of each point (load-factor units, see :class:`PathOptions`).
    limit_points : list of CriticalPoint
        Where the load factor passes through an extreme (the path's tangent
        ``dlambda/ds`` changes sign), located between the path points.
    bifurcations : list of CriticalPoint
        Where the tangent stiffness changes its number of unstable
        directions while the load factor goes on in the same direction: an
        eigenvalue crossed zero with no limit point, so another path
        branches off (buckling). Located by linear interpolation of that
        eigenvalue between the two path points.
    n_unstable : ndarray of int, shape (m,)
        Number of negative eigenvalues of the (symmetric part of the)
        reduced tangent stiffness at each point: 0 where the equilibrium is
        stable under conservative loads.
    load : str
        What the load factor scales.
    coordinate_names : list of str
        Names of the coordinates (the columns of ``x``).
    reached : bool
        Whether the path reached its target load factor (the last point).
    n_steps, n_rejected, n_iterations, n_tangents : int
        Accepted and rejected steps, Newton iterations, and tangent
        stiffness matrices formed (each by ``2 p`` force evaluations).
    """

    lam: np.ndarray
    x: np.ndarray
    residual: np.ndarray
    arc: np.ndarray
    limit_points: list
    bifurcations: list
    n_unstable: np.ndarray
    load: str
    coordinate_names: list
    reached: bool = False
    n_steps: int = 0
    n_rejected: int = 0
    n_iterations: int = 0
    n_tangents: int = 0

    def __repr__(self) -> str:
        lims = _list_limits(self.limit_points) or "none"
        bifs = f", bifurcations at lambda = {_list_limits(self.bifurcations)}" if self.bifurcations else ""
        return (f"LoadPath(load={self.load!r}, {len(self.lam)} points, lambda {self.lam[0]:.6g} -> "
                f"{self.lam[-1]:.6g}, limit points at lambda = {lims}{bifs}, reached={self.reached})")

    @property
    def stable(self) -> np.ndarray:
        """Whether each path point is a stable equilibrium (``n_unstable == 0``).

        Returns
        -------
        ndarray of bool, shape (m,)
            True where the tangent stiffness is positive definite.
        """
        return self.n_unstable == 0

    def coordinate(self, name) -> np.ndarray:
        """One coordinate along the path.

        Parameters
        ----------
        name : str or int
            Coordinate name (``system.coordinate_names``) or column.

        Returns
        -------
        ndarray, shape (m,)
            Its value at each path point.

        Raises
        ------
        ExportError
            If no coordinate has that name.
        """
        if isinstance(name, str):
            if name not in self.coordinate_names:
                raise ExportError(f"no coordinate {name!r}; coordinates are {self.coordinate_names}")
            name = self.coordinate_names.index(name)
        return self.x[:, int(name)]

    def plot(self, y=None, ax=None, path=None, xlabel: str | None = None):
        """Plot the load factor against a measure of the deformation (matplotlib).

        Parameters
        ----------
        y : str, int or callable, optional
            What goes on the horizontal axis: a coordinate name or column,
            or a function of the coordinates ``y(x) -> float`` (a tip
            deflection, say). Default: the distance ``|x - x[0]|`` from the
            first point.
        ax : matplotlib.axes.Axes, optional
            Axes to draw in (default: a new figure).
        path : str or path-like, optional
            Save the figure there (format from the suffix).
        xlabel : str, optional
            Label of the horizontal axis (default: the coordinate's name,
            the function's name, or ``|x - x0| (rad, m)``).

        Returns
        -------
        matplotlib.figure.Figure
            The figure; limit points and bifurcations are marked.

        Raises
        ------
        ExportError
            If matplotlib is not installed or ``y`` names no coordinate.
        """
        try:
            import matplotlib  # noqa: F401
        except ImportError as exc:
            raise ExportError("plot needs matplotlib: pip install 'flexmb[viz]'") from exc
        critical = [*self.limit_points, *self.bifurcations]
        if callable(y):
            values = np.array([float(y(x)) for x in self.x])
            at = [float(y(p.x)) for p in critical]
            axis_name = getattr(y, "__name__", "<")
            axis_name = "y(x)" if axis_name.startswith("<") else axis_name
        elif y is None:
            values = np.linalg.norm(self.x - self.x[0], axis=1)
            at = [float(np.linalg.norm(p.x - self.x[0])) for p in critical]
            axis_name = "|x - x0| (rad, m)"
        else:
            values = self.coordinate(y)
            col = self.coordinate_names.index(y) if isinstance(y, str) else int(y)
            at = [float(p.x[col]) for p in critical]
            axis_name = self.coordinate_names[col]
        if ax is None:
            if path is None:
                import matplotlib.pyplot as plt

                fig, ax = plt.subplots(figsize=(6.0, 4.0))
            else:
                from matplotlib.figure import Figure

                fig = Figure(figsize=(6.0, 4.0))
                ax = fig.subplots()
        else:
            fig = ax.figure
        ax.plot(values, self.lam, ".-", label=f"load path ({self.load})")
        n_lim = len(self.limit_points)
        if n_lim:
            ax.plot(at[:n_lim], [p.lam for p in self.limit_points], "rv", label="limit points")
        if self.bifurcations:
            ax.plot(at[n_lim:], [p.lam for p in self.bifurcations], "ks", label="bifurcations")
        ax.set_xlabel(axis_name if xlabel is None else xlabel)
        ax.set_ylabel("load factor (-)")
        ax.legend(fontsize="small")
        if path is not None:
            fig.savefig(path)
        return fig


def _list_limits(limits, most=4) -> str:
    text = ", ".join(f"{p.lam:.6g}" for p in limits[:most])
    return text + (f", ... ({len(limits)} in all)" if len(limits) > most else "")
