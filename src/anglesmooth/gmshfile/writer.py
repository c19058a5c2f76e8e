"""Writing: the MSH 4.1 file itself, ASCII or binary (see the package notes)."""

from __future__ import annotations

import numpy as np

from .blocks import (_cell_tags, _element_blocks, _entities, _merge_repeats, _node_dim_tags, _split_by_physical,
                     _valid_tags)

__all__ = ["write"]

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
