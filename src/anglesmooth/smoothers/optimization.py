"""Optimization-based smoothing: maximize the minimum angle around each node.

References: L. A. Freitag, "On combining Laplacian and optimization-based mesh
smoothing techniques" (1997); S. A. Canann, J. R. Tristano and M. L. Staten,
"An approach to combined Laplacian and optimization-based smoothing" (7th
IMR, 1998); Section 2.3 of Zhou & Shimada (2000).

Per free node the objective is the minimum corner angle of its incident cells
(non-smooth).  Each pass takes ``iterations`` steps of a compass (pattern)
search -- the 8 points at distance r, moving to the best if it improves the
objective, halving r otherwise, r starting at a quarter of the mean incident
edge length -- which handles the kinks of the max-min objective where a
gradient ascent stalls (see :func:`._local.optimize`).  Invalid positions (inverted,
degenerate or non-convex cells) rank below every valid one, so a valid mesh
stays valid.  Colour classes move in turn (Gauss-Seidel); within a class every
node is optimized at once, vectorized.

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
from ._local import angle_target, geometry, local_scale, optimize
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
    """One pass of local max-min-angle optimization over all free nodes (``floors``: see
    :func:`._floors.input_floors`)."""

    def update(pts, blk, cur):
        geom = geometry(pts, topo, blk, floors)
        start = cur
        if untangling:
            bad = invalid_nodes(geom.score(cur))
            if bad.size:
                extra = (angle_target(pts, topo, blk)[bad],)
                x, _ = untangle(geom.restrict(bad), pts, topo, blk, bad, cur[bad], floors, extra=extra)
                start = cur.copy()
                start[bad] = x
        new, _ = optimize(geom, start, local_scale(pts, topo, blk), iterations, area_band=area_band)
        if size_beta:
            new = size_guard(geom, pts, topo, blk, start, new, geom.score(start), size_beta, size_gamma)
        return new, 0

    res = run_blocks(points, topo, order, update)
    if pairs_below:
        return StepResult(pair_moves(res.points, topo, floors, pairs_below, iterations), res.rejected)
    return res
