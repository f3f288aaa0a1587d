"""Property-based robustness of deck reading: the shipped decks, mutated
(keys dropped, duplicated, retyped; values out of range, non-finite, scaled
by units mistakes; groups repeated; syntax broken; empty files; binary
garbage), always end either in a valid set-up or in a DeckError whose text is
one line naming the file. Never a traceback of another kind, a hang or a
crash of the solver."""

import math
import os

import f90nml
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import fsph
from fsph import deck as deck_module
from fsph.errors import DeckError
from conftest import CASES

DECKS = sorted(p for p in CASES.glob("*.nml"))
SCHEMA_KEYS = sorted({(g, k) for g, grp in deck_module.SCHEMA.items() for k in grp.keys})

VALUES = st.one_of(
    st.integers(min_value=-10**12, max_value=10**12),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, -1, 1e-30, 1e30, 1e3, 1e-3, 0.5, 2**31, "", "x", "rod", "fem", True, False]),
    st.text(max_size=12),
    st.lists(st.floats(allow_nan=False, allow_infinity=False, width=32), min_size=0, max_size=3),
)


@st.composite
def mutated_deck(draw):
    path = draw(st.sampled_from(DECKS))
    text = path.read_text()
    kind = draw(st.sampled_from(["value", "drop", "add", "dup_group", "text", "empty", "garbage",
                                 "scale"]))
    if kind == "empty":
        return path.name, ""
    if kind == "garbage":
        return path.name, draw(st.binary(max_size=200)).decode("latin-1")
    if kind == "text":
        pos = draw(st.integers(0, max(len(text) - 1, 0)))
        cut = draw(st.integers(0, 20))
        insert = draw(st.sampled_from(["", "&", "/", "=", "'", ",", "(", "!", "&body", "\x00", "1e999"]))
        return path.name, text[:pos] + insert + text[pos + cut:]
    nml = f90nml.reads(text)
    groups = list(nml.keys())
    g = draw(st.sampled_from(groups))
    target = nml[g] if not isinstance(nml[g], list) else nml[g][0]
    keys = list(target.keys())
    if kind == "drop" and keys:
        del target[draw(st.sampled_from(keys))]
    elif kind == "value" and keys:
        target[draw(st.sampled_from(keys))] = draw(VALUES)
    elif kind == "scale" and keys:
        k = draw(st.sampled_from(keys))
        if isinstance(target[k], (int, float)) and not isinstance(target[k], bool):
            target[k] = target[k] * draw(st.sampled_from([1e3, 1e-3, 1e6, -1, 0]))
    elif kind == "add":
        gk = draw(st.sampled_from(SCHEMA_KEYS + [("control", "bogus")]))
        if gk[0] in nml:
            tgt = nml[gk[0]] if not isinstance(nml[gk[0]], list) else nml[gk[0]][0]
            tgt[gk[1]] = draw(VALUES)
    elif kind == "dup_group":
        text = text + "\n" + text[text.find("&" + g):].split("/", 1)[0] + "/\n"
        return path.name, text
    try:
        return path.name, str(nml)
    except Exception:
        return path.name, text


# 1000 fixed examples in CI; FSPH_FUZZ_EXAMPLES=N FSPH_FUZZ_RANDOM=1 for a longer, random hunt
@settings(max_examples=int(os.environ.get("FSPH_FUZZ_EXAMPLES", "1000")), deadline=None,
          derandomize=os.environ.get("FSPH_FUZZ_RANDOM", "0") != "1",
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(mutated_deck())
def test_mutated_decks_fail_cleanly_or_set_up(tmp_path_factory, case):
    name, text = case
    folder = tmp_path_factory.mktemp("fuzz")
    (folder / "references").mkdir()
    for ref in (CASES / "references").glob("*.json"):
        (folder / "references" / ref.name).write_text(ref.read_text())
    path = folder / name
    path.write_bytes(text.encode("utf-8", "surrogatepass"))
    try:
        deck = deck_module.load(path)
        # a valid deck must set up, or fail the start-up checks (bodies
        # overlapping, behind a plane, without mass) with a deck error
        sim = fsph.Simulation(deck)
    except DeckError as err:
        message = str(err)
        assert "\n" not in message
        assert name in message
        event("clean deck error")
        return
    event("valid set-up")
    assert sim.n_elements + sim.n_particles > 0
    assert math.isfinite(sim.dt) and sim.dt > 0
