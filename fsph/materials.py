"""Named material library and the packing of material constants into the
property table the Fortran models read (layout of ``fsph_material``).

Every library entry states where its numbers come from. Values are SI.
"""

import functools
import math

import numpy as np

from . import layouts

# Property table layout, model ids: fsph.layouts, the one source the solver
# is generated from (the build checks both agree through the layout digest).
PROPERTY_NAMES = layouts.PROPERTY_NAMES
STRENGTH_MODELS = {name: k for k, (name, _) in enumerate(layouts.STRENGTH_MODELS, 1)}
EOS_MODELS = {name: k for k, (name, _) in enumerate(layouts.EOS_MODELS, 1)}
TEMPERATURE_MODELS = {name: k for k, (name, _) in enumerate(layouts.TEMPERATURE_MODELS, 1)}
MELT_MODELS = {name: k for k, (name, _) in enumerate(layouts.MELT_MODELS, 1)}
RATE_FORMS = {name: k for k, (name, _) in enumerate(layouts.RATE_FORMS, 1)}
#: Deck keys of the J2 power-law model (strength 'power_law').
POWER_LAW_KEYS = ("pl_sigma0", "pl_eps0", "pl_rate0", "pl_n", "pl_m", "pl_l", "pl_rate_form")
#: Deck keys of the Steinberg-Guinan model (strength 'steinberg_guinan').
STEINBERG_GUINAN_KEYS = ("sg_y0", "sg_ymax", "sg_beta", "sg_n", "sg_a", "sg_b")
#: Deck keys of the Johnson-Cook failure model (all or none).
JC_FAILURE_KEYS = ("jc_d1", "jc_d2", "jc_d3", "jc_d4", "jc_d5")
#: Deck keys of the Holmquist-Johnson-Cook model (strength hjc with eos hjc).
HJC_KEYS = ("hjc_a", "hjc_b", "hjc_n", "hjc_c", "hjc_fc", "hjc_t", "hjc_smax", "hjc_efmin",
            "hjc_d1", "hjc_d2", "hjc_pcrush", "hjc_mucrush", "hjc_plock", "hjc_mulock",
            "hjc_k1", "hjc_k2", "hjc_k3")

#: Pressure cut-off used when a material declares none [Pa]: no cut-off.
NO_PRESSURE_CUTOFF = -1.0e300

