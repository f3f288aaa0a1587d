"""Checkpoint and restart: the whole state the next cycle reads, written to
HDF5 by name (fsph.layouts: /state/nodes/x, /state/elements/rho, ...,
/scalars/time, ...) and read back so that a restarted run continues bit
for bit (same thread count). Files are written to a temporary name and
renamed: a crash mid-write never leaves a torn checkpoint."""

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from . import deck as deck_module
from . import layouts
from .errors import CheckpointError, DeckError, FsphError
from .hdf5_writes import write_attribute, write_dataset
from .output import writing_errors
from .simulation import STATUS_OK, _api

#: 3: datasets and scalars named (fsph.layouts), not numbered; 4: the deck
#: and the starting mesh's counts recorded (a restart from another deck is
#: refused), and the run's books (the largest energy error so far); 5: the
#: particles' ids (particles are renumbered in spatial order); 6: the
#: neighbour lists' books (/lists: a restart builds its lists when the run
#: did, and counts the builds of the whole run) and the driver's books as a
#: dataset (/books: also the peak forces, the last history row and the
#: snapshot series, which outgrow an attribute); 7: the momenta and the
#: contact's overlap of the metric series under keys naming their units
#: (momentum_z_N_s, contact_overlap_max_mm), and the gauges' states in
#: the books (a material gauge's particle and switch time); 8: the run's
#: wall time, phase times and cycles by thread count in the books, so that
#: a restarted run's summary gives the whole run's; 9: the internal energy
#: summed at the start of a recent cycle and that cycle (the scalars
#: energy_full_before and energy_full_cycle), for the time-centred energy
#: total
FORMAT = 9

#: What each format before FORMAT lacks: a restart from it is refused
#: rather than continued with a summary of the continuation alone.
_LACKS = {5: "the books a restarted run reports for the whole run (the neighbour lists' builds, "
             "the peak forces, the snapshot series and the debris metrics measured on it)",
          6: "the metric series keys of this fsph (momentum_z_N_s, contact_overlap_max_mm), "
             "which the run's series would mix with its own",
          7: "the wall time, phase times and cycles by thread count of the run before it, "
             "which the restarted run's summary adds to its own",
          8: "the internal energy summed at the start of a recent cycle, which the time-centred "
             "energy total pairs with the half-step kinetic energy"}

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
    ours, theirs = _restart_identity(sim.deck), _json_attribute(h5, path, "deck")
    where = sim.deck.get("path", "<deck>")
    may = ("&control " + ", ".join(RESTART_MAY_CHANGE["control"]) + ", &output, &metrics and "
           "&gauge")
    for gname in sorted(set(ours) | set(theirs)):
        a, b = theirs.get(gname, []), ours.get(gname, [])
        if not (isinstance(a, list) and all(isinstance(item, dict) for item in a)):
            raise CheckpointError(path, "attribute 'deck'", f"the deck's &{gname} groups as a "
                                  "list of objects", a)
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
    theirs = [int(v) for v in _attribute(h5, path, "counts0", "int", (3,))]
    if theirs != counts:
        raise DeckError(where, None, None, f"a starting mesh of {theirs} nodes, elements and "
                        f"particles as the checkpoint {path}'s", counts)


def _lists_books(sim):
    """The neighbour lists' books (fsph_verlet): (skin [m], its scale [-]),
    (builds so far, cycles the lists have served), and for lists that may
    be reused the real particles' (2, n) and nodes' (2, nodes) positions
    [m] and the elements' h (elements,) [m] at their build and the coupled
    bodies' nodes (1-based); those arrays have no columns for lists the
    next cycle rebuilds anyway."""
    sizes = [int(v) for v in _api.get_list_sizes(sim._run)]
    return _api.get_list_books(sim._run, *sizes)


