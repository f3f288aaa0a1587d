"""Command line: `fsph run DECK [-o DIR]`, `fsph check DECK`, `fsph sweep DECK
--set KEY=VALUES`, `fsph plot DIR`, `fsph report`, `fsph decks-reference`,
`fsph info`, `fsph --version`.

Exit codes: 0 success; 2 bad deck or usage; 3 the run went bad (outputs up
to the last good snapshot are kept; sweep: a variant did not complete;
report: a deck's run did not complete, the report is written); 4
interrupted by SIGINT/SIGTERM (a checkpoint is written); 1 any other fsph
error.
"""

import sys

from .errors import FsphError, InputError, OutputError

# Nothing more is imported before main() has taken over Ctrl-C: argparse,
# pathlib and the rest are imported where they are used.

EXIT_OK, EXIT_ERROR, EXIT_DECK, EXIT_RUN_FAILED, EXIT_INTERRUPTED = 0, 1, 2, 3, 4


def _parser():
    import argparse
    from . import __version__
    p = argparse.ArgumentParser(prog="fsph", description="Axisymmetric FEM-SPH impact hydrocode")
    p.add_argument("--version", action="version", version=f"fsph {__version__}",
                   help="print the version and exit")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run a namelist deck")
    r.add_argument("deck", help="namelist deck (.nml)")
    r.add_argument("-o", "--output", help="output folder (default out/<deck name>)")
    r.add_argument("-q", "--quiet", action="store_true", help="print nothing (no progress, no summary lines)")
    r.add_argument("--progress", choices=("auto", "bar", "lines"), default="auto",
                   help="progress display: a bar with simulated time, cycle, step, counts and "
                        "ETA (bar), n_progress plain lines (lines), or the bar on a terminal "
                        "and lines otherwise (auto, the default)")
    r.add_argument("--restart", help="continue from this checkpoint (checkpoint.h5 of a run "
                                     "of the same deck)")
    ck = sub.add_parser("check", help="validate a deck and its starting state without running "
                                       "it; print the bodies' counts and smallest cells, the "
                                       "first time step and an estimate of the cycles and wall "
                                       "time (a few cycles are timed)")
    ck.add_argument("deck", help="namelist deck (.nml)")
    sw = sub.add_parser("sweep", help="run variants of a deck as Dask tasks (ranges and lists "
                                      "of deck keys, their Cartesian product) and gather "
                                      "their results in DIR/sweep.csv and sweep.h5 "
                                      "(docs/sweeps.md)")
    sw.add_argument("deck", help="base namelist deck (.nml)")
    sw.add_argument("--set", dest="sets", action="append", required=True,
                    metavar="GROUP.KEY=VALUES",
                    help="a deck key and its values: GROUP.KEY, GROUP(I).KEY (I-th group "
                         "of that name, from 1) or GROUP(NAME).KEY; VALUES a:b:n (n values "
                         "from a to b inclusive), log:a:b:n (logarithmic) or v1,v2,...; "
                         "repeat for a Cartesian product")
    sw.add_argument("-o", "--output", help="sweep folder (default out/<deck name>_sweep)")
    sw.add_argument("--scheduler", help="address of a running Dask scheduler (default: a "
                                        "local cluster on this machine)")
    sw.add_argument("--workers", type=int, help="concurrent runs of the local cluster "
                                                "(default cores // threads)")
    sw.add_argument("--threads", type=int, default=1,
                    help="OpenMP threads of each run (default 1)")
    sw.add_argument("--free-p", action="store_true",
                    help="fit the Recht-Ipson exponent p too (default p = 2)")
    sw.add_argument("--rerun", action="store_true", help="run completed variants again")
    sw.add_argument("--max-variants", type=int, default=None, metavar="N",
                    help="refuse a sweep of more than N variants before writing anything "
                         "(default 10000)")
    sw.add_argument("-q", "--quiet", action="store_true", help="print nothing")
    pl = sub.add_parser("plot", help="PNGs of a run: deformed body at chosen times "
                                     "(shapes.png), energy and time-step histories "
                                     "(history.png), and where they apply the perforation "
                                     "histories (perforation.png), the damage map "
                                     "(damage.png), the gauges (gauges.png) and each "
                                     "body's energies (bodies.png); with --field, pictures "
                                     "of fields (field_NAME.png) instead; with --history, "
                                     "only the time histories")
    pl.add_argument("run_dir", help="output folder of `fsph run`")
    pl.add_argument("--times",
                    help="times in µs, comma separated: each panel draws the snapshot "
                         "nearest a time (each snapshot once) and is titled with the "
                         "snapshot's own time; a line names the snapshots drawn where they "
                         "are not at the times asked (default: four snapshots spread evenly "
                         "from the first to the last; a debris run: the snapshot of its "
                         "metrics)")
    pl.add_argument("--field", metavar="NAME[,NAME...]",
                    help="draw only these fields, each into RUN_DIR/field_NAME.png, at the "
                         "times of shapes.png: eps_p (equivalent plastic strain), pressure "
                         "[GPa], mises (von Mises stress [GPa]), temperature [K], damage, "
                         "density [kg/m^3], material; elements and particles on one colour "
                         "scale, mirrored about the axis")
    pl.add_argument("--history", action="store_true",
                    help="draw only the time histories: history.png (energies, energy "
                         "error, rigid-plane and body forces, time step), bodies.png (each "
                         "body's kinetic and internal energy, plastic, viscous, hourglass and "
                         "contact work) and, where they apply, gauges.png and "
                         "perforation.png")
    pl.add_argument("-o", "--output", help="PNG file (default RUN_DIR/shapes.png; with one "
                                           "--field, its picture)")
    pl.add_argument("--dpi", type=int, default=150, help="resolution of the PNG")
    report_help = ("run the validation decks (or reuse their outputs where deck and reference "
                   "are unchanged) and write a report with errors against the references; exit "
                   "3 when a deck's run did not complete (the report is written all the same)")
    rp = sub.add_parser("report", help=report_help, description=report_help)
    rp.add_argument("--cases", help="folder of the decks, their references in references/ "
                                    "beside them (default: the validation decks installed "
                                    "with fsph)")
    rp.add_argument("-o", "--output", default="out/report", help="report folder")
    rp.add_argument("--decks", help="comma-separated deck names (default: the validation set)")
    rp.add_argument("--rerun", action="store_true", help="run again even where the outputs of "
                                                          "the deck and reference as they are "
                                                          "now exist")
    d = sub.add_parser("decks-reference", help="print the deck reference (markdown)")
    d.add_argument("-o", "--output", help="write to this file instead")
    sub.add_parser("info", help="version and OpenMP threads")
    return p


