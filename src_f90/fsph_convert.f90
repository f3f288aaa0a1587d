!> Automatic conversion of distorted elements into particles (Xiao et al. 2012
!> section 2.3, eqs 9-13): element groups, the
!> conversion criteria and the making of particles (mass exact, momentum to
!> round-off, the kinetic energy of the nodes' relative motion turned into
!> heat of the new particle). The mesh surgery is fsph_remesh's, the ties
!> and associations of the new particles fsph_coupling's.
module fsph_convert
  use fsph_kinds, only: wp, pi
  use fsph_state, only: node_set_t, element_set_t, particle_set_t, coupling_t, conversion_t, contact_t
  use fsph_arrays, only: reserve
  use fsph_layouts, only: criterion_plastic_strain, criterion_equivalent_stress, hist_contact_allowance, hist_contact_corrected
  use fsph_material, only: equivalent_stress
  use fsph_coupling, only: coupled_body, update_tie_masses, element_mean, element_smoothing_length, &
                           associate_particles, tie_new_particles, association_reach
  use fsph_topology, only: edge_elements
  use fsph_remesh, only: remove_elements, remove_unused_nodes, mesh_changed
  implicit none
  private

  public :: assign_groups, convert_elements
  public :: minimum_angle, conversion_limits

contains

  !> Smallest interior angle of a triangle [rad].
  pure function minimum_angle(xe) result(angle)
    real(wp), intent(in) :: xe(2, 3)
    real(wp) :: angle, u(2), w(2)
    integer :: k
    angle = pi
    do k = 1, 3
      u = xe(:, modulo(k, 3) + 1) - xe(:, k)
      w = xe(:, modulo(k + 1, 3) + 1) - xe(:, k)
      angle = min(angle, atan2(abs(u(1)*w(2) - u(2)*w(1)), u(1)*w(1) + u(2)*w(2)))
    end do
  end function minimum_angle

  !> Median of positive values a (bisection on the value: O(n log(range))).
  pure real(wp) function median(a) result(m)
    real(wp), intent(in) :: a(:)
    real(wp) :: lo, hi
    integer :: it, half
    lo = minval(a)
    hi = maxval(a)
    half = (size(a) + 1)/2
    do it = 1, 100
      m = 0.5_wp*(lo + hi)
      if (m <= lo .or. m >= hi) exit
      if (count(a <= m) >= half) then
        hi = m
      else
        lo = m
      end if
    end do
    m = hi
  end function median

  !> Whether a triangle has an interior angle below the angle whose cosine
  !> is cos_limit > 0 (the minimum-angle test without trigonometric calls or
  !> square roots: an angle below it has u.w > 0 and
  !> (u.w)^2 > cos_limit^2 |u|^2 |w|^2, u and w its two edges from the
  !> corner). The edges e_k = x_(k+1) - x_k serve all three corners (at
  !> corner k, u = e_k and w = -e_(k-1)): negation is exact, so the test is
  !> the one with each corner's own differences, to the bit.
  pure logical function has_angle_below(xe, cos_limit) result(below)
    real(wp), intent(in) :: xe(2, 3), cos_limit
    real(wp) :: e(2, 3), len2(3), uw, c2
    integer :: k, km
    do k = 1, 3
      e(:, k) = xe(:, modulo(k, 3) + 1) - xe(:, k)
      len2(k) = e(1, k)**2 + e(2, k)**2
    end do
    c2 = cos_limit**2
    below = .false.
    do k = 1, 3
      km = modulo(k + 1, 3) + 1
      uw = -(e(1, k)*e(1, km) + e(2, k)*e(2, km))
      if (uw > 0.0_wp .and. uw*uw > c2*len2(k)*len2(km)) below = .true.
    end do
  end function has_angle_below

  !> Element groups of every coupled body from the initial mesh (eqs 9-13):
  !> Delta_s = kappa R_max, R_max = 2 alpha_h sqrt(A0) (A0 the median initial area); N_r, N_z
  !> rectangles over the body's bounding box; an element belongs to the
  !> rectangle of its initial centroid. Group indices are global.
  subroutine assign_groups(el, nd, cv, body_coupled)
    type(element_set_t), intent(inout) :: el
    type(node_set_t), intent(in) :: nd
    type(conversion_t), intent(inout) :: cv
    logical, intent(in) :: body_coupled(:)
    integer :: ib, nb, ie, nr, nz, ir, iz, offset
    real(wp) :: rmin, rmax, zmin, zmax, a_ref, ds, dr, dz, xg(2)
    logical, allocatable :: in_body(:)
    el%group = 0
    if (el%n == 0) return
    nb = maxval(el%body)
    offset = 0
    allocate (in_body(el%n))
    do ib = 1, nb
      in_body = el%body(1:el%n) == ib
      if (.not. any(in_body)) cycle
      if (.not. coupled_body(body_coupled, ib)) cycle
      rmin = huge(1.0_wp); rmax = -huge(1.0_wp); zmin = huge(1.0_wp); zmax = -huge(1.0_wp)
      do ie = 1, el%n
        if (.not. in_body(ie)) cycle
        rmin = min(rmin, minval(nd%x0(1, el%conn(:, ie))))
        rmax = max(rmax, maxval(nd%x0(1, el%conn(:, ie))))
        zmin = min(zmin, minval(nd%x0(2, el%conn(:, ie))))
        zmax = max(zmax, maxval(nd%x0(2, el%conn(:, ie))))
      end do
      ! eq 9 takes the largest initial area; on a graded mesh (a plate
      ! whose rim cells are 20 times the impact zone's) that makes groups
      ! of hundreds of impact-zone elements, so the median area is used:
      ! the same on a uniform mesh
      a_ref = median(pack(el%area(1:el%n), in_body))
      ds = cv%kappa*2.0_wp*cv%alpha_h*sqrt(a_ref)
      nr = max(int((rmax - rmin)/ds), 1)
      nz = max(int((zmax - zmin)/ds), 1)
      dr = (rmax - rmin)/nr
      dz = (zmax - zmin)/nz
      do ie = 1, el%n
        if (.not. in_body(ie)) cycle
        xg = element_mean(nd%x0, el%conn, ie)
        ir = min(int((xg(1) - rmin)/dr) + 1, nr)
        iz = min(int((xg(2) - zmin)/dz) + 1, nz)
        el%group(ie) = offset + (iz - 1)*nr + ir
      end do
      offset = offset + nr*nz
    end do
    cv%n_groups = offset
    call conversion_limits(el, nd, cv)
  end subroutine assign_groups

  !> The minimum-angle criterion of every element from the initial mesh:
  !> the cosine of theta_c, or, for an element that starts below theta_c
  !> (graded or mapped meshes), of theta_relative times its initial
  !> minimum angle, so the check of a cycle is one trigonometry-free test.
  subroutine conversion_limits(el, nd, cv)
    type(element_set_t), intent(inout) :: el
    type(node_set_t), intent(in) :: nd
    type(conversion_t), intent(in) :: cv
    integer :: ie
    real(wp) :: xe(2, 3), cos_c
    if (allocated(el%cos_limit)) deallocate (el%cos_limit)
    allocate (el%cos_limit(max(el%n, 1)))
    cos_c = cos(cv%theta_c)
    do ie = 1, el%n
      xe = nd%x0(:, el%conn(:, ie))
      el%cos_limit(ie) = cos_c
      if (has_angle_below(xe, cos_c)) el%cos_limit(ie) = cos(cv%theta_relative*minimum_angle(xe))
    end do
  end subroutine conversion_limits

  !> Conversion check after the stress update: flag groups holding an
  !> element that meets the criterion, turn every element of those groups
  !> into a particle, remove orphan nodes, update the surface, associations
  !> and ties. Returns the number of elements converted.
  subroutine convert_elements(el, nd, pt, cp, cv, ct, continuum_of_body, body_coupled, n_new)
    type(element_set_t), intent(inout) :: el
    type(node_set_t), intent(inout) :: nd
    type(particle_set_t), intent(inout) :: pt
    type(coupling_t), intent(inout) :: cp
    type(conversion_t), intent(inout) :: cv
    type(contact_t), intent(inout) :: ct
    integer, intent(in) :: continuum_of_body(:)
    logical, intent(in) :: body_coupled(:)
    integer, intent(out) :: n_new
    logical, allocatable :: group_hit(:), convert(:), keep_node(:)
    integer, allocatable :: pending(:, :, :), new_index(:)
    integer :: ie, ng, k
    n_new = 0
    if (.not. cv%enabled .or. el%n == 0 .or. cv%n_groups == 0) return
    ng = cv%n_groups
    ! the criterion of every element, threaded (it is checked every
    ! cycle, conversions are rare); the work array outlives the call
    call reserve(cv%hit, el%n)
    call mark_criterion(el, nd, cv)
    if (.not. any(cv%hit(1:el%n))) return
    allocate (group_hit(ng), convert(el%n))
    group_hit = .false.
    do ie = 1, el%n
      if (cv%hit(ie)) group_hit(el%group(ie)) = .true.
    end do
    do ie = 1, el%n
      convert(ie) = .false.
      if (el%group(ie) > 0) convert(ie) = group_hit(el%group(ie))
    end do
    n_new = min(count(convert), pt%capacity - pt%n)
    allocate (pending(2, 2, n_new))
    call make_particles(el, nd, pt, cv, continuum_of_body, convert, pending)
    call remove_elements(el, nd%n, convert, keep_node)
    call remove_unused_nodes(nd, el, pt, cp, keep_node, new_index)
    do k = 1, n_new
      pending(1, :, k) = new_index(pending(1, :, k))
      pending(2, :, k) = new_index(pending(2, :, k))
    end do
    call mesh_changed(nd, el, ct, pt, continuum_of_body)
    call tie_new_particles(pt, nd, pending)
    call associate_particles(pt, el, nd, cp, continuum_of_body, body_coupled, cv%alpha_h, association_reach)
    call update_tie_masses(pt, nd)
    cv%n_converted = cv%n_converted + n_new
    cv%n_events = cv%n_events + 1
  end subroutine convert_elements

  !> conversion%hit(ie): element ie belongs to a group and meets the
  !> conversion criterion.
  subroutine mark_criterion(el, nd, cv)
    type(element_set_t), intent(in) :: el
    type(node_set_t), intent(in) :: nd
    type(conversion_t), intent(inout) :: cv
    integer :: ie
    !$omp parallel do default(none) shared(el, nd, cv) private(ie)
    do ie = 1, el%n
      cv%hit(ie) = el%group(ie) > 0
      if (cv%hit(ie)) cv%hit(ie) = meets_criterion(el, nd, cv, ie)
    end do
    !$omp end parallel do
  end subroutine mark_criterion

  !> Whether element ie meets the conversion criterion.
  logical function meets_criterion(el, nd, cv, ie)
    type(element_set_t), intent(in) :: el
    type(node_set_t), intent(in) :: nd
    type(conversion_t), intent(in) :: cv
    integer, intent(in) :: ie
    real(wp) :: xe(2, 3)
    integer :: k
    select case (cv%criterion)
    case (criterion_plastic_strain)
      meets_criterion = el%eps_p(ie) >= cv%eps_c
    case (criterion_equivalent_stress)
      meets_criterion = equivalent_stress(el%s(:, ie)) >= cv%sigma_c
    case default
      ! below theta_c; an element that started below theta_c (graded or
      ! mapped meshes) below theta_relative times its initial angle
      ! (conversion_limits)
      ! corner by corner: the vector subscript nd%x(:, el%conn(:, ie)) made
      ! gfortran allocate a temporary for every element at every cycle
      do k = 1, 3
        xe(:, k) = nd%x(:, el%conn(k, ie))
      end do
      meets_criterion = has_angle_below(xe, el%cos_limit(ie))
    end select
  end function meets_criterion

  !> Append one particle per converted element (Xiao et al. 2012: the variables of
  !> the imaginary particle): mass, density, stress, plastic strain,
  !> energy, temperature, strain rate and velocity gradient; velocity the
  !> mean of the nodes; position the centre of mass of the element's ring
  !> (ring_centroid); h = alpha_h sqrt(A). The kinetic energy of the nodes'
  !> motion relative to that mean, (m_e/3) sum |v_a - v_mean|^2 / 2,
  !> becomes heat of the particle. pending(:, slot, k) receives the (at most two) edges of the
  !> k-th converted element that border a remaining element, oriented as in
  !> that element (node pairs; 0 where none).
  subroutine make_particles(el, nd, pt, cv, continuum_of_body, convert, pending)
    type(element_set_t), intent(in) :: el
    type(node_set_t), intent(in) :: nd
    type(particle_set_t), intent(inout) :: pt
    type(conversion_t), intent(inout) :: cv
    integer, intent(in) :: continuum_of_body(:)
    logical, intent(in) :: convert(:)
    integer, intent(out) :: pending(:, :, :)
    integer :: ie, i, k, a, b, other, n_across, slot, knew
    real(wp) :: vbar(2), dke
    pending = 0
    knew = 0
    do ie = 1, el%n
      if (.not. convert(ie)) cycle
      if (knew == size(pending, 3)) exit
      knew = knew + 1
      pt%n = pt%n + 1
      i = pt%n
      pt%x(:, i) = ring_centroid(nd%x(:, el%conn(:, ie)))
      pt%x0(:, i) = ring_centroid(nd%x0(:, el%conn(:, ie)))
      vbar = element_mean(nd%v, el%conn, ie)
      dke = 0.0_wp
      do k = 1, 3
        dke = dke + 0.5_wp*(el%mass(ie)/3.0_wp)*sum((nd%v(:, el%conn(k, ie)) - vbar)**2)
      end do
      pt%v(:, i) = vbar
      pt%mass(i) = el%mass(ie)
      pt%rho(i) = el%rho(ie)
      pt%s(:, i) = el%s(:, ie)
      pt%p(i) = el%p(ie)
      pt%eps_p(i) = el%eps_p(ie)
      pt%hist(:, i) = el%hist(:, ie)
      ! its overlap with other bodies is measured at the next contact
      ! (fsph_contact, the birth allowance)
      pt%hist(hist_contact_allowance, i) = -1.0_wp
      pt%hist(hist_contact_corrected, i) = 0.0_wp
      pt%e(i) = el%e(ie) + dke/el%mass(ie)
      pt%temp(i) = el%temp(ie)
      pt%c(i) = el%c(ie)
      pt%d(:, i) = el%d(:, ie)
      pt%spin(i) = el%spin(ie)
      pt%grad_v(:, i) = [el%d(1, ie), el%d(3, ie) - el%spin(ie), el%d(3, ie) + el%spin(ie), el%d(2, ie)]
      pt%h(i) = element_smoothing_length(cv%alpha_h, el%area(ie))
      pt%mat(i) = el%mat(ie)
      pt%body(i) = el%body(ie)
      ! particles are only ever added: the n-th particle made has id n
      pt%id(i) = i
      pt%continuum(i) = continuum_of_body(el%body(ie))
      pt%acc(:, i) = 0.0_wp
      pt%tie_a(i) = 0
      pt%tie_b(i) = 0
      pt%tie_xi(i) = 0.0_wp
      pt%assoc(:, i) = 0
      cv%heat = cv%heat + dke
      slot = 0
      do k = 1, 3
        a = el%conn(k, ie)
        b = el%conn(modulo(k, 3) + 1, ie)
        call edge_elements(nd, el, a, b, ie, n_across, other)   ! the element across edge (a, b)
        if (other == 0) cycle
        if (convert(other)) cycle
        if (slot == 2) cycle
        slot = slot + 1
        pending(:, slot, knew) = [b, a]     ! counter-clockwise in the remaining element
      end do
    end do
  end subroutine make_particles

  !> Centre of mass (r, z) [m] of the ring swept by a triangle with nodes
  !> xn (2, 3), int x r dA / int r dA = (sum_a x_a r_a + 9 x_bar r_bar)/
  !> (12 r_bar) (the exact integral of a product of linear fields over a
  !> triangle): the point whose ring carries the element's mass and radial
  !> mass moment. It is the centroid for a triangle far from the axis; for
  !> one with an edge on the axis it lies at half the apex's radius, not at
  !> the centroid's third, where a particle with its mirror image across
  !> the axis heats (measured on the default Taylor case: the particles
  !> converted from those triangles reached 0.41 MJ/kg placed at the
  !> centroid, 0.27 MJ/kg at the ring's centre of mass).
  pure function ring_centroid(xn) result(xc)
    real(wp), intent(in) :: xn(2, 3)
    real(wp) :: xc(2), r_bar, x_bar(2)
    integer :: k
    r_bar = sum(xn(1, :))/3.0_wp
    x_bar = sum(xn, dim=2)/3.0_wp
    if (.not. (r_bar > 0.0_wp)) then
      xc = x_bar
      return
    end if
    do k = 1, 2
      xc(k) = (sum(xn(k, :)*xn(1, :)) + 9.0_wp*x_bar(k)*r_bar)/(12.0_wp*r_bar)
    end do
  end function ring_centroid

end module fsph_convert
