!> Results of parallel loops made independent of the thread count: the
!> smallest value with the lowest index among equal values (as a serial
!> scan would find it), and the first fault by priority. Each loop keeps
!> its candidates (a thread's minimum, the lowest failing index of each
!> check); these routines decide between them. And which rows each
!> thread takes in the particles' pair passes (thread_rows): the same
!> contiguous block in every pass.
module fsph_ordered
  use, intrinsic :: iso_fortran_env, only: int64
  use fsph_kinds, only: wp
  use fsph_status, only: status_ok
  !$ use omp_lib, only: omp_get_thread_num, omp_get_num_threads
  implicit none
  private
  public :: merge_minimum, first_fault, thread_rows

  !> Work of a row in thread_rows beside its entries, in entries [-]: the
  !> row's own loads and stores (its particle's data, its sums).
  integer, parameter :: row_overhead = 4

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

  !> The rows first..last that the calling thread of a parallel region
  !> takes in loops over rows 1..n whose entries are ptr_a(i) ..
  !> ptr_a(i+1)-1 and ptr_b(i) .. ptr_b(i+1)-1 (a particle's neighbour
  !> row and its partners' row): one contiguous block per thread, in thread
  !> order, of about equal work (the entries of both plus row_overhead per
  !> row). Every loop over the same rows gives a thread the same block, so
  !> that what one pass writes for its rows (the pair arrays, the sums) the
  !> next pass reads on the same core, and a row's partners, its nearest
  !> rows when the particles are in spatial order, are mostly its own
  !> thread's. (Chunks of 64 rows handed out dynamically, as before
  !> 2026-11-29, gave each pass the rows of the other core as often as its
  !> own: on two threads the pair passes of the SPH block took 1.3 to 1.4
  !> times the processor time of one thread, docs/performance.md.)
  !> Without OpenMP, or outside a parallel region: 1 .. n. The rows each
  !> thread takes change no result: each row sums in its own fixed order.
  subroutine thread_rows(n, ptr_a, ptr_b, first, last)
    integer, intent(in) :: n, ptr_a(n + 1), ptr_b(n + 1)
    integer, intent(out) :: first, last
    integer :: thread, threads
    thread = 0
    threads = 1
    !$ thread = omp_get_thread_num()
    !$ threads = omp_get_num_threads()
    first = row_at(n, ptr_a, ptr_b, thread, threads)
    last = row_at(n, ptr_a, ptr_b, thread + 1, threads) - 1
  end subroutine thread_rows

  !> The first row of block `part` of `parts` (thread_rows): the first row
  !> whose work before it is at least part/parts of the whole; n + 1 for
  !> part = parts.
  pure integer function row_at(n, ptr_a, ptr_b, part, parts) result(row)
    integer, intent(in) :: n, ptr_a(n + 1), ptr_b(n + 1), part, parts
    integer(int64) :: goal, total
    integer :: lo, hi, mid
    if (part >= parts) then
      row = n + 1
      return
    end if
    total = work_before(n + 1)
    goal = (total*part + parts - 1)/parts
    lo = 1
    hi = n + 1
    do while (lo < hi)
      mid = (lo + hi)/2
      if (work_before(mid) >= goal) then
        hi = mid
      else
        lo = mid + 1
      end if
    end do
    row = lo
  contains
    pure integer(int64) function work_before(i)
      integer, intent(in) :: i
      work_before = int(ptr_a(i) - ptr_a(1), int64) + int(ptr_b(i) - ptr_b(1), int64) &
                    + int(row_overhead, int64)*(i - 1)
    end function work_before
  end function row_at

end module fsph_ordered
