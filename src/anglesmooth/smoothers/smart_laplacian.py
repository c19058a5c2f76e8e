"""Smart (constrained) Laplacian smoothing with the minimum angle as constraint.

Reference: L. A. Freitag, "On combining Laplacian and optimization-based mesh
smoothing techniques", AMD Trends in Unstructured Mesh Generation 220 (1997)
37-43, as listed in Section 5.2 of Zhou & Shimada (2000): compute the minimum
angle of the cells around the node, compute the Laplacian position, and move
there only if the minimum angle of those cells improves.  A move that inverts
a cell or makes a quad non-convex never improves the minimum angle here (the
local score ranks invalid cells below every valid one), so this method is
guarded by construction; ``guard`` is accepted for a uniform interface.

>>> from anglesmooth.generate import structured_triangles
>>> from anglesmooth.topology import build_topology
>>> m = structured_triangles(4, 4)
>>> r = step(m.points, build_topology(m))
>>> bool((r.points == m.points).all())
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
    ties: bool = False,
    halvings: int = 0,
    untangling: bool = True,
) -> StepResult:
    """One smart-Laplacian pass: Laplacian moves accepted only where the local minimum angle improves.

    ``floors``: see :func:`._floors.input_floors`."""

    def update(pts, blk, cur):
        target = laplacian_target(pts, topo, blk)
        geom = geometry(pts, topo, blk, floors)
        s = geom.score(np.stack([target, cur]))
        take = s[0] >= s[1] if ties else s[0] > s[1]
        moved = (target != cur).any(axis=1)
        new = np.where(take[:, None], target, cur)
        rest = np.flatnonzero(~take & moved)
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
        if untangling:
            bad = invalid_nodes(s[1])
            bad = bad[~take[bad]]
            if bad.size:
                sub = geom.restrict(bad)
                x, sx = untangle(sub, pts, topo, blk, bad, cur[bad], floors, lap=target[bad])
                better = sx > s[1, bad]
                new[bad[better]] = x[better]
                take[bad[better]] = True
        return new, int((moved & ~take).sum())

    return run_blocks(points, topo, order, update)
