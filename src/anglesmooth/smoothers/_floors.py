"""Input floors: what keeps the anisotropic cells of a mesh from collapsing while it is smoothed.

An angle-only objective cannot see a thin quad being flattened (a boundary-layer quad keeps its right
angles while its height goes to zero), so every guarded method gets, from the driver, per incidence
row the smallest area and edge lengths the row's cell may reach: a fixed fraction of its *input*
values, for the cells that are anisotropic in the input.  The same pass over the input also marks
the nodes near triangles whose cells are all well shaped (see :attr:`Floors.keep`), and takes the input's
median cell area (stage 5's size scale, :attr:`Floors.area_median`) and its smallest local score over
the cells of free nodes (the default ``angle``'s ``keep_min``, :attr:`Floors.score_min`).  The score kernels of
:mod:`._local` and :mod:`._fastkernels` apply the floors.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..topology import Topology

__all__ = ["ANISO", "FLOOR", "Floors", "input_floors"]

#: Input floors (see :func:`input_floors`): a cell whose longest edge is at least ``ANISO`` times its
#: shortest in the input (a boundary-layer cell) may not get below ``FLOOR`` of its input area or
#: have an edge at the moving node shorter than ``FLOOR`` of its input length.
FLOOR = 0.25
ANISO = 4.0
#: Well-shaped input cells (see :func:`input_floors`): quad corners within KEEP_QUAD deg of a right
#: angle, triangle corners at least KEEP_TRI deg.
KEEP_QUAD = 30.0
KEEP_TRI = 40.0
KEEP_STRETCH = 1.5
KEEP_RECT = 15.0
_CHUNK = 1 << 16  # cells or rows per chunk of input_floors (bounded temporaries, same values)


class Floors(NamedTuple):
    """Per incidence row (``topo.tri_verts`` / ``topo.quad_verts`` order): twice the smallest
    allowed area and the smallest allowed lengths of the row's two edges at its node (0: no floor).
    ``packed``: the same as one (6, rows) array, for the compiled kernels."""

    t_area2: np.ndarray
    t_e1: np.ndarray
    t_e2: np.ndarray
    q_area2: np.ndarray
    q_e1: np.ndarray
    q_e3: np.ndarray
    packed: np.ndarray
    keep: np.ndarray  # (n_free,) bool: a node near triangles, every input cell well shaped (see below)
    area_median: float = 0.0  # the input's median cell area (stage 5's size scale, :mod:`._patch`); 0: none
    #: the input's smallest local score (``-cos`` of the smallest corner, quad corners ``min(angle, 180 -
    #: angle)``) over the cells of a free node: the default ``angle`` accepts no position below it in
    #: stages 1-2 (see :func:`.angle.step`, ``keep_min``); -inf: an invalid input cell (no such rule)
    score_min: float = -np.inf
    #: the input's largest corner (``-cos``; quads: every corner) over the cells of a free node: the default
    #: ``angle``'s ``keep_max`` opens no corner of a well-shaped input node beyond it (see :func:`.angle.step`);
    #: 1.0 (180 deg): an invalid input cell, or none (no such rule)
    largest_max: float = 1.0

    @property
    def active(self) -> bool:
        """True when some input cell is anisotropic (else nothing is checked)."""
        return self.packed.size > 0


def _gather(z: np.ndarray, cells: np.ndarray):
    """x and y of every corner of (n, k) ``cells``, as k columns each, from the nodes ``z`` as complex
    numbers: one gather fetches x and y together (one cache line, not two), and intp indices (numpy's
    gathers with int32 indices are about twice as slow).  The values are the very coordinates."""
    c = [np.take(z, col) for col in np.ascontiguousarray(cells.T, dtype=np.intp)]
    return [v.real for v in c], [v.imag for v in c]


def _edge_lengths(px, py):
    """(edge vectors ex, ey and lengths (k, n)) of the cells whose corners are at (px, py); edge m runs
    from corner m to m + 1."""
    k = len(px)
    ex = [px[(m + 1) % k] - px[m] for m in range(k)]
    ey = [py[(m + 1) % k] - py[m] for m in range(k)]
    return ex, ey, np.array([np.sqrt(ex[m] * ex[m] + ey[m] * ey[m]) for m in range(k)])


def _cell_shape(z: np.ndarray, cells: np.ndarray):
    """(edge lengths (k, n), well shaped (n,), near-rectangular (n,) or None, twice the signed area (n,),
    score (n,), largest (n,)) of (n, k) ccw cells.

    Edge m runs from corner m to m + 1; well shaped: every corner within ``KEEP_QUAD`` of a right
    angle (quads) or at least ``KEEP_TRI`` (triangles); near-rectangular: within ``KEEP_RECT``;
    score: the local score of the smoothers' kernels, ``-cos`` of the smallest corner (triangles)
    or ``-max |cos|`` (quads), -inf for a cell with an invalid (reflex, degenerate) corner; largest:
    ``-cos`` of the widest corner, 1.0 for a cell with an invalid one.
    """
    k = cells.shape[1]
    px, py = _gather(z, cells)
    ex, ey, e = _edge_lengths(px, py)
    good = np.ones(cells.shape[0], bool)
    rect = np.ones(cells.shape[0], bool) if k == 4 else None
    score = np.full(cells.shape[0], np.inf)
    largest = np.full(cells.shape[0], -np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        for m in range(k):
            j = m - 1  # corner m lies between edge m and the reversed edge m - 1
            cos = -(ex[m] * ex[j] + ey[m] * ey[j]) / (e[m] * e[j])
            ok = ex[j] * ey[m] - ey[j] * ex[m] > 0
            # (a NaN cosine fails ``< inf``: -inf)
            valid = ok & (np.abs(cos) < np.inf)
            score = np.minimum(score, np.where(valid, -np.abs(cos) if k == 4 else -cos, -np.inf))
            largest = np.maximum(largest, np.where(valid, -cos, 1.0))
            if k == 4:
                good &= (np.abs(cos) <= np.cos(np.radians(90.0 - KEEP_QUAD))) & ok
                rect &= (np.abs(cos) <= np.cos(np.radians(90.0 - KEEP_RECT))) & ok
            else:
                good &= (cos <= np.cos(np.radians(KEEP_TRI))) & ok
    return e, good, rect, _area2(px, py), score, largest


def input_floors(points: np.ndarray, topo: Topology, fraction: float = FLOOR, aniso: float = ANISO) -> Floors:
    """The floors that keep the anisotropic cells of the input ``points`` from collapsing, or None.

    Angles alone cannot see a thin quad collapse: a boundary-layer quad 1e-3 thick keeps its right
    angles while it is flattened to 1e-7.  So every guarded method, given these floors (the driver
    computes them from the mesh it is asked to smooth), treats a position where an anisotropic
    input cell (longest edge >= ``aniso`` x shortest) falls below ``fraction`` of its input area,
    or one of its edges at the moving node below ``fraction`` of its input length, as invalid.
    ``active`` is False when the input has no such cell (then nothing is checked, at no cost).

    ``keep`` marks the free nodes near triangles (a node of a triangle, or a corner of a quad that has
    one) whose input cells are all well shaped
    (quad corners within ``KEEP_QUAD`` of a right angle, triangle corners at least ``KEEP_TRI``) or
    that have a near-rectangular (``KEEP_RECT``) stretched (``KEEP_STRETCH``) quad: the default
    ``angle`` moves them to the angle position only where that does not lower their local quality,
    so that the good parts of a mesh (boundary layers made on purpose, already-good meshes) never
    get worse (measured: the angle rule's 45:45 split of a quad's diagonal shears the outer
    boundary-layer quads beside triangles from 93 to 129 deg).  Nodes among quads only are marked
    only when every quad of theirs is near-rectangular (``KEEP_RECT``): the inner layers of a
    boundary layer.  Marking every well-shaped one there held the well-shaped input nodes of the
    paper-style quad meshes where they were, so Table 5's surface error (improvement over
    Laplacian, f1 / f2 / f3, seeds 0-9) was 9.9 / 8.2 / 2.4 % against 13.0 / 10.5 / 3.9 % with no
    rule among quads only (12.1 / 10.4 / 3.7 % with the near-rectangular one); but with no rule there
    a gmsh boundary layer of five quad layers around a hole (input 39.2 / 103.9 deg) ended at
    36.3-41.3 / 127-140 deg instead of 41.8-42.9 / 108-110 (six meshes; see docs/default_method.md).
    """
    n = points.shape[0]
    z = np.ascontiguousarray(points, dtype=np.float64).view(np.complex128).reshape(n)  # x + iy of every node
    areas = []  # |area| of every input cell (for the median only)
    poor = np.zeros(n, bool)  # per point: some cell of it is not well shaped
    keep_q = np.zeros(n, bool)  # per point: a corner of a near-rectangular stretched quad
    an_node = np.zeros(n, bool)  # per point: a corner of an anisotropic cell
    not_rect = np.zeros(n, bool)  # per point: a quad of it is not near-rectangular
    s_min = np.inf  # the smallest score of a cell with a free node
    l_max = -np.inf  # the largest corner (-cos) of a cell with a free node
    # in chunks of cells / rows: element-wise, so the same values, with temporaries of a bounded size
    for all_cells in (topo.tri, topo.quad):
        k = all_cells.shape[1]
        for c0 in range(0, all_cells.shape[0], _CHUNK):
            cells = all_cells[c0 : c0 + _CHUNK]
            e, good, rect, a2, score, largest = _cell_shape(z, cells)
            areas.append(0.5 * np.abs(a2))
            moves = ~topo.fixed[cells].all(axis=1)
            if moves.any():
                s_min = min(s_min, float(score[moves].min()))
                l_max = max(l_max, float(largest[moves].max()))
            emax, emin = np.max(e, axis=0), np.min(e, axis=0)
            an = emax >= aniso * emin
            an_node[cells[an].ravel()] = True
            poor[cells[~good].ravel()] = True
            if k == 4:
                keep_q[cells[rect & (emax >= KEEP_STRETCH * emin)].ravel()] = True
                not_rect[cells[~rect].ravel()] = True
    # near triangles (a node with a triangle, the other corners of its quads): well shaped or a stretched
    # near-rectangular quad; among quads only: every quad near-rectangular (the inner layers of a boundary
    # layer), not merely well shaped (that held uniform quad meshes in place: Table 5, see the docstring)
    near_tri = np.zeros(n, bool)
    near_tri[topo.tri.ravel()] = True
    if topo.quad.shape[0]:
        near_tri[topo.quad[near_tri[topo.quad].any(axis=1)].ravel()] = True
    keep = np.where(near_tri, ~poor | keep_q, ~not_rect)[topo.free_nodes]
    # the six columns are views of one zero-filled (6, rows) array, the kernels' ``packed``: written
    # only where a floor applies (np.zeros pages that are never written take no memory)
    nrow = (topo.tri_verts.shape[0], topo.quad_verts.shape[0])
    packed = np.zeros((6, max(nrow)))
    out = [packed[k, : nrow[k // 3]] for k in range(6)]
    for j, verts in enumerate((topo.tri_verts, topo.quad_verts)):
        wanted = an_node[verts[:, 0]]  # rows of a node with an anisotropic cell
        for r0 in range(0, verts.shape[0], _CHUNK):
            part = wanted[r0 : r0 + _CHUNK]
            # a chunk of wanted rows only is a slice (no index copies); other rows keep their untouched zeros
            rows = slice(r0, r0 + part.shape[0]) if part.all() else np.flatnonzero(part) + r0
            _row_floors(z, verts, rows, out[3 * j : 3 * j + 3], fraction, aniso)
    if not an_node.any():
        packed = np.zeros((0, 0))
    med = float(np.median(np.concatenate(areas))) if areas else 0.0
    return Floors(*out, packed, keep, med, s_min if s_min < np.inf else -np.inf,
                  l_max if -np.inf < l_max < 1.0 else 1.0)


def _area2(px, py) -> np.ndarray:
    """Twice the signed areas of cells with corners at (px, py) (triangles: an edge cross product;
    quads: the diagonals)."""
    if len(px) == 3:
        return (px[1] - px[0]) * (py[2] - py[0]) - (py[1] - py[0]) * (px[2] - px[0])
    return (px[2] - px[0]) * (py[3] - py[1]) - (py[2] - py[0]) * (px[3] - px[1])


def _row_floors(z, verts, rows, out, fraction, aniso) -> None:
    """The floors of incidence rows ``rows`` (indices or a slice) of ``verts``, written into the three
    columns ``out``."""
    k = verts.shape[1]
    if not isinstance(rows, slice) and not rows.shape[0]:
        return
    px, py = _gather(z, verts[rows])  # once, for the lengths and the area
    _, _, e = _edge_lengths(px, py)
    an = np.max(e, axis=0) >= aniso * np.min(e, axis=0)
    area2 = _area2(px, py)
    f = np.where(an, fraction, 0.0)
    for c, v in zip(out, (f * np.abs(area2), f * e[0], f * e[k - 1])):
        c[rows] = v
