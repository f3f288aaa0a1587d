!> O(N) neighbour search for particles: a cell (bucket) list rebuilt every
!> step, then per-particle neighbour lists in CSR form, threaded over
!> particles with a count pass and a fill pass (no shared writes; the order
!> of each list is fixed, so results do not depend on the thread count).
!>
!> Three kinds of entries (ALGORITHMS.md sections 2 and 5):
!>  - same-body neighbours j within the kernel support 2 h_ij, stored as +j;
!>  - ghosts: the mirror image of a same-body particle j across the axis
!>    r = 0, within the support of particle i, stored as -j (i's own mirror
!>    included);
!>  - contact candidates: particles j of another body within 2 h_ij, in a
!>    separate list. SPH sums never cross body boundaries.
module fsph_neighbors
  use fsph_kinds, only: wp
  use fsph_kernel, only: kernel_support
  implicit none
  private

  public :: build_neighbors

contains

  !> Cell size and grid: cells of side >= 2 h_max starting at r = 0 and the
  !> lowest z; the side grows if needed so the grid never has more than
  !> about 4 cells per particle (memory stays O(N) when particles scatter).
  subroutine make_grid(n, x, h_max, cell, nr, nz, z0)
    integer, intent(in) :: n
    real(wp), intent(in) :: x(2, n), h_max
    real(wp), intent(out) :: cell, z0
    integer, intent(out) :: nr, nz
    real(wp) :: r_ext, z_ext
    real(wp), parameter :: cells_per_particle = 4.0_wp
    z0 = minval(x(2, :))
    r_ext = max(maxval(x(1, :)), 0.0_wp)
    z_ext = maxval(x(2, :)) - z0
    cell = kernel_support*h_max
    cell = max(cell, sqrt((r_ext + cell)*(z_ext + cell)/(cells_per_particle*n)))
    nr = int(r_ext/cell) + 1
    nz = int(z_ext/cell) + 1
  end subroutine make_grid

  !> Build the neighbour and contact lists of the first nq of n points (the
  !> real particles; the others, imaginary particles, appear only as
  !> neighbours and never as contact candidates). `body` is the continuum
  !> index: SPH neighbours share it, contact candidates do not. The
  !> allocatable lists grow as needed (no fixed capacity).
  subroutine build_neighbors(nq, n, x, h, body, cell_of, cell_start, cell_items, &
                             nbr_ptr, nbr_list, cnt_ptr, cnt_list)
    integer, intent(in) :: nq, n
    real(wp), intent(in) :: x(2, n)        !< positions (r >= 0, z) [m]
    real(wp), intent(in) :: h(n)           !< smoothing lengths [m]
    integer, intent(in) :: body(n)         !< continuum index
    integer, allocatable, intent(inout) :: cell_of(:), cell_start(:), cell_items(:)
    integer, intent(out) :: nbr_ptr(nq + 1), cnt_ptr(nq + 1)
    integer, allocatable, intent(inout) :: nbr_list(:), cnt_list(:)
    real(wp) :: cell, z0
    integer :: nr, nz, ncell, i, k
    integer, allocatable :: fill(:)

    nbr_ptr(1) = 1
    cnt_ptr(1) = 1
    if (nq == 0 .or. n == 0) return
    call make_grid(n, x, maxval(h), cell, nr, nz, z0)
    ncell = nr*nz
    if (allocated(cell_start)) then
      if (size(cell_start) < ncell + 1) deallocate (cell_start)
    end if
    if (.not. allocated(cell_start)) allocate (cell_start(ncell + 1))
    if (allocated(cell_of)) then
      if (size(cell_of) < n) deallocate (cell_of, cell_items)
    end if
    if (.not. allocated(cell_of)) allocate (cell_of(n), cell_items(n))

    ! counting sort of particles into cells (particle order kept in a cell)
    cell_start(1:ncell + 1) = 0
    do i = 1, n
      cell_of(i) = 1 + min(int(max(x(1, i), 0.0_wp)/cell), nr - 1) + &
                   nr*min(int((x(2, i) - z0)/cell), nz - 1)
      cell_start(cell_of(i) + 1) = cell_start(cell_of(i) + 1) + 1
    end do
    cell_start(1) = 1
    do k = 1, ncell
      cell_start(k + 1) = cell_start(k + 1) + cell_start(k)
    end do
    allocate (fill(ncell))
    fill = cell_start(1:ncell)
    do i = 1, n
      cell_items(fill(cell_of(i))) = i
      fill(cell_of(i)) = fill(cell_of(i)) + 1
    end do

    ! count pass, prefix sums, fill pass
    call scan_pairs(.false.)
    nbr_ptr(1) = 1
    cnt_ptr(1) = 1
    do i = 1, nq
      nbr_ptr(i + 1) = nbr_ptr(i) + nbr_ptr(i + 1)
      cnt_ptr(i + 1) = cnt_ptr(i) + cnt_ptr(i + 1)
    end do
    call ensure_size(nbr_list, nbr_ptr(nq + 1) - 1)
    call ensure_size(cnt_list, cnt_ptr(nq + 1) - 1)
    call scan_pairs(.true.)

  contains

    !> Visit every candidate pair. With fill = .false. store the counts in
    !> ptr(i+1); with fill = .true. write the entries from ptr(i).
    subroutine scan_pairs(fill_lists)
      logical, intent(in) :: fill_lists
      integer :: ii, jj, ir, iz, jr, jz, c, kk, n_nbr, n_cnt
      real(wp) :: ri, zi, reach2, d2
      !$omp parallel do default(none) schedule(dynamic, 64) &
      !$omp shared(nq, x, h, body, cell, z0, nr, nz, cell_start, cell_items, nbr_ptr, cnt_ptr) &
      !$omp shared(nbr_list, cnt_list, fill_lists) &
      !$omp private(ii, jj, ir, iz, jr, jz, c, kk, n_nbr, n_cnt, ri, zi, reach2, d2)
      do ii = 1, nq
        ri = x(1, ii)
        zi = x(2, ii)
        ir = min(int(max(ri, 0.0_wp)/cell), nr - 1)
        iz = min(int((zi - z0)/cell), nz - 1)
        n_nbr = 0
        n_cnt = 0
        do jz = max(iz - 1, 0), min(iz + 1, nz - 1)
          ! real neighbours and contact candidates
          do jr = max(ir - 1, 0), min(ir + 1, nr - 1)
            c = 1 + jr + nr*jz
            do kk = cell_start(c), cell_start(c + 1) - 1
              jj = cell_items(kk)
              if (jj == ii) cycle
              reach2 = (kernel_support*0.5_wp*(h(ii) + h(jj)))**2
              d2 = (ri - x(1, jj))**2 + (zi - x(2, jj))**2
              if (d2 >= reach2) cycle
              if (body(jj) == body(ii)) then
                n_nbr = n_nbr + 1
                if (fill_lists) nbr_list(nbr_ptr(ii) + n_nbr - 1) = jj
              else if (jj <= nq) then
                n_cnt = n_cnt + 1
                if (fill_lists) cnt_list(cnt_ptr(ii) + n_cnt - 1) = jj
              end if
            end do
          end do
          ! ghosts: mirrors (-r_j, z_j) of same-body particles in the first
          ! column, for particles whose support can reach the axis
          if (ir <= 1) then
            c = 1 + nr*jz
            do kk = cell_start(c), cell_start(c + 1) - 1
              jj = cell_items(kk)
              if (body(jj) /= body(ii)) cycle
              reach2 = (kernel_support*0.5_wp*(h(ii) + h(jj)))**2
              d2 = (ri + x(1, jj))**2 + (zi - x(2, jj))**2
              if (d2 >= reach2) cycle
              n_nbr = n_nbr + 1
              if (fill_lists) nbr_list(nbr_ptr(ii) + n_nbr - 1) = -jj
            end do
          end if
        end do
        if (.not. fill_lists) then
          nbr_ptr(ii + 1) = n_nbr
          cnt_ptr(ii + 1) = n_cnt
        end if
      end do
      !$omp end parallel do
    end subroutine scan_pairs

  end subroutine build_neighbors

  !> Grow an allocatable list to hold at least m entries (by 25 % headroom,
  !> so growth is rare).
  subroutine ensure_size(list, m)
    integer, allocatable, intent(inout) :: list(:)
    integer, intent(in) :: m
    if (allocated(list)) then
      if (size(list) >= max(m, 1)) return
      deallocate (list)
    end if
    allocate (list(max(m + m/4, 16)))
  end subroutine ensure_size

end module fsph_neighbors
