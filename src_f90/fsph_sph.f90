!> Axisymmetric SPH sums (seed 000 eqs 1-4; ALGORITHMS.md section 2) over
!> the neighbour lists of fsph_neighbors. Every routine is a gather loop
!> over particles i (each writes only its own entries), so it threads
!> without races and gives the same bits for any thread count. Pair terms
!> are evaluated identically from both sides, so the axial momentum of the
!> sums is conserved to round-off.
!>
!> With full-ring masses m, the planar density is eta = 2 pi r rho and the
!> stress weights r sigma / eta^2 = sigma / (4 pi^2 r rho^2). Ghost entries
!> (-j) are the mirror of j across the axis, the odd extension of the
!> planar fields: position (-r_j, z_j), velocity (-v_r, v_z), sigma_rz
!> reversed, density rho_j, and a ring mass 2 pi r rho A that changes sign
!> with r (-m_j). The planar density eta is then odd in r and its gradient
!> is right at the axis; m/r and the planar area m/(2 pi r rho) of a ghost
!> are those of its particle.
!>
!> Artificial viscosity: the continuum (FEM) form q = rho (C_Q h eps)^2 +
!> C_L rho c h |eps| evaluated pairwise with the normal strain rate
!> eps_ij = (v_i - v_j).(x_i - x_j)/(|x_ij|^2 + 0.01 h^2) < 0 and the pair
!> means of rho, c and h, acting as an extra pressure on both particles of
!> the pair: Johnson's "combined" viscosity as fsph implements it
!> (Johnson 1996, IJIE 18:477), equivalent to Monaghan's Pi_ij with
!> alpha = C_L, beta = C_Q^2.
module fsph_sph
  use fsph_kinds, only: wp, pi, two_pi
  use fsph_kernel, only: kernel_dwdr
  implicit none
  private

  public :: sph_accelerations, sph_rates, sph_energy_rate, sph_time_step, particle_radius

  !> Softening of the pairwise strain rate, times h^2 [-].
  real(wp), parameter :: visc_softening = 0.01_wp
  !> Range of det(L) of the gradient-correction matrix inside which the
  !> corrected velocity gradient is used; outside it (a particle with too
  !> few neighbours) the plain SPH gradient is kept [-].
  real(wp), parameter :: correction_det_min = 0.05_wp, correction_det_max = 5.0_wp

