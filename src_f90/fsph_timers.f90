!> Wall-clock time spent in each phase of the cycle, accumulated since the
!> last reset (for the benchmarks' cost split, as table 2 of Hu et al. 2013). A
!> timer reads the clock twice per phase per cycle, about 50 ns, which is
!> below 0.1 % of the cheapest cycle that is benchmarked. Serial code calls
!> the timers, never a parallel region.
module fsph_timers
  use fsph_kinds, only: wp
  use fsph_layouts, only: n_phases
  !$ use omp_lib, only: omp_get_wtime
  implicit none
  private

  ! the phases and their number: fsph_layouts (generated from fsph/layouts.py)

  !> The phase timers of one run.
  type, public :: phase_timers_t
    real(wp) :: elapsed(n_phases) = 0.0_wp   !< accumulated wall time [s]
    real(wp) :: started(n_phases) = 0.0_wp   !< clock at the open start [s]
  end type phase_timers_t

  public :: timer_start, timer_stop, wall_clock

contains

  !> Wall clock [s].
  function wall_clock() result(t)
    real(wp) :: t
    integer(kind=8) :: count, rate
    !$ t = omp_get_wtime()
    !$ return
    call system_clock(count, rate)
    t = real(count, wp)/real(rate, wp)
  end function wall_clock

  subroutine timer_start(timers, phase)
    type(phase_timers_t), intent(inout) :: timers
    integer, intent(in) :: phase
    timers%started(phase) = wall_clock()
  end subroutine timer_start

  subroutine timer_stop(timers, phase)
    type(phase_timers_t), intent(inout) :: timers
    integer, intent(in) :: phase
    timers%elapsed(phase) = timers%elapsed(phase) + (wall_clock() - timers%started(phase))
  end subroutine timer_stop

end module fsph_timers
