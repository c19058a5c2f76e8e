"""The computations behind docs/paper: every experiment returns plain, JSON-ready dicts.

Nothing here plots or writes files; :mod:`reproduce` orchestrates, :mod:`paper_figures`
draws and :mod:`paper_report` renders the README.
"""

from __future__ import annotations

import time

import numpy as np

from anglesmooth import generate as gen
from anglesmooth.driver import smooth
from anglesmooth.quality import summarize
from anglesmooth.topology import build_topology

# name -> (library method, guard, order, label)
METHODS = {
    "laplacian": ("laplacian", False, "colour", "Laplacian (unguarded)"),
    "smart-laplacian": ("smart-laplacian", True, "colour", "Smart Laplacian"),
    "angle-literal": ("angle", False, "colour", "Angle-based, literal (`--no-guard`)"),
    "angle-default": ("angle", True, "colour", "Angle-based, robust default"),
    "optimization": ("optimization", True, "colour", "Optimization-based"),
    "laplacian-jacobi": ("laplacian", False, "jacobi", "Laplacian (unguarded), Jacobi order"),
    "angle-literal-jacobi": ("angle", False, "jacobi", "Angle-based, literal, Jacobi order"),
}

# which methods run on which mesh kind (jacobi rows only on the triangle mesh)
MESH_METHODS = {
    "triangle": list(METHODS),
    "mixed": ["laplacian", "smart-laplacian", "angle-literal", "angle-default", "optimization"],
    "graded": ["laplacian", "smart-laplacian", "angle-literal", "angle-default", "optimization"],
    "quad": ["laplacian", "smart-laplacian", "angle-literal", "angle-default", "optimization"],
}

MESHES = {
    "triangle": gen.paper_triangle_mesh,
    "mixed": gen.paper_mixed_mesh,
    "graded": gen.graded_mesh,
    "quad": gen.paper_quad_mesh,
}

METRICS = (
    "min_angle",
    "max_angle",
    "angles_below_20",
    "angles_above_130",
    "angles_above_150",
    "min_area",
    "max_area",
    "area_ratio",
    "inverted",
    "nonconvex_quads",
)


def _metrics(points, topo) -> dict:
    s = summarize(points, topo)
    out = {k: s[k] for k in METRICS}
    if out["area_ratio"] is None:  # a zero-area cell
        out["area_ratio"] = float("inf")
    return out


def run_method(mesh, topo, key: str, passes: int):
    """Smooth with one configured method; record the quality after every pass."""
    method, guard, order, _ = METHODS[key]
    hist = [_metrics(mesh.points, topo)]
    disp = [0.0]
    prev = [np.array(mesh.points)]

    def cb(k, pts, d):
        disp.append(float(np.sqrt(((pts - prev[0]) ** 2).sum(axis=1)).max()))
        prev[0] = pts.copy()
        hist.append(_metrics(pts, topo))

    t0 = time.perf_counter()
    res = smooth(mesh, method, passes, guard=guard, order=order, topology=topo, callback=cb)
    elapsed = time.perf_counter() - t0
    final = dict(hist[-1])
    final["rejected"] = int(res.rejected)
    final["reverted"] = int(res.reverted)
    final["elapsed_s"] = elapsed
    return res.points, final, {"metrics": hist, "max_displacement": disp}


def aggregate(values) -> dict:
    """mean / min / max over seeds (None and inf kept out of the mean, counted)."""
    a = np.array([np.nan if v is None else v for v in values], dtype=float)
    finite = a[np.isfinite(a)]
    n_inf = int(np.isinf(a).sum())
    if finite.size == 0:
        return {"mean": None, "min": None, "max": None, "n": int(a.size), "n_inf": n_inf}
    return {
        "mean": float(finite.mean()),
        "min": float(finite.min()),
        "max": float(finite.max()) if n_inf == 0 else float("inf"),
        "n": int(a.size),
        "n_inf": n_inf,
    }


