!> Neighbour lists kept across cycles (Verlet lists): the lists of
!> fsph_neighbours are built with every pair's reach widened by a skin, and
!> reused while no pair can have come within the kernel support unlisted:
!> while 2 d_max + kernel_support dh_max < skin, with d_max the largest
!> displacement since the build of a real particle or of a node of an
!> element of a coupled body (the node farthest moved bounds the centroid
!> of its elements, where an imaginary particle stands, listed or not),
!> measured from a common axial shift c_z, and dh_max the largest growth of
!> such an element's h = alpha_h sqrt(A) (a particle's h does not change).
!> Two points' separation changes by |d_i - d_j| <= |d_i - c| + |d_j - c|
!> for any common c, and a ghost across the axis (-r, z) moves with
!> (-d_r, d_z), so c = (0, c_z) bounds its pairs too; c_z is the middle of
!> the axial displacements (a projectile or a flyer in flight, translating
!> along the axis, then keeps its lists). With a rigid plane normal to the
!> axis (mirror images chosen by their particle's distance to the fixed
!> plane) c_z is 0. Rows are sorted, and entries beyond the
!> support contribute exact zeros, so the sums, and the run, are the same
!> bit for bit as with lists rebuilt every cycle (tested). A conversion,
!> an erosion or a verification hook that moves particles forces a
!> rebuild. A restart does not: the lists' books are in the checkpoint
!> (restore_lists), so a restarted run rebuilds, adapts its skin and counts
!> its builds as the run that wrote the checkpoint; only the entries are
!> built again, once, wider (restored_skin).
module fsph_verlet
  use fsph_kinds, only: wp
  use fsph_state, only: particle_set_t, node_set_t, element_set_t
  use fsph_arrays, only: reserve
  use fsph_kernel, only: kernel_support
  use fsph_coupling, only: coupled_body, element_smoothing_length
  implicit none
  private

  public :: lists_still_valid, record_lists, invalidate_lists, list_skin, adapt_skin
  public :: listed_sizes, restore_lists, restored_skin, skin_scale_max

  !> Bounds of the skin's scale over the deck's `neighbour_skin` [-], the
  !> lives (cycles) of lists below and above which it grows and shrinks,
  !> and its factor per step.
  real(wp), parameter :: skin_scale_max = 3.0_wp, skin_scale_step = 1.5_wp
  integer, parameter :: short_life = 2, long_life = 12

