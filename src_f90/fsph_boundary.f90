!> Kinematic boundary conditions on nodes: the symmetry axis and rigid,
!> fixed, frictionless planes (the Taylor anvil). Applied to the half-step
!> velocities before positions are updated.
module fsph_boundary
  use fsph_kinds, only: wp
  implicit none
  private

  public :: apply_axis, apply_rigid_plane, wall_normal_velocity

contains

  !> Nodes on the axis keep v_r = 0 (and so r = 0).
  subroutine apply_axis(nn, on_axis, v)
    integer, intent(in) :: nn
    logical, intent(in) :: on_axis(nn)
    real(wp), intent(inout) :: v(2, nn)
    integer :: a
    !$omp parallel do default(none) shared(nn, on_axis, v) private(a)
    do a = 1, nn
      if (on_axis(a)) v(1, a) = 0.0_wp
    end do
    !$omp end parallel do
  end subroutine apply_axis

  !> A node whose predicted position x + dt v would fall behind the plane has
  !> its normal velocity replaced by the one that brings it exactly onto the
  !> plane; tangential velocity is untouched (frictionless). The plane is
  !> rigid and fixed: it takes the normal momentum. With `offset`
  !> (particles: a fraction of their radius [m]) the point keeps that
  !> distance from the plane. A point already closer than that (a particle
  !> just made from an element next to the plane) only stops approaching:
  !> it is not pushed out, which would put energy in. `work` [J] gets the
  !> work of the plane's impulses m dv, charged at the mean of the velocity
  !> before the kick (v_start) and the corrected one (the measure under
  !> which the central difference balances kinetic energy, as for contact):
  !> a point that rests on the plane costs nothing, one that strikes it
  !> loses its normal kinetic energy (the plane acts as a perfectly
  !> inelastic wall on it). `impulse` [N s] gets the impulse of the plane on
  !> the points, sum m dv (the plane's reaction is minus it).
  subroutine apply_rigid_plane(nn, point, normal, dt, x, mass, v_start, v, work, impulse, offset)
    integer, intent(in) :: nn
    real(wp), intent(in) :: point(2), normal(2) !< plane point [m], unit normal [-]
    real(wp), intent(in) :: dt                  !< step [s]
    real(wp), intent(in) :: x(2, nn)
    real(wp), intent(in) :: mass(nn)            !< [kg]
    real(wp), intent(in) :: v_start(2, nn)      !< velocity before the kick [m/s]
    real(wp), intent(inout) :: v(2, nn)
    real(wp), intent(inout) :: work             !< [J]
    real(wp), intent(inout) :: impulse(2)       !< [N s]
    real(wp), intent(in), optional :: offset(nn)
    real(wp) :: gap, vn, vn_new, w, dp
    integer :: a
    ! serial: the work and the impulse are summed in point order, so their
    ! bits do not depend on the thread count (a dot product per point)
    w = 0.0_wp
    dp = 0.0_wp
    do a = 1, nn
      gap = dot_product(x(:, a) - point, normal)
      if (present(offset)) gap = gap - offset(a)
      vn = dot_product(v(:, a), normal)
      if (gap + dt*vn < 0.0_wp) then
        vn_new = wall_normal_velocity(gap, vn, dt)
        v(:, a) = v(:, a) + (vn_new - vn)*normal
        w = w + mass(a)*(vn_new - vn)*0.5_wp*(dot_product(v_start(:, a), normal) + vn_new)
        dp = dp + mass(a)*(vn_new - vn)
      end if
    end do
    work = work + w
    impulse = impulse + dp*normal
  end subroutine apply_rigid_plane

  !> The rule of apply_rigid_plane for one point: its normal velocity
  !> [m/s] after a fixed wall at distance gap [m] (less any offset; negative
  !> when the point is already closer) has acted on its normal velocity vn
  !> [m/s] over the step dt [s]: unchanged when x + dt v stays clear of the
  !> wall; else the velocity that brings it onto the wall, and for a point
  !> already inside, only no approach. Contact predictions use it so that
  !> they see the positions the boundary conditions will allow.
  pure real(wp) function wall_normal_velocity(gap, vn, dt) result(vn_new)
    real(wp), intent(in) :: gap, vn, dt
    vn_new = vn
    if (.not. (gap + dt*vn < 0.0_wp)) return
    vn_new = max(-gap/dt, 0.0_wp)
    if (gap < 0.0_wp) vn_new = max(vn, 0.0_wp)
  end function wall_normal_velocity

end module fsph_boundary
