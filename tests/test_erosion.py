"""Element erosion (the FEM baseline of Hu et al. 2013): a copper rod striking a
copper block at 500 m/s with a low strain limit, so that elements of both
bodies are deleted at the interface. What erosion takes out of the mesh is
booked, so mass, momentum and energy balances close; deleted elements never
come back; a restart across erosion events is bit for bit."""

import numpy as np
import pytest

import fsph
from fsph import checkpoint
from fsph.errors import DeckError
from fsph import verify

DECK = """
&control
 title = 'eroding copper rod on a copper block'
 mode = 'fem'
 end_time = 12.0e-6
/
&material
 name = 'copper'
 library = 'ofhc_copper'
/
&body
 name = 'rod'
 material = 'copper'
 radius = 2.0e-3
 length = 8.0e-3
 n_radial = 5
 n_axial = 20
 z_base = 0.05e-3
 velocity_z = -500.0
/
&body
 name = 'block'
 material = 'copper'
 radius = 6.0e-3
 length = 4.0e-3
 z_base = -4.0e-3
 n_radial = 15
 n_axial = 10
/
&erosion
 enabled = .true.
 principal_strain = {limit}
/
"""


def node_totals(sim):
    snap = sim.snapshot()
    return snap["node_mass"].sum(), snap["node_mass"] @ snap["velocity"][:, 1]


@pytest.fixture(scope="module")
def eroding(tmp_path_factory):
    path = tmp_path_factory.mktemp("erosion") / "erode.nml"
    path.write_text(DECK.format(limit=0.4))
    sim = fsph.Simulation.from_deck(path)
    mass0, momentum0 = node_totals(sim)
    n0 = sim.n_elements
    records = []
    for t in np.linspace(1e-6, 12e-6, 12):
        sim.advance(t)
        er = sim.erosion()
        mass, momentum = node_totals(sim)
        records.append({"er": er, "mass": mass, "momentum": momentum,
                        "energy": sim.energies(), "n": sim.n_elements})
    return {"sim": sim, "mass0": mass0, "momentum0": momentum0, "n0": n0,
            "records": records, "path": path}


def test_elements_are_deleted_and_counted(eroding):
    last = eroding["records"][-1]
    assert last["er"]["n_eroded"] > 10
    assert eroding["n0"] - last["n"] == last["er"]["n_eroded"]
    counts = [r["er"]["n_eroded"] for r in eroding["records"]]
    assert counts == sorted(counts)
    # nothing left at or beyond the limit after a cycle's deletion
    assert verify.principal_strains(eroding["sim"]).max() < 0.4 + 0.05


def test_mass_stays_on_nodes_or_is_booked(eroding):
    """Node mass + mass of the nodes removed = initial mass, to round-off;
    the deleted elements' mass is part of it (kept on their nodes)."""
    for r in eroding["records"]:
        assert r["mass"] + r["er"]["node_mass_kg"] == pytest.approx(eroding["mass0"], rel=1e-12)
    assert eroding["records"][-1]["er"]["element_mass_kg"] > 0.0


def test_momentum_with_the_removed_nodes_is_conserved(eroding):
    p0 = eroding["momentum0"]
    for r in eroding["records"]:
        assert r["momentum"] + r["er"]["momentum_kg_m_s"][1] == pytest.approx(p0, rel=1e-9)


def test_energy_balance_closes_with_the_eroded_energy(eroding):
    """Kinetic + internal + contact work + energy removed by erosion stays
    within 1 % of the initial energy; the removed energy is a real share
    (the balance without it would be off)."""
    for r in eroding["records"]:
        assert abs(r["energy"]["relative_error"]) < 0.01
    last = eroding["records"][-1]["energy"]
    assert last["eroded"] > 0.01 * eroding["sim"].initial_energy


def test_restart_across_erosion_is_bit_for_bit(tmp_path):
    path = tmp_path / "erode.nml"
    path.write_text(DECK.format(limit=0.4))
    sim = fsph.Simulation.from_deck(path)
    sim.advance(3e-6, land=False)
    before = sim.erosion()["n_eroded"]
    saved = checkpoint.save(sim, tmp_path / "ckpt.h5")
    sim.advance(6e-6, land=False)
    assert sim.erosion()["n_eroded"] > before
    reference = sim.snapshot()

    again = fsph.Simulation.from_deck(path)
    checkpoint.restore(again, saved)
    again.advance(6e-6, land=False)
    restarted = again.snapshot()
    for key in ("x", "velocity", "stress", "node_mass", "damage"):
        assert np.array_equal(reference[key], restarted[key]), key
    assert again.erosion() == sim.erosion()


def test_erosion_outside_mode_fem_is_a_deck_error(tmp_path):
    path = tmp_path / "bad.nml"
    path.write_text(DECK.format(limit=0.4).replace("mode = 'fem'", "mode = 'adaptive'"))
    with pytest.raises(DeckError) as err:
        fsph.Simulation.from_deck(path)
    text = str(err.value)
    assert "erosion" in text and "enabled" in text and "fem" in text
