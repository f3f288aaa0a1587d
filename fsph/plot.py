"""Pictures of a run: the deformed body at chosen times, elements and
particles in different colours, with the experimental Taylor lengths marked
(as Xiao et al. 2012 Fig. 8); fields (plastic strain, pressure, von Mises
stress, temperature, damage, density, material) on the elements and
particles at chosen times. Reads the outputs of `fsph run` (fsph.h5,
summary.json); matplotlib with the Agg backend, no display needed."""

import json
import textwrap
from pathlib import Path

import h5py
import numpy as np

from .errors import InputError
from .output import STRESS_COMPONENTS
from .points import von_mises

#: colours of the bodies in deck order (repeating): (elements, particles);
#: the first as Xiao et al. 2012 Fig. 8
BODY_COLOURS = (("#4a7ab5", "#d9822b"),     # blue, orange
                ("#a0a0a0", "#7b3294"),     # grey, purple
                ("#74a96b", "#c2185b"),     # green, magenta
                ("#d4b44a", "#2b8c8c"))     # ochre, teal


#: the groups of fsph.h5 that every picture reads
RUN_GROUPS = ("snapshots", "history")
#: the history columns history.png draws (every run writes them)
HISTORY_COLUMNS = ("time", "dt", "kinetic", "internal", "total")
#: the entries of summary.json the pictures read as JSON objects
SUMMARY_OBJECTS = ("metrics", "reference", "energy", "material_state")
#: the JSON names of the Python types json.loads returns
JSON_TYPES = {list: "an array", str: "a string", int: "a number", float: "a number",
              bool: "a boolean", type(None): "null"}


def _not_a_summary(summary):
    """Why a parsed summary.json is not the summary of a run ("" when it
    is): `fsph run` writes a JSON object with its status, and objects
    under SUMMARY_OBJECTS."""
    if not isinstance(summary, dict):
        return f"{JSON_TYPES.get(type(summary), type(summary).__name__)}, not a JSON object"
    if not isinstance(summary.get("status"), str):
        return "no status"
    wrong = [key for key in SUMMARY_OBJECTS if key in summary and not isinstance(summary[key], dict)]
    return f"{wrong[0]} is not a JSON object" if wrong else ""


def read_summary(run_dir):
    """summary.json of a run folder as a dict; InputError (one line naming
    the file and what is wrong) where it cannot be read, is not JSON (cut
    short) or is not the summary of a run (_not_a_summary)."""
    path = Path(run_dir) / "summary.json"
    try:
        summary = json.loads(path.read_text())
    except OSError as err:
        raise InputError(f"{path}: cannot read it: {err.strerror or err}") from None
    except ValueError as err:       # not JSON, not UTF-8
        raise InputError(f"{path}: not a summary of `fsph run` (not JSON: {err})") from None
    why = _not_a_summary(summary)
    if why:
        raise InputError(f"{path}: not a summary of `fsph run` ({why})")
    return summary


def cannot_read(path, err):
    """The one line of a run file h5py cannot open or read: a run writing
    it (HDF5's lock, held for each write), else damaged or cut short."""
    if "unable to lock file" in str(err).lower():
        return (f"{path}: cannot read it now: a run is writing it (HDF5 could not lock the "
                f"file); try again once the write is done")
    return f"{path}: cannot read it, damaged or cut short ({err})"


def open_run_file(run_dir):
    """fsph.h5 of a run folder, open for reading (an h5py.File, to use in
    a `with`); InputError (cannot_read) where HDF5 cannot open it."""
    path = Path(run_dir) / "fsph.h5"
    try:
        return h5py.File(path, "r")
    except OSError as err:
        raise InputError(cannot_read(path, err)) from None


def check_run_file(run_dir):
    """InputError (one line naming the file) unless the run's fsph.h5
    opens, has the groups RUN_GROUPS, the history columns HISTORY_COLUMNS
    and a complete snapshot, and every object in it can be opened (a
    damaged header shows here, not halfway through a picture)."""
    path = Path(run_dir) / "fsph.h5"
    with open_run_file(run_dir) as h5:
        try:
            h5.visititems(lambda name, obj: None)
            for group in RUN_GROUPS:
                if not isinstance(h5.get(group), h5py.Group):
                    raise InputError(f"{path}: no '{group}' group (not written by `fsph run`, "
                                     f"or damaged)")
            missing = [c for c in HISTORY_COLUMNS if c not in h5["history"]]
            if missing:
                raise InputError(f"{path}: no history/{missing[0]} (not written by `fsph run`, "
                                 f"or damaged)")
            if not _snapshots(h5):
                raise InputError(f"{path}: no complete snapshot to draw")
        except (KeyError, OSError, RuntimeError, ValueError) as err:
            raise InputError(cannot_read(path, err)) from None


def _snapshots(h5):
    """(time, group) of every complete snapshot, in time order (a snapshot
    being written, or cut short, has no number yet)."""
    snaps = h5["snapshots"]
    return sorted(((snaps[k].attrs["time"], snaps[k]) for k in snaps if k.isdigit()),
                  key=lambda t: t[0])


#: panels of a picture drawn without --times
DEFAULT_PANELS = 4


def format_us(t_us):
    """A time [µs] as panel titles and notes print it: four significant
    digits, so that a snapshot near a requested time does not look at it."""
    return f"{t_us:.4g}"


def _same_time(a_us, b_us):
    """Whether two times [µs] print the same (format_us)."""
    return format_us(a_us) == format_us(b_us)


def choose_snapshots(snaps, times_us=None, fractions=None, n=DEFAULT_PANELS):
    """The snapshots to draw, each once, in time order: a list of
    (requested times [µs], time [s], group). With times_us, the snapshot
    nearest each requested time (requests that share a snapshot share its
    panel); without, `n` snapshots spread evenly in time over the run (the
    targets `fractions` of the way from the first snapshot to the last,
    default evenly from the first to the last; each target takes the nearest
    snapshot not yet taken, so a run with n snapshots or more gets n distinct
    panels), with no requested times."""
    if times_us is None:
        start, end = snaps[0][0], snaps[-1][0]
        fractions = np.linspace(0.0, 1.0, n) if fractions is None else fractions
        free = list(range(len(snaps)))
        picked = []
        for f in fractions:
            if not free:
                break
            target = start + f * (end - start)
            k = min(free, key=lambda i: abs(snaps[i][0] - target))
            free.remove(k)
            picked.append(k)
        return [([], snaps[k][0], snaps[k][1]) for k in sorted(picked)]
    requests = {}
    for t in times_us:
        k = int(np.argmin([abs(s[0] * 1e6 - t) for s in snaps]))
        requests.setdefault(k, []).append(t)
    return [(requests[k], snaps[k][0], snaps[k][1]) for k in sorted(requests)]


def snapshot_choice(run_dir, times_us):
    """(requested time, drawn snapshot's time) [µs] for each of times_us
    (the nearest snapshot of the run in run_dir, as the pictures draw it)."""
    with open_run_file(run_dir) as h5:
        chosen = choose_snapshots(_snapshots(h5), times_us)
    return [(t, time * 1e6) for requested, time, _ in chosen for t in requested]


def nearest_note(pairs):
    """One line for `fsph plot` when a requested time has no snapshot at
    it: each such request and the time of the snapshot drawn for it [µs]
    (and, when requests fall on one snapshot, that it is drawn once); None
    when every requested time has a snapshot of its own at it."""
    pairs = list(pairs)
    off = [(req, got) for req, got in pairs if not _same_time(req, got)]
    n_drawn = len({got for _, got in pairs})
    parts = []
    if off:
        parts.append("drew the nearest snapshots: " + ", ".join(
            f"{format_us(req)} µs → {format_us(got)} µs" for req, got in off))
    if n_drawn < len(pairs):
        parts.append(f"{len(pairs)} times fall on {n_drawn} snapshot"
                     + ("s, each drawn once" if n_drawn > 1 else ", drawn once"))
    return "fsph plot: " + "; ".join(parts) if parts else None


def _save(fig, output, dpi, **kwargs):
    """Write the figure and close it (tests look at the figure here);
    InputError naming the file where it cannot be written."""
    import matplotlib.pyplot as plt
    try:
        fig.savefig(output, dpi=dpi, **kwargs)
    except OSError as err:
        raise InputError(f"{output}: cannot write the picture: {err.strerror or err}") from None
    finally:
        plt.close(fig)


