"""Measures of the points of a snapshot that more than one module needs
(fsph.metrics, fsph.debris, fsph.output): the reach of element nodes, the
failed and molten mass of a body, the von Mises stress."""

import numpy as np


def node_radii(x, edges):
    """Half the shortest edge at each node [m] (inf for a node without
    edges)."""
    length = np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1)
    radius = np.full(len(x), np.inf)
    np.minimum.at(radius, edges[:, 0], 0.5 * length)
    np.minimum.at(radius, edges[:, 1], 0.5 * length)
    return radius


def state_masses(snap, body_index):
    """Mass [kg] of a body, and of its failed and its molten points
    (snapshot fields `failed`, `melted`; elements by their mass,
    particles by theirs; a snapshot without the fields has neither)."""
    out = {"mass_kg": 0.0, "failed_mass_kg": 0.0, "melted_mass_kg": 0.0}

    def add(fields, mass_key, keep):
        mass = fields[mass_key][keep]
        out["mass_kg"] += float(mass.sum())
        for flag in ("failed", "melted"):
            if flag in fields:
                out[f"{flag}_mass_kg"] += float(mass[fields[flag][keep] > 0.5].sum())
    if "conn" in snap and len(snap["conn"]):
        add(snap, "element_mass", snap["body"] == body_index)
    if "particles" in snap:
        add(snap["particles"], "mass", snap["particles"]["body"] == body_index)
    return out


def von_mises(stress):
    """Von Mises stress [Pa] of (n, 4) stresses in the order rr, zz, rz, tt
    (fsph.output STRESS_COMPONENTS; the snapshots' total Cauchy stress or a
    deviator): sqrt(3/2 s:s) of the deviator s (the mean of rr, zz, tt
    removed), the shear rz counted twice, the hoop tt included."""
    sig = np.asarray(stress, dtype=float)
    mean = (sig[:, 0] + sig[:, 1] + sig[:, 3]) / 3.0
    s_rr, s_zz, s_tt = sig[:, 0] - mean, sig[:, 1] - mean, sig[:, 3] - mean
    return np.sqrt(1.5 * (s_rr ** 2 + s_zz ** 2 + s_tt ** 2 + 2.0 * sig[:, 2] ** 2))
