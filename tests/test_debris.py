"""Debris clouds of a copper flyer striking a 6061-T6 plate at 5-6 km/s
(Piekutowski 1990): the 1D impedance match against hand-computed numbers,
each debris diagnostic on particle sets whose answer is known exactly, a
coarse short run of case 1 through `fsph run` (summary, fsph.h5
histories with units, exact mass, momentum), the interface state of the
run just after impact against the impedance match, and the validation
bars of the two cases (slow: they need the 0.1 mm runs)."""

import json
import subprocess
import sys

import f90nml
import h5py
import numpy as np
import pytest

from fsph import deck as deck_module
from fsph.debris import (FRONT_FRACTIONS, UNITS, DebrisCase, Frame, body_points, body_spacing,
                         debris, fraction_tag, initial_spacing, interface_probe, intact_plate,
                         ring_edges, touching, upper_quantile)
from fsph.driver import run
from fsph.hugoniot import ShockMaterial, front_time, impedance_match
from conftest import CASES, reference

#: Steinberg's constants (the decks' EOS): copper with the paper's density,
#: 6061-T6.
COPPER = ShockMaterial(8930.0, 3940.0, 1.489, 2.02, "copper")
ALUMINIUM = ShockMaterial(2703.0, 5240.0, 1.40, 1.97, "al_6061_t6")


# --------------------------------------------------------------------------
# the impedance match

def test_impedance_match_of_case_1_against_hand_numbers():
    """Cu on Al at 5.55 km/s: interface velocity 3750.67 m/s and pressure
    106.36 GPa (solved by hand from 2703 (5240 + 1.40 u) u = 8930 (3940 +
    1.489 (5550 - u)) (5550 - u)); shock speeds 10 490.9 m/s into the
    plate and 6 619.2 m/s into the flyer; the shocks cross the 2.87 mm
    plate in 0.2736 us and the 3.45 mm flyer in 0.5212 us."""
    m = impedance_match(COPPER, ALUMINIUM, 5550.0, 3.45e-3, 2.87e-3)
    assert m["particle_velocity_m_s"] == pytest.approx(3750.67, abs=0.01)
    assert m["pressure_Pa"] == pytest.approx(106.36e9, rel=1e-4)
    assert m["target_shock_speed_m_s"] == pytest.approx(10490.93, abs=0.01)
    assert m["flyer_shock_speed_m_s"] == pytest.approx(6619.21, abs=0.01)
    assert m["target_transit_s"] == pytest.approx(0.27357e-6, rel=1e-4)
    assert m["flyer_transit_s"] == pytest.approx(0.52121e-6, rel=1e-4)
    # both Hugoniots meet there: the same normal stress on either side
    u = m["particle_velocity_m_s"]
    assert COPPER.pressure(5550.0 - u) == pytest.approx(ALUMINIUM.pressure(u), rel=1e-12)


def test_impedance_match_of_case_2_and_of_a_symmetric_impact():
    """Case 2 (5.12 km/s): 3466.2 m/s, 94.56 GPa. A flyer striking a plate
    of its own material: the interface moves at exactly half the speed."""
    m = impedance_match(COPPER, ALUMINIUM, 5120.0)
    assert m["particle_velocity_m_s"] == pytest.approx(3466.16, abs=0.01)
    assert m["pressure_Pa"] == pytest.approx(94.558e9, rel=1e-4)
    same = impedance_match(ALUMINIUM, ALUMINIUM, 6000.0)
    assert same["particle_velocity_m_s"] == pytest.approx(3000.0, rel=1e-12)


def test_release_doubles_a_weak_shock_and_adds_a_little_to_a_strong_one():
    """Releasing a weak shock (0.1 GPa in aluminium) adds its particle
    velocity again (the free surface doubles it) to 0.1 %; at 106 GPa the
    release adds more than the shock did (the isentrope is stiffer than the
    Hugoniot below it) but within 10 %."""
    weak = 0.1e9
    assert ALUMINIUM.release_velocity(weak) == pytest.approx(ALUMINIUM.particle_velocity(weak),
                                                             rel=1e-3)
    m = impedance_match(COPPER, ALUMINIUM, 5550.0, 3.45e-3, 2.87e-3)
    u = m["particle_velocity_m_s"]
    assert 2.0 * u < m["target_free_surface_m_s"] < 2.1 * u


def test_case_1_ends_at_the_time_the_impedance_match_gives():
    """Case 1's radiograph time is not in the paper: the deck ends when the
    aluminium on the axis, leaving the plate's rear face at the 1D
    free-surface velocity once the shock has crossed it, stands at the
    experiment's 51.3 mm (6.49 us); the deck and its reference agree."""
    m = impedance_match(COPPER, ALUMINIUM, 5550.0, 3.45e-3, 2.87e-3)
    t_front = front_time(m, 51.3e-3, 2.87e-3)
    deck = deck_module.load(CASES / "debris_cu_al_1.nml")
    assert deck["control"]["end_time"] == pytest.approx(t_front, abs=0.005e-6)
    assert reference("debris_cu_al_1")["conditions"]["control.end_time"] == \
        deck["control"]["end_time"]
    materials = {mat["name"]: mat for mat in deck["material"]}
    for mat, expected in ((materials["copper"], COPPER), (materials["al_6061_t6"], ALUMINIUM)):
        shock = ShockMaterial.from_deck(mat)
        assert (shock.density, shock.c0, shock.s, shock.gamma0) == \
            (expected.density, expected.c0, expected.s, expected.gamma0)


