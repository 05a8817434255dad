"""``.vtu`` files written and read by flexmb itself.

meshio's VTU writer drops field data and cannot write string arrays, and
meshio 5.3 cannot read string arrays; :func:`_write_mesh` writes the XML
with base64 binary arrays and :func:`read_vtu` reads it back.
"""

from __future__ import annotations

import base64
import os
import sys
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np

from .._files import atomic_write
from ..errors import ExportError
from .layout import _VTK_CELLS

__all__ = ["read_vtu"]


_VTU_TYPES = {"f8": "Float64", "f4": "Float32", "i8": "Int64", "i4": "Int32", "i2": "Int16", "i1": "Int8",
              "u8": "UInt64", "u4": "UInt32", "u2": "UInt16", "u1": "UInt8"}


def _vtu_type(a: np.ndarray) -> str:
    key = f"{a.dtype.kind}{a.dtype.itemsize}"
    if a.dtype.kind == "b":
        return "UInt8"
    if key not in _VTU_TYPES:
        raise ExportError(f"cannot write an array of type {a.dtype} to VTK")
    return _VTU_TYPES[key]


def _binary(a: np.ndarray) -> str:
    """Inline binary data: base64 of a UInt64 byte count followed by the native-order bytes."""
    data = np.ascontiguousarray(a).tobytes()
    return base64.b64encode(np.uint64(len(data)).tobytes() + data).decode("ascii")


def _strings(values) -> str:
    """A VTK string array, inline binary: each string's UTF-8 bytes, then a 0."""
    data = b"".join(str(v).encode("utf-8") + b"\0" for v in values)
    return base64.b64encode(np.uint64(len(data)).tobytes() + data).decode("ascii")


def _data_array(name, a, field=False) -> str:
    a = np.asarray(a)
    if a.dtype.kind in "US":
        n = f' NumberOfTuples="{a.size}"' if field else ""
        return f'<Array type="String" Name={quoteattr(str(name))}{n} format="binary">{_strings(a.ravel())}</Array>\n'
    if a.dtype.kind == "b":
        a = a.astype(np.uint8)
    if field:  # field data in ASCII, exact (repr)
        a = a.ravel()
        text = " ".join(repr(float(v)) for v in a) if a.dtype.kind == "f" else " ".join(str(int(v)) for v in a)
        return (f'<DataArray type="{_vtu_type(a)}" Name={quoteattr(str(name))} NumberOfTuples="{a.size}" '
                f'format="ascii">{text}</DataArray>\n')
    nc = f' NumberOfComponents="{a.shape[1]}"' if a.ndim == 2 else ""
    return (f'<DataArray type="{_vtu_type(a)}" Name={quoteattr(str(name))}{nc} format="binary">'
            f'{_binary(a)}</DataArray>\n')


def _named(mesh) -> dict:
    """String cell data for ParaView: the names of the ids that have a name table."""
    out = {}
    for ids, table, name in (("body_id", "body_names", "body"), ("joint_id", "joint_names", "joint"),
                             ("part_id", "part_names", "part")):
        if ids in mesh.cell_data and table in mesh.field_data:
            names = np.append(np.asarray(mesh.field_data[table], dtype=str), "")
            out[name] = [names[np.where(v >= 0, v, len(names) - 1)] for v in mesh.cell_data[ids]]
    return out


def _cells_text(mesh) -> tuple[str, int]:
    """The CellData and Cells XML of a mesh, and its number of cells."""
    conn, offsets, types = [], [], []
    end = 0
    for block in mesh.cells:
        data = np.asarray(block.data, dtype=np.int64)
        conn.append(data.ravel())
        offsets.append(end + data.shape[1] * np.arange(1, len(data) + 1, dtype=np.int64))
        end += data.size
        vtk_type = _VTK_CELLS.get(block.type) or meshio._vtk_common.meshio_to_vtk_type[block.type]
        types.append(np.full(len(data), vtk_type, dtype=np.uint8))
    cell_data = {name: np.concatenate([np.asarray(v) for v in values]) for name, values in mesh.cell_data.items()}
    cell_data.update({name: np.concatenate(values) for name, values in _named(mesh).items()})
    text = "".join([
        "<CellData>\n",
        *(_data_array(k, v) for k, v in cell_data.items()),
        "</CellData>\n",
        "<Cells>\n",
        _data_array("connectivity", np.concatenate(conn) if conn else np.zeros(0, dtype=np.int64)),
        _data_array("offsets", np.concatenate(offsets) if offsets else np.zeros(0, dtype=np.int64)),
        _data_array("types", np.concatenate(types) if types else np.zeros(0, dtype=np.uint8)),
        "</Cells>\n",
    ])
    return text, sum(len(b.data) for b in mesh.cells)


