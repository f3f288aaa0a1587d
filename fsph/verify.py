"""Verification entry points, used by the tests only (the driver never
calls them): set states no deck can reach, run one kernel on given input,
or expose intermediate products of the cycle. They reach the solver
through ``fsph._core.fsph_verify``; each takes the `Simulation` it acts on
first. Indices are 0-based (-1: none) as everywhere in Python."""

import numpy as np

from . import layouts
from .errors import FsphError
from .checkpoint import set_state_array, state_array
from .materials import property_table
from .simulation import STATUS_OK, _api, python_index

from ._core import fsph_verify as _verify

_HISTORY = {name: k for k, (name, _, _) in enumerate(layouts.MATERIAL_HISTORY)}


def _check(ierr, what):
    if ierr != STATUS_OK:
        raise FsphError(f"{what}: {layouts.status_text(int(ierr))}")


# ---- states no deck can reach ---------------------------------------------
def set_velocities(sim, v):
    """Overwrite nodal velocities (n, 2) [m/s] (elements)."""
    set_state_array(sim, "nodes/v", np.asarray(v, float).T)


def set_element_energy(sim, e):
    """Overwrite the specific internal energy (m,) [J/kg] of every element."""
    set_state_array(sim, "elements/e", np.asarray(e, float)[None, :])


def set_particle_motion(sim, x, v):
    """Overwrite particle positions (n, 2) [m] and velocities (n, 2) [m/s]."""
    set_state_array(sim, "particles/x", np.asarray(x, float).T)
    set_state_array(sim, "particles/v", np.asarray(v, float).T)


def set_stress_state(sim, deviator, pressure):
    """Uniform stress in every element and particle: deviator (rr, zz, rz,
    tt) and pressure [Pa]."""
    _verify.set_stress_state(sim._run, np.asarray(deviator, dtype=float), float(pressure))


def set_neighbour_width(sim, width):
    """Row width of the neighbour search's buffers (the lists must not
    depend on it)."""
    _verify.set_neighbour_width(sim._run, int(width))


def convert_now(sim):
    """Run the conversion check immediately; returns elements converted."""
    return int(_verify.convert_now(sim._run))


def spatial_order(x, h):
    """The order in which particles at x (n, 2) (r, z) [m] with smoothing
    lengths h (n) [m] are renumbered (fsph_spatial spatial_order): order[k]
    is the particle (0-based) that takes place k."""
    x = np.asfortranarray(np.asarray(x, dtype=float).T)
    return np.asarray(_verify.spatial_order_of(x, np.asarray(h, dtype=float))) - 1


def renumber_due(n_before, n_after, n_min):
    """Whether a conversion that took the particles from n_before to
    n_after renumbers them under &sph spatial_order_min = n_min."""
    return bool(_verify.renumber_due_at(int(n_before), int(n_after), int(n_min)))


# ---- intermediate products of the cycle -----------------------------------
def strain_rates(sim):
    """Element strain rates (m, 4) (rr, zz, rz, tt) and spin (m,) for the
    current positions and velocities [1/s]."""
    d, spin, ierr = _verify.get_strain_rates(sim._run, sim.n_elements)
    _check(ierr, "strain_rates: state not set up")
    return d.T.copy(), spin.copy()


def principal_strains(sim):
    """Largest principal logarithmic strain of every element (the erosion
    measure) [-]."""
    strain, ierr = _verify.get_principal_strains(sim._run, sim.n_elements)
    _check(ierr, "principal_strains: no elements")
    return strain.copy()


def forces(sim, dt=None):
    """Nodal forces (n, 2) [N] (with coupling tractions and ties) and
    particle accelerations (m, 2) [m/s^2] of the current state."""
    f, acc = _verify.get_forces(sim._run, sim.n_nodes, sim.n_particles, float(dt or sim.dt))
    return f.T.copy(), acc.T.copy()


def particle_rates(sim):
    """SPH rates for the current state: accelerations (n, 2), density
    rate, energy rate, strain rates (n, 4), spin."""
    acc, drho, de, d, spin, ierr = _verify.get_particle_rates(sim._run, sim.n_particles)
    _check(ierr, "particle_rates: no particles set up")
    return {"acc": acc.T.copy(), "drho": drho.copy(), "de": de.copy(), "d": d.T.copy(),
            "spin": spin.copy()}


def neighbours(sim):
    """Neighbour lists of the last search: CSR pointer (n+1,) and entries
    (+j neighbour, -j mirror of j across the axis), 1-based as the solver
    stores them (the sign carries the meaning); a pair of real particles
    is in both lists. Raises if the search's pair bookkeeping is
    inconsistent."""
    n_entries = int(_verify.get_neighbour_count(sim._run))
    ptr, lst, consistent = _verify.get_neighbours(sim._run, sim.n_particles, n_entries)
    if not consistent:
        raise FsphError("neighbour lists: a low entry does not point at its pair")
    return ptr.copy(), lst.copy()


def element_groups(sim):
    """Conversion group of every element (0-based, -1 none)."""
    group = state_array(sim, "elements/group")
    return python_index(group[0]) if group is not None else np.zeros(0, dtype=int)


def ties(sim):
    """Particle ties: tied edge nodes (0-based, -1 free), position along
    the edge, associated edges (n, 2, 2) node pairs (-1 none)."""
    a, b, xi, assoc = _verify.get_particle_ties(sim._run, sim.n_particles)
    return {"tie_a": python_index(a), "tie_b": python_index(b), "tie_xi": xi.copy(),
            "assoc": python_index(assoc.transpose(2, 1, 0))}


