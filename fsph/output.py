"""Run outputs: HDF5 time history and snapshots (h5py), a ParaView series
(.pvd + .vtu, fsph.vtu) and summary.json."""

import json
import os
import re
import resource
import shutil
import socket
import time
from contextlib import contextmanager
from pathlib import Path

import h5py
import numpy as np

from . import layouts, vtu
from .errors import InputError, OutputError
from .hdf5_writes import append_rows, write_attribute, write_dataset
from .points import von_mises

#: columns of the time history (fsph.layouts), the energy total included
HISTORY_FIELDS = tuple(name for name, _, _ in layouts.HISTORY_COLUMNS)
BODY_FIELDS = tuple(name for name, _, _ in layouts.BODY_COLUMNS)
GAUGE_FIELDS = tuple(name for name, _, _ in layouts.GAUGE_COLUMNS)
#: The body history dataset derived from its momentum (RunWriter._body_rows).
BODY_FORCE = ("force_z", "N", "axial force on the body from everything outside it (contact, "
              "rigid planes), averaged between history rows (the rate of momentum_z over the "
              "times of the rows' half-step velocities, time - dt/2)")
#: Rows per chunk of the history datasets: a chunk is allocated whole at the
#: first write (4 kB), so a short run's file stays small and its first
#: snapshot's growth, on which the room check bases its estimate, is the
#: snapshot's own.
HISTORY_CHUNK = 512
#: The history dataset derived from the planes' impulse (RunWriter._plane_force).
PLANE_FORCE = ("plane_force_z", "N", "axial force of the rigid planes on the bodies, averaged "
               "between history rows (the rate of plane_impulse_z over the times of the rows' "
               "half-step velocities, time - dt/2); the bodies push the planes with minus it")
#: the element fields of a snapshot (failed and melted: the material
#: point's flags, 0/1, as the particles')
SNAPSHOT_CELL_FIELDS = ("stress", "pressure", "q", "plastic_strain", "density",
                        "internal_energy", "temperature", "damage", "failed", "melted",
                        "material", "body", "id")
STRESS_COMPONENTS = ("rr", "zz", "rz", "tt")
#: the lock file that keeps a second run out of an output folder in use
LOCK_NAME = "fsph.lock"
#: a snapshot is written under this name and renamed NNNNN when complete,
#: so a snapshot cut short (a full disk) never looks like one
PARTIAL_SNAPSHOT = "writing"
#: a snapshot needs room for this many times the bytes of the last one
ROOM_FACTOR = 2.0
#: how long a write of fsph.h5 waits for readers to close it [s], and how
#: often it tries again [s]; after that it writes without HDF5's lock
LOCK_WAIT_S = 10.0
LOCK_RETRY_S = 0.02


def _points3(xy):
    """(n, 2) (r, z) -> (n, 3) (r, z, 0) for ParaView."""
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    return np.column_stack([xy, np.zeros(len(xy))])


#: The parts of the .pvd series, in order.
VTU_PARTS = ("elements", "particles")
#: The ParaView series of a run: its .pvd collections in the output folder
#: and the names of its .vtu files in vtu/ (RunWriter._add_part: the part,
#: _3d for the revolved series, the snapshot's number). A run removes the
#: files of these names an earlier run left in its folder, its checkpoint
#: and the pictures `fsph plot` drew of it under their default names
#: (fsph.plot), and no other file.
PVD_NAMES = ("fsph.pvd", "fsph_3d.pvd")
VTU_FILE = re.compile(r"(?:elements|particles)(?:_3d)?_\d{5,}\.vtu")
CHECKPOINT_NAME = "checkpoint.h5"
PICTURE_FILE = re.compile(r"(?:shapes|history|perforation|gauges|bodies|damage|field_\w+)\.png")


def _element_mesh(snap):
    """The VTU mesh (fsph.vtu) of a snapshot's elements."""
    cell_data = {k: [snap[k]] for k in SNAPSHOT_CELL_FIELDS if k != "stress"}
    for j, comp in enumerate(STRESS_COMPONENTS):
        cell_data[f"stress_{comp}"] = [snap["stress"][:, j]]
    cell_data["mises"] = [von_mises(snap["stress"])]
    point_data = {"velocity": _points3(snap["velocity"]),
                  "displacement": _points3(snap["x"] - snap["x0"])}
    return vtu.Mesh(_points3(snap["x"]), [("triangle", snap["conn"])], point_data=point_data,
                          cell_data=cell_data)


