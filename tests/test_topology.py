"""build_cell_topology gives exactly the cell-level fields of build_topology, and summaries from either agree."""

from __future__ import annotations

from dataclasses import fields

import numpy as np
import pytest
from meshes import distorted, mixed_small, paper_mixed, regular_quads, regular_triangles, two_regions, with_hole

from anglesmooth.mesh import Mesh2D
from anglesmooth.quality import summarize
from anglesmooth.topology import CellTopology, Topology, build_cell_topology, build_topology


def clockwise(mesh: Mesh2D) -> Mesh2D:
    """Every cell written the other way round (the topology re-orients them all)."""
    return Mesh2D.from_arrays(mesh.points, triangles=mesh.triangles[:, ::-1], quads=mesh.quads[:, ::-1])


def half_flipped(mesh: Mesh2D) -> Mesh2D:
    """Every other triangle written clockwise: inconsistent winding, re-oriented patch by patch."""
    tri = mesh.triangles.copy()
    tri[::2] = tri[::2, ::-1]
    return Mesh2D.from_arrays(mesh.points, triangles=tri, quads=mesh.quads)


def bow_tie() -> Mesh2D:
    """Two fans of four triangles sharing one node (non-manifold there) plus an unused node."""
    pts = [[0, 0], [1, 0], [1, 1], [0, 1], [-1, 1], [-1, 0], [-1, -1], [0, -1], [1, -1], [5, 5]]
    pts = np.array(pts, float)
    tri = [[0, 1, 2], [0, 2, 3], [0, 5, 6], [0, 6, 7]]
    return Mesh2D.from_arrays(np.r_[pts, [[2, 2]]], triangles=tri)


MESHES = {
    "triangles": lambda: regular_triangles(6, 6),
    "quads": lambda: regular_quads(5, 5),
    "hole": lambda: with_hole("quad"),
    "regions": two_regions,
    "mixed": mixed_small,
    "paper-mixed": lambda: paper_mixed(1),
    "distorted": distorted,
    "clockwise": lambda: clockwise(mixed_small()),
    "half-flipped": lambda: half_flipped(regular_triangles(6, 6)),
    "bow-tie": bow_tie,
}


def _equal(a, b) -> bool:
    return a == b if isinstance(a, (int, dict)) else (a.dtype == b.dtype and np.array_equal(a, b))


@pytest.mark.parametrize("name", MESHES)
@pytest.mark.parametrize("extra", [False, True])
def test_cell_topology_is_the_cell_part_of_the_full_topology(name, extra):
    mesh = MESHES[name]()
    fix = np.arange(0, mesh.n_points, 7) if extra else None
    cells, full = build_cell_topology(mesh, fix), build_topology(mesh, fix)
    assert type(cells) is CellTopology and isinstance(full, CellTopology) and isinstance(full, Topology)
    for f in fields(CellTopology):
        assert _equal(getattr(cells, f.name), getattr(full, f.name)), f.name
    assert (cells.n_tri, cells.n_quad, cells.n_edges) == (full.n_tri, full.n_quad, full.n_edges)
    rng = np.random.default_rng(0)
    p = mesh.points + rng.normal(scale=0.05, size=mesh.points.shape)  # some cells poor, some inverted
    assert summarize(p, cells) == summarize(p, full)


def test_bow_tie_fixes_its_shared_node_and_unused_nodes():
    mesh = bow_tie()
    cells = build_cell_topology(mesh)
    unused = np.setdiff1d(np.arange(mesh.n_points), mesh.triangles)
    assert cells.fixed.all()  # the shared node and every other used node lie on the boundary
    assert cells.fixed_reasons["unused"] == unused.size == 4


