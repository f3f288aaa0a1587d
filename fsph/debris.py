"""Debris-cloud diagnostics of a flyer striking a plate at hypervelocity
(Piekutowski 1990's radiographs): the front of each body's cloud, the
back-splash ejecta height, the radius where the two clouds meet, the hole
in the plate, cloud masses and momenta, and the 1D interface state just
after impact. Definitions: docs/validation.md, "Debris clouds".

Bodies may be particles, elements or both: elements count by their nodes
(node mass, velocity; a node's reach is half its shortest edge) and, for
the interface state, by their centroids (element pressure and mass).
Vectorised numpy and scipy over points, no loops over particles or
elements. Lengths in the records are in mm, along the flight direction
from the plate's front face before impact."""

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .hugoniot import ShockMaterial, impedance_match
from .points import node_radii, state_masses

#: Fractions of a cloud's mass at which the fronts are tabulated [-].
FRONT_FRACTIONS = (0.005, 0.01, 0.02)
#: Width of the rings of the intact-plate test, in plate spacings [-].
RING_SPACINGS = 2.0
#: The probe of the interface state: within this fraction of the flyer's
#: radius from the axis [-], from this many spacings from the impact
#: plane [-] to this fraction of the distance the shock has run [-], once
#: that range spans this many spacings (several layers averaged) [-].
PROBE_RADIUS_FRACTION = 1.0 / 3.0
PROBE_FIRST_SPACINGS = 2.0
PROBE_SHOCK_FRACTION = 0.5
PROBE_MIN_SPACINGS = 3.0


def fraction_tag(fraction):
    """Key tag of a front fraction: 0.005 -> '0p5pct', 0.01 -> '1pct'."""
    return f"{100.0 * fraction:g}".replace(".", "p") + "pct"


def _units():
    """Units of every key of a per-snapshot debris record."""
    units = {"time_us": "us", "flyer_front_mm": "mm", "target_front_mm": "mm",
             "front_ratio": "-"}
    for q in FRONT_FRACTIONS:
        for body in ("flyer", "target"):
            units[f"{body}_front_{fraction_tag(q)}_mm"] = "mm"
    units.update({"flyer_cloud_radius_mm": "mm", "target_cloud_radius_mm": "mm",
                  "ejecta_height_mm": "mm", "intersection_radius_mm": "mm",
                  "hole_diameter_mm": "mm",
                  "flyer_cloud_mass_kg": "kg", "target_cloud_mass_kg": "kg", "ejecta_mass_kg": "kg",
                  "flyer_cloud_momentum_z_N_s": "N s", "target_cloud_momentum_z_N_s": "N s",
                  "flyer_mass_kg": "kg", "target_mass_kg": "kg", "momentum_z_N_s": "N s",
                  "flyer_failed_mass_kg": "kg", "target_failed_mass_kg": "kg",
                  "flyer_melted_mass_kg": "kg", "target_melted_mass_kg": "kg",
                  "flyer_interface_pressure_GPa": "GPa", "target_interface_pressure_GPa": "GPa",
                  "flyer_interface_velocity_m_s": "m/s", "target_interface_velocity_m_s": "m/s"})
    return units


#: Units of the per-snapshot record (the `units` attribute of the
#: /metrics/debris datasets of fsph.h5).
UNITS = _units()


@dataclass
class Points:
    """The points of one body: positions x and initial positions x0 (n, 2)
    (r, z) [m], velocities v (n, 2) [m/s], masses [kg], reach [m] (a
    particle's smoothing length, a node's half shortest edge) and radius
    [m] (a particle's, 0 for a node) now and initially (radius0)."""

    x: np.ndarray
    x0: np.ndarray
    v: np.ndarray
    mass: np.ndarray
    reach: np.ndarray
    radius: np.ndarray
    radius0: np.ndarray

    def __len__(self):
        return len(self.mass)

    def take(self, keep):
        """The points selected by a mask or index array."""
        return Points(self.x[keep], self.x0[keep], self.v[keep], self.mass[keep],
                      self.reach[keep], self.radius[keep], self.radius0[keep])


def _no_points():
    empty = np.zeros((0, 2))
    return Points(empty, empty, empty, np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0))


