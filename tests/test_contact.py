"""Contact between bodies (Xiao et al. 2012 section 2.2): the pair correction of
Hu et al. 2013 eqs 1-3, element-element slide lines against 1D theory, and
particle-element contact without interpenetration."""

import numpy as np
import pytest

import fsph
from fsph.simulation import _api
from fsph import verify

STEEL = "&material\n name = 'steel'\n library = 'steel_elastic_bar'\n/\n"


def two_bodies(write_deck, lower, upper, mode="fem", end_time=12.0e-6, extra=""):
    text = (f"&control\n title = 'two bodies'\n mode = '{mode}'\n end_time = {end_time}\n/\n"
            + STEEL + f"&body\n name = 'lower'\n material = 'steel'\n {lower}\n/\n"
            f"&body\n name = 'upper'\n material = 'steel'\n {upper}\n/\n"
            "&output\n n_snapshots = 2\n/\n" + extra)
    return fsph.Simulation.from_deck(write_deck(text))


def body_momentum_z(sim):
    """Axial momentum [kg m/s] of nodes and particles of each body, and
    the mean axial velocity of each body [m/s]."""
    snap = sim.snapshot()
    p = np.zeros(2)
    m = np.zeros(2)
    if "conn" in snap:
        for b in (0, 1):
            nodes = np.unique(snap["conn"][snap["body"] == b])
            p[b] += (snap["node_mass"][nodes] * snap["velocity"][nodes, 1]).sum()
            m[b] += snap["node_mass"][nodes].sum()
    if "particles" in snap:
        part = snap["particles"]
        for b in (0, 1):
            mine = part["body"] == b
            p[b] += (part["mass"][mine] * part["velocity"][mine, 1]).sum()
            m[b] += part["mass"][mine].sum()
    return p, p / np.where(m > 0, m, 1.0)


@pytest.mark.parametrize("weights", [(1.0, 0.0), (0.5, 0.5), (0.2, 0.8)])
def test_pair_correction_conserves_momentum_and_removes_penetration(weights):
    """Hu et al. 2013 eqs 1-3 for one pair: the momentum of slave and master nodes
    is unchanged, and the predicted penetration delta is removed exactly
    (the slave's displacement relative to the contact point grows by
    delta over the step)."""
    r1, r2 = weights
    rng = np.random.default_rng(7)
    for _ in range(20):
        ms, m1, m2 = rng.uniform(1e-6, 1e-3, 3)
        delta, dt = rng.uniform(1e-7, 1e-5), rng.uniform(1e-9, 1e-7)
        dvs, dv1, dv2 = verify.contact_pair(delta, dt, ms, m1, m2, r1, r2)
        assert ms * dvs + m1 * dv1 + m2 * dv2 == pytest.approx(0.0, abs=1e-14 * ms * abs(dvs))
        relative = dvs - (r1 * dv1 + r2 * dv2)
        assert relative * dt == pytest.approx(delta, rel=1e-12)


def test_equal_bars_exchange_velocities_through_a_slide_line(write_deck):
    """Two equal elastic bars, end-on, the upper at 20 m/s onto the lower at
    rest (element bodies, slide line): axial momentum conserved to
    round-off throughout; after the contact time 2L/c (3.9 us) the striker
    is nearly at rest and the target carries its velocity (1D theory: an
    exact exchange; the 2D bars keep a few per cent in radial ringing);
    the energy balance, with the work of the contact impulses, closes; the
    bars never interpenetrate."""
    v0 = 20.0
    geometry = "radius = 1.0e-3\n length = 10.0e-3\n n_radial = 4\n n_axial = 40"
    sim = two_bodies(write_deck, geometry,
                     geometry + f"\n z_base = 10.0e-3\n velocity_z = {-v0}")
    p0 = body_momentum_z(sim)[0].sum()
    deepest = 0.0
    for t in np.linspace(0.25e-6, 6.0e-6, 24):
        sim.advance(t)
        p = body_momentum_z(sim)[0].sum()
        assert p == pytest.approx(p0, rel=1e-12)
        deepest = max(deepest, sim.penetration()["relative"])
    _, v = body_momentum_z(sim)
    assert v[0] == pytest.approx(-v0, rel=0.05)       # target carries the velocity
    assert abs(v[1]) < 0.05 * v0                      # striker nearly at rest
    assert abs(sim.energies()["relative_error"]) < 0.01
    assert sim.contact()["dissipated_J"] < 0.01 * sim.initial_energy
    assert deepest < 0.01


