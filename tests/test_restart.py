"""Checkpoint and restart: a run restarted from a checkpoint continues bit
for bit like the uninterrupted run, across conversion events."""

import json

import numpy as np
import pytest

import fsph
from fsph.errors import FsphError
from fsph import checkpoint, layouts
from conftest import CASES, REFERENCE_DIGESTS


def state(sim):
    snap = sim.snapshot()
    part = snap.get("particles", {})
    return {"x": snap.get("x"), "v": snap.get("velocity"), "s": snap.get("stress"),
            "px": part.get("x"), "pv": part.get("velocity"), "ps": part.get("stress"),
            "pe": part.get("internal_energy"), "cycle": sim.cycle, "time": sim.time,
            "conv": sim.conversion()["n_converted"], "energy": sim.energies()["total"]}


def test_restart_is_bit_for_bit_across_conversions(tmp_path):
    deck = CASES / "taylor_armco.nml"
    sim = fsph.Simulation.from_deck(deck)
    sim.advance(6e-6, land=False)
    before = sim.conversion()["n_converted"]
    path = checkpoint.save(sim, tmp_path / "ckpt.h5")
    sim.advance(10e-6, land=False)
    reference = state(sim)
    assert reference["conv"] > before      # conversions happen after the checkpoint

    restarted = fsph.Simulation.from_deck(deck)
    checkpoint.restore(restarted, path)
    assert restarted.cycle > 0
    restarted.advance(10e-6, land=False)
    again = state(restarted)
    for key, value in reference.items():
        if isinstance(value, np.ndarray):
            assert np.array_equal(value, again[key]), key
        else:
            assert value == again[key], key


def _final_arrays(out):
    import h5py
    with h5py.File(out / "fsph.h5") as h5:
        snaps = h5["snapshots"]
        last = snaps[sorted(snaps)[-1]]
        arrays = {"time": last.attrs["time"]}
        for name in ("nodes", "velocity", "stress"):
            if name in last:
                arrays[name] = last[name][...]
        if "particles" in last:
            for name in ("x", "velocity", "stress"):
                arrays["p_" + name] = last["particles"][name][...]
    return arrays


def test_interrupted_run_restarts_to_the_same_end(tmp_path):
    """SIGINT during `fsph run`: exit code 4, a checkpoint and an
    'interrupted' summary; `fsph run --restart` from it ends in the same
    state, bit for bit, as the uninterrupted run."""
    import json
    import os
    import signal
    import subprocess
    import sys
    import time

    deck = CASES / "taylor_armco.nml"
    env = dict(os.environ, OMP_NUM_THREADS="1")
    cmd = [sys.executable, "-m", "fsph", "run", str(deck), "-q", "-o"]
    full = tmp_path / "full"
    subprocess.run(cmd + [str(full)], check=True, env=env, cwd=tmp_path, timeout=600)

    part = tmp_path / "part"
    proc = subprocess.Popen(cmd + [str(part)], env=env, cwd=tmp_path)
    deadline = time.time() + 300
    while not (part / "checkpoint.h5").exists() and time.time() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)
    proc.send_signal(signal.SIGINT)
    assert proc.wait(timeout=300) == 4
    summary = json.loads((part / "summary.json").read_text())
    assert summary["status"] == "interrupted"
    assert 0 < summary["end_time_s"] < 60e-6

    resumed = tmp_path / "resumed"
    subprocess.run(cmd + [str(resumed), "--restart", str(part / "checkpoint.h5")], check=True,
                   env=env, cwd=tmp_path, timeout=600)
    a, b = _final_arrays(full), _final_arrays(resumed)
    assert a.keys() == b.keys()
    for key in a:
        assert np.array_equal(a[key], b[key]), key
    # the whole state, books included, through the summaries' digests
    digests = [json.loads((d / "summary.json").read_text())["state_digest"] for d in (full, resumed)]
    assert digests[0] == digests[1]
    assert digests[1] in REFERENCE_DIGESTS["taylor_armco"]


