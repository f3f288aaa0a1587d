"""Layouts shared by the Fortran solver and the Python package, in one place.

Everything the two languages must agree on is listed here once: status
codes and their texts, the timed phases of the cycle, the columns of a
time-history record, the checkpoint's arrays and scalars by name, the
material property table, the material history and the model ids, the
conversion criteria and the rows of a snapshot. Python imports this
module; at build time meson runs it as a script to write
``fsph_layouts.f90`` (modules ``fsph_status`` and ``fsph_layouts``), so the
Fortran constants are generated from the same lists. The digest of the
whole layout is compiled in too: ``Simulation`` refuses a solver built from
another layout (a stale build) instead of misreading its arrays.

This file imports nothing from the package: the build runs it alone.
"""

import hashlib
import json
import sys

# ---- status codes: (name, where the index points, text); the code is the
# position (0: ok). Index kinds: "element" (> 0 element, < 0 particle),
# "node", "none". energy_limit and output are raised by the driver
# (fsph.driver), never by the solver.
STATUS_CODES = (
    ("ok", "none", "ok"),
    ("inverted_element", "element", "inverted element (area <= 0): the mesh has tangled"),
    ("nonfinite_element", "element", "non-finite stress or energy (NaN/Inf) in an element"),
    ("nonfinite_node", "node", "non-finite position or velocity (NaN/Inf) at a node"),
    ("dt_floor", "element", "time step collapsed below the floor (dt_floor_ratio x initial step)"),
    ("eos_range", "element", "compression beyond the range of the equation of state"),
    ("bad_input", "none", "invalid set-up input"),
    ("not_ready", "none", "state not initialised"),
    ("max_cycles", "none", "cycle limit (max_cycles) reached"),
    ("nonfinite_particle", "element", "non-finite state (NaN/Inf) or non-positive density in a particle"),
    ("particle_axis", "element", "a particle reached the axis (r <= 0)"),
    ("dt_drop", "element", "time step fell by more than the allowed factor in one cycle (dt_drop_ratio)"),
    ("energy_limit", "none", "energy error above the limit (energy_error_limit)"),
    ("output", "none", "writing the outputs failed or would not fit (disk full, file size limit)"),
)
STATUS = tuple((code, name, index, text) for code, (name, index, text) in enumerate(STATUS_CODES))

# ---- timed phases of the cycle (fsph_timers, fsph_solver) ------------------
PHASES = (
    ("element_forces", "corner forces and their gather"),
    ("element_update", "strain rates, geometry, stress update"),
    ("neighbours", "imaginary particles, cell list, neighbour lists"),
    ("sph_sums", "accelerations, rates and energy sums"),
    ("particle_update", "particle stress and energy update"),
    ("particle_contact", "particle-particle contact between bodies"),
    ("coupling", "edge reactions, ties, imaginary refill"),
    ("contact", "slide lines and particle-element contact"),
    ("integrate", "kick, boundaries, drift"),
    ("conversion", "erosion, conversion, surfaces and ties"),
    ("time_step", "stable step, history and the energy books"),
)

