!> Results of parallel loops made independent of the thread count: the
!> smallest value with the lowest index among equal values (as a serial
!> scan would find it), and the first fault by priority. Each loop keeps
!> its candidates (a thread's minimum, the lowest failing index of each
!> check); these routines decide between them.
module fsph_ordered
  use fsph_kinds, only: wp
  use fsph_status, only: status_ok
  implicit none
  private
  public :: merge_minimum, first_fault

contains

  !> Merge one thread's smallest value t_min at index t_i (0: none) into
  !> the shared minimum (v_min, i_min): the smaller value wins, the lower
  !> index among equal values. Call inside the loop's critical section.
  pure subroutine merge_minimum(t_min, t_i, v_min, i_min)
    real(wp), intent(in) :: t_min
    integer, intent(in) :: t_i
    real(wp), intent(inout) :: v_min
    integer, intent(inout) :: i_min
    if (t_i > 0 .and. (t_min < v_min .or. (t_min == v_min .and. t_i < i_min))) then
      v_min = t_min
      i_min = t_i
    end if
  end subroutine merge_minimum

  !> The fault to report after a loop over n items: faults(k) is the lowest
  !> index at which check k failed (n + 1: it never failed), codes(k) its
  !> status, the checks in order of priority. ierr is the status of the
  !> first check that failed and ifault its index; status_ok and 0 if none.
  pure subroutine first_fault(n, faults, codes, ierr, ifault)
    integer, intent(in) :: n, faults(:), codes(:)
    integer, intent(out) :: ierr, ifault
    integer :: k
    ierr = status_ok
    ifault = 0
    do k = 1, size(faults)
      if (faults(k) <= n) then
        ierr = codes(k)
        ifault = faults(k)
        return
      end if
    end do
  end subroutine first_fault

end module fsph_ordered
