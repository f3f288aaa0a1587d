!> The state arrays a checkpoint holds, each reachable by its id (named in
!> fsph_layouts, generated from fsph/layouts.py) as a (rows, cols) view:
!> the checkpoint and restore copy them out and back in (fsph_restart,
!> fsph_api), and the particles renumbered in spatial order move with
!> them (permute_particles), so that the one list of the checkpoint is
!> also the list of what a particle's state is.
module fsph_state_views
  use fsph_kinds, only: wp
  use fsph_state, only: simulation_t
  use fsph_layouts
  implicit none
  private

  public :: real_view, int_view, permute_particles

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

  !> Renumber the real particles: particle k takes the state of particle
  !> order(k) (fsph_spatial spatial_order), id included. What moves is
  !> every particle array of the checkpoint (fsph_layouts ckr_of_particles,
  !> cki_of_particles), which a restart shows to be the whole state the
  !> next cycle reads; the rest (mid-step and work arrays) is recomputed
  !> before it is read, and the neighbour lists, imaginary and mirror
  !> entries and pair arrays are rebuilt at the next cycle. What refers to
  !> particles by number outside the set (gauges) is the caller's to follow.
  subroutine permute_particles(sim, order)
    type(simulation_t), intent(inout), target :: sim
    integer, intent(in) :: order(:)        !< size: the real particles
    real(wp), pointer :: pr(:, :)
    integer, pointer :: pi(:, :)
    integer :: k
    do k = 1, size(ckr_of_particles)
      pr => real_view(sim, ckr_of_particles(k))
      if (associated(pr)) pr = pr(:, order)
    end do
    do k = 1, size(cki_of_particles)
      pi => int_view(sim, cki_of_particles(k))
      if (associated(pi)) pi = pi(:, order)
    end do
    sim%particles%lists_valid = .false.
  end subroutine permute_particles

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

end module fsph_state_views
