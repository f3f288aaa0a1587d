"""Run a deck from start to end: set up, advance output interval by output
interval, write history, snapshots and summary, report metrics."""

import json
import shutil
import signal
import sys
import time as wallclock
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from . import checkpoint as checkpoint_module
from . import deck as deck_module
from . import metrics as metrics_module
from .errors import FsphError, SimulationError
from .output import RunWriter, write_summary
from .simulation import Simulation, threads


def _targets(t_end, n_snapshots, n_progress):
    """Merged output times: (time, write_snapshot, print_progress)."""
    snaps = {round(k * 10**9 / n_snapshots): True for k in range(1, n_snapshots + 1)}
    progs = {round(k * 10**9 / n_progress): True for k in range(1, n_progress + 1)}
    keys = sorted(set(snaps) | set(progs))
    return [(t_end * k / 10**9, k in snaps, k in progs) for k in keys]


def _load_reference(deck):
    ref = deck["output"]["reference"]
    if ref is None:
        return None
    return json.loads((Path(deck["dir"]) / ref).read_text())


def _format_metrics(comparison, metrics):
    lines = []
    for group, values in metrics.items():
        for key, val in values.items():
            if not isinstance(val, float):
                continue
            cmp = comparison.get(group, {}).get(key)
            text = f"  {group}.{key:<14s} {val:10.4g}"
            if cmp:
                text += f"   reference {cmp['reference']:.4g}   error {cmp['error_percent']:+.1f} %"
            lines.append(text)
    return lines


def _format_peaks(peaks):
    """Printed lines of the peak fields (metrics.field_peaks)."""
    units = {"plastic_strain": "", "temperature": " K"}
    return [f"  peak {name:<17s} {p['value']:10.4g}{units[name]}   at r {p['r_mm']:.3f} mm, "
            f"z {p['z_mm']:.3f} mm ({p['in']} {p['index']})" for name, p in peaks.items()]


def _warnings(ctrl, energies, writer):
    """What a user must not miss about a run that completed: an energy
    error beyond &control energy_error_warning (the largest during the run
    or the final one). A list of {kind, message, value, limit}."""
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
            code=12, time=sim.time, cycle=sim.cycle)


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


