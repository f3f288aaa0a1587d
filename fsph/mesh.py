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
