"""Single states and mode shapes of a system as ``.vtu`` files (ParaView).

The states are held in a :class:`~flexmb.result.Result` built by
:meth:`Result.from_states <flexmb.result.Result.from_states>` and drawn by
the same meshes as :func:`flexmb.export.vtk.export_vtk`.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import ExportError
from ..model import as_system
from ..result import Result
from .meshes import _meshes
from .vtk import _check_prefix
from .vtu import _write_mesh

__all__ = ["export_snapshot", "export_modes"]


def _states(system, t: float, xs, xds) -> Result:
    """A Result holding a few states of ``system``, held at rest (``xdd = 0``), for export."""
    for name, v, n, what in (("x", xs, system.n_coords, "coordinates"), ("xd", xds, system.n_speeds, "speeds")):
        if v.shape != (len(xs), n) or not np.all(np.isfinite(v)):
            raise ExportError(f"{name} must be a finite array of {n} {what} per state, got shape "
                              f"{v.shape[1:]}")
    return Result.from_states(system, xs, xds, xdd=np.zeros_like(xds), t=np.full(len(xs), float(t)),
                              message="exported state")


def export_snapshot(system, x, path, *, xd=None, t: float = 0.0, reference=None, triad: float = 0.0) -> Path:
    """Write one state of a system to a ``.vtu`` file.

    Parameters
    ----------
    system : System or Model
        The model (a Model is built with the default complement).
    x : array_like, shape (nq,)
        Coordinates.
    path : str or path-like
        The ``.vtu`` file to write.
    xd : array_like, shape (n,), optional
        Speeds (default 0); velocities are exact.
    t : float
        Time written to the field data, s.
    reference : array_like, shape (nq,), optional
        Draw the bodies at these coordinates instead and add the point data
        ``displacement`` from there to ``x`` (ParaView: Warp By Vector,
        scale 1, shows the state ``x``). Default: drawn at ``x``, no
        displacement.
    triad : float
        Body-axis line length for rigid bodies, m (0: none).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ExportError
        If ``x``, ``xd`` or ``reference`` has the wrong length or is not finite.
    """
    system = as_system(system, ExportError)
    nq, n = system.n_coords, system.n_speeds
    xd = np.zeros(n) if xd is None else xd
    ref = system.layout.reference() if reference is None else reference
    res = _states(system, t, _stack(x, ref, nq), _stack(xd, np.zeros(n), n))
    mesh = next(_meshes(res, [0], system, triad, reference=None if reference is None else 1))
    return _write_mesh(mesh, path)


def _stack(a, b, n):
    try:
        return np.array([np.asarray(a, dtype=float).reshape(n), np.asarray(b, dtype=float).reshape(n)])
    except (TypeError, ValueError):
        raise ExportError(f"a state must have {n} coordinates, got shapes {np.shape(a)} and {np.shape(b)}") from None


def export_modes(system, frequencies, shapes, folder, *, scale: float = 0.1, prefix: str = "mode", x0=None,
                 triad: float = 0.0) -> list[Path]:
    """Write one ``.vtu`` file per mode shape.

    Each file draws the bodies at ``x0``, the configuration linearised
    about, with the point data ``displacement`` carrying them to ``x0 +
    scale * shapes[:, k]``: in ParaView, Warp By Vector on ``displacement``
    (scale factor 1, or -1 for the other half of the swing) shows the mode.

    Parameters
    ----------
    system : System or Model
        The model the modes belong to.
    frequencies : array_like, shape (k,)
        Natural frequencies, Hz (from :func:`flexmb.modes`).
    shapes : array_like, shape (n, k)
        Mode shapes in the coordinates x, one per column.
    folder : str or path-like
        Output folder (created if missing).
    scale : float
        Amplitude of the largest coordinate of each (unit-normalised) mode,
        rad or m.
    prefix : str
        File-name stem: ``<prefix>_01.vtu`` is the first mode.
    x0 : array_like, shape (n,), optional
        The configuration linearised about (default 0).
    triad : float
        Body-axis line length for rigid bodies, m (0: none).

    Returns
    -------
    list of pathlib.Path
        The files, lowest mode first. Field data: ``frequency`` (Hz) and
        ``mode`` (1-based); velocities are zero (a still shape); the
        section loads are those of the displaced shape.

    Raises
    ------
    ExportError
        If ``shapes`` does not have ``n`` rows and one column per frequency,
        or ``scale`` is not finite.
    """
    system = as_system(system, ExportError)
    prefix = _check_prefix(prefix)
    nq, n = system.n_coords, system.n_speeds
    f = np.asarray(frequencies, dtype=float).ravel()
    S = np.asarray(shapes, dtype=float)
    if S.ndim == 1:
        S = S[:, None]
    if S.shape != (n, f.size):
        raise ExportError(f"shapes must have shape (n_speeds, n_modes) = ({n}, {f.size}), got {S.shape}")
    if not np.isfinite(scale):
        raise ExportError(f"scale must be finite, got {scale}")
    x0 = _stack(np.zeros(nq), system.layout.reference() if x0 is None else x0, nq)[1]
    width = max(2, len(str(f.size)))
    folder = Path(os.fspath(folder))
    paths = []
    for k in range(f.size):
        res = _states(system, 0.0, np.array([system.layout.displace(x0, scale * S[:, k]), x0]), np.zeros((2, n)))
        mesh = next(_meshes(res, [0], system, triad, extra={"frequency": f[k], "mode": np.int64(k + 1)},
                            reference=1))
        del mesh.field_data["time"], mesh.field_data["TimeValue"]
        paths.append(_write_mesh(mesh, folder / f"{prefix}_{k + 1:0{width}d}.vtu"))
    return paths
