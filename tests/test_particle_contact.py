"""Contact between particle bodies by pairwise Riemann pressures
(fsph_particles riemann_contact_accelerations, docs/method.md): the 1D
impedance match of two elastic plates, momentum to round-off, no tension,
and the energy balance of a hard impact."""

import numpy as np
import pytest

import fsph
from fsph import deck as deck_module

#: Elastic aluminium (a plain linear material: only the impedance matters).
ALUMINIUM = """
&material
 name = 'aluminium'
 strength = 'elastic'
 eos = 'linear'
 density = 2700.0
 youngs_modulus = 69.0e9
 poisson_ratio = 0.33
/
"""


def two_plates(velocity, flyer_base=0.05e-3, contact="riemann", end_time=1.0e-6, radius=4.0e-3,
               flyer="steel", plate="aluminium", material_text=ALUMINIUM, n_across=40, inner_radius=0.0):
    """A steel flyer disc (2 mm thick) on an aluminium plate disc (2 mm),
    both of radius `radius` (tubes from inner_radius) on a 0.1 mm
    lattice, the flyer's face at flyer_base, moving at `velocity`
    (negative: towards the plate)."""
    return f"""
&control
 title = 'two plates'
 mode = 'sph'
 end_time = {end_time}
/
&material
 name = 'steel'
 library = 'steel_elastic_bar'
/
{material_text}
&body
 name = 'flyer'
 material = '{flyer}'
 radius = {radius}
 inner_radius = {inner_radius}
 length = 2.0e-3
 z_base = {flyer_base}
 n_radial = {n_across}
 n_axial = 20
 velocity_z = {velocity}
/
&body
 name = 'plate'
 material = '{plate}'
 radius = {radius}
 inner_radius = {inner_radius}
 length = 2.0e-3
 z_base = -1.95e-3
 n_radial = {n_across}
 n_axial = 20
/
&sph
 particle_contact = '{contact}'
/
&output
 n_snapshots = 2
 n_progress = 2
/
"""


def simulation(write_deck, text):
    return fsph.Simulation(deck_module.load(write_deck(text)))


def impedance(e, nu, rho):
    """Uniaxial-strain impedance rho c_L [kg/(m^2 s)] of an elastic solid."""
    k = e / (3.0 * (1.0 - 2.0 * nu))
    g = e / (2.0 * (1.0 + nu))
    return np.sqrt(rho * (k + 4.0 * g / 3.0))


#: Bar of the 1D impedance match [-]: the stress of one SPH body behind a
#: plane elastic wave is itself 2.2 % above 1D theory (the elastic bar in
#: docs/validation.md, held there to 5 %); the contact must not add to it.
STRESS_BAR = 0.03
#: Bar of the interface velocity and of the stress continuity [-].
MATCH_BAR = 0.02


def test_impedance_match_of_two_elastic_plates(write_deck):
    """Steel at 100 m/s onto aluminium: behind the two shocks, near the axis
    (before the release from the rim arrives), averaged over 0.2-0.3 us
    (the SPH wave's ringing), the particle velocity is the 1D impedance
    match u = Z_s v/(Z_s + Z_a) within 2 % in both plates, their axial
    stresses agree within 2 % (the contact carries the traction) and are
    sigma = Z_s Z_a v/(Z_s + Z_a) within 3 %."""
    v = 100.0
    sim = simulation(write_deck, two_plates(-v))
    z_s, z_a = impedance(206.0e9, 0.3, 7850.0), impedance(69.0e9, 0.33, 2700.0)
    sigma = z_s * z_a * v / (z_s + z_a)
    u = z_s * v / (z_s + z_a)
    stress = {0: [], 1: []}
    speed = {0: [], 1: []}
    for t in np.linspace(0.20e-6, 0.30e-6, 11):
        sim.advance(t)
        part = sim.snapshot()["particles"]
        r, z0 = part["x0"][:, 0], part["x0"][:, 1]
        # 0.15-1.05 mm from the interface (z = 0) on either side, within
        # 1.5 mm of the axis; the shocks have run 1.2-1.8 mm into each plate
        depth = np.where(part["body"] == 0, z0, -z0) - 0.05e-3
        for body in (0, 1):
            sel = (part["body"] == body) & (r < 1.5e-3) & (depth > 0.15e-3) & (depth < 1.05e-3)
            assert sel.sum() > 100
            stress[body].append(-part["stress"][sel, 1].mean())
            speed[body].append(-part["velocity"][sel, 1].mean())
    for body in (0, 1):
        assert np.mean(speed[body]) == pytest.approx(u, rel=MATCH_BAR), (body, np.mean(speed[body]), u)
        assert np.mean(stress[body]) == pytest.approx(sigma, rel=STRESS_BAR), (body, np.mean(stress[body]), sigma)
    assert np.mean(stress[0]) == pytest.approx(np.mean(stress[1]), rel=MATCH_BAR)


