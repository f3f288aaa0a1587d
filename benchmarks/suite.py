"""fsph benchmark suite: one command for the figures of docs/performance.md.

    python benchmarks/suite.py [--sections m,a,b,l,c,d,e,h,t] [--quick] [--json FILE]

Sections (each at 1 and 2 OpenMP threads, each measurement in a child
process of its own; peak memory is that child's resident set):
  a  T3 cycle alone on a large block (100 000 elements, EPP +
     Mie-Grueneisen): ns per element-cycle and the phase split
  b  pure SPH on a large block (40 000 particles, about 21 neighbours):
     us per particle-cycle, split into neighbour search, sums, stress update
  c  cases/taylor_armco.nml (adaptive, 60 us) through `fsph run`: wall time
     from process start, cycles, time share of elements, particles,
     coupling, conversion and contact (as table 2 of Hu et al. 2013); and
     start-up: the same deck cut to one cycle, launch to exit
  d  the 508 m/s plate case to 200 us, adaptive and pure SPH, and their
     wall-time ratio
  e  the adaptive Taylor case refined x1, x2, x4 in each direction (2 680,
     10 720, 42 880 elements): cost growth exponent against the number of
     elements (ideal explicit 2D: 1.5), and the series as time to answer:
     wall time against the L, D, W errors from experiment. On one thread
     with two processors the series runs on processor 0 while the x1 run
     repeats on processor 1 as a clock of the host's speed (--no-clock:
     without), and the exponent of the runs' times over the clock's is
     the target's figure
  h  the debris cloud of case 1 (cases/debris_cu_al_1.nml, pure SPH on
     0.1 mm lattices, about 8 900 particles) run on to 10 us through
     `fsph run`: the hypervelocity issue's speed figure
  t  threads under load: cases/taylor_armco.nml through `fsph run` with
     a competing busy process that the section starts itself (one core
     busy), on 1 thread and on 2 under the adaptive and the fixed thread
     policy (FSPH_THREAD_POLICY); idle, 2 threads adaptive against fixed.
     Medians of --repeat runs (the loaded fixed run once: it can take
     minutes)
  l  total-Lagrangian particles on the block of b (the same lattice,
     deck cases/taylor_armco_tlsph.nml), on the full support and on the
     selected-particle stencil: us per particle-cycle against the updated
     particles' of b, at equal particle count (their neighbours are
     fixed: no search)
  m  the machine: clock and memory bandwidth (STREAM add over 3 x 160 MB)
     for the roofline estimate
Speed-ups of 2 threads over 1 go with every section (f); peak memory with
every measurement (g). Each block and Taylor figure is the best of
--repeat runs, each plate figure of up to 2 (the wall time of this
machine's second core varies by up to a factor 3 from one minute to the
next; one core's by about 2 %). The last
table sets the figures against the targets of the performance issue.
--quick: smaller blocks, no pure SPH plate run, no x4 refinement, 2
threads only where a section is long.
"""

import argparse
import contextlib
import json
import math
import os
import time
from pathlib import Path

import numpy as np

from common import machine, machine_line, refined_deck, run_workload

REPO = Path(__file__).resolve().parents[1]
CASES = REPO / "cases"
THREADS = (1, 2)

#: phases of the cycle (fsph.simulation.PHASES) grouped as table 2 of Hu et al. 2013
GROUPS = {"elements": ("element_forces", "element_update"),
          "particles": ("neighbours", "sph_sums", "particle_update"),
          "coupling": ("coupling",),
          "conversion": ("conversion",),
          "contact": ("contact", "particle_contact"),
          "other": ("integrate", "time_step")}


def grouped(phases):
    return {g: sum(phases.get(p, 0.0) for p in names) for g, names in GROUPS.items()}


def shares_text(phases, total):
    return ", ".join(f"{g} {100.0 * t / total:.0f} %" for g, t in grouped(phases).items()
                     if t / total >= 0.005)


# ---- sections --------------------------------------------------------------
def best_of(repeat, name, params, threads, key, cpu=None, env_extra=None):
    """The run of `repeat` with the smallest `key` (each on processor `cpu`
    alone if given)."""
    return min((run_workload(name, params, threads, env_extra, cpu=cpu) for _ in range(repeat)),
               key=lambda r: r[key])


