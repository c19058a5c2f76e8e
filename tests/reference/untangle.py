"""References of the untangling rules (issue 12): a comparable local key (invalid cells first), the kernel
centroid of a node's star and the untangling pass."""

from __future__ import annotations

import math

import numpy as np

from .geometry import _with, cells_of, corner_angle, incident, laplacian_pos, neighbours


def _signed_area(p, c):
    return 0.5 * sum(p[c[m]][0] * p[c[(m + 1) % len(c)]][1] - p[c[(m + 1) % len(c)]][0] * p[c[m]][1] for m in range(len(c)))


def local_key(p, cells_i):
    """Comparable local quality: (-(1000 * inverted + other invalid cells), min corner quality), the
    quality 0 wherever some cell is invalid (all such positions with the same counts are equal)."""
    inv = bad = 0
    best = math.inf
    for c in cells_i:
        k = len(c)
        angles = [corner_angle(p, c[m], c[m - 1], c[(m + 1) % k]) for m in range(k)]
        if any(a is None for a in angles):
            if _signed_area(p, c) <= 0:
                inv += 1
            else:
                bad += 1
            continue
        for a in angles:
            best = min(best, a if k == 3 else min(a, math.pi - a))
    if inv or bad:
        return (-(1000 * inv + bad), 0.0)
    return (0, best)


def _rotated(c, i):
    m = c.index(i)
    return c[m:] + c[:m]


def _affine(f):
    """Coefficients (gx, gy, g0) of an affine function of x (evaluated at three points)."""
    g0 = f([0.0, 0.0])
    return f([1.0, 0.0]) - g0, f([0.0, 1.0]) - g0, g0


def _cross3(o, a, b):
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def kernel_centroid_ref(p, i, inc_i, nb_i):
    """Centroid of the positions of node i where every incident cell is valid (None if no area).

    Conditions (affine in x, so half-planes): every corner of every incident cell convex; for a quad
    whose corner opposite i is reflex (no position of i repairs it) only its area > 0.
    """
    planes = []
    for c in inc_i:
        c = _rotated(c, i)
        if len(c) == 3:
            a, b = p[c[1]], p[c[2]]
            planes.append(_affine(lambda x: _cross3(x, a, b)))
            continue
        a, b, d = p[c[1]], p[c[2]], p[c[3]]
        if _cross3(b, d, a) <= 0:  # corner b (between b->d and b->a) is reflex: keep the area positive
            planes.append(_affine(lambda x: (b[0] - x[0]) * (d[1] - a[1]) - (b[1] - x[1]) * (d[0] - a[0])))
            continue
        planes.append(_affine(lambda x: _cross3(x, a, d)))  # corner at x
        planes.append(_affine(lambda x: _cross3(a, b, x)))  # corner a: between a->b and a->x
        planes.append(_affine(lambda x: _cross3(d, x, b)))  # corner d: between d->x and d->b
    xs = [p[j][0] for j in nb_i]
    ys = [p[j][1] for j in nb_i]
    w = 10 * max(max(xs) - min(xs), max(ys) - min(ys))
    poly = [[min(xs) - w, min(ys) - w], [max(xs) + w, min(ys) - w], [max(xs) + w, max(ys) + w], [min(xs) - w, max(ys) + w]]
    for gx, gy, g0 in planes:  # Sutherland-Hodgman: keep g >= 0
        out = []
        for k in range(len(poly)):
            u, v = poly[k], poly[(k + 1) % len(poly)]
            gu, gv = gx * u[0] + gy * u[1] + g0, gx * v[0] + gy * v[1] + g0
            if gu >= 0:
                out.append(u)
            if (gu >= 0) != (gv >= 0):
                t = gu / (gu - gv)
                out.append([u[0] + t * (v[0] - u[0]), u[1] + t * (v[1] - u[1])])
        poly = out
        if not poly:
            return None
    area2 = cx = cy = 0.0
    for k in range(len(poly)):
        u, v = poly[k], poly[(k + 1) % len(poly)]
        cr = u[0] * v[1] - v[0] * u[1]
        area2 += cr
        cx += (u[0] + v[0]) * cr
        cy += (u[1] + v[1]) * cr
    if len(poly) < 3 or area2 <= 1e-12 * (max(xs) - min(xs) + max(ys) - min(ys)) ** 2 * 0.25:
        return None
    return [cx / (3 * area2), cy / (3 * area2)]


def untangle_ref(p, i, inc_i, nb_i, extra=()):
    """The best of: Laplacian L, its halved moves, ``extra``, the kernel centroid K, (K + L) / 2, staying."""
    cur = p[i]
    lap = [sum(p[j][0] for j in nb_i) / len(nb_i), sum(p[j][1] for j in nb_i) / len(nb_i)]
    k = kernel_centroid_ref(p, i, inc_i, nb_i)
    k = cur if k is None else k
    cands = [lap, [cur[0] + 0.5 * (lap[0] - cur[0]), cur[1] + 0.5 * (lap[1] - cur[1])],
             [cur[0] + 0.25 * (lap[0] - cur[0]), cur[1] + 0.25 * (lap[1] - cur[1])], *extra, k,
             [0.5 * (k[0] + lap[0]), 0.5 * (k[1] + lap[1])], cur]
    keys = [local_key(_with(p, i, x), inc_i) for x in cands]
    return cands[max(range(len(cands)), key=lambda m: (keys[m], -m))]


def reference_untangle_pass(points, topo, method, halvings=2):
    """One pass of ``smart-laplacian`` (the rule of issue 12: Laplacian, or its move halved once or
    twice, where the local quality does not decrease; nodes with an invalid incident cell untangled)
    or of ``optimization`` without its compass search (``iterations=0``: only the untangling), node by
    node in the colour order."""
    p = [list(map(float, x)) for x in points]
    cells = cells_of(topo)
    inc = incident(cells, len(p))
    nb = neighbours(cells, len(p))
    for i in map(int, topo.free_nodes):
        cur = p[i]
        key_c = local_key(p, inc[i])
        if key_c[0] < 0:
            p[i] = untangle_ref(p, i, inc[i], nb[i])
            continue
        if method == "optimization":
            continue
        lap = laplacian_pos(p, i, nb)
        for k in range(halvings + 1):
            f = 0.5**k
            x = [cur[0] + f * (lap[0] - cur[0]), cur[1] + f * (lap[1] - cur[1])]
            if local_key(_with(p, i, x), inc[i]) >= key_c:
                p[i] = x
                break
    return np.array(p)
