"""Each body's books at every history record (fsph.h5 body_history/<name>):
kinetic and internal energy, axial momentum, the axial force on the body,
its plastic, viscous and hourglass work and the energy it received
through contact; perforation runs as an engineer reads them (the
projectile's deceleration force, what the plate received)."""

import h5py
import numpy as np
import pytest

from fsph.driver import run

from conftest import CASES


def plate_books(tmp_path_factory, deck_name, end_time):
    """Run a 508 m/s plate deck (its end time 200 us) to end_time [s] and
    read its summary, history, each body's books and their units, and for
    each body the times of the last snapshot before it has particles (-inf:
    none) and of the first in which it has (inf: none), as a user would
    (h5py)."""
    folder = tmp_path_factory.mktemp(deck_name)
    deck = folder / "plate.nml"
    text = (CASES / f"{deck_name}.nml").read_text()
    assert "end_time = 200.0e-6" in text
    deck.write_text(text.replace("end_time = 200.0e-6", f"end_time = {end_time!r}").replace(
        "references/", str(CASES / "references") + "/"))
    summary = run(deck, folder / "out", quiet=True)
    with h5py.File(folder / "out" / "fsph.h5") as h5:
        hist = {k: h5["history"][k][...] for k in h5["history"]}
        bodies = {b: {k: g[k][...] for k in g} for b, g in h5["body_history"].items()}
        units = {k: g.attrs["units"] for k, g in h5["body_history/projectile"].items()}
        names = list(summary["bodies"])                # in the deck's order, as the snapshots' ids
        with_particles = {name: [] for name in names}
        for snap in h5["snapshots"].values():
            has = np.unique(snap["particles/body"][...]) if "particles" in snap else []
            for b, name in enumerate(names):
                with_particles[name].append((snap.attrs["time"], b in has))
    particle_times = {}
    for name, rows in with_particles.items():
        first = min((t for t, has in rows if has), default=np.inf)
        particle_times[name] = (max((t for t, _ in rows if t < first), default=-np.inf), first)
    return summary, hist, bodies, units, particle_times


@pytest.fixture(scope="module")
def plate_run(tmp_path_factory):
    """The 508 m/s plate case to 30 us (adaptive: elements, converted
    particles, slide lines and particle contact between the bodies)."""
    return plate_books(tmp_path_factory, "al_plate_508", 30.0e-6)


def test_bodies_add_up_to_the_whole(plate_run):
    """The bodies' kinetic and internal energies sum to the run's at every
    record (to round-off), with their units."""
    summary, hist, bodies, units, _ = plate_run
    assert sorted(bodies) == ["plate", "projectile"]
    assert units == {"kinetic": "J", "internal": "J", "momentum_z": "N s", "plastic_work": "J",
                     "viscous_work": "J", "hourglass_work": "J", "contact_work": "J", "force_z": "N"}
    scale = hist["kinetic"][0]
    for key in ("kinetic", "internal"):
        total = sum(b[key] for b in bodies.values())
        assert np.abs(total - hist[key]).max() < 1e-12 * scale


def test_contact_forces_are_equal_and_opposite(plate_run):
    """Nothing but the other body acts on each (no plane, free plate): the
    plate gains the axial momentum the projectile loses, within 0.5 % of
    it, and the projectile's force (its deceleration force, positive
    against the -z flight) integrates to its momentum change over the
    times of the half-step velocities."""
    summary, hist, bodies, _, _ = plate_run
    rod, plate = bodies["projectile"], bodies["plate"]
    lost = rod["momentum_z"][-1] - rod["momentum_z"][0]
    gained = plate["momentum_z"][-1] - plate["momentum_z"][0]
    assert lost > 0.0 and gained < 0.0          # the rod flies in -z and is slowed
    assert abs(lost + gained) < 0.005 * lost
    t_velocity = hist["time"] - 0.5 * hist["dt"]
    assert np.sum(rod["force_z"][1:] * np.diff(t_velocity)) == pytest.approx(lost, rel=1e-9)
    books = summary["bodies"]["projectile"]
    assert books["momentum_z_N_s"] == pytest.approx(rod["momentum_z"][-1], rel=1e-12)
    assert books["peak_force_z_N"] == pytest.approx(np.abs(rod["force_z"]).max(), rel=1e-12)


