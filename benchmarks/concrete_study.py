"""Ogive rod through the 178 mm slab of 48 MPa concrete (Hanchak et al.
1992): the 1058 m/s case in the three methods of table 1 of Hu et al. 2013 (FEM
with erosion, SPH, adaptive FEM-SPH: residual velocity, error against the
experiment's 947 m/s, relative wall time) and the 606 m/s case adaptive and
with fixed coupling (residual against 449 m/s, wall-time ratio
fixed/adaptive; Xiao et al. 2012: 167/59 min). Runs the decks (or reuses outputs in
--out) with the thread count of the environment, prints the tables, writes
JSON.

    OMP_NUM_THREADS=1 python benchmarks/concrete_study.py --out out/concrete \
        --json docs/concrete.json [--mesh-study]

--mesh-study also runs the 606 m/s adaptive case on a mesh refined by 1.6
in each direction (slab about 26 000 elements, near the 33 600 of Xiao et al. 2012) for
the convergence note.
"""

import argparse
import json
import os
from pathlib import Path

import numpy as np

from common import machine, machine_line, run_or_reuse
from common import refined_deck as common_refined_deck

CASES = Path(__file__).resolve().parents[1] / "cases"
#: deck, method label, the paper's residual velocity [m/s] and relative cost
RUNS_1058 = (("concrete_1058_fem", "FEM (erosion)", 956.598, 1.000),
             ("concrete_1058_sph", "SPH", 945.128, 4.128),
             ("concrete_1058", "FEM-SPH (adaptive)", 952.831, 2.831))
RUNS_606 = (("concrete_606", "adaptive", 464.0, 59.0), ("concrete_606_fixed", "fixed", 466.0, 167.0))
EXPERIMENT = {1058: 947.0, 606: 449.0}


#: (key, factor) of the mesh keys refined by --mesh-study, per body
REFINE = (("n_radial", 1.6), ("n_axial", 1.6), ("n_coarse", 1.25))


def refined_deck(deck, outdir):
    """A copy of `deck` in outdir with every body's cell counts refined
    (REFINE) and the reference path made absolute; returns its path."""
    return common_refined_deck(deck, outdir, REFINE, "fine")


def row(summary, experiment):
    v_r = summary["metrics"]["perforation"]["residual_velocity_m_s"]
    p = np.array(summary["metrics"]["series"]["momentum_z_N_s"])
    return {"status": summary["status"], "v_r": v_r,
            "error_percent": 100.0 * (v_r - experiment) / experiment,
            "wall_s": summary["wall_time_s"], "cycles": summary["cycles"],
            "threads": summary["threads"],
            "energy_error_end": summary["energy"]["relative_error"],
            "energy_error_max": summary["energy"]["max_relative_error"],
            "momentum_error": float(np.abs(p / p[0] - 1.0).max()),
            "n_elements": summary["n_elements_initial"], "n_particles_end": summary["n_particles"],
            "n_converted": summary["n_converted"],
            "n_eroded": summary.get("erosion", {}).get("n_eroded", 0)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/concrete")
    ap.add_argument("--json")
    ap.add_argument("--rerun", action="store_true", help="run even where outputs exist")
    ap.add_argument("--mesh-study", action="store_true",
                    help="also run the 606 m/s adaptive case on the refined mesh")
    args = ap.parse_args(argv)
    out = Path(args.out)
    info = machine()
    print(machine_line(info) + f"; OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'unset')}")

    result = {"machine": info}
    for velocity, runs in ((1058, RUNS_1058), (606, RUNS_606)):
        rows = {}
        for deck, label, paper_value, paper_cost in runs:
            summary = run_or_reuse(CASES / f"{deck}.nml", out / deck, args.rerun)
            rows[deck] = dict(row(summary, EXPERIMENT[velocity]), method=label,
                              paper_v_r=paper_value, paper_cost=paper_cost)
        base = rows[runs[0][0]]["wall_s"]
        print(f"\n{velocity} m/s (experiment {EXPERIMENT[velocity]:.0f} m/s)")
        print(f"{'method':>20s} {'v_r [m/s]':>10s} {'error':>7s} {'wall [s]':>9s} "
              f"{'relative':>8s} {'paper':>7s} {'E err max':>9s} {'momentum':>9s} {'status':>9s}")
        for deck, label, paper_value, paper_cost in runs:
            r = rows[deck]
            r["relative_wall"] = r["wall_s"] / base
            paper_rel = paper_cost / runs[0][3]
            print(f"{label:>20s} {r['v_r']:10.1f} {r['error_percent']:+6.1f}% {r['wall_s']:9.1f} "
                  f"{r['relative_wall']:8.2f} {paper_rel:7.2f} {r['energy_error_max']:+9.2%} "
                  f"{r['momentum_error']:9.1e} {r['status']:>9s}")
        result[str(velocity)] = rows
    if args.mesh_study:
        deck = refined_deck(CASES / "concrete_606.nml", out / "concrete_606_fine")
        fine = row(run_or_reuse(deck, out / "concrete_606_fine", args.rerun), EXPERIMENT[606])
        coarse = result["606"]["concrete_606"]
        print(f"\nmesh study, 606 m/s adaptive: {coarse['n_elements']} elements "
              f"{coarse['v_r']:.1f} m/s ({coarse['error_percent']:+.1f} %) in {coarse['wall_s']:.0f} s; "
              f"{fine['n_elements']} elements {fine['v_r']:.1f} m/s ({fine['error_percent']:+.1f} %) "
              f"in {fine['wall_s']:.0f} s")
        result["mesh_study_606"] = {"coarse": coarse, "fine": fine, "refinement": dict(REFINE)}
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=2) + "\n")
        print(f"\nwritten {args.json}")


if __name__ == "__main__":
    main()
