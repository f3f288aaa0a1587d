!> O(N) neighbour search for particles: a cell (bucket) list rebuilt every
!> step, then per-particle lists in CSR form, built so that the SPH sums
!> evaluate each pair of real particles once (a half list) and still
!> gather every particle's sum in a fixed order, whatever the thread count.
!>
!> The points are binned by size (a factor 2 in h per level, each level its
!> own cell grid) and copied into cell order (positions, reaches and
!> bodies side by side), so the candidates of a cell are read as one
!> contiguous run; each particle's accepted neighbours are appended without
!> a branch into its own rows of strided buffers in one threaded pass (a
!> row that overflows makes the rows wider and the pass run again, which is
!> rare: the width follows the longest list seen).
!>
!> The row of particle i (nbr_ptr(i) .. nbr_ptr(i+1)-1) holds
!>  - first its half entries, up to half_end(i)-1: the real particles j > i
!>    of its continuum within the kernel support 2 h_ij plus the skin (the
!>    lists are kept while no pair can have crossed the skin, fsph_verlet).
!>    Entry k is the pair (i, j): the sums compute it once, in i's row;
!>  - then its one-way entries: ghosts, the mirror images of same-body
!>    particles j across the axis r = 0 within the support (stored as -j,
!>    i's own mirror included), and the imaginary particles j > nq of its
!>    continuum (Petschek & Libersky 1993; Xiao et al. 2012 section 2.1).
!> Its low list (low_ptr(i) .. low_ptr(i+1)-1) holds the real particles
!> j < i within the support, as low_other = j and low_pair = the entry of
!> the pair (j, i) in j's row: the half rows transposed. Each part of a row
!> is ascending, so the order of the entries, and of every sum, depends
!> only on which points are listed, not on the cells or on when the lists
!> were built. Contact candidates, particles of
!> another body within the support (docs/method.md, "Contact"), have a separate full list
!> (cnt_ptr, cnt_list), mirror images across the axis as -j. SPH sums never
!> cross continuum boundaries. A point given a negative continuum (the
!> solver gives total-Lagrangian particles minus theirs) has empty SPH
!> rows and is in nobody's: it appears in contact lists only.
module fsph_neighbours
  use fsph_kinds, only: wp
  use fsph_kernel, only: kernel_support
  use fsph_arrays, only: reserve
  implicit none
  private

  public :: build_neighbours

  !> Largest number of size levels (a factor 2 in h each; the last takes
  !> all larger points).
  integer, parameter :: max_levels = 12

  !> Work arrays of the search, kept between calls so the cycle does not
  !> allocate once their sizes have settled.
  type, public :: neighbour_work_t
    integer :: width = 32                  !< row width of the half and one-way buffers
    integer :: contact_width = 4           !< row width of the contact buffer
    ! one grid per size level: points with h in [h_min 2^(l-1), h_min 2^l)
    integer :: n_levels = 0
    real(wp) :: level_cell(max_levels) = 0.0_wp  !< cell side [m]
    real(wp) :: level_z0(max_levels) = 0.0_wp    !< lowest z of the level's points [m]
    real(wp) :: level_reach(max_levels) = 0.0_wp !< largest reach (kernel_support h + skin)/2 [m]
    integer :: level_nr(max_levels) = 0, level_nz(max_levels) = 0 !< cells (0: empty level)
    integer :: level_offset(max_levels) = 0       !< cells of the levels before
    integer, allocatable :: cell_start(:)  !< CSR of cells into the sorted points (ncell + 1)
    integer, allocatable :: cell_of(:)     !< cell of each point
    integer, allocatable :: fill(:)        !< next free sorted slot of each cell (ncell)
    integer, allocatable :: item(:)        !< point at each sorted position
    real(wp), allocatable :: xs(:, :)      !< sorted positions (r, z) [m]
    real(wp), allocatable :: reach_s(:)    !< sorted reaches (kernel_support h + skin)/2 [m]
    integer, allocatable :: body_s(:)      !< sorted continuum indices
    !> strided buffers (width + 1, nq): the last slot takes the writes of
    !> rejected candidates once a row is full
    integer, allocatable :: half_row(:, :), one_row(:, :)
    integer, allocatable :: cnt_row(:, :)  !< (contact_width, nq)
    !> row lengths; n_low: the low rows' lengths, then their fill cursors
    integer, allocatable :: n_half(:), n_low(:), n_one(:), n_cnt(:)
  end type neighbour_work_t

  !> Rows are made this much wider than the longest list that overflowed [-].
  integer, parameter :: width_margin = 8

contains

  !> Size levels and their grids: level l holds the points with h in
  !> [h_min 2^(l-1), h_min 2^l) (the last, all larger ones); its cells, of
  !> side at least its largest reach (half the largest pair reach: a
  !> point's candidates fill about 5 x 5 cells, 6.25 squared pair reaches,
  !> against 9 with cells of the whole reach, for 12 % fewer instructions
  !> of the search in debris case 1), start at r = 0 and its lowest
  !> z; a side grows if needed so that a level never has more than about 4
  !> cells per point (memory stays O(N) when particles scatter). One grid
  !> for all would be as coarse as the largest particle: a graded plate's
  !> rim particles, 40 times the impact zone's, put thousands of candidates
  !> in every cell.
  subroutine make_levels(n, x, h, skin, level, work)
    integer, intent(in) :: n
    real(wp), intent(in) :: x(2, n), h(n), skin
    integer, intent(out) :: level(n)
    type(neighbour_work_t), intent(inout) :: work
    real(wp), parameter :: cells_per_point = 4.0_wp
    real(wp) :: h_min, z_lo(max_levels), z_hi(max_levels), r_hi(max_levels), cell
    integer :: i, l, count(max_levels), offset
    h_min = minval(h)
    z_lo = huge(1.0_wp); z_hi = -huge(1.0_wp); r_hi = 0.0_wp
    count = 0
    work%level_reach = 0.0_wp
    do i = 1, n
      l = min(exponent(h(i)/h_min), max_levels)
      level(i) = l
      count(l) = count(l) + 1
      z_lo(l) = min(z_lo(l), x(2, i))
      z_hi(l) = max(z_hi(l), x(2, i))
      r_hi(l) = max(r_hi(l), x(1, i))
      work%level_reach(l) = max(work%level_reach(l), 0.5_wp*kernel_support*h(i) + 0.5_wp*skin)
    end do
    work%n_levels = maxval(level)
    offset = 0
    do l = 1, work%n_levels
      work%level_offset(l) = offset
      if (count(l) == 0) then
        work%level_nr(l) = 0
        work%level_nz(l) = 0
        cycle
      end if
      cell = work%level_reach(l)
      cell = max(cell, sqrt((r_hi(l) + cell)*(z_hi(l) - z_lo(l) + cell)/(cells_per_point*count(l))))
      ! nor more than about cells_per_point cells per point along either
      ! side: a point flung far off along one side (a runaway the run is
      ! about to stop on) must not overflow the cell count
      cell = max(cell, max(r_hi(l), z_hi(l) - z_lo(l))/(cells_per_point*count(l)))
      work%level_cell(l) = cell
      work%level_z0(l) = z_lo(l)
      work%level_nr(l) = int(max(r_hi(l), 0.0_wp)/cell) + 1
      work%level_nz(l) = int((z_hi(l) - z_lo(l))/cell) + 1
      offset = offset + work%level_nr(l)*work%level_nz(l)
    end do
  end subroutine make_levels

  !> Global cell of a point at (r, z) in level l's grid.
  pure integer function cell_index(work, l, r, z)
    type(neighbour_work_t), intent(in) :: work
    integer, intent(in) :: l
    real(wp), intent(in) :: r, z
    cell_index = work%level_offset(l) + 1 &
                 + min(int(max(r, 0.0_wp)/work%level_cell(l)), work%level_nr(l) - 1) &
                 + work%level_nr(l)*min(int((z - work%level_z0(l))/work%level_cell(l)), work%level_nz(l) - 1)
  end function cell_index

  !> Build the lists (see the module header) of the first nq of n points
  !> (the real particles; the others, imaginary particles, appear only as
  !> one-way entries and never as contact candidates). `body` is the
  !> continuum index. The allocatable lists grow as needed.
  subroutine build_neighbours(nq, n, x, h, body, skin, work, nbr_ptr, nbr_list, half_end, low_ptr, low_pair, &
                             low_other, cnt_ptr, cnt_list)
    integer, intent(in) :: nq, n
    real(wp), intent(in) :: x(2, n)        !< positions (r >= 0, z) [m]
    real(wp), intent(in) :: h(n)           !< smoothing lengths [m]
    real(wp), intent(in) :: skin           !< added to every pair's reach, so the lists last [m]
    integer, intent(in) :: body(n)         !< continuum index
    type(neighbour_work_t), intent(inout) :: work
    integer, intent(out) :: nbr_ptr(nq + 1), half_end(nq), low_ptr(nq + 1), cnt_ptr(nq + 1)
    integer, allocatable, intent(inout) :: nbr_list(:), low_pair(:), low_other(:), cnt_list(:)
    integer :: i, m, j, k

    nbr_ptr(1) = 1
    low_ptr(1) = 1
    cnt_ptr(1) = 1
    if (nq == 0 .or. n == 0) return
    call sort_into_cells(n, x, h, body, skin, work)
    call ensure_rows(work, nq)
    do
      call scan_points(nq, n, x, h, body, skin, work)
      if (max(maxval(work%n_half(1:nq)), maxval(work%n_one(1:nq))) <= work%width &
          .and. maxval(work%n_cnt(1:nq)) <= work%contact_width) exit
      ! a row overflowed: widen the rows to the longest list and scan again
      work%width = max(work%width, maxval(work%n_half(1:nq)) + width_margin, &
                       maxval(work%n_one(1:nq)) + width_margin)
      work%contact_width = max(work%contact_width, maxval(work%n_cnt(1:nq)) + width_margin)
      call ensure_rows(work, nq)
    end do

    do i = 1, nq
      nbr_ptr(i + 1) = nbr_ptr(i) + work%n_half(i) + work%n_one(i)
      half_end(i) = nbr_ptr(i) + work%n_half(i)
      cnt_ptr(i + 1) = cnt_ptr(i) + work%n_cnt(i)
    end do
    call ensure_size(nbr_list, nbr_ptr(nq + 1) - 1)
    call ensure_size(cnt_list, cnt_ptr(nq + 1) - 1)
    ! rows in place, each part ascending: the order of the entries, and so
    ! of every sum, depends only on which particles are listed, not on the
    ! cells or on when the lists were built (entries beyond the support
    ! that a skin adds contribute exact zeros)
    !$omp parallel do default(none) schedule(static) &
    !$omp shared(nq, work, nbr_ptr, half_end, cnt_ptr, nbr_list, cnt_list) private(i)
    do i = 1, nq
      call sort_ascending(work%half_row(1:work%n_half(i), i))
      call sort_ascending(work%one_row(1:work%n_one(i), i))
      call sort_ascending(work%cnt_row(1:work%n_cnt(i), i))
      nbr_list(nbr_ptr(i):half_end(i) - 1) = work%half_row(1:work%n_half(i), i)
      nbr_list(half_end(i):nbr_ptr(i + 1) - 1) = work%one_row(1:work%n_one(i), i)
      cnt_list(cnt_ptr(i):cnt_ptr(i + 1) - 1) = work%cnt_row(1:work%n_cnt(i), i)
    end do
    !$omp end parallel do
    ! the low rows, the half rows transposed: i's low row lists each j < i
    ! whose half row holds i (the support test is symmetric in i and j, so
    ! i is there, once), with that entry as the pair; filled in ascending
    ! j, so each row is ascending. Two serial passes over the half entries
    ! (work%n_low counts, then serves as the rows' fill cursor).
    work%n_low(1:nq) = 0
    do j = 1, nq
      do k = nbr_ptr(j), half_end(j) - 1
        work%n_low(nbr_list(k)) = work%n_low(nbr_list(k)) + 1
      end do
    end do
    do i = 1, nq
      low_ptr(i + 1) = low_ptr(i) + work%n_low(i)
      work%n_low(i) = low_ptr(i)
    end do
    call ensure_size(low_pair, low_ptr(nq + 1) - 1)
    call ensure_size(low_other, low_ptr(nq + 1) - 1)
    do j = 1, nq
      do k = nbr_ptr(j), half_end(j) - 1
        i = nbr_list(k)
        m = work%n_low(i)
        low_other(m) = j
        low_pair(m) = k
        work%n_low(i) = m + 1
      end do
    end do

  end subroutine build_neighbours

  !> Insertion sort of a short list (a row of some tens of entries).
  pure subroutine sort_ascending(a)
    integer, intent(inout) :: a(:)
    integer :: i, k, v
    do i = 2, size(a)
      v = a(i)
      k = i - 1
      do while (k >= 1)
        if (a(k) <= v) exit
        a(k + 1) = a(k)
        k = k - 1
      end do
      a(k + 1) = v
    end do
  end subroutine sort_ascending

  !> Counting sort of the points into the cells of their levels (point
  !> order kept within a cell), with copies of their positions, reaches
  !> (half-support plus half the skin) and continua in that order.
  subroutine sort_into_cells(n, x, h, body, skin, work)
    integer, intent(in) :: n
    real(wp), intent(in) :: x(2, n), h(n), skin
    integer, intent(in) :: body(n)
    type(neighbour_work_t), intent(inout) :: work
    integer :: ncell, i, k, c, l
    call reserve(work%cell_of, n)
    call reserve(work%item, n)
    call reserve(work%xs, 2, n)
    call reserve(work%reach_s, n)
    call reserve(work%body_s, n)
    ! cell_of holds the levels first, then the cells
    call make_levels(n, x, h, skin, work%cell_of, work)
    l = work%n_levels
    ncell = work%level_offset(l) + work%level_nr(l)*work%level_nz(l)
    call reserve(work%cell_start, ncell + 1)
    call reserve(work%fill, ncell)
    work%cell_start(1:ncell + 1) = 0
    do i = 1, n
      c = cell_index(work, work%cell_of(i), x(1, i), x(2, i))
      work%cell_of(i) = c
      work%cell_start(c + 1) = work%cell_start(c + 1) + 1
    end do
    work%cell_start(1) = 1
    do c = 1, ncell
      work%cell_start(c + 1) = work%cell_start(c + 1) + work%cell_start(c)
    end do
    work%fill(1:ncell) = work%cell_start(1:ncell)
    do i = 1, n
      c = work%cell_of(i)
      k = work%fill(c)
      work%fill(c) = k + 1
      work%item(k) = i
      work%xs(:, k) = x(:, i)
      work%reach_s(k) = 0.5_wp*kernel_support*h(i) + 0.5_wp*skin
      work%body_s(k) = body(i)
    end do
  end subroutine sort_into_cells

  !> Rows of the strided buffers for nq points at the current widths, each
  !> with one scratch slot after the width.
  subroutine ensure_rows(work, nq)
    type(neighbour_work_t), intent(inout) :: work
    integer, intent(in) :: nq
    if (allocated(work%half_row)) then
      if (size(work%half_row, 1) < work%width + 1 .or. size(work%cnt_row, 1) < work%contact_width .or. &
          size(work%half_row, 2) < nq) &
        deallocate (work%half_row, work%one_row, work%cnt_row, work%n_half, work%n_low, &
                    work%n_one, work%n_cnt)
    end if
    if (.not. allocated(work%half_row)) &
      allocate (work%half_row(work%width + 1, nq), &
                work%one_row(work%width + 1, nq), work%cnt_row(work%contact_width, nq), &
                work%n_half(nq), work%n_low(nq), work%n_one(nq), work%n_cnt(nq))
  end subroutine ensure_rows

  !> One pass over the real points: each accepted candidate goes to the
  !> half or one-way row or the contact row (up to the row width; the
  !> counts go on, so the caller sees an overflow). A point looks, in every
  !> level, at the cells within its reach plus the level's largest reach:
  !> in its own level and the coarser ones, about the 5 x 5 cells around it.
  subroutine scan_points(nq, n, x, h, body, skin, work)
    integer, intent(in) :: nq, n
    real(wp), intent(in) :: x(2, n), h(n), skin
    integer, intent(in) :: body(n)
    type(neighbour_work_t), intent(inout) :: work
    integer :: ii, l, jz, n_half, n_one, n_cnt, bi, width, cwidth
    integer :: jr_lo, jr_hi, jz_lo, jz_hi, row
    real(wp) :: ri, zi, reach_i, big, cell
    ! a row holds width entries; writes past them go to the scratch slot
    ! width + 1, and a count above width makes the caller widen and rescan
    width = work%width
    cwidth = work%contact_width
    !$omp parallel do default(none) schedule(static) &
    !$omp shared(nq, x, h, body, skin, work, width, cwidth) &
    !$omp private(ii, l, jz, n_half, n_one, n_cnt, bi, ri, zi, reach_i, big, cell) &
    !$omp private(jr_lo, jr_hi, jz_lo, jz_hi, row)
    do ii = 1, nq
      ri = x(1, ii)
      zi = x(2, ii)
      reach_i = 0.5_wp*kernel_support*h(ii) + 0.5_wp*skin
      bi = body(ii)
      n_half = 0
      n_one = 0
      n_cnt = 0
      do l = 1, work%n_levels
        if (work%level_nr(l) == 0) cycle
        cell = work%level_cell(l)
        big = reach_i + work%level_reach(l)      ! farthest a neighbour of this level can be
        ! clamped before the conversion to integer: a point far outside
        ! this level's grid gives an empty range, not an overflow
        jr_lo = floor(min(max((ri - big)/cell, 0.0_wp), real(work%level_nr(l), wp)))
        jr_hi = floor(max(min((ri + big)/cell, real(work%level_nr(l) - 1, wp)), -1.0_wp))
        jz_lo = floor(min(max((zi - big - work%level_z0(l))/cell, 0.0_wp), real(work%level_nz(l), wp)))
        jz_hi = floor(max(min((zi + big - work%level_z0(l))/cell, real(work%level_nz(l) - 1, wp)), -1.0_wp))
        ! a point beyond this level's grid (farther out than its points) has
        ! no candidate in it; cell_start(row + jr_lo) would lie past the row
        if (jr_lo > jr_hi) cycle
        do jz = jz_lo, jz_hi
          ! real and imaginary neighbours and contact candidates: the cells
          ! jr_lo .. jr_hi of a row are one run of sorted points
          row = work%level_offset(l) + 1 + work%level_nr(l)*jz
          call scan_run(work%cell_start(row + jr_lo), work%cell_start(row + jr_hi + 1) - 1, work%item, work%xs, &
                        work%reach_s, work%body_s, ii, nq, ri, zi, reach_i, bi, width, cwidth, work%half_row(:, ii), &
                        work%one_row(:, ii), work%cnt_row(:, ii), n_half, n_one, n_cnt)
          ! ghosts, for points whose reach crosses the axis
          if (big > ri) call scan_mirrors(work, l, row, ii, nq, ri, zi, reach_i, big, bi, width, n_one, &
                                          cwidth, n_cnt)
        end do
      end do
      ! a point of negative continuum (a total-Lagrangian particle,
      ! fsph_total) has no SPH entries: it is a contact candidate only
      if (bi < 0) then
        n_half = 0
        n_one = 0
      end if
      work%n_half(ii) = n_half
      work%n_one(ii) = n_one
      work%n_cnt(ii) = n_cnt
    end do
    !$omp end parallel do
  end subroutine scan_points

  !> The candidates kk_lo .. kk_hi (one run of sorted points: the cells of
  !> a grid row) of query point ii at (ri, zi) with reach reach_i and body
  !> bi: each accepted one goes to the half or one-way row or the
  !> contact row (rows and counts as in scan_points). On arrays passed as
  !> arguments, which Fortran guarantees do not overlap, the compiler keeps
  !> the counts in registers across the rows' stores (as components of the
  !> search's work it reloaded them after every store). The run is taken in
  !> chunks: first the candidates within reach are gathered, in run order,
  !> by a branch-free loop of the distance test alone (about a third of the
  !> candidates pass it), then only those are sorted into the rows.
  subroutine scan_run(kk_lo, kk_hi, item, xs, reach_s, body_s, ii, nq, ri, zi, reach_i, bi, width, cwidth, &
                      half_row, one_row, cnt_row, n_half, n_one, n_cnt)
    integer, intent(in) :: kk_lo, kk_hi, item(*), body_s(*), ii, nq, bi, width, cwidth
    real(wp), intent(in) :: xs(2, *), reach_s(*), ri, zi, reach_i
    integer, intent(inout) :: half_row(width + 1), one_row(width + 1), cnt_row(cwidth)
    integer, intent(inout) :: n_half, n_one, n_cnt
    !> candidates taken per chunk [-]
    integer, parameter :: chunk = 64
    integer :: within(chunk + 1)
    integer :: kk, k0, k1, t, m, jj, near, same, real_j, up, nh, no, nc
    real(wp) :: d2, reach
    nh = n_half
    no = n_one
    nc = n_cnt
    do k0 = kk_lo, kk_hi, chunk
      k1 = min(k0 + chunk - 1, kk_hi)
      m = 0
      do kk = k0, k1
        d2 = (ri - xs(1, kk))**2 + (zi - xs(2, kk))**2
        reach = reach_i + reach_s(kk)
        within(m + 1) = kk
        m = m + merge(1, 0, d2 < reach*reach)
      end do
      do t = 1, m
        kk = within(t)
        jj = item(kk)
        ! 0/1 flags, so the common path has no data-dependent branch
        near = merge(1, 0, jj /= ii)
        same = merge(1, 0, body_s(kk) == bi)
        real_j = merge(1, 0, jj <= nq)
        up = merge(1, 0, jj > ii)
        half_row(min(nh + 1, width + 1)) = jj
        one_row(min(no + 1, width + 1)) = jj
        nh = nh + near*same*real_j*up
        no = no + near*same*(1 - real_j)
        if (near > same) then
          ! another body within reach: a contact candidate if real
          if (jj <= nq) then
            nc = nc + 1
            if (nc <= cwidth) cnt_row(nc) = jj
          end if
        end if
      end do
    end do
    n_half = nh
    n_one = no
    n_cnt = nc
  end subroutine scan_run

  !> Mirror images (-r_j, z_j) across the axis in grid row `row` of level
  !> l for query point ii at (ri, zi) (reach reach_i, level reach big, body
  !> bi): the same-body points within reach of the axis side, written to
  !> ii's one-way row as -j and counted in n_one (row width as scan_points);
  !> the real points (j <= nq) of other bodies, the same way, to its contact
  !> row (n_cnt, width cwidth): a contact near the axis feels the other
  !> body's ring all round, as the SPH sums feel their own.
  subroutine scan_mirrors(work, l, row, ii, nq, ri, zi, reach_i, big, bi, width, n_one, cwidth, n_cnt)
    type(neighbour_work_t), intent(inout) :: work
    integer, intent(in) :: l, row, ii, nq, bi, width, cwidth
    real(wp), intent(in) :: ri, zi, reach_i, big
    integer, intent(inout) :: n_one, n_cnt
    integer :: kk, last, near, same
    real(wp) :: d2, reach
    last = work%cell_start(row + floor(min((big - ri)/work%level_cell(l), real(work%level_nr(l) - 1, wp))) + 1) - 1
    do kk = work%cell_start(row), last
      d2 = (ri + work%xs(1, kk))**2 + (zi - work%xs(2, kk))**2
      reach = reach_i + work%reach_s(kk)
      near = merge(1, 0, d2 < reach*reach)
      same = merge(1, 0, work%body_s(kk) == bi)
      work%one_row(min(n_one + 1, width + 1), ii) = -work%item(kk)
      n_one = n_one + near*same
      if (near > same .and. work%item(kk) <= nq) then
        n_cnt = n_cnt + 1
        if (n_cnt <= cwidth) work%cnt_row(n_cnt, ii) = -work%item(kk)
      end if
    end do
  end subroutine scan_mirrors

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

end module fsph_neighbours
