"""Shared helpers: paths and small decks written on the fly."""

import json
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
CASES = REPO / "cases"

# Digest (fsph.checkpoint.state_digest) of the final state of each reference
# run (tests/test_runs.py advances the default case to its end in one call;
# the plate and concrete validations check the digest in their runs'
# summaries, the same state through the driver), measured with the release build
# (gfortran -O3) before the refactor that made the state an instance. The
# state does not depend on the thread count. A change meant to alter the
# results must re-measure the validations and update these with it. The
# material history grew by two rows (failed, melted: zero in these runs).
# Re-measured 2026-11-26 after the mirror images' frame-independent heat
# the Riemann contact between particle bodies and the elements'
# trapezoidal viscous work (docs/validation.md). The books grew by one
# scalar (the rigid planes' impulse, a diagnostic): without it the three
# states hash to the digests before (1e9b4a1f..., 2a045a7c..., 543c8e8c...);
# then by one array (the elements' persistent ids): without it they hash to
# 6335044f..., dac93c0c..., 38358ffd...; then by one material history row
# (plastic work): without it they hash to 0ad13e8d..., b93e4429..., 22fbae00...;
# then by three rows (viscous, hourglass and contact work): without them they hash
# to 32d3d3c1..., c50fc352..., 4b7065f7.... Re-measured 2026-11-26 after the
# particles' axis and anvil backstops moved to their radius and each body's
# axial resultant of the axis images was removed (docs/validation.md):
# before, 53be78ad..., 8f153020..., ec35eeaa.... Re-measured 2026-11-27 after
# the mirror images across the anvil took their particle's compression
# switch (the other two have no such images: unchanged); before,
# taylor_armco 31ed9818.... The particles' ids (kept since particles are
# renumbered in spatial order, from 4 096 of them after a conversion) enter
# the digest only once they differ from the particles' numbers: none of
# these runs renumbers, and their digests are those before the ids.
#
# The plate and concrete runs call the host's math library (pow, log and exp
# of the Johnson-Cook and HJC models), whose last bits depend on the code
# path it picks for the processor: glibc chooses among FMA, AVX and SSE2
# variants of exp, log and pow by the CPU's features. These two runs
# therefore have one state per host kind, all from the same source. The
# digests, in order: the Intel Xeon hosts where they were first stored; an
# AMD EPYC guest with AVX2 and FMA but no AVX-512 (2026-11-27: the same plate
# state as the Xeon's, another concrete state, for a cause not pinned down);
# that guest with glibc held to its SSE2 paths
# (GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2,-FMA,-FMA4,-AVX), which changes both.
# The Taylor rod (elastic-perfectly-plastic Armco) is the same on all. A
# host with yet another state fails here; its digest is added only once the
# code at the stored one is shown to give it there.
REFERENCE_DIGESTS = {
    "taylor_armco": ("2da700f26a7fb1357d105f9c95a067f997aa54e70e00e0094451bc293f40709a",),
    "al_plate_508": ("b0f8fc1c0f89bb5a656f9d69af65e901c8eed250061557c7b021fce652eb2cdd",
                     "8f9d604300c715b9fc94611c20fd2eba617d5e8a22a7e8a2445334b5e58cbf22"),
    "concrete_1058": ("a4de5c91b218811e85af360fae03631623b2214da8acd3ee622962d7ad474e35",
                      "7142ad813c181afed69e8448dc23175f7d412406aa9e387e1814018acb3cb405",
                      "ab9b54b1d2b58b95ec42216036a7131d669dd8ea5ff76a9fad08316b93f41c0f"),
}


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
