"""Mesh topology, built once per mesh with numpy only.

:func:`build_topology` turns a :class:`~anglesmooth.mesh.Mesh2D` into a
:class:`Topology`: consistently oriented cells, unique edges, boundary, the fixed
mask, node rings (CSR), a node colouring, and the per-node tables the smoothers
read.  Nothing here depends on coordinates except the choice of orientation, so
the smoothers never rebuild any of it between passes.

Orientation
    Cells are re-oriented internally (never in the written file) so that every
    cell is counter-clockwise.  Cells are grouped into patches that are
    connected through edges traversed in opposite directions (consistent
    winding); each patch takes the orientation of the sign of its total signed
    area.  A cell whose signed area is then <= 0 is *inverted* (tangled input).
    A file written clockwise, or with some cells written the other way round,
    is therefore read correctly; a folded cell is reported as inverted.

Fixed nodes
    Boundary nodes (outer and holes), nodes of line/vertex cells, nodes between
    cells of different regions, nodes on non-manifold edges or with an open or
    multiple fan, nodes used by no 2D cell, plus the caller's extra nodes.

Per-node tables
    Free nodes are ordered by (colour, index); every table below is sorted by
    the *local* index ``loc`` of its free node, so one colour class is one
    contiguous slice of every table (see :meth:`Topology.blocks`).

    * ring (Laplacian): ``ring_loc``, ``ring_nbr`` — the edge neighbours.
    * spokes (angle method): ``spoke_loc``, ``spoke_ring``, ``spoke_a``,
      ``spoke_b``, ``spoke_frac``.  For free node i and ring node j (edge
      neighbours and, for quads, the diagonal node), ``a`` and ``b`` are the
      nodes beside the spoke j->i such that, turning counter-clockwise about j,
      one meets a, then i, then b.  The angle method puts i on the ray from j
      that splits the counter-clockwise angle a-j-b in the ratio
      ``spoke_frac : 1 - spoke_frac`` (ideal angle of the a side over the sum of
      both ideal angles: 1/2 for equal cell types, 3/5 for quad:triangle).
    * incidence (guards, quality): ``tri_loc``/``tri_verts`` (m, 3) and
      ``quad_loc``/``quad_verts`` (m, 4): each cell around a free node, its
      nodes in counter-clockwise order starting at that node.

    A free node is interior and manifold, so its edge spokes are exactly its
    ring entries; without quads (no diagonal spokes) ``spoke_loc`` and
    ``spoke_ring`` are the very arrays ``ring_loc`` and ``ring_nbr``.

>>> import numpy as np
>>> from anglesmooth.mesh import Mesh2D
>>> pts = [[0, 0], [1, 0], [2, 0], [0, 1], [1, 1], [2, 1], [0, 2], [1, 2], [2, 2]]
>>> quads = [[0, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6], [4, 5, 8, 7]]
>>> topo = build_topology(Mesh2D.from_arrays(pts, quads=quads))
>>> topo.free_nodes.tolist(), topo.n_edges, int(topo.boundary.sum())
([4], 12, 8)
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from .errors import InvalidMeshError
from .mesh import Mesh2D

__all__ = ["Block", "CellTopology", "Topology", "build_cell_topology", "build_topology", "signed_areas"]

TRI_IDEAL = np.pi / 3
QUAD_IDEAL = np.pi / 2


@dataclass(frozen=True, eq=False)
class Block:
    """One update block: slices of the per-node tables plus reduction offsets.

    ``*_starts`` / ``*_has`` let ``np.minimum.reduceat`` reduce the incidence
    rows of the block per node (``has`` is False for a node with no row of that
    cell type); ``*_count`` are the number of rows per node.
    """

    nodes: slice
    ring: slice
    spokes: slice
    tris: slice
    quads: slice
    ring_count: np.ndarray
    spoke_count: np.ndarray
    tri_starts: np.ndarray
    tri_has: np.ndarray
    quad_starts: np.ndarray
    quad_has: np.ndarray

    @property
    def size(self) -> int:
        return self.nodes.stop - self.nodes.start


@dataclass(frozen=True, eq=False)
class CellTopology:
    """The cell-level part of a mesh's topology: oriented cells, edges, boundary, fixed mask.

    All that quality summaries and gates need (:func:`build_cell_topology`);
    smoothing needs the full :class:`Topology`, which extends it.
    """

    n_points: int
    tri: np.ndarray  # (nt, 3) counter-clockwise
    quad: np.ndarray  # (nq, 4) counter-clockwise
    flipped: np.ndarray  # (nt + nq,) bool: cell re-oriented relative to the file
    edges: np.ndarray  # (E, 2) unique, i < j
    edge_cells: np.ndarray  # (E,) number of 2D cells using each edge
    boundary: np.ndarray  # (N,) bool, node on a boundary edge
    fixed: np.ndarray  # (N,) bool
    fixed_reasons: dict  # name -> number of nodes fixed for that reason

    @property
    def n_tri(self) -> int:
        return int(self.tri.shape[0])

    @property
    def n_quad(self) -> int:
        return int(self.quad.shape[0])

    @property
    def n_edges(self) -> int:
        return int(self.edges.shape[0])


@dataclass(frozen=True, eq=False)
class Topology(CellTopology):
    """Everything about a mesh that does not change when nodes move.

    See the module docstring for the meaning of each table.
    """

    # CSR of edge neighbours for every node
    ring_offsets: np.ndarray
    ring_indices: np.ndarray
    # colouring and free-node tables
    colour: np.ndarray  # (N,) int, -1 for fixed nodes
    free_nodes: np.ndarray  # (F,) sorted by (colour, index)
    block_offsets: np.ndarray  # (n_colours + 1,) into free_nodes
    ring_loc: np.ndarray
    ring_nbr: np.ndarray
    spoke_loc: np.ndarray
    spoke_ring: np.ndarray
    spoke_a: np.ndarray
    spoke_b: np.ndarray
    spoke_frac: np.ndarray
    tri_loc: np.ndarray
    tri_verts: np.ndarray
    quad_loc: np.ndarray
    quad_verts: np.ndarray
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def n_free(self) -> int:
        return int(self.free_nodes.shape[0])

    @property
    def n_colours(self) -> int:
        return int(self.block_offsets.shape[0] - 1)

    def blocks(self, order: str = "colour") -> list[Block]:
        """Update blocks: one per colour class (``"colour"``) or all free nodes at once (``"jacobi"``).

        Computed once per topology and order, then cached.
        """
        cached = self._cache.get(("blocks", order))
        if cached is not None:
            return cached
        if order == "jacobi":
            offs = np.array([0, self.n_free], dtype=np.int64)
        elif order == "colour":
            offs = self.block_offsets
        else:
            raise ValueError(f"unknown update order {order!r} (use 'colour' or 'jacobi')")
        out = []
        for k in range(offs.shape[0] - 1):
            a, b = int(offs[k]), int(offs[k + 1])
            ring, spokes = _span(self.ring_loc, a, b), _span(self.spoke_loc, a, b)
            tris, quads = _span(self.tri_loc, a, b), _span(self.quad_loc, a, b)
            ts, th = _starts(self.tri_loc[tris] - a, b - a)
            qs, qh = _starts(self.quad_loc[quads] - a, b - a)
            out.append(
                Block(
                    nodes=slice(a, b),
                    ring=ring,
                    spokes=spokes,
                    tris=tris,
                    quads=quads,
                    ring_count=np.bincount(self.ring_loc[ring] - a, minlength=b - a),
                    spoke_count=np.bincount(self.spoke_loc[spokes] - a, minlength=b - a),
                    tri_starts=ts,
                    tri_has=th,
                    quad_starts=qs,
                    quad_has=qh,
                )
            )
        self._cache[("blocks", order)] = out
        return out

    def ring(self, node: int) -> np.ndarray:
        """Edge neighbours of one node (sorted)."""
        return self.ring_indices[self.ring_offsets[node] : self.ring_offsets[node + 1]]


def _starts(rel: np.ndarray, n: int):
    """reduceat offsets of sorted row owners ``rel`` (0..n-1) and which owners have rows."""
    starts = np.searchsorted(rel, np.arange(n))
    has = np.bincount(rel, minlength=n) > 0
    return starts[has], has


def _span(sorted_loc: np.ndarray, a: int, b: int) -> slice:
    lo, hi = np.searchsorted(sorted_loc, [a, b])
    return slice(int(lo), int(hi))


def signed_areas(points: np.ndarray, tri: np.ndarray, quad: np.ndarray) -> np.ndarray:
    """Signed areas of triangles then quads (shoelace; positive when counter-clockwise).

    >>> import numpy as np
    >>> signed_areas(np.array([[0., 0], [1, 0], [0, 1]]), np.array([[0, 1, 2]]), np.zeros((0, 4), int)).tolist()
    [0.5]
    """
    out = np.empty(tri.shape[0] + quad.shape[0])
    # gathers from the x and y columns (1-D) are much faster than from (N, 2) rows
    x, y = points[:, 0], points[:, 1]
    if tri.shape[0]:
        x0, y0 = x[tri[:, 0]], y[tri[:, 0]]
        _half_cross(x[tri[:, 1]] - x0, y[tri[:, 1]] - y0, x[tri[:, 2]] - x0, y[tri[:, 2]] - y0, out[: tri.shape[0]])
    if quad.shape[0]:
        q = [quad[:, k] for k in range(4)]
        _half_cross(x[q[2]] - x[q[0]], y[q[2]] - y[q[0]], x[q[3]] - x[q[1]], y[q[3]] - y[q[1]], out[tri.shape[0] :])
    return out


def _half_cross(ux, uy, vx, vy, out: np.ndarray) -> None:
    """``out = 0.5 * cross(u, v)``, rounded exactly as ``0.5 * (ux * vy - uy * vx)``."""
    ux *= vy
    uy *= vx
    ux -= uy
    np.multiply(ux, 0.5, out=out)


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


def _components(n: int, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Connected components of a graph with n vertices and edges (u, v): min-label hooking + pointer jumping."""
    label = np.arange(n, dtype=np.int64)
    while True:
        lu, lv = label[u], label[v]
        new = label.copy()
        np.minimum.at(new, lu, lv)
        np.minimum.at(new, lv, lu)
        while True:  # pointer jumping
            nxt = new[new]
            if np.array_equal(nxt, new):
                break
            new = nxt
        if np.array_equal(new, label):
            return label
        label = new