#: The blocks measure the kernels on a fixed thread count, as they did before
#: the thread governor (section t) existed: over a block's 40 to 100 cycles
#: (1.5 s) the governor's first probes on fewer threads are a tenth of the
#: time, which a run of minutes spreads over its exploitation periods of up
#: to 5 s. The governor's own cost is section t's; the blocks' 2-thread
#: figure with it is kept beside (speedup_2_adaptive).
FIXED_POLICY = {"FSPH_THREAD_POLICY": "fixed"}


def section_block(kind, n_radial, n_axial, cycles, repeat):
    params = {"kind": kind, "n_radial": n_radial, "n_axial": n_axial, "cycles": cycles}
    rows = [best_of(repeat, "block", params, t, "advance_s", env_extra=FIXED_POLICY) for t in THREADS]
    adaptive = best_of(repeat, "block", params, THREADS[-1], "advance_s")
    unit, scale = ("ns/element-cycle", 1.0) if kind == "fem" else ("us/particle-cycle", 1e-3)
    print(f"\n({dict(fem='a', sph='b', tlsph='l', tlsph_selected='l')[kind]}) {kind.upper()} block: {rows[0]['items']} "
          f"{'elements' if kind == 'fem' else 'particles'}, {rows[0]['cycles']} cycles")
    for r in rows:
        phases = r["phases_s"]
        per = {k: v / (r["cycles"] * r["items"]) * 1e9 * scale for k, v in phases.items()}
        if kind == "fem":
            split = (f"forces {per['element_forces']:.1f}, update {per['element_update']:.1f}, "
                     f"integrate {per['integrate']:.1f}, step {per['time_step']:.1f}")
        else:
            split = (f"search {per['neighbours']:.3f}, sums {per['sph_sums']:.3f}, "
                     f"stress {per['particle_update']:.3f}, other "
                     f"{sum(per.values()) - per['neighbours'] - per['sph_sums'] - per['particle_update']:.3f}")
        print(f"  {r['threads']} thread(s): {r['ns_per_item_cycle'] * scale:8.3f} {unit} "
              f"(speed-up {rows[0]['advance_s'] / r['advance_s']:.2f}); {split}; "
              f"peak memory {r['peak_rss_mb']:.0f} MB")
    print(f"  {adaptive['threads']} thread(s), adaptive thread policy: "
          f"{adaptive['ns_per_item_cycle'] * scale:8.3f} {unit} "
          f"(speed-up {rows[0]['advance_s'] / adaptive['advance_s']:.2f})")
    return {"rows": rows, "speedup_2": rows[0]["advance_s"] / rows[1]["advance_s"],
            "thread_policy": "fixed", "adaptive_2": adaptive,
            "speedup_2_adaptive": rows[0]["advance_s"] / adaptive["advance_s"]}


def section_run(label, deck, outroot, threads=THREADS, repeat=1, cpu=None):
    rows = []
    for t in threads:
        r = best_of(repeat, "run", {"deck": str(deck), "outdir": str(outroot / f"{Path(deck).stem}_t{t}")}, t,
                    "process_wall_s", cpu)
        rows.append(r)
        total = sum(r["phases_s"].values())
        print(f"  {label} {t} thread(s): {r['process_wall_s']:7.2f} s wall from launch "
              f"({r['solver_wall_s']:.2f} s in fsph.driver.run), {r['cycles']} cycles, "
              f"{r['n_elements_initial']} elements at t = 0, {r['n_particles_end']} particles at "
              f"the end; {shares_text(r['phases_s'], total)}; peak memory {r['peak_rss_mb']:.0f} MB")
    out = {"rows": rows}
    if len(rows) == 2:
        out["speedup_2"] = rows[0]["process_wall_s"] / rows[1]["process_wall_s"]
        print(f"  {label} speed-up 2 threads / 1: {out['speedup_2']:.2f}")
    return out


def section_taylor(outroot, repeat):
    print("\n(c) adaptive Taylor rod, cases/taylor_armco.nml, 60 us")
    result = section_run("taylor_armco", CASES / "taylor_armco.nml", outroot, repeat=repeat)
    result["startup"] = section_startup(outroot, repeat)
    return result


def deck_ending_at(deck, end_time, folder, suffix):
    """A copy of `deck` in `folder` named STEM_SUFFIX.nml whose &control
    end_time is end_time [s], its reference path made absolute."""
    import f90nml
    nml = f90nml.read(deck)
    nml["control"]["end_time"] = end_time
    nml["output"]["reference"] = str((deck.parent / nml["output"]["reference"]).resolve())
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{deck.stem}_{suffix}.nml"
    nml.write(path, force=True)
    return path


