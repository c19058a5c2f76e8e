"""Angle-based smoothing (Zhou & Shimada 2000), literal and robust.

Reference: T. Zhou and K. Shimada, "An angle-based approach to two-dimensional
mesh smoothing", Proceedings of the 9th International Meshing Roundtable
(2000) 373-384, Section 4.

The paper's rule, as implemented (``guard=False``)
    For a free node i and each node j of its ring, let a and b be the nodes
    beside the spoke j->i, met in the order a, i, b when turning
    counter-clockwise about j.  The spoke is rotated about j, keeping its
    length, onto the ray that splits the counter-clockwise angle a-j-b in the
    ratio of the ideal angles of the two sides: equally (the paper's
    ``b_j = (a_2 - a_1)/2``) when both sides are triangle corners (60:60) or
    both quad corners (90:90), 3:2 when a quad corner (90) is beside a
    triangle corner (60).  Quads also contribute their diagonal node as a ring
    node, where the quad angle is split by the diagonal (45:45).  The new
    position of i is the mean of the rotated positions over the whole ring.

    Interpretations where the paper is terse: the two angles beside a spoke
    are measured inside the counter-clockwise sweep from a to b about j, so a
    spoke lying outside it (a non-convex or inverted corner) is rotated back
    into it, which untangles rather than equalizing two reflex angles; the
    bisector of an equal split is computed from unit vectors,
    ``normalize(rot90(u_a - u_b))``, the "more efficient way" the paper
    mentions in Section 5.2, exact and free of trigonometry; nodes are updated
    colour class by colour class (Gauss-Seidel; ``order="jacobi"`` updates all
    at once).

    Worked example.  Ring node j = (1, 0) with a = (0.5, 0.866) and
    b = (0.5, -0.866) (two triangles of a regular hexagon around i), and i
    displaced to (0.2, 0.3).  The counter-clockwise angle from a to b about j
    runs from 120 deg to 240 deg, so its bisector points at 180 deg; the spoke
    length |i - j| = 0.854 is kept, giving the candidate (0.146, 0.0) for this
    spoke.  Had the a side been a quad corner and the b side a triangle
    corner, the ray would be at 120 + 0.6 * 120 = 192 deg instead.

The robust default (``guard=True``)
    The literal rule can invert cells on strongly graded meshes and end worse
    than Laplacian there; a guard that only ever accepts improvements gets
    stuck instead.  The default does, per colour class (nodes of one class
    share no cell, so every test below is exact):

    1. *Angle position where it is good enough.*  The node takes its angle
       position A when the local quality there (the smallest angle of its
       incident cells; quad corners count ``min(angle, 180 - angle)``) is at
       least ``accept_above`` (20 deg) -- whether or not staying would score
       higher.  This is most nodes of a decent mesh, and it is what keeps the
       paper's size uniformity.  Nodes near triangles (a triangle's, or a
       corner of a quad that has one) whose input cells were all well shaped
       (quad corners within 30 deg of a right angle, triangle corners >= 40
       deg, or a stretched well-shaped quad: see
       :func:`._floors.input_floors`) take it only if it is also no worse
       than staying, so the good parts of a mesh never get worse.
    2. *Otherwise the nearest good one, else the best of five*: of the
       Laplacian position L, (A+L)/2, (A+C)/2 and the current position C, the
       one nearest A whose local quality is at least the acceptance
       threshold; where none is, the best of those and A by local quality,
       no candidate with an inverted, degenerate or non-convex cell (C is one
       of them).  Nodes of well-shaped input cells always take the best.
    3. *Stuck nodes*: where all four moves are invalid and staying is not,
       the guarded Laplacian move (halved until valid).  A quad flattened
       onto the boundary whose two free corners block each other gets out
       only this way (every single move of either corner is invalid).
    4. *Local optimization of the worst*: the worst ``opt_fraction`` (5 %)
       of the class, if below ``opt_below`` (40 deg; 60 deg at a node of a
       quad: two thirds of the ideal angle, so that quads are not left at 40
       deg), take ``opt_iterations`` (4) compass-search steps of the local
       max-min-angle optimization (see :mod:`.optimization`), keeping the
       node's smallest incident cell above 0.8 of its area and above the
       smallest cell area of the mesh at the start of the pass, and its
       largest below 1/0.8 of its area and below the mesh's largest
       (``area_limits``; a cell already outside that range only may not get
       further out): the hybrid of Freitag (1997) and Canann, Tristano &
       Staten (1998).  At a node of well-shaped input cells that has both
       triangles and quads, the search counts a quad corner ``d`` degrees
       away from a right angle like a triangle corner ``d`` degrees below
       60 (``strict_quads``, :func:`._local.strict_quad`), not like one of
       ``90 - d``: otherwise it shears the good outer quads of a boundary
       layer (92.7 deg) up to 116-125 deg to lift the triangles beside them
       from 40 to 44 deg.  A node of quads only that scores higher where it
       is (C) than at its stage 1-2 choice and is at least ``resume_above``
       (45 deg) good there -- it was optimized in the previous pass and
       pulled back toward A -- resumes the search from C instead, with
       ``resume_iterations`` (12) steps from ``resume_radius`` (0.0625)
       times the mean edge length: otherwise it restarts from A every pass
       and never gets closer than 4 coarse steps to the local optimum.

    5. *Patches around the worst cells* (``patch_cells`` 8, ``patch_below``
       30 deg): after the pass, the free nodes within two rings of each of
       the 8 worst cells below 30 deg move together by a steepest ascent of
       the patch's minimum angle, with the guard, floors and area limits of
       stage 4 (see :mod:`._patch`): a valence-3 node inside a boundary sliver
       with two fixed corners can reach at most half the sliver's smallest
       angle alone, and the sliver opens only if its neighbours move too.

    Stage 5 (issue 12; mean minimum angle over seeds 0-2, per seed): paper-
    style mixed 18.73 / 25.06 / 23.51 (22.43) -> 20.29 / 28.56 / 26.97
    (25.27), triangles 24.83 -> 26.79, graded 18.41 -> 20.61 (area ratio
    median 109 -> 148), quads 29.32 -> 29.99; every family still passes.
    Cost: first a fixed ~0.12 s CPU a pass (numpy, 100k triangles: 0.08-0.09 ->
    0.20-0.23 s), 60 % of it a Frank-Wolfe loop for the min-norm direction;
    with the exact direction (Wolfe's algorithm) and the patches of a pass
    ascending in lockstep 9-15 ms a pass on either kernel (see :mod:`._patch`;
    that changed the meshes: quality matrix paper-style triangles 27.4 ->
    26.4, mixed 25.3 -> 25.7, quads 30.2 -> 33.1 deg, seeds 0-2).
    Alternatives: 4 patches instead of 8: mixed 24.84; Frank-Wolfe stopped
    at a 1e-3 relative gap and the active-set tolerance at 2e-3 rad
    (cheaper, 100k pass 0.22 s): mixed 24.83.  Patch nodes within one ring instead of two (post-hoc
    prototype): 20.75 / 29.40 / 29.31 against 20.71 / 29.59 / 29.35; three or
    five rings on seed 0: 20.73 / 20.72 (a local optimum: four cells balanced at
    20.72 deg, also without area band or limits); patches without the nodes of
    floored (anisotropic input) cells: no gain (mean 22.54); without the nodes
    of well-shaped input cells (``floors.keep``): mixed 23.06.
    Table 5 ablation (improvement over Laplacian, %, f1 / f2 / f3, seeds 0-9,
    before stage 5; literal 14.3 / 12.2 / 6.0, default 10.0 / 8.2 / 2.2 at a
    mean minimum angle of 29.6 deg): stage 4 off 11.2 / 9.8 / 3.1 (14.3 deg);
    stage 2 off (acceptance at 0 deg) 9.7 / 8.1 / 2.9; the well-shaped-input
    rule off 12.2 / 10.3 / 4.2 (29.3 deg); opt_fraction 0.02 9.6 / 8.8 / 2.5,
    0.10 7.2 / 6.4 / 1.4; area limits off 9.3 / 7.5 / 1.7; area band off
    8.6 / 7.6 / 0.9; band 0.9 9.8 / 8.3 / 1.8; resume off 9.8 / 8.1 / 2.0;
    nearest off 9.8 / 8.1 / 2.2; opt_below_quad 40: 10.1 / 8.4 / 2.6;
    2 optimization steps 9.2 / 7.8 / 2.3.  No single stage closes the gap:
    even without stage 4 the guarded choice (stages 1-3) stays 3 points
    below the literal rule on f1.  With stage 5 (committed): 8.8 / 7.8 / 1.9
    at 31.95 deg (seeds 0-9; stage 4 off as well: 10.8 / 9.2 / 2.6, 27.2).

    Size uniformity (issue 12).  Without stage 4 the default's area ratio on
    the paper-style triangle meshes is the literal rule's (12.9 / 12.2 / 12.8
    against 12.9 / 11.6 / 12.5, seeds 0-2); the loss came from the
    optimization alone: its 0.8 band is relative to the position it starts
    from, so a cell the worst nodes keep shrinking loses up to 20 % a pass
    (seed 0: smallest cell 1.06 against the literal rule's 2.18, the ratio
    rising from 19 after pass 3 to 25.5).  The worst nodes are mostly the
    rings of valence-3 nodes (three triangles: one angle >= 120 deg, so a
    smallest angle <= 30 deg whatever is done), optimized every pass.  The
    mesh-wide area limits stop the compounding: area ratio 25.5 / 16.3 /
    12.1 -> 15.1 / 9.8 / 11.4; but alone (5 %, 3 steps) they cost the
    minimum angle (paper-style triangles 24.8 -> 23.7 deg), which a fourth
    step and the stage 2 rule give back (24.8 deg, area ratio 0.97 / 0.80 /
    0.91 x literal).

    The well-shaped-input rule away from triangles (issue 12, size
    uniformity; Table 5 improvement over Laplacian f1 / f2 / f3 %, seeds
    0-9, paper-style quads' mean minimum angle): at every node 9.9 / 8.2 /
    2.4 at 31.9 deg, near triangles only (kept) 13.0 / 10.5 / 3.9 at 32.3
    deg (literal 14.3 / 12.2 / 6.0 at 4.9), other paper-style meshes
    unchanged.  At the nodes with a triangle only: the same on quads, mixed
    24.87 -> 25.05 deg, but a boundary layer (matrix seed 1) 103.9 -> 113.0
    deg maximum angle (near triangles: 106.5, every node: 106.7); and the
    stretched-quad part (1.5, 3, 4 x) at quad-only nodes too: 10.3, 11.6,
    12.3 on f1, boundary layers 106 / 119 / 115 deg (matrix mean).  Not kept (they cost minimum angle): stage 4's
    largest incident cell growing at most 1/0.95 (1/0.9) instead of 1/0.8 at
    quad-only nodes: 13.8 / 11.3 / 5.0 (13.2 / 10.7 / 5.3) at 31.5 (31.8)
    deg; at every node: triangles 24.85 -> 24.45, graded 20.4 -> 19.8; no
    growth: 14.2 / 11.9 / 5.7 at 29.5 deg; a cap of 1.5 / 2 / 3 x the mean
    cell area at quad-only nodes: 14.0 / 13.1 / 11.8 on f1 at 30.4 / 31.6 /
    32.5 deg; resume off, ``opt_below_quad`` 45 / 40, 6 / 3 steps,
    ``opt_fraction`` 0.03 / 0.02, 4 / 16 patches, ``resume_above`` 30 / 0:
    12.6, 13.0 / 12.9, 12.2 / 13.1, 12.7 / 13.5, 12.2 / 12.4, 11.6 / 11.4
    on f1 (31.0-32.5 deg; the 13.1 and 13.5 at 31.4 and 31.0).
    Without stages 4 and 5 as well the guarded choice is the literal rule's
    (14.4 / 12.3 / 5.8) at 14.5 deg: the rest of the gap is the optimization.

    Why not "take A only if it is no worse than staying" (the former
    default): that monotone acceptance is a local trap.  A sheared quad grid
    gets better only through positions that are locally worse for a moment,
    so jittered structured quad grids stopped at 48-59 deg where Laplacian
    and the literal rule reach 90 deg, and on gmsh quad meshes the default
    ended below Laplacian.  Thresholds are absolute angles for acceptance
    (20 deg for quad nodes too: 30 deg, a third of the quad's ideal, raised
    the paper-style mixed meshes' area ratio from 20 to 38 for 2 deg of
    minimum angle on quads) and relative to the ideal angle for the
    optimization (quad nodes: 60 instead of 40 deg, +2 deg minimum angle on
    jittered toothed and recombined gmsh quad meshes).  Measured alternatives
    that did not pay (10 passes, 3 seeds each):
    choosing between A and L for every node by local quality (paper-style
    tri area ratio 24.6, recombined quads no better), a quad corner score
    normalized to the triangle scale (``(1 + |cos|) / 2``: -4 deg on the
    toothed quad meshes), an area band relative to the node's mean cell area
    (factor 0.5: -1.7 deg on paper-style triangles, -3.3 on paper-style
    mixed meshes; 0.7: -11 deg on the toothed quads), an area band of 0.85
    or 0.9 (area ratio of paper-style triangle meshes 13 / 12 instead of 17,
    but graded meshes 16.7 / 13.7 instead of 18.4 deg), fewer optimization
    steps or nodes (-1 to -3 deg), three more optimization steps for the
    nodes still below 20 deg (+0.3 to +1 deg, not worth its cost).
    Measured for size uniformity (issue 12; mean minimum angle over seeds 0-2
    of paper-style triangles / mixed / graded, area ratio per seed x the
    literal rule's): with the area limits, 10 % and 3 steps 25.5 deg but
    1.49 x on seed 0; 5 % and 6 steps 25.1 deg but 1.57 x; 7 % 24.5 / 22.1 /
    19.0; 10 % and 4 steps 25.3 / 23.4 / 18.6 (with the stage 2 rule
    24.7 / 23.2 / 19.1, but the paper-style quads' mean Table 5 error over
    seeds 0-9 is 6.3 % below Laplacian's where the former default's was
    8.4 %: kept 5 % and 4 steps, 24.8 / 22.4 / 18.4 and 9.0 %; on seeds 3-5
    10 % is 1 deg better on triangles and graded meshes, 0.6 on mixed ones); ``opt_below`` 30: no
    change; acceptance at 25 deg: 1.38 x; at 15 deg: graded 16.8 deg.  Limits
    at the 0.5-2 % area quantiles instead of the extremes: graded 17.1-18.2,
    triangles 21.6-24.2 deg; limits 1.1 or 1.25 x inside the extremes:
    triangles 23.8 / 22.5 deg (up to 1.65 x with 6 steps).  The band
    relative to the areas at A instead of the start: graded 13.4-15 deg;
    relative to the pass-start position: triangles 23.7 deg, up to 1.41 x.
    Moving valence-3 nodes to the incentre of their ring (the exact max-min
    optimum of their three triangles): mixed -0.6 to -2.7 deg.  Stage 2
    nearest A instead of the best score (kept): paper-style quads +2.7 deg,
    graded +0.5, triangles -0.7, mixed -0.2 (seeds 3-5: within 0.3 deg, quads +1.4),
    triangles' area ratio 13.4 -> 12.7; letting the nodes of well-shaped
    input cells take it too: already-good triangles' maximum angle worse
    than the input's, boundary-layer maximum 130 deg against Laplacian's
    120.  Table 5's surface error (``L2 f1``) follows the optimization:
    without stage 4 it is within 0.1 % of the literal rule's on the gmsh
    quads, with it 0.6-1 % above (paper-style quads 1.6 %: 1.284 against 1.264).
    Toward the repaired ``optimization``'s 50.6 deg on the distorted toothed
    quads (the default: 50.4): 5 steps, ``opt_below_quad`` 70, 8 % of the
    nodes, quad acceptance at 25 deg all end at 50.1-50.4 deg (5 steps: 38.0
    on one family); it has pair moves the default lacks.

    Maximum angle of boundary layers (issue 12).  gmsh boundary-layer meshes
    (input maximum 104-109 deg) ended at 109-125 deg (seeds 0-5: 109.4,
    122.3, 109.9, 119.1, 109.8, 124.9; Laplacian 107.7-121.4), every time
    an outer layer quad at a tri-quad node sheared by stage 4 (without it:
    102-108 deg).  Counting such quad corners on the triangles' scale
    (``-(1 + |cos|) / 2``, ``d`` like ``2 d / 3``) at every tri-quad node:
    109.8, 115.9, 109.9, 110.8, 107.9, 112.6 deg, but paper-style mixed
    meshes' mean minimum angle (seeds 0-5) 20.5 -> 18.2 deg; the stricter
    ``q - 30`` at every tri-quad node: boundary layers 105.4-110.8 deg,
    paper-style mixed 11.8 deg; at the nodes of well-shaped input cells
    only (kept): ``2 d / 3`` 109.8-115.9 deg, ``q - 30`` 105.4-110.8 deg
    (107.1, 106.7, 105.4, 110.8, 109.8, 108.9), minimum angles unchanged
    (39.9-40.7), paper-style mixed 20.5 -> 20.5 deg; no other family has a
    free tri-quad node (the mixed two-region mesh's interface is fixed).

    Toward ``optimization`` on the distorted toothed quads (issue 12): the
    worst cells are boundary quads with two fixed corners, whose free node
    the optimization balanced between two cells (50.59 / 50.59 deg) and the
    default did not (50.19 / 50.99).  Resuming from C (above) at every
    worst node with 4 steps: jittered toothed quads mean minimum 50.36 ->
    50.51 deg; with half / a quarter of the radius 50.58 / 50.58; 8 steps at
    a quarter of it (0.0625) 50.61 (optimization 50.61), but paper-style
    triangles 24.83 -> 24.52 deg with area ratios 1.2-1.8 x, paper-style
    mixed 22.92 -> 22.76 (with the stage 1 test below), paper-style quads
    29.32 -> 27.82 deg; only where C is at least
    45 deg good: paper-style quads unchanged, toothed 50.6107 against
    optimization's 50.6108, paper-style mixed -0.5 deg; at quad-only nodes
    with 12 steps from 0.0625 (kept): toothed 50.6126 / 50.6126 (jittered /
    distorted; optimization 50.6108 / 50.6111), quad-recombined 53.01 ->
    54.02, good quads 53.85 -> 54.33, paper-style quads unchanged, paper-
    style mixed unchanged, but the distorted toothed quads' area ratio 7.4
    -> 10.6 (median; Laplacian 11.2), and with numpy kernels 1.7 x the CPU
    time per pass there (8 steps: 50.6107, short of 50.6108).  Scoring the stage 1 "no worse than
    staying" test of tri-quad nodes of well-shaped input cells with
    ``strict_quad`` too: boundary layers (seeds 0-5) 103.7-106.4 deg and
    paper-style mixed 22.39 -> 22.92 deg (seeds 0-2), but the paper-style
    mixed seed 5 area ratio 28.6 -> 54.4 (literal 28.5) and thicker layers
    (0.1 instead of 0.06) 105.9-115.1 -> 113.5-118.9 deg; scoring all of
    stages 1-2 of those nodes with it: paper-style mixed 22.39 -> 15.29 deg.

    Guarantees: no cell is ever inverted, made degenerate or (a quad) made
    non-convex, and an already invalid neighbourhood never gets more invalid
    cells (every candidate is checked exactly, and C is one of them); with
    the driver's input floors no anisotropic cell shrinks below a quarter of
    its input area or edge length.  *Not* guaranteed any more: that the
    local minimum angle of a node never decreases, hence that the mesh's
    minimum angle never decreases from one pass to the next (stages 1 and 3
    may lower it on the way out of a trap; the nodes of well-shaped input
    cells keep the monotone rule).  Figures: the quality matrix in README
    and ``benchmarks/quality_matrix.py``.

>>> import numpy as np
>>> from anglesmooth.generate import structured_triangles
>>> from anglesmooth.topology import build_topology
>>> m = structured_triangles(6, 6)
>>> topo = build_topology(m)
>>> p = m.points.copy(); i = topo.free_nodes[0]; p[i] += 0.2
>>> for _ in range(100):
...     p = step(p, topo, guard=False).points
>>> bool(np.allclose(p, m.points, atol=1e-6))   # the displaced node returns
True
"""

