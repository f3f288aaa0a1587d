"""`fsph plot` draws the deformed body of a run into a PNG."""

import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from fsph.driver import run
from conftest import rod_deck


def _snapshot_times_us(out):
    with h5py.File(out / "fsph.h5", "r") as h5:
        snaps = h5["snapshots"]
        return sorted(snaps[k].attrs["time"] * 1e6 for k in snaps if k.isdigit())


@pytest.fixture(scope="module")
def elastic_run(tmp_path_factory):
    """The small elastic rod (elements only) for 1 µs, 7 snapshots."""
    folder = tmp_path_factory.mktemp("elastic")
    deck = folder / "rod.nml"
    deck.write_text(rod_deck().replace("n_snapshots = 2", "n_snapshots = 7"))
    run(deck, folder / "out", quiet=True)
    return folder / "out"


@pytest.fixture(scope="module")
def taylor_run(tmp_path_factory):
    """An adaptive Armco rod at 400 m/s onto the rigid plane for 2 µs, with
    &metrics taylor and a reference of L, D and W: its elements turn into
    particles that reach z = 0."""
    folder = tmp_path_factory.mktemp("taylor")
    (folder / "rod.json").write_text(
        '{"source": "test", "taylor": {"L_mm": 3.9, "D_mm": 2.4, "W_mm": 2.1}}')
    deck = folder / "rod.nml"
    deck.write_text(rod_deck(control="mode = 'adaptive'\n end_time = 2e-6",
                             material="name = 'steel'\n library = 'armco_iron'",
                             body="velocity_z = -400.0\n n_radial = 6\n n_axial = 24",
                             output="reference = 'rod.json'")
                    .replace("n_snapshots = 2", "n_snapshots = 4")
                    + "&convert\n theta_c = 40.0\n/\n&metrics\n kind = 'taylor'\n/\n")
    summary = run(deck, folder / "out", quiet=True)
    assert summary["n_converted"] > 0
    return folder / "out"


@pytest.fixture(scope="module")
def block_run(tmp_path_factory):
    """A steel rod at 600 m/s into an HJC concrete block (two bodies), adaptive,
    6 µs, as a perforation run with a reference residual velocity."""
    folder = tmp_path_factory.mktemp("block")
    (folder / "block.json").write_text(
        '{"source": "test", "perforation": {"residual_velocity_m_s": 555.0}}')
    deck = folder / "block.nml"
    deck.write_text(rod_deck(control="mode = 'adaptive'\n end_time = 6e-6",
                             material="name = 'steel'\n library = 'projectile_bilinear_concrete'",
                             body="velocity_z = -600.0\n n_radial = 4\n n_axial = 16\n"
                                  " z_base = 0.05e-3", boundary=False,
                             output="reference = 'block.json'")
                    .replace("n_snapshots = 2", "n_snapshots = 6")
                    + "&material\n name = 'concrete'\n library = 'concrete_48mpa_hjc'\n/\n"
                    "&body\n name = 'block'\n material = 'concrete'\n radius = 6.0e-3\n"
                    " length = 4.0e-3\n z_base = -4.0e-3\n n_radial = 12\n n_axial = 8\n/\n"
                    "&metrics\n kind = 'perforation'\n body = 'rod'\n target = 'block'\n/\n")
    summary = run(deck, folder / "out", quiet=True)
    assert summary["reference"]["applies"]
    return folder / "out"


def _inside(inner, outer):
    return (inner.x0 >= outer.x0 and inner.y0 >= outer.y0 and inner.x1 <= outer.x1
            and inner.y1 <= outer.y1)


def _legend_texts(fig):
    return [t.get_text() for legend in fig.legends + [ax.get_legend() for ax in fig.axes]
            if legend for t in legend.get_texts()]


def plot_cli(monkeypatch, capsys, run_dir, *args):
    """`fsph plot RUN_DIR ARGS` in this process: its exit code, the lines it
    printed and the figures it drew (drawn, by file name)."""
    import fsph.plot
    from fsph.cli import main
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    figures = {}
    save = fsph.plot._save

    def keep(fig, output, dpi, **kwargs):
        save(fig, output, dpi, **kwargs)
        FigureCanvasAgg(fig).draw()         # closing the figure took its canvas
        figures[Path(output).name] = fig
    monkeypatch.setattr(fsph.plot, "_save", keep)
    code = main(["plot", str(run_dir), *args])
    return code, capsys.readouterr().out.splitlines(), figures


def _titles(fig):
    return [ax.get_title() for ax in fig.axes if ax.get_title()]


