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

def test_crossed_quads_layout_is_pinned():
    # corners row by row, then centres; the four triangles of a cell together
    m = mesh.crossed_quads([0.0, 1.0, 3.0], [0.0, 2.0])
    assert np.array_equal(m.x, [[0, 0], [1, 0], [3, 0], [0, 2], [1, 2], [3, 2],
                                [0.5, 1], [2, 1]])
    assert np.array_equal(m.conn, [[0, 1, 6], [1, 4, 6], [4, 3, 6], [3, 0, 6],
                                   [1, 2, 7], [2, 5, 7], [5, 4, 7], [4, 1, 7]])
    assert m.conn.dtype == np.int64


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


# -- ogive-nose projectile --------------------------------------------------

D, L, CRH = 12.9e-3, 88.9e-3, 3.0          # the validation projectile


def ogive_radius(x, diameter=D, crh=CRH):
    """Tangent-ogive outer radius at distance x from the nose/shank
    junction towards the tip (arc of radius S = crh D centred at r = R0 - S
    in the junction plane)."""
    r0, s = 0.5 * diameter, crh * diameter
    return r0 - s + np.sqrt(s * s - np.asarray(x, dtype=float) ** 2)


def gauss_volume(f, a, b, n=200, pieces=50):
    """pi * integral of f(x)^2 over [a, b] by composite Gauss-Legendre."""
    t, w = np.polynomial.legendre.leggauss(n)
    edges = np.linspace(a, b, pieces + 1)
    total = 0.0
    for lo, hi in zip(edges[:-1], edges[1:]):
        x = 0.5 * (hi - lo) * t + 0.5 * (hi + lo)
        total += 0.5 * (hi - lo) * np.sum(w * f(x) ** 2)
    return np.pi * total


def outline(m, z_tip):
    """Outer profile of a nose-down ogive mesh: the boundary corner nodes
    with r > 0 that are on neither the flat nor the base."""
    nodes = np.unique(mesh.boundary_edges(m.conn))
    r, z = m.x[nodes, 0], m.x[nodes, 1]
    keep = (r > 0.0) & (z > z_tip) & (z < z.max())
    order = np.argsort(z[keep])
    return r[keep][order], z[keep][order]


def test_ogive_nose_length_and_counts():
    r0, s = 0.5 * D, CRH * D
    nose = np.sqrt(s * s - (s - r0) ** 2)
    assert nose == pytest.approx(r0 * np.sqrt(4.0 * CRH - 1.0), rel=1e-14)
    assert ogive_radius(nose) == pytest.approx(0.0, abs=1e-15)
    prof = mesh.ogive_profile(D, L, CRH, 0.4e-3)
    assert prof.nose_length == pytest.approx(nose, rel=1e-14)
    assert prof.shank_length == pytest.approx(L - nose, rel=1e-14)
    m = mesh.ogive_projectile(D, L, CRH, 6, 40, 20, nose_layout="fan")
    assert m.n_elements == 4 * 6 * 60
    assert m.n_nodes == 7 * 61 + 6 * 60
    assert_valid(m)


