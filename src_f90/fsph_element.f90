!> Axisymmetric constant-strain triangles (T3): geometry, strain rates, nodal
!> forces, artificial viscosity, stress update driver and stable time step
!> (after EPIC, Johnson et al. 1997). Kernels take sizes first, then explicit-shape
!> arrays; they hold no module state and are threaded over elements.
!>
!> Coordinates x(1,:) = r (radius), x(2,:) = z (axis) [m]; nodes of each
!> element counter-clockwise in the (r, z) plane.
module fsph_element
  use fsph_kinds, only: wp, two_pi, one_third
  use fsph_status, only: status_ok, status_inverted_element, status_nonfinite_element, &
                         status_eos_range
  use fsph_layouts, only: n_props, n_hist, strength_epp, strength_johnson_cook, eos_mie_gruneisen
  use fsph_material, only: material_update
  use fsph_ordered, only: first_fault, merge_minimum
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  implicit none
  private

  public :: tri_gradients, tri_size, element_geometry, element_strain_rates, element_corner_forces
  public :: gather_corner_forces, element_update, element_time_step, element_step

contains

  !> Area, shape-function gradients and centroid radius of one triangle.
  !> One division (the reciprocal of 2A) serves the six gradients: a
  !> division costs the processor several multiplications' time.
  pure subroutine tri_gradients(xe, area, dndr, dndz, rbar)
    real(wp), intent(in) :: xe(2, 3)       !< nodal (r, z) [m]
    real(wp), intent(out) :: area          !< signed area [m^2]
    real(wp), intent(out) :: dndr(3), dndz(3) !< dN_a/dr, dN_a/dz [1/m]
    real(wp), intent(out) :: rbar          !< centroid radius [m]
    real(wp) :: r1, z1, r2, z2, r3, z3, two_a, inv
    r1 = xe(1, 1); z1 = xe(2, 1)
    r2 = xe(1, 2); z2 = xe(2, 2)
    r3 = xe(1, 3); z3 = xe(2, 3)
    two_a = (r2 - r1)*(z3 - z1) - (r3 - r1)*(z2 - z1)
    area = 0.5_wp*two_a
    rbar = (r1 + r2 + r3)*one_third
    inv = 0.0_wp
    if (two_a > 0.0_wp) inv = 1.0_wp/two_a
    dndr(1) = (z2 - z3)*inv; dndz(1) = (r3 - r2)*inv
    dndr(2) = (z3 - z1)*inv; dndz(2) = (r1 - r3)*inv
    dndr(3) = (z1 - z2)*inv; dndz(3) = (r2 - r1)*inv
  end subroutine tri_gradients

  !> Area, centroid radius and smallest altitude of one triangle.
  pure subroutine tri_size(xe, area, rbar, lmin)
    real(wp), intent(in) :: xe(2, 3)       !< nodal (r, z) [m]
    real(wp), intent(out) :: area          !< signed area [m^2]
    real(wp), intent(out) :: rbar          !< centroid radius [m]
    real(wp), intent(out) :: lmin          !< smallest altitude 2A/longest edge [m]
    real(wp) :: two_a, lmax2
    two_a = (xe(1, 2) - xe(1, 1))*(xe(2, 3) - xe(2, 1)) - (xe(1, 3) - xe(1, 1))*(xe(2, 2) - xe(2, 1))
    area = 0.5_wp*two_a
    rbar = (xe(1, 1) + xe(1, 2) + xe(1, 3))*one_third
    lmax2 = max((xe(1, 2) - xe(1, 1))**2 + (xe(2, 2) - xe(2, 1))**2, &
                (xe(1, 3) - xe(1, 2))**2 + (xe(2, 3) - xe(2, 2))**2, &
                (xe(1, 1) - xe(1, 3))**2 + (xe(2, 1) - xe(2, 3))**2)
    lmin = two_a/sqrt(lmax2)
  end subroutine tri_size

  !> Area, centroid radius, ring volume and smallest altitude of all
  !> elements. ierr = status_inverted_element with ifault the first element
  !> (lowest index) whose area is not positive.
  subroutine element_geometry(ne, nn, conn, x, area, rbar, volume, lmin, ierr, ifault)
    integer, intent(in) :: ne, nn
    integer, intent(in) :: conn(3, ne)
    real(wp), intent(in) :: x(2, nn)
    real(wp), intent(out) :: area(ne), rbar(ne), volume(ne), lmin(ne)
    integer, intent(out) :: ierr, ifault
    real(wp) :: xe(2, 3)
    integer :: ie
    ifault = ne + 1
    !$omp parallel do default(none) shared(ne, conn, x, area, rbar, volume, lmin) &
    !$omp private(ie, xe) reduction(min:ifault)
    do ie = 1, ne
      xe = x(:, conn(:, ie))
      call tri_size(xe, area(ie), rbar(ie), lmin(ie))
      volume(ie) = two_pi*rbar(ie)*area(ie)
      if (.not. (area(ie) > 0.0_wp)) ifault = min(ifault, ie)
    end do
    !$omp end parallel do
    call first_fault(ne, [ifault], [status_inverted_element], ierr, ifault)
  end subroutine element_geometry

  !> Strain rates (rr, zz, rz, tt; tensor components) and in-plane spin of
  !> one element from its nodal positions and velocities:
  !>   d_rr = sum dN/dr v_r, d_zz = sum dN/dz v_z,
  !>   d_rz = 1/2 sum (dN/dz v_r + dN/dr v_z), d_tt = mean(v_r)/rbar,
  !>   spin = 1/2 sum (dN/dz v_r - dN/dr v_z).
  pure subroutine tri_strain_rates(xe, ve, d, spin)
    real(wp), intent(in) :: xe(2, 3)       !< nodal positions [m]
    real(wp), intent(in) :: ve(2, 3)       !< nodal velocities [m/s]
    real(wp), intent(out) :: d(4)          !< strain rates [1/s]
    real(wp), intent(out) :: spin          !< spin [1/s]
    real(wp) :: dndr(3), dndz(3), area, rbar, dvrdz, dvzdr
    call tri_gradients(xe, area, dndr, dndz, rbar)
    dvrdz = dndz(1)*ve(1, 1) + dndz(2)*ve(1, 2) + dndz(3)*ve(1, 3)
    dvzdr = dndr(1)*ve(2, 1) + dndr(2)*ve(2, 2) + dndr(3)*ve(2, 3)
    d(1) = dndr(1)*ve(1, 1) + dndr(2)*ve(1, 2) + dndr(3)*ve(1, 3)
    d(2) = dndz(1)*ve(2, 1) + dndz(2)*ve(2, 2) + dndz(3)*ve(2, 3)
    d(3) = 0.5_wp*(dvrdz + dvzdr)
    if (rbar > 0.0_wp) then
      d(4) = (ve(1, 1) + ve(1, 2) + ve(1, 3))*one_third/rbar
    else
      d(4) = 0.0_wp
    end if
    spin = 0.5_wp*(dvrdz - dvzdr)
  end subroutine tri_strain_rates

  !> Strain rates and spin of every element (tri_strain_rates) at the
  !> geometry x.
  subroutine element_strain_rates(ne, nn, conn, x, v, d, spin)
    integer, intent(in) :: ne, nn
    integer, intent(in) :: conn(3, ne)
    real(wp), intent(in) :: x(2, nn)       !< nodal positions [m]
    real(wp), intent(in) :: v(2, nn)       !< nodal velocities [m/s]
    real(wp), intent(out) :: d(4, ne)      !< strain rates [1/s]
    real(wp), intent(out) :: spin(ne)      !< spin [1/s]
    integer :: ie
    !$omp parallel do default(none) shared(ne, conn, x, v, d, spin) private(ie)
    do ie = 1, ne
      call tri_strain_rates(x(:, conn(:, ie)), v(:, conn(:, ie)), d(:, ie), spin(ie))
    end do
    !$omp end parallel do
  end subroutine element_strain_rates

  !> Internal nodal forces -int B^T sigma dV of every element, written per
  !> corner (no shared writes):
  !>   f_a^r = -2 pi rbar A (s_rr dN_a/dr + s_rz dN_a/dz) - 2 pi A s_tt / 3
  !>   f_a^z = -2 pi rbar A (s_rz dN_a/dr + s_zz dN_a/dz)
  !> with sigma = s - (p + q) I the total Cauchy stress.
  subroutine element_corner_forces(ne, nn, conn, x, s, p, q, fc)
    integer, intent(in) :: ne, nn
    integer, intent(in) :: conn(3, ne)
    real(wp), intent(in) :: x(2, nn)
    real(wp), intent(in) :: s(4, ne)       !< deviatoric stress [Pa]
    real(wp), intent(in) :: p(ne), q(ne)   !< pressure, viscous pressure [Pa]
    real(wp), intent(out) :: fc(2, 3, ne)  !< corner forces [N]
    real(wp) :: xe(2, 3), dndr(3), dndz(3), area, rbar, srr, szz, srz, stt, vol
    integer :: ie
    !$omp parallel do default(none) shared(ne, conn, x, s, p, q, fc) &
    !$omp private(ie, xe, dndr, dndz, area, rbar, srr, szz, srz, stt, vol)
    do ie = 1, ne
      xe = x(:, conn(:, ie))
      call tri_gradients(xe, area, dndr, dndz, rbar)
      srr = s(1, ie) - p(ie) - q(ie)
      szz = s(2, ie) - p(ie) - q(ie)
      srz = s(3, ie)
      stt = s(4, ie) - p(ie) - q(ie)
      vol = two_pi*rbar*area
      fc(1, :, ie) = -vol*(srr*dndr + srz*dndz) - two_pi*one_third*area*stt
      fc(2, :, ie) = -vol*(srz*dndr + szz*dndz)
    end do
    !$omp end parallel do
  end subroutine element_corner_forces

  !> Nodal forces as the sum of corner forces, through the node-to-corner
  !> map (CSR: corners of node a are corner_list(corner_ptr(a):corner_ptr(a+1)-1),
  !> each encoded as 3*(element-1) + local corner). The summation order is
  !> fixed, so the result does not depend on the thread count.
  subroutine gather_corner_forces(nn, ne, ncorner, corner_ptr, corner_list, fc, f)
    integer, intent(in) :: nn, ne, ncorner
    integer, intent(in) :: corner_ptr(nn + 1), corner_list(ncorner)
    real(wp), intent(in) :: fc(2, 3*ne)
    real(wp), intent(out) :: f(2, nn)      !< nodal forces [N]
    integer :: a, k
    !$omp parallel do default(none) shared(nn, corner_ptr, corner_list, fc, f) private(a, k)
    do a = 1, nn
      f(:, a) = 0.0_wp
      do k = corner_ptr(a), corner_ptr(a + 1) - 1
        f(:, a) = f(:, a) + fc(:, corner_list(k))
      end do
    end do
    !$omp end parallel do
  end subroutine gather_corner_forces

  !> Artificial viscosity, density and constitutive update of one element
  !> over one step. q = rho (C_Q L tr d)^2 + C_L rho c L |tr d| in
  !> compression (tr d < 0), 0 otherwise, L = sqrt(A) [m]. ierr is the
  !> material's status.
  pure subroutine element_point_update(props, istrength, ieos, dt, c_q, c_l, d, spin, mass, volume, area, &
                                       rho, q, s, p, eps_p, e, temp, hist, c, ierr)
    real(wp), intent(in) :: props(n_props)
    integer, intent(in) :: istrength, ieos
    real(wp), intent(in) :: dt, c_q, c_l   !< step [s]; quadratic and linear viscosity coefficients [-]
    real(wp), intent(in) :: d(4), spin     !< strain rates and spin of the step [1/s]
    real(wp), intent(in) :: mass           !< ring mass [kg]
    real(wp), intent(in) :: volume, area   !< ring volume [m^3] and area [m^2] at the end of the step
    real(wp), intent(inout) :: rho         !< density [kg/m^3]: start of step in, end out
    real(wp), intent(inout) :: q           !< artificial viscous pressure [Pa]: the last step's in, this step's out
    real(wp), intent(inout) :: s(4), p, eps_p, e, temp, c
    real(wp), intent(inout) :: hist(n_hist) !< material history (damage, ...)
    integer, intent(out) :: ierr
    real(wp) :: rho_new, trace, len, q_old
    real(wp) :: q_mean                     !< viscous pressure over the step [Pa]
    rho_new = mass/volume
    trace = d(1) + d(2) + d(4)
    q_old = q
    q = 0.0_wp
    if (trace < 0.0_wp) then
      len = sqrt(area)
      q = rho_new*(c_q*len*trace)**2 + c_l*rho_new*c*len*abs(trace)
    end if
    ! the viscous work of the step at the mean of the q that pushed the
    ! nodes in it (the last step's) and this step's, as the pressure's
    ! (trapezoidal): charged at this step's q alone, an element compressed
    ! in one step by a contact (a flyer striking at 5.5 km/s) booked work
    ! its forces never did (+2.7 % energy in one cycle)
    q_mean = 0.5_wp*(q_old + q)
    ! the constitutive update; for the pairs of models most elements carry
    ! (elastic-perfectly-plastic and Johnson-Cook metals with the
    ! Mie-Grueneisen EOS) the switches go in as constants, and the compiler
    ! makes material_update and the model routines under it a copy for that
    ! pair with its switches resolved, inlined here (fsph_material's build,
    ! meson.build): one source, the same results
    if (ieos == eos_mie_gruneisen .and. istrength == strength_epp) then
      call material_update(props, strength_epp, eos_mie_gruneisen, dt, d, spin, rho, rho_new, q_mean, s, p, &
                           eps_p, e, temp, hist, c, ierr)
    else if (ieos == eos_mie_gruneisen .and. istrength == strength_johnson_cook) then
      call material_update(props, strength_johnson_cook, eos_mie_gruneisen, dt, d, spin, rho, rho_new, q_mean, s, p, &
                           eps_p, e, temp, hist, c, ierr)
    else
      call material_update(props, istrength, ieos, dt, d, spin, rho, rho_new, q_mean, s, p, &
                           eps_p, e, temp, hist, c, ierr)
    end if
    rho = rho_new
  end subroutine element_point_update

  !> The element part of a cycle after the nodes have moved, in one pass
  !> over the elements (each element's data is read once): strain rates
  !> and spin at the mid-step positions x_mid with the half-step
  !> velocities, the geometry at the new positions x (area, centroid
  !> radius, ring volume, smallest altitude), then viscosity, density and
  !> the constitutive update (element_point_update). ierr/ifault: the
  !> first element (lowest index) that has inverted (area <= 0; its
  !> material is left as it was), else the first with a non-finite stress
  !> or energy, else the first beyond the range of its equation of state.
  subroutine element_update(ne, nn, nmat, conn, x_mid, x, v, props, istrength, ieos, mat, dt, c_q, c_l, &
                            mass, d, spin, area, rbar, volume, lmin, rho, q, s, p, eps_p, e, temp, hist, c, &
                            ierr, ifault)
    integer, intent(in) :: ne, nn, nmat
    integer, intent(in) :: conn(3, ne)
    real(wp), intent(in) :: x_mid(2, nn), x(2, nn) !< mid-step and new nodal positions [m]
    real(wp), intent(in) :: v(2, nn)       !< half-step nodal velocities [m/s]
    real(wp), intent(in) :: props(n_props, nmat)
    integer, intent(in) :: istrength(nmat), ieos(nmat), mat(ne)
    real(wp), intent(in) :: dt, c_q, c_l   !< step [s]; viscosity coefficients [-]
    real(wp), intent(in) :: mass(ne)       !< element ring mass [kg]
    real(wp), intent(out) :: d(4, ne), spin(ne)  !< strain rates and spin of the step [1/s]
    real(wp), intent(out) :: area(ne), rbar(ne), volume(ne), lmin(ne) !< new geometry [m^2, m, m^3, m]
    real(wp), intent(inout) :: rho(ne)     !< density [kg/m^3]: start of step in, end out
    real(wp), intent(inout) :: q(ne)       !< artificial viscous pressure [Pa]: the last step's in, this step's out
    real(wp), intent(inout) :: s(4, ne), p(ne), eps_p(ne), e(ne), temp(ne), c(ne)
    real(wp), intent(inout) :: hist(n_hist, ne)  !< material history (damage, ...)
    integer, intent(out) :: ierr, ifault
    integer :: ie, im, ierr_e, ifault_inv, ifault_eos, ifault_nan, k, a
    real(wp) :: xm(2, 3), ve(2, 3), xe(2, 3)
    ifault_inv = ne + 1
    ifault_eos = ne + 1
    ifault_nan = ne + 1
    !$omp parallel do default(none) &
    !$omp shared(ne, conn, x_mid, x, v, props, istrength, ieos, mat, dt, c_q, c_l, mass) &
    !$omp shared(d, spin, area, rbar, volume, lmin, rho, q, s, p, eps_p, e, temp, hist, c) &
    !$omp private(ie, im, ierr_e, k, a, xm, ve, xe) reduction(min:ifault_inv, ifault_eos, ifault_nan)
    do ie = 1, ne
      do k = 1, 3
        a = conn(k, ie)
        xm(:, k) = x_mid(:, a)
        ve(:, k) = v(:, a)
        xe(:, k) = x(:, a)
      end do
      call tri_strain_rates(xm, ve, d(:, ie), spin(ie))
      call tri_size(xe, area(ie), rbar(ie), lmin(ie))
      volume(ie) = two_pi*rbar(ie)*area(ie)
      if (.not. (area(ie) > 0.0_wp)) then
        ifault_inv = min(ifault_inv, ie)
        q(ie) = 0.0_wp
        cycle
      end if
      im = mat(ie)
      call element_point_update(props(:, im), istrength(im), ieos(im), dt, c_q, c_l, d(:, ie), spin(ie), &
                                mass(ie), volume(ie), area(ie), rho(ie), q(ie), s(:, ie), p(ie), eps_p(ie), &
                                e(ie), temp(ie), hist(:, ie), c(ie), ierr_e)
      if (ierr_e /= status_ok) ifault_eos = min(ifault_eos, ie)
      ! one test: a NaN or infinity in any of them makes the sum non-finite
      if (.not. ieee_is_finite(p(ie) + e(ie) + s(1, ie) + s(2, ie) + s(3, ie) + s(4, ie))) &
        ifault_nan = min(ifault_nan, ie)
    end do
    !$omp end parallel do
    call first_fault(ne, [ifault_inv, ifault_nan, ifault_eos], &
                     [status_inverted_element, status_nonfinite_element, status_eos_range], ierr, ifault)
  end subroutine element_update

  !> Stable time step over all elements, dt_e = L_min/(Q + sqrt(Q^2 + c^2)),
  !> Q = C_L c + C_Q^2 sqrt(A) |tr d| in compression; returns the smallest
  !> dt_e [s] (before the safety factor) and the element that sets it (the
  !> lowest index among equal values, as a serial scan would, so the result
  !> does not depend on the thread count).
  subroutine element_time_step(ne, lmin, area, c, d, c_q, c_l, dt_min, icontrol)
    integer, intent(in) :: ne
    real(wp), intent(in) :: lmin(ne), area(ne), c(ne), d(4, ne), c_q, c_l
    real(wp), intent(out) :: dt_min
    integer, intent(out) :: icontrol
    real(wp) :: dte, t_min
    integer :: ie, t_i
    dt_min = huge(1.0_wp)
    icontrol = 0
    !$omp parallel default(none) shared(ne, lmin, area, c, d, c_q, c_l, dt_min, icontrol) &
    !$omp private(ie, dte, t_min, t_i)
    t_min = huge(1.0_wp)
    t_i = 0
    !$omp do schedule(static)
    do ie = 1, ne
      dte = element_step(lmin(ie), area(ie), c(ie), d(1, ie) + d(2, ie) + d(4, ie), c_q, c_l)
      if (dte < t_min) then
        t_min = dte
        t_i = ie
      end if
    end do
    !$omp end do
    !$omp critical (element_step_minimum)
    call merge_minimum(t_min, t_i, dt_min, icontrol)
    !$omp end critical (element_step_minimum)
    !$omp end parallel
  end subroutine element_time_step

  !> Stable step of one element [s] before the safety factor:
  !> L_min/(Q + sqrt(Q^2 + c^2)), Q = C_L c + C_Q^2 sqrt(A) |tr d| when the
  !> element is compressed (trace < 0) [1/s], else Q = 0.
  pure real(wp) function element_step(lmin, area, c, trace, c_q, c_l) result(dte)
    real(wp), intent(in) :: lmin, area, c, trace, c_q, c_l
    real(wp) :: qv
    qv = 0.0_wp
    if (trace < 0.0_wp) qv = c_l*c + c_q**2*sqrt(area)*abs(trace)
    dte = lmin/(qv + sqrt(qv*qv + c**2))
  end function element_step

end module fsph_element