def save(sim, path, books=None):
    """Write the state of `sim` to `path` (HDF5), with the deck it was set
    up from, the neighbour lists' books and `books` (a JSON-able dict the
    caller gets back from restore: the driver's books of the run so far)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    r, i = _scalars(sim)
    sizes = _api.checkpoint_sizes(sim._run, _REAL, 1)[2:]
    list_reals, list_ints, *list_arrays = _lists_books(sim)
    # a failed write (full disk) leaves the previous checkpoint as it was
    try:
        with writing_errors(path), h5py.File(tmp, "w") as h5:
            write_attribute(h5, "format", FORMAT)
            write_attribute(h5, "deck", json.dumps(_restart_identity(sim.deck)))
            write_attribute(h5, "counts0", np.array([sim.n_nodes0, sim.n_elements0, sim.n_particles0]))
            h5["books"] = json.dumps(books or {})       # a string dataset: no size limit
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
            lists = h5.create_group("lists")
            for name, value in zip(_LIST_SCALARS, (*list_reals, *list_ints, list_arrays[0].shape[1])):
                write_attribute(lists, name, value)
            for name, values in zip(_LIST_ARRAYS, list_arrays):
                write_dataset(lists, name, values)
        with writing_errors(path):
            os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


#: The attributes and datasets of /lists (see _lists_books), in the
#: solver's order; 'listed': the real particles the lists were built for
#: (0: the next cycle rebuilds them anyway).
_LIST_SCALARS = ("skin", "skin_scale", "builds", "uses", "listed")
_LIST_ARRAYS = ("particles_x", "nodes_x", "elements_h", "coupled_nodes")


# ---- reading a checkpoint: every item checked before any reaches the solver

def _where(obj, name):
    """'attribute NAME' of the file's root, or 'attribute NAME of /GROUP'."""
    return f"attribute '{name}'" + ("" if obj.name == "/" else f" of {obj.name}")


def _attribute(obj, path, name, kind, shape=()):
    """The attribute `name` of the open group `obj` of the checkpoint at
    `path`: kind 'text' (a string), 'real' (finite numbers) or 'int'
    (integers), of `shape`; CheckpointError otherwise."""
    expected = {"text": "a string", "real": "finite real numbers",
                "int": "integers"}[kind] + ("" if kind == "text" else f" of shape {shape}")
    if name not in obj.attrs:
        raise CheckpointError(path, _where(obj, name), expected, "no such attribute")
    value = obj.attrs[name]
    if kind == "text":
        if isinstance(value, bytes):
            value = value.decode("utf-8", "replace")
        if not isinstance(value, str):
            raise CheckpointError(path, _where(obj, name), expected, value)
        return value
    data = np.asarray(value)
    kinds = "fiu" if kind == "real" else "iu"
    if data.shape != shape or data.dtype.kind not in kinds:
        raise CheckpointError(path, _where(obj, name), expected, f"{data.dtype} of shape {data.shape}")
    if kind == "real" and not np.isfinite(data).all():
        raise CheckpointError(path, _where(obj, name), expected, data.tolist())
    return data


def _json_attribute(h5, path, name):
    """The JSON object held by the string attribute `name` of the file."""
    text = _attribute(h5, path, name, "text")
    try:
        value = json.loads(text)
    except ValueError:
        value = None
    if not isinstance(value, dict):
        raise CheckpointError(path, _where(h5, name), "a JSON object", text[:80])
    return value


def _shape_text(shape):
    """A shape as numpy prints it, 'any' for a length left free (None)."""
    return str(tuple("any" if n is None else n for n in shape)).replace("'", "")


def _array(h5, path, name, shape, kind, bounds=None):
    """The dataset `name` of the checkpoint as an array: present, of
    `shape` (None: any length), of kind 'real' (finite) or 'int' (within
    bounds (lo, hi), inclusive, hi None for none); CheckpointError
    otherwise."""
    item = f"dataset /{name}"
    expected = f"{'a real' if kind == 'real' else 'an integer'} array of shape {_shape_text(shape)}"
    if bounds is not None:
        expected += f" of values from {bounds[0]} to {'any' if bounds[1] is None else bounds[1]}"
    obj = h5.get(name)
    if not isinstance(obj, h5py.Dataset):
        raise CheckpointError(path, item, expected, "no such dataset" if obj is None else "a group")
    if len(obj.shape) != len(shape) or any(n is not None and n != m for n, m in zip(shape, obj.shape)):
        raise CheckpointError(path, item, expected, f"shape {obj.shape}")
    if obj.dtype.kind not in ("fiu" if kind == "real" else "iu"):
        raise CheckpointError(path, item, expected, f"{obj.dtype} values")
    data = obj[()]
    if kind == "real" and not np.isfinite(data).all():
        bad = np.argwhere(~np.isfinite(data))[0]
        raise CheckpointError(path, item, expected, f"{data[tuple(bad)]} at {tuple(int(k) for k in bad)}")
    if bounds is not None and data.size:
        lo, hi = bounds
        if data.min() < lo or (hi is not None and data.max() > hi):
            raise CheckpointError(path, item, expected, f"values from {data.min()} to {data.max()}")
    return data


def _group(h5, path, name):
    """The group `name` of the checkpoint; CheckpointError if it has none."""
    obj = h5.get(name)
    if not isinstance(obj, h5py.Group):
        raise CheckpointError(path, f"group /{name}", "a group of an fsph checkpoint",
                              "no such group" if obj is None else "a dataset")
    return obj


