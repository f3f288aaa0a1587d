"""Total-Lagrangian SPH kernels (fsph_tlsph) through the API's tlsph_*
entry points: reference lists with mirror images, corrected gradient,
deformation gradient, first Piola-Kirchhoff stress and ring forces.

Lattices are square with spacing d, planar area d^2 and h = 1.3 d (fsph's
alpha_h), as fsph's particles are made."""

import numpy as np
import pytest

from fsph._core import fsph_api as api
from fsph.layouts import status_code

ALPHA_H = 1.3
OK = status_code("ok")
BAD_INPUT = status_code("bad_input")
INVERTED = status_code("inverted_element")


def lattice(r0, r1, z0, z1, d, jitter=0.0, seed=1):
    """Particle centres of the square cells of side d filling [r0, r1] x
    [z0, z1], optionally moved by up to jitter*d in each coordinate; also
    the column and row index of each particle."""
    rs = np.arange(r0 + d / 2, r1 - 1e-9 * d, d)
    zs = np.arange(z0 + d / 2, z1 - 1e-9 * d, d)
    ir, iz = np.meshgrid(np.arange(len(rs)), np.arange(len(zs)), indexing="ij")
    x0 = np.vstack([rs[ir.ravel()], zs[iz.ravel()]])
    if jitter:
        x0 = x0 + jitter * d * np.random.default_rng(seed).uniform(-1, 1, x0.shape)
    return np.asfortranarray(x0), ir.ravel(), iz.ravel()


def reference(x0, d, stencil="full"):
    """Lists, kernel gradients and correction of particles at x0, on the
    full support or the selected-particle stencil."""
    n = x0.shape[1]
    h = np.full(n, ALPHA_H * d)
    area = np.full(n, d * d)
    nnz, ierr, ifault = api.tlsph_neighbour_count(x0, h)
    assert ierr == OK
    ptr, nbr, ierr, ifault = api.tlsph_neighbours(nnz, x0, h)
    assert ierr == OK
    if stencil == "selected":
        keep = api.tlsph_stencil(x0, ptr, nbr).astype(bool)
        counts = np.add.reduceat(keep.astype(int), ptr[:-1] - 1)
        ptr = np.concatenate([[1], 1 + np.cumsum(counts)]).astype(ptr.dtype)
        nbr = np.ascontiguousarray(nbr[keep])
    grad_w = api.tlsph_kernel_gradients(x0, h, ptr, nbr)
    bmat, eig_min, ierr, ifault = api.tlsph_correction(x0, area, ptr, nbr, grad_w)
    return dict(x0=x0, h=h, area=area, ptr=ptr, nbr=nbr, grad_w=grad_w, bmat=bmat,
                eig_min=eig_min, ierr=ierr, ifault=ifault)


def deformation(ref, x):
    """In-plane F (2, 2, n), F_tt, J and the status at positions x."""
    fmat, f_tt, jac, ierr, ifault = api.tlsph_deformation(
        ref["x0"], np.asfortranarray(x), ref["h"], ref["area"], ref["ptr"], ref["nbr"],
        ref["grad_w"], ref["bmat"])
    return fmat, f_tt, jac, ierr, ifault


def scalar_gradient(ref, f):
    return api.tlsph_scalar_gradient(ref["area"], ref["ptr"], ref["nbr"], ref["grad_w"], ref["bmat"],
                                     np.asarray(f, dtype=float))


def ring_forces(ref, fmat, f_tt, sig):
    p, p_tt = api.tlsph_piola(fmat, f_tt, np.asfortranarray(sig))
    return api.tlsph_ring_forces(ref["x0"], ref["h"], ref["area"], ref["ptr"], ref["nbr"], ref["grad_w"],
                                 ref["bmat"], p, p_tt)


