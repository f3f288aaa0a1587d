"""Parameter sweeps on Dask distributed: one base deck expanded into
variants (ranges and lists of any deck keys, their Cartesian product), each
variant run as a Dask task in its own folder, the results gathered into
one table (sweep.csv, sweep.h5) and, for striking-velocity sweeps of
perforation decks, a Recht-Ipson fit and its picture (sweep.png).

Keys: ``GROUP.KEY`` for a group the deck has once, ``GROUP(I).KEY`` (or
``GROUP[I].KEY``) for the I-th instance of a repeatable group, counted from
1 in file order as in the deck's error messages, or ``GROUP(NAME).KEY`` for
the instance whose ``name`` is NAME. Values: ``a:b:n`` n values from a to b
inclusive, evenly spaced; ``log:a:b:n`` the same, evenly spaced in log;
``v1,v2,...`` a list (one value: the key set for every variant).

Each variant runs in a separate process (``python -m fsph run``) with
OMP_NUM_THREADS set to the sweep's threads, so a crash of the solver costs
that variant only. The default cluster is a LocalCluster of
cores // threads thread-based workers, one run each, so that concurrent
runs x OpenMP threads <= cores. A variant whose folder holds a completed
summary.json and a variant.json with the hash of the same deck text is not
run again.

dask.distributed and pandas are imported when a sweep starts, not with fsph.
"""

import difflib
import itertools
import json
import math
import os
import re
import signal
import subprocess
import sys
import time as wallclock
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import f90nml
import numpy as np

from . import deck as deck_module
from . import references
from . import metrics as metrics_module
from .ballistics import fit_recht_ipson
from .errors import DeckError, FsphError, InputError
from .output import lock_owner

#: What a --set looks like, for error messages.
SET_SYNTAX = ("GROUP.KEY=VALUES, GROUP(I).KEY=VALUES or GROUP(NAME).KEY=VALUES with VALUES "
              "a:b:n (linear, inclusive), log:a:b:n (logarithmic) or v1,v2,... (a list)")
#: Deck keys holding paths relative to the deck's folder (rewritten absolute
#: in the variant decks, which live elsewhere).
PATH_KEYS = {"output": ("reference",), "body": ("mesh_file",)}
#: Scalars of summary.json copied into the table (besides energy.* and metrics.*).
SUMMARY_SCALARS = ("status", "cycles", "end_time_s", "n_elements", "n_nodes", "n_particles",
                   "n_converted", "n_debris_particles", "threads")
#: Status of a variant whose deck did not pass validation (it is not run).
INVALID = "invalid"
#: Status of a variant the sweep's interruption stopped or kept from running.
INTERRUPTED = "interrupted"
#: Most variants a sweep makes unless told otherwise (--max-variants): a
#: range or product beyond it is refused before anything is written.
MAX_VARIANTS = 10_000
#: How long to wait for a --scheduler to answer [s].
SCHEDULER_TIMEOUT_S = 10
#: How long an interrupted sweep waits for its runs to write their checkpoints [s].
STOP_WAIT_S = 120
#: In the sweep folder while an interrupted sweep stops: no variant starts.
STOP_MARK = "sweep.stopping"


@dataclass(frozen=True)
class Parameter:
    """One swept deck key: group, instance (0-based), key and its values."""

    column: str     # name in the table: group.key or group(i).key
    group: str
    index: int
    key: str
    values: tuple


@dataclass
class Variant:
    index: int
    name: str
    values: dict    # column -> value
    folder: Path
    deck_text: str
    status: str = None
    error: str = ""
    summary: dict = None
    wall_time_s: float = float("nan")
    reused: bool = False

    @property
    def deck_path(self):
        return self.folder / "deck.nml"

    @property
    def deck_hash(self):
        return deck_module.text_digest(self.deck_text)


# ---------------------------------------------------------------- values
def _number(text, kind):
    try:
        return int(text) if kind == "int" else float(text)
    except ValueError:
        raise ValueError(f"{'an integer' if kind == 'int' else 'a real number'} in place of "
                         f"{text!r}") from None


def _coerce(value, kind):
    """One value (text or a Python value) as the key's type."""
    if kind == "str":
        return str(value).strip().strip("'\"")
    if kind == "bool":
        if isinstance(value, (bool, np.bool_)):
            return bool(value)
        text = str(value).strip().lower().strip(".")
        if text in ("true", "t"):
            return True
        if text in ("false", "f"):
            return False
        raise ValueError(f".true. or .false. in place of {value!r}")
    if isinstance(value, str):
        return _number(value.strip(), kind)
    if kind == "int":
        if float(value) != round(float(value)):
            raise ValueError(f"integers, got {value!r}")
        return int(round(float(value)))
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"finite numbers, got {value!r}")
    return value


