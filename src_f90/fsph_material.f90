!> Constitutive models shared by elements and particles: equations of
!> state, strength models with radial return, the Jaumann rotation, the
!> energy update, temperature, melting and failure. Every routine is pure
!> and works on one material point, so a caller threads over points
!> (docs/method.md, "One cycle" and "Materials for hypervelocity impact").
!>
!> Conventions: Cauchy stress, tension positive; the stress of a point is
!> sigma = s - (p + q) I with s the deviator (rr, zz, rz, tt), p the EOS
!> pressure (compression positive) and q the artificial viscous pressure.
!> Strain rates d(4) = (d_rr, d_zz, d_rz, d_tt) are tensor components
!> (d_rz = gamma_rz / 2). Model switches stored in the property row
!> (temp_model, melt_model, pl_rate_form, jcf_on, spall_fail) are ids held as reals;
!> the strength model and EOS ids (istrength, ieos) are arguments passed by
!> value, so that a caller that passes them as constants (the element
!> update) gets from the compiler a copy of these routines with those
!> switches resolved (interprocedural constant propagation; meson.build).
module fsph_material
  use fsph_kinds, only: wp, one_third
  use fsph_status, only: status_ok, status_eos_range
  ! the property table, the material history and the model ids: fsph_layouts
  ! (generated from fsph/layouts.py)
  use fsph_layouts, only: eos_hjc, eos_linear, eos_mie_gruneisen, hist_damage, hist_mu_max, hist_failed, &
                          hist_melted, hist_plastic_work, hist_viscous_work, &
                          n_hist, n_props, prop_bulk, prop_c0, prop_chi, prop_cv, prop_eps0, &
                          prop_gamma0, prop_hard, prop_hjc_a, prop_hjc_b, prop_hjc_c, prop_hjc_d1, prop_hjc_d2, &
                          prop_hjc_efmin, prop_hjc_fc, prop_hjc_k1, prop_hjc_k2, prop_hjc_k3, &
                          prop_hjc_mucrush, prop_hjc_mulock, prop_hjc_muplock, prop_hjc_n, prop_hjc_pcrush, &
                          prop_hjc_plock, prop_hjc_smax, prop_hjc_t, prop_jc_a, prop_jc_b, prop_jc_c, &
                          prop_jc_m, prop_jc_n, prop_pmin, prop_rho0, prop_s, prop_shear, prop_t_melt, &
                          prop_t_room, prop_yield, prop_temp_model, prop_melt_model, prop_melt_a, &
                          prop_pl_sigma0, prop_pl_eps0, prop_pl_rate0, prop_pl_n, prop_pl_m, prop_pl_l, &
                          prop_pl_rate_form, prop_sg_y0, prop_sg_ymax, prop_sg_beta, prop_sg_n, prop_sg_eps_i, &
                          prop_sg_a, prop_sg_b, prop_jcf_on, prop_spall_fail, prop_jc_d1, prop_jc_d2, prop_jc_d3, prop_jc_d4, &
                          prop_jc_d5, prop_jc_efmin, prop_ise_mu_lo, prop_ise_beta, prop_ise_u_top, &
                          prop_ise_tw00, prop_ise_tdw00, prop_ise_cw00, prop_ise_cdw00, &
                          ise_tension_intervals, ise_compression_intervals, mg_denominator_floor, &
                          strength_bilinear, strength_elastic, strength_epp, strength_hjc, &
                          strength_johnson_cook, strength_power_law, strength_steinberg_guinan, &
                          temperature_plastic_work, temperature_internal_energy, melt_lindemann, rate_printed
  implicit none
  private

  !> Relative tolerance of the iterative return mapping [-].
  real(wp), parameter :: return_tolerance = 1.0e-12_wp
  integer, parameter :: return_max_iterations = 60
  !> Temperature to which the Steinberg-Guinan shear modulus and yield
  !> stress are referred (Steinberg, Cochran & Guinan 1980, J. Appl. Phys.
  !> 51:1498: the term B (T - 300) of G and Y) [K].
  real(wp), parameter :: sg_reference_temperature = 300.0_wp
  !> Largest magnitude of the argument D3 sigma* of the exponential in the
  !> Johnson-Cook strain to fracture: far inside the range of exp() (which
  !> overflows beyond 709), where eps_f is already infinite (or D1) for
  !> every purpose; sigma* itself is unbounded as the flow stress of a point
  !> near melt falls to zero [-].
  real(wp), parameter :: jc_exponent_limit = 100.0_wp
  !> Plastic strain rate, relative to the reference rate, below which the
  !> slope of the printed rate term (rate/rate0)^m is evaluated at this
  !> value: for m < 1 the slope is unbounded at zero rate [-].
  real(wp), parameter :: rate_slope_floor = 1.0e-9_wp
  !> A history flag (failed, melted) is set when it exceeds this; flags
  !> are stored as 0 or 1 [-].
  real(wp), parameter :: flag_threshold = 0.5_wp

  public :: material_update, strength_update, rotate_deviator, equivalent_stress, eos_pressure
  public :: deviator_double_contraction, sound_speed
  public :: hjc_pressure, hjc_yield_stress, hjc_update
  public :: shear_modulus, melting_temperature, state_temperature, isentrope_energy, melt_update
  public :: pressure_floor, cut_pressure, point_failed, flow_stress_at

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
    real(wp), intent(inout) :: s(4)    !< deviator [Pa]
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
    real(wp), intent(in) :: angle      !< [rad]
    real(wp), intent(out) :: cs, sn    !< [-]
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
    integer, value :: ieos
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

  ! ---- temperature, melting, failure flags --------------------------------

  !> The integer id of a model switch of the property row (temp_model,
  !> melt_model, pl_rate_form, jcf_on: whole numbers >= 0 held as reals):
  !> the nearest integer, int(x + 1/2). The same value as nint(x) for these
  !> arguments, converted in line: nint is a call of the C library's
  !> lround in a build without SSE4.1, and the switches are read several
  !> times for every element in every cycle.
  pure integer function model_id(x)
    real(wp), intent(in) :: x      !< model id [-]
    model_id = int(x + 0.5_wp)
  end function model_id

  !> .true. when a history flag (failed, melted) is set.
  pure logical function flag_set(flag)
    real(wp), intent(in) :: flag   !< 0 or 1 [-]
    flag_set = flag > flag_threshold
  end function flag_set

  !> .true. once the point has failed (Johnson-Cook damage D >= 1 or any
  !> other failure model that sets hist(hist_failed)): it carries no
  !> deviatoric stress and no tension, and keeps its mass and momentum.
  pure logical function point_failed(hist)
    real(wp), intent(in) :: hist(n_hist)   !< history variables of the point
    point_failed = flag_set(hist(hist_failed))
  end function point_failed

  !> Lowest pressure the point may carry [Pa]: the spall cut-off p_min of
  !> its material (-1e300, none, when the deck gives no p_min), and 0 once
  !> it has failed (no tension).
  pure function pressure_floor(props, hist) result(p_floor)
    real(wp), intent(in) :: props(n_props)
    real(wp), intent(in) :: hist(n_hist)   !< history variables of the point
    real(wp) :: p_floor
    p_floor = props(prop_pmin)
    if (point_failed(hist)) p_floor = max(p_floor, 0.0_wp)
  end function pressure_floor

  !> The pressure a point carries [Pa]: p not below its pressure floor (the
  !> spall cut-off; no tension once failed). The rule the particle code
  !> applies after its own energy update.
  pure function cut_pressure(props, hist, p) result(p_cut)
    real(wp), intent(in) :: props(n_props)
    real(wp), intent(in) :: hist(n_hist)   !< history variables of the point
    real(wp), intent(in) :: p              !< EOS pressure [Pa]
    real(wp) :: p_cut
    p_cut = max(p, pressure_floor(props, hist))
  end function cut_pressure

  !> Melting temperature at density rho [K]: constant T_m0, or the
  !> Lindemann law in the Steinberg-Guinan form (Steinberg, Cochran &
  !> Guinan 1980)
  !>   T_m = T_m0 exp(2a (1 - rho0/rho)) (rho/rho0)^(2 (Gamma0 - a - 1/3))
  !> in compression; below the reference density T_m = T_m0 (the law is a
  !> fit to compressed states; a separating fragment's density falls with
  !> the voids between its points, not the solid's).
  pure function melting_temperature(props, rho) result(tm)
    real(wp), intent(in) :: props(n_props)
    real(wp), intent(in) :: rho            !< density [kg/m^3]
    real(wp) :: tm, x, a
    tm = props(prop_t_melt)
    if (model_id(props(prop_melt_model)) == melt_lindemann .and. rho > props(prop_rho0)) then
      x = props(prop_rho0)/rho
      a = props(prop_melt_a)
      tm = tm*exp(2.0_wp*a*(1.0_wp - x))*x**(-2.0_wp*(props(prop_gamma0) - a - one_third))
    end if
  end function melting_temperature

  !> Whether a point at temperature temp [K] and density rho [kg/m^3] is at
  !> or above its melting temperature: temp >= melting_temperature, to the
  !> bit. Below T_m0 the Lindemann law's exponential and power are not
  !> evaluated when its coefficients cannot lower T_m (a >= 0 and
  !> Gamma0 - a - 1/3 >= 0: in compression both factors are then at least
  !> 1, and exp and pow, rounded faithfully, keep them so), which holds for
  !> every library entry; a Steinberg-Guinan point asks several times per
  !> step (shear modulus, flow stress, melting rule, sound speed).
  pure logical function at_melt(props, rho, temp)
    real(wp), intent(in) :: props(n_props)
    real(wp), intent(in) :: rho, temp
    real(wp) :: a
    a = props(prop_melt_a)
    if (temp < props(prop_t_melt)) then
      if (model_id(props(prop_melt_model)) /= melt_lindemann) then
        at_melt = .false.
        return
      else if (2.0_wp*a >= 0.0_wp .and. -2.0_wp*(props(prop_gamma0) - a - one_third) <= 0.0_wp) then
        at_melt = .false.
        return
      end if
    end if
    at_melt = temp >= melting_temperature(props, rho)
  end function at_melt

  !> Cubic Hermite interpolation on [0, 1]: values w0, w1 at the ends and
  !> slopes times the interval d0, d1.
  pure function hermite(w0, d0, w1, d1, t) result(w)
    real(wp), intent(in) :: w0, d0, w1, d1, t
    real(wp) :: w, t2, t3
    t2 = t*t
    t3 = t2*t
    w = (2.0_wp*t3 - 3.0_wp*t2 + 1.0_wp)*w0 + (t3 - 2.0_wp*t2 + t)*d0 + (3.0_wp*t2 - 2.0_wp*t3)*w1 &
        + (t3 - t2)*d1
  end function hermite

  !> Specific internal energy e_s(mu) on the reference isentrope of a
  !> Mie-Grueneisen material [J/kg]: the solution of de = -p dv through
  !> (rho0, e = 0) with fsph's p = a(rho) + Gamma0 rho0 e, tabulated at
  !> set-up (fsph.materials.isentrope_table) and interpolated by cubic
  !> Hermite polynomials with the exact slopes of that equation. Tension:
  !> nodes uniform in mu from ise_mu_lo (below it: the value there) to 0.
  !> Compression: w = e_s (1 - (s-1) mu), finite at the EOS's pole, on
  !> nodes uniform in u = -ln(1 - (s-1) mu) + beta (s-1) mu, which crowds
  !> them towards the pole, up to where 1 - (s-1) mu = mg_denominator_floor.
  pure function isentrope_energy(props, mu) result(es)
    real(wp), intent(in) :: props(n_props)
    real(wp), intent(in) :: mu             !< volumetric strain rho/rho0 - 1 [-]
    real(wp) :: es, h, x, t, y, den, u, w
    integer :: k
    if (mu <= 0.0_wp) then
      h = -props(prop_ise_mu_lo)/ise_tension_intervals
      x = max(mu - props(prop_ise_mu_lo), 0.0_wp)/h
      k = min(int(x), ise_tension_intervals - 1)
      t = x - k
      es = hermite(props(prop_ise_tw00 + k), h*props(prop_ise_tdw00 + k), props(prop_ise_tw00 + k + 1), &
                   h*props(prop_ise_tdw00 + k + 1), t)
    else
      y = (props(prop_s) - 1.0_wp)*mu
      den = max(1.0_wp - y, mg_denominator_floor)
      u = -log(den) + props(prop_ise_beta)*y
      h = props(prop_ise_u_top)/ise_compression_intervals
      x = min(u/h, real(ise_compression_intervals, wp))
      k = min(int(x), ise_compression_intervals - 1)
      t = x - k
      w = hermite(props(prop_ise_cw00 + k), h*props(prop_ise_cdw00 + k), props(prop_ise_cw00 + k + 1), &
                  h*props(prop_ise_cdw00 + k + 1), t)
      es = w/den
    end if
  end function isentrope_energy

  !> Temperature of the thermodynamic state [K]. Model internal_energy
  !> (Mie-Grueneisen with a specific heat c):
  !>   T = T_s(rho) + (e - e_s(rho))/c,  T_s = T_room exp(Gamma0 (1 - rho0/rho)),
  !> about the reference isentrope through (rho0, e = 0, T_room) (Gamma rho
  !> = Gamma0 rho0 along it), shock heating included. Below the reference
  !> density the state is taken at the matrix strain: where the pressure
  !> floor holds at energy e (voids open under the spall cut-off or after
  !> failure; the solid between them does not stretch further). Model
  !> plastic_work: temp unchanged (the strength step heats the point). The
  !> particle code calls this after its final energy update.
  pure function state_temperature(props, ieos, rho, e, hist, temp) result(t)
    real(wp), intent(in) :: props(n_props)
    integer, value :: ieos
    real(wp), intent(in) :: rho            !< density [kg/m^3]
    real(wp), intent(in) :: e              !< specific internal energy [J/kg]
    real(wp), intent(in) :: hist(n_hist)   !< history variables of the point
    real(wp), intent(in) :: temp           !< temperature before [K]
    real(wp) :: t, mu, k0, mu_floor
    t = temp
    if (model_id(props(prop_temp_model)) /= temperature_internal_energy .or. ieos /= eos_mie_gruneisen) return
    mu = rho/props(prop_rho0) - 1.0_wp
    if (mu < 0.0_wp) then
      k0 = props(prop_rho0)*props(prop_c0)**2
      mu_floor = min((pressure_floor(props, hist) - props(prop_gamma0)*props(prop_rho0)*e)/k0, 0.0_wp)
      mu = max(mu, mu_floor, props(prop_ise_mu_lo))
    end if
    t = props(prop_t_room)*exp(props(prop_gamma0)*mu/(1.0_wp + mu)) + (e - isentrope_energy(props, mu))/props(prop_cv)
  end function state_temperature

  !> Melting rule at the end of a step: a point at or above its melting
  !> temperature carries no deviatoric stress (every strength model) and is
  !> flagged melted; below it the flag is cleared (it may solidify again).
  pure subroutine melt_update(props, rho, temp, s, hist)
    real(wp), intent(in) :: props(n_props)
    real(wp), intent(in) :: rho            !< density [kg/m^3]
    real(wp), intent(in) :: temp           !< temperature [K]
    real(wp), intent(inout) :: s(4)        !< deviatoric stress [Pa]
    real(wp), intent(inout) :: hist(n_hist) !< history variables of the point
    if (at_melt(props, rho, temp)) then
      s = 0.0_wp
      hist(hist_melted) = 1.0_wp
    else
      hist(hist_melted) = 0.0_wp
    end if
  end subroutine melt_update

  ! ---- strength -----------------------------------------------------------

  !> Shear modulus of a point [Pa]: Steinberg-Guinan
  !>   G = G0 [1 + A p (rho/rho0)^(-1/3) - B (T - 300 K)]
  !> (Steinberg, Cochran & Guinan 1980), not below zero and zero at
  !> and above melt; the constant G of every other model. The elastic
  !> trial and the sound speed use it.
  pure function shear_modulus(props, istrength, rho, p, temp) result(g)
    real(wp), intent(in) :: props(n_props)
    integer, value :: istrength
    real(wp), intent(in) :: rho            !< density [kg/m^3]
    real(wp), intent(in) :: p              !< pressure [Pa]
    real(wp), intent(in) :: temp           !< temperature [K]
    real(wp) :: g
    if (istrength == strength_steinberg_guinan) then
      g = props(prop_shear)*sg_factor(props, rho, p, temp)
    else
      g = props(prop_shear)
    end if
  end function shear_modulus

  !> The Steinberg-Guinan pressure and temperature factor
  !> max(1 + A p (rho0/rho)^(1/3) - B (T - 300 K), 0) of G and Y, zero at
  !> and above melt [-].
  pure function sg_factor(props, rho, p, temp) result(f)
    real(wp), intent(in) :: props(n_props), rho, p, temp
    real(wp) :: f
    f = 0.0_wp
    if (at_melt(props, rho, temp)) return
    f = max(1.0_wp + props(prop_sg_a)*p*(props(prop_rho0)/rho)**one_third &
            - props(prop_sg_b)*(temp - sg_reference_temperature), 0.0_wp)
  end function sg_factor

  !> Rate term of the power-law model at plastic strain rate [1/s]:
  !> printed 1 + (rate/rate0)^m (Liao et al. 2022 eq 13), or power
  !> (1 + rate/rate0)^m [-].
  pure function power_law_rate(props, rate_p) result(r)
    real(wp), intent(in) :: props(n_props), rate_p
    real(wp) :: r
    if (model_id(props(prop_pl_rate_form)) == rate_printed) then
      r = 1.0_wp + (rate_p/props(prop_pl_rate0))**props(prop_pl_m)
    else
      r = (1.0_wp + rate_p/props(prop_pl_rate0))**props(prop_pl_m)
    end if
  end function power_law_rate

  !> d(rate term)/d(rate) of the power-law model [s].
  pure function power_law_rate_slope(props, rate_p) result(dr)
    real(wp), intent(in) :: props(n_props), rate_p
    real(wp) :: dr, inv_rate0, m
    inv_rate0 = 1.0_wp/props(prop_pl_rate0)
    m = props(prop_pl_m)
    if (model_id(props(prop_pl_rate_form)) == rate_printed) then
      dr = m*inv_rate0*max(rate_p*inv_rate0, rate_slope_floor)**(m - 1.0_wp)
    else
      dr = m*inv_rate0*(1.0_wp + rate_p*inv_rate0)**(m - 1.0_wp)
    end if
  end function power_law_rate_slope

  !> Current flow stress of the strength model [Pa] at plastic strain
  !> eps_p, plastic strain rate rate_p [1/s] (power law), rate factor
  !> (Johnson-Cook) and thermal factor (zero at melt; Steinberg-Guinan:
  !> the pressure and temperature factor).
  pure real(wp) function flow_stress(props, istrength, eps_p, rate_p, rate_factor, thermal_factor) result(sy)
    real(wp), intent(in) :: props(n_props)
    integer, value :: istrength
    real(wp), intent(in) :: eps_p, rate_p, rate_factor, thermal_factor
    select case (istrength)
    case (strength_epp)
      sy = props(prop_yield)*thermal_factor
    case (strength_bilinear)
      sy = (props(prop_yield) + props(prop_hard)*eps_p)*thermal_factor
    case (strength_johnson_cook)
      ! a point that has not yielded (most of a target) needs no power
      if (eps_p > 0.0_wp) then
        sy = (props(prop_jc_a) + props(prop_jc_b)*eps_p**props(prop_jc_n))*(rate_factor*thermal_factor)
      else
        sy = props(prop_jc_a)*(rate_factor*thermal_factor)
      end if
    case (strength_power_law)
      sy = props(prop_pl_sigma0)*(1.0_wp + eps_p/props(prop_pl_eps0))**props(prop_pl_n) &
           *power_law_rate(props, rate_p)*thermal_factor
    case (strength_steinberg_guinan)
      sy = min(sg_hardening(props, eps_p), props(prop_sg_ymax))*thermal_factor
    case default
      sy = huge(1.0_wp)
    end select
  end function flow_stress

  !> Steinberg-Guinan work hardening Y0 [1 + beta (eps_p + eps_i)]^n [Pa]
  !> (Steinberg, Cochran & Guinan 1980): Y0 itself, without the power, for
  !> a point that has not yielded (1^n = 1 exactly, so the same bits).
  pure real(wp) function sg_hardening(props, eps_p) result(hard)
    real(wp), intent(in) :: props(n_props)
    real(wp), intent(in) :: eps_p          !< equivalent plastic strain [-]
    real(wp) :: base
    base = 1.0_wp + props(prop_sg_beta)*(eps_p + props(prop_sg_eps_i))
    if (base == 1.0_wp) then
      hard = props(prop_sg_y0)
    else
      hard = props(prop_sg_y0)*base**props(prop_sg_n)
    end if
  end function sg_hardening

  !> Steinberg-Guinan flow stress min(hardening, Ymax) f [Pa] and its slope
  !> in eps_p [Pa] (zero at Ymax), f the pressure and temperature factor.
  pure subroutine sg_flow(props, eps_p, thermal_factor, sy, dsy)
    real(wp), intent(in) :: props(n_props)
    real(wp), intent(in) :: eps_p, thermal_factor
    real(wp), intent(out) :: sy, dsy
    real(wp) :: hard
    hard = sg_hardening(props, eps_p)
    sy = min(hard, props(prop_sg_ymax))*thermal_factor
    dsy = 0.0_wp
    if (hard < props(prop_sg_ymax)) &
      dsy = hard*props(prop_sg_n)*props(prop_sg_beta)/(1.0_wp + props(prop_sg_beta)*(eps_p + props(prop_sg_eps_i))) &
            *thermal_factor
  end subroutine sg_flow

  !> Slope of the flow stress along the return, d sy/d(d eps_p) [Pa], with
  !> the plastic strain rate d eps_p/dt (inv_dt = 1/dt [1/s]): only the
  !> plastic return needs it (a Johnson-Cook slope costs a power of its own).
  pure real(wp) function flow_slope(props, istrength, eps_p, rate_p, inv_dt, rate_factor, thermal_factor) result(dsy)
    real(wp), intent(in) :: props(n_props)
    integer, value :: istrength
    real(wp), intent(in) :: eps_p, rate_p, inv_dt, rate_factor, thermal_factor
    !> Plastic strain below which the Johnson-Cook slope is evaluated at this
    !> value (the slope of eps^n is unbounded at zero for n < 1) [-].
    real(wp), parameter :: eps_slope_floor = 1.0e-9_wp
    real(wp) :: hard, base
    select case (istrength)
    case (strength_bilinear)
      dsy = props(prop_hard)*thermal_factor
    case (strength_johnson_cook)
      dsy = props(prop_jc_b)*props(prop_jc_n)*max(eps_p, eps_slope_floor)**(props(prop_jc_n) - 1.0_wp) &
            *(rate_factor*thermal_factor)
    case (strength_power_law)
      base = 1.0_wp + eps_p/props(prop_pl_eps0)
      hard = base**props(prop_pl_n)
      dsy = props(prop_pl_sigma0)*thermal_factor &
            *(props(prop_pl_n)/props(prop_pl_eps0)*hard/base*power_law_rate(props, rate_p) &
              + hard*power_law_rate_slope(props, rate_p)*inv_dt)
    case (strength_steinberg_guinan)
      call sg_flow(props, eps_p, thermal_factor, hard, dsy)
    case default
      dsy = 0.0_wp
    end select
  end function flow_slope

  !> Flow stress and its slope along the return together (flow_stress,
  !> flow_slope), the same bits: Steinberg-Guinan's hardening power, which
  !> both carry, is taken once per Newton iteration.
  pure subroutine flow_stress_slope(props, istrength, eps_p, rate_p, inv_dt, rate_factor, thermal_factor, sy, dsy)
    real(wp), intent(in) :: props(n_props)
    integer, value :: istrength
    real(wp), intent(in) :: eps_p, rate_p, inv_dt, rate_factor, thermal_factor
    real(wp), intent(out) :: sy, dsy       !< [Pa]
    if (istrength == strength_steinberg_guinan) then
      call sg_flow(props, eps_p, thermal_factor, sy, dsy)
    else
      sy = flow_stress(props, istrength, eps_p, rate_p, rate_factor, thermal_factor)
      dsy = flow_slope(props, istrength, eps_p, rate_p, inv_dt, rate_factor, thermal_factor)
    end if
  end subroutine flow_stress_slope

  !> Flow stress of a point's strength model [Pa] at plastic strain eps_p,
  !> plastic strain rate rate_p [1/s], total equivalent strain rate
  !> rate_eq [1/s] (the Johnson-Cook rate term), pressure p [Pa] (Steinberg-
  !> Guinan), temperature [K] and density [kg/m^3]: the yield of a
  !> material point as the return mapping sees it (0 at and above melt).
  pure function flow_stress_at(props, istrength, eps_p, rate_p, rate_eq, p, temp, rho) result(sy)
    real(wp), intent(in) :: props(n_props)
    integer, value :: istrength
    real(wp), intent(in) :: eps_p, rate_p, rate_eq, p, temp, rho
    real(wp) :: sy, rate_factor, thermal_factor
    call strength_factors(props, istrength, rate_eq, p, temp, rho, rate_factor, thermal_factor)
    sy = flow_stress(props, istrength, eps_p, rate_p, rate_factor, thermal_factor)
  end function flow_stress_at

  !> The factors a step's flow stress carries: the Johnson-Cook rate factor
  !> (1 + C ln eps_dot*), eps_dot* = rate_eq/eps_dot_0 taken >= 1 (the
  !> usual form of the model below the reference rate; no logarithm where
  !> it is multiplied by C = 0), and the thermal factor of each model,
  !> zero at and above the melting temperature at density rho.
  pure subroutine strength_factors(props, istrength, rate_eq, p, temp, rho, rate_factor, thermal_factor)
    real(wp), intent(in) :: props(n_props)
    integer, value :: istrength
    real(wp), intent(in) :: rate_eq        !< equivalent total strain rate [1/s]
    real(wp), intent(in) :: p, temp, rho   !< [Pa], [K], [kg/m^3]
    real(wp), intent(out) :: rate_factor, thermal_factor
    rate_factor = 1.0_wp
    thermal_factor = 1.0_wp
    select case (istrength)
    case (strength_johnson_cook)
      if (props(prop_jc_c) /= 0.0_wp) then
        if (rate_eq > props(prop_eps0)) rate_factor = 1.0_wp + props(prop_jc_c)*log(rate_eq/props(prop_eps0))
      end if
      thermal_factor = softening(homologous_temperature(props, temp, melting_temperature(props, rho)), &
                                 props(prop_jc_m), .true.)
    case (strength_power_law)
      thermal_factor = softening(homologous_temperature(props, temp, melting_temperature(props, rho)), &
                                 props(prop_pl_l), .false.)
    case (strength_steinberg_guinan)
      thermal_factor = sg_factor(props, rho, p, temp)
    case default
      if (at_melt(props, rho, temp)) thermal_factor = 0.0_wp
    end select
  end subroutine strength_factors

  !> Return mapping to the von Mises surface. On entry s is the elastic
  !> trial deviator; on exit it lies on (or inside) the yield surface.
  !> Solves seq_trial - 3 G d eps_p = sy(eps_p + d eps_p, d eps_p/dt), the
  !> consistency condition with the plastic strain rate of the step (the
  !> power law's rate term): closed form for the linear models, safeguarded
  !> Newton otherwise. Returns the plastic strain increment and the flow
  !> stress at the end of the step.
  pure subroutine radial_return(props, istrength, g, dt, rate_factor, thermal_factor, eps_p, s, deps_p, sy)
    real(wp), intent(in) :: props(n_props)
    integer, value :: istrength
    real(wp), intent(in) :: g              !< shear modulus [Pa]
    real(wp), intent(in) :: dt             !< time step [s]
    real(wp), intent(in) :: rate_factor, thermal_factor, eps_p
    real(wp), intent(inout) :: s(4)        !< trial deviator in, returned out [Pa]
    real(wp), intent(out) :: deps_p        !< plastic strain increment [-]
    real(wp), intent(out) :: sy            !< flow stress at the end of the step [Pa]
    real(wp) :: seq_trial, seq2, g3, dsy, lo, hi, f, df, x, dx, inv_dt
    integer :: it
    deps_p = 0.0_wp
    sy = flow_stress(props, istrength, eps_p, 0.0_wp, rate_factor, thermal_factor)
    ! an elastic point (the common case) needs no square root
    seq2 = 1.5_wp*deviator_double_contraction(s, s)
    if (seq2 <= sy*sy) return
    seq_trial = sqrt(seq2)
    inv_dt = 1.0_wp/dt
    dsy = flow_slope(props, istrength, eps_p, 0.0_wp, inv_dt, rate_factor, thermal_factor)
    g3 = 3.0_wp*g
    select case (istrength)
    case (strength_epp, strength_bilinear)
      ! closed form: seq_trial - 3G dl = Y0 + H (eps_p + dl)
      deps_p = (seq_trial - sy)/(g3 + dsy)
    case (strength_power_law)
      deps_p = power_law_return(props, g3, inv_dt, rate_factor, thermal_factor, eps_p, seq_trial, &
                                (seq_trial - sy)/(g3 + dsy))
    case default
      ! safeguarded Newton on f(x) = seq_trial - 3G x - sy(eps_p + x, x/dt), x in [0, seq_trial/3G]
      lo = 0.0_wp
      hi = seq_trial/g3
      x = min((seq_trial - sy)/(g3 + dsy), hi)
      do it = 1, return_max_iterations
        call flow_stress_slope(props, istrength, eps_p + x, x*inv_dt, inv_dt, rate_factor, thermal_factor, sy, dsy)
        f = seq_trial - g3*x - sy
        df = -(g3 + dsy)
        call bracketed_newton_step(f, df, x, lo, hi, dx)
        x = x + dx
        if (abs(dx) <= return_tolerance*max(x, return_tolerance)) exit
      end do
      deps_p = x
    end select
    sy = flow_stress(props, istrength, eps_p + deps_p, deps_p*inv_dt, rate_factor, thermal_factor)
    s = s*(sy/seq_trial)
  end subroutine radial_return

  !> One safeguarded Newton step on a decreasing function f of v: the
  !> bracket [lo, hi] of the root shrinks to v on the side f's sign shows,
  !> then the Newton step -f/df, or bisection where it would leave the
  !> bracket.
  pure subroutine bracketed_newton_step(f, df, v, lo, hi, dv)
    real(wp), intent(in) :: f, df, v       !< function, its derivative and the point
    real(wp), intent(inout) :: lo, hi      !< bracket of the root
    real(wp), intent(out) :: dv            !< step
    if (f > 0.0_wp) then
      lo = v
    else
      hi = v
    end if
    dv = -f/df
    if (v + dv <= lo .or. v + dv >= hi) dv = 0.5_wp*(lo + hi) - v
  end subroutine bracketed_newton_step

  !> Plastic strain increment of the power-law return [-]: the root of
  !> f = seq_trial - 3G x - sy(eps_p + x, x/dt) by safeguarded Newton in
  !> z = ln x over [ln(hi) - power_law_log_span, ln(hi)], hi = seq_trial/3G.
  !> The rate term (x/dt)^m is a power of x, so steep near x = 0 for m < 1
  !> (the printed form's root can lie at x ~ 1e-20, out of reach of
  !> bisection in x), and a smooth exponential in z.
  pure function power_law_return(props, g3, inv_dt, rate_factor, thermal_factor, eps_p, seq_trial, guess) &
      result(x)
    real(wp), intent(in) :: props(n_props)
    real(wp), intent(in) :: g3                 !< three times the shear modulus [Pa]
    real(wp), intent(in) :: inv_dt             !< 1/dt [1/s]
    real(wp), intent(in) :: rate_factor, thermal_factor, eps_p
    real(wp), intent(in) :: seq_trial          !< equivalent trial stress [Pa]
    real(wp), intent(in) :: guess              !< first estimate of x [-]
    !> Span of the search in ln x: down to e^-80 (1.8e-35) of the largest
    !> possible increment [-].
    real(wp), parameter :: power_law_log_span = 80.0_wp
    real(wp) :: x, z, z_lo, z_hi, dz, f, df, sy, dsy
    integer :: it
    z_hi = log(seq_trial/g3)
    z_lo = z_hi - power_law_log_span
    z = min(max(log(max(guess, tiny(1.0_wp))), z_lo), z_hi)
    do it = 1, return_max_iterations
      x = exp(z)
      sy = flow_stress(props, strength_power_law, eps_p + x, x*inv_dt, rate_factor, thermal_factor)
      dsy = flow_slope(props, strength_power_law, eps_p + x, x*inv_dt, inv_dt, rate_factor, thermal_factor)
      f = seq_trial - g3*x - sy
      df = -(g3 + dsy)*x
      call bracketed_newton_step(f, df, z, z_lo, z_hi, dz)
      z = z + dz
      if (abs(dz) <= return_tolerance) exit
    end do
    x = exp(z)
  end function power_law_return

  !> Homologous temperature T* = (T - T_room)/(T_m - T_room) [-].
  pure function homologous_temperature(props, temp, tm) result(tstar)
    real(wp), intent(in) :: props(n_props)
    real(wp), intent(in) :: temp, tm       !< temperature and melting temperature [K]
    real(wp) :: tstar
    tstar = (temp - props(prop_t_room))/(tm - props(prop_t_room))
  end function homologous_temperature

  !> Thermal softening factor at homologous temperature T*: 1 at and below
  !> room temperature, 0 at and above melt, in between 1 - T*^x
  !> (Johnson-Cook, x = m; of_tstar) or (1 - T*)^x (power law, x = l);
  !> x = 1 (linear softening, 6061-T651) needs no power.
  pure function softening(tstar, x, of_tstar) result(f)
    real(wp), intent(in) :: tstar, x       !< [-]
    logical, intent(in) :: of_tstar
    real(wp) :: f
    if (tstar <= 0.0_wp) then
      f = 1.0_wp
    else if (tstar >= 1.0_wp) then
      f = 0.0_wp
    else if (x == 1.0_wp) then
      f = 1.0_wp - tstar
    else if (of_tstar) then
      f = 1.0_wp - tstar**x
    else
      f = (1.0_wp - tstar)**x
    end if
  end function softening

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
    real(wp), intent(out) :: s_old(4), d_dev(4)   !< [Pa], [1/s]
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
  !> trial deviator with the point's shear modulus (Steinberg-Guinan: at
  !> the start-of-step pressure and temperature), return mapping, adiabatic
  !> heating from plastic work (temperature model plastic_work). Returns the
  !> rotated start-of-step deviator s_old and the deviatoric strain rate
  !> d_dev for the caller's work integral, the plastic strain increment and
  !> the flow stress at the end of the step.
  pure subroutine strength_update(props, istrength, dt, d, spin, rho, p, s, eps_p, temp, s_old, d_dev, deps_p, sy)
    real(wp), intent(in) :: props(n_props)
    integer, value :: istrength
    real(wp), intent(in) :: dt              !< time step [s]
    real(wp), intent(in) :: d(4)            !< strain rate (rr, zz, rz, tt) [1/s]
    real(wp), intent(in) :: spin            !< in-plane spin 1/2 (dvr/dz - dvz/dr) [1/s]
    real(wp), intent(in) :: rho             !< density at the end of the step [kg/m^3]
    real(wp), intent(in) :: p               !< pressure at the start of the step [Pa]
    real(wp), intent(inout) :: s(4)         !< deviatoric stress [Pa]
    real(wp), intent(inout) :: eps_p        !< equivalent plastic strain [-]
    real(wp), intent(inout) :: temp         !< temperature [K]
    real(wp), intent(out) :: s_old(4)       !< rotated start-of-step deviator [Pa]
    real(wp), intent(out) :: d_dev(4)       !< deviatoric strain rate [1/s]
    real(wp), intent(out) :: deps_p         !< plastic strain increment [-]
    real(wp), intent(out) :: sy             !< flow stress at the end of the step [Pa]
    real(wp) :: g, rate_factor, thermal_factor, rate_eq

    if (istrength == strength_steinberg_guinan) then
      ! G and the flow stress carry the same factor (sg_factor, its melting
      ! test and cube root): evaluated once
      rate_factor = 1.0_wp
      thermal_factor = sg_factor(props, rho, p, temp)
      g = props(prop_shear)*thermal_factor
    else
      g = shear_modulus(props, istrength, rho, p, temp)
    end if
    call elastic_trial(g, dt, d, spin, s, s_old, d_dev)
    deps_p = 0.0_wp
    sy = 0.0_wp
    if (istrength == strength_elastic) return
    if (.not. (g > 0.0_wp)) then
      ! no shear modulus (Steinberg-Guinan at or above melt, or softened
      ! to zero): no deviator and no plastic flow; a return would divide
      ! by 3G = 0 (it made the plastic strain of molten copper NaN)
      s = 0.0_wp
      return
    end if

    rate_eq = 0.0_wp
    if (istrength == strength_johnson_cook .and. props(prop_jc_c) /= 0.0_wp) &
      rate_eq = sqrt(2.0_wp/3.0_wp*deviator_double_contraction(d_dev, d_dev))
    if (istrength /= strength_steinberg_guinan) &
      call strength_factors(props, istrength, rate_eq, p, temp, rho, rate_factor, thermal_factor)
    call radial_return(props, istrength, g, dt, rate_factor, thermal_factor, eps_p, s, deps_p, sy)
    eps_p = eps_p + deps_p
    if (model_id(props(prop_temp_model)) == temperature_plastic_work .and. props(prop_cv) > 0.0_wp) then
      temp = temp + props(prop_chi)*sy*deps_p/(rho*props(prop_cv))
    end if
  end subroutine strength_update

  !> Johnson-Cook failure (Johnson & Cook 1985, Eng. Fract. Mech. 21:31):
  !>   D <- min(D + d eps_p / eps_f, 1),
  !>   eps_f = [D1 + D2 exp(D3 sigma*)] [1 + D4 ln eps_dot*] [1 + D5 T*] >= eps_f,min,
  !> sigma* = -p/sigma_eq, eps_dot* = (d eps_p/dt)/eps_dot_0 taken >= 1 (as
  !> the strength's rate term), T* = (T - T_room)/(T_m - T_room) in [0, 1].
  !> At D = 1 the point has failed (hist failed = 1).
  pure subroutine jc_damage(props, dt, p, deps_p, seq, temp, tm, hist)
    real(wp), intent(in) :: props(n_props)
    real(wp), intent(in) :: dt             !< time step [s]
    real(wp), intent(in) :: p              !< pressure [Pa]
    real(wp), intent(in) :: deps_p         !< plastic strain increment of the step [-]
    real(wp), intent(in) :: seq            !< von Mises equivalent stress [Pa]
    real(wp), intent(in) :: temp, tm       !< temperature, melting temperature [K]
    real(wp), intent(inout) :: hist(n_hist) !< history variables (damage, failed)
    real(wp) :: arg, rate_star, tstar, eps_f
    if (.not. (deps_p > 0.0_wp .and. seq > 0.0_wp)) return
    arg = min(max(props(prop_jc_d3)*(-p/seq), -jc_exponent_limit), jc_exponent_limit)
    rate_star = max(deps_p/(dt*props(prop_eps0)), 1.0_wp)
    tstar = min(max(homologous_temperature(props, temp, tm), 0.0_wp), 1.0_wp)
    eps_f = (props(prop_jc_d1) + props(prop_jc_d2)*exp(arg))*(1.0_wp + props(prop_jc_d4)*log(rate_star)) &
            *(1.0_wp + props(prop_jc_d5)*tstar)
    eps_f = max(eps_f, props(prop_jc_efmin))
    hist(hist_damage) = min(hist(hist_damage) + deps_p/eps_f, 1.0_wp)
    if (hist(hist_damage) >= 1.0_wp) hist(hist_failed) = 1.0_wp
  end subroutine jc_damage

  !> One constitutive step of one material point (elements; particles with
  !> an energy estimate): the deviatoric step (a failed point's deviator is
  !> zero), Johnson-Cook damage, then EOS and internal energy solved
  !> together (p linear in e, trapezoidal p dv work, Wilkins), the pressure
  !> floor (spall cut-off; no tension once failed), the temperature of the
  !> state, the melting rule and the sound speed.
  pure subroutine material_update(props, istrength, ieos, dt, d, spin, rho_old, rho_new, q, &
                                  s, p, eps_p, e, temp, hist, c, ierr)
    real(wp), intent(in) :: props(n_props)
    integer, value :: istrength, ieos
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
    real(wp), intent(inout) :: hist(n_hist) !< history variables (damage, failed, melted, ...)
    real(wp), intent(out) :: c              !< longitudinal sound speed [m/s]
    integer, intent(out) :: ierr
    real(wp) :: s_old(4), d_dev(4), dw_dev, dv, a, b, dadrho, e_star, p_new, rho_sum, inv, deps_p, sy, p_floor

    if (istrength == strength_hjc) then
      ! pressure first (it sets the strength), energy-independent: b = 0
      call hjc_update(props, dt, d, spin, rho_new, s, eps_p, hist, a, c, s_old, d_dev)
      b = 0.0_wp
      ierr = status_ok
      if (point_failed(hist)) s = 0.0_wp
    else
      if (point_failed(hist)) then
        ! no deviatoric stress, no plastic flow
        call elastic_trial(shear_modulus(props, istrength, rho_new, p, temp), dt, d, spin, s, s_old, d_dev)
        s = 0.0_wp
      else
        call strength_update(props, istrength, dt, d, spin, rho_new, p, s, eps_p, temp, s_old, d_dev, deps_p, sy)
        if (deps_p > 0.0_wp) hist(hist_plastic_work) = hist(hist_plastic_work) + sy*deps_p/rho_new
        if (model_id(props(prop_jcf_on)) == 1) then
          call jc_damage(props, dt, p, deps_p, sy, temp, melting_temperature(props, rho_new), hist)
          if (point_failed(hist)) s = 0.0_wp
        end if
      end if
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
    hist(hist_viscous_work) = hist(hist_viscous_work) - q*dv
    e = (e_star - 0.5_wp*a*dv)/(1.0_wp + 0.5_wp*b*dv)
    p_new = a + b*e
    p_floor = pressure_floor(props, hist)
    if (p_new < p_floor) then
      ! spall cut-off (no tension once failed): the pressure stays at the
      ! floor and the p dv work is done at it; with spall failure the
      ! point has failed (no tension, no deviator from the next step on)
      p_new = p_floor
      e = e_star - 0.5_wp*p_new*dv
      if (model_id(props(prop_spall_fail)) == 1) hist(hist_failed) = 1.0_wp
    end if
    p = p_new
    temp = state_temperature(props, ieos, rho_new, e, hist, temp)
    call melt_update(props, rho_new, temp, s, hist)
    if (istrength /= strength_hjc) c = sound_speed_inv(shear_modulus(props, istrength, rho_new, p, temp), dadrho, b, &
                                                       rho_old*rho_sum*inv, p)
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
      hist(hist_plastic_work) = hist(hist_plastic_work) + sy*deps_p/rho
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
