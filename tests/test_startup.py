"""Checks of the starting state (fsph.startup): bodies that touch pass,
bodies that overlap by as little as part of a cell, cross a rigid plane or
have no mass are refused with the bodies named. The command-line side (exit
2, one line) is in test_cli_errors.py."""

import numpy as np
import pytest

from fsph import mesh
from fsph.errors import DeckError
from fsph.startup import check_starting_state

R, L = 1.0e-3, 4.0e-3


def _deck(names, boundaries=()):
    return {"path": "deck.nml", "body": [{"name": n, "geometry": "rod"} for n in names],
            "boundary": list(boundaries), "metrics": {"kind": "none"}}


def _pair(lower, upper):
    """Two bodies of the given kinds ('elements' or 'particles'): a rod
    0 <= z <= L and a tube R/2 <= r <= 2R standing on it at z = L + gap."""
    kinds = {"elements": (mesh.rod, 5, 20), "particles": (mesh.rod_particles, 5, 20)}

    def make(kind, radius, length, z_base, inner):
        gen, nr, nz = kinds[kind]
        return gen(radius, length, nr, nz, z_base=z_base, inner_radius=inner)
    return lambda gap: [(0, make(lower, R, L, 0.0, 0.0)), (1, make(upper, 2 * R, L, L + gap, 0.5 * R))]


KINDS = [("elements", "elements"), ("elements", "particles"), ("particles", "elements"),
         ("particles", "particles")]


@pytest.mark.parametrize("lower, upper", KINDS)
def test_touching_bodies_pass(lower, upper):
    check_starting_state(_deck(["rod", "tube"]), _pair(lower, upper)(0.0))


@pytest.mark.parametrize("lower, upper", KINDS)
def test_overlap_of_part_of_a_cell_is_refused(lower, upper):
    """The tube sinks 0.6 of the rod's axial cell (0.2 mm) into it."""
    with pytest.raises(DeckError, match=r"&body #\d: expected '(rod|tube)' clear of &body #\d"):
        check_starting_state(_deck(["rod", "tube"]), _pair(lower, upper)(-0.6 * L / 20))


def test_body_inside_another_is_refused():
    """A small rod wholly inside a large one: no boundary of either crosses
    the other's, the interior points find it."""
    inner = mesh.rod(0.3 * R, 0.3 * L, 2, 4, z_base=0.4 * L)
    outer = mesh.rod(R, L, 5, 20)
    with pytest.raises(DeckError, match=r"expected '(big|small)' clear of &body #\d \('(big|small)'\)"):
        check_starting_state(_deck(["big", "small"]), [(0, outer), (1, inner)])


def test_plane_tolerates_contact_and_refuses_crossing():
    plane = {"point": [0.0, 0.0], "normal": [0.0, 2.0]}       # the normal need not be unit
    check_starting_state(_deck(["rod"], [plane]), [(0, mesh.rod(R, L, 5, 20))])
    with pytest.raises(DeckError, match=r"part of it behind the plane, 0\.01 mm deep at r = "):
        check_starting_state(_deck(["rod"], [plane]), [(0, mesh.rod(R, L, 5, 20, z_base=-1e-5))])
    tilted = {"point": [0.0, 0.0], "normal": [-1.0, 1.0]}    # z >= r: the rod's corner is behind
    with pytest.raises(DeckError, match=r"&body #1: expected 'rod' in front of &boundary #1"):
        check_starting_state(_deck(["rod"], [tilted]), [(0, mesh.rod(R, L, 5, 20))])


def test_body_without_mass_is_refused():
    """Every node on the axis: the ring volume, hence the mass, is zero."""
    flat = mesh.rod(R, L, 2, 4)
    flat.x[:, 0] = 0.0
    with pytest.raises(DeckError, match=r"&body #1: expected a body with mass \('rod'"):
        check_starting_state(_deck(["rod"]), [(0, flat)])
    particles = mesh.rod_particles(R, L, 2, 4)
    particles.x[:, 0] = 0.0
    with pytest.raises(DeckError, match="a body with mass"):
        check_starting_state(_deck(["rod"]), [(0, particles)])
