"""SPH phase: kernel identities, SPH gradients, conservation of the sums,
axis ghosts and particle contact, through the API."""

import numpy as np
import pytest

import fsph
from fsph import deck as deck_module
from fsph.simulation import kernel
from fsph.verify import kernel_gradient_factor
from fsph import verify
from conftest import rod_deck


def particle_deck(body="", control="", boundary=False, extra=""):
    return rod_deck(control="mode = 'sph'\n " + control, body=body, boundary=boundary) + extra


@pytest.fixture
def rod(write_deck):
    """A particle rod 1 mm x 4 mm, 10 x 40 lattice (spacing 0.1 mm), free."""
    path = write_deck(particle_deck(body="n_radial = 10\n n_axial = 40"))
    return fsph.Simulation(deck_module.load(path))


# ---- kernel ---------------------------------------------------------------
def test_kernel_value_at_zero():
    h = 0.3e-3
    w, _ = kernel([0.0], h)
    assert w[0] == pytest.approx(10.0 / (7.0 * np.pi * h * h), rel=1e-14)


def test_kernel_normalisation_and_support():
    """The integral of W over the plane is 1 (2D normalisation); W and
    dW/dr vanish at and beyond 2h."""
    h = 0.25e-3
    r = np.linspace(0.0, 2.0 * h, 200_001)
    w, _ = kernel(r, h)
    integral = np.trapezoid(w * 2.0 * np.pi * r, r)
    assert integral == pytest.approx(1.0, abs=1e-8)
    w_out, dw_out = kernel([2.0 * h, 2.5 * h], h)
    assert np.all(w_out == 0.0) and np.all(dw_out == 0.0)


def test_kernel_gradient_matches_finite_difference():
    h = 0.2e-3
    r = np.linspace(0.01 * h, 1.99 * h, 97)
    step = 1e-7 * h
    _, dw = kernel(r, h)
    wp_, _ = kernel(r + step, h)
    wm_, _ = kernel(r - step, h)
    fd = (wp_ - wm_) / (2.0 * step)
    assert np.allclose(dw, fd, rtol=1e-6, atol=1e-9 * np.abs(dw).max())


def test_kernel_gradient_factor_is_derivative_over_distance():
    """The factor the pair sums use, F = (dW/dr)/r, times r is dW/dr on
    both branches of the spline, and zero beyond the support."""
    h = 0.2e-3
    r = np.linspace(0.01 * h, 2.4 * h, 239)
    _, dw = kernel(r, h)
    factor = kernel_gradient_factor(r, h)
    assert np.allclose(factor * r, dw, rtol=1e-13, atol=1e-12 * np.abs(dw).max())
    assert np.all(factor[r >= 2.0 * h] == 0.0)


# ---- neighbours -----------------------------------------------------------
def brute_force_pairs(x, h, i, skin=0.0):
    """Real neighbours (+j) and mirror images (-j), 1-based, within
    2 h_ij + skin of particle i, by an all-pairs check."""
    reach = h[i] + h + skin
    d_real = np.linalg.norm(x[i] - x, axis=1)
    d_ghost = np.linalg.norm(x[i] - x * [-1.0, 1.0], axis=1)
    real = {j + 1 for j in np.nonzero(d_real < reach)[0] if j != i}
    return real | {-(j + 1) for j in np.nonzero(d_ghost < reach)[0]}


def test_neighbour_lists_match_brute_force(rod):
    """The cell-list search lists every pair (and axis mirror) within
    2 h_ij that an all-pairs check finds, and none beyond 2 h_ij plus the
    skin (&sph neighbour_skin times the smallest 2h)."""
    verify.particle_rates(rod)                     # builds the lists
    ptr, lst = verify.neighbours(rod)
    part = rod.snapshot()["particles"]
    x, h = part["x"], part["h"]
    skin = rod.deck["sph"]["neighbour_skin"] * 2.0 * h.min()
    assert skin > 0.0
    for i in range(0, len(x), 7):
        got = set(lst[ptr[i] - 1:ptr[i + 1] - 1].tolist())
        assert brute_force_pairs(x, h, i) <= got <= brute_force_pairs(x, h, i, skin), i


