"""Mesh generators: bodies as crossed-triangle T3 meshes (arrays only).

Each quadrilateral is split into four triangles through a centre node: the
pattern that keeps constant-strain triangles from locking in nearly
incompressible plastic flow (after EPIC, Johnson et al. 1997).

Generators (each with a particle twin returning a ParticleLattice for
pure-SPH bodies): crossed_quads / lattice (tensor grids), crossed_mapped /
mapped_lattice (structured curvilinear grids), rod, ogive_projectile
(tangent-ogive nose, OgiveProfile for its exact outline; by default a
three-block nose whose cells stay near the shank's size, or the older
single-grid "fan"), plate (graded disc), sphere (a four-block
butterfly). read_gmsh imports triangles drawn in gmsh; triangle_areas,
ring_volume and mesh_quality measure a mesh.
"""

import math
from dataclasses import dataclass

import numpy as np


@dataclass
class Mesh:
    """Nodes x (n, 2) as (r, z) [m]; triangles conn (m, 3), 0-based,
    counter-clockwise in the (r, z) plane."""

    x: np.ndarray
    conn: np.ndarray

    @property
    def n_nodes(self):
        return len(self.x)

    @property
    def n_elements(self):
        return len(self.conn)


def crossed_quads(r_edges, z_edges):
    """Crossed-triangle mesh of the tensor grid r_edges x z_edges."""
    r_edges = np.asarray(r_edges, dtype=float)
    z_edges = np.asarray(z_edges, dtype=float)
    nr, nz = len(r_edges) - 1, len(z_edges) - 1
    rr, zz = np.meshgrid(r_edges, z_edges)                   # (nz+1, nr+1)
    corners = np.column_stack([rr.ravel(), zz.ravel()])
    rc = 0.5 * (r_edges[:-1] + r_edges[1:])
    zc = 0.5 * (z_edges[:-1] + z_edges[1:])
    rcc, zcc = np.meshgrid(rc, zc)                            # (nz, nr)
    centres = np.column_stack([rcc.ravel(), zcc.ravel()])
    return _crossed(corners, centres, nr, nz)


def _crossed(corners, centres, nr, nz):
    """Crossed triangles of a structured grid: corners ((nz+1)(nr+1), 2)
    row by row (index j*(nr+1) + i), then one centre per cell (nz*nr, 2)
    (index j*nr + i); the four triangles of a cell are stored together
    (bottom, right, top, left)."""
    x = np.vstack([corners, centres])
    j, i = np.meshgrid(np.arange(nz), np.arange(nr), indexing="ij")
    i, j = i.ravel(), j.ravel()
    c00 = j * (nr + 1) + i
    c10 = c00 + 1
    c01 = c00 + (nr + 1)
    c11 = c01 + 1
    m = len(corners) + j * nr + i
    conn = np.concatenate([
        np.column_stack([c00, c10, m]),   # bottom
        np.column_stack([c10, c11, m]),   # right
        np.column_stack([c11, c01, m]),   # top
        np.column_stack([c01, c00, m]),   # left
    ])
    # order elements quad by quad (the four triangles of a quad together)
    order = np.arange(len(conn)).reshape(4, -1).T.ravel()
    return Mesh(x=x, conn=conn[order].astype(np.int64))


def _grid(X, Z):
    """Validated float copies of the corner arrays of a structured grid."""
    X = np.array(X, dtype=float)
    Z = np.array(Z, dtype=float)
    if X.ndim != 2 or X.shape != Z.shape or min(X.shape) < 2:
        raise ValueError("X and Z must be arrays of the same shape (nz+1, nr+1) with "
                         f"nz, nr >= 1; got shapes {X.shape} and {Z.shape}")
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(Z))):
        raise ValueError("X and Z must be finite")
    return X, Z


def _cell_geometry(X, Z):
    """Signed areas (nz, nr) and area centroids (r, z) of the quadrilateral
    cells (corners 00, 10, 11, 01 in that order) of a structured grid."""
    px = [X[:-1, :-1], X[:-1, 1:], X[1:, 1:], X[1:, :-1]]
    pz = [Z[:-1, :-1], Z[:-1, 1:], Z[1:, 1:], Z[1:, :-1]]
    area = np.zeros_like(px[0])
    cr = np.zeros_like(px[0])
    cz = np.zeros_like(px[0])
    for k in range(4):
        x0, z0, x1, z1 = px[k], pz[k], px[(k + 1) % 4], pz[(k + 1) % 4]
        cross = x0 * z1 - x1 * z0
        area += cross
        cr += (x0 + x1) * cross
        cz += (z0 + z1) * cross
    area *= 0.5
    with np.errstate(divide="ignore", invalid="ignore"):
        cr /= 6.0 * area
        cz /= 6.0 * area
    return area, cr, cz


def crossed_mapped(X, Z):
    """Crossed-triangle mesh of a structured curvilinear grid.

    X, Z: (nz+1, nr+1) arrays of corner positions r and z [m]; index i
    (second axis) runs across the body (normally outwards in r) and index j
    (first axis) along it (normally upwards in z), so cell (j, i) has the
    corners (j, i), (j, i+1), (j+1, i+1), (j+1, i). Each cell is split into
    four triangles through a centre node at the mean of its four corners.

    Node order: the corners row by row (node j*(nr+1) + i), then the cell
    centres (node (nz+1)(nr+1) + j*nr + i); elements: the four triangles of
    cell j*nr + i at 4*(j*nr + i) ... +3 (bottom, right, top, left), the same
    layout as crossed_quads (which is the tensor-grid special case, its
    centres computed as edge midpoints).

    The triangles are counter-clockwise when the grid is right-handed (i
    towards +r, j towards +z); a left-handed grid (every triangle clockwise)
    is accepted and its triangles reversed. A folded grid (triangles of
    both signs, or of zero area) raises ValueError.
    """
    X, Z = _grid(X, Z)
    nz, nr = X.shape[0] - 1, X.shape[1] - 1
    corners = np.column_stack([X.ravel(), Z.ravel()])
    cx = 0.25 * (X[:-1, :-1] + X[:-1, 1:] + X[1:, 1:] + X[1:, :-1])
    cz = 0.25 * (Z[:-1, :-1] + Z[:-1, 1:] + Z[1:, 1:] + Z[1:, :-1])
    mesh = _crossed(corners, np.column_stack([cx.ravel(), cz.ravel()]), nr, nz)
    area = triangle_areas(mesh)
    scale = max(np.ptp(X), np.ptp(Z))
    tol = 1e-14 * scale * scale
    if np.all(area < -tol):
        mesh.conn = mesh.conn[:, [0, 2, 1]]
    elif not np.all(area > tol):
        majority = 1.0 if np.sum(area > 0) >= np.sum(area < 0) else -1.0
        bad = int(np.flatnonzero(majority * area <= tol)[0])
        raise ValueError(f"folded or degenerate grid: triangle {bad} (cell {bad // 4}) has "
                         f"signed area {area[bad]:.3e} m^2, against the majority sign")
    return mesh