def expand_values(text, kind="float", max_count=MAX_VARIANTS):
    """Values of one --set: 'a:b:n' (n evenly spaced from a to b
    inclusive), 'log:a:b:n' (evenly spaced in log; a and b of one sign) or
    'v1,v2,...' (no empty item). kind is the deck key's type (float, int,
    str, bool); int ranges must land on integers (log ranges are rounded to
    them); a range has at most max_count values (checked before they are
    made). Raises ValueError saying what was expected."""
    if kind not in ("float", "int", "str", "bool"):
        raise ValueError(f"a key of one value (a {kind} key cannot be swept)")
    text = str(text).strip()
    is_log = text.lower().startswith("log:")
    if kind in ("float", "int") and (is_log or ":" in text):
        parts = text.split(":")[1:] if is_log else text.split(":")
        if len(parts) != 3:
            raise ValueError(f"{'log:a:b:n' if is_log else 'a:b:n'} with three fields")
        a, b = (_number(t.strip(), "float") for t in parts[:2])
        n = _number(parts[2].strip(), "int")
        if n < 2:
            raise ValueError("n >= 2 values in a range (a single value: just the value)")
        if n > max_count:
            raise ValueError(f"n <= {max_count} values in a range (the most variants of a "
                             f"sweep; --max-variants raises it)")
        if is_log:
            if a == 0.0 or b == 0.0 or (a < 0.0) != (b < 0.0):
                raise ValueError("log:a:b:n with a and b non-zero and of one sign")
            values = np.geomspace(a, b, n)
            if kind == "int":
                values = np.round(values)
        else:
            values = np.linspace(a, b, n)
        if kind == "int" and np.any(np.abs(values - np.round(values)) > 1e-9 * np.abs(values)):
            raise ValueError(f"integers: (b - a)/(n - 1) = {(b - a) / (n - 1):g} is not whole")
        values = [_coerce(v, kind) for v in values]
    else:
        items = text.split(",")
        if len(items) > 1 and not all(t.strip() for t in items):
            raise ValueError("a list v1,v2,... without empty items (a ',' too many)")
        values = [_coerce(t, kind) for t in items if t.strip()]
    if not values:
        raise ValueError("at least one value")
    if len(set(values)) != len(values):
        raise ValueError("distinct values")
    return tuple(values)


# ---------------------------------------------------------------- keys
def _raw_groups(path):
    """The base deck validated (a bad one is reported as by `fsph run`), as
    f90nml parsed it, and group name -> list of raw dicts."""
    base = deck_module.load(path)
    nml = f90nml.Parser().reads(Path(path).read_text())
    return base, nml, deck_module._groups(nml)


def _suggest(word, choices):
    close = difflib.get_close_matches(word, choices, n=1)
    return f" (did you mean '{close[0]}'?)" if close else ""


def parse_parameter(path, spec, values, items_by_group, max_count=MAX_VARIANTS):
    """A Parameter from the key part of a --set (spec) and its values (the
    text after '=', or a sequence of values; a range of at most max_count);
    DeckError names the deck, the group, the key and what was expected."""
    m = deck_module.KEY_SPEC.match(spec)
    if not m:
        raise DeckError(path, None, None, f"--set {SET_SYNTAX}", f"{spec}={values}")
    gname, selector, key = m.group(1).lower(), m.group(2), m.group(3).lower()
    if gname not in deck_module.SCHEMA:
        raise DeckError(path, gname, None, "one of the groups "
                        + ", ".join("&" + g for g in deck_module.SCHEMA)
                        + _suggest(gname, list(deck_module.SCHEMA)), "unknown group")
    keys = deck_module.SCHEMA[gname].keys
    if key not in keys:
        raise DeckError(path, gname, key, f"one of the keys of &{gname}: " + ", ".join(keys)
                        + _suggest(key, list(keys)), "unknown key")
    items = items_by_group.get(gname, [])
    index = deck_module.group_instance(path, gname, selector, key, items)
    kind = keys[key].kind
    try:
        if isinstance(values, str):
            expanded = expand_values(values, kind, max_count)
        else:
            expanded = tuple(_coerce(v, kind) for v in values)
            if not expanded or len(set(expanded)) != len(expanded):
                raise ValueError("at least one value, all distinct")
    except ValueError as err:
        label = deck_module._group_label(gname, deck_module.SCHEMA[gname], index)
        raise DeckError(path, label, key, f"values for --set: {err}", values) from None
    column = f"{gname}({index + 1}).{key}" if len(items) > 1 else f"{gname}.{key}"
    return Parameter(column, gname, index, key, expanded)