def test_reference_lists_match_brute_force():
    """Every pair within the support 2 h and every mirror image (-R_j, Z_j)
    within it, each row once, and the lists symmetric: j in i's row iff i in
    j's, -j in i's iff -i in j's."""
    d = 0.1
    x0, _, _ = lattice(0.0, 0.7, 0.0, 0.8, d, jitter=0.3)
    ref = reference(x0, d)
    ptr, nbr = ref["ptr"], ref["nbr"]
    n = x0.shape[1]
    reach2 = (2.0 * ALPHA_H * d) ** 2
    rows = []
    for i in range(n):
        row = nbr[ptr[i] - 1:ptr[i + 1] - 1]
        assert len(set(row)) == len(row)
        dist2 = ((x0 - x0[:, [i]]) ** 2).sum(axis=0)
        image2 = (x0[0] + x0[0, i]) ** 2 + (x0[1] - x0[1, i]) ** 2
        expected = {j + 1 for j in range(n) if j != i and dist2[j] < reach2}
        expected |= {-(j + 1) for j in range(n) if image2[j] < reach2}
        assert set(row) == expected
        rows.append(set(row))
    for i in range(n):
        for e in rows[i]:
            assert (i + 1 if e > 0 else -(i + 1)) in rows[abs(e) - 1]
    # the particles next to the axis see their own image
    assert all(-(i + 1) in rows[i] for i in range(n) if x0[0, i] < ALPHA_H * d)


def test_gradient_converges():
    """f = x^3 + y^3 + 2xy on [1, 2]^2 (r as x, z as y, no mirror images):
    the RMS error of df/dX over all particles falls as d^1.45 (the first-
    order edges are a fraction d of the particles), over the interior
    particles (whose neighbours all have a full support) as d^2.00.
    Measured RMS errors at d = 0.1, 0.05, 0.025, 0.0125: all 0.476, 0.174,
    0.0625, 0.0223; interior -, 5.84e-3, 1.46e-3, 3.65e-4."""
    spacings = [0.1, 0.05, 0.025, 0.0125]
    rms_all, rms_inner = [], []
    for d in spacings:
        x0, _, _ = lattice(1.0, 2.0, 1.0, 2.0, d)
        ref = reference(x0, d)
        assert ref["ierr"] == OK
        x, y = x0
        g = scalar_gradient(ref, x ** 3 + y ** 3 + 2 * x * y)
        exact = np.vstack([3 * x ** 2 + 2 * y, 3 * y ** 2 + 2 * x])
        err2 = ((g - exact) ** 2).sum(axis=0)
        margin = 2 * 2 * ALPHA_H * d
        inner = (x > 1 + margin) & (x < 2 - margin) & (y > 1 + margin) & (y < 2 - margin)
        rms_all.append(np.sqrt(err2.mean()))
        rms_inner.append(np.sqrt(err2[inner].mean()) if inner.any() else np.nan)
    order_all = np.diff(np.log(rms_all)) / np.diff(np.log(spacings))
    order_inner = np.diff(np.log(rms_inner[1:])) / np.diff(np.log(spacings[1:]))
    assert np.all(order_all >= 1.0), order_all
    assert np.all(order_inner >= 1.9), order_inner


def test_gradient_next_to_the_axis_is_second_order():
    """With the mirror images and planar areas, the corrected gradient of a
    smooth axisymmetric field (f = Z^3 + R^2 Z + R^2, even in R) at the two
    columns next to the axis converges at second order: RMS error 0.022,
    0.0055, 0.0014 at d = 0.1, 0.05, 0.025 (with ring volumes as weights it
    was 0.15, 0.076, 0.038: first order)."""
    spacings = [0.1, 0.05, 0.025]
    rms = []
    for d in spacings:
        x0, ir, iz = lattice(0.0, 1.0, 0.0, 1.0, d)
        ref = reference(x0, d)
        assert ref["ierr"] == OK
        r, z = x0
        g = scalar_gradient(ref, z ** 3 + r ** 2 * z + r ** 2)
        exact = np.vstack([2 * r * z + 2 * r, 3 * z ** 2 + r ** 2])
        near = interior(ir, iz, ir.max() + 1, iz.max() + 1, axis=True) & (ir <= 1)
        rms.append(np.sqrt(((g - exact) ** 2).sum(axis=0)[near].mean()))
    order = np.diff(np.log(rms)) / np.diff(np.log(spacings))
    assert rms[0] < 0.03
    assert np.all(order >= 1.9), order


