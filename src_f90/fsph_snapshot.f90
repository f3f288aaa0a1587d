!> A snapshot of a run: the nodes, elements and particles as plain field
!> rows in the order of fsph_layouts (nf_*, ef_*, pf_*, id_*, ss_*), read
!> from the state and never written back. What the output needs that the
!> state does not hold (a particle's current radius, the deepest contact
!> penetration) is computed here into the snapshot, not into the state.
module fsph_snapshot
  use fsph_kinds, only: wp
  use fsph_state, only: simulation_t, node_set_t, element_set_t, particle_set_t
  use fsph_layouts, only: nf_x_r, nf_x0_r, nf_v_r, nf_mass, ms_s_rr, ms_s_tt, ms_p, ms_eps_p, ms_rho, ms_e, &
                          ms_temp, ms_c, ms_damage, ms_failed, ms_melted, n_material_state_fields, ef_s_rr, &
                          ef_q, ef_area, ef_mass, pf_x_r, pf_x0_r, pf_v_r, pf_mass, pf_h, pf_radius, pf_s_rr, &
                          id_material, id_body, id_id, ss_time, ss_cycle, ss_contact_penetration, &
                          ss_contact_penetration_relative, ss_eroded_momentum_z, hist_damage, hist_failed, &
                          hist_melted, prop_rho0
  implicit none
  private

  public :: node_rows, element_rows, particle_rows, snapshot_scalars

contains

  !> Node rows (fsph_layouts nf_*): position and initial position (r, z)
  !> [m], velocity [m/s], mass [kg].
  subroutine node_rows(nd, fields)
    type(node_set_t), intent(in) :: nd
    real(wp), intent(out) :: fields(:, :)
    integer :: n
    n = nd%n
    fields(nf_x_r:nf_x_r + 1, :) = nd%x(:, 1:n)
    fields(nf_x0_r:nf_x0_r + 1, :) = nd%x0(:, 1:n)
    fields(nf_v_r:nf_v_r + 1, :) = nd%v(:, 1:n)
    fields(nf_mass, :) = nd%mass(1:n)
  end subroutine node_rows

  !> Element rows (fsph_layouts ef_*): the material state (below), viscous
  !> pressure [Pa], area [m^2], mass [kg]; connectivity (1-based) and the
  !> material and body of each element (id_*).
  subroutine element_rows(el, conn, ids, fields)
    type(element_set_t), intent(in) :: el
    integer, intent(out) :: conn(:, :), ids(:, :)
    real(wp), intent(out) :: fields(:, :)
    integer :: n
    n = el%n
    conn = el%conn(:, 1:n)
    ids(id_material, :) = el%mat(1:n)
    ids(id_body, :) = el%body(1:n)
    ids(id_id, :) = el%id(1:n)
    call material_state_rows(n, el%s, el%p, el%eps_p, el%rho, el%e, el%temp, el%c, el%hist, &
                             fields(ef_s_rr:ef_s_rr + n_material_state_fields - 1, :))
    fields(ef_q, :) = el%q(1:n)
    fields(ef_area, :) = el%area(1:n)
    fields(ef_mass, :) = el%mass(1:n)
  end subroutine element_rows

  !> Particle rows (fsph_layouts pf_*): position, initial position [m],
  !> velocity [m/s], mass [kg], smoothing length [m], radius at the current
  !> position and density (not below the reference density, as the
  !> particle contact takes it) [m], then the material state (below);
  !> material and body.
  subroutine particle_rows(pt, props, ids, fields)
    use fsph_sph, only: particle_radius
    type(particle_set_t), intent(in) :: pt
    real(wp), intent(in) :: props(:, :)   !< material table (n_props, n_materials)
    integer, intent(out) :: ids(:, :)
    real(wp), intent(out) :: fields(:, :)
    integer :: i, n
    n = pt%n
    ids(id_material, :) = pt%mat(1:n)
    ids(id_body, :) = pt%body(1:n)
    ids(id_id, :) = pt%id(1:n)
    fields(pf_x_r:pf_x_r + 1, :) = pt%x(:, 1:n)
    fields(pf_x0_r:pf_x0_r + 1, :) = pt%x0(:, 1:n)
    fields(pf_v_r:pf_v_r + 1, :) = pt%v(:, 1:n)
    fields(pf_mass, :) = pt%mass(1:n)
    fields(pf_h, :) = pt%h(1:n)
    do i = 1, n
      fields(pf_radius, i) = particle_radius(pt%mass(i), pt%x(1, i), max(pt%rho(i), props(prop_rho0, pt%mat(i))))
    end do
    call material_state_rows(n, pt%s, pt%p, pt%eps_p, pt%rho, pt%e, pt%temp, pt%c, pt%hist, &
                             fields(pf_s_rr:pf_s_rr + n_material_state_fields - 1, :))
  end subroutine particle_rows

  !> The material state rows (fsph_layouts ms_*) of n points, shared by
  !> elements and particles: deviator (rr, zz, rz, tt) [Pa], pressure [Pa],
  !> plastic strain [-], density [kg/m^3], specific internal energy [J/kg],
  !> temperature [K], sound speed [m/s], damage [-], failed and melted
  !> (1 or 0).
  subroutine material_state_rows(n, s, p, eps_p, rho, e, temp, c, hist, rows)
    integer, intent(in) :: n
    real(wp), intent(in) :: s(:, :), p(:), eps_p(:), rho(:), e(:), temp(:), c(:), hist(:, :)
    real(wp), intent(out) :: rows(:, :)
    rows(ms_s_rr:ms_s_tt, :) = s(:, 1:n)
    rows(ms_p, :) = p(1:n)
    rows(ms_eps_p, :) = eps_p(1:n)
    rows(ms_rho, :) = rho(1:n)
    rows(ms_e, :) = e(1:n)
    rows(ms_temp, :) = temp(1:n)
    rows(ms_c, :) = c(1:n)
    rows(ms_damage, :) = hist(hist_damage, 1:n)
    rows(ms_failed, :) = hist(hist_failed, 1:n)
    rows(ms_melted, :) = hist(hist_melted, 1:n)
  end subroutine material_state_rows

  !> Snapshot scalars (fsph_layouts ss_*): time [s], cycle, deepest
  !> interpenetration of bodies [m] and relative to the penetrated
  !> segment [-], z momentum removed by erosion [kg m/s].
  subroutine snapshot_scalars(sim, scalars)
    use fsph_contact, only: contact_penetration
    type(simulation_t), intent(in) :: sim
    real(wp), intent(out) :: scalars(:)
    real(wp) :: depth, relative
    call contact_penetration(sim%contact, sim%nodes, sim%particles, depth, relative)
    scalars(ss_time) = sim%time
    scalars(ss_cycle) = real(sim%cycle, wp)
    scalars(ss_contact_penetration) = depth
    scalars(ss_contact_penetration_relative) = relative
    scalars(ss_eroded_momentum_z) = sim%erosion%momentum(2)
  end subroutine snapshot_scalars

end module fsph_snapshot
