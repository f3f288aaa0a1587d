"""Parameter sweeps on a Dask LocalCluster: range expansion, --set errors,
variant decks, failures isolated, resume, the table against runs one by
one, and the Recht-Ipson fit of a velocity sweep."""

import contextlib
import io
import json
import shutil

import h5py
import numpy as np
import pandas as pd
import pytest

import fsph
from conftest import rod_deck
from fsph import deck as deck_module
from fsph.ballistics import fit_recht_ipson
from fsph.cli import EXIT_DECK, EXIT_RUN_FAILED, main
from fsph.driver import run
from fsph.sweep import expand_values, experiment_points, plan, run_variant, summary_row

#: Columns that differ between two runs of the same deck (process, threads).
UNSTABLE = ("wall_time_s", "threads", "reused", "variant", "folder", "status", "error")


# ------------------------------------------------------------ ranges
def test_linear_log_and_list_ranges():
    assert expand_values("300:1100:9") == tuple(float(v) for v in range(300, 1101, 100))
    assert expand_values("-300:-500:3") == (-300.0, -400.0, -500.0)
    log = expand_values("log:1e-6:1e-4:3")
    assert log[0] == 1e-6 and log[2] == 1e-4 and log[1] == pytest.approx(1e-5, rel=1e-12)
    assert expand_values("log:50:400:4", "int") == (50, 100, 200, 400)
    assert expand_values("8:32:4", "int") == (8, 16, 24, 32)
    assert expand_values("1.2e9, 1.4e9") == (1.2e9, 1.4e9)
    assert expand_values("5e-6") == (5e-6,)
    assert expand_values("min_angle,plastic_strain", "str") == ("min_angle", "plastic_strain")
    assert expand_values(".true.,.false.", "bool") == (True, False)


@pytest.mark.parametrize("text, kind, expected", [
    ("1:2", "float", "a:b:n with three fields"),
    ("1:2:1", "float", "n >= 2"),
    ("log:-1:2:3", "float", "of one sign"),
    ("2:5:3", "int", "not whole"),
    ("a,b", "float", "a real number in place of 'a'"),
    ("1,1", "float", "distinct"),
    ("1:2:1000000000", "float", r"n <= 10000 values in a range"),
    ("1,,2", "float", "without empty items"),
    ("yes", "bool", ".true. or .false."),
    ("1", "float2", "cannot be swept"),
])
def test_bad_ranges_say_what_was_expected(text, kind, expected):
    with pytest.raises(ValueError, match=expected):
        expand_values(text, kind)


# ------------------------------------------------------------ --set errors
@pytest.mark.parametrize("setting, expected", [
    ("body.velocity=1:2:3", "&body key 'velocity': expected one of the keys of &body: "),
    ("bodyy.velocity_z=1", "&bodyy: expected one of the groups"),
    ("body.velocity_z", "expected --set GROUP.KEY=VALUES"),
    ("body.velocity_z=1:2", "&body #1 key 'velocity_z': expected values for --set: a:b:n"),
    ("body.n_radial=2:5:3", "&body #1 key 'n_radial': expected values for --set: integers"),
    ("body(2).velocity_z=1", "&body key 'velocity_z': expected an instance from 1 to 1"),
    ("body(bar).velocity_z=1", "&body key 'velocity_z': expected the name of a &body: rod"),
])
def test_bad_set_is_a_deck_error_naming_file_group_and_key(write_deck, tmp_path, capsys,
                                                            setting, expected):
    deck = write_deck(rod_deck())
    code = main(["sweep", str(deck), "--set", setting, "-o", str(tmp_path / "sweep")])
    err = capsys.readouterr().err
    assert code == EXIT_DECK
    assert err.startswith(f"fsph: error: {deck}: ") and expected in err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "sweep").exists()       # nothing written or run
    if setting.startswith("body.velocity="):
        assert "(did you mean 'velocity_z'?)" in err