def jittered_rod(write_deck, seed, smoothing_lengths):
    """The 10 x 40 particle rod (spacing 0.1 mm) with lists without a skin
    (exact), its particles moved by up to a fifth of a spacing and given the
    smoothing lengths smoothing_lengths(rng, n) [m]. Returns the simulation,
    positions and smoothing lengths."""
    from fsph.simulation import _api
    path = write_deck(particle_deck(body="n_radial = 10\n n_axial = 40",
                                    extra="&sph\n neighbour_skin = 0.0\n/\n"))
    rod = fsph.Simulation(deck_module.load(path))
    part = rod.snapshot()["particles"]
    rng = np.random.default_rng(seed)
    spacing = 0.1e-3
    x = part["x"] + rng.uniform(-0.2, 0.2, part["x"].shape) * spacing
    x[:, 0] = np.maximum(x[:, 0], 0.2 * spacing)
    h = smoothing_lengths(rng, len(x))
    ierr = _api.set_particles(rod._run, np.asfortranarray(x.T), np.zeros((2, len(x)), order="F"),
                              part["mass"], h, (part["material"] + 1).astype(np.int32),
                              (part["body"] + 1).astype(np.int32))
    assert ierr == 0
    assert _api.initialise(rod._run)[0] == 0
    return rod, x, h


def assert_lists_exact(rod, x, h, label):
    ptr, lst = verify.neighbours(rod)
    for i in range(len(x)):
        entries = lst[ptr[i] - 1:ptr[i + 1] - 1].tolist()
        assert len(entries) == len(set(entries)), (label, i)
        assert set(entries) == brute_force_pairs(x, h, i), (label, i)


def test_neighbour_lists_of_any_length_match_brute_force(write_deck):
    """Lists from 10 to 80 entries: a jittered lattice with smoothing lengths
    from 1.2 to 3 spacings. Every count the search's row buffers can meet
    (below, at and above their width, which then grows) gives exactly the
    pairs an all-pairs check finds, with no duplicates, and every pair's
    bookkeeping (the entry its partner reads) consistent."""
    from fsph.simulation import _api
    rod, x, h = jittered_rod(write_deck, 7, lambda rng, n: rng.uniform(1.2, 3.0, n) * 0.1e-3)
    verify.particle_rates(rod)
    counts = np.diff(verify.neighbours(rod)[0])
    assert counts.min() < 32 < counts.max()
    # buffer rows (half, low and one-way parts of the lists) of every width
    # from narrower than most parts (rows overflow and grow) to as wide as
    # the longest (full rows)
    for width in range(4, counts.max() + 2):
        verify.set_neighbour_width(rod, width)
        verify.particle_rates(rod)
        assert_lists_exact(rod, x, h, width)


def test_neighbour_lists_across_size_levels_match_brute_force(write_deck):
    """Particles whose smoothing lengths span a factor 16 (several of the
    search's size levels, each with its own cell grid, as on a graded
    plate): every list is exactly what an all-pairs check finds, mirror
    images across the axis included."""
    rod, x, h = jittered_rod(write_deck, 11,
                             lambda rng, n: 0.1e-3 * np.exp(rng.uniform(np.log(0.5), np.log(8.0), n)))
    verify.particle_rates(rod)
    assert_lists_exact(rod, x, h, "levels")


# ---- SPH gradients ----------------------------------------------------------
def set_particle_velocity(sim, v):
    """Rebuild the particle state with velocities v (n, 2) [m/s]."""
    from fsph.simulation import _api
    part = sim.snapshot()["particles"]
    ierr = _api.set_particles(sim._run, np.asfortranarray(part["x"].T), np.asfortranarray(np.asarray(v).T),
                              part["mass"], part["h"], (part["material"] + 1).astype(np.int32),
                              (part["body"] + 1).astype(np.int32))
    assert ierr == 0
    ierr, _ = _api.initialise(sim._run)
    assert ierr == 0


