"""Campbell diagrams: frequencies and damping of the linearised motion against a parameter."""

from __future__ import annotations

import numpy as np
from attrs import define
from scipy.optimize import linear_sum_assignment

from ..errors import ModelError
from ..threads import limited_blas
from .statespace import state_space

__all__ = ["Campbell", "campbell", "TRACKING"]

#: how :func:`campbell` follows the modes from one parameter value to the next
TRACKING = ("mac", "nearest", None)

#: an eigenvalue with ``Im > OSCILLATORY_TOL |lambda|`` is an oscillating mode
OSCILLATORY_TOL = 1e-9


@define
class Campbell:
    """Frequencies and damping ratios of tracked modes over a parameter sweep.

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    parameter : ndarray, shape (k,)
        The swept values.
    eigenvalues : ndarray, shape (k, n_modes), complex
        ``lambda`` of each tracked mode (the one with positive imaginary
        part of its conjugate pair), 1/s.
    shapes : ndarray, shape (k, n, n_modes), complex
        Mode shapes in the generalized coordinates x (``T phi``), unit norm.
    mac : ndarray, shape (k, n_modes)
        Modal assurance criterion of each mode with itself at the previous
        value (1 at the first): near 1, the tracking is sure.
    label : str
        Name of the parameter (axis label).

    Examples
    --------
    >>> import flexmb as fm
    >>> def build(k):  # a bar on a torsion spring k: f = sqrt(3 k) / (2 pi)
    ...     m = fm.Model()
    ...     bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    ...     pin = fm.Revolute("pin", m.ground, bar, axis=(0, 0, 1))
    ...     return m.add(pin, fm.JointSpringDamper("spring", pin, k, 0.01))
    >>> c = fm.campbell(build, [1.0, 4.0], n_modes=1, label="k (N m/rad)")
    >>> c.frequencies.round(4)
    array([[0.2757],
           [0.5513]])
    """

    parameter: np.ndarray
    eigenvalues: np.ndarray
    shapes: np.ndarray
    mac: np.ndarray
    label: str = "parameter"

    @property
    def frequencies(self) -> np.ndarray:
        """Damped natural frequencies ``Im(lambda) / 2 pi``, Hz, shape (k, n_modes)."""
        return self.eigenvalues.imag / (2 * np.pi)

    @property
    def natural_frequencies(self) -> np.ndarray:
        """Undamped natural frequencies ``|lambda| / 2 pi``, Hz, shape (k, n_modes)."""
        return np.abs(self.eigenvalues) / (2 * np.pi)

    @property
    def damping(self) -> np.ndarray:
        """Damping ratios ``-Re(lambda) / |lambda|``, shape (k, n_modes) (negative: unstable)."""
        return -self.eigenvalues.real / np.abs(self.eigenvalues)

    def plot(self, path=None, *, orders=(), hz: bool = True, damping: bool = True, figsize=(7.0, 6.0)):
        """Campbell diagram: frequency (and damping ratio) of each mode against the parameter.

        Parameters
        ----------
        path : str or path-like, optional
            Save the figure there (PNG, PDF, ... by its ending).
        orders : sequence of float
            Excitation orders to draw as lines ``f = order * parameter``
            (for a parameter that is a rotation rate in rad/s: drawn as
            ``order * parameter / 2 pi`` Hz); where a mode crosses one, that
            order of the rotation excites it.
        hz : bool
            Frequencies in Hz (default) or rad/s.
        damping : bool
            Add an axis with the damping ratios (default).
        figsize : tuple of float
            Figure size, inches.

        Returns
        -------
        matplotlib.figure.Figure
            The frequency axis (and the damping axis below it).

        Raises
        ------
        ExportError
            If matplotlib is not installed.
        """
        from .frequency import _figure

        fig, axes = _figure(path, figsize if damping else (figsize[0], figsize[1] / 1.6), 2 if damping else 1)
        scale = 1.0 if hz else 2 * np.pi
        x = self.parameter
        for i in range(self.eigenvalues.shape[1]):
            axes[0].plot(x, scale * self.frequencies[:, i], "o-", ms=3, label=f"mode {i + 1}")
            if damping:
                axes[1].plot(x, self.damping[:, i], "o-", ms=3, label=f"mode {i + 1}")
        for k in orders:
            axes[0].plot(x, k * x * (scale / (2 * np.pi)), "k--", lw=0.8, label=f"order {k:g}")
        axes[0].set_ylabel("frequency (Hz)" if hz else "frequency (rad/s)")
        axes[0].legend(fontsize="small")
        if damping:
            axes[1].set_ylabel("damping ratio (-)")
        axes[-1].set_xlabel(self.label)
        for ax in axes:
            ax.grid(True, alpha=0.3)
        from ..viz.plots import _finish

        return _finish(fig, path)


def _mac(a, b) -> np.ndarray:
    """Modal assurance criterion ``|a^H b|^2 / (|a|^2 |b|^2)`` of the columns, shape (a cols, b cols)."""
    num = np.abs(a.conj().T @ b) ** 2
    return num / np.outer(np.sum(np.abs(a) ** 2, axis=0), np.sum(np.abs(b) ** 2, axis=0))


def _oscillating(ss):
    """Eigenvalues with positive imaginary part, ascending, and their shapes in x (unit norm)."""
    lam, vec = np.linalg.eig(ss.A)
    keep = lam.imag > OSCILLATORY_TOL * np.abs(lam)
    lam, vec = lam[keep], vec[:, keep]
    order = np.argsort(lam.imag)
    lam, vec = lam[order], vec[:, order]
    p = ss.A.shape[0] // 2
    shapes = ss.linearization.T @ vec[:p]
    shapes /= np.linalg.norm(shapes, axis=0)
    return lam, shapes


