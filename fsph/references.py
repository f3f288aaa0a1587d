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

import hashlib
import json
import math
from pathlib import Path

from . import deck as deck_module
from .errors import DeckError

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


#: The entries of a reference that no run stores: the bars `fsph report`
#: holds the runs to, read afresh from the reference at each report.
BAR_ENTRIES = ("acceptance", "acceptance_by_mode")


def digest(reference):
    """SHA-256 (hex) of what a run takes from its reference (None
    without one): the values and conditions, not the bars (BAR_ENTRIES),
    written as canonical JSON (keys sorted), so a reference rewritten
    with the same content has the same digest."""
    if reference is None:
        return None
    kept = {key: value for key, value in reference.items() if key not in BAR_ENTRIES}
    return hashlib.sha256(json.dumps(kept, sort_keys=True).encode()).hexdigest()


def run_inputs(deck_text, reference):
    """What a run's results rest on besides fsph: the digests of the
    deck's text (deck.text_digest) and of its reference (digest), as
    summary.json keeps them ('inputs'); a stored run is one of the deck as
    it is now only where the two are the same (fsph.report)."""
    return {"deck_sha256": deck_module.text_digest(deck_text),
            "reference_sha256": digest(reference)}


def deck_value(deck, spec):
    """The value of a KEY_SPEC (GROUP.KEY, GROUP(I).KEY or GROUP(NAME).KEY,
    as for --set) in a loaded deck; KeyError or DeckError if the deck has
    no such group, instance or key."""
    m = deck_module.KEY_SPEC.match(spec)
    if not m:
        raise KeyError(spec)
    gname, selector, key = m.group(1).lower(), m.group(2), m.group(3).lower()
    items = deck[gname] if isinstance(deck[gname], list) else [deck[gname]]
    return items[deck_module.group_instance(deck["path"], gname, selector, key, items)][key]


def _same(a, b):
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        return math.isclose(a, b, rel_tol=CONDITION_TOLERANCE, abs_tol=0.0)
    return a == b


def not_applied_because(reference, deck):
    """Why the reference does not apply to the deck: the first condition
    that does not hold; "" when every one holds (it applies)."""
    for spec, expected in reference.get("conditions", {}).items():
        try:
            value = deck_value(deck, spec)
        except (KeyError, DeckError):
            return f"the deck has no single {spec} (a condition of the reference)"
        if not _same(value, expected):
            return f"{spec} is {value!r} here, {expected!r} in the reference"
    return ""
