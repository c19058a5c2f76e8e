"""gmsh files: what meshio's readers drop, and an MSH 4.1 writer that holds any mesh.

Reading
    :func:`install` wraps meshio's gmsh readers (once) so that each read leaves
    behind, in :func:`take_captured`, the gmsh node tags of the points (MSH 2.2,
    4.0, 4.1) and the whole MSH 4.1 ``$Entities`` table: bounding boxes, *all*
    physical tags of every entity and its bounding entities (meshio keeps one
    physical tag per entity and no bounding box).  It also reads MSH 4.1 files
    with elements outside every physical group, which meshio refuses.

Writing
    meshio's MSH 4.1 writer refuses two cell blocks of one entity ("non-unique
    CellBlock dim_tag"), which is what gmsh writes for a surface holding
    triangles and quads (``BoundaryLayer`` field with ``Quads = 1``, partial
    recombination).  The format allows one element block per entity *and element
    type*; :func:`write` writes such files, ASCII or binary:

    * ``$Entities``: the table read from the source when there is one (all
      physical tags, bounding entities, boxes), else one entity per
      (dimension, ``gmsh:geometrical`` tag) with the physical tags of its cells
      and a box around its nodes;
    * ``$Nodes``: one block per run of consecutive points on one entity
      (``gmsh:dim_tags``, or the lowest-dimensional entity of a cell using the
      node), so that the node order is kept, with the source's node tags
      (else 1..N);
    * ``$Elements``: one block per cell block and entity, element tags 1..M;
    * ``$PhysicalNames``, ``$Periodic``, ``$NodeData`` / ``$ElementData`` (1, 3
      or 9 doubles per node / element).
"""

from __future__ import annotations

import threading
from functools import partial
from typing import Any

import numpy as np

__all__ = ["first_of_duplicates", "gmsh_data", "gmsh_tags", "install", "int_tags", "take_captured", "write"]

_LOCAL = threading.local()  # per thread: reads in several threads do not mix their captures
_INSTALLED = False


def _captured() -> dict[str, Any]:
    if not hasattr(_LOCAL, "data"):
        _LOCAL.data = {}
    return _LOCAL.data


def take_captured() -> dict[str, Any]:
    """What this thread's last gmsh read left behind: ``node_tags`` (1-based, per point) and ``entities``."""
    data = _captured()
    out = dict(data)
    data.clear()
    return out


def install() -> None:
    """Wrap meshio's gmsh node and entity readers to capture node tags and the entity table."""
    global _INSTALLED
    if _INSTALLED:
        return
    from meshio.gmsh import _gmsh22, _gmsh40, _gmsh41

    def wrap(mod, offset):
        orig = mod._read_nodes

        def _read_nodes(*args, **kwargs):
            out = orig(*args, **kwargs)
            _captured()["node_tags"] = np.asarray(out[1], dtype=np.int64) + offset
            return out

        mod._read_nodes = _read_nodes

    wrap(_gmsh22, 0)
    wrap(_gmsh40, 0)
    wrap(_gmsh41, 1)  # meshio 5.3 returns tag - 1 there
    _gmsh41._read_entities = _read_entities_41
    _gmsh41._read_elements = _physical_per_block(_gmsh41._read_elements)
    _INSTALLED = True


def _physical_per_block(orig):
    """meshio's MSH 4.1 ``_read_elements``, with ``gmsh:physical`` for every cell block.

    meshio appends a ``gmsh:physical`` array only for blocks whose entity has a
    physical tag, so a file with elements outside every physical group
    (``Mesh.SaveAll = 1``) has fewer arrays than blocks and meshio refuses it
    ("Incompatible cell data"); the missing blocks get 0 (no group).
    """

    def _read_elements(f, point_tags, physical_tags, *args, **kwargs):
        cells, cell_data, cell_sets = orig(f, point_tags, physical_tags, *args, **kwargs)
        phys, geo = cell_data.get("gmsh:physical"), cell_data.get("gmsh:geometrical")
        if phys is not None and geo is not None and len(phys) != len(cells) and physical_tags:
            cell_data["gmsh:physical"] = [
                np.full(len(g), (list(physical_tags[c.dim].get(int(g[0]), [])) or [0])[0] if len(g) else 0, int)
                for c, g in zip(cells, geo)
            ]
        return cells, cell_data, cell_sets

    return _read_elements