# ---- a time-history record (fsph_solver record_history) --------------------
# The energy columns, kinetic to total, are also the energy budget
# (fsph_solver energy_budget): the total is summed there and nowhere else.
HISTORY_COLUMNS = (
    ("time", "s", "time"),
    ("cycle", "-", "cycle count"),
    ("dt", "s", "last step"),
    ("plane_impulse_z", "N s", "axial impulse of the rigid planes on the bodies since t = 0 (kinematic condition "
     "and mirror images; the force on a plane is minus its rate)"),
    ("kinetic", "J", "kinetic energy (half-step velocities)"),
    ("internal", "J", "internal energy"),
    ("contact", "J", "kinetic energy removed by the contact corrections"),
    ("eroded", "J", "internal and kinetic energy removed by erosion"),
    ("plane", "J", "kinetic energy removed by the rigid planes and the particles' axis wall"),
    ("total", "J", "kinetic + internal + contact + eroded + plane, centred in time: the internal energy "
     "(with the eroded elements') as the mean of the last step's two ends, at the half step of the rest"),
)
ENERGY_COLUMNS = tuple(name for name, _, _ in HISTORY_COLUMNS[4:])
#: Each body's books at every history record (fsph_solver body_budget).
BODY_COLUMNS = (
    ("kinetic", "J", "kinetic energy of the body's nodes and particles (half-step velocities)"),
    ("internal", "J", "internal energy of the body's elements and particles"),
    ("momentum_z", "N s", "axial momentum of the body's nodes and particles"),
    ("plastic_work", "J", "plastic work done in the body's elements and particles (and in the "
     "elements they were converted from)"),
    ("viscous_work", "J", "heat of the artificial viscosity in the body's elements and particles (and in "
     "the elements they were converted from)"),
    ("hourglass_work", "J", "heat of the particles' hourglass viscosity in the body (T3 elements have no "
     "hourglass mode)"),
    ("contact_work", "J", "energy the body received through contact: the work of the slide lines' "
     "corrections on its nodes and particles and of the particle contact's forces (with the heat it "
     "gives; the 'potential' particle contact is not counted); summed over the bodies, minus the history's "
     "contact column"),
)
#: Each gauge's record at every history record (fsph_gauges gauge_row):
#: the values of the element containing the point or of the nearest
#: particle (docs/method.md, Gauges); every field but r, z and inside is
#: NaN while the point is in no material (inside = 0).
GAUGE_COLUMNS = (
    ("r", "m", "radial position of the gauge (a fixed gauge: its point)"),
    ("z", "m", "axial position of the gauge (a fixed gauge: its point)"),
    ("velocity_r", "m/s", "radial velocity (an element's nodal velocities interpolated at the point)"),
    ("velocity_z", "m/s", "axial velocity (an element's nodal velocities interpolated at the point)"),
    ("pressure", "Pa", "pressure of the equation of state (no artificial viscosity)"),
    ("stress_zz", "Pa", "axial Cauchy stress s_zz - p (elements: - q as well; tension positive), as "
     "the snapshots' stress_zz"),
    ("von_mises", "Pa", "von Mises stress sqrt(3/2 s:s) of the deviator (hoop component included)"),
    ("plastic_strain", "-", "equivalent plastic strain"),
    ("temperature", "K", "temperature"),
    ("density", "kg/m^3", "density"),
    ("internal_energy", "J/kg", "specific internal energy"),
    ("damage", "-", "damage D of the material history (0 where the model has none)"),
    ("inside", "-", "1 while the point lies in material, 0 otherwise"),
)
#: Kinds of gauge (&gauge kind): the Fortran ids gauge_kind_*.
GAUGE_KINDS = (
    ("material", "follows the material point that is there at t = 0"),
    ("fixed", "a point fixed in space, sampling whatever material is there"),
)
#: What a gauge samples (fsph_gauges): nothing, an element or a particle (0-based ids gauge_on_*).
GAUGE_SOURCES = ("nothing", "element", "particle")

# ---- checkpoint: state arrays by name (fsph_restart) ----------------------
# Each is a (rows, cols) view of one state array; the order is the order
# of the state digest (fsph.checkpoint.state_digest).
CHECKPOINT_REAL = (
    "nodes/x", "nodes/x0", "nodes/v", "nodes/mass", "nodes/mass_tie",
    "elements/mass", "elements/rho", "elements/s", "elements/p", "elements/q",
    "elements/eps_p", "elements/e", "elements/temp", "elements/c", "elements/area",
    "elements/rbar", "elements/volume", "elements/lmin", "elements/d", "elements/spin",
    "particles/x", "particles/x0", "particles/v", "particles/mass", "particles/h",
    "particles/radius", "particles/rho", "particles/s", "particles/p", "particles/eps_p",
    "particles/e", "particles/temp", "particles/c", "particles/tie_xi",
    "nodes/mass_eroded", "elements/hist", "particles/hist", "particles/d", "particles/grad_v",
)
CHECKPOINT_INT = (
    "elements/conn", "elements/mat", "elements/body", "elements/group", "nodes/on_axis",
    "particles/mat", "particles/body", "particles/continuum", "particles/tie_a",
    "particles/tie_b", "particles/assoc", "coupling/edge", "elements/id", "particles/id",
)
# the clock and the books
CHECKPOINT_REAL_SCALARS = (
    "time", "dt", "dt_last", "dt_initial", "conversion_heat", "contact_dissipated",
    "eroded_element_mass", "eroded_internal", "eroded_node_mass", "eroded_kinetic",
    "eroded_momentum_r", "eroded_momentum_z", "plane_dissipated", "plane_impulse_z",
    "energy_full_before",
)
CHECKPOINT_INT_SCALARS = (
    "cycle", "dt_element", "dt_particle", "n_converted", "n_events", "n_groups", "n_edges",
    "n_imag", "n_eroded", "energy_full_cycle",
)

