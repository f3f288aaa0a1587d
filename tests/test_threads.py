"""OpenMP: the thread count honours OMP_NUM_THREADS, and results do not
depend on it (force assembly through corner arrays, no atomics)."""

import os
import subprocess
import sys

import numpy as np

from conftest import CASES

SCRIPT = """
import sys, numpy as np, fsph
sim = fsph.Simulation.from_deck(sys.argv[1])
sim.advance(float(sys.argv[2]))
snap = sim.snapshot()
snap = snap.get("particles", snap)
np.savez(sys.argv[3], x=snap["x"], v=snap["velocity"], s=snap["stress"], threads=fsph.threads())
"""


def run_with_threads(n, out, tmp_path, deck="taylor_armco_fem.nml", t_end="10e-6"):
    env = dict(os.environ, OMP_NUM_THREADS=str(n))
    subprocess.run([sys.executable, "-c", SCRIPT, str(CASES / deck), t_end, str(out)],
                   check=True, env=env, cwd=tmp_path, timeout=300)
    return np.load(out)


import pytest


@pytest.mark.parametrize("deck", ["taylor_armco_fem.nml", "taylor_armco_sph.nml",
                                  "taylor_armco.nml"])
def test_thread_count_and_determinism(tmp_path, deck):
    one = run_with_threads(1, tmp_path / "one.npz", tmp_path, deck)
    two = run_with_threads(2, tmp_path / "two.npz", tmp_path, deck)
    assert int(one["threads"]) == 1
    assert int(two["threads"]) == 2
    for key in ("x", "v", "s"):
        assert np.array_equal(one[key], two[key]), key
