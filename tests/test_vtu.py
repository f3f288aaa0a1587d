"""The ParaView files as a user reads them (meshio): one .pvd series with
elements as part 0 and particles as part 1 only where there are
particles; the von Mises stress, the displacement and persistent ids
beside the fields."""

import re

import meshio
import numpy as np
import pytest

from fsph.driver import run
from fsph.materials import LIBRARY

from conftest import rod_deck


@pytest.fixture(scope="module")
def adaptive_rod(tmp_path_factory):
    """An elastic-perfectly-plastic Armco rod at 400 m/s onto the plane,
    adaptive, 2 us: its elements yield and turn into particles, which are
    renumbered in spatial order from 20 of them."""
    folder = tmp_path_factory.mktemp("vtu")
    deck = folder / "rod.nml"
    deck.write_text(rod_deck(control="mode = 'adaptive'\n end_time = 2e-6",
                             material="name = 'steel'\n library = 'armco_iron'",
                             body="velocity_z = -400.0\n n_radial = 6\n n_axial = 24")
                    .replace("n_snapshots = 2", "n_snapshots = 4") + "&convert\n theta_c = 40.0\n/\n"
                    + "&sph\n spatial_order_min = 20\n/\n")
    summary = run(deck, folder / "out", quiet=True)
    assert summary["n_converted"] > 0
    return folder / "out"


def pvd_entries(out):
    text = (out / "fsph.pvd").read_text()
    return [(float(t), int(p), f) for t, p, f in
            re.findall(r'timestep="([^"]+)" group="" part="(\d)" file="([^"]+)"', text)]


def test_one_series_with_particles_only_where_they_are(adaptive_rod):
    """fsph.pvd alone: elements (part 0) at every time step, particles
    (part 1) only at the time steps that have them, so none at t = 0."""
    entries = pvd_entries(adaptive_rod)
    assert not (adaptive_rod / "fsph_particles.pvd").exists()
    times = sorted({t for t, _, _ in entries})
    assert len(times) == 5
    assert [p for t, p, _ in entries if t == 0.0] == [0]
    assert all(p in (0, 1) for _, p, _ in entries) and any(p == 1 for _, p, _ in entries)
    for _, part, name in entries:
        mesh = meshio.read(adaptive_rod / name)
        assert len(mesh.points) > 0
        assert ("triangle" if part == 0 else "vertex") in mesh.cells_dict


def test_mises_at_most_the_yield_stress_and_displacement(adaptive_rod):
    """Elastic-perfectly-plastic: the von Mises stress of every element and
    particle is at most Y0 (the pressure and the viscous q removed) and
    reaches it where the rod flows; the displacement is x - x0, zero at
    t = 0."""
    y0 = LIBRARY["armco_iron"]["yield_stress"]
    entries = pvd_entries(adaptive_rod)
    last_time = max(t for t, _, _ in entries)
    for t, part, name in entries:
        mesh = meshio.read(adaptive_rod / name)
        mises = mesh.cell_data["mises [Pa]"][0] if part == 0 else mesh.point_data["mises [Pa]"]
        assert mises.max() <= y0 * (1.0 + 1e-9)
        if t == last_time:
            assert mises.max() >= 0.999 * y0
        displacement = mesh.point_data["displacement [m]"]
        if t == 0.0:
            assert np.all(displacement == 0.0)
        else:
            assert np.abs(displacement[:, 1]).max() > 0.0


