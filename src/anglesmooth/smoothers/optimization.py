"""Optimization-based smoothing: maximize the minimum angle around each node.

References: L. A. Freitag, "On combining Laplacian and optimization-based mesh
smoothing techniques" (1997); S. A. Canann, J. R. Tristano and M. L. Staten,
"An approach to combined Laplacian and optimization-based smoothing" (7th
IMR, 1998); Section 2.3 of Zhou & Shimada (2000).

Per free node the objective is the minimum corner angle of its incident cells
(non-smooth; quad corners count ``min(angle, 180 - angle)``).  Each pass takes
``iterations`` steps of a compass (pattern) search -- the 8 points at distance
r, moving to the best if it improves the objective, halving r otherwise, r
starting at a quarter of the mean incident edge length -- which handles the
kinks of the max-min objective where a gradient ascent stalls (see
:func:`._local.optimize`).  Invalid positions (inverted, degenerate or
non-convex cells) rank below every valid one, so a valid mesh stays valid.
Colour classes move in turn (Gauss-Seidel); within a class every node is
optimized at once, vectorized.  Three stages around the search (issue 12):

1. *Untangling* (``untangling``).  Around an invalid cell the score is flat
   (every position with as many invalid cells scores the same), so the search
   from such a node never took a step: 7 input quads of the distorted toothed
   meshes stayed non-convex.  A node with an invalid incident cell first takes
   the best of its Laplacian position, its halved moves, the centroid of its
   kernel (the positions where every incident cell is
   valid) and staying (see :mod:`._untangle`); the search starts from there.
2. *Size guard* (``size_beta``, ``size_gamma``).  An angle-only objective makes
   small well-shaped cells (area ratio 938 on the paper-style quads against
   Laplacian's 53): a node whose smallest incident cell would end below
   ``size_beta`` (0.5) of the mean of its incident cells -- or, for a cell
   already that small, below ``size_gamma`` (0.8) of its own area -- takes its
   move halved, quartered, or stays, whichever first keeps the bound and scores
   no worse than the start (see :mod:`._size`).  ``area_band`` is the per-pass
   band of :func:`._local.optimize` (off by default: the guard above measured
   better area ratios at the same angles).
3. *Pair moves* (``pairs_below``).  A flattened boundary quad with two fixed
   corners traps any per-node max-min rule (lifting one free corner turns the
   other towards 180 deg); after the pass, the free corners of such quads below
   ``pairs_below`` (45) degrees move together by one compass-searched
   translation (see :mod:`._pairs`).

The input floors of the driver (:mod:`._floors`) apply throughout.

>>> from anglesmooth.generate import structured_quads
>>> from anglesmooth.topology import build_topology
>>> m = structured_quads(3, 3)
>>> bool((step(m.points, build_topology(m)).points == m.points).all())
True
"""

from __future__ import annotations

import numpy as np

from ..topology import Topology
from ._blocks import StepResult, run_blocks
from ._floors import Floors
from ._local import geometry, local_scale, optimize
from ._pairs import pair_moves
from ._size import size_guard
from ._untangle import invalid_nodes, untangle

__all__ = ["step"]


def step(
    points: np.ndarray,
    topo: Topology,
    /,
    *,
    guard: bool = True,
    order: str = "colour",
    iterations: int = 10,
    floors: Floors | None = None,
    untangling: bool = True,
    area_band: float | None = None,
    pairs_below: float = 45.0,
    size_beta: float | None = 0.5,
    size_gamma: float = 0.8,
) -> StepResult:
    """One pass of local max-min-angle optimization over all free nodes (the stages and their
    parameters: see the module docstring; ``floors``: see :func:`._floors.input_floors`)."""

    def update(pts, blk, cur):
        geom = geometry(pts, topo, blk, floors)
        start = cur
        if untangling:
            bad = invalid_nodes(geom.score(cur))
            if bad.size:
                x, _ = untangle(geom.restrict(bad), pts, topo, blk, bad, cur[bad], floors)
                start = cur.copy()
                start[bad] = x
        new, _ = optimize(geom, start, local_scale(pts, topo, blk), iterations, area_band=area_band)
        if size_beta:
            new = size_guard(geom, pts, topo, blk, start, new, size_beta, size_gamma)
        return new, 0

    res = run_blocks(points, topo, order, update)
    if pairs_below:
        return StepResult(pair_moves(res.points, topo, floors, pairs_below, iterations), res.rejected)
    return res
