"""Case metrics from a snapshot: Taylor L/D/W, elastic-bar stress plateau,
wave front and interface jump. Bodies may be elements, particles or both;
vectorised numpy over arrays, no loops over elements or particles."""

import numpy as np

from .mesh import boundary_edges
from .points import node_radii

EMPTY = np.zeros((0, 2))


def _body_elements(snap, body_index):
    keep = snap["body"] == body_index
    return snap["conn"][keep], keep


def _body_particles(snap, body_index):
    """A body's particles, selected once: centres (k, 2) [m], radii [m],
    masses [kg] and smoothing lengths [m] (k,)."""
    if "particles" not in snap:
        return EMPTY, np.zeros(0), np.zeros(0), np.zeros(0)
    part = snap["particles"]
    keep = part["body"] == body_index
    return part["x"][keep], part["radius"][keep], part["mass"][keep], part["h"][keep]


#: Height of the impact face's band, as a fraction of the initial length:
#: D is the largest diameter of the body within it (the mushroom's foot,
#: its rolled-over lip included) [-].
FACE_BAND = 0.02


def attached_points(x, reach, mass, links=None):
    """Which points belong to the body: the connected group of the largest
    mass, two points being connected when their distance is at most the sum
    of their reaches (a particle: its smoothing length, so that two
    particles are connected when they are SPH neighbours; a node: half its
    shortest edge), or when `links` (pairs of point indices, e.g. element
    edges) joins them. The other points are detached: fragments, or stray
    particles left on an anvil."""
    from ._core import fsph_api
    n = len(x)
    if n == 0:
        return np.zeros(0, dtype=bool)
    finite = np.where(np.isfinite(reach), reach, 0.0)
    links = np.zeros((0, 2), dtype=np.int32) if links is None else np.asarray(links).reshape(-1, 2)
    # the groups in Fortran (fsph_groups): label = smallest 1-based index of the group
    label = fsph_api.point_groups(np.asfortranarray(np.asarray(x, dtype=float).T), finite,
                                  np.asfortranarray((links + 1).astype(np.int32).T))
    main = np.bincount(label - 1, weights=mass, minlength=n).argmax()
    return label - 1 == main


def _body_proper(snap, body_index):
    """A body's points and which of them are the body proper
    (attached_points): its elements' connectivity (m, 3) over the
    snapshot's nodes, the index of each snapshot node among the body's
    nodes (-1: not the body's; None without elements), the body's node
    positions (n, 2) [m] and the mask of those attached, its particles'
    centres (k, 2) [m], radii [m] and masses [kg] and the mask of those
    attached."""
    xp, rad, p_mass, p_h = _body_particles(snap, body_index)
    nodes, node_r, node_m, links, index = EMPTY, np.zeros(0), np.zeros(0), None, None
    conn = _body_elements(snap, body_index)[0] if "conn" in snap else np.zeros((0, 3), dtype=int)
    if len(conn):
        ids = np.unique(conn)
        index = np.full(len(snap["x"]), -1)
        index[ids] = np.arange(len(ids))
        nodes = snap["x"][ids]
        links = index[np.vstack([conn[:, [0, 1]], conn[:, [1, 2]], conn[:, [2, 0]]])]
        node_r = node_radii(nodes, links)
        node_m = snap["node_mass"][ids] if "node_mass" in snap else np.ones(len(ids))
    keep = attached_points(np.vstack([nodes.reshape(-1, 2), xp.reshape(-1, 2)]),
                           np.concatenate([node_r, p_h]), np.concatenate([node_m, p_mass]), links)
    return conn, index, nodes, keep[:len(nodes)], xp, rad, p_mass, keep[len(nodes):]