def test_linear_velocity_gradient_exact_in_interior(rod):
    """The corrected SPH velocity gradient differentiates a linear field
    exactly away from the axis (where the mirror images are not the linear
    extension)."""
    part = rod.snapshot()["particles"]
    x = part["x"]
    a, c, e, b = 300.0, -150.0, 80.0, 500.0
    v = np.column_stack([2.0 + a * x[:, 0] + c * x[:, 1], -1.0 + e * x[:, 0] + b * x[:, 1]])
    set_particle_velocity(rod, v)
    rates = verify.particle_rates(rod)
    d = rates["d"]
    interior = x[:, 0] > 2.0 * part["h"].max()
    assert interior.sum() > 100
    scale = 500.0
    assert np.allclose(d[interior, 0], a, atol=1e-9 * scale)
    assert np.allclose(d[interior, 1], b, atol=1e-9 * scale)
    assert np.allclose(d[interior, 2], 0.5 * (c + e), atol=1e-9 * scale)
    assert np.allclose(rates["spin"][interior], 0.5 * (c - e), atol=1e-9 * scale)


def test_expanding_ring_with_axis_ghosts(rod):
    """Uniform radial expansion v_r = a r plus axial stretch v_z = b z: every
    particle, those next to the axis included (mirror ghosts), gets
    d_rr = d_tt = a, d_zz = b; the density rate is -rho (2a + b) in the
    interior."""
    part = rod.snapshot()["particles"]
    x = part["x"]
    a, b = 400.0, -250.0
    set_particle_velocity(rod, np.column_stack([a * x[:, 0], b * x[:, 1]]))
    rates = verify.particle_rates(rod)
    d = rates["d"]
    assert np.allclose(d[:, 3], a, rtol=1e-12)
    near_axis = x[:, 0] < 2.0 * part["h"].max()
    assert near_axis.sum() >= 40
    assert np.allclose(d[:, 0], a, rtol=1e-9)
    assert np.allclose(d[:, 1], b, rtol=1e-9)
    assert np.allclose(d[:, 2], 0.0, atol=1e-9 * a)
    inner = (x[:, 0] < 0.7e-3) & (x[:, 1] > 0.5e-3) & (x[:, 1] < 3.5e-3)
    rho = rod.snapshot()["particles"]["density"]
    assert np.allclose(rates["drho"][inner], -rho[inner] * (2 * a + b), rtol=0.02)


# ---- conservation -------------------------------------------------------------
def test_axial_momentum_of_sums_conserved(write_deck):
    """A closed system (a free tube, away from the axis) with a random
    velocity field and the stresses it builds: the SPH accelerations carry no
    net axial force (round-off), and the axial momentum stays constant over a
    run. (Next to the axis the mirror particles carry the axis reaction; its
    axial part vanishes only as h -> 0, see test_axis_axial_force_is_small.)"""
    path = write_deck(particle_deck(body="inner_radius = 2.0e-3\n radius = 3.0e-3\n"
                                         " n_radial = 8\n n_axial = 24", control="end_time = 2e-7"))
    sim = fsph.Simulation(deck_module.load(path))
    part = sim.snapshot()["particles"]
    rng = np.random.default_rng(7)
    v = rng.normal(0.0, 20.0, part["x"].shape)
    set_particle_velocity(sim, v)
    m = part["mass"]
    p0 = np.sum(m * v[:, 1])
    sim.advance(2e-7)
    rates = verify.particle_rates(sim)
    force = m * rates["acc"][:, 1]
    assert abs(force.sum()) < 1e-12 * np.abs(force).sum()
    p1 = np.sum(m * sim.snapshot()["particles"]["velocity"][:, 1])
    assert abs(p1 - p0) < 1e-12 * np.sum(m * np.abs(v[:, 1]))


def test_axis_axial_force_is_small(write_deck):
    """A solid rod: the mirror images carry the reaction of the axis. Its
    axial part is a discretisation error (sigma_rz is odd in r, so the exact
    flux through the axis is zero); measured after a random kick it stays
    below 2 % of the gross axial force."""
    path = write_deck(particle_deck(body="n_radial = 8\n n_axial = 24", control="end_time = 2e-7"))
    sim = fsph.Simulation(deck_module.load(path))
    part = sim.snapshot()["particles"]
    rng = np.random.default_rng(7)
    set_particle_velocity(sim, rng.normal(0.0, 20.0, part["x"].shape))
    sim.advance(2e-7)
    force = part["mass"] * verify.particle_rates(sim)["acc"][:, 1]
    assert abs(force.sum()) < 0.02 * np.abs(force).sum()