def _shape_marks(summary):
    """From a run's summary: the experiment's L, D and W [mm] where the
    reference has them, the height of W above the impact face [mm] and the
    band of the impact face in which D is measured [mm] (fsph.metrics.taylor;
    None without) and, for a perforation run, the half-width framed: three
    hole diameters [mm] (None otherwise)."""
    experiment = {}
    comparison = summary.get("reference", {}).get("comparison", {}).get("taylor", {})
    for key in ("L_mm", "D_mm", "W_mm"):
        if key in comparison:
            experiment[key] = comparison[key]["reference"]
    taylor = summary.get("metrics", {}).get("taylor", {})
    experiment["w_height_mm"] = taylor.get("w_height_mm")
    experiment["face_band_mm"] = taylor.get("face_band_mm")
    # a perforation run: frame the impact zone (three hole diameters), not the whole plate
    hole = (summary.get("metrics", {}).get("perforation") or {}).get("hole_diameter_mm")
    frame = 3.0 * hole if hole else None
    return experiment, frame


def body_names(summary):
    """The bodies' names in deck order (the order of their indices in the
    snapshots), from summary.json."""
    return list(summary.get("material_state", {}))


def _body_name(names, index):
    return names[index] if index < len(names) else f"body {index + 1}"


def _body_colour(index, kind):
    """Colour of body `index` (0-based, deck order): kind 0 its elements,
    1 its particles."""
    return BODY_COLOURS[index % len(BODY_COLOURS)][kind]


def _draw_body(ax, g, frame, bottom, present):
    """Draw the elements and particles of snapshot g on ax, mirrored about
    the axis, coloured by body (BODY_COLOURS); adds (body, kind) to the set
    `present` for what it draws (kind 0 elements, 1 particles); returns the
    extent (largest r, largest z) [mm] and `bottom` lowered to the lowest
    point within r <= frame [mm] (frame None: of all points)."""
    from matplotlib.collections import PolyCollection

    extent = [0.0, 0.0]
    conn = g["connectivity"][...] if "connectivity" in g else np.zeros((0, 3), dtype=int)
    xp = g["particles/x"][...] * 1e3 if "particles" in g else np.zeros((0, 2))
    if len(conn):
        x = g["nodes"][...] * 1e3
        body = g["body"][...] if "body" in g else np.zeros(len(conn), dtype=int)
        faces = [_body_colour(b, 0) for b in body]
        present.update((int(b), 0) for b in np.unique(body))
        used = x[np.unique(conn)]
        extent = [used[:, 0].max(), used[:, 1].max()]
        bottom = min(bottom, used[used[:, 0] <= (frame or np.inf), 1].min(initial=bottom))
    if len(xp):
        p_body = g["particles/body"][...] if "particles/body" in g else np.zeros(len(xp), dtype=int)
        dots = [_body_colour(b, 1) for b in p_body]
        present.update((int(b), 1) for b in np.unique(p_body))
        extent = [max(extent[0], xp[:, 0].max()), max(extent[1], xp[:, 1].max())]
        bottom = min(bottom, xp[xp[:, 0] <= (frame or np.inf), 1].min(initial=bottom))
    for side in (1.0, -1.0):
        if len(conn):
            tri = x[conn]
            tri[..., 0] *= side
            ax.add_collection(PolyCollection(tri, facecolors=faces, edgecolors="white",
                                             linewidths=0.15, alpha=0.9))
        if len(xp):
            ax.scatter(side * xp[:, 0], xp[:, 1], s=2.0, c=dots, linewidths=0)
    return extent, bottom


def _mark_experiment(ax, experiment):
    """The experiment's final length L (dashed line), impact-face diameter D
    (long ticks at z = 0) and width W (short ticks at its height above the
    face) [mm], those it has, each tick pair lettered."""
    if "L_mm" in experiment:
        ax.axhline(experiment["L_mm"], color="k", ls="--", lw=0.8)
    ticks = [("D", 0.0, 12)]
    if experiment.get("w_height_mm"):
        ticks.append(("W", experiment["w_height_mm"], 8))
    for letter, z, size in ticks:
        if f"{letter}_mm" in experiment:
            half = experiment[f"{letter}_mm"] / 2
            ax.plot([-half, half], [z, z], "k|", ms=size, mew=1.5)
            ax.annotate(letter, (half, z), xytext=(4, 3), textcoords="offset points",
                        fontsize=8, ha="left", va="bottom")


def _shapes_legend(fig, present, names, experiment):
    """Legend of the shapes: the elements and particles of each body that the
    panels show, and the experiment's marks where there are some, each
    saying what it is (fsph.metrics.taylor's definitions)."""
    from matplotlib.lines import Line2D

    handles = []
    for body, kind in sorted(present):
        name = _body_name(names, body)
        if kind == 0:
            handles.append(Line2D([], [], color=_body_colour(body, 0), lw=6,
                                  label=f"{name}: elements"))
        else:
            handles.append(Line2D([], [], color=_body_colour(body, 1), marker="o", ls="",
                                  label=f"{name}: particles"))
    if "L_mm" in experiment:
        handles.append(Line2D([], [], color="k", ls="--", lw=0.8,
                              label=f"experiment L = {experiment['L_mm']:.3g} mm: final length"))
    if "D_mm" in experiment:
        band = experiment.get("face_band_mm")
        within = f", widest within {band:.2g} mm of the face" if band else ""
        handles.append(Line2D([], [], color="k", marker="|", ls="", ms=12, mew=1.5,
                              label=f"experiment D = {experiment['D_mm']:.3g} mm: impact-face "
                                    f"diameter{within}"))
    if "W_mm" in experiment and experiment.get("w_height_mm"):
        handles.append(Line2D([], [], color="k", marker="|", ls="", ms=8, mew=1.5,
                              label=f"experiment W = {experiment['W_mm']:.3g} mm: diameter "
                                    f"{experiment['w_height_mm']:.3g} mm above the impact face"))
    fig.legend(handles=handles, loc="outside lower center", ncol=max(1, min(2, len(handles))),
               frameon=False, fontsize=8)


def _shapes_figure(run_dir, times_us=None):
    """The figure of deformed_shapes (matplotlib Figure, not saved)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    summary = read_summary(run_dir)
    experiment, frame = _shape_marks(summary)
    names = body_names(summary)
    present = set()
    with open_run_file(run_dir) as h5:
        chosen = [(time, g) for _, time, g in choose_snapshots(_snapshots(h5), times_us)]
        fig, axes = plt.subplots(1, len(chosen), sharey=True, squeeze=False,
                                 layout="constrained")
        axes = axes[0]
        top = experiment.get("L_mm", 0.0)
        width = experiment.get("D_mm", 0.0) / 2
        bottom = -0.5
        for ax, (time, g) in zip(axes, chosen):
            extent, bottom = _draw_body(ax, g, frame, bottom, present)
            _mark_experiment(ax, experiment)
            ax.set_title(f"{format_us(time * 1e6)} µs")
            ax.set_xlabel("r [mm]")
            top = max(top, extent[1])
            width = max(width, extent[0])
    if frame:
        width = frame / 1.15
    z_low = bottom - 0.05 * (top - bottom) if frame or bottom < -0.5 else bottom
    for ax in axes:
        ax.set_xlim(-1.15 * width, 1.15 * width)
        ax.set_ylim(z_low, 1.05 * top)
        ax.set_aspect("equal")
    axes[0].set_ylabel("z [mm]")
    # panels of the bodies' proportions, within reason [inches]
    ratio = (1.05 * top - z_low) / (2.3 * width)
    panel_width = min(max(5.0 / ratio, 1.3), 4.5)
    panel_height = min(max(panel_width * ratio, 1.5), 5.0)
    fig.set_size_inches(len(axes) * panel_width + 1.0, panel_height + 1.8)
    fig.suptitle(summary.get("title") or summary.get("case", ""))
    _shapes_legend(fig, present, names, experiment)
    return fig


def deformed_shapes(run_dir, times_us=None, output=None, dpi=150):
    """Write a PNG with one panel per snapshot drawn (choose_snapshots: the
    snapshot nearest each requested time [µs], each once; without times,
    four spread evenly from the first snapshot to the last), each titled
    with its snapshot's time, the bodies mirrored about the axis, elements
    and particles in colours of their own for each body, the legend naming
    only those drawn, and the experiment's L, D and W marked and explained
    (Xiao et al. 2012 Fig. 8); returns the PNG path. A debris run
    (&metrics kind 'debris') gets debris_cloud's picture instead."""
    run_dir = Path(run_dir)
    output = Path(output) if output else run_dir / "shapes.png"
    summary = read_summary(run_dir)
    if "debris" in summary.get("metrics", {}):
        return debris_cloud(run_dir, times_us, output, dpi)
    _save(_shapes_figure(run_dir, times_us), output, dpi, bbox_inches="tight")
    return output


