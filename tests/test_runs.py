"""Runs are instances: several fsph.Simulation objects in one process
advance independently, and the reference runs end in the same state, bit
for bit, as before the solver's state became an instance (the stored
digests)."""

import gc
import json
import os
import subprocess
import sys

import fsph
from fsph import deck as deck_module
from fsph.checkpoint import state_digest

from conftest import CASES, REFERENCE_DIGESTS, rod_deck


def test_reference_run_ends_in_the_stored_state():
    """The default case advanced to its end in one call ends in the stored
    state, as its run through the driver (outputs at every snapshot) does
    (tests/test_taylor_adaptive.py). The plate and the concrete slab are
    checked on the runs of their validations (tests/test_perforation.py,
    tests/test_concrete.py), through the digest in their summaries."""
    deck = deck_module.load(CASES / "taylor_armco.nml")
    sim = fsph.Simulation(deck)
    sim.advance(deck["control"]["end_time"])
    assert state_digest(sim) in REFERENCE_DIGESTS["taylor_armco"]


#: The reference decks, and a debris deck and the sphere deck for the
#: set-up they do not have (the Mie-Grueneisen isentrope tables, a graded
#: plate of particles, the sphere's arcs and graded layers).
SET_UP_CASES = tuple(REFERENCE_DIGESTS) + ("debris_cu_al_1", "sphere_al_bumper")

#: The initial state's digest of each deck of SET_UP_CASES, printed as JSON
#: by a child interpreter.
SET_UP_DIGESTS = f"""
import json
import fsph
from fsph import deck as deck_module
from fsph.checkpoint import state_digest
print(json.dumps({{name: state_digest(fsph.Simulation(deck_module.load({str(CASES)!r} + f"/{{name}}.nml")))
                  for name in {SET_UP_CASES!r}}}))
"""


def test_set_up_does_not_depend_on_numpy_vector_paths(tmp_path):
    """The reference decks, a debris deck and the sphere deck start in the
    same state when numpy is held to its baseline instruction set
    (NPY_ENABLE_CPU_FEATURES) as with the host's vector units: numpy's
    vector paths of some functions
    round differently from the C library's (np.arcsin on a host with
    AVX-512 changed the ogive's outline in its last bits, and with it the
    concrete run's final state: a digest of its own on such hosts). A
    host whose numpy has no other paths passes trivially."""
    try:
        from numpy._core._multiarray_umath import __cpu_baseline__ as baseline
    except ImportError:                      # numpy < 2
        from numpy.core._multiarray_umath import __cpu_baseline__ as baseline
    states = []
    for features in (None, " ".join(baseline)):
        env = {key: value for key, value in os.environ.items() if key != "NPY_ENABLE_CPU_FEATURES"}
        if features:
            env["NPY_ENABLE_CPU_FEATURES"] = features
        # run outside the checkout: its fsph/ has no compiled core
        child = subprocess.run([sys.executable, "-c", SET_UP_DIGESTS], env=env, cwd=tmp_path,
                               capture_output=True, text=True, check=True)
        states.append(json.loads(child.stdout.splitlines()[-1]))
    assert states[0] == states[1]


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
