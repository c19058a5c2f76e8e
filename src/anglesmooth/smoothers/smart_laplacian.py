"""Smart (constrained) Laplacian smoothing with the minimum angle as constraint.

Reference: L. A. Freitag, "On combining Laplacian and optimization-based mesh
smoothing techniques", AMD Trends in Unstructured Mesh Generation 220 (1997)
37-43, as described in Sections 2.2 and 5.2 of Zhou & Shimada (2000): compute
the minimum angle of the cells around the node and the Laplacian position;
move there if the minimum angle of those cells does not decrease, "or moves
only a fraction of the calculated amount of displacement" -- here the move
halved once, then twice, the first that does not lower it -- else stay.
Quad corners count ``min(angle, 180 - angle)``.  The local score ranks every
position with an invalid incident cell (inverted, degenerate, a non-convex
quad: a reflex corner is the worst quality there is) below every valid one,
fewer inverted cells first, then fewer invalid ones, so this method is
guarded by construction; ``guard`` is accepted for a uniform interface.

Nodes whose current neighbourhood is invalid are untangled instead (see
:mod:`._untangle`): the best of the Laplacian position, its halved moves, the
centroid of the ring's kernel (the positions where every incident cell is
valid) and staying, by the same score.  Measured on the distorted toothed
quad meshes: the Laplacian position of a node next to a non-convex quad often
has as many invalid cells as staying (so "improves" never held) and 7-19
input quads stayed non-convex through 10 passes; with the kernel candidate
none does.

>>> from anglesmooth.generate import structured_triangles
>>> from anglesmooth.topology import build_topology
>>> m = structured_triangles(4, 4)
>>> import numpy as np
>>> r = step(m.points, build_topology(m))   # a regular grid stays (to round-off: its Laplacian
>>> bool(np.allclose(r.points, m.points, rtol=0, atol=1e-12))   # positions tie with staying)
True
"""

from __future__ import annotations

import numpy as np

from ..topology import Topology
from ._blocks import StepResult, run_blocks
from ._floors import Floors
from ._local import geometry, laplacian_target
from ._untangle import invalid_nodes, untangle

__all__ = ["step"]


def step(
    points: np.ndarray,
    topo: Topology,
    /,
    *,
    guard: bool = True,
    order: str = "colour",
    floors: Floors | None = None,
    ties: bool = True,
    halvings: int = 2,
    untangling: bool = True,
) -> StepResult:
    """One smart-Laplacian pass: Laplacian moves (or their halves) accepted only where the local
    minimum angle does not decrease; nodes with an invalid incident cell untangled.

    ``ties``: False takes a move only where the minimum angle *increases* (the former rule);
    ``halvings``: how many halved moves are tried; ``untangling``: False leaves the invalid nodes
    to the same rule.  ``floors``: see :func:`._floors.input_floors`."""

    def update(pts, blk, cur):
        target = laplacian_target(pts, topo, blk)
        geom = geometry(pts, topo, blk, floors)
        s = geom.score(np.stack([target, cur]))
        take = s[0] >= s[1] if ties else s[0] > s[1]
        new = np.where(take[:, None], target, cur)
        moved = (target != cur).any(axis=1)
        bad = invalid_nodes(s[1]) if untangling else np.zeros(0, np.int64)
        if bad.size:
            x, sx = untangle(geom.restrict(bad), pts, topo, blk, bad, cur[bad], floors, lap=target[bad])
            new[bad] = x
            take[bad] = sx > s[1, bad]
        rest = np.flatnonzero(~take & moved)
        if bad.size:
            rest = np.setdiff1d(rest, bad, assume_unique=True)
        if halvings and rest.size:
            fr = 0.5 ** np.arange(1, halvings + 1)
            c, t = cur[rest], target[rest]
            cands = c[None] + fr[:, None, None] * (t - c)[None]
            sc = geom.restrict(rest).score(cands)
            ok = sc >= s[1, rest] if ties else sc > s[1, rest]
            hit = ok.any(axis=0)
            k = np.argmax(ok, axis=0)
            new[rest[hit]] = cands[k[hit], np.flatnonzero(hit)]
            take[rest[hit]] = True
        return new, int((moved & ~take).sum())

    return run_blocks(points, topo, order, update)