#: Colours of the debris picture: the flyer's material, the target's,
#: any other; the experiment's marks.
FLYER_COLOUR = "#c46a1b"
TARGET_COLOUR = "#3f6fb0"
OTHER_COLOUR = "#888888"
MARK_COLOUR = "k"


def _debris_colours(body_names, rec):
    """Colour of each body index (0-based, in deck order: `body_names`)
    for the debris picture: the flyer's, the target's, grey for any
    other. By body, not by material: a flyer and a plate of the same
    material (a Whipple shield's aluminium sphere and bumper) keep
    colours of their own, and with two materials it is the same picture."""
    return [FLYER_COLOUR if name == rec["flyer"] else
            TARGET_COLOUR if name == rec["target"] else OTHER_COLOUR
            for name in body_names]


def _draw_bodies(ax, g, colours, points_per_mm):
    """Elements (filled triangles) and particles (discs of their radius,
    at points_per_mm [pt/mm], at least a fraction of a point) of snapshot
    g, coloured by body and mirrored about the axis [mm]."""
    from matplotlib.collections import PolyCollection

    for side in (1.0, -1.0):
        if "connectivity" in g:
            tri = g["nodes"][...][g["connectivity"][...]] * 1e3
            tri[..., 0] *= side
            ax.add_collection(PolyCollection(tri, facecolors=np.take(colours, g["body"][...]),
                                             edgecolors="none"))
        if "particles" in g:
            xp = g["particles/x"][...] * 1e3
            size = np.maximum(2e3 * g["particles/radius"][...] * points_per_mm, 0.5) ** 2
            ax.scatter(side * xp[:, 0], xp[:, 1], s=size, linewidths=0,
                       c=np.take(colours, g["particles/body"][...]))


def _experiment_marks(ax, experiment, z_face, direction, half_width):
    """The experiment's positions on the panel [mm]: the fronts (dashed,
    in their material's colour), the ejecta height (dotted), the hole
    (ticks on the front face) and the intersection radius (dash-dotted)."""
    def z_at(s):
        return z_face + direction * s
    for key, colour in (("target_front_mm", TARGET_COLOUR), ("flyer_front_mm", FLYER_COLOUR)):
        if key in experiment:
            ax.axhline(z_at(experiment[key]), color=colour, ls="--", lw=1.0)
    if "ejecta_height_mm" in experiment:
        ax.axhline(z_at(-experiment["ejecta_height_mm"]), color=MARK_COLOUR, ls=":", lw=1.0)
    if "hole_diameter_mm" in experiment:
        hole = experiment["hole_diameter_mm"] / 2
        ax.plot([-hole, hole], [z_face, z_face], "|", color=MARK_COLOUR, ms=14, mew=1.8)
    if "intersection_radius_mm" in experiment:
        for side in (1.0, -1.0):
            ax.axvline(side * experiment["intersection_radius_mm"], color=MARK_COLOUR, ls="-.",
                       lw=0.8)
    ax.set_xlim(-half_width, half_width)


#: Height of the box of _debris_table, its margin from the panel's edge
#: included [pt]: seven lines of 6.5 pt text, spaced 1.2, and the box's
#: padding.
DEBRIS_TABLE_PT = 72.0


def _debris_table(ax, rec, experiment, direction):
    """A box of the run's values beside the experiment's [mm], in the
    panel's uprange corner (behind the plate, where only the ejecta are:
    the cloud fills the downrange half)."""
    rows = [(f"{rec['target']} front", "target_front_mm"),
            (f"{rec['flyer']} front", "flyer_front_mm"),
            ("ratio", "front_ratio"), ("ejecta", "ejecta_height_mm"),
            ("intersection r", "intersection_radius_mm"), ("hole D", "hole_diameter_mm")]
    lines = [f"{'':15s}{'fsph':>7s}{'exp.':>7s}"]
    for label, key in rows:
        value = rec.get(key)
        ref = experiment.get(key)
        lines.append(f"{label:15s}" + "".join(f"{v:7.3g}" if v is not None else f"{'—':>7s}"
                                             for v in (value, ref)))
    uprange_top = direction < 0.0                 # flight towards -z: uprange is the top
    ax.text(0.02, 0.98 if uprange_top else 0.02, "\n".join(lines), transform=ax.transAxes,
            family="monospace", fontsize=6.5, va="top" if uprange_top else "bottom", ha="left",
            bbox={"facecolor": "white", "alpha": 0.85, "edgecolor": "0.7"})


def _series_value(series, key, index):
    """The debris series' `key` at snapshot `index`, 0 where it is absent
    or undefined (None)."""
    value = series.get(key, [None] * (index + 1))[index]
    return value if value is not None else 0.0


def _body_points(g, index):
    """The points of body `index` (0-based, deck order) in snapshot g
    [mm]: the nodes of its elements and its particles' centres, (n, 2)."""
    points = [np.zeros((0, 2))]
    if "connectivity" in g:
        conn = g["connectivity"][...][g["body"][...] == index]
        points.append(g["nodes"][...][np.unique(conn)] * 1e3)
    if "particles" in g:
        points.append(g["particles/x"][...][g["particles/body"][...] == index] * 1e3)
    return np.vstack(points)


def _start_extent(first, names, rec):
    """Where the flyer and the target start [mm]: (z_low, z_high) of
    their points in the first snapshot, with a margin of a twentieth of
    that span, and the flyer's radius (None when the snapshot lacks
    them)."""
    points = [_body_points(first, names.index(rec[role]))
              for role in ("flyer", "target") if rec[role] in names]
    if len(points) < 2 or not all(len(p) for p in points):
        return None
    z = np.concatenate([p[:, 1] for p in points])
    pad = 0.05 * (z.max() - z.min())
    return (z.min() - pad, z.max() + pad), float(points[0][:, 0].max())


def _ejecta_radius(g, names, rec, z_face, direction, height):
    """Largest radius [mm] of the flyer's and the target's points in
    snapshot g that lie uprange of the plate's front face by no more than
    the ejecta height `height` [mm]: where the back-splash that sets the
    ejecta height is (the few points beyond it, which the height's mass
    quantile leaves out, are not framed). 0 when there are none."""
    radius = 0.0
    for role in ("flyer", "target"):
        if rec[role] in names:
            points = _body_points(g, names.index(rec[role]))
            behind = -direction * (points[:, 1] - z_face)        # [mm] uprange of the face
            uprange = points[(behind > 0.0) & (behind <= height), 0]
            radius = max(radius, float(uprange.max(initial=0.0)))
    return radius


def _debris_extent(series, index, experiment, z_face, direction, start=None,
                   ejecta_radius=0.0):
    """Half-width and (z_low, z_high) of a debris panel [mm]: the clouds'
    2 %-fronts and radii, the ejecta (up to its height, out to
    `ejecta_radius`: _ejecta_radius), the experiment's marks and where the
    bodies start (start: _start_extent, so that a panel before the clouds
    form shows the flyer and the plate), with a margin."""
    ahead = max(_series_value(series, "target_front_0p5pct_mm", index),
                _series_value(series, "flyer_front_0p5pct_mm", index),
                experiment.get("target_front_mm", 0.0), experiment.get("flyer_front_mm", 0.0))
    behind = max(_series_value(series, "ejecta_height_mm", index),
                 experiment.get("ejecta_height_mm", 0.0), 3.0)
    width = max(_series_value(series, "target_cloud_radius_mm", index),
                _series_value(series, "flyer_cloud_radius_mm", index),
                experiment.get("intersection_radius_mm", 0.0),
                0.75 * experiment.get("hole_diameter_mm", 0.0),
                0.75 * _series_value(series, "hole_diameter_mm", index), ejecta_radius, 5.0)
    ends = [z_face + direction * 1.1 * ahead, z_face - direction * 1.15 * behind]
    if start is not None:
        (z_low, z_high), flyer_radius = start
        ends += [z_low, z_high]
        width = max(width, flyer_radius)
    return 1.2 * width, [min(ends), max(ends)]


