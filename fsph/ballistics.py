"""Residual velocity against striking velocity: the Recht-Ipson form
v_r = a (v_s^p - v_bl^p)^(1/p) (v_r = 0 below the ballistic limit v_bl),
fitted by least squares, and the table of a set of perforation runs.

With a = 1 and p = 2 (a rigid, non-plugging projectile: the energy balance
of Recht & Ipson 1963) only v_bl is fitted; a and p may be freed. Standard
errors of the fitted constants come from the covariance s^2 (J^T J)^-1 of
the linearised least-squares problem at the optimum (J the Jacobian of the
residual velocities with respect to the fitted constants, s^2 the residual
sum of squares over the degrees of freedom); with no degree of freedom left
they are NaN. Vectorised numpy over the runs (a handful of numbers)."""

import json
from pathlib import Path

import numpy as np


def recht_ipson(v_s, v_bl, a=1.0, p=2.0):
    """Residual velocity [m/s] at striking velocities v_s [m/s]."""
    v_s = np.asarray(v_s, dtype=float)
    return a * np.maximum(v_s ** p - v_bl ** p, 0.0) ** (1.0 / p)


def _golden(f, lo, hi, tol):
    """Minimum of a unimodal f on [lo, hi] by golden-section search."""
    g = (np.sqrt(5.0) - 1.0) / 2.0
    c, d = hi - g * (hi - lo), lo + g * (hi - lo)
    while hi - lo > tol:
        if f(c) < f(d):
            hi, d = d, c
            c = hi - g * (hi - lo)
        else:
            lo, c = c, d
            d = lo + g * (hi - lo)
    return 0.5 * (lo + hi)


#: Interval searched for a free Recht-Ipson exponent p [-].
P_RANGE = (1.0, 10.0)


def _fit_v_bl(v_s, v_r, a, p):
    """Least-squares v_bl (and the best a for it when a is None) at fixed p."""
    def best_a(v_bl):
        if a is not None:
            return a
        shape = recht_ipson(v_s, v_bl, 1.0, p)
        denom = float(shape @ shape)
        return float(shape @ v_r) / denom if denom > 0.0 else 1.0

    def rms(v_bl):
        return float(np.sqrt(np.mean((recht_ipson(v_s, v_bl, best_a(v_bl), p) - v_r) ** 2)))

    v_bl = _golden(rms, 0.0, float(v_s.max()), 1e-6 * float(v_s.max()))
    return {"v_bl": float(v_bl), "a": best_a(v_bl), "p": p, "rms_residual": rms(v_bl)}


def _standard_errors(v_s, v_r, fit, free):
    """Standard errors of the constants named in `free` (of v_bl, a, p):
    square roots of the diagonal of s^2 (J^T J)^-1, J by central differences."""
    base = {k: fit[k] for k in ("v_bl", "a", "p")}
    jac = np.empty((len(v_s), len(free)))
    for j, name in enumerate(free):
        step = 1e-6 * max(abs(base[name]), 1.0)
        hi, lo = dict(base), dict(base)
        hi[name] += step
        lo[name] -= step
        jac[:, j] = (recht_ipson(v_s, **hi) - recht_ipson(v_s, **lo)) / (2.0 * step)
    dof = len(v_s) - len(free)
    if dof <= 0:
        return {name: float("nan") for name in free}
    s2 = float(np.sum((recht_ipson(v_s, **base) - v_r) ** 2)) / dof
    cov = s2 * np.linalg.pinv(jac.T @ jac)
    return {name: float(np.sqrt(max(cov[j, j], 0.0))) for j, name in enumerate(free)}


def fit_recht_ipson(v_s, v_r, a=None, p=2.0):
    """Least-squares v_bl (and a, when a is None: the best a for each v_bl
    is linear, so it is solved exactly) for fixed p, or for the best p in
    P_RANGE when p is None. Returns v_bl, a, p, the root-mean-square
    residual [m/s], their standard errors v_bl_err, a_err, p_err (None for
    a constant held fixed) and the degrees of freedom."""
    v_s = np.asarray(v_s, dtype=float)
    v_r = np.asarray(v_r, dtype=float)
    if len(v_s) < 2 or len(v_s) != len(v_r):
        raise ValueError("fit_recht_ipson needs at least two (v_s, v_r) pairs of equal length")
    if p is None:
        p_best = _golden(lambda q: _fit_v_bl(v_s, v_r, a, q)["rms_residual"], *P_RANGE, 1e-6)
        fit = _fit_v_bl(v_s, v_r, a, p_best)
    else:
        fit = _fit_v_bl(v_s, v_r, a, p)
    free = ["v_bl"] + (["a"] if a is None else []) + (["p"] if p is None else [])
    errors = _standard_errors(v_s, v_r, fit, free)
    for name in ("v_bl", "a", "p"):
        fit[f"{name}_err"] = errors.get(name)
    fit["dof"] = len(v_s) - len(free)
    return fit


def gather(run_dirs):
    """(striking velocity, residual velocity, exited) of perforation runs
    from their summary.json files, sorted by striking velocity."""
    rows = []
    for d in run_dirs:
        summary = json.loads((Path(d) / "summary.json").read_text())
        series = summary["metrics"]["series"]
        rows.append((abs(series["velocity_z_m_s"][0]),
                     summary["metrics"]["perforation"]["residual_velocity_m_s"],
                     summary["metrics"]["perforation"]["exited"], str(d)))
    rows.sort()
    return rows
