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

>>> import numpy as np
>>> from anglesmooth.mesh import Mesh2D
>>> pts = [[0, 0], [1, 0], [2, 0], [0, 1], [1, 1], [2, 1], [0, 2], [1, 2], [2, 2]]
>>> quads = [[0, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6], [4, 5, 8, 7]]
>>> topo = build_topology(Mesh2D.from_arrays(pts, quads=quads))
>>> topo.free_nodes.tolist(), topo.n_edges, int(topo.boundary.sum())
([4], 12, 8)
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import InvalidMeshError
from .mesh import Mesh2D

__all__ = ["Block", "Topology", "build_topology", "signed_areas"]

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
class Topology:
    """Everything about a mesh that does not change when nodes move.

    See the module docstring for the meaning of each table.
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
    def n_tri(self) -> int:
        return int(self.tri.shape[0])

    @property
    def n_quad(self) -> int:
        return int(self.quad.shape[0])

    @property
    def n_edges(self) -> int:
        return int(self.edges.shape[0])

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
    if tri.shape[0]:
        p0, p1, p2 = points[tri[:, 0]], points[tri[:, 1]], points[tri[:, 2]]
        out[: tri.shape[0]] = 0.5 * _cross(p1 - p0, p2 - p0)
    if quad.shape[0]:
        p0, p1, p2, p3 = (points[quad[:, k]] for k in range(4))
        out[tri.shape[0] :] = 0.5 * _cross(p2 - p0, p3 - p1)
    return out


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]


def _edge_keys(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    lo = np.minimum(a, b)
    hi = np.maximum(a, b)
    return lo * np.int64(n) + hi


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
        packed = np.sort((key << shift) | np.arange(m, dtype=np.int64))
        return packed & ((1 << shift) - 1), packed >> shift
    order = np.argsort(key, kind="stable")
    return order, key[order]


def _cell_edges(tri: np.ndarray, quad: np.ndarray):
    """Directed edges (a -> b) of every cell; edge h is also corner h (at node a[h])."""
    a = np.concatenate([tri.ravel(), quad.ravel()])
    b = np.concatenate([tri[:, [1, 2, 0]].ravel(), quad[:, [1, 2, 3, 0]].ravel()])
    return a, b


def _edge_cell(nt: int, nq: int) -> np.ndarray:
    """The cell of every directed edge / corner."""
    return np.concatenate([np.repeat(np.arange(nt), 3), nt + np.repeat(np.arange(nq), 4)])


def _corner_shift(nt: int, nq: int, step: int) -> np.ndarray:
    """Index of the corner ``step`` places further counter-clockwise in the same cell, for every corner."""
    t = (3 * np.arange(nt)[:, None] + (np.arange(step, step + 3) % 3)).ravel()
    q = (3 * nt + 4 * np.arange(nq)[:, None] + (np.arange(step, step + 4) % 4)).ravel()
    return np.concatenate([t, q])


class _HalfEdges:
    """Directed cell edges sorted by their undirected key (stable): twins are adjacent."""

    def __init__(self, tri: np.ndarray, quad: np.ndarray, n: int):
        self.a, self.b = _cell_edges(tri, quad)
        self.order, self.ks = _stable_order(_edge_keys(self.a, self.b, n))
        self.same = self.ks[1:] == self.ks[:-1]


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
    i0, i1 = he.order[:-1][he.same], he.order[1:][he.same]
    consistent = he.a[i0] != he.a[i1]  # opposite directions
    area = signed_areas(points, tri, quad)
    if consistent.all():
        flip = np.full(nc, area.sum() < 0)
    else:
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
    remaining = free.copy()
    loses = np.zeros(n, bool)
    k = 0
    while remaining.any():
        pu, pv = prio[u], prio[v]
        loses[np.where(pu < pv, u, v)] = True
        pick = remaining & ~loses
        colour[pick] = k
        remaining &= loses
        loses[:] = False
        alive = remaining[u] & remaining[v]
        u, v = u[alive], v[alive]
        k += 1
    return colour


def _by_loc(loc: np.ndarray, width: int, value: np.ndarray):
    """Rows with a free owner (``loc >= 0``) sorted by (loc, value) with one packed ``np.sort``.

    ``value`` (< width) orders the rows of one owner; returns (loc, value) of the sorted rows.
    """
    keep = loc >= 0
    key = np.sort(loc[keep] * np.int64(width) + value[keep])
    return key // width, key % width


def _incidence(cells: np.ndarray, loc_of: np.ndarray):
    """(loc, rotated cell) for every corner at a free node, sorted by (loc, rotation, cell)."""
    nc, k = cells.shape
    width = k * nc
    loc, r = _by_loc(loc_of[cells.T.ravel()], max(width, 1), np.arange(width, dtype=np.int64))
    cell, rot = r % max(nc, 1), r // max(nc, 1)
    flat = cells.ravel()
    verts = np.empty((r.shape[0], k), np.int64)
    for m in range(k):
        verts[:, m] = flat[k * cell + (rot + m) % k]
    return loc, verts


def build_topology(mesh: Mesh2D, extra_fixed: np.ndarray | None = None) -> Topology:
    """Build the :class:`Topology` of ``mesh``.

    Parameters
    ----------
    mesh : Mesh2D
    extra_fixed : (N,) bool array or int array of node indices, optional
        Nodes to keep fixed in addition to the default rules.
    """
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
    a, b, order, ks = he.a, he.b, he.order, he.ks
    first = np.empty(ks.shape[0], bool)
    first[0] = True
    np.logical_not(he.same, out=first[1:])
    starts = np.flatnonzero(first)
    uniq = ks[starts]
    counts = np.diff(np.append(starts, ks.shape[0]))
    edges = np.stack([uniq // n, uniq % n], axis=1)
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
        reg = np.concatenate(
            [
                mesh.triangle_region if mesh.triangle_region is not None else np.full(nt, -(2**62)),
                mesh.quad_region if mesh.quad_region is not None else np.full(nq, -(2**62)),
            ]
        )
        reg_all = np.concatenate([np.repeat(reg[:nt], 3), np.repeat(reg[nt:], 4)])
        some = np.empty(n, np.int64)
        some[a] = reg_all
        mixed = np.zeros(n, bool)
        mixed[a[reg_all != some[a]]] = True
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
    a_s = a[order]
    dup_same = he.same & (a_s[1:] == a_s[:-1])
    if dup_same.any():
        bad = order[:-1][dup_same]
        nm[a[bad]] = True
        nm[b[bad]] = True
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

    # --- rings (CSR of edge neighbours) ----------------------------------
    rkey = np.sort(np.concatenate([uniq, edges[:, 1] * np.int64(n) + edges[:, 0]]))
    src, dst = rkey // n, rkey % n
    ring_offsets = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(src, minlength=n), out=ring_offsets[1:])

    # --- spokes ------------------------------------------------------------
    # Corner c = (prev, node, next) of a cell; the directed edge h = c runs node -> next.
    # side A: corner (p, j, x) gives spoke (center=p, ring=j) with a = x
    # side B: corner (x, j, q) gives spoke (center=q, ring=j) with b = x
    # The side-B corner of spoke (p, j) is the twin p <- j of the edge p -> j into
    # side-A corner c: the first (lowest) directed edge j -> p, found in the
    # sorted run of edge {p, j} (runs are stable, so ascending in h).
    nh = a.shape[0]
    gid = np.cumsum(first) - 1  # run of each sorted position
    lo_s = edges[gid, 0]
    b_s = b[order]
    first_lo = np.minimum.reduceat(np.where(a_s == lo_s, order, nh), starts)
    first_hi = np.minimum.reduceat(np.where(a_s != lo_s, order, nh), starts)
    twin = np.empty(nh, np.int64)
    twin[order] = np.where(b_s == lo_s, first_lo[gid], first_hi[gid])
    pred = _corner_shift(nt, nq, -1)
    twin_in = twin[pred]  # side-B corner of every side-A corner, nh when unpaired
    prev = a[pred]
    matched = twin_in < nh
    # a free node needs every one of its edges paired (closed fan)
    paired = np.bincount(prev[matched], minlength=n)
    open_fan = used & ~fixed & (paired != deg_edges)
    if open_fan.any():
        reasons["non-manifold"] = reasons.get("non-manifold", 0) + int(open_fan.sum())
        fixed = fixed | open_fan
    free = ~fixed

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
    ring_loc, ring_nbr = _by_loc(loc_of[src], n, dst)
    # edge spokes: side-A corners with a free centre, by (loc, ring node, corner)
    rows = np.flatnonzero(matched & (loc_of[prev] >= 0))
    e_loc = loc_of[prev[rows]]
    o, _ = _stable_order(e_loc * np.int64(n) + a[rows])
    rows, e_loc = rows[o], e_loc[o]
    c_b = twin_in[rows]
    e_ideal_a = np.where(rows < 3 * nt, TRI_IDEAL, QUAD_IDEAL)
    e_ideal_b = np.where(c_b < 3 * nt, TRI_IDEAL, QUAD_IDEAL)
    spoke_loc = e_loc
    spoke_ring = a[rows]
    spoke_a = b[rows]
    spoke_b = prev[c_b]
    spoke_frac = e_ideal_a / (e_ideal_a + e_ideal_b)
    if nq:
        # diagonal spokes (quads): centre = opposite corner, after the edge spokes of each node
        qc = np.arange(3 * nt, nh)
        d_loc = loc_of[a[_corner_shift(nt, nq, 2)[3 * nt :]]]
        keep = d_loc >= 0
        qc, d_loc = qc[keep], d_loc[keep]
        o, _ = _stable_order(d_loc)
        qc, d_loc = qc[o], d_loc[o]
        ne = np.bincount(e_loc, minlength=nf)
        nd = np.bincount(d_loc, minlength=nf)
        off = np.zeros(nf + 1, np.int64)
        np.cumsum(ne + nd, out=off[1:])
        pos_e = np.arange(e_loc.shape[0]) - (np.cumsum(ne) - ne)[e_loc] + off[e_loc]
        pos_d = np.arange(d_loc.shape[0]) - (np.cumsum(nd) - nd)[d_loc] + off[d_loc] + ne[d_loc]
        m = off[-1]
        merged = []
        for e_col, d_col in (
            (spoke_loc, d_loc),
            (spoke_ring, a[qc]),
            (spoke_a, b[qc]),
            (spoke_b, prev[qc]),
            (spoke_frac, np.full(qc.shape[0], 0.5)),
        ):
            col = np.empty(m, e_col.dtype)
            col[pos_e] = e_col
            col[pos_d] = d_col
            merged.append(col)
        spoke_loc, spoke_ring, spoke_a, spoke_b, spoke_frac = merged
    # incidence: every cell around a free node, rotated to start at that node;
    # row r = k * n_cells + cell (rotation k major), rows of one node in r order
    tri_loc, tri_verts = _incidence(tri, loc_of)
    quad_loc, quad_verts = _incidence(quad, loc_of)

    return Topology(
        n_points=n,
        tri=tri,
        quad=quad,
        flipped=flipped,
        edges=edges,
        edge_cells=counts,
        boundary=boundary,
        fixed=fixed,
        fixed_reasons=reasons,
        ring_offsets=ring_offsets,
        ring_indices=dst,
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
