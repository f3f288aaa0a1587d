!> The hydrocode cycle (docs/method.md, "The cycle, module by module"): set-up of derived
!> quantities and `solver_advance`, one call per phase, for elements,
!> particles, their coupling and the conversion of elements to particles.
module fsph_solver
  use fsph_kinds, only: wp, axis_tolerance
  use fsph_status, only: status_ok, status_bad_input, status_not_ready, status_max_cycles, &
                         status_dt_floor, status_dt_drop, status_particle_axis, status_nonfinite_particle
  use fsph_state, only: simulation_t, particle_set_t, state_grow_particles
  use fsph_state_views, only: permute_particles
  use fsph_spatial, only: spatial_order, renumber_due
  use fsph_arrays, only: reserve, grow
  use fsph_layouts, only: n_strength_models, n_eos_models, prop_rho0, prop_fracture_energy, prop_shear, &
                          prop_t_room, strength_hjc, eos_hjc, history_columns, hcol_time, hcol_cycle, &
                          hcol_dt, hcol_plane_impulse_z, energy_first, body_columns, bcol_kinetic, &
                          bcol_internal, bcol_momentum_z, bcol_plastic_work, hist_plastic_work, gauge_columns, &
                          bcol_viscous_work, bcol_hourglass_work, bcol_contact_work, hist_viscous_work, &
                          hist_hourglass_work, hist_contact_work, hist_contact_corrected, &
                          phase_element_forces, phase_element_update, phase_neighbours, phase_sph_sums, &
                          phase_particle_update, phase_particle_contact, phase_coupling, phase_contact, &
                          phase_integrate, phase_conversion, phase_time_step, particle_contact_riemann
  use fsph_material, only: eos_pressure, sound_speed
  use fsph_element, only: element_geometry, element_corner_forces, gather_corner_forces, &
                          element_update, element_time_step
  use fsph_boundary, only: apply_axis, apply_rigid_plane
  use fsph_integrate, only: integrate_velocities, integrate_positions, kick_particles, mean_kick_velocity
  use fsph_neighbours, only: build_neighbours
  use fsph_sph, only: sph_accelerations, sph_rates, sph_energy_rate, sph_time_step, &
                      axis_resultant, particle_radii, &
                      pair_weights, compression_switch, artificial_stress, artificial_reference
  use fsph_mirror, only: mirror_plane_normal_to_axis, mirror_select, mirror_fill_start, mirror_fill_mid, &
                         mirror_fill_stress, mirror_reaction_z
  use fsph_particles, only: particle_state_update, particle_energy_update, &
                            particle_contact_accelerations, riemann_contact_accelerations, riemann_contact_heat, &
                            riemann_contact_density_rate, contact_normals, contact_pairs_in, total_stress, &
                            keep_start_state, mid_step_state, point_intact
  use fsph_eigenerosion, only: eigenerosion_failure
  use fsph_total, only: total_setup, total_forces, total_rates, total_energy_rate, total_time_step, total_active
  use fsph_coupling, only: fill_imaginary, coupling_tractions, tie_forces, tie_velocities, reaction_velocities, &
                           update_tie_masses, stage_select, stage_start, stage_mid, associate_particles, &
                           association_reach
  use fsph_verlet, only: lists_still_valid, record_lists, list_skin, adapt_skin, restored_skin
  use fsph_convert, only: assign_groups, convert_elements
  use fsph_topology, only: rebuild_corner_map, nodal_masses
  use fsph_contact, only: contact_rebuild_surface, contact_correct, contact_step_limit
  use fsph_erosion, only: erode_elements
  use fsph_timers, only: timer_start, timer_stop, wall_clock
  use fsph_threads, only: governor_begin, governor_cycle, governor_end
  use fsph_gauges, only: gauges_unlocate, gauges_locate_elements, gauges_locate_particles, gauges_track, &
                         gauges_refind, gauges_switch, gauges_lose, gauges_begin_record, gauges_find_elements, &
                         gauges_find_particles, gauges_element_rows, gauges_particle_rows, gauges_renumber
  implicit none
  private

  public :: solver_initialise, solver_advance, energy_budget, solver_stable_step, solver_forces
  public :: prepare_particle_sums, update_particle_radius, locate_gauges, setup_total

