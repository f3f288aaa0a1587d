"""Run a deck from start to end: set up, advance output interval by output
interval, write history, snapshots and summary, report metrics."""

import json
import math
import shutil
import signal
import sys
import time as wallclock
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from . import checkpoint as checkpoint_module
from . import deck as deck_module
from . import estimate
from . import layouts
from . import metrics as metrics_module
from . import references
from .errors import CheckpointError, DeckError, FsphError, OutputError, SimulationError
from .output import SNAPSHOT_UNITS, FolderLock, RunWriter, key_with_unit, write_summary
from .points import state_masses
from .simulation import Simulation, threads


def _targets(t_end, n_snapshots, n_progress):
    """Merged output times: (time, write_snapshot, print_progress)."""
    snaps = {round(k * 10**9 / n_snapshots): True for k in range(1, n_snapshots + 1)}
    progs = {round(k * 10**9 / n_progress): True for k in range(1, n_progress + 1)}
    keys = sorted(set(snaps) | set(progs))
    return [(t_end * k / 10**9, k in snaps, k in progs) for k in keys]


def _format_metrics(comparison, metrics):
    """The printed metric lines: each float metric, or one compared with
    the reference, its name padded to the longest printed so the values
    stand in one column, then its comparison."""
    rows = []
    for group, values in metrics.items():
        for key, val in values.items():
            cmp = comparison.get(group, {}).get(key)
            if not isinstance(val, float) and not cmp:
                continue
            # the compared value: none where the run did not measure it
            rows.append((f"{group}.{key}", cmp["computed"] if cmp else val, cmp))
    width = max((len(name) for name, _, _ in rows), default=0)
    return [f"  {name:<{width}s} " + _value_text(value) + (_reference_text(cmp) if cmp else "")
            for name, value, cmp in rows]


def _value_text(value):
    """A metric's value in 10 columns, 'none' where the run has none."""
    return f"{value:10.4g}" if value is not None else f"{'none':>10s}"


def _reference_text(cmp):
    """'   reference R   error E %' of a comparison entry, or 'not measured'
    (and why, where the comparison says) where the run has no value
    (metrics.compare)."""
    if cmp["error_percent"] is None:
        why = cmp.get("not_measured_because")
        return f"   reference {cmp['reference']:.4g}   not measured" + (f": {why}" if why else "")
    return f"   reference {cmp['reference']:.4g}   error {cmp['error_percent']:+.1f} %"


#: The debris quantities printed one to a line, with the reference where
#: it has them.
_DEBRIS_LINES = ("flyer_front_mm", "target_front_mm", "front_ratio", "ejecta_height_mm",
                 "intersection_radius_mm", "hole_diameter_mm")


def _format_debris(metrics, comparison):
    """Printed lines of a debris run: the fronts at the tabulated
    fractions, the quantities compared with the experiment, the clouds'
    masses and momenta, the impedance match against the run."""
    from .debris import FRONT_FRACTIONS, fraction_tag
    rec = metrics["debris"]

    def mm(value):
        return f"{value:9.2f}" if value is not None else f"{'-':>9s}"
    lines = [f"  debris at t = {rec['time_us']:.4g} us (lengths along the flight direction from "
             f"the plate's front face; fronts at {100 * rec['front_fraction']:g} % of each "
             f"cloud's mass)",
             f"    front [mm] at   {rec['flyer']} ({rec['flyer_material']})   "
             f"{rec['target']} ({rec['target_material']})"]
    for q in FRONT_FRACTIONS:
        tag = fraction_tag(q)
        lines.append(f"    {100 * q:6.3g} %      {mm(rec[f'flyer_front_{tag}_mm'])}   "
                     f"{mm(rec[f'target_front_{tag}_mm'])}")
    for key in _DEBRIS_LINES:
        value = rec[key]
        text = f"  debris.{key:<24s} " + _value_text(value)
        cmp = comparison.get("debris", {}).get(key)
        if cmp:
            text += _reference_text(cmp)
        lines.append(text)
    lines.append(f"  cloud mass [g] / axial momentum [N s]: {rec['flyer']} "
                 f"{1e3 * rec['flyer_cloud_mass_kg']:.4g} / {rec['flyer_cloud_momentum_z_N_s']:.4g}, "
                 f"{rec['target']} {1e3 * rec['target_cloud_mass_kg']:.4g} / "
                 f"{rec['target_cloud_momentum_z_N_s']:.4g}; ejecta {1e3 * rec['ejecta_mass_kg']:.4g} g")
    match = metrics.get("impedance_match")
    if match:
        text = (f"  impedance match: {match['pressure_GPa']:.4g} GPa, "
                f"{match['particle_velocity_m_s']:.4g} m/s (1D, analytic); ")
        if match["measured_pressure_GPa"] is None:
            text += (f"not measured (no snapshot before the plate's shock reaches its rear face "
                     f"at {match['target_transit_us']:.3g} us)")
        else:
            text += (f"run {match['measured_pressure_GPa']:.4g} GPa "
                     f"({match['pressure_error_percent']:+.1f} %), "
                     f"{match['measured_particle_velocity_m_s']:.4g} m/s "
                     f"({match['particle_velocity_error_percent']:+.1f} %) over "
                     f"{match['measured_snapshots']} snapshot(s)")
        lines.append(text)
    return lines


def _format_material_state(states):
    """Printed line of the failed and molten mass of each body
    (points.state_masses); none when nothing has failed or melted."""
    if not any(s["failed_mass_kg"] > 0.0 or s["melted_mass_kg"] > 0.0 for s in states.values()):
        return []
    parts = []
    for name, s in states.items():
        if s["mass_kg"] > 0.0:
            failed, melted = s["failed_mass_kg"], s["melted_mass_kg"]
            parts.append(f"{name} {1e3 * failed:.4g} / {1e3 * melted:.4g} g "
                         f"({100 * failed / s['mass_kg']:.1f} / {100 * melted / s['mass_kg']:.1f} %)")
    return ["  failed / molten mass: " + ", ".join(parts)]