# --------------------------------------------------------------------------
# the diagnostics on particle sets with known answers

def test_upper_quantile_is_the_point_where_the_mass_ahead_reaches_the_fraction():
    position = np.arange(1.0, 101.0)
    mass = np.ones(100)
    assert upper_quantile(position, mass, 0.005) == 100.0
    assert upper_quantile(position, mass, 0.01) == 100.0
    assert upper_quantile(position, mass, 0.02) == 99.0
    assert upper_quantile(position, mass, 0.025) == 98.0
    # a heavy point holds the fraction by itself; unsorted input
    assert upper_quantile(np.array([3.0, 9.0, 5.0]), np.array([1.0, 1.0, 98.0]), 0.02) == 5.0
    assert upper_quantile(np.zeros(0), np.zeros(0), 0.01) is None


#: spacing of the synthetic plate [m], its thickness, columns and rows
DX = 0.25e-3
THICKNESS = 2.0e-3
N_COLUMNS, N_ROWS = 80, 8
HOLE_COLUMNS = 20                    # columns inside r = 5 mm


def _plate():
    """A synthetic plate (r, z) [m], -THICKNESS < z < 0, equal masses."""
    r = (np.arange(N_COLUMNS) + 0.5) * DX
    z = -(np.arange(N_ROWS) + 0.5) * DX
    rr, zz = np.meshgrid(r, z, indexing="ij")
    return np.column_stack([rr.ravel(), zz.ravel()])


def _snap(groups, time=1.0e-6):
    """A snapshot of particles from (body, x, x0, v, mass) groups [SI];
    radius DX/2, smoothing length 0.3 mm."""
    x = np.vstack([g[1] for g in groups])
    n = len(x)
    return {"time": time, "particles": {
        "x": x, "x0": np.vstack([g[2] for g in groups]), "velocity": np.vstack([g[3] for g in groups]),
        "mass": np.concatenate([g[4] for g in groups]),
        "body": np.concatenate([np.full(len(g[1]), g[0]) for g in groups]),
        "h": np.full(n, 0.3e-3), "radius": np.full(n, 0.5 * DX), "radius0": np.full(n, 0.5 * DX),
        "pressure": np.zeros(n)}}


def _case(front_fraction=0.01, intact_fraction=0.5):
    """Flyer body 0 flying towards -z onto the plate, body 1, its front face
    at z = 0."""
    return DebrisCase(0, 1, "flyer", "plate", "copper", "al", None, None, 5000.0, -1.0,
                      front_fraction, intact_fraction, (5e-3, 3e-3), (-THICKNESS, 0.0))


def _debris_set():
    """The plate with a hole of radius 5 mm: of the 160 particles from the
    hole, 150 form the plate's cloud (r = 3 mm, 10.0 to 24.9 mm behind the
    front face, 0.1 mm apart, at 7 km/s) and 10 the ejecta (r = 4 mm,
    3.0 to 7.5 mm above the front face, moving back at 1 km/s); the
    flyer's cloud of 100 particles 5.0 to 14.9 mm behind the face at
    5 km/s, at r = 1 mm but for ten at r = 2.45 to 2.54 mm beside the
    plate's cloud (10.0 to 10.9 mm); one flyer particle still on its way
    in and one thrown back."""
    plate = _plate()
    hole = plate[:, 0] < 5e-3
    n_hole = int(hole.sum())
    assert n_hole == HOLE_COLUMNS * N_ROWS
    m_plate = 1e-6
    cloud_x = np.column_stack([np.full(150, 3e-3), -(10.0 + 0.1 * np.arange(150)) * 1e-3])
    ejecta_x = np.column_stack([np.full(10, 4e-3), (3.0 + 0.5 * np.arange(10)) * 1e-3])
    hole_x = np.vstack([cloud_x, ejecta_x])
    hole_v = np.vstack([np.tile([0.0, -7000.0], (150, 1)), np.tile([0.0, 1000.0], (10, 1))])
    s_flyer = 5.0 + 0.1 * np.arange(100)
    r_flyer = np.full(100, 1e-3)
    r_flyer[50:60] = (2.45 + 0.01 * np.arange(10)) * 1e-3
    flyer_x = np.vstack([np.column_stack([r_flyer, -s_flyer * 1e-3]),
                         [[0.5e-3, 1e-3], [6e-3, 2e-3]]])
    flyer_v = np.vstack([np.tile([0.0, -5000.0], (100, 1)), [[0.0, -5000.0], [0.0, 300.0]]])
    flyer_x0 = np.column_stack([flyer_x[:, 0], np.full(102, 1e-3)])
    return _snap([(0, flyer_x, flyer_x0, flyer_v, np.full(102, 3e-5)),
                  (1, plate[~hole], plate[~hole], np.zeros((len(plate) - n_hole, 2)),
                   np.full(len(plate) - n_hole, m_plate)),
                  (1, hole_x, plate[hole], hole_v, np.full(n_hole, m_plate))])


def test_fronts_at_the_three_fractions():
    """Fronts are the positions beyond which lies the fraction of the
    cloud's own mass: plate cloud (150 equal points) 24.9, 24.8, 24.7 mm at
    0.5, 1 and 2 %; flyer cloud (100 points) 14.9, 14.9, 14.8 mm. The
    plate left behind and the ejecta are not in the clouds."""
    rec = debris(_debris_set(), _case())
    expected = {"flyer": (14.9, 14.9, 14.8), "target": (24.9, 24.8, 24.7)}
    for body, values in expected.items():
        for q, value in zip(FRONT_FRACTIONS, values):
            assert rec[f"{body}_front_{fraction_tag(q)}_mm"] == pytest.approx(value, abs=1e-9)
    assert rec["flyer_front_mm"] == pytest.approx(14.9, abs=1e-9)
    assert rec["target_front_mm"] == pytest.approx(24.8, abs=1e-9)
    assert rec["front_ratio"] == pytest.approx(14.9 / 24.8, rel=1e-12)
    assert rec["target_cloud_mass_kg"] == pytest.approx(150e-6, rel=1e-12)
    assert rec["flyer_cloud_mass_kg"] == pytest.approx(100 * 3e-5, rel=1e-12)