def _short_taylor(tmp_path, name, output=""):
    """The adaptive Taylor deck cut to 4 us (about 250 cycles, conversions
    from cycle 35 on) with one snapshot, extra &output keys appended."""
    text = (CASES / "taylor_armco.nml").read_text().replace(
        "  n_snapshots = 16", "  n_snapshots = 1\n" + output)
    text = text.replace("end_time = 60.0e-6", "end_time = 4.0e-6")
    deck = tmp_path / f"{name}.nml"
    deck.write_text(text)
    refs = tmp_path / "references"
    refs.mkdir(exist_ok=True)
    (refs / "taylor_armco.json").write_text(
        (CASES / "references" / "taylor_armco.json").read_text())
    return deck


def _run_watching_checkpoints(deck, out, keep=None):
    """Run `deck` into `out`; returns the summary and the cycles at which
    checkpoints were written (each copied to keep/ckpt_<cycle>.h5 if keep
    is given)."""
    import shutil
    from fsph.driver import run
    seen = []
    original = checkpoint.save

    def spy(sim, path, *books):
        written = original(sim, path, *books)
        seen.append(sim.cycle)
        if keep is not None:
            shutil.copy(written, keep / f"ckpt_{sim.cycle}.h5")
        return written

    checkpoint.save = spy
    try:
        summary = run(deck, out, quiet=True)
    finally:
        checkpoint.save = original
    return summary, seen


def test_wall_clock_checkpoints(tmp_path):
    """checkpoint_minutes: a checkpoint appears before the first snapshot is
    due when the wall-clock interval is short (500-cycle granularity)."""
    import h5py
    deck = _short_taylor(tmp_path, "taylor", "  checkpoint_minutes = 1.0e-9\n")
    summary, seen = _run_watching_checkpoints(deck, tmp_path / "out")
    assert summary["status"] == "completed"
    assert len(seen) >= 2 and seen[0] < summary["cycles"]
    with h5py.File(tmp_path / "out" / "checkpoint.h5") as h5:
        assert h5.attrs["format"] == checkpoint.FORMAT


def test_cycle_checkpoints_restart_bit_for_bit(tmp_path):
    """checkpoint_cycles = 100: checkpoints at cycles 100 and 200 (then the
    end snapshot's), the trajectory is the same as without them, and a
    restart from the cycle-100 checkpoint ends in the same state, bit for
    bit, as the uninterrupted run."""
    from fsph.driver import run

    plain = run(_short_taylor(tmp_path, "plain"), tmp_path / "plain", quiet=True)
    deck = _short_taylor(tmp_path, "every", "  checkpoint_cycles = 100\n")
    summary, seen = _run_watching_checkpoints(deck, tmp_path / "every", keep=tmp_path)
    assert summary["status"] == "completed"
    assert summary["cycles"] == plain["cycles"] > 200
    assert seen == [100, 200, summary["cycles"]]
    assert summary["n_converted"] > 0

    restored = fsph.Simulation.from_deck(deck)
    checkpoint.restore(restored, tmp_path / "ckpt_100.h5")
    assert restored.cycle == 100
    assert restored.conversion()["n_converted"] < summary["n_converted"]

    resumed = run(deck, tmp_path / "resumed", quiet=True, restart=tmp_path / "ckpt_100.h5")
    assert resumed["status"] == "completed" and resumed["cycles"] == plain["cycles"]
    # the largest energy error of the whole run, the part before the checkpoint included
    for key in ("max_relative_error", "max_relative_error_time_s", "relative_error"):
        assert resumed["energy"][key] == plain["energy"][key], key
    a, b, c = (_final_arrays(tmp_path / d) for d in ("plain", "every", "resumed"))
    assert a.keys() == b.keys() == c.keys() and "p_x" in a
    for key in a:
        assert np.array_equal(a[key], b[key]), key
        assert np.array_equal(a[key], c[key]), key