def _orient(points, tri, quad, he: _HalfEdges):
    """Flip cells so that each consistently wound patch is counter-clockwise."""
    nt, nq = tri.shape[0], quad.shape[0]
    nc = nt + nq
    area = signed_areas(points, tri, quad)
    if not he.dup.any():  # every shared edge is traversed in opposite directions
        flip = np.full(nc, area.sum() < 0)
    else:
        i0, i1 = he.order[:-1][he.same], he.order[1:][he.same]
        consistent = he.a[i0] != he.a[i1]  # opposite directions
        cell = _edge_cell(nt, nq)
        comp = _components(nc, cell[i0][consistent], cell[i1][consistent])
        total = np.bincount(comp, weights=area, minlength=nc)
        flip = total[comp] < 0
    if flip.any():
        tri = tri.copy()
        quad = quad.copy()
        ft, fq = flip[:nt], flip[nt:]
        tri[ft] = tri[ft][:, ::-1]
        quad[fq] = quad[fq][:, ::-1]
    return tri, quad, flip


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
    lose, win = np.where(u_loses, u, v), np.where(u_loses, v, u)
    remaining = free.copy()
    loses = np.zeros(n, bool)
    k = 0
    while remaining.any():
        loses[lose] = True
        pick = remaining & ~loses
        colour[pick] = k
        remaining &= loses
        loses[:] = False
        alive = remaining[win]  # a loser is never coloured in its round
        lose, win = lose[alive], win[alive]
        k += 1
    return colour