def test_axis_resultant_is_removed_fragment_by_fragment(rod):
    """The images across the axis give the particles next to it an axial
    resultant that no load balances (fsph_sph axis_resultant); it is
    removed from each fragment, a connected set of particles of a body.
    A cluster of nine particles on the axis moved 1 mm away from its rod
    (as a plate's plug broke away) and both under a uniform shear stress
    sigma_rz, which the odd images turn into an axial force at the axis:
    the cluster's net axial force and the rod's are each zero to
    round-off. Removed over the whole body instead, the cluster kept its
    images' resultant less its share of the body's and sped up in flight."""
    part = rod.snapshot()["particles"]
    x, m = part["x"].copy(), part["mass"]
    cluster = (x[:, 0] < 0.3e-3) & (x[:, 1] > 3.7e-3)
    assert cluster.sum() == 9
    x[cluster, 1] += 1.0e-3
    verify.set_particle_motion(rod, x, np.zeros_like(x))
    verify.set_stress_state(rod, [0.0, 0.0, 100.0e6, 0.0], 0.0)
    force = m * verify.particle_rates(rod)["acc"][:, 1]
    for part_of in (cluster, ~cluster):
        gross = np.abs(force[part_of]).sum()
        assert gross > 0.0
        assert abs(force[part_of].sum()) < 1e-12 * gross


def test_energy_conserved_in_free_collision(write_deck):
    """Two halves of a free rod driven into each other at 2 x 50 m/s: total
    energy (kinetic + internal) constant within 1 % over 2 us."""
    path = write_deck(particle_deck(body="n_radial = 10\n n_axial = 40", control="end_time = 2e-6"))
    sim = fsph.Simulation(deck_module.load(path))
    x = sim.snapshot()["particles"]["x"]
    v = np.zeros_like(x)
    v[:, 1] = np.where(x[:, 1] < 2e-3, 50.0, -50.0)
    set_particle_velocity(sim, v)
    m = sim.snapshot()["particles"]["mass"]
    e0 = 0.5 * np.sum(m * v[:, 1] ** 2)
    sim.advance(2e-6)
    assert abs(sim.energies()["total"] - e0) / e0 < 0.01


# ---- particle contact -------------------------------------------------------
TWO_TUBES = """
&body
 name = 'upper'
 material = 'steel'
 inner_radius = 1.0e-3
 radius = 2.0e-3
 length = 2.0e-3
 z_base = 4.05e-3
 n_radial = 10
 n_axial = 20
 velocity_z = -100.0
/
"""


def test_particle_bodies_collide_without_interpenetration(write_deck):
    """Two elastic particle tubes collide end-on at 2 x 100 m/s (penalty
    contact, no SPH sums across bodies): axial momentum is conserved to
    round-off and no particle of one body passes into the other."""
    deck = particle_deck(body="inner_radius = 1.0e-3\n radius = 2.0e-3\n n_radial = 10\n"
                              " n_axial = 40\n velocity_z = 100.0",
                         control="end_time = 1.2e-6", extra=TWO_TUBES)
    sim = fsph.Simulation(deck_module.load(write_deck(deck)))
    part = sim.snapshot()["particles"]
    m, body = part["mass"], part["body"]
    p0 = np.sum(m * part["velocity"][:, 1])
    for k in range(1, 13):
        sim.advance(k * 1e-7)
        part = sim.snapshot()["particles"]
        z, rad = part["x"][:, 1], part["radius"]
        top_lower = (z + rad)[body == 0].max()
        bottom_upper = (z - rad)[body == 1].min()
        spacing = 0.1e-3
        assert bottom_upper - top_lower > -0.25 * spacing, (k, top_lower, bottom_upper)
    p1 = np.sum(m * part["velocity"][:, 1])
    assert abs(p1 - p0) < 1e-10 * np.sum(m * 100.0)
    # the bodies have met: both carry compressive axial stress at the contact
    assert part["stress"][:, 1].min() < -0.5e9


