"""Slow, obvious per-node reference implementations of the smoothers.

Written from the paper's formulas with plain Python loops and trigonometry
(acos, rotation matrices), independent of the vectorized code: the only thing
shared is the update order (``topo.free_nodes`` grouped by colour), which the
reference takes as given.  Nodes of one colour share no cell, so updating them
one after another in that order is the same as updating the class at once.
"""

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


def reference_keep(points, topo, keep_quad=30.0, keep_tri=40.0, keep_rect=15.0, keep_stretch=1.5, quads_too=False):
    """Per free node (``topo.free_nodes`` order): the default ``angle``'s well-shaped-input rule applies.

    A node with a triangle whose cells are all well shaped (triangle corners >= ``keep_tri``
    deg, quad corners within ``keep_quad`` deg of a right angle) or that has a near-rectangular
    (corners within ``keep_rect`` deg) quad whose longest edge is >= ``keep_stretch`` x its shortest;
    only a node with a triangle or a corner of a quad with such a node (``quads_too``: every node, the
    former rule); a node among quads only: when every quad of it is near-rectangular.
    """
    p = [list(map(float, x)) for x in points]
    inc = incident(cells_of(topo), len(p))
    out = []
    for i in map(int, topo.free_nodes):
        has_tri = any(any(len(d) == 3 for d in inc[v]) for c in inc[i] for v in c)
        good, stretched, all_rect = True, False, True
        for c in inc[i]:
            k = len(c)
            ang = [corner_angle(p, c[m], c[m - 1], c[(m + 1) % k]) for m in range(k)]
            valid = all(a is not None for a in ang)
            if k == 3:
                good &= valid and min(ang) >= math.radians(keep_tri)
            else:
                dev = max(abs(a - math.pi / 2) for a in ang) if valid else math.inf
                good &= dev <= math.radians(keep_quad)
                e = [math.dist(p[c[m]], p[c[(m + 1) % 4]]) for m in range(4)]
                stretched |= dev <= math.radians(keep_rect) and max(e) >= keep_stretch * min(e)
                all_rect &= dev <= math.radians(keep_rect)
        out.append((good or stretched) if (has_tri or quads_too) else all_rect)
    return np.array(out, dtype=bool)


def reference_input_min(points, topo):
    """The smallest local quality (degrees) of any free node of ``points``: its incident cells' smallest
    corner quality (triangles: the angle; quads: min(angle, 180 - angle)); None if a cell of a free
    node is invalid (the default's ``keep_min`` rule is then off)."""
    p = [list(map(float, x)) for x in points]
    inc = incident(cells_of(topo), len(p))
    worst = min(local_min_angle(p, inc[int(i)]) for i in topo.free_nodes)
    return None if worst < 0 else math.degrees(worst)


def _reference_compass(p, i, inc_i, x, r, iterations, cap=None):
    """Compass search of node ``i``'s smallest angle from ``x``: the 8 points at distance ``r`` (directions k * 45
    deg), the first best taken where it beats the score so far, else ``r`` halved.  ``cap`` (radians): a position
    whose largest moving corner is wider scores -inf."""
    dirs = np.stack([np.cos(np.arange(8) * np.pi / 4), np.sin(np.arange(8) * np.pi / 4)], axis=1)

    def score(y):
        if cap is not None and largest_moving_angle(_with(p, i, y), i, inc_i) > cap:
            return -math.inf
        return local_min_angle(_with(p, i, y), inc_i)

    x = list(x)
    s0 = score(x)
    for _ in range(iterations):
        cands = [[x[0] + dirs[k, 0] * r, x[1] + dirs[k, 1] * r] for k in range(8)]
        sc = [score(c) for c in cands]
        k = int(np.argmax(sc))
        if sc[k] > s0:
            x, s0 = cands[k], sc[k]
        else:
            r = 0.5 * r
    return x