def test_masses_and_momenta_of_the_clouds():
    """Cloud masses and axial momenta by body, the ejecta's mass, each
    body's total mass and the momentum of everything."""
    rec = debris(_debris_set(), _case())
    assert rec["flyer_cloud_momentum_z_N_s"] == pytest.approx(100 * 3e-5 * -5000.0, rel=1e-12)
    assert rec["target_cloud_momentum_z_N_s"] == pytest.approx(150e-6 * -7000.0, rel=1e-12)
    assert rec["ejecta_mass_kg"] == pytest.approx(10e-6 + 3e-5, rel=1e-12)
    assert rec["flyer_mass_kg"] == pytest.approx(102 * 3e-5, rel=1e-12)
    assert rec["target_mass_kg"] == pytest.approx(N_COLUMNS * N_ROWS * 1e-6, rel=1e-12)
    total = 101 * 3e-5 * -5000.0 + 3e-5 * 300.0 + 150e-6 * -7000.0 + 10e-6 * 1000.0
    assert rec["momentum_z_N_s"] == pytest.approx(total, rel=1e-12)


def test_ejecta_height_counts_only_material_moving_back():
    """The ejecta (10 plate points 3.0 to 7.5 mm above the face, and the
    flyer point thrown back at 2 mm) reach 7.5 mm at 1 % of their mass;
    the flyer point above the face still flying in is not ejecta."""
    rec = debris(_debris_set(), _case())
    assert rec["ejecta_height_mm"] == pytest.approx(7.5, abs=1e-9)
    # a fraction held by the heavy flyer point alone: 2 mm
    rec = debris(_debris_set(), _case(front_fraction=0.5))
    assert rec["ejecta_height_mm"] == pytest.approx(2.0, abs=1e-9)


def test_intersection_radius_is_where_the_flyer_cloud_touches_the_plate_cloud():
    """Ten flyer points at r = 2.45 to 2.54 mm lie within the sum of the
    smoothing lengths (0.6 mm) of the plate's cloud at r = 3 mm: the
    intersection is at 2.54 mm (1 %) or 2.52 mm (25 %: the third from
    outside); flyer points at 1 mm do not touch."""
    assert debris(_debris_set(), _case())["intersection_radius_mm"] == pytest.approx(2.54,
                                                                                     abs=1e-9)
    assert debris(_debris_set(), _case(front_fraction=0.25))["intersection_radius_mm"] == \
        pytest.approx(2.52, abs=1e-9)
    snap = _debris_set()
    plate_left = N_COLUMNS * N_ROWS - HOLE_COLUMNS * N_ROWS
    cloud = body_points(snap, 1).take(np.arange(plate_left, plate_left + 150))
    assert touching(body_points(snap, 0), cloud).sum() == 10


def test_hole_is_inside_the_intact_rings_counted_from_the_rim():
    """The plate without its inner 20 columns: hole diameter 10.0 mm
    (the innermost column at 5.125 mm less its radius). A lump torn off
    and left in the plate's band at r = 1 mm does not count: an empty ring
    separates it from the rim."""
    assert debris(_debris_set(), _case())["hole_diameter_mm"] == pytest.approx(10.0, abs=1e-9)
    snap = _debris_set()
    part = snap["particles"]
    lump = (part["body"] == 1) & (part["x"][:, 0] == 3e-3)
    part["x"][np.nonzero(lump)[0][:20]] = [1e-3, -1e-3]
    assert debris(snap, _case())["hole_diameter_mm"] == pytest.approx(10.0, abs=1e-9)
    # the smallest radius of any plate material in the band would be the lump's
    in_band = (part["body"] == 1) & (part["x"][:, 1] > -THICKNESS) & (part["x"][:, 1] < 0.0)
    assert 2e3 * (part["x"][in_band, 0] - part["radius"][in_band]).min() == \
        pytest.approx(1.75, abs=1e-9)


def test_a_ring_that_lost_more_than_the_intact_fraction_is_hole():
    """Move 7 of the 16 points of the ring 10.0-10.5 mm (two columns) into
    the cloud: it keeps 9/16 of its mass, intact at the default 1/2, and
    the hole stays 10.0 mm. With two more gone it keeps 7/16, and the hole
    reaches the next ring (its inner column at 10.625 mm less the radius
    0.125 mm: 21.0 mm across); intact_fraction 0.4 keeps the ring intact."""
    snap = _debris_set()
    part = snap["particles"]
    in_band = (part["body"] == 1) & (part["x"][:, 1] < 0.0) & (part["x"][:, 1] > -THICKNESS)
    ring = np.nonzero(in_band & (part["x"][:, 0] > 10e-3) & (part["x"][:, 0] < 10.5e-3))[0]
    assert len(ring) == 2 * N_ROWS
    part["x"][ring[:7], 1] -= 30e-3
    assert debris(snap, _case())["hole_diameter_mm"] == pytest.approx(10.0, abs=1e-9)
    part["x"][ring[7:9], 1] -= 30e-3
    assert debris(snap, _case())["hole_diameter_mm"] == pytest.approx(21.0, abs=1e-9)
    assert debris(snap, _case(intact_fraction=0.4))["hole_diameter_mm"] == \
        pytest.approx(10.0, abs=1e-9)


