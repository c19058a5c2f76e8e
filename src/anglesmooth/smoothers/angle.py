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
       higher -- and at least the input mesh's smallest local score
       (``keep_min``; the driver's :attr:`._floors.Floors.score_min`): "good
       enough" never means worse than the worst the user gave.  This is most
       nodes of a decent mesh, and it is what keeps the paper's size
       uniformity.  Nodes near triangles (a triangle's, or a
       corner of a quad that has one) whose input cells were all well shaped
       (quad corners within 30 deg of a right angle, triangle corners >= 40
       deg, or a stretched well-shaped quad), and nodes among quads only
       whose quads are all within 15 deg of right angles (the inner layers
       of a boundary layer; see :func:`._floors.input_floors`), take it only
       if it is also no worse than staying and opens none of the corners
       the node moves (every corner of its triangles, three of each quad)
       wider than the widest of them when staying, or than a right angle,
       so the good parts of a mesh never get worse: the smallest angle
       alone cannot see a quad beside 40 deg triangles open from 104 to
       112 deg.
    2. *Otherwise the nearest good one, else the best of five*: of the
       Laplacian position L, (A+L)/2, (A+C)/2 and the current position C, the
       one nearest A whose local quality is at least the acceptance
       threshold; where none is, the best of those and A by local quality,
       no candidate with an inverted, degenerate or non-convex cell (C is one
       of them).  Nodes of well-shaped input cells always take the best, of C
       and the candidates that open no corner the node moves wider than the
       widest of them at C and than the input's widest (``keep_max``,
       :attr:`._floors.Floors.largest_max`, at least 90 deg; only where that
       is below ``keep_max_below``, 150 deg, a good input): else the best
       of five took A anyway where stage 1's test refused it (gmsh boundary
       layers around a hole: 103.9 -> 108-116 deg).
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
       from 40 to 44 deg; only where the node still scores at least
       ``strict_above`` (25 deg) at its stage 1-2 choice, else the strict score
       trades a triangle corner for quads that are no longer the input's good
       ones.  That search maximizes another score than the local one, so it
       can lower a node's local score (its triangles traded for its quads):
       where it would end below the input's smallest local score, the node
       keeps its stage 1-2 choice (``keep_min``; gmsh boundary layers around a
       hole went 39.20 -> 38.3-39.1 deg without, see
       ``docs/default_method.md``).  Nor does the search see the widest
       angle: where it opens a corner of a node of well-shaped input cells
       beyond stage 2's cap (``keep_max``), that node searches again from the
       same start refusing every such position (:mod:`._keepmax`), else keeps
       its stage 1-2 choice.  A node of quads only that scores higher
       where it is (C) than at its stage 1-2 choice and is at least
       ``resume_above`` (45 deg) good there -- it was optimized in the previous pass and
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
       Every cell of a patch also counts like a 30 deg corner times its area
       over 0.15 x the input's median cell area, so that the patch grows a
       sliver rather than shrinking its neighbours (size uniformity).

    Every alternative measured while building these stages (stage 5's
    patch sizes and solvers, the Table 5 ablations, size uniformity, the
    boundary layers' maximum angle, the toothed quads), with its figures:
    ``docs/default_method.md``.

    Guarantees: no cell is ever inverted, made degenerate or (a quad) made
    non-convex, and an already invalid neighbourhood never gets more invalid
    cells (every candidate is checked exactly, and C is one of them); with
    the driver's input floors no anisotropic cell shrinks below a quarter of
    its input area or edge length.  With the driver's floors
    (``keep_min``), the mesh's smallest local score over its free nodes
    (smallest angle; quad corners ``min(angle, 180 - angle)``) never falls
    below the input's: stages 1-2 accept nothing below it (C, one of the
    five, is never below it), stage 4 starts from that choice and either
    climbs its own local score or, strict, is held at the input's, and
    stage 5 never lowers a patch's minimum.  Two exceptions: stage 3 (every
    move of a node invalid, a flattened cell; it fired only on inputs with
    invalid or nearly flat cells in the quality matrix) and stage 5's size
    term, which may trade a corner for a small cell's area in a patch of
    cells below ``patch_below`` (30 deg), so only on inputs worse than
    that.  With ``keep_max`` (an input widest below 150 deg) a node of
    well-shaped input cells opens no corner it moves wider than the widest
    of them before its move and than the input's widest (or 90 deg), in
    stages 1, 2 and 4 (stage 5 does not move it).  *Not*
    guaranteed: that the local minimum angle of a node never
    decreases, nor the mesh's minimum from one pass to the next (stage 1
    takes positions above the input's minimum but below the node's current
    score; the nodes of well-shaped input cells keep the monotone rule).
    Figures: the quality matrix in README and
    ``benchmarks/quality_matrix.py``.

Where the code is: :func:`step` (this module) runs the pass block by block;
stages 1-3 are :func:`._choose.chooser`, stage 4
:func:`._worst.worst_optimizer` (its holds, ``keep_max`` then ``keep_min``:
:func:`._worst.hold`), stage 5 :mod:`._patch`; their compiled twins are
``_fastkernels.angle_choose`` and ``angle_optimize`` (the search and both
holds, in the same order).

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
from ._blocks import StepResult, run_blocks, with_area_range
from ._choose import chooser
from ._floors import Floors
from ._local import angle_target, first_valid, geometry
from ._patch import patch_moves
from ._worst import worst_optimizer