# ---- material property table props(n_props) (fsph_material) --------------
# (name, unit, meaning); Holmquist-Johnson-Cook concrete after Holmquist,
# Johnson & Cook 1993 (14th Int. Symp. Ballistics 591-600), strengths
# normalised by f_c.
PROPERTIES = (
    ("rho0", "kg/m^3", "reference density"),
    ("shear", "Pa", "shear modulus G"),
    ("bulk", "Pa", "bulk modulus K, linear EOS"),
    ("yield", "Pa", "initial yield stress Y0"),
    ("hard", "Pa", "plastic modulus H = E E_T/(E - E_T)"),
    ("jc_a", "Pa", "Johnson-Cook A"),
    ("jc_b", "Pa", "Johnson-Cook B"),
    ("jc_n", "-", "Johnson-Cook n"),
    ("jc_c", "-", "Johnson-Cook C"),
    ("jc_m", "-", "Johnson-Cook m"),
    ("t_melt", "K", "melting temperature"),
    ("t_room", "K", "room (initial) temperature"),
    ("cv", "J/(kg K)", "specific heat"),
    ("chi", "-", "Taylor-Quinney coefficient"),
    ("eps0", "1/s", "Johnson-Cook reference strain rate"),
    ("c0", "m/s", "Mie-Grueneisen bulk sound speed c0"),
    ("s", "-", "Mie-Grueneisen Us-up slope s"),
    ("gamma0", "-", "Grueneisen coefficient Gamma0"),
    ("pmin", "Pa", "pressure cut-off p_min (<= 0)"),
    ("hjc_a", "-", "HJC normalised cohesive strength A"),
    ("hjc_b", "-", "HJC normalised pressure hardening B"),
    ("hjc_n", "-", "HJC pressure hardening exponent N"),
    ("hjc_c", "-", "HJC strain-rate coefficient C"),
    ("hjc_fc", "Pa", "HJC quasi-static compressive strength f_c"),
    ("hjc_t", "Pa", "HJC maximum tensile hydrostatic pressure T"),
    ("hjc_smax", "-", "HJC normalised maximum strength S_max"),
    ("hjc_efmin", "-", "HJC smallest plastic strain to fracture EF_min"),
    ("hjc_d1", "-", "HJC damage constant D1"),
    ("hjc_d2", "-", "HJC damage exponent D2"),
    ("hjc_pcrush", "Pa", "HJC crushing pressure P_crush"),
    ("hjc_mucrush", "-", "HJC volumetric strain at P_crush"),
    ("hjc_plock", "Pa", "HJC locking pressure P_lock"),
    ("hjc_mulock", "-", "HJC locking strain mu_lock = rho_grain/rho0 - 1"),
    ("hjc_k1", "Pa", "HJC fully dense EOS K1"),
    ("hjc_k2", "Pa", "HJC fully dense EOS K2"),
    ("hjc_k3", "Pa", "HJC fully dense EOS K3"),
    ("hjc_muplock", "-", "HJC strain where the fully dense curve reaches P_lock"),
    # temperature and melting (fsph_material state_temperature, melting_temperature)
    ("temp_model", "-", "temperature model id (TEMPERATURE_MODELS)"),
    ("melt_model", "-", "melting-temperature model id (MELT_MODELS)"),
    ("melt_a", "-", "Lindemann exponent a of the Steinberg-Guinan melting law"),
    # J2 power-law viscoplasticity (Liao et al. 2022 eq 13)
    ("pl_sigma0", "Pa", "power law: quasi-static yield stress sigma0"),
    ("pl_eps0", "-", "power law: reference plastic strain eps_p0"),
    ("pl_rate0", "1/s", "power law: reference plastic strain rate"),
    ("pl_n", "-", "power law: hardening exponent n"),
    ("pl_m", "-", "power law: rate exponent m"),
    ("pl_l", "-", "power law: thermal softening exponent l"),
    ("pl_rate_form", "-", "power law: rate term id (RATE_FORMS)"),
    # Steinberg-Guinan (Steinberg, Cochran & Guinan 1980); G0 is shear
    ("sg_y0", "Pa", "Steinberg-Guinan yield stress Y0"),
    ("sg_ymax", "Pa", "Steinberg-Guinan largest work-hardened yield stress Ymax"),
    ("sg_beta", "-", "Steinberg-Guinan hardening constant beta"),
    ("sg_n", "-", "Steinberg-Guinan hardening exponent n"),
    ("sg_eps_i", "-", "Steinberg-Guinan initial plastic strain eps_i"),
    ("sg_a", "1/Pa", "Steinberg-Guinan G'_p/G0 (A)"),
    ("sg_b", "1/K", "Steinberg-Guinan G'_T/G0 (B)"),
    # Johnson-Cook failure (Johnson & Cook 1985)
    ("jcf_on", "-", "Johnson-Cook failure: 1 on, 0 off"),
    ("spall_fail", "-", "spall failure: 1 a point whose pressure reaches p_min fails, 0 off"),
    ("jc_d1", "-", "Johnson-Cook failure D1"),
    ("jc_d2", "-", "Johnson-Cook failure D2"),
    ("jc_d3", "-", "Johnson-Cook failure D3"),
    ("jc_d4", "-", "Johnson-Cook failure D4"),
    ("jc_d5", "-", "Johnson-Cook failure D5"),
    ("jc_efmin", "-", "Johnson-Cook failure: smallest strain to fracture"),
    # failure by energy release rate (fsph_eigenerosion)
    ("fracture_energy", "J/m^2", "eigenerosion: critical energy release rate G_c (0: off)"),
    # the reference isentrope e_s(mu) of a Mie-Grueneisen material
    # (fsph.materials.isentrope_table): tension nodes uniform in mu from
    # ise_mu_lo to 0; compression nodes uniform in
    # u = -ln(1 - (s-1) mu) + ise_beta (s-1) mu from 0 to ise_u_top
    ("ise_mu_lo", "-", "isentrope table: volumetric strain of its tension end"),
    ("ise_beta", "-", "isentrope table: linear weight beta of the compression coordinate u"),
    ("ise_u_top", "-", "isentrope table: compression coordinate u of its last node"),
)
#: Intervals of the two parts of the isentrope table (tension, compression).
ISENTROPE_TABLE = (("tension_intervals", 16), ("compression_intervals", 64))
_N_TENSION = ISENTROPE_TABLE[0][1] + 1
_N_COMPRESSION = ISENTROPE_TABLE[1][1] + 1
PROPERTIES = PROPERTIES + tuple(
    (f"ise_{part}{k:02d}", unit, f"isentrope table: {what} at node {k}")
    for part, n, unit, what in (
        ("tw", _N_TENSION, "J/kg", "tension e_s"),
        ("tdw", _N_TENSION, "J/kg", "tension de_s/dmu"),
        ("cw", _N_COMPRESSION, "J/kg", "compression e_s (1 - (s-1) mu)"),
        ("cdw", _N_COMPRESSION, "J/kg", "compression d(e_s (1 - (s-1) mu))/du"))
    for k in range(n))