def _split_sets(path, sets):
    """(spec, values) pairs from a dict {spec: values} or 'spec=values' strings."""
    if isinstance(sets, dict):
        return list(sets.items())
    pairs = []
    for text in ([sets] if isinstance(sets, str) else sets):
        if "=" not in text:
            raise DeckError(path, None, None, f"--set {SET_SYNTAX}", text)
        spec, values = text.split("=", 1)
        pairs.append((spec, values))
    return pairs


# ---------------------------------------------------------------- variants
def _format(value):
    return f"{value:.6g}" if isinstance(value, float) else str(value)


def _folder_name(index, params, values):
    """v<index>_<key>=<value>_... over the keys that take several values."""
    label = "_".join(f"{p.key}={_format(values[p.column])}" for p in params if len(p.values) > 1)
    return f"v{index:03d}" + ("_" + re.sub(r"[^\w.=+-]", "-", label) if label else "")


def _variant_text(nml, base_dir, params, values, drop_reference=False):
    """Deck text of one variant: the base deck with the swept keys set and
    relative paths made absolute; without its &output reference if
    drop_reference (fsph.references: a reference without conditions does
    not say it applies to a changed deck)."""
    nml = f90nml.Parser().reads(str(nml))      # a deep copy
    for gname, keys in PATH_KEYS.items():
        if gname not in nml:
            continue
        groups = nml[gname] if isinstance(nml[gname], list) else [nml[gname]]
        for group in groups:
            for key in keys:
                if isinstance(group.get(key), str) and not Path(group[key]).is_absolute():
                    group[key] = str(base_dir / group[key].strip())
    for p in params:
        if p.group not in nml:
            nml[p.group] = {}
        group = nml[p.group][p.index] if isinstance(nml[p.group], list) else nml[p.group]
        group[p.key] = values[p.column]
    header = "".join(f"! sweep variant: {p.column} = {_format(values[p.column])}\n"
                     for p in params)
    if drop_reference and "reference" in nml.get("output", {}):
        del nml["output"]["reference"]
        header += ("! reference left out: it lists no conditions, so it does not say it applies "
                   "to a changed deck\n")
    return header + str(nml) + "\n"


def _base_value(items, p):
    """The base deck's raw value of a swept key (None where unset)."""
    group = items.get(p.group, [])
    return group[p.index].get(p.key) if p.index < len(group) else None


def _check_count(deck, params, max_variants):
    """DeckError if the Cartesian product of the parameters' values has
    more than max_variants variants."""
    count = math.prod(len(p.values) for p in params)
    if count > max_variants:
        sizes = " x ".join(f"{len(p.values)} ({p.column})" for p in params)
        raise DeckError(deck, None, None, f"at most {max_variants} variants in a sweep "
                        f"(--max-variants raises the limit)", f"{sizes} = {count} variants")


def _sweep_folder(output):
    """Create the sweep folder output (and its parents); InputError if a
    file stands in its place or on its path, or it cannot be created."""
    output = Path(output)
    for path in (output, *output.parents):
        if path.exists():
            if not path.is_dir():
                raise InputError(f"{path}: expected a folder for the sweep's outputs (-o "
                                 f"{output}), got a file of that name (give another -o)")
            break
    try:
        output.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise InputError(f"{output}: cannot create the sweep folder: "
                         f"{err.strerror or err}") from None


def _write_deck(v):
    """Create variant v's folder and write its deck (when its text
    changed); InputError naming the path if that fails."""
    try:
        v.folder.mkdir(exist_ok=True)
        if not v.deck_path.is_file() or v.deck_path.read_text() != v.deck_text:
            v.deck_path.write_text(v.deck_text)
    except OSError as err:
        raise InputError(f"{err.filename or v.folder}: cannot write the variant's deck: "
                         f"{err.strerror or err}") from None


