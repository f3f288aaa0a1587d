"""Checks of the starting state, made before the first cycle: no body
without mass, no body crossing or behind a rigid plane, no two bodies
overlapping, no gmsh mesh in the wrong units, no bar-wave probe outside its
bodies. Each failure is a DeckError naming the bodies (and the plane),
with where it happens; a deck that fails them would otherwise run to its end
with a large energy error, or fail only once the run is over.

Overlap means that an interior point of one body (an element's centroid or
a particle's centre) lies inside another body: inside one of its triangles,
or within half a cell spacing of one of its particles. Bodies that only
touch (a projectile resting on a plate, joined bodies) pass: their interior
points stay at least half a cell away from the other body."""

from functools import cached_property

import numpy as np

from .errors import DeckError
from .mesh import Mesh, ring_volume
from .metrics import joined_bodies

#: Relative tolerance of "behind a plane", a fraction of the body's size [-].
PLANE_TOLERANCE = 1e-9
#: A gmsh body this many times larger than every generated body has its
#: coordinates in other units than mesh_scale says (millimetres read as
#: metres make it 1000 times larger) [-].
MESH_UNITS_RATIO = 100.0
#: A gmsh body larger than this, with no generated body to compare, is
#: warned about: impact bodies are millimetres to a metre or so [m].
LARGE_BODY = 10.0


def _where(x):
    return f"r = {1e3 * x[0]:.4g} mm, z = {1e3 * x[1]:.4g} mm"


class _Body:
    """One body's starting discretisation seen as a region: its points on
    the boundary or beyond (nodes or particle centres), its interior points
    (centroids or particle centres), and a test of whether points lie
    inside it."""

    def __init__(self, index, spec, disc):
        self.index, self.name = index, spec["name"]
        self.label = f"body #{index + 1}"
        self.disc = disc
        self.is_mesh = isinstance(disc, Mesh)
        self.points = disc.x
        if self.is_mesh:
            self.mass_volume = ring_volume(disc)
            reach = 0.0
        else:
            self.mass_volume = disc.ring_volume.sum()
            self._half = 0.5 * disc.spacing
            reach = self._half[:, None]     # a particle stands for a cell about its centre
        self.lo, self.hi = (self.points - reach).min(axis=0), (self.points + reach).max(axis=0)
        self.size = float(np.max(self.hi - self.lo))

    # the search structures only for bodies whose boxes meet another's
    @cached_property
    def interior(self):
        return self.disc.x[self.disc.conn].mean(axis=1) if self.is_mesh else self.disc.x

    @cached_property
    def _finder(self):
        # imported here: matplotlib.tri and scipy.spatial cost about 0.15 s
        # of a start-up that needs neither when no two bodies' boxes meet
        from matplotlib.tri import Triangulation
        from scipy.spatial import cKDTree
        if self.is_mesh:
            return Triangulation(self.disc.x[:, 0], self.disc.x[:, 1], self.disc.conn).get_trifinder()
        return cKDTree(self.disc.x)

    def contains(self, x):
        """Which of the points x (n, 2) lie inside this body."""
        if self.is_mesh:
            return self._finder(x[:, 0], x[:, 1]) >= 0
        dist, k = self._finder.query(x)
        return dist < self._half[k]

    def boxes_meet(self, other):
        return bool(np.all(self.lo < other.hi) and np.all(other.lo < self.hi))


def _check_mass(path, body):
    if not body.mass_volume > 0.0:
        raise DeckError(path, body.label, None, f"a body with mass ('{body.name}': its ring "
                        "volume 2 pi r A summed over its cells is zero, all of it on the axis "
                        "r = 0?)", f"{body.mass_volume:g} m^3")


