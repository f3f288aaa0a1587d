"""Checkpoint and restart: the whole state the next cycle reads, written to
HDF5 by name (fsph.layouts: /state/nodes/x, /state/elements/rho, ...,
/scalars/time, ...) and read back so that a restarted run continues bit
for bit (same thread count). Files are written to a temporary name and
renamed: a crash mid-write never leaves a torn checkpoint."""

import hashlib
import json
import os
from pathlib import Path

import h5py
import numpy as np

from . import deck as deck_module
from . import layouts
from .errors import DeckError, FsphError
from .hdf5_writes import write_attribute, write_dataset
from .output import writing_errors
from .simulation import STATUS_OK, _api

#: 3: datasets and scalars named (fsph.layouts), not numbered; 4: the deck
#: and the starting mesh's counts recorded (a restart from another deck is
#: refused), and the run's books (the largest energy error so far); 5: the
#: particles' ids (particles are renumbered in spatial order)
FORMAT = 5

#: What a restart may change in the deck: these keys of &control, and the
#: whole of &output, &metrics and the &gauge groups (gauges only read the
#: state; a restart locates them again). Everything else must be as in the
#: checkpoint's deck.
RESTART_MAY_CHANGE = {"control": ("title", "end_time", "max_cycles", "energy_error_warning",
                                  "energy_error_limit"),
                      "output": None, "metrics": None, "gauge": None}
_REAL, _INT = 1, 2    # the solver's kinds of state array


def _state_id(name):
    """(kind, 1-based id) of the state array `name` (fsph.layouts)."""
    if name in layouts.CHECKPOINT_REAL:
        return _REAL, layouts.CHECKPOINT_REAL.index(name) + 1
    if name in layouts.CHECKPOINT_INT:
        return _INT, layouts.CHECKPOINT_INT.index(name) + 1
    raise FsphError(f"unknown state array '{name}' (fsph.layouts CHECKPOINT_REAL, CHECKPOINT_INT)")


def state_array(sim, name):
    """A copy of the state array `name` of `sim` ('nodes/v', 'elements/e',
    ...: fsph.layouts CHECKPOINT_REAL and CHECKPOINT_INT) as the solver
    holds it, (rows, cols) with one column per node, element or particle;
    None where the run has no such array. Indices are the solver's
    (1-based, 0 none)."""
    kind, k = _state_id(name)
    if name == "nodes/on_axis":
        _api.begin_checkpoint(sim._run)     # the axis flags as integers
    rows, cols = _api.checkpoint_sizes(sim._run, kind, k)[:2]
    if rows * cols == 0:
        return None
    getter = _api.get_real_state if kind == _REAL else _api.get_int_state
    return getter(sim._run, k, rows, cols)


def _write_state_array(sim, name, values):
    """Overwrite the state array `name`; False if the shape does not fit."""
    kind, k = _state_id(name)
    setter = _api.set_real_state if kind == _REAL else _api.set_int_state
    dtype = np.float64 if kind == _REAL else np.int32
    return setter(sim._run, k, np.asfortranarray(values, dtype=dtype)) == STATUS_OK


def set_state_array(sim, name, values):
    """Overwrite the state array `name` of `sim` with `values` of its
    shape (rows, cols) (see state_array); the neighbour lists are rebuilt
    at the next cycle."""
    if not _write_state_array(sim, name, values):
        raise FsphError(f"state array '{name}': expected the shape {np.shape(state_array(sim, name))}, "
                        f"got {np.shape(values)}")


def _state_arrays(sim):
    """Every non-empty state array of `sim`, in checkpoint order (the order
    of fsph.layouts), as (its name, the array)."""
    for name in layouts.CHECKPOINT_REAL + layouts.CHECKPOINT_INT:
        values = state_array(sim, name)
        if values is not None:
            yield name, values


def _scalars(sim):
    """The clock and books as (real, int) arrays in the order of fsph.layouts."""
    return sim.scalar_state()


def _restart_identity(deck):
    """The deck's groups a restart must keep (all but RESTART_MAY_CHANGE),
    as plain JSON values."""
    out = {}
    for gname, value in deck_module.groups_of(deck).items():
        if gname in RESTART_MAY_CHANGE and RESTART_MAY_CHANGE[gname] is None:
            continue
        free = RESTART_MAY_CHANGE.get(gname, ())
        items = value if isinstance(value, list) else [value]
        out[gname] = [{k: v for k, v in item.items() if k not in free} for item in items]
    return json.loads(json.dumps(out, default=repr))


def _check_same_deck(sim, h5, path):
    """The deck of `sim` is the checkpoint's but for what a restart may
    change; the starting mesh has the checkpoint's counts."""
    ours, theirs = _restart_identity(sim.deck), json.loads(h5.attrs["deck"])
    where = sim.deck.get("path", "<deck>")
    may = ("&control " + ", ".join(RESTART_MAY_CHANGE["control"]) + ", &output, &metrics and "
           "&gauge")
    for gname in sorted(set(ours) | set(theirs)):
        a, b = theirs.get(gname, []), ours.get(gname, [])
        if len(a) != len(b):
            raise DeckError(where, gname, None, f"{len(a)} &{gname} group(s) as in the deck of "
                            f"the checkpoint {path} (a restart may change only {may})", len(b))
        for k, (old, new) in enumerate(zip(a, b)):
            label = f"{gname} #{k + 1}" if isinstance(sim.deck[gname], list) else gname
            for key in sorted(set(old) | set(new)):
                if old.get(key) != new.get(key):
                    raise DeckError(where, label, key, f"{old.get(key)!r} as in the deck of the "
                                    f"checkpoint {path} (a restart may change only {may})",
                                    new.get(key))
    counts = [sim.n_nodes0, sim.n_elements0, sim.n_particles0]
    if list(h5.attrs["counts0"]) != counts:
        raise DeckError(where, None, None, f"a starting mesh of {list(h5.attrs['counts0'])} "
                        f"nodes, elements and particles as the checkpoint {path}'s", counts)