def _particle_mesh(part):
    """The VTU mesh (fsph.vtu) of a snapshot's particles, as vertices."""
    n = len(part["x"])
    point_data = {k: v for k, v in part.items()
                  if k not in ("x", "x0", "velocity", "stress") and np.ndim(v) == 1}
    point_data["velocity"] = _points3(part["velocity"])
    point_data["displacement"] = _points3(part["x"] - part["x0"])
    for j, comp in enumerate(STRESS_COMPONENTS):
        point_data[f"stress_{comp}"] = part["stress"][:, j]
    point_data["mises"] = von_mises(part["stress"])
    return vtu.Mesh(_points3(part["x"]), [("vertex", np.arange(n).reshape(-1, 1))],
                          point_data=point_data)


@contextmanager
def writing_errors(path):
    """Turn an OSError of the writes inside into an OutputError naming the
    file (a full disk, the file size limit, a folder removed)."""
    try:
        yield
    except OSError as err:
        raise OutputError(f"{path}: writing failed: {err.strerror or err}") from err


def _atomic_write_text(path, text):
    """Write to a temporary name then rename: a crash never leaves a torn file."""
    tmp = Path(str(path) + ".tmp")
    with writing_errors(path):
        try:
            tmp.write_text(text)
            os.replace(tmp, path)
        finally:
            tmp.unlink(missing_ok=True)


def remove_earlier_outputs(outdir):
    """Remove what an earlier run left in outdir that the new run may not
    replace: its ParaView series, the .pvd collections (PVD_NAMES) and the
    .vtu files in vtu/ named as fsph names them (VTU_FILE); its checkpoint
    (a run without checkpoints would leave it beside its own outputs); and
    the pictures fsph plot drew of it (PICTURE_FILE), so that the folder
    shows one run only (fsph.h5 and summary.json are replaced by the new
    run's). Any other file stays; vtu/ goes once empty. Returns the number
    of files removed."""
    outdir = Path(outdir)
    folder = outdir / "vtu"
    with writing_errors(outdir):
        stale = [outdir / name for name in PVD_NAMES + (CHECKPOINT_NAME,) if (outdir / name).is_file()]
        stale += [path for path in outdir.iterdir()
                  if PICTURE_FILE.fullmatch(path.name) and path.is_file()]
        if folder.is_dir():
            stale += [path for path in folder.iterdir()
                      if VTU_FILE.fullmatch(path.name) and path.is_file()]
        for path in stale:
            path.unlink()
        if folder.is_dir() and not any(folder.iterdir()):
            folder.rmdir()
    return len(stale)


def _pid_alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:     # alive, another user's
        return True
    return True


class FolderLock:
    """The output folder's lock file (fsph.lock: pid, host). A second run
    into a folder in use is refused, whatever HDF5's own file locking does
    (it is often off on cluster file systems). A lock left by a killed run
    on this host (its pid gone) is taken over; one from another host is
    not (its process cannot be checked): the message says to remove it.

    Creating the folder and the lock is also the test that the folder can
    be written: a file in its place, a folder without write permission and
    a folder in use are InputErrors (exit 2) before the run starts."""

    def __init__(self, outdir):
        outdir = Path(outdir)
        self.path = outdir / LOCK_NAME
        self.stale = None
        if outdir.exists() and not outdir.is_dir():
            raise InputError(f"{outdir}: expected an output folder, got a file of that name "
                             f"(give another -o)")
        try:
            outdir.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise InputError(f"{outdir}: cannot create the output folder: "
                             f"{err.strerror or err}") from err
        self._acquire()

    def _acquire(self):
        me = f"{os.getpid()} {socket.gethostname()}\n"
        for _ in range(2):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                self._refuse_or_clear()
                continue
            except OSError as err:
                raise InputError(f"{self.path.parent}: expected a writable output folder: "
                                 f"{err.strerror or err}") from err
            with os.fdopen(fd, "w") as fh:
                fh.write(me)
            return
        raise InputError(f"{self.path}: could not take the output folder's lock")

    def _refuse_or_clear(self):
        """Remove a stale lock (its process gone, on this host) or raise."""
        pid, host = lock_owner(self.path.parent) or (None, "?")
        if pid is not None and host == socket.gethostname() and not _pid_alive(pid):
            self.stale = pid
            self.path.unlink(missing_ok=True)
            return
        raise InputError(f"{self.path.parent}: output folder in use by another run (pid {pid} "
                         f"on {host}, {self.path}); give another -o, or remove {LOCK_NAME} if "
                         f"that run is dead")

    def release(self):
        self.path.unlink(missing_ok=True)


