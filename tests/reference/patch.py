"""Reference of stage 5 of the default ``angle`` (``smoothers._patch``, issue 12): the patch moves around the worst
cells, patch by patch with plain loops (Gaussian elimination, the min-norm element of a hull)."""

from __future__ import annotations

import math

import numpy as np

from .geometry import cells_of, neighbours


def _corner_q(p, c, m):
    """(quality, angle, cross, u, w) of corner m of cell c: the angle from u = next - v to w = prev - v."""
    k = len(c)
    v, a, b = p[c[m]], p[c[(m + 1) % k]], p[c[m - 1]]
    u = (a[0] - v[0], a[1] - v[1])
    w = (b[0] - v[0], b[1] - v[1])
    cr = u[0] * w[1] - u[1] * w[0]
    th = math.atan2(cr, u[0] * w[0] + u[1] * w[1])
    return (min(th, math.pi - th) if k == 4 else th), th, cr, u, w


def _ref_solve(A, b):
    """x with A x = b by Gaussian elimination with partial pivoting (None if singular)."""
    n = len(A)
    A = [list(r) + [b[i]] for i, r in enumerate(A)]
    for c in range(n):
        p = max(range(c, n), key=lambda r: abs(A[r][c]))
        if A[p][c] == 0.0:
            return None
        A[c], A[p] = A[p], A[c]
        for r in range(c + 1, n):
            f = A[r][c] / A[c][c]
            for k in range(c, n + 1):
                A[r][k] -= f * A[c][k]
    x = [0.0] * n
    for r in range(n - 1, -1, -1):
        x[r] = (A[r][n] - sum(A[r][k] * x[k] for k in range(r + 1, n))) / A[r][r]
    return x


def _ref_min_norm(G):
    """Wolfe's min-norm point algorithm on the rows of G, on the Gram matrix, ties by the first row."""
    a = len(G)
    if a == 1:
        return list(G[0])
    M = [[sum(x * y for x, y in zip(G[i], G[j])) for j in range(a)] for i in range(a)]
    tol = 1e-12 * max(M[i][i] for i in range(a))
    S = [min(range(a), key=lambda i: M[i][i])]
    lam = [1.0]
    for _ in range(4 * a + 8):
        g = [sum(M[i][s] * l for s, l in zip(S, lam)) for i in range(a)]
        j = min(range(a), key=lambda i: g[i])
        if sum(l * g[s] for s, l in zip(S, lam)) - g[j] <= tol or j in S:
            break
        S, lam = S + [j], lam + [0.0]
        for _ in range(len(S)):
            n = len(S)
            K = [[M[x][y] for y in S] + [1.0] for x in S] + [[1.0] * n + [0.0]]
            mu = _ref_solve(K, [0.0] * n + [1.0])
            if mu is None:
                break
            mu = mu[:n]
            if all(m > 0.0 for m in mu):
                lam = mu
                break
            r, i = min((lam[i] / (lam[i] - mu[i]), i) for i in range(n) if mu[i] <= 0.0)
            lam = [lam[k] + r * (mu[k] - lam[k]) for k in range(n)]
            lam[i] = 0.0
            S, lam = [s for s, l in zip(S, lam) if l > 0.0], [l for l in lam if l > 0.0]
        else:
            continue
        if mu is None:
            break
    return [sum(l * G[s][k] for s, l in zip(S, lam)) for k in range(len(G[0]))]


