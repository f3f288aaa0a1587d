"""Input decks: legacy-style Fortran namelists read with f90nml.

One group per concern. ``load(path)`` returns a validated plain dict with
every documented default filled in, or raises ``DeckError`` naming the file,
the group, the key and what was expected. The schema below is the single
source of the deck reference (``docs/decks.md`` is generated from it by
``python -m fsph decks-reference``).
"""

import copy
import hashlib
import json
import math
import numbers
import re
from dataclasses import dataclass, field
from pathlib import Path

import f90nml
import numpy as np

from . import layouts
from .errors import DeckError
from .materials import (EOS_MODELS, HJC_KEYS, JC_EFMIN_DEFAULT, JC_FAILURE_KEYS, LIBRARY,
                        MELT_MODELS, POWER_LAW_KEYS, RATE_FORMS, STEINBERG_GUINAN_KEYS,
                        STRENGTH_MODELS, TEMPERATURE_MODELS, elastic_moduli,
                        hjc_lock_strain, temperature_model)

REQUIRED = object()

#: Largest number of elements and particles a deck may ask for in all: far
#: above any 2D axisymmetric run this machine class can afford, low enough
#: that a units slip in a resolution is an error, not an exhausted memory.
MAX_ENTITIES = 4_000_000
#: Largest number of snapshots or progress lines over a run.
MAX_OUTPUTS = 100_000
#: Largest magnitude a value of each unit may have: far outside any impact
#: problem, close enough that a garbled number (1e154 m) is caught here
#: rather than overflowing in the solver.
UNIT_LIMITS = {"m": 1.0e3, "s": 1.0e3, "kg/m^3": 1.0e6, "Pa": 1.0e14, "m/s": 1.0e5,
               "K": 1.0e6, "J/(kg K)": 1.0e6, "1/s": 1.0e12, "-": 1.0e6, "deg": 360.0,
               "1/Pa": 1.0e-6, "1/K": 1.0}
#: Largest integer any key may hold (the solver counts in 32-bit integers).
MAX_INT = 1_000_000_000
#: Smallest value a strictly positive quantity of each unit may have (a
#: denormal density would give an infinite sound speed and a zero step).
UNIT_FLOORS = {"m": 1.0e-9, "s": 1.0e-15, "kg/m^3": 1.0e-3, "Pa": 1.0, "m/s": 1.0e-6,
               "K": 1.0e-3, "J/(kg K)": 1.0e-3, "1/s": 1.0e-12, "-": 1.0e-12, "1/Pa": 1.0e-20,
               "1/K": 1.0e-12}


@dataclass(frozen=True)
class Key:
    """One namelist key: type, default, unit, meaning and admissible values."""

    kind: str                 # 'float', 'int', 'str', 'bool', 'float2'
    default: object
    unit: str
    doc: str
    choices: tuple = ()
    lower: float = None       # admissible range; None = unbounded
    upper: float = None
    lower_open: bool = False  # True: value must be > lower (not >=)
    upper_open: bool = False
    implemented: tuple = ()   # subset of choices available in this version


@dataclass(frozen=True)
class Group:
    doc: str
    keys: dict
    repeatable: bool = False
    required: bool = False
    min_count: int = 0


def _pos(doc, unit, default=REQUIRED):
    return Key("float", default, unit, doc, lower=0.0, lower_open=True)


