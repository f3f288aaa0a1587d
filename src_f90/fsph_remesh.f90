!> Changes of the element mesh: removal of elements (conversion, erosion)
!> and of the nodes no element uses, with the renumbering of every node
!> reference, and the one epilogue that re-derives what depends on the
!> mesh (corner map, nodal masses, contact surfaces, neighbour lists).
!> Conversion, erosion and restart call it; what they add (particles,
!> ties, books) stays with them.
module fsph_remesh
  use fsph_kinds, only: wp
  use fsph_state, only: node_set_t, element_set_t, particle_set_t, coupling_t, contact_t
  use fsph_arrays, only: compact
  use fsph_topology, only: rebuild_corner_map, nodal_masses
  use fsph_contact, only: contact_rebuild_surface
  use fsph_verlet, only: invalidate_lists
  implicit none
  private

  public :: remove_elements, remove_unused_nodes, mesh_changed

contains

  !> Drop the elements marked in `drop`, keeping the order of the others;
  !> keep_node(a) tells whether node a (of n_nodes) is still used.
  subroutine remove_elements(el, n_nodes, drop, keep_node)
    type(element_set_t), intent(inout) :: el
    integer, intent(in) :: n_nodes
    logical, intent(in) :: drop(:)
    logical, allocatable, intent(out) :: keep_node(:)
    logical, allocatable :: keep(:)
    integer :: ie, k
    allocate (keep(el%n))
    keep = .not. drop(1:el%n)
    call compact(el%conn, keep); call compact(el%mat, keep); call compact(el%body, keep)
    call compact(el%group, keep); call compact(el%id, keep); call compact(el%mass, keep)
    call compact(el%rho, keep)
    call compact(el%s, keep); call compact(el%p, keep); call compact(el%q, keep)
    call compact(el%eps_p, keep); call compact(el%e, keep); call compact(el%temp, keep)
    call compact(el%c, keep); call compact(el%area, keep); call compact(el%rbar, keep)
    call compact(el%volume, keep); call compact(el%lmin, keep); call compact(el%d, keep)
    call compact(el%spin, keep); call compact(el%hist, keep)
    if (allocated(el%cos_limit)) call compact(el%cos_limit, keep)
    el%n = count(keep)
    if (allocated(el%fc)) deallocate (el%fc)
    allocate (el%fc(2, 3, max(el%n, 1)))
    allocate (keep_node(n_nodes))
    keep_node = .false.
    ! corner by corner (a vector subscript here was a heap temporary per
    ! element at every conversion)
    do ie = 1, el%n
      do k = 1, 3
        keep_node(el%conn(k, ie)) = .true.
      end do
    end do
  end subroutine remove_elements

  !> Remove the nodes not marked in keep_node and renumber every node
  !> reference of the state: element nodes, particle ties and coupling
  !> edges. new_index(a) is node a's new number (0: removed; new_index(0)
  !> is 0), for references the caller holds.
  subroutine remove_unused_nodes(nd, el, pt, cp, keep_node, new_index)
    type(node_set_t), intent(inout) :: nd
    type(element_set_t), intent(inout) :: el
    type(particle_set_t), intent(inout) :: pt
    type(coupling_t), intent(inout) :: cp
    logical, intent(in) :: keep_node(:)
    integer, allocatable, intent(out) :: new_index(:)
    integer :: a, m, i, k
    allocate (new_index(0:nd%n))
    new_index = 0
    m = 0
    do a = 1, nd%n
      if (.not. keep_node(a)) cycle
      m = m + 1
      new_index(a) = m
    end do
    do i = 1, el%n
      do a = 1, 3
        el%conn(a, i) = new_index(el%conn(a, i))
      end do
    end do
    do i = 1, pt%n
      pt%tie_a(i) = new_index(pt%tie_a(i))
      pt%tie_b(i) = new_index(pt%tie_b(i))
    end do
    do k = 1, cp%n_edges
      cp%edge(1, k) = new_index(cp%edge(1, k))
      cp%edge(2, k) = new_index(cp%edge(2, k))
    end do
    call compact(nd%x, keep_node); call compact(nd%x0, keep_node); call compact(nd%v, keep_node)
    call compact(nd%f, keep_node); call compact(nd%x_old, keep_node)
    call compact(nd%x_mid, keep_node); call compact(nd%mass, keep_node)
    call compact(nd%mass_tie, keep_node); call compact(nd%mass_total, keep_node)
    call compact(nd%mass_eroded, keep_node)
    call compact(nd%on_axis, keep_node)
    nd%n = m
  end subroutine remove_unused_nodes

  !> After the mesh changed (set-up, conversion, erosion, restart): the
  !> node -> corner map, the lumped nodal masses, the contact surfaces;
  !> the neighbour lists are rebuilt by the next cycle.
  subroutine mesh_changed(nd, el, ct, pt, continuum_of_body)
    type(node_set_t), intent(inout) :: nd
    type(element_set_t), intent(in) :: el
    type(contact_t), intent(inout) :: ct
    type(particle_set_t), intent(inout) :: pt
    integer, intent(in) :: continuum_of_body(:)
    if (nd%n > 0) then
      call rebuild_corner_map(nd, el)
      call nodal_masses(nd, el)
    end if
    call contact_rebuild_surface(ct, el, nd, continuum_of_body)
    call invalidate_lists(pt)
  end subroutine mesh_changed

end module fsph_remesh
