"""The Taylor rod (Armco iron, 221 m/s) in FEM mode: the baseline run.

No accuracy bar for FEM alone (the adaptive method must beat it); the run
must reach 80 us or stop cleanly, and report L/D/W and its energy error.
"""

import pytest

from fsph.driver import run
from conftest import CASES


@pytest.fixture(scope="module")
def taylor_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("taylor_fem")
    return run(CASES / "taylor_armco_fem.nml", out, quiet=True)


def test_taylor_reaches_end_or_stops_cleanly(taylor_run):
    if taylor_run["status"] == "failed":
        assert taylor_run["failure"]["message"]
    else:
        assert taylor_run["end_time_s"] == pytest.approx(80e-6, rel=1e-12)
    assert taylor_run["n_elements"] == 2680


def test_taylor_reports_lengths(taylor_run):
    lengths = taylor_run["metrics"]["taylor"]
    l0, d0 = 25.4, 7.6
    # the rod shortens and mushrooms; W lies between the original and the
    # maximum diameter
    assert lengths["L_mm"] < l0
    assert lengths["D_mm"] > d0
    assert d0 < lengths["W_mm"] < lengths["D_mm"]
    comparison = taylor_run["reference"]["comparison"]["taylor"]
    assert set(comparison) >= {"L_mm", "D_mm", "W_mm"}


def test_taylor_energy_balance(taylor_run):
    """The anvil is rigid and fixed: total energy is conserved up to the
    discrete loss of the impacting face nodes; 1 % bounds it."""
    assert abs(taylor_run["energy"]["relative_error"]) < 0.01
