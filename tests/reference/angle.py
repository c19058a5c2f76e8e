"""References of the smoothers' passes (``laplacian``, ``angle``: the literal rule and the default's stages 1-4
with ``keep_min`` / ``keep_max``), node by node in the topology's colour order, and the input rules they read
(well-shaped input cells, the input's smallest local score and widest corner)."""

from __future__ import annotations

import math

import numpy as np

from .geometry import (
    _with, angle_pos, cells_of, corner_angle, incident, laplacian_pos, largest_moving_angle, local_min_angle,
    neighbours,
)
from .untangle import local_key, untangle_ref


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
