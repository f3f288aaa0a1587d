"""`Simulation`: set up the Fortran state from a validated deck, advance it,
take snapshots. The Fortran side is reached only through ``fsph._core``."""

import numpy as np

from . import deck as deck_module
from . import mesh as mesh_module
from .errors import DeckError, FsphError, SimulationError
from .materials import PROPERTY_NAMES, property_table
try:
    from ._core import fsph_api as _api
except ImportError as exc:  # importing the source folder instead of the installed package
    raise ImportError(
        "fsph._core (the compiled solver) is not importable from "
        f"{__file__.rsplit('/', 2)[0]}: run `make test`/`make run` (they build and install "
        "fsph into .venv) and use .venv/bin/python from outside the source folder") from exc

# fsph_status codes (src_f90/fsph_status.f90)
STATUS_OK = 0
STATUS_MAX_CYCLES = 8
STATUS_TEXT = {
    1: "inverted element (area <= 0): the mesh has tangled",
    2: "non-finite stress or energy (NaN/Inf) in an element",
    3: "non-finite position or velocity (NaN/Inf) at a node",
    4: "time step collapsed below the floor (dt_floor_ratio x initial step)",
    5: "compression beyond the range of the equation of state",
    6: "invalid set-up input",
    7: "state not initialised",
    8: "cycle limit (max_cycles) reached",
    9: "non-finite state (NaN/Inf) or non-positive density in a particle",
    10: "a particle reached the axis (r <= 0)",
    11: "time step fell by more than the allowed factor in one cycle (dt_drop_ratio)",
    12: "energy error above the limit (energy_error_limit)",
}
# rows of the material history (fsph_material hist_*)
HIST_DAMAGE, HIST_MU_MAX = 0, 1
N_HIST = 2
# index conventions of fsph_solver: > 0 element (node for code 3), < 0 particle
NODE_FAULTS = {3}
# timed phases of the cycle, in the order of src_f90/fsph_timers.f90
PHASES = ("element_forces", "element_update", "neighbours", "sph_sums", "particle_update",
          "particle_contact", "coupling", "contact", "integrate", "conversion", "time_step")


def threads():
    """Number of OpenMP threads the solver uses (honours OMP_NUM_THREADS)."""
    return int(_api.threads())


def _check_layout():
    nprop, _, _ = _api.layout()
    if nprop != len(PROPERTY_NAMES):
        raise FsphError(f"fsph._core expects {nprop} material properties, the Python "
                        f"package packs {len(PROPERTY_NAMES)}: rebuild the package")


