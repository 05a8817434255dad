"""VTK export for ParaView: one ``.vtu`` per output time and a ``.pvd`` collection.

Every file is an unstructured grid holding the bodies where they are at
that time (the current configuration), drawn as their shapes through their
joint points. With the system the result came from (``system=``, a System
or the Model):

* a rigid body is the uniform box with its mass and central inertia
  (a ``hexahedron``; a ``line`` for a slender bar, a ``quad`` for a plate),
  centred at its mass centre along its principal axes, so a bar runs
  between the joints at its ends;
* a flexible body is one ``hexahedron`` per segment, the segment's length
  by the section's width and height, and its centre line (``line`` cells
  through the root, every segment joint and the tip);
* every joint is a ``vertex`` on each body it joins, at that body's joint
  point, and a ``line`` (a *lever*) joins a joint point outside the body's
  shape to the nearest point of the shape, so the bodies meet where their
  joints connect; a joint with translations adds a ``line`` from the
  parent's joint point to the child's (the slide).

Without a system a result alone carries no joint points and no sections: a
rigid body is then a line from its body-frame origin through its mass
centre to the mirror point (the whole of a bar whose frame sits at one end),
a flexible body its centre line, and velocities are finite differences.

Point data: ``elastic_displacement`` (m, the active vectors, so ParaView's
Warp By Vector takes it: a flexible body's points minus where they would be
on the body undeformed, moved rigidly with its clamp frame or first
segment; 0 on rigid bodies), ``velocity`` (m/s, exact with a system: ``v +
omega x (p - r)`` of the body that carries the point), the elastic
coordinates of the segment joints (``bending_y``, ``bending_z``,
``torsion``, plus ``axial``, ``shear_y``, ``shear_z`` when a body keeps
them) and, with a system, the section loads ``moment_torsion``,
``moment_bend_y``, ``moment_bend_z`` (N m) and ``von_mises`` (Pa)
(:mod:`flexmb.post`). Cell data: ``body_id``, ``joint_id``, ``segment``,
``part_id`` and ``angular_velocity`` (rad/s, inertial axes: that of the
body or segment a cell draws; exact with a system, from differences of the
rotations without). Field data: ``time``, ``TimeValue`` (ParaView's time of a
file), and the names of the ids, one entry ``"body:<name>"``,
``"joint:<name>"``, ``"part:<name>"`` holding its id (:func:`table_names`;
``open_in_paraview.py`` colours by ``body_id`` as categories labelled with
them). The files hold numbers only, so that meshio reads them as well as
VTK and ParaView. Mode shapes (and snapshots given a ``reference``) are
drawn at the reference configuration with a ``displacement`` to warp by.
See ``docs/export.md``.

meshio is imported by :mod:`flexmb.export`'s modules and nowhere else in
flexmb: ``import flexmb`` does not load it. A mesh is a
:class:`meshio.Mesh` (:mod:`flexmb.export.layout` places the cells,
:mod:`flexmb.export.meshes` builds the meshes), holding what its file
holds; the files are written by :mod:`flexmb.export.vtu` rather than by
meshio, whose VTU writer drops field data; read them with
``meshio.read``. meshio has no ``.pvd`` writer, so :func:`write_pvd` writes
the collection XML itself with :mod:`xml.etree`.
"""
from __future__ import annotations

import os
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from .._files import atomic_write
from ..errors import ExportError
from .layout import ELASTIC_FIELDS, PARTS, SECTION_FIELDS, _check_result
from .meshes import _meshes, body_names, joint_names, table_names, to_meshio
from .vtu import _write_mesh

__all__ = ["ELASTIC_FIELDS", "SECTION_FIELDS", "PARTS", "body_names", "joint_names", "table_names", "to_meshio",
           "write_vtu", "write_pvd", "export_vtk", "paraview_script"]

def _check_prefix(prefix: str) -> str:
    if not isinstance(prefix, str) or not prefix or os.sep in prefix or "/" in prefix or prefix.startswith("."):
        raise ExportError(f"prefix must be a non-empty file-name stem without a folder, not starting with '.' "
                          f"(a hidden file), got {prefix!r}")
    return prefix


def write_vtu(result, folder, prefix: str = "flexmb", *, system=None, triad: float = 0.0) -> list[Path]:
    """Write one ``.vtu`` file per output time.

    Parameters
    ----------
    result : Result
        A simulation result.
    folder : str or path-like
        Output folder (created if missing).
    prefix : str
        File-name stem: files are ``<prefix>_0000.vtu``, ``<prefix>_0001.vtu``, ...
    system : System or Model, optional
        The model the result came from: bodies through their joints, exact
        velocities, section loads; see :func:`to_meshio`.
    triad : float
        Body-axis line length for rigid bodies, m (0: none).

    Returns
    -------
    list of pathlib.Path
        The files, in output order.

    Raises
    ------
    ExportError
        On a malformed result or prefix, or a system that does not match.
    """
    nt = _check_result(result)
    prefix = _check_prefix(prefix)
    folder = Path(os.fspath(folder))
    width = max(4, len(str(nt - 1)))
    paths = []
    for i, mesh in enumerate(_meshes(result, range(nt), system, triad)):
        paths.append(_write_mesh(mesh, folder / f"{prefix}_{i:0{width}d}.vtu"))
    return paths


