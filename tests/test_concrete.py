"""Validation: the CRH 3.0 ogive rod (0.50 kg, 25.4 mm) through a 178 mm
slab of 48 MPa concrete (Hanchak et al. 1992; Xiao et al. 2012 section 3.4 and
Hu et al. 2013 section 4), HJC concrete with damage. Bars of the concrete issue:
606 m/s adaptive within 5 % of the experiment's 449 m/s; 1058 m/s within
3 % of 947 m/s in FEM with erosion, SPH and adaptive FEM-SPH. The adaptive
606 m/s and both 1058 m/s runs with elements are in CI; the pure SPH and
fixed-coupling runs (for the cost table of docs/validation.md) are slow
studies."""

import numpy as np
import pytest

from fsph.driver import run
from conftest import CASES, REFERENCE_DIGESTS, reference


def run_case(name, tmp_path_factory):
    out = tmp_path_factory.mktemp(name)
    summary = run(CASES / f"{name}.nml", out, quiet=True)
    summary["_output"] = out
    return summary


@pytest.fixture(scope="module")
def adaptive_606(tmp_path_factory):
    return run_case("concrete_606", tmp_path_factory)


@pytest.fixture(scope="module")
def fem_1058(tmp_path_factory):
    return run_case("concrete_1058_fem", tmp_path_factory)


@pytest.fixture(scope="module")
def adaptive_1058(tmp_path_factory):
    return run_case("concrete_1058", tmp_path_factory)


def residual_error_percent(summary, name):
    ref = reference(name)["perforation"]["residual_velocity_m_s"]
    v_r = summary["metrics"]["perforation"]["residual_velocity_m_s"]
    return 100.0 * (v_r - ref) / ref


def check_run(summary):
    """Completed; the projectile has gone through (its tip more than the
    slab thickness below the top face, and its rear past the far face:
    `exited`, so that the residual velocity is compared); axial momentum
    of the system (with what erosion removed) within 0.5 %; energy balance
    within 2 %."""
    assert summary["status"] == "completed", summary.get("failure")
    perf = summary["metrics"]["perforation"]
    assert perf["penetration_mm"] > 178.0 + 40.0
    assert perf["exited"]
    p = np.array(summary["metrics"]["series"]["momentum_z_N_s"])
    assert np.abs(p / p[0] - 1.0).max() < 0.005
    assert abs(summary["energy"]["max_relative_error"]) < 0.02


def check_perforation(summary, name, bar_percent):
    """check_run, and the residual velocity within the bar."""
    check_run(summary)
    assert abs(residual_error_percent(summary, name)) <= bar_percent


def test_606_adaptive_run(adaptive_606):
    check_run(adaptive_606)
    assert adaptive_606["n_converted"] > 0


@pytest.mark.xfail(strict=True, reason=(
    "measured 476.3 m/s (+6.1 %; 471.7, +5.1 %, while the hourglass term damped the slide "
    "line's corrections of the crater's particles, a drag removed 2026-11-28; 474.6, +5.7 %, "
    "with the axis backstop at half a particle's radius) once the SPH viscosity acts only in "
    "compression (the "
    "compression switch): the pairwise viscosity resisted the flow of the fully damaged "
    "concrete around the nose as a shear viscosity; the converged frictionless model lies "
    "near +7 % (docs/validation.md)"))
def test_606_adaptive_residual_velocity(adaptive_606):
    assert abs(residual_error_percent(adaptive_606, "concrete_606")) <= 5.0


def test_606_adaptive_damages_the_slab(adaptive_606):
    """Xiao et al. 2012 Fig. 13: fully damaged material around the channel, damage
    spreading far beyond it."""
    import h5py
    with h5py.File(adaptive_606["_output"] / "fsph.h5") as h5:
        snaps = h5["snapshots"]
        last = snaps[sorted(snaps)[-1]]
        damage = np.concatenate([last["damage"][...], last["particles/damage"][...]])
        r = np.concatenate([last["nodes"][...][last["connectivity"][...]].mean(axis=1)[:, 0],
                            last["particles/x"][...][:, 0]])
        body = np.concatenate([last["body"][...], last["particles/body"][...]])
    slab = body == 1
    assert damage[slab].max() == 1.0
    assert (damage[slab] >= 1.0).sum() > 100
    assert r[slab & (damage > 0.5)].max() > 4 * 12.7e-3


def test_1058_fem_erosion_residual_velocity(fem_1058):
    check_perforation(fem_1058, "concrete_1058", 3.0)
    er = fem_1058["erosion"]
    assert er["n_eroded"] > 0 and er["element_mass_kg"] > 0.0


def test_1058_adaptive_run_ends_in_the_stored_state(adaptive_1058):
    """The reference run of the slab (tests/conftest.py REFERENCE_DIGESTS):
    the summary's digest of the final state is the stored one."""
    assert adaptive_1058["state_digest"] in REFERENCE_DIGESTS["concrete_1058"]


def test_1058_adaptive_residual_velocity(adaptive_1058):
    check_perforation(adaptive_1058, "concrete_1058", 3.0)


@pytest.fixture(scope="module")
def sph_1058(tmp_path_factory):
    return run_case("concrete_1058_sph", tmp_path_factory)