SCHEMA = {
    "control": Group(
        "Run control and numerical parameters of the cycle.",
        {
            "title": Key("str", "", "-", "Free text naming the case (copied to summary.json)."),
            "mode": Key("str", "fem", "-",
                        "Discretisation mode: fem (elements only), sph (particles only), "
                        "fixed (FEM-SPH coupling as declared), adaptive (elements converted "
                        "to particles where they distort).",
                        choices=("fem", "sph", "fixed", "adaptive")),
            "end_time": _pos("Physical time at which the run stops.", "s"),
            "dt_safety": Key("float", 0.6, "-",
                             "Time-step safety factor s: dt = s * min(min_e L_min/(Q + sqrt(Q^2 + c^2)), "
                             "min_p h/(c + |v|)); an element that a contact is about to strike counts "
                             "with the compression rate of its closing speed (v_n/L_min). 0.6 leaves "
                             "margin for the axisymmetric hoop stiffness of elements next to the axis.",
                             lower=0.0, upper=1.0, lower_open=True),
            "c_q": Key("float", 1.5, "-",
                       "Quadratic artificial-viscosity coefficient C_Q in "
                       "q = rho (C_Q L tr d)^2 + C_L rho c L |tr d| (compression only, L = sqrt(A)). "
                       "1.5 is the customary von Neumann-Richtmyer value.", lower=0.0),
            "c_l": Key("float", 0.06, "-",
                       "Linear artificial-viscosity coefficient C_L (see c_q). 0.06 is the "
                       "customary value of explicit Lagrangian codes.", lower=0.0),
            "dt_floor_ratio": Key("float", 1.0e-3, "-",
                                  "The run stops with a diagnostic when the stable step falls "
                                  "below this fraction of the initial step.",
                                  lower=0.0, upper=1.0, lower_open=True, upper_open=True),
            "dt_drop_ratio": Key("float", 0.0, "-",
                                 "The run stops with a diagnostic when the stable step falls "
                                 "below this fraction of the previous cycle's (a collapse in one "
                                 "cycle). 0: off.", lower=0.0, upper=1.0, upper_open=True),
            "energy_error_limit": Key("float", None, "-",
                                      "The run stops with a diagnostic (exit 3) when |total energy "
                                      "- initial| / initial exceeds this, checked every "
                                      "few hundred cycles: the hard stop for a run that loses its "
                                      "energy balance. Unset: off (energy_error_warning still "
                                      "flags it).",
                                      lower=0.0, lower_open=True),
            "energy_error_warning": Key("float", 0.02, "-",
                                        "A run whose energy error (|total - initial| / initial, "
                                        "the largest during the run) exceeds this completes with "
                                        "a warning: printed, written to summary.json "
                                        "(`warnings`) and flagged by `fsph report`. The total "
                                        "counts the kinetic and internal energy and what contact, "
                                        "rigid planes and erosion removed. Set "
                                        "energy_error_limit to stop the run instead.",
                                        lower=0.0, lower_open=True),
            "max_cycles": Key("int", 50_000_000, "-", "Hard limit on the number of cycles.",
                              lower=1),
        },
        required=True,
    ),
    "material": Group(
        "A material, referred to by name from &body. Repeatable. Start from a library "
        "entry with `library = '...'` and override any key; or give every key needed by "
        "the chosen models. Elasticity: either youngs_modulus + poisson_ratio, or "
        "shear_modulus (+ bulk_modulus for the linear EOS; the Mie-Grueneisen bulk "
        "modulus is rho0 c0^2). bulk_modulus goes only with shear_modulus and the linear "
        "EOS: beside youngs_modulus + poisson_ratio, or with eos 'mie_gruneisen' or 'hjc', "
        "it is an error (nothing would tell which one wins). With 'mie_gruneisen', a bulk "
        "modulus E/(3(1 - 2 nu)) more than 5 % from rho0 c0^2 gets a warning at the start "
        "of the run and in summary.json: the pressure uses rho0 c0^2, E and nu set the "
        "shear modulus only.",
        {
            "name": Key("str", REQUIRED, "-", "Name used by &body material."),
            "library": Key("str", None, "-", "Library entry to start from.",
                           choices=tuple(LIBRARY)),
            "strength": Key("str", REQUIRED, "-", "Strength model.",
                            choices=tuple(STRENGTH_MODELS)),
            "eos": Key("str", REQUIRED, "-", "Equation of state.", choices=tuple(EOS_MODELS)),
            "density": _pos("Reference density rho0.", "kg/m^3"),
            "youngs_modulus": _pos("Young's modulus E.", "Pa", None),
            "poisson_ratio": Key("float", None, "-", "Poisson's ratio nu.",
                                 lower=0.0, upper=0.5, upper_open=True),
            "shear_modulus": _pos("Shear modulus G.", "Pa", None),
            "bulk_modulus": _pos("Bulk modulus K (linear EOS p = K (rho/rho0 - 1)).", "Pa", None),
            "yield_stress": _pos("Initial yield stress Y0 (epp, bilinear).", "Pa", None),
            "tangent_modulus": Key("float", None, "Pa",
                                   "Tangent modulus E_T of the bilinear model (0 <= E_T < E).",
                                   lower=0.0),
            "jc_a": Key("float", None, "Pa", "Johnson-Cook A.", lower=0.0),
            "jc_b": Key("float", None, "Pa", "Johnson-Cook B.", lower=0.0),
            "jc_n": _pos("Johnson-Cook hardening exponent n.", "-", None),
            "jc_c": Key("float", None, "-", "Johnson-Cook strain-rate coefficient C.", lower=0.0),
            "jc_m": _pos("Johnson-Cook thermal-softening exponent m.", "-", None),
            "jc_ref_strain_rate": _pos("Reference strain rate of the Johnson-Cook and HJC "
                                       "rate terms.", "1/s", 1.0),
            "melt_temperature": _pos("Melting temperature: T_m (melt_model 'constant') or T_m0 "
                                     "(melt_model 'lindemann'). A point at or above its melting "
                                     "temperature carries no deviatoric stress, whatever its "
                                     "strength model (snapshot field `melted`); Johnson-Cook, "
                                     "power_law and steinberg_guinan soften to zero there.",
                                     "K", None),
            "melt_model": Key("str", "constant", "-",
                              "Melting temperature: constant (melt_temperature), or the "
                              "Lindemann law of Steinberg, Cochran & Guinan 1980, "
                              "T_m = T_m0 exp(2 a (1 - rho0/rho)) (rho/rho0)^(2 (gamma0 - a - 1/3)) "
                              "above the reference density and T_m0 below it (needs eos "
                              "'mie_gruneisen' for gamma0, and lindemann_a).",
                              choices=tuple(MELT_MODELS)),
            "lindemann_a": Key("float", None, "-",
                               "Lindemann exponent a of melt_model 'lindemann' (Steinberg's "
                               "tables: 1.5 for copper and aluminium).", lower=0.0),
            "room_temperature": _pos("Room and initial temperature.", "K", 293.15),
            "specific_heat": _pos("Specific heat c of the temperature models: "
                                  "dT = taylor_quinney dW_p/(rho c) ('plastic_work') or "
                                  "T = T_s(rho) + (e - e_s(rho))/c ('internal_energy'). The "
                                  "solids' tables (Johnson & Cook 1983 among them) give c_p, at "
                                  "constant pressure; give that: for metals c_p - c_v is 2-3 % at "
                                  "room temperature, well inside the scatter of the constants, "
                                  "and the Mie-Grueneisen energy term does not use it. Needed by "
                                  "johnson_cook, power_law, steinberg_guinan and by any "
                                  "melt_temperature.",
                                  "J/(kg K)", None),
            "temperature": Key("str", None, "-",
                               "Temperature model. plastic_work: adiabatic heating by plastic "
                               "work only, dT = taylor_quinney dW_p/(rho c). internal_energy: "
                               "T = T_s(rho) + (e - e_s(rho))/c from the thermodynamic state, "
                               "shock and viscous heating included, about the reference "
                               "isentrope through (rho0, e = 0, room_temperature), "
                               "T_s = T_room exp(gamma0 (1 - rho0/rho)) (eos 'mie_gruneisen' "
                               "with s > 1 and specific_heat; all plastic work is heat, "
                               "taylor_quinney unused). Unset: internal_energy for strength "
                               "power_law and steinberg_guinan with eos mie_gruneisen (the "
                               "hypervelocity models: the heat is mostly the shock's), "
                               "plastic_work otherwise (the Johnson-Cook cases were validated "
                               "with it; docs/method.md).",
                               choices=tuple(TEMPERATURE_MODELS)),
            "taylor_quinney": Key("float", 0.9, "-",
                                  "Fraction of plastic work turned into heat (Taylor-Quinney).",
                                  lower=0.0, upper=1.0),
            "c0": _pos("Mie-Grueneisen bulk sound speed c0 (Us = c0 + s up).", "m/s", None),
            "s": _pos("Mie-Grueneisen Us-up slope s.", "-", None),
            "gamma0": Key("float", None, "-", "Grueneisen coefficient Gamma0.", lower=0.0),
            "p_min": Key("float", None, "Pa",
                         "Pressure cut-off (spall) of eos 'linear' and 'mie_gruneisen': the "
                         "pressure never falls below p_min (<= 0); the p dv work of the step "
                         "is done at p_min. Unset: no cut-off. Not with eos 'hjc' (its tensile "
                         "limit is -hjc_t (1 - D)). A failed point carries no tension at all "
                         "(p >= 0).", upper=0.0),
            "spall_failure": Key("bool", False, "-",
                                 "Spall as a failure: a point whose EOS pressure falls below "
                                 "p_min fails (snapshot field `failed`: no deviatoric stress, no "
                                 "tension from then on, its mass and momentum kept) instead of "
                                 "carrying p_min for as long as it is stretched. Needs p_min."),
            "pl_sigma0": _pos("power_law (Liao et al. 2022 eq 13): quasi-static yield stress "
                              "sigma0 of sigma_y = sigma0 (1 + eps_p/pl_eps0)^pl_n R "
                              "(1 - (T - T_room)/(T_m - T_room))^pl_l, zero at and above melt.",
                              "Pa", None),
            "pl_eps0": _pos("power_law: reference plastic strain eps_p0.", "-", None),
            "pl_rate0": _pos("power_law: reference plastic strain rate of the rate term R.",
                             "1/s", None),
            "pl_n": Key("float", None, "-", "power_law: hardening exponent n.", lower=0.0),
            "pl_m": Key("float", None, "-", "power_law: rate exponent m.", lower=0.0),
            "pl_l": _pos("power_law: thermal softening exponent l.", "-", None),
            "pl_rate_form": Key("str", None, "-",
                                "power_law: rate term R of the plastic strain rate (the "
                                "return mapping solves for it): printed, "
                                "R = 1 + (rate/pl_rate0)^pl_m (Liao et al. 2022 eq 13 as "
                                "printed: R = 2 at the reference rate), or power, "
                                "R = (1 + rate/pl_rate0)^pl_m (the usual form of "
                                "optimal-transportation meshfree codes: R = 1 at rest). "
                                "No default: the two differ by a factor near 2 at ordinary "
                                "rates.", choices=tuple(RATE_FORMS)),
            "sg_y0": _pos("steinberg_guinan (Steinberg, Cochran & Guinan 1980): yield stress Y0 of "
                          "Y = min(Y0 [1 + sg_beta (eps_p + sg_eps_i)]^sg_n, sg_ymax) "
                          "G(p, T)/G0; G = G0 [1 + sg_a p (rho0/rho)^(1/3) - sg_b (T - 300 K)], "
                          "G0 the shear modulus; both zero at and above melt.", "Pa", None),
            "sg_ymax": _pos("steinberg_guinan: largest work-hardened yield stress Ymax "
                            "(>= sg_y0).", "Pa", None),
            "sg_beta": Key("float", None, "-", "steinberg_guinan: hardening constant beta.",
                           lower=0.0),
            "sg_n": Key("float", None, "-", "steinberg_guinan: hardening exponent n.", lower=0.0),
            "sg_eps_i": Key("float", 0.0, "-", "steinberg_guinan: initial plastic strain eps_i.",
                            lower=0.0),
            "sg_a": Key("float", None, "1/Pa", "steinberg_guinan: pressure derivative of the "
                        "shear modulus over G0, A = G'_p/G0 (Steinberg's tables give it per "
                        "Mbar: 2.83 /Mbar = 2.83e-11 /Pa).", lower=0.0),
            "sg_b": Key("float", None, "1/K", "steinberg_guinan: temperature derivative of the "
                        "shear modulus over G0, B = -G'_T/G0.", lower=0.0),
            "jc_d1": Key("float", None, "-",
                         "Johnson-Cook failure (Johnson & Cook 1985), with any plastic strength "
                         "model: D += d eps_p / eps_f, eps_f = [jc_d1 + jc_d2 exp(jc_d3 sigma*)] "
                         "[1 + jc_d4 ln eps_dot*] [1 + jc_d5 T*] >= jc_efmin, sigma* = -p/sigma_eq, "
                         "eps_dot* = plastic rate/jc_ref_strain_rate taken >= 1, "
                         "T* = (T - T_room)/(T_m - T_room) in [0, 1]. At D = 1 the point has "
                         "failed: no deviatoric stress, no tension (snapshot field `failed`), "
                         "its mass and momentum kept. jc_d1 to jc_d5 go together; unset: off."),
            "jc_d2": Key("float", None, "-", "Johnson-Cook failure D2.", lower=0.0),
            "jc_d3": Key("float", None, "-", "Johnson-Cook failure D3."),
            "jc_d4": Key("float", None, "-", "Johnson-Cook failure D4."),
            "jc_d5": Key("float", None, "-", "Johnson-Cook failure D5."),
            "jc_efmin": _pos("Johnson-Cook failure: smallest strain to fracture, so eps_f stays "
                             "positive where the formula is not (failure at once there, as it "
                             "means; LS-DYNA's default EFMIN).", "-", JC_EFMIN_DEFAULT),
            "fracture_energy": _pos("Failure by energy release rate (eigenerosion: Pandolfi & "
                                    "Ortiz 2012; Liao et al. 2022 eq 12) of the material's "
                                    "particles: critical energy release rate G_c. A particle whose "
                                    "largest principal stress is tensile fails when "
                                    "G = eigenerosion_factor 2h sum V_q W_q / sum V_q >= G_c, "
                                    "the mean over itself and its intact same-body neighbours "
                                    "within the kernel support (ring volumes V = m/rho) of the "
                                    "elastic energy density W = s:s/(4G) + p^2/(2K) (the p part "
                                    "in tension only). A failed particle keeps its mass, momentum "
                                    "and internal energy and carries no deviatoric stress and no "
                                    "tension (snapshot field `failed`). Elements do not use it "
                                    "(mode 'fem' gets a warning); unset: off.", "J/m^2", None),
            "hjc_a": _pos("HJC normalised cohesive strength A (strength and eos 'hjc', "
                          "Holmquist, Johnson & Cook 1993: sigma* = [A (1 - D) + B P*^N] "
                          "[1 + C ln(rate/jc_ref_strain_rate)] <= S_max, sigma* = sigma/f_c, "
                          "P* = p/f_c).", "-", None),
            "hjc_b": _pos("HJC normalised pressure hardening B.", "-", None),
            "hjc_n": _pos("HJC pressure hardening exponent N.", "-", None),
            "hjc_c": Key("float", None, "-", "HJC strain-rate coefficient C.", lower=0.0),
            "hjc_fc": _pos("HJC quasi-static uniaxial compressive strength f_c.", "Pa", None),
            "hjc_t": _pos("HJC maximum tensile hydrostatic pressure T (tensile limit "
                          "-T (1 - D)).", "Pa", None),
            "hjc_smax": _pos("HJC normalised maximum strength S_max.", "-", None),
            "hjc_efmin": _pos("HJC smallest plastic strain to fracture EF_min.", "-", None),
            "hjc_d1": _pos("HJC damage constant D1: strain to fracture "
                           "max(D1 (P* + T*)^D2, EF_min), D = sum (d eps_p + d mu_p) / that.",
                           "-", None),
            "hjc_d2": _pos("HJC damage exponent D2.", "-", None),
            "hjc_pcrush": _pos("HJC crushing pressure P_crush (end of the elastic range; "
                               "elastic bulk modulus P_crush/mu_crush).", "Pa", None),
            "hjc_mucrush": _pos("HJC volumetric strain mu_crush at P_crush.", "-", None),
            "hjc_plock": _pos("HJC locking pressure P_lock (end of compaction).", "Pa", None),
            "hjc_mulock": _pos("HJC locking volumetric strain mu_lock = rho_grain/rho0 - 1 "
                               "(the fully dense curve's zero-pressure intercept; compaction "
                               "runs to where that curve reaches P_lock).", "-", None),
            "hjc_k1": _pos("HJC fully dense EOS K1 (p = K1 x + K2 x^2 + K3 x^3, "
                           "x = (mu - mu_lock)/(1 + mu_lock)).", "Pa", None),
            "hjc_k2": Key("float", None, "Pa", "HJC fully dense EOS K2."),
            "hjc_k3": Key("float", None, "Pa", "HJC fully dense EOS K3."),
        },
        repeatable=True, required=True, min_count=1,
    ),
    "body": Group(
        "A body: a geometry generator, its resolution, its material and initial velocity. "
        "Repeatable. Generators (all crossed quadrilaterals: 4 triangles through a centre "
        "node; particles at the cell centroids with the planar cell area): rod, the "
        "rectangle inner_radius <= r <= radius, z_base <= z <= z_base + length in n_radial x "
        "n_axial cells; ogive, a tangent-ogive-nose projectile of radius `radius`, ideal "
        "length `length` (sharp tip to base), caliber radius head crh, tip pointing to -z at "
        "z_base, n_radial cells across, n_axial along the shank and n_nose along the nose; "
        "plate, a disc 0 <= r <= radius, z_base <= z <= z_base + length (the thickness) with "
        "n_axial cells through the thickness, n_radial uniform cells out to fine_radius and "
        "n_coarse cells growing geometrically to the rim; sphere, a ball of radius `radius` "
        "whose lowest point is at z_base, n_radial cells along its equatorial radius (a "
        "four-block butterfly: a core and three blocks of layers out to the outline; no "
        "length or n_axial); gmsh, the triangles of a 2D gmsh file (mesh_file, coordinates "
        "(r, z) times mesh_scale).",
        {
            "name": Key("str", REQUIRED, "-", "Body name."),
            "material": Key("str", REQUIRED, "-", "Name of a &material."),
            "geometry": Key("str", "rod", "-", "Geometry generator.",
                            choices=("rod", "ogive", "plate", "sphere", "gmsh")),
            "discretisation": Key("str", None, "-",
                                  "elements or particles. Unset: particles in mode sph, elements "
                                  "otherwise; mode fem takes only elements, mode sph only "
                                  "particles. Particles sit at the cell centroids, each carrying "
                                  "the ring mass of its cell (gmsh: elements only).",
                                  choices=("elements", "particles")),
            "formulation": Key("str", "updated", "-",
                               "Particle bodies: updated (the SPH of the other particle bodies: "
                               "neighbours searched every cycle, kernels on the current "
                               "positions) or total (total-Lagrangian SPH, Wang, Xu & Yang "
                               "2022: neighbours, kernels and the corrected gradient of the "
                               "initial configuration, the deformation gradient F, the first "
                               "Piola-Kirchhoff stress; no tensile instability, but the "
                               "neighbours never change, so it is not for flows that mix "
                               "material). total needs discretisation 'particles' and no "
                               "joined_to; the body meets the others through the particle "
                               "contact and the planes. A failed particle (any failure model "
                               "of the material) keeps its pairs but carries no tension and no "
                               "deviatoric stress, so cracks open (docs/method.md, "
                               "'Total-Lagrangian particles').", choices=("updated", "total")),
            "joined_to": Key("str", None, "-",
                             "Name of another body this one is glued to as one continuum (modes "
                             "fixed and adaptive): element and particle parts are coupled through "
                             "imaginary particles and interface tractions; no contact between "
                             "them."),
            "radius": _pos("Outer radius (rod, ogive shank, plate, sphere). Required except for "
                           "gmsh.",
                           "m", None),
            "inner_radius": Key("float", 0.0, "m",
                                "rod: inner radius, 0 for a solid rod, > 0 for a tube.", lower=0.0),
            "length": _pos("rod: length; ogive: ideal length, sharp tip to base; plate: "
                           "thickness. Required except for sphere (its diameter; leave unset) "
                           "and gmsh.", "m", None),
            "z_base": Key("float", 0.0, "m",
                          "Axial position of the lower end face (ogive: of the tip; sphere: "
                          "of its lowest point)."),
            "n_radial": Key("int", None, "-",
                            "Cells across the radius (plate: uniform cells out to fine_radius; "
                            "sphere: along the equatorial radius, >= 2). Required except for gmsh.",
                            lower=1),
            "n_axial": Key("int", None, "-",
                           "Cells along the length (ogive: along the shank; plate: through the "
                           "thickness). Required except for sphere (leave unset) and gmsh.",
                           lower=1),
            "crh": Key("float", 3.0, "-",
                       "ogive: caliber radius head psi (ogive radius / diameter), >= 0.5.",
                       lower=0.5),
            "n_nose": Key("int", None, "-",
                          "ogive: cells along the nose. Unset: cells about as long as wide.",
                          lower=1),
            "fine_radius": _pos("plate: radius of the uniformly meshed impact zone. For a body "
                                "of particles keep it beyond the zone that will yield or "
                                "fail: SPH sums lose accuracy where the spacing grades, and "
                                "a concrete slab whose particles graded from 50 mm let a "
                                "606 m/s rod through 18 m/s faster than one uniform to "
                                "150 mm (docs/validation.md).", "m", None),
            "n_coarse": Key("int", 0, "-",
                            "plate: cells from fine_radius to the rim, growing geometrically "
                            "from the fine cell width (0: uniform to the rim).", lower=0),
            "mesh_file": Key("str", None, "-",
                             "gmsh: path of a 2D triangle mesh (.msh), relative to the deck."),
            "mesh_scale": Key("float", 1.0, "-",
                              "gmsh: factor from file coordinates to metres (1e-3 for mm).",
                              lower=0.0, lower_open=True),
            "velocity_z": Key("float", 0.0, "m/s", "Initial axial velocity (negative: towards -z)."),
        },
        repeatable=True, required=True, min_count=1,
    ),
    "sph": Group(
        "Particle (SPH) parameters.",
        {
            "alpha_h": Key("float", 1.3, "-",
                           "Smoothing length h = alpha_h * Delta, Delta the particle spacing "
                           "(sqrt of the lattice cell area). 1.3 gives about 21 neighbours within "
                           "the 2h support of the cubic B-spline on a square lattice.",
                           lower=0.5, upper=3.0),
            "c_q": Key("float", 1.0, "-",
                       "Quadratic coefficient of the pairwise (Johnson 'combined') viscosity "
                       "q_ij = rho (C_Q h eps_ij)^2 + C_L rho c h |eps_ij|, eps_ij the normal "
                       "strain rate of the pair (Monaghan beta = C_Q^2). 1.0 and 0.2 (c_l) are "
                       "the customary quadratic and linear coefficients of commercial "
                       "hydrocodes for solids.", lower=0.0),
            "c_l": Key("float", 0.2, "-", "Linear coefficient of the pairwise viscosity "
                       "(Monaghan alpha = C_L). Both terms are scaled by the pair's compression "
                       "switch |div v|/(|div v| + |D'| + 1e-4 c/h): the viscosity acts in "
                       "compression and shocks, not in isochoric plastic flow (docs/method.md).",
                       lower=0.0),
            "hourglass": Key("float", 0.1, "-",
                             "Coefficient C_hg of the hourglass viscosity: a pair force "
                             "C_hg rho c h dW/dr (dv - G dx)/r on the part of the pair's velocity "
                             "difference that the particles' velocity gradients G do not explain "
                             "(zero for any linear velocity field). It damps the particle-scale "
                             "modes that the collocated SPH gradient does not see (alternating "
                             "columns sliding along each other), which otherwise grew in the "
                             "shank of a Taylor rod into a band of spurious plastic strain. "
                             "0 turns it off (the pure SPH Armco rod then shortens 1.7 % more "
                             "than with 0.1); from 0.05 to 0.5 its L stays within 0.1 % and "
                             "its D falls by 2.5 % (docs/validation.md). Values above 0.5 "
                             "are not accepted: untested.",
                             lower=0.0, upper=0.5),
            "artificial_stress": Key("float", 0.0, "-",
                                     "Coefficient eps of the artificial stress against the "
                                     "tensile instability (Monaghan 2000; Gray, Monaghan & Swift "
                                     "2001 for solids): each tensile principal stress of a "
                                     "particle's in-plane stress adds -eps times itself to its "
                                     "pair stress, weighted by (W(r)/W(dp))^4 for a pair r apart "
                                     "(dp = h/alpha_h, the initial spacing), so particles held in "
                                     "tension repel as they close in below their spacing instead "
                                     "of clumping; its work is charged in the energy equation. "
                                     "0 turns it off (the default); 0.3 is the value of Gray et "
                                     "al. for solids. In the debris clouds 0.1 and 0.3 take the "
                                     "particles within 1 um of another from 3.8-6.4 % to 0-0.3 % "
                                     "(case 1) with the fronts within 0.3 % and the energy as "
                                     "without; in a Taylor rod's foot, whose lattice the plastic "
                                     "flow has squashed below dp, it drives the particles apart "
                                     "(0.3: D -3.6 %, tension to -16 GPa; 0.1: D -1.1 %) "
                                     "(docs/method.md, docs/validation.md). The debris and sphere "
                                     "decks set 0.1. Values above 1 are not "
                                     "accepted: untested.",
                                     lower=0.0, upper=1.0),
            "total_hourglass": Key("float", 1.0, "-",
                                   "Coefficient gamma of the hourglass control of total-"
                                   "Lagrangian bodies (Ganzenmueller 2015): a pair force along "
                                   "the line of centres, proportional to gamma E W_ij times the "
                                   "difference between the pair's separation and the one its "
                                   "deformation gradients predict (zero for any affine "
                                   "deformation). It is elastic: it also resists plastic flow. "
                                   "On the Armco Taylor rod (20 particles across) gamma 0 / 1 / "
                                   "2 / 5 / 10 gave an impact-face diameter of 14.15 / 13.49 / "
                                   "13.23 / 12.91 / 12.41 mm (FEM 14.74, experiment 13.7) and "
                                   "from 2 up particles colder than the reference state; 20 "
                                   "was unstable (docs/method.md). 0 turns it off.",
                                   lower=0.0, upper=10.0),
            "total_stencil": Key("str", "full", "-",
                                 "Stencil of the corrected gradient of total-Lagrangian bodies. "
                                 "full: every neighbour within the kernel support (about 21 on "
                                 "a lattice with h = 1.3 spacings). selected: the selected-"
                                 "particle stencil of Wang, Xu & Yang 2022 (SFPM): the nearest "
                                 "neighbour in each of four sectors around +r, -r, +z, -z (on a "
                                 "lattice, central differences), at a surface the three nearest "
                                 "that span the plane, made symmetric pair by pair; cheaper, and "
                                 "it leans on the hourglass control (docs/method.md measures "
                                 "the trade-off).", choices=("full", "selected")),
            "debris_density": Key("float", 0.1, "-",
                                  "A particle whose density falls below this fraction of its "
                                  "material's reference density is debris: fragments that have "
                                  "separated, the particle's volume mostly void. Its density is "
                                  "held there and it carries no stress; the count is reported "
                                  "(summary.json n_debris_particles). Without it the density of "
                                  "separating concrete fragments fell through zero (the summed "
                                  "continuity equation is not relative to the particle's own "
                                  "density) and stopped the 1058 m/s slab run. Particle radii "
                                  "(contact thickness) use the reference density as a lower "
                                  "bound for the same reason.",
                                  lower=0.0, upper=1.0, lower_open=True, upper_open=True),
            "neighbour_skin": Key("float", 0.1, "-",
                                  "Skin of the neighbour lists, as a fraction of the smallest "
                                  "kernel support 2h: the lists hold the pairs within 2h plus "
                                  "the skin and are rebuilt only when a particle or an element "
                                  "centroid may have crossed it (twice the largest displacement "
                                  "since the build, plus the growth of the elements' h, reaches "
                                  "the skin), or after a conversion. The results do not depend "
                                  "on it (pairs beyond the support add exact zeros, the lists "
                                  "are in index order); 0 rebuilds every cycle. It trades the "
                                  "cost of the search against that of the extra pairs "
                                  "(docs/performance.md). The skin follows the flow from this "
                                  "value up to three times it: lists that expire within two "
                                  "cycles of their build widen the next one by 1.5, lists that "
                                  "last twelve narrow it again (a debris cloud at 5 km/s).",
                                  lower=0.0, upper=1.0),
            "spatial_order_min": Key("int", 4096, "-",
                                     "Fewest particles kept in spatial order. Particles made by "
                                     "conversion are appended in the order their elements "
                                     "convert, which spreads the data of a particle's neighbours "
                                     "over memory; from this many particles on, they are "
                                     "renumbered by cell rows after a conversion, and again each "
                                     "time their number has grown by 5 %. It reorders the pair "
                                     "sums, so results change in their last digits (not with the "
                                     "thread count; a restart renumbers where the run did); the "
                                     "snapshots' particle id stays with each particle. Below "
                                     "about 4 000 particles the neighbours' data fit in a core's "
                                     "L2 cache in any order (docs/performance.md, \"Particles in "
                                     "spatial order\"). 0: never. Runs with total-Lagrangian "
                                     "bodies are not renumbered.",
                                     lower=0),
            "eigenerosion_factor": _pos("Geometric factor lambda of the eigenerosion energy "
                                        "release rate G = lambda 2h <W> of &material "
                                        "fracture_energy (of order 1; Pandolfi & Ortiz 2012 "
                                        "leave it to calibration).", "-", 1.0),
            "particle_contact": Key("str", "riemann", "-",
                                    "Contact between particles of different bodies. riemann: "
                                    "pairwise contact pressures p* >= 0 of the acoustic Riemann "
                                    "problem across the contact (Wang, Xu & Yang 2022), a "
                                    "frictionless pressure along the contact normal in the SPH "
                                    "momentum and density sums; it does not depend on the time "
                                    "step, so it holds at 100 GPa (a copper flyer on aluminium "
                                    "at 5.55 km/s: energy within 0.2 %). potential: a contact "
                                    "potential of each particle's kernel filling by the other "
                                    "bodies (contact_penalty), whose stiffness grows as 1/dt^2 "
                                    "(the same impact gained 37 % energy). docs/method.md "
                                    "compares them. Between total-Lagrangian bodies the "
                                    "Riemann pressures' work is heat with no compression "
                                    "behind it (a Taylor rod against its mirror image: foot "
                                    "3.9 % narrower than on the anvil, the potential 0.1 %; "
                                    "docs/validation.md).",
                                    choices=tuple(name for name, _ in layouts.PARTICLE_CONTACTS)),
            "contact_penalty": Key("float", 0.03, "-",
                                   "particle_contact 'potential' only: a particle's "
                                   "filling by the other bodies' kernels beyond its value at "
                                   "touching is pushed back by this fraction per step (the "
                                   "stiffness of a contact potential, docs/method.md). Every "
                                   "neighbour pair adds to it, so the default is low: with 0.1 "
                                   "the 800 m/s plate case gained 5 % energy, with 0.3 it "
                                   "failed; the 508 m/s pure SPH residual velocity is 419.4 "
                                   "m/s with 0.03 and 418.6 with 0.1.",
                                   lower=0.0, upper=1.0, lower_open=True),
        },
    ),
    "convert": Group(
        "Automatic conversion of distorted elements into particles (mode adaptive; Xiao et al. 2012 "
        "section 2.3). Elements are grouped at set-up into rectangles of side kappa * R_max, "
        "R_max = 2 alpha_h sqrt(A0) (&sph alpha_h), A0 the median initial element area of the "
        "body (eq 9 takes the largest, the same on a uniform mesh; on a graded plate the "
        "largest would make groups of hundreds of impact-zone elements); when one element of a "
        "group meets the criterion, the whole group becomes particles.",
        {
            "criterion": Key("str", "min_angle", "-",
                             "min_angle: smallest interior angle below theta_c (Xiao et al. 2012); "
                             "plastic_strain: equivalent plastic strain at least eps_c "
                             "(Hu et al. 2013); equivalent_stress: von Mises stress at least sigma_c.",
                             choices=tuple(name for name, _ in layouts.CONVERSION_CRITERIA)),
            "theta_c": Key("float", 30.0, "deg", "Critical minimum interior angle (Xiao et al. 2012: 30).",
                           lower=0.0, upper=60.0, lower_open=True, upper_open=True),
            "relative_angle": Key("float", 0.75, "-",
                                  "min_angle criterion for elements that start below theta_c "
                                  "(graded or mapped meshes, e.g. the wide cells at a plate's "
                                  "rim or next to an ogive tip): such an element converts when "
                                  "its minimum angle is below both theta_c and relative_angle "
                                  "times its initial minimum angle. Elements that start at or "
                                  "above theta_c (crossed squares: 45 deg) see theta_c alone, "
                                  "as in Xiao et al. 2012.", lower=0.0, upper=1.0, lower_open=True),
            "eps_c": Key("float", 0.4, "-",
                         "Critical equivalent plastic strain (Hu et al. 2013 use 0.4; 0.3-0.6 usual).",
                         lower=0.0, lower_open=True),
            "sigma_c": _pos("Critical equivalent stress (criterion equivalent_stress).", "Pa", None),
            "kappa": Key("float", 1.5, "-",
                         "Group size factor of Xiao et al. 2012 eq 9 (> 1, so a converted group's "
                         "particles stay within its neighbouring groups).",
                         lower=1.0, lower_open=True),
        },
    ),
    "contact": Group(
        "Contact between bodies (Xiao et al. 2012 section 2.2): element-element slide lines "
        "(every surface node against the other bodies' surface segments, so each surface is "
        "master and slave in turn, after Johnson & Stryk 2001) and particle-element contact "
        "(Hu et al. 2013 eqs 1-3, the particle radius as contact thickness), as momentum-conserving "
        "corrections of the half-step velocities; particle-particle contact between bodies is "
        "&sph particle_contact (Riemann pressures by default). Surfaces follow the element region as elements "
        "are converted. The kinetic energy the corrections remove is reported "
        "(contact_dissipation_J) and counted in the energy balance.",
        {
            "enabled": Key("bool", True, "-",
                           "Contact on. It only acts where two bodies (or a particle and an "
                           "element surface) meet, so leaving it on costs little."),
            "passes": Key("int", 3, "-",
                          "Correction passes per cycle (Hu et al. 2013: 3 to 5 give satisfactory "
                          "results; the pairs share master nodes, so one pass does not remove "
                          "every penetration).", lower=1, upper=20),
            "friction": Key("float", 0.0, "-",
                            "Coulomb friction coefficient of element and particle contact "
                            "(0: frictionless, as in Xiao et al. 2012 and Hu et al. 2013).", lower=0.0, upper=2.0),
            "own_particles": Key("bool", True, "-",
                                 "Untied particles may not cross into their own body's element "
                                 "region either (zero contact thickness; nearer than that the "
                                 "SPH sums with the imaginary particles act)."),
        },
    ),
    "erosion": Group(
        "Element erosion, the FEM baseline of Hu et al. 2013 (mode fem only): an element whose "
        "largest principal strain (logarithmic: ln of the largest principal stretch, the hoop "
        "stretch included, from the deformation since t = 0) reaches principal_strain is "
        "deleted. A third of its mass stays on each of its nodes while the node belongs to a "
        "remaining element (Hu et al. 2013: the mass goes to the neighbouring nodes); a node left "
        "without elements is removed. The deleted internal energy and the removed nodes' "
        "mass, momentum and kinetic energy are reported (summary.json `erosion`) and counted "
        "in the energy balance.",
        {
            "enabled": Key("bool", False, "-", "Erosion on."),
            "principal_strain": Key("float", 1.5, "-",
                                    "Largest principal strain at deletion (Hu et al. 2013: 1.5; "
                                    "1.0-3.0 usual, chosen by experience, and the result is "
                                    "sensitive to it).", lower=0.0, lower_open=True),
        },
    ),
    "boundary": Group(
        "A rigid, fixed, frictionless plane (e.g. the Taylor anvil). Repeatable. Bodies stay "
        "on the side the normal points to.",
        {
            "type": Key("str", "rigid_plane", "-", "Boundary type.", choices=("rigid_plane",)),
            "point": Key("float2", (0.0, 0.0), "m", "A point (r, z) of the plane."),
            "normal": Key("float2", (0.0, 1.0), "-", "Normal (r, z) towards the bodies "
                          "(normalised by fsph; must not be zero)."),
        },
        repeatable=True,
    ),
    "gauge": Group(
        "A gauge: the time history of the material state at a point, recorded at every "
        "history record (&output history_every; the rows of fsph.h5 /history) into fsph.h5 "
        "/gauge_history/<name>/<field> (r, z, velocity, pressure, axial stress, von Mises "
        "stress, plastic strain, temperature, density, internal energy, damage, inside: "
        "fsph.layouts GAUGE_COLUMNS, each with its units), with the peak |pressure| and the "
        "last values in summary.json `gauges`. Repeatable. The value is that of the element "
        "containing the point (nodal velocities interpolated), else of the nearest particle "
        "within its kernel support (no smoothing); where neither, inside = 0 and the fields "
        "are NaN (docs/method.md, Gauges). Gauges only read the state; a restart locates "
        "them again from the deck (they may be added or changed on restart), and a gauge "
        "of the same name, kind and point carries on: its peak, and for a material gauge "
        "the particle it followed and its switch time.",
        {
            "name": Key("str", REQUIRED, "-", "Gauge name, unique, without '/' (an HDF5 group)."),
            "point": Key("float2", REQUIRED, "m",
                         "The point (r, z), r >= 0: the material point there at t = 0 (kind "
                         "material) or a point fixed in space (kind fixed)."),
            "kind": Key("str", "material", "-",
                        "material: a Lagrangian tracer that follows the material point at "
                        "`point` at t = 0 (in its element, with fixed barycentric weights; "
                        "when the element turns into particles, the particle of its body "
                        "nearest the gauge then; when it is eroded, no material from then "
                        "on); the point must lie in a body at t = 0. fixed: a point fixed in "
                        "space that samples whatever material is there, nothing when empty.",
                        choices=tuple(name for name, _ in layouts.GAUGE_KINDS)),
        },
        repeatable=True,
    ),
    "output": Group(
        "What is written and how often.",
        {
            "n_snapshots": Key("int", 10, "-",
                               "Snapshots at equal intervals of end_time (plus t = 0), each at "
                               "the first cycle end at or after its time (a snapshot never "
                               "shortens a step, so the outputs do not alter the run); where one "
                               "step passes several of these times they share one snapshot. The "
                               "last is always at end_time exactly.", lower=1,
                               upper=MAX_OUTPUTS),
            "n_progress": Key("int", 20, "-", "Progress lines printed over the run (at most one "
                              "per cycle; they do not alter the run).", lower=1,
                              upper=MAX_OUTPUTS),
            "history_every": Key("int", 10, "-", "Cycles between time-history records.", lower=1),
            "vtu": Key("bool", True, "-", "Write a ParaView series (.pvd + .vtu)."),
            "revolve_segments": Key("int", 0, "-",
                                    "Also write the bodies revolved about the axis into 3D, for "
                                    "viewing (fsph_3d.pvd: elements as wedges, particles as "
                                    "rings of points), with this many segments over "
                                    "revolve_angle (0: off; needs vtu).", lower=0, upper=360),
            "revolve_angle": Key("float", 360.0, "deg",
                                 "Angle the bodies are revolved through: below 360 a wedge "
                                 "is left out, to see inside.", lower=0.0, lower_open=True,
                                 upper=360.0),
            "checkpoint": Key("bool", True, "-",
                              "Write checkpoint.h5 at every snapshot and on SIGINT/SIGTERM "
                              "(fsph run DECK --restart DIR/checkpoint.h5 continues bit for bit)."),
            "checkpoint_minutes": Key("float", 0.0, "-",
                                      "Also write the checkpoint whenever this many minutes of "
                                      "wall time have passed since the last one (0: only at "
                                      "snapshots and interrupts).", lower=0.0),
            "checkpoint_cycles": Key("int", 0, "-",
                                     "Also write the checkpoint every this many cycles (at "
                                     "cycles that are multiples of it; 0: off). The run's "
                                     "trajectory does not depend on it.", lower=0),
            "reference": Key("str", None, "-",
                             "JSON file of reference (experimental or analytic) values, "
                             "relative to the deck's folder: 'source' (text), and the "
                             "measured values by metric group ({\"taylor\": {\"L_mm\": "
                             "19.8}}: finite numbers other than 0, the errors being relative "
                             "to them; checked when the deck is read). Its optional "
                             "'conditions' ({\"body(rod).velocity_z\": -221.0, ...}) are the "
                             "deck values the values hold for, or least values "
                             "({\"control.end_time\": {\"at_least\": 6.0e-5}}: a final shape, "
                             "a residual velocity): a run that differs in one is not compared "
                             "(the summary says why), and a sweep keeps a reference without "
                             "conditions only for the variants that change nothing."),
        },
    ),
    "metrics": Group(
        "Case metrics written to summary.json.",
        {
            "kind": Key("str", "none", "-",
                        "taylor: final length L, maximum diameter D and width W at "
                        "w_height above the impact face; bar_wave: stress plateau and wave "
                        "front along a line r = probe_radius; perforation: the projectile's "
                        "mass-weighted axial velocity and its residual velocity (the "
                        "component along the striking direction; 0 for a projectile that "
                        "stopped or rebounds, flagged 'rebounded'), penetration depth, "
                        "whether it has left the target ('exited': its rear has passed the "
                        "target's initial far face; a residual velocity is compared with a "
                        "reference only then) and the hole diameter, with their "
                        "history at every snapshot, and whether the velocity had settled "
                        "(changed by at most 1 % of the striking speed over the last fifth "
                        "of the run; 'settled'); debris: a flyer's debris cloud behind a "
                        "plate (docs/validation.md, Debris clouds): the front of each body's "
                        "cloud (at front_fraction of the cloud's mass, and at 0.5, 1 and 2 %), "
                        "their ratio, the back-splash ejecta height, the radius where the "
                        "clouds meet, the hole diameter, cloud masses and axial momenta, "
                        "lengths along the flight direction from the plate's front face "
                        "before impact, at every snapshot (summary.json and /metrics/debris "
                        "in fsph.h5), with the 1D impedance match of the two Hugoniots "
                        "against the interface state measured in the run (not for a sphere "
                        "flyer, whose shock is not 1D).",
                        choices=("none", "taylor", "bar_wave", "perforation", "debris")),
            "body": Key("str", None, "-", "Body measured (default: the first body; "
                        "perforation: the projectile; debris: the flyer)."),
            "target": Key("str", None, "-", "perforation and debris: the target body "
                          "(default: the first body other than the projectile or flyer)."),
            "w_height": _pos("Height above the impact face at which W is measured "
                             "(default 0.2 L0 of the body).", "m", None),
            "probe_radius": _pos("Radius of the bar_wave sampling line.", "m", None),
            "plateau_from": Key("float", None, "m",
                                "bar_wave: start of the plateau window, distance from the "
                                "impact face in the initial configuration.", lower=0.0),
            "plateau_to": _pos("bar_wave: end of the plateau window (see plateau_from).", "m", None),
            "interface": Key("float", None, "m",
                             "bar_wave: initial distance from the face of an element-particle "
                             "interface; the jump of the mean stress across it (3 mm either "
                             "side, relative to the plateau) is reported.", lower=0.0),
            "front_fraction": Key("float", 0.01, "-",
                                  "debris: the front of a cloud is the position along the "
                                  "flight direction beyond which lies this fraction of the "
                                  "cloud's own mass (a few stray particles do not move it; "
                                  "the fronts at 0.5, 1 and 2 % are reported beside it). "
                                  "The same fraction gives the ejecta height and the "
                                  "intersection radius.",
                                  lower=0.0, upper=0.5, lower_open=True),
            "intact_fraction": Key("float", 0.5, "-",
                                   "debris: a ring of the plate (twice the plate's spacing "
                                   "wide) is intact while the plate's band (its initial "
                                   "thickness widened by one thickness on each side) holds "
                                   "at least this fraction of the mass that started in it; "
                                   "the hole is inside the intact rings counted from the "
                                   "rim.", lower=0.0, upper=1.0, lower_open=True),
        },
    ),
}