def _node_points(snap, body_index):
    """The nodes of a body's elements, as Points."""
    if "conn" not in snap or not len(snap["conn"]):
        return _no_points()
    conn = snap["conn"][snap["body"] == body_index]
    if not len(conn):
        return _no_points()
    ids = np.unique(conn)
    index = np.full(len(snap["x"]), -1)
    index[ids] = np.arange(len(ids))
    edges = index[np.vstack([conn[:, [0, 1]], conn[:, [1, 2]], conn[:, [2, 0]]])]
    zero = np.zeros(len(ids))
    return Points(snap["x"][ids], snap["x0"][ids], snap["velocity"][ids], snap["node_mass"][ids],
                  node_radii(snap["x"][ids], edges), zero, zero)


def _particle_points(snap, body_index):
    """A body's particles, as Points."""
    if "particles" not in snap:
        return _no_points()
    part = snap["particles"]
    keep = part["body"] == body_index
    return Points(part["x"][keep], part["x0"][keep], part["velocity"][keep], part["mass"][keep],
                  part["h"][keep], part["radius"][keep], part["radius0"][keep])


def _body_parts(snap, body_index):
    """A body's (nodes, particles), each as Points."""
    return _node_points(snap, body_index), _particle_points(snap, body_index)


def _joined(parts):
    """The Points of a body's parts together, nodes first."""
    parts = [p for p in parts if len(p)]
    if not parts:
        return _no_points()
    return Points(*[np.concatenate([getattr(p, name) for p in parts])
                    for name in ("x", "x0", "v", "mass", "reach", "radius", "radius0")])


def _parts_spacing(parts):
    """The initial spacing [m] of the points a body started as
    (initial_spacing): its elements' nodes while it has elements, its
    particles otherwise. The particles converted from elements stand at
    the elements' initial centroids, between the nodes, and were not
    points of the mesh: counted in, they made an adaptive plate's spacing
    a third of its mesh's and its rings too narrow to hold a column of
    nodes that the plate's outward flow had moved by half a column."""
    nodes, particles = parts
    return initial_spacing((nodes if len(nodes) >= 2 else particles).x0)


def body_points(snap, body_index):
    """The nodes of a body's elements and its particles, as Points."""
    return _joined(_body_parts(snap, body_index))


def body_spacing(snap, body_index):
    """_parts_spacing of a body of the snapshot [m]."""
    return _parts_spacing(_body_parts(snap, body_index))


@dataclass(frozen=True)
class Frame:
    """Where the plate was: the flight direction along z (+1 or -1), the
    plate's front face z_face [m] (its initial extreme on the flyer's
    side) and its thickness [m]."""

    direction: float
    z_face: float
    thickness: float

    @classmethod
    def of_plate(cls, bottom, top, direction):
        """From the plate's initial lower and upper faces [m]."""
        return cls(direction, top if direction < 0 else bottom, top - bottom)

    def along(self, z):
        """Distance [m] along the flight direction from the front face."""
        return self.direction * (np.asarray(z) - self.z_face)


def initial_spacing(x0):
    """The median distance [m] from a point's initial position to its
    nearest neighbour's (nan for fewer than two points)."""
    from scipy.spatial import cKDTree
    if len(x0) < 2:
        return float("nan")
    dist, _ = cKDTree(x0).query(x0, k=2)
    return float(np.median(dist[:, 1]))


def upper_quantile(position, mass, fraction):
    """The position beyond which lies `fraction` of the mass: of the points
    sorted by decreasing position, the first at which the mass so far
    reaches fraction times the total (None without points)."""
    if len(position) == 0:
        return None
    order = np.argsort(-np.asarray(position), kind="stable")
    held = np.cumsum(np.asarray(mass)[order])
    # the relative slack keeps a fraction that is exactly a sum of point
    # masses on its point despite round-off in the sums
    k = np.searchsorted(held, fraction * held[-1] * (1.0 - 1e-12))
    return float(np.asarray(position)[order][min(k, len(held) - 1)])