def _format_peaks(peaks):
    """Printed lines of the peak fields (_peaks), each value with its unit
    and where it is ('everywhere' for a field of one value)."""
    return [f"  peak {name:<17s} {p['value']:10.4g}"
            f"{'' if p['unit'] == '-' else ' ' + p['unit']}   "
            + ("everywhere" if p["in"] is None else
               f"at r {p['r_mm']:.3f} mm, z {p['z_mm']:.3f} mm ({p['in']} id {p['id']})")
            for name, p in peaks.items()]


def _warnings(ctrl, energies, writer):
    """What a user must not miss about a run that completed: an energy
    error beyond &control energy_error_warning (the largest during the run
    or the final one), snapshots written while a reader held fsph.h5. A list
    of {kind, message[, value, limit]}."""
    out = []
    limit = ctrl["energy_error_warning"]
    worst = writer.max_energy_error
    if abs(energies["relative_error"]) > abs(worst):
        worst = energies["relative_error"]
    if abs(worst) > limit:
        out.append({"kind": "energy_error", "value": worst, "limit": limit,
                    "message": f"energy error {100 * worst:+.2f} % exceeds energy_error_warning = "
                               f"{100 * limit:g} %: the run lost its energy balance and its "
                               f"results should not be trusted (energy_error_limit makes this "
                               f"a hard stop)"})
    if writer.lock_warning:
        out.append({"kind": "output", "message": writer.lock_warning})
    return out


#: Cycles per call into the solver between checks for an interrupt [-].
CYCLES_PER_CALL = 500


def _cycles_this_call(cycle, every):
    """Cycles of the next call into the solver: CYCLES_PER_CALL, cut so that
    the call ends on the next multiple of `every` (checkpoint_cycles; 0 off)."""
    if every <= 0:
        return CYCLES_PER_CALL
    return min(CYCLES_PER_CALL, every - cycle % every)


class _ProgressBar:
    """tqdm bar over simulated time with cycle, step, element and particle
    counts and the ETA, for runs on a terminal."""

    FORMAT = "{percentage:3.0f}%|{bar}| t {n:.4g}/{total:.4g} us [{elapsed}<{remaining}{postfix}]"
    #: Terminals narrower than this get the short labels.
    WIDE = 120

    def __init__(self, stream, sim, end_time):
        from tqdm import tqdm
        # the width and height are given: on a pseudo-terminal that reports
        # a 0 x 0 size (script, some CI runners and editors) tqdm would
        # otherwise take the bar to be below the last row and print nothing
        cols, rows = shutil.get_terminal_size()
        self.wide = cols >= self.WIDE
        self.bar = tqdm(total=end_time * 1e6, initial=sim.time * 1e6, file=stream,
                        ncols=cols, nrows=rows, dynamic_ncols=False, mininterval=0.2,
                        leave=True, disable=False, bar_format=self.FORMAT,
                        postfix=self._state(sim))

    def _state(self, sim):
        if self.wide:
            return (f"cycle {sim.cycle}, dt {sim.dt * 1e9:.4g} ns, {sim.n_elements} elements, "
                    f"{sim.n_particles} particles")
        return (f"cycle {sim.cycle}, dt {sim.dt * 1e9:.3g} ns, el {sim.n_elements}, "
                f"pt {sim.n_particles}")

    def update(self, sim):
        self.bar.set_postfix_str(self._state(sim), refresh=False)
        self.bar.update(sim.time * 1e6 - self.bar.n)

    def close(self):
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def _isatty(stream):
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False


def _progress_kind(progress, quiet, stream):
    """'none', 'lines' or 'bar' for the deck's run on `stream`."""
    if quiet:
        return "none"
    if progress not in ("auto", "bar", "lines"):
        raise FsphError(f"progress: expected auto, bar or lines, got {progress!r}")
    if progress == "auto":
        progress = "bar" if _isatty(stream) else "lines"
    if progress == "bar":
        try:
            import tqdm  # noqa: F401
        except ImportError:
            return "lines"
    return progress


def _check_energy(sim, limit):
    """Stop (as a failed run) when the energy error exceeds the deck's limit."""
    if limit is None:
        return
    error = sim.energies()["relative_error"]
    if abs(error) > limit:
        raise SimulationError(
            f"run stopped at t = {sim.time * 1e6:.6g} us, cycle {sim.cycle}: energy error above "
            f"the limit (energy_error_limit = {limit:g}): {error:+.3e}",
            code=layouts.status_code("energy_limit"), time=sim.time, cycle=sim.cycle)


@contextmanager
def _interrupt_flag():
    """SIGINT and SIGTERM set a flag (the run then stops at the end of the
    current call with a checkpoint) instead of killing the process."""
    flag = {"signal": None}

    def handler(signum, frame):
        flag["signal"] = signum

    previous = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        try:
            previous[sig] = signal.signal(sig, handler)
        except ValueError:      # not the main thread: leave signals alone
            pass
    try:
        yield flag
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)


@dataclass
class _Setup:
    """A run ready to start: the deck path and its validated dict, the
    reference values (None without) and why they do not apply to this deck
    ("" where they do: references.not_applied_because, decided once), the output
    folder and its lock, the simulation (at the checkpoint's state on a
    restart), its writer and the digests of the deck and the reference
    (references.run_inputs); on a restart, the snapshot series of the run
    before the checkpoint (_carry_on; None where none carries on) and
    what the run took before it (the books' timing; None without a
    restart: _run_timing)."""

    deck_path: Path
    deck: dict
    reference: dict
    not_applied_because: str
    outdir: Path
    lock: FolderLock
    sim: Simulation
    writer: RunWriter
    inputs: dict
    series: list = None
    timing_before: dict = None


