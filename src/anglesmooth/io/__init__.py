"""Reading meshes into :class:`~anglesmooth.mesh.Mesh2D` and writing them back.

This is the only module that imports :mod:`meshio` (lazily, inside functions).
:func:`read` accepts any format meshio reads; :func:`write` writes the original
meshio mesh back with only the coordinates of moved nodes replaced, so node
order, z, cell blocks (lines, vertices, second-order cells), point/cell/field
data and sets survive as far as the target format can hold them.

Format notes
------------
* ``.msh`` is always written as gmsh (meshio would pick ANSYS).  The MSH
  version and ASCII/binary mode of a gmsh input are kept; other inputs are
  written as MSH 2.2 ASCII, which stores physical and geometrical tags per
  element (MSH 4 stores one tag per cell block, and non-gmsh readers merge
  blocks).  Missing gmsh tags are taken from ``medit:ref`` / ``CellEntityIds``
  or set to 0.  Asking for MSH 4.1 explicitly (``file_format="gmsh41"``) for a
  mesh without gmsh entities makes one entity per cell block (or per
  ``gmsh:geometrical`` tag).  MSH 4.0 is not written (meshio's writer loses
  entities and groups): a 4.0 input is written back as 4.1.
* ``.xdmf`` is written with HDF5 data (``NAME.h5`` beside ``NAME.xdmf``), as
  meshio does by default, unless the input was XDMF with inline XML data,
  ``binary=False`` is asked, or h5py is missing.
* MSH 4.1 is written by :mod:`anglesmooth.gmshfile` (meshio's writer refuses
  two cell blocks of one entity); the conversion between meshio meshes and
  :class:`Mesh2D` is :mod:`anglesmooth.meshconv`, the plane of 3D meshes
  :mod:`anglesmooth.plane`, format names :mod:`anglesmooth.formats`.
* VTU, VTK, XDMF, ... cannot hold cell/point sets or field data: every named
  group (cell set, point set, gmsh physical group) is stored as an integer
  data array ``"set:NAME"`` (1 = member), which :func:`read` turns back into a
  group.  gmsh physical tags survive as the ``gmsh:physical`` cell data array.
"""

from __future__ import annotations

import errno
import os
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np

from .. import _guard, _paths, formats, gmshfile
from ..errors import AngleSmoothError, InvalidMeshError, MeshReadError, MeshWriteError, UnsupportedMeshError
from ..mesh import Mesh2D
from ..meshconv import _QUAD, _TRI, as_mesh2d, node_tags, to_meshio  # noqa: F401  (to_meshio: public through io)
from ..meshconv import Source as _Source
from ..meshconv import out_mesh as _out_mesh
from ..meshconv import sample as _sample
from ..meshconv import to_mesh2d as _to_mesh2d
from . import _vtu
from ._common import _formats_for, _gmsh_header, _meshio, _plain_reason, _quiet, _reason, supported_formats

__all__ = ["as_mesh2d", "check_output", "node_tags", "output_format", "read", "supported_formats", "to_meshio", "write"]

# ---------------------------------------------------------------------------
# read
# ---------------------------------------------------------------------------


