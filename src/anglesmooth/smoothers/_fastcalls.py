"""Entry points of the compiled kernels: the twins of :mod:`._local`'s numpy kernels that the smoothers call.

Each function gathers the topology's tables a kernel takes (row pointers cached per topology) and
runs it through :func:`._fast._run` (threads, compile-time accounting); :class:`FastGeometry`
stands in for :class:`._local.BlockGeometry`.  :func:`warm_up` compiles (or loads) the kernels on a
tiny mesh.  Why compiled kernels, when they run and why their numbers are the numpy kernels': see
:mod:`._fast`.
"""

from __future__ import annotations

import numpy as np

from . import _fast
from ._fast import COMPILE_S, _k, _run

__all__ = [
    "FastGeometry",
    "angle_choose",
    "angle_optimize",
    "angle_target",
    "area_limits",
    "laplacian_target",
    "local_scale",
    "screen_cells",
    "warm_up",
]


def _csr(topo):
    """Row pointers of the per-node tables (ring, spokes, triangles, quads) over all free nodes, cached."""
    hit = topo._cache.get(("csr",))
    if hit is None:
        f = np.arange(topo.n_free + 1)
        hit = topo._cache[("csr",)] = tuple(
            np.searchsorted(loc, f).astype(np.int64) for loc in (topo.ring_loc, topo.spoke_loc, topo.tri_loc, topo.quad_loc)
        )
    return hit


_PARTNER_NODES = 65536  # nodes a chunk of _spoke_partner


def _spoke_partner(topo) -> np.ndarray:
    """Per spoke (``topo.spoke_*`` order), the place among its node's spokes (int8) of the spoke whose
    ring node is this spoke's ``a`` and whose ``b`` is this spoke's ring node (its ``b`` edge is this
    spoke's ``a`` edge reversed: every spoke of a triangle fan), or -1 (none, or beyond the 127th
    spoke: ``_node_angle`` then computes the edge itself); topology only, cached.  One byte per
    spoke: 3 MB on 1M triangles (a table of spoke ids took 12-24 MB for some 7 % of the kernel's time
    more than searching the node's spokes in the kernel; the table 12 %)."""
    hit = topo._cache.get(("spoke-partner",))
    if hit is None:
        loc_all, ring_all, a_all, b = topo.spoke_loc, topo.spoke_ring, topo.spoke_a, topo.spoke_b
        n = np.int64(max(topo.n_points, 1))
        out = np.full(ring_all.shape[0], -1, np.int8)
        # a node's spokes are contiguous (sorted by node) and a partner is one of them: whole nodes a chunk,
        # so that the int64 temporaries stay small (one pass over all 3M spokes of 1M triangles held ten
        # 24 MB arrays at once: +130 MB of the CLI's peak, on the first pass)
        n_loc = int(loc_all[-1]) + 1 if loc_all.shape[0] else 0
        cuts = np.searchsorted(loc_all, np.arange(0, n_loc + _PARTNER_NODES, _PARTNER_NODES))
        for s0, s1 in zip(cuts[:-1].tolist(), cuts[1:].tolist()):
            if s1 <= s0:
                continue
            loc = loc_all[s0:s1].astype(np.int64)
            ring = ring_all[s0:s1]
            key = loc * n + ring
            order = np.argsort(key, kind="stable")
            ks = key[order]
            want = loc * n + a_all[s0:s1]
            at = np.minimum(np.searchsorted(ks, want), ks.shape[0] - 1)
            p = order[at]  # chunk-local
            first = np.searchsorted(loc, loc, side="left")  # each spoke's node's first spoke
            rel = p - first
            ok = (ks[at] == want) & (b[s0 + p] == ring) & (rel < 127)
            out[s0:s1][ok] = rel[ok]
        hit = topo._cache[("spoke-partner",)] = out
    return hit


