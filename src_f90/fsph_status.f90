!> Status codes returned by kernels and by the API. Nothing in the library
!> stops the process: every failure travels back as one of these codes plus
!> the index of the element, node or material at fault.
module fsph_status
  implicit none
  private

  integer, parameter, public :: status_ok = 0
  !> An element has zero or negative area (tangled mesh). Index: element.
  integer, parameter, public :: status_inverted_element = 1
  !> A NaN or infinity appeared in a state array. Index: element (or node if
  !> the fault is a nodal quantity, reported with status_nonfinite_node).
  integer, parameter, public :: status_nonfinite_element = 2
  integer, parameter, public :: status_nonfinite_node = 3
  !> The stable time step fell below the floor set in the control input.
  !> Index: the element that controls the step.
  integer, parameter, public :: status_dt_floor = 4
  !> Compression beyond the range of the equation of state (Mie-Grueneisen
  !> denominator vanishes). Index: element.
  integer, parameter, public :: status_eos_range = 5
  !> Invalid set-up input (sizes, connectivity, material model ids).
  integer, parameter, public :: status_bad_input = 6
  !> A call made before the state was set up.
  integer, parameter, public :: status_not_ready = 7
  !> The cycle limit was reached before the target time.
  integer, parameter, public :: status_max_cycles = 8
  !> A NaN or infinity (or a non-positive density) in a particle. Index: particle.
  integer, parameter, public :: status_nonfinite_particle = 9
  !> A particle reached the axis (r <= 0). Index: particle.
  integer, parameter, public :: status_particle_axis = 10
  !> The stable step fell by more than the allowed factor in one cycle.
  !> Index: the element (> 0) or particle (< 0) that sets the step.
  integer, parameter, public :: status_dt_drop = 11
end module fsph_status