def test_graded_rim_columns_that_drift_stay_intact():
    """Columns 2 mm apart beyond the uniform zone each get a ring reaching
    halfway to their neighbours: an elastic drift of 0.3 mm leaves the
    plate intact (with rings of fixed width it would cut it)."""
    r = np.concatenate([(np.arange(40) + 0.5) * DX, 10e-3 + 2e-3 * np.arange(1, 6)])
    z = -(np.arange(N_ROWS) + 0.5) * DX
    rr, zz = np.meshgrid(r, z, indexing="ij")
    x0 = np.column_stack([rr.ravel(), zz.ravel()])
    x = x0.copy()
    x[x0[:, 0] > 10e-3, 0] += 0.3e-3
    snap = _snap([(1, x, x0, np.zeros_like(x), np.ones(len(x)))])
    target = body_points(snap, 1)
    intact, hole = intact_plate(target, Frame.of_plate(-THICKNESS, 0.0, -1.0), 0.5, 2 * DX)
    assert intact.all() and hole == pytest.approx(0.0, abs=1e-15)


def _adaptive_plate(cell=0.2e-3, n_cells=40, n_layers=4, hole_cells=25, shift=0.12e-3):
    """An adaptive plate (body 1) of crossed-quadrilateral T3 cells
    (corner nodes of mass 2, centre nodes of mass 1) whose inner
    `hole_cells` columns of cells have converted: their particles (mass
    1, initial positions the elements' centroids) are 20 mm downrange,
    and the remaining elements' nodes have flowed outward by `shift` [m]."""
    corner = {(i, j): k for k, (i, j) in enumerate(
        (i, j) for i in range(n_cells + 1) for j in range(n_layers + 1))}
    x0 = [(i * cell, -j * cell) for (i, j) in corner]
    mass = [2.0] * len(x0)
    tris, column = [], []
    for i in range(n_cells):
        for j in range(n_layers):
            centre = len(x0)
            x0.append(((i + 0.5) * cell, -(j + 0.5) * cell))
            mass.append(1.0)
            ring = [corner[(i, j)], corner[(i + 1, j)], corner[(i + 1, j + 1)], corner[(i, j + 1)]]
            for a, b in zip(ring, ring[1:] + ring[:1]):
                tris.append((a, b, centre))
                column.append(i)
    x0, tris, converted = np.array(x0), np.array(tris), np.array(column) < hole_cells
    used = np.unique(tris[~converted])
    renumber = np.full(len(x0), -1)
    renumber[used] = np.arange(len(used))
    px0 = x0[tris[converted]].mean(axis=1)
    n_p = len(px0)
    return {"time": 1e-6, "x": x0[used] + [shift, 0.0], "x0": x0[used],
            "velocity": np.zeros((len(used), 2)), "node_mass": np.array(mass)[used],
            "conn": renumber[tris[~converted]], "body": np.ones(int((~converted).sum()), int),
            "element_mass": np.ones(int((~converted).sum())),
            "particles": {"x": np.column_stack([px0[:, 0], np.full(n_p, -20e-3)]), "x0": px0,
                          "velocity": np.tile([0.0, -7000.0], (n_p, 1)), "mass": np.ones(n_p),
                          "body": np.ones(n_p, int), "h": np.full(n_p, 0.3e-3),
                          "radius": np.full(n_p, 0.1e-3), "radius0": np.full(n_p, 0.1e-3),
                          "pressure": np.zeros(n_p)}}


def test_no_ring_is_narrower_than_its_width():
    """The rings' edges stand halfway between columns of points, each at
    least a ring width beyond the one before (the first at least a width
    from the axis): across a uniform zone of 0.1 mm columns that meets a
    rim graded by 8 % a column, no ring is narrower than the width
    (0.2 mm), and on the rim, where the columns are farther apart than
    that, every column has a ring of its own. Thinned to one edge per
    width of radius, as before, two edges here stood 0.1 mm apart (on the
    adaptive plate of case 1 refined x2 a ring 0.58 widths wide where the
    zones meet held 48 % of its mass as the plate bent, and the hole read
    42.1 mm)."""
    uniform = 0.05e-3 + 0.1e-3 * np.arange(200)
    rim = uniform[-1] + np.cumsum(0.1e-3 * 1.08 ** np.arange(1, 40))
    columns = np.concatenate([uniform, rim])
    width = 0.2e-3
    edges = ring_edges(np.repeat(columns, 3), width)
    assert edges[0] >= width * (1.0 - 1e-9)
    assert np.diff(edges).min() >= width * (1.0 - 1e-9)
    mids = 0.5 * (columns[:-1] + columns[1:])
    apart = np.diff(columns) > width
    for k in np.nonzero(apart)[0][1:]:
        assert np.isclose(edges, mids[k], rtol=0, atol=1e-6 * width).any()
    # the old thinning, for the record of what it did here
    _, first = np.unique(np.floor(mids / width), return_index=True)
    assert np.diff(mids[first]).min() < 0.6 * width