LIBRARY = {
    "steel_elastic_bar": {
        "source": "Xiao et al. 2012 section 3.1 (elastic bar): rho 7850 kg/m^3, E 206 GPa, nu 0.3",
        "strength": "elastic", "eos": "linear",
        "density": 7850.0, "youngs_modulus": 206.0e9, "poisson_ratio": 0.3,
    },
    "armco_iron": {
        "source": ("Libersky et al. 1993 (J. Comput. Phys. 109:67) as used by Xiao et al. 2012 "
                   "section 3.2: EPP + Mie-Grueneisen; values as read in a public SPH "
                   "Taylor-bar example of the same geometry (s printed there as 1800, "
                   "a typo for 1.8)"),
        "strength": "epp", "eos": "mie_gruneisen",
        "density": 7850.0, "shear_modulus": 80.0e9, "yield_stress": 0.6e9,
        "c0": 3630.0, "s": 1.8, "gamma0": 1.81,
    },
    "armco_iron_jc": {
        "source": ("Johnson & Cook 1983 Armco iron constants (read second-hand), "
                   "with the Mie-Grueneisen EOS of armco_iron"),
        "strength": "johnson_cook", "eos": "mie_gruneisen",
        "density": 7850.0, "shear_modulus": 80.0e9,
        "jc_a": 175.0e6, "jc_b": 380.0e6, "jc_n": 0.32, "jc_c": 0.06, "jc_m": 0.55,
        "melt_temperature": 1811.0, "specific_heat": 452.0,
        "c0": 3630.0, "s": 1.8, "gamma0": 1.81,
    },
    "steel_4340_epp": {
        "source": "Xiao et al. 2012 section 3.3 projectile: EPP, rho 7830, E 206 GPa, nu 0.3, Y0 1.43 GPa",
        "strength": "epp", "eos": "linear",
        "density": 7830.0, "youngs_modulus": 206.0e9, "poisson_ratio": 0.3,
        "yield_stress": 1.43e9,
    },
    "al_6061_t651": {
        "source": "Xiao et al. 2012 table 1 (6061-T651 target): Johnson-Cook + Mie-Grueneisen",
        "strength": "johnson_cook", "eos": "mie_gruneisen",
        "density": 2710.0, "youngs_modulus": 69.0e9, "poisson_ratio": 0.33,
        "c0": 5380.0, "s": 1.337, "gamma0": 2.1, "specific_heat": 880.0,
        "jc_a": 0.262e9, "jc_b": 0.161e9, "jc_c": 0.0, "jc_n": 0.3156,
        "melt_temperature": 920.0, "jc_m": 1.0, "p_min": -0.5e9,
    },
    "projectile_bilinear_concrete": {
        "source": ("Xiao et al. 2012 section 3.4 projectile: bilinear hardening rho 8300, "
                   "E 200 GPa, nu 0.3, Y0 1.72 GPa, E_T 15 GPa"),
        "strength": "bilinear", "eos": "linear",
        "density": 8300.0, "youngs_modulus": 200.0e9, "poisson_ratio": 0.3,
        "yield_stress": 1.72e9, "tangent_modulus": 15.0e9,
    },
    "concrete_48mpa_hjc": {
        "source": ("Holmquist, Johnson & Cook 1993 (14th Int. Symp. Ballistics 591-600) "
                   "constants for the 48 MPa concrete of Hanchak et al. 1992, as used by "
                   "Xiao et al. 2012 section 3.4 and Hu et al. 2013 section 4 (read in two independent public "
                   "decks)"),
        "strength": "hjc", "eos": "hjc",
        "density": 2440.0, "shear_modulus": 14.86e9,
        "hjc_a": 0.79, "hjc_b": 1.60, "hjc_n": 0.61, "hjc_c": 0.007,
        "hjc_fc": 48.0e6, "hjc_t": 4.0e6, "hjc_smax": 7.0, "hjc_efmin": 0.01,
        "hjc_d1": 0.04, "hjc_d2": 1.0,
        "hjc_pcrush": 16.0e6, "hjc_mucrush": 0.001, "hjc_plock": 0.80e9, "hjc_mulock": 0.10,
        "hjc_k1": 85.0e9, "hjc_k2": -171.0e9, "hjc_k3": 208.0e9,
    },
    "steel_4340_jc": {
        "source": ("Johnson & Cook 1983 4340 steel (A 792 MPa, B 510 MPa, n 0.26, C 0.014, "
                   "m 1.03, T_melt 1793 K, c_p 477 J/(kg K)), rho 7830 kg/m^3, E 200 GPa, "
                   "nu 0.29; Mie-Grueneisen c0 4578 m/s, s 1.33, Gamma0 1.67 (Steinberg 1996 "
                   "tables)"),
        "strength": "johnson_cook", "eos": "mie_gruneisen",
        "density": 7830.0, "youngs_modulus": 200.0e9, "poisson_ratio": 0.29,
        "jc_a": 792.0e6, "jc_b": 510.0e6, "jc_n": 0.26, "jc_c": 0.014, "jc_m": 1.03,
        "melt_temperature": 1793.0, "specific_heat": 477.0,
        "c0": 4578.0, "s": 1.33, "gamma0": 1.67,
    },
    "ofhc_copper": {
        "source": ("Johnson & Cook 1983 OFHC copper (A 90 MPa, B 292 MPa, n 0.31, "
                   "C 0.025, m 1.09, T_melt 1356 K); Mie-Grueneisen c0 3940 m/s, "
                   "s 1.489, Gamma0 2.02 (Steinberg 1996 tables)"),
        "strength": "johnson_cook", "eos": "mie_gruneisen",
        "density": 8960.0, "shear_modulus": 46.0e9,
        "jc_a": 90.0e6, "jc_b": 292.0e6, "jc_n": 0.31, "jc_c": 0.025, "jc_m": 1.09,
        "melt_temperature": 1356.0, "specific_heat": 383.0,
        "c0": 3940.0, "s": 1.489, "gamma0": 2.02,
    },
    # ---- hypervelocity impact (docs/method.md, "Materials for hypervelocity impact")
    "ofhc_copper_power_law": {
        "source": ("Liao et al. 2022 (Explosion and Shock Waves 42(10)) tables 1-2, OFHC copper: "
                   "rho 8930 kg/m^3, E 129 GPa, nu 0.35 (given as G = E/(2(1 + nu)) = 47.78 GPa: "
                   "the EOS sets the bulk modulus), J2 power law sigma0 120 MPa, eps_p0 0.0278, "
                   "rate0 1/s, n 0.45, m 1.0, l 1.0, T_m 1790 K with the rate term in the "
                   "power form (1 + rate/rate0)^m (the printed 1 + (rate/rate0)^m doubles "
                   "the yield at the reference rate); with m = 1 both forms multiply the "
                   "flow stress by about 1e5 at 1e5 1/s (a deck warning says so). T_m 1790 K "
                   "is Steinberg's T_m0, used with his Lindemann law (a 1.5). Mie-Grueneisen "
                   "c0 3940 m/s, s 1.489, Gamma0 2.02 (Steinberg 1996); c_p 385 J/(kg K) (CRC "
                   "Handbook of Chemistry and Physics, copper at 298 K); spall strength "
                   "1.35 GPa (J. Appl. Phys. doi:10.1063/1.3607294, as read in the pyko "
                   "material examples); G_c 250 kJ/m^2 for eigenerosion (Liao et al. 2022 table 1)"),
        "strength": "power_law", "eos": "mie_gruneisen", "temperature": "internal_energy",
        "density": 8930.0, "shear_modulus": 129.0e9 / (2.0 * 1.35),
        "pl_sigma0": 120.0e6, "pl_eps0": 0.0278, "pl_rate0": 1.0, "pl_n": 0.45, "pl_m": 1.0,
        "pl_l": 1.0, "pl_rate_form": "power",
        "melt_temperature": 1790.0, "melt_model": "lindemann", "lindemann_a": 1.5,
        "specific_heat": 385.0, "c0": 3940.0, "s": 1.489, "gamma0": 2.02, "p_min": -1.35e9,
        "fracture_energy": 250.0e3,
    },
    "al_6061_t6_power_law": {
        "source": ("Liao et al. 2022 (Explosion and Shock Waves 42(10)) tables 1-2, Al 6061-T6: "
                   "rho 2700 kg/m^3, E 68.9 GPa, nu 0.33 (given as G = E/(2(1 + nu)) = 25.90 GPa: "
                   "the EOS sets the bulk modulus), J2 power law sigma0 270 MPa, eps_p0 0.0025, "
                   "rate0 1/s, n 0.148, m 0.01389, l 1.0, T_m 1200 K, rate term in the power "
                   "form (1 + rate/rate0)^m; T_m with Steinberg's Lindemann law (a 1.5). The "
                   "paper's SESAME EOS replaced by Mie-Grueneisen c0 5240 m/s, s 1.40, "
                   "Gamma0 1.97 (Steinberg 1996); c_p 896 J/(kg K) (MatWeb 6061-T6 data, as read "
                   "in Sandia's Payette material database); spall strength 1.2 GPa assumed (the "
                   "order of plate-impact values for aluminium alloys; not checked against a "
                   "6061-T6 measurement); G_c 100 kJ/m^2 for eigenerosion (Liao et al. 2022 table 2)"),
        "strength": "power_law", "eos": "mie_gruneisen", "temperature": "internal_energy",
        "density": 2700.0, "shear_modulus": 68.9e9 / (2.0 * 1.33),
        "pl_sigma0": 270.0e6, "pl_eps0": 0.0025, "pl_rate0": 1.0, "pl_n": 0.148, "pl_m": 0.01389,
        "pl_l": 1.0, "pl_rate_form": "power",
        "melt_temperature": 1200.0, "melt_model": "lindemann", "lindemann_a": 1.5,
        "specific_heat": 896.0, "c0": 5240.0, "s": 1.40, "gamma0": 1.97, "p_min": -1.2e9,
        "fracture_energy": 100.0e3,
    },
    "ofhc_copper_sg": {
        "source": ("Steinberg 1996 tables (OFHC copper; read in Uintah's SCG material data): "
                   "rho 8930 kg/m^3, G0 47.7 GPa, Y0 0.12 GPa, Ymax 0.64 GPa, beta 36, n 0.45, "
                   "G'_p/G0 2.83 /Mbar, G'_T/G0 3.77e-4 /K, T_m0 1790 K, a 1.5; "
                   "Mie-Grueneisen c0 3940 m/s, s 1.489, Gamma0 2.02; c_p 385 J/(kg K) (CRC "
                   "Handbook); spall strength 1.35 GPa and G_c 250 kJ/m^2 (as ofhc_copper_power_law)"),
        "strength": "steinberg_guinan", "eos": "mie_gruneisen", "temperature": "internal_energy",
        "density": 8930.0, "shear_modulus": 47.7e9,
        "sg_y0": 0.12e9, "sg_ymax": 0.64e9, "sg_beta": 36.0, "sg_n": 0.45, "sg_eps_i": 0.0,
        "sg_a": 2.83e-11, "sg_b": 3.77e-4,
        "melt_temperature": 1790.0, "melt_model": "lindemann", "lindemann_a": 1.5,
        "specific_heat": 385.0, "c0": 3940.0, "s": 1.489, "gamma0": 2.02, "p_min": -1.35e9,
        "fracture_energy": 250.0e3,
    },
    "al_6061_t6_sg": {
        "source": ("Steinberg 1996 tables (6061-T6 aluminium; read in Uintah's SCG material "
                   "data): rho 2703 kg/m^3, G0 27.6 GPa, Y0 0.29 GPa, Ymax 0.68 GPa, beta 125, "
                   "n 0.1, G'_p/G0 6.52 /Mbar, G'_T/G0 6.16e-4 /K, T_m0 1220 K, a 1.5; "
                   "Mie-Grueneisen c0 5240 m/s, s 1.40, Gamma0 1.97; c_p 896 J/(kg K) (as "
                   "al_6061_t6_power_law); spall strength 1.2 GPa assumed (as "
                   "al_6061_t6_power_law); G_c 100 kJ/m^2 (as al_6061_t6_power_law)"),
        "strength": "steinberg_guinan", "eos": "mie_gruneisen", "temperature": "internal_energy",
        "density": 2703.0, "shear_modulus": 27.6e9,
        "sg_y0": 0.29e9, "sg_ymax": 0.68e9, "sg_beta": 125.0, "sg_n": 0.1, "sg_eps_i": 0.0,
        "sg_a": 6.52e-11, "sg_b": 6.16e-4,
        "melt_temperature": 1220.0, "melt_model": "lindemann", "lindemann_a": 1.5,
        "specific_heat": 896.0, "c0": 5240.0, "s": 1.40, "gamma0": 1.97, "p_min": -1.2e9,
        "fracture_energy": 100.0e3,
    },
}

