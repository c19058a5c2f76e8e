"""The pruned numpy compass search (``_compass._Pruned``) gives the numbers of scoring every candidate.

``optimize(..., prune=False)`` scores all eight candidates of every node with
``BlockGeometry.score`` at every step; the default scores in full only the candidates whose
critical corners could still beat the node's score.  Positions and scores must be equal bit for
bit, on triangles, quads and mixed meshes, with and without the area band, limits, ``strict``,
per-node steps, input floors and invalid start positions, and on a block large enough for the
row layout grouped by row count (not sorted by node).
"""

from __future__ import annotations

import numpy as np
import pytest

from anglesmooth import generate as gen
from anglesmooth.smoothers import _compass
from anglesmooth.smoothers._floors import input_floors
from anglesmooth.smoothers._local import BlockGeometry, local_scale, optimize
from anglesmooth.topology import build_topology, signed_areas

MESHES = {
    "triangles": lambda: gen.random_delaunay(600, seed=5),
    "quads": lambda: gen.random_quad_mesh(500, seed=6),
    "mixed": lambda: gen.paper_mixed_mesh(4),
    "graded": lambda: gen.graded_mesh(2, per_layer=30, per_side=6),
}


def _jittered(mesh, amount, seed):
    """The mesh's free nodes moved by up to ``amount`` x the mean edge length (some cells invert)."""
    topo = build_topology(mesh)
    p = np.array(mesh.points)
    h = np.mean([np.ptp(p[:, 0]), np.ptp(p[:, 1])]) / np.sqrt(p.shape[0])
    rng = np.random.default_rng(seed)
    p[topo.free_nodes] += rng.uniform(-amount, amount, (topo.n_free, 2)) * h
    return topo, p


def _count_scored(monkeypatch):
    """Patch ``_Pruned._scores`` to count the (candidate, node) pairs scored in full."""
    seen = {"pairs": 0}
    real = _compass._Pruned._scores

    def counted(self, px, py, node):
        seen["pairs"] += node.shape[0]
        return real(self, px, py, node)

    monkeypatch.setattr(_compass._Pruned, "_scores", counted)
    return seen


