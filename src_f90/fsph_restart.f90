!> Checkpoint and restart: every state array that the next cycle reads is
!> reachable by its id (named in fsph_layouts), as a (rows, cols) view, so the API can copy the
!> whole state out and back in without one routine per array. Arrays the
!> cycle recomputes before use (forces, neighbour lists, work arrays) are
!> not part of it.
module fsph_restart
  use fsph_kinds, only: wp
  use fsph_state, only: simulation_t, state_allocate, state_allocate_particles
  use fsph_layouts
  implicit none
  private

  ! the arrays and scalars by name (ckr_*, cki_*, csr_*, csi_*) and their
  ! numbers: fsph_layouts (generated from fsph/layouts.py)

  public :: real_view, int_view, get_scalars, set_scalars, allocate_for_restart
  public :: prepare_checkpoint, finish_restore

contains

  !> Rank-2 view (rows, cols) of real array `id` (null if not allocated).
  function real_view(sim, id) result(p)
    type(simulation_t), intent(in), target :: sim
    integer, intent(in) :: id
    real(wp), pointer :: p(:, :)
    integer :: nn, ne, np
    nn = sim%nodes%n
    ne = sim%elements%n
    np = sim%particles%n
    p => null()
    select case (id)
    case (ckr_nodes_x); if (allocated(sim%nodes%x)) p => sim%nodes%x
    case (ckr_nodes_x0); if (allocated(sim%nodes%x0)) p => sim%nodes%x0
    case (ckr_nodes_v); if (allocated(sim%nodes%v)) p => sim%nodes%v
    case (ckr_nodes_mass); if (allocated(sim%nodes%mass)) p => real_row(sim%nodes%mass, nn)
    case (ckr_nodes_mass_tie); if (allocated(sim%nodes%mass_tie)) p => real_row(sim%nodes%mass_tie, nn)
    case (ckr_elements_mass); if (allocated(sim%elements%mass)) p => real_row(sim%elements%mass, ne)
    case (ckr_elements_rho); if (allocated(sim%elements%rho)) p => real_row(sim%elements%rho, ne)
    case (ckr_elements_s); if (allocated(sim%elements%s)) p => sim%elements%s
    case (ckr_elements_p); if (allocated(sim%elements%p)) p => real_row(sim%elements%p, ne)
    case (ckr_elements_q); if (allocated(sim%elements%q)) p => real_row(sim%elements%q, ne)
    case (ckr_elements_eps_p); if (allocated(sim%elements%eps_p)) p => real_row(sim%elements%eps_p, ne)
    case (ckr_elements_e); if (allocated(sim%elements%e)) p => real_row(sim%elements%e, ne)
    case (ckr_elements_temp); if (allocated(sim%elements%temp)) p => real_row(sim%elements%temp, ne)
    case (ckr_elements_c); if (allocated(sim%elements%c)) p => real_row(sim%elements%c, ne)
    case (ckr_elements_area); if (allocated(sim%elements%area)) p => real_row(sim%elements%area, ne)
    case (ckr_elements_rbar); if (allocated(sim%elements%rbar)) p => real_row(sim%elements%rbar, ne)
    case (ckr_elements_volume); if (allocated(sim%elements%volume)) p => real_row(sim%elements%volume, ne)
    case (ckr_elements_lmin); if (allocated(sim%elements%lmin)) p => real_row(sim%elements%lmin, ne)
    case (ckr_elements_d); if (allocated(sim%elements%d)) p => sim%elements%d
    case (ckr_elements_spin); if (allocated(sim%elements%spin)) p => real_row(sim%elements%spin, ne)
    case (ckr_particles_x); if (allocated(sim%particles%x)) p => sim%particles%x(:, 1:np)
    case (ckr_particles_x0); if (allocated(sim%particles%x0)) p => sim%particles%x0(:, 1:np)
    case (ckr_particles_v); if (allocated(sim%particles%v)) p => sim%particles%v(:, 1:np)
    case (ckr_particles_mass); if (allocated(sim%particles%mass)) p => real_row(sim%particles%mass, np)
    case (ckr_particles_h); if (allocated(sim%particles%h)) p => real_row(sim%particles%h, np)
    case (ckr_particles_radius); if (allocated(sim%particles%radius)) p => real_row(sim%particles%radius, np)
    case (ckr_particles_rho); if (allocated(sim%particles%rho)) p => real_row(sim%particles%rho, np)
    case (ckr_particles_s); if (allocated(sim%particles%s)) p => sim%particles%s(:, 1:np)
    case (ckr_particles_p); if (allocated(sim%particles%p)) p => real_row(sim%particles%p, np)
    case (ckr_particles_eps_p); if (allocated(sim%particles%eps_p)) p => real_row(sim%particles%eps_p, np)
    case (ckr_particles_e); if (allocated(sim%particles%e)) p => real_row(sim%particles%e, np)
    case (ckr_particles_temp); if (allocated(sim%particles%temp)) p => real_row(sim%particles%temp, np)
    case (ckr_particles_c); if (allocated(sim%particles%c)) p => real_row(sim%particles%c, np)
    case (ckr_particles_tie_xi); if (allocated(sim%particles%tie_xi)) p => real_row(sim%particles%tie_xi, np)
    case (ckr_nodes_mass_eroded); if (allocated(sim%nodes%mass_eroded)) p => real_row(sim%nodes%mass_eroded, nn)
    case (ckr_elements_hist); if (allocated(sim%elements%hist)) p => sim%elements%hist
    case (ckr_particles_hist); if (allocated(sim%particles%hist)) p => sim%particles%hist(:, 1:np)
    case (ckr_particles_d); if (allocated(sim%particles%d)) p => sim%particles%d(:, 1:np)
    case (ckr_particles_grad_v); if (allocated(sim%particles%grad_v)) p => sim%particles%grad_v(:, 1:np)
    end select
  end function real_view

  !> Rank-2 view (rows, cols) of integer array `id` (null if not allocated).
  function int_view(sim, id) result(p)
    type(simulation_t), intent(in), target :: sim
    integer, intent(in) :: id
    integer, pointer :: p(:, :)
    integer :: nn, ne, np
    nn = sim%nodes%n
    ne = sim%elements%n
    np = sim%particles%n
    p => null()
    select case (id)
    case (cki_elements_conn); if (allocated(sim%elements%conn)) p => sim%elements%conn
    case (cki_elements_mat); if (allocated(sim%elements%mat)) p => int_row(sim%elements%mat, ne)
    case (cki_elements_body); if (allocated(sim%elements%body)) p => int_row(sim%elements%body, ne)
    case (cki_elements_group); if (allocated(sim%elements%group)) p => int_row(sim%elements%group, ne)
    case (cki_elements_id); if (allocated(sim%elements%id)) p => int_row(sim%elements%id, ne)
    case (cki_nodes_on_axis); if (allocated(sim%nodes%on_axis_int)) p => int_row(sim%nodes%on_axis_int, nn)
    case (cki_particles_mat); if (allocated(sim%particles%mat)) p => int_row(sim%particles%mat, np)
    case (cki_particles_body); if (allocated(sim%particles%body)) p => int_row(sim%particles%body, np)
    case (cki_particles_continuum); if (allocated(sim%particles%continuum)) p => int_row(sim%particles%continuum, np)
    case (cki_particles_tie_a); if (allocated(sim%particles%tie_a)) p => int_row(sim%particles%tie_a, np)
    case (cki_particles_tie_b); if (allocated(sim%particles%tie_b)) p => int_row(sim%particles%tie_b, np)
    case (cki_particles_assoc); if (allocated(sim%particles%assoc)) p => sim%particles%assoc(:, 1:np)
    case (cki_particles_id); if (allocated(sim%particles%id)) p => int_row(sim%particles%id, np)
    case (cki_coupling_edge); if (allocated(sim%coupling%edge)) p => sim%coupling%edge(:, 1:sim%coupling%n_edges)
    end select
  end function int_view

  !> A (1, n) view of the first n entries of a rank-1 state array.
  function real_row(a, n) result(p)
    real(wp), intent(in), target :: a(:)
    integer, intent(in) :: n
    real(wp), pointer :: p(:, :)
    p(1:1, 1:n) => a(1:n)
  end function real_row

  function int_row(a, n) result(p)
    integer, intent(in), target :: a(:)
    integer, intent(in) :: n
    integer, pointer :: p(:, :)
    p(1:1, 1:n) => a(1:n)
  end function int_row

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