def triangle_areas(mesh):
    """Signed planar areas (m,) [m^2] of the triangles (> 0 counter-clockwise)."""
    p = mesh.x[mesh.conn]
    d1 = p[:, 1] - p[:, 0]
    d2 = p[:, 2] - p[:, 0]
    return 0.5 * (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])


def ring_volume(mesh):
    """Volume [m^3] of the body of revolution: 2 pi sum(r_centroid * area),
    exact for triangles with straight sides (Pappus)."""
    rbar = mesh.x[mesh.conn, 0].mean(axis=1)
    return float(2.0 * np.pi * np.sum(rbar * triangle_areas(mesh)))


def mesh_quality(mesh):
    """Summary of a triangle mesh: counts, smallest edge [m], smallest
    altitude [m] (the length that sets the explicit time step), largest
    aspect ratio, smallest area [m^2] and ring volume [m^3].

    The aspect ratio of a triangle is its longest edge over its smallest
    altitude, L_max^2 / (2 A): 2/sqrt(3) ~ 1.15 for an equilateral
    triangle, 2 for the crossed triangles of a square cell, and about
    2 max(a/b, b/a) for those of an a x b rectangle."""
    p = mesh.x[mesh.conn]
    edges = np.linalg.norm(p[:, [1, 2, 0]] - p, axis=2)        # (m, 3)
    area = triangle_areas(mesh)
    lmax = edges.max(axis=1)
    return {
        "n_nodes": mesh.n_nodes,
        "n_elements": mesh.n_elements,
        "min_edge": float(edges.min()),
        "min_altitude": float(np.min(2.0 * area / lmax)),
        "max_aspect": float(np.max(lmax * lmax / (2.0 * area))),
        "min_area": float(area.min()),
        "volume": ring_volume(mesh),
    }


def rod(radius, length, n_radial, n_axial, z_base=0.0, inner_radius=0.0):
    """Rod inner_radius <= r <= radius, z_base <= z <= z_base + length
    (solid for inner_radius = 0, a tube otherwise)."""
    return crossed_quads(np.linspace(inner_radius, radius, n_radial + 1),
                         np.linspace(z_base, z_base + length, n_axial + 1))


@dataclass
class ParticleLattice:
    """Particles at the centres of lattice cells: positions x (n, 2) (r, z)
    [m], planar cell areas (n,) [m^2] and spacings (n,) sqrt(area) [m]. The
    ring volume a particle stands for is 2 pi r area (exact for a
    rectangular cell centred at r)."""

    x: np.ndarray
    area: np.ndarray

    @property
    def spacing(self):
        return np.sqrt(self.area)

    @property
    def ring_volume(self):
        return 2.0 * np.pi * self.x[:, 0] * self.area

    @property
    def n_particles(self):
        return len(self.x)


def lattice(r_edges, z_edges):
    """Particles at the centres of the tensor-grid cells r_edges x z_edges."""
    r_edges = np.asarray(r_edges, dtype=float)
    z_edges = np.asarray(z_edges, dtype=float)
    rc = 0.5 * (r_edges[:-1] + r_edges[1:])
    zc = 0.5 * (z_edges[:-1] + z_edges[1:])
    rr, zz = np.meshgrid(rc, zc)
    dr, dz = np.meshgrid(np.diff(r_edges), np.diff(z_edges))
    return ParticleLattice(x=np.column_stack([rr.ravel(), zz.ravel()]),
                           area=(dr * dz).ravel())


def rod_particles(radius, length, n_radial, n_axial, z_base=0.0, inner_radius=0.0):
    """Rod (or tube) as an n_radial x n_axial particle lattice."""
    return lattice(np.linspace(inner_radius, radius, n_radial + 1),
                   np.linspace(z_base, z_base + length, n_axial + 1))


def mapped_lattice(X, Z):
    """Particles at the area centroids of the cells of a structured
    curvilinear grid (X, Z as for crossed_mapped), each with its planar cell
    area, ordered cell by cell (j*nr + i). By Pappus' theorem 2 pi r area is
    then exactly the ring volume of the cell. Raises ValueError for a cell
    of zero area or for cells of both orientations."""
    X, Z = _grid(X, Z)
    area, cr, cz = _cell_geometry(X, Z)
    scale = max(np.ptp(X), np.ptp(Z))
    tol = 1e-14 * scale * scale
    if not (np.all(area > tol) or np.all(area < -tol)):
        raise ValueError("folded or degenerate grid: cells of zero area or of both orientations")
    return ParticleLattice(x=np.column_stack([cr.ravel(), cz.ravel()]),
                           area=np.abs(area).ravel())


def _blocks_to_quads(blocks):
    """Merge structured blocks (each an (nz+1, nr+1, 2) array of corner
    positions) into one quadrilateral mesh: nodes (n, 2) in order of first
    appearance (block by block, row by row) and quads (q, 4) (corners 00,
    10, 11, 01 of each cell, block by block, row by row). Nodes shared by
    blocks must be given bitwise equal."""
    pts, quads, offset = [], [], 0
    for P in blocks:
        nz, nr = P.shape[0] - 1, P.shape[1] - 1
        idx = offset + np.arange((nz + 1) * (nr + 1)).reshape(nz + 1, nr + 1)
        quads.append(np.stack([idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]],
                              axis=-1).reshape(-1, 4))
        pts.append(P.reshape(-1, 2))
        offset += len(pts[-1])
    pts, quads = np.vstack(pts), np.vstack(quads)
    _, first, inverse = np.unique(pts, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)                      # keep the order of first appearance
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return pts[first[order]], rank[inverse.ravel()][quads]


def _quad_geometry(x, quads):
    """Signed areas (q,) and area centroids (q, 2) of quadrilaterals."""
    p = x[quads]
    area = np.zeros(len(quads))
    cen = np.zeros((len(quads), 2))
    for k in range(4):
        a, b = p[:, k], p[:, (k + 1) % 4]
        cross = a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1]
        area += cross
        cen += (a + b) * cross[:, None]
    area *= 0.5
    return area, cen / (6.0 * area[:, None])