@pytest.mark.parametrize("jitter", [0.0, 0.3])
def test_linear_patch(jitter):
    """A linear displacement u = c + G X: F = I + G at every particle, edges
    and corners included, on a regular and on a jittered lattice; the
    gradient of a linear scalar is exact likewise (measured: 4e-15)."""
    d = 0.1
    x0, _, _ = lattice(1.0, 2.0, 1.0, 2.0, d, jitter=jitter)
    ref = reference(x0, d)
    assert ref["ierr"] == OK
    g = np.array([[0.12, -0.31], [0.27, -0.08]])
    c = np.array([[0.05], [-0.02]])
    fmat, f_tt, jac, ierr, _ = deformation(ref, x0 + c + g @ x0)
    assert ierr == OK
    expected = np.eye(2) + g
    assert np.abs(fmat - expected[:, :, None]).max() < 1e-13
    grad_f = scalar_gradient(ref, 3.0 - 2.0 * x0[0] + 5.0 * x0[1])
    assert np.abs(grad_f - np.array([[-2.0], [5.0]])).max() < 1e-13
    # the hoop stretch is the ring's own r/R; J = det(F) r/R
    r = x0[0] + c[0] + g[0] @ x0
    assert np.allclose(f_tt, r / x0[0], rtol=1e-15, atol=0)
    assert np.allclose(jac, np.linalg.det(expected) * f_tt, rtol=1e-13, atol=0)


def test_rigid_rotation_has_no_strain():
    """A block away from the axis turned by 90 degrees in the meridian plane
    and moved: the in-plane F is the rotation and the Green-Lagrange strain
    (F^T F - I)/2 is zero to round-off (measured 4e-16; F - Q 7e-16) at every particle."""
    d = 0.1
    x0, _, _ = lattice(1.0, 2.0, 1.0, 2.0, d)
    ref = reference(x0, d)
    q = np.array([[0.0, -1.0], [1.0, 0.0]])
    centre = np.array([[1.5], [1.5]])
    x = centre + np.array([[0.2], [-0.7]]) + q @ (x0 - centre)
    fmat, _, _, ierr, _ = deformation(ref, x)
    assert ierr == OK
    assert np.abs(fmat - q[:, :, None]).max() < 1e-13
    strain = 0.5 * (np.einsum("kai,kbi->abi", fmat, fmat) - np.eye(2)[:, :, None])
    assert np.abs(strain).max() < 1e-13


def test_first_piola_is_j_sigma_f_inverse_transpose():
    """P = J sigma F^-T with the 3 x 3 r-z-theta F and the Cauchy stress."""
    rng = np.random.default_rng(3)
    n = 20
    fmat = np.eye(2)[:, :, None] + 0.2 * rng.uniform(-1, 1, (2, 2, n))
    f_tt = 1.0 + 0.2 * rng.uniform(-1, 1, n)
    sig = rng.uniform(-1e9, 1e9, (4, n))
    p, p_tt = api.tlsph_piola(np.asfortranarray(fmat), f_tt, np.asfortranarray(sig))
    for i in range(n):
        f3 = np.zeros((3, 3))
        f3[:2, :2] = fmat[:, :, i]
        f3[2, 2] = f_tt[i]
        s3 = np.array([[sig[0, i], sig[2, i], 0], [sig[2, i], sig[1, i], 0], [0, 0, sig[3, i]]])
        p3 = np.linalg.det(f3) * s3 @ np.linalg.inv(f3).T
        assert np.allclose(p[:, :, i], p3[:2, :2], rtol=1e-12, atol=1e-12 * 1e9)
        assert np.isclose(p_tt[i], p3[2, 2], rtol=1e-12)


@pytest.mark.parametrize("stencil", ["full", "selected"])
@pytest.mark.parametrize("r0", [1.0, 0.0])
def test_pair_forces_conserve_momentum(r0, stencil):
    """Arbitrary stresses and a deformed state, away from the axis (r0 = 1)
    and touching it (r0 = 0, with mirror images): the pair terms are equal
    and opposite (the image pairs (i, j') and (j, i') too), so the sum of the
    forces' axial components and the sum of their radial components without
    the hoop term vanish to round-off (measured 2e-17 of the gross sum); the
    hoop term alone changes the radial momentum. On the full support and on
    the selected stencil (made symmetric for this)."""
    d = 0.1
    x0, _, _ = lattice(r0, r0 + 0.8, 0.0, 0.9, d, jitter=0.2)
    ref = reference(x0, d, stencil)
    assert ref["ierr"] == OK
    n = x0.shape[1]
    rng = np.random.default_rng(7)
    fmat = np.asfortranarray(np.eye(2)[:, :, None] + 0.1 * rng.uniform(-1, 1, (2, 2, n)))
    f_tt = 1.0 + 0.1 * rng.uniform(-1, 1, n)
    sig = rng.uniform(-1e9, 1e9, (4, n))
    force, hoop = ring_forces(ref, fmat, f_tt, sig)
    pair_r = force[0] - hoop
    assert abs(force[1].sum()) < 1e-14 * np.abs(force[1]).sum()
    assert abs(pair_r.sum()) < 1e-14 * np.abs(pair_r).sum()
    assert abs(force[0].sum() - hoop.sum()) < 1e-14 * np.abs(force[0]).sum()