def _history(out):
    """{group/field: column} of fsph.h5's history, bodies' and gauges'
    histories (the rows of /history)."""
    import h5py
    columns = {}
    with h5py.File(out / "fsph.h5") as h5:
        for group in ("history", "body_history", "gauge_history"):
            h5[group].visititems(lambda name, obj, g=group: columns.__setitem__(
                f"{g}/{name}", obj[...]) if hasattr(obj, "shape") else None)
    return columns


def test_a_restarted_run_reports_what_the_whole_run_does(tmp_path):
    """The short Taylor deck with a gauge at the impact face, restarted
    from its checkpoint at cycle 100 (after the impact's peak forces and
    pressure, and after neighbour lists were built), reports what the
    uninterrupted run reports: the anvil's and the rod's peak forces and
    their times, the gauge's peak pressure, the neighbour-list builds and
    the largest energy error. Its history rows are the uninterrupted
    run's after the checkpoint, bit for bit, the forces of the first row
    (rates from the row before the checkpoint) included."""
    from fsph.driver import run
    deck = _short_taylor(tmp_path, "every", "  checkpoint_cycles = 100\n")
    deck.write_text(deck.read_text() + "&gauge\n  name = 'face'\n  kind = 'fixed'\n"
                                       "  point = 1.0e-3, 1.0e-3\n/\n"
                                       "&gauge\n  name = 'edge'\n  kind = 'material'\n"
                                       "  point = 3.5e-3, 0.3e-3\n/\n")
    full, seen = _run_watching_checkpoints(deck, tmp_path / "full", keep=tmp_path)
    assert seen[0] == 100 and full["status"] == "completed"
    restored = fsph.Simulation.from_deck(deck)
    checkpoint.restore(restored, tmp_path / "ckpt_100.h5")
    resumed = run(deck, tmp_path / "resumed", quiet=True, restart=tmp_path / "ckpt_100.h5")
    assert resumed["state_digest"] == full["state_digest"]

    # what the continuation alone would miss happened before the checkpoint
    assert full["rigid_planes"]["peak_force_time_s"] < restored.time
    assert full["bodies"]["rod"]["peak_force_time_s"] < restored.time
    assert full["gauges"]["face"]["peak_pressure_time_s"] < restored.time
    # the material gauge's element converted before the checkpoint: it
    # follows the particle the whole run follows, from the same time on
    assert full["gauges"]["edge"]["switch_time_s"] < restored.time
    assert resumed["gauges"]["edge"] == full["gauges"]["edge"]
    assert 0 < restored.list_rebuilds < full["neighbour_list_builds"]
    for part in ("rigid_planes", ("bodies", "rod"), ("gauges", "face"), "energy"):
        a, b = full, resumed
        for key in part if isinstance(part, tuple) else (part,):
            a, b = a[key], b[key]
        for key in a:
            if "peak" in key or key.startswith("max_"):
                assert b[key] == a[key], (part, key)
    assert resumed["neighbour_list_builds"] == full["neighbour_list_builds"]
    # the whole run's cycles by thread count and phase times: the
    # continuation's added to those of the run before the checkpoint
    assert sum(resumed["cycles_by_threads"].values()) == resumed["cycles"] == full["cycles"]
    assert resumed["phase_times_s"].keys() == full["phase_times_s"].keys()
    before = _books(tmp_path / "ckpt_100.h5")["timing"]
    assert sum(before["cycles_by_threads"].values()) == 100
    assert resumed["wall_time_s"] == pytest.approx(resumed["wall_time_process_s"] + before["wall_time_s"],
                                                   abs=0.05)
    assert before["wall_time_s"] > 0.0 and resumed["wall_time_process_s"] > 0.0
    for name, t in before["phase_times_s"].items():
        assert resumed["phase_times_s"][name] >= t
    assert full["wall_time_s"] == full["wall_time_process_s"]

    whole, after = _history(tmp_path / "full"), _history(tmp_path / "resumed")
    assert whole.keys() == after.keys() and "history/plane_force_z" in whole
    first = np.searchsorted(whole["history/cycle"], 100, side="right")
    assert whole["history/cycle"][first - 1] == 100 and after["history/cycle"][0] > 100
    assert whole["history/plane_force_z"][first] != 0.0
    for name in whole:
        assert np.array_equal(whole[name][first:], after[name], equal_nan=True), name