def test_repeated_group_needs_an_instance(tmp_path):
    deck = tmp_path / "two.nml"
    deck.write_text(_two_body_deck())
    with pytest.raises(fsph.DeckError, match=r"an instance of the 2 &body groups: "
                                             r"body\(1\).velocity_z to body\(2\).velocity_z"):
        plan(deck, ["body.velocity_z=-1,-2"], tmp_path / "out")


def test_variant_decks_set_the_chosen_instance_and_keep_references(tmp_path):
    """body(rod) and material(2) address the named body and the
    second material; the reference path of the base deck still resolves
    from the variant folder; a variant with an inadmissible value is marked
    invalid with the validator's message, the others are valid decks."""
    deck = tmp_path / "case" / "two.nml"
    deck.parent.mkdir()
    deck.write_text(_two_body_deck(reference=True))
    (deck.parent / "ref.json").write_text(json.dumps(
        {"conditions": {"material(2).density": 2700.0},     # the target, whatever the velocity
         "ballistic": {"striking_velocity_m_s": [650.0, 550.0],
                       "residual_velocity_m_s": [520.0, 400.0]},
         "perforation": {"residual_velocity_m_s": 480.0}}))
    params, variants = plan(deck, {"body(rod).velocity_z": "-500:-700:3",
                                   "material(2).density": [2700.0, 2.0e7]}, tmp_path / "out")
    assert [p.column for p in params] == ["body(1).velocity_z", "material(2).density"]
    assert len(variants) == 6
    for v in variants:
        if v.values["material(2).density"] > 1e6:
            assert v.status == "invalid" and "&material #2 key 'density'" in v.error
            continue
        assert v.status is None
        d = deck_module.load(v.deck_path)
        assert d["body"][0]["velocity_z"] == v.values["body(1).velocity_z"]
        assert d["body"][1]["velocity_z"] == 0.0
        assert d["material"][1]["density"] == 2700.0
        assert d["output"]["reference"] == str(deck.parent / "ref.json")
    assert variants[0].folder.name == "v000_velocity_z=-500_density=2700"
    assert experiment_points(deck) == [(50.0, 480.0), (550.0, 400.0), (650.0, 520.0)]


def test_a_reference_without_conditions_leaves_changed_variants(tmp_path):
    """A reference that lists no conditions does not say it applies to a
    changed deck: the variants that change a key lose it (and say so),
    the one at the base deck's values keeps it."""
    deck = tmp_path / "case" / "two.nml"
    deck.parent.mkdir()
    deck.write_text(_two_body_deck(reference=True))
    (deck.parent / "ref.json").write_text(json.dumps({"perforation": {"residual_velocity_m_s": 480.0}}))
    base = deck_module.load(deck)["body"][0]["velocity_z"]
    _, variants = plan(deck, {"body(rod).velocity_z": [base, base - 100.0]}, tmp_path / "out")
    kept, dropped = (deck_module.load(v.deck_path)["output"]["reference"] for v in variants)
    assert kept == str(deck.parent / "ref.json") and dropped is None
    assert "! reference left out" in variants[1].deck_text
    assert "! reference left out" not in variants[0].deck_text


# ------------------------------------------------------------ on a cluster
SETS = ["body.velocity_z=-40,-60,-2e5", "control.energy_error_limit=0.5,0.001"]


@pytest.fixture(scope="module")
def rod_sweep(tmp_path_factory):
    """`fsph sweep` of the small elastic rod: 3 velocities (one beyond the
    plausible magnitude: invalid) x 2 energy-error limits (0.001 stops the
    run: its error reaches 0.2 % by 0.8 us; 1.4 % with the internal
    energy of the step's end, whose first-order error this coarse rod
    shows most) on a LocalCluster of 2 workers."""
    root = tmp_path_factory.mktemp("rod_sweep")
    deck = root / "rod.nml"
    deck.write_text(rod_deck(metrics="kind = 'taylor'"))
    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        code = main(["sweep", str(deck), *sum((["--set", s] for s in SETS), []),
                     "-o", str(root / "out"), "--workers", "2"])
    return {"deck": deck, "out": root / "out", "code": code, "log": text.getvalue(),
            "table": pd.read_csv(root / "out" / "sweep.csv", keep_default_na=False,
                                 na_values=[""])}