#: picture formats `fsph plot -o` writes (matplotlib's Agg backend)
PLOT_FORMATS = (".png", ".pdf", ".svg")
#: the resolutions `fsph plot --dpi` accepts [dots per inch]
PLOT_DPI = (10, 2400)


def _check(deck_path):
    """`fsph check`: the deck validated and set up (DeckError: exit 2),
    then its sizes and the estimate of its cost."""
    from . import deck as deck_module
    from . import estimate
    from .simulation import Simulation, threads
    deck = deck_module.load(deck_path)
    sim = Simulation(deck)
    estimate.check_reachable(sim)
    print(f"fsph check: {deck_path}: the deck and its starting state are valid")
    for text in deck.get("warnings", []):
        print(f"fsph: warning: {text}")
    for line in estimate.report_lines(sim, threads()):
        print(line)
    return EXIT_OK


def _plot_times(text):
    """--times as a list of finite times >= 0 [µs]; InputError otherwise."""
    import math
    expected = f"--times: expected times in microseconds >= 0 separated by commas, got {text!r}"
    try:
        times = [float(t) for t in text.split(",") if t.strip()]
    except ValueError:
        raise InputError(expected) from None
    if not times or not all(math.isfinite(t) and t >= 0.0 for t in times):
        raise InputError(expected)
    return times


