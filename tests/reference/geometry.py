"""The shared primitives of the references: cells as Python lists, incidence, corner angles by ``acos``, a
node's local minimum angle and widest moving corner, the Laplacian and angle-based positions (the paper's
rotation, with trigonometry)."""

from __future__ import annotations

import math

import numpy as np


def cells_of(topo):
    """Counter-clockwise cells as Python lists."""
    return [list(map(int, c)) for c in topo.tri] + [list(map(int, c)) for c in topo.quad]


def incident(cells, n):
    inc = [[] for _ in range(n)]
    for c in cells:
        for v in c:
            inc[v].append(c)
    return inc


def neighbours(cells, n):
    nb = [set() for _ in range(n)]
    for c in cells:
        k = len(c)
        for m in range(k):
            a, b = c[m], c[(m + 1) % k]
            nb[a].add(b)
            nb[b].add(a)
    return [sorted(s) for s in nb]


def corner_angle(p, v, prev, nxt):
    """Counter-clockwise angle (radians) at v from (nxt - v) to (prev - v); None if not in (0, pi)."""
    ux, uy = p[nxt][0] - p[v][0], p[nxt][1] - p[v][1]
    wx, wy = p[prev][0] - p[v][0], p[prev][1] - p[v][1]
    cross = ux * wy - uy * wx
    lu, lw = math.hypot(ux, uy), math.hypot(wx, wy)
    if cross <= 0 or lu == 0 or lw == 0:
        return None
    c = max(-1.0, min(1.0, (ux * wx + uy * wy) / (lu * lw)))
    return math.acos(c)


def local_min_angle(p, cells_i):
    """Minimum corner quality over the cells; a negative count of invalid cells if any.

    Corner quality: the angle for triangles, min(angle, pi - angle) for quads.
    """
    best = math.inf
    bad = 0
    for c in cells_i:
        k = len(c)
        cell_ok = True
        for m in range(k):
            a = corner_angle(p, c[m], c[m - 1], c[(m + 1) % k])
            if a is None:
                cell_ok = False
            else:
                best = min(best, a if k == 3 else min(a, math.pi - a))
        if not cell_ok:
            bad += 1
    return -10.0 - bad if bad else best


def largest_moving_angle(p, i, cells_i):
    """The largest corner angle (radians) that node ``i`` moves: every corner of its triangles, every corner
    of its quads but the one opposite ``i``; reflex or degenerate corners count as pi."""
    big = 0.0
    for c in cells_i:
        k = len(c)
        for m in range(k):
            if k == 4 and c[m] == c[(c.index(i) + 2) % 4]:
                continue
            a = corner_angle(p, c[m], c[m - 1], c[(m + 1) % k])
            big = max(big, math.pi if a is None else a)
    return big


def laplacian_pos(p, i, nb):
    return [sum(p[j][0] for j in nb[i]) / len(nb[i]), sum(p[j][1] for j in nb[i]) / len(nb[i])]


def rotate_about(p_c, p_j, beta):
    """Rotate point p_c about p_j by beta (the paper's x', y' formula)."""
    x, y = p_c
    x0, y0 = p_j
    return [
        x0 + (x - x0) * math.cos(beta) - (y - y0) * math.sin(beta),
        y0 + (x - x0) * math.sin(beta) + (y - y0) * math.cos(beta),
    ]


def ccw_angle(u, v):
    """Counter-clockwise angle from vector u to vector v in [0, 2 pi)."""
    a = math.atan2(u[0] * v[1] - u[1] * v[0], u[0] * v[0] + u[1] * v[1])
    return a + 2 * math.pi if a < 0 else a


def angle_pos(p, i, inc_i):
    """The paper's rule for node i: rotate each spoke to split the two adjacent angles in the ideal ratio."""
    # collect, for each ring node j, the two sides (other node, ideal angle)
    sides = {}
    for c in inc_i:
        k = len(c)
        m = c.index(i)
        ideal = math.pi / 3 if k == 3 else math.pi / 2
        nxt, prv = c[(m + 1) % k], c[m - 1]
        # ring node nxt: turning ccw about nxt we meet ... ; its corner has prev = i -> side "a"
        sides.setdefault(nxt, {})["a"] = (c[(m + 2) % k], ideal)
        sides.setdefault(prv, {})["b"] = (c[m - 2], ideal)
        if k == 4:
            d = c[(m + 2) % 4]
            sides[d] = {"a": (c[(m + 3) % 4], math.pi / 4), "b": (c[(m + 1) % 4], math.pi / 4)}
    xs, ys = [], []
    for j, s in sides.items():
        (na, wa), (nb_, wb) = s["a"], s["b"]
        pj = p[j]
        ua = (p[na][0] - pj[0], p[na][1] - pj[1])
        ui = (p[i][0] - pj[0], p[i][1] - pj[1])
        ub = (p[nb_][0] - pj[0], p[nb_][1] - pj[1])
        # the two angles beside the spoke, inside the counter-clockwise sweep from a to b;
        # a spoke outside the sweep (non-convex or inverted corner) is rotated into it
        sweep = ccw_angle(ua, ub)
        a1 = ccw_angle(ua, ui)  # angle on the a side
        target_a1 = sweep * wa / (wa + wb)
        beta = target_a1 - a1  # rotate counter-clockwise by beta
        q = rotate_about(p[i], pj, beta)
        xs.append(q[0])
        ys.append(q[1])
    return [sum(xs) / len(xs), sum(ys) / len(ys)]


def _with(p, i, x):
    q = list(p)
    q[i] = x
    return q


def free_corner_degrees(points, topo):
    """The corner angles (degrees, by atan2) of the cells with a free node: (k, (n, k) array) per cell kind."""
    out = []
    for cells in (topo.tri, topo.quad):
        c = cells[~topo.fixed[cells].all(axis=1)]
        k = c.shape[1]
        a = np.empty(c.shape)
        for m in range(k):
            u, v = points[c[:, (m + 1) % k]] - points[c[:, m]], points[c[:, m - 1]] - points[c[:, m]]
            a[:, m] = np.degrees(np.arctan2(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0], (u * v).sum(axis=1)))
        out.append((k, a))
    return out
