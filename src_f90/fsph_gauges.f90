!> Gauges: time histories at points (&gauge; docs/method.md, "Gauges").
!> A gauge samples the T3 element that contains its point (barycentric
!> test; the element's constant fields, the nodal velocities interpolated
!> with the barycentric weights) or, where no element does, the nearest
!> particle within its kernel support kernel_support h (that particle's
!> own fields: no kernel smoothing). A material gauge follows the material
!> point that is there at t = 0: its element and barycentric weights (or,
!> in a body of particles, its particle) are found once; when its element
!> turns into particles it moves to the particle of that element's body
!> nearest its position then and follows that particle; when its element
!> is deleted (erosion) it is in no material from then on. A fixed gauge is
!> searched for at every record. Gauges only read the state.
!>
!> The gauges' state (gauge_set_t) lives in the run's simulation_t; the
!> procedures take the arrays they read as explicit arguments. Serial
!> loops in index order: the records are the same on any thread count.
module fsph_gauges
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
  use fsph_kinds, only: wp
  use fsph_kernel, only: kernel_support
  use fsph_material, only: equivalent_stress
  use fsph_layouts, only: n_hist, hist_damage, gauge_columns, gcol_r, gcol_z, gcol_velocity_r, &
                          gcol_velocity_z, gcol_pressure, gcol_stress_zz, gcol_von_mises, gcol_plastic_strain, &
                          gcol_temperature, gcol_density, gcol_internal_energy, gcol_damage, gcol_inside, &
                          gauge_kind_material, gauge_kind_fixed, gauge_on_nothing, gauge_on_element, &
                          gauge_on_particle
  implicit none
  private

  !> Tolerance of the barycentric test, on each weight [-]: a point on an
  !> edge (the axis, a face) belongs to the elements on either side.
  real(wp), parameter :: weight_tolerance = 1.0e-10_wp

  !> The run's gauges: what the deck gave, where each material gauge is,
  !> and their records at the history records not yet drained.
  type, public :: gauge_set_t
    integer :: n = 0
    integer, allocatable :: kind(:)          !< fsph_layouts gauge_kind_*
    real(wp), allocatable :: point(:, :)     !< (2, n) point of the deck (r, z) [m]
    integer, allocatable :: on(:)            !< material gauges: gauge_on_* of what they follow
    integer, allocatable :: index(:)         !< that element or particle
    integer, allocatable :: body(:)          !< body of the material point (0: none)
    real(wp), allocatable :: weight(:, :)    !< (3, n) barycentric weights in the element [-]
    real(wp), allocatable :: corner0(:, :, :) !< (2, 3, n) initial corners of the element (its identity) [m]
    real(wp), allocatable :: x(:, :)         !< (2, n) position at the last gauges_track [m]
    real(wp), allocatable :: switch_time(:)  !< when the gauge moved from its element to a particle [s] (-1: never)
    real(wp), allocatable :: lost_time(:)    !< when its element was deleted [s] (-1: never)
    !> (gauge_columns, n, capacity): each gauge's row at the history records
    real(wp), allocatable :: history(:, :, :)
  end type gauge_set_t

  public :: gauges_define, gauges_unlocate, gauges_locate_elements, gauges_locate_particles, gauges_track, gauges_refind
  public :: gauges_switch, gauges_lose, gauges_renumber, gauges_begin_record, gauges_find_elements, gauges_find_particles
  public :: gauges_element_rows, gauges_particle_rows, gauges_resume
  public :: barycentric_weights, containing_element, nearest_particle, gauge_row