def _plot_fields(text, run_dir):
    """--field as a list of distinct field names the run has; InputError
    (one line: the field, why, the fields the run has) otherwise."""
    from .plot import FIELDS, missing_fields
    names = list(dict.fromkeys(n.strip() for n in text.split(",") if n.strip()))
    if not names:
        raise InputError(f"--field: expected field names separated by commas "
                         f"({', '.join(FIELDS)}), got {text!r}")
    missing = missing_fields(run_dir)
    available = ", ".join(f for f in FIELDS if f not in missing)
    for name in names:
        if name not in FIELDS or name in missing:
            why = missing.get(name, "no such field")
            raise InputError(f"--field {name}: {why}; fields of this run: {available}")
    return names


def _plot_run_dir(run_dir):
    """The run folder of `fsph plot` checked before anything is drawn:
    a folder (not one of its files) with a readable summary.json and
    fsph.h5 (fsph.plot.read_summary, check_run_file); InputError, one
    line, otherwise."""
    from .plot import check_run_file, read_summary
    if run_dir.is_file():
        raise InputError(f"{run_dir}: a file; expected the output folder of `fsph run` "
                         f"(the folder that holds fsph.h5 and summary.json)")
    for name in ("fsph.h5", "summary.json"):
        if not (run_dir / name).is_file():
            raise InputError(f"{run_dir}: expected the output folder of `fsph run` (no {name})")
    read_summary(run_dir)
    check_run_file(run_dir)


def _plot(args):
    """`fsph plot`: the arguments checked (InputError, exit 2) before any picture is drawn."""
    from pathlib import Path
    from .plot import (body_energies, cannot_read, damage_map, deformed_shapes, field_map,
                       gauge_histories, histories, nearest_note, perforation_histories,
                       snapshot_choice)
    times = _plot_times(args.times) if args.times is not None else None
    if not PLOT_DPI[0] <= args.dpi <= PLOT_DPI[1]:
        raise InputError(f"--dpi: expected an integer from {PLOT_DPI[0]} to {PLOT_DPI[1]}, "
                         f"got {args.dpi}")
    run_dir = Path(args.run_dir)
    _plot_run_dir(run_dir)
    if args.output:
        output = Path(args.output)
        if output.suffix.lower() not in PLOT_FORMATS:
            raise InputError(f"-o {output}: expected a file name ending in "
                             f"{', '.join(PLOT_FORMATS)}")
        if not output.parent.is_dir():
            raise InputError(f"-o {output}: expected an existing folder, no {output.parent}")
    if args.history:
        clash = [name for name, given in (("--field", args.field is not None),
                                          ("--times", times is not None), ("-o", bool(args.output))) if given]
        if clash:
            raise InputError(f"--history: draws the time histories only, each into its RUN_DIR file; "
                             f"expected no {', '.join(clash)}")
    fields = _plot_fields(args.field, run_dir) if args.field is not None else None
    if fields and len(fields) > 1 and args.output:
        raise InputError(f"-o {args.output}: names one picture, --field asks for {len(fields)} "
                         f"(without -o each goes to RUN_DIR/field_NAME.png)")
    try:
        note = nearest_note(snapshot_choice(run_dir, times)) if times else None
        if note:
            print(note)
        if fields:
            for name in fields:
                print(field_map(run_dir, name, times, args.output, args.dpi))
            return EXIT_OK
        if not args.history:
            print(deformed_shapes(run_dir, times, args.output, args.dpi))
        print(histories(run_dir, dpi=args.dpi))
        for extra in (perforation_histories(run_dir, dpi=args.dpi),
                      None if args.history else damage_map(run_dir, times, dpi=args.dpi),
                      gauge_histories(run_dir, dpi=args.dpi),
                      body_energies(run_dir, dpi=args.dpi)):
            if extra:
                print(extra)
    except OSError as err:      # h5py's reading; a picture not written says so itself
        if err.filename:
            raise InputError(f"{err.filename}: {err.strerror or err}") from None
        raise InputError(cannot_read(run_dir / "fsph.h5", err)) from None
    return EXIT_OK


def _exit_of_runs(statuses):
    """Exit code of `fsph report` and `fsph sweep` from their runs'
    statuses: 4 where one was interrupted, 3 where one did not complete
    (the report and the sweep's table are written all the same and name
    them), else 0."""
    statuses = list(statuses)
    if "interrupted" in statuses:
        return EXIT_INTERRUPTED
    return EXIT_OK if all(s == "completed" for s in statuses) else EXIT_RUN_FAILED


