"""Gauges (&gauge): time histories at points. The elastic bar's material
gauge records the analytic plateau and arrival; a material gauge is the
barycentric point of its element's nodes; a fixed gauge in empty space
is empty; a gauge by the Taylor rod's impact face moves to a particle when
its element converts and follows it; bad gauges stop the run with one
line; the records do not depend on the thread count."""

import json
import os
import subprocess
import sys

import h5py
import numpy as np
import pytest

import fsph
from fsph import deck as deck_module
from fsph import layouts

from conftest import CASES, rod_deck
from test_cli_errors import fsph_cli

FIELDS = [name for name, _, _ in layouts.GAUGE_COLUMNS]


def col(name):
    return FIELDS.index(name)


def case_deck(case, gauges, **changes):
    """The validated deck of cases/CASE.nml with the &gauge groups
    `gauges` and changes {group: {key: value}}."""
    groups = deck_module.groups_of(deck_module.load(CASES / f"{case}.nml"))
    groups["gauge"] = gauges
    for gname, keys in changes.items():
        groups[gname].update(keys)
    return deck_module.from_groups(groups, f"{case}.nml", CASES)


def run_gauges(deck, t_end):
    """Advance a run of `deck` to t_end [s]; its history times, gauge rows
    (k, gauges, columns) and the run."""
    sim = fsph.Simulation(deck)
    sim.advance(t_end)
    records, _, gauges = sim.drain_histories(gauges=True)
    return records[:, 0], gauges, sim


# ---- 1. the elastic bar (docs/validation.md, Elastic bar) -----------------
BAR_PLATEAU = 2.011e9       # rho c0 v [Pa], 1D bar theory
BAR_MID = 10.0e-3           # the gauge: mid-length, on the axis [m]
BAR_END = 5.5e-6            # before the free end's reflection is back at mid-length (5.86 us) [s]


def test_elastic_bar_gauge_records_the_plateau_and_the_arrival():
    """A material gauge at the bar's mid-length on the axis: the axial
    stress (stress_zz) reaches half the plateau within 2 % of the bar
    wave's time L/2 / c0, and its mean from 0.5 us after that to 5.5 us is
    the analytic 2.011 GPa within 2 % (the Pochhammer-Chree oscillations
    average out)."""
    deck = case_deck("elastic_bar", [{"name": "mid", "point": [0.0, BAR_MID]}],
                     control={"end_time": BAR_END}, output={"history_every": 1})
    material = deck["material"][0]
    c0 = np.sqrt(material["youngs_modulus"] / material["density"])
    t, gauges, _ = run_gauges(deck, BAR_END)
    stress = -gauges[:, 0, col("stress_zz")]
    assert np.all(gauges[:, 0, col("inside")] == 1.0)
    k = int(np.argmax(stress >= 0.5 * BAR_PLATEAU))
    assert k > 0
    arrival = t[k - 1] + (0.5 * BAR_PLATEAU - stress[k - 1]) * (t[k] - t[k - 1]) / (stress[k] - stress[k - 1])
    expected = BAR_MID / c0
    assert abs(arrival / expected - 1.0) < 0.02, (arrival, expected)
    window = (t >= arrival + 0.5e-6) & (t <= BAR_END)
    plateau = np.trapezoid(stress[window], t[window]) / (t[window][-1] - t[window][0])
    assert abs(plateau / BAR_PLATEAU - 1.0) < 0.02, plateau
    # before the wave (its dispersive precursor aside): still at -50 m/s, unstressed
    early = t < 0.7 * expected
    assert np.all(np.abs(gauges[early, 0, col("velocity_z")] + 50.0) < 0.01 * 50.0)
    assert np.all(np.abs(stress[early]) < 0.01 * BAR_PLATEAU)


# ---- 2. where a material gauge is; an empty fixed gauge -------------------
def barycentric(corners, point):
    """Barycentric weights (3,) of point in the triangle corners (3, 2)."""
    a, b = corners[1] - corners[0], corners[2] - corners[0]
    d = point - corners[0]
    det = a[0] * b[1] - a[1] * b[0]
    w2 = (d[0] * b[1] - d[1] * b[0]) / det
    w3 = (a[0] * d[1] - a[1] * d[0]) / det
    return np.array([1.0 - w2 - w3, w2, w3])