def quality_tables(seeds, passes: int, log=print):
    """Tables 1-4 + graded: every mesh kind, every method, every seed.

    Returns (results, keep) where results[kind] holds per-seed rows and aggregates and
    keep[kind] the seed-0 coordinates per method (for the figures).
    """
    results, keep = {}, {}
    for kind, make in MESHES.items():
        rows = {k: [] for k in ["original", *MESH_METHODS[kind]]}
        history = {k: [] for k in MESH_METHODS[kind]}
        counts = []
        t0 = time.perf_counter()
        for i, seed in enumerate(seeds):
            mesh = make(seed=seed)
            topo = build_topology(mesh)
            counts.append({"nodes": mesh.n_points, "triangles": topo.n_tri, "quads": topo.n_quad})
            rows["original"].append(_metrics(mesh.points, topo))
            if i == 0:
                keep[kind] = {"mesh": mesh, "topo": topo, "points": {"original": np.array(mesh.points)}}
            for key in MESH_METHODS[kind]:
                pts, final, hist = run_method(mesh, topo, key, passes)
                rows[key].append(final)
                history[key].append(hist)
                if i == 0:
                    keep[kind]["points"][key] = pts
        log(f"  {kind:8s}: {len(seeds)} seeds x {len(MESH_METHODS[kind])} methods in {time.perf_counter() - t0:.1f} s")
        agg = {
            key: {m: aggregate([r[m] for r in rs]) for m in rs[0]} for key, rs in rows.items()
        }
        # per-pass means over seeds
        per_pass = {}
        for key, hs in history.items():
            npass = len(hs[0]["metrics"])
            per_pass[key] = {
                "max_displacement": aggregate_list([h["max_displacement"] for h in hs]),
                **{
                    m: aggregate_list([[h["metrics"][p][m] for p in range(npass)] for h in hs])
                    for m in ("min_angle", "min_area", "max_area", "area_ratio", "inverted")
                },
            }
        results[kind] = {
            "counts": {k: aggregate([c[k] for c in counts]) for k in counts[0]},
            "per_seed": rows,
            "aggregate": agg,
            "per_pass": per_pass,
        }
    return results, keep


def aggregate_list(series):
    """Per-position aggregate of equal-length series (one per seed)."""
    a = np.array(series, dtype=float)
    return [aggregate(a[:, j]) for j in range(a.shape[1])]


# ---------------------------------------------------------------------------
# Figure 12 and Figure 8
# ---------------------------------------------------------------------------
def five_element(passes: int):
    starts = gen.five_element_starts()
    paths, ratios = [], []
    for start in starts:
        mesh = gen.five_element_polygon(center=start)
        path = [np.array(mesh.points[5])]
        smooth(mesh, "angle", passes, guard=False, callback=lambda k, p, d: path.append(np.array(p[5])))
        path = np.array(path)
        steps = np.linalg.norm(np.diff(path, axis=0), axis=1)
        paths.append(path)
        ratios.append(float(steps[-1] / steps[0]) if steps[0] > 0 else float("nan"))
    finals = np.array([p[-1] for p in paths])
    d = np.linalg.norm(finals[:, None] - finals[None], axis=2)
    poly = np.array(gen.five_element_polygon().points[:5])
    return {
        "starts": starts.tolist(),
        "paths": [p.tolist() for p in paths],
        "step_lengths": [np.linalg.norm(np.diff(p, axis=0), axis=1).tolist() for p in paths],
        "last_over_first_pct": [100.0 * r for r in ratios],
        "final_points": finals.tolist(),
        "max_final_distance": float(d.max()),
        "polygon": poly.tolist(),
        "laplacian_centroid": poly.mean(axis=0).tolist(),
        "passes": passes,
    }


def distorted(passes: int):
    mesh = gen.distorted_mesh()
    topo = build_topology(mesh)
    rows = {"original": {**_metrics(mesh.points, topo), "centre": mesh.points[8].tolist(), "passes": 0}}
    configs = [
        ("laplacian-1pass", "laplacian", False, 1),
        ("laplacian", "laplacian", False, passes),
        ("laplacian-guarded", "laplacian", True, passes),
        ("smart-laplacian", "smart-laplacian", True, passes),
        ("angle-literal", "angle", False, passes),
        ("angle-default", "angle", True, passes),
        ("optimization", "optimization", True, passes),
    ]
    pts_keep = {"original": np.array(mesh.points)}
    for name, method, guard, n in configs:
        r = smooth(mesh, method, n, guard=guard, topology=topo)
        rows[name] = {**_metrics(r.points, topo), "centre": r.points[8].tolist(), "passes": n, "rejected": r.rejected}
        pts_keep[name] = r.points
    return rows, {"mesh": mesh, "topo": topo, "points": pts_keep}


# ---------------------------------------------------------------------------
# Table 5: L2 error of bilinear patches
# ---------------------------------------------------------------------------
def _f1(x, y, l):
    return np.sin(2 * np.pi * x / l) * np.sin(2 * np.pi * y / l)


def _f2(x, y, l):
    return np.sqrt(62500.0 - x * x - y * y)


def _f3(x, y, l):
    return x**3


FUNCTIONS = {"f1": _f1, "f2": _f2, "f3": _f3}