def _crossed_quads_of(x, quads):
    """Crossed-triangle mesh of a quadrilateral mesh (quads counter-
    clockwise): the corners, then one centre per quad at the mean of its
    corners; the four triangles of a quad together (bottom, right, top,
    left as in crossed_mapped). Raises ValueError for a folded mesh."""
    centres = x[quads].mean(axis=1)
    m = len(x) + np.arange(len(quads))
    conn = np.stack([np.column_stack([quads[:, k], quads[:, (k + 1) % 4], m])
                     for k in range(4)], axis=1).reshape(-1, 3)
    mesh = Mesh(x=np.vstack([x, centres]), conn=conn.astype(np.int64))
    area = triangle_areas(mesh)
    scale = np.ptp(x, axis=0).max()
    if not np.all(area > 1e-14 * scale * scale):
        bad = int(np.argmin(area))
        raise ValueError(f"folded or degenerate quadrilateral mesh: triangle {bad} "
                         f"(cell {bad // 4}) has signed area {area[bad]:.3e} m^2")
    return mesh


def _laplace_smooth(x, quads, free, sweeps):
    """Jacobi Laplacian smoothing of the free nodes of a quad mesh: each
    moves to the mean of its edge neighbours, `sweeps` times."""
    x = x.copy()
    n = len(x)
    count = np.zeros(n)
    for k in range(4):
        np.add.at(count, quads[:, k], 2.0)
    for _ in range(sweeps):
        p = x[quads]
        total = np.zeros_like(x)
        for k in range(4):
            np.add.at(total, quads[:, k], p[:, (k + 1) % 4] + p[:, (k + 3) % 4])
        x[free] = total[free] / count[free, None]
    return x


def _graded_unit(n, ratio):
    """n + 1 points from 0 to 1 whose cell widths grow geometrically so the
    last cell is `ratio` times the first (uniform for ratio = 1)."""
    if ratio <= 0.0:
        raise ValueError(f"grading ratio must be positive, got {ratio}")
    if n == 1 or ratio == 1.0:
        return np.linspace(0.0, 1.0, n + 1)
    w = ratio ** (np.arange(n) / (n - 1))
    s = np.concatenate([[0.0], np.cumsum(w)])
    s /= s[-1]
    s[-1] = 1.0
    return s


@dataclass
class OgiveProfile:
    """Outline of a tangent-ogive-nose rod, truncated at a flat tip (meplat).

    Derivation. The nose of caliber-radius-head crh = psi is an arc of a
    circle of radius S = psi D (the ogive radius) whose centre lies in the
    plane of the nose/shank junction at r = R0 - S (R0 = D/2; the centre is
    on the far side of the axis for psi > 1/2), so the arc meets the shank
    with a common tangent. With x the axial distance from the junction
    towards the tip, the outer radius is

        R(x) = R0 - S + sqrt(S^2 - x^2),

    and the ideal (sharp) tip, R = 0, is at x = l_n with
    S^2 - l_n^2 = (S - R0)^2, i.e. the nose length

        l_n = sqrt(S^2 - (S - R0)^2) = sqrt(2 S R0 - R0^2) = R0 sqrt(4 psi - 1).

    (psi = 1/2 is the hemispherical nose, l_n = R0.) The tip is cut by a
    flat of radius r_m (meplat_radius), at x_m = sqrt(S^2 - (r_m + S - R0)^2);
    the length cut off is meplat_height = l_n - x_m.

    With a = R0 - S, the volume of the nose from the junction to x is
    pi F(x), F(x) = (S^2 + a^2) x - x^3/3 + a (x sqrt(S^2 - x^2) + S^2 asin(x/S)),
    so the ideal nose holds pi (S^2 l_n - l_n^3/3 + a S^2 asin(l_n/S)) (using
    sqrt(S^2 - l_n^2) = -a) and the meplat removes pi (F(l_n) - F(x_m)).

    Attributes are in metres: radius R0, ogive_radius S, nose_length l_n,
    length (of the ideal, untruncated body: nose + shank), shank_length,
    meplat_radius r_m, meplat_height.
    """

    radius: float
    ogive_radius: float
    nose_length: float
    length: float
    meplat_radius: float

    @property
    def shank_length(self):
        return self.length - self.nose_length

    @property
    def _a(self):
        return self.radius - self.ogive_radius

    @property
    def meplat_x(self):
        """Distance of the flat from the junction, x_m [m]."""
        return float(np.sqrt(max(self.ogive_radius ** 2 - (self.meplat_radius - self._a) ** 2,
                                 0.0)))

    @property
    def meplat_height(self):
        """Length of the ideal tip removed by the flat, l_n - x_m [m]."""
        return self.nose_length - self.meplat_x

    @property
    def body_length(self):
        """Length of the truncated body, flat to base [m]."""
        return self.length - self.meplat_height

    def radius_at(self, zeta):
        """Outer radius R [m] at axial distance zeta [m] from the flat
        (0 <= zeta <= body_length): the ogive, then the shank."""
        zeta = np.asarray(zeta, dtype=float)
        x = np.clip(self.meplat_x - zeta, 0.0, None)
        return self._a + np.sqrt(self.ogive_radius ** 2 - x * x)

    def _nose_volume(self, x):
        # the scalar arcsine of the C library (math.asin), not numpy's,
        # whose vector paths round differently on hosts with AVX-512 and
        # made the set-up's geometry, and so the run, depend on the host
        S, a = self.ogive_radius, self._a
        return np.pi * ((S * S + a * a) * x - x ** 3 / 3.0
                        + a * (x * np.sqrt(max(S * S - x * x, 0.0)) + S * S * math.asin(x / S)))

    @property
    def ideal_volume(self):
        """Volume of the untruncated body [m^3]."""
        return float(np.pi * self.radius ** 2 * self.shank_length
                     + self._nose_volume(self.nose_length))

    @property
    def meplat_volume(self):
        """Volume of the tip removed by the flat [m^3]."""
        return float(self._nose_volume(self.nose_length) - self._nose_volume(self.meplat_x))

    @property
    def volume(self):
        """Volume of the truncated body [m^3] (ideal_volume - meplat_volume)."""
        return float(np.pi * self.radius ** 2 * self.shank_length
                     + self._nose_volume(self.meplat_x))

    def _nose_measure(self, zeta):
        """Cumulative integral of dzeta / R(zeta) over the nose, sampled at
        zeta (sorted, from 0), by trapezoids on a fine graded sampling."""
        xm = self.meplat_x
        fine = np.unique(np.concatenate([
            np.linspace(0.0, xm, 4001),
            xm * np.geomspace(1e-7, 1.0, 4001),
            np.asarray(zeta, dtype=float)]))
        g = 1.0 / self.radius_at(fine)
        cum = np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(fine))])
        return fine, cum

    def nose_cells(self, n_radial):
        """Smallest number of axial nose cells for which the cells, spaced
        as in ogive_projectile, are nowhere taller than the mean radial cell
        width R(zeta)/n_radial of their station: ceil(n_radial * integral of
        dzeta/R over the nose)."""
        _, cum = self._nose_measure([0.0])
        return max(1, int(np.ceil(n_radial * cum[-1] - 1e-9)))

    def nose_stations(self, n_axial_nose):
        """Axial positions zeta [m] (from the flat) of the n_axial_nose + 1
        nose stations: equal steps of the integral of dzeta / R(zeta), so the
        axial spacing is proportional to the local radius (geometric near
        the tip) and every nose cell has the same height-to-width ratio."""
        fine, cum = self._nose_measure([0.0])
        target = np.linspace(0.0, cum[-1], n_axial_nose + 1)
        zeta = np.interp(target, cum, fine)
        zeta[0], zeta[-1] = 0.0, self.meplat_x
        return zeta


