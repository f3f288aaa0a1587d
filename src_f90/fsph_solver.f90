!> The hydrocode cycle (ALGORITHMS.md section 7) for the element phase:
!> set-up of derived quantities and `solver_advance`, one call per phase.
module fsph_solver
  use fsph_kinds, only: wp, axis_tolerance
  use fsph_status, only: status_ok, status_bad_input, status_not_ready, status_max_cycles, &
                         status_dt_floor
  use fsph_state, only: sim, history_columns
  use fsph_material, only: prop_rho0, prop_shear, prop_t_room, eos_pressure, sound_speed, &
                           strength_elastic, strength_johnson_cook, eos_linear, eos_mie_gruneisen
  use fsph_element, only: element_geometry, element_strain_rates, element_corner_forces, &
                          gather_corner_forces, element_stress_update, element_time_step
  use fsph_boundary, only: apply_axis, apply_rigid_plane
  use fsph_integrate, only: integrate_velocities, integrate_positions
  implicit none
  private

  public :: solver_initialise, solver_advance, solver_energies, solver_stable_step

contains

  !> Derived set-up once nodes, elements, materials and planes are in place:
  !> element geometry, masses and densities, lumped nodal masses (1/3 of
  !> each element's ring mass to each of its nodes, EPIC style), the
  !> node-to-corner map, axis flags, initial material state and time step.
  subroutine solver_initialise(ierr, ifault)
    integer, intent(out) :: ierr, ifault
    integer :: ne, nn, ie, k, a, im, ncorner
    integer, allocatable :: fill(:)
    real(wp) :: r_extent, a_eos, b_eos, dadrho

    ifault = 0
    ierr = status_bad_input
    ne = sim%elements%n
    nn = sim%nodes%n
    if (ne < 1 .or. nn < 3 .or. sim%n_materials < 1) return
    associate (el => sim%elements, nd => sim%nodes)
      if (any(el%conn < 1) .or. any(el%conn > nn)) return
      if (any(el%mat < 1) .or. any(el%mat > sim%n_materials)) return
      if (any(sim%istrength < strength_elastic) .or. any(sim%istrength > strength_johnson_cook)) return
      if (any(sim%ieos < eos_linear) .or. any(sim%ieos > eos_mie_gruneisen)) return

      ! axis: nodes within a tiny fraction of the radial extent of r = 0
      r_extent = maxval(nd%x(1, :)) - minval(nd%x(1, :))
      nd%on_axis = abs(nd%x(1, :)) <= axis_tolerance*r_extent
      where (nd%on_axis) nd%x(1, :) = 0.0_wp
      nd%x0 = nd%x

      call element_geometry(ne, nn, el%conn, nd%x, el%area, el%rbar, el%volume, el%lmin, ierr, ifault)
      if (ierr /= status_ok) return

      do ie = 1, ne
        im = el%mat(ie)
        el%rho(ie) = sim%props(prop_rho0, im)
        el%mass(ie) = el%rho(ie)*el%volume(ie)
        el%temp(ie) = sim%props(prop_t_room, im)
        call eos_pressure(sim%props(:, im), sim%ieos(im), el%rho(ie), a_eos, b_eos, dadrho, ierr)
        el%c(ie) = sound_speed(sim%props(prop_shear, im), dadrho, b_eos, el%rho(ie), 0.0_wp)
      end do
      el%s = 0.0_wp; el%p = 0.0_wp; el%q = 0.0_wp; el%eps_p = 0.0_wp; el%e = 0.0_wp
      el%d = 0.0_wp; el%spin = 0.0_wp

      ! lumped masses and the node -> corner map (CSR, corners in element order)
      nd%mass = 0.0_wp
      allocate (fill(nn + 1))
      fill = 0
      do ie = 1, ne
        do k = 1, 3
          a = el%conn(k, ie)
          nd%mass(a) = nd%mass(a) + el%mass(ie)/3.0_wp
          fill(a + 1) = fill(a + 1) + 1
        end do
      end do
      ierr = status_bad_input
      if (any(fill(2:) == 0)) then
        ifault = findloc(fill(2:) == 0, .true., dim=1)   ! a node no element uses
        return
      end if
      nd%corner_ptr(1) = 1
      do a = 1, nn
        nd%corner_ptr(a + 1) = nd%corner_ptr(a) + fill(a + 1)
      end do
      ncorner = 3*ne
      if (allocated(nd%corner_list)) deallocate (nd%corner_list)
      allocate (nd%corner_list(ncorner))
      fill(1:nn) = nd%corner_ptr(1:nn)
      do ie = 1, ne
        do k = 1, 3
          a = el%conn(k, ie)
          nd%corner_list(fill(a)) = 3*(ie - 1) + k
          fill(a) = fill(a) + 1
        end do
      end do
    end associate

    sim%time = 0.0_wp
    sim%cycle = 0
    sim%dt_last = 0.0_wp
    call solver_stable_step()
    sim%dt_initial = sim%dt
    sim%n_history = 0
    sim%history_cycle = -1
    call record_history()
    sim%ready = .true.
    ierr = status_ok
    ifault = 0
  end subroutine solver_initialise

  !> Stable step for the next cycle: safety factor times the element limit.
  subroutine solver_stable_step()
    real(wp) :: dt_e
    associate (el => sim%elements)
      call element_time_step(el%n, el%lmin, el%area, el%c, el%d, sim%control%c_q, &
                             sim%control%c_l, dt_e, sim%dt_element)
    end associate
    sim%dt = sim%control%dt_safety*dt_e
  end subroutine solver_stable_step

  !> Run cycles until the clock reaches t_target [s] (the last steps are
  !> shortened to land on it), or a failure, or max_cycles more cycles.
  subroutine solver_advance(t_target, max_cycles, ierr, ifault)
    real(wp), intent(in) :: t_target
    integer, intent(in) :: max_cycles
    integer, intent(out) :: ierr, ifault
    !> Remaining time below this fraction of a step counts as arrived [-].
    real(wp), parameter :: arrival_fraction = 1.0e-9_wp
    real(wp) :: remaining, dt_step
    integer :: n_done

    ierr = status_not_ready
    ifault = 0
    if (.not. sim%ready) return
    ierr = status_ok
    n_done = 0
    do
      remaining = t_target - sim%time
      if (remaining <= arrival_fraction*sim%dt) exit
      if (n_done >= max_cycles) then
        ierr = status_max_cycles
        exit
      end if
      ! land on t_target without a sliver step: the last one or two steps
      ! share the remainder
      if (remaining <= sim%dt) then
        dt_step = remaining
      else if (remaining < 2.0_wp*sim%dt) then
        dt_step = 0.5_wp*remaining
      else
        dt_step = sim%dt
      end if
      call cycle(dt_step, ierr, ifault)
      n_done = n_done + 1
      if (ierr /= status_ok) exit
    end do
    ! the state at the end of each advance is always in the history
    if (sim%history_cycle /= sim%cycle) call record_history()
  end subroutine solver_advance

  !> One explicit cycle of length dt_step [s], ALGORITHMS.md section 7.
  subroutine cycle(dt_step, ierr, ifault)
    real(wp), intent(in) :: dt_step
    integer, intent(out) :: ierr, ifault

    ! 1. internal forces from the stress at t^n on the geometry at t^n
    call compute_forces()
    ! 2. central difference: velocities to t^(n+1/2)
    call update_velocities(0.5_wp*(sim%dt_last + dt_step))
    ! 3. boundary conditions on the half-step velocities
    call apply_boundaries(dt_step)
    ! 4. positions to t^(n+1); the clock moves with them, so a failure in
    !    the rest of the cycle is reported at the time the geometry reached
    call update_positions(dt_step, ierr, ifault)
    if (ierr /= status_ok) return
    sim%time = sim%time + dt_step
    sim%cycle = sim%cycle + 1
    sim%dt_last = dt_step
    ! 5. element strain rates at mid-step, new geometry, stress update
    call update_elements(dt_step, ierr, ifault)
    if (ierr /= status_ok) return
    ! 6. next stable step
    call solver_stable_step()
    if (mod(sim%cycle, sim%control%history_every) == 0) call record_history()
    if (sim%dt < sim%control%dt_floor_ratio*sim%dt_initial) then
      ierr = status_dt_floor
      ifault = sim%dt_element
    end if
  end subroutine cycle

  subroutine compute_forces()
    associate (el => sim%elements, nd => sim%nodes)
      call element_corner_forces(el%n, nd%n, el%conn, nd%x, el%s, el%p, el%q, el%fc)
      call gather_corner_forces(nd%n, el%n, size(nd%corner_list), nd%corner_ptr, nd%corner_list, &
                                el%fc, nd%f)
    end associate
  end subroutine compute_forces

  subroutine update_velocities(dt_v)
    real(wp), intent(in) :: dt_v  !< velocity step: mean of the two position steps [s]
    call integrate_velocities(sim%nodes%n, sim%nodes%mass, sim%nodes%f, dt_v, sim%nodes%v)
  end subroutine update_velocities

  subroutine apply_boundaries(dt_step)
    real(wp), intent(in) :: dt_step
    integer :: ip
    associate (nd => sim%nodes)
      call apply_axis(nd%n, nd%on_axis, nd%v)
      do ip = 1, sim%n_planes
        call apply_rigid_plane(nd%n, sim%planes(ip)%point, sim%planes(ip)%normal, dt_step, &
                               nd%x, nd%v)
      end do
    end associate
  end subroutine apply_boundaries

  subroutine update_positions(dt_step, ierr, ifault)
    real(wp), intent(in) :: dt_step
    integer, intent(out) :: ierr, ifault
    call integrate_positions(sim%nodes%n, dt_step, sim%nodes%v, sim%nodes%x, sim%nodes%x_old, &
                             sim%nodes%x_mid, ierr, ifault)
  end subroutine update_positions

  subroutine update_elements(dt_step, ierr, ifault)
    real(wp), intent(in) :: dt_step
    integer, intent(out) :: ierr, ifault
    associate (el => sim%elements, nd => sim%nodes)
      call element_strain_rates(el%n, nd%n, el%conn, nd%x_mid, nd%v, el%d, el%spin)
      call element_geometry(el%n, nd%n, el%conn, nd%x, el%area, el%rbar, el%volume, el%lmin, &
                            ierr, ifault)
      if (ierr /= status_ok) return
      call element_stress_update(el%n, sim%n_materials, sim%props, sim%istrength, sim%ieos, &
                                 el%mat, dt_step, sim%control%c_q, sim%control%c_l, el%d, el%spin, &
                                 el%mass, el%volume, el%area, el%rho, el%q, el%s, el%p, el%eps_p, &
                                 el%e, el%temp, el%c, ierr, ifault)
    end associate
  end subroutine update_elements

  !> Append (time, cycle, dt, kinetic, internal) to the history buffer,
  !> doubling its capacity when full (rare: the API drains it).
  subroutine record_history()
    real(wp), allocatable :: grown(:, :)
    real(wp) :: kinetic, internal
    integer, parameter :: initial_capacity = 256
    if (.not. allocated(sim%history)) allocate (sim%history(history_columns, initial_capacity))
    if (sim%n_history == size(sim%history, 2)) then
      allocate (grown(history_columns, 2*size(sim%history, 2)))
      grown(:, 1:sim%n_history) = sim%history(:, 1:sim%n_history)
      call move_alloc(grown, sim%history)
    end if
    call solver_energies(kinetic, internal)
    sim%history_cycle = sim%cycle
    sim%n_history = sim%n_history + 1
    sim%history(:, sim%n_history) = [sim%time, real(sim%cycle, wp), sim%dt_last, kinetic, internal]
  end subroutine record_history

  !> Kinetic energy (half-step velocities) and internal energy [J].
  subroutine solver_energies(kinetic, internal)
    real(wp), intent(out) :: kinetic, internal
    associate (el => sim%elements, nd => sim%nodes)
      kinetic = 0.5_wp*sum(nd%mass*(nd%v(1, :)**2 + nd%v(2, :)**2))
      internal = sum(el%mass*el%e)
    end associate
  end subroutine solver_energies

end module fsph_solver