def interior(ir, iz, nr, nz, axis=False):
    """Particles whose neighbours all have a full support (4 spacings from an
    edge, with h = 1.3 d); at the axis the mirror images complete it."""
    deep = 4
    ok_r = (ir <= nr - 1 - deep) if axis else ((ir >= deep) & (ir <= nr - 1 - deep))
    return ok_r & (iz >= deep) & (iz <= nz - 1 - deep)


@pytest.mark.parametrize("sig_zz", [-1.0, -2.5])
def test_uniform_stress_in_a_ring_is_in_equilibrium(sig_zz):
    """A ring of square cross-section [1, 2] x [0, 1] under a uniform stress
    with sigma_rr = sigma_tt = -1 (Pa) and sigma_zz as given, sigma_rz = 0 (an
    equilibrium state in a ring): every interior particle feels no force to
    round-off, measured against the size of its pair terms, 2 pi A |sigma| R/d
    (measured 2e-15 of it, 2e-13 of the hoop force 2 pi A |sigma_tt|). The
    hoop term is needed: the pair terms alone leave minus the hoop force."""
    d = 0.05
    x0, ir, iz = lattice(1.0, 2.0, 0.0, 1.0, d)
    nr, nz = ir.max() + 1, iz.max() + 1
    ref = reference(x0, d)
    n = x0.shape[1]
    sig = np.zeros((4, n))
    sig[[0, 3]] = -1.0
    sig[1] = sig_zz
    fmat = np.asfortranarray(np.repeat(np.eye(2)[:, :, None], n, axis=2))
    force, hoop = ring_forces(ref, fmat, np.ones(n), sig)
    scale = 2 * np.pi * d * d
    inner = interior(ir, iz, nr, nz)
    assert inner.sum() > 50
    pair_size = scale * np.abs(sig).max() * x0[0].max() / d
    assert np.abs(force[:, inner]).max() < 1e-13 * pair_size
    assert np.allclose(force[0, inner] - hoop[inner], -hoop[inner], rtol=1e-12)
    assert np.allclose(hoop, scale * 1.0)


def test_uniform_pressure_at_the_axis_is_in_equilibrium():
    """A disc [0, 1] x [0, 1] touching the axis under a uniform pressure:
    with the mirror images, the particles next to the axis feel no force
    either (measured 3e-15 of 2 pi A p). Each particle's stress acts along
    its own kernel gradient towards the other's image; with the image's
    stress mirrored instead (the exact derivative of the discrete strain
    energy) the first column felt 0.55 and the second 0.054 of the hoop
    force. Measured against the pair terms' size 2 pi A |sigma| R/d."""
    d = 0.05
    x0, ir, iz = lattice(0.0, 1.0, 0.0, 1.0, d)
    nr, nz = ir.max() + 1, iz.max() + 1
    ref = reference(x0, d)
    assert ref["ierr"] == OK
    n = x0.shape[1]
    sig = np.zeros((4, n))
    sig[[0, 1, 3]] = -1.0
    fmat = np.asfortranarray(np.repeat(np.eye(2)[:, :, None], n, axis=2))
    force, _ = ring_forces(ref, fmat, np.ones(n), sig)
    inner = interior(ir, iz, nr, nz, axis=True)
    assert inner[ir == 0].sum() > 5
    pair_size = 2 * np.pi * d * d * x0[0].max() / d
    assert np.abs(force[:, inner]).max() < 1e-13 * pair_size
    assert np.abs(force[:, inner & (ir <= 1)]).max() < 1e-13 * 2 * np.pi * d * d