def _read_entities_41(f, is_ascii: bool, data_size):
    """meshio's ``_read_entities`` (same return value), keeping the whole table."""
    from meshio.gmsh._gmsh41 import _size_type
    from meshio.gmsh.common import _fast_forward_to_end_block

    fromfile = partial(np.fromfile, sep=" " if is_ascii else "")
    c_int, c_double, c_size_t = np.dtype("i"), np.dtype("d"), _size_type(data_size)
    physical_tags: tuple[dict, ...] = ({}, {}, {}, {})
    bounding_entities: tuple[dict, ...] = ({}, {}, {}, {})
    table: dict[tuple[int, int], tuple] = {}
    number = fromfile(f, c_size_t, 4)
    for d, n in enumerate(number):
        for _ in range(n):
            (tag,) = fromfile(f, c_int, 1)
            box = fromfile(f, c_double, 3 if d == 0 else 6)
            (num_physicals,) = fromfile(f, c_size_t, 1)
            phys = fromfile(f, c_int, num_physicals)
            physical_tags[d][tag] = list(phys)
            bounds = np.zeros(0, np.int32)
            if d > 0:
                num_bounds = fromfile(f, c_size_t, 1)[0]
                bounds = fromfile(f, c_int, num_bounds)
                bounding_entities[d][tag] = bounds
            table[(d, int(tag))] = (np.array(box, np.float64), tuple(int(p) for p in phys), tuple(int(b) for b in bounds))
    _fast_forward_to_end_block(f, "Entities")
    _captured()["entities"] = table
    return physical_tags, bounding_entities


# ---------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------

_FLOAT = "%.17g"  # 17 significant digits: every double reads back bit for bit
_CHUNK = 200_000
_MAX_RUNS = 1000  # node blocks kept in point order up to this many (or 4 per entity)


class _Out:
    """ASCII or binary output of numbers, in chunks (no Python loop per row)."""

    def __init__(self, fh, binary: bool):
        self.fh, self.binary = fh, binary

    def text(self, s: str) -> None:
        self.fh.write(s.encode())

    def ints(self, values, dtype, sep: str = " ") -> None:
        a = np.asarray(values).astype(dtype, copy=False).ravel()
        if self.binary:
            self.fh.write(a.tobytes())
        else:
            self.text(sep.join(map(str, a.tolist())) + "\n")

    def table(self, columns: list[np.ndarray], dtypes: list[str]) -> None:
        """Rows made of several columns (each (n,) or (n, k)) of the given dtypes."""
        cols = [np.asarray(c).reshape(len(c), -1) for c in columns]
        n = cols[0].shape[0] if cols else 0
        if self.binary:
            fields = [(f"f{i}", dt, (c.shape[1],)) for i, (c, dt) in enumerate(zip(cols, dtypes))]
            rec = np.empty(n, dtype=fields)
            for i, c in enumerate(cols):
                rec[f"f{i}"] = c
            self.fh.write(rec.tobytes())
            return
        fmt = " ".join(" ".join([_FLOAT if dt == "d" else "%d"] * c.shape[1]) for c, dt in zip(cols, dtypes)) + "\n"
        for s in range(0, n, _CHUNK):
            e = min(n, s + _CHUNK)
            parts = [c[s:e].astype(np.float64 if dt == "d" else np.int64) for c, dt in zip(cols, dtypes)]
            flat = np.concatenate([p.astype(object) for p in parts], axis=1) if len(parts) > 1 else parts[0]
            self.text((fmt * (e - s)) % tuple(flat.ravel().tolist()))

    def end(self, name: str) -> None:
        if self.binary:
            self.fh.write(b"\n")
        self.text(f"$End{name}\n")


def _cell_tags(m, key: str) -> list[np.ndarray] | None:
    data = m.cell_data.get(key)
    if data is None or len(data) != len(m.cells):
        return None
    return [np.asarray(a).reshape(-1).astype(np.int64) for a in data]