# --------------------------------------------------------------------------
def _type_name(kind):
    return {"float": "a real number", "int": "an integer", "str": "a quoted string",
            "bool": "a logical (.true. or .false.)", "float2": "two real numbers"}[kind]


def _coerce(path, gname, kname, key, value):
    """Check the type of one raw value and return it in Python form."""
    expected = _type_name(key.kind)
    if key.kind == "float":
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise DeckError(path, gname, kname, expected, value)
        value = float(value)
        if not math.isfinite(value):
            raise DeckError(path, gname, kname, "a finite real number", value)
    elif key.kind == "int":
        if isinstance(value, bool) or not isinstance(value, numbers.Integral):
            raise DeckError(path, gname, kname, expected, value)
        value = int(value)
    elif key.kind == "str":
        if not isinstance(value, str):
            raise DeckError(path, gname, kname, expected, value)
        value = value.strip()
    elif key.kind == "bool":
        if not isinstance(value, (bool, np.bool_)):
            raise DeckError(path, gname, kname, expected, value)
        value = bool(value)
    elif key.kind == "float2":
        if (not isinstance(value, (list, tuple)) or len(value) != 2
                or any(isinstance(v, bool) or not isinstance(v, numbers.Real) for v in value)):
            raise DeckError(path, gname, kname, expected, value)
        value = tuple(float(v) for v in value)
        if not all(math.isfinite(v) for v in value):
            raise DeckError(path, gname, kname, "two finite real numbers", list(value))
    return value


