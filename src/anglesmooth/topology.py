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


def _cell_edges(tri: np.ndarray, quad: np.ndarray):
    """Directed edges (a -> b) of every cell and the cell they belong to."""
    nt = tri.shape[0]
    a = np.concatenate([tri.ravel(), quad.ravel()])
    b = np.concatenate([np.roll(tri, -1, axis=1).ravel(), np.roll(quad, -1, axis=1).ravel()])
    cell = np.concatenate([np.repeat(np.arange(nt), 3), nt + np.repeat(np.arange(quad.shape[0]), 4)])
    return a, b, cell


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


def _orient(points, tri, quad, n):
    """Flip cells so that each consistently wound patch is counter-clockwise."""
    nc = tri.shape[0] + quad.shape[0]
    a, b, cell = _cell_edges(tri, quad)
    key = _edge_keys(a, b, n)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    same = ks[1:] == ks[:-1]
    i0, i1 = order[:-1][same], order[1:][same]
    consistent = a[i0] != a[i1]  # opposite directions
    area = signed_areas(points, tri, quad)
    if consistent.all():
        flip = np.full(nc, area.sum() < 0)
    else:
        comp = _components(nc, cell[i0][consistent], cell[i1][consistent])
        total = np.bincount(comp, weights=area, minlength=nc)
        flip = total[comp] < 0
    if flip.any():
        nt = tri.shape[0]
        tri = tri.copy()
        quad = quad.copy()
        ft, fq = flip[:nt], flip[nt:]
        tri[ft] = tri[ft][:, ::-1]
        quad[fq] = quad[fq][:, ::-1]
    return tri, quad, flip


def _corners(tri: np.ndarray, quad: np.ndarray):
    """Every cell corner as (prev, node, next, diag, ideal, cell) arrays."""
    nt = tri.shape[0]
    prev = np.concatenate([np.roll(tri, 1, axis=1).ravel(), np.roll(quad, 1, axis=1).ravel()])
    node = np.concatenate([tri.ravel(), quad.ravel()])
    nxt = np.concatenate([np.roll(tri, -1, axis=1).ravel(), np.roll(quad, -1, axis=1).ravel()])
    diag = np.concatenate([np.full(tri.size, -1, np.int64), np.roll(quad, 2, axis=1).ravel()])
    ideal = np.concatenate([np.full(tri.size, TRI_IDEAL), np.full(quad.size, QUAD_IDEAL)])
    cell = np.concatenate([np.repeat(np.arange(nt), 3), nt + np.repeat(np.arange(quad.shape[0]), 4)])
    return prev, node, nxt, diag, ideal, cell