def debris_cloud(run_dir, times_us=None, output=None, dpi=150):
    """Write a PNG of a debris run (&metrics kind 'debris'): the cloud at
    the requested times (the nearest snapshots, each once; default the
    snapshot of the metrics), coloured by body (flyer, target; their
    materials in the legend) and mirrored about the axis, each panel
    titled with its snapshot's exact time; the panel of the metrics'
    snapshot carries the experiment's fronts, ejecta height, hole and
    intersection radius (where the reference applies) and a box of the
    run's values beside them. Returns the PNG path."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    run_dir = Path(run_dir)
    output = Path(output) if output else run_dir / "shapes.png"
    summary = read_summary(run_dir)
    metrics = summary["metrics"]
    rec = metrics["debris"]
    series = metrics.get("series", {})
    experiment = {key: cmp["reference"] for key, cmp in
                  summary.get("reference", {}).get("comparison", {}).get("debris", {}).items()}
    z_face, direction = rec["plate_front_face_z_mm"], rec["flight_direction"]
    with open_run_file(run_dir) as h5:
        snaps = _snapshots(h5)
        names = [str(n) for n in h5.attrs["body_names"]]
        colours = _debris_colours(names, rec)
        start = _start_extent(snaps[0][1], names, rec)
        if times_us is None:
            times_us = [summary["metrics_time_s"] * 1e6]
        chosen = [(time, g) for _, time, g in choose_snapshots(snaps, times_us)]
        panel_inches = 4.6
        fig, axes = plt.subplots(1, len(chosen), figsize=(panel_inches * len(chosen), 6.4),
                                 squeeze=False)
        axes = axes[0]
        series_times = series.get("time_us", [])
        for ax, (time, g) in zip(axes, chosen):
            index = int(np.argmin(np.abs(np.asarray(series_times) - time * 1e6))) \
                if series_times else 0
            at_metrics = abs(time - summary["metrics_time_s"]) <= 1e-12 * max(time, 1e-30)
            marks = experiment if at_metrics else {}
            ejecta_radius = _ejecta_radius(g, names, rec, z_face, direction,
                                           _series_value(series, "ejecta_height_mm", index))
            half_width, (z_low, z_high) = _debris_extent(series, index, marks, z_face, direction,
                                                          start, ejecta_radius)
            # about four fifths of the panel's width is the axes' [pt/mm]
            pt_per_mm = 72.0 * 0.8 * panel_inches / (2.0 * half_width)
            if at_metrics:
                # room for the box of values beyond the uprange end, so
                # that it covers neither the plate nor the ejecta
                room = DEBRIS_TABLE_PT / pt_per_mm
                z_low, z_high = (z_low, z_high + room) if direction < 0.0 else (z_low - room, z_high)
            _draw_bodies(ax, g, colours, pt_per_mm)
            if marks:
                _experiment_marks(ax, marks, z_face, direction, half_width)
            if at_metrics:
                _debris_table(ax, rec, marks, direction)
            ax.set_xlim(-half_width, half_width)
            ax.set_ylim(z_low, z_high)
            ax.set_aspect("equal")
            ax.set_title(f"t = {time * 1e6:.3f} µs")
            ax.set_xlabel("r [mm]")
        axes[0].set_ylabel("z [mm]")
        handles = [Line2D([], [], color=FLYER_COLOUR, marker="o", ls="",
                          label=f"{rec['flyer']} ({rec['flyer_material']})"),
                   Line2D([], [], color=TARGET_COLOUR, marker="o", ls="",
                          label=f"{rec['target']} ({rec['target_material']})")]
        if experiment:
            handles += [Line2D([], [], color="0.3", ls="--",
                               label="experiment: fronts (by material)"),
                        Line2D([], [], color=MARK_COLOUR, ls=":", label="ejecta height"),
                        Line2D([], [], color=MARK_COLOUR, ls="-.", label="intersection radius"),
                        Line2D([], [], color=MARK_COLOUR, marker="|", ls="", ms=10,
                               label="hole")]
        fig.suptitle(textwrap.fill(summary.get("title") or summary.get("case", ""),
                                   width=int(12 * panel_inches * len(chosen))), fontsize=10)
        # one panel is too narrow for three columns of labels
        ncol = 3 if len(chosen) > 1 else 2
        fig.legend(handles=handles, loc="lower center", ncol=ncol, frameon=False, fontsize=8)
        fig.tight_layout(rect=(0, 0.04 * -(-len(handles) // ncol), 1, 0.96))
        _save(fig, output, dpi)
    return output


#: the history rows within this many stable steps of the end time of a run
#: that reached it are the landing's (the solver shortens the last one or
#: two steps to end on it: fsph_solver's solver_advance)
LANDING_STEPS = 2.0


def _landing_rows(time, dt, end_time):
    """How many rows at the end of the history belong to the landing on the
    end time [s] (0 when the history stops elsewhere: a failed or stopped
    run): those within LANDING_STEPS stable steps of it, the stable step
    being the largest step of the last three rows."""
    if len(time) < 3 or end_time is None or not abs(time[-1] - end_time) <= 1e-9 * end_time:
        return 0
    stable = dt[-3:].max()
    return int(np.count_nonzero(time > time[-1] - LANDING_STEPS * stable * (1.0 - 1e-9)))


def _history_figure(run_dir):
    """The figure of histories (matplotlib Figure, not saved)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    run_dir = Path(run_dir)
    with open_run_file(run_dir) as h5:
        hist = {k: h5["history"][k][...] for k in h5["history"]}
        body_force = {name: g["force_z"][...] for name, g in h5.get("body_history", {}).items()}
    summary_path = run_dir / "summary.json"
    summary = read_summary(run_dir) if summary_path.is_file() else {}
    t = hist["time"] * 1e6
    # the rigid planes' force, where a plane has acted (runs before it have no column)
    force = hist.get("plane_force_z")
    with_force = force is not None and bool(np.any(force))
    # each body's axial force where two or more bodies meet (a projectile's deceleration)
    with_bodies = len(body_force) > 1 and any(np.any(f) for f in body_force.values())
    n_panels = 3 + with_force + with_bodies
    fig, axes = plt.subplots(n_panels, 1, figsize=(7, 8 + 2 * (with_force + with_bodies)), sharex=True,
                             height_ratios=(2,) + (1,) * (n_panels - 1), layout="constrained")
    ax_e, ax_err, ax_dt = axes[0], axes[1], axes[-1]
    if with_force:
        impulse = hist["plane_impulse_z"][-1]
        axes[2].plot(t, force * 1e-3, lw=0.9,
                     label=f"axial, on the bodies; impulse {impulse:.4g} N s at the end")
        axes[2].set_ylabel("rigid-plane force [kN]")
        axes[2].legend(frameon=False, fontsize="small")
    if with_bodies:
        ax_b = axes[2 + with_force]
        for name, f in body_force.items():
            ax_b.plot(t, f * 1e-3, lw=0.9, label=name)
        ax_b.axhline(0.0, color="0.6", lw=0.6)
        ax_b.set_ylabel("axial force on\neach body [kN]")
        ax_b.legend(frameon=False, fontsize="small")
    ax_e.plot(t, hist["kinetic"], label="kinetic")
    ax_e.plot(t, hist["internal"], label="internal")
    if "contact" in hist and hist["contact"].any():
        # the energy the contact corrections removed (summary.json
        # contact_dissipation_J), as the other terms removed are named;
        # not the work each body received through contact (bodies.png)
        ax_e.plot(t, hist["contact"], label="removed by contact")
    if "eroded" in hist and hist["eroded"].any():
        ax_e.plot(t, hist["eroded"], label="removed by erosion")
    if "plane" in hist and hist["plane"].any():
        ax_e.plot(t, hist["plane"], label="removed by rigid planes and the axis wall")
    ax_e.plot(t, hist["total"], "k", lw=1.2, label="total")
    ax_e.set_ylabel("energy [J]")
    ax_e.legend(frameon=False)
    # the error as the run reports it: the total against the initial energy
    initial = summary.get("energy", {}).get("initial_J") or (hist["total"][0] if len(t) else 0.0)
    if initial:
        error = 100.0 * (hist["total"] - initial) / initial
        ax_err.plot(t, error, "k", lw=1.0,
                    label=f"(total - initial) / initial, {error[-1]:+.3g} % at the end")
        ax_err.axhline(0.0, color="0.6", lw=0.6)
        ax_err.legend(frameon=False, fontsize="small")
    else:
        ax_err.text(0.5, 0.5, "no initial energy: no relative error", ha="center",
                    va="center", transform=ax_err.transAxes)
    ax_err.set_ylabel("energy error [%]")
    landing = _landing_rows(hist["time"], hist["dt"], summary.get("requested_end_time_s"))
    keep = slice(1, len(t) - landing)
    ax_dt.plot(t[keep], hist["dt"][keep] * 1e9, lw=0.8)
    ax_dt.set_ylabel("time step [ns]")
    ax_dt.set_xlabel("t [µs]")
    if landing:
        ax_dt.set_title("not drawn: the last step(s), shortened to land on the end time",
                        fontsize="small", loc="right")
    fig.suptitle(summary.get("title") or summary.get("case") or run_dir.name)
    return fig


