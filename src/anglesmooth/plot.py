"""Plots (optional extra ``anglesmooth[plot]``): matplotlib is imported only when a plot is made.

* :func:`plot_smooth` - the mesh before and after, every cell coloured by its
  minimum angle, the worst cells marked, a zoom on the worst cell (before and
  after), and log-scale histograms of the cell minimum and maximum angles.
* :func:`plot_compare` - minimum angle and area ratio per pass for each method
  (the paper's Figure 13).
* :func:`worst_cells`, :func:`zoom_window`, :func:`edge_widths`, :func:`draw_mesh` - which
  cells the figure marks and zooms on, which edges it draws, and how it draws cells: from
  :mod:`anglesmooth.meshplot`, re-exported here.

Drawn so that the few bad cells of a large or graded mesh are found at a glance:

* Cells are filled as triangles (quads split in two along the diagonal that
  keeps both halves valid) with one colour each, in one rasterized renderer call
  (Gouraud triangles with equal corner colours: no seams, no ``Path`` per cell),
  which stays fast at a million cells.
* Cell edges are drawn only where cells are at least :data:`EDGE_MIN_PX` pixels wide on
  screen: none when the median cell is narrower (a 300k-cell mesh shows its colours, not
  black noise), otherwise only between cells that wide, fading in up to
  :data:`EDGE_FULL_PX` (a graded mesh shows the edges of its coarse part, and its
  refined ring is not solid black).  The zoom panels show the edges.
* The :data:`WORST_K` cells with the smallest minimum angle are circled, the
  :data:`WORST_K` cells with the largest maximum angle marked with diamonds
  (fixed-size markers, visible however small the cell).
* Histogram counts are on a log scale, so one bad cell is one visible bar.

Figures are built with ``matplotlib.figure.Figure`` on the Agg canvas (no
pyplot, no global state, no display needed) and written atomically.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from . import _paths
from .errors import AngleSmoothError
from .meshplot import (
    CMAP,
    EDGE_FULL_PX,
    EDGE_MIN_PX,
    WORST_K,
    ZOOM_HALF_CELLS,
    _cell_nodes,
    _cells_in,
    _centroids,
    _extremes,
    _px_per_unit,
    _smallest,
    draw_mesh,
    edge_alpha,
    edge_widths,
    worst_cells,
    zoom_window,
)
from .quality import cell_areas, degenerate_cells, inverted_cells
from .topology import CellTopology

__all__ = [
    "MISSING_MATPLOTLIB",
    "compare_figure",
    "draw_mesh",
    "edge_alpha",
    "edge_widths",
    "plot_compare",
    "plot_smooth",
    "require_matplotlib",
    "smooth_figure",
    "worst_cells",
    "zoom_window",
]

MISSING_MATPLOTLIB = "plotting needs matplotlib: pip install 'anglesmooth[plot]'"

DPI = 110
#: Inverted cells marked with a cross in each mesh panel, at most.
MAX_INVERTED_MARKS = 500
MIN_COLOUR = "#1030ff"  # circles: smallest minimum angles
MAX_COLOUR = "#c000c0"  # diamonds: largest maximum angles
#: Fill and marker of degenerate (zero or nearly zero area, not inverted) cells; inverted cells are black.
DEGENERATE_COLOUR = "#00c8ff"


def require_matplotlib() -> None:
    """Raise :class:`AngleSmoothError` (exit 3) with an install hint when matplotlib is missing."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise AngleSmoothError(MISSING_MATPLOTLIB) from None


def _figure(width: float, height: float):
    require_matplotlib()
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _save(fig, path: str | Path) -> None:
    """Write the PNG like every output (atomically, or into a device / FIFO; see ``_paths``)."""

    def write(tmp):
        with open(tmp, "wb") as fh:
            # print_png rather than savefig: savefig draws twice when the figure has a layout engine
            fig.canvas.print_png(fh)

    try:
        _paths.atomic_write(path, write, suffix=".png", what="cannot write plot")
    except OSError as exc:
        raise AngleSmoothError(f"cannot write plot '{path}': {exc.strerror or exc}") from None


def _draw_mesh(ax, topo, points, values, norm, cmap):
    """Every cell and every edge (the small meshes of ``benchmarks/paper``); sets equal aspect, no ticks."""
    draw_mesh(ax, points, topo, values, norm=norm, cmap=cmap)
    ax.update_datalim(np.asarray(points, dtype=np.float64)[:, :2])
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set_xticks([])
    ax.set_yticks([])


def _mesh_axes(ax, window) -> None:
    ax.set_xlim(window[0], window[1])
    ax.set_ylim(window[2], window[3])
    ax.set_aspect("equal", adjustable="box")
    ax.set_xticks([])
    ax.set_yticks([])


