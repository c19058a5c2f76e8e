"""The topology types: :class:`Block`, :class:`CellTopology`, :class:`Topology` (tables only, no building)."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

__all__ = ["Block", "CellTopology", "Topology"]


@dataclass(frozen=True, eq=False)
class Block:
    """One update block: slices of the per-node tables plus reduction offsets.

    ``*_starts`` / ``*_has`` let ``np.minimum.reduceat`` reduce the incidence
    rows of the block per node (``has`` is False for a node with no row of that
    cell type); ``*_count`` are the number of rows per node.  These per-node
    arrays are computed on first use and then kept: the compiled kernels read
    the slices only (1M triangles: 0.1 s and 20 MB saved).
    """

    nodes: slice
    ring: slice
    spokes: slice
    tris: slice
    quads: slice
    _locs: tuple = field(repr=False)  # the topology's (ring_loc, spoke_loc, tri_loc, quad_loc)

    @property
    def size(self) -> int:
        return self.nodes.stop - self.nodes.start

    def _count(self, table: int, rows: slice) -> np.ndarray:
        return np.bincount(self._locs[table][rows] - self.nodes.start, minlength=self.size)

    @cached_property
    def ring_count(self) -> np.ndarray:
        return self._count(0, self.ring)

    @cached_property
    def spoke_count(self) -> np.ndarray:
        return self._count(1, self.spokes)

    @cached_property
    def _tri_starts(self):
        return _starts(self._locs[2][self.tris] - self.nodes.start, self.size)

    @cached_property
    def _quad_starts(self):
        return _starts(self._locs[3][self.quads] - self.nodes.start, self.size)

    @property
    def tri_starts(self) -> np.ndarray:
        return self._tri_starts[0]

    @property
    def tri_has(self) -> np.ndarray:
        return self._tri_starts[1]

    @property
    def quad_starts(self) -> np.ndarray:
        return self._quad_starts[0]

    @property
    def quad_has(self) -> np.ndarray:
        return self._quad_starts[1]


@dataclass(frozen=True, eq=False)
class CellTopology:
    """The cell-level part of a mesh's topology: oriented cells, edges, boundary, fixed mask.

    All that quality summaries and gates need (:func:`build_cell_topology`);
    smoothing needs the full :class:`Topology`, which extends it.
    """

    n_points: int
    tri: np.ndarray  # (nt, 3) counter-clockwise
    quad: np.ndarray  # (nq, 4) counter-clockwise
    flipped: np.ndarray  # (nt + nq,) bool: cell re-oriented relative to the file
    edges: np.ndarray  # (E, 2) unique, i < j
    edge_cells: np.ndarray  # (E,) number of 2D cells using each edge
    boundary: np.ndarray  # (N,) bool, node on a boundary edge
    fixed: np.ndarray  # (N,) bool
    fixed_reasons: dict  # name -> number of nodes fixed for that reason

    @property
    def n_tri(self) -> int:
        return int(self.tri.shape[0])

    @property
    def n_quad(self) -> int:
        return int(self.quad.shape[0])

    @property
    def n_edges(self) -> int:
        return int(self.edges.shape[0])


@dataclass(frozen=True, eq=False)
class Topology(CellTopology):
    """Everything about a mesh that does not change when nodes move.

    See the module docstring for the meaning of each table.
    """

    # CSR of edge neighbours for every node
    ring_offsets: np.ndarray
    ring_indices: np.ndarray
    # colouring and free-node tables
    colour: np.ndarray  # (N,) int, -1 for fixed nodes
    free_nodes: np.ndarray  # (F,) sorted by (colour, index)
    block_offsets: np.ndarray  # (n_colours + 1,) into free_nodes
    ring_loc: np.ndarray
    ring_nbr: np.ndarray
    spoke_loc: np.ndarray
    spoke_ring: np.ndarray
    spoke_a: np.ndarray
    spoke_b: np.ndarray
    spoke_frac: np.ndarray
    tri_loc: np.ndarray
    tri_verts: np.ndarray
    tri_cell: np.ndarray  # the triangle (row of ``tri``) of every incidence row
    quad_loc: np.ndarray
    quad_verts: np.ndarray
    quad_cell: np.ndarray  # the quad (row of ``quad``) of every incidence row
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def n_free(self) -> int:
        return int(self.free_nodes.shape[0])

    @property
    def n_colours(self) -> int:
        return int(self.block_offsets.shape[0] - 1)

    def blocks(self, order: str = "colour") -> list[Block]:
        """Update blocks: one per colour class (``"colour"``) or all free nodes at once (``"jacobi"``).

        Computed once per topology and order, then cached.
        """
        cached = self._cache.get(("blocks", order))
        if cached is not None:
            return cached
        if order == "jacobi":
            offs = np.array([0, self.n_free], dtype=np.int64)
        elif order == "colour":
            offs = self.block_offsets
        else:
            raise ValueError(f"unknown update order {order!r} (use 'colour' or 'jacobi')")
        out = []
        locs = (self.ring_loc, self.spoke_loc, self.tri_loc, self.quad_loc)
        for k in range(offs.shape[0] - 1):
            a, b = int(offs[k]), int(offs[k + 1])
            spans = [_span(loc, a, b) for loc in locs]
            out.append(Block(slice(a, b), *spans, locs))
        self._cache[("blocks", order)] = out
        return out

    def release(self, obj) -> None:
        """Drop the cache entries that hold ``obj`` (data of one run, such as the input floors, which a
        cache entry would otherwise keep alive as long as the topology: 70 MB at 1M triangles)."""
        for key in [k for k, v in self._cache.items() if v is obj or (type(v) is tuple and any(x is obj for x in v))]:
            del self._cache[key]

    def ring(self, node: int) -> np.ndarray:
        """Edge neighbours of one node (sorted)."""
        return self.ring_indices[self.ring_offsets[node] : self.ring_offsets[node + 1]]


def _starts(rel: np.ndarray, n: int):
    """reduceat offsets of sorted row owners ``rel`` (0..n-1) and which owners have rows."""
    count = np.bincount(rel, minlength=n)
    starts = np.cumsum(count)  # rows before each owner (rel is sorted): np.searchsorted(rel, np.arange(n))
    starts -= count
    has = count > 0
    return starts[has], has


def _span(sorted_loc: np.ndarray, a: int, b: int) -> slice:
    # the needles in the table's own type: a list of ints would convert the whole table to int64 first
    lo, hi = np.searchsorted(sorted_loc, np.array([a, b], sorted_loc.dtype))
    return slice(int(lo), int(hi))