def _element_blocks(m, geo: list[np.ndarray]) -> list[tuple[int, int, int, np.ndarray]]:
    """(dim, entity tag, cell block, rows) per element block: each cell block split by entity."""
    out = []
    for b, c in enumerate(m.cells):
        g = geo[b]
        if not len(g):
            continue
        if (g == g[0]).all():
            out.append((c.dim, int(g[0]), b, np.arange(len(g))))
            continue
        out += [(c.dim, int(g[seg[0]]), b, seg) for seg in _segments(g)]
    return out


def _segments(values: np.ndarray) -> list[np.ndarray]:
    """Indices of each distinct value (one sort, not one pass per value), ascending within a segment."""
    order = np.argsort(values, kind="stable")
    v = values[order]
    return np.split(order, np.flatnonzero(v[1:] != v[:-1]) + 1)


def first_of_duplicates(cells: np.ndarray) -> np.ndarray:
    """Mask keeping the first of cells with the same node set (any order).

    >>> first_of_duplicates(np.array([[0, 1, 2], [1, 2, 3], [2, 0, 1]])).tolist()
    [True, True, False]
    """
    if len(cells) < 2:
        return np.ones(len(cells), bool)
    cells = np.asarray(cells, dtype=np.int64)
    if cells.shape[1] == 3 and cells.max() < 2**21:  # sorted corners packed in one int64: one 1D sort
        a, b, c = cells[:, 0], cells[:, 1], cells[:, 2]
        lo, hi = np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)
        key = (lo << 42) | ((a + b + c - lo - hi) << 21) | hi
        order = np.argsort(key, kind="stable")  # stable: among equal cells the first occurrence leads
        ks = key[order]
        same = ks[1:] == ks[:-1]
    else:
        s = np.sort(cells, axis=1)
        order = np.lexsort(s.T[::-1])  # rows in lexicographic order (stable as well)
        ordered = s[order]
        same = (ordered[1:] == ordered[:-1]).all(axis=1)
    keep = np.ones(len(cells), bool)
    keep[order[1:][same]] = False
    return keep


def _merge_repeats(m, blocks, phys):
    """MSH 2.2 repeats an element once per physical group: keep the first, put its entity in every group.

    Returns the blocks without the repetitions and {(dim, tag): physical tags of the dropped copies}.
    """
    out, extra = [], {}
    for dim, tag, b, rows in blocks:
        keep = first_of_duplicates(np.asarray(m.cells[b].data)[rows])
        if not keep.all():
            extra.setdefault((dim, tag), set()).update(int(v) for v in np.unique(phys[b][rows[~keep]]) if v != 0)
            rows = rows[keep]
        out.append((dim, tag, b, rows))
    return out, extra


def _split_by_physical(blocks, phys, used_tags):
    """MSH 4 gives physical groups per entity: an entity whose cells have several physical tags is split.

    The cells of the entity's smallest physical tag keep the entity; the others get new entity tags of
    that dimension.
    """
    groups: dict[tuple[int, int], list] = {}
    for blk in blocks:
        groups.setdefault((blk[0], blk[1]), []).append(blk)
    next_tag = {d: t + 1 for d, t in used_tags.items()}
    out = []
    for (dim, tag), members in groups.items():
        values = np.unique(np.concatenate([phys[b][rows] for _, _, b, rows in members]))
        if values.size <= 1:
            out += members
            continue
        new = {int(values[0]): tag}
        for v in values[1:].tolist():
            new[v] = next_tag.get(dim, 1)
            next_tag[dim] = new[v] + 1
        for _, _, b, rows in members:
            p = phys[b][rows]
            out += [(dim, new[int(p[seg[0]])], b, rows[seg]) for seg in _segments(p)]
    return out


def _node_dim_tags(m, blocks, n: int) -> np.ndarray:
    dt = m.point_data.get("gmsh:dim_tags")
    if dt is not None:
        dt = np.asarray(dt).astype(np.int64)
        if dt.shape == (n, 2):
            return dt
    out = np.zeros((n, 2), np.int64)
    if blocks:
        top = max(blocks, key=lambda blk: blk[0])
        out[:] = (top[0], top[1])
    for dim, tag, b, rows in sorted(blocks, key=lambda blk: -blk[0]):  # lower dimensions last: they win
        out[np.asarray(m.cells[b].data)[rows].ravel()] = (dim, tag)
    return out


