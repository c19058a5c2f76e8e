"""Triangle -> quad conversions: greedy pairing of adjacent triangles, splitting every cell into quads."""

from __future__ import annotations

import numpy as np

from ._common import _corner_angles, _interior_edges

__all__ = ["pair_triangles", "split_to_quads"]


def pair_triangles(
    points,
    triangles,
    *,
    max_angle: float = 180.0,
    longest_edge: bool = False,
    max_pairs: int | None = None,
):
    """Merge adjacent triangles into convex quads by greedy matching on quad quality.

    Candidate pairs are the interior edges whose two triangles form a strictly
    convex quad with every corner angle below ``max_angle`` degrees; with
    ``longest_edge`` the shared edge must also be the longest edge of at least
    one of the two triangles (merging across a short edge makes a kite, not a
    quad).  The quality of a candidate is ``1 - max|corner angle - 90| / 90``.
    Candidates are accepted best first, each triangle at most once: the greedy
    matching, computed in vectorized rounds (a candidate is accepted in a round
    when it is the best remaining candidate of both its triangles, which gives
    exactly the sequential greedy result).

    Parameters
    ----------
    points : (N, 2) array
    triangles : (nt, 3) int array, counter-clockwise
    max_angle : float
        Largest corner angle (degrees) allowed in a merged quad.
    longest_edge : bool
        Only merge across an edge that is the longest of one of its triangles.
    max_pairs : int, optional
        Keep only the best ``max_pairs`` accepted pairs.

    Returns
    -------
    triangles : (nt - 2 p, 3) int array
        The triangles left unpaired.
    quads : (p, 4) int array
        The merged quads, counter-clockwise.

    >>> pts = np.array([[0., 0], [1, 0], [1, 1], [0, 1]])
    >>> t, q = pair_triangles(pts, np.array([[0, 1, 2], [0, 2, 3]]))
    >>> t.shape, q.tolist()
    ((0, 3), [[1, 2, 3, 0]])
    """
    pts = np.asarray(points, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    t1, k1, t2, k2, _ = _interior_edges(tri, pts.shape[0])
    o1 = tri[t1, k1]
    p = tri[t1, (k1 + 1) % 3]
    q = tri[t1, (k1 + 2) % 3]
    o2 = tri[t2, k2]
    quads = np.stack([o1, p, o2, q], axis=1)
    ang = np.degrees(_corner_angles(pts, quads))
    ok = (ang > 1e-6).all(axis=1) & (ang < max_angle).all(axis=1)
    if longest_edge:
        e = np.linalg.norm(pts[np.roll(tri, -1, 1)] - pts[np.roll(tri, -2, 1)], axis=2)  # edge opposite corner k
        longest = np.argmax(e, axis=1)
        ok &= (longest[t1] == k1) | (longest[t2] == k2)
    quality = 1.0 - np.abs(ang - 90.0).max(axis=1) / 90.0
    cand = np.flatnonzero(ok)
    # rank: higher is better; ties broken by edge order (deterministic)
    order = cand[np.lexsort((-cand, quality[cand]))]
    rank = np.empty(quads.shape[0], np.int64)
    rank[order] = np.arange(order.shape[0])
    live = order
    nt = tri.shape[0]
    taken = np.zeros(nt, bool)
    accepted = []
    while live.size:
        best = np.full(nt, -1, np.int64)
        np.maximum.at(best, t1[live], rank[live])
        np.maximum.at(best, t2[live], rank[live])
        win = live[(best[t1[live]] == rank[live]) & (best[t2[live]] == rank[live])]
        accepted.append(win)
        taken[t1[win]] = True
        taken[t2[win]] = True
        live = live[~(taken[t1[live]] | taken[t2[live]])]
    acc = np.concatenate(accepted) if accepted else np.zeros(0, np.int64)
    acc = acc[np.argsort(-rank[acc], kind="stable")]  # best first
    if max_pairs is not None:
        acc = acc[:max_pairs]
    used = np.zeros(nt, bool)
    used[t1[acc]] = True
    used[t2[acc]] = True
    return tri[~used], quads[np.sort(acc)]


def split_to_quads(points, triangles=None, quads=None):
    """Split every triangle into 3 quads and every quad into 4 (edge midpoints + cell centroid).

    New nodes are appended after the old ones: edge midpoints (in sorted edge
    order), then triangle centroids, then quad centroids.  Convex cells give
    convex quads.

    Returns
    -------
    points : (N', 2) array
    quads : (3 nt + 4 nq, 4) int array, counter-clockwise if the input was

    >>> p, q = split_to_quads([[0., 0], [1, 0], [0, 1]], [[0, 1, 2]])
    >>> p.shape, q.shape
    ((7, 2), (3, 4))
    """
    pts = np.asarray(points, dtype=np.float64)
    tri = np.zeros((0, 3), np.int64) if triangles is None else np.asarray(triangles, np.int64).reshape(-1, 3)
    quad = np.zeros((0, 4), np.int64) if quads is None else np.asarray(quads, np.int64).reshape(-1, 4)
    n = pts.shape[0]
    # directed edges (c[k], c[k+1]) of each cell, in cell order
    ea = np.concatenate([tri.ravel(), quad.ravel()])
    eb = np.concatenate([np.roll(tri, -1, 1).ravel(), np.roll(quad, -1, 1).ravel()])
    key = np.minimum(ea, eb) * np.int64(n) + np.maximum(ea, eb)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    first = np.ones(ks.shape[0], bool)
    first[1:] = ks[1:] != ks[:-1]
    uid = np.empty(ks.shape[0], np.int64)
    uid[order] = np.cumsum(first) - 1
    uk = ks[first]
    mid = 0.5 * (pts[uk // n] + pts[uk % n])
    ne = uk.shape[0]
    nt, nq = tri.shape[0], quad.shape[0]
    tc = pts[tri].mean(axis=1)
    qc = pts[quad].mean(axis=1)
    new_pts = np.concatenate([pts, mid, tc, qc])
    out = []
    for cells, k, off, cstart in ((tri, 3, 0, n + ne), (quad, 4, 3 * nt, n + ne + nt)):
        m = cells.shape[0]
        if not m:
            continue
        e_next = (n + uid[off : off + k * m]).reshape(m, k)  # midpoint of edge (c[j], c[j+1])
        e_prev = np.roll(e_next, 1, axis=1)  # midpoint of edge (c[j-1], c[j])
        centre = np.broadcast_to((cstart + np.arange(m))[:, None], (m, k))
        out.append(np.stack([cells, e_next, centre, e_prev], axis=2).reshape(-1, 4))
    return new_pts, (np.concatenate(out) if out else np.zeros((0, 4), np.int64))