contains

  !> Barycentric weights w (3) of point p in the triangle of corners xe
  !> (2, 3) [-] (sum 1; all >= 0 inside).
  pure function barycentric_weights(xe, p) result(w)
    real(wp), intent(in) :: xe(2, 3), p(2)
    real(wp) :: w(3), a(2), b(2), d(2), det
    a = xe(:, 2) - xe(:, 1)
    b = xe(:, 3) - xe(:, 1)
    d = p - xe(:, 1)
    det = a(1)*b(2) - a(2)*b(1)
    if (.not. (abs(det) > 0.0_wp)) then
      w = -1.0_wp                     ! a degenerate triangle contains nothing
      return
    end if
    w(2) = (d(1)*b(2) - d(2)*b(1))/det
    w(3) = (a(1)*d(2) - a(2)*d(1))/det
    w(1) = 1.0_wp - w(2) - w(3)
  end function barycentric_weights

  !> The first element (in index order) whose triangle, corners x(:,
  !> conn(:, ie)), contains p, and p's barycentric weights w in it; ie = 0
  !> where none does.
  pure subroutine containing_element(ne, nn, conn, x, p, ie, w)
    integer, intent(in) :: ne, nn, conn(3, ne)
    real(wp), intent(in) :: x(2, nn), p(2)
    integer, intent(out) :: ie
    real(wp), intent(out) :: w(3)
    real(wp) :: xe(2, 3), slack
    integer :: k
    ie = 0
    w = 0.0_wp
    do k = 1, ne
      xe = x(:, conn(:, k))
      ! the box first: most elements are far from the point
      slack = weight_tolerance*(maxval(xe(1, :)) - minval(xe(1, :)) + maxval(xe(2, :)) - minval(xe(2, :)))
      if (p(1) < minval(xe(1, :)) - slack .or. p(1) > maxval(xe(1, :)) + slack) cycle
      if (p(2) < minval(xe(2, :)) - slack .or. p(2) > maxval(xe(2, :)) + slack) cycle
      w = barycentric_weights(xe, p)
      if (all(w >= -weight_tolerance)) then
        ie = k
        return
      end if
    end do
    w = 0.0_wp
  end subroutine containing_element

  !> The real particle nearest p (the lowest index among equals): of body
  !> `body` only when body > 0, and only within its kernel support
  !> kernel_support h when within_support. 0 where none qualifies.
  pure function nearest_particle(np, x, h, part_body, p, body, within_support) result(ip)
    integer, intent(in) :: np, part_body(np), body
    real(wp), intent(in) :: x(2, np), h(np), p(2)
    logical, intent(in) :: within_support
    integer :: ip, i
    real(wp) :: d2, best
    ip = 0
    best = huge(1.0_wp)
    do i = 1, np
      if (body > 0 .and. part_body(i) /= body) cycle
      d2 = (x(1, i) - p(1))**2 + (x(2, i) - p(2))**2
      if (within_support .and. .not. d2 < (kernel_support*h(i))**2) cycle
      if (d2 < best) then
        best = d2
        ip = i
      end if
    end do
  end function nearest_particle

  !> A gauge's record (fsph_layouts gcol_*) of a material point at x (2)
  !> [m] moving at v (2) [m/s] with pressure p, artificial viscous pressure
  !> q [Pa] (0 for a particle), deviator s (rr, zz, rz, tt) [Pa], plastic
  !> strain, temperature [K], density [kg/m^3], specific internal energy
  !> [J/kg] and material history hist (n_hist).
  pure function gauge_row(x, v, p, q, s, eps_p, temp, rho, e, hist) result(row)
    real(wp), intent(in) :: x(2), v(2), p, q, s(4), eps_p, temp, rho, e, hist(n_hist)
    real(wp) :: row(gauge_columns)
    row(gcol_r) = x(1)
    row(gcol_z) = x(2)
    row(gcol_velocity_r) = v(1)
    row(gcol_velocity_z) = v(2)
    row(gcol_pressure) = p
    row(gcol_stress_zz) = s(2) - p - q
    row(gcol_von_mises) = equivalent_stress(s)
    row(gcol_plastic_strain) = eps_p
    row(gcol_temperature) = temp
    row(gcol_density) = rho
    row(gcol_internal_energy) = e
    row(gcol_damage) = hist(hist_damage)
    row(gcol_inside) = 1.0_wp
  end function gauge_row

  !> The record of a point in no material: inside 0, r and z the point
  !> (NaN where unknown), every other field NaN.
  pure function empty_row(x) result(row)
    real(wp), intent(in) :: x(2)
    real(wp) :: row(gauge_columns)
    row = ieee_value(1.0_wp, ieee_quiet_nan)
    row(gcol_r) = x(1)
    row(gcol_z) = x(2)
    row(gcol_inside) = 0.0_wp
  end function empty_row

  !> Store the deck's gauges: kinds (fsph_layouts gauge_kind_*) and points
  !> (2, n) [m]; nothing located yet, no records.
  pure subroutine gauges_define(g, n, kinds, points)
    type(gauge_set_t), intent(inout) :: g
    integer, intent(in) :: n, kinds(n)
    real(wp), intent(in) :: points(2, n)
    g = gauge_set_t()
    g%n = n
    allocate (g%kind(n), g%point(2, n), g%on(n), g%index(n), g%body(n), g%weight(3, n), g%corner0(2, 3, n), &
              g%x(2, n), g%switch_time(n), g%lost_time(n))
    g%kind = kinds
    g%point = points
    call gauges_unlocate(g)
  end subroutine gauges_define

  !> Forget where the gauges are: each on nothing, at its point, no switch
  !> or loss, no records (before locating them again: set-up, restart).
  pure subroutine gauges_unlocate(g)
    type(gauge_set_t), intent(inout) :: g
    if (allocated(g%history)) deallocate (g%history)
    g%on = gauge_on_nothing
    g%index = 0
    g%body = 0
    g%weight = 0.0_wp
    g%corner0 = 0.0_wp
    g%x = g%point
    g%switch_time = -1.0_wp
    g%lost_time = -1.0_wp
  end subroutine gauges_unlocate

  !> Find the material point of every material gauge in the initial
  !> configuration (x0 of the nodes and particles: at t = 0 the current
  !> one; after a restart, where the material started), first among the
  !> elements: the element whose initial triangle contains the point, with
  !> its barycentric weights (after gauges_unlocate). The gauges not found
  !> stay on nothing (gauges_locate_particles may find them). Fixed gauges
  !> are searched at every record instead.
  pure subroutine gauges_locate_elements(g, ne, nn, conn, el_body, node_x0)
    type(gauge_set_t), intent(inout) :: g
    integer, intent(in) :: ne, nn, conn(3, ne), el_body(ne)
    real(wp), intent(in) :: node_x0(2, nn)
    integer :: k, ie
    real(wp) :: w(3)
    do k = 1, g%n
      if (g%kind(k) /= gauge_kind_material) cycle
      call containing_element(ne, nn, conn, node_x0, g%point(:, k), ie, w)
      if (ie == 0) cycle
      g%on(k) = gauge_on_element
      g%index(k) = ie
      g%body(k) = el_body(ie)
      g%weight(:, k) = w
      g%corner0(:, :, k) = node_x0(:, conn(:, ie))
    end do
  end subroutine gauges_locate_elements

  !> The material gauges no element holds (call gauges_unlocate, then
  !> gauges_locate_elements where there are elements): the particle that started nearest the
  !> point (x0) within its kernel support, which the gauge then is.
  pure subroutine gauges_locate_particles(g, np, part_x0, h, part_body)
    type(gauge_set_t), intent(inout) :: g
    integer, intent(in) :: np, part_body(np)
    real(wp), intent(in) :: part_x0(2, np), h(np)
    integer :: k, ip
    do k = 1, g%n
      if (g%kind(k) /= gauge_kind_material .or. g%on(k) /= gauge_on_nothing) cycle
      ip = nearest_particle(np, part_x0, h, part_body, g%point(:, k), 0, .true.)
      if (ip == 0) cycle
      g%on(k) = gauge_on_particle
      g%index(k) = ip
      g%body(k) = part_body(ip)
    end do
  end subroutine gauges_locate_particles

  !> Current position of every material gauge on an element (2, n) [m]:
  !> the barycentric weights times its nodes' positions x. Called before
  !> erosion and conversion change the mesh, so that a gauge whose element
  !> goes knows where it was.
  pure subroutine gauges_track(g, ne, nn, conn, x)
    type(gauge_set_t), intent(inout) :: g
    integer, intent(in) :: ne, nn, conn(3, ne)
    real(wp), intent(in) :: x(2, nn)
    integer :: k
    do k = 1, g%n
      if (g%kind(k) /= gauge_kind_material .or. g%on(k) /= gauge_on_element) cycle
      g%x(:, k) = matmul(x(:, conn(:, g%index(k))), g%weight(:, k))
    end do
  end subroutine gauges_track

  !> After erosion or conversion removed elements (the order of the rest
  !> kept, fsph_remesh): each material gauge on an element finds its
  !> element again, at its old index or below, by its initial corners and
  !> body. gone(k): gauge k's element is no more (then gauges_switch or
  !> gauges_lose).
  pure subroutine gauges_refind(g, ne, nn, conn, el_body, node_x0, gone)
    type(gauge_set_t), intent(inout) :: g
    integer, intent(in) :: ne, nn, conn(3, ne), el_body(ne)
    real(wp), intent(in) :: node_x0(2, nn)
    logical, intent(out) :: gone(g%n)
    integer :: k, ie
    gone = .false.
    do k = 1, g%n
      if (g%kind(k) /= gauge_kind_material .or. g%on(k) /= gauge_on_element) cycle
      gone(k) = .true.
      do ie = min(g%index(k), ne), 1, -1
        if (el_body(ie) /= g%body(k)) cycle
        if (all(node_x0(:, conn(:, ie)) == g%corner0(:, :, k))) then
          g%index(k) = ie
          gone(k) = .false.
          exit
        end if
      end do
    end do
  end subroutine gauges_refind

  !> The gauges whose element converted into particles (gone) move, at
  !> `time` [s], to the particle of their body nearest their position
  !> before the conversion (gauges_track) and follow it from then on.
  pure subroutine gauges_switch(g, gone, np, part_x, h, part_body, time)
    type(gauge_set_t), intent(inout) :: g
    logical, intent(in) :: gone(g%n)
    integer, intent(in) :: np, part_body(np)
    real(wp), intent(in) :: part_x(2, np), h(np), time
    integer :: k, ip
    do k = 1, g%n
      if (.not. gone(k)) cycle
      ip = nearest_particle(np, part_x, h, part_body, g%x(:, k), g%body(k), .false.)
      if (ip == 0) then
        call lose(g, k, time)
        cycle
      end if
      g%on(k) = gauge_on_particle
      g%index(k) = ip
      g%switch_time(k) = time
    end do
  end subroutine gauges_switch

  !> The real particles were renumbered, particle k being the one that was
  !> order(k) (fsph_spatial): the material gauges on particles follow
  !> theirs.
  pure subroutine gauges_renumber(g, order)
    type(gauge_set_t), intent(inout) :: g
    integer, intent(in) :: order(:)
    integer, allocatable :: place(:)
    integer :: k
    if (g%n == 0) return
    allocate (place(size(order)))
    do k = 1, size(order)
      place(order(k)) = k
    end do
    do k = 1, g%n
      if (g%kind(k) == gauge_kind_material .and. g%on(k) == gauge_on_particle) g%index(k) = place(g%index(k))
    end do
  end subroutine gauges_renumber

  !> A restart: material gauge k takes up again what it followed when the
  !> checkpoint was written, in place of what gauges_locate_* found in the
  !> initial configuration: particle ip (of np, bodies part_body) since
  !> switch_time [s], or nothing since lost_time [s] (its element eroded,
  !> or converted with no particle of its body left). ok false, nothing
  !> changed, where that does not fit: not a material gauge, a particle
  !> beyond the particles or of another body, a time below 0.
  pure subroutine gauges_resume(g, k, on, ip, switch_time, lost_time, np, part_body, ok)
    type(gauge_set_t), intent(inout) :: g
    integer, intent(in) :: k, on, ip, np, part_body(np)
    real(wp), intent(in) :: switch_time, lost_time
    logical, intent(out) :: ok
    ok = .false.
    if (k < 1 .or. k > g%n) return
    if (g%kind(k) /= gauge_kind_material) return
    select case (on)
    case (gauge_on_particle)
      if (ip < 1 .or. ip > np .or. switch_time < 0.0_wp) return
      if (part_body(ip) /= g%body(k)) return
      g%on(k) = gauge_on_particle
      g%index(k) = ip
      g%switch_time(k) = switch_time
    case (gauge_on_nothing)
      if (lost_time < 0.0_wp) return
      g%switch_time(k) = max(switch_time, -1.0_wp)
      call lose(g, k, lost_time)
    case default
      return
    end select
    ok = .true.
  end subroutine gauges_resume

  !> The gauges whose element was deleted (gone; erosion) are in no
  !> material from `time` [s] on.
  pure subroutine gauges_lose(g, gone, time)
    type(gauge_set_t), intent(inout) :: g
    logical, intent(in) :: gone(g%n)
    real(wp), intent(in) :: time
    integer :: k
    do k = 1, g%n
      if (gone(k)) call lose(g, k, time)
    end do
  end subroutine gauges_lose

  pure subroutine lose(g, k, time)
    type(gauge_set_t), intent(inout) :: g
    integer, intent(in) :: k
    real(wp), intent(in) :: time
    g%on(k) = gauge_on_nothing
    g%index(k) = 0
    g%lost_time(k) = time
  end subroutine lose

  !> Start a record: what each gauge samples now, src(k) (gauge_on_*),
  !> idx(k) and weights w(3, k): a material gauge what it follows, a fixed
  !> gauge nothing yet (gauges_find_elements, gauges_find_particles); every
  !> row empty (inside 0, NaN fields; r, z the point of a fixed gauge).
  pure subroutine gauges_begin_record(g, src, idx, w, rows)
    type(gauge_set_t), intent(in) :: g
    integer, intent(out) :: src(g%n), idx(g%n)
    real(wp), intent(out) :: w(3, g%n), rows(gauge_columns, g%n)
    real(wp) :: nan
    integer :: k
    nan = ieee_value(1.0_wp, ieee_quiet_nan)
    do k = 1, g%n
      src(k) = gauge_on_nothing
      idx(k) = 0
      w(:, k) = 0.0_wp
      if (g%kind(k) == gauge_kind_material) then
        src(k) = g%on(k)
        idx(k) = g%index(k)
        w(:, k) = g%weight(:, k)
        rows(:, k) = empty_row([nan, nan])
      else
        rows(:, k) = empty_row(g%point(:, k))
      end if
    end do
  end subroutine gauges_begin_record

  !> Fixed gauges: the element whose current triangle contains the point.
  pure subroutine gauges_find_elements(g, ne, nn, conn, x, src, idx, w)
    type(gauge_set_t), intent(in) :: g
    integer, intent(in) :: ne, nn, conn(3, ne)
    real(wp), intent(in) :: x(2, nn)
    integer, intent(inout) :: src(g%n), idx(g%n)
    real(wp), intent(inout) :: w(3, g%n)
    integer :: k, ie
    real(wp) :: wk(3)
    do k = 1, g%n
      if (g%kind(k) /= gauge_kind_fixed .or. src(k) /= gauge_on_nothing) cycle
      call containing_element(ne, nn, conn, x, g%point(:, k), ie, wk)
      if (ie == 0) cycle
      src(k) = gauge_on_element
      idx(k) = ie
      w(:, k) = wk
    end do
  end subroutine gauges_find_elements

  !> Fixed gauges no element holds: the nearest particle within its kernel
  !> support.
  pure subroutine gauges_find_particles(g, np, px, h, part_body, src, idx)
    type(gauge_set_t), intent(in) :: g
    integer, intent(in) :: np, part_body(np)
    real(wp), intent(in) :: px(2, np), h(np)
    integer, intent(inout) :: src(g%n), idx(g%n)
    integer :: k, ip
    do k = 1, g%n
      if (g%kind(k) /= gauge_kind_fixed .or. src(k) /= gauge_on_nothing) cycle
      ip = nearest_particle(np, px, h, part_body, g%point(:, k), 0, .true.)
      if (ip == 0) cycle
      src(k) = gauge_on_particle
      idx(k) = ip
    end do
  end subroutine gauges_find_particles

  !> The rows of the gauges that sample an element (src): its constant
  !> fields, the nodal positions x and velocities v interpolated with the
  !> weights w (a fixed gauge keeps its point as r, z).
  pure subroutine gauges_element_rows(g, src, idx, w, nn, x, v, ne, conn, p, q, s, eps_p, temp, rho, e, hist, rows)
    type(gauge_set_t), intent(in) :: g
    integer, intent(in) :: src(g%n), idx(g%n), nn, ne, conn(3, ne)
    real(wp), intent(in) :: w(3, g%n), x(2, nn), v(2, nn)
    real(wp), intent(in) :: p(ne), q(ne), s(4, ne), eps_p(ne), temp(ne), rho(ne), e(ne), hist(n_hist, ne)
    real(wp), intent(inout) :: rows(gauge_columns, g%n)
    integer :: k, ie
    do k = 1, g%n
      if (src(k) /= gauge_on_element) cycle
      ie = idx(k)
      rows(:, k) = gauge_row(matmul(x(:, conn(:, ie)), w(:, k)), matmul(v(:, conn(:, ie)), w(:, k)), p(ie), &
                             q(ie), s(:, ie), eps_p(ie), temp(ie), rho(ie), e(ie), hist(:, ie))
      if (g%kind(k) == gauge_kind_fixed) rows(gcol_r:gcol_z, k) = g%point(:, k)
    end do
  end subroutine gauges_element_rows

  !> The rows of the gauges that sample a particle (src): its own fields,
  !> no kernel smoothing (a fixed gauge keeps its point as r, z).
  pure subroutine gauges_particle_rows(g, src, idx, np, px, pv, p, s, eps_p, temp, rho, e, hist, rows)
    type(gauge_set_t), intent(in) :: g
    integer, intent(in) :: src(g%n), idx(g%n), np
    real(wp), intent(in) :: px(2, np), pv(2, np), p(np), s(4, np), eps_p(np), temp(np), rho(np), e(np), &
                            hist(n_hist, np)
    real(wp), intent(inout) :: rows(gauge_columns, g%n)
    integer :: k, ip
    do k = 1, g%n
      if (src(k) /= gauge_on_particle) cycle
      ip = idx(k)
      rows(:, k) = gauge_row(px(:, ip), pv(:, ip), p(ip), 0.0_wp, s(:, ip), eps_p(ip), temp(ip), rho(ip), e(ip), &
                             hist(:, ip))
      if (g%kind(k) == gauge_kind_fixed) rows(gcol_r:gcol_z, k) = g%point(:, k)
    end do
  end subroutine gauges_particle_rows

end module fsph_gauges