def save(sim, path, books=None):
    """Write the state of `sim` to `path` (HDF5), with the deck it was set
    up from and `books` (a JSON-able dict the caller gets back from
    restore: the driver's largest energy error so far)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    r, i = _scalars(sim)
    sizes = _api.checkpoint_sizes(sim._run, _REAL, 1)[2:]
    # a failed write (full disk) leaves the previous checkpoint as it was
    try:
        with writing_errors(path), h5py.File(tmp, "w") as h5:
            write_attribute(h5, "format", FORMAT)
            write_attribute(h5, "deck", json.dumps(_restart_identity(sim.deck)))
            write_attribute(h5, "counts0", np.array([sim.n_nodes0, sim.n_elements0, sim.n_particles0]))
            write_attribute(h5, "books", json.dumps(books or {}))
            write_attribute(h5, "initial_energy", sim.initial_energy)
            write_dataset(h5, "particle_radius0", sim.particle_radius0)
            scalars = h5.create_group("scalars")
            for names, values in ((layouts.CHECKPOINT_REAL_SCALARS, r),
                                  (layouts.CHECKPOINT_INT_SCALARS, i)):
                for name, value in zip(names, values):
                    write_attribute(scalars, name, value)
            write_attribute(h5, "sizes", np.array(sizes))     # nodes, elements, particles, capacity, edges
            state = h5.create_group("state")
            for name, values in _state_arrays(sim):
                write_dataset(state, name, values)
        with writing_errors(path):
            os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


def _read_scalars(h5, path):
    """(real, int) scalar arrays of a checkpoint, in the order of fsph.layouts."""
    attrs = h5["scalars"].attrs
    missing = [n for n in layouts.CHECKPOINT_REAL_SCALARS + layouts.CHECKPOINT_INT_SCALARS
               if n not in attrs]
    if missing:
        raise DeckError(path, None, None, "a checkpoint with every scalar of fsph.layouts",
                        "none for " + ", ".join(missing))
    return (np.array([attrs[n] for n in layouts.CHECKPOINT_REAL_SCALARS], dtype=np.float64),
            np.array([attrs[n] for n in layouts.CHECKPOINT_INT_SCALARS], dtype=np.int32))


def _restore_arrays(sim, h5, path):
    """Copy every named state array of the checkpoint into `sim`."""
    known = set(layouts.CHECKPOINT_REAL + layouts.CHECKPOINT_INT)
    names = []
    h5["state"].visititems(lambda name, obj: names.append(name) if isinstance(obj, h5py.Dataset) else None)
    for name in names:
        if name not in known:
            raise DeckError(path, None, None, "state arrays of fsph.layouts (written by another "
                            "fsph version?)", name)
        data = h5["state"][name][...]
        if not _write_state_array(sim, name, data):
            got = f"shape {data.shape}"
            rows = len(layouts.MATERIAL_HISTORY)
            if name.endswith("/hist") and data.ndim == 2 and data.shape[0] != rows:
                got += (f": {data.shape[0]} material history rows where this version has {rows} "
                        "(written by another fsph version)")
            raise DeckError(path, None, None, f"a state array '{name}' that fits this deck", got)


def restore(sim, path):
    """Replace the state of `sim` by the checkpoint at `path`, written from
    the same deck (but for RESTART_MAY_CHANGE; a DeckError names what
    differs). The gauges are not in a checkpoint: they are located again
    from the deck (Simulation.locate_gauges), so a material gauge whose
    element had converted follows the particle that started nearest its
    point, and its switch time is not carried over. Returns the books
    given to save."""
    path = Path(path)
    try:
        h5 = h5py.File(path, "r")
    except OSError as exc:
        raise DeckError(path, None, None, "an fsph checkpoint (HDF5)", str(exc)) from None
    with h5:
        if h5.attrs.get("format") != FORMAT:
            raise DeckError(path, None, None, f"an fsph checkpoint of format {FORMAT}",
                            h5.attrs.get("format"))
        _check_same_deck(sim, h5, path)
        nn, ne, np_, cap, n_edges = (int(v) for v in h5.attrs["sizes"])
        r, i = _read_scalars(h5, path)
        if _api.restore_begin(sim._run, nn, ne, np_, cap, n_edges, r, i) != STATUS_OK:
            raise DeckError(path, None, None, "checkpoint scalars that fit this build", "others")
        _restore_arrays(sim, h5, path)
        _api.restore_end(sim._run)
        # not in the checkpoint: located again, in the initial configuration
        sim.locate_gauges()
        sim.initial_energy = float(h5.attrs["initial_energy"])
        sim.particle_radius0 = h5["particle_radius0"][...]
        return json.loads(h5.attrs["books"])


def state_digest(sim):
    """SHA-256 (hex) of the whole state a checkpoint holds: the clock and
    books, then every state array in checkpoint order. Two runs with the
    same digest continue identically; the reference runs' digests guard
    refactoring (tests/test_runs.py). The particles' ids enter only where
    they differ from the particles' numbers (the particles were renumbered
    in spatial order): a run that never renumbers hashes as it did before
    the ids were kept, so the digests stored on hosts of other kinds stay
    valid."""
    digest = hashlib.sha256()
    for scalars in _scalars(sim):
        digest.update(np.ascontiguousarray(scalars).tobytes())
    for name, values in _state_arrays(sim):
        if name == "particles/id" and np.array_equal(values.ravel(), np.arange(1, values.size + 1)):
            continue
        digest.update(np.ascontiguousarray(values).tobytes())
    return digest.hexdigest()