contains

  !> Skin for lists built now [m]: the control fraction of the smallest
  !> kernel support of the real particles, times the adapted scale (0:
  !> lists rebuilt every cycle).
  real(wp) function list_skin(pt, neighbour_skin)
    type(particle_set_t), intent(in) :: pt
    real(wp), intent(in) :: neighbour_skin
    integer :: n
    n = pt%n
    list_skin = 0.0_wp
    if (n > 0) list_skin = pt%skin_scale*neighbour_skin*kernel_support*minval(pt%h(1:n))
  end function list_skin

  !> The skin follows the flow: when lists that expired by the
  !> displacement test (not a conversion or another forced rebuild) had
  !> served short_life cycles or fewer, the next skin is skin_scale_step
  !> times wider (up to skin_scale_max times the deck's); when they served
  !> long_life cycles or more, that much narrower (down to the deck's). A
  !> wider skin lists more pairs beyond the support, which add exact
  !> zeros: the run is the same bit for bit at any skin, only its cost
  !> moves (at 5 km/s the points' spread of velocities used the deck's
  !> skin up in about a step, and the search was 30 % of a debris run).
  !> A function of the cycle history only: the same for any thread count.
  subroutine adapt_skin(pt)
    type(particle_set_t), intent(inout) :: pt
    if (pt%list_uses <= short_life) then
      pt%skin_scale = min(pt%skin_scale*skin_scale_step, skin_scale_max)
    else if (pt%list_uses >= long_life) then
      pt%skin_scale = max(pt%skin_scale/skin_scale_step, 1.0_wp)
    end if
  end subroutine adapt_skin

  !> Forget the lists: the next cycle rebuilds them.
  subroutine invalidate_lists(pt)
    type(particle_set_t), intent(inout) :: pt
    pt%lists_valid = .false.
    pt%lists_pending = .false.
  end subroutine invalidate_lists

  !> Positions of the real particles and of the nodes, the h of the
  !> elements and which nodes belong to elements of coupled bodies, at a
  !> build with skin `skin` [m].
  subroutine record_lists(pt, nd, el, body_coupled, alpha_h, skin)
    type(particle_set_t), intent(inout) :: pt
    type(node_set_t), intent(in) :: nd
    type(element_set_t), intent(in) :: el
    logical, intent(in) :: body_coupled(:)
    real(wp), intent(in) :: alpha_h
    real(wp), intent(in) :: skin
    integer :: n, ne, ie, a, k
    n = pt%n
    ne = el%n
    if (.not. allocated(pt%x_listed)) allocate (pt%x_listed(2, pt%capacity))
    pt%x_listed(:, 1:n) = pt%x(:, 1:n)
    call reserve(pt%elem_listed, max(ne, 1))
    call reserve(pt%node_listed, 2, max(nd%n, 1))
    call reserve(pt%coupled_nodes, max(nd%n, 1))
    !$omp parallel default(none) shared(pt, nd, el, alpha_h, ne) private(ie, a)
    !$omp do
    do ie = 1, ne
      pt%elem_listed(ie) = element_smoothing_length(alpha_h, el%area(ie))
    end do
    !$omp end do nowait
    !$omp do
    do a = 1, nd%n
      pt%node_listed(:, a) = nd%x(:, a)
    end do
    !$omp end do
    !$omp end parallel
    ! the coupled bodies' nodes, in index order (a node marked by its
    ! elements first, then listed)
    pt%coupled_nodes(1:nd%n) = 0
    do ie = 1, ne
      if (.not. coupled_body(body_coupled, el%body(ie))) cycle
      do a = 1, 3
        pt%coupled_nodes(el%conn(a, ie)) = 1
      end do
    end do
    k = 0
    do a = 1, nd%n
      if (pt%coupled_nodes(a) == 0) cycle
      k = k + 1
      pt%coupled_nodes(k) = a
    end do
    pt%n_coupled_nodes = k
    pt%skin = skin
    pt%n_listed = n
    pt%lists_valid = skin > 0.0_wp
    pt%n_rebuilds = pt%n_rebuilds + 1
    pt%list_uses = 0
    pt%lists_pending = .false.
  end subroutine record_lists

  !> Columns of the books a checkpoint keeps of lists that may be reused:
  !> the real particles, nodes and elements they were built at and the
  !> coupled bodies' nodes; all 0 for lists the next cycle rebuilds anyway.
  subroutine listed_sizes(pt, nd, el, n_listed, n_nodes, n_elements, n_coupled)
    type(particle_set_t), intent(in) :: pt
    type(node_set_t), intent(in) :: nd
    type(element_set_t), intent(in) :: el
    integer, intent(out) :: n_listed, n_nodes, n_elements, n_coupled
    n_listed = 0; n_nodes = 0; n_elements = 0; n_coupled = 0
    if (.not. pt%lists_valid .or. pt%n /= pt%n_listed .or. pt%n == 0) return
    n_listed = pt%n
    n_nodes = nd%n
    n_elements = el%n
    n_coupled = pt%n_coupled_nodes
  end subroutine listed_sizes

  !> A restart takes the lists' books from its checkpoint (their entries
  !> are not in it): the skin [m] and its scale [-], the builds so far and
  !> the cycles the lists have served; for lists that may be reused (n_listed
  !> > 0, listed_sizes), the real particles' and nodes' positions [m] and
  !> the elements' h [m] at their build and the coupled bodies' nodes. The
  !> next cycle then rebuilds, adapts the skin and counts builds as the run
  !> that wrote the checkpoint did; the entries of reused lists are built
  !> by it uncounted (lists_pending, restored_skin). ok is false, and
  !> nothing is changed, where the books do not fit the state.
  subroutine restore_lists(pt, nd, el, skin, skin_scale, n_rebuilds, list_uses, x_listed, node_listed, &
                           elem_listed, coupled_nodes, ok)
    type(particle_set_t), intent(inout) :: pt
    type(node_set_t), intent(in) :: nd
    type(element_set_t), intent(in) :: el
    real(wp), intent(in) :: skin, skin_scale
    integer, intent(in) :: n_rebuilds, list_uses
    real(wp), intent(in) :: x_listed(:, :), node_listed(:, :), elem_listed(:)
    integer, intent(in) :: coupled_nodes(:)
    logical, intent(out) :: ok
    integer :: n, nc
    n = size(x_listed, 2)
    nc = size(coupled_nodes)
    ok = skin >= 0.0_wp .and. skin_scale >= 1.0_wp .and. skin_scale <= skin_scale_max &
         .and. n_rebuilds >= 0 .and. list_uses >= 0
    if (n > 0) ok = ok .and. skin > 0.0_wp .and. n == pt%n .and. size(x_listed, 1) == 2 &
                    .and. size(node_listed, 1) == 2 .and. size(node_listed, 2) == nd%n &
                    .and. size(elem_listed) == el%n .and. nc <= nd%n
    if (ok .and. nc > 0) ok = minval(coupled_nodes) >= 1 .and. maxval(coupled_nodes) <= nd%n
    if (.not. ok) return
    pt%skin = skin
    pt%skin_scale = skin_scale
    pt%n_rebuilds = n_rebuilds
    pt%list_uses = list_uses
    if (n == 0) return
    if (.not. allocated(pt%x_listed)) allocate (pt%x_listed(2, pt%capacity))
    pt%x_listed(:, 1:n) = x_listed
    call reserve(pt%elem_listed, max(el%n, 1))
    call reserve(pt%node_listed, 2, max(nd%n, 1))
    call reserve(pt%coupled_nodes, max(nd%n, 1))
    pt%elem_listed(1:el%n) = elem_listed
    pt%node_listed(:, 1:nd%n) = node_listed
    pt%coupled_nodes(1:nc) = coupled_nodes
    pt%n_coupled_nodes = nc
    pt%n_listed = n
    pt%lists_valid = .true.
    pt%lists_pending = .true.
  end subroutine restore_lists

  !> Skin [m] of the entries built for restored books (restore_lists): a
  !> pair within the kernel support at a later cycle, while the books
  !> hold, has moved apart by less than the skin s since their build, and
  !> had moved by less than s from the build to now, so it is now within
  !> its support at now's h plus 2 s plus kernel_support times the
  !> largest shrinking of an element's h since the build; one s more
  !> covers rounding. The pairs beyond the support that the wider skin
  !> lists add exact zeros, as at any skin.
  real(wp) function restored_skin(pt, el, body_coupled, alpha_h)
    type(particle_set_t), intent(in) :: pt
    type(element_set_t), intent(in) :: el
    logical, intent(in) :: body_coupled(:)
    real(wp), intent(in) :: alpha_h
    integer :: ie, ne
    real(wp) :: shrink
    ne = el%n
    shrink = 0.0_wp
    !$omp parallel do default(none) shared(pt, el, body_coupled, alpha_h, ne) private(ie) reduction(max:shrink)
    do ie = 1, ne
      if (.not. coupled_body(body_coupled, el%body(ie))) cycle
      shrink = max(shrink, pt%elem_listed(ie) - element_smoothing_length(alpha_h, el%area(ie)))
    end do
    !$omp end parallel do
    restored_skin = 3.0_wp*pt%skin + kernel_support*shrink
  end function restored_skin

  !> Whether the lists of the last build still hold every pair within the
  !> kernel support (see the module header). An element's imaginary
  !> particle stands at the mean of its nodes, so it has moved, from any
  !> common shift, no farther than the farthest of its nodes: the nodes of
  !> the coupled bodies bound the imaginary particles' displacements (one
  !> pass over the nodes instead of a centroid per element).
  logical function lists_still_valid(pt, nd, el, body_coupled, alpha_h, axial_shift)
    type(particle_set_t), intent(in) :: pt
    type(node_set_t), intent(in) :: nd
    type(element_set_t), intent(in) :: el
    logical, intent(in) :: body_coupled(:)
    real(wp), intent(in) :: alpha_h
    !> displacements may be measured from a common axial shift (no rigid
    !> plane normal to the axis)
    logical, intent(in) :: axial_shift
    integer :: n, ne, ie, k, a, n_nodes
    real(wp) :: d2_max, dh_max, dz_lo, dz_hi, c_z
    lists_still_valid = .false.
    n = pt%n
    ne = el%n
    if (.not. pt%lists_valid .or. n /= pt%n_listed .or. n == 0) return
    n_nodes = pt%n_coupled_nodes
    if (ne > 0) then
      if (size(pt%elem_listed) < ne) return
    end if
    if (n_nodes > 0) then
      if (size(pt%node_listed, 2) < nd%n) return
    end if
    ! the common axial shift: the middle of the points' axial displacements
    c_z = 0.0_wp
    if (axial_shift) then
      dz_lo = huge(1.0_wp)
      dz_hi = -huge(1.0_wp)
      !$omp parallel do default(none) shared(pt, n) private(ie) reduction(min:dz_lo) reduction(max:dz_hi)
      do ie = 1, n
        dz_lo = min(dz_lo, pt%x(2, ie) - pt%x_listed(2, ie))
        dz_hi = max(dz_hi, pt%x(2, ie) - pt%x_listed(2, ie))
      end do
      !$omp end parallel do
      !$omp parallel do default(none) shared(pt, nd, n_nodes) private(k, a) &
      !$omp reduction(min:dz_lo) reduction(max:dz_hi)
      do k = 1, n_nodes
        a = pt%coupled_nodes(k)
        dz_lo = min(dz_lo, nd%x(2, a) - pt%node_listed(2, a))
        dz_hi = max(dz_hi, nd%x(2, a) - pt%node_listed(2, a))
      end do
      !$omp end parallel do
      c_z = 0.5_wp*(dz_lo + dz_hi)
    end if
    d2_max = 0.0_wp
    dh_max = 0.0_wp
    !$omp parallel do default(none) shared(pt, n, c_z) private(ie) reduction(max:d2_max)
    do ie = 1, n
      d2_max = max(d2_max, (pt%x(1, ie) - pt%x_listed(1, ie))**2 + (pt%x(2, ie) - pt%x_listed(2, ie) - c_z)**2)
    end do
    !$omp end parallel do
    !$omp parallel do default(none) shared(pt, nd, n_nodes, c_z) private(k, a) reduction(max:d2_max)
    do k = 1, n_nodes
      a = pt%coupled_nodes(k)
      d2_max = max(d2_max, (nd%x(1, a) - pt%node_listed(1, a))**2 + (nd%x(2, a) - pt%node_listed(2, a) - c_z)**2)
    end do
    !$omp end parallel do
    !$omp parallel do default(none) shared(pt, el, body_coupled, alpha_h, ne) private(ie) reduction(max:dh_max)
    do ie = 1, ne
      if (.not. coupled_body(body_coupled, el%body(ie))) cycle
      dh_max = max(dh_max, element_smoothing_length(alpha_h, el%area(ie)) - pt%elem_listed(ie))
    end do
    !$omp end parallel do
    lists_still_valid = 2.0_wp*sqrt(d2_max) + kernel_support*dh_max < pt%skin
  end function lists_still_valid

end module fsph_verlet