def _check_range(path, gname, kname, key, value):
    if key.choices and value not in key.choices:
        raise DeckError(path, gname, kname, "one of " + ", ".join(key.choices), value)
    if key.implemented and value not in key.implemented:
        raise DeckError(path, gname, kname,
                        "one of " + ", ".join(key.implemented)
                        + f" ('{value}' is not available in this version)", value)
    if key.kind in ("float", "float2"):
        limit = UNIT_LIMITS.get(key.unit)
        values = value if key.kind == "float2" else (value,)
        if limit is not None and any(abs(v) > limit for v in values):
            raise DeckError(path, gname, kname,
                            f"a value of plausible magnitude (at most {limit:g} {key.unit})", value)
        floor = UNIT_FLOORS.get(key.unit)
        if key.lower == 0.0 and key.lower_open and floor is not None and 0.0 < value < floor:
            raise DeckError(path, gname, kname,
                            f"a value of plausible magnitude (at least {floor:g} {key.unit})", value)
    if key.kind == "int" and abs(value) > MAX_INT:
        raise DeckError(path, gname, kname, f"an integer of magnitude at most {MAX_INT}", value)
    if key.kind in ("float", "int"):
        lo, hi = key.lower, key.upper
        bad = ((lo is not None and (value <= lo if key.lower_open else value < lo))
               or (hi is not None and (value >= hi if key.upper_open else value > hi)))
        if bad:
            raise DeckError(path, gname, kname, f"a value in {_range_text(key)} [{key.unit}]",
                            value)


