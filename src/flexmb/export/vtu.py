"""``.vtu`` files written by flexmb: VTK XML that meshio, VTK (pyvista) and ParaView read.

meshio's VTU writer drops field data (the times and the name tables), so
:func:`_write_mesh` writes the XML itself, with base64 binary arrays. The
files hold numbers only: meshio's reader stops at VTK string arrays
(``Illegal data type 'String'``), so names go into the field data as one
numeric entry per name (see :data:`flexmb.export.layout.NAME_TABLES`).
"""

from __future__ import annotations

import base64
import sys
from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np

from .._files import atomic_write
from ..errors import ExportError
from .layout import _VTK_CELLS

__all__: list[str] = []


_VTU_TYPES = {"f8": "Float64", "f4": "Float32", "i8": "Int64", "i4": "Int32", "i2": "Int16", "i1": "Int8",
              "u8": "UInt64", "u4": "UInt32", "u2": "UInt16", "u1": "UInt8"}


#: the point data a file names as its active vectors, the first present: what ParaView's Warp By Vector takes
_WARP = ("displacement", "elastic_displacement")


def _vtu_type(name, a: np.ndarray) -> str:
    key = f"{a.dtype.kind}{a.dtype.itemsize}"
    if key not in _VTU_TYPES:
        raise ExportError(f"cannot write the array {name!r} of type {a.dtype} to a .vtu file: flexmb's VTK "
                          f"files hold numbers only (meshio reads no string arrays)")
    return _VTU_TYPES[key]


def _binary(a: np.ndarray) -> str:
    """Inline binary data: base64 of a UInt64 byte count followed by the native-order bytes."""
    data = np.ascontiguousarray(a).tobytes()
    return base64.b64encode(np.uint64(len(data)).tobytes() + data).decode("ascii")


def _data_array(name, a, field=False) -> str:
    a = np.asarray(a)
    if a.dtype.kind == "b":
        a = a.astype(np.uint8)
    if field:  # field data in ASCII, exact (repr)
        a = a.ravel()
        kind = _vtu_type(name, a)
        text = " ".join(repr(float(v)) for v in a) if a.dtype.kind == "f" else " ".join(str(int(v)) for v in a)
        return (f'<DataArray type="{kind}" Name={quoteattr(str(name))} NumberOfTuples="{a.size}" '
                f'format="ascii">{text}</DataArray>\n')
    nc = f' NumberOfComponents="{a.shape[1]}"' if a.ndim == 2 else ""
    return (f'<DataArray type="{_vtu_type(name, a)}" Name={quoteattr(str(name))}{nc} format="binary">'
            f'{_binary(a)}</DataArray>\n')


def _cell_data_text(mesh, cache) -> str:
    """The CellData XML of a mesh; an array given as the same per-block arrays as before is taken from ``cache``."""
    parts = []
    for name, values in mesh.cell_data.items():
        hit = cache.get(("cell", name)) if cache is not None else None
        if hit is not None and len(hit[0]) == len(values) and all(a is b for a, b in zip(hit[0], values)):
            parts.append(hit[1])
            continue
        text = _data_array(name, np.concatenate([np.asarray(v) for v in values]))
        if cache is not None:
            cache[("cell", name)] = (list(values), text)
        parts.append(text)
    return "".join(["<CellData>\n", *parts, "</CellData>\n"])


def _cells_text(mesh) -> tuple[str, int]:
    """The Cells XML of a mesh, and its number of cells."""
    conn, offsets, types = [], [], []
    end = 0
    for block in mesh.cells:
        data = np.asarray(block.data, dtype=np.int64)
        conn.append(data.ravel())
        offsets.append(end + data.shape[1] * np.arange(1, len(data) + 1, dtype=np.int64))
        end += data.size
        vtk_type = _VTK_CELLS.get(block.type) or meshio._vtk_common.meshio_to_vtk_type[block.type]
        types.append(np.full(len(data), vtk_type, dtype=np.uint8))
    text = "".join([
        "<Cells>\n",
        _data_array("connectivity", np.concatenate(conn) if conn else np.zeros(0, dtype=np.int64)),
        _data_array("offsets", np.concatenate(offsets) if offsets else np.zeros(0, dtype=np.int64)),
        _data_array("types", np.concatenate(types) if types else np.zeros(0, dtype=np.uint8)),
        "</Cells>\n",
    ])
    return text, sum(len(b.data) for b in mesh.cells)


def _vtu_text(mesh) -> str:
    """The VTU XML of a meshio mesh: binary point and cell data, ASCII field data.

    The meshes of one export share their cells, the cell data that do not
    change, and name tables (and a ``_vtu_cache`` dict): their XML is made
    once.
    """
    byte_order = "LittleEndian" if sys.byteorder == "little" else "BigEndian"
    field = dict(mesh.field_data)
    cache = getattr(mesh, "_vtu_cache", None)
    hit = cache.get("cells") if cache is not None else None
    if hit and len(hit[0]) == len(mesh.cells) and all(a is b for a, b in zip(hit[0], mesh.cells)):
        cells, n_cells = hit[1:]
    else:
        cells, n_cells = _cells_text(mesh)
        if cache is not None:
            cache["cells"] = (list(mesh.cells), cells, n_cells)
    cells = _cell_data_text(mesh, cache) + cells

    def field_array(name, value):
        if cache is None:
            return _data_array(name, value, field=True)
        hit = cache.get(("field", name))
        if hit is None or hit[0] is not value:
            hit = cache[("field", name)] = (value, _data_array(name, value, field=True))
        return hit[1]

    points = np.asarray(mesh.points, dtype=float).reshape(-1, 3)
    warp = next((f' Vectors="{name}"' for name in _WARP if name in mesh.point_data), "")
    return "".join([
        '<?xml version="1.0"?>\n',
        f'<VTKFile type="UnstructuredGrid" version="1.0" byte_order="{byte_order}" header_type="UInt64">\n',
        "<UnstructuredGrid>\n<FieldData>\n",
        *(field_array(k, v) for k, v in field.items()),
        f'</FieldData>\n<Piece NumberOfPoints="{len(points)}" NumberOfCells="{n_cells}">\n<PointData{warp}>\n',
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
