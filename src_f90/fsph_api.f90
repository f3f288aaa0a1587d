!> The only module exposed to Python (through numpy.f2py). Plain arrays and
!> scalars in and out; the state stays inside Fortran. Every routine that can
!> fail returns ierr (a fsph_status code) and, where useful, ifault (the
!> 1-based index of the element or node at fault). Nothing here stops the
!> process. A routine that reads or changes a run's state takes the run's
!> handle (open_run) first and works on that run alone (fsph_runs).
module fsph_api
  use fsph_kinds, only: wp
  use fsph_state, only: simulation_t
  use fsph_runs, only: run_state
  implicit none
  private
  public :: open_run, close_run, layout, threads, set_control, set_materials, set_mesh, add_rigid_plane
  public :: initialise, advance, get_sizes, get_clock, get_nodes, get_elements
  public :: get_element_fields, get_energies, set_node_velocities, set_particle_motion, set_element_energy
  public :: get_strain_rates
  public :: material_point, history_count, drain_history, set_sph_control, set_particles
  public :: get_particle_count, get_particles, get_particle_fields, get_particle_rates
  public :: get_neighbour_count, get_neighbours, kernel_values, set_continua, reserve_particles
  public :: set_conversion, get_element_groups, get_conversion_stats, get_particle_ties
  public :: convert_now, set_stress_state, get_forces
  public :: checkpoint_layout, checkpoint_sizes, get_real_state, get_int_state, set_real_state
  public :: set_int_state, get_scalar_state, restore_begin, restore_end
  public :: set_contact, get_contact_stats, get_contact_penetration, contact_pair_values
  public :: set_erosion, get_erosion_stats, get_material_history, get_plane_dissipation
  public :: get_principal_strains, hjc_point_pressure, triangle_principal_strain, get_debris_count
  public :: phase_count, get_phase_times, reset_phase_times, set_neighbour_width, get_list_rebuilds

