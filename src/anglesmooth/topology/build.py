"""The smoothing tables of :class:`Topology`: rings, colour classes, spokes and incidence rows."""

from __future__ import annotations

from dataclasses import fields

import numpy as np

from ..mesh import Mesh2D
from ._keys import _cell_shift, _radix_order, _rows_by_loc
from .cells import _cell_topology
from .colouring import _colour
from .types import CellTopology, Topology

__all__ = ["QUAD_IDEAL", "TRI_IDEAL", "build_topology"]

TRI_IDEAL = np.pi / 3
QUAD_IDEAL = np.pi / 2


def _rings(edges: np.ndarray, deg: np.ndarray, n: int):
    """CSR of edge neighbours (rows ascending) and the edge behind every entry.

    Row v lists the neighbours below v (edges with hi == v, by lo), then those
    above it (edges with lo == v, by hi: ``edges`` is sorted by (lo, hi)); a
    self-edge (v, v) appears once in each part.  ``deg`` is the row length.
    """
    lo, hi = edges[:, 0], edges[:, 1]
    ne = edges.shape[0]
    idx = edges.dtype
    offsets = np.zeros(n + 1, idx)
    np.cumsum(deg, out=offsets[1:])
    n_lo = np.bincount(lo, minlength=n)
    n_hi = np.bincount(hi, minlength=n)
    eid = np.arange(ne, dtype=np.int64)
    indices = np.empty(2 * ne, idx)
    edge = np.empty(2 * ne, idx)
    # upper part: edge e is entry e - (first edge with this lo) of lo's upper part
    pos = (offsets[:-1] + n_hi - (np.cumsum(n_lo) - n_lo))[lo]
    pos += eid
    indices[pos] = hi
    edge[pos] = eid
    # lower part: the edges in (hi, lo) order (a stable radix sort by hi: O(E), 1M triangles 85 -> 35 ms);
    # the q-th one is entry q - (first of its hi), and the sorted his are runs of n_hi (a repeat, no gather)
    by_hi = _radix_order(hi)
    pos = np.repeat(offsets[:-1] - (np.cumsum(n_hi) - n_hi), n_hi)
    pos += eid
    indices[pos] = lo[by_hi]
    edge[pos] = by_hi
    return offsets, indices, edge


def _rows(offsets: np.ndarray, nodes: np.ndarray):
    """The CSR rows of ``nodes``, concatenated: (position in ``nodes``, CSR entry) of every entry."""
    start = offsets[nodes]
    count = offsets[nodes + 1] - start
    owner = np.repeat(np.arange(nodes.shape[0], dtype=nodes.dtype), count)
    entry = np.repeat(start - (np.cumsum(count) - count), count)
    entry += np.arange(entry.shape[0], dtype=np.int64)
    return owner, entry


def _edge_spokes(tri: np.ndarray, quad: np.ndarray, centre: np.ndarray, ring: np.ndarray, up, down):
    """(a, b, frac) of the edge spokes (centre p, ring node j).

    ``up`` / ``down`` are the directed edges lo -> hi / hi -> lo of each
    spoke's edge (overwritten).  p is free, so that edge holds exactly p -> j
    and j -> p.  Corner (p, j, x) of the cell of p -> j gives a = x (two
    places after p); corner (x, j, p) of the cell of j -> p gives b = x (just
    before j).
    """
    h_out = np.where(centre < ring, up, down)  # p -> j: lo -> hi when p is the lower node
    h_in = up
    h_in += down
    h_in -= h_out  # j -> p
    idx = ring.dtype
    before = _cell_shift(tri, quad, -1, idx)
    # np.take: numpy's fancy indexing with int32 indices is about 1.5x slower (a cast per call), take is not
    spoke_b = np.take(before, h_in)
    spoke_a = np.take(_cell_shift(tri, quad, 2, idx) if quad.size else before, h_out)  # the same node in a triangle
    # frac = ideal angle of the a side / both; a side in the cell of p -> j, b side in that of j -> p
    ideal = np.array([TRI_IDEAL, QUAD_IDEAL])
    frac = (ideal[:, None] / (ideal[:, None] + ideal[None, :])).ravel()
    side = (h_out >= tri.size).view(np.uint8) * np.uint8(2)
    side += h_in >= tri.size
    return spoke_a, spoke_b, frac[side]


