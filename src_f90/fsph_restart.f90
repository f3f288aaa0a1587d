!> Checkpoint and restart: every state array that the next cycle reads is
!> reachable by a number, as a (rows, cols) view, so the API can copy the
!> whole state out and back in without one routine per array. Arrays the
!> cycle recomputes before use (forces, neighbour lists, work arrays) are
!> not part of it.
module fsph_restart
  use fsph_kinds, only: wp
  use fsph_state, only: simulation_t, state_allocate, state_allocate_particles
  implicit none
  private

  !> Real arrays: 1-20 nodes and elements, 21-34 particles, 35-37 eroded
  !> node mass and element and particle material history, 38-39 the
  !> particles' strain rates and velocity gradients of the last step (the
  !> viscosity's compression switch and the hourglass term read them).
  integer, parameter, public :: n_real_arrays = 39
  !> Integer arrays: 1-5 nodes and elements, 6-12 particles and coupling.
  integer, parameter, public :: n_int_arrays = 12
  !> Real and integer scalars of the clock and the conversion books.
  integer, parameter, public :: n_real_scalars = 13, n_int_scalars = 9

  public :: real_view, int_view, get_scalars, set_scalars, allocate_for_restart
  public :: prepare_checkpoint, finish_restore

contains

  !> Rank-2 view (rows, cols) of real array `id` (null if not allocated).
  function real_view(sim, id) result(p)
    type(simulation_t), intent(in), target :: sim
    integer, intent(in) :: id
    real(wp), pointer :: p(:, :)
    p => null()
      select case (id)
      case (1); if (allocated(sim%nodes%x)) p => sim%nodes%x
      case (2); if (allocated(sim%nodes%x0)) p => sim%nodes%x0
      case (3); if (allocated(sim%nodes%v)) p => sim%nodes%v
      case (4); if (allocated(sim%nodes%mass)) p(1:1, 1:sim%nodes%n) => sim%nodes%mass
      case (5); if (allocated(sim%nodes%mass_tie)) p(1:1, 1:sim%nodes%n) => sim%nodes%mass_tie
      case (6); if (allocated(sim%elements%mass)) p(1:1, 1:sim%elements%n) => sim%elements%mass
      case (7); if (allocated(sim%elements%rho)) p(1:1, 1:sim%elements%n) => sim%elements%rho
      case (8); if (allocated(sim%elements%s)) p => sim%elements%s
      case (9); if (allocated(sim%elements%p)) p(1:1, 1:sim%elements%n) => sim%elements%p
      case (10); if (allocated(sim%elements%q)) p(1:1, 1:sim%elements%n) => sim%elements%q
      case (11); if (allocated(sim%elements%eps_p)) p(1:1, 1:sim%elements%n) => sim%elements%eps_p
      case (12); if (allocated(sim%elements%e)) p(1:1, 1:sim%elements%n) => sim%elements%e
      case (13); if (allocated(sim%elements%temp)) p(1:1, 1:sim%elements%n) => sim%elements%temp
      case (14); if (allocated(sim%elements%c)) p(1:1, 1:sim%elements%n) => sim%elements%c
      case (15); if (allocated(sim%elements%area)) p(1:1, 1:sim%elements%n) => sim%elements%area
      case (16); if (allocated(sim%elements%rbar)) p(1:1, 1:sim%elements%n) => sim%elements%rbar
      case (17); if (allocated(sim%elements%volume)) p(1:1, 1:sim%elements%n) => sim%elements%volume
      case (18); if (allocated(sim%elements%lmin)) p(1:1, 1:sim%elements%n) => sim%elements%lmin
      case (19); if (allocated(sim%elements%d)) p => sim%elements%d
      case (20); if (allocated(sim%elements%spin)) p(1:1, 1:sim%elements%n) => sim%elements%spin
      case (21); if (allocated(sim%particles%x)) p => sim%particles%x(:, 1:sim%particles%n)
      case (22); if (allocated(sim%particles%x0)) p => sim%particles%x0(:, 1:sim%particles%n)
      case (23); if (allocated(sim%particles%v)) p => sim%particles%v(:, 1:sim%particles%n)
      case (24); if (allocated(sim%particles%mass)) p(1:1, 1:sim%particles%n) => sim%particles%mass(1:sim%particles%n)
      case (25); if (allocated(sim%particles%h)) p(1:1, 1:sim%particles%n) => sim%particles%h(1:sim%particles%n)
      case (26); if (allocated(sim%particles%radius)) p(1:1, 1:sim%particles%n) => sim%particles%radius(1:sim%particles%n)
      case (27); if (allocated(sim%particles%rho)) p(1:1, 1:sim%particles%n) => sim%particles%rho(1:sim%particles%n)
      case (28); if (allocated(sim%particles%s)) p => sim%particles%s(:, 1:sim%particles%n)
      case (29); if (allocated(sim%particles%p)) p(1:1, 1:sim%particles%n) => sim%particles%p(1:sim%particles%n)
      case (30); if (allocated(sim%particles%eps_p)) p(1:1, 1:sim%particles%n) => sim%particles%eps_p(1:sim%particles%n)
      case (31); if (allocated(sim%particles%e)) p(1:1, 1:sim%particles%n) => sim%particles%e(1:sim%particles%n)
      case (32); if (allocated(sim%particles%temp)) p(1:1, 1:sim%particles%n) => sim%particles%temp(1:sim%particles%n)
      case (33); if (allocated(sim%particles%c)) p(1:1, 1:sim%particles%n) => sim%particles%c(1:sim%particles%n)
      case (34); if (allocated(sim%particles%tie_xi)) p(1:1, 1:sim%particles%n) => sim%particles%tie_xi(1:sim%particles%n)
      case (35); if (allocated(sim%nodes%mass_eroded)) p(1:1, 1:sim%nodes%n) => sim%nodes%mass_eroded
      case (36); if (allocated(sim%elements%hist)) p => sim%elements%hist
      case (37); if (allocated(sim%particles%hist)) p => sim%particles%hist(:, 1:sim%particles%n)
      case (38); if (allocated(sim%particles%d)) p => sim%particles%d(:, 1:sim%particles%n)
      case (39); if (allocated(sim%particles%grad_v)) p => sim%particles%grad_v(:, 1:sim%particles%n)
      end select
  end function real_view

  !> Rank-2 view (rows, cols) of integer array `id` (null if not allocated).
  function int_view(sim, id) result(p)
    type(simulation_t), intent(in), target :: sim
    integer, intent(in) :: id
    integer, pointer :: p(:, :)
    p => null()
      select case (id)
      case (1); if (allocated(sim%elements%conn)) p => sim%elements%conn
      case (2); if (allocated(sim%elements%mat)) p(1:1, 1:sim%elements%n) => sim%elements%mat
      case (3); if (allocated(sim%elements%body)) p(1:1, 1:sim%elements%n) => sim%elements%body
      case (4); if (allocated(sim%elements%group)) p(1:1, 1:sim%elements%n) => sim%elements%group
      case (5); if (allocated(sim%nodes%on_axis_int)) p(1:1, 1:sim%nodes%n) => sim%nodes%on_axis_int
      case (6); if (allocated(sim%particles%mat)) p(1:1, 1:sim%particles%n) => sim%particles%mat(1:sim%particles%n)
      case (7); if (allocated(sim%particles%body)) p(1:1, 1:sim%particles%n) => sim%particles%body(1:sim%particles%n)
      case (8); if (allocated(sim%particles%continuum)) p(1:1, 1:sim%particles%n) => sim%particles%continuum(1:sim%particles%n)
      case (9); if (allocated(sim%particles%tie_a)) p(1:1, 1:sim%particles%n) => sim%particles%tie_a(1:sim%particles%n)
      case (10); if (allocated(sim%particles%tie_b)) p(1:1, 1:sim%particles%n) => sim%particles%tie_b(1:sim%particles%n)
      case (11); if (allocated(sim%particles%assoc)) p => sim%particles%assoc(:, 1:sim%particles%n)
      case (12); if (allocated(sim%coupling%edge)) p => sim%coupling%edge(:, 1:sim%coupling%n_edges)
      end select
  end function int_view

  !> Clock and books: reals (time, dt, dt_last, dt_initial, conversion heat,
  !> contact dissipation, erosion: element mass, internal energy, node mass,
  !> kinetic energy, momentum r and z, work of the planes) and integers (cycle, dt_element,
  !> dt_particle, n_converted, n_events, n_groups, n_edges, n_imag, n_eroded).
  subroutine get_scalars(sim, r, i)
    type(simulation_t), intent(in) :: sim
    real(wp), intent(out) :: r(n_real_scalars)
    integer, intent(out) :: i(n_int_scalars)
    associate (er => sim%erosion)
      r = [sim%time, sim%dt, sim%dt_last, sim%dt_initial, sim%conversion%heat, sim%contact%dissipated, &
           er%element_mass, er%internal, er%node_mass, er%kinetic, er%momentum(1), er%momentum(2), &
           sim%plane_dissipated]
      i = [sim%cycle, sim%dt_element, sim%dt_particle, sim%conversion%n_converted, &
           sim%conversion%n_events, sim%conversion%n_groups, sim%coupling%n_edges, sim%particles%n_imag, &
           er%n_eroded]
    end associate
  end subroutine get_scalars

  subroutine set_scalars(sim, r, i)
    type(simulation_t), intent(inout) :: sim
    real(wp), intent(in) :: r(n_real_scalars)
    integer, intent(in) :: i(n_int_scalars)
    sim%time = r(1); sim%dt = r(2); sim%dt_last = r(3); sim%dt_initial = r(4)
    sim%conversion%heat = r(5)
    sim%contact%dissipated = r(6)
    sim%erosion%element_mass = r(7); sim%erosion%internal = r(8); sim%erosion%node_mass = r(9)
    sim%erosion%kinetic = r(10); sim%erosion%momentum = r(11:12)
    sim%plane_dissipated = r(13)
    sim%erosion%n_eroded = i(9)
    sim%cycle = i(1); sim%dt_element = i(2); sim%dt_particle = i(3)
    sim%conversion%n_converted = i(4); sim%conversion%n_events = i(5)
    sim%conversion%n_groups = i(6); sim%coupling%n_edges = i(7); sim%particles%n_imag = 0; sim%particles%n_mirror = 0
    sim%history_cycle = sim%cycle
    sim%n_history = 0
  end subroutine set_scalars

  !> Allocate nodes, elements, particles (with their capacity) and coupling
  !> edges for the sizes of a checkpoint; the contents follow through the
  !> views. Materials, planes, control and continua stay as set up.
  subroutine allocate_for_restart(sim, nn, ne, np, capacity, n_edges)
    type(simulation_t), intent(inout) :: sim
    integer, intent(in) :: nn, ne, np, capacity, n_edges
    if (ne > 0) then
      call state_allocate(sim, nn, ne)
    else
      sim%nodes%n = 0
      sim%elements%n = 0
    end if
    if (capacity > 0) call state_allocate_particles(sim, np, capacity)
    if (allocated(sim%coupling%edge)) deallocate (sim%coupling%edge)
    allocate (sim%coupling%edge(2, max(n_edges, 64)))
    sim%coupling%n_edges = n_edges
    if (allocated(sim%nodes%on_axis_int)) deallocate (sim%nodes%on_axis_int)
    allocate (sim%nodes%on_axis_int(max(nn, 1)))
  end subroutine allocate_for_restart

  !> Before reading integer array 5: the axis flags as integers.
  subroutine prepare_checkpoint(sim)
    type(simulation_t), intent(inout) :: sim
    if (allocated(sim%nodes%on_axis_int)) deallocate (sim%nodes%on_axis_int)
    allocate (sim%nodes%on_axis_int(max(sim%nodes%n, 1)))
    sim%nodes%on_axis_int = 0
    if (sim%nodes%n > 0) sim%nodes%on_axis_int(1:sim%nodes%n) = merge(1, 0, sim%nodes%on_axis)
  end subroutine prepare_checkpoint

  !> After every array is in: axis flags, then what derives from the mesh
  !> (fsph_remesh mesh_changed), the tied masses and the conversion limits;
  !> the state is ready.
  subroutine finish_restore(sim)
    use fsph_remesh, only: mesh_changed
    use fsph_coupling, only: update_tie_masses
    use fsph_convert, only: conversion_limits
    type(simulation_t), intent(inout) :: sim
    if (sim%nodes%n > 0) sim%nodes%on_axis = sim%nodes%on_axis_int(1:sim%nodes%n) /= 0
    call mesh_changed(sim%nodes, sim%elements, sim%contact, sim%particles, sim%continuum_of_body)
    if (sim%nodes%n > 0) call update_tie_masses(sim%particles, sim%nodes)
    ! the conversion criterion of each element, from the initial mesh
    if (sim%elements%n > 0 .and. sim%conversion%n_groups > 0) &
      call conversion_limits(sim%elements, sim%nodes, sim%conversion)
    sim%ready = .true.
  end subroutine finish_restore

end module fsph_restart
