"""Checkpoint and restart: the whole state the next cycle reads, written to
HDF5 by name (fsph.layouts: /state/nodes/x, /state/elements/rho, ...,
/scalars/time, ...) and read back so that a restarted run continues bit
for bit (same thread count). Files are written to a temporary name and
renamed: a crash mid-write never leaves a torn checkpoint."""

import hashlib
import os
from pathlib import Path

import h5py
import numpy as np

from . import layouts
from .errors import FsphError
from .simulation import STATUS_OK, _api

#: 3: datasets and scalars named (fsph.layouts), not numbered
FORMAT = 3
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
    r, i, ierr = _api.get_scalar_state(sim._run, len(layouts.CHECKPOINT_REAL_SCALARS),
                                       len(layouts.CHECKPOINT_INT_SCALARS))
    if ierr != STATUS_OK:
        raise FsphError("checkpoint scalars: layout mismatch, rebuild the package")
    return r, i


def save(sim, path):
    """Write the state of `sim` to `path` (HDF5)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    r, i = _scalars(sim)
    with h5py.File(tmp, "w") as h5:
        h5.attrs["format"] = FORMAT
        h5.attrs["initial_energy"] = sim.initial_energy
        h5.attrs["n_elements0"] = sim.n_elements0
        h5["particle_radius0"] = sim.particle_radius0
        scalars = h5.create_group("scalars")
        for names, values in ((layouts.CHECKPOINT_REAL_SCALARS, r), (layouts.CHECKPOINT_INT_SCALARS, i)):
            for name, value in zip(names, values):
                scalars.attrs[name] = value
        sizes = _api.checkpoint_sizes(sim._run, _REAL, 1)[2:]
        h5.attrs["sizes"] = np.array(sizes)          # nodes, elements, particles, capacity, edges
        state = h5.create_group("state")
        for name, values in _state_arrays(sim):
            state[name] = values
    os.replace(tmp, path)
    return path


def _read_scalars(h5, path):
    """(real, int) scalar arrays of a checkpoint, in the order of fsph.layouts."""
    attrs = h5["scalars"].attrs
    missing = [n for n in layouts.CHECKPOINT_REAL_SCALARS + layouts.CHECKPOINT_INT_SCALARS
               if n not in attrs]
    if missing:
        raise FsphError(f"{path}: checkpoint lacks the scalars {', '.join(missing)}")
    return (np.array([attrs[n] for n in layouts.CHECKPOINT_REAL_SCALARS], dtype=np.float64),
            np.array([attrs[n] for n in layouts.CHECKPOINT_INT_SCALARS], dtype=np.int32))


def _restore_arrays(sim, h5, path):
    """Copy every named state array of the checkpoint into `sim`."""
    known = set(layouts.CHECKPOINT_REAL + layouts.CHECKPOINT_INT)
    names = []
    h5["state"].visititems(lambda name, obj: names.append(name) if isinstance(obj, h5py.Dataset) else None)
    for name in names:
        if name not in known:
            raise FsphError(f"{path}: unknown state array '{name}' (written by another fsph version?)")
        if not _write_state_array(sim, name, h5["state"][name][...]):
            raise FsphError(f"{path}: state array '{name}' does not fit this deck "
                            "(was the checkpoint written from another deck?)")


def restore(sim, path):
    """Replace the state of `sim` (set up from the same deck) by the
    checkpoint at `path`."""
    path = Path(path)
    try:
        h5 = h5py.File(path, "r")
    except OSError as exc:
        raise FsphError(f"{path}: expected an fsph checkpoint (HDF5): {exc}") from None
    with h5:
        if h5.attrs.get("format") != FORMAT:
            raise FsphError(f"{path}: expected an fsph checkpoint of format {FORMAT}")
        nn, ne, np_, cap, n_edges = (int(v) for v in h5.attrs["sizes"])
        r, i = _read_scalars(h5, path)
        if _api.restore_begin(sim._run, nn, ne, np_, cap, n_edges, r, i) != STATUS_OK:
            raise FsphError(f"{path}: checkpoint scalars do not fit this build")
        _restore_arrays(sim, h5, path)
        _api.restore_end(sim._run)
        sim.initial_energy = float(h5.attrs["initial_energy"])
        sim.n_elements0 = int(h5.attrs["n_elements0"])
        sim.particle_radius0 = h5["particle_radius0"][...]


def state_digest(sim):
    """SHA-256 (hex) of the whole state a checkpoint holds: the clock and
    books, then every state array in checkpoint order. Two runs with the
    same digest continue identically; the reference runs' digests guard
    refactoring (tests/test_runs.py)."""
    digest = hashlib.sha256()
    for scalars in _scalars(sim):
        digest.update(np.ascontiguousarray(scalars).tobytes())
    for _, values in _state_arrays(sim):
        digest.update(np.ascontiguousarray(values).tobytes())
    return digest.hexdigest()
