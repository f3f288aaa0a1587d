"""Shared pieces of the benchmark scripts: run a measurement in a child
process with a given OMP_NUM_THREADS (read once at start-up) and describe
the machine."""

import json
import os
import platform
import subprocess
import sys


def run_child(code, args, threads):
    """Run `python -c code args...` with OMP_NUM_THREADS=threads; the child
    prints one JSON object on its last line."""
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    out = subprocess.run([sys.executable, "-c", code, *map(str, args)], env=env, check=True,
                         capture_output=True, text=True, cwd="/")
    return json.loads(out.stdout.strip().splitlines()[-1])


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
    from pathlib import Path
    from fsph.driver import run
    summary_path = Path(outdir) / "summary.json"
    if summary_path.exists() and not rerun:
        return json.loads(summary_path.read_text())
    print(f"running {Path(deck).name} ...", flush=True)
    return run(deck, outdir, quiet=True)