def test_an_adaptive_plate_keeps_the_rings_of_its_mesh():
    """The rings of a plate of elements are twice its mesh's spacing wide
    (the nodes' nearest-neighbour distance, 0.141 mm here), not its
    points': the particles converted from its elements stand at their
    centroids, a third of a cell from the nodes (0.067 mm). Rings of the
    points' spacing, thinned to one edge per ring width of radius, were
    as narrow as a third of it and lost columns of nodes that the plate's
    outward flow (0.12 mm) had moved out of them, so that the intact
    plate began at 7.7 mm (the adaptive case 1 reported a hole of 39.7 mm
    in a plate whose picture showed 22 mm). No ring is narrower than its
    width now (test below), and with the mesh's rings, as with the
    points', the hole is where the remaining nodes begin (5.12 mm) within
    a ring."""
    snap = _adaptive_plate()
    target = body_points(snap, 1)
    assert initial_spacing(target.x0) == pytest.approx(0.2e-3 / 3, rel=1e-9)
    assert body_spacing(snap, 1) == pytest.approx(0.2e-3 / np.sqrt(2.0), rel=1e-9)
    frame = Frame.of_plate(-0.8e-3, 0.0, -1.0)
    _, narrow = intact_plate(target, frame, 0.5, 2 * initial_spacing(target.x0))
    assert abs(narrow - 5.12e-3) <= 2 * initial_spacing(target.x0)
    ring = 2 * body_spacing(snap, 1)
    _, hole = intact_plate(target, frame, 0.5, ring)
    assert abs(hole - 5.12e-3) <= ring
    case = DebrisCase(0, 1, "flyer", "plate", "copper", "al", None, None, 5000.0, -1.0,
                      0.01, 0.5, (5e-3, 3e-3), (-0.8e-3, 0.0))
    assert debris(snap, case)["hole_diameter_mm"] == pytest.approx(2e3 * hole, rel=1e-12)


def test_interface_probe_reads_the_shocked_layers_only():
    """Points of a body that started within a third of the flyer's radius
    of the axis, from two spacings to half the shock's run from the
    impact plane, give their mass-weighted mean pressure and velocity
    along the flight direction; the contact layer, the shock front and
    the points farther out are left out. Before that range spans three
    spacings there is no reading."""
    dx = 0.1e-3
    r = (np.arange(60) + 0.5) * dx
    z = -(np.arange(30) + 0.5) * dx
    rr, zz = np.meshgrid(r, z, indexing="ij")
    x0 = np.column_stack([rr.ravel(), zz.ravel()])
    depth = -x0[:, 1]
    probe = (x0[:, 0] <= 2e-3) & (depth >= 2 * dx) & (depth <= 1.0e-3)
    pressure = np.where(probe, 100e9, 3e9)
    velocity = np.column_stack([np.zeros(len(x0)), np.where(probe, -3700.0, -10.0)])
    snap = _snap([(1, x0, x0, velocity, 1.0 + depth)])
    snap["particles"]["pressure"] = pressure
    frame = Frame.of_plate(-3e-3, 0.0, -1.0)
    p, u = interface_probe(snap, 1, frame, 6e-3, 2.0e-3, dx, flyer_side=False)
    assert p == pytest.approx(100e9, rel=1e-12) and u == pytest.approx(3700.0, rel=1e-12)
    assert interface_probe(snap, 1, frame, 6e-3, 0.99e-3, dx, flyer_side=False) == (None, None)


# --------------------------------------------------------------------------
# runs

def _variant(tmp_path, deck, name, control=None, output=None, bodies=()):
    """A copy of a shipped deck with some keys changed (bodies: (index,
    {key: value})), its reference made absolute; returns the path."""
    nml = f90nml.read(CASES / deck)
    nml["output"]["reference"] = str(CASES / nml["output"]["reference"])
    nml["control"].update(control or {})
    nml["output"].update(output or {})
    for index, keys in bodies:
        nml["body"][index].update(keys)
    path = tmp_path / f"{name}.nml"
    nml.write(path, force=True)
    return path


#: case 1 at 0.2 mm (flyer 28 x 17, plate 100 + 20 graded x 14)
COARSE_CASE_1 = ((0, {"n_radial": 28, "n_axial": 17}),
                 (1, {"n_radial": 100, "n_coarse": 20, "n_axial": 14}))


@pytest.fixture(scope="module")
def coarse(tmp_path_factory):
    """Case 1 at 0.2 mm for 1.5 us through `fsph run` (the printed lines
    kept)."""
    tmp = tmp_path_factory.mktemp("debris_coarse")
    deck = _variant(tmp, "debris_cu_al_1.nml", "coarse", {"end_time": 1.5e-6},
                    {"n_snapshots": 6, "vtu": False}, COARSE_CASE_1)
    res = subprocess.run([sys.executable, "-m", "fsph", "run", str(deck), "-o", str(tmp / "out"),
                          "--progress", "lines"], capture_output=True, text=True, cwd=tmp,
                         timeout=600)
    assert res.returncode == 0, res.stdout + res.stderr
    return tmp / "out", json.loads((tmp / "out" / "summary.json").read_text()), res.stdout


