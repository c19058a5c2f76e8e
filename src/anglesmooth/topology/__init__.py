"""Mesh topology, built once per mesh with numpy only.

Modules, imported in one direction: :mod:`.types` (the dataclasses), :mod:`._keys`
(directed edges and key sorts), :mod:`.orient` (signed areas, orientation), :mod:`.cells`
(edges, boundary, fixed mask), :mod:`.colouring`, :mod:`.build` (the smoothing tables).

:func:`build_topology` turns a :class:`~anglesmooth.mesh.Mesh2D` into a
:class:`Topology`: consistently oriented cells, unique edges, boundary, the fixed
mask, node rings (CSR), a node colouring, and the per-node tables the smoothers
read.  Nothing here depends on coordinates except the choice of orientation, so
the smoothers never rebuild any of it between passes.

Orientation
    Cells are re-oriented internally (never in the written file) so that every
    cell is counter-clockwise.  Cells are grouped into patches that are
    connected through edges traversed in opposite directions (consistent
    winding); each patch takes the orientation of the sign of its total signed
    area.  A cell whose signed area is then <= 0 is *inverted* (tangled input).
    A file written clockwise, or with some cells written the other way round,
    is therefore read correctly; a folded cell is reported as inverted.

Fixed nodes
    Boundary nodes (outer and holes), nodes of line/vertex cells, nodes between
    cells of different regions, nodes on non-manifold edges or with an open or
    multiple fan, nodes used by no 2D cell, plus the caller's extra nodes.

Per-node tables
    Free nodes are ordered by (colour, index); every table below is sorted by
    the *local* index ``loc`` of its free node, so one colour class is one
    contiguous slice of every table (see :meth:`Topology.blocks`).

    * ring (Laplacian): ``ring_loc``, ``ring_nbr`` — the edge neighbours.
    * spokes (angle method): ``spoke_loc``, ``spoke_ring``, ``spoke_a``,
      ``spoke_b``, ``spoke_frac``.  For free node i and ring node j (edge
      neighbours and, for quads, the diagonal node), ``a`` and ``b`` are the
      nodes beside the spoke j->i such that, turning counter-clockwise about j,
      one meets a, then i, then b.  The angle method puts i on the ray from j
      that splits the counter-clockwise angle a-j-b in the ratio
      ``spoke_frac : 1 - spoke_frac`` (ideal angle of the a side over the sum of
      both ideal angles: 1/2 for equal cell types, 3/5 for quad:triangle).
    * incidence (guards, quality): ``tri_loc``/``tri_verts`` (m, 3) and
      ``quad_loc``/``quad_verts`` (m, 4): each cell around a free node, its
      nodes in counter-clockwise order starting at that node; ``tri_cell`` /
      ``quad_cell``: the row of ``tri`` / ``quad`` it is (so a free node's
      rows give its cells: the node -> cells table of the patch moves).

    Index tables (node ids, locs, edges, ring entries, incidence rows) are
    int32 while every count fits (nodes and four times the corners below
    2**31: half the memory and page faults of int64), int64 beyond; the values
    are the same either way.

    A free node is interior and manifold, so its edge spokes are exactly its
    ring entries; without quads (no diagonal spokes) ``spoke_loc`` and
    ``spoke_ring`` are the very arrays ``ring_loc`` and ``ring_nbr``.

>>> import numpy as np
>>> from anglesmooth.mesh import Mesh2D
>>> pts = [[0, 0], [1, 0], [2, 0], [0, 1], [1, 1], [2, 1], [0, 2], [1, 2], [2, 2]]
>>> quads = [[0, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6], [4, 5, 8, 7]]
>>> topo = build_topology(Mesh2D.from_arrays(pts, quads=quads))
>>> topo.free_nodes.tolist(), topo.n_edges, int(topo.boundary.sum())
([4], 12, 8)
"""

from __future__ import annotations

from .build import QUAD_IDEAL, TRI_IDEAL, build_topology
from .cells import build_cell_topology
from .orient import signed_areas
from .types import Block, CellTopology, Topology

__all__ = ["Block", "CellTopology", "QUAD_IDEAL", "TRI_IDEAL", "Topology", "build_cell_topology", "build_topology", "signed_areas"]