def test_a_gauge_state_that_does_not_fit_is_refused(tmp_path, capsys):
    """A checkpoint whose books put a material gauge on a particle the
    state does not have, or on one of another body, is refused with one
    line (exit 2); unchanged, it restarts."""
    import h5py
    deck = _short_taylor(tmp_path, "gauge", "  checkpoint_cycles = 100\n")
    deck.write_text(deck.read_text() + "&gauge\n  name = 'edge'\n  kind = 'material'\n"
                                       "  point = 3.5e-3, 0.3e-3\n/\n")
    _, seen = _run_watching_checkpoints(deck, tmp_path / "full", keep=tmp_path)
    original = tmp_path / f"ckpt_{seen[0]}.h5"
    with h5py.File(original) as h5:
        books = json.loads(h5["books"][()])
    assert books["gauges"]["edge"]["on"] == "particle"
    for index in (10**6, -5):
        books["gauges"]["edge"]["index"] = index
        path = _copy(original, tmp_path)
        with h5py.File(path, "r+") as h5:
            _replace(h5, "books", json.dumps(books))
        line = _restart_refused(deck, path, tmp_path, capsys)
        assert "dataset /books" in line and "gauges that follow particles" in line and "edge" in line


def test_a_restarted_debris_run_keeps_its_series_and_measured_state(tmp_path):
    """Debris case 1 for its first 0.27 us (the plate a 10 mm disc, as
    tests/test_debris.py measures the interface state), restarted from its
    checkpoint at the snapshot at 0.18 us: the summary's snapshot series,
    debris record, impedance match with the state measured over the
    snapshots before and after the checkpoint, and neighbour-list builds
    are the uninterrupted run's; with &metrics changed the series begins
    at the checkpoint."""
    import f90nml
    from fsph.driver import run
    nml = f90nml.read(CASES / "debris_cu_al_1.nml")
    nml["output"].update(reference=str(CASES / nml["output"]["reference"]), n_snapshots=9, vtu=False)
    nml["control"]["end_time"] = 0.27e-6
    nml["body"][1].update(radius=10e-3, fine_radius=10e-3, n_radial=100, n_coarse=0)
    deck = tmp_path / "debris.nml"
    nml.write(deck)
    full, seen = _run_watching_checkpoints(deck, tmp_path / "full", keep=tmp_path)
    ckpt = tmp_path / f"ckpt_{seen[5]}.h5"          # at the sixth snapshot
    restored = fsph.Simulation.from_deck(deck)
    checkpoint.restore(restored, ckpt)
    resumed = run(deck, tmp_path / "resumed", quiet=True, restart=ckpt)
    assert resumed["state_digest"] == full["state_digest"]

    match = full["metrics"]["impedance_match"]
    assert match["measured_snapshots"] >= 3
    assert min(match["measured_times_us"]) < 1e6 * restored.time < max(match["measured_times_us"])
    assert len(full["metrics"]["series"]["time_us"]) == 10
    for key in ("series", "debris", "impedance_match"):
        assert resumed["metrics"][key] == full["metrics"][key], key
    assert resumed["neighbour_list_builds"] == full["neighbour_list_builds"]

    # a restart that changes &metrics (it may) begins its series at the checkpoint
    nml["metrics"]["front_fraction"] = 0.02
    nml.write(deck, force=True)
    changed = run(deck, tmp_path / "changed", quiet=True, restart=ckpt)["metrics"]["series"]["time_us"]
    assert changed == [1e6 * restored.time] + full["metrics"]["series"]["time_us"][7:]