def ring_edges(r0, ring_width):
    """Inner edges [m] of the rings of the intact-plate test, from the
    initial radii r0 [m] of the plate's points: midpoints between
    consecutive columns of points, each the first at least ring_width [m]
    beyond the edge before it (the first at least ring_width from the
    axis), so that no ring is narrower than ring_width. Where the columns
    are closer than ring_width (the uniform zone) the rings are ring_width
    wide or a little more; where they are farther apart (a graded rim)
    each column has a ring of its own, reaching halfway to its
    neighbours, so that a column that moves by less than that stays in
    its ring. Radii within a millionth of ring_width are one column (a
    column whose points differ by round-off gets no edge through it).
    (Thinned instead to one edge per ring_width of radius, two edges
    could stand almost together: on the adaptive plate of case 1 refined
    ×2 a ring 0.58 ring_width wide where the uniform zone meets the
    graded rim held 48 % of its mass as the plate bent elastically, and
    the hole measured 42.1 mm.) The loop is over the rings, not the
    points."""
    columns = np.unique(np.round(np.asarray(r0) / ring_width, 6)) * ring_width
    mid = 0.5 * (columns[:-1] + columns[1:])
    # the relative slack keeps a gap of exactly ring_width despite round-off
    reach = ring_width * (1.0 - 1e-9)
    edges = []
    k = int(np.searchsorted(mid, reach))
    while k < len(mid):
        edges.append(mid[k])
        k = int(np.searchsorted(mid, mid[k] + reach))
    return np.array(edges)


def intact_plate(target, frame, intact_fraction, ring_width):
    """Which target points are intact plate (mask) and the hole radius
    [m] (the smallest radius of intact material, a particle's centre less
    its radius; 0 when every ring is intact, None when none is): points in
    the band -T <= s <= 2T in rings (ring_edges) that hold at least
    intact_fraction of the mass that started in them, from the outermost
    ring inwards to the first ring that holds less."""
    s = frame.along(target.x[:, 1])
    band = (s >= -frame.thickness) & (s <= 2.0 * frame.thickness)
    edges = ring_edges(target.x0[:, 0], ring_width)
    n_rings = len(edges) + 1
    ring0 = np.searchsorted(edges, target.x0[:, 0], side="right")
    ring = np.searchsorted(edges, target.x[:, 0], side="right")
    started = np.bincount(ring0, weights=target.mass, minlength=n_rings)
    held = np.bincount(ring[band], weights=target.mass[band], minlength=n_rings)
    failing = np.nonzero(held < intact_fraction * started)[0]
    if not len(failing):
        return band, 0.0                    # intact to the axis: no hole
    intact = band & (ring > failing.max())
    if not intact.any():
        return intact, None
    return intact, float((target.x[intact, 0] - target.radius[intact]).min())


def touching(points, others):
    """Mask of `points` within the sum of the two reaches of some point of
    `others`."""
    from scipy.spatial import cKDTree
    if len(points) == 0 or len(others) == 0:
        return np.zeros(len(points), dtype=bool)
    reach_max = points.reach.max() + others.reach.max()
    pairs = cKDTree(points.x).sparse_distance_matrix(cKDTree(others.x), reach_max,
                                                     output_type="ndarray")
    near = pairs["v"] <= points.reach[pairs["i"]] + others.reach[pairs["j"]]
    out = np.zeros(len(points), dtype=bool)
    out[pairs["i"][near]] = True
    return out


def _mm(value):
    return None if value is None else value * 1e3


def _fronts(cloud, frame, front_fraction, prefix):
    """Front of a cloud [mm] at front_fraction and at FRONT_FRACTIONS."""
    s = frame.along(cloud.x[:, 1])
    out = {f"{prefix}_front_mm": _mm(upper_quantile(s, cloud.mass, front_fraction))}
    for q in FRONT_FRACTIONS:
        out[f"{prefix}_front_{fraction_tag(q)}_mm"] = _mm(upper_quantile(s, cloud.mass, q))
    return out


def element_centroids(snap, body_index):
    """Centroids of a body's elements: initial positions (k, 2) [m],
    velocities (mean of the nodes') [m/s], pressures [Pa] and masses [kg]."""
    if "conn" not in snap or not len(snap["conn"]):
        return np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), np.zeros(0)
    keep = snap["body"] == body_index
    conn = snap["conn"][keep]
    return (snap["x0"][conn].mean(axis=1), snap["velocity"][conn].mean(axis=1),
            snap["pressure"][keep], snap["element_mass"][keep])


