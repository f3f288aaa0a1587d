"""What a run will cost, known before it runs: each body's counts and
smallest cell, the first stable step, the cycles to end_time at that step
and the wall time from a few timed cycles (`fsph check`); and the set-up's
refusal of an end time that max_cycles cannot reach."""

import math
import time as wallclock

import numpy as np

from .errors import DeckError

#: `fsph check` times cycles for about this long [s] ...
TIMED_SECONDS = 1.0
#: ... and at most this many of them [-].
TIMED_CYCLES = 200
#: An estimated wall time above this is flagged [s].
LONG_RUN_S = 3600.0


def cycles_at_first_step(sim):
    """Cycles from the current time to &control end_time at the current
    stable step [-]: a lower bound where, as in an impact, the step shrinks."""
    remaining = sim.control["end_time"] - sim.time
    return max(0, math.ceil(remaining / sim.dt)) if sim.dt > 0.0 else 0


def check_reachable(sim):
    """DeckError if end_time needs more cycles at the current step than
    &control max_cycles allows: such a run could only stop at max_cycles,
    after the whole cost of getting there."""
    cycles = cycles_at_first_step(sim)
    limit = sim.control["max_cycles"]
    if cycles > limit:
        raise DeckError(sim.deck.get("path", "deck"), "control", "end_time",
                        f"an end time max_cycles = {limit} cycles can reach (the first step is "
                        f"{sim.dt * 1e9:.4g} ns: {cycles:.3g} cycles at least; raise max_cycles "
                        "if that is meant)", sim.control["end_time"])
    return cycles


def body_sizes(sim):
    """Per body: name, element, node and particle counts, the shortest
    element edge [m] and the smallest particle radius [m] (None without)."""
    snap = sim.snapshot()
    rows = []
    for ib, name in enumerate(sim.body_names):
        row = {"body": name, "elements": 0, "nodes": 0, "particles": 0,
               "shortest_edge_m": None, "smallest_particle_radius_m": None}
        if "conn" in snap and (snap["body"] == ib).any():
            conn = snap["conn"][snap["body"] == ib]
            x = snap["x"]
            edges = np.concatenate([x[conn[:, k]] - x[conn[:, (k + 1) % 3]] for k in range(3)])
            row.update(elements=len(conn), nodes=len(np.unique(conn)),
                       shortest_edge_m=float(np.sqrt((edges ** 2).sum(axis=1)).min()))
        if "particles" in snap and (snap["particles"]["body"] == ib).any():
            keep = snap["particles"]["body"] == ib
            row.update(particles=int(keep.sum()),
                       smallest_particle_radius_m=float(snap["particles"]["radius"][keep].min()))
        rows.append(row)
    return rows


def time_cycles(sim, seconds=TIMED_SECONDS, most=TIMED_CYCLES):
    """Run cycles one call each until `seconds` of wall time or `most`
    cycles; returns (cycles run, wall time per cycle [s]). The state moves
    on: time a Simulation made for the purpose."""
    t0 = wallclock.perf_counter()
    cycle0 = sim.cycle
    end = sim.control["end_time"]
    while sim.cycle - cycle0 < most and wallclock.perf_counter() - t0 < seconds and sim.time < end:
        sim.advance(end, land=False, max_cycles=1, partial=True)
    n = sim.cycle - cycle0
    return n, (wallclock.perf_counter() - t0) / n if n else float("nan")


def _duration(seconds):
    if seconds < 120:
        return f"{seconds:.3g} s"
    if seconds < 7200:
        return f"{seconds / 60:.3g} min"
    return f"{seconds / 3600:.3g} h"


def report_lines(sim, threads):
    """The lines of `fsph check` for a freshly set-up `sim` that passed
    check_reachable (it is advanced by the timed cycles)."""
    ctrl = sim.control
    lines = [f"  mode {ctrl['mode']}, {sim.n_elements} elements, {sim.n_nodes} nodes, "
             f"{sim.n_particles} particles"]
    for row, body in zip(body_sizes(sim), sim.deck["body"]):
        text = f"  body '{row['body']}':"
        if row["elements"]:
            text += (f" {row['elements']} elements, {row['nodes']} nodes, shortest edge "
                     f"{row['shortest_edge_m'] * 1e3:.4g} mm")
        if row["particles"]:
            total = body.get("formulation") == "total"
            text += (f" {row['particles']} {'total-Lagrangian ' if total else ''}particles, smallest radius "
                     f"{row['smallest_particle_radius_m'] * 1e3:.4g} mm")
        lines.append(text)
    dt = sim.dt
    cycles = cycles_at_first_step(sim)
    lines.append(f"  first time step {dt * 1e9:.4g} ns; end time {ctrl['end_time'] * 1e6:.6g} us: "
                 f"at least {cycles} cycles at that step (an impact usually shrinks it)")
    if any(b.get("formulation") == "total" for b in sim.deck["body"]):
        lines.append("  total-Lagrangian particles: their step falls with their smallest stretch (the Armco "
                     "Taylor rod took 5 times its first step's cycle count)")
    n, per_cycle = time_cycles(sim)
    wall = per_cycle * cycles
    lines.append(f"  wall time: about {_duration(wall)} or more on {threads} thread(s) "
                 f"({n} cycles timed, {per_cycle * 1e3:.3g} ms each)")
    if wall > LONG_RUN_S:
        lines.append(f"  warning: an estimated {_duration(wall)}; a coarser mesh, a shorter "
                     "end time or more threads cut it")
    return lines
