"""Validation: the Taylor rod (Armco iron, 221 m/s) in pure-SPH mode against
Johnson & Holmquist's experiment, at the bar of the SPH issue: L, D, W each
within 6 %, energy error below 3 %, the run reaching 80 us."""

import pytest

from fsph.driver import run
from conftest import CASES, reference


@pytest.fixture(scope="module")
def taylor_sph(tmp_path_factory):
    out = tmp_path_factory.mktemp("taylor_sph")
    return run(CASES / "taylor_armco_sph.nml", out, quiet=True)


def test_taylor_sph_reaches_end(taylor_sph):
    assert taylor_sph["status"] == "completed"
    assert taylor_sph["end_time_s"] == pytest.approx(80e-6, rel=1e-12)
    assert taylor_sph["n_particles"] == 2680


@pytest.mark.parametrize("key", ["L_mm", "D_mm", "W_mm"])
def test_taylor_sph_against_experiment(taylor_sph, key):
    ref = reference("taylor_armco")["taylor"][key]
    got = taylor_sph["metrics"]["taylor"][key]
    assert abs(got - ref) / ref < 0.06, f"{key}: {got:.3f} vs {ref}"


def test_taylor_sph_energy(taylor_sph):
    assert abs(taylor_sph["energy"]["relative_error"]) < 0.03
