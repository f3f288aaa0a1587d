"""One-dimensional shock physics of a flyer striking a plate: the impedance
match of two linear Us-up Hugoniots, the shock speeds and transit times,
and the release of the shocked states to zero pressure along the
Mie-Grueneisen isentropes (the velocities of the free surfaces).

The Hugoniot of a material with the linear shock-velocity fit
Us = c0 + s up (the reference curve of fsph's Mie-Grueneisen EOS) gives
the pressure behind a shock that sets the material in motion at up:

    p = rho0 Us up = rho0 (c0 + s up) up.

A flyer of material F striking a plate of material T at speed v: the
interface moves at u with p_T(u) = p_F(v - u) (normal stress and velocity
continuous across it), a quadratic in u (e.g. Meyers 1994, Dynamic
Behavior of Materials, section 4.5). The shocks then run into the plate
at U_T = c_T + s_T u and back into the flyer at U_F = c_F + s_F (v - u)
relative to the flyer's unshocked material.

Releasing a shocked state to p = 0 adds (or, facing the other way, takes
off) the Riemann integral of the isentrope, du = dp / (rho c), to the
particle velocity: the plate's rear face leaves at u + du_T, close to the
free-surface doubling 2u (Rice, McQueen & Walsh 1958). The isentrope is
integrated with the same Mie-Grueneisen form fsph's EOS uses
(fsph_material eos_pressure: Steinberg/LS-DYNA form, Gamma rho =
Gamma0 rho0).

SI units throughout: kg/m^3, m/s, Pa, m, s.
"""

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ShockMaterial:
    """A material's shock constants: reference density rho0 [kg/m^3], bulk
    sound speed c0 [m/s], slope s [-] of Us = c0 + s up and Grueneisen
    coefficient gamma0 [-]."""

    density: float
    c0: float
    s: float
    gamma0: float
    name: str = ""

    @classmethod
    def from_deck(cls, material):
        """From a validated &material of eos 'mie_gruneisen' (ValueError
        for another EOS: its Hugoniot is not a linear Us-up fit)."""
        if material["eos"] != "mie_gruneisen":
            raise ValueError(f"material {material['name']!r}: the impedance match needs eos "
                             f"'mie_gruneisen' (a linear Us-up Hugoniot), not {material['eos']!r}")
        return cls(material["density"], material["c0"], material["s"], material["gamma0"],
                   material["name"])

    def shock_speed(self, up):
        """Shock speed Us [m/s] relative to the unshocked material, for a
        particle velocity jump up [m/s]."""
        return self.c0 + self.s * up

    def pressure(self, up):
        """Hugoniot pressure [Pa] behind a shock of particle velocity jump
        up [m/s]."""
        return self.density * self.shock_speed(up) * up

    def particle_velocity(self, pressure):
        """Particle velocity jump up [m/s] of the shock to `pressure` [Pa]
        (the positive root of rho0 (c0 + s up) up = p)."""
        return 2.0 * pressure / self.density / (self.c0 + np.sqrt(self.c0**2 + 4.0 * self.s
                                                                   * pressure / self.density))

    def shocked_density(self, up):
        """Density [kg/m^3] behind the shock: rho0 Us / (Us - up)."""
        us = self.shock_speed(up)
        return self.density * us / (us - up)

    def eos(self, rho, energy):
        """Mie-Grueneisen pressure [Pa] at density rho [kg/m^3] and specific
        internal energy [J/kg], with d(pressure)/d(rho) at constant energy
        [m^2/s^2] and d(pressure)/d(energy) at constant density [kg/m^3],
        in the form of fsph's EOS: mu = rho/rho0 - 1; compression
        rho0 c0^2 mu [1 + (1 - Gamma0/2) mu] / [1 - (s - 1) mu]^2, expansion
        rho0 c0^2 mu, plus Gamma0 rho0 e."""
        k0 = self.density * self.c0**2
        mu = rho / self.density - 1.0
        b = self.gamma0 * self.density
        if mu <= 0.0:
            return k0 * mu + b * energy, k0 / self.density, b
        g = 1.0 - 0.5 * self.gamma0
        den = 1.0 - (self.s - 1.0) * mu
        num = mu * (1.0 + g * mu)
        a = k0 * num / den**2
        dadrho = k0 * ((1.0 + 2.0 * g * mu) * den + 2.0 * (self.s - 1.0) * num) / den**3 / self.density
        return a + b * energy, dadrho, b

    def release_velocity(self, pressure, rtol=1e-10):
        """Particle velocity [m/s] a state shocked from rest to `pressure`
        [Pa] gains when it releases to zero pressure: the Riemann integral
        of c/rho d(rho) along the isentrope through the Hugoniot state,
        integrated in density (de/drho = p/rho^2, dp/drho = c^2) down to
        where the pressure vanishes."""
        from scipy.integrate import solve_ivp

        up = self.particle_velocity(pressure)
        rho_h = self.shocked_density(up)
        e_h = 0.5 * up**2                   # Rankine-Hugoniot energy from rest [J/kg]

        def rates(rho, y):
            p, dpdrho_e, dpde = self.eos(rho, y[0])
            c2 = dpdrho_e + dpde * p / rho**2
            return [p / rho**2, np.sqrt(max(c2, 0.0)) / rho]

        def zero_pressure(rho, y):
            return self.eos(rho, y[0])[0]
        zero_pressure.terminal = True
        zero_pressure.direction = -1

        sol = solve_ivp(rates, (rho_h, 0.2 * self.density), [e_h, 0.0], events=zero_pressure,
                        rtol=rtol, atol=1e-9, method="DOP853")
        if not sol.t_events[0].size:
            raise ValueError(f"{self.name or 'material'}: the isentrope from {pressure:.4g} Pa "
                             "does not reach zero pressure")
        return float(-sol.y_events[0][0][1])


