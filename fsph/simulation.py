"""`Simulation`: set up the Fortran state from a validated deck, advance it,
take snapshots. The Fortran side is reached only through ``fsph._core``."""

import math
import numbers
import os

import numpy as np

from . import deck as deck_module
from . import layouts
from . import mesh as mesh_module
from .errors import DeckError, FsphError, InputError, SimulationError
from .materials import property_table
from .startup import check_starting_state
try:
    from ._core import fsph_api as _api
except ImportError as exc:  # importing the source folder instead of the installed package
    raise ImportError(
        "fsph._core (the compiled solver) is not importable from "
        f"{__file__.rsplit('/', 2)[0]}: run `make test`/`make run` (they build and install "
        "fsph into .venv) and use .venv/bin/python from outside the source folder") from exc

# status codes, phases and row layouts: fsph.layouts (the solver is built from it)
STATUS_OK = layouts.status_code("ok")
STATUS_MAX_CYCLES = layouts.status_code("max_cycles")
STATUS_BAD_INPUT = layouts.status_code("bad_input")
NODE_FAULTS = {code for code, _, index, _ in layouts.STATUS if index == "node"}
# where a failure's position may be (Simulation._plausible): the bodies'
# box at set-up widened by this many box sizes [-] and by the distance covered
# at this speed [m/s] since t = 0
PLAUSIBLE_SIZES = 100.0
PLAUSIBLE_SPEED = 1.0e5
PHASES = tuple(name for name, _ in layouts.PHASES)


def threads():
    """Most OpenMP threads a run uses (honours OMP_NUM_THREADS); under the
    adaptive thread policy a cycle may use fewer (thread_policy)."""
    return int(_api.threads())


#: Environment variable that chooses the thread policy, and its values.
THREAD_POLICY_VARIABLE = "FSPH_THREAD_POLICY"
THREAD_POLICIES = {
    "adaptive": "times the cycles at the thread count in use and at half or double it, "
                "and keeps the faster (fewer threads when another process holds a core)",
    "fixed": "every cycle uses all the threads",
}


def thread_policy():
    """The thread policy from FSPH_THREAD_POLICY: 'adaptive' (unset or
    empty) or 'fixed'. InputError for any other value."""
    value = os.environ.get(THREAD_POLICY_VARIABLE, "").strip().lower() or "adaptive"
    if value not in THREAD_POLICIES:
        raise InputError(f"environment variable {THREAD_POLICY_VARIABLE}: expected one of "
                         f"{', '.join(THREAD_POLICIES)}, got {os.environ[THREAD_POLICY_VARIABLE]!r}")
    return value


def openmp_wait_settings():
    """The OpenMP wait settings of the environment (OMP_WAIT_POLICY,
    GOMP_SPINCOUNT), 'unset' where not given."""
    return {name: os.environ.get(name, "unset") for name in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}


#: The landing time of an advance that never shortens a step [s].
_NEVER_LANDS = 1.0e300