def ogive_profile(diameter, length, crh, meplat_radius):
    """OgiveProfile of a tangent-ogive-nose rod (see its docstring for the
    geometry). diameter D, length (ideal tip to base) [m], crh = psi >= 1/2
    (ogive radius psi D), 0 < meplat_radius < D/2 [m]. Raises ValueError
    when the rod is shorter than its nose."""
    if diameter <= 0.0:
        raise ValueError(f"ogive diameter must be positive, got {diameter}")
    if crh < 0.5:
        raise ValueError(f"crh must be >= 0.5 (0.5 is a hemispherical nose), got {crh}")
    r0 = 0.5 * diameter
    s = crh * diameter
    nose = float(np.sqrt(s * s - (s - r0) ** 2))
    if length < nose * (1.0 - 1e-12):
        raise ValueError(f"ogive length {length} m is shorter than its nose "
                         f"({nose} m for D = {diameter} m, crh = {crh})")
    if not 0.0 < meplat_radius < r0:
        raise ValueError(f"meplat radius must lie in (0, D/2 = {r0}) m, got {meplat_radius}")
    return OgiveProfile(radius=r0, ogive_radius=s, nose_length=nose,
                        length=max(float(length), nose), meplat_radius=float(meplat_radius))


NOSE_LAYOUTS = ("cap", "fan")
CAP_TIP_GRADING = 1.5        # tip-block cells, along the axis and the outline, vs the rest
CAP_SMOOTHING_SWEEPS = 150   # Laplacian sweeps over the interior nodes of the cap nose


def _tfi(left, right, bottom, top):
    """Transfinite (Coons) interpolation of a block from its four sides:
    left and right (nz+1, 2) upwards, bottom and top (nr+1, 2) left to
    right; returns (nz+1, nr+1, 2) with the sides copied exactly."""
    nz, nr = len(left) - 1, len(bottom) - 1
    u = np.linspace(0.0, 1.0, nr + 1)[None, :, None]
    v = np.linspace(0.0, 1.0, nz + 1)[:, None, None]
    P = ((1.0 - u) * left[:, None] + u * right[:, None]
         + (1.0 - v) * bottom[None] + v * top[None]
         - ((1.0 - u) * (1.0 - v) * bottom[0] + u * (1.0 - v) * bottom[-1]
            + (1.0 - u) * v * top[0] + u * v * top[-1]))
    P[:, 0], P[:, -1], P[0], P[-1] = left, right, bottom, top
    return P


def _segment(p, q, n):
    t = np.linspace(0.0, 1.0, n + 1)[:, None]
    out = (1.0 - t) * p + t * q
    out[0], out[-1] = p, q
    return out


def _weighted_unit(n, n_first, weight):
    """n + 1 points from 0 to 1: the first n_first cells `weight` times
    as long as the others."""
    w = np.where(np.arange(n) < n_first, weight, 1.0)
    u = np.concatenate([[0.0], np.cumsum(w)])
    u /= u[-1]
    u[-1] = 1.0
    return u


def _cap_counts(prof, n_radial, n_axial_nose):
    """Split of the cap nose: a cells across the axis strip (and along the
    tip block's outline, the flat included), b = n_radial - a across the
    outline strip (and along the tip block's axis), c along both strips;
    the nose has b + c cells along the axis."""
    a = (n_radial + 1) // 2
    b = n_radial - a
    h = prof.radius / n_radial
    if n_axial_nose is None:
        c = max(1, int(round(prof.meplat_x / h - CAP_TIP_GRADING * b)))
    else:
        c = n_axial_nose - b
        if c < 1:
            raise ValueError(f"n_axial_nose must be >= {b + 1} with nose_layout 'cap' and "
                             f"n_radial = {n_radial}, got {n_axial_nose}")
    return a, b, c


def _ogive_cap_blocks(prof, n_radial, n_axial_nose, radial_grading):
    """The three blocks of the cap nose in (r, zeta), zeta from the flat:
    the tip block (M, Mo, C, Ma), the axis strip (Ma, C, Ms, A) and the
    outline strip (C, Mo, B, Ms), meeting at the interior node C; M is the
    centre of the flat, A and B the ends of the shoulder line zeta = x_m,
    Ma, Mo and Ms the block corners on the axis, the outline and the
    shoulder line."""
    a, b, c = _cap_counts(prof, n_radial, n_axial_nose)
    S, R0, zs, rm = prof.ogive_radius, prof.radius, prof.meplat_x, prof.meplat_radius
    # outline: flat (one cell) then the ogive from its edge E to the shoulder,
    # its first a - 1 cells (in the tip block) CAP_TIP_GRADING times longer
    phi_e = math.asin(min(zs / S, 1.0))    # not np.arcsin: see OgiveProfile._nose_volume
    phi = phi_e * (1.0 - _weighted_unit(a - 1 + c, a - 1, CAP_TIP_GRADING))
    ogive = np.column_stack([prof._a + S * np.cos(phi), zs - S * np.sin(phi)])
    ogive[0], ogive[-1] = (rm, 0.0), (R0, zs)
    bottom = np.vstack([[0.0, 0.0], ogive[:a]])                  # M -> Mo, a cells
    outer = ogive[a - 1:]                                        # Mo -> B, c cells
    axis = np.column_stack([np.zeros(b + c + 1),
                            zs * _weighted_unit(b + c, b, CAP_TIP_GRADING)])
    axis[-1, 1] = zs
    shoulder = np.column_stack([R0 * _graded_unit(n_radial, radial_grading),
                                np.full(n_radial + 1, zs)])
    ma, mo, ms = axis[b], bottom[-1], shoulder[a]
    corner = 0.6 * (ma + mo)                                     # C, before smoothing
    ma_c, mo_c, c_ms = _segment(ma, corner, a), _segment(mo, corner, b), _segment(corner, ms, c)
    return [_tfi(axis[:b + 1], mo_c, bottom, ma_c),
            _tfi(axis[b:], c_ms, ma_c, shoulder[:a + 1]),
            _tfi(c_ms, outer, mo_c[::-1], shoulder[a:])], shoulder


