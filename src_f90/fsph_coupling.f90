!> Element-particle coupling (Xiao et al. 2012 section 2.1, eqs 5-8)
!> and the ties of particles to element edges (Johnson et al.
!> 2002, as in Xiao et al. 2012 section 2.3).
!>
!>  - Elements -> particles: each element of a coupled body is an imaginary
!>    particle (mass and density of the element, position and velocity the
!>    mean of its nodes, stress of the element, h = alpha_h sqrt(A)), stored
!>    after the real particles and refilled every step; it enters the SPH
!>    sums of the real particles of its continuum as a neighbour.
!>  - Particles -> elements: each coupling-interface edge IJ receives the
!>    traction t = sigma_bar . n of the mean stress of its associated
!>    particles (n the outward normal of the element region; the printed
!>    eq 6 has index typos, this is the Cauchy traction), F = 2 pi r_bar l t,
!>    half to each node. Tied particles are left out of the mean: their
!>    whole force already goes to the edge nodes through the tie (counting
!>    both raised the Taylor energy error from +3 % to +6 %).
!>  - Ties: a tied particle moves with the point xi of its edge; its force
!>    and mass go to the edge nodes with weights (1 - xi, xi), so momentum is
!>    conserved. A particle made by conversion is tied to an edge of the
!>    remaining elements it was made next to (tie_new_particles).
!>  - Association: every particle faces at most two surface edges of its
!>    continuum's element region, the edges its reaction loads
!>    (associate_particles, which also rebuilds the coupling-edge list).
module fsph_coupling
  use fsph_kinds, only: wp, pi, two_pi
  use fsph_state, only: particle_set_t, node_set_t, element_set_t, coupling_t
  use fsph_kernel, only: kernel_support
  use fsph_neighbours, only: build_neighbours
  use fsph_topology, only: elements_with_edge
  use fsph_sph, only: imag_work_pair, imag_work_none, imag_work_edges
  implicit none
  private

  public :: fill_imaginary, coupling_tractions, tie_forces, tie_velocities, update_tie_masses
  public :: coupled_body, element_mean, element_smoothing_length
  public :: associate_particles, tie_new_particles, reaction_velocities

  !> A particle is associated with a surface edge of the element region when
  !> its centre lies within this many smoothing lengths of the edge, on its
  !> outer side [-]: the kernel support, so the particles whose mean stress
  !> loads an edge are those its elements act on through their imaginary
  !> particles. (The first particle row only, as in Xiao et al. 2012, left the
  !> energy 5.6 % high mid-run on the Taylor rod; the support, 1.6 %.)
  real(wp), parameter, public :: association_reach = kernel_support

  !> Stage of the cycle at which imaginary particles are filled.
  integer, parameter, public :: stage_select = 0 !< choose the elements, then fill at x^n
  integer, parameter, public :: stage_start = 1  !< positions x^n, velocities v^(n-1/2)
  integer, parameter, public :: stage_mid = 2    !< positions x^(n+1/2), velocities v^(n+1/2)

