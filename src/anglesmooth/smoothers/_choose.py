"""Stages 1-3 of the default ``angle`` pass (:func:`.angle.step`; the stages are documented in :mod:`.angle`).

Per colour block, each node chooses where to go before stage 4 optimizes the worst of them: its angle position
where that is good enough (stage 1), else the nearest good one or the best of five candidates (stage 2), and a
stuck node the guarded Laplacian move (stage 3).  With the compiled kernels the three are one fused loop per
node (``_fastkernels.angle_choose``, via :func:`._fastcalls.angle_choose`); the numpy code below is its twin,
operation for operation.  ``keep_max``'s cap on stage 2's candidates: :func:`._keepmax.capped_argmax`.
"""

from __future__ import annotations

import numpy as np

from . import _fastcalls
from ._keepmax import capped_argmax
from ._local import INVALID, angle_target, first_valid, laplacian_target
from ._nodekinds import _per_node

__all__ = ["chooser"]

#: Most nodes of well-shaped input cells whose stage 1 test shares stage 2's geometry and scores (more: the
#: test's own, where scoring four candidates at each costs more than the calls it saves; about a quarter
#: of a numpy call's overhead a row)
_JOINT_TEST = 256


def chooser(topo, *, fast, floors, s_in, m_in, accept_above, accept_above_quad, nearest, opt_iterations, opt_below,
            opt_below_quad):
    """Stages 1-3 of one pass: ``choose(pts, blk, cur, geom)`` for the block ``blk`` at ``pts`` (current positions
    ``cur``, geometry ``geom``) -> (positions, their local scores, number of invalid angle positions, None or the
    nodes whose score is ``inf`` instead: certainly not below the optimization threshold).  ``fast``: the compiled
    kernel; ``s_in``: ``keep_min``'s input worst (-inf: none); ``m_in``: ``keep_max``'s cap (inf: none); the
    others as given to :func:`.angle.step`.  (Made once a pass: a call per block takes no keyword arguments.)"""

    def choose(pts, blk, cur, geom):
        """Stages 1 and 2: (positions, their local scores, number of invalid angle positions, None or the
        nodes whose score is ``inf`` instead: certainly not below the optimization threshold)."""
        good = _per_node(topo, blk, accept_above, accept_above_quad)
        if good.size and s_in > good.min():  # never accept below the input's worst (a fresh array: cached)
            good = np.maximum(good, s_in)
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
            new, best, refused, lazy = _fastcalls.angle_choose(pts, topo, blk, good, floors, keep, nearest, certify,
                                                               cap=m_in)
            return new, best, int(refused.sum()), lazy
        target = angle_target(pts, topo, blk, cur)  # (cur: run_blocks' gather of the same positions)
        s_a = geom.score(target)
        refused = int((s_a <= INVALID + 0.5).sum())
        # stage 1: where the angle position is good enough, take it (even when staying scores higher;
        # nodes whose input cells were all well shaped only when it is no worse than staying)
        new, best = target, s_a
        take = s_a >= good
        pre = None  # (nodes, their geometry, Laplacian and scores of the four other candidates) if computed
        if keep is not None:
            k = np.flatnonzero(keep & take)
            if 0 < k.size <= _JOINT_TEST:
                # few nodes to test: one geometry, Laplacian and score of the other four candidates for them
                # and the nodes that go to stage 2 anyway (the test needs the score at C, one of the four;
                # a node's numbers are the same on any subset): one restrict and one score call fewer
                u = np.flatnonzero(keep | ~take)  # (k and the others, sorted)
                su = geom if u.size == blk.size else geom.restrict(u)
                t, c = target[u], cur[u]
                lap = laplacian_target(pts, topo, blk, subset=u)
                extra = np.stack([lap, 0.5 * (t + lap), 0.5 * (t + c), c])
                pre = u, su, lap, extra, su.score(extra)
                ik = np.flatnonzero(take[u])  # (k in u)
                # no worse than staying, nor its largest moving corner opened beyond staying's (or 90 deg)
                m_a = su.largest(t)[ik]
                take[k] = (s_a[k] >= pre[4][3, ik]) & ((m_a <= su.largest(c)[ik]) | (m_a <= 0.0))
            elif k.size:
                g = geom.restrict(k)
                # no worse than staying, nor its largest moving corner opened beyond staying's (or 90 deg)
                m_a = g.largest(target[k])
                take[k] = (s_a[k] >= g.score(cur[k])) & ((m_a <= g.largest(cur[k])) | (m_a <= 0.0))
        rest = np.flatnonzero(~take)
        if rest.size:
            # stage 2: the others choose among all five candidates (the first best wins)
            t, c = target[rest], cur[rest]
            if pre is None:
                lap = laplacian_target(pts, topo, blk, subset=rest)
                sub = geom if rest.size == blk.size else geom.restrict(rest)
                extra = np.stack([lap, 0.5 * (t + lap), 0.5 * (t + c), c])
                s4 = sub.score(extra)
            else:  # computed with stage 1's test, on more nodes
                u, su, lap, extra, s4 = pre
                ir = np.searchsorted(u, rest)
                whole = ir.size == u.size
                sub = su if whole else su.restrict(ir) if m_in != np.inf else None  # (capped_argmax's)
                if not whole:
                    lap, extra, s4 = lap[ir], extra[:, ir], s4[:, ir]
            s = np.concatenate([s_a[None, rest], s4])
            cands = np.concatenate([t[None], extra])
            # (keep_max: at the nodes of well-shaped input cells, only the candidates within its cap)
            k = np.argmax(s, 0) if m_in == np.inf or keep is None else capped_argmax(sub, keep[rest], cands, s, m_in)
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
                g3 = sub.restrict(stuck) if pre is None else su.restrict(ir[stuck])
                x, _ = first_valid(g3, c[stuck], lap[stuck])
                new[rest[stuck]], best[rest[stuck]] = x, g3.score(x)
        return new, best, refused, None

    return choose