def taylor(snap, body, body_index, w_height=None):
    """Taylor-test lengths of a body made of elements, particles or both,
    in mm, as the literature defines them (e.g. Johnson & Holmquist 1988):
    the final length L, the impact-face diameter D (the largest diameter
    within FACE_BAND L0 of the impact face: the foot, its lip included),
    the largest diameter D_max anywhere on the body, and the width W at
    w_height (default 0.2 L0) above the impact face. Only the body proper
    counts: particles that have left it (attached_points: no longer an SPH
    neighbour of the body, e.g. a fragment or a stray particle left on the
    anvil) are excluded from L, D, D_max and W, and
    their number and mass reported. Elements count by their nodes and
    boundary edges; each particle counts as a square of half-side its
    radius. The impact face is the lowest point of the body; W is twice
    the largest radius at which the deformed body (boundary edges crossing
    the level, or particles whose extent covers it) meets the level
    z_face + w_height."""
    ea, eb = EMPTY, EMPTY
    conn, index, nodes, keep_n, xp, rad, p_mass, keep_p = _body_proper(snap, body_index)
    if len(nodes):
        bnd = boundary_edges(conn)
        bnd = bnd[keep_n[index[bnd[:, 0]]] & keep_n[index[bnd[:, 1]]]]
        ea, eb = snap["x"][bnd[:, 0]], snap["x"][bnd[:, 1]]
        nodes = nodes[keep_n]
    detached = ~keep_p
    xp, rad = xp[keep_p], rad[keep_p]
    z_lo = min(nodes[:, 1].min(initial=np.inf), (xp[:, 1] - rad).min(initial=np.inf))
    z_hi = max(nodes[:, 1].max(initial=-np.inf), (xp[:, 1] + rad).max(initial=-np.inf))
    r_hi = max(nodes[:, 0].max(initial=-np.inf), (xp[:, 0] + rad).max(initial=-np.inf))
    face_top = z_lo + FACE_BAND * body["length"]
    in_face = nodes[:, 1] <= face_top
    p_face = xp[:, 1] - rad <= face_top
    r_face = max(nodes[in_face, 0].max(initial=-np.inf), (xp[p_face, 0] + rad[p_face]).max(initial=-np.inf))
    if w_height is None:
        w_height = 0.2 * body["length"]
    level = z_lo + w_height
    off_axis = (ea[:, 0] > 0.0) | (eb[:, 0] > 0.0)
    crosses = off_axis & ((ea[:, 1] - level) * (eb[:, 1] - level) <= 0.0) & (ea[:, 1] != eb[:, 1])
    t = (level - ea[crosses, 1]) / (eb[crosses, 1] - ea[crosses, 1])
    r_cross = ea[crosses, 0] + t * (eb[crosses, 0] - ea[crosses, 0])
    at_level = (xp[:, 1] - rad <= level) & (xp[:, 1] + rad >= level)
    r_level = max(r_cross.max(initial=-np.inf),
                  (xp[at_level, 0] + rad[at_level]).max(initial=-np.inf))
    width = 2.0 * r_level if np.isfinite(r_level) else float("nan")
    return {"L_mm": (z_hi - z_lo) * 1e3, "D_mm": 2.0 * r_face * 1e3, "D_max_mm": 2.0 * r_hi * 1e3,
            "W_mm": width * 1e3, "w_height_mm": w_height * 1e3,
            "face_band_mm": FACE_BAND * body["length"] * 1e3,
            "n_detached_particles": int(detached.sum()),
            "detached_mass_kg": float(p_mass[detached].sum()) if len(p_mass) else 0.0}


def field_peaks(snap, fields=("plastic_strain", "temperature", "internal_energy")):
    """Largest value of each of fields (plastic strain [-], temperature [K],
    specific internal energy [J/kg])
    over elements and particles, with where: the point (r, z) [mm] (element
    centroid or particle centre), whether an element or a particle, its
    index in the snapshot, its id (the snapshots' `id` field, which stays
    with it: elements are removed and particles renumbered) and body
    (0-based). A field of one value everywhere (the plastic strain of a
    body that never yielded) has no peak to locate: its value, and None
    for where."""
    peaks = {}
    for field in fields:
        best, least = None, np.inf
        if "conn" in snap and len(snap["conn"]):
            values = snap[field]
            k = int(np.argmax(values))
            least = min(least, float(np.min(values)))
            where = snap["x"][snap["conn"][k]].mean(axis=0)
            best = (float(values[k]), where, "element", k, int(snap["id"][k]), int(snap["body"][k]))
        if "particles" in snap:
            part = snap["particles"]
            values = part[field]
            if len(values):
                k = int(np.argmax(values))
                least = min(least, float(np.min(values)))
                if best is None or values[k] > best[0]:
                    best = (float(values[k]), part["x"][k], "particle", k, int(part["id"][k]),
                            int(part["body"][k]))
        if best is not None:
            value, where, kind, index, ident, body = best
            peaks[field] = {"value": value, "r_mm": float(where[0] * 1e3), "z_mm": float(where[1] * 1e3),
                            "in": kind, "index": index, "id": ident, "body": body}
            if value == least:
                peaks[field].update({key: None for key in ("r_mm", "z_mm", "in", "index", "id", "body")})
    return peaks