def _region_interfaces(n: int, parts) -> np.ndarray:
    """Nodes whose corners do not all carry one region; ``parts`` are (cells, region of each cell) pairs."""
    some = np.empty(n, np.int64)  # the region of some corner of each node
    for cells, reg in parts:
        for k in range(cells.shape[1]):
            some[cells[:, k]] = reg
    mixed = np.zeros(n, bool)
    for cells, reg in parts:
        for k in range(cells.shape[1]):
            col = cells[:, k]
            mixed[col[reg != some[col]]] = True
    return mixed


def _pairing(he: _HalfEdges, starts: np.ndarray, e_lo: np.ndarray, n: int):
    """Twins of the directed edges, per node and per edge.

    A directed edge is paired when its edge also holds one running the other
    way; a self-edge v -> v pairs with itself.  Returns ``paired`` (N,), the
    number of paired directed edges leaving each node, and ``up``, ``down``
    (E,): the first two directed edges of each edge's run, as lo -> hi and
    hi -> lo when the run is such a pair (meaningless otherwise).  ``paired``
    is exact at nodes whose edges are each used by at most two cells, which are
    the only nodes it is asked about (the others are fixed as non-manifold).
    """
    opposite = he.same & ~he.dup  # sorted positions q, q + 1: one edge, both directions
    twin = np.zeros(he.a_s.shape[0], bool)
    twin[:-1] = opposite
    twin[1:] |= opposite
    paired = np.bincount(he.a_s[twin], minlength=n)
    loops = he.a == he.b
    if loops.any():
        paired += np.bincount(he.a[loops], minlength=n)
    s0 = he.order[starts]
    s1 = he.order[np.minimum(starts + 1, he.order.shape[0] - 1)]
    up = np.where(he.a_s[starts] == e_lo, s0, s1)  # lo -> hi
    down = s0
    down += s1
    down -= up  # the other one
    return paired, up, down


