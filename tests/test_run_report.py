"""What a run reports beyond its lengths: warnings that a run must not
complete silently with (a lost energy balance, an inconsistent material),
the peak fields with where they are, and the Taylor metrics as the
literature defines them (impact-face and largest diameter, detached
particles left out and counted)."""

import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from fsph import deck as deck_module
from fsph import metrics
from fsph.report import write_report
from conftest import CASES, reference, rod_deck


def fsph_cli(args, cwd):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    return subprocess.run([sys.executable, "-m", "fsph", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


# ---- energy warning -------------------------------------------------------------
def test_energy_error_beyond_the_warning_level_is_reported(write_deck, tmp_path):
    """A run whose energy error exceeds &control energy_error_warning
    completes, but says so: on the console ('completed with 1 warning' and
    a warning line), in summary.json (warnings) and in `fsph report`."""
    deck = write_deck(rod_deck(control="energy_error_warning = 1.0e-9\n end_time = 2.0e-6"))
    out = tmp_path / "run"
    proc = fsph_cli(["run", str(deck), "-o", str(out), "--progress", "lines"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "completed with 1 warning" in proc.stdout
    assert "warning: energy error" in proc.stdout and "energy_error_limit" in proc.stdout
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed"
    assert [w["kind"] for w in summary["warnings"]] == ["energy_error"]
    assert summary["warnings"][0]["limit"] == 1.0e-9
    (tmp_path / "cases").mkdir()
    (tmp_path / "cases" / "rod.nml").write_text(deck.read_text())
    (tmp_path / "report" / "runs").mkdir(parents=True)
    (tmp_path / "report" / "runs" / "rod").symlink_to(out)
    report = write_report(tmp_path / "cases", tmp_path / "report", decks=("rod",))
    assert "**energy_error**" in report.read_text()


def test_balanced_run_has_no_warning_and_no_untracked_temperature(tmp_path):
    """The elastic bar keeps its energy balance: no warning. Its material
    does not heat (no Johnson-Cook), so no temperature peak is reported
    that would read as a measured room temperature; nor does it yield, so
    its plastic strain, zero everywhere, has no place named for its peak."""
    proc = fsph_cli(["run", str(CASES / "elastic_bar.nml"), "-o", str(tmp_path / "bar"),
                     "--progress", "lines"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "bar" / "summary.json").read_text())
    assert summary["warnings"] == []
    assert list(summary["peaks"]) == ["plastic_strain", "internal_energy"]
    assert "peak temperature" not in proc.stdout
    strain = summary["peaks"]["plastic_strain"]
    assert strain["value"] == 0.0 and strain["r_mm"] is None and strain["in"] is None
    (line,) = [line for line in proc.stdout.splitlines() if "peak plastic_strain" in line]
    assert line.split()[-1] == "everywhere" and " at r " not in line
    assert summary["peaks"]["internal_energy"]["r_mm"] is not None


# ---- material consistency --------------------------------------------------------
COPPER_E_NU = """name = 'copper'
 strength = 'elastic'
 eos = 'mie_gruneisen'
 density = 8960.0
 youngs_modulus = 124.0e9
 poisson_ratio = 0.34
 c0 = 3940.0
 s = 1.489
 gamma0 = 2.02"""


def test_mie_gruneisen_bulk_mismatch_is_a_warning(write_deck, tmp_path):
    """With the Mie-Grueneisen EOS, E and nu whose bulk modulus differs
    from rho0 c0^2 by more than 5 % (copper's tabulated 124 GPa and 0.34:
    129 GPa against 139 GPa, -7.4 %) load with a warning naming both and
    saying which is used; the run carries it into summary.json."""
    text = rod_deck(material=COPPER_E_NU).replace("material = 'steel'", "material = 'copper'")
    deck = deck_module.load(write_deck(text))
    assert len(deck["warnings"]) == 1
    message = deck["warnings"][0]
    assert "&material #1 'copper'" in message and "129.2 GPa" in message and "139.1 GPa" in message
    assert "-7.1 %" in message or "-7.2 %" in message or "-7.3 %" in message or "-7.4 %" in message
    assert "the pressure uses rho0 c0^2" in message
    proc = fsph_cli(["run", str(write_deck(text, "copper.nml")), "-o", str(tmp_path / "cu"),
                     "--quiet"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "cu" / "summary.json").read_text())
    assert [w["kind"] for w in summary["warnings"]] == ["deck"]


def test_consistent_mie_gruneisen_moduli_give_no_warning(write_deck):
    """4340 steel of the library: E/(3(1 - 2 nu)) = 158.7 GPa within 3.3 %
    of rho0 c0^2 = 164.1 GPa."""
    text = rod_deck(material="name = 'steel'\n library = 'steel_4340_jc'")
    assert deck_module.load(write_deck(text))["warnings"] == []


# ---- peaks -------------------------------------------------------------------------
def test_peak_fields_in_summary_and_console(tmp_path):
    """summary.json and the printed summary give the peak plastic strain
    and temperature with their units and where they are; the peak is the largest value of
    the last snapshot's elements and particles."""
    import h5py
    out = tmp_path / "cu"
    deck = CASES / "taylor_copper_fem.nml"
    text = deck.read_text().replace("n_radial = 10", "n_radial = 4").replace(
        "n_axial = 67", "n_axial = 27").replace("end_time = 100.0e-6", "end_time = 20.0e-6")
    (tmp_path / "deck.nml").write_text(text)
    proc = fsph_cli(["run", "deck.nml", "-o", str(out), "--progress", "lines"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "peak plastic_strain" in proc.stdout and "peak temperature" in proc.stdout
    peaks = json.loads((out / "summary.json").read_text())["peaks"]
    with h5py.File(out / "fsph.h5") as h5:
        last = h5["snapshots"][sorted(h5["snapshots"])[-1]]
        eps = last["plastic_strain"][...]
        temp = last["temperature"][...]
        k = int(np.argmax(eps))
        centre = last["nodes"][...][last["connectivity"][...][k]].mean(axis=0)
    assert peaks["plastic_strain"]["value"] == pytest.approx(eps.max(), rel=1e-12)
    assert [peaks[name]["unit"] for name in ("plastic_strain", "temperature", "internal_energy")] \
        == ["-", "K", "J/kg"]
    assert peaks["plastic_strain"]["in"] == "element" and peaks["plastic_strain"]["index"] == k
    assert peaks["plastic_strain"]["r_mm"] == pytest.approx(centre[0] * 1e3, rel=1e-12)
    assert peaks["temperature"]["value"] == pytest.approx(temp.max(), rel=1e-12)
    with h5py.File(out / "fsph.h5") as h5:
        last = h5["snapshots"][sorted(h5["snapshots"])[-1]]
        last_e = last["internal_energy"][...]
    assert peaks["internal_energy"]["value"] == pytest.approx(last_e.max(), rel=1e-12)
    assert "peak internal_energy" in proc.stdout
    # adiabatic heating of Johnson-Cook copper: hotter than the room
    assert peaks["temperature"]["value"] > 293.15 + 10.0


# ---- Taylor metrics ------------------------------------------------------------------
def particle_rod(n_r=4, n_z=20, spacing=1e-3):
    """A lattice of particles (r, z) standing for a rod of radius n_r
    spacing on z = 0, with ring masses and h = 1.3 spacing."""
    r, z = np.meshgrid((np.arange(n_r) + 0.5) * spacing, (np.arange(n_z) + 0.5) * spacing)
    x = np.column_stack([r.ravel(), z.ravel()])
    n = len(x)
    return {"particles": {"x": x, "radius": np.full(n, 0.5 * spacing),
                          "h": np.full(n, 1.3 * spacing), "mass": 2 * np.pi * x[:, 0] * spacing ** 2,
                          "body": np.zeros(n, dtype=int)}}


def with_particles(snap, x, radius, h, mass):
    part = dict(snap["particles"])
    part["x"] = np.vstack([part["x"], x])
    part["radius"] = np.concatenate([part["radius"], radius])
    part["h"] = np.concatenate([part["h"], h])
    part["mass"] = np.concatenate([part["mass"], mass])
    part["body"] = np.concatenate([part["body"], np.zeros(len(radius), dtype=int)])
    return {"particles": part}


def test_stray_particle_is_left_out_of_the_lengths_and_counted():
    """A particle left 3 mm below the face (on the anvil of a rod that
    rebounded) and one 5 mm to the side are not SPH neighbours of the rod:
    L, D and W are the rod's own, and their count and mass are reported."""
    rod = particle_rod()
    body = {"length": 20e-3}
    base = metrics.taylor(rod, body, 0)
    m = rod["particles"]["mass"].mean()
    snap = with_particles(rod, np.array([[0.5e-3, -3e-3], [9e-3, 1e-3]]), np.full(2, 0.5e-3),
                          np.full(2, 1.3e-3), np.array([m, 2 * m]))
    got = metrics.taylor(snap, body, 0)
    for key in ("L_mm", "D_mm", "D_max_mm", "W_mm"):
        assert got[key] == pytest.approx(base[key], rel=1e-12), key
    assert base["L_mm"] == pytest.approx(20.0) and base["D_mm"] == pytest.approx(8.0)
    assert got["n_detached_particles"] == 2
    assert got["detached_mass_kg"] == pytest.approx(3 * m)


def test_particle_touching_the_rod_stays_in_it():
    """A particle within the kernel reach of the rod is part of it."""
    rod = particle_rod()
    snap = with_particles(rod, np.array([[5.6e-3, 0.5e-3]]), np.full(1, 0.5e-3), np.full(1, 1.3e-3),
                          rod["particles"]["mass"][:1])
    got = metrics.taylor(snap, {"length": 20e-3}, 0)
    assert got["n_detached_particles"] == 0
    assert got["D_mm"] == pytest.approx(2 * 6.1)


def test_face_diameter_and_largest_diameter():
    """D is the largest diameter within FACE_BAND L0 of the impact face;
    D_max the largest anywhere: a collar higher up the rod widens D_max
    only."""
    rod = particle_rod()
    snap = with_particles(rod, np.array([[4.5e-3, 10.5e-3]]), np.full(1, 0.5e-3), np.full(1, 1.3e-3),
                          rod["particles"]["mass"][:1])
    got = metrics.taylor(snap, {"length": 20e-3}, 0)
    assert got["D_mm"] == pytest.approx(8.0)
    assert got["D_max_mm"] == pytest.approx(10.0)
    assert got["face_band_mm"] == pytest.approx(metrics.FACE_BAND * 20.0)


# ---- references and their conditions ---------------------------------------------
def _taylor_at(tmp_path, speed, reference_text=None):
    """The Taylor deck cut to 2 us at `speed` [m/s], with the shipped
    reference or `reference_text` as references/taylor_armco.json."""
    text = (CASES / "taylor_armco.nml").read_text().replace("end_time = 60.0e-6", "end_time = 2.0e-6")
    deck = tmp_path / f"taylor_{speed:g}.nml"
    deck.write_text(text.replace("velocity_z = -221.0", f"velocity_z = -{speed:.1f}"))
    (tmp_path / "references").mkdir(exist_ok=True)
    (tmp_path / "references" / "taylor_armco.json").write_text(
        reference_text or (CASES / "references" / "taylor_armco.json").read_text())
    return deck


def without_end_time(name):
    """The text of the shipped reference NAME without its condition on
    the end time: its values hold at the deck's end time, which the short
    runs of these tests do not reach; the tests of the other conditions
    and of the report compare them all the same."""
    ref = reference(name)
    del ref["conditions"]["control.end_time"]
    return json.dumps(ref)


def test_reference_is_compared_only_where_its_conditions_hold(tmp_path):
    """The 221 m/s experiment: compared at 221 m/s; at 180 m/s the summary
    and the console say why not, and no error against it is reported."""
    text = without_end_time("taylor_armco")
    same = fsph_cli(["run", str(_taylor_at(tmp_path, 221.0, text)), "-o", "same"], tmp_path)
    slower = fsph_cli(["run", str(_taylor_at(tmp_path, 180.0, text)), "-o", "slower"], tmp_path)
    assert same.returncode == slower.returncode == 0, same.stderr + slower.stderr
    ref_same = json.loads((tmp_path / "same" / "summary.json").read_text())["reference"]
    ref_slow = json.loads((tmp_path / "slower" / "summary.json").read_text())["reference"]
    assert ref_same["applies"] and set(ref_same["comparison"]["taylor"]) == {"L_mm", "D_mm", "W_mm"}
    assert not ref_slow["applies"] and ref_slow["comparison"] == {}
    assert ref_slow["not_applied_because"] == "body(rod).velocity_z is -180.0 here, -221.0 in the reference"
    assert "fsph: not compared with the reference" in slower.stdout
    assert "reference 19.8" in same.stdout and "reference 19.8" not in slower.stdout


def test_a_run_cut_short_is_not_compared_with_the_final_state_of_the_experiment(tmp_path):
    """The Taylor rod's final shape holds from the shipped deck's 60 us on,
    the elastic bar's front at its 3 us: their references name the end
    time (a least one for the rod), so a run cut short says why it is not
    compared (the rod at 15 us was +13 % on L, the bar at 1.5 us -48 % on
    its plateau), and every shipped deck meets the conditions of its
    reference."""
    from fsph import references
    rod = fsph_cli(["run", str(_taylor_at(tmp_path, 221.0)), "-o", "rod"], tmp_path)
    bar = fsph_cli(["run", "bar.nml", "-o", "bar"], _short_cases(tmp_path, bar=None,
                                                                 end_time=True))
    assert rod.returncode == bar.returncode == 0, rod.stderr + bar.stderr
    for out, why in ((tmp_path / "rod", "control.end_time is 2e-06 here, at least 6e-05 in the "
                                        "reference"),
                     (tmp_path / "cases" / "bar", "control.end_time is 5e-07 here, 3e-06 in the "
                                                  "reference")):
        ref = json.loads((out / "summary.json").read_text())["reference"]
        assert not ref["applies"] and ref["comparison"] == {}, out
        assert ref["not_applied_because"] == why
    assert f"fsph: not compared with the reference ({reference('taylor_armco')['source']}): " \
           "control.end_time is 2e-06 here" in rod.stdout and "reference 19.8" not in rod.stdout
    shipped = [deck_module.load(path) for path in sorted(CASES.glob("*.nml"))]
    named = [deck for deck in shipped if deck["output"]["reference"] is not None]
    assert len(named) >= 15
    for deck in named:
        assert references.not_applied_because(references.load(deck), deck) == "", deck["path"]
    taylor = deck_module.load(CASES / "taylor_armco.nml")
    longer = taylor | {"control": dict(taylor["control"], end_time=1.0e-4)}
    assert references.not_applied_because(references.load(longer), longer) == ""


def test_a_projectile_still_in_the_target_has_no_residual_velocity_compared(tmp_path):
    """A perforation run whose projectile has not left the target (a rod
    6 us into a 4 mm block) printed its velocity as a residual velocity
    against the experiment's; it now says it was not measured and why,
    and `fsph report` counts it outside the bar."""
    (tmp_path / "block.json").write_text(
        '{"source": "test", "perforation": {"residual_velocity_m_s": 555.0}}')
    (tmp_path / "block.nml").write_text(
        rod_deck(control="mode = 'adaptive'\n end_time = 6e-6",
                 material="name = 'steel'\n library = 'projectile_bilinear_concrete'",
                 body="velocity_z = -600.0\n n_radial = 4\n n_axial = 16\n z_base = 0.05e-3",
                 boundary=False, output="reference = 'block.json'")
        + "&material\n name = 'concrete'\n library = 'concrete_48mpa_hjc'\n/\n"
        "&body\n name = 'block'\n material = 'concrete'\n radius = 6.0e-3\n"
        " length = 4.0e-3\n z_base = -4.0e-3\n n_radial = 12\n n_axial = 8\n/\n"
        "&metrics\n kind = 'perforation'\n body = 'rod'\n target = 'block'\n/\n")
    proc = fsph_cli(["run", "block.nml", "-o", "out"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["metrics"]["perforation"]["exited"] is False
    assert summary["reference"]["applies"]
    got = summary["reference"]["comparison"]["perforation"]["residual_velocity_m_s"]
    assert got["computed"] is None and got["error_percent"] is None
    line = [t for t in proc.stdout.splitlines() if "perforation.residual_velocity_m_s" in t]
    assert len(line) == 1 and line[0].split()[1] == "none", line
    assert line[0].endswith("reference 555   not measured: the projectile has not left the target")
    from fsph.report import _compared
    result, cells = _compared("block", "perforation.residual_velocity_m_s", got, ("percent", 5.0))
    assert result["within"] is False
    assert result["error"] == "not measured (the projectile has not left the target)"


def test_malformed_reference_is_a_deck_error(tmp_path):
    res = fsph_cli(["run", str(_taylor_at(tmp_path, 221.0, '{"taylor": {"L_mm": 19.8,}')), "-o", "o"],
                   tmp_path)
    assert res.returncode == 2 and "Traceback" not in res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "&output key 'reference': expected a readable JSON file" in lines[0]
    assert not (tmp_path / "o" / "fsph.h5").exists()


@pytest.mark.parametrize("entries, key, expected, got", [
    ('"taylor": {"L_mm": null}', "taylor.L_mm", "a finite number other than 0", "null"),
    ('"taylor": {"L_mm": "19.8 mm"}', "taylor.L_mm", "a finite number other than 0", '"19.8 mm"'),
    ('"taylor": {"L_mm": NaN}', "taylor.L_mm", "a finite number other than 0", "NaN"),
    ('"taylor": {"L_mm": 0}', "taylor.L_mm", "a finite number other than 0", "0"),
    ('"taylor": {"L_mm": true}', "taylor.L_mm", "a finite number other than 0", "true"),
    ('"taylor": 19.8', "taylor", "an object of measured values", "19.8"),
    ('"source": 1988', "source", "text", "1988"),
    ('"conditions": {"body(rod).velocity_z": {"about": -221.0}}',
     "conditions.body(rod).velocity_z", "a deck value", '{"about": -221.0}'),
    ('"conditions": {"velocity": -221.0}', "conditions.velocity", "a deck key GROUP.KEY", '"velocity"'),
    ('"ballistic": {"striking_velocity_m_s": [300, 400], "residual_velocity_m_s": [0, "x"]}',
     "ballistic.residual_velocity_m_s", "a list of finite numbers", '[0, "x"]'),
    ('"ballistic": {"striking_velocity_m_s": [300, 400], "residual_velocity_m_s": [0]}',
     "ballistic", "striking_velocity_m_s and residual_velocity_m_s of one length", '{"striking_velocity_m_s": 2, "residual_velocity_m_s": 1}'),
])
def test_a_reference_entry_out_of_the_format_is_a_deck_error(tmp_path, entries, key, expected, got):
    """A reference value that is null, text, not finite, 0 (the errors are
    relative to it) or true, a group that is not an object, a condition
    that is no deck key or value, a ballistic curve that is not two lists
    of numbers of one length: exit 2 at set-up, one line naming the
    reference file, the key, what was expected and the value as written
    (before, a value of null or text was a traceback at the first
    snapshot)."""
    res = fsph_cli(["run", str(_taylor_at(tmp_path, 221.0, "{" + entries + "}")), "-o", "o"], tmp_path)
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert f"taylor_armco.json key '{key}': expected {expected}" in lines[0], lines[0]
    assert lines[0].endswith(f", got {got}"), lines[0]
    assert not (tmp_path / "o").exists()


# ---- fsph report: the installed decks and the bars ---------------------------------
def _report_rows(text, case):
    """The table cells of the rows of `case` in report.md."""
    return [[cell.strip() for cell in line.strip("|").split("|")]
            for line in text.splitlines() if line.startswith(f"| {case} |")]


def test_installed_decks_are_the_validation_decks_with_their_references():
    """meson.build installs every deck of the report and the reference it
    names into fsph/cases, as in the checkout; the report finds them there,
    not in the checkout (the report must not need the repository)."""
    from fsph import references
    from fsph.report import VALIDATION_DECKS, installed_cases
    folder = installed_cases()
    assert CASES.resolve() not in folder.resolve().parents and folder.resolve() != CASES.resolve()
    for name in VALIDATION_DECKS:
        deck_path = folder / f"{name}.nml"
        assert deck_path.read_text() == (CASES / deck_path.name).read_text(), name
        deck = deck_module.load(deck_path)
        ref = deck["output"]["reference"]
        assert ref is not None and references.load(deck) is not None, name
        assert (folder / ref).read_text() == (CASES / ref).read_text(), name


def test_report_runs_from_any_folder_with_the_installed_decks(tmp_path):
    """`fsph report` from a folder without cases/ (outside the checkout):
    the elastic bar from the installed decks, its two metrics within their
    bars (3 %, 0.5 mm) and the summary line at the top."""
    assert not (tmp_path / "cases").exists()
    proc = fsph_cli(["report", "--decks", "elastic_bar", "-o", "rep"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    text = (tmp_path / "rep" / "report.md").read_text()
    assert text.splitlines()[2] == "2 of 2 metrics within their bars."
    rows = {row[2]: row for row in _report_rows(text, "elastic_bar")}
    assert set(rows) == {"bar_wave.plateau_GPa", "bar_wave.front_mm"}
    assert rows["bar_wave.plateau_GPa"][6:8] == ["3 %", "yes"]
    assert rows["bar_wave.front_mm"][6:8] == ["0.5 mm", "yes"]
    assert str(tmp_path) not in text.split("`")[1] and "fsph" in text.split("`")[3]


@pytest.fixture(scope="module")
def bar_runs(tmp_path_factory):
    """The elastic bar with elements and with particles, run once; the
    tests report on these runs against references of their own."""
    runs = tmp_path_factory.mktemp("bar_runs")
    for name in ("elastic_bar", "elastic_bar_sph"):
        proc = fsph_cli(["run", str(CASES / f"{name}.nml"), "-o", str(runs / name), "--quiet"], runs)
        assert proc.returncode == 0, proc.stderr
    return runs


def _report_on(bar_runs, tmp_path, acceptance_by_mode=None, acceptance=None,
               decks=("elastic_bar", "elastic_bar_sph")):
    """report.md of the bar runs, the decks in a cases folder of their own
    with the elastic-bar reference given these bars."""
    cases = tmp_path / "cases"
    (cases / "references").mkdir(parents=True)
    ref = json.loads((CASES / "references" / "elastic_bar.json").read_text())
    ref.pop("acceptance_by_mode")
    if acceptance_by_mode is not None:
        ref["acceptance_by_mode"] = acceptance_by_mode
    if acceptance is not None:
        ref["acceptance"] = acceptance
    (cases / "references" / "elastic_bar.json").write_text(json.dumps(ref))
    (tmp_path / "rep" / "runs").mkdir(parents=True)
    for name in decks:
        (cases / f"{name}.nml").write_text((CASES / f"{name}.nml").read_text())
        (tmp_path / "rep" / "runs" / name).symlink_to(bar_runs / name)
    return write_report(cases, tmp_path / "rep", decks=decks).read_text()


def test_within_bar_flags_a_metric_outside_its_bar(bar_runs, tmp_path):
    """A bar the run cannot meet (the plateau, -1.2 % off, held to 0.01 %)
    reads NO; the front, 0.26 mm short, is within 0.5 mm and reads yes, and
    within 0.2 mm it reads NO; the summary names the failures."""
    text = _report_on(bar_runs, tmp_path, decks=("elastic_bar",), acceptance_by_mode={
        "source": "test", "fem": {"plateau_percent": 0.01, "front_mm_absolute": 0.5}})
    rows = {row[2]: row for row in _report_rows(text, "elastic_bar")}
    assert rows["bar_wave.plateau_GPa"][5] == "-1.21 %"
    assert rows["bar_wave.plateau_GPa"][6:8] == ["0.01 %", "NO"]
    assert rows["bar_wave.front_mm"][5] == "-1.69 % (-0.259 mm)"
    assert rows["bar_wave.front_mm"][6:8] == ["0.5 mm", "yes"]
    assert text.splitlines()[2] == ("1 of 2 metrics within their bars; outside: elastic_bar "
                                    "bar_wave.plateau_GPa (-1.21 %, bar 0.01 %)")
    # report.html: the same rows, the one outside its bar marked, the summary on top
    import html.parser
    page = (tmp_path / "rep" / "report.html").read_text()

    class Rows(html.parser.HTMLParser):
        rows, marked, cell = [], [], None

        def handle_starttag(self, tag, attrs):
            if tag == "tr":
                self.rows.append([])
                self.marked.append(dict(attrs).get("class") == "no")
            elif tag == "td":
                self.cell = ""

        def handle_data(self, data):
            if self.cell is not None:
                self.cell += data

        def handle_endtag(self, tag):
            if tag == "td":
                self.rows[-1].append(self.cell.strip())
                self.cell = None
    parser = Rows()
    parser.feed(page)
    body = [(r, m) for r, m in zip(parser.rows, parser.marked) if r]
    assert [(r[2], m) for r, m in body] == [("bar_wave.plateau_GPa", True), ("bar_wave.front_mm", False)]
    assert "1 of 2 metrics within their bars" in page.split("<table>")[0]
    text = _report_on(bar_runs, tmp_path / "tighter", decks=("elastic_bar",), acceptance_by_mode={
        "source": "test", "fem": {"plateau_percent": 3.0, "front_mm_absolute": 0.2}})
    rows = {row[2]: row for row in _report_rows(text, "elastic_bar")}
    assert rows["bar_wave.plateau_GPa"][6:8] == ["3 %", "yes"]
    assert rows["bar_wave.front_mm"][6:8] == ["0.2 mm", "NO"]


def test_summary_line_counts_the_metrics_with_a_bar(bar_runs, tmp_path):
    """Two decks, four metrics: a mode named in acceptance_by_mode takes its
    bars, another mode the reference's acceptance (each_percent for every
    metric); the count is of metrics with a bar, those without listed."""
    text = _report_on(bar_runs, tmp_path, acceptance={"source": "test", "each_percent": 2.0},
                      acceptance_by_mode={"source": "test", "fem": {"plateau_percent": 3.0}})
    fem = {row[2]: row for row in _report_rows(text, "elastic_bar")}
    sph = {row[2]: row for row in _report_rows(text, "elastic_bar_sph")}
    assert fem["bar_wave.plateau_GPa"][6:8] == ["3 %", "yes"]
    assert fem["bar_wave.front_mm"][6:8] == ["none", "–"]
    assert sph["bar_wave.plateau_GPa"][6:8] == ["2 %", "NO"]       # +2.3 %
    assert sph["bar_wave.front_mm"][6:8] == ["2 %", "NO"]          # -3.5 %
    lines = text.splitlines()
    assert lines[2] == ("1 of 3 metrics within their bars; outside: elastic_bar_sph "
                        "bar_wave.plateau_GPa (+2.26 %, bar 2 %), elastic_bar_sph "
                        "bar_wave.front_mm (-3.54 %, bar 2 %)")
    assert lines[3] == "Without a bar (1): elastic_bar bar_wave.front_mm (-1.69 %)."


def test_shipped_bars_are_the_bars_the_tests_assert():
    """The bars of the report come from the reference files; those of the
    validation decks are the ones their tests assert: the elastic bar's
    BARS of tests/test_elastic_bar.py, 6 % each in pure SPH
    (test_taylor_sph.py), the adaptive acceptance (test_taylor_adaptive.py)
    and no bar for the FEM baseline (test_taylor_fem.py). The acceptance
    keys of the other references name their metrics."""
    from fsph.report import acceptance, bar
    from test_elastic_bar import BARS
    bar_ref, taylor = reference("elastic_bar"), reference("taylor_armco")
    for name, (plateau, front) in BARS.items():
        mode = deck_module.load(CASES / f"{name}.nml")["control"]["mode"]
        block = acceptance(bar_ref, mode)
        assert bar(block, "plateau_GPa") == ("percent", pytest.approx(100 * plateau)), name
        assert bar(block, "front_mm") == ("absolute", pytest.approx(front)), name
    for mode, expected in (("sph", ("percent", 6.0)), ("adaptive", ("percent", 4.0)), ("fem", None)):
        for key in ("L_mm", "D_mm", "W_mm"):
            assert bar(acceptance(taylor, mode), key) == expected, (mode, key)
    debris = acceptance(reference("debris_cu_al_1"), "sph")
    assert bar(debris, "front_ratio") == ("percent", 5.0)
    assert bar(debris, "target_front_mm") == ("percent", 5.0)
    assert bar(debris, "intersection_radius_mm") == ("percent", 10.0)
    assert bar(debris, "flyer_front_mm") is None
    assert bar(acceptance(reference("concrete_1058"), "fem"), "residual_velocity_m_s") == ("percent", 3.0)


@pytest.mark.parametrize("args, message, checked_first", [
    (["--cases", "nothere"], "nothere: expected a folder of decks (--cases)", True),
    (["--cases", "deck.nml"], "deck.nml: expected a folder of decks (--cases)", True),
    (["--cases", "cases", "--decks", "elastic_bar,taylor"], "cases: expected a deck taylor.nml (--decks)",
     True),
    (["--decks", "elastic_bar,nothere"], "expected a deck nothere.nml (--decks)", True),
    (["--cases", "cases", "--decks", "orphan"], "&output key 'reference': expected an existing JSON",
     False),
    (["--cases", "cases", "--decks", "elastic_bar"], "the reference's front_mm_absolute: expected a "
                                                     "non-negative number, got '0.5 mm'", False),
])
def test_bad_cases_folder_or_deck_is_one_line_and_exit_2(tmp_path, args, message, checked_first):
    """A --cases that is no folder or a deck missing from it (checked before
    anything runs), a deck whose reference is missing, a bar that is not a
    number: exit 2, one line, no traceback."""
    (tmp_path / "deck.nml").write_text((CASES / "elastic_bar.nml").read_text())
    (tmp_path / "cases" / "references").mkdir(parents=True)
    for name in ("elastic_bar", "orphan"):
        (tmp_path / "cases" / f"{name}.nml").write_text((CASES / "elastic_bar.nml").read_text().replace(
            "references/elastic_bar.json", f"references/{name}.json"))
    ref = reference("elastic_bar")
    ref["acceptance_by_mode"]["fem"]["front_mm_absolute"] = "0.5 mm"
    (tmp_path / "cases" / "references" / "elastic_bar.json").write_text(json.dumps(ref))
    proc = fsph_cli(["report", *args, "-o", "rep"], tmp_path)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("fsph: error: ") and message in lines[0], lines
    assert (tmp_path / "rep").exists() != checked_first


def test_a_reference_the_run_did_not_measure_is_reported_not_met():
    """A metric with a reference value that the run could not measure
    (None: the group it measures is empty, e.g. no copper touching the
    aluminium for the intersection radius) stays in the comparison with
    the reference, is printed as not measured and is outside any bar of
    `fsph report` (before, it was left out of all three, and a report
    counted the bars of the metrics left as all met)."""
    from fsph.driver import _reference_text
    from fsph.report import within
    got = metrics.compare({"debris": {"intersection_radius_mm": None, "hole_diameter_mm": 22.0,
                                      "flyer": "copper"}},
                          {"debris": {"intersection_radius_mm": 27.9, "hole_diameter_mm": 20.0}})
    missing = got["debris"]["intersection_radius_mm"]
    assert missing == {"computed": None, "reference": 27.9, "error_percent": None}
    assert got["debris"]["hole_diameter_mm"]["error_percent"] == pytest.approx(10.0)
    assert "flyer" not in got["debris"]
    assert "not measured" in _reference_text(missing) and "27.9" in _reference_text(missing)
    assert not within(("percent", 1e9), missing)
    assert not within(("absolute", 1e9), missing)
    assert within(("percent", 10.0 + 1e-9), got["debris"]["hole_diameter_mm"])


# ---- fsph report: stale runs, decks without a comparison, failed runs ----------------
def _short_cases(tmp_path, end_time=False, **edits):
    """A cases folder of the elastic bar cut to 0.5 us (about 50 cycles),
    its reference beside it (without its condition on the end time, so
    that the short runs are compared, unless end_time); each edit
    NAME=(old, new) writes NAME.nml with that text replaced (None: as
    is). Returns the folder."""
    cases = tmp_path / "cases"
    (cases / "references").mkdir(parents=True)
    (cases / "references" / "elastic_bar.json").write_text(
        (CASES / "references" / "elastic_bar.json").read_text() if end_time
        else without_end_time("elastic_bar"))
    text = (CASES / "elastic_bar.nml").read_text().replace("end_time = 3.0e-6", "end_time = 0.5e-6")
    for name, edit in edits.items():
        (cases / f"{name}.nml").write_text(text.replace(*edit) if edit else text)
    return cases


def test_report_runs_again_a_deck_or_reference_changed_since_its_run(tmp_path):
    """A second `fsph report` reuses the runs of unchanged decks; a deck
    edited since its run (end time 0.5 -> 1 us), or a reference whose
    values changed, is run again and a line says why (the old run was
    reported as if current). New bars alone do not rerun: the report
    reads them afresh."""
    cases = _short_cases(tmp_path, ok=None)
    args = ["report", "--cases", "cases", "--decks", "ok", "-o", "rep"]
    summary_path = tmp_path / "rep" / "runs" / "ok" / "summary.json"
    first = fsph_cli(args, tmp_path)
    assert first.returncode == 0, first.stderr
    assert json.loads(summary_path.read_text())["requested_end_time_s"] == 0.5e-6
    again = fsph_cli(args, tmp_path)
    assert again.returncode == 0 and "running it again" not in again.stdout
    deck = cases / "ok.nml"
    deck.write_text(deck.read_text().replace("end_time = 0.5e-6", "end_time = 1.0e-6"))
    changed = fsph_cli(args, tmp_path)
    assert changed.returncode == 0, changed.stderr
    assert f"fsph report: {os.path.join('rep', 'runs', 'ok')}: cases/ok.nml changed since that " \
           "run; running it again" in changed.stdout
    assert json.loads(summary_path.read_text())["requested_end_time_s"] == 1.0e-6
    ref_path = cases / "references" / "elastic_bar.json"
    ref = json.loads(ref_path.read_text())
    ref["acceptance_by_mode"]["fem"]["plateau_percent"] = 50.0
    ref_path.write_text(json.dumps(ref))
    bars = fsph_cli(args, tmp_path)
    assert bars.returncode == 0 and "running it again" not in bars.stdout
    assert "| 50 % |" in (tmp_path / "rep" / "report.md").read_text()
    ref["bar_wave"]["front_mm"] = 15.0
    ref_path.write_text(json.dumps(ref))
    values = fsph_cli(args, tmp_path)
    assert "the reference of cases/ok.nml changed since that run" in values.stdout
    assert "| 15 |" in (tmp_path / "rep" / "report.md").read_text()


def test_report_lists_the_decks_it_could_not_compare(tmp_path):
    """A deck without a reference, and one whose reference's conditions do
    not hold (40 m/s, the reference's 50), ran but were in no row of the
    report: each now has its measured metrics with the reason in the
    reference column and a line of the summary."""
    _short_cases(tmp_path, ok=None,
                 noref=("  reference = 'references/elastic_bar.json'\n", ""),
                 slower=("velocity_z = -50.0", "velocity_z = -40.0"))
    proc = fsph_cli(["report", "--cases", "cases", "--decks", "ok,noref,slower", "-o", "rep"],
                    tmp_path)
    assert proc.returncode == 0, proc.stderr
    text = (tmp_path / "rep" / "report.md").read_text()
    for case, why in (("noref", "no reference"), ("slower", "not compared")):
        rows = {row[2]: row for row in _report_rows(text, case)}
        assert {"bar_wave.plateau_GPa", "bar_wave.front_mm"} <= set(rows), case
        assert rows["bar_wave.front_mm"][4:8] == [why, "–", "none", "–"], case
    assert text.splitlines()[3] == (
        "Without a reference (2): noref (no reference), slower (not compared: "
        "body(1).velocity_z is -40.0 here, -50.0 in the reference).")
    assert "noref" in (tmp_path / "rep" / "report.html").read_text()


def test_report_exits_3_when_a_run_failed(tmp_path):
    """A deck whose run fails (an energy error limit it cannot meet): the
    report is written with its status row and 'Not completed', and the
    exit code is 3 (was 0)."""
    _short_cases(tmp_path, ok=None,
                 fails=("end_time = 0.5e-6", "end_time = 0.5e-6\n  energy_error_limit = 1.0e-12"))
    proc = fsph_cli(["report", "--cases", "cases", "--decks", "ok,fails", "-o", "rep"], tmp_path)
    assert proc.returncode == 3, proc.stderr
    assert "Traceback" not in proc.stderr
    assert proc.stdout.strip().splitlines()[-1] == os.path.join("rep", "report.md")
    text = (tmp_path / "rep" / "report.md").read_text()
    assert "Not completed: fails (failed)." in text.splitlines()
    assert _report_rows(text, "fails")[0][2:4] == ["status", "failed"]
    assert _report_rows(text, "ok")


def test_a_run_that_failed_is_not_compared_with_its_reference(tmp_path):
    """The elastic bar with its reference's conditions met, stopped by an
    energy error limit it cannot meet: its metrics are those of its last
    good snapshot, before the end time the reference's values hold at, so
    the summary says why it is not compared (it was compared as if
    complete) and prints no error against the reference."""
    deck = tmp_path / "bar.nml"
    deck.write_text((CASES / "elastic_bar.nml").read_text()
                    .replace("end_time = 3.0e-6", "end_time = 3.0e-6\n  energy_error_limit = 1.0e-12")
                    .replace("references/", f"{CASES / 'references'}/"))
    proc = fsph_cli(["run", str(deck), "-o", "out", "--progress", "lines"], tmp_path)
    assert proc.returncode == 3, proc.stderr
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["status"] == "failed"
    ref = summary["reference"]
    assert ref["applies"] is False and ref["comparison"] == {}
    assert ref["not_applied_because"].startswith("the run failed and its last good snapshot is at t = ")
    assert ref["not_applied_because"].endswith("before its end time 3 us")
    assert not re.search(r"reference \S+ +error", proc.stdout) and "not compared" in proc.stdout


def test_printed_metrics_stand_in_one_column():
    """The printed metric lines pad every name to the longest, so the
    values line up (a name longer than 14 characters pushed its value
    out of line: 'taylor.detached_mass_kg          0')."""
    from fsph.driver import _format_metrics
    metrics = {"taylor": {"L_mm": 19.87, "detached_mass_kg": 0.0, "n_detached_particles": 0}}
    comparison = {"taylor": {"L_mm": {"computed": 19.87, "reference": 19.8, "error_percent": 0.35}}}
    lines = _format_metrics(comparison, metrics)
    assert [line.split()[0] for line in lines] == ["taylor.L_mm", "taylor.detached_mass_kg"]
    ends = {len(line.split("   reference")[0]) for line in lines}
    assert len(ends) == 1, lines