def section_startup(outroot, repeat):
    """Start-up: the default deck cut to one cycle (end_time 1 ns) through
    `fsph run`, launch to exit, 1 thread: interpreter, imports, set-up, the
    t = 0 snapshot and its metrics, one cycle, the closing outputs."""
    path = deck_ending_at(CASES / "taylor_armco.nml", 1.0e-9, outroot / "decks", "one_cycle")
    r = best_of(max(repeat, 5), "run", {"deck": str(path), "outdir": str(outroot / "one_cycle")}, 1,
                "process_wall_s")
    print(f"  start-up (one cycle, launch to exit, 1 thread, best of {max(repeat, 5)}): "
          f"{r['process_wall_s']:.3f} s, of which {r['solver_wall_s']:.3f} s in fsph.driver.run")
    return {"process_wall_s": r["process_wall_s"], "solver_wall_s": r["solver_wall_s"], "cycles": r["cycles"]}


def section_plate(outroot, quick, repeat):
    print("\n(d) ogive rod through the 26.3 mm plate, 508 m/s, 200 us")
    adaptive = section_run("al_plate_508", CASES / "al_plate_508.nml", outroot,
                           threads=(2,) if quick else THREADS, repeat=repeat)
    result = {"adaptive": adaptive}
    if not quick:
        sph = section_run("al_plate_508_sph", CASES / "al_plate_508_sph.nml", outroot, repeat=repeat)
        result["sph"] = sph
        result["ratio_sph_over_adaptive_2_threads"] = (sph["rows"][-1]["process_wall_s"]
                                                       / adaptive["rows"][-1]["process_wall_s"])
        print(f"  pure SPH / adaptive wall time (2 threads): "
              f"{result['ratio_sph_over_adaptive_2_threads']:.2f}")
    return result


class ReferenceClock:
    """The x1 deck run over and over on processor `cpu`, one thread, in a
    thread of this process, while the series runs on another processor:
    the mean duration of the clock's runs that overlap a window measures
    how fast the host was then. This host's speed drifts by more than the
    exponent's differences within the minutes a series takes; a run's
    time over the clock's is free of that drift."""

    def __init__(self, deck, outdir, cpu):
        import threading
        self.deck, self.outdir, self.cpu = deck, outdir, cpu
        self.windows = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)

    def _loop(self):
        while not self._stop.is_set():
            r = run_workload("run", {"deck": str(self.deck), "outdir": str(self.outdir)}, 1, cpu=self.cpu)
            self.windows.append(r["window_s"])

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()

    def duration_during(self, window):
        """Mean duration [s] of the clock's runs weighted by their overlap
        with window (start, end); nan if none overlaps."""
        w = np.array(self.windows, float).reshape(-1, 2)
        overlap = np.clip(np.minimum(w[:, 1], window[1]) - np.maximum(w[:, 0], window[0]), 0.0, None)
        if overlap.sum() <= 0.0:
            return float("nan")
        return float((overlap * (w[:, 1] - w[:, 0])).sum() / overlap.sum())


