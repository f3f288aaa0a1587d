!> Contact between bodies (Xiao et al. 2012 section 2.2; Hu et al. 2013 section 3.2.3):
!> element-element slide lines and particle-element contact, as
!> momentum-conserving corrections of the half-step velocities, so that
!> the predicted positions x + dt v do not interpenetrate.
!>
!>  - Surfaces: edges used by one element only (the element-region
!>    boundary, which follows conversion), without edges lying on the axis.
!>  - Slide lines, node on segment: every surface node is a slave of the
!>    segments of the other continua, so each surface is master and slave
!>    in turn (symmetric, in the manner of Johnson & Stryk 2001).
!>  - Particle on segment: a particle (radius r_p as contact thickness)
!>    against the segments of the other continua; an untied particle also
!>    against its own continuum's surface, with zero thickness (it may not
!>    cross into the element region; nearer than that, the SPH sums with
!>    the imaginary particles and the coupling tractions act).
!>  - Cases of Hu et al. 2013 fig 2: (a) one penetrated segment; (b) several: the
!>    deepest; (c) the projection falls beyond two adjacent segments: the
!>    shared node.
!>  - Correction of one pair (Hu et al. 2013 eqs 1-3), along the contact normal:
!>    dV_s = (delta/dt) / (1 + R1^2 M_s/M_1 + R2^2 M_s/M_2),
!>    dV_1 = -R1 M_s dV_s/M_1, dV_2 = -R2 M_s dV_s/M_2 (R1, R2 the linear
!>    weights of the contact point), which removes the predicted
!>    penetration delta of the pair and conserves its momentum. Pairs are
!>    corrected one after another (Gauss-Seidel, in a fixed order) in
!>    n_passes passes (Hu et al. 2013: 3-5). Optional Coulomb friction: the
!>    tangential impulse that stops the relative sliding, at most mu times
!>    the normal impulse.
!>  - A tied particle moves with its edge: its correction goes to the two
!>    edge nodes with the tie weights (effective mass of the tie point).
!>  - Search in stages: buckets (each segment registered in the cells its
!>    reach overlaps), candidates in the point's cell, a box test (the
!>    segment's box widened by its reach), distance, then the correction;
!>    O(N) per pass.
module fsph_contact
  use fsph_kinds, only: wp
  use fsph_state, only: contact_t, contact_grid_t, node_set_t, element_set_t, particle_set_t
  use fsph_arrays, only: reserve
  use fsph_layouts, only: hist_contact_work, hist_contact_allowance, hist_contact_corrected
  use fsph_boundary, only: wall_normal_velocity
  use fsph_topology, only: elements_with_edge
  use fsph_element, only: element_step
  implicit none
  private

  public :: contact_rebuild_surface, contact_correct, contact_penetration, pair_correction, contact_step_limit

  !> A point counts as penetrating a segment only down to this fraction of
  !> the segment's length below it (deeper, it belongs to the other side of
  !> the body or to another segment) [-].
  real(wp), parameter :: capture_depth = 0.5_wp

  !> Margins of find_contact's box test [-]: the box around a segment is
  !> widened beyond the exact bound by reach_margin times its reach and
  !> its size, and by coordinate_margin times the point's coordinates, far
  !> above the rounding of the distances the test stands for, so that it
  !> passes over only segments the search would have passed over.
  real(wp), parameter :: reach_margin = 1.0e-6_wp, coordinate_margin = 1.0e-12_wp

  !> Largest growth of a particle's contact thickness within one step
  !> (predicted_thickness) [-].
  real(wp), parameter :: growth_max = 1.01_wp

  !> Slave kinds.
  integer, parameter :: slave_node = 1, slave_particle = 2

  !> The contact found for one slave.
  type :: contact_pair_t
    logical :: found = .false.
    real(wp) :: delta = 0.0_wp          !< predicted penetration [m]
    real(wp) :: normal(2) = 0.0_wp      !< unit normal, from master to slave
    integer :: master(2) = 0            !< master nodes (second 0 for a node contact)
    real(wp) :: weight(2) = 0.0_wp      !< R1, R2
    real(wp) :: length = 0.0_wp         !< master segment length [m]
    integer :: segment = 0              !< the master segment
  end type contact_pair_t