def _locate(points, x, conn):
    """Index of the triangle (of conn over nodes x) containing each point, -1
    if none (barycentric test, vectorised over points x triangles)."""
    a, b, c = x[conn[:, 0]], x[conn[:, 1]], x[conn[:, 2]]
    v0, v1 = b - a, c - a
    det = v0[:, 0] * v1[:, 1] - v0[:, 1] * v1[:, 0]
    d = points[:, None, :] - a[None, :, :]
    l1 = (d[..., 0] * v1[None, :, 1] - d[..., 1] * v1[None, :, 0]) / det
    l2 = (v0[None, :, 0] * d[..., 1] - v0[None, :, 1] * d[..., 0]) / det
    tol = 1e-12
    inside = (l1 >= -tol) & (l2 >= -tol) & (l1 + l2 <= 1.0 + tol)
    found = inside.any(axis=1)
    return np.where(found, inside.argmax(axis=1), -1)


def initial_face(snap, body_indices):
    """Lowest initial point of the bodies: element nodes, or particle centres
    less their initial radius [m]."""
    z = []
    for ib in body_indices:
        if "conn" in snap:
            conn, _ = _body_elements(snap, ib)
            if len(conn):
                z.append(snap["x0"][np.unique(conn), 1].min())
        if "particles" in snap:
            part = snap["particles"]
            keep = part["body"] == ib
            if keep.any():
                z.append((part["x0"][keep, 1] - part["radius0"][keep]).min())
    return min(z)


def stress_profile(snap, body_index, probe_radius, z_face, n_samples=801):
    """Axial stress sigma_zz [Pa] of the elements of a body along the line
    r = probe_radius of the initial configuration, against the initial
    distance from the impact face z_face [m]. Material coordinates are the
    ones in which the bar wave travels at c0."""
    conn, keep = _body_elements(snap, body_index)
    x0 = snap["x0"]
    nodes = np.unique(conn)
    z = np.linspace(x0[nodes, 1].min(), x0[nodes, 1].max(), n_samples)
    pts = np.column_stack([np.full_like(z, probe_radius), z])
    idx = _locate(pts, x0, conn)
    ok = idx >= 0
    return z[ok] - z_face, snap["stress"][keep][idx[ok], 1]


def particle_stress_profile(part, body_index, probe_radius, z_face):
    """Axial stress [Pa] of the particle column whose initial radius is
    nearest probe_radius, against the initial distance from z_face [m]."""
    keep = part["body"] == body_index
    x0, szz = part["x0"][keep], part["stress"][keep, 1]
    r_col = x0[np.argmin(np.abs(x0[:, 0] - probe_radius)), 0]
    col = np.isclose(x0[:, 0], r_col, rtol=1e-9, atol=0.0)
    order = np.argsort(x0[col, 1])
    return x0[col, 1][order] - z_face, szz[col][order]


def bar_profile(snap, body_indices, probe_radius):
    """Axial stress along r = probe_radius over the given bodies (elements
    sampled on the line, particles by their nearest column), sorted by the
    initial distance from the common impact face."""
    z_face = initial_face(snap, body_indices)
    dists, stresses = [], []
    for ib in body_indices:
        if "conn" in snap and (snap["body"] == ib).any():
            d, s = stress_profile(snap, ib, probe_radius, z_face)
            dists.append(d)
            stresses.append(s)
        if "particles" in snap and (snap["particles"]["body"] == ib).any():
            d, s = particle_stress_profile(snap["particles"], ib, probe_radius, z_face)
            dists.append(d)
            stresses.append(s)
    dist, szz = np.concatenate(dists), np.concatenate(stresses)
    order = np.argsort(dist, kind="stable")
    return dist[order], szz[order]


