!> Particle-wise updates that are not SPH sums: density, energy and stress
!> update after the rates, and the contact between particles of different
!> bodies (a contact potential, or pairwise Riemann pressures).
module fsph_particles
  use fsph_kinds, only: wp, pi, two_pi
  use fsph_status, only: status_ok, status_nonfinite_particle, status_eos_range, &
                         status_particle_axis
  use fsph_layouts, only: n_props, n_hist, prop_pmin, prop_shear, prop_rho0, eos_hjc, hist_viscous_work, &
                          hist_hourglass_work, hist_contact_work
  use fsph_material, only: material_update, eos_pressure, sound_speed, cut_pressure, state_temperature, &
                           melt_update, shear_modulus, point_failed
  use fsph_ordered, only: first_fault
  use fsph_sph, only: ghost_work, entry_sign
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use fsph_kernel, only: kernel_w, kernel_dwdr, kernel_gradient_factor, in_support
  implicit none
  private

  public :: particle_state_update, particle_energy_update, particle_contact_accelerations
  !> Below this fraction of the particles' normals' size a pair's normal
  !> difference is taken as no normal, and the line of centres is used [-].
  real(wp), parameter :: normal_floor = 1.0e-6_wp

  public :: riemann_contact_accelerations, riemann_contact_heat, riemann_contact_density_rate, contact_normals, &
            contact_pairs_in, riemann_pair
  public :: total_stress, keep_start_state, mid_step_state, point_intact