def _reference_compass_hold(p, i, cur, inc_i, nb_i, kp, input_max, iterations, radius):
    """Stage 4 of node ``i`` (its stage 1-2 choice at ``p[i]``, its position before the pass ``cur``): the compass
    search from the choice, radius ``radius`` times the mean length of its edges at ``cur``; a ``keep`` node (``kp``)
    whose result opens a moving corner wider than the largest of its at ``cur``, ``input_max`` (degrees; None: no
    rule) and a right angle searches again with such positions refused, and keeps its choice if that result is
    too (the default's ``keep_max``)."""
    choice = list(p[i])
    scale = sum(math.dist(cur, p[j]) for j in nb_i) / len(nb_i)
    y = _reference_compass(p, i, inc_i, choice, radius * scale, iterations)
    if kp and input_max is not None:
        cap = max(largest_moving_angle(_with(p, i, cur), i, inc_i), math.radians(input_max), math.pi / 2)
        if largest_moving_angle(_with(p, i, y), i, inc_i) > cap:
            y = _reference_compass(p, i, inc_i, choice, radius * scale, iterations, cap)
            if largest_moving_angle(_with(p, i, y), i, inc_i) > cap:
                y = choice
    return y


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


def reference_input_max(points, topo):
    """The largest corner angle (degrees; quads: every corner) of the cells of a free node of ``points``; None
    if one of them is invalid (the default's ``keep_max`` rule is then off)."""
    p = [list(map(float, x)) for x in points]
    fixed = set(map(int, np.flatnonzero(topo.fixed)))
    big = 0.0
    for c in cells_of(topo):
        if all(v in fixed for v in c):
            continue
        k = len(c)
        for m in range(k):
            a = corner_angle(p, c[m], c[m - 1], c[(m + 1) % k])
            if a is None:
                return None
            big = max(big, a)
    return math.degrees(big)