def plan(deck, sets, output, max_variants=MAX_VARIANTS):
    """Parameters and variants of a sweep; writes each variant's deck (when
    its text changed) and validates it. Variants whose deck is invalid get
    status 'invalid' and the message; a bad --set, or more than
    max_variants variants, raises DeckError and an output folder that
    cannot be made InputError, before anything is written."""
    deck = Path(deck)
    base, nml, items = _raw_groups(deck)
    params = [parse_parameter(deck, spec, values, items, max_variants)
              for spec, values in _split_sets(deck, sets)]
    if not params:
        raise DeckError(deck, None, None, f"at least one --set {SET_SYNTAX}", "none")
    columns = [p.column for p in params]
    if len(set(columns)) != len(columns):
        raise DeckError(deck, None, None, "each key set once", ", ".join(columns))
    _check_count(deck, params, max_variants)
    reference = references.load(base)
    unconditional = reference is not None and "conditions" not in reference
    _sweep_folder(output)
    variants = []
    for i, combo in enumerate(itertools.product(*(p.values for p in params))):
        values = dict(zip(columns, combo))
        folder = Path(output) / _folder_name(i, params, values)
        changed = any(_base_value(items, p) != values[p.column] for p in params)
        v = Variant(i, folder.name, values, folder,
                    _variant_text(nml, deck.resolve().parent, params, values,
                                  drop_reference=unconditional and changed))
        _write_deck(v)
        try:
            deck_module.load(v.deck_path)
        except DeckError as err:
            v.status, v.error = INVALID, str(err)
        variants.append(v)
    return params, variants


def _reuse(v):
    """Mark v completed with the summary and wall time of an earlier run
    of this very deck (same hash) that completed; False if there is none."""
    try:
        record = json.loads((v.folder / "variant.json").read_text())
        summary = json.loads((v.folder / "summary.json").read_text())
    except (OSError, ValueError):
        return False
    if record.get("deck_sha256") != v.deck_hash or summary.get("status") != "completed":
        return False
    v.status, v.reused = "completed", True
    v.summary, v.wall_time_s = summary, record["wall_time_s"]
    return True


# ---------------------------------------------------------------- one run
def _last_line(text):
    lines = [line for line in text.strip().splitlines() if line.strip()]
    return lines[-1] if lines else ""


def run_variant(deck_path, folder, threads, deck_hash):
    """Run one variant deck in a child process (`python -m fsph run`) with
    OMP_NUM_THREADS = threads; the Dask task. Returns status, error
    message, wall time and the summary (None when the run left none), and
    writes them with the deck's hash to folder/variant.json."""
    folder = Path(folder)
    if (folder.parent / STOP_MARK).exists():
        return {"status": INTERRUPTED, "error": "the sweep was interrupted before this run",
                "returncode": None, "wall_time_s": 0.0, "deck_sha256": deck_hash,
                "threads": threads, "summary": None}
    for name in ("summary.json", "variant.json"):
        (folder / name).unlink(missing_ok=True)
    package_root = str(Path(__file__).resolve().parents[1])
    env = dict(os.environ, OMP_NUM_THREADS=str(threads),
               PYTHONPATH=os.pathsep.join(filter(None, [package_root,
                                                        os.environ.get("PYTHONPATH")])))
    t0 = wallclock.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "fsph", "run", str(deck_path), "-o",
                           str(folder), "--quiet"], env=env, cwd=folder, capture_output=True,
                          text=True)
    wall = wallclock.perf_counter() - t0
    (folder / "run.log").write_text(proc.stdout + proc.stderr)
    try:
        summary = json.loads((folder / "summary.json").read_text())
    except (OSError, ValueError):
        summary = None
    if summary is not None and summary["status"] == "running":
        summary = None      # the summary of the last snapshot of a run that was killed
    if summary is not None:
        status = summary["status"]
        error = summary.get("failure", {}).get("message", "") if status != "completed" else ""
        error = error or ("" if status == "completed" else status)
    elif proc.returncode < 0:
        status = "crashed"
        error = f"killed by signal {-proc.returncode}: {_last_line(proc.stderr)}".rstrip(": ")
    else:
        status = {2: INVALID, 4: INTERRUPTED}.get(proc.returncode, "error")
        error = _last_line(proc.stderr) or f"exit code {proc.returncode}"
    record = {"status": status, "error": error, "returncode": proc.returncode,
              "wall_time_s": wall, "deck_sha256": deck_hash, "threads": threads}
    (folder / "variant.json").write_text(json.dumps(record, indent=2) + "\n")
    return dict(record, summary=summary)


