"""Mesh generators: bodies as crossed-triangle T3 meshes (arrays only).

Each quadrilateral is split into four triangles through a centre node: the
pattern that keeps constant-strain triangles from locking in nearly
incompressible plastic flow (ALGORITHMS.md section 1).
"""

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


GENERATORS = {
    ("rod", "elements"): lambda b: rod(b["radius"], b["length"], b["n_radial"], b["n_axial"],
                                       b["z_base"], b["inner_radius"]),
    ("rod", "particles"): lambda b: rod_particles(b["radius"], b["length"], b["n_radial"],
                                                  b["n_axial"], b["z_base"], b["inner_radius"]),
}


def body_discretisation(body):
    """Mesh (elements) or ParticleLattice (particles) of one validated &body."""
    return GENERATORS[(body["geometry"], body["discretisation"])](body)


def boundary_edges(conn):
    """Edges (k, 2) used by exactly one triangle, oriented as in their
    triangle (the body lies to their left)."""
    edges = np.concatenate([conn[:, [0, 1]], conn[:, [1, 2]], conn[:, [2, 0]]])
    key = np.sort(edges, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return edges[counts[inverse.ravel()] == 1]