def lock_owner(folder):
    """(pid, host) of the run holding folder's lock, None without a
    readable lock."""
    try:
        pid_text, host = (Path(folder) / LOCK_NAME).read_text().split()
        return int(pid_text), host
    except (OSError, ValueError):
        return None


def _file_size_limit():
    """The process's file size limit [bytes] (ulimit -f), None without."""
    soft = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    return None if soft == resource.RLIM_INFINITY else soft


class RunWriter:
    """Writes one run's outputs into a folder.

    fsph.h5: /history/<field> (time [s], cycle, dt [s], the rigid planes'
    axial impulse [N s] and force [N] on the bodies, kinetic [J],
    internal [J], contact work [J], energy removed by erosion [J], kinetic
    energy removed by the rigid planes and the particles' axis wall [J],
    total [J]; each with its `units`); /body_history/<body>/<field> at the
    same rows (kinetic [J], internal [J], axial momentum [N s], axial force
    on the body [N]); /gauge_history/<gauge>/<field> at the same rows
    (fsph.layouts GAUGE_COLUMNS, each with its `units` and `description`;
    the group's attributes: kind, point (r, z) [m] with point_units,
    switch_time and lost_time [s], NaN where none, with time_units);
    /snapshots/NNNNN/ with nodes (n, 2) (r, z)
    [m], velocity (n, 2) [m/s], connectivity (m, 3) 0-based and element
    fields; attributes time [s] and cycle; particles, if any, in
    /snapshots/NNNNN/particles/ (x, x0, velocity, mass, h, radius, stress,
    pressure, ...); the case metrics that have a history (&metrics kind
    debris) in /metrics/<kind>/<key>, one value per snapshot (NaN where
    undefined) with its unit in the attribute `units`. The deck text is
    stored in /deck. fsph.pvd with vtu/ (elements as part 0, particles
    as vertices as part 1), and fsph_3d.pvd where the deck revolves them:
    the same snapshots for ParaView (points at (r, z, 0)). The series an
    earlier run left in the folder is removed first
    (remove_earlier_outputs).

    fsph.h5 is opened for each write and closed after it, so other
    processes can read it while the run goes on: each write holds HDF5's
    exclusive file lock, so a reader with HDF5's default locking gets an
    OSError ("unable to lock file") during a write instead of a half-written
    file, and a write waits for readers to close it (LOCK_WAIT_S; after that
    it writes without the lock and says so in `lock_warning`). The folder's
    lock file keeps other writers out. The history is written with each
    snapshot. Every failed
    write is an OutputError; before a snapshot, check_room refuses to start
    one the disk or the file size limit has no room for, so the last
    complete snapshot stays readable.
    """

    def __init__(self, outdir, deck_text, title, vtu=True, body_names=(), material_names=(),
                 revolve=(0, 360.0), gauges=()):
        self.outdir = Path(outdir)
        self.h5_path = self.outdir / "fsph.h5"
        self.lock_warning = ""      # set once a write could not wait for a reader
        self.removed_earlier = remove_earlier_outputs(self.outdir)   # files of an earlier run
        self._file_locks = True     # False on a file system without locks
        with self._h5("w") as h5:
            h5.attrs["title"] = title
            h5.attrs["units"] = ("SI: m, s, kg, N, Pa, J, K; each dataset's own `units` "
                                 "attribute names its unit (the /metrics series: mm, us, GPa "
                                 "as their names end)")
            # the snapshots' body and material fields index these (0-based)
            h5.attrs["body_names"] = list(body_names)
            h5.attrs["material_names"] = list(material_names)
            h5["deck"] = deck_text
            _history_datasets(h5.create_group("history"), layouts.HISTORY_COLUMNS + (PLANE_FORCE,))
            for body in body_names:
                _history_datasets(h5.create_group(f"body_history/{body}"), layouts.BODY_COLUMNS + (BODY_FORCE,))
            for gauge in gauges:
                group = h5.create_group(f"gauge_history/{gauge['name']}")
                group.attrs["kind"] = gauge["kind"]
                group.attrs["point"] = np.asarray(gauge["point"], dtype=float)
                group.attrs["point_units"] = "m"
                group.attrs["switch_time"] = np.nan
                group.attrs["lost_time"] = np.nan
                group.attrs["time_units"] = "s"     # of switch_time and lost_time
                _history_datasets(group, layouts.GAUGE_COLUMNS)
            h5.create_group("snapshots")
        self.n_snapshots = 0
        self._history = []          # history rows not yet written
        self.last_snapshot_bytes = 0
        self.energy0 = None
        self.max_energy_error = 0.0
        self.max_energy_error_time = 0.0
        self.body_names = tuple(body_names)
        self.material_names = tuple(material_names)
        self._bodies = []           # the bodies' rows not yet written (k, bodies, columns)
        self._body_last = None      # (time [s], momenta [N s]) of the last history row
        self.body_force_peak = [(0.0, 0.0)] * len(self.body_names)  # (force [N], time [s])
        self.body_books = {}        # each body's books at the last history row
        self.gauges = [dict(g) for g in gauges]
        self._gauges = []           # the gauges' rows not yet written (k, gauges, columns)
        # each gauge's largest |pressure| so far: (signed value [Pa], time [s]), and last row
        self.gauge_peak = [(None, None)] * len(self.gauges)
        self.gauge_last = [None] * len(self.gauges)
        self.gauge_state = {}       # Simulation.gauge_state() at the last history drained
        self._plane_last = None     # (time [s], impulse [N s]) of the last history row
        self.plane_force_peak = 0.0       # [N]
        self.plane_force_peak_time = 0.0  # [s]
        self.vtu = vtu
        self.pvd_entries = []       # (time [s], part, file) of every .vtu written
        self.revolve = revolve      # (segments, angle [deg]) of the 3D series; 0 segments: none
        self.pvd_3d_entries = []
        if vtu:
            with writing_errors(self.outdir / "vtu"):
                (self.outdir / "vtu").mkdir(exist_ok=True)

    @contextmanager
    def _h5(self, mode="a"):
        """fsph.h5 open for one write, under HDF5's exclusive lock when the
        readers let it have it within LOCK_WAIT_S (OSError -> OutputError)."""
        with writing_errors(self.h5_path), self._locked_file(mode) as h5:
            yield h5

    def _locked_file(self, mode):
        """h5py.File(mode) with HDF5's file lock, tried again while a
        reader holds the file; unlocked (lock_warning set) once it has
        waited LOCK_WAIT_S. Other errors pass through."""
        if self.lock_warning or not self._file_locks:
            return h5py.File(self.h5_path, mode, locking=False)
        deadline = time.monotonic() + LOCK_WAIT_S
        while True:
            try:
                return h5py.File(self.h5_path, mode, locking=True)
            except BlockingIOError:
                if time.monotonic() > deadline:
                    break
                time.sleep(LOCK_RETRY_S)
            except OSError:
                # a file system without locks (or another fault, which the
                # unlocked open raises again)
                self._file_locks = False
                return h5py.File(self.h5_path, mode, locking=False)
        self.lock_warning = (f"{self.h5_path} was held open by another process for more than "
                             f"{LOCK_WAIT_S:g} s: later snapshots are written without waiting "
                             f"for it, and a program that keeps it open may read them torn "
                             f"(close the file between reads)")
        return h5py.File(self.h5_path, mode, locking=False)

    def _h5_bytes(self):
        """Size of fsph.h5 [B]."""
        with writing_errors(self.h5_path):
            return self.h5_path.stat().st_size

    def check_room(self, time, other_bytes=0):
        """Raise OutputError if the disk, or the file size limit, leaves no
        room for the next snapshot (ROOM_FACTOR times the last one) and
        other_bytes [B] more (the checkpoint rewritten beside it); time [s]
        for the message. Nothing is known before the first snapshot."""
        need = ROOM_FACTOR * self.last_snapshot_bytes
        if not need:
            return
        with writing_errors(self.outdir):
            free = shutil.disk_usage(self.outdir).free
        where = f"the disk of {self.outdir} has {free / 2**20:.1f} MiB free"
        limit = _file_size_limit()
        short = free < need + other_bytes
        if limit is not None and not short:
            largest = max(self._h5_bytes() + need, other_bytes)
            short = largest > limit
            where = f"the file size limit (ulimit -f) is {limit / 2**20:.1f} MiB"
        if short:
            raise OutputError(f"no room for the snapshot at t = {time * 1e6:.6g} us: {where}, "
                              f"the next snapshot needs about {need / 2**20:.1f} MiB "
                              f"(and {other_bytes / 2**20:.1f} MiB for the checkpoint)")

    def append_history(self, records, bodies=None, gauges=None):
        """records: (k, len(HISTORY_FIELDS)) rows; bodies: the bodies' books
        at the same rows (k, bodies, len(BODY_COLUMNS)), or None for a writer
        without bodies; gauges: the gauges' rows (k, gauges,
        len(GAUGE_COLUMNS)), or None for a writer without gauges. Also
        tracks each gauge's peak |pressure| and last row, and the largest
        departure of the total energy (kinetic + internal + the work of the
        contact corrections + the energy erosion removed + the energy the
        rigid planes removed, summed by the solver) from its first value.
        The rows are written with the next snapshot (one opening of fsph.h5
        each), or by flush()."""
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
        records = np.asarray(records, dtype=float)
        force = self._plane_force(records)
        self._history.append(np.column_stack([records, force]))
        if self.body_names:
            self._bodies.append(self._body_rows(records[:, HISTORY_FIELDS.index("time")],
                                                _velocity_times(records), bodies))
        if self.gauges:
            self._gauges.append(self._gauge_rows(records[:, HISTORY_FIELDS.index("time")], gauges))

    def last_rates_row(self):
        """The last history row the forces are rates from, for a
        checkpoint: (time [s] of its half-step velocities, the planes'
        axial impulse [N s]) and (that time [s], each body's axial momentum
        [N s]); None for one not yet met."""
        return self._plane_last, self._body_last

    def continue_rates_from(self, time, plane_impulse_z, body_momentum_z=None):
        """A restart's writer: the forces of its first history rows are
        rates from the checkpoint's last row, its velocities at `time` [s] (the planes'
        axial impulse [N s]; each body's axial momentum [N s], None where
        the checkpoint had no body rows)."""
        self._plane_last = (time, np.float64(plane_impulse_z))
        if body_momentum_z is not None:
            self._body_last = (time, np.array(body_momentum_z, dtype=float))

    def _gauge_rows(self, t, gauges):
        """The gauges' rows (k, gauges, columns), tracking each gauge's
        largest |pressure| (the first time it is reached) and last row."""
        gauges = np.asarray(gauges, dtype=float).reshape(len(t), len(self.gauges), len(GAUGE_FIELDS))
        pressure = gauges[:, :, GAUGE_FIELDS.index("pressure")]
        for g in range(len(self.gauges)):
            self.gauge_last[g] = (float(t[-1]), gauges[-1, g].copy())
            p = np.abs(pressure[:, g])
            if np.all(np.isnan(p)):         # in no material at any of these rows
                continue
            k = int(np.nanargmax(p))
            best = self.gauge_peak[g][0]
            if best is None or p[k] > abs(best):
                self.gauge_peak[g] = (float(pressure[k, g]), float(t[k]))
        return gauges

    def gauge_summary(self):
        """Each gauge's summary.json entry: kind, point (r, z) [m], the
        pressure [Pa] where |pressure| was largest and its time [s], when a
        material gauge moved from its element to a particle and when its
        element was deleted [s] (None: never) and its last row by field,
        each key naming its unit (key_with_unit: pressure_Pa, velocity_z_m_s;
        None where NaN: no material there)."""
        out = {}
        for g, gauge in enumerate(self.gauges):
            peak, time = self.gauge_peak[g]
            state = self.gauge_state.get(gauge["name"], {})
            last_time, last = self.gauge_last[g] if self.gauge_last[g] is not None else (None, None)
            out[gauge["name"]] = {
                "kind": gauge["kind"], "point_m": [float(v) for v in gauge["point"]],
                "peak_pressure_Pa": peak, "peak_pressure_time_s": time,
                "switch_time_s": state.get("switch_time"), "lost_time_s": state.get("lost_time"),
                "last_time_s": last_time,
                "last": None if last is None else {
                    key_with_unit(name, unit): (None if np.isnan(v) else float(v))
                    for (name, unit, _), v in zip(layouts.GAUGE_COLUMNS, last)},
            }
        return out

    def _body_rows(self, t, t_velocity, bodies):
        """The bodies' rows at times t [s] with their axial force [N]
        appended: the change of each body's momentum since the row before
        over the time between the rows' half-step velocities t_velocity
        [s] (0 at the first row)."""
        bodies = np.asarray(bodies, dtype=float).reshape(len(t), len(self.body_names), len(BODY_FIELDS))
        force, self._body_last = _rate_between_rows(t_velocity,
                                                    bodies[:, :, BODY_FIELDS.index("momentum_z")],
                                                    self._body_last)
        worst = np.abs(force).argmax(axis=0)
        for b, k in enumerate(worst):
            if abs(force[k, b]) > abs(self.body_force_peak[b][0]):
                self.body_force_peak[b] = (float(force[k, b]), float(t[k]))
        self.body_books = {name: dict(zip(BODY_FIELDS, (float(v) for v in bodies[-1, b])))
                           for b, name in enumerate(self.body_names)}
        return np.concatenate([bodies, force[:, :, None]], axis=2)

    def _plane_force(self, records):
        """The planes' axial force on the bodies [N] at each row: the change
        of their impulse since the row before over the time between the
        rows' half-step velocities (0 at the first row); tracks its largest
        magnitude."""
        t = records[:, HISTORY_FIELDS.index("time")]
        force, self._plane_last = _rate_between_rows(_velocity_times(records),
                                                     records[:, HISTORY_FIELDS.index("plane_impulse_z")],
                                                     self._plane_last)
        worst = int(np.abs(force).argmax())
        if abs(force[worst]) > abs(self.plane_force_peak):
            self.plane_force_peak = float(force[worst])
            self.plane_force_peak_time = float(t[worst])
        return force

    def _write_history(self, h5):
        """Append the rows kept since the last write to /history of the open h5."""
        if not self._history:
            return
        records = np.concatenate(self._history)
        hist = h5["history"]
        n0 = hist["time"].shape[0]
        for j, name in enumerate(HISTORY_FIELDS + (PLANE_FORCE[0],)):
            append_rows(hist, name, n0, records[:, j])
        self._history = []
        if self._bodies:
            rows = np.concatenate(self._bodies)
            for b, body in enumerate(self.body_names):
                group = h5[f"body_history/{body}"]
                for j, name in enumerate(BODY_FIELDS + (BODY_FORCE[0],)):
                    append_rows(group, name, n0, rows[:, b, j])
            self._bodies = []
        if self._gauges:
            rows = np.concatenate(self._gauges)
            for g, gauge in enumerate(self.gauges):
                group = h5[f"gauge_history/{gauge['name']}"]
                state = self.gauge_state.get(gauge["name"], {})
                for key in ("switch_time", "lost_time"):
                    group.attrs[key] = np.nan if state.get(key) is None else state[key]
                for j, name in enumerate(GAUGE_FIELDS):
                    append_rows(group, name, n0, rows[:, g, j])
            self._gauges = []

    def _name_ids(self, g):
        """The names the body and material fields of a snapshot group (and
        its particles) index, as their attribute `names`."""
        for group in (g, g.get("particles")):
            if group is None:
                continue
            for field, names in (("body", self.body_names), ("material", self.material_names)):
                if field in group and names:
                    group[field].attrs["names"] = list(names)

    def flush(self):
        """Write the history rows kept since the last snapshot."""
        if self._history:
            with self._h5() as h5:
                self._write_history(h5)

    def write_snapshot(self, snap, metrics=None):
        """Write snap into fsph.h5 (under PARTIAL_SNAPSHOT, renamed NNNNN
        once complete) and the vtu series; metrics: (kind, record, units),
        a per-snapshot record of the case metrics appended to their
        history (_append_metrics), or None."""
        before = self._h5_bytes()
        with self._h5() as h5:
            self._write_history(h5)
            if metrics is not None:
                _append_metrics(h5, *metrics)
            snapshots = h5["snapshots"]
            if PARTIAL_SNAPSHOT in snapshots:
                del snapshots[PARTIAL_SNAPSHOT]
            g = snapshots.create_group(PARTIAL_SNAPSHOT)
            write_attribute(g, "time", snap["time"])
            write_attribute(g, "cycle", snap["cycle"])
            if "conn" in snap:
                for name, field in (("nodes", "x"), ("nodes_initial", "x0"), ("velocity", "velocity"),
                                    ("connectivity", "conn")):
                    _put_field(g, name, snap[field], field)
                for name in SNAPSHOT_CELL_FIELDS:
                    _put_field(g, name, snap[name], name)
            if "particles" in snap:
                pg = g.create_group("particles")
                for name, values in snap["particles"].items():
                    _put_field(pg, name, values, name)
            self._name_ids(g)
            snapshots.move(PARTIAL_SNAPSHOT, f"{self.n_snapshots:05d}")
        vtu_bytes = self._write_vtu(snap) if self.vtu else 0
        self.n_snapshots += 1
        self.last_snapshot_bytes = max(self._h5_bytes() - before, 0) + vtu_bytes

    def _write_vtu(self, snap):
        """The snapshot's .vtu files, elements and particles, and the one
        .pvd collection that lists both as parts 0 and 1 of each time
        step; returns their bytes [B]. A kind is listed only at the time
        steps that have it, so ParaView, which reads at a time step the
        parts listed there, draws no particles before the first conversion
        (two separate series drew the first particles over the t = 0 mesh).
        Fields as in fsph.h5, with the von Mises stress `mises` [Pa] and the
        displacement since t = 0 `displacement` [m]."""
        written = 0
        segments, angle = self.revolve
        meshes = {}
        if "conn" in snap:
            meshes["elements"] = _element_mesh(snap)
        if "particles" in snap:
            meshes["particles"] = _particle_mesh(snap["particles"])
        for kind, mesh in meshes.items():
            written += self._add_part(kind, snap["time"], mesh, self.pvd_entries)
            if segments:
                written += self._add_part(kind + "_3d", snap["time"], _revolved(mesh, segments, angle),
                                          self.pvd_3d_entries)
        self._write_pvd("fsph.pvd", self.pvd_entries)
        if segments:
            self._write_pvd("fsph_3d.pvd", self.pvd_3d_entries)
        return written

    def _add_part(self, kind, time, mesh, entries):
        """One .vtu of a kind for this snapshot, listed in entries; returns
        its bytes [B]."""
        name = f"vtu/{kind}_{self.n_snapshots:05d}.vtu"
        # uncompressed binary: double-precision fields hardly compress, and
        # zlib was the largest output cost of a short run
        with writing_errors(self.outdir / name):
            written = vtu.write(self.outdir / name, _with_units(mesh))
        entries.append((time, VTU_PARTS.index(kind.removesuffix("_3d")), name))
        return written

    def _write_pvd(self, name, entries):
        """A .pvd collection: every snapshot's files, elements as part 0 and
        particles as part 1 of one series."""
        rows = "\n".join(f'    <DataSet timestep="{t:.9e}" group="" part="{p}" file="{f}"/>'
                         for t, p, f in entries)
        _atomic_write_text(self.outdir / name,
                           '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n'
                           f"  <Collection>\n{rows}\n  </Collection>\n</VTKFile>\n")

    def mark_failure(self, message):
        with self._h5() as h5:
            self._write_history(h5)
            h5.attrs["failure"] = message


