"""The layers of docs/method.md ("Architecture") hold in the code: every
Fortran module of src_f90/ (and every generated one it uses) is in the
table, a module uses only modules of its own layer or below, and below
layer 3 no module but fsph_state (which declares it) names simulation_t."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def documented_layers():
    """{module: layer} from the layer table of docs/method.md: the
    backquoted fsph_ names of each row's modules cell, parenthetical
    remarks (which name other modules and types) left out."""
    text = (ROOT / "docs" / "method.md").read_text()
    start = text.index("| layer | modules |")
    layers = {}
    for line in text[start:].splitlines()[2:]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in line.strip("|").split("|")]
        layer = int(cells[0].split(".")[0])
        modules = cells[1]
        while True:
            bare = re.sub(r"\([^()]*\)", "", modules)
            if bare == modules:
                break
            modules = bare
        for name in re.findall(r"`(fsph_\w+)`", modules):
            assert name not in layers, f"{name} is in two layers"
            layers[name] = layer
    return layers


def module_sources():
    """{module: (set of fsph_ modules it uses, its code without comments)}
    over src_f90/*.f90 and the templates *.f90.in."""
    sources = {}
    for path in sorted((ROOT / "src_f90").glob("*.f90*")):
        source = path.read_text()
        used = {u.lower() for u in re.findall(r"^\s*use\s+(fsph_\w+)", source, re.M | re.I)}
        code = "\n".join(line.split("!", 1)[0] for line in source.splitlines())
        for name in re.findall(r"^\s*module\s+(fsph_\w+)\s*$", source, re.M | re.I):
            sources[name.lower()] = (used, code)
    return sources


LAYERS = documented_layers()
SOURCES = module_sources()
USES = {module: used for module, (used, _) in SOURCES.items()}


def test_the_table_is_read():
    assert LAYERS["fsph_kinds"] == 0 and LAYERS["fsph_api"] == 4
    assert len(USES) >= 30


@pytest.mark.parametrize("module", sorted(USES))
def test_module_is_in_the_table(module):
    assert module in LAYERS, f"{module} (src_f90/) is in no layer of docs/method.md"


@pytest.mark.parametrize("module", sorted(USES))
def test_module_uses_only_its_layer_or_below(module):
    layer = LAYERS.get(module)
    if layer is None:
        pytest.skip("not in the table (the test above fails)")
    for used in sorted(USES[module]):
        assert used in LAYERS, f"{module} uses {used}, which is in no layer of docs/method.md"
        assert LAYERS[used] <= layer, (f"{module} (layer {layer}) uses {used} "
                                       f"(layer {LAYERS[used]})")


@pytest.mark.parametrize("module", sorted(m for m in USES if m != "fsph_state" and LAYERS.get(m, 0) < 3))
def test_only_the_run_and_the_api_see_the_whole_state(module):
    """docs/method.md, "Parts, not the whole": below layer 3 a routine
    receives the parts of the state it touches, never simulation_t
    (fsph_state, which declares it, aside)."""
    assert not re.search(r"\bsimulation_t\b", SOURCES[module][1], re.I), \
        f"{module} (layer {LAYERS.get(module)}) uses simulation_t"