def test_particle_on_the_axis_is_refused(rod):
    """No particle may sit at r <= 0: set-up reports the particle (status 10
    with its index, negative for particles)."""
    from fsph.simulation import _api
    part = rod.snapshot()["particles"]
    x = part["x"].copy()
    x[5, 0] = 0.0
    ierr = _api.set_particles(rod._run, np.asfortranarray(x.T), np.asfortranarray(part["velocity"].T),
                              part["mass"], part["h"], (part["material"] + 1).astype(np.int32),
                              (part["body"] + 1).astype(np.int32))
    assert ierr == 0
    ierr, ifault = _api.initialise(rod._run)
    assert ierr == 10 and ifault == -6


# ---- the axis, the hourglass term and the anvil's mirror images ---------------
def test_particle_moving_off_the_axis_keeps_its_density(rod):
    """A particle of the first column (r = spacing/2) moving out from a
    lattice at rest carries its ring mass into a region of larger planar
    density: with the planar-density continuity its density changes by
    little (measured +0.11 of the hoop rate rho v/r), where the hoop term
    alone would rarefy it at the full rate."""
    part = rod.snapshot()["particles"]
    x = part["x"]
    i = int(np.argmin(np.hypot(x[:, 0] - 0.05e-3, x[:, 1] - 2.05e-3)))
    v = np.zeros_like(x)
    v[i, 0] = 1.0
    set_particle_velocity(rod, v)
    rate = verify.particle_rates(rod)["drho"][i]
    hoop = part["density"][i] * 1.0 / x[i, 0]
    assert abs(rate) < 0.2 * hoop


def rod_with_hourglass(write_deck, coefficient):
    return fsph.Simulation(deck_module.load(write_deck(particle_deck(
        body="n_radial = 10\n n_axial = 40", extra=f"&sph\n hourglass = {coefficient}\n/\n"),
        name=f"hg{coefficient}.nml")))


def test_hourglass_term_vanishes_for_a_linear_velocity_field(write_deck):
    """The hourglass viscosity acts on the velocity difference the
    particles' gradients do not explain: for a linear field away from the
    axis the accelerations are those without it."""
    accs = []
    for coefficient in (0.0, 0.2):
        sim = rod_with_hourglass(write_deck, coefficient)
        x = sim.snapshot()["particles"]["x"]
        v = np.column_stack([2.0 + 300.0 * x[:, 0] - 150.0 * x[:, 1], -1.0 + 80.0 * x[:, 0] + 500.0 * x[:, 1]])
        set_particle_velocity(sim, v)
        accs.append(verify.particle_rates(sim)["acc"])
    # away from the axis (whose mirror images are not the linear extension
    # of a field with v_r != 0 at r = 0); the corrected gradient is exact
    # for a linear field at the free surfaces too
    interior = x[:, 0] > 4.0 * 1.3 * 0.1e-3
    assert interior.sum() > 100
    # round-off of an acceleration of order c |v| / h (that of a mismatch as
    # large as the velocities themselves)
    scale = 5000.0 * np.abs(v).max() / (1.3 * 0.1e-3)
    assert np.allclose(accs[1][interior], accs[0][interior], atol=1e-12 * scale)


def test_hourglass_term_resists_columns_sliding_past_each_other(write_deck):
    """Alternate lattice columns moving axially in opposite directions (a
    mode the collocated gradient does not see): the hourglass term
    decelerates every interior particle against its motion."""
    accs = []
    for coefficient in (0.0, 0.2):
        sim = rod_with_hourglass(write_deck, coefficient)
        x = sim.snapshot()["particles"]["x"]
        column = np.rint(x[:, 0] / 0.1e-3 - 0.5).astype(int)
        v = np.column_stack([np.zeros(len(x)), np.where(column % 2 == 0, 1.0, -1.0)])
        set_particle_velocity(sim, v)
        accs.append(verify.particle_rates(sim)["acc"])
    interior = (column > 2) & (column < 7) & (x[:, 1] > 0.5e-3) & (x[:, 1] < 3.5e-3)
    extra = accs[1][interior, 1] - accs[0][interior, 1]
    assert np.all(extra * v[interior, 1] < 0.0)


