"""Writing, the bookkeeping: element blocks per cell block and entity, repeated elements, entities and node tags."""

from __future__ import annotations

import numpy as np

__all__ = ["first_of_duplicates"]


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
