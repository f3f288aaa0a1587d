!> Automatic conversion of distorted elements into particles (Xiao et al. 2012
!> section 2.3, eqs 9-13): element groups, the
!> conversion criteria, the conversion itself (mass exact, momentum to
!> round-off, the kinetic energy of the nodes' relative motion turned into
!> heat of the new particle), removal of orphan nodes, the element-region
!> surface (coupling and contact) and the association and ties of particles
!> to its edges.
module fsph_convert
  use fsph_kinds, only: wp, pi
  use fsph_state, only: sim
  use fsph_arrays, only: compact, reserve
  use fsph_material, only: equivalent_stress
  use fsph_coupling, only: coupled_body, update_tie_masses, fill_imaginary, stage_select, &
                           element_mean, element_smoothing_length
  use fsph_neighbors, only: build_neighbors
  use fsph_kernel, only: kernel_support
  use fsph_topology, only: rebuild_corner_map, nodal_masses, elements_with_edge, element_across
  use fsph_contact, only: contact_rebuild_surface
  use fsph_verlet, only: invalidate_lists
  implicit none
  private

  integer, parameter, public :: criterion_min_angle = 1
  integer, parameter, public :: criterion_plastic_strain = 2
  integer, parameter, public :: criterion_equivalent_stress = 3

  public :: assign_groups, convert_elements, associate_particles, remove_elements, remove_nodes
  public :: minimum_angle, conversion_limits

  !> A particle is associated with a surface edge of the element region when
  !> its centre lies within this many smoothing lengths of the edge, on its
  !> outer side [-]: the kernel support, so the particles whose mean stress
  !> loads an edge are those its elements act on through their imaginary
  !> particles. (The first particle row only, as in Xiao et al. 2012, left the
  !> energy 5.6 % high mid-run on the Taylor rod; the support, 1.6 %.)
  real(wp), parameter, public :: association_reach = kernel_support

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
  !> (u.w)^2 > cos_limit^2 |u|^2 |w|^2).
  pure logical function has_angle_below(xe, cos_limit) result(below)
    real(wp), intent(in) :: xe(2, 3), cos_limit
    real(wp) :: u(2), w(2), uw
    integer :: k
    below = .false.
    do k = 1, 3
      u = xe(:, modulo(k, 3) + 1) - xe(:, k)
      w = xe(:, modulo(k + 1, 3) + 1) - xe(:, k)
      uw = u(1)*w(1) + u(2)*w(2)
      if (uw > 0.0_wp .and. uw*uw > cos_limit**2*(u(1)**2 + u(2)**2)*(w(1)**2 + w(2)**2)) below = .true.
    end do
  end function has_angle_below

  !> Element groups of every coupled body from the initial mesh (eqs 9-13):
  !> Delta_s = kappa R_max, R_max = 2 alpha_h sqrt(A0) (A0 the median initial area); N_r, N_z
  !> rectangles over the body's bounding box; an element belongs to the
  !> rectangle of its initial centroid. Group indices are global.
  subroutine assign_groups()
    integer :: ib, nb, ie, nr, nz, ir, iz, offset
    real(wp) :: rmin, rmax, zmin, zmax, a_ref, ds, dr, dz, xg(2)
    logical, allocatable :: in_body(:)
    associate (el => sim%elements, nd => sim%nodes, cv => sim%conversion)
      el%group = 0
      if (el%n == 0) return
      nb = maxval(el%body)
      offset = 0
      allocate (in_body(el%n))
      do ib = 1, nb
        in_body = el%body(1:el%n) == ib
        if (.not. any(in_body)) cycle
        if (.not. coupled_body(ib)) cycle
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
          xg = element_mean(nd%x0, ie)
          ir = min(int((xg(1) - rmin)/dr) + 1, nr)
          iz = min(int((xg(2) - zmin)/dz) + 1, nz)
          el%group(ie) = offset + (iz - 1)*nr + ir
        end do
        offset = offset + nr*nz
      end do
      cv%n_groups = offset
    end associate
    call conversion_limits()
  end subroutine assign_groups

  !> The minimum-angle criterion of every element from the initial mesh:
  !> the cosine of theta_c, or, for an element that starts below theta_c
  !> (graded or mapped meshes), of theta_relative times its initial
  !> minimum angle, so the check of a cycle is one trigonometry-free test.
  subroutine conversion_limits()
    integer :: ie
    real(wp) :: xe(2, 3), cos_c
    associate (el => sim%elements, nd => sim%nodes, cv => sim%conversion)
      if (allocated(el%cos_limit)) deallocate (el%cos_limit)
      allocate (el%cos_limit(max(el%n, 1)))
      cos_c = cos(cv%theta_c)
      do ie = 1, el%n
        xe = nd%x0(:, el%conn(:, ie))
        el%cos_limit(ie) = cos_c
        if (has_angle_below(xe, cos_c)) el%cos_limit(ie) = cos(cv%theta_relative*minimum_angle(xe))
      end do
    end associate
  end subroutine conversion_limits




  !> Distance of point p from segment a-b and the parameter xi in [0, 1] of
  !> its projection.
  pure subroutine segment_projection(p, xa, xb, dist, xi)
    real(wp), intent(in) :: p(2), xa(2), xb(2)
    real(wp), intent(out) :: dist, xi
    real(wp) :: t(2), l2
    t = xb - xa
    l2 = t(1)**2 + t(2)**2
    xi = 0.0_wp
    if (l2 > 0.0_wp) xi = max(0.0_wp, min(1.0_wp, dot_product(p - xa, t)/l2))
    dist = norm2(p - (xa + xi*t))
  end subroutine segment_projection

  !> Index of coupling edge (a, b) in the list, adding it if new.
  integer function coupling_edge_index(a, b) result(k)
    integer, intent(in) :: a, b
    integer, allocatable :: grown(:, :)
    associate (cp => sim%coupling)
      do k = 1, cp%n_edges
        if (cp%edge(1, k) == a .and. cp%edge(2, k) == b) return
      end do
      if (.not. allocated(cp%edge)) allocate (cp%edge(2, 64))
      if (cp%n_edges == size(cp%edge, 2)) then
        allocate (grown(2, 2*size(cp%edge, 2)))
        grown(:, 1:cp%n_edges) = cp%edge(:, 1:cp%n_edges)
        call move_alloc(grown, cp%edge)
      end if
      cp%n_edges = cp%n_edges + 1
      k = cp%n_edges
      cp%edge(:, k) = [a, b]
    end associate
  end function coupling_edge_index

  !> Associate every real particle with the element-region surface edges of
  !> its continuum that it faces: edges of the elements among its imaginary
  !> neighbours (so the search is O(N)), with no element on their other side,
  !> the particle on their outer side within `reach` smoothing lengths of the
  !> edge. The two nearest are kept. A tie to an edge that is no longer on
  !> the surface is released; a tied edge is always among the associations.
  !> Rebuilds the coupling-edge list.
  subroutine associate_particles(reach)
    real(wp), intent(in) :: reach
    integer :: i, k, j, ie, e, a, b, n
    real(wp) :: dist, xi, best(2), t(2), nrm(2), l
    integer :: best_edge(2, 2)
    n = sim%particles%n
    sim%coupling%n_edges = 0
    if (n == 0 .or. sim%elements%n == 0) return
    call fill_imaginary(stage_select)
    associate (pt => sim%particles, el => sim%elements, nd => sim%nodes)
      ! lists without a skin, for this search only: the cycle rebuilds its own
      call build_neighbors(n, n + pt%n_imag, pt%x, pt%h, pt%continuum, 0.0_wp, pt%search, pt%nbr_ptr, &
                           pt%nbr_list, pt%half_end, pt%low_ptr, pt%low_pair, pt%low_other, pt%cnt_ptr, &
                           pt%cnt_list)
      pt%lists_valid = .false.
      pt%radius(1:n) = 0.5_wp*sqrt(pt%mass(1:n)/(2.0_wp*pi*pt%x(1, 1:n)*pt%rho(1:n)))
      do i = 1, n
        ! release a tie whose edge left the surface
        if (pt%tie_a(i) > 0) then
          if (elements_with_edge(pt%tie_a(i), pt%tie_b(i), 0) /= 1) then
            pt%tie_a(i) = 0
            pt%tie_b(i) = 0
          end if
        end if
        best = huge(1.0_wp)
        best_edge = 0
        do k = pt%nbr_ptr(i), pt%nbr_ptr(i + 1) - 1
          j = pt%nbr_list(k)
          if (j <= n) cycle                      ! real particles and mirror images
          ie = pt%imag_elem(j)
          do e = 1, 3
            a = el%conn(e, ie)
            b = el%conn(modulo(e, 3) + 1, ie)
            if (any(best_edge(1, :) == a .and. best_edge(2, :) == b)) cycle
            call segment_projection(pt%x(:, i), nd%x(:, a), nd%x(:, b), dist, xi)
            if (dist > reach*pt%h(i) .or. dist >= best(2)) cycle
            t = nd%x(:, b) - nd%x(:, a)
            l = norm2(t)
            if (l <= 0.0_wp) cycle
            nrm = [t(2), -t(1)]/l
            if (dot_product(pt%x(:, i) - nd%x(:, a), nrm) <= 0.0_wp) cycle
            if (elements_with_edge(a, b, ie) /= 0) cycle
            if (dist < best(1)) then
              best(2) = best(1); best_edge(:, 2) = best_edge(:, 1)
              best(1) = dist; best_edge(:, 1) = [a, b]
            else
              best(2) = dist; best_edge(:, 2) = [a, b]
            end if
          end do
        end do
        if (pt%tie_a(i) > 0) then
          if (.not. any(best_edge(1, :) == pt%tie_a(i) .and. best_edge(2, :) == pt%tie_b(i))) then
            if (best_edge(1, 1) == 0) then
              best_edge(:, 1) = [pt%tie_a(i), pt%tie_b(i)]
            else
              best_edge(:, 2) = [pt%tie_a(i), pt%tie_b(i)]
            end if
          end if
        end if
        pt%assoc(:, i) = 0
        do e = 1, 2
          if (best_edge(1, e) /= 0) pt%assoc(e, i) = coupling_edge_index(best_edge(1, e), best_edge(2, e))
        end do
      end do
    end associate
  end subroutine associate_particles

  !> Conversion check after the stress update: flag groups holding an
  !> element that meets the criterion, turn every element of those groups
  !> into a particle, remove orphan nodes, update the surface, associations
  !> and ties. Returns the number of elements converted.
  subroutine convert_elements(n_new)
    integer, intent(out) :: n_new
    logical, allocatable :: group_hit(:), convert(:), keep_node(:)
    integer, allocatable :: pending(:, :, :)
    integer :: ie, ng
    n_new = 0
    associate (el => sim%elements, cv => sim%conversion)
      if (.not. cv%enabled .or. el%n == 0 .or. cv%n_groups == 0) return
      ng = cv%n_groups
      ! the criterion of every element, threaded (it is checked every
      ! cycle, conversions are rare); the work array outlives the call
      call reserve(cv%hit, el%n)
      call mark_criterion()
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
      n_new = min(count(convert), sim%particles%capacity - sim%particles%n)
      allocate (pending(2, 2, n_new))
      call make_particles(convert, pending)
      call remove_elements(convert, keep_node)
      call remove_nodes(keep_node, pending)
      call rebuild_corner_map()
      call nodal_masses()
      call tie_new_particles(pending)
      call associate_particles(association_reach)
      call update_tie_masses()
      call contact_rebuild_surface()
      call invalidate_lists()
      cv%n_converted = cv%n_converted + n_new
      cv%n_events = cv%n_events + 1
    end associate
  end subroutine convert_elements

  !> conversion%hit(ie): element ie belongs to a group and meets the
  !> conversion criterion.
  subroutine mark_criterion()
    integer :: ie
    !$omp parallel do default(none) shared(sim) private(ie)
    do ie = 1, sim%elements%n
      sim%conversion%hit(ie) = sim%elements%group(ie) > 0
      if (sim%conversion%hit(ie)) sim%conversion%hit(ie) = meets_criterion(ie)
    end do
    !$omp end parallel do
  end subroutine mark_criterion

  !> Whether element ie meets the conversion criterion.
  logical function meets_criterion(ie)
    integer, intent(in) :: ie
    real(wp) :: xe(2, 3)
    associate (el => sim%elements, cv => sim%conversion)
      select case (cv%criterion)
      case (criterion_plastic_strain)
        meets_criterion = el%eps_p(ie) >= cv%eps_c
      case (criterion_equivalent_stress)
        meets_criterion = equivalent_stress(el%s(:, ie)) >= cv%sigma_c
      case default
        ! below theta_c; an element that started below theta_c (graded or
        ! mapped meshes) below theta_relative times its initial angle
        ! (conversion_limits)
        xe = sim%nodes%x(:, el%conn(:, ie))
        meets_criterion = has_angle_below(xe, el%cos_limit(ie))
      end select
    end associate
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
  subroutine make_particles(convert, pending)
    logical, intent(in) :: convert(:)
    integer, intent(out) :: pending(:, :, :)
    integer :: ie, i, k, a, b, other, slot, knew
    real(wp) :: vbar(2), dke
    pending = 0
    knew = 0
    associate (el => sim%elements, nd => sim%nodes, pt => sim%particles, cv => sim%conversion)
      do ie = 1, el%n
        if (.not. convert(ie)) cycle
        if (knew == size(pending, 3)) exit
        knew = knew + 1
        pt%n = pt%n + 1
        i = pt%n
        pt%x(:, i) = ring_centroid(nd%x(:, el%conn(:, ie)))
        pt%x0(:, i) = ring_centroid(nd%x0(:, el%conn(:, ie)))
        vbar = element_mean(nd%v, ie)
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
        pt%e(i) = el%e(ie) + dke/el%mass(ie)
        pt%temp(i) = el%temp(ie)
        pt%c(i) = el%c(ie)
        pt%d(:, i) = el%d(:, ie)
        pt%spin(i) = el%spin(ie)
        pt%grad_v(:, i) = [el%d(1, ie), el%d(3, ie) - el%spin(ie), el%d(3, ie) + el%spin(ie), el%d(2, ie)]
        pt%h(i) = element_smoothing_length(ie)
        pt%mat(i) = el%mat(ie)
        pt%body(i) = el%body(ie)
        pt%continuum(i) = sim%continuum_of_body(el%body(ie))
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
          other = element_across(a, b, ie)
          if (other == 0) cycle
          if (convert(other)) cycle
          if (slot == 2) cycle
          slot = slot + 1
          pending(:, slot, knew) = [b, a]     ! counter-clockwise in the remaining element
        end do
      end do
    end associate
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

  !> Drop converted elements; keep_node marks nodes still used.
  subroutine remove_elements(convert, keep_node)
    logical, intent(in) :: convert(:)
    logical, allocatable, intent(out) :: keep_node(:)
    logical, allocatable :: keep(:)
    integer :: ie
    associate (el => sim%elements)
      allocate (keep(el%n))
      keep = .not. convert(1:el%n)
      call compact(el%conn, keep); call compact(el%mat, keep); call compact(el%body, keep)
      call compact(el%group, keep); call compact(el%mass, keep); call compact(el%rho, keep)
      call compact(el%s, keep); call compact(el%p, keep); call compact(el%q, keep)
      call compact(el%eps_p, keep); call compact(el%e, keep); call compact(el%temp, keep)
      call compact(el%c, keep); call compact(el%area, keep); call compact(el%rbar, keep)
      call compact(el%volume, keep); call compact(el%lmin, keep); call compact(el%d, keep)
      call compact(el%spin, keep); call compact(el%hist, keep)
      if (allocated(el%cos_limit)) call compact(el%cos_limit, keep)
      el%n = count(keep)
      if (allocated(el%fc)) deallocate (el%fc)
      allocate (el%fc(2, 3, max(el%n, 1)))
      allocate (keep_node(sim%nodes%n))
      keep_node = .false.
      do ie = 1, el%n
        keep_node(el%conn(:, ie)) = .true.
      end do
    end associate
  end subroutine remove_elements

  !> Remove nodes no element uses and renumber every node reference.
  subroutine remove_nodes(keep_node, pending)
    logical, intent(in) :: keep_node(:)
    integer, intent(inout) :: pending(:, :, :)
    integer, allocatable :: new_index(:)
    integer :: a, m, i, k
    associate (nd => sim%nodes, el => sim%elements, pt => sim%particles, cp => sim%coupling)
      allocate (new_index(0:nd%n))
      new_index = 0
      m = 0
      do a = 1, nd%n
        if (.not. keep_node(a)) cycle
        m = m + 1
        new_index(a) = m
      end do
      do i = 1, el%n
        el%conn(:, i) = new_index(el%conn(:, i))
      end do
      do i = 1, pt%n
        pt%tie_a(i) = new_index(pt%tie_a(i))
        pt%tie_b(i) = new_index(pt%tie_b(i))
      end do
      do k = 1, size(pending, 3)
        pending(1, :, k) = new_index(pending(1, :, k))
        pending(2, :, k) = new_index(pending(2, :, k))
      end do
      do k = 1, cp%n_edges
        cp%edge(:, k) = new_index(cp%edge(:, k))
      end do
      call compact(nd%x, keep_node); call compact(nd%x0, keep_node); call compact(nd%v, keep_node)
      call compact(nd%f, keep_node); call compact(nd%x_old, keep_node)
      call compact(nd%x_mid, keep_node); call compact(nd%mass, keep_node)
      call compact(nd%mass_tie, keep_node); call compact(nd%mass_total, keep_node)
      call compact(nd%mass_eroded, keep_node)
      call compact(nd%on_axis, keep_node)
      nd%n = m
    end associate
  end subroutine remove_nodes


  !> The new particles (the last size(pending, 3)) are tied to the nearer
  !> of their pending edges (edges of remaining elements they were made
  !> next to; Xiao et al. 2012 Fig. 5); associations follow in associate_particles.
  subroutine tie_new_particles(pending)
    integer, intent(in) :: pending(:, :, :)
    integer :: i, k, slot, n_new
    real(wp) :: dist(2), xi(2)
    associate (pt => sim%particles, nd => sim%nodes)
      n_new = size(pending, 3)
      do k = 1, n_new
        i = pt%n - n_new + k
        dist = huge(1.0_wp)
        xi = 0.0_wp
        do slot = 1, 2
          if (pending(1, slot, k) == 0) cycle
          call segment_projection(pt%x(:, i), nd%x(:, pending(1, slot, k)), &
                                  nd%x(:, pending(2, slot, k)), dist(slot), xi(slot))
        end do
        if (pending(1, 1, k) == 0) cycle
        slot = 1
        if (dist(2) < dist(1)) slot = 2
        pt%tie_a(i) = pending(1, slot, k)
        pt%tie_b(i) = pending(2, slot, k)
        pt%tie_xi(i) = xi(slot)
      end do
    end associate
  end subroutine tie_new_particles

end module fsph_convert
