"""Holmquist-Johnson-Cook concrete at one point, through the API, against
hand-computed points on every branch (Holmquist, Johnson & Cook 1993), and
the principal-strain measure of element erosion."""

import math

import numpy as np
import pytest

from fsph.materials import hjc_lock_strain
from fsph.verify import hjc_pressure, material_point_update, triangle_principal_strain
from test_materials import material

# 48 MPa concrete (library entry concrete_48mpa_hjc)
RHO0, G = 2440.0, 14.86e9
A, B, N, C = 0.79, 1.60, 0.61, 0.007
FC, T, SMAX, EFMIN, D1, D2 = 48e6, 4e6, 7.0, 0.01, 0.04, 1.0
PCRUSH, MUCRUSH, PLOCK, MULOCK = 16e6, 0.001, 0.8e9, 0.10
K1, K2, K3 = 85e9, -171e9, 208e9
KE = PCRUSH / MUCRUSH   # elastic bulk modulus 16 GPa


def concrete(**overrides):
    return material("concrete_48mpa_hjc", **overrides)


def mu_plock():
    """Where the fully dense curve reaches P_lock, by bisection here."""
    lo, hi = 0.0, 0.1
    for _ in range(200):
        x = 0.5 * (lo + hi)
        if K1 * x + K2 * x**2 + K3 * x**3 < PLOCK:
            lo = x
        else:
            hi = x
    return MULOCK + 0.5 * (lo + hi) * (1 + MULOCK)


def loading(mu):
    """The virgin loading curve by hand."""
    if mu <= MUCRUSH:
        return KE * mu
    mp = mu_plock()
    if mu <= mp:
        return PCRUSH + (PLOCK - PCRUSH) * (mu - MUCRUSH) / (mp - MUCRUSH)
    x = (mu - MULOCK) / (1 + MULOCK)
    return K1 * x + K2 * x**2 + K3 * x**3


def test_lock_strain_is_where_the_fully_dense_curve_reaches_p_lock():
    assert hjc_lock_strain(concrete()) == pytest.approx(mu_plock(), rel=1e-10)
    assert 0.110 < mu_plock() < 0.111


@pytest.mark.parametrize("mu", [-2e-4, 5e-4, 1e-3, 0.02, 0.05, 0.10, 0.15, 0.25])
def test_loading_curve_on_every_branch(mu):
    out = hjc_pressure(concrete(), mu)
    expected = max(loading(mu), -T)
    assert out["p"] == pytest.approx(expected, rel=1e-12, abs=1e-3)
    assert out["mu_max"] == max(mu, 0.0)


def test_loading_curve_is_continuous_at_crush_and_lock():
    m = concrete()
    for mu in (MUCRUSH, mu_plock()):
        below = hjc_pressure(m, mu * (1 - 1e-9))["p"]
        above = hjc_pressure(m, mu * (1 + 1e-9))["p"]
        assert abs(above - below) < 1e-5 * abs(below)


def test_unloading_in_compaction_uses_the_interpolated_modulus():
    """From mu_max = 0.05 back to 0.045: slope (1 - F) K_e + F K1 with
    F = (mu_max - mu_crush)/(mu_plock - mu_crush)."""
    f = (0.05 - MUCRUSH) / (mu_plock() - MUCRUSH)
    k_u = (1 - f) * KE + f * K1
    out = hjc_pressure(concrete(), 0.045, mu_max=0.05)
    assert out["p"] == pytest.approx(loading(0.05) - k_u * 0.005, rel=1e-12)
    assert out["dpdmu"] == pytest.approx(k_u, rel=1e-12)
    assert out["mu_max"] == 0.05 and out["dmu_p"] == 0.0


def test_unloading_when_fully_dense_uses_k1():
    out = hjc_pressure(concrete(), 0.19, mu_max=0.2)
    assert out["p"] == pytest.approx(loading(0.2) - K1 / (1 + MULOCK) * 0.01, rel=1e-12)