PROPERTY_NAMES = tuple(name for name, _, _ in PROPERTIES)
# history variables of a material point hist(n_hist)
MATERIAL_HISTORY = (
    ("damage", "-", "damage D in [0, 1] (HJC, Johnson-Cook failure)"),
    ("mu_max", "-", "largest volumetric strain reached (HJC)"),
    ("failed", "-", "1 once the point has failed (no deviator, no tension), else 0"),
    ("melted", "-", "1 while the point is at or above its melting temperature, else 0"),
    ("plastic_work", "J/kg", "plastic work per unit mass: the sum of flow stress x plastic strain "
     "increment / density over the steps"),
    ("viscous_work", "J/kg", "heat of the artificial viscosity per unit mass (elements: -q dv; particles: "
     "their share of the pairs' viscous work)"),
    ("hourglass_work", "J/kg", "heat of the hourglass viscosity per unit mass (particles: their share of "
     "the pairs' hourglass work, of either sign; 0 in elements)"),
    ("contact_work", "J/kg", "energy received through contact per unit mass: the work of the slide-line "
     "corrections on the point (an element: its share of its nodes') and of the particle contact's forces "
     "with the heat it gives"),
    ("contact_allowance", "m", "particles: the overlap of the particle's contact thickness with another body's "
     "surface that it was made with, kept while it lasts (fsph_contact; -1 until first measured; 0 in "
     "elements)"),
    ("contact_corrected", "-", "particles: 1 when the contact corrected the particle's velocity in the last "
     "cycle (its pairs then carry no hourglass force in the next; fsph_sph), else 0; 0 in elements"),
)
STRENGTH_MODELS = (
    ("elastic", "elastic"),
    ("epp", "elastic-perfectly-plastic"),
    ("bilinear", "linear isotropic hardening"),
    ("johnson_cook", "Johnson-Cook"),
    ("hjc", "Holmquist-Johnson-Cook (with eos hjc)"),
    ("power_law", "J2 power-law viscoplasticity (Liao et al. 2022 eq 13)"),
    ("steinberg_guinan", "Steinberg-Guinan (Steinberg, Cochran & Guinan 1980)"),
)
EOS_MODELS = (
    ("linear", "linear in the volumetric strain"),
    ("mie_gruneisen", "Mie-Grueneisen"),
    ("hjc", "HJC three-phase p(mu) with unloading"),
)
TEMPERATURE_MODELS = (
    ("plastic_work", "adiabatic heating by plastic work, dT = chi dW_p/(rho c)"),
    ("internal_energy", "T from density and internal energy about the reference isentrope"),
)
MELT_MODELS = (
    ("constant", "constant melting temperature"),
    ("lindemann", "Lindemann law in the Steinberg-Guinan form"),
)
RATE_FORMS = (
    ("printed", "1 + (rate/rate0)^m, Liao et al. 2022 eq 13 as printed"),
    ("power", "(1 + rate/rate0)^m"),
)
#: Real constants both languages use: (name, value, unit, meaning).
REAL_CONSTANTS = (
    ("mg_denominator_floor", 1.0e-3, "-",
     "smallest Mie-Grueneisen denominator 1 - (s-1) mu before the state is out of range"),
)
# element-to-particle conversion criteria (fsph_convert)
CONVERSION_CRITERIA = (
    ("min_angle", "smallest interior angle"),
    ("plastic_strain", "equivalent plastic strain"),
    ("equivalent_stress", "equivalent stress"),
)

