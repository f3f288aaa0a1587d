!> Total-Lagrangian particle bodies in the cycle (docs/method.md,
!> "Total-Lagrangian particles"): which particles are total-Lagrangian,
!> their reference data (fsph_tlsph: neighbour lists with mirror images
!> across the axis, kernel gradients, pair areas and hourglass
!> coefficients, corrections, planar areas), and the steps the cycle
!> calls on them, each over
!> explicit particle arrays:
!>  - total_forces (step 1): F at t^n, the first Piola-Kirchhoff stress of
!>    the Cauchy stress minus the bulk viscosity, the pairwise momentum
!>    with the hoop term, and the hourglass control; the accelerations of
!>    these particles are replaced by them (the SPH sums leave them out,
!>    fsph_neighbours);
!>  - total_rates (step 6): F at the end of the step (kept for the next
!>    force stage), at mid-step and its rate from F at both ends, L =
!>    dF/dt F^-1, so d, spin and grad_v as the updated particles carry
!>    them, and the density rate that lands exactly on rho0/J at the end
!>    of the step;
!>  - total_energy_rate (step 6): sigma_mid : d / rho_mid (= P : dF/dt /
!>    rho0), the viscous work and the hourglass forces' work as heat.
!> The material update, contact, boundaries, integration and outputs
!> treat them as any particle.
!>
!> Indexing: the kernels of fsph_tlsph run on compact arrays of the
!> total-Lagrangian particles only (k = 1 .. n), index(k) being the
!> particle; a body's particles have neighbours in their own body only.
module fsph_total
  use fsph_kinds, only: wp, two_pi
  use fsph_ordered, only: merge_minimum
  use fsph_status, only: status_ok, status_bad_input, status_inverted_element
  use fsph_tlsph, only: reference_neighbours, reference_kernel_gradients, reference_correction, &
                        reference_pair_factors, deformation_gradients, first_piola, tlsph_forces, &
                        rate_of_deformation, smallest_stretch, select_stencil, compress_rows
  implicit none
  private

  public :: total_setup, total_forces, total_rates, total_energy_rate, total_time_step, total_active

  !> The total-Lagrangian particles of a run and their reference data.
  type, public :: total_set_t
    logical, allocatable :: body_total(:) !< formulation of each body: total-Lagrangian
    real(wp) :: hourglass = 0.0_wp         !< hourglass coefficient gamma [-] (fsph_tlsph reference_pair_factors)
    logical :: selected = .false.          !< the selected-particle stencil (fsph_tlsph select_stencil), not the full support
    integer :: n = 0                       !< total-Lagrangian particles
    !> every particle of the run is total-Lagrangian, of one body, and no
    !> elements can add others: no particle pair is ever searched for
    logical :: alone = .false.
    integer, allocatable :: index(:)       !< particle of each
    integer, allocatable :: ptr(:), list(:) !< reference neighbour lists (CSR, images as -k)
    real(wp), allocatable :: x0(:, :)      !< reference positions (R, Z) [m]
    real(wp), allocatable :: h(:)          !< smoothing lengths [m]
    real(wp), allocatable :: area(:)       !< planar areas m/(2 pi R rho0) [m^2]
    real(wp), allocatable :: rho0(:)       !< reference densities [kg/m^3]
    real(wp), allocatable :: modulus(:)    !< Young's modulus at the reference state [Pa]
    real(wp), allocatable :: grad_w(:, :)  !< reference kernel gradient per entry [1/m^3]
    real(wp), allocatable :: pair_area(:)  !< 2 pi A_i A_j per entry [m^4]
    real(wp), allocatable :: hg_coef(:)    !< hourglass coefficient per entry [N/m] (fsph_tlsph reference_pair_factors)
    real(wp), allocatable :: bmat(:, :, :) !< corrections B [-]
    ! cycle work arrays
    real(wp), allocatable :: x(:, :)       !< gathered positions [m]
    logical :: f_current = .false.         !< fmat, f_tt, jac hold F at the current positions
    real(wp), allocatable :: fmat(:, :, :), f_tt(:), jac(:) !< deformation gradient at the current positions [-]
    real(wp), allocatable :: fmat_old(:, :, :), f_tt_old(:) !< at the start of the step (the force stage's) [-]
    real(wp), allocatable :: jac_mid(:)    !< J at mid-step (total_rates, for total_energy_rate) [-]
    real(wp), allocatable :: sig(:, :)     !< Cauchy stress with the viscosity [Pa]
    real(wp), allocatable :: p(:, :, :), p_tt(:) !< first Piola-Kirchhoff stress [Pa]
    real(wp), allocatable :: q_work(:, :, :) !< R P B [Pa m]
    real(wp), allocatable :: force(:, :)   !< internal force [N]
    real(wp), allocatable :: hg_pair(:, :) !< hourglass force on the row's particle per entry [N]
    real(wp), allocatable :: q(:)          !< bulk viscous pressure of the last force call [Pa]
    real(wp), allocatable :: stretch(:)    !< smallest in-plane stretch at the last force call [-]
    real(wp), allocatable :: jac_old(:)    !< J at the start of the step [-]
    logical, allocatable :: failed(:)      !< the particle had failed at the start of the step
  end type total_set_t

contains

  !> Any total-Lagrangian particle in the run.
  pure logical function total_active(ts)
    type(total_set_t), intent(in) :: ts
    total_active = ts%n > 0
  end function total_active

  !> The total-Lagrangian particles (those of bodies with body_total) and
  !> their reference data, from the particles' positions x0 [m] (the
  !> reference configuration), smoothing lengths h [m], ring masses [kg],
  !> reference densities rho0 [kg/m^3] and Young's moduli [Pa]; each body
  !> is searched on its own. ierr = status_bad_input, ifault = -particle,
  !> for a particle whose neighbours do not span the plane (fsph_tlsph
  !> reference_correction: a single row, an isolated particle).
  subroutine total_setup(ts, n, x0, h, mass, body, rho0, modulus, n_elements, ierr, ifault)
    type(total_set_t), intent(inout) :: ts
    integer, intent(in) :: n
    integer, intent(in) :: n_elements      !< elements of the run (they may turn into particles)
    real(wp), intent(in) :: x0(2, n), h(n), mass(n), rho0(n), modulus(n)
    integer, intent(in) :: body(n)
    integer, intent(out) :: ierr, ifault
    integer, allocatable :: sel(:), bptr(:), blist(:), ptr(:), list(:)
    real(wp), allocatable :: eig(:)
    integer :: b, k, m, nb, nnz, first
    logical, allocatable :: body_total(:), keep(:)
    real(wp) :: hourglass
    logical :: selected
    ierr = status_ok
    ifault = 0
    ! a fresh set (a restore sets up again), keeping the formulation
    call move_alloc(ts%body_total, body_total)
    hourglass = ts%hourglass
    selected = ts%selected
    ts = total_set_t()
    call move_alloc(body_total, ts%body_total)
    ts%hourglass = hourglass
    ts%selected = selected
    if (.not. allocated(ts%body_total)) return
    if (.not. any(ts%body_total)) return
    ts%index = pack([(k, k = 1, n)], [(tl_body(ts, body(k)), k = 1, n)])
    ts%n = size(ts%index)
    if (ts%n == 0) return
    associate (nt => ts%n, idx => ts%index)
      ts%x0 = x0(:, idx)
      ts%h = h(idx)
      ts%rho0 = rho0(idx)
      ts%modulus = modulus(idx)
      ts%area = mass(idx)/(two_pi*ts%x0(1, :)*ts%rho0)
      ! the lists of each body, one after the other, in compact numbering
      allocate (ptr(nt + 1), list(0))
      ptr(1) = 1
      do b = 1, size(ts%body_total)
        if (.not. ts%body_total(b)) cycle
        sel = pack([(k, k = 1, nt)], body(idx) == b)
        nb = size(sel)
        if (nb == 0) cycle
        allocate (bptr(nb + 1))
        call reference_neighbours(nb, ts%x0(:, sel), ts%h(sel), bptr, blist, ierr, ifault)
        if (ierr /= status_ok) then
          ifault = -idx(sel(max(ifault, 1)))
          return
        end if
        ! sel is ascending and the bodies' particles come in blocks
        first = sel(1)
        if (any(sel /= [(first + m - 1, m = 1, nb)])) then
          ierr = status_bad_input
          ifault = -idx(sel(1))
          return
        end if
        nnz = size(list)
        list = [list, merge(blist + (first - 1), blist - (first - 1), blist > 0)]
        ptr(first + 1:first + nb) = nnz + bptr(2:nb + 1)
        deallocate (bptr)
      end do
      if (ts%selected) then
        allocate (keep(size(list)))
        call select_stencil(nt, ts%x0, ptr, list, keep)
        allocate (ts%ptr(nt + 1))
        call compress_rows(nt, ptr, list, keep, ts%ptr, ts%list)
      else
        call move_alloc(ptr, ts%ptr)
        call move_alloc(list, ts%list)
      end if
      nnz = size(ts%list)
      allocate (ts%grad_w(2, nnz), ts%pair_area(nnz), ts%hg_coef(nnz), ts%bmat(2, 2, nt), eig(nt), ts%hg_pair(2, nnz))
      call reference_kernel_gradients(nt, ts%x0, ts%h, ts%ptr, ts%list, ts%grad_w)
      call reference_pair_factors(nt, ts%x0, ts%h, ts%area, ts%modulus, ts%hourglass, ts%ptr, ts%list, ts%pair_area, &
                                  ts%hg_coef)
      call reference_correction(nt, ts%x0, ts%area, ts%ptr, ts%list, ts%grad_w, ts%bmat, eig, ierr, ifault)
      if (ierr /= status_ok) then
        ifault = -idx(ifault)
        return
      end if
      allocate (ts%x(2, nt), ts%fmat(2, 2, nt), ts%f_tt(nt), ts%jac(nt), ts%sig(4, nt), ts%p(2, 2, nt), &
                ts%p_tt(nt), ts%q_work(2, 2, nt), ts%force(2, nt), ts%q(nt), ts%stretch(nt), &
                ts%fmat_old(2, 2, nt), ts%f_tt_old(nt), ts%jac_mid(nt))
      ts%q = 0.0_wp
      ts%stretch = 1.0_wp
      ts%alone = nt == n .and. n_elements == 0 .and. all(body(idx) == body(idx(1)))
      allocate (ts%jac_old(nt), ts%failed(nt))
      ts%failed = .false.
    end associate
  end subroutine total_setup

  !> Body b is total-Lagrangian.
  pure logical function tl_body(ts, b)
    type(total_set_t), intent(in) :: ts
    integer, intent(in) :: b
    tl_body = .false.
    if (b >= 1 .and. b <= size(ts%body_total)) tl_body = ts%body_total(b)
  end function tl_body

  !> Bulk viscous pressure [Pa] of a point (the elements' form,
  !> fsph_element: rho (c_q L tr d)^2 + c_l rho c L |tr d| in compression,
  !> L the particle spacing sqrt(A J_plane) [m]).
  pure elemental real(wp) function bulk_viscosity(rho, c, len, trace, c_q, c_l)
    real(wp), intent(in) :: rho, c, len, trace, c_q, c_l
    bulk_viscosity = 0.0_wp
    if (trace < 0.0_wp) bulk_viscosity = rho*(c_q*len*trace)**2 + c_l*rho*c*len*abs(trace)
  end function bulk_viscosity

  !> Step 1: the accelerations [m/s^2] of the total-Lagrangian particles at
  !> positions x (t^n) with Cauchy stress sig = s - p I, the bulk viscosity
  !> of the last step's rates d at the density rho and sound speed c, and
  !> the hourglass control. ierr/ifault: fsph_tlsph deformation_gradients
  !> (an inverted particle, ifault = -particle).
  subroutine total_forces(ts, n, x, sig, d, rho, c, mass, intact, c_q, c_l, acc, ierr, ifault)
    type(total_set_t), intent(inout) :: ts
    integer, intent(in) :: n
    real(wp), intent(in) :: x(2, n), sig(4, n), d(4, n), rho(n), c(n), mass(n)
    real(wp), intent(in) :: intact(n)      !< 1 intact, 0 failed (fsph_solver fill_intact) [-]
    real(wp), intent(in) :: c_q, c_l       !< bulk viscosity coefficients [-]
    real(wp), intent(inout) :: acc(2, n)
    integer, intent(out) :: ierr, ifault
    integer :: k, i
    ierr = status_ok
    ifault = 0
    associate (nt => ts%n, idx => ts%index)
      ts%x = x(:, idx)
      ! F at these positions: the last step's end (total_rates), else now
      ts%failed = intact(idx) < 0.5_wp
      if (.not. ts%f_current) then
        call deformation_gradients(nt, ts%x0, ts%x, ts%h, ts%area, ts%ptr, ts%list, ts%grad_w, ts%bmat, ts%fmat, &
                                   ts%f_tt, ts%jac, ierr, ifault)
        call intact_inverted(ts, ierr, ifault)
        if (ierr /= status_ok) return
        ts%f_current = .true.
      end if
      ts%fmat_old = ts%fmat
      ts%f_tt_old = ts%f_tt
      ts%jac_old = ts%jac
      !$omp parallel do default(none) schedule(static) shared(ts, sig, d, rho, c, c_q, c_l) private(k, i)
      do k = 1, ts%n
        i = ts%index(k)
        ts%stretch(k) = smallest_stretch(ts%fmat(1, 1, k), ts%fmat(2, 1, k), ts%fmat(1, 2, k), ts%fmat(2, 2, k))
        if (ts%jac(k) > 0.0_wp) then
          ts%q(k) = bulk_viscosity(rho(i), c(i), sqrt(ts%area(k)*ts%jac(k)/ts%f_tt(k)), &
                                   d(1, i) + d(2, i) + d(4, i), c_q, c_l)
          ts%sig(:, k) = sig(:, i)
          ts%sig([1, 2, 4], k) = ts%sig([1, 2, 4], k) - ts%q(k)
        else
          ! a failed particle folded over by its neighbours: no stress acts
          ts%q(k) = 0.0_wp
          ts%sig(:, k) = 0.0_wp
        end if
      end do
      !$omp end parallel do
      call first_piola(nt, ts%fmat, ts%f_tt, ts%sig, ts%p, ts%p_tt)
      call tlsph_forces(nt, ts%x0, ts%x, ts%area, ts%ptr, ts%list, ts%grad_w, ts%pair_area, ts%hg_coef, ts%bmat, &
                        ts%fmat, merge(0.0_wp, 1.0_wp, ts%failed), ts%p, ts%p_tt, ts%q_work, ts%hg_pair, ts%force)
      !$omp parallel do default(none) schedule(static) shared(ts, acc, mass) private(k)
      do k = 1, ts%n
        acc(:, ts%index(k)) = ts%force(:, k)/mass(ts%index(k))
      end do
      !$omp end parallel do
    end associate
  end subroutine total_forces

  !> Step 6, rates: F at the end of the step (x_end: it is also the next
  !> force stage's), and since F is linear in the positions and x_mid =
  !> (x_old + x_end)/2, x_end = x_old + dt v, F at mid-step and its rate
  !> over the step follow from F at its start (total_forces) and end:
  !> F_mid = (F_old + F_end)/2, dF/dt = grad0 v = (F_end - F_old)/dt (the
  !> hoop part likewise). Then the rate of deformation d, spin and grad_v
  !> of each total-Lagrangian particle (L = dF/dt F_mid^-1), and the
  !> density rate drho = (rho0/J(F_end) - rho)/dt that makes the particle
  !> update land on the density of its deformation [kg/(m^3 s)].
  !> ierr/ifault: an inverted particle (ifault = -particle).
  subroutine total_rates(ts, n, x_end, rho, dt, drho, d, spin, grad_v, ierr, ifault)
    type(total_set_t), intent(inout) :: ts
    integer, intent(in) :: n
    real(wp), intent(in) :: x_end(2, n), rho(n)
    real(wp), intent(in) :: dt             !< [s]
    real(wp), intent(inout) :: drho(n), d(4, n), spin(n), grad_v(4, n)
    integer, intent(out) :: ierr, ifault
    integer :: k, i
    real(wp) :: fmat_mid(2, 2), f_tt_mid, fdot(2, 2), fdot_tt
    associate (nt => ts%n, idx => ts%index)
      ts%x = x_end(:, idx)
      call deformation_gradients(nt, ts%x0, ts%x, ts%h, ts%area, ts%ptr, ts%list, ts%grad_w, ts%bmat, ts%fmat, &
                                 ts%f_tt, ts%jac, ierr, ifault)
      call intact_inverted(ts, ierr, ifault)
      ts%f_current = ierr == status_ok
      if (ierr /= status_ok) return
      !$omp parallel do default(none) schedule(static) shared(ts, rho, dt, drho, d, spin, grad_v) &
      !$omp private(k, i, fmat_mid, f_tt_mid, fdot, fdot_tt)
      do k = 1, ts%n
        i = ts%index(k)
        fmat_mid = 0.5_wp*(ts%fmat_old(:, :, k) + ts%fmat(:, :, k))
        f_tt_mid = 0.5_wp*(ts%f_tt_old(k) + ts%f_tt(k))
        ts%jac_mid(k) = (fmat_mid(1, 1)*fmat_mid(2, 2) - fmat_mid(1, 2)*fmat_mid(2, 1))*f_tt_mid
        fdot = (ts%fmat(:, :, k) - ts%fmat_old(:, :, k))/dt
        fdot_tt = (ts%f_tt(k) - ts%f_tt_old(k))/dt
        if (.not. ts%failed(k)) then
          drho(i) = (ts%rho0(k)/ts%jac(k) - rho(i))/dt
        else if (ts%jac_old(k) > 0.0_wp .and. ts%jac(k) > 0.0_wp) then
          ! a failed particle's density follows the change of J over the
          ! step (rho0/J of a folded-over particle has no meaning)
          drho(i) = rho(i)*(ts%jac_old(k)/ts%jac(k) - 1.0_wp)/dt
        else
          drho(i) = 0.0_wp
        end if
        if (ts%jac_mid(k) > 0.0_wp .and. ts%jac_old(k) > 0.0_wp .and. ts%jac(k) > 0.0_wp) then
          call rate_of_deformation(fmat_mid, f_tt_mid, fdot, fdot_tt, d(:, i), spin(i), grad_v(:, i))
        else
          d(:, i) = 0.0_wp
          spin(i) = 0.0_wp
          grad_v(:, i) = 0.0_wp
        end if
      end do
      !$omp end parallel do
    end associate
  end subroutine total_rates

  !> Step 6, energy: the specific internal energy rate [W/kg] of each
  !> total-Lagrangian particle, replacing the SPH sum's: the stress power
  !> sig_mid : d / rho_mid with rho_mid = rho0/J(F_mid) (total_rates must
  !> have run in this cycle: it leaves J(F_mid) and F_end in ts), the bulk viscosity's
  !> work at the mean of the pressure that pushed in this step's kick and
  !> this step's (the elements' trapezoidal rule), and half of each
  !> hourglass pair force's work at the kick's mean velocities v_bar
  !> (f_ij . (v_j - v_i)/2: the heat that balances the kinetic energy the
  !> pair gives or takes; an image pair's partner velocity is the image's,
  !> (-v_r, v_z)). de_parts(1:2) get the viscous and hourglass parts.
  subroutine total_energy_rate(ts, n, sig_mid, d, rho_end, rho_mean, c_end, v_bar, mass, c_q, c_l, de, de_parts)
    type(total_set_t), intent(in) :: ts
    integer, intent(in) :: n
    real(wp), intent(in) :: sig_mid(4, n)   !< mid-step Cauchy stress s - p I [Pa]
    real(wp), intent(in) :: d(4, n)         !< rate of deformation of the step [1/s]
    real(wp), intent(in) :: rho_end(n), c_end(n) !< density and sound speed at the end of the step
    real(wp), intent(in) :: rho_mean(n)     !< mean density over the step (a failed particle's rho_mid) [kg/m^3]
    real(wp), intent(in) :: v_bar(2, n)     !< velocity at which the kick's work is charged [m/s]
    real(wp), intent(in) :: mass(n)         !< [kg]
    real(wp), intent(in) :: c_q, c_l        !< bulk viscosity coefficients [-]
    real(wp), intent(inout) :: de(n), de_parts(3, n)
    integer :: k, i, m, j
    real(wp) :: rho_mid, trace, q_new, q_mean, power, hg, sg
    !$omp parallel do default(none) schedule(static) &
    !$omp shared(ts, sig_mid, d, rho_end, rho_mean, c_end, v_bar, mass, c_q, c_l, de, de_parts) &
    !$omp private(k, i, m, j, rho_mid, trace, q_new, q_mean, power, hg, sg)
    do k = 1, ts%n
      i = ts%index(k)
      if (ts%failed(k)) then
        rho_mid = rho_mean(i)
      else
        rho_mid = ts%rho0(k)/ts%jac_mid(k)
      end if
      trace = d(1, i) + d(2, i) + d(4, i)
      q_new = 0.0_wp
      if (ts%jac(k) > 0.0_wp) &
        q_new = bulk_viscosity(rho_end(i), c_end(i), sqrt(ts%area(k)*ts%jac(k)/ts%f_tt(k)), trace, c_q, c_l)
      q_mean = 0.5_wp*(ts%q(k) + q_new)
      power = sig_mid(1, i)*d(1, i) + sig_mid(2, i)*d(2, i) + 2.0_wp*sig_mid(3, i)*d(3, i) &
              + sig_mid(4, i)*d(4, i)
      hg = 0.0_wp
      do m = ts%ptr(k), ts%ptr(k + 1) - 1
        ! an image's velocity is (-v_r, v_z)
        j = ts%index(abs(ts%list(m)))
        sg = merge(-1.0_wp, 1.0_wp, ts%list(m) < 0)
        hg = hg + 0.5_wp*(ts%hg_pair(1, m)*(sg*v_bar(1, j) - v_bar(1, i)) &
                          + ts%hg_pair(2, m)*(v_bar(2, j) - v_bar(2, i)))
      end do
      de_parts(1, i) = -q_mean*trace/rho_mid
      de_parts(2, i) = hg/mass(i)
      de(i) = power/rho_mid + de_parts(1, i) + de_parts(2, i)
    end do
    !$omp end parallel do
  end subroutine total_energy_rate

  !> Stable step of the total-Lagrangian particles [s]: the smoothing
  !> length shrunk by the smallest in-plane stretch, over the sound speed
  !> raised by the bulk viscosity plus the speed, as the elements'
  !> (fsph_element element_time_step); icontrol the particle that sets it.
  subroutine total_time_step(ts, n, c, v, d, c_q, c_l, dt_min, icontrol)
    type(total_set_t), intent(in) :: ts
    integer, intent(in) :: n
    real(wp), intent(in) :: c(n), v(2, n), d(4, n), c_q, c_l
    real(wp), intent(out) :: dt_min
    integer, intent(out) :: icontrol
    integer :: k, i, t_i
    real(wp) :: len, trace, cv, dtk, t_min
    dt_min = huge(1.0_wp)
    icontrol = 0
    ! per-thread minima merged to the lowest particle among equal values,
    ! as a serial scan finds it
    !$omp parallel default(none) shared(ts, c, v, d, c_q, c_l, dt_min, icontrol) &
    !$omp private(k, i, len, trace, cv, dtk, t_min, t_i)
    t_min = huge(1.0_wp)
    t_i = 0
    !$omp do schedule(static)
    do k = 1, ts%n
      ! a failed particle: the particles' step h/(c + |v|) of fsph_sph
      if (ts%failed(k)) cycle
      i = ts%index(k)
      len = ts%h(k)*ts%stretch(k)
      trace = d(1, i) + d(2, i) + d(4, i)
      cv = c(i)
      if (trace < 0.0_wp) cv = cv + c_l*c(i) + c_q**2*len*abs(trace)
      dtk = len/(cv + sqrt(v(1, i)**2 + v(2, i)**2))
      if (dtk < t_min) then
        t_min = dtk
        t_i = i
      end if
    end do
    !$omp end do
    !$omp critical (total_step_minimum)
    call merge_minimum(t_min, t_i, dt_min, icontrol)
    !$omp end critical (total_step_minimum)
    !$omp end parallel
  end subroutine total_time_step

  !> The lowest intact particle whose J is not positive (ierr =
  !> status_inverted_element, ifault = -particle); a failed particle may
  !> fold over (it carries no tension: its neighbours can close over it).
  subroutine intact_inverted(ts, ierr, ifault)
    type(total_set_t), intent(in) :: ts
    integer, intent(out) :: ierr
    integer, intent(out) :: ifault
    integer :: k
    ierr = status_ok
    ifault = 0
    do k = 1, ts%n
      if (ts%jac(k) > 0.0_wp .or. ts%failed(k)) cycle
      ierr = status_inverted_element
      ifault = -ts%index(k)
      return
    end do
  end subroutine intact_inverted

end module fsph_total
