!> Checkpoint and restart: every state array that the next cycle reads is
!> reachable by its id (named in fsph_layouts), as a (rows, cols) view
!> (fsph_state_views), so the API can copy the whole state out and back in
!> without one routine per array. Arrays the cycle recomputes before use
!> (forces, neighbour lists, work arrays) are not part of it.
module fsph_restart
  use fsph_kinds, only: wp
  use fsph_state, only: simulation_t, state_allocate, state_allocate_particles
  use fsph_state_views, only: real_view, int_view
  use fsph_layouts
  implicit none
  private

  ! the arrays and scalars by name (ckr_*, cki_*, csr_*, csi_*) and their
  ! numbers: fsph_layouts (generated from fsph/layouts.py)

  public :: real_view, int_view, get_scalars, set_scalars, allocate_for_restart
  public :: prepare_checkpoint, finish_restore

contains

  !> Clock and books (fsph_layouts csr_* and csi_*): time and steps, the
  !> conversion heat, the contact and plane dissipation, the erosion books;
  !> cycle, the element or particle setting the step, conversion counts,
  !> coupling edges, imaginary particles, eroded elements. One list,
  !> real_scalar and int_scalar, serves the checkpoint and the restore.
  subroutine get_scalars(sim, r, i)
    type(simulation_t), intent(in), target :: sim
    real(wp), intent(out) :: r(n_real_scalars)
    integer, intent(out) :: i(n_int_scalars)
    real(wp), pointer :: pr
    integer, pointer :: pi
    integer :: k
    do k = 1, n_real_scalars
      pr => real_scalar(sim, k)
      r(k) = pr
    end do
    do k = 1, n_int_scalars
      pi => int_scalar(sim, k)
      i(k) = pi
    end do
  end subroutine get_scalars

  !> The inverse of get_scalars; the imaginary particles and the history
  !> buffer start empty.
  subroutine set_scalars(sim, r, i)
    type(simulation_t), intent(inout), target :: sim
    real(wp), intent(in) :: r(n_real_scalars)
    integer, intent(in) :: i(n_int_scalars)
    real(wp), pointer :: pr
    integer, pointer :: pi
    integer :: k
    do k = 1, n_real_scalars
      pr => real_scalar(sim, k)
      pr = r(k)
    end do
    do k = 1, n_int_scalars
      pi => int_scalar(sim, k)
      pi = i(k)
    end do
    sim%particles%n_imag = 0
    sim%particles%n_mirror = 0
    sim%history_cycle = sim%cycle
    sim%n_history = 0
  end subroutine set_scalars

  !> The real scalar `id` (fsph_layouts csr_*) of the run.
  function real_scalar(sim, id) result(p)
    type(simulation_t), intent(in), target :: sim
    integer, intent(in) :: id
    real(wp), pointer :: p
    p => null()
    select case (id)
    case (csr_time); p => sim%time
    case (csr_dt); p => sim%dt
    case (csr_dt_last); p => sim%dt_last
    case (csr_dt_initial); p => sim%dt_initial
    case (csr_conversion_heat); p => sim%conversion%heat
    case (csr_contact_dissipated); p => sim%contact%dissipated
    case (csr_eroded_element_mass); p => sim%erosion%element_mass
    case (csr_eroded_internal); p => sim%erosion%internal
    case (csr_eroded_node_mass); p => sim%erosion%node_mass
    case (csr_eroded_kinetic); p => sim%erosion%kinetic
    case (csr_eroded_momentum_r); p => sim%erosion%momentum(1)
    case (csr_eroded_momentum_z); p => sim%erosion%momentum(2)
    case (csr_plane_dissipated); p => sim%plane_dissipated
    case (csr_plane_impulse_z); p => sim%plane_impulse_z
    case (csr_energy_full_before); p => sim%energy_full_before
    end select
  end function real_scalar

  !> The integer scalar `id` (fsph_layouts csi_*) of the run.
  function int_scalar(sim, id) result(p)
    type(simulation_t), intent(in), target :: sim
    integer, intent(in) :: id
    integer, pointer :: p
    p => null()
    select case (id)
    case (csi_cycle); p => sim%cycle
    case (csi_dt_element); p => sim%dt_element
    case (csi_dt_particle); p => sim%dt_particle
    case (csi_n_converted); p => sim%conversion%n_converted
    case (csi_n_events); p => sim%conversion%n_events
    case (csi_n_groups); p => sim%conversion%n_groups
    case (csi_n_edges); p => sim%coupling%n_edges
    case (csi_n_imag); p => sim%particles%n_imag
    case (csi_n_eroded); p => sim%erosion%n_eroded
    case (csi_energy_full_cycle); p => sim%energy_full_cycle
    end select
  end function int_scalar

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

  !> Before reading nodes/on_axis: the axis flags as integers.
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
    use fsph_solver, only: setup_total
    type(simulation_t), intent(inout) :: sim
    integer :: ierr, ifault
    if (sim%nodes%n > 0) sim%nodes%on_axis = sim%nodes%on_axis_int(1:sim%nodes%n) /= 0
    call mesh_changed(sim%nodes, sim%elements, sim%contact, sim%particles, sim%continuum_of_body)
    if (sim%nodes%n > 0) call update_tie_masses(sim%particles, sim%nodes)
    ! the conversion criterion of each element, from the initial mesh
    if (sim%elements%n > 0 .and. sim%conversion%n_groups > 0) &
      call conversion_limits(sim%elements, sim%nodes, sim%conversion)
    ! the total-Lagrangian reference data, from the initial configuration
    ! (it was refused at set-up if singular, so it is not now)
    if (sim%particles%n > 0) call setup_total(sim, ierr, ifault)
    sim%ready = .true.
  end subroutine finish_restore

end module fsph_restart
