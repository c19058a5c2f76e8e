"""Patch moves: the free nodes around the mesh's worst cells move together (issue 12).

The trap
    A per-node rule can be stuck where several nodes must move at once.  Paper-style mixed mesh,
    seed 0: the worst triangle (18.7 deg after 10 default passes) belongs to a valence-3 node inside
    a sliver triangle with two fixed boundary corners; that node alone can reach at most half of the
    sliver's smallest angle, and the sliver's third corner cannot open the sliver without closing
    its other cells (a 160 deg quad corner), and so on one ring further out.

The move
    After the per-class loop of a pass, the ``cells`` worst cells whose quality (triangle corners:
    the angle; quad corners: ``min(angle, 180 - angle)``) is below ``below`` degrees each give a
    patch: their free corners and the free nodes within ``rings`` edge rings of them (nodes of
    anisotropic input cells, which have input floors, and nodes whose input cells were all well
    shaped, ``floors.keep``, could be left out: ``BLOCK_FLOORED``, ``BLOCK_KEEP``, both off, see
    below).  The patch's nodes move together by an ascent of the
    patch's minimum corner quality over every cell incident to them: the direction is the
    min-norm element of the convex hull of the gradients of the corners within ``eps`` of the
    minimum (Freitag's steepest ascent of a max-min, here in 2 x nodes dimensions, its min-norm
    problem solved exactly by Wolfe's algorithm, :mod:`._patchascent`), the step the longest of 8 halvings that raises the
    minimum with every cell valid (positive area, convex quads) and every cell area inside the
    band of :func:`._local.optimize`, every input floor of the moving nodes' incidence rows kept
    (:mod:`._floors`), (at least ``area_band`` of the smallest, at most ``1 /
    area_band`` of the largest start area of the patch, and within the mesh's area range
    ``area_limits``, unless already outside).  A patch that shares a cell with an earlier
    (worse) one is skipped, so every patch's score is exact.  The patch's minimum never decreases.

The size term (``size``, :data:`SIZE` 0.15)
    Every cell of a patch also counts in the patch's minimum, as if it were a corner of ``below``
    (30) deg times its area over ``size`` x the input's median cell area (``floors.area_median``),
    and its area's gradient joins the corners' in the min-norm problem.  It binds only at cells
    smaller than ``size`` x the median x (the patch's minimum / ``below``): the patches are around
    the worst cells, usually input slivers, and the band above is relative to the patch's smallest
    start area, the sliver's own, so on angles alone the ascent opened a sliver by shrinking its
    neighbours (paper-style mixed mesh, seed 3: a triangle of 0.40 x the median input area ended at
    0.10 after the first pass; the literal rule keeps it at 0.40).  With the term the ascent grows
    the sliver instead, often to a higher angle too (that patch after 3 passes: 17.3 deg and 0.11
    x the median on angles alone, 20.4 deg and 0.21 with ``size`` 0.3).  Measured (10 passes; mean
    of the mesh minimum angle, area ratio per seed over the literal rule's, mean (max); seeds 0-9
    then 10-29): paper-style mixed 24.91, 1.264 (2.05) / 26.43, 1.240 (1.91) -> 24.94, 1.201 (1.85)
    / 26.38, 1.153 (1.91); triangles 24.63, 1.039 (1.30) / 24.41, 1.041 (1.79) -> 24.66, 1.047
    (1.36) / 24.25, 1.016 (1.68); graded 20.28, 0.918 (1.23) / 19.19, 1.375 (5.77) -> 20.44, 0.810
    (1.14) / 20.35, 1.004 (1.68); paper-style quads (0-9) 32.07 -> 32.51.  ``size`` 0.2: mixed 24.58
    / 25.64 (1.114 / 1.038), 0.25 (the mesh's current median): mixed 23.78, 0.974 (1.40); 0.1: no
    gain.  Bounds on the areas instead of the term all cost minimum angle (docs/default_method.md).
    Pure numpy on a few dozen nodes after the pass, so the same for the numpy and compiled kernels;
    only the screen that finds the cells below ``below`` (:func:`_maybe_below`, a superset; the exact
    quality of the cells it keeps decides) is compiled where the mesh runs on the compiled kernels.
    The patches share no cell, so they ascend in lockstep (:func:`._patchascent.ascend_all`: one
    evaluation of every patch's trial steps per ascent step, bit for bit the ascent of each alone).

Cost (issue 12 item 3; 100k random Delaunay triangles, 10 default passes, CPU, one thread, a loaded
machine; stage 5 alone, median ms a pass)
    Frank-Wolfe (50 steps of tiny numpy operations per min-norm solve, one evaluation per patch and
    step): numba 41-51, numpy 45-47; now (exact min-norm, warm-started; lockstep patches; the screen
    and the candidates' quality by columns, only the worst candidates sorted): numba 9-15, numpy
    13.6-14.2.  The exact min-norm direction is also a better one: on the same stage-5 inputs
    (paper-style tri / mixed, graded, 2 seeds, and random 100k; 218 patches) the patch's final
    minimum is 0.17 deg higher on average (155 better, 49 worse); after 10 passes, seeds 0-2, the
    minimum angle (mean) paper-style triangles 27.37 -> 26.44, mixed 25.34 -> 25.74, quads 30.22 ->
    33.14, graded 20.69 -> 20.75 (seeds 0-9: -0.22 / +0.04 / +0.83 / -0.11: the trajectories differ,
    the mean does not move).
    Instructions (callgrind, stage 5 alone on the inputs of passes 3-5, M a call; bit-identical): numba
    67.5 -> 56.7, numpy 74.6 -> 66.1: the compiled screen hands over the kept cells' cotangents (no
    second gather of some 10 % of the cells: 16 ms a call at 1M triangles, one thread), the min-norm
    solver's corral as an index array, the batch score on node-major planes with takes instead of fancy
    indexing.  What is left (numba, 100k): the screen ~11 (a compiled read of every cell, ~100
    instructions a cell; at 1M triangles ~75 % of stage 5's time, memory-bound), the min-norm solves ~13
    (LAPACK's dgesv on 5-10 rows: ~15k instructions each), the rest numpy calls on a few hundred corners.

Measured (issue 12; paper-style meshes, 10 default passes, seeds 0 / 1 / 2, minimum angle)
    The prototype, run only after the 10 passes (5 rounds of the 8 worst cells): paper-style mixed
    18.73 / 25.06 / 23.51 -> 20.75 / 29.40 / 29.31 with one ring, 20.71 / 29.59 / 29.35 with two;
    seed 0 with three or five rings 20.73 / 20.72, and without area band or limits the same 20.72:
    the sliver's patch ends balanced (four cells at 20.72 deg), a local max-min optimum of that
    topology.  Leaving out nodes with an input floor (the paper-style meshes' input slivers are
    anisotropic, so the trapped node was one of them): no gain at all (22.54 mean); with the floors
    kept exactly instead (areas then from corner cross products, Frank-Wolfe ties by argmin): mixed
    20.29 / 28.21 / 28.12 (mean 25.54), triangles 26.13 / 28.46 / 25.47 (26.69, was 24.83); as
    committed (shoelace areas and a round-off-proof tie rule, so that the reference agrees): mixed
    20.29 / 28.56 / 26.97 (25.27), triangles 26.78 / 28.06 / 25.52 (26.79), with 30 ascent steps a pass;
    the default is 15 (``angle.step``'s ``patch_iterations``): mixed 20.47 / 27.69 / 27.87 (25.34),
    triangles 27.29 / 29.22 / 25.59 (27.37), at 0.6x the time.  See ``angle.py``.
"""