def test_elastic_unloading_below_crush_is_reversible():
    out = hjc_pressure(concrete(), 2e-4, mu_max=8e-4)
    assert out["p"] == pytest.approx(KE * 2e-4, rel=1e-12)


@pytest.mark.parametrize("damage", [0.0, 0.5, 1.0])
def test_tensile_limit_falls_with_damage(damage):
    out = hjc_pressure(concrete(), -0.01, damage=damage)
    assert out["p"] == pytest.approx(-T * (1 - damage), abs=1e-6)


def test_permanent_compaction_grows_only_on_loading():
    """Crushing to mu = 0.05 leaves mu_p = mu_max - p(mu_max)/K_u; a
    further load from there adds only the growth."""
    f = (0.05 - MUCRUSH) / (mu_plock() - MUCRUSH)
    k_u = (1 - f) * KE + f * K1
    out = hjc_pressure(concrete(), 0.05)
    assert out["dmu_p"] == pytest.approx(0.05 - loading(0.05) / k_u, rel=1e-12)
    f2 = (0.06 - MUCRUSH) / (mu_plock() - MUCRUSH)
    k_u2 = (1 - f2) * KE + f2 * K1
    again = hjc_pressure(concrete(), 0.06, mu_max=0.05)
    assert again["dmu_p"] == pytest.approx((0.06 - loading(0.06) / k_u2)
                                           - (0.05 - loading(0.05) / k_u), rel=1e-10)


def shear_step(m, mu, rate, damage=0.0, dt=1e-6):
    """One step at fixed density (on the loading curve at mu) with a pure
    shear rate d_rz = rate, from zero deviator."""
    rho = RHO0 * (1 + mu)
    d = np.array([0.0, 0.0, rate, 0.0])
    state = {"s": np.zeros(4), "p": 0.0, "eps_p": 0.0, "e": 0.0, "temp": 293.15,
             "damage": damage, "mu_max": max(rho / RHO0 - 1.0, 0.0)}   # as the solver computes mu
    return material_point_update(m, dt, d, 0.0, rho, rho, 0.0, state)


def equivalent(s):
    return math.sqrt(1.5 * (s[0] ** 2 + s[1] ** 2 + s[3] ** 2 + 2 * s[2] ** 2))


def strength(p, damage, rate_eq):
    """HJC strength by hand [Pa]."""
    factor = 1 + C * math.log(rate_eq) if rate_eq > 1.0 else 1.0
    if p > 0:
        return FC * min((A * (1 - damage) + B * (p / FC) ** N) * factor, SMAX)
    return FC * A * (1 - damage) * (1 + p / T) * factor


@pytest.mark.parametrize("mu,damage", [(0.0005, 0.0), (0.03, 0.0), (0.03, 0.6), (0.12, 0.0),
                                       (-5e-5, 0.0), (-5e-5, 0.3)])
def test_strength_and_damage_growth(mu, damage):
    """Trial deviator far above the surface: the return lands on the HJC
    strength at the step's pressure; damage grows by
    d eps_p / max(D1 (P* + T*)^D2, EF_min) (no compaction at fixed mu)."""
    rate, dt = 2.0e3, 2e-5     # trial deviator 2.06 GPa, above any strength here
    m = concrete()
    out = shear_step(m, mu, rate, damage, dt)
    p = max(loading(mu), -T * (1 - damage))
    assert out["p"] == pytest.approx(p, rel=1e-12, abs=1e-3)
    rate_eq = math.sqrt(2.0 / 3.0 * 2 * rate**2)
    sy = strength(p, damage, rate_eq)
    assert equivalent(out["s"]) == pytest.approx(sy, rel=1e-10)
    seq_trial = math.sqrt(3.0) * 2 * G * dt * rate
    deps = (seq_trial - sy) / (3 * G)
    assert out["eps_p"] == pytest.approx(deps, rel=1e-10)
    pts = (p + T) / FC
    eps_f = max(D1 * pts**D2, EFMIN) if pts > 0 else EFMIN
    assert out["damage"] == pytest.approx(min(damage + deps / eps_f, 1.0), rel=1e-10)


