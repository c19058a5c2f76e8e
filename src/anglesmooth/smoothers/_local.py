"""Vectorized per-block kernels shared by all smoothers.

A *block* is a set of free nodes that share no cell (one colour class), so
while its nodes move every incident cell has exactly one moving node and the
quality of each node's cells can be evaluated exactly and independently.

Local score
    For a node at a candidate position, the score is the minimum over the
    corners of its incident cells of ``-cos(angle)`` for triangle corners and
    ``-|cos(angle)|`` for quad corners: monotone in the angle for triangles (the
    best score is the best minimum angle; the largest angle of a triangle is
    bounded by its smallest) and in ``min(angle, 180 - angle)`` for quads, whose
    large angles are not bounded by their small ones (measured on paper-style
    tri-quad meshes, a min-angle-only score leaves quad angles of 179 deg).
    No ``acos`` is needed.  A cell
    whose corner has a cross product <= 0 (inverted, degenerate, or a
    non-convex quad) is *invalid*; a position with ``i`` inverted (area <= 0)
    and ``k`` other invalid incident cells scores ``-3 - 1000 i - k``, below
    every valid position: fewer inverted cells first, then fewer invalid ones
    score higher, which is what lets guarded smoothing untangle and never
    tangle more.  With input floors (:func:`._floors.input_floors`), a position where
    an anisotropic input cell shrinks below a fixed fraction of its input
    area or edge length counts as an invalid (non-inverted) cell too.
"""

from __future__ import annotations

import numpy as np

from ..topology import Block, Topology
from . import _fast, _fastcalls
from ._floors import Floors
from ._compass import _COMPASS, optimize  # noqa: F401 (re-exported: moved to _compass)
from ._targets import angle_target, laplacian_target, local_scale  # noqa: F401 (re-exported: moved to _targets)
from ._rows import _C30, _CHUNK, _SMALL, _SMALL_SUBSET, _layout, _rowreduce, _Rows, strict_quad  # noqa: F401
from ._rows import INVALID, INVERTED_WEIGHT, _gather_xy, _largest_rows, _norm, _quad_vals, _row_area, _tri_vals, finish_scores, score_rows  # noqa: F401



_NO_ROWS = np.zeros(0, np.intp)
_NO_VALUES, _NO_BOOLS = np.zeros(0), np.zeros(0, bool)  # the columns of no rows (never written: empty)
_EMPTY_ROWS = object.__new__(_Rows)  # the row layout of no rows (what _Rows gives for none: no chunk)
_EMPTY_ROWS.perm, _EMPTY_ROWS.chunks = _NO_ROWS, []


