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
!>    conserved.
module fsph_coupling
  use fsph_kinds, only: wp, two_pi
  use fsph_state, only: sim
  implicit none
  private

  public :: fill_imaginary, coupling_tractions, tie_forces, tie_velocities, update_tie_masses
  public :: coupled_body, element_mean, element_smoothing_length

  !> Stage of the cycle at which imaginary particles are filled.
  integer, parameter, public :: stage_select = 0 !< choose the elements, then fill at x^n
  integer, parameter, public :: stage_start = 1  !< positions x^n, velocities v^(n-1/2)
  integer, parameter, public :: stage_mid = 2    !< positions x^(n+1/2), velocities v^(n+1/2)

contains

  !> Whether the elements of body ib take part in coupling (their continuum
  !> has or may get particles).
  pure logical function coupled_body(ib)
    integer, intent(in) :: ib
    coupled_body = .false.
    if (.not. allocated(sim%body_coupled)) return
    if (ib < 1 .or. ib > size(sim%body_coupled)) return
    coupled_body = sim%body_coupled(ib)
  end function coupled_body

  !> Mean over element ie's three nodes of the nodal field f (2, nodes):
  !> of positions, the centroid (r, z) [m], where its imaginary particle
  !> stands; of velocities, the velocity it carries [m/s].
  pure function element_mean(f, ie) result(fe)
    real(wp), intent(in) :: f(:, :)
    integer, intent(in) :: ie
    real(wp) :: fe(2)
    fe = (f(:, sim%elements%conn(1, ie)) + f(:, sim%elements%conn(2, ie)) &
          + f(:, sim%elements%conn(3, ie)))/3.0_wp
  end function element_mean

  !> Smoothing length alpha_h sqrt(A) [m] of the particle that stands for
  !> element ie (imaginary, or made from it by conversion).
  pure real(wp) function element_smoothing_length(ie)
    integer, intent(in) :: ie
    element_smoothing_length = sim%conversion%alpha_h*sqrt(max(sim%elements%area(ie), 0.0_wp))
  end function element_smoothing_length

  !> Refill the imaginary particles from the elements of coupled bodies. At
  !> stage_select the elements are chosen: those of a continuum with real
  !> particles whose centroid lies within the kernel reach, plus `margin`
  !> [m] (the neighbour lists' skin), of the bounding box of those
  !> particles (an element farther away is no particle's neighbour; leaving
  !> it out keeps the neighbour grid fine and the search O(real
  !> particles)). At stage_start and stage_mid the same elements are
  !> refilled, so neighbour lists built on them stay valid.
  subroutine fill_imaginary(stage, margin)
    use fsph_kernel, only: kernel_support
    integer, intent(in) :: stage
    real(wp), intent(in), optional :: margin
    integer :: ie, k, n0, i, c, nc
    real(wp) :: xe(2), reach, extra
    real(wp), allocatable :: lo(:, :), hi(:, :), h_max(:)
    associate (pt => sim%particles, el => sim%elements, nd => sim%nodes)
      n0 = pt%n
      if (stage == stage_select) then
        extra = 0.0_wp
        if (present(margin)) extra = margin
        nc = 0
        if (allocated(sim%continuum_of_body)) nc = maxval(sim%continuum_of_body)
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
          if (.not. coupled_body(el%body(ie))) cycle
          c = sim%continuum_of_body(el%body(ie))
          if (h_max(c) < 0.0_wp) cycle          ! no real particle in this continuum
          xe = element_mean(nd%x, ie)
          reach = kernel_support*0.5_wp*(h_max(c) + element_smoothing_length(ie)) + extra
          if (any(xe < lo(:, c) - reach) .or. any(xe > hi(:, c) + reach)) cycle
          k = k + 1
          if (n0 + k > pt%capacity) exit
          pt%imag_elem(n0 + k) = ie
        end do
        pt%n_imag = min(k, pt%capacity - n0)
      end if
    end associate
    call fill_imaginary_entries(n0, stage)
  end subroutine fill_imaginary

  !> Values of the imaginary entries n0+1 .. n0+n_imag (eq 5).
  subroutine fill_imaginary_entries(n0, stage)
    integer, intent(in) :: n0, stage
    integer :: k, ie
    real(wp) :: xe(2), ve(2)
    !$omp parallel do default(none) shared(sim, n0, stage) private(k, ie, xe, ve)
    do k = n0 + 1, n0 + sim%particles%n_imag
      ie = sim%particles%imag_elem(k)
      associate (pt => sim%particles, el => sim%elements, nd => sim%nodes)
        if (stage == stage_mid) then
          xe = element_mean(nd%x_mid, ie)
        else
          xe = element_mean(nd%x, ie)
        end if
        ve = element_mean(nd%v, ie)
        pt%x(:, k) = xe
        pt%x_mid(:, k) = xe
        pt%v(:, k) = ve
        pt%v_bar(:, k) = ve
        pt%mass(k) = el%mass(ie)
        pt%rho(k) = el%rho(ie)
        pt%rho_mid(k) = el%rho(ie)
        pt%h(k) = element_smoothing_length(ie)
        pt%radius(k) = 0.5_wp*sqrt(el%area(ie))
        pt%c(k) = el%c(ie)
        pt%sig(:, k) = el%s(:, ie)
        pt%sig([1, 2, 4], k) = pt%sig([1, 2, 4], k) - el%p(ie)
        pt%sig_mid(:, k) = pt%sig(:, k)
        pt%continuum(k) = sim%continuum_of_body(el%body(ie))
        pt%mat(k) = el%mat(ie)
        pt%body(k) = el%body(ie)
      end associate
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
  subroutine coupling_tractions()
    integer :: i, k, slot, a, b, c, nc, n_assoc
    real(wp) :: f(2), l, rbar, share
    associate (cp => sim%coupling, pt => sim%particles, nd => sim%nodes)
      nc = maxval(sim%continuum_of_body)
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
    end associate
  end subroutine coupling_tractions

  !> Nodal masses of tied particles: (1 - xi) m_p to node a, xi m_p to b.
  subroutine update_tie_masses()
    integer :: i
    associate (pt => sim%particles, nd => sim%nodes)
      if (nd%n == 0) return
      nd%mass_tie = 0.0_wp
      do i = 1, pt%n
        if (pt%tie_a(i) == 0) cycle
        nd%mass_tie(pt%tie_a(i)) = nd%mass_tie(pt%tie_a(i)) + (1.0_wp - pt%tie_xi(i))*pt%mass(i)
        nd%mass_tie(pt%tie_b(i)) = nd%mass_tie(pt%tie_b(i)) + pt%tie_xi(i)*pt%mass(i)
      end do
      nd%mass_total = nd%mass + nd%mass_tie
    end associate
  end subroutine update_tie_masses

  !> The force m_p a_p of each tied particle goes to its edge nodes.
  subroutine tie_forces()
    integer :: i
    real(wp) :: f(2)
    associate (pt => sim%particles, nd => sim%nodes)
      do i = 1, pt%n
        if (pt%tie_a(i) == 0) cycle
        ! the particle's force with the reaction of its imaginary part
        f = pt%mass(i)*(pt%acc(:, i) - pt%acc_imag(:, i))
        nd%f(:, pt%tie_a(i)) = nd%f(:, pt%tie_a(i)) + (1.0_wp - pt%tie_xi(i))*f
        nd%f(:, pt%tie_b(i)) = nd%f(:, pt%tie_b(i)) + pt%tie_xi(i)*f
      end do
    end associate
  end subroutine tie_forces

  !> A tied particle takes the velocity of its edge point.
  subroutine tie_velocities()
    integer :: i
    associate (pt => sim%particles, nd => sim%nodes)
      do i = 1, pt%n
        if (pt%tie_a(i) == 0) cycle
        pt%v(:, i) = (1.0_wp - pt%tie_xi(i))*nd%v(:, pt%tie_a(i)) + pt%tie_xi(i)*nd%v(:, pt%tie_b(i))
      end do
    end associate
  end subroutine tie_velocities

end module fsph_coupling
