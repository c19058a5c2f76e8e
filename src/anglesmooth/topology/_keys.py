"""Directed cell edges and the integer-key sorts the topology build is made of."""

from __future__ import annotations

import numpy as np


def _edge_keys(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    """Undirected key ``min * n + max`` of every directed edge a -> b."""
    key = np.minimum(a, b)
    key *= n
    key += np.maximum(a, b)
    return key


def _stable_order(key: np.ndarray):
    """Stable argsort of a non-negative int64 ``key``; returns (order, sorted keys).

    When key and row index fit in 63 bits together, the row index is packed
    into the low bits and a plain ``np.sort`` (SIMD, about 10x faster than a
    stable ``argsort`` on millions of int64) gives the stable order; otherwise
    it falls back to ``np.argsort(kind="stable")``.
    """
    m = key.shape[0]
    shift = max(int(m - 1).bit_length(), 1)
    if m == 0 or int(key.max()).bit_length() + shift <= 63:
        packed = key << shift
        packed |= np.arange(m, dtype=np.int64)
        packed.sort()
        order = packed & ((1 << shift) - 1)
        packed >>= shift
        return order, packed
    order = np.argsort(key, kind="stable")
    return order, key[order]


def _cell_edges(tri: np.ndarray, quad: np.ndarray):
    """Directed edges (a -> b) of every cell; edge h is also corner h (at node a[h])."""
    return _cell_shift(tri, quad, 0), _cell_shift(tri, quad, 1)


def _cell_shift(tri: np.ndarray, quad: np.ndarray, step: int) -> np.ndarray:
    """For every corner (triangles, then quads, cell by cell), the node ``step`` places further counter-clockwise."""
    out = np.empty(tri.size + quad.size, np.int64)
    for cells, part in ((tri, out[: tri.size]), (quad, out[tri.size :])):
        k = cells.shape[1]
        part = part.reshape(-1, k)
        s = step % k
        part[:, : k - s] = cells[:, s:]
        part[:, k - s :] = cells[:, :s]
    return out


def _edge_cell(nt: int, nq: int) -> np.ndarray:
    """The cell of every directed edge / corner."""
    return np.concatenate([np.repeat(np.arange(nt), 3), nt + np.repeat(np.arange(nq), 4)])


class _HalfEdges:
    """Directed cell edges sorted by their undirected key (stable): twins are adjacent.

    ``order`` sorts the edges, ``ks`` are the sorted keys ``lo * n + hi`` and
    ``a_s`` the sorted tails; ``same[q]`` says that sorted position q + 1 is
    the same undirected edge as q, ``dup[q]`` that it also runs the same way.
    """

    def __init__(self, tri: np.ndarray, quad: np.ndarray, n: int):
        self.a, self.b = _cell_edges(tri, quad)
        self.order, self.ks = _stable_order(_edge_keys(self.a, self.b, n))
        self.same = self.ks[1:] == self.ks[:-1]
        self.a_s = self.a[self.order]
        self.dup = self.same & (self.a_s[1:] == self.a_s[:-1])


def _by_loc(loc: np.ndarray, width: int, value: np.ndarray):
    """Rows with a free owner (``loc >= 0``) sorted by (loc, value); returns (loc, value) of the sorted rows.

    ``value`` (0 <= value < width) orders the rows of one owner.  Both are
    packed into one int64 key for a plain ``np.sort``; rows of fixed owners
    (loc = -1) get negative keys, sort first and are cut off.  Falls back to
    ``np.lexsort`` when the key would not fit in 63 bits.  ``loc`` is
    overwritten.
    """
    shift = max(int(width - 1).bit_length(), 1)
    if loc.shape[0] == 0 or int(loc.max()).bit_length() + shift <= 63:
        key = loc
        key <<= shift
        key |= value
        key.sort()
        key = key[np.searchsorted(key, 0) :]
        loc = key >> shift
        key &= (1 << shift) - 1
        return loc, key
    keep = loc >= 0
    loc, value = loc[keep], value[keep]
    o = np.lexsort((value, loc))
    return loc[o], value[o]