from __future__ import annotations

import numpy as np

from ..topology import Topology, signed_areas
from . import _fast, _fastcalls
from ._blocks import StepResult, run_blocks
from ._floors import Floors
from ._local import _COMPASS, INVALID, angle_target, first_valid, geometry, laplacian_target, local_scale, optimize
from ._patch import patch_moves

__all__ = ["step"]


def _per_node(topo: Topology, blk, tri_deg: float, quad_deg: float) -> np.ndarray:
    """Score threshold of each block node: ``tri_deg`` for nodes of triangles only, ``quad_deg`` for nodes of a quad.

    Thresholds relative to the ideal angle (60 deg for triangles, 90 for quads) mean the same for
    both; a node with both kinds of cell uses the quad's (its quad corners are the ones judged on
    ``min(angle, 180 - angle)``).  Cached per block (topology only).
    """
    key = ("angle-thresholds", blk.nodes.start, blk.nodes.stop, float(tri_deg), float(quad_deg))
    hit = topo._cache.get(key)
    if hit is None:
        hasq = np.bincount(topo.quad_loc[blk.quads] - blk.nodes.start, minlength=blk.size) > 0
        lo, hi = -np.cos(np.radians(tri_deg)), -np.cos(np.radians(quad_deg))
        hit = topo._cache[key] = np.where(hasq, hi, lo)
    return hit


