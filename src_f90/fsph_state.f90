!> The types of a run's state: nodes, elements, particles, coupling,
!> conversion, contact, erosion, materials, boundaries, control parameters,
!> clock and gauges, gathered in simulation_t. The module holds no state: each run
!> is an instance owned by fsph_runs, and procedures receive the parts they
!> touch as arguments. Derived types never cross the f2py boundary;
!> fsph_api copies plain arrays in and out.
module fsph_state
  use fsph_kinds, only: wp
  use fsph_layouts, only: n_hist
  use fsph_neighbours, only: neighbour_work_t
  use fsph_arrays, only: grow
  use fsph_timers, only: phase_timers_t
  use fsph_threads, only: thread_governor_t
  use fsph_gauges, only: gauge_set_t
  use fsph_total, only: total_set_t
  implicit none
  private

  !> Nodes of the element mesh.
  type, public :: node_set_t
    integer :: n = 0
    real(wp), allocatable :: x(:, :)      !< position (r, z) [m]
    real(wp), allocatable :: x0(:, :)     !< initial position [m]
    real(wp), allocatable :: v(:, :)      !< velocity at the last half step [m/s]
    real(wp), allocatable :: v_start(:, :) !< velocity before this cycle's kick [m/s]
    real(wp), allocatable :: x_old(:, :)  !< position at the start of the cycle [m]
    real(wp), allocatable :: x_mid(:, :)  !< mid-step position [m]
    real(wp), allocatable :: f(:, :)      !< internal force [N]
    real(wp), allocatable :: mass(:)      !< lumped ring mass [kg]
    real(wp), allocatable :: mass_tie(:)  !< mass of particles tied to the node's edges [kg]
    real(wp), allocatable :: mass_total(:) !< mass + mass_tie: the mass the kick divides by [kg]
    real(wp), allocatable :: mass_eroded(:) !< mass inherited from deleted (eroded) elements [kg]
    logical, allocatable :: on_axis(:)    !< node lies on r = 0 (v_r held at 0)
    integer, allocatable :: on_axis_int(:) !< the same as 0/1, for checkpoints
    integer, allocatable :: corner_ptr(:) !< CSR into corner_list, size n+1
    integer, allocatable :: corner_list(:) !< element corners 3*(ie-1)+k of each node
  end type node_set_t

  !> Constant-strain triangles and their material-point state.
  type, public :: element_set_t
    integer :: n = 0
    integer, allocatable :: conn(:, :)    !< nodes, counter-clockwise (3, n)
    integer, allocatable :: mat(:)        !< material index
    integer, allocatable :: body(:)       !< body index
    integer, allocatable :: group(:)      !< conversion group (global index, 0: none)
    integer, allocatable :: id(:)         !< the element's index at set-up: kept when elements are removed
    real(wp), allocatable :: mass(:)      !< ring mass [kg]
    real(wp), allocatable :: rho(:)       !< density [kg/m^3]
    real(wp), allocatable :: s(:, :)      !< deviatoric stress rr, zz, rz, tt [Pa]
    real(wp), allocatable :: p(:)         !< pressure [Pa]
    real(wp), allocatable :: q(:)         !< artificial viscous pressure [Pa]
    real(wp), allocatable :: eps_p(:)     !< equivalent plastic strain [-]
    real(wp), allocatable :: e(:)         !< specific internal energy [J/kg]
    real(wp), allocatable :: temp(:)      !< temperature [K]
    real(wp), allocatable :: hist(:, :)   !< material history (n_hist, n): damage, ... (fsph_material)
    real(wp), allocatable :: c(:)         !< sound speed [m/s]
    real(wp), allocatable :: area(:), rbar(:), volume(:), lmin(:) !< geometry [m^2, m, m^3, m]
    real(wp), allocatable :: d(:, :)      !< strain rate of the last step [1/s]
    real(wp), allocatable :: spin(:)      !< spin of the last step [1/s]
    real(wp), allocatable :: fc(:, :, :)  !< corner forces (2, 3, n) [N]
    real(wp), allocatable :: cos_limit(:) !< cosine of the element's conversion angle (fsph_convert)
  end type element_set_t

  !> SPH particles (full-ring masses) and their material-point state.
  !> Entries 1..n are real particles; entries n+1..n+n_imag are the
  !> imaginary particles of the elements (Xiao et al. 2012 eq 5) and entries
  !> n+n_imag+1..n+n_imag+n_mirror the mirror images of particles across
  !> rigid planes (fsph_mirror), refilled every step: they enter the SPH
  !> sums of real particles as neighbours only. Arrays are sized for
  !> `capacity` entries.
  type, public :: particle_set_t
    integer :: n = 0
    integer :: n_imag = 0
    integer :: n_mirror = 0
    integer :: capacity = 0
    integer :: n_debris = 0               !< debris particles (density held, no stress) after the last cycle
    integer, allocatable :: imag_elem(:)  !< element of each imaginary entry (index - n)
    integer, allocatable :: continuum(:)  !< SPH sums only join entries of one continuum
    integer, allocatable :: tie_a(:), tie_b(:) !< nodes of the edge a particle is tied to (0: free)
    real(wp), allocatable :: tie_xi(:)    !< position of the tie along the edge a -> b [-]
    integer, allocatable :: assoc(:, :)   !< coupling edges associated with the particle (2, n)
    real(wp), allocatable :: x(:, :)      !< position (r, z) [m]
    real(wp), allocatable :: x0(:, :)     !< initial position [m]
    real(wp), allocatable :: x_old(:, :), x_mid(:, :) !< start-of-cycle and mid-step positions [m]
    real(wp), allocatable :: v(:, :)      !< velocity at the last half step [m/s]
    real(wp), allocatable :: v_bar(:, :)  !< mean of the velocities before and after the kick [m/s]
    real(wp), allocatable :: acc(:, :)    !< acceleration [m/s^2]
    real(wp), allocatable :: acc_imag(:, :) !< acceleration from imaginary neighbours [m/s^2]
    real(wp), allocatable :: mass(:)      !< ring mass [kg]
    real(wp), allocatable :: h(:)         !< smoothing length [m]
    real(wp), allocatable :: radius(:)    !< particle radius (contact, planes) [m]
    integer, allocatable :: mat(:), body(:)
    !> the particle's number as it was made (set-up, then conversion, in
    !> order): kept when the particles are renumbered in spatial order
    integer, allocatable :: id(:)
    real(wp), allocatable :: rho(:)       !< density [kg/m^3]
    real(wp), allocatable :: s(:, :)      !< deviatoric stress rr, zz, rz, tt [Pa]
    real(wp), allocatable :: sig(:, :)    !< total stress s - p I [Pa]
    real(wp), allocatable :: p(:)         !< pressure [Pa]
    real(wp), allocatable :: eps_p(:), e(:), temp(:), c(:) !< [-], [J/kg], [K], [m/s]
    real(wp), allocatable :: hist(:, :)   !< material history (n_hist, capacity): damage, ...
    real(wp), allocatable :: drho(:), de(:), d(:, :), spin(:) !< rates of the last step
    real(wp), allocatable :: de_parts(:, :) !< viscous, hourglass and contact parts of de (3, capacity) [W/kg]
    real(wp), allocatable :: grad_v(:, :) !< velocity gradient of the last step (dv_r/dr, dv_z/dr, dv_r/dz, dv_z/dz) [1/s]
    real(wp), allocatable :: switch(:)    !< compression switch of the pairwise viscosity [-]
    integer, allocatable :: mirror_of(:)  !< particle of each mirror image (index - n - n_imag)
    integer, allocatable :: mirror_plane(:) !< plane of each mirror image
    real(wp), allocatable :: e_old(:), rho_old(:), rho_mid(:), sig_mid(:, :) !< cycle work arrays
    ! neighbour search (fsph_neighbours): its work arrays, same-body and contact lists
    type(neighbour_work_t) :: search
    ! lists kept across cycles (fsph_verlet)
    logical :: lists_valid = .false.      !< the lists may be reused (false forces a rebuild)
    !> the lists' books came from a checkpoint without their entries: the next
    !> cycle builds the entries and keeps the books (fsph_verlet restored_skin)
    logical :: lists_pending = .false.
    real(wp) :: skin = 0.0_wp             !< skin of the current lists [m]
    integer :: n_listed = 0               !< real particles when the lists were built
    integer :: n_rebuilds = 0             !< list builds so far
    real(wp) :: skin_scale = 1.0_wp       !< the skin over the deck's (fsph_verlet adapt_skin) [-]
    integer :: list_uses = 0              !< cycles the current lists have served
    real(wp), allocatable :: x_listed(:, :) !< real particle positions at the build (2, capacity) [m]
    real(wp), allocatable :: elem_listed(:) !< h of each element at the build (ne) [m]
    real(wp), allocatable :: node_listed(:, :) !< node positions at the build (2, nodes) [m]
    integer, allocatable :: coupled_nodes(:) !< the nodes of the elements of coupled bodies at the build
    integer :: n_coupled_nodes = 0
    integer, allocatable :: nbr_ptr(:), nbr_list(:), cnt_ptr(:), cnt_list(:)
    integer, allocatable :: half_end(:)   !< end (exclusive) of the half entries of each row
    integer, allocatable :: low_ptr(:), low_pair(:), low_other(:) !< low lists: partner and pair entry
    real(wp), allocatable :: pair_q(:)    !< viscous pressure per neighbour entry [Pa]
    real(wp), allocatable :: pair_force(:, :) !< acceleration per unit neighbour mass per entry [m/(kg s^2)]
    real(wp), allocatable :: pair_hg(:, :) !< hourglass term per entry [kg/(m^4 s^2)]
    real(wp), allocatable :: pair_work(:, :) !< partner's work rate per entry and unit mass, its viscous and
                                             !< hourglass parts (3, entries) [m^2/(kg s^3)]
    logical, allocatable :: pair_in(:)    !< entry within the kernel support at the start of the cycle
    real(wp), allocatable :: rate_sums(:, :) !< work: partial rate sums (9, capacity)
    real(wp), allocatable :: contact_excess(:) !< work: particle contact stiffness times excess filling
    real(wp), allocatable :: cnt_force(:, :) !< Riemann contact: acceleration per unit partner mass per contact entry [m/(kg s^2)]
    real(wp), allocatable :: acc_axis(:)  !< work: axial acceleration of the axis images' stress terms [m/s^2]
    real(wp), allocatable :: cnt_vstar(:, :) !< Riemann contact: interface velocity u* n per contact entry [m/s]
    real(wp), allocatable :: cnt_normal(:, :) !< Riemann contact: each particle's contact normal [1/m]
    real(wp), allocatable :: fracture_work(:, :) !< eigenerosion work space (3, n)
    real(wp), allocatable :: intact(:)   !< per entry: 1 intact, 0 failed (fsph_eigenerosion) [-]
    integer :: n_failed_last = 0         !< particles that failed by eigenerosion in the last cycle
    logical, allocatable :: cnt_in(:)     !< Riemann contact: entry within the kernel support at the start of the cycle
    real(wp), allocatable :: nbr_grad(:, :) !< kernel gradient per neighbour entry at mid-step [1/m^3]
    real(wp), allocatable :: wgt(:)       !< work: stress weight 1/(4 pi^2 r rho^2) per entry [m^5/kg^2]
    real(wp), allocatable :: planar_area(:) !< work: planar area m/(2 pi r rho) per entry [m^2]
    !> work: artificial stress R (rr, zz, rz) per entry, of the stress the
    !> pair sums use at that stage (fsph_sph artificial_stress) [Pa]
    real(wp), allocatable :: art_stress(:, :)
  end type particle_set_t

  !> Coupling-interface edges of the element region: node pairs oriented as
  !> in their element (element region on the left), with the particles
  !> associated with them (Xiao et al. 2012 eqs 6-8).
  type, public :: coupling_t
    integer :: n_edges = 0
    integer, allocatable :: edge(:, :)    !< (2, n_edges) node pairs
    integer, allocatable :: edge_cont(:)  !< work: continuum loading each edge this cycle
    real(wp), allocatable :: loose_z(:), ring(:) !< work: per continuum, unassociated axial force, edge ring area
    !> work, per particle, set at each kick (fsph_coupling reaction_velocities):
    !> how its pairs with imaginary particles do work (fsph_sph imag_work_*)
    integer, allocatable :: imag_work(:)
    !> work, per particle: the velocity of the point of its coupling edges
    !> that takes its reaction, at the half step (1:2) and over the kick (3:4) [m/s]
    real(wp), allocatable :: v_react(:, :)
  end type coupling_t

  !> Conversion of elements to particles (Xiao et al. 2012 section 2.3).
  type, public :: conversion_t
    logical :: enabled = .false.
    integer :: criterion = 1              !< 1 min angle, 2 plastic strain, 3 equivalent stress
    real(wp) :: theta_c = 0.5235987755982988_wp !< critical minimum angle [rad] (30 deg)
    real(wp) :: theta_relative = 0.75_wp  !< or this fraction of the initial minimum angle, if lower [-]
    real(wp) :: eps_c = 0.4_wp            !< critical equivalent plastic strain [-]
    real(wp) :: sigma_c = 0.0_wp          !< critical equivalent stress [Pa]
    real(wp) :: kappa = 1.5_wp            !< group size factor of eq 9 [-]
    real(wp) :: alpha_h = 1.3_wp          !< smoothing-length factor h = alpha_h sqrt(A) [-]
    integer :: n_groups = 0
    integer :: n_converted = 0            !< elements converted so far
    integer :: n_events = 0               !< cycles in which a conversion happened
    real(wp) :: heat = 0.0_wp             !< kinetic energy turned into heat at conversion [J]
    logical, allocatable :: hit(:)        !< work: elements meeting the criterion this cycle
  end type conversion_t

  !> Grid of the contact buckets (fsph_contact), rebuilt every cycle.
  type, public :: contact_grid_t
    integer :: nr = 0, nz = 0             !< cells along r and z
    logical :: ok = .false.               !< the grid holds every segment
    real(wp) :: origin(2) = 0.0_wp        !< lower corner (r, z) [m]
    real(wp) :: cell = 1.0_wp             !< cell side [m]
  end type contact_grid_t

  !> Contact between bodies (Xiao et al. 2012 section 2.2): the element-region
  !> surfaces (segments and their nodes), rebuilt at set-up and after every
  !> conversion, and the books of the corrections.
  type, public :: contact_t
    logical :: enabled = .false.
    integer :: n_passes = 3               !< correction passes per cycle (Hu et al. 2013: 3-5)
    real(wp) :: friction = 0.0_wp         !< Coulomb friction coefficient [-]
    logical :: own_particles = .true.     !< untied particles also against their own body's surface
    real(wp) :: dissipated = 0.0_wp       !< kinetic energy removed by the corrections [J]
    integer :: n_active = 0               !< contact pairs corrected in the last cycle
    integer :: n_seg = 0
    logical :: several_continua = .false. !< the surface belongs to more than one continuum
    integer, allocatable :: seg(:, :)     !< (2, n_seg) surface edges, element region on the left
    integer, allocatable :: seg_cont(:)   !< continuum of each segment's body
    integer, allocatable :: seg_elem(:)   !< the element each segment bounds
    integer :: n_snode = 0
    integer, allocatable :: snode(:)      !< surface nodes (slaves of the slide lines)
    integer, allocatable :: snode_cont(:) !< continuum of each surface node
    integer, allocatable :: cell_start(:), cell_items(:), fill(:) !< work: segment buckets
    type(contact_grid_t) :: grid          !< the buckets' grid
    real(wp), allocatable :: v_node0(:, :), v_part0(:, :) !< work: velocities before the corrections [m/s]
  end type contact_t

  !> Element erosion (the FEM baseline of Hu et al. 2013): an element whose
  !> largest principal strain reaches the limit is deleted. Its mass stays
  !> on its nodes while they belong to a remaining element; a node left
  !> without elements is removed. Everything removed is booked.
  type, public :: erosion_t
    logical :: enabled = .false.
    real(wp) :: strain_limit = 1.5_wp     !< largest principal (logarithmic) strain [-]
    integer :: n_eroded = 0               !< elements deleted so far
    real(wp) :: element_mass = 0.0_wp     !< mass of the deleted elements [kg]
    real(wp) :: internal = 0.0_wp         !< internal energy of the deleted elements [J]
    real(wp) :: node_mass = 0.0_wp        !< mass of the nodes removed [kg]
    real(wp) :: kinetic = 0.0_wp          !< kinetic energy of the nodes removed [J]
    real(wp) :: momentum(2) = 0.0_wp      !< momentum (r, z) of the nodes removed [kg m/s]
    real(wp), allocatable :: strain(:)    !< work: largest principal strain of each element [-]
  end type erosion_t

  !> Rigid, fixed, frictionless plane: points x with (x - point).normal >= 0
  !> are outside it.
  type, public :: rigid_plane_t
    real(wp) :: point(2) = 0.0_wp     !< a point of the plane (r, z) [m]
    real(wp) :: normal(2) = [0.0_wp, 1.0_wp] !< unit normal towards the bodies
  end type rigid_plane_t

  !> Numerical parameters of the cycle.
  type, public :: control_t
    real(wp) :: dt_safety = 0.6_wp    !< time-step safety factor s [-]
    real(wp) :: c_q = 1.5_wp          !< quadratic viscosity coefficient [-]
    real(wp) :: c_l = 0.06_wp         !< linear viscosity coefficient [-]
    real(wp) :: dt_floor_ratio = 1.0e-3_wp !< stop when dt < ratio * initial dt [-]
    real(wp) :: dt_drop_ratio = 0.0_wp !< stop when dt < ratio * previous stable dt (0: off) [-]
    integer :: history_every = 10     !< cycles between time-history records
    real(wp) :: sph_c_q = 1.0_wp      !< SPH quadratic viscosity coefficient [-]
    real(wp) :: sph_c_l = 0.2_wp      !< SPH linear viscosity coefficient [-]
    real(wp) :: sph_c_hg = 0.1_wp     !< SPH hourglass viscosity coefficient [-]
    !> coefficient eps of the SPH artificial stress (fsph_sph; 0: off) [-]
    real(wp) :: sph_artificial_stress = 0.0_wp
    integer :: particle_contact = 1   !< contact between particle bodies (fsph_layouts particle_contact_*)
    real(wp) :: contact_penalty = 0.03_wp !< particle contact: approach fraction pushed back per step [-]
    real(wp) :: contact_touch = 0.2367_wp !< particle contact: other-body filling C at touching [-]
    real(wp) :: contact_slope = 0.45_wp  !< particle contact: dC per spacing of approach at touching [-]
    real(wp) :: debris_ratio = 0.1_wp    !< particles below this fraction of the reference density are debris [-]
    real(wp) :: neighbour_skin = 0.1_wp  !< skin of the neighbour lists, fraction of the smallest support [-]
    real(wp) :: eigenerosion_factor = 1.0_wp !< geometric factor lambda of the eigenerosion release rate [-]
    integer :: spatial_order_min = 4096  !< fewest real particles renumbered in spatial order (0: never) [-]
  end type control_t

  type, public :: simulation_t
    type(node_set_t) :: nodes
    type(element_set_t) :: elements
    type(particle_set_t) :: particles
    type(coupling_t) :: coupling
    type(conversion_t) :: conversion
    type(contact_t) :: contact
    type(erosion_t) :: erosion
    integer, allocatable :: continuum_of_body(:) !< bodies joined into one continuum share it
    logical, allocatable :: body_coupled(:) !< the body's elements act as imaginary particles
    integer :: n_materials = 0
    real(wp), allocatable :: props(:, :)  !< (n_props, n_materials)
    integer, allocatable :: istrength(:), ieos(:)
    integer :: n_planes = 0
    type(rigid_plane_t), allocatable :: planes(:)
    real(wp) :: plane_dissipated = 0.0_wp !< kinetic energy removed by the rigid planes and the axis wall [J]
    real(wp) :: plane_impulse_z = 0.0_wp  !< axial impulse of the rigid planes on the bodies since t = 0 [N s]
    !> internal energy of the elements and particles and that erosion removed, at the start of
    !> cycle energy_full_cycle + 1, with the heat of that cycle's conversions [J] (fsph_solver
    !> energy_budget; summed only before the cycles a history record may follow)
    real(wp) :: energy_full_before = 0.0_wp
    !> the cycle count at whose start energy_full_before was summed; -1 when the latest cycle
    !> started without summing it (a record after it takes the books of now at both ends)
    integer :: energy_full_cycle = 0
    type(control_t) :: control
    logical :: ready = .false.
    real(wp) :: time = 0.0_wp             !< [s]
    integer :: cycle = 0
    real(wp) :: dt = 0.0_wp               !< stable step for the next cycle (with safety) [s]
    real(wp) :: dt_last = 0.0_wp          !< step taken by the last cycle [s]
    real(wp) :: dt_initial = 0.0_wp       !< stable step at set-up [s]
    real(wp) :: dt_previous = 0.0_wp      !< stable step of the previous cycle [s]
    integer :: dt_element = 0             !< element controlling dt (0: a particle does)
    integer :: dt_particle = 0            !< particle controlling dt (0: an element does)
    integer :: n_history = 0              !< records waiting in history
    integer :: history_cycle = -1         !< cycle of the last record
    real(wp), allocatable :: history(:, :) !< (history_columns, capacity), drained by the API
    !> each body's books at the same records: (body_columns, bodies, capacity), fsph_solver body_budget
    real(wp), allocatable :: body_history(:, :, :)
    !> the gauges (&gauge; fsph_gauges) and their records at the same records; not part of a
    !> checkpoint: a restart locates them again from the deck
    type(gauge_set_t) :: gauges
    type(total_set_t) :: total            !< total-Lagrangian particle bodies (fsph_total)
    type(phase_timers_t) :: timers        !< wall time of each phase of the cycle
    type(thread_governor_t) :: governor   !< OpenMP threads of each cycle (fsph_threads)
  end type simulation_t

  public :: state_allocate, state_allocate_particles, state_grow_particles

