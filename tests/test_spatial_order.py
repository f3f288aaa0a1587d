"""Particles kept in spatial order (&sph spatial_order_min, fsph_spatial):
the order puts neighbours close together in memory; renumbering changes a
run only by the order of its sums (round-off), keeps each particle's id,
the gauges on their particles, the thread-count independence and the
bit-for-bit restart."""

import os
import subprocess
import sys

import numpy as np
import pytest

import fsph
from fsph import checkpoint, verify
from fsph import deck as deck_module
from conftest import CASES


def lattice(n_across, n_along, spacing=1.0e-3):
    """A rod's particles (r, z) [m] on a square lattice, and their h."""
    r = (np.arange(n_across) + 0.5) * spacing
    z = (np.arange(n_along) + 0.5) * spacing
    rr, zz = np.meshgrid(r, z)
    x = np.column_stack([rr.ravel(), zz.ravel()])
    return x, np.full(len(x), 1.3 * spacing)


def neighbour_index_gaps(x, h, order):
    """Index distances |k - l| of the pairs within 2h once the points are
    in `order`."""
    y = x[order]
    d2 = ((y[:, None, :] - y[None, :, :]) ** 2).sum(axis=2)
    k, l = np.nonzero(np.triu(d2 < (2.0 * h[0]) ** 2, 1))
    return np.abs(k - l)


@pytest.mark.parametrize("shape", [(12, 60), (60, 12)], ids=["rod", "plate"])
def test_order_keeps_neighbours_within_three_cell_rows(shape):
    """A shuffled lattice put in spatial order: every pair within the
    support lies within three rows of cells (of side 2h, across the
    shorter side) of each other in the new numbering, for a rod along the
    axis and for a plate across it; shuffled, pairs lie up to the whole set
    apart."""
    x, h = lattice(*shape)
    rng = np.random.default_rng(3)
    shuffled = rng.permutation(len(x))
    x, h = x[shuffled], h[shuffled]
    order = verify.spatial_order(x, h)
    assert np.array_equal(np.sort(order), np.arange(len(x)))
    across = min(shape)
    cell_rows = 2.0 * 1.3                       # lattice rows per row of cells
    per_row = across * int(np.ceil(cell_rows))  # points in one row of cells, at most
    assert neighbour_index_gaps(x, h, order).max() <= 3 * per_row
    assert neighbour_index_gaps(x, h, np.arange(len(x))).max() > len(x) // 2


def test_renumbering_steps():
    """Renumbered when the count reaches spatial_order_min, then at each
    further 5 % (integer steps from the minimum), never with 0."""
    assert verify.renumber_due(4000, 4096, 4096)
    assert not verify.renumber_due(4000, 4095, 4096)
    assert not verify.renumber_due(4096, 4299, 4096)
    assert verify.renumber_due(4096, 4300, 4096)         # 4096 + 4096 // 20
    assert verify.renumber_due(4299, 4300, 4096)
    assert verify.renumber_due(10, 100000, 4096)
    assert not verify.renumber_due(0, 100000, 0)
    assert verify.renumber_due(0, 5, 1)


def taylor(spatial_order_min, end_time=None):
    deck = deck_module.load(CASES / "taylor_armco.nml")
    deck["sph"]["spatial_order_min"] = spatial_order_min
    if end_time is not None:
        deck["control"]["end_time"] = end_time
    return deck


def by_id(sim):
    part = sim.snapshot()["particles"]
    order = np.argsort(part["id"])
    return part, order


