!> Failure of particles by energy release rate ("eigenerosion": Pandolfi &
!> Ortiz 2012, Int. J. Numer. Meth. Eng. 92:694; the form used by Liao et al. 2022,
!> Explosion and Shock Waves 42(10), eq 12, for debris clouds): a point p
!> fails when the elastic energy its neighbourhood would release,
!>   G_p = lambda eta sum_q V_q W_q / sum_q V_q,
!> reaches the material's critical energy release rate G_c. The
!> neighbourhood C_eta is the point itself and the intact particles of its
!> body within the kernel support of the cycle's pairs (eta = 2 h_p, about
!> 2.6 lattice spacings); V_q = m_q/rho_q the ring volume of q (full ring,
!> so the mean weights each ring by its volume in r-z); W_q the recoverable
!> elastic energy density, s:s/(4G) + p^2/(2K) in tension (p < 0), the
!> deviatoric part alone in compression (a compressed point does not
!> release its volumetric energy by cracking). Only a point whose largest
!> principal stress is tensile may fail. A failed point keeps its mass,
!> momentum and internal energy (the released elastic energy stays in it
!> as heat, so the energy balance is untouched) and from then on carries
!> no deviatoric stress and no tension (fsph_material pressure_floor).
module fsph_eigenerosion
  use fsph_kinds, only: wp
  use fsph_layouts, only: n_props, n_hist, prop_bulk, prop_fracture_energy, hist_failed
  use fsph_material, only: point_failed, shear_modulus
  implicit none
  private

  public :: elastic_energy_density, largest_principal_stress, eigenerosion_failure

contains

  !> Recoverable elastic energy density [J/m^3] of a point with deviator s
  !> (rr, zz, rz, tt) [Pa] and pressure p [Pa]: s:s/(4G) + p^2/(2K) in
  !> tension, s:s/(4G) in compression; zero for a point without a shear
  !> modulus (molten).
  pure function elastic_energy_density(s, p, g, k) result(w)
    real(wp), intent(in) :: s(4), p       !< [Pa]
    real(wp), intent(in) :: g, k          !< shear and bulk moduli [Pa]
    real(wp) :: w
    w = 0.0_wp
    if (g > 0.0_wp) w = (s(1)**2 + s(2)**2 + 2.0_wp*s(3)**2 + s(4)**2)/(4.0_wp*g)
    if (p < 0.0_wp .and. k > 0.0_wp) w = w + p*p/(2.0_wp*k)
  end function elastic_energy_density

  !> Largest principal value of the stress sigma = s - p I [Pa]: the
  !> larger in-plane (r-z) principal stress or the hoop stress.
  pure function largest_principal_stress(s, p) result(smax)
    real(wp), intent(in) :: s(4), p       !< [Pa]
    real(wp) :: smax
    smax = 0.5_wp*(s(1) + s(2)) - p + sqrt((0.5_wp*(s(1) - s(2)))**2 + s(3)**2)
    smax = max(smax, s(4) - p)
  end function largest_principal_stress

  !> The eigenerosion check at the end of a step, for the particles of the
  !> materials with a critical energy release rate (props fracture_energy
  !> > 0). The pairs are the cycle's (pair_in: within the support at its
  !> start), the same-body real entries of each row and the low lists; the
  !> rates are evaluated for all particles first and the failures applied
  !> after, so the result does not depend on the order or the threads.
  !> lambda: the geometric factor of G_p [-]. work(3, n): space for V W,
  !> V and the verdict. n_new: particles that failed in this step.
  subroutine eigenerosion_failure(n, nmat, props, istrength, mat, mass, rho, h, temp, nbr_ptr, nbr_list, &
                                  low_ptr, low_pair, low_other, pair_in, lambda, s, p, hist, work, n_new)
    integer, intent(in) :: n, nmat
    real(wp), intent(in) :: props(n_props, nmat)
    integer, intent(in) :: istrength(nmat), mat(n)
    real(wp), intent(in) :: mass(n)       !< ring masses [kg]
    real(wp), intent(in) :: rho(n)        !< densities [kg/m^3]
    real(wp), intent(in) :: h(n)          !< smoothing lengths [m]
    real(wp), intent(in) :: temp(n)       !< temperatures [K]
    integer, intent(in) :: nbr_ptr(n + 1), nbr_list(*), low_ptr(n + 1), low_pair(*), low_other(*)
    logical, intent(in) :: pair_in(*)     !< the entries of this cycle
    real(wp), intent(in) :: lambda        !< geometric factor [-]
    real(wp), intent(inout) :: s(4, n)    !< deviatoric stress [Pa]
    real(wp), intent(inout) :: p(n)       !< pressure [Pa]
    real(wp), intent(inout) :: hist(n_hist, n) !< history variables
    real(wp), intent(out) :: work(3, n)
    integer, intent(out) :: n_new
    integer :: i, k, j, m, im
    real(wp) :: sum_vw, sum_v, g_c, g_p
    n_new = 0
    !$omp parallel default(none) &
    !$omp shared(n, props, istrength, mat, mass, rho, h, temp, nbr_ptr, nbr_list, low_ptr, low_pair, low_other) &
    !$omp shared(pair_in, lambda, s, p, hist, work) &
    !$omp private(i, k, j, m, im, sum_vw, sum_v, g_c, g_p) reduction(+:n_new)
    ! each intact point's volume and elastic energy (zero for failed ones:
    ! they are no longer part of the neighbourhood)
    !$omp do schedule(static)
    do i = 1, n
      im = mat(i)
      work(:, i) = 0.0_wp
      if (point_failed(hist(:, i))) cycle
      work(2, i) = mass(i)/rho(i)
      work(1, i) = work(2, i)*elastic_energy_density(s(:, i), p(i), &
                   shear_modulus(props(:, im), istrength(im), rho(i), p(i), temp(i)), props(prop_bulk, im))
    end do
    !$omp end do
    !$omp do schedule(static)
    do i = 1, n
      work(3, i) = 0.0_wp
      im = mat(i)
      g_c = props(prop_fracture_energy, im)
      if (.not. (g_c > 0.0_wp) .or. work(2, i) <= 0.0_wp) cycle
      if (largest_principal_stress(s(:, i), p(i)) <= 0.0_wp) cycle
      sum_vw = work(1, i)
      sum_v = work(2, i)
      do k = nbr_ptr(i), nbr_ptr(i + 1) - 1
        j = nbr_list(k)
        if (j <= 0 .or. j > n) cycle          ! mirror images, imaginary particles
        if (.not. pair_in(k)) cycle
        sum_vw = sum_vw + work(1, j)
        sum_v = sum_v + work(2, j)
      end do
      do m = low_ptr(i), low_ptr(i + 1) - 1
        if (.not. pair_in(low_pair(m))) cycle
        j = low_other(m)
        sum_vw = sum_vw + work(1, j)
        sum_v = sum_v + work(2, j)
      end do
      g_p = lambda*2.0_wp*h(i)*sum_vw/sum_v
      if (g_p >= g_c) work(3, i) = 1.0_wp
    end do
    !$omp end do
    !$omp do schedule(static)
    do i = 1, n
      if (.not. (work(3, i) > 0.0_wp)) cycle
      hist(hist_failed, i) = 1.0_wp
      s(:, i) = 0.0_wp
      p(i) = max(p(i), 0.0_wp)
      n_new = n_new + 1
    end do
    !$omp end do
    !$omp end parallel
  end subroutine eigenerosion_failure

end module fsph_eigenerosion