def impedance_match(flyer, target, impact_speed, flyer_length=None, plate_thickness=None):
    """The 1D state of a flyer (ShockMaterial) striking a plate at rest at
    impact_speed [m/s] > 0: interface pressure [Pa] and particle velocity
    [m/s] (along the flight direction), the shock speeds relative to the
    unshocked material of each [m/s], the shocked densities [kg/m^3]; with
    the flyer's length and the plate's thickness [m], the times [s] the
    shocks take to cross them (in material terms: the thickness over the
    shock speed relative to the material ahead of it); and the release
    velocities: of the plate's rear face once the shock has reached it
    (u + du_target) and of the flyer's rear face (u - du_flyer), both
    along the flight direction [m/s]."""
    v = float(impact_speed)
    if not v > 0.0:
        raise ValueError(f"impact speed: expected a value > 0 m/s, got {v}")
    rho_f, rho_t = flyer.density, target.density
    # rho_t (c_t + s_t u) u = rho_f (c_f + s_f (v - u)) (v - u):  a u^2 + b u - c = 0
    a = rho_t * target.s - rho_f * flyer.s
    b = rho_t * target.c0 + rho_f * flyer.c0 + 2.0 * rho_f * flyer.s * v
    c = rho_f * v * (flyer.c0 + flyer.s * v)
    u = 2.0 * c / (b + np.sqrt(b * b + 4.0 * a * c))      # the root in (0, v), stable as a -> 0
    pressure = target.pressure(u)
    out = {"impact_speed_m_s": v, "pressure_Pa": float(pressure),
           "particle_velocity_m_s": float(u),
           "target_shock_speed_m_s": float(target.shock_speed(u)),
           "flyer_shock_speed_m_s": float(flyer.shock_speed(v - u)),
           "target_density_kg_m3": float(target.shocked_density(u)),
           "flyer_density_kg_m3": float(flyer.shocked_density(v - u))}
    if plate_thickness is not None:
        out["target_transit_s"] = plate_thickness / out["target_shock_speed_m_s"]
    if flyer_length is not None:
        out["flyer_transit_s"] = flyer_length / out["flyer_shock_speed_m_s"]
    out["target_free_surface_m_s"] = float(u + target.release_velocity(pressure))
    out["flyer_rear_surface_m_s"] = float(u - flyer.release_velocity(pressure))
    return out


def front_time(match, front, plate_thickness):
    """Time [s] at which the plate's rear free surface on the axis, leaving
    at the 1D free-surface velocity once the shock has crossed the plate,
    reaches `front` [m] from the plate's front face (the plate's rear face
    being at plate_thickness [m] from it)."""
    return match["target_transit_s"] + (front - plate_thickness) / match["target_free_surface_m_s"]
