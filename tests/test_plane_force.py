"""The rigid planes' load on the bodies (the Taylor anvil force): the
impulse the solver books (kinematic plane condition and mirror images)
equals the rod's change of axial momentum, in every mode; fsph.h5 keeps
the impulse and the force with their units, and summary.json the peak."""

import h5py
import numpy as np
import pytest

import fsph
from fsph.driver import run

from conftest import CASES


def axial_momentum(snap):
    """Sum of m v_z over nodes and particles [N s] (half-step velocities)."""
    p = 0.0
    if "conn" in snap:
        p += np.sum(snap["node_mass"] * snap["velocity"][:, 1])
    if "particles" in snap:
        p += np.sum(snap["particles"]["mass"] * snap["particles"]["velocity"][:, 1])
    return p


@pytest.mark.parametrize("deck, bar", [("taylor_armco_fem.nml", 1e-9), ("taylor_armco_sph.nml", 0.01),
                                       ("taylor_armco.nml", 0.01)])
def test_anvil_impulse_equals_the_rods_momentum_change(deck, bar):
    """At 4, 12 and 25 us the planes' impulse matches p_z(t) - p_z(0)
    within 1 % of the change (elements alone: to round-off, the plane
    being their only external load)."""
    sim = fsph.Simulation.from_deck(CASES / deck)
    p0 = axial_momentum(sim.snapshot())
    for t in (4e-6, 12e-6, 25e-6):
        sim.advance(t)
        change = axial_momentum(sim.snapshot()) - p0
        assert change > 0.0     # the anvil stops the rod falling in -z
        assert abs(sim.plane_impulse_z() - change) <= bar * change


def test_force_history_in_the_run_files(tmp_path):
    """fsph.h5 history: plane_impulse_z [N s] and plane_force_z [N] with
    units; the force integrates back to the impulse, peaks at impact near
    the elastic-plastic estimate, and summary.json names the peak."""
    out = tmp_path / "run"
    deck = tmp_path / "short.nml"
    deck.write_text((CASES / "taylor_armco_fem.nml").read_text().replace(
        "end_time = 60.0e-6", "end_time = 10.0e-6").replace(
        "references/", str(CASES / "references") + "/"))
    summary = run(deck, out, quiet=True)
    with h5py.File(out / "fsph.h5") as h5:
        hist = h5["history"]
        assert hist["plane_impulse_z"].attrs["units"] == "N s"
        assert hist["plane_force_z"].attrs["units"] == "N"
        t, dt = hist["time"][:], hist["dt"][:]
        impulse, force = hist["plane_impulse_z"][:], hist["plane_force_z"][:]
    assert np.sum(force[1:] * np.diff(t - 0.5 * dt)) == pytest.approx(impulse[-1], rel=1e-12)
    planes = summary["rigid_planes"]
    assert planes["impulse_z_N_s"] == pytest.approx(impulse[-1], rel=1e-15)
    # at impact the face carries less than the uniaxial-strain elastic
    # load rho c_L v A (c_L from K = rho c0^2 and G of the library's Armco
    # iron) and more than the yield load Y A; 221 m/s, radius 3.8 mm
    from fsph.materials import LIBRARY
    m = LIBRARY["armco_iron"]
    c_l = np.sqrt(m["c0"] ** 2 + 4.0 * m["shear_modulus"] / (3.0 * m["density"]))
    area = np.pi * 3.8e-3 ** 2
    assert m["yield_stress"] * area < planes["peak_force_z_N"] < m["density"] * c_l * 221.0 * area
    assert planes["peak_force_time_s"] < 1e-6


def test_wall_force_of_the_elastic_bar_through_the_landing_steps(tmp_path):
    """The elastic bar on the wall: the wall carries sigma A = rho c0 v pi R^2
    while the wave runs up the bar, and the force of the last rows, whose
    steps the solver shortens to land on the end time, is that plateau too
    (not a rate over the rows' times, which the shortened steps do not
    match): the wall's and the bar's force rise by under 2 % from the row
    before the landing to each row of it, stay within 15 % of the plateau
    after the first rows (the impact) and the peaks of summary.json are
    not at the landing."""
    deck = tmp_path / "bar.nml"
    deck.write_text((CASES / "elastic_bar.nml").read_text().replace(
        "end_time = 3.0e-6", "end_time = 2.0e-6").replace(
        "n_snapshots = 6", "n_snapshots = 1\n  history_every = 2").replace(
        "references/", str(CASES / "references") + "/"))
    summary = run(deck, tmp_path / "run", quiet=True)
    with h5py.File(tmp_path / "run" / "fsph.h5") as h5:
        hist = h5["history"]
        t, dt = hist["time"][:], hist["dt"][:]
        impulse, wall = hist["plane_impulse_z"][:], hist["plane_force_z"][:]
        bar = h5["body_history/bar/force_z"][:]
    from fsph.materials import LIBRARY
    m = LIBRARY["steel_elastic_bar"]
    plateau = m["density"] * np.sqrt(m["youngs_modulus"] / m["density"]) * 50.0 * np.pi * 1e-3 ** 2
    # the impulse's rate over the times of the velocities integrates back
    assert np.sum(wall[1:] * np.diff(t - 0.5 * dt)) == pytest.approx(impulse[-1], rel=1e-12)
    landing = 1 + np.flatnonzero(dt[1:] < 0.9 * np.median(dt[1:]))
    assert len(landing) and landing[0] > 10
    before = landing[0] - 1
    for force in (wall, bar):
        assert np.all(np.abs(force[landing] / force[before] - 1.0) < 0.02)
        late = t > 0.5e-6
        assert np.mean(force[late]) == pytest.approx(plateau, rel=0.02)
        assert np.all(np.abs(force[late] / plateau - 1.0) < 0.15)
    for peak in (summary["rigid_planes"], summary["bodies"]["bar"]):
        assert peak["peak_force_time_s"] < t[landing[0]]