def _check_format(h5, path):
    """The checkpoint's format is this version's; one written before says
    what it lacks."""
    found = h5.attrs.get("format")
    if isinstance(found, (int, np.integer)):
        found = int(found)
        if found == FORMAT:
            return
    expected = f"an fsph checkpoint of format {FORMAT}"
    if isinstance(found, int) and found in _LACKS:
        expected += (f" (format {found} was written by an earlier fsph and lacks "
                     f"{_LACKS[found]}: restart with the fsph that wrote it, or run the "
                     f"deck again)")
    raise CheckpointError(path, None, expected, found)


def _read_sizes(sim, h5, path, rows):
    """(nodes, elements, particles, particle capacity, coupling edges) of
    the checkpoint: sets this deck's run does not have (rows: the state
    arrays' rows, 0 where the run has none) must be empty, and the
    capacity no larger than conversions and mirror images can make it."""
    sizes = [int(v) for v in _attribute(h5, path, "sizes", "int", (5,))]
    nn, ne, np_, cap, n_edges = sizes
    limit = 4 * (sim.n_elements0 + sim.n_particles0 + np_) + 64
    has = {prefix: any(rows[name] for name in rows if name.startswith(prefix))
           for prefix in ("nodes", "particles", "coupling")}
    fits = (min(sizes) >= 0 and np_ <= cap <= limit and (has["nodes"] or nn == ne == 0)
            and (has["particles"] or cap == 0) and (has["coupling"] or n_edges == 0))
    if not fits:
        raise CheckpointError(path, _where(h5, "sizes"), f"nodes, elements, particles, particle "
                              f"capacity (from the particles to {limit}) and coupling edges "
                              f"that this deck's run can have", sizes)
    return sizes


#: Checks of the scalars beyond being finite: (test of the value and the
#: sizes, what it must be).
_SCALAR_RULES = {
    "time": (lambda v, s: v >= 0.0, ">= 0"),
    "dt": (lambda v, s: v > 0.0, "> 0"),
    "dt_initial": (lambda v, s: v > 0.0, "> 0"),
    "cycle": (lambda v, s: v >= 0, ">= 0"),
    "dt_element": (lambda v, s: 0 <= v <= s[1], "an element or 0"),
    "dt_particle": (lambda v, s: 0 <= v <= s[2], "a particle or 0"),
    "n_converted": (lambda v, s: v >= 0, ">= 0"),
    "n_events": (lambda v, s: v >= 0, ">= 0"),
    "n_groups": (lambda v, s: v >= 0, ">= 0"),
    "n_edges": (lambda v, s: v == s[4], "the coupling edges of the attribute 'sizes'"),
    "n_eroded": (lambda v, s: v >= 0, ">= 0"),
}


def _read_scalars(h5, path, sizes):
    """(real, int) scalar arrays of a checkpoint, in the order of fsph.layouts."""
    group = _group(h5, path, "scalars")
    values = {}
    for names, kind in ((layouts.CHECKPOINT_REAL_SCALARS, "real"),
                        (layouts.CHECKPOINT_INT_SCALARS, "int")):
        for name in names:
            value = _attribute(group, path, name, kind).item()
            test, text = _SCALAR_RULES.get(name, (None, ""))
            if test is not None and not test(value, sizes):
                raise CheckpointError(path, _where(group, name), f"{kind} {text}", value)
            values[name] = value
    return (np.array([values[n] for n in layouts.CHECKPOINT_REAL_SCALARS], dtype=np.float64),
            np.array([values[n] for n in layouts.CHECKPOINT_INT_SCALARS], dtype=np.int32))


def _state_rows(sim):
    """{name: rows} of every state array as this run holds it (0: it has
    none); a run's arrays have the same rows at any size."""
    _api.begin_checkpoint(sim._run)
    return {name: int(_api.checkpoint_sizes(sim._run, *_state_id(name))[0])
            for name in layouts.CHECKPOINT_REAL + layouts.CHECKPOINT_INT}


def _index_bounds(sim, sizes, n_groups):
    """(lowest, highest) of the state arrays that index others (1-based;
    0: none)."""
    nn, ne, np_, cap, n_edges = sizes
    n_bodies, n_materials = len(sim.body_names), len(sim.material_names)
    return {"elements/conn": (1, nn), "coupling/edge": (1, nn), "particles/tie_a": (0, nn),
            "particles/tie_b": (0, nn), "elements/mat": (1, n_materials),
            "particles/mat": (1, n_materials), "elements/body": (1, n_bodies),
            "particles/body": (1, n_bodies), "particles/continuum": (1, n_bodies),
            "elements/group": (0, n_groups), "particles/assoc": (0, n_edges),
            "nodes/on_axis": (0, 1), "elements/id": (1, None), "particles/id": (1, None)}


