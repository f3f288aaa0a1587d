"""Named material library and the packing of material constants into the
property table the Fortran models read (layout of ``fsph_material``).

Every library entry states where its numbers come from. Values are SI.
"""

import math

import numpy as np

from . import layouts

# Property table layout, model ids: fsph.layouts, the one source the solver
# is generated from (the build checks both agree through the layout digest).
PROPERTY_NAMES = layouts.PROPERTY_NAMES
STRENGTH_MODELS = {name: k for k, (name, _) in enumerate(layouts.STRENGTH_MODELS, 1)}
EOS_MODELS = {name: k for k, (name, _) in enumerate(layouts.EOS_MODELS, 1)}
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
}


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
    if not math.isfinite(row["t_melt"]):
        row["t_melt"] = 1.0e300
    return np.array([row[name] for name in PROPERTY_NAMES], dtype=np.float64)


def property_table(materials):
    """Property table (n_props, n_materials), strength and EOS ids."""
    props = np.asfortranarray(np.stack([property_row(m) for m in materials], axis=1))
    strength = np.array([STRENGTH_MODELS[m["strength"]] for m in materials], dtype=np.int32)
    eos = np.array([EOS_MODELS[m["eos"]] for m in materials], dtype=np.int32)
    return props, strength, eos