# contact between particles of different bodies (fsph_particles)
PARTICLE_CONTACTS = (
    ("riemann", "pairwise Riemann pressures, p* >= 0"),
    ("potential", "potential of the kernel filling by the other bodies"),
)

# ---- rows of a snapshot (fsph_api get_snapshot) ---------------------------
NODE_FIELDS = ("x_r", "x_z", "x0_r", "x0_z", "v_r", "v_z", "mass")
# the material state elements and particles share, in both in this order
MATERIAL_STATE_FIELDS = ("s_rr", "s_zz", "s_rz", "s_tt", "p", "eps_p", "rho", "e", "temp", "c",
                         "damage", "failed", "melted")
ELEMENT_FIELDS = MATERIAL_STATE_FIELDS + ("q", "area", "mass")
PARTICLE_FIELDS = ("x_r", "x_z", "x0_r", "x0_z", "v_r", "v_z", "mass", "h", "radius") + MATERIAL_STATE_FIELDS
# material and body of an element or particle
ID_FIELDS = ("material", "body", "id")
SNAPSHOT_SCALARS = ("time", "cycle", "contact_penetration", "contact_penetration_relative",
                    "eroded_momentum_z")


def status_text(code):
    """Text of a status code ('status N' for an unknown one)."""
    for c, _, _, text in STATUS:
        if c == code:
            return text
    return f"status {code}"


