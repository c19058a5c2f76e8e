"""Where a block's nodes may move: the Laplacian and angle targets, and each node's local length scale.

Vectorized numpy over one block (colour class) at a time, or the compiled twins of :mod:`._fastcalls`
on large meshes; the per-node sums add in ring order, so that a subset's targets are bit for bit the
block's (tests/test_kernels.py).  The angle target is the paper's rule, described in :mod:`.angle`.
"""

from __future__ import annotations

import numpy as np

from ..topology import Block, Topology
from . import _fast, _fastcalls
from ._blocks import intp
from ._rows import _CHUNK, _gather_xy

__all__ = ["angle_target", "laplacian_target", "local_scale"]


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[..., 0] * v[..., 0] + u[..., 1] * v[..., 1]


def _ring_subset(topo: Topology, blk: Block, subset: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(ring entries, their subset-local node) of the block-local nodes ``subset``: each node's entries
    in ring order (the table is sorted by node), so per-node sums over them add in the same order as over
    the whole block's ring."""
    count = blk.ring_count[subset]
    offs = topo._cache.get(("ring-offsets", blk.nodes.start, blk.nodes.stop))
    if offs is None:
        offs = topo._cache[("ring-offsets", blk.nodes.start, blk.nodes.stop)] = (
            np.cumsum(blk.ring_count) - blk.ring_count + blk.ring.start)
    ends = np.cumsum(count)
    entries = np.repeat(offs[subset] - (ends - count), count) + np.arange(int(ends[-1]) if ends.size else 0)
    return entries, np.repeat(np.arange(subset.shape[0]), count)


def laplacian_target(points: np.ndarray, topo: Topology, blk: Block, subset: np.ndarray | None = None) -> np.ndarray:
    """Centroid of the edge neighbours of each block node, (n, 2), or of the block-local nodes ``subset`` only."""
    if _fast.active(topo):
        out = _fastcalls.laplacian_target(points, topo, blk)
        return out if subset is None else out[subset]
    if subset is not None:
        entries, rel = _ring_subset(topo, blk, subset)
        nb = np.take(points, topo.ring_nbr[entries], axis=0)
        n = subset.shape[0]
        out = np.empty((n, 2))
        out[:, 0] = np.bincount(rel, weights=nb[:, 0], minlength=n)
        out[:, 1] = np.bincount(rel, weights=nb[:, 1], minlength=n)
        out /= blk.ring_count[subset][:, None]
        return out
    a = blk.nodes.start
    rel = intp(topo, "ring_loc")[blk.ring] - a
    nb = np.take(points, intp(topo, "ring_nbr")[blk.ring], axis=0)
    n = blk.size
    out = np.empty((n, 2))
    out[:, 0] = np.bincount(rel, weights=nb[:, 0], minlength=n)
    out[:, 1] = np.bincount(rel, weights=nb[:, 1], minlength=n)
    out /= blk.ring_count[:, None]
    return out


def angle_target(points: np.ndarray, topo: Topology, blk: Block, cur: np.ndarray | None = None) -> np.ndarray:
    """Zhou & Shimada's angle-based position of each block node, (n, 2).

    For every spoke (ring node j, with a and b the nodes beside the spoke when
    turning counter-clockwise about j) the node is put on the ray from j that
    splits the counter-clockwise angle a-j-b in the ratio ``frac : 1 - frac``,
    at its current distance from j; the result is the mean over all spokes.
    Equal splits use the exact bisector ``rot90(u_a - u_b)`` (no trigonometry);
    only unequal splits (quad beside triangle) use atan2/cos/sin.  ``cur``: the block nodes' current
    positions (``points`` at them), if the caller has them (numpy kernels: one gather fewer).
    """
    if _fast.active(topo):
        return _fastcalls.angle_target(points, topo, blk)
    a0 = blk.nodes.start
    sl = blk.spokes
    n = blk.size
    if cur is None:
        cur = np.take(points, intp(topo, "free_nodes")[blk.nodes], axis=0)
    out = np.empty((n, 2))
    # node-aligned chunks of about _CHUNK spokes: the temporaries stay in cache, and
    # every node's spokes are summed in the same order as by one bincount
    offs = np.zeros(n + 1, np.int64)
    np.cumsum(blk.spoke_count, out=offs[1:])
    cuts = np.searchsorted(offs, np.arange(0, offs[-1], _CHUNK), side="right") - 1
    cuts = np.unique(np.concatenate([[0], cuts[cuts < n], [n]]))
    for n0, n1 in zip(cuts[:-1].tolist(), cuts[1:].tolist()):
        chunk = slice(sl.start + int(offs[n0]), sl.start + int(offs[n1]))
        out[n0:n1] = _angle_sums(points, topo, chunk, intp(topo, "spoke_loc")[chunk] - (a0 + n0), cur[n0:n1],
                                 blk.spoke_count[n0:n1])
    out /= blk.spoke_count[:, None]
    return out


def _angle_sums(points: np.ndarray, topo: Topology, sl: slice, rel: np.ndarray, cur: np.ndarray,
                counts: np.ndarray | None = None) -> np.ndarray:
    """Per node (rows of ``cur``), the sum over its spokes ``sl`` of the rotated positions (``rel``: the spokes'
    node, sorted; ``counts``: spokes per node, if the caller has them)."""
    n = cur.shape[0]
    # each node's spokes are contiguous (in node order): its current position repeated (cheaper than a gather)
    cnt = np.bincount(rel, minlength=n) if counts is None else counts
    cx, cy = cur[:, 0].repeat(cnt), cur[:, 1].repeat(cnt)
    jx, jy = _gather_xy(points, intp(topo, "spoke_ring")[sl])
    pax, pay = _gather_xy(points, intp(topo, "spoke_a")[sl])
    pbx, pby = _gather_xy(points, intp(topo, "spoke_b")[sl])
    with np.errstate(divide="ignore", invalid="ignore"):
        ax, ay = pax - jx, pay - jy
        bx, by = pbx - jx, pby - jy
        la = np.sqrt(ax * ax + ay * ay)
        ax /= la
        ay /= la
        lb = np.sqrt(bx * bx + by * by)
        bx /= lb
        by /= lb
        tx, ty = by - ay, ax - bx
        frac = topo.spoke_frac[sl]
        uneq = np.flatnonzero(frac != 0.5)
        if uneq.shape[0]:
            u = np.stack([ax[uneq], ay[uneq]], axis=1)
            v = np.stack([bx[uneq], by[uneq]], axis=1)
            theta = np.arctan2(_cross(u, v), _dot(u, v))
            theta = np.where(theta <= 0, theta + 2 * np.pi, theta)
            phi = frac[uneq] * theta
            cs, sn = np.cos(phi), np.sin(phi)
            tx[uneq] = cs * u[:, 0] - sn * u[:, 1]
            ty[uneq] = sn * u[:, 0] + cs * u[:, 1]
        dx, dy = cx - jx, cy - jy
        scale = np.sqrt(dx * dx + dy * dy)
        scale /= np.sqrt(tx * tx + ty * ty)
        tx *= scale
        ty *= scale
    # a degenerate spoke (zero-length ring edge) keeps its current position
    good = np.isfinite(tx) & np.isfinite(ty)
    tx += jx
    ty += jy
    if not good.all():
        bad = ~good
        tx[bad], ty[bad] = cx[bad], cy[bad]
    out = np.empty((n, 2))
    out[:, 0] = np.bincount(rel, weights=tx, minlength=n)
    out[:, 1] = np.bincount(rel, weights=ty, minlength=n)
    return out


def local_scale(points: np.ndarray, topo: Topology, blk: Block, subset: np.ndarray | None = None) -> np.ndarray:
    """Mean length of the edges at each block node, (n,), or at the block-local nodes ``subset`` only."""
    if _fast.active(topo):
        return _fastcalls.local_scale(points, topo, blk, subset)
    a = blk.nodes.start
    if subset is not None:
        entries, rel = _ring_subset(topo, blk, subset)
        loc, nbr, count, n = topo.ring_loc[entries], topo.ring_nbr[entries], blk.ring_count[subset], subset.shape[0]
    else:
        loc = intp(topo, "ring_loc")[blk.ring]
        nbr = intp(topo, "ring_nbr")[blk.ring]
        count = blk.ring_count
        n = blk.size
        rel = loc - a
    d = np.take(points, nbr, axis=0) - np.take(points, intp(topo, "free_nodes")[loc], axis=0)
    ln = np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1])
    return np.bincount(rel, weights=ln, minlength=n) / count