def test_elastic_rod_rebounds_from_the_anvil(write_deck):
    """An elastic particle rod (10 x 40 lattice) strikes the anvil at 50 m/s:
    the mirror images across the anvil act as the wall, so the energy
    balance holds within 1 % throughout (measured within 0.85 %; a
    kinematic wall alone stops every face particle dead), the rod rebounds
    (its mean axial velocity upwards, measured 43 m/s: the rest is left in
    the rod's vibration) and leaves the anvil: the wall does not hold it in
    tension."""
    path = write_deck(rod_deck(control="mode = 'sph'\n end_time = 3e-6",
                               body="n_radial = 10\n n_axial = 40"))
    sim = fsph.Simulation(deck_module.load(path))
    gaps = []
    for k in range(1, 13):
        sim.advance(k * 0.25e-6)
        assert abs(sim.energies()["relative_error"]) < 0.01
        part = sim.snapshot()["particles"]
        gaps.append((part["x"][:, 1] - part["radius"]).min())
    m = part["mass"]
    assert (m * part["velocity"][:, 1]).sum() / m.sum() > 0.8 * 50.0
    assert gaps[-1] > 0.0 and gaps[-1] > gaps[-3]


def _tube_on_anvil(write_deck, receding):
    """A tube of particles (r = 2-3 mm, 8 x 24 lattice, no axis images)
    standing on the anvil, moved off the lattice, under a small uniform
    compression (0.03 GPa), moving at random and towards the anvil, or
    with every other particle moving away from it (receding): the images
    of the approaching ones act with their particle's whole mass, those
    of the receding ones with about a fifth of it (fsph_mirror). Returns
    the kinetic power and heating of every particle, m a.v and m de."""
    path = write_deck(particle_deck(body="inner_radius = 2.0e-3\n radius = 3.0e-3\n n_radial = 8\n n_axial = 24",
                                    boundary=True), name=f"tube_on_anvil{int(receding)}.nml")
    sim = fsph.Simulation(deck_module.load(path))
    part = sim.snapshot()["particles"]
    rng = np.random.default_rng(5)
    spacing = 0.125e-3
    x = part["x"] + rng.uniform(-0.1, 0.1, part["x"].shape) * spacing
    v = rng.normal(0.0, 5.0, x.shape)
    if receding:
        v[:, 1] += np.where(np.arange(len(v)) % 2 == 0, -10.0, 10.0)
        first_row = x[:, 1] < 0.17e-3                  # 24 rows over 4 mm
        assert (v[first_row, 1] < 0.0).sum() >= 2 and (v[first_row, 1] > 0.0).sum() >= 2
    else:
        v[:, 1] = -np.abs(v[:, 1]) - 1.0
    verify.set_particle_motion(sim, x, v)
    verify.set_stress_state(sim, [0.0, 0.0, 0.0, 0.0], 0.03e9)
    rates = verify.particle_rates(sim)
    m = part["mass"]
    return m * np.sum(rates["acc"] * v, axis=1), m * rates["de"]


def test_images_at_a_plane_make_no_energy(write_deck):
    """Every particle approaching the anvil, so every image weighs its
    particle's mass: the pairs (i, j') and (j, i') are mirror twins, the
    particles' own-stress shares add up to their forces' work, and the
    kinetic power sum m a.v and the heating sum m de cancel to round-off,
    as in a body without a wall (the plane takes the reaction and does
    not move)."""
    power, heat = _tube_on_anvil(write_deck, receding=False)
    assert abs(power.sum() + heat.sum()) < 1e-11 * np.abs(power).sum()


@pytest.mark.xfail(strict=True, reason=(
    "measured 8.5e-4 of the power sum: where a particle leaving the anvil meets one pressing on it, "
    "i takes j's image at j's weight and j takes i's at i's, the pairs are no longer mirror twins and "
    "the own-stress shares do not add up to the forces' work (docs/method.md, 'The axis and the anvil', "
    "still open; +0.26 % of the default Taylor rod's energy by 6 us)"))
def test_images_of_unequal_weight_make_no_energy(write_deck):
    """Every other particle leaving the anvil: the kinetic power sum and
    the heating sum cancel to round-off as with equal weights."""
    power, heat = _tube_on_anvil(write_deck, receding=True)
    assert abs(power.sum() + heat.sum()) < 1e-11 * np.abs(power).sum()