def write_pvd(paths, times, path) -> Path:
    """Write a ParaView collection (``.pvd``) listing data files with their times.

    Parameters
    ----------
    paths : sequence of str or path-like
        The data files (``.vtu``), in time order; they must exist.
    times : array_like, shape (len(paths),)
        Their times, s, strictly increasing.
    path : str or path-like
        The ``.pvd`` file to write. File names in it are relative to its folder.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ExportError
        If the lengths differ, the times are not finite and increasing, or a
        file is missing.

    Notes
    -----
    The format is ``<VTKFile type="Collection"><Collection><DataSet
    timestep="t" group="" part="0" file="name.vtu"/>...``; times are written
    with ``repr`` so they read back exactly. ParaView opens it as one time
    series.
    """
    paths = [Path(os.fspath(p)) for p in paths]
    times = np.asarray(times, dtype=float).ravel()
    if len(paths) == 0 or len(paths) != len(times):
        raise ExportError(f"write_pvd needs one time per file and at least one file: got {len(paths)} files "
                          f"and {len(times)} times")
    if not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
        raise ExportError("write_pvd: times must be finite and strictly increasing")
    missing = [str(p) for p in paths if not p.is_file()]
    if missing:
        raise ExportError(f"write_pvd: data file(s) not found: {missing[:3]}")
    path = Path(os.fspath(path))
    base = path.parent.resolve() if path.parent.exists() else Path(os.path.abspath(path.parent))
    root = ET.Element("VTKFile", type="Collection", version="0.1",
                      byte_order="LittleEndian" if sys.byteorder == "little" else "BigEndian")
    collection = ET.SubElement(root, "Collection")
    for p, t in zip(paths, times):
        rel = Path(os.path.relpath(p.resolve(), base)).as_posix()
        ET.SubElement(collection, "DataSet", timestep=repr(float(t)), group="", part="0", file=rel)
    ET.indent(root)
    tree = ET.ElementTree(root)
    return atomic_write(path, lambda tmp: tree.write(tmp, encoding="utf-8", xml_declaration=True), suffix=".pvd")


def export_vtk(result, folder, prefix: str = "flexmb", *, system=None, triad: float = 0.0) -> Path:
    """Write a result for ParaView: one ``.vtu`` per output time and ``<prefix>.pvd``.

    Parameters
    ----------
    result : Result
        A simulation result.
    folder : str or path-like
        Output folder (created if missing).
    prefix : str
        File-name stem.
    system : System or Model, optional
        The model the result came from: pass it to draw the bodies through
        their joints, with exact velocities and the section loads and
        stresses (see :func:`to_meshio`).
    triad : float
        Body-axis line length for rigid bodies, m (0: none).

    Returns
    -------
    pathlib.Path
        The ``.pvd`` file; open it in ParaView (File > Open), or run
        :func:`paraview_script` in ``pvpython``.

    Raises
    ------
    ExportError
        On a malformed result or prefix, or a system that does not match.

    Examples
    --------
    >>> import tempfile, flexmb as fm
    >>> from flexmb.export.vtk import export_vtk
    >>> model = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    >>> _ = model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0, -9.81, 0)))
    >>> res = fm.simulate(model, 0.1, positions={"pin": 0.5}, n_out=3)
    >>> export_vtk(res, tempfile.mkdtemp(), system=model).name
    'flexmb.pvd'
    """
    paths = write_vtu(result, folder, prefix, system=system, triad=triad)
    return write_pvd(paths, result.t, Path(os.fspath(folder)) / f"{prefix}.pvd")


def paraview_script(path) -> Path:
    """Write the ParaView script that opens flexmb's ``.pvd`` series coloured by stress.

    Parameters
    ----------
    path : str or path-like
        Where to write it (e.g. ``results/open_in_paraview.py``).

    Returns
    -------
    pathlib.Path
        ``path``. Run it with ``pvpython path`` (or ``paraview
        --script=path``): it opens every ``.pvd`` below its folder, or the
        ones named on its command line; see
        :mod:`flexmb.export.open_in_paraview`.
    """
    from . import open_in_paraview

    source = Path(open_in_paraview.__file__).read_text(encoding="utf-8")
    return atomic_write(path, lambda tmp: Path(tmp).write_text(source, encoding="utf-8"), suffix=".py")
