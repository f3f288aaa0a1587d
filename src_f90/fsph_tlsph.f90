!> Total-Lagrangian SPH in r-z (TLSPH): the kernels of the method, pure
!> and over explicit arrays (the solver's cycle does not call them yet).
!> Everything is evaluated on the reference configuration X = (R, Z) of
!> t = 0: the neighbour lists, the kernel gradients and the correction
!> matrices are built once and never change (Wang et al. 2022; the
!> corrected gradient of Randles & Libersky 1996 and Bonet & Lok 1999;
!> docs/method.md, "Total-Lagrangian particles (kernels)").
!>
!> Conventions, as fsph_sph: coordinates (1, 2) = (r, z); particles carry
!> full-ring masses m = 2 pi R rho0 A with A their planar (meridian) area
!> [m^2]; the kernel is fsph_kernel's cubic B-spline with its planar
!> normalisation and the pair smoothing length h_ij = (h_i + h_j)/2;
!> forces are per full ring [N] (m_i dv_i/dt); stresses (rr, zz, rz, tt).
!>
!> Corrected gradient, in the meridian plane with planar areas:
!>   grad0 f_i = B_i sum_j A_j (f_j - f_i) grad0 W_ij,
!>   B_i = [sum_j A_j grad0 W_ij (x) (X_j - X_i)]^-1,
!> grad0 W_ij the gradient of W(|X_i - X_j|) with respect to X_i. The sums
!> are quadratures of integrals over the meridian plane (the kernel is
!> normalised there), whose weights are the planar areas. Ring volumes
!> 2 pi R_j A_j would make the corrected gradient just as exact for linear
!> fields (the correction absorbs any weights) but weight the inner side
!> of the support less than the outer, which spoils the symmetric
!> cancellation that makes the corrected gradient second-order inside a
!> lattice by an error of order h^2/R, first order next to the axis: for
!> f = Z^3 + R^2 Z + R^2 at the two columns next to the axis (h = 1.3
!> spacings, d = 0.1, 0.05, 0.025) the RMS error of the gradient was
!> 0.022, 0.0055, 0.0014 with planar areas and 0.15, 0.076, 0.038 with
!> ring volumes (measured; the planar figures are tested).
!>
!> Mirror images across the axis (ghosts): a particle j whose image
!> (-R_j, Z_j) lies within the support of particle i is an entry -j of i's
!> row (i's own image included). An image carries the odd extension of the
!> meridian fields: position (-R_j, Z_j) and (-r_j, z_j), displacement
!> (-u_r, u_z), a scalar f_j unchanged, the same planar area A_j (the
!> values of a smooth axisymmetric field: u_r and the rz, zr components of
!> a tensor are odd in r, the rest even). With them a particle next to the
!> axis has a full support, and the corrected gradient is exact for the
!> linear fields an axisymmetric body admits there, u_r = a R and
!> u_z = b + c Z. Their forces: see below.
!>
!> Deformation gradient (3 x 3 in r-z-theta, no torsion):
!>   F = [[dr/dR, dr/dZ, 0], [dz/dR, dz/dZ, 0], [0, 0, r/R]],
!> the in-plane block I + grad0 u, the hoop stretch F_tt = r_i/R_i of the
!> particle's own ring (exact for any displacement, not a kernel
!> estimate). On the axis (R_i <= axis_tolerance h_i, a particle standing
!> on r = 0) r/R has the limit dr/dR (r is odd in R), and the in-plane
!> F_rr is used.
!>
!> Momentum, from the weak form in r-z: with dV0 = 2 pi R dA the internal
!> virtual work is 2 pi int (P : grad0 du + P_tt du_r/R) R dA; with the
!> particles as quadrature points (weights 2 pi R_i A_i) and the corrected
!> gradient above for grad0 du, minus its derivative with respect to du_k
!> is the force on particle k:
!>   f_k = 2 pi A_k sum_j A_j (Q_k grad0 W_kj - Q_j grad0 W_jk)
!>         - 2 pi A_k P_tt,k e_r,       Q = R P B [Pa m],
!> the hoop term being -V0_k P_tt,k/R_k e_r with V0_k = 2 pi R_k A_k, and
!> grad0 W_jk = -grad0 W_kj. For one reference density this is eq 14 of
!> the paper (m_i dv_i/dt = sum_j m_i m_j (P_i B_i/rho0_i^2 + P_j
!> B_j/rho0_j^2) grad0 W_ij in the plane) with the ring weights R_i, R_j
!> on each stress. On a uniform lattice a uniform stress with sigma_rr =
!> sigma_tt and sigma_rz = 0 (a state in equilibrium in a ring) gives zero
!> force on every particle whose neighbours all have a full support: there
!> B_j = B_k and B_k sum_j A_j (R_j - R_k) grad0 W_kj = e_r exactly.
!>
!> An image pair takes the same form: the image j' of j acts on k with
!> 2 pi A_k A_j (Q_k grad0 W_kj' - Q_j grad0 W_jk'), each particle's stress
!> along its own kernel gradient towards the other's image (grad0 W_jk' =
!> -S grad0 W_kj', S = diag(-1, 1), so the term is 2 pi A_k A_j (Q_k + Q_j S)
!> grad0 W_kj'). The exact derivative of the discrete strain energy would
!> mirror j's part instead (S Q_j S: the image's reaction reflected back
!> onto k); that form does not keep a uniform pressure in equilibrium next
!> to the axis: the image weights R_j continue |R|, not R, across it, and
!> the particles of the first column felt 0.55 of their hoop force (0.054
!> the second; measured on a square lattice, h = 1.3 spacings). With the
!> form above they feel none (tested), and the pair (k, j') is exactly
!> minus the pair (j, k'): all pair terms, real and image, conserve both
!> components of the momentum, and only the hoop term changes the radial
!> one. Its price: next to the axis the radial image terms are not the
!> derivative of the strain energy, so their work is not the stress power
!> P : dF/dt of the particles, and the time loop must book it (as fsph_sph
!> books the work of its mirror images as heat): in a uniform radial
!> expansion of a disc under a uniform pressure the forces' power fell
!> short of the stress power by 9 % of that of the two columns next to
!> the axis (measured, d = 0.05 on [0, 1]^2); an axial stretch has none.
!>
!> Each loop writes only its own particle's entries and sums its row in
!> list order, so results do not depend on the thread count.
module fsph_tlsph
  use fsph_kinds, only: wp, pi, two_pi, axis_tolerance
  use fsph_kernel, only: kernel_gradient_factor, in_support, kernel_w
  use fsph_spatial, only: make_grid
  use fsph_status, only: status_ok, status_bad_input, status_inverted_element
  use fsph_ordered, only: thread_rows
  implicit none
  private

  public :: reference_neighbours, reference_kernel_gradients, reference_correction
  public :: corrected_gradient, deformation_gradients, first_piola, first_piola_point
  public :: tlsph_forces, hoop_force, rate_of_deformation, reference_pair_factors
  public :: smallest_stretch, select_stencil, compress_rows

  !> Smallest eigenvalue of M = sum_j A_j grad0 W_ij (x) (X_j - X_i) [-]
  !> below which a particle's correction is refused as singular. M is
  !> symmetric and positive semi-definite (grad0 W is parallel to X_i - X_j
  !> with a negative factor) and is the identity for a full support (the
  !> kernel is normalised in the plane: int grad W (x) (X' - X) dA' = I).
  !> On a square lattice with h = 1.3 spacings (fsph's alpha_h) it is 1.01
  !> inside and 0.27 at a corner (0.29 with h = 1.2 spacings, the paper's
  !> ratio), 0.15 at the worst particle of a lattice jittered by up to 0.3
  !> spacings, and 0 for a particle alone or a single row of particles
  !> (measured; the h = 1.3 figures are tested in
  !> tests/test_tlsph_kernels.py). A tenth of a lattice corner's value
  !> flags a particle whose neighbours barely span the plane: its condition
  !> number would exceed about 40 [-].
  real(wp), parameter, public :: correction_min_eigenvalue = 2.7e-2_wp

contains

  ! ---- reference neighbour lists -------------------------------------

  !> Neighbour lists of the reference configuration x0 (t = 0) in CSR
  !> form: the row of particle i, list(ptr(i) .. ptr(i+1)-1), holds first
  !> the particles j /= i within the support 2 h_ij (fsph_kernel
  !> in_support), then the mirror images -j of the particles whose image
  !> (-R_j, Z_j) is within it (i's own image included), each in the order
  !> of a scan over a cell grid (cells, then particles by index): the
  !> order depends on the positions only. Coincident points (distance 0)
  !> are left out (their kernel gradient is zero). O(N): one cell grid of
  !> side the largest support. ierr = status_bad_input (ifault the first
  !> particle at fault) for a particle with R < 0 or h <= 0, or n < 1.
  subroutine reference_neighbours(n, x0, h, ptr, list, ierr, ifault)
    integer, intent(in) :: n
    real(wp), intent(in) :: x0(2, n)   !< reference positions (R, Z) [m]
    real(wp), intent(in) :: h(n)       !< smoothing lengths [m]
    integer, intent(out) :: ptr(n + 1)
    integer, allocatable, intent(out) :: list(:)
    integer, intent(out) :: ierr, ifault
    real(wp) :: cell, r0, z0
    integer :: nr, nz, i, filled
    integer, allocatable :: cell_start(:), item(:), counts(:)
    integer :: dummy(1)
    ptr = 1
    ierr = status_bad_input
    ifault = 0
    if (n < 1) then
      allocate (list(0))
      return
    end if
    do i = 1, n
      if (.not. (x0(1, i) >= 0.0_wp .and. h(i) > 0.0_wp)) then
        ifault = i
        allocate (list(0))
        return
      end if
    end do
    call make_grid(n, x0, h, cell, r0, z0, nr, nz, cell_start, item)
    allocate (counts(n))
    !$omp parallel do default(none) schedule(dynamic, 64) &
    !$omp shared(n, x0, h, cell, r0, z0, nr, nz, cell_start, item, counts) private(i, dummy)
    do i = 1, n
      call scan_row(i, n, x0, h, cell, r0, z0, nr, nz, cell_start, item, 0, dummy, counts(i))
    end do
    !$omp end parallel do
    do i = 1, n
      ptr(i + 1) = ptr(i) + counts(i)
    end do
    allocate (list(ptr(n + 1) - 1))
    !$omp parallel do default(none) schedule(dynamic, 64) &
    !$omp shared(n, x0, h, cell, r0, z0, nr, nz, cell_start, item, counts, ptr, list) private(i, filled)
    do i = 1, n
      call scan_row(i, n, x0, h, cell, r0, z0, nr, nz, cell_start, item, counts(i), &
                    list(ptr(i):ptr(i + 1) - 1), filled)
    end do
    !$omp end parallel do
    ierr = status_ok
  end subroutine reference_neighbours

  !> The row of particle i: its count, and with cap > 0 its first cap
  !> entries in row (reals first, then mirror images as -j).
  pure subroutine scan_row(i, n, x0, h, cell, r0, z0, nr, nz, cell_start, item, cap, row, count)
    integer, intent(in) :: i, n, nr, nz, cap
    real(wp), intent(in) :: x0(2, n), h(n), cell, r0, z0
    integer, intent(in) :: cell_start(nr*nz + 1), item(n)
    integer, intent(inout) :: row(*)
    integer, intent(out) :: count
    integer :: ir, iz, jr, jz, lo, hi, c, m, j
    real(wp) :: dist2
    count = 0
    ir = min(int((x0(1, i) - r0)/cell), nr - 1)
    iz = min(int((x0(2, i) - z0)/cell), nz - 1)
    ! real neighbours: the 3 x 3 cells around i
    do jz = max(iz - 1, 0), min(iz + 1, nz - 1)
      do jr = max(ir - 1, 0), min(ir + 1, nr - 1)
        c = 1 + jr + nr*jz
        do m = cell_start(c), cell_start(c + 1) - 1
          j = item(m)
          if (j == i) cycle
          dist2 = (x0(1, i) - x0(1, j))**2 + (x0(2, i) - x0(2, j))**2
          if (.not. (in_support(dist2, h(i), h(j)) .and. dist2 > 0.0_wp)) cycle
          count = count + 1
          if (count <= cap) row(count) = j
        end do
      end do
    end do
    ! mirror images: the real particles near i's own image (-R_i, Z_i)
    ! are those whose images are near i; the cells within one side of it
    lo = floor((-x0(1, i) - cell - r0)/cell)
    hi = floor((-x0(1, i) + cell - r0)/cell)
    do jz = max(iz - 1, 0), min(iz + 1, nz - 1)
      do jr = max(lo, 0), min(hi, nr - 1)
        c = 1 + jr + nr*jz
        do m = cell_start(c), cell_start(c + 1) - 1
          j = item(m)
          dist2 = (x0(1, i) + x0(1, j))**2 + (x0(2, i) - x0(2, j))**2
          if (.not. (in_support(dist2, h(i), h(j)) .and. dist2 > 0.0_wp)) cycle
          count = count + 1
          if (count <= cap) row(count) = -j
        end do
      end do
    end do
  end subroutine scan_row

  !> X_i - X_j' of entry `entry` of row i [m]: the offset from the entry's
  !> reference position ((-R_j, Z_j) for an image) to particle i's.
  pure function reference_offset(x0i, x0j, entry) result(dx)
    real(wp), intent(in) :: x0i(2), x0j(2)  !< [m]
    integer, intent(in) :: entry
    real(wp) :: dx(2)
    dx(1) = x0i(1) - image_sign(entry)*x0j(1)
    dx(2) = x0i(2) - x0j(2)
  end function reference_offset

  !> Sign of an entry's radial coordinate: -1 for a mirror image (-j),
  !> +1 for a particle [-].
  pure real(wp) function image_sign(entry)
    integer, intent(in) :: entry
    image_sign = merge(-1.0_wp, 1.0_wp, entry < 0)
  end function image_sign

  !> Kernel gradient grad0 W_ij = grad_{X_i} W(|X_i - X_j'|, h_ij) of
  !> every entry [1/m^3], X_j' the entry's position ((-R_j, Z_j) for an
  !> image). Computed once: the reference configuration does not move. The
  !> entry (j, i) gets exactly minus the bits of (i, j), and the image
  !> entry (j, -i) exactly S times minus those of (i, -j).
  subroutine reference_kernel_gradients(n, x0, h, ptr, list, grad_w)
    integer, intent(in) :: n
    real(wp), intent(in) :: x0(2, n), h(n)  !< [m]
    integer, intent(in) :: ptr(n + 1), list(*)
    real(wp), intent(out) :: grad_w(2, *)
    integer :: i, k, j
    real(wp) :: dx(2), dist2
    !$omp parallel do default(none) schedule(dynamic, 64) &
    !$omp shared(n, x0, h, ptr, list, grad_w) private(i, k, j, dx, dist2)
    do i = 1, n
      do k = ptr(i), ptr(i + 1) - 1
        j = abs(list(k))
        dx = reference_offset(x0(:, i), x0(:, j), list(k))
        dist2 = dx(1)**2 + dx(2)**2
        grad_w(:, k) = kernel_gradient_factor(dist2, 2.0_wp/(h(i) + h(j)))*dx
      end do
    end do
    !$omp end parallel do
  end subroutine reference_kernel_gradients

  ! ---- the correction ------------------------------------------------

  !> Correction matrices B_i = M_i^-1, M_i = sum_j A_j grad0 W_ij (x)
  !> (X_j' - X_i) (module header), and the smallest eigenvalue of each
  !> M_i [-]. A particle whose smallest eigenvalue is below
  !> correction_min_eigenvalue (an isolated particle, a single row) is not
  !> corrected: its B is set to zero (no gradient at all, so that a caller
  !> that ignores the report sees no deformation rather than a made-up
  !> one), and ierr = status_bad_input with ifault the lowest such index.
  subroutine reference_correction(n, x0, area, ptr, list, grad_w, bmat, eig_min, ierr, ifault)
    integer, intent(in) :: n
    real(wp), intent(in) :: x0(2, n)     !< [m]
    real(wp), intent(in) :: area(n)      !< planar areas [m^2]
    integer, intent(in) :: ptr(n + 1), list(*)
    real(wp), intent(in) :: grad_w(2, *) !< [1/m^3]
    real(wp), intent(out) :: bmat(2, 2, n) !< [-]
    real(wp), intent(out) :: eig_min(n)  !< [-]
    integer, intent(out) :: ierr, ifault
    integer :: i, k, j
    real(wp) :: m(2, 2), dx(2), det, half_trace, spread
    !$omp parallel do default(none) schedule(dynamic, 64) &
    !$omp shared(n, x0, area, ptr, list, grad_w, bmat, eig_min) private(i, k, j, m, dx, det, half_trace, spread)
    do i = 1, n
      m = 0.0_wp
      do k = ptr(i), ptr(i + 1) - 1
        j = abs(list(k))
        dx = -reference_offset(x0(:, i), x0(:, j), list(k))
        m(1, 1) = m(1, 1) + area(j)*grad_w(1, k)*dx(1)
        m(2, 1) = m(2, 1) + area(j)*grad_w(2, k)*dx(1)
        m(1, 2) = m(1, 2) + area(j)*grad_w(1, k)*dx(2)
        m(2, 2) = m(2, 2) + area(j)*grad_w(2, k)*dx(2)
      end do
      ! eigenvalues of the symmetric part (M is symmetric up to round-off)
      half_trace = 0.5_wp*(m(1, 1) + m(2, 2))
      spread = sqrt((0.5_wp*(m(1, 1) - m(2, 2)))**2 + (0.5_wp*(m(1, 2) + m(2, 1)))**2)
      eig_min(i) = half_trace - spread
      det = m(1, 1)*m(2, 2) - m(1, 2)*m(2, 1)
      if (eig_min(i) < correction_min_eigenvalue) then
        bmat(:, :, i) = 0.0_wp
      else
        bmat(1, 1, i) = m(2, 2)/det
        bmat(2, 2, i) = m(1, 1)/det
        bmat(1, 2, i) = -m(1, 2)/det
        bmat(2, 1, i) = -m(2, 1)/det
      end if
    end do
    !$omp end parallel do
    ifault = 0
    ierr = status_ok
    do i = 1, n
      if (eig_min(i) < correction_min_eigenvalue) then
        ifault = i
        ierr = status_bad_input
        return
      end if
    end do
  end subroutine reference_correction

  ! ---- gradients -----------------------------------------------------

  !> Corrected reference gradient of a scalar field f (mirror images take
  !> f_j): grad0 f_i = B_i sum_j A_j (f_j - f_i) grad0 W_ij, (d/dR, d/dZ)
  !> [units of f per m].
  subroutine corrected_gradient(n, area, ptr, list, grad_w, bmat, f, grad_f)
    integer, intent(in) :: n
    real(wp), intent(in) :: area(n)      !< [m^2]
    integer, intent(in) :: ptr(n + 1), list(*)
    real(wp), intent(in) :: grad_w(2, *) !< [1/m^3]
    real(wp), intent(in) :: bmat(2, 2, n), f(n)
    real(wp), intent(out) :: grad_f(2, n)
    integer :: i, k, j, first, last
    real(wp) :: s(2)
    !$omp parallel default(none) shared(n, area, ptr, list, grad_w, bmat, f, grad_f) private(i, k, j, s, first, last)
    call thread_rows(n, ptr, ptr, first, last)
    do i = first, last
      s = 0.0_wp
      do k = ptr(i), ptr(i + 1) - 1
        j = abs(list(k))
        s = s + area(j)*(f(j) - f(i))*grad_w(:, k)
      end do
      grad_f(:, i) = matmul(bmat(:, :, i), s)
    end do
    !$omp end parallel
  end subroutine corrected_gradient

  !> Deformation gradients at the current positions x: the in-plane block
  !> fmat = I + grad0 u (fmat(a, b) = d x_a / d X_b, (1, 2) = (r, z)),
  !> grad0 u_i = sum_j A_j (u_j' - u_i) (x) B_i grad0 W_ij with an image's
  !> displacement (-u_r, u_z); the hoop stretch f_tt = r_i/R_i (its limit
  !> dr/dR on the axis); J = det(fmat) f_tt. ierr =
  !> status_inverted_element with ifault = -i (a particle, fsph_layouts)
  !> for the lowest i whose det(fmat) or f_tt is not positive.
  subroutine deformation_gradients(n, x0, x, h, area, ptr, list, grad_w, bmat, fmat, f_tt, jac, ierr, ifault)
    integer, intent(in) :: n
    real(wp), intent(in) :: x0(2, n), x(2, n)  !< reference and current positions [m]
    real(wp), intent(in) :: h(n)         !< [m]
    real(wp), intent(in) :: area(n)      !< [m^2]
    integer, intent(in) :: ptr(n + 1), list(*)
    real(wp), intent(in) :: grad_w(2, *) !< [1/m^3]
    real(wp), intent(in) :: bmat(2, 2, n)
    real(wp), intent(out) :: fmat(2, 2, n), f_tt(n), jac(n) !< [-]
    integer, intent(out) :: ierr, ifault
    integer :: i, k, j, first, last
    real(wp) :: s(2, 2), du(2), ui(2), sg, det
    !$omp parallel default(none) &
    !$omp shared(n, x0, x, h, area, ptr, list, grad_w, bmat, fmat, f_tt, jac) &
    !$omp private(i, k, j, s, du, ui, sg, det, first, last)
    call thread_rows(n, ptr, ptr, first, last)
    do i = first, last
      ui = x(:, i) - x0(:, i)
      s = 0.0_wp
      do k = ptr(i), ptr(i + 1) - 1
        j = abs(list(k))
        sg = image_sign(list(k))
        du(1) = sg*(x(1, j) - x0(1, j)) - ui(1)
        du(2) = (x(2, j) - x0(2, j)) - ui(2)
        s(1, 1) = s(1, 1) + area(j)*du(1)*grad_w(1, k)
        s(2, 1) = s(2, 1) + area(j)*du(2)*grad_w(1, k)
        s(1, 2) = s(1, 2) + area(j)*du(1)*grad_w(2, k)
        s(2, 2) = s(2, 2) + area(j)*du(2)*grad_w(2, k)
      end do
      ! grad0 u = s B^T: (B grad0 W)_b = B(b, c) grad0 W_c
      fmat(:, :, i) = matmul(s, transpose(bmat(:, :, i)))
      fmat(1, 1, i) = fmat(1, 1, i) + 1.0_wp
      fmat(2, 2, i) = fmat(2, 2, i) + 1.0_wp
      if (x0(1, i) > axis_tolerance*h(i)) then
        f_tt(i) = x(1, i)/x0(1, i)
      else
        f_tt(i) = fmat(1, 1, i)
      end if
      det = fmat(1, 1, i)*fmat(2, 2, i) - fmat(1, 2, i)*fmat(2, 1, i)
      jac(i) = merge(det*f_tt(i), -abs(det*f_tt(i)), det > 0.0_wp .and. f_tt(i) > 0.0_wp)
    end do
    !$omp end parallel
    ifault = 0
    ierr = status_ok
    do i = 1, n
      if (.not. (jac(i) > 0.0_wp)) then
        ifault = -i
        ierr = status_inverted_element
        return
      end if
    end do
  end subroutine deformation_gradients

  ! ---- stress and forces ---------------------------------------------

  !> First Piola-Kirchhoff stress P = J sigma F^-T of one point [Pa], from
  !> the Cauchy stress sig = (rr, zz, rz, tt) [Pa] and the deformation
  !> gradient (in-plane fmat, hoop f_tt). With J F^-T = f_tt cof(fmat) in
  !> the plane and J/f_tt = det(fmat) in the hoop direction, nothing is
  !> divided: p = sigma f_tt cof(fmat) (p(a, b): row a spatial, column b
  !> reference), p_tt = det(fmat) sigma_tt.
  pure subroutine first_piola_point(fmat, f_tt, sig, p, p_tt)
    real(wp), intent(in) :: fmat(2, 2), f_tt, sig(4)
    real(wp), intent(out) :: p(2, 2), p_tt
    real(wp) :: cof(2, 2), s2(2, 2)
    cof(1, 1) = fmat(2, 2); cof(1, 2) = -fmat(2, 1)
    cof(2, 1) = -fmat(1, 2); cof(2, 2) = fmat(1, 1)
    s2(1, 1) = sig(1); s2(2, 2) = sig(2); s2(1, 2) = sig(3); s2(2, 1) = sig(3)
    p = f_tt*matmul(s2, cof)
    p_tt = (fmat(1, 1)*fmat(2, 2) - fmat(1, 2)*fmat(2, 1))*sig(4)
  end subroutine first_piola_point

  !> first_piola_point for n particles.
  subroutine first_piola(n, fmat, f_tt, sig, p, p_tt)
    integer, intent(in) :: n
    real(wp), intent(in) :: fmat(2, 2, n), f_tt(n) !< [-]
    real(wp), intent(in) :: sig(4, n)              !< Cauchy (rr, zz, rz, tt) [Pa]
    real(wp), intent(out) :: p(2, 2, n), p_tt(n)   !< [Pa]
    integer :: i
    !$omp parallel do default(none) schedule(static) shared(n, fmat, f_tt, sig, p, p_tt) private(i)
    do i = 1, n
      call first_piola_point(fmat(:, :, i), f_tt(i), sig(:, i), p(:, :, i), p_tt(i))
    end do
    !$omp end parallel do
  end subroutine first_piola

  !> Hoop force of a particle per full ring [N], radial: -V0 P_tt/R =
  !> -2 pi A P_tt with V0 = 2 pi R A (no division: finite on the axis).
  pure elemental real(wp) function hoop_force(area, p_tt)
    real(wp), intent(in) :: area  !< planar area [m^2]
    real(wp), intent(in) :: p_tt  !< first Piola-Kirchhoff hoop stress [Pa]
    hoop_force = -two_pi*area*p_tt
  end function hoop_force

  !> Internal forces per full ring [N] (module header):
  !>   f_k = sum_j pair_area_kj (Q_k + Q_j S_j) grad0 W_kj + hoop_force e_r
  !>         + sum_j hourglass_pair(k, j),
  !> Q = R P B [Pa m], S_j = diag(-1, 1) for an image, I for a particle,
  !> pair_area_kj = 2 pi A_k A_j (reference_pair_factors), in one pass over
  !> the rows (hg_coef = 0: no hourglass control; a pair with a particle
  !> whose hg_on is 0, none either). The pair factors are
  !> symmetric (A_k A_j, Q_k + Q_j), so the term of (j, k) is exactly minus
  !> that of (k, j), and the term of the image pair (j, k') exactly minus
  !> that of (k, j'). work is space for Q; hg_pair gets each entry's
  !> hourglass force on the row's particle [N].
  subroutine tlsph_forces(n, x0, x, area, ptr, list, grad_w, pair_area, hg_coef, bmat, fmat, hg_on, p, p_tt, &
                          work, hg_pair, force)
    integer, intent(in) :: n
    real(wp), intent(in) :: x0(2, n), x(2, n)  !< reference and current positions [m]
    real(wp), intent(in) :: area(n)      !< [m^2]
    integer, intent(in) :: ptr(n + 1), list(*)
    real(wp), intent(in) :: grad_w(2, *) !< [1/m^3]
    real(wp), intent(in) :: pair_area(*) !< 2 pi A_k A_j per entry [m^4]
    real(wp), intent(in) :: hg_coef(*)   !< hourglass coefficient per entry (reference_pair_factors) [N/m]
    real(wp), intent(in) :: bmat(2, 2, n), fmat(2, 2, n) !< [-]
    real(wp), intent(in) :: hg_on(n)     !< 1: the particle's pairs take the hourglass control, 0: not [-]
    real(wp), intent(in) :: p(2, 2, n), p_tt(n)     !< first Piola-Kirchhoff [Pa]
    real(wp), intent(out) :: work(2, 2, n)          !< Q [Pa m]
    real(wp), intent(out) :: hg_pair(2, *)          !< [N]
    real(wp), intent(out) :: force(2, n)            !< [N]
    integer :: i, k, j, first, last
    real(wp) :: qs(2, 2), f(2), sg
    !$omp parallel default(none) &
    !$omp shared(n, x0, x, area, ptr, list, grad_w, pair_area, hg_coef, bmat, fmat, hg_on, p, p_tt, work, hg_pair) &
    !$omp shared(force) &
    !$omp private(i, k, j, qs, f, sg, first, last)
    call thread_rows(n, ptr, ptr, first, last)
    do i = first, last
      work(:, :, i) = x0(1, i)*matmul(p(:, :, i), bmat(:, :, i))
    end do
    ! the neighbours' Q of other rows
    !$omp barrier
    do i = first, last
      f = 0.0_wp
      do k = ptr(i), ptr(i + 1) - 1
        j = abs(list(k))
        sg = image_sign(list(k))
        ! Q_i + Q_j S for an image (S = diag(-1, 1)), Q_i + Q_j otherwise
        qs(1, 1) = work(1, 1, i) + sg*work(1, 1, j)
        qs(2, 1) = work(2, 1, i) + sg*work(2, 1, j)
        qs(1, 2) = work(1, 2, i) + work(1, 2, j)
        qs(2, 2) = work(2, 2, i) + work(2, 2, j)
        f(1) = f(1) + pair_area(k)*(qs(1, 1)*grad_w(1, k) + qs(1, 2)*grad_w(2, k))
        f(2) = f(2) + pair_area(k)*(qs(2, 1)*grad_w(1, k) + qs(2, 2)*grad_w(2, k))
        hg_pair(:, k) = hourglass_pair(x0(:, i), x0(:, j), x(:, i), x(:, j), fmat(:, :, i), fmat(:, :, j), sg, &
                                       hg_coef(k)*(hg_on(i)*hg_on(j)))
        f = f + hg_pair(:, k)
      end do
      force(1, i) = f(1) + hoop_force(area(i), p_tt(i))
      force(2, i) = f(2)
    end do
    !$omp end parallel
  end subroutine tlsph_forces

  !> The reference factors of each entry (i, j'): pair_area = 2 pi A_i A_j
  !> [m^4] of the momentum sum, and the hourglass coefficient
  !> hg_coef = pi gamma Rbar A_i A_j W_ij E_ij / |X_ij'|^2 [N/m] of
  !> hourglass_pair (Rbar = (R_i + R_j)/2, E_ij = (E_i + E_j)/2, W_ij the
  !> kernel at the reference distance), both symmetric in i and j.
  subroutine reference_pair_factors(n, x0, h, area, modulus, gamma, ptr, list, pair_area, hg_coef)
    integer, intent(in) :: n
    real(wp), intent(in) :: x0(2, n), h(n)  !< [m]
    real(wp), intent(in) :: area(n)         !< [m^2]
    real(wp), intent(in) :: modulus(n)      !< Young's modulus [Pa]
    real(wp), intent(in) :: gamma           !< hourglass coefficient [-]
    integer, intent(in) :: ptr(n + 1), list(*)
    real(wp), intent(out) :: pair_area(*), hg_coef(*)
    integer :: i, k, j
    real(wp) :: dx(2), dist2
    !$omp parallel do default(none) schedule(dynamic, 64) &
    !$omp shared(n, x0, h, area, modulus, gamma, ptr, list, pair_area, hg_coef) private(i, k, j, dx, dist2)
    do i = 1, n
      do k = ptr(i), ptr(i + 1) - 1
        j = abs(list(k))
        dx = reference_offset(x0(:, i), x0(:, j), list(k))
        dist2 = dx(1)**2 + dx(2)**2
        pair_area(k) = two_pi*(area(i)*area(j))
        hg_coef(k) = 0.5_wp*pi*gamma*(x0(1, i) + x0(1, j))*(area(i)*area(j)) &
                     *kernel_w(sqrt(dist2), 0.5_wp*(h(i) + h(j)))*0.5_wp*(modulus(i) + modulus(j))/dist2
      end do
    end do
    !$omp end parallel do
  end subroutine reference_pair_factors

  !> Spatial velocity gradient L = dF/dt F^-1 of one point (in the plane;
  !> L_tt = fdot_tt/f_tt = v_r/r in the hoop direction) as the updated
  !> particles carry it: the rate of deformation d = (rr, zz, rz, tt), the
  !> spin (L_rz - L_zr)/2 and grad_v = (L_rr, L_zr, L_rz, L_zz) [1/s]
  !> (L(a, b) = d v_a / d x_b, fsph_sph sph_rates).
  pure subroutine rate_of_deformation(fmat, f_tt, fdot, fdot_tt, d, spin, grad_v)
    real(wp), intent(in) :: fmat(2, 2), f_tt, fdot(2, 2), fdot_tt
    real(wp), intent(out) :: d(4), spin, grad_v(4)
    real(wp) :: inv(2, 2), det, l(2, 2)
    det = fmat(1, 1)*fmat(2, 2) - fmat(1, 2)*fmat(2, 1)
    inv(1, 1) = fmat(2, 2)/det; inv(1, 2) = -fmat(1, 2)/det
    inv(2, 1) = -fmat(2, 1)/det; inv(2, 2) = fmat(1, 1)/det
    l = matmul(fdot, inv)
    d(1) = l(1, 1)
    d(2) = l(2, 2)
    d(3) = 0.5_wp*(l(1, 2) + l(2, 1))
    d(4) = fdot_tt/f_tt
    spin = 0.5_wp*(l(1, 2) - l(2, 1))
    grad_v = [l(1, 1), l(2, 1), l(1, 2), l(2, 2)]
  end subroutine rate_of_deformation

  !> Smallest principal stretch of the in-plane block of F [-] (the
  !> square root of the smaller eigenvalue of F^T F): how much the
  !> particle spacing has shrunk in its most compressed direction.
  pure elemental real(wp) function smallest_stretch(f11, f21, f12, f22)
    real(wp), intent(in) :: f11, f21, f12, f22
    real(wp) :: c11, c22, c12, half_trace, spread
    c11 = f11**2 + f21**2
    c22 = f12**2 + f22**2
    c12 = f11*f12 + f21*f22
    half_trace = 0.5_wp*(c11 + c22)
    spread = sqrt((0.5_wp*(c11 - c22))**2 + c12**2)
    smallest_stretch = sqrt(max(half_trace - spread, 0.0_wp))
  end function smallest_stretch

  !> Hourglass control of Ganzenmueller (2015, Comput. Methods Appl. Mech.
  !> Engrg. 286:87), the force on particle i of its entry j [N]: a pair
  !> whose current separation x_ij = x_j - x_i differs from what the two
  !> deformation gradients predict, F_i X_ij and F_j X_ij (X_ij = X_j - X_i),
  !> is pushed along x_ij by
  !>   f_i = -pi gamma Rbar A_i A_j W_ij E_ij (delta_i + delta_j)/|X_ij|^2 e_ij,
  !>   delta_i = (F_i X_ij - x_ij).e_ij, delta_j = (F_j X_ij - x_ij).e_ij,
  !> e_ij = x_ij/|x_ij|, Rbar = (|R_i| + |R_j|)/2 the ring weight
  !> (Ganzenmueller's V_i V_j with ring volumes 2 pi R A in r-z), E_ij the
  !> mean of the two Young's moduli, W_ij the kernel at the reference
  !> distance. A mode that F sees (any affine field) gives delta = 0: no
  !> force. The terms are formed so that the entry (j, i) gives exactly
  !> minus the force of (i, j), along the line of centres: momentum is
  !> conserved. Mirror images (sg = -1) take part as in the momentum sum:
  !> the image j' of j sits at (-R_j, Z_j), (-r_j, z_j) with F_j' = S F_j S
  !> (S = diag(-1, 1)); its pair acts on i only, and j's row holds the
  !> mirror of it (the axial parts cancel). Left out, the images left the
  !> particles next to the axis with one-sided pairs: in a Taylor rod their
  !> plastic strain grew to 20 times their neighbours' (measured,
  !> docs/method.md).
  pure function hourglass_pair(x0i, x0j, xi, xj, fi, fj, sg, coef) result(f)
    real(wp), intent(in) :: x0i(2), x0j(2), xi(2), xj(2) !< reference and current positions [m]
    real(wp), intent(in) :: fi(2, 2), fj(2, 2)  !< deformation gradients (fj: the particle's, not its image's)
    real(wp), intent(in) :: sg                  !< -1 for an image, 1 for a particle [-]
    real(wp), intent(in) :: coef                !< pi gamma Rbar A_i A_j W_ij E_ij/|X_ij|^2 [N/m]
    real(wp) :: f(2)
    real(wp) :: dxr(2), dx(2), e(2), delta, fj12, fj21
    dxr(1) = sg*x0j(1) - x0i(1)
    dxr(2) = x0j(2) - x0i(2)
    dx(1) = sg*xj(1) - xi(1)
    dx(2) = xj(2) - xi(2)
    fj12 = sg*fj(1, 2)
    fj21 = sg*fj(2, 1)
    e = dx/sqrt(dx(1)**2 + dx(2)**2)
    delta = ((fi(1, 1)*dxr(1) + fi(1, 2)*dxr(2) - dx(1))*e(1) &
             + (fi(2, 1)*dxr(1) + fi(2, 2)*dxr(2) - dx(2))*e(2)) &
            + ((fj(1, 1)*dxr(1) + fj12*dxr(2) - dx(1))*e(1) &
               + (fj21*dxr(1) + fj(2, 2)*dxr(2) - dx(2))*e(2))
    f = (-coef*delta)*e
  end function hourglass_pair

  ! ---- the selected-particle stencil (SFPM) ------------------------------

  !> The selected-particle stencil of Wang et al. (2022, SFPM) within the
  !> reference lists: keep(k) marks the entries kept. A particle takes, in
  !> each of the four sectors of 90 degrees around +R, -R, +Z and -Z (the
  !> diagonals going to the R sectors), its nearest entry (images
  !> included; ties to the first in row order); with all four sectors
  !> filled (an interior particle: on a lattice the central differences)
  !> those four, otherwise (a boundary particle) its three nearest entries,
  !> and more in order of distance until they span the plane (one-sided
  !> differences). The marks are then made symmetric: an entry (i, j) kept
  !> keeps (j, i), an image entry (i, -j) keeps (j, -i) (the pair at the
  !> same reference distance): the pair sum of tlsph_forces is then the
  !> derivative of the discrete strain energy on the stencil and conserves
  !> momentum pair by pair, as on the full support. Symmetrising adds a
  !> boundary particle to the stencils of the neighbours it chose.
  subroutine select_stencil(n, x0, ptr, list, keep)
    integer, intent(in) :: n
    real(wp), intent(in) :: x0(2, n)      !< [m]
    integer, intent(in) :: ptr(n + 1), list(*)
    logical, intent(out) :: keep(*)
    integer :: i, k, j, m
    keep(1:ptr(n + 1) - 1) = .false.
    !$omp parallel do default(none) schedule(dynamic, 64) shared(n, x0, ptr, list, keep) private(i)
    do i = 1, n
      call stencil_row(i, n, x0, ptr, list, keep)
    end do
    !$omp end parallel do
    ! symmetric: the reverse of every kept entry (serial: it writes other rows)
    do i = 1, n
      do k = ptr(i), ptr(i + 1) - 1
        if (.not. keep(k)) cycle
        j = abs(list(k))
        do m = ptr(j), ptr(j + 1) - 1
          if (list(m) == sign(i, list(k))) keep(m) = .true.
        end do
      end do
    end do
  end subroutine select_stencil

  !> The stencil of particle i (select_stencil): its entries' marks.
  pure subroutine stencil_row(i, n, x0, ptr, list, keep)
    integer, intent(in) :: i, n, ptr(n + 1), list(*)
    real(wp), intent(in) :: x0(2, n)
    logical, intent(inout) :: keep(*)
    integer :: k, j, sector, best(4), count, chosen, first
    real(wp) :: d(2), dist2, best_d2(4), near_d2
    logical :: taken(ptr(i + 1) - ptr(i))
    best = 0
    best_d2 = huge(1.0_wp)
    first = ptr(i)
    do k = ptr(i), ptr(i + 1) - 1
      j = abs(list(k))
      d = -reference_offset(x0(:, i), x0(:, j), list(k))
      dist2 = d(1)**2 + d(2)**2
      if (abs(d(2)) <= abs(d(1))) then
        sector = merge(1, 2, d(1) > 0.0_wp)
      else
        sector = merge(3, 4, d(2) > 0.0_wp)
      end if
      if (dist2 < best_d2(sector)) then
        best_d2(sector) = dist2
        best(sector) = k
      end if
    end do
    if (all(best > 0)) then
      keep(best) = .true.
      return
    end if
    ! a boundary particle: the nearest entries until three that span the plane
    taken = .false.
    count = 0
    do
      if (count >= 3 .and. taken_span()) exit
      if (count == size(taken)) exit
      chosen = 0
      near_d2 = huge(1.0_wp)
      do k = ptr(i), ptr(i + 1) - 1
        if (taken(k - first + 1)) cycle
        dist2 = entry_offset(k, 1)**2 + entry_offset(k, 2)**2
        if (dist2 < near_d2) then
          near_d2 = dist2
          chosen = k
        end if
      end do
      taken(chosen - first + 1) = .true.
      count = count + 1
    end do
    do k = ptr(i), ptr(i + 1) - 1
      if (taken(k - first + 1)) keep(k) = .true.
    end do
  contains
    !> Component c of the offset X_e' - X_i of entry e [m].
    pure real(wp) function entry_offset(e, c)
      integer, intent(in) :: e, c
      real(wp) :: dx(2)
      dx = -reference_offset(x0(:, i), x0(:, abs(list(e))), list(e))
      entry_offset = dx(c)
    end function entry_offset
    !> Two of the taken directions are not parallel.
    pure logical function taken_span()
      integer :: a, b
      real(wp) :: c2
      taken_span = .false.
      do a = ptr(i), ptr(i + 1) - 1
        if (.not. taken(a - first + 1)) cycle
        do b = a + 1, ptr(i + 1) - 1
          if (.not. taken(b - first + 1)) cycle
          c2 = entry_offset(a, 1)*entry_offset(b, 2) - entry_offset(a, 2)*entry_offset(b, 1)
          if (abs(c2) > 1.0e-6_wp*(entry_offset(a, 1)**2 + entry_offset(a, 2)**2 + entry_offset(b, 1)**2 &
                                   + entry_offset(b, 2)**2)) taken_span = .true.
        end do
      end do
    end function taken_span
  end subroutine stencil_row

  !> The rows of the entries marked keep, in CSR form, in the order of the
  !> full rows (sub_ptr(n + 1) - 1 entries).
  subroutine compress_rows(n, ptr, list, keep, sub_ptr, sub_list)
    integer, intent(in) :: n, ptr(n + 1), list(*)
    logical, intent(in) :: keep(*)
    integer, intent(out) :: sub_ptr(n + 1)
    integer, allocatable, intent(out) :: sub_list(:)
    integer :: i, k, m
    sub_ptr(1) = 1
    do i = 1, n
      sub_ptr(i + 1) = sub_ptr(i) + count(keep(ptr(i):ptr(i + 1) - 1))
    end do
    allocate (sub_list(sub_ptr(n + 1) - 1))
    m = 0
    do k = 1, ptr(n + 1) - 1
      if (.not. keep(k)) cycle
      m = m + 1
      sub_list(m) = list(k)
    end do
  end subroutine compress_rows

end module fsph_tlsph
