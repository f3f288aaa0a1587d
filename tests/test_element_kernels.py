"""T3 kinematics through the API: patch test and spin."""

import numpy as np
import pytest

import fsph
from fsph import deck as deck_module
from fsph import verify
from conftest import rod_deck


@pytest.fixture
def sim(write_deck):
    # a rod touching the axis (z from 1 mm) so axis elements are in the patch
    path = write_deck(rod_deck(body="z_base = 1.0e-3", boundary=False))
    return fsph.Simulation(deck_module.load(path))


def test_patch_linear_velocity_gives_exact_strain_rates(sim):
    """A linear velocity field gives the exact constant strain rates in every
    element, and the hoop rate v_r/r at the centroid."""
    a0, a1, a2 = 3.0, 2.0e3, -1.5e3     # v_r = a0 + a1 r + a2 z
    b0, b1, b2 = -7.0, 4.0e2, 5.0e3     # v_z = b0 + b1 r + b2 z
    snap = sim.snapshot()
    x = snap["x"]
    v = np.column_stack([a0 + a1 * x[:, 0] + a2 * x[:, 1], b0 + b1 * x[:, 0] + b2 * x[:, 1]])
    verify.set_velocities(sim, v)
    d, spin = verify.strain_rates(sim)
    centroid = x[snap["conn"]].mean(axis=1)
    vr_centroid = a0 + a1 * centroid[:, 0] + a2 * centroid[:, 1]
    scale = 5.0e3
    assert np.allclose(d[:, 0], a1, rtol=0, atol=1e-9 * scale)
    assert np.allclose(d[:, 1], b2, rtol=0, atol=1e-9 * scale)
    assert np.allclose(d[:, 2], 0.5 * (a2 + b1), rtol=0, atol=1e-9 * scale)
    assert np.allclose(d[:, 3], vr_centroid / centroid[:, 0], rtol=1e-12)
    assert np.allclose(spin, 0.5 * (a2 - b1), rtol=0, atol=1e-9 * scale)


def test_rigid_translation_gives_no_strain(sim):
    snap = sim.snapshot()
    v = np.tile([0.0, -123.0], (len(snap["x"]), 1))
    verify.set_velocities(sim, v)
    d, spin = verify.strain_rates(sim)
    assert np.abs(d).max() < 1e-9
    assert np.abs(spin).max() < 1e-9


def test_free_body_keeps_momentum_and_energy(write_deck):
    """A free, pre-stressed-by-impact body: with no plane the rod flies
    freely; a body with a velocity gradient oscillates elastically. Total
    axial momentum and total energy are conserved."""
    path = write_deck(rod_deck(boundary=False, control="end_time = 2.0e-6"))
    sim = fsph.Simulation(deck_module.load(path))
    snap = sim.snapshot()
    x = snap["x"]
    # stretch-and-spin field: axial gradient plus radial breathing
    v = np.column_stack([20.0 * x[:, 0] / 1e-3, -50.0 + 30.0 * (x[:, 1] - 2e-3) / 2e-3])
    verify.set_velocities(sim, v)
    m = snap["node_mass"]
    p0 = np.sum(m * v[:, 1])
    e0 = 0.5 * np.sum(m * (v ** 2).sum(axis=1))
    sim.advance(2.0e-6)
    snap = sim.snapshot()
    p1 = np.sum(m * snap["velocity"][:, 1])
    assert abs(p1 - p0) < 1e-10 * abs(p0)
    total = sim.energies()["total"]
    assert abs(total - e0) / e0 < 5e-3