def _ogive_body(diameter, length, crh, n_radial, n_axial_shank, n_axial_nose, z_tip,
                meplat_fraction, nose_down, radial_grading, meplat_radius, nose_layout):
    """("grid", X, Z, prof) for the fan layout (one structured grid) or
    ("quads", x, quads, prof) for the cap layout (counter-clockwise quads)."""
    if nose_layout not in NOSE_LAYOUTS:
        raise ValueError(f"nose_layout must be one of {NOSE_LAYOUTS}, got {nose_layout!r}")
    cap = nose_layout == "cap"
    if n_radial < (2 if cap else 1):
        raise ValueError(f"n_radial must be >= {2 if cap else 1} with nose_layout "
                         f"{nose_layout!r}, got {n_radial}")
    if meplat_radius is None:
        if meplat_fraction is None:
            meplat_fraction = 1.0 if cap else 0.5
        meplat_radius = meplat_fraction * 0.5 * diameter / n_radial
    prof = ogive_profile(diameter, length, crh, meplat_radius)
    shank = prof.shank_length
    if shank > 1e-12 * diameter and n_axial_shank < 1:
        raise ValueError(f"n_axial_shank must be >= 1 for a shank of {shank} m")
    if shank <= 1e-12 * diameter:
        n_axial_shank = 0
    shank_z = prof.meplat_x + np.linspace(0.0, shank, n_axial_shank + 1)

    if not cap:
        if n_axial_nose is None:
            n_axial_nose = prof.nose_cells(n_radial)
        if n_axial_nose < 1:
            raise ValueError(f"n_axial_nose must be >= 1, got {n_axial_nose}")
        zeta = np.concatenate([prof.nose_stations(n_axial_nose), shank_z[1:]])
        outer = prof.radius_at(zeta)
        outer[n_axial_nose:] = prof.radius       # the shank, exactly
        s = _graded_unit(n_radial, radial_grading)
        X = outer[:, None] * s[None, :]
        Z = np.broadcast_to(zeta[:, None], X.shape).copy()
        if nose_down:
            Z = z_tip + Z
        else:                                     # mirrored: tip up, rows still upwards
            X, Z = X[::-1].copy(), (z_tip - Z)[::-1].copy()
        return "grid", X, Z, prof

    blocks, shoulder = _ogive_cap_blocks(prof, n_radial, n_axial_nose, radial_grading)
    if n_axial_shank:
        blocks.append(np.stack(np.broadcast_arrays(shoulder[None, :, 0], shank_z[:, None]),
                               axis=-1))
    x, quads = _blocks_to_quads(blocks)
    # smooth the interior nose nodes (the axis, outline and shoulder stay)
    edges = np.sort(np.concatenate([quads[:, [k, (k + 1) % 4]] for k in range(4)]), axis=1)
    edges, counts = np.unique(edges, axis=0, return_counts=True)
    boundary = np.zeros(len(x), dtype=bool)
    boundary[edges[counts == 1].ravel()] = True
    free = ~boundary & (x[:, 1] < prof.meplat_x * (1.0 - 1e-12))
    x = _laplace_smooth(x, quads, free, CAP_SMOOTHING_SWEEPS)
    if nose_down:
        x[:, 1] = z_tip + x[:, 1]
    else:
        x[:, 1] = z_tip - x[:, 1]
        quads = quads[:, [0, 3, 2, 1]]            # mirrored: counter-clockwise again
    return "quads", x, quads, prof


def ogive_projectile(diameter, length, crh, n_radial, n_axial_shank, n_axial_nose=None,
                     z_tip=0.0, meplat_fraction=None, nose_down=True, radial_grading=1.0,
                     meplat_radius=None, nose_layout="cap"):
    """Crossed-triangle mesh of a tangent-ogive-nose rod on the axis r = 0.

    diameter D [m]; length [m]: the ideal body, sharp tip to base (nose +
    shank); crh: caliber radius head psi, ogive radius S = psi D, nose length
    l_n = (D/2) sqrt(4 psi - 1) (derived in OgiveProfile); the shank,
    length - l_n, must be >= 0. Every quadrilateral cell is crossed into
    four triangles through a centre node at the mean of its corners.

    The sharp tip is cut by a flat (meplat) of radius meplat_radius or, by
    default, meplat_fraction times the mean shank radial spacing h =
    (D/2)/n_radial. The flat is the lowest point of the body and lies at
    z = z_tip with nose_down (the body occupies z_tip <= z <= z_tip + length
    - meplat_height); with nose_down False the body is mirrored (flat at
    z = z_tip pointing up, body below). The cut removes
    OgiveProfile.meplat_volume, which scales as the cube of the meplat
    radius.

    The shank is n_radial x n_axial_shank cells, uniform along and, with
    radial_grading = g, with widths growing geometrically outwards so the
    outermost is g times the innermost (uniform for g = 1); its cells are
    square for n_axial_shank ~ n_radial * shank_length / (D/2).

    nose_layout "cap" (default): cells of about the shank's size all over
    the nose, so the nose does not shorten the explicit time step. The flat
    is a single cell (meplat_fraction 1 by default: one h wide) and the nose
    is three structured blocks meeting at one interior node C (valence 3):
    a tip block above the flat (a x b cells, a = ceil(n_radial/2),
    b = n_radial - a), an axis strip (a cells across) and an outline strip
    (b cells across) running from the tip block to the shoulder with c cells
    along; n_axial_nose = b + c is the number of cells along the axis in
    the nose (None: the axis and outline spacing about h, the tip block's
    CAP_TIP_GRADING = 1.5 times longer). Outline nodes are spaced evenly in
    arc length, each block is filled by transfinite interpolation and the
    interior nose nodes are relaxed by CAP_SMOOTHING_SWEEPS Laplacian
    sweeps. The nose holds a b + n_radial c cells; the mesh has 4 times as
    many triangles as cells and the corners plus one centre per cell as
    nodes (corners of the tip block, axis strip, outline strip and shank,
    shared ones once, then the centres). For D = 12.9 mm, crh 3,
    n_radial = 8: smallest altitude about 0.35 of the shank's, smallest
    triangle angle about 17 degrees (at the edge of the flat).

    nose_layout "fan": one structured grid, n_radial cells across at every
    station, n_axial_nose + n_axial_shank along (4 n_radial n triangles
    and (n_radial + 1)(n + 1) + n_radial n nodes for n cells along,
    corners row by row then centres, as crossed_mapped). The flat is
    meplat_fraction = 0.5 of h by default, the nose stations are spaced in
    proportion to the local radius (equal steps of the integral of dz/R),
    so every nose cell has the same height-to-width ratio and the cells get
    finer towards the tip; n_axial_nose = None picks the smallest count for
    which no nose cell is taller than its mean radial width
    (OgiveProfile.nose_cells). The cells at the flat are meplat_radius /
    n_radial wide: they set the explicit time step of the body (about 20
    times shorter than the shank's for the default flat).

    Boundary nodes lie on the exact profile; the outline between them is
    straight, so the mesh volume falls short of the truncated body by the
    chord error, O(dz^3 / S) per outline segment.
    """
    kind, a, b, _ = _ogive_body(diameter, length, crh, n_radial, n_axial_shank, n_axial_nose,
                                z_tip, meplat_fraction, nose_down, radial_grading,
                                meplat_radius, nose_layout)
    return crossed_mapped(a, b) if kind == "grid" else _crossed_quads_of(a, b)


