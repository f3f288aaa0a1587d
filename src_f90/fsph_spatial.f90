!> Spatial order of points: a cell grid of the points (used by the
!> total-Lagrangian reference lists, fsph_tlsph) and the order in which the
!> real particles are renumbered (fsph_solver keep_spatial_order), so that
!> the neighbours a pair loop gathers lie close together in memory.
!>
!> Particles made by conversion are appended in the order their elements
!> convert, so the data of a particle's neighbours end up spread over the
!> whole set. In the adaptive Taylor rod refined x4 (13 178 particles at
!> the end), its state at 30 us advanced 200 cycles in conversion order and
!> renumbered by cell rows: SPH sums 9.34 and 7.90 s against 6.72 and
!> 7.04 s; the whole run renumbered from 4 096 particles on: 0.94-0.96 of
!> its time (1 thread, docs/performance.md, "Particles in spatial order").
!> Renumbering only reorders the sums, so a run's results change in their
!> last bits, and not with the thread count.
module fsph_spatial
  use fsph_kinds, only: wp
  use fsph_kernel, only: kernel_support
  implicit none
  private

  public :: make_grid, spatial_order, renumber_due

  !> Largest number of cells of a grid per point [-]: the cells grow when
  !> the points are spread out (memory stays O(N)).
  real(wp), parameter :: cells_per_point = 4.0_wp
  !> Growth of the particle count between renumberings, as 1/renumber_growth
  !> of it: the particles appended since the last one stay at the end of
  !> the set, out of order, and are at most this fraction of it [-].
  integer, parameter :: renumber_growth = 20

contains

  !> The cell grid of the points x0: square cells of side at least
  !> the largest support kernel_support max(h) (so a point's neighbours
  !> lie in its own and the 8 adjacent cells), from the lowest (R, Z),
  !> widened when there would be more than cells_per_point cells per
  !> point; the points sorted by cell (counting sort, by index inside a
  !> cell). cell_start(c) .. cell_start(c+1)-1 are cell c's positions in
  !> item.
  subroutine make_grid(n, x0, h, cell, r0, z0, nr, nz, cell_start, item)
    integer, intent(in) :: n
    real(wp), intent(in) :: x0(2, n), h(n)
    real(wp), intent(out) :: cell, r0, z0  !< [m]
    integer, intent(out) :: nr, nz
    integer, allocatable, intent(out) :: cell_start(:), item(:)
    integer, allocatable :: cell_of(:), fill(:)
    real(wp) :: r1, z1
    integer :: i, c
    r0 = minval(x0(1, :)); r1 = maxval(x0(1, :))
    z0 = minval(x0(2, :)); z1 = maxval(x0(2, :))
    cell = kernel_support*maxval(h)
    cell = max(cell, sqrt((r1 - r0 + cell)*(z1 - z0 + cell)/(cells_per_point*n)), &
               max(r1 - r0, z1 - z0)/(cells_per_point*n))
    nr = int((r1 - r0)/cell) + 1
    nz = int((z1 - z0)/cell) + 1
    allocate (cell_start(nr*nz + 1), item(n), cell_of(n), fill(nr*nz))
    cell_start = 0
    do i = 1, n
      c = grid_cell(x0(1, i), x0(2, i), cell, r0, z0, nr, nz)
      cell_of(i) = c
      cell_start(c + 1) = cell_start(c + 1) + 1
    end do
    cell_start(1) = 1
    do c = 1, nr*nz
      cell_start(c + 1) = cell_start(c + 1) + cell_start(c)
    end do
    fill = cell_start(1:nr*nz)
    do i = 1, n
      item(fill(cell_of(i))) = i
      fill(cell_of(i)) = fill(cell_of(i)) + 1
    end do
  end subroutine make_grid

  !> Cell (1 .. nr nz) of a point of the grid.
  pure integer function grid_cell(r, z, cell, r0, z0, nr, nz)
    real(wp), intent(in) :: r, z, cell, r0, z0
    integer, intent(in) :: nr, nz
    grid_cell = 1 + min(int((r - r0)/cell), nr - 1) + nr*min(int((z - z0)/cell), nz - 1)
  end function grid_cell

  !> The order in which n points are renumbered: order(k) is the point that
  !> takes place k, cell by cell of make_grid's grid (cells of side the
  !> largest support kernel_support max(h)), the cells row by row with the
  !> rows across the shorter side of the points' bounding box (a rod along
  !> the axis: rows across its radius; a plate: rows along its thickness),
  !> by index inside a cell. A pair loop then finds a point's neighbours in
  !> its own row and the two next to it. Depends on x and h only.
  subroutine spatial_order(n, x, h, order)
    integer, intent(in) :: n
    real(wp), intent(in) :: x(2, n)   !< positions (r, z) [m]
    real(wp), intent(in) :: h(n)      !< smoothing lengths [m]
    integer, intent(out) :: order(n)
    real(wp) :: cell, c0, c1
    integer :: nc, nrow
    integer, allocatable :: cell_start(:), item(:)
    if (n < 1) return
    if (maxval(x(1, :)) - minval(x(1, :)) <= maxval(x(2, :)) - minval(x(2, :))) then
      call make_grid(n, x, h, cell, c0, c1, nc, nrow, cell_start, item)
    else
      call make_grid(n, x([2, 1], :), h, cell, c0, c1, nc, nrow, cell_start, item)
    end if
    order = item
  end subroutine spatial_order

  !> Whether the real particles are put in spatial order after a
  !> conversion took their count from n_before to n_after: when it reaches
  !> n_min (&sph spatial_order_min; 0: never), and then each time it has
  !> grown by a further 1/renumber_growth. The steps depend on the counts
  !> alone, so a run restarted from a checkpoint renumbers where the run
  !> that wrote it did.
  pure logical function renumber_due(n_before, n_after, n_min)
    integer, intent(in) :: n_before, n_after, n_min
    integer :: step
    renumber_due = .false.
    if (n_min < 1 .or. n_after < n_min .or. n_after <= n_before) return
    step = n_min
    do while (step <= n_before)
      step = step + max(1, step/renumber_growth)
    end do
    renumber_due = n_after >= step
  end function renumber_due

end module fsph_spatial
