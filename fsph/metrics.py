"""Case metrics from a snapshot: Taylor L/D/W, elastic-bar stress plateau
and wave front. Vectorised numpy over arrays; no loops over elements."""

import numpy as np

from .mesh import boundary_edges


def _body_elements(snap, body_index):
    keep = snap["body"] == body_index
    conn = snap["conn"][keep]
    return conn, keep


def taylor_particles(part, body, body_index, w_height=None):
    """Taylor L, D, W [mm] of a particle body, each particle counted as a
    square of half-side its radius: L spans the lowest and highest particle
    edges, D is twice the largest r + radius, W twice the largest r + radius
    among particles whose axial extent covers the level w_height above the
    impact face."""
    keep = part["body"] == body_index
    x, rad = part["x"][keep], part["radius"][keep]
    z_face = (x[:, 1] - rad).min()
    length = (x[:, 1] + rad).max() - z_face
    diameter = 2.0 * (x[:, 0] + rad).max()
    if w_height is None:
        w_height = 0.2 * body["length"]
    level = z_face + w_height
    at_level = (x[:, 1] - rad <= level) & (x[:, 1] + rad >= level)
    width = 2.0 * (x[at_level, 0] + rad[at_level]).max() if at_level.any() else float("nan")
    return {"L_mm": length * 1e3, "D_mm": diameter * 1e3, "W_mm": width * 1e3,
            "w_height_mm": w_height * 1e3}


def taylor(snap, body, body_index, w_height=None):
    """Final length L, maximum diameter D and width W at w_height (default
    0.2 L0) above the impact face, in mm. The impact face is the lowest
    point of the body; W is twice the largest radius at which the deformed
    outer boundary crosses the level z_face + w_height."""
    conn, _ = _body_elements(snap, body_index)
    nodes = np.unique(conn)
    x = snap["x"]
    z_face = x[nodes, 1].min()
    length = x[nodes, 1].max() - z_face
    diameter = 2.0 * x[nodes, 0].max()
    if w_height is None:
        w_height = 0.2 * body["length"]
    level = z_face + w_height
    edges = boundary_edges(conn)
    a, b = x[edges[:, 0]], x[edges[:, 1]]
    off_axis = (a[:, 0] > 0.0) | (b[:, 0] > 0.0)
    crosses = off_axis & ((a[:, 1] - level) * (b[:, 1] - level) <= 0.0) & (a[:, 1] != b[:, 1])
    t = (level - a[crosses, 1]) / (b[crosses, 1] - a[crosses, 1])
    r_cross = a[crosses, 0] + t * (b[crosses, 0] - a[crosses, 0])
    width = 2.0 * r_cross.max() if r_cross.size else float("nan")
    return {"L_mm": length * 1e3, "D_mm": diameter * 1e3, "W_mm": width * 1e3,
            "w_height_mm": w_height * 1e3}


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


def stress_profile(snap, body_index, probe_radius, n_samples=801):
    """Axial stress sigma_zz [Pa] along the line r = probe_radius of the
    initial configuration, against the initial distance from the impact
    face (the lowest initial z of the body) [m]. Material coordinates are
    the ones in which the bar wave travels at c0."""
    conn, keep = _body_elements(snap, body_index)
    x0 = snap["x0"]
    nodes = np.unique(conn)
    z_lo, z_hi = x0[nodes, 1].min(), x0[nodes, 1].max()
    z = np.linspace(z_lo, z_hi, n_samples)
    pts = np.column_stack([np.full_like(z, probe_radius), z])
    idx = _locate(pts, x0, conn)
    ok = idx >= 0
    szz = snap["stress"][keep][idx[ok], 1]
    return z[ok] - z_lo, szz


def particle_stress_profile(part, body_index, probe_radius):
    """Axial stress [Pa] of the particle column whose initial radius is
    nearest probe_radius, against the initial distance from the impact face
    (lowest initial particle edge) [m]."""
    keep = part["body"] == body_index
    x0, rad0, szz = part["x0"][keep], part["radius0"][keep], part["stress"][keep, 1]
    r_col = x0[np.argmin(np.abs(x0[:, 0] - probe_radius)), 0]
    col = np.isclose(x0[:, 0], r_col, rtol=1e-9, atol=0.0)
    order = np.argsort(x0[col, 1])
    face = (x0[:, 1] - rad0).min()
    return x0[col, 1][order] - face, szz[col][order]


def bar_wave(snap, body_index, probe_radius, plateau_from, plateau_to):
    """Mean compressive stress of the plateau window [GPa] and wave front
    [mm]: the farthest initial distance from the face where the compressive
    stress still reaches half the plateau (linear interpolation)."""
    if "particles" in snap and "conn" not in snap:
        dist, szz = particle_stress_profile(snap["particles"], body_index, probe_radius)
    else:
        dist, szz = stress_profile(snap, body_index, probe_radius)
    comp = -szz
    window = (dist >= plateau_from) & (dist <= plateau_to)
    plateau = comp[window].mean()
    above = np.nonzero(comp >= 0.5 * plateau)[0]
    k = above.max()
    front = dist[k]
    if k + 1 < len(dist):
        c0, c1 = comp[k], comp[k + 1]
        front = dist[k] + (c0 - 0.5 * plateau) / (c0 - c1) * (dist[k + 1] - dist[k])
    return {"plateau_GPa": plateau / 1e9, "front_mm": front * 1e3,
            "probe_radius_mm": probe_radius * 1e3,
            "plateau_window_mm": [plateau_from * 1e3, plateau_to * 1e3]}


def case_metrics(snap, deck):
    """Metrics named by the deck's &metrics kind ({} for 'none')."""
    met = deck["metrics"]
    names = [b["name"] for b in deck["body"]]
    ib = names.index(met["body"]) if met["body"] else 0
    if met["kind"] == "taylor":
        if deck["body"][ib]["discretisation"] == "particles":
            return {"taylor": taylor_particles(snap["particles"], deck["body"][ib], ib,
                                               met["w_height"])}
        return {"taylor": taylor(snap, deck["body"][ib], ib, met["w_height"])}
    if met["kind"] == "bar_wave":
        return {"bar_wave": bar_wave(snap, ib, met["probe_radius"], met["plateau_from"],
                                     met["plateau_to"])}
    return {}


def compare(metrics, reference):
    """Relative errors [%] of each metric that has a reference value."""
    out = {}
    for group, values in metrics.items():
        ref = reference.get(group, {})
        for key, val in values.items():
            if key in ref and isinstance(val, float):
                out.setdefault(group, {})[key] = {
                    "computed": val, "reference": ref[key],
                    "error_percent": 100.0 * (val - ref[key]) / ref[key]}
    return out
