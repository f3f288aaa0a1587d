!> The runs of this process. Each fsph.Simulation owns one run, known to
!> Python by its handle (a positive integer); the API routines that read or
!> change a run's state take the handle and work on that instance alone,
!> so several runs in one process advance independently. The table is the
!> only state that outlives a call, and only the API uses it.
module fsph_runs
  use fsph_state, only: simulation_t
  implicit none
  private

  type :: run_slot_t
    type(simulation_t), pointer :: state => null()
  end type run_slot_t

  type(run_slot_t), allocatable, save :: slots(:)

  !> A closed or unknown handle reaches this empty, never-ready state
  !> instead of another run's (Python checks its handle before calling).
  type(simulation_t), target, save :: no_run

  public :: run_open, run_close, run_state, run_is_open

contains

  !> A new, empty run; handle is its number.
  subroutine run_open(handle)
    integer, intent(out) :: handle
    type(run_slot_t), allocatable :: grown(:)
    if (.not. allocated(slots)) allocate (slots(4))
    do handle = 1, size(slots)
      if (.not. associated(slots(handle)%state)) exit
    end do
    if (handle > size(slots)) then
      allocate (grown(2*size(slots)))
      grown(1:size(slots)) = slots
      call move_alloc(grown, slots)
    end if
    allocate (slots(handle)%state)
  end subroutine run_open

  !> Free the run `handle` (nothing happens for a closed or unknown one).
  subroutine run_close(handle)
    integer, intent(in) :: handle
    if (.not. run_is_open(handle)) return
    deallocate (slots(handle)%state)
    slots(handle)%state => null()
  end subroutine run_close

  logical function run_is_open(handle)
    integer, intent(in) :: handle
    run_is_open = .false.
    if (.not. allocated(slots)) return
    if (handle < 1 .or. handle > size(slots)) return
    run_is_open = associated(slots(handle)%state)
  end function run_is_open

  !> The state of run `handle`.
  function run_state(handle) result(state)
    integer, intent(in) :: handle
    type(simulation_t), pointer :: state
    if (run_is_open(handle)) then
      state => slots(handle)%state
    else
      no_run = simulation_t()
      state => no_run
    end if
  end function run_state

end module fsph_runs
