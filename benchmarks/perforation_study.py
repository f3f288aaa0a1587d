"""Ogive rod through the 26.3 mm 6061-T651 plate: residual velocity against
striking velocity (cases/al_plate_<v>.nml, adaptive), the Recht-Ipson fit,
and the 508 m/s case in pure SPH against adaptive (residual velocities and
wall times). Runs the decks (or reuses outputs in --out), prints a table,
writes JSON and a PNG.

    python benchmarks/perforation_study.py --out out/perforation \
        --json docs/perforation.json --png docs/img/al_plate_residual.png
"""

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from common import run_or_reuse
from fsph.ballistics import fit_recht_ipson, gather, recht_ipson
from fsph.plot import residual_velocity

CASES = Path(__file__).resolve().parents[1] / "cases"
VELOCITIES = (300, 400, 508, 650, 800)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/perforation")
    ap.add_argument("--json")
    ap.add_argument("--png")
    ap.add_argument("--rerun", action="store_true", help="run even where outputs exist")
    args = ap.parse_args(argv)
    out = Path(args.out)

    summaries = {}
    for v in VELOCITIES:
        summaries[v] = run_or_reuse(CASES / f"al_plate_{v}.nml", out / f"al_plate_{v}", args.rerun)
    sph = run_or_reuse(CASES / "al_plate_508_sph.nml", out / "al_plate_508_sph", args.rerun)

    rows = gather([out / f"al_plate_{v}" for v in VELOCITIES])
    v_s = np.array([r[0] for r in rows])
    v_r = np.array([r[1] for r in rows])
    fit = fit_recht_ipson(v_s, v_r, a=1.0, p=2.0)
    fit_free_a = fit_recht_ipson(v_s, v_r, a=None, p=2.0)

    print(f"{'v_s [m/s]':>10s} {'v_r [m/s]':>10s} {'R-I fit':>9s} {'wall [s]':>9s} "
          f"{'cycles':>7s} {'E err':>8s} {'momentum':>9s} {'converted':>9s}")
    table = []
    for v in VELOCITIES:
        s = summaries[v]
        perf = s["metrics"]["perforation"]
        p = np.array(s["metrics"]["series"]["momentum_z_N_s"])
        row = {"v_s": float(v), "v_r": perf["residual_velocity_m_s"],
               "fit": float(recht_ipson(v, fit["v_bl"])), "wall_s": s["wall_time_s"],
               "cycles": s["cycles"], "energy_error": s["energy"]["max_relative_error"],
               "momentum_error": float(np.abs(p / p[0] - 1.0).max()),
               "n_converted": s["n_converted"], "status": s["status"]}
        table.append(row)
        print(f"{v:10.0f} {row['v_r']:10.1f} {row['fit']:9.1f} {row['wall_s']:9.1f} "
              f"{row['cycles']:7d} {row['energy_error']:+8.2%} {row['momentum_error']:9.2e} "
              f"{row['n_converted']:9d}")
    print(f"Recht-Ipson (a = 1, p = 2): v_bl = {fit['v_bl']:.1f} m/s, rms residual "
          f"{fit['rms_residual']:.1f} m/s; a free: v_bl = {fit_free_a['v_bl']:.1f} m/s, "
          f"a = {fit_free_a['a']:.3f}, rms {fit_free_a['rms_residual']:.1f} m/s")
    v_a = summaries[508]["metrics"]["perforation"]["residual_velocity_m_s"]
    v_sph = sph["metrics"]["perforation"]["residual_velocity_m_s"]
    ratio = sph["wall_time_s"] / summaries[508]["wall_time_s"]
    print(f"508 m/s: adaptive {v_a:.1f} m/s in {summaries[508]['wall_time_s']:.1f} s, pure SPH "
          f"{v_sph:.1f} m/s ({(v_sph - v_a) / v_a:+.1%}) in {sph['wall_time_s']:.1f} s; "
          f"wall-time ratio SPH/adaptive {ratio:.2f} (Xiao et al. 2012: 71/20 min = 3.55)")

    result = {"runs": table, "recht_ipson": fit, "recht_ipson_free_a": fit_free_a,
              "sph_508": {"v_r": v_sph, "wall_s": sph["wall_time_s"],
                          "particles": sph["n_particles"]},
              "adaptive_508": {"v_r": v_a, "wall_s": summaries[508]["wall_time_s"]},
              "wall_ratio_sph_adaptive": ratio}
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=1) + "\n")
    if args.png:
        residual_velocity([("fsph adaptive", v_s, v_r),
                           ("fsph pure SPH (508 m/s)", [508.0], [v_sph])],
                          [(f"Recht-Ipson a=1, p=2: v_bl = {fit['v_bl']:.0f} m/s", fit)],
                          output=args.png, title="4340 ogive rod, 26.3 mm 6061-T651 plate")
    return 0


if __name__ == "__main__":
    sys.exit(main())
