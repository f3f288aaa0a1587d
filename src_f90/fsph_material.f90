!> Constitutive models shared by elements and (later) particles: equations of
!> state, strength models with radial return, the Jaumann rotation and the
!> energy update. Every routine is pure and works on one material point, so a
!> caller threads over points (docs/method.md, "One cycle").
!>
!> Conventions: Cauchy stress, tension positive; the stress of a point is
!> sigma = s - (p + q) I with s the deviator (rr, zz, rz, tt), p the EOS
!> pressure (compression positive) and q the artificial viscous pressure.
!> Strain rates d(4) = (d_rr, d_zz, d_rz, d_tt) are tensor components
!> (d_rz = gamma_rz / 2).
module fsph_material
  use fsph_kinds, only: wp, one_third
  use fsph_status, only: status_ok, status_eos_range
  ! the property table, the material history and the model ids: fsph_layouts
  ! (generated from fsph/layouts.py)
  use fsph_layouts, only: eos_hjc, eos_linear, eos_mie_gruneisen, hist_damage, hist_mu_max, n_hist, &
                          n_props, prop_bulk, prop_c0, prop_chi, prop_cv, prop_eps0, prop_gamma0, &
                          prop_hard, prop_hjc_a, prop_hjc_b, prop_hjc_c, prop_hjc_d1, prop_hjc_d2, &
                          prop_hjc_efmin, prop_hjc_fc, prop_hjc_k1, prop_hjc_k2, prop_hjc_k3, &
                          prop_hjc_mucrush, prop_hjc_mulock, prop_hjc_muplock, prop_hjc_n, prop_hjc_pcrush, &
                          prop_hjc_plock, prop_hjc_smax, prop_hjc_t, prop_jc_a, prop_jc_b, prop_jc_c, &
                          prop_jc_m, prop_jc_n, prop_pmin, prop_rho0, prop_s, prop_shear, prop_t_melt, &
                          prop_t_room, prop_yield, strength_bilinear, strength_elastic, strength_epp, &
                          strength_hjc, strength_johnson_cook
  implicit none
  private

  !> Smallest admissible value of the Mie-Grueneisen denominator
  !> 1 - (s - 1) mu before the state is declared out of range [-].
  real(wp), parameter :: mg_denominator_floor = 1.0e-3_wp
  !> Relative tolerance of the Johnson-Cook return-mapping iteration [-].
  real(wp), parameter :: return_tolerance = 1.0e-12_wp
  integer, parameter :: return_max_iterations = 60

  public :: material_update, strength_update, rotate_deviator, equivalent_stress, eos_pressure
  public :: deviator_double_contraction, sound_speed
  public :: hjc_pressure, hjc_yield_stress, hjc_update

