"""Laplacian smoothing: each free node moves to the centroid of its edge neighbours.

Reference: D. A. Field, "Laplacian smoothing and Delaunay triangulations",
Communications in Applied Numerical Methods 4 (1988) 709-712; Section 2.1 of
Zhou & Shimada (2000).  Quads use their edge neighbours only (not the diagonal
nodes).

With ``guard=True`` (the default) a move that would invert or degenerate an
incident cell, or make a quad non-convex, is halved up to six times and
refused if still invalid; ``guard=False`` is the classical, unguarded method.

>>> from anglesmooth.generate import structured_quads
>>> from anglesmooth.topology import build_topology
>>> m = structured_quads(3, 3)
>>> topo = build_topology(m)
>>> bool((step(m.points, topo).points == m.points).all())   # a regular grid does not move
True
"""

from __future__ import annotations

import numpy as np

from ..topology import Topology
from ._blocks import StepResult, run_blocks
from ._floors import Floors
from ._local import first_valid, geometry, laplacian_target

__all__ = ["step"]


def step(
    points: np.ndarray, topo: Topology, /, *, guard: bool = True, order: str = "colour", floors: Floors | None = None
) -> StepResult:
    """One Laplacian pass over all free nodes (``floors``: see :func:`._floors.input_floors`)."""

    def update(pts, blk, cur):
        target = laplacian_target(pts, topo, blk)
        if not guard:
            return target, 0
        new, refused = first_valid(geometry(pts, topo, blk, floors), cur, target)
        return new, refused.sum()

    return run_blocks(points, topo, order, update)