def test_failures_are_reported_and_the_others_finish(rod_sweep):
    t, log = rod_sweep["table"], rod_sweep["log"]
    assert rod_sweep["code"] == EXIT_RUN_FAILED
    assert len(t) == 6
    status = dict(zip(zip(t["body.velocity_z"], t["control.energy_error_limit"]), t["status"]))
    assert status == {(-40.0, 0.5): "completed", (-60.0, 0.5): "completed",
                      (-40.0, 0.001): "failed", (-60.0, 0.001): "failed",
                      (-2e5, 0.5): "invalid", (-2e5, 0.001): "invalid"}
    failed = t[t["status"] == "failed"]
    assert failed["error"].str.contains("energy error above the limit").all()
    assert t[t["status"] == "invalid"]["error"].str.contains(
        "key 'velocity_z': expected a value of plausible magnitude").all()
    assert t[t["status"] == "completed"]["error"].isna().all()
    assert t[t["status"] == "completed"]["taylor.L_mm"].between(3.9, 4.0).all()
    # runs: one progress line each; the summary line names what did not complete
    assert log.count("] v0") == 4
    last = log.strip().splitlines()[-1]
    assert last.startswith("fsph sweep: 2 of 6 completed: not completed ")
    assert all(name in last for name in t[t["status"] != "completed"]["folder"])
    # every variant ran in its own folder with its own deck and summary
    for row in t.itertuples():
        folder = rod_sweep["out"] / row.folder
        assert (folder / "deck.nml").is_file()
        assert (folder / "summary.json").is_file() == (row.status != "invalid")


def test_table_is_what_the_variants_give_run_one_by_one(rod_sweep, tmp_path):
    """Each completed and failed variant deck run in this process with
    fsph.driver.run gives the row of sweep.h5 and sweep.csv, value for
    value; the runs had the sweep's one OpenMP thread."""
    out = rod_sweep["out"]
    with h5py.File(out / "sweep.h5") as h5:
        columns = list(h5["table"].attrs["columns"])
        h5_table = {c: h5["table"][c][()] for c in columns}
        meta = json.loads(h5.attrs["sweep"])
    assert columns == list(rod_sweep["table"].columns)
    assert meta["counts"] == {"completed": 2, "failed": 2, "invalid": 2}
    ran = 0
    for i, row in rod_sweep["table"].iterrows():
        if row["status"] == "invalid":
            continue
        assert row["threads"] == 1
        summary = run(out / row["folder"] / "deck.nml", tmp_path / row["folder"], quiet=True)
        assert summary["status"] == row["status"]
        for key, value in summary_row(summary).items():
            if key in UNSTABLE:
                continue
            assert h5_table[key][i] == value, key
            assert row[key] == pytest.approx(value, rel=1e-15), key     # through text
        ran += 1
    assert ran == 4