#: Johnson & Cook 1985 (Eng. Fract. Mech. 21:31) failure constants D1-D5 of
#: the Johnson-Cook metals, offered as entries NAME_failure (the entry with
#: them): switched on in the entries themselves they change the validated
#: Taylor rods (docs/method.md: points fail at the impact face and the
#: 4340 rod grows 3.4 % longer in FEM at 5 cells across).
JC_1985_FAILURE = {
    "ofhc_copper": ((0.54, 4.89, -3.03, 0.014, 1.12), "also in Uintah's material data"),
    "steel_4340_jc": ((0.05, 3.44, -2.12, 0.002, 0.61), "also in Uintah's material data"),
    "armco_iron_jc": ((-2.20, 5.43, -0.47, 0.016, 0.63), "read second-hand, not checked against "
                      "a second public copy"),
}
for _base, (_constants, _where) in JC_1985_FAILURE.items():
    LIBRARY[f"{_base}_failure"] = {
        **LIBRARY[_base], **dict(zip(JC_FAILURE_KEYS, _constants)),
        "source": (LIBRARY[_base]["source"] + "; failure D1-D5 "
                   + ", ".join(f"{v:g}" for v in _constants)
                   + f" (Johnson & Cook 1985, Eng. Fract. Mech. 21:31; {_where})"),
    }