contains

  !> Radius of a particle: half the side of the square of its planar area
  !> A = m/(2 pi r rho) [m]. Used for contact, rigid planes and lengths.
  pure elemental function particle_radius(mass, r, rho) result(radius)
    real(wp), intent(in) :: mass, r, rho
    real(wp) :: radius
    ! |r|: a particle found across the axis (the axis guard stops the run
    ! in this cycle) keeps the radius of its mirror ring
    radius = 0.5_wp*sqrt(mass/(two_pi*abs(r)*rho))
  end function particle_radius

  !> Neighbour of an entry: index j, position, velocity, total stress and
  !> signed ring mass (negative for a ghost, see the module header).
  pure subroutine neighbour_view(entry, x, v, sig, mass, j, xj, vj, sj, mj)
    integer, intent(in) :: entry
    real(wp), intent(in) :: x(:, :), v(:, :), sig(:, :), mass(:)
    integer, intent(out) :: j
    real(wp), intent(out) :: xj(2), vj(2), sj(4), mj
    j = abs(entry)
    xj = x(:, j)
    vj = v(:, j)
    sj = sig(:, j)
    mj = mass(j)
    if (entry < 0) then
      xj(1) = -xj(1)
      vj(1) = -vj(1)
      sj(3) = -sj(3)
      mj = -mj
    end if
  end subroutine neighbour_view

  !> Pairwise artificial viscous pressure q_ij [Pa] (see module header).
  pure function pair_viscosity(dx, dv, dist2, hij, rho_ij, c_ij, c_q, c_l) result(q)
    real(wp), intent(in) :: dx(2), dv(2), dist2, hij, rho_ij, c_ij, c_q, c_l
    real(wp) :: q, vx, eps
    q = 0.0_wp
    vx = dv(1)*dx(1) + dv(2)*dx(2)
    if (vx >= 0.0_wp) return
    eps = vx/(dist2 + visc_softening*hij*hij)
    q = rho_ij*(c_q*hij*eps)**2 + c_l*rho_ij*c_ij*hij*abs(eps)
  end function pair_viscosity

  !> Pair stress S = w_i sig_i + w_j sig_j - q_ij (w_i + w_j) I of the
  !> momentum and energy equations, w = r/eta^2 = 1/(4 pi^2 r rho^2).
  pure function pair_stress(wi, sig_i, wj, sig_j, q) result(stot)
    real(wp), intent(in) :: wi, sig_i(4), wj, sig_j(4), q
    real(wp) :: stot(4)
    stot = wi*sig_i + wj*sig_j
    stot(1) = stot(1) - q*(wi + wj)
    stot(2) = stot(2) - q*(wi + wj)
  end function pair_stress

  !> Work term S : (v_j - v_i) grad W of eq 3 for one pair.
  pure function pair_work(stot, dvji, grad) result(w)
    real(wp), intent(in) :: stot(4), dvji(2), grad(2)
    real(wp) :: w
    w = stot(1)*dvji(1)*grad(1) + stot(3)*dvji(1)*grad(2) + &
        stot(3)*dvji(2)*grad(1) + stot(2)*dvji(2)*grad(2)
  end function pair_work

  !> Accelerations (eqs 2a, 2b) [m/s^2] of every particle from the total
  !> stress sig = s - p I (rr, zz, rz, tt):
  !>  a_r = -sig_tt/(rho r) + 2 pi sum m_j [S^rr dW/dr + S^rz dW/dz]
  !>  a_z =                   2 pi sum m_j [S^rz dW/dr + S^zz dW/dz]
  !> with S = r_i sig_i/eta_i^2 + r_j sig_j/eta_j^2 - q_ij (...) I.
  !> The pairwise viscous pressures are stored per neighbour entry in
  !> pair_q so that the energy equation charges exactly the viscous work
  !> these forces do.
  subroutine sph_accelerations(n, ntot, x, v, mass, rho, h, c, sig, nbr_ptr, nbr_list, c_q, c_l, &
                               acc, pair_q, acc_imag)
    integer, intent(in) :: n             !< real particles (rows computed)
    integer, intent(in) :: ntot          !< real and imaginary particles (neighbours)
    real(wp), intent(in) :: x(2, ntot), v(2, ntot), mass(ntot), rho(ntot), h(ntot), c(ntot), sig(4, ntot)
    integer, intent(in) :: nbr_ptr(n + 1), nbr_list(*)
    real(wp), intent(in) :: c_q, c_l     !< viscosity coefficients [-]
    real(wp), intent(out) :: acc(2, n)
    real(wp), intent(out) :: pair_q(*)   !< viscous pressure of each entry [Pa]
    real(wp), intent(out) :: acc_imag(2, n) !< the part of acc from imaginary neighbours [m/s^2]
    integer :: i, k, j
    real(wp) :: xj(2), vj(2), sj(4), mj, dx(2), dist2, dist, hij, dw, grad(2), wi, wj, q, stot(4), a(2)
    real(wp) :: a_imag(2), da(2)
    !$omp parallel do default(none) schedule(dynamic, 64) &
    !$omp shared(n, x, v, mass, rho, h, c, sig, nbr_ptr, nbr_list, c_q, c_l, acc, pair_q, acc_imag) &
    !$omp private(i, k, j, xj, vj, sj, mj, dx, dist2, dist, hij, dw, grad, wi, wj, q, stot, a, a_imag, da)
    do i = 1, n
      wi = 1.0_wp/(4.0_wp*pi*pi*x(1, i)*rho(i)**2)
      a(1) = -sig(4, i)/(rho(i)*x(1, i))
      a(2) = 0.0_wp
      a_imag = 0.0_wp
      do k = nbr_ptr(i), nbr_ptr(i + 1) - 1
        call neighbour_view(nbr_list(k), x, v, sig, mass, j, xj, vj, sj, mj)
        dx = x(:, i) - xj
        dist2 = dx(1)**2 + dx(2)**2
        pair_q(k) = 0.0_wp
        if (dist2 <= 0.0_wp) cycle
        dist = sqrt(dist2)
        hij = 0.5_wp*(h(i) + h(j))
        dw = kernel_dwdr(dist, hij)
        grad = dw*dx/dist
        wj = 1.0_wp/(4.0_wp*pi*pi*xj(1)*rho(j)**2)
        q = pair_viscosity(dx, v(:, i) - vj, dist2, hij, 0.5_wp*(rho(i) + rho(j)), &
                           0.5_wp*(c(i) + c(j)), c_q, c_l)
        pair_q(k) = q
        stot = pair_stress(wi, sig(:, i), wj, sj, q)
        da = two_pi*mj*[stot(1)*grad(1) + stot(3)*grad(2), stot(3)*grad(1) + stot(2)*grad(2)]
        a = a + da
        if (nbr_list(k) > n) a_imag = a_imag + da
      end do
      acc(:, i) = a
      acc_imag(:, i) = a_imag
    end do
    !$omp end parallel do
  end subroutine sph_accelerations

  !> Rates for the update of density (eq 1), specific internal energy
  !> (eq 3, with the same pair stress as the momentum equation, so the
  !> energy of the sums is conserved) and the velocity gradient, corrected
  !> (Randles-Libersky) so that a linear velocity field is differentiated
  !> exactly: strain rates d (rr, zz, rz, tt) with d_tt = v_r/r, and spin.
  subroutine sph_rates(n, ntot, x, v, mass, rho, h, sig, nbr_ptr, nbr_list, pair_q, drho, de, d, spin)
    integer, intent(in) :: n, ntot
    real(wp), intent(in) :: x(2, ntot), v(2, ntot), mass(ntot), rho(ntot), h(ntot), sig(4, ntot)
    integer, intent(in) :: nbr_ptr(n + 1), nbr_list(*)
    real(wp), intent(in) :: pair_q(*)    !< viscous pressures of the accelerations [Pa]
    real(wp), intent(out) :: drho(n)     !< [kg/(m^3 s)]
    real(wp), intent(out) :: de(n)       !< [J/(kg s)]
    real(wp), intent(out) :: d(4, n), spin(n) !< [1/s]
    integer :: i, k, j
    real(wp) :: xj(2), vj(2), sj(4), mj, dx(2), dvji(2), dist2, dist, hij, dw, grad(2), wi, wj
    real(wp) :: stot(4), vol_j, gv(2, 2), lm(2, 2), inv(2, 2), det, g(2, 2), sum_rho, sum_e
    !$omp parallel do default(none) schedule(dynamic, 64) &
    !$omp shared(n, x, v, mass, rho, h, sig, nbr_ptr, nbr_list, pair_q, drho, de, d, spin) &
    !$omp private(i, k, j, xj, vj, sj, mj, dx, dvji, dist2, dist, hij, dw, grad, wi, wj, stot) &
    !$omp private(vol_j, gv, lm, inv, det, g, sum_rho, sum_e)
    do i = 1, n
      wi = 1.0_wp/(4.0_wp*pi*pi*x(1, i)*rho(i)**2)
      sum_rho = 0.0_wp
      sum_e = 0.0_wp
      gv = 0.0_wp
      lm = 0.0_wp
      do k = nbr_ptr(i), nbr_ptr(i + 1) - 1
        call neighbour_view(nbr_list(k), x, v, sig, mass, j, xj, vj, sj, mj)
        dx = x(:, i) - xj
        dist2 = dx(1)**2 + dx(2)**2
        if (dist2 <= 0.0_wp) cycle
        dist = sqrt(dist2)
        hij = 0.5_wp*(h(i) + h(j))
        dw = kernel_dwdr(dist, hij)
        grad = dw*dx/dist
        dvji = vj - v(:, i)
        ! (1): (1/2 pi) sum m_j/r_j (v_i - v_j).grad W
        sum_rho = sum_rho - mj/xj(1)*(dvji(1)*grad(1) + dvji(2)*grad(2))
        ! (3): pi sum m_j S : (v_j - v_i) grad W
        wj = 1.0_wp/(4.0_wp*pi*pi*xj(1)*rho(j)**2)
        stot = pair_stress(wi, sig(:, i), wj, sj, pair_q(k))
        sum_e = sum_e + mj*pair_work(stot, dvji, grad)
        ! velocity gradient and its correction matrix, planar volume A_j
        vol_j = mj/(two_pi*xj(1)*rho(j))
        gv(:, 1) = gv(:, 1) + vol_j*dvji*grad(1)
        gv(:, 2) = gv(:, 2) + vol_j*dvji*grad(2)
        lm(:, 1) = lm(:, 1) - vol_j*dx*grad(1)
        lm(:, 2) = lm(:, 2) - vol_j*dx*grad(2)
      end do
      drho(i) = -rho(i)*v(1, i)/x(1, i) + sum_rho/two_pi
      de(i) = sig(4, i)*v(1, i)/(rho(i)*x(1, i)) + pi*sum_e
      ! g = gv L^-1 where the correction applies
      det = lm(1, 1)*lm(2, 2) - lm(1, 2)*lm(2, 1)
      if (det > correction_det_min .and. det < correction_det_max) then
        inv(1, 1) = lm(2, 2)/det; inv(1, 2) = -lm(1, 2)/det
        inv(2, 1) = -lm(2, 1)/det; inv(2, 2) = lm(1, 1)/det
        g = matmul(gv, inv)
      else
        g = gv
      end if
      ! g(a, b) = d v_a / d x_b with (1, 2) = (r, z)
      d(1, i) = g(1, 1)
      d(2, i) = g(2, 2)
      d(3, i) = 0.5_wp*(g(1, 2) + g(2, 1))
      d(4, i) = v(1, i)/x(1, i)
      spin(i) = 0.5_wp*(g(1, 2) - g(2, 1))
    end do
    !$omp end parallel do
  end subroutine sph_rates

  !> Energy rate of eq 3 alone [J/(kg s)] for the stress, density and
  !> velocity given (the cycle passes mid-step values, so the stress work
  !> matches the time-centred force), with the viscous work of the pair
  !> pressures pair_q charged at the velocities v_visc (the cycle passes the
  !> mean of the velocities before and after the kick, which is exactly the
  !> kinetic energy those forces removed).
  subroutine sph_energy_rate(n, ntot, x, v, v_visc, mass, rho, h, sig, nbr_ptr, nbr_list, pair_q, de)
    integer, intent(in) :: n, ntot
    real(wp), intent(in) :: x(2, ntot), v(2, ntot), v_visc(2, ntot), mass(ntot), rho(ntot), h(ntot)
    real(wp), intent(in) :: sig(4, ntot)
    integer, intent(in) :: nbr_ptr(n + 1), nbr_list(*)
    real(wp), intent(in) :: pair_q(*)
    real(wp), intent(out) :: de(n)
    integer :: i, k, j
    real(wp) :: xj(2), vj(2), sj(4), mj, dx(2), dvji(2), dist2, dist, hij, grad(2), wi, wj, sum_e
    real(wp) :: vq(2), qwork(4)
    !$omp parallel do default(none) schedule(dynamic, 64) &
    !$omp shared(n, x, v, v_visc, mass, rho, h, sig, nbr_ptr, nbr_list, pair_q, de) &
    !$omp private(i, k, j, xj, vj, sj, mj, dx, dvji, dist2, dist, hij, grad, wi, wj, sum_e, vq, qwork)
    do i = 1, n
      wi = 1.0_wp/(4.0_wp*pi*pi*x(1, i)*rho(i)**2)
      sum_e = 0.0_wp
      do k = nbr_ptr(i), nbr_ptr(i + 1) - 1
        call neighbour_view(nbr_list(k), x, v, sig, mass, j, xj, vj, sj, mj)
        dx = x(:, i) - xj
        dist2 = dx(1)**2 + dx(2)**2
        if (dist2 <= 0.0_wp) cycle
        dist = sqrt(dist2)
        hij = 0.5_wp*(h(i) + h(j))
        grad = kernel_dwdr(dist, hij)*dx/dist
        dvji = vj - v(:, i)
        wj = 1.0_wp/(4.0_wp*pi*pi*xj(1)*rho(j)**2)
        sum_e = sum_e + mj*pair_work(pair_stress(wi, sig(:, i), wj, sj, 0.0_wp), dvji, grad)
        if (pair_q(k) > 0.0_wp) then
          vq = v_visc(:, j)
          if (nbr_list(k) < 0) vq(1) = -vq(1)
          qwork = pair_stress(wi, [0.0_wp, 0.0_wp, 0.0_wp, 0.0_wp], wj, &
                              [0.0_wp, 0.0_wp, 0.0_wp, 0.0_wp], pair_q(k))
          sum_e = sum_e + mj*pair_work(qwork, vq - v_visc(:, i), grad)
        end if
      end do
      de(i) = sig(4, i)*v(1, i)/(rho(i)*x(1, i)) + pi*sum_e
    end do
    !$omp end parallel do
  end subroutine sph_energy_rate

  !> Stable particle step before the safety factor: min L/(c + |v|) [s]
  !> with L = min(h, 2r) and the particle that sets it. h/(c + |v|) is the
  !> step of ALGORITHMS.md section 1; next to the axis the hoop term
  !> -sigma_tt/(rho r) adds a mode of frequency about c/r, stable under the
  !> central difference for dt < 2r/c, which a particle made from an
  !> element touching the axis (r = Delta/6) would break.
  subroutine sph_time_step(n, x, h, c, v, dt_min, icontrol)
    integer, intent(in) :: n
    real(wp), intent(in) :: x(2, n), h(n), c(n), v(2, n)
    real(wp), intent(out) :: dt_min
    integer, intent(out) :: icontrol
    real(wp) :: dti
    integer :: i
    dt_min = huge(1.0_wp)
    icontrol = 0
    do i = 1, n
      dti = min(h(i), 2.0_wp*x(1, i))/(c(i) + sqrt(v(1, i)**2 + v(2, i)**2))
      if (dti < dt_min) then
        dt_min = dti
        icontrol = i
      end if
    end do
  end subroutine sph_time_step

end module fsph_sph