def test_ids_follow_elements_and_particles(adaptive_rod):
    """An element keeps its id (its index at t = 0) when others turn into
    particles: the initial positions of its nodes, which travel with the
    material, are those of that id at t = 0; a particle's id is its number
    as it was made, which it keeps when the particles are renumbered in
    spatial order: the initial position of each id does not change between
    snapshots."""
    import h5py
    with h5py.File(adaptive_rod / "fsph.h5") as h5:
        snaps = [h5["snapshots"][k] for k in sorted(h5["snapshots"])]
        first, last = snaps[0], snaps[-1]
        centroid0 = first["nodes_initial"][...][first["connectivity"][...]].mean(axis=1)
        ids = last["id"][...]
        centroid = last["nodes_initial"][...][last["connectivity"][...]].mean(axis=1)
        assert list(first["id"][...]) == list(range(len(centroid0)))
        assert len(ids) < len(centroid0) and len(set(ids)) == len(ids)
        assert np.array_equal(centroid, centroid0[ids])
        particles = [s["particles"] for s in snaps if "particles" in s]
        assert len(particles) >= 2
        a, b = particles[0], particles[-1]
        id_a, id_b = a["id"][...], b["id"][...]
        assert sorted(id_a) == list(range(len(id_a))) and sorted(id_b) == list(range(len(id_b)))
        assert len(id_b) > len(id_a) and list(id_b) != list(range(len(id_b)))   # renumbered
        x0_of_id = b["x0"][...][np.argsort(id_b)]
        assert np.array_equal(x0_of_id[id_a], a["x0"][...])
    mesh = meshio.read(adaptive_rod / f"vtu/elements_{len(snaps) - 1:05d}.vtu")
    assert np.array_equal(mesh.cell_data["id"][0], ids)


def test_every_dataset_of_fsph_h5_has_its_unit(adaptive_rod):
    """Every history and snapshot dataset of fsph.h5 carries `units`; the
    body and material fields name what they index; the file says SI."""
    import h5py
    missing = []
    with h5py.File(adaptive_rod / "fsph.h5") as h5:
        assert h5.attrs["units"].startswith("SI")
        assert list(h5.attrs["body_names"]) == ["rod"]
        assert list(h5.attrs["material_names"]) == ["steel"]

        def visit(name, item):
            if isinstance(item, h5py.Dataset) and name != "deck" and "units" not in item.attrs:
                missing.append(name)
        h5.visititems(visit)
        last = h5["snapshots"][sorted(h5["snapshots"])[-1]]
        assert list(last["particles/body"].attrs["names"]) == ["rod"]
        assert last["stress"].attrs["units"] == "Pa"
    assert missing == []


def test_element_snapshots_carry_the_failed_and_melted_flags(tmp_path):
    """Elements have the failed and melted flags of their material point,
    as particles do: in fsph.h5 and in the .vtu cell data alike. An Armco
    rod at 400 m/s in mode fem (no conversion: the elements stay), with
    Johnson-Cook failure at a plastic strain of 0.3 and a melting
    temperature of 300 K on the temperature of the internal energy: some
    elements fail and some melt, others neither, and summary.json counts
    a failed and a molten mass."""
    import h5py
    deck = tmp_path / "rod.nml"
    deck.write_text(rod_deck(control="mode = 'fem'\n end_time = 2e-6",
                             material="name = 'steel'\n library = 'armco_iron_jc'\n"
                                      " melt_temperature = 300.0\n temperature = 'internal_energy'\n"
                                      " jc_d1 = 0.3\n jc_d2 = 0.0\n jc_d3 = 0.0\n jc_d4 = 0.0\n"
                                      " jc_d5 = 0.0",
                             body="velocity_z = -400.0\n n_radial = 6\n n_axial = 24"))
    summary = run(deck, tmp_path / "out", quiet=True)
    assert summary["status"] == "completed" and summary["n_particles"] == 0
    with h5py.File(tmp_path / "out" / "fsph.h5") as h5:
        last_key = sorted(h5["snapshots"])[-1]
        last = h5["snapshots"][last_key]
        flags = {name: last[name][...] for name in ("failed", "melted")}
        assert all(last[name].attrs["units"] == "-" for name in flags)
    mesh = meshio.read(tmp_path / "out" / f"vtu/elements_{last_key}.vtu")
    state = summary["material_state"]["rod"]
    for name, flag in flags.items():
        assert set(np.unique(flag)) == {0.0, 1.0}, name       # some flagged, not all
        assert np.array_equal(mesh.cell_data[name][0], flag), name
        assert state[f"{name}_mass_kg"] > 0.0, name