def test_rerun_skips_completed_variants_and_reruns_changed_decks(rod_sweep, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(rod_sweep["out"], out)
    done = rod_sweep["table"][rod_sweep["table"]["status"] == "completed"]["folder"]
    failed = rod_sweep["table"][rod_sweep["table"]["status"] == "failed"]["folder"]
    mtimes = {f: (out / f / "summary.json").stat().st_mtime_ns for f in (*done, *failed)}
    table = fsph.sweep(rod_sweep["deck"], SETS, out, workers=2, quiet=True)
    reused = dict(zip(table["folder"], table["reused"]))
    for f in done:
        assert reused[f] and (out / f / "summary.json").stat().st_mtime_ns == mtimes[f]
    for f in failed:            # not completed: run again
        assert not reused[f] and (out / f / "summary.json").stat().st_mtime_ns > mtimes[f]
    first = rod_sweep["table"].set_index("folder")
    again = table.set_index("folder")
    for f in done:
        assert again.loc[f, "taylor.L_mm"] == first.loc[f, "taylor.L_mm"]
        assert again.loc[f, "wall_time_s"] == first.loc[f, "wall_time_s"]
    # a changed base deck changes every variant's deck hash: all run again
    deck = tmp_path / "rod.nml"
    deck.write_text(rod_deck(metrics="kind = 'taylor'").replace("'test rod'", "'rod 2'"))
    table = fsph.sweep(deck, ["body.velocity_z=-40,-60"], out, workers=2, quiet=True)
    assert not table["reused"].any() and (table["status"] == "completed").all()


def test_velocity_sweep_of_perforation_runs_fits_recht_ipson(tmp_path, monkeypatch):
    """Three striking velocities of a small rod into a thin plate (2 us,
    so the 'residual' velocity is the projectile's at 2 us: plumbing, not
    physics): the fit in the table's attrs and sweep.json is the fit of
    the table's columns, with finite standard errors; sweep.png drawn with
    the reference's measurements."""
    deck = tmp_path / "case" / "two.nml"
    deck.parent.mkdir()
    deck.write_text(_two_body_deck(reference=True))
    (deck.parent / "ref.json").write_text(json.dumps(
        {"ballistic": {"striking_velocity_m_s": [550.0, 650.0],
                       "residual_velocity_m_s": [400.0, 520.0]}}))
    out = tmp_path / "out"
    monkeypatch.chdir(tmp_path)         # relative deck and output paths
    table = fsph.sweep("case/two.nml", {"body(rod).velocity_z": "-500:-700:3",
                                        "control.end_time": "2e-6"}, "out", workers=2,
                       quiet=True)
    assert (table["status"] == "completed").all()
    v_s = table["perforation.striking_velocity_m_s"].to_numpy()
    assert v_s == pytest.approx([500.0, 600.0, 700.0])
    (fit,) = table.attrs["recht_ipson"]
    expected = fit_recht_ipson(v_s, table["perforation.residual_velocity_m_s"], a=None, p=2.0)
    assert fit["v_bl"] == expected["v_bl"] and fit["a"] == expected["a"]
    assert np.isfinite(fit["v_bl_err"]) and np.isfinite(fit["a_err"]) and fit["p_err"] is None
    assert json.loads((out / "sweep.json").read_text())["recht_ipson"][0]["v_bl"] == fit["v_bl"]
    assert (out / "sweep.png").stat().st_size > 10_000


def test_sweep_png_marks_the_failed_runs_on_the_axis(tmp_path, monkeypatch):
    """A velocity sweep whose runs at 600 and 800 m/s failed and crashed:
    sweep.png draws them as red crosses at v_r = 0 with their count in the
    legend, the completed runs as before; the invalid and interrupted
    variants (no run of their own to an end) are not drawn, and sweep.json
    lists every variant that did not complete."""
    import fsph.plot
    from fsph.sweep import write_outputs
    deck = tmp_path / "two.nml"
    deck.write_text(_two_body_deck())
    params, variants = plan(deck, ["body(rod).velocity_z=-500:-1000:6"], tmp_path / "out")
    status = ["completed", "failed", "completed", "crashed", "invalid", "interrupted"]
    v_s = np.array([abs(v.values["body(1).velocity_z"]) for v in variants])
    done = np.array([s == "completed" for s in status])
    frame = pd.DataFrame({"variant": range(6), "folder": [v.name for v in variants],
                          "body(1).velocity_z": -v_s, "status": status,
                          "error": ["" if s == "completed" else s for s in status],
                          "perforation.striking_velocity_m_s": np.where(done, v_s, np.nan),
                          "perforation.residual_velocity_m_s": np.where(done, 0.8 * v_s, np.nan)})
    figures = {}

    def keep(fig, output, dpi, **kwargs):
        figures[output.name] = fig
    monkeypatch.setattr(fsph.plot, "_save", keep)
    write_outputs(tmp_path / "out", deck, params, frame)
    ax = figures["sweep.png"].axes[0]
    lines = {line.get_label(): line for line in ax.get_lines()}
    crosses = lines["failed run (2)"]
    assert list(crosses.get_xdata()) == [600.0, 800.0] and list(crosses.get_ydata()) == [0, 0]
    assert crosses.get_marker() == "x" and crosses.get_color() == "red"
    assert list(lines["fsph"].get_xdata()) == [500.0, 700.0]
    assert "failed run (2)" in [t.get_text() for t in ax.get_legend().get_texts()]
    failed = json.loads((tmp_path / "out" / "sweep.json").read_text())["failed"]
    assert sorted(failed) == sorted(v.name for v, s in zip(variants, status) if s != "completed")


def test_a_crashing_run_is_recorded_not_raised(tmp_path, monkeypatch):
    """A child process killed by a signal (as a segmentation fault in the
    solver would) gives status 'crashed' with the signal, in the result and
    in variant.json, instead of an exception in the Dask task."""
    fake = tmp_path / "python"
    fake.write_text("#!/bin/sh\necho 'about to crash' >&2\nkill -SEGV $$\n")
    fake.chmod(0o755)
    monkeypatch.setattr("sys.executable", str(fake))
    record = run_variant(tmp_path / "deck.nml", tmp_path, 1, "abc")
    assert record["status"] == "crashed" and record["summary"] is None
    assert record["error"] == "killed by signal 11: about to crash"
    assert json.loads((tmp_path / "variant.json").read_text())["status"] == "crashed"


#: A 1 mm aluminium plate under the rod of conftest.rod_deck.
PLATE = ("&material\n name = 'al'\n library = 'al_6061_t651'\n/\n"
         "&body\n name = 'plate'\n material = 'al'\n geometry = 'plate'\n radius = 4.0e-3\n"
         " fine_radius = 4.0e-3\n length = 1.0e-3\n z_base = -1.0e-3\n n_radial = 12\n"
         " n_axial = 3\n/\n")


def _two_body_deck(reference=False):
    """The 3 x 12 rod of conftest (4340 steel, 50 m/s) onto a 1 mm
    aluminium plate, FEM, perforation metrics: 336 elements."""
    return rod_deck(control="mode = 'fem'",
                    material="name = 'steel'\n library = 'steel_4340_epp'",
                    body="z_base = 0.05e-3", boundary=False,
                    output="vtu = .false.\n" + ("reference = 'ref.json'" if reference else ""),
                    metrics="kind = 'perforation'\n body = 'rod'\n target = 'plate'") + PLATE


def test_fit_label_keeps_the_first_significant_digit_of_the_error():
    """A ballistic limit known to 0.13 m/s prints as 265.3 ± 0.1, not
    265 ± 0; one known to 6 m/s keeps whole metres per second."""
    from fsph.sweep import _fit_label
    fit = {"group": {}, "v_bl": 265.259, "v_bl_err": 0.133, "a": 0.98812, "a_err": 0.00123,
           "p": 2.0, "p_err": None}
    assert _fit_label(fit) == "v_bl = 265.3 ± 0.1 m/s, a = 0.988 ± 0.001, p = 2"
    fit.update(v_bl_err=6.2, a_err=0.029)
    assert _fit_label(fit) == "v_bl = 265 ± 6 m/s, a = 0.988 ± 0.029, p = 2"


def test_unreachable_scheduler_is_a_one_line_error(tmp_path):
    """--scheduler at an address nothing listens on: exit 2 after the
    connection timeout, one line naming the address."""
    import subprocess
    import sys
    deck = tmp_path / "rod.nml"
    deck.write_text(rod_deck())
    res = subprocess.run([sys.executable, "-m", "fsph", "sweep", str(deck), "--set",
                          "body.velocity_z=-40,-50", "--scheduler", "tcp://127.0.0.1:9", "-o",
                          str(tmp_path / "sweep")], capture_output=True, text=True,
                         cwd=tmp_path, timeout=300)
    assert res.returncode == EXIT_DECK, res.stderr
    lines = res.stderr.strip().splitlines()
    assert "Traceback" not in res.stderr and len(lines) == 1, res.stderr
    assert "--scheduler tcp://127.0.0.1:9: expected the address of a running Dask scheduler" \
        in lines[0]


def test_ctrl_c_stops_a_sweep_and_its_runs(tmp_path):
    """SIGINT to a sweep of two long runs on one worker, once the first
    has started: the run under way stops with its checkpoint, the queued
    one never starts, the sweep writes its table and exits 4 without a
    traceback; no run is left behind."""
    import os
    import signal
    import subprocess
    import sys
    import time
    deck = tmp_path / "rod.nml"
    deck.write_text(rod_deck(control="end_time = 2.0e-3", body="n_radial = 6\n n_axial = 24",
                             output="n_snapshots = 1000"))
    out = tmp_path / "sweep"
    proc = subprocess.Popen([sys.executable, "-m", "fsph", "sweep", str(deck), "--set",
                             "body.velocity_z=-40,-50", "--workers", "1", "-o", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            cwd=tmp_path, env=dict(os.environ, OMP_NUM_THREADS="1"))
    deadline = time.monotonic() + 120
    while not list(out.glob("*/summary.json")):
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.2)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=150)
    assert proc.returncode == 4, stdout + stderr
    assert "Traceback" not in stdout + stderr
    frame = pd.read_csv(out / "sweep.csv")
    assert list(frame["status"]) == ["interrupted", "interrupted"]
    first, second = sorted(p for p in out.iterdir() if p.is_dir())
    assert (first / "checkpoint.h5").is_file() and not (first / "fsph.lock").exists()
    assert json.loads((first / "summary.json").read_text())["status"] == "interrupted"
    assert not (second / "fsph.h5").exists()
    assert not (out / "sweep.stopping").exists()