def _rings(edges: np.ndarray, deg: np.ndarray, n: int):
    """CSR of edge neighbours (rows ascending) and the edge behind every entry.

    Row v lists the neighbours below v (edges with hi == v, by lo), then those
    above it (edges with lo == v, by hi: ``edges`` is sorted by (lo, hi)); a
    self-edge (v, v) appears once in each part.  ``deg`` is the row length.
    """
    lo, hi = edges[:, 0], edges[:, 1]
    ne = edges.shape[0]
    offsets = np.zeros(n + 1, np.int64)
    np.cumsum(deg, out=offsets[1:])
    n_lo = np.bincount(lo, minlength=n)
    n_hi = np.bincount(hi, minlength=n)
    eid = np.arange(ne, dtype=np.int64)
    indices = np.empty(2 * ne, np.int64)
    edge = np.empty(2 * ne, np.int64)
    # upper part: edge e is entry e - (first edge with this lo) of lo's upper part
    pos = (offsets[:-1] + n_hi - (np.cumsum(n_lo) - n_lo))[lo]
    pos += eid
    indices[pos] = hi
    edge[pos] = eid
    # lower part: the edges in (hi, lo) order; the q-th one is entry q - (first of its hi)
    by_hi, hi_sorted = _stable_order(hi)
    pos = (offsets[:-1] - (np.cumsum(n_hi) - n_hi))[hi_sorted]
    pos += eid
    indices[pos] = lo[by_hi]
    edge[pos] = by_hi
    return offsets, indices, edge


def _rows(offsets: np.ndarray, nodes: np.ndarray):
    """The CSR rows of ``nodes``, concatenated: (position in ``nodes``, CSR entry) of every entry."""
    start = offsets[nodes]
    count = offsets[nodes + 1] - start
    owner = np.repeat(np.arange(nodes.shape[0], dtype=np.int64), count)
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
    before = _cell_shift(tri, quad, -1)
    spoke_b = before[h_in]
    spoke_a = (_cell_shift(tri, quad, 2) if quad.size else before)[h_out]  # the same node in a triangle
    # frac = ideal angle of the a side / both; a side in the cell of p -> j, b side in that of j -> p
    ideal = np.array([TRI_IDEAL, QUAD_IDEAL])
    frac = (ideal[:, None] / (ideal[:, None] + ideal[None, :])).ravel()
    side = (h_out >= tri.size).view(np.uint8) * np.uint8(2)
    side += h_in >= tri.size
    return spoke_a, spoke_b, frac[side]


def _with_diagonals(quad: np.ndarray, loc_of: np.ndarray, nf: int, spokes):
    """Merge the diagonal spokes of quads after the edge spokes (loc, ring, a, b, frac) of each node.

    Every quad corner j (b before it, a after it) gives the opposite corner's
    node, when free, a spoke to j with sides a and b and frac 1/2; the
    diagonal spokes of one node are in corner order.
    """
    no_tri = np.zeros((0, 3), np.int64)
    e_loc = spokes[0]
    d_loc, qc = _by_loc(loc_of[_cell_shift(no_tri, quad, 2)], quad.size, np.arange(quad.size, dtype=np.int64))
    ne = np.bincount(e_loc, minlength=nf)
    nd = np.bincount(d_loc, minlength=nf)
    off = np.zeros(nf + 1, np.int64)
    np.cumsum(ne + nd, out=off[1:])
    pos_e = np.arange(e_loc.shape[0]) - (np.cumsum(ne) - ne)[e_loc] + off[e_loc]
    pos_d = np.arange(d_loc.shape[0]) - (np.cumsum(nd) - nd)[d_loc] + off[d_loc] + ne[d_loc]
    m = off[-1]
    merged = []
    for e_col, d_col in zip(
        spokes,
        (
            d_loc,
            quad.ravel()[qc],
            _cell_shift(no_tri, quad, 1)[qc],
            _cell_shift(no_tri, quad, -1)[qc],
            np.full(qc.shape[0], 0.5),
        ),
    ):
        col = np.empty(m, e_col.dtype)
        col[pos_e] = e_col
        col[pos_d] = d_col
        merged.append(col)
    return tuple(merged)


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


