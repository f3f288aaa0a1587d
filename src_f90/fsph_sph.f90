!> Axisymmetric SPH sums (Xiao et al. 2012 eqs 2-4) over
!> the neighbour lists of fsph_neighbours. A pair of real particles is
!> evaluated once, in the row of the lower index, which keeps what the
!> partner needs per entry (force, kernel gradient, work); a second loop
!> over every particle's low list adds the partners' terms in a fixed
!> order. Each loop writes only its own particle's entries, so the sums
!> thread without races and give the same bits for any thread count, and
!> the pair terms are equal and opposite, so the axial momentum of the sums
!> is conserved to round-off.
!>
!> With full-ring masses m, the planar density is eta = 2 pi r rho and the
!> stress weights r sigma / eta^2 = sigma / (4 pi^2 r rho^2). Ghost entries
!> (-j) are the mirror of j across the axis, the odd extension of the
!> planar fields: position (-r_j, z_j), velocity (-v_r, v_z), sigma_rz
!> reversed, density rho_j, and a ring mass 2 pi r rho A that changes sign
!> with r (-m_j). The planar density eta is then odd in r and its gradient
!> is right at the axis (Petschek & Libersky 1993, J. Comput. Phys.
!> 109:76).
!>
!> Density: the planar density is carried, d eta_i/dt = sum_j m_j
!> (v_i - v_j) . grad_i W (ghosts with their signed mass), and rho_i =
!> eta_i/(2 pi r_i) (Petschek & Libersky 1993). Eq 1 of Xiao et al. 2012 weights
!> the neighbours by m_j/r_j instead: a particle next to the axis that
!> moves out by delta from a lattice at rest then loses density delta/r_i
!> (the hoop term alone), while eta-continuity lets it carry its ring mass
!> into a region of larger eta = 2 pi r rho, as a summed density would,
!> and so keeps its density. With eq 1 the particles converted next to
!> the axis of the Taylor rod drifted out, rarefied to 0.4 rho0 in deep
!> tension and heated to 4 MJ/kg; an elastic rod in pure SPH gained 44 %
!> energy in 80 us (docs/method.md).
!>
!> Energy: the stress power of each particle is its own stress times the
!> rate conjugate to the momentum equation, de_i/dt = sigma_tt v_r/(rho r)
!> + 2 pi sum_j m_j (r_i/eta_i^2) sigma_i : (v_j - v_i) grad_i W, so the
!> pair work of eqs 2-3 is exactly the change of kinetic energy, and the
!> pressure work of a particle is the p dv of its own density (the
!> eta-continuity above); the half-and-half split of eq 3 of Xiao et al. 2012 gave
!> a particle next to the axis half its own pressure work against the
!> whole hoop work, which drained its energy in tension until it flew
!> apart. A ghost is not a particle of its own: the heat of a ghost entry
!> is minus the work of its force on the particle, so ghosts neither make
!> nor lose energy radially (their axial stress forces, less each
!> fragment's resultant, work on the motion relative to the fragment
!> unbooked: axis_resultant, docs/method.md). For a particle whose
!> reaction goes to its coupling edges the pairs with the imaginary
!> particles of the elements are charged whole, at the edges' velocity
!> (sph_energy_rate).
!>
!> Artificial viscosity: the continuum (FEM) form q = rho (C_Q h eps)^2 +
!> C_L rho c h |eps| evaluated pairwise with the normal strain rate
!> eps_ij = (v_i - v_j).(x_i - x_j)/(|x_ij|^2 + 0.01 h^2) < 0 and the pair
!> means of rho, c and h, acting as an extra pressure on both particles of
!> the pair (Johnson's "combined" viscosity, Johnson 1996, IJIE 18:477,
!> i.e. Monaghan's Pi_ij with alpha = C_L, beta = C_Q^2), scaled by the
!> pair mean of a compression switch f = |div v|/(|div v| + |D'| +
!> 1e-4 c/h) (in the spirit of Balsara 1995, J. Comput. Phys. 121:357,
!> with the deviatoric rate D' for his vorticity): the pairwise form
!> resists every approaching pair, so in the isochoric plastic flow of a
!> Taylor foot it acted as a shear viscosity (the SPH foot 10 % narrower
!> than the element one); the switch keeps it in compression and shocks.
!> A ghost pair resists like a real one (its viscous pressure acts with
!> the ring mass m_j, not -m_j). A mirror image across the axis or across
!> a plane (fsph_mirror) takes its particle's switch: the mirrored strain
!> rate has the same divergence and deviator. Images across the anvil
!> without it resisted the foot's isochoric flow along the anvil in full:
!> the converted particles at the face of the adaptive Armco rod (10
!> cells across) held 60 kJ/kg of viscous heat against the FEM face's 24,
!> and the hottest was 10.2 times the largest element's energy (9.7 with
!> it).
!>
!> Hourglass control: the collocated SPH gradient does not see a particle
!> field that alternates from one lattice column to the next (columns
!> sliding past each other cost no strain), and such modes grew in the
!> shank of a pure SPH Taylor rod until the plastic strain there reached
!> 0.3 (FEM 0.01). Each pair of a particle and its neighbour or ghost gets
!> a viscous force on the part of their velocity difference that the
!> particles' own velocity gradients G do not explain,
!> dv_hg = v_i - v_j - (G_i + G_j)/2 (x_i - x_j), zero for any linear
!> velocity field: P_ij = C_hg rho c h F(r_ij) dv_hg (F = dW/dr / r < 0),
!> added as 2 pi m_j (w_i + w_j) P_ij to the acceleration (the idea of
!> hourglass viscosity for under-integrated elements, Flanagan &
!> Belytschko 1981, IJNME 17:679, applied to the pair sums).
!>
!> Artificial stress (&sph artificial_stress = eps > 0; off by default):
!> the corrective stress of Monaghan 2000 (J. Comput. Phys. 159:290) in
!> the form for solids of Gray, Monaghan & Swift 2001 (Comput. Methods
!> Appl. Mech. Engrg. 190:6641) against the tensile instability, by which
!> particles in tension clump. Per particle, the in-plane stress (rr, zz,
!> rz) is taken to its principal axes; each tensile principal stress
!> sigma' > 0 gives R' = -eps sigma' (a compressive one 0), and R is R'
!> turned back (artificial_stress). A pair then adds f_ij^n (w_i R_i +
!> w_j R_j) to its pair stress S, in the force and in the energy equation
!> alike (each particle's own share w R, as its stress's), with f_ij =
!> W(r_ij, h_ij)/W(dp_ij, h_ij); n = 4 and eps = 0.3 are Gray et al.'s for
!> solids. dp is the particles' initial spacing: every particle's h is
!> alpha_h times its spacing at set-up (the lattice's, or sqrt of the area
!> of the element it was made from), and h never changes, so dp_ij =
!> h_ij/alpha_h. With alpha_h = 1.3, f^4 is 1 at r = dp, 0.03 at sqrt(2)
!> dp and 1e-5 at 2 dp, but 10.7 at dp/2 and 23.6 at r -> 0: a repulsion
!> between particles in tension that grows steeply as they close in below
!> their spacing (a uniform R on a regular lattice adds no net force).
!> Where a large plastic strain has squashed the lattice below dp and the
!> stress turns tensile it drives the particles instead (the foot of a
!> Taylor rod: docs/method.md); hence off by default. No hoop component:
!> sigma_tt enters the momentum equation through the particle's own term
!> -sigma_tt/(rho r), no pair term, and so has no pairing instability; an
!> artificial R_tt there would act at any spacing (no f_ij) and only take
!> 30 % off the hoop tension. (The codes found that carry the correction,
!> plane or 3D, apply it to the components of the pair sums.)
!> Ghosts (-j) take R_j's odd extension (R_rz reversed, as sigma_rz, and
!> the ghost's signed weight), so their force, whose work a ghost entry
!> books as heat from pair_force, and their axial resultant (acc_axis)
!> include it; mirror images across a plane compute it from their own
!> mirrored stress. An element's imaginary particle takes no part: the
!> element is not a particle lattice, and the reaction of its pairs
!> reaches the nodes through the coupling tractions of the particles'
!> stress (fsph_coupling), which know nothing of R, so a force there
!> would have no reaction.
module fsph_sph
  use fsph_kinds, only: wp, pi, two_pi
  use fsph_kernel, only: kernel_gradient_factor, in_support, kernel_shape
  use fsph_ordered, only: merge_minimum, thread_rows
  use fsph_groups, only: root
  implicit none
  private

  public :: sph_accelerations, sph_rates, sph_energy_rate, sph_time_step, particle_radius, pair_weights, particle_radii
  public :: imag_work_pair, imag_work_none, imag_work_edges
  public :: compression_switch, ghost_work, entry_sign, axis_resultant, artificial_stress, artificial_reference

  !> How the pairs of a particle with imaginary particles (elements) do
  !> work in the energy equation (sph_energy_rate): as a pair with a real
  !> partner, the particle's own share at the imaginary particle's
  !> velocity; none (a tied particle); the whole pair at the velocity of
  !> the coupling edges that take the particle's reaction.
  integer, parameter :: imag_work_pair = 0, imag_work_none = 1, imag_work_edges = 2

  !> Softening of the pairwise strain rate, times h^2 [-].
  real(wp), parameter :: visc_softening = 0.01_wp
  !> Range of det(L) of the gradient-correction matrix inside which the
  !> corrected velocity gradient is used; outside it (a particle with too
  !> few neighbours) the plain SPH gradient is kept [-].
  real(wp), parameter :: correction_det_min = 0.05_wp, correction_det_max = 5.0_wp
  !> Floor of the compression switch's denominator, times c/h (Balsara
  !> 1995 uses 1e-4 c/h) [-].
  real(wp), parameter :: switch_floor = 1.0e-4_wp
  !> Exponent n of the artificial stress's pair factor f_ij^n (Gray,
  !> Monaghan & Swift 2001 for solids) [-].
  integer, parameter :: artificial_exponent = 4

