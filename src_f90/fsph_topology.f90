!> Topology of the element mesh: the node -> element corner map, lumped
!> nodal masses and edge queries. Rebuilt at set-up and whenever the mesh
!> changes (fsph_remesh).
module fsph_topology
  use fsph_kinds, only: wp
  use fsph_state, only: node_set_t, element_set_t
  implicit none
  private

  public :: rebuild_corner_map, nodal_masses, edge_elements, elements_with_edge

contains

  !> Node -> element-corner map (CSR) of the current mesh.
  subroutine rebuild_corner_map(nd, el)
    type(node_set_t), intent(inout) :: nd
    type(element_set_t), intent(in) :: el
    integer :: ie, k, a
    integer, allocatable :: fill(:)
    if (allocated(nd%corner_ptr)) deallocate (nd%corner_ptr)
    allocate (nd%corner_ptr(nd%n + 1), fill(nd%n + 1))
    fill = 0
    do ie = 1, el%n
      do k = 1, 3
        fill(el%conn(k, ie) + 1) = fill(el%conn(k, ie) + 1) + 1
      end do
    end do
    nd%corner_ptr(1) = 1
    do a = 1, nd%n
      nd%corner_ptr(a + 1) = nd%corner_ptr(a) + fill(a + 1)
    end do
    if (allocated(nd%corner_list)) deallocate (nd%corner_list)
    allocate (nd%corner_list(max(3*el%n, 1)))
    fill(1:nd%n) = nd%corner_ptr(1:nd%n)
    do ie = 1, el%n
      do k = 1, 3
        a = el%conn(k, ie)
        nd%corner_list(fill(a)) = 3*(ie - 1) + k
        fill(a) = fill(a) + 1
      end do
    end do
  end subroutine rebuild_corner_map

  !> Lumped nodal masses: 1/3 of each element's ring mass to each of its
  !> nodes (EPIC style), plus the mass inherited from eroded elements.
  subroutine nodal_masses(nd, el)
    type(node_set_t), intent(inout) :: nd
    type(element_set_t), intent(in) :: el
    integer :: ie, k
    nd%mass = nd%mass_eroded
    do ie = 1, el%n
      do k = 1, 3
        nd%mass(el%conn(k, ie)) = nd%mass(el%conn(k, ie)) + el%mass(ie)/3.0_wp
      end do
    end do
    nd%mass_total = nd%mass + nd%mass_tie
  end subroutine nodal_masses

  !> The elements other than `except` (0: none excepted) that have both
  !> nodes a and b, i.e. the edge (a, b): how many (count) and the first in
  !> the corner list of a (first, 0 if none).
  subroutine edge_elements(nd, el, a, b, except, count, first)
    type(node_set_t), intent(in) :: nd
    type(element_set_t), intent(in) :: el
    integer, intent(in) :: a, b, except
    integer, intent(out) :: count, first
    integer :: k, ie
    count = 0
    first = 0
    do k = nd%corner_ptr(a), nd%corner_ptr(a + 1) - 1
      ie = (nd%corner_list(k) - 1)/3 + 1
      if (ie == except) cycle
      if (any(el%conn(:, ie) == b)) then
        count = count + 1
        if (first == 0) first = ie
      end if
    end do
  end subroutine edge_elements

  !> Number of elements, other than `except`, that have edge (a, b)
  !> (0: a surface edge of `except`).
  integer function elements_with_edge(nd, el, a, b, except) result(count)
    type(node_set_t), intent(in) :: nd
    type(element_set_t), intent(in) :: el
    integer, intent(in) :: a, b, except
    integer :: first
    call edge_elements(nd, el, a, b, except, count, first)
  end function elements_with_edge

end module fsph_topology
