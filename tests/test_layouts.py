"""One source for the layouts shared by the solver and the package
(fsph/layouts.py): the solver is built from it, refuses to run with a
package of other layouts, and the files name what they hold by it."""

import h5py
import numpy as np
import pytest

import fsph
from fsph import checkpoint, layouts
from fsph import deck as deck_module
from fsph.errors import FsphError
from fsph.simulation import _api

from conftest import rod_deck


def test_the_solver_is_built_from_these_layouts():
    assert int(_api.get_layout_digest()) == layouts.digest()


def test_a_package_of_other_layouts_is_refused(write_deck, monkeypatch):
    """A stale build (the Python layouts changed, the solver not rebuilt)
    stops at set-up with a clear error instead of misreading arrays."""
    deck = deck_module.load(write_deck(rod_deck()))
    monkeypatch.setattr(layouts, "digest", lambda: -1)
    with pytest.raises(FsphError, match="rebuild the package"):
        fsph.Simulation(deck)


def test_codes_and_names_are_unique_and_every_code_has_a_text():
    for table in (layouts.STATUS, layouts.PHASES, layouts.HISTORY_COLUMNS, layouts.PROPERTIES,
                  layouts.STRENGTH_MODELS, layouts.EOS_MODELS, layouts.CONVERSION_CRITERIA):
        names = [row[1] if table is layouts.STATUS else row[0] for row in table]
        assert len(set(names)) == len(names)
    codes = [row[0] for row in layouts.STATUS]
    assert codes == list(range(len(codes)))
    assert all(layouts.status_text(c) and not layouts.status_text(c).startswith("status ")
               for c in codes)
    for names in (layouts.CHECKPOINT_REAL, layouts.CHECKPOINT_INT, layouts.CHECKPOINT_REAL_SCALARS,
                  layouts.CHECKPOINT_INT_SCALARS, layouts.NODE_FIELDS, layouts.ELEMENT_FIELDS,
                  layouts.PARTICLE_FIELDS, layouts.SNAPSHOT_SCALARS):
        assert len(set(names)) == len(names)


def test_checkpoint_holds_named_datasets_and_scalars(write_deck, tmp_path):
    """The checkpoint names every array and scalar (layouts), and names
    only those; a restore reads them back to the same state."""
    deck = deck_module.load(write_deck(rod_deck(control="mode = 'adaptive'\n end_time = 2.0e-6")))
    sim = fsph.Simulation(deck)
    sim.advance(1.0e-6, land=False)
    path = checkpoint.save(sim, tmp_path / "ckpt.h5")
    with h5py.File(path) as h5:
        assert h5.attrs["format"] == checkpoint.FORMAT == 9
        assert set(h5["scalars"].attrs) == set(layouts.CHECKPOINT_REAL_SCALARS
                                              + layouts.CHECKPOINT_INT_SCALARS)
        assert h5["scalars"].attrs["cycle"] == sim.cycle
        assert h5["scalars"].attrs["time"] == sim.time
        stored = []
        h5["state"].visititems(lambda n, o: stored.append(n) if isinstance(o, h5py.Dataset) else None)
        assert {"nodes/x", "elements/conn", "elements/rho"} <= set(stored)
        assert set(stored) <= set(layouts.CHECKPOINT_REAL + layouts.CHECKPOINT_INT)
        np.testing.assert_array_equal(h5["state/nodes/x"][...].T, sim.snapshot()["x"])
    restored = fsph.Simulation(deck)
    checkpoint.restore(restored, path)
    assert checkpoint.state_digest(restored) == checkpoint.state_digest(sim)


def test_history_total_does_not_depend_on_how_often_it_is_recorded(tmp_path):
    """The full-step energy books that the time-centred total pairs with
    the half-step kinetic energy are summed only before the cycles a
    record may follow; the adaptive Taylor rod cut to 4 us (conversions,
    whose heat joins those books, from cycle 35) recorded every cycle and
    every 10 cycles has the same total, to the bit, at every record the
    two share."""
    from conftest import CASES
    text = (CASES / "taylor_armco.nml").read_text().replace("end_time = 60.0e-6", "end_time = 4.0e-6")
    text = text.replace("reference = 'references/", f"reference = '{CASES}/references/")
    totals = []
    for every in (1, 10):
        path = tmp_path / f"every_{every}.nml"
        path.write_text(text.replace("  n_snapshots = 16", f"  n_snapshots = 1\n  history_every = {every}"))
        sim = fsph.Simulation(deck_module.load(path))
        sim.advance(4.0e-6)
        records = sim.drain_history()
        col = {name: k for k, (name, _, _) in enumerate(layouts.HISTORY_COLUMNS)}
        totals.append(dict(zip(records[:, col["cycle"]].astype(int), records[:, col["total"]])))
    assert sim.conversion()["heat_J"] > 0.0
    shared = sorted(set(totals[0]) & set(totals[1]))
    assert len(shared) > 20
    assert [totals[0][c] for c in shared] == [totals[1][c] for c in shared]


def test_history_total_is_the_budget_the_solver_sums(write_deck):
    """The time history's columns are the layout's; its total is the sum
    of the budget's terms with the internal energy centred in time, the
    mean of its values at the step's two ends (a record every cycle: the
    record before holds the start's; docs/method.md, "The energy
    balance"), and the energy report reads the same budget."""
    deck = deck_module.load(write_deck(rod_deck(control="end_time = 2.0e-6", output="history_every = 1")))
    sim = fsph.Simulation(deck)
    sim.advance(2.0e-6)
    records = sim.drain_history()
    assert records.shape[1] == len(layouts.HISTORY_COLUMNS)
    col = {name: k for k, (name, _, _) in enumerate(layouts.HISTORY_COLUMNS)}
    np.testing.assert_array_equal(records[:, col["cycle"]], np.arange(len(records)))
    assert np.all(records[:, col["eroded"]] == 0.0)
    internal = records[:, col["internal"]]
    centred = np.concatenate([internal[:1], 0.5 * (internal[:-1] + internal[1:])])
    terms = centred + sum(records[:, col[name]] for name in layouts.ENERGY_COLUMNS[:-1] if name != "internal")
    np.testing.assert_allclose(records[:, col["total"]], terms, rtol=1e-14)
    # centred, the total is not the plain sum of the columns while energy
    # moves from motion into strain
    plain = sum(records[:, col[name]] for name in layouts.ENERGY_COLUMNS[:-1])
    assert np.abs(records[:, col["total"]] - plain).max() > 1e-6 * records[0, col["total"]]
    assert records[-1, col["time"]] == sim.time
    energies = sim.energies()
    assert energies["total"] == records[-1, col["total"]]
    assert energies["kinetic"] > 0.0 and energies["internal"] > 0.0