def _range_text(key):
    lo = "(-inf" if key.lower is None else ("(" if key.lower_open else "[") + f"{key.lower:g}"
    hi = "inf)" if key.upper is None else f"{key.upper:g}" + (")" if key.upper_open else "]")
    return f"{lo}, {hi}"


def _group_label(gname, group, index):
    return f"{gname} #{index + 1}" if group.repeatable else gname


def _read_group(path, gname, group, raw, index, base=None):
    """Validate one group instance; `base` gives defaults (library entry)."""
    label = _group_label(gname, group, index)
    out = {}
    for kname, value in raw.items():
        if kname not in group.keys:
            raise DeckError(path, label, kname, "one of the keys of &" + gname + ": "
                            + ", ".join(group.keys), "unknown key")
        key = group.keys[kname]
        if value is None:
            raise DeckError(path, label, kname, _type_name(key.kind), "an empty value")
        value = _coerce(path, label, kname, key, value)
        _check_range(path, label, kname, key, value)
        out[kname] = value
    for kname, key in group.keys.items():
        if kname in out:
            continue
        if base is not None and kname in base:
            out[kname] = base[kname]
        elif key.default is REQUIRED:
            raise DeckError(path, label, kname, f"a value ({key.doc.rstrip('.')})", "missing key")
        else:
            out[kname] = copy.deepcopy(key.default)
    return out


def _groups(nml):
    """Group name -> list of raw dicts, in file order."""
    out = {}
    for gname, value in nml.items():
        items = list(value) if isinstance(value, list) else [value]
        out.setdefault(gname.lower(), []).extend(dict(v) for v in items)
    return out


#: A deck key as `fsph sweep --set` and a reference's conditions write it:
#: GROUP.KEY, GROUP(I).KEY (I from 1) or GROUP(NAME).KEY.
KEY_SPEC = re.compile(r"^\s*([A-Za-z_]\w*)\s*(?:[(\[]\s*([^)\]]*?)\s*[)\]])?\s*\.\s*(\w+)\s*$")


def group_instance(path, gname, selector, key, items):
    """0-based instance among `items` (the group's dicts) chosen by the
    selector of a KEY_SPEC (None, a 1-based index or a name); DeckError
    names the deck at `path` where none or several fit."""
    group = SCHEMA[gname]
    n = len(items)
    if selector is None:
        if group.repeatable and n > 1:
            raise DeckError(path, gname, key,
                            f"an instance of the {n} &{gname} groups: {gname}(1).{key} to "
                            f"{gname}({n}).{key} or {gname}(NAME).{key}", f"{gname}.{key}")
        return 0
    if selector.isdigit():
        i = int(selector)
        if not 1 <= i <= max(n, 1) or (not group.repeatable and i != 1):
            raise DeckError(path, gname, key, f"an instance from 1 to {max(n, 1)} (the deck "
                            f"has {n} &{gname} group(s))", f"{gname}({selector})")
        return i - 1
    names = [str(item.get("name", "")).strip() for item in items]
    if selector.strip("'\"") not in names:
        raise DeckError(path, gname, key, f"the name of a &{gname}: " + ", ".join(names),
                        selector)
    return names.index(selector.strip("'\""))


def _group_openings(text):
    """The namelist structure of a deck's text, outside strings and
    comments: a list of (kind, group name or None, line), kind 'open'
    (&name or $name) or 'close' (/, &end or $end)."""
    events, line, k, n = [], 1, 0, len(text)
    while k < n:
        c = text[k]
        if c == "\n":
            line += 1
        elif c == "!":                                   # comment to the end of the line
            while k < n and text[k] != "\n":
                k += 1
            continue
        elif c in "'\"":                                # string; a doubled quote stays inside
            k += 1
            while k < n and not (text[k] == c and text[k + 1:k + 2] != c):
                if text[k] == c:
                    k += 1
                line += text[k] == "\n"
                k += 1
        elif c == "/":
            events.append(("close", None, line))
        elif c in "&$":
            m = re.match(r"[A-Za-z_]\w*", text[k + 1:])
            name = m.group(0).lower() if m else ""
            events.append(("close" if name == "end" else "open", name, line))
            k += len(name)
        k += 1
    return events


