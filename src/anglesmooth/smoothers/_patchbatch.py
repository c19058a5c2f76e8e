"""The lockstep evaluation of stage 5's patches (:mod:`._patchascent`): the corners, cells and floor rows
of every patch of a pass in one set of arrays, so that one call scores every patch's trial steps, bit
for bit each patch's own score (:meth:`._patchascent._Patch.score`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["_Batch"]

_BAND_MIN = 1024  # corners x trial steps below which the batch score takes every corner's arctan2


class _Batch:
    """The corners, cells and floor rows of several patches in one set of arrays (patch after patch),
    so that one evaluation scores every patch's trial steps: :meth:`score` is :meth:`_Patch.score`
    of each patch, the same values bit for bit (per-patch minima and maxima by ``reduceat``)."""

    def __init__(self, patches):
        L = np.array([p.n + p.ext.shape[0] for p in patches])
        C = np.array([p.lv.shape[0] for p in patches])
        nq = np.array([p.nq for p in patches])
        self.off = np.concatenate([[0], np.cumsum(L)])  # local node block of each patch
        self.cst = np.concatenate([[0], np.cumsum(C)])  # corner block
        qst = np.concatenate([[0], np.cumsum(nq)])
        self.lv, self.ln, self.lp = (np.concatenate([getattr(p, a) + o for p, o in zip(patches, self.off)])
                                     for a in ("lv", "ln", "lp"))
        self.quad = np.concatenate([p.quad for p in patches])
        self.any_quad = bool(nq.sum())
        self.tri0 = np.concatenate([c + np.arange(p.ntri) for p, c in zip(patches, self.cst)])
        if self.any_quad:
            self.lq = np.concatenate([p.lq + o for p, o in zip(patches, self.off) if p.nq])
        # the cells' areas patch by patch: its triangles (tri0) then its quads
        self.aord = np.concatenate([np.concatenate([t0 + np.arange(p.ntri), self.tri0.shape[0] + q0 + np.arange(p.nq)])
                                    for p, t0, q0 in zip(patches, np.concatenate([[0], np.cumsum([p.ntri for p in patches])]), qst)])
        self.ast = np.concatenate([[0], np.cumsum([p.ntri + p.nq for p in patches])[:-1]])
        rows = [(i, p.floor) for i, p in enumerate(patches) if p.floor is not None]
        self.floor = None
        if rows:
            fc = np.concatenate([f[0] + self.cst[i] for i, f in rows])
            fq = np.concatenate([f[1] for _, f in rows])
            qc = np.minimum(np.concatenate([f[2] + qst[i] for i, f in rows]), max(int(qst[-1]) - 1, 0))
            fa, f1, f2 = (np.concatenate([f[j] for _, f in rows]) for j in (3, 4, 5))
            # a False column before every patch's rows, so that every reduceat segment is non-empty
            cnt = np.zeros(len(patches), np.intp)
            cnt[[i for i, _ in rows]] = [f[0].shape[0] for _, f in rows]
            fst = np.concatenate([[0], np.cumsum(cnt + 1)[:-1]])
            pos = np.concatenate([fst[i] + 1 + np.arange(f[0].shape[0]) for i, f in rows])
            self.floor = (fc, fq, qc, fa, f1, f2, pos, fst, int(cnt.sum()) + len(patches))
        self.cpatch = np.repeat(np.arange(len(patches)), C)  # the patch of every corner
        self.ccount = C  # corners per patch
        self.cst_end = self.cst[1:].tolist()
        self.cst = self.cst[:-1]
        self.crange = [np.arange(a, b) for a, b in zip(self.cst.tolist(), self.cst_end)]  # corners of patch i
        # triangles only: the areas in patch order straight from the cross products (a[:, aord] of 0.5 cr[:, tri0])
        self.a_idx = None if self.any_quad else self.tri0[self.aord]
        self.S = patches[0].S  # one size scale for every patch of a pass

    def score(self, Y, lo, hi):
        """(K, patches) minimum corner quality at Y (K, all local nodes, 2), -inf where a patch is invalid
        or breaks a limit; and the corners (:meth:`score_planes`)."""
        return self.score_planes(np.ascontiguousarray(Y[..., 0].T), np.ascontiguousarray(Y[..., 1].T), lo, hi)

    def score_planes(self, XT, ZT, lo, hi):
        """:meth:`score` at the local positions' x and y planes XT, ZT (all local nodes, K; C-contiguous):
        (K, patches) and the corners (cross, dot, (ux, uy), (wx, wy), areas), each (corners or cells, K).

        Node-major planes: every gather takes whole rows of K trial steps (a gather along the trial axis
        copied one number at a time: most of a score's cost); the same operations on every element."""
        vx, vy = XT.take(self.lv, axis=0), ZT.take(self.lv, axis=0)
        ux, uy = XT.take(self.ln, axis=0), ZT.take(self.ln, axis=0)
        wx, wy = XT.take(self.lp, axis=0), ZT.take(self.lp, axis=0)
        ux -= vx
        uy -= vy
        wx -= vx
        wy -= vy
        cr = ux * wy - uy * wx
        dot = ux * wx + uy * wy
        q = self._band_quality(cr, dot)
        ok = np.minimum.reduceat(cr, self.cst, axis=0) > 0  # (cr > 0).all() per patch, NaN included
        if self.any_quad:
            a = 0.5 * cr.take(self.tri0, axis=0)
            cx, cz = XT.take(self.lq, axis=0), ZT.take(self.lq, axis=0)  # (quads, 4, K)
            d02x, d02y, d13x, d13y = cx[:, 2] - cx[:, 0], cz[:, 2] - cz[:, 0], cx[:, 3] - cx[:, 1], cz[:, 3] - cz[:, 1]
            q2 = d02x * d13y - d02y * d13x  # _area2's diagonal formula
            a = np.concatenate([a, 0.5 * q2], axis=0).take(self.aord, axis=0)
        else:
            a = 0.5 * cr.take(self.a_idx, axis=0)
        amin = np.minimum.reduceat(a, self.ast, axis=0)
        ok &= (amin >= np.reshape(lo, (-1, 1))) & (np.maximum.reduceat(a, self.ast, axis=0) <= np.reshape(hi, (-1, 1)))
        if self.floor is not None:
            fc, fq, qc, fa, f1, f2, pos, fst, width = self.floor
            a2 = cr.take(fc, axis=0)
            if self.any_quad:
                a2 = np.where(fq[:, None], q2.take(qc, axis=0), a2)
            e1 = np.hypot(ux.take(fc, axis=0), uy.take(fc, axis=0))
            e2 = np.hypot(wx.take(fc, axis=0), wy.take(fc, axis=0))
            bad = np.zeros((width, XT.shape[1]), bool)
            bad[pos] = ~((a2 >= fa[:, None]) & (e1 >= f1[:, None]) & (e2 >= f2[:, None]))
            ok &= ~np.logical_or.reduceat(bad, fst, axis=0)
        f = np.minimum.reduceat(q, self.cst, axis=0)
        if self.S is not None:
            f = np.minimum(f, self.S * amin)
        return np.where(ok, f, -np.inf).T, (cr, dot, (ux, uy), (wx, wy), a)

    @staticmethod
    def finite(pm) -> bool:
        """Every patch's largest cotangent finite (so that no p is NaN: ``p >= thr`` is ``~(p < thr)``)."""
        return bool(np.isfinite(np.add.reduce(pm, axis=None)))

    def corner_range(self, i):
        """The corner indices of patch i."""
        return self.crange[i]

    def _band_quality(self, cr, dot):
        """(corners, K): the corners' quality (``_Patch.corners``' ``arctan2`` and quad fold, the same
        bits) where it may be its patch's minimum, +inf elsewhere: the patch's minimum, exactly.

        A corner's quality is a decreasing function of p = dot / cr (its cotangent; quads: |dot| / cr)
        where cr > 0 (elsewhere the patch is invalid and its minimum unused).  Only the corners with p
        within 1e-8 (1 + pmax^2) of their patch's largest p get the arctan2: every other corner's angle
        is above the minimum's by more than 1e-9 radians, far above the round-off of either; a NaN or
        infinite p (or an overflowing pmax^2) keeps every corner of the patch."""
        if cr.size <= _BAND_MIN:  # a few corners: every arctan2 costs less than the band's operations
            return self.quality(cr, dot, (slice(None), None))[0]
        p = dot / cr  # (ascend_all ignores floating-point errors: cr = 0 or an overflow, handled here)
        if self.any_quad:
            p = np.where(self.quad[:, None], np.abs(p), p)
        pm = np.maximum.reduceat(p, self.cst, axis=0)
        thr = pm - 1e-8 * (1.0 + pm * pm)
        tc = thr.repeat(self.ccount, axis=0)  # (thr[cpatch]: each patch's threshold at its corners)
        at = np.flatnonzero(p >= tc if self.finite(pm) else ~(p < tc))  # (flat indices, corner by corner)
        q = np.full(cr.shape, np.inf)
        q.ravel()[at] = self.quality(cr.ravel().take(at), dot.ravel().take(at), at // cr.shape[1])[0]
        return q

    def quality(self, cr, dot, cols):
        """(quality, angle) of corners ``cols`` with cross and dot products cr, dot (``_Patch.corners``)."""
        th = np.arctan2(cr, dot)
        return (np.where(self.quad[cols], np.minimum(th, np.pi - th), th) if self.any_quad else th), th
