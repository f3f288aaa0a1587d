"""OpenMP: the thread count honours OMP_NUM_THREADS, results do not depend
on it (force assembly through corner arrays, no atomics), and the adaptive
thread policy (fsph_threads) that changes it between cycles changes nothing
else."""

import os
import subprocess
import sys

import numpy as np
import pytest

from conftest import CASES

SCRIPT = """
import sys, numpy as np, fsph
from fsph.simulation import _api
sim = fsph.Simulation.from_deck(sys.argv[1])
if len(sys.argv) > 4:   # the governor's probe and exploitation times [s]
    _api.set_thread_policy(sim._run, 1, float(sys.argv[4]), float(sys.argv[5]))
sim.advance(float(sys.argv[2]))
snap = sim.snapshot()
use = sim.thread_use()
arrays = {"threads": fsph.threads(), "cycles": sim.cycle,
          "use": np.array([use.get(n, 0) for n in (1, 2)])}
for name, part in (("e", snap), ("p", snap.get("particles"))):
    if part is not None and "x" in part:
        arrays.update({name + "x": part["x"], name + "v": part["velocity"], name + "s": part["stress"]})
np.savez(sys.argv[3], **arrays)
"""


def run_with_threads(n, out, tmp_path, deck="taylor_armco_fem.nml", t_end="10e-6", policy="fixed",
                     timing=()):
    env = dict(os.environ, OMP_NUM_THREADS=str(n), FSPH_THREAD_POLICY=policy)
    subprocess.run([sys.executable, "-c", SCRIPT, str(CASES / deck), t_end, str(out), *timing],
                   check=True, env=env, cwd=tmp_path, timeout=300)
    return np.load(out)


def assert_same_fields(one, two):
    assert sorted(one.files) == sorted(two.files) and len(one.files) > 3
    for key in one.files:
        if key not in ("threads", "use"):
            assert np.array_equal(one[key], two[key]), key


@pytest.mark.parametrize("deck, t_end", [("taylor_armco_fem.nml", "10e-6"),
                                         ("taylor_armco_sph.nml", "10e-6"),
                                         ("taylor_armco.nml", "10e-6"),
                                         ("al_plate_508.nml", "12e-6")])
def test_thread_count_and_determinism(tmp_path, deck, t_end):
    """Bit-identical elements and particles on 1 and 2 threads: FEM, SPH,
    adaptive, and the perforation case (two bodies, slide lines,
    particle-element and particle-particle contact, conversion in both)."""
    one = run_with_threads(1, tmp_path / "one.npz", tmp_path, deck, t_end)
    two = run_with_threads(2, tmp_path / "two.npz", tmp_path, deck, t_end)
    assert int(one["threads"]) == 1
    assert int(two["threads"]) == 2
    # the fixed policy runs every cycle on all the threads
    assert list(two["use"]) == [0, int(two["cycles"])]
    assert_same_fields(one, two)


def test_artificial_stress_does_not_depend_on_the_thread_count(tmp_path):
    """The sphere onto the bumper with &sph artificial_stress = 0.3 (its
    per-particle tensor, the pair factor and its work in the energy
    equation): bit-identical particles on 1 and 2 threads to 2 us, when
    the cloud is in tension."""
    deck = tmp_path / "sphere_artificial_stress.nml"
    text = (CASES / "sphere_al_bumper.nml").read_text()
    assert "  artificial_stress = 0.1\n" in text          # the deck's own
    deck.write_text(text.replace("  artificial_stress = 0.1\n", "  artificial_stress = 0.3\n"))
    one = run_with_threads(1, tmp_path / "one.npz", tmp_path, deck, "2e-6")
    two = run_with_threads(2, tmp_path / "two.npz", tmp_path, deck, "2e-6")
    assert int(one["threads"]) == 1 and int(two["threads"]) == 2
    assert_same_fields(one, two)


def test_adaptive_policy_switching_every_cycle_changes_nothing(tmp_path):
    """The governor with zero probe and exploitation times switches between
    1 and 2 threads every cycle or two; the adaptive run (conversion,
    particles and elements) is bit-identical to the 1-thread run and books
    every cycle at one of the two counts."""
    one = run_with_threads(1, tmp_path / "one.npz", tmp_path, "taylor_armco.nml", "8e-6")
    mixed = run_with_threads(2, tmp_path / "mixed.npz", tmp_path, "taylor_armco.nml", "8e-6",
                             policy="adaptive", timing=("0", "0"))
    use = mixed["use"]
    assert use.sum() == int(mixed["cycles"]) and use.min() > 0.3 * use.sum()
    assert_same_fields(one, mixed)


def test_unknown_thread_policy_is_refused(tmp_path):
    """FSPH_THREAD_POLICY other than adaptive or fixed: exit 2, one line
    naming the variable and the values expected; `fsph info` shows the
    policy in force."""
    env = dict(os.environ, OMP_NUM_THREADS="1", FSPH_THREAD_POLICY="turbo")
    res = subprocess.run([sys.executable, "-m", "fsph", "run", str(CASES / "elastic_bar.nml"),
                          "-o", str(tmp_path / "out")], env=env, cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 2 and "Traceback" not in res.stderr
    line, = res.stderr.strip().splitlines()
    assert "FSPH_THREAD_POLICY" in line and "adaptive, fixed" in line and "'turbo'" in line
    env["FSPH_THREAD_POLICY"] = "fixed"
    res = subprocess.run([sys.executable, "-m", "fsph", "info"], env=env, cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0 and "thread policy: fixed" in res.stdout