from __future__ import annotations

import numpy as np

from ..topology import Topology, signed_areas
from ._floors import Floors
from . import _fast, _fastcalls
from ._patchascent import _Patch, _loc_of, ascend_all

__all__ = ["patch_moves"]

#: Leave out of the patches the nodes of well-shaped input cells / of anisotropic input cells (floored):
#: measured off (see the module docstring; the floors are kept exactly instead).
BLOCK_KEEP = False
BLOCK_FLOORED = False
#: Stage 5's size term (see :func:`patch_moves`): a cell of SIZE x the input's median area weighs like a
#: corner of ``below`` degrees (measured: 0.1 / 0.2 / 0.25 in the module docstring)
SIZE = 0.15
_CHUNK = 1 << 15  # cells per chunk of the numpy screen (its temporaries stay in the caches)


def _csr(topo: Topology, nodes: np.ndarray) -> np.ndarray:
    """Ids of the cells of the free ``nodes`` (triangles, then quads from nt; a shared cell repeated).

    The incidence rows of a free node are one slice of ``topo.tri_loc`` / ``topo.quad_loc`` (found by
    binary search), and ``topo.tri_cell`` / ``topo.quad_cell`` give their cells: no node -> cell table
    of the whole mesh (at 1M triangles it took 0.4 s and 30 MB kept, 70 MB while sorted).
    """
    loc = _loc_of(topo)[nodes]
    out = []
    for table, cell, shift in ((topo.tri_loc, topo.tri_cell, 0), (topo.quad_loc, topo.quad_cell, topo.n_tri)):
        lc = loc.astype(table.dtype)  # the needles in the table's own type (no conversion of the table)
        lo = np.searchsorted(table, lc, "left")
        n = np.searchsorted(table, lc, "right") - lo
        rows = np.repeat(lo - (np.cumsum(n) - n), n) + np.arange(int(n.sum()))
        out.append(cell[rows].astype(np.intp) + shift)
    return np.concatenate(out)