@pytest.mark.parametrize("deck", ["taylor_armco_fem.nml", "taylor_armco.nml"])
def test_plastic_work_of_a_perfectly_plastic_rod(deck):
    """Elastic-perfectly-plastic Armco iron flows at Y0 = 0.6 GPa: the
    body's plastic work is the sum of Y0 d(eps_p)/rho over its points, so
    within the density's change (under 2 %) sum m Y0 eps_p / rho of the
    snapshot; it stays below the internal energy, which also holds the
    elastic and the viscous part (FEM and adaptive, to 20 us)."""
    import fsph
    from fsph.materials import LIBRARY
    y0 = LIBRARY["armco_iron"]["yield_stress"]
    sim = fsph.Simulation.from_deck(CASES / deck)
    sim.advance(20e-6)
    _, bodies = sim.drain_histories()
    work = bodies[-1, 0, 3]
    snap = sim.snapshot()
    estimate = np.sum(snap["element_mass"] * y0 * snap["plastic_strain"] / snap["density"])
    if "particles" in snap:
        part = snap["particles"]
        estimate += np.sum(part["mass"] * y0 * part["plastic_strain"] / part["density"])
    assert work == pytest.approx(estimate, rel=0.02)
    assert 0.5 * bodies[-1, 0, 1] < work < bodies[-1, 0, 1]


def test_contact_work_is_each_bodys_energy_change(plate_run):
    """The energy each body received through contact: summed over the
    bodies it is minus the kinetic energy the slide lines' corrections
    removed (the history's contact column) to round-off; the projectile
    (nothing but the plate acts on it) changes its kinetic and
    internal energy by its contact work within 0.1 % of it, the plate
    within 1 % (its particles' share of the run's energy error)."""
    _, hist, bodies, _, _ = plate_run
    work = {b: books["contact_work"] for b, books in bodies.items()}
    transferred = np.abs(work["projectile"]).max()
    assert transferred > 100.0                        # joules: the plate is being perforated
    total = work["projectile"] + work["plate"]
    assert np.allclose(total, -hist["contact"], rtol=0.0, atol=1e-9 * transferred)
    for body, tolerance in (("projectile", 1e-3), ("plate", 1e-2)):
        energy = bodies[body]["kinetic"] + bodies[body]["internal"]
        assert energy[-1] - energy[0] == pytest.approx(work[body][-1], rel=tolerance)


def test_viscous_and_hourglass_books(plate_run):
    """The elements' viscous work -q dv (q acts in compression; a step
    charges the mean of the q before and after it, so a step that expands
    right after a compression may give a little back) is positive and never
    falls below zero; the hourglass viscosity exists only in particles, so the
    projectile books none until its tip's first elements convert (about
    18 us) and the plate (converted particles from 2 us) some; each part
    is below the body's internal energy."""
    _, hist, bodies, _, particle_times = plate_run
    projectile, plate = bodies["projectile"], bodies["plate"]
    assert projectile["viscous_work"][-1] > 0.0
    assert projectile["viscous_work"].min() >= -1e-12 * projectile["viscous_work"][-1]
    elements_only = hist["time"] <= particle_times["projectile"][0]
    assert elements_only.sum() > 10
    assert np.all(projectile["hourglass_work"][elements_only] == 0.0)
    assert particle_times["plate"][1] < 5e-6
    assert plate["hourglass_work"][-1] != 0.0
    for books in (projectile, plate):
        for key in ("plastic_work", "viscous_work", "hourglass_work"):
            assert abs(books[key][-1]) < books["internal"][-1]


@pytest.fixture(scope="module")
def sph_plate_run(tmp_path_factory):
    """The pure SPH 508 m/s plate to 20 us: the bodies touch only through
    the Riemann particle contact."""
    _, hist, bodies, _, _ = plate_books(tmp_path_factory, "al_plate_508_sph", 20.0e-6)
    return hist, bodies


def test_particle_contact_transfers_energy_between_bodies(sph_plate_run):
    """The Riemann contact's pair forces are equal and opposite and work
    at one interface velocity: what one body receives the other gives
    (within 0.1 % of the transfer: the images across the axis have no
    partner), and each body's energy changes by what it received within
    1 % (no slide line: the contact column stays 0)."""
    hist, bodies = sph_plate_run
    work = {b: books["contact_work"][-1] for b, books in bodies.items()}
    transferred = abs(work["projectile"])
    assert transferred > 100.0
    assert np.all(hist["contact"] == 0.0)
    assert abs(work["projectile"] + work["plate"]) < 1e-3 * transferred
    for body, books in bodies.items():
        energy = books["kinetic"] + books["internal"]
        assert energy[-1] - energy[0] == pytest.approx(work[body], rel=1e-2)