def histories(run_dir, output=None, dpi=150):
    """Write a PNG of the time histories of a run, titled with the case:
    kinetic, internal, contact, eroded, rigid-plane and total energy; the
    relative energy error, (total - initial) / initial [%] (the initial
    energy of summary.json, else the first total), the quantity of
    summary.json's energy.relative_error; where a rigid plane acted, its
    axial force on the bodies (history plane_force_z, averaged between
    history rows, over the times of their half-step velocities; a Taylor
    test's anvil force); where two or more bodies
    are, the axial force on each (body_history force_z: a projectile's
    deceleration force); and the time step. The time-step
    curve leaves out the step of the first row (none) and, when the run
    reached its end time, the rows of the landing on it (_landing_rows: the
    solver shortens the last one or two steps to end on the end time, which
    drew a spike down at the end that is no property of the run); the
    panel says so. Returns the PNG path."""
    run_dir = Path(run_dir)
    output = Path(output) if output else run_dir / "history.png"
    _save(_history_figure(run_dir), output, dpi)
    return output


def _experiment_residual(summary):
    """The experiment's residual velocity [m/s] the run is compared with
    (summary.json reference.comparison.perforation; None without one, or
    where the reference does not apply to the run)."""
    ref = summary.get("reference") or {}
    if not ref.get("applies", True):
        return None
    cmp = ref.get("comparison", {}).get("perforation", {}).get("residual_velocity_m_s")
    return cmp["reference"] if cmp else None


def _perforation_figure(run_dir):
    """The figure of perforation_histories (None for a run that is not a
    perforation run)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    summary = read_summary(run_dir)
    series = summary.get("metrics", {}).get("series")
    if not series or "velocity_z_m_s" not in series:
        return None
    t = series["time_us"]
    # along the striking direction (fsph.metrics: the sign of the first
    # velocity, -z from rest): a projectile that rebounds goes below zero
    velocity_z = series["velocity_z_m_s"]
    direction = 1.0 if velocity_z[0] > 0.0 else -1.0
    along = [direction * v for v in velocity_z]
    hole = [h if h is not None else float("nan") for h in series["hole_diameter_mm"]]
    fig, axes = plt.subplots(3, 1, figsize=(7, 7.4), sharex=True, layout="constrained")
    axes[0].plot(t, along, "o-", ms=3, label=f"fsph, {along[-1]:.4g} m/s at the end"
                 + (" (rebounded)" if along[-1] < 0.0 else ""))
    if min(along) < 0.0:
        axes[0].axhline(0.0, color="0.6", lw=0.6)
    experiment = _experiment_residual(summary)
    if experiment is not None:
        axes[0].axhline(experiment, color="k", ls="--", lw=0.8)
        axes[0].plot([t[-1]], [experiment], "k*", ms=11, ls="--", lw=0.8,
                     label=f"experiment: residual velocity {experiment:.4g} m/s")
    axes[0].set_ylabel("projectile velocity\nalong the strike [m/s]")
    axes[0].legend(frameon=False, fontsize="small")
    axes[1].plot(t, series["penetration_mm"], "o-", ms=3)
    axes[1].set_ylabel("penetration [mm]")
    axes[2].plot(t, hole, "o-", ms=3)
    axes[2].set_ylabel("hole diameter [mm]")
    axes[2].set_xlabel("t [µs]")
    fig.suptitle(summary.get("title") or summary.get("case", ""))
    return fig


def perforation_histories(run_dir, output=None, dpi=150):
    """Write a PNG of a perforation run's histories at the snapshots
    (projectile velocity along the striking direction, negative once it
    rebounds; penetration depth, hole diameter) from
    summary.json, titled with the case; the experiment's residual velocity
    the run is compared with (summary.json reference.comparison.perforation)
    is a star at the end time on a dashed line, with its legend entry.
    Returns the PNG path, or None for other runs."""
    return _save_if_drawn(_perforation_figure(Path(run_dir)), run_dir, "perforation.png", output, dpi)


def _save_if_drawn(fig, run_dir, name, output, dpi):
    """Save a figure that may not apply to a run (None: nothing drawn) to
    output or RUN_DIR/name; returns the path or None."""
    if fig is None:
        return None
    output = Path(output) if output else Path(run_dir) / name
    _save(fig, output, dpi)
    return output


#: The gauge fields gauges.png draws: (field, label, scale to the label's unit).
GAUGE_PANELS = (("pressure", "pressure [GPa]", 1e-9), ("stress_zz", "axial stress σ_zz [GPa]", 1e-9),
                ("velocity_z", "axial velocity [m/s]", 1.0), ("plastic_strain", "plastic strain [-]", 1.0))


def _named_histories(run_dir, group, keys):
    """Time [µs] of fsph.h5's history rows, each member of `group`
    (gauge_history, body_history) as (its datasets among keys, its
    attributes), and the run's title; None for a run without the group or
    with an empty one."""
    with open_run_file(run_dir) as h5:
        if group not in h5 or not len(h5[group]):
            return None
        t = h5["history/time"][...] * 1e6
        members = {name: ({k: g[k][...] for k in keys if k in g}, dict(g.attrs)) for name, g in h5[group].items()}
        return t, members, h5.attrs.get("title", "")


def _gauge_figure(run_dir):
    """The figure of gauge_histories (None for a run without gauges)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    found = _named_histories(run_dir, "gauge_history", [f for f, _, _ in GAUGE_PANELS])
    if found is None:
        return None
    t, members, title = found
    gauges = {name: (fields, attrs.get("kind", "")) for name, (fields, attrs) in members.items()}
    fig, axes = plt.subplots(len(GAUGE_PANELS), 1, figsize=(7, 2.2 * len(GAUGE_PANELS) + 0.6), sharex=True,
                             layout="constrained")
    for (field, label, scale), ax in zip(GAUGE_PANELS, axes):
        for name, (fields, kind) in gauges.items():
            if field in fields:
                ax.plot(t, fields[field] * scale, lw=0.9, label=f"{name} ({kind})" if kind else name)
        ax.set_ylabel(label)
    axes[0].legend(frameon=False, fontsize="small")
    axes[-1].set_xlabel("t [µs]")
    fig.suptitle(f"{title}: gauges" if title else "gauges")
    return fig


def gauge_histories(run_dir, output=None, dpi=150):
    """Write a PNG of the run's gauges (&gauge; fsph.h5 gauge_history):
    pressure, axial stress, axial velocity and plastic strain against time,
    one curve per gauge, gaps where a gauge is in no material. Returns the
    PNG path, or None for a run without gauges."""
    return _save_if_drawn(_gauge_figure(Path(run_dir)), run_dir, "gauges.png", output, dpi)


#: The books bodies.png draws for each body: (body_history column, legend label).
BODY_CURVES = (("kinetic", "kinetic"), ("internal", "internal"), ("plastic_work", "plastic work"),
               ("viscous_work", "viscous work"), ("hourglass_work", "hourglass work"),
               ("contact_work", "received through contact"))


