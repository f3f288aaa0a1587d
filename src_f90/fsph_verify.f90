!> Verification entry points, exposed to Python beside fsph_api (as
!> fsph._core.fsph_verify) and used by the tests only: they set states no
!> deck can reach (uniform stresses), run one kernel on given input (a
!> material point, an HJC pressure, a contact pair, a triangle's strain)
!> or expose intermediate products of the cycle (forces, SPH rates,
!> neighbour lists, ties). Single state arrays (velocities, energies,
!> groups) are read and overwritten by name through the checkpoint views
!> instead (fsph_api get_real_state, set_real_state; fsph.checkpoint
!> state_array). The driver never calls them.
module fsph_verify
  use fsph_kinds, only: wp
  use fsph_state, only: simulation_t
  use fsph_runs, only: run_state
  implicit none
  private
  public :: get_particle_rates, get_principal_strains, triangle_principal_strain
  public :: hjc_point_pressure, contact_pair_values, riemann_pair_values, get_particle_ties, convert_now
  public :: set_stress_state
  public :: get_forces, set_neighbour_width, get_neighbour_count, get_neighbours
  public :: get_strain_rates, material_point, material_point_functions, spatial_order_of, renumber_due_at

contains

  !> SPH rates for the current positions and velocities (verification):
  !> accelerations [m/s^2], density rate [kg/(m^3 s)], energy rate
  !> [J/(kg s)], strain rates (rr, zz, rz, tt) and spin [1/s]. Builds the
  !> neighbour lists; does not change the state.
  subroutine get_particle_rates(run, np, acc, drho, de, d, spin, ierr)
    use fsph_status, only: status_ok, status_bad_input
    use fsph_sph, only: sph_accelerations, sph_rates, sph_energy_rate, pair_weights, compression_switch, &
                        axis_resultant, artificial_stress, artificial_reference
    use fsph_solver, only: prepare_particle_sums
    use fsph_layouts, only: hist_contact_corrected
    use fsph_coupling, only: reaction_velocities
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: np
    real(wp), intent(out) :: acc(2, np), drho(np), de(np), d(4, np), spin(np)
    integer, intent(out) :: ierr
    integer :: ntot
    real(wp), allocatable :: grad_v(:, :), switch(:)
    real(wp) :: no_nodes(2, 0)
    sim => run_state(run)
    ierr = status_bad_input
    acc = 0.0_wp; drho = 0.0_wp; de = 0.0_wp; d = 0.0_wp; spin = 0.0_wp
    if (np /= sim%particles%n .or. np == 0 .or. .not. sim%ready) return
    call prepare_particle_sums(sim, ntot)
    allocate (grad_v(4, np), switch(np))
    associate (pt => sim%particles)
      call pair_weights(ntot, pt%x, pt%mass, pt%rho, pt%wgt, pt%planar_area)
      if (sim%control%sph_artificial_stress > 0.0_wp) &
        call artificial_stress(np, ntot, pt%n_imag, pt%sig, sim%control%sph_artificial_stress, pt%art_stress)
      ! the pairs of this state (pair_in), then its velocity gradient and
      ! compression switch, then the accelerations with them
      grad_v = 0.0_wp
      switch = 0.0_wp
      call sph_accelerations(np, ntot, pt%n_imag, pt%x, pt%v, pt%mass, pt%rho, pt%h, pt%c, pt%sig, pt%wgt, pt%intact, &
                             grad_v, switch, pt%hist(hist_contact_corrected, 1:np), pt%mirror_of, pt%nbr_ptr, &
                             pt%nbr_list, pt%low_ptr, pt%low_pair, pt%low_other, &
                             sim%control%sph_c_q, sim%control%sph_c_l, 0.0_wp, 0.0_wp, pt%art_stress, 1.0_wp, acc, &
                             pt%pair_q, pt%pair_force, pt%pair_hg, pt%pair_in, pt%acc_imag, pt%acc_axis)
      call sph_rates(np, ntot, pt%x, pt%v, pt%mass, pt%rho, pt%h, pt%planar_area, pt%intact, pt%nbr_ptr, &
                     pt%nbr_list, pt%low_ptr, pt%low_pair, pt%low_other, pt%pair_in, pt%nbr_grad, pt%rate_sums, &
                     drho, d, spin, grad_v)
      call compression_switch(np, d, pt%c, pt%h, switch)
      call sph_accelerations(np, ntot, pt%n_imag, pt%x, pt%v, pt%mass, pt%rho, pt%h, pt%c, pt%sig, pt%wgt, pt%intact, &
                             grad_v, switch, pt%hist(hist_contact_corrected, 1:np), pt%mirror_of, pt%nbr_ptr, &
                             pt%nbr_list, pt%low_ptr, pt%low_pair, pt%low_other, &
                             sim%control%sph_c_q, sim%control%sph_c_l, sim%control%sph_c_hg, &
                             sim%control%sph_artificial_stress, pt%art_stress, &
                             artificial_reference(sim%conversion%alpha_h), acc, pt%pair_q, &
                             pt%pair_force, pt%pair_hg, pt%pair_in, pt%acc_imag, pt%acc_axis)
      call axis_resultant(np, pt%mass, pt%nbr_ptr, pt%half_end, pt%nbr_list, pt%pair_in, pt%acc_axis, acc)
      ! the energy equation with the stress, viscosity and velocities of this state
      if (sim%nodes%n > 0) then
        call reaction_velocities(sim%coupling, pt, sim%nodes%v(:, 1:sim%nodes%n), sim%nodes%v(:, 1:sim%nodes%n), &
                                 1.0_wp)
      else
        call reaction_velocities(sim%coupling, pt, no_nodes, no_nodes, 1.0_wp)
      end if
      call sph_energy_rate(np, ntot, pt%n_imag, pt%x, pt%v, pt%v, pt%mass, pt%rho, pt%h, pt%sig, pt%wgt, &
                           pt%intact, sim%coupling%imag_work, sim%coupling%v_react, pt%nbr_ptr, pt%nbr_list, &
                           pt%low_ptr, pt%low_pair, pt%low_other, &
                           pt%pair_q, pt%pair_hg, pt%pair_force, pt%nbr_grad, sim%control%sph_artificial_stress, &
                           pt%art_stress, artificial_reference(sim%conversion%alpha_h), pt%pair_work, de, pt%de_parts)
    end associate
    ierr = status_ok
  end subroutine get_particle_rates

  !> Largest principal logarithmic strain of every element [-] (the erosion
  !> measure).
  subroutine get_principal_strains(run, ne, strain, ierr)
    use fsph_status, only: status_ok, status_bad_input
    use fsph_erosion, only: principal_strains
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: ne
    real(wp), intent(out) :: strain(ne)
    integer, intent(out) :: ierr
    sim => run_state(run)
    strain = 0.0_wp
    ierr = status_bad_input
    if (ne /= sim%elements%n .or. ne == 0) return
    call principal_strains(ne, sim%nodes%n, sim%elements%conn, sim%nodes%x, sim%nodes%x0, strain)
    ierr = status_ok
  end subroutine get_principal_strains

  !> Largest principal logarithmic strain of one triangle from its initial
  !> and current node positions (r, z) [m] (unit tests of the measure).
  subroutine triangle_principal_strain(x, x0, strain)
    use fsph_erosion, only: principal_log_strain
    real(wp), intent(in) :: x(2, 3), x0(2, 3)
    real(wp), intent(out) :: strain
    strain = principal_log_strain(x, x0)
  end subroutine triangle_principal_strain

  !> The order in which n points (r, z) [m] with smoothing lengths h [m]
  !> are renumbered: order(k) is the point (1-based) that takes place k
  !> (fsph_spatial spatial_order).
  subroutine spatial_order_of(n, x, h, order)
    use fsph_spatial, only: spatial_order
    integer, intent(in) :: n
    real(wp), intent(in) :: x(2, n), h(n)
    integer, intent(out) :: order(n)
    call spatial_order(n, x, h, order)
  end subroutine spatial_order_of

  !> Whether a conversion that took the particles from n_before to n_after
  !> renumbers them, with &sph spatial_order_min = n_min (fsph_spatial).
  subroutine renumber_due_at(n_before, n_after, n_min, due)
    use fsph_spatial, only: renumber_due
    integer, intent(in) :: n_before, n_after, n_min
    logical, intent(out) :: due
    due = renumber_due(n_before, n_after, n_min)
  end subroutine renumber_due_at

  !> HJC pressure of one point (unit tests of the branches): volumetric
  !> strain, damage and largest strain so far in; pressure [Pa], dp/dmu [Pa]
  !> and the growth of the permanent volumetric strain out.
  subroutine hjc_point_pressure(nprop, props, mu, damage, mu_max, p, dpdmu, dmu_p, ierr)
    use fsph_layouts, only: n_props
    use fsph_material, only: hjc_pressure
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: nprop
    real(wp), intent(in) :: props(nprop), mu, damage
    real(wp), intent(inout) :: mu_max
    real(wp), intent(out) :: p, dpdmu, dmu_p
    integer, intent(out) :: ierr
    p = 0.0_wp; dpdmu = 0.0_wp; dmu_p = 0.0_wp
    ierr = status_bad_input
    if (nprop /= n_props) return
    call hjc_pressure(props, mu, damage, mu_max, p, dpdmu, dmu_p)
    ierr = status_ok
  end subroutine hjc_point_pressure

  !> The correction of one contact pair (Hu et al. 2013 eqs 1-3), for
  !> verification: normal velocity changes of slave and master nodes [m/s].
  subroutine contact_pair_values(delta, dt, m_s, m_1, m_2, r_1, r_2, dv_s, dv_1, dv_2)
    use fsph_contact, only: pair_correction
    real(wp), intent(in) :: delta, dt, m_s, m_1, m_2, r_1, r_2
    real(wp), intent(out) :: dv_s, dv_1, dv_2
    call pair_correction(delta, dt, m_s, m_1, m_2, r_1, r_2, dv_s, dv_1, dv_2)
  end subroutine contact_pair_values

  !> The acoustic Riemann problem of one particle contact pair
  !> (fsph_particles riemann_pair), for verification: unit normal nij
  !> from i to j, velocities [m/s], densities [kg/m^3], sound speeds
  !> [m/s], stresses (rr, zz, rz, tt) [Pa], sg the sign j is seen with;
  !> p_eq, p_star [Pa] and u_star [m/s].
  subroutine riemann_pair_values(nij, vi, rho_i, c_i, sig_i, vj, rho_j, c_j, sig_j, sg, p_eq, p_star, u_star)
    use fsph_particles, only: riemann_pair
    real(wp), intent(in) :: nij(2), vi(2), rho_i, c_i, sig_i(4), vj(2), rho_j, c_j, sig_j(4), sg
    real(wp), intent(out) :: p_eq, p_star, u_star
    call riemann_pair(nij, vi, rho_i, c_i, sig_i, vj, rho_j, c_j, sig_j, sg, p_eq, p_star, u_star)
  end subroutine riemann_pair_values

  !> Ties and associations of the particles: tied edge nodes (0: free),
  !> position along the edge, and the node pairs of up to two associated
  !> coupling edges (0: none).
  subroutine get_particle_ties(run, np, tie_a, tie_b, tie_xi, assoc_nodes)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: np
    integer, intent(out) :: tie_a(np), tie_b(np), assoc_nodes(2, 2, np)
    real(wp), intent(out) :: tie_xi(np)
    integer :: i, slot
    sim => run_state(run)
    tie_a = 0; tie_b = 0; tie_xi = 0.0_wp; assoc_nodes = 0
    if (np /= sim%particles%n .or. np == 0) return
    associate (pt => sim%particles)
      tie_a = pt%tie_a(1:np); tie_b = pt%tie_b(1:np); tie_xi = pt%tie_xi(1:np)
      do i = 1, np
        do slot = 1, 2
          if (pt%assoc(slot, i) > 0) assoc_nodes(:, slot, i) = sim%coupling%edge(:, pt%assoc(slot, i))
        end do
      end do
    end associate
  end subroutine get_particle_ties

  !> Run the conversion check of the cycle now (verification): returns the
  !> number of elements converted.
  subroutine convert_now(run, n_new)
    use fsph_convert, only: convert_elements
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(out) :: n_new
    sim => run_state(run)
    call convert_elements(sim%elements, sim%nodes, sim%particles, sim%coupling, sim%conversion, sim%contact, &
                          sim%continuum_of_body, sim%body_coupled, n_new)
  end subroutine convert_now

  !> Give every element and real particle the deviator s (rr, zz, rz, tt)
  !> [Pa] and pressure p [Pa] (verification of equilibrium states).
  subroutine set_stress_state(run, s, p)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    real(wp), intent(in) :: s(4), p
    integer :: i
    sim => run_state(run)
    do i = 1, sim%elements%n
      sim%elements%s(:, i) = s
      sim%elements%p(i) = p
      sim%elements%q(i) = 0.0_wp
    end do
    do i = 1, sim%particles%n
      sim%particles%s(:, i) = s
      sim%particles%p(i) = p
    end do
  end subroutine set_stress_state

  !> Forces of the current state as the cycle computes them (element nodal
  !> forces with coupling tractions and tie forces [N], particle
  !> accelerations [m/s^2]), without advancing (verification). dt [s] is
  !> the step the particle contact penalty would use.
  subroutine get_forces(run, nn, np, dt, f, acc)
    use fsph_solver, only: solver_forces
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: nn, np
    real(wp), intent(in) :: dt
    real(wp), intent(out) :: f(2, nn), acc(2, np)
    integer :: ierr, ifault
    sim => run_state(run)
    f = 0.0_wp
    acc = 0.0_wp
    if (nn /= sim%nodes%n .or. np /= sim%particles%n) return
    call solver_forces(sim, dt, ierr, ifault)
    if (nn > 0) f = sim%nodes%f(:, 1:nn)
    if (np > 0) acc = sim%particles%acc(:, 1:np)
  end subroutine get_forces

  !> Row width of the neighbour search's buffers (verification: the lists
  !> must not depend on it; it grows by itself when a list is longer).
  subroutine set_neighbour_width(run, width)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: width
    sim => run_state(run)
    sim%particles%search%width = max(width, 1)
    sim%particles%lists_valid = .false.
  end subroutine set_neighbour_width

  !> Total number of neighbour entries (ghosts included) of the last search,
  !> each pair of real particles counted in both particles' lists.
  subroutine get_neighbour_count(run, nentries)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(out) :: nentries
    integer :: n
    sim => run_state(run)
    nentries = 0
    n = sim%particles%n
    if (n > 0 .and. allocated(sim%particles%nbr_list)) &
      nentries = sim%particles%nbr_ptr(n + 1) - 1 + sim%particles%low_ptr(n + 1) - 1
  end subroutine get_neighbour_count

  !> Full neighbour lists of the last search: CSR pointer (np+1) and entries
  !> (+j neighbour, -j mirror of j across the axis): each particle's own
  !> row (half and one-way entries) followed by its low partners.
  !> consistent = 1 when every low entry points at the pair entry that
  !> holds the particle in its partner's half row (verification).
  subroutine get_neighbours(run, np, nentries, ptr, list, consistent)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: np, nentries
    integer, intent(out) :: ptr(np + 1), list(nentries), consistent
    integer :: i, n_own, n_low, m, k, j
    sim => run_state(run)
    ptr = 1
    list = 0
    consistent = 0
    if (np /= sim%particles%n .or. np == 0) return
    associate (pt => sim%particles)
      if (nentries /= pt%nbr_ptr(np + 1) - 1 + pt%low_ptr(np + 1) - 1) return
      consistent = 1
      do i = 1, np
        n_own = pt%nbr_ptr(i + 1) - pt%nbr_ptr(i)
        n_low = pt%low_ptr(i + 1) - pt%low_ptr(i)
        ptr(i + 1) = ptr(i) + n_own + n_low
        list(ptr(i):ptr(i) + n_own - 1) = pt%nbr_list(pt%nbr_ptr(i):pt%nbr_ptr(i + 1) - 1)
        list(ptr(i) + n_own:ptr(i + 1) - 1) = pt%low_other(pt%low_ptr(i):pt%low_ptr(i + 1) - 1)
        do m = pt%low_ptr(i), pt%low_ptr(i + 1) - 1
          j = pt%low_other(m)
          k = pt%low_pair(m)
          if (j >= i .or. k < pt%nbr_ptr(j) .or. k >= pt%half_end(j)) then
            consistent = 0
          else if (pt%nbr_list(k) /= i) then
            consistent = 0
          end if
        end do
      end do
    end associate
  end subroutine get_neighbours

  !> Strain rates (rr, zz, rz, tt) [1/s] and spin [1/s] of every element for
  !> the current positions and velocities (the kernel the cycle uses).
  subroutine get_strain_rates(run, ne, d, spin, ierr)
    use fsph_status, only: status_ok, status_bad_input
    use fsph_element, only: element_strain_rates
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: ne
    real(wp), intent(out) :: d(4, ne), spin(ne)
    integer, intent(out) :: ierr
    sim => run_state(run)
    d = 0.0_wp
    spin = 0.0_wp
    ierr = status_bad_input
    if (ne /= sim%elements%n) return
    call element_strain_rates(ne, sim%nodes%n, sim%elements%conn, sim%nodes%x, sim%nodes%v, d, spin)
    ierr = status_ok
  end subroutine get_strain_rates

  !> One constitutive step of a single material point (unit tests of the
  !> material models; see fsph_material material_update).
  subroutine material_point(nprop, nh, props, istrength, ieos, dt, d, spin, rho_old, rho_new, q, &
                            s, p, eps_p, e, temp, hist, c, ierr)
    use fsph_layouts, only: n_props, n_hist
    use fsph_material, only: material_update
    use fsph_status, only: status_bad_input
    integer, intent(in) :: nprop, nh
    real(wp), intent(in) :: props(nprop)
    integer, intent(in) :: istrength, ieos
    real(wp), intent(in) :: dt, d(4), spin, rho_old, rho_new, q
    real(wp), intent(inout) :: s(4), p, eps_p, e, temp, hist(nh)
    real(wp), intent(out) :: c
    integer, intent(out) :: ierr
    c = 0.0_wp
    ierr = status_bad_input
    if (nprop /= n_props .or. nh /= n_hist) return
    call material_update(props, istrength, ieos, dt, d, spin, rho_old, rho_new, q, &
                         s, p, eps_p, e, temp, hist, c, ierr)
  end subroutine material_point

  !> The pure point functions of fsph_material at one state (unit tests of
  !> the models): melting temperature [K], shear modulus [Pa], flow stress
  !> [Pa] (at plastic strain eps_p, plastic strain rate rate_p and total
  !> equivalent strain rate rate_eq [1/s]), temperature of the state [K],
  !> energy of the reference isentrope at the state's volumetric strain
  !> [J/kg] and the pressure the point carries [Pa] (spall cut-off, no
  !> tension once failed).
  subroutine material_point_functions(nprop, nh, props, istrength, ieos, rho, e, p, temp, eps_p, rate_p, &
                                      rate_eq, hist, t_melt, g, sy, t_state, e_s, p_cut, ierr)
    use fsph_layouts, only: n_props, n_hist, prop_rho0
    use fsph_material, only: melting_temperature, shear_modulus, flow_stress_at, state_temperature, &
                             isentrope_energy, cut_pressure
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: nprop, nh
    real(wp), intent(in) :: props(nprop)
    integer, intent(in) :: istrength, ieos
    real(wp), intent(in) :: rho, e, p, temp, eps_p, rate_p, rate_eq, hist(nh)
    real(wp), intent(out) :: t_melt, g, sy, t_state, e_s, p_cut
    integer, intent(out) :: ierr
    t_melt = 0.0_wp; g = 0.0_wp; sy = 0.0_wp; t_state = 0.0_wp; e_s = 0.0_wp; p_cut = 0.0_wp
    ierr = status_bad_input
    if (nprop /= n_props .or. nh /= n_hist) return
    t_melt = melting_temperature(props, rho)
    g = shear_modulus(props, istrength, rho, p, temp)
    sy = flow_stress_at(props, istrength, eps_p, rate_p, rate_eq, p, temp, rho)
    t_state = state_temperature(props, ieos, rho, e, hist, temp)
    e_s = isentrope_energy(props, rho/props(prop_rho0) - 1.0_wp)
    p_cut = cut_pressure(props, hist, p)
    ierr = status_ok
  end subroutine material_point_functions

end module fsph_verify
