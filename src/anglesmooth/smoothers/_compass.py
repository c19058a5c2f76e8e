"""The local max-min-angle optimization (compass search) of :func:`optimize`, shared by ``angle``
(stage 4) and ``optimization``: numpy on a :class:`._local.BlockGeometry`, or one compiled loop per
node on a :class:`._fastcalls.FastGeometry` (moved out of :mod:`._local`, which re-exports it)."""

from __future__ import annotations

import numpy as np

from . import _fastcalls


def optimize(
    geom,  # a _local.BlockGeometry or a _fastcalls.FastGeometry
    x: np.ndarray,
    scale: np.ndarray,
    iterations: int = 3,
    radius: float = 0.25,
    area_band: float | None = None,
    area_limits: tuple[float, float] | None = None,
    strict: np.ndarray | None = None,
    start_score: np.ndarray | None = None,
):
    """Local max-min-angle optimization by compass (pattern) search, vectorized over nodes.

    Each iteration tries the 8 points at distance ``r`` in the compass
    directions and moves to the best one if it raises the local score;
    otherwise ``r`` is halved.  ``r`` starts at ``radius * scale`` (scale: mean
    incident edge length).  Pattern search copes with the kinks of the
    non-smooth max-min objective where a (finite-difference) steepest ascent
    stalls: measured on the paper's triangle meshes, 10 passes reach a mean
    minimum angle of 25.0 deg against 18.5 deg for gradient ascent with a line
    search at a similar cost.

    With ``area_band`` (0 < band < 1), a step is only taken if the node's
    smallest incident cell keeps at least ``band`` times, and its largest at
    most ``1/band`` times, the area they had at the start: the angle alone
    would happily shrink a cell to a sliver of good shape.  ``area_limits``
    (lo, hi), with ``area_band``, also keeps that smallest cell at least at
    ``min(lo, its start area)`` and the largest at most ``max(hi, its start
    area)`` (the default ``angle`` passes the mesh's area range at the start
    of the pass).  ``strict`` (per node, bool): those nodes score their quad corners with
    :func:`strict_quad` where they also have triangles (see ``angle.step``'s ``strict_quads``).
    ``iterations`` and ``radius`` may also be one value per node (numpy kernels only).
    ``start_score``: the score at ``x`` if the caller has it (numpy kernels, without ``strict``: the
    same numbers the search would compute).  Returns (positions, scores).
    """
    if isinstance(geom, _fastcalls.FastGeometry):  # the same search, one compiled loop per node
        return geom.compass(x, scale, iterations, radius, area_band, _COMPASS, area_limits, strict)
    if start_score is None or (strict is not None and np.any(strict)):
        s0 = geom.score(x, strict=strict)
    else:
        s0 = np.array(start_score, dtype=np.float64)
    lo0 = hi0 = None
    if area_band is not None:
        lr, hr = geom.area_range(x)
        lo0, hi0 = area_band * lr, hr / area_band
        if area_limits is not None:
            lo0 = np.maximum(lo0, np.minimum(area_limits[0], lr))
            hi0 = np.minimum(hi0, np.maximum(area_limits[1], hr))
    r = radius * scale
    if np.ndim(iterations) == 0:
        for _ in range(iterations):
            x, s0, r = _compass_step(geom, x, s0, r, area_band, lo0, hi0, strict)
        return x, s0
    # one number of steps per node: all nodes while every one still steps, then only the ones that do
    # (the geometry restricted once per change of that set; every node's numbers are its own)
    its = np.asarray(iterations)
    x, s0, r = np.array(x, dtype=np.float64), np.array(s0), np.array(r, dtype=np.float64)  # written in place below
    act, g = None, geom
    for k in range(int(its.max(initial=0))):
        on = its if act is None else its[act]
        if not (on > k).all():
            sub = np.flatnonzero(on > k)
            act = sub if act is None else act[sub]
            g = g.restrict(sub)
            if area_band is not None:
                lo0, hi0 = lo0[sub], hi0[sub]
            strict = None if strict is None else strict[sub]
        if act is None:
            x, s0, r = _compass_step(g, x, s0, r, area_band, lo0, hi0, strict)
        else:
            x[act], s0[act], r[act] = _compass_step(g, x[act], s0[act], r[act], area_band, lo0, hi0, strict)
    return x, s0


def _compass_step(geom, x, s0, r, area_band, lo0, hi0, strict):
    """One step of :func:`optimize`'s compass search: (positions, scores, radii)."""
    cands = x[None] + _COMPASS[:, None, :] * r[None, :, None]
    sc = geom.score(cands, strict=strict) if area_band is None else geom.banded_score(cands, lo0, hi0, strict)
    k = np.argmax(sc, axis=0)
    idx = np.arange(x.shape[0])
    sk = sc[k, idx]
    better = sk > s0
    x = np.where(better[:, None], cands[k, idx], x)
    s0 = np.where(better, sk, s0)
    r = np.where(better, r, 0.5 * r)
    return x, s0, r


_COMPASS = np.stack([np.cos(np.arange(8) * np.pi / 4), np.sin(np.arange(8) * np.pi / 4)], axis=1)