def _split(built):
    if isinstance(built, tuple):
        if len(built) != 2:
            raise ModelError("campbell: build must return a System or Model, or (system, about)")
        return built
    return built, None


@limited_blas
def campbell(build, values, *, n_modes: int = 3, track: str | None = "mac", method: str = "auto",
             label: str = "parameter") -> Campbell:
    """Sweep a parameter and follow the frequencies and damping of the linearised modes (Campbell diagram).

    Parameters
    ----------
    build : callable
        ``build(value)`` returns the model at one parameter value: a
        :class:`~flexmb.System` or :class:`~flexmb.Model` (linearised about
        the zero state), or ``(system, about)`` with ``about`` as in
        :func:`~flexmb.state_space` (e.g. a steadily spinning state).
    values : array_like, shape (k,)
        Parameter values, in the order the modes are followed.
    n_modes : int
        How many modes to follow (the lowest oscillating ones at the first
        value).
    track : {'mac', 'nearest', None}
        How a mode is recognised at the next value: by the largest modal
        assurance criterion of the shapes (default), by the nearest
        frequency, or not at all (sorted by frequency at each value).
        Tracking keeps a mode's line continuous where frequencies cross.
    method : {'auto', 'analytic', 'fd'}
        How K and C are formed, see :func:`~flexmb.linearize`.
    label : str
        Name of the parameter, for the plot.

    Returns
    -------
    Campbell
        ``.frequencies`` (Hz), ``.damping`` (ratios), ``.eigenvalues``,
        ``.shapes``, ``.mac``, ``.plot()``.

    Raises
    ------
    ModelError
        If ``track`` is unknown or a value has fewer than ``n_modes``
        oscillating modes.

    Notes
    -----
    At each value the eigenvalues of the state matrix A of
    :func:`~flexmb.state_space` are taken (damping and gyroscopic terms
    included); a conjugate pair ``lambda = -zeta w +/- j w sqrt(1 - zeta^2)``
    counts once. Eigenvalues on the real axis (rigid-body and overdamped
    motions) are left out. With tracking, ``2 n_modes + 2`` candidates are
    compared at each value, and the assignment that maximises the summed
    MAC (or minimises the summed frequency change) is taken
    (:func:`scipy.optimize.linear_sum_assignment`).

    Examples
    --------
    The B3 beam (10 m, E I = 1.4e4 N m^2, rho A = 1.2 kg/m, 8 segments)
    bending in its plane of rotation, about steady spin at 0 and 4 rad/s: the
    first frequency rises nearly as Southwell's ``w^2 = w0^2 + 0.193 Omega^2``
    (1.4 % below it at 4 rad/s with 8 segments).

    >>> import numpy as np
    >>> import flexmb as fm
    >>> def spinning(rate):
    ...     m = fm.Model()
    ...     beam = fm.FlexibleBody("beam", 10.0, fm.Section(area=1e-3, Iy=1e-6, Iz=1e-6, J=2e-6),
    ...                            fm.Material(E=1.4e10, density=1200.0), 8, keep=("bend_z",),
    ...                            rotary_inertia=False)
    ...     hub = fm.Revolute("hub", m.ground, beam, axis=(0, 0, 1))
    ...     system = m.add(hub, fm.Driver.constant_speed("spin", hub, rate)).build()
    ...     xd0 = np.zeros(system.n_coords)
    ...     xd0[system.coordinate_slice(hub)] = rate
    ...     return system, (np.zeros(system.n_coords), xd0)
    >>> c = fm.campbell(spinning, [0.0, 4.0], n_modes=1, label="spin rate (rad/s)")
    >>> w = 2 * np.pi * c.frequencies[:, 0]
    >>> round(float(w[1] / np.sqrt(w[0] ** 2 + 0.1933 * 4.0 ** 2)), 3)
    0.986
    """
    if track not in TRACKING:
        raise ModelError(f"campbell: unknown track {track!r}; pick one of {list(TRACKING)}")
    values = np.atleast_1d(np.asarray(values, dtype=float))
    lams, shapes, macs = [], [], []
    for i, v in enumerate(values):
        system, about = _split(build(v))
        ss = state_space(system, about=about, method=method)
        lam, phi = _oscillating(ss)
        if lam.shape[0] < n_modes:
            raise ModelError(f"campbell: at {label} = {v:g} there are {lam.shape[0]} oscillating modes, "
                             f"fewer than n_modes = {n_modes}")
        if i == 0 or track is None:
            pick = np.arange(n_modes)
            mac = np.ones(n_modes) if i == 0 else _mac(shapes[-1], phi[:, :n_modes]).diagonal()
        else:
            m = min(lam.shape[0], 2 * n_modes + 2)
            cand_lam, cand_phi = lam[:m], phi[:, :m]
            mac_all = _mac(shapes[-1], cand_phi)
            if track == "mac":
                cost = -mac_all
            else:
                prev = lams[-1].imag
                guess = prev if i < 2 else 2 * prev - lams[-2].imag  # linear extrapolation of the lines
                cost = np.abs(guess[:, None] - cand_lam.imag[None, :])
            rows, cols = linear_sum_assignment(cost)
            pick = cols[np.argsort(rows)]
            mac = mac_all[np.arange(n_modes), pick]
        lams.append(lam[pick])
        shapes.append(phi[:, pick])
        macs.append(mac)
    return Campbell(parameter=values, eigenvalues=np.array(lams), shapes=np.array(shapes), mac=np.array(macs),
                    label=label)
