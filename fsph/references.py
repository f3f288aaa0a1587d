"""The experiment a run is compared with (&output reference, a JSON file)
and whether it applies to the run.

A reference may list the deck values its measurements were made at:

    "conditions": {"body(rod).velocity_z": -221.0, "body(rod).radius": 3.8e-3}

keys written as for `fsph sweep --set` (GROUP.KEY, GROUP(NAME).KEY or
GROUP(I).KEY). A condition may also be a least value,

    "conditions": {"control.end_time": {"at_least": 6.0e-5}}

for a value measured once a process has ended (a Taylor rod's final
shape, a residual velocity): any later end time gives it. A run whose
deck differs in one of them (a sweep variant at another striking
velocity, a run cut short, say) is not compared with it: the summary says
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
    not a JSON object is a DeckError naming it, and so is one whose entries
    are not of the format (check)."""
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
    check(reference, path)
    return reference


#: The entries of a reference that no run stores: the bars `fsph report`
#: holds the runs to, read afresh from the reference at each report.
BAR_ENTRIES = ("acceptance", "acceptance_by_mode")


#: The entries of a reference that are not metric groups: its source
#: (text), its conditions (not_applied_because), the bars of `fsph report`
#: (BAR_ENTRIES, checked there) and a sweep's measured ballistic curve
#: (fsph.sweep.experiment_points: lists of striking and residual velocities
#: [m/s]). Every other entry is a metric group: an object of measured
#: values, as the run's metrics of that group name them (fsph.metrics).
SOURCE, CONDITIONS, BALLISTIC = "source", "conditions", "ballistic"
BALLISTIC_KEYS = ("striking_velocity_m_s", "residual_velocity_m_s")


def _json_text(value, limit=60):
    """A value as the JSON file writes it, cut to `limit` characters."""
    text = json.dumps(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _refused(path, key, expected, value):
    """The DeckError of an entry `key` of the reference file at `path`
    that is not what the format allows (one line: file, key, expected,
    the value as written)."""
    return DeckError(path, None, key, f"{expected}, got {_json_text(value)}")


def _number(value):
    """Whether a JSON value is a finite number (not true or false)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def check(reference, path):
    """Refuse (DeckError naming the file and the key) a reference whose
    entries are not of the format: a measured value that is not a finite
    number other than 0 (the errors are relative to it), a source that is
    not text, a condition that names no deck key or whose value is no deck
    value, a ballistic curve that is not two lists of finite numbers of
    one length. The bars are checked where `fsph report` reads them."""
    for group, values in reference.items():
        if group == SOURCE:
            if not isinstance(values, str):
                raise _refused(path, group, "text (where the values come from)", values)
        elif group == CONDITIONS:
            for spec, expected in values.items():
                _check_condition(path, spec, expected)
        elif group == BALLISTIC:
            _check_ballistic(path, values)
        elif group not in BAR_ENTRIES:
            if not isinstance(values, dict):
                raise _refused(path, group, "an object of measured values (a metric group), "
                               "'source', 'conditions' or 'ballistic'", values)
            for key, value in values.items():
                if not _number(value) or value == 0:
                    raise _refused(path, f"{group}.{key}", "a finite number other than 0 (a "
                                   "measured value: errors are relative to it)", value)


#: The key of a condition that is a least value.
AT_LEAST = "at_least"


def _check_condition(path, spec, expected):
    """A condition: a KEY_SPEC and a deck value (a number, text, true or
    false, null for unset, or a list of numbers), or {AT_LEAST: a finite
    number}."""
    key = f"conditions.{spec}"
    if not deck_module.KEY_SPEC.match(spec):
        raise _refused(path, key, "a deck key GROUP.KEY, GROUP(I).KEY or GROUP(NAME).KEY",
                       spec)
    if isinstance(expected, dict):
        ok = set(expected) == {AT_LEAST} and _number(expected[AT_LEAST])
    elif isinstance(expected, list):
        ok = all(_number(v) for v in expected)
    else:
        ok = expected is None or isinstance(expected, (str, bool)) or _number(expected)
    if not ok:
        raise _refused(path, key, "a deck value (a finite number, text, true or false, null "
                       f"for unset, or a list of numbers) or {{\"{AT_LEAST}\": a finite number}}",
                       expected)


def _check_ballistic(path, curve):
    """A ballistic curve: an object of BALLISTIC_KEYS, lists of finite
    numbers [m/s] of one length."""
    if not isinstance(curve, dict) or set(curve) - set(BALLISTIC_KEYS):
        raise _refused(path, BALLISTIC, f"an object of {' and '.join(BALLISTIC_KEYS)}", curve)
    for key, values in curve.items():
        if not isinstance(values, list) or not all(_number(v) for v in values):
            raise _refused(path, f"{BALLISTIC}.{key}", "a list of finite numbers [m/s]", values)
    if len({len(v) for v in curve.values()}) > 1:
        raise _refused(path, BALLISTIC, f"{' and '.join(BALLISTIC_KEYS)} of one length",
                       {key: len(v) for key, v in curve.items()})


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


def _at_least(value, bound):
    """Whether a deck value is a number at least `bound` (within
    CONDITION_TOLERANCE)."""
    return _number(value) and (value >= bound or _same(value, bound))


def not_applied_because(reference, deck):
    """Why the reference does not apply to the deck: the first condition
    that does not hold; "" when every one holds (it applies)."""
    for spec, expected in reference.get("conditions", {}).items():
        try:
            value = deck_value(deck, spec)
        except (KeyError, DeckError):
            return f"the deck has no single {spec} (a condition of the reference)"
        if isinstance(expected, dict):
            if not _at_least(value, expected[AT_LEAST]):
                return f"{spec} is {value!r} here, at least {expected[AT_LEAST]!r} in the reference"
        elif not _same(value, expected):
            return f"{spec} is {value!r} here, {expected!r} in the reference"
    return ""
