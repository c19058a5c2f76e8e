"""The min-norm point of the convex hull of a few gradients (stage 5's ascent direction,
:mod:`._patchascent`): Wolfe's algorithm, exact, on a few dozen rows.

Every product, dot and solve is one numpy BLAS / LAPACK call on the same values as the plain loop;
only the bookkeeping around them is in Python floats and lists.
"""

from __future__ import annotations

import numpy as np

__all__ = ["_min_norm", "_wolfe"]

_WOLFE_TOL = 1e-12  # the min-norm point is found when no row is below it along itself by this x the largest |row|^2


def _solve_checked(A, b):
    try:
        return np.linalg.solve(A, b)
    except np.linalg.LinAlgError:
        return np.full(b.shape, np.nan)


_solve = _solve_checked
try:  # np.linalg.solve's own kernel without its wrapper (a third of a small solve's time); NaN if singular
    from numpy.linalg._umath_linalg import solve1 as _solve1

    with np.errstate(all="ignore"):  # a private kernel: used only if it still solves as np.linalg.solve
        if np.array_equal(_solve1(np.array([[2.0, 1.0], [1.0, 3.0]]), np.array([3.0, 5.0])),
                          _solve_checked(np.array([[2.0, 1.0], [1.0, 3.0]]), np.array([3.0, 5.0]))):
            _solve = _solve1
except Exception:  # noqa: BLE001 - another numpy layout or signature: the public solve
    pass


def _min_norm(G: np.ndarray, start=()) -> tuple[np.ndarray, list]:
    """The min-norm point of the convex hull of the rows of G (a, d), exactly: Wolfe's algorithm.

    A corral S of rows (affinely independent) holds the current point x = lam @ G[S] (lam > 0,
    sum 1); a major cycle adds the row j that is most negative along x (x . G[j] < x . x, by more
    than :data:`_WOLFE_TOL` times the largest squared row norm: otherwise x is the min-norm point)
    and moves to the affine minimizer of the corral, a minor cycle drops the rows whose weight that
    move would make non-positive (the segment stops where the first one reaches 0).  Everything on
    the Gram matrix M = G G^T; the affine minimizer solves [[M_SS, 1], [1^T, 0]] [mu, nu] = [0, 1].
    Ties by the first index.  ``start``: rows to start from (the corral of the previous ascent step,
    where they are still active), when their affine minimizer is inside their hull; else the
    shortest row.  The min-norm point is unique, so the start only changes the round-off.
    Returns the point and its corral.
    """
    a = G.shape[0]
    if a == 1:
        return G[0].copy(), [0]
    with np.errstate(all="ignore"):  # a singular corral system: NaN, handled below
        return _wolfe(G, a, list(start))


def _rhs(s: int) -> np.ndarray:
    """(s + 1,) the corral system's right-hand side [0, ..., 0, 1] (a view of one cached array)."""
    global _RHS
    if s + 1 > _RHS.shape[0]:
        _RHS = np.zeros(2 * (s + 1))
        _RHS[-1] = 1.0
    return _RHS[-s - 1:]


_RHS = np.zeros(64)
_RHS[-1] = 1.0
_ONES = np.ones((64, 64))


def _ones(s: int) -> np.ndarray:
    """(s, s) ones (a copy of one cached array)."""
    global _ONES
    if s > _ONES.shape[0]:
        _ONES = np.ones((2 * s, 2 * s))
    return _ONES[:s, :s].copy()
_INF = float("inf")
_ZERO_LT = (0.0).__lt__


def _positive(mu) -> bool:
    """``np.isfinite(mu).all() and (mu > 0.0).all()`` of a short vector (in Python floats: no ufunc calls)."""
    x = mu.tolist()
    return all(map(_ZERO_LT, x)) and max(x) < _INF  # (every x > 0: no NaN, so max is the largest)


def _wolfe(G, a, S):
    # the same BLAS / LAPACK calls on the same values as the plain loop (every product, dot and solve
    # below); only the bookkeeping around them is in Python floats and lists (a few rows), the corral's
    # rows also in an index array (``ix[:s]``, then the border row a: ``ix[:s + 1]``), so that no take
    # converts a list
    M = G @ G.T
    B = _ones(a + 1)  # M bordered by ones: the corral's affine system is a submatrix
    B[:a, :a] = M
    B[a, a] = 0.0
    dg = M.diagonal()
    tol = _WOLFE_TOL * float(np.maximum.reduce(dg))
    ix = np.empty(a + 2, np.intp)
    mu = None
    s = len(S)
    if s > 1:
        ix[:s] = S
        ix[s] = a
        c = ix[: s + 1]
        mu = _solve(B.take(c, 0).take(c, 1), _rhs(s))[:-1]
    if mu is not None and _positive(mu):
        lam = mu
        S = list(S)
    else:
        S = [int(dg.argmin())]
        s = 1
        ix[0] = S[0]
        lam = _ONE
    for _ in range(4 * a + 8):
        g = M.take(ix[:s], 1) @ lam
        j = int(g.argmin())
        if j in S or float(lam @ g.take(ix[:s])) - float(g[j]) <= tol:  # (either way: done)
            break
        S.append(j)
        ix[s] = j
        s += 1
        lam = np.concatenate((lam, _ZERO))
        for _ in range(s):  # minor cycles: at most one row dropped each
            ix[s] = a
            c = ix[: s + 1]
            mu = _solve(B.take(c, 0).take(c, 1), _rhs(s))[:s]
            if _positive(mu):
                lam = mu
                break
            if not np.isfinite(mu).all():  # singular (round-off): stop where we are
                return lam @ G.take(ix[:s], 0), S
            neg = np.flatnonzero(mu <= 0.0)
            r = lam[neg] / (lam[neg] - mu[neg])
            i = int(neg[np.argmin(r)])
            lam = lam + float(r.min()) * (mu - lam)
            lam[i] = 0.0
            keep = lam > 0.0
            S = [x for x, k in zip(S, keep.tolist()) if k]
            ix[: len(S)] = ix[:s][keep]
            s = len(S)
            lam = lam[keep]
    return lam @ G.take(ix[:s], 0), S


_ONE = np.ones(1)
_ZERO = np.zeros(1)