def status_code(name):
    """Code of the status called `name`."""
    return next(c for c, n, _, _ in STATUS if n == name)


def index_of(names, name):
    """1-based position of `name` in a layout (the Fortran id)."""
    return names.index(name) + 1


def _everything():
    return {key: value for key, value in globals().items()
            if key.isupper() and isinstance(value, tuple)}


def digest():
    """32-bit digest of every layout above (compiled into the solver)."""
    text = json.dumps(_everything(), sort_keys=True)
    return int(hashlib.sha256(text.encode()).hexdigest()[:7], 16)


# ---- Fortran source -------------------------------------------------------
def _constants(prefix, names, docs=None, first=1, count=None):
    """`integer, parameter, public :: prefix_name = k` lines."""
    width = max(len(prefix + n) for n in names)
    lines = []
    for k, name in enumerate(names, first):
        line = f"  integer, parameter, public :: {(prefix + name).ljust(width)} = {k}"
        if docs:
            line += f"  !< {docs[k - first]}"
        lines.append(line)
    if count:
        lines.append(f"  integer, parameter, public :: {count} = {len(names)}")
    return lines


def _particle_arrays(names):
    """1-based ids of the particles' arrays among checkpoint `names`."""
    return [k for k, n in enumerate(names, 1) if n.startswith("particles/")]


def _ident(name):
    return name.replace("/", "_")


_GENERATED = "!> GENERATED at build time from fsph/layouts.py: edit that file, not this one."


def fortran_status_source():
    """The text of fsph_status.f90 (one module a file: build tools track
    a Fortran file by the module it provides)."""
    out = [_GENERATED,
           "!> Status codes returned by kernels and by the API. Nothing in the library",
           "!> stops the process: every failure travels back as one of these codes plus",
           "!> the index of the element (> 0), particle (< 0) or node at fault.",
           "module fsph_status", "  implicit none", "  private"]
    for code, name, index, text in STATUS:
        out.append(f"  !> {text} (index: {index})")
        out.append(f"  integer, parameter, public :: status_{name} = {code}")
    out.append("end module fsph_status")
    return "\n".join(out) + "\n"