def _check_group_bounds(path, text):
    """Every group is closed by '/' before the next one opens: a missing
    '/' would otherwise let the group swallow the next one, which the
    namelist reader drops without a word."""
    seen, current = {}, None
    for kind, name, line in _group_openings(text):
        if kind == "close":
            current = None
            continue
        seen[name] = seen.get(name, 0) + 1
        group = SCHEMA.get(name)
        label = _group_label(name, group, seen[name] - 1) if group else name
        if current is not None:
            raise DeckError(path, current[0], None,
                            f"a '/' closing &{current[0]} (opened on line {current[1]}) before "
                            f"the next group", f"&{label} on line {line} inside it")
        current = (label, line)
    if current is not None:
        raise DeckError(path, current[0], None,
                        f"a '/' closing &{current[0]} (opened on line {current[1]})",
                        "the end of the file")


def _parse(path):
    path = Path(path)
    if path.is_dir():
        raise DeckError(path, None, None, "a deck file", "a folder")
    if not path.is_file():
        raise DeckError(path, None, None, "an existing deck file", "no such file")
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise DeckError(path, None, None, "a readable text file", str(exc)) from None
    if "&" not in text:
        raise DeckError(path, None, None, "at least one namelist group (&control ... /)",
                        "no namelist group")
    _check_group_bounds(path, text)
    try:
        parser = f90nml.Parser()
        nml = parser.reads(text)
    except Exception as exc:  # f90nml raises several types on broken syntax
        raise DeckError(path, None, None, "valid Fortran namelist syntax",
                        f"{type(exc).__name__}: {exc}") from None
    return _groups(nml)


# --------------------------------------------------------------------------
def _check_material_keys(path, label, m):
    """The keys the material's strength model and EOS need are all given,
    and strength and EOS are both 'hjc' or neither."""
    need = {
        "epp": ("yield_stress",),
        "bilinear": ("yield_stress", "tangent_modulus"),
        "johnson_cook": ("jc_a", "jc_b", "jc_n", "jc_c", "jc_m", "melt_temperature"),
        "power_law": POWER_LAW_KEYS + ("melt_temperature",),
        "steinberg_guinan": STEINBERG_GUINAN_KEYS + ("melt_temperature",),
        "hjc": (),
        "elastic": (),
    }[m["strength"]]
    if (m["strength"] == "hjc") != (m["eos"] == "hjc"):
        key = "eos" if m["strength"] == "hjc" else "strength"
        raise DeckError(path, label, key, "'hjc' together with "
                        + ("strength" if key == "eos" else "eos") + " 'hjc' (the HJC strength "
                        "and pressure share the damage and compaction history)", m[key])
    if m["eos"] == "mie_gruneisen":
        need += ("c0", "s", "gamma0")
    if m["eos"] == "hjc":
        need += HJC_KEYS
    for k in need:
        if m.get(k) is None:
            raise DeckError(path, label, k,
                            f"a value (needed by strength '{m['strength']}' / eos '{m['eos']}')",
                            "missing key")


def _check_elastic_constants(path, label, m):
    """Either youngs_modulus + poisson_ratio or shear_modulus (+
    bulk_modulus for the linear EOS); no bulk_modulus where something else
    fixes the bulk modulus."""
    has_e = m.get("youngs_modulus") is not None or m.get("poisson_ratio") is not None
    has_g = m.get("shear_modulus") is not None
    if has_e and has_g:
        raise DeckError(path, label, "shear_modulus",
                        "either youngs_modulus + poisson_ratio or shear_modulus, not both",
                        m["shear_modulus"])
    if has_e:
        for k in ("youngs_modulus", "poisson_ratio"):
            if m.get(k) is None:
                raise DeckError(path, label, k, "a value (youngs_modulus and poisson_ratio "
                                "go together)", "missing key")
        if m.get("bulk_modulus") is not None:
            raise DeckError(path, label, "bulk_modulus",
                            "no value with youngs_modulus + poisson_ratio (they fix the bulk "
                            "modulus; give shear_modulus + bulk_modulus instead)",
                            m["bulk_modulus"])
    elif not has_g:
        raise DeckError(path, label, "shear_modulus",
                        "elastic constants: youngs_modulus + poisson_ratio, or shear_modulus",
                        "missing key")
    elif m["eos"] == "linear" and m.get("bulk_modulus") is None:
        raise DeckError(path, label, "bulk_modulus",
                        "a value (the linear EOS with shear_modulus needs bulk_modulus)",
                        "missing key")
    if m["eos"] in ("mie_gruneisen", "hjc") and m.get("bulk_modulus") is not None:
        raise DeckError(path, label, "bulk_modulus",
                        f"no value for eos '{m['eos']}' (its bulk modulus is "
                        + ("rho0 c0^2" if m["eos"] == "mie_gruneisen" else "hjc_pcrush/hjc_mucrush")
                        + ")", m["bulk_modulus"])


def _check_hjc(path, label, m):
    """An HJC material: shear_modulus, not youngs_modulus; P_lock above
    P_crush; a fully dense curve that rises to P_lock beyond mu_crush."""
    if m.get("youngs_modulus") is not None:
        raise DeckError(path, label, "youngs_modulus", "no value for eos 'hjc' (give "
                        "shear_modulus; the bulk modulus is hjc_pcrush/hjc_mucrush)",
                        m["youngs_modulus"])
    if not m["hjc_plock"] > m["hjc_pcrush"]:
        raise DeckError(path, label, "hjc_plock",
                        f"a value above hjc_pcrush = {m['hjc_pcrush']} Pa", m["hjc_plock"])
    try:
        mu_plock = hjc_lock_strain(m)
    except ValueError as err:
        raise DeckError(path, label, "hjc_k2", "K1, K2, K3 with a fully dense curve "
                        "rising to hjc_plock", str(err)) from None
    if not mu_plock > m["hjc_mucrush"]:
        raise DeckError(path, label, "hjc_mulock",
                        f"a locking strain whose fully dense curve reaches hjc_plock beyond "
                        f"hjc_mucrush = {m['hjc_mucrush']} (it does at {mu_plock:.4g})",
                        m["hjc_mulock"])


def _validate_material(path, label, m):
    """The material's models have the keys they need, consistent elastic
    constants and admissible values across keys (label names it in
    errors, e.g. 'material #1'). Fills in the temperature model of an
    unset `temperature`."""
    m["temperature"] = temperature_model(m)
    _check_material_keys(path, label, m)
    _check_elastic_constants(path, label, m)
    if m["strength"] == "bilinear":
        _, _, e = elastic_moduli(m)
        if not m["tangent_modulus"] < e:
            raise DeckError(path, label, "tangent_modulus",
                            f"a value below Young's modulus E = {e:.4g} Pa", m["tangent_modulus"])
    if m["eos"] == "hjc":
        _check_hjc(path, label, m)
    if m["strength"] in ("johnson_cook", "power_law", "steinberg_guinan"):
        if m["specific_heat"] is None:
            raise DeckError(path, label, "specific_heat",
                            f"a value (strength '{m['strength']}' softens with the temperature, "
                            "which needs the specific heat c_p)", "missing key")
    if m["melt_temperature"] is not None:
        _check_melting(path, label, m)
    if m["strength"] == "steinberg_guinan" and not m["sg_ymax"] >= m["sg_y0"]:
        raise DeckError(path, label, "sg_ymax", f"a value of at least sg_y0 = {m['sg_y0']} Pa",
                        m["sg_ymax"])
    _check_temperature(path, label, m)
    _check_jc_failure(path, label, m)
    if m["eos"] == "hjc" and m["p_min"] is not None:
        raise DeckError(path, label, "p_min", "no value for eos 'hjc' (its tensile limit is "
                        "-hjc_t (1 - D))", m["p_min"])
    if m["spall_failure"] and m["p_min"] is None:
        raise DeckError(path, label, "spall_failure", "a p_min to fail at (spall_failure = .true. "
                        "needs the material's spall cut-off p_min)", "no p_min")


def _check_melting(path, label, m):
    """A melting temperature above room temperature, a temperature that
    can reach it, and the Lindemann law's needs."""
    if not m["melt_temperature"] > m["room_temperature"]:
        raise DeckError(path, label, "melt_temperature",
                        f"a value above room_temperature = {m['room_temperature']} K",
                        m["melt_temperature"])
    if m["specific_heat"] is None:
        raise DeckError(path, label, "specific_heat", "a value (a melting temperature needs a "
                        "temperature that changes, hence the specific heat c_p)", "missing key")
    if m["strength"] == "elastic" and temperature_model(m) == "plastic_work":
        raise DeckError(path, label, "melt_temperature",
                        "no value for an elastic material with temperature 'plastic_work' (it "
                        "never heats; temperature 'internal_energy' heats it)",
                        m["melt_temperature"])
    if m["melt_model"] == "lindemann":
        if m["eos"] != "mie_gruneisen":
            raise DeckError(path, label, "melt_model", "'constant' unless eos is "
                            "'mie_gruneisen' (the Lindemann law uses gamma0)", m["melt_model"])
        if m["lindemann_a"] is None:
            raise DeckError(path, label, "lindemann_a",
                            "a value (needed by melt_model 'lindemann')", "missing key")


def _check_temperature(path, label, m):
    """Temperature 'internal_energy' has its EOS and specific heat; no
    Lindemann exponent without the Lindemann law."""
    if m["lindemann_a"] is not None and m["melt_model"] != "lindemann":
        raise DeckError(path, label, "lindemann_a", "no value unless melt_model is 'lindemann'",
                        m["lindemann_a"])
    if temperature_model(m) != "internal_energy":
        return
    if m["eos"] != "mie_gruneisen":
        raise DeckError(path, label, "temperature", "'plastic_work' unless eos is "
                        "'mie_gruneisen' (internal_energy measures the energy from its "
                        "isentrope)", m["temperature"])
    if m["specific_heat"] is None:
        raise DeckError(path, label, "specific_heat",
                        "a value (needed by temperature 'internal_energy')", "missing key")
    if not m["s"] > 1.0:
        raise DeckError(path, label, "s", "a value above 1 for temperature 'internal_energy' "
                        "(its isentrope table runs up to the EOS's pole at mu = 1/(s - 1))",
                        m["s"])


def _check_jc_failure(path, label, m):
    """Johnson-Cook failure: its five constants together, with a plastic
    strength model that is not HJC (HJC has its own damage)."""
    given = [k for k in JC_FAILURE_KEYS if m.get(k) is not None]
    if not given:
        return
    for k in JC_FAILURE_KEYS:
        if m.get(k) is None:
            raise DeckError(path, label, k, "a value (jc_d1 to jc_d5 go together; "
                            f"{given[0]} is given)", "missing key")
    if m["strength"] in ("elastic", "hjc"):
        raise DeckError(path, label, "jc_d1",
                        f"no value with strength '{m['strength']}' (Johnson-Cook failure "
                        "accumulates plastic strain; hjc has its own damage)", m["jc_d1"])