def test_strength_is_capped_at_s_max():
    out = shear_step(concrete(), 0.25, 5.0e3, dt=2e-5)
    assert equivalent(out["s"]) == pytest.approx(SMAX * FC, rel=1e-12)


def test_elastic_step_below_the_surface():
    """A small shear at 0.5 GPa stays elastic: s_rz = 2 G dt d_rz, no
    plastic strain, no damage."""
    out = shear_step(concrete(), 0.07, 1.0, dt=1e-6)
    assert out["s"][2] == pytest.approx(2 * G * 1e-6, rel=1e-12)
    assert out["eps_p"] == 0.0 and out["damage"] == 0.0


def test_crush_and_release_cycle_dissipates_the_hysteresis_area():
    """Load to mu = 0.06 and unload to p = 0 in small steps: the internal
    energy left is the area between the loading and unloading paths,
    integral of p dv, computed here from the hand curves."""
    m = concrete()
    steps = 2000
    f = (0.06 - MUCRUSH) / (mu_plock() - MUCRUSH)
    k_u = (1 - f) * KE + f * K1
    mu_p = 0.06 - loading(0.06) / k_u
    path = np.concatenate([np.linspace(0.0, 0.06, steps), np.linspace(0.06, mu_p, steps)[1:]])
    state = {"s": np.zeros(4), "p": 0.0, "eps_p": 0.0, "e": 0.0, "temp": 293.15,
             "damage": 0.0, "mu_max": 0.0}
    for mu0, mu1 in zip(path[:-1], path[1:]):
        state = material_point_update(m, 1e-7, np.zeros(4), 0.0, RHO0 * (1 + mu0),
                                      RHO0 * (1 + mu1), 0.0, state)
    # -p dv along both paths, v = 1/(rho0 (1 + mu)): the energy left [J/kg]
    load = np.linspace(0.0, 0.06, 20001)
    work_in = np.trapezoid([loading(x) for x in load], -1 / (RHO0 * (1 + load)))
    unload = np.linspace(0.06, mu_p, 20001)
    work_out = np.trapezoid(loading(0.06) - k_u * (0.06 - unload), -1 / (RHO0 * (1 + unload)))
    area = work_in + work_out
    assert area > 4e3   # about p_max mu_p / (2 rho0)
    assert state["e"] == pytest.approx(area, rel=2e-3)
    assert abs(state["p"]) < 1e-6 * PLOCK


# ---- erosion measure ------------------------------------------------------
TRI0 = np.array([[0.01, 0.0], [0.012, 0.0], [0.01, 0.002]])


def test_principal_strain_of_a_uniaxial_stretch():
    x = TRI0.copy()
    x[:, 1] *= 2.5
    assert triangle_principal_strain(x, TRI0) == pytest.approx(math.log(2.5), rel=1e-12)


def test_principal_strain_of_a_rotation_is_zero():
    angle = 0.7
    rot = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
    centre = TRI0.mean(axis=0)
    x = (TRI0 - centre) @ rot.T + centre
    assert abs(triangle_principal_strain(x, TRI0)) < 1e-12


def test_principal_strain_includes_the_hoop_stretch():
    """Moved outwards without in-plane strain: the hoop stretch rbar/rbar0."""
    x = TRI0 + [0.02, 0.0]
    rbar0, rbar = TRI0[:, 0].mean(), x[:, 0].mean()
    assert triangle_principal_strain(x, TRI0) == pytest.approx(math.log(rbar / rbar0), rel=1e-12)


def test_principal_strain_of_simple_shear():
    """Shear gamma: largest stretch gamma/2 + sqrt(1 + gamma^2/4)."""
    gamma = 1.2
    x = TRI0.copy()
    x[:, 0] += gamma * (TRI0[:, 1] - TRI0[0, 1])
    lam = gamma / 2 + math.sqrt(1 + gamma**2 / 4)
    assert triangle_principal_strain(x, TRI0) == pytest.approx(math.log(lam), rel=1e-12)