def interface_probe(snap, body_index, frame, flyer_radius, shock_run, spacing, flyer_side):
    """Mass-weighted mean pressure [Pa] and velocity along the flight
    direction [m/s] of a body's particles and element centroids that
    started within PROBE_RADIUS_FRACTION of the flyer's radius of the axis
    and between PROBE_FIRST_SPACINGS spacings [m] and PROBE_SHOCK_FRACTION
    of shock_run [m] (the distance the body's shock has run through it)
    from the impact plane; (None, None) before that range spans
    PROBE_MIN_SPACINGS spacings, or where no point qualifies. flyer_side:
    the body lies uprange of the impact plane (the flyer)."""
    near, far = PROBE_FIRST_SPACINGS * spacing, PROBE_SHOCK_FRACTION * shock_run
    if far - near < PROBE_MIN_SPACINGS * spacing:
        return None, None
    x0, v, p, m = element_centroids(snap, body_index)
    if "particles" in snap:
        part = snap["particles"]
        keep = part["body"] == body_index
        x0 = np.vstack([x0, part["x0"][keep]])
        v = np.vstack([v, part["velocity"][keep]])
        p = np.concatenate([p, part["pressure"][keep]])
        m = np.concatenate([m, part["mass"][keep]])
    depth = frame.along(x0[:, 1])               # from the impact plane, the plate's front face
    if flyer_side:
        depth = -depth
    probe = (x0[:, 0] <= PROBE_RADIUS_FRACTION * flyer_radius) & (depth >= near) & (depth <= far)
    if not probe.any():
        return None, None
    weight = m[probe] / m[probe].sum()
    return float(weight @ p[probe]), float(frame.direction * (weight @ v[probe, 1]))


def _extent(points):
    """Initial (r_max, z_low, z_high) [m] of a body's points: element
    nodes as they are, particles with their initial radius."""
    return ((points.x0[:, 0] + points.radius0).max(), (points.x0[:, 1] - points.radius0).min(),
            (points.x0[:, 1] + points.radius0).max())


@lru_cache(maxsize=16)
def _impedance(flyer_shock, target_shock, impact_speed, flyer_length, plate_thickness):
    """hugoniot.impedance_match, kept: the same case asks at every snapshot."""
    return impedance_match(flyer_shock, target_shock, impact_speed, flyer_length, plate_thickness)


@dataclass(frozen=True)
class DebrisCase:
    """What the debris diagnostics need from the deck: the flyer's and the
    target's body indices, names and materials (ShockMaterial, None for an
    EOS without a linear Us-up Hugoniot; the flyer's also for a sphere,
    whose shock is not the 1D state), the flyer's speed relative to
    the target [m/s] and its direction along z (+1, -1), the thresholds,
    and the generated bodies' dimensions [m]: the flyer's (radius,
    length) and the plate's (lower face, upper face), None for a body
    read from a mesh file (then taken from its initial nodes)."""

    flyer: int
    target: int
    flyer_name: str
    target_name: str
    flyer_material: str
    target_material: str
    flyer_shock: ShockMaterial
    target_shock: ShockMaterial
    impact_speed: float
    direction: float
    front_fraction: float
    intact_fraction: float
    flyer_size: tuple = None
    plate_faces: tuple = None

    @classmethod
    def from_deck(cls, deck):
        met = deck["metrics"]
        names = [b["name"] for b in deck["body"]]
        flyer = names.index(met["body"]) if met["body"] else 0
        target = names.index(met["target"]) if met["target"] else (1 if flyer == 0 else 0)
        bodies = deck["body"]
        relative = bodies[flyer]["velocity_z"] - bodies[target]["velocity_z"]
        materials = {m["name"]: m for m in deck["material"]}

        def shock(body):
            material = materials[body["material"]]
            return ShockMaterial.from_deck(material) if material["eos"] == "mie_gruneisen" else None

        def planar(body):
            # a sphere strikes with a point, not a face: its shock is not the 1D state
            return body["geometry"] != "sphere"

        def generated(body):
            return body["geometry"] != "gmsh"
        fb, tb = bodies[flyer], bodies[target]
        return cls(flyer, target, names[flyer], names[target], fb["material"], tb["material"],
                   shock(fb) if planar(fb) else None, shock(tb), abs(relative), 1.0 if relative > 0.0 else -1.0,
                   met["front_fraction"], met["intact_fraction"],
                   (fb["radius"], fb["length"]) if generated(fb) else None,
                   (tb["z_base"], tb["z_base"] + tb["length"]) if generated(tb) else None)

    def frame(self, target):
        """The plate's Frame: from the deck, or from the target's points."""
        if self.plate_faces is not None:
            return Frame.of_plate(*self.plate_faces, self.direction)
        return Frame.of_plate(*_extent(target)[1:], self.direction)

    def flyer_dimensions(self, flyer):
        """The flyer's initial radius and length [m]: from the deck, or
        from its points."""
        if self.flyer_size is not None:
            return self.flyer_size
        r_max, z_low, z_high = _extent(flyer)
        return r_max, z_high - z_low

    def impedance(self, flyer, frame):
        """The 1D impedance match (hugoniot.impedance_match) of this case:
        the flyer's initial length, the plate's thickness (None without
        two linear Hugoniots)."""
        if self.flyer_shock is None or self.target_shock is None:
            return None
        return _impedance(self.flyer_shock, self.target_shock, self.impact_speed,
                          self.flyer_dimensions(flyer)[1], frame.thickness)