# ---- one kernel on given input --------------------------------------------
def kernel_gradient_factor(dist, h):
    """(dW/dr)/dist [1/m^4] at distances dist [m], as the pair sums take it
    (grad_i W = factor (x_i - x_j))."""
    return _api.kernel_values(np.asarray(dist, dtype=float), float(h))[2]


def contact_pair(delta, dt, m_s, m_1, m_2, r_1, r_2):
    """Normal velocity changes [m/s] of the slave and the two master nodes
    of one contact pair (Hu et al. 2013 eqs 1-3)."""
    return _verify.contact_pair_values(delta, dt, m_s, m_1, m_2, r_1, r_2)


def riemann_pair(normal, v_i, rho_i, c_i, sig_i, v_j, rho_j, c_j, sig_j, sign=1.0):
    """The acoustic Riemann problem of one particle contact pair across the
    unit normal (from i to j): velocities (2,) [m/s], densities [kg/m^3],
    sound speeds [m/s], stresses (rr, zz, rz, tt) [Pa], j seen with
    `sign` (-1: a mirror image across the axis). Returns (p_eq, p_star
    [Pa], u_star [m/s])."""
    normal, v_i, sig_i, v_j, sig_j = (np.asarray(a, dtype=float) for a in (normal, v_i, sig_i, v_j, sig_j))
    return tuple(float(x) for x in _verify.riemann_pair_values(
        normal, v_i, float(rho_i), float(c_i), sig_i, v_j, float(rho_j), float(c_j), sig_j, float(sign)))


def material_point_update(material, dt, d, spin, rho_old, rho_new, q, state):
    """One constitutive step of a single point of a validated material dict.
    `state` holds s (4,), p, eps_p, e, temp and optionally damage and mu_max
    (history, 0 if absent); returns the new state and c."""
    props, strength, eos = property_table([material])
    s = np.array(state["s"], dtype=float)
    p = np.array(state["p"], dtype=float)
    eps_p = np.array(state["eps_p"], dtype=float)
    e = np.array(state["e"], dtype=float)
    temp = np.array(state["temp"], dtype=float)
    hist = np.zeros(len(_HISTORY))
    for name, k in _HISTORY.items():
        hist[k] = state.get(name, 0.0)
    c, ierr = _verify.material_point(props[:, 0], int(strength[0]), int(eos[0]), dt,
                                     np.asarray(d, float), spin, rho_old, rho_new, q,
                                     s, p, eps_p, e, temp, hist)
    out = {"s": s, "p": float(p), "eps_p": float(eps_p), "e": float(e),
           "temp": float(temp), "c": float(c), "ierr": int(ierr)}
    out.update({name: float(hist[k]) for name, k in _HISTORY.items()})
    return out


def material_point_functions(material, rho, e=0.0, p=0.0, temp=None, eps_p=0.0, rate_p=0.0,
                             rate_eq=0.0, **history):
    """The pure point functions of fsph_material for one state of a
    validated material dict: density rho [kg/m^3], specific internal
    energy e [J/kg], pressure p [Pa], temperature [K] (default: room),
    plastic strain, plastic strain rate rate_p and total equivalent strain
    rate rate_eq [1/s], history by name (damage, failed, ...). Returns the
    melting temperature 't_melt' [K], shear modulus 'g' [Pa], flow stress
    'sy' [Pa], temperature of the state 'temp' [K], isentrope energy 'e_s'
    at rho [J/kg] and the pressure the point carries 'p_cut' [Pa]."""
    props, strength, eos = property_table([material])
    hist = np.zeros(len(_HISTORY))
    for name, value in history.items():
        hist[_HISTORY[name]] = value
    temp = material["room_temperature"] if temp is None else temp
    t_melt, g, sy, t_state, e_s, p_cut, ierr = _verify.material_point_functions(
        props[:, 0], int(strength[0]), int(eos[0]), rho, e, p, temp, eps_p, rate_p, rate_eq, hist)
    _check(ierr, "material_point_functions: layout mismatch, rebuild the package")
    return {"t_melt": float(t_melt), "g": float(g), "sy": float(sy), "temp": float(t_state),
            "e_s": float(e_s), "p_cut": float(p_cut)}


def hjc_pressure(material, mu, damage=0.0, mu_max=0.0):
    """HJC pressure of one point of a validated material dict at
    volumetric strain mu with history (damage, mu_max): returns pressure
    [Pa], dp/dmu [Pa], the new mu_max and the growth of the permanent
    volumetric strain."""
    props, _, _ = property_table([material])
    mu_max = np.array(mu_max, dtype=float)
    p, dpdmu, dmu_p, ierr = _verify.hjc_point_pressure(props[:, 0], mu, damage, mu_max)
    _check(ierr, "hjc_pressure: layout mismatch, rebuild the package")
    return {"p": float(p), "dpdmu": float(dpdmu), "mu_max": float(mu_max), "dmu_p": float(dmu_p)}


def triangle_principal_strain(x, x0):
    """Largest principal logarithmic strain [-] of one triangle from its
    current and initial node positions (3, 2) (r, z) [m] (the erosion
    measure of fsph_erosion)."""
    return float(_verify.triangle_principal_strain(np.asfortranarray(np.asarray(x, float).T),
                                                   np.asfortranarray(np.asarray(x0, float).T)))