contains

  !> Allocate every node and element array for nn nodes and ne elements,
  !> and room for coupling edges (an element region may get them: every
  !> state array of a checkpoint then has its rows from set-up on).
  subroutine state_allocate(sim, nn, ne)
    type(simulation_t), intent(inout) :: sim
    integer, intent(in) :: nn, ne
    integer :: k
    if (.not. allocated(sim%coupling%edge)) allocate (sim%coupling%edge(2, 64))
    sim%nodes = node_set_t()
    sim%elements = element_set_t()
    sim%ready = .false.
    sim%nodes%n = nn
    allocate (sim%nodes%x(2, nn), sim%nodes%x0(2, nn), sim%nodes%v(2, nn), sim%nodes%f(2, nn), &
              sim%nodes%x_old(2, nn), sim%nodes%x_mid(2, nn), sim%nodes%mass(nn), sim%nodes%v_start(2, nn), &
              sim%nodes%on_axis(nn), sim%nodes%corner_ptr(nn + 1), sim%nodes%mass_tie(nn), &
              sim%nodes%mass_total(nn), sim%nodes%mass_eroded(nn))
    sim%nodes%f = 0.0_wp
    sim%nodes%mass_tie = 0.0_wp
    sim%nodes%mass_eroded = 0.0_wp
    sim%elements%n = ne
    associate (el => sim%elements)
      allocate (el%conn(3, ne), el%mat(ne), el%body(ne), el%group(ne), el%id(ne), el%mass(ne), el%rho(ne), el%s(4, ne), &
                el%p(ne), el%q(ne), el%eps_p(ne), el%e(ne), el%temp(ne), el%c(ne), el%area(ne), &
                el%rbar(ne), el%volume(ne), el%lmin(ne), el%d(4, ne), el%spin(ne), el%fc(2, 3, ne), &
                el%hist(n_hist, ne))
      el%hist = 0.0_wp
      el%group = 0      ! no conversion group until assign_groups (checkpoints read it)
      el%id = [(k, k = 1, ne)]
    end associate
  end subroutine state_allocate

  !> Allocate every particle array for np real particles and room for
  !> `capacity` entries in all (real and imaginary).
  subroutine state_allocate_particles(sim, np, capacity)
    type(simulation_t), intent(inout) :: sim
    integer, intent(in) :: np, capacity
    integer :: cap, i
    cap = max(capacity, np, 1)
    sim%particles = particle_set_t()
    sim%ready = .false.
    sim%particles%n = np
    sim%particles%capacity = cap
    associate (pt => sim%particles)
      allocate (pt%x(2, cap), pt%x0(2, cap), pt%x_old(2, cap), pt%x_mid(2, cap), pt%v(2, cap), &
                pt%v_bar(2, cap), pt%acc(2, cap), pt%acc_imag(2, cap), pt%mass(cap), pt%h(cap), pt%radius(cap), &
                pt%mat(cap), pt%body(cap), pt%rho(cap), pt%s(4, cap), pt%sig(4, cap), pt%p(cap), &
                pt%eps_p(cap), pt%e(cap), pt%temp(cap), pt%c(cap), pt%drho(cap), pt%de(cap), pt%de_parts(3, cap), &
                pt%d(4, cap), pt%spin(cap), pt%e_old(cap), pt%rho_old(cap), pt%rho_mid(cap), &
                pt%sig_mid(4, cap), pt%nbr_ptr(cap + 1), pt%cnt_ptr(cap + 1), pt%imag_elem(cap), &
                pt%continuum(cap), pt%tie_a(cap), pt%tie_b(cap), pt%tie_xi(cap), pt%assoc(2, cap), &
                pt%hist(n_hist, cap), pt%wgt(cap), pt%planar_area(cap), pt%half_end(cap), &
                pt%low_ptr(cap + 1), pt%rate_sums(9, cap), pt%contact_excess(cap), pt%grad_v(4, cap), &
                pt%switch(cap), pt%mirror_of(cap), pt%mirror_plane(cap), pt%id(cap))
      pt%grad_v = 0.0_wp; pt%switch = 0.0_wp; pt%mirror_of = 0; pt%mirror_plane = 0
      pt%hist = 0.0_wp
      pt%wgt = 0.0_wp; pt%planar_area = 0.0_wp
      pt%x = 0.0_wp; pt%x0 = 0.0_wp; pt%x_old = 0.0_wp; pt%x_mid = 0.0_wp; pt%v = 0.0_wp
      pt%v_bar = 0.0_wp; pt%acc = 0.0_wp; pt%acc_imag = 0.0_wp; pt%mass = 0.0_wp; pt%h = 0.0_wp; pt%radius = 0.0_wp
      pt%mat = 0; pt%body = 0; pt%rho = 0.0_wp; pt%s = 0.0_wp; pt%sig = 0.0_wp; pt%p = 0.0_wp
      pt%eps_p = 0.0_wp; pt%e = 0.0_wp; pt%temp = 0.0_wp; pt%c = 0.0_wp; pt%drho = 0.0_wp
      pt%de = 0.0_wp; pt%de_parts = 0.0_wp; pt%d = 0.0_wp; pt%spin = 0.0_wp; pt%e_old = 0.0_wp; pt%rho_old = 0.0_wp
      pt%rho_mid = 0.0_wp; pt%sig_mid = 0.0_wp; pt%imag_elem = 0; pt%continuum = 0
      pt%tie_a = 0; pt%tie_b = 0; pt%tie_xi = 0.0_wp; pt%assoc = 0
      pt%id = [(i, i = 1, cap)]
    end associate
  end subroutine state_allocate_particles

  !> Make room for `capacity` particle entries (real, imaginary and
  !> mirror), keeping every array's contents.
  subroutine state_grow_particles(pt, capacity)
    type(particle_set_t), intent(inout) :: pt
    integer, intent(in) :: capacity
    integer :: cap
    block
      if (capacity <= pt%capacity) return
      cap = capacity
      pt%capacity = cap
      call grow(pt%x, cap); call grow(pt%x0, cap); call grow(pt%x_old, cap); call grow(pt%x_mid, cap)
      call grow(pt%v, cap); call grow(pt%v_bar, cap); call grow(pt%acc, cap); call grow(pt%acc_imag, cap)
      call grow(pt%mass, cap); call grow(pt%h, cap); call grow(pt%radius, cap); call grow(pt%mat, cap)
      call grow(pt%body, cap); call grow(pt%rho, cap); call grow(pt%s, cap); call grow(pt%sig, cap)
      call grow(pt%p, cap); call grow(pt%eps_p, cap); call grow(pt%e, cap); call grow(pt%temp, cap)
      call grow(pt%c, cap); call grow(pt%drho, cap); call grow(pt%de, cap); call grow(pt%d, cap)
      call grow(pt%de_parts, cap)
      call grow(pt%spin, cap); call grow(pt%e_old, cap); call grow(pt%rho_old, cap); call grow(pt%rho_mid, cap)
      call grow(pt%sig_mid, cap); call grow(pt%nbr_ptr, cap + 1); call grow(pt%cnt_ptr, cap + 1)
      call grow(pt%imag_elem, cap); call grow(pt%continuum, cap); call grow(pt%tie_a, cap)
      call grow(pt%tie_b, cap); call grow(pt%tie_xi, cap); call grow(pt%assoc, cap); call grow(pt%hist, cap)
      call grow(pt%wgt, cap); call grow(pt%planar_area, cap); call grow(pt%half_end, cap)
      call grow(pt%low_ptr, cap + 1); call grow(pt%rate_sums, cap); call grow(pt%contact_excess, cap)
      call grow(pt%grad_v, cap); call grow(pt%switch, cap); call grow(pt%mirror_of, cap)
      call grow(pt%mirror_plane, cap); call grow(pt%id, cap)
      if (allocated(pt%x_listed)) call grow(pt%x_listed, cap)
    end block
  end subroutine state_grow_particles

end module fsph_state
