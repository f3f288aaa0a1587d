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
arrays = {"threads": fsph.threads()}
for name, part in (("e", snap), ("p", snap.get("particles"))):
    if part is not None and "x" in part:
        arrays.update({name + "x": part["x"], name + "v": part["velocity"], name + "s": part["stress"]})
np.savez(sys.argv[3], **arrays)
"""


def run_with_threads(n, out, tmp_path, deck="taylor_armco_fem.nml", t_end="10e-6"):
    env = dict(os.environ, OMP_NUM_THREADS=str(n))
    subprocess.run([sys.executable, "-c", SCRIPT, str(CASES / deck), t_end, str(out)],
                   check=True, env=env, cwd=tmp_path, timeout=300)
    return np.load(out)


import pytest


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
    assert sorted(one.files) == sorted(two.files) and len(one.files) > 1
    for key in one.files:
        if key != "threads":
            assert np.array_equal(one[key], two[key]), key