def section_refinement(outroot, quick, threads, repeat, clock=True):
    """The series x1, x2 (x4) on `threads` threads; with `clock` (one
    thread, two processors or more) the series runs on processor 0 beside
    a ReferenceClock on processor 1, and the exponent is also fitted to the
    runs' times over the clock's."""
    factors = (1, 2) if quick else (1, 2, 4)
    clock = clock and threads == 1 and len(os.sched_getaffinity(0)) >= 2
    print(f"\n(e) adaptive Taylor rod refined x{', x'.join(map(str, factors))} in each direction"
          + (" (series on processor 0, the x1 run repeated on processor 1 as the host's clock)" if clock else ""))
    decks = {f: (CASES / "taylor_armco.nml" if f == 1 else
                 refined_deck(CASES / "taylor_armco.nml", outroot / "decks", (("n_radial", f), ("n_axial", f)),
                              f"x{f}")) for f in factors}
    rows = []
    with (ReferenceClock(decks[1], outroot / "clock", 1) if clock else contextlib.nullcontext()) as ref:
        for f in factors:
            # the short runs are repeated (the best counts); the x4 run, minutes long, once
            rows.append({"factor": f, **section_run(f"x{f}", decks[f], outroot / f"x{f}", threads=(threads,),
                                                    repeat=repeat if f < 4 else 1,
                                                    cpu=0 if clock else None)["rows"][0]})
    if clock:
        # the clock's runs overlapping each window, once all have ended
        for r in rows:
            r["clock_s"] = ref.duration_during(r["window_s"])
        print("  the clock's x1 run meanwhile: "
              + ", ".join(f"x{r['factor']} {r['clock_s']:.2f} s" for r in rows))
    n = np.array([r["n_elements_initial"] for r in rows], float)
    wall = np.array([r["solver_wall_s"] for r in rows])
    cycles = np.array([r["cycles"] for r in rows], float)
    exponent = float(np.polyfit(np.log(n), np.log(wall), 1)[0])
    cycle_exponent = float(np.polyfit(np.log(n), np.log(cycles), 1)[0])
    print(f"  cost exponent (wall of the run against elements at t = 0, {threads} thread(s)): "
          f"{exponent:.2f}; cycles grow as N^{cycle_exponent:.2f} (ideal 0.5)")
    out = {"rows": rows, "exponent": exponent, "cycle_exponent": cycle_exponent, "threads": threads}
    if clock:
        clocked = wall / np.array([r["clock_s"] for r in rows])
        out["exponent_clocked"] = float(np.polyfit(np.log(n), np.log(clocked), 1)[0])
        print(f"  cost exponent of the runs' times over the clock's: {out['exponent_clocked']:.2f}")
    time_to_answer(rows, threads)
    return out


def time_to_answer(rows, threads):
    """Print the refinement series as time to answer: wall time from launch
    against the L, D, W errors from experiment (the run's own comparison
    with its reference) and their mean magnitude, so that a change that
    buys speed with accuracy shows. Adds 'mean_abs_error_percent' to each
    row."""
    keys = ("L_mm", "D_mm", "W_mm")
    print(f"  time to answer ({threads} thread(s)):")
    print(f"  {'mesh':>5s} {'elements':>9s} {'cycles':>7s} {'wall [s]':>9s} "
          + " ".join(f"{k[0] + ' err':>8s}" for k in keys) + f" {'mean |err|':>10s}")
    for r in rows:
        cmp = r.get("comparison", {}).get("taylor", {})
        errors = [cmp.get(k, {}).get("error_percent") for k in keys]
        errors = [float("nan") if e is None else e for e in errors]
        r["mean_abs_error_percent"] = float(np.mean(np.abs(errors)))
        print(f"  {'x' + str(r['factor']):>5s} {r['n_elements_initial']:9d} {r['cycles']:7d} "
              f"{r['process_wall_s']:9.2f} " + " ".join(f"{e:+7.2f}%" for e in errors)
              + f" {r['mean_abs_error_percent']:9.2f}%")


def section_debris(outroot, repeat):
    """Case 1 of the debris clouds at the deck's 0.1 mm to 10 us."""
    print("\n(h) debris cloud, case 1 at 0.1 mm, to 10 us")
    path = deck_ending_at(CASES / "debris_cu_al_1.nml", 10.0e-6, outroot / "decks", "10us")
    return section_run("debris_cu_al_1 to 10 us", path, outroot, repeat=repeat)