def _layered_mixed() -> Mesh2D:
    """Thin quads graded towards the bottom (a boundary layer) below a row of triangles, with a hole
    (a removed quad): every table kind (edge and diagonal spokes, both incidences) and hole boundary."""
    from anglesmooth.generate import structured_quads

    m = structured_quads(8, 6)
    p = m.points.copy()
    p[:, 1] = p[:, 1].max() * (p[:, 1] / p[:, 1].max()) ** 3
    quads = np.delete(m.quads, [19], axis=0)  # a hole away from the outer boundary
    top = quads[-8:]
    tri = np.concatenate([top[:, [0, 1, 2]], top[:, [0, 2, 3]]])
    return Mesh2D.from_arrays(p, triangles=tri, quads=quads[:-8])


@pytest.mark.parametrize("name", [*MESHES, "layered-mixed"])
def test_int32_tables_hold_the_int64_build_values(name, monkeypatch):
    """The index tables are int32 when the mesh allows (half the memory); forcing int64 (what a mesh
    beyond 2**31 entries gets) gives the same values in every table and every block."""
    from anglesmooth.topology import _keys

    mesh = _layered_mixed() if name == "layered-mixed" else MESHES[name]()
    fix = np.arange(0, mesh.n_points, 5)
    small = build_topology(mesh, fix)
    monkeypatch.setattr(_keys, "INT32_MAX", 0)
    wide = build_topology(mesh, fix)
    assert small.tri_verts.dtype == small.ring_nbr.dtype == small.edges.dtype == np.int32
    assert wide.tri_verts.dtype == wide.ring_nbr.dtype == wide.edges.dtype == np.int64
    for f in fields(Topology):
        a, b = getattr(small, f.name), getattr(wide, f.name)
        if isinstance(a, np.ndarray):
            assert a.shape == b.shape and np.array_equal(a, b), f.name
        elif f.name != "_cache":
            assert a == b, f.name
    for p, q in zip(small.blocks(), wide.blocks(), strict=True):
        for name in BLOCK_FIELDS:
            a, b = getattr(p, name), getattr(q, name)
            assert np.array_equal(a, b) if isinstance(a, np.ndarray) else a == b, name


BLOCK_FIELDS = ("nodes", "ring", "spokes", "tris", "quads", "ring_count", "spoke_count", "tri_starts", "tri_has",
                "quad_starts", "quad_has")


@pytest.mark.parametrize("name", [*MESHES, "layered-mixed"])
@pytest.mark.parametrize("order", ["colour", "jacobi"])
def test_block_arrays_count_the_rows_of_each_node(name, order):
    """The per-node arrays of a block (computed on first use) count and locate each node's rows, as a
    per-node scan of the tables finds them; the slices hold exactly the block's rows."""
    mesh = _layered_mixed() if name == "layered-mixed" else MESHES[name]()
    topo = build_topology(mesh, np.arange(0, mesh.n_points, 6))
    blocks = topo.blocks(order)
    assert sum(b.size for b in blocks) == topo.n_free
    for blk in blocks:
        a = blk.nodes.start
        for loc, rows, count in ((topo.ring_loc, blk.ring, blk.ring_count), (topo.spoke_loc, blk.spokes, blk.spoke_count),
                                 (topo.tri_loc, blk.tris, None), (topo.quad_loc, blk.quads, None)):
            assert np.array_equal(np.flatnonzero((loc >= a) & (loc < blk.nodes.stop)), np.arange(rows.start, rows.stop))
            n = [int((loc == a + i).sum()) for i in range(blk.size)]
            if count is not None:
                assert count.tolist() == n
        for loc, rows, starts, has in ((topo.tri_loc, blk.tris, blk.tri_starts, blk.tri_has),
                                       (topo.quad_loc, blk.quads, blk.quad_starts, blk.quad_has)):
            rel = (loc[rows] - a).tolist()
            assert has.tolist() == [i in rel for i in range(blk.size)]
            assert starts.tolist() == [rel.index(i) for i in range(blk.size) if i in rel]
    assert topo.blocks(order) is blocks