def _halo():
    from matplotlib import patheffects

    return [patheffects.withStroke(linewidth=3.2, foreground="white")]


def _mark(ax, cent: np.ndarray, lo: np.ndarray, hi: np.ndarray, inverted: np.ndarray,
          degenerate: np.ndarray) -> None:
    """Fixed-size markers on the worst cells: diamonds under circles (the minimum angle matters most),
    a black cross on each inverted cell and a :data:`DEGENERATE_COLOUR` plus on each degenerate one (the
    first :data:`MAX_INVERTED_MARKS` of each)."""
    for idx, marker, size, colour, gid in ((hi, "D", 8, MAX_COLOUR, "worst-max"), (lo, "o", 11, MIN_COLOUR, "worst-min")):
        if idx.size:
            (line,) = ax.plot(cent[idx, 0], cent[idx, 1], linestyle="none", marker=marker, markersize=size,
                              markerfacecolor="none", markeredgecolor=colour, markeredgewidth=1.6, zorder=5,
                              path_effects=_halo())
            line.set_gid(gid)
    if inverted.size:
        idx = inverted[:MAX_INVERTED_MARKS]
        ax.plot(cent[idx, 0], cent[idx, 1], linestyle="none", marker="X", markersize=9, markerfacecolor="k",
                markeredgecolor="white", markeredgewidth=0.8, zorder=6, gid="inverted")
    if degenerate.size:
        idx = degenerate[:MAX_INVERTED_MARKS]
        ax.plot(cent[idx, 0], cent[idx, 1], linestyle="none", marker="P", markersize=9,
                markerfacecolor=DEGENERATE_COLOUR, markeredgecolor="k", markeredgewidth=0.8, zorder=6,
                gid="degenerate")


def _outline(ax, points, topo, idx: np.ndarray, colour: str, gid: str) -> None:
    """Outline the cells ``idx`` (in the zoom panels, where the cells are large enough)."""
    from matplotlib.collections import PolyCollection

    if not idx.size:
        return
    polys = [points[_cell_nodes(topo, int(c))] for c in idx]
    ax.add_collection(PolyCollection(polys, facecolors="none", edgecolors=colour, linewidths=2.0, zorder=4,
                                     path_effects=_halo(), gid=gid))


def _window_marker(ax, window, px_per_unit: float) -> None:
    from matplotlib.patches import Rectangle

    x0, x1, y0, y1 = window
    if (x1 - x0) * px_per_unit >= 12:
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, edgecolor="k", linewidth=1.2,
                               linestyle="--", zorder=6, gid="zoom-window"))
    else:  # too small to see as a rectangle: a fixed-size square
        ax.plot([(x0 + x1) / 2], [(y0 + y1) / 2], marker="s", markersize=16, markerfacecolor="none",
                markeredgecolor="k", markeredgewidth=1.2, linestyle="none", zorder=6, gid="zoom-window")


def _hist(ax, before: np.ndarray, after: np.ndarray, bins: np.ndarray, labels, xlabel: str, lines) -> None:
    lo, hi = bins[0], bins[-1]
    ax.hist(np.clip(before, lo, hi), bins=bins, color="0.65", label=labels[0], log=True)
    ax.hist(np.clip(after, lo, hi), bins=bins, histtype="step", color="C0", linewidth=1.5, label=labels[1], log=True)
    ax.set_yscale("log")
    ax.set_ylim(bottom=0.5)
    for x in lines:
        ax.axvline(x, color="k", linestyle=":", linewidth=0.8)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("cells (log scale)")
    ax.legend(fontsize="small")


def _span(*pts: np.ndarray):
    allp = np.vstack(pts)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    pad = 0.02 * max(float((hi - lo).max()), 1e-300)
    return (lo[0] - pad, hi[0] + pad, lo[1] - pad, hi[1] + pad)