def test_plot_writes_png(tmp_path, write_deck):
    deck = write_deck(rod_deck(control="mode = 'adaptive'\n end_time = 2e-6",
                               material="name = 'steel'\n library = 'armco_iron'",
                               body="velocity_z = -400.0\n n_radial = 6\n n_axial = 24")
                      + "&convert\n theta_c = 40.0\n/\n&metrics\n kind = 'taylor'\n/\n")
    out = tmp_path / "out"
    summary = run(deck, out, quiet=True)
    assert summary["n_converted"] > 0
    res = subprocess.run([sys.executable, "-m", "fsph", "plot", str(out), "--times", "0,1,2"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert res.returncode == 0, res.stderr
    png = out / "shapes.png"
    assert png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert png.stat().st_size > 20_000
    hist = out / "history.png"
    assert hist.is_file() and hist.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not (out / "damage.png").exists()      # no damage model, no damage map


def test_plot_of_a_non_run_folder_is_a_clean_error(tmp_path):
    res = subprocess.run([sys.executable, "-m", "fsph", "plot", str(tmp_path)],
                         capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert res.returncode == 2
    assert "Traceback" not in res.stderr and "fsph.h5" in res.stderr


def test_report_tables_errors_against_references(tmp_path):
    """`fsph report` on two small decks: a table row per referenced metric
    with the computed value, the reference and the error, and a picture of
    the Taylor-type case."""
    cases = tmp_path / "cases"
    (cases / "references").mkdir(parents=True)
    (cases / "references" / "rod.json").write_text(
        '{"source": "test", "taylor": {"L_mm": 3.9, "D_mm": 2.0, "W_mm": 2.0}}')
    (cases / "rod.nml").write_text(
        rod_deck(control="end_time = 1e-6", output="reference = 'references/rod.json'")
        + "&metrics\n kind = 'taylor'\n/\n")
    (cases / "bar.nml").write_text(rod_deck(control="end_time = 1e-6"))
    res = subprocess.run([sys.executable, "-m", "fsph", "report", "--cases", str(cases),
                          "--decks", "rod,bar", "-o", str(tmp_path / "rep")],
                         capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert res.returncode == 0, res.stderr
    text = (tmp_path / "rep" / "report.md").read_text()
    rows = [line for line in text.splitlines() if line.startswith("| rod |")]
    assert len(rows) == 3 and "taylor.L_mm" in rows[0] and "%" in rows[0]
    assert (tmp_path / "rep" / "rod.png").is_file()
    missing = subprocess.run([sys.executable, "-m", "fsph", "report", "--cases", str(cases),
                              "--decks", "nothere"], capture_output=True, text=True,
                             cwd=tmp_path, timeout=300)
    assert missing.returncode == 2 and "nothere.nml" in missing.stderr


def test_plot_draws_the_damage_map_of_a_concrete_run(tmp_path, write_deck):
    """A steel rod at 600 m/s into an HJC concrete block, adaptive, 6 us:
    the snapshots carry the damage field, the crushed zone is damaged, and
    `fsph plot` adds damage.png; a run without damage draws none."""
    deck = write_deck(rod_deck(control="mode = 'adaptive'\n end_time = 6e-6",
                               material="name = 'steel'\n library = 'projectile_bilinear_concrete'",
                               body="velocity_z = -600.0\n n_radial = 4\n n_axial = 16\n"
                                    " z_base = 0.05e-3", boundary=False)
                      + "&material\n name = 'concrete'\n library = 'concrete_48mpa_hjc'\n/\n"
                      "&body\n name = 'block'\n material = 'concrete'\n radius = 6.0e-3\n"
                      " length = 4.0e-3\n z_base = -4.0e-3\n n_radial = 12\n n_axial = 8\n/\n")
    out = tmp_path / "out"
    run(deck, out, quiet=True)
    import h5py
    with h5py.File(out / "fsph.h5") as h5:
        snaps = h5["snapshots"]
        last = snaps[sorted(snaps)[-1]]
        damage = last["damage"][...]
        if "particles" in last:
            damage = np.concatenate([damage, last["particles/damage"][...]])
    assert damage.max() > 0.5 and damage.min() == 0.0
    res = subprocess.run([sys.executable, "-m", "fsph", "plot", str(out), "--times", "2,6"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert res.returncode == 0, res.stderr
    png = out / "damage.png"
    assert str(png) in res.stdout
    assert png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("args, expected", [
    (["--times", ""], "--times: expected times in microseconds >= 0"),
    (["--times=-5,10"], "--times: expected times in microseconds >= 0"),
    (["--times", "nan"], "--times: expected times in microseconds >= 0"),
    (["--dpi", "0"], "--dpi: expected an integer from 10 to 2400, got 0"),
    (["-o", "shapes.txt"], "expected a file name ending in .png, .pdf, .svg"),
    (["-o", "no_such_folder/shapes.png"], "expected an existing folder, no no_such_folder"),
    (["--field", "eps_p,mises", "-o", "f.png"], "-o f.png: names one picture, --field asks for 2"),
    (["--field", "damage"], "--field damage: no material of this run has a damage model"),
])
def test_bad_plot_arguments_are_one_line_errors(tmp_path, args, expected):
    """Each bad argument of `fsph plot` is refused before anything is drawn:
    exit 2, one line, no picture."""
    out = tmp_path / "out"
    run(_small_deck(tmp_path), out, quiet=True)
    res = subprocess.run([sys.executable, "-m", "fsph", "plot", str(out), *args],
                         capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert expected in res.stderr, res.stderr
    assert not list(out.glob("*.png"))


def _small_deck(tmp_path):
    deck = tmp_path / "rod.nml"
    deck.write_text(rod_deck())
    return deck


def test_version_prints_the_version_and_exits_0(tmp_path):
    import fsph
    res = subprocess.run([sys.executable, "-m", "fsph", "--version"], capture_output=True,
                         text=True, cwd=tmp_path, timeout=300)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == f"fsph {fsph.__version__}"


def test_panels_carry_the_drawn_times_and_a_line_names_the_nearest(elastic_run, monkeypatch,
                                                                    capsys):
    """Times without a snapshot at them: each panel is titled with the time
    of the snapshot drawn and one printed line says which snapshot was drawn
    for which time; a time at a snapshot is not in it."""
    from fsph.plot import format_us
    times = _snapshot_times_us(elastic_run)       # 0, about 1/7, ..., 1 µs
    code, lines, figures = plot_cli(monkeypatch, capsys, elastic_run, "--times", "0.2,1")
    assert code == 0
    near = min(times, key=lambda t: abs(t - 0.2))
    assert _titles(figures["shapes.png"]) == [f"{format_us(near)} µs", "1 µs"]
    notes = [line for line in lines if line.startswith("fsph plot:")]
    assert notes == [f"fsph plot: drew the nearest snapshots: 0.2 µs → {format_us(near)} µs"]
    code, lines, _ = plot_cli(monkeypatch, capsys, elastic_run, "--times", "0,1")
    assert code == 0 and not [line for line in lines if line.startswith("fsph plot:")]


def test_default_times_spread_over_the_run(elastic_run, monkeypatch, capsys):
    """Without --times: four distinct snapshots from the first to the last
    (the 1 µs rod drew four identical panels at the 10-60 µs of a Taylor rod)."""
    code, lines, figures = plot_cli(monkeypatch, capsys, elastic_run)
    assert code == 0 and not [line for line in lines if line.startswith("fsph plot:")]
    titles = _titles(figures["shapes.png"])
    assert len(titles) == 4 == len(set(titles))
    assert titles[0] == "0 µs" and titles[-1] == "1 µs"


def test_times_on_one_snapshot_share_a_panel(elastic_run, monkeypatch, capsys):
    code, lines, figures = plot_cli(monkeypatch, capsys, elastic_run, "--times", "10,20")
    assert code == 0
    assert _titles(figures["shapes.png"]) == ["1 µs"]
    assert [line for line in lines if line.startswith("fsph plot:")] == [
        "fsph plot: drew the nearest snapshots: 10 µs → 1 µs, 20 µs → 1 µs; "
        "2 times fall on 1 snapshot, drawn once"]


def test_shapes_keep_their_labels_and_explain_the_marks(taylor_run, monkeypatch, capsys):
    """Particles at z = 0: every axis label and the legend lie inside the
    figure, the legend clear of the panels; it names the rod's elements and
    particles and says what L, D and W are (fsph.metrics.taylor)."""
    code, _, figures = plot_cli(monkeypatch, capsys, taylor_run)
    assert code == 0
    fig = figures["shapes.png"]
    renderer = fig.canvas.get_renderer()
    with h5py.File(taylor_run / "fsph.h5", "r") as h5:
        snaps = h5["snapshots"]
        assert snaps[sorted(snaps)[-1]]["particles/x"][:, 1].min() < 0.2e-3
    for ax in fig.axes:
        for label in (ax.xaxis.label, ax.yaxis.label):
            if label.get_text():
                assert _inside(label.get_window_extent(renderer), fig.bbox), label.get_text()
    legend = fig.legends[0].get_window_extent(renderer)
    assert _inside(legend, fig.bbox)
    assert not any(legend.overlaps(ax.get_window_extent(renderer)) for ax in fig.axes)
    texts = _legend_texts(fig)
    assert texts[:2] == ["rod: elements", "rod: particles"]
    assert "experiment L = 3.9 mm: final length" in texts
    assert any(t.startswith("experiment D = 2.4 mm: impact-face diameter") for t in texts)
    assert "experiment W = 2.1 mm: diameter 0.8 mm above the impact face" in texts


def test_shapes_legend_names_only_what_is_drawn(elastic_run, monkeypatch, capsys):
    code, _, figures = plot_cli(monkeypatch, capsys, elastic_run)
    assert code == 0
    assert _legend_texts(figures["shapes.png"]) == ["rod: elements"]


def test_shapes_colour_each_body(block_run, monkeypatch, capsys):
    """Projectile and target in colours of their own, in the panels and the legend."""
    from matplotlib.colors import to_hex
    from matplotlib.collections import PolyCollection
    code, _, figures = plot_cli(monkeypatch, capsys, block_run, "--times", "6")
    assert code == 0
    fig = figures["shapes.png"]
    legend = fig.legends[0]
    colours = {t.get_text(): to_hex(h.get_color())
               for t, h in zip(legend.get_texts(), legend.legend_handles)}
    assert colours["rod: elements"] != colours["block: elements"]
    faces = {to_hex(c) for coll in fig.axes[0].collections if isinstance(coll, PolyCollection)
             for c in coll.get_facecolors()}
    assert {colours["rod: elements"], colours["block: elements"]} <= faces
    # no hole yet (no framing by the hole): the whole block is in the panel
    assert fig.axes[0].get_ylim()[0] <= -4.0


def test_history_has_title_energy_error_and_no_landing_step(elastic_run, monkeypatch, capsys):
    """history.png: titled with the case, a curve of the relative energy
    error ending on summary.json's, and a time-step curve without the steps
    shortened to land on the end time."""
    import json
    code, _, figures = plot_cli(monkeypatch, capsys, elastic_run)
    assert code == 0
    fig = figures["history.png"]
    summary = json.loads((elastic_run / "summary.json").read_text())
    assert fig._suptitle.get_text() == "test rod"
    axes = {ax.get_ylabel(): ax for ax in fig.axes}
    error = axes["energy error [%]"].get_lines()[0].get_ydata()
    assert error[-1] == pytest.approx(100 * summary["energy"]["relative_error"], rel=1e-9)
    with h5py.File(elastic_run / "fsph.h5", "r") as h5:
        time = h5["history/time"][...] * 1e6
        velocity_time = h5["history/time"][...] - 0.5 * h5["history/dt"][...]
    assert time[-1] == pytest.approx(1.0)
    steps = axes["time step [ns]"].get_lines()[0].get_xdata()
    assert list(steps) == list(time[1:-1])        # no first row (no step), no landing
    # the rod stands on a rigid plane: its force, which integrates to the
    # impulse over the times of the half-step velocities
    force = axes["rigid-plane force [kN]"].get_lines()[0].get_ydata() * 1e3
    assert np.sum(force[1:] * np.diff(velocity_time)) == pytest.approx(
        summary["rigid_planes"]["impulse_z_N_s"], rel=1e-9)
    assert summary["rigid_planes"]["impulse_z_N_s"] > 0.0


def test_perforation_draws_the_experimental_residual_velocity(block_run, monkeypatch, capsys):
    """perforation.png: the reference's residual velocity is a marked point
    with a legend entry beside the run's velocity history."""
    code, _, figures = plot_cli(monkeypatch, capsys, block_run)
    assert code == 0
    fig = figures["perforation.png"]
    assert fig._suptitle.get_text() == "test rod"
    velocity = next(ax for ax in fig.axes
                    if ax.get_ylabel() == "projectile velocity\nalong the strike [m/s]")
    assert "experiment: residual velocity 555 m/s" in _legend_texts(fig)
    marks = [line for line in velocity.get_lines() if line.get_label().startswith("experiment")]
    assert len(marks) == 1 and list(marks[0].get_ydata()) == [555.0]
    assert marks[0].get_marker() not in (None, "None", "")


def test_damage_map_honours_times_and_greys_the_undamaged_body(block_run, monkeypatch, capsys):
    """damage.png: the panels at the requested times (as shapes.png), and
    the steel rod, never damaged, in the neutral colour named in the legend
    rather than the colour of undamaged concrete."""
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import to_hex
    from fsph.plot import UNDAMAGED_COLOUR, format_us
    code, _, figures = plot_cli(monkeypatch, capsys, block_run, "--times", "2.2,6")
    assert code == 0
    times = _snapshot_times_us(block_run)
    expected = [f"{format_us(min(times, key=lambda t: abs(t - r)))} µs" for r in (2.2, 6.0)]
    fig = figures["damage.png"]
    assert _titles(fig) == expected == _titles(figures["shapes.png"])
    assert _legend_texts(fig) == ["rod: no damage in this run"]
    for ax in (ax for ax in fig.axes if ax.get_title()):
        polys = [c for c in ax.collections if isinstance(c, PolyCollection)]
        neutral = [c for c in polys if c.get_array() is None]
        assert neutral and all(to_hex(f) == UNDAMAGED_COLOUR
                               for c in neutral for f in c.get_facecolors())
        assert any(c.get_array() is not None and c.get_array().max() > 0.0 for c in polys)


def test_times_are_in_microseconds_written_µs(block_run, monkeypatch, capsys):
    """Every label, title and legend of the five pictures, the printed lines
    and the help of `fsph plot` write µs, never us."""
    import re
    from matplotlib.text import Text
    from fsph.cli import _parser
    code, lines, figures = plot_cli(monkeypatch, capsys, block_run, "--times", "2,6")
    assert code == 0
    assert set(figures) == {"shapes.png", "history.png", "perforation.png", "damage.png", "bodies.png"}
    texts = [t.get_text() for fig in figures.values() for t in fig.findobj(Text)]
    texts += lines + [_parser()._subparsers._group_actions[0].choices["plot"].format_help()]
    assert not [t for t in texts if re.search(r"\bus\b", t)]
    assert sum("µs" in t for t in texts) >= 8
    assert figures["history.png"].axes[-1].get_xlabel() == "t [µs]"
    assert figures["perforation.png"].axes[-1].get_xlabel() == "t [µs]"
    assert any("µs" in line for line in lines)


def _field_range(run_dir, dataset, times_us, scale=1.0):
    """Least and largest value of a field over the snapshots at times_us
    [µs], elements and particles, from fsph.h5 (dataset 'mises': the von
    Mises stress of the deviator of the stored stress) times scale."""
    values = []
    with h5py.File(run_dir / "fsph.h5", "r") as h5:
        snaps = h5["snapshots"]
        for g in (snaps[k] for k in snaps if k.isdigit()):
            if not any(g.attrs["time"] * 1e6 == t for t in times_us):
                continue
            for prefix in ("", "particles/"):
                if dataset != "mises":
                    values.append(g[prefix + dataset][...]) if prefix + dataset in g else None
                    continue
                if prefix + "stress" not in g:
                    continue
                stress = g[prefix + "stress"]
                col = dict(zip(stress.attrs["components"].split(","), stress[...].T))
                mean = (col["rr"] + col["zz"] + col["tt"]) / 3
                dev = [col[c] - mean for c in ("rr", "zz", "tt")]
                values.append(np.sqrt(1.5 * (sum(d ** 2 for d in dev) + 2 * col["rz"] ** 2)))
    values = np.concatenate(values) * scale
    return values.min(), values.max()


def test_field_pictures_draw_elements_and_particles_on_one_scale(taylor_run, monkeypatch,
                                                                 capsys):
    """--field eps_p,pressure,mises on the adaptive rod: field_NAME.png for
    each and no other picture, panels at the snapshots of --times (the
    nearest named as for shapes.png), elements and particles both drawn on
    each side of the axis, every one on the colour scale from the least to
    the largest value over the panels, a colour bar naming the quantity and
    its unit."""
    from matplotlib.collections import PathCollection, PolyCollection
    from fsph.plot import format_us
    times = _snapshot_times_us(taylor_run)
    drawn = [min(times, key=lambda t: abs(t - r)) for r in (0.0, 1.1, 2.0)]
    code, lines, figures = plot_cli(monkeypatch, capsys, taylor_run, "--field",
                                    "eps_p,pressure,mises", "--times", "0,1.1,2")
    assert code == 0
    assert set(figures) == {"field_eps_p.png", "field_pressure.png", "field_mises.png"}
    note = f"fsph plot: drew the nearest snapshots: 1.1 µs → {format_us(drawn[1])} µs"
    assert lines == [note, *(str(taylor_run / f"field_{name}.png")
                             for name in ("eps_p", "pressure", "mises"))]
    for name, dataset, scale, label in (
            ("eps_p", "plastic_strain", 1.0, "equivalent plastic strain ε_p [-]"),
            ("pressure", "pressure", 1e-9, "pressure p, > 0 in compression [GPa]"),
            ("mises", "mises", 1e-9, "von Mises stress σ_eq [GPa]")):
        fig = figures[f"field_{name}.png"]
        panels = [ax for ax in fig.axes if ax.get_title()]
        (bar,) = [ax for ax in fig.axes if not ax.get_title()]
        assert bar.get_ylabel() == label
        assert [ax.get_title() for ax in panels] == [f"{format_us(t)} µs" for t in drawn]
        assert fig._suptitle.get_text().startswith("test rod\n")
        lo, hi = _field_range(taylor_run, dataset, drawn, scale)
        assert hi > lo
        for ax in panels:
            for coll in ax.collections:
                assert coll.norm.vmin == pytest.approx(lo, rel=1e-12, abs=1e-12)
                assert coll.norm.vmax == pytest.approx(hi, rel=1e-12)
        last = panels[-1].collections
        elements = [c for c in last if isinstance(c, PolyCollection) and c.get_array() is not None]
        particles = [c for c in last if isinstance(c, PathCollection) and c.get_array() is not None]
        assert len(elements) == 2 and len(particles) == 2           # r > 0 and mirrored
        assert min(c.get_offsets()[:, 0].min() for c in particles) < 0.0 \
            < max(c.get_offsets()[:, 0].max() for c in particles)
        assert max(c.get_array().max() for c in last) == pytest.approx(
            _field_range(taylor_run, dataset, drawn[-1:], scale)[1], rel=1e-12)


def test_material_picture_names_the_deck_materials(block_run, monkeypatch, capsys):
    """--field material: one colour per material, the legend naming the
    deck's materials (not its bodies); --field damage: the steel, which has
    no damage model, in the neutral colour and named so."""
    from matplotlib.colors import to_hex
    code, _, figures = plot_cli(monkeypatch, capsys, block_run, "--field", "material,damage",
                                "--times", "6")
    assert code == 0
    fig = figures["field_material.png"]
    legend = fig.legends[0]
    assert [t.get_text() for t in legend.get_texts()] == ["steel", "concrete"]
    colours = [to_hex(h.get_facecolor()) for h in legend.legend_handles]
    drawn = {to_hex(c) for c in fig.axes[0].collections for c in c.get_facecolors()}
    assert len(set(colours)) == 2 and set(colours) <= drawn
    assert len(fig.axes) == 1                   # no colour bar
    damage = figures["field_damage.png"]
    assert _legend_texts(damage) == ["steel: no damage model"]
    assert [ax.get_ylabel() for ax in damage.axes if not ax.get_title()] == ["damage D [-]"]


@pytest.mark.parametrize("field, why", [
    ("damage", "no material of this run has a damage model"),
    ("temperature", "no material of this run has a temperature model"),
    ("strain", "no such field"),
])
def test_a_field_the_run_lacks_is_a_one_line_error(taylor_run, capsys, field, why):
    """Armco iron has neither damage nor a temperature model: exit 2, one
    line naming the field, why, and the fields the run has; nothing drawn."""
    from fsph.cli import main
    before = {p: p.stat().st_mtime_ns for p in taylor_run.glob("*.png")}
    assert main(["plot", str(taylor_run), "--field", f"eps_p,{field}"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"fsph: error: --field {field}: {why}")
    assert err[0].endswith("; fields of this run: eps_p, pressure, mises, density, material")
    assert {p: p.stat().st_mtime_ns for p in taylor_run.glob("*.png")} == before


def test_history_draws_each_bodys_force(block_run, monkeypatch, capsys):
    """history.png of a two-body run: a panel of the axial force on each
    body, one curve per body; nothing else acts on them, so the impulses
    under the two curves are equal and opposite within 0.5 % (the bar of
    the momentum balance of the perforation runs). The energy the contact
    corrections removed is labelled as removed, as erosion's and the
    planes'."""
    code, _, figures = plot_cli(monkeypatch, capsys, block_run)
    assert code == 0
    axes = {ax.get_ylabel(): ax for ax in figures["history.png"].axes}
    curves = {line.get_label(): (line.get_xdata(), line.get_ydata())
              for line in axes["axial force on\neach body [kN]"].get_lines()
              if not line.get_label().startswith("_")}
    assert set(curves) == {"rod", "block"}
    # the energy the contact removed is named as the other energies removed,
    # apart from the work each body received through contact (bodies.png)
    energies = _legend_texts(figures["history.png"])
    assert "removed by contact" in energies and "contact work" not in energies
    impulse = {name: np.sum(f[1:] * np.diff(t)) for name, (t, f) in curves.items()}
    assert impulse["rod"] > 0.0
    assert abs(impulse["rod"] + impulse["block"]) <= 0.005 * impulse["rod"]


def test_bodies_png_draws_each_bodys_books(block_run, monkeypatch, capsys):
    """bodies.png of a two-body run: a panel per body with its kinetic and
    internal energy and the energy received through contact; what the rod
    gives the block receives but for the kinetic energy the slide lines'
    corrections removed (the history's contact column), and a book that
    stays zero is not drawn (hourglass work: the block's converted
    particles have some, the rod stays elements)."""
    import h5py
    code, printed, figures = plot_cli(monkeypatch, capsys, block_run)
    assert code == 0
    assert str(block_run / "bodies.png") in printed
    curves = {}
    for ax in figures["bodies.png"].axes:
        body = ax.get_ylabel().split(":")[0]
        curves[body] = {line.get_label(): line.get_ydata() for line in ax.get_lines()
                        if not line.get_label().startswith("_")}
    assert set(curves) == {"rod", "block"}
    for books in curves.values():
        assert {"kinetic", "internal", "received through contact"} <= set(books)
    with h5py.File(block_run / "fsph.h5") as h5:
        removed = h5["history/contact"][-1]
    given, received = curves["rod"]["received through contact"][-1], curves["block"]["received through contact"][-1]
    assert "hourglass work" in curves["block"] and "hourglass work" not in curves["rod"]
    assert given < 0.0 < received
    assert given + received == pytest.approx(-removed, abs=1e-9 * received)


def test_history_option_draws_the_time_histories_only(block_run, monkeypatch, capsys):
    """`fsph plot DIR --history`: history.png, bodies.png and
    perforation.png of the two-body run, no shapes or damage map; with
    --field, --times or -o it is a one-line error, nothing drawn."""
    from fsph.cli import main
    code, printed, figures = plot_cli(monkeypatch, capsys, block_run, "--history")
    assert code == 0
    assert set(figures) == {"history.png", "bodies.png", "perforation.png"}
    assert printed == [str(block_run / name) for name in ("history.png", "perforation.png", "bodies.png")]
    for extra in (["--times", "2"], ["--field", "eps_p"], ["-o", str(block_run / "x.png")]):
        before = {p: p.stat().st_mtime_ns for p in block_run.glob("*.png")}
        assert main(["plot", str(block_run), "--history", *extra]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("fsph: error: --history: ")
        assert extra[0] in err[0]
        assert {p: p.stat().st_mtime_ns for p in block_run.glob("*.png")} == before


def test_gauges_png_draws_each_gauge(tmp_path, monkeypatch, capsys):
    """A run with two gauges: gauges.png has a curve per gauge in every
    panel, named with its kind, starting at the rod's striking velocity
    (-50 m/s here), and a run without gauges draws no gauges.png."""
    deck = tmp_path / "rod.nml"
    deck.write_text(rod_deck(body="velocity_z = -50.0")
                    + "&gauge\n name = 'top'\n point = 0.0, 3.5e-3\n kind = 'material'\n/\n"
                    + "&gauge\n name = 'face'\n point = 0.5e-3, 0.1e-3\n kind = 'material'\n/\n")
    run(deck, tmp_path / "out", quiet=True)
    code, _, figures = plot_cli(monkeypatch, capsys, tmp_path / "out")
    assert code == 0
    axes = {ax.get_ylabel(): ax for ax in figures["gauges.png"].axes}
    for label in ("pressure [GPa]", "axial velocity [m/s]"):
        names = [line.get_label() for line in axes[label].get_lines()]
        assert sorted(names) == ["face (material)", "top (material)"]
    for line in axes["axial velocity [m/s]"].get_lines():
        assert line.get_ydata()[0] == pytest.approx(-50.0)
    assert (tmp_path / "out" / "gauges.png").is_file()


# ---- a run folder fsph plot cannot read -------------------------------------------
def _plot_refused(run_dir, cwd, *args, env=None):
    """`fsph plot RUN_DIR ARGS` in a child process that must be refused:
    exit 2, one line without a traceback, no picture; returns the line."""
    res = subprocess.run([sys.executable, "-m", "fsph", "plot", str(run_dir), *args],
                         capture_output=True, text=True, cwd=cwd, timeout=300, env=env)
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 2 and "Traceback" not in res.stderr and len(lines) == 1, res.stderr
    assert not [png for png in Path(run_dir).glob("*.png") if png.is_file()]
    return lines[0]


def _copy_run(run_dir, tmp_path):
    """A copy of a run folder to spoil, without the pictures drawn in it."""
    import shutil
    return Path(shutil.copytree(run_dir, tmp_path / "run", ignore=shutil.ignore_patterns("*.png")))


@pytest.mark.parametrize("text, why", [
    ('{"status": ', "(not JSON: Expecting value: line 1 column 12"),
    ("[]", "(an array, not a JSON object)"),
    ('{"case": "rod"}', "(no status)"),
    ('{"status": "completed", "metrics": []}', "(metrics is not a JSON object)"),
])
def test_a_summary_that_is_not_a_runs_is_a_one_line_error(elastic_run, tmp_path, text, why):
    """summary.json cut short, or JSON that is not a run's summary: exit 2
    naming the file and what is wrong (were tracebacks)."""
    out = _copy_run(elastic_run, tmp_path)
    (out / "summary.json").write_text(text)
    line = _plot_refused(out, tmp_path)
    assert f"{out / 'summary.json'}: not a summary of `fsph run` {why}" in line


@pytest.mark.parametrize("group, says", [
    ("snapshots", "no 'snapshots' group"), ("history", "no 'history' group"),
    ("history/total", "no history/total"),
])
def test_a_run_file_without_its_groups_is_a_one_line_error(elastic_run, tmp_path, group, says):
    """fsph.h5 without its snapshots or history (was a KeyError traceback):
    exit 2 naming the file and what it lacks."""
    out = _copy_run(elastic_run, tmp_path)
    with h5py.File(out / "fsph.h5", "a") as h5:
        del h5[group]
    assert f"{out / 'fsph.h5'}: {says}" in _plot_refused(out, tmp_path)


def test_a_run_file_that_cannot_be_read_is_not_a_picture_not_written(elastic_run, tmp_path):
    """A cut-short fsph.h5 and one a run holds locked are refused as files
    that cannot be read (were "cannot write the picture"), the lock as a
    run writing it; a path to fsph.h5 itself asks for the run's folder
    (was "(no fsph.h5)")."""
    import os
    out = _copy_run(elastic_run, tmp_path)
    line = _plot_refused(out / "fsph.h5", tmp_path)
    assert f"{out / 'fsph.h5'}: a file; expected the output folder of `fsph run`" in line
    env = {k: v for k, v in os.environ.items() if k != "HDF5_USE_FILE_LOCKING"}
    with h5py.File(out / "fsph.h5", "a"):            # a run writing it holds HDF5's lock
        line = _plot_refused(out, tmp_path, env=env)
    assert f"{out / 'fsph.h5'}: cannot read it now: a run is writing it" in line
    assert "cannot write" not in line
    with open(out / "fsph.h5", "r+b") as fh:
        fh.truncate(4000)
    line = _plot_refused(out, tmp_path)
    assert f"{out / 'fsph.h5'}: cannot read it, damaged or cut short (" in line
    assert "truncated file" in line and "cannot write" not in line


def test_a_picture_that_cannot_be_written_says_so(elastic_run, tmp_path):
    """-o into a folder that cannot take the file: the picture's name and
    that it cannot be written."""
    out = _copy_run(elastic_run, tmp_path)
    (tmp_path / "shapes.png").mkdir()
    line = _plot_refused(out, tmp_path, "-o", str(tmp_path / "shapes.png"))
    assert f"{tmp_path / 'shapes.png'}: cannot write the picture" in line


def test_debris_panel_before_the_clouds_shows_both_bodies(tmp_path, monkeypatch, capsys):
    """Case 1 of the debris clouds, coarse, a 10 mm plate, 0.4 us: the
    panel at 0 us frames the flyer and the plate where they start (it
    framed the flyer only: no cloud, no fronts yet)."""
    import f90nml
    from conftest import CASES
    nml = f90nml.read(CASES / "debris_cu_al_1.nml")
    nml["output"].update({"n_snapshots": 2, "n_progress": 2, "vtu": False, "checkpoint": False})
    del nml["output"]["reference"]
    nml["control"]["end_time"] = 0.4e-6
    nml["body"][0].update({"n_radial": 14, "n_axial": 9})
    nml["body"][1].update({"radius": 10e-3, "fine_radius": 10e-3, "n_radial": 25, "n_coarse": 0,
                           "n_axial": 7})
    nml.write(tmp_path / "debris.nml", force=True)
    run(tmp_path / "debris.nml", tmp_path / "out", quiet=True)
    code, _, figures = plot_cli(monkeypatch, capsys, tmp_path / "out", "--times", "0")
    assert code == 0
    (ax,) = [ax for ax in figures["shapes.png"].axes if ax.get_title()]
    z_low, z_high = ax.get_ylim()
    assert z_low < -2.87 and z_high > 3.45          # the plate's rear face, the flyer's top
    assert ax.get_xlim()[1] > 5.565                  # the flyer's radius


def test_debris_panel_frames_the_ejecta_up_to_their_height():
    """The panel's half-width reaches the back-splash that sets the ejecta
    height (a point 22 mm out, 20 mm uprange of the face, with the height
    25 mm: a sphere's bumper throws its ejecta wider than either cloud),
    and not a stray point beyond the height (35 mm out, 40 mm uprange)."""
    from fsph.plot import _debris_extent, _ejecta_radius
    x = np.array([[0.0, -30.0], [8.0, -20.0], [22.0, 20.0], [35.0, 40.0], [29.0, -1.0]]) * 1e-3
    snapshot = {"particles": None, "particles/x": x, "particles/body": np.array([0, 0, 1, 1, 1])}
    rec = {"flyer": "sphere", "target": "bumper"}
    reach = _ejecta_radius(snapshot, ["sphere", "bumper"], rec, 0.0, -1.0, 25.0)
    assert reach == pytest.approx(22.0)
    series = {"ejecta_height_mm": [25.0], "target_front_0p5pct_mm": [31.0],
              "flyer_front_0p5pct_mm": [30.0], "target_cloud_radius_mm": [12.0],
              "flyer_cloud_radius_mm": [9.0], "hole_diameter_mm": [14.0]}
    half_width, (z_low, z_high) = _debris_extent(series, 0, {}, 0.0, -1.0, None, reach)
    assert 22.0 < half_width < 35.0
    assert z_high > 25.0 and z_low < -31.0


def test_pressure_scale_keeps_zero_neutral_and_round_off_unsigned():
    """The pressure picture's colour of zero is the diverging map's middle
    (neither tension nor compression) whatever the range: a compressed body
    whose unloaded part carries round-off tension (-3e-11 GPa against
    1.1 GPa, as the elastic bar) draws that round-off as zero, on a colour
    bar from 0 to the peak; a range with real tension stays diverging
    about zero; a field in tension alone draws from its least value to 0."""
    import matplotlib.pyplot as plt
    from fsph.plot import _field_scale
    middle = plt.get_cmap("coolwarm")(0.5)

    def colour(scale, value):
        cmap, norm = scale
        return np.array(cmap(norm(np.array([value]))))[0]
    compressed = _field_scale("pressure", -3e-11, 1.1)
    assert compressed[1].vmin == 0.0 and compressed[1].vmax == 1.1
    assert colour(compressed, -3e-11) == pytest.approx(colour(compressed, 0.0))
    assert colour(compressed, 0.0) == pytest.approx(middle, abs=0.01)
    assert colour(compressed, 1.1) == pytest.approx(plt.get_cmap("coolwarm")(1.0), abs=0.01)
    both = _field_scale("pressure", -0.3, 1.1)
    assert (both[1].vmin, both[1].vmax) == (-0.3, 1.1)
    assert colour(both, 0.0) == pytest.approx(middle, abs=0.01)
    assert colour(both, -0.3) == pytest.approx(plt.get_cmap("coolwarm")(0.0), abs=0.01)
    stretched = _field_scale("pressure", -0.4, -0.1)
    assert (stretched[1].vmin, stretched[1].vmax) == (-0.4, 0.0)
    assert colour(stretched, 0.0) == pytest.approx(middle, abs=0.01)
    # the other fields keep their least-to-largest scale
    assert (_field_scale("mises", 0.2, 1.5)[1].vmin, _field_scale("mises", 0.2, 1.5)[1].vmax) == (0.2, 1.5)


def test_panel_titles_of_a_slender_rod_stand_apart(tmp_path, monkeypatch, capsys):
    """A rod ten times longer than its diameter (the elastic bar's
    proportions): the field picture's panel titles, the snapshots' times,
    do not run into each other."""
    deck = tmp_path / "bar.nml"
    deck.write_text(rod_deck(control="", body="").replace("length = 4.0e-3", "length = 20.0e-3")
                    .replace("n_axial = 12", "n_axial = 40").replace("end_time = 1.0e-6",
                                                                    "end_time = 0.3e-6")
                    .replace("n_snapshots = 2", "n_snapshots = 3"))
    run(deck, tmp_path / "out", quiet=True)
    code, _, figures = plot_cli(monkeypatch, capsys, tmp_path / "out", "--field", "pressure")
    assert code == 0
    fig = figures["field_pressure.png"]
    renderer = fig.canvas.get_renderer()
    titles = [ax.title.get_window_extent(renderer) for ax in fig.axes if ax.get_title()]
    assert len(titles) == 4
    assert all(a.x1 < b.x0 for a, b in zip(titles, titles[1:]))


def test_perforation_velocity_of_a_rebounding_projectile_goes_below_zero(tmp_path):
    """perforation.png draws the projectile's velocity along the striking
    direction, as the residual velocity is measured: a projectile striking
    at 300 m/s towards -z that stops and flies back at 40 m/s ends at
    -40 m/s, not at +40 m/s as if it went on, and the legend says it
    rebounded; one striking towards +z is drawn positive."""
    import json
    from fsph.plot import _perforation_figure
    for velocity_z, last in (([-300.0, -120.0, 0.0, 40.0], -40.0), ([250.0, 200.0], 200.0)):
        n = len(velocity_z)
        (tmp_path / "summary.json").write_text(json.dumps({
            "status": "completed", "title": "rebound",
            "metrics": {"series": {"time_us": [10.0 * k for k in range(n)],
                                   "velocity_z_m_s": velocity_z,
                                   "penetration_mm": [0.0] * n,
                                   "hole_diameter_mm": [None] * n}}}))
        fig = _perforation_figure(tmp_path)
        (ax,) = [ax for ax in fig.axes if ax.get_ylabel().startswith("projectile velocity")]
        assert ax.get_ylabel().endswith("[m/s]")
        drawn = ax.get_lines()[0].get_ydata()
        assert drawn[0] == abs(velocity_z[0]) and drawn[-1] == last
        assert ("rebounded" in _legend_texts(fig)[0]) == (last < 0.0)
