"""The Python API refuses what the command line refuses: a deck given as a
dict is validated as a deck file is (so is a loaded deck changed since),
and advance() takes only finite times >= 0."""

import copy
import math

import pytest

import fsph
from fsph import deck as deck_module
from fsph.checkpoint import state_digest
from fsph.errors import DeckError, FsphError, SimulationError
from conftest import CASES

ROD = {
    "control": {"title": "rod", "end_time": 1.0e-6},
    "material": {"name": "steel", "library": "steel_elastic_bar"},
    "body": [{"name": "rod", "material": "steel", "radius": 1.0e-3, "length": 4.0e-3,
              "n_radial": 3, "n_axial": 12, "velocity_z": -50.0}],
    "boundary": {"type": "rigid_plane", "point": (0.0, 0.0), "normal": (0.0, 1.0)},
}


def test_from_dict_runs_like_the_deck_file(write_deck):
    """The same rod from a dict and from a file: the same state after a few
    cycles, bit for bit."""
    text = ("&control title='rod' end_time=1.0e-6 /\n&material name='steel' library='steel_elastic_bar' /\n"
            "&body name='rod' material='steel' radius=1.0e-3 length=4.0e-3 n_radial=3 n_axial=12 "
            "velocity_z=-50.0 /\n&boundary type='rigid_plane' point=0.0,0.0 normal=0.0,1.0 /\n")
    a, b = fsph.Simulation.from_dict(ROD), fsph.Simulation.from_deck(write_deck(text))
    for sim in (a, b):
        sim.advance(0.5e-6)
    assert a.cycle == b.cycle > 0
    assert (a.snapshot()["x"] == b.snapshot()["x"]).all()


@pytest.mark.parametrize("group, key, value, fragment", [
    ("material", "density", 0.0, "&material #1 key 'density': expected a value in (0, inf)"),
    ("body", "n_axial", "many", "&body #1 key 'n_axial': expected an integer"),
    ("body", "colour", "red", "&body #1 key 'colour'"),
    ("control", "end_time", math.nan, "&control key 'end_time': expected a finite real number"),
])
def test_from_dict_is_validated(group, key, value, fragment):
    groups = copy.deepcopy(ROD)
    target = groups[group][0] if isinstance(groups[group], list) else groups[group]
    target[key] = value
    with pytest.raises(DeckError) as err:
        fsph.Simulation.from_dict(groups, name="mine")
    assert str(err.value).startswith("mine: ") and fragment in str(err.value), str(err.value)


def test_a_changed_deck_is_validated_again():
    """A loaded deck changed by a script: a valid change is taken, an
    invalid one refused as in a file."""
    deck = deck_module.load(CASES / "taylor_armco.nml")
    deck["body"][0]["velocity_z"] = -180.0
    assert fsph.Simulation(deck).deck["body"][0]["velocity_z"] == -180.0
    deck["material"][0]["density"] = 0.0
    with pytest.raises(DeckError, match=r"taylor_armco.nml: &material #1 key 'density'"):
        fsph.Simulation(deck)


@pytest.mark.parametrize("t", [math.nan, math.inf, -1.0e-6, "soon", None, True, "2e-6"])
def test_advance_refuses_bad_times(t):
    """Not a number of seconds >= 0: refused (a bool was taken as 1 s, a
    string that reads as a number as that number)."""
    sim = fsph.Simulation.from_dict(ROD)
    with pytest.raises(FsphError, match="advance: expected a"):
        sim.advance(t)
    assert sim.cycle == 0


def test_advance_lands_on_land_on_and_refuses_one_before_t():
    """land_on: the stops on the way keep the stable step, the last steps
    land on it; the run's steps are those of one call to land_on."""
    one = fsph.Simulation.from_dict(ROD)
    one.advance(1.0e-6)
    parts = fsph.Simulation.from_dict(ROD)
    for k in range(1, 40):
        parts.advance(k * 0.0251e-6, land=False, land_on=1.0e-6)
    parts.advance(1.0e-6, land=False, land_on=1.0e-6)
    assert parts.time == 1.0e-6 and parts.cycle == one.cycle
    assert state_digest(parts) == state_digest(one)
    with pytest.raises(FsphError, match="land_on"):
        parts.advance(2.0e-6, land=False, land_on=1.5e-6)


def test_advance_after_a_failure_is_refused():
    """After a SimulationError the state is the failed cycle's: a further
    advance is refused, not run on it."""
    sim = fsph.Simulation.from_dict(ROD)
    sim.control["max_cycles"] = 3
    with pytest.raises(SimulationError):
        sim.advance(1.0e-6)
    cycle = sim.cycle
    with pytest.raises(FsphError, match="the run failed"):
        sim.advance(2.0e-6)
    assert sim.cycle == cycle


@pytest.mark.parametrize("max_cycles", [-3, 2.5, "10", True])
def test_advance_refuses_bad_cycle_limits(max_cycles):
    """A cycle limit that is not a whole number >= 0 is refused, not
    clamped or truncated."""
    sim = fsph.Simulation.from_dict(ROD)
    with pytest.raises(FsphError, match="advance: expected max_cycles an integer >= 0"):
        sim.advance(1.0e-6, max_cycles=max_cycles, partial=True)
    assert sim.cycle == 0


def test_import_leaves_meshio_and_scipy_to_their_first_use(tmp_path):
    """`import fsph` loads neither meshio (the VTU files) nor SciPy (the
    metrics, the materials' integrals): a script or a command that does
    not use them does not pay for them."""
    import subprocess
    import sys
    code = "import sys, fsph; print(sorted(m for m in ('meshio', 'scipy') if m in sys.modules))"
    # run outside the checkout, so that the installed package is imported
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=tmp_path)
    assert out.stdout.strip() == "[]"



def test_radius0_is_a_property_of_the_initial_configuration():
    """A snapshot's radius0: the set-up particles' radius at t = 0, and for
    a particle converted from an element the particle radius (half the
    square root of m / (2 pi r rho)) at its initial position x0 and the
    material's reference density: the same at every snapshot (it was the
    present radius). The formula gives the set-up particles' own radii."""
    import numpy as np

    def by_id(part, key):
        return part[key][np.argsort(part["id"])]

    deck = deck_module.load(CASES / "taylor_armco.nml")
    deck["body"][0].update(n_radial=5, n_axial=34)
    sim = fsph.Simulation(deck)
    sim.advance(20e-6)
    first = sim.snapshot()["particles"]
    sim.advance(30e-6)
    later = sim.snapshot()["particles"]
    n = len(first["id"])
    assert n > 20 and np.array_equal(np.sort(first["id"]), np.sort(later["id"])[:n])
    np.testing.assert_array_equal(by_id(first, "radius0"), by_id(later, "radius0")[:n])
    assert not np.allclose(first["radius"], first["radius0"], rtol=1e-3)
    rho0 = deck["material"][0]["density"]
    np.testing.assert_allclose(first["radius0"], 0.5 * np.sqrt(
        first["mass"] / (2 * np.pi * first["x0"][:, 0] * rho0)), rtol=1e-12)

    lattice = copy.deepcopy(ROD)
    lattice["control"]["mode"] = "sph"
    part = fsph.Simulation.from_dict(lattice).snapshot()["particles"]
    np.testing.assert_allclose(part["radius0"], 0.5 * np.sqrt(
        part["mass"] / (2 * np.pi * part["x0"][:, 0] * part["density"])), rtol=1e-12)
