!> A snapshot of a run: the nodes, elements and particles as plain field
!> rows in the order of fsph_layouts (nf_*, ef_*, pf_*, id_*, ss_*), read
!> from the state and never written back. What the output needs that the
!> state does not hold (a particle's current radius, the deepest contact
!> penetration) is computed here into the snapshot, not into the state.
module fsph_snapshot
  use fsph_kinds, only: wp
  use fsph_state, only: simulation_t, node_set_t, element_set_t, particle_set_t
  use fsph_layouts, only: nf_x_r, nf_x0_r, nf_v_r, nf_mass, &
                          ef_s_rr, ef_s_tt, ef_p, ef_q, ef_eps_p, ef_rho, ef_e, ef_temp, ef_c, ef_area, &
                          ef_mass, ef_damage, pf_x_r, pf_x0_r, pf_v_r, pf_mass, pf_h, pf_radius, &
                          pf_s_rr, pf_s_tt, pf_p, pf_eps_p, pf_rho, pf_e, pf_temp, pf_c, pf_damage, &
                          id_material, id_body, ss_time, ss_cycle, ss_contact_penetration, &
                          ss_contact_penetration_relative, ss_eroded_momentum_z, hist_damage, prop_rho0
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

  !> Element rows (fsph_layouts ef_*): deviator (rr, zz, rz, tt) [Pa],
  !> pressure and viscous pressure [Pa], plastic strain [-], density
  !> [kg/m^3], specific internal energy [J/kg], temperature [K], sound
  !> speed [m/s], area [m^2], mass [kg], damage [-]; connectivity (1-based)
  !> and the material and body of each element (id_*).
  subroutine element_rows(el, conn, ids, fields)
    type(element_set_t), intent(in) :: el
    integer, intent(out) :: conn(:, :), ids(:, :)
    real(wp), intent(out) :: fields(:, :)
    integer :: n
    n = el%n
    conn = el%conn(:, 1:n)
    ids(id_material, :) = el%mat(1:n)
    ids(id_body, :) = el%body(1:n)
    fields(ef_s_rr:ef_s_tt, :) = el%s(:, 1:n)
    fields(ef_p, :) = el%p(1:n)
    fields(ef_q, :) = el%q(1:n)
    fields(ef_eps_p, :) = el%eps_p(1:n)
    fields(ef_rho, :) = el%rho(1:n)
    fields(ef_e, :) = el%e(1:n)
    fields(ef_temp, :) = el%temp(1:n)
    fields(ef_c, :) = el%c(1:n)
    fields(ef_area, :) = el%area(1:n)
    fields(ef_mass, :) = el%mass(1:n)
    fields(ef_damage, :) = el%hist(hist_damage, 1:n)
  end subroutine element_rows

  !> Particle rows (fsph_layouts pf_*): position, initial position [m],
  !> velocity [m/s], mass [kg], smoothing length [m], radius at the current
  !> position and density (not below the reference density, as the
  !> particle contact takes it) [m], deviator [Pa], pressure [Pa], plastic
  !> strain [-], density [kg/m^3], specific internal energy [J/kg],
  !> temperature [K], sound speed [m/s], damage [-]; material and body.
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
    fields(pf_x_r:pf_x_r + 1, :) = pt%x(:, 1:n)
    fields(pf_x0_r:pf_x0_r + 1, :) = pt%x0(:, 1:n)
    fields(pf_v_r:pf_v_r + 1, :) = pt%v(:, 1:n)
    fields(pf_mass, :) = pt%mass(1:n)
    fields(pf_h, :) = pt%h(1:n)
    do i = 1, n
      fields(pf_radius, i) = particle_radius(pt%mass(i), pt%x(1, i), max(pt%rho(i), props(prop_rho0, pt%mat(i))))
    end do
    fields(pf_s_rr:pf_s_tt, :) = pt%s(:, 1:n)
    fields(pf_p, :) = pt%p(1:n)
    fields(pf_eps_p, :) = pt%eps_p(1:n)
    fields(pf_rho, :) = pt%rho(1:n)
    fields(pf_e, :) = pt%e(1:n)
    fields(pf_temp, :) = pt%temp(1:n)
    fields(pf_c, :) = pt%c(1:n)
    fields(pf_damage, :) = pt%hist(hist_damage, 1:n)
  end subroutine particle_rows

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
