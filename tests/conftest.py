"""Shared helpers: paths and small decks written on the fly."""

import json
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
CASES = REPO / "cases"


def reference(name):
    """Reference values kept beside the decks (cases/references/NAME.json)."""
    return json.loads((CASES / "references" / f"{name}.json").read_text())


def rod_deck(control="", material=None, body="", boundary=True, output="", metrics=""):
    """Text of a small deck: an elastic steel rod falling on a rigid plane."""
    material = material if material is not None else (
        "name = 'steel'\n library = 'steel_elastic_bar'")
    text = f"""
&control
 title = 'test rod'
 end_time = 1.0e-6
 {control}
/
&material
 {material}
/
&body
 name = 'rod'
 material = 'steel'
 radius = 1.0e-3
 length = 4.0e-3
 n_radial = 3
 n_axial = 12
 velocity_z = -50.0
 {body}
/
&output
 n_snapshots = 2
 n_progress = 2
 {output}
/
"""
    if boundary:
        text += "&boundary\n type = 'rigid_plane'\n point = 0.0, 0.0\n normal = 0.0, 1.0\n/\n"
    if metrics:
        text += f"&metrics\n {metrics}\n/\n"
    return text


@pytest.fixture
def write_deck(tmp_path):
    def _write(text, name="deck.nml"):
        path = tmp_path / name
        path.write_text(text)
        return path
    return _write
