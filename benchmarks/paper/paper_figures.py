"""PNG figures for docs/paper (matplotlib, no pyplot state).

Mesh pictures reuse :mod:`anglesmooth.plot`'s cell drawing (cells coloured by their
minimum angle); only the multi-panel layouts live here.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from anglesmooth.quality import cell_areas, cell_min_angles

try:  # the CLI's plotting helper: cells coloured by a value, shared norm / colour map
    from anglesmooth.plot import _draw_mesh
except ImportError:  # pragma: no cover - only if plot.py changes its private helper
    _draw_mesh = None

DPI = 100
CMAP = "RdYlGn"


def _draw(ax, topo, points, values, norm):
    if _draw_mesh is not None:
        return _draw_mesh(ax, topo, points, values, norm, CMAP)
    from matplotlib.collections import PolyCollection  # local fallback

    nt = topo.n_tri
    for cells, vals in ((topo.tri, values[:nt]), (topo.quad, values[nt:])):
        if cells.shape[0]:
            ax.add_collection(PolyCollection(points[cells], array=vals, cmap=CMAP, norm=norm, edgecolors="k", linewidths=0.3))
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set_xticks([])
    ax.set_yticks([])


def _save(fig, path):
    """PNG quantized to a 256-colour palette (mesh pictures shrink 3-5x with no visible change)."""
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    try:
        from PIL import Image
    except ImportError:  # pragma: no cover - pillow comes with matplotlib
        Path(path).write_bytes(buf.getvalue())
        return
    buf.seek(0)
    img = Image.open(buf).convert("RGB").quantize(colors=256, method=Image.Quantize.MEDIANCUT)
    img.save(Path(path), format="PNG", optimize=True)


def mesh_panels(path, topo, panels, title, labels, ncols=3):
    """``panels``: list of (key, points); each panel coloured by cell min angle, one colour scale.

    Inverted cells (signed area <= 0) are drawn black and counted in the panel title.
    """
    from matplotlib.collections import PolyCollection

    nrows = int(np.ceil(len(panels) / ncols))
    p0 = panels[0][1]
    ext = p0.max(axis=0) - p0.min(axis=0)
    aspect = float(ext[1] / ext[0]) if ext[0] > 0 else 1.0
    fig = Figure(figsize=(4.0 * ncols + 1.0, (4.0 * aspect + 0.7) * nrows + 0.4), layout="constrained")
    fig.suptitle(title)
    vmax = 90.0 if topo.n_quad else 60.0
    norm = Normalize(0.0, vmax)
    axes = fig.subplots(nrows, ncols, squeeze=False)
    nt = topo.n_tri
    for ax, (key, pts) in zip(axes.ravel(), panels):
        mins = cell_min_angles(pts, topo)
        bad = cell_areas(pts, topo) <= 0
        _draw(ax, topo, pts, np.where(bad, 0.0, mins), norm)
        polys = [pts[c] for c in topo.tri[bad[:nt]]] + [pts[c] for c in topo.quad[bad[nt:]]]
        if polys:
            ax.add_collection(PolyCollection(polys, facecolors="k", edgecolors="w", linewidths=0.8, hatch="xx"))
        extra = f", {int(bad.sum())} inverted (black)" if bad.any() else ""
        lo = mins[~bad].min() if (~bad).any() else float("nan")
        ax.set_title(f"{labels.get(key, key)}\nmin angle {lo:.1f}° over valid cells{extra}", fontsize=9)
    for ax in axes.ravel()[len(panels):]:
        ax.set_visible(False)
    fig.colorbar(axes.ravel()[0].collections[0], ax=axes, label="cell minimum angle (°)", shrink=0.7)
    _save(fig, path)


def figure12(path, fe):
    fig = Figure(figsize=(6.5, 5.5), layout="constrained")
    ax = fig.subplots()
    poly = np.array(fe["polygon"])
    closed = np.vstack([poly, poly[:1]])
    ax.plot(closed[:, 0], closed[:, 1], "k-", lw=1.2)
    final = np.array(fe["final_points"]).mean(axis=0)
    for v in poly:
        ax.plot([v[0], final[0]], [v[1], final[1]], color="0.75", lw=0.8, zorder=0)
    for k, path_pts in enumerate(fe["paths"]):
        p = np.array(path_pts)
        ax.plot(p[:, 0], p[:, 1], "o-", ms=3.5, color=f"C{k}",
                label=f"start {k + 1} ({p[0, 0]:g}, {p[0, 1]:g}): pass {fe['passes']} / pass 1 = {fe['last_over_first_pct'][k]:.2g}%")
        ax.plot(*p[0], "s", color=f"C{k}", ms=7)
    ax.plot(*final, "k*", ms=12, label=f"mean of the final points ({final[0]:.3f}, {final[1]:.3f})")
    c = fe["laplacian_centroid"]
    ax.plot(*c, "X", color="m", ms=10, label=f"Laplacian position (vertex centroid) ({c[0]:.2f}, {c[1]:.2f})")
    ax.set_aspect("equal")
    ax.set_title(f"Figure 12: central node paths, literal angle rule, {fe['passes']} passes\n"
                 f"final points within {fe['max_final_distance']:.1e} of each other", fontsize=10)
    ax.legend(fontsize=7, loc="upper left")
    ax.grid(True, alpha=0.3)
    _save(fig, path)


def figure13(path, per_pass, paper_t4, labels):
    """Three stacked panels: max displacement, min angle, area ratio vs pass (mean over seeds, min-max band)."""
    fig = Figure(figsize=(7.0, 9.0), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    specs = [("max_displacement", "max node displacement\n(mesh units, square side 100)", None),
             ("min_angle", "minimum angle (°)", 0),
             ("area_ratio", "area ratio max / min", "ratio")]
    paper_keys = {"laplacian": "laplacian", "angle-literal": "angle"}
    for ax, (metric, ylabel, pidx) in zip(axes, specs):
        for k, (key, series) in enumerate(per_pass.items()):
            s = series[metric]
            x = np.arange(len(s))
            lo = 1 if metric == "max_displacement" else 0
            mean = np.array([v["mean"] for v in s], dtype=float)[lo:]
            mn = np.array([v["min"] for v in s], dtype=float)[lo:]
            mx = np.array([v["max"] for v in s], dtype=float)[lo:]
            ax.plot(x[lo:], mean, "o-", ms=3, color=f"C{k}", label=f"{labels[key]} (mean of seeds)")
            ax.fill_between(x[lo:], mn, mx, color=f"C{k}", alpha=0.15, lw=0)
            pk = paper_keys.get(key)
            if pk and pidx is not None:
                rows = paper_t4[pk]
                vals = [r[0] for r in rows] if pidx == 0 else [r[2] / r[1] for r in rows]
                ax.plot(np.arange(1, 11), vals, "x--", color=f"C{k}", alpha=0.8,
                        label=f"paper, {'Laplacian' if pk == 'laplacian' else 'angle-based'} (Table 4)")
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
        if metric != "min_angle":
            ax.set_yscale("log")
    axes[0].set_title("Figure 13: triangle mesh, per pass (pass 0 = original); bands = min..max over seeds", fontsize=10)
    axes[1].legend(fontsize=7)
    axes[2].set_xlabel("pass")
    _save(fig, path)
