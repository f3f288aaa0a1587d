"""The output folder and its files under misuse and faults: a folder that is
a file or cannot be written, a second run into a folder in use, reading
fsph.h5 while the run writes it, a killed run, a full disk."""

import errno
import json
import os
import re
import resource
import signal
import socket
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest

from conftest import rod_deck
from test_cli_errors import fsph_cli

#: a deck of about 20 s on one thread (it is killed long before), and the
#: same rod for 60 us (about a second)
LONG_DECK = rod_deck(control="end_time = 2.0e-3", body="n_radial = 6\n n_axial = 24",
                     output="n_snapshots = 1000")
SHORT_DECK = rod_deck(control="end_time = 60.0e-6", body="n_radial = 6\n n_axial = 24",
                      output="n_snapshots = 40")


def one_line_error(res, code, *fragments):
    """res ended with `code`, no traceback and one stderr line holding every fragment."""
    assert res.returncode == code, res.stdout + res.stderr
    assert "Traceback" not in res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    return lines[0]


def complete_snapshots(path):
    """Times [s] of the complete snapshots of fsph.h5, read as a user reads it."""
    with h5py.File(path, "r") as h5:
        snaps = h5["snapshots"]
        return sorted(snaps[k].attrs["time"] for k in snaps if k.isdigit())


def test_output_folder_that_is_a_file(tmp_path):
    deck = tmp_path / "rod.nml"
    deck.write_text(rod_deck())
    (tmp_path / "taken").write_text("not a folder")
    res = fsph_cli(["run", str(deck), "-o", str(tmp_path / "taken")], tmp_path)
    one_line_error(res, 2, "taken", "expected an output folder, got a file")
    res = fsph_cli(["run", str(deck), "-o", str(tmp_path / "taken" / "out")], tmp_path)
    one_line_error(res, 2, "cannot create the output folder")