contains

  !> Derived set-up once nodes, elements, materials and planes are in place:
  !> element geometry, masses and densities, lumped nodal masses (1/3 of
  !> each element's ring mass to each of its nodes, EPIC style), the
  !> node-to-corner map, axis flags, initial material state and time step.
  subroutine solver_initialise(sim, ierr, ifault)
    type(simulation_t), intent(inout) :: sim
    integer, intent(out) :: ierr, ifault

    ifault = 0
    ierr = status_bad_input
    if (sim%elements%n < 1 .and. sim%particles%n < 1) return
    if (sim%n_materials < 1) return
    if (any(sim%istrength < 1) .or. any(sim%istrength > n_strength_models)) return
    if (any(sim%ieos < 1) .or. any(sim%ieos > n_eos_models)) return
    ! the HJC strength and EOS go together
    if (any((sim%istrength == strength_hjc) .neqv. (sim%ieos == eos_hjc))) return
    call default_continua(sim)
    if (sim%elements%n > 0) then
      call initialise_elements(sim, ierr, ifault)
      if (ierr /= status_ok) return
    end if
    if (sim%particles%n > 0) then
      call initialise_particles(sim, ierr, ifault)
      if (ierr /= status_ok) return
      call setup_total(sim, ierr, ifault)
      if (ierr /= status_ok) return
    end if
    if (sim%elements%n > 0 .and. sim%particles%capacity > 0) then
      call assign_groups(sim%elements, sim%nodes, sim%conversion, sim%body_coupled)
      ! fixed coupling: particles next to the element region are associated
      ! with its surface edges
      call associate_particles(sim%particles, sim%elements, sim%nodes, sim%coupling, sim%continuum_of_body, &
                               sim%body_coupled, sim%conversion%alpha_h, association_reach)
      call update_tie_masses(sim%particles, sim%nodes)
    end if
    call contact_rebuild_surface(sim%contact, sim%elements, sim%nodes, sim%continuum_of_body)
    sim%contact%dissipated = 0.0_wp
    sim%plane_dissipated = 0.0_wp
    sim%plane_impulse_z = 0.0_wp

    sim%time = 0.0_wp
    sim%cycle = 0
    sim%dt_last = 0.0_wp
    call solver_stable_step(sim)
    sim%dt_initial = sim%dt
    sim%n_history = 0
    sim%history_cycle = -1
    sim%energy_full_before = energy_full_step(sim)
    sim%energy_full_cycle = 0
    call record_history(sim)
    sim%ready = .true.
    ierr = status_ok
    ifault = 0
  end subroutine solver_initialise

  !> Without set_continua every body is its own, uncoupled continuum.
  subroutine default_continua(sim)
    type(simulation_t), intent(inout) :: sim
    integer :: nb, ib
    nb = 0
    if (sim%elements%n > 0) nb = max(nb, maxval(sim%elements%body))
    if (sim%particles%n > 0) nb = max(nb, maxval(sim%particles%body(1:sim%particles%n)))
    if (allocated(sim%continuum_of_body)) then
      if (size(sim%continuum_of_body) >= nb) return
    end if
    sim%continuum_of_body = [(ib, ib = 1, nb)]
    if (allocated(sim%body_coupled)) deallocate (sim%body_coupled)
    allocate (sim%body_coupled(nb))
    sim%body_coupled = .false.
  end subroutine default_continua

  !> Elements: geometry, masses and densities, lumped nodal masses (1/3 of
  !> each element's ring mass to each of its nodes, EPIC style), the
  !> node-to-corner map, axis flags, initial material state.
  subroutine initialise_elements(sim, ierr, ifault)
    type(simulation_t), intent(inout) :: sim
    integer, intent(out) :: ierr, ifault
    integer :: ne, nn, ie, im
    real(wp) :: r_extent

    ifault = 0
    ierr = status_bad_input
    ne = sim%elements%n
    nn = sim%nodes%n
    associate (el => sim%elements, nd => sim%nodes)
      if (nn < 3) return
      if (any(el%conn < 1) .or. any(el%conn > nn)) return
      if (any(el%mat < 1) .or. any(el%mat > sim%n_materials)) return

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
        el%c(ie) = reference_sound_speed(sim, im)
      end do
      el%s = 0.0_wp; el%p = 0.0_wp; el%q = 0.0_wp; el%eps_p = 0.0_wp; el%e = 0.0_wp
      el%hist = 0.0_wp
      el%d = 0.0_wp; el%spin = 0.0_wp

      ! the node -> corner map and lumped masses; every node must belong to
      ! an element
      call rebuild_corner_map(nd, el)
      call nodal_masses(nd, el)
      ierr = status_bad_input
      if (any(nd%corner_ptr(2:nn + 1) == nd%corner_ptr(1:nn))) then
        ifault = findloc(nd%corner_ptr(2:nn + 1) == nd%corner_ptr(1:nn), .true., dim=1)
        return
      end if
    end associate
    ierr = status_ok
  end subroutine initialise_elements

  !> Particles: reference density, temperature, sound speed, radius; all
  !> particles must start off the axis (r > 0).
  subroutine initialise_particles(sim, ierr, ifault)
    type(simulation_t), intent(inout) :: sim
    integer, intent(out) :: ierr, ifault
    integer :: i, im, n
    ierr = status_bad_input
    ifault = 0
    n = sim%particles%n
    associate (pt => sim%particles)
      if (any(pt%mat(1:n) < 1) .or. any(pt%mat(1:n) > sim%n_materials)) return
      if (any(.not. (pt%mass(1:n) > 0.0_wp)) .or. any(.not. (pt%h(1:n) > 0.0_wp))) return
      if (any(.not. (pt%x(1, 1:n) > 0.0_wp))) then
        ierr = status_particle_axis
        ifault = -findloc(.not. (pt%x(1, 1:n) > 0.0_wp), .true., dim=1)
        return
      end if
      pt%x0(:, 1:n) = pt%x(:, 1:n)
      do i = 1, n
        im = pt%mat(i)
        pt%rho(i) = sim%props(prop_rho0, im)
        pt%temp(i) = sim%props(prop_t_room, im)
        pt%c(i) = reference_sound_speed(sim, im)
        pt%continuum(i) = sim%continuum_of_body(pt%body(i))
      end do
      pt%s = 0.0_wp; pt%p = 0.0_wp; pt%sig = 0.0_wp; pt%eps_p = 0.0_wp; pt%e = 0.0_wp
      pt%hist = 0.0_wp
      pt%d = 0.0_wp; pt%spin = 0.0_wp; pt%drho = 0.0_wp; pt%de = 0.0_wp
      pt%tie_a = 0; pt%tie_b = 0; pt%assoc = 0
    end associate
    call update_particle_radius(sim)
    ierr = status_ok
  end subroutine initialise_particles

  !> The imaginary particles of the run's elements at `stage` (fsph_coupling
  !> fill_imaginary; margin: the neighbour lists' skin [m]).
  subroutine refill_imaginary(sim, stage, margin)
    type(simulation_t), intent(inout) :: sim
    integer, intent(in) :: stage
    real(wp), intent(in), optional :: margin
    call fill_imaginary(sim%particles, sim%elements, sim%nodes, sim%continuum_of_body, sim%body_coupled, &
                        sim%conversion%alpha_h, stage, margin)
  end subroutine refill_imaginary

  !> Particle radius (contact thickness, plane and axis offsets) from the
  !> mass and ring radius at the density, but never above the radius at
  !> the reference density: the (SPH) density of separating fragments falls
  !> while the fragments keep their size, and a radius grown from it
  !> reached 7 mm on a concrete debris particle and drew contact kicks.
  subroutine update_particle_radius(sim)
    type(simulation_t), intent(inout) :: sim
    integer :: n
    n = sim%particles%n
    associate (pt => sim%particles)
      call particle_radii(n, sim%props(prop_rho0, :), pt%mat, pt%mass, pt%x, pt%rho, pt%radius)
    end associate
  end subroutine update_particle_radius

  !> The total-Lagrangian particles and their reference data (fsph_total),
  !> from the particles' initial positions, smoothing lengths and masses,
  !> their materials' reference densities and Young's moduli E = 9 K G /
  !> (3 K + G), K = rho0 c0^2 - 4 G / 3 from the reference sound speed c0.
  !> At set-up and after a restore (the data follow from the state).
  subroutine setup_total(sim, ierr, ifault)
    type(simulation_t), intent(inout) :: sim
    integer, intent(out) :: ierr, ifault
    real(wp) :: rho0(sim%particles%n), modulus(sim%particles%n), mat_modulus(sim%n_materials)
    real(wp) :: g, bulk
    integer :: im, n
    n = sim%particles%n
    do im = 1, sim%n_materials
      g = sim%props(prop_shear, im)
      bulk = sim%props(prop_rho0, im)*reference_sound_speed(sim, im)**2 - 4.0_wp*g/3.0_wp
      mat_modulus(im) = 0.0_wp
      if (g > 0.0_wp .and. bulk > 0.0_wp) mat_modulus(im) = 9.0_wp*bulk*g/(3.0_wp*bulk + g)
    end do
    associate (pt => sim%particles)
      rho0 = sim%props(prop_rho0, pt%mat(1:n))
      modulus = mat_modulus(pt%mat(1:n))
      call total_setup(sim%total, n, pt%x0(:, 1:n), pt%h(1:n), pt%mass(1:n), pt%body(1:n), rho0, modulus, &
                       sim%elements%n, ierr, ifault)
    end associate
  end subroutine setup_total

  !> Sound speed of material im at its reference state [m/s].
  function reference_sound_speed(sim, im) result(c)
    type(simulation_t), intent(in) :: sim
    integer, intent(in) :: im
    real(wp) :: c, a_eos, b_eos, dadrho
    integer :: ierr
    call eos_pressure(sim%props(:, im), sim%ieos(im), sim%props(prop_rho0, im), a_eos, b_eos, &
                      dadrho, ierr)
    c = sound_speed(sim%props(prop_shear, im), dadrho, b_eos, sim%props(prop_rho0, im), 0.0_wp)
  end function reference_sound_speed

  !> Stable step for the next cycle: safety factor times the smallest of
  !> the element limit (with the elements a contact is about to strike at
  !> their closing speed: fsph_contact contact_step_limit) and the particle
  !> limit h/(c + |v|).
  subroutine solver_stable_step(sim)
    type(simulation_t), intent(inout) :: sim
    real(wp) :: dt_e, dt_p, dt_t, dt_c
    integer :: i_e, i_p, i_t, i_c
    dt_e = huge(1.0_wp)
    dt_p = huge(1.0_wp)
    i_e = 0
    i_p = 0
    associate (el => sim%elements, pt => sim%particles)
      if (el%n > 0) call element_time_step(el%n, el%lmin, el%area, el%c, el%d, sim%control%c_q, &
                                           sim%control%c_l, dt_e, i_e)
      if (pt%n > 0) call sph_time_step(pt%n, pt%x, pt%h, pt%c, pt%v, dt_p, i_p)
      if (total_active(sim%total)) then
        call total_time_step(sim%total, pt%n, pt%c, pt%v, pt%d, sim%control%c_q, sim%control%c_l, dt_t, i_t)
        if (dt_t < dt_p) then
          dt_p = dt_t
          i_p = i_t
        end if
      end if
      ! the elements a contact will strike in this step, at its closing speed
      if (el%n > 0) then
        call contact_step_limit(sim%contact, sim%nodes, pt, el, sim%control%dt_safety*min(dt_e, dt_p), &
                                sim%control%c_q, sim%control%c_l, dt_c, i_c)
        if (dt_c < dt_e) then
          dt_e = dt_c
          i_e = i_c
        end if
      end if
    end associate
    if (dt_e <= dt_p) then
      sim%dt_element = i_e
      sim%dt_particle = 0
    else
      sim%dt_element = 0
      sim%dt_particle = i_p
    end if
    sim%dt = sim%control%dt_safety*min(dt_e, dt_p)
  end subroutine solver_stable_step

  !> Run cycles until the clock reaches t_target [s], or a failure, or
  !> max_cycles more cycles, the clock stopping at the first cycle end at
  !> or after t_target. No step crosses t_land [s] (>= t_target): the last
  !> steps before it are shortened to end exactly on it, and every other
  !> step is the stable one. A run that lands on its end time (t_land) and
  !> stops on the way for its outputs (t_target < t_land) therefore takes
  !> the same steps whatever its output times; t_land = t_target lands on
  !> t_target, a t_land beyond the run's end never shortens a step.
  subroutine solver_advance(sim, t_target, max_cycles, t_land, ierr, ifault)
    type(simulation_t), intent(inout) :: sim
    real(wp), intent(in) :: t_target, t_land
    integer, intent(in) :: max_cycles
    integer, intent(out) :: ierr, ifault
    !> Remaining time below this fraction of a step counts as arrived [-].
    real(wp), parameter :: arrival_fraction = 1.0e-9_wp
    !> A cycle that leaves less than this fraction of a step to t_target
    !> may end the advance (a generous bound on the arrival test) [-].
    real(wp), parameter :: may_arrive_fraction = 1.0e-3_wp
    real(wp) :: remaining, to_land, dt_step, started
    integer :: n_done
    logical :: may_record

    ierr = status_not_ready
    ifault = 0
    if (.not. sim%ready) return
    ierr = status_ok
    n_done = 0
    call governor_begin(sim%governor)
    do
      remaining = t_target - sim%time
      if (remaining <= arrival_fraction*sim%dt) exit
      if (n_done >= max_cycles) then
        ierr = status_max_cycles
        exit
      end if
      ! land on t_land without a sliver step: the last one or two steps
      ! share the remainder
      dt_step = sim%dt
      to_land = t_land - sim%time
      if (to_land <= sim%dt) then
        dt_step = to_land
      else if (to_land < 2.0_wp*sim%dt) then
        dt_step = 0.5_wp*to_land
      end if
      ! a history record may follow this cycle: sum the full-step energy
      ! books at its start (energy_budget)
      may_record = mod(sim%cycle + 1, sim%control%history_every) == 0 .or. n_done + 1 >= max_cycles &
                   .or. remaining - dt_step <= may_arrive_fraction*max(dt_step, sim%dt)
      started = wall_clock()
      call cycle(sim, dt_step, may_record, ierr, ifault)
      call governor_cycle(sim%governor, wall_clock() - started)
      n_done = n_done + 1
      if (ierr /= status_ok) exit
    end do
    call governor_end(sim%governor)
    ! the state at the end of each advance is always in the history
    if (sim%history_cycle /= sim%cycle) call record_history(sim)
  end subroutine solver_advance

  !> One explicit cycle of length dt_step [s] (docs/method.md, "One cycle").
  !> With may_record the full-step energy books are summed at its start, for
  !> the time-centred total of a history record after it (energy_budget).
  !> On failure ifault is the element or node (> 0) or minus the particle
  !> (< 0) at fault.
  subroutine cycle(sim, dt_step, may_record, ierr, ifault)
    type(simulation_t), intent(inout) :: sim
    real(wp), intent(in) :: dt_step
    logical, intent(in) :: may_record
    integer, intent(out) :: ierr, ifault
    integer :: n_new, n_eroded, n_before
    real(wp) :: heat_before

    ! 0. the full-step energy books at t^n, for the time-centred total of a
    !    record after this cycle (timed with the history records)
    if (may_record) then
      call timer_start(sim%timers, phase_time_step)
      sim%energy_full_before = energy_full_step(sim)
      sim%energy_full_cycle = sim%cycle
      call timer_stop(sim%timers, phase_time_step)
    else
      sim%energy_full_cycle = -1
    end if
    ! 1. forces at t^n: element nodal forces; imaginary particles,
    !    particle neighbours, SPH accelerations, particle contact; coupling
    !    tractions on interface edges; tied particles' forces to their edges
    call compute_forces(sim, dt_step, ierr, ifault)
    if (ierr /= status_ok) return
    ! 2. central difference: velocities to t^(n+1/2)
    call timer_start(sim%timers, phase_integrate)
    call update_velocities(sim, 0.5_wp*(sim%dt_last + dt_step))
    call timer_stop(sim%timers, phase_integrate)
    ! 3. contact between bodies, then boundary conditions on the half-step
    !    velocities; tied particles follow their edges
    call timer_start(sim%timers, phase_contact)
    call contact_correct(sim%contact, sim%nodes, sim%particles, sim%elements, dt_step, 0.5_wp*(sim%dt_last + dt_step))
    call timer_stop(sim%timers, phase_contact)
    call timer_start(sim%timers, phase_integrate)
    call apply_boundaries(sim, dt_step)
    call finish_particle_kick(sim, 0.5_wp*(sim%dt_last + dt_step), dt_step)
    ! 4. positions to t^(n+1); the clock moves with them, so a failure in
    !    the rest of the cycle is reported at the time the geometry reached
    call update_positions(sim, dt_step, ierr, ifault)
    call timer_stop(sim%timers, phase_integrate)
    if (ierr /= status_ok) return
    sim%time = sim%time + dt_step
    sim%cycle = sim%cycle + 1
    sim%dt_last = dt_step
    ! 5. element strain rates at mid-step, new geometry, stress update
    call timer_start(sim%timers, phase_element_update)
    call update_elements(sim, dt_step, ierr, ifault)
    call timer_stop(sim%timers, phase_element_update)
    if (ierr /= status_ok) return
    ! 6. particle rates at mid-step (density, energy, strain rate), update
    call update_particles(sim, dt_step, ierr, ifault)
    if (ierr /= status_ok) return
    ! 7. erosion of over-strained elements (FEM baseline), conversion of
    !    distorted element groups, surface and ties
    call timer_start(sim%timers, phase_conversion)
    if (sim%gauges%n > 0 .and. sim%elements%n > 0 .and. (sim%erosion%enabled .or. sim%conversion%enabled)) &
      call gauges_track(sim%gauges, sim%elements%n, sim%nodes%n, sim%elements%conn, sim%nodes%x)
    call erode_elements(sim%erosion, sim%elements, sim%nodes, sim%particles, sim%coupling, sim%contact, &
                        sim%continuum_of_body, n_eroded)
    n_before = sim%particles%n
    heat_before = sim%conversion%heat
    call convert_elements(sim%elements, sim%nodes, sim%particles, sim%coupling, sim%conversion, sim%contact, &
                          sim%continuum_of_body, sim%body_coupled, n_new)
    ! the kinetic energy a conversion turns into heat leaves the half-step
    ! books now and joins the full-step books at both ends of the step
    sim%energy_full_before = sim%energy_full_before + (sim%conversion%heat - heat_before)
    if (sim%gauges%n > 0 .and. n_eroded + n_new > 0) call follow_gauges(sim, n_new > 0)
    if (n_new > 0) call keep_spatial_order(sim, n_before)
    call timer_stop(sim%timers, phase_conversion)
    ! 8. next stable step
    call timer_start(sim%timers, phase_time_step)
    sim%dt_previous = sim%dt
    call solver_stable_step(sim)
    if (mod(sim%cycle, sim%control%history_every) == 0) call record_history(sim)
    call timer_stop(sim%timers, phase_time_step)
    if (sim%dt < sim%control%dt_floor_ratio*sim%dt_initial) then
      ierr = status_dt_floor
      ifault = sim%dt_element - sim%dt_particle   ! particle faults are negative
    else if (sim%dt < sim%control%dt_drop_ratio*sim%dt_previous) then
      ierr = status_dt_drop
      ifault = sim%dt_element - sim%dt_particle
    end if
  end subroutine cycle

  subroutine compute_forces(sim, dt_step, ierr, ifault)
    type(simulation_t), intent(inout) :: sim
    real(wp), intent(in) :: dt_step
    integer, intent(out) :: ierr, ifault
    integer :: n, ntot
    ierr = status_ok
    ifault = 0
    associate (el => sim%elements, nd => sim%nodes, pt => sim%particles)
      if (el%n > 0) then
        call timer_start(sim%timers, phase_element_forces)
        call element_corner_forces(el%n, nd%n, el%conn, nd%x, el%s, el%p, el%q, el%fc)
        call gather_corner_forces(nd%n, el%n, size(nd%corner_list), nd%corner_ptr, nd%corner_list, &
                                  el%fc, nd%f)
        call timer_stop(sim%timers, phase_element_forces)
      end if
      n = pt%n
      if (n > 0) then
        call timer_start(sim%timers, phase_neighbours)
        call prepare_particle_sums(sim, ntot)
        call timer_stop(sim%timers, phase_neighbours)
        call timer_start(sim%timers, phase_sph_sums)
        call pair_weights(ntot, pt%x, pt%mass, pt%rho, pt%wgt, pt%planar_area)
        call compression_switch(n, pt%d, pt%c, pt%h, pt%switch)
        if (sim%control%sph_artificial_stress > 0.0_wp) &
          call artificial_stress(n, ntot, pt%n_imag, pt%sig, sim%control%sph_artificial_stress, pt%art_stress)
        call sph_accelerations(n, ntot, pt%n_imag, pt%x, pt%v, pt%mass, pt%rho, pt%h, pt%c, pt%sig, pt%wgt, pt%intact, &
                               pt%grad_v, pt%switch, pt%hist(hist_contact_corrected, 1:n), pt%mirror_of, pt%nbr_ptr, &
                               pt%nbr_list, pt%low_ptr, &
                               pt%low_pair, pt%low_other, sim%control%sph_c_q, sim%control%sph_c_l, sim%control%sph_c_hg, &
                               sim%control%sph_artificial_stress, pt%art_stress, &
                               artificial_reference(sim%conversion%alpha_h), &
                               pt%acc, pt%pair_q, pt%pair_force, pt%pair_hg, pt%pair_in, pt%acc_imag, &
                               pt%acc_axis)
        ! total-Lagrangian particles: their own forces (no SPH sums)
        if (total_active(sim%total)) then
          call total_forces(sim%total, n, pt%x, pt%sig, pt%d, pt%rho, pt%c, pt%mass, pt%intact, sim%control%c_q, &
                            sim%control%c_l, pt%acc, ierr, ifault)
          if (ierr /= status_ok) then
            call timer_stop(sim%timers, phase_sph_sums)
            return
          end if
        end if
        ! the planes' images push with these forces over this cycle's kick
        if (pt%n_mirror > 0) sim%plane_impulse_z = sim%plane_impulse_z + 0.5_wp*(sim%dt_last + dt_step)* &
          mirror_reaction_z(n, n + pt%n_imag, pt%nbr_ptr, pt%nbr_list, pt%mass, pt%pair_force)
        call timer_stop(sim%timers, phase_sph_sums)
        call timer_start(sim%timers, phase_particle_contact)
        call update_particle_radius(sim)
        if (sim%control%particle_contact == particle_contact_riemann) then
          call contact_pairs_in(n, pt%x, pt%h, pt%cnt_ptr, pt%cnt_list, pt%cnt_in)
          call contact_normals(n, pt%x, pt%mass, pt%rho, pt%h, pt%cnt_ptr, pt%cnt_list, pt%cnt_in, pt%cnt_normal)
          call riemann_contact_accelerations(n, pt%x, pt%v, pt%mass, pt%rho, pt%c, pt%sig, pt%h, pt%cnt_normal, &
                                             pt%cnt_ptr, pt%cnt_list, pt%cnt_in, pt%acc, pt%cnt_force, pt%cnt_vstar, &
                                             pt%acc_axis)
        else
          ! planar areas of pair_weights, from the positions and densities of this stage
          call particle_contact_accelerations(n, pt%x, pt%mass, pt%planar_area, pt%h, pt%cnt_ptr, pt%cnt_list, &
                                              dt_step, sim%control%contact_penalty, sim%control%contact_touch, &
                                              sim%control%contact_slope, pt%contact_excess, pt%acc)
        end if
        ! the axis carries no axial load: each fragment's resultant of the
        ! images' axial stress forces is removed
        call axis_resultant(n, pt%mass, pt%nbr_ptr, pt%half_end, pt%nbr_list, pt%pair_in, pt%acc_axis, pt%acc)
        call timer_stop(sim%timers, phase_particle_contact)
        if (el%n > 0) then
          call timer_start(sim%timers, phase_coupling)
          call coupling_tractions(sim%coupling, sim%particles, sim%nodes, sim%continuum_of_body)
          call tie_forces(sim%particles, sim%nodes)
          call timer_stop(sim%timers, phase_coupling)
        end if
      end if
    end associate
  end subroutine compute_forces

  !> Imaginary particles and mirror images at t^n, neighbour lists of the
  !> real particles (rebuilt, with the imaginary elements and the mirrored
  !> particles chosen again, only when the kept lists may miss a pair:
  !> fsph_verlet), their total stress s - p I and room for the pair work
  !> arrays; ntot is the number of real, imaginary and mirror entries.
  subroutine prepare_particle_sums(sim, ntot)
    type(simulation_t), intent(inout) :: sim
    integer, intent(out) :: ntot
    integer :: n
    real(wp) :: skin
    logical :: expired
    associate (pt => sim%particles)
      n = pt%n
      ! lists that may only expire by the displacement test
      expired = pt%lists_valid .and. n == pt%n_listed .and. n > 0
      if (pt%lists_valid) then
        if (sim%elements%n > 0 .and. pt%n_imag > 0) call refill_imaginary(sim, stage_start)
        call fill_mirrors_start(sim)
      end if
      if (sim%total%alone) then
        ! one total-Lagrangian body and nothing else: no SPH sums, no
        ! contact between particles; the lists stay empty
        call empty_lists(sim%particles)
      else if (.not. lists_still_valid(sim%particles, sim%nodes, sim%elements, sim%body_coupled, &
                                       sim%conversion%alpha_h, .not. any_mirror_plane(sim))) then
        if (expired) call adapt_skin(sim%particles)
        skin = list_skin(sim%particles, sim%control%neighbour_skin)
        call build_lists(sim, skin)
        call record_lists(sim%particles, sim%nodes, sim%elements, sim%body_coupled, sim%conversion%alpha_h, &
                          skin)
      else
        ! books of lists a restart restored (fsph_verlet restore_lists):
        ! their entries, built once, not counted as a build
        if (pt%lists_pending) call build_lists(sim, restored_skin(sim%particles, sim%elements, &
                                                                  sim%body_coupled, sim%conversion%alpha_h))
        pt%lists_pending = .false.
        pt%list_uses = pt%list_uses + 1
      end if
      ntot = n + pt%n_imag + pt%n_mirror
      call total_stress(n, pt%s, pt%p, pt%sig)
      call reserve(pt%intact, ntot)
      call fill_intact(sim%particles)
      call reserve(pt%pair_q, size(pt%nbr_list))
      call reserve(pt%nbr_grad, 2, size(pt%nbr_list))
      call reserve(pt%pair_force, 2, size(pt%nbr_list))
      call reserve(pt%pair_hg, 2, size(pt%nbr_list))
      call reserve(pt%pair_work, 3, size(pt%nbr_list))
      call reserve(pt%pair_in, size(pt%nbr_list))
      call reserve(pt%art_stress, 3, ntot)
      call reserve(pt%cnt_force, 2, size(pt%cnt_list))
      call reserve(pt%acc_axis, n)
      call reserve(pt%cnt_vstar, 2, size(pt%cnt_list))
      call reserve(pt%cnt_normal, 2, n)
      call reserve(pt%fracture_work, 3, n)
      call reserve(pt%cnt_in, size(pt%cnt_list))
    end associate
  end subroutine prepare_particle_sums

  !> Choose the imaginary particles and the mirror images and build the
  !> neighbour and contact lists with every pair's reach widened by `skin`
  !> [m] (fsph_neighbours); the caller books the build (fsph_verlet).
  subroutine build_lists(sim, skin)
    type(simulation_t), intent(inout) :: sim
    real(wp), intent(in) :: skin
    integer :: n
    integer, allocatable :: search_body(:)
    associate (pt => sim%particles)
      n = pt%n
      pt%n_imag = 0
      if (sim%elements%n > 0) call refill_imaginary(sim, stage_select, skin)
      call select_mirrors(sim, skin)
      call fill_mirrors_start(sim)
      ! total-Lagrangian particles take part in the search as contact
      ! candidates only: a negative continuum keeps them out of the sums
      search_body = pt%continuum(1:n + pt%n_imag + pt%n_mirror)
      if (total_active(sim%total)) search_body(sim%total%index) = -search_body(sim%total%index)
      call build_neighbours(n, n + pt%n_imag + pt%n_mirror, pt%x, pt%h, search_body, skin, pt%search, &
                           pt%nbr_ptr, pt%nbr_list, pt%half_end, pt%low_ptr, pt%low_pair, pt%low_other, &
                           pt%cnt_ptr, pt%cnt_list)
    end associate
  end subroutine build_lists

  !> Empty neighbour and contact lists for the n particles, without mirror
  !> images or imaginary particles.
  subroutine empty_lists(pt)
    type(particle_set_t), intent(inout) :: pt
    integer :: n
    n = pt%n
    pt%n_imag = 0
    pt%n_mirror = 0
    pt%nbr_ptr(1:n + 1) = 1
    pt%half_end(1:n) = 1
    pt%low_ptr(1:n + 1) = 1
    pt%cnt_ptr(1:n + 1) = 1
    call reserve(pt%nbr_list, 1)
    call reserve(pt%low_pair, 1)
    call reserve(pt%low_other, 1)
    call reserve(pt%cnt_list, 1)
  end subroutine empty_lists

  !> Which entries are intact (1) and which have failed (0): real particles
  !> by their history, imaginary ones (elements) intact, mirror images as
  !> their particle (fsph_sph acts_on).
  subroutine fill_intact(pt)
    type(particle_set_t), intent(inout) :: pt
    integer :: i, n
    n = pt%n
    call point_intact(n, pt%hist, pt%intact)
    pt%intact(n + 1:n + pt%n_imag) = 1.0_wp
    do i = 1, pt%n_mirror
      pt%intact(n + pt%n_imag + i) = pt%intact(pt%mirror_of(i))
    end do
  end subroutine fill_intact

  !> Choose the particles mirrored across rigid planes normal to the axis
  !> (fsph_mirror), making room for their images after the imaginary
  !> particles.
  subroutine select_mirrors(sim, skin)
    type(simulation_t), intent(inout) :: sim
    real(wp), intent(in) :: skin
    integer :: first, ip
    real(wp) :: point(2, max(sim%n_planes, 1)), normal(2, max(sim%n_planes, 1))
    associate (pt => sim%particles)
      pt%n_mirror = 0
      if (sim%n_planes == 0 .or. pt%n == 0) return
      do ip = 1, sim%n_planes
        point(:, ip) = sim%planes(ip)%point
        normal(:, ip) = sim%planes(ip)%normal
      end do
      first = pt%n + pt%n_imag
      call mirror_select(pt%n, pt%x, pt%h, skin, sim%n_planes, point, normal, pt%capacity - first, pt%n_mirror, &
                         pt%mirror_of, pt%mirror_plane)
      if (first + pt%n_mirror > pt%capacity) then
        call state_grow_particles(sim%particles, first + pt%n_mirror + (first + pt%n_mirror)/4)
        call mirror_select(pt%n, pt%x, pt%h, skin, sim%n_planes, point, normal, pt%capacity - first, &
                           pt%n_mirror, pt%mirror_of, pt%mirror_plane)
      end if
    end associate
  end subroutine select_mirrors

  !> Whether a rigid plane gives the particles mirror images (a plane
  !> normal to the axis, fsph_mirror).
  logical function any_mirror_plane(sim)
    type(simulation_t), intent(in) :: sim
    integer :: ip
    any_mirror_plane = .false.
    do ip = 1, sim%n_planes
      if (mirror_plane_normal_to_axis(sim%planes(ip)%normal)) any_mirror_plane = .true.
    end do
  end function any_mirror_plane

  !> Plane points and normals as arrays (2, n_planes).
  subroutine plane_arrays(sim, point, normal)
    type(simulation_t), intent(in) :: sim
    real(wp), intent(out) :: point(:, :), normal(:, :)
    integer :: ip
    do ip = 1, sim%n_planes
      point(:, ip) = sim%planes(ip)%point
      normal(:, ip) = sim%planes(ip)%normal
    end do
  end subroutine plane_arrays

  !> Mirror images at the start of the cycle.
  subroutine fill_mirrors_start(sim)
    type(simulation_t), intent(inout) :: sim
    real(wp) :: point(2, max(sim%n_planes, 1)), normal(2, max(sim%n_planes, 1))
    associate (pt => sim%particles)
      if (pt%n_mirror == 0) return
      call plane_arrays(sim, point, normal)
      call mirror_fill_start(pt%n + pt%n_imag, pt%n_mirror, pt%mirror_of, pt%mirror_plane, sim%n_planes, point, &
                             normal, pt%x, pt%v, pt%v_bar, pt%mass, pt%rho, pt%rho_mid, pt%h, pt%radius, pt%c, &
                             pt%s, pt%p, pt%sig, pt%grad_v, pt%continuum, pt%mat, pt%body)
    end associate
  end subroutine fill_mirrors_start

  !> Forces of the current state (step 1 of the cycle), for verification.
  subroutine solver_forces(sim, dt_step, ierr, ifault)
    type(simulation_t), intent(inout) :: sim
    real(wp), intent(in) :: dt_step
    integer, intent(out) :: ierr, ifault
    call compute_forces(sim, dt_step, ierr, ifault)
  end subroutine solver_forces

  subroutine update_velocities(sim, dt_v)
    type(simulation_t), intent(inout) :: sim
    real(wp), intent(in) :: dt_v  !< velocity step: mean of the two position steps [s]
    integer :: n
    associate (nd => sim%nodes, pt => sim%particles)
      if (nd%n > 0) then
        nd%v_start = nd%v                 ! velocity before the kick (work of the planes)
        call integrate_velocities(nd%n, nd%mass_total, nd%f, dt_v, nd%v)
      end if
      n = pt%n
      if (n > 0) then
        ! v_bar: the velocity before the kick
        call kick_particles(n, dt_v, pt%acc, pt%v, pt%v_bar)
      end if
    end associate
  end subroutine update_velocities

  subroutine apply_boundaries(sim, dt_step)
    type(simulation_t), intent(inout) :: sim
    real(wp), intent(in) :: dt_step
    integer :: ip, n
    real(wp) :: work, impulse(2), axis_impulse(2)
    work = 0.0_wp
    impulse = 0.0_wp
    axis_impulse = 0.0_wp     ! radial: no resultant on an axisymmetric body
    n = sim%particles%n
    associate (nd => sim%nodes, pt => sim%particles)
      if (nd%n > 0) call apply_axis(nd%n, nd%on_axis, nd%v)
      ! particles keep at least their radius from the axis and from every
      ! rigid plane: a particle stands for a ring whose planar cell reaches
      ! one radius either side of it, and that cell does not cross the
      ! axis or a wall (the first column and row of a lattice sit there).
      ! The axis acts as a frictionless wall (the odd-extension ghosts
      ! alone let a particle driven hard inwards cross r = 0); across the
      ! planes normal to the axis the mirror images hold the particles and
      ! the wall is a backstop. With the backstops at half the radius,
      ! copper rods had particles that moved in to a third of their radius
      ! from the axis, rang radially against their own images and ended far
      ! colder than the reference state (-456 and -569 kJ/kg; docs/method.md,
      ! "The axis and the anvil"). v_bar still holds the velocity before
      ! the kick.
      if (n > 0) call apply_rigid_plane(n, [0.0_wp, 0.0_wp], [1.0_wp, 0.0_wp], dt_step, pt%x, pt%mass, &
                                        pt%v_bar, pt%v, work, axis_impulse, pt%radius(1:n))
      do ip = 1, sim%n_planes
        if (nd%n > 0) call apply_rigid_plane(nd%n, sim%planes(ip)%point, sim%planes(ip)%normal, dt_step, &
                                             nd%x, nd%mass_total, nd%v_start, nd%v, work, impulse)
        if (n > 0) call apply_rigid_plane(n, sim%planes(ip)%point, sim%planes(ip)%normal, dt_step, pt%x, &
                                          pt%mass, pt%v_bar, pt%v, work, impulse, pt%radius(1:n))
      end do
    end associate
    sim%plane_dissipated = sim%plane_dissipated - work
    ! the axial resultant of the ring loads (their radial parts cancel)
    sim%plane_impulse_z = sim%plane_impulse_z + impulse(2)
  end subroutine apply_boundaries

  !> Tied particles take their edge velocity; v_bar becomes the velocity at
  !> which the viscous work of this kick is charged: the mean over the kick,
  !> scaled from the kick length to the step length.
  subroutine finish_particle_kick(sim, dt_v, dt_step)
    type(simulation_t), intent(inout) :: sim
    real(wp), intent(in) :: dt_v, dt_step
    integer :: n
    real(wp) :: no_nodes(2, 0)
    n = sim%particles%n
    if (n == 0) return
    if (sim%nodes%n > 0) call tie_velocities(sim%particles, sim%nodes)
    associate (pt => sim%particles)
      call mean_kick_velocity(n, dt_v/dt_step, pt%v, pt%v_bar)
    end associate
    ! the velocities at which the pairs with imaginary particles do work
    if (sim%nodes%n > 0) then
      call reaction_velocities(sim%coupling, sim%particles, sim%nodes%v(:, 1:sim%nodes%n), &
                               sim%nodes%v_start(:, 1:sim%nodes%n), dt_v/dt_step)
    else
      call reaction_velocities(sim%coupling, sim%particles, no_nodes, no_nodes, 1.0_wp)
    end if
  end subroutine finish_particle_kick

  subroutine update_positions(sim, dt_step, ierr, ifault)
    type(simulation_t), intent(inout) :: sim
    real(wp), intent(in) :: dt_step
    integer, intent(out) :: ierr, ifault
    ierr = status_ok
    ifault = 0
    associate (nd => sim%nodes, pt => sim%particles)
      if (nd%n > 0) then
        call integrate_positions(nd%n, dt_step, nd%v, nd%x, nd%x_old, nd%x_mid, ierr, ifault)
        if (ierr /= status_ok) return
      end if
      if (pt%n > 0) then
        call integrate_positions(pt%n, dt_step, pt%v, pt%x, pt%x_old, pt%x_mid, ierr, ifault)
        if (ierr /= status_ok) then
          ierr = status_nonfinite_particle
          ifault = -ifault
        end if
      end if
    end associate
  end subroutine update_positions

  subroutine update_elements(sim, dt_step, ierr, ifault)
    type(simulation_t), intent(inout) :: sim
    real(wp), intent(in) :: dt_step
    integer, intent(out) :: ierr, ifault
    ierr = status_ok
    ifault = 0
    associate (el => sim%elements, nd => sim%nodes)
      if (el%n == 0) return
      call element_update(el%n, nd%n, sim%n_materials, el%conn, nd%x_mid, nd%x, nd%v, sim%props, &
                          sim%istrength, sim%ieos, el%mat, dt_step, sim%control%c_q, sim%control%c_l, &
                          el%mass, el%d, el%spin, el%area, el%rbar, el%volume, el%lmin, el%rho, el%q, &
                          el%s, el%p, el%eps_p, el%e, el%temp, el%hist, el%c, ierr, ifault)
    end associate
  end subroutine update_elements

  !> Particle rates at the mid-step positions with the half-step velocities
  !> (neighbour lists of this cycle): density and strain rate, a predictor
  !> energy with the start-of-step stress, the stress update, then the
  !> energy of eq 3 with the mid-step stress and density (the time-centred
  !> work of the central difference, so no secular energy drift), and the
  !> pressure at the final energy.
  subroutine update_particles(sim, dt_step, ierr, ifault)
    type(simulation_t), intent(inout) :: sim
    real(wp), intent(in) :: dt_step
    integer, intent(out) :: ierr, ifault
    integer :: n, ntot
    real(wp) :: point(2, max(sim%n_planes, 1)), normal(2, max(sim%n_planes, 1))
    ierr = status_ok
    ifault = 0
    n = sim%particles%n
    if (n == 0) return
    associate (pt => sim%particles)
      if (any(.not. (pt%x_mid(1, 1:n) > 0.0_wp))) then
        ierr = status_particle_axis
        ifault = -findloc(.not. (pt%x_mid(1, 1:n) > 0.0_wp), .true., dim=1)
        return
      end if
      call timer_start(sim%timers, phase_coupling)
      if (pt%n_imag > 0) call refill_imaginary(sim, stage_mid)
      if (pt%n_mirror > 0) then
        call plane_arrays(sim, point, normal)
        call mirror_fill_mid(n + pt%n_imag, pt%n_mirror, pt%mirror_of, pt%mirror_plane, sim%n_planes, point, &
                             pt%x_mid, pt%v, pt%v_bar, pt%rho, pt%rho_mid)
      end if
      call timer_stop(sim%timers, phase_coupling)
      ntot = n + pt%n_imag + pt%n_mirror
      call timer_start(sim%timers, phase_sph_sums)
      call pair_weights(ntot, pt%x_mid, pt%mass, pt%rho, pt%wgt, pt%planar_area)
      call sph_rates(n, ntot, pt%x_mid, pt%v, pt%mass, pt%rho, pt%h, pt%planar_area, pt%intact, pt%nbr_ptr, &
                     pt%nbr_list, pt%low_ptr, pt%low_pair, pt%low_other, pt%pair_in, pt%nbr_grad, pt%rate_sums, &
                     pt%drho, &
                     pt%d, pt%spin, pt%grad_v)
      if (sim%control%particle_contact == particle_contact_riemann) then
        call contact_normals(n, pt%x_mid, pt%mass, pt%rho, pt%h, pt%cnt_ptr, pt%cnt_list, pt%cnt_in, pt%cnt_normal)
        call riemann_contact_density_rate(n, pt%x_mid, pt%v, pt%mass, pt%rho, pt%c, pt%sig, pt%h, pt%cnt_normal, &
                                          pt%cnt_ptr, pt%cnt_list, pt%cnt_in, pt%drho)
      end if
      if (total_active(sim%total)) then
        call total_rates(sim%total, n, pt%x, pt%rho, dt_step, pt%drho, pt%d, pt%spin, pt%grad_v, ierr, ifault)
        if (ierr /= status_ok) then
          call timer_stop(sim%timers, phase_sph_sums)
          return
        end if
      end if
      call timer_stop(sim%timers, phase_sph_sums)
      call timer_start(sim%timers, phase_particle_update)
      call keep_start_state(n, pt%e, pt%rho, pt%e_old, pt%rho_old)
      call particle_state_update(n, sim%n_materials, sim%props, sim%istrength, sim%ieos, pt%mat, dt_step, &
                                 sim%control%debris_ratio, pt%x, pt%drho, pt%d, pt%spin, pt%e, pt%rho, &
                                 pt%s, pt%p, pt%eps_p, pt%temp, pt%hist, pt%c, pt%n_debris, ierr, ifault)
      ! failure by energy release rate at the end-of-step stress, before the
      ! energy equation: the stress and the pairs (fsph_sph acts_on) that its
      ! mid-step work uses are then those the next kick acts with (failing
      ! after it booked the work of a stress the next kick no longer has:
      ! +1.5 % energy in a spalling steel tube)
      if (ierr == status_ok .and. any(sim%props(prop_fracture_energy, :) > 0.0_wp)) then
        call eigenerosion_failure(n, sim%n_materials, sim%props, sim%istrength, pt%mat, pt%mass, pt%rho, pt%h, &
                                  pt%temp, pt%nbr_ptr, pt%nbr_list, pt%low_ptr, pt%low_pair, pt%low_other, &
                                  pt%pair_in, sim%control%eigenerosion_factor, pt%s, pt%p, pt%hist, &
                                  pt%fracture_work, pt%n_failed_last)
        if (pt%n_failed_last > 0) call fill_intact(sim%particles)
      end if
      call timer_stop(sim%timers, phase_particle_update)
      if (ierr == status_ok) then
        call timer_start(sim%timers, phase_sph_sums)
        call mid_step_state(n, pt%sig, pt%s, pt%p, pt%rho_old, pt%rho, pt%sig_mid, pt%rho_mid)
        if (pt%n_mirror > 0) call mirror_fill_stress(n + pt%n_imag, pt%n_mirror, pt%mirror_of, pt%rho_mid, &
                                                     pt%sig_mid)
        call pair_weights(ntot, pt%x_mid, pt%mass, pt%rho_mid, pt%wgt, pt%planar_area)
        ! the artificial stress of the mid-step stress, whose work the
        ! energy equation charges as that of the stress itself
        if (sim%control%sph_artificial_stress > 0.0_wp) &
          call artificial_stress(n, ntot, pt%n_imag, pt%sig_mid, sim%control%sph_artificial_stress, pt%art_stress)
        call sph_energy_rate(n, ntot, pt%n_imag, pt%x_mid, pt%v, pt%v_bar, pt%mass, pt%rho_mid, pt%h, pt%sig_mid, &
                             pt%wgt, pt%intact, sim%coupling%imag_work, sim%coupling%v_react, pt%nbr_ptr, &
                             pt%nbr_list, pt%low_ptr, pt%low_pair, &
                             pt%low_other, &
                             pt%pair_q, pt%pair_hg, pt%pair_force, pt%nbr_grad, sim%control%sph_artificial_stress, &
                             pt%art_stress, artificial_reference(sim%conversion%alpha_h), pt%pair_work, pt%de, &
                             pt%de_parts)
        if (total_active(sim%total)) &
          call total_energy_rate(sim%total, n, pt%sig_mid, pt%d, pt%rho, pt%rho_mid, pt%c, pt%v_bar, pt%mass, &
                                 sim%control%c_q, sim%control%c_l, pt%de, pt%de_parts)
        if (sim%control%particle_contact == particle_contact_riemann) &
          call riemann_contact_heat(n, pt%v_bar, pt%mass, pt%cnt_ptr, pt%cnt_list, pt%cnt_force, pt%cnt_vstar, &
                                    pt%de, pt%de_parts)
        call timer_stop(sim%timers, phase_sph_sums)
        call timer_start(sim%timers, phase_particle_update)
        call particle_energy_update(n, sim%n_materials, sim%props, sim%istrength, sim%ieos, pt%mat, dt_step, &
                                    sim%control%debris_ratio, pt%e_old, pt%de, pt%de_parts, pt%rho, pt%e, pt%p, pt%s, &
                                    pt%temp, pt%hist, pt%c, ierr, ifault)
        call timer_stop(sim%timers, phase_particle_update)
      end if
      ifault = -ifault
    end associate
  end subroutine update_particles

  !> Append a record (fsph_layouts hcol_*: time, cycle, dt, then the energy
  !> budget) to the history buffer, doubling its capacity when full (rare:
  !> the API drains it).
  subroutine record_history(sim)
    type(simulation_t), intent(inout) :: sim
    integer, parameter :: initial_capacity = 256
    integer :: n_bodies
    n_bodies = 0
    if (allocated(sim%continuum_of_body)) n_bodies = size(sim%continuum_of_body)
    if (.not. allocated(sim%history)) then
      allocate (sim%history(history_columns, initial_capacity))
      allocate (sim%body_history(body_columns, n_bodies, initial_capacity))
    end if
    if (sim%n_history == size(sim%history, 2)) then
      call grow(sim%history, 2*size(sim%history, 2))
      call grow(sim%body_history, size(sim%history, 2))
    end if
    sim%history_cycle = sim%cycle
    sim%n_history = sim%n_history + 1
    associate (record => sim%history(:, sim%n_history))
      record(hcol_time) = sim%time
      record(hcol_cycle) = real(sim%cycle, wp)
      record(hcol_dt) = sim%dt_last
      record(hcol_plane_impulse_z) = sim%plane_impulse_z
      record(energy_first:) = energy_budget(sim)
    end associate
    if (n_bodies > 0) sim%body_history(:, :, sim%n_history) = body_budget(sim, n_bodies)
    if (sim%gauges%n > 0) call record_gauges(sim, sim%n_history, sim%n_history)
  end subroutine record_history

  !> The gauges' rows of the current state (fsph_gauges: what each
  !> samples, then the rows of those on elements and on particles) at
  !> records first..last of the buffer, which grows with the history.
  subroutine record_gauges(sim, first, last)
    type(simulation_t), intent(inout) :: sim
    integer, intent(in) :: first, last
    integer :: k, src(sim%gauges%n), idx(sim%gauges%n)
    real(wp) :: w(3, sim%gauges%n)
    associate (g => sim%gauges, el => sim%elements, nd => sim%nodes, pt => sim%particles)
      if (.not. allocated(g%history)) allocate (g%history(gauge_columns, g%n, size(sim%history, 2)))
      if (size(g%history, 3) < size(sim%history, 2)) call grow(g%history, size(sim%history, 2))
      if (last < first) return
      call gauges_begin_record(g, src, idx, w, g%history(:, :, first))
      if (el%n > 0) then
        call gauges_find_elements(g, el%n, nd%n, el%conn, nd%x, src, idx, w)
        call gauges_element_rows(g, src, idx, w, nd%n, nd%x, nd%v, el%n, el%conn, el%p, el%q, el%s, el%eps_p, &
                                 el%temp, el%rho, el%e, el%hist, g%history(:, :, first))
      end if
      if (pt%n > 0) then
        call gauges_find_particles(g, pt%n, pt%x, pt%h, pt%body, src, idx)
        call gauges_particle_rows(g, src, idx, pt%n, pt%x, pt%v, pt%p, pt%s, pt%eps_p, pt%temp, pt%rho, pt%e, &
                                  pt%hist, g%history(:, :, first))
      end if
      do k = first + 1, last
        g%history(:, :, k) = g%history(:, :, first)
      end do
    end associate
  end subroutine record_gauges

  !> Locate the gauges (fsph_gauges: in the initial configuration, among
  !> the elements, then the particles) once the state is set up or
  !> restored, and give the records waiting in the history (set-up: the
  !> one at t = 0, where no cycle has run) their gauge rows of the current
  !> state.
  subroutine locate_gauges(sim)
    type(simulation_t), intent(inout) :: sim
    associate (g => sim%gauges, el => sim%elements, nd => sim%nodes, pt => sim%particles)
      if (g%n == 0) return
      call gauges_unlocate(g)
      if (el%n > 0) call gauges_locate_elements(g, el%n, nd%n, el%conn, el%body, nd%x0)
      if (pt%n > 0) call gauges_locate_particles(g, pt%n, pt%x0, pt%h, pt%body)
      if (allocated(sim%history)) call record_gauges(sim, 1, sim%n_history)
    end associate
  end subroutine locate_gauges

  !> After a conversion took the real particles from n_before: put them in
  !> spatial order when their count has grown enough (fsph_spatial), the
  !> gauges following their particles. Not in a run with total-Lagrangian
  !> particles, whose reference data are held by particle number.
  subroutine keep_spatial_order(sim, n_before)
    type(simulation_t), intent(inout) :: sim
    integer, intent(in) :: n_before
    integer, allocatable :: order(:)
    integer :: n
    n = sim%particles%n
    if (total_active(sim%total) .or. .not. renumber_due(n_before, n, sim%control%spatial_order_min)) return
    allocate (order(n))
    call spatial_order(n, sim%particles%x(:, 1:n), sim%particles%h(1:n), order)
    call permute_particles(sim, order)
    call gauges_renumber(sim%gauges, order)
  end subroutine keep_spatial_order

  !> After erosion or conversion removed elements: the material gauges
  !> find their elements again, or move to a particle (converted: the
  !> cycle converted elements) or to no material (fsph_gauges).
  subroutine follow_gauges(sim, converted)
    type(simulation_t), intent(inout) :: sim
    logical, intent(in) :: converted
    logical :: gone(sim%gauges%n)
    associate (el => sim%elements, nd => sim%nodes, pt => sim%particles)
      call gauges_refind(sim%gauges, el%n, nd%n, el%conn, el%body, nd%x0, gone)
      if (.not. any(gone)) return
      if (converted) then
        call gauges_switch(sim%gauges, gone, pt%n, pt%x, pt%h, pt%body, sim%time)
      else
        call gauges_lose(sim%gauges, gone, sim%time)
      end if
    end associate
  end subroutine follow_gauges

  !> Each body's books (body_columns of fsph_layouts, in their order):
  !> kinetic energy (half-step velocities) [J], internal energy [J] and
  !> axial momentum [N s] of its nodes (a node belongs to the body of the
  !> elements it joins), elements and particles, summed as energy_budget
  !> sums the whole; and its work books [J], each the mass-weighted sum of
  !> a material history row of its elements and particles (work_books).
  !> Serial, in index order: once per history record.
  function body_budget(sim, n_bodies) result(books)
    type(simulation_t), intent(in) :: sim
    integer, intent(in) :: n_bodies
    real(wp) :: books(body_columns, n_bodies)
    !> (book column, material history row [J/kg]) of each work book
    integer, parameter :: work_books(2, 4) = reshape([bcol_plastic_work, hist_plastic_work, &
                                                      bcol_viscous_work, hist_viscous_work, &
                                                      bcol_hourglass_work, hist_hourglass_work, &
                                                      bcol_contact_work, hist_contact_work], [2, 4])
    integer, allocatable :: node_body(:)
    integer :: a, e, i, b, k
    books = 0.0_wp
    associate (el => sim%elements, nd => sim%nodes, pt => sim%particles)
      allocate (node_body(nd%n))
      node_body = 0
      do e = 1, el%n
        do k = 1, 3
          node_body(el%conn(k, e)) = el%body(e)
        end do
      end do
      do a = 1, nd%n
        b = node_body(a)
        if (b < 1) cycle
        books(bcol_kinetic, b) = books(bcol_kinetic, b) + 0.5_wp*nd%mass(a)*(nd%v(1, a)**2 + nd%v(2, a)**2)
        books(bcol_momentum_z, b) = books(bcol_momentum_z, b) + nd%mass(a)*nd%v(2, a)
      end do
      do e = 1, el%n
        b = el%body(e)
        books(bcol_internal, b) = books(bcol_internal, b) + el%mass(e)*el%e(e)
        do k = 1, size(work_books, 2)
          books(work_books(1, k), b) = books(work_books(1, k), b) + el%mass(e)*el%hist(work_books(2, k), e)
        end do
      end do
      do i = 1, pt%n
        b = pt%body(i)
        books(bcol_kinetic, b) = books(bcol_kinetic, b) + 0.5_wp*pt%mass(i)*(pt%v(1, i)**2 + pt%v(2, i)**2)
        books(bcol_internal, b) = books(bcol_internal, b) + pt%mass(i)*pt%e(i)
        books(bcol_momentum_z, b) = books(bcol_momentum_z, b) + pt%mass(i)*pt%v(2, i)
        do k = 1, size(work_books, 2)
          books(work_books(1, k), b) = books(work_books(1, k), b) + pt%mass(i)*pt%hist(work_books(2, k), i)
        end do
      end do
    end associate
  end function body_budget

  !> The energy budget [J] in the order of the history columns from
  !> energy_first (fsph_layouts): kinetic (half-step velocities), internal,
  !> removed by the contact corrections, removed by erosion, removed by the
  !> rigid planes and the particles' axis wall, and their total, which the
  !> method conserves. The one place the total is summed.
  !>
  !> The total is centred in time. The velocities, and the kinetic energy
  !> the contact, the planes and erosion remove from them, stand at the
  !> half step t^(n+1/2); the internal energies at t^(n+1). Summed as they
  !> are, the total is off by half a step's energy flow (dt/2 times the
  !> rate at which kinetic energy becomes internal), an error of first
  !> order in dt that moves whenever the step changes (the last steps,
  !> shortened to land on the end time). The total therefore takes the
  !> full-step books as the mean of their values at the last step's two
  !> ends, sim%energy_full_before and now (docs/method.md, "The energy balance"): for
  !> the central difference the error is then of second order in dt. The
  !> books at the start are summed before the cycles a record may follow
  !> (solver_advance); where the latest cycle started without them (a run
  !> that stopped in an unforeseen cycle: a fault), the total takes the
  !> books of now at both ends.
  function energy_budget(sim) result(budget)
    type(simulation_t), intent(in) :: sim
    real(wp) :: budget(history_columns - energy_first + 1)
    real(wp) :: kinetic, internal, eroded, half_step, full_now, full_before
    kinetic = 0.0_wp
    associate (nd => sim%nodes, pt => sim%particles)
      if (nd%n > 0) kinetic = kinetic + 0.5_wp*sum(nd%mass*(nd%v(1, :)**2 + nd%v(2, :)**2))
      if (pt%n > 0) kinetic = kinetic + 0.5_wp*sum(pt%mass(1:pt%n)*(pt%v(1, 1:pt%n)**2 + pt%v(2, 1:pt%n)**2))
    end associate
    internal = internal_energy(sim)
    eroded = sim%erosion%internal + sim%erosion%kinetic
    half_step = kinetic + sim%contact%dissipated + sim%erosion%kinetic + sim%plane_dissipated
    full_now = internal + sim%erosion%internal
    full_before = sim%energy_full_before
    if (sim%energy_full_cycle < 0) full_before = full_now
    budget = [kinetic, internal, sim%contact%dissipated, eroded, sim%plane_dissipated, &
              half_step + 0.5_wp*(full_before + full_now)]
  end function energy_budget

  !> Internal energy of the elements and particles [J].
  function internal_energy(sim) result(internal)
    type(simulation_t), intent(in) :: sim
    real(wp) :: internal
    internal = 0.0_wp
    associate (el => sim%elements, pt => sim%particles)
      if (el%n > 0) internal = internal + sum(el%mass*el%e)
      if (pt%n > 0) internal = internal + sum(pt%mass(1:pt%n)*pt%e(1:pt%n))
    end associate
  end function internal_energy

  !> The energy books that stand at full steps [J]: the internal energy of
  !> the elements and particles and the internal energy erosion removed.
  function energy_full_step(sim) result(full)
    type(simulation_t), intent(in) :: sim
    real(wp) :: full
    full = internal_energy(sim) + sim%erosion%internal
  end function energy_full_step

end module fsph_solver
