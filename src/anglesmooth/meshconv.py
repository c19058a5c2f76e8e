"""Between ``meshio.Mesh`` and :class:`~anglesmooth.mesh.Mesh2D`, both ways.

Reading side: :func:`to_mesh2d` takes the corner connectivity of every
triangle-like and quad-like block, region tags, pinned nodes of line / vertex
cells, second-order node tables, named groups and physical groups by number,
and the plane of a 3D mesh (:mod:`anglesmooth.plane`).  Writing side:
:func:`copy_with_points` is a fresh meshio mesh with the new coordinates
(mapped back into the plane) and everything of the source; :func:`out_mesh`
adapts its sets and names to a target format (see :mod:`anglesmooth.io`).
The source mesh is never modified.  :mod:`anglesmooth.io` holds the files.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .errors import InvalidMeshError, UnsupportedMeshError
from .gmshfile import first_of_duplicates
from .gmshfile import int_tags as _int_tags
from .mesh import MAX_COORD, Mesh2D
from .plane import PlaneFrame, fit_plane

__all__ = ["Source", "as_mesh2d", "copy_with_points", "node_tags", "out_mesh", "sample", "to_mesh2d", "to_meshio"]

_TRI = ("triangle", "triangle6", "triangle7")
_QUAD = ("quad", "quad8", "quad9")
_REGION_KEYS = ("gmsh:physical", "gmsh:geometrical", "medit:ref", "CellEntityIds")
_NO_REGION = -(2**62)  # region of 2D blocks without a tag (same sentinel as topology)
_SET = "set:"


@dataclass(frozen=True)
class Source:
    """What :func:`write` needs to write a mesh back (stored in ``Mesh2D.source``)."""

    mesh: Any  # meshio.Mesh, never modified
    format: str | None
    gmsh_version: str | None
    gmsh_binary: bool | None
    had_z: bool
    node_tags: Any = None  # (N,) int64 gmsh node tags of the points, when the file had them
    gmsh_entities: Any = None  # MSH 4 $Entities as read (see gmshfile)
    binary: bool | None = None  # the input's encoding, where its format has a choice


def _points(m) -> tuple[np.ndarray, PlaneFrame | None]:
    pts = np.asarray(m.points)
    if pts.size == 0:
        raise InvalidMeshError("the mesh has no nodes")
    if pts.ndim != 2 or pts.shape[1] not in (2, 3) or pts.dtype.kind not in "fiu":
        raise InvalidMeshError(f"points have shape {pts.shape} and type {pts.dtype}, expected (N, 2) or (N, 3) numbers")
    pts = pts.astype(np.float64)
    if not np.isfinite(pts).all():  # the per-node masks only to name the first bad node
        i = int(np.flatnonzero(~np.isfinite(pts).all(axis=1))[0])
        raise InvalidMeshError(f"node {i} has a non-finite coordinate {pts[i].tolist()}")
    if pts.max() > MAX_COORD or pts.min() < -MAX_COORD:
        i = int(np.flatnonzero((np.abs(pts) > MAX_COORD).any(axis=1))[0])
        raise InvalidMeshError(f"node {i} has an absurd coordinate {pts[i].tolist()} (limit {MAX_COORD:g})")
    had_z = pts.shape[1] == 3
    if not had_z:
        return pts, None
    frame, uv = fit_plane(pts)
    return uv, frame


def _check_cell_types(m) -> None:
    """Unsupported cell types first: a tetra mesh is 'unsupported', not 'not planar'."""
    for block in m.cells:
        t, data = block.type, np.asarray(block.data)
        if t == "polygon" and data.ndim == 2 and data.shape[1] in (3, 4):
            continue
        if not (t in _TRI or t in _QUAD or t == "vertex" or t.startswith("line")):
            raise UnsupportedMeshError(
                f"unsupported cell type '{block.type}' (anglesmooth smooths 2D triangle and quad meshes)"
            )


def to_mesh2d(m, src: Source, *, owned: bool = False) -> Mesh2D:
    """The :class:`Mesh2D` of meshio mesh ``m``; ``owned``: ``m`` is the reader's own (kept unmodified in
    ``src``), so int64 connectivity is shared with it rather than copied (a caller's mesh is copied)."""
    _check_cell_types(m)
    pts, frame = _points(m)
    src = replace(src, had_z=frame is not None)
    n = pts.shape[0]
    key = next((k for k in _REGION_KEYS if k in m.cell_data), None)
    tri, quad, tri_ids, quad_ids, tri_reg, quad_reg, mids, cens = ([] for _ in range(8))
    pinned = np.zeros(n, dtype=bool)
    cid = 0
    for b, block in enumerate(m.cells):
        t, data = block.type, np.asarray(block.data)
        nc = len(data)
        if t == "polygon" and data.ndim == 2 and data.shape[1] in (3, 4):
            t = "triangle" if data.shape[1] == 3 else "quad"
        is_tri, is_quad = t in _TRI, t in _QUAD
        if not (is_tri or is_quad or t == "vertex" or t.startswith("line")):
            raise UnsupportedMeshError(
                f"unsupported cell type '{block.type}' (anglesmooth smooths 2D triangle and quad meshes)"
            )
        if nc and (data.dtype.kind not in "iu" or data.ndim != 2):
            raise InvalidMeshError(f"cell block {b} ({block.type}) has connectivity of type {data.dtype}")
        if nc and (data.min() < 0 or data.max() >= n):
            i = int(np.flatnonzero(((data < 0) | (data >= n)).any(axis=1))[0])
            bad = data[i][(data[i] < 0) | (data[i] >= n)][0]
            what = (
                f"node {int(bad)}, a node the file does not define (in a gmsh file: a node tag missing or repeated)"
                if bad < 0 else f"node {int(bad)}, but the mesh has {n} nodes"
            )
            raise InvalidMeshError(f"cell {cid + i} ({block.type} {i} of block {b}) references {what}")
        data = data.astype(np.int64, copy=not owned)
        if is_tri or is_quad:
            k = 3 if is_tri else 4
            (tri if is_tri else quad).append(data[:, :k])
            (tri_ids if is_tri else quad_ids).append(np.arange(cid, cid + nc, dtype=np.int64))
            tags = _int_tags(m.cell_data[key][b], nc) if key is not None and b < len(m.cell_data[key]) else None
            (tri_reg if is_tri else quad_reg).append(tags if tags is not None else np.full(nc, _NO_REGION))
            if t == "triangle6" or t in ("quad8", "quad9"):
                for j in range(k):
                    mids.append(np.stack([data[:, k + j], data[:, j], data[:, (j + 1) % k]], axis=1))
            if t == "quad9":
                cens.append(np.column_stack([data[:, 8], data[:, :4]]))
        else:
            pinned[data.ravel()] = True
        cid += nc
    if not tri and not quad:
        raise InvalidMeshError("the mesh has no triangle or quad cells")

    def cat(parts, width):  # every part is fresh or the reader's own: a single one needs no copy
        if len(parts) == 1:
            return parts[0]
        return np.concatenate(parts) if parts else np.zeros((0, width) if width else 0, np.int64)

    midside = cat(mids, 3)
    if midside.shape[0]:
        order = np.argsort(midside[:, 0], kind="stable")
        s = midside[order]
        keep = np.ones(s.shape[0], bool)
        keep[1:] = s[1:, 0] != s[:-1, 0]
        midside = s[keep]
    cells = {"tri": [cat(tri, 3), cat(tri_reg, 0) if key is not None else None, cat(tri_ids, 0)],
             "quad": [cat(quad, 4), cat(quad_reg, 0) if key is not None else None, cat(quad_ids, 0)]}
    if src.gmsh_version == "2.2":  # MSH 2.2 repeats an element once per physical group it belongs to
        for parts in cells.values():
            keep = first_of_duplicates(parts[0])
            if not keep.all():
                parts[:] = [None if a is None else a[keep] for a in parts]
    return Mesh2D(
        points=pts,
        triangles=cells["tri"][0],
        quads=cells["quad"][0],
        triangle_region=cells["tri"][1],
        quad_region=cells["quad"][1],
        triangle_ids=cells["tri"][2],
        quad_ids=cells["quad"][2],
        pinned=pinned,
        midside=midside,
        centres=cat(cens, 5),
        groups=_groups(m, n),
        physical=_physical_groups(m, src.gmsh_entities),
        source=src,
        frame=frame,
    )


def _cell_masks(m) -> dict[str, list[np.ndarray]]:
    """Named cell groups as per-block boolean masks (physical groups, cell sets, set: data)."""
    out: dict[str, list[np.ndarray]] = {}
    sizes = [len(c) for c in m.cells]

    def add(name, masks):
        old = out.get(name)
        out[name] = masks if old is None else [a | b for a, b in zip(old, masks)]

    phys = m.cell_data.get("gmsh:physical")
    for name, val in (m.field_data or {}).items():
        v = np.asarray(val).reshape(-1)
        if phys is None or v.size != 2 or v.dtype.kind not in "iu" or len(phys) != len(sizes):
            continue
        tag, dim = int(v[0]), int(v[1])
        masks = []
        for block, ph, nc in zip(m.cells, phys, sizes):
            t = _int_tags(ph, nc)
            masks.append((t == tag) if (t is not None and block.dim == dim) else np.zeros(nc, bool))
        add(str(name), masks)
    for name, per_block in (m.cell_sets or {}).items():
        if name.startswith("gmsh:") or len(per_block) != len(sizes):
            continue
        try:
            masks = []
            for idx, nc in zip(per_block, sizes):
                mk = np.zeros(nc, bool)
                if idx is not None:
                    mk[np.asarray(idx, dtype=np.int64)] = True
                masks.append(mk)
        except (IndexError, ValueError, TypeError):
            continue
        add(name, masks)
    for name, per_block in m.cell_data.items():
        if name.startswith(_SET) and len(per_block) == len(sizes):
            add(name[len(_SET) :], [np.asarray(a).reshape(-1) != 0 for a in per_block])
    return out


def _physical_groups(m, entities) -> dict[tuple[int, int], np.ndarray]:
    """Node indices of every physical group by (dimension, number), named or not.

    From the MSH 4.1 entity table when there is one (an entity can be in several
    groups), else from the ``gmsh:physical`` cell data (0 = none).
    """
    phys = m.cell_data.get("gmsh:physical")
    geo = m.cell_data.get("gmsh:geometrical")
    parts: dict[tuple[int, int], list[np.ndarray]] = {}
    for b, block in enumerate(m.cells):
        data = np.asarray(block.data)
        nc = len(data)
        if not nc:
            continue
        g = _int_tags(geo[b], nc) if entities and geo is not None and b < len(geo) else None
        if g is not None:
            for t in np.unique(g).tolist():
                for ph in entities.get((block.dim, int(t)), (None, ()))[1]:
                    parts.setdefault((block.dim, int(ph)), []).append(data[g == t].ravel())
            continue
        t = _int_tags(phys[b], nc) if phys is not None and b < len(phys) else None
        if t is None:
            continue
        for ph in np.unique(t).tolist():
            if ph != 0:
                parts.setdefault((block.dim, int(ph)), []).append(data[t == ph].ravel())
    return {k: np.unique(np.concatenate(v)) for k, v in sorted(parts.items())}


def _groups(m, n: int) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    for name, masks in _cell_masks(m).items():
        parts = [np.asarray(c.data)[mk].ravel() for c, mk in zip(m.cells, masks) if mk.any()]
        out[name] = np.unique(np.concatenate(parts)) if parts else np.zeros(0, np.int64)
    node_sets = {k: np.asarray(v).reshape(-1) for k, v in (m.point_sets or {}).items()}
    node_sets.update(
        {k[len(_SET) :]: np.flatnonzero(np.asarray(v).reshape(-1) != 0) for k, v in m.point_data.items() if k.startswith(_SET)}
    )
    for name, idx in node_sets.items():
        if name.startswith("gmsh:") or idx.dtype.kind not in "iu" or (idx.size and (idx.min() < 0 or idx.max() >= n)):
            continue
        old = out.get(name)
        out[name] = np.unique(idx if old is None else np.concatenate([old, idx]))
    return out


def out_mesh(mesh: Mesh2D, src: Source | None, xy: np.ndarray, fmt: str):
    """A fresh meshio.Mesh for format ``fmt``, sharing no mutable container with the source."""
    m = copy_with_points(mesh, src, xy)
    if fmt.startswith("gmsh") and not m.field_data:
        _names_from_sets(m)
    if fmt in _FACES_ONLY:
        _drop_line_cells(m)
    return _adapt_sets(m, fmt)


#: Formats whose meshio writer holds 2D faces only and refuses line / vertex cells (STL, OFF and WKT drop them).
_FACES_ONLY = ("obj",)


def _drop_line_cells(m) -> None:
    """Leave out the line and vertex cell blocks (boundary and point markers) with their cell data and sets,
    as the STL, OFF and WKT writers do: a gmsh mesh (which has boundary lines) can then be written."""
    keep = [b for b, c in enumerate(m.cells) if not (c.type == "vertex" or c.type.startswith("line"))]
    if len(keep) == len(m.cells) or not keep:
        return
    n = len(m.cells)
    m.cells = [m.cells[b] for b in keep]
    m.cell_data = {k: [v[b] for b in keep] for k, v in m.cell_data.items() if len(v) == n}
    m.cell_sets = {k: [v[b] for b in keep] for k, v in m.cell_sets.items() if len(v) == n}


def _names_from_sets(m) -> None:
    """Physical names back for MSH: a ``set:NAME`` cell array that is exactly one physical group.

    (``msh -> vtu -> msh``: VTU has no field data, so the names travel as
    ``set:NAME`` arrays beside ``gmsh:physical``.)
    """
    phys = m.cell_data.get("gmsh:physical")
    if phys is None or len(phys) != len(m.cells):
        return
    for key in [k for k in m.cell_data if k.startswith(_SET)]:
        per_block = m.cell_data[key]
        if len(per_block) != len(m.cells):
            continue
        members, all_cells = set(), {}
        for block, mk, ph in zip(m.cells, per_block, phys):
            t = _int_tags(ph, len(block.data))
            if t is None:
                return
            mk = np.asarray(mk).reshape(-1) != 0
            members |= {(block.dim, int(v)) for v in np.unique(t[mk]).tolist()}
            for v in np.unique(t).tolist():
                all_cells[(block.dim, int(v))] = all_cells.get((block.dim, int(v)), True) and bool(mk[t == v].all())
        if len(members) == 1:
            (dim, tag), = members
            if tag != 0 and all_cells[(dim, tag)]:
                m.field_data[key[len(_SET):]] = np.array([tag, dim])
                del m.cell_data[key]


def copy_with_points(mesh: Mesh2D, src: Source | None, xy: np.ndarray):
    """A fresh meshio.Mesh of ``mesh`` with coordinates ``xy``, everything of the source kept."""
    import meshio

    if src is None:
        cells = [(t, c) for t, c in (("triangle", mesh.triangles), ("quad", mesh.quads)) if len(c)]
        cell_data = {}
        regs = [r for r, (t, c) in zip((mesh.triangle_region, mesh.quad_region), cells) if r is not None]
        if len(regs) == len(cells):
            cell_data["gmsh:physical"] = [np.asarray(r, dtype=np.int32) for r in regs]
        pts = xy.copy() if mesh.frame is None else mesh.points_3d(xy)
        m = meshio.Mesh(pts, [(t, np.array(c)) for t, c in cells], cell_data=cell_data)
        m.point_sets = {k: np.array(v) for k, v in mesh.groups.items()}
        return m
    s = src.mesh
    pts = np.array(s.points, dtype=np.float64, copy=True)
    if mesh.frame is not None and pts.shape[1] == 3:
        pts = mesh.frame.to_3d(xy, base=pts)  # fixed nodes: bit-identical in all three coordinates
    else:
        pts[:, :2] = xy
    m = meshio.Mesh(
        pts,
        [meshio.CellBlock(c.type, c.data, getattr(c, "tags", None)) for c in s.cells],
        point_data=dict(s.point_data),
        cell_data={k: list(v) for k, v in s.cell_data.items()},
        field_data=dict(s.field_data),
        point_sets=dict(s.point_sets),
        cell_sets={k: list(v) for k, v in s.cell_sets.items()},
        gmsh_periodic=getattr(s, "gmsh_periodic", None),
        info=getattr(s, "info", None),
    )
    return m


def _adapt_sets(m, fmt: str):
    """Make sets and groups storable by the target format (see module notes)."""
    sizes = [len(c) for c in m.cells]
    gmsh = fmt.startswith("gmsh")
    if fmt in ("abaqus", "flac3d"):  # hold named sets natively
        m.cell_sets = {k: v for k, v in m.cell_sets.items() if not k.startswith("gmsh:") and len(v) == len(sizes)}
        return m
    physical = set(m.field_data) if gmsh else set()
    for name, masks in _cell_masks(m).items():
        if name in physical or _SET + name in m.cell_data:
            continue
        m.cell_data[_SET + name] = [mk.astype(np.int32) for mk in masks]
    n = len(m.points)
    for name, idx in m.point_sets.items():
        if _SET + name not in m.point_data:
            v = np.zeros(n, np.int32)
            with contextlib.suppress(IndexError, ValueError, TypeError):
                v[np.asarray(idx, dtype=np.int64)] = 1
                m.point_data[_SET + name] = v
    m.point_sets = {}
    if fmt == "medit":  # takes the first integer point data as labels; dim_tags has 2 columns
        m.point_data.pop("gmsh:dim_tags", None)
    keep = ("gmsh:bounding_entities",) if gmsh else ()
    m.cell_sets = {k: v for k, v in m.cell_sets.items() if k in keep and len(v) == len(sizes)}
    return m


def as_mesh2d(mesh) -> Mesh2D:
    """``mesh`` itself if it is a :class:`Mesh2D`; a ``meshio.Mesh`` is converted (as :func:`read` would).

    >>> import meshio
    >>> as_mesh2d(meshio.Mesh([[0, 0], [1, 0], [0, 1]], [("triangle", [[0, 1, 2]])])).n_cells
    1
    """
    if isinstance(mesh, Mesh2D):
        return mesh
    if hasattr(mesh, "points") and hasattr(mesh, "cells") and hasattr(mesh, "cell_data"):
        return to_mesh2d(mesh, Source(mesh, None, None, None, False))
    raise TypeError(f"expected a Mesh2D or a meshio.Mesh, got {type(mesh).__name__}")


def to_meshio(mesh, points=None):
    """A fresh ``meshio.Mesh`` of ``mesh`` with ``points`` (default ``mesh.points``) as its plane coordinates.

    Everything of the source is kept (cell blocks, point/cell/field data, sets,
    z or the 3D plane); the source is never modified.
    """
    mesh = as_mesh2d(mesh)
    xy = np.asarray(mesh.points if points is None else points, dtype=np.float64)
    if xy.shape != (mesh.n_points, 2):
        raise InvalidMeshError(f"points have shape {xy.shape}, expected ({mesh.n_points}, 2)")
    return copy_with_points(mesh, mesh.source if isinstance(mesh.source, Source) else None, xy)


def node_tags(mesh) -> np.ndarray | None:
    """The gmsh node tag (1-based) of every node of a mesh read from an MSH file, else None."""
    src = getattr(mesh, "source", None)
    tags = getattr(src, "node_tags", None)
    if tags is None or len(tags) != mesh.n_points:
        return None
    return np.asarray(tags, dtype=np.int64)


def sample(m, node_tags_):
    """A few cells of meshio mesh ``m``: the first of every (block, tags) combination, with their nodes."""
    import meshio

    keys = [k for k in ("gmsh:physical", "gmsh:geometrical") if k in m.cell_data and len(m.cell_data[k]) == len(m.cells)]
    rows = []
    for b, c in enumerate(m.cells):
        nc = len(c.data)
        if not nc:
            rows.append(np.zeros(0, np.int64))
            continue
        cols = [np.asarray(m.cell_data[k][b]).reshape(-1)[:nc] for k in keys]
        if cols and all(len(x) == nc for x in cols) and not all((x == x[0]).all() for x in cols):
            _, first = np.unique(np.column_stack(cols), axis=0, return_index=True)
            rows.append(np.sort(first)[:1000])  # enough to show a writer every kind of block
        else:
            rows.append(np.zeros(1, np.int64))
    used = np.unique(np.concatenate([np.asarray(c.data)[r].ravel() for c, r in zip(m.cells, rows)] + [np.zeros(0, np.int64)]))
    remap = np.full(len(m.points), -1, np.int64)
    remap[used] = np.arange(used.size)
    cells = [meshio.CellBlock(c.type, remap[np.asarray(c.data)[r]]) for c, r in zip(m.cells, rows)]

    def take(a, r):
        a = np.asarray(a)
        return a[r] if a.ndim and len(a) >= (r.max() + 1 if r.size else 0) else a

    out = meshio.Mesh(
        np.asarray(m.points)[used], cells,
        point_data={k: take(v, used) for k, v in m.point_data.items()},
        cell_data={k: [take(a, r) for a, r in zip(v, rows)] for k, v in m.cell_data.items() if len(v) == len(rows)},
        field_data=dict(m.field_data),
    )
    out.cell_sets = {
        k: [np.flatnonzero(np.isin(r, np.asarray(v if v is not None else [], dtype=np.int64))) for v, r in zip(sets, rows)]
        for k, sets in m.cell_sets.items() if len(sets) == len(rows) and k != "gmsh:bounding_entities"
    }
    if "gmsh:bounding_entities" in m.cell_sets:
        out.cell_sets["gmsh:bounding_entities"] = m.cell_sets["gmsh:bounding_entities"]
    return out, None if node_tags_ is None else np.asarray(node_tags_)[used]
