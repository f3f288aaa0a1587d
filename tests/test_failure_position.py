"""Where a failure is: the 26.3 mm plate deck with half the cells in each
direction at the striking velocities that once failed, and runaway nodes
and particles (a velocity or position flung far off, as a run that goes
bad produces them) whose diagnostic once put them at r = -2.9e216 mm or
r = -inf mm. Every position a diagnostic prints is finite and inside the
bodies; one that is not known is said to be unknown."""

import json
import math
import os
import re
import subprocess
import sys

import numpy as np
import pytest

import fsph
from fsph import deck as deck_module
from fsph import layouts, verify
from fsph.errors import SimulationError
from fsph.checkpoint import set_state_array, state_array
from conftest import CASES

# the plate deck's cells, halved: (key, value in the deck, halved), in file order
HALVED = (("n_radial", 8, 4), ("n_axial", 84, 42), ("n_radial", 30, 15), ("n_coarse", 24, 12),
          ("n_axial", 30, 15))
# the bodies' box at set-up [mm]: the plate (r to 152, z -26.3 to 0) and the
# rod above it (z 0.1 to 89)
R_MAX_MM, Z_MIN_MM, Z_MAX_MM = 152.0, -26.3, 89.0
POSITION = re.compile(r"at r = (\S+) mm, z = (\S+) mm")


def half_plate_deck(velocity):
    """Text of cases/al_plate_508.nml with half the cells in each direction
    and the rod striking at `velocity` [m/s]."""
    text = (CASES / "al_plate_508.nml").read_text()
    pos = 0
    for key, value, halved in HALVED:
        match = re.compile(rf"^(\s*{key}\s*=\s*){value}\s*$", re.M).search(text, pos)
        assert match, (key, value)
        text = text[:match.start()] + f"{match.group(1)}{halved}" + text[match.end():]
        pos = match.start()
    text, n = re.subn(r"velocity_z\s*=\s*-508\.0", f"velocity_z = {-float(velocity)!r}", text)
    assert n == 1
    return text


def assert_positions_real(message, reach_mm):
    """Every position the diagnostic prints is finite and inside the
    bodies' box at set-up widened by reach_mm [mm]; returns them."""
    found = [(float(r), float(z)) for r, z in POSITION.findall(message)]
    for r, z in found:
        assert math.isfinite(r) and math.isfinite(z), message
        assert -reach_mm <= r <= R_MAX_MM + reach_mm, message
        assert Z_MIN_MM - reach_mm <= z <= Z_MAX_MM + reach_mm, message
    return found


@pytest.mark.parametrize("velocity", [500, 700])
def test_half_cell_plate_completes_or_stops_at_a_real_place(velocity, tmp_path):
    """The plate with half the cells at 500 and 700 m/s (both once failed,
    one diagnostic at r = -2.9e216 mm): the run completes with its energy
    error within the deck's warning, or stops (exit 3) naming a place
    inside the bodies (the box at set-up widened by the distance the rod
    covers at its striking speed by then)."""
    deck = tmp_path / f"half_{velocity}.nml"
    deck.write_text(half_plate_deck(velocity))
    warning = deck_module.load(deck)["control"]["energy_error_warning"]
    out = tmp_path / "out"
    res = subprocess.run([sys.executable, "-m", "fsph", "run", str(deck), "-o", str(out), "-q"],
                         cwd=tmp_path, env=dict(os.environ, OMP_NUM_THREADS="1"),
                         capture_output=True, text=True, timeout=600)
    assert "Traceback" not in res.stderr
    summary = json.loads((out / "summary.json").read_text())
    if res.returncode == 0:
        assert summary["status"] == "completed"
        assert abs(summary["energy"]["max_relative_error"]) <= warning
    else:
        assert res.returncode == 3, res.stdout + res.stderr
        failure = summary["failure"]
        assert_positions_real(failure["message"], velocity * failure["time_s"] * 1e3)


def plate_at(write_deck, time=20.0e-6, velocity=700):
    """The half-cell plate run at `velocity` [m/s] advanced to `time` [s]:
    the rod's tip in the plate, elements of both bodies become particles."""
    sim = fsph.Simulation.from_deck(write_deck(half_plate_deck(velocity), "half_plate.nml"))
    sim.advance(time, land=False)
    assert sim.n_particles > 0
    return sim


def fail(sim, time=25.0e-6):
    """The SimulationError the run meets before `time` [s]."""
    with pytest.raises(SimulationError) as err:
        sim.advance(time, land=False)
    return err.value


def assert_unknown_position(err, what):
    """The diagnostic names `what`, says its position is unknown and gives
    where it started (inside the bodies); the error has no location."""
    message = str(err)
    assert f"{what}, position unknown (not finite or far outside the bodies), initially at r = " \
        in message, message
    assert len(assert_positions_real(message, 0.0)) == 1
    assert err.location is None


def test_runaway_node_is_not_placed(write_deck):
    """A node of the rod's tip given 1e9 m/s (a runaway force) tangles its
    elements at once: the inverted element is named, its position (once
    r = 1.1e+06 mm, with 1e100 m/s r = 1.1e+188 mm) is unknown, its start
    is given."""
    sim = plate_at(write_deck)
    snap = sim.snapshot()
    k = int(np.argmin(np.hypot(snap["x"][:, 0] - 3.0e-3, snap["x"][:, 1] + 10.0e-3)))
    v = snap["velocity"].copy()
    v[k] = (-0.7e9, 0.1e9)
    verify.set_velocities(sim, v)
    err = fail(sim)
    assert err.code == layouts.status_code("inverted_element")
    assert_unknown_position(err, f"element {err.index} of body 'projectile'")


def test_runaway_particle_is_not_placed(write_deck):
    """A plate particle given 1e9 m/s: the time step collapses on it, and
    the diagnostic (once r = 1.2e+08 mm) says its position is unknown; at
    1e200 m/s its state turns non-finite (once r = -inf mm), the same."""
    for speed, status in ((1.0e9, "dt_floor"), (1.0e200, "nonfinite_particle")):
        sim = plate_at(write_deck)
        part = sim.snapshot()["particles"]
        k = len(part["x"]) // 2
        v = part["velocity"].copy()
        v[k] = (-0.7 * speed, 0.1 * speed)
        verify.set_particle_motion(sim, part["x"], v)
        err = fail(sim)
        assert err.code == layouts.status_code(status)
        assert_unknown_position(err, f"particle {-err.index} of body 'plate'")


def test_particle_flung_across_the_axis_stops_cleanly(write_deck):
    """A plate particle at r = -2.9e213 m (the reported diagnostic's
    -2.9e216 mm): the neighbour search no longer overflows its cell indices
    on it (a segmentation fault), the axis guard stops the run and its
    diagnostic says the position is unknown. A particle far off the other
    way, beyond every grid, runs on alone."""
    for far in ((-2.9e213, 1.0e212), (2.9e213, -1.0e212)):
        sim = plate_at(write_deck)
        x = state_array(sim, "particles/x")
        k = x.shape[1] // 2
        x[:, k] = far
        set_state_array(sim, "particles/x", x)
        if far[0] < 0.0:
            err = fail(sim)
            assert err.code == layouts.status_code("particle_axis")
            assert err.index == -(k + 1)
            assert_unknown_position(err, f"particle {k + 1} of body 'plate'")
        else:
            sim.advance(21.0e-6, land=False)
            assert np.all(np.isfinite(sim.snapshot()["particles"]["x"]))