def ogive_projectile_particles(diameter, length, crh, n_radial, n_axial_shank,
                               n_axial_nose=None, z_tip=0.0, meplat_fraction=None,
                               nose_down=True, radial_grading=1.0, meplat_radius=None,
                               nose_layout="cap"):
    """The ogive_projectile cells (same arguments and layout) as particles:
    one per cell at its area centroid with its planar area
    (ParticleLattice), for pure-SPH bodies; the ring volumes 2 pi r area sum
    to the volume of the meshed outline."""
    kind, a, b, _ = _ogive_body(diameter, length, crh, n_radial, n_axial_shank, n_axial_nose,
                                z_tip, meplat_fraction, nose_down, radial_grading,
                                meplat_radius, nose_layout)
    if kind == "grid":
        return mapped_lattice(a, b)
    area, centroid = _quad_geometry(a, b)
    if not np.all(area > 0.0):
        raise ValueError("folded or degenerate cap nose: a cell of non-positive area")
    return ParticleLattice(x=centroid, area=area)


#: The sphere's butterfly layout (sphere, sphere_particles): the core's
#: half-width as a fraction of the radius, how far its curved sides bulge
#: beyond it (a fraction of the half-width), and the share of the
#: equatorial radius's cells that lie in the core. Chosen by scanning the
#: layouts of 2 to 60 cells across the radius for the largest smallest
#: triangle angle (at least 26.9 degrees, 27.5 from 5 cells on; from 10
#: cells on at most 0.5 % of the triangles below 30 degrees) with cells
#: within a factor 2.1 in size.
SPHERE_CORE = 0.45
SPHERE_BULGE = 0.1
SPHERE_CORE_SHARE = 0.6


def _arc_points(centre, radius, angles):
    """Points (len(angles), 2) on a circle [m]. math.cos and math.sin, not
    numpy's: numpy's vector paths may round differently from one host to
    the next (see OgiveProfile._nose_volume)."""
    return np.array([(centre[0] + radius * math.cos(t), centre[1] + radius * math.sin(t))
                     for t in angles])


def _arc_through(p, q, mid, n):
    """n equal-angle cells along the circular arc from p through mid to q
    (points (n + 1, 2), the ends exactly p and q). The centre by Cramer's
    rule in Python floats (a library solve may take another path on
    another processor)."""
    (px, pz), (qx, qz), (mx, mz) = (tuple(map(float, v)) for v in (p, q, mid))
    a11, a12, b1 = mx - px, mz - pz, 0.5 * (mx * mx + mz * mz - px * px - pz * pz)
    a21, a22, b2 = qx - mx, qz - mz, 0.5 * (qx * qx + qz * qz - mx * mx - mz * mz)
    det = a11 * a22 - a12 * a21
    cx, cz = (b1 * a22 - a12 * b2) / det, (a11 * b2 - b1 * a21) / det
    radius = math.hypot(px - cx, pz - cz)
    t0, tm, t1 = (math.atan2(z - cz, x - cx) for x, z in ((px, pz), (mx, mz), (qx, qz)))
    sweep = t1 - t0
    if not min(t0, t1) <= tm <= max(t0, t1):        # the arc through mid goes the other way
        sweep -= math.copysign(2.0 * math.pi, sweep)
    out = _arc_points((cx, cz), radius, [t0 + sweep * k / n for k in range(n + 1)])
    out[0], out[-1] = p, q
    return out


def _graded_segment(p, q, n, ratio):
    """n cells from p to q, the last `ratio` times as long as the first
    (widths growing geometrically; math.pow, not numpy's, as above)."""
    widths = [math.pow(ratio, k / (n - 1)) if n > 1 else 1.0 for k in range(n)]
    ends = [0.0]
    for w in widths:
        ends.append(ends[-1] + w)
    u = np.array([e / ends[-1] for e in ends])[:, None]
    out = (1.0 - u) * p + u * q
    out[0], out[-1] = p, q
    return out


def _sphere_quads(radius, n_radial, z_base):
    """The sphere's quadrilaterals: nodes (n, 2) and counter-clockwise
    quads (q, 4) (see sphere)."""
    if n_radial < 2:
        raise ValueError(f"n_radial must be >= 2 for a sphere, got {n_radial}")
    R, zc = radius, z_base + radius
    nc = max(1, int(round(SPHERE_CORE_SHARE * n_radial)))
    m = max(1, n_radial - nc)
    a = SPHERE_CORE * R
    bulge = 1.0 + SPHERE_BULGE

    def P(r, z):
        return np.array([r, z], dtype=float)

    corner_lo, corner_hi = P(a, zc - a), P(a, zc + a)
    core_right = _arc_through(corner_lo, corner_hi, P(a * bulge, zc), 2 * nc)
    # the lower and upper sides: arcs symmetric about the axis (they meet it square)
    core_bottom = _arc_through(P(-a, zc - a), corner_lo, P(0.0, zc - a * bulge), 2 * nc)[nc:]
    core_top = _arc_through(P(-a, zc + a), corner_hi, P(0.0, zc + a * bulge), 2 * nc)[nc:]
    core_bottom[0], core_top[0] = P(0.0, zc - a * bulge), P(0.0, zc + a * bulge)
    core_axis = _segment(core_bottom[0], core_top[0], 2 * nc)
    # the layers grow outwards so that the outermost cells are about square
    ratio = (R * 0.25 * math.pi / nc) / (a * bulge / nc)
    quarter = 0.25 * math.pi
    outline_lo = _arc_points((0.0, zc), R, [-2.0 * quarter + quarter * k / nc for k in range(nc + 1)])
    outline_mid = _arc_points((0.0, zc), R, [-quarter + quarter * k / nc for k in range(2 * nc + 1)])
    outline_hi = _arc_points((0.0, zc), R, [2.0 * quarter - quarter * k / nc for k in range(nc + 1)])
    outline_lo[0], outline_hi[0] = P(0.0, zc - R), P(0.0, zc + R)
    outline_mid[0], outline_mid[-1] = outline_lo[-1], outline_hi[-1]
    axis_lo = _graded_segment(P(0.0, zc - R), core_bottom[0], m, 1.0 / ratio)
    axis_hi = _graded_segment(core_top[0], P(0.0, zc + R), m, ratio)
    diagonal_lo = _graded_segment(outline_lo[-1], corner_lo, m, 1.0 / ratio)
    diagonal_hi = _graded_segment(corner_hi, outline_hi[-1], m, ratio)
    blocks = [_tfi(core_axis, core_right, core_bottom, core_top),
              _tfi(axis_lo, diagonal_lo, outline_lo, core_bottom),
              _tfi(core_right, outline_mid, diagonal_lo[::-1], diagonal_hi),
              _tfi(axis_hi, diagonal_hi, core_top, outline_hi)]
    return _blocks_to_quads(blocks)