contains

  !> Momentum-weighted correction of one contact pair (Hu et al. 2013 eqs 1-3):
  !> normal velocity changes [m/s] of the slave and of the two master nodes
  !> that remove the predicted penetration delta [m] in one step dt [s].
  pure subroutine pair_correction(delta, dt, m_s, m_1, m_2, r_1, r_2, dv_s, dv_1, dv_2)
    real(wp), intent(in) :: delta, dt, m_s, m_1, m_2, r_1, r_2
    real(wp), intent(out) :: dv_s, dv_1, dv_2
    real(wp) :: denominator
    denominator = 1.0_wp
    if (r_1 > 0.0_wp) denominator = denominator + r_1**2*m_s/m_1
    if (r_2 > 0.0_wp) denominator = denominator + r_2**2*m_s/m_2
    dv_s = (delta/dt)/denominator
    dv_1 = 0.0_wp
    dv_2 = 0.0_wp
    if (r_1 > 0.0_wp) dv_1 = -r_1*m_s*dv_s/m_1
    if (r_2 > 0.0_wp) dv_2 = -r_2*m_s*dv_s/m_2
  end subroutine pair_correction

  !> Surface segments and nodes of the element region, from the current
  !> mesh (after set-up, a conversion or a restart); built with contact off
  !> too, so penetration can still be measured.
  subroutine contact_rebuild_surface(ct, el, nd, continuum_of_body)
    type(contact_t), intent(inout) :: ct
    type(element_set_t), intent(in) :: el
    type(node_set_t), intent(in) :: nd
    integer, intent(in) :: continuum_of_body(:)
    integer :: ie, k, a, b, n_seg
    logical, allocatable :: on_surface(:)
    integer, allocatable :: cont_of_node(:)
    ct%n_seg = 0
    ct%n_snode = 0
    if (el%n == 0) return
    if (allocated(ct%seg)) deallocate (ct%seg, ct%seg_cont, ct%seg_elem)
    allocate (ct%seg(2, 3*el%n), ct%seg_cont(3*el%n), ct%seg_elem(3*el%n), on_surface(nd%n), cont_of_node(nd%n))
    on_surface = .false.
    cont_of_node = 0
    n_seg = 0
    do ie = 1, el%n
      do k = 1, 3
        a = el%conn(k, ie)
        b = el%conn(modulo(k, 3) + 1, ie)
        if (nd%on_axis(a) .and. nd%on_axis(b)) cycle
        if (elements_with_edge(nd, el, a, b, ie) /= 0) cycle
        n_seg = n_seg + 1
        ct%seg(:, n_seg) = [a, b]
        ct%seg_cont(n_seg) = continuum_of_body(el%body(ie))
        ct%seg_elem(n_seg) = ie
        on_surface(a) = .true.
        on_surface(b) = .true.
        cont_of_node(a) = ct%seg_cont(n_seg)
        cont_of_node(b) = ct%seg_cont(n_seg)
      end do
    end do
    ct%n_seg = n_seg
    ct%several_continua = .false.
    if (n_seg > 0) ct%several_continua = any(ct%seg_cont(1:n_seg) /= ct%seg_cont(1))
    ct%n_snode = count(on_surface)
    if (allocated(ct%snode)) deallocate (ct%snode, ct%snode_cont)
    ct%snode = pack([(a, a = 1, nd%n)], on_surface)
    ct%snode_cont = cont_of_node(ct%snode)
  end subroutine contact_rebuild_surface

  !> Predicted position x + dt v of node a [m], as the boundary conditions
  !> that act after the contact will let it move: a node on the axis keeps
  !> r = 0 (fsph_boundary apply_axis).
  pure function node_predicted(nd, a, dt) result(p)
    type(node_set_t), intent(in) :: nd
    integer, intent(in) :: a
    real(wp), intent(in) :: dt
    real(wp) :: p(2)
    p = nd%x(:, a) + dt*nd%v(:, a)
    if (nd%on_axis(a)) p(1) = nd%x(1, a)
  end function node_predicted

  !> Predicted position of particle i [m]; a tied particle moves with the
  !> tie point of its edge; a free one as the axis wall will let it move
  !> (it keeps its radius from r = 0: fsph_boundary wall_normal_velocity,
  !> the rule fsph_solver apply_boundaries applies after the contact).
  !> Without the wall in the prediction, a particle driven towards the
  !> axis was corrected against a segment for a motion it would not make.
  pure function particle_predicted(pt, nd, i, dt) result(p)
    type(particle_set_t), intent(in) :: pt
    type(node_set_t), intent(in) :: nd
    integer, intent(in) :: i
    real(wp), intent(in) :: dt
    real(wp) :: p(2), xi
    if (pt%tie_a(i) > 0) then
      xi = pt%tie_xi(i)
      p = pt%x(:, i) + dt*((1.0_wp - xi)*nd%v(:, pt%tie_a(i)) + xi*nd%v(:, pt%tie_b(i)))
    else
      p(1) = pt%x(1, i) + dt*wall_normal_velocity(pt%x(1, i) - pt%radius(i), pt%v(1, i), dt)
      p(2) = pt%x(2, i) + dt*pt%v(2, i)
    end if
  end function particle_predicted

  !> Contact thickness [m] of particle i at its predicted position p: its
  !> radius 1/2 sqrt(A) with the planar area A = m/(2 pi r rho) of its ring
  !> at the predicted radius (fsph_sph particle_radius), so a particle
  !> moving towards the axis thickens within the step it moves. At most 1 %
  !> thicker than now in one step, and r taken no smaller than the radius
  !> (the axis wall's distance), so that no step near the axis makes it jump.
  pure real(wp) function predicted_thickness(pt, i, p) result(tau)
    type(particle_set_t), intent(in) :: pt
    integer, intent(in) :: i
    real(wp), intent(in) :: p(2)
    tau = pt%radius(i)*min(sqrt(max(abs(pt%x(1, i)), pt%radius(i))/max(abs(p(1)), pt%radius(i))), growth_max)
  end function predicted_thickness

  !> The birth allowance of particle i [m] (hist_contact_allowance; 0 until
  !> measured).
  pure real(wp) function allowance_of(pt, i) result(allowance)
    type(particle_set_t), intent(in) :: pt
    integer, intent(in) :: i
    allowance = max(pt%hist(hist_contact_allowance, i), 0.0_wp)
  end function allowance_of

  !> Bucket the segments: each is registered in every cell that its reach
  !> (its predicted end points, widened by its capture depth and the
  !> largest contact thickness) overlaps, so a point looks in its own cell
  !> only. Cells as wide as the mean segment, so long segments (a graded
  !> plate's rim) do not coarsen the search near the impact.
  subroutine build_buckets(ct, nd, pt, dt)
    type(contact_t), intent(inout) :: ct
    type(node_set_t), intent(in) :: nd
    type(particle_set_t), intent(in) :: pt
    real(wp), intent(in) :: dt
    !> At most this many cells per segment (widely scattered surfaces get
    !> bigger cells instead of a huge grid) [-].
    integer, parameter :: cells_per_segment = 16
    real(wp) :: lo(2), hi(2), l_sum, r_max, xa(2), xb(2), seg_lo(2), seg_hi(2), reach
    integer :: k, ic, n_cells, n_items, ir, iz, c_lo(2), c_hi(2), pass
    r_max = 0.0_wp
    if (pt%n > 0) r_max = growth_max*maxval(pt%radius(1:pt%n))
    lo = huge(1.0_wp)
    hi = -huge(1.0_wp)
    l_sum = 0.0_wp
    do k = 1, ct%n_seg
      xa = node_predicted(nd, ct%seg(1, k), dt)
      xb = node_predicted(nd, ct%seg(2, k), dt)
      reach = capture_depth*norm2(xb - xa) + r_max
      lo = min(lo, min(xa, xb) - reach)
      hi = max(hi, max(xa, xb) + reach)
      l_sum = l_sum + norm2(xb - xa)
    end do
    ct%grid%cell = max(l_sum/ct%n_seg, 2.0_wp*r_max, tiny(1.0_wp))
    ! a non-finite position (the run is about to stop on it): no search
    ct%grid%ok = all(abs(lo) <= huge(1.0_wp)) .and. all(abs(hi) <= huge(1.0_wp)) .and. &
              all(abs(hi - lo) <= huge(1.0_wp)) .and. abs(ct%grid%cell) <= huge(1.0_wp)
    if (.not. ct%grid%ok) return
    ! the cell counts in reals until they fit: a node flung far off (a
    ! runaway the run is about to stop on) must not overflow the integers
    do
      if ((aint((hi(1) - lo(1))/ct%grid%cell) + 1.0_wp)*(aint((hi(2) - lo(2))/ct%grid%cell) + 1.0_wp) &
          <= real(cells_per_segment*ct%n_seg + 1024, wp)) exit
      ct%grid%cell = 2.0_wp*ct%grid%cell
    end do
    ct%grid%nr = int((hi(1) - lo(1))/ct%grid%cell) + 1
    ct%grid%nz = int((hi(2) - lo(2))/ct%grid%cell) + 1
    ct%grid%origin = lo
    n_cells = ct%grid%nr*ct%grid%nz
    call reserve(ct%cell_start, n_cells + 1)
    call reserve(ct%fill, n_cells + 1)
    associate (fill => ct%fill(1:n_cells + 1))
    ! two passes: count the registrations per cell, then store them
    fill = 0
    do pass = 1, 2
      do k = 1, ct%n_seg
        xa = node_predicted(nd, ct%seg(1, k), dt)
        xb = node_predicted(nd, ct%seg(2, k), dt)
        reach = capture_depth*norm2(xb - xa) + r_max
        seg_lo = min(xa, xb) - reach
        seg_hi = max(xa, xb) + reach
        c_lo = cell_coords(ct%grid, seg_lo)
        c_hi = cell_coords(ct%grid, seg_hi)
        do iz = c_lo(2), c_hi(2)
          do ir = c_lo(1), c_hi(1)
            ic = iz*ct%grid%nr + ir + 1
            if (pass == 1) then
              fill(ic + 1) = fill(ic + 1) + 1
            else
              ct%cell_items(fill(ic)) = k
              fill(ic) = fill(ic) + 1
            end if
          end do
        end do
      end do
      if (pass == 1) then
        ct%cell_start(1) = 1
        do ic = 1, n_cells
          ct%cell_start(ic + 1) = ct%cell_start(ic) + fill(ic + 1)
        end do
        n_items = ct%cell_start(n_cells + 1) - 1
        if (allocated(ct%cell_items)) then
          if (size(ct%cell_items) < n_items) deallocate (ct%cell_items)
        end if
        if (.not. allocated(ct%cell_items)) allocate (ct%cell_items(max(n_items + n_items/4, 16)))
        fill(1:n_cells) = ct%cell_start(1:n_cells)
      end if
    end do
    end associate
  end subroutine build_buckets

  !> Cell coordinates (0-based, clamped to the grid) of point p.
  pure function cell_coords(grid, p) result(c)
    type(contact_grid_t), intent(in) :: grid
    real(wp), intent(in) :: p(2)
    integer :: c(2)
    c(1) = min(max(int((p(1) - grid%origin(1))/grid%cell), 0), grid%nr - 1)
    c(2) = min(max(int((p(2) - grid%origin(2))/grid%cell), 0), grid%nz - 1)
  end function cell_coords

  !> Deepest contact of point p (predicted; p_now its current position)
  !> with thickness tau [m] (tau_now now) among the segments registered in
  !> its cell. Against other continua the thickness is less the point's
  !> allowance [m] (a particle's birth overlap, contact_correct). Segments
  !> of continuum `own` are skipped unless own_allowed (then with zero
  !> thickness); segments holding node `self` are skipped. The penetration
  !> to remove is the predicted one less any overlap that already exists (a
  !> point that came in deeper than the capture depth): an existing
  !> overlap only stops growing, it is not pushed out in one step, which
  !> would put energy in. With `whole` the whole penetration is returned
  !> (measurement).
  subroutine find_contact(ct, nd, p, p_now, tau, tau_now, allowance, own, own_allowed, self, dt, best, whole)
    type(contact_t), intent(in) :: ct
    type(node_set_t), intent(in) :: nd
    real(wp), intent(in) :: p(2), p_now(2), tau, tau_now, allowance, dt
    integer, intent(in) :: own, self
    logical, intent(in) :: own_allowed
    type(contact_pair_t), intent(out) :: best
    logical, intent(in), optional :: whole
    real(wp) :: xa(2), xb(2), t(2), nrm(2), l, s, g, delta, thick, thick_now, d, e(2), overlap, reach
    integer :: ir, iz, ic, m, k, a, b
    if (.not. ct%grid%ok) return
    if (.not. (abs(p(1)) <= huge(1.0_wp) .and. abs(p(2)) <= huge(1.0_wp))) return
    if (p(1) < ct%grid%origin(1) .or. p(2) < ct%grid%origin(2)) return
    if (p(1) >= ct%grid%origin(1) + ct%grid%nr*ct%grid%cell .or. p(2) >= ct%grid%origin(2) + ct%grid%nz*ct%grid%cell) return
    ir = min(int((p(1) - ct%grid%origin(1))/ct%grid%cell), ct%grid%nr - 1)
    iz = min(int((p(2) - ct%grid%origin(2))/ct%grid%cell), ct%grid%nz - 1)
    ic = iz*ct%grid%nr + ir + 1
    do m = ct%cell_start(ic), ct%cell_start(ic + 1) - 1
      k = ct%cell_items(m)
      a = ct%seg(1, k)
      b = ct%seg(2, k)
      if (a == self .or. b == self) cycle
      thick = tau - allowance
      thick_now = tau_now - allowance
      if (ct%seg_cont(k) == own) then
        if (.not. own_allowed) cycle
        thick = 0.0_wp
        thick_now = 0.0_wp
      end if
      xa = node_predicted(nd, a, dt)
      xb = node_predicted(nd, b, dt)
      t = xb - xa
      ! beyond every reach of the segment, passed before the square root:
      ! a contact needs the point within max(thick, capture_depth l) of
      ! the segment (case a) or within thick of an end (case c), so within
      ! the segment's box widened by that reach (l bounded by |t_r| + |t_z|,
      ! and a margin far above the rounding of the tests below)
      reach = max(thick, capture_depth*(abs(t(1)) + abs(t(2))))
      reach = reach*(1.0_wp + reach_margin) + reach_margin*(abs(t(1)) + abs(t(2))) &
              + coordinate_margin*(abs(p(1)) + abs(p(2)))
      if (p(1) < min(xa(1), xb(1)) - reach .or. p(1) > max(xa(1), xb(1)) + reach .or. &
          p(2) < min(xa(2), xb(2)) - reach .or. p(2) > max(xa(2), xb(2)) + reach) cycle
      l = norm2(t)
      if (.not. (l > 0.0_wp)) cycle
      t = t/l
      nrm = [t(2), -t(1)]           ! outward: the element region is on the left
      s = dot_product(p - xa, t)
      g = dot_product(p - xa, nrm)
      if (s >= 0.0_wp .and. s <= l) then
        ! case (a): onto the segment
        delta = thick - g
        if (delta <= 0.0_wp .or. g <= -capture_depth*l) cycle
        overlap = thick_now - gap_now(p_now, nd%x(:, a), nd%x(:, b))
        if (present(whole)) overlap = 0.0_wp
        delta = delta - max(overlap, 0.0_wp)
        if (delta <= 0.0_wp) cycle
        if (best%found .and. delta <= best%delta) cycle   ! case (b): the deepest
        best = contact_pair_t(.true., delta, nrm, [a, b], [1.0_wp - s/l, s/l], l, k)
      else if (thick > 0.0_wp .and. g > 0.0_wp) then
        ! case (c): beyond the segment's end, on its outer side: the node
        if (s < 0.0_wp) then
          e = xa
        else
          e = xb
        end if
        d = norm2(p - e)
        delta = thick - d
        if (delta <= 0.0_wp .or. .not. (d > 0.0_wp)) cycle
        overlap = thick_now - norm2(p_now - nd%x(:, merge(a, b, s < 0.0_wp)))
        if (present(whole)) overlap = 0.0_wp
        delta = delta - max(overlap, 0.0_wp)
        if (delta <= 0.0_wp) cycle
        if (best%found .and. delta <= best%delta) cycle
        best = contact_pair_t(.true., delta, (p - e)/d, [merge(a, b, s < 0.0_wp), 0], &
                              [1.0_wp, 0.0_wp], l, k)
      end if
    end do
  end subroutine find_contact

  !> Signed distance of point p from the line of segment a-b, positive on
  !> the outer side [m].
  pure real(wp) function gap_now(p, xa, xb) result(g)
    real(wp), intent(in) :: p(2), xa(2), xb(2)
    real(wp) :: t(2), l
    t = xb - xa
    l = norm2(t)
    g = 0.0_wp
    if (l > 0.0_wp) g = dot_product(p - xa, [t(2), -t(1)])/l
  end function gap_now

  !> Correct the half-step velocities of nodes and particles so that no
  !> predicted position x + dt v penetrates another body's surface, and
  !> book the work of the contact impulses. dt_v is the step of the kick
  !> that produced the velocities (mean of the two position steps) [s].
  subroutine contact_correct(ct, nd, pt, el, dt, dt_v)
    type(contact_t), intent(inout) :: ct
    type(node_set_t), intent(inout) :: nd
    type(particle_set_t), intent(inout) :: pt
    type(element_set_t), intent(inout) :: el !< its material history takes the books of its nodes' corrections
    real(wp), intent(in) :: dt, dt_v
    integer :: pass, j, a, i, n_pairs
    real(wp) :: p(2)
    type(contact_pair_t) :: pair
    ct%n_active = 0
    if (pt%n > 0) pt%hist(hist_contact_corrected, 1:pt%n) = 0.0_wp
    if (.not. ct%enabled .or. ct%n_seg == 0) return
    ! one body's surface and no particle: nothing can touch anything
    if (.not. ct%several_continua .and. pt%n == 0) return
    call keep_start_velocities(ct, nd, pt)
    call update_allowances(ct, nd, pt)
    call build_buckets(ct, nd, pt, dt)
    do pass = 1, ct%n_passes
      n_pairs = 0
      ! slide lines: surface nodes on the other continua's segments
      do j = 1, ct%n_snode
        a = ct%snode(j)
        call find_contact(ct, nd, node_predicted(nd, a, dt), nd%x(:, a), 0.0_wp, 0.0_wp, 0.0_wp, &
                          ct%snode_cont(j), .false., a, dt, pair)
        if (.not. pair%found) cycle
        call apply_pair(ct, nd, pt, pair, dt, slave_node, a)
        n_pairs = n_pairs + 1
      end do
      ! particles on segments: other continua with thickness r_p; their
      ! own continuum's surface (untied particles) with zero thickness
      do i = 1, pt%n
        p = particle_predicted(pt, nd, i, dt)
        call find_contact(ct, nd, p, pt%x(:, i), predicted_thickness(pt, i, p), pt%radius(i), allowance_of(pt, i), &
                          pt%continuum(i), ct%own_particles .and. pt%tie_a(i) == 0, 0, dt, pair)
        if (.not. pair%found) cycle
        call apply_pair(ct, nd, pt, pair, dt, slave_particle, i)
        n_pairs = n_pairs + 1
      end do
      if (pass == 1) ct%n_active = n_pairs
      if (n_pairs == 0) exit
    end do
    ct%dissipated = ct%dissipated - impulse_work(ct, nd, pt, el, dt_v)
  end subroutine contact_correct

  !> Stable step [s] (before the safety factor) of the elements that a
  !> contact is about to strike, and the element that sets it (0: none).
  !> Every surface node and particle whose predicted position x + dt v
  !> would close a gap onto another body's segment within the step dt
  !> compresses that segment's element, in the cycle it strikes, at about
  !> its closing speed over the element's smallest height, v_n/L_min; the
  !> element's stable step for that rate (fsph_element element_step, the
  !> viscosity Q of the compression included) bounds the step. Without it
  !> the step of the striking cycle is the one of the state before the
  !> impact: a copper flyer onto elements at 5.55 km/s took a 5.8 ns step
  !> that compressed the struck elements by a third, whose energy the
  !> central difference then paid back only in part over the 1-3 ns
  !> steps that followed (+1.48 % of the energy in that cycle).
  subroutine contact_step_limit(ct, nd, pt, el, dt, c_q, c_l, dt_min, icontrol)
    type(contact_t), intent(inout) :: ct   !< its buckets are rebuilt for the step dt
    type(node_set_t), intent(in) :: nd
    type(particle_set_t), intent(in) :: pt
    type(element_set_t), intent(in) :: el
    real(wp), intent(in) :: dt            !< the step about to be taken [s]
    real(wp), intent(in) :: c_q, c_l      !< the elements' viscosity coefficients [-]
    real(wp), intent(out) :: dt_min
    integer, intent(out) :: icontrol
    type(contact_pair_t) :: pair
    integer :: j, i, n_node, ie, ie_min
    real(wp) :: v_s(2), dte, dte_min, p(2)
    dt_min = huge(1.0_wp)
    icontrol = 0
    if (.not. ct%enabled .or. ct%n_seg == 0 .or. .not. (dt > 0.0_wp)) return
    ! one continuum, and no particle of another: nothing can strike it
    if (.not. ct%several_continua) then
      if (pt%n == 0) return
      if (all(pt%continuum(1:pt%n) == ct%seg_cont(1))) return
    end if
    call build_buckets(ct, nd, pt, dt)
    n_node = 0
    if (ct%several_continua) n_node = ct%n_snode
    ! slaves 1..n_node the surface nodes, then the particles; each thread
    ! keeps the least (step, element) it meets and the threads' are merged
    ! the same way: the least pair does not depend on the order, so the
    ! result does not depend on the thread count
    !$omp parallel default(none) shared(ct, nd, pt, el, dt, c_q, c_l, n_node, dt_min, icontrol) &
    !$omp private(j, i, pair, v_s, ie, dte, dte_min, ie_min, p)
    dte_min = huge(1.0_wp)
    ie_min = 0
    !$omp do schedule(dynamic, 64)
    do j = 1, n_node + pt%n
      if (j <= n_node) then
        call find_contact(ct, nd, node_predicted(nd, ct%snode(j), dt), nd%x(:, ct%snode(j)), 0.0_wp, 0.0_wp, &
                          0.0_wp, ct%snode_cont(j), .false., ct%snode(j), dt, pair)
        if (.not. pair%found) cycle
        v_s = nd%v(:, ct%snode(j))
      else
        i = j - n_node
        p = particle_predicted(pt, nd, i, dt)
        call find_contact(ct, nd, p, pt%x(:, i), predicted_thickness(pt, i, p), pt%radius(i), allowance_of(pt, i), &
                          pt%continuum(i), .false., 0, dt, pair)
        if (.not. pair%found) cycle
        if (pt%tie_a(i) > 0) then
          v_s = (1.0_wp - pt%tie_xi(i))*nd%v(:, pt%tie_a(i)) + pt%tie_xi(i)*nd%v(:, pt%tie_b(i))
        else
          v_s = pt%v(:, i)
        end if
      end if
      call strike_step(ct, nd, el, pair, v_s, c_q, c_l, dte, ie)
      if (ie > 0) call keep_least(dte, ie, dte_min, ie_min)
    end do
    !$omp end do
    !$omp critical (contact_step_merge)
    if (ie_min > 0) call keep_least(dte_min, ie_min, dt_min, icontrol)
    !$omp end critical (contact_step_merge)
    !$omp end parallel
  end subroutine contact_step_limit

  !> The struck element's step [s] at the closing speed of a slave moving
  !> at v_s [m/s] onto the master segment of `pair`, and the element (0 when
  !> the slave does not close on it).
  pure subroutine strike_step(ct, nd, el, pair, v_s, c_q, c_l, dte, ie)
    type(contact_t), intent(in) :: ct
    type(node_set_t), intent(in) :: nd
    type(element_set_t), intent(in) :: el
    type(contact_pair_t), intent(in) :: pair
    real(wp), intent(in) :: v_s(2), c_q, c_l
    real(wp), intent(out) :: dte
    integer, intent(out) :: ie
    real(wp) :: v_m(2), v_n
    dte = huge(1.0_wp)
    ie = 0
    v_m = pair%weight(1)*nd%v(:, pair%master(1))
    if (pair%master(2) > 0) v_m = v_m + pair%weight(2)*nd%v(:, pair%master(2))
    v_n = dot_product(v_m - v_s, pair%normal)     ! closing speed [m/s]
    if (.not. (v_n > 0.0_wp)) return
    ie = ct%seg_elem(pair%segment)
    dte = element_step(el%lmin(ie), el%area(ie), el%c(ie), -v_n/el%lmin(ie), c_q, c_l)
  end subroutine strike_step

  !> (dt_min, icontrol) becomes the lesser of itself and (dte, ie): the
  !> smaller step, the lower element on a tie.
  pure subroutine keep_least(dte, ie, dt_min, icontrol)
    real(wp), intent(in) :: dte
    integer, intent(in) :: ie
    real(wp), intent(inout) :: dt_min
    integer, intent(inout) :: icontrol
    if (dte < dt_min .or. (dte == dt_min .and. (ie < icontrol .or. icontrol == 0))) then
      dt_min = dte
      icontrol = ie
    end if
  end subroutine keep_least

  !> Birth allowances (hist_contact_allowance) [m]. A particle made by
  !> conversion stands at its element's ring centroid with the radius
  !> 1/2 sqrt(A) of a square cell; an element flattened against another
  !> body's surface (the plate under a flat rod tip) makes a particle whose
  !> cell overlaps that surface by up to half its radius although all its
  !> material lay on its own side. That overlap is measured in the first
  !> contact after the particle is made (allowance -1 until then) and
  !> taken off its thickness against the other continua, so the contact
  !> neither pushes it out (energy in) nor counts it as penetration; each
  !> cycle the allowance becomes the least of itself and the particle's
  !> whole overlap now (0 once it is clear), so it only ever shrinks. A
  !> particle with no allowance is not searched. The search grid is built
  !> for the current positions (and rebuilt for the step by the caller).
  subroutine update_allowances(ct, nd, pt)
    type(contact_t), intent(inout) :: ct
    type(node_set_t), intent(in) :: nd
    type(particle_set_t), intent(inout) :: pt
    type(contact_pair_t) :: pair
    integer :: i
    real(wp) :: overlap
    if (pt%n == 0) return
    if (all(pt%hist(hist_contact_allowance, 1:pt%n) == 0.0_wp)) return
    call build_buckets(ct, nd, pt, 0.0_wp)
    do i = 1, pt%n
      if (pt%hist(hist_contact_allowance, i) == 0.0_wp) cycle
      call find_contact(ct, nd, pt%x(:, i), pt%x(:, i), pt%radius(i), pt%radius(i), 0.0_wp, pt%continuum(i), &
                        .false., 0, 0.0_wp, pair, whole=.true.)
      overlap = 0.0_wp
      if (pair%found) overlap = pair%delta
      if (pt%hist(hist_contact_allowance, i) < 0.0_wp) then
        pt%hist(hist_contact_allowance, i) = overlap
      else
        pt%hist(hist_contact_allowance, i) = min(pt%hist(hist_contact_allowance, i), overlap)
      end if
    end do
  end subroutine update_allowances

  !> Velocities of nodes and free particles before the corrections.
  subroutine keep_start_velocities(ct, nd, pt)
    type(contact_t), intent(inout) :: ct
    type(node_set_t), intent(in) :: nd
    type(particle_set_t), intent(in) :: pt
    call reserve(ct%v_node0, 2, max(nd%n, 1))
    call reserve(ct%v_part0, 2, max(pt%n, 1))
    if (nd%n > 0) ct%v_node0(:, 1:nd%n) = nd%v(:, 1:nd%n)
    if (pt%n > 0) ct%v_part0(:, 1:pt%n) = pt%v(:, 1:pt%n)
  end subroutine keep_start_velocities

  !> Work of this cycle's contact impulses J = m dv [J], charged at the
  !> mean of the velocities before and after the whole kick (the measure
  !> under which the central difference balances kinetic energy against
  !> the work of the forces): surfaces that stay together do no work, an
  !> inelastic closing of a gap removes kinetic energy. Each point books
  !> the work done on it in its material history (hist_contact_work, per
  !> unit mass, for the bodies' books, fsph_solver body_budget): a free
  !> particle its own, a node's goes to the elements at its corners in
  !> proportion to the third of their mass each lumps onto it.
  real(wp) function impulse_work(ct, nd, pt, el, dt_v) result(work)
    type(contact_t), intent(in) :: ct
    type(node_set_t), intent(in) :: nd
    type(particle_set_t), intent(inout) :: pt
    type(element_set_t), intent(inout) :: el
    real(wp), intent(in) :: dt_v
    real(wp) :: dv(2), v_before(2), w, lumped
    integer :: a, i, m, ie
    work = 0.0_wp
    do a = 1, nd%n
      dv = nd%v(:, a) - ct%v_node0(:, a)
      if (dv(1) == 0.0_wp .and. dv(2) == 0.0_wp) cycle
      v_before = ct%v_node0(:, a) - (dt_v/nd%mass_total(a))*nd%f(:, a)
      w = nd%mass_total(a)*dot_product(dv, 0.5_wp*(v_before + nd%v(:, a)))
      work = work + w
      lumped = 0.0_wp
      do m = nd%corner_ptr(a), nd%corner_ptr(a + 1) - 1
        lumped = lumped + el%mass((nd%corner_list(m) - 1)/3 + 1)/3.0_wp
      end do
      if (.not. (lumped > 0.0_wp)) cycle
      do m = nd%corner_ptr(a), nd%corner_ptr(a + 1) - 1
        ie = (nd%corner_list(m) - 1)/3 + 1
        el%hist(hist_contact_work, ie) = el%hist(hist_contact_work, ie) + w/(3.0_wp*lumped)
      end do
    end do
    do i = 1, pt%n
      if (pt%tie_a(i) > 0) cycle
      dv = pt%v(:, i) - ct%v_part0(:, i)
      if (dv(1) == 0.0_wp .and. dv(2) == 0.0_wp) cycle
      v_before = ct%v_part0(:, i) - dt_v*pt%acc(:, i)
      w = dot_product(dv, 0.5_wp*(v_before + pt%v(:, i)))
      work = work + pt%mass(i)*w
      pt%hist(hist_contact_work, i) = pt%hist(hist_contact_work, i) + w
    end do
  end function impulse_work

  !> Apply the correction of one pair to the slave (node or particle; a
  !> tied particle through its edge nodes) and its master nodes.
  subroutine apply_pair(ct, nd, pt, pair, dt, kind, is)
    type(contact_t), intent(in) :: ct
    type(node_set_t), intent(inout) :: nd
    type(particle_set_t), intent(inout) :: pt
    type(contact_pair_t), intent(in) :: pair
    real(wp), intent(in) :: dt
    integer, intent(in) :: kind, is
    real(wp) :: m_s, m_1, m_2, dv_s, dv_1, dv_2, v_s(2), v_m(2), t(2), w_s(2), p_t, p_max, inv_m
    integer :: ta, tb
    ta = 0
    tb = 0
    w_s = [1.0_wp, 0.0_wp]
    if (kind == slave_node) then
      m_s = nd%mass_total(is)
    else if (pt%tie_a(is) > 0) then
      ta = pt%tie_a(is)
      tb = pt%tie_b(is)
      w_s = [1.0_wp - pt%tie_xi(is), pt%tie_xi(is)]
      m_s = 1.0_wp/(w_s(1)**2/nd%mass_total(ta) + w_s(2)**2/nd%mass_total(tb))
    else
      m_s = pt%mass(is)
      pt%hist(hist_contact_corrected, is) = 1.0_wp
    end if
    m_1 = nd%mass_total(pair%master(1))
    m_2 = 1.0_wp
    if (pair%master(2) > 0) m_2 = nd%mass_total(pair%master(2))
    call pair_correction(pair%delta, dt, m_s, m_1, m_2, pair%weight(1), pair%weight(2), &
                         dv_s, dv_1, dv_2)
    call kick_slave(nd, pt, kind, is, ta, tb, w_s, m_s, dv_s*pair%normal)
    nd%v(:, pair%master(1)) = nd%v(:, pair%master(1)) + dv_1*pair%normal
    if (pair%master(2) > 0) nd%v(:, pair%master(2)) = nd%v(:, pair%master(2)) + dv_2*pair%normal

    if (ct%friction <= 0.0_wp) return
    ! Coulomb friction: the tangential impulse that stops the relative
    ! sliding, capped by mu times the normal impulse of this correction
    t = [-pair%normal(2), pair%normal(1)]
    v_s = slave_velocity(nd, pt, kind, is, ta, tb, w_s)
    v_m = pair%weight(1)*nd%v(:, pair%master(1))
    if (pair%master(2) > 0) v_m = v_m + pair%weight(2)*nd%v(:, pair%master(2))
    inv_m = 1.0_wp/m_s + pair%weight(1)**2/m_1
    if (pair%master(2) > 0) inv_m = inv_m + pair%weight(2)**2/m_2
    p_t = dot_product(v_s - v_m, t)/inv_m
    p_max = ct%friction*m_s*abs(dv_s)
    p_t = sign(min(abs(p_t), p_max), p_t)
    call kick_slave(nd, pt, kind, is, ta, tb, w_s, m_s, -(p_t/m_s)*t)
    nd%v(:, pair%master(1)) = nd%v(:, pair%master(1)) + (pair%weight(1)*p_t/m_1)*t
    if (pair%master(2) > 0) nd%v(:, pair%master(2)) = nd%v(:, pair%master(2)) + &
                                                   (pair%weight(2)*p_t/m_2)*t
  end subroutine apply_pair

  !> Velocity change dv of a slave of effective mass m_s: a node or free
  !> particle directly; a tied particle as the impulse m_s dv shared by its
  !> edge nodes with weights w_s.
  subroutine kick_slave(nd, pt, kind, is, ta, tb, w_s, m_s, dv)
    type(node_set_t), intent(inout) :: nd
    type(particle_set_t), intent(inout) :: pt
    integer, intent(in) :: kind, is, ta, tb
    real(wp), intent(in) :: w_s(2), m_s, dv(2)
    if (kind == slave_node) then
      nd%v(:, is) = nd%v(:, is) + dv
    else if (ta > 0) then
      nd%v(:, ta) = nd%v(:, ta) + (w_s(1)*m_s/nd%mass_total(ta))*dv
      nd%v(:, tb) = nd%v(:, tb) + (w_s(2)*m_s/nd%mass_total(tb))*dv
    else
      pt%v(:, is) = pt%v(:, is) + dv
    end if
  end subroutine kick_slave

  function slave_velocity(nd, pt, kind, is, ta, tb, w_s) result(v)
    type(node_set_t), intent(in) :: nd
    type(particle_set_t), intent(in) :: pt
    integer, intent(in) :: kind, is, ta, tb
    real(wp), intent(in) :: w_s(2)
    real(wp) :: v(2)
    if (kind == slave_node) then
      v = nd%v(:, is)
    else if (ta > 0) then
      v = w_s(1)*nd%v(:, ta) + w_s(2)*nd%v(:, tb)
    else
      v = pt%v(:, is)
    end if
  end function slave_velocity

  !> Deepest interpenetration at the current positions: the largest
  !> penetration [m] of a surface node or particle (with the thickness the
  !> contact uses: a particle's radius less its birth allowance), and the
  !> same relative to the length of the segment penetrated [-] (the local
  !> element size). A particle made in the last cycle, whose allowance is
  !> measured at the next contact, has none by definition. Reads the
  !> contact state only: the search grid for the current positions is
  !> built in a copy.
  subroutine contact_penetration(ct, nd, pt, depth, relative)
    type(contact_t), intent(in) :: ct
    type(node_set_t), intent(in) :: nd
    type(particle_set_t), intent(in) :: pt
    real(wp), intent(out) :: depth, relative
    integer :: j, i
    type(contact_pair_t) :: pair
    type(contact_t) :: probe
    depth = 0.0_wp
    relative = 0.0_wp
    if (ct%n_seg == 0) return
    probe = ct
    call build_buckets(probe, nd, pt, 0.0_wp)
    do j = 1, probe%n_snode
      call find_contact(probe, nd, nd%x(:, probe%snode(j)), nd%x(:, probe%snode(j)), 0.0_wp, 0.0_wp, 0.0_wp, &
                        probe%snode_cont(j), .false., probe%snode(j), 0.0_wp, pair, whole=.true.)
      if (pair%found) call keep_deepest(pair)
    end do
    do i = 1, pt%n
      if (pt%hist(hist_contact_allowance, i) < 0.0_wp) cycle
      call find_contact(probe, nd, pt%x(:, i), pt%x(:, i), pt%radius(i), pt%radius(i), allowance_of(pt, i), &
                        pt%continuum(i), probe%own_particles .and. pt%tie_a(i) == 0, 0, 0.0_wp, pair, whole=.true.)
      if (pair%found) call keep_deepest(pair)
    end do
  contains
    subroutine keep_deepest(found)
      type(contact_pair_t), intent(in) :: found
      depth = max(depth, found%delta)
      relative = max(relative, found%delta/found%length)
    end subroutine keep_deepest
  end subroutine contact_penetration

end module fsph_contact