def _vtu_text(mesh) -> str:
    """The VTU XML of a meshio mesh: binary point and cell data, ASCII field data, string arrays.

    The meshes of one export share their cells, cell data and name tables
    (and a ``_vtu_cache`` dict): their XML is made once.
    """
    byte_order = "LittleEndian" if sys.byteorder == "little" else "BigEndian"
    field = dict(mesh.field_data)
    if "time" in field:
        field.setdefault("TimeValue", field["time"])  # the name ParaView reads as a file's time
    cache = getattr(mesh, "_vtu_cache", None)
    hit = cache.get("cells") if cache is not None else None
    if hit and len(hit[0]) == len(mesh.cells) and all(a is b for a, b in zip(hit[0], mesh.cells)) \
            and hit[1] is mesh.cell_data:
        cells, n_cells = hit[2:]
    else:
        cells, n_cells = _cells_text(mesh)
        if cache is not None:
            cache["cells"] = (list(mesh.cells), mesh.cell_data, cells, n_cells)

    def field_array(name, value):
        if cache is None or np.asarray(value).dtype.kind not in "US":
            return _data_array(name, value, field=True)
        hit = cache.get(("field", name))
        if hit is None or hit[0] is not value:
            hit = cache[("field", name)] = (value, _data_array(name, value, field=True))
        return hit[1]

    points = np.asarray(mesh.points, dtype=float).reshape(-1, 3)
    return "".join([
        '<?xml version="1.0"?>\n',
        f'<VTKFile type="UnstructuredGrid" version="1.0" byte_order="{byte_order}" header_type="UInt64">\n',
        "<UnstructuredGrid>\n<FieldData>\n",
        *(field_array(k, v) for k, v in field.items()),
        f'</FieldData>\n<Piece NumberOfPoints="{len(points)}" NumberOfCells="{n_cells}">\n<PointData>\n',
        *(_data_array(k, v) for k, v in mesh.point_data.items()),
        "</PointData>\n",
        cells,
        "<Points>\n",
        _data_array("Points", points),
        "</Points>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n",
    ])


def _write_text(path, text: str) -> None:
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)


def _write_mesh(mesh, path) -> Path:
    """Write a .vtu file, with the mesh's field data, whole or not at all (through a temporary name)."""
    text = _vtu_text(mesh)
    return atomic_write(path, lambda tmp: _write_text(tmp, text), suffix=".vtu")


def read_vtu(path) -> "meshio.Mesh":
    """Read a ``.vtu`` file written by flexmb, string arrays included.

    Parameters
    ----------
    path : str or path-like
        The file.

    Returns
    -------
    meshio.Mesh
        Points, cells, point and cell data and field data; the string
        arrays (the name tables ``body_names``, ``joint_names``,
        ``part_names`` and the cell data ``body``, ``joint``, ``part``) as
        arrays of str.

    Notes
    -----
    meshio 5.3 reads VTU files but not VTK string arrays (it stops at
    ``Illegal data type 'String'``): this reader takes them out, lets
    meshio read the rest and puts them back. pyvista (VTK) reads the files
    as they are.
    """
    tree = ET.parse(os.fspath(path))
    root = tree.getroot()
    strings: dict[str, dict] = {"FieldData": {}, "CellData": {}, "PointData": {}}
    for parent in root.iter():
        if parent.tag not in strings:
            continue
        for arr in [a for a in parent if a.tag == "Array" and a.get("type") == "String"]:
            strings[parent.tag][arr.get("Name")] = _read_strings(arr)
            parent.remove(arr)
    with tempfile.TemporaryDirectory() as tmp:
        stripped = os.path.join(tmp, "mesh.vtu")
        tree.write(stripped)
        mesh = meshio.read(stripped)
    mesh.field_data.update(strings["FieldData"])
    for name, values in strings["PointData"].items():
        mesh.point_data[name] = values
    sizes = np.cumsum([len(c.data) for c in mesh.cells])[:-1]
    for name, values in strings["CellData"].items():
        mesh.cell_data[name] = np.split(values, sizes)
    return mesh


def _read_strings(arr) -> np.ndarray:
    text = (arr.text or "").strip()
    if arr.get("format", "ascii") == "ascii":
        raw = bytes(int(c) for c in text.split())
    else:
        raw = base64.b64decode(text)[8:]  # our header: one UInt64 byte count
    return np.array([s.decode("utf-8") for s in raw.split(b"\0")[:-1]], dtype=str)
