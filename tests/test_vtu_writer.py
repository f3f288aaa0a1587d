"""fsph.vtu, the .vtu writer of the snapshots, read back by VTK's own
reader (as ParaView reads) and by meshio: every cell type it writes, arrays
of every kind it is given, names that XML must quote."""

import meshio
import numpy as np
import pytest

from fsph import vtu

from conftest import read_vtu

pytest.importorskip("vtk")
from vtk.util.numpy_support import vtk_to_numpy  # noqa: E402


def arrays(data):
    return {data.GetArrayName(i): vtk_to_numpy(data.GetArray(i)) for i in range(data.GetNumberOfArrays())}


def sample_mesh(rng):
    """Two triangles and one wedge over six points, with point and cell
    arrays of the types the snapshots hold."""
    points = rng.random((6, 3))
    cells = [("triangle", np.array([[0, 1, 2], [1, 3, 2]])), ("wedge", np.array([[0, 1, 2, 3, 4, 5]]))]
    point_data = {"velocity [m/s]": rng.random((6, 3)), "id": np.arange(6, dtype=np.int32),
                  "failed": np.array([True, False, True, False, False, True]),
                  'odd "name" & <more>': rng.random(6)}
    cell_data = {"pressure [Pa]": [rng.random(2), rng.random(1)],
                 "material": [np.array([1, 2], dtype=np.int64), np.array([3], dtype=np.int64)]}
    return vtu.Mesh(points, cells, point_data=point_data, cell_data=cell_data)


def test_vtk_reads_what_was_written(tmp_path):
    mesh = sample_mesh(np.random.default_rng(3))
    path = tmp_path / "sample.vtu"
    size = vtu.write(path, mesh)
    assert size == path.stat().st_size
    grid = read_vtu(path)
    assert np.array_equal(vtk_to_numpy(grid.GetPoints().GetData()), mesh.points)
    assert [grid.GetCellType(i) for i in range(grid.GetNumberOfCells())] == [5, 5, 13]
    assert [[grid.GetCell(i).GetPointId(k) for k in range(grid.GetCell(i).GetNumberOfPoints())]
            for i in range(3)] == [[0, 1, 2], [1, 3, 2], [0, 1, 2, 3, 4, 5]]
    got = arrays(grid.GetPointData())
    assert set(got) == set(mesh.point_data)
    for name, values in mesh.point_data.items():
        assert np.array_equal(got[name], values), name
    got = arrays(grid.GetCellData())
    for name, per_block in mesh.cell_data.items():
        assert np.array_equal(got[name], np.concatenate(per_block)), name
    assert got["material"].dtype == np.int64


def test_meshio_reads_what_was_written(tmp_path):
    """meshio, which wrote these files before: the same points, cells and
    arrays (it gives a wedge in gmsh's node order, the first face's nodes
    1 and 2 swapped on both faces)."""
    mesh = sample_mesh(np.random.default_rng(4))
    vtu.write(tmp_path / "sample.vtu", mesh)
    back = meshio.read(tmp_path / "sample.vtu")
    assert np.array_equal(back.points, mesh.points)
    assert back.cells_dict["triangle"].tolist() == [[0, 1, 2], [1, 3, 2]]
    assert back.cells_dict["wedge"].tolist() == [[0, 2, 1, 3, 5, 4]]
    for name, values in mesh.point_data.items():
        assert np.array_equal(back.point_data[name], values), name
        assert back.point_data[name].shape == np.shape(values)


def test_an_unknown_cell_type_or_array_type_is_refused(tmp_path):
    with pytest.raises(ValueError, match="quad"):
        vtu.Mesh(np.zeros((4, 3)), [("quad", np.array([[0, 1, 2, 3]]))])
    mesh = vtu.Mesh(np.zeros((1, 3)), [("vertex", np.array([[0]]))],
                    point_data={"c": np.array([1 + 2j])})
    with pytest.raises(TypeError, match="complex"):
        vtu.write(tmp_path / "c.vtu", mesh)