def _restart(sim, deck, restart, outdir):
    """Restore `sim` from the checkpoint `restart`; returns the output
    folder of the continuation and the books the checkpoint kept. The deck
    must end after the checkpoint; the continuation writes into a folder
    of its own (default: restart_<cycle> beside the checkpoint), so the
    outputs before the checkpoint are never overwritten."""
    books = checkpoint_module.restore(sim, restart)
    end_time = deck["control"]["end_time"]
    if not end_time > sim.time:
        raise DeckError(deck["path"], "control", "end_time", f"a time after the checkpoint's "
                        f"t = {sim.time:.6g} s ({restart})", end_time)
    outdir = Path(outdir) if outdir else Path(restart).parent / f"restart_{sim.cycle:07d}"
    earlier = [name for name in ("fsph.h5", "summary.json", "checkpoint.h5") if (outdir / name).exists()]
    if earlier:
        raise DeckError(restart, None, None, "an output folder for the continuation that "
                        "holds no earlier run (a restart never overwrites one; give -o)",
                        f"{outdir} with {', '.join(earlier)}")
    return outdir, books


def _metrics_identity(deck):
    """The deck's &metrics group as plain JSON values: the snapshot series
    carries on across a restart that keeps it."""
    return json.loads(json.dumps(deck["metrics"], default=repr))


def _run_timing(sim, process_wall, before):
    """The whole run's wall time [s], the time of each phase of the cycle
    [s] and the cycles run at each thread count: this process's
    (process_wall [s], the phases and cycles since set-up) added to
    `before`, what the run took before the checkpoint it restarted from
    (the books' timing; None: no restart)."""
    phases = sim.phase_times()
    cycles = {str(n): c for n, c in sim.thread_use().items()}
    wall = process_wall
    if before:
        wall += before["wall_time_s"]
        phases = {name: t + before["phase_times_s"].get(name, 0.0) for name, t in phases.items()}
        for n, c in before["cycles_by_threads"].items():
            cycles[n] = cycles.get(n, 0) + c
        cycles = dict(sorted(cycles.items(), key=lambda item: int(item[0])))
    return {"wall_time_s": wall, "phase_times_s": phases, "cycles_by_threads": cycles}


def _books_to_carry(writer, series, sim, timing):
    """What a restart carries on from the run before its checkpoint (the
    checkpoint's books, JSON): the largest energy error and its time, the
    peak axial forces of the rigid planes and of each body with their
    times [N, s], each gauge's peak pressure with its time [Pa, s] and what
    it follows (Simulation.gauge_state of `sim`: a material gauge's
    particle since its switch time), the last history row the forces are
    rates from (its time [s], the planes' impulse and each body's axial
    momentum [N s], at the time of its half-step velocities,
    velocity_time [s]) and the snapshot series
    (metrics.snapshot_series records) with the &metrics group it was
    recorded under, and the run's timing so far (_run_timing), so that
    summary.json covers the whole run."""
    plane, bodies = writer.last_rates_row()
    states = sim.gauge_state()
    return {
        "metrics": _metrics_identity(sim.deck),
        "max_energy_error": writer.max_energy_error,
        "max_energy_error_time": writer.max_energy_error_time,
        "plane_force_peak": [writer.plane_force_peak, writer.plane_force_peak_time],
        "body_force_peaks": {name: list(peak) for name, peak in zip(writer.body_names,
                                                                   writer.body_force_peak)},
        "gauges": {g["name"]: {"kind": g["kind"], "point": [float(v) for v in g["point"]],
                               "peak_pressure": list(peak),
                               **{key: states[g["name"]][key] for key in _GAUGE_STATE}}
                   for g, peak in zip(writer.gauges, writer.gauge_peak)},
        "last_row": None if plane is None else {
            "velocity_time": float(plane[0]), "plane_impulse_z": float(plane[1]),
            "body_momentum_z": None if bodies is None else [float(v) for v in bodies[1]]},
        "series": series,
        "timing": timing}


#: What a checkpoint's books keep of each gauge's state (Simulation.gauge_state).
_GAUGE_STATE = ("on", "index", "switch_time", "lost_time")

#: The books a restart carries on (_books_to_carry), with what each must be.
_CARRIED = {"metrics": "the &metrics group", "max_energy_error": "a number",
            "max_energy_error_time": "a number",
            "plane_force_peak": "[force, time]", "body_force_peaks": "{body: [force, time]}",
            "gauges": "{gauge: {kind, point, peak_pressure, on, index, switch_time, lost_time}}",
            "last_row": "null or {velocity_time, plane_impulse_z, body_momentum_z}",
            "series": "a list of snapshot records with the same keys",
            "timing": "{wall_time_s, phase_times_s: {phase: s}, cycles_by_threads: {threads: cycles}}"}