def _quads_only(topo: Topology, blk) -> np.ndarray:
    """Per block node: it has no triangle (cached per block, topology only)."""
    key = ("angle-quads-only", blk.nodes.start, blk.nodes.stop)
    hit = topo._cache.get(key)
    if hit is None:
        hit = topo._cache[key] = np.bincount(topo.tri_loc[blk.tris] - blk.nodes.start, minlength=blk.size) == 0
    return hit


def step(
    points: np.ndarray,
    topo: Topology,
    /,
    *,
    guard: bool = True,
    order: str = "colour",
    hybrid: bool = True,
    opt_fraction: float = 0.05,
    opt_iterations: int = 4,
    area_band: float | None = 0.8,
    area_limits: bool = True,
    opt_below: float = 40.0,
    opt_below_quad: float = 60.0,
    accept_above: float = 20.0,
    accept_above_quad: float = 20.0,
    nearest: bool = True,
    strict_quads: bool = True,
    resume_iterations: int = 12,
    resume_radius: float = 0.0625,
    resume_above: float = 45.0,
    patch_cells: int = 8,
    patch_below: float = 30.0,
    patch_iterations: int = 15,
    floors: Floors | None = None,
) -> StepResult:
    """One angle-based pass.

    Parameters
    ----------
    guard : bool
        False: the paper's literal rule.  True (default): the robust variant
        described in the module docstring.
    hybrid : bool
        With ``guard``: choose among candidates and optimize the worst nodes
        (default).  False: only halve/refuse moves that would invalidate a cell.
    accept_above, accept_above_quad : float
        A node takes its angle position when the local quality there (its
        incident cells' smallest angle; quad corners ``min(angle, 180 - angle)``)
        is at least this many degrees -- ``accept_above`` for a node of
        triangles only, ``accept_above_quad`` for a node of a quad: a third of
        the ideal angle (60, 90) for both.  Below it, the node chooses among
        five candidates.  180 makes every node choose.
    resume_iterations, resume_radius, resume_above : int, float, float
        Stage 4 at a node of quads only that scores higher staying than at its
        stage 1-2 choice and at least ``resume_above`` degrees there: that many
        steps from the current position, from this radius (times the mean edge
        length).  0 iterations: every worst node starts from its choice.
    strict_quads : bool
        In the optimization, nodes of well-shaped input cells (``floors.keep``)
        that have both triangles and quads score a quad corner ``q`` (``min(angle,
        180 - angle)``) like a triangle corner of ``q - 30`` (default; see the
        module docstring).  False: ``q``, as everywhere else.
    nearest : bool
        In that choice, take the candidate nearest the angle position among
        those whose local quality is at least the acceptance threshold (else
        the best; nodes of well-shaped input cells always take the best).
        False: always the best (the former rule).
    opt_fraction, opt_iterations, opt_below, opt_below_quad : float, int, float, float
        Share of each colour class that gets local optimization, its number of
        steps, and the local quality (degrees; triangle-only nodes / quad nodes,
        two thirds of the ideal angle) a node must be below to get it:
        optimizing nodes that are already good only moves them along plateaus
        of the max-min objective and keeps a disturbed regular mesh from
        returning to its place.
    patch_cells, patch_below : int, float
        Stage 5: after the pass, the free nodes within two rings of each of the ``patch_cells`` worst
        cells below ``patch_below`` degrees move together (see :mod:`._patch`); 0 cells: off.
        ``patch_iterations`` ascent steps per patch and pass (15: the 30 of the first version cost
        1.7x the time for no better minimum angle: paper-style mixed 25.27 / triangles 26.79 / graded
        20.61 deg with 30, 25.34 / 27.37 / 20.69 with 15; 10 steps: mixed 23.97, seed 0 16.2).
    floors : :class:`._floors.Floors` or None
        Input floors of the guard (see :func:`._floors.input_floors`; the
        driver passes them).
    area_band : float or None
        During that optimization a node's smallest incident cell keeps at least
        ``area_band`` of its area and its largest grows at most ``1/area_band``
        (see :func:`._local.optimize`); None lets the angle alone decide.
    area_limits : bool
        With ``area_band``: nor may that optimization take a node's smallest
        incident cell below the smallest cell area of the mesh at the start of
        the pass, or its largest above the largest (unless the cell already
        was): the optimization never widens the mesh's area range, so the
        band's per-step 0.8 cannot compound over passes into the
        size-uniformity loss of a mesh-wide sliver (paper-style triangle
        meshes: area ratio 25.5 -> 13.4 against the literal rule's 12.9).
    """

    fast = guard and hybrid and _fast.active(topo)
    limits = None
    if guard and hybrid and opt_iterations > 0 and area_band is not None and area_limits:
        if fast:  # the same two numbers, one compiled loop
            limits = _fastcalls.area_limits(points, topo)
        else:
            areas = signed_areas(points, topo.tri, topo.quad)
            if areas.size:
                limits = (float(areas.min()), float(areas.max()))

    any_keep = floors is not None and bool(floors.keep.any())  # once per pass, not per colour class

    def choose(pts, blk, cur, geom):
        """Stages 1 and 2: (positions, their local scores, number of invalid angle positions, None or the
        nodes whose score is ``inf`` instead: certainly not below the optimization threshold)."""
        good = _per_node(topo, blk, accept_above, accept_above_quad)
        keep = None
        if floors is not None:
            keep = floors.keep[blk.nodes]
            keep = keep if keep.any() else None
        if fast:  # the same choice, fused per node in a compiled loop
            # nodes certainly above every optimization threshold of the block need no exact score (the
            # highest: a mixed block orders its triangle and quad nodes together)
            certify = None
            if opt_iterations > 0 and not (floors is not None and floors.active):
                below = _per_node(topo, blk, opt_below, opt_below_quad)
                certify = np.full(blk.size, below.max() if below.size else -np.inf)
            new, best, refused, lazy = _fastcalls.angle_choose(pts, topo, blk, good, floors, keep, nearest, certify)
            return new, best, int(refused.sum()), lazy
        target = angle_target(pts, topo, blk)
        s_a = geom.score(target)
        refused = int((s_a <= INVALID + 0.5).sum())
        # stage 1: where the angle position is good enough, take it (even when staying scores higher;
        # nodes whose input cells were all well shaped only when it is no worse than staying)
        new, best = target, s_a
        take = s_a >= good
        if keep is not None:
            k = np.flatnonzero(keep & take)
            if k.size:
                take[k] = s_a[k] >= geom.restrict(k).score(cur[k])
        rest = np.flatnonzero(~take)
        if rest.size:
            # stage 2: the others choose among all five candidates (the first best wins)
            lap = laplacian_target(pts, topo, blk)[rest]
            t, c = target[rest], cur[rest]
            sub = geom if rest.size == blk.size else geom.restrict(rest)
            extra = np.stack([lap, 0.5 * (t + lap), 0.5 * (t + c), c])
            s = np.concatenate([s_a[None, rest], sub.score(extra)])
            cands = np.concatenate([t[None], extra])
            k = np.argmax(s, axis=0)
            if nearest:
                # the candidate nearest A among those good enough (not A itself: it was not taken,
                # nor for the nodes of well-shaped input cells, which keep the best)
                dx, dy = cands[1:, :, 0] - t[None, :, 0], cands[1:, :, 1] - t[None, :, 1]
                ok = s[1:] >= good[rest][None]
                if keep is not None:
                    ok &= ~keep[rest][None]
                near = 1 + np.argmin(np.where(ok, dx * dx + dy * dy, np.inf), axis=0)
                k = np.where(ok.any(axis=0), near, k)
            idx = np.arange(rest.size)
            new, best = target.copy(), s_a.copy()
            new[rest], best[rest] = cands[k, idx], s[k, idx]
            # stage 3: where every move (full or half) is invalid and staying is not, the guarded
            # Laplacian move (halved until valid): the way out of a flattened cell whose free
            # corners block each other
            stuck = np.flatnonzero((s[:4] <= INVALID + 0.5).all(axis=0) & (s[4] > INVALID + 0.5))
            if stuck.size:
                g3 = sub.restrict(stuck)
                x, _ = first_valid(g3, c[stuck], lap[stuck])
                new[rest[stuck]], best[rest[stuck]] = x, g3.score(x)
        return new, best, refused, None

    def update(pts, blk, cur):
        if not guard:
            return angle_target(pts, topo, blk), 0
        geom = geometry(pts, topo, blk, floors)
        if not hybrid:
            new, refused = first_valid(geom, cur, angle_target(pts, topo, blk))
            return new, refused.sum()
        new, best, refused, lazy = choose(pts, blk, cur, geom)
        idx = np.arange(blk.size)
        n_opt = int(np.ceil(opt_fraction * blk.size)) if opt_iterations > 0 else 0
        if n_opt:
            below = _per_node(topo, blk, opt_below, opt_below_quad)
            if lazy is not None and n_opt < blk.size and lazy.any() and (best < below).sum() > n_opt:
                v = np.partition(best, [n_opt - 1, n_opt])
                if v[n_opt - 1] == v[n_opt]:  # a tie where argpartition cuts: its pick depends on every score
                    z = np.flatnonzero(lazy)
                    best[z] = geom.restrict(z).score(new[z])
            worst = np.argpartition(best, n_opt - 1)[:n_opt] if n_opt < blk.size else idx
            worst = np.sort(worst[best[worst] < below[worst]])
        if n_opt and worst.size:
            strict = None
            if strict_quads and any_keep:
                strict = floors.keep[blk.nodes][worst]
            if fast:  # the same search, one compiled loop (scale, resume test, compass) per node
                new[worst], _ = _fastcalls.angle_optimize(
                    pts, topo, blk, worst, new[worst], best[worst], opt_iterations, 0.25, area_band, _COMPASS, limits,
                    strict, floors, resume_iterations, resume_radius, -np.cos(np.radians(resume_above)))
                return new, refused
            sub = geom.restrict(worst)
            scale = local_scale(pts, topo, blk, subset=worst)
            start, its, rad = new[worst], opt_iterations, 0.25
            if resume_iterations > 0:
                # a quad node that scores higher staying (optimized in the previous pass, pulled back by
                # stages 1-2) and is already good there resumes the search from there, finer and longer
                # (scored at the quad-only nodes alone: the others never resume); one search for all
                # (per-node steps and radii: the numbers of two separate searches)
                q = np.flatnonzero(_quads_only(topo, blk)[worst])
                if q.size:
                    s_c = (sub if q.size == worst.size else sub.restrict(q)).score(cur[worst[q]])
                    b = q[(s_c > best[worst[q]]) & (s_c >= -np.cos(np.radians(resume_above)))]
                    if b.size:
                        start[b] = cur[worst[b]]
                        its, rad = np.full(worst.size, opt_iterations), np.full(worst.size, 0.25)
                        its[b], rad[b] = resume_iterations, resume_radius
            new[worst], _ = optimize(sub, start, scale, its, rad, area_band, limits, strict)
        return new, refused

    res = run_blocks(points, topo, order, update)
    if guard and hybrid and patch_cells > 0:  # stage 5: numpy, on a few nodes, the same for either kernel
        pts = patch_moves(res.points, topo, floors, below=patch_below, cells=patch_cells, iterations=patch_iterations,
                          area_band=area_band,
                          area_limits=limits)
        return StepResult(pts, res.rejected)
    return res