contains

  !> s:t for two symmetric axisymmetric tensors stored as (rr, zz, rz, tt).
  pure function deviator_double_contraction(s, t) result(st)
    real(wp), intent(in) :: s(4), t(4)
    real(wp) :: st
    st = s(1)*t(1) + s(2)*t(2) + 2.0_wp*s(3)*t(3) + s(4)*t(4)
  end function deviator_double_contraction

  !> von Mises equivalent stress sqrt(3/2 s:s) of a deviator [Pa].
  pure function equivalent_stress(s) result(seq)
    real(wp), intent(in) :: s(4)
    real(wp) :: seq
    seq = sqrt(1.5_wp*deviator_double_contraction(s, s))
  end function equivalent_stress

  !> Jaumann objective rotation of the in-plane block of a deviator over a
  !> step: the solution of ds/dt = W s - s W for constant spin omega,
  !> s <- R s R^T with R = exp(W dt), a rotation by omega*dt. Exact, so the
  !> invariants of s are preserved to round-off. The hoop component is a
  !> principal direction and does not rotate.
  pure subroutine rotate_deviator(omega_dt, s)
    real(wp), intent(in) :: omega_dt   !< spin times step [rad]
    real(wp), intent(inout) :: s(4)
    real(wp) :: cs, sn, srr, szz, srz
    call rotation_cos_sin(omega_dt, cs, sn)
    srr = s(1); szz = s(2); srz = s(3)
    s(1) = cs*cs*srr + 2.0_wp*cs*sn*srz + sn*sn*szz
    s(2) = sn*sn*srr - 2.0_wp*cs*sn*srz + cs*cs*szz
    s(3) = (cs*cs - sn*sn)*srz + cs*sn*(szz - srr)
  end subroutine rotate_deviator

  !> cos and sin of a step's rotation angle [rad]. Below 0.1 rad the Taylor
  !> series to the 8th and 9th power are exact to round-off (next terms
  !> < 3e-17), a few multiplications where sin and cos are library calls.
  pure subroutine rotation_cos_sin(angle, cs, sn)
    real(wp), intent(in) :: angle
    real(wp), intent(out) :: cs, sn
    real(wp), parameter :: series_angle = 0.1_wp
    real(wp) :: a2, a4, a8
    if (abs(angle) < series_angle) then
      ! Estrin's scheme: the powers and partial sums are independent, so
      ! the series does not wait on a chain of nested multiplications
      a2 = angle*angle
      a4 = a2*a2
      a8 = a4*a4
      cs = (1.0_wp - a2*(1.0_wp/2.0_wp)) + a4*((1.0_wp/24.0_wp) - a2*(1.0_wp/720.0_wp)) &
           + a8*(1.0_wp/40320.0_wp)
      sn = angle*((1.0_wp - a2*(1.0_wp/6.0_wp)) + a4*((1.0_wp/120.0_wp) - a2*(1.0_wp/5040.0_wp)) &
                  + a8*(1.0_wp/362880.0_wp))
    else
      cs = cos(angle)
      sn = sin(angle)
    end if
  end subroutine rotation_cos_sin

  !> Equation of state written as p = a + b e (e specific internal energy),
  !> which holds for both models here; also the derivative da/drho used for
  !> the sound speed. Mie-Grueneisen with a linear Us-up Hugoniot reference
  !> (Steinberg/LS-DYNA form, no volume-dependent Gamma correction):
  !>   mu > 0: p = rho0 c0^2 mu [1 + (1 - Gamma0/2) mu] / [1 - (s-1) mu]^2 + Gamma0 rho0 e
  !>   mu <= 0: p = rho0 c0^2 mu + Gamma0 rho0 e,     mu = rho/rho0 - 1.
  !> Linear: p = K mu.
  pure subroutine eos_pressure(props, ieos, rho, a, b, dadrho, ierr)
    real(wp), intent(in) :: props(n_props)
    integer, intent(in) :: ieos
    real(wp), intent(in) :: rho           !< density [kg/m^3]
    real(wp), intent(out) :: a            !< energy-independent part [Pa]
    real(wp), intent(out) :: b            !< dp/de at constant rho [kg/m^3]
    real(wp), intent(out) :: dadrho       !< da/drho [m^2/s^2]
    integer, intent(out) :: ierr
    real(wp) :: rho0, inv_rho0, mu, k0, den, inv_den, num, dnum
    ierr = status_ok
    rho0 = props(prop_rho0)
    inv_rho0 = 1.0_wp/rho0
    mu = rho*inv_rho0 - 1.0_wp
    select case (ieos)
    case (eos_mie_gruneisen)
      k0 = rho0*props(prop_c0)**2
      b = props(prop_gamma0)*rho0
      if (mu > 0.0_wp) then
        den = 1.0_wp - (props(prop_s) - 1.0_wp)*mu
        if (den < mg_denominator_floor) then
          ierr = status_eos_range
          a = 0.0_wp; dadrho = 0.0_wp
          return
        end if
        num = mu*(1.0_wp + (1.0_wp - 0.5_wp*props(prop_gamma0))*mu)
        dnum = 1.0_wp + 2.0_wp*(1.0_wp - 0.5_wp*props(prop_gamma0))*mu
        inv_den = 1.0_wp/den
        a = k0*num*inv_den**2
        dadrho = k0*(dnum*den + 2.0_wp*(props(prop_s) - 1.0_wp)*num)*inv_den**3*inv_rho0
      else
        a = k0*mu
        dadrho = k0*inv_rho0
      end if
    case (eos_hjc)
      ! virgin loading curve (no history): set-up sound speed and checks;
      ! the cycle uses hjc_pressure
      b = 0.0_wp
      call hjc_loading(props, mu, a, dadrho)
      dadrho = dadrho*inv_rho0
    case default ! eos_linear
      a = props(prop_bulk)*mu
      b = 0.0_wp
      dadrho = props(prop_bulk)*inv_rho0
    end select
  end subroutine eos_pressure

  !> Current flow stress of the strength model [Pa].
  pure real(wp) function flow_stress(props, istrength, eps_p, rate_factor, thermal_factor) result(sy)
    real(wp), intent(in) :: props(n_props)
    integer, intent(in) :: istrength
    real(wp), intent(in) :: eps_p, rate_factor, thermal_factor
    select case (istrength)
    case (strength_epp)
      sy = props(prop_yield)
    case (strength_bilinear)
      sy = props(prop_yield) + props(prop_hard)*eps_p
    case (strength_johnson_cook)
      ! a point that has not yielded (most of a target) needs no power
      if (eps_p > 0.0_wp) then
        sy = (props(prop_jc_a) + props(prop_jc_b)*eps_p**props(prop_jc_n))*(rate_factor*thermal_factor)
      else
        sy = props(prop_jc_a)*(rate_factor*thermal_factor)
      end if
    case default
      sy = huge(1.0_wp)
    end select
  end function flow_stress

  !> Slope of the flow stress with respect to the equivalent plastic
  !> strain [Pa]: only the plastic return needs it (a Johnson-Cook slope
  !> costs a power of its own).
  pure real(wp) function flow_slope(props, istrength, eps_p, rate_factor, thermal_factor) result(dsy)
    real(wp), intent(in) :: props(n_props)
    integer, intent(in) :: istrength
    real(wp), intent(in) :: eps_p, rate_factor, thermal_factor
    !> Plastic strain below which the Johnson-Cook slope is evaluated at this
    !> value (the slope of eps^n is unbounded at zero for n < 1) [-].
    real(wp), parameter :: eps_slope_floor = 1.0e-9_wp
    select case (istrength)
    case (strength_bilinear)
      dsy = props(prop_hard)
    case (strength_johnson_cook)
      dsy = props(prop_jc_b)*props(prop_jc_n)*max(eps_p, eps_slope_floor)**(props(prop_jc_n) - 1.0_wp) &
            *(rate_factor*thermal_factor)
    case default
      dsy = 0.0_wp
    end select
  end function flow_slope

  !> Radial return to the von Mises surface. On entry s is the elastic trial
  !> deviator; on exit it lies on (or inside) the yield surface. Returns the
  !> plastic strain increment and the flow stress at the end of the step.
  pure subroutine radial_return(props, istrength, rate_factor, thermal_factor, eps_p, s, deps_p, sy)
    real(wp), intent(in) :: props(n_props)
    integer, intent(in) :: istrength
    real(wp), intent(in) :: rate_factor, thermal_factor, eps_p
    real(wp), intent(inout) :: s(4)
    real(wp), intent(out) :: deps_p, sy
    real(wp) :: seq_trial, seq2, g3, dsy, lo, hi, f, df, x, dx
    integer :: it
    deps_p = 0.0_wp
    sy = flow_stress(props, istrength, eps_p, rate_factor, thermal_factor)
    ! an elastic point (the common case) needs no square root
    seq2 = 1.5_wp*deviator_double_contraction(s, s)
    if (seq2 <= sy*sy) return
    seq_trial = sqrt(seq2)
    dsy = flow_slope(props, istrength, eps_p, rate_factor, thermal_factor)
    g3 = 3.0_wp*props(prop_shear)
    select case (istrength)
    case (strength_epp, strength_bilinear)
      ! closed form: seq_trial - 3G dl = Y0 + H (eps_p + dl)
      deps_p = (seq_trial - sy)/(g3 + dsy)
    case default
      ! safeguarded Newton on f(x) = seq_trial - 3G x - sy(eps_p + x), x in [0, seq_trial/3G]
      lo = 0.0_wp
      hi = seq_trial/g3
      x = min((seq_trial - sy)/(g3 + dsy), hi)
      do it = 1, return_max_iterations
        sy = flow_stress(props, istrength, eps_p + x, rate_factor, thermal_factor)
        dsy = flow_slope(props, istrength, eps_p + x, rate_factor, thermal_factor)
        f = seq_trial - g3*x - sy
        df = -(g3 + dsy)
        if (f > 0.0_wp) then
          lo = x
        else
          hi = x
        end if
        dx = -f/df
        if (x + dx <= lo .or. x + dx >= hi) dx = 0.5_wp*(lo + hi) - x
        x = x + dx
        if (abs(dx) <= return_tolerance*max(x, return_tolerance)) exit
      end do
      deps_p = x
    end select
    sy = flow_stress(props, istrength, eps_p + deps_p, rate_factor, thermal_factor)
    s = s*(sy/seq_trial)
  end subroutine radial_return

  !> Johnson-Cook thermal softening factor 1 - T*^m with
  !> T* = (T - T_room)/(T_melt - T_room); 1 below room temperature, 0 at and
  !> above melt.
  pure function thermal_softening(props, temp) result(f)
    real(wp), intent(in) :: props(n_props), temp
    real(wp) :: f, tstar
    tstar = (temp - props(prop_t_room))/(props(prop_t_melt) - props(prop_t_room))
    if (tstar <= 0.0_wp) then
      f = 1.0_wp
    else if (tstar >= 1.0_wp) then
      f = 0.0_wp
    else if (props(prop_jc_m) == 1.0_wp) then
      f = 1.0_wp - tstar          ! linear softening (6061-T651): no power
    else
      f = 1.0_wp - tstar**props(prop_jc_m)
    end if
  end function thermal_softening

  !> Start of every strength step: Jaumann rotation of s by the exact angle
  !> spin*dt (s_old, the rotated start-of-step deviator), the deviatoric
  !> strain rate d_dev and the elastic trial deviator s + 2 G dt d_dev.
  !> Written component by component from scalars: an element's deviator
  !> stored in part and read back whole stalled the processor's store
  !> forwarding, a fifth of a FEM cycle.
  pure subroutine elastic_trial(g, dt, d, spin, s, s_old, d_dev)
    real(wp), intent(in) :: g               !< shear modulus [Pa]
    real(wp), intent(in) :: dt, d(4), spin  !< [s], [1/s], [1/s]
    real(wp), intent(inout) :: s(4)         !< deviator: start of step in, trial out [Pa]
    real(wp), intent(out) :: s_old(4), d_dev(4)
    real(wp) :: cs, sn, r1, r2, r3, r4, trace, d1, d2, d3, d4, k
    call rotation_cos_sin(spin*dt, cs, sn)
    r1 = cs*cs*s(1) + 2.0_wp*cs*sn*s(3) + sn*sn*s(2)
    r2 = sn*sn*s(1) - 2.0_wp*cs*sn*s(3) + cs*cs*s(2)
    r3 = (cs*cs - sn*sn)*s(3) + cs*sn*(s(2) - s(1))
    r4 = s(4)
    trace = (d(1) + d(2) + d(4))*one_third
    d1 = d(1) - trace
    d2 = d(2) - trace
    d3 = d(3)
    d4 = d(4) - trace
    k = 2.0_wp*g*dt
    s_old(1) = r1; s_old(2) = r2; s_old(3) = r3; s_old(4) = r4
    d_dev(1) = d1; d_dev(2) = d2; d_dev(3) = d3; d_dev(4) = d4
    s(1) = r1 + k*d1; s(2) = r2 + k*d2; s(3) = r3 + k*d3; s(4) = r4 + k*d4
  end subroutine elastic_trial

  !> Deviatoric part of a constitutive step, shared by elements and
  !> particles: Jaumann rotation of s by the exact angle spin*dt, elastic
  !> trial deviator, radial return, adiabatic heating from plastic work
  !> (Johnson-Cook). Returns the rotated start-of-step deviator s_old and the
  !> deviatoric strain rate d_dev for the caller's work integral.
  pure subroutine strength_update(props, istrength, dt, d, spin, rho, s, eps_p, temp, s_old, d_dev)
    real(wp), intent(in) :: props(n_props)
    integer, intent(in) :: istrength
    real(wp), intent(in) :: dt              !< time step [s]
    real(wp), intent(in) :: d(4)            !< strain rate (rr, zz, rz, tt) [1/s]
    real(wp), intent(in) :: spin            !< in-plane spin 1/2 (dvr/dz - dvz/dr) [1/s]
    real(wp), intent(in) :: rho             !< density at the end of the step [kg/m^3]
    real(wp), intent(inout) :: s(4)         !< deviatoric stress [Pa]
    real(wp), intent(inout) :: eps_p        !< equivalent plastic strain [-]
    real(wp), intent(inout) :: temp         !< temperature [K]
    real(wp), intent(out) :: s_old(4)       !< rotated start-of-step deviator [Pa]
    real(wp), intent(out) :: d_dev(4)       !< deviatoric strain rate [1/s]
    real(wp) :: rate_factor, thermal_factor, deps_p, sy, rate_eq

    call elastic_trial(props(prop_shear), dt, d, spin, s, s_old, d_dev)
    if (istrength == strength_elastic) return

    rate_factor = 1.0_wp
    thermal_factor = 1.0_wp
    if (istrength == strength_johnson_cook) then
      ! (1 + C ln eps_dot*) with eps_dot* = eps_dot_eq/eps_dot_0 taken >= 1,
      ! the usual form of the model below the reference rate.
      ! (no logarithm where it is multiplied by C = 0 or taken of 1)
      if (props(prop_jc_c) /= 0.0_wp) then
        rate_eq = sqrt(2.0_wp/3.0_wp*deviator_double_contraction(d_dev, d_dev))
        if (rate_eq > props(prop_eps0)) rate_factor = 1.0_wp + props(prop_jc_c)*log(rate_eq/props(prop_eps0))
      end if
      thermal_factor = thermal_softening(props, temp)
    end if
    call radial_return(props, istrength, rate_factor, thermal_factor, eps_p, s, deps_p, sy)
    eps_p = eps_p + deps_p
    if (istrength == strength_johnson_cook .and. props(prop_cv) > 0.0_wp) then
      temp = temp + props(prop_chi)*sy*deps_p/(rho*props(prop_cv))
    end if
  end subroutine strength_update

  !> One constitutive step of one element material point: strength update,
  !> then EOS and internal energy solved together (p linear in e,
  !> trapezoidal p dv work, Wilkins), pressure cut-off, sound speed.
  pure subroutine material_update(props, istrength, ieos, dt, d, spin, rho_old, rho_new, q, &
                                  s, p, eps_p, e, temp, hist, c, ierr)
    real(wp), intent(in) :: props(n_props)
    integer, intent(in) :: istrength, ieos
    real(wp), intent(in) :: dt              !< time step [s]
    real(wp), intent(in) :: d(4)            !< strain rate (rr, zz, rz, tt) [1/s]
    real(wp), intent(in) :: spin            !< in-plane spin 1/2 (dvr/dz - dvz/dr) [1/s]
    real(wp), intent(in) :: rho_old, rho_new !< density at start and end of step [kg/m^3]
    real(wp), intent(in) :: q               !< artificial viscous pressure over the step [Pa]
    real(wp), intent(inout) :: s(4)         !< deviatoric stress [Pa]
    real(wp), intent(inout) :: p            !< pressure [Pa]
    real(wp), intent(inout) :: eps_p        !< equivalent plastic strain [-]
    real(wp), intent(inout) :: e            !< specific internal energy [J/kg]
    real(wp), intent(inout) :: temp         !< temperature [K]
    real(wp), intent(inout) :: hist(n_hist) !< history variables (damage, ...)
    real(wp), intent(out) :: c              !< longitudinal sound speed [m/s]
    integer, intent(out) :: ierr
    real(wp) :: s_old(4), d_dev(4), dw_dev, dv, a, b, dadrho, e_star, p_new, rho_sum, inv

    if (istrength == strength_hjc) then
      ! pressure first (it sets the strength), energy-independent: b = 0
      call hjc_update(props, dt, d, spin, rho_new, s, eps_p, hist, a, c, s_old, d_dev)
      b = 0.0_wp
      ierr = status_ok
    else
      call strength_update(props, istrength, dt, d, spin, rho_new, s, eps_p, temp, s_old, d_dev)
      call eos_pressure(props, ieos, rho_new, a, b, dadrho, ierr)
      if (ierr /= status_ok) return
    end if

    ! internal energy: deviatoric work with the mid-step deviator, then the
    ! pressure work -(q + (p_n + p_n+1)/2) dv solved with p_n+1 = a + b e_n+1;
    ! one reciprocal gives both 1/rho_mid and dv = 1/rho_new - 1/rho_old
    rho_sum = rho_old + rho_new
    inv = 1.0_wp/(rho_old*rho_new*rho_sum)    ! so 1/rho_new = rho_old rho_sum inv
    dw_dev = dt*deviator_double_contraction(0.5_wp*(s_old + s), d_dev)*(2.0_wp*rho_old*rho_new*inv)
    dv = (rho_old - rho_new)*rho_sum*inv
    e_star = e + dw_dev - (q + 0.5_wp*p)*dv
    e = (e_star - 0.5_wp*a*dv)/(1.0_wp + 0.5_wp*b*dv)
    p_new = a + b*e
    if (p_new < props(prop_pmin)) then
      ! spall cut-off: the material carries no more tension than p_min
      p_new = props(prop_pmin)
      e = e_star - 0.5_wp*p_new*dv
    end if
    p = p_new
    if (istrength /= strength_hjc) c = sound_speed_inv(props(prop_shear), dadrho, b, rho_old*rho_sum*inv, p)
  end subroutine material_update

  ! ---- Holmquist-Johnson-Cook concrete ----------------------------------

  !> HJC loading curve of virgin material: pressure [Pa] and dp/dmu [Pa] at
  !> volumetric strain mu = rho/rho0 - 1 (Holmquist, Johnson & Cook 1993):
  !> elastic p = K_e mu up to (mu_crush, P_crush), K_e = P_crush/mu_crush;
  !> linear compaction to (mu_plock, P_lock); fully dense
  !> p = K1 mub + K2 mub^2 + K3 mub^3, mub = (mu - mu_lock)/(1 + mu_lock).
  !> mu_plock is where the fully dense curve reaches P_lock (the paper's
  !> figure), so the curve is continuous; mu_lock is its zero-pressure
  !> intercept (the grain density).
  pure subroutine hjc_loading(props, mu, p, dpdmu)
    real(wp), intent(in) :: props(n_props), mu
    real(wp), intent(out) :: p, dpdmu
    real(wp) :: mub, k_e
    if (mu <= props(prop_hjc_mucrush)) then
      k_e = props(prop_hjc_pcrush)/props(prop_hjc_mucrush)
      p = k_e*mu
      dpdmu = k_e
    else if (mu <= props(prop_hjc_muplock)) then
      dpdmu = (props(prop_hjc_plock) - props(prop_hjc_pcrush)) &
              /(props(prop_hjc_muplock) - props(prop_hjc_mucrush))
      p = props(prop_hjc_pcrush) + dpdmu*(mu - props(prop_hjc_mucrush))
    else
      mub = (mu - props(prop_hjc_mulock))/(1.0_wp + props(prop_hjc_mulock))
      p = mub*(props(prop_hjc_k1) + mub*(props(prop_hjc_k2) + mub*props(prop_hjc_k3)))
      dpdmu = (props(prop_hjc_k1) + mub*(2.0_wp*props(prop_hjc_k2) + 3.0_wp*mub*props(prop_hjc_k3))) &
              /(1.0_wp + props(prop_hjc_mulock))
    end if
  end subroutine hjc_loading

  !> HJC unloading modulus dp/dmu [Pa] after a largest strain mu_max:
  !> K_e while elastic, (1 - F) K_e + F K1 in compaction with
  !> F = (mu_max - mu_crush)/(mu_plock - mu_crush), K1 once fully dense (in
  !> mu: K1/(1 + mu_lock)).
  pure function hjc_unloading_modulus(props, mu_max) result(k_u)
    real(wp), intent(in) :: props(n_props), mu_max
    real(wp) :: k_u, k_e, f
    k_e = props(prop_hjc_pcrush)/props(prop_hjc_mucrush)
    if (mu_max <= props(prop_hjc_mucrush)) then
      k_u = k_e
    else if (mu_max <= props(prop_hjc_muplock)) then
      f = (mu_max - props(prop_hjc_mucrush))/(props(prop_hjc_muplock) - props(prop_hjc_mucrush))
      k_u = (1.0_wp - f)*k_e + f*props(prop_hjc_k1)
    else
      k_u = props(prop_hjc_k1)/(1.0_wp + props(prop_hjc_mulock))
    end if
  end function hjc_unloading_modulus

  !> Permanent (plastic) volumetric strain after a largest strain mu_max:
  !> where the unloading line from the loading curve crosses p = 0 [-].
  pure function hjc_permanent_strain(props, mu_max) result(mu_p)
    real(wp), intent(in) :: props(n_props), mu_max
    real(wp) :: mu_p, p, dpdmu
    mu_p = 0.0_wp
    if (mu_max <= props(prop_hjc_mucrush)) return
    call hjc_loading(props, mu_max, p, dpdmu)
    mu_p = max(mu_max - p/hjc_unloading_modulus(props, mu_max), 0.0_wp)
  end function hjc_permanent_strain

  !> HJC pressure with its history: loading along hjc_loading when mu
  !> exceeds the largest strain reached (which it then becomes), otherwise
  !> along the unloading line from there; tension limited to -T (1 - D).
  !> Returns the pressure [Pa], dp/dmu on the branch taken [Pa] and the
  !> growth of the permanent volumetric strain over the step (damage) [-].
  pure subroutine hjc_pressure(props, mu, damage, mu_max, p, dpdmu, dmu_p)
    real(wp), intent(in) :: props(n_props)
    real(wp), intent(in) :: mu                !< volumetric strain rho/rho0 - 1 [-]
    real(wp), intent(in) :: damage            !< damage D [-]
    real(wp), intent(inout) :: mu_max         !< largest volumetric strain reached [-]
    real(wp), intent(out) :: p, dpdmu, dmu_p
    real(wp) :: mu_p_old, p_max
    dmu_p = 0.0_wp
    if (mu > mu_max) then
      mu_p_old = hjc_permanent_strain(props, mu_max)
      mu_max = mu
      call hjc_loading(props, mu, p, dpdmu)
      dmu_p = max(hjc_permanent_strain(props, mu_max) - mu_p_old, 0.0_wp)
    else if (mu == mu_max) then
      call hjc_loading(props, mu, p, dpdmu)
    else
      call hjc_loading(props, mu_max, p_max, dpdmu)
      dpdmu = hjc_unloading_modulus(props, mu_max)
      p = p_max - dpdmu*(mu_max - mu)
    end if
    p = max(p, -props(prop_hjc_t)*(1.0_wp - damage))
  end subroutine hjc_pressure

  !> HJC equivalent strength [Pa] at pressure p [Pa], damage D and
  !> equivalent strain rate [1/s]:
  !>   sigma* = [A (1 - D) + B P*^N] [1 + C ln(rate/rate0)] <= S_max  (P* = p/f_c > 0),
  !>   sigma* = A (1 - D) (1 + p/T) [1 + C ln(rate/rate0)]           (p <= 0),
  !> the rate term taken as 1 below the reference rate. The tension branch
  !> (not in the paper, which has P* >= 0 only) falls linearly to zero
  !> strength at the tensile limit -T.
  pure function hjc_yield_stress(props, p, damage, rate_eq) result(sy)
    real(wp), intent(in) :: props(n_props), p, damage, rate_eq
    real(wp) :: sy, pstar, star
    pstar = p/props(prop_hjc_fc)
    if (pstar > 0.0_wp) then
      star = props(prop_hjc_a)*(1.0_wp - damage) + props(prop_hjc_b)*pstar**props(prop_hjc_n)
    else
      star = max(props(prop_hjc_a)*(1.0_wp - damage)*(1.0_wp + p/props(prop_hjc_t)), 0.0_wp)
    end if
    if (rate_eq > props(prop_eps0)) star = star*(1.0_wp + props(prop_hjc_c)*log(rate_eq/props(prop_eps0)))
    if (pstar > 0.0_wp) star = min(star, props(prop_hjc_smax))
    sy = props(prop_hjc_fc)*star
  end function hjc_yield_stress

  !> One HJC step of a material point: Jaumann rotation and elastic trial
  !> deviator, the pressure at the end-of-step density (with its history),
  !> radial return to the strength at that pressure and the start-of-step
  !> damage, then damage growth
  !>   D <- min(1, D + (d eps_p + d mu_p) / max(D1 (P* + T*)^D2, EF_min)),
  !> and the sound speed. Below the reference density (opened, cracked or
  !> fragmented concrete) the shear part of the sound speed is taken at
  !> the reference density: the (SPH) density of separating fragments falls
  !> towards zero, and 4G/(3 rho) would collapse the time step of material
  !> that carries no stress (a 606 m/s run stopped on a debris particle at
  !> 2 kg/m^3 whose sound speed had reached 107 km/s).
  pure subroutine hjc_update(props, dt, d, spin, rho, s, eps_p, hist, p, c, s_old, d_dev)
    real(wp), intent(in) :: props(n_props)
    real(wp), intent(in) :: dt, d(4), spin     !< [s], [1/s], [1/s]
    real(wp), intent(in) :: rho                !< density at the end of the step [kg/m^3]
    real(wp), intent(inout) :: s(4)            !< deviatoric stress [Pa]
    real(wp), intent(inout) :: eps_p           !< equivalent plastic strain [-]
    real(wp), intent(inout) :: hist(n_hist)    !< damage and largest volumetric strain
    real(wp), intent(out) :: p                 !< pressure [Pa]
    real(wp), intent(out) :: c                 !< longitudinal sound speed [m/s]
    real(wp), intent(out) :: s_old(4), d_dev(4)
    real(wp) :: dadrho, dpdmu, dmu_p, rate_eq, sy, seq, deps_p, pt_sum, eps_f
    call elastic_trial(props(prop_shear), dt, d, spin, s, s_old, d_dev)
    call hjc_pressure(props, rho/props(prop_rho0) - 1.0_wp, hist(hist_damage), hist(hist_mu_max), &
                      p, dpdmu, dmu_p)
    dadrho = dpdmu/props(prop_rho0)
    c = sound_speed(props(prop_shear), dadrho, 0.0_wp, max(rho, props(prop_rho0)), p)
    rate_eq = sqrt(2.0_wp/3.0_wp*deviator_double_contraction(d_dev, d_dev))
    sy = hjc_yield_stress(props, p, hist(hist_damage), rate_eq)
    seq = equivalent_stress(s)
    deps_p = 0.0_wp
    if (seq > sy) then
      deps_p = (seq - sy)/(3.0_wp*props(prop_shear))
      s = s*(sy/seq)
    end if
    eps_p = eps_p + deps_p
    if (deps_p + dmu_p > 0.0_wp) then
      pt_sum = (p + props(prop_hjc_t))/props(prop_hjc_fc)
      eps_f = props(prop_hjc_efmin)
      if (pt_sum > 0.0_wp) eps_f = max(props(prop_hjc_d1)*pt_sum**props(prop_hjc_d2), eps_f)
      hist(hist_damage) = min(hist(hist_damage) + (deps_p + dmu_p)/eps_f, 1.0_wp)
    end if
  end subroutine hjc_update

  !> Longitudinal sound speed sqrt(c_b^2 + 4G/(3 rho)) [m/s] with the
  !> isentropic bulk sound speed c_b^2 = (dp/drho)_e + p/rho^2 (dp/de)_rho,
  !> taken as zero where that expression is negative (strongly stretched
  !> states), so that the shear part still bounds the time step.
  pure function sound_speed(g, dadrho, b, rho, p) result(c)
    real(wp), intent(in) :: g       !< shear modulus [Pa]
    real(wp), intent(in) :: dadrho  !< (dp/drho) at constant e [m^2/s^2]
    real(wp), intent(in) :: b       !< (dp/de) at constant rho [kg/m^3]
    real(wp), intent(in) :: rho, p  !< density [kg/m^3], pressure [Pa]
    real(wp) :: c
    c = sound_speed_inv(g, dadrho, b, 1.0_wp/rho, p)
  end function sound_speed

  !> The same with 1/rho given [m^3/kg] (a caller that has it saves a
  !> division).
  pure function sound_speed_inv(g, dadrho, b, inv_rho, p) result(c)
    real(wp), intent(in) :: g, dadrho, b, inv_rho, p
    real(wp) :: c
    c = sqrt(max(dadrho + p*b*inv_rho**2, 0.0_wp) + 4.0_wp*one_third*g*inv_rho)
  end function sound_speed_inv

end module fsph_material