class Simulation:
    """One run. Build with `Simulation.from_deck(path)` or `Simulation(deck_dict)`."""

    def __init__(self, deck):
        _check_layout()
        self.deck = deck
        self.control = deck["control"]
        materials = deck["material"]
        self.material_names = [m["name"] for m in materials]
        self.body_names = [b["name"] for b in deck["body"]]
        rho0 = {m["name"]: m["density"] for m in materials}

        # this run's own state in the solver: runs in one process are independent
        self._run = int(_api.open_run())
        c = self.control
        _api.set_control(self._run, c["dt_safety"], c["c_q"], c["c_l"], c["dt_floor_ratio"], c["dt_drop_ratio"],
                         deck["output"]["history_every"])
        sph = deck["sph"]
        touch, slope = contact_filling(sph["alpha_h"])
        _api.set_sph_control(self._run, sph["c_q"], sph["c_l"], sph["hourglass"], sph["contact_penalty"], touch,
                             slope, sph["debris_density"], sph["neighbour_skin"])
        props, strength, eos = property_table(materials)
        self._call(_api.set_materials(self._run, props, strength, eos), "material table")

        elem_bodies, part_bodies = [], []
        for ib, b in enumerate(deck["body"]):
            try:
                geometry = mesh_module.body_discretisation(b)
            except ValueError as err:   # a combination of keys the generator cannot mesh
                raise DeckError(deck.get("path", "deck"), f"body #{ib + 1}", "geometry",
                                f"keys that '{b['geometry']}' can mesh", str(err)) from None
            mat = self.material_names.index(b["material"]) + 1
            (elem_bodies if b["discretisation"] == "elements" else part_bodies).append(
                (ib, b, geometry, mat))

        if elem_bodies:
            self._set_elements(elem_bodies)
        if part_bodies:
            self._set_particles(part_bodies, rho0, sph["alpha_h"])
        self._set_coupling(deck, bool(elem_bodies), bool(part_bodies))
        ct = deck["contact"]
        self._call(_api.set_contact(self._run, int(ct["enabled"]), ct["passes"], ct["friction"],
                                    int(ct["own_particles"])), "contact")
        er = deck["erosion"]
        self._call(_api.set_erosion(self._run, int(er["enabled"]), er["principal_strain"]), "erosion")
        for bc in deck["boundary"]:
            self._call(_api.add_rigid_plane(self._run, np.array(bc["point"]), np.array(bc["normal"])),
                       "rigid plane")
        ierr, ifault = _api.initialise(self._run)
        if ierr != STATUS_OK:
            raise self._failure(ierr, ifault, during="set-up")
        ke, ie = _api.get_energies(self._run)
        self.initial_energy = ke + ie
        self.particle_radius0 = (self._particles()["radius"].copy() if self.n_particles
                                 else np.zeros(0))
        self.n_elements0 = self.n_elements

    def __del__(self):
        # free this run's state in the solver (other runs are untouched)
        run = getattr(self, "_run", None)
        if run is not None and _api is not None:
            _api.close_run(run)
            self._run = None

    def _set_elements(self, bodies):
        xs, conns, mats, body_ids, vels = [], [], [], [], []
        offset = 0
        for ib, b, m, mat in bodies:
            xs.append(m.x)
            conns.append(m.conn + offset)
            vel = np.zeros_like(m.x)
            vel[:, 1] = b["velocity_z"]
            vels.append(vel)
            mats.append(np.full(m.n_elements, mat))
            body_ids.append(np.full(m.n_elements, ib + 1))
            offset += m.n_nodes
        x, conn = np.vstack(xs), np.vstack(conns)
        self._call(_api.set_mesh(self._run, np.asfortranarray(x.T), np.asfortranarray(np.vstack(vels).T),
                                 np.asfortranarray(conn.T + 1, dtype=np.int32),
                                 np.concatenate(mats).astype(np.int32),
                                 np.concatenate(body_ids).astype(np.int32)), "mesh")

    def _set_particles(self, bodies, rho0, alpha_h):
        xs, vels, masses, hs, mats, body_ids = [], [], [], [], [], []
        for ib, b, lat, mat in bodies:
            xs.append(lat.x)
            vel = np.zeros_like(lat.x)
            vel[:, 1] = b["velocity_z"]
            vels.append(vel)
            masses.append(rho0[b["material"]] * lat.ring_volume)
            hs.append(alpha_h * lat.spacing)
            mats.append(np.full(lat.n_particles, mat))
            body_ids.append(np.full(lat.n_particles, ib + 1))
        x = np.vstack(xs)
        self._call(_api.set_particles(self._run, np.asfortranarray(x.T), np.asfortranarray(np.vstack(vels).T),
                                      np.concatenate(masses), np.concatenate(hs),
                                      np.concatenate(mats).astype(np.int32),
                                      np.concatenate(body_ids).astype(np.int32)), "particles")

    def _set_coupling(self, deck, has_elements, has_particles):
        """Continua (bodies joined by joined_to), which element bodies act as
        imaginary particles, and the conversion parameters."""
        bodies = deck["body"]
        names = [b["name"] for b in bodies]
        continuum = list(range(1, len(bodies) + 1))

        def root(k):
            while continuum[k] != k + 1:
                k = continuum[k] - 1
            return k

        for ib, b in enumerate(bodies):
            if b["joined_to"] is not None:
                a, c = root(ib), root(names.index(b["joined_to"]))
                continuum[max(a, c)] = min(a, c) + 1
        continuum = [root(k) + 1 for k in range(len(bodies))]
        mode = self.control["mode"]
        coupled = []
        for ib, b in enumerate(bodies):
            same = [j for j in range(len(bodies)) if continuum[j] == continuum[ib]]
            has_part = any(bodies[j]["discretisation"] == "particles" for j in same)
            coupled.append(int(b["discretisation"] == "elements"
                               and (mode == "adaptive" or (mode == "fixed" and has_part))))
        self._call(_api.set_continua(self._run, np.array(continuum, dtype=np.int32),
                                     np.array(coupled, dtype=np.int32)), "continua")
        conv = deck["convert"]
        criteria = {"min_angle": 1, "plastic_strain": 2, "equivalent_stress": 3}
        _api.set_conversion(self._run, int(mode == "adaptive"), criteria[conv["criterion"]],
                            np.radians(conv["theta_c"]), conv["relative_angle"], conv["eps_c"], conv["sigma_c"] or 0.0,
                            conv["kappa"], deck["sph"]["alpha_h"])
        if has_elements and not has_particles and mode == "adaptive":
            self._call(_api.reserve_particles(self._run), "particle capacity")

    @classmethod
    def from_deck(cls, path):
        return cls(deck_module.load(path))

    # ------------------------------------------------------------------
    @staticmethod
    def _call(ierr, what):
        if ierr != STATUS_OK:
            raise FsphError(f"set-up of the {what} rejected by the solver: "
                            f"{STATUS_TEXT.get(ierr, ierr)}")

    def _failure(self, ierr, ifault, during="run"):
        time, cycle = self.time, self.cycle
        text = STATUS_TEXT.get(int(ierr), f"status {ierr}")
        where, location = "", None
        if ifault < 0:
            part = self._particles()
            k = -ifault - 1
            location = part["x"][k]
            where = (f"; particle {-ifault} of body '{self.body_names[part['body'][k]]}' "
                     f"at r = {location[0] * 1e3:.4g} mm, z = {location[1] * 1e3:.4g} mm")
        elif ifault > 0 and ierr in NODE_FAULTS:
            nn, _ = _api.get_sizes(self._run)
            x, x0, _, _ = _api.get_nodes(self._run, nn)
            location = x0[:, ifault - 1]
            where = (f"; node {ifault} (initially at r = {location[0] * 1e3:.4g} mm, "
                     f"z = {location[1] * 1e3:.4g} mm)")
        elif ifault > 0 and ierr != 6:
            nn, ne = _api.get_sizes(self._run)
            x, _, _, _ = _api.get_nodes(self._run, nn)
            conn, _, body = _api.get_elements(self._run, ne)
            location = x[:, conn[:, ifault - 1] - 1].mean(axis=1)
            where = (f"; element {ifault} of body '{self.body_names[body[ifault - 1] - 1]}' "
                     f"at r = {location[0] * 1e3:.4g} mm, z = {location[1] * 1e3:.4g} mm")
        elif ifault > 0:
            where = f"; index {ifault}"
        msg = f"{during} stopped at t = {time * 1e6:.6g} us, cycle {cycle}: {text}{where}"
        return SimulationError(msg, code=int(ierr), index=int(ifault), time=float(time),
                               cycle=int(cycle), location=location)

    # ------------------------------------------------------------------
    def advance(self, t, max_cycles=None, land=True, partial=False):
        """Advance the state to time t [s]; raises SimulationError on failure.
        land=True shortens the last steps to end exactly on t; land=False
        keeps the stable step and stops at the first cycle end at or after t
        (outputs then do not alter the trajectory). With partial=True at most
        max_cycles cycles are run and reaching that number is not an error
        (the deck's max_cycles still is)."""
        limit = self.control["max_cycles"] - self.cycle
        if max_cycles is None or not partial:
            max_cycles = limit if max_cycles is None else max_cycles
        ierr, ifault = _api.advance(self._run, float(t), int(max(min(max_cycles, limit), 0)), int(bool(land)))
        if ierr == STATUS_MAX_CYCLES and partial and self.cycle < self.control["max_cycles"]:
            return
        if ierr != STATUS_OK:
            raise self._failure(ierr, ifault)

    def phase_times(self):
        """Wall time [s] spent in each phase of the cycle since set-up (or
        the last reset_phase_times), by name (PHASES)."""
        times = _api.get_phase_times(self._run, int(_api.phase_count()))
        return dict(zip(PHASES, (float(t) for t in times)))

    def reset_phase_times(self):
        _api.reset_phase_times(self._run)

    def drain_history(self):
        """Time-history records (k, 8) recorded by the cycle since the last
        call: time [s], cycle, dt [s], kinetic [J], internal [J], work of the
        contact corrections [J], energy removed by erosion [J], kinetic energy
        removed by the rigid planes and the particles' axis wall [J]."""
        n = int(_api.history_count(self._run))
        if n == 0:
            return np.zeros((0, 8))
        return _api.drain_history(self._run, n).T.copy()

    @property
    def list_rebuilds(self):
        """Neighbour-list builds so far (the lists are kept while their
        skin allows: &sph neighbour_skin)."""
        return int(_api.get_list_rebuilds(self._run))

    @property
    def n_nodes(self):
        return int(_api.get_sizes(self._run)[0])

    @property
    def n_elements(self):
        return int(_api.get_sizes(self._run)[1])

    @property
    def n_particles(self):
        return int(_api.get_particle_count(self._run))

    def conversion(self):
        """Elements converted so far, conversion events, kinetic energy of
        the nodes' relative motion turned into heat at conversion [J], and
        coupling-interface edges in use."""
        n_conv, n_events, heat, n_edges = _api.get_conversion_stats(self._run)
        return {"n_converted": int(n_conv), "n_events": int(n_events), "heat_J": float(heat),
                "n_coupling_edges": int(n_edges)}

    def ties(self):
        """Particle ties: tied edge nodes (0-based, -1 free), position along
        the edge, associated edges (n, 2, 2) node pairs (-1 none)."""
        a, b, xi, assoc = _api.get_particle_ties(self._run, self.n_particles)
        return {"tie_a": a - 1, "tie_b": b - 1, "tie_xi": xi.copy(),
                "assoc": assoc.transpose(2, 1, 0) - 1}

    def convert_now(self):
        """Run the conversion check immediately; returns elements converted."""
        return int(_api.convert_now(self._run))

    def set_stress_state(self, deviator, pressure):
        """Uniform stress in every element and particle: deviator (rr, zz,
        rz, tt) and pressure [Pa] (verification)."""
        _api.set_stress_state(self._run, np.asarray(deviator, dtype=float), float(pressure))

    def forces(self, dt=None):
        """Nodal forces (n, 2) [N] (with coupling tractions and ties) and
        particle accelerations (m, 2) [m/s^2] of the current state."""
        f, acc = _api.get_forces(self._run, self.n_nodes, self.n_particles, float(dt or self.dt))
        return f.T.copy(), acc.T.copy()

    def element_groups(self):
        """Conversion group of every element (0-based, -1 none)."""
        return _api.get_element_groups(self._run, self.n_elements) - 1

    @property
    def time(self):
        return float(_api.get_clock(self._run)[0])

    @property
    def cycle(self):
        return int(_api.get_clock(self._run)[4])

    @property
    def dt(self):
        """Stable step of the next cycle [s]."""
        return float(_api.get_clock(self._run)[1])

    def contact(self):
        """Contact books: kinetic energy removed by the corrections so far
        [J], pairs corrected in the last cycle, surface segments and nodes."""
        dissipated, n_active, n_seg, n_snode = _api.get_contact_stats(self._run)
        return {"dissipated_J": float(dissipated), "n_active": int(n_active),
                "n_segments": int(n_seg), "n_surface_nodes": int(n_snode)}

    def erosion(self):
        """Erosion books: elements deleted, their mass [kg] and internal
        energy [J]; mass [kg], kinetic energy [J] and momentum (r, z)
        [kg m/s] of the nodes removed with their last element."""
        n, emass, internal, nmass, kinetic, momentum = _api.get_erosion_stats(self._run)
        return {"n_eroded": int(n), "element_mass_kg": float(emass),
                "internal_J": float(internal), "node_mass_kg": float(nmass),
                "kinetic_J": float(kinetic), "momentum_kg_m_s": [float(v) for v in momentum]}

    def debris_count(self):
        """Particles that are debris after the last cycle: density held at
        &sph debris_density times the reference, no stress."""
        return int(_api.get_debris_count(self._run))

    def principal_strains(self):
        """Largest principal logarithmic strain of every element (the
        erosion measure) [-]."""
        strain, ierr = _api.get_principal_strains(self._run, self.n_elements)
        if ierr != STATUS_OK:
            raise FsphError("principal_strains: no elements")
        return strain.copy()

    def penetration(self):
        """Deepest interpenetration of bodies at the current positions [m]
        and relative to the penetrated segment's length [-]."""
        depth, relative = _api.get_contact_penetration(self._run)
        return {"depth": float(depth), "relative": float(relative)}

    def energies(self):
        """Kinetic, internal, contact-dissipated, plane-dissipated and total
        energy [J] and the relative error of the total against the initial
        energy. Contact corrections and the kinematic condition of rigid
        planes (and of the particles' axis wall) remove kinetic energy as
        perfectly inelastic collisions of what strikes them; both are
        booked, so the total is conserved by the method."""
        ke, ie = _api.get_energies(self._run)
        dissipated = float(_api.get_contact_stats(self._run)[0])
        plane = float(_api.get_plane_dissipation(self._run))
        er = self.erosion()
        eroded = er["internal_J"] + er["kinetic_J"]
        total = ke + ie + dissipated + plane + eroded
        return {"kinetic": float(ke), "internal": float(ie), "contact": dissipated,
                "plane": plane, "eroded": eroded, "total": float(total),
                "relative_error": float((total - self.initial_energy) / self.initial_energy)
                if self.initial_energy else 0.0}

    def _particles(self):
        """Particle arrays (positions etc.), 0-based material and body."""
        np_ = int(_api.get_particle_count(self._run))
        x, x0, v, mass, h, radius, mat, body = _api.get_particles(self._run, np_)
        return {"x": x.T.copy(), "x0": x0.T.copy(), "velocity": v.T.copy(), "mass": mass,
                "h": h, "radius": radius, "material": mat - 1, "body": body - 1}

    def snapshot(self):
        """Current state as plain arrays. Elements: nodes (n, 2), connectivity
        (m, 3) 0-based and element fields; particles (if any) under
        "particles". Stress is the total Cauchy stress (rr, zz, rz, tt)."""
        pen = self.penetration()
        snap = {"time": self.time, "cycle": self.cycle, "contact_penetration": pen["depth"],
                "contact_penetration_relative": pen["relative"],
                "eroded_momentum_z": self.erosion()["momentum_kg_m_s"][1]}
        if self.n_elements:
            nn, ne = _api.get_sizes(self._run)
            x, x0, v, mass = _api.get_nodes(self._run, nn)
            conn, mat, body = _api.get_elements(self._run, ne)
            s, p, q, eps_p, rho, e, temp, c, area, emass = _api.get_element_fields(self._run, ne)
            stress = s.T.copy()
            stress[:, [0, 1, 3]] -= (p + q)[:, None]
            snap.update({
                "x": x.T.copy(), "x0": x0.T.copy(), "velocity": v.T.copy(), "node_mass": mass,
                "conn": conn.T - 1, "material": mat - 1, "body": body - 1,
                "stress": stress, "pressure": p.copy(), "q": q.copy(),
                "plastic_strain": eps_p.copy(), "density": rho.copy(),
                "internal_energy": e.copy(), "temperature": temp.copy(), "sound_speed": c.copy(),
                "area": area.copy(), "element_mass": emass.copy(),
                "damage": self._history("element", ne)[HIST_DAMAGE],
            })
        if self.n_particles:
            part = self._particles()
            s, p, eps_p, rho, e, temp, c = _api.get_particle_fields(self._run, self.n_particles)
            stress = s.T.copy()
            stress[:, [0, 1, 3]] -= p[:, None]
            radius0 = part["radius"].copy()
            radius0[:len(self.particle_radius0)] = self.particle_radius0
            part.update({"stress": stress, "pressure": p.copy(), "plastic_strain": eps_p.copy(),
                         "density": rho.copy(), "internal_energy": e.copy(),
                         "temperature": temp.copy(), "sound_speed": c.copy(),
                         "damage": self._history("particle", self.n_particles)[HIST_DAMAGE],
                         "radius0": radius0})
            snap["particles"] = part
        return snap

    def _history(self, kind, n):
        """Material history rows (N_HIST, n) of elements or particles."""
        hist, ierr = _api.get_material_history(self._run, 1 if kind == "element" else 2, N_HIST, n)
        if ierr != STATUS_OK:
            raise FsphError(f"{kind} history: layout mismatch, rebuild the package")
        return hist.copy()

    def particle_rates(self):
        """SPH rates for the current state (verification): accelerations
        (n, 2), density rate, energy rate, strain rates (n, 4), spin."""
        acc, drho, de, d, spin, ierr = _api.get_particle_rates(self._run, self.n_particles)
        if ierr != STATUS_OK:
            raise FsphError("particle_rates: no particles set up")
        return {"acc": acc.T.copy(), "drho": drho.copy(), "de": de.copy(), "d": d.T.copy(),
                "spin": spin.copy()}

    def neighbours(self):
        """Neighbour lists of the last search: CSR pointer (n+1,) and entries
        (+j neighbour, -j mirror of j across the axis), 1-based as in Fortran;
        a pair of real particles is in both lists. Raises if the search's
        pair bookkeeping is inconsistent."""
        n_entries = int(_api.get_neighbour_count(self._run))
        ptr, lst, consistent = _api.get_neighbours(self._run, self.n_particles, n_entries)
        if not consistent:
            raise FsphError("neighbour lists: a low entry does not point at its pair")
        return ptr.copy(), lst.copy()

    # ---- verification hooks (used by tests) ----------------------------
    def set_velocities(self, v):
        """Overwrite nodal velocities (n, 2) [m/s] (elements)."""
        ierr = _api.set_node_velocities(self._run, np.asfortranarray(np.asarray(v, float).T))
        if ierr != STATUS_OK:
            raise FsphError("set_velocities: wrong number of nodes")

    def set_element_energy(self, e):
        """Overwrite the specific internal energy (m,) [J/kg] of every element."""
        ierr = _api.set_element_energy(self._run, np.asarray(e, float))
        if ierr != STATUS_OK:
            raise FsphError("set_element_energy: wrong number of elements")

    def set_particle_motion(self, x, v):
        """Overwrite particle positions (n, 2) [m] and velocities (n, 2) [m/s]."""
        ierr = _api.set_particle_motion(self._run, np.asfortranarray(np.asarray(x, float).T),
                                        np.asfortranarray(np.asarray(v, float).T))
        if ierr != STATUS_OK:
            raise FsphError("set_particle_motion: wrong number of particles")

    def strain_rates(self):
        """Element strain rates (m, 4) (rr, zz, rz, tt) and spin (m,) for the
        current positions and velocities [1/s]."""
        d, spin, ierr = _api.get_strain_rates(self._run, self.n_elements)
        if ierr != STATUS_OK:
            raise FsphError("strain_rates: state not set up")
        return d.T.copy(), spin.copy()