def _entities(m, pts, fpts, blocks, phys, runs, source_table, extra_phys=None):
    """{(dim, tag): (box, physical tags, bounding tags)} in the order to write.

    ``runs`` are the node blocks (key, start, count) into ``fpts`` (the nodes in
    file order); an entity not in the source table gets a box around its
    classified nodes and its cells' nodes.
    """
    table: dict[tuple[int, int], tuple] = dict(source_table or {})
    bounding_sets = m.cell_sets.get("gmsh:bounding_entities")
    extra: dict[tuple[int, int], list] = {}
    node_runs: dict[tuple[int, int], list] = {}
    for dim, tag, b, rows in blocks:
        extra.setdefault((dim, tag), []).append((b, rows))
    for key, start, cnt in runs:
        extra.setdefault(key, [])
        node_runs.setdefault(key, []).append(fpts[start : start + cnt])
    for key in sorted(extra):
        if key in table:
            continue
        dim, tag = key
        parts = [pts[np.asarray(m.cells[b].data)[rows].ravel()] for b, rows in extra[key]] + node_runs.get(key, [])
        xyz = np.concatenate(parts) if any(len(x) for x in parts) else np.zeros((1, 3))
        box = xyz[0] if dim == 0 else np.concatenate([xyz.min(axis=0), xyz.max(axis=0)])
        ph = {int(v) for b, rows in extra[key] if phys is not None for v in np.unique(phys[b][rows]) if v != 0}
        ph = sorted(ph | (extra_phys or {}).get(key, set()))
        bounds: tuple = ()
        if bounding_sets is not None and len(bounding_sets) == len(m.cells) and extra[key]:
            bset = bounding_sets[extra[key][0][0]]
            bounds = tuple(int(v) for v in np.asarray(bset if bset is not None else [], dtype=np.int64).ravel())
        table[key] = (box, tuple(ph), bounds)
    have = {d: {t for dd, t in table if dd == d} for d in range(4)}
    kept = set(source_table or {})  # gmsh's own lists are written verbatim
    return {
        key: (box, ph, bnd if key in kept else tuple(v for v in bnd if abs(v) in have.get(key[0] - 1, set())))
        for key, (box, ph, bnd) in sorted(table.items(), key=lambda kv: kv[0])
    }


def _valid_tags(tags, n: int) -> np.ndarray:
    if tags is not None:
        t = np.asarray(tags, dtype=np.int64).reshape(-1)
        if t.shape == (n,) and n and t.min() > 0:
            if (t[1:] > t[:-1]).all():  # the usual case (gmsh writes increasing tags): no sort needed
                return t
            s = np.sort(t)
            if (s[1:] != s[:-1]).all():
                return t
    return np.arange(1, n + 1, dtype=np.int64)