# ------------------------------------------------------------ misuse, through the command line
def _sweep_cli(args, cwd):
    """`python -m fsph sweep ARGS` in cwd with one OpenMP thread."""
    import os
    import subprocess
    import sys
    return subprocess.run([sys.executable, "-m", "fsph", "sweep", *args], capture_output=True,
                          text=True, cwd=cwd, env=dict(os.environ, OMP_NUM_THREADS="1"),
                          timeout=300)


def _one_line_error(res, *expected):
    """res ended with exit 2 and one stderr line holding each of expected,
    no traceback."""
    assert res.returncode == EXIT_DECK, res.stdout + res.stderr
    lines = res.stderr.strip().splitlines()
    assert "Traceback" not in res.stdout + res.stderr and len(lines) == 1, res.stderr
    assert lines[0].startswith("fsph: error: ")
    for text in expected:
        assert text in lines[0], lines[0]


@pytest.mark.parametrize("output", ["afile", "afile/x"])
def test_output_that_is_a_file_is_a_one_line_error(tmp_path, output):
    """-o naming a file, or a folder under a file: exit 2, one line naming
    the file, nothing written."""
    deck = tmp_path / "rod.nml"
    deck.write_text(rod_deck())
    (tmp_path / "afile").write_text("not a folder\n")
    res = _sweep_cli([str(deck), "--set", "control.end_time=1e-7,2e-7", "-o", output], tmp_path)
    _one_line_error(res, f"{tmp_path / 'afile'}: expected a folder for the sweep's outputs",
                    "got a file of that name")
    assert (tmp_path / "afile").read_text() == "not a folder\n"


