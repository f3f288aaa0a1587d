"""Runs are instances: several fsph.Simulation objects in one process
advance independently, and the reference runs end in the same state, bit
for bit, as before the solver's state became an instance (the stored
digests)."""

import gc

import pytest

import fsph
from fsph import deck as deck_module
from fsph.checkpoint import state_digest

from conftest import CASES, rod_deck

# Digest (fsph.checkpoint.state_digest) of the final state of each reference
# run, advanced to its end time in one call, measured with the release build
# (gfortran -O3) before the refactor that made the state an instance. The
# state does not depend on the thread count. A change meant to alter the
# results must re-measure the validations and update these with it. The
# material history grew by two rows (failed, melted: zero in these runs).
# Re-measured 2026-11-26 after the mirror images' frame-independent heat
# the Riemann contact between particle bodies and the elements'
# trapezoidal viscous work (docs/validation.md). The books grew by one
# scalar (the rigid planes' impulse, a diagnostic): without it the three
# states hash to the digests before (1e9b4a1f..., 2a045a7c..., 543c8e8c...);
# then by one array (the elements' persistent ids): without it they hash to
# 6335044f..., dac93c0c..., 38358ffd...; then by one material history row
# (plastic work): without it they hash to 0ad13e8d..., b93e4429..., 22fbae00...;
# then by three rows (viscous, hourglass and contact work): without them they hash
# to 32d3d3c1..., c50fc352..., 4b7065f7.... Re-measured 2026-11-26 after the
# particles' axis and anvil backstops moved to their radius and each body's
# axial resultant of the axis images was removed (docs/validation.md):
# before, 53be78ad..., 8f153020..., ec35eeaa.... Re-measured 2026-11-27 after
# the mirror images across the anvil took their particle's compression
# switch (the other two have no such images: unchanged); before,
# taylor_armco 31ed9818.... The particles' ids (kept since particles are
# renumbered in spatial order, from 4 096 of them after a conversion) enter
# the digest only once they differ from the particles' numbers: none of
# these runs renumbers, and their digests are those before the ids.
#
# The plate and concrete runs call the host's math library (pow, log and exp
# of the Johnson-Cook and HJC models), whose last bits depend on the code
# path it picks for the processor: glibc chooses among FMA, AVX and SSE2
# variants of exp, log and pow by the CPU's features. These two runs
# therefore have one state per host kind, all from the same source. The
# digests, in order: the Intel Xeon hosts where they were first stored; an
# AMD EPYC guest with AVX2 and FMA but no AVX-512 (2026-11-27: the same plate
# state as the Xeon's, another concrete state, for a cause not pinned down);
# that guest with glibc held to its SSE2 paths
# (GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2,-FMA,-FMA4,-AVX), which changes both.
# The Taylor rod (elastic-perfectly-plastic Armco) is the same on all. A
# host with yet another state fails here; its digest is added only once the
# code at the stored one is shown to give it there.
REFERENCE_DIGESTS = {
    "taylor_armco": ("2da700f26a7fb1357d105f9c95a067f997aa54e70e00e0094451bc293f40709a",),
    "al_plate_508": ("b0f8fc1c0f89bb5a656f9d69af65e901c8eed250061557c7b021fce652eb2cdd",
                     "8f9d604300c715b9fc94611c20fd2eba617d5e8a22a7e8a2445334b5e58cbf22"),
    "concrete_1058": ("a4de5c91b218811e85af360fae03631623b2214da8acd3ee622962d7ad474e35",
                      "7142ad813c181afed69e8448dc23175f7d412406aa9e387e1814018acb3cb405",
                      "ab9b54b1d2b58b95ec42216036a7131d669dd8ea5ff76a9fad08316b93f41c0f"),
}


@pytest.mark.parametrize("case", sorted(REFERENCE_DIGESTS))
def test_reference_run_ends_in_the_stored_state(case):
    deck = deck_module.load(CASES / f"{case}.nml")
    sim = fsph.Simulation(deck)
    sim.advance(deck["control"]["end_time"])
    assert state_digest(sim) in REFERENCE_DIGESTS[case]


def small_decks(write_deck):
    """Two different small runs: an elastic element rod on a plane, and a
    particle rod striking it faster."""
    elements = write_deck(rod_deck(control="end_time = 4.0e-6"), "elements.nml")
    particles = write_deck(rod_deck(control="end_time = 4.0e-6\n mode = 'sph'",
                                    body="velocity_z = -120.0"), "particles.nml")
    return [deck_module.load(elements), deck_module.load(particles)]


STEPS = 8


def run_alone(deck):
    """Digest and sizes of a run advanced alone, in STEPS calls (landing
    on each call's end shapes the trajectory, so both sides use them)."""
    sim = fsph.Simulation(deck)
    for step in range(1, STEPS + 1):
        sim.advance(deck["control"]["end_time"] * step / STEPS)
    return state_digest(sim), sim.n_elements, sim.n_particles


def test_interleaved_runs_match_each_run_alone(write_deck):
    """Two runs built one after the other and advanced in alternation end
    in the state each reaches alone, bit for bit."""
    decks = small_decks(write_deck)
    alone = [run_alone(deck) for deck in decks]
    sims = [fsph.Simulation(deck) for deck in decks]
    for step in range(1, STEPS + 1):
        for sim, deck in zip(sims, decks):
            sim.advance(deck["control"]["end_time"] * step / STEPS)
    together = [(state_digest(sim), sim.n_elements, sim.n_particles) for sim in sims]
    assert together == alone
    assert alone[0][1] > 0 and alone[1][2] > 0      # the runs differ in kind


def test_a_new_run_leaves_a_live_one_alone(write_deck):
    """Building, advancing and freeing a second run changes nothing in the
    first: its mesh, clock and energy balance stay its own."""
    first_deck, second_deck = small_decks(write_deck)
    first = fsph.Simulation(first_deck)
    end = first_deck["control"]["end_time"]
    first.advance(end / STEPS)
    before = (state_digest(first), first.n_elements, first.time, first.energies()["relative_error"])
    second = fsph.Simulation(second_deck)
    second.advance(2.0e-6)
    assert (state_digest(first), first.n_elements, first.time,
            first.energies()["relative_error"]) == before
    del second
    gc.collect()
    assert state_digest(first) == before[0]
    for step in range(2, STEPS + 1):
        first.advance(end * step / STEPS)
    assert state_digest(first) == run_alone(first_deck)[0]


def test_snapshots_change_no_state(write_deck):
    """A snapshot reads the run and writes nothing back (particle radii and
    the contact search grid included): the digest is the same before and
    after one, and runs that take a snapshot after every call end in the
    state they reach without any."""
    for deck in small_decks(write_deck):
        sim = fsph.Simulation(deck)
        for step in range(1, STEPS + 1):
            sim.advance(deck["control"]["end_time"] * step / STEPS)
            before = state_digest(sim)
            snap = sim.snapshot()
            sim.penetration()
            assert state_digest(sim) == before
        assert snap["cycle"] == sim.cycle
        assert state_digest(sim) == run_alone(deck)[0]