def _check_planes(path, body, boundaries):
    for k, bc in enumerate(boundaries):
        n = np.asarray(bc["normal"], float)
        n = n / np.linalg.norm(n)
        depth = (body.points - np.asarray(bc["point"], float)) @ n
        worst = int(np.argmin(depth))
        if depth[worst] < -PLANE_TOLERANCE * body.size:
            raise DeckError(path, body.label, None,
                            f"'{body.name}' in front of &boundary #{k + 1} (the rigid plane "
                            f"through {list(bc['point'])} m facing along {list(bc['normal'])})",
                            f"{'all' if depth.max() < 0 else 'part'} of it behind the plane, "
                            f"{1e3 * -depth[worst]:.4g} mm deep at {_where(body.points[worst])}")


def _check_overlap(path, a, b):
    """Interior points of either body inside the other."""
    if not a.boxes_meet(b):
        return
    for inner, outer in ((a, b), (b, a)):
        inside = outer.contains(inner.interior)
        if inside.any():
            first = inner.interior[np.flatnonzero(inside)[0]]
            raise DeckError(path, inner.label, None,
                            f"'{inner.name}' clear of &{outer.label} ('{outer.name}') at the "
                            "start (bodies may touch, not overlap)",
                            f"{int(inside.sum())} of its cells inside it, the first at "
                            f"{_where(first)}")


def _check_mesh_units(path, bodies, specs, warnings):
    """A gmsh body MESH_UNITS_RATIO times larger than the largest generated
    body is an error naming its mesh_scale; one larger than LARGE_BODY
    with no generated body beside it, a warning."""
    read = [b for b in bodies if specs[b.index]["geometry"] == "gmsh"]
    made = [b for b in bodies if specs[b.index]["geometry"] != "gmsh"]
    for g in read:
        scale = specs[g.index]["mesh_scale"]
        if made:
            ref = max(made, key=lambda b: b.size)
            if g.size > MESH_UNITS_RATIO * ref.size:
                raise DeckError(path, g.label, "mesh_scale",
                                f"a scale giving '{g.name}' a size like the other bodies' (file "
                                "coordinates in millimetres need mesh_scale = 1e-3)",
                                f"{scale:g}: the mesh spans {g.size:.4g} m, "
                                f"{g.size / ref.size:.0f} times '{ref.name}' ({ref.size:.4g} m)")
        elif g.size > LARGE_BODY:
            warnings.append(f"&{g.label} ('{g.name}'): the gmsh mesh spans {g.size:.4g} m with "
                            f"mesh_scale = {scale:g}; file coordinates in millimetres need "
                            "mesh_scale = 1e-3")


def _check_probe(path, deck, bodies):
    """A bar-wave probe radius inside every body it samples (the metric's
    body and those joined to it): outside, the profile would be empty or
    taken from the nearest edge."""
    met = deck["metrics"]
    if met["kind"] != "bar_wave":
        return
    names = [b["name"] for b in deck["body"]]
    sampled = joined_bodies(deck, names.index(met["body"]) if met["body"] else 0)
    r = met["probe_radius"]
    for body in bodies:
        if body.index in sampled and not body.lo[0] <= r <= body.hi[0]:
            raise DeckError(path, "metrics", "probe_radius",
                            f"a radius inside the body it samples ('{body.name}' spans r = "
                            f"{1e3 * body.lo[0]:.4g} to {1e3 * body.hi[0]:.4g} mm)",
                            f"{1e3 * r:.4g} mm")


def check_starting_state(deck, discretisations):
    """Raise a DeckError if a body has no mass, lies behind or across a
    rigid plane, overlaps another body, is a gmsh mesh in the wrong units,
    or a bar-wave probe lies outside the bodies it samples; a gmsh body of
    implausible size adds to deck["warnings"]. discretisations: (body
    index, Mesh or ParticleLattice) for every body."""
    path = deck.get("path", "deck")
    bodies = [_Body(ib, deck["body"][ib], disc) for ib, disc in discretisations]
    _check_mesh_units(path, bodies, deck["body"], deck.setdefault("warnings", []))
    _check_probe(path, deck, bodies)
    for body in bodies:
        _check_mass(path, body)
        _check_planes(path, body, deck["boundary"])
    for i, a in enumerate(bodies):
        for b in bodies[i + 1:]:
            _check_overlap(path, a, b)