@pytest.mark.parametrize("jitter", [0.0, 0.25])
def test_axis_patch(jitter):
    """A lattice touching r = 0, with mirror images: u_r = a R, u_z = b + c Z
    gives F = diag(1 + a, 1 + c) and F_tt = 1 + a at every particle, those
    next to the axis included (measured 1e-15), and the gradient of a
    scalar linear in Z is exact."""
    d = 0.05
    x0, ir, _ = lattice(0.0, 0.5, 0.0, 0.5, d, jitter=jitter)
    ref = reference(x0, d)
    assert ref["ierr"] == OK
    a, b, c = 0.07, -0.01, -0.12
    x = np.vstack([(1 + a) * x0[0], x0[1] + b + c * x0[1]])
    fmat, f_tt, jac, ierr, _ = deformation(ref, x)
    assert ierr == OK
    expected = np.diag([1 + a, 1 + c])
    next_to_axis = ir <= 1
    assert np.abs(fmat - expected[:, :, None])[:, :, next_to_axis].max() < 1e-13
    assert np.abs(fmat - expected[:, :, None]).max() < 1e-13
    assert np.allclose(f_tt, 1 + a, rtol=1e-14, atol=0)
    assert np.allclose(jac, (1 + a) ** 2 * (1 + c), rtol=1e-13, atol=0)
    grad_f = scalar_gradient(ref, 2.0 + 3.0 * x0[1])
    assert np.abs(grad_f - np.array([[0.0], [3.0]])).max() < 1e-13


def test_hoop_stretch_on_the_axis_is_dr_dR():
    """A particle standing on the axis (R = 0): r/R has the limit dr/dR,
    which the in-plane F gives; a radial field u_r = a R then has F_tt = 1 + a
    there as elsewhere."""
    d = 0.05
    x0, ir, _ = lattice(-0.5 * d, 0.5, 0.0, 0.5, d)
    assert np.all(x0[0][ir == 0] == 0.0)
    ref = reference(x0, d)
    assert ref["ierr"] == OK
    a = 0.05
    x = np.vstack([(1 + a) * x0[0], x0[1]])
    _, f_tt, _, ierr, _ = deformation(ref, x)
    assert ierr == OK
    assert np.allclose(f_tt, 1 + a, rtol=1e-13, atol=0)


def test_singular_correction_is_reported():
    """The smallest eigenvalue of sum_j A_j grad W (x) (X_j - X_i) is 1.01
    inside a lattice, 0.27 at its corners and 0 for a particle alone or a
    single row: those are refused (status bad_input, the lowest such index),
    with B = 0, not clamped."""
    d = 0.1
    x0, ir, iz = lattice(1.0, 2.0, 1.0, 2.0, d)
    ref = reference(x0, d)
    assert ref["ierr"] == OK and ref["ifault"] == 0
    corner = (ir == 0) & (iz == 0)
    assert 0.25 < ref["eig_min"][corner][0] < 0.3
    assert 0.99 < ref["eig_min"].max() < 1.02
    # a lattice and a particle far from it
    lone = np.asfortranarray(np.hstack([x0, [[5.0], [5.0]]]))
    ref = reference(lone, d)
    n = lone.shape[1]
    assert ref["ierr"] == BAD_INPUT and ref["ifault"] == n
    assert ref["eig_min"][n - 1] == 0.0
    assert np.all(ref["bmat"][:, :, n - 1] == 0.0)
    assert np.all(ref["eig_min"][:n - 1] > 0.25)
    # a single row of particles spans one direction only
    row, _, _ = lattice(1.0, 1.0 + d, 1.0, 2.0, d)
    ref = reference(row, d)
    assert ref["ierr"] == BAD_INPUT and ref["ifault"] == 1


def test_inverted_particle_is_reported():
    """A reflected configuration (det F < 0) is reported as an inverted
    particle: status inverted_element, the index negative (a particle)."""
    d = 0.1
    x0, _, _ = lattice(1.0, 2.0, 1.0, 2.0, d)
    ref = reference(x0, d)
    x = np.vstack([x0[0], 3.0 - x0[1]])
    _, _, jac, ierr, ifault = deformation(ref, x)
    assert ierr == INVERTED and ifault == -1
    assert np.all(jac < 0)


def test_bad_reference_input_is_reported():
    """A particle at R < 0 or with h <= 0 is refused with its index."""
    x0 = np.asfortranarray([[0.5, -0.1, 0.7], [0.0, 0.0, 0.0]])
    nnz, ierr, ifault = api.tlsph_neighbour_count(x0, np.full(3, 0.2))
    assert ierr == BAD_INPUT and ifault == 2
    x0 = np.asfortranarray([[0.5, 0.6, 0.7], [0.0, 0.0, 0.0]])
    nnz, ierr, ifault = api.tlsph_neighbour_count(x0, np.array([0.2, 0.2, 0.0]))
    assert ierr == BAD_INPUT and ifault == 3