@pytest.mark.parametrize("n_radial, n_shank, n_nose", [(4, 20, 12), (8, 84, None), (6, 30, 25)])
def test_ogive_volume_matches_analytic(n_radial, n_shank, n_nose):
    m = mesh.ogive_projectile(D, L, CRH, n_radial, n_shank, n_nose, z_tip=1e-3, nose_layout="fan")
    assert_valid(m)
    r0, s = 0.5 * D, CRH * D
    nose = np.sqrt(s * s - (s - r0) ** 2)
    r_m = 0.5 * r0 / n_radial                              # the default flat
    x_m = np.sqrt(s * s - (r_m + s - r0) ** 2)
    # analytic ideal body: cylinder + tangent-ogive solid, against quadrature
    a = r0 - s
    v_ogive = np.pi * (s * s * nose - nose ** 3 / 3.0 + a * s * s * np.arcsin(nose / s))
    assert gauss_volume(ogive_radius, 0.0, nose) == pytest.approx(v_ogive, rel=1e-12)
    v_ideal = np.pi * r0 ** 2 * (L - nose) + v_ogive
    v_cap = gauss_volume(ogive_radius, x_m, nose)            # removed by the flat
    assert 0.0 < v_cap < np.pi * r_m ** 2 * (nose - x_m)     # inside its cylinder
    v_exact = v_ideal - v_cap
    prof = mesh.ogive_profile(D, L, CRH, r_m)
    assert prof.volume == pytest.approx(v_exact, rel=1e-12)
    assert prof.meplat_volume == pytest.approx(v_cap, rel=1e-9)

    # the mesh is the stack of frustums through its outline, exactly
    r, z = outline(m, 1e-3)
    zs = np.concatenate([[1e-3], z, [m.x[:, 1].max()]])
    rs = np.concatenate([[r_m], r, [r0]])
    assert rs[0] == pytest.approx(m.x[m.x[:, 1] == 1e-3, 0].max(), rel=1e-14)
    dz = np.diff(zs)
    frustums = np.pi / 3.0 * np.sum(dz * (rs[:-1] ** 2 + rs[:-1] * rs[1:] + rs[1:] ** 2))
    v_mesh = mesh.ring_volume(m)
    assert v_mesh == pytest.approx(frustums, rel=1e-12)
    # ... short of the body by the chord error only: the profile is concave,
    # so chords lie inside, and each segment loses at most
    # 2 pi R_max max|R''| dz^3 / 12 with |R''| = S^2 / (S^2 - x^2)^(3/2),
    # largest at the tip end of the segment
    x_lo = np.clip(x_m - (zs[:-1] - 1e-3), 0.0, None)          # tip end of each segment
    curv = s * s / (s * s - x_lo ** 2) ** 1.5
    bound = np.sum(2.0 * np.pi * rs[1:] * curv * dz ** 3 / 12.0)
    deficit = v_exact - v_mesh
    assert 0.0 <= deficit <= bound
    assert deficit / v_exact < 1e-3


def test_ogive_boundary_on_profile_and_flat():
    n_radial, z_tip = 8, -2e-3
    m = mesh.ogive_projectile(D, L, CRH, n_radial, 84, None, z_tip=z_tip, nose_layout="fan")
    prof = mesh.ogive_profile(D, L, CRH, 0.5 * 0.5 * D / n_radial)
    r, z = outline(m, z_tip)
    x = prof.meplat_x - (z - z_tip)                            # distance from the junction
    expect = np.where(x > 0.0, ogive_radius(np.clip(x, 0.0, None)), 0.5 * D)
    assert np.allclose(r, expect, rtol=0.0, atol=1e-12 * D)
    # one outline node per station strictly inside the nose
    assert np.sum(x > 0.0) == prof.nose_cells(n_radial) - 1
    # the flat: the lowest point, at z_tip, of radius r_m = half a shank cell
    assert m.x[:, 1].min() == z_tip
    flat = m.x[m.x[:, 1] == z_tip]
    assert flat[:, 0].max() == pytest.approx(0.25 * D / n_radial, rel=1e-14)
    assert len(flat) == n_radial + 1
    assert m.x[:, 1].max() == pytest.approx(z_tip + L - prof.meplat_height, rel=1e-14)
    assert m.x[:, 0].min() == 0.0
    assert m.x[:, 0].max() == pytest.approx(0.5 * D, rel=1e-15)


