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
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from .errors import AngleSmoothError, InvalidMeshError, MeshReadError, MeshWriteError, UnsupportedMeshError
from .mesh import Mesh2D
from . import formats, gmshfile
from .gmshfile import int_tags as _int_tags
from .plane import PlaneFrame, fit_plane

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
    node_tags: Any = None  # (N,) int64 gmsh node tags of the points, when the file had them
    gmsh_entities: Any = None  # MSH 4 $Entities as read (see gmshfile)
    binary: bool | None = None  # the input's encoding, where its format has a choice


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
    gmshfile.install()
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
    fmt = formats.resolve(file_format)
    if fmt is None:
        if header is not None:
            fmt = "gmsh"
        elif not _formats_for(p):
            raise MeshReadError(
                f"{where}: unknown file extension '{''.join(p.suffixes) or '(none)'}' "
                "(name the format with --input-format)"
            )
    m, used, extra = _read_meshio(p, fmt, where)
    is_gmsh = header is not None and used.startswith("gmsh")
    binary = header[1] if is_gmsh else formats.detect_binary(p, used)
    src = _Source(m, used, header[0] if is_gmsh else None, header[1] if is_gmsh else None, False, binary=binary, **extra)
    try:
        return _to_mesh2d(m, src)
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
            gmshfile.take_captured()
            with _quiet():
                m = reader_map[name](str(p))
            got = gmshfile.take_captured() if name.startswith("gmsh") else {}
            return m, name, {"node_tags": got.get("node_tags"), "gmsh_entities": got.get("entities")}
        except MemoryError:
            raise MeshReadError(f"{where}: too large to read: out of memory") from None
        except (Exception, SystemExit) as e:
            cause = e
            if isinstance(e, meshio.ReadError) and not str(e).strip() and e.__context__ is not None:
                cause = e.__context__
            detail = _reason(cause) if str(cause).strip() else "truncated or corrupt"
            reasons.append(f"not a valid {name} file ({detail})")
    raise MeshReadError(f"{where}: {'; '.join(reasons) if len(reasons) < 3 else reasons[0] + '; ...'}")


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
    if pts.max() > _MAX_COORD or pts.min() < -_MAX_COORD:
        i = int(np.flatnonzero((np.abs(pts) > _MAX_COORD).any(axis=1))[0])
        raise InvalidMeshError(f"node {i} has an absurd coordinate {pts[i].tolist()} (limit {_MAX_COORD:g})")
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


def _to_mesh2d(m, src: _Source) -> Mesh2D:
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


# ---------------------------------------------------------------------------
# write
# ---------------------------------------------------------------------------