def _body_figure(run_dir):
    """The figure of body_energies (None for a run without body books)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    found = _named_histories(run_dir, "body_history", [k for k, _ in BODY_CURVES])
    if found is None:
        return None
    t, members, title = found
    bodies = {name: books for name, (books, _) in members.items()}
    fig, axes = plt.subplots(len(bodies), 1, figsize=(7, 3.2 * len(bodies) + 0.6), sharex=True,
                             layout="constrained", squeeze=False)
    for ax, (name, books) in zip(axes[:, 0], bodies.items()):
        for k, (key, label) in enumerate(BODY_CURVES):
            # a book that stays zero (no hourglass in elements, no contact) is left out;
            # each book keeps its colour in every panel
            if key in books and np.any(books[key]):
                ax.plot(t, books[key], lw=0.9, color=f"C{k}", label=label)
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.set_ylabel(f"{name}: energy [J]")
        ax.legend(frameon=False, fontsize="small")
    axes[-1, 0].set_xlabel("t [µs]")
    fig.suptitle(f"{title}\neach body's energies" if title else "each body's energies")
    return fig


def body_energies(run_dir, output=None, dpi=150):
    """Write a PNG of each body's books (fsph.h5 body_history) against
    time, a panel per body: kinetic and internal energy, plastic, viscous
    and hourglass work and the energy received through contact (negative:
    given away), books that stay zero left out. Returns the PNG path, or
    None for a run without body books."""
    return _save_if_drawn(_body_figure(Path(run_dir)), run_dir, "bodies.png", output, dpi)


#: colour of the bodies never damaged in a damage map (outside the damage colour map)
UNDAMAGED_COLOUR = "#8fa3b8"
#: where the damage map's default panels fall, as fractions of the run
DAMAGE_FRACTIONS = (0.25, 0.5, 0.75, 1.0)


def _damaged_bodies(snaps):
    """Indices of the bodies with a damaged point (D > 0) in any snapshot."""
    damaged = set()
    for _, g in snaps:
        for prefix in ("", "particles/"):
            if f"{prefix}damage" in g and f"{prefix}body" in g:
                damage = g[f"{prefix}damage"][...]
                damaged.update(int(b) for b in np.unique(g[f"{prefix}body"][...][damage > 0.0]))
    return damaged


def _damage_figure(run_dir, times_us=None):
    """The figure of damage_map (None when no point of the run is damaged)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection
    from matplotlib.patches import Patch

    run_dir = Path(run_dir)
    summary = read_summary(run_dir)
    names = body_names(summary)
    with open_run_file(run_dir) as h5:
        snaps = _snapshots(h5)
        damaged = _damaged_bodies(snaps)
        if not damaged:
            return None
        chosen = choose_snapshots(snaps, times_us, fractions=DAMAGE_FRACTIONS)
        fig, axes = plt.subplots(1, len(chosen), figsize=(3.4 * len(chosen), 4.2),
                                 sharey=True, squeeze=False, layout="constrained")
        axes = axes[0]
        cmap = plt.get_cmap("inferno_r")
        lo = np.array([np.inf, np.inf])
        hi = -lo
        undamaged = set()
        for ax, (_, time, g) in zip(axes, chosen):
            for side in (1.0, -1.0):
                if "connectivity" in g and len(g["connectivity"]):
                    x = g["nodes"][...] * 1e3
                    conn = g["connectivity"][...]
                    body = g["body"][...]
                    hit = np.isin(body, list(damaged))
                    tri = x[conn]
                    tri[..., 0] *= side
                    coll = PolyCollection(tri[hit], cmap=cmap, edgecolors="none")
                    coll.set_array(g["damage"][...][hit])
                    coll.set_clim(0.0, 1.0)
                    ax.add_collection(coll)
                    if (~hit).any():
                        ax.add_collection(PolyCollection(tri[~hit], facecolors=UNDAMAGED_COLOUR,
                                                         edgecolors="none"))
                        undamaged.update(int(b) for b in np.unique(body[~hit]))
                    used = x[np.unique(conn)]
                    lo, hi = np.minimum(lo, used.min(axis=0)), np.maximum(hi, used.max(axis=0))
                if "particles" in g and len(g["particles/x"]):
                    xp = g["particles/x"][...] * 1e3
                    p_body = g["particles/body"][...]
                    hit = np.isin(p_body, list(damaged))
                    ax.scatter(side * xp[hit, 0], xp[hit, 1], c=g["particles/damage"][...][hit],
                               s=1.5, cmap=cmap, vmin=0.0, vmax=1.0, linewidths=0)
                    if (~hit).any():
                        ax.scatter(side * xp[~hit, 0], xp[~hit, 1], color=UNDAMAGED_COLOUR,
                                   s=1.5, linewidths=0)
                        undamaged.update(int(b) for b in np.unique(p_body[~hit]))
                    lo, hi = np.minimum(lo, xp.min(axis=0)), np.maximum(hi, xp.max(axis=0))
            ax.set_title(f"{format_us(time * 1e6)} µs")
            ax.set_xlabel("r [mm]")
            ax.set_aspect("equal")
    for ax in axes:
        ax.set_xlim(-hi[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
    axes[0].set_ylabel("z [mm]")
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(0.0, 1.0))
    fig.colorbar(sm, ax=list(axes), shrink=0.9, label="damage D")
    if undamaged:
        fig.legend(handles=[Patch(facecolor=UNDAMAGED_COLOUR,
                                  label=f"{_body_name(names, b)}: no damage in this run")
                            for b in sorted(undamaged)],
                   loc="outside lower center", ncol=len(undamaged), frameon=False,
                   fontsize="small")
    fig.suptitle(summary.get("title") or summary.get("case", ""))
    return fig


def damage_map(run_dir, times_us=None, output=None, dpi=150):
    """Write a PNG of the damage field (HJC or Johnson-Cook damage D, 0 to
    1) at chosen times (choose_snapshots: the snapshot nearest each
    requested time [µs], each once; default: four, at a quarter, half,
    three quarters and the end of the run), one panel each titled with its
    snapshot's time, elements as filled triangles and particles as dots,
    mirrored about the axis (as Xiao et al. 2012 Fig. 13); a body with no
    damaged point in the whole run (a steel projectile) is drawn in a
    neutral colour outside the colour map, named in the legend. Returns
    the PNG path, or None when no point of the run is damaged."""
    run_dir = Path(run_dir)
    fig = _damage_figure(run_dir, times_us)
    if fig is None:
        return None
    output = Path(output) if output else run_dir / "damage.png"
    _save(fig, output, dpi)
    return output


# ---------------------------------------------------------------- field pictures
#: The fields `fsph plot --field` draws: NAME -> (what it is, unit, snapshot
#: dataset, factor from the stored SI value to the unit, colour map). The
#: pressure is the EOS's (an element's artificial viscosity q left out);
#: mises is computed from the stored stress (_mises); material is categorical.
FIELDS = {
    "eps_p": ("equivalent plastic strain ε_p", "-", "plastic_strain", 1.0, "viridis"),
    "pressure": ("pressure p, > 0 in compression", "GPa", "pressure", 1e-9, "coolwarm"),
    "mises": ("von Mises stress σ_eq", "GPa", "stress", 1e-9, "plasma"),
    "temperature": ("temperature T", "K", "temperature", 1.0, "inferno"),
    "damage": ("damage D", "-", "damage", 1.0, "inferno_r"),
    "density": ("density ρ", "kg/m³", "density", 1.0, "cividis"),
    "material": ("material", None, "material", None, None),
}
#: colour of the points of a material without the field's model (damage,
#: temperature), outside the colour map: the damage map's neutral colour
NO_MODEL_COLOUR = UNDAMAGED_COLOUR
#: colours of the materials in the material picture (deck order, repeating)
MATERIAL_COLOURS = ("#4a7ab5", "#d9822b", "#74a96b", "#c2185b", "#d4b44a", "#7b3294",
                    "#2b8c8c", "#8c564b")


def field_label(field):
    """The colour bar's label of a field: what it is and its unit."""
    what, unit = FIELDS[field][:2]
    return f"{what} [{unit}]" if unit else what


def _mises(stress, components):
    """von Mises stress [Pa] (fsph.points.von_mises) of the total Cauchy
    stress (n, 4) of a snapshot, its columns named by `components` (the
    dataset's attribute; fsph.output.STRESS_COMPONENTS: rr, zz, rz, tt)."""
    order = [list(components).index(name) for name in STRESS_COMPONENTS]
    return von_mises(np.asarray(stress)[:, order])


def _field_values(g, field):
    """The field's values of the elements and of the particles of snapshot
    group g, in its unit (FIELDS; material: 0-based indices): (elements,
    particles), each None where the snapshot has none of them."""
    dataset, scale = FIELDS[field][2:4]
    out = []
    for prefix, present in (("", "connectivity"), ("particles/", "particles/x")):
        if present not in g or not len(g[present]) or f"{prefix}{dataset}" not in g:
            out.append(None)
            continue
        data = g[f"{prefix}{dataset}"]
        if field == "mises":
            components = data.attrs.get("components", ",".join(STRESS_COMPONENTS))
            out.append(_mises(data[...], str(components).split(",")) * scale)
        elif field == "material":
            out.append(data[...].astype(int))
        else:
            out.append(data[...] * scale)
    return tuple(out)


def _deck_materials(h5):
    """The materials of the run's deck (fsph.h5 /deck), in deck order (the
    order of the material indices of the snapshots): dicts of their keys,
    library entry and defaults filled in; None when the deck cannot be read."""
    import f90nml

    from . import deck as deck_module
    from .materials import LIBRARY
    try:
        text = h5["deck"][()]
        text = text.decode() if isinstance(text, bytes) else str(text)
        raw = deck_module._groups(f90nml.Parser().reads(text)).get("material", [])
        group = deck_module.SCHEMA["material"]
        out = []
        for i, item in enumerate(raw):
            lib = str(item.get("library", "")).strip()
            base = {k: v for k, v in LIBRARY.get(lib, {}).items() if k != "source"}
            out.append(deck_module._read_group("fsph.h5 deck", "material", group, item, i,
                                               base or None))
        return out
    except Exception:       # f90nml raises many kinds; a hand-made file: the fields stored decide
        return None


def _has_damage(m):
    """Whether a material has a damage model: HJC or Johnson-Cook failure."""
    return m["strength"] == "hjc" or m["jc_d1"] is not None


def _heats(m):
    """Whether a material's temperature changes (as fsph.driver's peaks
    decide): temperature from the internal energy, or heating by plastic
    work of a plastic material with a specific heat."""
    from .materials import temperature_model
    return temperature_model(m) == "internal_energy" or (
        m["strength"] not in ("elastic", "hjc") and m["specific_heat"] is not None)


#: why a field is not in a run: no material with the model that makes it
FIELD_MODELS = {
    "damage": (_has_damage, "no material of this run has a damage model (HJC or Johnson-Cook "
                            "failure)"),
    "temperature": (_heats, "no material of this run has a temperature model (heating by "
                            "plastic work with a specific heat, or from the internal energy)"),
}


def material_names(run_dir):
    """The names of the run's materials in deck order (fsph.h5 /deck;
    'material N' where it cannot be read)."""
    with open_run_file(run_dir) as h5:
        materials = _deck_materials(h5) or []
        n = max([len(materials)] + [int(g["material"][...].max(initial=-1)) + 1
                                    for _, g in _snapshots(h5) if "material" in g])
    return [materials[k]["name"] if k < len(materials) else f"material {k + 1}"
            for k in range(n)]


def missing_fields(run_dir):
    """The fields of FIELDS a run does not have, each with why: its
    dataset in none of the snapshots, or (damage, temperature) no material
    of the deck with the model that computes it (their stored values are
    then zero and room temperature throughout). A dict NAME -> reason."""
    missing = {}
    with open_run_file(run_dir) as h5:
        snaps = [g for _, g in _snapshots(h5)]
        materials = _deck_materials(h5)
        for field, (_, _, dataset, _, _) in FIELDS.items():
            if not any(dataset in g or f"particles/{dataset}" in g for g in snaps):
                missing[field] = "not stored in the snapshots of this run"
            elif field in FIELD_MODELS and materials is not None:
                has, why = FIELD_MODELS[field]
                if not any(has(m) for m in materials):
                    missing[field] = why
    return missing


#: A pressure below this fraction of the largest of the other sign is
#: round-off (an unloaded body's 1e-11 of the shock's), not a sign of its own
PRESSURE_ROUND_OFF = 1e-6


def _field_scale(field, lo, hi):
    """The colour map and scale of a field from lo to hi (its least and
    largest value over the panels): (cmap, norm). Pressure keeps zero at the
    middle colour of its diverging map: diverging about zero where it takes
    both signs, else the half of the map on its side, from zero to its
    largest magnitude (a side within PRESSURE_ROUND_OFF of the other is
    round-off and drawn as zero),
    so no colour says tension or compression that is not there; the plastic
    strain on a square-root scale (a few converted particles strain ten
    times more than the rest); a field of one value gets a small range
    about it."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap, Normalize, PowerNorm, TwoSlopeNorm
    cmap = plt.get_cmap(FIELDS[field][4])
    if field == "pressure":
        largest = max(abs(lo), abs(hi))
        lo = 0.0 if lo > -PRESSURE_ROUND_OFF * largest else lo
        hi = 0.0 if hi < PRESSURE_ROUND_OFF * largest else hi
        if lo < 0.0 < hi:
            return cmap, TwoSlopeNorm(0.0, lo, hi)
        if hi > 0.0 or lo < 0.0:
            half = np.linspace(0.5, 1.0, 128) if hi > 0.0 else np.linspace(0.0, 0.5, 128)
            return (ListedColormap(cmap(half), name=f"{cmap.name}_half"),
                    Normalize(min(lo, 0.0), max(hi, 0.0)))
    if not hi > lo:
        pad = 0.01 * abs(lo) or 0.5
        return cmap, Normalize(lo - pad, hi + pad)
    if field == "eps_p":
        return cmap, PowerNorm(0.5, lo, hi)
    return cmap, Normalize(lo, hi)


def _without_model(h5, field):
    """Indices of the materials whose points carry no value of the field
    (damage, temperature: a material without the model; their stored zero
    damage and room temperature mean nothing), as a set."""
    materials = _deck_materials(h5) if field in FIELD_MODELS else None
    if not materials:
        return set()
    has = FIELD_MODELS[field][0]
    return {k for k, m in enumerate(materials) if not has(m)}


def _panel(g, field, without):
    """The drawing of a field in snapshot g: a dict with, where the snapshot
    has them, 'nodes' (n, 2) [mm] and for the elements 'conn', 'values'
    (the field in its unit) and 'own' (bool: of a material with the
    field's model), and for the particles 'x' [mm], 'radius' [mm],
    'p_values' and 'p_own'."""
    elements, particles = _field_values(g, field)
    out = {}
    if elements is not None:
        out["nodes"] = g["nodes"][...] * 1e3
        out["conn"] = g["connectivity"][...]
        out["values"] = elements
        out["own"] = ~np.isin(g["material"][...], list(without))
    if particles is not None:
        out["x"] = g["particles/x"][...] * 1e3
        out["radius"] = g["particles/radius"][...] * 1e3
        out["p_values"] = particles
        out["p_own"] = ~np.isin(g["particles/material"][...], list(without))
    return out


def _two_slope_ticks(lo, hi):
    """Ticks of a colour bar from lo < 0 to hi > 0 with zero in its middle:
    a few on each side (one linear locator over both leaves the short side
    bare)."""
    from matplotlib.ticker import MaxNLocator
    below = MaxNLocator(3).tick_values(lo, 0.0)
    above = MaxNLocator(4).tick_values(0.0, hi)
    ticks = np.concatenate([below[below >= lo], above[(above <= hi) & (above > 0.0)]])
    return np.unique(ticks)


def _field_extent(panels, frame):
    """Half-width and (z_low, z_high) [mm] of the panels of a field picture:
    all the points drawn (perforation runs: frame, three hole diameters,
    wide, and the points within it), with a margin."""
    width, top, bottom = 0.0, -np.inf, np.inf
    for _, p in panels:
        points = ([p["nodes"][np.unique(p["conn"])]] if "conn" in p else []) + \
                 ([p["x"]] if "x" in p else [])
        if not points:
            continue
        xy = np.vstack(points)
        width = max(width, xy[:, 0].max())
        top = max(top, xy[:, 1].max())
        near = xy[xy[:, 0] <= (frame or np.inf), 1]
        bottom = min(bottom, near.min() if len(near) else xy[:, 1].min())
    if not np.isfinite(top):
        width, top, bottom = 1.0, 1.0, 0.0
    margin = 0.04 * max(top - bottom, 1e-3)
    return (frame if frame else 1.1 * width), (bottom - margin, top + margin)


#: inches^2 of a panel of a field picture, and the width / height of the
#: whole picture its grid of panels comes closest to
FIELD_PANEL_AREA = 12.0
FIELD_ASPECT = 1.8
#: inches: the narrowest room for a panel, wide enough for its title (the
#: snapshot's time, '12.34 µs'); a slenderer body is drawn narrower in it
FIELD_PANEL_MIN_WIDTH = 1.1


def _field_grid(n, ratio):
    """(rows, columns) and (width, height) [inches] of the panels of a
    field picture: n panels of height / width `ratio` (a rod: one row; a
    plate or a debris cloud, wider than tall: a grid), each of about
    FIELD_PANEL_AREA, at most 5.5 inches tall and 7 wide, at least
    FIELD_PANEL_MIN_WIDTH wide."""
    width = min(max(np.sqrt(FIELD_PANEL_AREA / ratio), 1.3), 7.0)
    height = min(max(width * ratio, 1.5), 5.5)
    width = max(min(width, height / ratio), FIELD_PANEL_MIN_WIDTH) if ratio > 0 else width
    cols = min(range(1, n + 1), key=lambda c: abs(np.log(c * width / (-(-n // c) * height))
                                                  - np.log(FIELD_ASPECT)))
    return (-(-n // cols), cols), (width, height)


def _field_figure(run_dir, field, times_us=None):
    """The figure of field_map (matplotlib Figure, not saved)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import ListedColormap, Normalize, TwoSlopeNorm
    from matplotlib.patches import Patch

    run_dir = Path(run_dir)
    summary = read_summary(run_dir)
    _, frame = _shape_marks(summary)
    names = material_names(run_dir)
    with open_run_file(run_dir) as h5:
        without = _without_model(h5, field)
        panels = [(time, _panel(g, field, without))
                  for _, time, g in choose_snapshots(_snapshots(h5), times_us)]
    if field == "material":
        n = max(len(names), 1)
        cmap = ListedColormap([MATERIAL_COLOURS[k % len(MATERIAL_COLOURS)] for k in range(n)])
        norm = Normalize(-0.5, n - 0.5)
    else:
        values = [p[v][p[own]] for _, p in panels
                  for v, own in (("values", "own"), ("p_values", "p_own")) if v in p]
        values = [v for v in values if len(v)] or [np.zeros(1)]
        cmap, norm = _field_scale(field, min(v.min() for v in values), max(v.max() for v in values))

    half, (z_low, z_high) = _field_extent(panels, frame)
    ratio = (z_high - z_low) / (2 * half)
    (n_rows, n_cols), (panel_width, panel_height) = _field_grid(len(panels), ratio)
    fig, grid = plt.subplots(n_rows, n_cols, sharex=True, sharey=True, squeeze=False,
                             layout="constrained",
                             figsize=(n_cols * panel_width + 1.6, n_rows * panel_height + 1.5))
    axes = grid.ravel()[:len(panels)]
    for ax in grid.ravel()[len(panels):]:
        fig.delaxes(ax)
    dots = []       # (axes, scatter, radius [mm]): sized once the layout is known
    drawn = set()   # material indices drawn (the material picture's legend)
    for k, (ax, (time, p)) in enumerate(zip(axes, panels)):
        if field == "material":
            drawn.update(np.unique(np.concatenate([p.get("values", []), p.get("p_values", [])]))
                         .astype(int).tolist())
        for side in (1.0, -1.0):
            if "conn" in p:
                x, z, own = side * p["nodes"][:, 0], p["nodes"][:, 1], p["own"]
                if own.any():
                    ax.tripcolor(x, z, p["conn"][own], facecolors=p["values"][own], cmap=cmap,
                                 norm=norm, edgecolors="face", linewidth=0.4)
                if not own.all():
                    tri = np.stack([x, z], axis=1)[p["conn"][~own]]
                    ax.add_collection(PolyCollection(tri, facecolors=NO_MODEL_COLOUR,
                                                     edgecolors=NO_MODEL_COLOUR,
                                                     linewidths=0.4))
            if "x" in p:
                own = p["p_own"]
                for keep, style in ((own, {"c": p["p_values"][own], "cmap": cmap, "norm": norm}),
                                    (~own, {"color": NO_MODEL_COLOUR})):
                    if keep.any():
                        dots.append((ax, ax.scatter(side * p["x"][keep, 0], p["x"][keep, 1],
                                                    s=1.0, linewidths=0, **style),
                                     p["radius"][keep]))
        ax.set_title(f"{format_us(time * 1e6)} µs")
        ax.set_xlim(-half, half)
        ax.set_ylim(z_low, z_high)
        ax.set_aspect("equal")
        if k + n_cols >= len(panels):       # no panel below it
            ax.set_xlabel("r [mm]")
            ax.xaxis.set_tick_params(labelbottom=True)
        if k % n_cols == 0:
            ax.set_ylabel("z [mm]")
    title = summary.get("title") or summary.get("case", "")
    what = FIELDS[field][0]
    fig.suptitle(textwrap.fill(title, width=int(14 * n_cols * panel_width)) + "\n"
                 + (what if field in what.split() else f"{what} ({field})"))
    if field == "material":
        handles = [Patch(facecolor=cmap(k), label=names[k]) for k in sorted(drawn)]
    else:
        bar = fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), ax=list(axes),
                           shrink=0.9, label=field_label(field))
        if isinstance(norm, TwoSlopeNorm):      # ticks on both sides of zero
            ticks = _two_slope_ticks(norm.vmin, norm.vmax)
            bar.set_ticks(ticks, labels=[f"{t:g}" for t in ticks])
        handles = [Patch(facecolor=NO_MODEL_COLOUR, label=f"{names[k]}: no {field} model")
                   for k in sorted(without) if k < len(names)]
    if handles:
        fig.legend(handles=handles, loc="outside lower center", ncol=min(len(handles), 4),
                   frameon=False, fontsize="small")
    # the particles as discs of their radius at the panels' scale [pt/mm],
    # at least a point across (smaller ones fall apart into single pixels)
    fig.draw_without_rendering()
    for ax, dot, r in dots:
        pt_per_mm = ax.bbox.width * 72.0 / fig.dpi / np.diff(ax.get_xlim())[0]
        dot.set_sizes(np.maximum(2.0 * r * pt_per_mm, 1.0) ** 2)
    return fig