def _interface(snap, case, frame, flyer, match, parts):
    """The four interface entries of a record: each body's probe pressure
    [GPa] and velocity [m/s] while the plate's shock has not reached the
    plate's rear face (None outside that window); parts: each body's
    (nodes, particles) by its index."""
    out = {f"{b}_interface_{q}": None for b in ("flyer", "target")
           for q in ("pressure_GPa", "velocity_m_s")}
    t = snap["time"]
    if match is None or not 0.0 < t <= match["target_transit_s"]:
        return out
    flyer_radius = case.flyer_dimensions(flyer)[0]
    for name, index, speed, flyer_side in (
            ("flyer", case.flyer, match["flyer_shock_speed_m_s"], True),
            ("target", case.target, match["target_shock_speed_m_s"], False)):
        pressure, velocity = interface_probe(snap, index, frame, flyer_radius, speed * t,
                                             _parts_spacing(parts[index]), flyer_side)
        out[f"{name}_interface_pressure_GPa"] = None if pressure is None else pressure / 1e9
        out[f"{name}_interface_velocity_m_s"] = velocity
    return out


def _momentum_z(snap):
    """Axial momentum of every node and particle and of the nodes erosion
    removed [kg m/s]."""
    total = snap.get("eroded_momentum_z", 0.0)
    if "conn" in snap and len(snap["conn"]):
        total += snap["node_mass"] @ snap["velocity"][:, 1]
    if "particles" in snap:
        total += snap["particles"]["mass"] @ snap["particles"]["velocity"][:, 1]
    return float(total)


