"""Mesh families for the quality matrix (``quality_matrix.py``), made the way users get them.

Each family builds one mesh per seed, deterministically (except the boundary layers: gmsh's 2D
BoundaryLayer meshing differs by a node or two from call to call, and from session to session by
more: its full-size seeds 0-2 are therefore committed in ``benchmarks/meshes/`` and read from there,
so that every run of the matrix judges the same meshes): gmsh (through its Python API, into a
temporary directory, read back with :func:`anglesmooth.read`) or :mod:`anglesmooth.generate`,
then, for the ``*-jitter`` / ``*-distorted`` families, every free node moved by a random offset
(uniform in a disc whose radius is a fraction of the node's mean incident edge length; fixed
nodes -- boundary, region interfaces -- never move).  The seed changes the jitter and, for the
gmsh families, the geometry or mesh size slightly, so that the seeds are different meshes.

Generated meshes are cached as ``.npz`` (points, cells, regions, pinned nodes) in a cache
directory, keyed by family, seed, size and :data:`VERSION`.

Families (``FAMILIES``; sizes at full size, ``tiny=True`` gives coarse versions for tests):

* ``quad-distorted-toothed``: a gear-like part (18 teeth with arc tips and roots, a central
  hole), gmsh frontal-Delaunay-for-quads + "simple full-quad" recombination, ~6.6k nodes /
  ~6.3k quads; interior jittered by up to 0.45 of the local edge length, then 40 % of the quads
  with two fixed corners on one boundary edge squashed (their free corners moved 90 % of the way
  to that edge: :func:`flatten_boundary_cells`).  This reproduces issue 12's public benchmark
  mesh, where the default got trapped (7 / 173 degrees) while Laplacian reached 41.5 / 144.
* ``quad-jitter-toothed``: the same without the squashing (jitter only).
* ``tri-distorted-toothed``: the same part in triangles (~14k), jittered likewise.
* ``quad-recombined-jitter``: an L-shaped plate with three holes, Blossom-recombined quads
  (~1.2k nodes), jitter 0.25.
* ``tri-curved``: an elliptic plate with three holes, triangles graded by a distance/threshold
  size field (fine at the holes), jitter 0.25.
* ``mixed-two-region``: a rectangle in two regions (physical groups), triangles left and
  recombined quads right, a hole in each; the interface is fixed; jitter 0.25.
* ``graded``: :func:`anglesmooth.generate.graded_mesh` (the paper's Figure 11 mesh).
* ``boundary-layer``: a channel with a cylinder, gmsh ``BoundaryLayer`` field with ``Quads=1``
  (thin quads around the cylinder, triangles elsewhere); jitter 0.1 of the nodes outside the layer.
* ``boundary-layer-hole``: a plate with a hole, a ``BoundaryLayer`` of about five layers of quads
  stretched up to 10:1 around it and coarse triangles elsewhere, not jittered (the inner layers' nodes
  have quads only: the default once sheared them to 127-140 deg; committed, like ``boundary-layer``).
* ``paper-tri``, ``paper-mixed``, ``paper-quad``: the paper-style meshes of
  ``benchmarks/paper/paper_experiments.py`` (``MESHES``), used as they are (no jitter).
* ``good-tri``, ``good-quad``: gmsh meshes of the elliptic plate with holes, uniform size
  (quads: "simple full-quad" recombination), not jittered (already good: smoothing must not make them worse).
"""

from __future__ import annotations

import math
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from anglesmooth.mesh import Mesh2D
from anglesmooth.topology import build_topology

sys.path.insert(0, str(Path(__file__).resolve().parent / "paper"))
import paper_experiments  # noqa: E402  (benchmarks/paper, reused: the paper tables' meshes)

#: Bump when a family's construction changes (invalidates the cache).
VERSION = 2


@dataclass(frozen=True)
class Family:
    name: str
    kind: str  # "tri", "quad" or "mixed"
    description: str
    build: Callable[[int, bool], Mesh2D]  # (seed, tiny) -> mesh
    distorted_quad: bool = False  # the verdict also compares the default with optimization's min angle
    paper: bool = False  # the verdict also checks the area ratio against the literal rule
    good: bool = False  # the verdict also checks "never worse than the input"
    min_angle_target: float | None = None  # issue 12's "Done means" threshold on the seeds' mean of the min angle