@pytest.mark.slow
def test_1058_sph_residual_velocity(sph_1058):
    """Completed, through, energy within 2 %, residual velocity within 3 %
    of the experiment's (momentum: the next test)."""
    assert sph_1058["status"] == "completed", sph_1058.get("failure")
    assert sph_1058["metrics"]["perforation"]["penetration_mm"] > 178.0 + 40.0
    assert abs(sph_1058["energy"]["max_relative_error"]) < 0.02
    assert abs(residual_error_percent(sph_1058, "concrete_1058")) <= 3.0


@pytest.mark.slow
def test_1058_sph_conserves_momentum(sph_1058):
    """Axial momentum of rod and slab within 0.5 % at every snapshot
    (measured: round-off; -0.53 % while the mirror images' axial forces
    added up to a load on the axis, fsph_sph axis_resultant)."""
    p = np.array(sph_1058["metrics"]["series"]["momentum_z_N_s"])
    assert np.abs(p / p[0] - 1.0).max() < 0.005


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=(
    "measured -1244 kJ/kg against a hottest projectile particle of +1785 kJ/kg (-70 %): a particle "
    "of the steel nose's surface at the contact, at -10 GPa; from 100 to 200 us its booked energy "
    "fell 1381 kJ/kg while its own stress times its corrected strain rate gave +1782 kJ/kg: the "
    "energy equation charges the plain SPH rate conjugate to the momentum equation (exact "
    "conservation), the stress update the corrected one, and at an incomplete kernel they part; "
    "charging the corrected rate instead left it at -809 kJ/kg and the run +2.6 % "
    "(docs/validation.md, concrete, fields)"))
def test_1058_sph_projectile_has_no_particle_colder_than_the_reference_state(sph_1058):
    """The family's bar on the projectile of the pure SPH run: no particle
    below minus 1 % of its hottest particle's specific internal energy
    (along an isentrope from rho0, e = 0 compression and tension both
    raise e; plastic and viscous work only add)."""
    import h5py
    with h5py.File(sph_1058["_output"] / "fsph.h5") as h5:
        snaps = h5["snapshots"]
        part = snaps[sorted(snaps)[-1]]["particles"]
        rod = part["body"][...] == 0
        e = part["internal_energy"][...][rod]
    assert e.min() >= -0.01 * e.max()


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="measured 489.6 m/s, +9.0 % against 449 (Xiao et al. 2012 with fixed "
                   "coupling: 466; 481.7 m/s before the hourglass term stopped damping the slide "
                   "line's corrections, 2026-11-28; 472.8 m/s before the SPH viscosity's compression switch, which "
                   "removed the viscous drag of the fully damaged crater); the converged "
                   "frictionless model lies near +7 % (docs/validation.md)")
def test_606_fixed_residual_velocity(tmp_path_factory):
    check_perforation(run_case("concrete_606_fixed", tmp_path_factory), "concrete_606", 5.0)


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="measured 480.5 m/s, +7.0 % against 449 on the mesh refined "
                   "by 1.6 (26 432 elements, 10 188 converted; 476.3 m/s, +6.1 %, on the case's "
                   "mesh; 478.7 and 471.7 m/s before the contact changes of 2026-11-28): the "
                   "converged frictionless model lies near +7 % (docs/validation.md)")
def test_606_adaptive_refined_mesh_residual_velocity(tmp_path_factory):
    """The convergence check of the 606 m/s case: the deck with every cell
    count refined as benchmarks/concrete_study.py --mesh-study does."""
    import sys
    sys.path.insert(0, str(CASES.parent / "benchmarks"))
    from concrete_study import refined_deck
    out = tmp_path_factory.mktemp("concrete_606_fine")
    summary = run(refined_deck(CASES / "concrete_606.nml", out), out / "run", quiet=True)
    check_perforation(summary, "concrete_606", 5.0)


def test_1058_decks_differ_only_in_method():
    """The three methods of the table of Hu et al. 2013 run the same problem: the
    decks agree on materials, bodies, outputs and metrics; only the mode,
    title, the method's own group (&convert, &erosion) and the resolution
    of the SPH lattices (twice as fine as the quadrilaterals, so there are
    about as many particles as elements) differ."""
    from fsph import deck as deck_module
    decks = {name: deck_module.load(CASES / f"{name}.nml")
             for name in ("concrete_1058", "concrete_1058_fem", "concrete_1058_sph")}
    base = decks["concrete_1058"]
    assert [d["control"]["mode"] for d in decks.values()] == ["adaptive", "fem", "sph"]
    assert decks["concrete_1058_fem"]["erosion"]["enabled"]
    assert decks["concrete_1058_fem"]["erosion"]["principal_strain"] == 1.5
    for d in decks.values():
        for group in ("material", "output", "metrics", "contact", "sph"):
            assert d[group] == base[group], group
        skip = ("discretisation", "n_radial", "n_axial", "n_coarse")
        assert ([{k: v for k, v in b.items() if k not in skip} for b in d["body"]]
                == [{k: v for k, v in b.items() if k not in skip} for b in base["body"]])
        factor = 2 if d["control"]["mode"] == "sph" else 1
        for b, b0 in zip(d["body"], base["body"]):
            assert [b[k] for k in skip[1:]] == [factor * b0[k] for k in skip[1:]]
        assert d["control"]["end_time"] == base["control"]["end_time"]