def sphere(radius, n_radial, z_base=0.0):
    """Crossed-triangle mesh of a sphere of radius R on the axis, lowest
    point at z = z_base (the body occupies z_base <= z <= z_base + 2R).

    The half disc r >= 0 of the (r, z) plane is four structured blocks (a
    butterfly): a core about the centre, 0.45 R wide with sides bulging
    out to 0.495 R, and three blocks between it and the outline (below,
    beside and above the core) whose layers grow outwards so that the
    outermost cells are about square. n_radial (>= 2) is the number of
    cells along the equatorial radius: 0.6 n_radial (rounded) in the core
    and the rest in the layers; the outline has 4 round(0.6 n_radial)
    cells. Each block is filled by transfinite interpolation; every
    quadrilateral is crossed into four triangles through a centre node at
    the mean of its corners. For 2 to 60 cells across the smallest
    triangle angle is at least 26.9 degrees (crossed squares: 45), 27.5
    from 5 cells on; from 10 cells on at most 0.5 % of the triangles
    start below the conversion angle theta_c = 30 degrees (up to 17 %
    below 10 cells; the relative_angle rule of &convert applies to
    them). The cells differ in size by up to
    a factor 2.1 (the core's are the smallest), so the core sets the
    explicit time step: the smallest altitude is about 0.31 R / n_radial.

    Boundary nodes lie on the sphere; the outline between them is
    straight, so the mesh volume falls short of 4/3 pi R^3 by the chord
    error: 0.43 % at 10 cells across, 0.11 % at 20, 0.03 % at 40.
    """
    x, quads = _sphere_quads(radius, n_radial, z_base)
    return _crossed_quads_of(x, quads)


def sphere_particles(radius, n_radial, z_base=0.0):
    """The sphere's cells (same arguments and layout) as particles: one
    per cell at its area centroid with its planar area (ParticleLattice);
    the ring volumes 2 pi r area sum to the volume of the meshed outline."""
    x, quads = _sphere_quads(radius, n_radial, z_base)
    area, centroid = _quad_geometry(x, quads)
    if not np.all(area > 0.0):
        raise ValueError("folded or degenerate sphere layout: a cell of non-positive area")
    return ParticleLattice(x=centroid, area=area)


def geometric_ratio(first, total, n):
    """Growth ratio q > 0 of n cells whose widths first, first q, ...,
    first q^(n-1) add up to total: the root of
    first (1 + q + ... + q^(n-1)) = total, found by bisection (the sum grows
    monotonically with q) to round-off. q > 1 when total > n first, q < 1
    when total < n first. Raises ValueError when no such ratio exists
    (total < first, or n = 1 and total != first)."""
    first, total = float(first), float(total)
    if n < 1 or first <= 0.0 or total <= 0.0:
        raise ValueError(f"geometric_ratio needs n >= 1 and positive widths, got first = "
                         f"{first}, total = {total}, n = {n}")
    target = total / first
    if n == 1:
        if abs(target - 1.0) > 1e-12:
            raise ValueError(f"a single cell of width {total} cannot start with width {first}")
        return 1.0
    if target < 1.0:
        raise ValueError(f"{n} cells starting at width {first} cannot fit in {total}")
    k = np.arange(n)

    def excess(q):
        return np.sum(q ** k) - target

    lo, hi = 0.0, max(1.0, target ** (1.0 / (n - 1)))
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if excess(mid) > 0.0:
            hi = mid
        else:
            lo = mid
        if hi - lo <= 4e-16 * hi:
            break
    return 0.5 * (lo + hi)


def plate_growth_ratio(radius, r_fine, n_fine, n_coarse):
    """Growth ratio of the coarse radial cells of plate(): n_coarse cells
    from r_fine to radius, the first as wide as the fine cells,
    r_fine / n_fine (1.0 when there is no coarse zone)."""
    if n_coarse == 0:
        return 1.0
    return geometric_ratio(r_fine / n_fine, radius - r_fine, n_coarse)


def plate_r_edges(radius, r_fine, n_fine, n_coarse):
    """Radial cell edges of plate(): n_fine uniform cells over [0, r_fine],
    then n_coarse cells growing geometrically (plate_growth_ratio) out to
    radius, the first of them as wide as a fine cell. The last edge is
    radius exactly."""
    if not 0.0 < r_fine <= radius:
        raise ValueError(f"plate needs 0 < r_fine <= radius, got r_fine = {r_fine}, "
                         f"radius = {radius}")
    if n_fine < 1 or n_coarse < 0:
        raise ValueError(f"plate needs n_fine >= 1 and n_coarse >= 0, got {n_fine}, {n_coarse}")
    fine = np.linspace(0.0, r_fine, n_fine + 1)
    if r_fine >= radius * (1.0 - 1e-12):
        if n_coarse:
            raise ValueError(f"r_fine = radius = {radius}: no room for {n_coarse} coarse cells")
        fine[-1] = radius
        return fine
    if n_coarse == 0:
        raise ValueError(f"the plate beyond r_fine = {r_fine} (out to {radius}) needs "
                         "n_coarse >= 1")
    q = plate_growth_ratio(radius, r_fine, n_fine, n_coarse)
    widths = (r_fine / n_fine) * q ** np.arange(n_coarse)
    coarse = r_fine + np.cumsum(widths)
    coarse[-1] = radius
    return np.concatenate([fine, coarse])


def plate(radius, thickness, n_thickness, r_fine, n_fine, n_coarse, z_top=0.0):
    """Crossed-triangle mesh of a disc (target plate) 0 <= r <= radius,
    z_top - thickness <= z <= z_top [m].

    Radially: n_fine uniform cells of width r_fine / n_fine out to r_fine
    (the impact zone), then n_coarse cells growing geometrically to radius,
    the first as wide as a fine cell (ratio: plate_growth_ratio; edges:
    plate_r_edges). Through the thickness: n_thickness uniform cells.
    4 (n_fine + n_coarse) n_thickness triangles, nodes and elements laid
    out as crossed_quads (rows of constant z from the bottom face up)."""
    if thickness <= 0.0 or n_thickness < 1:
        raise ValueError(f"plate needs thickness > 0 and n_thickness >= 1, got {thickness}, "
                         f"{n_thickness}")
    return crossed_quads(plate_r_edges(radius, r_fine, n_fine, n_coarse),
                         np.linspace(z_top - thickness, z_top, n_thickness + 1))