#: Smallest strain to fracture of the Johnson-Cook failure model when the
#: deck gives none [-]: keeps eps_f positive where D1 + D2 exp(D3 sigma*)
#: is not (Armco iron's D1 < 0 at high triaxiality), i.e. failure at once
#: there, as the formula means (LS-DYNA's default EFMIN is the same).
JC_EFMIN_DEFAULT = 1.0e-6
#: Strength models whose temperature comes from the internal energy when
#: the deck leaves `temperature` unset (with eos 'mie_gruneisen'): the
#: hypervelocity models, whose heat is mostly the shock's. Every other
#: material keeps 'plastic_work', with which the Johnson-Cook cases were
#: validated: 'internal_energy' moved the Taylor rods' lengths by -0.1 to
#: -0.2 % and their foot diameters by +0.4 to +1.4 %, and let the excess
#: heat of converted particles soften them (the hottest copper particle
#: of the 10 x 67 adaptive rod at 1214 K instead of 575 K, its melting
#: point 1356 K); docs/method.md.
INTERNAL_ENERGY_BY_DEFAULT = ("power_law", "steinberg_guinan")
#: Volumetric strain of the tension end of the isentrope table [-]: half
#: the reference density, far below any spall strain (a few per cent);
#: further stretched states take the value there (docs/method.md).
ISENTROPE_MU_LO = -0.5
#: Weight beta of the table's compression coordinate
#: u = -ln(1 - (s-1) mu) + beta (s-1) mu [-]: the logarithm crowds the nodes
#: towards the EOS's pole, the linear term keeps enough of them at the
#: moderate strains of most material (chosen for the smallest largest
#: error over copper and aluminium among 3, 4 and 5 with 48 intervals;
#: with the 64 of fsph.layouts the table's temperature is within 0.16 K of
#: an independent integration, tests/test_hypervelocity_materials.py).
ISENTROPE_BETA = 4.0