def _nodes(blk, topo=None) -> np.ndarray:
    """The block's free-node indices (int64), the kernels' ``nodes``; with ``topo``, cached per block
    (topology only: 8 bytes a free node; three calls per colour class and pass otherwise)."""
    if topo is None:
        return np.arange(blk.nodes.start, blk.nodes.stop, dtype=np.int64)
    key = ("block-nodes", blk.nodes.start, blk.nodes.stop)
    hit = topo._cache.get(key)
    if hit is None:
        hit = topo._cache[key] = np.arange(blk.nodes.start, blk.nodes.stop, dtype=np.int64)
    return hit


def angle_target(points: np.ndarray, topo, blk) -> np.ndarray:
    """Compiled :func:`._local.angle_target`."""
    _, sp, _, _ = _csr(topo)
    return _run(
        _k().angle_target,
        points, _nodes(blk, topo), topo.free_nodes, sp, topo.spoke_ring, topo.spoke_a, topo.spoke_b, topo.spoke_frac,
        _spoke_partner(topo),
    )


def laplacian_target(points: np.ndarray, topo, blk) -> np.ndarray:
    """Compiled :func:`._local.laplacian_target`."""
    rp, _, _, _ = _csr(topo)
    return _run(_k().ring_mean, points, _nodes(blk), topo.free_nodes, rp, topo.ring_nbr, False)


def local_scale(points: np.ndarray, topo, blk, subset: np.ndarray | None = None) -> np.ndarray:
    """Compiled :func:`._local.local_scale`."""
    rp, _, _, _ = _csr(topo)
    nodes = _nodes(blk)
    if subset is not None:
        nodes = nodes[subset]
    return _run(_k().ring_mean, points, nodes, topo.free_nodes, rp, topo.ring_nbr, True)[:, 0]


def area_limits(points: np.ndarray, topo):
    """(smallest, largest) signed area of the mesh's cells at ``points`` (``float(areas.min())``,
    ``float(areas.max())`` of ``topology.signed_areas``, the same numbers), or None without cells."""
    if topo.tri.shape[0] + topo.quad.shape[0] == 0:
        return None
    lo, hi = _run(_k()._cell_area_range, np.ascontiguousarray(points, dtype=np.float64), topo.tri, topo.quad)
    return float(lo), float(hi)