#: The modules of each command, imported before it begins (main): the
#: solver, numpy, h5py and the rest come with them (about 0.3 s).
COMMAND_MODULES = {"run": ("driver",), "check": ("estimate", "simulation"), "sweep": ("sweep",),
                   "plot": ("plot",), "report": ("report",), "decks-reference": ("deck",),
                   "info": ("simulation",)}
#: What a Ctrl-C outside a run's own handling prints (stderr).
INTERRUPTED = "fsph: interrupted"


def _interrupted(exit_now):
    """The one line and the exit code of a Ctrl-C outside a run's own
    handling (which stops at the end of a call, with a checkpoint). With
    exit_now the process ends here, its output flushed, without the
    interpreter's shutdown: a Ctrl-C during the imports leaves modules
    half set up (h5py's printed errors of their own as they were cleared
    away, and one made the process end by SIGINT after the line)."""
    if not exit_now:
        print(INTERRUPTED, file=sys.stderr)
        return EXIT_INTERRUPTED
    import os
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError, RuntimeError):   # closed, or in the middle of a write
            pass
    os.write(2, f"{INTERRUPTED}\n".encode())
    os._exit(EXIT_INTERRUPTED)


def _exit_at_interrupt(signum, frame):
    """The SIGINT and SIGTERM handler while the program starts (_start)."""
    _interrupted(exit_now=True)


def _start(argv, exit_at_interrupt):
    """The parsed command line, the modules of its command imported
    (COMMAND_MODULES). With exit_at_interrupt a Ctrl-C meanwhile ends the
    process at once (_interrupted): as a KeyboardInterrupt it could be
    raised inside a clean-up the import machinery runs (a weak
    reference's callback), which drops it with a traceback, and the run
    went on. SIGTERM likewise. A signal the process was started to ignore
    stays ignored."""
    import signal
    previous = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    caught = [sig for sig, handler in previous.items()
              if exit_at_interrupt and handler is not signal.SIG_IGN]
    for sig in caught:
        signal.signal(sig, _exit_at_interrupt)
    try:
        args = _parser().parse_args(argv)
        for name in COMMAND_MODULES[args.command]:
            __import__(f"{__package__}.{name}")
        return args
    finally:
        for sig in caught:
            # SIGINT: Python's own (KeyboardInterrupt) unless another was set in C
            signal.signal(sig, signal.default_int_handler if previous[sig] is None
                          else previous[sig])


#: How long after a Ctrl-C dropped in a clean-up _unraisable raises it
#: again [s]: long enough for the clean-up to have returned.
UNRAISABLE_INTERRUPT_DELAY_S = 0.01


def _unraisable(info):
    """sys.unraisablehook of the program: a Ctrl-C (KeyboardInterrupt)
    that came while Python ran a clean-up that cannot raise (a weak
    reference's callback, a __del__: a lazy import of numpy's, say) is
    raised again in the program's own code, where main() reports it,
    instead of being dropped with a traceback while the run went on;
    anything else as Python reports it."""
    if issubclass(info.exc_type, KeyboardInterrupt):
        import _thread
        import threading
        # SIGINT again, from another thread a moment later, so that it is
        # handled once this has returned: raised here (signal.raise_signal,
        # or _thread.interrupt_main called in this thread, whose pending
        # SIGINT Python handles right after the call) it would be dropped
        # again
        again = threading.Timer(UNRAISABLE_INTERRUPT_DELAY_S, _thread.interrupt_main)
        again.daemon = True
        again.start()
        return
    sys.__unraisablehook__(info)


def _terminate_as_interrupt(signum, frame):
    """The program's SIGTERM outside a run's own handling (the driver's,
    which stops at the end of a call with a checkpoint): as a Ctrl-C, one
    line and exit 4 (it ended the process without a word)."""
    raise KeyboardInterrupt