contains

  !> Whether the elements of body ib take part in coupling (their continuum
  !> has or may get particles).
  pure logical function coupled_body(body_coupled, ib)
    logical, intent(in) :: body_coupled(:)  !< whether each body's elements couple
    integer, intent(in) :: ib
    coupled_body = .false.
    if (ib < 1 .or. ib > size(body_coupled)) return
    coupled_body = body_coupled(ib)
  end function coupled_body

  !> Mean over element ie's three nodes of the nodal field f (2, nodes):
  !> of positions, the centroid (r, z) [m], where its imaginary particle
  !> stands; of velocities, the velocity it carries [m/s].
  pure function element_mean(f, conn, ie) result(fe)
    real(wp), intent(in) :: f(:, :)
    integer, intent(in) :: conn(:, :)   !< element nodes (3, elements)
    integer, intent(in) :: ie
    real(wp) :: fe(2)
    fe = (f(:, conn(1, ie)) + f(:, conn(2, ie)) + f(:, conn(3, ie)))/3.0_wp
  end function element_mean

  !> Smoothing length alpha_h sqrt(A) [m] of the particle that stands for
  !> an element of area A [m^2] (imaginary, or made from it by conversion).
  pure real(wp) function element_smoothing_length(alpha_h, area)
    real(wp), intent(in) :: alpha_h   !< smoothing-length factor [-]
    real(wp), intent(in) :: area      !< element area [m^2]
    element_smoothing_length = alpha_h*sqrt(max(area, 0.0_wp))
  end function element_smoothing_length

  !> Refill the imaginary particles from the elements of coupled bodies. At
  !> stage_select the elements are chosen: those of a continuum with real
  !> particles whose centroid lies within the kernel reach, plus `margin`
  !> [m] (the neighbour lists' skin), of the bounding box of those
  !> particles (an element farther away is no particle's neighbour; leaving
  !> it out keeps the neighbour grid fine and the search O(real
  !> particles)). At stage_start and stage_mid the same elements are
  !> refilled, so neighbour lists built on them stay valid.
  subroutine fill_imaginary(pt, el, nd, continuum_of_body, body_coupled, alpha_h, stage, margin)
    type(particle_set_t), intent(inout) :: pt
    type(element_set_t), intent(in) :: el
    type(node_set_t), intent(in) :: nd
    integer, intent(in) :: continuum_of_body(:)
    logical, intent(in) :: body_coupled(:)
    real(wp), intent(in) :: alpha_h
    integer, intent(in) :: stage
    real(wp), intent(in), optional :: margin
    integer :: ie, k, n0, i, c, nc
    real(wp) :: xe(2), reach, extra
    real(wp), allocatable :: lo(:, :), hi(:, :), h_max(:)
    n0 = pt%n
    if (stage == stage_select) then
      extra = 0.0_wp
      if (present(margin)) extra = margin
      nc = 0
      if (size(continuum_of_body) > 0) nc = maxval(continuum_of_body)
      allocate (lo(2, nc), hi(2, nc), h_max(nc))
      lo = huge(1.0_wp)
      hi = -huge(1.0_wp)
      h_max = -1.0_wp
      do i = 1, n0
        c = pt%continuum(i)
        lo(:, c) = min(lo(:, c), pt%x(:, i))
        hi(:, c) = max(hi(:, c), pt%x(:, i))
        h_max(c) = max(h_max(c), pt%h(i))
      end do
      k = 0
      do ie = 1, el%n
        if (.not. coupled_body(body_coupled, el%body(ie))) cycle
        c = continuum_of_body(el%body(ie))
        if (h_max(c) < 0.0_wp) cycle          ! no real particle in this continuum
        xe = element_mean(nd%x, el%conn, ie)
        reach = kernel_support*0.5_wp*(h_max(c) + element_smoothing_length(alpha_h, el%area(ie))) + extra
        if (any(xe < lo(:, c) - reach) .or. any(xe > hi(:, c) + reach)) cycle
        k = k + 1
        if (n0 + k > pt%capacity) exit
        pt%imag_elem(n0 + k) = ie
      end do
      pt%n_imag = min(k, pt%capacity - n0)
    end if
    call fill_imaginary_entries(pt, el, nd, continuum_of_body, alpha_h, n0, stage)
  end subroutine fill_imaginary

  !> Values of the imaginary entries n0+1 .. n0+n_imag (eq 5).
  subroutine fill_imaginary_entries(pt, el, nd, continuum_of_body, alpha_h, n0, stage)
    type(particle_set_t), intent(inout) :: pt
    type(element_set_t), intent(in) :: el
    type(node_set_t), intent(in) :: nd
    integer, intent(in) :: continuum_of_body(:)
    real(wp), intent(in) :: alpha_h
    integer, intent(in) :: n0, stage
    integer :: k, ie
    real(wp) :: xe(2), ve(2)
    !$omp parallel do default(none) shared(pt, el, nd, continuum_of_body, alpha_h, n0, stage) private(k, ie, xe, ve)
    do k = n0 + 1, n0 + pt%n_imag
      ie = pt%imag_elem(k)
      if (stage == stage_mid) then
        xe = element_mean(nd%x_mid, el%conn, ie)
      else
        xe = element_mean(nd%x, el%conn, ie)
      end if
      ve = element_mean(nd%v, el%conn, ie)
      pt%x(:, k) = xe
      pt%x_mid(:, k) = xe
      pt%v(:, k) = ve
      pt%v_bar(:, k) = ve
      pt%mass(k) = el%mass(ie)
      pt%rho(k) = el%rho(ie)
      pt%rho_mid(k) = el%rho(ie)
      pt%h(k) = element_smoothing_length(alpha_h, el%area(ie))
      pt%radius(k) = 0.5_wp*sqrt(el%area(ie))
      pt%c(k) = el%c(ie)
      pt%sig(:, k) = el%s(:, ie)
      pt%sig([1, 2, 4], k) = pt%sig([1, 2, 4], k) - el%p(ie)
      pt%sig_mid(:, k) = pt%sig(:, k)
      pt%continuum(k) = continuum_of_body(el%body(ie))
      pt%mat(k) = el%mat(ie)
      pt%body(k) = el%body(ie)
    end do
    !$omp end parallel do
  end subroutine fill_imaginary_entries

  !> Forces of the particles on the element region (the reaction of eq 5).
  !> A particle feels the elements through its imaginary neighbours; the
  !> reaction of that force, -m_i a_imag,i, is put on the coupling edges
  !> the particle is associated with (shared equally, half to each edge
  !> node), so particles and elements exchange action and reaction and
  !> momentum is conserved. In a uniformly stressed body the reactions of
  !> the particles along an edge add up to the traction sigma . n of eqs
  !> 6-8 (the kernel sum's deficiency at the interface), which is what the
  !> edge needs. Placing them on the nearest edge, not on the nodes of the
  !> imaginary elements (where the free-edge imbalance of the element
  !> region is not), avoids spurious loads across the element band. A
  !> tied particle's reaction is applied in tie_forces. The axial
  !> reaction of an untied particle without an associated edge (one that
  !> has crossed into the element region) is spread over the continuum's
  !> edges in proportion to their ring area.
  subroutine coupling_tractions(cp, pt, nd, continuum_of_body)
    type(coupling_t), intent(inout) :: cp
    type(particle_set_t), intent(in) :: pt
    type(node_set_t), intent(inout) :: nd
    integer, intent(in) :: continuum_of_body(:)
    integer :: i, k, slot, a, b, c, nc, n_assoc
    real(wp) :: f(2), l, rbar, share
    nc = maxval(continuum_of_body)
    ! work arrays that only grow (no allocation in an ordinary cycle)
    if (allocated(cp%edge_cont)) then
      if (size(cp%edge_cont) < cp%n_edges .or. size(cp%loose_z) < nc) deallocate (cp%edge_cont, cp%loose_z, cp%ring)
    end if
    if (.not. allocated(cp%edge_cont)) allocate (cp%edge_cont(max(cp%n_edges, 1) + 64), cp%loose_z(nc), cp%ring(nc))
    associate (loose_z => cp%loose_z(1:nc), ring => cp%ring(1:nc), edge_cont => cp%edge_cont)
    loose_z = 0.0_wp
    ring = 0.0_wp
    edge_cont(1:max(cp%n_edges, 1)) = 0
    do i = 1, pt%n
      if (pt%tie_a(i) /= 0) cycle
      f = -pt%mass(i)*pt%acc_imag(:, i)
      n_assoc = count(pt%assoc(:, i) /= 0)
      if (n_assoc == 0) then
        loose_z(pt%continuum(i)) = loose_z(pt%continuum(i)) + f(2)
        cycle
      end if
      do slot = 1, 2
        k = pt%assoc(slot, i)
        if (k == 0) cycle
        edge_cont(k) = pt%continuum(i)
        nd%f(:, cp%edge(1, k)) = nd%f(:, cp%edge(1, k)) + (0.5_wp/n_assoc)*f
        nd%f(:, cp%edge(2, k)) = nd%f(:, cp%edge(2, k)) + (0.5_wp/n_assoc)*f
      end do
    end do
    if (.not. any(loose_z /= 0.0_wp)) return
    do k = 1, cp%n_edges
      c = edge_cont(k)
      if (c == 0) cycle
      a = cp%edge(1, k)
      b = cp%edge(2, k)
      ring(c) = ring(c) + two_pi*0.5_wp*(nd%x(1, a) + nd%x(1, b))*norm2(nd%x(:, b) - nd%x(:, a))
    end do
    do k = 1, cp%n_edges
      c = edge_cont(k)
      if (c == 0) cycle
      if (.not. (ring(c) > 0.0_wp)) cycle
      a = cp%edge(1, k)
      b = cp%edge(2, k)
      l = norm2(nd%x(:, b) - nd%x(:, a))
      rbar = 0.5_wp*(nd%x(1, a) + nd%x(1, b))
      share = loose_z(c)*two_pi*rbar*l/ring(c)
      nd%f(2, a) = nd%f(2, a) + 0.5_wp*share
      nd%f(2, b) = nd%f(2, b) + 0.5_wp*share
    end do
    end associate
  end subroutine coupling_tractions

  !> How each particle's pairs with imaginary particles do work in the
  !> energy equation (fsph_sph sph_energy_rate), and the velocity of the
  !> point that takes its reaction: a tied particle none (imag_work_none);
  !> a particle with coupling edges (imag_work_edges) the mean of their
  !> nodes' velocities with the weights coupling_tractions gives them its
  !> reaction, v_now in v_react(1:2, i) and (v_before + v_now)/2 times
  !> scale in v_react(3:4, i) (the velocities at which the particles'
  !> stress and viscous work are charged); any other particle
  !> (imag_work_pair) its own share of each pair, as before the edges.
  !> With the reaction and the pair work at the same velocities, the
  !> kinetic energy the pair force and its reaction give is the heat the
  !> particle takes.
  subroutine reaction_velocities(cp, pt, v_now, v_before, scale)
    type(coupling_t), intent(inout) :: cp
    type(particle_set_t), intent(in) :: pt
    real(wp), intent(in) :: v_now(:, :)    !< nodal velocities after the kick [m/s]
    real(wp), intent(in) :: v_before(:, :) !< nodal velocities before the kick [m/s]
    real(wp), intent(in) :: scale          !< kick length over step length [-]
    integer :: i, slot, k, a, b, n_assoc
    real(wp) :: w
    if (allocated(cp%imag_work)) then
      if (size(cp%imag_work) < pt%n) deallocate (cp%imag_work, cp%v_react)
    end if
    if (.not. allocated(cp%imag_work)) allocate (cp%imag_work(max(pt%n, 1) + 64), cp%v_react(4, max(pt%n, 1) + 64))
    ! in the static blocks of the other particle loops (fsph_integrate)
    !$omp parallel do default(none) shared(cp, pt, v_now, v_before, scale) private(i, slot, k, a, b, n_assoc, w)
    do i = 1, pt%n
      cp%v_react(:, i) = 0.0_wp
      if (pt%tie_a(i) /= 0) then
        cp%imag_work(i) = imag_work_none
        cycle
      end if
      n_assoc = count(pt%assoc(:, i) /= 0)
      if (n_assoc == 0 .or. size(v_now, 2) == 0) then
        cp%imag_work(i) = imag_work_pair
        cycle
      end if
      cp%imag_work(i) = imag_work_edges
      w = 0.5_wp/n_assoc
      do slot = 1, 2
        k = pt%assoc(slot, i)
        if (k == 0) cycle
        a = cp%edge(1, k)
        b = cp%edge(2, k)
        cp%v_react(1:2, i) = cp%v_react(1:2, i) + w*(v_now(:, a) + v_now(:, b))
        cp%v_react(3:4, i) = cp%v_react(3:4, i) + w*0.5_wp*scale*(v_before(:, a) + v_now(:, a) + v_before(:, b) &
                                                                   + v_now(:, b))
      end do
    end do
    !$omp end parallel do
  end subroutine reaction_velocities

  !> Nodal masses of tied particles: (1 - xi) m_p to node a, xi m_p to b.
  subroutine update_tie_masses(pt, nd)
    type(particle_set_t), intent(in) :: pt
    type(node_set_t), intent(inout) :: nd
    integer :: i
    if (nd%n == 0) return
    nd%mass_tie = 0.0_wp
    do i = 1, pt%n
      if (pt%tie_a(i) == 0) cycle
      nd%mass_tie(pt%tie_a(i)) = nd%mass_tie(pt%tie_a(i)) + (1.0_wp - pt%tie_xi(i))*pt%mass(i)
      nd%mass_tie(pt%tie_b(i)) = nd%mass_tie(pt%tie_b(i)) + pt%tie_xi(i)*pt%mass(i)
    end do
    nd%mass_total = nd%mass + nd%mass_tie
  end subroutine update_tie_masses

  !> The force m_p a_p of each tied particle goes to its edge nodes.
  subroutine tie_forces(pt, nd)
    type(particle_set_t), intent(in) :: pt
    type(node_set_t), intent(inout) :: nd
    integer :: i
    real(wp) :: f(2)
    do i = 1, pt%n
      if (pt%tie_a(i) == 0) cycle
      ! the particle's force with the reaction of its imaginary part
      f = pt%mass(i)*(pt%acc(:, i) - pt%acc_imag(:, i))
      nd%f(:, pt%tie_a(i)) = nd%f(:, pt%tie_a(i)) + (1.0_wp - pt%tie_xi(i))*f
      nd%f(:, pt%tie_b(i)) = nd%f(:, pt%tie_b(i)) + pt%tie_xi(i)*f
    end do
  end subroutine tie_forces

  !> A tied particle takes the velocity of its edge point.
  subroutine tie_velocities(pt, nd)
    type(particle_set_t), intent(inout) :: pt
    type(node_set_t), intent(in) :: nd
    integer :: i
    do i = 1, pt%n
      if (pt%tie_a(i) == 0) cycle
      pt%v(:, i) = (1.0_wp - pt%tie_xi(i))*nd%v(:, pt%tie_a(i)) + pt%tie_xi(i)*nd%v(:, pt%tie_b(i))
    end do
  end subroutine tie_velocities

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
  integer function coupling_edge_index(cp, a, b) result(k)
    type(coupling_t), intent(inout) :: cp
    integer, intent(in) :: a, b
    integer, allocatable :: grown(:, :)
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
  end function coupling_edge_index

  !> Associate every real particle with the element-region surface edges of
  !> its continuum that it faces: edges of the elements among its imaginary
  !> neighbours (so the search is O(N)), with no element on their other side,
  !> the particle on their outer side within `reach` smoothing lengths of the
  !> edge. The two nearest are kept. A tie to an edge that is no longer on
  !> the surface is released; a tied edge is always among the associations.
  !> Rebuilds the coupling-edge list.
  subroutine associate_particles(pt, el, nd, cp, continuum_of_body, body_coupled, alpha_h, reach)
    type(particle_set_t), intent(inout) :: pt
    type(element_set_t), intent(in) :: el
    type(node_set_t), intent(in) :: nd
    type(coupling_t), intent(inout) :: cp
    integer, intent(in) :: continuum_of_body(:)
    logical, intent(in) :: body_coupled(:)
    real(wp), intent(in) :: alpha_h
    real(wp), intent(in) :: reach
    integer :: i, k, j, ie, e, a, b, n
    real(wp) :: dist, xi, best(2), t(2), nrm(2), l
    integer :: best_edge(2, 2)
    n = pt%n
    cp%n_edges = 0
    if (n == 0 .or. el%n == 0) return
    call fill_imaginary(pt, el, nd, continuum_of_body, body_coupled, alpha_h, stage_select)
    ! lists without a skin, for this search only: the cycle rebuilds its own
    call build_neighbours(n, n + pt%n_imag, pt%x, pt%h, pt%continuum, 0.0_wp, pt%search, pt%nbr_ptr, &
                         pt%nbr_list, pt%half_end, pt%low_ptr, pt%low_pair, pt%low_other, pt%cnt_ptr, &
                         pt%cnt_list)
    pt%lists_valid = .false.
    pt%radius(1:n) = 0.5_wp*sqrt(pt%mass(1:n)/(2.0_wp*pi*pt%x(1, 1:n)*pt%rho(1:n)))
    do i = 1, n
      ! release a tie whose edge left the surface
      if (pt%tie_a(i) > 0) then
        if (elements_with_edge(nd, el, pt%tie_a(i), pt%tie_b(i), 0) /= 1) then
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
          if (elements_with_edge(nd, el, a, b, ie) /= 0) cycle
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
        if (best_edge(1, e) /= 0) pt%assoc(e, i) = coupling_edge_index(cp, best_edge(1, e), best_edge(2, e))
      end do
    end do
  end subroutine associate_particles

  !> The new particles (the last size(pending, 3)) are tied to the nearer
  !> of their pending edges (edges of remaining elements they were made
  !> next to; Xiao et al. 2012 Fig. 5); associations follow in associate_particles.
  subroutine tie_new_particles(pt, nd, pending)
    type(particle_set_t), intent(inout) :: pt
    type(node_set_t), intent(in) :: nd
    integer, intent(in) :: pending(:, :, :)
    integer :: i, k, slot, n_new
    real(wp) :: dist(2), xi(2)
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
  end subroutine tie_new_particles

end module fsph_coupling