def field_map(run_dir, field, times_us=None, output=None, dpi=150):
    """Write a PNG of a field (FIELDS: eps_p, pressure, mises, temperature,
    damage, density, material) at the chosen snapshots (choose_snapshots, as
    shapes.png: the snapshot nearest each requested time [µs], each once;
    without times, four spread evenly over the run), one panel each titled
    with its snapshot's time: elements flat-coloured per triangle, particles
    as discs of their radius, mirrored about the axis (a section through the
    body), equal aspect, one colour scale over the picture from the field's
    least to its largest value over the panels drawn (_field_scale:
    pressure keeps zero in the middle colour), and a colour bar
    naming the quantity and its unit; material: one colour per material of
    the deck, named in the legend. A perforation run is framed as in
    shapes.png (three hole diameters). Returns the PNG path (default
    RUN_DIR/field_<field>.png); InputError for a field not in FIELDS or not
    in the run (missing_fields)."""
    run_dir = Path(run_dir)
    missing = missing_fields(run_dir)
    if field not in FIELDS or field in missing:
        raise InputError(f"field {field}: {missing.get(field, 'no such field')}")
    output = Path(output) if output else run_dir / f"field_{field}.png"
    _save(_field_figure(run_dir, field, times_us), output, dpi, bbox_inches="tight")
    return output