def screen_cells(points: np.ndarray, cells: np.ndarray, t: float):
    """Stage 5's screen of ``cells`` (``_patch._maybe_below``'s test with the padded tangent ``t``) fused
    with their area range: (ids of the cells it keeps, ascending; (lo, hi, nan) per chunk of
    ``_patchkernels.RANGE_CHUNK`` cells, see :func:`area_range_of`; the kept cells' largest corner
    cotangents, ``_patch._cell_cot``'s numbers).  The cells are cut into spans of
    whole chunks that :func:`._fast.threads` threads take (one thread below ``2 * MIN_CHUNK`` cells)."""
    pts = np.ascontiguousarray(points[:, :2], dtype=np.float64)
    m = cells.shape[0]
    rc = _k().RANGE_CHUNK
    n_chunks = -(-m // rc)
    out = np.empty(m, np.bool_)
    lo, hi, nan = np.empty(n_chunks), np.empty(n_chunks), np.empty(n_chunks, np.bool_)
    cot = np.empty(m)  # (the kept cells' cotangents packed from each span's start: only those pages touched)
    fn = _k()._screen_below
    n_threads = _fast.threads(m) if m >= 2 * _fast.MIN_CHUNK else 1
    if n_threads == 1:
        cuts, kept = [0], [_run(fn, pts, cells, t, 0, m, out, lo, hi, nan, cot)]
    else:
        _fast._prepare(fn, (pts, cells, t, 0, m, out, lo, hi, nan, cot))
        cuts = (np.linspace(0, n_chunks, n_threads + 1).astype(np.int64) * rc).tolist()
        cuts[-1] = m
        pool = _fast._get_pool(n_threads - 1)
        jobs = [pool.submit(fn, pts, cells, t, a, b, out, lo, hi, nan, cot) for a, b in zip(cuts[1:-1], cuts[2:])]
        try:
            kept = [fn(pts, cells, t, cuts[0], cuts[1], out, lo, hi, nan, cot)]
        finally:
            for j in jobs:  # wait for the others even when this thread failed (they write the arrays)
                j.exception()
        kept += [j.result() for j in jobs]
    ids = np.flatnonzero(out)
    parts = [cot[a:a + n] for a, n in zip(cuts, kept)]
    return ids, (lo, hi, nan), parts[0].copy() if len(parts) == 1 else np.concatenate(parts)


def area_range_of(points: np.ndarray, topo, ranges, moved_cells=None):
    """The (smallest, largest) signed cell area at ``points`` from the per-chunk ranges ``ranges`` =
    [(lo, hi, nan) of the triangles, of the quads] that :func:`screen_cells` gave at points that differ
    from ``points`` only at corners of the cells ``moved_cells`` (ids: triangles, then quads from
    ``topo.n_tri``; their chunks are computed again): :func:`area_limits`' numbers exactly (the same
    areas folded in the same order), or None without cells."""
    if topo.tri.shape[0] + topo.quad.shape[0] == 0:
        return None
    k = _k()
    rc = k.RANGE_CHUNK
    pts = np.ascontiguousarray(points, dtype=np.float64)
    if moved_cells is not None and moved_cells.size:
        nt = topo.n_tri
        for cells, (lo, hi, nan), ids in ((topo.tri, ranges[0], moved_cells[moved_cells < nt]),
                                          (topo.quad, ranges[1], moved_cells[moved_cells >= nt] - nt)):
            if ids.size:
                _run(k._chunk_ranges, pts, cells, np.unique(ids // rc).astype(np.int64), lo, hi, nan)
    lo, hi = _run(k._fold_range, *(np.concatenate([a, b]) for a, b in zip(*ranges)))
    return float(lo), float(hi)


def _floors(floors) -> np.ndarray:
    """The input floors (``_floors.Floors`` or None) as the (6, rows) array the kernels take; (0, 0) for none."""
    return np.zeros((0, 0)) if floors is None or not floors.active else floors.packed


def _floored_nodes(topo, floors) -> np.ndarray:
    """Per free node: some incidence row of it has a nonzero input floor (``angle_choose``'s ``flnode``);
    empty without floors.  Cached per floors (n_free bytes)."""
    if floors is None or not floors.active:
        return np.zeros(0, np.bool_)
    key = ("floored-nodes", id(floors))
    hit = topo._cache.get(key)
    if hit is None or hit[0] is not floors:
        out = np.zeros(topo.n_free, np.bool_)
        for loc, cols in ((topo.tri_loc, floors[0:3]), (topo.quad_loc, floors[3:6])):
            some = np.zeros(loc.shape[0], np.bool_)
            for c in cols:
                some |= c[: loc.shape[0]] != 0
            out[loc[some]] = True
        hit = topo._cache[key] = (floors, out)
    return hit[1]


def angle_choose(points: np.ndarray, topo, blk, good, floors=None, keep=None, nearest=False, certify=None, cap=None):
    """Stages 1 and 2 of the robust ``angle`` update, fused per node (see :func:`.angle.step`).

    ``good``: the acceptance score threshold, one per block node or one for all; ``keep``: None or
    a bool per block node, where the angle position must also be no worse than staying (and open no
    moving corner beyond staying's widest or 90 deg); ``nearest``:
    stage 2 takes the good-enough candidate nearest the angle position (see :func:`.angle.step`);
    ``certify``: None or a score per block node (see ``_fastkernels.angle_choose``); ``cap``: None or
    ``keep_max``'s widest corner (``-cos``; see there).  Returns (positions,
    scores, refused, lazy): ``lazy`` marks the nodes whose score is ``inf`` instead of the exact one.
    """
    rp, sp, tp, qp = _csr(topo)
    # always fresh writeable copies: a broadcast view is read-only, another compiled signature (a
    # scalar ``good``, as in warm_up, copied, and a per-node one did not: two compiles)
    if not (isinstance(good, np.ndarray) and good.dtype == np.float64 and good.shape == (blk.size,)
            and good.flags.c_contiguous and good.flags.writeable):  # (the cached per-node thresholds are)
        good = np.array(np.broadcast_to(np.asarray(good, dtype=np.float64), (blk.size,)))
    return _run(
        _k().angle_choose,
        points, _nodes(blk, topo), topo.free_nodes, sp, topo.spoke_ring, topo.spoke_a, topo.spoke_b, topo.spoke_frac,
        _spoke_partner(topo), rp, topo.ring_nbr, tp, topo.tri_verts, qp, topo.quad_verts, good, _floors(floors),
        _floored_nodes(topo, floors), np.zeros(0, np.bool_) if keep is None else np.array(keep, dtype=np.bool_),
        bool(nearest),
        np.zeros(0) if certify is None else np.ascontiguousarray(certify, dtype=np.float64),
        np.inf if cap is None else float(cap),
    )


def angle_optimize(points: np.ndarray, topo, blk, worst, x, best, iterations: int, radius: float,
                   area_band: float | None, directions: np.ndarray, area_limits=None, strict=None, floors=None,
                   resume_iterations: int = 0, resume_radius: float = 0.0, resume_above: float = np.inf,
                   keep=None, cap=None, score_min=-np.inf):
    """Stage 4 of the robust ``angle`` update for the block-local nodes ``worst`` (see :func:`.angle.step`),
    one compiled loop: their local scale, the resume test of quad-only nodes and the compass search
    (``resume_above``: the score, not the angle); ``keep`` (None or a bool per node of ``worst``) and ``cap``
    (None or a ``-cos``): ``keep_max``; ``score_min`` (-inf: none): ``keep_min`` on its result, at the ``strict``
    nodes (see ``_fastkernels.angle_optimize``).  Returns (positions, scores): the numbers of :func:`local_scale`,
    :meth:`FastGeometry.score` and two :meth:`FastGeometry.compass` calls, and of :func:`._worst.hold`."""
    rp, _, tp, qp = _csr(topo)
    band = -1.0 if area_band is None else float(area_band)
    lo, hi = (-np.inf, np.inf) if area_limits is None else (float(area_limits[0]), float(area_limits[1]))
    return _run(
        _k().angle_optimize, points, np.ascontiguousarray(x, dtype=np.float64), _nodes(blk, topo)[worst], topo.free_nodes,
        rp, topo.ring_nbr, tp, topo.tri_verts, qp, topo.quad_verts, np.ascontiguousarray(best, dtype=np.float64),
        int(iterations), float(radius), band, directions, _floors(floors), lo, hi,
        np.zeros(0, np.bool_) if strict is None else np.ascontiguousarray(strict, dtype=np.bool_),
        int(resume_iterations), float(resume_radius), float(resume_above),
        np.zeros(0, np.bool_) if keep is None or cap is None else np.ascontiguousarray(keep, dtype=np.bool_),
        np.inf if cap is None else float(cap), float(score_min),
    )


class FastGeometry:
    """Compiled stand-in for :class:`._local.BlockGeometry` (``n``, ``restrict``, ``score``) plus
    the whole compass search of :func:`._local.optimize`; no gathered copies.

    It keeps a reference to ``points`` (which must not change while it is
    used: the block loop writes a block's moves only after its update) and
    the free-node indices it scores.
    """

    def __init__(self, points: np.ndarray, topo, blk, nodes: np.ndarray | None = None, floors=None):
        self._pts = points
        self._topo = topo
        self._nodes = _nodes(blk, topo) if nodes is None else nodes
        self.n = self._nodes.shape[0]
        self._fl = floors if isinstance(floors, np.ndarray) else _floors(floors)

    def restrict(self, subset: np.ndarray) -> FastGeometry:
        return FastGeometry(self._pts, self._topo, None, self._nodes[subset], self._fl)

    def score(self, X: np.ndarray) -> np.ndarray:
        """Local score at candidate positions ``X`` (..., n, 2) -> (..., n)."""
        t = self._topo
        _, _, tp, qp = _csr(t)
        X = np.asarray(X, dtype=np.float64)
        Xf = np.ascontiguousarray(X.reshape((-1, self.n, 2)))
        s = _run(_k().score, self._pts, Xf, self._nodes, tp, t.tri_verts, qp, t.quad_verts, self._fl)
        return s.reshape(X.shape[:-2] + (self.n,))

    def compass(self, x, scale, iterations: int, radius: float, area_band: float | None, directions: np.ndarray,
                area_limits=None, strict=None):
        """:func:`._local.optimize` from positions ``x`` (n, 2): (positions, scores)."""
        t = self._topo
        _, _, tp, qp = _csr(t)
        band = -1.0 if area_band is None else float(area_band)
        lo, hi = (-np.inf, np.inf) if area_limits is None else (float(area_limits[0]), float(area_limits[1]))
        return _run(
            _k().compass, self._pts, np.ascontiguousarray(x, dtype=np.float64), self._nodes, tp, t.tri_verts, qp,
            t.quad_verts, np.ascontiguousarray(scale, dtype=np.float64), int(iterations), float(radius), band,
            directions, self._fl, lo, hi,
            np.zeros(0, np.bool_) if strict is None else np.ascontiguousarray(strict, dtype=np.bool_),
        )


def warm_up(kernels=None) -> None:
    """Compile (or load from the cache) the ``kernels`` named (default: every kernel) on a tiny mesh.

    The tiny mesh's tables have the types of any mesh's, so the compiled code is what a large mesh
    runs (a different signature would only compile again).
    """
    want = set(COMPILE_S if kernels is None else kernels)
    from ..generate import structured_quads, structured_triangles
    from ..mesh import Mesh2D
    from ..topology import build_topology

    t, q = structured_triangles(4, 4), structured_quads(4, 4)
    n = t.points.shape[0]
    m = Mesh2D.from_arrays(
        np.concatenate([t.points, q.points + [5.0, 0.0]]), triangles=t.triangles, quads=q.quads + n
    )
    topo = build_topology(m)
    pts = np.array(m.points)  # writeable, as the points a smoothing run passes (another signature otherwise)
    for blk in topo.blocks():
        g = FastGeometry(pts, topo, blk)
        x = pts[topo.free_nodes[blk.nodes]]
        if "score" in want:
            g.score(x)
        if "compass" in want:
            g.compass(x, np.ones(g.n), 1, 0.25, 0.8, np.eye(2)), g.compass(x, np.ones(g.n), 1, 0.25, None, np.eye(2))
        if "angle_target" in want:
            angle_target(pts, topo, blk)
        if "ring_mean" in want:
            laplacian_target(pts, topo, blk), local_scale(pts, topo, blk)
        if "angle_choose" in want:
            angle_choose(pts, topo, blk, 0.5), angle_choose(pts, topo, blk, 0.5, certify=np.full(g.n, -0.5))
        if "angle_optimize" in want:
            w = np.arange(g.n)
            angle_optimize(pts, topo, blk, w, x, np.zeros(g.n), 1, 0.25, 0.8, np.eye(2), None, np.ones(g.n, bool),
                           None, 1, 0.0625, 0.5)
    if "_cell_area_range" in want:
        area_limits(pts, topo)
    if want & {"_screen_below", "_chunk_ranges", "_fold_range"}:  # stage 5's screen, the area range it carries
        ranges = [screen_cells(pts, cells, 1.0)[1] for cells in (topo.tri, topo.quad)]
        area_range_of(pts, topo, ranges, np.array([0, topo.n_tri]))