def write(path, m, *, binary: bool, entities=None, node_tags=None) -> None:
    """Write meshio mesh ``m`` as MSH 4.1 (see the module notes).

    ``entities`` is an ``$Entities`` table captured at read time, ``node_tags``
    the source's gmsh node tags (both optional).
    """
    from meshio.gmsh.common import _meshio_to_gmsh_order, _meshio_to_gmsh_type

    pts = np.asarray(m.points, dtype=np.float64)
    if pts.shape[1] == 2:
        pts = np.column_stack([pts, np.zeros(len(pts))])
    n = len(pts)
    geo = _cell_tags(m, "gmsh:geometrical") or [np.full(len(c), k + 1, np.int64) for k, c in enumerate(m.cells)]
    phys = _cell_tags(m, "gmsh:physical")
    blocks = _element_blocks(m, geo)
    extra_phys: dict = {}
    if entities is None and phys is not None:  # not from MSH 4.1: per-element tags to per-entity groups
        blocks, extra_phys = _merge_repeats(m, blocks, phys)
        used: dict[int, int] = {}
        for dim, tag, _, _ in blocks:
            used[dim] = max(used.get(dim, 0), tag)
        dt = m.point_data.get("gmsh:dim_tags")
        if dt is not None and np.asarray(dt).ndim == 2 and len(dt):
            dt = np.asarray(dt)
            for d in np.unique(dt[:, 0]).tolist():
                used[int(d)] = max(used.get(int(d), 0), int(dt[dt[:, 0] == d, 1].max()))
        blocks = _split_by_physical(blocks, phys, used)
    dim_tags = _node_dim_tags(m, blocks, n)
    # node blocks: runs of consecutive points on one entity, so that the node order is kept (the
    # format allows several blocks of one entity; gmsh and meshio read them); when the entities'
    # nodes are interleaved (many runs; meshio reads blocks in a Python loop) they are grouped by
    # entity instead: the order changes, the node tags stay
    node_order = None
    change = np.flatnonzero((dim_tags[1:] != dim_tags[:-1]).any(axis=1)) + 1 if n else np.zeros(0, np.int64)
    if len(change) > max(_MAX_RUNS, 4 * len({(int(d), int(t)) for d, t, _, _ in blocks})):
        code = dim_tags[:, 0] * (1 << 40) + dim_tags[:, 1]
        node_order = np.argsort(code, kind="stable")
        code = code[node_order]
        change = np.flatnonzero(code[1:] != code[:-1]) + 1
    starts = np.concatenate([[0], change]).astype(np.int64) if n else np.zeros(0, np.int64)
    counts = np.diff(np.concatenate([starts, [n]])).astype(np.int64)
    fpts = pts if node_order is None else pts[node_order]  # the nodes in file order
    block_keys = (dim_tags if node_order is None else dim_tags[node_order])[starts]
    runs = [(tuple(k), int(s0), int(c0)) for k, s0, c0 in zip(block_keys.tolist(), starts.tolist(), counts.tolist())]
    table = _entities(m, pts, fpts, blocks, phys, runs, entities, extra_phys)
    tags = _valid_tags(node_tags, n)
    file_tags = tags if node_order is None else tags[node_order]  # the tag of each node as written
    size_t, c_int = "u8", "i4"
    with open(path, "wb") as fh:
        out = _Out(fh, binary)
        out.text(f"$MeshFormat\n4.1 {int(binary)} 8\n")
        if binary:
            fh.write(np.array([1], np.int32).tobytes() + b"\n")
        out.text("$EndMeshFormat\n")
        names = []
        for key, val in (m.field_data or {}).items():
            v = np.asarray(val).reshape(-1)
            if v.size == 2 and v.dtype.kind in "iu":
                names.append((int(v[1]), int(v[0]), str(key)))
        names.sort()
        if names:
            out.text("$PhysicalNames\n" + f"{len(names)}\n" + "".join(f'{d} {t} "{s}"\n' for d, t, s in names))
            out.text("$EndPhysicalNames\n")
        # $Entities
        out.text("$Entities\n")
        per_dim = [sum(1 for d, _ in table if d == k) for k in range(4)]
        out.ints(per_dim, size_t)
        for (dim, tag), (box, ph, bnd) in table.items():
            if binary:
                fh.write(np.array([tag], np.int32).tobytes() + np.asarray(box, np.float64).tobytes())
                fh.write(np.array([len(ph)], np.uint64).tobytes() + np.array(ph, np.int32).tobytes())
                if dim > 0:
                    fh.write(np.array([len(bnd)], np.uint64).tobytes() + np.array(bnd, np.int32).tobytes())
            else:
                items = [str(tag), *(_FLOAT % v for v in np.asarray(box, np.float64)), str(len(ph)), *map(str, ph)]
                if dim > 0:
                    items += [str(len(bnd)), *map(str, bnd)]
                out.text(" ".join(items) + "\n")
        out.end("Entities")
        # $Nodes
        out.text("$Nodes\n")
        out.ints([len(block_keys), n, int(tags.min()) if n else 0, int(tags.max()) if n else 0], size_t)
        start = 0
        for (dim, etag), cnt in zip(block_keys.tolist(), counts.tolist()):
            idx = slice(start, start + cnt)
            start += cnt
            if binary:
                fh.write(np.array([dim, etag, 0], np.int32).tobytes() + np.array([cnt], np.uint64).tobytes())
                fh.write(file_tags[idx].astype(np.uint64).tobytes())
                fh.write(np.ascontiguousarray(fpts[idx]).tobytes())
            else:
                out.text(f"{dim} {etag} 0 {cnt}\n")
                if cnt:
                    out.ints(file_tags[idx], np.int64, sep="\n")
                    out.table([fpts[idx]], ["d"])
        out.end("Nodes")
        # $Elements
        total = sum(len(rows) for *_, rows in blocks)
        out.text("$Elements\n")
        out.ints([len(blocks), total, 1 if total else 0, total], size_t)
        elem_tags, t0 = [], 1
        for dim, etag, b, rows in blocks:
            c = m.cells[b]
            data = np.asarray(c.data)
            conn = tags[_meshio_to_gmsh_order(c.type, data if len(rows) == len(data) else data[rows])]
            ids = np.arange(t0, t0 + len(rows), dtype=np.int64)
            elem_tags.append(ids)
            t0 += len(rows)
            if binary:
                fh.write(np.array([dim, etag, _meshio_to_gmsh_type[c.type]], np.int32).tobytes())
                fh.write(np.array([len(rows)], np.uint64).tobytes())
                rec = np.empty((len(rows), 1 + conn.shape[1]), np.uint64)  # one buffer, no stacked copies
                rec[:, 0] = ids
                rec[:, 1:] = conn
                rec.tofile(fh)
                del rec
            else:
                out.text(f"{dim} {etag} {_meshio_to_gmsh_type[c.type]} {len(rows)}\n")
                out.table([ids, conn], ["i", "i"])
        out.end("Elements")
        if getattr(m, "gmsh_periodic", None):
            from meshio.gmsh._gmsh41 import _write_periodic

            _write_periodic(fh, m.gmsh_periodic, ".16e", binary)
        for name, data in m.point_data.items():
            if name != "gmsh:dim_tags":
                vals = np.asarray(data, dtype=np.float64)  # in file order: meshio reads values by position
                _write_data(out, "NodeData", name, vals if node_order is None else vals[node_order], file_tags)
        skip = ("gmsh:physical", "gmsh:geometrical", "cell_tags")
        for name, per_block in m.cell_data.items():
            if name in skip or len(per_block) != len(m.cells):
                continue
            vals = [np.asarray(per_block[b], dtype=np.float64)[rows] for _, _, b, rows in blocks]
            if vals:
                _write_data(out, "ElementData", name, np.concatenate(vals), np.concatenate(elem_tags))