def test_material_gauge_is_its_element_point_and_empty_space_is_empty(tmp_path):
    """fsph run of a rod with a material gauge inside it, one on its axis
    and a fixed gauge beside it: in fsph.h5, at each snapshot's time, the
    material gauges' r and z are the barycentric interpolation of their
    element's nodes (weights from the t = 0 mesh) to round-off, and their
    velocity that of the nodal velocities; the fixed gauge is never
    inside, its fields NaN. Every gauge dataset has the rows of /history
    and its units; summary.json has the peak |pressure| and last values."""
    points = {"inner": (0.37e-3, 1.13e-3), "axis": (0.0, 2.5e-3), "air": (3.0e-3, 2.0e-3)}
    gauges = "".join(f"&gauge\n name = '{name}'\n point = {r!r}, {z!r}\n"
                     + (" kind = 'fixed'\n" if name == "air" else "") + "/\n"
                     for name, (r, z) in points.items())
    deck = tmp_path / "rod.nml"
    deck.write_text(rod_deck(control="end_time = 3.0e-6", output="n_snapshots = 3\n vtu = .false.")
                    + gauges)
    res = fsph_cli(["run", str(deck), "-o", str(tmp_path / "out"), "-q"], tmp_path)
    assert res.returncode == 0, res.stderr
    with h5py.File(tmp_path / "out" / "fsph.h5", "r") as h5:
        time = h5["history/time"][...]
        rows = {name: {f: h5[f"gauge_history/{name}/{f}"][...] for f in FIELDS} for name in points}
        for name in points:
            group = h5[f"gauge_history/{name}"]
            assert group.attrs["kind"] == ("fixed" if name == "air" else "material")
            assert np.array_equal(group.attrs["point"], points[name])
            # the group's numbers name their units as the datasets do
            assert group.attrs["point_units"] == "m" and group.attrs["time_units"] == "s"
            assert np.isnan(group.attrs["switch_time"]) and np.isnan(group.attrs["lost_time"])
            for f, unit, _ in layouts.GAUGE_COLUMNS:
                assert group[f].shape == time.shape and group[f].attrs["units"] == unit
        snaps = [h5[f"snapshots/{k}"] for k in sorted(h5["snapshots"]) if k.isdigit()]
        checked = 0
        for snap in snaps:
            x0, x = snap["nodes_initial"][...], snap["nodes"][...]
            v, conn = snap["velocity"][...], snap["connectivity"][...]
            row = int(np.flatnonzero(time == snap.attrs["time"])[-1])
            for name in ("inner", "axis"):
                point = np.array(points[name])
                for element in conn:
                    w = barycentric(x0[element], point)
                    if np.all(w >= -1e-10):
                        break
                else:
                    pytest.fail(f"no element holds {name}")
                got = np.array([rows[name]["r"][row], rows[name]["z"][row]])
                np.testing.assert_allclose(got, w @ x[element], rtol=1e-13, atol=1e-18)
                np.testing.assert_allclose([rows[name]["velocity_r"][row], rows[name]["velocity_z"][row]],
                                           w @ v[element], rtol=1e-12, atol=1e-12)
                checked += 1
        assert checked == 2 * len(snaps) and snaps[-1].attrs["time"] > 0.0
    assert np.ptp(rows["inner"]["z"]) > 1.0e-6   # it moves with the rod (not a fixed point)
    assert np.all(rows["axis"]["r"] == 0.0)   # on the axis it stays there
    air = rows["air"]
    assert np.all(air["inside"] == 0.0)
    assert np.all(air["r"] == points["air"][0]) and np.all(air["z"] == points["air"][1])
    for f in FIELDS:
        if f not in ("r", "z", "inside"):
            assert np.all(np.isnan(air[f])), f
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())["gauges"]
    inner = summary["inner"]
    k = int(np.argmax(np.abs(rows["inner"]["pressure"])))
    assert inner["peak_pressure_Pa"] == rows["inner"]["pressure"][k] != 0.0
    assert inner["peak_pressure_time_s"] == time[k]
    assert inner["last"]["z_m"] == rows["inner"]["z"][-1] and inner["switch_time_s"] is None
    assert summary["air"]["last"]["pressure_Pa"] is None and summary["air"]["peak_pressure_Pa"] is None
    # every last value's key names its unit, as fsph.h5's `units` does
    units = {name: unit for name, unit, _ in layouts.GAUGE_COLUMNS}
    assert set(inner["last"]) == {name if units[name] == "-" else
                                  f"{name}_{units[name].replace('/', '_').replace('^', '')}"
                                  for name in FIELDS}
    assert {"velocity_z_m_s", "density_kg_m3", "internal_energy_J_kg", "temperature_K",
            "plastic_strain"} <= set(inner["last"])