def _books(path):
    """The run's books a checkpoint holds (the dataset /books, JSON)."""
    import h5py
    import json
    with h5py.File(path) as h5:
        return json.loads(h5["books"].asstr()[()])


def _set_books(path, books):
    """Replace the run's books of the checkpoint at `path`."""
    import h5py
    import json
    with h5py.File(path, "r+") as h5:
        del h5["books"]
        h5["books"] = json.dumps(books)


def test_largest_energy_error_survives_a_restart(tmp_path):
    """The largest energy error before the checkpoint (booked in it) is the
    whole run's largest when the continuation stays below it: summary and
    warning report it, at its time."""
    from fsph.driver import run
    deck = _short_taylor(tmp_path, "taylor")
    early = tmp_path / "early.nml"
    early.write_text(deck.read_text().replace("end_time = 4.0e-6", "end_time = 1.0e-6"))
    assert run(early, tmp_path / "early", quiet=True)["status"] == "completed"
    path = tmp_path / "early" / "checkpoint.h5"
    _set_books(path, dict(_books(path), max_energy_error=-0.2, max_energy_error_time=0.5e-6))
    summary = run(deck, tmp_path / "resumed", quiet=True, restart=path)
    assert summary["status"] == "completed"
    energy = summary["energy"]
    assert energy["max_relative_error"] == -0.2 and energy["max_relative_error_time_s"] == 0.5e-6
    assert abs(energy["relative_error"]) < 0.01
    assert any(w["kind"] == "energy_error" and w["value"] == -0.2 for w in summary["warnings"])


def _checkpoint_of(deck, tmp_path, t=1.0e-6):
    sim = fsph.Simulation.from_deck(deck)
    sim.advance(t)
    return checkpoint.save(sim, tmp_path / "ckpt.h5"), sim.cycle


def test_restart_refuses_another_deck(tmp_path):
    """A checkpoint restored into a run of another deck: one line naming
    the group and key that differ and the checkpoint (exit 2 from the
    command line); a change a restart may make is taken."""
    from fsph import cli
    deck = _short_taylor(tmp_path, "taylor")
    path, _ = _checkpoint_of(deck, tmp_path)
    faster = tmp_path / "faster.nml"
    faster.write_text(deck.read_text().replace("velocity_z = -221.0", "velocity_z = -250.0"))
    with pytest.raises(FsphError, match=r"faster.nml: &body #1 key 'velocity_z': expected -221.0 as "
                                        r"in the deck of the checkpoint .*ckpt.h5 \(a restart may change "
                                        r"only &control title, end_time"):
        checkpoint.restore(fsph.Simulation.from_deck(faster), path)
    other = tmp_path / "bar.nml"
    other.write_text((CASES / "elastic_bar.nml").read_text())
    assert cli.main(["run", str(other), "-q", "--restart", str(path), "-o",
                     str(tmp_path / "bar_out")]) == cli.EXIT_DECK == 2
    longer = tmp_path / "longer.nml"
    longer.write_text(deck.read_text().replace("end_time = 4.0e-6", "end_time = 5.0e-6")
                      .replace("n_snapshots = 1", "n_snapshots = 2"))
    restored = fsph.Simulation.from_deck(longer)
    checkpoint.restore(restored, path)
    assert restored.time > 0.9e-6


