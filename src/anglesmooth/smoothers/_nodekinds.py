"""Node kinds of a colour block of the default ``angle`` pass, and the score thresholds that depend on them.

Stages 1-2 (:mod:`._choose`: the acceptance threshold) and stage 4 (:mod:`._worst`: the optimization threshold,
the resume test of quad-only nodes, ``keep_min``'s nodes with both kinds of cell) ask the same questions of a
block's nodes: does it have a quad, a triangle, both.  Topology only, so each answer is cached per block in
``topo._cache``.
"""

from __future__ import annotations

import numpy as np

from ..topology import Topology

__all__ = ["_mixed", "_per_node", "_quads_only"]


def _per_node(topo: Topology, blk, tri_deg: float, quad_deg: float) -> np.ndarray:
    """Score threshold of each block node: ``tri_deg`` for nodes of triangles only, ``quad_deg`` for nodes of a quad.

    Thresholds relative to the ideal angle (60 deg for triangles, 90 for quads) mean the same for
    both; a node with both kinds of cell uses the quad's (its quad corners are the ones judged on
    ``min(angle, 180 - angle)``).  Cached per block (topology only).
    """
    key = ("angle-thresholds", blk.nodes.start, blk.nodes.stop, float(tri_deg), float(quad_deg))
    hit = topo._cache.get(key)
    if hit is None:
        hasq = np.bincount(topo.quad_loc[blk.quads] - blk.nodes.start, minlength=blk.size) > 0
        lo, hi = -np.cos(np.radians(tri_deg)), -np.cos(np.radians(quad_deg))
        hit = topo._cache[key] = np.where(hasq, hi, lo)
    return hit


def _quads_only(topo: Topology, blk) -> np.ndarray:
    """Per block node: it has no triangle (cached per block, topology only)."""
    key = ("angle-quads-only", blk.nodes.start, blk.nodes.stop)
    hit = topo._cache.get(key)
    if hit is None:
        hit = topo._cache[key] = np.bincount(topo.tri_loc[blk.tris] - blk.nodes.start, minlength=blk.size) == 0
    return hit


def _mixed(topo: Topology, blk) -> np.ndarray:
    """Per block node: it has both a triangle and a quad (cached per block, topology only)."""
    key = ("angle-mixed", blk.nodes.start, blk.nodes.stop)
    hit = topo._cache.get(key)
    if hit is None:
        hasq = np.bincount(topo.quad_loc[blk.quads] - blk.nodes.start, minlength=blk.size) > 0
        hit = topo._cache[key] = hasq & ~_quads_only(topo, blk)
    return hit
