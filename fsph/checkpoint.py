"""Checkpoint and restart: the whole state the next cycle reads, written to
HDF5 through the solver's numbered state arrays and read back so that a
restarted run continues bit for bit (same thread count). Files are written
to a temporary name and renamed: a crash mid-write never leaves a torn
checkpoint."""

import hashlib
import os
from pathlib import Path

import h5py
import numpy as np

from .errors import FsphError
from .simulation import _api

FORMAT = 2


def _state_arrays(sim):
    """Every non-empty state array of `sim`, in checkpoint order, as
    ("real" or "int", its number, the array)."""
    n_real, n_int, _, _ = _api.checkpoint_layout(sim._run)
    for kind, name, count, getter in ((1, "real", n_real, _api.get_real_state),
                                      (2, "int", n_int, _api.get_int_state)):
        for k in range(1, count + 1):
            rows, cols = _api.checkpoint_sizes(sim._run, kind, k)[:2]
            if rows * cols > 0:
                yield name, k, getter(sim._run, k, rows, cols)


def save(sim, path):
    """Write the state of `sim` to `path` (HDF5)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    r, i = _api.get_scalar_state(sim._run)
    with h5py.File(tmp, "w") as h5:
        h5.attrs["format"] = FORMAT
        h5.attrs["initial_energy"] = sim.initial_energy
        h5.attrs["n_elements0"] = sim.n_elements0
        h5["particle_radius0"] = sim.particle_radius0
        h5["scalars_real"] = r
        h5["scalars_int"] = i
        sizes = _api.checkpoint_sizes(sim._run, 1, 1)[2:]
        h5.attrs["sizes"] = np.array(sizes)          # nodes, elements, particles, capacity, edges
        groups = {"real": h5.create_group("real"), "int": h5.create_group("int")}
        for kind, k, values in _state_arrays(sim):
            groups[kind][str(k)] = values
    os.replace(tmp, path)
    return path


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
        _api.restore_begin(sim._run, nn, ne, np_, cap, n_edges, h5["scalars_real"][...],
                           h5["scalars_int"][...])
        for kind, setter in ((1, _api.set_real_state), (2, _api.set_int_state)):
            group = h5["real" if kind == 1 else "int"]
            for key in group:
                values = np.asfortranarray(group[key][...])
                if setter(sim._run, int(key), values) != 0:
                    raise FsphError(f"{path}: state array {kind}/{key} does not fit this deck "
                                    "(was the checkpoint written from another deck?)")
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
    for scalars in _api.get_scalar_state(sim._run):
        digest.update(np.ascontiguousarray(scalars).tobytes())
    for _, _, values in _state_arrays(sim):
        digest.update(np.ascontiguousarray(values).tobytes())
    return digest.hexdigest()
