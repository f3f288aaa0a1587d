"""SPH cycle benchmark: pure-SPH Armco rods of 1k, 4k and 16k particles at
the same spacing (0.19 mm, h = 1.3 spacing, about 21 neighbours) striking
the anvil at 221 m/s, EPP + Mie-Grueneisen, 200 cycles each, at 1 and 2
OpenMP threads. Prints microseconds per particle-cycle (neighbour search,
sums and stress update together) and writes JSON. O(N) means the figure
stays flat as N grows.

    python benchmarks/bench_sph.py [--cycles 200] [--repeat 3] [--json FILE]
"""

import argparse
import json
from pathlib import Path

from common import machine, machine_line, run_child

REPO = Path(__file__).resolve().parents[1]
SIZES = {1000: (20, 50), 4000: (40, 100), 16000: (80, 200)}   # particles: (n_radial, n_axial)
SPACING = 0.19e-3   # [m]

CHILD = r"""
import json, sys, time
import fsph
from fsph import deck as deck_module
deck = deck_module.load(sys.argv[1])
nr, nz, spacing, cycles, repeat = int(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4]), int(sys.argv[5]), int(sys.argv[6])
body = deck["body"][0]
body.update(n_radial=nr, n_axial=nz, radius=nr * spacing, length=nz * spacing)
best = None
for _ in range(repeat):
    sim = fsph.Simulation(deck)
    t0 = time.perf_counter()
    # advance by the stable step until `cycles` cycles are done
    while sim.cycle < cycles:
        sim.advance(sim.time + sim.dt * min(50, cycles - sim.cycle) * 0.999)
    t1 = time.perf_counter()
    row = {"particles": sim.n_particles, "cycles": sim.cycle, "advance_s": t1 - t0,
           "threads": fsph.threads()}
    if best is None or row["advance_s"] < best["advance_s"]:
        best = row
best["us_per_particle_cycle"] = best["advance_s"] / (best["cycles"] * best["particles"]) * 1e6
print(json.dumps(best))
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--deck", default=str(REPO / "cases" / "taylor_armco_sph.nml"))
    ap.add_argument("--cycles", type=int, default=200)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args()
    rows = []
    for n, (nr, nz) in SIZES.items():
        for threads in (1, 2):
            rows.append(run_child(CHILD, [args.deck, nr, nz, SPACING, args.cycles, args.repeat],
                                  threads))
    info = machine()
    print(machine_line(info))
    print(f"{'particles':>9s} {'threads':>7s} {'cycles':>6s} {'advance [s]':>11s} "
          f"{'us/particle-cycle':>17s}")
    for row in rows:
        print(f"{row['particles']:9d} {row['threads']:7d} {row['cycles']:6d} "
              f"{row['advance_s']:11.3f} {row['us_per_particle_cycle']:17.3f}")
    if args.json:
        Path(args.json).write_text(json.dumps({"deck": args.deck, "machine": info,
                                               "results": rows}, indent=2) + "\n")


if __name__ == "__main__":
    main()