def _write_data(out: _Out, section: str, name: str, data: np.ndarray, tags: np.ndarray) -> None:
    data = data.reshape(len(data), -1)
    if data.shape[1] not in (1, 3, 9):
        return
    out.text(f'${section}\n1\n"{name}"\n1\n0\n3\n0\n{data.shape[1]}\n{len(data)}\n')
    out.table([tags, data], ["i4" if out.binary else "i", "d"])
    out.end(section)


# ---------------------------------------------------------------------------
# making a meshio mesh storable in MSH (any version)
# ---------------------------------------------------------------------------

_REGION_KEYS = ("gmsh:physical", "gmsh:geometrical", "medit:ref", "CellEntityIds")


def int_tags(arr, n: int) -> np.ndarray | None:
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


def gmsh_tags(m) -> None:
    """Supply gmsh:physical / gmsh:geometrical from the region tags (or zeros) when missing."""
    key = next((k for k in _REGION_KEYS[2:] if k in m.cell_data), None)
    for name in ("gmsh:physical", "gmsh:geometrical"):
        if name not in m.cell_data:
            m.cell_data[name] = [
                _physical_from(m.cell_data[key][b] if key else None, len(c)) for b, c in enumerate(m.cells)
            ]


def _physical_from(tags, nc: int) -> np.ndarray:
    t = int_tags(tags, nc) if tags is not None else None
    return np.zeros(nc, np.int32) if t is None else t.astype(np.int32)


def gmsh_data(m, ascii_: bool) -> None:
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
