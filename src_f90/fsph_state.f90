!> The one simulation state: nodes, elements, materials, boundaries, control
!> parameters and clock. Derived types live here and never cross the f2py
!> boundary; fsph_api copies plain arrays in and out.
module fsph_state
  use fsph_kinds, only: wp
  implicit none
  private

  !> Nodes of the element mesh.
  type, public :: node_set_t
    integer :: n = 0
    real(wp), allocatable :: x(:, :)      !< position (r, z) [m]
    real(wp), allocatable :: x0(:, :)     !< initial position [m]
    real(wp), allocatable :: v(:, :)      !< velocity at the last half step [m/s]
    real(wp), allocatable :: x_old(:, :)  !< position at the start of the cycle [m]
    real(wp), allocatable :: x_mid(:, :)  !< mid-step position [m]
    real(wp), allocatable :: f(:, :)      !< internal force [N]
    real(wp), allocatable :: mass(:)      !< lumped ring mass [kg]
    logical, allocatable :: on_axis(:)    !< node lies on r = 0 (v_r held at 0)
    integer, allocatable :: corner_ptr(:) !< CSR into corner_list, size n+1
    integer, allocatable :: corner_list(:) !< element corners 3*(ie-1)+k of each node
  end type node_set_t

  !> Constant-strain triangles and their material-point state.
  type, public :: element_set_t
    integer :: n = 0
    integer, allocatable :: conn(:, :)    !< nodes, counter-clockwise (3, n)
    integer, allocatable :: mat(:)        !< material index
    integer, allocatable :: body(:)       !< body index
    real(wp), allocatable :: mass(:)      !< ring mass [kg]
    real(wp), allocatable :: rho(:)       !< density [kg/m^3]
    real(wp), allocatable :: s(:, :)      !< deviatoric stress rr, zz, rz, tt [Pa]
    real(wp), allocatable :: p(:)         !< pressure [Pa]
    real(wp), allocatable :: q(:)         !< artificial viscous pressure [Pa]
    real(wp), allocatable :: eps_p(:)     !< equivalent plastic strain [-]
    real(wp), allocatable :: e(:)         !< specific internal energy [J/kg]
    real(wp), allocatable :: temp(:)      !< temperature [K]
    real(wp), allocatable :: c(:)         !< sound speed [m/s]
    real(wp), allocatable :: area(:), rbar(:), volume(:), lmin(:) !< geometry [m^2, m, m^3, m]
    real(wp), allocatable :: d(:, :)      !< strain rate of the last step [1/s]
    real(wp), allocatable :: spin(:)      !< spin of the last step [1/s]
    real(wp), allocatable :: fc(:, :, :)  !< corner forces (2, 3, n) [N]
  end type element_set_t

  !> SPH particles (full-ring masses) and their material-point state.
  type, public :: particle_set_t
    integer :: n = 0
    real(wp), allocatable :: x(:, :)      !< position (r, z) [m]
    real(wp), allocatable :: x0(:, :)     !< initial position [m]
    real(wp), allocatable :: x_old(:, :), x_mid(:, :) !< start-of-cycle and mid-step positions [m]
    real(wp), allocatable :: v(:, :)      !< velocity at the last half step [m/s]
    real(wp), allocatable :: v_bar(:, :)  !< mean of the velocities before and after the kick [m/s]
    real(wp), allocatable :: acc(:, :)    !< acceleration [m/s^2]
    real(wp), allocatable :: mass(:)      !< ring mass [kg]
    real(wp), allocatable :: h(:)         !< smoothing length [m]
    real(wp), allocatable :: radius(:)    !< particle radius (contact, planes) [m]
    integer, allocatable :: mat(:), body(:)
    real(wp), allocatable :: rho(:)       !< density [kg/m^3]
    real(wp), allocatable :: s(:, :)      !< deviatoric stress rr, zz, rz, tt [Pa]
    real(wp), allocatable :: sig(:, :)    !< total stress s - p I [Pa]
    real(wp), allocatable :: p(:)         !< pressure [Pa]
    real(wp), allocatable :: eps_p(:), e(:), temp(:), c(:) !< [-], [J/kg], [K], [m/s]
    real(wp), allocatable :: drho(:), de(:), d(:, :), spin(:) !< rates of the last step
    real(wp), allocatable :: e_old(:), rho_old(:), rho_mid(:), sig_mid(:, :) !< cycle work arrays
    ! neighbour search (fsph_neighbors): cells, same-body and contact lists
    integer, allocatable :: cell_of(:), cell_start(:), cell_items(:)
    integer, allocatable :: nbr_ptr(:), nbr_list(:), cnt_ptr(:), cnt_list(:)
    real(wp), allocatable :: pair_q(:)    !< viscous pressure per neighbour entry [Pa]
  end type particle_set_t

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
    integer :: history_every = 10     !< cycles between time-history records
    real(wp) :: sph_c_q = 1.0_wp      !< SPH quadratic viscosity coefficient [-]
    real(wp) :: sph_c_l = 0.2_wp      !< SPH linear viscosity coefficient [-]
    real(wp) :: contact_penalty = 0.1_wp !< particle contact: overlap fraction removed per step [-]
  end type control_t

  !> Columns of a time-history record.
  integer, parameter, public :: history_columns = 5 !< time [s], cycle, dt [s], kinetic [J], internal [J]

  type, public :: simulation_t
    type(node_set_t) :: nodes
    type(element_set_t) :: elements
    type(particle_set_t) :: particles
    integer :: n_materials = 0
    real(wp), allocatable :: props(:, :)  !< (n_props, n_materials)
    integer, allocatable :: istrength(:), ieos(:)
    integer :: n_planes = 0
    type(rigid_plane_t), allocatable :: planes(:)
    type(control_t) :: control
    logical :: ready = .false.
    real(wp) :: time = 0.0_wp             !< [s]
    integer :: cycle = 0
    real(wp) :: dt = 0.0_wp               !< stable step for the next cycle (with safety) [s]
    real(wp) :: dt_last = 0.0_wp          !< step taken by the last cycle [s]
    real(wp) :: dt_initial = 0.0_wp       !< stable step at set-up [s]
    integer :: dt_element = 0             !< element controlling dt (0: a particle does)
    integer :: dt_particle = 0            !< particle controlling dt (0: an element does)
    integer :: n_history = 0              !< records waiting in history
    integer :: history_cycle = -1         !< cycle of the last record
    real(wp), allocatable :: history(:, :) !< (history_columns, capacity), drained by the API
  end type simulation_t

  !> The simulation state of this process.
  type(simulation_t), public, save :: sim

  public :: state_reset, state_allocate, state_allocate_particles