def _carried_books_fit(books, body_names):
    """The name of the first of the checkpoint's books that is missing or
    not of its form (_CARRIED) for this run's bodies, None if all fit."""
    def number(v):
        return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)

    def pair(v):
        return isinstance(v, list) and len(v) == 2 and all(number(x) for x in v)

    def integer(v):
        return isinstance(v, int) and not isinstance(v, bool)

    gauges = books.get("gauges")
    row = books.get("last_row")
    timing = books.get("timing")
    fits = {
        "metrics": isinstance(books.get("metrics"), dict),
        "max_energy_error": number(books.get("max_energy_error")),
        "max_energy_error_time": number(books.get("max_energy_error_time")),
        "plane_force_peak": pair(books.get("plane_force_peak")),
        "body_force_peaks": isinstance(books.get("body_force_peaks"), dict)
        and all(pair(books["body_force_peaks"].get(name)) for name in body_names),
        "gauges": isinstance(gauges, dict) and all(
            isinstance(g, dict) and isinstance(g.get("peak_pressure"), list)
            and len(g["peak_pressure"]) == 2 and g.get("on") in layouts.GAUGE_SOURCES
            and integer(g.get("index"))
            and all(g.get(key) is None or number(g[key]) for key in ("switch_time", "lost_time"))
            for g in gauges.values()),
        "last_row": row is None or (
            isinstance(row, dict) and number(row.get("velocity_time"))
            and number(row.get("plane_impulse_z"))
            and (row.get("body_momentum_z") is None
                 or (isinstance(row["body_momentum_z"], list)
                     and len(row["body_momentum_z"]) == len(body_names)
                     and all(number(v) for v in row["body_momentum_z"])))),
        # records of one form: summary.json's series are columns of them
        "series": isinstance(books.get("series"), list)
        and all(isinstance(r, dict) for r in books["series"])
        and len({tuple(sorted(r)) for r in books["series"]}) <= 1,
        "timing": isinstance(timing, dict) and number(timing.get("wall_time_s"))
        and timing["wall_time_s"] >= 0.0
        and isinstance(timing.get("phase_times_s"), dict)
        and all(number(t) and t >= 0.0 for t in timing["phase_times_s"].values())
        and isinstance(timing.get("cycles_by_threads"), dict)
        and all(n.isdigit() and int(n) > 0 and integer(c) and c >= 0
                for n, c in timing["cycles_by_threads"].items()),
    }
    return next((key for key, ok in fits.items() if not ok), None)


def _resume_books(books, restart, sim):
    """Check the books of the run before the checkpoint `restart`
    (_books_to_carry) and give `sim` what of them it holds: a gauge
    carries on where the deck has a gauge of that name, kind and point (a
    restart may change the gauges), and a material gauge follows again
    what it followed (the particle its element turned into, since when).
    Before the output folder is touched: a checkpoint refused leaves it
    as it was. Books from a checkpoint written without them
    (checkpoint.save through the Python API: no outputs before it) are
    empty and not read."""
    if not books:
        return
    bad = _carried_books_fit(books, sim.body_names)
    if bad:
        raise CheckpointError(restart, "dataset /books", f"the books of the run before the "
                              f"checkpoint, '{bad}' {_CARRIED[bad]}", books.get(bad))
    states = {g["name"]: books["gauges"][g["name"]] for g in sim.deck["gauge"]
              if _same_gauge(books["gauges"].get(g["name"], {}), g)}
    try:
        sim.resume_gauges(states)
    except FsphError:
        raise CheckpointError(restart, "dataset /books", "gauges that follow particles of their "
                              "own bodies in this checkpoint's state",
                              {name: {key: s[key] for key in _GAUGE_STATE}
                               for name, s in states.items()}) from None


def _same_gauge(before, gauge):
    """Whether the books' gauge `before` is the deck's `gauge` (its kind
    and point)."""
    return [before.get("kind"), before.get("point")] == [gauge["kind"], [float(v) for v in gauge["point"]]]


def _carry_on(writer, books, sim):
    """Put the books of the run before the checkpoint, checked
    (_resume_books), into `writer`: the largest energy error, the peak
    forces and gauge pressures, the last history row; returns its
    snapshot series, None where the deck's &metrics differs from the one
    it was recorded under (a restart may change &metrics: the series then
    begins at the restart)."""
    writer.max_energy_error = books["max_energy_error"]
    writer.max_energy_error_time = books["max_energy_error_time"]
    writer.plane_force_peak, writer.plane_force_peak_time = books["plane_force_peak"]
    writer.body_force_peak = [tuple(books["body_force_peaks"][name]) for name in writer.body_names]
    for g, gauge in enumerate(writer.gauges):
        before = books["gauges"].get(gauge["name"], {})
        if _same_gauge(before, gauge):
            writer.gauge_peak[g] = tuple(before["peak_pressure"])
    row = books["last_row"]
    if row is not None:
        # the forces of the first rows after the restart are rates from this row
        writer.continue_rates_from(row["velocity_time"], row["plane_impulse_z"],
                                   row["body_momentum_z"])
    return books["series"] if books["metrics"] == _metrics_identity(sim.deck) else None


def _set_up(deck_path, outdir, restart):
    """Load the deck and its reference, set up the simulation (restored
    from the checkpoint `restart` unless None), take the output folder's
    lock and open the writer."""
    deck_path = Path(deck_path)
    deck = deck_module.load(deck_path)
    deck_text = deck_path.read_text()
    reference = references.load(deck)
    why = "" if reference is None else references.not_applied_because(reference, deck)
    sim = Simulation(deck)
    books = {}
    if restart is not None:
        outdir, books = _restart(sim, deck, restart, outdir)
        _resume_books(books, restart, sim)
    estimate.check_reachable(sim)
    outdir = Path(outdir) if outdir else Path("out") / deck_path.stem
    lock = FolderLock(outdir)
    try:
        writer = RunWriter(outdir, deck_text, deck["control"]["title"],
                           vtu=deck["output"]["vtu"], body_names=sim.body_names,
                           material_names=sim.material_names,
                           revolve=(deck["output"]["revolve_segments"], deck["output"]["revolve_angle"]),
                           gauges=deck["gauge"])
    except BaseException:
        lock.release()
        raise
    writer.energy0 = sim.initial_energy
    series = _carry_on(writer, books, sim) if books else None
    return _Setup(deck_path, deck, reference, why, outdir, lock, sim, writer,
                  references.run_inputs(deck_text, reference), series, books.get("timing"))


