"""Reading meshes into :class:`~anglesmooth.mesh.Mesh2D` and writing them back.

This is the only module that imports :mod:`meshio` (lazily, inside functions).
:func:`read` accepts any format meshio reads; :func:`write` writes the original
meshio mesh back with only the x, y columns of its points replaced, so node
order, z, cell blocks (lines, vertices, second-order cells), point/cell/field
data and sets survive as far as the target format can hold them.

Format notes
------------
* ``.msh`` is always written as gmsh (meshio would pick ANSYS).  The MSH
  version and ASCII/binary mode of a gmsh input are kept; other inputs are
  written as MSH 2.2 ASCII, which stores physical and geometrical tags per
  element (MSH 4 stores one tag per cell block, and non-gmsh readers merge
  blocks).  Missing gmsh tags are taken from ``medit:ref`` / ``CellEntityIds``
  or set to 0.  Asking for MSH 4 explicitly (``file_format="gmsh41"``) for a
  mesh without gmsh entities makes every cell block its own entity.
* ``.xdmf`` is written with inline XML data, so there is no companion ``.h5``.
* VTU, VTK, XDMF, ... cannot hold cell/point sets or field data: every named
  group (cell set, point set, gmsh physical group) is stored as an integer
  data array ``"set:NAME"`` (1 = member), which :func:`read` turns back into a
  group.  gmsh physical tags survive as the ``gmsh:physical`` cell data array.
"""

from __future__ import annotations

import contextlib
import io as _stdio
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from . import _guard, _paths
from .errors import AngleSmoothError, InvalidMeshError, MeshReadError, MeshWriteError, UnsupportedMeshError
from .mesh import Mesh2D

__all__ = ["read", "write", "supported_formats"]

_TRI = ("triangle", "triangle6", "triangle7")
_QUAD = ("quad", "quad8", "quad9")
_REGION_KEYS = ("gmsh:physical", "gmsh:geometrical", "medit:ref", "CellEntityIds")
_NO_REGION = -(2**62)  # region of 2D blocks without a tag (same sentinel as topology)
_SET = "set:"
_MAX_COORD = 1e150
_GMSH_WRITE_VERSIONS = ("2.2", "4.0", "4.1")


@dataclass(frozen=True)
class _Source:
    """What :func:`write` needs to write a mesh back (stored in ``Mesh2D.source``)."""

    mesh: Any  # meshio.Mesh, never modified
    format: str | None
    gmsh_version: str | None
    gmsh_binary: bool | None
    had_z: bool


@contextlib.contextmanager
def _quiet():
    """Silence meshio's stdout blank lines and its rich warnings on stderr."""
    sink = _stdio.StringIO()
    with contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
        yield


def _meshio():
    """Import meshio, fixing its MSH 2.2 ElementData reader once.

    meshio 5.3.5 splits MSH 2.2 ``$ElementData`` by ``len((type, array))`` (= 2),
    so any file with element data fails to load; the wrapper passes the arrays.
    """
    import meshio
    from meshio.gmsh import _gmsh22

    orig = _gmsh22.cell_data_from_raw
    if not getattr(orig, "_anglesmooth_fix", False):

        def cell_data_from_raw(cells, cell_data_raw):
            return orig([c[1] if isinstance(c, tuple) else c for c in cells], cell_data_raw)

        cell_data_from_raw._anglesmooth_fix = True
        _gmsh22.cell_data_from_raw = cell_data_from_raw
    return meshio


def supported_formats() -> list[str]:
    """File extensions meshio knows, for help texts.

    >>> ".vtu" in supported_formats() and ".msh" in supported_formats()
    True
    """
    import meshio

    return sorted(meshio.extension_to_filetypes)


def _formats_for(path: Path) -> list[str]:
    import meshio

    out: list[str] = []
    ext = ""
    for suffix in reversed(path.suffixes):
        ext = (suffix + ext).lower()
        out += meshio.extension_to_filetypes.get(ext, [])
    return out