def smooth_figure(topo: CellTopology, before: np.ndarray, after: np.ndarray, *, title: str = "",
                  k: int = WORST_K):
    """The figure of :func:`plot_smooth` (a matplotlib ``Figure``, not saved).

    Axes carry labels for inspection: ``"mesh before"``, ``"mesh after"``,
    ``"zoom before"``, ``"zoom after"``, ``"hist min"``, ``"hist max"``; artists carry
    gids ``"cells"``, ``"edges"``, ``"worst-min"``, ``"worst-max"``, ``"inverted"``, ``"degenerate"``,
    ``"zoom-window"``.  Inverted cells (signed area < 0, :func:`~anglesmooth.quality.inverted_cells`)
    are filled black and crossed; degenerate cells (zero or nearly zero area, not inverted,
    :func:`~anglesmooth.quality.degenerate_cells`) are filled :data:`DEGENERATE_COLOUR` and marked
    with a plus (their fill is a sliver or nothing).  Both are counted in the titles, have a legend
    entry and are left out of the minimum-angle histogram (an inverted cell's angles are > 180°, in
    the maximum-angle one's last bin); the zoom is on the most folded inverted cell after, if any,
    else on a degenerate cell after, else on the cell with the smallest minimum angle after.
    """
    import matplotlib
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.lines import Line2D

    before = np.asarray(before, dtype=np.float64)[:, :2]
    after = np.asarray(after, dtype=np.float64)[:, :2]
    n_cells = topo.n_tri + topo.n_quad
    if n_cells == 0:
        raise AngleSmoothError("nothing to plot: the mesh has no cells")
    stages = {"before": before, "after": after}
    mins, maxs, cent, areas, inverted, degenerate, colour = {}, {}, {}, {}, {}, {}, {}
    ideal = 90.0 if topo.n_quad else 60.0
    for s, p in stages.items():
        mins[s], maxs[s] = _extremes(p, topo)
        cent[s] = _centroids(p, topo)
        areas[s] = cell_areas(p, topo)
        inverted[s] = inverted_cells(p, topo)  # as the report counts them: disjoint categories
        degenerate[s] = degenerate_cells(p, topo)
        colour[s] = mins[s].copy()
        colour[s][inverted[s]] = -1.0  # below the colour scale: drawn black (an inverted cell's angles are > 180)
        colour[s][degenerate[s]] = ideal + 1.0  # above it (no cell's minimum angle is): DEGENERATE_COLOUR
    bad = {s: int(inverted[s].size) for s in stages}
    flat = {s: int(degenerate[s].size) for s in stages}
    worst = {s: (_smallest(mins[s], k), _smallest(-maxs[s], k)) for s in stages}
    # zoom on the worst cell after: the most folded inverted cell if any, else a degenerate cell, else the
    # smallest minimum angle
    if bad["after"]:
        focus = int(inverted["after"][np.argmax(maxs["after"][inverted["after"]])])
    elif flat["after"]:
        focus = int(degenerate["after"][0])
    else:
        focus = int(worst["after"][0][0])
    window = zoom_window(after, topo, focus, centroids=cent["after"], areas=areas["after"])
    extent = _span(before, after)

    norm = Normalize(vmin=0.0, vmax=ideal)
    cmap = matplotlib.colormaps[CMAP].with_extremes(under="black", over=DEGENERATE_COLOUR)
    aspect = (extent[3] - extent[2]) / (extent[1] - extent[0]) if extent[1] > extent[0] else 1.0
    mesh_h = float(np.clip(6.3 * aspect, 2.5, 7.5))
    fig = _figure(14.5, mesh_h + 4.9)
    if title:
        fig.suptitle(title)
    grid = fig.add_gridspec(2, 4, height_ratios=[mesh_h, 3.6])
    axes = {"mesh before": fig.add_subplot(grid[0, 0:2]), "mesh after": fig.add_subplot(grid[0, 2:4]),
            "zoom before": fig.add_subplot(grid[1, 0]), "zoom after": fig.add_subplot(grid[1, 1]),
            "hist min": fig.add_subplot(grid[1, 2]), "hist max": fig.add_subplot(grid[1, 3])}
    for label, ax in axes.items():
        ax.set_label(label)
    for s in stages:
        ax = axes[f"mesh {s}"]
        _mesh_axes(ax, extent)
        inv = (f", {bad[s]} inverted" if bad[s] else "") + (f", {flat[s]} degenerate" if flat[s] else "")
        ax.set_title(f"{s}: min angle {mins[s].min():.2f}°, max angle {maxs[s].max():.2f}°{inv}")
        _mesh_axes(axes[f"zoom {s}"], window)
        axes[f"zoom {s}"].set_title(f"{s}: zoom on the worst cell after", fontsize="medium")
    any_bad = bool(bad["before"] or bad["after"])
    any_flat = bool(flat["before"] or flat["after"])
    extend = {(False, False): "neither", (True, False): "min", (False, True): "max", (True, True): "both"}
    fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=[axes["mesh before"], axes["mesh after"]],
                 label="cell minimum angle (°)" + ("; black: inverted" if any_bad else "")
                 + ("; cyan: degenerate" if any_flat else ""), shrink=0.85, extend=extend[any_bad, any_flat])
    kk = min(k, n_cells)
    handles = [Line2D([], [], linestyle="none", marker="o", markersize=9, markerfacecolor="none",
                      markeredgecolor=MIN_COLOUR, markeredgewidth=1.6, label=f"smallest minimum angles ({kk} cell{'s' * (kk > 1)})"),
               Line2D([], [], linestyle="none", marker="D", markersize=7, markerfacecolor="none",
                      markeredgecolor=MAX_COLOUR, markeredgewidth=1.6, label=f"largest maximum angles ({kk} cell{'s' * (kk > 1)})"),
               Line2D([], [], linestyle="none", marker="s", markersize=9, markerfacecolor="none",
                      markeredgecolor="k", label="zoom window")]
    if any_bad:
        handles.append(Line2D([], [], linestyle="none", marker="X", markersize=9, markerfacecolor="k",
                              markeredgecolor="white", label="inverted cells (area < 0)"))
    if any_flat:
        handles.append(Line2D([], [], linestyle="none", marker="P", markersize=9, markerfacecolor=DEGENERATE_COLOUR,
                              markeredgecolor="k", label="degenerate cells (zero area)"))
    fig.legend(handles=handles, loc="outside lower center", ncols=len(handles), frameon=False)

    mbins = np.arange(0.0, ideal + 1.0, 1.0)
    hidden = {s: ", ".join([f"{bad[s]} inverted"] * bool(bad[s]) + [f"{flat[s]} degenerate"] * bool(flat[s]))
              for s in stages}
    labels = [f"{s}" + (f" ({hidden[s]} not shown)" if hidden[s] else "") for s in stages]
    valid = {s: np.delete(mins[s], np.concatenate([inverted[s], degenerate[s]])) for s in stages}
    _hist(axes["hist min"], valid["before"], valid["after"], mbins, labels, "cell minimum angle (°)", [20])
    axes["hist min"].set_title("cell minimum angles")
    xbins = np.concatenate([np.arange(60.0 if topo.n_tri else 90.0, 181.0, 1.0), [185.0]])
    _hist(axes["hist max"], maxs["before"], maxs["after"], xbins, list(stages),
          "cell maximum angle (°); red: > 180°, invalid", [130, 150])
    axes["hist max"].axvspan(180, 185, color="r", alpha=0.2, linewidth=0)
    axes["hist max"].set_title("cell maximum angles")

    # freeze the layout before adding the mesh artists: the pixel size of a cell is then known,
    # and a million polygons never enter the layout computation
    fig.get_layout_engine().execute(fig)
    fig.set_layout_engine("none")
    for s, pts in stages.items():
        lo, hi = worst[s]
        ax = axes[f"mesh {s}"]
        ppu = _px_per_unit(ax)
        draw_mesh(ax, pts, topo, colour[s], norm=norm, cmap=cmap, px_per_unit=ppu)
        _mark(ax, cent[s], lo, hi, inverted[s], degenerate[s])
        _window_marker(ax, window, ppu)
        zax = axes[f"zoom {s}"]
        inside = _cells_in(pts, topo, window)
        draw_mesh(zax, pts, topo, colour[s], norm=norm, cmap=cmap, px_per_unit=_px_per_unit(zax), cells=inside)
        shown = set(inside.tolist())
        _outline(zax, pts, topo, np.array([c for c in hi if c in shown], dtype=np.int64), MAX_COLOUR, "worst-max")
        _outline(zax, pts, topo, np.array([c for c in lo if c in shown], dtype=np.int64), MIN_COLOUR, "worst-min")
        c = cent[s][focus]
        towards = np.sign([(window[0] + window[1]) / 2 - c[0], (window[2] + window[3]) / 2 - c[1]]) + (0.5, 0.5)
        label = "inverted" if focus in inverted[s] else "degenerate" if focus in degenerate[s] \
            else f"{mins[s][focus]:.1f}°"
        zax.annotate(label, c, xytext=tuple(9 * np.sign(towards)), textcoords="offset points",
                     ha="left" if towards[0] > 0 else "right", va="bottom" if towards[1] > 0 else "top",
                     fontsize="small", fontweight="bold", color="k", path_effects=_halo(), zorder=7,
                     annotation_clip=True, clip_on=True)
    return fig


def plot_smooth(path: str | Path, topo: CellTopology, before: np.ndarray, after: np.ndarray, *,
                title: str = "") -> None:
    """Write a PNG: the mesh before / after coloured by cell minimum angle, worst cells marked, zoom, histograms.

    ``before`` and ``after`` are (N, 2) coordinates of the same mesh (``topo``).
    See :func:`smooth_figure`.
    """
    _save(smooth_figure(topo, before, after, title=title), path)


def compare_figure(histories: Mapping[str, Mapping[str, Sequence[float | None]]], *, title: str = ""):
    """The figure of :func:`plot_compare` (not saved)."""
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
    return fig


def plot_compare(path: str | Path, histories: Mapping[str, Mapping[str, Sequence[float | None]]], *,
                 title: str = "") -> None:
    """Write a PNG with the per-pass curves of every method.

    ``histories`` maps a method name to ``{"min_angle": [...], "area_ratio": [...]}``,
    index 0 being the input mesh; an infinite area ratio may be given as None.
    """
    _save(compare_figure(histories, title=title), path)