#: Column heads of the progress lines.
_PROGRESS_HEADER = (f"{'cycle':>9s} {'t [us]':>10s} {'dt [ns]':>9s} {'energy err':>11s} "
                    f"{'wall [s]':>9s} {'elements':>9s} {'particles':>9s}")


def _print_banner(say, setup, restart, lines):
    """The opening lines: case, mode, counts, threads and end time; where a
    restart begins; the deck's warnings; the progress lines' heads."""
    sim, deck_path, ctrl = setup.sim, setup.deck_path, setup.deck["control"]
    say(f"fsph: {ctrl['title'] or deck_path.stem}: mode {ctrl['mode']}, {sim.n_elements} elements, "
        f"{sim.n_nodes} nodes, {sim.n_particles} particles, {threads()} thread(s) "
        f"({sim.thread_policy}), "
        f"end time {ctrl['end_time'] * 1e6:g} us")
    if restart is not None:
        say(f"fsph: restarted from {restart} at t = {sim.time * 1e6:.6g} us, cycle {sim.cycle}")
    say(f"fsph: first time step {sim.dt * 1e9:.4g} ns: at least "
        f"{estimate.cycles_at_first_step(sim)} cycles to the end time")
    if setup.lock.stale:
        say(f"fsph: warning: took over the lock of a run that is gone (pid {setup.lock.stale}) "
            f"in {setup.outdir}")
    if setup.writer.removed_earlier:
        say(f"fsph: removed {setup.writer.removed_earlier} files an earlier run left in "
            f"{setup.outdir} (its ParaView series, checkpoint and pictures)")
    for text in setup.deck.get("warnings", []):
        say(f"fsph: warning: {text}")
    if lines:
        say(_PROGRESS_HEADER)


def _progress_line(sim, t_wall0):
    """One progress line: cycle, time [us], step [ns], energy error, wall
    time since t_wall0 [s], element and particle counts."""
    return (f"{sim.cycle:9d} {sim.time * 1e6:10.4f} {sim.dt * 1e9:9.4f} "
            f"{sim.energies()['relative_error']:+11.3e} "
            f"{wallclock.perf_counter() - t_wall0:9.2f} {sim.n_elements:9d} "
            f"{sim.n_particles:9d}")


@dataclass
class _Books:
    """What the run keeps from its outputs: the last snapshot written (the
    one the metrics use) and its metric record, the per-snapshot metric
    records of the whole run (perforation and debris series; a restart
    starts from those of the run before its checkpoint), and how the
    advance ended: the SimulationError of a failure, the signal name of an
    interruption (both None: completed); ended False while the run goes on
    (status 'running')."""

    last_good: dict = None
    last_record: dict = None
    series: list = field(default_factory=list)
    failure: SimulationError = None
    interrupted: str = None
    ended: bool = False

    def record(self, sim, deck, writer, in_series=True):
        """Take a snapshot of `sim`, write it with its metric record (and
        that record's history in fsph.h5 for the kinds that keep one) and
        keep the record, in the series unless in_series is False (the
        state a restart begins from: the run before it had its snapshots
        at the output times)."""
        snap = sim.snapshot()
        record = metrics_module.snapshot_series(snap, deck)
        units = metrics_module.series_units(deck)
        writer.write_snapshot(snap, (deck["metrics"]["kind"], record, units) if units else None)
        self.last_good, self.last_record = snap, record
        if record and in_series:
            self.series.append(record)

    @property
    def status(self):
        if self.failure:
            return "failed"
        if self.interrupted:
            return "interrupted"
        return "completed" if self.ended else "running"


@dataclass
class _Checkpoints:
    """Where and when the run writes its checkpoint: path, on or off
    (&output checkpoint), every `cycles` cycles (0: off) and every
    `minutes` of wall time (0: off); `last` the wall clock of the last one
    (or of the start) [s]; what a restart carries on (_books_to_carry):
    the run's set-up (its writer's books, the timing of the run before its
    own restart), the run's books and the wall clock of this process's
    start t_wall0 [s]."""

    path: Path
    enabled: bool
    cycles: int
    minutes: float
    last: float
    setup: _Setup
    books: _Books
    t_wall0: float

    @classmethod
    def from_output(cls, path, setup, books, t_wall0):
        """From the deck's &output of `setup`, the clock started now."""
        out = setup.deck["output"]
        return cls(path, out["checkpoint"], out["checkpoint_cycles"] if out["checkpoint"] else 0,
                   out["checkpoint_minutes"], wallclock.perf_counter(), setup, books, t_wall0)

    def due(self, cycle0, cycle):
        """Whether a call that went from cycle0 to cycle ends on a multiple
        of `cycles`, or `minutes` have passed since the last checkpoint."""
        return bool((self.cycles and cycle != cycle0 and cycle % self.cycles == 0)
                    or (self.enabled and self.minutes > 0.0
                        and wallclock.perf_counter() - self.last >= 60.0 * self.minutes))

    def save(self, sim):
        # the writer's books first take the history up to this cycle
        writer = self.setup.writer
        _drain_history(sim, writer)
        timing = _run_timing(sim, wallclock.perf_counter() - self.t_wall0, self.setup.timing_before)
        checkpoint_module.save(sim, self.path, _books_to_carry(writer, self.books.series, sim, timing))
        self.last = wallclock.perf_counter()


def _advance_to(sim, t, t_end, flag, energy_limit, checkpoints, bar):
    """Advance `sim` to time t [s] call by call, no step crossing the run's
    end time t_end (its last steps land on it), until t or a signal
    (flag), checking the energy error and writing the checkpoints that fall
    due after each call."""
    while sim.time < t and not flag["signal"]:
        # a call never crosses a multiple of checkpoint_cycles; where a
        # call ends does not alter the trajectory (land=False: the stable
        # step, shortened only to land on t_end)
        n_cycles = _cycles_this_call(sim.cycle, checkpoints.cycles)
        cycle0 = sim.cycle
        sim.advance(t, land=False, land_on=t_end, max_cycles=n_cycles, partial=True)
        if sim.cycle == cycle0:
            break           # within a billionth of a step of t: the solver counts it reached
        _check_energy(sim, energy_limit)
        if checkpoints.due(cycle0, sim.cycle):
            checkpoints.save(sim)
        if bar:
            bar.update(sim)