@pytest.mark.parametrize("name", sorted(MESHES))
def test_pruned_search_equals_the_full_one(name, monkeypatch):
    seen = _count_scored(monkeypatch)
    mesh = MESHES[name]()
    topo, pts = _jittered(mesh, 0.6, 3)
    floors = input_floors(np.array(mesh.points), topo)
    areas = np.sort(signed_areas(pts, topo.tri, topo.quad))
    limits = (areas[len(areas) // 4], areas[3 * len(areas) // 4])
    rng = np.random.default_rng(4)
    searched = scored = invalid_starts = 0
    for blk in topo.blocks():
        cur = pts[topo.free_nodes[blk.nodes]]
        scale = local_scale(pts, topo, blk)
        for fl in (None, floors):
            geom = BlockGeometry(pts, topo, blk, floors=fl)
            invalid_starts += int((geom.score(cur) < -2.5).sum())
            strict = rng.random(blk.size) < 0.5
            its = rng.integers(1, 7, blk.size)
            for band, lim, st, it in ((None, None, None, 4), (0.8, None, None, 4), (0.8, limits, None, 4),
                                      (0.8, limits, strict, 4), (None, None, strict, 3), (0.8, limits, None, its)):
                kw = dict(area_band=band, area_limits=lim, strict=st)
                start = seen["pairs"]
                a = optimize(geom, cur, scale, it, **kw)
                if blk.size >= _compass.PRUNE_MIN_NODES:
                    scored += seen["pairs"] - start
                    searched += 8 * int(np.sum(np.broadcast_to(it, (blk.size,))))
                b = optimize(geom, cur, scale, it, prune=False, **kw)
                np.testing.assert_array_equal(a[0], b[0])
                np.testing.assert_array_equal(a[1], b[1])
                # a few nodes (below PRUNE_MIN_NODES: every candidate scored, by _Pruned's own code)
                few = np.arange(0, blk.size, 5)[: _compass.PRUNE_MIN_NODES - 1]
                kw["strict"] = None if st is None else st[few]
                itf = it if np.ndim(it) == 0 else it[few]
                before = seen["pairs"]
                a = optimize(geom.restrict(few), cur[few], scale[few], itf, **kw)
                assert seen["pairs"] - before == 8 * int(np.sum(np.broadcast_to(itf, few.shape)))  # all of them
                b = optimize(geom.restrict(few), cur[few], scale[few], itf, prune=False, **kw)
                np.testing.assert_array_equal(a[0], b[0])
                np.testing.assert_array_equal(a[1], b[1])
    assert invalid_starts > 0  # the jitter inverted cells: invalid scores were searched too
    assert 0 < scored < searched  # some candidates pruned (most starts here are valid, not all)


def test_pruning_skips_most_candidates(monkeypatch):
    """On a mildly jittered mesh (valid starts, as stage 4's), most candidates are never scored in full
    (measured in stage 4 of 100k random triangles: about 26 % are)."""
    seen = _count_scored(monkeypatch)
    topo, pts = _jittered(gen.random_delaunay(3000, seed=7), 0.2, 2)
    searched = 0
    for blk in topo.blocks():
        if blk.size < _compass.PRUNE_MIN_NODES:
            continue
        cur = pts[topo.free_nodes[blk.nodes]]
        optimize(BlockGeometry(pts, topo, blk), cur, local_scale(pts, topo, blk), 4, area_band=0.8)
        searched += 8 * 4 * blk.size
    assert 0 < seen["pairs"] < 0.5 * searched


def test_pruned_search_on_a_large_block_with_grouped_rows(monkeypatch):
    """A block of more than ``_rows._SMALL`` rows: its rows are grouped by count, not sorted by node (every
    group in regular chunks: ``_rows._MERGE`` 0)."""
    from anglesmooth.smoothers import _rows

    monkeypatch.setattr(_rows, "_MERGE", 0)
    mesh = gen.random_delaunay(20000, seed=2)
    topo, pts = _jittered(mesh, 0.3, 1)
    blk = max(topo.blocks(), key=lambda b: b.size)
    geom = BlockGeometry(pts, topo, blk)
    first, _ = geom._starts("t_rel")
    assert not (np.diff(first) > 0).all()  # the layout this test is for
    cur = pts[topo.free_nodes[blk.nodes]]
    scale = local_scale(pts, topo, blk)
    for band in (None, 0.8):
        a = optimize(geom, cur, scale, 5, area_band=band)
        b = optimize(geom, cur, scale, 5, area_band=band, prune=False)
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[1], b[1])
        assert (a[0] != cur).any()


def test_lowest_rows_per_node():
    """``_lowest``: each node's PRUNE_ROWS lowest rows (NaN as +inf), all its rows where it has fewer."""
    rng = np.random.default_rng(0)
    cnt = rng.integers(1, 6, 40)
    cnt[[3, 17]] = 0  # nodes without rows of this kind
    cnt[[5, 8]] = 1
    order = rng.permutation(40)  # the nodes' runs of rows in a shuffled order (a grouped layout)
    first = np.zeros(40, np.int64)
    first[order] = np.cumsum(cnt[order]) - cnt[order]
    rel = np.empty(cnt.sum(), np.int64)
    for i in range(40):
        rel[first[i]:first[i] + cnt[i]] = i
    v = rng.random(rel.shape[0])
    v[rng.random(rel.shape[0]) < 0.15] = np.nan
    nodes, crit = _compass._lowest(v, rel, first, cnt)
    np.testing.assert_array_equal(nodes, np.flatnonzero(cnt))
    k = _compass.PRUNE_ROWS
    for j, i in enumerate(nodes):
        rows = first[i] + np.arange(cnt[i])
        key = np.where(np.isnan(v), np.inf, v)
        got = crit[:, j]
        assert np.isin(got, rows).all()
        if cnt[i] >= k:
            assert len(set(got.tolist())) == k  # distinct rows
            np.testing.assert_array_equal(np.sort(key[got]), np.sort(key[rows])[:k])
        else:
            assert set(got.tolist()) == set(rows.tolist())