def plate_particles(radius, thickness, n_thickness, r_fine, n_fine, n_coarse, z_top=0.0):
    """The plate() cells as particles (ParticleLattice, one per cell at its
    centre with its planar area), for pure-SPH targets."""
    if thickness <= 0.0 or n_thickness < 1:
        raise ValueError(f"plate needs thickness > 0 and n_thickness >= 1, got {thickness}, "
                         f"{n_thickness}")
    return lattice(plate_r_edges(radius, r_fine, n_fine, n_coarse),
                   np.linspace(z_top - thickness, z_top, n_thickness + 1))


def read_gmsh(path, scale=1.0):
    """Mesh of the 3-node triangles of a 2D gmsh .msh file (read with meshio).

    The first two coordinates of each node, times scale (e.g. 1e-3 for a
    file drawn in millimetres), are taken as (r, z) [m]; every other cell
    type (points, lines, quadrilaterals, quadratic triangles) is ignored;
    each triangle is reordered counter-clockwise in the (r, z) plane; nodes
    no triangle uses are dropped and the rest renumbered in their file
    order. Radii within round-off of the axis (|r| <= 1e-12 of the mesh
    size) are set to 0.

    Raises ValueError, naming the file, when it is not a readable .msh
    file (OSError, e.g. FileNotFoundError, when it cannot be opened), holds no
    3-node triangles, has a node used by a triangle at r < 0 beyond
    round-off, or has a degenerate triangle (|area| <= 1e-12 of its longest
    edge squared).
    """
    from meshio import gmsh    # the reader itself: meshio.read exits the process on failure

    try:
        msh = gmsh.read(path)
    except OSError:
        raise
    except Exception as exc:  # meshio raises several types for a malformed file
        raise ValueError(f"{path}: cannot be read as a gmsh .msh file "
                         f"({type(exc).__name__}: {exc})") from exc
    tris = [np.asarray(c.data) for c in msh.cells if c.type == "triangle"]
    if not tris or sum(len(t) for t in tris) == 0:
        found = sorted({c.type for c in msh.cells}) or ["none"]
        raise ValueError(f"{path}: expected a 2D mesh of 3-node triangles ('triangle' "
                         f"cells), found cell types {', '.join(found)}")
    conn = np.vstack(tris).astype(np.int64)
    points = np.asarray(msh.points, dtype=float)
    if points.ndim != 2 or points.shape[1] < 2:
        raise ValueError(f"{path}: expected nodes with at least 2 coordinates, "
                         f"got an array of shape {points.shape}")
    used, inverse = np.unique(conn, return_inverse=True)
    conn = inverse.reshape(conn.shape).astype(np.int64)
    x = points[used, :2] * float(scale)
    size = max(np.ptp(x[:, 0]), np.ptp(x[:, 1]))
    neg = x[:, 0] < -1e-12 * size
    if np.any(neg):
        k = int(np.flatnonzero(neg)[0])
        raise ValueError(f"{path}: {int(neg.sum())} node(s) at r < 0, e.g. file node "
                         f"{int(used[k])} at (r, z) = ({x[k, 0]:.6g}, {x[k, 1]:.6g}) m; "
                         "expected the body on the r >= 0 side of the axis")
    x[:, 0] = np.maximum(x[:, 0], 0.0)
    m = Mesh(x=x, conn=conn)
    area = triangle_areas(m)
    p = x[conn]
    lmax2 = np.max(np.sum((p[:, [1, 2, 0]] - p) ** 2, axis=2), axis=1)
    flat = np.abs(area) <= 1e-12 * lmax2
    if np.any(flat):
        k = int(np.flatnonzero(flat)[0])
        raise ValueError(f"{path}: {int(flat.sum())} degenerate triangle(s) (zero area), e.g. "
                         f"triangle {k} on file nodes {used[conn[k]].tolist()}")
    cw = area < 0.0
    m.conn[cw] = m.conn[cw][:, [0, 2, 1]]
    return m


def _ogive_args(b):
    return (2.0 * b["radius"], b["length"], b["crh"], b["n_radial"], b["n_axial"], b["n_nose"])


def _plate_args(b):
    return (b["radius"], b["length"], b["n_axial"], b["fine_radius"], b["n_radial"],
            b["n_coarse"], b["z_base"] + b["length"])


GENERATORS = {
    ("rod", "elements"): lambda b: rod(b["radius"], b["length"], b["n_radial"], b["n_axial"],
                                       b["z_base"], b["inner_radius"]),
    ("rod", "particles"): lambda b: rod_particles(b["radius"], b["length"], b["n_radial"],
                                                  b["n_axial"], b["z_base"], b["inner_radius"]),
    ("ogive", "elements"): lambda b: ogive_projectile(*_ogive_args(b), z_tip=b["z_base"]),
    ("ogive", "particles"): lambda b: ogive_projectile_particles(*_ogive_args(b),
                                                                 z_tip=b["z_base"]),
    ("plate", "elements"): lambda b: plate(*_plate_args(b)),
    ("plate", "particles"): lambda b: plate_particles(*_plate_args(b)),
    ("sphere", "elements"): lambda b: sphere(b["radius"], b["n_radial"], b["z_base"]),
    ("sphere", "particles"): lambda b: sphere_particles(b["radius"], b["n_radial"], b["z_base"]),
    ("gmsh", "elements"): lambda b: read_gmsh(b["mesh_file"], b["mesh_scale"]),
}


def body_discretisation(body):
    """Mesh (elements) or ParticleLattice (particles) of one validated &body."""
    return GENERATORS[(body["geometry"], body["discretisation"])](body)


def boundary_edges(conn):
    """Edges (k, 2) used by exactly one triangle, oriented as in their
    triangle (the body lies to their left)."""
    edges = np.concatenate([conn[:, [0, 1]], conn[:, [1, 2]], conn[:, [2, 0]]])
    if len(edges) == 0:
        return edges
    # an edge's sorted node pair as one integer (a row-wise unique sorts
    # structured records, ten times slower: it was most of the metrics of
    # a snapshot)
    key = np.sort(edges, axis=1).astype(np.int64)
    key = key[:, 0] * (int(key[:, 1].max()) + 1) + key[:, 1]
    _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    return edges[counts[inverse] == 1]