def kernel(dist, h):
    """Smoothing kernel W [1/m^2] and dW/dr [1/m^3] at distances dist [m]."""
    w, dw, _ = _api.kernel_values(np.asarray(dist, dtype=float), float(h))
    return w, dw


def kernel_gradient_factor(dist, h):
    """(dW/dr)/dist [1/m^4] at distances dist [m], as the pair sums take it
    (grad_i W = factor (x_i - x_j))."""
    return _api.kernel_values(np.asarray(dist, dtype=float), float(h))[2]


def contact_filling(alpha_h):
    """Particle contact between bodies (fsph_particles): the filling
    C = sum_j V_j W(|x - x_j|, h) of a particle by another body whose
    square lattice (spacing 1, h = alpha_h) lies from one spacing away, and
    its rate per spacing of approach there. Returns (c_touch, slope)."""
    xs = np.arange(-12, 13, dtype=float)
    rows = np.arange(0, 8, dtype=float)

    def filling(y):
        xx, yy = np.meshgrid(xs, y + rows)
        w, _ = kernel(np.hypot(xx, yy).ravel(), alpha_h)
        return float(w.sum())

    step = 0.05
    return filling(1.0), (filling(1.0 - step) - filling(1.0 + step)) / (2.0 * step)




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
    hist = np.zeros(N_HIST)
    hist[HIST_DAMAGE] = state.get("damage", 0.0)
    hist[HIST_MU_MAX] = state.get("mu_max", 0.0)
    c, ierr = _api.material_point(props[:, 0], int(strength[0]), int(eos[0]), dt,
                                  np.asarray(d, float), spin, rho_old, rho_new, q,
                                  s, p, eps_p, e, temp, hist)
    return {"s": s, "p": float(p), "eps_p": float(eps_p), "e": float(e),
            "temp": float(temp), "damage": float(hist[HIST_DAMAGE]),
            "mu_max": float(hist[HIST_MU_MAX]), "c": float(c), "ierr": int(ierr)}


def hjc_pressure(material, mu, damage=0.0, mu_max=0.0):
    """HJC pressure of one point of a validated material dict at
    volumetric strain mu with history (damage, mu_max): returns pressure
    [Pa], dp/dmu [Pa], the new mu_max and the growth of the permanent
    volumetric strain."""
    props, _, _ = property_table([material])
    mu_max = np.array(mu_max, dtype=float)
    p, dpdmu, dmu_p, ierr = _api.hjc_point_pressure(props[:, 0], mu, damage, mu_max)
    if ierr != STATUS_OK:
        raise FsphError("hjc_pressure: layout mismatch, rebuild the package")
    return {"p": float(p), "dpdmu": float(dpdmu), "mu_max": float(mu_max), "dmu_p": float(dmu_p)}


def triangle_principal_strain(x, x0):
    """Largest principal logarithmic strain [-] of one triangle from its
    current and initial node positions (3, 2) (r, z) [m] (the erosion
    measure of fsph_erosion)."""
    return float(_api.triangle_principal_strain(np.asfortranarray(np.asarray(x, float).T),
                                                np.asfortranarray(np.asarray(x0, float).T)))