#: A power-law material whose rate term exceeds RATE_WARNING_FACTOR at the
#: plastic strain rate RATE_WARNING_RATE [1/s] gets a warning: the rates
#: of the shocked zone of a hypervelocity impact are 1e5-1e7 1/s.
RATE_WARNING_RATE = 1.0e5
RATE_WARNING_FACTOR = 10.0

#: Largest relative difference between the bulk modulus of (E, nu) and the
#: Mie-Grueneisen rho0 c0^2 that passes without a warning [-].
BULK_MISMATCH_WARNING = 0.05


def _material_warnings(label, m):
    """Messages about a valid material that a user should read: a
    power-law rate term above RATE_WARNING_FACTOR at RATE_WARNING_RATE;
    with the Mie-Grueneisen EOS, a bulk modulus implied by youngs_modulus
    and poisson_ratio more than BULK_MISMATCH_WARNING from rho0 c0^2 (the
    EOS uses rho0 c0^2; E and nu then set the shear modulus only)."""
    out = []
    if m["strength"] == "power_law":
        rate = RATE_WARNING_RATE / m["pl_rate0"]
        factor = (1.0 + rate ** m["pl_m"] if m["pl_rate_form"] == "printed"
                  else (1.0 + rate) ** m["pl_m"])
        if factor > RATE_WARNING_FACTOR:
            out.append(f"{label} '{m['name']}': the power-law rate term multiplies the flow stress "
                       f"by {factor:.3g} at a plastic strain rate of {RATE_WARNING_RATE:g} 1/s "
                       f"(pl_m = {m['pl_m']:g}, pl_rate_form '{m['pl_rate_form']}'): where the "
                       "material is strained that fast it stays close to elastic")
    if m["eos"] == "mie_gruneisen" and m.get("youngs_modulus") is not None:
        e, nu = m["youngs_modulus"], m["poisson_ratio"]
        k_e = e / (3.0 * (1.0 - 2.0 * nu))
        k_eos = m["density"] * m["c0"] ** 2
        diff = k_e / k_eos - 1.0
        if abs(diff) > BULK_MISMATCH_WARNING:
            out.append(f"{label} '{m['name']}': the bulk modulus of youngs_modulus and "
                       f"poisson_ratio, K = E/(3(1 - 2 nu)) = {k_e / 1e9:.4g} GPa, differs from the "
                       f"Mie-Grueneisen rho0 c0^2 = {k_eos / 1e9:.4g} GPa by {100 * diff:+.1f} %: "
                       f"the pressure uses rho0 c0^2; E and nu set the shear modulus "
                       f"G = E/(2(1 + nu)) = {e / (2 * (1 + nu)) / 1e9:.4g} GPa only")
    return out


def load(path):
    """Read and validate a deck; returns a dict of groups (lists for the
    repeatable ones) with defaults filled in."""
    path = Path(path)
    return _validate(_parse(path), path, path.resolve().parent)


def from_groups(groups, name="<dict>", folder=None):
    """Validate a deck given as a dict: group name -> dict of keys (a list
    of dicts for a repeatable group such as body), the keys and values as
    in a namelist file; relative paths (references, meshes) from `folder`
    (default the current folder). Returns what load returns; errors name
    `name`."""
    if not isinstance(groups, dict):
        raise DeckError(name, None, None, "a dict of namelist groups", type(groups).__name__)
    raw = {}
    for gname, value in groups.items():
        items = list(value) if isinstance(value, (list, tuple)) else [value]
        for item in items:
            if not isinstance(item, dict):
                raise DeckError(name, str(gname), None, "a dict of keys (a list of dicts for a "
                                "repeatable group)", type(item).__name__)
        raw.setdefault(str(gname).lower(), []).extend(
            {str(k).lower(): v for k, v in item.items() if v is not None} for item in items)
    return _validate(raw, Path(name), Path(folder) if folder is not None else Path.cwd())


def groups_of(deck):
    """The namelist groups of a deck dict (not its path, folder, warnings)."""
    return {g: deck[g] for g in SCHEMA if g in deck}


def text_digest(text):
    """SHA-256 (hex) of a deck's text: what a stored run keeps of the deck
    it ran (summary.json inputs; fsph.sweep's variant.json), so that a run
    of a deck changed since, even by a comment, is not taken for one of
    the deck as it is now."""
    return hashlib.sha256(text.encode()).hexdigest()


def _fingerprint(deck):
    """Digest of a deck's groups (what a Simulation is built from)."""
    return hashlib.sha256(json.dumps(groups_of(deck), sort_keys=True, default=repr).encode()).hexdigest()


def checked(deck):
    """`deck` itself if it is a validated deck unchanged since validation;
    otherwise its groups validated again (a dict built by hand, or a
    loaded deck whose values were changed), as from_groups does."""
    if not isinstance(deck, dict):
        raise DeckError("<deck>", None, None, "a deck dict (fsph.deck.load or from_groups)",
                        type(deck).__name__)
    if deck.get("fingerprint") == _fingerprint(deck):
        return deck
    return from_groups(copy.deepcopy(groups_of(deck)), deck.get("path", "<dict>"), deck.get("dir"))


def _validate(raw, path, folder):
    """The deck of raw groups (name -> list of dicts of raw values), read
    from `path`, relative paths from `folder`."""
    for gname in raw:
        if gname not in SCHEMA:
            raise DeckError(path, gname, None, "one of the groups "
                            + ", ".join("&" + g for g in SCHEMA), "unknown group")
    deck = {"path": str(path), "dir": str(folder), "warnings": []}
    for gname, group in SCHEMA.items():
        items = raw.get(gname, [])
        if group.required and not items:
            raise DeckError(path, gname, None, f"a &{gname} group", "none found")
        if not group.repeatable and len(items) > 1:
            raise DeckError(path, gname, None, f"a single &{gname} group", f"{len(items)} groups")
        if group.repeatable:
            parsed = []
            for i, item in enumerate(items):
                base = None
                if gname == "material" and "library" in item:
                    lib = item["library"]
                    if not isinstance(lib, str) or lib.strip() not in LIBRARY:
                        raise DeckError(path, _group_label(gname, group, i), "library",
                                        "one of " + ", ".join(LIBRARY), lib)
                    base = {k: v for k, v in LIBRARY[lib.strip()].items() if k != "source"}
                parsed.append(_read_group(path, gname, group, item, i, base))
            deck[gname] = parsed
        else:
            deck[gname] = _read_group(path, gname, group, items[0] if items else {}, 0)

    _cross_check(path, deck)
    deck["fingerprint"] = _fingerprint(deck)
    return deck


def _unique_names(path, gname, items):
    seen = set()
    for i, item in enumerate(items):
        # names become HDF5 groups (fsph.h5 body_history/<body>)
        if not item["name"].strip() or "/" in item["name"] or item["name"].strip() == ".":
            raise DeckError(path, f"{gname} #{i + 1}", "name", "a name without '/', not empty "
                            "and not '.'", item["name"])
        if item["name"] in seen:
            raise DeckError(path, f"{gname} #{i + 1}", "name", "a name not used by another "
                            f"&{gname}", item["name"])
        seen.add(item["name"])


#: Keys each geometry generator needs.
GEOMETRY_KEYS = {
    "rod": ("radius", "length", "n_radial", "n_axial"),
    "ogive": ("radius", "length", "n_radial", "n_axial"),
    "plate": ("radius", "length", "n_radial", "n_axial", "fine_radius"),
    "sphere": ("radius", "n_radial"),
    "gmsh": ("mesh_file",),
}


def _check_geometry(path, where, b):
    geometry = b["geometry"]
    for key in GEOMETRY_KEYS[geometry]:
        if b[key] is None:
            raise DeckError(path, where, key, f"a value (needed by geometry '{geometry}')",
                            "missing key")
    if geometry == "gmsh":
        if b["discretisation"] != "elements":
            raise DeckError(path, where, "discretisation",
                            "'elements' for geometry 'gmsh'", b["discretisation"])
        mesh_path = Path(b["mesh_file"])
        if not mesh_path.is_absolute():
            mesh_path = Path(path).parent / mesh_path
        if not mesh_path.is_file():
            raise DeckError(path, where, "mesh_file", "an existing gmsh file", str(mesh_path))
        b["mesh_file"] = str(mesh_path)
    if geometry == "sphere":
        for key, why in (("length", "the sphere's axial extent is its diameter"),
                         ("n_axial", "the sphere's cells follow from n_radial")):
            if b[key] is not None:
                raise DeckError(path, where, key, f"no value for geometry 'sphere' ({why})",
                                b[key])
        if b["n_radial"] < 2:
            raise DeckError(path, where, "n_radial", "at least 2 for geometry 'sphere'",
                            b["n_radial"])
        b["length"] = 2.0 * b["radius"]          # the axial extent, as a rod's length
    if geometry == "ogive":
        nose = b["radius"] * math.sqrt(4.0 * b["crh"] - 1.0)     # (D/2) sqrt(4 psi - 1)
        if not b["length"] > nose:
            raise DeckError(path, where, "length",
                            f"more than the ogive nose length {nose:.6g} m (crh {b['crh']})",
                            b["length"])
    if geometry == "plate" and not b["fine_radius"] <= b["radius"]:
        raise DeckError(path, where, "fine_radius", f"at most radius = {b['radius']} m",
                        b["fine_radius"])
    if geometry == "plate" and (b["n_coarse"] == 0) != (b["fine_radius"] == b["radius"]):
        raise DeckError(path, where, "n_coarse",
                        "0 exactly when fine_radius equals radius (cells beyond fine_radius "
                        "need n_coarse >= 1)", b["n_coarse"])


def _cell_estimate(b):
    """Cells a body's generator makes (before the 4 triangles per cell)."""
    if b["geometry"] == "gmsh":
        return 0
    if b["geometry"] == "plate":
        return (b["n_radial"] + b["n_coarse"]) * b["n_axial"]
    if b["geometry"] == "ogive":
        return b["n_radial"] * (b["n_axial"] + (b["n_nose"] or 8 * b["n_radial"]))
    if b["geometry"] == "sphere":                # 2 nc^2 + 4 nc m (nc = 0.6 n_radial): about 1.7 n^2
        return 2 * b["n_radial"] * b["n_radial"]
    return b["n_radial"] * b["n_axial"]


def _check_discretisation(path, bodies, mode):
    """Fill in each body's default discretisation; modes fem and sph take
    only elements, only particles."""
    default_disc = "particles" if mode == "sph" else "elements"
    for i, b in enumerate(bodies):
        if b["discretisation"] is None:
            b["discretisation"] = default_disc
        elif mode in ("fem", "sph") and b["discretisation"] != default_disc:
            raise DeckError(path, f"body #{i + 1}", "discretisation",
                            f"'{default_disc}' in mode '{mode}' (mixed bodies need mode 'fixed' "
                            "or 'adaptive')", b["discretisation"])