def bar_wave(snap, body_indices, probe_radius, plateau_from, plateau_to, interface=None):
    """Mean compressive stress of the plateau window [GPa] and wave front
    [mm]: the farthest initial distance from the face where the compressive
    stress still reaches half the plateau (linear interpolation). With an
    interface distance [m] (coupled bar), also the jump of the mean stress
    across it: means over 3 mm on either side, relative to the plateau
    (None while the plateau carries no compression)."""
    dist, szz = bar_profile(snap, body_indices, probe_radius)
    comp = -szz
    window = (dist >= plateau_from) & (dist <= plateau_to)
    plateau = comp[window].mean()
    above = np.nonzero(comp >= 0.5 * plateau)[0]
    k = above.max()
    front = dist[k]
    if k + 1 < len(dist):
        c0, c1 = comp[k], comp[k + 1]
        front = dist[k] + (c0 - 0.5 * plateau) / (c0 - c1) * (dist[k + 1] - dist[k])
    out = {"plateau_GPa": plateau / 1e9, "front_mm": front * 1e3,
           "probe_radius_mm": probe_radius * 1e3,
           "plateau_window_mm": [plateau_from * 1e3, plateau_to * 1e3]}
    if interface is not None:
        span = 3.0e-3
        below = comp[(dist >= interface - span) & (dist < interface)].mean()
        beyond = comp[(dist >= interface) & (dist <= interface + span)].mean()
        out["interface_mm"] = interface * 1e3
        # none before the wave has arrived (a running summary at t = 0)
        out["interface_jump"] = float(abs(beyond - below) / plateau) if plateau > 0.0 else None
    return out


def joined_bodies(deck, ib):
    """Body ib with every body joined to it (one continuum), sorted."""
    names = [b["name"] for b in deck["body"]]
    joined = {ib}
    changed = True
    while changed:
        changed = False
        for j, b in enumerate(deck["body"]):
            if b["joined_to"] is None:
                continue
            partner = names.index(b["joined_to"])
            if (j in joined) != (partner in joined):
                joined |= {j, partner}
                changed = True
    return sorted(joined)


def _merge_bodies(snap, bodies):
    """A view of the snapshot where the given bodies carry the index of the
    first (metrics of a continuum made of several bodies)."""
    out = dict(snap)
    if "conn" in snap:
        out["body"] = np.where(np.isin(snap["body"], bodies), bodies[0], snap["body"])
    if "particles" in snap:
        part = dict(snap["particles"])
        part["body"] = np.where(np.isin(part["body"], bodies), bodies[0], part["body"])
        out["particles"] = part
    return out


def _body_points(snap, body_index):
    """Positions, initial positions, velocities and masses (nodes, then
    particles) and particle radii (0 for nodes) of one body."""
    xs, x0s, vs, ms, rs = [], [], [], [], []
    if "conn" in snap:
        nodes = np.unique(snap["conn"][snap["body"] == body_index])
        xs.append(snap["x"][nodes]); x0s.append(snap["x0"][nodes])
        vs.append(snap["velocity"][nodes]); ms.append(snap["node_mass"][nodes])
        rs.append(np.zeros(len(nodes)))
    if "particles" in snap:
        part = snap["particles"]
        keep = part["body"] == body_index
        xs.append(part["x"][keep]); x0s.append(part["x0"][keep])
        vs.append(part["velocity"][keep]); ms.append(part["mass"][keep])
        rs.append(part["radius"][keep])
    if not xs:
        return EMPTY, EMPTY, EMPTY, np.zeros(0), np.zeros(0)
    return (np.vstack(xs), np.vstack(x0s), np.vstack(vs), np.concatenate(ms),
            np.concatenate(rs))