contains

  ! The particles' per-point steps of a cycle below run in the static
  ! blocks of every other particle loop (docs/performance.md, "Which core
  ! holds a particle"): written serially, each pulled every particle's
  ! data to the first thread's core and the next parallel loop pulled half
  ! of them back.

  !> Total stress sig = s - p I (rr, zz, rz, tt) [Pa] of the deviator s
  !> and the pressure p [Pa].
  subroutine total_stress(n, s, p, sig)
    integer, intent(in) :: n
    real(wp), intent(in) :: s(4, n), p(n)
    real(wp), intent(out) :: sig(4, n)
    integer :: i
    !$omp parallel do default(none) shared(n, s, p, sig) private(i)
    do i = 1, n
      sig(:, i) = s(:, i)
      sig([1, 2, 4], i) = sig([1, 2, 4], i) - p(i)
    end do
    !$omp end parallel do
  end subroutine total_stress

  !> The internal energy [J/kg] and density [kg/m^3] at the start of the
  !> step, kept before the particle update.
  subroutine keep_start_state(n, e, rho, e_old, rho_old)
    integer, intent(in) :: n
    real(wp), intent(in) :: e(n), rho(n)
    real(wp), intent(out) :: e_old(n), rho_old(n)
    integer :: i
    !$omp parallel do default(none) shared(n, e, rho, e_old, rho_old) private(i)
    do i = 1, n
      e_old(i) = e(i)
      rho_old(i) = rho(i)
    end do
    !$omp end parallel do
  end subroutine keep_start_state

  !> Mid-step total stress (the mean of the stress sig at the start of the
  !> step and of the end-of-step deviator s and pressure p) [Pa] and
  !> density (the mean of rho_old and rho) [kg/m^3].
  subroutine mid_step_state(n, sig, s, p, rho_old, rho, sig_mid, rho_mid)
    integer, intent(in) :: n
    real(wp), intent(in) :: sig(4, n), s(4, n), p(n), rho_old(n), rho(n)
    real(wp), intent(out) :: sig_mid(4, n), rho_mid(n)
    integer :: i
    !$omp parallel do default(none) shared(n, sig, s, p, rho_old, rho, sig_mid, rho_mid) private(i)
    do i = 1, n
      sig_mid(:, i) = 0.5_wp*(sig(:, i) + s(:, i))
      sig_mid([1, 2, 4], i) = sig_mid([1, 2, 4], i) - 0.5_wp*p(i)
      rho_mid(i) = 0.5_wp*(rho_old(i) + rho(i))
    end do
    !$omp end parallel do
  end subroutine mid_step_state

  !> 1 for an intact point, 0 for a failed one, by its history [-].
  subroutine point_intact(n, hist, intact)
    integer, intent(in) :: n
    real(wp), intent(in) :: hist(n_hist, n)
    real(wp), intent(out) :: intact(n)
    integer :: i
    !$omp parallel do default(none) shared(n, hist, intact) private(i)
    do i = 1, n
      intact(i) = merge(0.0_wp, 1.0_wp, point_failed(hist(:, i)))
    end do
    !$omp end parallel do
  end subroutine point_intact

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
      if (.not. (ieee_is_finite(p(i)) .and. all(ieee_is_finite(s(:, i))) .and. ieee_is_finite(eps_p(i)) &
                 .and. ieee_is_finite(temp(i)))) f_nan = min(f_nan, i)
    end do
    !$omp end parallel do
    call first_fault(n, [f_axis, f_nan, f_eos], [status_particle_axis, status_nonfinite_particle, status_eos_range], &
                     ierr, ifault)
  end subroutine particle_state_update

  !> Final internal energy e = e_old + dt de (de from the mid-step stress)
  !> and what follows from it at the new density: the pressure (not below
  !> the point's floor: spall cut-off, no tension once failed), the
  !> temperature of the state (model internal_energy; a plastic_work
  !> temperature is already final), melting (a molten point loses its
  !> deviator) and the sound speed; debris keeps p = 0, HJC concrete its
  !> energy-independent pressure. ierr/ifault: the first particle with a
  !> non-finite energy or pressure, or a density beyond the range of its
  !> equation of state.
  subroutine particle_energy_update(n, nmat, props, istrength, ieos, mat, dt, debris_ratio, e_old, de, de_parts, &
                                    rho, e, p, s, temp, hist, c, ierr, ifault)
    integer, intent(in) :: n, nmat
    real(wp), intent(in) :: props(n_props, nmat)
    integer, intent(in) :: istrength(nmat), ieos(nmat), mat(n)
    real(wp), intent(in) :: debris_ratio  !< debris below this fraction of the reference density [-]
    real(wp), intent(in) :: dt            !< time step [s]
    real(wp), intent(in) :: e_old(n)      !< specific internal energy at the start of the step [J/kg]
    real(wp), intent(in) :: de(n)         !< its rate [W/kg]
    real(wp), intent(in) :: de_parts(3, n) !< its viscous, hourglass and contact parts [W/kg], booked in hist
    real(wp), intent(in) :: rho(n)        !< density at the end of the step [kg/m^3]
    real(wp), intent(inout) :: e(n)       !< specific internal energy [J/kg]
    real(wp), intent(inout) :: p(n)       !< pressure [Pa]
    real(wp), intent(inout) :: s(4, n)    !< deviatoric stress [Pa]
    real(wp), intent(inout) :: temp(n)    !< temperature [K]
    real(wp), intent(inout) :: hist(n_hist, n) !< history variables (failed, melted, ...)
    real(wp), intent(inout) :: c(n)       !< sound speed [m/s]
    integer, intent(out) :: ierr, ifault
    integer :: i, im, ierr_i, f_nan, f_eos
    real(wp) :: a, b, dadrho
    f_nan = n + 1
    f_eos = n + 1
    !$omp parallel do default(none) &
    !$omp shared(n, props, istrength, ieos, mat, dt, debris_ratio, e_old, de, de_parts, rho, e, p, s, temp, hist, c) &
    !$omp private(i, im, ierr_i, a, b, dadrho) reduction(min:f_nan, f_eos)
    do i = 1, n
      im = mat(i)
      e(i) = e_old(i) + dt*de(i)
      hist(hist_viscous_work, i) = hist(hist_viscous_work, i) + dt*de_parts(1, i)
      hist(hist_hourglass_work, i) = hist(hist_hourglass_work, i) + dt*de_parts(2, i)
      hist(hist_contact_work, i) = hist(hist_contact_work, i) + dt*de_parts(3, i)
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
      p(i) = cut_pressure(props(:, im), hist(:, i), a + b*e(i))
      temp(i) = state_temperature(props(:, im), ieos(im), rho(i), e(i), hist(:, i), temp(i))
      call melt_update(props(:, im), rho(i), temp(i), s(:, i), hist(:, i))
      c(i) = sound_speed(shear_modulus(props(:, im), istrength(im), rho(i), p(i), temp(i)), dadrho, b, rho(i), p(i))
      if (.not. (ieee_is_finite(e(i)) .and. ieee_is_finite(p(i)) .and. ieee_is_finite(temp(i)))) &
        f_nan = min(f_nan, i)
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
        if (j < 0) cycle     ! mirror images across the axis: Riemann contact only
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
        if (j < 0) cycle
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

  !> Contact between particles of different bodies by pairwise Riemann
  !> pressures (Wang, Xu & Yang 2022, eqs 20-23; the acoustic Riemann
  !> solver of Godunov SPH, Inutsuka 2002, J. Comput. Phys. 179:238). For
  !> each pair of particles of different continua within the kernel support
  !> (and the mirror images of the other body across the axis), the 1D
  !> problem across the contact (riemann_pair, along the pair's contact
  !> normal, pair_normal) gives the contact pressure p* >= 0 and the
  !> interface velocity u*. p* acts in the pair sums of the momentum
  !> equation as a pressure on both sides, in the form of Wang, Xu & Yang's
  !> pair force -2 m_i m_j p*/(rho_i rho_j) grad W carried to r-z with
  !> full-ring masses:
  !>   a_i += -2 pi m_j p* (u_i + u_j) grad_i W,  u = 1/(4 pi^2 r rho_i rho_j),
  !> equal and opposite pair by pair (momentum to round-off). With
  !> 1/(rho_i rho_j), not the 1/rho^2 weights of the SPH stress sums, a
  !> neighbour counts by its volume, not its mass: with 1/rho^2 the copper
  !> particles of a copper-aluminium interface pushed the aluminium ones 3.3
  !> times (the density ratio) harder than the aluminium behind them held
  !> them, and the bodies stood two particle spacings apart with a velocity
  !> jump of 900 m/s across the gap. Unlike a penalty the force does not
  !> depend on the time step: at a 100 GPa impact it is the interface
  !> pressure itself. A mirror image of the other body is an entry of the
  !> odd extension, as in the SPH sums: the equilibrium part p_e acts with
  !> the signed weights (-u_i + u_j), the rest p* - p_e with (u_i + u_j), as
  !> the pairwise viscosity does. force(:, k) keeps each entry's
  !> acceleration per unit partner mass, v_star(:, k) the interface
  !> velocity (interface_velocity; riemann_contact_heat). normal:
  !> contact_normals at these positions.
  subroutine riemann_contact_accelerations(n, x, v, mass, rho, c, sig, h, normal, cnt_ptr, cnt_list, cnt_in, acc, &
                                           force, v_star, acc_axis)
    integer, intent(in) :: n
    real(wp), intent(in) :: x(2, n), v(2, n), mass(n), rho(n), c(n), h(n)
    real(wp), intent(in) :: sig(4, n)    !< total stress s - p I (rr, zz, rz, tt) [Pa]
    real(wp), intent(in) :: normal(2, n) !< towards the other bodies (contact_normals) [1/m]
    integer, intent(in) :: cnt_ptr(n + 1), cnt_list(*)
    logical, intent(in) :: cnt_in(*)     !< the contact pairs of this cycle (contact_pairs_in)
    real(wp), intent(inout) :: acc(2, n) !< [m/s^2]
    real(wp), intent(out) :: force(2, *) !< acceleration of i per unit mass of entry k [m/(kg s^2)]
    real(wp), intent(out) :: v_star(2, *) !< interface velocity of entry k [m/s]
    !> axial acceleration of the equilibrium part of the mirror images'
    !> forces (odd weights, as the images' stress terms of the SPH sums:
    !> fsph_sph axis_resultant) [m/s^2]
    real(wp), intent(inout) :: acc_axis(n)
    integer :: i, k, j
    real(wp) :: sg, dx(2), dist2, nij(2), p_eq, p_star, us, f(2), a(2), ui, uj, rho2, gn, a_axis
    !$omp parallel do default(none) schedule(static) &
    !$omp shared(n, x, v, mass, rho, c, sig, h, normal, cnt_ptr, cnt_list, cnt_in, acc, force, v_star) &
    !$omp shared(acc_axis) &
    !$omp private(i, k, j, sg, dx, dist2, nij, p_eq, p_star, us, f, a, ui, uj, rho2, gn, a_axis)
    do i = 1, n
      a = 0.0_wp
      a_axis = 0.0_wp
      do k = cnt_ptr(i), cnt_ptr(i + 1) - 1
        j = abs(cnt_list(k))
        sg = entry_sign(cnt_list(k))
        force(:, k) = 0.0_wp
        v_star(:, k) = 0.0_wp
        dx = [x(1, i) - sg*x(1, j), x(2, i) - x(2, j)]
        dist2 = dx(1)**2 + dx(2)**2
        if (.not. cnt_in(k)) cycle
        nij = pair_normal(normal(:, i), normal(:, j), sg, dx, dist2)
        call riemann_pair(nij, v(:, i), rho(i), c(i), sig(:, i), v(:, j), rho(j), c(j), sig(:, j), sg, &
                          p_eq, p_star, us)
        if (p_star == 0.0_wp) cycle
        rho2 = 4.0_wp*pi*pi*(rho(i)*rho(j))
        ui = 1.0_wp/(rho2*x(1, i))
        uj = 1.0_wp/(rho2*x(1, j))
        ! the kernel gradient across the contact, along the pair normal
        gn = kernel_gradient_factor(dist2, 2.0_wp/(h(i) + h(j)))*(dx(1)*nij(1) + dx(2)*nij(2))
        if (sg > 0.0_wp) then
          f = (-two_pi*p_star*(ui + uj)*gn)*nij
        else
          f = (-two_pi*(p_eq*(uj - ui) + (p_star - p_eq)*(ui + uj))*gn)*nij
          a_axis = a_axis + mass(j)*((-two_pi*p_eq*(uj - ui)*gn)*nij(2))
        end if
        force(:, k) = f
        v_star(:, k) = us*nij
        a = a + mass(j)*f
      end do
      acc(:, i) = acc(:, i) + a
      acc_axis(i) = acc_axis(i) + a_axis
    end do
    !$omp end parallel do
  end subroutine riemann_contact_accelerations

  !> The contact pairs of this cycle: the listed entries within the kernel
  !> support at the start of the cycle, by the search's own test (as the
  !> SPH sums' pair_in), so that the mid-step sums of the contact use the
  !> same pairs and a run is the same bit for bit whatever the lists' skin.
  subroutine contact_pairs_in(n, x, h, cnt_ptr, cnt_list, cnt_in)
    integer, intent(in) :: n
    real(wp), intent(in) :: x(2, n), h(n)
    integer, intent(in) :: cnt_ptr(n + 1), cnt_list(*)
    logical, intent(out) :: cnt_in(*)
    integer :: i, k, j
    real(wp) :: sg, dist2
    !$omp parallel do default(none) schedule(static) shared(n, x, h, cnt_ptr, cnt_list, cnt_in) &
    !$omp private(i, k, j, sg, dist2)
    do i = 1, n
      do k = cnt_ptr(i), cnt_ptr(i + 1) - 1
        j = abs(cnt_list(k))
        sg = entry_sign(cnt_list(k))
        dist2 = (x(1, i) - sg*x(1, j))**2 + (x(2, i) - x(2, j))**2
        cnt_in(k) = in_support(dist2, h(i), h(j)) .and. dist2 > 0.0_wp
      end do
    end do
    !$omp end parallel do
  end subroutine contact_pairs_in

  !> Contact normal of every particle [1/m]: the gradient of the other
  !> bodies' filling of its kernel, sum_j A_j grad_i W over its contact
  !> entries (A_j the planar area of j, m_j/(2 pi r_j rho_j); mirror images
  !> across the axis as their particle), pointing towards the other bodies.
  !> Not normalised: pair_normal combines two of them.
  subroutine contact_normals(n, x, mass, rho, h, cnt_ptr, cnt_list, cnt_in, normal)
    integer, intent(in) :: n
    real(wp), intent(in) :: x(2, n), mass(n), rho(n), h(n)
    integer, intent(in) :: cnt_ptr(n + 1), cnt_list(*)
    logical, intent(in) :: cnt_in(*)     !< the contact pairs of this cycle (contact_pairs_in)
    real(wp), intent(out) :: normal(2, n)
    integer :: i, k, j
    real(wp) :: sg, dx(2), dist2, g(2)
    !$omp parallel do default(none) schedule(static) &
    !$omp shared(n, x, mass, rho, h, cnt_ptr, cnt_list, cnt_in, normal) private(i, k, j, sg, dx, dist2, g)
    do i = 1, n
      g = 0.0_wp
      do k = cnt_ptr(i), cnt_ptr(i + 1) - 1
        j = abs(cnt_list(k))
        sg = entry_sign(cnt_list(k))
        dx = [x(1, i) - sg*x(1, j), x(2, i) - x(2, j)]
        dist2 = dx(1)**2 + dx(2)**2
        if (.not. cnt_in(k)) cycle
        ! grad_i W = factor dx with factor < 0 points from i to j
        g = g + mass(j)/(two_pi*x(1, j)*rho(j))*kernel_gradient_factor(dist2, 2.0_wp/(h(i) + h(j)))*dx
      end do
      normal(:, i) = g
    end do
    !$omp end parallel do
  end subroutine contact_normals

  !> Unit normal of a contact pair, from i's side towards j's [-]: the
  !> difference of the two particles' contact normals (j's mirrored for a
  !> mirror image, sg = -1), so that the pair seen from j has exactly the
  !> opposite one; the line of centres where the two cancel (a particle
  !> wholly surrounded). Along it the Riemann problem sees only the bodies'
  !> approach: two lattices sliding past each other under pressure have no
  !> normal velocity difference, where along the oblique lines of centres
  !> the acoustic term resisted every sliding pair as a viscosity (the pure
  !> SPH rod through the 508 m/s plate left at 272 m/s, still slowing,
  !> against 430 m/s adaptive).
  pure function pair_normal(normal_i, normal_j, sg, dx, dist2) result(nij)
    real(wp), intent(in) :: normal_i(2), normal_j(2), sg, dx(2), dist2
    real(wp) :: nij(2), d(2), len2
    d = [normal_i(1) - sg*normal_j(1), normal_i(2) - normal_j(2)]
    len2 = d(1)**2 + d(2)**2
    if (len2 > normal_floor**2*((normal_i(1)**2 + normal_i(2)**2) + (normal_j(1)**2 + normal_j(2)**2))) then
      nij = d/sqrt(len2)
    else
      nij = -dx/sqrt(dist2)
    end if
  end function pair_normal

  !> The acoustic Riemann problem of one contact pair across the unit
  !> normal n (from i towards j): left state (Z_i = rho_i c_i, u_i = v_i.n,
  !> p_i = -n.sig_i.n), right state likewise for j (seen with sign sg: a
  !> mirror image has -v_r and -sigma_rz). Contact pressure
  !>   p* = max(0, [Z_i p_j + Z_j p_i + Z_i Z_j (u_i - u_j)]/(Z_i + Z_j))
  !> (bodies push, never pull), its equilibrium part p_eq = (Z_i p_j +
  !> Z_j p_i)/(Z_i + Z_j) and the interface velocity
  !>   u* = [Z_i u_i + Z_j u_j + (p_i - p_j)]/(Z_i + Z_j).
  !> Written so that the pair seen from j (normal -n) gives the same p* and
  !> -u* to the last bit. Two sides without impedance (molten particles
  !> expanded until their EOS gives no sound speed: c = 0 on both) make
  !> these 0/0; there the limit of two equal impedances going to zero
  !> stands for them, p_eq the mean of p_i and p_j and u* the mean of u_i
  !> and u_j (the pressure's limit; the velocity's has no limit, and no
  !> wave carries one side's velocity to the other).
  pure subroutine riemann_pair(nij, vi, rho_i, c_i, sig_i, vj, rho_j, c_j, sig_j, sg, p_eq, p_star, u_star)
    real(wp), intent(in) :: nij(2), vi(2), rho_i, c_i, sig_i(4), vj(2), rho_j, c_j, sig_j(4), sg
    real(wp), intent(out) :: p_eq, p_star, u_star
    real(wp) :: zi, zj, pi_n, pj_n, ui, uj
    zi = rho_i*c_i
    zj = rho_j*c_j
    ui = vi(1)*nij(1) + vi(2)*nij(2)
    uj = sg*vj(1)*nij(1) + vj(2)*nij(2)
    pi_n = -normal_stress(sig_i, 1.0_wp, nij)
    pj_n = -normal_stress(sig_j, sg, nij)
    if (zi + zj > 0.0_wp) then
      p_eq = (zi*pj_n + zj*pi_n)/(zi + zj)
      p_star = max(p_eq + zi*zj*(ui - uj)/(zi + zj), 0.0_wp)
      u_star = (zi*ui + zj*uj + (pi_n - pj_n))/(zi + zj)
    else
      p_eq = 0.5_wp*(pi_n + pj_n)
      p_star = max(p_eq, 0.0_wp)
      u_star = 0.5_wp*(ui + uj)
    end if
  end subroutine riemann_pair

  !> Normal stress e.sig.e [Pa] of an in-plane direction e for a stress
  !> (rr, zz, rz, tt), its rz component seen with sign sg (a mirror image
  !> across the axis: -1).
  pure real(wp) function normal_stress(sig, sg, e) result(snn)
    real(wp), intent(in) :: sig(4), sg, e(2)
    snn = sig(1)*e(1)*e(1) + 2.0_wp*sg*sig(3)*e(1)*e(2) + sig(2)*e(2)*e(2)
  end function normal_stress

  !> Heat of the Riemann contact [J/(kg s)], added to de: the kinetic
  !> energy its pair forces remove, charged at the velocities v_bar (the
  !> mean of the velocities before and after the kick, under which the
  !> central difference balances kinetic energy). A pair of particles
  !> shares its work as Godunov SPH does: each particle takes the work of
  !> its force on its own motion relative to the interface velocity v*
  !> (interface_velocity), -m_j f . (v_i - v*), so the particle that moves more against the
  !> interface (the softer material) is heated more, and the two shares add
  !> up to the work of the pair exactly (the pair seen from j has the same
  !> v* and the opposite force). A mirror image is not a particle of its
  !> own: the heat of its entry is minus the work of its force on the
  !> particle, axially relative to the image (fsph_sph ghost_work).
  subroutine riemann_contact_heat(n, v_bar, mass, cnt_ptr, cnt_list, force, v_star, de, de_parts)
    integer, intent(in) :: n
    real(wp), intent(in) :: v_bar(2, n), mass(n)
    integer, intent(in) :: cnt_ptr(n + 1), cnt_list(*)
    real(wp), intent(in) :: force(2, *), v_star(2, *)
    real(wp), intent(inout) :: de(n)
    real(wp), intent(inout) :: de_parts(3, n) !< row 3 out: energy the contact gives the particle, for the books [W/kg]
    integer :: i, k, j
    real(wp) :: heat, given
    !$omp parallel do default(none) schedule(static) &
    !$omp shared(n, v_bar, mass, cnt_ptr, cnt_list, force, v_star, de, de_parts) private(i, k, j, heat, given)
    do i = 1, n
      heat = 0.0_wp
      given = 0.0_wp
      do k = cnt_ptr(i), cnt_ptr(i + 1) - 1
        j = abs(cnt_list(k))
        if (cnt_list(k) < 0) then
          heat = heat - mass(j)*ghost_work(force(:, k), v_bar(:, i), v_bar(2, j))
          ! the force's work on the motion plus the heat: axially at the
          ! mean of the particle's and the image's velocities
          given = given + mass(j)*0.5_wp*force(2, k)*(v_bar(2, i) + v_bar(2, j))
        else
          heat = heat - mass(j)*(force(1, k)*(v_bar(1, i) - v_star(1, k)) + force(2, k)*(v_bar(2, i) - v_star(2, k)))
          ! the force's work on the motion plus the heat: at the interface velocity
          given = given + mass(j)*(force(1, k)*v_star(1, k) + force(2, k)*v_star(2, k))
        end if
      end do
      de(i) = de(i) + heat
      de_parts(3, i) = given
    end do
    !$omp end parallel do
  end subroutine riemann_contact_heat

  !> The contact's part of the density rate [kg/(m^3 s)], added to drho:
  !> the other body fills part of a particle's kernel and moves at the
  !> interface velocity v* (interface_velocity, riemann_pair at these
  !> positions and velocities, normal from contact_normals at them), so while the bodies
  !> press (p* > 0) the particle is compressed by its approach to the
  !> interface as by a neighbour of its own material of the same volume:
  !>   d eta_i/dt += sum_j 2 pi rho_i A_j (r_i + r_j) (v_i - v*) . grad_i W,
  !> eta = 2 pi r rho (the planar-density continuity of the SPH sums,
  !> fsph_sph), A_j the planar area of j; a mirror image has r_j -> -r_j,
  !> the odd extension, so that next to the axis a particle's image pairs
  !> add up to its planar compression. In one material u* is the mean of
  !> the pair's velocities and, for r_i = r_j, this is the continuity sum
  !> m_j (v_i - v_j) . grad W of a neighbour; across an interface the
  !> softer side takes the larger share of the compression. Its p* dv work
  !> is, pair by pair, the heat riemann_contact_heat books for the pair's
  !> force (ring-weighted with (r_i + r_j)/2 as that force). Without it the
  !> particles next to the interface were not compressed by the other body
  !> and the contact acted as a dashpot: in a steel plate striking an
  !> aluminium one at 100 m/s the interface rows kept a velocity jump of
  !> 15 m/s and 25 % less stress than the bulk.
  subroutine riemann_contact_density_rate(n, x, v, mass, rho, c, sig, h, normal, cnt_ptr, cnt_list, cnt_in, drho)
    integer, intent(in) :: n
    real(wp), intent(in) :: x(2, n), v(2, n), mass(n), rho(n), c(n), h(n)
    real(wp), intent(in) :: sig(4, n)    !< total stress of the start of the step [Pa]
    real(wp), intent(in) :: normal(2, n) !< contact normals at these positions [1/m]
    integer, intent(in) :: cnt_ptr(n + 1), cnt_list(*)
    logical, intent(in) :: cnt_in(*)     !< the contact pairs of this cycle (contact_pairs_in)
    real(wp), intent(inout) :: drho(n)   !< [kg/(m^3 s)]
    integer :: i, k, j
    real(wp) :: sg, dx(2), dist2, nij(2), p_eq, p_star, us, gn, deta
    !$omp parallel do default(none) schedule(static) &
    !$omp shared(n, x, v, mass, rho, c, sig, h, normal, cnt_ptr, cnt_list, cnt_in, drho) &
    !$omp private(i, k, j, sg, dx, dist2, nij, p_eq, p_star, us, gn, deta)
    do i = 1, n
      deta = 0.0_wp
      do k = cnt_ptr(i), cnt_ptr(i + 1) - 1
        j = abs(cnt_list(k))
        sg = entry_sign(cnt_list(k))
        dx = [x(1, i) - sg*x(1, j), x(2, i) - x(2, j)]
        dist2 = dx(1)**2 + dx(2)**2
        if (.not. cnt_in(k) .or. dist2 <= 0.0_wp) cycle
        nij = pair_normal(normal(:, i), normal(:, j), sg, dx, dist2)
        call riemann_pair(nij, v(:, i), rho(i), c(i), sig(:, i), v(:, j), rho(j), c(j), sig(:, j), sg, &
                          p_eq, p_star, us)
        if (p_star == 0.0_wp) cycle
        gn = kernel_gradient_factor(dist2, 2.0_wp/(h(i) + h(j)))*(dx(1)*nij(1) + dx(2)*nij(2))
        ! 2 pi rho_i A_j (r_i + r_j), A_j = m_j/(2 pi r_j rho_j) the planar area of j
        deta = deta + rho(i)*mass(j)/(x(1, j)*rho(j))*(x(1, i) + sg*x(1, j)) &
                      *((v(1, i)*nij(1) + v(2, i)*nij(2)) - us)*gn
      end do
      drho(i) = drho(i) + deta/(two_pi*x(1, i))
    end do
    !$omp end parallel do
  end subroutine riemann_contact_density_rate

end module fsph_particles