def test_restart_end_time_and_folders(tmp_path, capsys):
    """An end time at or before the checkpoint's is an error; the
    continuation goes to restart_<cycle> beside the checkpoint by default,
    and a folder holding a run's outputs is refused (nothing is
    overwritten)."""
    from fsph import cli
    from fsph.driver import run
    deck = _short_taylor(tmp_path, "taylor")
    first = run(deck, tmp_path / "first", quiet=True)
    assert first["status"] == "completed"
    ckpt = tmp_path / "first" / "checkpoint.h5"
    shutil_copy = (tmp_path / "first" / "fsph.h5").read_bytes()
    # the end-of-run checkpoint is at end_time: nothing is left to run
    assert cli.main(["run", str(deck), "-q", "--restart", str(ckpt)]) == 2
    assert "&control key 'end_time': expected a time after the checkpoint's" in capsys.readouterr().err
    path, cycle = _checkpoint_of(deck, tmp_path)
    assert cli.main(["run", str(deck), "-q", "--restart", str(path), "-o",
                     str(tmp_path / "first")]) == 2
    err = capsys.readouterr().err
    assert "holds no earlier run" in err and "fsph.h5, summary.json, checkpoint.h5" in err
    assert (tmp_path / "first" / "fsph.h5").read_bytes() == shutil_copy
    assert cli.main(["run", str(deck), "-q", "--restart", str(path)]) == 0
    resumed = tmp_path / f"restart_{cycle:07d}"
    assert (resumed / "summary.json").is_file() and (resumed / "fsph.h5").is_file()


def test_state_arrays_by_name():
    """One state array read and overwritten by its checkpoint name: the
    copy is the snapshot's field, a write reaches the solver, and an unknown
    name or a wrong shape is refused with the name and the expected shape."""
    sim = fsph.Simulation.from_deck(CASES / "taylor_armco.nml")
    v = checkpoint.state_array(sim, "nodes/v")
    assert v.shape == (2, sim.n_nodes)
    assert np.array_equal(v.T, sim.snapshot()["velocity"])
    checkpoint.set_state_array(sim, "nodes/v", 0.5 * v)
    assert np.array_equal(sim.snapshot()["velocity"], 0.5 * v.T)
    with pytest.raises(FsphError, match=rf"'nodes/v': expected the shape \(2, {sim.n_nodes}\)"):
        checkpoint.set_state_array(sim, "nodes/v", v[:, :-1])
    with pytest.raises(FsphError, match="unknown state array 'nodes/speed'"):
        checkpoint.state_array(sim, "nodes/speed")


def test_checkpoint_of_another_material_history_is_refused(tmp_path):
    """A checkpoint whose material history has another number of rows
    (written by a version before the history grew) is refused with the
    rows it has and the rows this version has, not restored."""
    import h5py
    from fsph import layouts
    deck = CASES / "taylor_armco.nml"
    sim = fsph.Simulation.from_deck(deck)
    path = checkpoint.save(sim, tmp_path / "ckpt.h5")
    rows = len(layouts.MATERIAL_HISTORY)
    with h5py.File(path, "r+") as h5:
        hist = h5["state/elements/hist"][...]
        del h5["state/elements/hist"]
        h5["state/elements/hist"] = hist[:rows - 2]
    with pytest.raises(FsphError, match=rf"'elements/hist' that fits this deck, got 'shape \({rows - 2}, "
                                        rf"{sim.n_elements}\): {rows - 2} material history rows where "
                                        rf"this version has {rows}"):
        checkpoint.restore(fsph.Simulation.from_deck(deck), path)


# --------------------------------------------------------------------------
# malformed checkpoints: exit 2, one line naming the file, the item and
# what was expected; nothing of them reaches the solver

@pytest.fixture(scope="module")
def adaptive_checkpoint(tmp_path_factory):
    """The short Taylor deck and its checkpoint at 3 us, after conversions:
    elements, particles, coupling edges and neighbour lists kept, so that
    it holds every dataset a restore reads."""
    tmp = tmp_path_factory.mktemp("checkpoint")
    deck = _short_taylor(tmp, "taylor")
    sim = fsph.Simulation.from_deck(deck)
    sim.advance(3.0e-6)
    return deck, checkpoint.save(sim, tmp / "ckpt.h5")


#: every dataset a restore reads
CHECKPOINT_DATASETS = (["books", "particle_radius0", "lists/particles_x", "lists/nodes_x",
                        "lists/elements_h", "lists/coupled_nodes"]
                       + [f"state/{name}" for name in layouts.CHECKPOINT_REAL + layouts.CHECKPOINT_INT])