def perforation(snap, projectile, target, direction=-1.0):
    """Projectile against a target (body indices): the projectile's
    mass-weighted axial velocity velocity_z [m/s]; its residual velocity,
    the component of that velocity along the striking direction (direction:
    -1 towards -z, +1 towards +z), which is 0 for a projectile that has
    stopped or rebounds (rebounded: the component is negative; its speed is
    then |velocity_z|), once it has left the target or at the time of the
    snapshot; penetration depth of
    its lowest point below the target's initial top face [mm], whether it
    has left the target (`exited`: the rear of the projectile proper, its
    last attached point along the striking direction, has passed the
    target's initial far face; target material carried ahead of it, spall
    and debris, and fragments of it left behind do not hold it in),
    and the hole diameter [mm]: twice the smallest radius of target
    material (nodes, particles less their radius) within the plate's
    initial thickness."""
    xp, _, vp, mp, rp = _body_points(snap, projectile)
    xt, xt0, _, _, rt = _body_points(snap, target)
    velocity = float((mp * vp[:, 1]).sum() / mp.sum())
    top0, bottom0 = xt0[:, 1].max(), xt0[:, 1].min()
    tip = (xp[:, 1] - rp).min()
    in_plate = (xt[:, 1] <= top0) & (xt[:, 1] >= bottom0)
    hole = 2.0 * max((xt[in_plate, 0] - rt[in_plate]).min(initial=np.inf), 0.0)
    # axial momentum of every body: all nodes and particles, and the nodes
    # erosion removed
    total = snap.get("eroded_momentum_z", 0.0)
    if "conn" in snap:
        total += snap["node_mass"] @ snap["velocity"][:, 1]
    if "particles" in snap:
        total += snap["particles"]["mass"] @ snap["particles"]["velocity"][:, 1]
    along = direction * velocity
    return {"velocity_z_m_s": velocity, "residual_velocity_m_s": max(along, 0.0),
            "rebounded": bool(along < 0.0),
            "momentum_z_N_s": float(total),
            "contact_overlap_max_mm": float(snap.get("contact_penetration", 0.0) * 1e3),
            "contact_overlap_relative_max": float(snap.get("contact_penetration_relative", 0.0)),
            "penetration_mm": float((top0 - tip) * 1e3),
            "exited": _exited(snap, projectile, direction, top0, bottom0),
            "hole_diameter_mm": float(hole * 1e3) if np.isfinite(hole) else None,
            "time_us": float(snap["time"] * 1e6)}


def _exited(snap, projectile, direction, top0, bottom0):
    """Whether the projectile proper (_body_proper: its fragments left
    out) lies wholly beyond the target's initial faces top0 and bottom0
    [m] along the striking direction (-1: towards -z)."""
    _, _, nodes, keep_n, xp, rad, _, keep_p = _body_proper(snap, projectile)
    # a particle reaches back by its radius
    z = np.concatenate([nodes[keep_n, 1], xp[keep_p, 1] - direction * rad[keep_p]])
    if not len(z):
        return False
    return bool(z.max() < bottom0 if direction < 0.0 else z.min() > top0)


def _projectile_and_target(deck):
    met = deck["metrics"]
    names = [b["name"] for b in deck["body"]]
    ib = names.index(met["body"]) if met["body"] else 0
    it = names.index(met["target"]) if met["target"] else (1 if ib == 0 else 0)
    # striking direction: the sign of the projectile's initial velocity
    # (-z when it starts at rest)
    return ib, it, (1.0 if deck["body"][ib]["velocity_z"] > 0.0 else -1.0)


#: Part of a perforation run, at its end, over which the projectile's
#: velocity must have settled [-], and by how much at most, as a fraction of
#: the striking speed [-].
SETTLING_WINDOW = 0.2
SETTLING_TOLERANCE = 0.01


def perforation_settling(time_us, velocity_z, window=SETTLING_WINDOW,
                         tolerance=SETTLING_TOLERANCE):
    """Whether a perforation run's residual velocity is final: the change
    of the projectile's axial velocity [m/s] over the last `window` of the
    run (from the snapshot series), and settled = that change is at most
    `tolerance` times the striking speed. A rod still decelerating in the
    target at the end time is not settled, and its residual velocity is
    not the one an experiment would measure: a longer end time settles it.
    None where the series has fewer than two snapshots."""
    t = np.asarray(time_us, dtype=float)
    v = np.asarray(velocity_z, dtype=float)
    if len(t) < 2:
        return {"velocity_change_end_m_s": None, "settled": None}
    start = t[-1] - window * (t[-1] - t[0])
    change = float(v[-1] - v[np.searchsorted(t, start)])
    return {"velocity_change_end_m_s": change,
            "settled": bool(abs(change) <= tolerance * abs(v[0]))}