# ---- the selected-particle stencil (SFPM) ------------------------------------

def test_selected_stencil_is_central_inside_and_symmetric():
    """On a square lattice an interior particle keeps its four nearest
    neighbours (central differences), a particle of the first column its
    own image among them; the stencil is symmetric (j in i's row iff i in
    j's; -j in i's iff -i in j's); boundary rows have at least three
    entries that span the plane."""
    d = 0.1
    x0, ir, iz = lattice(0.0, 1.0, 0.0, 1.2, d)
    ref = reference(x0, d, "selected")
    assert ref["ierr"] == OK
    ptr, nbr = ref["ptr"], ref["nbr"]
    nr, nz = ir.max() + 1, iz.max() + 1
    rows = [set(nbr[ptr[i] - 1:ptr[i + 1] - 1]) for i in range(x0.shape[1])]
    for i, row in enumerate(rows):
        for e in row:
            assert (np.sign(e) * (i + 1)) in rows[abs(e) - 1]
    deep = (ir >= 2) & (ir <= nr - 3) & (iz >= 2) & (iz <= nz - 3)
    for i in np.flatnonzero(deep):
        offsets = sorted(tuple(np.round((x0[:, abs(e) - 1] * [np.sign(e), 1] - x0[:, i]) / d, 9))
                         for e in rows[i])
        assert offsets == [(-1.0, 0.0), (0.0, -1.0), (0.0, 1.0), (1.0, 0.0)], offsets
    first = np.flatnonzero((ir == 0) & (iz >= 2) & (iz <= nz - 3))
    assert all(-(i + 1) in rows[i] for i in first)
    assert min(len(r) for r in rows) >= 3


@pytest.mark.parametrize("jitter", [0.0, 0.3])
def test_selected_stencil_linear_patch(jitter):
    """The corrected gradient on the selected stencil is exact for linear
    fields too, edges and corners included (measured: 1e-14)."""
    d = 0.1
    x0, _, _ = lattice(1.0, 2.0, 1.0, 2.0, d, jitter=jitter)
    ref = reference(x0, d, "selected")
    assert ref["ierr"] == OK
    g = np.array([[0.12, -0.31], [0.27, -0.08]])
    fmat, _, _, ierr, _ = deformation(ref, x0 + g @ x0)
    assert ierr == OK
    assert np.abs(fmat - (np.eye(2) + g)[:, :, None]).max() < 1e-12


def test_selected_stencil_gradient_converges():
    """f = x^3 + y^3 + 2xy on [1, 2]^2: on the selected stencil the RMS error
    of the gradient over all particles falls at least as fast as d (the
    one-sided edges), over the interior at second order (central
    differences). Measured RMS errors at d = 0.1, 0.05, 0.025, 0.0125: all
    0.299, 0.106, 0.0375, 0.0133 (order 1.5; the full support's 0.476,
    0.174, 0.0625, 0.0223); interior 0.0141, 3.54e-3, 8.8e-4, 2.2e-4 (order
    2.0; the full support's 5.84e-3, 1.46e-3, 3.65e-4 from d = 0.05)."""
    spacings = [0.1, 0.05, 0.025, 0.0125]
    rms_all, rms_inner = [], []
    for d in spacings:
        x0, _, _ = lattice(1.0, 2.0, 1.0, 2.0, d)
        ref = reference(x0, d, "selected")
        assert ref["ierr"] == OK
        x, y = x0
        g = scalar_gradient(ref, x ** 3 + y ** 3 + 2 * x * y)
        exact = np.vstack([3 * x ** 2 + 2 * y, 3 * y ** 2 + 2 * x])
        err2 = ((g - exact) ** 2).sum(axis=0)
        inner = (x > 1 + 2 * d) & (x < 2 - 2 * d) & (y > 1 + 2 * d) & (y < 2 - 2 * d)
        rms_all.append(np.sqrt(err2.mean()))
        rms_inner.append(np.sqrt(err2[inner].mean()))
    order_all = np.diff(np.log(rms_all)) / np.diff(np.log(spacings))
    order_inner = np.diff(np.log(rms_inner)) / np.diff(np.log(spacings))
    assert np.all(order_all >= 1.0), order_all
    assert np.all(order_inner >= 1.9), order_inner