def _read_state(sim, h5, path, rows, sizes, n_groups):
    """{name: array} of the checkpoint's state arrays: each array this
    run has at these sizes, of its shape, finite or within the range of
    what it indexes; none other."""
    state = _group(h5, path, "state")
    present = []
    state.visititems(lambda name, obj: present.append(name) if isinstance(obj, h5py.Dataset) else None)
    known = set(rows)
    for name in present:
        if name not in known:
            raise CheckpointError(path, f"dataset /state/{name}", "state arrays of fsph.layouts "
                                  "(written by another fsph version?)", name)
    nn, ne, np_, cap, n_edges = sizes
    cols = {"nodes": nn, "elements": ne, "particles": np_, "coupling": n_edges}
    bounds = _index_bounds(sim, sizes, n_groups)
    arrays = {}
    for name in layouts.CHECKPOINT_REAL + layouts.CHECKPOINT_INT:
        shape = (rows[name], cols[name.split("/")[0]])
        if shape[0] * shape[1] == 0:
            if name in present:
                raise CheckpointError(path, f"dataset /state/{name}", "no such array in a "
                                      "checkpoint of this deck's run at its sizes",
                                      f"shape {state[name].shape}")
            continue
        _check_history_rows(state, path, name, shape)
        kind = "real" if _state_id(name)[0] == _REAL else "int"
        arrays[name] = _array(h5, path, f"state/{name}", shape, kind, bounds.get(name))
    if "particles/continuum" in arrays:
        continuum = np.asarray(sim.continuum_of_body)[arrays["particles/body"][0] - 1] + 1
        if not np.array_equal(arrays["particles/continuum"][0], continuum):
            raise CheckpointError(path, "dataset /state/particles/continuum", "the continuum of "
                                  "each particle's body (particles/body)", "others")
    return arrays


def _check_history_rows(state, path, name, shape):
    """A material history of another number of rows was written by another
    fsph version: the message says so."""
    obj = state.get(name)
    if not (name.endswith("/hist") and isinstance(obj, h5py.Dataset) and len(obj.shape) == 2
            and obj.shape[0] != shape[0]):
        return
    raise CheckpointError(path, f"dataset /state/{name}", f"a state array '{name}' that fits this "
                          f"deck", f"shape {obj.shape}: {obj.shape[0]} material history rows where "
                          f"this version has {shape[0]} (written by another fsph version)")


def _read_lists(h5, path, sizes):
    """The neighbour lists' books (_lists_books) of the checkpoint."""
    nn, ne, np_, cap, n_edges = sizes
    group = _group(h5, path, "lists")
    skin, scale = (_attribute(group, path, name, "real").item() for name in _LIST_SCALARS[:2])
    builds, uses, n = (_attribute(group, path, name, "int").item() for name in _LIST_SCALARS[2:])
    scale_max = float(_api.get_skin_scale_max())
    if not (skin >= 0.0 and 1.0 <= scale <= scale_max and builds >= 0 and uses >= 0 and n in (0, np_)):
        raise CheckpointError(path, "group /lists", f"a skin >= 0, its scale in [1, {scale_max:g}], counts "
                              f">= 0 and 0 or {np_} particles listed",
                              dict(zip(_LIST_SCALARS, [skin, scale, builds, uses, n])))
    shapes = ((2, n), (2, nn if n else 0), (ne if n else 0,), (None,))
    kinds = ("real", "real", "real", "int")
    arrays = [_array(h5, path, f"lists/{name}", shape, kind, (1, nn) if kind == "int" else None)
              for name, shape, kind in zip(_LIST_ARRAYS, shapes, kinds)]
    if n == 0 and arrays[3].size:
        raise CheckpointError(path, "dataset /lists/coupled_nodes", "no coupled nodes for lists "
                              "that are rebuilt", arrays[3].size)
    return np.array([skin, scale]), np.array([builds, uses], dtype=np.int32), arrays


@dataclass
class _Checkpoint:
    """What a restore reads from a checkpoint, checked: sizes, scalars,
    state arrays, the neighbour lists' books, the energy and radii at
    set-up and the caller's books."""

    sizes: list
    scalars: tuple
    arrays: dict
    lists: tuple
    initial_energy: float
    particle_radius0: np.ndarray
    books: dict


