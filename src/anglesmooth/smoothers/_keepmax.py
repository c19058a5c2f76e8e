"""``keep_max`` in stage 4 of the default ``angle`` (numpy kernels): the compass search again, refusing every
position that opens a corner beyond a cap.

The compass search (:func:`._compass.optimize`) maximizes the smallest angle, which cannot see a node's
widest corner open: at a node of well-shaped input cells (``floors.keep``) whose search result opens a
corner it moves beyond ``max(its widest when staying, the input's widest)``, :func:`._worst.hold` runs the search
again from the same start with :class:`Capped`, a geometry whose scores are ``-inf`` wherever a candidate
opens a corner beyond that cap (the compiled twin: ``_fastkernels._node_compass``'s ``cap``).  Only
those few nodes pay for it.
"""

from __future__ import annotations

import numpy as np

from ._compass import optimize

__all__ = ["Capped", "capped_argmax", "hold_max"]


class Capped:
    """``geom`` (a :class:`._local.BlockGeometry`) whose scores are ``-inf`` where the position ``X`` of a node
    opens a corner it moves (:meth:`._local.BlockGeometry.largest`, ``-cos``) beyond ``cap`` (per node, ``-cos``;
    NaN fails the test too): what :func:`._compass.optimize` (``prune=False``) reads."""

    def __init__(self, geom, cap: np.ndarray):
        self.geom, self.cap, self.n = geom, np.asarray(cap, dtype=np.float64), geom.n

    def _capped(self, X, s):
        X = np.asarray(X, dtype=np.float64)
        flat = X.reshape((-1, self.n, 2))
        wide = np.stack([self.geom.largest(x) for x in flat]).reshape(X.shape[:-1])
        return np.where(wide <= self.cap, s, -np.inf)

    def score(self, X, band=None, strict=None):
        return self._capped(X, self.geom.score(X, band, strict))

    def banded_score(self, X, lo0, hi0, strict=None):
        return self._capped(X, self.geom.banded_score(X, lo0, hi0, strict))

    def area_range(self, X):
        return self.geom.area_range(X)

    def restrict(self, subset: np.ndarray) -> Capped:
        return Capped(self.geom.restrict(subset), self.cap[subset])


def capped_argmax(sub, keep: np.ndarray, cands: np.ndarray, s: np.ndarray, cap: float) -> np.ndarray:
    """Stage 2's choice (``np.argmax(s, axis=0)``, the first best) among the candidates ``cands`` (5, n, 2: A, L,
    (A+L)/2, (A+C)/2, C) scored ``s`` (5, n), where a ``keep`` node's candidate but C counts -inf if it opens a
    corner the node moves (``sub.largest``) beyond the widest of them at C and beyond ``cap`` (``-cos``).  The
    largest corners are computed only where they decide: the first best is tested, and where it is refused
    the next one, so most nodes score one or two positions, not five (the same choice)."""
    k = np.argmax(s, axis=0)
    kr = np.flatnonzero(keep & (k != 4))  # (C is always allowed)
    if not kr.size:
        return k
    g = sub.restrict(kr)
    lim = np.maximum(g.largest(cands[4, kr]), cap)
    sc = s[:, kr].copy()
    pick = k[kr]
    todo = np.arange(kr.size)  # the nodes whose first best is not yet known to be allowed
    while todo.size:
        gt = g if todo.size == kr.size else g.restrict(todo)
        bad = ~(gt.largest(cands[pick[todo], kr[todo]]) <= lim[todo])
        todo = todo[bad]
        if not todo.size:
            break
        sc[pick[todo], todo] = -np.inf
        pick[todo] = np.argmax(sc[:, todo], axis=0)
        todo = todo[pick[todo] != 4]
    k[kr] = pick
    return k


def hold_max(sub, held, cur, new, choice, cap, start, scale, its, rad, area_band, limits, strict):
    """Stage 4's results ``new`` (n, 2) of the worst nodes (geometry ``sub``, current positions ``cur``,
    stage 1-2 choices ``choice``), where a ``held`` node's opens a corner it moves beyond ``max(its widest at
    cur, cap)``: the compass search again from its start (``start``, ``scale``, ``its``, ``rad``, ... as
    given to :func:`._compass.optimize`) with every such position refused (:class:`Capped`), else (that
    result beyond it too) the choice.  A new array."""
    new = np.array(new)
    h = np.flatnonzero(held)
    g = sub.restrict(h)
    lim = np.maximum(g.largest(cur[h]), cap)
    back = np.flatnonzero(~(g.largest(new[h]) <= lim))
    if back.size:
        hb = h[back]
        gb = Capped(g.restrict(back), lim[back])
        x, _ = optimize(gb, start[hb], scale[hb], its if np.ndim(its) == 0 else its[hb],
                        rad if np.ndim(rad) == 0 else rad[hb], area_band, limits,
                        None if strict is None else strict[hb], None, prune=False)
        new[hb] = np.where((gb.geom.largest(x) <= gb.cap)[:, None], x, choice[hb])
    return new