def program():
    """The program `fsph` (the console script, and python -m fsph): main()
    on the command line, a Ctrl-C or a SIGTERM that it reports ending the
    process at once (_interrupted), none dropped in a clean-up
    (_unraisable)."""
    import signal
    sys.unraisablehook = _unraisable
    if signal.getsignal(signal.SIGTERM) is signal.SIG_DFL:
        signal.signal(signal.SIGTERM, _terminate_as_interrupt)
    return main(exit_at_interrupt=True)


def main(argv=None, exit_at_interrupt=False):
    """The command line (argv: the arguments, default sys.argv[1:]);
    returns the exit code. A Ctrl-C at any moment from here, the imports
    of the solver, numpy and h5py included (fsph imports them on first
    use, after this has begun), ends with one line and exit 4, as later in
    a run; with exit_at_interrupt the process ends there (_interrupted)."""
    try:
        args = _start(argv, exit_at_interrupt)
    except KeyboardInterrupt:
        return _interrupted(exit_at_interrupt)
    try:
        if args.command == "run":
            from .driver import run
            summary = run(args.deck, args.output, quiet=args.quiet, restart=args.restart,
                          progress=args.progress)
            return {"failed": EXIT_RUN_FAILED, "interrupted": EXIT_INTERRUPTED}.get(
                summary["status"], EXIT_OK)
        if args.command == "check":
            return _check(args.deck)
        if args.command == "sweep":
            from .sweep import MAX_VARIANTS, sweep
            max_variants = MAX_VARIANTS if args.max_variants is None else args.max_variants
            if args.threads < 1 or (args.workers is not None and args.workers < 1) \
                    or max_variants < 1:
                print("fsph: error: --threads, --workers and --max-variants: expected integers "
                      ">= 1", file=sys.stderr)
                return EXIT_DECK
            frame = sweep(args.deck, args.sets, args.output, scheduler=args.scheduler,
                          workers=args.workers, threads=args.threads, free_p=args.free_p,
                          rerun=args.rerun, quiet=args.quiet, max_variants=max_variants)
            return _exit_of_runs(frame["status"])
        if args.command == "plot":
            return _plot(args)
        if args.command == "report":
            from pathlib import Path
            from .report import VALIDATION_DECKS, installed_cases, make_report
            decks = tuple(d.strip() for d in args.decks.split(",")) if args.decks else VALIDATION_DECKS
            cases = Path(args.cases) if args.cases is not None else installed_cases()
            if not cases.is_dir():
                raise InputError(f"{cases}: expected a folder of decks (--cases)"
                                 if args.cases is not None else
                                 f"{cases}: the validation decks are not installed with fsph; "
                                 "name a folder of decks with --cases")
            for name in decks:
                if not name or not (cases / f"{name}.nml").is_file():
                    raise InputError(f"{cases}: expected a deck {name}.nml (--decks)")
            path, statuses = make_report(cases, args.output, decks, args.rerun, say=print)
            print(path)
            return _exit_of_runs(statuses.values())
        if args.command == "decks-reference":
            from .deck import reference_markdown
            text = reference_markdown()
            if args.output:
                with open(args.output, "w") as fh:
                    fh.write(text)
            else:
                sys.stdout.write(text)
            return EXIT_OK
        if args.command == "info":
            from . import __version__, threads
            from .simulation import (THREAD_POLICIES, THREAD_POLICY_VARIABLE, openmp_wait_settings,
                                     thread_policy)
            policy = thread_policy()
            waits = ", ".join(f"{k}={v}" for k, v in openmp_wait_settings().items())
            print(f"fsph {__version__}, OpenMP threads: {threads()} at most")
            print(f"thread policy: {policy} ({THREAD_POLICY_VARIABLE}): {THREAD_POLICIES[policy]}")
            print(f"OpenMP wait: {waits}")
            return EXIT_OK
    except InputError as err:
        print(f"fsph: error: {err}", file=sys.stderr)
        return EXIT_DECK
    except OutputError as err:
        print(f"fsph: error: {err}", file=sys.stderr)
        return EXIT_RUN_FAILED
    except KeyboardInterrupt:
        return _interrupted(exit_at_interrupt)
    except FsphError as err:
        print(f"fsph: error: {err}", file=sys.stderr)
        return EXIT_ERROR
    return EXIT_ERROR


if __name__ == "__main__":
    raise SystemExit(program())