def _read(sim, h5, path):
    """Every item of the checkpoint a restore reads, checked (_Checkpoint)."""
    rows = _state_rows(sim)
    sizes = _read_sizes(sim, h5, path, rows)
    scalars = _read_scalars(h5, path, sizes)
    n_groups = int(scalars[1][layouts.CHECKPOINT_INT_SCALARS.index("n_groups")])
    arrays = _read_state(sim, h5, path, rows, sizes, n_groups)
    books = h5.get("books")
    if not isinstance(books, h5py.Dataset) or books.dtype.kind != "O" or books.shape != ():
        raise CheckpointError(path, "dataset /books", "a string (the run's books as JSON)",
                              "no such dataset" if books is None else f"{books}")
    try:
        books = json.loads(books.asstr()[()])
    except (ValueError, TypeError):
        books = None
    if not isinstance(books, dict):
        raise CheckpointError(path, "dataset /books", "a JSON object (the run's books)", "other text")
    return _Checkpoint(sizes, scalars, arrays, _read_lists(h5, path, sizes),
                       float(_attribute(h5, path, "initial_energy", "real")),
                       _array(h5, path, "particle_radius0", sim.particle_radius0.shape, "real"),
                       books)


def _load(sim, content, path):
    """Put a checked checkpoint into the solver; the arrays fit (_read)."""
    if _api.restore_begin(sim._run, *content.sizes, *content.scalars) != STATUS_OK:
        raise FsphError(f"{path}: the solver refused the checkpoint's scalars (layout mismatch, "
                        "rebuild the package)")
    for name, values in content.arrays.items():
        if not _write_state_array(sim, name, values):
            raise FsphError(f"{path}: the solver refused the state array '{name}' of shape "
                            f"{values.shape}")
    _api.restore_end(sim._run)
    reals, ints, arrays = content.lists
    if _api.set_list_books(sim._run, reals, ints, *(np.asfortranarray(a) for a in arrays)) != STATUS_OK:
        raise CheckpointError(path, "group /lists", "neighbour lists' books that fit the state",
                              "others")


def restore(sim, path):
    """Replace the state of `sim` by the checkpoint at `path`, written from
    the same deck (but for RESTART_MAY_CHANGE; a DeckError names what
    differs). Every item the restore reads is checked first (presence,
    shape, kind, finite values, indices within what they index): a
    CheckpointError names the file, the dataset or attribute and what was
    expected, and nothing of the checkpoint reaches the solver. The
    gauges are located again from the deck (Simulation.locate_gauges);
    what a material gauge followed is in the books (the driver's
    _resume_books gives it back). Returns the books given to save."""
    path = Path(path)
    try:
        with h5py.File(path, "r") as h5:
            _check_format(h5, path)
            _check_same_deck(sim, h5, path)
            content = _read(sim, h5, path)
    except (OSError, RuntimeError) as exc:     # not HDF5, or damaged
        raise CheckpointError(path, None, "a readable fsph checkpoint (HDF5)", str(exc)) from None
    _load(sim, content, path)
    # not in the checkpoint: located again, in the initial configuration
    sim.locate_gauges()
    sim.initial_energy = content.initial_energy
    sim.particle_radius0 = content.particle_radius0
    return content.books


def state_digest(sim):
    """SHA-256 (hex) of the whole state a checkpoint holds: the clock and
    books, then every state array in checkpoint order. Two runs with the
    same digest continue identically; the reference runs' digests guard
    refactoring (tests/test_runs.py). The particles' ids enter only where
    they differ from the particles' numbers (the particles were renumbered
    in spatial order): a run that never renumbers hashes as it did before
    the ids were kept, so the digests stored on hosts of other kinds stay
    valid. The internal energy summed at the start of a recent cycle and
    that cycle (`energy_full_before`, `energy_full_cycle`, for the
    time-centred energy total) are left out: the cycles before a record
    sum it again from the state, so it does not decide how the run
    continues, and without it the digests are those of the runs before
    it was kept."""
    digest = hashlib.sha256()
    real, integer = _scalars(sim)
    real = np.delete(real, layouts.CHECKPOINT_REAL_SCALARS.index("energy_full_before"))
    integer = np.delete(integer, layouts.CHECKPOINT_INT_SCALARS.index("energy_full_cycle"))
    for scalars in (real, integer):
        digest.update(np.ascontiguousarray(scalars).tobytes())
    for name, values in _state_arrays(sim):
        if name == "particles/id" and np.array_equal(values.ravel(), np.arange(1, values.size + 1)):
            continue
        digest.update(np.ascontiguousarray(values).tobytes())
    return digest.hexdigest()