# --------------------------------------------------------------------------- helpers
def jitter(mesh: Mesh2D, amount: float, seed: int, movable: np.ndarray | None = None) -> Mesh2D:
    """Move every free node by a random offset of length up to ``amount`` x its mean incident edge length.

    Offsets are uniform in the disc (radius ``amount * h_i``).  Fixed nodes (the topology's
    boundary, interfaces and pinned nodes) and nodes outside ``movable`` stay put.
    """
    topo = build_topology(mesh)
    pts = np.array(mesh.points, dtype=np.float64)
    e0, e1 = topo.edges[:, 0], topo.edges[:, 1]
    length = np.hypot(*(pts[e1] - pts[e0]).T)
    n = pts.shape[0]
    deg = np.bincount(e0, minlength=n) + np.bincount(e1, minlength=n)
    h = (np.bincount(e0, length, n) + np.bincount(e1, length, n)) / np.maximum(deg, 1)
    free = ~np.asarray(topo.fixed, dtype=bool) & (deg > 0)
    if movable is not None:
        free &= movable
    rng = np.random.default_rng(seed)
    r = amount * h * np.sqrt(rng.uniform(0.0, 1.0, n))
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    pts[free, 0] += (r * np.cos(phi))[free]
    pts[free, 1] += (r * np.sin(phi))[free]
    return mesh.with_points(pts)


def flatten_boundary_cells(mesh: Mesh2D, fraction: float, probability: float, seed: int) -> Mesh2D:
    """Squash cells that sit on the boundary: the trap of issue 12.

    A candidate is a cell with one edge between two fixed nodes and every other corner free (a
    quad with two fixed corners, a triangle with one free corner).  With ``probability`` each
    candidate's free corners are moved towards the line of the fixed edge by ``fraction`` of
    their distance to it (0.9: to a tenth of the cell's height), so the cell becomes nearly flat
    (angles like 7, 12, 168, 173 degrees).  A node moves once (the first candidate that has it).
    """
    topo = build_topology(mesh)
    fixed = np.asarray(topo.fixed, dtype=bool)
    pts = np.array(mesh.points, dtype=np.float64)
    rng = np.random.default_rng(10_000 + seed)
    moved = np.zeros(pts.shape[0], dtype=bool)
    for cells in (np.asarray(topo.tri), np.asarray(topo.quad)):
        if not cells.size:
            continue
        k = cells.shape[1]
        fc = fixed[cells]
        take = rng.random(cells.shape[0]) < probability
        for j in range(k):
            a, b = cells[:, j], cells[:, (j + 1) % k]
            others = [cells[:, (j + i) % k] for i in range(2, k)]
            cand = take & fc[:, j] & fc[:, (j + 1) % k] & ~fc[:, [(j + i) % k for i in range(2, k)]].any(axis=1)
            for idx in np.flatnonzero(cand):  # a few hundred candidates, in order, so a node moves once
                vs = [o[idx] for o in others]
                if moved[vs].any():
                    continue
                ab = pts[b[idx]] - pts[a[idx]]
                nrm = np.array([-ab[1], ab[0]]) / np.hypot(ab[0], ab[1])
                for v in vs:
                    pts[v] -= fraction * float((pts[v] - pts[a[idx]]) @ nrm) * nrm
                moved[vs] = True
    return mesh.with_points(pts)


class _Gmsh:
    """``with _Gmsh("name") as g:`` -- an initialized, silent gmsh model; finalized on exit."""

    def __init__(self, name: str):
        self.name = name

    def __enter__(self):
        import gmsh

        gmsh.initialize(readConfigFiles=False, interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.model.add(self.name)
        self.gmsh = gmsh
        return gmsh

    def __exit__(self, *exc):
        self.gmsh.finalize()
        return False


def _mesh_and_read(gmsh, quads: bool, algorithm: int | None = None, recombination: int = 1) -> Mesh2D:
    """Generate the 2D mesh of the current model, write it to a temporary .msh, read it back.

    ``recombination``: gmsh's ``Mesh.RecombinationAlgorithm`` (1 Blossom, gmsh's default; 2 "simple
    full-quad", which avoids the quads with two edges on a curved boundary whose middle corner is
    ~180 degrees and cannot be repaired by moving the one free node).
    """
    import anglesmooth

    if quads:
        gmsh.option.setNumber("Mesh.Algorithm", 8 if algorithm is None else algorithm)  # frontal-Delaunay for quads
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.option.setNumber("Mesh.RecombinationAlgorithm", recombination)
    else:
        gmsh.option.setNumber("Mesh.Algorithm", 6 if algorithm is None else algorithm)  # frontal-Delaunay
    gmsh.model.mesh.generate(2)
    with tempfile.TemporaryDirectory(prefix="qmatrix-") as tmp:
        path = Path(tmp) / "mesh.msh"
        gmsh.write(str(path))
        return anglesmooth.read(path)


def _uniform_size(gmsh, h: float) -> None:
    gmsh.option.setNumber("Mesh.MeshSizeMin", h)
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)