def run(deck_path, outdir=None, quiet=False, stream=None, restart=None, progress="auto"):
    """Run one deck; returns the summary dict (its 'status' says whether the
    run completed, failed or was interrupted). Raises DeckError for a bad
    deck. With restart, the state is read from that checkpoint first.
    progress: 'bar' (a tqdm bar), 'lines' (n_progress plain lines) or
    'auto' (the bar when `stream` is a terminal); quiet: neither."""
    stream = stream or sys.stdout
    kind = _progress_kind(progress, quiet, stream)

    def say(text):
        if not quiet:
            print(text, file=stream, flush=True)

    t_wall0 = wallclock.perf_counter()
    deck_path = Path(deck_path)
    deck = deck_module.load(deck_path)
    reference = _load_reference(deck)
    outdir = Path(outdir) if outdir else Path("out") / deck_path.stem
    sim = Simulation(deck)
    if restart is not None:
        checkpoint_module.restore(sim, restart)
    ctrl, out = deck["control"], deck["output"]
    writer = RunWriter(outdir, deck_path.read_text(), ctrl["title"], vtu=out["vtu"])
    checkpoint_path = outdir / "checkpoint.h5"
    say(f"fsph: {ctrl['title'] or deck_path.stem}: mode {ctrl['mode']}, {sim.n_elements} elements, "
        f"{sim.n_nodes} nodes, {sim.n_particles} particles, {threads()} thread(s), "
        f"end time {ctrl['end_time'] * 1e6:g} us")
    if restart is not None:
        say(f"fsph: restarted from {restart} at t = {sim.time * 1e6:.6g} us, cycle {sim.cycle}")
    for text in deck.get("warnings", []):
        say(f"fsph: warning: {text}")
    if kind == "lines":
        say(f"{'cycle':>9s} {'t [us]':>10s} {'dt [ns]':>9s} {'energy err':>11s} {'wall [s]':>9s} "
            f"{'elements':>9s} {'particles':>9s}")
    last_good = sim.snapshot()
    writer.write_snapshot(last_good)
    series = [r for r in [metrics_module.snapshot_series(last_good, deck)] if r]
    writer.energy0 = sim.initial_energy
    writer.append_history(sim.drain_history())
    failure = interrupted = None
    last_checkpoint = wallclock.perf_counter()
    every = out["checkpoint_cycles"] if out["checkpoint"] else 0
    bar = _ProgressBar(stream, sim, ctrl["end_time"]) if kind == "bar" else None
    try:
        with _interrupt_flag() as flag:
            for t, snap_due, progress_due in _targets(ctrl["end_time"], out["n_snapshots"],
                                                      out["n_progress"]):
                if t <= sim.time:
                    continue            # a restart begins after these
                # intermediate outputs never shorten a step; the run ends on end_time
                land = t >= ctrl["end_time"]
                while sim.time < t and not flag["signal"]:
                    # a call never crosses a multiple of checkpoint_cycles; where a
                    # call ends does not alter the trajectory (land=False)
                    n_cycles = _cycles_this_call(sim.cycle, every)
                    cycle0 = sim.cycle
                    sim.advance(t, land=land, max_cycles=n_cycles, partial=True)
                    _check_energy(sim, ctrl["energy_error_limit"])
                    if ((every and sim.cycle != cycle0 and sim.cycle % every == 0)
                            or (out["checkpoint"] and out["checkpoint_minutes"] > 0.0
                                and wallclock.perf_counter() - last_checkpoint
                                >= 60.0 * out["checkpoint_minutes"])):
                        checkpoint_module.save(sim, checkpoint_path)
                        last_checkpoint = wallclock.perf_counter()
                    if bar:
                        bar.update(sim)
                writer.append_history(sim.drain_history())
                if flag["signal"]:
                    interrupted = signal.Signals(flag["signal"]).name
                    if bar:
                        bar.close()
                    if out["checkpoint"]:
                        checkpoint_module.save(sim, checkpoint_path)
                    say(f"fsph: {interrupted} at t = {sim.time * 1e6:.6g} us, cycle {sim.cycle}: "
                        f"stopped; restart with --restart {checkpoint_path}")
                    break
                if snap_due:
                    last_good = sim.snapshot()
                    writer.write_snapshot(last_good)
                    record = metrics_module.snapshot_series(last_good, deck)
                    if record:
                        series.append(record)
                    if out["checkpoint"]:
                        checkpoint_module.save(sim, checkpoint_path)
                        last_checkpoint = wallclock.perf_counter()
                if progress_due and kind == "lines":
                    say(f"{sim.cycle:9d} {sim.time * 1e6:10.4f} {sim.dt * 1e9:9.4f} "
                        f"{sim.energies()['relative_error']:+11.3e} "
                        f"{wallclock.perf_counter() - t_wall0:9.2f} {sim.n_elements:9d} "
                        f"{sim.n_particles:9d}")
    except SimulationError as err:
        if bar:
            bar.close()
        failure = err
        writer.append_history(sim.drain_history())
        writer.mark_failure(str(err))
        say(f"fsph: run failed: {err}")
        say(f"fsph: last good snapshot t = {last_good['time'] * 1e6:.4g} us kept in {writer.h5_path}")
    finally:
        if bar:
            bar.close()
    writer.close()

    energies = sim.energies()
    case_metrics = metrics_module.case_metrics(last_good, deck)
    if series:
        case_metrics["series"] = {key: [r[key] for r in series] for key in series[0]}
        if "perforation" in case_metrics:
            case_metrics["perforation"].update(metrics_module.perforation_settling(
                case_metrics["series"]["time_us"], case_metrics["series"]["velocity_z_m_s"]))
    comparison = metrics_module.compare(case_metrics, reference) if reference else {}
    # temperature only changes where Johnson-Cook heats adiabatically; a run
    # without it reports no temperature peak rather than room temperature
    heated = {m["name"] for m in deck["material"] if m["strength"] == "johnson_cook"}
    peak_fields = ["plastic_strain"]
    if any(b["material"] in heated for b in deck["body"]):
        peak_fields.append("temperature")
    peaks = metrics_module.field_peaks(last_good, peak_fields)
    warnings = [{"kind": "deck", "message": text} for text in deck.get("warnings", [])]
    warnings += _warnings(ctrl, energies, writer)
    summary = {
        "case": deck_path.stem,
        "title": ctrl["title"],
        "mode": ctrl["mode"],
        "status": "failed" if failure else ("interrupted" if interrupted else "completed"),
        "end_time_s": sim.time,
        "requested_end_time_s": ctrl["end_time"],
        "metrics_time_s": last_good["time"],
        "cycles": sim.cycle,
        "wall_time_s": wallclock.perf_counter() - t_wall0,
        "threads": threads(),
        # wall time of each phase of the cycle (benchmarks' cost split)
        "phase_times_s": sim.phase_times(),
        "neighbour_list_builds": sim.list_rebuilds,
        "n_elements": sim.n_elements,
        "n_nodes": sim.n_nodes,
        "n_particles": sim.n_particles,
        "n_elements_initial": sim.n_elements0,
        "n_converted": sim.conversion()["n_converted"],
        "conversion": sim.conversion(),
        "erosion": sim.erosion(),
        "n_debris_particles": sim.debris_count(),
        "energy": {"initial_J": sim.initial_energy, "final_J": energies["total"],
                   "kinetic_J": energies["kinetic"], "internal_J": energies["internal"],
                   "conversion_heat_J": sim.conversion()["heat_J"],
                   "contact_dissipation_J": energies["contact"],
                   "plane_dissipation_J": energies["plane"],
                   "eroded_J": energies["eroded"],
                   "relative_error": energies["relative_error"],
                   "max_relative_error": writer.max_energy_error,
                   "max_relative_error_time_s": writer.max_energy_error_time},
        "metrics": case_metrics,
        "peaks": peaks,
        "warnings": warnings,
    }
    if reference:
        summary["reference"] = {"source": reference.get("source", ""), "comparison": comparison}
    if failure:
        summary["failure"] = {"message": str(failure), "code": failure.code,
                              "index": failure.index, "time_s": failure.time,
                              "cycle": failure.cycle}
    write_summary(outdir, summary)

    status = summary["status"]
    if warnings:
        status += f" with {len(warnings)} warning{'s' if len(warnings) > 1 else ''}"
    say(f"fsph: {status} at t = {sim.time * 1e6:.4g} us after {sim.cycle} cycles, "
        f"{summary['wall_time_s']:.2f} s wall; energy error {energies['relative_error']:+.3e} "
        f"(largest {writer.max_energy_error:+.3e} at {writer.max_energy_error_time * 1e6:.4g} us)")
    for warning in warnings:
        say(f"fsph: warning: {warning['message']}")
    for line in _format_metrics(comparison, case_metrics):
        say(line)
    for line in _format_peaks(peaks):
        say(line)
    say(f"fsph: outputs in {outdir}/ (fsph.h5, ParaView .pvd series, summary.json)")
    return summary