def _colour(n: int, free: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Colour free nodes so that no two nodes of one cell share a colour.

    Luby / Jones-Plassmann rounds: in each round the uncoloured nodes whose
    (fixed, pseudo-random) priority beats every uncoloured neighbour's form the
    next colour class.  (u, v) are the directed node pairs that share a cell.
    """
    colour = np.full(n, -1, dtype=np.int64)
    if not free.any():
        return colour
    keep = free[u] & free[v]
    u, v = u[keep], v[keep]
    order = np.argsort(u, kind="stable")
    u, v = u[order], v[order]
    prio = np.random.default_rng(12345).permutation(n).astype(np.int64)
    # CSR over u for reduceat; nodes with no free neighbour are coloured in round 0
    starts = np.searchsorted(u, np.arange(n))
    has = np.zeros(n, bool)
    has[u] = True
    cur = np.where(free, prio, -1)
    k = 0
    remaining = free.copy()
    while remaining.any():
        nb_max = np.full(n, -1, dtype=np.int64)
        if u.size:
            red = np.maximum.reduceat(cur[v], starts[has])
            nb_max[has] = red
        pick = remaining & (cur > nb_max)
        colour[pick] = k
        cur[pick] = -1
        remaining &= ~pick
        k += 1
    return colour


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
    tri, quad, flipped = _orient(pts, mesh.triangles, mesh.quads, n)
    nt = tri.shape[0]

    # --- edges -----------------------------------------------------------
    a, b, cell = _cell_edges(tri, quad)
    key = _edge_keys(a, b, n)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    first = np.empty(ks.shape[0], bool)
    first[0] = True
    first[1:] = ks[1:] != ks[:-1]
    uniq = ks[first]
    counts = np.diff(np.append(np.flatnonzero(first), ks.shape[0]))
    edges = np.stack([uniq // n, uniq % n], axis=1)
    bnd_edges = edges[counts == 1]
    boundary = np.zeros(n, bool)
    boundary[bnd_edges.ravel()] = True

    # --- fixed nodes -----------------------------------------------------
    reasons: dict[str, int] = {}
    used = np.zeros(n, bool)
    used[tri.ravel()] = True
    used[quad.ravel()] = True
    fixed = boundary | ~used
    reasons["boundary"] = int(boundary.sum())
    reasons["unused"] = int((~used).sum())
    pinned = mesh.pinned & ~fixed
    reasons["line/vertex cells"] = int(pinned.sum())
    fixed |= mesh.pinned
    # interfaces between regions
    if mesh.triangle_region is not None or mesh.quad_region is not None:
        reg = np.concatenate(
            [
                mesh.triangle_region if mesh.triangle_region is not None else np.full(nt, -(2**62)),
                mesh.quad_region if mesh.quad_region is not None else np.full(quad.shape[0], -(2**62)),
            ]
        )
        node_all = np.concatenate([tri.ravel(), quad.ravel()])
        reg_all = np.concatenate([np.repeat(reg[:nt], 3), np.repeat(reg[nt:], 4)])
        rmin = np.full(n, np.iinfo(np.int64).max)
        rmax = np.full(n, np.iinfo(np.int64).min)
        np.minimum.at(rmin, node_all, reg_all)
        np.maximum.at(rmax, node_all, reg_all)
        iface = used & (rmin != rmax) & ~fixed
        reasons["region interfaces"] = int(iface.sum())
        fixed |= iface
    # non-manifold: an edge used by > 2 cells, or a fan that is not one closed disc
    nm = np.zeros(n, bool)
    nm[edges[counts > 2].ravel()] = True
    deg_edges = np.bincount(edges.ravel(), minlength=n)
    deg_cells = np.bincount(np.concatenate([tri.ravel(), quad.ravel()]), minlength=n)
    nm |= used & ~boundary & (deg_edges != deg_cells)
    # consistent orientation around the node: every interior edge is traversed both ways
    a_s = a[order]
    dup_same = (ks[1:] == ks[:-1]) & (a_s[1:] == a_s[:-1])
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
    src = np.concatenate([edges[:, 0], edges[:, 1]])
    dst = np.concatenate([edges[:, 1], edges[:, 0]])
    o = np.lexsort((dst, src))
    src, dst = src[o], dst[o]
    ring_offsets = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(src, minlength=n), out=ring_offsets[1:])

    # --- corners and spokes ----------------------------------------------
    prev, node, nxt, diag, ideal, ccell = _corners(tri, quad)
    # side A: corner (p, j, x) gives spoke (center=p, ring=j) with a = x
    # side B: corner (x, j, q) gives spoke (center=q, ring=j) with b = x
    ka = prev * np.int64(n) + node
    kb = nxt * np.int64(n) + node
    oa = np.argsort(ka, kind="stable")
    ob = np.argsort(kb, kind="stable")
    kbs = kb[ob]
    pos = np.searchsorted(kbs, ka[oa])
    pos_c = np.minimum(pos, kbs.shape[0] - 1)
    match = kbs[pos_c] == ka[oa]
    ia = oa[match]
    ib = ob[pos_c[match]]
    e_center = prev[ia]
    e_ring = node[ia]
    e_a = nxt[ia]
    e_b = prev[ib]
    e_frac = ideal[ia] / (ideal[ia] + ideal[ib])
    isq = diag >= 0
    d_center = diag[isq]
    d_ring = node[isq]
    d_a = nxt[isq]
    d_b = prev[isq]
    d_frac = np.full(d_center.shape[0], 0.5)
    # a free node needs every one of its edges paired (closed fan)
    paired = np.bincount(e_center, minlength=n)
    open_fan = used & ~fixed & (paired != deg_edges)
    if open_fan.any():
        reasons["non-manifold"] = reasons.get("non-manifold", 0) + int(open_fan.sum())
        fixed = fixed | open_fan
    free = ~fixed

    # --- colouring: nodes sharing a cell get different colours -----------
    pu = [edges[:, 0], edges[:, 1]]
    pv = [edges[:, 1], edges[:, 0]]
    if quad.shape[0]:
        pu += [quad[:, 0], quad[:, 2], quad[:, 1], quad[:, 3]]
        pv += [quad[:, 2], quad[:, 0], quad[:, 3], quad[:, 1]]
    colour = _colour(n, free, np.concatenate(pu), np.concatenate(pv))
    free_idx = np.flatnonzero(free)
    free_nodes = free_idx[np.lexsort((free_idx, colour[free_idx]))]
    ncol = int(colour.max()) + 1 if free_nodes.size else 0
    block_offsets = np.searchsorted(colour[free_nodes], np.arange(ncol + 1))
    loc_of = np.full(n, -1, np.int64)
    loc_of[free_nodes] = np.arange(free_nodes.shape[0])

    def by_loc(center, *cols):
        loc = loc_of[center]
        keep = loc >= 0
        loc = loc[keep]
        o = np.argsort(loc, kind="stable")
        return (loc[o],) + tuple(c[keep][o] for c in cols)

    ring_loc, ring_nbr = by_loc(src, dst)
    spoke_loc, spoke_ring, spoke_a, spoke_b, spoke_frac = by_loc(
        np.concatenate([e_center, d_center]),
        np.concatenate([e_ring, d_ring]),
        np.concatenate([e_a, d_a]),
        np.concatenate([e_b, d_b]),
        np.concatenate([e_frac, d_frac]),
    )
    # incidence: every cell around a free node, rotated to start at that node
    tri_rot = np.concatenate([tri, np.roll(tri, -1, axis=1), np.roll(tri, -2, axis=1)])
    tri_loc, tri_verts = by_loc(tri_rot[:, 0], tri_rot)
    quad_rot = np.concatenate([np.roll(quad, -k, axis=1) for k in range(4)])
    quad_loc, quad_verts = by_loc(quad_rot[:, 0], quad_rot)

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