#: colour of the failed runs of a sweep (crosses on the axis of sweep.png)
FAILED_COLOUR = "red"


def residual_velocity(points, fits=(), experiment=(), output="residual.png", title=None,
                      dpi=120, failed=()):
    """Write a PNG of residual against striking velocity: `points` a list of
    (label, v_s, v_r) computed series, `fits` a list of (label, fit) with a
    fit of fsph.ballistics.fit_recht_ipson drawn as a curve, `experiment`
    (v_s, v_r) pairs of measurements, `failed` the striking velocities of
    runs that failed (red crosses on the axis, v_r = 0, with their count in
    the legend); returns the PNG path."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .ballistics import recht_ipson

    output = Path(output)
    fig, ax = plt.subplots(figsize=(6, 4.5))
    top = max([max(v_s, default=0.0) for _, v_s, _ in points]
              + [v for v, _ in experiment] + list(failed) + [1.0])
    grid = np.linspace(0.0, 1.05 * top, 300)
    for i, (label, v_s, v_r) in enumerate(points):
        ax.plot(v_s, v_r, "os^v"[i % 4], mfc="none" if i else None, label=label)
    for label, fit in fits:
        ax.plot(grid, recht_ipson(grid, fit["v_bl"], fit["a"], fit["p"]), "-", label=label)
    if experiment:
        v_s, v_r = zip(*experiment)
        ax.plot(v_s, v_r, "kx", ms=8, label="experiment")
    if len(failed):
        ax.plot(failed, np.zeros(len(failed)), "x", color=FAILED_COLOUR, ms=9, mew=2, ls="",
                clip_on=False, zorder=5, label=f"failed run ({len(failed)})")
    ax.set_xlabel("striking velocity [m/s]")
    ax.set_ylabel("residual velocity [m/s]")
    if title:
        ax.set_title(title)
    ax.legend(fontsize="small")
    fig.tight_layout()
    _save(fig, output, dpi)
    return output