def debris(snap, case):
    """The per-snapshot debris record of `snap` (keys: UNITS; lengths [mm]
    along the flight direction from the plate's front face before impact,
    None where the group they measure is empty)."""
    parts = {index: _body_parts(snap, index) for index in (case.flyer, case.target)}
    flyer, target = _joined(parts[case.flyer]), _joined(parts[case.target])
    frame = case.frame(target)
    ring_width = RING_SPACINGS * _parts_spacing(parts[case.target])
    intact, hole_radius = intact_plate(target, frame, case.intact_fraction, ring_width)
    beyond = frame.thickness
    flyer_cloud = flyer.take(frame.along(flyer.x[:, 1]) > beyond)
    target_cloud = target.take((frame.along(target.x[:, 1]) > beyond) & ~intact)
    ejecta = [p.take((frame.along(p.x[:, 1]) < 0.0) & (frame.direction * p.v[:, 1] < 0.0) & ~keep)
              for p, keep in ((flyer, np.zeros(len(flyer), dtype=bool)), (target, intact))]
    ejecta_height = upper_quantile(np.concatenate([-frame.along(p.x[:, 1]) for p in ejecta]),
                                   np.concatenate([p.mass for p in ejecta]), case.front_fraction)
    meeting = flyer_cloud.take(touching(flyer_cloud, target_cloud))
    record = {"time_us": snap["time"] * 1e6}
    record.update(_fronts(flyer_cloud, frame, case.front_fraction, "flyer"))
    record.update(_fronts(target_cloud, frame, case.front_fraction, "target"))
    fronts = (record["flyer_front_mm"], record["target_front_mm"])
    record["front_ratio"] = fronts[0] / fronts[1] if None not in fronts and fronts[1] > 0 else None
    record.update({
        "flyer_cloud_radius_mm": _mm(upper_quantile(flyer_cloud.x[:, 0], flyer_cloud.mass,
                                                    case.front_fraction)),
        "target_cloud_radius_mm": _mm(upper_quantile(target_cloud.x[:, 0], target_cloud.mass,
                                                     case.front_fraction)),
        "ejecta_height_mm": _mm(ejecta_height),
        "intersection_radius_mm": _mm(upper_quantile(meeting.x[:, 0], meeting.mass,
                                                     case.front_fraction)),
        "hole_diameter_mm": None if hole_radius is None else 2e3 * max(hole_radius, 0.0),
        "flyer_cloud_mass_kg": float(flyer_cloud.mass.sum()),
        "target_cloud_mass_kg": float(target_cloud.mass.sum()),
        "ejecta_mass_kg": float(sum(p.mass.sum() for p in ejecta)),
        "flyer_cloud_momentum_z_N_s": float(flyer_cloud.mass @ flyer_cloud.v[:, 1]),
        "target_cloud_momentum_z_N_s": float(target_cloud.mass @ target_cloud.v[:, 1]),
        "flyer_mass_kg": float(flyer.mass.sum()), "target_mass_kg": float(target.mass.sum()),
        "momentum_z_N_s": _momentum_z(snap)})
    for body, index in (("flyer", case.flyer), ("target", case.target)):
        state = state_masses(snap, index)
        record[f"{body}_failed_mass_kg"] = state["failed_mass_kg"]
        record[f"{body}_melted_mass_kg"] = state["melted_mass_kg"]
    record.update(_interface(snap, case, frame, flyer, case.impedance(flyer, frame), parts))
    return record


def impedance_check(snap, case, series):
    """The analytic 1D state of the case (from the first snapshot's
    geometry) beside the one measured in the run: the mean over the
    snapshots of `series` (the per-snapshot records) that have both
    bodies' interface probes, of the mean of the two bodies. None without
    two linear Hugoniots."""
    match = case.impedance(body_points(snap, case.flyer),
                           case.frame(body_points(snap, case.target)))
    if match is None:
        return None
    out = {"pressure_GPa": match["pressure_Pa"] / 1e9,
           "particle_velocity_m_s": match["particle_velocity_m_s"],
           "target_shock_speed_m_s": match["target_shock_speed_m_s"],
           "flyer_shock_speed_m_s": match["flyer_shock_speed_m_s"],
           "target_transit_us": match["target_transit_s"] * 1e6,
           "flyer_transit_us": match["flyer_transit_s"] * 1e6,
           "target_free_surface_m_s": match["target_free_surface_m_s"],
           "flyer_rear_surface_m_s": match["flyer_rear_surface_m_s"]}
    keys = ("flyer_interface_pressure_GPa", "target_interface_pressure_GPa",
            "flyer_interface_velocity_m_s", "target_interface_velocity_m_s")
    rows = [r for r in series if all(r.get(k) is not None for k in keys)]
    out["measured_snapshots"] = len(rows)
    if not rows:
        out.update({"measured_pressure_GPa": None, "measured_particle_velocity_m_s": None})
        return out
    pressure = np.mean([0.5 * (r[keys[0]] + r[keys[1]]) for r in rows])
    velocity = np.mean([0.5 * (r[keys[2]] + r[keys[3]]) for r in rows])
    out.update({"measured_pressure_GPa": float(pressure),
                "measured_particle_velocity_m_s": float(velocity),
                "measured_times_us": [r["time_us"] for r in rows],
                "pressure_error_percent": float(100.0 * (pressure / out["pressure_GPa"] - 1.0)),
                "particle_velocity_error_percent": float(
                    100.0 * (velocity / out["particle_velocity_m_s"] - 1.0))})
    return out