def _incidence(cells: np.ndarray, loc_of: np.ndarray, free_nodes: np.ndarray):
    """(loc, rotated cell) for every corner at a free node, sorted by (loc, rotation, cell)."""
    nc, k = cells.shape
    width = k * nc
    # ext[r], r = rotation * nc + cell, is the node of that corner; the nodes after it in
    # the cell are ext[r + nc], ext[r + 2 nc], ... (ext repeats the first k - 1 rotations)
    ext = np.empty(width + (k - 1) * nc, np.int64)
    ext[:width].reshape(k, nc)[:] = cells.T
    ext[width:] = ext[: (k - 1) * nc]
    loc, r = _by_loc(loc_of[ext[:width]], width, np.arange(width, dtype=np.int64))
    verts = np.empty((r.shape[0], k), np.int64)
    verts[:, 0] = free_nodes[loc]  # the node itself
    for m in range(1, k):
        r += nc
        np.take(ext, r, out=verts[:, m], mode="clip")  # all in range; "clip" writes straight into the column
    return loc, verts


def build_cell_topology(mesh: Mesh2D, extra_fixed: np.ndarray | None = None) -> CellTopology:
    """Oriented cells, edges, boundary and fixed mask of ``mesh``, without the smoothing tables.

    The same values as the corresponding fields of :func:`build_topology`, at
    about half its cost (1M triangles: 0.7-0.9 s instead of 1.7 s): enough for
    :func:`anglesmooth.quality.summarize` and the quality gates (``anglesmooth
    check``).

    >>> from anglesmooth.generate import structured_quads
    >>> cells = build_cell_topology(structured_quads(3, 3))
    >>> cells.n_quad, int(cells.fixed.sum()), int((~cells.fixed).sum())
    (9, 12, 4)
    """
    return _cell_topology(mesh, extra_fixed)[0]