def temperature_model(m):
    """The temperature model of a material dict: its `temperature` key, or
    when unset 'internal_energy' for the strength models of
    INTERNAL_ENERGY_BY_DEFAULT with eos 'mie_gruneisen', else
    'plastic_work'."""
    if m.get("temperature"):
        return m["temperature"]
    if m["strength"] in INTERNAL_ENERGY_BY_DEFAULT and m["eos"] == "mie_gruneisen":
        return "internal_energy"
    return "plastic_work"


def _hugoniot_part(rho0, c0, s, gamma0, mu):
    """Energy-independent part a(mu) [Pa] of fsph's Mie-Grueneisen pressure
    p = a + Gamma0 rho0 e (fsph_material eos_pressure)."""
    k0 = rho0 * c0 ** 2
    if mu > 0.0:
        return k0 * mu * (1.0 + (1.0 - 0.5 * gamma0) * mu) / (1.0 - (s - 1.0) * mu) ** 2
    return k0 * mu


@functools.lru_cache(maxsize=64)
def isentrope_table(rho0, c0, s, gamma0):
    """The reference isentrope of fsph's Mie-Grueneisen EOS through
    (rho0, e = 0): e_s(mu) solves de/dv = -p with p = a(rho) + b e,
    b = Gamma0 rho0, i.e. with x = rho0/rho
        e_s(x) = (1/rho0) exp(-Gamma0 x) int_x^1 a(x') exp(Gamma0 x') dx',
    integrated node to node by adaptive quadrature (relative 1e-13).
    Returns (mu_lo, beta, u_top, tension values, tension slopes de_s/dmu,
    compression values w = e_s (1 - (s-1) mu), compression slopes dw/du)
    on the nodes fsph_material isentrope_energy interpolates (tension
    uniform in mu from mu_lo to 0, compression uniform in
    u = -ln(1 - (s-1) mu) + beta (s-1) mu up to where 1 - (s-1) mu is the
    EOS's floor). Needs s > 1 (the EOS has a pole)."""
    # imported here: scipy.integrate alone costs about 0.2 s of every start-up
    from scipy.integrate import quad
    from scipy.optimize import brentq
    floor = dict((n, v) for n, v, _, _ in layouts.REAL_CONSTANTS)["mg_denominator_floor"]
    n_t = dict(layouts.ISENTROPE_TABLE)["tension_intervals"]
    n_c = dict(layouts.ISENTROPE_TABLE)["compression_intervals"]
    b = gamma0 * rho0

    def integrand(x):
        return _hugoniot_part(rho0, c0, s, gamma0, 1.0 / x - 1.0) * math.exp(gamma0 * x)

    def energies(mus):
        """e_s at strains ordered outwards from 0 (cumulative quadrature)."""
        out, total, x_prev = [], 0.0, 1.0
        for mu in mus:
            x = 1.0 / (1.0 + mu)
            total += quad(integrand, x, x_prev, epsabs=0.0, epsrel=1e-13, limit=200)[0]
            x_prev = x
            out.append(total * math.exp(-gamma0 * x) / rho0)
        return np.array(out)

    def slope(mu, e):
        """de_s/dmu = p/(rho0 (1 + mu)^2) along the isentrope [J/kg]."""
        return (_hugoniot_part(rho0, c0, s, gamma0, mu) + b * e) / (rho0 * (1.0 + mu) ** 2)

    mu_t = np.linspace(ISENTROPE_MU_LO, 0.0, n_t + 1)
    e_t = energies(mu_t[::-1])[::-1]
    de_t = np.array([slope(m, e) for m, e in zip(mu_t, e_t)])

    beta, sm1 = ISENTROPE_BETA, s - 1.0
    y_top = 1.0 - floor
    u_top = -math.log(floor) + beta * y_top
    u = np.linspace(0.0, u_top, n_c + 1)
    y = [0.0] + [brentq(lambda yy, uu=uu: -math.log(1.0 - yy) + beta * yy - uu, 0.0, y_top,
                        xtol=1e-15, rtol=1e-15) for uu in u[1:-1]] + [y_top]
    mu_c = np.array(y) / sm1
    e_c = energies(mu_c)
    den = 1.0 - sm1 * mu_c
    w_c = e_c * den
    dw_dmu = np.array([slope(m, e) for m, e in zip(mu_c, e_c)]) * den - sm1 * e_c
    dw_c = dw_dmu / (sm1 / den + beta * sm1)
    return ISENTROPE_MU_LO, beta, u_top, e_t, de_t, w_c, dw_c