def test_the_table_holds_every_dataset_of_a_checkpoint(adaptive_checkpoint):
    import h5py
    names = []
    with h5py.File(adaptive_checkpoint[1]) as h5:
        h5.visititems(lambda name, obj: names.append(name) if isinstance(obj, h5py.Dataset) else None)
    assert sorted(names) == sorted(CHECKPOINT_DATASETS)


def _restart_refused(deck, path, tmp_path, capsys):
    """The one line `fsph run DECK --restart PATH` prints, checking that it
    exits 2 with that line alone."""
    from fsph import cli
    code = cli.main(["run", str(deck), "-q", "--restart", str(path), "-o", str(tmp_path / "out")])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(lines) == 1, lines
    assert lines[0].startswith(f"fsph: error: {path}: ") and "expected" in lines[0], lines[0]
    return lines[0]


def _copy(original, tmp_path):
    import shutil
    path = tmp_path / "ckpt.h5"
    shutil.copy(original, path)
    return path


@pytest.mark.parametrize("name", CHECKPOINT_DATASETS)
def test_a_checkpoint_without_a_dataset_is_refused(name, adaptive_checkpoint, tmp_path, capsys):
    import h5py
    deck, original = adaptive_checkpoint
    path = _copy(original, tmp_path)
    with h5py.File(path, "r+") as h5:
        assert name in h5
        del h5[name]
    assert f": dataset /{name}: expected " in _restart_refused(deck, path, tmp_path, capsys)


def _replace(h5, name, values):
    del h5[name]
    h5[name] = values


def _books_with(h5, **changes):
    """Books of the form a run's checkpoint holds for the short Taylor
    deck's one body (no history row, no series yet), with `changes` made,
    as /books JSON."""
    body = json.loads(h5.attrs["deck"])["body"][0]["name"]
    books = {"metrics": {}, "max_energy_error": 0.0, "max_energy_error_time": 0.0,
             "plane_force_peak": [0.0, 0.0], "body_force_peaks": {body: [0.0, 0.0]},
             "gauges": {}, "last_row": None, "series": [],
             "timing": {"wall_time_s": 0.0, "phase_times_s": {}, "cycles_by_threads": {}}}
    books.update(changes)
    return json.dumps(books)