def _with_diagonals(quad: np.ndarray, loc_of: np.ndarray, nf: int, spokes):
    """Merge the diagonal spokes of quads after the edge spokes (loc, ring, a, b, frac) of each node.

    ``spokes`` is a list; its entries are dropped (set to None) as they are merged.

    Every quad corner j (b before it, a after it) gives the opposite corner's
    node, when free, a spoke to j with sides a and b and frac 1/2; the
    diagonal spokes of one node are in corner order.
    """
    no_tri = np.zeros((0, 3), np.int64)
    e_loc = spokes[0]
    # the opposite corner's node as intp: numpy's fancy indexing with int32 indices is about 2x slower
    d_loc, qc = _rows_by_loc(loc_of[_cell_shift(no_tri, quad, 2, np.intp)])
    ne = np.bincount(e_loc, minlength=nf)
    nd = np.bincount(d_loc, minlength=nf)
    off = np.zeros(nf + 1, np.int64)
    np.cumsum(ne + nd, out=off[1:])
    # entry q of node i's edge spokes goes to off[i] + q, its diagonal spoke q to off[i] + ne[i] + q;
    # e_loc and d_loc are sorted, so the per-node shift is a np.repeat (sequential) rather than a gather
    first = np.cumsum(ne)
    first -= ne
    pos_e = np.repeat(off[:-1] - first, ne)
    pos_e += np.arange(e_loc.shape[0])
    np.cumsum(nd, out=first)
    first -= nd
    shift = off[:-1] - first
    shift += ne
    pos_d = np.repeat(shift, nd)
    pos_d += np.arange(d_loc.shape[0])
    del first, shift
    m = off[-1]
    # corner qc = 4 * cell + r: its node, and the nodes after (a) and before (b) it in the cell,
    # gathered straight from the quads (no shifted copies of the whole corner table), each one just
    # before it is merged and its index freed right after (a smaller peak of memory)
    flat = quad.ravel()

    def beside(step):
        near = qc + step
        near &= 3
        near |= qc & ~3
        return flat[near]

    diagonal = (lambda: d_loc, lambda: flat[qc], lambda: beside(1), lambda: beside(3), lambda: 0.5)
    merged = []
    for i, d_col in enumerate(diagonal):
        e_col, spokes[i] = spokes[i], None  # the caller's list lets go of the edge column once merged
        col = np.empty(m, e_col.dtype)
        col[pos_e] = e_col
        del e_col
        col[pos_d] = d_col()
        merged.append(col)
    return tuple(merged)


def _incidence(cells: np.ndarray, loc_of: np.ndarray, free_nodes: np.ndarray):
    """(loc, rotated cell, cell id) for every corner at a free node, sorted by (loc, rotation, cell)."""
    nc, k = cells.shape
    width = k * nc
    # ext[r], r = rotation * nc + cell, is the node of that corner; the nodes after it in
    # the cell are ext[r + nc], ext[r + 2 nc], ... (ext repeats the first k - 1 rotations)
    idx = free_nodes.dtype
    ext = np.empty(width + (k - 1) * nc, idx)
    ext[:width].reshape(k, nc)[:] = cells.T
    ext[width:] = ext[: (k - 1) * nc]
    loc, r = _rows_by_loc(np.take(loc_of, ext[:width]))
    cell = np.remainder(r, nc, out=np.empty(r.shape[0], idx), casting="same_kind") if nc else r.astype(idx)
    verts = np.empty((r.shape[0], k), idx)
    verts[:, 0] = free_nodes[loc]  # the node itself
    for m in range(1, k):
        r += nc
        np.take(ext, r, out=verts[:, m], mode="clip")  # all in range; "clip" writes straight into the column
    return loc.astype(idx), verts, cell