# ---------------------------------------------------------------- table
def summary_row(summary):
    """Flat {name: scalar} of a summary: status, counts, energy.*, and the
    case metrics as kind.key (histories left out); perforation runs add
    perforation.striking_velocity_m_s (the projectile's first velocity)."""
    row = {k: summary.get(k) for k in SUMMARY_SCALARS if k in summary}
    for key, value in summary.get("energy", {}).items():
        row[f"energy.{key}"] = value
    for group, values in summary.get("metrics", {}).items():
        if group == "series":
            continue
        for key, value in values.items():
            if value is None or isinstance(value, (bool, int, float, str)):
                row[f"{group}.{key}"] = value
    series = summary.get("metrics", {}).get("series", {})
    if series.get("velocity_z_m_s"):
        row["perforation.striking_velocity_m_s"] = abs(series["velocity_z_m_s"][0])
    return row


def warning_kinds(summary):
    """The kinds of a run's warnings (summary['warnings']: energy_error,
    output, deck), each once in order of first appearance, and how many
    warnings there are: ([], 0) without a summary or warnings."""
    kinds = [w.get("kind", "warning") for w in (summary or {}).get("warnings", [])]
    return list(dict.fromkeys(kinds)), len(kinds)


def _status_text(v):
    """Variant v's status, with its warnings' count and kinds if it has
    any: 'completed with 1 warning: energy_error'."""
    kinds, n = warning_kinds(v.summary)
    if not n:
        return v.status
    return f"{v.status} with {n} warning{'s' if n > 1 else ''}: {', '.join(kinds)}"


def table(variants):
    """pandas DataFrame, one row per variant: index, folder, the swept
    values, status, error, warnings (the kinds of the run's warnings,
    ';'-joined, '' when none), wall time [s] of its process, whether an
    earlier run was reused, and summary_row of its summary."""
    import pandas as pd
    rows = []
    for v in variants:
        row = {"variant": v.index, "folder": v.name, **v.values, "status": v.status,
               "error": v.error, "warnings": ";".join(warning_kinds(v.summary)[0]),
               "wall_time_s": v.wall_time_s, "reused": v.reused}
        if v.summary:
            row.update({k: x for k, x in summary_row(v.summary).items() if k != "status"})
        rows.append(row)
    return pd.DataFrame(rows)


def ballistic_fits(frame, params, free_p=False):
    """Recht-Ipson fits of a sweep of a projectile's velocity_z: one per
    combination of the other swept keys, over its completed perforation
    runs (a free, p = 2 or free). List of dicts: the fit plus 'group'
    (the other keys' values) and 'n' (runs)."""
    vel = [p for p in params if p.group == "body" and p.key == "velocity_z"]
    need = ("perforation.striking_velocity_m_s", "perforation.residual_velocity_m_s")
    if not vel or any(c not in frame.columns for c in need):
        return []
    others = [p.column for p in params if p not in vel and len(p.values) > 1]
    done = frame[frame["status"] == "completed"].dropna(subset=list(need))
    groups = done.groupby(others, sort=True) if others else [((), done)]
    fits = []
    for key, g in groups:
        if g[need[0]].nunique() < (4 if free_p else 3):
            continue            # no degree of freedom for the standard errors
        fit = fit_recht_ipson(g[need[0]].to_numpy(), g[need[1]].to_numpy(), a=None,
                              p=None if free_p else 2.0)
        key = key if isinstance(key, tuple) else (key,)
        fits.append(dict(fit, group=dict(zip(others, key)), n=len(g)))
    return fits


def experiment_points(deck_path):
    """(v_s, v_r) measurements from the deck's reference JSON: the pairs of
    its 'ballistic' entry (striking_velocity_m_s and residual_velocity_m_s,
    lists of equal length) and its 'perforation' residual_velocity_m_s at
    the deck's own striking velocity (the projectile's speed)."""
    deck = deck_module.load(deck_path)
    if deck["output"]["reference"] is None:
        return []
    ref = json.loads((Path(deck["dir"]) / deck["output"]["reference"]).read_text())
    curve = ref.get("ballistic", {})
    points = list(zip(map(float, curve.get("striking_velocity_m_s", [])),
                      map(float, curve.get("residual_velocity_m_s", []))))
    if "residual_velocity_m_s" in ref.get("perforation", {}):
        names = [b["name"] for b in deck["body"]]
        projectile = deck["body"][names.index(deck["metrics"]["body"] or names[0])]
        points.append((abs(projectile["velocity_z"]),
                       float(ref["perforation"]["residual_velocity_m_s"])))
    return sorted(points)


