"""Plots (optional extra ``anglesmooth[plot]``): matplotlib is imported only when a plot is made.

* :func:`plot_smooth` - the mesh before and after, every cell coloured by its
  minimum angle, with histograms of the corner angles and of the cell minimum
  angles.
* :func:`plot_compare` - minimum angle and area ratio per pass for each method
  (the paper's Figure 13).

Figures are built with ``matplotlib.figure.Figure`` (no pyplot, no global state,
no display needed) and written atomically.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from . import _paths
from .errors import AngleSmoothError
from .quality import cell_min_angles, corner_angles
from .topology import Topology

__all__ = ["MISSING_MATPLOTLIB", "plot_compare", "plot_smooth", "require_matplotlib"]

MISSING_MATPLOTLIB = "plotting needs matplotlib: pip install 'anglesmooth[plot]'"

#: Above this many cells, cell edges are not drawn (they would only darken the picture).
EDGE_LIMIT = 20_000


def require_matplotlib() -> None:
    """Raise :class:`AngleSmoothError` (exit 3) with an install hint when matplotlib is missing."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise AngleSmoothError(MISSING_MATPLOTLIB) from None


def _figure(width: float, height: float):
    require_matplotlib()
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height), layout="constrained")


def _save(fig, path: str | Path) -> None:
    """Write the PNG like every output (atomically, or into a device / FIFO; see ``_paths``)."""

    def write(tmp):
        with open(tmp, "wb") as fh:
            fig.savefig(fh, format="png", dpi=110)

    try:
        _paths.atomic_write(path, write, suffix=".png", what="cannot write plot")
    except OSError as exc:
        raise AngleSmoothError(f"cannot write plot '{path}': {exc.strerror or exc}") from None


def _draw_mesh(ax, topo: Topology, points: np.ndarray, values: np.ndarray, norm, cmap):
    from matplotlib.collections import PolyCollection

    lw = 0.3 if topo.n_tri + topo.n_quad <= EDGE_LIMIT else 0.0
    nt = topo.n_tri
    for cells, vals in ((topo.tri, values[:nt]), (topo.quad, values[nt:])):
        if cells.shape[0] == 0:
            continue
        pc = PolyCollection(points[cells], array=vals, cmap=cmap, norm=norm, edgecolors="k", linewidths=lw)
        ax.add_collection(pc)
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set_xticks([])
    ax.set_yticks([])


def _angles(points: np.ndarray, topo: Topology) -> np.ndarray:
    t, q = corner_angles(points, topo)
    return np.concatenate([t.ravel(), q.ravel()])


def plot_smooth(path: str | Path, topo: Topology, before: np.ndarray, after: np.ndarray, *, title: str = "") -> None:
    """Write a PNG: mesh before / after coloured by cell minimum angle, plus angle histograms.

    ``before`` and ``after`` are (N, 2) coordinates of the same mesh (``topo``).
    """
    from matplotlib.colors import Normalize

    span = np.ptp(np.vstack([before, after]), axis=0) if before.shape[0] else np.ones(2)
    mesh_h = float(np.clip(5.2 * span[1] / span[0], 2.0, 7.0)) if span[0] > 0 else 5.0
    fig = _figure(12, mesh_h + 4.5)
    if title:
        fig.suptitle(title)
    grid = fig.add_gridspec(2, 2, height_ratios=[mesh_h, 4.0])
    ideal = 90.0 if topo.n_quad else 60.0
    norm = Normalize(vmin=0.0, vmax=ideal)
    cmap = "RdYlGn"
    mins = {"before": cell_min_angles(before, topo), "after": cell_min_angles(after, topo)}
    ax0 = fig.add_subplot(grid[0, 0])
    ax1 = fig.add_subplot(grid[0, 1], sharex=ax0, sharey=ax0)
    for ax, (label, pts) in zip((ax0, ax1), (("before", before), ("after", after))):
        _draw_mesh(ax, topo, pts, mins[label], norm, cmap)
        ax.set_title(f"{label}: min angle {mins[label].min():.2f}°")
    sm = ax1.collections[0]
    fig.colorbar(sm, ax=[ax0, ax1], label="cell minimum angle (°)", shrink=0.8)

    bins = np.arange(0.0, 182.0, 2.0)
    hist_c = fig.add_subplot(grid[1, 0])
    for label, pts, style in (("before", before, dict(color="0.6", alpha=0.7)),
                              ("after", after, dict(histtype="step", color="C0", linewidth=1.5))):
        hist_c.hist(np.clip(_angles(pts, topo), 0, 180), bins=bins, label=label, **style)
    for x in (20, 130, 150):
        hist_c.axvline(x, color="k", linestyle=":", linewidth=0.8)
    hist_c.set_xlabel("corner angle (°)")
    hist_c.set_ylabel("corners")
    hist_c.set_title("all corner angles")
    hist_c.legend()

    hist_m = fig.add_subplot(grid[1, 1])
    mbins = np.arange(0.0, ideal + 2.0, 1.0)
    for label, style in (("before", dict(color="0.6", alpha=0.7)),
                         ("after", dict(histtype="step", color="C0", linewidth=1.5))):
        hist_m.hist(np.clip(mins[label], 0, ideal), bins=mbins, label=label, **style)
    hist_m.axvline(20, color="k", linestyle=":", linewidth=0.8)
    hist_m.set_xlabel("cell minimum angle (°)")
    hist_m.set_ylabel("cells")
    hist_m.set_title("cell minimum angles")
    hist_m.legend()
    _save(fig, path)


def plot_compare(path: str | Path, histories: Mapping[str, Mapping[str, Sequence[float | None]]], *,
                 title: str = "") -> None:
    """Write a PNG with the per-pass curves of every method.

    ``histories`` maps a method name to ``{"min_angle": [...], "area_ratio": [...]}``,
    index 0 being the input mesh; an infinite area ratio may be given as None.
    """
    fig = _figure(12, 4.5)
    if title:
        fig.suptitle(title)
    ax_a, ax_r = fig.subplots(1, 2)
    for k, (method, hist) in enumerate(histories.items()):
        style = dict(marker="o", markersize=3, color=f"C{k}", label=method)
        mins = np.array([np.nan if v is None else v for v in hist["min_angle"]], dtype=float)
        ratios = np.array([np.nan if v is None else v for v in hist["area_ratio"]], dtype=float)
        ax_a.plot(np.arange(mins.size), mins, **style)
        ax_r.plot(np.arange(ratios.size), ratios, **style)
    ax_a.set_xlabel("pass")
    ax_a.set_ylabel("minimum angle (°)")
    ax_a.set_title("minimum angle per pass")
    ax_r.set_xlabel("pass")
    ax_r.set_ylabel("area ratio (max / min)")
    if np.isfinite([v for h in histories.values() for v in h["area_ratio"] if v is not None]).any():
        ax_r.set_yscale("log")
    ax_r.set_title("area ratio per pass")
    for ax in (ax_a, ax_r):
        ax.grid(True, alpha=0.3)
        ax.legend()
    _save(fig, path)
