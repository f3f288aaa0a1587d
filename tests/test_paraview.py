"""The ParaView entry points read with the vtk package, as ParaView reads
them: fsph.pvd's files open, hold the fields with their units, at the
snapshot times of fsph.h5; the revolved series (&output revolve_segments)
has the volume of the bodies it revolves."""

import re

import h5py
import numpy as np
import pytest

from fsph.driver import run

from conftest import read_vtu, rod_deck

vtk = pytest.importorskip("vtk")

SEGMENTS, ANGLE = 12, 270.0


@pytest.fixture(scope="module")
def revolved_rod(tmp_path_factory):
    """An adaptive Armco rod at 400 m/s onto the plane, 2 us, with the
    revolved series: elements turn into particles."""
    folder = tmp_path_factory.mktemp("paraview")
    deck = folder / "rod.nml"
    deck.write_text(rod_deck(control="mode = 'adaptive'\n end_time = 2e-6",
                             material="name = 'steel'\n library = 'armco_iron'",
                             body="velocity_z = -400.0\n n_radial = 6\n n_axial = 24",
                             output=f"revolve_segments = {SEGMENTS}\n revolve_angle = {ANGLE}")
                    .replace("n_snapshots = 2", "n_snapshots = 4") + "&convert\n theta_c = 40.0\n/\n")
    summary = run(deck, folder / "out", quiet=True)
    assert summary["n_converted"] > 0
    return folder / "out"


def collection(path):
    return [(float(t), int(p), f) for t, p, f in
            re.findall(r'timestep="([^"]+)" group="" part="(\d)" file="([^"]+)"', path.read_text())]


def test_series_opens_with_fields_at_the_snapshot_times(revolved_rod):
    with h5py.File(revolved_rod / "fsph.h5") as h5:
        times = sorted(h5["snapshots"][k].attrs["time"] for k in h5["snapshots"])
    entries = collection(revolved_rod / "fsph.pvd")
    assert sorted({t for t, _, _ in entries}) == pytest.approx(times, rel=1e-8)
    for t, part, name in entries:
        grid = read_vtu(revolved_rod / name)
        data = grid.GetCellData() if part == 0 else grid.GetPointData()
        names = {data.GetArrayName(i) for i in range(data.GetNumberOfArrays())}
        assert {"mises [Pa]", "pressure [Pa]", "plastic_strain", "damage", "id",
                "temperature [K]"} <= names
        assert "displacement [m]" in {grid.GetPointData().GetArrayName(i)
                                      for i in range(grid.GetPointData().GetNumberOfArrays())}
        assert grid.GetNumberOfCells() > 0
        assert grid.GetCellType(0) == (vtk.VTK_TRIANGLE if part == 0 else vtk.VTK_VERTEX)


def test_revolved_elements_have_the_bodys_volume(revolved_rod):
    """Pappus: a triangle of area A and centroid radius r swept through the
    angle a holds a A r; the wedges, flat between segments of angle d,
    hold sin(d)/d of it. The series lists the same times as fsph.pvd."""
    entries = collection(revolved_rod / "fsph_3d.pvd")
    assert [(t, p) for t, p, _ in entries] == [(t, p) for t, p, _ in collection(revolved_rod / "fsph.pvd")]
    t, _, name = [e for e in entries if e[1] == 0][-1]
    grid = read_vtu(revolved_rod / name)
    assert grid.GetCellType(0) == vtk.VTK_WEDGE
    sizes = vtk.vtkCellSizeFilter()
    sizes.SetInputData(grid)
    sizes.Update()
    volume = sizes.GetOutput().GetCellData().GetArray("Volume")
    volumes = np.array([volume.GetValue(i) for i in range(volume.GetNumberOfTuples())])
    assert volumes.min() > 0.0                    # wedges oriented as VTK wants
    with h5py.File(revolved_rod / "fsph.h5") as h5:
        last = h5["snapshots"][sorted(h5["snapshots"])[-1]]
        x, conn = last["nodes"][...], last["connectivity"][...]
    corners = x[conn]
    a, b = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    area = 0.5 * np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
    step = np.radians(ANGLE) / SEGMENTS
    pappus = np.radians(ANGLE) * np.sum(area * corners[:, :, 0].mean(axis=1))
    assert volumes.sum() == pytest.approx(pappus * np.sin(step) / step, rel=2e-3)