def _plus_minus(value, error, decimals):
    """'value ± error' with at least `decimals` decimals and enough for the
    error's first significant digit (at most 6)."""
    if error is None or not np.isfinite(error):
        return f"{value:.{decimals}f}"
    if error > 0.0:
        decimals = min(max(decimals, -int(np.floor(np.log10(error)))), 6)
    return f"{value:.{decimals}f} ± {error:.{decimals}f}"


def _fit_label(fit):
    text = ", ".join(f"{k} = {_format(v)}" for k, v in fit["group"].items())
    p = f"p = {_plus_minus(fit['p'], fit['p_err'], 2)}" if fit["p_err"] is not None else "p = 2"
    return (f"{text + ': ' if text else ''}v_bl = {_plus_minus(fit['v_bl'], fit['v_bl_err'], 0)} m/s, "
            f"a = {_plus_minus(fit['a'], fit['a_err'], 3)}, {p}")


def write_h5(path, frame, meta):
    """The table as /table/<column> datasets (numbers as float or int,
    the rest as strings; attribute 'columns' gives the order) and meta
    (JSON text) as the root attribute 'sweep'."""
    import h5py
    import pandas as pd
    with h5py.File(path, "w") as h5:
        group = h5.create_group("table")
        group.attrs["columns"] = list(frame.columns)
        for column in frame.columns:
            s = frame[column]
            if pd.api.types.is_bool_dtype(s) or pd.api.types.is_numeric_dtype(s):
                data = s.to_numpy()
            else:
                data = np.array(["" if pd.isna(x) else str(x) for x in s],
                                dtype=h5py.string_dtype())
            group.create_dataset(column, data=data)
        h5.attrs["sweep"] = json.dumps(meta)


def _warned(frame):
    """{folder: warning kinds} of the rows with warnings (none if the
    table has no 'warnings' column)."""
    kinds = frame.get("warnings", [""] * len(frame))
    return {f: w for f, w in zip(frame["folder"], kinds) if isinstance(w, str) and w}


def write_outputs(output, deck, params, frame, free_p=False):
    """sweep.csv, sweep.h5, sweep.json (the sweep, fits and failures) and,
    for a velocity sweep of perforation runs, sweep.png (the runs that
    failed, crashed or errored drawn at their swept speed on the axis, not
    left out; variants invalid or interrupted did not run to an end of
    their own and are not drawn); returns the fits."""
    output = Path(output)
    fits = ballistic_fits(frame, params, free_p)
    meta = {"deck": str(Path(deck).resolve()),
            "parameters": {p.column: list(p.values) for p in params},
            "counts": frame["status"].value_counts().to_dict(),
            "recht_ipson": fits,
            "failed": {r.folder: f"{r.status}: {r.error}"
                       for r in frame.itertuples() if r.status != "completed"},
            "warnings": _warned(frame)}
    frame.to_csv(output / "sweep.csv", index=False)
    write_h5(output / "sweep.h5", frame, meta)
    (output / "sweep.json").write_text(json.dumps(meta, indent=2) + "\n")
    done = frame[frame["status"] == "completed"]
    failed = frame[~frame["status"].isin(("completed", INVALID, INTERRUPTED))]
    if _is_velocity_sweep(params, frame) and (len(done) or len(failed)):
        from .plot import residual_velocity
        swept = next(p for p in params if p.group == "body" and p.key == "velocity_z")
        residual_velocity([("fsph", done["perforation.striking_velocity_m_s"].to_numpy(),
                            done["perforation.residual_velocity_m_s"].to_numpy())],
                          [(_fit_label(f), f) for f in fits], experiment_points(deck),
                          output / "sweep.png", title=Path(deck).stem,
                          failed=np.abs(failed[swept.column].to_numpy(dtype=float)))
    return fits


def unsettled(frame):
    """One line for each completed perforation run whose projectile was
    still changing speed at the end (perforation.settled false): its
    residual velocity, and any fit through it, is not final."""
    if "perforation.settled" not in frame.columns:
        return []
    rows = frame[(frame["status"] == "completed") & (frame["perforation.settled"] == False)]  # noqa: E712
    return [f"{r['folder']}: the projectile's velocity changed by "
            f"{r['perforation.velocity_change_end_m_s']:+.1f} m/s over the last "
            f"{100 * metrics_module.SETTLING_WINDOW:.0f} % of the run: its residual velocity is "
            f"not final (a longer control.end_time settles it); it is in the table and the fit"
            for _, r in rows.iterrows()]


