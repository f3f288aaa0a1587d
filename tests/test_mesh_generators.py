"""Geometry generators of fsph.mesh: the mapped crossed-quad mesher, the
ogive-nose projectile, the graded plate and the gmsh reader.

Every check is geometric: orientation and positivity of the triangles,
volumes of revolution against their analytic values, boundary nodes on the
analytic profile, requested counts and bounded aspect ratios.
"""

import numpy as np
import pytest

from fsph import mesh


def assert_valid(m):
    """Positive counter-clockwise triangles, every node used, conforming
    (each interior edge shared by exactly two triangles)."""
    area = mesh.triangle_areas(m)
    assert np.all(area > 0.0)
    assert np.array_equal(np.unique(m.conn), np.arange(m.n_nodes))
    edges = np.sort(np.concatenate([m.conn[:, [0, 1]], m.conn[:, [1, 2]],
                                    m.conn[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert counts.max() <= 2


def tapered_grid(nr=5, nz=7):
    """A curved, tapered structured grid (corners (nz+1, nr+1))."""
    s = np.linspace(0.0, 1.0, nr + 1)
    t = np.linspace(0.0, 1.0, nz + 1)
    outer = 1e-3 * (1.0 + 0.5 * t + 0.3 * np.sin(3.0 * t))
    X = outer[:, None] * s[None, :]
    Z = 4e-3 * t[:, None] + 2e-4 * np.sin(np.pi * s)[None, :] * t[:, None]
    return X, Z


def polygon_ring_volume(X, Z):
    """Volume of revolution of each grid cell from the exact polygon
    formula V = (pi/3) sum (r_k + r_k+1) (r_k z_k+1 - r_k+1 z_k) ... summed
    (Pappus with the polygon centroid)."""
    px = [X[:-1, :-1], X[:-1, 1:], X[1:, 1:], X[1:, :-1]]
    pz = [Z[:-1, :-1], Z[:-1, 1:], Z[1:, 1:], Z[1:, :-1]]
    vol = 0.0
    for k in range(4):
        x0, z0, x1, z1 = px[k], pz[k], px[(k + 1) % 4], pz[(k + 1) % 4]
        vol = vol + (x0 + x1) * (x0 * z1 - x1 * z0)
    return np.pi / 3.0 * vol


# -- mapped crossed quads ---------------------------------------------------

def test_crossed_mapped_reduces_to_crossed_quads():
    r = np.array([0.0, 0.1, 0.35, 0.7, 1.3]) * 1e-3
    z = np.array([-3.0, -1.1, 0.2, 0.5]) * 1e-3
    ref = mesh.crossed_quads(r, z)
    R, Z = np.meshgrid(r, z)
    m = mesh.crossed_mapped(R, Z)
    assert np.array_equal(m.conn, ref.conn)
    assert np.allclose(m.x, ref.x, rtol=0.0, atol=1e-18)
    assert_valid(m)


def test_crossed_mapped_curvilinear_grid():
    X, Z = tapered_grid()
    m = mesh.crossed_mapped(X, Z)
    nz, nr = X.shape[0] - 1, X.shape[1] - 1
    assert m.n_elements == 4 * nr * nz
    assert m.n_nodes == (nr + 1) * (nz + 1) + nr * nz
    assert_valid(m)
    # corners first, then centres at the mean of the four corners
    assert np.array_equal(m.x[:(nr + 1) * (nz + 1)], np.column_stack([X.ravel(), Z.ravel()]))
    centre = 0.25 * (X[1, 2] + X[1, 3] + X[2, 2] + X[2, 3])
    assert m.x[(nr + 1) * (nz + 1) + 1 * nr + 2, 0] == pytest.approx(centre, rel=1e-15)
    # the triangles tile the quads exactly: same ring volume as the polygons
    assert mesh.ring_volume(m) == pytest.approx(polygon_ring_volume(X, Z).sum(), rel=1e-12)


def test_crossed_mapped_orientation_and_folds():
    X, Z = tapered_grid()
    flipped = mesh.crossed_mapped(X[::-1], Z[::-1])      # left-handed: reversed
    assert np.all(mesh.triangle_areas(flipped) > 0.0)
    Xf = X.copy()
    Xf[3, 2], Xf[3, 3] = Xf[3, 3], Xf[3, 2]              # a folded cell
    with pytest.raises(ValueError, match="folded or degenerate"):
        mesh.crossed_mapped(Xf, Z)
    with pytest.raises(ValueError, match="same shape"):
        mesh.crossed_mapped(X, Z[:, :-1])


def test_mapped_lattice_centroids_and_areas():
    X, Z = tapered_grid()
    p = mesh.mapped_lattice(X, Z)
    m = mesh.crossed_mapped(X, Z)
    area = mesh.triangle_areas(m).reshape(-1, 4).sum(axis=1)
    assert np.allclose(p.area, area, rtol=1e-12, atol=0.0)
    assert p.area.sum() == pytest.approx(area.sum(), rel=1e-13)
    # ring volumes at the centroids are the exact cell volumes (Pappus)
    assert np.allclose(p.ring_volume, polygon_ring_volume(X, Z).ravel(), rtol=1e-12, atol=0.0)
    # a tensor grid gives the plain lattice
    r, z = np.linspace(0.0, 2e-3, 5), np.linspace(1e-3, 3e-3, 4)
    R, Zg = np.meshgrid(r, z)
    a, b = mesh.mapped_lattice(R, Zg), mesh.lattice(r, z)
    assert np.allclose(a.x, b.x, rtol=1e-13, atol=1e-19)
    assert np.allclose(a.area, b.area, rtol=1e-13, atol=0.0)


def test_mesh_quality_of_a_square_grid():
    m = mesh.crossed_quads(np.linspace(0.0, 1e-3, 5), np.linspace(0.0, 2e-3, 9))
    q = mesh.mesh_quality(m)
    assert q["n_elements"] == 4 * 4 * 8
    assert q["max_aspect"] == pytest.approx(2.0, rel=1e-12)     # crossed square cells
    assert q["min_edge"] == pytest.approx(0.25e-3 / np.sqrt(2.0), rel=1e-12)
    assert q["min_altitude"] == pytest.approx(0.125e-3, rel=1e-12)
    assert q["volume"] == pytest.approx(np.pi * 1e-6 * 2e-3, rel=1e-13)