contains

  !> Allocate every node and element array for nn nodes and ne elements.
  subroutine state_allocate(nn, ne)
    integer, intent(in) :: nn, ne
    sim%nodes = node_set_t()
    sim%elements = element_set_t()
    sim%ready = .false.
    sim%nodes%n = nn
    allocate (sim%nodes%x(2, nn), sim%nodes%x0(2, nn), sim%nodes%v(2, nn), sim%nodes%f(2, nn), &
              sim%nodes%x_old(2, nn), sim%nodes%x_mid(2, nn), sim%nodes%mass(nn), &
              sim%nodes%on_axis(nn), sim%nodes%corner_ptr(nn + 1))
    sim%nodes%f = 0.0_wp
    sim%elements%n = ne
    associate (el => sim%elements)
      allocate (el%conn(3, ne), el%mat(ne), el%body(ne), el%mass(ne), el%rho(ne), el%s(4, ne), &
                el%p(ne), el%q(ne), el%eps_p(ne), el%e(ne), el%temp(ne), el%c(ne), el%area(ne), &
                el%rbar(ne), el%volume(ne), el%lmin(ne), el%d(4, ne), el%spin(ne), el%fc(2, 3, ne))
    end associate
  end subroutine state_allocate

  !> Forget everything: deallocate and return to defaults.
  subroutine state_reset()
    sim = simulation_t()
  end subroutine state_reset

  !> Allocate every particle array for np particles.
  subroutine state_allocate_particles(np)
    integer, intent(in) :: np
    sim%particles = particle_set_t()
    sim%ready = .false.
    sim%particles%n = np
    associate (pt => sim%particles)
      allocate (pt%x(2, np), pt%x0(2, np), pt%x_old(2, np), pt%x_mid(2, np), pt%v(2, np), pt%v_bar(2, np), &
                pt%acc(2, np), pt%mass(np), pt%h(np), pt%radius(np), pt%mat(np), pt%body(np), &
                pt%rho(np), pt%s(4, np), pt%sig(4, np), pt%p(np), pt%eps_p(np), pt%e(np), &
                pt%temp(np), pt%c(np), pt%drho(np), pt%de(np), pt%d(4, np), pt%spin(np), &
                pt%e_old(np), pt%rho_old(np), pt%rho_mid(np), pt%sig_mid(4, np), &
                pt%nbr_ptr(np + 1), pt%cnt_ptr(np + 1))
      pt%acc = 0.0_wp
    end associate
  end subroutine state_allocate_particles

end module fsph_state