def _gmsh_header(path: Path) -> tuple[str, bool] | None:
    """(version, binary) from a ``$MeshFormat`` header, or None if not gmsh."""
    try:
        with open(path, "rb") as f:
            head = f.read(256)
    except OSError:
        return None
    lines = head.split(b"\n")
    if len(lines) < 2 or not lines[0].strip().startswith(b"$MeshFormat"):
        return None
    parts = lines[1].split()
    try:
        return parts[0].decode("ascii"), parts[1] == b"1"
    except (IndexError, UnicodeDecodeError):
        return None


def _reason(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or "no details"
    text = text if len(text) <= 160 else text[:157] + "..."
    return f"{type(exc).__name__}: {text}"


# ---------------------------------------------------------------------------
# read
# ---------------------------------------------------------------------------


def read(path, *, file_format: str | None = None) -> Mesh2D:
    """Read a planar triangle / quad mesh from any format meshio reads.

    Parameters
    ----------
    path : str or os.PathLike
        The mesh file.
    file_format : str, optional
        A meshio format name (``"gmsh"``, ``"vtu"``, ...) for files whose
        extension does not tell.

    Returns
    -------
    Mesh2D
        Corner connectivity of all triangle-like and quad-like cells, region
        tags, pinned nodes of line/vertex cells, second-order node tables,
        named node groups, and ``source`` for :func:`write`.

    Raises
    ------
    MeshReadError, UnsupportedMeshError, InvalidMeshError

    Examples
    --------
    >>> import os, tempfile, meshio
    >>> d = tempfile.mkdtemp()
    >>> f = os.path.join(d, "sq.vtu")
    >>> meshio.write(f, meshio.Mesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [("quad", [[0, 1, 2, 3]])]))
    >>> m = read(f)
    >>> m.points.shape, m.quads.tolist()
    ((4, 2), [[0, 1, 2, 3]])
    >>> os.remove(f); os.rmdir(d)
    """
    p = Path(os.fspath(path))
    where = f"cannot read '{p}'"
    if not p.exists():
        raise MeshReadError(f"{where}: no such file")
    if p.is_dir():
        raise MeshReadError(f"{where}: is a directory")
    try:
        if p.stat().st_size == 0:
            raise MeshReadError(f"{where}: the file is empty")
    except OSError as e:
        raise MeshReadError(f"{where}: {e.strerror or _reason(e)}") from None
    header = _gmsh_header(p)
    fmt = file_format
    if fmt is None:
        if header is not None:
            fmt = "gmsh"
        elif not _formats_for(p):
            raise MeshReadError(
                f"{where}: unknown file extension '{''.join(p.suffixes) or '(none)'}' "
                "(name the format with --input-format)"
            )
    m = _read_meshio(p, fmt, where)
    is_gmsh = header is not None and (fmt or "").startswith("gmsh")
    try:
        return _to_mesh2d(m, _Source(m, fmt, header[0] if is_gmsh else None, header[1] if is_gmsh else None, False))
    except (InvalidMeshError, UnsupportedMeshError) as e:
        raise type(e)(f"'{p}': {e}") from None
    except MemoryError:
        raise MeshReadError(f"{where}: too large to read: out of memory") from None


def _read_meshio(p: Path, fmt: str | None, where: str):
    """Call meshio's reader for each candidate format; the first that parses wins.

    ``meshio.read`` prints each reader's error to stdout and ends with
    ``sys.exit(1)`` when every candidate fails, which hides the reason; calling
    the readers directly keeps it.  Readers raise anything on corrupt input.
    """
    meshio = _meshio()
    from meshio._helpers import reader_map

    cands = [fmt] if fmt else list(dict.fromkeys(_formats_for(p)))
    if "gmsh" in cands:  # '.msh' is far more often gmsh than ANSYS: report gmsh's reason first
        cands.insert(0, cands.pop(cands.index("gmsh")))
    unknown = [c for c in cands if c not in reader_map]
    if unknown:
        raise MeshReadError(f"{where}: unknown format '{unknown[0]}' (meshio reads: {', '.join(sorted(reader_map))})")
    reasons = []
    for name in cands:
        try:
            with _quiet(), _guard.limits(p, name):
                return reader_map[name](str(p))
        except MemoryError:
            raise MeshReadError(f"{where}: too large to read: out of memory") from None
        except (Exception, SystemExit) as e:
            cause = e
            if isinstance(e, meshio.ReadError) and not str(e).strip() and e.__context__ is not None:
                cause = e.__context__
            detail = _reason(cause) if str(cause).strip() else "truncated or corrupt"
            reasons.append(f"not a valid {name} file ({detail})")
    raise MeshReadError(f"{where}: {'; '.join(reasons) if len(reasons) < 3 else reasons[0] + '; ...'}")


def _points(m) -> tuple[np.ndarray, bool]:
    pts = np.asarray(m.points)
    if pts.size == 0:
        raise InvalidMeshError("the mesh has no nodes")
    if pts.ndim != 2 or pts.shape[1] not in (2, 3) or pts.dtype.kind not in "fiu":
        raise InvalidMeshError(f"points have shape {pts.shape} and type {pts.dtype}, expected (N, 2) or (N, 3) numbers")
    pts = pts.astype(np.float64)
    if not np.isfinite(pts).all():  # the per-node masks only to name the first bad node
        i = int(np.flatnonzero(~np.isfinite(pts).all(axis=1))[0])
        raise InvalidMeshError(f"node {i} has a non-finite coordinate {pts[i].tolist()}")
    if pts.max() > _MAX_COORD or pts.min() < -_MAX_COORD:
        i = int(np.flatnonzero((np.abs(pts) > _MAX_COORD).any(axis=1))[0])
        raise InvalidMeshError(f"node {i} has an absurd coordinate {pts[i].tolist()} (limit {_MAX_COORD:g})")
    had_z = pts.shape[1] == 3
    if had_z and pts.shape[0]:
        z = pts[:, 2]
        zmin, zmax = float(z.min()), float(z.max())
        size = max(float(np.ptp(pts[:, k])) for k in range(3))  # per column: far faster than axis=0 on (N, 3)
        if zmax - zmin > 1e-12 * size:
            raise UnsupportedMeshError(f"mesh is not planar: z varies from {zmin:g} to {zmax:g}")
    return pts[:, :2], had_z


def _int_tags(arr, n: int) -> np.ndarray | None:
    """An (n,) int64 tag array from cell data, or None if it is not one."""
    try:
        a = np.asarray(arr)
    except Exception:
        return None
    if a.size != n or a.dtype.kind not in "iuf":
        return None
    a = a.reshape(-1)
    if a.dtype.kind == "f":
        if not (np.isfinite(a).all() and (a == np.round(a)).all()):
            return None
    return a.astype(np.int64)


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


def _to_mesh2d(m, src: _Source) -> Mesh2D:
    _check_cell_types(m)
    pts, had_z = _points(m)
    src = _Source(src.mesh, src.format, src.gmsh_version, src.gmsh_binary, had_z)
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
            raise InvalidMeshError(
                f"cell {cid + i} ({block.type} {i} of block {b}) references node {int(bad)}, "
                f"but the mesh has {n} nodes"
            )
        data = data.astype(np.int64)
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

    def cat(parts, width):  # every part is a fresh array: a single one needs no copy
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
    return Mesh2D(
        points=pts,
        triangles=cat(tri, 3),
        quads=cat(quad, 4),
        triangle_region=cat(tri_reg, 0) if key is not None else None,
        quad_region=cat(quad_reg, 0) if key is not None else None,
        triangle_ids=cat(tri_ids, 0),
        quad_ids=cat(quad_ids, 0),
        pinned=pinned,
        midside=midside,
        centres=cat(cens, 5),
        groups=_groups(m, n),
        source=src,
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


# ---------------------------------------------------------------------------
# write
# ---------------------------------------------------------------------------


def write(mesh: Mesh2D, path, *, points=None, file_format: str | None = None, binary: bool | None = None) -> None:
    """Write ``mesh`` (with ``points`` as its x, y coordinates) atomically to ``path``.

    The original meshio mesh in ``mesh.source`` is written with only x, y of
    its points replaced; it is never modified.  The file appears complete or
    not at all: a temporary file in the target directory is written, synced
    and renamed (a symlink is followed; a device, FIFO or socket is written
    into, never replaced: see ``anglesmooth._paths``).

    Parameters
    ----------
    mesh : Mesh2D
    path : str or os.PathLike
    points : (N, 2) array, optional
        New coordinates (default ``mesh.points``).
    file_format : str, optional
        meshio format name; default from the extension (``.msh`` is gmsh).
    binary : bool, optional
        Binary or ASCII where the format has both; default: the input's mode
        for gmsh, meshio's default otherwise.

    Raises
    ------
    MeshWriteError, InvalidMeshError

    Examples
    --------
    >>> import os, tempfile
    >>> d = tempfile.mkdtemp()
    >>> m = Mesh2D.from_arrays([[0, 0], [1, 0], [0, 1]], triangles=[[0, 1, 2]])
    >>> write(m, os.path.join(d, "t.vtu"), points=[[0, 0], [2, 0], [0, 2]])
    >>> read(os.path.join(d, "t.vtu")).points[1].tolist()
    [2.0, 0.0]
    >>> os.remove(os.path.join(d, "t.vtu")); os.rmdir(d)
    """
    p = Path(os.fspath(path))
    where = f"cannot write '{p}'"
    xy = np.asarray(mesh.points if points is None else points, dtype=np.float64)
    if xy.shape != (mesh.n_points, 2):
        raise InvalidMeshError(f"points have shape {xy.shape}, expected ({mesh.n_points}, 2)")
    if not np.isfinite(xy).all():
        raise InvalidMeshError(f"node {int(np.flatnonzero(~np.isfinite(xy).all(axis=1))[0])} has a non-finite coordinate")
    fmt = file_format
    if fmt is None:
        cands = _formats_for(p)
        if not cands:
            raise MeshWriteError(f"{where}: unknown file extension '{''.join(p.suffixes) or '(none)'}' (name the format)")
        fmt = "gmsh" if "gmsh" in cands else cands[0]
    src = mesh.source if isinstance(mesh.source, _Source) else None
    try:
        out = _out_mesh(mesh, src, xy, fmt)
    except AngleSmoothError:
        raise
    except Exception as e:
        raise MeshWriteError(f"{where}: {_reason(e)}") from None
    suffix = "".join(p.suffixes[-2:]) if fmt in ("permas", "netgen") else p.suffix
    try:  # temporary file + rename for a regular file, streamed into a device / FIFO (see _paths)
        _paths.atomic_write(p, lambda tmp: _write_quiet(tmp, out, fmt, src, binary), suffix=suffix)
    except BaseException as e:
        if isinstance(e, AngleSmoothError) or not isinstance(e, (Exception, SystemExit)):
            raise
        if isinstance(e, MemoryError):
            raise MeshWriteError(f"{where}: out of memory") from None
        raise MeshWriteError(f"{where}: {_reason(e)}") from None


def _write_quiet(tmp: str, out, fmt: str, src: _Source | None, binary: bool | None) -> None:
    with _quiet():
        _write_meshio(tmp, out, fmt, src, binary)


def _write_meshio(tmp: str, out, fmt: str, src: _Source | None, binary: bool | None) -> None:
    import meshio

    if fmt in ("gmsh", "gmsh22", "gmsh40", "gmsh41"):
        from meshio import gmsh

        version = {"gmsh22": "2.2", "gmsh40": "4.0", "gmsh41": "4.1"}.get(fmt)
        if version is None:
            version = src.gmsh_version if src is not None and src.gmsh_version in _GMSH_WRITE_VERSIONS else "2.2"
        if binary is None:
            binary = bool(src.gmsh_binary) if src is not None and src.gmsh_version else False
        _gmsh_tags(out)
        _gmsh_data(out, ascii_=not binary)
        if version in ("4.0", "4.1"):
            _gmsh4_entities(out)
        gmsh.write(tmp, out, fmt_version=version, binary=binary)
    elif fmt == "xdmf":
        meshio.xdmf.write(tmp, out, data_format="XML")
    else:
        kwargs = {} if binary is None else {"binary": binary}
        meshio.write(tmp, out, file_format=fmt, **kwargs)


def _out_mesh(mesh: Mesh2D, src: _Source | None, xy: np.ndarray, fmt: str):
    """A fresh meshio.Mesh sharing no mutable container with the source."""
    import meshio

    if src is None:
        cells = [(t, c) for t, c in (("triangle", mesh.triangles), ("quad", mesh.quads)) if len(c)]
        cell_data = {}
        regs = [r for r, (t, c) in zip((mesh.triangle_region, mesh.quad_region), cells) if r is not None]
        if len(regs) == len(cells):
            cell_data["gmsh:physical"] = [np.asarray(r, dtype=np.int32) for r in regs]
        m = meshio.Mesh(xy.copy(), [(t, np.array(c)) for t, c in cells], cell_data=cell_data)
        m.point_sets = {k: np.array(v) for k, v in mesh.groups.items()}
        return _adapt_sets(m, fmt)
    s = src.mesh
    pts = np.array(s.points, dtype=np.float64, copy=True)
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
    return _adapt_sets(m, fmt)


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


def _gmsh4_entities(m) -> None:
    """Give a mesh without gmsh entities one entity per cell block (MSH 4 needs them)."""
    n = len(m.points)
    if "gmsh:dim_tags" in m.point_data and "gmsh:geometrical" in m.cell_data:
        return
    m.cell_data["gmsh:geometrical"] = [np.full(len(c), k + 1, np.int32) for k, c in enumerate(m.cells)]
    two_d = [k for k, c in enumerate(m.cells) if c.dim == 2] or [0]
    dim_tags = np.tile([m.cells[two_d[0]].dim, two_d[0] + 1], (n, 1)).astype(np.int64)
    order = sorted(range(len(m.cells)), key=lambda k: -m.cells[k].dim)
    for k in order:  # lower dimensions last: nodes on lines belong to the line entity
        dim_tags[np.asarray(m.cells[k].data).ravel()] = (m.cells[k].dim, k + 1)
    m.point_data["gmsh:dim_tags"] = dim_tags
    m.cell_sets.pop("gmsh:bounding_entities", None)


def _gmsh_tags(m) -> None:
    """Supply gmsh:physical / gmsh:geometrical from the region tags (or zeros) when missing."""
    key = next((k for k in _REGION_KEYS[2:] if k in m.cell_data), None)
    for name in ("gmsh:physical", "gmsh:geometrical"):
        if name not in m.cell_data:
            m.cell_data[name] = [
                _physical_from(m.cell_data[key][b] if key else None, len(c)) for b, c in enumerate(m.cells)
            ]


def _physical_from(tags, nc: int) -> np.ndarray:
    t = _int_tags(tags, nc) if tags is not None else None
    return np.zeros(nc, np.int32) if t is None else t.astype(np.int32)


def _gmsh_data(m, ascii_: bool) -> None:
    """Make point/cell data storable in MSH: doubles with 1, 3 or 9 components.

    Two-component data are padded with a zero column; other widths are dropped.
    meshio's ASCII writer prints ``repr`` of numpy scalars (``np.float64(1.0)``
    under numpy 2), so for ASCII the values are handed over as Python floats.
    """

    def conv(a):
        a = np.asarray(a, dtype=np.float64)
        a = a.reshape(len(a), -1) if a.ndim > 1 else a
        if a.ndim == 2 and a.shape[1] == 2:
            a = np.column_stack([a, np.zeros(len(a))])
        if a.ndim == 2 and a.shape[1] not in (1, 3, 9):
            return None
        return np.array(a.tolist(), dtype=object) if ascii_ else a

    tags = ("gmsh:physical", "gmsh:geometrical", "cell_tags")
    for k in list(m.point_data):
        if k != "gmsh:dim_tags":
            v = conv(m.point_data[k])
            if v is None:
                del m.point_data[k]
            else:
                m.point_data[k] = v
    for k in list(m.cell_data):
        if k not in tags:
            v = [conv(a) for a in m.cell_data[k]]
            if any(a is None for a in v):
                del m.cell_data[k]
            else:
                m.cell_data[k] = v
