!> Mirror images of particles across rigid planes normal to the axis (the
!> anvil of a Taylor test), so that the SPH sums of the particles next to
!> a wall are complete: the wall acts on them through the pair terms of
!> their images (the ghost particles of Libersky, Petschek, Carney, Hipp &
!> Allahdadi 1993, J. Comput. Phys. 109:67, at a rigid wall). Across a
!> plane z = z_p the image of particle i stands at (r_i, 2 z_p - z_i) with
!> velocity (v_r, -v_z), sigma_rz and the off-diagonal velocity gradients
!> reversed, and the particle's ring mass, density, smoothing length and
!> material (the ring radius does not change across such a plane). The
!> image is a neighbour of the particles of the same continuum only; its
!> reaction goes to the plane, which is fixed.
!>
!> An image takes part in the viscosity with its particle's compression
!> switch (fsph_sph) and carries no hourglass term: with the hourglass
!> term on the image pairs (the image's velocity gradient its particle's
!> mirrored) the particle at the corner of axis and anvil of the adaptive
!> Armco rod (10 cells across) gained 50 instead of 38 kJ/kg of hourglass
!> heat.
!>
!> The wall only pushes: an image acts with the particle's ring mass while
!> the particle presses on the wall (normal stress sigma_nn <= 0) and
!> approaches it, and otherwise with that mass times
!> clamp(-sigma_nn/(ramp rho c^2), 0, 1), so that a particle in tension
!> (a rod that rebounds) leaves the wall. Without the images the particles
!> of the impact face saw the anvil only through the kinematic plane
!> condition: every face particle was stopped dead (-0.8 % of the energy
!> of the 20-across pure SPH Armco rod at impact, -1.6 % at 10 across),
!> the face rows reached twice the plastic strain of the FEM face, and
!> the energy kept falling by another 0.7 % as the foot spread.
!>
!> Images are chosen when the neighbour lists are built (every particle
!> within twice the largest smoothing length plus the lists' skin of such
!> a plane) and refilled at every stage of the cycle, like the imaginary
!> particles of the elements. A plane not normal to the axis gets no
!> images (its image of a ring would be no ring): particles meet it
!> through the kinematic plane condition alone.
module fsph_mirror
  use fsph_kinds, only: wp
  implicit none
  private

  public :: mirror_plane_normal_to_axis, mirror_select, mirror_fill_start, mirror_fill_mid, mirror_fill_stress
  public :: mirror_reaction_z

  !> A plane counts as normal to the axis when the radial component of its
  !> unit normal is below this [-].
  real(wp), parameter :: normal_tolerance = 1.0e-12_wp
  !> Normal stress over which an image fades in or out, as a fraction of
  !> the particle's rho c^2 (about 0.1 GPa for iron) [-].
  real(wp), parameter :: ramp_fraction = 5.0e-4_wp