def test_renumbered_run_differs_only_by_round_off():
    """The adaptive Taylor rod to 12 us renumbered from 100 particles
    against the same run in conversion order: the ids are a permutation
    that is not the identity, the same cycles and conversions, and every
    particle (matched by id) at the same place and state to round-off."""
    runs = {}
    for n_min in (0, 100):
        sim = fsph.Simulation(taylor(n_min))
        sim.advance(12e-6)
        runs[n_min] = sim
    part, order = by_id(runs[100])
    plain, plain_order = by_id(runs[0])
    ids = part["id"]
    assert np.array_equal(np.sort(ids), np.arange(len(ids))) and len(ids) > 200
    assert not np.array_equal(ids, np.arange(len(ids)))
    assert np.array_equal(plain["id"], np.arange(len(ids)))
    assert runs[100].cycle == runs[0].cycle
    assert runs[100].conversion()["n_converted"] == runs[0].conversion()["n_converted"]
    scale = np.abs(plain["x"]).max()
    assert np.abs(part["x"][order] - plain["x"][plain_order]).max() < 1e-9 * scale
    e = plain["internal_energy"]
    assert np.abs(part["internal_energy"][order] - e[plain_order]).max() < 1e-9 * np.abs(e).max()
    assert np.array_equal(part["mass"][order], plain["mass"][plain_order])
    e0, e1 = runs[0].energies(), runs[100].energies()
    assert abs(e1["relative_error"] - e0["relative_error"]) < 1e-9


def test_gauge_follows_its_particle_through_renumbering():
    """A material gauge on the impact face, whose element converts and
    which then follows a particle: its history with renumbering from 100
    particles equals the one without to round-off."""
    histories = {}
    for n_min in (0, 100):
        groups = deck_module.groups_of(taylor(n_min))
        groups["gauge"] = [{"name": "face", "point": [0.5e-3, 0.3e-3]}]
        deck = deck_module.from_groups(groups, "taylor_armco.nml", CASES)
        sim = fsph.Simulation(deck)
        sim.advance(12e-6)
        assert sim.gauge_state()["face"]["on"] == "particle"
        histories[n_min] = sim.drain_histories(gauges=True)[2][:, 0, :]
    a, b = histories[0], histories[100]
    assert a.shape == b.shape and len(a) > 50
    assert np.array_equal(np.isnan(a), np.isnan(b))
    a, b = np.nan_to_num(a), np.nan_to_num(b)
    assert np.all(np.abs(a - b) <= 1e-9 * np.abs(a).max(axis=0))


def test_renumbered_run_restarts_bit_for_bit(tmp_path):
    """Renumbering from 100 particles: a run restarted from a checkpoint at
    6 us renumbers where the uninterrupted run does and ends at 10 us in
    its state, to the bit."""
    deck = taylor(100)
    sim = fsph.Simulation(deck)
    sim.advance(6e-6, land=False)
    path = checkpoint.save(sim, tmp_path / "ckpt.h5")
    sim.advance(10e-6, land=False)
    restarted = fsph.Simulation(deck)
    checkpoint.restore(restarted, path)
    restarted.advance(10e-6, land=False)
    assert checkpoint.state_digest(restarted) == checkpoint.state_digest(sim)
    assert not np.array_equal(sim.snapshot()["particles"]["id"], np.arange(sim.n_particles))


SCRIPT = """
import sys, fsph
from fsph import checkpoint, deck as deck_module
deck = deck_module.load(sys.argv[1])
deck["sph"]["spatial_order_min"] = 100
sim = fsph.Simulation(deck)
sim.advance(10e-6)
print(fsph.threads(), checkpoint.state_digest(sim))
"""


def test_renumbered_run_does_not_depend_on_the_thread_count(tmp_path):
    """Renumbering from 100 particles, 1 and 2 threads: the same state to
    the bit at 10 us."""
    out = []
    for n in (1, 2):
        env = dict(os.environ, OMP_NUM_THREADS=str(n), FSPH_THREAD_POLICY="fixed")
        res = subprocess.run([sys.executable, "-c", SCRIPT, str(CASES / "taylor_armco.nml")],
                             env=env, cwd=tmp_path, capture_output=True, text=True, timeout=300)
        assert res.returncode == 0, res.stderr
        threads, digest = res.stdout.split()
        assert threads == str(n)
        out.append(digest)
    assert out[0] == out[1]