def _time_argument(name, value):
    """A time argument of advance as a float [s]: a real number (not a
    bool, not a string), finite and >= 0; FsphError otherwise."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise FsphError(f"advance: expected a time in seconds (a number) for {name}, got {value!r}")
    value = float(value)
    if not (math.isfinite(value) and value >= 0.0):
        raise FsphError(f"advance: expected a finite time >= 0 s for {name}, got {value!r}")
    return value


def fortran_index(index):
    """1-based Fortran indices (int32) of 0-based ones; -1 (none) becomes 0.
    Every index handed to the solver goes through here."""
    return (np.asarray(index) + 1).astype(np.int32)


def python_index(index):
    """0-based indices of the solver's 1-based ones; 0 (none) becomes -1.
    Every index read from the solver goes through here."""
    return np.asarray(index) - 1


def _check_layout():
    if int(_api.get_layout_digest()) != layouts.digest():
        raise FsphError("fsph._core was built from other layouts than fsph/layouts.py "
                        "(a stale build): rebuild the package")


class Simulation:
    """One run. Build with `Simulation.from_deck(path)`, `Simulation.from_dict(groups)` or
    `Simulation(deck)` (a deck from fsph.deck.load; changed or hand-built ones are validated)."""

    def __init__(self, deck):
        _check_layout()
        # a dict built by hand, or a loaded deck changed since, is validated as a deck is
        deck = deck_module.checked(deck)
        self.deck = deck
        self.control = deck["control"]
        materials = deck["material"]
        self.material_names = [m["name"] for m in materials]
        self.body_names = [b["name"] for b in deck["body"]]
        rho0 = {m["name"]: m["density"] for m in materials}
        #: each material's reference density [kg/m^3], by material index
        self.material_density0 = np.array([m["density"] for m in materials], dtype=float)

        # this run's own state in the solver: runs in one process are independent
        self.thread_policy = thread_policy()
        self._run = int(_api.open_run())
        _api.set_thread_policy(self._run, int(self.thread_policy == "adaptive"), -1.0, -1.0)
        c = self.control
        _api.set_control(self._run, c["dt_safety"], c["c_q"], c["c_l"], c["dt_floor_ratio"], c["dt_drop_ratio"],
                         deck["output"]["history_every"])
        sph = deck["sph"]
        touch, slope = contact_filling(sph["alpha_h"])
        _api.set_sph_control(self._run, sph["c_q"], sph["c_l"], sph["hourglass"],
                             layouts.index_of([n for n, _ in layouts.PARTICLE_CONTACTS], sph["particle_contact"]),
                             sph["contact_penalty"], touch, slope, sph["debris_density"], sph["neighbour_skin"],
                             sph["eigenerosion_factor"], sph["spatial_order_min"], sph["artificial_stress"])
        props, strength, eos = property_table(materials)
        self._call(_api.set_materials(self._run, props, strength, eos), "material table")

        elem_bodies, part_bodies = [], []
        for ib, b in enumerate(deck["body"]):
            try:
                geometry = mesh_module.body_discretisation(b)
            except ValueError as err:   # a combination of keys the generator cannot mesh
                raise DeckError(deck.get("path", "deck"), f"body #{ib + 1}", "geometry",
                                f"keys that '{b['geometry']}' can mesh", str(err)) from None
            mat = self.material_names.index(b["material"])
            (elem_bodies if b["discretisation"] == "elements" else part_bodies).append(
                (ib, b, geometry, mat))

        check_starting_state(deck, [(ib, geometry) for ib, _, geometry, _ in elem_bodies + part_bodies])
        # the bodies' box at set-up: a failure's position is reported only inside its reach
        self._box0 = _bounding_box([geometry.x for _, _, geometry, _ in elem_bodies + part_bodies])
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
        if ierr == STATUS_BAD_INPUT and ifault < 0:
            self._refuse_total_body(deck, int(python_index(-ifault)))
        if ierr != STATUS_OK:
            raise self._failure(ierr, ifault, during="set-up")
        self.gauge_names = [g["name"] for g in deck["gauge"]]
        on = self.locate_gauges()
        for k, g in enumerate(deck["gauge"]):
            if g["kind"] == "material" and on[k] == "nothing":
                raise DeckError(deck.get("path", "deck"), f"gauge #{k + 1}", "point",
                                "a point inside a body at t = 0 (kind 'material' follows the "
                                "material there)", list(g["point"]))
        self.initial_energy = self.energy_budget()["total"]
        #: the SimulationError that ended the run, None while it can go on
        self.failure = None
        # radii at set-up (a snapshot's radius0 for the particles present then)
        self.particle_radius0 = self._raw_snapshot()["particle_fields"][:, _PF["radius"]].copy()
        self.n_elements0 = self.n_elements
        self.n_nodes0, self.n_particles0 = self.n_nodes, self.n_particles

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
            body_ids.append(np.full(m.n_elements, ib))
            offset += m.n_nodes
        x, conn = np.vstack(xs), np.vstack(conns)
        self._call(_api.set_mesh(self._run, np.asfortranarray(x.T), np.asfortranarray(np.vstack(vels).T),
                                 np.asfortranarray(fortran_index(conn.T)),
                                 fortran_index(np.concatenate(mats)),
                                 fortran_index(np.concatenate(body_ids))), "mesh")

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
            body_ids.append(np.full(lat.n_particles, ib))
        x = np.vstack(xs)
        self._call(_api.set_particles(self._run, np.asfortranarray(x.T), np.asfortranarray(np.vstack(vels).T),
                                      np.concatenate(masses), np.concatenate(hs),
                                      fortran_index(np.concatenate(mats)),
                                      fortran_index(np.concatenate(body_ids))), "particles")

    def _set_coupling(self, deck, has_elements, has_particles):
        """Continua (bodies joined by joined_to), which element bodies act as
        imaginary particles, and the conversion parameters."""
        bodies = deck["body"]
        names = [b["name"] for b in bodies]
        continuum = list(range(len(bodies)))     # union-find of joined bodies, 0-based

        def root(k):
            while continuum[k] != k:
                k = continuum[k]
            return k

        for ib, b in enumerate(bodies):
            if b["joined_to"] is not None:
                a, c = root(ib), root(names.index(b["joined_to"]))
                continuum[max(a, c)] = min(a, c)
        continuum = [root(k) for k in range(len(bodies))]
        #: the continuum of each body (0-based: the first body joined into it)
        self.continuum_of_body = continuum
        mode = self.control["mode"]
        coupled = []
        for ib, b in enumerate(bodies):
            same = [j for j in range(len(bodies)) if continuum[j] == continuum[ib]]
            has_part = any(bodies[j]["discretisation"] == "particles" for j in same)
            coupled.append(int(b["discretisation"] == "elements"
                               and (mode == "adaptive" or (mode == "fixed" and has_part))))
        self._call(_api.set_continua(self._run, fortran_index(continuum),
                                     np.array(coupled, dtype=np.int32)), "continua")
        total = np.array([int(b["formulation"] == "total") for b in bodies], dtype=np.int32)
        self._call(_api.set_formulation(self._run, total, deck["sph"]["total_hourglass"],
                                        int(deck["sph"]["total_stencil"] == "selected")), "formulation")
        conv = deck["convert"]
        criteria = [name for name, _ in layouts.CONVERSION_CRITERIA]
        _api.set_conversion(self._run, int(mode == "adaptive"), layouts.index_of(criteria, conv["criterion"]),
                            np.radians(conv["theta_c"]), conv["relative_angle"], conv["eps_c"], conv["sigma_c"] or 0.0,
                            conv["kappa"], deck["sph"]["alpha_h"])
        if has_elements and not has_particles and mode == "adaptive":
            self._call(_api.reserve_particles(self._run), "particle capacity")

    @classmethod
    def from_deck(cls, path):
        """The run of the namelist deck at `path`."""
        return cls(deck_module.load(path))

    @classmethod
    def from_dict(cls, groups, name="<dict>"):
        """The run of a deck given as a dict (group -> keys, a list of
        dicts for repeatable groups; fsph.deck.from_groups), validated
        exactly as a deck file is."""
        return cls(deck_module.from_groups(groups, name))

    # ------------------------------------------------------------------
    @staticmethod
    def _call(ierr, what):
        if ierr != STATUS_OK:
            raise FsphError(f"set-up of the {what} rejected by the solver: "
                            f"{layouts.status_text(int(ierr))}")

    def _refuse_total_body(self, deck, k):
        """A total-Lagrangian body refused at set-up: particle k (0-based)
        has neighbours that do not span the plane (fsph_tlsph
        reference_correction), so its corrected gradient does not exist."""
        raw = self._raw_snapshot()
        fields = raw["particle_fields"]
        if not 0 <= k < len(fields):
            return
        ib = int(python_index(raw["particle_ids"][k][_ID["body"]]))
        body = deck["body"][ib]
        if body["formulation"] != "total":
            return
        r, z = fields[k, _PF["x0_r"]:_PF["x0_r"] + 2] * 1e3
        raise DeckError(deck.get("path", "deck"), f"body #{ib + 1}", "formulation",
                        "'updated', or a lattice whose every particle has neighbours in two "
                        "directions within 2h (total-Lagrangian particles need them for their "
                        f"corrected gradient; the one at r = {r:.4g} mm, z = {z:.4g} mm has not: "
                        "more cells, or a larger &sph alpha_h)", body["formulation"])

    def _failure(self, ierr, ifault, during="run"):
        """The SimulationError of status ierr, naming where the element,
        particle (ifault < 0) or node at fault is. A position is given only
        when it is finite and within reach of the bodies (_plausible);
        otherwise the diagnostic says the position is unknown and gives where
        the element or particle started, and the error's location is None."""
        time, cycle = self.time, self.cycle
        text = layouts.status_text(int(ierr))
        where, location = "", None
        raw = self._raw_snapshot()
        if ifault < 0:
            k = int(python_index(-ifault))
            fields = raw["particle_fields"]
            if 0 <= k < len(fields):
                where, location = self._placed(
                    f"particle {-ifault}{self._of_body(raw['particle_ids'][k])}",
                    fields[k:k + 1, _PF["x_r"]:_PF["x_r"] + 2], fields[k:k + 1, _PF["x0_r"]:_PF["x0_r"] + 2])
            else:
                where = f"; particle {-ifault} (not among the run's {len(fields)} particles)"
        elif ifault > 0 and ierr in NODE_FAULTS:
            k = int(python_index(ifault))
            nodes = raw["node_fields"]
            start = nodes[k, _NF["x0_r"]:_NF["x0_r"] + 2] if 0 <= k < len(nodes) else None
            if start is not None and self._plausible(start):
                location = start
                where = (f"; node {ifault} (initially at r = {start[0] * 1e3:.4g} mm, "
                         f"z = {start[1] * 1e3:.4g} mm)")
            else:
                where = f"; node {ifault} (position unknown)"
        elif ifault > 0 and ierr != STATUS_BAD_INPUT:
            k = int(python_index(ifault))
            nodes = raw["node_fields"]
            if 0 <= k < len(raw["conn"]) and np.all((raw["conn"][k] >= 1) & (raw["conn"][k] <= len(nodes))):
                corners = python_index(raw["conn"][k])
                where, location = self._placed(
                    f"element {ifault}{self._of_body(raw['element_ids'][k])}",
                    nodes[corners, _NF["x_r"]:_NF["x_r"] + 2], nodes[corners, _NF["x0_r"]:_NF["x0_r"] + 2])
            else:
                where = f"; element {ifault} (not among the run's {len(raw['conn'])} elements)"
        elif ifault > 0:
            where = f"; index {ifault}"
        msg = f"{during} stopped at t = {time * 1e6:.6g} us, cycle {cycle}: {text}{where}"
        return SimulationError(msg, code=int(ierr), index=int(ifault), time=float(time),
                               cycle=int(cycle), location=location)

    def _of_body(self, ids):
        """' of body NAME' for a row of snapshot ids ('' for a body index
        the deck does not have)."""
        body = int(python_index(ids[_ID["body"]]))
        return f" of body '{self.body_names[body]}'" if 0 <= body < len(self.body_names) else ""

    def _placed(self, what, points, starts):
        """The diagnostic's '; WHAT at r = .., z = ..' and the location (r, z)
        [m]: the mean of `points` (k, 2) [m] (an element's corners, a
        particle) when every one is plausible; else '; WHAT, position
        unknown' with the mean of their initial positions `starts` [m], and
        no location."""
        if all(self._plausible(p) for p in points):
            location = points.mean(axis=0)
            return f"; {what} at r = {location[0] * 1e3:.4g} mm, z = {location[1] * 1e3:.4g} mm", location
        where = f"; {what}, position unknown (not finite or far outside the bodies)"
        if all(self._plausible(p) for p in starts):
            start = starts.mean(axis=0)
            where += f", initially at r = {start[0] * 1e3:.4g} mm, z = {start[1] * 1e3:.4g} mm"
        return where, None

    def _plausible(self, point):
        """Whether (r, z) [m] can be where part of a body is: finite and
        inside the bodies' box at set-up widened on every side by
        PLAUSIBLE_SIZES box sizes and the distance covered at
        PLAUSIBLE_SPEED since t = 0. A finite position farther out is a
        node or particle flung off by a runaway force, not a place."""
        r_lo, r_hi, z_lo, z_hi = self._box0
        time = self.time if math.isfinite(self.time) and self.time > 0.0 else 0.0
        reach = PLAUSIBLE_SIZES * max(r_hi - r_lo, z_hi - z_lo) + PLAUSIBLE_SPEED * time
        r, z = (float(c) for c in point)
        return (math.isfinite(r) and math.isfinite(z)
                and r_lo - reach <= r <= r_hi + reach and z_lo - reach <= z <= z_hi + reach)

    # ------------------------------------------------------------------
    def advance(self, t, max_cycles=None, land=True, partial=False, land_on=None):
        """Advance the state to time t [s]; raises SimulationError on failure.
        land=True shortens the last steps to end exactly on t; land=False
        keeps the stable step and stops at the first cycle end at or after t
        (outputs then do not alter the trajectory). land_on [s] (>= t, with
        land=False) is a time no step crosses, the last steps before it
        shortened to end on it: the end time of a run that stops on the
        way for its outputs, so that its last intermediate call cannot step
        past the end. With partial=True at most max_cycles cycles are run
        and reaching that number is not an error (the deck's max_cycles
        still is). A t at or before the current time does nothing; a t that
        is not a finite number >= 0, a max_cycles that is not an integer
        >= 0, or a land_on before t is refused, and so is any advance after
        one that failed (the state is the failed cycle's)."""
        if self.failure is not None:
            raise FsphError(f"advance: the run failed ({self.failure}); its state cannot be "
                            "advanced further")
        t = _time_argument("t", t)
        if land_on is None:
            t_land = t if land else _NEVER_LANDS
        else:
            t_land = _time_argument("land_on", land_on)
            if land or t_land < t:
                raise FsphError(f"advance: land_on ({t_land!r} s) needs land=False and a time at "
                                f"or after t ({t!r} s)")
        if max_cycles is not None and not (isinstance(max_cycles, numbers.Integral)
                                           and not isinstance(max_cycles, bool) and max_cycles >= 0):
            raise FsphError(f"advance: expected max_cycles an integer >= 0 (or None), got {max_cycles!r}")
        limit = self.control["max_cycles"] - self.cycle
        if max_cycles is None or not partial:
            max_cycles = limit if max_cycles is None else max_cycles
        ierr, ifault = _api.advance(self._run, t, int(max(min(max_cycles, limit), 0)), t_land)
        if ierr == STATUS_MAX_CYCLES and partial and self.cycle < self.control["max_cycles"]:
            return
        if ierr != STATUS_OK:
            self.failure = self._failure(ierr, ifault)
            raise self.failure

    def thread_use(self):
        """Cycles run so far at each thread count, {threads: cycles}, for
        the counts used (the adaptive policy may use fewer than threads())."""
        n = threads()
        counts = _api.get_thread_use(self._run, n)
        return {k + 1: int(c) for k, c in enumerate(counts) if c > 0}

    def phase_times(self):
        """Wall time [s] spent in each phase of the cycle since set-up (or
        the last reset_phase_times), by name (PHASES)."""
        times = _api.get_phase_times(self._run, int(_api.phase_count()))
        return dict(zip(PHASES, (float(t) for t in times)))

    def reset_phase_times(self):
        _api.reset_phase_times(self._run)

    def locate_gauges(self):
        """Locate the deck's gauges (&gauge) in the current state, in the
        initial configuration (fsph_gauges): at set-up, and after a restart
        (the gauges are not in a checkpoint). Returns what each samples
        now: 'element', 'particle' or 'nothing' (a material gauge whose
        point is in no body; a fixed gauge, searched at every record)."""
        gauges = self.deck["gauge"]
        if not gauges:
            return []
        kinds = [name for name, _ in layouts.GAUGE_KINDS]
        on, ierr = _api.set_gauges(self._run, fortran_index([kinds.index(g["kind"]) for g in gauges]),
                                   np.asfortranarray(np.array([g["point"] for g in gauges], dtype=float).T))
        if ierr != STATUS_OK:
            raise FsphError(f"set-up of the gauges rejected by the solver: {layouts.status_text(int(ierr))}")
        return [layouts.GAUGE_SOURCES[int(k)] for k in on]

    def gauge_state(self):
        """What each gauge (in deck order) samples now, by name: 'on'
        ('element', 'particle' or 'nothing'; a fixed gauge is searched at
        each record and says 'nothing'), 'index' (0-based, -1 none), and
        the times [s] at which a material gauge moved from its element to a
        particle ('switch_time') and at which its element was deleted
        ('lost_time'), None where it has not."""
        n = len(self.gauge_names)
        if n == 0:
            return {}
        on, index, switch, lost, ierr = _api.get_gauge_state(self._run, n)
        if ierr != STATUS_OK:
            raise FsphError("gauge state: the solver holds other gauges than the deck")
        return {name: {"on": layouts.GAUGE_SOURCES[int(on[k])], "index": int(python_index(index[k])),
                       "switch_time": float(switch[k]) if switch[k] >= 0.0 else None,
                       "lost_time": float(lost[k]) if lost[k] >= 0.0 else None}
                for k, name in enumerate(self.gauge_names)}

    def resume_gauges(self, states):
        """A restart: the material gauges named in `states` (name: a
        state as gauge_state gives it) that had left their elements when
        the checkpoint was written follow again what they followed, a
        particle since its switch_time or nothing since its lost_time,
        in place of what the restart located in the initial
        configuration. FsphError where a state does not fit the run (a
        particle index beyond its particles or of another body)."""
        n = len(self.gauge_names)
        if n == 0:
            return
        kinds = {g["name"]: g["kind"] for g in self.deck["gauge"]}
        on, index = np.full(n, -1, dtype=np.int32), np.zeros(n, dtype=np.int32)
        switch, lost = np.full(n, -1.0), np.full(n, -1.0)
        for k, name in enumerate(self.gauge_names):
            state = states.get(name)
            if state is None or kinds[name] != "material" or state["on"] == "element":
                continue
            if state["on"] == "nothing" and state["lost_time"] is None:
                continue                      # outside every body from the start
            on[k] = layouts.GAUGE_SOURCES.index(state["on"])
            index[k] = fortran_index(state["index"]) if state["on"] == "particle" else 0
            switch[k] = -1.0 if state["switch_time"] is None else state["switch_time"]
            lost[k] = -1.0 if state["lost_time"] is None else state["lost_time"]
        if _api.resume_gauges(self._run, on, index, switch, lost) != STATUS_OK:
            raise FsphError("gauge states that do not fit this run's particles")

    def drain_history(self):
        """Time-history records (k, len(fsph.layouts.HISTORY_COLUMNS))
        recorded by the cycle since the last call: time [s], cycle, dt [s],
        the rigid planes' axial impulse on the bodies since t = 0 [N s], then
        the energy budget [J] (kinetic, internal, removed by contact,
        erosion and the rigid planes, total)."""
        return self.drain_histories()[0]

    def drain_histories(self, gauges=False):
        """(records, bodies): the time-history records of drain_history and,
        at the same records, each body's books (k, bodies,
        len(fsph.layouts.BODY_COLUMNS): kinetic [J], internal [J], axial
        momentum [N s], plastic work [J]); with gauges=True (records,
        bodies, gauges), gauges each gauge's row at the same records (k,
        gauges, len(fsph.layouts.GAUGE_COLUMNS)), in deck order."""
        n = int(_api.history_count(self._run))
        bodies, ierr = _api.get_body_history(self._run, len(layouts.BODY_COLUMNS), len(self.body_names), n)
        if ierr != STATUS_OK:
            raise FsphError("body history: layout mismatch, rebuild the package")
        rows = np.zeros((len(layouts.GAUGE_COLUMNS), 0, n))
        if self.gauge_names:
            rows, ierr = _api.get_gauge_history(self._run, len(layouts.GAUGE_COLUMNS), len(self.gauge_names), n)
            if ierr != STATUS_OK:
                raise FsphError("gauge history: layout mismatch, rebuild the package")
        records, ierr = _api.drain_history(self._run, len(layouts.HISTORY_COLUMNS), n)
        if ierr != STATUS_OK:
            raise FsphError("time history: layout mismatch, rebuild the package")
        drained = (records.T.copy(), np.transpose(bodies, (2, 1, 0)).copy())
        return drained + (np.transpose(rows, (2, 1, 0)).copy(),) if gauges else drained

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
        return int(_api.get_sizes(self._run)[2])

    def conversion(self):
        """Elements converted so far, conversion events, kinetic energy of
        the nodes' relative motion turned into heat at conversion [J], and
        coupling-interface edges in use."""
        n_conv, n_events, heat, n_edges = _api.get_conversion_stats(self._run)
        return {"n_converted": int(n_conv), "n_events": int(n_events), "heat_J": float(heat),
                "n_coupling_edges": int(n_edges)}

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

    def penetration(self):
        """Deepest interpenetration of bodies at the current positions [m]
        and relative to the penetrated segment's length [-]."""
        scalars, ierr = _api.get_snapshot_scalars(self._run, len(layouts.SNAPSHOT_SCALARS))
        if ierr != STATUS_OK:
            raise FsphError("snapshot: layout mismatch, rebuild the package")
        return {"depth": float(scalars[_SS["contact_penetration"]]),
                "relative": float(scalars[_SS["contact_penetration_relative"]])}

    def energy_budget(self):
        """The solver's energy budget [J] by name (fsph.layouts.ENERGY_COLUMNS:
        kinetic, internal, contact, eroded, plane, total)."""
        budget, ierr = _api.get_energy_budget(self._run, len(layouts.ENERGY_COLUMNS))
        if ierr != STATUS_OK:
            raise FsphError("energy budget: layout mismatch, rebuild the package")
        return dict(zip(layouts.ENERGY_COLUMNS, (float(v) for v in budget)))

    def plane_impulse_z(self):
        """Axial impulse of the rigid planes on the bodies since t = 0 [N s]
        (kinematic condition and mirror images); with a plane the only
        external load, it equals the bodies' change of axial momentum."""
        real, _ = self.scalar_state()
        return float(real[layouts.CHECKPOINT_REAL_SCALARS.index("plane_impulse_z")])

    def scalar_state(self):
        """The clock and books as (real, int) arrays in the order of
        fsph.layouts CHECKPOINT_REAL_SCALARS and CHECKPOINT_INT_SCALARS."""
        r, i, ierr = _api.get_scalar_state(self._run, len(layouts.CHECKPOINT_REAL_SCALARS),
                                           len(layouts.CHECKPOINT_INT_SCALARS))
        if ierr != STATUS_OK:
            raise FsphError("scalar state: layout mismatch, rebuild the package")
        return r, i

    def energies(self):
        """Kinetic, internal, contact-dissipated, plane-dissipated, eroded
        and total energy [J] and the relative error of the total against the
        initial energy. Contact corrections and the kinematic condition of
        rigid planes (and of the particles' axis wall) remove kinetic energy
        as perfectly inelastic collisions of what strikes them; both are
        booked, so the total is conserved by the method. The total is
        centred in time: the internal energy in it is the mean of its
        values at the last step's two ends, beside the kinetic energy of
        the half-step velocities (docs/method.md, "The energy balance"),
        so it is not the sum of the other entries."""
        energies = self.energy_budget()
        energies["relative_error"] = ((energies["total"] - self.initial_energy) / self.initial_energy
                                      if self.initial_energy else 0.0)
        return energies

    def _raw_snapshot(self):
        """The solver's snapshot rows (fsph.layouts NODE_FIELDS, ...), one
        row per node, element or particle; indices 1-based as stored."""
        nn, ne, np_ = (int(v) for v in _api.get_sizes(self._run))
        nodes, conn, eids, efields, pids, pfields, scalars, ierr = _api.get_snapshot(
            self._run, nn, ne, np_, len(layouts.NODE_FIELDS), len(layouts.ELEMENT_FIELDS),
            len(layouts.PARTICLE_FIELDS), len(layouts.ID_FIELDS), len(layouts.SNAPSHOT_SCALARS))
        if ierr != STATUS_OK:
            raise FsphError("snapshot: layout mismatch, rebuild the package")
        return {"node_fields": nodes.T, "conn": conn.T, "element_ids": eids.T,
                "element_fields": efields.T, "particle_ids": pids.T, "particle_fields": pfields.T,
                "scalars": scalars}

    def snapshot(self):
        """Current state as plain arrays in SI units, from one solver call
        that changes nothing: `time`, `cycle`; the nodes' `x`, `x0`,
        `velocity` (n, 2) and `node_mass`; the elements' `conn` (m, 3,
        0-based into the nodes), `material`, `body`, `id` and fields
        (`stress`, the total Cauchy stress rr, zz, rz, tt; `pressure`, `q`,
        `plastic_strain`, `density`, `internal_energy` per mass,
        `temperature`, `sound_speed`, `area`, `element_mass`, `damage`,
        `failed`, `melted`); the particles (if any) under "particles", with
        `x`, `x0`, `velocity`, `mass`, `h`, `radius`, `radius0` (in the
        initial configuration) and the same fields. fsph.h5 holds the same
        arrays, the nodes' positions as `nodes` and the connectivity as
        `connectivity`."""
        raw = self._raw_snapshot()
        scalars = raw["scalars"]
        snap = {"time": float(scalars[_SS["time"]]), "cycle": int(scalars[_SS["cycle"]]),
                "contact_penetration": float(scalars[_SS["contact_penetration"]]),
                "contact_penetration_relative": float(scalars[_SS["contact_penetration_relative"]]),
                "eroded_momentum_z": float(scalars[_SS["eroded_momentum_z"]])}
        if len(raw["conn"]):
            snap.update(_element_snapshot(raw))
        if len(raw["particle_ids"]):
            part = _particle_snapshot(raw["particle_fields"], raw["particle_ids"])
            part["radius0"] = self._particle_radius0(part)
            snap["particles"] = part
        return snap


    def _particle_radius0(self, part):
        """Each particle's radius [m] in the initial configuration: a
        set-up particle's radius then (by its id: particles are renumbered
        in spatial order); a converted one's from its element's ring at
        t = 0, half the square root of the planar area m / (2 pi r0 rho0)
        at its initial position r0 = x0[:, 0] (the radius a particle gets,
        fsph_sph.f90 particle_radius)."""
        initial = part["id"] < len(self.particle_radius0)
        ring_r0 = np.maximum(np.abs(part["x0"][:, 0]), np.finfo(float).tiny)
        rho0 = self.material_density0[part["material"]]
        radius0 = 0.5 * np.sqrt(part["mass"] / (2.0 * np.pi * ring_r0 * rho0))
        radius0[initial] = self.particle_radius0[part["id"][initial]]
        return radius0


