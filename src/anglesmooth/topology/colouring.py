"""Node colouring: nodes that share a cell get different colours (the Gauss-Seidel update blocks)."""

from __future__ import annotations

import numpy as np


def _colour(n: int, free: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Colour free nodes so that no two nodes of one cell share a colour.

    Luby / Jones-Plassmann rounds: in each round the uncoloured nodes whose
    (fixed, pseudo-random) priority beats every uncoloured neighbour's form the
    next colour class.  (u, v) are the (undirected) node pairs that share a cell.
    Each round only looks at the pairs whose two nodes are both still uncoloured.
    """
    colour = np.full(n, -1, dtype=np.int64)
    if not free.any():
        return colour
    keep = free[u] & free[v] & (u != v)
    u, v = u[keep], v[keep]
    prio = np.random.default_rng(12345).permutation(n).astype(np.int64)
    # the node of lower priority loses the pair in every round: find it once
    u_loses = prio[u] < prio[v]
    # intp: numpy's fancy indexing with int32 indices is about 2x slower (a cast per call)
    lose, win = np.where(u_loses, u, v).astype(np.intp), np.where(u_loses, v, u).astype(np.intp)
    del u, v, u_loses, keep
    remaining = free.copy()
    loses = np.zeros(n, bool)
    k = 0
    while remaining.any():
        loses[lose] = True
        pick = remaining & ~loses
        colour[pick] = k
        remaining &= loses
        loses[:] = False
        alive = np.flatnonzero(remaining[win])  # a loser is never coloured in its round
        lose, win = lose[alive], win[alive]  # (one index list for both: faster than two masks)
        k += 1
    return colour
