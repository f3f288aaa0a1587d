!> How many OpenMP threads the cycles of a run use: the thread governor.
!>
!> OMP_NUM_THREADS (or the core count) is the most a run may use. When
!> another process keeps a core busy, a team that spans that core waits at
!> every barrier for the thread the operating system has descheduled, and
!> two threads become slower than one (docs/performance.md, "Threads under
!> load": 2.3 to 30 times on the default case). The governor therefore
!> measures: in turn it times a few cycles at the thread count in use and at
!> a neighbouring count (half or double it), keeps the faster, and uses it
!> for an exploitation period that doubles while the same count keeps
!> winning (from exploit_min to exploit_max seconds of wall time) and falls
!> back to exploit_min when the other wins. Results do not depend on the
!> thread count (force assembly through corner arrays, no atomics), so the
!> trajectory is the same bit for bit whatever the governor chooses.
!>
!> With the policy 'fixed' (FSPH_THREAD_POLICY=fixed) every cycle uses the
!> most threads. The governor reads the wall clock once per cycle and
!> changes nothing else of the run.
module fsph_threads
  use fsph_kinds, only: wp
  !$ use omp_lib, only: omp_get_max_threads, omp_set_num_threads
  implicit none
  private

  integer, parameter :: phase_exploit = 0       !< using the chosen count
  integer, parameter :: phase_measure_chosen = 1 !< timing the chosen count
  integer, parameter :: phase_measure_other = 2  !< timing the other count

  !> Thread governor of one run.
  type, public :: thread_governor_t
    logical :: adaptive = .true.       !< measure and choose (.false.: always max_threads)
    logical :: started = .false.       !< max_threads read (the first advance)
    integer :: max_threads = 1         !< OMP_NUM_THREADS when the run first advanced
    integer :: chosen = 1              !< count of the exploitation periods
    integer :: in_use = 1              !< count of the cycle being run
    integer :: phase = phase_measure_chosen
    logical :: probe_down = .true.     !< the next other count is half the chosen one (else double)
    !> Shortest wall time a count is timed over [s]: about ten time slices of
    !> a loaded Linux core (3-4 ms), so that a descheduled thread shows.
    real(wp) :: probe_seconds = 0.03_wp
    !> Fewest cycles a count is timed over [-]: a neighbour-list build falls
    !> in one cycle of several, not in the whole sample.
    integer :: probe_cycles = 3
    real(wp) :: exploit_min = 0.2_wp   !< first exploitation period [s]
    real(wp) :: exploit_max = 5.0_wp   !< longest exploitation period [s]
    real(wp) :: exploit = 0.2_wp       !< current exploitation period [s]
    real(wp) :: seconds = 0.0_wp       !< wall time of the phase so far [s]
    integer :: cycles = 0              !< cycles of the phase so far
    real(wp) :: chosen_per_cycle = 0.0_wp !< measured wall time per cycle at `chosen` [s]
    integer, allocatable :: cycles_at(:) !< cycles run at each thread count
  end type thread_governor_t

  public :: governor_begin, governor_cycle, governor_end, governor_set

contains

  !> Policy and (for tests) the timing of a run's governor; a negative
  !> time keeps the default.
  subroutine governor_set(gov, adaptive, probe_seconds, exploit_seconds)
    type(thread_governor_t), intent(inout) :: gov
    logical, intent(in) :: adaptive
    real(wp), intent(in) :: probe_seconds, exploit_seconds
    gov%adaptive = adaptive
    if (probe_seconds >= 0.0_wp) then
      gov%probe_seconds = probe_seconds
      if (probe_seconds == 0.0_wp) gov%probe_cycles = 1
    end if
    if (exploit_seconds >= 0.0_wp) then
      gov%exploit_min = exploit_seconds
      gov%exploit_max = max(exploit_seconds, 25.0_wp*exploit_seconds)
      gov%exploit = exploit_seconds
    end if
  end subroutine governor_set

  !> Start of an advance: read the most threads at the first one, and set
  !> the count of the next cycle.
  subroutine governor_begin(gov)
    type(thread_governor_t), intent(inout) :: gov
    if (.not. gov%started) then
      gov%started = .true.
      gov%max_threads = 1
      !$ gov%max_threads = omp_get_max_threads()
      gov%chosen = gov%max_threads
      gov%in_use = gov%max_threads
      gov%phase = phase_measure_chosen
      gov%seconds = 0.0_wp
      gov%cycles = 0
      allocate (gov%cycles_at(gov%max_threads))
      gov%cycles_at = 0
    end if
    if (.not. gov%adaptive) gov%in_use = gov%max_threads
    call use_threads(gov%in_use)
  end subroutine governor_begin

  !> Book one cycle of `seconds` wall time [s] run at gov%in_use threads,
  !> and choose the count of the next.
  subroutine governor_cycle(gov, seconds)
    type(thread_governor_t), intent(inout) :: gov
    real(wp), intent(in) :: seconds
    real(wp) :: per_cycle
    integer :: next
    gov%cycles_at(gov%in_use) = gov%cycles_at(gov%in_use) + 1
    if (.not. gov%adaptive .or. gov%max_threads == 1) return
    gov%seconds = gov%seconds + seconds
    gov%cycles = gov%cycles + 1
    select case (gov%phase)
    case (phase_exploit)
      if (gov%seconds < gov%exploit) return
      gov%phase = phase_measure_chosen
    case (phase_measure_chosen)
      if (gov%seconds < gov%probe_seconds .or. gov%cycles < gov%probe_cycles) return
      gov%chosen_per_cycle = gov%seconds/gov%cycles
      next = other_count(gov)
      gov%in_use = next
      gov%phase = phase_measure_other
    case (phase_measure_other)
      if (gov%seconds < gov%probe_seconds .or. gov%cycles < gov%probe_cycles) return
      per_cycle = gov%seconds/gov%cycles
      if (per_cycle < gov%chosen_per_cycle) then
        gov%chosen = gov%in_use
        gov%exploit = gov%exploit_min
      else
        gov%in_use = gov%chosen
        gov%exploit = min(2.0_wp*gov%exploit, gov%exploit_max)
      end if
      gov%phase = phase_exploit
    end select
    gov%seconds = 0.0_wp
    gov%cycles = 0
    call use_threads(gov%in_use)
  end subroutine governor_cycle

  !> End of an advance: parallel regions outside the cycles (set-up,
  !> snapshots) use the most threads again.
  subroutine governor_end(gov)
    type(thread_governor_t), intent(inout) :: gov
    if (gov%started) call use_threads(gov%max_threads)
  end subroutine governor_end

  !> The count timed against the chosen one: half or double it in turn,
  !> within 1..max_threads.
  integer function other_count(gov) result(n)
    type(thread_governor_t), intent(inout) :: gov
    integer :: down, up
    down = max(1, gov%chosen/2)
    up = min(gov%max_threads, 2*gov%chosen)
    if (down == gov%chosen) then
      n = up
    else if (up == gov%chosen) then
      n = down
    else if (gov%probe_down) then
      n = down
    else
      n = up
    end if
    gov%probe_down = .not. gov%probe_down
  end function other_count

  subroutine use_threads(n)
    integer, intent(in) :: n
    !$ call omp_set_num_threads(n)
  end subroutine use_threads

end module fsph_threads