def _can_create_in(folder):
    probe = os.path.join(folder, "fsph-probe")
    try:
        os.close(os.open(probe, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
    except OSError:
        return False
    os.unlink(probe)
    return True


def test_output_folder_not_writable(tmp_path):
    """A folder without write permission (as root, which ignores it, a
    read-only system folder) is refused before the run, exit 2."""
    deck = tmp_path / "rod.nml"
    deck.write_text(rod_deck())
    folder = tmp_path / "read_only"
    folder.mkdir()
    folder.chmod(0o555)
    if _can_create_in(folder):
        folder = "/sys/kernel"
        if not os.path.isdir(folder) or _can_create_in(folder):
            pytest.skip("no folder this user cannot write")
    res = fsph_cli(["run", str(deck), "-o", str(folder)], tmp_path)
    one_line_error(res, 2, str(folder), "expected a writable output folder")


def test_a_run_is_readable_while_it_writes_and_its_folder_is_locked(tmp_path):
    """While a run writes: a second process (this test) opens fsph.h5 with
    HDF5's default locking and reads complete snapshots; summary.json says
    'running'; a second run into the folder is refused (exit 2) even with
    HDF5's file locking off. Killed (SIGKILL), the run leaves a summary of
    its last snapshot that `fsph plot` reads, and a stale lock the next
    run takes over."""
    deck = tmp_path / "rod.nml"
    deck.write_text(LONG_DECK)
    out = tmp_path / "out"
    env = dict(os.environ, OMP_NUM_THREADS="1")
    first = subprocess.Popen([sys.executable, "-m", "fsph", "run", str(deck), "-o", str(out),
                              "-q"], cwd=tmp_path, env=env, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        times = []
        while len(times) < 3:
            assert first.poll() is None and time.monotonic() < deadline, first.stderr.read()
            time.sleep(0.2)
            try:
                times = complete_snapshots(out / "fsph.h5")
            except (OSError, KeyError):
                # during a write (the writer holds HDF5's lock: OSError), or
                # between the file's creation and its first snapshot
                times = []
        summary = json.loads((out / "summary.json").read_text())
        assert summary["status"] == "running" and summary["metrics_time_s"] > 0
        second = subprocess.run([sys.executable, "-m", "fsph", "run", str(deck), "-o", str(out)],
                                cwd=tmp_path, capture_output=True, text=True, timeout=120,
                                env=dict(env, HDF5_USE_FILE_LOCKING="FALSE"))
        one_line_error(second, 2, "output folder in use by another run", f"pid {first.pid}")
        assert first.poll() is None, "the run ended before the test could watch it"
    finally:
        first.send_signal(signal.SIGKILL)
        first.wait()
    assert (out / "fsph.lock").is_file()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "running"
    assert summary["metrics_time_s"] in complete_snapshots(out / "fsph.h5")
    plot = fsph_cli(["plot", str(out), "--times", "0,1"], tmp_path)
    assert plot.returncode == 0, plot.stderr
    deck.write_text(rod_deck())
    again = fsph_cli(["run", str(deck), "-o", str(out)], tmp_path)
    assert again.returncode == 0, again.stderr
    assert f"took over the lock of a run that is gone (pid {first.pid})" in again.stdout
    assert not (out / "fsph.lock").exists()
    assert json.loads((out / "summary.json").read_text())["status"] == "completed"


_HOLD_OPEN = """
import sys, time, h5py
with h5py.File(sys.argv[1], "r") as h5:
    print("open", flush=True)
    time.sleep(float(sys.argv[2]))
"""


def _reader_holding(path, seconds):
    """A process that holds `path` open with HDF5's default (shared) lock
    for `seconds`; returned once it has the file open."""
    reader = subprocess.Popen([sys.executable, "-c", _HOLD_OPEN, str(path), str(seconds)],
                              stdout=subprocess.PIPE, text=True)
    assert reader.stdout.readline().strip() == "open"
    return reader


@pytest.mark.parametrize("hold_s, wait_s, warned", [(0.5, 20.0, False), (5.0, 0.5, True)])
def test_a_write_waits_for_a_reader_then_goes_on(tmp_path, monkeypatch, hold_s, wait_s, warned):
    """A write of fsph.h5 takes HDF5's exclusive lock, so a reader never
    sees a half-written file: it waits for a reader that holds the file
    open, up to LOCK_WAIT_S, then writes without the lock and says so."""
    from fsph import output
    monkeypatch.setattr(output, "LOCK_WAIT_S", wait_s)
    writer = output.RunWriter(tmp_path, "&control /", "t", vtu=False)
    row = [[0.0] * len(output.HISTORY_FIELDS)]
    reader = _reader_holding(tmp_path / "fsph.h5", hold_s)
    start = time.monotonic()
    writer.append_history(np.array(row))
    writer.flush()
    waited = time.monotonic() - start
    reader.wait()
    assert bool(writer.lock_warning) == warned, writer.lock_warning
    assert waited >= (wait_s if warned else 0.8 * hold_s) - 0.1
    with h5py.File(tmp_path / "fsph.h5", "r") as h5:
        assert h5["history/time"].shape == (1,)


def test_lock_of_another_host_is_not_taken_over(tmp_path):
    """A lock whose process cannot be checked (another host) keeps the run out."""
    deck = tmp_path / "rod.nml"
    deck.write_text(rod_deck())
    out = tmp_path / "out"
    out.mkdir()
    (out / "fsph.lock").write_text(f"12345 not-{socket.gethostname()}\n")
    res = fsph_cli(["run", str(deck), "-o", str(out)], tmp_path)
    one_line_error(res, 2, "in use by another run (pid 12345", "remove fsph.lock")


def test_a_run_replaces_the_series_of_an_earlier_run_and_leaves_other_files(tmp_path):
    """A run into a folder used before: the earlier run's .vtu files (more
    snapshots than this run has, a revolved series), its .pvd files, its
    checkpoint and the pictures fsph plot drew of it go, so the folder and
    fsph.pvd show this run alone; files fsph does not name so (a user's
    notes, a .vtu or a picture of another name) stay. A run without vtu
    and without checkpoints removes the earlier series and checkpoint too,
    and vtu/ once it is empty."""
    deck = tmp_path / "rod.nml"
    deck.write_text(rod_deck())
    out = tmp_path / "out"
    (out / "vtu").mkdir(parents=True)
    stale = ["vtu/elements_00042.vtu", "vtu/particles_00007.vtu", "vtu/elements_3d_00003.vtu",
             "vtu/particles_3d_123456.vtu", "fsph_3d.pvd", "fsph.pvd", "checkpoint.h5",
             "shapes.png", "history.png", "field_eps_p.png", "damage.png"]
    users = ["vtu/elements_final.vtu", "vtu/my_cut.vtu", "vtu/elements_00001.vtu.bak",
             "notes.txt", "elements_00001.vtu", "my_shapes.png", "shapes.png.bak",
             "vtu/history.png"]
    for name in stale + users:
        (out / name).write_text("an earlier run's or a user's file")
    res = fsph_cli(["run", str(deck), "-o", str(out)], tmp_path)
    assert res.returncode == 0, res.stderr
    assert (f"removed 11 files an earlier run left in {out} (its ParaView series, checkpoint "
            "and pictures)") in res.stdout
    for name in users:
        assert (out / name).read_text() == "an earlier run's or a user's file", name
    assert not any((out / name).exists() for name in ("fsph_3d.pvd", "shapes.png", "history.png",
                                                      "field_eps_p.png", "damage.png"))
    with h5py.File(out / "checkpoint.h5") as h5:          # this run's own
        assert len(h5.keys()) > 0
    listed = sorted(re.findall(r'file="([^"]+)"', (out / "fsph.pvd").read_text()))
    fsph_files = sorted(f"vtu/{p.name}" for p in (out / "vtu").iterdir()
                        if p.name not in {n.split("/")[1] for n in users if "/" in n})
    assert listed == fsph_files == ["vtu/elements_00000.vtu", "vtu/elements_00001.vtu",
                                    "vtu/elements_00002.vtu"]
    # no series at all: the earlier one goes, vtu/ too once nothing else is in it
    for name in users:
        (out / name).unlink()
    (out / "shapes.png").write_text("a picture of the run before")
    deck.write_text(rod_deck(output="vtu = .false.\n checkpoint = .false."))
    res = fsph_cli(["run", str(deck), "-o", str(out)], tmp_path)
    assert res.returncode == 0, res.stderr
    assert not (out / "vtu").exists() and not (out / "fsph.pvd").exists()
    assert not (out / "checkpoint.h5").exists() and not (out / "shapes.png").exists()
    assert (out / "fsph.h5").is_file() and (out / "summary.json").is_file()


def _limit_file_size(limit):
    """preexec_fn: the child may write no file larger than `limit` bytes
    (ulimit -f; Python ignores SIGXFSZ, so a write beyond fails with EFBIG)."""
    def apply():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return apply


def test_full_disk_stops_before_the_snapshot_that_would_not_fit(tmp_path):
    """Under a file size limit of half what the run writes into fsph.h5,
    the run stops with exit 3 and one line before the snapshot that would
    not fit; every snapshot written before stays complete and readable,
    and summary.json says where and why."""
    deck = tmp_path / "rod.nml"
    deck.write_text(SHORT_DECK)
    whole = fsph_cli(["run", str(deck), "-o", str(tmp_path / "whole"), "-q"], tmp_path)
    assert whole.returncode == 0, whole.stderr
    full_size = (tmp_path / "whole" / "fsph.h5").stat().st_size
    out = tmp_path / "out"
    res = subprocess.run([sys.executable, "-m", "fsph", "run", str(deck), "-o", str(out)],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300,
                         env=dict(os.environ, OMP_NUM_THREADS="1"),
                         preexec_fn=_limit_file_size(full_size // 2))
    assert res.returncode == 3, res.stdout + res.stderr
    assert "Traceback" not in res.stdout + res.stderr
    assert "no room for the snapshot" in res.stdout and "file size limit" in res.stdout
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "failed"
    assert summary["failure"]["message"].startswith("run stopped at t = ")
    times = complete_snapshots(out / "fsph.h5")
    assert 3 <= len(times) < 40
    assert summary["metrics_time_s"] == times[-1]
    assert f"last good snapshot t = {times[-1] * 1e6:.4g} us" in res.stdout
    assert not (out / "fsph.lock").exists()


def test_failed_write_stops_the_run_and_keeps_what_was_written(tmp_path, monkeypatch, capsys):
    """A write that fails however much room there seemed to be (here the
    third .vtu file, ENOSPC) stops the run: exit 3, the failure named on
    one line, the snapshots written before complete."""
    from fsph import cli, layouts, vtu
    calls = {"n": 0}
    real_write = vtu.write

    def write(path, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 3:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        return real_write(path, *args, **kwargs)

    monkeypatch.setattr(vtu, "write", write)   # fsph.output writes through the module
    deck = tmp_path / "rod.nml"
    deck.write_text(rod_deck(output="n_snapshots = 4"))
    out = tmp_path / "out"
    assert cli.main(["run", str(deck), "-o", str(out)]) == 3
    stdout = capsys.readouterr().out
    assert "Traceback" not in stdout
    failure = [line for line in stdout.splitlines() if line.startswith("fsph: run failed:")]
    assert len(failure) == 1 and "No space left on device" in failure[0]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["failure"]["code"] == layouts.status_code("output")
    times = complete_snapshots(out / "fsph.h5")
    assert len(times) == 3          # the third's vtu failed after its fsph.h5 group
    assert summary["metrics_time_s"] == times[1]


def test_low_level_writes_make_what_the_high_level_interface_makes(tmp_path):
    """fsph.hdf5_writes (the snapshot, history and checkpoint writers)
    against h5py's high-level interface: every dataset and attribute the
    same type, shape, layout and values, rows appended the same way."""
    from fsph.hdf5_writes import append_rows, write_attribute, write_dataset
    arrays = {"x": np.arange(12.0).reshape(3, 4), "flags": np.array([True, False, True]),
              "conn": np.arange(6, dtype=np.int32).reshape(2, 3), "ids": np.arange(4, dtype=np.int64)[::-1],
              "empty": np.zeros(0), "nodes/x": np.ones((2, 5)), "transposed": np.arange(6.0).reshape(2, 3).T,
              "scalar": np.float64(2.5)}
    attributes = {"units": "m/s", "time": 1.5e-6, "cycle": 42, "counts": np.array([3, 4, 5]),
                  "names": ["rod", "anvil"]}
    rows = [np.array([1.0, 2.0]), np.array([3.0]), np.array([4.0, 5.0, 6.0])]
    for name, low in (("high.h5", False), ("low.h5", True)):
        with h5py.File(tmp_path / name, "w") as h5:
            group = h5.create_group("g")
            for key, values in arrays.items():
                if low:
                    data = write_dataset(group, key, values)
                else:
                    group[key] = values
                    data = group[key]
                for attr, value in attributes.items():
                    if low:
                        write_attribute(data, attr, value)
                    else:
                        group[key].attrs[attr] = value
            series = h5.create_dataset("series", shape=(0,), maxshape=(None,), dtype="f8", chunks=(4,))
            n0 = 0
            for chunk in rows:
                if low:
                    append_rows(h5, "series", None if n0 else 0, chunk)
                else:
                    series.resize((n0 + len(chunk),))
                    series[n0:] = chunk
                n0 += len(chunk)
    with h5py.File(tmp_path / "high.h5") as a, h5py.File(tmp_path / "low.h5") as b:
        for key, values in arrays.items():
            da, db = a["g"][key], b["g"][key]
            assert da.id.get_type().equal(db.id.get_type()) and da.shape == db.shape == values.shape
            assert da.id.get_create_plist().get_layout() == db.id.get_create_plist().get_layout()
            np.testing.assert_array_equal(db[...], values)
            for attr in attributes:
                assert da.attrs.get_id(attr).get_type().equal(db.attrs.get_id(attr).get_type())
                np.testing.assert_array_equal(da.attrs[attr], db.attrs[attr])
        assert type(b["g/x"].attrs["units"]) is str
        np.testing.assert_array_equal(b["series"][...], [1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
        np.testing.assert_array_equal(a["series"][...], b["series"][...])


@pytest.mark.parametrize("end_time", [1.0e-6, 30.0e-9, 1.0e-15])
def test_outputs_do_not_alter_the_run_and_it_ends_on_its_end_time(tmp_path, end_time):
    """Progress lines and snapshots every few cycles (or more often than
    the step) leave the run as it is with the default outputs: the same
    final state, at end_time exactly, the last snapshot there and the
    metrics of it. (A step that stopped for an output used to run past
    end_time: the elastic bar at 0.5 us with n_progress = 1000 ended at
    0.5058 us with only its t = 0 snapshot, and its metrics of t = 0.)"""
    from fsph.driver import run
    summaries, times = [], []
    for name, outputs in (("default", ""), ("dense", "n_progress = 1000\n n_snapshots = 500")):
        deck = tmp_path / f"{name}.nml"
        deck.write_text(rod_deck(control=f"end_time = {end_time!r}", output=outputs + "\n vtu = .false."))
        summaries.append(run(deck, tmp_path / name, quiet=True))
        with h5py.File(tmp_path / name / "fsph.h5", "r") as h5:
            snaps = h5["snapshots"]
            times.append([snaps[k].attrs["time"] for k in sorted(snaps)])
    for summary, snap_times in zip(summaries, times):
        assert summary["status"] == "completed"
        assert summary["metrics_time_s"] == end_time
        assert snap_times[-1] == end_time and snap_times[0] == 0.0
        assert np.all(np.diff(snap_times) > 0.0)          # no two snapshots of one cycle
    assert summaries[0]["state_digest"] == summaries[1]["state_digest"]