@pytest.mark.parametrize("args, expected", [
    (["--set", "control.end_time=1e-7:2e-7:1000000000"],
     "&control key 'end_time': expected values for --set: n <= 10000 values in a range"),
    (["--set", "control.end_time=1e-7:2e-7:200", "--set", "body.velocity_z=-10:-60:51"],
     "expected at most 10000 variants in a sweep (--max-variants raises the limit), "
     "got '200 (control.end_time) x 51 (body.velocity_z) = 10200 variants'"),
    (["--set", "control.end_time=1e-7,2e-7,3e-7", "--max-variants", "2"],
     "expected at most 2 variants in a sweep"),
])
def test_too_many_variants_are_refused_before_anything_is_written(tmp_path, args, expected):
    """A range of a billion values, or a product beyond the limit (10 000
    by default, --max-variants): exit 2 at once, one line with the count,
    no folder made (and no memory spent on the values)."""
    deck = tmp_path / "rod.nml"
    deck.write_text(rod_deck())
    res = _sweep_cli([str(deck), *args, "-o", "sweep"], tmp_path)
    _one_line_error(res, f"{deck}: ", expected)
    assert not (tmp_path / "sweep").exists()


@pytest.mark.parametrize("values", ["1e-7,,2e-7", "1e-7,2e-7,", ",1e-7"])
def test_a_list_with_an_empty_item_is_refused(tmp_path, values):
    """An empty item in a list is a mistake, not a value to drop: exit 2,
    one line naming the key and the --set's values, nothing written."""
    deck = tmp_path / "rod.nml"
    deck.write_text(rod_deck())
    res = _sweep_cli([str(deck), "--set", f"control.end_time={values}", "-o", "sweep"],
                     tmp_path)
    _one_line_error(res, f"{deck}: &control key 'end_time': expected values for --set: a list "
                         f"v1,v2,... without empty items", repr(values))
    assert not (tmp_path / "sweep").exists()


