"""The experiment a run is compared with (&output reference, a JSON file)
and whether it applies to the run.

A reference may list the deck values its measurements were made at:

    "conditions": {"body(rod).velocity_z": -221.0, "body(rod).radius": 3.8e-3}

keys written as for `fsph sweep --set` (GROUP.KEY, GROUP(NAME).KEY or
GROUP(I).KEY). A run whose deck differs in one of them (a sweep variant at
another striking velocity, say) is not compared with it: the summary says
why instead of reporting an error against another experiment. A reference
without conditions applies to the deck that names it; a sweep drops it
from the variants that change a key (fsph.sweep)."""

import json
import math
import re
from pathlib import Path

from .errors import DeckError

_KEY = re.compile(r"^(\w+)(?:\((\w+)\))?\.(\w+)$")

#: Relative tolerance of a numeric condition [-].
CONDITION_TOLERANCE = 1e-9


def load(deck):
    """The reference JSON named by the deck (None without); a file that is
    not a JSON object is a DeckError naming it."""
    name = deck["output"]["reference"]
    if name is None:
        return None
    path = Path(deck["dir"]) / name
    try:
        reference = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise DeckError(deck["path"], "output", "reference", "a readable JSON file", f"{path}: {exc}") from None
    if not isinstance(reference, dict) or not isinstance(reference.get("conditions", {}), dict):
        raise DeckError(deck["path"], "output", "reference", "a JSON object (with 'conditions' an "
                        "object of deck keys, if any)", str(path))
    return reference


def deck_value(deck, spec):
    """The value of GROUP.KEY, GROUP(NAME).KEY or GROUP(I).KEY in a loaded
    deck; KeyError if the deck has no such group, item or key."""
    m = _KEY.match(spec)
    if not m:
        raise KeyError(spec)
    gname, selector, key = m.groups()
    group = deck[gname]
    if isinstance(group, list):
        if selector is None:
            item = group[0]
        elif selector.isdigit():
            item = group[int(selector) - 1]
        else:
            item = next(g for g in group if g.get("name") == selector)
    else:
        item = group
    return item[key]


def _same(a, b):
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        return math.isclose(a, b, rel_tol=CONDITION_TOLERANCE, abs_tol=0.0)
    return a == b


def applies(reference, deck):
    """(True, "") when every condition of the reference holds for the deck;
    (False, why) otherwise."""
    for spec, expected in reference.get("conditions", {}).items():
        try:
            value = deck_value(deck, spec)
        except (KeyError, IndexError, StopIteration):
            return False, f"the deck has no {spec} (a condition of the reference)"
        if not _same(value, expected):
            return False, f"{spec} is {value!r} here, {expected!r} in the reference"
    return True, ""