def test_coarse_run_has_the_debris_summary_and_histories(coarse):
    """summary.json holds the debris record, its history at every snapshot
    and the impedance match; fsph.h5 holds /metrics/debris/<key> with one
    value per snapshot and its unit; the printed summary has the table."""
    out, summary, printed = coarse
    assert summary["status"] == "completed"
    rec = summary["metrics"]["debris"]
    assert set(UNITS) <= set(rec)
    assert rec["flyer_material"] == "copper" and rec["target_material"] == "al_6061_t6"
    series = summary["metrics"]["series"]
    assert set(UNITS) <= set(series) and len(series["time_us"]) == 7
    assert rec["flyer_front_mm"] > 0.0 and rec["target_front_mm"] > rec["flyer_front_mm"]
    assert summary["metrics"]["impedance_match"]["pressure_GPa"] == pytest.approx(106.36, rel=1e-4)
    with h5py.File(out / "fsph.h5", "r") as h5:
        group = h5["metrics/debris"]
        assert set(group) == set(UNITS)
        for key, unit in UNITS.items():
            assert group[key].attrs["units"] == unit
            assert group[key].shape == (7,)
        np.testing.assert_allclose(group["time_us"][...], series["time_us"], rtol=1e-12)
        assert np.isnan(group["target_front_mm"][0])           # no cloud at t = 0
        assert group["target_front_mm"][-1] == pytest.approx(rec["target_front_mm"], rel=1e-12)
    assert "debris at t = 1.5 us" in printed
    assert "debris.hole_diameter_mm" in printed and "impedance match: 106.4 GPa" in printed
    # the experiment's numbers are for the radiograph's time, not 1.5 us
    assert summary["reference"]["applies"] is False
    assert "control.end_time" in summary["reference"]["not_applied_because"]


def test_coarse_run_keeps_mass_exactly_and_momentum(coarse):
    """Each body's mass is the same at every snapshot (to round-off in the
    sums); the axial momentum of everything stays within 0.05 % of its
    initial value (no boundary; measured over the whole run at 0.2 mm
    0.010 %, at 0.1 mm 0.003 %; at 0.4 mm one contact event at 1.5 us
    changes it by 0.34 %)."""
    series = coarse[1]["metrics"]["series"]
    for key in ("flyer_mass_kg", "target_mass_kg"):
        mass = np.array(series[key])
        assert np.abs(mass / mass[0] - 1.0).max() < 1e-13
    assert series["flyer_mass_kg"][0] == pytest.approx(8930.0 * np.pi * 5.565e-3**2 * 3.45e-3,
                                                       rel=1e-3)
    momentum = np.array(series["momentum_z_N_s"])
    assert momentum[0] == pytest.approx(series["flyer_mass_kg"][0] * -5550.0, rel=1e-12)
    assert np.abs(momentum / momentum[0] - 1.0).max() < 5e-4


#: both cases at 0.2 mm (half the decks' lattice counts)
COARSE = {"debris_cu_al_1": COARSE_CASE_1,
          "debris_cu_al_2": ((0, {"n_radial": 42, "n_axial": 26}),
                             (1, {"n_radial": 125, "n_coarse": 22, "n_axial": 22}))}


@pytest.mark.parametrize("case", sorted(COARSE))
def test_both_cases_at_the_default_settings_keep_their_energy(tmp_path, case):
    """The whole of each case at 0.2 mm with the decks' default settings
    (no contact parameter): no crash, kinetic + internal + contact work
    within 1 % throughout (measured -0.15 % and -0.14 % at the worst
    moment; -0.23 and -0.20 % with the internal energy of the step's
    end), every particle field finite, part of the copper molten."""
    deck = _variant(tmp_path, f"{case}.nml", "coarse", None,
                    {"n_snapshots": 4, "vtu": False, "checkpoint": False}, COARSE[case])
    summary = run(deck, tmp_path / "out", quiet=True)
    assert summary["status"] == "completed"
    assert abs(summary["energy"]["max_relative_error"]) < 0.01
    assert summary["material_state"]["flyer"]["melted_mass_kg"] > 0.0
    with h5py.File(tmp_path / "out" / "fsph.h5", "r") as h5:
        last = h5["snapshots"][sorted(h5["snapshots"])[-1]]["particles"]
        for field in ("plastic_strain", "temperature", "pressure", "internal_energy", "density"):
            assert np.isfinite(last[field][...]).all(), field


def test_spall_failure_breaks_the_copper_and_stops_its_spall_zone_heating(tmp_path):
    """Case 1 at 0.2 mm with spall as failure on both materials
    (`spall_failure`): nearly all the copper fails (the release waves
    cross it everywhere), the energy stays within 1 %, and the molten
    copper falls to under half of the floor-only run's (measured 13.8
    against 29.6 %: with the floor the copper behind the spall plane,
    held at p_min while the cloud stretches it, keeps heating)."""
    molten = {}
    for failure in (False, True):
        deck = _variant(tmp_path, "debris_cu_al_1.nml", f"spall_{failure}", None,
                        {"n_snapshots": 2, "vtu": False, "checkpoint": False}, COARSE_CASE_1)
        nml = f90nml.read(deck)
        for material in nml["material"]:
            material["spall_failure"] = failure
        nml.write(deck, force=True)
        summary = run(deck, tmp_path / f"out_{failure}", quiet=True)
        assert summary["status"] == "completed"
        assert abs(summary["energy"]["max_relative_error"]) < 0.01
        flyer = summary["material_state"]["flyer"]
        molten[failure] = flyer["melted_mass_kg"] / flyer["mass_kg"]
        failed = flyer["failed_mass_kg"] / flyer["mass_kg"]
        assert failed > 0.9 if failure else failed == 0.0
    assert molten[True] < 0.5 * molten[False]


def test_plot_of_a_debris_run(coarse, tmp_path):
    """`fsph plot` of a debris run draws the cloud coloured by body at
    the snapshots asked for (each once)."""
    out = coarse[0]
    res = subprocess.run([sys.executable, "-m", "fsph", "plot", str(out), "--times", "0.5,1.5,9",
                          "-o", str(tmp_path / "cloud.png")], capture_output=True, text=True,
                         cwd=tmp_path, timeout=300)
    assert res.returncode == 0, res.stderr
    png = tmp_path / "cloud.png"
    assert png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert png.stat().st_size > 20_000