#: The unit of each snapshot field (fsph.h5 attribute `units`; SI throughout).
SNAPSHOT_UNITS = {
    "x": "m", "x0": "m", "velocity": "m/s", "conn": "-", "stress": "Pa", "pressure": "Pa", "q": "Pa",
    "plastic_strain": "-", "density": "kg/m^3", "internal_energy": "J/kg", "temperature": "K",
    "damage": "-", "material": "-", "body": "-", "id": "-", "mass": "kg", "h": "m", "radius": "m",
    "radius0": "m", "sound_speed": "m/s", "failed": "-", "melted": "-",
}


def key_with_unit(name, unit):
    """A summary.json key that names its unit, as the others do: name_unit
    with '/' as '_' and no '^' (velocity_z_m_s, density_kg_m3,
    internal_energy_J_kg); the name alone for a dimensionless '-'."""
    if unit == "-":
        return name
    return f"{name}_{unit.replace('/', '_').replace('^', '').replace(' ', '_')}"


def _velocity_times(records):
    """The times [s] of the velocities at history rows (k, HISTORY_FIELDS):
    the half step before each row's time, t - dt/2 (the central difference
    keeps velocities at half steps; the impulse and the momenta of a row
    are of those velocities). Rates over these times stay exact where the
    steps change, as the last ones that land on the end time."""
    return (records[:, HISTORY_FIELDS.index("time")]
            - 0.5 * records[:, HISTORY_FIELDS.index("dt")])