def _ring_of(topo: Topology, nodes: np.ndarray) -> np.ndarray:
    """The ring neighbours of ``nodes``, node after node (``topo.ring_indices``' slices, concatenated)."""
    lo, hi = topo.ring_offsets[nodes], topo.ring_offsets[nodes + 1]
    n = hi - lo
    return topo.ring_indices[np.repeat(lo - (np.cumsum(n) - n), n) + np.arange(int(n.sum()))]


def _corner_products(points: np.ndarray, cells: np.ndarray):
    """(cross, dot) (k, m) of every corner of the cells (m, k): :func:`cell_quality`'s products."""
    m, k = cells.shape
    pts = np.asarray(points, dtype=np.float64)
    z = np.ascontiguousarray(pts[:, :2]).view(np.complex128).ravel()
    c = cells.T.astype(np.intp)
    zc = [z[c[i]] for i in range(k)]
    cr, dot = np.empty((k, m)), np.empty((k, m))
    for i in range(k):
        u, w = zc[(i + 1) % k] - zc[i], zc[i - 1] - zc[i]
        ux, uy, wx, wy = u.real, u.imag, w.real, w.imag
        np.subtract(ux * wy, uy * wx, out=cr[i])
        np.add(ux * wx, uy * wy, out=dot[i])
    return cr, dot