def write(mesh: Mesh2D, path, *, points=None, file_format: str | None = None, binary: bool | None = None) -> None:
    """Write ``mesh`` (with ``points`` as its x, y coordinates) atomically to ``path``.

    The original meshio mesh in ``mesh.source`` is written with only x, y of
    its points replaced; it is never modified.  The file appears complete or
    not at all: a temporary file in the target directory is written, synced
    and renamed.

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
    mesh = as_mesh2d(mesh)
    p = Path(os.fspath(path))
    where = f"cannot write '{p}'"
    xy = np.asarray(mesh.points if points is None else points, dtype=np.float64)
    if xy.shape != (mesh.n_points, 2):
        raise InvalidMeshError(f"points have shape {xy.shape}, expected ({mesh.n_points}, 2)")
    if not np.isfinite(xy).all():
        raise InvalidMeshError(f"node {int(np.flatnonzero(~np.isfinite(xy).all(axis=1))[0])} has a non-finite coordinate")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        what = "is not a directory" if parent.exists() else "does not exist"
        raise MeshWriteError(f"{where}: directory '{parent}' {what}")
    if p.is_dir():
        raise MeshWriteError(f"{where}: is a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise MeshWriteError(f"{where}: directory '{parent}' is not writable")
    fmt = output_format(p, file_format)
    src = mesh.source if isinstance(mesh.source, _Source) else None
    _check_binary(fmt, binary, where)
    try:
        out = _out_mesh(mesh, src, xy, fmt)
    except AngleSmoothError:
        raise
    except Exception as e:
        raise MeshWriteError(f"{where}: {_reason(e)}") from None
    suffix = "".join(p.suffixes[-2:]) if fmt in ("permas", "netgen") else p.suffix
    try:  # root passes os.access on read-only file systems (and /sys, /proc): creating the file tells
        fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.tmp", suffix=suffix, dir=parent)
    except OSError as e:
        raise MeshWriteError(f"{where}: cannot create a file in '{parent}': {e.strerror or _reason(e)}") from None
    os.close(fd)
    try:
        with _quiet():
            _write_meshio(tmp, out, fmt, src, binary, final=p)
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.chmod(tmp, _mode_for(p))
        os.replace(tmp, p)
    except BaseException as e:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(e, AngleSmoothError) or not isinstance(e, (Exception, SystemExit)):
            raise
        if isinstance(e, MemoryError):
            raise MeshWriteError(f"{where}: out of memory") from None
        raise MeshWriteError(f"{where}: {_reason(e)}") from None


def _mode_for(p: Path) -> int:
    try:
        return p.stat().st_mode & 0o7777
    except OSError:
        mask = os.umask(0)
        os.umask(mask)
        return 0o666 & ~mask


def output_format(path, file_format: str | None = None) -> str:
    """The format :func:`write` uses for ``path``: ``file_format`` (a name or alias) or the extension's.

    Raises UnknownFormatError (exit code 2) for an unknown name, MeshWriteError for an unknown extension.

    >>> output_format("a.msh"), output_format("-", "msh"), output_format("b.xmf")
    ('gmsh', 'gmsh', 'xdmf')
    """
    if file_format is not None:
        return formats.resolve(file_format)
    p = Path(os.fspath(path))
    cands = _formats_for(p)
    if not cands:
        raise MeshWriteError(
            f"cannot write '{p}': unknown file extension '{''.join(p.suffixes) or '(none)'}' (name the format)"
        )
    return "gmsh" if "gmsh" in cands else cands[0]


def _check_binary(fmt: str, binary: bool | None, where: str) -> None:
    if binary is not None and fmt not in formats.BINARY_CHOICE:
        raise MeshWriteError(f"{where}: format {fmt} has no ASCII/binary choice ({'binary' if binary else 'ASCII'} asked)")


def _default_binary(fmt: str, src: _Source | None) -> bool | None:
    """The input's encoding when it was read from the same format (None: the writer's default)."""
    if src is None or src.binary is None or src.format is None:
        return None
    return src.binary if src.format == fmt else None


def _has_h5py() -> bool:
    try:
        import h5py  # noqa: F401
    except ImportError:
        return False
    return True


def _write_xdmf_hdf(tmp: str, out, final: Path) -> None:
    """XDMF with HDF5 data; the ``.h5`` is ``final`` with suffix ``.h5``, beside it.

    meshio names the ``.h5`` after the ``.xdmf`` it writes and refers to it by
    that name (which is why a temporary ``.xdmf`` used to get inline XML): both
    are written under their final names in a temporary directory beside
    ``final``; the ``.h5`` is moved into place, the ``.xdmf`` goes to ``tmp``,
    which :func:`write` renames last.
    """
    import meshio

    parent = Path(tmp).parent
    with tempfile.TemporaryDirectory(prefix=f".{final.name}.tmp", dir=parent) as d:
        x = Path(d) / final.name
        meshio.xdmf.write(str(x), out, data_format="HDF")
        h5 = x.with_suffix(".h5")
        with open(h5, "rb+") as f:
            os.fsync(f.fileno())
        os.replace(x, tmp)
        os.replace(h5, parent / h5.name)


def _write_meshio(tmp: str, out, fmt: str, src: _Source | None, binary: bool | None, final: Path | None = None) -> None:
    import meshio

    if fmt in ("gmsh", "gmsh22", "gmsh40", "gmsh41"):
        from meshio import gmsh

        version = {"gmsh22": "2.2", "gmsh40": "4.0", "gmsh41": "4.1"}.get(fmt)
        if version is None:
            version = src.gmsh_version if src is not None and src.gmsh_version in _GMSH_WRITE_VERSIONS else "2.2"
        if binary is None:
            binary = bool(src.gmsh_binary) if src is not None and src.gmsh_version else False
        gmshfile.gmsh_tags(out)
        gmshfile.gmsh_data(out, ascii_=not binary)
        if version == "4.1":  # meshio's 4.1 writer refuses two cell blocks of one entity
            gmsh_src = src if src is not None and src.gmsh_version else None
            gmshfile.write(tmp, out, binary=binary, entities=gmsh_src.gmsh_entities if gmsh_src else None,
                        node_tags=src.node_tags if src is not None else None)
            return
        if version == "4.0":
            gmshfile.gmsh4_entities(out)
        gmsh.write(tmp, out, fmt_version=version, binary=binary)
        return
    if binary is None:
        binary = _default_binary(fmt, src)
    if fmt == "xdmf":
        # HDF5 data (meshio's default) needs h5py and the final file name; else inline XML
        if binary is not False and final is not None and _has_h5py():
            _write_xdmf_hdf(tmp, out, final)
        else:
            meshio.xdmf.write(tmp, out, data_format="XML")
    elif fmt == "vtu" and binary is False:
        meshio.vtu.write(tmp, out, binary=False)
    else:
        kwargs = {} if binary is None else {"binary": binary}
        meshio.write(tmp, out, file_format=fmt, **kwargs)


def _out_mesh(mesh: Mesh2D, src: _Source | None, xy: np.ndarray, fmt: str):
    """A fresh meshio.Mesh for format ``fmt``, sharing no mutable container with the source."""
    m = _copy_with_points(mesh, src, xy)
    if fmt.startswith("gmsh") and not m.field_data:
        _names_from_sets(m)
    return _adapt_sets(m, fmt)


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


def _copy_with_points(mesh: Mesh2D, src: _Source | None, xy: np.ndarray):
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


# ---------------------------------------------------------------------------
# meshio objects, node tags, the output check
# ---------------------------------------------------------------------------


def as_mesh2d(mesh) -> Mesh2D:
    """``mesh`` itself if it is a :class:`Mesh2D`; a ``meshio.Mesh`` is converted (as :func:`read` would).

    >>> import meshio
    >>> as_mesh2d(meshio.Mesh([[0, 0], [1, 0], [0, 1]], [("triangle", [[0, 1, 2]])])).n_cells
    1
    """
    if isinstance(mesh, Mesh2D):
        return mesh
    if hasattr(mesh, "points") and hasattr(mesh, "cells") and hasattr(mesh, "cell_data"):
        return _to_mesh2d(mesh, _Source(mesh, None, None, None, False))
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
    return _copy_with_points(mesh, mesh.source if isinstance(mesh.source, _Source) else None, xy)


def node_tags(mesh) -> np.ndarray | None:
    """The gmsh node tag (1-based) of every node of a mesh read from an MSH file, else None."""
    src = getattr(mesh, "source", None)
    tags = getattr(src, "node_tags", None)
    if tags is None or len(tags) != mesh.n_points:
        return None
    return np.asarray(tags, dtype=np.int64)


def _sample(m, node_tags_):
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
        if cols and all(len(x) == nc for x in cols):
            _, first = np.unique(np.column_stack(cols), axis=0, return_index=True)
            rows.append(np.sort(first))
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


def _lost_cells(sample, target: Path, fmt: str) -> str | None:
    """'quad' / 'triangle' when the written sample reads back with fewer such cells (a writer that drops them)."""
    from meshio._helpers import reader_map

    if fmt.startswith("gmsh") or fmt not in reader_map:
        return None
    try:
        with _quiet():
            back = reader_map[fmt](str(target))
    except (Exception, SystemExit):
        return None  # not readable by meshio (or not alone): nothing to compare

    def count(m) -> tuple[int, int]:
        tri = quad = 0
        for c in m.cells:
            data = np.asarray(c.data)
            width = data.shape[1] if data.ndim == 2 else 0
            tri += len(data) if c.type in _TRI or (c.type == "polygon" and width == 3) else 0
            quad += len(data) if c.type in _QUAD or (c.type == "polygon" and width == 4) else 0
        return tri, quad

    (t0, q0), (t1, q1) = count(sample), count(back)
    return "quad" if q1 < q0 else "triangle" if t1 < t0 else None


def check_output(mesh, path, *, file_format: str | None = None, binary: bool | None = None) -> str:
    """Fail now if the output format cannot hold ``mesh``; return the format name.

    Writes a sample of the mesh (one cell of every cell block and tag
    combination) in the output format to a temporary directory and reads it
    back, so that a writer's refusal, or a writer that silently drops a cell
    type (WKT keeps only triangles), is found before smoothing rather than after.

    Raises
    ------
    UnknownFormatError, MeshWriteError
    """
    mesh = as_mesh2d(mesh)
    p = Path(os.fspath(path))
    fmt = output_format(p, file_format)
    where = f"cannot write '{p}'"
    _check_binary(fmt, binary, where)
    src = mesh.source if isinstance(mesh.source, _Source) else None
    try:
        full = _out_mesh(mesh, src, np.asarray(mesh.points), fmt)
        sample, tags = _sample(full, src.node_tags if src is not None else None)
        sample_src = replace(src, mesh=sample, node_tags=tags) if src is not None else None
        with tempfile.TemporaryDirectory(prefix="anglesmooth-check-") as d:
            target = Path(d) / ("sample" + ("".join(p.suffixes[-2:]) if fmt in ("permas", "netgen") else p.suffix))
            with _quiet():
                _write_meshio(str(target), sample, fmt, sample_src, binary, final=target)
            lost = _lost_cells(sample, target, fmt)
        if lost:
            raise MeshWriteError(f"{where}: the {fmt} format cannot hold this mesh: its {lost} cells would be lost")
    except AngleSmoothError:
        raise
    except MemoryError:
        raise MeshWriteError(f"{where}: out of memory") from None
    except (Exception, SystemExit) as e:
        raise MeshWriteError(f"{where}: the {fmt} format cannot hold this mesh: {_reason(e)}") from None
    return fmt