def _rate_between_rows(t, values, last):
    """The rate of change of values (k,) or (k, m) between consecutive
    history rows at times t (k,) [s]: the change since the row before over
    the time between, 0 where no time passed (the first row of a run).
    last: (time, values) of the row before these, None at the first rows.
    Returns (rates, (time, values) of the last row)."""
    values = np.asarray(values, dtype=float)
    t_prev, v_prev = last if last is not None else (t[0], values[0])
    t_before = np.concatenate([[t_prev], t[:-1]])
    v_before = np.concatenate([np.asarray(v_prev, dtype=float)[None], values[:-1]])
    span = (t - t_before).reshape((-1,) + (1,) * (values.ndim - 1))
    rates = np.divide(values - v_before, span, out=np.zeros_like(values), where=span > 0.0)
    return rates, (t[-1], values[-1].copy())


def _history_datasets(group, columns):
    """Empty extendable datasets in `group`, one per (name, unit, meaning)
    of columns, each with its `units` and `description`."""
    for name, unit, meaning in columns:
        group.create_dataset(name, shape=(0,), maxshape=(None,), dtype="f8", chunks=(HISTORY_CHUNK,))
        group[name].attrs["units"] = unit
        group[name].attrs["description"] = meaning


def _vtu_unit(name):
    """The unit of a VTU array (the fsph.h5 field's; stress components,
    the von Mises stress and the displacement included)."""
    if name.startswith("stress_") or name == "mises":
        return "Pa"
    return SNAPSHOT_UNITS.get("x" if name == "displacement" else name, "-")