@pytest.mark.parametrize("name", ["layered-mixed", "distorted", "paper-mixed"])
def test_input_floors_in_chunks_equal_the_whole_arrays(name, monkeypatch):
    """The driver's per-incidence-row input floors are computed in chunks of cells and rows (bounded
    temporaries); chunks of 7 give the same arrays as one chunk, and the six columns are views of
    the kernels' packed array."""
    from anglesmooth.smoothers import _floors

    mesh = _layered_mixed() if name == "layered-mixed" else MESHES[name]()
    topo = build_topology(mesh)
    whole = _floors.input_floors(mesh.points, topo)
    monkeypatch.setattr(_floors, "_CHUNK", 7)
    chunked = _floors.input_floors(mesh.points, topo)
    for a, b in zip(whole, chunked, strict=True):
        assert np.shape(a) == np.shape(b) and np.array_equal(a, b)  # arrays, and the input's median area
    if whole.active:
        assert whole.t_area2.any() or whole.q_area2.any()
        assert all(np.shares_memory(col, whole.packed) for col in whole[:6])


@pytest.mark.parametrize("name", ["mixed", "paper-mixed", "distorted", "layered-mixed"])
def test_signed_areas_from_complex_gathers_equal_the_column_formula(name, monkeypatch):
    """signed_areas gathers x and y of a node together (complex128) in chunks of cells; its values are
    the bits of the x/y column formula, on tangled points with zero and negative areas too, and the
    column formula still serves points of another dtype or width."""
    from anglesmooth.topology import orient

    mesh = _layered_mixed() if name == "layered-mixed" else MESHES[name]()
    rng = np.random.default_rng(3)
    pts = mesh.points + rng.normal(scale=0.3, size=mesh.points.shape)
    tri, quad = mesh.triangles.astype(np.int32), mesh.quads
    for cells in (tri, quad):  # a collapsed cell of each kind: an exact zero
        if cells.shape[0]:
            pts[cells[0]] = pts[cells[0, 0]]
    empty = np.empty(0)
    ref = orient._signed_areas_columns(pts, tri, quad, np.empty(tri.shape[0] + quad.shape[0]))
    assert (ref == 0).any() and (ref != 0).any()
    monkeypatch.setattr(orient, "CHUNK", 3)
    for got in (orient.signed_areas(pts, tri, quad), orient.signed_areas(pts, tri[:0], quad),
                orient.signed_areas(pts, tri, quad[:0])):
        want = np.concatenate([ref[: tri.shape[0]] if got.size != quad.shape[0] else empty,
                               ref[tri.shape[0] :] if got.size != tri.shape[0] else empty])
        assert got.dtype == np.float64 and np.array_equal(got.view(np.int64), want.view(np.int64))
    wide = np.c_[pts, np.ones(len(pts))]  # (N, 3): the column formula
    assert np.array_equal(orient.signed_areas(wide, tri, quad).view(np.int64), ref.view(np.int64))
    single = orient.signed_areas(pts.astype(np.float32), tri, quad)
    assert single.dtype == np.float64 and np.allclose(single, ref, rtol=1e-4, atol=1e-4)


@pytest.mark.parametrize("name", [*MESHES, "layered-mixed"])
def test_incidence_cells_are_the_cells_of_every_free_node(name):
    """``tri_cell`` / ``quad_cell`` name the cell of every incidence row (its rotation starting at the
    row's node), and the rows of a free node list every cell of that node once: what a slow per-node
    scan of the cells finds."""
    mesh = _layered_mixed() if name == "layered-mixed" else MESHES[name]()
    topo = build_topology(mesh, np.arange(0, mesh.n_points, 7))
    for cells, loc, verts, cell in ((topo.tri, topo.tri_loc, topo.tri_verts, topo.tri_cell),
                                    (topo.quad, topo.quad_loc, topo.quad_verts, topo.quad_cell)):
        assert cell.dtype == verts.dtype and cell.shape == loc.shape
        for r in range(loc.shape[0]):
            c = cells[cell[r]].tolist()
            j = c.index(int(verts[r, 0]))
            assert verts[r].tolist() == c[j:] + c[:j]
        for i, v in enumerate(topo.free_nodes.tolist()):
            want = [c for c in range(cells.shape[0]) if v in cells[c].tolist()]
            assert sorted(cell[loc == i].tolist()) == want


