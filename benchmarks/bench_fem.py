"""FEM cycle benchmark: the Taylor rod (cases/taylor_armco_fem.nml) at 1 and
2 OpenMP threads. Prints wall time, cycles and ns per element-cycle and
writes JSON. Each thread count runs in its own process (OMP_NUM_THREADS is
read at start-up); the figure is the best of --repeat runs of the advance
loop alone (set-up and output excluded; Python is called once per output
interval, as in `fsph run`).

    python benchmarks/bench_fem.py [--deck DECK] [--repeat 3] [--json FILE]
"""

import argparse
import json
from pathlib import Path

from common import machine, machine_line, run_child

REPO = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, sys, time
import fsph
from fsph import deck as deck_module
deck = deck_module.load(sys.argv[1])
best = None
for _ in range(int(sys.argv[2])):
    t0 = time.perf_counter()
    sim = fsph.Simulation(deck)
    t1 = time.perf_counter()
    n_out = deck["output"]["n_snapshots"]
    t_end = deck["control"]["end_time"]
    for k in range(1, n_out + 1):
        sim.advance(t_end * k / n_out)
    t2 = time.perf_counter()
    row = {"setup_s": t1 - t0, "advance_s": t2 - t1, "cycles": sim.cycle,
           "elements": sim.n_elements, "threads": fsph.threads()}
    if best is None or row["advance_s"] < best["advance_s"]:
        best = row
best["ns_per_element_cycle"] = best["advance_s"] / (best["cycles"] * best["elements"]) * 1e9
print(json.dumps(best))
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--deck", default=str(REPO / "cases" / "taylor_armco_fem.nml"))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args()
    rows = [run_child(CHILD, [args.deck, args.repeat], n) for n in (1, 2)]
    info = machine()
    print(f"deck: {args.deck}")
    print(machine_line(info))
    print(f"{'threads':>7s} {'elements':>8s} {'cycles':>7s} {'advance [s]':>11s} "
          f"{'ns/elem-cycle':>13s} {'speed-up':>8s}")
    for row in rows:
        print(f"{row['threads']:7d} {row['elements']:8d} {row['cycles']:7d} "
              f"{row['advance_s']:11.3f} {row['ns_per_element_cycle']:13.1f} "
              f"{rows[0]['advance_s'] / row['advance_s']:8.2f}")
    if args.json:
        Path(args.json).write_text(json.dumps({"deck": args.deck, "machine": info,
                                               "results": rows}, indent=2) + "\n")


if __name__ == "__main__":
    main()