def snapshot_series(snap, deck):
    """Per-snapshot record of the case metric that has a history
    (perforation: velocity, penetration, hole; debris: fronts, hole,
    ejecta, intersection, masses and momenta), or None."""
    kind = deck["metrics"]["kind"]
    if kind not in ("perforation", "debris") or len(deck["body"]) < 2:
        return None
    if kind == "debris":
        from . import debris
        return debris.debris(snap, debris.DebrisCase.from_deck(deck))
    return perforation(snap, *_projectile_and_target(deck))


def series_units(deck):
    """Units of the per-snapshot record's keys, for the kinds whose history
    fsph.h5 keeps under /metrics/<kind> (debris), or None."""
    if deck["metrics"]["kind"] != "debris":
        return None
    from . import debris
    return debris.UNITS


def case_metrics(snap, deck, series_record=None):
    """Metrics named by the deck's &metrics kind ({} for 'none'). A
    perforation or debris case starts from series_record, the snapshot's
    own record of snapshot_series where the caller holds it (the same
    numbers, not computed twice)."""
    met = deck["metrics"]
    names = [b["name"] for b in deck["body"]]
    ib = names.index(met["body"]) if met["body"] else 0
    joined = joined_bodies(deck, ib)
    if met["kind"] == "taylor":
        return {"taylor": taylor(_merge_bodies(snap, joined), deck["body"][ib], joined[0],
                                 met["w_height"])}
    if met["kind"] == "perforation":
        return {"perforation": dict(series_record) if series_record is not None
                else perforation(snap, *_projectile_and_target(deck))}
    if met["kind"] == "debris":
        from . import debris
        case = debris.DebrisCase.from_deck(deck)
        record = dict(series_record) if series_record is not None else debris.debris(snap, case)
        record.update({"flyer": case.flyer_name, "flyer_material": case.flyer_material,
                       "target": case.target_name, "target_material": case.target_material,
                       "materials": [m["name"] for m in deck["material"]],
                       "front_fraction": case.front_fraction,
                       "intact_fraction": case.intact_fraction,
                       "flight_direction": case.direction,
                       "plate_front_face_z_mm": case.frame(
                           debris.body_points(snap, case.target)).z_face * 1e3})
        return {"debris": record}
    if met["kind"] == "bar_wave":
        return {"bar_wave": bar_wave(snap, joined, met["probe_radius"], met["plateau_from"],
                                     met["plateau_to"], met["interface"])}
    return {}


#: Metrics that measure what a reference measured only once the run's own
#: flag says so: (group, key) -> (flag of the group, why not without it).
#: A projectile still in the target has a velocity, not a residual one.
MEASURED_ONLY_WHEN = {
    ("perforation", "residual_velocity_m_s"): ("exited", "the projectile has not left the target"),
}


def compare(metrics, reference):
    """Relative errors [%] of each metric that has a reference value. A
    metric the run did not measure (None: the group it measures is empty,
    e.g. no copper touching the aluminium for the intersection radius; or
    its flag in MEASURED_ONLY_WHEN is not set, with the reason as
    not_measured_because) is kept with computed and error_percent None, so
    that the printed summary, `fsph report` (outside any bar) and the
    pictures show the reference and that it was not met."""
    out = {}
    for group, values in metrics.items():
        ref = reference.get(group, {})
        for key, val in values.items():
            if key not in ref:
                continue
            flag, why = MEASURED_ONLY_WHEN.get((group, key), (None, None))
            if flag is not None and not values.get(flag):
                val = None              # what the run has is not what was measured
            else:
                why = None
            if isinstance(val, float):
                entry = {"computed": val, "reference": ref[key],
                         "error_percent": 100.0 * (val - ref[key]) / ref[key]}
            elif val is None:
                entry = {"computed": None, "reference": ref[key], "error_percent": None}
                if why:
                    entry["not_measured_because"] = why
            else:
                continue
            out.setdefault(group, {})[key] = entry
    return out
