"""Making a meshio mesh storable in MSH (any version): region tags and point / cell data."""

from __future__ import annotations

import numpy as np

__all__ = ["gmsh_data", "gmsh_tags", "int_tags"]

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