def _revolved(mesh, segments, angle_deg):
    """The r-z mesh (points (r, z, 0)) revolved about the z axis through
    angle_deg in `segments` steps, for viewing: triangles become wedges,
    vertices rings of vertices; point arrays repeat on every copy of a
    point (vectors (v_r, v_z, 0) turned with it), cell arrays on every copy
    of a cell. Returns a VTU mesh (fsph.vtu) in (x, y, z) [m]."""
    theta = np.radians(np.linspace(0.0, angle_deg, segments + 1))
    if angle_deg >= 360.0:
        theta = theta[:-1]                      # the last copy is the first
    n, k = len(mesh.points), len(theta)
    r, z = mesh.points[:, 0], mesh.points[:, 1]
    c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
    points = np.stack([(r * c).ravel(), (r * s).ravel(), np.tile(z, k)], axis=1)

    def turned(values):
        values = np.asarray(values)
        if values.ndim == 2 and values.shape[1] == 3:   # (r, z, 0) vectors
            return np.stack([(values[:, 0] * c).ravel(), (values[:, 0] * s).ravel(),
                             np.tile(values[:, 1], k)], axis=1)
        return np.tile(values, k)
    point_data = {name: turned(v) for name, v in mesh.point_data.items()}
    block = mesh.cells[0]
    if block.type == "triangle":
        steps = segments if angle_deg < 360.0 else k
        a = np.arange(steps)[:, None, None] * n
        b = ((np.arange(steps) + 1) % k)[:, None, None] * n
        # VTK's wedge: the triangle's nodes in the order 0, 2, 1 on both
        # faces (VTK's node order; gmsh's prism, which meshio took, has the
        # other orientation)
        face = block.data[:, [0, 2, 1]]
        wedges = np.concatenate([face[None] + a, face[None] + b], axis=2).reshape(-1, 6)
        cell_data = {name: [np.tile(v[0], steps)] for name, v in mesh.cell_data.items()}
        return vtu.Mesh(points, [("wedge", wedges)], point_data=point_data, cell_data=cell_data)
    return vtu.Mesh(points, [("vertex", np.arange(len(points)).reshape(-1, 1))], point_data=point_data)