def cell_quality(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Per cell (m, k), the smallest corner quality in radians (quads: ``min(a, pi - a)``); -1 if invalid.

    Corner c: the angle from u = p_{c+1} - p_c to w = p_{c-1} - p_c, ``arctan2(u x w, u . w)``.
    """
    cr, dot = _corner_products(points, cells)
    th = np.arctan2(cr, dot)
    if cells.shape[1] == 4:
        th = np.minimum(th, np.pi - th)
    return np.where((cr > 0).all(axis=0), th.min(axis=0), -1.0)


def _cell_cot(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Per cell (m, k), the largest corner cotangent (quads: its absolute value), +inf if invalid: a
    decreasing function of :func:`cell_quality` up to round-off (see :func:`_worst_first`); no arctan2."""
    cr, dot = _corner_products(points, cells)
    with np.errstate(divide="ignore", invalid="ignore"):
        p = dot / cr
    if cells.shape[1] == 4:
        np.abs(p, out=p)
    return np.where((cr > 0).all(axis=0), p.max(axis=0), np.inf)


def _maybe_below(points: np.ndarray, cells: np.ndarray, below: float, fast: bool = False, ranges=None,
                 cots=None) -> np.ndarray:
    """Ids (ascending) of a superset of the cells whose :func:`cell_quality` is below ``below`` degrees.

    A corner of angle a in (0, 180) has min(a, 180 - a) < b exactly when its cross product is below
    tan(b) times the absolute dot product; the test is padded so that round-off never drops a cell
    (the exact quality then decides), and an invalid corner (cross <= 0) always counts.  Sqrt- and
    arctan-free, on a few columns at a time.  ``ranges`` (a list): the cells' area range per chunk,
    from the same read (:func:`._fastcalls.screen_cells`; numpy: (lo, hi) per :data:`_RANGE_CHUNK`
    cells), is appended to it, None where the screen did not run.  ``cots`` (a list): the kept cells'
    :func:`_cell_cot`, where the compiled screen gave it (from the same read), is appended to it, else None.
    """
    m, k = cells.shape
    if cots is not None and not (fast and m and 0.0 < below < 89.0):
        cots.append(None)
    if m == 0 or below <= 0.0 or below >= 89.0:  # no cell, or none / (almost) every cell: no screen
        if ranges is not None:
            ranges.append((np.empty(0), np.empty(0), np.empty(0, bool)) if m == 0 else None)
        return np.zeros(0, np.intp) if m == 0 or below <= 0.0 else np.arange(m)
    t = np.tan(np.radians(below)) * (1.0 + 1e-6)
    if fast:  # the same test, compiled (``fast``: the mesh runs on the compiled kernels), threaded, with
        # the cells' area range in the same read (the next pass's ``area_limits``); through _fast: its
        # compile (0.2-0.4 s, the first run ever) is timed apart, as every kernel's
        ids, rng, cot = _fastcalls.screen_cells(points, cells, t)
        if ranges is not None:
            ranges.append(rng)
        if cots is not None:
            cots.append(cot)
        return ids
    rlo = rhi = None
    if ranges is not None:  # the area range per chunk of _RANGE_CHUNK cells, from the same read
        n_chunks = -(-m // _RANGE_CHUNK)
        rlo, rhi = np.empty(n_chunks), np.empty(n_chunks)
        ranges.append((rlo, rhi))
    # the edges e_c = p_{c+1} - p_c once (the corner's u is e_c, its w is -e_{c-1} exactly), so that
    # cross = uy ex - ux ey and |dot| = |ux ex + uy ey| with e = e_{c-1}: the same bits as from u and w
    z = np.ascontiguousarray(points[:, :2], dtype=np.float64).view(np.complex128).ravel()
    hit = np.zeros(m, bool)
    for s0 in range(0, m, _CHUNK):
        c = cells[s0:s0 + _CHUNK].T.astype(np.intp)
        zc = [z[c[i]] for i in range(k)]
        e = [zc[(i + 1) % k] - zc[i] for i in range(k)]
        ex, ey = [x.real.copy() for x in e], [x.imag.copy() for x in e]
        h = hit[s0:s0 + _CHUNK]
        for i in range(k):
            cr = ey[i] * ex[i - 1]
            cr -= ex[i] * ey[i - 1]
            dot = ex[i] * ex[i - 1]
            dot += ey[i] * ey[i - 1]
            np.abs(dot, out=dot)
            dot *= t
            dot += 1e-300
            h |= cr < dot
            if rlo is not None and i == 0 and k == 3:
                # twice a triangle's area, signed_areas' bits: its u = e_0 and v = -e_2 exactly, so that
                # ux vy - uy vx = e0y e2x - e0x e2y, this corner's cross product
                _chunk_range(0.5 * cr, s0, rlo, rhi)
        if rlo is not None and k == 4:
            d02, d13 = zc[2] - zc[0], zc[3] - zc[1]  # signed_areas' diagonals, the same operations
            _chunk_range(0.5 * (d02.real * d13.imag - d02.imag * d13.real), s0, rlo, rhi)
    return np.flatnonzero(hit)


#: cells a chunk of the area range the numpy screen gives (a few chunks are recomputed after stage 5
#: moved some nodes: :func:`_area_range_np`); a divisor of _CHUNK
_RANGE_CHUNK = 256


def _chunk_range(a: np.ndarray, s0: int, lo: np.ndarray, hi: np.ndarray) -> None:
    """The smallest and largest of the areas ``a`` of cells ``s0:`` (``s0`` a multiple of
    :data:`_RANGE_CHUNK`) per chunk of :data:`_RANGE_CHUNK` cells, into ``lo`` / ``hi`` (NaN where one is
    NaN: numpy's ``min`` / ``max`` propagate it)."""
    j0, m = s0 // _RANGE_CHUNK, a.shape[0]
    full = m // _RANGE_CHUNK
    if full:
        w = a[: full * _RANGE_CHUNK].reshape(full, _RANGE_CHUNK)
        lo[j0:j0 + full], hi[j0:j0 + full] = w.min(axis=1), w.max(axis=1)
    if m > full * _RANGE_CHUNK:
        lo[j0 + full], hi[j0 + full] = a[full * _RANGE_CHUNK:].min(), a[full * _RANGE_CHUNK:].max()


def _area_range_np(points: np.ndarray, topo: Topology, ranges, moved_cells=None):
    """The numpy screen's twin of :func:`._fastcalls.area_range_of`: the (smallest, largest) signed cell
    area at ``points`` (``float(areas.min())``, ``float(areas.max())`` of ``signed_areas``: the same
    values, NaN when one is NaN) from the per-chunk ranges ``ranges`` (of the triangles, of the quads)
    the screen gave at points that differ from ``points`` only at corners of ``moved_cells`` (their
    chunks are computed again with ``signed_areas``), or None without cells."""
    if topo.tri.shape[0] + topo.quad.shape[0] == 0:
        return None
    nt = topo.n_tri
    empty = np.zeros((0, 4), topo.quad.dtype)
    for cells, (lo, hi, *_), ids, tri in ((topo.tri, ranges[0], None if moved_cells is None else moved_cells[moved_cells < nt], True),
                                      (topo.quad, ranges[1], None if moved_cells is None else moved_cells[moved_cells >= nt] - nt, False)):
        if ids is None or not ids.size:
            continue
        for j in np.unique(ids // _RANGE_CHUNK).tolist():
            part = cells[j * _RANGE_CHUNK:(j + 1) * _RANGE_CHUNK]
            a = signed_areas(points, part, empty) if tri else signed_areas(points, empty[:, :3], part)
            lo[j], hi[j] = a.min(), a.max()
    lo = np.concatenate([ranges[0][0], ranges[1][0]])  # (an empty kind: the screen's (empty, empty, empty))
    hi = np.concatenate([ranges[0][1], ranges[1][1]])
    return float(lo.min()), float(hi.max())


def _blocked(topo: Topology, floors: Floors | None) -> np.ndarray:
    """(N,) bool: nodes a patch may not move (fixed, floored or well-shaped input); cached per floors."""
    key = ("patch-blocked", id(floors))
    hit = topo._cache.get(key)
    if hit is None or hit[0] is not floors:
        out = np.asarray(topo.fixed, bool).copy()
        if floors is not None:
            fn = topo.free_nodes
            if BLOCK_KEEP:
                out[fn[floors.keep]] = True
            if floors.active and BLOCK_FLOORED:
                for loc, area in ((topo.tri_loc, floors.t_area2), (topo.quad_loc, floors.q_area2)):
                    out[fn[np.unique(loc[area > 0])]] = True
        hit = topo._cache[key] = (floors, out)
    return hit[1]


def _worst_first(cot: np.ndarray, exact, k: int, below: float):
    """The candidates (indices) whose exact quality ``exact(ids)`` (:func:`cell_quality`) is below
    ``below`` radians, in ``np.argsort(quality, kind="stable")`` order, one by one; the exact quality
    only of the ``k`` (or a few more) worst by ``cot`` (:func:`_cell_cot`) unless more are asked for:
    the loop over the candidates stops after a few.

    A corner's quality is arccot of its (absolute, quads) cotangent p.  Every cell whose cotangent is
    below pk - 1e-8 (1 + pk^2), pk the k-th largest, has every corner above the worst corner of each
    of the k by more than 1e-9 radians (far above the round-off of arctan2 or of p): its exact quality
    is above theirs.  So the cells within that band, sorted by their exact quality up to the largest
    of the k's, are a prefix of the stable order of all (an infinite or overflowing pk: every cell)."""
    m = cot.shape[0]
    pk = np.partition(cot, m - k)[m - k] if m > k else np.nan
    if pk == pk:  # (a NaN: every cell)
        with np.errstate(over="ignore", invalid="ignore"):
            thr = pk - 1e-8 * (1.0 + pk * pk)
        head = np.flatnonzero(~(cot < thr))
        qh = exact(head)
        v = qh[cot[head] >= pk].max()
        first = qh <= v
        hq = qh[first]
        for i in np.argsort(hq, kind="stable").tolist():
            if not hq[i] < below:
                return
            yield int(head[first][i])
        rest = np.flatnonzero(np.isin(np.arange(m), head[first], invert=True))
    else:
        rest = np.arange(m)
    qr = exact(rest)
    for i in np.argsort(qr, kind="stable").tolist():
        if not qr[i] < below:
            return
        yield int(rest[i])


def patch_moves(
    points: np.ndarray,
    topo: Topology,
    floors: Floors | None = None,
    *,
    below: float = 30.0,
    cells: int = 8,
    rings: int = 2,
    iterations: int = 30,
    eps: float = 2.0,
    area_band: float | None = 0.8,
    area_limits: tuple[float, float] | None = None,
    size: float | None = SIZE,
    with_range: bool = False,
    overwrite: bool = False,
):
    """The points with the patches of the worst cells moved (see the module docstring).

    ``size``: a cell of ``size`` x the input's median cell area (``floors.area_median``) counts in the
    patch's minimum like a corner of ``below`` degrees, smaller cells proportionally less (None, or no
    floors: angles only).  ``with_range``: (points, the (smallest, largest) signed cell area at them,
    :func:`._fastcalls.area_limits`' numbers, or None where the compiled screen did not give it).
    ``overwrite``: the patches' nodes move in ``points`` itself when it is a float64 array (one the caller
    gives away: ``angle.step``'s pass result; no copy of every point, 16 MB at 1M triangles)."""
    P, rng, moved = _patch_moves(points, topo, floors, below, cells, rings, iterations, eps, area_band, area_limits,
                                 size, with_range, overwrite)
    if not with_range:
        return P
    if rng is None or any(r is None for r in rng):
        return P, None
    if _fast.active(topo):
        return P, _fastcalls.area_range_of(P, topo, rng, moved)
    return P, _area_range_np(P, topo, rng, moved)


def _patch_moves(points, topo, floors, below, cells, rings, iterations, eps, area_band, area_limits, size, with_range,
                 overwrite=False):
    """:func:`patch_moves`: (points, the screen's per-chunk area ranges or None, the ids of the cells whose
    corners moved, or None)."""
    P = np.asarray(points, dtype=np.float64)
    nt = topo.n_tri
    blocked = _blocked(topo, floors)
    allc = [topo.tri, topo.quad]
    # the exact quality (arctan2) only of the cells a cheap test cannot clear (1M triangles: the
    # exact quality of every cell was most of a pass); the same cells, values and order as from all
    fast = _fast.active(topo)
    rng = [] if with_range else None
    cots = []  # the candidates' _cell_cot where the compiled screen gave it
    cand = np.concatenate([_maybe_below(P, topo.tri, below, fast, rng, cots),
                           nt + _maybe_below(P, topo.quad, below, fast, rng, cots)])
    ntc = int(cand.searchsorted(nt))  # the candidates: triangles, then quads
    if not cand.size:
        return P, rng, None
    cot = np.concatenate([_cell_cot(P, topo.tri[cand[:ntc]]) if cots[0] is None else cots[0],
                          _cell_cot(P, topo.quad[cand[ntc:] - nt]) if cots[1] is None else cots[1]])

    def exact(ids):
        t = ids[: int(ids.searchsorted(ntc))]
        return np.concatenate([cell_quality(P, topo.tri[cand[t]]), cell_quality(P, topo.quad[cand[ids[t.shape[0]:]] - nt])])

    S = None
    if size and floors is not None and floors.area_median > 0:
        S = np.radians(below) / (size * floors.area_median)
    used_cells = set()  # the cells of the patches so far (a few hundred: no per-cell array)
    out = P if overwrite else P.copy()  # (the patches read P only before any of them moves)
    done = 0
    patches, patch_cells = [], []
    for i in _worst_first(cot, exact, 4 * cells + 16, np.radians(below)):  # at most a few dozen candidates, at most ``cells`` patches
        if done >= cells:
            break
        c = int(cand[i])
        verts = allc[0][c] if c < nt else allc[1][c - nt]
        nodes = verts[~blocked[verts]]
        if not nodes.size:
            continue
        done += 1
        if c in used_cells:  # the cell is one of its own patch's (a corner of it moves): shared, skipped
            continue
        for _ in range(rings):
            nb = _ring_of(topo, nodes)
            nodes = np.union1d(nodes, nb[~blocked[nb]])
        ids = np.unique(_csr(topo, nodes))
        idl = ids.tolist()
        if not used_cells.isdisjoint(idl):
            continue
        used_cells.update(idl)
        patches.append(_Patch(P, topo, nodes, ids, floors, S))
        patch_cells.append(ids)
    # the patches share no cell, so none has another's moving nodes among its cells: all at once
    for patch, X in zip(patches, ascend_all(patches, [P[p.nodes] for p in patches], iterations, np.radians(eps),
                                            area_band, area_limits)):
        out[patch.nodes] = X
    moved = np.concatenate(patch_cells) if patch_cells else None  # (every patch's cells: a superset)
    return out, rng, moved