__all__ = ["step"]


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
    strict_above: float | None = 25.0,
    resume_iterations: int = 12,
    resume_radius: float = 0.0625,
    resume_above: float = 45.0,
    patch_cells: int = 8,
    patch_below: float = 30.0,
    patch_iterations: int = 15,
    keep_min: bool = True,
    keep_max: bool = True,
    keep_max_below: float = 150.0,
    floors: Floors | None = None,
    area_range: tuple[float, float] | None = None,
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
    strict_above : float or None
        Only those of them whose local score at their stage 1-2 choice is at least this many degrees
        (25): where it is lower their quads are no longer the input's good ones, and the strict score
        would trade the node's smallest triangle corner for a quad corner the mesh's minimum angle
        does not see (paper-style mixed mesh seed 9: 22.5 -> 16.8 deg in one step).  None: all of them.
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
    keep_min : bool
        No move below the input mesh's smallest local score (``floors.score_min``, the input's worst
        local score over its free nodes): stages 1-2 accept at ``max(accept_above[_quad], that)``, so
        that "good enough" never means worse than the worst cell the user gave, and a node whose
        strict stage-4 search (``strict_quads``) ends below it keeps its stage 1-2 choice (see the
        module docstring).  Off without ``floors`` (a library call that passes none: no input to
        compare with; the driver always passes them) and where an input cell of a free node is
        invalid (``score_min`` -inf).
    keep_max : bool
        At nodes of well-shaped input cells (``floors.keep``), stage 2 takes no candidate but C that opens
        a corner the node moves wider than ``max(its widest at C, floors.largest_max, 90 deg)``, and a
        stage-4 result that does searches again with such positions refused (else the stage 1-2 choice);
        see the module docstring.  Only where the input's widest corner is below ``keep_max_below`` (150
        deg; paper-style mixed seed 27, input 169.7: 28.00 -> 27.11 deg with it), with ``floors``.
    floors : :class:`._floors.Floors` or None
        Input floors of the guard (see :func:`._floors.input_floors`; the
        driver passes them).
    area_range : (float, float) or None
        The smallest and largest signed cell area at ``points``, if the caller has them: the
        previous pass's ``StepResult.area_range`` (the compiled kernels' default pass gives it, from
        stage 5's screen, which reads every cell anyway), so that this pass need not read every cell
        for ``area_limits``; None: computed here.  The same numbers either way.
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
        if area_range is not None:  # the previous pass's (the same numbers)
            limits = (float(area_range[0]), float(area_range[1]))
        elif fast:  # the same two numbers, one compiled loop
            limits = _fastcalls.area_limits(points, topo)
        else:
            areas = signed_areas(points, topo.tri, topo.quad)
            if areas.size:
                limits = (float(areas.min()), float(areas.max()))

    any_keep = floors is not None and bool(floors.keep.any())  # once per pass, not per colour class
    s_in = floors.score_min if keep_min and floors is not None else -np.inf  # the input's worst local score
    # keep_max: the widest corner (-cos) a node of well-shaped input cells may open beyond its own widest when
    # staying, in stages 2 and 4: the input's widest, and at least a right angle (inf: no such rule)
    m_in = np.inf
    if keep_max and any_keep and floors.largest_max < -np.cos(np.radians(keep_max_below)):
        m_in = max(float(floors.largest_max), 0.0)

    # stages 1-3 (._choose), then stage 4 (._worst): this pass's settings, once
    choose = chooser(topo, fast=fast, floors=floors, s_in=s_in, m_in=m_in, accept_above=accept_above,
                     accept_above_quad=accept_above_quad, nearest=nearest, opt_iterations=opt_iterations,
                     opt_below=opt_below, opt_below_quad=opt_below_quad)
    optimize_worst = worst_optimizer(
        topo, fast=fast, floors=floors, any_keep=any_keep, s_in=s_in, m_in=m_in, limits=limits,
        opt_fraction=opt_fraction, opt_iterations=opt_iterations, opt_below=opt_below, opt_below_quad=opt_below_quad,
        area_band=area_band, strict_quads=strict_quads, strict_above=strict_above,
        resume_iterations=resume_iterations, resume_radius=resume_radius, resume_above=resume_above)

    def update(pts, blk, cur):
        if not guard:
            return angle_target(pts, topo, blk), 0
        geom = geometry(pts, topo, blk, floors)
        if not hybrid:
            new, refused = first_valid(geom, cur, angle_target(pts, topo, blk))
            return new, refused.sum()
        new, best, refused, lazy = choose(pts, blk, cur, geom)
        return optimize_worst(pts, blk, cur, geom, new, best, lazy), refused

    # the literal rule and the compiled default read no current positions (their kernels do)
    res = run_blocks(points, topo, order, update, current=guard and not fast)
    if guard and hybrid and patch_cells > 0:  # stage 5: numpy, on a few nodes, the same for either kernel
        # with the compiled kernels, stage 5's screen reads every cell anyway: it gives the next pass's
        # area range too (1M triangles: ~12 ms a pass of reading the cells again at the next start)
        pts, rng = patch_moves(res.points, topo, floors, below=patch_below, cells=patch_cells,
                               iterations=patch_iterations, area_band=area_band, area_limits=limits,
                               with_range=True, overwrite=True)
        return with_area_range(StepResult(pts, res.rejected), rng)
    return res
