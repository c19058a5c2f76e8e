"""Reading: meshio's gmsh readers wrapped to keep the node tags and the whole MSH 4.1 ``$Entities`` table."""

from __future__ import annotations

import threading
from functools import partial
from typing import Any

import numpy as np

__all__ = ["install", "take_captured"]

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