def _drain_history(sim, writer):
    """Hand the history records waiting in `sim` (with the bodies' books
    and the gauges' rows) and the gauges' state to `writer`."""
    writer.gauge_state = sim.gauge_state()
    writer.append_history(*sim.drain_histories(gauges=True))


def _stop_on_signal(say, sim, signum, checkpoints, bar):
    """Close the bar, write the checkpoint (when the deck keeps one) and say
    where the run stopped; returns the signal's name."""
    name = signal.Signals(signum).name
    if bar:
        bar.close()
    if checkpoints.enabled:
        checkpoints.save(sim)
        then = f"restart with --restart {checkpoints.path}"
    else:
        then = "no checkpoint (&output checkpoint = .false.), the run cannot be continued"
    say(f"fsph: {name} at t = {sim.time * 1e6:.6g} us, cycle {sim.cycle}: stopped; {then}")
    return name


def _record_failure(say, err, sim, writer, books, bar, outputs_usable=True):
    """Book a failed run: its error, the history up to it and the failure
    mark in the outputs (unless writing them is what failed); say where
    the last good snapshot is."""
    if bar:
        bar.close()
    books.failure = err
    if outputs_usable:
        _drain_history(sim, writer)
        writer.mark_failure(str(err))
    say(f"fsph: run failed: {err}")
    say(f"fsph: last good snapshot t = {books.last_good['time'] * 1e6:.4g} us kept in "
        f"{writer.h5_path}")


def _snapshot(setup, books, t_wall0, checkpoints=None, in_series=True):
    """Write a snapshot (once sure the disk has room for it), the checkpoint
    (checkpoints: a _Checkpoints, None for none), and summary.json with the
    status so far ('running'), so a run killed later leaves a summary of
    its last snapshot; in_series False keeps its metric record out of the
    run's series (_Books.record). OutputError when a write fails or would
    not fit."""
    sim = setup.sim
    checkpoint_bytes = 0
    if checkpoints and checkpoints.path.is_file():
        checkpoint_bytes = checkpoints.path.stat().st_size
    setup.writer.check_room(sim.time, checkpoint_bytes)
    books.record(sim, setup.deck, setup.writer, in_series)
    if checkpoints:
        checkpoints.save(sim)
    write_summary(setup.outdir, _summary(setup, books, t_wall0))


def _advance(say, setup, books, checkpoints, bar, lines, t_wall0):
    """Advance the run through its output times to &control end_time: the
    history after each, a snapshot (and checkpoint) and a progress line
    (lines: True) where due; the history still kept is written at the end.
    A SimulationError ends it as a failure, an OutputError as a failure
    that writes nothing more, SIGINT or SIGTERM as an interruption
    (books.failure, .interrupted)."""
    sim, deck, writer = setup.sim, setup.deck, setup.writer
    ctrl, out = deck["control"], deck["output"]
    t_start = sim.time
    written = {"snapshot": sim.cycle, "progress": None}      # cycles of the last outputs
    try:
        with _interrupt_flag() as flag:
            for t, snap_due, progress_due in _targets(ctrl["end_time"], out["n_snapshots"],
                                                      out["n_progress"]):
                if t <= t_start:
                    continue            # a restart begins after these
                # intermediate outputs never shorten a step; the run ends on end_time
                _advance_to(sim, t, ctrl["end_time"], flag, ctrl["energy_error_limit"],
                            checkpoints, bar)
                _drain_history(sim, writer)
                if flag["signal"]:
                    books.interrupted = _stop_on_signal(say, sim, flag["signal"], checkpoints, bar)
                    break
                # a step longer than the outputs' spacing passes several of
                # them: the first cycle end after them has their one output
                if snap_due and written["snapshot"] != sim.cycle:
                    _snapshot(setup, books, t_wall0,
                              checkpoints if checkpoints.enabled else None)
                    written["snapshot"] = sim.cycle
                if progress_due and lines and written["progress"] != sim.cycle:
                    say(_progress_line(sim, t_wall0))
                    written["progress"] = sim.cycle
        writer.flush()
    except SimulationError as err:
        _record_failure(say, err, sim, writer, books, bar)
    except OutputError as err:
        failure = SimulationError(f"run stopped at t = {sim.time * 1e6:.6g} us, cycle "
                                  f"{sim.cycle}: {err}", code=layouts.status_code("output"),
                                  time=sim.time, cycle=sim.cycle)
        _record_failure(say, failure, sim, writer, books, bar, outputs_usable=False)
    finally:
        if bar:
            bar.close()


def _final_metrics(books, deck, reference):
    """Case metrics of the last good snapshot, with the snapshot series
    (and a perforation's settling) where there is one, and their comparison
    with the reference ({} without)."""
    series = books.series
    # the last good snapshot's own record (Books.record keeps both)
    case_metrics = metrics_module.case_metrics(books.last_good, deck, books.last_record)
    if series:
        case_metrics["series"] = {key: [r[key] for r in series] for key in series[0]}
        if "perforation" in case_metrics:
            case_metrics["perforation"].update(metrics_module.perforation_settling(
                case_metrics["series"]["time_us"], case_metrics["series"]["velocity_z_m_s"]))
        if "debris" in case_metrics:
            from . import debris
            match = debris.impedance_check(books.last_good, debris.DebrisCase.from_deck(deck),
                                           series)
            if match is not None:           # both materials with a linear Us-up Hugoniot
                case_metrics["impedance_match"] = match
    comparison = metrics_module.compare(case_metrics, reference) if reference else {}
    return case_metrics, comparison