def fortran_source():
    """The text of fsph_layouts.f90."""
    out = [_GENERATED,
           "!> Layouts shared with Python (fsph/layouts.py): phases, history columns,",
           "!> checkpoint arrays and scalars, material properties, history and",
           "!> model ids, conversion criteria, snapshot rows.",
           "module fsph_layouts", "  use, intrinsic :: iso_fortran_env, only: real64",
           "  implicit none", "  private",
           f"  !> digest of the layouts (fsph.layouts.digest), checked by Python at set-up",
           f"  integer, parameter, public :: layout_digest = {digest()}",
           "  ! timed phases of the cycle"]
    out += _constants("phase_", [n for n, _ in PHASES], [d for _, d in PHASES], count="n_phases")
    out.append("  ! columns of a time-history record; energy_first..history_columns: the budget")
    out += _constants("hcol_", [n for n, _, _ in HISTORY_COLUMNS],
                      [f"{d} [{u}]" for _, u, d in HISTORY_COLUMNS], count="history_columns")
    out.append(f"  integer, parameter, public :: energy_first = {len(HISTORY_COLUMNS) - len(ENERGY_COLUMNS) + 1}")
    out.append("  ! columns of a body's books at a history record")
    out += _constants("bcol_", [n for n, _, _ in BODY_COLUMNS],
                      [f"{d} [{u}]" for _, u, d in BODY_COLUMNS], count="body_columns")
    out.append("  ! columns of a gauge's record, kinds of gauge, what a gauge samples")
    out += _constants("gcol_", [n for n, _, _ in GAUGE_COLUMNS],
                      [f"{d} [{u}]" for _, u, d in GAUGE_COLUMNS], count="gauge_columns")
    out += _constants("gauge_kind_", [n for n, _ in GAUGE_KINDS], [d for _, d in GAUGE_KINDS])
    out += _constants("gauge_on_", GAUGE_SOURCES, first=0)
    out.append("  ! checkpoint: real and integer state arrays, real and integer scalars")
    out += _constants("ckr_", [_ident(n) for n in CHECKPOINT_REAL], count="n_real_arrays")
    out += _constants("cki_", [_ident(n) for n in CHECKPOINT_INT], count="n_int_arrays")
    out.append("  ! the particles' arrays among them (each column one particle)")
    out += [f"  integer, parameter, public :: {name}(*) = [{', '.join(str(k) for k in ids)}]"
            for name, ids in (("ckr_of_particles", _particle_arrays(CHECKPOINT_REAL)),
                              ("cki_of_particles", _particle_arrays(CHECKPOINT_INT)))]
    out += _constants("csr_", CHECKPOINT_REAL_SCALARS, count="n_real_scalars")
    out += _constants("csi_", CHECKPOINT_INT_SCALARS, count="n_int_scalars")
    out.append("  ! material property table props(n_props)")
    out += _constants("prop_", PROPERTY_NAMES, [f"{d} [{u}]" for _, u, d in PROPERTIES], count="n_props")
    out.append("  ! history variables of a material point hist(n_hist)")
    out += _constants("hist_", [n for n, _, _ in MATERIAL_HISTORY],
                      [f"{d} [{u}]" for _, u, d in MATERIAL_HISTORY], count="n_hist")
    out.append("  ! strength, EOS, temperature, melting and rate-form model ids, conversion criteria,")
    out.append("  ! particle contacts")
    out += _constants("strength_", [n for n, _ in STRENGTH_MODELS], [d for _, d in STRENGTH_MODELS],
                      count="n_strength_models")
    out += _constants("eos_", [n for n, _ in EOS_MODELS], [d for _, d in EOS_MODELS],
                      count="n_eos_models")
    out += _constants("temperature_", [n for n, _ in TEMPERATURE_MODELS],
                      [d for _, d in TEMPERATURE_MODELS])
    out += _constants("melt_", [n for n, _ in MELT_MODELS], [d for _, d in MELT_MODELS])
    out += _constants("rate_", [n for n, _ in RATE_FORMS], [d for _, d in RATE_FORMS])
    out.append("  ! intervals of the isentrope table")
    out += [f"  integer, parameter, public :: ise_{name} = {n}" for name, n in ISENTROPE_TABLE]
    out.append("  ! real constants")
    out += [f"  real(real64), parameter, public :: {name} = {value!r}_real64  !< {doc} [{unit}]"
            for name, value, unit, doc in REAL_CONSTANTS]
    out += _constants("criterion_", [n for n, _ in CONVERSION_CRITERIA],
                      [d for _, d in CONVERSION_CRITERIA])
    out += _constants("particle_contact_", [n for n, _ in PARTICLE_CONTACTS],
                      [d for _, d in PARTICLE_CONTACTS])
    out.append("  ! rows of a snapshot")
    out += _constants("nf_", NODE_FIELDS, count="n_node_fields")
    out += _constants("ms_", MATERIAL_STATE_FIELDS, count="n_material_state_fields")
    out += _constants("ef_", ELEMENT_FIELDS, count="n_element_fields")
    out += _constants("pf_", PARTICLE_FIELDS, count="n_particle_fields")
    out += _constants("id_", ID_FIELDS, count="n_id_fields")
    out += _constants("ss_", SNAPSHOT_SCALARS, count="n_snapshot_scalars")
    out.append("end module fsph_layouts")
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    # python layouts.py fsph_status.f90 fsph_layouts.f90 (meson, at build time)
    for target, text in zip(sys.argv[1:3], (fortran_status_source(), fortran_source())):
        with open(target, "w", encoding="utf-8") as f:
            f.write(text)