def test_ogive_aspect_ratio_bounded():
    # shank cells square, nose count automatic: every cell near square
    for n_radial in (4, 8):
        prof = mesh.ogive_profile(D, L, CRH, 0.25 * D / n_radial)
        n_shank = round(n_radial * prof.shank_length / (0.5 * D))
        q = mesh.mesh_quality(mesh.ogive_projectile(D, L, CRH, n_radial, n_shank, None,
                                                    nose_layout="fan"))
        assert q["max_aspect"] < 3.0
        # the smallest cells are at the flat: r_m / n_radial wide
        assert q["min_altitude"] > 0.3 * prof.meplat_radius / n_radial
    # half the nose cells: twice as tall, the aspect ratio about doubles
    prof = mesh.ogive_profile(D, L, CRH, 0.25 * D / 8)
    q = mesh.mesh_quality(mesh.ogive_projectile(D, L, CRH, 8, 84, prof.nose_cells(8) // 2))
    assert q["max_aspect"] < 6.0


def test_ogive_nose_stations_graded_towards_tip():
    prof = mesh.ogive_profile(D, L, CRH, 0.4e-3)
    zeta = prof.nose_stations(30)
    dz = np.diff(zeta)
    assert np.all(dz > 0.0) and np.all(np.diff(dz) > -1e-15)   # growing away from the tip
    # equal height-to-width ratio: dz / R at mid-cell nearly constant
    ratio = dz / prof.radius_at(0.5 * (zeta[1:] + zeta[:-1]))
    assert ratio.max() / ratio.min() < 1.05


def test_ogive_nose_up_radial_grading_and_particles():
    z_tip = 0.1
    up = mesh.ogive_projectile(D, L, CRH, 6, 30, 20, z_tip=z_tip, nose_down=False,
                               nose_layout="fan")
    down = mesh.ogive_projectile(D, L, CRH, 6, 30, 20, z_tip=z_tip, nose_layout="fan")
    assert_valid(up)
    assert up.x[:, 1].max() == z_tip
    assert mesh.ring_volume(up) == pytest.approx(mesh.ring_volume(down), rel=1e-12)
    assert np.allclose(np.sort(up.x[:, 1]), np.sort(2.0 * z_tip - down.x[:, 1]), atol=1e-15)

    graded = mesh.ogive_projectile(D, L, CRH, 6, 30, 20, radial_grading=3.0, nose_layout="fan")
    assert_valid(graded)
    base = graded.x[np.isclose(graded.x[:, 1], graded.x[:, 1].max(), atol=1e-15)]
    w = np.diff(np.unique(base[:, 0]))
    assert w[-1] / w[0] == pytest.approx(3.0, rel=1e-12)
    assert mesh.ring_volume(graded) == pytest.approx(mesh.ring_volume(down), rel=1e-12)

    parts = mesh.ogive_projectile_particles(D, L, CRH, 6, 30, 20, z_tip=z_tip, nose_layout="fan")
    assert parts.n_particles == 6 * 50
    assert np.all(parts.area > 0.0)
    assert parts.ring_volume.sum() == pytest.approx(mesh.ring_volume(down), rel=1e-12)
    assert np.all(parts.x[:, 0] > 0.0) and parts.x[:, 1].min() > z_tip


def test_ogive_rejects_bad_geometry():
    with pytest.raises(ValueError, match="shorter than its nose"):
        mesh.ogive_projectile(D, 10e-3, CRH, 4, 5, 5, nose_layout="fan")
    with pytest.raises(ValueError, match="crh"):
        mesh.ogive_projectile(D, L, 0.3, 4, 5, 5, nose_layout="fan")
    with pytest.raises(ValueError, match="meplat"):
        mesh.ogive_projectile(D, L, CRH, 4, 5, 5, meplat_radius=D, nose_layout="fan")
    # a pure nose (no shank) needs no shank cells
    prof = mesh.ogive_profile(D, L, CRH, 1e-4)
    m = mesh.ogive_projectile(D, prof.nose_length, CRH, 4, 0, 10, nose_layout="fan")
    assert m.n_elements == 4 * 4 * 10
    assert_valid(m)


# -- graded plate -----------------------------------------------------------

def test_geometric_ratio_reproduces_the_total():
    for first, total, n in [(1.0, 30.0, 10), (0.5e-3, 0.13, 20), (1.0, 5.0, 5), (1.0, 3.0, 4)]:
        q = mesh.geometric_ratio(first, total, n)
        assert first * np.sum(q ** np.arange(n)) == pytest.approx(total, rel=1e-13)
        if q != 1.0:
            assert first * (q ** n - 1.0) / (q - 1.0) == pytest.approx(total, rel=1e-10)
    assert mesh.geometric_ratio(1.0, 5.0, 5) == pytest.approx(1.0, abs=1e-14)
    assert mesh.geometric_ratio(1.0, 3.0, 4) < 1.0
    with pytest.raises(ValueError, match="cannot fit"):
        mesh.geometric_ratio(2.0, 1.0, 3)


def test_plate_grading_and_volume():
    radius, thickness, z_top = 0.152, 26.3e-3, -1e-4
    r_fine, n_fine, n_coarse, n_t = 16e-3, 24, 20, 30
    m = mesh.plate(radius, thickness, n_t, r_fine, n_fine, n_coarse, z_top=z_top)
    assert m.n_elements == 4 * (n_fine + n_coarse) * n_t
    assert m.n_nodes == (n_fine + n_coarse + 1) * (n_t + 1) + (n_fine + n_coarse) * n_t
    assert_valid(m)
    assert mesh.ring_volume(m) == pytest.approx(np.pi * radius ** 2 * thickness, rel=1e-13)
    assert m.x[:, 1].min() == pytest.approx(z_top - thickness, rel=1e-15)
    assert m.x[:, 1].max() == z_top
    # fine zone uniform, first coarse cell as wide, growth ratio to the rim
    # (the top face holds the cell corners only)
    edges = np.unique(m.x[np.isclose(m.x[:, 1], z_top, rtol=0.0, atol=1e-15), 0])
    assert len(edges) == n_fine + n_coarse + 1
    w = np.diff(edges)
    h = r_fine / n_fine
    assert np.allclose(w[:n_fine + 1], h, rtol=1e-10, atol=0.0)
    q = mesh.plate_growth_ratio(radius, r_fine, n_fine, n_coarse)
    assert q > 1.0
    assert np.allclose(w[n_fine + 1:] / w[n_fine:-1], q, rtol=1e-9, atol=0.0)
    assert r_fine + h * (q ** n_coarse - 1.0) / (q - 1.0) == pytest.approx(radius, rel=1e-12)
    assert edges[-1] == radius
    # aspect ratio: crossed a x b cells give 2 max(a/b, b/a)
    dz = thickness / n_t
    q_mesh = mesh.mesh_quality(m)
    assert q_mesh["max_aspect"] == pytest.approx(2.0 * max(w.max() / dz, dz / w.min()), rel=1e-9)


def test_plate_particles_and_limits():
    p = mesh.plate_particles(0.1, 0.02, 10, 0.02, 10, 8, z_top=0.0)
    assert p.n_particles == 18 * 10
    assert p.ring_volume.sum() == pytest.approx(np.pi * 0.1 ** 2 * 0.02, rel=1e-13)
    assert np.all(p.x[:, 1] < 0.0) and np.all(p.x[:, 1] > -0.02)
    uniform = mesh.plate(0.05, 0.01, 4, 0.05, 10, 0)          # fine all the way
    assert mesh.plate_growth_ratio(0.05, 0.05, 10, 0) == 1.0
    assert mesh.ring_volume(uniform) == pytest.approx(np.pi * 0.05 ** 2 * 0.01, rel=1e-13)
    with pytest.raises(ValueError, match="n_coarse"):
        mesh.plate(0.1, 0.01, 4, 0.05, 10, 0)
    with pytest.raises(ValueError, match="r_fine"):
        mesh.plate(0.1, 0.01, 4, 0.2, 10, 5)


# -- gmsh import ------------------------------------------------------------

def write_msh(path, points, cells, fmt="gmsh22"):
    """A .msh file written by meshio (points (n, 2) padded with z = 0)."""
    import meshio

    points = np.column_stack([points, np.zeros(len(points))])
    cell_data = {"gmsh:physical": [np.ones(len(c[1]), dtype=int) for c in cells],
                 "gmsh:geometrical": [np.ones(len(c[1]), dtype=int) for c in cells]}
    meshio.write(path, meshio.Mesh(points, cells, cell_data=cell_data), file_format=fmt,
                 binary=False)
    return path


def test_read_gmsh_round_trip(tmp_path):
    pytest.importorskip("meshio")
    ref = mesh.ogive_projectile(D, L, CRH, 3, 8, 6, z_tip=2e-3, nose_layout="fan")
    conn = ref.conn.copy()
    conn[::3] = conn[::3][:, [0, 2, 1]]                   # a third clockwise in the file
    # in millimetres, with a stray node no triangle uses and a boundary line
    points = np.vstack([ref.x * 1e3, [[50.0, 50.0]]])
    path = write_msh(tmp_path / "ogive.msh", points,
                     [("line", np.array([[0, 1]])), ("triangle", conn)])
    m = mesh.read_gmsh(path, scale=1e-3)
    assert m.n_nodes == ref.n_nodes and m.n_elements == ref.n_elements
    assert np.allclose(m.x, ref.x, rtol=1e-14, atol=1e-18)
    assert np.array_equal(m.conn, ref.conn)                # counter-clockwise again
    assert np.all(mesh.triangle_areas(m) > 0.0)
    assert mesh.ring_volume(m) == pytest.approx(mesh.ring_volume(ref), rel=1e-13)

    # gmsh 4.1 with the unused node first: renumbered, order kept
    pts = np.array([[9.0, 9.0], [0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    tri = np.array([[1, 3, 2], [1, 3, 4]])                 # clockwise, counter-clockwise
    import meshio
    meshio.write(tmp_path / "square.msh",
                 meshio.Mesh(np.column_stack([pts, np.zeros(5)]), [("triangle", tri)]),
                 file_format="gmsh", binary=False)
    sq = mesh.read_gmsh(tmp_path / "square.msh")
    assert np.array_equal(sq.x, pts[1:])
    assert np.array_equal(sq.conn, [[0, 1, 2], [0, 2, 3]])
    assert mesh.ring_volume(sq) == pytest.approx(np.pi, rel=1e-14)


def test_read_gmsh_errors(tmp_path):
    pytest.importorskip("meshio")
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    lines = write_msh(tmp_path / "lines.msh", square, [("line", np.array([[0, 1], [1, 2]]))])
    with pytest.raises(ValueError, match=r"lines\.msh.*expected a 2D mesh of 3-node triangles"):
        mesh.read_gmsh(lines)
    left = write_msh(tmp_path / "left.msh", square - [0.5, 0.0],
                     [("triangle", np.array([[0, 1, 2], [0, 2, 3]]))])
    with pytest.raises(ValueError, match=r"left\.msh.*r < 0"):
        mesh.read_gmsh(left)
    flat = write_msh(tmp_path / "flat.msh", np.vstack([square, [[2.0, 0.0]]]),
                     [("triangle", np.array([[0, 1, 2], [0, 1, 4]]))])
    with pytest.raises(ValueError, match=r"flat\.msh.*degenerate"):
        mesh.read_gmsh(flat)
    junk = tmp_path / "junk.msh"
    junk.write_text("not a mesh\n")
    with pytest.raises(ValueError, match=r"junk\.msh.*cannot be read"):
        mesh.read_gmsh(junk)
    # round-off on the axis is forgiven and snapped to r = 0
    near = write_msh(tmp_path / "near.msh", square - [1e-17, 0.0],
                     [("triangle", np.array([[0, 1, 2], [0, 2, 3]]))])
    m = mesh.read_gmsh(near)
    assert m.x[:, 0].min() == 0.0


# -- ogive-nose projectile, cap nose (the default) ----------------------------

def min_angles(m):
    """Smallest interior angle [deg] of each triangle."""
    p = m.x[m.conn]
    out = []
    for k in range(3):
        u, v = p[:, (k + 1) % 3] - p[:, k], p[:, (k + 2) % 3] - p[:, k]
        out.append(np.degrees(np.arctan2(np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]),
                                         np.sum(u * v, axis=1))))
    return np.min(out, axis=0)


def boundary_ring_volume(m):
    """Volume of revolution of the closed outline (the boundary edges,
    counter-clockwise): (pi/3) sum (r1 + r2)(r1 z2 - r2 z1)."""
    e = m.x[mesh.boundary_edges(m.conn)]
    r1, z1, r2, z2 = e[:, 0, 0], e[:, 0, 1], e[:, 1, 0], e[:, 1, 1]
    return np.pi / 3.0 * np.sum((r1 + r2) * (r1 * z2 - r2 * z1))


def shank_quality(m, z_shoulder):
    shank = m.x[m.conn, 1].min(axis=1) >= z_shoulder - 1e-12
    return mesh.mesh_quality(mesh.Mesh(x=m.x, conn=m.conn[shank]))


def test_ogive_cap_validation_projectile_quality():
    # D = 12.9 mm, L = 88.9 mm, crh 3, 8 cells across, 84 shank cells of ~0.8 mm
    m = mesh.ogive_projectile(D, L, CRH, 8, 84, None)
    assert_valid(m)
    prof = mesh.ogive_profile(D, L, CRH, 0.5 * D / 8)         # the default flat: one cell
    a, b, c = mesh._cap_counts(prof, 8, None)
    assert (a, b) == (4, 4)
    assert m.n_elements == 4 * (a * b + 8 * c + 8 * 84)
    q = mesh.mesh_quality(m)
    qs = shank_quality(m, prof.meplat_x)
    assert qs["min_altitude"] == pytest.approx(0.5 * 0.5 * D / 8, rel=0.01)
    # no nose cell much smaller than the shank's: the time step is kept
    assert q["min_altitude"] >= qs["min_altitude"] / 3.0
    assert q["max_aspect"] < 6.0
    # smallest interior angle (at the edge of the flat): 16.7 degrees
    assert min_angles(m).min() > 15.0
    # the fan layout, for comparison: tip cells ~20 times thinner
    fan = mesh.ogive_projectile(D, L, CRH, 8, 84, None, nose_layout="fan")
    assert mesh.mesh_quality(fan)["min_altitude"] < q["min_altitude"] / 5.0


def test_ogive_cap_boundary_on_profile_and_volume():
    z_tip = -2e-3
    for crh, n_radial, n_shank in [(CRH, 8, 84), (CRH, 3, 30), (1.0, 6, 40), (6.0, 4, 20)]:
        m = mesh.ogive_projectile(D, L, crh, n_radial, n_shank, None, z_tip=z_tip)
        assert_valid(m)
        prof = mesh.ogive_profile(D, L, crh, 0.5 * D / n_radial)
        s = crh * D
        nodes = np.unique(mesh.boundary_edges(m.conn))
        r, z = m.x[nodes, 0], m.x[nodes, 1]
        zeta = z - z_tip
        top = m.x[:, 1].max()
        assert top == pytest.approx(z_tip + prof.body_length, rel=1e-14)
        on_axis = r == 0.0
        on_flat = zeta == 0.0
        on_base = z == top
        on_side = ~(on_axis | on_flat | on_base)
        # the flat is a single cell, the outline on the exact profile
        assert np.array_equal(np.sort(r[on_flat]), [0.0, prof.meplat_radius])
        assert np.allclose(r[on_side], prof.radius_at(zeta[on_side]), rtol=0.0, atol=1e-12 * D)
        # the mesh fills its outline exactly, short of the body by the chord error:
        # each ogive chord of length l cuts a circular segment S^2 (t - sin t) / 2,
        # t = 2 asin(l / 2S), from the section, at a radius below the chord's largest
        v_mesh = mesh.ring_volume(m)
        assert v_mesh == pytest.approx(boundary_ring_volume(m), rel=1e-12)
        e = m.x[mesh.boundary_edges(m.conn)]
        nose = ((e[:, :, 0].min(axis=1) > 0.0) & (e[:, :, 1].max(axis=1) > z_tip)
                & (e[:, :, 1].max(axis=1) <= z_tip + prof.meplat_x * (1.0 + 1e-12)))
        chord = np.linalg.norm(e[nose, 1] - e[nose, 0], axis=1)
        t = 2.0 * np.arcsin(chord / (2.0 * s))
        bound = np.sum(2.0 * np.pi * e[nose, :, 0].max(axis=1) * s * s * (t - np.sin(t)) / 2.0)
        deficit = prof.volume - v_mesh
        assert 0.0 <= deficit <= bound
        assert deficit / prof.volume < 1e-3
        # the shank is the plain n_radial x n_shank grid
        qs = shank_quality(m, z_tip + prof.meplat_x)
        assert qs["n_elements"] == 4 * n_radial * n_shank
        assert mesh.mesh_quality(m)["min_altitude"] >= qs["min_altitude"] / 3.0


def test_ogive_cap_shapes_and_counts():
    # blunt to slender noses, coarse to fine: never folded, nose cells near shank size
    for crh in (0.5, 1.0, 3.0, 6.0):
        for n_radial in (2, 4, 8, 12):
            m = mesh.ogive_projectile(D, 5 * D, crh, n_radial, 6 * n_radial, None)
            assert_valid(m)
            prof = mesh.ogive_profile(D, 5 * D, crh, 0.5 * D / n_radial)
            qs = shank_quality(m, prof.meplat_x)
            assert mesh.mesh_quality(m)["min_altitude"] >= qs["min_altitude"] / 4.0
            assert min_angles(m).min() > 12.0
    # n_axial_nose: the cells along the axis in the nose
    m = mesh.ogive_projectile(D, L, CRH, 6, 40, 30)
    on_axis = np.sort(m.x[m.x[:, 0] == 0.0, 1])
    prof = mesh.ogive_profile(D, L, CRH, 0.5 * D / 6)
    assert np.sum(on_axis < prof.meplat_x * (1.0 - 1e-12)) == 30
    a, b, c = mesh._cap_counts(prof, 6, 30)
    assert m.n_elements == 4 * (a * b + 6 * c + 6 * 40)
    # a pure nose, no shank
    m = mesh.ogive_projectile(D, prof.nose_length, CRH, 4, 0, None)
    assert_valid(m)


def test_ogive_cap_nose_up_grading_and_particles():
    z_tip = 0.1
    down = mesh.ogive_projectile(D, L, CRH, 6, 30, None, z_tip=z_tip)
    up = mesh.ogive_projectile(D, L, CRH, 6, 30, None, z_tip=z_tip, nose_down=False)
    assert_valid(up)
    assert up.x[:, 1].max() == z_tip
    assert mesh.ring_volume(up) == pytest.approx(mesh.ring_volume(down), rel=1e-12)
    assert np.allclose(np.sort(up.x[:, 1]), np.sort(2.0 * z_tip - down.x[:, 1]), atol=1e-15)

    graded = mesh.ogive_projectile(D, L, CRH, 6, 30, None, radial_grading=3.0)
    assert_valid(graded)
    base = graded.x[np.isclose(graded.x[:, 1], graded.x[:, 1].max(), atol=1e-15)]
    w = np.diff(np.unique(base[:, 0]))
    assert w[-1] / w[0] == pytest.approx(3.0, rel=1e-12)

    parts = mesh.ogive_projectile_particles(D, L, CRH, 6, 30, None, z_tip=z_tip)
    assert parts.n_particles == down.n_elements // 4
    assert np.all(parts.area > 0.0)
    # Pappus: the particles' ring volumes are the cells', which the triangles tile
    assert parts.ring_volume.sum() == pytest.approx(mesh.ring_volume(down), rel=1e-12)
    cells = mesh.triangle_areas(down).reshape(-1, 4).sum(axis=1)
    assert np.allclose(parts.area, cells, rtol=1e-12, atol=0.0)
    assert np.all(parts.x[:, 0] > 0.0) and parts.x[:, 1].min() > z_tip
    up_parts = mesh.ogive_projectile_particles(D, L, CRH, 6, 30, None, z_tip=z_tip,
                                               nose_down=False)
    assert up_parts.ring_volume.sum() == pytest.approx(parts.ring_volume.sum(), rel=1e-12)


def test_ogive_cap_rejects_bad_arguments():
    with pytest.raises(ValueError, match="nose_layout"):
        mesh.ogive_projectile(D, L, CRH, 8, 84, None, nose_layout="cone")
    with pytest.raises(ValueError, match="n_radial must be >= 2"):
        mesh.ogive_projectile(D, L, CRH, 1, 84, None)
    with pytest.raises(ValueError, match="n_axial_nose must be >= 5"):
        mesh.ogive_projectile(D, L, CRH, 8, 84, 4)
    with pytest.raises(ValueError, match="meplat"):
        mesh.ogive_projectile(D, L, CRH, 8, 84, None, meplat_radius=D)
