"""Named tiny meshes for the tests (import with ``from meshes import ...``).

Thin wrappers of :mod:`anglesmooth.generate`; every mesh is small, deterministic
and counter-clockwise.  pytest's default ``prepend`` import mode puts ``tests/``
on ``sys.path`` for test modules in it, so ``import meshes`` works there.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from anglesmooth import generate as gen
from anglesmooth.mesh import Mesh2D

__all__ = [
    "compact",
    "distorted",
    "five_element",
    "gmsh_files",
    "gmsh_two_squares",
    "mixed_small",
    "paper_mixed",
    "paper_quads",
    "paper_triangles",
    "regular_quads",
    "regular_triangles",
    "single_displaced",
    "two_regions",
    "with_hole",
]


def compact(points, triangles=None, quads=None, **kwargs) -> Mesh2D:
    """A mesh from arrays with the nodes no cell uses removed (indices renumbered)."""
    pts = np.asarray(points, dtype=np.float64)
    tri = np.zeros((0, 3), np.int64) if triangles is None else np.asarray(triangles, np.int64).reshape(-1, 3)
    quad = np.zeros((0, 4), np.int64) if quads is None else np.asarray(quads, np.int64).reshape(-1, 4)
    used = np.zeros(pts.shape[0], bool)
    used[tri.ravel()] = True
    used[quad.ravel()] = True
    new = np.cumsum(used) - 1
    return Mesh2D.from_arrays(pts[used], triangles=new[tri], quads=new[quad], **kwargs)


def regular_triangles(nx: int = 6, ny: int = 6) -> Mesh2D:
    """Equilateral triangles with unit edges (every interior node has six neighbours)."""
    return gen.structured_triangles(nx, ny)


def regular_quads(nx: int = 5, ny: int = 5) -> Mesh2D:
    """Unit squares."""
    return gen.structured_quads(nx, ny)


def single_displaced(kind: str = "triangle", offset=(0.2, -0.15)):
    """A regular mesh with one interior node moved by ``offset``.

    ``kind`` is ``"triangle"`` (6 x 6 equilateral) or ``"quad"`` (5 x 5 squares).
    Returns ``(mesh, node, original_position)``.
    """
    if kind == "triangle":
        m = regular_triangles(6, 6)
        node = 3 * 7 + 3  # row 3, column 3
    elif kind == "quad":
        m = regular_quads(5, 5)
        node = 2 * 6 + 2
    else:
        raise ValueError(f"kind must be 'triangle' or 'quad', not {kind!r}")
    pts = m.points.copy()
    orig = pts[node].copy()
    pts[node] += np.asarray(offset, dtype=np.float64)
    return m.with_points(pts), node, orig


def with_hole(kind: str = "quad") -> Mesh2D:
    """A 6 x 6 square with the central 2 x 2 cells removed (a hole: its nodes are boundary nodes).

    ``kind="triangle"`` splits every square by its diagonal.
    """
    m = gen.structured_quads(6, 6)
    q = m.quads
    centre = m.points[q].mean(axis=1)
    keep = ~((np.abs(centre[:, 0] - 3) < 1.1) & (np.abs(centre[:, 1] - 3) < 1.1))
    q = q[keep]
    if kind == "quad":
        return compact(m.points, quads=q)
    if kind == "triangle":
        tri = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
        return compact(m.points, triangles=tri)
    raise ValueError(f"kind must be 'triangle' or 'quad', not {kind!r}")


def two_regions() -> Mesh2D:
    """6 x 4 right triangles (squares cut by a diagonal) with region 1 for x < 3 and region 2 for x > 3.

    The interior nodes on the line x = 3 (y = 1, 2, 3) lie between regions and are fixed.
    """
    m = gen.structured_triangles(6, 4, equilateral=False)
    cx = m.points[m.triangles].mean(axis=1)[:, 0]
    return Mesh2D.from_arrays(m.points, triangles=m.triangles, triangle_region=np.where(cx < 3, 1, 2))


def mixed_small() -> Mesh2D:
    """6 x 4 unit squares: quads for x < 3, each square cut into two triangles for x > 3 (one region).

    Interior nodes on x = 3 touch both quads and triangles (mixed 3 : 2 spokes).
    """
    m = gen.structured_quads(6, 4)
    q = m.quads
    left = m.points[q].mean(axis=1)[:, 0] < 3
    qr = q[~left]
    tri = np.concatenate([qr[:, [0, 1, 2]], qr[:, [0, 2, 3]]])
    return Mesh2D.from_arrays(m.points, triangles=tri, quads=q[left])


def five_element(center=None) -> Mesh2D:
    """The 5-element polygon of the paper's Figures 2, 3 and 12 (free node 5)."""
    return gen.five_element_polygon(center)


def distorted() -> Mesh2D:
    """Figure 8: one free node (8) whose Laplacian target inverts two triangles."""
    return gen.distorted_mesh()


def paper_triangles(seed: int = 0) -> Mesh2D:
    """Section 5.1.2: 580 nodes, 1078 random Delaunay triangles in a 100 x 100 square."""
    return gen.paper_triangle_mesh(seed)


def paper_mixed(seed: int = 0) -> Mesh2D:
    """Section 5.1.2: the same triangulation with about 400 triangle pairs merged into quads."""
    return gen.paper_mixed_mesh(seed)


def paper_quads(seed: int = 0) -> Mesh2D:
    """Section 5.4: 571 nodes, 530 quads."""
    return gen.paper_quad_mesh(seed)


# --------------------------------------------------------------------------- gmsh-built files (tests that import gmsh)


def gmsh_two_squares():
    """Two unit squares side by side in the current gmsh model (OCC, fragmented, synchronized):
    ``(left, right)``, the surface tags of each."""
    import gmsh

    occ = gmsh.model.occ
    a = occ.addRectangle(0, 0, 0, 1, 1)
    b = occ.addRectangle(1, 0, 0, 1, 1)
    occ.fragment([(2, a)], [(2, b)])
    occ.synchronize()
    surfaces = [t for _, t in gmsh.model.getEntities(2)]
    left = [t for t in surfaces if occ.getCenterOfMass(2, t)[0] < 1]
    right = [t for t in surfaces if occ.getCenterOfMass(2, t)[0] > 1]
    return left, right


def gmsh_files(root, models, variants, after_meshing=None) -> dict:
    """``{(model, variant): path}``: every model (name -> a function building it in a fresh gmsh model)
    meshed in 2D and written in every variant (name -> (MSH version, binary)) under ``root``.

    ``after_meshing`` (name -> function) runs after meshing that model, before writing it.
    """
    import gmsh

    out = {}
    gmsh.initialize(readConfigFiles=False)
    try:
        for name, build in models.items():
            gmsh.clear()
            gmsh.option.restoreDefaults()
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.model.add(name)
            build()
            gmsh.model.mesh.generate(2)
            if after_meshing and name in after_meshing:
                after_meshing[name]()
            for var, (version, binary) in variants.items():
                gmsh.option.setNumber("Mesh.MshFileVersion", version)
                gmsh.option.setNumber("Mesh.Binary", binary)
                out[name, var] = Path(root) / f"{name}_{var}.msh"
                gmsh.write(str(out[name, var]))
    finally:
        gmsh.finalize()
    return out