def _is_velocity_sweep(params, frame):
    return (any(p.group == "body" and p.key == "velocity_z" for p in params)
            and "perforation.residual_velocity_m_s" in frame.columns)


# ---------------------------------------------------------------- cluster
def cores():
    """Cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


@contextmanager
def _client(scheduler, workers):
    """A dask.distributed Client: on the scheduler at that address, or on a
    LocalCluster of `workers` thread-based workers with one task slot each
    (closed afterwards). The local scheduler has no dashboard, and its HTTP
    server (which it starts all the same) listens on a free port of
    127.0.0.1 rather than 8787, so that sweeps running side by side do not
    warn of the port in use. The local cluster's logs below ERROR stay
    quiet after it has closed too: its INFO lines while it stops (a
    worker's "Batched Comm Closed" when the machine is loaded) would
    reach stderr once the cluster's own silencing has ended, so the
    level of the 'distributed' logger stays at ERROR."""
    from distributed import Client, LocalCluster
    if scheduler:
        try:
            client = Client(scheduler, timeout=SCHEDULER_TIMEOUT_S)
        except (OSError, ValueError, TypeError) as err:
            raise InputError(f"--scheduler {scheduler}: expected the address of a running "
                             f"Dask scheduler: {err}") from None
        with client:
            yield client
        return
    import logging
    logging.getLogger("distributed").setLevel(logging.ERROR)
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=False,
                      dashboard_address=None, silence_logs=logging.ERROR,
                      scheduler_kwargs={"dashboard": False,
                                        "dashboard_address": "127.0.0.1:0"}) as cluster, \
            Client(cluster) as client:
        yield client


def sweep(deck, sets, output=None, scheduler=None, workers=None, threads=1, free_p=False,
          rerun=False, quiet=False, stream=None, max_variants=MAX_VARIANTS):
    """Run the variants of `deck` given by `sets` and return their table
    (a pandas DataFrame; the Recht-Ipson fits in its attrs['recht_ipson']).

    sets: {'body(1).velocity_z': '-300:-1100:9', 'material.yield_stress':
    [1e9, 1.2e9]} or a list of 'KEY=VALUES' strings. output: the sweep's
    folder (default out/<deck>_sweep). scheduler: address of a running
    Dask scheduler; default a LocalCluster of `workers` workers (default
    cores // threads). threads: OpenMP threads of each run. free_p: fit the
    Recht-Ipson exponent too (else p = 2). rerun: run completed variants
    again. max_variants: the most variants the sets may make (a sweep of
    more is refused). Raises DeckError for a bad deck or --set, and
    InputError for an output folder that cannot be made, before anything
    runs."""
    stream = stream or sys.stdout

    def say(text):
        if not quiet:
            print(text, file=stream, flush=True)

    if threads < 1:
        raise FsphError(f"sweep: threads: expected an integer >= 1, got {threads!r}")
    if max_variants < 1:
        raise FsphError(f"sweep: max_variants: expected an integer >= 1, got {max_variants!r}")
    deck = Path(deck)
    # absolute: the runs start in their own folders, maybe on other hosts
    output = (Path(output) if output else Path("out") / f"{deck.stem}_sweep").resolve()
    params, variants = plan(deck, sets, output, max_variants)
    (output / STOP_MARK).unlink(missing_ok=True)      # an earlier sweep's, interrupted
    todo = [v for v in variants if v.status is None and (rerun or not _reuse(v))]
    workers = workers or max(1, cores() // threads)
    invalid = [v for v in variants if v.status == INVALID]
    say(f"fsph sweep: {deck.name}: {len(variants)} variant(s) in {output}/: {len(todo)} to run, "
        f"{sum(v.reused for v in variants)} already completed, {len(invalid)} invalid")
    for v in invalid:
        say(f"fsph sweep: {v.name}: invalid, not run: {v.error}")
    if not scheduler and workers * threads > cores():
        say(f"fsph sweep: warning: {workers} concurrent runs x {threads} thread(s) exceed "
            f"{cores()} cores")
    if todo:
        _run_all(todo, scheduler, workers, threads, say)
    frame = table(variants)
    frame.attrs["recht_ipson"] = write_outputs(output, deck, params, frame, free_p)
    for v in variants:
        for warning in (v.summary or {}).get("warnings", []):
            say(f"fsph sweep: warning: {v.name}: {warning.get('message', '')}")
    for line in unsettled(frame):
        say(f"fsph sweep: warning: {line}")
    for fit in frame.attrs["recht_ipson"]:
        say(f"fsph sweep: Recht-Ipson ({fit['n']} runs, rms {fit['rms_residual']:.1f} m/s): "
            f"{_fit_label(fit)}")
    say(f"fsph sweep: {_closing_counts(frame)}; table in {output / 'sweep.csv'}")
    return frame


def _closing_counts(frame):
    """'K of N completed', the variants that did not complete with their
    status, then those that completed with warnings, with their kinds."""
    bad = frame[frame["status"] != "completed"]
    warned = frame[(frame["status"] == "completed") & (frame["warnings"] != "")]
    text = f"{len(frame) - len(bad)} of {len(frame)} completed"
    if len(bad):
        text += ": not completed " + ", ".join(f"{r.folder} ({r.status})"
                                               for r in bad.itertuples())
    if len(warned):
        text += "; completed with warnings " + ", ".join(f"{r.folder} ({r.warnings})"
                                                         for r in warned.itertuples())
    return text


def _run_all(todo, scheduler, workers, threads, say):
    """Submit the variants as Dask tasks and record each result as it comes.
    SIGINT (Ctrl-C) stops the sweep: runs under way are asked to stop (they
    write their checkpoints), queued ones are cancelled; both are
    'interrupted', and the same command resumes the sweep."""
    from distributed import as_completed
    with _client(scheduler, workers) as client, _interruptible():
        where = (f"scheduler {scheduler}" if scheduler else
                 f"local cluster of {workers} worker(s)")
        say(f"fsph sweep: {where}, {threads} OpenMP thread(s) per run")
        futures = {client.submit(run_variant, str(v.deck_path), str(v.folder), threads,
                                 v.deck_hash, key=f"fsph-{v.name}-{v.deck_hash[:12]}",
                                 pure=False): v for v in todo}
        done = 0
        try:
            for future in as_completed(futures):
                done += 1
                _record(futures[future], future, f"[{done}/{len(todo)}]", say)
        except KeyboardInterrupt:
            say("fsph sweep: interrupted: stopping the runs under way (they keep their "
                "checkpoints); the same command resumes the sweep")
            _stop(futures, say)


@contextmanager
def _interruptible():
    """SIGINT raises KeyboardInterrupt here even if the sweep was started
    with it ignored (a background job of a non-interactive shell inherits
    SIG_IGN, and Python then installs no handler of its own), as `fsph run`
    takes SIGINT whatever it inherited; the handler before is restored."""
    try:
        previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    except ValueError:          # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _stop(futures, say):
    """Stop a sweep: the stop mark keeps queued variants from starting;
    runs under way get SIGINT until they have ended (STOP_WAIT_S at most)."""
    from distributed import wait
    pending = [f for f in futures if not f.done()]
    if not pending:
        return
    mark = futures[pending[0]].folder.parent / STOP_MARK
    mark.touch()
    deadline = wallclock.monotonic() + STOP_WAIT_S
    while pending and wallclock.monotonic() < deadline:
        _stop_runs([futures[f] for f in pending])
        wait(pending, timeout=1.0)
        for future in [f for f in pending if f.done()]:
            _record(futures[future], future, "[stopped]", say)
        pending = [f for f in pending if not f.done()]
    for future in pending:
        future.cancel()
        v = futures[future]
        v.status, v.error = INTERRUPTED, "the sweep was interrupted before this run ended"
    if not pending:
        mark.unlink(missing_ok=True)


def _record(v, future, count, say):
    """Book the result of variant v's finished future; say it."""
    try:
        record = future.result()
    except Exception as exc:      # the task itself failed (worker lost...)
        record = {"status": "error", "error": f"{type(exc).__name__}: {exc}",
                  "wall_time_s": float("nan"), "summary": None}
    v.status, v.error = record["status"], record["error"]
    v.summary, v.wall_time_s = record["summary"], record["wall_time_s"]
    say(f"fsph sweep: {count} {v.name}: {_status_text(v)} "
        f"({v.wall_time_s:.1f} s)" + (f": {v.error}" if v.error else ""))


def _stop_runs(variants):
    """SIGINT to the runs of these variants under way on this host (their
    pids are in their folders' lock files); they stop with a checkpoint."""
    import socket
    for v in variants:
        owner = lock_owner(v.folder)
        if owner and owner[1] == socket.gethostname():
            try:
                os.kill(owner[0], signal.SIGINT)
            except OSError:
                pass        # ended meanwhile