def test_release_drops_the_cache_entries_holding_an_object():
    """The driver releases its input floors from the topology's caches after the passes (else a cache
    entry keeps them alive as long as the topology); other entries stay."""
    import gc
    import weakref

    from anglesmooth.driver import smooth

    mesh = paper_mixed(1)
    topo = build_topology(mesh)
    marker = np.zeros(3)
    ref = weakref.ref(marker)
    topo._cache["a"] = (marker, 1)
    topo._cache["b"] = marker
    topo._cache["c"] = (np.zeros(1), 2)
    topo.release(marker)
    assert set(topo._cache) == {"c"}
    del marker
    gc.collect()
    assert ref() is None
    from anglesmooth.smoothers._floors import Floors

    smooth(mesh, "angle", 2, topology=topo)
    assert topo._cache  # the smoothers cached tables of the topology, but none holds the floors
    assert not [v for v in topo._cache.values()
                if isinstance(v, Floors) or (type(v) is tuple and any(isinstance(x, Floors) for x in v))]


def _by_loc(  # the build's former row sort, kept here as the radix sort's oracle
    loc: np.ndarray, width: int, value: np.ndarray):
    """Rows with a free owner (``loc >= 0``) sorted by (loc, value); returns (loc, value) of the sorted rows.

    ``value`` (0 <= value < width) orders the rows of one owner.  Both are
    packed into one int64 key for a plain ``np.sort``; rows of fixed owners
    (loc = -1) get negative keys, sort first and are cut off.  Falls back to
    ``np.lexsort`` when the key would not fit in 63 bits.  ``loc`` may be
    overwritten (when it is int64).  Returns int64 arrays.
    """
    shift = max(int(width - 1).bit_length(), 1)
    if loc.shape[0] == 0 or int(loc.max()).bit_length() + shift <= 63:
        key = loc if loc.dtype == np.int64 else loc.astype(np.int64)
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
    return loc[o].astype(np.int64), value[o].astype(np.int64)


@pytest.mark.parametrize("n, high", [(0, 5), (1, 0), (10, 3), (1000, 2**8 - 1), (1000, 2**8 + 1), (5000, 2**16 - 1),
                                     (5000, 2**16 + 3), (20000, 2**20), (20000, 2**24 + 5), (3000, 2**30)])
@pytest.mark.parametrize("dtype", [np.int32, np.int64])
def test_rows_by_loc_radix_sort_equals_the_packed_key_sort(n, high, dtype):
    """The radix sort of the incidence / diagonal rows by owner gives the rows and owners of the packed
    int64 key sort (and of a lexsort), fixed owners (-1) dropped, for owners of one to four digits."""
    from anglesmooth.topology._keys import _rows_by_loc

    rng = np.random.default_rng(n + high)
    loc = rng.integers(-1, high, n).astype(dtype) if high else np.full(n, -1, dtype)
    owner, rows = _rows_by_loc(loc)
    want = _by_loc(loc.copy(), max(n, 1), np.arange(n, dtype=np.int64))
    keep = np.flatnonzero(loc >= 0)
    lex = keep[np.lexsort((keep, loc[keep]))]
    assert owner.dtype == rows.dtype == np.int64
    assert np.array_equal(owner, want[0]) and np.array_equal(rows, want[1]) and np.array_equal(rows, lex)
    assert np.array_equal(owner, loc[rows])