def hjc_lock_strain(m):
    """Volumetric strain mu_plock at which the HJC fully dense curve
    K1 x + K2 x^2 + K3 x^3, x = (mu - mu_lock)/(1 + mu_lock), reaches
    P_lock (Newton from the linear estimate; the curve must rise
    monotonically up to there). Raises ValueError if it does not."""
    k1, k2, k3, plock = m["hjc_k1"], m["hjc_k2"], m["hjc_k3"], m["hjc_plock"]
    x = plock / k1
    for _ in range(100):
        f = x * (k1 + x * (k2 + x * k3)) - plock
        df = k1 + x * (2.0 * k2 + 3.0 * x * k3)
        if df <= 0.0:
            break
        step = f / df
        x -= step
        if abs(step) <= 1e-15 * max(abs(x), 1e-30):
            break
    grid = np.linspace(0.0, x, 200)
    slopes = k1 + grid * (2.0 * k2 + 3.0 * grid * k3)
    if not (x > 0.0 and np.all(slopes > 0.0)
            and abs(x * (k1 + x * (k2 + x * k3)) - plock) <= 1e-9 * plock):
        raise ValueError("the fully dense curve K1 x + K2 x^2 + K3 x^3 does not rise "
                         "monotonically to hjc_plock")
    return m["hjc_mulock"] + x * (1.0 + m["hjc_mulock"])


def elastic_moduli(m):
    """Shear and bulk moduli [Pa] and Young's modulus of a validated material
    dict. Bulk is from (E, nu), or given, or rho0 c0^2 for Mie-Grueneisen,
    or the HJC elastic bulk modulus P_crush/mu_crush."""
    if m.get("youngs_modulus") is not None:
        e, nu = m["youngs_modulus"], m["poisson_ratio"]
        g = e / (2.0 * (1.0 + nu))
        k = e / (3.0 * (1.0 - 2.0 * nu))
    else:
        g = m["shear_modulus"]
        k = m.get("bulk_modulus")
        if m["eos"] == "hjc":
            k = m["hjc_pcrush"] / m["hjc_mucrush"]
        elif k is None:
            k = m["density"] * m["c0"] ** 2
        e = 9.0 * k * g / (3.0 * k + g)
    if m["eos"] == "linear" and m.get("bulk_modulus") is not None:
        k = m["bulk_modulus"]
    return g, k, e


def _given(m, key, default):
    """m[key], or `default` when the key is unset (None or absent)."""
    value = m.get(key)
    return default if value is None else value