def reference_pass(points, topo, method, guard=True, halvings=6, accept_above=20.0, accept_above_quad=20.0,
                   keep=None, keep_largest=True, input_min=None, input_max=None, optimize=None):
    """One pass of ``method`` in the topology's colour order, node by node.

    For ``angle`` with ``guard`` this is the robust candidate selection (the
    angle position when its local quality is at least ``accept_above`` degrees
    -- ``accept_above_quad`` for a node of a quad -- whether or not staying
    would score higher, else of the four other candidates, staying included,
    the one nearest the angle position among those at least that good, else
    the best of five; where every candidate but staying is invalid, the
    guarded Laplacian move)
    without the local optimization of the worst nodes (``opt_iterations=0``).
    ``keep`` (per free node, bool; see :func:`reference_keep`): those nodes take the angle position
    only where it is also no worse than staying and opens none of the corners the node moves beyond the
    largest of them when staying (or a right angle; ``keep_largest=False``: without this second test), and
    otherwise always the best of five.
    ``input_min`` (degrees, :func:`reference_input_min` of the input; None: no such rule): the acceptance
    threshold, for the angle position and for the nearest good candidate alike, is the larger of it and
    ``accept_above[_quad]`` (the default's ``keep_min``).
    ``input_max`` (degrees, :func:`reference_input_max` of the input; None: no such rule): a ``keep`` node's
    best of five leaves out every candidate but staying whose largest moving corner is wider than the
    largest of staying's, ``input_max`` and a right angle (the default's ``keep_max``).
    ``optimize`` (iterations, radius; None: none): every node then takes stage 4's compass search from its stage
    1-2 choice (:func:`_reference_compass_hold`; the default with ``opt_fraction=1``, thresholds above any
    score, ``area_band=None``, ``strict_quads=False``, ``resume_iterations=0``).
    """
    p = [list(map(float, x)) for x in points]
    cells = cells_of(topo)
    inc = incident(cells, len(p))
    nb = neighbours(cells, len(p))
    for f, i in enumerate(map(int, topo.free_nodes)):
        kp = keep is not None and bool(keep[f])
        cur = p[i]
        lap = laplacian_pos(p, i, nb)
        if method == "laplacian":
            if not guard:
                p[i] = lap
                continue
            chosen = None
            for k in range(halvings + 1):
                f = 0.5**k
                x = [cur[0] + f * (lap[0] - cur[0]), cur[1] + f * (lap[1] - cur[1])]
                if local_min_angle(_with(p, i, x), inc[i]) > 0:
                    chosen = x
                    break
            p[i] = chosen if chosen is not None else cur
        elif method == "smart-laplacian":  # issue 12's rule: see reference_untangle_pass
            key_c = local_key(p, inc[i])
            if key_c[0] < 0:
                p[i] = untangle_ref(p, i, inc[i], nb[i])
                continue
            for k in range(3):
                f = 0.5**k
                x = [cur[0] + f * (lap[0] - cur[0]), cur[1] + f * (lap[1] - cur[1])]
                if local_key(_with(p, i, x), inc[i]) >= key_c:
                    p[i] = x
                    break
        elif method == "angle":
            ang = angle_pos(p, i, inc[i])
            if not guard:
                p[i] = ang
                continue
            q_ang = local_min_angle(_with(p, i, ang), inc[i])
            has_quad = any(len(c) == 4 for c in inc[i])
            good = max(accept_above_quad if has_quad else accept_above, -math.inf if input_min is None else input_min)
            if q_ang >= math.radians(good) and (
                    not kp or (q_ang >= local_min_angle(p, inc[i])
                               and (not keep_largest or largest_moving_angle(_with(p, i, ang), i, inc[i])
                                    <= max(largest_moving_angle(p, i, inc[i]), math.pi / 2)))):
                p[i] = ang
            else:
                cands = [ang, lap, [(ang[0] + lap[0]) / 2, (ang[1] + lap[1]) / 2], [(ang[0] + cur[0]) / 2, (ang[1] + cur[1]) / 2], cur]
                scores = [local_min_angle(_with(p, i, x), inc[i]) for x in cands]
                allowed = scores
                if kp and input_max is not None:
                    cap = max(largest_moving_angle(p, i, inc[i]), math.radians(input_max), math.pi / 2)
                    allowed = [s if k == 4 or largest_moving_angle(_with(p, i, x), i, inc[i]) <= cap else -math.inf
                               for k, (x, s) in enumerate(zip(cands, scores))]
                p[i] = cands[int(np.argmax(allowed))]
                # the candidate nearest the angle position among those good enough (first on ties)
                near = [k for k in range(1, 5) if scores[k] >= math.radians(good)]
                if near and not kp:
                    dist = [(cands[k][0] - ang[0]) ** 2 + (cands[k][1] - ang[1]) ** 2 for k in near]
                    p[i] = cands[near[int(np.argmin(dist))]]
                if all(s < 0 for s in scores[:4]) and scores[4] >= 0:
                    # every move invalid (negative), staying valid (>= 0, a 0 deg corner included):
                    # the guarded Laplacian move, halved until valid, else stay
                    for k in range(halvings + 1):
                        f = 0.5**k
                        x = [cur[0] + f * (lap[0] - cur[0]), cur[1] + f * (lap[1] - cur[1])]
                        if local_min_angle(_with(p, i, x), inc[i]) >= 0:
                            p[i] = x
                            break
            if optimize is not None:  # stage 4 (every node; no area band, no strict quads, no resume)
                p[i] = _reference_compass_hold(p, i, cur, inc[i], nb[i], kp, input_max, *optimize)
        else:
            raise ValueError(method)
    return np.array(p)



def reference_strict(points, topo, keep, node, x, strict_above=25.0):
    """Whether the default's stage 4 scores free node ``node`` (at its stage 1-2 choice ``x``, the other nodes
    at ``points``) with ``strict_quad``: a node of well-shaped input cells (``keep``, per free node) with both
    triangles and quads whose local quality at ``x`` (:func:`local_min_angle`) is at least ``strict_above`` deg."""
    p = [list(map(float, q)) for q in points]
    cells = cells_of(topo)
    inc = incident(cells, len(p))[node]
    f = int(np.flatnonzero(topo.free_nodes == node)[0])
    if not (keep[f] and any(len(c) == 3 for c in inc) and any(len(c) == 4 for c in inc)):
        return False
    return local_min_angle(_with(p, node, list(map(float, x))), inc) >= math.radians(strict_above)


# --------------------------------------------------------------------------- untangling (issue 12)


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


# --------------------------------------------------------------------------- patch moves (issue 12)


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