# rows of the snapshot layouts by name (0-based columns of the transposed rows)
_NF = {name: k for k, name in enumerate(layouts.NODE_FIELDS)}
_EF = {name: k for k, name in enumerate(layouts.ELEMENT_FIELDS)}
_PF = {name: k for k, name in enumerate(layouts.PARTICLE_FIELDS)}
_ID = {name: k for k, name in enumerate(layouts.ID_FIELDS)}
_SS = {name: k for k, name in enumerate(layouts.SNAPSHOT_SCALARS)}


def _pairs(fields, rows, first):
    """(n, 2) columns first_r, first_z of a row table."""
    return fields[:, rows[first + "_r"]:rows[first + "_r"] + 2].copy()


def _cauchy_stress(fields, rows, pressure):
    """Total Cauchy stress (n, 4) (rr, zz, rz, tt) [Pa] from the deviator
    rows and a pressure (n,) [Pa] (tension positive)."""
    stress = fields[:, rows["s_rr"]:rows["s_tt"] + 1].copy()
    stress[:, [0, 1, 3]] -= pressure[:, None]
    return stress


def _bounding_box(points):
    """(r_lo, r_hi, z_lo, z_hi) [m] of a list of (k, 2) position arrays [m]."""
    x = np.vstack(points) if points else np.zeros((1, 2))
    return (float(x[:, 0].min()), float(x[:, 0].max()), float(x[:, 1].min()), float(x[:, 1].max()))