def _model_rows(m):
    """The property entries of the temperature, melting, power-law,
    Steinberg-Guinan and Johnson-Cook failure models and of the isentrope
    table (zeros where a model is not used)."""
    row = {
        "temp_model": TEMPERATURE_MODELS[temperature_model(m)],
        "melt_model": MELT_MODELS[_given(m, "melt_model", "constant")],
        "melt_a": _given(m, "lindemann_a", 0.0),
        "pl_sigma0": _given(m, "pl_sigma0", 0.0), "pl_eps0": _given(m, "pl_eps0", 1.0),
        "pl_rate0": _given(m, "pl_rate0", 1.0), "pl_n": _given(m, "pl_n", 0.0),
        "pl_m": _given(m, "pl_m", 0.0), "pl_l": _given(m, "pl_l", 1.0),
        "pl_rate_form": RATE_FORMS[_given(m, "pl_rate_form", "power")],
        "sg_eps_i": _given(m, "sg_eps_i", 0.0),
        "jcf_on": 1.0 if all(m.get(k) is not None for k in JC_FAILURE_KEYS) else 0.0,
        "spall_fail": 1.0 if m.get("spall_failure") else 0.0,
        "jc_efmin": _given(m, "jc_efmin", JC_EFMIN_DEFAULT),
        "fracture_energy": _given(m, "fracture_energy", 0.0),
    }
    for key in STEINBERG_GUINAN_KEYS + JC_FAILURE_KEYS:
        row[key] = _given(m, key, 0.0)
    n_t = dict(layouts.ISENTROPE_TABLE)["tension_intervals"] + 1
    n_c = dict(layouts.ISENTROPE_TABLE)["compression_intervals"] + 1
    table = (0.0, 0.0, 0.0, np.zeros(n_t), np.zeros(n_t), np.zeros(n_c), np.zeros(n_c))
    if temperature_model(m) == "internal_energy":
        table = isentrope_table(float(m["density"]), float(m["c0"]), float(m["s"]),
                                float(m["gamma0"]))
    row["ise_mu_lo"], row["ise_beta"], row["ise_u_top"] = table[:3]
    for part, values in zip(("tw", "tdw", "cw", "cdw"), table[3:]):
        for k, value in enumerate(values):
            row[f"ise_{part}{k:02d}"] = float(value)
    return row


def property_row(m):
    """Pack one validated material dict into the Fortran property layout."""
    g, k, e = elastic_moduli(m)
    hard = 0.0
    if m["strength"] == "bilinear":
        et = m["tangent_modulus"]
        hard = e * et / (e - et)
    row = {
        "rho0": m["density"], "shear": g, "bulk": k,
        "yield": m.get("yield_stress") or 0.0, "hard": hard,
        "jc_a": m.get("jc_a") or 0.0, "jc_b": m.get("jc_b") or 0.0,
        "jc_n": m.get("jc_n") or 1.0, "jc_c": m.get("jc_c") or 0.0,
        "jc_m": m.get("jc_m") or 1.0,
        "t_melt": m.get("melt_temperature") or math.inf,
        "t_room": m["room_temperature"], "cv": m.get("specific_heat") or 0.0,
        "chi": m["taylor_quinney"], "eps0": m["jc_ref_strain_rate"],
        "c0": m.get("c0") or 0.0, "s": m.get("s") or 0.0, "gamma0": m.get("gamma0") or 0.0,
        "pmin": NO_PRESSURE_CUTOFF if m.get("p_min") is None else m["p_min"],
    }
    for key in HJC_KEYS:
        row[key] = m.get(key) or 0.0
    row["hjc_muplock"] = hjc_lock_strain(m) if m["eos"] == "hjc" else 0.0
    row.update(_model_rows(m))
    if not math.isfinite(row["t_melt"]):
        row["t_melt"] = 1.0e300
    return np.array([row[name] for name in PROPERTY_NAMES], dtype=np.float64)


def property_table(materials):
    """Property table (n_props, n_materials), strength and EOS ids."""
    props = np.asfortranarray(np.stack([property_row(m) for m in materials], axis=1))
    strength = np.array([STRENGTH_MODELS[m["strength"]] for m in materials], dtype=np.int32)
    eos = np.array([EOS_MODELS[m["eos"]] for m in materials], dtype=np.int32)
    return props, strength, eos
