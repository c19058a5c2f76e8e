"""The quality summary of a mesh (:func:`summarize`) and the definition of each of its keys (:data:`METRICS`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..topology import CellTopology, signed_areas
from ._corners import _corners, _tri_area, _unit
from .validity import _degenerate_mask
from .verdict import _quad_aspect, _quad_condition, _quad_jac, _tri_aspect, _tri_radius

__all__ = ["METRICS", "summarize"]

METRICS: dict[str, str] = {
    "nodes": "number of mesh nodes (points), used or not",
    "triangles": "number of triangle cells (corner nodes of triangle-like cells)",
    "quads": "number of quad cells (corner nodes of quad-like cells)",
    "fixed_nodes": "number of nodes the smoother keeps fixed (boundary, interfaces, line/vertex cells, user-given, ...)",
    "min_angle": "smallest corner angle over all cells, degrees (counter-clockwise angle, in [0, 360))",
    "max_angle": "largest corner angle over all cells, degrees (reflex corners of non-convex quads are > 180)",
    "tri_min_angle": "smallest triangle corner angle, degrees; null without triangles",
    "tri_max_angle": "largest triangle corner angle, degrees; null without triangles",
    "quad_min_angle": "smallest quad corner angle, degrees; null without quads",
    "quad_max_angle": "largest quad corner angle, degrees; null without quads",
    "angles_below_20": "number of cell corners with angle < 20 degrees",
    "angles_above_130": "number of cell corners with angle > 130 degrees",
    "angles_above_150": "number of cell corners with angle > 150 degrees",
    "min_area": "smallest absolute cell area",
    "max_area": "largest absolute cell area",
    "area_ratio": "max_area / min_area; null when min_area is 0 (the ratio is infinite)",
    "inverted": "number of cells with signed area < 0 relative to the mesh orientation (orientation flipped; a zero-area cell is degenerate, not inverted)",
    "inverted_cells": "indices of the first 10 inverted cells (triangles first, then quads)",
    "degenerate": "number of cells that are not inverted and have area <= 1e-12 * (diagonal of the bounding box of all nodes)^2 (zero area or nearly)",
    "degenerate_cells": "indices of the first 10 degenerate cells (triangles first, then quads)",
    "nonconvex_quads": "number of quads with positive area and a corner whose cross product is <= 0 (angle >= 180 or 0)",
    "tri_aspect_ratio": "Verdict triangle aspect ratio l_max*(l0+l1+l2)/(4*sqrt(3)*|A|), 1 ideal: {min, mean, max} or null",
    "tri_radius_ratio": "Verdict triangle radius ratio R/(2r) (circumradius over twice the inradius), 1 ideal: {min, mean, max} or null",
    "quad_scaled_jacobian": "Verdict quad scaled Jacobian, min over corners of cross(e_prev, e_next)/(|e_prev||e_next|), in [-1, 1], 1 ideal: {min, mean, max} or null",
    "quad_aspect_ratio": "Verdict quad aspect ratio l_max*(l0+l1+l2+l3)/(4*|A|), 1 ideal: {min, mean, max} or null",
    "quad_condition": "Verdict quad condition, max over corners of (|e_prev|^2+|e_next|^2)/(2*cross), 1 ideal: {min, mean, max} or null",
    "min_edge": "shortest cell edge length; null without cells",
    "edge_ratio": "longest / shortest cell edge length; null when the shortest is 0 or without cells (a collapsing edge shows here)",
}


def _stats(a: np.ndarray) -> dict[str, float] | None:
    if a.size == 0:
        return None
    return {"min": float(a.min()), "mean": float(a.mean()), "max": float(a.max())}


def _opt(a: np.ndarray, fn) -> float | None:
    return float(fn(a)) if a.size else None


def _extreme(fn, *angles: np.ndarray) -> float | None:
    """``fn`` (np.min or np.max) over all the (k, n) corner angle arrays, None when there are none.

    Equals ``fn`` over the angles listed cell by cell, without concatenating
    them; only a zero is recomputed that way, as -0.0 and 0.0 tie and which one
    a reduction returns depends on the order of the elements.
    """
    angles = tuple(a for a in angles if a.size)
    if not angles:
        return None
    value = fn([fn(a) for a in angles])
    if value == 0:
        value = fn(np.concatenate([a.T.ravel() for a in angles]))
    return float(value)


def _unscaled(value: float | None, e: int) -> float | None:
    """``value * 2**e``: a length or an area of the scaled coordinates in the units of the mesh (inf past 1e308)."""
    if value is None or e == 0:
        return value
    with np.errstate(over="ignore", under="ignore"):
        return float(np.ldexp(value, e))


def summarize(points: np.ndarray, topo: CellTopology) -> dict[str, Any]:
    """Quality summary of a mesh as a JSON-ready dict (plain ints, floats, lists, None).

    Keys and definitions are listed in :data:`METRICS`.  ``area_ratio`` is None
    when the smallest area is 0 (JSON has no infinity); per-type angle entries
    and Verdict statistics are None when that cell type is absent.  Each
    corner's edge vectors are computed once and the angles, lengths and Verdict
    measures are derived from them, on the coordinates scaled by the power of two
    that brings the bounding-box diagonal into [0.5, 1): the scaling is exact, so
    the summary of a mesh scaled by 2**k is the same but for ``min_area``,
    ``max_area`` (times 4**k) and ``min_edge`` (times 2**k), whatever k.

    Parameters
    ----------
    points : (N, 2) float array
        Node coordinates (may differ from the mesh the topology was built from,
        e.g. after smoothing).
    topo : CellTopology (or Topology)

    Returns
    -------
    dict

    Examples
    --------
    >>> import numpy as np
    >>> from anglesmooth.mesh import Mesh2D
    >>> from anglesmooth.topology import build_topology
    >>> m = Mesh2D.from_arrays([[0, 0], [1, 0], [1, 1], [0, 1]], triangles=[[0, 1, 2], [0, 2, 3]])
    >>> s = summarize(m.points, build_topology(m))
    >>> s["triangles"], s["min_angle"], s["max_angle"], s["angles_below_20"], s["area_ratio"], s["quad_min_angle"]
    (2, 45.0, 90.0, 0, 1.0, None)
    """
    pts, e = _unit(points)  # exact power-of-two scaling: no under- or overflow whatever the mesh size
    nt, nq = topo.n_tri, topo.n_quad
    ct = _corners(pts, topo.tri)
    cq = _corners(pts, topo.quad)
    at, aq = _tri_area(ct), signed_areas(pts, topo.tri[:0], topo.quad)
    area = np.concatenate([at, aq])
    angles = [c.angle for c in (ct, cq) if c.angle.size]
    absa = np.abs(area)
    inv = np.flatnonzero(area < 0)
    deg = np.flatnonzero(_degenerate_mask(area, pts))
    edge_len = [c.length for c in (ct, cq) if c.length.size]
    min_edge = _extreme(np.min, *edge_len) if edge_len else None
    max_edge = _extreme(np.max, *edge_len) if edge_len else None
    min_area = _opt(absa, np.min)
    max_area = _opt(absa, np.max)
    return {
        "nodes": int(topo.n_points),
        "triangles": int(nt),
        "quads": int(nq),
        "fixed_nodes": int(np.count_nonzero(topo.fixed)),
        "min_angle": _extreme(np.min, ct.angle, cq.angle),
        "max_angle": _extreme(np.max, ct.angle, cq.angle),
        "tri_min_angle": _extreme(np.min, ct.angle),
        "tri_max_angle": _extreme(np.max, ct.angle),
        "quad_min_angle": _extreme(np.min, cq.angle),
        "quad_max_angle": _extreme(np.max, cq.angle),
        "angles_below_20": sum(int(np.count_nonzero(a < 20.0)) for a in angles),
        "angles_above_130": sum(int(np.count_nonzero(a > 130.0)) for a in angles),
        "angles_above_150": sum(int(np.count_nonzero(a > 150.0)) for a in angles),
        "min_area": _unscaled(min_area, 2 * e),
        "max_area": _unscaled(max_area, 2 * e),
        "area_ratio": (max_area / min_area) if min_area else None,
        "inverted": int(inv.size),
        "inverted_cells": inv[:10].tolist(),
        "degenerate": int(deg.size),
        "degenerate_cells": deg[:10].tolist(),
        "nonconvex_quads": int(np.count_nonzero((aq > 0) & (cq.cross <= 0).any(axis=0))),
        "tri_aspect_ratio": _stats(_tri_aspect(ct, at)),
        "tri_radius_ratio": _stats(_tri_radius(ct, at)),
        "quad_scaled_jacobian": _stats(_quad_jac(cq)),
        "quad_aspect_ratio": _stats(_quad_aspect(cq, aq)),
        "quad_condition": _stats(_quad_condition(cq)),
        "min_edge": _unscaled(min_edge, e),
        "edge_ratio": (max_edge / min_edge) if min_edge else None,
    }