def build_topology(mesh: Mesh2D, extra_fixed: np.ndarray | None = None) -> Topology:
    """Build the :class:`Topology` of ``mesh``.

    Parameters
    ----------
    mesh : Mesh2D
    extra_fixed : (N,) bool array or int array of node indices, optional
        Nodes to keep fixed in addition to the default rules.
    """
    cells, (deg_edges, up, down) = _cell_topology(mesh, extra_fixed)
    n, tri, quad, edges, fixed = cells.n_points, cells.tri, cells.quad, cells.edges, cells.fixed
    nq = quad.shape[0]
    free = ~fixed
    idx = edges.dtype  # int32 unless the mesh is too large for it (see _keys.index_dtype)

    # --- rings (CSR of edge neighbours) ----------------------------------
    ring_offsets, ring_indices, ring_edge = _rings(edges, deg_edges, n)

    # --- colouring: nodes sharing a cell get different colours -----------
    pu, pv = [edges[:, 0]], [edges[:, 1]]
    if nq:
        pu += [quad[:, 0], quad[:, 1]]
        pv += [quad[:, 2], quad[:, 3]]
    colour = _colour(n, free, np.concatenate(pu, dtype=idx, casting="same_kind"),
                     np.concatenate(pv, dtype=idx, casting="same_kind"))
    free_idx = np.flatnonzero(free).astype(idx)
    free_nodes = free_idx[_radix_order(colour[free_idx])]  # stable; one uint8 pass below 256 colours
    ncol = int(colour.max()) + 1 if free_nodes.size else 0
    block_offsets = np.searchsorted(colour[free_nodes], np.arange(ncol + 1))
    loc_of = np.full(n, -1, idx)
    loc_of[free_nodes] = np.arange(free_nodes.shape[0])
    nf = free_nodes.shape[0]

    # --- per-node tables, sorted by loc ----------------------------------
    # rings: the CSR rows of the free nodes in loc order
    ring_loc, entry = _rows(ring_offsets, free_nodes)
    ring_nbr = ring_indices[entry]
    # edge spokes: one per ring entry (a free node is interior and manifold)
    e = ring_edge[entry]
    del entry, ring_edge
    spokes = [ring_loc, ring_nbr, *_edge_spokes(tri, quad, np.take(free_nodes, ring_loc), ring_nbr, np.take(up, e),
                                                np.take(down, e))]
    del e, up, down
    if nq:
        spokes = _with_diagonals(quad, loc_of, nf, spokes)
    spoke_loc, spoke_ring, spoke_a, spoke_b, spoke_frac = spokes
    # incidence: every cell around a free node, rotated to start at that node;
    # row r = k * n_cells + cell (rotation k major), rows of one node in r order
    tri_loc, tri_verts, tri_cell = _incidence(tri, loc_of, free_nodes)
    quad_loc, quad_verts, quad_cell = _incidence(quad, loc_of, free_nodes)

    return Topology(
        **{f.name: getattr(cells, f.name) for f in fields(CellTopology)},
        ring_offsets=ring_offsets,
        ring_indices=ring_indices,
        colour=np.where(free, colour, -1).astype(idx),
        free_nodes=free_nodes,
        block_offsets=block_offsets,
        ring_loc=ring_loc,
        ring_nbr=ring_nbr,
        spoke_loc=spoke_loc,
        spoke_ring=spoke_ring,
        spoke_a=spoke_a,
        spoke_b=spoke_b,
        spoke_frac=spoke_frac,
        tri_loc=tri_loc,
        tri_verts=tri_verts,
        tri_cell=tri_cell,
        quad_loc=quad_loc,
        quad_verts=quad_verts,
        quad_cell=quad_cell,
    )
