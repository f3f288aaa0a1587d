"""Taylor-rod mesh study: adaptive FEM-SPH at 10 x 67 and 20 x 134
quadrilaterals (x 4 triangles), with pure FEM and pure SPH at the same
resolutions (the SPH lattice has as many particles as there are triangles).
Prints a table and writes JSON; the table goes into docs/validation.md.

    python benchmarks/mesh_study.py [--json FILE] [--fine]
"""

import argparse
import json
import time
from pathlib import Path

import fsph
from fsph import deck as deck_module
from fsph import metrics

REPO = Path(__file__).resolve().parents[1]
EXPERIMENT = {"L_mm": 19.8, "D_mm": 13.7, "W_mm": 8.6}
# mode: (deck, lattice factor: particles per quadrilateral side)
MODES = {"adaptive": ("taylor_armco.nml", 1), "fem": ("taylor_armco_fem.nml", 1),
         "sph": ("taylor_armco_sph.nml", 2)}


def run(mode, n_radial, n_axial, end_time=60e-6):
    deck = deck_module.load(REPO / "cases" / MODES[mode][0])
    k = MODES[mode][1]
    deck["body"][0].update(n_radial=k * n_radial, n_axial=k * n_axial)
    deck["control"]["end_time"] = end_time
    t0 = time.perf_counter()
    sim = fsph.Simulation(deck)
    status = "completed"
    try:
        for i in range(1, 13):
            sim.advance(end_time * i / 12, land=(i == 12))
    except fsph.SimulationError as err:
        status = f"failed: {err}"
    wall = time.perf_counter() - t0
    taylor = metrics.case_metrics(sim.snapshot(), deck)["taylor"]
    errors = {k: 100.0 * (taylor[k] - v) / v for k, v in EXPERIMENT.items()}
    return {"mode": mode, "mesh": f"{n_radial} x {n_axial}", "status": status,
            "time_us": sim.time * 1e6, "cycles": sim.cycle, "wall_s": wall,
            "threads": fsph.threads(), "n_elements_initial": sim.n_elements0,
            "n_particles": sim.n_particles, "n_converted": sim.conversion()["n_converted"],
            "energy_error": sim.energies()["relative_error"],
            **{k: float(taylor[k]) for k in EXPERIMENT},
            "mean_error_percent": sum(abs(e) for e in errors.values()) / 3}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json")
    args = ap.parse_args()
    rows = []
    for nr, nz in ((10, 67), (20, 134)):
        for mode in MODES:
            row = run(mode, nr, nz)
            rows.append(row)
            print(f"{row['mode']:9s} {row['mesh']:9s} L {row['L_mm']:6.2f} D {row['D_mm']:6.2f} "
                  f"W {row['W_mm']:5.2f} mean {row['mean_error_percent']:4.1f} % "
                  f"E {100 * row['energy_error']:+5.1f} % conv {row['n_converted']:5d} "
                  f"cycles {row['cycles']:6d} wall {row['wall_s']:7.1f} s  {row['status'][:60]}",
                  flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()
