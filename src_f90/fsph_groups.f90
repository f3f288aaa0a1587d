!> Connected groups of points, for the metrics' "attached body"
!> (fsph.metrics attached_points): two points are joined when their
!> distance is at most the sum of their reaches, or when a link (an
!> element edge) joins them. O(N): the points are binned in a grid of
!> cells no smaller than twice the largest reach, so every joined pair
!> lies in the same or adjacent cells; the groups are merged by union-find
!> with the smaller index as the root, so a point's label is the smallest
!> index of its group whatever the order of the merges. Serial: called
!> once per snapshot, not in the cycle. Its root also serves the
!> union-find of the fragments of fsph_sph axis_resultant, in the cycle.
module fsph_groups
  use fsph_kinds, only: wp
  implicit none
  private

  public :: connected_groups, root

contains

  !> label(i) = the smallest index of point i's group (1-based).
  subroutine connected_groups(n, x, reach, n_links, links, label)
    integer, intent(in) :: n, n_links
    real(wp), intent(in) :: x(2, n)         !< positions (r, z) [m]
    real(wp), intent(in) :: reach(n)        !< reach of each point (>= 0) [m]
    integer, intent(in) :: links(2, n_links) !< pairs of points always joined (1-based)
    integer, intent(out) :: label(n)
    integer, allocatable :: cell_of(:), cell_start(:), item(:), fill(:)
    real(wp) :: cell, lo(2), hi(2), dist
    integer :: i, j, k, m, nr, nz, ncell, ir, iz, jr, jz, c
    integer(kind=8) :: cells_wanted

    do i = 1, n
      label(i) = i
    end do
    do k = 1, n_links
      call join(label, links(1, k), links(2, k))
    end do
    if (n > 1) then
      cell = 2.0_wp*maxval(reach)
      if (cell > 0.0_wp) then
        lo = minval(x, dim=2)
        hi = maxval(x, dim=2)
        ! no more cells than about four per point: a larger cell only adds candidates
        cells_wanted = (int((hi(1) - lo(1))/cell, 8) + 1)*(int((hi(2) - lo(2))/cell, 8) + 1)
        if (cells_wanted > 4_8*n + 16_8) cell = cell*sqrt(real(cells_wanted, wp)/real(4*n + 16, wp))
        nr = int((hi(1) - lo(1))/cell) + 1
        nz = int((hi(2) - lo(2))/cell) + 1
        ncell = nr*nz
        allocate (cell_of(n), cell_start(ncell + 1), item(n), fill(ncell))
        cell_start = 0
        do i = 1, n
          ir = min(int((x(1, i) - lo(1))/cell), nr - 1)
          iz = min(int((x(2, i) - lo(2))/cell), nz - 1)
          cell_of(i) = 1 + ir + nr*iz
          cell_start(cell_of(i) + 1) = cell_start(cell_of(i) + 1) + 1
        end do
        cell_start(1) = 1
        do c = 1, ncell
          cell_start(c + 1) = cell_start(c + 1) + cell_start(c)
        end do
        fill = cell_start(1:ncell)
        do i = 1, n
          item(fill(cell_of(i))) = i
          fill(cell_of(i)) = fill(cell_of(i)) + 1
        end do
        do i = 1, n
          ir = mod(cell_of(i) - 1, nr)
          iz = (cell_of(i) - 1)/nr
          do jz = max(iz - 1, 0), min(iz + 1, nz - 1)
            do jr = max(ir - 1, 0), min(ir + 1, nr - 1)
              c = 1 + jr + nr*jz
              do m = cell_start(c), cell_start(c + 1) - 1
                j = item(m)
                if (j <= i) cycle
                dist = sqrt((x(1, i) - x(1, j))**2 + (x(2, i) - x(2, j))**2)
                if (dist <= reach(i) + reach(j)) call join(label, i, j)
              end do
            end do
          end do
        end do
      end if
    end if
    do i = 1, n
      label(i) = root(label, i)
    end do
  end subroutine connected_groups

  !> Root of point i's group, halving the path on the way.
  integer function root(parent, i) result(r)
    integer, intent(inout) :: parent(:)
    integer, intent(in) :: i
    r = i
    do while (parent(r) /= r)
      parent(r) = parent(parent(r))
      r = parent(r)
    end do
  end function root

  !> Merge the groups of i and j; the smaller root becomes the root.
  subroutine join(parent, i, j)
    integer, intent(inout) :: parent(:)
    integer, intent(in) :: i, j
    integer :: ri, rj
    ri = root(parent, i)
    rj = root(parent, j)
    if (ri < rj) then
      parent(rj) = ri
    else if (rj < ri) then
      parent(ri) = rj
    end if
  end subroutine join

end module fsph_groups