_SIZE_FACTOR = (1.0, 0.97, 1.03, 0.985, 1.015)


def _factor(seed: int) -> float:
    return _SIZE_FACTOR[seed % len(_SIZE_FACTOR)] * (1.0 + 0.002 * (seed // len(_SIZE_FACTOR)))


# --------------------------------------------------------------------------- geometries
def gear_mesh(h: float, quads: bool, rotation: float = 0.0, n_teeth: int = 18,
              r_root: float = 1.0, r_tip: float = 1.2, r_hole: float = 0.35) -> Mesh2D:
    """A toothed part: ``n_teeth`` teeth (arc root, straight flanks, arc tip) around a central hole."""
    with _Gmsh("gear") as gmsh:
        g = gmsh.model.geo
        c = g.addPoint(0, 0, 0)
        pitch = 2 * math.pi / n_teeth
        frac = (0.0, 0.30, 0.42, 0.78)  # root arc 0..0.30, flank, tip arc 0.42..0.78, flank to the next tooth
        rad = (r_root, r_root, r_tip, r_tip)
        pts = []
        for k in range(n_teeth):
            for f, r in zip(frac, rad):
                a = rotation + (k + f) * pitch
                pts.append(g.addPoint(r * math.cos(a), r * math.sin(a), 0))
        curves = []
        for i, p in enumerate(pts):
            q = pts[(i + 1) % len(pts)]
            curves.append(g.addCircleArc(p, c, q) if i % 4 in (0, 2) else g.addLine(p, q))
        outer = g.addCurveLoop(curves)
        hp = [g.addPoint(r_hole * math.cos(a + rotation), r_hole * math.sin(a + rotation), 0)
              for a in np.arange(4) * math.pi / 2]
        hole = g.addCurveLoop([g.addCircleArc(hp[i], c, hp[(i + 1) % 4]) for i in range(4)])
        s = g.addPlaneSurface([outer, hole])
        g.synchronize()
        gmsh.model.addPhysicalGroup(2, [s], 1)
        _uniform_size(gmsh, h)
        return _mesh_and_read(gmsh, quads, recombination=2)


def l_plate_mesh(h: float, quads: bool, seed: int = 0) -> Mesh2D:
    """An L-shaped plate (2 x 2 minus the upper-right 1 x 1) with three round holes."""
    rng = np.random.default_rng(1000 + seed)
    with _Gmsh("lplate") as gmsh:
        occ = gmsh.model.occ
        a = occ.addRectangle(0, 0, 0, 2, 1)
        b = occ.addRectangle(0, 0, 0, 1, 2)
        lshape, _ = occ.fuse([(2, a)], [(2, b)])
        holes = []
        for (x, y, r) in ((0.5, 0.5, 0.22), (1.5, 0.5, 0.16), (0.5, 1.5, 0.16)):
            dx, dy = rng.uniform(-0.05, 0.05, 2)
            holes.append((2, occ.addDisk(x + dx, y + dy, 0, r, r)))
        out, _ = occ.cut(lshape, holes)
        occ.synchronize()
        gmsh.model.addPhysicalGroup(2, [t for _, t in out], 1)
        _uniform_size(gmsh, h)
        return _mesh_and_read(gmsh, quads)


def plate_mesh(h: float, quads: bool, seed: int = 0, graded: bool = False, recombination: int = 2) -> Mesh2D:
    """An elliptic plate (semi-axes 2 and 1.4) with three round holes; ``graded``: fine (h/4) at the holes."""
    rng = np.random.default_rng(2000 + seed)
    with _Gmsh("plate") as gmsh:
        occ = gmsh.model.occ
        outer = occ.addDisk(0, 0, 0, 2.0, 1.4)
        holes = []
        for (x, y, r) in ((-0.9, 0.1, 0.3), (0.6, 0.45, 0.22), (0.5, -0.55, 0.18)):
            dx, dy = rng.uniform(-0.05, 0.05, 2)
            holes.append((2, occ.addDisk(x + dx, y + dy, 0, r, r)))
        out, _ = occ.cut([(2, outer)], holes)
        occ.synchronize()
        surf = [t for _, t in out]
        gmsh.model.addPhysicalGroup(2, surf, 1)
        if graded:
            hole_curves = [c for _, c in gmsh.model.getBoundary(out, oriented=False)
                           if gmsh.model.getBoundingBox(1, c)[3] - gmsh.model.getBoundingBox(1, c)[0] < 1.0]
            fld = gmsh.model.mesh.field
            d = fld.add("Distance")
            fld.setNumbers(d, "CurvesList", hole_curves)
            fld.setNumber(d, "Sampling", 200)
            t = fld.add("Threshold")
            fld.setNumber(t, "InField", d)
            fld.setNumber(t, "SizeMin", h / 4)
            fld.setNumber(t, "SizeMax", h)
            fld.setNumber(t, "DistMin", 0.02)
            fld.setNumber(t, "DistMax", 0.8)
            fld.setAsBackgroundMesh(t)
            gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
            gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
            gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        else:
            _uniform_size(gmsh, h)
        return _mesh_and_read(gmsh, quads, recombination=recombination)


def two_region_mesh(h: float, seed: int = 0) -> Mesh2D:
    """A 2 x 1 rectangle in two regions: triangles in the left half, recombined quads in the right, a hole in each."""
    rng = np.random.default_rng(3000 + seed)
    with _Gmsh("tworegion") as gmsh:
        occ = gmsh.model.occ
        left = occ.addRectangle(0, 0, 0, 1, 1)
        right = occ.addRectangle(1, 0, 0, 1, 1)
        dx, dy = rng.uniform(-0.05, 0.05, 2)
        h1 = occ.addDisk(0.45 + dx, 0.5 + dy, 0, 0.2, 0.2)
        h2 = occ.addDisk(1.55 - dx, 0.5 - dy, 0, 0.18, 0.18)
        l_out, _ = occ.cut([(2, left)], [(2, h1)])
        r_out, _ = occ.cut([(2, right)], [(2, h2)])
        occ.fragment(l_out, r_out)  # a conforming interface at x = 1
        occ.synchronize()
        surfs = gmsh.model.getEntities(2)
        lt = [t for _, t in surfs if gmsh.model.occ.getCenterOfMass(2, t)[0] < 1]
        rt = [t for _, t in surfs if gmsh.model.occ.getCenterOfMass(2, t)[0] >= 1]
        gmsh.model.addPhysicalGroup(2, lt, 1)
        gmsh.model.addPhysicalGroup(2, rt, 2)
        for t in rt:
            gmsh.model.mesh.setRecombine(2, t)
        _uniform_size(gmsh, h)
        gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 1)
        return _mesh_and_read(gmsh, quads=False, algorithm=8)


#: boundary-layer geometry: channel [0, 4] x [0, 1.5], cylinder at (1, 0.75)
_BL_CENTRE, _BL_R, _BL_THICK = (1.0, 0.75), 0.2, 0.06


def boundary_layer_mesh(h: float, seed: int = 0) -> Mesh2D:
    """A channel with a cylinder; gmsh BoundaryLayer field (Quads=1) around the cylinder."""
    cx, cy = _BL_CENTRE
    with _Gmsh("bl") as gmsh:
        g = gmsh.model.geo
        corners = [g.addPoint(x, y, 0) for x, y in ((0, 0), (4, 0), (4, 1.5), (0, 1.5))]
        box = g.addCurveLoop([g.addLine(corners[i], corners[(i + 1) % 4]) for i in range(4)])
        c = g.addPoint(cx, cy, 0)
        rot = 0.3 * seed
        cp = [g.addPoint(cx + _BL_R * math.cos(a + rot), cy + _BL_R * math.sin(a + rot), 0)
              for a in np.arange(4) * math.pi / 2]
        arcs = [g.addCircleArc(cp[i], c, cp[(i + 1) % 4]) for i in range(4)]
        cyl = g.addCurveLoop(arcs)
        s = g.addPlaneSurface([box, cyl])
        g.synchronize()
        gmsh.model.addPhysicalGroup(2, [s], 1)
        fld = gmsh.model.mesh.field
        bl = fld.add("BoundaryLayer")
        fld.setNumbers(bl, "CurvesList", arcs)
        fld.setNumber(bl, "Size", h / 12)
        fld.setNumber(bl, "Ratio", 1.3)
        fld.setNumber(bl, "Thickness", _BL_THICK)
        fld.setNumber(bl, "Quads", 1)
        fld.setAsBoundaryLayer(bl)
        _uniform_size(gmsh, h)
        gmsh.option.setNumber("Mesh.MeshSizeMin", h / 3)
        # finer near the cylinder, so that the layer's outer cells meet triangles of similar size
        d = fld.add("Distance")
        fld.setNumbers(d, "CurvesList", arcs)
        t = fld.add("Threshold")
        fld.setNumber(t, "InField", d)
        fld.setNumber(t, "SizeMin", h / 3)
        fld.setNumber(t, "SizeMax", h)
        fld.setNumber(t, "DistMin", _BL_THICK)
        fld.setNumber(t, "DistMax", 0.6)
        fld.setAsBackgroundMesh(t)
        return _mesh_and_read(gmsh, quads=False, algorithm=6)


def hole_layer_mesh(h: float, seed: int = 0) -> Mesh2D:
    """A plate with a hole; gmsh BoundaryLayer field (Quads=1) of about five layers around the hole, the
    size elsewhere ``h``: the layer's inner nodes have quads only, the quads stretched up to 10:1."""
    with _Gmsh("blhole") as gmsh:
        occ = gmsh.model.occ
        plate = occ.addRectangle(0, 0, 0, 2, 1)
        hole = occ.addDisk(0.6 + 0.02 * seed, 0.5, 0, 0.2, 0.2)
        (surf,), _ = occ.cut([(2, plate)], [(2, hole)])
        occ.synchronize()
        curves = [t for _, t in gmsh.model.getBoundary([surf], oriented=False)]
        circle = [t for t in curves if abs(occ.getCenterOfMass(1, t)[0] - (0.6 + 0.02 * seed)) < 1e-6]
        gmsh.model.addPhysicalGroup(2, [surf[1]], 1)
        fld = gmsh.model.mesh.field
        bl = fld.add("BoundaryLayer")
        fld.setNumbers(bl, "CurvesList", circle)
        fld.setNumber(bl, "Size", h / 10)
        fld.setNumber(bl, "Ratio", 1.3)
        fld.setNumber(bl, "Thickness", 0.08)
        fld.setNumber(bl, "Quads", 1)
        fld.setAsBoundaryLayer(bl)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        return _mesh_and_read(gmsh, quads=False)


def _outside_layer(mesh: Mesh2D) -> np.ndarray:
    cx, cy = _BL_CENTRE
    r = np.hypot(mesh.points[:, 0] - cx, mesh.points[:, 1] - cy)
    return r > _BL_R + 1.1 * _BL_THICK


# --------------------------------------------------------------------------- the families
def _h(full: float, tiny: bool) -> float:
    return full * (5.0 if tiny else 1.0)


def _toothed(quads: bool, amount: float, flatten: float = 0.0):
    def build(seed: int, tiny: bool) -> Mesh2D:
        h = _h(0.0256 if quads else 0.0240, tiny) * _factor(seed)
        mesh = jitter(gear_mesh(h, quads, rotation=0.17 * seed), amount, seed)
        if flatten:
            mesh = flatten_boundary_cells(mesh, 0.9, flatten, seed)
        return mesh

    return build


def _lplate(seed, tiny):
    return jitter(l_plate_mesh(_h(0.05, tiny) * _factor(seed), True, seed), 0.25, seed)


def _tricurved(seed, tiny):
    return jitter(plate_mesh(_h(0.12, tiny) * _factor(seed), False, seed, graded=True), 0.25, seed)


def _mixed(seed, tiny):
    return jitter(two_region_mesh(_h(0.04, tiny) * _factor(seed), seed), 0.25, seed)


def _bl(seed, tiny):
    mesh = boundary_layer_mesh(_h(0.06, tiny) * _factor(seed), seed)
    return jitter(mesh, 0.1, seed, movable=_outside_layer(mesh))


def _blhole(seed, tiny):
    return hole_layer_mesh(_h(0.1, tiny) * _factor(seed), seed)


def _paper(kind):
    def build(seed, tiny):
        return paper_experiments.MESHES[kind](seed=seed)

    return build


def _good(quads):
    def build(seed, tiny):
        return plate_mesh(_h(0.07 if quads else 0.08, tiny) * _factor(seed), quads, seed)

    return build


FAMILIES: dict[str, Family] = {
    f.name: f
    for f in (
        Family("quad-distorted-toothed", "quad",
               "gmsh quads of a toothed part, jitter 0.45, 40% of boundary quads squashed to 1/10 height",
               _toothed(True, 0.45, flatten=0.4), distorted_quad=True),
        Family("quad-jitter-toothed", "quad", "gmsh quads of the toothed part, jitter 0.45 only",
               _toothed(True, 0.45), distorted_quad=True),
        Family("tri-distorted-toothed", "tri", "gmsh triangles of the toothed part, jitter 0.45", _toothed(False, 0.45)),
        Family("quad-recombined-jitter", "quad", "gmsh recombined quads, L-plate with holes, jitter 0.25", _lplate),
        Family("tri-curved", "tri", "gmsh graded triangles, elliptic plate with holes, jitter 0.25", _tricurved),
        Family("mixed-two-region", "mixed", "gmsh triangles | quads in two regions with holes, jitter 0.25", _mixed),
        Family("graded", "tri", "anglesmooth.generate.graded_mesh (paper Fig. 11)", _paper("graded"),
               min_angle_target=18.0),
        Family("boundary-layer", "mixed", "gmsh BoundaryLayer quads around a cylinder + triangles, jitter 0.1 outside",
               _bl),
        Family("boundary-layer-hole", "mixed",
               "gmsh BoundaryLayer of ~5 stretched quad layers around a hole + coarse triangles, not jittered", _blhole),
        Family("paper-tri", "tri", "paper_triangle_mesh (paper Table 1)", _paper("triangle"), paper=True,
               min_angle_target=24.0),
        Family("paper-mixed", "mixed", "paper_mixed_mesh (paper Table 2)", _paper("mixed"), paper=True,
               min_angle_target=25.0),
        Family("paper-quad", "quad", "paper_quad_mesh (paper Section 5.4)", _paper("quad"), paper=True),
        Family("good-tri", "tri", "gmsh triangles of the plate with holes, not jittered", _good(False), good=True),
        Family("good-quad", "quad", "gmsh recombined quads of the plate with holes, not jittered", _good(True),
               good=True),
    )
}

#: short names accepted by --families
ALIASES = {"good": ["good-tri", "good-quad"], "paper": ["paper-tri", "paper-mixed", "paper-quad"]}


def resolve(names: list[str]) -> list[str]:
    out: list[str] = []
    for n in names:
        for m in ALIASES.get(n, [n]):
            if m not in FAMILIES:
                raise KeyError(f"unknown family {m!r}; known: {', '.join(FAMILIES)}")
            if m not in out:
                out.append(m)
    return out


def _save(path: Path, mesh: Mesh2D) -> None:
    arrays = {"points": mesh.points, "triangles": mesh.triangles, "quads": mesh.quads, "pinned": mesh.pinned}
    if mesh.triangle_region is not None:
        arrays["triangle_region"] = mesh.triangle_region
    if mesh.quad_region is not None:
        arrays["quad_region"] = mesh.quad_region
    tmp = path.with_suffix(".tmp.npz")
    np.savez(tmp, **arrays)
    tmp.replace(path)


def _load(path: Path) -> Mesh2D:
    with np.load(path) as z:
        kw = {k: z[k] for k in ("triangle_region", "quad_region") if k in z}
        return Mesh2D.from_arrays(z["points"], triangles=z["triangles"], quads=z["quads"], pinned=z["pinned"], **kw)


#: committed input meshes of the families gmsh does not rebuild identically (see the module docstring)
STORED = Path(__file__).resolve().parent / "meshes"


def _key(name: str, seed: int, tiny: bool) -> str:
    return f"{name}-s{seed}-{'tiny' if tiny else 'full'}-v{VERSION}.npz"


def get(name: str, seed: int, cache: Path | None = None, tiny: bool = False) -> Mesh2D:
    """The mesh of family ``name`` for ``seed`` (from ``cache`` when it is there)."""
    fam = FAMILIES[name]
    stored = STORED / _key(name, seed, tiny)
    if stored.exists():  # a mesh gmsh does not rebuild identically (boundary-layer): the committed copy
        return _load(stored)
    path = None
    if cache is not None:
        cache.mkdir(parents=True, exist_ok=True)
        path = cache / _key(name, seed, tiny)
        if path.exists():
            return _load(path)
    mesh = fam.build(seed, tiny)
    # drop what the cache cannot hold (source object, groups): every family is rebuilt from arrays
    mesh = Mesh2D.from_arrays(mesh.points, triangles=mesh.triangles, quads=mesh.quads, pinned=mesh.pinned,
                              triangle_region=mesh.triangle_region, quad_region=mesh.quad_region)
    if path is not None:
        _save(path, mesh)
    return mesh