def test_contact_conserves_momentum_to_round_off(write_deck):
    """A hard impact of two tubes (steel on aluminium at 1 km/s): the pair
    forces are equal and opposite, so the axial momentum of the two bodies
    does not change (the radial momentum of rings is not a conserved
    quantity; away from the axis, since mirror images across it carry an
    axial reaction, as in the SPH sums)."""
    sim = simulation(write_deck, two_plates(-1000.0, n_across=20, radius=3.0e-3, inner_radius=1.0e-3))
    assert_momentum_kept_through_impact(sim)


def assert_momentum_kept_through_impact(sim, t=0.4e-6, speed=1000.0):
    """Advanced to t [s], the bodies' axial momentum is what it was to
    round-off (1e-12 of the total mass times the impact speed [m/s]), and
    the bodies met: the plate (body 1) moves at more than 200 m/s."""
    part = sim.snapshot()["particles"]
    m = part["mass"]
    p0 = np.sum(m * part["velocity"][:, 1])
    sim.advance(t)
    part = sim.snapshot()["particles"]
    p1 = np.sum(m * part["velocity"][:, 1])
    assert abs(p1 - p0) <= 1e-12 * np.sum(m) * speed
    assert part["velocity"][part["body"] == 1, 1].min() < -200.0


def test_bodies_that_separate_feel_no_contact(write_deck):
    """Two stress-free bodies touching (one spacing apart) and moving apart
    at 10 m/s: the contact pressure is clipped at zero (no adhesion), so
    the velocities change only by the round-off of the bodies' own SPH sums
    (an adhesive contact would pull them back by metres per second)."""
    sim = simulation(write_deck, two_plates(10.0, n_across=10, radius=1.0e-3))
    v0 = sim.snapshot()["particles"]["velocity"].copy()
    sim.advance(0.2e-6)
    v1 = sim.snapshot()["particles"]["velocity"]
    assert np.abs(v1 - v0).max() < 1e-9 * 10.0


def test_hard_impact_keeps_its_energy(write_deck):
    """Steel onto aluminium at 2 km/s, elastic (about 25 GPa at the
    interface): the energy balance holds within 0.5 % (the work of the
    contact pressures becomes heat of the two particles)."""
    sim = simulation(write_deck, two_plates(-2000.0, n_across=20, radius=2.0e-3))
    e0 = sim.energies()["total"]
    sim.advance(0.6e-6)
    energies = sim.energies()
    assert abs(energies["total"] - e0) <= 0.005 * e0
    assert energies["internal"] > 0.1 * e0


def test_riemann_pair_of_two_sides_without_sound_speed():
    """The contact pressure of two particles whose EOS gives no sound speed
    (molten and expanded: c = 0 on both sides) was 0/0, NaN, which stops a
    run. It is the limit of two equal impedances going to zero: p* the
    mean of the two normal pressures (never below 0), u* the mean of the
    two normal velocities; seen from j the same p* and -u*. With impedance
    on one side only it is the acoustic solution as before: p* the
    pressure of the side without impedance (3 GPa), u* finite."""
    import math
    from fsph import verify
    n = [0.0, 1.0]
    sig_i, sig_j = [0.0, -3.0e9, 0.0, 0.0], [0.0, -1.0e9, 0.0, 0.0]
    p_eq, p_star, u_star = verify.riemann_pair(n, [0.0, 50.0], 2700.0, 0.0, sig_i,
                                               [0.0, -30.0], 8930.0, 0.0, sig_j)
    assert (p_eq, p_star, u_star) == (2.0e9, 2.0e9, 10.0)
    back = verify.riemann_pair([0.0, -1.0], [0.0, -30.0], 8930.0, 0.0, sig_j, [0.0, 50.0], 2700.0, 0.0, sig_i)
    assert back == (p_eq, p_star, -u_star)
    # stretched on both sides: no pull
    assert verify.riemann_pair(n, [0.0, 0.0], 2700.0, 0.0, [0.0, 1e9, 0.0, 0.0],
                               [0.0, 0.0], 8930.0, 0.0, [0.0, 1e9, 0.0, 0.0])[1] == 0.0
    # one side with impedance: the acoustic formulas, finite
    z_j = 8930.0 * 3940.0
    p_eq, p_star, u_star = verify.riemann_pair(n, [0.0, 50.0], 2700.0, 0.0, sig_i,
                                               [0.0, -30.0], 8930.0, 3940.0, sig_j)
    assert p_eq == pytest.approx(3.0e9) and p_star == pytest.approx(3.0e9)
    assert u_star == pytest.approx(-30.0 + 2.0e9 / z_j) and math.isfinite(u_star)
