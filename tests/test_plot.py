"""Plots of real meshes: valid PNGs, the right worst cells marked, edges only where visible, log histograms."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

pytest.importorskip("matplotlib")
pytest.importorskip("scipy")

from matplotlib.collections import LineCollection  # noqa: E402
from matplotlib.colors import Normalize  # noqa: E402

from anglesmooth import generate as gen  # noqa: E402
from anglesmooth import meshplot, plot  # noqa: E402
from anglesmooth.errors import AngleSmoothError  # noqa: E402
from anglesmooth.mesh import Mesh2D  # noqa: E402
from anglesmooth.quality import cell_areas, cell_max_angles, cell_min_angles, inverted_cells  # noqa: E402
from anglesmooth.topology import build_cell_topology  # noqa: E402

PNG = b"\x89PNG\r\n\x1a\n"


def _moved(mesh: Mesh2D, scale: float = 0.2, seed: int = 0) -> np.ndarray:
    """Interior nodes jittered (a stand-in for a smoothed mesh; the figure only needs two coordinate sets)."""
    topo = build_cell_topology(mesh)
    rng = np.random.default_rng(seed)
    h = np.sqrt(np.abs(cell_areas(mesh.points, topo)).mean())
    pts = mesh.points.copy()
    free = ~topo.fixed
    pts[free] += rng.uniform(-scale * h, scale * h, size=(int(free.sum()), 2))
    return pts


def _by_label(fig, label):
    (ax,) = [a for a in fig.axes if a.get_label() == label]
    return ax


def _gid(ax, gid):
    return [a for a in ax.get_children() if a.get_gid() == gid]


@pytest.fixture(scope="module")
def large():
    m = gen.random_delaunay(60_000, seed=3)
    topo = build_cell_topology(m)
    return m, topo, _moved(m)


@pytest.fixture(scope="module")
def large_fig(large):
    m, topo, after = large
    return plot.smooth_figure(topo, m.points, after, title="large")


SMALL = {"triangles": lambda: gen.paper_triangle_mesh(seed=1), "quads": lambda: gen.paper_quad_mesh(seed=4),
         "mixed": lambda: gen.paper_mixed_mesh(seed=4)}


@pytest.fixture(scope="module", params=list(SMALL))
def small_fig(request):
    m = SMALL[request.param]()
    topo = build_cell_topology(m)
    return m, topo, plot.smooth_figure(topo, m.points, _moved(m), title=request.param)


# ---------------------------------------------------------------- worst cells


@given(st.lists(st.integers(0, 6), min_size=1, max_size=40), st.integers(0, 45))
@settings(max_examples=60, deadline=None)
def test_smallest_is_a_stable_sort_prefix(values, k):
    v = np.array(values, dtype=float)  # many ties
    assert plot._smallest(v, k).tolist() == np.argsort(v, kind="stable")[:k].tolist()


@pytest.mark.parametrize("mesh", [gen.random_delaunay(3000, seed=5), gen.paper_mixed_mesh(seed=2),
                                  gen.paper_quad_mesh(seed=1), gen.structured_triangles(8, 6)],
                         ids=["delaunay", "mixed", "quads", "equilateral-ties"])
@pytest.mark.parametrize("k", [1, 20, 10_000])
def test_worst_cells_against_a_full_sort(mesh, k):
    topo = build_cell_topology(mesh)
    pts = _moved(mesh, 0.3, seed=k)
    lo, hi = plot.worst_cells(pts, topo, k)
    mins, maxs = cell_min_angles(pts, topo), cell_max_angles(pts, topo)
    assert lo.tolist() == np.argsort(mins, kind="stable")[:k].tolist()
    assert hi.tolist() == np.argsort(-maxs, kind="stable")[:k].tolist()
    assert lo.size == hi.size == min(k, topo.n_tri + topo.n_quad)


def test_worst_cells_on_a_known_mesh():
    # three triangles of a fan: the flattest one is worst on both counts, the equilateral one is best
    pts = [[0, 0], [1, 0], [0.5, np.sqrt(3) / 2], [-0.5, np.sqrt(3) / 2], [2.0, -0.05]]
    m = Mesh2D.from_arrays(pts, triangles=[[0, 1, 2], [0, 2, 3], [0, 4, 1]])
    lo, hi = plot.worst_cells(m.points, build_cell_topology(m), k=2)
    assert lo.tolist() == [2, 0] and hi.tolist() == [2, 0]


def test_marked_cells_are_the_worst_cells(large, large_fig):
    m, topo, after = large
    for stage, pts in (("before", m.points), ("after", after)):
        ax = _by_label(large_fig, f"mesh {stage}")
        lo, hi = plot.worst_cells(pts, topo, plot.WORST_K)
        cent = plot._centroids(pts, topo)
        (circles,) = _gid(ax, "worst-min")
        (diamonds,) = _gid(ax, "worst-max")
        np.testing.assert_allclose(np.c_[circles.get_xdata(), circles.get_ydata()], cent[lo])
        np.testing.assert_allclose(np.c_[diamonds.get_xdata(), diamonds.get_ydata()], cent[hi])
        assert circles.get_marker() == "o" and diamonds.get_marker() == "D"


def test_zoom_is_on_the_worst_cell_after(large, large_fig):
    m, topo, after = large
    bad = np.flatnonzero(cell_areas(after, topo) <= 0)
    assert bad.size  # the jitter folds a few cells: the zoom goes to the most folded one
    worst = bad[np.argmax(cell_max_angles(after, topo)[bad])]
    c = plot._centroids(after, topo)[worst]
    for stage in ("before", "after"):
        ax = _by_label(large_fig, f"zoom {stage}")
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        assert x0 < c[0] < x1 and y0 < c[1] < y1
        assert (x1 - x0) < 0.05 * np.ptp(m.points[:, 0])  # a zoom, not the whole mesh
        (cells,) = _gid(ax, "cells")
        assert 0 < cells.verts.shape[0] < 2000  # only the cells in the window are drawn
    outlined = _gid(_by_label(large_fig, "zoom after"), "worst-max")  # a folded cell has the largest angles
    assert outlined and any(np.allclose(p.vertices[:3], after[topo.tri[worst]]) for p in outlined[0].get_paths())
    labels = [t.get_text() for t in _by_label(large_fig, "zoom after").texts]
    assert labels == ["inverted"]


def test_zoom_without_inverted_cells_is_on_the_smallest_minimum_angle():
    import anglesmooth

    m = gen.paper_mixed_mesh(seed=3)
    result = anglesmooth.smooth(m, "angle", passes=3)  # guarded: nothing inverted
    topo, after = result.topology, result.points
    assert not (cell_areas(after, topo) <= 0).any()
    fig = plot.smooth_figure(topo, m.points, after)
    worst = plot.worst_cells(after, topo, 1)[0][0]
    c = plot._centroids(after, topo)[worst]
    ax = _by_label(fig, "zoom after")
    assert ax.get_xlim()[0] < c[0] < ax.get_xlim()[1] and ax.get_ylim()[0] < c[1] < ax.get_ylim()[1]
    assert [t.get_text() for t in ax.texts] == [f"{cell_min_angles(after, topo)[worst]:.1f}°"]
    assert not _gid(_by_label(fig, "mesh after"), "inverted")


def test_inverted_cells_are_black_and_crossed(large, large_fig):
    m, topo, after = large
    bad = inverted_cells(after, topo)
    ax = _by_label(large_fig, "mesh after")
    (crosses,) = _gid(ax, "inverted")
    np.testing.assert_allclose(np.c_[crosses.get_xdata(), crosses.get_ydata()],
                               plot._centroids(after, topo)[bad[: plot.MAX_INVERTED_MARKS]])
    (cells,) = _gid(ax, "cells")
    black = np.all(cells.rgba[:, :3] == 0, axis=1)  # triangles only here: one drawn triangle per cell
    assert np.flatnonzero(black).tolist() == bad.tolist()


def test_zoom_window_stays_in_the_mesh_and_around_the_cell():
    m = gen.graded_mesh(seed=2)
    topo = build_cell_topology(m)
    cent = plot._centroids(m.points, topo)
    corner = int(np.argmin(cent.sum(axis=1)))  # the cell nearest (0, 0), on the boundary
    x0, x1, y0, y1 = plot.zoom_window(m.points, topo, corner)
    half = (x1 - x0) / 2
    assert y1 - y0 == pytest.approx(2 * half)
    c = cent[corner]
    assert x0 <= c[0] - 0.5 * half + 1e-9 and c[0] + 0.5 * half - 1e-9 <= x1  # well inside the window
    assert x0 >= c[0] - 1.5 * half - 1e-9 and y0 >= c[1] - 1.5 * half - 1e-9  # slid towards the mesh


def test_zoom_window_of_a_tiny_mesh_is_the_whole_mesh():
    m = Mesh2D.from_arrays([[0, 0], [1, 0], [0, 1]], triangles=[[0, 1, 2]])
    x0, x1, y0, y1 = plot.zoom_window(m.points, build_cell_topology(m), 0)
    assert x0 < 0 and y0 < 0 and x1 > 1 and y1 > 1 and x1 - x0 == pytest.approx(y1 - y0)
    assert x1 - x0 < 1.2


# ---------------------------------------------------------------- edges by on-screen size


def test_large_mesh_is_drawn_without_edges(large, large_fig):
    m, topo, _ = large
    for stage in ("before", "after"):
        ax = _by_label(large_fig, f"mesh {stage}")
        assert not _gid(ax, "edges")
        assert not [a for a in ax.collections if isinstance(a, LineCollection)]
        (cells,) = _gid(ax, "cells")
        assert cells.get_rasterized()
        assert cells.verts.shape == (topo.n_tri, 3, 2) and cells.rgba.shape == (topo.n_tri, 4)
        # the zoom on the same mesh shows its edges
        assert _gid(_by_label(large_fig, f"zoom {stage}"), "edges")


def test_small_mesh_is_drawn_with_its_edges(small_fig):
    m, topo, fig = small_fig
    for stage, pts in (("before", m.points), ("after", None)):
        ax = _by_label(fig, f"mesh {stage}")
        (edges,) = _gid(ax, "edges")
        n = len(edges.get_segments())
        assert n >= 0.97 * topo.n_edges  # all but those between the tiniest cells
        if pts is not None:
            wide = plot.edge_widths(pts, topo) * plot._px_per_unit(ax) >= plot.EDGE_MIN_PX
            assert n == wide.sum()


def test_edges_drawn_exactly_where_the_cells_are_wide_enough_on_screen():
    from matplotlib.figure import Figure

    m = gen.graded_mesh(seed=2)  # cells from ~1 to ~15 units wide
    topo = build_cell_topology(m)
    width = plot.edge_widths(m.points, topo)
    values = cell_min_angles(m.points, topo)
    partly = 0
    for ppu in (0.2, 1.0, 3.0, 50.0):
        ax = Figure().add_subplot()
        art = plot.draw_mesh(ax, m.points, topo, values, norm=Normalize(0, 60), px_per_unit=ppu)
        wide = width * ppu >= plot.EDGE_MIN_PX
        if meshplot._median_width(m.points, topo, None) * ppu < plot.EDGE_MIN_PX:
            wide[:] = False  # most cells too small: no edges at all
        if not wide.any():
            assert art["edges"] is None and not _gid(ax, "edges")
            continue
        drawn = np.asarray(art["edges"].get_segments())
        np.testing.assert_array_equal(drawn, m.points[topo.edges[wide]])
        alphas = art["edges"].get_colors()[:, 3]
        np.testing.assert_allclose(alphas, plot.edge_alpha(width[wide] * ppu))
        partly += 0 < wide.sum() < topo.n_edges  # the narrow cells of the refined corner are left out
    assert partly >= 1
    assert not (width * 0.2 >= plot.EDGE_MIN_PX).any() and (width * 50 >= plot.EDGE_MIN_PX).all()


def test_median_width_rule_drops_every_edge():
    from matplotlib.figure import Figure

    m = gen.graded_mesh(seed=2)
    topo = build_cell_topology(m)
    median = meshplot._median_width(m.points, topo, None)
    values = cell_min_angles(m.points, topo)
    ppu = 0.99 * plot.EDGE_MIN_PX / median  # the median cell just under the threshold
    assert (plot.edge_widths(m.points, topo) * ppu >= plot.EDGE_MIN_PX).any()  # some would pass alone
    art = plot.draw_mesh(Figure().add_subplot(), m.points, topo, values, norm=Normalize(0, 60), px_per_unit=ppu)
    assert art["edges"] is None
    art = plot.draw_mesh(Figure().add_subplot(), m.points, topo, values, norm=Normalize(0, 60),
                         px_per_unit=1.02 * plot.EDGE_MIN_PX / median)
    assert art["edges"] is not None


def test_edge_widths_by_hand():
    # two unit squares and a right triangle of legs 1 (width sqrt(2 * 0.5) = 1): every width is 1
    m = Mesh2D.from_arrays([[0, 0], [1, 0], [2, 0], [0, 1], [1, 1], [2, 1], [1, 2]],
                           triangles=[[3, 4, 6]], quads=[[0, 1, 4, 3], [1, 2, 5, 4]])
    topo = build_cell_topology(m)
    np.testing.assert_allclose(plot.edge_widths(m.points, topo), 1.0)
    big = m.points * 10
    np.testing.assert_allclose(plot.edge_widths(big, topo), 10.0)


def test_edge_alpha_ramp():
    a = plot.edge_alpha(np.array([0.0, plot.EDGE_MIN_PX - 1e-9, plot.EDGE_MIN_PX, plot.EDGE_FULL_PX, 1e6]))
    assert a.tolist() == pytest.approx([0.0, 0.0, 0.2, 0.8, 0.8])


def test_quads_split_into_two_valid_triangles():
    # a non-convex quad (dart): only the diagonal through the reflex corner gives two valid halves
    pts = np.array([[0, 0], [2, 0], [0.6, 0.6], [0, 2], [2.5, 2.5]], float)
    m = Mesh2D.from_arrays(pts, triangles=[[1, 4, 2]], quads=[[0, 1, 2, 3]])
    topo = build_cell_topology(m)
    tris, owner = meshplot._split(pts, topo, None)
    assert owner.tolist() == [0, 1, 1]
    p = pts[tris]
    cross = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0])
    assert (cross > 0).all()
    assert cross[1:].sum() / 2 == pytest.approx(cell_areas(pts, topo)[1])


# ---------------------------------------------------------------- histograms and files


def test_histograms_are_log_scale(small_fig):
    _, _, fig = small_fig
    for label in ("hist min", "hist max"):
        ax = _by_label(fig, label)
        assert ax.get_yscale() == "log"
        before, after = (t.get_text() for t in ax.get_legend().get_texts())
        assert before.startswith("before") and after.startswith("after")
        assert 0 < ax.get_ylim()[0] < 1  # a bin holding one bad cell is a visible bar


def test_plot_smooth_writes_a_png(small_fig, tmp_path):
    from PIL import Image

    out = tmp_path / "fig.png"
    plot._save(small_fig[2], out)  # what plot_smooth does after smooth_figure
    assert out.read_bytes()[:8] == PNG
    with Image.open(out) as im:
        im.verify()
    with Image.open(out) as im:
        assert im.size[0] > 1000 and im.size[1] > 800
    assert [p.name for p in tmp_path.iterdir()] == [out.name]  # no temporary file left


def test_plot_smooth_end_to_end(tmp_path):
    m = gen.structured_quads(4, 3)
    topo = build_cell_topology(m)
    out = tmp_path / "q.png"
    plot.plot_smooth(out, topo, m.points, _moved(m), title="tiny")
    assert out.read_bytes()[:8] == PNG


def test_large_mesh_png(large_fig, tmp_path):
    out = tmp_path / "large.png"
    plot._save(large_fig, out)
    assert out.read_bytes()[:8] == PNG and out.stat().st_size > 50_000


def test_inverted_cells_are_counted_in_the_titles(small_fig):
    m, topo, fig = small_fig
    after = _moved(m)  # the coordinates small_fig was drawn with (same seed)
    for stage, pts in (("before", m.points), ("after", after)):
        n_bad = int(inverted_cells(pts, topo).size)
        title = _by_label(fig, f"mesh {stage}").get_title()
        assert (f"{n_bad} inverted" in title) if n_bad else ("inverted" not in title)
    if topo.n_quad == 0:
        assert inverted_cells(after, topo).size  # the jitter folds some triangles: the case is exercised


def test_plot_compare_png(tmp_path):
    out = tmp_path / "cmp.png"
    hist = {"angle": {"min_angle": [1.0, 20.0, 30.0], "area_ratio": [100.0, 20.0, None]},
            "laplacian": {"min_angle": [1.0, 15.0, 18.0], "area_ratio": [100.0, 30.0, 25.0]}}
    plot.plot_compare(out, hist, title="t")
    assert out.read_bytes()[:8] == PNG


def test_unwritable_plot_path_is_a_clean_error(tmp_path):
    with pytest.raises(AngleSmoothError, match="cannot write plot"):
        plot._save(plot._figure(1, 1), tmp_path / "missing" / "p.png")
    assert not list(tmp_path.iterdir())


def test_paper_figures_helper_draws_every_edge():
    from matplotlib.figure import Figure

    m = gen.paper_mixed_mesh(seed=1)
    topo = build_cell_topology(m)
    ax = Figure().add_subplot()
    plot._draw_mesh(ax, topo, m.points, cell_min_angles(m.points, topo), Normalize(0, 90), "RdYlGn")
    (edges,) = _gid(ax, "edges")
    assert len(edges.get_segments()) == topo.n_edges
    x0, x1 = ax.get_xlim()
    assert x0 <= m.points[:, 0].min() and x1 >= m.points[:, 0].max()


def test_degenerate_cells_have_their_own_colour_marker_and_legend():
    """Zero-area cells are not inverted (the report keeps the two apart): own fill colour, plus marker, legend
    entry, title count; inverted cells stay black and crossed."""
    from matplotlib.colors import to_rgba

    from anglesmooth.quality import degenerate_cells, inverted_cells

    pts = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]], dtype=float)
    m = Mesh2D.from_arrays(pts, triangles=[[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    topo = build_cell_topology(m)
    flat, folded = pts.copy(), pts.copy()
    flat[4] = [0.5, 0.0]  # cell 0 collinear: degenerate, not inverted
    folded[4] = [0.5, -0.2]  # cell 0 inverted
    assert degenerate_cells(flat, topo).tolist() == [0] and inverted_cells(flat, topo).size == 0
    assert inverted_cells(folded, topo).tolist() == [0] and degenerate_cells(folded, topo).size == 0
    fig = plot.smooth_figure(topo, flat, folded)
    before, after = _by_label(fig, "mesh before"), _by_label(fig, "mesh after")
    (plus,) = _gid(before, "degenerate")
    np.testing.assert_allclose(np.c_[plus.get_xdata(), plus.get_ydata()], plot._centroids(flat, topo)[[0]])
    assert not _gid(before, "inverted") and not _gid(after, "degenerate")
    (cross,) = _gid(after, "inverted")
    np.testing.assert_allclose(np.c_[cross.get_xdata(), cross.get_ydata()], plot._centroids(folded, topo)[[0]])
    rgba = {s: _gid(ax, "cells")[0].rgba for s, ax in (("before", before), ("after", after))}
    np.testing.assert_allclose(rgba["before"][0], to_rgba(plot.DEGENERATE_COLOUR))
    np.testing.assert_allclose(rgba["after"][0], to_rgba("black"))
    assert not np.all(rgba["before"][1:, :3] == 0, axis=1).any()  # no other cell black before
    assert "1 degenerate" in before.get_title() and "inverted" not in before.get_title()
    assert "1 inverted" in after.get_title() and "degenerate" not in after.get_title()
    legend = [t.get_text() for lg in fig.legends for t in lg.get_texts()]
    assert "degenerate cells (zero area)" in legend and "inverted cells (area < 0)" in legend
    hist = [t.get_text() for t in _by_label(fig, "hist min").get_legend().get_texts()]
    assert hist == ["before (1 degenerate not shown)", "after (1 inverted not shown)"]
    assert [t.get_text() for t in _by_label(fig, "zoom before").texts] == ["degenerate"]
    cbar = [a for a in fig.axes if "cell minimum angle" in a.get_ylabel()]
    assert cbar and "cyan: degenerate" in cbar[0].get_ylabel() and "black: inverted" in cbar[0].get_ylabel()