def read(path, *, file_format: str | None = None) -> Mesh2D:
    """Read a planar triangle / quad mesh from any format meshio reads.

    A mesh with three coordinates may lie in any plane: its plane is fitted
    here (``Mesh2D.frame``, see :mod:`anglesmooth.plane`) and ``points`` are
    the coordinates in that plane (x, y for z = const).

    Parameters
    ----------
    path : str or os.PathLike
        The mesh file.
    file_format : str, optional
        A format name or alias (``"gmsh"``, ``"msh"``, ``"vtu"``, ...; see
        :mod:`anglesmooth.formats`) for files whose extension does not tell.

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
        return _to_mesh2d(m, src, owned=True)  # m is ours and kept unmodified in src: share its cells
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
            with _quiet(), _guard.limits(p, name):
                m = reader_map[name](str(p))
            got = gmshfile.take_captured() if name.startswith("gmsh") else {}
            return m, name, {"node_tags": got.get("node_tags"), "gmsh_entities": got.get("entities")}
        except MemoryError:
            raise MeshReadError(f"{where}: too large to read: out of memory") from None
        except (Exception, SystemExit) as e:
            cause = e
            if isinstance(e, meshio.ReadError) and not str(e).strip() and e.__context__ is not None:
                cause = e.__context__
            detail = _plain_reason(cause)
            reasons.append(f"not a valid {name} file ({detail})")
    raise MeshReadError(f"{where}: {'; '.join(reasons) if len(reasons) < 3 else reasons[0] + '; ...'}")


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
        Format name or alias (``"gmsh41"``, ``"msh"``, ``"vtu"``, ...); default
        from the extension (``.msh`` is gmsh).
    binary : bool, optional
        Binary or ASCII where the format has both (XDMF: HDF5 or inline XML);
        default: the input's encoding when it has the output's format (gmsh:
        the input's MSH mode), the writer's default otherwise.

    Raises
    ------
    MeshWriteError, InvalidMeshError, UnknownFormatError

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
    try:  # temporary file + rename for a regular file, streamed into a device / FIFO (see _paths)
        _paths.atomic_write(p, lambda tmp: _write_quiet(tmp, out, fmt, src, binary, final=p), suffix=suffix)
    except BaseException as e:
        if isinstance(e, AngleSmoothError) or not isinstance(e, (Exception, SystemExit)):
            raise
        if isinstance(e, MemoryError):
            raise MeshWriteError(f"{where}: out of memory") from None
        raise MeshWriteError(f"{where}: {_reason(e)}") from None


def prepare_write(mesh: Mesh2D, path, *, file_format: str | None = None, binary: bool | None = None) -> bool:
    """Start, on a background thread, the work of a later :func:`write` of ``mesh`` to ``path`` that the
    new points do not change (compressed VTU: the cell arrays' zlib blocks, see ``_vtu.precompress``);
    True when started.  The file :func:`write` makes is the same either way."""
    try:
        mesh = as_mesh2d(mesh)
        fmt = output_format(Path(os.fspath(path)), file_format)
        src = mesh.source if isinstance(mesh.source, _Source) else None
        if fmt != "vtu" or (binary if binary is not None else _default_binary(fmt, src)) is False:
            return False
        out = _out_mesh(mesh, src, np.asarray(mesh.points, dtype=np.float64), fmt)
        out.points = None  # a copy, not needed (the cells and cell data are the source's arrays)
        return _vtu.precompress(out)
    except Exception:  # noqa: BLE001 - the write itself reports any problem
        return False


def _write_quiet(tmp: str, out, fmt: str, src: _Source | None, binary: bool | None, final: Path | None = None) -> None:
    with _quiet():
        _write_meshio(tmp, out, fmt, src, binary, final=final)


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
            f"cannot write '{p}': unknown file extension '{''.join(p.suffixes) or '(none)'}' "
            "(name the format with --output-format)"
        )
    return "gmsh" if "gmsh" in cands else cands[0]


def _check_binary(fmt: str, binary: bool | None, where: str) -> None:
    """Refuse what cannot be written: MSH 4.0, an encoding the format has no choice of."""
    if fmt == "gmsh40":
        raise MeshWriteError(f"{where}: MSH 4.0 output is not supported (meshio's 4.0 writer loses the entities "
                             "and physical groups); write MSH 4.1 (gmsh41) or 2.2 (gmsh22)")
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
    """XDMF with HDF5 data; the ``.h5`` is ``final`` (OUTPUT as named) with suffix ``.h5``, beside it.

    meshio names the ``.h5`` after the ``.xdmf`` it writes and refers to it by
    that name (which is why a temporary ``.xdmf`` used to get inline XML): both
    are written under their final names in a temporary directory beside the
    staged ``tmp``; the ``.xdmf`` goes to ``tmp``, which :func:`write` renames, and
    the ``.h5`` is written as an output of its own (:func:`._paths.atomic_write`):
    inside a command's :class:`._paths.Outputs` it is staged and committed with
    the other outputs (so a run that fails after the write leaves no ``.h5``
    behind and keeps the one that was there), outside one it is renamed into
    place at once.

    A symlinked OUTPUT ``out.xdmf -> elsewhere/real.xdmf`` is followed, as every
    output: the XDMF replaces ``real.xdmf`` and its data is ``elsewhere/real.h5``,
    the name it refers to (meshio's reader looks for it beside the link's target),
    the path the command line checks like every other output.  It used to be
    ``elsewhere/out.h5``, a path nobody checked, where it could replace an input.
    """
    import meshio

    if os.path.islink(final):
        final = Path(os.path.realpath(final))
    target = final.with_suffix(".h5")
    with _paths.temporary_directory(Path(tmp).parent, prefix=f".{final.name}.tmp") as d:
        x = Path(d) / final.name
        meshio.xdmf.write(str(x), out, data_format="HDF")
        h5 = x.with_suffix(".h5")
        _paths.atomic_write(target, lambda t: _move(h5, Path(t)), suffix=".h5")
        os.replace(x, tmp)


def _move(src: Path, dst: Path) -> None:
    """Rename ``src`` over ``dst``; copied when they are on two file systems (a symlinked OUTPUT's target)."""
    try:
        os.replace(src, dst)
    except OSError as exc:
        if exc.errno != errno.EXDEV:
            raise
        shutil.copyfile(src, dst)


def _write_meshio(tmp: str, out, fmt: str, src: _Source | None, binary: bool | None, final: Path | None = None) -> None:
    import meshio

    if fmt in ("gmsh", "gmsh22", "gmsh40", "gmsh41"):
        from meshio import gmsh

        version = {"gmsh22": "2.2", "gmsh41": "4.1"}.get(fmt)
        if version is None:  # the input's version; 4.0 (not written, see _check_binary) becomes 4.1
            old = src.gmsh_version if src is not None else None
            version = "4.1" if old in ("4", "4.0", "4.1") else "2.2"
        if binary is None:
            binary = bool(src.gmsh_binary) if src is not None and src.gmsh_version else False
        gmshfile.gmsh_tags(out)
        gmshfile.gmsh_data(out, ascii_=not binary)
        if version == "4.1":  # meshio's 4.1 writer refuses two cell blocks of one entity
            gmsh_src = src if src is not None and src.gmsh_version else None
            gmshfile.write(tmp, out, binary=binary, entities=gmsh_src.gmsh_entities if gmsh_src else None,
                        node_tags=src.node_tags if src is not None else None)
            return
        gmsh.write(tmp, out, fmt_version=version, binary=binary)  # 2.2
        return
    if binary is None:
        binary = _default_binary(fmt, src)
    if fmt == "xdmf":
        # HDF5 data (meshio's default) needs h5py and a regular file (the .h5 goes beside it); else inline XML
        regular = final is not None and (final.is_file() or not final.exists())
        if binary is not False and regular and _has_h5py():
            _write_xdmf_hdf(tmp, out, final)
        else:
            meshio.xdmf.write(tmp, out, data_format="XML")
    elif fmt == "vtu" and binary is False:
        meshio.vtu.write(tmp, out, binary=False)
    elif fmt == "vtu":  # binary, zlib (meshio's default): the same bytes, the blocks compressed on threads
        with _vtu.threaded_zlib():
            meshio.write(tmp, out, file_format=fmt)
    else:
        kwargs = {} if binary is None else {"binary": binary}
        meshio.write(tmp, out, file_format=fmt, **kwargs)


# ---------------------------------------------------------------------------
# meshio objects, node tags, the output check
# ---------------------------------------------------------------------------


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
        with _paths.temporary_directory(prefix="anglesmooth-check-") as d:
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
