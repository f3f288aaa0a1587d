"""Bad decks end in one line naming file, group, key and what was expected,
with exit code 2 and no traceback; a run that goes bad exits 3 and keeps the
last good snapshot."""

import json
import os
import subprocess
import sys

import h5py
import numpy as np
import pytest

import fsph
from fsph import verify
from conftest import rod_deck


def fsph_cli(args, cwd):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    return subprocess.run([sys.executable, "-m", "fsph", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


#: the rod deck's body as a sphere of radius 1 mm, 3 cells along its radius
SPHERE = rod_deck(body="geometry = 'sphere'").replace(" length = 4.0e-3\n", "").replace(
    " n_axial = 12\n", "")

BAD_DECKS = {
    "unknown_group": (rod_deck() + "&nonsense x = 1 /\n", ["&nonsense", "unknown group"]),
    "unknown_key": (rod_deck(body="colour = 'red'"), ["&body #1", "'colour'", "unknown key"]),
    "wrong_type": (rod_deck(body="n_axial = 'many'"), ["&body #1", "'n_axial'", "an integer"]),
    "negative_density": (rod_deck(material="name='steel'\n library='steel_elastic_bar'\n density=-7850.0"),
                         ["&material #1", "'density'", "(0, inf)", "kg/m^3"]),
    "poisson_half": (rod_deck(material="name='steel'\n library='steel_elastic_bar'\n poisson_ratio=0.5"),
                     ["&material #1", "'poisson_ratio'", "[0, 0.5)"]),
    "zero_resolution": (rod_deck(body="n_radial = 0"), ["&body #1", "'n_radial'", "[1, inf)"]),
    "slash_in_name": (rod_deck().replace("name = 'rod'", "name = 'rod/tip'"),
                      ["&body #1", "'name'", "without '/'", "rod/tip"]),
    "oversized_n_radial": (rod_deck(body="n_radial = 100000"),
                           ["&body #1", "'n_radial'", "at most 4000000", "n_radial 100000 x n_axial 12"]),
    "missing_required": (rod_deck().replace(" end_time = 1.0e-6\n", ""),
                         ["&control", "'end_time'", "missing key"]),
    "unknown_material": (rod_deck(body="material = 'unobtainium'"),
                         ["&body #1", "'material'", "steel"]),
    "bad_choice": (rod_deck(material="name='steel'\n library='steel_elastic_bar'\n strength='rubber'"),
                   ["&material #1", "'strength'", "johnson_cook"]),
    "mixed_in_fem": (rod_deck(body="discretisation = 'particles'"),
                     ["&body #1", "'discretisation'", "'elements' in mode 'fem'"]),
    "join_outside_coupling": (rod_deck(body="joined_to = 'rod'"),
                              ["&body #1", "'joined_to'", "modes 'fixed' and 'adaptive'"]),
    "total_on_elements": (rod_deck(body="formulation = 'total'"),
                          ["&body #1", "'formulation'", "'updated' unless discretisation is 'particles'"]),
    "total_single_particle": (rod_deck(control="mode = 'sph'", body="formulation = 'total'")
                              .replace("n_radial = 3", "n_radial = 1").replace("n_axial = 12", "n_axial = 1"),
                              ["&body #1", "'formulation'", "neighbours in two directions",
                               "r = 0.5 mm, z = 2 mm"]),
    "total_joined": (rod_deck(control="mode = 'fixed'", body="discretisation = 'particles'\n formulation = 'total'")
                     + "&body\n name = 'cap'\n material = 'steel'\n radius = 1.0e-3\n length = 1.0e-3\n"
                       " z_base = 4.0e-3\n n_radial = 3\n n_axial = 3\n joined_to = 'rod'\n/\n",
                     ["&body #1", "'formulation'", "'updated' for a body joined to another"]),
    "total_hourglass_too_high": (rod_deck(control="mode = 'sph'", body="formulation = 'total'")
                                 + "&sph total_hourglass = 50 /\n",
                                 ["&sph", "'total_hourglass'", "[0, 10]"]),
    "artificial_stress_negative": (rod_deck(control="mode = 'sph'") + "&sph artificial_stress = -0.3 /\n",
                                   ["&sph", "'artificial_stress'", "[0, 1]"]),
    "artificial_stress_too_high": (rod_deck(control="mode = 'sph'") + "&sph artificial_stress = 3.0 /\n",
                                   ["&sph", "'artificial_stress'", "[0, 1]"]),
    "artificial_stress_not_a_number": (rod_deck(control="mode = 'sph'") + "&sph artificial_stress = 'on' /\n",
                                       ["&sph", "'artificial_stress'", "a real number", "'on'"]),
    "missing_model_constant": (rod_deck(material="name='steel'\n strength='epp'\n eos='linear'\n"
                                        " density=7850.0\n youngs_modulus=2e11\n poisson_ratio=0.3"),
                               ["&material #1", "'yield_stress'", "missing key"]),
    "hjc_strength_without_hjc_eos": (
        rod_deck(material="name='steel'\n library='concrete_48mpa_hjc'\n eos='linear'"),
        ["&material #1", "'eos'", "'hjc' together with strength 'hjc'"]),
    "hjc_lock_below_crush": (
        rod_deck(material="name='steel'\n library='concrete_48mpa_hjc'\n hjc_plock=1.0e7"),
        ["&material #1", "'hjc_plock'", "a value above hjc_pcrush"]),
    "hjc_missing_constant": (
        rod_deck(material="name='steel'\n strength='hjc'\n eos='hjc'\n density=2440.0\n"
                          " shear_modulus=1.486e10"),
        ["&material #1", "'hjc_a'", "missing key"]),
    "hjc_falling_dense_curve": (
        rod_deck(material="name='steel'\n library='concrete_48mpa_hjc'\n hjc_k2=-5.0e12"),
        ["&material #1", "'hjc_k2'", "rising to hjc_plock"]),
    "bulk_beside_e_and_nu": (rod_deck(material="name='steel'\n library='steel_elastic_bar'\n"
                                         " bulk_modulus=1.7e11"),
                             ["&material #1", "'bulk_modulus'", "youngs_modulus + poisson_ratio"]),
    "bulk_with_mie_gruneisen": (rod_deck(material="name='steel'\n library='ofhc_copper'\n"
                                             " bulk_modulus=1.3e11"),
                                ["&material #1", "'bulk_modulus'", "eos 'mie_gruneisen'", "c0^2"]),
    "erosion_outside_fem": (rod_deck(control="mode = 'adaptive'") + "&erosion\n enabled = .true.\n/\n",
                            ["&erosion", "'enabled'", "outside mode 'fem'"]),
    "erosion_zero_strain": (rod_deck() + "&erosion\n enabled = .true.\n principal_strain = 0.0\n/\n",
                            ["&erosion", "'principal_strain'", "(0, inf)"]),
    "broken_syntax": ("&control end_time = (1.0e-6, 2 /\n", ["namelist syntax"]),
    "empty_file": ("", ["namelist group"]),
    "negative_checkpoint_cycles": (rod_deck(output="checkpoint_cycles = -100"),
                                   ["&output", "'checkpoint_cycles'", "[0, inf)"]),
    "checkpoint_cycles_without_checkpoint": (
        rod_deck(output="checkpoint = .false.\n checkpoint_cycles = 100"),
        ["&output", "'checkpoint_cycles'", "when checkpoint = .false.", "100"]),
    "group_swallows_the_next": (rod_deck().replace(" velocity_z = -50.0\n \n/\n",
                                                   " velocity_z = -50.0\n \n"),
                                ["&body #1", "a '/' closing &body #1 (opened on line 11)",
                                 "&output on line 20 inside it"]),
    "group_never_closed": (rod_deck().rstrip()[:-1],
                           ["&boundary #1", "a '/' closing &boundary #1", "the end of the file"]),
    "body_across_plane": (rod_deck(body="z_base = -1.0e-3"),
                          ["&body #1", "'rod' in front of &boundary #1", "part of it behind the plane",
                           "1 mm deep"]),
    "body_behind_plane": (rod_deck(body="z_base = -9.0e-3"),
                          ["&body #1", "'rod' in front of &boundary #1", "all of it behind the plane"]),
    "probe_outside_body": (rod_deck(metrics="kind = 'bar_wave'\n probe_radius = 5.0e-3\n"
                                            " plateau_from = 1.0e-3\n plateau_to = 2.0e-3"),
                           ["&metrics", "'probe_radius'", "inside the body it samples ('rod' "
                            "spans r = 0 to 1 mm)", "'5 mm'"]),
    "bodies_overlap": (rod_deck() + "&body\n name = 'cap'\n material = 'steel'\n radius = 1.0e-3\n"
                       " length = 1.0e-3\n z_base = 3.5e-3\n n_radial = 3\n n_axial = 3\n/\n",
                       ["&body #1", "'rod' clear of &body #2 ('cap')", "of its cells inside it"]),
    "zero_normal": (rod_deck().replace("normal = 0.0, 1.0", "normal = 0.0, 0.0"),
                    ["&boundary #1", "'normal'", "non-zero"]),
    "gauge_outside_body": (rod_deck() + "&gauge\n name = 'air'\n point = 2.0e-3, 1.0e-3\n/\n",
                           ["&gauge #1", "'point'", "a point inside a body at t = 0", "[0.002, 0.001]"]),
    "gauge_name_twice": (rod_deck() + "&gauge name = 'g' point = 0.0, 1.0e-3 /\n"
                         "&gauge name = 'g' point = 0.5e-3, 1.0e-3 /\n",
                         ["&gauge #2", "'name'", "not used by another &gauge"]),
    "gauge_behind_axis": (rod_deck() + "&gauge name = 'g' point = -0.5e-3, 1.0e-3 kind = 'fixed' /\n",
                          ["&gauge #1", "'point'", "r >= 0"]),
    "sphere_with_length": (rod_deck(body="geometry = 'sphere'"),
                           ["&body #1", "'length'", "no value for geometry 'sphere'", "diameter"]),
    "sphere_with_n_axial": (SPHERE.replace(" radius = 1.0e-3\n", " radius = 1.0e-3\n n_axial = 12\n"),
                            ["&body #1", "'n_axial'", "no value for geometry 'sphere'"]),
    "sphere_of_one_cell": (SPHERE.replace(" n_radial = 3\n", " n_radial = 1\n"),
                           ["&body #1", "'n_radial'", "at least 2 for geometry 'sphere'"]),
    "tube_of_a_sphere": (SPHERE.replace(" radius = 1.0e-3\n", " radius = 1.0e-3\n inner_radius = 0.5e-3\n"),
                         ["&body #1", "'inner_radius'", "only a rod can be a tube"]),
}


@pytest.mark.parametrize("name", sorted(BAD_DECKS))
def test_bad_deck_one_line_exit_2(name, tmp_path):
    text, fragments = BAD_DECKS[name]
    deck = tmp_path / f"{name}.nml"
    deck.write_text(text)
    res = fsph_cli(["run", str(deck), "-o", str(tmp_path / "out")], tmp_path)
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert f"{name}.nml" in lines[0]
    for frag in fragments:
        assert frag in lines[0], lines[0]


def test_reliability_table_lists_every_bad_deck():
    """docs/reliability.md keeps the table of inputs tried: every case of
    the bad-deck family has its row there."""
    from pathlib import Path
    text = (Path(__file__).resolve().parents[1] / "docs" / "reliability.md").read_text()
    missing = [name for name in BAD_DECKS if f"| `{name}` |" not in text]
    assert not missing, missing


def test_missing_deck_file(tmp_path):
    res = fsph_cli(["run", str(tmp_path / "nowhere.nml")], tmp_path)
    assert res.returncode == 2
    assert "nowhere.nml" in res.stderr and "no such file" in res.stderr


def test_gmsh_mesh_in_millimetres(tmp_path):
    """A gmsh anvil drawn in millimetres read with mesh_scale = 1 is 5000
    times the rod beside it: exit 2 before the run, naming mesh_scale.
    Alone, such a body runs with a warning."""
    import meshio
    r, z = np.meshgrid(np.linspace(0.0, 20.0, 6), np.linspace(-3.0, -1.0, 3))
    points = np.column_stack([r.ravel(), z.ravel(), np.zeros(r.size)])
    quads = [(j * 6 + i, j * 6 + i + 1, (j + 1) * 6 + i + 1, (j + 1) * 6 + i)
             for j in range(2) for i in range(5)]
    triangles = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    meshio.write(tmp_path / "anvil_mm.msh", meshio.Mesh(points, [("triangle", triangles)]),
                 file_format="gmsh22", binary=False)
    anvil = ("&body\n name = 'anvil'\n material = 'steel'\n geometry = 'gmsh'\n"
             " mesh_file = 'anvil_mm.msh'\n/\n")
    deck = tmp_path / "mm.nml"
    deck.write_text(rod_deck(boundary=False) + anvil)
    res = fsph_cli(["run", str(deck), "-o", str(tmp_path / "out")], tmp_path)
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
    for fragment in ("mm.nml: &body #2 key 'mesh_scale'", "millimetres need mesh_scale = 1e-3",
                     "the mesh spans 20 m, 5000 times 'rod' (0.004 m)"):
        assert fragment in res.stderr, res.stderr
    alone = rod_deck(boundary=False)
    alone = alone[:alone.index("&body")] + anvil + alone[alone.index("&output"):]
    deck.write_text(alone.replace("end_time = 1.0e-6", "end_time = 1.0e-9"))
    res = fsph_cli(["run", str(deck), "-o", str(tmp_path / "alone")], tmp_path)
    assert res.returncode == 0, res.stderr
    assert "the gmsh mesh spans 20 m with mesh_scale = 1" in res.stdout


def test_check_prints_sizes_step_and_cost_without_running(tmp_path):
    """`fsph check`: exit 0, the counts, the first step and the cycles at
    that step of the Simulation the deck sets up, a wall-time estimate; no
    output folder."""
    import math
    deck = tmp_path / "rod.nml"
    deck.write_text(rod_deck())
    res = fsph_cli(["check", str(deck)], tmp_path)
    assert res.returncode == 0, res.stderr
    sim = fsph.Simulation.from_deck(deck)
    cycles = math.ceil(1.0e-6 / sim.dt)
    for text in ("the deck and its starting state are valid",
                 f"{sim.n_elements} elements, {sim.n_nodes} nodes, 0 particles",
                 f"first time step {sim.dt * 1e9:.4g} ns", f"at least {cycles} cycles",
                 "wall time: about"):
        assert text in res.stdout, res.stdout
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("name", ["unknown_key", "bodies_overlap", "probe_outside_body"])
def test_check_refuses_what_run_refuses(name, tmp_path):
    text, fragments = BAD_DECKS[name]
    deck = tmp_path / f"{name}.nml"
    deck.write_text(text)
    res = fsph_cli(["check", str(deck)], tmp_path)
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    assert len(res.stderr.strip().splitlines()) == 1 and res.stdout == ""
    for frag in fragments:
        assert frag in res.stderr


@pytest.mark.parametrize("command", ["run", "check"])
def test_end_time_beyond_max_cycles_is_refused(command, tmp_path):
    """An end time of 999 s would take 1e10 cycles: refused at set-up."""
    deck = tmp_path / "long.nml"
    deck.write_text(rod_deck(control="end_time = 999.0").replace("end_time = 1.0e-6\n", ""))
    res = fsph_cli([command, str(deck), *(["-o", str(tmp_path / "out")] if command == "run" else [])],
                   tmp_path)
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    assert "&control key 'end_time': expected an end time max_cycles = 50000000 cycles can reach" \
        in res.stderr


def test_deck_path_that_is_a_folder(tmp_path):
    (tmp_path / "decks").mkdir()
    res = fsph_cli(["run", str(tmp_path / "decks")], tmp_path)
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert "decks: expected a deck file, got 'a folder'" in res.stderr


def run_failing(tmp_path, deck_text, code, what):
    """Run a deck that must go bad: exit 3, no traceback, the diagnostic in
    the output, a failed summary with the status code, the failure recorded
    in the HDF5 file beside the t = 0 snapshot."""
    deck = tmp_path / "bad_run.nml"
    deck.write_text(deck_text)
    out = tmp_path / "out"
    res = fsph_cli(["run", str(deck), "-o", str(out)], tmp_path)
    assert res.returncode == 3, res.stdout + res.stderr
    assert "Traceback" not in res.stderr
    assert what in res.stdout
    assert "stopped at t =" in res.stdout
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "failed"
    assert summary["failure"]["code"] == code
    assert summary["failure"]["time_s"] > 0
    with h5py.File(out / "fsph.h5") as h5:
        assert "failure" in h5.attrs
        assert h5["snapshots"]["00000"].attrs["time"] == 0.0
    return res.stdout, summary


def test_collapsing_time_step_stops_cleanly(tmp_path):
    """A floor the shrinking impact step must cross: the diagnostic names
    the element controlling the step."""
    stdout, summary = run_failing(
        tmp_path, rod_deck(control="end_time = 3.0e-6\n dt_floor_ratio = 0.9",
                           material="name='steel'\n library='armco_iron'",
                           body="velocity_z = -400.0"),
        code=4, what="time step collapsed")
    assert "element" in stdout and "body 'rod'" in stdout
    assert summary["failure"]["index"] > 0


def test_tangled_mesh_stops_cleanly(tmp_path):
    """An unstable step (safety 1, no viscosity, elastic rod at 5 km/s)
    tangles the mesh: the diagnostic names the inverted element and where."""
    stdout, _ = run_failing(
        tmp_path, rod_deck(control="end_time = 3.0e-6\n dt_safety = 1.0\n c_q = 0.0\n c_l = 0.0",
                           body="velocity_z = -5000.0"),
        code=1, what="inverted element")
    assert "r = " in stdout and "z = " in stdout


def test_eos_range_stops_cleanly(tmp_path):
    """Mie-Grueneisen iron crushed in one oversized step: out of EOS range."""
    run_failing(
        tmp_path, rod_deck(control="end_time = 3.0e-6\n dt_safety = 1.0\n c_q = 0.0\n c_l = 0.0",
                           material="name='steel'\n library='armco_iron'",
                           body="velocity_z = -3000.0"),
        code=5, what="equation of state")


def test_collapse_in_one_cycle_stops_cleanly(tmp_path):
    """dt_drop_ratio: the impact makes the stable step fall; a ratio of 0.999
    per cycle is crossed at once."""
    run_failing(
        tmp_path, rod_deck(control="end_time = 3.0e-6\n dt_drop_ratio = 0.999",
                           material="name='steel'\n library='armco_iron'",
                           body="velocity_z = -400.0"),
        code=11, what="fell by more than the allowed factor")


def test_energy_error_limit_stops_cleanly(tmp_path):
    """energy_error_limit far below the drift of the impact run."""
    run_failing(
        tmp_path, rod_deck(control="end_time = 1.0e-6\n energy_error_limit = 1.0e-9"),
        code=12, what="energy error above the limit")


def test_progress_lines_and_quiet(tmp_path):
    """Not on a terminal: periodic plain progress lines (n_progress of them);
    --quiet: none."""
    deck = tmp_path / "deck.nml"
    deck.write_text(rod_deck(output="n_progress = 5"))
    res = fsph_cli(["run", str(deck), "-o", str(tmp_path / "a")], tmp_path)
    assert res.returncode == 0
    rows = [line for line in res.stdout.splitlines() if line.strip() and line.split()[0].isdigit()]
    assert len(rows) == 5
    quiet = fsph_cli(["run", str(deck), "-o", str(tmp_path / "b"), "--quiet"], tmp_path)
    assert quiet.returncode == 0 and quiet.stdout == ""


def run_with_fault(tmp_path, monkeypatch, capsys, deck_text, inject):
    """`fsph run` (in this process) of a deck whose state `inject(sim)`
    damages once the first snapshot after t = 0 and its checkpoint are
    written. Returns the exit code, stdout, summary, the output folder and
    the cycle, time and result of the injection."""
    from fsph import cli, driver
    deck = tmp_path / "faulty.nml"
    deck.write_text(deck_text)
    first_snapshot = driver.deck_module.load(deck)["control"]["end_time"] / 4
    done = {}

    class Faulty(driver.Simulation):
        def advance(self, t, **kwargs):
            if not done and self.time >= first_snapshot:
                done.update(cycle=self.cycle, time=self.time, result=inject(self))
            return super().advance(t, **kwargs)

    monkeypatch.setattr(driver, "Simulation", Faulty)
    out = tmp_path / "out"
    code = cli.main(["run", str(deck), "-o", str(out)])
    stdout = capsys.readouterr().out
    assert done, "the fault was never injected"
    assert first_snapshot <= done["time"] < 1.5 * first_snapshot
    summary = json.loads((out / "summary.json").read_text())
    return code, stdout, summary, out, done


def assert_last_good_kept(out, summary, done, deck):
    """The last snapshot and the checkpoint are the state the fault was
    injected into, and the run restarted from that checkpoint completes."""
    import fsph
    from fsph import checkpoint, cli
    assert summary["metrics_time_s"] == done["time"]
    with h5py.File(out / "fsph.h5") as h5:
        assert "failure" in h5.attrs
        snaps = h5["snapshots"]
        assert len(snaps) == 2              # t = 0 and the first quarter
        assert snaps[sorted(snaps)[-1]].attrs["time"] == done["time"]
    sim = fsph.Simulation.from_deck(deck)
    checkpoint.restore(sim, out / "checkpoint.h5")
    assert sim.cycle == done["cycle"] and sim.time == done["time"]
    assert cli.main(["run", str(deck), "-o", str(out.parent / "again"), "-q",
                     "--restart", str(out / "checkpoint.h5")]) == 0


def assert_clean_stop(stdout, summary, status, what, out, done, deck, clock_moved):
    """The common end of a provoked failure: exit code 3 already checked by
    the caller; the summary's status code; the cycle and time the run
    stopped at (the next cycle when the fault showed after the positions
    and the clock moved, else the state the fault was injected into); the
    one-line diagnostic `what` after them, on stdout and in the summary;
    the last good snapshot kept and restartable."""
    failure = summary["failure"]
    assert summary["status"] == "failed"
    assert failure["code"] == status
    if clock_moved:
        assert failure["cycle"] == done["cycle"] + 1 and failure["time_s"] > done["time"]
    else:
        assert failure["cycle"] == done["cycle"] and failure["time_s"] == done["time"]
    message = (f"run stopped at t = {failure['time_s'] * 1e6:.6g} us, cycle {failure['cycle']}: "
               + what)
    assert message in stdout and failure["message"].startswith(message)
    assert f"last good snapshot t = {done['time'] * 1e6:.4g} us" in stdout
    assert_last_good_kept(out, summary, done, deck)


def test_particle_on_axis_stops_cleanly(tmp_path, monkeypatch, capsys):
    """A particle put across the axis (r < 0; in a run the axis acts on
    particles as a wall at half their radius, see the next test, so only a
    corrupted state gets there, hence the hook): exit 3, the axis guard's
    diagnostic names the particle, its body, where and when; the last good
    snapshot and checkpoint are kept."""
    from fsph import cli

    def inject(sim):
        part = sim.snapshot()["particles"]
        x, v = part["x"].copy(), part["velocity"]
        inner = np.flatnonzero(x[:, 0] < 1.5 * x[:, 0].min())
        k = int(inner[len(inner) // 2])           # an inner particle half-way up
        x[k, 0] = -x[k, 0]
        verify.set_particle_motion(sim, x, v)
        return k

    text = rod_deck(control="mode = 'sph'", body="n_radial = 4\n n_axial = 16",
                    output="n_snapshots = 4")
    code, stdout, summary, out, done = run_with_fault(tmp_path, monkeypatch, capsys, text, inject)
    k = done["result"]
    assert code == cli.EXIT_RUN_FAILED == 3
    assert summary["failure"]["index"] == -(k + 1)
    # the positions, and the clock with them, reached the next cycle
    assert_clean_stop(stdout, summary, 10, f"a particle reached the axis (r <= 0); particle {k + 1} "
                      "of body 'rod' at r = -", out, done, tmp_path / "faulty.nml", clock_moved=True)
    assert " mm, z = " in summary["failure"]["message"]


def test_axis_stops_a_particle_driven_across_it(write_deck):
    """A particle next to the axis given an inward radial velocity that
    carries it across r = 0 within one step (before the axis acted on
    particles as a wall, this injection tripped the axis guard): the
    axis is a frictionless wall at half the particle radius, so every
    particle stays off it and the run goes on."""
    sim = fsph.Simulation.from_deck(write_deck(rod_deck(
        control="mode = 'sph'", body="n_radial = 4\n n_axial = 16")))
    part = sim.snapshot()["particles"]
    x, v = part["x"], part["velocity"].copy()
    k = int(np.argmin(x[:, 0] + 1e-9 * x[:, 1]))
    v[k, 0] = -4.0 * x[k, 0] / sim.dt
    verify.set_particle_motion(sim, x, v)
    for _ in range(20):
        sim.advance(sim.time + 0.5 * sim.dt, land=False)
        after = sim.snapshot()["particles"]
        assert np.all(after["x"][:, 0] >= 0.5 * part["radius"].min() * (1.0 - 1e-9))


def test_non_finite_element_state_stops_cleanly(tmp_path, monkeypatch, capsys):
    """A NaN in one element's internal energy: its stress update gives a
    NaN pressure, and the element guard stops the run (exit 3) naming the
    element, its body, where and when; the last good snapshot and
    checkpoint are kept."""
    from fsph import cli

    def inject(sim):
        e = sim.snapshot()["internal_energy"].copy()
        k = sim.n_elements // 2
        e[k] = np.nan
        verify.set_element_energy(sim, e)
        return k

    text = rod_deck(output="n_snapshots = 4")
    code, stdout, summary, out, done = run_with_fault(tmp_path, monkeypatch, capsys, text, inject)
    k = done["result"]
    assert code == cli.EXIT_RUN_FAILED == 3
    assert summary["failure"]["index"] == k + 1
    assert_clean_stop(stdout, summary, 2, f"non-finite stress or energy (NaN/Inf) in an element; "
                      f"element {k + 1} of body 'rod' at r = ", out, done, tmp_path / "faulty.nml",
                      clock_moved=True)


def test_non_finite_particle_stops_cleanly(tmp_path, monkeypatch, capsys):
    """A NaN in one particle's velocity (pure SPH rod): exit 3, the
    particle guard's diagnostic names a particle (the NaN reaches the
    neighbours through the next force sum, the lowest index is named) and
    its body, with time and cycle; the last good snapshot and checkpoint
    are kept."""
    from fsph import cli

    def inject(sim):
        part = sim.snapshot()["particles"]
        v = part["velocity"].copy()
        k = len(v) // 2
        v[k, 1] = np.nan
        verify.set_particle_motion(sim, part["x"], v)
        return k

    text = rod_deck(control="mode = 'sph'", body="n_radial = 4\n n_axial = 16",
                    output="n_snapshots = 4")
    code, stdout, summary, out, done = run_with_fault(tmp_path, monkeypatch, capsys, text, inject)
    k = done["result"]
    assert code == cli.EXIT_RUN_FAILED == 3
    index = summary["failure"]["index"]
    assert -(k + 1) <= index < 0
    assert_clean_stop(stdout, summary, 9, "non-finite state (NaN/Inf) or non-positive density in "
                      f"a particle; particle {-index} of body 'rod'", out, done,
                      tmp_path / "faulty.nml", clock_moved=False)


def test_non_finite_velocity_stops_cleanly(tmp_path, monkeypatch, capsys):
    """A NaN in one node's velocity: exit 3, the NaN/Inf guard's diagnostic
    names the node and where it started, with time and cycle; the last good
    snapshot and checkpoint are kept."""
    from fsph import cli

    def inject(sim):
        v = sim.snapshot()["velocity"].copy()
        k = sim.n_nodes // 2
        v[k, 1] = np.nan
        verify.set_velocities(sim, v)
        return k

    text = rod_deck(output="n_snapshots = 4")
    code, stdout, summary, out, done = run_with_fault(tmp_path, monkeypatch, capsys, text, inject)
    k = done["result"]
    assert code == cli.EXIT_RUN_FAILED == 3
    assert summary["failure"]["index"] == k + 1
    # the position update of the next cycle failed: the clock stays put
    assert_clean_stop(stdout, summary, 3, f"non-finite position or velocity (NaN/Inf) at a node; "
                      f"node {k + 1} (initially at r = ", out, done, tmp_path / "faulty.nml",
                      clock_moved=False)
    assert " mm, z = " in summary["failure"]["message"]


def test_progress_bar_text(tmp_path, monkeypatch):
    """--progress bar: one tqdm bar over simulated time whose last state
    shows 100 %, the final cycle, the step, elements and particles and the
    elapsed<remaining times; no plain progress rows."""
    import io
    import re
    from fsph.driver import run
    monkeypatch.setenv("COLUMNS", "150")
    monkeypatch.setenv("LINES", "40")
    deck = tmp_path / "deck.nml"
    deck.write_text(rod_deck(output="n_progress = 5"))
    stream = io.StringIO()
    summary = run(deck, tmp_path / "out", stream=stream, progress="bar")
    text = stream.getvalue()
    states = [s.split("\n")[0] for s in text.split("\r") if "%|" in s]
    assert len(states) >= 2                    # the start and the end at least
    assert re.search(r"^\s*0%\|.*\| t 0/1 us \[00:00<\?, cycle 0, dt [0-9.]+ ns, 144 elements, "
                     r"0 particles\]", states[0]), states[0]
    final = (rf"^100%\|.*\| t 1/1 us \[\d\d:\d\d<\d\d:\d\d, cycle {summary['cycles']}, "
             rf"dt [0-9.]+ ns, 144 elements, 0 particles\]")
    assert re.search(final, states[-1]), states[-1]
    assert all(len(s) <= 150 for s in states)
    assert not [line for line in text.splitlines() if line.split() and line.split()[0].isdigit()]
    assert "fsph: completed" in text


def test_progress_bar_on_a_pseudo_terminal(tmp_path):
    """`fsph run` with stdout on a pseudo-terminal (whose size is 0 x 0, as
    under `script` or some CI runners) draws the bar, short labels for the
    80-column default; with --quiet nothing is printed."""
    import fcntl
    import pty
    import struct
    import termios
    deck = tmp_path / "deck.nml"
    deck.write_text(rod_deck())
    env = {k: v for k, v in os.environ.items() if k not in ("COLUMNS", "LINES")}
    env["OMP_NUM_THREADS"] = "1"

    def on_pty(*extra):
        master, slave = pty.openpty()
        # a terminal that reports no size: tqdm alone prints nothing there
        fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 0, 0, 0, 0))
        proc = subprocess.Popen([sys.executable, "-m", "fsph", "run", str(deck), "-o",
                                 str(tmp_path / "out"), *extra], stdout=slave,
                                stderr=subprocess.PIPE, cwd=tmp_path, env=env)
        os.close(slave)
        chunks = []
        while True:
            try:
                data = os.read(master, 4096)
            except OSError:                    # EIO: the child closed the terminal
                break
            if not data:
                break
            chunks.append(data)
        os.close(master)
        assert proc.wait(timeout=300) == 0, proc.stderr.read()
        return b"".join(chunks).decode()

    text = on_pty()
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    final = [s for s in text.replace("\n", "\r").split("\r") if s.startswith("100%|")]
    assert final, text
    assert "t 1/1 us [" in final[-1]
    assert f"cycle {summary['cycles']}, dt " in final[-1] and ", el 144, pt 0]" in final[-1]
    assert "    cycle     t [us]" not in text        # no table of plain lines
    assert on_pty("--quiet") == ""


#: a rod deck of some seconds: still running when the last interrupt comes
SECONDS_DECK = rod_deck(control="end_time = 2.0e-4", body="n_radial = 6\n n_axial = 24")


@pytest.mark.parametrize("entry, signal_name", [("console script", "SIGINT"),
                                                 ("python -m fsph", "SIGINT"),
                                                 ("console script", "SIGTERM")])
def test_ctrl_c_at_any_moment_of_the_start_is_one_line_and_exit_4(entry, signal_name, tmp_path):
    """SIGINT in the first 0.2 s of `fsph run`, while the solver, numpy and
    h5py are imported, was a KeyboardInterrupt traceback (or the noise of
    modules half set up, an exit by SIGINT, or the interrupt dropped in a
    clean-up while the run went on). From the moment fsph's code runs (its
    first module imported, as Python's import profile says: the
    interpreter's own start-up before it is Python's) through the
    imports, the set-up and into the run: exit 4, no traceback, and on
    stderr at most the line 'fsph: interrupted'. SIGTERM the same (it
    ended the process without a word before the run's own handling)."""
    from pathlib import Path
    import signal
    import time
    deck = tmp_path / "rod.nml"
    deck.write_text(SECONDS_DECK)
    command = ([str(Path(sys.executable).parent / "fsph")] if entry == "console script"
               else [sys.executable, "-m", "fsph"])
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPROFILEIMPORTTIME="1")
    for k, delay in enumerate((0.02, 0.05, 0.1, 0.2, 0.35)):
        proc = subprocess.Popen(command + ["run", str(deck), "-o", str(tmp_path / f"out{k}"), "-q"],
                                cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
        seen = []
        for line in proc.stderr:            # one line per import, as each ends
            seen.append(line)
            if line.rsplit("|", 1)[-1].strip() == "fsph.errors":
                break
        time.sleep(delay)
        proc.send_signal(getattr(signal, signal_name))
        _, rest = proc.communicate(timeout=120)
        stderr = "".join(seen) + rest
        said = [line for line in stderr.splitlines() if not line.startswith("import time:")]
        assert proc.returncode == 4 and "Traceback" not in stderr, (delay, proc.returncode, said)
        assert said in ([], ["fsph: interrupted"]), (delay, said)


def test_a_ctrl_c_dropped_in_a_clean_up_is_raised_again_in_the_program(tmp_path):
    """A KeyboardInterrupt raised where Python cannot raise it (a __del__,
    a weak reference's callback) reaches the program's own code through
    its unraisable hook (fsph.cli._unraisable), not dropped: interrupting
    the main thread from within the hook raised it inside the hook, where
    Python dropped it again and the run went on (SIGTERM at 0.2 s into
    `fsph run`, exit 0)."""
    code = ("import sys, time\n"
            "from fsph import cli\n"
            "sys.unraisablehook = cli._unraisable\n"
            "class Dropped:\n"
            "    def __del__(self):\n"
            "        raise KeyboardInterrupt\n"
            "try:\n"
            "    x = Dropped(); del x\n"
            "    end = time.monotonic() + 5.0\n"
            "    while time.monotonic() < end:\n"
            "        pass\n"
            "    print('went on')\n"
            "except KeyboardInterrupt:\n"
            "    print('interrupted')\n")
    res = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True,
                         timeout=120)
    assert res.stdout.strip() == "interrupted" and res.stderr == "", (res.stdout, res.stderr)


def test_the_package_loads_the_solver_on_first_use(tmp_path):
    """`import fsph` (the command line's first step) loads neither numpy
    nor the solver; Simulation, threads and sweep come on first use, and
    fsph.sweep stays the function when the module of that name is
    imported."""
    code = ("import sys, fsph; light = not {'numpy', 'h5py', 'fsph.simulation'} & set(sys.modules); "
            "import fsph.sweep; print(light, fsph.sweep.__module__, fsph.Simulation.__name__, "
            "fsph.threads.__name__, sorted(set(fsph.__all__) - set(dir(fsph))))")
    res = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stderr
    assert res.stdout.split() == ["True", "fsph.sweep", "Simulation", "threads", "[]"]
