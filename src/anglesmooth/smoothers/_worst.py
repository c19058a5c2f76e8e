"""Stage 4 of the default ``angle`` pass (:func:`.angle.step`; the stages are documented in :mod:`.angle`): the local
optimization of the worst nodes of a colour block, and its holds.

After stages 1-3 (:mod:`._choose`), the worst ``opt_fraction`` of the block's nodes below ``opt_below``
(``opt_below_quad`` at a node of a quad) take a few compass-search steps of the local max-min-angle optimization
(:func:`._local.optimize`), from their stage 1-2 choice or, a quad-only node already good where it is, resumed from
there.  Two holds then act on the search's result, in this order: ``keep_max`` (a node of well-shaped input cells
whose result opens a corner beyond its cap searches again with such positions refused, :mod:`._keepmax`, else keeps
its stage 1-2 choice), then ``keep_min`` on that result (a strict node of both kinds of cell that ends below the
input's worst local score keeps its stage 1-2 choice).  Both holds sit at one depth per kernel: with the compiled
kernels the scale, resume test, search, ``keep_max`` and ``keep_min`` are one loop per node
(``_fastkernels.angle_optimize``, via :func:`._fastcalls.angle_optimize`); with numpy, :func:`hold` applies the
two after the search, in the same order with the same numbers.
"""

from __future__ import annotations

import numpy as np

from . import _fastcalls
from ._keepmax import hold_max
from ._local import _COMPASS, local_scale, optimize
from ._nodekinds import _mixed, _per_node, _quads_only

__all__ = ["hold", "worst_optimizer"]


def worst_optimizer(topo, *, fast, floors, any_keep, s_in, m_in, limits, opt_fraction, opt_iterations, opt_below,
                    opt_below_quad, area_band, strict_quads, strict_above, resume_iterations, resume_radius,
                    resume_above):
    """Stage 4 of one pass: ``optimize_worst(pts, blk, cur, geom, new, best, lazy)`` for the block ``blk`` at ``pts``
    (current positions ``cur``, geometry ``geom``) from stages 1-2's positions ``new`` and their scores ``best``
    (``lazy``: None or the nodes whose score is ``inf`` instead, see :func:`._choose.chooser`) -> ``new`` with the
    worst nodes' moves (the same array, written in place).  ``fast``: the compiled kernel; ``any_keep``: some
    node of the mesh has well-shaped input cells; ``s_in``: ``keep_min``'s input worst (-inf: none); ``m_in``:
    ``keep_max``'s cap (inf: none); ``limits``: the mesh's area range or None; the others as given to
    :func:`.angle.step`.  (Made once a pass: a call per block takes no keyword arguments.)"""

    def optimize_worst(pts, blk, cur, geom, new, best, lazy):
        idx = np.arange(blk.size)
        n_opt = int(np.ceil(opt_fraction * blk.size)) if opt_iterations > 0 else 0
        if n_opt:
            below = _per_node(topo, blk, opt_below, opt_below_quad)
            if lazy is not None and n_opt < blk.size and lazy.any() and (best < below).sum() > n_opt:
                v = np.partition(best, [n_opt - 1, n_opt])
                if v[n_opt - 1] == v[n_opt]:  # a tie where argpartition cuts: its pick depends on every score
                    z = np.flatnonzero(lazy)
                    best[z] = geom.restrict(z).score(new[z])
            if not (best < below).any():  # none below its threshold: none of the n_opt worst is (no partition)
                worst = idx[:0]
            else:
                worst = np.argpartition(best, n_opt - 1)[:n_opt] if n_opt < blk.size else idx
                worst = np.sort(worst[best[worst] < below[worst]])
        if n_opt and worst.size:
            strict = None
            if strict_quads and any_keep:
                strict = floors.keep[blk.nodes][worst]
                if strict_above is not None:  # best: the plain score at the stage 1-2 choice, exact here
                    strict = strict & (best[worst] >= -np.cos(np.radians(strict_above)))
            held = floors.keep[blk.nodes][worst] if m_in < np.inf else None  # keep_max's nodes
            if fast:  # the same search, one compiled loop (scale, resume test, compass, keep_max, keep_min) per node
                new[worst], _ = _fastcalls.angle_optimize(
                    pts, topo, blk, worst, new[worst], best[worst], opt_iterations, 0.25, area_band, _COMPASS, limits,
                    strict, floors, resume_iterations, resume_radius, -np.cos(np.radians(resume_above)), held, m_in,
                    s_in)
                return new
            choice = new[worst]  # (a copy) stages 1-2's, where the holds put a node back
            sub = geom.restrict(worst)
            scale = local_scale(pts, topo, blk, subset=worst)
            start, its, rad, s_start = new[worst], opt_iterations, 0.25, best[worst]  # best: exact at new
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
                        start[b], s_start[b] = cur[worst[b]], s_c[np.searchsorted(q, b)]
                        its, rad = np.full(worst.size, opt_iterations), np.full(worst.size, 0.25)
                        its[b], rad[b] = resume_iterations, resume_radius
            new[worst], _ = optimize(sub, start, scale, its, rad, area_band, limits, strict, s_start)
            hold(geom, sub, topo, blk, worst, cur, new, choice, strict, held, s_in, m_in, start, scale, its, rad,
                 area_band, limits)
        return new

    return optimize_worst


def hold(geom, sub, topo, blk, worst, cur, new, choice, strict, held, s_in, m_in, start, scale, its, rad, area_band,
         limits):
    """Stage 4's two holds (numpy kernels) on the search's results ``new[worst]`` (written in place), in the order
    of the compiled ``_fastkernels.angle_optimize``: ``keep_max`` (``held``: its nodes among ``worst``, or None;
    ``m_in``: its cap), then ``keep_min`` on that result (``strict``: the strict nodes among ``worst``, or None;
    ``s_in``: the input's worst local score, -inf: none), so that a capped result below the input's worst keeps
    the stage 1-2 choice ``choice`` too.  ``geom``: the block's geometry, ``sub`` its restriction to ``worst``;
    ``start``, ``scale``, ``its``, ``rad``, ``area_band``, ``limits``: the search's, for keep_max's search again.

    ``keep_max``: a node of well-shaped input cells whose result opens a corner it moves beyond ``max(its widest
    at cur, m_in)`` searches again refusing such positions, else keeps its choice (:func:`._keepmax.hold_max`).
    ``keep_min``: the strict search maximizes another score than the local one (quad corners on the triangles'
    scale), so it may take a node's local score below the input's worst (its triangles traded for its quads);
    there the node keeps its stage 1-2 choice."""
    if held is not None and bool(held.any()):  # keep_max
        new[worst] = hold_max(sub, held, cur[worst], new[worst], choice, m_in, start, scale, its, rad,
                              area_band, limits, strict)
    if strict is not None and s_in > -np.inf:  # keep_min, on keep_max's result
        z = worst[strict & _mixed(topo, blk)[worst]]  # (strict scores differ at nodes with both kinds only)
        if z.size:
            low = geom.restrict(z).score(new[z]) < s_in
            new[z[low]] = choice[np.searchsorted(worst, z[low])]