contains

  !> Radius of a particle: half the side of the square of its planar area
  !> A = m/(2 pi r rho) [m]. Used for contact, rigid planes and lengths.
  pure elemental function particle_radius(mass, r, rho) result(radius)
    real(wp), intent(in) :: mass, r, rho
    real(wp) :: radius
    ! |r|: a particle found across the axis (the axis guard stops the run
    ! in this cycle) keeps the radius of its mirror ring
    radius = 0.5_wp*sqrt(mass/(two_pi*abs(r)*rho))
  end function particle_radius

  !> Radius of every particle (particle_radius) [m] at its density, but
  !> never above the radius at its material's reference density rho0(mat)
  !> [kg/m^3] (fsph_solver update_particle_radius says why).
  subroutine particle_radii(n, rho0, mat, mass, x, rho, radius)
    integer, intent(in) :: n, mat(n)
    real(wp), intent(in) :: rho0(:), mass(n), x(2, n), rho(n)
    real(wp), intent(out) :: radius(n)
    integer :: i
    !$omp parallel do default(none) shared(n, rho0, mat, mass, x, rho, radius) private(i)
    do i = 1, n
      radius(i) = particle_radius(mass(i), x(1, i), max(rho(i), rho0(mat(i))))
    end do
    !$omp end parallel do
  end subroutine particle_radii

  !> Per-entry factors of the pair sums, for entries 1..ntot (real and
  !> imaginary particles): the stress weight w = r/eta^2 =
  !> 1/(4 pi^2 r rho^2) [m^5/kg^2] and the planar area A = m/(2 pi r rho)
  !> [m^2]. A ghost (mirror) entry has weight -w and
  !> the same area; m/r = 2 pi rho A of a ghost is that of its particle.
  subroutine pair_weights(ntot, x, mass, rho, wgt, area)
    integer, intent(in) :: ntot
    real(wp), intent(in) :: x(2, ntot), mass(ntot), rho(ntot)
    real(wp), intent(out) :: wgt(ntot), area(ntot)
    integer :: i
    !$omp parallel do default(none) shared(ntot, x, mass, rho, wgt, area) private(i)
    do i = 1, ntot
      wgt(i) = 1.0_wp/(4.0_wp*pi*pi*x(1, i)*rho(i)**2)
      area(i) = mass(i)/(two_pi*x(1, i)*rho(i))
    end do
    !$omp end parallel do
  end subroutine pair_weights

  !> Sign of a neighbour entry as a factor: -1 for a ghost (-j), +1 else.
  !> A ghost's r, v_r, sigma_rz, signed ring mass and stress weight are
  !> those of j times this factor.
  pure real(wp) function entry_sign(entry)
    integer, intent(in) :: entry
    entry_sign = merge(-1.0_wp, 1.0_wp, entry < 0)
  end function entry_sign

  !> 1 when the stress of a point (intact_i) acts on a neighbour
  !> (intact_j) and the neighbour enters its density and velocity
  !> gradient, else 0: an intact point does not act through its own stress
  !> on a failed neighbour, nor count it (the flank of a crack is a free
  !> surface for it); a failed point (no tension, no deviator) acts on and
  !> counts every neighbour, so debris still resists compression
  !> (fsph_eigenerosion). 1 for every pair while nothing has failed.
  pure real(wp) function acts_on(intact_i, intact_j)
    real(wp), intent(in) :: intact_i, intact_j  !< 1 intact, 0 failed [-]
    acts_on = merge(intact_j, 1.0_wp, intact_i > 0.0_wp)
  end function acts_on

  !> Pairwise artificial viscous pressure q_ij [Pa] (see module header);
  !> zero for a pair that separates (eps = 0, no branch: about half of the
  !> pairs of a compressed region approach).
  pure function pair_viscosity(dx, dv, dist2, hij, rho_ij, c_ij, c_q, c_l) result(q)
    real(wp), intent(in) :: dx(2), dv(2), dist2, hij, rho_ij, c_ij, c_q, c_l
    real(wp) :: q, eps
    eps = min(dv(1)*dx(1) + dv(2)*dx(2), 0.0_wp)/(dist2 + visc_softening*hij*hij)
    q = rho_ij*(c_q*hij*eps)**2 - c_l*rho_ij*c_ij*hij*eps
  end function pair_viscosity

  !> Pair stress S = w_i sig_i + w_j sig_j of the momentum and energy
  !> equations, w = r/eta^2 = 1/(4 pi^2 r rho^2), for a neighbour j seen
  !> with sign sg (sigma_rz and w of a ghost change sign; wj is passed with
  !> its sign).
  pure function pair_stress(wi, sig_i, wj, sig_j, sg) result(stot)
    real(wp), intent(in) :: wi, sig_i(4), wj, sig_j(4), sg
    real(wp) :: stot(4)
    stot(1) = wi*sig_i(1) + wj*sig_j(1)
    stot(2) = wi*sig_i(2) + wj*sig_j(2)
    stot(3) = wi*sig_i(3) + wj*sg*sig_j(3)
    stot(4) = wi*sig_i(4) + wj*sig_j(4)
  end function pair_stress

  !> Work term S : (v_j - v_i) grad W of eq 3 for one pair.
  pure function pair_work(stot, dvji, grad) result(w)
    real(wp), intent(in) :: stot(4), dvji(2), grad(2)
    real(wp) :: w
    w = stot(1)*dvji(1)*grad(1) + stot(3)*dvji(1)*grad(2) + &
        stot(3)*dvji(2)*grad(1) + stot(2)*dvji(2)*grad(2)
  end function pair_work

  !> Pair artificial stress w_i R_i + w_j R_j (rr, zz, rz; tt 0: no hoop
  !> component, module header) [Pa m^5/kg^2], for a neighbour seen with
  !> sign sg (R_rz and w of a ghost change sign; wj is passed with its
  !> sign), in the layout of pair_stress.
  pure function pair_artificial(wi, r_i, wj, r_j, sg) result(stot)
    real(wp), intent(in) :: wi, r_i(3), wj, r_j(3), sg
    real(wp) :: stot(4)
    stot = pair_stress(wi, [r_i, 0.0_wp], wj, [r_j, 0.0_wp], sg)
  end function pair_artificial

  !> The artificial stress's pair factor f^n = (W(r, h_ij)/W(dp_ij,
  !> h_ij))^n [-] of a pair at squared distance dist2 [m^2] with 1/h_ij
  !> given [1/m]; w_ref = 1/W(dp/h, 1) in units of the kernel's
  !> normalisation (artificial_reference) [-].
  pure real(wp) function artificial_factor(dist2, inv_h, w_ref) result(fn)
    real(wp), intent(in) :: dist2, inv_h, w_ref
    fn = (kernel_shape(sqrt(dist2)*inv_h)*w_ref)**artificial_exponent
  end function artificial_factor

  !> 1/W(dp/h, 1) [-], in units of the kernel's normalisation, for
  !> particles whose smoothing length is alpha_h [-] times their initial
  !> spacing dp (the reference of artificial_factor).
  pure real(wp) function artificial_reference(alpha_h) result(w_ref)
    real(wp), intent(in) :: alpha_h
    w_ref = 1.0_wp/kernel_shape(1.0_wp/alpha_h)
  end function artificial_reference

  !> Artificial stress R (rr, zz, rz) [Pa] of a total stress sig (rr, zz,
  !> rz, tt) [Pa] (module header): in the principal axes of the in-plane
  !> stress, R' = -eps sigma' where sigma' > 0, else 0, turned back. With
  !> c, d the mean and half difference of sig_rr and sig_zz and rad =
  !> sqrt(d^2 + sig_rz^2), the principal stresses are c +- rad, and a
  !> tensor of principal values r1, r2 on the same axes is
  !> (r1 + r2)/2 I + (r1 - r2)/(2 rad) (d, -d, sig_rz).
  pure function tensile_correction(sig, eps) result(r)
    real(wp), intent(in) :: sig(4), eps
    real(wp) :: r(3), c, d, rad, r1, r2, mean, slope
    c = 0.5_wp*(sig(1) + sig(2))
    d = 0.5_wp*(sig(1) - sig(2))
    rad = sqrt(d*d + sig(3)*sig(3))
    r1 = -eps*max(c + rad, 0.0_wp)
    r2 = -eps*max(c - rad, 0.0_wp)
    mean = 0.5_wp*(r1 + r2)
    slope = 0.0_wp
    if (rad > 0.0_wp) slope = 0.5_wp*(r1 - r2)/rad
    r(1) = mean + slope*d
    r(2) = mean - slope*d
    r(3) = slope*sig(3)
  end function tensile_correction

  !> Artificial stress R (rr, zz, rz) [Pa] of every entry 1..ntot from the
  !> total stress sig [Pa] the pair sums use (tensile_correction with the
  !> coefficient eps [-]); imaginary particles (entries n+1..n+n_imag)
  !> take none (module header). Mirror images across planes carry their
  !> mirrored stress, and so their mirrored R.
  subroutine artificial_stress(n, ntot, n_imag, sig, eps, art)
    integer, intent(in) :: n, ntot, n_imag
    real(wp), intent(in) :: sig(4, ntot), eps
    real(wp), intent(out) :: art(3, ntot)
    integer :: i
    !$omp parallel do default(none) shared(n, ntot, n_imag, sig, eps, art) private(i)
    do i = 1, ntot
      if (i > n .and. i <= n + n_imag) then
        art(:, i) = 0.0_wp
      else
        art(:, i) = tensile_correction(sig(:, i), eps)
      end if
    end do
    !$omp end parallel do
  end subroutine artificial_stress

  !> Velocity gradient G(a, b) = d v_a / d x_b of entry j, (1, 2) = (r, z),
  !> from the stored (dv_r/dr, dv_z/dr, dv_r/dz, dv_z/dz); a ghost (sg =
  !> -1) has the mirrored gradient (the off-diagonal terms change sign).
  pure function entry_gradient(gv, sg) result(g)
    real(wp), intent(in) :: gv(4), sg
    real(wp) :: g(2, 2)
    g(1, 1) = gv(1); g(2, 1) = sg*gv(2); g(1, 2) = sg*gv(3); g(2, 2) = gv(4)
  end function entry_gradient

  !> Work rate per unit masses [m^2/(kg s^3)] of a mirror image's force f on
  !> particle i (velocity v_i), booked as i's heat: radially f_r v_r,i
  !> (the axis is at rest), axially half of f_z (v_z,i - v_z,j) with v_z,j
  !> the image's axial velocity. The image pairs (i, j') and (j, i') come
  !> together, and their forces' axial parts are mirror images where they
  !> derive from velocity differences (the viscosity, the hourglass term,
  !> the contact's dissipation): half the relative velocity each is then
  !> exactly their work, and unlike f_z v_z,i it does not depend on the
  !> frame. Charged at v_z,i, the axial force of the images, which the axis
  !> takes without a partner, traded the kinetic energy of a fast fragment
  !> for internal energy of its particles next to the axis: in a copper rod
  !> bouncing off an anvil at 4.4 km/s an axis particle fell to -16.6 MJ/kg
  !> within 2 us (its stress part alone: -2.5e15 W/kg in 0.2 us).
  pure real(wp) function ghost_work(f, v_i, vz_j) result(w)
    real(wp), intent(in) :: f(2), v_i(2), vz_j
    w = f(1)*v_i(1) + 0.5_wp*f(2)*(v_i(2) - vz_j)
  end function ghost_work

  !> The real particle an entry j of the sums stands for: itself (1..n),
  !> none for an imaginary particle (an element, 0), minus it for a mirror
  !> image across a plane (entries after the imaginary ones; mirror_of
  !> names their particles).
  pure integer function entry_particle(j, n, n_imag, mirror_of) result(src)
    integer, intent(in) :: j, n, n_imag, mirror_of(*)
    if (j <= n) then
      src = j
    else if (j > n + n_imag) then
      src = -mirror_of(j - n - n_imag)
    else
      src = 0
    end if
  end function entry_particle

  !> Compression switch of the pairwise viscosity, per particle:
  !> f = |div v|/(|div v| + |D'| + 1e-4 c/h), from the strain rates d
  !> (rr, zz, rz, tt) of the particle's last update [1/s]: 1 in a uniform
  !> compression, about 0.55 in a uniaxial-strain shock, 0 in an
  !> isochoric (plastic) flow, and 0 for a particle with no strain rate and
  !> no sound speed (a molten particle expanded until its EOS gives none:
  !> 0/0 there made the switch, and the viscosity of the particle's pairs,
  !> NaN: a copper particle left alone on the axis, at the spall floor, in
  !> case 1 of the debris clouds at 0.2 mm with &sph artificial_stress 0.3).
  subroutine compression_switch(n, d, c, h, f)
    integer, intent(in) :: n
    real(wp), intent(in) :: d(4, n), c(n), h(n)
    real(wp), intent(out) :: f(n)
    integer :: i
    real(wp) :: div, dev, den
    !$omp parallel do default(none) shared(n, d, c, h, f) private(i, div, dev, den)
    do i = 1, n
      div = d(1, i) + d(2, i) + d(4, i)
      dev = sqrt((d(1, i) - div/3.0_wp)**2 + (d(2, i) - div/3.0_wp)**2 + (d(4, i) - div/3.0_wp)**2 &
                 + 2.0_wp*d(3, i)**2)
      den = abs(div) + dev + switch_floor*c(i)/h(i)
      if (den > 0.0_wp) then
        f(i) = abs(div)/den
      else
        f(i) = 0.0_wp
      end if
    end do
    !$omp end parallel do
  end subroutine compression_switch

  !> Accelerations (eqs 2a, 2b) [m/s^2] of every particle from the total
  !> stress sig = s - p I (rr, zz, rz, tt):
  !>  a_r = -sig_tt/(rho r) + 2 pi sum m_j [S^rr dW/dr + S^rz dW/dz]
  !>  a_z =                   2 pi sum m_j [S^rz dW/dr + S^zz dW/dz]
  !> with S = r_i sig_i/eta_i^2 + r_j sig_j/eta_j^2 (ghosts with their
  !> signed mass and weight), plus the pairwise viscosity -q_ij (w_i + w_j)
  !> and the hourglass viscosity (w_i + w_j) P_ij of the module header
  !> (both with the ring mass m_j, also for ghosts); wgt are the stress
  !> weights of pair_weights at these positions and densities. Every entry
  !> k of i's row is evaluated once, in i's row: its force per unit
  !> neighbour mass (a_i gets m_j times it) goes to pair_force(:, k), its
  !> viscous pressure to pair_q(k) and its hourglass term P to
  !> pair_hg(:, k) (so that the energy equation charges exactly the work
  !> these forces do); the partner j of a half entry then takes -m_i times
  !> the force, in a second loop over j's low list, in a fixed order.
  !> grad_v holds the velocity gradients of the real particles (entries
  !> 1..n) for the hourglass term and switch their compression switches;
  !> imaginary particles and mirror images (entries > n) carry neither.
  !> With eps_art > 0 the pairs of particles (real, ghosts, images across
  !> planes; not imaginary ones) add the artificial stress f^n (w_i R_i +
  !> w_j R_j) to S (module header), R from artificial_stress of sig (art)
  !> and f from w_ref; with eps_art = 0 neither is read.
  subroutine sph_accelerations(n, ntot, n_imag, x, v, mass, rho, h, c, sig, wgt, intact, grad_v, switch, &
                               corrected, mirror_of, nbr_ptr, nbr_list, low_ptr, low_pair, low_other, c_q, c_l, c_hg, &
                               eps_art, art, w_ref, acc, pair_q, pair_force, pair_hg, pair_in, acc_imag, acc_axis)
    integer, intent(in) :: n             !< real particles (rows computed)
    integer, intent(in) :: ntot          !< real, imaginary and mirror entries (neighbours)
    integer, intent(in) :: n_imag        !< imaginary entries n+1 .. n+n_imag (elements)
    real(wp), intent(in) :: x(2, ntot), v(2, ntot), mass(ntot), rho(ntot), h(ntot), c(ntot), sig(4, ntot)
    real(wp), intent(in) :: wgt(ntot)    !< stress weights 1/(4 pi^2 r rho^2)
    real(wp), intent(in) :: intact(ntot) !< 1 intact, 0 failed: whose stress acts on whom (acts_on) [-]
    real(wp), intent(in) :: grad_v(4, n) !< dv_r/dr, dv_z/dr, dv_r/dz, dv_z/dz of the last update [1/s]
    real(wp), intent(in) :: switch(n)    !< compression switch of the viscosity [-]
    !> 1 where the contact corrected the particle's velocity in the last
    !> cycle, else 0 [-]: its pairs carry no hourglass force (below)
    real(wp), intent(in) :: corrected(n)
    !> the particle of each mirror image across a plane (entries
    !> n + n_imag + 1 ..)
    integer, intent(in) :: mirror_of(*)
    integer, intent(in) :: nbr_ptr(n + 1), nbr_list(*), low_ptr(n + 1), low_pair(*), low_other(*)
    real(wp), intent(in) :: c_q, c_l     !< viscosity coefficients [-]
    real(wp), intent(in) :: c_hg         !< hourglass coefficient [-]
    real(wp), intent(in) :: eps_art      !< artificial stress coefficient (0: off) [-]
    real(wp), intent(in) :: art(3, ntot) !< artificial stress R (rr, zz, rz) of each entry [Pa]
    real(wp), intent(in) :: w_ref        !< 1/W(dp/h, 1), of the kernel at the initial spacing (artificial_factor) [-]
    real(wp), intent(out) :: acc(2, n)
    real(wp), intent(out) :: pair_q(*)   !< viscous pressure of each entry [Pa]
    real(wp), intent(out) :: pair_force(2, *) !< acceleration of i per unit mass of entry k [m/(kg s^2)]
    real(wp), intent(out) :: pair_hg(2, *) !< hourglass term P of each entry [kg/(m^4 s^2)]
    logical, intent(out) :: pair_in(*)   !< the entry lies within the kernel support at these positions
    real(wp), intent(out) :: acc_imag(2, n) !< the part of acc from imaginary neighbours [m/s^2]
    !> the axial part of acc from the stress terms of the mirror images
    !> across the axis (axis_resultant) [m/s^2]
    real(wp), intent(out) :: acc_axis(n)
    integer :: i, k, j, src, first, last
    real(wp) :: sg, dx(2), dv(2), dist2, hij, grad(2), wi, q, stot(4), f(2), a(2), a_imag(2), da(2), a_axis
    real(wp) :: factor, p_hg(2), dv_hg(2), gi(2, 2), xi(2), vi(2), hi, rhoi, ci, sigi(4), inti, switch_i
    real(wp) :: corrected_i
    logical :: with_art, tense_i
    with_art = eps_art > 0.0_wp
    !$omp parallel default(none) &
    !$omp shared(n, n_imag, x, v, mass, rho, h, c, sig, wgt, intact, grad_v, switch, corrected, mirror_of) &
    !$omp shared(nbr_ptr, nbr_list) &
    !$omp shared(low_ptr, low_pair, low_other, c_q, c_l, c_hg, acc, pair_q, pair_force, pair_hg, pair_in) &
    !$omp shared(acc_imag, acc_axis, with_art, art, w_ref) &
    !$omp private(i, k, j, sg, dx, dv, dist2, hij, grad, wi, q, stot, f, a, a_imag, da, factor, p_hg, dv_hg, gi) &
    !$omp private(a_axis, src, xi, vi, hi, rhoi, ci, sigi, inti, switch_i, corrected_i, tense_i, first, last)
    call thread_rows(n, nbr_ptr, low_ptr, first, last)
    do i = first, last
      ! the row's own values in locals: the stores to the pair arrays
      ! below would otherwise make the compiler read them again for every
      ! entry
      wi = wgt(i)
      xi = x(:, i)
      vi = v(:, i)
      hi = h(i)
      rhoi = rho(i)
      ci = c(i)
      sigi = sig(:, i)
      inti = intact(i)
      switch_i = switch(i)
      corrected_i = corrected(i)
      gi = entry_gradient(grad_v(:, i), 1.0_wp)
      ! R /= 0 exactly when its trace is negative (a tensile principal stress)
      tense_i = .false.
      if (with_art) tense_i = art(1, i) + art(2, i) < 0.0_wp
      a(1) = -sig(4, i)/(rho(i)*x(1, i))
      a(2) = 0.0_wp
      a_imag = 0.0_wp
      a_axis = 0.0_wp
      do k = nbr_ptr(i), nbr_ptr(i + 1) - 1
        j = abs(nbr_list(k))
        sg = entry_sign(nbr_list(k))
        dx = [xi(1) - sg*x(1, j), xi(2) - x(2, j)]
        dist2 = dx(1)**2 + dx(2)**2
        ! the pairs of this cycle: those within the support now, by the
        ! search's own test (a listed pair beyond it, from the lists' skin,
        ! adds exact zeros here and in the mid-step sums)
        pair_in(k) = in_support(dist2, hi, h(j)) .and. dist2 > 0.0_wp
        pair_q(k) = 0.0_wp
        pair_force(:, k) = 0.0_wp
        pair_hg(:, k) = 0.0_wp
        if (.not. pair_in(k)) cycle
        hij = 0.5_wp*(hi + h(j))
        factor = kernel_gradient_factor(dist2, 1.0_wp/hij)
        grad = factor*dx
        dv = [vi(1) - sg*v(1, j), vi(2) - v(2, j)]
        q = pair_viscosity(dx, dv, dist2, hij, 0.5_wp*(rhoi + rho(j)), 0.5_wp*(ci + c(j)), c_q, c_l)
        ! particles, their ghosts and their images across planes: the
        ! compression switch (an image's is its particle's: the mirrored
        ! strain rate has the same divergence and deviator); between a
        ! particle and an element the viscosity acts in full
        src = entry_particle(j, n, n_imag, mirror_of)
        if (src /= 0) q = q*0.5_wp*(switch_i + switch(abs(src)))
        if (src > 0 .and. corrected_i == 0.0_wp .and. corrected(max(src, 1)) == 0.0_wp) then
          ! particles and their ghosts: the hourglass term on the
          ! velocity difference their gradients do not explain. Not on
          ! the pairs of a particle the contact corrected in the last
          ! cycle: that velocity jump is the contact's boundary condition,
          ! not a mode of the particle lattice, and damping it against the
          ! neighbours turned the contact's work into heat at the contact
          ! (docs/method.md, "Contact and the hourglass viscosity")
          dv_hg = dv - 0.5_wp*matmul(gi + entry_gradient(grad_v(:, j), sg), dx)
          p_hg = c_hg*0.5_wp*(rhoi + rho(j))*0.5_wp*(ci + c(j))*hij*factor*dv_hg
        else
          p_hg = 0.0_wp
        end if
        pair_q(k) = q
        pair_hg(:, k) = p_hg
        stot = pair_stress(acts_on(inti, intact(j))*wi, sigi, &
                           acts_on(intact(j), inti)*sg*wgt(j), sig(:, j), sg)
        ! the artificial stress, part of the pair stress, between particles
        ! (src /= 0: not with an element's imaginary particle), where
        ! either has one
        if (with_art .and. src /= 0) then
          if (tense_i .or. art(1, j) + art(2, j) < 0.0_wp) &
            stot = stot + artificial_factor(dist2, 1.0_wp/hij, w_ref)* &
                   pair_artificial(acts_on(inti, intact(j))*wi, art(:, i), acts_on(intact(j), inti)*sg*wgt(j), &
                                   art(:, j), sg)
        end if
        ! stress with the signed ring mass, viscosity and hourglass with m_j
        f(1) = two_pi*(sg*(stot(1)*grad(1) + stot(3)*grad(2)) + (wi + wgt(j))*(p_hg(1) - q*grad(1)))
        f(2) = two_pi*(sg*(stot(3)*grad(1) + stot(2)*grad(2)) + (wi + wgt(j))*(p_hg(2) - q*grad(2)))
        pair_force(:, k) = f
        da = mass(j)*f
        a = a + da
        if (j > n .and. j <= n + n_imag) a_imag = a_imag + da
        if (sg < 0.0_wp) a_axis = a_axis + mass(j)*(two_pi*sg*(stot(3)*grad(1) + stot(2)*grad(2)))
      end do
      acc(:, i) = a
      acc_imag(:, i) = a_imag
      acc_axis(i) = a_axis
    end do
    ! the partners' forces of other rows
    !$omp barrier
    call add_partner_forces(n, first, last, mass, low_ptr, low_pair, low_other, pair_force, acc)
    !$omp end parallel
  end subroutine sph_accelerations

  !> The partners' side of the half entries: each particle takes minus the
  !> force its lower-index partners computed for their pair, in list order.
  !> Called by each thread of the parallel region of sph_accelerations for
  !> its rows first..last (thread_rows).
  subroutine add_partner_forces(n, first, last, mass, low_ptr, low_pair, low_other, pair_force, acc)
    integer, intent(in) :: n, first, last, low_ptr(n + 1), low_pair(*), low_other(*)
    real(wp), intent(in) :: mass(*), pair_force(2, *)
    real(wp), intent(inout) :: acc(2, n)
    integer :: i, m
    real(wp) :: a(2)
    do i = first, last
      a = acc(:, i)
      do m = low_ptr(i), low_ptr(i + 1) - 1
        a = a - mass(low_other(m))*pair_force(:, low_pair(m))
      end do
      acc(:, i) = a
    end do
  end subroutine add_partner_forces

  !> The terms of one neighbour in the rate sums of a particle: planar
  !> density (eta-continuity, signed ring mass m_j), velocity gradient and
  !> its correction matrix, for separation dx = x_i - x_j, velocity
  !> difference dvji = v_j - v_i, kernel gradient g = grad_i W and planar
  !> area A_j. sums = (sum m_j dvji . g, gv(1,1), gv(2,1), gv(1,2),
  !> gv(2,2), L(1,1), L(2,1), L(1,2), L(2,2)).
  pure subroutine add_rate_terms(dx, dvji, g, vol_j, m_j, sums)
    real(wp), intent(in) :: dx(2), dvji(2), g(2), vol_j, m_j
    real(wp), intent(inout) :: sums(9)
    sums(1) = sums(1) + m_j*(dvji(1)*g(1) + dvji(2)*g(2))
    sums(2) = sums(2) + vol_j*dvji(1)*g(1)
    sums(3) = sums(3) + vol_j*dvji(2)*g(1)
    sums(4) = sums(4) + vol_j*dvji(1)*g(2)
    sums(5) = sums(5) + vol_j*dvji(2)*g(2)
    sums(6) = sums(6) - vol_j*dx(1)*g(1)
    sums(7) = sums(7) - vol_j*dx(2)*g(1)
    sums(8) = sums(8) - vol_j*dx(1)*g(2)
    sums(9) = sums(9) - vol_j*dx(2)*g(2)
  end subroutine add_rate_terms

  !> Rates for the update of density (eta-continuity, module header:
  !> drho_i = -rho_i v_r/r_i - sum_j m_j (v_j - v_i) . grad_i W/(2 pi r_i))
  !> and the velocity gradient, corrected (Randles-Libersky) so that a
  !> linear velocity field is differentiated exactly: strain rates d (rr,
  !> zz, rz, tt) with d_tt = v_r/r, spin, and the whole gradient grad_v
  !> (dv_r/dr, dv_z/dr, dv_r/dz, dv_z/dz; the hourglass term of the next
  !> accelerations uses it). area is the planar area of pair_weights at
  !> these positions and densities; the sums run over the entries pair_in
  !> marks (the pairs within the support at the start of the cycle, as the
  !> accelerations). The kernel gradient grad_i W of every entry of i's row
  !> is computed once and kept in grad, for the partner's terms (grad_j W
  !> = -grad_i W, in a second loop over the low lists) and for the energy
  !> sum at the same positions (sph_energy_rate). sums is work space (9, n).
  !> intact: 1 for an intact point, 0 for one that has failed
  !> (fsph_eigenerosion); an intact particle's density and velocity
  !> gradient leave its failed neighbours out (acts_on), a failed
  !> particle's take all.
  subroutine sph_rates(n, ntot, x, v, mass, rho, h, area, intact, nbr_ptr, nbr_list, low_ptr, low_pair, &
                       low_other, pair_in, grad, sums, drho, d, spin, grad_v)
    integer, intent(in) :: n, ntot
    real(wp), intent(in) :: x(2, ntot), v(2, ntot), mass(ntot), rho(ntot), h(ntot), area(ntot)
    real(wp), intent(in) :: intact(ntot)  !< 1 intact, 0 failed [-]
    integer, intent(in) :: nbr_ptr(n + 1), nbr_list(*), low_ptr(n + 1), low_pair(*), low_other(*)
    logical, intent(in) :: pair_in(*)    !< the entries of this cycle (sph_accelerations)
    real(wp), intent(out) :: grad(2, *)  !< kernel gradient grad_i W of each entry [1/m^3]
    real(wp), intent(out) :: sums(9, n)
    real(wp), intent(out) :: drho(n)     !< [kg/(m^3 s)]
    real(wp), intent(out) :: d(4, n), spin(n) !< [1/s]
    real(wp), intent(out) :: grad_v(4, n) !< [1/s]
    integer :: i, k, j, m, first, last
    real(wp) :: sg, dx(2), dvji(2), dist2, g_ij(2), acc9(9), gv(2, 2), lm(2, 2), inv(2, 2), det, g(2, 2)
    real(wp) :: seen
    !$omp parallel default(none) &
    !$omp shared(n, x, v, mass, rho, h, area, intact, nbr_ptr, nbr_list, low_ptr, low_pair, low_other, pair_in) &
    !$omp shared(grad, sums, drho, d, spin, grad_v) &
    !$omp private(i, k, j, m, sg, dx, dvji, dist2, g_ij, acc9, gv, lm, inv, det, g, seen, first, last)
    call thread_rows(n, nbr_ptr, low_ptr, first, last)
    do i = first, last
      acc9 = 0.0_wp
      do k = nbr_ptr(i), nbr_ptr(i + 1) - 1
        ! a listed pair outside the support at the start of the cycle adds
        ! nothing (a zero gradient); the lists' skin makes about a sixth
        ! of the entries such pairs. (The same test in the energy sum,
        ! whose entries cost less, mispredicted more than it saved.)
        if (.not. pair_in(k)) then
          grad(:, k) = 0.0_wp
          cycle
        end if
        j = abs(nbr_list(k))
        sg = entry_sign(nbr_list(k))
        dx(1) = x(1, i) - sg*x(1, j)
        dx(2) = x(2, i) - x(2, j)
        dist2 = dx(1)**2 + dx(2)**2
        if (dist2 <= 0.0_wp) then
          grad(:, k) = 0.0_wp
          cycle
        end if
        g_ij = merge(kernel_gradient_factor(dist2, 2.0_wp/(h(i) + h(j))), 0.0_wp, &
                     in_support(dist2, h(i), h(j)))*dx
        grad(:, k) = g_ij
        dvji(1) = sg*v(1, j) - v(1, i)
        dvji(2) = v(2, j) - v(2, i)
        seen = acts_on(intact(i), intact(j))
        call add_rate_terms(dx, dvji, g_ij, seen*area(j), seen*sg*mass(j), acc9)
      end do
      sums(:, i) = acc9
    end do
    ! the kernel gradients of other rows
    !$omp barrier
    ! the partners' side of the half entries, then the rates
    do i = first, last
      acc9 = sums(:, i)
      do m = low_ptr(i), low_ptr(i + 1) - 1
        j = low_other(m)
        seen = acts_on(intact(i), intact(j))
        call add_rate_terms(x(:, i) - x(:, j), v(:, j) - v(:, i), -grad(:, low_pair(m)), seen*area(j), &
                            seen*mass(j), acc9)
      end do
      drho(i) = -rho(i)*v(1, i)/x(1, i) - acc9(1)/(two_pi*x(1, i))
      gv(1, 1) = acc9(2); gv(2, 1) = acc9(3); gv(1, 2) = acc9(4); gv(2, 2) = acc9(5)
      lm(1, 1) = acc9(6); lm(2, 1) = acc9(7); lm(1, 2) = acc9(8); lm(2, 2) = acc9(9)
      ! g = gv L^-1 where the correction applies
      det = lm(1, 1)*lm(2, 2) - lm(1, 2)*lm(2, 1)
      if (det > correction_det_min .and. det < correction_det_max) then
        inv(1, 1) = lm(2, 2)/det; inv(1, 2) = -lm(1, 2)/det
        inv(2, 1) = -lm(2, 1)/det; inv(2, 2) = lm(1, 1)/det
        g = matmul(gv, inv)
      else
        g = gv
      end if
      ! g(a, b) = d v_a / d x_b with (1, 2) = (r, z)
      d(1, i) = g(1, 1)
      d(2, i) = g(2, 2)
      d(3, i) = 0.5_wp*(g(1, 2) + g(2, 1))
      d(4, i) = v(1, i)/x(1, i)
      spin(i) = 0.5_wp*(g(1, 2) - g(2, 1))
      grad_v(:, i) = [g(1, 1), g(2, 1), g(1, 2), g(2, 2)]
    end do
    !$omp end parallel
  end subroutine sph_rates

  !> Energy rate [J/(kg s)] of every particle (module header), with the
  !> stress sig and stress weights wgt of the densities given (the cycle
  !> passes mid-step values, so the stress work matches the time-centred
  !> force), the velocities v at which the rates were taken and the kernel
  !> gradients grad of each entry (sph_rates at the same positions):
  !>  - a pair with a real particle or a mirror image: the particle's own
  !>    stress work 2 pi m_j w_i sig_i :
  !>    (v_j - v_i) grad_i W, and its share w_i/(w_i + w_j) of the work of
  !>    the viscous pressure pair_q and the hourglass term pair_hg, charged
  !>    at the velocities v_visc (the cycle passes the mean of the
  !>    velocities before and after the kick, which is exactly the kinetic
  !>    energy those forces removed); the partner of a half entry takes
  !>    the same with its own stress and weight (kept per unit mass of the
  !>    particle in pair_work_k and added in a second loop over the low
  !>    lists);
  !>  - a pair with an imaginary particle, by the particle's imag_work:
  !>    imag_work_edges (a free particle whose reaction goes to its
  !>    coupling edges, fsph_coupling coupling_tractions): the whole work
  !>    of the pair force, both stresses and the viscous pressure, at the
  !>    velocity of the point that takes the reaction, v_react(1:2, i) for
  !>    the stress and v_react(3:4, i) for the viscous part (as v and
  !>    v_visc): the pair force and its reaction then do work only on the
  !>    particle's motion relative to its edges, and that work is the
  !>    particle's heat, so the coupling neither makes nor loses energy.
  !>    (Until 2026-11-29 the particle took its own stress's share at the
  !>    imaginary particle's velocity, the mean of the element's nodes, and
  !>    the element's share was left to the element's own work, which does
  !>    not see the reaction: the coupled bar lost 0.34 % of its energy as
  !>    the wave crossed the interface, the adaptive Taylor rods 0.3-0.4 %.)
  !>    imag_work_none (a particle tied to an edge): no work: the forces
  !>    on it and its reaction act on the same edge nodes and cancel
  !>    (fsph_coupling tie_forces), and heat booked for them would be
  !>    energy made from nothing (measured: +4.1 J of the +5.0 J the
  !>    coarse adaptive Armco rod gained). imag_work_pair (a particle with
  !>    no coupling edge, whose axial reaction is spread over the
  !>    continuum's edges): its own share, as with a real partner, at the
  !>    imaginary particle's velocity;
  !>  - a ghost: minus the work m_j pair_force . v_visc,i its force does on
  !>    the particle, axially at half the velocity relative to the image
  !>    (ghost_work);
  !>  - the hoop work sig_tt v_r/(rho r).
  !> With eps_art > 0 the artificial stress is part of each particle's own
  !> stress in its pairs with particles (real ones and images across
  !> planes: f^n w_i R_i with R of sig, art, and f at these positions;
  !> module header), and a ghost's heat follows from its force as before.
  !> de_parts(1:2) [J/(kg s)] are the parts of de that the viscous
  !> pressure and the hourglass term make (bookkeeping: each particle's
  !> share of its pairs' work, a ghost's at its force's viscous and
  !> hourglass parts with the weights given; de itself is summed as
  !> without them).
  subroutine sph_energy_rate(n, ntot, n_imag, x, v, v_visc, mass, rho, h, sig, wgt, intact, imag_work, v_react, &
                             nbr_ptr, nbr_list, low_ptr, low_pair, low_other, pair_q, pair_hg, pair_force, grad, &
                             eps_art, art, w_ref, pair_work_k, de, de_parts)
    integer, intent(in) :: n, ntot
    integer, intent(in) :: n_imag        !< imaginary entries n+1 .. n+n_imag (elements)
    real(wp), intent(in) :: x(2, ntot), v(2, ntot), v_visc(2, ntot), mass(ntot), rho(ntot)
    real(wp), intent(in) :: h(ntot)      !< smoothing lengths [m]
    real(wp), intent(in) :: sig(4, ntot), wgt(ntot)
    real(wp), intent(in) :: intact(ntot) !< 1 intact, 0 failed: whose stress acts on whom (acts_on) [-]
    !> how a particle's pairs with imaginary particles do work (imag_work_pair, _none, _edges)
    integer, intent(in) :: imag_work(n)
    !> with imag_work_edges: the velocity of the point that takes the
    !> particle's reaction, as v (1:2) and as v_visc (3:4) [m/s]
    real(wp), intent(in) :: v_react(4, n)
    integer, intent(in) :: nbr_ptr(n + 1), nbr_list(*), low_ptr(n + 1), low_pair(*), low_other(*)
    real(wp), intent(in) :: pair_q(*), pair_hg(2, *), pair_force(2, *), grad(2, *)
    real(wp), intent(in) :: eps_art      !< artificial stress coefficient (0: off) [-]
    real(wp), intent(in) :: art(3, ntot) !< artificial stress R (rr, zz, rz) of each entry [Pa]
    real(wp), intent(in) :: w_ref        !< 1/W(dp/h, 1) (artificial_factor) [-]
    !> the partner's work rate per unit mass of i, then its viscous and
    !> hourglass parts [m^2/(kg s^3)]
    real(wp), intent(out) :: pair_work_k(3, *)
    real(wp), intent(out) :: de(n)
    !> the viscous and hourglass parts of de (rows 1, 2) [J/(kg s)]; row 3,
    !> the contact's, set to 0 (riemann_contact_heat adds it)
    real(wp), intent(out) :: de_parts(3, n)
    integer :: i, k, j, m, o, first, last
    real(wp) :: dvji(2), vq(2), wi, wj, sum_e, w_own, w_partner, q_work, visc_work, hg_work, sum_visc, sum_hg, &
                f_part(2), fn, a_ij, a_ji
    real(wp), parameter :: zero3(3) = 0.0_wp, zero4(4) = 0.0_wp
    logical :: with_art, tense_i, tense_j
    with_art = eps_art > 0.0_wp
    !$omp parallel default(none) &
    !$omp shared(n, n_imag, x, v, v_visc, mass, rho, h, sig, wgt, intact, imag_work, v_react, nbr_ptr) &
    !$omp shared(nbr_list, low_ptr) &
    !$omp shared(low_pair, low_other, with_art, art, w_ref) &
    !$omp shared(pair_q, pair_hg, pair_force, grad, pair_work_k, de, de_parts) &
    !$omp private(i, k, j, m, o, dvji, vq, wi, wj, sum_e, w_own, w_partner, q_work, visc_work, hg_work) &
    !$omp private(sum_visc, sum_hg, f_part, fn, a_ij, a_ji, tense_i, tense_j, first, last)
    call thread_rows(n, nbr_ptr, low_ptr, first, last)
    do i = first, last
      wi = wgt(i)
      sum_e = 0.0_wp
      sum_visc = 0.0_wp
      sum_hg = 0.0_wp
      tense_i = .false.
      if (with_art) tense_i = art(1, i) + art(2, i) < 0.0_wp
      do k = nbr_ptr(i), nbr_ptr(i + 1) - 1
        j = abs(nbr_list(k))
        if (nbr_list(k) < 0) then
          ! a ghost: the work of its force on the particle becomes heat,
          ! axially at the velocity relative to the image (ghost_work)
          pair_work_k(:, k) = 0.0_wp
          sum_e = sum_e - mass(j)*ghost_work(pair_force(:, k), v_visc(:, i), v_visc(2, j))
          f_part = -two_pi*(wi + wgt(j))*pair_q(k)*grad(:, k)
          sum_visc = sum_visc - mass(j)*ghost_work(f_part, v_visc(:, i), v_visc(2, j))
          f_part = two_pi*(wi + wgt(j))*pair_hg(:, k)
          sum_hg = sum_hg - mass(j)*ghost_work(f_part, v_visc(:, i), v_visc(2, j))
          cycle
        end if
        if (j > n .and. j <= n + n_imag .and. imag_work(i) /= imag_work_pair) then
          pair_work_k(:, k) = 0.0_wp
          if (imag_work(i) == imag_work_none) cycle
          ! the whole pair, at the velocity of the edges that take the reaction
          dvji = v_react(1:2, i) - v(:, i)
          vq = v_react(3:4, i) - v_visc(:, i)
          visc_work = -pair_q(k)*(vq(1)*grad(1, k) + vq(2)*grad(2, k))
          wj = wgt(j)
          sum_visc = sum_visc + two_pi*mass(j)*(wi + wj)*visc_work
          sum_e = sum_e + two_pi*mass(j)*(pair_work(pair_stress(acts_on(intact(i), intact(j))*wi, sig(:, i), &
                                                                acts_on(intact(j), intact(i))*wj, sig(:, j), &
                                                                1.0_wp), dvji, grad(:, k)) + (wi + wj)*visc_work)
          cycle
        end if
        wj = wgt(j)
        dvji = v(:, j) - v(:, i)
        vq = v_visc(:, j) - v_visc(:, i)
        ! viscous and hourglass work per unit (w_i + w_j)
        visc_work = -pair_q(k)*(vq(1)*grad(1, k) + vq(2)*grad(2, k))
        hg_work = pair_hg(1, k)*vq(1) + pair_hg(2, k)*vq(2)
        q_work = visc_work + pair_hg(1, k)*vq(1) + pair_hg(2, k)*vq(2)
        sum_visc = sum_visc + two_pi*mass(j)*wi*visc_work
        sum_hg = sum_hg + two_pi*mass(j)*wi*hg_work
        a_ij = acts_on(intact(i), intact(j))
        a_ji = acts_on(intact(j), intact(i))
        w_own = pair_work(pair_stress(a_ij*wi, sig(:, i), 0.0_wp, zero4, 1.0_wp), dvji, grad(:, k)) + wi*q_work
        w_partner = pair_work(pair_stress(a_ji*wj, sig(:, j), 0.0_wp, zero4, 1.0_wp), dvji, grad(:, k)) + wj*q_work
        ! each particle's artificial stress, as its own stress, in its pairs
        ! with particles (not with an element's imaginary particle)
        if (with_art .and. (j <= n .or. j > n + n_imag)) then
          tense_j = art(1, j) + art(2, j) < 0.0_wp
          if (tense_i .or. tense_j) then
            fn = artificial_factor((x(1, i) - x(1, j))**2 + (x(2, i) - x(2, j))**2, 2.0_wp/(h(i) + h(j)), w_ref)
            if (tense_i) w_own = w_own + fn*pair_work(pair_artificial(a_ij*wi, art(:, i), 0.0_wp, zero3, 1.0_wp), &
                                                      dvji, grad(:, k))
            if (tense_j) w_partner = w_partner + fn*pair_work(pair_artificial(a_ji*wj, art(:, j), 0.0_wp, zero3, &
                                                                              1.0_wp), dvji, grad(:, k))
          end if
        end if
        pair_work_k(:, k) = two_pi*[w_partner, wj*visc_work, wj*hg_work]
        sum_e = sum_e + two_pi*mass(j)*w_own
      end do
      de(i) = sum_e
      de_parts(1, i) = sum_visc
      de_parts(2, i) = sum_hg
    end do
    ! the partners' work of other rows
    !$omp barrier
    ! the partners' side of the half entries, then the rates
    do i = first, last
      sum_e = de(i)
      sum_visc = de_parts(1, i)
      sum_hg = de_parts(2, i)
      do m = low_ptr(i), low_ptr(i + 1) - 1
        k = low_pair(m)
        o = low_other(m)
        sum_e = sum_e + mass(o)*pair_work_k(1, k)
        sum_visc = sum_visc + mass(o)*pair_work_k(2, k)
        sum_hg = sum_hg + mass(o)*pair_work_k(3, k)
      end do
      de_parts(1, i) = sum_visc
      de_parts(2, i) = sum_hg
      de_parts(3, i) = 0.0_wp
      de(i) = sig(4, i)*v(1, i)/(rho(i)*x(1, i)) + sum_e
    end do
    !$omp end parallel
  end subroutine sph_energy_rate

  !> The axis carries no axial load. The mirror images across it act on
  !> the particles next to it with the odd extension of the stress
  !> (ghosts), and the pairs (i, j') and (j, i') give i and j the same
  !> axial force, not opposite ones: no pair form can be both consistent
  !> (the images fill the half of a kernel beyond the axis, so a particle
  !> next to it sees the whole axial stress gradient) and equal and
  !> opposite (the images' half would then count with the opposite sign),
  !> so the images' axial forces add up to a resultant that no physical
  !> load balances (docs/method.md, "The axis"). It vanishes with the
  !> resolution, but in a pure SPH projectile leaving a concrete slab with
  !> debris on its axis it changed the axial momentum by 0.53 % (1.7 %
  !> with the particles held one radius off the axis) and, at the
  !> projectile's speed, made the energy error (its work U F at the
  !> projectile's speed U, which no heat books). Here the resultant F of
  !> the images' axial stress forces (acc_axis, from sph_accelerations and
  !> the equilibrium part of the Riemann contact's image entries) is
  !> removed fragment by fragment, by a uniform axial acceleration -F/M of
  !> the fragment's particles (M their mass): a rigid motion, so no stress
  !> changes. A fragment is a connected set of particles of one continuum,
  !> linked by the pairs within the kernel support this cycle (pair_in).
  !> Removed over the whole continuum instead, a cluster of nine plate
  !> particles that broke away on the axis with its stresses locked in
  !> kept the resultant of its images and sped up at 4.7e6 m/s^2, from the
  !> plate's 500 m/s to 1 020 m/s at 200 us (docs/validation.md). The
  !> images' forces and the correction then do work only on the motion
  !> relative to each fragment's mean axial velocity, which does not
  !> depend on the frame; the ghosts' heat stays as it was (ghost_work).
  !> The fragments are found by union-find over the pairs of the half rows
  !> (the partition does not depend on the order); the sums run serially
  !> in index order, so they do not depend on the thread count.
  subroutine axis_resultant(n, mass, nbr_ptr, half_end, nbr_list, pair_in, acc_axis, acc)
    integer, intent(in) :: n
    real(wp), intent(in) :: mass(n)         !< ring masses [kg]
    !> the rows of fsph_neighbours: entries nbr_ptr(i) .. half_end(i) - 1
    !> are i's pairs with the particles j > i of its continuum
    integer, intent(in) :: nbr_ptr(n + 1), half_end(n), nbr_list(*)
    logical, intent(in) :: pair_in(*)       !< the entries within the support this cycle
    real(wp), intent(in) :: acc_axis(n)     !< [m/s^2]
    real(wp), intent(inout) :: acc(2, n)    !< [m/s^2]
    integer, allocatable :: fragment(:), members(:)
    real(wp), allocatable :: force(:), total(:)
    integer :: i, j, k, ri, rj
    if (n == 0) return
    if (all(acc_axis(1:n) == 0.0_wp)) return
    allocate (fragment(n), members(n), force(n), total(n))
    do i = 1, n
      fragment(i) = i
    end do
    members = 1
    ! union-find (fsph_groups root) over the pairs of the continuum, each
    ! once, in its lower particle's half row (a ghost entry links two
    ! particles whose own pair is then within the support too: no link of
    ! its own); the smaller tree goes under the larger one's root, which
    ! keeps the trees shallow. Which particle is a fragment's root does not
    ! matter: its sums below run in index order
    do i = 1, n
      ri = root(fragment, i)
      do k = nbr_ptr(i), half_end(i) - 1
        if (.not. pair_in(k)) cycle
        j = nbr_list(k)
        if (fragment(j) == ri) cycle     ! j hangs from i's root itself
        rj = root(fragment, j)
        if (rj == ri) cycle
        if (members(rj) > members(ri)) then
          fragment(ri) = rj
          members(rj) = members(rj) + members(ri)
          ri = rj
        else
          fragment(rj) = ri
          members(ri) = members(ri) + members(rj)
        end if
      end do
    end do
    force = 0.0_wp
    total = 0.0_wp
    do i = 1, n
      fragment(i) = root(fragment, i)    ! the fragment's root
      force(fragment(i)) = force(fragment(i)) + mass(i)*acc_axis(i)
      total(fragment(i)) = total(fragment(i)) + mass(i)
    end do
    do i = 1, n
      acc(2, i) = acc(2, i) - force(fragment(i))/total(fragment(i))
    end do
  end subroutine axis_resultant

  !> Stable particle step before the safety factor: min L/(c + |v|) [s]
  !> with L = min(h, 2r) and the particle that sets it. h/(c + |v|) is the
  !> particle step (docs/method.md, "The particle phase"); next to the axis the hoop term
  !> -sigma_tt/(rho r) adds a mode of frequency about c/r, stable under the
  !> central difference for dt < 2r/c, which a particle made from an
  !> element touching the axis (r = Delta/6) would break.
  subroutine sph_time_step(n, x, h, c, v, dt_min, icontrol)
    integer, intent(in) :: n
    real(wp), intent(in) :: x(2, n), h(n), c(n), v(2, n)
    real(wp), intent(out) :: dt_min
    integer, intent(out) :: icontrol
    real(wp) :: dti, t_min
    integer :: i, t_i
    dt_min = huge(1.0_wp)
    icontrol = 0
    ! per-thread minima combined to the lowest index among equal values, as
    ! a serial scan would find it
    !$omp parallel default(none) shared(n, x, h, c, v, dt_min, icontrol) private(i, dti, t_min, t_i)
    t_min = huge(1.0_wp)
    t_i = 0
    !$omp do schedule(static)
    do i = 1, n
      dti = min(h(i), 2.0_wp*x(1, i))/(c(i) + sqrt(v(1, i)**2 + v(2, i)**2))
      if (dti < t_min) then
        t_min = dti
        t_i = i
      end if
    end do
    !$omp end do
    !$omp critical (particle_step_minimum)
    call merge_minimum(t_min, t_i, dt_min, icontrol)
    !$omp end critical (particle_step_minimum)
    !$omp end parallel
  end subroutine sph_time_step

end module fsph_sph