def bilinear_l2_error(points, quads, f, l, n_gauss: int = 5):
    """||f - f_h||_L2 over all quads, f_h the bilinear (isoparametric Q1) interpolant of nodal values.

    ``sum over quads of the integral of (f - f_h)^2 dA`` by an ``n_gauss x n_gauss``
    Gauss-Legendre rule on the reference square [-1, 1]^2 mapped by each quad's
    bilinear map (weights times |det J|).  Also returns the sum of the per-quad norms
    (another reading of the paper's "summation of the errors computed for each
    quadrilateral element").  Vectorized over quads.
    """
    g, w = np.polynomial.legendre.leggauss(n_gauss)
    xi, eta = np.meshgrid(g, g, indexing="ij")
    xi, eta = xi.ravel(), eta.ravel()
    W = np.outer(w, w).ravel()
    # shape functions for corners (-1,-1), (1,-1), (1,1), (-1,1) (counter-clockwise)
    sx = np.array([-1.0, 1.0, 1.0, -1.0])
    sy = np.array([-1.0, -1.0, 1.0, 1.0])
    N = 0.25 * (1 + xi[:, None] * sx) * (1 + eta[:, None] * sy)  # (G, 4)
    dNx = 0.25 * sx * (1 + eta[:, None] * sy)
    dNy = 0.25 * sy * (1 + xi[:, None] * sx)
    P = points[quads]  # (nq, 4, 2)
    X = np.einsum("ga,qad->qgd", N, P)  # (nq, G, 2)
    Jx = np.einsum("ga,qad->qgd", dNx, P)  # d(x, y)/dxi
    Jy = np.einsum("ga,qad->qgd", dNy, P)  # d(x, y)/deta
    det = Jx[..., 0] * Jy[..., 1] - Jx[..., 1] * Jy[..., 0]
    fn = f(P[..., 0], P[..., 1], l)  # (nq, 4)
    fh = fn @ N.T  # (nq, G)
    e2 = (f(X[..., 0], X[..., 1], l) - fh) ** 2
    per_quad = (e2 * np.abs(det) * W).sum(axis=1)
    return float(np.sqrt(per_quad.sum())), float(np.sqrt(per_quad).sum())


def surface_errors(seeds, passes: int, n_gauss: int = 5):
    keys = ["original", "laplacian", "angle-literal", "angle-default"]
    per_seed = []
    size = None
    for seed in seeds:
        mesh = gen.paper_quad_mesh(seed=seed)
        topo = build_topology(mesh)
        pts = {"original": np.array(mesh.points)}
        for key in keys[1:]:
            method, guard, order, _ = METHODS[key]
            pts[key] = smooth(mesh, method, passes, guard=guard, order=order, topology=topo).points
        lo, hi = mesh.points.min(axis=0), mesh.points.max(axis=0)
        size = float(hi[0] - lo[0])
        row = {}
        for fname, f in FUNCTIONS.items():
            row[fname] = {k: bilinear_l2_error(p, topo.quad, f, size, n_gauss) for k, p in pts.items()}
        per_seed.append(row)
    out = {"domain": {"size_l": size, "origin": "lower-left corner at (0, 0): domain [0, l]^2"}, "gauss": n_gauss}
    for fname in FUNCTIONS:
        out[fname] = {}
        for k in keys:
            out[fname][k] = aggregate([r[fname][k][0] for r in per_seed])
            out[fname][k + "_sum_of_norms"] = aggregate([r[fname][k][1] for r in per_seed])
        for a in ("angle-literal", "angle-default"):
            imp = [100.0 * (r[fname]["laplacian"][0] - r[fname][a][0]) / r[fname][a][0] for r in per_seed]
            out[fname]["improvement_pct_" + a] = aggregate(imp)
            out[fname]["seeds_better_" + a] = int(sum(i > 0 for i in imp))
    out["per_seed"] = per_seed
    return out


# ---------------------------------------------------------------------------
# Section 5.2: cost per pass
# ---------------------------------------------------------------------------
COST_METHODS = ["laplacian", "laplacian-guarded", "smart-laplacian", "angle-literal", "angle-default", "optimization"]


def cost(mesh, passes: int, repeats: int = 1):
    topo = build_topology(mesh)
    out = {}
    for key in COST_METHODS:
        if key == "laplacian-guarded":
            method, guard, order = "laplacian", True, "colour"
        else:
            method, guard, order, _ = METHODS[key]
        times = []
        for _ in range(repeats):
            ts = [time.perf_counter()]
            smooth(mesh, method, passes, guard=guard, order=order, topology=topo,
                   callback=lambda k, p, d: ts.append(time.perf_counter()))
            times.extend(np.diff(ts).tolist())
        out[key] = {"median_s": float(np.median(times)), "times_s": times}
    base = out["laplacian"]["median_s"]
    for key in out:
        out[key]["relative"] = out[key]["median_s"] / base
    return {"triangles": topo.n_tri, "nodes": mesh.n_points, "passes": passes, "repeats": repeats, "methods": out}
