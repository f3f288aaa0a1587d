"""Run outputs: HDF5 time history and snapshots (h5py), a ParaView series
(.pvd + .vtu through meshio) and summary.json."""

import json
import os
from pathlib import Path

import h5py
import meshio
import numpy as np

from . import layouts

#: columns of the time history (fsph.layouts), the energy total included
HISTORY_FIELDS = tuple(name for name, _, _ in layouts.HISTORY_COLUMNS)
SNAPSHOT_CELL_FIELDS = ("stress", "pressure", "q", "plastic_strain", "density",
                        "internal_energy", "temperature", "damage", "material", "body")
STRESS_COMPONENTS = ("rr", "zz", "rz", "tt")


def _points3(xy):
    """(n, 2) (r, z) -> (n, 3) (r, z, 0) for ParaView."""
    return np.column_stack([xy, np.zeros(len(xy))])


def _atomic_write_text(path, text):
    """Write to a temporary name then rename: a crash never leaves a torn file."""
    tmp = Path(str(path) + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


class RunWriter:
    """Writes one run's outputs into a folder.

    fsph.h5: /history/<field> (time [s], cycle, dt [s], kinetic [J],
    internal [J], contact work [J], energy removed by erosion [J], kinetic
    energy removed by the rigid planes and the particles' axis wall [J],
    total [J]); /snapshots/NNNNN/ with nodes (n, 2) (r, z)
    [m], velocity (n, 2) [m/s], connectivity (m, 3) 0-based and element
    fields; attributes time [s] and cycle; particles, if any, in
    /snapshots/NNNNN/particles/ (x, x0, velocity, mass, h, radius, stress,
    pressure, ...). The deck text is stored in /deck. vtu/ with fsph.pvd
    (elements) and fsph_particles.pvd (particles as vertices): the same
    snapshots for ParaView (points at (r, z, 0)).
    """

    def __init__(self, outdir, deck_text, title, vtu=True):
        self.outdir = Path(outdir)
        self.outdir.mkdir(parents=True, exist_ok=True)
        self.h5_path = self.outdir / "fsph.h5"
        self.h5 = h5py.File(self.h5_path, "w")
        self.h5.attrs["title"] = title
        self.h5["deck"] = deck_text
        hist = self.h5.create_group("history")
        for name in HISTORY_FIELDS:
            hist.create_dataset(name, shape=(0,), maxshape=(None,), dtype="f8", chunks=(4096,))
        self.snapshots = self.h5.create_group("snapshots")
        self.n_snapshots = 0
        self.energy0 = None
        self.max_energy_error = 0.0
        self.max_energy_error_time = 0.0
        self.vtu = vtu
        self.pvd_entries = {}
        if vtu:
            (self.outdir / "vtu").mkdir(exist_ok=True)

    def append_history(self, records):
        """records: (k, len(HISTORY_FIELDS)) rows. Also tracks the largest
        departure of the total energy (kinetic + internal + the work of the
        contact corrections + the energy erosion removed + the energy the
        rigid planes removed, summed by the solver) from its first value."""
        if len(records) == 0:
            return
        total = records[:, HISTORY_FIELDS.index("total")]
        if self.energy0 is None:
            self.energy0 = total[0]
        if self.energy0:
            worst = np.abs(total - self.energy0).argmax()
            error = (total[worst] - self.energy0) / self.energy0
            if abs(error) > abs(self.max_energy_error):
                self.max_energy_error = float(error)
                self.max_energy_error_time = float(records[worst, HISTORY_FIELDS.index("time")])
        hist = self.h5["history"]
        n0 = hist["time"].shape[0]
        n1 = n0 + len(records)
        for j, name in enumerate(HISTORY_FIELDS):
            hist[name].resize((n1,))
            hist[name][n0:n1] = records[:, j]

    def write_snapshot(self, snap):
        g = self.snapshots.create_group(f"{self.n_snapshots:05d}")
        g.attrs["time"] = snap["time"]
        g.attrs["cycle"] = snap["cycle"]
        if "conn" in snap:
            g["nodes"] = snap["x"]
            g["nodes_initial"] = snap["x0"]
            g["velocity"] = snap["velocity"]
            g["connectivity"] = snap["conn"]
            for name in SNAPSHOT_CELL_FIELDS:
                g[name] = snap[name]
            g["stress"].attrs["components"] = ",".join(STRESS_COMPONENTS)
        if "particles" in snap:
            pg = g.create_group("particles")
            for name, values in snap["particles"].items():
                pg[name] = values
            pg["stress"].attrs["components"] = ",".join(STRESS_COMPONENTS)
        self.h5.flush()
        if self.vtu:
            self._write_vtu(snap)
        self.n_snapshots += 1

    def _write_vtu(self, snap):
        if "conn" in snap:
            cell_data = {k: [snap[k]] for k in SNAPSHOT_CELL_FIELDS if k != "stress"}
            for j, comp in enumerate(STRESS_COMPONENTS):
                cell_data[f"stress_{comp}"] = [snap["stress"][:, j]]
            mesh = meshio.Mesh(_points3(snap["x"]), [("triangle", snap["conn"])],
                               point_data={"velocity": _points3(snap["velocity"])},
                               cell_data=cell_data)
            self._add_series("elements", snap["time"], mesh)
        if "particles" in snap:
            part = snap["particles"]
            n = len(part["x"])
            point_data = {k: v for k, v in part.items()
                          if k not in ("x", "x0", "velocity", "stress") and np.ndim(v) == 1}
            point_data["velocity"] = _points3(part["velocity"])
            for j, comp in enumerate(STRESS_COMPONENTS):
                point_data[f"stress_{comp}"] = part["stress"][:, j]
            mesh = meshio.Mesh(_points3(part["x"]), [("vertex", np.arange(n).reshape(-1, 1))],
                               point_data=point_data)
            self._add_series("particles", snap["time"], mesh)

    def _add_series(self, kind, time, mesh):
        """One .vtu per snapshot and kind; the .pvd collection rewritten."""
        name = f"vtu/{kind}_{self.n_snapshots:05d}.vtu"
        # uncompressed binary: double-precision fields hardly compress, and
        # zlib was the largest output cost of a short run
        meshio.write(self.outdir / name, mesh, binary=True, compression=None)
        entries = self.pvd_entries.setdefault(kind, [])
        entries.append((time, name))
        rows = "\n".join(f'    <DataSet timestep="{t:.9e}" group="" part="0" file="{f}"/>'
                         for t, f in entries)
        pvd = "fsph.pvd" if kind == "elements" else f"fsph_{kind}.pvd"
        _atomic_write_text(self.outdir / pvd,
                           '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n'
                           f"  <Collection>\n{rows}\n  </Collection>\n</VTKFile>\n")

    def mark_failure(self, message):
        self.h5.attrs["failure"] = message

    def close(self):
        self.h5.close()


def write_summary(outdir, summary):
    _atomic_write_text(Path(outdir) / "summary.json", json.dumps(summary, indent=2) + "\n")