# ---- 3. the Taylor rod: an element that converts --------------------------
def test_taylor_gauge_moves_to_a_particle_when_its_element_converts():
    """Adaptive Armco rod to 15 us: the material gauge at (0.5 mm, 0.3 mm)
    by the impact face starts in an element at -221 m/s, moves to a
    particle when its element converts (the switch time recorded) and
    follows that particle (its rows are the particle's position and
    velocity), always inside; its axial velocity ends near rest. The run
    ends in the state of the run without the gauge, bit for bit."""
    deck = case_deck("taylor_armco", [{"name": "face", "point": [0.5e-3, 0.3e-3]}])
    t, gauges, sim = run_gauges(deck, 15.0e-6)
    state = sim.gauge_state()["face"]
    assert state["on"] == "particle" and state["lost_time"] is None
    switch = state["switch_time"]
    assert 0.0 < switch < 15.0e-6
    rows = gauges[:, 0]
    assert np.all(rows[:, col("inside")] == 1.0)
    assert rows[0, col("velocity_z")] == -221.0
    assert abs(rows[-1, col("velocity_z")]) < 0.1 * 221.0
    assert np.all(np.isfinite(rows))
    part = sim.snapshot()["particles"]
    i = state["index"]
    assert np.array_equal(rows[-1, [col("r"), col("z")]], part["x"][i])
    assert np.array_equal(rows[-1, [col("velocity_r"), col("velocity_z")]], part["velocity"][i])
    assert rows[-1, col("plastic_strain")] == part["plastic_strain"][i] > 0.4
    # the gauge only reads: the run ends in the state of the run without it
    from fsph.checkpoint import state_digest
    _, _, plain = run_gauges(case_deck("taylor_armco", []), 15.0e-6)
    assert state_digest(sim) == state_digest(plain)


# ---- 4. bad gauges ---------------------------------------------------------
@pytest.mark.parametrize("gauges, fragments", [
    ("&gauge name = 'a' point = 0.0, 1.0e-3 /\n&gauge name = 'b' point = 2.0e-3, 1.0e-3 /\n",
     ["&gauge #2 key 'point'", "a point inside a body at t = 0", "[0.002, 0.001]"]),
    ("&gauge name = 'a' point = 0.0, 1.0e-3 /\n&gauge name = 'a' point = 0.5e-3, 1.0e-3 /\n",
     ["&gauge #2 key 'name'", "a name not used by another &gauge", "'a'"]),
])
def test_bad_gauges_stop_with_one_line(tmp_path, gauges, fragments):
    """A material gauge outside every body at t = 0 and two gauges of one
    name: exit 2, one line naming the file, the group and the key; no
    outputs."""
    deck = tmp_path / "rod.nml"
    deck.write_text(rod_deck() + gauges)
    res = fsph_cli(["run", str(deck), "-o", str(tmp_path / "out")], tmp_path)
    assert res.returncode == 2, res.stdout + res.stderr
    assert "Traceback" not in res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "rod.nml" in lines[0], res.stderr
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    assert not (tmp_path / "out" / "fsph.h5").exists()