def test_quad_verdict_measures_row_by_row_equal_the_whole_array_formulas():
    """The quad scaled Jacobian and condition, computed one corner row at a time (bounded
    temporaries), are the bits of the (4, n) whole-array formulas, zeros, -0.0, inf and nan included."""
    from anglesmooth.quality import verdict as V
    from anglesmooth.quality._corners import _Corners

    def jac(c):
        den = np.roll(c.length, 1, axis=0) * c.length
        out = np.zeros(c.cross.shape)
        np.divide(c.cross, den, out=out, where=den > 0)
        return out.min(axis=0)

    def cond(c):
        l2 = c.length * c.length
        out = np.full(c.cross.shape, V.VERDICT_DBL_MAX)
        with np.errstate(invalid="ignore"):
            np.divide(l2 + np.roll(l2, 1, axis=0), c.cross, out=out, where=c.cross > V._DBL_MIN)
        out = out.max(axis=0) if out.size else np.zeros(c.cross.shape[1])
        out *= 0.5
        return np.minimum(out, V.VERDICT_DBL_MAX, out=out)

    rng = np.random.default_rng(0)
    for n in (0, 1, 7, 5000):
        length, cross, u = np.abs(rng.normal(size=(4, n))), rng.normal(size=(4, n)), rng.random((4, n))
        length[u < 0.05] = 0.0
        cross[u > 0.95] = 0.0
        cross[(u > 0.9) & (u <= 0.95)] = -0.0
        cross[(u > 0.4) & (u < 0.41)] = np.nan
        cross[(u > 0.5) & (u < 0.505)] = np.inf
        length[(u > 0.6) & (u < 0.605)] = np.inf
        c = _Corners(length, cross, np.zeros((4, n)))
        with np.errstate(invalid="ignore"):
            for got, want in ((V._quad_jac(c), jac(c)), (V._quad_condition(c), cond(c))):
                assert got.shape == want.shape == (n,) and np.array_equal(got.view(np.int64), want.view(np.int64))


def _rings_oracle(edges: np.ndarray, n: int):
    """Per node, a Python loop: the neighbours below it (by lo) then above it (by hi), and each entry's edge."""
    rows = [[] for _ in range(n)]
    for e in sorted(range(edges.shape[0]), key=lambda e: (int(edges[e, 1]), int(edges[e, 0]))):
        rows[int(edges[e, 1])].append((int(edges[e, 0]), e))  # lower part: edges with hi == v, by lo
    for e in range(edges.shape[0]):  # edges are sorted by (lo, hi): the upper part in order
        rows[int(edges[e, 0])].append((int(edges[e, 1]), e))
    offsets = np.cumsum([0] + [len(r) for r in rows])
    flat = [x for r in rows for x in r]
    return offsets, np.array([x[0] for x in flat], np.int64), np.array([x[1] for x in flat], np.int64)


@pytest.mark.parametrize("seed", range(6))
def test_rings_csr_equals_a_per_node_loop(seed):
    """The ring CSR (radix sort of the edges by hi for the lower parts) equals a per-node loop, self-edges
    included, on random edge sets of 0 .. 3000 nodes (three radix digits at the largest)."""
    from anglesmooth.topology.build import _rings

    rng = np.random.default_rng(seed)
    n = [1, 7, 300, 3000, 70000, 5][seed]
    pairs = rng.integers(0, n, (3 * n + 2, 2))
    pairs.sort(axis=1)
    edges = np.unique(pairs, axis=0).astype(np.int32 if seed % 2 else np.int64)
    deg = np.bincount(edges.ravel(), minlength=n)
    offsets, indices, edge = _rings(edges, deg, n)
    want = _rings_oracle(edges, n)
    assert np.array_equal(offsets, want[0]) and np.array_equal(indices, want[1]) and np.array_equal(edge, want[2])
    assert offsets.dtype == indices.dtype == edge.dtype == edges.dtype


@pytest.mark.parametrize("name", MESHES)
def test_free_nodes_are_ordered_by_colour_then_index(name):
    """The radix sort of the free nodes by colour gives the (colour, index) order of a lexsort."""
    topo = build_topology(MESHES[name]())
    free = np.flatnonzero(topo.colour >= 0)
    assert np.array_equal(topo.free_nodes, free[np.lexsort((free, topo.colour[free]))])
