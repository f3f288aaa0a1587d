"""Neighbour lists kept across cycles (&sph neighbour_skin, fsph_verlet):
the lists are rebuilt far less often than every cycle, and a run is the
same bit for bit whatever the skin, 0 (rebuilt every cycle) included:
rows are in index order, the pairs of a cycle are those within the
support at its start, by the search's own test, and the skin's extra
pairs add exact zeros. Covers conversion (adaptive rod: imaginary
particles, ghosts, ties), two bodies in contact (pure SPH plate:
particle contact lists) and a debris cloud at 5.55 km/s, whose lists
expire within a step or two at the deck's skin so that the skin widens
(fsph_verlet adapt_skin)."""

import numpy as np
import pytest

import fsph
from fsph import deck as deck_module
from conftest import CASES


def run(deck_name, skin, cycles):
    deck = deck_module.load(CASES / deck_name)
    deck["sph"]["neighbour_skin"] = skin
    sim = fsph.Simulation(deck)
    sim.advance(1.0, max_cycles=cycles, partial=True)
    snap = sim.snapshot()
    state = {f"p_{k}": snap["particles"][k] for k in ("x", "velocity", "stress", "internal_energy")}
    if "x" in snap:
        state.update({k: snap[k] for k in ("x", "velocity", "stress")})
    return state, sim.list_rebuilds, sim.n_particles


@pytest.mark.parametrize("deck_name, cycles", [("taylor_armco.nml", 400), ("al_plate_508_sph.nml", 60),
                                               ("debris_cu_al_1.nml", 60)])
def test_results_do_not_depend_on_the_skin(deck_name, cycles):
    fresh, builds_fresh, n = run(deck_name, 0.0, cycles)
    # skin 0: a build every cycle that has particles
    assert n > 0 and cycles * 0.8 < builds_fresh <= cycles
    for skin in (0.1, 0.3):
        kept, builds, _ = run(deck_name, skin, cycles)
        assert builds < builds_fresh / 2, skin
        for key, value in fresh.items():
            assert np.array_equal(value, kept[key]), (skin, key)


def test_a_rod_in_free_flight_keeps_its_lists():
    """Without a plane normal to the axis the displacements are measured
    from the middle of their axial spread (fsph_verlet): a rod flying
    along the axis at 221 m/s (the Taylor rod without its anvil) keeps the
    lists of its first cycle, where measured from rest it rebuilt them
    every few cycles; and its state is that of lists rebuilt every cycle."""
    def flight(skin, cycles=150):
        deck = deck_module.load(CASES / "taylor_armco_sph.nml")
        deck["boundary"] = []
        deck["sph"]["neighbour_skin"] = skin
        sim = fsph.Simulation(deck)
        sim.advance(1.0, max_cycles=cycles, partial=True)
        snap = sim.snapshot()["particles"]
        return sim.list_rebuilds, snap
    builds, kept = flight(0.1)
    assert builds == 1
    builds_fresh, fresh = flight(0.0)
    assert builds_fresh == 150
    for key in ("x", "velocity", "stress", "internal_energy"):
        assert np.array_equal(kept[key], fresh[key]), key
