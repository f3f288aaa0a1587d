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