PARTICLE_BLOCK = ("discretisation = 'particles'\n radius = 2.0e-3\n length = 6.0e-3\n"
                  " z_base = 2.0e-3\n n_radial = 10\n n_axial = 30\n velocity_z = -20.0")
ELEMENT_BASE = ("discretisation = 'elements'\n radius = 2.0e-3\n length = 2.0e-3\n"
                " n_radial = 8\n n_axial = 8")


@pytest.mark.parametrize("enabled", [True, False])
def test_particle_block_pressed_on_elements_does_not_penetrate(write_deck, enabled):
    """A 6 mm particle block driven at 20 m/s onto a 2 mm element block at
    rest (separate bodies, no gravity): while the longer block keeps them
    pressed together, no particle comes closer to the element surface
    than its radius by more than 1 % of the element size, and the axial
    momentum is conserved within 0.5 %, the bar of the perforation cases
    (the corrections conserve it pair by pair, see above; what remains,
    0.16 % at most here, is the axial reaction of the SPH axis ghosts of
    the compressed block, docs/method.md; without stress the block keeps
    its momentum exactly). Without contact the particles pass
    into the elements (the control case)."""
    extra = "" if enabled else "&contact\n enabled = .false.\n/\n"
    sim = two_bodies(write_deck, ELEMENT_BASE, PARTICLE_BLOCK, mode="fixed", end_time=4e-6,
                     extra=extra)
    p0 = body_momentum_z(sim)[0].sum()
    deepest, active = 0.0, 0
    for t in np.linspace(0.05e-6, 2.0e-6, 40):
        sim.advance(t)
        deepest = max(deepest, sim.penetration()["relative"])
        active = max(active, sim.contact()["n_active"])
        assert body_momentum_z(sim)[0].sum() == pytest.approx(p0, rel=5e-3)
    if enabled:
        assert active >= 10          # the whole face row of particles in contact
        assert deepest < 0.01
    else:
        assert deepest > 0.05


def test_a_hard_impact_of_element_bodies_keeps_its_energy(write_deck):
    """An elastic steel disc striking an aluminium one at 3 km/s (FEM, slide
    line; 20 x 10 cells each): the slide line stops the striker's face on
    the target's surface in one step, so the struck elements are
    compressed before any force has acted. With the step's artificial
    viscosity charged at the mean of the last step's q and this one's (as
    the pressure, trapezoidal) the energy stays within 0.5 % throughout
    and ends within 0.2 %: measured +0.22 % and +0.05 % with the step of
    the striking cycle bounded at the closing speed (+0.37 % and +0.18 %
    without that bound); charged at this step's q alone it made +0.82 %
    and +0.54 %."""
    deck = f"""
&control
 title = 'steel onto aluminium at 3 km/s'
 mode = 'fem'
 end_time = 1.0e-6
/
&material
 name = 'steel'
 library = 'steel_elastic_bar'
/
&material
 name = 'al'
 strength = 'elastic'
 eos = 'linear'
 density = 2700.0
 youngs_modulus = 69.0e9
 poisson_ratio = 0.33
/
&body
 name = 'flyer'
 material = 'steel'
 radius = 4.0e-3
 length = 2.0e-3
 n_radial = 20
 n_axial = 10
 velocity_z = -3000.0
/
&body
 name = 'plate'
 material = 'al'
 radius = 4.0e-3
 length = 2.0e-3
 z_base = -2.0e-3
 n_radial = 20
 n_axial = 10
/
"""
    sim = fsph.Simulation(fsph.deck.load(write_deck(deck)))
    largest = 0.0
    for t in np.linspace(0.02e-6, 1.0e-6, 50):
        sim.advance(t)
        largest = max(largest, abs(sim.energies()["relative_error"]))
    assert largest < 0.005
    assert abs(sim.energies()["relative_error"]) < 0.002