def reference_patch_moves(points, topo, floors=None, below=30.0, cells=8, rings=2, iterations=30, eps=2.0,
                          area_band=0.8, area_limits=None, size=None):
    """Stage 5 of the default ``angle`` (``smoothers._patch``), patch by patch with plain loops.

    ``size``: every cell of a patch also counts in its minimum as ``S`` x its area, S = below (rad) /
    (size x the input's median cell area, ``floors.area_median``), with the area's gradient in the
    ascent direction's hull (the corners first, then the cells)."""
    S = None
    if size and floors is not None and floors.area_median > 0:
        S = math.radians(below) / (size * floors.area_median)
    p = [tuple(map(float, x)) for x in points]
    allc = cells_of(topo)
    nb = neighbours(allc, len(p))
    inc = [[] for _ in p]
    for ci, c in enumerate(allc):
        for v in c:
            inc[v].append(ci)
    fixed = [bool(f) for f in topo.fixed]
    loc = {int(v): i for i, v in enumerate(topo.free_nodes)}
    qual = []
    for c in allc:
        qs = [_corner_q(p, c, m) for m in range(len(c))]
        qual.append(min(q[0] for q in qs) if all(q[2] > 0 for q in qs) else -1.0)
    cand = sorted((q, ci) for ci, q in enumerate(qual) if q < math.radians(below))
    used = set()
    done = 0
    for _, ci in cand:
        if done >= cells:
            break
        nodes = sorted({v for v in allc[ci] if not fixed[v]})
        if not nodes:
            continue
        for _ in range(rings):
            nodes = sorted(set(nodes) | {j for v in nodes for j in nb[v] if not fixed[j]})
        ids = sorted({c for v in nodes for c in inc[v]})
        done += 1
        if used & set(ids):
            continue
        used |= set(ids)
        pc = [allc[c] for c in ids if len(allc[c]) == 3] + [allc[c] for c in ids if len(allc[c]) == 4]
        corners = [(c, m) for k in (3, 4) for m in range(k) for c in pc if len(c) == k]
        slot = {v: i for i, v in enumerate(nodes)}
        rows = []
        if floors is not None and floors.active:
            for tab, verts, fa, f1, f2 in ((topo.tri_loc, topo.tri_verts, floors.t_area2, floors.t_e1, floors.t_e2),
                                           (topo.quad_loc, topo.quad_verts, floors.q_area2, floors.q_e1, floors.q_e3)):
                for r in range(len(tab)):
                    if int(topo.free_nodes[tab[r]]) in slot and fa[r] > 0:
                        rows.append((list(map(int, verts[r])), float(fa[r]), float(f1[r]), float(f2[r])))

        def area(q, c):
            if len(c) == 3:
                return 0.5 * ((q[c[1]][0] - q[c[0]][0]) * (q[c[2]][1] - q[c[0]][1]) - (q[c[1]][1] - q[c[0]][1]) * (q[c[2]][0] - q[c[0]][0]))
            return 0.5 * ((q[c[2]][0] - q[c[0]][0]) * (q[c[3]][1] - q[c[1]][1]) - (q[c[2]][1] - q[c[0]][1]) * (q[c[3]][0] - q[c[1]][0]))

        a0 = [area(p, c) for c in pc]
        lo0, hi0 = min(a0), max(a0)
        lo, hi = -math.inf, math.inf
        if area_band is not None:
            lo, hi = area_band * lo0, hi0 / area_band
            if area_limits is not None:
                lo, hi = max(lo, min(area_limits[0], lo0)), min(hi, max(area_limits[1], hi0))

        def score(q):
            cs = [_corner_q(q, c, m) for c, m in corners]
            if any(x[2] <= 0 for x in cs):
                return -math.inf
            ar = [area(q, c) for c in pc]
            if min(ar) < lo or max(ar) > hi:
                return -math.inf
            for vv, fa, f1, f2 in rows:
                if 2 * area(q, vv) < fa or math.dist(q[vv[1]], q[vv[0]]) < f1 or math.dist(q[vv[-1]], q[vv[0]]) < f2:
                    return -math.inf
            return min(x[0] for x in cs) if S is None else min(min(x[0] for x in cs), min(S * a for a in ar))

        f0 = score(p)
        if not math.isfinite(f0):
            continue
        h = sum(math.hypot(*_corner_q(p, c, m)[3]) for c, m in corners) / len(corners)
        t, e = 0.1 * h, math.radians(eps)
        for _ in range(iterations):
            cs = [_corner_q(p, c, m) for c, m in corners]
            sz = [] if S is None else [S * area(p, c) for c in pc]
            qmin = min([x[0] for x in cs] + sz)
            G = []
            for (c, m), (qq, th, cr, u, w) in zip(corners, cs):
                if qq > qmin + e:
                    continue
                s = -1.0 if len(c) == 4 and th > math.pi / 2 else 1.0
                k = len(c)
                gp = (-w[1] / (w[0] ** 2 + w[1] ** 2) * s, w[0] / (w[0] ** 2 + w[1] ** 2) * s)
                gn = (u[1] / (u[0] ** 2 + u[1] ** 2) * s, -u[0] / (u[0] ** 2 + u[1] ** 2) * s)
                g = [0.0] * (2 * len(nodes))
                for node, vec in ((c[m - 1], gp), (c[(m + 1) % k], gn), (c[m], (-(gp[0] + gn[0]), -(gp[1] + gn[1])))):
                    if node in slot:
                        g[2 * slot[node]] += vec[0]
                        g[2 * slot[node] + 1] += vec[1]
                G.append(g)
            for c, v in zip(pc, sz):  # the cells' size terms: d(2 area)/d p_i = (y_{i+1} - y_{i-1}, x_{i-1} - x_{i+1})
                if v > qmin + e:
                    continue
                g = [0.0] * (2 * len(nodes))
                for i, node in enumerate(c):
                    if node in slot:
                        nx, pv = p[c[(i + 1) % len(c)]], p[c[i - 1]]
                        g[2 * slot[node]] += 0.5 * S * (nx[1] - pv[1])
                        g[2 * slot[node] + 1] += 0.5 * S * (pv[0] - nx[0])
                G.append(g)
            d = _ref_min_norm(G)
            nd = math.sqrt(sum(x * x for x in d))
            if nd < 1e-12:
                e *= 0.5
                if e < 1e-4:
                    break
                continue
            moved = False
            for j in range(8):
                st = t * 0.5**j
                q = list(p)
                for v, i in slot.items():
                    q[v] = (p[v][0] + st * d[2 * i] / nd, p[v][1] + st * d[2 * i + 1] / nd)
                f = score(q)
                if f > f0 + 1e-10:
                    p, f0, t, moved = q, f, min(2 * st, 0.5 * h), True
                    break
            if not moved:
                e *= 0.5
                t = t * 0.5**7
                if e < 1e-4:
                    break
    return np.array(p)