def _cell_topology(mesh: Mesh2D, extra_fixed):
    """:class:`CellTopology` plus what :func:`build_topology` goes on from (edge degrees, edge twins)."""
    n = mesh.n_points
    if mesh.n_cells == 0:
        raise InvalidMeshError("the mesh has no triangle or quad cells")
    pts = mesh.points
    he = _HalfEdges(mesh.triangles, mesh.quads, n)
    tri, quad, flipped = _orient(pts, mesh.triangles, mesh.quads, he)
    if flipped.any():
        he = _HalfEdges(tri, quad, n)
    nt, nq = tri.shape[0], quad.shape[0]

    # --- edges -----------------------------------------------------------
    a, nh = he.a, he.a.shape[0]
    first = np.empty(nh, bool)
    first[0] = True
    np.logical_not(he.same, out=first[1:])
    starts = np.flatnonzero(first)  # sorted position of the first directed edge of each edge
    counts = np.diff(np.append(starts, nh))
    uniq = he.ks[starts]  # lo * n + hi of each edge
    e_lo = uniq // n
    edges = np.stack([e_lo, uniq - e_lo * n], axis=1)
    bnd_edges = edges[counts == 1]
    boundary = np.zeros(n, bool)
    boundary[bnd_edges.ravel()] = True

    # --- fixed nodes -----------------------------------------------------
    reasons: dict[str, int] = {}
    used = np.zeros(n, bool)
    used[a] = True  # a lists the node of every corner
    fixed = boundary | ~used
    reasons["boundary"] = int(boundary.sum())
    reasons["unused"] = int((~used).sum())
    pinned = mesh.pinned & ~fixed
    reasons["line/vertex cells"] = int(pinned.sum())
    fixed |= mesh.pinned
    # interfaces between regions: a node whose corners do not all carry the region of one of them
    if mesh.triangle_region is not None or mesh.quad_region is not None:
        none = -(2**62)
        mixed = _region_interfaces(
            n,
            [
                (tri, mesh.triangle_region if mesh.triangle_region is not None else np.full(nt, none)),
                (quad, mesh.quad_region if mesh.quad_region is not None else np.full(nq, none)),
            ],
        )
        iface = mixed & ~fixed
        reasons["region interfaces"] = int(iface.sum())
        fixed |= iface
    # non-manifold: an edge used by > 2 cells, or a fan that is not one closed disc
    nm = np.zeros(n, bool)
    nm[edges[counts > 2].ravel()] = True
    deg_edges = np.bincount(edges.ravel(), minlength=n)
    deg_cells = np.bincount(a, minlength=n)
    nm |= used & ~boundary & (deg_edges != deg_cells)
    # consistent orientation around the node: every interior edge is traversed both ways
    if he.dup.any():
        bad = he.order[:-1][he.dup]
        nm[a[bad]] = True
        nm[he.b[bad]] = True
    nm &= ~fixed
    reasons["non-manifold"] = int(nm.sum())
    fixed |= nm
    if extra_fixed is not None:
        ef = np.asarray(extra_fixed)
        if ef.dtype == bool:
            if ef.shape != (n,):
                raise InvalidMeshError(f"fixed mask has shape {ef.shape}, expected ({n},)")
            mask = ef
        else:
            ef = ef.astype(np.int64).ravel()
            if ef.size and (ef.min() < 0 or ef.max() >= n):
                raise InvalidMeshError(f"fixed node index out of range 0..{n - 1}")
            mask = np.zeros(n, bool)
            mask[ef] = True
        reasons["user"] = int((mask & ~fixed).sum())
        fixed = fixed | mask
    # a free node needs every one of its edges paired (closed fan)
    paired, up, down = _pairing(he, starts, e_lo, n)
    del he, a  # the directed edges are not needed any more
    open_fan = used & ~fixed & (paired != deg_edges)
    if open_fan.any():
        reasons["non-manifold"] = reasons.get("non-manifold", 0) + int(open_fan.sum())
        fixed = fixed | open_fan
    cells = CellTopology(
        n_points=n, tri=tri, quad=quad, flipped=flipped, edges=edges, edge_cells=counts, boundary=boundary,
        fixed=fixed, fixed_reasons=reasons,
    )
    return cells, (deg_edges, up, down)


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

    # --- rings (CSR of edge neighbours) ----------------------------------
    ring_offsets, ring_indices, ring_edge = _rings(edges, deg_edges, n)

    # --- colouring: nodes sharing a cell get different colours -----------
    pu, pv = [edges[:, 0]], [edges[:, 1]]
    if nq:
        pu += [quad[:, 0], quad[:, 1]]
        pv += [quad[:, 2], quad[:, 3]]
    colour = _colour(n, free, np.concatenate(pu), np.concatenate(pv))
    free_idx = np.flatnonzero(free)
    free_nodes = free_idx[_stable_order(colour[free_idx])[0]]
    ncol = int(colour.max()) + 1 if free_nodes.size else 0
    block_offsets = np.searchsorted(colour[free_nodes], np.arange(ncol + 1))
    loc_of = np.full(n, -1, np.int64)
    loc_of[free_nodes] = np.arange(free_nodes.shape[0])
    nf = free_nodes.shape[0]

    # --- per-node tables, sorted by loc ----------------------------------
    # rings: the CSR rows of the free nodes in loc order
    ring_loc, entry = _rows(ring_offsets, free_nodes)
    ring_nbr = ring_indices[entry]
    # edge spokes: one per ring entry (a free node is interior and manifold)
    e = ring_edge[entry]
    del entry, ring_edge
    spokes = (ring_loc, ring_nbr, *_edge_spokes(tri, quad, free_nodes[ring_loc], ring_nbr, up[e], down[e]))
    del e, up, down
    if nq:
        spokes = _with_diagonals(quad, loc_of, nf, spokes)
    spoke_loc, spoke_ring, spoke_a, spoke_b, spoke_frac = spokes
    # incidence: every cell around a free node, rotated to start at that node;
    # row r = k * n_cells + cell (rotation k major), rows of one node in r order
    tri_loc, tri_verts = _incidence(tri, loc_of, free_nodes)
    quad_loc, quad_verts = _incidence(quad, loc_of, free_nodes)

    return Topology(
        **{f.name: getattr(cells, f.name) for f in fields(CellTopology)},
        ring_offsets=ring_offsets,
        ring_indices=ring_indices,
        colour=np.where(free, colour, -1),
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
        quad_loc=quad_loc,
        quad_verts=quad_verts,
    )