contains

  !> Whether a plane of unit normal `normal` (r, z) gets mirror images.
  pure logical function mirror_plane_normal_to_axis(normal)
    real(wp), intent(in) :: normal(2)
    mirror_plane_normal_to_axis = abs(normal(1)) < normal_tolerance
  end function mirror_plane_normal_to_axis

  !> Choose the images: every real particle within the reach
  !> 2 h_max + skin of a plane normal to the axis (and not more than h_max
  !> behind it), plane by plane in particle order. n_mirror is the number
  !> found; only the first max_mirror are stored (the caller makes room
  !> and calls again when n_mirror > max_mirror).
  subroutine mirror_select(n, x, h, skin, n_planes, point, normal, max_mirror, n_mirror, mirror_of, mirror_plane)
    integer, intent(in) :: n
    real(wp), intent(in) :: x(2, n), h(n)
    real(wp), intent(in) :: skin              !< skin of the neighbour lists [m]
    integer, intent(in) :: n_planes
    real(wp), intent(in) :: point(2, n_planes), normal(2, n_planes) !< [m], unit normals [-]
    integer, intent(in) :: max_mirror
    integer, intent(out) :: n_mirror
    integer, intent(inout) :: mirror_of(max_mirror), mirror_plane(max_mirror)
    integer :: i, ip
    real(wp) :: h_max, gap
    n_mirror = 0
    if (n == 0) return
    h_max = maxval(h)
    do ip = 1, n_planes
      if (.not. mirror_plane_normal_to_axis(normal(:, ip))) cycle
      do i = 1, n
        gap = (x(2, i) - point(2, ip))*normal(2, ip)
        if (gap >= 2.0_wp*h_max + skin .or. gap <= -h_max) cycle
        n_mirror = n_mirror + 1
        if (n_mirror > max_mirror) cycle
        mirror_of(n_mirror) = i
        mirror_plane(n_mirror) = ip
      end do
    end do
  end subroutine mirror_select

  !> Weight of an image's ring mass: 1 while its particle presses on the
  !> plane and approaches it, else clamp(-sigma_nn/(ramp rho c^2), 0, 1).
  pure real(wp) function image_weight(sigma_nn, v_n, rho, c)
    real(wp), intent(in) :: sigma_nn  !< normal stress of the particle [Pa]
    real(wp), intent(in) :: v_n       !< its velocity along the plane's normal [m/s]
    real(wp), intent(in) :: rho, c    !< [kg/m^3], [m/s]
    if (sigma_nn <= 0.0_wp .and. v_n < 0.0_wp) then
      image_weight = 1.0_wp
    else
      image_weight = min(max(-sigma_nn/(ramp_fraction*rho*c*c), 0.0_wp), 1.0_wp)
    end if
  end function image_weight

  !> Images at the start of the cycle (positions x^n, velocities
  !> v^(n-1/2)): entries first+1 .. first+n_mirror of the particle arrays.
  !> Everything the accelerations and the neighbour search read: position,
  !> velocity, weighted ring mass, density, smoothing length, radius, sound
  !> speed, total stress, velocity gradient, continuum, material, body.
  subroutine mirror_fill_start(first, n_mirror, mirror_of, mirror_plane, n_planes, point, normal, x, v, v_bar, &
                               mass, rho, rho_mid, h, radius, c, s, p, sig, grad_v, continuum, mat, body)
    integer, intent(in) :: first, n_mirror
    integer, intent(in) :: mirror_of(n_mirror), mirror_plane(n_mirror), n_planes
    real(wp), intent(in) :: point(2, n_planes), normal(2, n_planes)
    real(wp), intent(inout) :: x(:, :), v(:, :), v_bar(:, :), mass(:), rho(:), rho_mid(:), h(:), radius(:)
    real(wp), intent(inout) :: c(:), s(:, :), p(:), sig(:, :), grad_v(:, :)
    integer, intent(inout) :: continuum(:), mat(:), body(:)
    integer :: k, i, e, ip
    real(wp) :: sigma_nn
    !$omp parallel do default(none) private(k, i, e, ip, sigma_nn) &
    !$omp shared(first, n_mirror, mirror_of, mirror_plane, point, normal, x, v, v_bar, mass, rho, rho_mid, h) &
    !$omp shared(radius, c, s, p, sig, grad_v, continuum, mat, body)
    do k = 1, n_mirror
      i = mirror_of(k)
      ip = mirror_plane(k)
      e = first + k
      x(1, e) = x(1, i)
      x(2, e) = 2.0_wp*point(2, ip) - x(2, i)
      v(1, e) = v(1, i)
      v(2, e) = -v(2, i)
      v_bar(:, e) = v(:, e)
      sigma_nn = s(2, i) - p(i)
      mass(e) = mass(i)*image_weight(sigma_nn, v(2, i)*normal(2, ip), rho(i), c(i))
      rho(e) = rho(i)
      rho_mid(e) = rho(i)
      h(e) = h(i)
      radius(e) = radius(i)
      c(e) = c(i)
      sig(:, e) = s(:, i)
      sig([1, 2, 4], e) = sig([1, 2, 4], e) - p(i)
      sig(3, e) = -sig(3, e)
      grad_v(:, e) = [grad_v(1, i), -grad_v(2, i), -grad_v(3, i), grad_v(4, i)]
      continuum(e) = continuum(i)
      mat(e) = mat(i)
      body(e) = body(i)
    end do
    !$omp end parallel do
  end subroutine mirror_fill_start

  !> Images at mid-step (positions x^(n+1/2), velocities v^(n+1/2) and the
  !> kick's mean velocity v_bar, density rho^n) for the rates; the ring
  !> mass stays that of the start of the cycle.
  subroutine mirror_fill_mid(first, n_mirror, mirror_of, mirror_plane, n_planes, point, x_mid, v, v_bar, rho, &
                             rho_mid)
    integer, intent(in) :: first, n_mirror
    integer, intent(in) :: mirror_of(n_mirror), mirror_plane(n_mirror), n_planes
    real(wp), intent(in) :: point(2, n_planes)
    real(wp), intent(inout) :: x_mid(:, :), v(:, :), v_bar(:, :), rho(:), rho_mid(:)
    integer :: k, i, e
    !$omp parallel do default(none) private(k, i, e) &
    !$omp shared(first, n_mirror, mirror_of, mirror_plane, point, x_mid, v, v_bar, rho, rho_mid)
    do k = 1, n_mirror
      i = mirror_of(k)
      e = first + k
      x_mid(1, e) = x_mid(1, i)
      x_mid(2, e) = 2.0_wp*point(2, mirror_plane(k)) - x_mid(2, i)
      v(1, e) = v(1, i)
      v(2, e) = -v(2, i)
      v_bar(1, e) = v_bar(1, i)
      v_bar(2, e) = -v_bar(2, i)
      rho(e) = rho(i)
      rho_mid(e) = rho(i)
    end do
    !$omp end parallel do
  end subroutine mirror_fill_mid

  !> Images of the mid-step density and stress, for the energy sums.
  subroutine mirror_fill_stress(first, n_mirror, mirror_of, rho_mid, sig_mid)
    integer, intent(in) :: first, n_mirror
    integer, intent(in) :: mirror_of(n_mirror)
    real(wp), intent(inout) :: rho_mid(:), sig_mid(:, :)
    integer :: k, i, e
    !$omp parallel do default(none) private(k, i, e) shared(first, n_mirror, mirror_of, rho_mid, sig_mid)
    do k = 1, n_mirror
      i = mirror_of(k)
      e = first + k
      rho_mid(e) = rho_mid(i)
      sig_mid(:, e) = sig_mid(:, i)
      sig_mid(3, e) = -sig_mid(3, i)
    end do
    !$omp end parallel do
  end subroutine mirror_fill_stress

  !> Axial force [N] of all the images on the n real particles: the sum,
  !> over each particle's entries of images (index above `first`, the last
  !> imaginary entry), of m_i m_j times the pair's force per unit masses
  !> (pair_force of fsph_sph sph_accelerations, computed for i's row). The
  !> planes take minus it. Each particle's sum is formed in its row order
  !> and the particles' sums in index order, so the bits do not depend on
  !> the thread count.
  function mirror_reaction_z(n, first, nbr_ptr, nbr_list, mass, pair_force) result(force_z)
    integer, intent(in) :: n, first
    integer, intent(in) :: nbr_ptr(n + 1), nbr_list(*)
    real(wp), intent(in) :: mass(*), pair_force(2, *)
    real(wp) :: force_z
    real(wp), allocatable :: f_i(:)
    integer :: i, k, j
    allocate (f_i(n))
    !$omp parallel do default(none) private(i, k, j) shared(n, first, nbr_ptr, nbr_list, mass, pair_force, f_i) &
    !$omp schedule(static)
    do i = 1, n
      f_i(i) = 0.0_wp
      do k = nbr_ptr(i), nbr_ptr(i + 1) - 1
        j = abs(nbr_list(k))
        if (j > first) f_i(i) = f_i(i) + mass(j)*pair_force(2, k)
      end do
      f_i(i) = mass(i)*f_i(i)
    end do
    !$omp end parallel do
    force_z = sum(f_i)
  end function mirror_reaction_z

end module fsph_mirror