def test_interface_state_just_after_impact_matches_the_impedance_match(tmp_path):
    """Case 1 at 0.1 mm for the first 0.27 us (the plate a 10 mm disc:
    nothing from its rim arrives by then): the mean of the two bodies'
    interface probes over the snapshots before the plate's shock reaches
    its rear face is within 2 % of the 1D pressure and particle velocity."""
    deck = _variant(tmp_path, "debris_cu_al_1.nml", "impact", {"end_time": 0.27e-6},
                    {"n_snapshots": 9, "vtu": False, "checkpoint": False},
                    [(1, {"radius": 10e-3, "fine_radius": 10e-3, "n_radial": 100,
                          "n_coarse": 0})])
    summary = run(deck, tmp_path / "out", quiet=True)
    match = summary["metrics"]["impedance_match"]
    assert match["measured_snapshots"] >= 3
    assert abs(match["pressure_error_percent"]) < 2.0
    assert abs(match["particle_velocity_error_percent"]) < 2.0


def test_particles_striking_elements_at_5_km_s_keep_the_energy(tmp_path):
    """The adaptive case 1 for its first 0.12 us (about 50 cycles): the
    flyer's particles strike the plate's elements at 5.55 km/s. The step of
    the striking cycle is the struck elements' step at the closing speed
    (fsph_contact contact_step_limit), so the energy stays within 0.3 %
    (measured +0.32 % after the first cycle and +0.09 % from the third;
    with the step of the state before the impact the first cycle alone
    made +1.48 %, and the run stayed at +1.2 %)."""
    deck = _variant(tmp_path, "debris_cu_al_1_adaptive.nml", "strike", {"end_time": 0.12e-6},
                    {"n_snapshots": 2, "vtu": False, "checkpoint": False})
    summary = run(deck, tmp_path / "out", quiet=True)
    assert summary["status"] == "completed"
    assert abs(summary["energy"]["relative_error"]) < 0.003


def test_a_flyer_without_a_us_up_hugoniot_has_no_impedance_match(tmp_path):
    """A flyer of linear EOS: the debris metrics are there, the impedance
    match (which needs two linear Us-up Hugoniots) is left out, and the
    interface entries are empty."""
    nml = f90nml.read(CASES / "debris_cu_al_1.nml")
    nml["output"].update({"n_snapshots": 2, "vtu": False, "checkpoint": False})
    del nml["output"]["reference"]
    nml["control"]["end_time"] = 0.3e-6
    nml["material"][0] = {"name": "copper", "library": "steel_elastic_bar"}
    for index, keys in COARSE_CASE_1:
        nml["body"][index].update(keys)
    path = tmp_path / "linear.nml"
    nml.write(path, force=True)
    summary = run(path, tmp_path / "out", quiet=True)
    assert summary["status"] == "completed"
    assert "debris" in summary["metrics"] and "impedance_match" not in summary["metrics"]
    assert summary["metrics"]["debris"]["flyer_interface_pressure_GPa"] is None


def _metrics_group(text):
    """The case 1 deck with its &metrics group replaced by `text`."""
    def edit(source):
        return source[:source.index("&metrics")] + text
    return edit


@pytest.mark.parametrize("edit, key, says", [
    (_metrics_group("&metrics\n kind = 'debris'\n body = 'flyer'\n target = 'flyer'\n/\n"),
     "target", "another &body"),
    (_metrics_group("&metrics\n kind = 'debris'\n target = 'flyer'\n/\n"),
     "body", "a flyer other than the target"),
    (lambda source: source.replace("velocity_z = -5550.0", "velocity_z = 0.0"),
     "body", "moving relative to the target"),
])
def test_bad_debris_metrics_are_deck_errors(tmp_path, edit, key, says):
    """A debris metric whose flyer is its target (named twice, or the
    default flyer, the first body, named as the target), or whose flyer
    does not move relative to the target, is a bad deck (exit 2, one line
    naming the group and key)."""
    source = edit((CASES / "debris_cu_al_1.nml").read_text())
    path = tmp_path / "bad.nml"
    path.write_text(source.replace("references/", str(CASES / "references") + "/"))
    res = subprocess.run([sys.executable, "-m", "fsph", "check", str(path)], capture_output=True,
                         text=True, cwd=tmp_path, timeout=300)
    assert res.returncode == 2
    assert f"&metrics key '{key}'" in res.stderr and says in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1


# --------------------------------------------------------------------------
# validation against Piekutowski 1990 (slow): each case on the finest
# lattice of the resolution study, 0.05 mm (the decks' counts doubled;
# case 1 about 6 minutes on one core)

def _fine(tmp_path_factory, case):
    """The case at 0.05 mm, run to the deck's end time."""
    tmp = tmp_path_factory.mktemp(case)
    bodies = f90nml.read(CASES / f"{case}.nml")["body"]
    fine = [(index, {key: 2 * value for key, value in bodies[index].items()
                     if key in ("n_radial", "n_axial", "n_coarse")}) for index in (0, 1)]
    deck = _variant(tmp, f"{case}.nml", "fine", None,
                    {"n_snapshots": 8, "vtu": False, "checkpoint": False}, fine)
    return run(deck, tmp / "out", quiet=True)


@pytest.fixture(scope="module")
def case_1(tmp_path_factory):
    return _fine(tmp_path_factory, "debris_cu_al_1")