def _element_snapshot(raw):
    """Node and element entries of a snapshot from the solver's rows."""
    nodes, ef = raw["node_fields"], raw["element_fields"]
    column = {name: ef[:, k].copy() for name, k in _EF.items()}
    return {
        "x": _pairs(nodes, _NF, "x"), "x0": _pairs(nodes, _NF, "x0"), "velocity": _pairs(nodes, _NF, "v"),
        "node_mass": nodes[:, _NF["mass"]].copy(),
        "conn": python_index(raw["conn"]), "material": python_index(raw["element_ids"][:, _ID["material"]]),
        "body": python_index(raw["element_ids"][:, _ID["body"]]),
        "id": python_index(raw["element_ids"][:, _ID["id"]]),
        "stress": _cauchy_stress(ef, _EF, column["p"] + column["q"]), "pressure": column["p"],
        "q": column["q"], "plastic_strain": column["eps_p"], "density": column["rho"],
        "internal_energy": column["e"], "temperature": column["temp"], "sound_speed": column["c"],
        "area": column["area"], "element_mass": column["mass"], "damage": column["damage"],
        "failed": column["failed"], "melted": column["melted"],
    }


def _particle_snapshot(pf, ids):
    """Particle entries of a snapshot from the solver's rows."""
    column = {name: pf[:, k].copy() for name, k in _PF.items()}
    return {
        "x": _pairs(pf, _PF, "x"), "x0": _pairs(pf, _PF, "x0"), "velocity": _pairs(pf, _PF, "v"),
        "mass": column["mass"], "h": column["h"], "radius": column["radius"],
        "material": python_index(ids[:, _ID["material"]]), "body": python_index(ids[:, _ID["body"]]),
        "id": python_index(ids[:, _ID["id"]]),
        "stress": _cauchy_stress(pf, _PF, column["p"]), "pressure": column["p"],
        "plastic_strain": column["eps_p"], "density": column["rho"], "internal_energy": column["e"],
        "temperature": column["temp"], "sound_speed": column["c"], "damage": column["damage"],
        "failed": column["failed"], "melted": column["melted"],
    }


def kernel(dist, h):
    """Smoothing kernel W [1/m^2] and dW/dr [1/m^3] at distances dist [m]."""
    w, dw, _ = _api.kernel_values(np.asarray(dist, dtype=float), float(h))
    return w, dw


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
