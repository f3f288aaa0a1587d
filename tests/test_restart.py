"""Checkpoint and restart: a run restarted from a checkpoint continues bit
for bit like the uninterrupted run, across conversion events."""

import numpy as np
import pytest

import fsph
from fsph.errors import FsphError
from fsph import checkpoint
from conftest import CASES


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

    def spy(sim, path):
        written = original(sim, path)
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
        assert h5.attrs["format"] == 3


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
    a, b, c = (_final_arrays(tmp_path / d) for d in ("plain", "every", "resumed"))
    assert a.keys() == b.keys() == c.keys() and "p_x" in a
    for key in a:
        assert np.array_equal(a[key], b[key]), key
        assert np.array_equal(a[key], c[key]), key


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