def _median_run(repeat, deck, outdir, threads, env_extra=None):
    """The run of median process wall time among `repeat` runs."""
    runs = sorted((run_workload("run", {"deck": str(deck), "outdir": str(outdir)}, threads, env_extra)
                   for _ in range(repeat)), key=lambda r: r["process_wall_s"])
    return runs[len(runs) // 2]


def _thread_row(label, r):
    use = r["cycles_by_threads"]
    total = max(sum(use.values()), 1)
    split = ", ".join(f"{n} thread(s) {100.0 * c / total:.0f} %" for n, c in sorted(use.items()))
    print(f"  {label:34s} {r['process_wall_s']:7.2f} s wall from launch; cycles at {split}")
    return {"label": label, "process_wall_s": r["process_wall_s"], "cycles_by_threads": use,
            "thread_policy": r["thread_policy"], "threads": r["threads"]}


def section_threads(outroot, repeat):
    """The default case beside a busy process, and idle: what the adaptive
    thread policy buys and costs."""
    import subprocess
    import sys
    print("\n(t) threads under load: cases/taylor_armco.nml, one core kept busy by another process")
    deck = CASES / "taylor_armco.nml"
    out = outroot / "taylor_armco"
    rows = {}
    rows["idle_2_fixed"] = _thread_row("idle, 2 threads, fixed", _median_run(
        repeat, deck, out, 2, {"FSPH_THREAD_POLICY": "fixed"}))
    rows["idle_2_adaptive"] = _thread_row("idle, 2 threads, adaptive", _median_run(
        repeat, deck, out, 2, {"FSPH_THREAD_POLICY": "adaptive"}))
    busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        time.sleep(0.5)
        rows["loaded_1"] = _thread_row("loaded, 1 thread", _median_run(repeat, deck, out, 1))
        rows["loaded_2_adaptive"] = _thread_row("loaded, 2 threads, adaptive", _median_run(
            repeat, deck, out, 2, {"FSPH_THREAD_POLICY": "adaptive"}))
        rows["loaded_2_fixed"] = _thread_row("loaded, 2 threads, fixed", _median_run(
            1, deck, out, 2, {"FSPH_THREAD_POLICY": "fixed"}))
    finally:
        busy.kill()
        busy.wait()
    result = {"rows": rows,
              "loaded_ratio_adaptive": rows["loaded_2_adaptive"]["process_wall_s"]
              / rows["loaded_1"]["process_wall_s"],
              "loaded_ratio_fixed": rows["loaded_2_fixed"]["process_wall_s"] / rows["loaded_1"]["process_wall_s"],
              "idle_cost_adaptive": rows["idle_2_adaptive"]["process_wall_s"]
              / rows["idle_2_fixed"]["process_wall_s"]}
    print(f"  loaded, 2 threads / 1: adaptive {result['loaded_ratio_adaptive']:.2f}, "
          f"fixed {result['loaded_ratio_fixed']:.2f}; idle, adaptive / fixed "
          f"{result['idle_cost_adaptive']:.3f}")
    return result


def section_machine():
    """Sustained memory bandwidth of one core: best of 5 passes of STREAM's
    add, a = b + c, over 2 x 10^7 doubles (3 x 160 MB), counted as STREAM
    counts it: 24 bytes per entry (the store's write-allocate not counted)."""
    n = 20_000_000
    b = np.random.default_rng(0).random(n)
    c = np.random.default_rng(1).random(n)
    a = np.empty(n)
    best = math.inf
    for _ in range(5):
        t0 = time.perf_counter()
        np.add(b, c, out=a)
        best = min(best, time.perf_counter() - t0)
    bandwidth = 3 * 8 * n / best / 1e9
    del a, b, c   # the measurements' children are forked from this process
    info = machine()
    mhz = _cpu_mhz()
    print(f"\n(m) {machine_line(info)}; clock {mhz:.0f} MHz; STREAM add bandwidth (one core) "
          f"{bandwidth:.1f} GB/s")
    return {"machine": info, "cpu_mhz": mhz, "stream_add_gb_s": bandwidth}


#: (label, how to read the figure from the results, target, unit, "max" or "min").
#: The bars of the speed work now open (T3 60 ns, SPH 0.40 us, the default
#: case 1.5 s, exponent 1.55, start-up 0.3 s, loaded threads 1.2); those of
#: the work before it (80 ns, 1.0 us, 3 s, 1.6) are met and kept in
#: docs/performance.md's Targets table beside them.
TARGETS = (
    ("T3 element cycle, 1 thread", lambda r: r["fem_block"]["rows"][0]["ns_per_item_cycle"], 60.0, "ns", "max"),
    ("SPH particle cycle, 1 thread", lambda r: r["sph_block"]["rows"][0]["ns_per_item_cycle"] / 1e3, 0.40,
     "us", "max"),
    ("taylor_armco.nml fsph run, 2 threads", lambda r: r["taylor_adaptive"]["rows"][-1]["process_wall_s"], 1.5,
     "s", "max"),
    ("start-up: one-cycle run, launch to exit", lambda r: r["taylor_adaptive"]["startup"]["process_wall_s"], 0.3,
     "s", "max"),
    ("al_plate_508 adaptive to 200 us, 2 threads", lambda r: r["plate_508"]["adaptive"]["rows"][-1]["process_wall_s"],
     60.0, "s", "max"),
    ("pure SPH / adaptive, plate 508", lambda r: r["plate_508"]["ratio_sph_over_adaptive_2_threads"], 3.0, "",
     "min"),
    ("cost exponent under refinement", lambda r: r["refinement"].get("exponent_clocked",
                                                                   r["refinement"]["exponent"]), 1.55, "", "max"),
    ("debris case 1, 0.1 mm, to 10 us, 2 threads", lambda r: r["debris"]["rows"][-1]["process_wall_s"],
     60.0, "s", "max"),
    ("default case loaded, 2 threads / 1", lambda r: r["threads_under_load"]["loaded_ratio_adaptive"], 1.2, "",
     "max"),
    ("2 threads / 1, T3 block", lambda r: r["fem_block"]["speedup_2"], 1.7, "", "min"),
    ("2 threads / 1, SPH block", lambda r: r["sph_block"]["speedup_2"], 1.7, "", "min"),
    ("TLSPH / SPH particle cycle, 1 thread", lambda r: r["tlsph_block"]["ratio_to_sph"], 0.8, "", "max"),
)


def targets_table(results):
    """Print and return the measured figures against the targets (those
    the sections run have measured)."""
    rows = []
    print(f"\n{'target':44s} {'measured':>10s} {'bar':>8s}  met")
    for label, read, bar, unit, kind in TARGETS:
        try:
            value = float(read(results))
        except (KeyError, IndexError, TypeError):
            continue
        met = value <= bar if kind == "max" else value >= bar
        rows.append({"target": label, "measured": value, "bar": bar, "unit": unit, "met": met})
        print(f"{label:44s} {value:10.3g} {('<= ' if kind == 'max' else '>= ') + f'{bar:g}':>8s}  "
              f"{'yes' if met else 'NO'} {unit}")
    return rows


def _cpu_mhz():
    try:
        with open("/proc/cpuinfo") as fh:
            return float(next(line.split(":")[1] for line in fh if line.startswith("cpu MHz")))
    except (OSError, StopIteration, ValueError):
        return float("nan")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sections", default="m,a,b,l,c,d,e,h,t", help="comma-separated, of m a b l c d e h t")
    ap.add_argument("--quick", action="store_true", help="smaller and fewer runs")
    ap.add_argument("--repeat", type=int, default=3, help="runs of each block and Taylor figure (best)")
    ap.add_argument("--refinement-threads", type=int, default=1,
                    help="threads of the refinement runs (one core's timing is the steady one)")
    ap.add_argument("--no-clock", action="store_true",
                    help="section e without the x1 run repeated on the other processor as a clock")
    ap.add_argument("--out", default=str(REPO / "out" / "bench"), help="folder for run outputs")
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args(argv)
    sections = [s.strip() for s in args.sections.split(",") if s.strip()]
    outroot = Path(args.out)
    results = {"date": time.strftime("%Y-%m-%d"), "quick": args.quick}
    fem_size, sph_size = ((25, 250), (50, 200)) if args.quick else ((50, 500), (100, 400))
    for s in sections:
        if s == "m":
            results["machine"] = section_machine()
        elif s == "a":
            results["fem_block"] = section_block("fem", *fem_size, 50 if args.quick else 100, args.repeat)
        elif s == "b":
            results["sph_block"] = section_block("sph", *sph_size, 20 if args.quick else 40, args.repeat)
        elif s == "l":
            results["tlsph_block"] = section_block("tlsph", *sph_size, 20 if args.quick else 40, args.repeat)
            results["tlsph_selected_block"] = section_block("tlsph_selected", *sph_size, 20 if args.quick else 40,
                                                            args.repeat)
            if "sph_block" in results:
                for key in ("tlsph_block", "tlsph_selected_block"):
                    ratio = (results[key]["rows"][0]["ns_per_item_cycle"]
                             / results["sph_block"]["rows"][0]["ns_per_item_cycle"])
                    results[key]["ratio_to_sph"] = ratio
                    print(f"  {key}: total-Lagrangian / updated particle-cycle, 1 thread: {ratio:.2f}")
        elif s == "c":
            results["taylor_adaptive"] = section_taylor(outroot / "taylor", args.repeat)
        elif s == "d":
            results["plate_508"] = section_plate(outroot / "plate", args.quick, min(args.repeat, 2))
        elif s == "h":
            results["debris"] = section_debris(outroot / "debris", min(args.repeat, 2))
        elif s == "e":
            results["refinement"] = section_refinement(outroot / "refinement", args.quick,
                                                       args.refinement_threads, args.repeat,
                                                       clock=not args.no_clock)
        elif s == "t":
            results["threads_under_load"] = section_threads(outroot / "threads", args.repeat)
        else:
            ap.error(f"unknown section {s!r}: expected m, a, b, l, c, d, e, h or t")
    results["targets"] = targets_table(results)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
