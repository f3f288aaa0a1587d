!> Particle-wise updates that are not SPH sums: density, energy and stress
!> update after the rates, and the penalty contact between particles of
!> different bodies.
module fsph_particles
  use fsph_kinds, only: wp, two_pi
  use fsph_status, only: status_ok, status_nonfinite_particle, status_eos_range, &
                         status_particle_axis
  use fsph_layouts, only: n_props, n_hist, prop_pmin, prop_shear, prop_rho0, eos_hjc
  use fsph_material, only: material_update, eos_pressure, sound_speed
  use fsph_ordered, only: first_fault
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use fsph_kernel, only: kernel_w, kernel_dwdr, in_support
  implicit none
  private

  public :: particle_state_update, particle_energy_update, particle_contact_accelerations

contains

  !> rho <- rho + dt drho, then the constitutive step of fsph_material
  !> (shared with elements): deviator, and the end-of-step pressure with a
  !> local energy estimate (the Wilkins p dv work of the step, solved with
  !> the equation of state), which the mid-step stress of the SPH energy
  !> equation needs; the energy itself is then integrated by that equation
  !> (particle_energy_update), which sets the final pressure. A particle
  !> whose density falls below debris_ratio times its reference density is
  !> debris (fragments that have separated: the particle's volume is mostly
  !> void): its density is held at that bound and it carries no stress.
  !> ierr/ifault: first particle with a non-positive radius position, a
  !> non-finite or non-positive density, a non-finite stress or a density
  !> beyond the range of its equation of state; n_debris the number of
  !> debris particles.
  subroutine particle_state_update(n, nmat, props, istrength, ieos, mat, dt, debris_ratio, x, drho, &
                                   d, spin, e, rho, s, p, eps_p, temp, hist, c, n_debris, ierr, ifault)
    integer, intent(in) :: n, nmat
    real(wp), intent(in) :: props(n_props, nmat)
    integer, intent(in) :: istrength(nmat), ieos(nmat), mat(n)
    real(wp), intent(in) :: debris_ratio  !< debris below this fraction of the reference density [-]
    real(wp), intent(in) :: dt, x(2, n), drho(n), d(4, n), spin(n)
    real(wp), intent(in) :: e(n)          !< specific internal energy at the start of the step [J/kg]
    real(wp), intent(inout) :: rho(n), s(4, n), p(n), eps_p(n), temp(n), c(n)
    real(wp), intent(inout) :: hist(n_hist, n)  !< material history (damage, ...)
    integer, intent(out) :: n_debris, ierr, ifault
    integer :: i, im, ierr_i, f_axis, f_nan, f_eos
    real(wp) :: rho_debris, rho_old, e_local
    f_axis = n + 1; f_nan = n + 1; f_eos = n + 1
    n_debris = 0
    !$omp parallel do default(none) &
    !$omp shared(n, props, istrength, ieos, mat, dt, debris_ratio, x, drho, d, spin, e) &
    !$omp shared(rho, s, p, eps_p, temp, hist, c) &
    !$omp private(i, im, ierr_i, rho_debris, rho_old, e_local) reduction(min:f_axis, f_nan, f_eos) &
    !$omp reduction(+:n_debris)
    do i = 1, n
      if (.not. (x(1, i) > 0.0_wp)) then
        f_axis = min(f_axis, i)
        cycle
      end if
      im = mat(i)
      rho_old = rho(i)
      rho(i) = rho_old + dt*drho(i)
      if (.not. (ieee_is_finite(rho(i)) .and. ieee_is_finite(e(i)))) then
        f_nan = min(f_nan, i)
        cycle
      end if
      rho_debris = debris_ratio*props(prop_rho0, im)
      if (rho(i) <= rho_debris) then
        rho(i) = rho_debris
        s(:, i) = 0.0_wp
        p(i) = 0.0_wp
        n_debris = n_debris + 1
        cycle
      end if
      if (.not. (rho(i) > 0.0_wp)) then
        f_nan = min(f_nan, i)
        cycle
      end if
      ! the pairwise viscosity does its work through the SPH energy sum
      e_local = e(i)
      call material_update(props(:, im), istrength(im), ieos(im), dt, d(:, i), spin(i), rho_old, rho(i), &
                           0.0_wp, s(:, i), p(i), eps_p(i), e_local, temp(i), hist(:, i), c(i), ierr_i)
      if (ierr_i /= status_ok) f_eos = min(f_eos, i)
      if (.not. (ieee_is_finite(p(i)) .and. all(ieee_is_finite(s(:, i))))) f_nan = min(f_nan, i)
    end do
    !$omp end parallel do
    call first_fault(n, [f_axis, f_nan, f_eos], [status_particle_axis, status_nonfinite_particle, status_eos_range], &
                     ierr, ifault)
  end subroutine particle_state_update

  !> Final internal energy e = e_old + dt de (de from the mid-step stress)
  !> and the pressure and sound speed that follow from it at the new
  !> density (the deviator is already final); debris keeps p = 0, HJC
  !> concrete its energy-independent pressure. ierr/ifault: the first
  !> particle with a non-finite energy or pressure, or a density beyond the
  !> range of its equation of state.
  subroutine particle_energy_update(n, nmat, props, ieos, mat, dt, debris_ratio, e_old, de, rho, e, p, c, &
                                    ierr, ifault)
    integer, intent(in) :: n, nmat
    real(wp), intent(in) :: props(n_props, nmat)
    integer, intent(in) :: ieos(nmat), mat(n)
    real(wp), intent(in) :: debris_ratio  !< debris below this fraction of the reference density [-]
    real(wp), intent(in) :: dt, e_old(n), de(n), rho(n)
    real(wp), intent(inout) :: e(n), p(n), c(n)
    integer, intent(out) :: ierr, ifault
    integer :: i, im, ierr_i, f_nan, f_eos
    real(wp) :: a, b, dadrho
    f_nan = n + 1
    f_eos = n + 1
    !$omp parallel do default(none) shared(n, props, ieos, mat, dt, debris_ratio, e_old, de, rho, e, p, c) &
    !$omp private(i, im, ierr_i, a, b, dadrho) reduction(min:f_nan, f_eos)
    do i = 1, n
      im = mat(i)
      e(i) = e_old(i) + dt*de(i)
      if (ieos(im) == eos_hjc .or. rho(i) <= debris_ratio*props(prop_rho0, im)) then
        ! energy-independent pressure with history, or debris: already final
        if (.not. ieee_is_finite(e(i))) f_nan = min(f_nan, i)
        cycle
      end if
      call eos_pressure(props(:, im), ieos(im), rho(i), a, b, dadrho, ierr_i)
      if (ierr_i /= status_ok) then
        f_eos = min(f_eos, i)
        cycle
      end if
      p(i) = max(a + b*e(i), props(prop_pmin, im))   ! spall cut-off, as for elements
      c(i) = sound_speed(props(prop_shear, im), dadrho, b, rho(i), p(i))
      if (.not. (ieee_is_finite(e(i)) .and. ieee_is_finite(p(i)))) f_nan = min(f_nan, i)
    end do
    !$omp end parallel do
    call first_fault(n, [f_nan, f_eos], [status_nonfinite_particle, status_eos_range], ierr, ifault)
  end subroutine particle_energy_update

  !> Contact between particles of different bodies (in the spirit of
  !> Campbell, Vignjevic & Libersky 2000, CMAME 184:49: the kernel detects
  !> the contact, no force crosses between bodies through the SPH sums). A
  !> particle i measures how much of its kernel support the other bodies
  !> fill, C_i = sum_j V_j W_ij (V_j = m_j/(2 pi r_j rho_j), the planar
  !> area of j), and the potential U = sum_i k_i/2 max(0, C_i - c_touch)^2
  !> acts once C_i exceeds its value c_touch for two lattices one spacing
  !> apart. The forces are -grad U:
  !>   F_i = -sum_j (e_i V_j + e_j V_i) dW/dr (x_i - x_j)/|x_i - x_j|,
  !> e_i = k_i max(0, C_i - c_touch), equal and opposite pair by pair
  !> (momentum conserved) and derived from a potential (no work in a
  !> closed cycle). C is smooth along a surface (sliding one lattice half
  !> a spacing along another changes it by under 1 %), so the contact is
  !> close to frictionless; a penalty on the overlap of particle discs,
  !> along the line of centres, acted as a friction that kept slowing an
  !> ogive rod after it had perforated a plate. Stiffness: k_i = penalty
  !> m_i Delta_i^2 / (dt^2 slope^2), so a normal approach delta changes C
  !> by slope delta/Delta_i and is pushed back by the fraction `penalty`
  !> per step (Delta_i = sqrt(V_i), slope = dC/d(y/Delta) at touching).
  subroutine particle_contact_accelerations(n, x, mass, area, h, cnt_ptr, cnt_list, dt, penalty, &
                                           c_touch, slope, excess, acc)
    integer, intent(in) :: n
    real(wp), intent(in) :: x(2, n), mass(n), h(n)
    real(wp), intent(in) :: area(n)     !< planar areas m/(2 pi r rho) [m^2]
    integer, intent(in) :: cnt_ptr(n + 1), cnt_list(*)
    real(wp), intent(in) :: dt          !< step the force acts over [s]
    real(wp), intent(in) :: penalty     !< fraction of an approach pushed back per step [-]
    real(wp), intent(in) :: c_touch     !< other-body filling at contact [-]
    real(wp), intent(in) :: slope       !< its rate per spacing of approach [-]
    real(wp), intent(out) :: excess(n)  !< work: each particle's contact stiffness times its excess filling
    real(wp), intent(inout) :: acc(2, n)
    integer :: i, k, j
    real(wp) :: dx(2), dist, f(2), dw
    !$omp parallel do default(none) shared(n, x, mass, h, cnt_ptr, cnt_list, dt, penalty, c_touch, slope) &
    !$omp shared(area, excess) private(i, k, j, dx, dist)
    do i = 1, n
      excess(i) = 0.0_wp
      if (cnt_ptr(i + 1) == cnt_ptr(i)) cycle
      do k = cnt_ptr(i), cnt_ptr(i + 1) - 1
        j = cnt_list(k)
        dx = x(:, i) - x(:, j)
        ! candidates beyond the support (the lists' skin) add nothing, by the
        ! search's own test
        if (.not. in_support(dx(1)**2 + dx(2)**2, h(i), h(j))) cycle
        dist = sqrt(dx(1)**2 + dx(2)**2)
        excess(i) = excess(i) + area(j)*kernel_w(dist, 0.5_wp*(h(i) + h(j)))
      end do
      excess(i) = penalty*mass(i)*area(i)/(dt*slope)**2*max(excess(i) - c_touch, 0.0_wp)
    end do
    !$omp end parallel do
    !$omp parallel do default(none) shared(n, x, mass, h, cnt_ptr, cnt_list, area, excess, acc) &
    !$omp private(i, k, j, dx, dist, f, dw)
    do i = 1, n
      f = 0.0_wp
      do k = cnt_ptr(i), cnt_ptr(i + 1) - 1
        j = cnt_list(k)
        if (excess(i) == 0.0_wp .and. excess(j) == 0.0_wp) cycle
        dx = x(:, i) - x(:, j)
        if (.not. in_support(dx(1)**2 + dx(2)**2, h(i), h(j))) cycle
        dist = sqrt(dx(1)**2 + dx(2)**2)
        if (dist <= 0.0_wp) cycle
        dw = kernel_dwdr(dist, 0.5_wp*(h(i) + h(j)))
        f = f - (excess(i)*area(j) + excess(j)*area(i))*dw*dx/dist
      end do
      acc(:, i) = acc(:, i) + f/mass(i)
    end do
    !$omp end parallel do
  end subroutine particle_contact_accelerations

end module fsph_particles
