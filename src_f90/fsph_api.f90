!> The module exposed to Python (through numpy.f2py; the tests' entry points
!> are in fsph_verify). Plain arrays and scalars in and out; every layout the
!> arrays follow is named in fsph_layouts (generated from fsph/layouts.py);
!> the state stays inside Fortran. Every routine that can fail returns ierr
!> (a fsph_status code) and, where useful, ifault (the 1-based index of the
!> element or node at fault). Nothing here stops the process. A routine
!> that reads or changes a run's state takes the run's handle (open_run)
!> first and works on that run alone (fsph_runs).
module fsph_api
  use fsph_kinds, only: wp
  use fsph_state, only: simulation_t
  use fsph_runs, only: run_state
  implicit none
  private
  public :: open_run, close_run, get_layout_digest, phase_count, get_phase_times, reset_phase_times
  public :: threads, set_thread_policy, get_thread_use, point_groups
  public :: set_control, set_sph_control, set_particles, set_continua, reserve_particles
  public :: set_conversion, set_contact, set_erosion, get_erosion_stats, get_debris_count
  public :: get_contact_stats, get_conversion_stats, begin_checkpoint, checkpoint_sizes, get_real_state
  public :: get_int_state, set_real_state, set_int_state, get_scalar_state, restore_begin, restore_end
  public :: get_skin_scale_max, get_list_sizes, get_list_books, set_list_books
  public :: set_formulation
  public :: kernel_values, get_list_rebuilds, set_materials, set_mesh, add_rigid_plane, initialise, advance
  public :: get_sizes, get_snapshot, get_snapshot_scalars, get_clock, get_energy_budget, history_count
  public :: drain_history, get_body_history, set_gauges, get_gauge_history, get_gauge_state, resume_gauges
  public :: tlsph_neighbour_count, tlsph_neighbours, tlsph_kernel_gradients, tlsph_correction
  public :: tlsph_scalar_gradient, tlsph_deformation, tlsph_piola, tlsph_ring_forces, tlsph_stencil

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

  !> Digest of the layouts the solver was built with (fsph_layouts,
  !> generated from fsph/layouts.py): Python compares it with its own, so
  !> a stale build is refused rather than misread.
  subroutine get_layout_digest(digest)
    use fsph_layouts, only: layout_digest
    integer, intent(out) :: digest
    digest = layout_digest
  end subroutine get_layout_digest

  !> Number of timed phases of the cycle (fsph_layouts).
  subroutine phase_count(n)
    use fsph_layouts, only: n_phases
    integer, intent(out) :: n
    n = n_phases
  end subroutine phase_count

  !> Wall time [s] spent in each phase of the cycle since the last reset,
  !> in the order of fsph_layouts (element forces, element update,
  !> neighbours, SPH sums, particle update, particle contact, coupling,
  !> contact, integration, conversion, time step).
  subroutine get_phase_times(run, n, times)
    use fsph_layouts, only: n_phases
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

  !> Thread policy of run `run` (fsph_threads): adaptive /= 0 lets the
  !> governor choose each cycle's thread count, 0 keeps the most threads.
  !> probe_seconds, exploit_seconds [s]: the governor's timing, negative for
  !> its defaults (tests shorten them to make it switch often).
  subroutine set_thread_policy(run, adaptive, probe_seconds, exploit_seconds)
    use fsph_threads, only: governor_set
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    integer, intent(in) :: adaptive
    real(wp), intent(in) :: probe_seconds, exploit_seconds
    type(simulation_t), pointer :: sim
    sim => run_state(run)
    call governor_set(sim%governor, adaptive /= 0, probe_seconds, exploit_seconds)
  end subroutine set_thread_policy

  !> Cycles run so far at 1, 2, ..., n threads (0 beyond the most the run
  !> may use, and all 0 before its first advance).
  subroutine get_thread_use(run, n, cycles_at)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    integer, intent(in) :: n
    integer, intent(out) :: cycles_at(n)
    type(simulation_t), pointer :: sim
    integer :: m
    sim => run_state(run)
    cycles_at = 0
    if (.not. allocated(sim%governor%cycles_at)) return
    m = min(n, size(sim%governor%cycles_at))
    cycles_at(1:m) = sim%governor%cycles_at(1:m)
  end subroutine get_thread_use

  !> Connected groups of n points (fsph_groups): label(i) is the smallest
  !> 1-based index of point i's group; points join within the sum of
  !> their reaches [m] or through links (1-based pairs). Touches no run.
  subroutine point_groups(n, x, reach, n_links, links, label)
    use fsph_groups, only: connected_groups
    integer, intent(in) :: n, n_links
    real(wp), intent(in) :: x(2, n), reach(n)
    integer, intent(in) :: links(2, n_links)
    integer, intent(out) :: label(n)
    call connected_groups(n, x, reach, n_links, links, label)
  end subroutine point_groups

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
  !> its model (Riemann pressures or a potential) and the potential's
  !> penalty (fraction of an approach pushed back per step), other-body
  !> filling at touching and its rate per spacing of approach [-]; the
  !> debris density fraction [-]; the neighbour lists' skin as a fraction
  !> of the smallest kernel support (0: lists rebuilt every cycle) [-]; the
  !> fewest particles kept in spatial order (0: never; fsph_spatial); the
  !> coefficient of the artificial stress (0: off; fsph_sph) [-].
  subroutine set_sph_control(run, c_q, c_l, c_hg, particle_contact, contact_penalty, contact_touch, contact_slope, &
                             debris_ratio, neighbour_skin, eigenerosion_factor, spatial_order_min, artificial_stress)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: particle_contact !< contact between particle bodies (fsph.layouts PARTICLE_CONTACTS, 1-based)
    real(wp), intent(in) :: c_q, c_l, contact_penalty, contact_touch, contact_slope
    real(wp), intent(in) :: c_hg          !< hourglass viscosity coefficient [-]
    real(wp), intent(in) :: debris_ratio  !< debris below this fraction of the reference density [-]
    real(wp), intent(in) :: neighbour_skin
    real(wp), intent(in) :: eigenerosion_factor !< geometric factor lambda of the eigenerosion release rate [-]
    integer, intent(in) :: spatial_order_min
    real(wp), intent(in) :: artificial_stress !< coefficient eps of the artificial stress [-]
    sim => run_state(run)
    sim%control%spatial_order_min = spatial_order_min
    sim%control%neighbour_skin = max(neighbour_skin, 0.0_wp)
    sim%particles%lists_valid = .false.
    sim%control%sph_c_q = c_q
    sim%control%sph_c_l = c_l
    sim%control%sph_c_hg = c_hg
    sim%control%sph_artificial_stress = max(artificial_stress, 0.0_wp)
    sim%control%particle_contact = particle_contact
    sim%control%contact_penalty = contact_penalty
    sim%control%contact_touch = contact_touch
    sim%control%contact_slope = contact_slope
    sim%control%debris_ratio = debris_ratio
    sim%control%eigenerosion_factor = eigenerosion_factor
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

  !> The particle formulation of every body: total(b) /= 0 for a
  !> total-Lagrangian body (fsph_total; its particles must have no
  !> element coupling), the hourglass coefficient gamma [-] of those
  !> bodies (fsph_tlsph reference_pair_factors) and their stencil.
  !> Before initialise.
  subroutine set_formulation(run, nbody, total, hourglass, selected, ierr)
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: nbody
    integer, intent(in) :: total(nbody)
    real(wp), intent(in) :: hourglass
    integer, intent(in) :: selected        !< 1: the selected-particle stencil, 0: the full support
    integer, intent(out) :: ierr
    sim => run_state(run)
    ierr = status_bad_input
    if (nbody < 1 .or. .not. (hourglass >= 0.0_wp)) return
    sim%total%body_total = total /= 0
    sim%total%hourglass = hourglass
    sim%total%selected = selected /= 0
    ierr = status_ok
  end subroutine set_formulation

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

  !> Debris particles (density held at the debris bound, no stress) after
  !> the last cycle.
  subroutine get_debris_count(run, n_debris)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(out) :: n_debris
    sim => run_state(run)
    n_debris = sim%particles%n_debris
  end subroutine get_debris_count

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

  !> Before the state arrays are read for a checkpoint: the axis flags as
  !> integers (fsph_restart prepare_checkpoint, for nodes/on_axis).
  subroutine begin_checkpoint(run)
    use fsph_restart, only: prepare_checkpoint
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    sim => run_state(run)
    call prepare_checkpoint(sim)
  end subroutine begin_checkpoint

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

  !> Copy of state array id (fsph_layouts ckr_*, cki_*) of shape (rows,
  !> cols) (zeros if the shape does not fit): checkpoints, and tests that
  !> read one array by name (fsph.checkpoint state_array).
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

  !> Overwrite state array id with a (rows, cols) array of its shape
  !> (restarts, and tests that set a state no deck reaches); the neighbour
  !> lists are rebuilt at the next cycle.
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
    sim%particles%lists_valid = .false.    ! the neighbour lists rest on the old state
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
    sim%particles%lists_valid = .false.    ! the neighbour lists rest on the old state
    ierr = status_ok
  end subroutine set_int_state

  !> Clock and books of a checkpoint (fsph_restart get_scalars; nr and ni
  !> are fsph_layouts n_real_scalars and n_int_scalars).
  subroutine get_scalar_state(run, nr, ni, r, i, ierr)
    use fsph_restart, only: get_scalars
    use fsph_layouts, only: n_real_scalars, n_int_scalars
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: nr, ni
    real(wp), intent(out) :: r(nr)
    integer, intent(out) :: i(ni), ierr
    sim => run_state(run)
    r = 0.0_wp
    i = 0
    ierr = status_bad_input
    if (nr /= n_real_scalars .or. ni /= n_int_scalars) return
    call get_scalars(sim, r, i)
    ierr = status_ok
  end subroutine get_scalar_state

  !> Start a restore: allocate for the checkpoint's sizes and set the clock
  !> and books (nr, ni: fsph_layouts n_real_scalars, n_int_scalars).
  subroutine restore_begin(run, nn, ne, np, capacity, n_edges, nr, ni, r, i, ierr)
    use fsph_restart, only: allocate_for_restart, set_scalars
    use fsph_layouts, only: n_real_scalars, n_int_scalars
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: nn, ne, np, capacity, n_edges, nr, ni
    real(wp), intent(in) :: r(nr)
    integer, intent(in) :: i(ni)
    integer, intent(out) :: ierr
    sim => run_state(run)
    ierr = status_bad_input
    if (nr /= n_real_scalars .or. ni /= n_int_scalars) return
    call allocate_for_restart(sim, nn, ne, np, capacity, n_edges)
    call set_scalars(sim, r, i)
    ierr = status_ok
  end subroutine restore_begin

  !> End a restore: derived maps rebuilt, state ready.
  subroutine restore_end(run)
    use fsph_restart, only: finish_restore
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    sim => run_state(run)
    call finish_restore(sim)
  end subroutine restore_end

  !> The largest scale of the lists' skin over the deck's (fsph_verlet
  !> skin_scale_max) [-]: the range a checkpoint's books are checked in.
  subroutine get_skin_scale_max(scale_max)
    use fsph_verlet, only: skin_scale_max
    real(wp), intent(out) :: scale_max
    scale_max = skin_scale_max
  end subroutine get_skin_scale_max

  !> Columns of the neighbour lists' books in a checkpoint (fsph_verlet
  !> listed_sizes): real particles, nodes, elements and coupled nodes at
  !> the lists' build; all 0 where the next cycle rebuilds the lists.
  subroutine get_list_sizes(run, n_listed, n_nodes, n_elements, n_coupled)
    use fsph_verlet, only: listed_sizes
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(out) :: n_listed, n_nodes, n_elements, n_coupled
    sim => run_state(run)
    call listed_sizes(sim%particles, sim%nodes, sim%elements, n_listed, n_nodes, n_elements, n_coupled)
  end subroutine get_list_sizes

  !> The neighbour lists' books for a checkpoint, of the sizes
  !> get_list_sizes gives: reals (skin [m], its scale over the deck's
  !> [-]), integers (builds so far, cycles the lists have served), the
  !> real particles' and nodes' positions [m] and the elements' h [m] at
  !> the build, the coupled bodies' nodes (1-based).
  subroutine get_list_books(run, n_listed, n_nodes, n_elements, n_coupled, reals, ints, x_listed, &
                            node_listed, elem_listed, coupled_nodes)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: n_listed, n_nodes, n_elements, n_coupled
    real(wp), intent(out) :: reals(2), x_listed(2, n_listed), node_listed(2, n_nodes), elem_listed(n_elements)
    integer, intent(out) :: ints(2), coupled_nodes(n_coupled)
    sim => run_state(run)
    associate (pt => sim%particles)
      reals = [pt%skin, pt%skin_scale]
      ints = [pt%n_rebuilds, pt%list_uses]
      x_listed = 0.0_wp; node_listed = 0.0_wp; elem_listed = 0.0_wp; coupled_nodes = 0
      if (n_listed > 0 .and. n_listed == pt%n_listed) x_listed = pt%x_listed(:, 1:n_listed)
      if (n_listed > 0 .and. n_nodes <= size(pt%node_listed, 2)) node_listed = pt%node_listed(:, 1:n_nodes)
      if (n_listed > 0 .and. n_elements <= size(pt%elem_listed)) elem_listed = pt%elem_listed(1:n_elements)
      if (n_listed > 0 .and. n_coupled == pt%n_coupled_nodes) coupled_nodes = pt%coupled_nodes(1:n_coupled)
    end associate
  end subroutine get_list_books

  !> After restore_end: the neighbour lists' books of the checkpoint (as
  !> get_list_books gives them; fsph_verlet restore_lists), so the
  !> restarted run builds its lists when the run that wrote the checkpoint
  !> did. ierr status_bad_input, nothing changed, where they do not fit.
  subroutine set_list_books(run, n_listed, n_nodes, n_elements, n_coupled, reals, ints, x_listed, &
                            node_listed, elem_listed, coupled_nodes, ierr)
    use fsph_verlet, only: restore_lists
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: n_listed, n_nodes, n_elements, n_coupled
    real(wp), intent(in) :: reals(2), x_listed(2, n_listed), node_listed(2, n_nodes), elem_listed(n_elements)
    integer, intent(in) :: ints(2), coupled_nodes(n_coupled)
    integer, intent(out) :: ierr
    logical :: ok
    sim => run_state(run)
    call restore_lists(sim%particles, sim%nodes, sim%elements, reals(1), reals(2), ints(1), ints(2), &
                       x_listed, node_listed, elem_listed, coupled_nodes, ok)
    ierr = merge(status_ok, status_bad_input, ok)
  end subroutine set_list_books

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

  !> Material table: props(nprop, nmat) in the fsph_layouts prop_* order and the
  !> strength and EOS model ids of each material.
  subroutine set_materials(run, nprop, nmat, props, istrength, ieos, ierr)
    use fsph_layouts, only: n_props
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

  !> Advance to t_target [s], at most max_cycles cycles, no step crossing
  !> t_land [s] (the last steps end on it; see solver_advance).
  !> In a debug build, floating-point traps (invalid, division by zero,
  !> overflow) are on during the cycle and restored afterwards.
  subroutine advance(run, t_target, max_cycles, t_land, ierr, ifault)
    use fsph_solver, only: solver_advance
    use fsph_build, only: debug_checks
    use, intrinsic :: ieee_exceptions, only: ieee_get_halting_mode, ieee_set_halting_mode, &
                                              ieee_invalid, ieee_divide_by_zero, ieee_overflow
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    real(wp), intent(in) :: t_target       !< stop at the first cycle end at or after it [s]
    real(wp), intent(in) :: t_land         !< no step crosses it: the last ones land on it [s]
    integer, intent(in) :: max_cycles
    integer, intent(out) :: ierr, ifault
    logical :: halting(3)
    sim => run_state(run)
    if (debug_checks) then
      call ieee_get_halting_mode([ieee_invalid, ieee_divide_by_zero, ieee_overflow], halting)
      call ieee_set_halting_mode([ieee_invalid, ieee_divide_by_zero, ieee_overflow], .true.)
    end if
    call solver_advance(sim, t_target, max_cycles, t_land, ierr, ifault)
    if (debug_checks) then
      call ieee_set_halting_mode([ieee_invalid, ieee_divide_by_zero, ieee_overflow], halting)
    end if
  end subroutine advance

  !> Numbers of nodes, elements and (real) particles of run `run`.
  subroutine get_sizes(run, nn, ne, np)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(out) :: nn, ne, np
    sim => run_state(run)
    nn = sim%nodes%n
    ne = sim%elements%n
    np = sim%particles%n
  end subroutine get_sizes

  !> A snapshot of run `run` in the row layouts of fsph_layouts (built by
  !> fsph_snapshot): node, element and particle field rows, connectivity
  !> (1-based), material and body ids, and the snapshot scalars. Changes
  !> nothing in the run. ierr = status_bad_input when a size does not
  !> match the run (get_sizes) or the layout.
  subroutine get_snapshot(run, nn, ne, np, nnf, nef, npf, nid, nss, node_fields, conn, element_ids, &
                          element_fields, particle_ids, particle_fields, scalars, ierr)
    use fsph_layouts, only: n_node_fields, n_element_fields, n_particle_fields, n_id_fields, &
                            n_snapshot_scalars
    use fsph_snapshot, only: node_rows, element_rows, particle_rows, snapshot_scalars
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    integer, intent(in) :: nn, ne, np, nnf, nef, npf, nid, nss
    real(wp), intent(out) :: node_fields(nnf, nn), element_fields(nef, ne), particle_fields(npf, np)
    real(wp), intent(out) :: scalars(nss)
    integer, intent(out) :: conn(3, ne), element_ids(nid, ne), particle_ids(nid, np), ierr
    type(simulation_t), pointer :: sim
    sim => run_state(run)
    node_fields = 0.0_wp; element_fields = 0.0_wp; particle_fields = 0.0_wp; scalars = 0.0_wp
    conn = 0; element_ids = 0; particle_ids = 0
    ierr = status_bad_input
    if (nn /= sim%nodes%n .or. ne /= sim%elements%n .or. np /= sim%particles%n) return
    if (nnf /= n_node_fields .or. nef /= n_element_fields .or. npf /= n_particle_fields .or. &
        nid /= n_id_fields .or. nss /= n_snapshot_scalars) return
    if (nn > 0) call node_rows(sim%nodes, node_fields)
    if (ne > 0) call element_rows(sim%elements, conn, element_ids, element_fields)
    if (np > 0) call particle_rows(sim%particles, sim%props, particle_ids, particle_fields)
    call snapshot_scalars(sim, scalars)
    ierr = status_ok
  end subroutine get_snapshot

  !> The snapshot scalars alone (fsph_layouts ss_*, nss of them), for a
  !> caller that wants no fields; changes nothing in the run.
  subroutine get_snapshot_scalars(run, nss, scalars, ierr)
    use fsph_layouts, only: n_snapshot_scalars
    use fsph_snapshot, only: snapshot_scalars
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    integer, intent(in) :: nss
    real(wp), intent(out) :: scalars(nss)
    integer, intent(out) :: ierr
    type(simulation_t), pointer :: sim
    sim => run_state(run)
    scalars = 0.0_wp
    ierr = status_bad_input
    if (nss /= n_snapshot_scalars) return
    call snapshot_scalars(sim, scalars)
    ierr = status_ok
  end subroutine get_snapshot_scalars

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

  !> The energy budget [J] (fsph_solver energy_budget: kinetic, internal,
  !> removed by contact, erosion and the rigid planes, total; n entries,
  !> the history columns from fsph_layouts energy_first).
  subroutine get_energy_budget(run, n, budget, ierr)
    use fsph_solver, only: energy_budget
    use fsph_layouts, only: history_columns, energy_first
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    integer, intent(in) :: n
    real(wp), intent(out) :: budget(n)
    integer, intent(out) :: ierr
    type(simulation_t), pointer :: sim
    sim => run_state(run)
    budget = 0.0_wp
    ierr = status_bad_input
    if (n /= history_columns - energy_first + 1) return
    budget = energy_budget(sim)
    ierr = status_ok
  end subroutine get_energy_budget

  !> Number of time-history records waiting to be drained.
  subroutine history_count(run, n)
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(out) :: n
    sim => run_state(run)
    n = sim%n_history
  end subroutine history_count

  !> Take the n waiting time-history records (nc = history_columns rows,
  !> fsph_layouts hcol_*) and empty the buffer.
  subroutine drain_history(run, nc, n, records, ierr)
    use fsph_layouts, only: history_columns
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: nc, n
    real(wp), intent(out) :: records(nc, n)
    integer, intent(out) :: ierr
    integer :: k
    sim => run_state(run)
    records = 0.0_wp
    ierr = status_bad_input
    if (nc /= history_columns) return
    k = min(n, sim%n_history)
    if (k > 0) records(:, 1:k) = sim%history(:, 1:k)
    sim%n_history = 0
    ierr = status_ok
  end subroutine drain_history

  !> The bodies' books at the records drain_history returns (call it
  !> first, with the count history_count gave before): (nc, nb, n) with nc
  !> = fsph_layouts body_columns, nb bodies; empties nothing itself
  !> (drain_history does).
  subroutine get_body_history(run, nc, nb, n, records, ierr)
    use fsph_layouts, only: body_columns
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    type(simulation_t), pointer :: sim
    integer, intent(in) :: nc, nb, n
    real(wp), intent(out) :: records(nc, nb, n)
    integer, intent(out) :: ierr
    sim => run_state(run)
    records = 0.0_wp
    ierr = status_bad_input
    if (nc /= body_columns) return
    if (.not. allocated(sim%body_history)) then
      ierr = status_ok
      return
    end if
    if (nb /= size(sim%body_history, 2) .or. n > size(sim%body_history, 3)) return
    if (n > 0) records = sim%body_history(:, :, 1:n)
    ierr = status_ok
  end subroutine get_body_history

  !> The gauges (&gauge; fsph_gauges): kinds (n, fsph_layouts
  !> gauge_kind_*) and points (2, n) (r, z) [m]. Call once the state is
  !> set up (initialise) or restored (restore_end), before advancing: the
  !> gauges are located in the initial configuration and the records
  !> waiting (at set-up, t = 0) get their rows. on(k): what material
  !> gauge k follows (fsph_layouts gauge_on_*: 0 nothing, its point in no
  !> body).
  subroutine set_gauges(run, n, kinds, points, on, ierr)
    use fsph_gauges, only: gauges_define
    use fsph_layouts, only: gauge_kind_material, gauge_kind_fixed
    use fsph_solver, only: locate_gauges
    use fsph_status, only: status_ok, status_bad_input, status_not_ready
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    integer, intent(in) :: n
    integer, intent(in) :: kinds(n)
    real(wp), intent(in) :: points(2, n)
    integer, intent(out) :: on(n)
    integer, intent(out) :: ierr
    type(simulation_t), pointer :: sim
    sim => run_state(run)
    on = 0
    ierr = status_not_ready
    if (.not. sim%ready) return
    ierr = status_bad_input
    if (any(kinds /= gauge_kind_material .and. kinds /= gauge_kind_fixed)) return
    call gauges_define(sim%gauges, n, kinds, points)
    call locate_gauges(sim)
    on = sim%gauges%on
    ierr = status_ok
  end subroutine set_gauges

  !> The gauges' rows at the records drain_history returns (call it first,
  !> with the count history_count gave before): (nc, ng, n) with nc =
  !> fsph_layouts gauge_columns, ng gauges; empties nothing itself.
  subroutine get_gauge_history(run, nc, ng, n, records, ierr)
    use fsph_layouts, only: gauge_columns
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    integer, intent(in) :: nc, ng, n
    real(wp), intent(out) :: records(nc, ng, n)
    integer, intent(out) :: ierr
    type(simulation_t), pointer :: sim
    sim => run_state(run)
    records = 0.0_wp
    ierr = status_bad_input
    if (nc /= gauge_columns .or. ng /= sim%gauges%n) return
    ierr = status_ok
    if (ng == 0 .or. n == 0) return
    if (.not. allocated(sim%gauges%history)) return
    if (n > size(sim%gauges%history, 3)) then
      ierr = status_bad_input
      return
    end if
    records = sim%gauges%history(:, :, 1:n)
  end subroutine get_gauge_history

  !> What each of the n gauges samples now: on (fsph_layouts gauge_on_*;
  !> a fixed gauge: 0, it is searched at each record) and the element or
  !> particle index (1-based, 0 none); when a material gauge moved from its
  !> element to a particle and when its element was deleted [s] (-1 never).
  subroutine get_gauge_state(run, n, on, index, switch_time, lost_time, ierr)
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    integer, intent(in) :: n
    integer, intent(out) :: on(n), index(n)
    real(wp), intent(out) :: switch_time(n), lost_time(n)
    integer, intent(out) :: ierr
    type(simulation_t), pointer :: sim
    sim => run_state(run)
    on = 0
    index = 0
    switch_time = -1.0_wp
    lost_time = -1.0_wp
    ierr = status_bad_input
    if (n /= sim%gauges%n) return
    ierr = status_ok
    if (n == 0) return
    on = sim%gauges%on
    index = sim%gauges%index
    switch_time = sim%gauges%switch_time
    lost_time = sim%gauges%lost_time
  end subroutine get_gauge_state

  !> After set_gauges on a restart: the material gauges k with on(k) >= 0
  !> take up what they followed when the checkpoint was written (as
  !> get_gauge_state gave it: a particle, 1-based index(k), since
  !> switch_time(k), or nothing since lost_time(k) [s]; fsph_gauges
  !> gauges_resume); on(k) = -1 keeps what set_gauges located. ierr
  !> status_bad_input where a state does not fit (the gauges before it
  !> taken up).
  subroutine resume_gauges(run, n, on, index, switch_time, lost_time, ierr)
    use fsph_gauges, only: gauges_resume
    use fsph_status, only: status_ok, status_bad_input
    integer, intent(in) :: run             !< handle of the run (fsph_runs)
    integer, intent(in) :: n
    integer, intent(in) :: on(n), index(n)
    real(wp), intent(in) :: switch_time(n), lost_time(n)
    integer, intent(out) :: ierr
    type(simulation_t), pointer :: sim
    integer, allocatable :: bodies(:)
    logical :: ok
    integer :: k
    sim => run_state(run)
    ierr = status_bad_input
    if (n /= sim%gauges%n) return
    allocate (bodies(sim%particles%n))
    if (sim%particles%n > 0) bodies = sim%particles%body(1:sim%particles%n)
    do k = 1, n
      if (on(k) < 0) cycle
      call gauges_resume(sim%gauges, k, on(k), index(k), switch_time(k), lost_time(k), size(bodies), &
                         bodies, ok)
      if (.not. ok) return
    end do
    ierr = status_ok
  end subroutine resume_gauges

  ! ---- total-Lagrangian particles (fsph_tlsph): its kernels on given
  ! arrays, for the tests (no run's state). x0 reference positions (R, Z)
  ! [m], h smoothing lengths [m], area planar areas [m^2]; the lists in CSR
  ! form (ptr, nbr: 1-based, mirror images across the axis as -j).

  !> Number of entries nnz of the reference neighbour lists of n particles
  !> (fsph_tlsph reference_neighbours; ierr, ifault as there).
  subroutine tlsph_neighbour_count(n, x0, h, nnz, ierr, ifault)
    use fsph_tlsph, only: reference_neighbours
    integer, intent(in) :: n
    real(wp), intent(in) :: x0(2, n), h(n)
    integer, intent(out) :: nnz, ierr, ifault
    integer :: ptr(n + 1)
    integer, allocatable :: list(:)
    call reference_neighbours(n, x0, h, ptr, list, ierr, ifault)
    nnz = size(list)
  end subroutine tlsph_neighbour_count

  !> The reference neighbour lists (nnz from tlsph_neighbour_count;
  !> status_bad_input if it does not match).
  subroutine tlsph_neighbours(n, nnz, x0, h, ptr, nbr, ierr, ifault)
    use fsph_status, only: status_ok, status_bad_input
    use fsph_tlsph, only: reference_neighbours
    integer, intent(in) :: n, nnz
    real(wp), intent(in) :: x0(2, n), h(n)
    integer, intent(out) :: ptr(n + 1), nbr(nnz), ierr, ifault
    integer, allocatable :: list(:)
    nbr = 0
    call reference_neighbours(n, x0, h, ptr, list, ierr, ifault)
    if (ierr /= status_ok) return
    if (size(list) /= nnz) then
      ierr = status_bad_input
      return
    end if
    nbr = list
  end subroutine tlsph_neighbours

  !> The selected-particle stencil within the reference lists (fsph_tlsph
  !> select_stencil): keep(k) = 1 for an entry kept, 0 otherwise.
  subroutine tlsph_stencil(n, nnz, x0, ptr, nbr, keep)
    use fsph_tlsph, only: select_stencil
    integer, intent(in) :: n, nnz
    real(wp), intent(in) :: x0(2, n)
    integer, intent(in) :: ptr(n + 1), nbr(nnz)
    integer, intent(out) :: keep(nnz)
    logical :: marks(nnz)
    call select_stencil(n, x0, ptr, nbr, marks)
    keep = merge(1, 0, marks)
  end subroutine tlsph_stencil

  !> Reference kernel gradient of every entry [1/m^3].
  subroutine tlsph_kernel_gradients(n, nnz, x0, h, ptr, nbr, grad_w)
    use fsph_tlsph, only: reference_kernel_gradients
    integer, intent(in) :: n, nnz
    real(wp), intent(in) :: x0(2, n), h(n)
    integer, intent(in) :: ptr(n + 1), nbr(nnz)
    real(wp), intent(out) :: grad_w(2, nnz)
    call reference_kernel_gradients(n, x0, h, ptr, nbr, grad_w)
  end subroutine tlsph_kernel_gradients

  !> Correction matrices B [-] and the smallest eigenvalue of their
  !> inverses (fsph_tlsph reference_correction; ifault the lowest particle
  !> refused as singular).
  subroutine tlsph_correction(n, nnz, x0, area, ptr, nbr, grad_w, bmat, eig_min, ierr, ifault)
    use fsph_tlsph, only: reference_correction
    integer, intent(in) :: n, nnz
    real(wp), intent(in) :: x0(2, n), area(n)
    integer, intent(in) :: ptr(n + 1), nbr(nnz)
    real(wp), intent(in) :: grad_w(2, nnz)
    real(wp), intent(out) :: bmat(2, 2, n), eig_min(n)
    integer, intent(out) :: ierr, ifault
    call reference_correction(n, x0, area, ptr, nbr, grad_w, bmat, eig_min, ierr, ifault)
  end subroutine tlsph_correction

  !> Corrected reference gradient (d/dR, d/dZ) of a scalar field f.
  subroutine tlsph_scalar_gradient(n, nnz, area, ptr, nbr, grad_w, bmat, f, grad_f)
    use fsph_tlsph, only: corrected_gradient
    integer, intent(in) :: n, nnz
    real(wp), intent(in) :: area(n)
    integer, intent(in) :: ptr(n + 1), nbr(nnz)
    real(wp), intent(in) :: grad_w(2, nnz), bmat(2, 2, n), f(n)
    real(wp), intent(out) :: grad_f(2, n)
    call corrected_gradient(n, area, ptr, nbr, grad_w, bmat, f, grad_f)
  end subroutine tlsph_scalar_gradient

  !> Deformation gradients at the current positions x [m]: in-plane
  !> fmat(a, b) = d x_a/d X_b, hoop stretch f_tt, J (ierr, ifault as
  !> fsph_tlsph deformation_gradients).
  subroutine tlsph_deformation(n, nnz, x0, x, h, area, ptr, nbr, grad_w, bmat, fmat, f_tt, jac, ierr, ifault)
    use fsph_tlsph, only: deformation_gradients
    integer, intent(in) :: n, nnz
    real(wp), intent(in) :: x0(2, n), x(2, n), h(n), area(n)
    integer, intent(in) :: ptr(n + 1), nbr(nnz)
    real(wp), intent(in) :: grad_w(2, nnz), bmat(2, 2, n)
    real(wp), intent(out) :: fmat(2, 2, n), f_tt(n), jac(n)
    integer, intent(out) :: ierr, ifault
    call deformation_gradients(n, x0, x, h, area, ptr, nbr, grad_w, bmat, fmat, f_tt, jac, ierr, ifault)
  end subroutine tlsph_deformation

  !> First Piola-Kirchhoff stress [Pa] (in-plane p, hoop p_tt) from the
  !> Cauchy stress sig (rr, zz, rz, tt) [Pa] and the deformation gradient.
  subroutine tlsph_piola(n, fmat, f_tt, sig, p, p_tt)
    use fsph_tlsph, only: first_piola
    integer, intent(in) :: n
    real(wp), intent(in) :: fmat(2, 2, n), f_tt(n), sig(4, n)
    real(wp), intent(out) :: p(2, 2, n), p_tt(n)
    call first_piola(n, fmat, f_tt, sig, p, p_tt)
  end subroutine tlsph_piola

  !> Internal forces per full ring [N] (fsph_tlsph tlsph_forces, without
  !> the hourglass control) and, apart, the radial hoop part they include [N].
  subroutine tlsph_ring_forces(n, nnz, x0, h, area, ptr, nbr, grad_w, bmat, p, p_tt, force, hoop)
    use fsph_tlsph, only: tlsph_forces, hoop_force, reference_pair_factors
    integer, intent(in) :: n, nnz
    real(wp), intent(in) :: x0(2, n), h(n), area(n)
    integer, intent(in) :: ptr(n + 1), nbr(nnz)
    real(wp), intent(in) :: grad_w(2, nnz), bmat(2, 2, n), p(2, 2, n), p_tt(n)
    real(wp), intent(out) :: force(2, n), hoop(n)
    real(wp), allocatable :: work(:, :, :), hg_pair(:, :), pair_area(:), hg_coef(:), unit_f(:, :, :)
    integer :: i
    ! the pair areas of the reference configuration; with gamma = 0 the
    ! hourglass coefficients are zero, so the terms they scale vanish
    ! (the unit F those multiply is a placeholder)
    allocate (work(2, 2, n), hg_pair(2, nnz), pair_area(nnz), hg_coef(nnz), unit_f(2, 2, n))
    call reference_pair_factors(n, x0, h, area, [(0.0_wp, i = 1, n)], 0.0_wp, ptr, nbr, pair_area, hg_coef)
    do i = 1, n
      unit_f(:, :, i) = reshape([1.0_wp, 0.0_wp, 0.0_wp, 1.0_wp], [2, 2])
    end do
    call tlsph_forces(n, x0, x0, area, ptr, nbr, grad_w, pair_area, hg_coef, bmat, unit_f, &
                      [(1.0_wp, i = 1, n)], p, p_tt, work, hg_pair, force)
    hoop = hoop_force(area, p_tt)
  end subroutine tlsph_ring_forces

end module fsph_api
