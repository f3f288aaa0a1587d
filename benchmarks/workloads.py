"""What benchmarks/suite.py measures, each run in a child process of its own
(OMP_NUM_THREADS is read once at start-up, and the peak memory is the
child's). A child prints one JSON object on its last line:

    python workloads.py block '{"kind": "fem", "n_radial": 50, ...}'
    python workloads.py run '{"deck": "cases/taylor_armco.nml", "outdir": ...}'

block: a large rod of T3 elements (fem), updated particles (sph) or
total-Lagrangian particles (tlsph; tlsph_selected: on the selected-particle
stencil) at the spacing
of the Taylor decks striking the anvil at 221 m/s (Armco iron, EPP +
Mie-Grueneisen), advanced `cycles` cycles after `warmup` cycles; the figure
is the wall time of the advance loop per element- or particle-cycle, with
the time of each phase of the cycle (fsph_timers).

run: `fsph run DECK -o OUTDIR --quiet` in this process, as a user runs it;
the wall time counts from the process start (interpreter, imports, set-up,
outputs), and the summary's cycles and phase times come with it.
"""

import json
import resource
import sys
import time
from pathlib import Path

T_START = time.perf_counter()

REPO = Path(__file__).resolve().parents[1]
BLOCK_DECKS = {"fem": REPO / "cases" / "taylor_armco_fem.nml",
               "sph": REPO / "cases" / "taylor_armco_sph.nml",
               "tlsph": REPO / "cases" / "taylor_armco_tlsph.nml"}


def peak_rss_mb():
    """Peak resident memory of this process [MB]: VmHWM of /proc/self/status,
    which starts afresh at exec (getrusage's ru_maxrss keeps the peak of
    the parent the child was forked from)."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return float(line.split()[1]) / 1024.0
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def block(kind, n_radial, n_axial, cycles, warmup=5):
    import fsph
    from fsph import deck as deck_module
    deck = deck_module.load(BLOCK_DECKS["tlsph" if kind == "tlsph_selected" else kind])
    if kind == "tlsph_selected":
        deck["sph"]["total_stencil"] = "selected"
    body = deck["body"][0]
    spacing = body["radius"] / body["n_radial"]
    body.update(n_radial=n_radial, n_axial=n_axial, radius=n_radial * spacing,
                length=n_axial * spacing)
    rss_before = peak_rss_mb()
    t0 = time.perf_counter()
    sim = fsph.Simulation(deck)
    t1 = time.perf_counter()
    sim.advance(1.0, max_cycles=warmup, partial=True)
    sim.reset_phase_times()
    c0 = sim.cycle
    t2 = time.perf_counter()
    sim.advance(1.0, max_cycles=cycles, partial=True)
    t3 = time.perf_counter()
    n_items = sim.n_elements if kind == "fem" else sim.n_particles
    n_cycles = sim.cycle - c0
    per_item_cycle = (t3 - t2) / (n_cycles * n_items)
    return {"kind": kind, "items": n_items, "cycles": n_cycles, "setup_s": t1 - t0,
            "advance_s": t3 - t2, "ns_per_item_cycle": per_item_cycle * 1e9,
            "phases_s": sim.phase_times(), "threads": fsph.threads(),
            "peak_rss_mb": peak_rss_mb(), "rss_before_setup_mb": rss_before}


def run(deck, outdir):
    import fsph
    from fsph.driver import run as fsph_run
    summary = fsph_run(deck, outdir, quiet=True)
    wall = time.perf_counter() - T_START
    return {"deck": str(deck), "status": summary["status"], "wall_s": wall,
            "solver_wall_s": summary["wall_time_s"], "cycles": summary["cycles"],
            "n_elements_initial": summary["n_elements_initial"],
            "n_particles_end": summary["n_particles"], "n_converted": summary["n_converted"],
            "phases_s": summary["phase_times_s"], "threads": fsph.threads(),
            "thread_policy": summary["thread_policy"], "cycles_by_threads": summary["cycles_by_threads"],
            "peak_rss_mb": peak_rss_mb(), "metrics": summary["metrics"],
            "comparison": summary.get("reference", {}).get("comparison", {})}


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    name, params = argv[0], json.loads(argv[1])
    result = {"block": block, "run": run}[name](**params)
    print(json.dumps(result))


if __name__ == "__main__":
    main()