@pytest.fixture(scope="module")
def case_2(tmp_path_factory):
    return _fine(tmp_path_factory, "debris_cu_al_2")


def _within_bar(summary, case, key):
    """The run's error against the experiment [%] on `key` is within the
    reference's acceptance bar (the comparison applies: the run ended at
    the experiment's time)."""
    assert summary["status"] == "completed"
    assert summary["reference"]["applies"]
    error = summary["reference"]["comparison"]["debris"][key]["error_percent"]
    assert error is not None, f"{key}: not measured (the group it measures is empty)"
    bar = reference(case)["acceptance"][key.removesuffix("_mm") + "_percent"]
    assert abs(error) <= bar, f"{key}: {error:+.1f} % against a bar of {bar} %"


@pytest.mark.slow
def test_case_1_conserves_energy(case_1):
    """Kinetic + internal + contact work within 1 % throughout."""
    assert abs(case_1["energy"]["max_relative_error"]) < 0.01


@pytest.mark.slow
def test_case_1_ratio_of_the_fronts(case_1):
    """Copper front over aluminium front within 5 % of 33.5/51.3 (the ratio
    does not depend on the radiograph's time)."""
    _within_bar(case_1, "debris_cu_al_1", "front_ratio")


@pytest.mark.slow
def test_case_1_aluminium_front(case_1):
    """Aluminium front within 5 % of 51.3 mm at 6.49 us, the time the 1D
    impedance match gives for it."""
    _within_bar(case_1, "debris_cu_al_1", "target_front_mm")


@pytest.mark.slow
def test_case_1_hole(case_1):
    """Hole diameter within 10 % of 20.1 mm."""
    _within_bar(case_1, "debris_cu_al_1", "hole_diameter_mm")


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=(
    "measured 17.69 mm at 0.05 mm (-36.6 %; 17.12 at 0.1 mm and 15.58 at 0.2 mm) with the decks' "
    "artificial stress (eps 0.1, 2026-11-29); 17.73 at 0.05 mm without it, 17.74 at 0.025 mm: "
    "converged): the copper cloud's brim ends near r = 18 mm where the experiment's spreads to "
    "27.9 mm"))
def test_case_1_intersection_radius(case_1):
    """Radius where the copper cloud meets the aluminium cloud within 10 %
    of 27.9 mm."""
    _within_bar(case_1, "debris_cu_al_1", "intersection_radius_mm")



@pytest.mark.slow
def test_case_2_conserves_energy(case_2):
    """Kinetic + internal + contact work within 1 % throughout."""
    assert abs(case_2["energy"]["max_relative_error"]) < 0.01


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=(
    "measured 53.83 mm at 0.05 mm (+13.3 %; 53.93 at 0.1 mm, 60.29 at 0.2 mm) with the decks' "
    "artificial stress (eps 0.1, 2026-11-29; 54.03 at 0.05 mm without it): the 1D free "
    "surface itself is at 55.7 mm at 7.6 us, 17 % ahead of the experiment's front"))
def test_case_2_aluminium_front(case_2):
    """Aluminium front within 5 % of 47.5 mm at 7.6 us."""
    _within_bar(case_2, "debris_cu_al_2", "target_front_mm")


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=(
    "measured 34.73 mm at 0.05 mm (+33.6 %; 34.50 at 0.1 mm, 34.34 at 0.2 mm) with the decks' "
    "artificial stress (eps 0.1, 2026-11-29; 34.75 at 0.05 mm without it): the copper "
    "hat's crown leads at 4.6 km/s where the radiograph's front moved at 3.4"))
def test_case_2_copper_front(case_2):
    """Copper front within 10 % of 26.0 mm at 7.6 us."""
    _within_bar(case_2, "debris_cu_al_2", "flyer_front_mm")


@pytest.mark.slow
def test_case_2_hole(case_2):
    """Hole diameter within 10 % of 31.6 mm."""
    _within_bar(case_2, "debris_cu_al_2", "hole_diameter_mm")


@pytest.fixture(scope="module")
def adaptive_case_1(tmp_path_factory):
    """The adaptive variant of case 1 (plate elements that turn into
    particles) at twice its deck's counts (the flyer's lattice 0.05 mm,
    the plate's elements 0.1 mm), the finest of its study as the pure
    particle cases run at theirs (about 4 minutes on one core)."""
    return _fine(tmp_path_factory, "debris_cu_al_1_adaptive")


@pytest.mark.slow
def test_adaptive_case_1_runs_with_its_energy(adaptive_case_1):
    """It runs to its end with the energy within 1 % (measured +0.07 % at
    its largest; at the deck's counts +0.17 %, +0.21 % with the internal
    energy of the step's end, and +1.34 % before the step of the
    striking cycle was bounded by the struck elements' step at the
    closing speed, when the first cycle alone made +1.48 %)."""
    assert adaptive_case_1["status"] == "completed"
    assert abs(adaptive_case_1["energy"]["max_relative_error"]) < 0.01


@pytest.mark.slow
def test_adaptive_case_1_hole(adaptive_case_1):
    """Its hole within the 10 % bar of the particle deck (measured
    21.95 mm, +9.2 %; 22.05 mm, +9.7 %, at the deck's counts; the pure
    particle deck 21.57 mm at 0.05 mm). With rings as narrow as half
    their width (until 2026-11-29, later) the deck's counts gave 22.32 mm
    (+11.0 %, a strict expected failure then) and twice them 42.1 mm."""
    _within_bar(adaptive_case_1, "debris_cu_al_1", "hole_diameter_mm")