def test_a_variant_with_warnings_does_not_say_only_completed(tmp_path):
    """A variant whose run completed with an energy error beyond its
    energy_error_warning: its line says 'completed with 1 warning:
    energy_error', the warning's message is printed, the closing line
    names it, and sweep.csv, sweep.h5 and sweep.json carry the kinds
    (empty for the variant without warnings); exit 0."""
    deck = tmp_path / "rod.nml"
    deck.write_text(rod_deck(control="end_time = 0.3e-6"))
    res = _sweep_cli([str(deck), "--set", "control.energy_error_warning=1e-9,0.5", "-o",
                      "sweep"], tmp_path)
    assert res.returncode == 0 and "Traceback" not in res.stderr, res.stdout + res.stderr
    warned, clean = "v000_energy_error_warning=1e-09", "v001_energy_error_warning=0.5"
    lines = res.stdout.splitlines()
    assert any(line.startswith(f"fsph sweep: [") and f"] {warned}: completed with 1 warning: "
               f"energy_error (" in line for line in lines), res.stdout
    assert any(f"] {clean}: completed (" in line for line in lines), res.stdout
    assert f"fsph sweep: warning: {warned}: energy error " in res.stdout
    assert lines[-1].startswith(f"fsph sweep: 2 of 2 completed; completed with warnings "
                                f"{warned} (energy_error); table in ")
    out = tmp_path / "sweep"
    t = pd.read_csv(out / "sweep.csv", keep_default_na=False)
    assert list(t.columns[t.columns.get_loc("error"):][:2]) == ["error", "warnings"]
    assert dict(zip(t["folder"], t["warnings"])) == {warned: "energy_error", clean: ""}
    with h5py.File(out / "sweep.h5") as h5:
        assert list(h5["table/warnings"].asstr()[()]) == ["energy_error", ""]
        assert json.loads(h5.attrs["sweep"])["warnings"] == {warned: "energy_error"}


def test_a_sweep_beside_another_is_quiet(tmp_path):
    """Port 8787 (the Dask dashboard's default) taken, as by a sweep
    running beside this one: the sweep prints nothing on stderr (no 'Port
    8787 is already in use' warning) and exits 0."""
    import socket
    deck = tmp_path / "rod.nml"
    deck.write_text(rod_deck(control="end_time = 0.2e-6"))
    with socket.socket() as taken:
        with contextlib.suppress(OSError):     # in use already: as good
            taken.bind(("", 8787))
            taken.listen()
        res = _sweep_cli([str(deck), "--set", "body.velocity_z=-40,-50", "-o", "sweep"],
                         tmp_path)
    assert res.returncode == 0 and res.stderr == "", res.stderr