contains

  !> A new, empty run: its handle, which every routine below that reads or
  !> changes a run's state takes first.
  subroutine open_run(run)
    use fsph_runs, only: run_open
    integer, intent(out) :: run
    call run_open(run)
  end subroutine open_run

  !> Free run `run` (a closed or unknown handle is ignored).
  subroutine close_run(run)
    use fsph_runs, only: run_close
    integer, intent(in) :: run
    call run_close(run)
  end subroutine close_run

  !> Sizes of the tables Python must match: number of material properties
  !> and of strength and EOS models.
  subroutine layout(nprop, n_strength, n_eos)
    use fsph_material, only: n_props, strength_johnson_cook, eos_mie_gruneisen
    integer, intent(out) :: nprop, n_strength, n_eos
    nprop = n_props
    n_strength = strength_johnson_cook
    n_eos = eos_mie_gruneisen
  end subroutine layout

  !> Number of timed phases of the cycle (fsph_timers).
  subroutine phase_count(n)
    use fsph_timers, only: n_phases
    integer, intent(out) :: n
    n = n_phases
  end subroutine phase_count

  !> Wall time [s] spent in each phase of the cycle since the last reset,
  !> in the order of fsph_timers (element forces, element update,
  !> neighbours, SPH sums, particle update, particle contact, coupling,
  !> contact, integration, conversion, time step).
  subroutine get_phase_times(run, n, times)
    use fsph_timers, only: n_phases
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: n
    real(wp), intent(out) :: times(n)
    sim => run_state(run)
    times = 0.0_wp
    times(1:min(n, n_phases)) = sim%timers%elapsed(1:min(n, n_phases))
  end subroutine get_phase_times

  !> Zero the phase timers of run `run`.
  subroutine reset_phase_times(run)
    use fsph_timers, only: phase_timers_t
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    sim => run_state(run)
    sim%timers = phase_timers_t()
  end subroutine reset_phase_times

  !> Number of OpenMP threads a parallel region will use (1 without OpenMP).
  subroutine threads(n)
    !$ use omp_lib, only: omp_get_max_threads
    integer, intent(out) :: n
    n = 1
    !$ n = omp_get_max_threads()
  end subroutine threads

  !> Numerical parameters of the cycle (see fsph_state control_t).
  subroutine set_control(run, dt_safety, c_q, c_l, dt_floor_ratio, dt_drop_ratio, history_every)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    real(wp), intent(in) :: dt_safety, c_q, c_l, dt_floor_ratio, dt_drop_ratio
    integer, intent(in) :: history_every
    sim => run_state(run)
    sim%control%history_every = max(history_every, 1)
    sim%control%dt_safety = dt_safety
    sim%control%c_q = c_q
    sim%control%c_l = c_l
    sim%control%dt_floor_ratio = dt_floor_ratio
    sim%control%dt_drop_ratio = dt_drop_ratio
  end subroutine set_control

  !> SPH parameters: viscosity coefficients [-] and the particle contact:
  !> penalty (fraction of an approach pushed back per step), other-body
  !> filling at touching and its rate per spacing of approach [-]; the
  !> debris density fraction [-]; the neighbour lists' skin as a fraction
  !> of the smallest kernel support (0: lists rebuilt every cycle) [-].
  subroutine set_sph_control(run, c_q, c_l, c_hg, contact_penalty, contact_touch, contact_slope, debris_ratio, &
                             neighbour_skin)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    real(wp), intent(in) :: c_q, c_l, contact_penalty, contact_touch, contact_slope
    real(wp), intent(in) :: c_hg          !< hourglass viscosity coefficient [-]
    real(wp), intent(in) :: debris_ratio  !< debris below this fraction of the reference density [-]
    real(wp), intent(in) :: neighbour_skin
    sim => run_state(run)
    sim%control%neighbour_skin = max(neighbour_skin, 0.0_wp)
    sim%particles%lists_valid = .false.
    sim%control%sph_c_q = c_q
    sim%control%sph_c_l = c_l
    sim%control%sph_c_hg = c_hg
    sim%control%contact_penalty = contact_penalty
    sim%control%contact_touch = contact_touch
    sim%control%contact_slope = contact_slope
    sim%control%debris_ratio = debris_ratio
  end subroutine set_sph_control

  !> Particles: positions (r, z) [m], velocities [m/s], ring masses [kg],
  !> smoothing lengths [m], material and body index.
  subroutine set_particles(run, np, x, v, mass, h, mat, body, ierr)
    use fsph_state, only: state_allocate_particles
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: np
    real(wp), intent(in) :: x(2, np), v(2, np), mass(np), h(np)
    integer, intent(in) :: mat(np), body(np)
    integer, intent(out) :: ierr
    sim => run_state(run)
    ierr = status_bad_input
    if (np < 1) return
    ! room for the imaginary particles of every element, and for the
    ! particles the elements may become
    call state_allocate_particles(sim, np, np + sim%elements%n)
    ! slices: whole-array assignment would reallocate to np and lose the room
    sim%particles%x(:, 1:np) = x
    sim%particles%v(:, 1:np) = v
    sim%particles%mass(1:np) = mass
    sim%particles%h(1:np) = h
    sim%particles%mat(1:np) = mat
    sim%particles%body(1:np) = body
    ierr = status_ok
  end subroutine set_particles

  subroutine get_particle_count(run, np)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(out) :: np
    sim => run_state(run)
    np = sim%particles%n
  end subroutine get_particle_count

  !> Particle positions, initial positions [m], velocities [m/s], masses
  !> [kg], smoothing lengths [m], radii [m], material and body index.
  subroutine get_particles(run, np, x, x0, v, mass, h, radius, mat, body)
    use fsph_solver, only: update_particle_radius
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: np
    real(wp), intent(out) :: x(2, np), x0(2, np), v(2, np), mass(np), h(np), radius(np)
    integer, intent(out) :: mat(np), body(np)
    sim => run_state(run)
    if (np /= sim%particles%n .or. np == 0) return
    associate (pt => sim%particles)
      x = pt%x(:, 1:np); x0 = pt%x0(:, 1:np); v = pt%v(:, 1:np); mass = pt%mass(1:np)
      h = pt%h(1:np)
      call update_particle_radius(sim)
      radius = pt%radius(1:np)
      mat = pt%mat(1:np); body = pt%body(1:np)
    end associate
  end subroutine get_particles

  !> Particle fields: deviator s (rr, zz, rz, tt) [Pa], pressure [Pa],
  !> plastic strain [-], density [kg/m^3], specific internal energy [J/kg],
  !> temperature [K], sound speed [m/s].
  subroutine get_particle_fields(run, np, s, p, eps_p, rho, e, temp, c)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: np
    real(wp), intent(out) :: s(4, np), p(np), eps_p(np), rho(np), e(np), temp(np), c(np)
    sim => run_state(run)
    if (np /= sim%particles%n .or. np == 0) return
    associate (pt => sim%particles)
      s = pt%s(:, 1:np); p = pt%p(1:np); eps_p = pt%eps_p(1:np); rho = pt%rho(1:np)
      e = pt%e(1:np); temp = pt%temp(1:np); c = pt%c(1:np)
    end associate
  end subroutine get_particle_fields

  !> SPH rates for the current positions and velocities (verification):
  !> accelerations [m/s^2], density rate [kg/(m^3 s)], energy rate
  !> [J/(kg s)], strain rates (rr, zz, rz, tt) and spin [1/s]. Builds the
  !> neighbour lists; does not change the state.
  subroutine get_particle_rates(run, np, acc, drho, de, d, spin, ierr)
    use fsph_status, only: status_ok, status_bad_input
    use fsph_sph, only: sph_accelerations, sph_rates, sph_energy_rate, pair_weights, compression_switch
    use fsph_solver, only: prepare_particle_sums
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: np
    real(wp), intent(out) :: acc(2, np), drho(np), de(np), d(4, np), spin(np)
    integer, intent(out) :: ierr
    integer :: ntot
    real(wp), allocatable :: grad_v(:, :), switch(:)
    sim => run_state(run)
    ierr = status_bad_input
    acc = 0.0_wp; drho = 0.0_wp; de = 0.0_wp; d = 0.0_wp; spin = 0.0_wp
    if (np /= sim%particles%n .or. np == 0 .or. .not. sim%ready) return
    call prepare_particle_sums(sim, ntot)
    allocate (grad_v(4, np), switch(np))
    associate (pt => sim%particles)
      call pair_weights(ntot, pt%x, pt%mass, pt%rho, pt%wgt, pt%planar_area)
      ! the pairs of this state (pair_in), then its velocity gradient and
      ! compression switch, then the accelerations with them
      grad_v = 0.0_wp
      switch = 0.0_wp
      call sph_accelerations(np, ntot, pt%n_imag, pt%x, pt%v, pt%mass, pt%rho, pt%h, pt%c, pt%sig, pt%wgt, &
                             grad_v, switch, pt%nbr_ptr, pt%nbr_list, pt%low_ptr, pt%low_pair, pt%low_other, &
                             sim%control%sph_c_q, sim%control%sph_c_l, 0.0_wp, acc, pt%pair_q, pt%pair_force, &
                             pt%pair_hg, pt%pair_in, pt%acc_imag)
      call sph_rates(np, ntot, pt%x, pt%v, pt%mass, pt%rho, pt%h, pt%planar_area, pt%nbr_ptr, pt%nbr_list, &
                     pt%low_ptr, pt%low_pair, pt%low_other, pt%pair_in, pt%nbr_grad, pt%rate_sums, drho, d, &
                     spin, grad_v)
      call compression_switch(np, d, pt%c, pt%h, switch)
      call sph_accelerations(np, ntot, pt%n_imag, pt%x, pt%v, pt%mass, pt%rho, pt%h, pt%c, pt%sig, pt%wgt, &
                             grad_v, switch, pt%nbr_ptr, pt%nbr_list, pt%low_ptr, pt%low_pair, pt%low_other, &
                             sim%control%sph_c_q, sim%control%sph_c_l, sim%control%sph_c_hg, acc, pt%pair_q, &
                             pt%pair_force, pt%pair_hg, pt%pair_in, pt%acc_imag)
      ! the energy equation with the stress, viscosity and velocities of this state
      call sph_energy_rate(np, ntot, pt%x, pt%v, pt%v, pt%mass, pt%rho, pt%sig, pt%wgt, pt%nbr_ptr, &
                           pt%nbr_list, pt%low_ptr, pt%low_pair, pt%low_other, pt%pair_q, pt%pair_hg, &
                           pt%pair_force, pt%nbr_grad, pt%pair_work, de)
    end associate
    ierr = status_ok
  end subroutine get_particle_rates

  !> Continuum index of every body (bodies joined into one continuum share
  !> it: SPH sums and coupling join them, contact does not) and whether the
  !> body's elements act as imaginary particles (coupled modes).
  subroutine set_continua(run, nbody, continuum, coupled, ierr)
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: nbody
    integer, intent(in) :: continuum(nbody), coupled(nbody)
    integer, intent(out) :: ierr
    sim => run_state(run)
    ierr = status_bad_input
    if (nbody < 1) return
    sim%continuum_of_body = continuum
    sim%body_coupled = coupled /= 0
    ierr = status_ok
  end subroutine set_continua

  !> Room for particles when a run starts with none (adaptive mode): one per
  !> element, plus the imaginary entries.
  subroutine reserve_particles(run, ierr)
    use fsph_state, only: state_allocate_particles
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(out) :: ierr
    sim => run_state(run)
    ierr = status_bad_input
    if (sim%particles%n > 0 .or. sim%elements%n == 0) return
    call state_allocate_particles(sim, 0, 2*sim%elements%n)
    ierr = status_ok
  end subroutine reserve_particles

  !> Conversion of elements to particles: enabled flag (0/1), criterion
  !> (1 minimum angle, 2 plastic strain, 3 equivalent stress), critical
  !> angle [rad], plastic strain [-], equivalent stress [Pa], group factor
  !> kappa [-] and smoothing-length factor alpha_h [-] (also used for the
  !> imaginary particles of fixed coupling).
  subroutine set_conversion(run, enabled, criterion, theta_c, theta_relative, eps_c, sigma_c, kappa, alpha_h)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: enabled, criterion
    real(wp), intent(in) :: theta_c, theta_relative, eps_c, sigma_c, kappa, alpha_h
    sim => run_state(run)
    sim%conversion%enabled = enabled /= 0
    sim%conversion%criterion = criterion
    sim%conversion%theta_c = theta_c
    sim%conversion%theta_relative = theta_relative
    sim%conversion%eps_c = eps_c
    sim%conversion%sigma_c = sigma_c
    sim%conversion%kappa = kappa
    sim%conversion%alpha_h = alpha_h
  end subroutine set_conversion

  !> Conversion group of every element (0: not in a coupled body).
  subroutine get_element_groups(run, ne, group)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: ne
    integer, intent(out) :: group(ne)
    sim => run_state(run)
    group = 0
    if (ne /= sim%elements%n .or. ne == 0) return
    group = sim%elements%group(1:ne)
  end subroutine get_element_groups

  !> Contact between bodies: on/off, correction passes per cycle, Coulomb
  !> friction coefficient [-], untied particles also against their own
  !> body's element surface (1/0).
  subroutine set_contact(run, enabled, n_passes, friction, own_particles, ierr)
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: enabled, n_passes, own_particles
    real(wp), intent(in) :: friction
    integer, intent(out) :: ierr
    sim => run_state(run)
    ierr = status_bad_input
    if (n_passes < 1 .or. .not. (friction >= 0.0_wp)) return
    sim%contact%enabled = enabled /= 0
    sim%contact%n_passes = n_passes
    sim%contact%friction = friction
    sim%contact%own_particles = own_particles /= 0
    ierr = status_ok
  end subroutine set_contact

  !> Element erosion (fsph_erosion): on/off and the largest principal
  !> (logarithmic) strain at which an element is deleted [-].
  subroutine set_erosion(run, enabled, strain_limit, ierr)
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: enabled
    real(wp), intent(in) :: strain_limit
    integer, intent(out) :: ierr
    sim => run_state(run)
    ierr = status_bad_input
    if (.not. (strain_limit > 0.0_wp)) return
    sim%erosion%enabled = enabled /= 0
    sim%erosion%strain_limit = strain_limit
    ierr = status_ok
  end subroutine set_erosion

  !> Erosion books: elements deleted, their mass [kg] and internal energy
  !> [J]; mass [kg], kinetic energy [J] and momentum (r, z) [kg m/s] of the
  !> nodes removed with their last element.
  subroutine get_erosion_stats(run, n_eroded, element_mass, internal, node_mass, kinetic, momentum)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(out) :: n_eroded
    real(wp), intent(out) :: element_mass, internal, node_mass, kinetic, momentum(2)
    sim => run_state(run)
    n_eroded = sim%erosion%n_eroded
    element_mass = sim%erosion%element_mass
    internal = sim%erosion%internal
    node_mass = sim%erosion%node_mass
    kinetic = sim%erosion%kinetic
    momentum = sim%erosion%momentum
  end subroutine get_erosion_stats

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

  !> Debris particles (density held at the debris bound, no stress) after
  !> the last cycle.
  subroutine get_debris_count(run, n_debris)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(out) :: n_debris
    sim => run_state(run)
    n_debris = sim%particles%n_debris
  end subroutine get_debris_count

  !> Largest principal logarithmic strain of one triangle from its initial
  !> and current node positions (r, z) [m] (unit tests of the measure).
  subroutine triangle_principal_strain(x, x0, strain)
    use fsph_erosion, only: principal_log_strain
    real(wp), intent(in) :: x(2, 3), x0(2, 3)
    real(wp), intent(out) :: strain
    strain = principal_log_strain(x, x0)
  end subroutine triangle_principal_strain

  !> Material history (n_hist rows: damage, largest volumetric strain;
  !> fsph_material) of every element (kind 1) or particle (kind 2).
  subroutine get_material_history(run, kind, nh, n, hist, ierr)
    use fsph_status, only: status_ok, status_bad_input
    use fsph_material, only: n_hist
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: kind, nh, n
    real(wp), intent(out) :: hist(nh, n)
    integer, intent(out) :: ierr
    sim => run_state(run)
    hist = 0.0_wp
    ierr = status_bad_input
    if (nh /= n_hist .or. n == 0) return
    if (kind == 1 .and. n == sim%elements%n) then
      hist = sim%elements%hist
    else if (kind == 2 .and. n == sim%particles%n) then
      hist = sim%particles%hist(:, 1:n)
    else
      return
    end if
    ierr = status_ok
  end subroutine get_material_history

  !> HJC pressure of one point (unit tests of the branches): volumetric
  !> strain, damage and largest strain so far in; pressure [Pa], dp/dmu [Pa]
  !> and the growth of the permanent volumetric strain out.
  subroutine hjc_point_pressure(nprop, props, mu, damage, mu_max, p, dpdmu, dmu_p, ierr)
    use fsph_material, only: n_props, hjc_pressure
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

  !> Kinetic energy removed by the rigid planes and the particles' axis wall
  !> (perfectly inelastic on what strikes them) [J].
  subroutine get_plane_dissipation(run, dissipated)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    real(wp), intent(out) :: dissipated
    sim => run_state(run)
    dissipated = sim%plane_dissipated
  end subroutine get_plane_dissipation

  !> Contact books: kinetic energy removed by the corrections so far [J],
  !> pairs corrected in the last cycle, surface segments and nodes.
  subroutine get_contact_stats(run, dissipated, n_active, n_seg, n_snode)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    real(wp), intent(out) :: dissipated
    integer, intent(out) :: n_active, n_seg, n_snode
    sim => run_state(run)
    dissipated = sim%contact%dissipated
    n_active = sim%contact%n_active
    n_seg = sim%contact%n_seg
    n_snode = sim%contact%n_snode
  end subroutine get_contact_stats

  !> Deepest interpenetration at the current positions [m] and relative to
  !> the penetrated segment's length [-].
  subroutine get_contact_penetration(run, depth, relative)
    use fsph_contact, only: contact_penetration
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    real(wp), intent(out) :: depth, relative
    sim => run_state(run)
    call contact_penetration(sim%contact, sim%nodes, sim%particles, depth, relative)
  end subroutine get_contact_penetration

  !> The correction of one contact pair (Hu et al. 2013 eqs 1-3), for
  !> verification: normal velocity changes of slave and master nodes [m/s].
  subroutine contact_pair_values(delta, dt, m_s, m_1, m_2, r_1, r_2, dv_s, dv_1, dv_2)
    use fsph_contact, only: pair_correction
    real(wp), intent(in) :: delta, dt, m_s, m_1, m_2, r_1, r_2
    real(wp), intent(out) :: dv_s, dv_1, dv_2
    call pair_correction(delta, dt, m_s, m_1, m_2, r_1, r_2, dv_s, dv_1, dv_2)
  end subroutine contact_pair_values

  !> Elements converted, conversion events, kinetic energy turned into
  !> heat at conversion [J], coupling edges in use.
  subroutine get_conversion_stats(run, n_converted, n_events, heat, n_edges)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(out) :: n_converted, n_events, n_edges
    real(wp), intent(out) :: heat
    sim => run_state(run)
    n_converted = sim%conversion%n_converted
    n_events = sim%conversion%n_events
    heat = sim%conversion%heat
    n_edges = sim%coupling%n_edges
  end subroutine get_conversion_stats

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

  !> Numbers of real and integer state arrays and scalars of a checkpoint.
  subroutine checkpoint_layout(run, n_real, n_int, n_rs, n_is)
    use fsph_restart, only: n_real_arrays, n_int_arrays, n_real_scalars, n_int_scalars, &
                            prepare_checkpoint
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(out) :: n_real, n_int, n_rs, n_is
    sim => run_state(run)
    n_real = n_real_arrays
    n_int = n_int_arrays
    n_rs = n_real_scalars
    n_is = n_int_scalars
    call prepare_checkpoint(sim)
  end subroutine checkpoint_layout

  !> Shape (rows, cols) of state array id, real (kind 1) or integer (2);
  !> (0, 0) when absent. Also the sizes to allocate at restart.
  subroutine checkpoint_sizes(run, kind, id, rows, cols, nn, ne, np, capacity, n_edges)
    use fsph_restart, only: real_view, int_view
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: kind, id
    integer, intent(out) :: rows, cols, nn, ne, np, capacity, n_edges
    real(wp), pointer :: r(:, :)
    integer, pointer :: i(:, :)
    sim => run_state(run)
    rows = 0
    cols = 0
    if (kind == 1) then
      r => real_view(sim, id)
      if (associated(r)) then
        rows = size(r, 1); cols = size(r, 2)
      end if
    else
      i => int_view(sim, id)
      if (associated(i)) then
        rows = size(i, 1); cols = size(i, 2)
      end if
    end if
    nn = sim%nodes%n; ne = sim%elements%n; np = sim%particles%n
    capacity = sim%particles%capacity; n_edges = sim%coupling%n_edges
  end subroutine checkpoint_sizes

  subroutine get_real_state(run, id, rows, cols, a)
    use fsph_restart, only: real_view
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: id, rows, cols
    real(wp), intent(out) :: a(rows, cols)
    real(wp), pointer :: r(:, :)
    sim => run_state(run)
    r => real_view(sim, id)
    a = 0.0_wp
    if (associated(r)) then
      if (size(r, 1) == rows .and. size(r, 2) == cols) a = r
    end if
  end subroutine get_real_state

  subroutine get_int_state(run, id, rows, cols, a)
    use fsph_restart, only: int_view
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: id, rows, cols
    integer, intent(out) :: a(rows, cols)
    integer, pointer :: i(:, :)
    sim => run_state(run)
    i => int_view(sim, id)
    a = 0
    if (associated(i)) then
      if (size(i, 1) == rows .and. size(i, 2) == cols) a = i
    end if
  end subroutine get_int_state

  subroutine set_real_state(run, id, rows, cols, a, ierr)
    use fsph_restart, only: real_view
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: id, rows, cols
    real(wp), intent(in) :: a(rows, cols)
    integer, intent(out) :: ierr
    real(wp), pointer :: r(:, :)
    sim => run_state(run)
    ierr = status_bad_input
    r => real_view(sim, id)
    if (.not. associated(r)) return
    if (size(r, 1) /= rows .or. size(r, 2) /= cols) return
    r = a
    ierr = status_ok
  end subroutine set_real_state

  subroutine set_int_state(run, id, rows, cols, a, ierr)
    use fsph_restart, only: int_view
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: id, rows, cols
    integer, intent(in) :: a(rows, cols)
    integer, intent(out) :: ierr
    integer, pointer :: i(:, :)
    sim => run_state(run)
    ierr = status_bad_input
    i => int_view(sim, id)
    if (.not. associated(i)) return
    if (size(i, 1) /= rows .or. size(i, 2) /= cols) return
    i = a
    ierr = status_ok
  end subroutine set_int_state

  !> Clock and conversion books (see fsph_restart get_scalars).
  subroutine get_scalar_state(run, r, i)
    use fsph_restart, only: get_scalars
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    real(wp), intent(out) :: r(13)   ! fsph_restart n_real_scalars
    integer, intent(out) :: i(9)     ! fsph_restart n_int_scalars
    sim => run_state(run)
    call get_scalars(sim, r, i)
  end subroutine get_scalar_state

  !> Start a restore: allocate for the checkpoint's sizes and set the clock.
  subroutine restore_begin(run, nn, ne, np, capacity, n_edges, r, i)
    use fsph_restart, only: allocate_for_restart, set_scalars
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: nn, ne, np, capacity, n_edges
    real(wp), intent(in) :: r(13)
    integer, intent(in) :: i(9)
    sim => run_state(run)
    call allocate_for_restart(sim, nn, ne, np, capacity, n_edges)
    call set_scalars(sim, r, i)
  end subroutine restore_begin

  !> End a restore: derived maps rebuilt, state ready.
  subroutine restore_end(run)
    use fsph_restart, only: finish_restore
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    sim => run_state(run)
    call finish_restore(sim)
  end subroutine restore_end

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
    sim => run_state(run)
    f = 0.0_wp
    acc = 0.0_wp
    if (nn /= sim%nodes%n .or. np /= sim%particles%n) return
    call solver_forces(sim, dt)
    if (nn > 0) f = sim%nodes%f(:, 1:nn)
    if (np > 0) acc = sim%particles%acc(:, 1:np)
  end subroutine get_forces

  !> The smoothing kernel, its radial derivative and the gradient factor
  !> (dW/d dist)/dist the pair sums use, at distances dist [m] for
  !> smoothing length h [m] (verification).
  subroutine kernel_values(n, dist, h, w, dwdr, factor)
    use fsph_kernel, only: kernel_w, kernel_dwdr, kernel_gradient_factor
    integer, intent(in) :: n
    real(wp), intent(in) :: dist(n), h
    real(wp), intent(out) :: w(n), dwdr(n), factor(n)
    w = kernel_w(dist, h)
    dwdr = kernel_dwdr(dist, h)
    factor = kernel_gradient_factor(dist**2, 1.0_wp/h)
  end subroutine kernel_values

  !> Number of neighbour-list builds of the cycle so far (the lists are
  !> kept while their skin allows, fsph_verlet).
  subroutine get_list_rebuilds(run, n)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(out) :: n
    sim => run_state(run)
    n = sim%particles%n_rebuilds
  end subroutine get_list_rebuilds

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

  !> Material table: props(nprop, nmat) in the fsph_material layout and the
  !> strength and EOS model ids of each material.
  subroutine set_materials(run, nprop, nmat, props, istrength, ieos, ierr)
    use fsph_material, only: n_props
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: nprop, nmat
    real(wp), intent(in) :: props(nprop, nmat)
    integer, intent(in) :: istrength(nmat), ieos(nmat)
    integer, intent(out) :: ierr
    sim => run_state(run)
    ierr = status_bad_input
    if (nprop /= n_props .or. nmat < 1) return
    sim%n_materials = nmat
    sim%props = props
    sim%istrength = istrength
    sim%ieos = ieos
    ierr = status_ok
  end subroutine set_materials

  !> Element mesh: node positions (r, z) and initial velocities, element
  !> connectivity (1-based, counter-clockwise), material and body index.
  subroutine set_mesh(run, nn, ne, x, v, conn, mat, body, ierr)
    use fsph_state, only: state_allocate
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: nn, ne
    real(wp), intent(in) :: x(2, nn), v(2, nn)
    integer, intent(in) :: conn(3, ne), mat(ne), body(ne)
    integer, intent(out) :: ierr
    sim => run_state(run)
    ierr = status_bad_input
    if (nn < 3 .or. ne < 1) return
    call state_allocate(sim, nn, ne)
    sim%nodes%x = x
    sim%nodes%v = v
    sim%elements%conn = conn
    sim%elements%mat = mat
    sim%elements%body = body
    ierr = status_ok
  end subroutine set_mesh

  !> Add a rigid, fixed, frictionless plane through point with unit normal
  !> pointing towards the bodies.
  subroutine add_rigid_plane(run, point, normal, ierr)
    use fsph_state, only: rigid_plane_t
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    real(wp), intent(in) :: point(2), normal(2)
    integer, intent(out) :: ierr
    type(rigid_plane_t) :: plane
    real(wp) :: length
    sim => run_state(run)
    ierr = status_bad_input
    length = norm2(normal)
    if (.not. (length > 0.0_wp)) return
    plane%point = point
    plane%normal = normal/length
    if (.not. allocated(sim%planes)) allocate (sim%planes(0))
    sim%planes = [sim%planes, plane]
    sim%n_planes = size(sim%planes)
    ierr = status_ok
  end subroutine add_rigid_plane

  !> Derived set-up (masses, densities, maps, first time step).
  subroutine initialise(run, ierr, ifault)
    use fsph_solver, only: solver_initialise
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(out) :: ierr, ifault
    sim => run_state(run)
    call solver_initialise(sim, ierr, ifault)
  end subroutine initialise

  !> Advance to t_target [s], at most max_cycles cycles; land /= 0: end
  !> exactly on t_target (see solver_advance).
  !> In a debug build, floating-point traps (invalid, division by zero,
  !> overflow) are on during the cycle and restored afterwards.
  subroutine advance(run, t_target, max_cycles, land, ierr, ifault)
    use fsph_solver, only: solver_advance
    use fsph_build, only: debug_checks
    use, intrinsic :: ieee_exceptions, only: ieee_get_halting_mode, ieee_set_halting_mode, &
                                              ieee_invalid, ieee_divide_by_zero, ieee_overflow
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    real(wp), intent(in) :: t_target
    integer, intent(in) :: max_cycles, land
    integer, intent(out) :: ierr, ifault
    logical :: halting(3)
    sim => run_state(run)
    if (debug_checks) then
      call ieee_get_halting_mode([ieee_invalid, ieee_divide_by_zero, ieee_overflow], halting)
      call ieee_set_halting_mode([ieee_invalid, ieee_divide_by_zero, ieee_overflow], .true.)
    end if
    call solver_advance(sim, t_target, max_cycles, land, ierr, ifault)
    if (debug_checks) then
      call ieee_set_halting_mode([ieee_invalid, ieee_divide_by_zero, ieee_overflow], halting)
    end if
  end subroutine advance

  subroutine get_sizes(run, nn, ne)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(out) :: nn, ne
    sim => run_state(run)
    nn = sim%nodes%n
    ne = sim%elements%n
  end subroutine get_sizes

  !> Clock: time [s], stable step for the next cycle [s], last step [s],
  !> initial stable step [s], cycle count, element or particle controlling
  !> the step (0 for the other kind).
  subroutine get_clock(run, time, dt, dt_last, dt_initial, cycle, dt_element, dt_particle)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    real(wp), intent(out) :: time, dt, dt_last, dt_initial
    integer, intent(out) :: cycle, dt_element, dt_particle
    sim => run_state(run)
    dt_particle = sim%dt_particle
    time = sim%time
    dt = sim%dt
    dt_last = sim%dt_last
    dt_initial = sim%dt_initial
    cycle = sim%cycle
    dt_element = sim%dt_element
  end subroutine get_clock

  !> Node positions, initial positions [m], velocities [m/s], masses [kg].
  subroutine get_nodes(run, nn, x, x0, v, mass)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: nn
    real(wp), intent(out) :: x(2, nn), x0(2, nn), v(2, nn), mass(nn)
    sim => run_state(run)
    x = sim%nodes%x
    x0 = sim%nodes%x0
    v = sim%nodes%v
    mass = sim%nodes%mass
  end subroutine get_nodes

  subroutine get_elements(run, ne, conn, mat, body)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: ne
    integer, intent(out) :: conn(3, ne), mat(ne), body(ne)
    sim => run_state(run)
    conn = sim%elements%conn
    mat = sim%elements%mat
    body = sim%elements%body
  end subroutine get_elements

  !> Element fields: deviator s (rr, zz, rz, tt) [Pa], pressure p and viscous
  !> pressure q [Pa], plastic strain [-], density [kg/m^3], specific internal
  !> energy [J/kg], temperature [K], sound speed [m/s], area [m^2], mass [kg].
  subroutine get_element_fields(run, ne, s, p, q, eps_p, rho, e, temp, c, area, mass)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: ne
    real(wp), intent(out) :: s(4, ne), p(ne), q(ne), eps_p(ne), rho(ne), e(ne), temp(ne)
    real(wp), intent(out) :: c(ne), area(ne), mass(ne)
    sim => run_state(run)
    associate (el => sim%elements)
      s = el%s; p = el%p; q = el%q; eps_p = el%eps_p; rho = el%rho; e = el%e
      temp = el%temp; c = el%c; area = el%area; mass = el%mass
    end associate
  end subroutine get_element_fields

  !> Kinetic energy (half-step velocities) and internal energy [J].
  subroutine get_energies(run, kinetic, internal)
    use fsph_solver, only: solver_energies
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    real(wp), intent(out) :: kinetic, internal
    sim => run_state(run)
    call solver_energies(sim, kinetic, internal)
  end subroutine get_energies

  !> Number of time-history records waiting to be drained.
  subroutine history_count(run, n)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(out) :: n
    sim => run_state(run)
    n = sim%n_history
  end subroutine history_count

  !> Take the n waiting records (time [s], cycle, dt [s], kinetic [J],
  !> internal [J], contact work [J], energy removed by erosion [J], work of
  !> the rigid planes and the particles' axis wall [J]) and empty the buffer.
  subroutine drain_history(run, n, records)
    use fsph_state, only: history_columns
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: n
    ! literal 8 = history_columns: f2py cannot size arrays by module constants
    real(wp), intent(out) :: records(8, n)
    integer :: k
    sim => run_state(run)
    k = min(n, sim%n_history)
    if (history_columns /= size(records, 1)) k = 0
    records = 0.0_wp
    if (k > 0) records(:, 1:k) = sim%history(:, 1:k)
    sim%n_history = 0
  end subroutine drain_history

  !> Overwrite nodal velocities [m/s] (verification tests and restarts).
  subroutine set_node_velocities(run, nn, v, ierr)
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: nn
    real(wp), intent(in) :: v(2, nn)
    integer, intent(out) :: ierr
    sim => run_state(run)
    ierr = status_bad_input
    if (nn /= sim%nodes%n) return
    sim%nodes%v = v
    ierr = status_ok
  end subroutine set_node_velocities

  !> Overwrite the specific internal energy of every element [J/kg]
  !> (verification tests: e.g. a NaN to exercise the element guard).
  subroutine set_element_energy(run, ne, e, ierr)
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: ne
    real(wp), intent(in) :: e(ne)
    integer, intent(out) :: ierr
    sim => run_state(run)
    ierr = status_bad_input
    if (ne /= sim%elements%n) return
    sim%elements%e(1:ne) = e
    ierr = status_ok
  end subroutine set_element_energy

  !> Overwrite particle positions [m] and velocities [m/s] (verification
  !> tests: e.g. put a particle across the axis to exercise its guard).
  subroutine set_particle_motion(run, np, x, v, ierr)
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: np
    real(wp), intent(in) :: x(2, np), v(2, np)
    integer, intent(out) :: ierr
    sim => run_state(run)
    ierr = status_bad_input
    if (np /= sim%particles%n) return
    sim%particles%x(:, 1:np) = x
    sim%particles%v(:, 1:np) = v
    sim%particles%lists_valid = .false.
    ierr = status_ok
  end subroutine set_particle_motion

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
    use fsph_material, only: n_props, n_hist, material_update
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

end module fsph_api