#: other damage: (what it does to the open checkpoint, what the line says)
CONN = "state/elements/conn"
MALFORMED = {
    "conn_of_another_shape": (lambda h5: _replace(h5, CONN, h5[CONN][:, :-1]),
                              [f"dataset /{CONN}", "an integer array of shape (3, ", "got 'shape (3, "]),
    "conn_of_reals": (lambda h5: _replace(h5, CONN, h5[CONN][...] * 1.0),
                      [f"dataset /{CONN}", "an integer array", "float64"]),
    "conn_beyond_the_nodes": (lambda h5: _replace(h5, CONN, h5[CONN][...] + 10**6),
                              [f"dataset /{CONN}", "of values from 1 to "]),
    "position_not_finite": (lambda h5: h5["state/nodes/x"].__setitem__((0, 5), np.nan),
                            ["dataset /state/nodes/x", "a real array", "nan at (0, 5)"]),
    "scalar_missing": (lambda h5: h5["scalars"].attrs.__delitem__("time"),
                       ["attribute 'time' of /scalars", "no such attribute"]),
    "step_not_positive": (lambda h5: h5["scalars"].attrs.__setitem__("dt", 0.0),
                          ["attribute 'dt' of /scalars", "> 0"]),
    "sizes_missing": (lambda h5: h5.attrs.__delitem__("sizes"), ["attribute 'sizes'", "no such attribute"]),
    "capacity_beyond_reason": (lambda h5: h5.attrs.__setitem__("sizes",
                                                               h5.attrs["sizes"] * [1, 1, 1, 9**9, 1]),
                               ["attribute 'sizes'", "particle capacity"]),
    "lists_missing": (lambda h5: h5.__delitem__("lists"), ["group /lists", "no such group"]),
    "books_not_json": (lambda h5: _replace(h5, "books", "{"), ["dataset /books", "a JSON object"]),
    "books_incomplete": (lambda h5: _replace(h5, "books", '{"max_energy_error": 0.0}'),
                         ["dataset /books", "the books of the run before the checkpoint, 'metrics'"]),
    "format_5": (lambda h5: h5.attrs.__setitem__("format", 5),
                 ["of format 9 (format 5 was written by an earlier fsph and lacks the books", "got 5"]),
    "format_6": (lambda h5: h5.attrs.__setitem__("format", 6),
                 ["of format 9 (format 6 was written by an earlier fsph and lacks the metric series keys",
                  "got 6"]),
    "format_7": (lambda h5: h5.attrs.__setitem__("format", 7),
                 ["of format 9 (format 7 was written by an earlier fsph and lacks the wall time, phase "
                  "times and cycles by thread count", "got 7"]),
    "format_8": (lambda h5: h5.attrs.__setitem__("format", 8),
                 ["of format 9 (format 8 was written by an earlier fsph and lacks the internal energy summed "
                  "at the start of a recent cycle", "got 8"]),
    "books_timing_negative": (lambda h5: _replace(h5, "books", _books_with(
        h5, timing={"wall_time_s": -1.0, "phase_times_s": {}, "cycles_by_threads": {}})),
                              ["dataset /books", "'timing' {wall_time_s, phase_times_s"]),
    "books_nan": (lambda h5: _replace(h5, "books", _books_with(h5, max_energy_error=float("nan"))),
                  ["dataset /books", "'max_energy_error' a number"]),
    "books_series_mixed": (lambda h5: _replace(h5, "books", _books_with(
        h5, series=[{"time_us": 1.0, "momentum_z": 0.0}, {"time_us": 2.0, "momentum_z_N_s": 0.0}])),
                           ["dataset /books", "'series' a list of snapshot records with the same keys"]),
}


@pytest.mark.parametrize("name", sorted(MALFORMED))
def test_a_malformed_checkpoint_is_refused(name, adaptive_checkpoint, tmp_path, capsys):
    import h5py
    deck, original = adaptive_checkpoint
    path = _copy(original, tmp_path)
    damage, fragments = MALFORMED[name]
    with h5py.File(path, "r+") as h5:
        damage(h5)
    line = _restart_refused(deck, path, tmp_path, capsys)
    for fragment in fragments:
        assert fragment in line, line


def test_a_file_that_is_not_a_checkpoint_is_refused(adaptive_checkpoint, tmp_path, capsys):
    deck, _ = adaptive_checkpoint
    path = tmp_path / "ckpt.h5"
    path.write_text("not HDF5")
    assert "expected a readable fsph checkpoint (HDF5)" in _restart_refused(deck, path, tmp_path, capsys)


@pytest.mark.parametrize("damage", ["delete", "shape"])
def test_a_checkpoint_without_its_connectivity_is_one_line_not_a_crash(damage, adaptive_checkpoint,
                                                                       tmp_path):
    """A checkpoint without state/elements/conn (or with too few columns)
    crashed the solver: through the command line it is one line, exit 2."""
    import h5py
    import os
    import subprocess
    import sys
    deck, original = adaptive_checkpoint
    path = _copy(original, tmp_path)
    with h5py.File(path, "r+") as h5:
        conn = h5["state/elements/conn"][...]
        del h5["state/elements/conn"]
        if damage == "shape":
            h5["state/elements/conn"] = conn[:, :-1]
    res = subprocess.run([sys.executable, "-m", "fsph", "run", str(deck), "-q", "--restart", str(path),
                          "-o", str(tmp_path / "out")], capture_output=True, text=True, timeout=300,
                         env=dict(os.environ, OMP_NUM_THREADS="1"), cwd=tmp_path)
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in res.stderr
    assert str(path) in lines[0] and "dataset /state/elements/conn" in lines[0]