def _peaks(last_good, deck):
    """Peak plastic strain, temperature where a material heats, and
    specific internal energy of the last good snapshot
    (metrics.field_peaks). The internal energy is there for every run: a
    temperature from plastic work alone does not show a point heated by
    viscous, hourglass or contact work (a plate particle riding on a
    projectile at 4 MJ/kg and 918 K). Each peak carries the unit of its
    value (`unit`: the snapshots' unit of the field)."""
    # temperature only changes where plastic work heats a material with a
    # specific heat, or where it comes from the internal energy; a run
    # without either reports no temperature peak rather than room temperature
    heated = {m["name"] for m in deck["material"]
              if m.get("temperature") == "internal_energy"
              or (m["strength"] not in ("elastic", "hjc") and m.get("specific_heat") is not None)}
    peak_fields = ["plastic_strain"]
    if any(b["material"] in heated for b in deck["body"]):
        peak_fields.append("temperature")
    peak_fields.append("internal_energy")
    peaks = metrics_module.field_peaks(last_good, peak_fields)
    for name, peak in peaks.items():
        peak["unit"] = SNAPSHOT_UNITS[name]
    return peaks


def _energy_summary(sim, energies, writer):
    """The energy books of summary.json [J], relative errors [-] and the
    time of the largest [s]."""
    return {"initial_J": sim.initial_energy, "final_J": energies["total"],
            "kinetic_J": energies["kinetic"], "internal_J": energies["internal"],
            "conversion_heat_J": sim.conversion()["heat_J"],
            "contact_dissipation_J": energies["contact"],
            "plane_dissipation_J": energies["plane"],
            "eroded_J": energies["eroded"],
            "relative_error": energies["relative_error"],
            "max_relative_error": writer.max_energy_error,
            "max_relative_error_time_s": writer.max_energy_error_time}


def _plane_summary(sim, deck, writer):
    """The rigid planes' axial impulse on the bodies since t = 0 [N s] and
    the largest force between history rows [N] and its time [s]; None
    without a plane."""
    if not deck["boundary"]:
        return None
    return {"impulse_z_N_s": sim.plane_impulse_z(),
            "peak_force_z_N": writer.plane_force_peak,
            "peak_force_time_s": writer.plane_force_peak_time}


def _body_summary(writer):
    """Each body's books at the last history row (layouts.BODY_COLUMNS,
    keyed name_unit: kinetic_J, internal_J, momentum_z_N_s, plastic_work_J,
    viscous_work_J, hourglass_work_J, contact_work_J), and the largest
    axial force on it between history rows [N] with its time [s] (fsph.h5
    body_history)."""
    out = {}
    for b, name in enumerate(writer.body_names):
        books = writer.body_books.get(name, {})
        force, time = writer.body_force_peak[b]
        out[name] = {key_with_unit(key, unit): books.get(key) for key, unit, _ in layouts.BODY_COLUMNS}
        out[name].update(peak_force_z_N=force, peak_force_time_s=time)
    return out


def _ended_early_because(books, control):
    """Why a run that failed or was interrupted is not compared with its
    reference (whose values hold at the deck's end time, the conditions
    say): its metrics are those of its last good snapshot, before that
    time. "" for a run that completed or goes on."""
    if books.status not in ("failed", "interrupted"):
        return ""
    reached = books.last_good["time"] if books.last_good else 0.0
    return (f"the run {books.status} and its last good snapshot is at t = {reached * 1e6:.6g} us, "
            f"before its end time {control['end_time'] * 1e6:.6g} us")


def _summary(setup, books, t_wall0):
    """The summary dict of a run that has ended (summary.json)."""
    sim, deck, writer, reference = setup.sim, setup.deck, setup.writer, setup.reference
    ctrl = deck["control"]
    energies = sim.energies()
    why = setup.not_applied_because or _ended_early_because(books, ctrl)
    case_metrics, comparison = _final_metrics(books, deck, None if why else reference)
    peaks = _peaks(books.last_good, deck)
    warnings = [{"kind": "deck", "message": text} for text in deck.get("warnings", [])]
    warnings += _warnings(ctrl, energies, writer)
    process_wall = wallclock.perf_counter() - t_wall0
    timing = _run_timing(sim, process_wall, setup.timing_before)
    summary = {
        "case": setup.deck_path.stem,
        "title": ctrl["title"],
        "mode": ctrl["mode"],
        "status": books.status,
        "end_time_s": sim.time,
        "requested_end_time_s": ctrl["end_time"],
        "metrics_time_s": books.last_good["time"],
        "cycles": sim.cycle,
        # the whole run's: a restart adds what the run took before its checkpoint
        "wall_time_s": timing["wall_time_s"],
        # this process's, from its start
        "wall_time_process_s": process_wall,
        "threads": threads(),
        # the adaptive policy may run cycles on fewer threads (fsph_threads)
        "thread_policy": sim.thread_policy,
        "cycles_by_threads": timing["cycles_by_threads"],
        # wall time of each phase of the cycle (benchmarks' cost split)
        "phase_times_s": timing["phase_times_s"],
        "neighbour_list_builds": sim.list_rebuilds,
        "n_elements": sim.n_elements,
        "n_nodes": sim.n_nodes,
        "n_particles": sim.n_particles,
        "n_elements_initial": sim.n_elements0,
        "n_converted": sim.conversion()["n_converted"],
        "conversion": sim.conversion(),
        "erosion": sim.erosion(),
        "n_debris_particles": sim.debris_count(),
        "energy": _energy_summary(sim, energies, writer),
        "rigid_planes": _plane_summary(sim, deck, writer),
        "bodies": _body_summary(writer),
        "gauges": writer.gauge_summary(),
        "metrics": case_metrics,
        "peaks": peaks,
        "material_state": {b["name"]: state_masses(books.last_good, ib)
                           for ib, b in enumerate(deck["body"])},
        "warnings": warnings,
        # SHA-256 of the whole state at the end (fsph.checkpoint.state_digest;
        # None in the running summaries): the same deck on the same build and
        # kind of host ends with the same digest, whatever the thread count,
        # the outputs or a restart
        "state_digest": checkpoint_module.state_digest(sim) if books.ended else None,
        # SHA-256 of the deck's text and of the reference's values (references.run_inputs):
        # `fsph report` reuses this run only for the deck and reference as they are now
        "inputs": setup.inputs,
    }
    if reference:
        summary["reference"] = {"source": reference.get("source", ""), "applies": not why,
                                "comparison": comparison}
        if why:
            summary["reference"]["not_applied_because"] = why
    failure = books.failure
    if failure:
        summary["failure"] = {"message": str(failure), "code": failure.code,
                              "index": failure.index, "time_s": failure.time,
                              "cycle": failure.cycle}
    return summary