class BlockGeometry:
    """The fixed part of a block's incident cells, gathered once per block update.

    Parameters
    ----------
    points : (N, 2) current coordinates (the block's own nodes are ignored)
    topo, blk : the topology and one of its blocks
    subset : optional int array of block-local node indices to restrict to

    Every per-row quantity is stored as separate contiguous x / y arrays and
    the score is evaluated one candidate and one chunk of rows at a time, so
    that the numpy temporaries stay in cache.
    """

    def __init__(
        self, points: np.ndarray, topo: Topology, blk: Block, subset: np.ndarray | None = None, floors: Floors | None = None
    ):
        if subset is None:
            key = ("geometry", blk.nodes.start, blk.nodes.stop)
            layout = topo._cache.get(key)
            if layout is None:
                layout = topo._cache[key] = _layout(topo, blk, None)
            self._key, self._cache = key[1:], topo._cache
        else:
            layout = _layout(topo, blk, subset)
        self.n, self._t, self.t_rel, t_v, self._q, self.q_rel, q_v, t_ids, q_ids = layout
        self.floors = floors is not None and floors.active
        if self.floors:
            self.t_fa, self.t_f1, self.t_f2, self.q_fa, self.q_f1, self.q_f3 = _row_floors(
                topo, floors, None if subset is not None else key[1:], t_ids, q_ids)
        with np.errstate(divide="ignore", invalid="ignore"):
            if t_v[0].shape[0]:
                self._tri_columns(points, t_v)
            else:  # no triangle rows (a mesh of quads): empty columns, nothing to gather
                for name in self._TRI:
                    setattr(self, name, _NO_VALUES)
            if not q_v[0].shape[0]:  # no quad rows
                for name in self._QUAD:
                    setattr(self, name, _NO_VALUES)
                self.q_ok2 = _NO_BOOLS
                return
            # quads (p0 moving; p1, p2, p3 fixed); corner 2 does not depend on p0
            self.q_x1, self.q_y1 = _gather_xy(points, q_v[0])
            x2, y2 = _gather_xy(points, q_v[1])
            self.q_x3, self.q_y3 = _gather_xy(points, q_v[2])
            self.q_ux, self.q_uy = x2 - self.q_x1, y2 - self.q_y1  # e12
            ux, uy = self.q_ux, self.q_uy
            # e23, into p2's columns (not needed again)
            self.q_vx, self.q_vy = vx, vy = np.subtract(self.q_x3, x2, out=x2), np.subtract(self.q_y3, y2, out=y2)
            self.q_l12 = _norm(ux, uy)
            self.q_l23 = _norm(vx, vy)
            # corner 2: the angle between e23 and -e12.  Its cross product e23 x -e12 = vx (-uy) - vy (-ux) is
            # -(vx uy) + vy ux exactly (negation is exact), positive exactly where vy ux > vx uy; its cosine
            # (vx (-ux) + vy (-uy)) / (l23 l12) is exactly -((vx ux + vy uy) / (l23 l12)), the same |cos| and
            # finiteness: the former numbers with two negations and three temporaries fewer
            cos2 = vx * ux
            cos2 += vy * uy
            np.divide(cos2, self.q_l23 * self.q_l12, out=cos2)
            ok2 = np.greater(vy * ux, vx * uy)
        ok2 &= np.isfinite(cos2)
        self.q_ok2 = ok2
        self.q_cos2 = np.absolute(cos2, out=cos2)
        if np.count_nonzero(ok2) != ok2.size:  # (np.where(ok2, |cos2|, 1.0)'s numbers)
            cos2[~ok2] = 1.0

    def _tri_columns(self, points: np.ndarray, t_v: tuple) -> None:
        """The triangle rows' columns (p0 moving, p1, p2 fixed), contiguous x / y (see _gather_xy)."""
        self.t_x1, self.t_y1 = _gather_xy(points, t_v[0])
        self.t_x2, self.t_y2 = _gather_xy(points, t_v[1])
        self.t_ux = self.t_x2 - self.t_x1  # e12 = p2 - p1
        self.t_uy = self.t_y2 - self.t_y1
        self.t_l12 = _norm(self.t_ux, self.t_uy)

    _TRI = ("t_x1", "t_y1", "t_x2", "t_y2", "t_ux", "t_uy", "t_l12")
    _QUAD = ("q_x1", "q_y1", "q_x3", "q_y3", "q_ux", "q_uy", "q_vx", "q_vy", "q_l12", "q_l23", "q_ok2", "q_cos2")
    _TRI_FLOORS = ("t_fa", "t_f1", "t_f2")
    _QUAD_FLOORS = ("q_fa", "q_f1", "q_f3")

    def restrict(self, subset: np.ndarray) -> BlockGeometry:
        """The same geometry for the node indices ``subset`` only, without gathering again.

        Each node's rows are taken straight from its run of rows (:meth:`_starts`: every node's rows
        are contiguous in the layout), in O(subset) instead of a remap over all the block's rows, in
        the order a remap, ``flatnonzero`` and :class:`_Rows` give for sorted ``subset``.
        """
        picks, counts = [], []
        for rel_name in ("t_rel", "q_rel"):
            if not getattr(self, rel_name).shape[0]:  # no rows of this kind (a mesh of one kind): none to pick
                picks += [_NO_ROWS, _NO_ROWS]
                counts.append(None)
                continue
            first, cnt = self._starts(rel_name)
            c = cnt[subset]
            ends = np.cumsum(c)
            m = int(ends[-1]) if ends.size else 0
            picks.append(np.repeat(first[subset] - (ends - c), c) + np.arange(m))
            picks.append(np.repeat(np.arange(subset.shape[0]), c))
            counts.append(c)
        return self.pick(subset.shape[0], *picks, counts=counts)

    def pick(self, n: int, t_keep: np.ndarray, t_rel: np.ndarray, q_keep: np.ndarray, q_rel: np.ndarray,
             counts=None) -> BlockGeometry:
        """A geometry of ``n`` nodes made of the rows ``t_keep`` / ``q_keep`` of this one, the row ``t_keep[j]``
        belonging to node ``t_rel[j]`` (``t_rel`` sorted, each node's rows in the order given; ``counts``: the
        rows per node of each kind, or None, if the caller has them)."""
        g = object.__new__(BlockGeometry)
        g.n = n
        g.floors = fl = self.floors
        for keep, rel, rel_name, rows_name, names, cnt in (
            (t_keep, t_rel, "t_rel", "_t", self._TRI + (self._TRI_FLOORS if fl else ()), None if counts is None else counts[0]),
            (q_keep, q_rel, "q_rel", "_q", self._QUAD + (self._QUAD_FLOORS if fl else ()), None if counts is None else counts[1]),
        ):
            if not keep.shape[0]:  # no row of this kind: empty columns (views), no layout to build
                setattr(g, rows_name, _EMPTY_ROWS)
                setattr(g, rel_name, rel)
                for name in names:
                    setattr(g, name, getattr(self, name)[:0])
                continue
            if keep.shape[0] <= _SMALL_SUBSET:  # one ragged chunk, the rows in their order (rel is sorted):
                # what _Rows gives (its stable argsort of a sorted rel is the identity), without sorting
                cnt = np.bincount(rel, minlength=n) if cnt is None else cnt
                nodes = np.flatnonzero(cnt)
                rows = object.__new__(_Rows)
                rows.perm, rows.chunks = None, [(0, keep.shape[0], nodes, cnt[nodes])]
                setattr(g, rows_name, rows)
                setattr(g, rel_name, rel)
                for name in names:
                    setattr(g, name, getattr(self, name).take(keep))
                continue
            rows = _Rows(rel, n, _SMALL_SUBSET)
            setattr(g, rows_name, rows)
            setattr(g, rel_name, rel[rows.perm])
            keep = keep[rows.perm]
            for name in names:
                setattr(g, name, getattr(self, name).take(keep))  # (take: fewer instructions than [keep])
        return g

    def _starts(self, rel_name: str) -> tuple[np.ndarray, np.ndarray]:
        """(first row, number of rows) of every node in the rows ``rel_name`` (``t_rel`` / ``q_rel``): each
        node's rows are contiguous (see :class:`_Rows`).  Topology only: cached with the layout of a whole
        block, computed once per geometry otherwise."""
        hit = self.__dict__.get("_starts_" + rel_name)
        if hit is None:
            key = None if self._key is None else ("geometry-starts", rel_name) + self._key
            hit = None if key is None else self._cache.get(key)
            if hit is None:
                rel = getattr(self, rel_name)
                counts = np.bincount(rel, minlength=self.n)
                first = np.zeros(self.n, np.int64)
                if rel.shape[0]:
                    brk = np.flatnonzero(np.concatenate([[True], rel[1:] != rel[:-1]]))
                    first[rel[brk]] = brk
                hit = (first, counts)
                if key is not None:
                    self._cache[key] = hit
            self.__dict__["_starts_" + rel_name] = hit
        return hit

    _key = None  # (block start, stop) of a whole block's geometry: its row starts are cached with the topology

    def score(self, X: np.ndarray, band: tuple | None = None, strict: np.ndarray | None = None) -> np.ndarray:
        """Local score of every node at candidate positions ``X`` (..., n, 2) -> (..., n).

        With ``band`` = (lo0, hi0) (per node), -inf where an incident area leaves [lo0, hi0]: the
        areas come out of the same pass over the cells as the score (see :meth:`banded_score`).
        With ``strict`` (per node, bool), the quad corners of those nodes that also have triangles
        score :func:`strict_quad` (on the triangles' scale) instead of ``-|cos|``.
        """
        # per quad row: its node is strict and has triangles too
        q_strict = None if strict is None else (self._has_tris() & strict)[self.q_rel]
        X = np.asarray(X, dtype=np.float64)
        lead = X.shape[:-2]
        Xf = X.reshape((-1, self.n, 2))
        K = Xf.shape[0]
        x0, y0 = np.ascontiguousarray(Xf[..., 0]), np.ascontiguousarray(Xf[..., 1])
        best = None  # (K, n): the first chunk's minimum itself where it covers every node, else inf-filled
        bad = out_band = None
        if band is not None:
            b_lo, b_hi = (np.broadcast_to(np.asarray(b, dtype=np.float64), (self.n,)) for b in band)
        fresh = True  # no row reduced into ``best`` yet (min(inf, v) is v: the first chunk of all nodes assigns)
        with np.errstate(divide="ignore", invalid="ignore"):
            for quads, rows in ((False, self._t), (True, self._q)):
                firsts = self._first_chunks() if quads else None
                for ci, (r0, r1, nodes, d) in enumerate(rows.chunks):
                    # small chunks take several candidates at once (fewer, larger numpy calls)
                    kb = max(1, _CHUNK // (r1 - r0))
                    whole = fresh and kb >= K and nodes.shape[0] == self.n  # nodes: sorted, distinct
                    fresh = False
                    # no earlier chunk reduced into these nodes' ``best`` (still inf): assigned, not min-ed
                    first = True if firsts is None else firsts[ci]
                    starts = None if isinstance(d, int) else np.cumsum(d) - d
                    sr = q_strict[r0:r1] if quads and q_strict is not None else None
                    bnd = None if band is None else (b_lo[nodes], b_hi[nodes])
                    for k0 in range(0, K, kb):
                        k1 = min(k0 + kb, K)
                        # one candidate: 1-d rows (a (1, rows) operand against the (rows,) columns costs every
                        # ufunc numpy's general iterator instead of its plain loop)
                        at = (k0, nodes) if K == 1 else (slice(k0, k1), nodes)
                        px, py = _chunk_xy(x0, y0, at, d, nodes.shape[0] == self.n)
                        cols, fl = self._chunk_cols(quads, px, r0, r1)
                        low, w, out = score_rows(quads, px, py, cols, fl, d, starts, sr, bnd)
                        if whole:  # (nodes: sorted, the ragged chunk's too; low: a fresh array)
                            best = low.reshape(K, self.n)
                        else:
                            if best is None:
                                best = np.full((K, self.n), np.inf)
                            if first:
                                best[at] = low
                            else:
                                best[at] = np.minimum(best[at], low)
                        if w is not None:
                            if bad is None:
                                bad = np.zeros((K, self.n))
                            bad[at] += w
                        if out is not None:
                            if out_band is None:
                                out_band = np.zeros((K, self.n), bool)
                            out_band[at] |= out
        if best is None:  # (no rows)
            best = np.full((K, self.n), np.inf)
        return finish_scores(best, bad, out_band).reshape(lead + (self.n,))

    def _first_chunks(self) -> list:
        """Per chunk of quad rows: none of its nodes has a triangle row (the triangle rows' chunks come first
        in :meth:`score`; each node's rows of one kind are in one chunk), so that its minimum is the nodes'
        first.  Topology only: cached with the layout of a whole block, computed once per geometry otherwise."""
        hit = self.__dict__.get("_firsts")
        if hit is None:
            key = None if self._key is None else ("geometry-first-chunks",) + self._key
            hit = None if key is None else self._cache.get(key)
            if hit is None:
                if not self.t_rel.shape[0]:
                    hit = [True] * len(self._q.chunks)
                else:
                    has = self._has_tris()
                    hit = [not has[nodes].any() for _, _, nodes, _ in self._q.chunks]
                if key is not None:
                    self._cache[key] = hit
            self._firsts = hit
        return hit

    def _has_tris(self) -> np.ndarray:
        """Per node: it has a triangle row (topology only: computed once per geometry)."""
        hit = self.__dict__.get("_has_tri")
        if hit is None:
            hit = self._has_tri = np.bincount(self.t_rel, minlength=self.n) > 0
        return hit

    def banded_score(self, X: np.ndarray, lo0: np.ndarray, hi0: np.ndarray, strict=None) -> np.ndarray:
        """The score at ``X`` where every incident area stays within [lo0, hi0] (per node), -inf elsewhere.

        The same numbers as ``np.where`` of :meth:`area_range` and :meth:`score`, in one pass: the
        score kernels' corner cross products give the areas exactly (:func:`._rows.score_rows`).
        """
        return self.score(X, (lo0, hi0), strict)

    def _cols(self, px, r0, r1, *names):
        """The rows r0:r1 of the per-row arrays ``names``, shaped like ``px``: the slices themselves for one
        candidate, else copies tiled to (candidates, rows), made once per geometry and kept (the same
        values; numpy broadcasting a (rows,) operand against (k, rows) ones buffers it on every
        operation, about twice a same-shape operation's time: the compass scores 8 candidates 4 times).
        The triangle rows only: tiling the quad rows' arrays measured no gain (100k quads, numpy:
        instructions per pass without stage 5 395.3 M untiled, 400.5 M tiled)."""
        k = px.shape[0] if px.ndim == 2 else 1
        if k == 1:
            if r0 == 0 and r1 == self.t_x1.shape[0]:  # every row: the columns themselves
                return tuple(getattr(self, name) for name in names)
            return tuple(getattr(self, name)[r0:r1] for name in names)
        tiles = self.__dict__.setdefault("_tiles", {})
        out = []
        for name in names:
            key = (name, r0, r1, k)
            t = tiles.get(key)
            if t is None:
                t = tiles[key] = np.empty((k, r1 - r0), getattr(self, name).dtype)
                t[...] = getattr(self, name)[r0:r1]  # np.tile's values, without its Python-level overhead
            out.append(t)
        return tuple(out)

    def _chunk_cols(self, quads: bool, px, r0: int, r1: int) -> tuple:
        """(columns, floor columns or None) of the rows r0:r1, the operands of :func:`._rows.score_rows`:
        triangle rows tiled like ``px`` (:meth:`_cols`), quad rows as slices."""
        if not quads:
            return self._cols(px, r0, r1, *self._TRI), self._cols(px, r0, r1, *self._TRI_FLOORS) if self.floors else None
        if r0 == 0 and r1 == self.q_x1.shape[0]:  # every row (a small geometry's one chunk): the columns themselves
            return (tuple(getattr(self, name) for name in self._QUAD),
                    tuple(getattr(self, name) for name in self._QUAD_FLOORS) if self.floors else None)
        cols = (self.q_x1[r0:r1], self.q_y1[r0:r1], self.q_x3[r0:r1], self.q_y3[r0:r1], self.q_ux[r0:r1],
                self.q_uy[r0:r1], self.q_vx[r0:r1], self.q_vy[r0:r1], self.q_l12[r0:r1], self.q_l23[r0:r1],
                self.q_ok2[r0:r1], self.q_cos2[r0:r1])  # _QUAD
        return cols, ((self.q_fa[r0:r1], self.q_f1[r0:r1], self.q_f3[r0:r1]) if self.floors else None)

    def columns(self, quads: bool, rows: np.ndarray | None = None) -> tuple:
        """(columns, floor columns or None) of the triangle (``quads`` False) or quad rows ``rows``
        (all rows: None), the operands of :func:`_tri_vals` / :func:`_quad_vals`; ``rows`` may be 2-d."""
        names, fl = (self._QUAD, self._QUAD_FLOORS) if quads else (self._TRI, self._TRI_FLOORS)
        if rows is None:
            get = lambda name: getattr(self, name)  # noqa: E731
        else:
            get = lambda name: np.take(getattr(self, name), rows)  # noqa: E731
        return tuple(get(name) for name in names), (tuple(get(name) for name in fl) if self.floors else None)

    def largest(self, X: np.ndarray) -> np.ndarray:
        """``-cos`` of the largest corner each node's position ``X`` (n, 2) moves: every corner of its
        triangles, corners 0, 1 and 3 of its quads (corner 2 does not depend on it); the score's
        operations, NaN where one is NaN.  Stage 1's test at nodes of well-shaped input cells."""
        x0, y0 = np.asarray(X[:, 0], dtype=np.float64), np.asarray(X[:, 1], dtype=np.float64)
        out = None  # (n,): the first chunk's maximum itself where it covers every node, else -inf-filled
        fresh = True
        with np.errstate(divide="ignore", invalid="ignore"):
            for quads, rows in ((False, self._t), (True, self._q)):
                firsts = self._first_chunks() if quads else None
                for ci, (r0, r1, nodes, d) in enumerate(rows.chunks):
                    every = nodes.shape[0] == self.n  # (nodes: sorted, distinct)
                    if every:
                        px, py = np.repeat(x0, d), np.repeat(y0, d)
                    else:
                        px, py = np.repeat(x0[nodes], d), np.repeat(y0[nodes], d)
                    v = _largest_rows(quads, px, py, self._chunk_cols(quads, px, r0, r1)[0])
                    v = _rowreduce(v, d, np.maximum)
                    if fresh and every:
                        out = v
                    else:
                        if out is None:
                            out = np.full(self.n, -np.inf)
                        # max(-inf, v) is v: a chunk whose nodes no earlier chunk had assigns
                        out[nodes] = v if firsts is None or firsts[ci] else np.maximum(out[nodes], v)
                    fresh = False
        return np.full(self.n, -np.inf) if out is None else out

    def area_range(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Smallest and largest signed area of each node's incident cells at positions ``X`` (..., n, 2)."""
        X = np.asarray(X, dtype=np.float64)
        lead = X.shape[:-2]
        Xf = X.reshape((-1, self.n, 2))
        K = Xf.shape[0]
        x0, y0 = np.ascontiguousarray(Xf[..., 0]), np.ascontiguousarray(Xf[..., 1])
        lo = np.full((K, self.n), np.inf)
        hi = np.full((K, self.n), -np.inf)
        for quads, rows in ((False, self._t), (True, self._q)):
            for r0, r1, nodes, d in rows.chunks:
                kb = max(1, _CHUNK // (r1 - r0))
                for k0 in range(0, K, kb):
                    at = (k0, nodes) if K == 1 else (slice(k0, min(k0 + kb, K)), nodes)
                    px, py = _chunk_xy(x0, y0, at, d)
                    ar = _row_area(quads, px, py, self._chunk_cols(quads, px, r0, r1)[0])
                    lo[at] = np.minimum(lo[at], _rowreduce(ar, d))
                    hi[at] = np.maximum(hi[at], _rowreduce(ar, d, np.maximum))
        return lo.reshape(lead + (self.n,)), hi.reshape(lead + (self.n,))


def _chunk_xy(x0: np.ndarray, y0: np.ndarray, at: tuple, d, every: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The moving corner of a chunk's rows: the candidates ``at`` (``(k, nodes)``: one candidate, 1-d rows;
    ``(slice, nodes)``: (candidates, rows)) of ``x0``, ``y0`` (candidates, nodes), each node's repeated for
    its ``d`` rows.  ``every``: ``nodes`` is every node (``arange``), nothing to gather."""
    if isinstance(at[0], slice):
        if every:
            return np.repeat(x0[at[0]], d, axis=1), np.repeat(y0[at[0]], d, axis=1)
        return np.repeat(x0[at], d, axis=1), np.repeat(y0[at], d, axis=1)
    k, nodes = at
    if every:
        return x0[k].repeat(d), y0[k].repeat(d)
    return x0[k].take(nodes).repeat(d), y0[k].take(nodes).repeat(d)


#: Largest number of incidence rows (triangles' plus quads') of a mesh whose blocks keep their rows'
#: input floors with the topology (3 floats a row: 7 MB on 100k triangles, a third of
#: :class:`BlockGeometry`'s set-up a pass; not kept on large meshes, which run the compiled kernels)
FLOORS_CACHE_ROWS = 1 << 20


def _row_floors(topo: Topology, floors: Floors, key, t_ids: np.ndarray, q_ids: np.ndarray) -> tuple:
    """The input floors of a block's layout rows (``t_ids`` / ``q_ids``): (t_fa, t_f1, t_f2, q_fa, q_f1,
    q_f3).  Topology and floors only: kept with the topology for a whole block (``key``: its (start,
    stop)) of a mesh of at most :data:`FLOORS_CACHE_ROWS` rows, until ``topo.release(floors)``."""
    small = key is not None and topo.tri_loc.shape[0] + topo.quad_loc.shape[0] <= FLOORS_CACHE_ROWS
    ck = ("geometry-floors",) + tuple(key) if small else None
    hit = topo._cache.get(ck) if small else None
    if hit is not None and hit[0] is floors:
        return hit[1:]
    out = tuple(np.take(a, t_ids) for a in floors[:3]) + tuple(np.take(a, q_ids) for a in floors[3:6])
    if small:
        for a in out:
            a.flags.writeable = False  # shared by every pass's geometry of the block
        topo._cache[ck] = (floors,) + out
    return out


def geometry(points: np.ndarray, topo: Topology, blk: Block, floors: Floors | None = None):
    """The block's geometry: a :class:`BlockGeometry`, or its compiled twin on large meshes (see :mod:`._fast`)."""
    if _fast.active(topo):
        return _fastcalls.FastGeometry(points, topo, blk, floors=floors)
    return BlockGeometry(points, topo, blk, floors=floors)


# --------------------------------------------------------------------------
# selection and local optimization


def first_valid(geom: BlockGeometry, current: np.ndarray, target: np.ndarray, halvings: int = 6):
    """Guard: the target, or the move halved until no incident cell becomes invalid.

    A node whose every shortened move is invalid stays (unless its current
    position is itself invalid and a move reduces the number of invalid cells).
    Returns (positions, rejected mask: True where the full move was refused).

    The full moves are scored first; only the nodes where one is refused score
    the shortened moves (the same choice as scoring every candidate).
    """
    full = current + (target - current)
    refused = ~(geom.score(full) > INVALID - 0.5)
    if not refused.any():
        return full, refused
    sub = np.flatnonzero(refused)
    cur, tgt = current[sub], target[sub]
    fr = 0.5 ** np.arange(halvings + 1)
    cands = cur[None] + fr[:, None, None] * (tgt - cur)[None]
    cands = np.concatenate([cands, cur[None]])
    s = geom.restrict(sub).score(cands)
    valid = s > INVALID - 0.5
    # first valid fraction; where none is valid, the best (staying is a candidate,
    # so an already invalid neighbourhood never gets more invalid cells)
    k = np.where(valid.any(axis=0), np.argmax(valid, axis=0), np.argmax(s, axis=0))
    full[sub] = cands[k, np.arange(sub.shape[0])]
    refused[sub] = k != 0
    return full, refused