def _check_size(path, bodies):
    """At most MAX_ENTITIES elements and particles in all bodies."""
    entities = 0
    for i, b in enumerate(bodies):
        entities += _cell_estimate(b) * (4 if b["discretisation"] == "elements" else 1)
        if entities > MAX_ENTITIES:
            counts = {k: b[k] for k in ("n_radial", "n_coarse", "n_axial", "n_nose") if b.get(k)}
            largest = max(counts, key=counts.get)
            raise DeckError(path, f"body #{i + 1}", largest,
                            f"a resolution with at most {MAX_ENTITIES} elements and particles "
                            "in all bodies (each quadrilateral is 4 elements)",
                            " x ".join(f"{k} {v}" for k, v in counts.items()))


def _check_formulation(path, bodies):
    """formulation 'total' only for particle bodies that are joined to no
    other body and that no body joins."""
    joined = {b["joined_to"] for b in bodies if b["joined_to"] is not None}
    for i, b in enumerate(bodies):
        if b["formulation"] != "total":
            continue
        if b["discretisation"] != "particles":
            raise DeckError(path, f"body #{i + 1}", "formulation",
                            "'updated' unless discretisation is 'particles' (total-Lagrangian "
                            "bodies are particles)", b["formulation"])
        if b["joined_to"] is not None or b["name"] in joined:
            raise DeckError(path, f"body #{i + 1}", "formulation",
                            "'updated' for a body joined to another (a total-Lagrangian body "
                            "is a continuum of its own)", b["formulation"])


def _check_joins(path, bodies, mode):
    """joined_to only in modes fixed and adaptive, naming another body."""
    names = [b["name"] for b in bodies]
    for i, b in enumerate(bodies):
        if b["joined_to"] is None:
            continue
        if mode not in ("fixed", "adaptive"):
            raise DeckError(path, f"body #{i + 1}", "joined_to",
                            "no value outside modes 'fixed' and 'adaptive'", b["joined_to"])
        if b["joined_to"] not in names or b["joined_to"] == b["name"]:
            raise DeckError(path, f"body #{i + 1}", "joined_to",
                            "the name of another &body: " + ", ".join(names), b["joined_to"])


def _check_materials(path, deck):
    """Each material valid (its warnings added to the deck's), each body's
    material one of them."""
    for i, m in enumerate(deck["material"]):
        _validate_material(path, f"material #{i + 1}", m)
        deck["warnings"].extend(_material_warnings(f"&material #{i + 1}", m))
        # a G_c the deck sets itself (not one a library entry brings along)
        # that no particle can use
        from_library = LIBRARY.get((m.get("library") or "").strip(), {}).get("fracture_energy")
        if m.get("fracture_energy") not in (None, from_library) and deck["control"]["mode"] == "fem":
            deck["warnings"].append(f"&material #{i + 1} '{m['name']}': fracture_energy acts on "
                                    "particles only; mode 'fem' has none, so it is not used")
    names = [m["name"] for m in deck["material"]]
    for i, b in enumerate(deck["body"]):
        if b["material"] not in names:
            raise DeckError(path, f"body #{i + 1}", "material",
                            "the name of a &material: " + ", ".join(names), b["material"])


def _check_debris(path, met, bodies):
    """kind 'debris': the flyer (body, default the first) and the target
    (default the first other body) are two bodies, the flyer moving
    towards the target along the axis (bodies: the &body groups)."""
    names = [b["name"] for b in bodies]
    flyer = names.index(met["body"]) if met["body"] else 0
    target = names.index(met["target"]) if met["target"] else (1 if flyer == 0 else 0)
    if flyer == target:
        raise DeckError(path, "metrics", "body", "a flyer other than the target "
                        f"'{names[target]}' (kind 'debris')", names[flyer])
    if bodies[flyer]["velocity_z"] == bodies[target]["velocity_z"]:
        raise DeckError(path, "metrics", "body", f"a flyer moving relative to the target "
                        f"'{names[target]}' (kind 'debris': the flight direction is that of "
                        f"its velocity_z)", names[flyer])


def _check_metrics(path, met, deck_bodies):
    """&metrics names existing bodies (the target another than the body)
    and has what its kind needs (deck_bodies: the &body groups)."""
    bodies = [b["name"] for b in deck_bodies]
    if met["target"] is not None and (met["target"] not in bodies
                                      or met["target"] == met["body"]):
        raise DeckError(path, "metrics", "target", "the name of another &body: "
                        + ", ".join(bodies), met["target"])
    if met["kind"] in ("perforation", "debris") and len(bodies) < 2:
        raise DeckError(path, "metrics", "kind", "a deck with a projectile and a target body "
                        f"for kind '{met['kind']}'", met["kind"])
    if met["body"] is not None and met["body"] not in bodies:
        raise DeckError(path, "metrics", "body", "the name of a &body: " + ", ".join(bodies),
                        met["body"])
    if met["kind"] == "debris":
        _check_debris(path, met, deck_bodies)
    if met["kind"] == "bar_wave":
        for k in ("probe_radius", "plateau_from", "plateau_to"):
            if met[k] is None:
                raise DeckError(path, "metrics", k, "a value (needed by kind 'bar_wave')",
                                "missing key")
        if not met["plateau_to"] > met["plateau_from"]:
            raise DeckError(path, "metrics", "plateau_to",
                            f"a value above plateau_from = {met['plateau_from']} m",
                            met["plateau_to"])


def _check_output(path, deck):
    """No checkpoint timing without checkpoints; the reference file exists."""
    out = deck["output"]
    if not out["checkpoint"]:
        for key, off in (("checkpoint_minutes", 0.0), ("checkpoint_cycles", 0)):
            if out[key] != off:
                raise DeckError(path, "output", key, f"{off} (or unset) when checkpoint = "
                                ".false.", out[key])
    ref = deck["output"]["reference"]
    if ref is not None and not (Path(deck["dir"]) / ref).is_file():
        raise DeckError(path, "output", "reference", "an existing JSON file relative to the "
                        "deck's folder", ref)


def _cross_check(path, deck):
    """Checks across keys and groups, in this order: bodies
    (discretisation, geometry, size, joins, formulation), erosion and conversion, rod
    radii, unique names, materials, boundaries, gauges, metrics, output. Fills in
    the bodies' default discretisation and the deck's material warnings."""
    mode = deck["control"]["mode"]
    _check_discretisation(path, deck["body"], mode)
    for i, b in enumerate(deck["body"]):
        _check_geometry(path, f"body #{i + 1}", b)
    _check_size(path, deck["body"])
    _check_joins(path, deck["body"], mode)
    _check_formulation(path, deck["body"])
    if deck["output"]["revolve_segments"] and not deck["output"]["vtu"]:
        raise DeckError(path, "output", "revolve_segments", "0 when vtu = .false. (the revolved "
                        "series is written beside the ParaView series)", deck["output"]["revolve_segments"])
    if deck["erosion"]["enabled"] and mode != "fem":
        raise DeckError(path, "erosion", "enabled", ".false. outside mode 'fem' (erosion is the "
                        "FEM baseline; modes fixed and adaptive turn distorted elements into "
                        "particles instead)", True)
    conv = deck["convert"]
    if conv["criterion"] == "equivalent_stress" and conv["sigma_c"] is None:
        raise DeckError(path, "convert", "sigma_c",
                        "a value (needed by criterion 'equivalent_stress')", "missing key")
    for i, b in enumerate(deck["body"]):
        if b["geometry"] != "rod" and b["inner_radius"] != 0.0:
            raise DeckError(path, f"body #{i + 1}", "inner_radius",
                            f"0 for geometry '{b['geometry']}' (only a rod can be a tube)",
                            b["inner_radius"])
        if b["geometry"] == "rod" and not b["inner_radius"] < b["radius"]:
            raise DeckError(path, f"body #{i + 1}", "inner_radius",
                            f"a value below radius = {b['radius']} m", b["inner_radius"])
    _unique_names(path, "material", deck["material"])
    _unique_names(path, "body", deck["body"])
    _check_materials(path, deck)
    for i, bc in enumerate(deck["boundary"]):
        if bc["normal"][0] == 0.0 and bc["normal"][1] == 0.0:
            raise DeckError(path, f"boundary #{i + 1}", "normal", "a non-zero vector",
                            list(bc["normal"]))
    _unique_names(path, "gauge", deck["gauge"])
    for i, gauge in enumerate(deck["gauge"]):
        if gauge["point"][0] < 0.0:
            raise DeckError(path, f"gauge #{i + 1}", "point", "a point (r, z) with r >= 0 (the "
                            "axis is r = 0)", list(gauge["point"]))
    _check_metrics(path, deck["metrics"], deck["body"])
    _check_output(path, deck)


# --------------------------------------------------------------------------
def reference_markdown():
    """The deck reference (docs/decks.md), generated from SCHEMA."""
    lines = [
        "# Deck reference",
        "",
        "Decks are Fortran namelist files (`&group key = value ... /`), read with f90nml.",
        "Units are SI. Keys are case-insensitive. An unknown group or key, a value of the",
        "wrong type or outside its range stops `fsph run` with a one-line message naming",
        "the file, the group, the key and what was expected (exit code 2).",
        "",
        "This page is generated from `fsph/deck.py` (`python -m fsph decks-reference`);",
        "a test keeps it in step.",
        "",
        "Beyond the ranges below, every value must have a plausible magnitude for its unit",
        "(a garbled number is an error, not an overflow in the solver): at most "
        + ", ".join(f"{v:g} {u}" for u, v in UNIT_LIMITS.items()) + ";",
        "a strictly positive value at least "
        + ", ".join(f"{v:g} {u}" for u, v in UNIT_FLOORS.items()) + ";",
        f"integers at most {MAX_INT}; all bodies together at most {MAX_ENTITIES} elements",
        "and particles (a quadrilateral counts 4 elements).",
        "",
    ]
    for gname, group in SCHEMA.items():
        flags = []
        if group.required:
            flags.append("required")
        if group.repeatable:
            flags.append("repeatable")
        lines += [f"## &{gname}" + (f" ({', '.join(flags)})" if flags else ""), "",
                  group.doc, "",
                  "| key | type | unit | default | meaning |", "|---|---|---|---|---|"]
        for kname, key in group.keys.items():
            if key.default is REQUIRED:
                default = "**required**"
            elif key.default is None:
                default = "unset"
            else:
                default = f"`{key.default!r}`" if key.kind != "str" else f"`'{key.default}'`"
            doc = key.doc
            if key.choices:
                doc += " Values: " + ", ".join(f"`{c}`" for c in key.choices) + "."
            if key.implemented:
                doc += " Available now: " + ", ".join(f"`{c}`" for c in key.implemented) + "."
            if key.kind in ("float", "int") and (key.lower is not None or key.upper is not None):
                doc += f" Range {_range_text(key)}."
            lines.append(f"| `{kname}` | {key.kind} | {key.unit} | {default} | {doc} |")
        lines.append("")
    lines += ["## Material library", "",
              "`library = 'NAME'` in a &material starts from these values:", "",
              "| name | models | source |", "|---|---|---|"]
    for name, entry in LIBRARY.items():
        lines.append(f"| `{name}` | {entry['strength']} + {entry['eos']} | {entry['source']} |")
    lines.append("")
    return "\n".join(lines)