def _format_thread_use(summary):
    """One line: how many cycles ran on how many threads, and the policy."""
    use = summary["cycles_by_threads"]
    total = max(sum(use.values()), 1)
    parts = ", ".join(f"{n} for {100.0 * c / total:.0f} %" for n, c in
                      sorted(use.items(), key=lambda item: -int(item[0])))
    return (f"fsph: threads ({summary['thread_policy']} policy, at most {summary['threads']}): "
            f"{parts or 'no cycles'} of the cycles")


def _process_share(summary):
    """' (X s of it since the restart)' for a restarted run (its wall time
    is the whole run's, X this process's), else ''."""
    if summary["wall_time_s"] == summary["wall_time_process_s"]:
        return ""
    return f" ({summary['wall_time_process_s']:.2f} s of it since the restart)"


def _print_summary(say, summary, outdir):
    """The closing lines: status, time, cycles, wall time and energy error;
    the warnings; the metrics against their references; the peaks; where
    the outputs are."""
    warnings, energy = summary["warnings"], summary["energy"]
    status = summary["status"]
    if warnings:
        status += f" with {len(warnings)} warning{'s' if len(warnings) > 1 else ''}"
    say(f"fsph: {status} at t = {summary['end_time_s'] * 1e6:.4g} us after {summary['cycles']} "
        f"cycles, {summary['wall_time_s']:.2f} s wall{_process_share(summary)}; energy error "
        f"{energy['relative_error']:+.3e} (largest {energy['max_relative_error']:+.3e} at "
        f"{energy['max_relative_error_time_s'] * 1e6:.4g} us)")
    if summary["threads"] > 1:
        say(_format_thread_use(summary))
    for warning in warnings:
        say(f"fsph: warning: {warning['message']}")
    ref = summary.get("reference", {})
    if ref and not ref["applies"]:
        say(f"fsph: not compared with the reference ({ref['source']}): "
            f"{ref['not_applied_because']}")
    comparison = ref.get("comparison", {})
    metrics = summary["metrics"]
    if "debris" in metrics:
        for line in _format_debris(metrics, comparison):
            say(line)
        metrics = {k: v for k, v in metrics.items() if k not in ("debris", "impedance_match")}
    for line in _format_metrics(comparison, metrics):
        say(line)
    for line in _format_peaks(summary["peaks"]):
        say(line)
    for line in _format_material_state(summary["material_state"]):
        say(line)
    say(f"fsph: outputs in {outdir}/ (fsph.h5, ParaView .pvd series, summary.json)")


def _printer(quiet, stream):
    """say(text): print a line to `stream` and flush; nothing when quiet."""
    def say(text):
        if not quiet:
            print(text, file=stream, flush=True)
    return say


def run(deck_path, outdir=None, quiet=False, stream=None, restart=None, progress="auto"):
    """Run one deck; returns the summary dict (its 'status' says whether the
    run completed, failed or was interrupted). Raises DeckError for a bad
    deck. With restart, the state is read from that checkpoint first.
    progress: 'bar' (a tqdm bar), 'lines' (n_progress plain lines) or
    'auto' (the bar when `stream` is a terminal); quiet: neither."""
    stream = stream or sys.stdout
    kind = _progress_kind(progress, quiet, stream)
    say = _printer(quiet, stream)
    t_wall0 = wallclock.perf_counter()
    setup = _set_up(deck_path, outdir, restart)
    try:
        return _run(say, setup, restart, kind, stream, t_wall0)
    finally:
        setup.lock.release()


def _run(say, setup, restart, kind, stream, t_wall0):
    """The run of run() once set up: banner, the first snapshot, the
    advance to the end, the summary."""
    _print_banner(say, setup, restart, kind == "lines")
    books = _Books(series=list(setup.series or []))
    checkpoints = _Checkpoints.from_output(setup.outdir / "checkpoint.h5", setup, books, t_wall0)
    _drain_history(setup.sim, setup.writer)
    # a restart's first snapshot is the checkpoint's state, not an output
    # time of the run whose series it continues
    _snapshot(setup, books, t_wall0, in_series=setup.series is None)
    end_time = setup.deck["control"]["end_time"]
    bar = _ProgressBar(stream, setup.sim, end_time) if kind == "bar" else None
    _advance(say, setup, books, checkpoints, bar, kind == "lines", t_wall0)
    books.ended = True
    summary = _summary(setup, books, t_wall0)
    write_summary(setup.outdir, summary)
    _print_summary(say, summary, setup.outdir)
    return summary