# ---- artificial stress --------------------------------------------------------
def disordered_tube(write_deck, eps, deviator, pressure, seed=11):
    """A free tube (r = 2-3 mm, 8 x 24 lattice, no axis images, no plane)
    whose particles are moved off the lattice by up to 0.15 spacings, with
    random velocities and a uniform stress; &sph artificial_stress = eps.
    Returns the run, the masses and velocities."""
    path = write_deck(particle_deck(body="inner_radius = 2.0e-3\n radius = 3.0e-3\n n_radial = 8\n n_axial = 24",
                                    boundary=False, extra=f"&sph\n artificial_stress = {eps}\n/\n"),
                      name=f"tube{eps}.nml")
    sim = fsph.Simulation(deck_module.load(path))
    part = sim.snapshot()["particles"]
    rng = np.random.default_rng(seed)
    spacing = 0.125e-3
    x = part["x"] + rng.uniform(-0.15, 0.15, part["x"].shape) * spacing
    v = rng.normal(0.0, 20.0, x.shape)
    verify.set_particle_motion(sim, x, v)
    verify.set_stress_state(sim, deviator, pressure)
    return sim, part["mass"], v


def test_artificial_stress_work_is_charged_in_the_energy_equation(write_deck):
    """A free, disordered tube in tension (principal stresses 1.2 and 0.8 GPa
    in the plane) moving at random: the artificial stress changes the
    accelerations, and the energy equation charges exactly its work: the
    kinetic power sum m a.v and the heating sum m de cancel to round-off
    with it as without it."""
    accs = {}
    for eps in (0.0, 0.3):
        sim, m, v = disordered_tube(write_deck, eps, [0.1e9, -0.1e9, 0.15e9, 0.0], -1.0e9)
        rates = verify.particle_rates(sim)
        power = m * np.sum(rates["acc"] * v, axis=1)
        heat = m * rates["de"]
        assert abs(power.sum() + heat.sum()) < 1e-11 * np.abs(power).sum(), eps
        accs[eps] = rates["acc"]
    change = np.abs(accs[0.3] - accs[0.0]).max()
    assert change > 0.05 * np.abs(accs[0.0]).max()


def test_artificial_stress_leaves_compression_alone(write_deck):
    """All principal stresses compressive (the hoop one included): the
    accelerations and heating are those without the artificial stress, to
    the bit."""
    rates = []
    for eps in (0.0, 0.3):
        sim, _, _ = disordered_tube(write_deck, eps, [0.1e9, -0.1e9, 0.15e9, 0.0], 1.0e9)
        rates.append(verify.particle_rates(sim))
    for key in ("acc", "de"):
        assert np.array_equal(rates[0][key], rates[1][key]), key


def test_artificial_stress_pushes_a_closing_pair_in_tension_apart(write_deck):
    """Uniform hydrostatic tension of 1 GPa in the rod of particles (10 x 40
    lattice), two interior particles moved to a fifth of the spacing apart
    along r: without the artificial stress the tension pulls them together
    (the tensile instability), with it (eps = 0.3) it pushes them apart."""
    closing = {}
    for eps in (0.0, 0.3):
        sim = fsph.Simulation(deck_module.load(write_deck(particle_deck(
            body="n_radial = 10\n n_axial = 40", extra=f"&sph\n artificial_stress = {eps}\n/\n"),
            name=f"pair{eps}.nml")))
        x = sim.snapshot()["particles"]["x"].copy()
        one = np.argmin(np.hypot(x[:, 0] - 0.55e-3, x[:, 1] - 2.05e-3))
        two = np.argmin(np.hypot(x[:, 0] - 0.65e-3, x[:, 1] - 2.05e-3))
        x[two] = x[one] + [0.02e-3, 0.0]
        verify.set_particle_motion(sim, x, np.zeros_like(x))
        verify.set_stress_state(sim, [0.0, 0.0, 0.0, 0.0], -1.0e9)
        acc = verify.particle_rates(sim)["acc"]
        closing[eps] = acc[one, 0] - acc[two, 0]     # > 0: the pair closes in
    assert closing[0.0] > 0.0 and closing[0.3] < 0.0, closing
