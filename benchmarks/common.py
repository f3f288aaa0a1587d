"""Shared pieces of the benchmark scripts: run a measurement in a child
process with a given OMP_NUM_THREADS (read once at start-up), describe
the machine, run or reuse a deck's outputs, refine a deck's meshes."""

import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

WORKLOADS = Path(__file__).resolve().parent / "workloads.py"


def run_child(code, args, threads):
    """Run `python -c code args...` with OMP_NUM_THREADS=threads; the child
    prints one JSON object on its last line."""
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    out = subprocess.run([sys.executable, "-c", code, *map(str, args)], env=env, check=True,
                         capture_output=True, text=True, cwd="/")
    return json.loads(out.stdout.strip().splitlines()[-1])


def run_workload(name, params, threads, env_extra=None, cpu=None):
    """Run benchmarks/workloads.py NAME PARAMS in a child process with
    OMP_NUM_THREADS=threads and env_extra (from /, so the installed fsph is
    imported), on processor `cpu` alone if given; returns its JSON result
    with the child's wall time from launch to exit (interpreter start-up
    included) as process_wall_s, and its start and end on this process's
    perf_counter clock as window_s."""
    env = dict(os.environ, OMP_NUM_THREADS=str(threads), **(env_extra or {}))
    pin = None if cpu is None else (lambda: os.sched_setaffinity(0, {cpu}))
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, str(WORKLOADS), name, json.dumps(params)], env=env,
                         check=True, capture_output=True, text=True, cwd="/", preexec_fn=pin)
    t1 = time.perf_counter()
    result = json.loads(out.stdout.strip().splitlines()[-1])
    result["process_wall_s"] = t1 - t0
    result["window_s"] = [t0, t1]
    return result


def refined_deck(deck, outdir, factors, suffix):
    """A copy of `deck` in outdir named STEM_SUFFIX.nml with every body's
    cell counts multiplied by their factors ((key, factor), ...; rounded)
    and the reference path made absolute; returns its path."""
    import f90nml
    deck = Path(deck)
    nml = f90nml.read(deck)
    bodies = nml["body"] if isinstance(nml["body"], list) else [nml["body"]]
    for body in bodies:
        for key, factor in factors:
            if key in body:
                body[key] = int(round(body[key] * factor))
    if "reference" in nml.get("output", {}):
        nml["output"]["reference"] = str((deck.parent / nml["output"]["reference"]).resolve())
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    path = outdir / f"{deck.stem}_{suffix}.nml"
    nml.write(path, force=True)
    return path


def machine():
    info = {"processor": platform.processor() or platform.machine(), "cpus": os.cpu_count(),
            "python": platform.python_version()}
    try:
        with open("/proc/cpuinfo") as fh:
            models = [line.split(":", 1)[1].strip() for line in fh if line.startswith("model name")]
        if models:
            info["cpu_model"] = models[0]
    except OSError:
        pass
    return info


def machine_line(info):
    return f"machine: {info.get('cpu_model', info['processor'])}, {info['cpus']} cpus"


def run_or_reuse(deck, outdir, rerun):
    """The summary of `fsph run deck` into outdir, reusing a finished
    run's summary.json unless rerun."""
    from fsph.driver import run
    summary_path = Path(outdir) / "summary.json"
    if summary_path.exists() and not rerun:
        return json.loads(summary_path.read_text())
    print(f"running {Path(deck).name} ...", flush=True)
    return run(deck, outdir, quiet=True)