def _with_units(mesh):
    """The mesh with each array named with its unit, "pressure [Pa]" (a
    dimensionless one keeps its name): the unit travels with the array
    into ParaView, whatever reads the file."""
    def named(data):
        return {(k if _vtu_unit(k) == "-" else f"{k} [{_vtu_unit(k)}]"): v for k, v in data.items()}
    return vtu.Mesh(mesh.points, mesh.cells, point_data=named(mesh.point_data),
                          cell_data=named(mesh.cell_data))


def _put_field(group, name, values, field):
    """The dataset `name` of a snapshot group holding `values`, with the
    attribute `units` of its field (SNAPSHOT_UNITS; none for a field not
    listed there) and, for the stress, its `components`. Set on the new
    dataset at once: reopening each dataset by name afterwards cost as
    much as writing it."""
    data = write_dataset(group, name, values)
    unit = SNAPSHOT_UNITS.get(field)
    if unit is not None:
        write_attribute(data, "units", unit)
    if name == "stress":
        write_attribute(data, "components", ",".join(STRESS_COMPONENTS))


def _append_metrics(h5, kind, record, units):
    """Append one row to /metrics/<kind>/<key> of the open h5 for each key
    of `units` (a dict key -> unit): the record's value, NaN where it has
    None; each dataset carries its unit in the attribute `units`."""
    group = h5.require_group(f"metrics/{kind}")
    for key, unit in units.items():
        if key not in group:
            group.create_dataset(key, shape=(0,), maxshape=(None,), dtype="f8", chunks=(256,))
            group[key].attrs["units"] = unit
        value = record.get(key)
        append_rows(group, key, None, [np.nan if value is None else value])


def write_summary(outdir, summary):
    _atomic_write_text(Path(outdir) / "summary.json", json.dumps(summary, indent=2) + "\n")