# ---- 5. threads ------------------------------------------------------------
SCRIPT = """
import sys, numpy as np, fsph
from fsph import deck as dm
groups = dm.groups_of(dm.load(sys.argv[1]))
groups["gauge"] = [{"name": "face", "point": [0.5e-3, 0.3e-3]},
                   {"name": "shank", "point": [3.0e-3, 10.0e-3]},
                   {"name": "bulge", "point": [4.5e-3, 0.5e-3], "kind": "fixed"},
                   {"name": "anvil", "point": [2.0e-3, 0.2e-3], "kind": "fixed"}]
sim = fsph.Simulation(dm.from_groups(groups, sys.argv[1], sys.argv[4]))
rows = []
for step in range(1, 5):
    sim.advance(float(sys.argv[2]) * step / 4)
    rows.append(sim.drain_histories(gauges=True)[2])
np.save(sys.argv[3], np.concatenate(rows))
print(fsph.threads())
"""


def test_gauge_histories_do_not_depend_on_the_thread_count(tmp_path):
    """The adaptive Taylor rod to 10 us with material and fixed gauges
    (elements, a conversion switch, particles, empty space): the gauge
    histories on 2 threads equal those on 1 bit for bit, NaN included."""
    out = {}
    for n in (1, 2):
        env = dict(os.environ, OMP_NUM_THREADS=str(n), FSPH_THREAD_POLICY="fixed")
        res = subprocess.run([sys.executable, "-c", SCRIPT, str(CASES / "taylor_armco.nml"), "10e-6",
                              str(tmp_path / f"g{n}.npy"), str(CASES)],
                             env=env, cwd=tmp_path, capture_output=True, text=True, timeout=300)
        assert res.returncode == 0, res.stderr
        assert res.stdout.split() == [str(n)]
        out[n] = np.load(tmp_path / f"g{n}.npy")
    assert out[1].shape[1:] == (4, len(FIELDS)) and len(out[1]) > 50
    assert np.array_equal(out[1], out[2], equal_nan=True)
    inside = out[1][:, :, col("inside")]
    assert inside[:, [0, 1, 3]].all()
    # the bulge gauge starts beyond the rod's radius and is reached by its mushrooming face
    assert inside[0, 2] == 0.0 and inside[-1, 2] == 1.0


# ---- restart ---------------------------------------------------------------
def test_gauges_are_located_again_after_a_restart(tmp_path):
    """Gauges are not in a checkpoint: a restart locates them from the
    deck. A material gauge whose element is still there and a fixed gauge
    then record after the checkpoint exactly what the uninterrupted run
    records; the face gauge, whose element converted before the
    checkpoint, follows a particle (inside) without the switch time."""
    from fsph import checkpoint
    deck = case_deck("taylor_armco", [{"name": "face", "point": [0.5e-3, 0.3e-3]},
                                      {"name": "shank", "point": [3.0e-3, 10.0e-3]},
                                      {"name": "bulge", "point": [4.5e-3, 0.5e-3], "kind": "fixed"}])
    sim = fsph.Simulation(deck)
    sim.advance(6.0e-6, land=False)
    first = sim.drain_histories(gauges=True)
    path = checkpoint.save(sim, tmp_path / "ckpt.h5")
    assert sim.gauge_state()["face"]["switch_time"] is not None
    sim.advance(10.0e-6, land=False)
    after = sim.drain_histories(gauges=True)
    restarted = fsph.Simulation(deck)
    checkpoint.restore(restarted, path)
    state = restarted.gauge_state()
    assert state["face"]["on"] == "particle" and state["face"]["switch_time"] is None
    assert state["shank"]["on"] == "element"
    restarted.advance(10.0e-6, land=False)
    again = restarted.drain_histories(gauges=True)
    assert np.array_equal(after[0], again[0]) and first[0][-1, 0] < again[0][0, 0]
    assert np.array_equal(after[2][:, 1:], again[2][:, 1:], equal_nan=True)
    assert np.all(again[2][:, 0, col("inside")] == 1.0)
