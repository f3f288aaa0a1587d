"""VTK XML unstructured-grid files (.vtu) of the snapshots, written here:
the XML header names every array and its offset, the arrays follow as raw
little-endian bytes in one appended block, each preceded by its length in
bytes (UInt64), as VTK's own writers make them (the "appended raw" form of
the VTK XML file formats). ParaView, VTK's readers and meshio read them.

Written before through meshio, whose binary form is base64 text inside
the XML: its import (about 0.13 s, the readers and writers of every format
it knows) and the encoding were a tenth of the output cost of the default
case (docs/performance.md, "Snapshot and checkpoint writes")."""

from xml.sax.saxutils import quoteattr

import numpy as np

#: VTK cell type ids of the cells fsph writes (VTK's vtkCellType.h): a
#: particle is a vertex, an element a triangle, a revolved element a
#: wedge (VTK's node order: one triangle, then the other).
CELL_TYPES = {"vertex": 1, "triangle": 5, "wedge": 13}

#: VTK's names of the array types written, by numpy type.
_ARRAY_TYPES = {
    np.dtype(np.float64): "Float64", np.dtype(np.float32): "Float32",
    np.dtype(np.int64): "Int64", np.dtype(np.int32): "Int32", np.dtype(np.int16): "Int16",
    np.dtype(np.int8): "Int8", np.dtype(np.uint64): "UInt64", np.dtype(np.uint32): "UInt32",
    np.dtype(np.uint16): "UInt16", np.dtype(np.uint8): "UInt8",
}


class CellBlock:
    """Cells of one type: `type` (a key of CELL_TYPES) and `data`, the
    point indices of each cell, (n_cells, points per cell)."""

    def __init__(self, cell_type, data):
        if cell_type not in CELL_TYPES:
            raise ValueError(f"cell type {cell_type!r}: one of {', '.join(CELL_TYPES)} expected")
        self.type = cell_type
        self.data = np.asarray(data)


class Mesh:
    """Points (n, 3) [m], cell blocks (CellBlock or (type, data) pairs),
    point arrays {name: (n,) or (n, k)} and cell arrays {name: [one array
    per block]}."""

    def __init__(self, points, cells, point_data=None, cell_data=None):
        self.points = np.asarray(points, dtype=float)
        self.cells = [c if isinstance(c, CellBlock) else CellBlock(*c) for c in cells]
        self.point_data = dict(point_data or {})
        self.cell_data = dict(cell_data or {})


def _little_endian(values):
    """values as a C-contiguous little-endian array of a type VTK names
    (booleans as UInt8)."""
    values = np.asarray(values)
    if values.dtype == np.bool_:
        values = values.astype(np.uint8)
    if values.dtype.newbyteorder("=") not in _ARRAY_TYPES:
        raise TypeError(f"no VTK array type for {values.dtype}")
    return np.ascontiguousarray(values, dtype=values.dtype.newbyteorder("<"))


class _Appended:
    """The appended block as it grows, and the XML element of each array."""

    def __init__(self):
        self.blocks = []
        self.offset = 0

    def array(self, name, values):
        """The XML element of one array (a 1-D array has one component, the
        default; an (n, k) one k), its bytes appended."""
        values = _little_endian(values)
        body = values.tobytes()
        components = "" if values.ndim == 1 else \
            f' NumberOfComponents="{int(np.prod(values.shape[1:]))}"'
        xml = (f'<DataArray type="{_ARRAY_TYPES[values.dtype.newbyteorder("=")]}" '
               f'Name={quoteattr(name)}{components} format="appended" offset="{self.offset}"/>')
        self.blocks += [np.uint64(len(body)).astype("<u8").tobytes(), body]
        self.offset += 8 + len(body)
        return xml


def _joined(per_block, dtype):
    """The arrays of the cell blocks end to end, of type dtype (empty
    without blocks)."""
    return np.concatenate([np.zeros(0, dtype)] + per_block).astype(dtype)


def write(path, mesh):
    """Write mesh (a Mesh) to path as a .vtu file; returns its size [B]."""
    appended = _Appended()
    connectivity = _joined([block.data.reshape(-1) for block in mesh.cells], np.int64)
    sizes = _joined([np.full(len(block.data), block.data.shape[1]) for block in mesh.cells], np.int64)
    types = _joined([np.full(len(block.data), CELL_TYPES[block.type]) for block in mesh.cells], np.uint8)
    lines = ['<?xml version="1.0"?>',
             '<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">',
             "<UnstructuredGrid>",
             f'<Piece NumberOfPoints="{len(mesh.points)}" NumberOfCells="{len(types)}">',
             "<Points>", appended.array("Points", mesh.points), "</Points>",
             "<Cells>",
             appended.array("connectivity", connectivity),
             appended.array("offsets", np.cumsum(sizes)),
             appended.array("types", types),
             "</Cells>"]
    if mesh.point_data:
        lines.append("<PointData>")
        lines += [appended.array(name, values) for name, values in mesh.point_data.items()]
        lines.append("</PointData>")
    if mesh.cell_data:
        lines.append("<CellData>")
        lines += [appended.array(name, np.concatenate([np.asarray(v) for v in per_block]))
                  for name, per_block in mesh.cell_data.items()]
        lines.append("</CellData>")
    lines += ["</Piece>", "</UnstructuredGrid>", '<AppendedData encoding="raw">']
    head = ("\n".join(lines) + "\n_").encode()
    tail = b"\n</AppendedData>\n</VTKFile>\n"
    with open(path, "wb") as f:
        f.write(head)
        f.writelines(appended.blocks)
        f.write(tail)
    return len(head) + appended.offset + len(tail)
