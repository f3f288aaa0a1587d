!> Central-difference time integration of nodal velocities and positions,
!> and the particles' kick. Loops over points are split between threads
!> in the static blocks of every other particle loop, so that a point's
!> data stay with one core from phase to phase (docs/performance.md,
!> "Which core holds a particle").
module fsph_integrate
  use fsph_kinds, only: wp
  use fsph_status, only: status_ok, status_nonfinite_node
  use fsph_ordered, only: first_fault
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  implicit none
  private

  public :: integrate_velocities, integrate_positions, kick_particles, mean_kick_velocity

contains

  !> v <- v + dt_v f/m.
  subroutine integrate_velocities(nn, mass, f, dt_v, v)
    integer, intent(in) :: nn
    real(wp), intent(in) :: mass(nn)   !< nodal mass [kg]
    real(wp), intent(in) :: f(2, nn)   !< nodal force [N]
    real(wp), intent(in) :: dt_v       !< velocity step [s]
    real(wp), intent(inout) :: v(2, nn) !< velocity [m/s]
    integer :: a
    !$omp parallel do default(none) shared(nn, mass, f, dt_v, v) private(a)
    do a = 1, nn
      v(:, a) = v(:, a) + dt_v*f(:, a)/mass(a)
    end do
    !$omp end parallel do
  end subroutine integrate_velocities

  !> The particles' kick: v_before <- v, v <- v + dt_v acc.
  subroutine kick_particles(n, dt_v, acc, v, v_before)
    integer, intent(in) :: n
    real(wp), intent(in) :: dt_v             !< velocity step [s]
    real(wp), intent(in) :: acc(2, n)        !< [m/s^2]
    real(wp), intent(inout) :: v(2, n)       !< [m/s]
    real(wp), intent(out) :: v_before(2, n)  !< [m/s]
    integer :: i
    !$omp parallel do default(none) shared(n, dt_v, acc, v, v_before) private(i)
    do i = 1, n
      v_before(:, i) = v(:, i)
      v(:, i) = v(:, i) + dt_v*acc(:, i)
    end do
    !$omp end parallel do
  end subroutine kick_particles

  !> v_bar <- (v_bar + v)/2 scale: from the velocity before the kick, the
  !> mean over the kick times scale [-].
  subroutine mean_kick_velocity(n, scale, v, v_bar)
    integer, intent(in) :: n
    real(wp), intent(in) :: scale
    real(wp), intent(in) :: v(2, n)          !< [m/s]
    real(wp), intent(inout) :: v_bar(2, n)   !< [m/s]
    integer :: i
    !$omp parallel do default(none) shared(n, scale, v, v_bar) private(i)
    do i = 1, n
      v_bar(:, i) = 0.5_wp*(v_bar(:, i) + v(:, i))*scale
    end do
    !$omp end parallel do
  end subroutine mean_kick_velocity

  !> x <- x_old + dt v, x_mid = (x_old + x)/2; ierr = status_nonfinite_node
  !> with ifault the first node whose position or velocity is not finite.
  subroutine integrate_positions(nn, dt, v, x, x_old, x_mid, ierr, ifault)
    integer, intent(in) :: nn
    real(wp), intent(in) :: dt                 !< position step [s]
    real(wp), intent(in) :: v(2, nn)           !< half-step velocity [m/s]
    real(wp), intent(inout) :: x(2, nn)        !< position [m]
    real(wp), intent(out) :: x_old(2, nn), x_mid(2, nn)
    integer, intent(out) :: ierr, ifault
    integer :: a
    ifault = nn + 1
    !$omp parallel do default(none) shared(nn, dt, v, x, x_old, x_mid) private(a) &
    !$omp reduction(min:ifault)
    do a = 1, nn
      x_old(:, a) = x(:, a)
      x(:, a) = x_old(:, a) + dt*v(:, a)
      x_mid(:, a) = 0.5_wp*(x_old(:, a) + x(:, a))
      if (.not. (ieee_is_finite(x(1, a)) .and. ieee_is_finite(x(2, a)) .and. &
                 ieee_is_finite(v(1, a)) .and. ieee_is_finite(v(2, a)))) ifault = min(ifault, a)
    end do
    !$omp end parallel do
    call first_fault(nn, [ifault], [status_nonfinite_node], ierr, ifault)
  end subroutine integrate_positions

end module fsph_integrate
